"""The one verdict on a whole flight, from arming to disarm (issue 37).

:func:`judge_flight` is what ``plan``, ``validate``, ``simulate`` and ``render`` judge a
mission by, and what ``fly`` can judge a flown track by:

1. **The parameters the vehicle will hold** (:func:`held_parameters`): the firmware's
   defaults, overlaid by the parameters the mission relies on (the ``.plan``'s
   ``parameters``: the RTL altitude, PX4's RTL_TYPE, the fence), overlaid by values given
   explicitly (``simulate --param``, or the values read from the vehicle).
2. **The whole flight**: the mission flown through the flight model with those parameters
   (or a flown track), from take-off to touchdown, its real end included (the landing, the
   autopilot's return to launch at the RTL altitude the vehicle holds, or the planned
   return), checked by the one check (:func:`uavplan.flightcheck.check_track`).
3. **A failsafe return from every point**: where a failsafe (a lost link, a low battery,
   the RTL switch) sends the vehicle home from anywhere on that flight, PX4 with RTL_TYPE 2
   and a mission landing flies the mission on to it (the flight itself, already checked);
   otherwise the autopilot's own return, braking on before it turns home
   (:func:`uavplan.wayhome.proof.check_returns`), at the RTL altitude held.

One result (:class:`FlightVerdict`): ``ok`` or not, the one worst point
(:class:`Finding`: phase, time, position, what it is near, clearance) and the lines every
command prints (:meth:`FlightVerdict.summary`, :meth:`FlightVerdict.problem`,
:meth:`FlightVerdict.warnings`). A flight that comes within the margin or leaves the flight
volume is an error (exit 3, SPEC); a failsafe return that would is a ``warning:`` (shown with
``-q``): the flight as planned is safe, the contingency is not, and what would make it so is
said with it.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from uavplan.autopilot.params import GuidanceLimits, Parameters, guidance_limits, param_table
from uavplan.autopilot.power import VehicleSpec
from uavplan.autopilot.simulate import FlightEnd, FlownTrack
from uavplan.flavour import Autopilot
from uavplan.flightcheck import TrackCheck, flight_of_track
from uavplan.mission.items import MavCmd, MissionPlan, MissionType
from uavplan.mission.track import Track
from uavplan.rehearsal import CheckSite, Rehearsal, rehearsal_of, rehearse, tracking_allowance_m
from uavplan.wayhome.proof import (
    RTL_PARAMETERS,
    ReturnSamples,
    ReturnsVerdict,
    Where,
    check_returns,
    prove_rtl,
    return_paths,
)
from uavplan.world import World

__all__ = [
    "FailsafeCheck",
    "FailsafeKind",
    "Finding",
    "FlightVerdict",
    "Phase",
    "held_parameters",
    "judge_flight",
]

#: a flown track that ends this close to the ground landed (m)
_LANDED_M = 1.0


class Phase(enum.Enum):
    """Where in the flight a point is."""

    TAKEOFF = "the take-off"
    ROUTE = "the route"
    RETURN_TO_LAUNCH = "the return to launch"
    PLANNED_RETURN = "the planned return"
    LANDING = "the landing"
    FAILSAFE = "a failsafe return"


@dataclass(frozen=True)
class Finding:
    """One point of a judged flight: in which ``phase``, when (``time_s`` from the mission's
    start; None for a planned line), flying to which item (``seq``), where (site ENU, m),
    what it is nearest (in words) and how close (``clearance_m``, against ``margin_m``);
    ``outside``: the point is outside the flight volume."""

    phase: Phase
    time_s: float | None
    seq: int | None
    position_enu: tuple[float, float, float]
    nearest: str
    clearance_m: float
    margin_m: float
    outside: bool = False
    #: kept beyond the margin: a predicted flight's tracking allowance (m)
    allowance_m: float = 0.0

    @property
    def keeps_margin(self) -> bool:
        from uavplan.route import keeps_margin

        return not self.outside and keeps_margin(self.clearance_m, self.margin_m + self.allowance_m)

    def when(self) -> str:
        if self.time_s is None:
            return ""
        minutes, seconds = divmod(self.time_s, 60.0)
        text = f"{int(minutes)} min {seconds:04.1f} s into the flight"
        return text + (f" (item {self.seq})" if self.seq is not None and self.seq >= 0 else "")

    def text(self) -> str:
        x, y, z = self.position_enu
        where = f"at ({x:.0f}, {y:.0f}, {z:.0f})"
        when = self.when()
        head = f"{when}, during {self.phase.value}" if when else f"during {self.phase.value}"
        if self.outside:
            return f"{head}, {where} is outside the flight volume"
        return f"{head}, {where}: {self.clearance_m:.2f} m from {self.nearest}"

    def report(self) -> dict[str, Any]:
        return {
            "phase": self.phase.name.lower(),
            "time_s": None if self.time_s is None else round(self.time_s, 1),
            "seq": self.seq,
            "position_enu": [round(v, 1) for v in self.position_enu],
            "nearest": self.nearest,
            "clearance_m": round(self.clearance_m, 3) if math.isfinite(self.clearance_m) else None,
            "margin_m": self.margin_m,
            "allowance_m": self.allowance_m,
            "outside": self.outside,
        }


class FailsafeKind(enum.Enum):
    """What a failsafe return during the flight flies."""

    RTL = "the autopilot's return to launch"  # straight home at the RTL altitude
    MISSION = "the mission on to its landing"  # PX4 RTL_TYPE 2 with a mission landing
    NONE = "nothing to check"  # no flight in the air


@dataclass(frozen=True)
class FailsafeCheck:
    """The failsafe return from every point of the flight: what it flies (``kind``), and for
    a return to launch the returns checked at the RTL altitude held (``returns``), the lowest
    RTL altitude that would keep the margin from every point (``lowest_safe_m``, None: none
    up to ``ceiling_m``; only computed when the held one does not) and the legal ceiling
    above home (``legal_ceiling_m``)."""

    kind: FailsafeKind
    autopilot: Autopilot
    returns: ReturnsVerdict | None = None
    lowest_safe_m: float | None = None
    ceiling_m: float | None = None
    legal_ceiling_m: float | None = None
    param_text: str = ""
    #: where the returns begin, home (site ENU) and the limits they fly by: for the paths
    samples: ReturnSamples | None = field(default=None, repr=False)
    home_enu: tuple[float, float, float] | None = None
    limits: GuidanceLimits | None = field(default=None, repr=False)

    def paths(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Every leg of every return checked (brake, climb, way back, leg home) as segments
        ``(a, b)``, each ``(n, 3)`` in the site frame: what a geofence must keep clear of
        when the mission relies on the return (empty without returns)."""
        if self.samples is None or self.home_enu is None or self.limits is None:
            return np.empty((0, 3)), np.empty((0, 3))
        return return_paths(self.samples, self.home_enu, self.limits)

    @property
    def ok(self) -> bool:
        return self.returns is None or self.returns.ok

    @property
    def worst(self) -> Where | None:
        return None if self.returns is None else self.returns.worst

    def summary(self) -> str:
        if self.kind is FailsafeKind.MISSION:
            return "a failsafe return flies the mission on to its landing (RTL_TYPE 2): the flight"
        if self.kind is FailsafeKind.NONE or self.returns is None:
            return "no failsafe return to check"
        r = self.returns
        return (
            f"a failsafe return ({self.param_text}) from each of {r.samples:,} points keeps "
            f"the {r.margin_m:g} m margin"
        )

    def warning(self) -> str | None:
        """The failsafe finding as a ``warning:`` line (None: every return is safe)."""
        r = self.returns
        if r is None or r.ok:
            return None
        head = (
            f"warning: failsafe: a return to launch during the flight (a lost link, a low "
            f"battery, the RTL switch: {self.param_text}) would come closer than the "
            f"{r.margin_m:g} m margin or leave the flight volume from {r.unsafe:,} of "
            f"{r.samples:,} points of the flight"
        )
        if r.worst is not None:
            head += f"; the worst: {r.worst.text()}"
        return f"{head}; {self.advice()}"

    def advice(self) -> str:
        spec = RTL_PARAMETERS[self.autopilot]
        legal = self.legal_ceiling_m
        low = self.lowest_safe_m
        if low is not None and (legal is None or low <= legal + 1e-9):
            value = math.ceil(low - 1e-9) * spec.per_m
            fix = (
                f"an RTL altitude of {low:.2f} m or more keeps it (set {spec.name} ≥ "
                f"{value:g} {spec.unit})"
            )
        elif low is not None:
            fix = (
                f"it needs an RTL altitude of {low:.2f} m, above the legal ceiling "
                f"({legal:.0f} m above home)"
            )
        else:
            ceiling = "" if self.ceiling_m is None else f" ({self.ceiling_m:.0f} m above home)"
            fix = f"no RTL altitude up to the ceiling{ceiling} keeps it"
        if self.autopilot is Autopilot.PX4:
            other = (
                "PX4's RTL_TYPE 2 flies a mission with a landing (mission.end: land or "
                "return) on to it instead, which uavplan proves with the flight"
            )
        else:
            other = (
                "ArduPilot's return to launch flies straight home; a failsafe action "
                "'Auto DO_LAND_START/DO_RETURN_PATH_START or RTL' (FS_THR_ENABLE, FS_GCS_ENABLE, "
                "BATT_FS_LOW_ACT 6) flies to the mission's landing sequence instead, which "
                "uavplan does not prove"
            )
        return f"{fix}; {other}"

    def report(self) -> dict[str, Any]:
        r = self.returns
        return {
            "kind": self.kind.name.lower(),
            "ok": self.ok,
            "held": self.param_text,
            "rtl_altitude_m": None if r is None else r.altitude_m,
            "samples": None if r is None else r.samples,
            "sample_step_m": None if r is None else r.step_m,
            "unsafe": None if r is None else r.unsafe,
            "brake_m": None if r is None else round(r.brake_m, 2),
            "worst": None if r is None or r.worst is None else r.worst.report(),
            "lowest_safe_altitude_m": self.lowest_safe_m,
            "legal_ceiling_m": self.legal_ceiling_m,
        }


