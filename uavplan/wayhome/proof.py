"""The way home, proven: does the autopilot's own return to launch keep the margin from every
point of the flight, and from which RTL altitude up?

Both firmwares return the same way (:mod:`uavplan.autopilot.rtl` holds the altitude rule, which the
flight model flies too): the vehicle **brakes** (it goes on along its velocity to its
stopping point), climbs to the return altitude (if below it), flies straight home at it and
descends at home. :func:`prove_rtl` checks that return from points every ``step_m`` along
the flight (:class:`ReturnSamples`: a planned line, or the flight model's or a vehicle's
track with its velocities), for an RTL altitude parameter A, with the world's exact segment
clearances (the same machinery as :func:`uavplan.flightcheck.check_flight`): the brake, the climb,
the straight return at the return altitude and the descent at home must each keep the safety
margin from the obstacles and the terrain.

**The brake before the turn home** (issue 32: ArduPilot SITL braked 17 m on at about 9 m/s
before it climbed, and its return passed 7.99 m from a building the straight return from the
trigger point cleared by 9.22 m):

- ArduPilot Copter builds its return from the stopping point (``ModeRTL::build_path``:
  ``rtl_path.origin_point = get_stopping_point()``), which ``AC_PosControl::
  get_stopping_point_xy_cm`` places ``stopping_distance(v, PSC_POSXY_P, accel)`` along the
  velocity, the inverse of the square-root controller (AP_Math/control.cpp,
  ``inv_sqrt_controller``): ``v / P`` below ``accel / P``, else ``accel / (2 P²) +
  v² / (2 accel)``, with the waypoint acceleration (WPNAV_ACCEL) and P = 1 (the default of
  PSC_POSXY_P): 17.45 m at 9 m/s, 30.05 m at 12 m/s. The climb starts there, and the return
  altitude (the cone) is computed there.
- PX4 (``RtlDirect::set_rtl_item``, state CLIMBING) sets its climb setpoint at the position
  where the return began; a multicopter moving at v overshoots it by the braking distance
  ``Navigator::calculate_breaking_stop`` predicts (TrajMath.hpp
  ``computeBrakingDistanceFromVelocity(v, MPC_JERK_AUTO, MPC_ACC_HOR, 0.6·MPC_JERK_AUTO)``,
  v²/(2·MPC_ACC_HOR) + 0.6 s·v: 31.2 m at 12 m/s) and comes back to it while it climbs. The
  proof checks the overshoot, the climb above its far end, the way back at the return
  altitude and the legs home from both ends (everything between them lies above the
  overshoot, which is nearer the ground-standing solids).

**Monotonicity.** Every solid a return must clear stands on the ground (obstacles, the
terrain's solids: from below the ground up to a height), so a point's distance to them never
shrinks as the point rises. The brake does not depend on A; a return's climb is nearest to
them at its bottom (the same for every A); its leg home lies higher when A is higher (the
return altitude never decreases with A, :func:`~uavplan.autopilot.rtl.return_altitude_m`), and the
descent at home is nearest at the ground. So a return that keeps the margin at A keeps it at
every higher A: the safe altitudes are an interval [lowest, ceiling], and the lowest is found
by bisection (to 1 cm). The ceiling (the flight volume's top above home, less ArduPilot's
FENCE_MARGIN under an altitude fence, which caps its return altitude) bounds it from above: a
return above the ceiling leaves the volume. The terrain's ceiling over each cell (the route's
highest height above the ground) is not a wall a return must clear, so the proof uses the
world without it (:func:`uavplan.worlds.return_world`, a check site's ``floor``).

PX4 ends its climb within ``NAV_MC_ALT_RAD`` (0.8 m) of the return altitude and flies home
from there, so its leg home is checked that much lower.

What is left out (docs/way-home.md): ArduPilot's S-curve corner between the climb and the
leg home (within WPNAV_RADIUS), rally points (none are planned), wind and position error, and
terrain following (RTL_ALT_TYPE): the return altitude is above home.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uavplan.autopilot.params import GuidanceLimits, Parameters, guidance_limits, param_table
from uavplan.autopilot.rtl import ARDUPILOT_RTL_ALT_MIN_M, return_altitude_m
from uavplan.flavour import Autopilot
from uavplan.flightcheck import Flight
from uavplan.route import PlannedRoute, keeps_margin
from uavplan.world import GROUND, World
from uavplan.worlds import RETURN_BOUNDS_PAD_M

__all__ = [
    "ARDUPILOT_FENCE_MARGIN_M",
    "ARDUPILOT_POS_XY_P",
    "RETURN_BOUNDS_PAD_M",
    "RTL_PARAMETERS",
    "ReturnCheck",
    "ReturnSamples",
    "ReturnsVerdict",
    "RtlParameter",
    "RtlProof",
    "Where",
    "ceiling_above_home",
    "check_returns",
    "default_rtl_altitude_m",
    "firmware_rtl",
    "prove_rtl",
    "return_paths",
    "return_samples",
    "sample_step_m",
    "stopping_distance_m",
    "unsafe_returns",
]

#: the bisection stops when the safe and the unsafe altitude are this close (m)
RESOLUTION_M = 0.01
#: the RTL altitude advised is the least whole metre at least this far above the lowest safe one
RTL_SLACK_M = 0.5
#: returns are checked from points at most this far apart along the flown line (m) ...
SAMPLE_STEP_M = 1.0
#: ... or as many as this on a long route (the step grows with the route's length)
MAX_SAMPLES = 4000
#: ArduPilot's FENCE_MARGIN default (m): under an altitude fence its return flies at most
#: FENCE_ALT_MAX less this (ModeRTL::compute_return_target, AC_Fence::get_safe_alt_max)
ARDUPILOT_FENCE_MARGIN_M = 2.0
#: the worst return is measured exactly among at most this many candidates; beyond that
#: (over terrain, where the margin's bisection does not narrow them) every k-th is measured
#: and then the unsafe returns within k of the closest :data:`WORST_NEIGHBOURS`
WORST_EXACT = 400
WORST_NEIGHBOURS = 8
#: ArduPilot's horizontal position gain PSC_POSXY_P (1/s, its default: AC_PosControl.h
#: POSCONTROL_POS_XY_P), the P of its stopping distance
ARDUPILOT_POS_XY_P = 1.0
#: PX4's braking delay: Navigator::calculate_breaking_stop passes 0.6 × MPC_JERK_AUTO as the
#: acceleration that defines the delay, a delay of 0.6 s (TrajMath.hpp)
PX4_BRAKE_DELAY_S = 0.6


@dataclass(frozen=True)
class RtlParameter:
    """The parameter that sets a firmware's RTL altitude: its name and unit per metre."""

    name: str
    unit: str
    per_m: float
    minimum_m: float


