"""Kinematic building blocks of the flight model: vectors, speed profiles, wind, firmware maths.

Pure functions and small value types, no I/O. Positions are ENU metres as plain
``(x, y, z)`` float tuples: the model steps one vehicle at a time, and for three numbers
plain floats are several times faster than numpy arrays (the track is turned into arrays,
vectorised, once it is flown: :mod:`uavplan.sim.simulate`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

__all__ = [
    "Profile",
    "Vec",
    "add",
    "dist_xy",
    "ground_speed_limit",
    "kinematic_limit",
    "max_speed_from_distance",
    "max_speed_in_waypoint",
    "norm",
    "scale",
    "sub",
    "unit",
]

Vec = tuple[float, float, float]

_EPS = 1e-9


def add(a: Vec, b: Vec) -> Vec:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def sub(a: Vec, b: Vec) -> Vec:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def scale(a: Vec, k: float) -> Vec:
    return (a[0] * k, a[1] * k, a[2] * k)


def norm(a: Vec) -> float:
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


def unit(a: Vec) -> Vec:
    """``a`` scaled to length 1, or the zero vector for a (near) zero ``a``."""
    n = norm(a)
    if n < _EPS:
        return (0.0, 0.0, 0.0)
    return (a[0] / n, a[1] / n, a[2] / n)


def dist_xy(a: Vec, b: Vec) -> float:
    return math.hypot(a[0] - b[0], a[1] - b[1])


# ---------------------------------------------------------------------------------------------
# Limits along a direction, wind


def kinematic_limit(direction: Vec, limit_xy: float, limit_up: float, limit_down: float) -> float:
    """The largest magnitude along unit ``direction`` whose horizontal part stays within
    ``limit_xy`` and whose vertical part within ``limit_up`` (climbing) or ``limit_down``
    (descending): ArduPilot's ``kinematic_limit`` (AP_Math/vector3.cpp), used for speeds and
    accelerations along a 3-D leg."""
    h = math.hypot(direction[0], direction[1])
    z = direction[2]
    if h < _EPS and abs(z) < _EPS:
        return 0.0
    limit = math.inf
    if h >= _EPS:
        limit = limit_xy / h
    if z > _EPS:
        limit = min(limit, limit_up / z)
    elif z < -_EPS:
        limit = min(limit, limit_down / -z)
    return limit


def ground_speed_limit(
    air_speed_m_s: float, direction_xy: tuple[float, float], wind_en: tuple[float, float]
) -> float:
    """Ground speed along the horizontal unit ``direction_xy`` when the vehicle moves at
    ``air_speed_m_s`` through a wind ``wind_en`` (east, north m/s) and holds its track: the
    wind triangle, ``w·d + sqrt(V² − (w×d)²)``. 0 when the crosswind alone needs more than
    ``air_speed_m_s`` or the headwind is stronger than it (the vehicle makes no headway)."""
    dx, dy = direction_xy
    if dx == 0.0 and dy == 0.0:
        return air_speed_m_s
    we, wn = wind_en
    along = we * dx + wn * dy
    cross = we * dy - wn * dx
    if cross * cross >= air_speed_m_s * air_speed_m_s:
        return 0.0
    return max(0.0, along + math.sqrt(air_speed_m_s * air_speed_m_s - cross * cross))


def max_speed_from_distance(
    jerk: float | None, accel: float, distance: float, final_speed: float
) -> float:
    """The speed from which the vehicle reaches ``final_speed`` within ``distance`` braking
    at ``accel`` after a delay of ``2·accel/jerk`` to build up the deceleration: PX4's
    ``computeMaxSpeedFromDistance`` (lib/mathlib/math/TrajMath.hpp). Without a jerk limit,
    the plain ``sqrt(v_f² + 2 a d)``."""
    distance = max(0.0, distance)
    if jerk is None or jerk <= 0.0:
        return math.sqrt(final_speed * final_speed + 2.0 * accel * distance)
    b = 4.0 * accel * accel / jerk
    c = -2.0 * accel * distance - final_speed * final_speed
    return 0.5 * (-b + math.sqrt(b * b - 4.0 * c))


def max_speed_in_waypoint(alpha_rad: float, accel: float, radius: float) -> float:
    """The tangential speed of the circle tangent to two legs ``radius`` from their corner,
    ``alpha_rad`` being the angle between the legs (π: straight on), at lateral
    acceleration ``accel``: PX4's ``computeMaxSpeedInWaypoint`` (TrajMath.hpp)."""
    half = alpha_rad / 2.0
    if half >= math.pi / 2.0 - 1e-12:
        return math.inf
    return math.sqrt(max(0.0, accel * radius * math.tan(half)))