@dataclass(frozen=True, eq=False)
class FlightVerdict:
    """A whole flight judged (see the module doc).

    ``params``: what the vehicle holds; ``relied``: the names the mission relies on (from
    the plan) and ``given``: the names given explicitly; ``check``: the whole track
    measured; ``failsafe``: the returns from every point (None: not asked); ``rehearsal``:
    the flight model's flight (None: a flown ``track`` was judged); ``ended``: how the
    flight ended (``landed``, ``mission_complete``, ...); ``site_label``: against what."""

    autopilot: Autopilot
    params: Parameters
    relied: tuple[str, ...]
    given: tuple[str, ...]
    track: Track
    check: TrackCheck
    flight_worst: Finding
    failsafe: FailsafeCheck | None
    rehearsal: Rehearsal | None
    ended: FlightEnd
    site_label: str
    end: str

    @property
    def flight_ok(self) -> bool:
        return self.check.ok

    @property
    def failsafe_ok(self) -> bool:
        return self.failsafe is None or self.failsafe.ok

    @property
    def ok(self) -> bool:
        """The flight and every failsafe return keep the margin inside the flight volume."""
        return self.flight_ok and self.failsafe_ok

    @property
    def margin_m(self) -> float:
        return self.check.margin_m

    @property
    def worst(self) -> Finding:
        """The one worst point: the flight's where it breaks the margin, else a failsafe
        return's where one does, else the flight's least clearance."""
        if not self.flight_ok or self.failsafe_ok:
            return self.flight_worst
        assert self.failsafe is not None and self.failsafe.worst is not None
        w = self.failsafe.worst
        return Finding(
            Phase.FAILSAFE,
            w.time_s,
            w.seq,
            w.point,
            w.nearest,
            w.clearance_m,
            self.margin_m,
        )

    @property
    def flight_time_s(self) -> float:
        times = self.track.time_s
        return float(times[-1] - times[0]) if len(times) else 0.0

    def held_text(self) -> str:
        """``RTL_ALT 23000 cm, the plan's``: the RTL parameters held, and from where."""
        return _held_text(self.autopilot, self.params, self.relied, self.given)

    def _head(self) -> str:
        source = "flight model" if self.rehearsal is not None else "flown track"
        ended = {
            FlightEnd.LANDED: "take-off to touchdown",
            FlightEnd.MISSION_COMPLETE: "take-off to the mission's end in the air",
            FlightEnd.NO_HEADWAY: "take-off until the wind stopped it",
            FlightEnd.TIMEOUT: "take-off until the simulation gave up",
            FlightEnd.TRACK_END: "take-off to the end of the track",
        }[self.ended]
        minutes, seconds = divmod(round(self.flight_time_s), 60)
        return (
            f"whole flight as {self.autopilot.label} flies it ({source}, {self.held_text()}; "
            f"{ended}, {minutes} min {seconds:02d} s, against {self.site_label})"
        )

    def _margin_text(self) -> str:
        """``10 m margin``, and the tracking allowance a predicted flight keeps beyond it."""
        extra = self.check.check.allowance_m
        text = f"{self.margin_m:g} m margin"
        return text + (f" and {extra:g} m for the autopilot's tracking error" if extra else "")

    def summary(self) -> str:
        """One line: the flight and the failsafe, as every command prints them."""
        w = self.flight_worst
        text = f"{self._head()}: "
        if self.flight_ok and not math.isfinite(w.clearance_m):
            text += f"keeps the {self._margin_text()}: nothing to keep clear of"
        elif self.flight_ok:
            text += (
                f"keeps the {self._margin_text()}, least {w.clearance_m:.2f} m from "
                f"{w.nearest} ({w.when() or 'planned'}, {w.phase.value})"
            )
        else:
            text += f"breaks the {self._margin_text()}: {w.text()}"
        if self.failsafe is not None:
            text += (
                f"; {self.failsafe.summary()}"
                if self.failsafe.ok
                else ("; a failsafe return does not (warning below)")
            )
        return text

    def problem(self) -> str | None:
        """The flight's finding as an error (exit 3), or None when the flight keeps the
        margin inside the flight volume."""
        if self.flight_ok:
            return None
        words = self.check.margin_words()
        return f"{self._head()}: {self.flight_worst.text()} (safety margin {words})"

    def warnings(self) -> list[str]:
        """``warning:`` lines: a failsafe return that would break the margin, a flight that
        did not finish."""
        out = []
        if self.failsafe is not None:
            line = self.failsafe.warning()
            if line is not None:
                out.append(line)
        if self.ended in (FlightEnd.NO_HEADWAY, FlightEnd.TIMEOUT):
            out.append(f"warning: the flight did not finish ({self.ended})")
        return out

    def report(self) -> dict[str, Any]:
        """The report's ``whole_flight`` entry."""
        return {
            "ok": self.ok,
            "flight_ok": self.flight_ok,
            "failsafe_ok": self.failsafe_ok,
            "autopilot": self.autopilot.label,
            "held": self.held_text(),
            "relied_on": list(self.relied),
            "end": self.end,
            "ended": self.ended,
            "flight_time_s": round(self.flight_time_s, 1),
            "margin_m": self.margin_m,
            "tracking_allowance_m": self.check.check.allowance_m,
            "worst": self.worst.report(),
            "flight_worst": self.flight_worst.report(),
            "failsafe": None if self.failsafe is None else self.failsafe.report(),
        }


