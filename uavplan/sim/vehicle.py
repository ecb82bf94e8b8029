"""The simulated vehicle: PX4 or ArduPilot Copter as a sans-I/O state machine.

:class:`SimVehicle` is what a ground station talks to: messages and the time go in
(:meth:`SimVehicle.receive`, :meth:`SimVehicle.tick`), the messages it sends come out. It does
no I/O and reads no clock; :class:`uavplan.sim.mock.MockVehicle` is the thin loop that drives
it over a real MAVLink endpoint. Inside:

- the mission, geofence and rally points and their protocol (:class:`.mission_server.
  MissionServer`);
- the flight model (:class:`uavplan.autopilot.model.FlightModel`) flying the stored mission
  in simulated time, ``speedup`` times faster than the link's clock;
- modes and arming as the firmware has them (:mod:`uavplan.mavlink.modes`; each flavour's
  rules in :mod:`.px4` and :mod:`.ardupilot`): PX4's MISSION_START arms and starts, PX4
  refuses Mission mode and MISSION_START without a valid mission, ArduPilot refuses to arm
  in AUTO and refuses AUTO from the ground without a take-off, ArduPilot's MISSION_START
  wants param1 = param2 = 0 (the firmware's STATUSTEXT and COMMAND_ACK results, cited where
  each is made);
- telemetry as the firmware streams it (HEARTBEAT, SYS_STATUS, GLOBAL_POSITION_INT,
  MISSION_CURRENT, MISSION_ITEM_REACHED, HOME_POSITION, EXTENDED_SYS_STATE, BATTERY_STATUS,
  STATUSTEXT), with SET_MESSAGE_INTERVAL, REQUEST_MESSAGE and ArduPilot's
  REQUEST_DATA_STREAM honoured;
- the parameters the flight model flies by (:mod:`uavplan.autopilot.params`):
  PARAM_REQUEST_LIST / PARAM_REQUEST_READ / PARAM_SET / PARAM_VALUE, unknown names refused
  as each firmware does;
- a battery drained by :func:`uavplan.autopilot.power.power_w`;
- one fault model (:class:`.faults.Faults`): packet faults, protocol misbehaviour, a link
  lost in flight.

Stream intervals are simulated seconds (as in SITL: at ``speedup`` 20 a 5 Hz position
stream arrives at 100 Hz); protocol timers (re-requests, transfer timeouts) run on the
link's clock, since the ground station's timers do. Simulated time runs at ``speedup`` times
the link's clock while the vehicle keeps up; when it looks late (a starved thread on a loaded
machine) it advances at most :data:`MAX_CATCH_UP_S` at a time, so the simulation slows down as
SITL's does under load instead of sending the missed telemetry in one burst that a ground
station's socket buffer would drop.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from struct import error as struct_error

from uavplan.autopilot.model import DEFAULT_DT_S, AirState, EventKind, FlightEvent, FlightModel
from uavplan.autopilot.nav import nav_items
from uavplan.autopilot.params import Parameters, ParamSpec, UnknownParameter
from uavplan.autopilot.power import X500, Battery, PowerState, VehicleSpec
from uavplan.geo import GeoPoint
from uavplan.mavlink.messages import (
    SYS_STATUS_PREARM_CHECK,
    AutopilotVersion,
    BatteryStatus,
    Capability,
    CommandAck,
    CommandInt,
    CommandLong,
    ExtendedSysState,
    GlobalPositionInt,
    Heartbeat,
    HomePosition,
    LandedState,
    MalformedMessage,
    MavAutopilotId,
    MavCommand,
    MavModeFlag,
    MavResult,
    MavState,
    MavType,
    Message,
    MessageId,
    MissionCurrent,
    MissionItemReached,
    MissionSetCurrent,
    MissionState,
    ParamRequestList,
    ParamRequestRead,
    ParamSet,
    ParamValue,
    Received,
    RequestDataStream,
    SetMode,
    Severity,
    StatusText,
    SysStatus,
    message_name,
)
from uavplan.mavlink.modes import (
    FlightMode,
    ModeKind,
    mode_named,
)
from uavplan.mission.items import Autopilot, MissionItem, MissionType, deg_to_e7
from uavplan.sim.faults import FaultInjector, Faults
from uavplan.sim.mission_server import MISSION_MESSAGES, MissionServer

__all__ = ["DEFAULT_HOME", "SimConfig", "SimVehicle"]

#: where the vehicle stands when nothing says otherwise: PX4 SITL's default home
DEFAULT_HOME = GeoPoint(47.397742, 8.545594, 488.0)
#: the most simulated time one look at the clock advances (s): a vehicle that looked late
#: slows down rather than catching up in a burst (25 positions at 5 Hz at most)
MAX_CATCH_UP_S = 5.0
#: PX4 disarms this long after landing (commander COM_DISARM_LAND, 2 s)
PX4_DISARM_AFTER_LANDING_S = 2.0
#: MAV_CMD_COMPONENT_ARM_DISARM param2 that forces arming / disarming
FORCE_MAGIC = 21196.0
#: SYS_STATUS sensors: 3D gyro, accel, mag, absolute pressure, GPS, battery, and the pre-arm
#: checks (both firmwares report them as a sensor: QGroundControl's "Ready To Fly")
_SENSORS = 0x1 | 0x2 | 0x4 | 0x8 | 0x20 | 0x2000000 | SYS_STATUS_PREARM_CHECK
#: ArduPilot repeats a failing pre-arm check's message this often while disarmed
#: (libraries/AP_Arming/AP_Arming.cpp, PREARM_DISPLAY_PERIOD)
ARDUPILOT_PREARM_DISPLAY_S = 30.0
_UINT16_MAX = 65535
_INT16_MAX = 32767

#: default stream intervals (simulated seconds); HEARTBEAT's is the config's
_STREAMS: dict[int, float] = {
    MessageId.SYS_STATUS: 1.0,
    MessageId.GLOBAL_POSITION_INT: 0.2,
    MessageId.MISSION_CURRENT: 1.0,
    MessageId.BATTERY_STATUS: 1.0,
    MessageId.EXTENDED_SYS_STATE: 1.0,
    MessageId.HOME_POSITION: 2.0,
}


@dataclass(frozen=True)
class SimConfig:
    """How the simulated vehicle is set up.

    ``home``: where it stands, and for ArduPilot what a download returns as mission seq 0
    (:data:`DEFAULT_HOME` stands in for ``None``, and downloads then return the seq 0 that
    was uploaded). ``params``: changes to the flavour's parameter defaults by name.
    ``speedup``: simulated time runs this many times faster than the link's clock.
    ``wind_en_m_s``: wind (east, north) m/s. ``telemetry``: stream the telemetry messages
    (HEARTBEAT is ``send_heartbeats``).
    """

    autopilot: Autopilot = Autopilot.PX4
    system_id: int = 1
    component_id: int = 1
    heartbeat_period_s: float = 1.0
    send_heartbeats: bool = True
    home: GeoPoint | None = None
    firmware_timing: bool = False
    #: AUTOPILOT_VERSION.capabilities to report; None: MISSION_FLOAT/INT, COMMAND_INT,
    #: MAVLINK2, MISSION_FENCE, MISSION_RALLY and the flavour's parameter encoding
    capabilities: int | None = None
    faults: Faults = field(default_factory=Faults)
    params: Mapping[str, float] = field(default_factory=dict)
    speedup: float = 1.0
    wind_en_m_s: tuple[float, float] = (0.0, 0.0)
    vehicle: VehicleSpec = X500
    telemetry: bool = True
    dt_s: float = DEFAULT_DT_S

    def __post_init__(self) -> None:
        if self.autopilot not in (Autopilot.PX4, Autopilot.ARDUPILOT):
            raise ValueError("the simulated vehicle is px4 or ardupilot")
        if not self.heartbeat_period_s > 0:
            raise ValueError("heartbeat_period_s must be positive")
        if not (math.isfinite(self.speedup) and 0.0 < self.speedup <= 1000.0):
            raise ValueError(f"speedup must be within (0, 1000], got {self.speedup!r}")
        if len(self.wind_en_m_s) != 2 or not all(math.isfinite(v) for v in self.wind_en_m_s):
            raise ValueError("wind must be two finite numbers (east, north m/s)")
        Parameters(self.autopilot, dict(self.params))  # unknown names / bad values raise

    @property
    def standing_at(self) -> GeoPoint:
        return self.home if self.home is not None else DEFAULT_HOME


@dataclass
class _Stream:
    interval_s: float | None  # None: off
    next_due_s: float


def whole_number(value: float) -> int | None:
    """A command param that must hold a whole number, or ``None`` (NaN, inf, 2.5)."""
    if not math.isfinite(value) or value != math.floor(value) or abs(value) > 2**31:
        return None
    return int(value)


def _text(severity: Severity, text: str) -> StatusText:
    return StatusText(int(severity), text)


class SimVehicle:
    """A simulated PX4 or ArduPilot Copter vehicle, sans-I/O (see the module docstring).

    ``now`` (seconds, any monotonic origin) is the link's clock; every call passes it.
    This class holds what both flavours share; where the firmwares differ (modes, arming,
    MISSION_START, parameter encoding, telemetry fields) the flavour's subclass says how:
    :class:`uavplan.sim.px4.Px4Vehicle`, :class:`uavplan.sim.ardupilot.ArduPilotVehicle`.
    Make one with :func:`new_vehicle` (``uavplan.sim.vehicles``), which picks the subclass
    for ``config.autopilot``.
    """

    #: the first mission seq a start flies (ArduPilot's seq 0 is home)
    FIRST_SEQ = 0
    #: COMMAND_ACK results: a disarm in the air without the force value, and an
    #: arm / disarm command whose param1 is neither 0 nor 1
    DISARM_IN_AIR_REFUSED = MavResult.FAILED
    BAD_ARM_PARAM = MavResult.DENIED
    #: the prefix of a failing pre-arm check's STATUSTEXT
    PREARM_PREFIX = ""
    #: whether a failing pre-arm check is repeated while disarmed
    REPEATS_PREARM = False
    #: component ids besides the configured one that the firmware answers as itself
    ALSO_ANSWERS: frozenset[int] = frozenset()
    #: HEARTBEAT.autopilot, AUTOPILOT_VERSION's parameter encoding and software version
    MAV_AUTOPILOT = MavAutopilotId.GENERIC
    PARAM_ENCODING = Capability.PARAM_ENCODE_C_CAST
    FLIGHT_SW_VERSION = 0

    def __init__(self, config: SimConfig | None = None, now: float = 0.0) -> None:
        c = config or SimConfig()
        self.config = c
        self.autopilot = c.autopilot
        self.params = Parameters(c.autopilot, dict(c.params))
        self.home = c.standing_at
        self.server = MissionServer(
            c.autopilot,
            system_id=c.system_id,
            component_id=c.component_id,
            home=c.home,
            firmware_timing=c.firmware_timing,
            faults=c.faults,
        )
        self.faults = c.faults
        self._injector = FaultInjector(c.faults)
        self.flight = FlightModel(self.params, wind_en_m_s=c.wind_en_m_s, dt_s=c.dt_s)
        self.battery = Battery(c.vehicle)
        self.armed = False
        self.mode: FlightMode = self._initial_mode()
        self.mission_state = MissionState.NOT_STARTED
        self.link_lost = False
        self.sim_time_s = 0.0
        self._last_now = now
        self._armed_at_s: float | None = None
        #: (armed at, disarmed at or None while armed) in simulated seconds, oldest first
        self.armed_periods: list[tuple[float, float | None]] = []
        #: everything the flight model reported (item reached, take-off, landed ...), in order
        self.flight_events: list[FlightEvent] = []
        self._disarm_at_s: float | None = None
        self._loaded_version = -1
        self._mission_active = False
        #: ArduPilot Copter's ap.auto_armed: an armed copter on the ground in AUTO waits
        #: for it (a raised throttle, or MISSION_START) before it takes off
        self._auto_armed = False
        self._heading_cdeg = 0
        self._geodetic: tuple[tuple[float, float], tuple[float, float]] | None = None
        self._streams: dict[int, _Stream] = {}
        self._reset_streams()
        #: messages whose handling failed (hostile or broken input), and the last reason
        self.rejected_messages = 0
        self.last_rejection: str | None = None
        #: every STATUSTEXT sent, for tests and the I/O loop's log
        self.texts: list[StatusText] = []
        self._next_prearm_display_s = 0.0

    # -- inspection -----------------------------------------------------------------------
    @property
    def busy(self) -> bool:
        return self.server.busy

    def wire_items(self, mission_type: MissionType) -> list:
        return self.server.wire_items(mission_type)

    def items(self, mission_type: MissionType) -> list[MissionItem]:
        return self.server.items(mission_type)

    def preload(self, mission_type: MissionType, items: list[MissionItem]) -> None:
        self.server.preload(mission_type, items)

    def set_faults(self, faults: Faults) -> None:
        """Change the fault model while running (the packet generators keep their state)."""
        self.faults = faults
        self._injector.faults = faults
        self.server.faults = faults

    @property
    def injector(self) -> FaultInjector:
        return self._injector

    @property
    def landed_state(self) -> LandedState:
        return {
            AirState.GROUND: LandedState.ON_GROUND,
            AirState.TAKEOFF: LandedState.TAKEOFF,
            AirState.LANDING: LandedState.LANDING,
            AirState.AIR: LandedState.IN_AIR,
        }[self.flight.phase]

    def position(self) -> tuple[float, float, float, float]:
        """(lat deg, lon deg, altitude AMSL m, altitude above home m) of the vehicle."""
        x, y, z = self.flight.position
        lat, lon = self._latlon(x, y)
        return lat, lon, self.home.alt_m + z, z

    # -- the sans-I/O interface -----------------------------------------------------------
    def receive(self, received: Received, now: float) -> list[Message]:
        """One message from the link at ``now``; the messages to send."""
        out = self._advance(now)
        if self.link_lost:
            return []
        for _ in range(self._injector.inbound_copies(received.message)):
            out.extend(self._handle_safely(received))
        return self._injector.outbound(out)

    def tick(self, now: float, *, link_idle: bool = False) -> list[Message]:
        """Time passes: flight, telemetry, protocol timers; the messages to send.
        ``link_idle``: nothing arrived lately, so a held-back packet may go out."""
        out = self._advance(now)
        if self.link_lost:
            return []
        out.extend(self.server.timers(now))
        out.extend(self._due_streams(self.sim_time_s))
        out.extend(self._prearm_display())
        wire = self._injector.outbound(out)
        if link_idle:
            wire.extend(self._injector.flush())
        return wire

    def next_wakeup(self, now: float) -> float:
        """The link time by which :meth:`tick` has something to do."""
        due = min((s.next_due_s for s in self._streams.values() if s.interval_s), default=math.inf)
        if self.flight.busy or self.armed:
            due = min(due, self.flight.t_s + self.flight.dt_s)
        wake = now + max(0.0, due - self.sim_time_s) / self.config.speedup
        return min(wake, self.server.next_timer(now))

    # -- time -----------------------------------------------------------------------------
    def _advance(self, now: float) -> list[Message]:
        elapsed = max(0.0, now - self._last_now)
        self._last_now = now
        # a vehicle that looked late (its thread starved on a loaded machine) slows its clock
        # rather than catching up in one burst: at speedup 100 a 1 s stall would put 500
        # positions on the wire at once, more than a ground station's UDP buffer holds
        self.sim_time_s += min(elapsed * self.config.speedup, MAX_CATCH_UP_S)
        out: list[Message] = []
        flight = self.flight
        while flight.t_s + flight.dt_s <= self.sim_time_s + 1e-9:
            events = flight.step()
            self.flight_events.extend(events)
            self.battery.drain(self._power_state(), flight.dt_s)
            out.extend(self._on_flight_events(events))
            # telemetry is sampled when it falls due, not when the link next looks
            out.extend(self._due_streams(flight.t_s))
            if self._disarm_at_s is not None and flight.t_s >= self._disarm_at_s:
                self._disarm_at_s = None
                self._disarm()
            lost_after = self.faults.link_lost_after_s
            if (
                lost_after is not None
                and self._armed_at_s is not None
                and flight.t_s - self._armed_at_s >= lost_after
            ):
                self.link_lost = True
        return out

    def _on_flight_events(self, events: list[FlightEvent]) -> list[Message]:
        out: list[Message] = []
        for event in events:
            if event.kind is EventKind.CURRENT and event.seq is not None:
                self.server.current_seq = event.seq
                out.append(self._mission_current())
            elif event.kind is EventKind.REACHED and event.seq is not None:
                out.append(MissionItemReached(event.seq))
            elif event.kind is EventKind.MISSION_COMPLETE:
                self.mission_state = MissionState.COMPLETE
                self._mission_active = False
                self._on_mission_done()
                out.append(self._mission_current())
            elif event.kind is EventKind.RTL:
                self.mode = mode_named(self.autopilot, ModeKind.RETURN)
            elif event.kind is EventKind.LANDED:
                self._on_landed()
            elif event.kind is EventKind.NO_HEADWAY:
                out.append(self._say(Severity.WARNING, "Wind: cannot hold the track"))
            elif event.kind is EventKind.FENCE_BREACH:
                ceiling = self.flight.limits.fence_ceiling_m
                out.append(
                    self._say(Severity.CRITICAL, f"Fence: above the ceiling ({ceiling:g} m)")
                )
        return out

    # -- dispatch -------------------------------------------------------------------------
    def _handle_safely(self, received: Received) -> list[Message]:
        """One message; anything it could break is caught here so the vehicle keeps serving
        (a hostile packet costs that packet only, never the stored plans)."""
        try:
            return self._handle(received)
        except (ArithmeticError, ValueError, TypeError, struct_error) as err:
            self.rejected_messages += 1
            self.last_rejection = f"{message_name(received.message)}: {err}"
            return []

    def _addressed_to_us(self, message: Message) -> bool:
        target_system = getattr(message, "target_system", None)
        if target_system is None:
            return True
        if target_system not in (0, self.config.system_id):
            return False
        target_component = getattr(message, "target_component", 0)
        return target_component in {0, self.config.component_id, *self.ALSO_ANSWERS}

    def _handle(self, received: Received) -> list[Message]:
        message = received.message
        partner = (received.system_id, received.component_id)
        if isinstance(message, Heartbeat):
            if message.type == MavType.GCS and self.config.send_heartbeats:
                # answer a ground station's heartbeat at once instead of at the next tick, so
                # connecting takes a round trip (only a GCS's: two vehicles must not echo)
                return [self._heartbeat()]
            return []
        if isinstance(message, MalformedMessage):
            out = self.server.handle(partner, message, self._last_now)
            self.rejected_messages = self.server.rejected_messages
            self.last_rejection = self.server.last_rejection
            return out
        if isinstance(message, StatusText) or not self._addressed_to_us(message):
            return []
        if isinstance(message, CommandLong | CommandInt):
            return self._on_command(partner, message)
        if isinstance(message, SetMode):
            return self._on_set_mode_message(partner, message)
        if isinstance(message, ParamRequestList | ParamRequestRead | ParamSet):
            return self._on_param(message)
        if isinstance(message, RequestDataStream):
            return self._on_data_stream(message)
        if isinstance(message, MISSION_MESSAGES):
            out = self.server.handle(partner, message, self._last_now)
            if self.server.current_changed:
                self.server.current_changed = False
                out.append(self._mission_current())
                if isinstance(message, MissionSetCurrent):
                    self._jump_to_current()
            return out
        return []

    # -- commands -------------------------------------------------------------------------
    def _on_command(self, partner: tuple[int, int], cmd: CommandLong | CommandInt) -> list[Message]:
        out: list[Message] = []

        def ack(result: MavResult) -> list[Message]:
            # a refusal's STATUSTEXT goes out while the command runs, before its ACK (as
            # ArduPilot's check_failed and PX4's mavlink_log_critical send it)
            texts = [m for m in out if isinstance(m, StatusText)]
            rest = [m for m in out if not isinstance(m, StatusText)]
            return [*texts, CommandAck(cmd.command, int(result), partner[0], partner[1]), *rest]

        command = cmd.command
        if command == MavCommand.REQUEST_MESSAGE:
            wanted = whole_number(cmd.param1)
            if wanted is None:
                return ack(MavResult.DENIED)  # NaN / inf / fractional: names no message
            message = self._requested(wanted)
            if message is None:
                return ack(MavResult.UNSUPPORTED)
            return [*ack(MavResult.ACCEPTED), message]
        if command == MavCommand.REQUEST_AUTOPILOT_CAPABILITIES:
            return [*ack(MavResult.ACCEPTED), self._autopilot_version()]
        if command == MavCommand.GET_HOME_POSITION:
            return [*ack(MavResult.ACCEPTED), self._home_position()]
        if command == MavCommand.SET_MESSAGE_INTERVAL:
            return ack(self._set_interval(cmd.param1, cmd.param2))
        if command == MavCommand.DO_SET_MISSION_CURRENT:
            return ack(self._do_set_mission_current(cmd.param1, out))
        if command == MavCommand.COMPONENT_ARM_DISARM:
            return ack(self._arm_disarm(cmd.param1, cmd.param2, out))
        if command == MavCommand.RUN_PREARM_CHECKS:
            # ArduPilot GCS_Common.cpp handle_command_run_prearm_checks, PX4 Commander
            # VEHICLE_CMD_RUN_PREARM_CHECKS: run the checks and report what fails
            if self.armed:
                return ack(MavResult.TEMPORARILY_REJECTED)
            out.extend(self._prearm_report())
            return ack(MavResult.ACCEPTED)
        if command == MavCommand.DO_SET_MODE:
            return ack(self._do_set_mode(cmd.param1, cmd.param2, cmd.param3, out))
        if command == MavCommand.MISSION_START:
            return ack(self._mission_start(cmd.param1, cmd.param2, out))
        if command == MavCommand.NAV_RETURN_TO_LAUNCH:
            return ack(self._set_mode(mode_named(self.autopilot, ModeKind.RETURN), out))
        if command == MavCommand.NAV_LAND:
            return ack(self._set_mode(mode_named(self.autopilot, ModeKind.LAND), out))
        if command == MavCommand.NAV_TAKEOFF:
            return ack(self._takeoff_command(cmd, out))
        if command == MavCommand.DO_CHANGE_SPEED:
            if not (math.isfinite(cmd.param2) and cmd.param2 > 0):
                return ack(MavResult.DENIED)
            self.flight.set_speed(cmd.param2)
            return ack(MavResult.ACCEPTED)
        return ack(MavResult.UNSUPPORTED)

    def _requested(self, message_id: int) -> Message | None:
        makers: dict[int, Callable[[], Message]] = {
            MessageId.AUTOPILOT_VERSION: self._autopilot_version,
            MessageId.HEARTBEAT: self._heartbeat,
            MessageId.HOME_POSITION: self._home_position,
            MessageId.GLOBAL_POSITION_INT: self._global_position,
            MessageId.SYS_STATUS: self._sys_status,
            MessageId.BATTERY_STATUS: self._battery_status,
            MessageId.EXTENDED_SYS_STATE: self._extended_sys_state,
            MessageId.MISSION_CURRENT: self._mission_current,
        }
        maker = makers.get(message_id)
        return None if maker is None else maker()

    def _set_interval(self, message_id: float, interval_us: float) -> MavResult:
        wanted = whole_number(message_id)
        if wanted is None or not math.isfinite(interval_us):
            return MavResult.DENIED
        if wanted not in self._streams:
            return MavResult.FAILED  # a message this vehicle does not stream
        stream = self._streams[wanted]
        if interval_us < 0:
            stream.interval_s = None
        elif interval_us == 0:
            stream.interval_s = self._default_interval(wanted)
        else:
            stream.interval_s = interval_us / 1e6
        stream.next_due_s = self.sim_time_s
        return MavResult.ACCEPTED

    def _do_set_mission_current(self, param1: float, out: list[Message]) -> MavResult:
        seq = whole_number(param1)
        if seq is None:
            return MavResult.DENIED
        count = len(self.server.wire_items(MissionType.MISSION))
        if seq == -1 or 0 <= seq < count:
            if seq >= 0:
                self.server.current_seq = seq
                self._jump_to_current()
            out.append(self._mission_current())
            return MavResult.ACCEPTED
        return MavResult.FAILED

    def _jump_to_current(self) -> None:
        """A new current item while the mission flies: go there (both firmwares do)."""
        if self._mission_active and self.armed:
            self._load_mission()
            self.flight.start_mission(self.server.current_seq)

    # -- modes and arming -----------------------------------------------------------------
    def _say(self, severity: Severity, text: str) -> StatusText:
        message = _text(severity, text)
        self.texts.append(message)
        return message

    def _arm_disarm(self, param1: float, param2: float, out: list[Message]) -> MavResult:
        forced = param2 == FORCE_MAGIC
        if param1 == 1.0:
            if self.armed:
                return MavResult.ACCEPTED
            return self._arm(out, forced=forced)
        if param1 == 0.0:
            if not self.armed:
                return MavResult.ACCEPTED
            if not self.flight.landed and not forced:
                # both refuse to disarm in the air without the force value
                return self.DISARM_IN_AIR_REFUSED
            self._disarm()
            return MavResult.ACCEPTED
        return self.BAD_ARM_PARAM

    def _prearm_display(self) -> list[Message]:
        """ArduPilot repeats a failing pre-arm check every PREARM_DISPLAY_PERIOD while
        disarmed (AP_Arming::update); PX4 reports it when asked or when arming."""
        if (
            self.faults.prearm_failure is None
            or self.armed
            or not self.REPEATS_PREARM
            or self.sim_time_s < self._next_prearm_display_s
        ):
            return []
        self._next_prearm_display_s = self.sim_time_s + ARDUPILOT_PREARM_DISPLAY_S
        return self._prearm_report()

    def _prearm_report(self) -> list[Message]:
        """The failing pre-arm check's STATUSTEXT in the firmware's words (ArduPilot's
        AP_Arming::check_failed prefixes "PreArm: ", PX4's health checks "Preflight Fail: "),
        or nothing when the checks pass."""
        reason = self.faults.prearm_failure
        if reason is None:
            return []
        return [self._say(Severity.CRITICAL, self.PREARM_PREFIX + reason)]

    def _arm(self, out: list[Message], *, forced: bool = False) -> MavResult:
        refused = self._arm_refused(out, forced=forced)
        if refused is not None:
            return refused
        self.armed = True
        self._armed_at_s = self.flight.t_s
        self.armed_periods.append((self.flight.t_s, None))
        self._after_arming()
        return MavResult.ACCEPTED

    def _after_arming(self) -> None:
        """What arming in the current mode starts."""
        kind = self.mode.kind
        if kind is ModeKind.MISSION:
            self._start_mission()
        elif kind is ModeKind.TAKEOFF:
            self.flight.takeoff(self.flight.limits.takeoff_min_altitude_m)

    def _disarm(self) -> None:
        self.armed = False
        self._auto_armed = False  # Copter::update_auto_armed: disarmed clears it
        if self.armed_periods and self.armed_periods[-1][1] is None:
            self.armed_periods[-1] = (self.armed_periods[-1][0], self.flight.t_s)
        self._armed_at_s = None
        self._disarm_at_s = None
        self._mission_active = False
        if self.flight.landed:
            self.flight.stop()

    def _load_mission(self) -> None:
        if self._loaded_version != self.server.mission_version:
            items = self.server.items(MissionType.MISSION)
            self.flight.set_mission(nav_items(items, self.home))
            self._loaded_version = self.server.mission_version

    def _start_mission(self) -> None:
        """Fly the stored mission from the current item (resume), or from the start."""
        self._load_mission()
        first = self.FIRST_SEQ
        current = self.server.current_seq
        complete = self.mission_state is MissionState.COMPLETE
        start = first if (complete or current < first) else current
        self.flight.start_mission(start)
        self.mission_state = MissionState.ACTIVE
        self._mission_active = True

    def _set_mode(self, mode: FlightMode | None, out: list[Message]) -> MavResult:
        """Enter ``mode`` as the firmware does; the COMMAND_ACK result."""
        if mode is None:
            return MavResult.FAILED
        return self._switch_to(mode, out)

    def _enter(self, mode: FlightMode) -> None:
        """Switch to ``mode`` (accepted) and make the flight follow."""
        previous = self.mode
        self.mode = mode
        kind = mode.kind
        if kind is not ModeKind.MISSION and self._mission_active:
            self._mission_active = False
            if self.mission_state is MissionState.ACTIVE:
                self.mission_state = MissionState.PAUSED
        if not self.armed:
            return
        if kind is ModeKind.MISSION:
            if self._waits_for_mission_start():
                return
            if previous.kind is not ModeKind.MISSION or not self._mission_active:
                self._start_mission()
        elif kind is ModeKind.RETURN:
            self.flight.rtl()
        elif kind is ModeKind.LAND:
            self.flight.land()
        elif kind is ModeKind.TAKEOFF:
            self.flight.takeoff(self.flight.limits.takeoff_min_altitude_m)
        elif not self.flight.landed:
            self.flight.hold()  # Hold / LOITER / a manual mode without a pilot: hold

    # -- parameters -----------------------------------------------------------------------
    def _param_value(self, spec: ParamSpec) -> ParamValue:
        value = self.params[spec.name]
        wire = self._param_to_wire(spec, value)
        return ParamValue(
            spec.name,
            wire,
            int(spec.type),
            len(self.params.specs),
            self.params.index_of(spec.name),
        )

    def _on_param(self, message: ParamRequestList | ParamRequestRead | ParamSet) -> list[Message]:
        specs = self.params.specs
        if isinstance(message, ParamRequestList):
            return [self._param_value(spec) for spec in specs]
        if isinstance(message, ParamRequestRead):
            if message.param_index >= 0:
                if message.param_index < len(specs):
                    return [self._param_value(specs[message.param_index])]
                return self._unknown_param_index(message.param_index)
            try:
                return [self._param_value(self.params.spec(message.param_id))]
            except UnknownParameter:
                return []  # both firmwares stay silent for an unknown name
        try:
            spec = self.params.spec(message.param_id)
        except UnknownParameter:
            return self._unknown_param_set(message.param_id)
        value = self._param_from_wire(spec, message.param_value)
        if not math.isfinite(value):
            return []  # ArduPilot ignores NaN / inf; PX4's reply would repeat garbage
        if spec.name in self.faults.refuse_param_set:
            # a parameter the vehicle will not write (read-only): ArduPilot's GCS_Param.cpp
            # handle_param_set says so and sends the value it keeps; PX4 (our model) only
            # sends the value it keeps
            return [*self._param_write_denied(spec), self._param_value(spec)]
        self.params = self.params.with_values({spec.name: value}, checked=False)
        self.flight.set_params(self.params)
        return [self._param_value(spec)]

    # -- telemetry ------------------------------------------------------------------------
    def _default_interval(self, message_id: int) -> float | None:
        if message_id == MessageId.HEARTBEAT:
            return self.config.heartbeat_period_s if self.config.send_heartbeats else None
        if not self.config.telemetry:
            return None
        return _STREAMS.get(message_id)

    def _reset_streams(self) -> None:
        self._streams = {
            MessageId.HEARTBEAT: _Stream(self._default_interval(MessageId.HEARTBEAT), 0.0)
        }
        for offset, message_id in enumerate(_STREAMS):
            first = 0.5 if message_id == MessageId.MISSION_CURRENT else 0.05 * (offset + 1)
            self._streams[message_id] = _Stream(self._default_interval(message_id), first)

    def _due_streams(self, now: float) -> list[Message]:
        out: list[Message] = []
        for message_id, stream in self._streams.items():
            if stream.interval_s is None or stream.next_due_s > now + 1e-9:
                continue
            message = self._requested(message_id)
            if message is not None:
                out.append(message)
            stream.next_due_s += stream.interval_s
            if stream.next_due_s <= now:
                stream.next_due_s = now + stream.interval_s
        return out

    def _heartbeat(self) -> Heartbeat:
        kind = self.mode.kind
        base = MavModeFlag.CUSTOM_MODE_ENABLED
        if self.armed:
            base |= MavModeFlag.SAFETY_ARMED
        if kind in (
            ModeKind.MISSION,
            ModeKind.HOLD,
            ModeKind.RETURN,
            ModeKind.LAND,
            ModeKind.TAKEOFF,
        ):
            base |= (
                MavModeFlag.AUTO_ENABLED
                | MavModeFlag.GUIDED_ENABLED
                | MavModeFlag.STABILIZE_ENABLED
            )
        elif kind in (ModeKind.GUIDED, ModeKind.OFFBOARD):
            base |= MavModeFlag.GUIDED_ENABLED | MavModeFlag.STABILIZE_ENABLED
        else:
            base |= MavModeFlag.MANUAL_INPUT_ENABLED | MavModeFlag.STABILIZE_ENABLED
        return Heartbeat(
            type=MavType.QUADROTOR,
            autopilot=self.MAV_AUTOPILOT,
            base_mode=int(base),
            custom_mode=self.mode.custom_mode,
            system_status=int(MavState.ACTIVE if self.armed else MavState.STANDBY),
        )

    def _autopilot_version(self) -> AutopilotVersion:
        caps = self.config.capabilities
        if caps is None:
            encoding = self.PARAM_ENCODING
            caps = (
                Capability.MISSION_FLOAT
                | Capability.MISSION_INT
                | Capability.COMMAND_INT
                | Capability.MAVLINK2
                | Capability.MISSION_FENCE
                | Capability.MISSION_RALLY
                | encoding
            )
        return AutopilotVersion(
            capabilities=int(caps),
            flight_sw_version=self.FLIGHT_SW_VERSION,
            vendor_id=0x1209,
            product_id=0x5740,
            uid=0x55A0_0000 + self.config.system_id,
        )

    def _mission_current(self) -> MissionCurrent:
        count = len(self.server.wire_items(MissionType.MISSION))
        total = self._mission_total(count)
        state = self.mission_state if count else MissionState.NO_MISSION
        if self._mission_active:
            mission_mode = 1
        elif state in (MissionState.PAUSED, MissionState.COMPLETE):
            mission_mode = 2
        else:
            mission_mode = 0
        return MissionCurrent(self.server.current_seq, total, int(state), mission_mode)

    def _latlon(self, x: float, y: float) -> tuple[float, float]:
        if x == 0.0 and y == 0.0:
            return self.home.lat_deg, self.home.lon_deg
        cached = self._geodetic
        if cached is not None and cached[0] == (x, y):
            return cached[1]
        import numpy as np

        from uavplan.geo import EnuFrame

        lat, lon, _ = EnuFrame.at(self.home).to_geodetic(np.array([x, y, 0.0]))
        result = (float(lat[0]), float(lon[0]))
        self._geodetic = ((x, y), result)
        return result

    def _global_position(self) -> GlobalPositionInt:
        lat, lon, alt, rel = self.position()
        vx, vy, vz = self.flight.velocity
        if math.hypot(vx, vy) > 0.5:
            self._heading_cdeg = round(math.degrees(math.atan2(vx, vy)) % 360.0 * 100.0) % 36000
        return GlobalPositionInt(
            # the flight model's time: a sample taken while catching up keeps its own time
            time_boot_ms=int(round(self.flight.t_s * 1000.0)) & 0xFFFFFFFF,
            lat=deg_to_e7(lat),
            lon=deg_to_e7(lon),
            alt=round(alt * 1000.0),
            relative_alt=round(rel * 1000.0),
            vx=round(vy * 100.0),  # NED north
            vy=round(vx * 100.0),  # east
            vz=round(-vz * 100.0),  # down
            hdg=self._heading_cdeg,
        )

    def _home_position(self) -> HomePosition:
        return HomePosition(
            deg_to_e7(self.home.lat_deg),
            deg_to_e7(self.home.lon_deg),
            round(self.home.alt_m * 1000.0),
        )

    def _extended_sys_state(self) -> ExtendedSysState:
        return ExtendedSysState(vtol_state=0, landed_state=int(self.landed_state))

    def _power_state(self) -> PowerState:
        """What the battery is drained by now: the velocity through the wind, the altitude."""
        vx, vy, vz = self.flight.velocity
        we, wn = self.config.wind_en_m_s
        return PowerState(
            self.armed,
            not self.flight.landed,
            math.hypot(vx, vy),
            vz,
            airspeed_m_s=math.hypot(vx - we, vy - wn),
            altitude_amsl_m=self.home.alt_m + self.flight.position[2],
        )

    def _sys_status(self) -> SysStatus:
        battery = self.battery
        return SysStatus(
            onboard_control_sensors_present=_SENSORS,
            onboard_control_sensors_enabled=_SENSORS,
            onboard_control_sensors_health=self._health(),
            load=200,
            voltage_battery=round(battery.voltage_v * 1000.0),
            current_battery=round(battery.current_a * 100.0),
            battery_remaining=round(battery.remaining_fraction * 100.0),
        )

    def _health(self) -> int:
        """SYS_STATUS health: every sensor healthy; the pre-arm check bit clear while a
        pre-arm check fails on the ground (it is "always healthy when armed")."""
        if self.faults.prearm_failure is not None and not self.armed:
            return _SENSORS & ~SYS_STATUS_PREARM_CHECK
        return _SENSORS

    def _battery_status(self) -> BatteryStatus:
        battery = self.battery
        cells = battery.spec.cells
        cell_mv = round(battery.cell_voltage_v * 1000.0)
        voltages = tuple([cell_mv] * min(cells, 10) + [_UINT16_MAX] * (10 - min(cells, 10)))
        remaining = battery.time_remaining_s(self._power_state())
        return BatteryStatus(
            id=0,
            battery_function=1,  # MAV_BATTERY_FUNCTION_ALL
            type=1,  # MAV_BATTERY_TYPE_LIPO
            temperature=_INT16_MAX,  # unknown
            voltages=voltages,
            current_battery=round(battery.current_a * 100.0),
            current_consumed=round(battery.used_mah),
            energy_consumed=round(battery.used_wh * 36.0),  # hJ
            battery_remaining=round(battery.remaining_fraction * 100.0),
            time_remaining=0 if remaining is None else int(remaining),
            charge_state=1,  # MAV_BATTERY_CHARGE_STATE_OK
        )

    # -- what each flavour says (uavplan.sim.px4, uavplan.sim.ardupilot) -------------------
    def _initial_mode(self) -> FlightMode:
        """The mode the vehicle boots in."""
        raise NotImplementedError

    def _on_mission_done(self) -> None:
        """The mission's last item is done."""
        raise NotImplementedError

    def _on_landed(self) -> None:
        """The flight model touched down."""
        raise NotImplementedError

    def _mission_valid(self) -> bool:
        """Whether the stored mission can be started."""
        raise NotImplementedError

    def _arm_refused(self, out: list[Message], *, forced: bool) -> MavResult | None:
        """The firmware's refusal to arm now (its STATUSTEXT into ``out``), or None."""
        raise NotImplementedError

    def _switch_to(self, mode: FlightMode, out: list[Message]) -> MavResult:
        """Enter ``mode`` if the firmware allows it now; the COMMAND_ACK result."""
        raise NotImplementedError

    def _waits_for_mission_start(self) -> bool:
        """Whether the mission mode, armed, waits for MISSION_START before it flies."""
        return False

    def _do_set_mode(
        self, base_mode: float, custom: float, sub: float, out: list[Message]
    ) -> MavResult:
        """MAV_CMD_DO_SET_MODE's params as the firmware reads them."""
        raise NotImplementedError

    @staticmethod
    def _custom_mode(base_mode: float, custom: float) -> int | None:
        """MAV_CMD_DO_SET_MODE's custom main mode, or None: param 1 does not enable custom
        modes, or a param is not a whole number."""
        base = whole_number(base_mode)
        main = whole_number(custom)
        if base is None or main is None or not (base & MavModeFlag.CUSTOM_MODE_ENABLED):
            return None
        return main

    def _on_set_mode_message(self, partner: tuple[int, int], msg: SetMode) -> list[Message]:
        """The SET_MODE message and its acknowledgement."""
        raise NotImplementedError

    def _mission_start(self, first: float, last: float, out: list[Message]) -> MavResult:
        """MAV_CMD_MISSION_START."""
        raise NotImplementedError

    def _takeoff_command(self, cmd: CommandLong | CommandInt, out: list[Message]) -> MavResult:
        """MAV_CMD_NAV_TAKEOFF sent as a command."""
        raise NotImplementedError

    def _param_to_wire(self, spec: ParamSpec, value: float) -> float:
        """A parameter's value as PARAM_VALUE carries it."""
        return float(value)

    def _param_from_wire(self, spec: ParamSpec, wire: float) -> float:
        """PARAM_SET's value as the parameter's."""
        return float(wire)

    def _unknown_param_index(self, index: int) -> list[Message]:
        """The answer to PARAM_REQUEST_READ of an index the table does not have."""
        return []

    def _unknown_param_set(self, name: str) -> list[Message]:
        """The answer to PARAM_SET of a name the table does not have."""
        return []

    def _param_write_denied(self, spec: ParamSpec) -> list[Message]:
        """What the firmware says of a parameter it will not write (before its value)."""
        return []

    def _on_data_stream(self, msg: RequestDataStream) -> list[Message]:
        """REQUEST_DATA_STREAM (PX4 ignores it)."""
        return []

    def _mission_total(self, count: int) -> int:
        """MISSION_CURRENT.total for ``count`` stored wire items."""
        raise NotImplementedError
