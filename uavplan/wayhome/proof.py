"""The way home, proven: does the autopilot's own return to launch keep the margin from every
point of the route, and from which RTL altitude up?

Both firmwares return the same way (:mod:`uavplan.sim.rtl` holds the rule, which the flight
model flies too): from where the return begins they climb vertically to the return altitude
(if below it), fly straight home at it, and descend at home. :func:`prove_rtl` checks that
return from points every ``step_m`` along the flown line (vertical legs included), for an
RTL altitude parameter A, with the world's exact segment clearances (the same machinery as
:func:`uavplan.flight.check_flight`): the climb, the straight return at the return altitude
and the descent at home must each keep the safety margin from the obstacles and the terrain.

**Monotonicity.** Every solid a return must clear stands on the ground (obstacles, the
terrain's solids: from below the ground up to a height), so a point's distance to them never
shrinks as the point rises. A return's climb is nearest to them at its bottom (the route
point, the same for every A), its straight leg home lies higher when A is higher (the
return altitude never decreases with A, :func:`~uavplan.sim.rtl.return_altitude_m`), and the
descent at home is nearest at the ground. So a return that keeps the margin at A keeps it at
every higher A: the safe altitudes are an interval [lowest, ceiling], and the lowest is
found by bisection (to 1 cm). The ceiling (the flight volume's top above home, less
ArduPilot's FENCE_MARGIN under an altitude fence, which caps its return altitude) bounds it
from above: a return above the ceiling leaves the volume. The terrain's ceiling over each
cell (the route's highest height above the ground) is not a wall a return must clear, so the
proof uses the world without it (:func:`floor_world`).

PX4 ends its climb within ``NAV_MC_ALT_RAD`` (0.8 m) of the return altitude and flies home
from there, so its leg home is checked that much lower.

What is left out (docs/way-home.md): the braking distance before the climb (the return
starts where the vehicle stops, up to v²/2a further along the track), ArduPilot's S-curve
corner between the climb and the leg home, rally points (none are planned), and terrain
following (RTL_ALT_TYPE): the return altitude is above home.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from uavplan.config import Autopilot
from uavplan.flight import Flight
from uavplan.route import PlannedRoute, keeps_margin
from uavplan.sim.params import FlightLimits, Parameters, flight_limits, param_table
from uavplan.sim.rtl import ARDUPILOT_RTL_ALT_MIN_M, return_altitude_m
from uavplan.world import GROUND, World

__all__ = [
    "ARDUPILOT_FENCE_MARGIN_M",
    "RTL_PARAMETERS",
    "ReturnCheck",
    "RtlParameter",
    "RtlProof",
    "ceiling_above_home",
    "default_rtl_altitude_m",
    "firmware_rtl",
    "prove_rtl",
    "return_samples",
    "sample_step_m",
    "unsafe_returns",
]

#: the bisection stops when the safe and the unsafe altitude are this close (m)
RESOLUTION_M = 0.01
#: returns are checked from points at most this far apart along the flown line (m) ...
SAMPLE_STEP_M = 1.0
#: ... or as many as this on a long route (the step grows with the route's length)
MAX_SAMPLES = 4000
#: ArduPilot's FENCE_MARGIN default (m): under an altitude fence its return flies at most
#: FENCE_ALT_MAX less this (ModeRTL::compute_return_target, AC_Fence::get_safe_alt_max)
ARDUPILOT_FENCE_MARGIN_M = 2.0


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


def firmware_rtl(autopilot: Autopilot) -> FlightLimits:
    """The firmware's return behaviour at its parameter defaults (cone, climb, descent)."""
    return flight_limits(Parameters.defaults(autopilot))


