"""What moves the vehicle for one step, flavour aside: the base of every motion, holding
still, braking to a stop, and a landing descent. The flavours' own guidance lives in
:mod:`.ardupilot` and :mod:`.px4`; :mod:`.model` runs them."""

from __future__ import annotations

import math
from collections.abc import Callable

from uavplan.autopilot.kinematics import (
    Vec,
    add,
    norm,
    scale,
)
from uavplan.autopilot.params import GuidanceLimits

#: speeds below this count as standing still
STILL_M_S = 0.01
#: a landing descent ends this close above the ground
TOUCHDOWN_M = 0.01


class Motion:
    """Moves ``pos``/``vel`` by one step. ``done`` when it has finished."""

    pos: Vec
    vel: Vec
    done: bool = False

    def step(self, dt: float) -> None:
        raise NotImplementedError


class Hold(Motion):
    def __init__(self, pos: Vec) -> None:
        self.pos = pos
        self.vel = (0.0, 0.0, 0.0)

    def step(self, dt: float) -> None:
        pass


class Brake(Motion):
    """Slow to a stop at the flavour's accelerations (the stopping point both firmwares
    compute before a new task)."""

    def __init__(self, pos: Vec, vel: Vec, limits: GuidanceLimits) -> None:
        self.pos, self.vel = pos, vel
        self.limits = limits
        self.done = norm(vel) < STILL_M_S

    def step(self, dt: float) -> None:
        vx, vy, vz = self.vel
        h = math.hypot(vx, vy)
        dv = self.limits.accel_xy_m_s2 * dt
        k = max(0.0, h - dv) / h if h > 0.0 else 0.0
        az = self.limits.accel_up_m_s2 if vz < 0 else self.limits.accel_down_m_s2
        nz = math.copysign(max(0.0, abs(vz) - az * dt), vz)
        self.vel = (vx * k, vy * k, nz)
        self.pos = add(self.pos, scale(self.vel, dt))
        self.done = norm(self.vel) < STILL_M_S
        if self.done:
            self.vel = (0.0, 0.0, 0.0)


class Descend(Motion):
    """A landing: descend at the flavour's landing speeds to the ground, drifting onto
    ``target_xy`` (the landing point) within the horizontal limits."""

    def __init__(
        self,
        pos: Vec,
        vel: Vec,
        ground: float,
        speed_at: Callable[[float], float],
        limits: GuidanceLimits,
        target_xy: tuple[float, float] | None = None,
    ) -> None:
        self.pos, self.vel = pos, vel
        self.ground = ground
        self.speed_at = speed_at
        self.limits = limits
        self.target_xy = target_xy if target_xy is not None else (pos[0], pos[1])

    def step(self, dt: float) -> None:
        lim = self.limits
        x, y, z = self.pos
        vx, vy, vz = self.vel
        ex, ey = self.target_xy[0] - x, self.target_xy[1] - y
        d = math.hypot(ex, ey)
        cmd_speed = min(lim.speed_xy_m_s, math.sqrt(2.0 * lim.accel_xy_m_s2 * d))
        cx, cy = (ex / d * cmd_speed, ey / d * cmd_speed) if d > 1e-6 else (0.0, 0.0)
        ax, ay = cx - vx, cy - vy
        a_h = math.hypot(ax, ay)
        a_max = lim.accel_xy_m_s2 * dt
        if a_h > a_max:
            ax, ay = ax * a_max / a_h, ay * a_max / a_h
        target_vz = -self.speed_at(z - self.ground)
        if vz > target_vz:
            vz = max(target_vz, vz - lim.accel_down_m_s2 * dt)
        else:
            vz = min(target_vz, vz + lim.accel_up_m_s2 * dt)
        self.vel = (vx + ax, vy + ay, vz)
        x, y, z = add(self.pos, scale(self.vel, dt))
        if z <= self.ground + TOUCHDOWN_M:
            z = self.ground
            self.vel = (0.0, 0.0, 0.0)
            self.done = True
        self.pos = (x, y, z)