# ---------------------------------------------------------------------------------------------
# 1-D speed profiles


@dataclass(frozen=True)
class Profile:
    """Move ``distance`` metres along a line, starting at ``v0``, limited to ``vmax`` and
    ``accel``, ending at rest: accelerate (or slow down) to the top speed, cruise, brake.

    The constant-acceleration (trapezoidal) form of the firmware's jerk-limited S-curves:
    what the model leaves out is the jerk ramp at each change of acceleration
    (docs/flight-model.md). A start too fast to stop within ``distance`` at ``accel``
    brakes harder (the firmware overshoots instead). Times are seconds from the profile's
    start.
    """

    distance: float
    v0: float
    vmax: float
    accel: float
    #: (start time, start distance, start speed, acceleration) of each phase, and the end time
    phases: tuple[tuple[float, float, float, float], ...] = field(init=False, repr=False)
    duration: float = field(init=False)
    accel_end: float = field(init=False)
    decel_start: float = field(init=False)

    def __post_init__(self) -> None:
        d, v0, vmax, a = self.distance, max(0.0, self.v0), self.vmax, self.accel
        raw: list[tuple[float, float]] = []  # (duration, acceleration)
        if d <= _EPS or a <= 0.0 or (vmax <= _EPS and v0 <= _EPS):
            raw = []
        elif v0 * v0 / (2.0 * a) > d + 1e-9:
            hard = v0 * v0 / (2.0 * d)
            raw = [(v0 / hard, -hard)]
        elif v0 <= vmax:
            peak = min(vmax, math.sqrt((2.0 * a * d + v0 * v0) / 2.0))
            peak = max(peak, v0)
            d1 = (peak * peak - v0 * v0) / (2.0 * a)
            d3 = peak * peak / (2.0 * a)
            cruise = max(0.0, d - d1 - d3)
            raw = [
                ((peak - v0) / a, a),
                (cruise / peak if peak > _EPS else 0.0, 0.0),
                (peak / a, -a),
            ]
        else:
            d1 = (v0 * v0 - vmax * vmax) / (2.0 * a)
            d3 = vmax * vmax / (2.0 * a)
            cruise = max(0.0, d - d1 - d3)
            raw = [
                ((v0 - vmax) / a, -a),
                (cruise / vmax if vmax > _EPS else 0.0, 0.0),
                (vmax / a, -a),
            ]
        phases: list[tuple[float, float, float, float]] = []
        t = s = 0.0
        v = v0 if raw else 0.0
        for duration, acc in raw:
            phases.append((t, s, v, acc))
            s += v * duration + 0.5 * acc * duration * duration
            v = max(0.0, v + acc * duration)
            t += duration
        object.__setattr__(self, "phases", tuple(phases))
        object.__setattr__(self, "duration", t)
        accel_end = phases[0][0] + raw[0][0] if raw and raw[0][1] > 0 else 0.0
        object.__setattr__(self, "accel_end", accel_end)
        object.__setattr__(self, "decel_start", phases[-1][0] if phases else 0.0)

    def at(self, t: float) -> tuple[float, float, float]:
        """(distance, speed, acceleration) at time ``t`` (clamped to the profile)."""
        phases = self.phases
        if not phases:
            return (0.0, 0.0, 0.0)
        if t >= self.duration:
            return (self.distance, 0.0, 0.0)
        if t <= 0.0:
            return (0.0, phases[0][2], phases[0][3])
        for index in range(len(phases) - 1, -1, -1):
            t0, s0, v0, acc = phases[index]
            if t >= t0:
                tau = t - t0
                return (s0 + v0 * tau + 0.5 * acc * tau * tau, v0 + acc * tau, acc)
        raise AssertionError("unreachable")  # pragma: no cover