def held_parameters(
    plan: MissionPlan,
    autopilot: Autopilot,
    given: Mapping[str, float] | None = None,
) -> tuple[Parameters, tuple[str, ...], tuple[str, ...]]:
    """What the vehicle will hold: the firmware's defaults (:mod:`uavplan.autopilot.params`),
    overlaid by ``plan``'s parameters (those the flight model knows, in ``autopilot``'s own
    table), overlaid by ``given`` (unknown names raise
    :class:`~uavplan.autopilot.params.UnknownParameter`). Returns (parameters, the names taken
    from the plan, the names given)."""
    known = {row.name for row in param_table(autopilot)}
    values: dict[str, float] = {}
    relied = []
    for p in plan.parameters:
        if p.name in known:
            values[p.name] = float(p.value)
            relied.append(p.name)
    given = dict(given or {})
    values.update(given)
    params = Parameters(autopilot, values)
    return params, tuple(relied), tuple(given)


def judge_flight(
    plan: MissionPlan,
    site: CheckSite,
    *,
    autopilot: Autopilot | None = None,
    params: Mapping[str, float] | Parameters | None = None,
    wind_en_m_s: tuple[float, float] = (0.0, 0.0),
    vehicle: VehicleSpec | None = None,
    track: Track | None = None,
    failsafe: bool = True,
    flown: FlownTrack | None = None,
) -> FlightVerdict:
    """Judge the whole flight of ``plan`` in ``site`` (see the module doc).

    ``autopilot``: the flavour that flies it (default the plan's); ``params``: values the
    vehicle holds beyond the plan's (``simulate --param``; ``fly --accept-vehicle-params``
    passes every value it read; a :class:`~uavplan.autopilot.params.Parameters` is taken as the
    whole set); ``wind_en_m_s`` and ``vehicle``: how the flight model flies it (the
    scenario's: :func:`uavplan.rehearsal.conditions_of`); ``track``: judge this flown track
    instead of flying the model (``fly``'s final check); ``failsafe``: also check a failsafe
    return from every point; ``flown``: the flight model's flight of this very plan under
    these conditions, already flown (``plan``'s rehearsal): used instead of flying it again
    when it was flown with exactly the parameters the vehicle will hold.

    Raises :class:`~uavplan.autopilot.simulate.MissionRefused` (exit 2) when the autopilot would
    refuse to start the mission, ``ValueError`` for a plan without a home."""
    flavour = autopilot or plan.autopilot
    if flavour not in RTL_PARAMETERS:
        raise ValueError(f"no flight model for autopilot {flavour.label}")
    held: Parameters
    relied: tuple[str, ...]
    given: tuple[str, ...]
    if isinstance(params, Parameters):
        held, relied, given = params, (), tuple(params.values)
    else:
        held, relied, given = held_parameters(plan, flavour, params)
    rehearsal = None
    allowance = 0.0  # a flown track is the firmware's own: judged against the margin alone
    if track is None:
        allowance = tracking_allowance_m(flavour)
        if flown is not None and flown.autopilot == flavour and _same_flight(flown, held, plan):
            rehearsal = rehearsal_of(flown)
        else:
            kwargs: dict[str, Any] = {"wind_en_m_s": wind_en_m_s}
            if vehicle is not None:
                kwargs["vehicle"] = vehicle
            rehearsal = rehearse(plan, site, autopilot=flavour, params=held, check=False, **kwargs)
        track = rehearsal.track
        ended = rehearsal.flown.ended
        lands = ended is FlightEnd.LANDED
    else:
        lands = bool(len(track)) and float(track.relative_alt_m[-1]) <= _LANDED_M
        ended = FlightEnd.LANDED if lands else FlightEnd.TRACK_END
    check = site.check(track, lands=lands, allowance_m=allowance)
    wire = replace(plan, autopilot=flavour).wire_items(MissionType.MISSION)
    marks = _Marks.of(wire)
    finding = _flight_finding(check, marks, site.world)
    end = marks.end
    fs: FailsafeCheck | None = None
    if failsafe:
        fs = _failsafe(site, track, held, relied, given, flavour, marks, lands)
    return FlightVerdict(
        flavour, held, relied, given, track, check, finding, fs, rehearsal, ended,
        site.label, end,
    )  # fmt: skip


