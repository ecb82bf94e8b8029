"""ArduPilot Copter's waypoint navigation (AC_WPNav with S-curves), kinematically: each leg a
jerk-limited speed profile along the straight line (AP_Math/SCurve.cpp, ported in
:mod:`.kinematics`), the next leg blended into this one's braking at a corner, and the
terrain-frame legs' vertical offset (AC_PosControl). docs/flight-model.md cites each rule."""

from __future__ import annotations

import math
from collections.abc import Callable

from uavplan.autopilot.kinematics import (
    Profile,
    SCurve,
    Vec,
    add,
    ground_speed_limit,
    kinematic_limit,
    norm,
    scale,
    sqrt_controller,
    sub,
    unit,
)
from uavplan.autopilot.motion import Motion
from uavplan.autopilot.params import GuidanceLimits


class ScurveLeg:
    """One straight leg of ArduPilot's waypoint navigation: a speed profile along the line
    from ``origin`` to ``dest`` at the leg's kinematic limits (ground speed through the
    wind), from rest to rest."""

    def __init__(
        self,
        origin: Vec,
        dest: Vec,
        limits: GuidanceLimits,
        speed_xy: float,
        wind: tuple[float, float],
    ) -> None:
        self.origin, self.dest = origin, dest
        delta = sub(dest, origin)
        self.length = norm(delta)
        self.u = unit(delta)
        self.limits = limits
        self.wind = wind
        self.s_base = 0.0  # distance done before the current profile (a speed change re-plans)
        self.t = 0.0  # time into the current profile
        self.profile = self._plan(self.length, 0.0, speed_xy)

    def _plan(self, distance: float, v0: float, speed_xy: float) -> Profile | SCurve:
        u, lim = self.u, self.limits
        h = math.hypot(u[0], u[1])
        direction = (u[0] / h, u[1] / h) if h > 1e-9 else (0.0, 0.0)
        ground_xy = ground_speed_limit(speed_xy, direction, self.wind)
        vmax = kinematic_limit(u, ground_xy, lim.speed_up_m_s, lim.speed_down_m_s)
        amax = kinematic_limit(u, lim.accel_xy_m_s2, lim.accel_up_m_s2, lim.accel_down_m_s2)
        if lim.scurve_jerk_m_s3 > 0.0:
            # SCurve::calculate_track (set_kinematic_limits: the speed and acceleration along
            # the 3-D leg), jerk and snap from AC_WPNav::calc_scurve_jerk_and_snap
            return SCurve(distance, v0, vmax, amax, lim.scurve_jerk_m_s3, lim.scurve_snap_m_s4)
        return Profile(distance, v0, vmax, amax)

    @property
    def vmax(self) -> float:
        return self.profile.vmax

    @property
    def stuck(self) -> bool:
        """The wind leaves no ground speed along this leg."""
        return self.length > 1e-6 and self.profile.vmax <= 1e-9

    @property
    def finished(self) -> bool:
        return self.t >= self.profile.duration - 1e-12 and not self.stuck

    @property
    def remaining(self) -> float:
        return max(0.0, self.profile.duration - self.t)

    def advance(self, dt: float) -> None:
        self.t = min(self.t + dt, self.profile.duration)

    def state(self, t: float | None = None) -> tuple[float, float, float]:
        s, v, a = self.profile.at(self.t if t is None else t)
        return self.s_base + s, v, a

    def from_origin(self, t: float | None = None) -> Vec:
        return scale(self.u, self.state(t)[0])

    def to_dest(self, t: float | None = None) -> Vec:
        return scale(self.u, self.state(t)[0] - self.length)

    def velocity(self, t: float | None = None) -> Vec:
        return scale(self.u, self.state(t)[1])

    def acceleration(self, t: float | None = None) -> Vec:
        return scale(self.u, self.state(t)[2])

    def set_speed(self, speed_xy: float) -> None:
        """Re-plan the rest of the leg from where it is at the new horizontal speed."""
        s, v, _ = self.state()
        self.s_base = s
        self.t = 0.0
        self.profile = self._plan(self.length - s, v, speed_xy)