def default_rtl_altitude_m(autopilot: Autopilot) -> float:
    """The firmware's default RTL altitude (ArduPilot 15 m, PX4 60 m)."""
    spec = RTL_PARAMETERS[autopilot]
    for row in param_table(autopilot):
        if row.name == spec.name:
            return row.default / spec.per_m
    raise KeyError(spec.name)  # pragma: no cover - the tables hold both


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
class RtlProof:
    """The autopilot's return checked from every point of a route (see the module doc).

    ``safe_altitude_m``: the lowest RTL altitude above home from which every return keeps
    the margin (None: none up to ``ceiling_m``). ``default_safe``: the firmware's default
    (``default_altitude_m``) does. ``blocked``: the first point (ENU) from which no altitude
    up to the ceiling is safe, and what its return passes (words, clearance m), else None;
    ``default_blocked`` the same at the default altitude."""

    autopilot: Autopilot
    safe_altitude_m: float | None
    ceiling_m: float
    default_altitude_m: float
    default_safe: bool
    samples: int
    step_m: float
    margin_m: float
    #: the least whole metre at or above the safe altitude found safe (what to set)
    setting_m: float | None = None
    blocked: tuple[tuple[float, float, float], str, float] | None = None
    default_blocked: tuple[tuple[float, float, float], str, float] | None = None
    evaluations: int = 0

    @property
    def proven(self) -> bool:
        return self.safe_altitude_m is not None

    @property
    def parameter(self) -> RtlParameter:
        return RTL_PARAMETERS[self.autopilot]

    def report(self) -> dict[str, object]:
        def where(b: tuple[tuple[float, float, float], str, float] | None) -> object:
            if b is None:
                return None
            return {"point": list(b[0]), "nearest": b[1], "clearance_m": b[2]}

        return {
            "rtl_safe_altitude_m": self.safe_altitude_m,
            "rtl_ceiling_m": self.ceiling_m,
            "rtl_setting_m": self.setting_m,
            "rtl_default_altitude_m": self.default_altitude_m,
            "rtl_default_safe": self.default_safe,
            "rtl_samples": self.samples,
            "rtl_sample_step_m": self.step_m,
            "rtl_blocked": where(self.blocked),
            "rtl_default_blocked": where(self.default_blocked),
        }


def sample_step_m(length_m: float) -> float:
    """The sampling step for a flown line ``length_m`` long (:data:`SAMPLE_STEP_M`, longer
    beyond :data:`MAX_SAMPLES` samples)."""
    return max(SAMPLE_STEP_M, length_m / MAX_SAMPLES)


