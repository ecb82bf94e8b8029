"""Flying a mission, ground side, as state machines that do no I/O.

Like :mod:`uavplan.mavlink.machines` (the mission protocol), each machine takes events and
returns the messages to send: ``start(now)``, ``on_message(message, now)`` for every message
from the vehicle, ``on_timeout(now)`` once ``now >= machine.deadline`` with nothing received.
It is done when :attr:`FlightMachine.finished` is set. ``now`` is any monotonic clock (the
driver, :class:`uavplan.mavlink.flightclient.FlightClient`, passes the wall clock; a test a
fake one). All of them share one :class:`VehicleState`: what the vehicle last said.

- :class:`PreflightMachine`: the vehicle's home (HOME_POSITION), its health and whether it
  can arm (SYS_STATUS's pre-arm check bit, MAV_CMD_RUN_PREARM_CHECKS and the firmware's
  pre-arm STATUSTEXT), armed or not, its mode and landed state;
- :class:`CommandSequence`: commands one after another, each acknowledged (COMMAND_ACK,
  re-sent with a growing ``confirmation`` as the MAVLink command protocol says) and then
  confirmed by what the vehicle reports (its HEARTBEAT's mode and armed bit), with the
  sequences QGroundControl and MAVSDK use to start a mission (:func:`start_steps`) and to
  change mode (:func:`mode_steps`);
- :class:`MonitorMachine`: the flight, sample by sample, until the mission is complete and
  the vehicle is down, or the link is lost.

A refusal ends a machine with the vehicle's own words: the COMMAND_ACK result by name and the
STATUSTEXT it sent while the command ran.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from uavplan.mavlink.messages import (
    SYS_STATUS_PREARM_CHECK,
    BatteryStatus,
    CommandAck,
    CommandLong,
    ExtendedSysState,
    GlobalPositionInt,
    Heartbeat,
    HomePosition,
    LandedState,
    MavCommand,
    MavModeFlag,
    MavResult,
    Message,
    MessageId,
    MissionCurrent,
    MissionItemReached,
    MissionState,
    StatusText,
    SysStatus,
)
from uavplan.mavlink.modes import FlightMode, ModeKind, mode_from_heartbeat, mode_named
from uavplan.mission.items import Autopilot

__all__ = [
    "CommandOutcome",
    "CommandSequence",
    "FlightMachine",
    "FlightTimeouts",
    "MonitorEnd",
    "MonitorMachine",
    "Preflight",
    "PreflightMachine",
    "Step",
    "TelemetrySample",
    "VehicleState",
    "disarm_step",
    "mode_steps",
    "start_steps",
]


@dataclass(frozen=True)
class FlightTimeouts:
    """How long the ground station waits (wall seconds).

    ``ack_s`` for a COMMAND_ACK before re-sending the command (MAVSDK's default command
    timeout is 0.5 s, QGroundControl's 3 s; 1.5 s sits between them, as the mission
    protocol's ack timeout), ``retries`` re-sends; ``confirm_s`` for the vehicle's telemetry
    to show an accepted command's effect (its next HEARTBEAT); ``preflight_s`` for the
    answers to the pre-flight requests; ``text_grace_s`` for the STATUSTEXT that explains a
    refusal; ``link_s`` without a message from the vehicle before the link counts as lost
    (QGroundControl warns after about 3.5 s without a HEARTBEAT; the default allows a
    missed heartbeat or two more)."""

    ack_s: float = 1.5
    retries: int = 3
    confirm_s: float = 5.0
    preflight_s: float = 3.0
    text_grace_s: float = 0.3
    link_s: float = 5.0

    def __post_init__(self) -> None:
        for name in ("ack_s", "confirm_s", "preflight_s", "text_grace_s", "link_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number of seconds, got {value!r}")
        if not 0 <= self.retries <= 20:
            raise ValueError(f"retries must be within 0..20, got {self.retries!r}")


# ---------------------------------------------------------------------------------------------
# What the vehicle said


@dataclass(frozen=True)
class TelemetrySample:
    """One GLOBAL_POSITION_INT with what was known when it came: ``time_s`` is the vehicle's
    own clock (``time_boot_ms``; simulated time on a simulated vehicle)."""

    time_s: float
    lat_deg: float
    lon_deg: float
    alt_amsl_m: float
    relative_alt_m: float
    speed_m_s: float
    climb_m_s: float
    current_seq: int
    mode: str
    landed_state: int
    armed: bool


@dataclass
class VehicleState:
    """What the vehicle last reported (updated by :meth:`update` with each message)."""

    autopilot: Autopilot
    armed: bool = False
    mode: FlightMode | None = None
    custom_mode: int | None = None
    system_status: int | None = None
    landed_state: int = LandedState.UNDEFINED
    home: tuple[float, float, float] | None = None  # lat deg, lon deg, altitude AMSL m
    sensors_present: int | None = None
    sensors_enabled: int | None = None
    sensors_health: int | None = None
    battery_pct: float | None = None
    voltage_v: float | None = None
    current_seq: int = -1
    mission_total: int | None = None
    mission_state: int = MissionState.UNKNOWN
    reached: list[int] = field(default_factory=list)
    position: TelemetrySample | None = None
    heartbeats: int = 0
    last_heard: float | None = None
    #: every STATUSTEXT, with when it came: (now, severity, text)
    texts: list[tuple[float, int, str]] = field(default_factory=list)
    #: samples are kept while this is set (:meth:`take_samples` hands them over)
    recording: bool = False
    samples: list[TelemetrySample] = field(default_factory=list)
    #: the vehicle has been in the air (landed state IN_AIR, or armed and 1 m up)
    flew: bool = False

    def update(self, message: Message, now: float) -> None:
        self.last_heard = now
        if isinstance(message, Heartbeat):
            self.heartbeats += 1
            self.armed = bool(message.base_mode & MavModeFlag.SAFETY_ARMED)
            self.custom_mode = message.custom_mode
            self.mode = mode_from_heartbeat(self.autopilot, message.custom_mode)
            self.system_status = message.system_status
        elif isinstance(message, StatusText):
            self.texts.append((now, message.severity, message.text))
        elif isinstance(message, HomePosition):
            self.home = (message.latitude / 1e7, message.longitude / 1e7, message.altitude / 1e3)
        elif isinstance(message, SysStatus):
            self.sensors_present = message.onboard_control_sensors_present
            self.sensors_enabled = message.onboard_control_sensors_enabled
            self.sensors_health = message.onboard_control_sensors_health
            if message.battery_remaining >= 0:
                self.battery_pct = float(message.battery_remaining)
            if message.voltage_battery not in (0, 65535):
                self.voltage_v = message.voltage_battery / 1000.0
        elif isinstance(message, BatteryStatus):
            if message.battery_remaining >= 0:
                self.battery_pct = float(message.battery_remaining)
        elif isinstance(message, ExtendedSysState):
            self.landed_state = message.landed_state
            if message.landed_state == LandedState.IN_AIR:
                self.flew = True
        elif isinstance(message, MissionCurrent):
            self.current_seq = message.seq
            self.mission_total = message.total
            self.mission_state = message.mission_state
        elif isinstance(message, MissionItemReached):
            self.reached.append(message.seq)
        elif isinstance(message, GlobalPositionInt):
            self._position(message)

    def _position(self, m: GlobalPositionInt) -> None:
        vn, ve, vd = m.vx / 100.0, m.vy / 100.0, m.vz / 100.0
        sample = TelemetrySample(
            time_s=m.time_boot_ms / 1000.0,
            lat_deg=m.lat / 1e7,
            lon_deg=m.lon / 1e7,
            alt_amsl_m=m.alt / 1000.0,
            relative_alt_m=m.relative_alt / 1000.0,
            speed_m_s=math.hypot(vn, ve),
            climb_m_s=-vd,
            current_seq=self.current_seq,
            mode="" if self.mode is None else self.mode.name,
            landed_state=self.landed_state,
            armed=self.armed,
        )
        self.position = sample
        if self.armed and sample.relative_alt_m > 1.0:
            self.flew = True
        if self.recording:
            self.samples.append(sample)

    def take_samples(self) -> list[TelemetrySample]:
        """The samples recorded since the last call."""
        out, self.samples = self.samples, []
        return out

    def texts_since(self, since: float) -> list[str]:
        return [text for when, _severity, text in self.texts if when >= since]

    @property
    def prearm_ready(self) -> bool | None:
        """SYS_STATUS's pre-arm check bit: True passes, False fails, None: not reported."""
        enabled = self.sensors_enabled
        if enabled is None or not enabled & SYS_STATUS_PREARM_CHECK:
            return None
        return bool((self.sensors_health or 0) & SYS_STATUS_PREARM_CHECK)

    @property
    def on_ground(self) -> bool:
        if self.landed_state == LandedState.ON_GROUND:
            return True
        return not self.armed and self.landed_state == LandedState.UNDEFINED

    def describe(self) -> str:
        """What the vehicle was doing, in words (for a lost link)."""
        parts = [f"{'armed' if self.armed else 'disarmed'}"]
        parts.append(f"in {self.mode.name}" if self.mode is not None else "in an unknown mode")
        if self.current_seq >= 0:
            total = f"/{self.mission_total}" if self.mission_total else ""
            parts.append(f"at mission item {self.current_seq}{total}")
        p = self.position
        if p is not None:
            parts.append(
                f"{p.relative_alt_m:.0f} m above home at {p.lat_deg:.6f}, {p.lon_deg:.6f}, "
                f"{p.speed_m_s:.1f} m/s"
            )
        landed = _LANDED_WORDS.get(self.landed_state)
        if landed:
            parts.append(landed)
        return ", ".join(parts)


_LANDED_WORDS = {
    int(LandedState.ON_GROUND): "on the ground",
    int(LandedState.IN_AIR): "in the air",
    int(LandedState.TAKEOFF): "taking off",
    int(LandedState.LANDING): "landing",
}


# ---------------------------------------------------------------------------------------------
# The machines' common parts


class FlightMachine:
    """The outbox, the deadline and the shared state."""

    def __init__(self, state: VehicleState, target: tuple[int, int], timeouts: FlightTimeouts):
        self.state = state
        self.target = target
        self.timeouts = timeouts
        self.deadline = math.inf
        self.finished: object | None = None

    def command(self, command: int, params: Sequence[float], confirmation: int = 0) -> CommandLong:
        p = [*params, *([0.0] * 7)][:7]
        return CommandLong(
            self.target[0], self.target[1], int(command), confirmation, *(float(v) for v in p)
        )

    def start(self, now: float) -> list[Message]:
        raise NotImplementedError

    def on_message(self, message: Message, now: float) -> list[Message]:
        self.state.update(message, now)
        return self.handle(message, now)

    def handle(self, message: Message, now: float) -> list[Message]:
        return []

    def on_timeout(self, now: float) -> list[Message]:
        raise NotImplementedError


def _result_name(result: int | None) -> str:
    if result is None:
        return "no COMMAND_ACK"
    try:
        return f"MAV_RESULT_{MavResult(result).name}"
    except ValueError:
        return f"MAV_RESULT {result}"


# ---------------------------------------------------------------------------------------------
# Pre-flight


@dataclass(frozen=True)
class Preflight:
    """What the pre-flight requests found. ``home``: (lat deg, lon deg, altitude AMSL m) or
    None (not reported); ``prearm_ready``: SYS_STATUS's pre-arm check (None: not reported);
    ``prearm_result``: the answer to MAV_CMD_RUN_PREARM_CHECKS (None: none came);
    ``texts``: the STATUSTEXT the vehicle sent meanwhile."""

    home: tuple[float, float, float] | None
    prearm_ready: bool | None
    prearm_result: int | None
    texts: tuple[str, ...]
    armed: bool
    mode: FlightMode | None
    landed_state: int


class PreflightMachine(FlightMachine):
    """Ask for HOME_POSITION and SYS_STATUS (MAV_CMD_REQUEST_MESSAGE, as QGroundControl and
    MAVSDK do), run the pre-arm checks (MAV_CMD_RUN_PREARM_CHECKS: ArduPilot and PX4 report
    what fails in a STATUSTEXT), wait a moment for those texts; re-ask what is missing."""

    def start(self, now: float) -> list[Message]:
        self.started = now
        self.sends = 1
        self.prearm_result: int | None = None
        self.texts_until: float | None = None
        self.deadline = now + self.timeouts.preflight_s / 3.0
        return self._requests(include_prearm=True)

    def _requests(self, *, include_prearm: bool) -> list[Message]:
        out: list[Message] = []
        if self.state.home is None:
            out.append(self.command(MavCommand.REQUEST_MESSAGE, [MessageId.HOME_POSITION]))
        if self.state.sensors_health is None:
            out.append(self.command(MavCommand.REQUEST_MESSAGE, [MessageId.SYS_STATUS]))
        out.append(self.command(MavCommand.REQUEST_MESSAGE, [MessageId.EXTENDED_SYS_STATE]))
        if include_prearm:
            out.append(self.command(MavCommand.RUN_PREARM_CHECKS, []))
        return out

    def handle(self, message: Message, now: float) -> list[Message]:
        if isinstance(message, CommandAck) and message.command == MavCommand.RUN_PREARM_CHECKS:
            self.prearm_result = message.result
        self._maybe_done(now)
        return []

    def _complete(self) -> bool:
        s = self.state
        return (
            s.home is not None and s.sensors_health is not None and self.prearm_result is not None
        )

    def _maybe_done(self, now: float) -> None:
        if self._complete() and self.texts_until is None:
            # the checks' STATUSTEXT may trail their COMMAND_ACK
            self.texts_until = now + self.timeouts.text_grace_s
            self.deadline = self.texts_until

    def _finish(self) -> None:
        s = self.state
        self.finished = Preflight(
            home=s.home,
            prearm_ready=s.prearm_ready,
            prearm_result=self.prearm_result,
            texts=tuple(s.texts_since(self.started)),
            armed=s.armed,
            mode=s.mode,
            landed_state=s.landed_state,
        )

    def on_timeout(self, now: float) -> list[Message]:
        if self.texts_until is not None or now - self.started >= self.timeouts.preflight_s:
            self._finish()
            return []
        self.sends += 1
        self.deadline = now + self.timeouts.preflight_s / 3.0
        return self._requests(include_prearm=self.prearm_result is None)


# ---------------------------------------------------------------------------------------------
# Commands: start, mode changes


@dataclass(frozen=True)
class Step:
    """One command of a sequence: what it is called in messages, MAV_CMD and params 1-7,
    and what the vehicle's telemetry shows once it took effect (None: the ACK is enough)."""

    label: str
    command: int
    params: tuple[float, ...]
    confirm: Callable[[VehicleState], bool] | None = None
    expect: str = ""  # what ``confirm`` waits for, in words


@dataclass(frozen=True)
class CommandOutcome:
    """How a :class:`CommandSequence` ended: ``ok``, or at ``step`` with the vehicle's
    ``result`` (a MAV_RESULT, None: no answer) and the STATUSTEXT it sent meanwhile."""

    ok: bool
    step: str = ""
    result: int | None = None
    texts: tuple[str, ...] = ()
    detail: str = ""

    @property
    def result_name(self) -> str:
        return _result_name(self.result)

    def message(self) -> str:
        """The refusal in the vehicle's words: its texts and its ACK."""
        said = "; ".join(f'"{t}"' for t in self.texts)
        head = f"{self.step}: {self.detail}" if self.detail else self.step
        if said:
            return f"{head}: the vehicle said {said} ({self.result_name})"
        return f"{head} ({self.result_name})"


class _Phase(enum.Enum):
    ACK = "ack"
    CONFIRM = "confirm"
    GRACE = "grace"


class CommandSequence(FlightMachine):
    """Send ``steps`` one after another: each is re-sent until its COMMAND_ACK comes
    (``confirmation`` counts the re-sends), then confirmed by the vehicle's telemetry. Any
    result but ACCEPTED (IN_PROGRESS waits) ends the sequence as a refusal, after a short
    grace for the STATUSTEXT explaining it."""

    def __init__(
        self,
        state: VehicleState,
        target: tuple[int, int],
        timeouts: FlightTimeouts,
        steps: Sequence[Step],
    ) -> None:
        super().__init__(state, target, timeouts)
        if not steps:
            raise ValueError("a command sequence needs a step")
        self.steps = tuple(steps)
        self.index = 0
        self.phase = _Phase.ACK
        self.confirmation = 0
        self.step_started = 0.0
        self.refusal: CommandOutcome | None = None

    @property
    def step(self) -> Step:
        return self.steps[self.index]

    def _send_step(self, now: float) -> list[Message]:
        step = self.step
        self.phase = _Phase.ACK
        self.deadline = now + self.timeouts.ack_s
        return [self.command(step.command, step.params, self.confirmation)]

    def start(self, now: float) -> list[Message]:
        self.step_started = now
        return self._send_step(now)

    def _next(self, now: float) -> list[Message]:
        self.index += 1
        self.confirmation = 0
        if self.index >= len(self.steps):
            self.finished = CommandOutcome(True)
            self.deadline = math.inf
            return []
        self.step_started = now
        return self._send_step(now)

    def _confirmed(self) -> bool:
        confirm = self.step.confirm
        return confirm is None or confirm(self.state)

    def handle(self, message: Message, now: float) -> list[Message]:
        if self.phase is _Phase.GRACE:
            return []
        step = self.step
        if isinstance(message, CommandAck) and message.command == step.command:
            if self.phase is not _Phase.ACK:
                return []  # the answer to a re-send, already taken
            if message.result == MavResult.IN_PROGRESS:
                self.deadline = now + self.timeouts.confirm_s
                return []
            if message.result != MavResult.ACCEPTED:
                self.refusal = CommandOutcome(False, step.label, message.result)
                self.phase = _Phase.GRACE
                self.deadline = now + self.timeouts.text_grace_s
                return []
            self.phase = _Phase.CONFIRM
            self.deadline = now + self.timeouts.confirm_s
        if self.phase is _Phase.CONFIRM and self._confirmed():
            return self._next(now)
        return []

    def on_timeout(self, now: float) -> list[Message]:
        step = self.step
        if self.phase is _Phase.GRACE:
            assert self.refusal is not None
            r = self.refusal
            texts = tuple(self.state.texts_since(self.step_started))
            self.finished = CommandOutcome(False, r.step, r.result, texts, r.detail)
            return []
        if self.phase is _Phase.CONFIRM:
            texts = tuple(self.state.texts_since(self.step_started))
            seen = "unknown" if self.state.mode is None else self.state.mode.name
            armed = "armed" if self.state.armed else "disarmed"
            self.finished = CommandOutcome(
                False,
                step.label,
                MavResult.ACCEPTED,
                texts,
                f"accepted, but after {self.timeouts.confirm_s:g} s the vehicle still reports "
                f"{seen}, {armed} (expected {step.expect or 'the change'})",
            )
            return []
        if self.confirmation >= self.timeouts.retries:
            self.finished = CommandOutcome(
                False,
                step.label,
                None,
                tuple(self.state.texts_since(self.step_started)),
                f"no COMMAND_ACK after {self.confirmation + 1} tries",
            )
            return []
        self.confirmation += 1
        return self._send_step(now)


def _in_mode(mode: FlightMode, *, armed: bool = False) -> Callable[[VehicleState], bool]:
    def confirm(state: VehicleState) -> bool:
        return state.mode == mode and (state.armed or not armed)

    return confirm


def set_mode_step(autopilot: Autopilot, mode: FlightMode) -> Step:
    """MAV_CMD_DO_SET_MODE into ``mode``: param1 MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, param2
    the custom (PX4: main) mode, param3 PX4's sub mode (uavplan.mavlink.modes); confirmed
    by the HEARTBEAT's custom_mode."""
    main, sub = mode.numbers
    params = (float(MavModeFlag.CUSTOM_MODE_ENABLED), float(main), float(sub))
    if autopilot == Autopilot.ARDUPILOT:
        params = (float(MavModeFlag.CUSTOM_MODE_ENABLED), float(main), 0.0)
    return Step(
        f"set mode {mode.name} (MAV_CMD_DO_SET_MODE)",
        MavCommand.DO_SET_MODE,
        params,
        _in_mode(mode),
        f"mode {mode.name}",
    )


def arm_step() -> Step:
    """MAV_CMD_COMPONENT_ARM_DISARM param1 = 1 (no force); confirmed by the armed bit."""
    return Step(
        "arm (MAV_CMD_COMPONENT_ARM_DISARM)",
        MavCommand.COMPONENT_ARM_DISARM,
        (1.0,),
        lambda s: s.armed,
        "armed",
    )


def disarm_step() -> Step:
    """MAV_CMD_COMPONENT_ARM_DISARM param1 = 0 (no force: refused in the air)."""
    return Step(
        "disarm (MAV_CMD_COMPONENT_ARM_DISARM)",
        MavCommand.COMPONENT_ARM_DISARM,
        (0.0,),
        lambda s: not s.armed,
        "disarmed",
    )


def mission_start_step(autopilot: Autopilot) -> Step:
    """MAV_CMD_MISSION_START with param1 = param2 = 0 (first and last item: the whole
    mission; ArduPilot refuses anything else); confirmed by the mission mode."""
    mission = mode_named(autopilot, ModeKind.MISSION)
    return Step(
        "start the mission (MAV_CMD_MISSION_START)",
        MavCommand.MISSION_START,
        (0.0, 0.0),
        _in_mode(mission, armed=True),
        f"mode {mission.name}, armed",
    )


def start_steps(autopilot: Autopilot) -> list[Step]:
    """How each firmware is started from the ground, as QGroundControl does it:

    - PX4 (``PX4FirmwarePlugin::startMission``, src/FirmwarePlugin/PX4/PX4FirmwarePlugin.cc):
      Mission mode, then arm; arming in Mission mode starts the mission. MAVSDK's
      ``Action::arm`` then ``MissionRaw::start_mission`` (which sets Mission mode) reach the
      same state.
    - ArduPilot Copter (``APMFirmwarePlugin::startMission``,
      src/FirmwarePlugin/APM/APMFirmwarePlugin.cc): GUIDED (a mode it can arm in), arm,
      then MAV_CMD_MISSION_START, which switches to AUTO and lets the mission's take-off run
      (arming in AUTO is refused: "Arm: AUTO mode not armable").
    """
    if autopilot == Autopilot.PX4:
        return [set_mode_step(autopilot, mode_named(autopilot, ModeKind.MISSION)), arm_step()]
    if autopilot == Autopilot.ARDUPILOT:
        guided = mode_named(autopilot, ModeKind.GUIDED)
        return [set_mode_step(autopilot, guided), arm_step(), mission_start_step(autopilot)]
    raise ValueError(f"no start sequence for a {autopilot.label} vehicle")


def mode_steps(autopilot: Autopilot, kind: ModeKind) -> list[Step]:
    """Change to the mode of ``kind`` (HOLD: PX4 Hold / ArduPilot BRAKE; RETURN; LAND)."""
    return [set_mode_step(autopilot, mode_named(autopilot, kind))]


# ---------------------------------------------------------------------------------------------
# Monitoring


class MonitorEnd(enum.Enum):
    """How a monitored flight ended."""

    COMPLETE = "complete"  # the mission is done and the vehicle is on the ground
    COMPLETE_IN_AIR = "complete in the air"  # done, and the mission does not land
    LANDED_EARLY = "landed early"  # down (disarmed) before the mission was done
    LINK_LOST = "link lost"  # nothing from the vehicle for FlightTimeouts.link_s


#: the telemetry :class:`MonitorMachine` asks for, with its interval (µs): the position at
#: 5 Hz (QGroundControl's rate for GLOBAL_POSITION_INT), the rest at 1 Hz
STREAMS = (
    (MessageId.GLOBAL_POSITION_INT, 200_000),
    (MessageId.MISSION_CURRENT, 1_000_000),
    (MessageId.EXTENDED_SYS_STATE, 1_000_000),
    (MessageId.SYS_STATUS, 1_000_000),
    (MessageId.BATTERY_STATUS, 1_000_000),
)


#: messages a landed mission's monitor waits for a position report before it ends anyway
SETTLE_MESSAGES = 20


class MonitorMachine(FlightMachine):
    """Follow the flight until it ends (:class:`MonitorEnd`).

    ``last_seq``: the mission's last item (wire seq); ``lands``: the mission ends on the
    ground (a landing or a return to launch). Done when the vehicle has flown, the mission
    is complete (MISSION_CURRENT's mission_state, or the last item reached, or the return
    or landing begun after the last item) and the vehicle is down (landed state, or
    disarmed); with a mission that does not land, when the last item is reached.
    """

    def __init__(
        self,
        state: VehicleState,
        target: tuple[int, int],
        timeouts: FlightTimeouts,
        *,
        last_seq: int,
        lands: bool,
    ) -> None:
        super().__init__(state, target, timeouts)
        self.last_seq = last_seq
        self.lands = lands
        self._settling = 0

    def start(self, now: float) -> list[Message]:
        self.deadline = now + self.timeouts.link_s
        return [
            self.command(MavCommand.SET_MESSAGE_INTERVAL, [float(message), float(interval)])
            for message, interval in STREAMS
        ]

    @property
    def mission_done(self) -> bool:
        s = self.state
        if s.mission_state == MissionState.COMPLETE and s.flew:
            return True
        if self.last_seq in s.reached:
            return True
        at_end = s.current_seq >= self.last_seq
        if at_end and self.lands and (s.landed_state == LandedState.ON_GROUND or not s.armed):
            # down on the last item of a mission that ends on the ground: that item is the
            # landing (or the return that lands), and it is done; the vehicle's word that the
            # mission is complete may come after its disarm (ArduPilot disarms on touchdown)
            return s.flew
        return at_end and s.mode is not None and s.mode.kind in (ModeKind.RETURN, ModeKind.LAND)

    def handle(self, message: Message, now: float) -> list[Message]:
        self.deadline = now + self.timeouts.link_s
        s = self.state
        if not s.flew:
            return []
        down = s.landed_state == LandedState.ON_GROUND or not s.armed
        if self.lands and self.mission_done and down:
            # done once a position report shows where it came down (the track's last sample,
            # which the take-off-to-touchdown time reads), or a few messages on without one
            self._settling += 1
            if isinstance(message, GlobalPositionInt) or self._settling > SETTLE_MESSAGES:
                self.finished = MonitorEnd.COMPLETE
        elif not self.lands and self.mission_done:
            self.finished = MonitorEnd.COMPLETE_IN_AIR if not down else MonitorEnd.COMPLETE
        elif not s.armed and down:
            self.finished = MonitorEnd.LANDED_EARLY
        return []

    def on_timeout(self, now: float) -> list[Message]:
        self.finished = MonitorEnd.LINK_LOST
        return []
