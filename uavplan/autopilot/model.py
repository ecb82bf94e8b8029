"""The flight model: a kinematic multirotor flying a mission as PX4 or ArduPilot Copter does.

:class:`FlightModel` is a deterministic, fixed-step (``dt``, simulated seconds) model of a
multirotor that tracks its guidance perfectly: position and velocity are the guidance's
trajectory, limited by the flavour's speeds and accelerations (:mod:`.params`). It has no
I/O and no clock of its own; :meth:`FlightModel.step` advances it by ``dt``. The same model
flies the simulated vehicle (:mod:`uavplan.sim.vehicle`) and
:func:`uavplan.autopilot.simulate.simulate`, so a flight against the vehicle and a
simulation take the same time.

Two guidance laws, one per flavour (:mod:`.ardupilot`, :mod:`.px4`; this module runs the
mission, take-off, landing and RTL around them):

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
half of WPNAV_TER_MARGIN slows the vehicle along the track (``ardupilot.ScurveTrack``,
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
from dataclasses import dataclass

from uavplan.autopilot.ardupilot import ScurveTrack
from uavplan.autopilot.kinematics import (
    Vec,
    dist_xy,
)
from uavplan.autopilot.motion import TOUCHDOWN_M, Brake, Descend, Hold, Motion
from uavplan.autopilot.nav import NavItem
from uavplan.autopilot.params import Parameters, guidance_limits
from uavplan.autopilot.px4 import SmoothingTrack
from uavplan.autopilot.rtl import return_altitude_m
from uavplan.flavour import Autopilot
from uavplan.mission.items import MavCmd

__all__ = [
    "DEFAULT_DT_S",
    "AirState",
    "EventKind",
    "FlightEvent",
    "FlightModel",
]

#: the model's fixed step (simulated seconds)
DEFAULT_DT_S = 0.1
_DO_JUMP = int(MavCmd.DO_JUMP)
_DO_CHANGE_SPEED = int(MavCmd.DO_CHANGE_SPEED)
_NAV_LOITER_TIME = 19
_NAV_LOITER_UNLIM = int(MavCmd.NAV_LOITER_UNLIM)
_DO_LAND_START = int(MavCmd.DO_LAND_START)


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


class AirState(enum.StrEnum):
    """Where the modelled vehicle is (EXTENDED_SYS_STATE's landed state, which the simulated
    vehicle reports from it)."""

    GROUND = "ground"
    #: climbing off the ground
    TAKEOFF = "takeoff"
    #: descending to land
    LANDING = "landing"
    AIR = "air"


@dataclass(frozen=True)
class FlightEvent:
    kind: EventKind
    t_s: float
    seq: int | None = None


#: a task of the model: advanced one model step per ``next()``
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
        self.limits = guidance_limits(params)
        self.wind: tuple[float, float] = (we, wn)
        self.dt_s = float(dt_s)
        self._ground = ground_z
        self.t_s = 0.0
        self.landed = True
        self._motion: Motion = Hold(start)
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
    def phase(self) -> AirState:
        """Where the vehicle is: on the ground, taking off, landing or in the air."""
        if self.landed:
            return AirState.GROUND
        if isinstance(self._motion, Descend):
            return AirState.LANDING
        if self._taking_off:
            return AirState.TAKEOFF
        return AirState.AIR

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
        self.limits = guidance_limits(params)
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
        self._motion = Hold(self._motion.pos)

    def set_speed(self, speed_xy_m_s: float) -> None:
        """DO_CHANGE_SPEED: the horizontal speed of the legs flown from now on."""
        speed = max(0.2, min(float(speed_xy_m_s), self.limits.speed_xy_max_m_s))
        self._speed_xy = speed
        motion = self._motion
        if isinstance(motion, ScurveTrack | SmoothingTrack):
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
            and self._motion.pos[2] - self.ground_at(0.0, 0.0) > ceiling + TOUCHDOWN_M
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

    def _run(self, motion: Motion, until: Callable[[], bool] | None = None) -> Task:
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
        if isinstance(motion, Hold):
            return
        yield from self._run(Brake(motion.pos, motion.vel, self.limits))
        self._motion = Hold(self._motion.pos)

    def _set_current(self, seq: int) -> None:
        if self.current_seq != seq:
            self.current_seq = seq
            self._emit(EventKind.CURRENT, seq)

    # -- guidance helpers -----------------------------------------------------------------
    def _ap_track(self) -> Generator[None, None, ScurveTrack]:
        motion = self._motion
        if isinstance(motion, ScurveTrack):
            return motion
        yield from self._brake()
        track = ScurveTrack(
            self._motion.pos, self.limits, self._speed_xy, self.wind, self.ground_at
        )
        self._motion = track
        return track

    def _px4_track(self) -> SmoothingTrack:
        motion = self._motion
        if isinstance(motion, SmoothingTrack):
            motion.climb_speed_at = None
            return motion
        track = SmoothingTrack(motion.pos, motion.vel, self.limits, self._speed_xy, self.wind)
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
        motion = Descend(
            self._motion.pos,
            self._motion.vel,
            self.ground_at(x, y),
            self._land_speed,
            self.limits,
            (x, y),
        )
        yield from self._run(motion)
        self._motion = Hold(motion.pos)
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
            assert item.altitude_m is not None
            altitude = self.ground_at(here[0], here[1]) + item.altitude_m
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
                    max(item.position[2], here[2] + self.limits.takeoff_min_altitude_m),
                    takeoff=True,
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
