"""Fly a mission through the flight model in simulated time: the flown track, no link.

:func:`simulate` is a pure function: a :class:`~uavplan.mission.items.MissionPlan` in, a
:class:`FlownTrack` out. It arms the model at the plan's home, starts the mission as the
autopilot does (ArduPilot from seq 1, after its home slot; PX4 from seq 0) and steps the
same :class:`~uavplan.autopilot.model.FlightModel` the simulated vehicle flies, until the vehicle
has landed or the mission has ended in the air. A bundled mission takes a few tens of
milliseconds (docs/flight-model.md).
"""

from __future__ import annotations

import array
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from enum import Enum, StrEnum

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uavplan.autopilot.model import DEFAULT_DT_S, EventKind, FlightEvent, FlightModel
from uavplan.autopilot.nav import NavItem, nav_items, planned_legs
from uavplan.autopilot.params import Parameters
from uavplan.autopilot.power import X500, VehicleSpec, power_w_array
from uavplan.errors import InputError
from uavplan.flavour import Autopilot
from uavplan.geo import GeoPoint
from uavplan.mission.items import MavCmd, MissionItem, MissionPlan, MissionType

__all__ = [
    "FlightEnd",
    "FlownTrack",
    "MissionRefused",
    "StartRefusal",
    "StartRefused",
    "check_startable",
    "refusal_of",
    "simulate",
    "start_refusal",
]

#: a simulation stops after this much simulated time (a mission that never ends)
MAX_DURATION_S = 6 * 3600.0
#: ... or when the wind has held the vehicle still for this long
NO_HEADWAY_LIMIT_S = 60.0
#: the values recorded at each step: time, position (3), velocity (3), the current item, and
#: whether the vehicle is in the air (1.0) or on the ground (0.0)
TRACK_COLUMNS = 9


class StartRefused(Enum):
    """Why the autopilot refuses to start a mission from the ground."""

    NO_TAKEOFF = "no take-off"  # ArduPilot: the first NAV command is not NAV_TAKEOFF
    NO_POSITION = "no position item"  # PX4: no item with a position


@dataclass(frozen=True)
class StartRefusal:
    """Why the autopilot would refuse to start a mission from the ground: the ``reason``,
    our words (``detail``) and the firmware's (``firmware_text``, its STATUSTEXT). An
    expected end (:class:`~uavplan.outcome.Ended`: never ok, at the ``start`` step)."""

    reason: StartRefused
    detail: str
    firmware_text: str

    ok = False
    interrupted = False
    step = "start"

    @property
    def message(self) -> str:
        return self.text()

    def text(self) -> str:
        return f"{self.detail} ({self.firmware_text!r})"


class MissionRefused(InputError):
    """An error: the mission was to be flown, and the autopilot would refuse to start it
    (``simulate``: exit 2); ``firmware_text`` is its words. Code that only asks whether a
    mission can start calls :func:`start_refusal` instead."""

    def __init__(self, refusal: StartRefusal) -> None:
        super().__init__(refusal.text())
        self.refusal = refusal
        self.firmware_text = refusal.firmware_text


def _first_nav(items: list[MissionItem], start: int) -> MissionItem | None:
    for item in items[start:]:
        if item.command < 80:
            return item
    return None


def start_refusal(wire_items: list[MissionItem], autopilot: Autopilot) -> StartRefusal | None:
    """Why ``autopilot`` would refuse to start this mission from the ground, or None: PX4
    without a mission ("Mission start denied! No valid mission", commander/Commander.cpp),
    ArduPilot without a take-off as its first NAV command ("Auto: Missing Takeoff Cmd",
    ArduCopter/mode_auto.cpp ``ModeAuto::init``)."""
    if autopilot == Autopilot.ARDUPILOT:
        first = _first_nav(wire_items, 1)
        if first is None or first.command != MavCmd.NAV_TAKEOFF:
            return StartRefusal(
                StartRefused.NO_TAKEOFF,
                "ArduPilot refuses a mission that does not begin with NAV_TAKEOFF",
                "Auto: Missing Takeoff Cmd",
            )
        return None
    if not any(item.command < 80 and item.is_global for item in wire_items):
        return StartRefusal(
            StartRefused.NO_POSITION,
            "PX4 refuses a mission without a position item",
            "Mission start denied! No valid mission",
        )
    return None


def refusal_of(plan: MissionPlan, autopilot: Autopilot | None = None) -> StartRefusal | None:
    """:func:`start_refusal` of ``plan`` as ``autopilot`` (default: the plan's) holds it."""
    flavour = autopilot or plan.autopilot
    return start_refusal(replace(plan, autopilot=flavour).wire_items(MissionType.MISSION), flavour)


def check_startable(wire_items: list[MissionItem], autopilot: Autopilot) -> None:
    """Raise :class:`MissionRefused` when ``autopilot`` would refuse to start this mission
    (:func:`start_refusal`)."""
    refusal = start_refusal(wire_items, autopilot)
    if refusal is not None:
        raise MissionRefused(refusal)