class TerrainOffset:
    """AC_PosControl's vertical position offset (``update_pos_offset_z``): on a terrain-frame
    leg it takes up the ground under the vehicle, as ``shape_pos_vel_accel`` does, through
    a square-root controller (gain ½·PSC_JERK_Z / WPNAV_ACCEL_Z, half of WPNAV_ACCEL_Z),
    within the climb and descent speeds and WPNAV_ACCEL_Z (the jerk's ramp left out, as
    elsewhere in the model). Off terrain it brings itself back to zero. ``z`` is added to
    the leg's altitude: the vehicle is where the leg puts it, ``z`` higher."""

    def __init__(self, limits: GuidanceLimits) -> None:
        self.limits = limits
        self.z = 0.0
        self.v = 0.0

    @property
    def active(self) -> bool:
        return self.z != 0.0 or self.v != 0.0

    def step(self, target: float, dt: float) -> None:
        lim = self.limits
        accel = lim.accel_up_m_s2
        gain = 0.5 * lim.jerk_z_m_s3 / accel if accel > 0.0 else 0.0
        want = sqrt_controller(target - self.z, gain, 0.5 * accel, dt)
        want = max(-lim.speed_down_m_s, min(lim.speed_up_m_s, want))
        dv = max(-accel * dt, min(accel * dt, want - self.v))
        self.v += dv
        self.z += self.v * dt
        if target == 0.0 and abs(self.z) < 1e-6 and abs(self.v) < 1e-6:
            self.z = self.v = 0.0  # settled: back to the plain leg


def terrain_pace(lag_m: float, margin_m: float) -> float:
    """The share of its speed the vehicle keeps along a terrain-frame leg when its altitude
    is ``lag_m`` off the ground-following target: 1 up to half of WPNAV_TER_MARGIN, down to
    0.01 at all of it (AC_PosControl::pos_offset_z_scaler); 1 without a margin."""
    if margin_m <= 0.0:
        return 1.0
    half = 0.5 * margin_m
    return max(0.01, min(1.0, 1.0 - (abs(lag_m) - half) / half))