#: ArduPilot Copter RTL_ALT (cm, at least RTL_ALT_MIN's 30 cm); PX4 RTL_RETURN_ALT (m)
RTL_PARAMETERS = {
    Autopilot.ARDUPILOT: RtlParameter("RTL_ALT", "cm", 100.0, ARDUPILOT_RTL_ALT_MIN_M),
    Autopilot.PX4: RtlParameter("RTL_RETURN_ALT", "m", 1.0, 0.0),
}


def firmware_rtl(autopilot: Autopilot) -> GuidanceLimits:
    """The firmware's return behaviour at its parameter defaults (cone, climb, descent)."""
    return guidance_limits(Parameters.defaults(autopilot))


def default_rtl_altitude_m(autopilot: Autopilot) -> float:
    """The firmware's default RTL altitude (ArduPilot 15 m, PX4 60 m)."""
    spec = RTL_PARAMETERS[autopilot]
    for row in param_table(autopilot):
        if row.name == spec.name:
            return row.default / spec.per_m
    raise KeyError(spec.name)  # pragma: no cover - the tables hold both


def stopping_distance_m(limits: GuidanceLimits, speed_m_s: ArrayLike) -> NDArray[np.float64]:
    """How far (m) a multicopter moving at ``speed_m_s`` horizontally goes on before its
    return turns home (see the module docstring): ArduPilot's stopping point
    (``inv_sqrt_controller(v, PSC_POSXY_P, WPNAV_ACCEL)``), PX4's braking distance
    (``v²/(2·MPC_ACC_HOR) + 0.6 s·v`` with its jerk limit, ``v²/(2·MPC_ACC_HOR)`` without)."""
    v = np.abs(np.asarray(speed_m_s, dtype=np.float64))
    a = max(float(limits.accel_xy_m_s2), 1e-9)
    if limits.is_px4:
        delay = PX4_BRAKE_DELAY_S if (limits.jerk_m_s3 or 0.0) > 0.0 else 0.0
        return v * (v / (2.0 * a) + delay)
    p = ARDUPILOT_POS_XY_P
    return np.where(v < a / p, v / p, a / (2.0 * p * p) + v * v / (2.0 * a))