class FlightEnd(StrEnum):
    """How a flight record ends: the flight model's (:func:`simulate`), or a track given as
    flown that does not land (``TRACK_END``). A ``str`` enum: the reports' ``ended``."""

    LANDED = "landed"
    #: the mission's last item done, in the air (a mission that does not land)
    MISSION_COMPLETE = "mission_complete"
    #: the wind left the vehicle no ground speed along its track
    NO_HEADWAY = "no_headway"
    #: the simulation gave up (``max_duration_s``)
    TIMEOUT = "timeout"
    #: a flown track that ends without a landing
    TRACK_END = "track_end"

    @property
    def finished(self) -> bool:
        """The flight did what it was asked (landed, or its mission done in the air)."""
        return self in (FlightEnd.LANDED, FlightEnd.MISSION_COMPLETE)


@dataclass(frozen=True)
class FlownTrack:
    """What the flight model flew: one row per step of ``dt`` simulated seconds.

    ``x_m``/``y_m``/``z_m`` are ENU metres in the frame at ``home`` (``z_m`` is the altitude
    above home); ``lat_deg``/``lon_deg`` the position below the vehicle and ``alt_amsl_m``
    its altitude above mean sea level (home's plus ``z_m``), the convention of the mission
    builder. ``current_seq`` is the current mission item (-1 before the first). ``ended``:
    how the flight ended (:class:`FlightEnd`).
    """

    autopilot: Autopilot
    home: GeoPoint
    t_s: NDArray[np.float64]
    x_m: NDArray[np.float64]
    y_m: NDArray[np.float64]
    z_m: NDArray[np.float64]
    lat_deg: NDArray[np.float64]
    lon_deg: NDArray[np.float64]
    alt_amsl_m: NDArray[np.float64]
    speed_m_s: NDArray[np.float64]
    climb_m_s: NDArray[np.float64]
    current_seq: NDArray[np.int64]
    events: tuple[FlightEvent, ...]
    ended: FlightEnd
    energy_wh: float
    battery_used_pct: float
    params: Parameters
    wind_en_m_s: tuple[float, float] = (0.0, 0.0)
    nav: tuple[NavItem, ...] = field(default=(), repr=False)
    #: the electrical power drawn over the step that ended at each row (W; row 0: 0)
    power_w: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0), repr=False)
    #: the simulated vehicle (its power model profile and pack)
    vehicle: VehicleSpec = field(default=X500, repr=False)

    @property
    def completed(self) -> bool:
        return self.ended.finished

    @property
    def flight_time_s(self) -> float:
        """From the mission start to touchdown (or the mission's end in the air)."""
        return float(self.t_s[-1]) if len(self.t_s) else 0.0

    @property
    def enu_m(self) -> NDArray[np.float64]:
        """The track as ENU points ``(n, 3)`` in the frame at home."""
        return np.column_stack((self.x_m, self.y_m, self.z_m))

    @property
    def relative_alt_m(self) -> NDArray[np.float64]:
        return self.z_m

    def reached(self) -> list[tuple[int, float]]:
        """(seq, time) of every mission item the vehicle completed, in order."""
        return [
            (e.seq, e.t_s) for e in self.events if e.kind is EventKind.REACHED and e.seq is not None
        ]

    def planned_polyline_enu(self) -> NDArray[np.float64]:
        """The straight legs of the mission (home, the take-off's climb, the positional items
        in order) ``(m, 3)``, in the same frame as the track (:func:`~.nav.planned_legs`)."""
        return planned_legs(self.nav)[0]

    def deviation_from(self, polyline_enu: ArrayLike) -> NDArray[np.float64]:
        """Each track point's distance to the polyline ``(m, 3)`` (same frame), ``(n,)``."""
        return distance_to_polyline(self.enu_m, polyline_enu)