class ScurveTrack(Motion):
    """ArduPilot Copter's waypoint navigation (AC_WPNav, S-curves), kinematically: the
    previous, current and next legs whose motions add up (see the module docstring).

    A leg to a terrain-frame item (``set_destination(..., terrain=True)``) is flown in the
    frame above the ground, as AC_WPNav does with ``terrain_alt``: the legs' z are heights
    above the ground (the origin turned into one on entering that frame), and the vehicle
    flies at the leg's height plus :class:`TerrainOffset`, which follows ``ground(x, y)``
    under it. How far the offset lags the ground slows the legs' progress
    (:func:`terrain_pace`, approached within WPNAV_ACCEL, ``advance_wp_target_along_track``'s
    ``vel_scaler_dt``)."""

    def __init__(
        self,
        start: Vec,
        limits: GuidanceLimits,
        speed_xy: float,
        wind: tuple[float, float],
        ground: Callable[[float, float], float] | None = None,
    ) -> None:
        self.limits = limits
        self.wind = wind
        self.speed_xy = speed_xy
        self.origin = start
        self.dest = start
        self.prev: ScurveLeg | None = None
        self.this: ScurveLeg | None = None
        self.next: ScurveLeg | None = None
        self.next_started = False
        self.fast = False
        self.reached = True
        self.pos = start
        self.vel = (0.0, 0.0, 0.0)
        self.ground = ground if ground is not None else (lambda x, y: 0.0)
        self.terrain = False  # the legs are in the frame above the ground
        self.offset = TerrainOffset(limits)
        self.pace = 1.0  # the share of the legs' speed flown (terrain_pace, shaped)

    def lag_m(self) -> float:
        """How far the vehicle is above (+) or below the ground-following target."""
        if not self.terrain:
            return self.offset.z
        return self.offset.z - self.ground(self.pos[0], self.pos[1])

    def _in_frame(self, pos: Vec) -> Vec:
        """The vehicle's position in the legs' frame."""
        if not self.terrain:
            return pos
        return (pos[0], pos[1], pos[2] - self.ground(pos[0], pos[1]))

    def set_destination(self, dest: Vec, next_dest: Vec | None, *, terrain: bool = False) -> None:
        """Fly to ``dest``; with ``next_dest`` it is a fast waypoint (the corner is blended).
        ``terrain``: ``dest`` and ``next_dest`` are heights above the ground (the next one
        is in the same frame: the caller drops a next waypoint of the other frame, as
        AC_WPNav::set_wp_destination_next does)."""
        if terrain != self.terrain:
            # AC_WPNav::set_wp_destination: the origin (the last destination) and the
            # offset change frame by the ground under the vehicle; no leg carries over
            g = self.ground(self.pos[0], self.pos[1])
            shift = -g if terrain else g
            self.dest = (self.dest[0], self.dest[1], self.dest[2] + shift)
            self.offset.z -= shift
            self.terrain = terrain
            self.this = self.next = self.prev = None
            self.fast = False
        if self.this is not None and self.fast and self.next is not None and self.next.dest == dest:
            new_this = self.next
        else:
            new_this = ScurveLeg(self.dest, dest, self.limits, self.speed_xy, self.wind)
        self.prev = self.this if self.this is not None and not self.this.finished else None
        self.origin = self.dest
        self.this = new_this
        self.dest = dest
        self.next = (
            ScurveLeg(dest, next_dest, self.limits, self.speed_xy, self.wind)
            if next_dest is not None
            else None
        )
        self.next_started = False
        self.fast = next_dest is not None
        self.reached = False

    def set_speed(self, speed_xy: float) -> None:
        self.speed_xy = speed_xy
        if self.this is not None and not self.this.finished:
            self.this.set_speed(speed_xy)
        if self.next is not None and not self.next_started:
            self.next = ScurveLeg(
                self.next.origin, self.next.dest, self.limits, speed_xy, self.wind
            )

    @property
    def stuck(self) -> bool:
        return self.this is not None and self.this.stuck

    def _blend_ok(self, this: ScurveLeg, nxt: ScurveLeg) -> bool:
        """``SCurve::advance_target_along_track``'s test for starting the next leg now."""
        remaining = this.remaining
        mid_this = this.t + remaining / 2.0
        mid_next = remaining / 2.0
        turn_pos = add(this.to_dest(mid_this), nxt.from_origin(mid_next))
        turn_vel = add(this.velocity(mid_this), nxt.velocity(mid_next))
        turn_acc = add(this.acceleration(mid_this), nxt.acceleration(mid_next))
        lim = self.limits
        return (
            norm(turn_pos) < lim.acceptance_radius_m
            and norm(turn_vel) < min(this.vmax, nxt.vmax)
            and math.hypot(turn_acc[0], turn_acc[1]) < lim.accel_corner_m_s2
            and abs(turn_acc[2]) < min(lim.accel_up_m_s2, lim.accel_down_m_s2) + 1e-9
        )

    def step(self, dt: float) -> None:
        this = self.this
        if this is None:
            return
        follow = self.terrain or self.offset.active or self.pace != 1.0
        pace = 1.0
        if follow:
            # advance_wp_target_along_track: the pace from the lag before this step, then
            # the offset shaped toward the ground under the vehicle (off terrain: to zero)
            target = self.ground(self.pos[0], self.pos[1]) if self.terrain else 0.0
            wanted = terrain_pace(self.offset.z - target, self.limits.terrain_margin_m)
            rate = self.limits.accel_xy_m_s2 / max(self.speed_xy, 1e-9) * dt
            self.pace = max(self.pace - rate, min(self.pace + rate, wanted))
            if not self.terrain and self.pace > 1.0 - 1e-12:
                self.pace = 1.0
            self.offset.step(target, dt)
            pace = self.pace
            dt = dt * pace
        prev = self.prev
        if prev is not None:
            prev.advance(dt)
        this.advance(dt)
        finished = this.finished
        nxt = self.next
        if self.fast and nxt is not None:
            if not self.next_started:
                if (
                    this.t >= this.profile.decel_start
                    and this.remaining <= nxt.profile.accel_end
                    and self._blend_ok(this, nxt)
                ):
                    # the next leg starts now and moves from the next step on, in step with
                    # this one's remaining time: the blend is symmetric about its midpoint,
                    # which _blend_ok kept within the radius
                    self.next_started = True
            else:
                nxt.advance(dt)
                if nxt.t >= this.remaining:
                    finished = True  # past the middle of the turn
        pos = add(self.origin, this.from_origin())
        vel = this.velocity()
        if prev is not None:
            pos = add(pos, prev.to_dest())
            vel = add(vel, prev.velocity())
            if prev.finished:
                self.prev = None
        if self.next_started and nxt is not None:
            pos = add(pos, nxt.from_origin())
            vel = add(vel, nxt.velocity())
        if follow:
            vel = scale(vel, pace)
            pos = (pos[0], pos[1], pos[2] + self.offset.z)
            vel = (vel[0], vel[1], vel[2] + self.offset.v)
        self.pos, self.vel = pos, vel
        if not self.reached and finished:
            if (
                self.fast
                or norm(sub(self._in_frame(pos), self.dest)) <= self.limits.acceptance_radius_m
            ):
                self.reached = True