@dataclass(frozen=True, eq=False)
class ReturnSamples:
    """The points a return may begin from, at most a step apart along a flight: ``points``
    ``(n, 3)`` (site frame), the horizontal velocity there ``velocity`` ``(n, 2)`` (m/s: the
    brake goes on along it), which of them are on the landing descent (``grounded``: their
    climb starts near the ground and is measured against the obstacles only, as the landing
    is), and, from a track, when (``time_s``) and flying to which item (``seq``)."""

    points: NDArray[np.float64]
    velocity: NDArray[np.float64]
    grounded: NDArray[np.bool_]
    step_m: float
    time_s: NDArray[np.float64] | None = None
    seq: NDArray[np.int64] | None = None

    def __len__(self) -> int:
        return len(self.points)

    @classmethod
    def along(
        cls, flight: Flight, step_m: float | None = None, speed_m_s: float = 0.0
    ) -> ReturnSamples:
        """Along a planned line: its airborne part and landing descent (:func:`return_samples`),
        flown at ``speed_m_s`` along each leg (horizontal legs at that speed, vertical ones
        still)."""
        step = sample_step_m(flight.length_m) if step_m is None else float(step_m)
        points, grounded, legs = _sampled(flight.points_enu, flight.airborne, step)
        p = flight.points_enu
        d = (p[1:] - p[:-1])[:, :2] if len(p) > 1 else np.zeros((0, 2))
        norm = np.hypot(d[:, 0], d[:, 1])
        unit = np.divide(d, norm[:, None], out=np.zeros_like(d), where=norm[:, None] > 1e-9)
        velocity = unit[legs] * float(speed_m_s) if len(unit) else np.zeros((len(points), 2))
        return cls(points, velocity, grounded, step)

    @classmethod
    def of_track(
        cls,
        flight: Flight,
        time_s: NDArray[np.float64],
        seq: NDArray[np.int64] | None = None,
        *,
        end: int | None = None,
        step_m: float | None = None,
    ) -> ReturnSamples:
        """Along a flown track (its :class:`~uavplan.flightcheck.Flight` in the site frame and the
        time of each sample): from the top of the take-off climb to sample ``end`` (where the
        mission's own return begins; None: the end, the landing descent included), with the
        track's velocities (interpolated between samples)."""
        p = flight.points_enu
        t = np.asarray(time_s, dtype=np.float64)
        last = len(p) - 1 if end is None else max(0, min(int(end), len(p) - 1))
        first = min(flight.airborne[0], last)
        cut = Flight(p[: last + 1], (first, min(flight.airborne[1], last)))
        length = float(np.linalg.norm(np.diff(cut.points_enu[first:], axis=0), axis=1).sum())
        step = sample_step_m(length) if step_m is None else float(step_m)
        points, grounded, legs = _sampled(cut.points_enu, cut.airborne, step)
        if len(p) > 1:
            v = np.gradient(p[:, :2], t, axis=0, edge_order=1)
        else:
            v = np.zeros((len(p), 2))
        # the position along each leg, to interpolate the velocity and the time
        a, b = p[legs], p[np.minimum(legs + 1, len(p) - 1)]
        span = np.linalg.norm(b - a, axis=1)
        frac = np.divide(
            np.linalg.norm(points - a, axis=1), span, out=np.zeros(len(points)), where=span > 0
        )
        frac = np.clip(frac, 0.0, 1.0)
        nxt = np.minimum(legs + 1, len(p) - 1)
        velocity = v[legs] + frac[:, None] * (v[nxt] - v[legs])
        times = t[legs] + frac * (t[nxt] - t[legs])
        seqs = None if seq is None else np.asarray(seq, dtype=np.int64)[nxt]
        return cls(points, velocity, grounded, step, times, seqs)


def sample_step_m(length_m: float) -> float:
    """The sampling step for a flown line ``length_m`` long (:data:`SAMPLE_STEP_M`, longer
    beyond :data:`MAX_SAMPLES` samples)."""
    return max(SAMPLE_STEP_M, length_m / MAX_SAMPLES)


def _sampled(
    p: NDArray[np.float64], airborne: tuple[int, int], step_m: float
) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.int64]]:
    """Points at most ``step_m`` apart (horizontally and vertically) along ``p`` from
    ``airborne[0]`` on, vertices included; which are on the landing descent (after
    ``airborne[1]``); and the segment each lies on."""
    first, last = airborne
    if len(p) < 2 or first >= len(p) - 1:
        end = min(first, len(p) - 1)
        return p[end : end + 1].copy(), np.array([False]), np.array([max(0, end)], np.int64)
    a, b = p[first:-1], p[first + 1 :]
    span = np.maximum(np.hypot(b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]), np.abs(b[:, 2] - a[:, 2]))
    k = np.maximum(1, np.ceil(span / step_m).astype(np.int64))
    seg = np.repeat(np.arange(first, len(p) - 1, dtype=np.int64), k)
    starts = np.repeat(np.cumsum(k) - k, k)
    t = (np.arange(int(k.sum())) - starts) / np.repeat(k, k)
    points = p[seg] + t[:, None] * (p[seg + 1] - p[seg])
    end = len(p) - 1
    points = np.vstack([points, p[end : end + 1]])
    seg = np.concatenate([seg, [end - 1]])
    grounded = np.concatenate([seg[:-1] >= last, [end > last]])
    return points, grounded, seg