def _same_flight(flown: FlownTrack, held: Parameters, plan: MissionPlan) -> bool:
    """Would the flight model fly ``plan`` with ``held`` as it flew ``flown``? The same
    parameters, or ones that differ only in the altitude fence (the flight model honours
    it only in a return to launch, which a mission without NAV_RETURN_TO_LAUNCH never flies
    unless a failsafe sends it: the fence parameters ``plan --fence`` writes)."""
    if dict(flown.params.values) == dict(held.values):
        return True
    if any(item.command == MavCmd.NAV_RETURN_TO_LAUNCH for item in plan.items):
        return False
    before = replace(guidance_limits(flown.params), fence_ceiling_m=None, fence_margin_m=0.0)
    return before == replace(guidance_limits(held), fence_ceiling_m=None, fence_margin_m=0.0)


@dataclass(frozen=True)
class _Marks:
    """Where the mission's phases begin, in wire seqs: its return to launch, its landing
    sequence (DO_LAND_START: the planned return), and whether it has a landing."""

    rtl: int | None
    land_start: int | None
    lands: bool

    @property
    def end(self) -> str:
        if self.rtl is not None:
            return "rtl"
        if self.land_start is not None:
            return "planned return"
        return "land" if self.lands else "none"

    @classmethod
    def of(cls, wire: list[Any]) -> _Marks:
        rtl = land_start = None
        lands = False
        for seq, item in enumerate(wire):
            if item.command == MavCmd.NAV_RETURN_TO_LAUNCH and rtl is None:
                rtl = seq
            elif item.command == MavCmd.DO_LAND_START and land_start is None:
                land_start = seq
            elif item.command == MavCmd.NAV_LAND and rtl is None:
                lands = True
        return cls(rtl, land_start, lands)

    def phase(
        self, seq: int, sample: int, airborne: tuple[int, int], n: int, end: int | None = None
    ) -> Phase:
        """The phase of a segment from track sample ``sample`` (to ``end``, default the
        next), flying to item ``seq``."""
        first, last = airborne
        end = sample + 1 if end is None else end
        if end <= first:
            return Phase.TAKEOFF
        if sample >= last and last < n - 1:
            return Phase.LANDING
        if self.rtl is not None and seq >= self.rtl:
            return Phase.RETURN_TO_LAUNCH
        if self.land_start is not None and seq > self.land_start:
            return Phase.PLANNED_RETURN
        return Phase.ROUTE