def return_samples(flight: Flight, step_m: float) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Points ``(n, 3)`` at most ``step_m`` apart (horizontally and vertically) along the
    airborne part of ``flight`` and its landing descent, vertices included, and which of
    them are on the landing descent (their climb starts near the ground and is measured
    against the obstacles only, as the landing is). The take-off climb is left out: a
    return from it descends where it climbed."""
    p = flight.points_enu
    first, last = flight.airborne
    pieces: list[NDArray[np.float64]] = []
    grounded: list[NDArray[np.bool_]] = []
    for i in range(first, len(p) - 1):
        a, b = p[i], p[i + 1]
        span = max(float(np.hypot(*(b[:2] - a[:2]))), abs(float(b[2] - a[2])))
        k = max(1, math.ceil(span / step_m))
        t = np.arange(k)[:, None] / k
        pieces.append(a + t * (b - a))
        grounded.append(np.full(k, i >= last))
    end = len(p) - 1
    pieces.append(p[end : end + 1])
    grounded.append(np.array([end > last]))
    return np.vstack(pieces), np.concatenate(grounded)


def unsafe_returns(
    world: World,
    flight: Flight,
    *,
    home_enu: tuple[float, float, float],
    autopilot: Autopilot,
    altitude_m: float,
    step_m: float | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """The samples of ``flight`` (:func:`return_samples`) and which of their returns at RTL
    altitude ``altitude_m`` fail to keep the margin (the test :func:`prove_rtl` bisects)."""
    step = sample_step_m(flight.length_m) if step_m is None else float(step_m)
    points, grounded = return_samples(flight, step)
    returns = _Returns(world, points, grounded, home_enu, firmware_rtl(autopilot))
    return points, returns.at(altitude_m, None).unsafe


def prove_rtl(
    world: World,
    flight: Flight,
    *,
    home_enu: tuple[float, float, float],
    autopilot: Autopilot,
    ceiling_m: float,
    name_of: Callable[[int], str],
    limits: FlightLimits | None = None,
    step_m: float | None = None,
) -> RtlProof:
    """Check the autopilot's return from every point of ``flight`` in ``world`` (ground
    standing solids only: :func:`floor_world`) and find the lowest safe RTL altitude up to
    ``ceiling_m`` above home (see the module docstring). ``limits``: the firmware's return
    behaviour (default: its parameter defaults, :func:`firmware_rtl`); ``name_of(i)`` names
    obstacle ``i`` for the messages."""
    base = limits or firmware_rtl(autopilot)
    step = sample_step_m(flight.length_m) if step_m is None else float(step_m)
    points, grounded = return_samples(flight, step)
    checker = _Returns(world, points, grounded, home_enu, base)
    spec = RTL_PARAMETERS[autopilot]
    default = default_rtl_altitude_m(autopilot)
    floor = spec.minimum_m
    margin = world.margin_m
    describe = _Describer(world, name_of, checker)

    # A return safe at an altitude stays safe higher up (the module doc), so once the lowest
    # altitude has been checked from every sample, only those it fails need a further look.
    low = checker.at(max(floor, min(floor, ceiling_m)), None)
    still = np.flatnonzero(low.unsafe)
    at_default = checker.at(max(floor, min(default, ceiling_m)), still)
    default_safe = default <= ceiling_m + 1e-9 and at_default.safe
    default_blocked = None if default_safe else describe.first(points, at_default)
    common = dict(
        autopilot=autopilot,
        ceiling_m=float(ceiling_m),
        default_altitude_m=default,
        default_safe=default_safe,
        samples=len(points),
        step_m=step,
        margin_m=margin,
        default_blocked=default_blocked,
    )
    if ceiling_m < floor:
        return RtlProof(
            safe_altitude_m=None,
            blocked=describe.first(points, low),
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
            blocked=describe.first(points, high),
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
    if not final.safe:  # pragma: no cover - monotonicity holds (tests/test_way_home.py)
        raise AssertionError(f"the return at {safe} m is not safe after the bisection")
    # the whole metre to advise: the one just below the bisection's answer when that is
    # safe too (the answer lies up to RESOLUTION_M above the exact lowest), else the next
    whole = float(math.ceil(safe - 1e-9))
    below = whole - 1.0
    if safe - below <= RESOLUTION_M + 1e-9 and checker.at(below, unsafe_low).safe:
        whole = below
    return RtlProof(
        safe_altitude_m=round(safe, 2),
        setting_m=whole,
        evaluations=checker.evaluations,
        **common,  # type: ignore[arg-type]
    )


class _Returns:
    """The returns from ``points`` at any RTL altitude, measured in ``world``."""

    def __init__(
        self,
        world: World,
        points: NDArray[np.float64],
        grounded: NDArray[np.bool_],
        home: tuple[float, float, float],
        limits: FlightLimits,
    ) -> None:
        self.world = world
        self.obstacles = world.without_ground()
        self.points = points
        self.grounded = grounded
        self.home = np.asarray(home, dtype=np.float64)
        self.distance_m = np.hypot(points[:, 0] - home[0], points[:, 1] - home[1])
        self.limits = limits
        self.evaluations = 0
        # the descent at home, from as high as any return can fly (the volume's top): nearest
        # the obstacles at its bottom, whatever the altitude, so measured once (it is the
        # take-off column, which the scenario's checks keep clear)
        column = np.array([[home[0], home[1], float(world.zlim[1])]])
        d_home, p_home = self.obstacles.segments_nearest(column, self.home[None, :])
        self.home_clearance_m = float(d_home[0])
        self.home_owner = int(self.obstacles.owner_of(p_home)[0])
        self.home_free = keeps_margin(self.home_clearance_m, world.margin_m)

    def at(self, altitude_m: float, which: NDArray[np.int64] | None) -> ReturnCheck:
        """The returns from the samples ``which`` (None: all) at RTL altitude ``altitude_m``
        above home: climb, straight leg home, descent at home (each with
        :meth:`~uavplan.world.World.segments_free`, the world's exact test)."""
        self.evaluations += 1
        idx = np.arange(len(self.points)) if which is None else which
        p, top, home = self.legs(altitude_m, idx)
        free = self.world.segments_free(top, home)
        air = ~self.grounded[idx]
        for space, mask in ((self.world, air), (self.obstacles, ~air)):
            if mask.any():
                free[mask] &= space.segments_free(p[mask], top[mask])
        unsafe = ~free if self.home_free else np.ones(len(idx), dtype=bool)
        return ReturnCheck(float(altitude_m), idx, top[:, 2].copy(), unsafe)

    def legs(
        self, altitude_m: float, idx: NDArray[np.int64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """The samples ``idx``, the tops of their climbs and home at that height."""
        p = self.points[idx]
        hx, hy, hz = (float(v) for v in self.home)
        lim = replace(self.limits, rtl_altitude_m=float(altitude_m))
        top_z = hz + return_altitude_m(lim, self.distance_m[idx], p[:, 2] - hz)
        if lim.is_px4:
            # PX4 ends its climb once within NAV_MC_ALT_RAD of the return altitude and flies
            # home from there: the leg home may be that much lower
            top_z = np.where(
                top_z > p[:, 2], np.maximum(p[:, 2], top_z - lim.altitude_acceptance_m), top_z
            )
        top = p.copy()
        top[:, 2] = top_z
        home = np.column_stack([np.full(len(p), hx), np.full(len(p), hy), top_z])
        return p, top, home

    def nearest(
        self, altitude_m: float, i: int
    ) -> tuple[str, float, int, tuple[float, float] | None]:
        """What the return from sample ``i`` passes nearest: (which leg, clearance m, the
        obstacle index or GROUND or -1, where on the terrain (x, y) when it is the ground)."""
        idx = np.array([i])
        p, top, home = self.legs(altitude_m, idx)
        space = self.obstacles if self.grounded[i] else self.world
        legs = [
            ("climb", space, p, top),
            ("leg home", self.world, top, home),
        ]
        best: tuple[str, float, int, tuple[float, float] | None] = (
            "descent at home",
            self.home_clearance_m,
            self.home_owner,
            None,
        )
        for name, world, a, b in legs:
            dist, piece = world.segments_nearest(a, b)
            if float(dist[0]) < best[1]:
                owner = int(world.owner_of(piece)[0])
                where = None
                if owner == GROUND:
                    _, _, at = world.terrain_nearest(a, b)
                    where = (float(at[0, 0]), float(at[0, 1]))
                best = (name, float(dist[0]), owner, where)
        return best


class _Describer:
    """Names what a return passes, in words, as the flight check does."""

    def __init__(self, world: World, name_of: Callable[[int], str], returns: _Returns) -> None:
        self.world = world
        self.name_of = name_of
        self.returns = returns

    def first(
        self, points: NDArray[np.float64], check: ReturnCheck
    ) -> tuple[tuple[float, float, float], str, float] | None:
        """The first unsafe sample (in flight order), what its return passes, how close."""
        bad = np.flatnonzero(check.unsafe)
        if not bad.size:
            return None
        i = int(check.index[int(bad[0])])
        leg, clearance, owner, where = self.returns.nearest(check.altitude_m, i)
        x, y, z = (round(float(v), 1) for v in points[i])
        return (x, y, z), f"{self.name(owner, where)} ({leg})", max(0.0, clearance)

    def name(self, owner: int, where: tuple[float, float] | None) -> str:
        if owner == -1:
            return "nothing"
        if owner != GROUND:
            return self.name_of(owner)
        if where is None:
            return "the ground"
        return f"the terrain at ({where[0]:.0f}, {where[1]:.0f})"


def ceiling_above_home(route: PlannedRoute, top_z_m: float) -> float:
    """The flight volume's top ``top_z_m`` (site z) as an altitude above home."""
    home_z = 0.0 if route.waypoint_ground_z_m is None else float(route.waypoint_ground_z_m[0])
    return float(top_z_m) - home_z
