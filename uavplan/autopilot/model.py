"""The flight model: a kinematic multirotor flying a mission as PX4 or ArduPilot Copter does.

:class:`FlightModel` is a deterministic, fixed-step (``dt``, simulated seconds) model of a
multirotor that tracks its guidance perfectly: position and velocity are the guidance's
trajectory, limited by the flavour's speeds and accelerations (:mod:`.params`). It has no
I/O and no clock of its own; :meth:`FlightModel.step` advances it by ``dt``. The same model
flies the simulated vehicle (:mod:`.vehicle`) and :func:`uavplan.autopilot.simulate.simulate`, so a
flight against the vehicle and a simulation take the same time.

Two guidance laws, one per flavour:

- **ArduPilot Copter** (AC_WPNav with S-curves, ``SCurve::advance_target_along_track``): each
  leg is a speed profile along the straight line from waypoint to waypoint, from rest to
  rest; at a waypoint followed by another one (a "fast" waypoint) the next leg's profile is
  started while this one still brakes, and the two are *added*: that superposition is the
  corner. The next leg starts once this one is braking, its remaining time fits within the
  next leg's acceleration, and the blend's midpoint passes within WPNAV_RADIUS of the
  waypoint (slower than either leg's top speed, under the cornering acceleration). The
  waypoint counts as reached at the blend's midpoint.
- **PX4** (FlightTaskAuto + PositionSmoothing): the velocity setpoint points at the current
  waypoint (at an L1 point on the leg while turning onto it), its horizontal size limited
  so the vehicle can still reach the corner speed at the waypoint,
  ``sqrt(MPC_XY_TRAJ_P·MPC_ACC_HOR·r·tan(α/2))`` for acceptance radius ``r`` and leg angle
  ``α``, through PX4's braking distance with the jerk delay (TrajMath.hpp); the vehicle
  follows the setpoint within MPC_ACC_HOR / MPC_ACC_UP_MAX / MPC_ACC_DOWN_MAX. The waypoint
  counts as reached within its acceptance radius (param 2, else NAV_ACC_RAD) and
  NAV_MC_ALT_RAD of altitude, and the next one takes over from there.

On a leg to a terrain-frame item ArduPilot flies above the ground (AC_WPNav with
``terrain_alt``): the leg runs in heights above the ground, a vertical offset shaped within
the climb and descent limits takes up the ground under the vehicle, and a lag of more than
half of WPNAV_TER_MARGIN slows the vehicle along the track (``_ScurveTrack``,
docs/flight-model.md "Terrain-frame legs"). PX4 flies such an item at the ground under it
plus its height, on a straight leg.

Both climb and descend at their own rates, take off vertically, land with the flavour's
landing speeds, fly RTL as the firmware does (:meth:`FlightModel.rtl`), honour
DO_CHANGE_SPEED, hold times and DO_JUMP, and keep their commanded speed through the air:
wind (east, north m/s) changes the ground speed along each leg (the wind triangle).

Mission items come in as :class:`NavItem` (ENU positions in the frame at home, see
:func:`nav_items`), numbered as on the wire (ArduPilot's seq 0 is home and is never flown).
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable, Generator, Sequence
from dataclasses import dataclass, replace

from uavplan.autopilot.kinematics import (
    Profile,
    SCurve,
    Vec,
    add,
    dist_xy,
    ground_speed_limit,
    kinematic_limit,
    max_speed_from_distance,
    max_speed_in_waypoint,
    norm,
    scale,
    sqrt_controller,
    sub,
    unit,
)
from uavplan.autopilot.params import FlightLimits, Parameters, flight_limits
from uavplan.autopilot.rtl import return_altitude_m
from uavplan.config import Autopilot
from uavplan.geo import GeoPoint
from uavplan.mission.items import MavCmd, MavFrame, MissionItem, canonical_frame

__all__ = [
    "DEFAULT_DT_S",
    "EventKind",
    "FlightEvent",
    "FlightModel",
    "NavItem",
    "nav_items",
]

#: the model's fixed step (simulated seconds)
DEFAULT_DT_S = 0.1
#: PX4 takes off to at least MIS_TAKEOFF_ALT when a mission starts on the ground with a
#: waypoint (navigator/mission_params: 2.5 m)
PX4_MIS_TAKEOFF_ALT_M = 2.5
#: speeds below this count as standing still
_STILL_M_S = 0.01
_TOUCHDOWN_M = 0.01

#: MAV_CMD values below this are NAV commands
_FIRST_DO_COMMAND = 80
_DO_JUMP = int(MavCmd.DO_JUMP)
_DO_CHANGE_SPEED = int(MavCmd.DO_CHANGE_SPEED)
_NAV_LOITER_TIME = 19
_NAV_LOITER_UNLIM = int(MavCmd.NAV_LOITER_UNLIM)
_DO_LAND_START = int(MavCmd.DO_LAND_START)


# ---------------------------------------------------------------------------------------------
# Mission items for the model


@dataclass(frozen=True)
class NavItem:
    """A mission item as the model flies it: ``seq`` as on the wire, position in ENU metres
    in the frame at home (``None`` for items without one, or at lat/lon 0: "here").

    ``terrain_m``: for an item in a terrain frame, its height above the ground (its
    ``position`` z is that height over the ground beneath it); ArduPilot follows the ground
    on the leg to it. ``None`` for the other frames."""

    seq: int
    command: int
    position: Vec | None = None
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    terrain_m: float | None = None

    @property
    def is_nav(self) -> bool:
        return self.command < _FIRST_DO_COMMAND

    @property
    def is_position(self) -> bool:
        return self.is_nav and self.position is not None


def nav_items(
    items: Sequence[MissionItem],
    home: GeoPoint,
    *,
    ground_z: Callable[[float, float], float] | None = None,
) -> tuple[NavItem, ...]:
    """Wire-ordered mission items (ArduPilot's home at seq 0 included) → :class:`NavItem`.

    Positions go into the ENU frame at ``home`` exactly as the mission builder made them
    (:mod:`uavplan.mission.builder`): x/y where the ellipsoid normal through lat/lon meets
    the ground plane, z the altitude above home (relative frames), AMSL minus home's
    altitude (frame 0), or above the ground (terrain frames: ``ground_z(x, y)``, the
    ground's height above home; flat ground without it). Vectorised: one conversion for all
    items.
    """
    from uavplan.geo import EnuFrame

    frame = EnuFrame.at(home)
    located = [
        i
        for i, item in enumerate(items)
        if item.is_global and item.command < _FIRST_DO_COMMAND and (item.x, item.y) != (0.0, 0.0)
    ]
    where: dict[int, tuple[float, float]] = {}
    if located:
        xy = frame.to_enu_xy([items[i].x for i in located], [items[i].y for i in located])
        where = {index: (float(xy[k][0]), float(xy[k][1])) for k, index in enumerate(located)}
    out: list[NavItem] = []
    for seq, item in enumerate(items):
        position: Vec | None = None
        terrain_m: float | None = None
        if seq in where:
            x, y = where[seq]
            frame_id = canonical_frame(item.frame)
            if frame_id == MavFrame.GLOBAL:
                z = item.z - home.alt_m
            elif frame_id == MavFrame.GLOBAL_TERRAIN_ALT:
                terrain_m = float(item.z)
                z = item.z if ground_z is None else item.z + ground_z(x, y)
            else:
                z = item.z
            position = (x, y, z)
        elif item.is_global and item.command < _FIRST_DO_COMMAND:
            # lat/lon 0: "where the vehicle is"; keep the altitude in the z slot of a marker
            position = None
        out.append(
            NavItem(
                seq=seq,
                command=int(item.command),
                position=position,
                param1=item.param1 or 0.0,
                param2=item.param2 or 0.0,
                param3=item.param3 or 0.0,
                param4=item.param4 or 0.0,
                terrain_m=terrain_m,
            )
        )
        if position is None and item.is_global and item.command == MavCmd.NAV_TAKEOFF:
            # a take-off at lat/lon 0 still carries its altitude
            out[-1] = replace(out[-1], position=(math.nan, math.nan, float(item.z)))
    return tuple(out)


# ---------------------------------------------------------------------------------------------
# Events


class EventKind(enum.Enum):
    CURRENT = "current"  # a new current mission item
    REACHED = "reached"  # a mission item done
    TAKEOFF = "takeoff"  # left the ground
    LANDED = "landed"  # touched down
    MISSION_COMPLETE = "mission_complete"  # no more items
    RTL = "rtl"  # a return to launch began (PX4 switches to its RTL mode)
    NO_HEADWAY = "no_headway"  # the wind stops the vehicle: it cannot hold the track
    FENCE_BREACH = "fence_breach"  # above the enabled altitude fence's ceiling


@dataclass(frozen=True)
class FlightEvent:
    kind: EventKind
    t_s: float
    seq: int | None = None


# ---------------------------------------------------------------------------------------------
# Motions: what moves the vehicle for one step


class _Motion:
    """Moves ``pos``/``vel`` by one step. ``done`` when it has finished."""

    pos: Vec
    vel: Vec
    done: bool = False

    def step(self, dt: float) -> None:
        raise NotImplementedError


class _Hold(_Motion):
    def __init__(self, pos: Vec) -> None:
        self.pos = pos
        self.vel = (0.0, 0.0, 0.0)

    def step(self, dt: float) -> None:
        pass


class _Brake(_Motion):
    """Slow to a stop at the flavour's accelerations (the stopping point both firmwares
    compute before a new task)."""

    def __init__(self, pos: Vec, vel: Vec, limits: FlightLimits) -> None:
        self.pos, self.vel = pos, vel
        self.limits = limits
        self.done = norm(vel) < _STILL_M_S

    def step(self, dt: float) -> None:
        vx, vy, vz = self.vel
        h = math.hypot(vx, vy)
        dv = self.limits.accel_xy_m_s2 * dt
        k = max(0.0, h - dv) / h if h > 0.0 else 0.0
        az = self.limits.accel_up_m_s2 if vz < 0 else self.limits.accel_down_m_s2
        nz = math.copysign(max(0.0, abs(vz) - az * dt), vz)
        self.vel = (vx * k, vy * k, nz)
        self.pos = add(self.pos, scale(self.vel, dt))
        self.done = norm(self.vel) < _STILL_M_S
        if self.done:
            self.vel = (0.0, 0.0, 0.0)


class _Descend(_Motion):
    """A landing: descend at the flavour's landing speeds to the ground, drifting onto
    ``target_xy`` (the landing point) within the horizontal limits."""

    def __init__(
        self,
        pos: Vec,
        vel: Vec,
        ground: float,
        speed_at: Callable[[float], float],
        limits: FlightLimits,
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
        if z <= self.ground + _TOUCHDOWN_M:
            z = self.ground
            self.vel = (0.0, 0.0, 0.0)
            self.done = True
        self.pos = (x, y, z)


class _Leg:
    """One straight leg of ArduPilot's waypoint navigation: a speed profile along the line
    from ``origin`` to ``dest`` at the leg's kinematic limits (ground speed through the
    wind), from rest to rest."""

    def __init__(
        self,
        origin: Vec,
        dest: Vec,
        limits: FlightLimits,
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


class _TerrainOffset:
    """AC_PosControl's vertical position offset (``update_pos_offset_z``): on a terrain-frame
    leg it takes up the ground under the vehicle, as ``shape_pos_vel_accel`` does, through
    a square-root controller (gain ½·PSC_JERK_Z / WPNAV_ACCEL_Z, half of WPNAV_ACCEL_Z),
    within the climb and descent speeds and WPNAV_ACCEL_Z (the jerk's ramp left out, as
    elsewhere in the model). Off terrain it brings itself back to zero. ``z`` is added to
    the leg's altitude: the vehicle is where the leg puts it, ``z`` higher."""

    def __init__(self, limits: FlightLimits) -> None:
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