#: the worst segment of a track is cut into this many pieces to place its closest point
_PIECES = 32


def _flight_finding(check: TrackCheck, marks: _Marks, world: World) -> Finding:
    """The worst point of the whole track: its first point outside the volume, else the
    point of its least clearance (the closest piece of the worst segment, its time and item
    interpolated between the segment's samples)."""
    fc = check.check
    points = fc.flight.points_enu
    track = check.track
    n = len(track)
    if not len(points) or not len(check.samples):
        return Finding(
            Phase.ROUTE, None, None, (0.0, 0.0, 0.0), "nothing", math.inf, fc.margin_m,
            allowance_m=fc.allowance_m,
        )  # fmt: skip
    first = int(check.samples[fc.flight.airborne[0]])
    last = int(check.samples[fc.flight.airborne[1]])
    if fc.outside is not None:
        k = fc.outside
        sample = int(check.samples[k])
        seq = int(track.current_seq[sample])
        x, y, z = (float(v) for v in points[k])
        clearance = (
            float(fc.clearance_m[min(k, len(fc.clearance_m) - 1)])
            if fc.clearance_m.size
            else math.inf
        )
        return Finding(
            marks.phase(seq, sample, (first, last), n),
            float(track.time_s[sample]),
            seq,
            (x, y, z),
            fc.nearest,
            clearance,
            fc.margin_m,
            outside=True,
            allowance_m=fc.allowance_m,
        )
    k = fc.worst
    a, b = points[k], points[min(k + 1, len(points) - 1)]
    s0, s1 = int(check.samples[k]), int(check.samples[min(k + 1, len(check.samples) - 1)])
    # the closest piece of the segment: where, and when (between its two samples)
    f = np.linspace(0.0, 1.0, _PIECES + 1)
    cuts = a + f[:, None] * (b - a)
    space = world if first <= s0 and s1 <= last else world.without_ground()
    dist, _ = space.segments_nearest(cuts[:-1], cuts[1:])
    j = int(np.argmin(dist))
    t = 0.5 * (f[j] + f[j + 1])
    x, y, z = (float(v) for v in a + t * (b - a))
    # the track is thinned to 1 cm: a long straight stretch is one segment, so the time is
    # interpolated along it and the item read from the sample nearest that time
    time_s = float(track.time_s[s0] + t * (track.time_s[s1] - track.time_s[s0]))
    sample = int(np.clip(np.searchsorted(track.time_s, time_s), s0, s1))
    seq = int(track.current_seq[sample])
    return Finding(
        marks.phase(seq, max(s0, min(sample, s1 - 1)), (first, last), n, s1),
        time_s,
        seq,
        (x, y, z),
        fc.nearest,
        fc.min_clearance_m,
        fc.margin_m,
        allowance_m=fc.allowance_m,
    )


