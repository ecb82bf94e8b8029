"""Kinematic building blocks of the flight model: vectors, speed profiles, wind, firmware maths.

Pure functions and small value types, no I/O. Positions are ENU metres as plain
``(x, y, z)`` float tuples: the model steps one vehicle at a time, and for three numbers
plain floats are several times faster than numpy arrays (the track is turned into arrays,
vectorised, once it is flown: :mod:`uavplan.autopilot.simulate`).
"""

from __future__ import annotations

import math
from bisect import bisect_right
from dataclasses import dataclass, field

__all__ = [
    "Profile",
    "SCurve",
    "Vec",
    "add",
    "dist_xy",
    "ground_speed_limit",
    "kinematic_limit",
    "max_speed_from_distance",
    "max_speed_in_waypoint",
    "norm",
    "scale",
    "sqrt_controller",
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


def sqrt_controller(error: float, p: float, accel: float, dt: float) -> float:
    """The rate that corrects ``error``: linear (gain ``p``) near zero, beyond
    ``accel / p²`` the speed from which ``accel`` stops the error at zero, and never more
    than the whole error in one step ``dt``: ArduPilot's ``sqrt_controller``
    (AP_Math/control.cpp)."""
    if accel <= 0.0:
        rate = error * p
    elif p <= 0.0:
        rate = math.copysign(math.sqrt(2.0 * accel * abs(error)), error)
    else:
        linear = accel / (p * p)
        if abs(error) > linear:
            rate = math.copysign(math.sqrt(2.0 * accel * (abs(error) - linear / 2.0)), error)
        else:
            rate = error * p
    if dt > 0.0:
        bound = abs(error) / dt
        rate = max(-bound, min(bound, rate))
    return rate


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


# ---------------------------------------------------------------------------------------------
# ArduPilot's jerk-limited S-curve (libraries/AP_Math/SCurve.cpp)

_SEG_ACCEL_END = 7
_SEG_SPEED_CHANGE_END = 14
_SEG_CONST = 15
_SEG_DECEL_END = 22
_CONST, _INCR, _DECR = 0, 1, 2


def _scurve_path(
    snap: float, jerk: float, v0: float, accel: float, vmax: float, length: float
) -> tuple[float, float, float, float, float]:
    """``SCurve::calculate_path``: the jerk (Jm), its raised-cosine ramp time (tj) and the
    durations t2 (constant jerk), t4 (constant acceleration), t6 (constant jerk) of a speed
    change from ``v0`` toward ``vmax`` within ``length``."""
    if not (snap > 0 and jerk > 0 and accel > 0 and vmax > 0 and length > 0) or v0 >= vmax:
        return 0.0, 0.0, 0.0, 0.0, 0.0
    sm, jm, am, vm, ln = snap, jerk, accel, vmax, length
    tj = jm * math.pi / (2.0 * sm)
    at = min(am, (vm - v0) / (2.0 * tj), (ln + 4.0 * v0 * tj) / (4.0 * tj * tj))
    t2 = t4 = t6 = 0.0

    def t4_of(am: float, jm: float) -> float:
        root = math.sqrt(
            max(
                0.0,
                am**4 / 4.0
                + jm * jm * v0 * v0
                + am * am * jm * jm * tj * tj / 4.0
                + am * jm * jm * ln * 2.0
                - am * am * jm * v0
                + am**3 * jm * tj / 2.0
                - am * jm * jm * v0 * tj,
            )
        )
        base = -(am * am) * 1.5 - jm * v0 - am * jm * tj * 1.5
        return min(
            -(v0 - vm + am * tj + am * am / jm) / am,
            max((base + root) / (am * jm), (base - root) / (am * jm)),
        )

    if abs(at) < jm * tj:
        if v0 == 0.0:
            tj = min(
                tj,
                (ln * math.pi / (8.0 * sm)) ** 0.25,
                (vm * math.pi / (4.0 * sm)) ** (1.0 / 3.0),
                math.sqrt(am * math.pi / (2.0 * sm)),
            )
            jm = 2.0 * sm * tj / math.pi
            am = jm * tj
        else:
            am = at
            jm = am / tj
        if vm <= v0 + 2.0 * am * tj or ln <= 4.0 * v0 * tj + 4.0 * am * tj * tj:
            t4 = 0.0
        else:
            t4 = max(t4_of(am, jm), 0.0)
    else:
        short_speed = vm < v0 + am * tj + am * am / jm
        short_length = ln < (am**3 + am * jm * (v0 * 2.0 + am * tj * 2.0)) / (jm * jm) + (
            v0 * tj * 2.0 + am * tj * tj
        )
        if short_speed or short_length:
            disc = (-4.0 * v0 + 4.0 * vm + jm * tj * tj) / jm
            by_speed = max(
                jm * (tj + math.sqrt(max(0.0, disc))) * -0.5,
                jm * (tj - math.sqrt(max(0.0, disc))) * -0.5,
            )
            q = (jm * jm * tj * tj) / 9.0 - jm * v0 * (2.0 / 3.0)
            r = (
                -(jm * jm) * ln / 2.0
                + (jm**3) * tj**3 * (8.0 / 27.0)
                - jm * tj * (jm * jm * tj * tj + jm * v0 * 2.0) / 3.0
                + jm * jm * v0 * tj
            )
            s = math.sqrt(max(0.0, r * r - q**3)) - r
            cube = math.copysign(abs(s) ** (1.0 / 3.0), s) if s != 0 else 0.0
            by_length = jm * tj * (-2.0 / 3.0) + (q / cube if cube else 0.0) + cube
            am = min(am, by_speed, by_length)
            t2 = am / jm - tj
            t6 = t2
        else:
            t2 = am / jm - tj
            t4 = max(t4_of(am, jm), 0.0)
            t6 = t2
    values = (jm, tj, t2, t4, t6)
    if not all(math.isfinite(v) and v >= 0.0 for v in values):
        return 0.0, 0.0, 0.0, 0.0, 0.0
    return values


class SCurve:
    """ArduPilot Copter's straight-leg speed profile (``SCurve``, AP_Math/SCurve.cpp): from
    ``v0`` to rest over ``distance``, within ``vmax`` and ``accel``, the acceleration built
    up and taken down with ``jerk`` through raised-cosine jerk ramps whose steepness is
    ``snap``. Its 23 segments are the firmware's: the start, seven of acceleration, seven of
    a speed change, the constant speed, seven of deceleration (``add_segments``,
    ``set_origin_speed_max``). The same interface as :class:`Profile`: ``at(t)`` gives
    (distance, speed, acceleration), ``accel_end`` the end of the acceleration
    (``time_accel_end``), ``decel_start`` the start of the deceleration
    (``time_decel_start``)."""

    __slots__ = (
        "accel",
        "accel_end",
        "decel_start",
        "distance",
        "duration",
        "ends",
        "jerk",
        "segs",
        "snap",
        "v0",
        "vmax",
    )

    def __init__(
        self, distance: float, v0: float, vmax: float, accel: float, jerk: float, snap: float
    ) -> None:
        self.distance, self.vmax, self.accel, self.jerk, self.snap = (
            distance,
            vmax,
            accel,
            jerk,
            snap,
        )
        self.v0 = v0 = max(0.0, min(v0, vmax)) if vmax > 0 else 0.0
        # (end time, type, jerk, end accel, end vel, end pos)
        segs: list[tuple[float, int, float, float, float, float]] = [
            (0.0, _CONST, 0.0, 0.0, 0.0, 0.0)
        ]
        self.segs = segs
        if distance > _EPS and vmax > _EPS and accel > 0 and jerk > 0 and snap > 0:
            half = distance * 0.5
            jm, tj, t2, t4, t6 = _scurve_path(snap, jerk, 0.0, accel, vmax, half)
            self._jerk3(tj, jm, t2)
            self._const(t4, 0.0)
            self._jerk3(tj, -jm, t6)
            self._fix(_SEG_ACCEL_END, accel=0.0)
            for _ in range(7):
                self._const(0.0, 0.0)
            speed = segs[_SEG_SPEED_CHANGE_END][4]
            t15 = max(0.0, (distance - 2.0 * segs[_SEG_SPEED_CHANGE_END][5]) / speed)
            self._const(t15, 0.0)
            self._jerk3(tj, -jm, t6)
            self._const(t4, 0.0)
            self._jerk3(tj, jm, t2)
            self._fix(_SEG_DECEL_END, accel=0.0, vel=0.0)
            if v0 > 0.0:
                self._origin_speed(v0)
        self.ends = [s[0] for s in segs]
        self.duration = segs[-1][0]
        full = len(segs) == _SEG_DECEL_END + 1
        self.accel_end = segs[_SEG_ACCEL_END][0] if full else 0.0
        self.decel_start = segs[_SEG_CONST][0] if full else 0.0

    # -- building (SCurve::add_segment_*) ------------------------------------------------
    def _fix(self, index: int, *, accel: float | None = None, vel: float | None = None) -> None:
        t, kind, j, a, v, p = self.segs[index]
        self.segs[index] = (
            t,
            kind,
            j,
            a if accel is None else accel,
            max(0.0, v) if vel is None else vel,
            p,
        )

    def _const(self, dt: float, j0: float) -> None:
        t, _, _, a, v, p = self.segs[-1]
        if dt <= 0.0:
            self.segs.append((t, _CONST, j0, a, v, p))
            return
        self.segs.append(
            (
                t + dt,
                _CONST,
                j0,
                a + j0 * dt,
                v + a * dt + 0.5 * j0 * dt * dt,
                p + v * dt + 0.5 * a * dt * dt + j0 * dt**3 / 6.0,
            )
        )

    def _ramp(self, tj: float, jm: float, up: bool) -> None:
        t, _, _, a, v, p = self.segs[-1]
        if tj <= 0.0:
            self.segs.append((t, _CONST, 0.0, a, v, p))
            return
        beta = math.pi / tj
        alpha = jm * 0.5
        at = alpha * tj
        vt = alpha * (tj * tj * 0.5 - 2.0 / (beta * beta))
        pt = alpha * (-tj / (beta * beta) + tj**3 / 6.0)
        if up:
            self.segs.append(
                (t + tj, _INCR, jm, a + at, v + a * tj + vt, p + v * tj + 0.5 * a * tj * tj + pt)
            )
            return
        a2t, v2t = jm * tj, jm * tj * tj
        p2t = alpha * (-2.0 * tj / (beta * beta) + 4.0 / 3.0 * tj**3)
        self.segs.append(
            (
                t + tj,
                _DECR,
                jm,
                (a - at) + a2t,
                (v - vt) + (a - at) * tj + v2t,
                (p - pt) + (v - vt) * tj + 0.5 * (a - at) * tj * tj + p2t,
            )
        )

    def _jerk3(self, tj: float, jm: float, tcj: float) -> None:
        self._ramp(tj, jm, up=True)
        self._const(tcj, jm)
        self._ramp(tj, jm, up=False)

    def _origin_speed(self, speed: float) -> None:
        """``SCurve::set_origin_speed_max``: the profile rebuilt to start at ``speed``."""
        segs = self.segs
        vm = segs[_SEG_ACCEL_END][4]
        speed = min(speed, vm)
        length = self.distance
        jm, tj, t2, t4, t6 = _scurve_path(self.snap, self.jerk, speed, self.accel, vm, length / 2)
        del segs[:]
        segs.append((0.0, _CONST, 0.0, 0.0, speed, 0.0))
        self._jerk3(tj, jm, t2)
        self._const(t4, 0.0)
        self._jerk3(tj, -jm, t6)
        self._fix(_SEG_ACCEL_END, accel=0.0)
        d_start = min(0.0, length * 0.5 - segs[_SEG_ACCEL_END][5])
        end_vel = segs[_SEG_ACCEL_END][4]
        dt = d_start / end_vel if end_vel > 0 else 0.0
        for i in range(_SEG_ACCEL_END + 1):
            t, kind, j, a, v, p = segs[i]
            segs[i] = (t + dt, kind, j, a, v, p + d_start)
        for _ in range(7):
            self._const(0.0, 0.0)
        self._const(0.0, 0.0)
        cruise = segs[_SEG_CONST][4]
        jm, tj, t2, t4, t6 = _scurve_path(self.snap, self.jerk, 0.0, self.accel, cruise, length / 2)
        self._jerk3(tj, -jm, t6)
        self._const(t4, 0.0)
        self._jerk3(tj, jm, t2)
        self._fix(_SEG_DECEL_END, accel=0.0)
        d_end = max(0.0, length - segs[_SEG_DECEL_END][5])
        t15 = d_end / cruise if cruise > 0 else 0.0
        for i in range(_SEG_CONST, _SEG_DECEL_END + 1):
            t, kind, j, a, v, p = segs[i]
            segs[i] = (t + t15, kind, j, a, v, p + d_end)

    # -- evaluation (SCurve::get_jerk_accel_vel_pos_at_time) ----------------------------
    def at(self, t: float) -> tuple[float, float, float]:
        """(distance, speed, acceleration) at time ``t`` (clamped to the profile)."""
        segs = self.segs
        n = len(segs)
        if n < 2:
            return (0.0, 0.0, 0.0)
        i = bisect_right(self.ends, t)
        if i >= n:
            _, _, _, a, v, p = segs[-1]
            return (min(p, self.distance), max(0.0, v), a)
        if i == 0:
            _, _, _, a, v, p = segs[0]
            return (p, v, a)
        t0, _, _, a0, v0, p0 = segs[i - 1]
        t1, kind, jm, _, _, _ = segs[i]
        tau = t - t0
        if kind == _CONST or t1 - t0 <= 0.0:
            a = a0 + jm * tau
            v = v0 + a0 * tau + 0.5 * jm * tau * tau
            p = p0 + v0 * tau + 0.5 * a0 * tau * tau + jm * tau**3 / 6.0
        else:
            tj = t1 - t0
            alpha, beta = jm * 0.5, math.pi / tj
            if kind == _INCR:
                a = a0 + alpha * tau - alpha / beta * math.sin(beta * tau)
                v = (
                    v0
                    + a0 * tau
                    + alpha * 0.5 * tau * tau
                    + alpha / (beta * beta) * math.cos(beta * tau)
                    - alpha / (beta * beta)
                )
                p = (
                    p0
                    + v0 * tau
                    + 0.5 * a0 * tau * tau
                    - alpha / (beta * beta) * tau
                    + alpha * tau**3 / 6.0
                    + alpha / beta**3 * math.sin(beta * tau)
                )
            else:
                at = alpha * tj
                vt = alpha * (tj * tj * 0.5 - 2.0 / (beta * beta))
                pt = alpha * (-tj / (beta * beta) + tj**3 / 6.0)
                u = tau + tj
                a = (a0 - at) + alpha * u - alpha / beta * math.sin(beta * u)
                v = (
                    (v0 - vt)
                    + (a0 - at) * tau
                    + 0.5 * alpha * u * u
                    + alpha / (beta * beta) * math.cos(beta * u)
                    - alpha / (beta * beta)
                )
                p = (
                    (p0 - pt)
                    + (v0 - vt) * tau
                    + 0.5 * (a0 - at) * tau * tau
                    - alpha / (beta * beta) * u
                    + alpha / 6.0 * u**3
                    + alpha / beta**3 * math.sin(beta * u)
                )
        return (min(max(0.0, p), self.distance), max(0.0, v), a)
