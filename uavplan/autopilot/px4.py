"""PX4's auto-mode guidance (FlightTaskAuto with PositionSmoothing), kinematically: a velocity
setpoint toward the waypoint (while turning, toward the L1 point on the next leg), limited
by the corner speed and the braking distance (TrajMath.hpp), followed within the
acceleration limits. docs/flight-model.md cites each rule."""

from __future__ import annotations

import math
from collections.abc import Callable

from uavplan.autopilot.kinematics import (
    Vec,
    add,
    dist_xy,
    ground_speed_limit,
    max_speed_from_distance,
    max_speed_in_waypoint,
    norm,
    scale,
    sub,
    unit,
)
from uavplan.autopilot.motion import Motion
from uavplan.autopilot.params import GuidanceLimits


class SmoothingTrack(Motion):
    """PX4's auto-mode guidance (FlightTaskAuto + PositionSmoothing), kinematically: a
    velocity setpoint toward the waypoint, limited by the corner speed and the braking
    distance, followed within the acceleration limits."""

    def __init__(
        self, pos: Vec, vel: Vec, limits: GuidanceLimits, speed_xy: float, wind: tuple[float, float]
    ) -> None:
        self.pos, self.vel = pos, vel
        self.limits = limits
        self.wind = wind
        self.speed_xy = speed_xy
        self.prev_wp = pos
        self.target = pos
        self.next: Vec | None = None
        self.acceptance_m = limits.acceptance_radius_m
        self.max_speed_previous = 0.0
        self.climb_speed_at: Callable[[float], float] | None = None
        self.ground = 0.0
        self.stuck = False

    def set_target(self, target: Vec, next_target: Vec | None, acceptance_m: float) -> None:
        self.prev_wp = self.target if self.target != target else self.prev_wp
        self.target = target
        self.next = next_target
        self.acceptance_m = acceptance_m

    def set_speed(self, speed_xy: float) -> None:
        self.speed_xy = speed_xy

    def _speed_at_target(self, cruise: float) -> float:
        """The speed the corner at the target allows (computeXYSpeedFromWaypoints)."""
        lim, target, nxt = self.limits, self.target, self.next
        if nxt is None:
            return 0.0
        d_next = dist_xy(target, nxt)
        if d_next <= 0.001 or d_next < self.acceptance_m:
            return 0.0
        exit_speed = min(
            cruise, max_speed_from_distance(lim.jerk_m_s3, lim.accel_xy_m_s2, d_next, 0.0)
        )
        a = (target[0] - self.pos[0], target[1] - self.pos[1])
        b = (target[0] - nxt[0], target[1] - nxt[1])
        na, nb = math.hypot(*a), math.hypot(*b)
        cos_alpha = (a[0] * b[0] + a[1] * b[1]) / (na * nb) if na > 1e-9 and nb > 1e-9 else 0.0
        alpha = min(math.acos(max(-1.0, min(1.0, cos_alpha))), math.pi - 1e-6)
        turn = max_speed_in_waypoint(alpha, lim.accel_corner_m_s2, self.acceptance_m)
        return min(turn, exit_speed, cruise)

    def _arrival_z_speed(self, z_limit: float, z_acc: float) -> float:
        """The vertical speed the trajectory may keep at the target when the next one
        changes altitude too (PositionSmoothing::_getMaxZSpeed): the corner speed of the
        turn between the legs drawn in (horizontal distance from home, altitude), with
        NAV_MC_ALT_RAD as its radius; 0 when the next target is at the same altitude."""
        nxt = self.next
        if nxt is None or abs(self.target[2] - nxt[2]) <= 0.001:
            return 0.0
        start = (math.hypot(self.pos[0], self.pos[1]), self.pos[2])
        target = (math.hypot(self.target[0], self.target[1]), self.target[2])
        after = (math.hypot(nxt[0], nxt[1]), nxt[2])
        a = (target[0] - start[0], target[1] - start[1])
        b = (target[0] - after[0], target[1] - after[1])
        na, nb = math.hypot(*a), math.hypot(*b)
        cos_alpha = (a[0] * b[0] + a[1] * b[1]) / (na * nb) if na > 1e-9 and nb > 1e-9 else 1.0
        alpha = min(math.acos(max(-1.0, min(1.0, cos_alpha))), math.pi - 1e-6)
        turn = max_speed_in_waypoint(alpha, z_acc, self.limits.altitude_acceptance_m)
        return min(turn, z_limit)

    def _l1_point(self) -> Vec:
        """Where PX4 aims while turning onto the leg prev → target (PositionSmoothing's
        _getL1Point): the point L1 = max(acceptance, 5 m) ahead on the leg, in 3-D. On a leg
        that climbs or descends it lies on the slope: aiming at the target's altitude instead
        would drop the vehicle down a descending lane before it moved along it."""
        u = sub(self.target, self.prev_wp)
        n = norm(u)
        if n < 1e-9:
            return self.target
        u = scale(u, 1.0 / n)
        rel = sub(self.pos, self.prev_wp)
        closest = add(self.prev_wp, scale(u, rel[0] * u[0] + rel[1] * u[1] + rel[2] * u[2]))
        crosstrack = norm(sub(closest, self.pos))
        l1 = max(self.acceptance_m, 5.0)
        ahead = math.sqrt(l1 * l1 - crosstrack * crosstrack) if l1 > crosstrack else 0.0
        return add(closest, scale(u, ahead))

    def step(self, dt: float) -> None:
        lim = self.limits
        x, y, z = self.pos
        vx, vy, vz = self.vel
        tx, ty, tz = self.target
        xy_dist = math.hypot(tx - x, ty - y)
        speed_now = math.hypot(vx, vy)
        cos_align = (
            ((tx - x) * vx + (ty - y) * vy) / (xy_dist * speed_now)
            if xy_dist > 1e-9 and speed_now > 1e-9
            else 1.0
        )
        turning = speed_now > 0.2 and cos_align < 0.98 and xy_dist > self.acceptance_m
        cx, cy, cz = self._l1_point() if turning else self.target
        dz = cz - z
        d = unit((cx - x, cy - y, dz))
        h = math.hypot(d[0], d[1])
        # the commanded speed is through the air: along this direction the wind makes it
        cruise = (
            ground_speed_limit(self.speed_xy, (d[0] / h, d[1] / h), self.wind)
            if h > 1e-9
            else self.speed_xy
        )
        xy_speed = min(
            cruise,
            max_speed_from_distance(
                lim.jerk_m_s3, lim.accel_xy_m_s2, xy_dist, self._speed_at_target(cruise)
            ),
        )
        if turning:
            xy_speed = min(self.max_speed_previous, xy_speed)
        else:
            self.max_speed_previous = xy_speed
        self.stuck = (
            h > 1e-9
            and xy_dist > self.acceptance_m
            and cruise <= 1e-9
            and abs(dz) < lim.altitude_acceptance_m
        )
        if dz > 0:
            z_limit, z_acc = lim.speed_up_m_s, lim.accel_up_m_s2
            if self.climb_speed_at is not None and z - self.ground < lim.takeoff_slow_below_m:
                # FlightTaskAuto::_updateTrajConstraints: a take-off below MPC_LAND_ALT1
                # climbs at MPC_TKO_SPEED, accelerating at most MPC_TKO_SPEED / MPC_TKO_RAMP_T
                # ("to emulate the motor ramp")
                z_limit = self.climb_speed_at(z - self.ground)
                z_acc = min(z_acc, lim.takeoff_speed_m_s / max(lim.takeoff_ramp_s, 0.1))
        else:
            z_limit, z_acc = lim.speed_down_m_s, lim.accel_down_m_s2
        z_speed = min(
            z_limit,
            max_speed_from_distance(
                lim.jerk_m_s3, z_acc, abs(tz - z), self._arrival_z_speed(z_limit, z_acc)
            ),
        )
        total = math.hypot(xy_speed, z_speed)
        cmd = scale(d, total)
        cmd = _clamp_xy(cmd, xy_speed)
        cmd = _clamp_z(cmd, z_speed)
        # follow the setpoint within the acceleration limits
        ax, ay = cmd[0] - vx, cmd[1] - vy
        a_h = math.hypot(ax, ay)
        a_max = lim.accel_xy_m_s2 * dt
        if a_h > a_max:
            ax, ay = ax * a_max / a_h, ay * a_max / a_h
        az = cmd[2] - vz
        up_acc = z_acc if dz > 0 else lim.accel_up_m_s2
        az = min(az, up_acc * dt) if az > 0 else max(az, -lim.accel_down_m_s2 * dt)
        self.vel = (vx + ax, vy + ay, vz + az)
        self.pos = add(self.pos, scale(self.vel, dt))

    def reached(self, altitude_only: bool = False) -> bool:
        """The navigator's acceptance test for the current target."""
        tx, ty, tz = self.target
        if abs(self.pos[2] - tz) > self.limits.altitude_acceptance_m:
            return False
        return altitude_only or math.hypot(tx - self.pos[0], ty - self.pos[1]) <= self.acceptance_m


def _clamp_xy(v: Vec, limit: float) -> Vec:
    """PX4's clampToXYNorm (accuracy 0.5)."""
    n = math.hypot(v[0], v[1])
    if n <= 1e-12 or n <= limit:
        return v
    k = limit / n
    if limit < 0.5 and n < 0.5:
        return (v[0] * k, v[1] * k, v[2])
    return scale(v, k)


def _clamp_z(v: Vec, limit: float) -> Vec:
    """PX4's clampToZNorm (accuracy 0.5)."""
    n = abs(v[2])
    if n <= 1e-12 or n <= limit:
        return v
    k = limit / n
    if limit < 0.5 and n < 0.5:
        return (v[0], v[1], v[2] * k)
    return scale(v, k)