class _ScurveTrack(_Motion):
    """ArduPilot Copter's waypoint navigation (AC_WPNav, S-curves), kinematically: the
    previous, current and next legs whose motions add up (see the module docstring).

    A leg to a terrain-frame item (``set_destination(..., terrain=True)``) is flown in the
    frame above the ground, as AC_WPNav does with ``terrain_alt``: the legs' z are heights
    above the ground (the origin turned into one on entering that frame), and the vehicle
    flies at the leg's height plus :class:`_TerrainOffset`, which follows ``ground(x, y)``
    under it. How far the offset lags the ground slows the legs' progress
    (:func:`terrain_pace`, approached within WPNAV_ACCEL, ``advance_wp_target_along_track``'s
    ``vel_scaler_dt``)."""

    def __init__(
        self,
        start: Vec,
        limits: FlightLimits,
        speed_xy: float,
        wind: tuple[float, float],
        ground: Callable[[float, float], float] | None = None,
    ) -> None:
        self.limits = limits
        self.wind = wind
        self.speed_xy = speed_xy
        self.origin = start
        self.dest = start
        self.prev: _Leg | None = None
        self.this: _Leg | None = None
        self.next: _Leg | None = None
        self.next_started = False
        self.fast = False
        self.reached = True
        self.pos = start
        self.vel = (0.0, 0.0, 0.0)
        self.ground = ground if ground is not None else (lambda x, y: 0.0)
        self.terrain = False  # the legs are in the frame above the ground
        self.offset = _TerrainOffset(limits)
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
            new_this = _Leg(self.dest, dest, self.limits, self.speed_xy, self.wind)
        self.prev = self.this if self.this is not None and not self.this.finished else None
        self.origin = self.dest
        self.this = new_this
        self.dest = dest
        self.next = (
            _Leg(dest, next_dest, self.limits, self.speed_xy, self.wind)
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
            self.next = _Leg(self.next.origin, self.next.dest, self.limits, speed_xy, self.wind)

    @property
    def stuck(self) -> bool:
        return self.this is not None and self.this.stuck

    def _blend_ok(self, this: _Leg, nxt: _Leg) -> bool:
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


class _SmoothingTrack(_Motion):
    """PX4's auto-mode guidance (FlightTaskAuto + PositionSmoothing), kinematically: a
    velocity setpoint toward the waypoint, limited by the corner speed and the braking
    distance, followed within the acceleration limits."""

    def __init__(
        self, pos: Vec, vel: Vec, limits: FlightLimits, speed_xy: float, wind: tuple[float, float]
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


# ---------------------------------------------------------------------------------------------

Task = Generator[None, None, None]


class FlightModel:
    """A kinematic multirotor flying as ``params.autopilot`` does (see the module docstring).

    Commands: :meth:`start_mission`, :meth:`hold`, :meth:`rtl`, :meth:`land`,
    :meth:`set_speed`; :meth:`step` advances ``dt`` and returns the events of that step. The
    vehicle stands on the ground at home, ENU (0, 0, 0), until it takes off.
    """

    def __init__(
        self,
        params: Parameters,
        *,
        wind_en_m_s: tuple[float, float] = (0.0, 0.0),
        dt_s: float = DEFAULT_DT_S,
        ground_z: Callable[[float, float], float] | None = None,
        start: Vec = (0.0, 0.0, 0.0),
    ) -> None:
        if not (dt_s > 0.0 and math.isfinite(dt_s)):
            raise ValueError(f"dt_s must be positive, got {dt_s!r}")
        we, wn = (float(v) for v in wind_en_m_s)
        if not (math.isfinite(we) and math.isfinite(wn)):
            raise ValueError("wind must be finite")
        self.autopilot = params.autopilot
        self.params = params
        self.limits = flight_limits(params)
        self.wind: tuple[float, float] = (we, wn)
        self.dt_s = float(dt_s)
        self._ground = ground_z
        self.t_s = 0.0
        self.landed = True
        self._motion: _Motion = _Hold(start)
        self._task: Task | None = None
        self.mission: tuple[NavItem, ...] = ()
        self.current_seq: int | None = None
        self.mission_complete = False
        self._speed_xy = self.limits.speed_xy_m_s
        self._events: list[FlightEvent] = []
        self._stuck_since: float | None = None
        self._taking_off = False
        #: the running task flies the mission (a return may continue it: PX4 RTL_TYPE 2)
        self._mission_task = False
        self._above_fence = False

    # -- state ----------------------------------------------------------------------------
    @property
    def position(self) -> Vec:
        return self._motion.pos

    @property
    def velocity(self) -> Vec:
        return self._motion.vel

    @property
    def stuck_for_s(self) -> float:
        """How long the wind has left the vehicle no ground speed along its track (0: not)."""
        return 0.0 if self._stuck_since is None else self.t_s - self._stuck_since

    @property
    def phase(self) -> str:
        """ "ground", "takeoff" (climbing off the ground), "landing" (descending to land) or
        "air" (EXTENDED_SYS_STATE's landed state)."""
        if self.landed:
            return "ground"
        if isinstance(self._motion, _Descend):
            return "landing"
        if self._taking_off:
            return "takeoff"
        return "air"

    @property
    def busy(self) -> bool:
        """A task (mission, return, landing, hold) is running."""
        return self._task is not None

    def ground_at(self, x: float, y: float) -> float:
        return 0.0 if self._ground is None else float(self._ground(x, y))

    def set_params(self, params: Parameters) -> None:
        """New parameter values, honoured from the next leg (a speed change at once)."""
        if params.autopilot != self.autopilot:
            raise ValueError("parameters of another autopilot")
        old = self.limits
        self.params = params
        self.limits = flight_limits(params)
        if self._speed_xy == old.speed_xy_m_s:
            self.set_speed(self.limits.speed_xy_m_s)

    # -- commands -------------------------------------------------------------------------
    def set_mission(self, items: Sequence[NavItem]) -> None:
        self.mission = tuple(items)
        self.mission_complete = False

    def start_mission(self, seq: int | None = None) -> None:
        """Fly the mission from ``seq`` (default: the first item; ArduPilot skips home)."""
        first = 1 if self.autopilot == Autopilot.ARDUPILOT else 0
        start = first if seq is None else max(first, seq)
        self.mission_complete = False
        self._set_task(self._fly_mission(start))
        self._mission_task = True

    def hold(self) -> None:
        """Stop where the vehicle can and hold there (PX4 Hold, ArduPilot LOITER)."""
        self._set_task(self._hold_task())

    def rtl(self) -> None:
        """Return to launch as the flavour does (PX4 with RTL_TYPE 2 during a mission that
        has a landing: the rest of the mission, see :meth:`_rtl_task`)."""
        resume = self.current_seq if self._mission_task and not self.mission_complete else None
        self._set_task(self._rtl_task(resume))

    def landing_sequence(self) -> int | None:
        """Where the mission's landing begins: its first DO_LAND_START, else (PX4, a
        multicopter) its first NAV_LAND; None without either."""
        for item in self.mission:
            if item.command == _DO_LAND_START:
                return item.seq
        if self.autopilot == Autopilot.PX4:
            for item in self.mission:
                if item.command == MavCmd.NAV_LAND:
                    return item.seq
        return None

    def land(self) -> None:
        """Land where the vehicle is."""
        self._set_task(self._land_task())

    def takeoff(self, altitude_m: float) -> None:
        """Climb vertically to ``altitude_m`` above the ground here, then hold."""
        self._set_task(self._takeoff_task(altitude_m))

    def stop(self) -> None:
        """Drop any task (disarmed on the ground)."""
        self._set_task(None)
        self._motion = _Hold(self._motion.pos)

    def set_speed(self, speed_xy_m_s: float) -> None:
        """DO_CHANGE_SPEED: the horizontal speed of the legs flown from now on."""
        speed = max(0.2, min(float(speed_xy_m_s), self.limits.speed_xy_max_m_s))
        self._speed_xy = speed
        motion = self._motion
        if isinstance(motion, _ScurveTrack | _SmoothingTrack):
            motion.set_speed(speed)

    def _set_task(self, task: Task | None) -> None:
        old, self._task = self._task, task
        self._mission_task = False
        if old is not None:
            old.close()  # its clean-up runs now, before the new task's first step

    # -- stepping -------------------------------------------------------------------------
    def step(self) -> list[FlightEvent]:
        """Advance one step of ``dt_s``; the events of that step."""
        self._events = []
        if self._task is not None:
            try:
                next(self._task)
            except StopIteration:
                self._task = None
        self.t_s += self.dt_s
        self._watch_headway()
        self._watch_fence()
        return self._events

    def _watch_fence(self) -> None:
        """A FENCE_BREACH event when the vehicle rises above the enabled altitude fence
        (once per excursion; the model reports it and flies on)."""
        ceiling = self.limits.fence_ceiling_m
        above = (
            ceiling is not None
            and self._motion.pos[2] - self.ground_at(0.0, 0.0) > ceiling + _TOUCHDOWN_M
        )
        if above and not self._above_fence:
            self._emit(EventKind.FENCE_BREACH, self.current_seq)
        self._above_fence = above

    def _emit(self, kind: EventKind, seq: int | None = None) -> None:
        self._events.append(FlightEvent(kind, self.t_s + self.dt_s, seq))

    def _watch_headway(self) -> None:
        motion = self._motion
        stuck = bool(getattr(motion, "stuck", False))
        if not stuck:
            self._stuck_since = None
        elif self._stuck_since is None:
            self._stuck_since = self.t_s
            self._emit(EventKind.NO_HEADWAY, self.current_seq)

    def _run(self, motion: _Motion, until: Callable[[], bool] | None = None) -> Task:
        """Step ``motion`` once per model step until it is done (or ``until()`` holds)."""
        self._motion = motion
        while True:
            if until is not None and until():
                return
            if until is None and motion.done:
                return
            motion.step(self.dt_s)
            yield

    def _wait(self, seconds: float) -> Task:
        """Keep the current motion going for ``seconds``."""
        steps = max(0, round(seconds / self.dt_s))
        motion = self._motion
        for _ in range(steps):
            motion.step(self.dt_s)
            yield

    def _forever(self) -> Task:
        motion = self._motion
        while True:
            motion.step(self.dt_s)
            yield

    def _brake(self) -> Task:
        motion = self._motion
        if isinstance(motion, _Hold):
            return
        yield from self._run(_Brake(motion.pos, motion.vel, self.limits))
        self._motion = _Hold(self._motion.pos)

    def _set_current(self, seq: int) -> None:
        if self.current_seq != seq:
            self.current_seq = seq
            self._emit(EventKind.CURRENT, seq)

    # -- guidance helpers -----------------------------------------------------------------
    def _ap_track(self) -> Generator[None, None, _ScurveTrack]:
        motion = self._motion
        if isinstance(motion, _ScurveTrack):
            return motion
        yield from self._brake()
        track = _ScurveTrack(
            self._motion.pos, self.limits, self._speed_xy, self.wind, self.ground_at
        )
        self._motion = track
        return track

    def _px4_track(self) -> _SmoothingTrack:
        motion = self._motion
        if isinstance(motion, _SmoothingTrack):
            motion.climb_speed_at = None
            return motion
        track = _SmoothingTrack(motion.pos, motion.vel, self.limits, self._speed_xy, self.wind)
        track.ground = self.ground_at(motion.pos[0], motion.pos[1])
        self._motion = track
        return track

    def _goto(
        self,
        dest: Vec,
        next_dest: Vec | None,
        acceptance_m: float | None = None,
        *,
        terrain: bool = False,
    ) -> Task:
        """Fly to ``dest`` (to the reached test); ``next_dest``: the corner to blend into.
        ``terrain`` (ArduPilot): both are heights above the ground, followed on the way."""
        if self.autopilot == Autopilot.ARDUPILOT:
            track = yield from self._ap_track()
            track.set_destination(dest, next_dest, terrain=terrain)
            yield from self._run(track, until=lambda: track.reached)
            return
        ptrack = self._px4_track()
        ptrack.set_target(dest, next_dest, acceptance_m or self.limits.acceptance_radius_m)
        yield from self._run(ptrack, until=lambda: ptrack.reached())

    def _climb_to(self, altitude: float, *, takeoff: bool = False) -> Task:
        """Climb (or descend) vertically to ``altitude`` where the vehicle is."""
        x, y, z = self._motion.pos
        if self.landed:
            self.landed = False
            self._emit(EventKind.TAKEOFF, self.current_seq)
        if abs(altitude - z) < 1e-3:
            return
        self._taking_off = takeoff
        try:
            yield from self._climb(x, y, altitude, takeoff)
        finally:
            self._taking_off = False

    def _climb(self, x: float, y: float, altitude: float, takeoff: bool) -> Task:
        if self.autopilot == Autopilot.ARDUPILOT:
            yield from self._goto((x, y, altitude), None)
            return
        track = self._px4_track()
        if takeoff:
            lim = self.limits
            ground = self.ground_at(x, y)
            track.ground = ground

            def climb(height: float) -> float:
                return (
                    lim.takeoff_speed_m_s if height < lim.takeoff_slow_below_m else lim.speed_up_m_s
                )

            track.climb_speed_at = climb
        track.set_target((x, y, altitude), None, self.limits.acceptance_radius_m)
        yield from self._run(track, until=lambda: track.reached(altitude_only=True))
        track.climb_speed_at = None

    def _land_speed(self, height: float) -> float:
        """The flavour's landing descent speed at ``height`` above the ground."""
        lim = self.limits
        if lim.is_px4:
            if height <= lim.land_final_below_m:
                return lim.land_speed_m_s
            if height >= lim.land_slow_below_m:
                return lim.land_speed_high_m_s
            span = lim.land_slow_below_m - lim.land_final_below_m
            k = (height - lim.land_final_below_m) / span if span > 0 else 1.0
            return lim.land_speed_m_s + k * (lim.land_speed_high_m_s - lim.land_speed_m_s)
        if height <= lim.land_slow_below_m:
            return lim.land_speed_m_s
        # ArduPilot: LAND_SPEED_HIGH until it must slow to reach LAND_SPEED at LAND_ALT_LOW
        brake = math.sqrt(
            lim.land_speed_m_s**2 + 2.0 * lim.accel_down_m_s2 * (height - lim.land_slow_below_m)
        )
        return max(lim.land_speed_m_s, min(lim.land_speed_high_m_s, brake))

    def _descend_and_land(self, at: tuple[float, float] | None = None) -> Task:
        """Land on the ground below the vehicle, or at ``at`` (x, y) it drifts onto."""
        yield from self._brake()
        x, y, _ = self._motion.pos
        if at is not None:
            x, y = at
        motion = _Descend(
            self._motion.pos,
            self._motion.vel,
            self.ground_at(x, y),
            self._land_speed,
            self.limits,
            (x, y),
        )
        yield from self._run(motion)
        self._motion = _Hold(motion.pos)
        self.landed = True
        self._emit(EventKind.LANDED, self.current_seq)

    # -- tasks ----------------------------------------------------------------------------
    def _hold_task(self) -> Task:
        yield from self._brake()
        yield from self._forever()

    def _takeoff_task(self, altitude_m: float) -> Task:
        x, y, z = self._motion.pos
        target = self.ground_at(x, y) + altitude_m
        if self.landed or target > z:
            yield from self._climb_to(max(target, z), takeoff=self.landed)
        yield from self._forever()

    def _land_task(self) -> Task:
        if self.landed:
            return
        yield from self._descend_and_land()

    def _rtl_task(self, resume_seq: int | None = None) -> Task:
        """The flavour's return; ``resume_seq``: the mission item being flown when the
        return began in a mission. PX4 with RTL_TYPE 2 and a mission landing then flies the
        rest of the mission to its landing (navigator's mission-path return, "fast-forward":
        here the items as they are, DO commands included)."""
        if self.landed:
            return
        if (
            self.autopilot == Autopilot.PX4
            and self.limits.rtl_type == 2
            and resume_seq is not None
            and self.landing_sequence() is not None
        ):
            self._mission_task = True
            yield from self._fly_mission(resume_seq)
            return
        if self.autopilot == Autopilot.ARDUPILOT:
            yield from self._rtl_ardupilot()
        else:
            yield from self._rtl_px4()

    def _rtl_ardupilot(self) -> Task:
        """ArduPilot Copter's RTL (mode_rtl.cpp): from the stopping point climb to the return
        altitude (RTL_ALT, at least the current altitude + RTL_CLIMB_MIN, lowered by the cone
        RTL_CONE_SLOPE near home), fly home at RTL_SPEED, hover RTL_LOIT_TIME, then land (or
        descend to RTL_ALT_FINAL and stay)."""
        lim = self.limits
        yield from self._brake()
        x, y, z = self._motion.pos
        target = float(return_altitude_m(lim, math.hypot(x, y), z))
        home_ground = self.ground_at(0.0, 0.0)
        saved = self._speed_xy
        yield from self._goto((x, y, target), None)
        self.set_speed(lim.rtl_speed_m_s)
        yield from self._goto((0.0, 0.0, target), None)
        self.set_speed(saved)
        yield from self._wait(lim.rtl_loiter_s)
        if lim.rtl_final_altitude_m > 0.0:
            yield from self._goto((0.0, 0.0, home_ground + lim.rtl_final_altitude_m), None)
            yield from self._forever()
        yield from self._descend_and_land(at=(0.0, 0.0))

    def _rtl_px4(self) -> Task:
        """PX4's return (navigator/rtl.cpp, RtlDirect): climb to the return altitude
        (RTL_RETURN_ALT, or the cone RTL_CONE_ANG within RTL_MIN_DIST of home, never below
        the current altitude), fly home, descend to RTL_DESCEND_ALT, wait RTL_LAND_DELAY
        (-1: stay), land."""
        lim = self.limits
        yield from self._brake()
        x, y, z = self._motion.pos
        home_z = self.ground_at(0.0, 0.0)
        ret = home_z + float(return_altitude_m(lim, math.hypot(x, y), z - home_z))
        if ret > z + lim.altitude_acceptance_m:
            yield from self._climb_to(ret)
        saved = self._speed_xy
        self.set_speed(lim.rtl_speed_m_s)
        yield from self._goto((0.0, 0.0, ret), None)
        self.set_speed(saved)
        descend_to = home_z + (lim.rtl_descend_altitude_m or 0.0)
        if ret > descend_to:
            track = self._px4_track()
            track.set_target((0.0, 0.0, descend_to), None, lim.acceptance_radius_m)
            yield from self._run(track, until=lambda: track.reached())
        if lim.rtl_loiter_s < 0.0:
            yield from self._forever()
        yield from self._wait(lim.rtl_loiter_s)
        yield from self._descend_and_land(at=(0.0, 0.0))

    def _leg_target(self, item: NavItem) -> tuple[Vec, bool]:
        """Where the guidance flies to for ``item``: its position, or (ArduPilot, an item in a
        terrain frame) its height above the ground, and whether it is that. PX4 does not
        fly terrain-frame items as such (its navigator takes the altitude as it is; plan
        warns): the item's position, the ground under it plus the height, as before."""
        assert item.position is not None
        if self.autopilot == Autopilot.ARDUPILOT and item.terrain_m is not None:
            x, y, _ = item.position
            return (x, y, item.terrain_m), True
        return item.position, False

    def _lookahead(self, seq: int) -> NavItem | None:
        """The next waypoint after the one at ``seq`` when the firmware blends the corner
        (ArduPilot: the next NAV command is a waypoint; PX4: the next position item), across
        DO commands; ``None`` when the vehicle stops at ``seq``."""
        items = self.mission
        item = items[seq]
        if item.param1 > 0.0:  # a hold time: stop there
            return None
        for later in items[seq + 1 :]:
            if not later.is_nav:
                if later.command == _DO_JUMP:
                    return None
                continue
            if self.autopilot == Autopilot.ARDUPILOT and later.command != MavCmd.NAV_WAYPOINT:
                return None
            if later.command in (MavCmd.NAV_WAYPOINT, _NAV_LOITER_TIME, _NAV_LOITER_UNLIM):
                return later if later.position is not None else None
            return None
        return None

    def _do_command(self, item: NavItem) -> None:
        if item.command != _DO_CHANGE_SPEED:
            return
        kind, speed = int(item.param1), item.param2
        if speed > 0.0:
            if self.autopilot == Autopilot.ARDUPILOT and kind in (2, 3):
                return  # climb / descent speed types: not modelled (docs/flight-model.md)
            self.set_speed(speed)
        elif speed == -2.0:
            self.set_speed(self.limits.speed_xy_m_s)

    def _fly_mission(self, seq: int) -> Task:
        items = self.mission
        jumps: dict[int, int] = {}
        ap = self.autopilot == Autopilot.ARDUPILOT
        done_dos: set[int] = set()
        while seq < len(items):
            item = items[seq]
            if item.command == _DO_JUMP:
                left = jumps.setdefault(seq, int(item.param2))
                target = int(item.param1)
                if left != 0 and 0 <= target < len(items):
                    if left > 0:
                        jumps[seq] = left - 1
                    seq = target
                    done_dos.clear()
                    continue
                seq += 1
                continue
            if not item.is_nav:
                if seq not in done_dos:
                    self._do_command(item)
                if not ap:
                    self._set_current(seq)
                seq += 1
                continue
            self._set_current(seq)
            if ap:  # ArduPilot runs the DO commands after a NAV command while it flies
                for later in items[seq + 1 :]:
                    if later.is_nav or later.command == _DO_JUMP:
                        break
                    self._do_command(later)
                    done_dos.add(later.seq)
            yield from self._fly_item(item)
            if self.landed and item.command in (MavCmd.NAV_LAND, MavCmd.NAV_RETURN_TO_LAUNCH):
                break  # on the ground, disarming: the mission is over
            seq += 1
        self.mission_complete = True
        self._emit(EventKind.MISSION_COMPLETE, self.current_seq)
        if not self.landed:
            yield from self._forever()

    def _fly_item(self, item: NavItem) -> Task:
        cmd = item.command
        here = self._motion.pos
        if cmd == MavCmd.NAV_TAKEOFF:
            assert item.position is not None
            altitude = self.ground_at(here[0], here[1]) + item.position[2]
            if not self.landed:
                altitude = max(altitude, here[2])
            yield from self._climb_to(altitude, takeoff=True)
            self._emit(EventKind.REACHED, item.seq)
            return
        if cmd == MavCmd.NAV_RETURN_TO_LAUNCH:
            if self.autopilot == Autopilot.PX4:
                # PX4 leaves the mission for its RTL mode at this item
                self._emit(EventKind.REACHED, item.seq)
                self._emit(EventKind.RTL, item.seq)
                yield from self._rtl_task()
                return
            yield from self._rtl_task()
            self._emit(EventKind.REACHED, item.seq)
            return
        if cmd == MavCmd.NAV_LAND:
            at = None
            if item.position is not None:
                at = (item.position[0], item.position[1])
                if dist_xy(here, item.position) > 0.1:
                    yield from self._goto((at[0], at[1], here[2]), None)
            yield from self._descend_and_land(at=at)
            self._emit(EventKind.REACHED, item.seq)
            return
        if item.position is None:
            self._emit(EventKind.REACHED, item.seq)  # a NAV command the model does not fly
            return
        if self.landed:
            if self.autopilot == Autopilot.PX4:
                yield from self._climb_to(
                    max(item.position[2], here[2] + PX4_MIS_TAKEOFF_ALT_M), takeoff=True
                )
            else:
                return  # ArduPilot refuses AUTO on the ground without a take-off first
        acceptance = item.param2 if (item.param2 > 0.0 and self.limits.is_px4) else None
        dest, terrain = self._leg_target(item)
        later = self._lookahead(item.seq)
        next_dest: Vec | None = None
        if later is not None:
            next_dest, next_terrain = self._leg_target(later)
            if next_terrain != terrain:
                next_dest = None  # AC_WPNav::set_wp_destination_next: frames must match
        yield from self._goto(dest, next_dest, acceptance, terrain=terrain)
        if cmd == _NAV_LOITER_UNLIM:
            yield from self._forever()
        hold_s = item.param1 if cmd in (MavCmd.NAV_WAYPOINT, _NAV_LOITER_TIME) else 0.0
        if hold_s > 0.0:
            yield from self._wait(hold_s)
        self._emit(EventKind.REACHED, item.seq)