def distance_to_polyline(points: ArrayLike, polyline: ArrayLike) -> NDArray[np.float64]:
    """Distance of each of ``points`` ``(n, 3)`` to the polyline ``(m, 3)``: ``(n,)``.
    Vectorised over points and segments (n × (m - 1) at once)."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    line = np.asarray(polyline, dtype=np.float64).reshape(-1, 3)
    if len(line) == 1:
        return np.linalg.norm(p - line[0], axis=1)
    a = line[:-1][None, :, :]
    d = (line[1:] - line[:-1])[None, :, :]
    length2 = np.maximum(np.sum(d * d, axis=2), 1e-18)
    t = np.clip(np.sum((p[:, None, :] - a) * d, axis=2) / length2, 0.0, 1.0)
    closest = a + t[:, :, None] * d
    return np.min(np.linalg.norm(p[:, None, :] - closest, axis=2), axis=1)


def simulate(
    plan: MissionPlan,
    *,
    autopilot: Autopilot | None = None,
    params: Parameters | Mapping[str, float] | None = None,
    wind_en_m_s: tuple[float, float] = (0.0, 0.0),
    dt_s: float = DEFAULT_DT_S,
    ground_z: Callable[[float, float], float] | None = None,
    vehicle: VehicleSpec = X500,
    max_duration_s: float = MAX_DURATION_S,
) -> FlownTrack:
    """Fly ``plan`` from its home through the flight model and return the flown track.

    ``autopilot``: the flavour to fly it as (default: the plan's); ``params``: parameter
    values of that flavour, or changes to its defaults by name; ``wind_en_m_s``: wind
    (east, north) m/s; ``ground_z``: the ground's height above home at ENU (x, y), for
    terrain-frame altitudes and landings (flat ground at home's altitude without it).

    Raises :class:`MissionRefused` (an :class:`~uavplan.errors.InputError`) when the
    autopilot would refuse to start the mission, ``ValueError`` for a plan without a home.
    """
    flavour = autopilot or plan.autopilot
    if flavour not in (Autopilot.PX4, Autopilot.ARDUPILOT):
        raise ValueError("simulate needs a PX4 or ArduPilot plan (give autopilot=)")
    if plan.home is None:
        raise ValueError("the plan has no home: the vehicle must stand somewhere")
    if isinstance(params, Parameters):
        if params.autopilot != flavour:
            raise ValueError(f"parameters of {params.autopilot.label} for a {flavour.label} flight")
        values = params
    else:
        values = Parameters(flavour, dict(params or {}))
    wire = replace(plan, autopilot=flavour).wire_items(MissionType.MISSION)
    check_startable(wire, flavour)
    nav = nav_items(wire, plan.home, ground_z=ground_z)

    model = FlightModel(values, wind_en_m_s=wind_en_m_s, dt_s=dt_s, ground_z=ground_z)
    model.set_mission(nav)
    model.start_mission()

    # one row of TRACK_COLUMNS doubles a step, packed as they come: a list of tuples of
    # Python floats held some 340 bytes a row (a 25 km flight: 60,000 rows, 20 MB, most of it
    # left behind in the allocator's arenas once freed), the packed rows 72
    rows = array.array("d")
    events: list[FlightEvent] = []

    def record() -> None:
        x, y, z = model.position
        vx, vy, vz = model.velocity
        seq = -1 if model.current_seq is None else model.current_seq
        rows.extend((model.t_s, x, y, z, vx, vy, vz, seq, 0.0 if model.landed else 1.0))

    record()
    ended = FlightEnd.TIMEOUT
    while model.t_s < max_duration_s:
        step_events = model.step()
        record()
        events.extend(step_events)
        kinds = {e.kind for e in step_events}
        if EventKind.MISSION_COMPLETE in kinds:
            ended = FlightEnd.LANDED if model.landed else FlightEnd.MISSION_COMPLETE
            break
        if model.stuck_for_s >= NO_HEADWAY_LIMIT_S:
            ended = FlightEnd.NO_HEADWAY
            break

    table = np.frombuffer(rows, dtype=np.float64).reshape(-1, TRACK_COLUMNS)
    t, x, y, z = table[:, 0], table[:, 1], table[:, 2], table[:, 3]
    speed = np.hypot(table[:, 4], table[:, 5])
    climb = table[:, 6]
    # the battery: each step drains the power of the state it ended in (armed throughout)
    we, wn = (float(v) for v in wind_en_m_s)
    power = power_w_array(
        vehicle,
        armed=np.ones(len(t), dtype=bool),
        airborne=table[:, 8] > 0.5,
        airspeed_m_s=np.hypot(table[:, 4] - we, table[:, 5] - wn),
        climb_m_s=climb,
        altitude_amsl_m=plan.home.alt_m + z,
    )
    power[0] = 0.0
    energy_wh = float(np.sum(power) * dt_s / 3600.0)
    from uavplan.geo import EnuFrame

    lat, lon, _ = EnuFrame.at(plan.home).to_geodetic(np.column_stack((x, y, np.zeros_like(x))))
    return FlownTrack(
        autopilot=flavour,
        home=plan.home,
        t_s=t,
        x_m=x,
        y_m=y,
        z_m=z,
        lat_deg=lat,
        lon_deg=lon,
        alt_amsl_m=plan.home.alt_m + z,
        speed_m_s=speed,
        climb_m_s=climb,
        current_seq=table[:, 7].astype(np.int64),
        events=tuple(events),
        ended=ended,
        energy_wh=energy_wh,
        battery_used_pct=100.0 * energy_wh / vehicle.usable_wh,
        params=values,
        wind_en_m_s=(float(wind_en_m_s[0]), float(wind_en_m_s[1])),
        nav=nav,
        power_w=power,
        vehicle=vehicle,
    )