def _failsafe(
    site: CheckSite,
    track: Track,
    held: Parameters,
    relied: tuple[str, ...],
    given: tuple[str, ...],
    autopilot: Autopilot,
    marks: _Marks,
    lands: bool,
) -> FailsafeCheck:
    limits = guidance_limits(held)
    param_text = _held_text(autopilot, held, relied, given, rtl_only=True)
    if (
        autopilot is Autopilot.PX4
        and limits.rtl_type == 2
        and (marks.lands or marks.land_start is not None)
    ):
        # navigator's mission-path return (RTL_TYPE 2): a return during the mission flies the
        # rest of the mission to its landing, which is the flight just checked
        return FailsafeCheck(FailsafeKind.MISSION, autopilot, param_text="RTL_TYPE 2")
    if len(track) < 2:
        return FailsafeCheck(FailsafeKind.NONE, autopilot)
    flight = flight_of_track(track, site.frame, datum_amsl_m=site.datum_amsl_m, lands=lands)
    end = None
    if marks.rtl is not None:
        hits = np.flatnonzero(track.current_seq >= marks.rtl)
        end = int(hits[0]) if hits.size else None
    samples = ReturnSamples.of_track(flight, track.time_s, track.current_seq, end=end)
    home = tuple(float(v) for v in flight.points_enu[0])
    home_xyz = (home[0], home[1], home[2])
    floor = site.floor
    ceiling = None if site.top_z_m is None else float(site.top_z_m) - home_xyz[2]
    returns = check_returns(
        floor, samples, home_enu=home_xyz, limits=limits, name_of=site.name_of, ceiling_m=ceiling
    )
    legal = site.legal_ceiling_m
    if legal is not None and site.ground is not None:
        legal = max(0.0, legal - max(0.0, home_xyz[2] - float(site.ground.field.zmin)))
    lowest = None
    if not returns.ok:
        proof = prove_rtl(
            floor,
            home_enu=home_xyz,
            autopilot=autopilot,
            ceiling_m=ceiling if ceiling is not None else float(limits.rtl_altitude_m) * 4,
            name_of=site.name_of,
            limits=limits,
            samples=samples,
            describe=False,
        )
        lowest = proof.safe_altitude_m
    return FailsafeCheck(
        FailsafeKind.RTL,
        autopilot,
        returns,
        lowest,
        ceiling,
        legal,
        param_text,
        samples,
        home_xyz,
        limits,
    )


def _held_text(
    autopilot: Autopilot,
    params: Parameters,
    relied: tuple[str, ...],
    given: tuple[str, ...],
    *,
    rtl_only: bool = False,
) -> str:
    """``RTL_ALT 23000 cm (the plan's)``: the RTL altitude parameter held and where its value
    comes from (the plan, given, the firmware's default); PX4's RTL_TYPE when not 0."""
    spec = RTL_PARAMETERS[autopilot]
    value = params[spec.name]

    def source(name: str) -> str:
        if name in given:
            return "given"
        if name in relied:
            return "the plan's"
        return "the firmware's default"

    parts = [f"{spec.name} {value:g} {spec.unit} ({source(spec.name)})"]
    if autopilot is Autopilot.PX4 and params["RTL_TYPE"] != 0:
        parts.append(f"RTL_TYPE {params['RTL_TYPE']:g} ({source('RTL_TYPE')})")
    if not rtl_only:
        other = {n for n in (*relied, *given) if n not in (spec.name, "RTL_TYPE")}
        if other:
            return ", ".join(parts) + f" and {len(other)} more parameters set"
    return ", ".join(parts)
