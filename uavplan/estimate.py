"""Before it flies: the flight time, the energy and the battery of a route or a mission.

The one place that turns a flown line into the power model's legs (:mod:`uavplan.airframe`)
the way the autopilot flies it, for ``plan`` (the planned route), ``validate`` (a mission
file against a scenario, or a scenario's straight route) and the physical fitness's speeds
(:func:`mission_limits`):

* the take-off climb at the autopilot's take-off speed (ArduPilot ``WPNAV_SPEED_UP``; PX4
  ``MPC_TKO_SPEED`` below ``MPC_LAND_ALT1``, then ``MPC_Z_V_AUTO_UP``);
* the legs between the waypoints at the mission's speed (the scenario's ``cruise_speed``, a
  mission's DO_CHANGE_SPEED, else ``WPNAV_SPEED`` / ``MPC_XY_CRUISE``), climbing and
  descending no faster than ``WPNAV_SPEED_UP``/``_DN`` or ``MPC_Z_V_AUTO_UP``/``_DN``;
* the end: a landing at the landing speeds (``LAND_SPEED_HIGH`` then ``LAND_SPEED`` below
  ``LAND_ALT_LOW``; ``MPC_Z_V_AUTO_DN`` then ``MPC_LAND_SPEED``), or the return home of
  ``end: rtl``: climb to the RTL altitude (never below the current one), straight home at the
  RTL speed, the RTL loiter, the landing; or nothing (``end: none``: the mission ends in the
  air at the goal).

The autopilot's defaults come from the simulated vehicle's parameter tables
(:mod:`uavplan.autopilot.params`, each with its source), so the estimate and ``simulate`` fly by
the same numbers. Corners, accelerations and the RTL cone are not modelled here (the
simulation flies them; docs/energy.md says how far the two differ).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from uavplan.errors import InputError
from uavplan.flavour import Autopilot
from uavplan.mission.items import MavCmd, MissionPlan

if TYPE_CHECKING:
    from uavplan.autopilot.simulate import FlownTrack
    from uavplan.flightcheck import Flight
from uavplan.airframe import DEFAULT_RESERVE_PCT, EnergyUse, Legs, VehicleProfile, Wind
from uavplan.airframe import flight_energy as _flight_energy
from uavplan.autopilot.params import GuidanceLimits, Parameters, guidance_limits
from uavplan.scenario import Scenario

__all__ = [
    "DEFAULT_RESERVE_PCT",
    "BatteryEstimate",
    "estimate_flight",
    "estimate_mission",
    "estimate_route",
    "estimate_straight_route",
    "flown_energy",
    "mission_limits",
]

GroundZ = Callable[[NDArray[np.float64]], NDArray[np.float64]]


def mission_limits(autopilot: Autopilot, cruise_speed_m_s: float | None = None) -> GuidanceLimits:
    """The autopilot's default speeds (its parameter table), flying the mission at
    ``cruise_speed_m_s`` when given (a DO_CHANGE_SPEED: capped at the autopilot's top speed,
    as the firmwares cap it)."""
    flavour = autopilot if autopilot in (Autopilot.PX4, Autopilot.ARDUPILOT) else Autopilot.PX4
    limits = guidance_limits(Parameters(flavour))
    if cruise_speed_m_s is None:
        return limits
    speed = min(float(cruise_speed_m_s), limits.speed_xy_max_m_s)
    return replace(limits, speed_xy_m_s=speed)


@dataclass(frozen=True, eq=False)
class BatteryEstimate:
    """What a flight needs of the battery, and what that leaves.

    ``named``: the scenario names its vehicle (else the default profile was used and a flight
    over the budget is a warning, not a refusal). ``what`` says what was estimated (``the
    planned route``, ``the mission``, ``the straight route``).
    """

    energy: EnergyUse
    profile: VehicleProfile
    named: bool
    wind: Wind | None
    reserve_pct: float
    end: str
    what: str
    rtl_altitude_m: float | None = None

    @property
    def fits(self) -> bool:
        return self.energy.fits(self.reserve_pct)

    def summary(self) -> str:
        """One line: the vehicle, time, energy, battery used and left, the reserve, the wind."""
        vehicle = self.profile.name + ("" if self.named else " (default vehicle)")
        wind = ""
        if self.wind is not None and self.wind.speed_m_s != 0.0:
            speed = (
                f"{self.wind.speed_m_s:g} m/s" if self.wind.speed_m_s is not None else "by height"
            )
            wind = f", wind {speed} from {self.wind.from_deg:g}°"
        return f"{self.what}, {vehicle}{wind}: {self.energy.summary(self.reserve_pct)}"

    def report_fields(self) -> dict[str, Any]:
        """The report's ``flight_time_s``, ``energy_wh``, ``battery_used_pct`` and, under
        ``energy_estimate``, what they rest on (the vehicle, the reserve, the legs)."""
        e = self.energy
        fields = e.report_fields()
        legs = fields.pop("legs")
        return {
            **fields,
            "energy_estimate": {
                "what": self.what,
                "vehicle": self.profile.name,
                "vehicle_named": self.named,
                "battery_wh": e.battery_wh,
                "usable_wh": round(e.usable_wh, 2),
                "reserve_pct": self.reserve_pct,
                "remaining_pct": round(e.remaining_pct, 1),
                "fits": self.fits,
                "end": self.end,
                "rtl_altitude_m": self.rtl_altitude_m,
                "legs": legs,
            },
        }

    def check(self, *, allow_over_battery: bool = False) -> str | None:
        """Raise :class:`~uavplan.airframe.EnergyBudgetError` (exit 2, with the numbers) when
        the flight does not leave the reserve (issue 37: a flight over the battery is never
        a success, whether or not the scenario names its vehicle); with
        ``allow_over_battery`` (``--allow-over-battery``) return the same words as a
        warning. None: it fits."""
        if self.fits:
            return None
        vehicle = "" if self.named else f" ({self.profile.name}, the default vehicle)"
        try:
            self.energy.require_reserve(self.reserve_pct)
        except InputError as err:
            if not allow_over_battery:
                raise type(err)(
                    f"{err.reason}{vehicle}: {self.what} does not leave the reserve; "
                    "--allow-over-battery lets it through",
                    key=err.key,
                    file=err.file,
                ) from None
            return f"warning: {err.reason}{vehicle} (--allow-over-battery)"
        return None  # pragma: no cover - fits() said it does not


def estimate_flight(
    points_enu: NDArray[np.float64],
    *,
    profile: VehicleProfile,
    limits: GuidanceLimits,
    from_ground: bool,
    end: str,
    wind: Wind | None = None,
    datum_amsl_m: float = 0.0,
    ground_z: GroundZ | None = None,
    rtl_altitude_m: float | None = None,
) -> tuple[EnergyUse, float | None]:
    """(energy, RTL altitude used) of the flown line ``points_enu`` ``(n, 3)`` (site frame:
    z above the datum at ``datum_amsl_m``; ``ground_z`` the ground's z, None: flat at 0),
    flown as :func:`legs_of` says."""
    legs, altitudes, rtl = legs_of(
        points_enu,
        limits=limits,
        from_ground=from_ground,
        end=end,
        ground_z=ground_z,
        rtl_altitude_m=rtl_altitude_m,
    )
    energy = _flight_energy(profile, legs, wind, altitude_amsl_m=datum_amsl_m + altitudes)
    return energy, rtl


def legs_of(
    points_enu: NDArray[np.float64],
    *,
    limits: GuidanceLimits,
    from_ground: bool,
    end: str,
    ground_z: GroundZ | None = None,
    rtl_altitude_m: float | None = None,
) -> tuple[Legs, NDArray[np.float64], float | None]:
    """The legs of a flown line, the z of each leg's middle, and the RTL altitude used.

    ``points_enu`` is what :func:`uavplan.route.flown_polyline` or a mission's reading gives:
    with ``from_ground`` it begins on the ground with the take-off climb; with ``end ==
    "land"`` it ends with the landing descent; with ``end == "rtl"`` the return home (from
    the last point) is added here at ``rtl_altitude_m`` above home (default: the
    autopilot's RTL altitude)."""
    p = np.asarray(points_enu, dtype=np.float64).reshape(-1, 3)
    if len(p) < 2:
        raise InputError("a flight needs at least two positions", key="flight")
    first, last = _airborne(p, from_ground=from_ground, to_ground=end == "land")
    home = p[0]
    home_ground = _ground(ground_z, home[None, :2])[0] if ground_z is not None else 0.0
    if from_ground:
        home_ground = float(home[2])

    pts = [p[0]]
    speed: list[float] = []
    climb: list[float] = []
    descent: list[float] = []
    hold: list[float] = [0.0]

    def add(
        point: NDArray[np.float64], h: float, up: float, down: float, wait: float = 0.0
    ) -> None:
        pts.append(point)
        speed.append(h)
        climb.append(up)
        descent.append(down)
        hold.append(wait)

    cruise, up, down = limits.speed_xy_m_s, limits.speed_up_m_s, limits.speed_down_m_s
    for i in range(1, len(p)):
        if i <= first:  # the take-off climb
            for point, rate in _takeoff(p[i - 1], p[i], home_ground, limits):
                add(point, cruise, rate, down)
        elif i > last:  # the landing descent
            for point, rate in _landing(p[i - 1], p[i], float(p[-1][2]), limits):
                add(point, cruise, up, rate)
        else:
            add(p[i], cruise, up, down)

    rtl_used = None
    if end == "rtl":
        rtl_used = limits.rtl_altitude_m if rtl_altitude_m is None else float(rtl_altitude_m)
        here = np.array(pts[-1])
        cruise_alt = max(home_ground + rtl_used, float(here[2]) + limits.rtl_climb_min_m)
        if cruise_alt > here[2] + 1e-9:
            add(np.array([here[0], here[1], cruise_alt]), cruise, up, down)
        rtl_speed = limits.rtl_speed_m_s
        add(np.array([home[0], home[1], cruise_alt]), rtl_speed, up, down, limits.rtl_loiter_s)
        final = home_ground + limits.rtl_final_altitude_m
        top = np.array([home[0], home[1], cruise_alt])
        for point, rate in _landing(top, np.array([home[0], home[1], final]), home_ground, limits):
            add(point, rtl_speed, up, rate)

    points = np.vstack(pts)
    if ground_z is None:
        agl = points[:, 2]
    else:
        agl = points[:, 2] - _ground(ground_z, points[:, :2])
    legs = Legs.from_path(
        points,
        speed_m_s=np.array(speed),
        climb_rate_m_s=np.array(climb),
        descent_rate_m_s=np.array(descent),
        hold_s=np.array(hold),
        heights_agl_m=np.maximum(agl, 0.0),
    )
    middles = (points[:-1, 2] + points[1:, 2]) / 2.0
    if hold[0] > 0:  # pragma: no cover - the line never begins with a hold
        middles = np.concatenate([[points[0, 2]], middles])
    return legs, middles, rtl_used


#: consecutive points this close horizontally are a climb or a descent (as uavplan.flightcheck's)
_VERTICAL_TOL_M = 0.05


def _airborne(p: NDArray[np.float64], *, from_ground: bool, to_ground: bool) -> tuple[int, int]:
    """(first, last) point in the air: the leading points above the first are the take-off
    climb, the trailing ones above the last the landing (:meth:`uavplan.flightcheck.Flight.
    from_polyline`'s rule; that module is not imported here, it loads the world's kernels)."""
    n = len(p)
    first, last = 0, n - 1
    if from_ground:
        while first + 1 < n and _same_place(p[first + 1], p[0]):
            first += 1
    if to_ground:
        while last - 1 > first and _same_place(p[last - 1], p[-1]):
            last -= 1
    return first, last


def _same_place(a: NDArray[np.float64], b: NDArray[np.float64]) -> bool:
    return math.hypot(float(a[0] - b[0]), float(a[1] - b[1])) <= _VERTICAL_TOL_M


def _ground(ground_z: GroundZ | None, xy: NDArray[np.float64]) -> NDArray[np.float64]:
    if ground_z is None:
        return np.zeros(len(xy))
    return np.asarray(ground_z(np.asarray(xy, dtype=np.float64)), dtype=np.float64).reshape(-1)


def _takeoff(
    a: NDArray[np.float64], b: NDArray[np.float64], home_z: float, limits: GuidanceLimits
) -> list[tuple[NDArray[np.float64], float]]:
    """The climb a → b split where the take-off speed changes (PX4 climbs at MPC_TKO_SPEED
    below MPC_LAND_ALT1, then at MPC_Z_V_AUTO_UP; ArduPilot at WPNAV_SPEED_UP throughout)."""
    slow = limits.takeoff_slow_below_m
    if slow <= 0.0:
        return [(b, limits.takeoff_speed_m_s)]
    top = home_z + slow
    if a[2] < top < b[2]:
        return [(np.array([b[0], b[1], top]), limits.takeoff_speed_m_s), (b, limits.speed_up_m_s)]
    return [(b, limits.takeoff_speed_m_s if b[2] <= top else limits.speed_up_m_s)]


def _landing(
    a: NDArray[np.float64], b: NDArray[np.float64], ground_z: float, limits: GuidanceLimits
) -> list[tuple[NDArray[np.float64], float]]:
    """The descent a → b split where the landing slows down (ArduPilot LAND_SPEED_HIGH above
    LAND_ALT_LOW, then LAND_SPEED; PX4 MPC_Z_V_AUTO_DN, then MPC_LAND_SPEED)."""
    slow_top = ground_z + limits.land_slow_below_m
    if b[2] >= a[2]:
        return [(b, limits.land_speed_high_m_s)]
    if b[2] < slow_top < a[2]:
        return [
            (np.array([b[0], b[1], slow_top]), limits.land_speed_high_m_s),
            (b, limits.land_speed_m_s),
        ]
    return [(b, limits.land_speed_m_s if a[2] <= slow_top else limits.land_speed_high_m_s)]


# ---------------------------------------------------------------------------------------------
# From a scenario


def _estimate(
    scenario: Scenario,
    points_enu: NDArray[np.float64],
    *,
    what: str,
    autopilot: Autopilot,
    end: str,
    from_ground: bool,
    cruise_speed_m_s: float | None,
    reserve_pct: float,
    rtl_altitude_m: float | None,
) -> BatteryEstimate:
    site = scenario.site
    ground = site.ground
    profile = scenario.vehicle.profile
    energy, rtl = estimate_flight(
        points_enu,
        profile=profile,
        limits=mission_limits(autopilot, cruise_speed_m_s),
        from_ground=from_ground,
        end=end,
        wind=scenario.wind,
        datum_amsl_m=site.origin.alt_m,
        ground_z=None if ground is None else ground.z_at,
        rtl_altitude_m=rtl_altitude_m,
    )
    return BatteryEstimate(
        energy, profile, scenario.vehicle.named, scenario.wind, reserve_pct, end, what, rtl
    )


def estimate_route(
    scenario: Scenario,
    flown_enu: NDArray[np.float64],
    *,
    reserve_pct: float = DEFAULT_RESERVE_PCT,
    rtl_altitude_m: float | None = None,
) -> BatteryEstimate:
    """The planned route's flight (its flown line, :attr:`PlannedRoute.flown_enu`) with the
    scenario's vehicle, wind, autopilot, speed and end. ``rtl_altitude_m``: the RTL altitude
    the mission uses (default: the autopilot's ``RTL_ALT`` / ``RTL_RETURN_ALT``)."""
    return _estimate(
        scenario,
        flown_enu,
        what="the planned route",
        autopilot=scenario.mission.autopilot,
        end=scenario.mission.end,
        from_ground=scenario.mission.takeoff,
        cruise_speed_m_s=scenario.vehicle.cruise_speed_m_s,
        reserve_pct=reserve_pct,
        rtl_altitude_m=rtl_altitude_m,
    )


def estimate_straight_route(
    scenario: Scenario, *, reserve_pct: float = DEFAULT_RESERVE_PCT
) -> BatteryEstimate:
    """The scenario's route points flown straight (start, via points, goal; the take-off and
    the end as the mission flies them): what the flight needs at the least, before any
    planning (the planned route goes round the obstacles and is longer)."""
    from uavplan.route import flown_polyline

    site = scenario.site
    points = np.array(site.route_points(), dtype=np.float64)
    ground = site.ground
    ends = (0.0, 0.0)
    if ground is not None:
        z = ground.z_at(points[[0, -1]])
        ends = (float(z[0]), float(z[-1]))
    flown = flown_polyline(
        points,
        takeoff_altitude_m=scenario.vehicle.takeoff_altitude_m,
        end=scenario.mission.end,  # type: ignore[arg-type]
        ground_z_m=ends,
    )
    return _estimate(
        scenario,
        flown,
        what="the straight route (the least it can take)",
        autopilot=scenario.mission.autopilot,
        end=scenario.mission.end,
        from_ground=True,
        cruise_speed_m_s=scenario.vehicle.cruise_speed_m_s,
        reserve_pct=reserve_pct,
        rtl_altitude_m=None,
    )


def estimate_mission(
    scenario: Scenario,
    plan: MissionPlan,
    flight: Flight,
    *,
    reserve_pct: float = DEFAULT_RESERVE_PCT,
    rtl_altitude_m: float | None = None,
) -> BatteryEstimate:
    """A mission file's flight (``flight``: its reading in the scenario's site frame) with
    the scenario's vehicle and wind, the mission's autopilot, speed (its first
    DO_CHANGE_SPEED, else the scenario's cruise speed) and end (RTL, a landing or none)."""
    autopilot = plan.autopilot
    if autopilot not in (Autopilot.PX4, Autopilot.ARDUPILOT):
        autopilot = scenario.mission.autopilot
    speed = scenario.vehicle.cruise_speed_m_s
    end = "none"
    for item in plan.items:
        if item.command == MavCmd.DO_CHANGE_SPEED and item.param2 and item.param2 > 0:
            speed = float(item.param2)
            break
    for item in plan.items:
        if item.command == MavCmd.NAV_RETURN_TO_LAUNCH:
            end = "rtl"
            break
        if item.command == MavCmd.NAV_LAND:
            end = "land"
            break
    if not math.isfinite(speed or 0.0):
        speed = None
    return _estimate(
        scenario,
        flight.points_enu,
        what="the mission",
        autopilot=autopilot,
        end=end,
        from_ground=plan.home is not None,
        cruise_speed_m_s=speed,
        reserve_pct=reserve_pct,
        rtl_altitude_m=rtl_altitude_m,
    )


def estimate_flown(
    scenario: Scenario, track: FlownTrack, *, reserve_pct: float = DEFAULT_RESERVE_PCT
) -> BatteryEstimate:
    """A mission as the flight model flew it for ``scenario`` (``uavplan.rehearsal``: the
    scenario's vehicle and its wind, the autopilot's own speeds, corners and end): the time,
    energy and battery of every step of ``track`` (:func:`flown_energy`). ``plan`` reports
    this one, so its flight time is the flight model's."""
    return BatteryEstimate(
        flown_energy(track),
        scenario.vehicle.profile,
        scenario.vehicle.named,
        scenario.wind,
        reserve_pct,
        scenario.mission.end,
        f"the mission as {track.autopilot.label} flies it",
    )


def flown_energy(track: FlownTrack) -> EnergyUse:
    """A simulated (or flown) track's time, energy and battery, step by step, as the
    estimate's :class:`~uavplan.airframe.EnergyUse`: its ``summary()`` is the line ``plan``
    prints, its ``report_fields()`` the report's keys, so ``simulate`` and ``fly`` print what
    the vehicle drew next to the estimate (:func:`estimate_mission`) of the same mission."""
    from uavplan.airframe.legs import LegFigures

    dt = np.diff(track.t_s)
    power = np.asarray(track.power_w, dtype=np.float64)[1:]
    we, wn = track.wind_en_m_s
    vx = np.gradient(track.x_m, track.t_s)[1:] if len(track.t_s) > 1 else np.zeros(0)
    vy = np.gradient(track.y_m, track.t_s)[1:] if len(track.t_s) > 1 else np.zeros(0)
    legs = LegFigures(
        duration_s=dt,
        energy_wh=power * dt / 3600.0,
        power_w=power,
        ground_speed_m_s=track.speed_m_s[1:],
        airspeed_m_s=np.hypot(vx - we, vy - wn),
        vertical_speed_m_s=track.climb_m_s[1:],
    )
    profile = track.vehicle.profile
    return EnergyUse(
        profile_name=profile.name,
        time_s=track.flight_time_s,
        energy_wh=float(np.sum(legs.energy_wh)),
        battery_wh=profile.battery_wh,
        usable_wh=profile.usable_wh,
        legs=legs,
    )