def return_samples(flight: Flight, step_m: float) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Points ``(n, 3)`` at most ``step_m`` apart (horizontally and vertically) along the
    airborne part of ``flight`` and its landing descent, vertices included, and which of
    them are on the landing descent. The take-off climb is left out: a return from it
    descends where it climbed."""
    points, grounded, _ = _sampled(flight.points_enu, flight.airborne, step_m)
    return points, grounded


@dataclass(frozen=True)
class ReturnCheck:
    """Returns from samples (``index``) at one RTL altitude: which of them fail to keep the
    margin (``unsafe``), and the altitude each flies home at (``top_z``, site z)."""

    altitude_m: float
    index: NDArray[np.int64]
    top_z: NDArray[np.float64]
    unsafe: NDArray[np.bool_]

    @property
    def safe(self) -> bool:
        return not bool(self.unsafe.any())


@dataclass(frozen=True)
class Where:
    """The worst return: where it began (site ENU, rounded to 0.1 m), what it passes nearest
    (in words, with the leg: ``obstacle #0 (leg home)``), how close (m), and, from a track,
    when and flying to which item."""

    point: tuple[float, float, float]
    nearest: str
    clearance_m: float
    time_s: float | None = None
    seq: int | None = None

    def text(self) -> str:
        x, y, z = self.point
        when = ""
        if self.time_s is not None:
            minutes, seconds = divmod(self.time_s, 60.0)
            when = f"{int(minutes)} min {seconds:04.1f} s into the flight, "
        return (
            f"{when}from ({x:.0f}, {y:.0f}, {z:.0f}) its return passes {self.clearance_m:.2f} m "
            f"from {self.nearest}"
        )

    def report(self) -> dict[str, object]:
        return {
            "point": list(self.point),
            "nearest": self.nearest,
            "clearance_m": round(self.clearance_m, 3),
            "time_s": None if self.time_s is None else round(self.time_s, 1),
            "seq": self.seq,
        }


@dataclass(frozen=True)
class RtlProof:
    """The autopilot's return checked from every point of a flight (see the module doc).

    ``safe_altitude_m``: the lowest RTL altitude above home from which every return keeps
    the margin (None: none up to ``ceiling_m``). ``default_safe``: the firmware's default
    (``default_altitude_m``) does. ``blocked``: where no altitude up to the ceiling is safe,
    the worst return at the ceiling, else None; ``default_blocked`` the worst return at the
    default altitude (None: it is safe). ``legal_ceiling_m``: the highest RTL altitude above
    home that may be flown (None: no legal limit), which :attr:`usable` compares with."""

    autopilot: Autopilot
    safe_altitude_m: float | None
    ceiling_m: float
    default_altitude_m: float
    default_safe: bool
    samples: int
    step_m: float
    margin_m: float
    #: the least whole metre RTL_SLACK_M or more above the safe altitude (what to set)
    setting_m: float | None = None
    blocked: Where | None = None
    default_blocked: Where | None = None
    evaluations: int = 0
    legal_ceiling_m: float | None = None
    #: the braking distance at the fastest sample (m): how far the longest brake goes on
    brake_m: float = 0.0

    @property
    def proven(self) -> bool:
        return self.safe_altitude_m is not None

    @property
    def usable(self) -> bool:
        """A safe RTL altitude exists that may also be flown: its setting (a whole metre)
        at most the ceiling and the legal ceiling."""
        if self.setting_m is None:
            return False
        return self.setting_m <= self.highest_m + 1e-9

    @property
    def highest_m(self) -> float:
        """The highest RTL altitude that may be advised: the ceiling, or the legal one."""
        if self.legal_ceiling_m is None:
            return self.ceiling_m
        return min(self.ceiling_m, self.legal_ceiling_m)

    @property
    def parameter(self) -> RtlParameter:
        return RTL_PARAMETERS[self.autopilot]

    def report(self) -> dict[str, object]:
        def where(b: Where | None) -> object:
            return None if b is None else b.report()

        return {
            "rtl_safe_altitude_m": self.safe_altitude_m,
            "rtl_ceiling_m": self.ceiling_m,
            "rtl_legal_ceiling_m": self.legal_ceiling_m,
            "rtl_setting_m": self.setting_m,
            "rtl_usable": self.usable,
            "rtl_default_altitude_m": self.default_altitude_m,
            "rtl_default_safe": self.default_safe,
            "rtl_samples": self.samples,
            "rtl_sample_step_m": self.step_m,
            "rtl_brake_m": round(self.brake_m, 2),
            "rtl_blocked": where(self.blocked),
            "rtl_default_blocked": where(self.default_blocked),
        }


def unsafe_returns(
    world: World,
    flight: Flight,
    *,
    home_enu: tuple[float, float, float],
    autopilot: Autopilot,
    altitude_m: float,
    step_m: float | None = None,
    speed_m_s: float | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """The samples of ``flight`` (:meth:`ReturnSamples.along`, at ``speed_m_s``, default the
    firmware's cruise speed) and which of their returns at RTL altitude ``altitude_m`` fail
    to keep the margin (the test :func:`prove_rtl` bisects)."""
    limits = firmware_rtl(autopilot)
    speed = limits.speed_xy_m_s if speed_m_s is None else float(speed_m_s)
    samples = ReturnSamples.along(flight, step_m, speed)
    returns = _Returns(world, samples, home_enu, limits)
    return samples.points, returns.at(altitude_m, None).unsafe


def prove_rtl(
    world: World,
    flight: Flight | None = None,
    *,
    home_enu: tuple[float, float, float],
    autopilot: Autopilot,
    ceiling_m: float,
    name_of: Callable[[int], str],
    limits: GuidanceLimits | None = None,
    step_m: float | None = None,
    samples: ReturnSamples | None = None,
    speed_m_s: float | None = None,
    legal_ceiling_m: float | None = None,
    describe: bool = True,
) -> RtlProof:
    """Check the autopilot's return from every point of a flight in ``world`` (ground
    standing solids only: :func:`~uavplan.worlds.return_world`) and find the lowest
    safe RTL altitude up to ``ceiling_m`` above home (see the module docstring).

    The points are ``samples`` (a track's, with its velocities) or, without them, points
    along ``flight`` flown at ``speed_m_s`` (default: the firmware's cruise speed).
    ``limits``: the firmware's return behaviour (default: its parameter defaults,
    :func:`firmware_rtl`); ``name_of(i)`` names obstacle ``i`` for the messages;
    ``legal_ceiling_m`` is reported with the proof (:attr:`RtlProof.usable`); without
    ``describe`` the worst returns are not looked for (``blocked`` and ``default_blocked``
    stay None)."""
    base = limits or firmware_rtl(autopilot)
    if samples is None:
        if flight is None:
            raise ValueError("prove_rtl needs a flight or samples")
        speed = base.speed_xy_m_s if speed_m_s is None else float(speed_m_s)
        samples = ReturnSamples.along(flight, step_m, speed)
    checker = _Returns(world, samples, home_enu, base)
    spec = RTL_PARAMETERS[autopilot]
    default = default_rtl_altitude_m(autopilot)
    floor = spec.minimum_m
    margin = world.margin_m
    describer = _Describer(world, name_of, checker)

    def worst(check: ReturnCheck) -> Where | None:
        return describer.worst(check) if describe else None

    # A return safe at an altitude stays safe higher up (the module doc), so once the lowest
    # altitude has been checked from every sample, only those it fails need a further look.
    low = checker.at(max(floor, min(floor, ceiling_m)), None)
    still = np.flatnonzero(low.unsafe)
    at_default = checker.at(max(floor, min(default, ceiling_m)), still)
    default_safe = default <= ceiling_m + 1e-9 and at_default.safe
    default_blocked = None if default_safe else worst(at_default)
    common = dict(
        autopilot=autopilot,
        ceiling_m=float(ceiling_m),
        default_altitude_m=default,
        default_safe=default_safe,
        samples=len(samples),
        step_m=samples.step_m,
        margin_m=margin,
        default_blocked=default_blocked,
        legal_ceiling_m=None if legal_ceiling_m is None else float(legal_ceiling_m),
        brake_m=checker.brake_m,
    )
    if ceiling_m < floor:
        return RtlProof(
            safe_altitude_m=None,
            blocked=worst(low),
            evaluations=checker.evaluations,
            **common,  # type: ignore[arg-type]
        )
    if low.safe:
        return RtlProof(
            safe_altitude_m=floor,
            setting_m=float(math.ceil(floor - 1e-9)),
            evaluations=checker.evaluations,
            **common,  # type: ignore[arg-type]
        )
    high = checker.at(ceiling_m, still)
    if not high.safe:
        return RtlProof(
            safe_altitude_m=None,
            blocked=worst(high),
            evaluations=checker.evaluations,
            **common,  # type: ignore[arg-type]
        )
    # bisection over the samples still unsafe at the lower end
    lo, hi = floor, float(ceiling_m)
    while hi - lo > RESOLUTION_M:
        mid = 0.5 * (lo + hi)
        check = checker.at(mid, still)
        if check.safe:
            hi = mid
        else:
            lo, still = mid, still[check.unsafe]
    safe = math.ceil(hi / RESOLUTION_M - 1e-9) * RESOLUTION_M
    unsafe_low = np.flatnonzero(low.unsafe)
    final = checker.at(safe, unsafe_low)
    if not final.safe:  # pragma: no cover - monotonicity holds (tests/flying/test_way_home.py)
        raise AssertionError(f"the return at {safe} m is not safe after the bisection")
    # the whole metre to advise: at least RTL_SLACK_M above the lowest safe altitude (at the
    # lowest, the worst return passes exactly the margin: a flown track's telemetry, rounded
    # to a centimetre, then reads it a hair inside)
    whole = float(math.ceil(safe + RTL_SLACK_M - 1e-9))
    return RtlProof(
        safe_altitude_m=round(safe, 2),
        setting_m=whole,
        evaluations=checker.evaluations,
        **common,  # type: ignore[arg-type]
    )


@dataclass(frozen=True)
class ReturnsVerdict:
    """The failsafe returns of a flight at the RTL altitude the vehicle holds: how many
    samples (``samples``, ``step_m`` apart), how many of their returns fail the margin
    (``unsafe``: closer than the margin to something, or above ``ceiling_m``), the worst
    of those (``worst``: the least clearance; None when every return keeps the margin),
    the return altitude held (``altitude_m``) and the longest brake (``brake_m``)."""

    altitude_m: float
    samples: int
    step_m: float
    unsafe: int
    margin_m: float
    worst: Where | None
    brake_m: float
    above_ceiling: int = 0
    ceiling_m: float | None = None

    @property
    def ok(self) -> bool:
        return self.unsafe == 0


def check_returns(
    world: World,
    samples: ReturnSamples,
    *,
    home_enu: tuple[float, float, float],
    limits: GuidanceLimits,
    name_of: Callable[[int], str],
    ceiling_m: float | None = None,
) -> ReturnsVerdict:
    """The return from every sample at the RTL altitude of ``limits`` (the parameters the
    vehicle holds: altitude, cone, climb, an altitude fence), measured in ``world``: which
    break the margin (or climb above ``ceiling_m`` above home, out of the flight volume),
    and the worst of all (:class:`ReturnsVerdict`)."""
    checker = _Returns(world, samples, home_enu, limits)
    altitude = float(limits.rtl_altitude_m)
    if not len(samples):
        return ReturnsVerdict(altitude, 0, samples.step_m, 0, world.margin_m, None, 0.0)
    check = checker.at(altitude, None)
    unsafe = check.unsafe.copy()
    above = 0
    if ceiling_m is not None:
        over = check.top_z - checker.home[2] > float(ceiling_m) + 1e-6
        above = int(over.sum())
        unsafe |= over
    describe = _Describer(world, name_of, checker)
    worst = describe.worst(check)
    if ceiling_m is not None and above and not bool(check.unsafe.any()):
        # only the ceiling fails: name the highest return
        j = int(np.argmax(check.top_z))
        x, y, z = (round(float(v), 1) for v in samples.points[j])
        top = float(check.top_z[j] - checker.home[2])
        worst = Where(
            (x, y, z),
            f"the ceiling ({ceiling_m:.0f} m above home): it climbs to {top:.0f} m",
            0.0,
            None if samples.time_s is None else float(samples.time_s[j]),
            None if samples.seq is None else int(samples.seq[j]),
        )
    return ReturnsVerdict(
        altitude,
        len(samples),
        samples.step_m,
        int(unsafe.sum()),
        world.margin_m,
        worst,
        checker.brake_m,
        above,
        None if ceiling_m is None else float(ceiling_m),
    )


#: the legs of a return, in the order :meth:`_Returns.legs` gives them
_LEGS = ("brake", "climb", "way back", "leg home", "leg home")


class _Returns:
    """The returns from ``samples`` at any RTL altitude, measured in ``world``."""

    def __init__(
        self,
        world: World,
        samples: ReturnSamples,
        home: tuple[float, float, float],
        limits: GuidanceLimits,
    ) -> None:
        self.world = world
        self.obstacles = world.without_ground()
        self.samples = samples
        self.points = samples.points
        self.grounded = samples.grounded
        self.home = np.asarray(home, dtype=np.float64)
        self.limits = limits
        self.evaluations = 0
        # the brake: on along the velocity to the stopping point, at the same height
        v = np.asarray(samples.velocity, dtype=np.float64).reshape(-1, 2)
        speed = np.hypot(v[:, 0], v[:, 1])
        brake = stopping_distance_m(limits, speed)
        unit = np.divide(v, speed[:, None], out=np.zeros_like(v), where=speed[:, None] > 1e-6)
        self.stops = self.points.copy()
        self.stops[:, :2] += unit * brake[:, None]
        self.brake_m = float(brake.max()) if len(brake) else 0.0
        # the return altitude: ArduPilot's from its stopping point, PX4's from where it began
        origin = self.points if limits.is_px4 else self.stops
        self.origin = origin
        self.distance_m = np.hypot(origin[:, 0] - home[0], origin[:, 1] - home[1])
        # the descent at home, from as high as any return can fly (the volume's top): nearest
        # the obstacles at its bottom, whatever the altitude, so measured once (it is the
        # take-off column, which the scenario's checks keep clear)
        column = np.array([[home[0], home[1], float(world.zlim[1])]])
        d_home, p_home = self.obstacles.segments_nearest(column, self.home[None, :])
        self.home_clearance_m = float(d_home[0])
        self.home_owner = int(self.obstacles.owner_of(p_home)[0])
        self.home_free = keeps_margin(self.home_clearance_m, world.margin_m)
        # the brake does not depend on the altitude: measured once
        air = ~self.grounded
        free = np.ones(len(self.points), dtype=bool)
        for space, mask in ((self.world, air), (self.obstacles, ~air)):
            if mask.any():
                free[mask] = space.segments_free(self.points[mask], self.stops[mask])
        self.brake_free = free
        #: the legs at the return altitude (indices into :meth:`legs`): ArduPilot flies home
        #: from its stopping point, PX4 comes back above where it began first
        self.air_legs = (2, 3, 4) if limits.is_px4 else (3,)

    def top_z(self, altitude_m: float, idx: NDArray[np.int64]) -> NDArray[np.float64]:
        """The altitude (site z) the returns from samples ``idx`` fly home at."""
        hz = float(self.home[2])
        lim = replace(self.limits, rtl_altitude_m=float(altitude_m))
        o = self.origin[idx]
        top = hz + return_altitude_m(lim, self.distance_m[idx], o[:, 2] - hz)
        if lim.is_px4:
            # PX4 ends its climb once within NAV_MC_ALT_RAD of the return altitude and flies
            # home from there: the leg home may be that much lower
            top = np.where(top > o[:, 2], np.maximum(o[:, 2], top - lim.altitude_acceptance_m), top)
        return np.asarray(top, dtype=np.float64)

    def legs(
        self, altitude_m: float, idx: NDArray[np.int64]
    ) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
        """The legs of the returns from samples ``idx`` (as :data:`_LEGS` names them): the
        brake, the climb above the stopping point, the way back at the return altitude to
        above where the return began (PX4; ArduPilot: none), and the legs home from both
        ends of that."""
        p, s = self.points[idx], self.stops[idx]
        top = self.top_z(altitude_m, idx)
        hx, hy = float(self.home[0]), float(self.home[1])
        s_top = np.column_stack([s[:, 0], s[:, 1], np.maximum(top, s[:, 2])])
        p_top = np.column_stack([p[:, 0], p[:, 1], np.maximum(top, p[:, 2])])
        home_top = np.column_stack([np.full(len(p), hx), np.full(len(p), hy), top])
        if not self.limits.is_px4:
            p_top = s_top
        return [(p, s), (s, s_top), (s_top, p_top), (s_top, home_top), (p_top, home_top)]

    def at(self, altitude_m: float, which: NDArray[np.int64] | None) -> ReturnCheck:
        """The returns from the samples ``which`` (None: all) at RTL altitude ``altitude_m``
        above home (each leg with :meth:`~uavplan.world.World.segments_free`, the world's
        exact test)."""
        self.evaluations += 1
        idx = np.arange(len(self.points)) if which is None else which
        free = self.free(altitude_m, idx, None)
        unsafe = ~free if self.home_free else np.ones(len(idx), dtype=bool)
        return ReturnCheck(float(altitude_m), idx, self.top_z(altitude_m, idx), unsafe)

    def free(
        self, altitude_m: float, idx: NDArray[np.int64], margin_m: float | None
    ) -> NDArray[np.bool_]:
        """Which returns from samples ``idx`` keep ``margin_m`` (None: the world's margin; a
        smaller one finds how close the unsafe ones come) on every leg but the descent at
        home, inside the (padded) flight volume."""
        legs = self.legs(altitude_m, idx)
        if margin_m is None:
            free = self.brake_free[idx].copy()
        else:
            free = np.ones(len(idx), dtype=bool)
        air = ~self.grounded[idx]
        first = (0, 1) if margin_m is not None else (1,)
        for k in first:
            a, b = legs[k]
            for space, mask in ((self.world, air), (self.obstacles, ~air)):
                if mask.any():
                    free[mask] &= space.segments_free(a[mask], b[mask], margin_m)
        for k in self.air_legs:
            a, b = legs[k]
            moved = np.any(a != b, axis=1)
            if moved.any():
                sub = self.world.segments_free(a[moved], b[moved], margin_m)
                free[np.flatnonzero(moved)[~sub]] = False
        return free

    def least(self, altitude_m: float, idx: NDArray[np.int64]) -> tuple[NDArray[np.int64], float]:
        """The samples of ``idx`` whose returns come closest to something (within 1 cm of
        the least clearance below the margin: few), found by bisecting the margin with the
        fast free test; and that clearance's upper bound. ``idx`` are unsafe returns."""
        lo, hi = 0.0, float(self.world.margin_m)
        still = idx
        while hi - lo > RESOLUTION_M and len(still) > 1:
            mid = 0.5 * (lo + hi)
            closer = ~self.free(altitude_m, still, mid)
            if closer.any():
                still, hi = still[closer], mid
            else:
                lo = mid
        return still, hi

    def clearances(
        self, altitude_m: float, idx: NDArray[np.int64]
    ) -> tuple[NDArray[np.float64], list[str], NDArray[np.int64], list[World]]:
        """Per sample of ``idx``: the least clearance of its return, on which leg, the
        obstacle index there (or GROUND / -1), and the world it was measured in."""
        legs = self.legs(altitude_m, idx)
        n = len(idx)
        best = np.full(n, self.home_clearance_m)
        which = ["descent at home"] * n
        owner = np.full(n, self.home_owner, dtype=np.int64)
        spaces: list[World] = [self.obstacles] * n
        air = ~self.grounded[idx]
        everywhere = np.ones(n, dtype=bool)
        for k, (a, b) in enumerate(legs):
            if k >= 2 and k not in self.air_legs:
                continue
            parts = (
                [(self.world, air), (self.obstacles, ~air)] if k < 2 else [(self.world, everywhere)]
            )
            for space, mask in parts:
                if not mask.any():
                    continue
                rows = np.flatnonzero(mask)
                dist, piece = space.segments_nearest(a[rows], b[rows])
                closer = dist < best[rows]
                if closer.any():
                    hit = rows[closer]
                    best[hit] = dist[closer]
                    owner[hit] = space.owner_of(piece[closer])
                    for r in hit:
                        which[int(r)] = _LEGS[k]
                        spaces[int(r)] = space
        return best, which, owner, spaces


class _Describer:
    """Names what a return passes, in words, as the flight check does."""

    def __init__(self, world: World, name_of: Callable[[int], str], returns: _Returns) -> None:
        self.world = world
        self.name_of = name_of
        self.returns = returns

    def worst(self, check: ReturnCheck) -> Where | None:
        """The unsafe sample whose return comes closest to something, what it passes, how
        close (None: none is unsafe). The candidates are narrowed by bisecting the margin
        with the fast free test; the exact clearances are measured for those few only."""
        bad = check.index[np.flatnonzero(check.unsafe)]
        if not bad.size:
            return None
        bad, _ = self.returns.least(check.altitude_m, bad)
        if len(bad) > WORST_EXACT:
            if self.world.has_ground:
                bad = self._closest(check.altitude_m, bad)
            else:  # the bisection converged: all within 1 cm of the least, the first few
                bad = bad[:WORST_NEIGHBOURS]
        clearance, leg, owner, spaces = self.returns.clearances(check.altitude_m, bad)
        k = int(np.argmin(clearance))
        return self.at(
            check.altitude_m, int(bad[k]), (leg[k], float(clearance[k]), int(owner[k]), spaces[k])
        )

    def _closest(self, altitude_m: float, bad: NDArray[np.int64]) -> NDArray[np.int64]:
        """Among many unsafe returns whose clearances the margin's bisection cannot narrow
        (over terrain the ground's solids hold the world's margin): the exact clearance of
        every ``stride``-th (:data:`WORST_EXACT` of them), then of the unsafe returns within
        a stride of the closest few; the candidates for the worst."""
        stride = math.ceil(len(bad) / WORST_EXACT)
        picked = bad[::stride]
        clearance, _, _, _ = self.returns.clearances(altitude_m, picked)
        best = picked[np.argsort(clearance, kind="stable")[:WORST_NEIGHBOURS]]
        near = np.isin(bad, best)
        for shift in range(1, stride):
            near[shift:] |= np.isin(bad[:-shift], best)
            near[:-shift] |= np.isin(bad[shift:], best)
        return bad[near]

    def at(self, altitude_m: float, i: int, found: tuple[str, float, int, World]) -> Where:
        """Sample ``i``'s return described: ``found`` is (leg, clearance, owner, world); a
        return that keeps the margin but leaves the (padded) flight volume is named so."""
        leg, clearance, owner, space = found
        if keeps_margin(clearance, self.world.margin_m):
            for k, (a, b) in enumerate(self.returns.legs(altitude_m, np.array([i]))):
                if not self.world.points_inside_bounds(np.vstack([a, b])).all():
                    samples = self.returns.samples
                    x, y, z = (round(float(v), 1) for v in samples.points[i])
                    return Where(
                        (x, y, z),
                        f"the edge of the flight volume ({_LEGS[k]})",
                        0.0,
                        None if samples.time_s is None else float(samples.time_s[i]),
                        None if samples.seq is None else int(samples.seq[i]),
                    )
        where = None
        if owner == GROUND:
            a, b = self._leg(altitude_m, i, leg)
            _, _, at = space.terrain_nearest(a, b)
            where = (float(at[0, 0]), float(at[0, 1]))
        samples = self.returns.samples
        x, y, z = (round(float(v), 1) for v in samples.points[i])
        return Where(
            (x, y, z),
            f"{self.name(owner, where)} ({leg})",
            max(0.0, clearance),
            None if samples.time_s is None else float(samples.time_s[i]),
            None if samples.seq is None else int(samples.seq[i]),
        )

    def _leg(
        self, altitude_m: float, i: int, leg: str
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        legs = self.returns.legs(altitude_m, np.array([i]))
        k = _LEGS.index(leg) if leg in _LEGS else 3
        return legs[k]

    def name(self, owner: int, where: tuple[float, float] | None) -> str:
        if owner == -1:
            return "nothing"
        if owner != GROUND:
            return self.name_of(owner)
        if where is None:
            return "the ground"
        return f"the terrain at ({where[0]:.0f}, {where[1]:.0f})"


def return_paths(
    samples: ReturnSamples, home_enu: tuple[float, float, float], limits: GuidanceLimits
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Every leg of the returns from ``samples`` at the RTL altitude of ``limits`` (the brake,
    the climb, PX4's way back and the legs home) as segments ``(a, b)`` ``(n, 3)``: the lines
    a failsafe return flies (a geofence keeps its distance from them)."""
    if not len(samples):
        return np.empty((0, 3)), np.empty((0, 3))
    # no world is measured here: an empty one carries the home column's clearance
    empty = World.build([], bounds_xyz=((-1e7, 1e7), (-1e7, 1e7), (-1e7, 1e7)), margin_m=0.0)
    returns = _Returns(empty, samples, home_enu, limits)
    idx = np.arange(len(samples))
    legs = returns.legs(float(limits.rtl_altitude_m), idx)
    keep = (0, 1, *returns.air_legs)
    a = np.vstack([legs[k][0] for k in keep])
    b = np.vstack([legs[k][1] for k in keep])
    return a, b


def ceiling_above_home(route: PlannedRoute, top_z_m: float) -> float:
    """The flight volume's top ``top_z_m`` (site z) as an altitude above home."""
    home_z = 0.0 if route.waypoint_ground_z_m is None else float(route.waypoint_ground_z_m[0])
    return float(top_z_m) - home_z
