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
  the vehicle is down, or the link is lost; on the way it notices what changes behind the
  ground station's back (:class:`Notice`: a mode it did not command, a new mission or home,
  a disarm in the air, a restart, the link going quiet and coming back) and decides an
  ending only on state the vehicle reported after the last such event (:class:`WatchRules`).

Telemetry as it really arrives: :class:`VehicleState` orders the position samples by the
vehicle's own clock (``time_boot_ms``), drops duplicates and late copies, records the stretches
without any sample (:data:`GAP_S`) and takes a clock that goes back and stays back
(:data:`REORDER_WINDOW_S`, :data:`RESTART_SAMPLES`) for a restart of the vehicle.

A refusal ends a machine with the vehicle's own words: the COMMAND_ACK result by name and the
STATUSTEXT it sent while the command ran.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

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
    MissionAck,
    MissionCurrent,
    MissionItemReached,
    MissionResult,
    MissionState,
    Received,
    StatusText,
    SysStatus,
)
from uavplan.mavlink.modes import FlightMode, ModeKind, mode_from_heartbeat, mode_named
from uavplan.mission.items import Autopilot

__all__ = [
    "GAP_S",
    "REORDER_WINDOW_S",
    "RESTART_SAMPLES",
    "CommandEnd",
    "CommandOutcome",
    "CommandSequence",
    "FlightMachine",
    "FlightTimeouts",
    "MonitorEnd",
    "MonitorMachine",
    "Notice",
    "NoticeKind",
    "Preflight",
    "PreflightMachine",
    "Restart",
    "Step",
    "TelemetrySample",
    "VehicleState",
    "WatchRules",
    "disarm_step",
    "flight_clock",
    "mode_steps",
    "start_steps",
]

#: the longest stretch (vehicle seconds) between two position samples that still counts as
#: observed: ten samples of the 5 Hz stream lost in a row. Over a longer one nothing was seen,
#: and a straight line drawn across it would be a guess (at 12 m/s, 24 m of flight)
GAP_S = 2.0
#: a position sample up to this far (vehicle seconds) behind the newest one is a late or
#: reordered copy and is dropped; further behind, it may be the first of a new clock
REORDER_WINDOW_S = 3.0
#: samples in a row, each further behind the newest than :data:`REORDER_WINDOW_S` and each
#: later than the one before, that make a new clock: the vehicle restarted
RESTART_SAMPLES = 3


@dataclass(frozen=True)
class FlightTimeouts:
    """How long the ground station waits (wall seconds).

    ``ack_s`` for a COMMAND_ACK before re-sending the command (MAVSDK's default command
    timeout is 0.5 s, QGroundControl's 3 s; 1.5 s sits between them, as the mission
    protocol's ack timeout), ``retries`` re-sends (six: QGroundControl and MAVSDK re-send three
    times, but at 20 % loss each way one exchange in three fails, and a start lost to the link
    is worse than 10.5 s of waiting for a vehicle that does not answer: four tries fail one
    start command in 60, seven one in 1,300); ``confirm_s`` for the vehicle's telemetry
    to show an accepted command's effect (its next HEARTBEAT); ``preflight_s`` for the
    answers to the pre-flight requests; ``text_grace_s`` for the STATUSTEXT that explains a
    refusal; ``link_s`` without a message from the vehicle before the link counts as lost
    (QGroundControl warns after about 3.5 s without a HEARTBEAT; the default allows a
    missed heartbeat or two more); ``busy_s`` how long a step that may wait (the arm) is
    asked again, every ``busy_every_s``, while the vehicle answers
    MAV_RESULT_TEMPORARILY_REJECTED. MAVLink defines that result as a problem "that should
    be fixed just by waiting ... Retrying later should work", and PX4 gives it when a health
    check flickers just after it passed (its estimator's "vertical velocity unstable"); a
    check that keeps failing is reported, in the vehicle's words, once ``busy_s`` has
    passed."""

    ack_s: float = 1.5
    retries: int = 6
    confirm_s: float = 5.0
    preflight_s: float = 3.0
    text_grace_s: float = 0.3
    link_s: float = 5.0
    busy_s: float = 10.0
    busy_every_s: float = 1.0

    def __post_init__(self) -> None:
        names = ("ack_s", "confirm_s", "preflight_s", "text_grace_s", "link_s", "busy_every_s")
        for name in names:
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number of seconds, got {value!r}")
        if not 0 <= self.retries <= 20:
            raise ValueError(f"retries must be within 0..20, got {self.retries!r}")
        if not (math.isfinite(self.busy_s) and self.busy_s >= 0):
            raise ValueError(f"busy_s must be a number of seconds >= 0, got {self.busy_s!r}")


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
    #: which run of the vehicle's clock: 0, then 1 after a restart, ...
    epoch: int = 0


@dataclass(frozen=True)
class Restart:
    """The vehicle's clock went back and stayed back: ``before_s`` its newest time before,
    ``after_s`` its first time after (vehicle seconds), ``at`` the ground clock then."""

    before_s: float
    after_s: float
    at: float


def flight_clock(seconds: float) -> str:
    """``1 min 12 s`` (a time into the flight)."""
    minutes, rest = divmod(max(0, round(seconds)), 60)
    return f"{minutes} min {rest:02d} s"


#: what VehicleState.heard stamps: the message kinds a decision rests on
HEARD_KINDS = ("heartbeat", "mission_current", "extended_sys_state", "position", "home")


@dataclass
class VehicleState:
    """What the vehicle last reported (updated by :meth:`update` with each message).

    Position samples are taken in the order of the vehicle's clock: a sample no later than
    the newest one is a duplicate or a late copy and is dropped (counted in ``duplicates`` and
    ``late``); one more than :data:`REORDER_WINDOW_S` behind it starts a candidate new clock,
    which :data:`RESTART_SAMPLES` such samples confirm (a :class:`Restart`: ``epoch`` counts
    them). While recording, a step longer than :data:`GAP_S` between accepted samples is a
    gap (``gaps``, vehicle seconds). ``heard`` keeps the ground time each kind of state
    (:data:`HEARD_KINDS`) was last reported: what a decision after a gap may rest on."""

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
    #: BATTERY_STATUS.time_remaining (s; None: not reported)
    battery_time_s: float | None = None
    #: the vehicle's clock: its newest accepted position sample (s; None: none yet)
    newest_s: float | None = None
    #: the first recorded sample's time: the flight's zero (s, vehicle clock)
    origin_s: float | None = None
    duplicates: int = 0
    late: int = 0
    epoch: int = 0
    restarts: list[Restart] = field(default_factory=list)
    #: stretches without a position sample while recording: (from, to), vehicle seconds
    gaps: list[tuple[float, float]] = field(default_factory=list)
    heard: dict[str, float] = field(default_factory=dict)
    #: what the monitor noticed, in order (:class:`Notice`)
    notices: list[Notice] = field(default_factory=list)
    _behind: list[TelemetrySample] = field(default_factory=list)

    def update(self, message: Message, now: float) -> None:
        self.last_heard = now
        if isinstance(message, Heartbeat):
            self.heard["heartbeat"] = now
            self.heartbeats += 1
            self.armed = bool(message.base_mode & MavModeFlag.SAFETY_ARMED)
            self.custom_mode = message.custom_mode
            self.mode = mode_from_heartbeat(self.autopilot, message.custom_mode)
            self.system_status = message.system_status
        elif isinstance(message, StatusText):
            self.texts.append((now, message.severity, message.text))
        elif isinstance(message, HomePosition):
            self.heard["home"] = now
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
            # 0: "not provided by autopilot" (common.xml)
            self.battery_time_s = float(message.time_remaining) if message.time_remaining else None
        elif isinstance(message, ExtendedSysState):
            self.heard["extended_sys_state"] = now
            self.landed_state = message.landed_state
            if message.landed_state == LandedState.IN_AIR:
                self.flew = True
        elif isinstance(message, MissionCurrent):
            self.heard["mission_current"] = now
            self.current_seq = message.seq
            self.mission_total = message.total
            self.mission_state = message.mission_state
        elif isinstance(message, MissionItemReached):
            self.reached.append(message.seq)
        elif isinstance(message, GlobalPositionInt):
            self._position(message, now)

    def _position(self, m: GlobalPositionInt, now: float) -> None:
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
            epoch=self.epoch,
        )
        newest = self.newest_s
        t = sample.time_s
        if newest is not None and t <= newest:
            self._behind_or_late(sample, now)
            return
        self._behind.clear()
        self._accept(sample, now)

    def _behind_or_late(self, sample: TelemetrySample, now: float) -> None:
        newest = self.newest_s
        assert newest is not None
        t = sample.time_s
        if t == newest:
            self.duplicates += 1
            return
        if newest - t <= REORDER_WINDOW_S:
            self.late += 1
            return
        behind = self._behind
        if behind and t <= behind[-1].time_s:
            if t == behind[-1].time_s:
                self.duplicates += 1
            else:
                self.late += 1
            return
        behind.append(sample)
        if len(behind) < RESTART_SAMPLES:
            return
        # the clock went back and runs on from there: the vehicle restarted
        self.restarts.append(Restart(newest, behind[0].time_s, now))
        self.epoch += 1
        self.newest_s = None
        taken, self._behind = behind, []
        for old in taken:
            self._accept(replace(old, epoch=self.epoch), now)

    def _accept(self, sample: TelemetrySample, now: float) -> None:
        newest = self.newest_s
        self.newest_s = sample.time_s
        self.heard["position"] = now
        self.position = sample
        if self.armed and sample.relative_alt_m > 1.0:
            self.flew = True
        if not self.recording:
            return
        if self.origin_s is None:
            self.origin_s = sample.time_s
        if newest is not None and sample.time_s - newest > GAP_S:
            self.gaps.append((newest, sample.time_s))
        self.samples.append(sample)

    def since_origin(self, vehicle_s: float) -> float:
        """Seconds into the flight (from the first recorded sample) of vehicle time
        ``vehicle_s`` (of the first clock)."""
        return vehicle_s - (self.origin_s if self.origin_s is not None else vehicle_s)

    def not_heard_since(self, since: float, kinds: tuple[str, ...] = HEARD_KINDS) -> list[str]:
        """Of ``kinds`` the vehicle ever reported, those not reported since ``since``."""
        return [k for k in kinds if k in self.heard and self.heard[k] < since]

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

    def request_messages(self, messages: Sequence[int]) -> list[Message]:
        """MAV_CMD_REQUEST_MESSAGE for each message id (sent once each: no answer needed)."""
        return [self.command(MavCommand.REQUEST_MESSAGE, [float(m)]) for m in messages]

    def start(self, now: float) -> list[Message]:
        raise NotImplementedError

    def on_message(self, message: Message, now: float) -> list[Message]:
        self.state.update(message, now)
        return self.handle(message, now)

    def handle(self, message: Message, now: float) -> list[Message]:
        return []

    def on_overheard(self, received: Received, now: float) -> list[Message]:
        """A message from the vehicle to another ground station (what it answered them)."""
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
    #: asked again while the vehicle answers TEMPORARILY_REJECTED (FlightTimeouts.busy_s)
    waits_when_busy: bool = False


class CommandEnd(enum.Enum):
    """Why a :class:`CommandSequence` did not end ok."""

    REFUSED = "refused"  # the vehicle answered a MAV_RESULT other than ACCEPTED
    UNCONFIRMED = "unconfirmed"  # accepted, but its telemetry never showed the effect
    UNANSWERED = "unanswered"  # no COMMAND_ACK after every re-send


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
    def interrupted(self) -> bool:
        """Never: a Ctrl-C stops the driver's loop, which then has no outcome."""
        return False

    @property
    def reason(self) -> CommandEnd | None:
        """Why it did not end ok (:class:`~uavplan.outcome.Ended`); None: it did."""
        if self.ok:
            return None
        if self.result is None:
            return CommandEnd.UNANSWERED
        if self.result == MavResult.ACCEPTED:
            return CommandEnd.UNCONFIRMED
        return CommandEnd.REFUSED

    @property
    def result_name(self) -> str:
        return _result_name(self.result)

    @property
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
    BUSY = "busy"  # temporarily rejected: asked again at the deadline


class CommandSequence(FlightMachine):
    """Send ``steps`` one after another: each is re-sent until its COMMAND_ACK comes
    (``confirmation`` counts the re-sends), then confirmed by the vehicle's telemetry. Any
    result but ACCEPTED (IN_PROGRESS waits) ends the sequence as a refusal, after a short
    grace for the STATUSTEXT explaining it; a step that ``waits_when_busy`` is asked again
    after TEMPORARILY_REJECTED until :attr:`FlightTimeouts.busy_s` has passed (``busy``
    counts those refusals)."""

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
        self.busy = 0

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

    def _waits(self, result: int, now: float) -> bool:
        """Ask again later: the step waits while busy and ``busy_s`` has not passed."""
        t = self.timeouts
        return (
            self.step.waits_when_busy
            and result == MavResult.TEMPORARILY_REJECTED
            and now + t.busy_every_s - self.step_started <= t.busy_s
        )

    def handle(self, message: Message, now: float) -> list[Message]:
        if self.phase is _Phase.GRACE:
            return []
        step = self.step
        if self.phase is _Phase.BUSY:
            # a late ACCEPTED to an earlier try may still take effect
            return self._next(now) if step.confirm is not None and self._confirmed() else []
        if isinstance(message, CommandAck) and message.command == step.command:
            if self.phase is not _Phase.ACK:
                return []  # the answer to a re-send, already taken
            if message.result == MavResult.IN_PROGRESS:
                self.deadline = now + self.timeouts.confirm_s
                return []
            if self._waits(message.result, now):
                self.busy += 1
                self.phase = _Phase.BUSY
                self.deadline = now + self.timeouts.busy_every_s
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
        if self.phase is _Phase.BUSY:
            self.confirmation = 0  # a new try, not a re-send of the refused one
            return self._send_step(now)
        if self.phase is _Phase.GRACE:
            assert self.refusal is not None
            r = self.refusal
            texts = tuple(dict.fromkeys(self.state.texts_since(self.step_started)))
            detail = r.detail
            if self.busy:
                waited = now - self.step_started
                detail = f"asked {self.busy + 1} times over {waited:.1f} s"
            self.finished = CommandOutcome(False, r.step, r.result, texts, detail)
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
        waits_when_busy=True,
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
    RESTARTED = "restarted"  # the vehicle's clock went back: it restarted
    MISSION_CHANGED = "mission changed"  # it holds another mission: not this flight any more
    HELD = "held"  # a mode the ground station did not command outlasted takeover_wait_s
    DISARMED_IN_AIR = "disarmed in the air"
    STALLED = "no progress"  # the caller's judge: no progress for its stated time
    #: the ground station's own end: a Ctrl-C stopped the watch (``fly`` then commands its
    #: --on-interrupt mode); the machine never ends so by itself
    INTERRUPTED = "interrupted"


class NoticeKind(enum.Enum):
    """What the monitor noticed on the way."""

    LINK_QUIET = "link quiet"  # nothing heard for WatchRules.quiet_s
    LINK_BACK = "link back"  # heard again after that
    GAP = "no telemetry"  # a stretch without position samples (GAP_S)
    RESTART = "restart"  # the vehicle's clock went back
    MODE_CHANGED = "mode changed"  # a mode neither commanded nor the mission's own
    MISSION_RESUMED = "mission resumed"  # back in the mission mode after that
    MISSION_CHANGED = "mission changed"  # another mission on board (count, or upload seen)
    PLAN_CHANGED = "fence or rally changed"  # another ground station's fence / rally upload
    HOME_MOVED = "home moved"  # HOME_POSITION moved beyond the tolerance
    DISARMED = "disarmed in the air"
    NO_PROGRESS = "no progress"  # the caller's: no progress for its stated time
    BATTERY = "battery"  # the caller's: the ETA passes what the battery has left


#: notices of a change behind the ground station's back: the flight is no longer the one it
#: started, whatever happens next
TAKEOVERS = frozenset(
    {
        NoticeKind.RESTART,
        NoticeKind.MODE_CHANGED,
        NoticeKind.MISSION_CHANGED,
        NoticeKind.PLAN_CHANGED,
        NoticeKind.HOME_MOVED,
        NoticeKind.DISARMED,
    }
)


@dataclass(frozen=True)
class Notice:
    """Something the monitor noticed: ``text`` in words, ``at`` the ground clock, and
    ``flight_s`` the seconds into the flight by the vehicle's clock (None: after a restart,
    on a clock of its own)."""

    kind: NoticeKind
    text: str
    at: float
    flight_s: float | None

    @property
    def takeover(self) -> bool:
        return self.kind in TAKEOVERS

    def line(self) -> str:
        """``1 min 12 s into the flight: <text>``."""
        if self.flight_s is None:
            return self.text
        return f"{flight_clock(self.flight_s)} into the flight: {self.text}"


@dataclass(frozen=True)
class WatchRules:
    """How :class:`MonitorMachine` reads a flight (docs/flying.md, Monitoring and Endings).

    ``quiet_s`` (ground seconds): nothing heard for this long is said at once (the link may
    be lost; it counts as lost after ``FlightTimeouts.link_s``). ``takeover_wait_s`` (vehicle
    seconds): how long a mode the ground station did not command (a hold, another ground
    station's GUIDED ...) may last before the watch ends; the mission mode coming back in
    time resumes it. ``fresh_retry_s`` / ``fresh_wait_s`` (ground seconds): after a gap, the
    link's return or a restart the state is asked for again (MAV_CMD_REQUEST_MESSAGE) this
    often, and an ending waits at most this long for the answers before it is decided on
    what there is (saying what was not confirmed). ``home_moved_m``: how far (horizontal,
    vertical) HOME_POSITION may move before it is a new home. ``other_command_s``: an
    accepted mode command the vehicle acknowledged to another ground station this recently
    explains a mode change."""

    quiet_s: float = 2.0
    takeover_wait_s: float = 30.0
    fresh_retry_s: float = 1.0
    fresh_wait_s: float = 5.0
    home_moved_m: tuple[float, float] = (10.0, 3.0)
    other_command_s: float = 5.0

    def __post_init__(self) -> None:
        for name in ("quiet_s", "takeover_wait_s", "fresh_retry_s", "fresh_wait_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number of seconds, got {value!r}")


#: the telemetry :class:`MonitorMachine` asks for, with its interval (µs): the position at
#: 5 Hz (QGroundControl's rate for GLOBAL_POSITION_INT), the rest at 1 Hz
STREAMS = (
    (MessageId.GLOBAL_POSITION_INT, 200_000),
    (MessageId.MISSION_CURRENT, 1_000_000),
    (MessageId.EXTENDED_SYS_STATE, 1_000_000),
    (MessageId.SYS_STATUS, 1_000_000),
    (MessageId.BATTERY_STATUS, 1_000_000),
    (MessageId.HOME_POSITION, 1_000_000),
)

#: what is asked for again (MAV_CMD_REQUEST_MESSAGE) before a decision after a gap
FRESH_MESSAGES = (
    MessageId.HEARTBEAT,
    MessageId.MISSION_CURRENT,
    MessageId.EXTENDED_SYS_STATE,
    MessageId.GLOBAL_POSITION_INT,
    MessageId.HOME_POSITION,
)

#: commands (and SET_MODE, message 11, which ArduPilot acknowledges as command 11) whose
#: acceptance by another ground station explains a change of mode
_MODE_COMMANDS = frozenset(
    {
        int(MavCommand.DO_SET_MODE),
        int(MavCommand.NAV_RETURN_TO_LAUNCH),
        int(MavCommand.NAV_LAND),
        int(MavCommand.MISSION_START),
        int(MavCommand.COMPONENT_ARM_DISARM),
        11,
    }
)

#: messages a landed mission's monitor waits for a position report before it ends anyway
SETTLE_MESSAGES = 20
_EARTH_RADIUS_M = 6_371_000.0


def _home_offset_m(
    a: tuple[float, float, float], b: tuple[float, float, float]
) -> tuple[float, float]:
    """Horizontal and vertical distance between two homes (lat, lon, alt): a local flat
    approximation, metres apart matter here, not kilometres."""
    lat = math.radians((a[0] + b[0]) / 2.0)
    north = math.radians(b[0] - a[0]) * _EARTH_RADIUS_M
    east = math.radians(b[1] - a[1]) * _EARTH_RADIUS_M * math.cos(lat)
    return math.hypot(north, east), b[2] - a[2]


class MonitorMachine(FlightMachine):
    """Follow the flight until it ends (:class:`MonitorEnd`).

    ``last_seq``: the mission's last item (wire seq); ``lands``: the mission ends on the
    ground (a landing or a return to launch); ``return_seq`` / ``land_seq``: where the
    mission's own return to launch / landing begins (the modes the vehicle switches to by
    itself there are not a change). Done when the vehicle has flown, the mission is complete
    (MISSION_CURRENT's mission_state, or the last item reached, or the return or landing
    begun after the last item) and the vehicle is down (landed state, or disarmed); with a
    mission that does not land, when the last item is reached.

    On the way it notices (:attr:`VehicleState.notices`) the link going quiet and coming
    back, gaps, a restart, a mode it did not command (and by whom, when the vehicle
    acknowledged it to another ground station), a new mission, fence or home, and a disarm
    in the air. After a gap, the link's return, a restart or a disarm it asks for the state
    again and decides nothing until the answers came (:class:`WatchRules`): a restart, a new
    mission and a disarm in the air then end the watch; a mode that is not the mission's
    ends it after ``takeover_wait_s`` unless the mission resumes (a return or a landing is
    watched to the ground).
    """

    def __init__(
        self,
        state: VehicleState,
        target: tuple[int, int],
        timeouts: FlightTimeouts,
        *,
        last_seq: int,
        lands: bool,
        return_seq: int | None = None,
        land_seq: int | None = None,
        rules: WatchRules | None = None,
    ) -> None:
        super().__init__(state, target, timeouts)
        self.last_seq = last_seq
        self.lands = lands
        self.return_seq = return_seq
        self.land_seq = land_seq
        self.rules = rules or WatchRules()
        self._settling = 0
        self._last_message_at = -math.inf
        self._quiet = False
        self._fresh_since: float | None = None
        self._fresh_asked_at = -math.inf
        self._pending: MonitorEnd | None = None
        self._disarm_check = False
        self._stable_custom = state.custom_mode
        self._last_hb_custom: int | None = None
        self._armed_stable: bool | None = True if state.armed else None
        self._last_hb_armed: bool | None = None
        self._total: int | None = None
        self._new_total: int | None = None
        self._home = state.home
        self._new_home: tuple[float, float, float] | None = None
        #: every gap since the recording began is said, those of the start sequence (arming,
        #: the mode change) too: the track holds them. Only the ones after this watch began
        #: need the state asked for again.
        self._gaps_seen = 0
        self._gaps_before = len(state.gaps)
        self._restarts_seen = len(state.restarts)
        self._others: list[tuple[float, int, int, int]] = []
        #: a mode change said without its author (when, the mode, what fly does about it):
        #: the other station's acknowledgement can arrive just after the heartbeat
        self._unattributed: tuple[float, FlightMode | None, str, str] | None = None
        #: the mode the ground station did not command, while the vehicle is in it
        self.foreign_mode: FlightMode | None = None
        #: the vehicle's clock when a foreign hold began (None: none, or a return / landing)
        self.held_since_s: float | None = None
        #: kinds of state not confirmed when an ending had to be decided without them
        self.unconfirmed: list[str] = []
        #: the furthest mission item the vehicle flew to while armed, in this boot: ArduPilot
        #: sets its current item back to the first when it disarms after the landing, and
        #: that MISSION_CURRENT can arrive before the heartbeats that say it disarmed
        self.furthest_seq = -1

    # -- helpers --------------------------------------------------------------------------
    def _flight_s(self) -> float | None:
        s = self.state
        if s.epoch != 0 or s.newest_s is None:
            return None
        return s.since_origin(s.newest_s)

    def _notice(self, kind: NoticeKind, text: str, now: float) -> None:
        self.state.notices.append(Notice(kind, text, now, self._flight_s()))

    def _streams(self) -> list[Message]:
        return [
            self.command(MavCommand.SET_MESSAGE_INTERVAL, [float(message), float(interval)])
            for message, interval in STREAMS
        ]

    def _ask_fresh(self, now: float, *, restart: bool = False) -> list[Message]:
        """Ask for the state again; decisions wait for the answers (:meth:`_fresh`)."""
        if restart or self._fresh_since is None:
            self._fresh_since = now
        if now - self._fresh_asked_at < 0.2 and not restart:
            return []
        self._fresh_asked_at = now
        out = self._streams() if restart else []  # a restarted vehicle forgot the intervals
        return out + self.request_messages(FRESH_MESSAGES)

    def _fresh(self, now: float) -> bool:
        since = self._fresh_since
        if since is None:
            return True
        missing = self.state.not_heard_since(since)
        if missing and now - since < self.rules.fresh_wait_s:
            return False
        self.unconfirmed = missing
        self._fresh_since = None
        return True

    def _who(self, now: float) -> str:
        recent = [o for o in self._others if now - o[0] <= self.rules.other_command_s]
        if recent:
            _, _command, system, component = recent[-1]
            return f"commanded by another ground station (system {system}, component {component})"
        return "not commanded by this ground station"

    @property
    def mission_done(self) -> bool:
        s = self.state
        if s.mission_state == MissionState.COMPLETE and s.flew:
            return True
        if self.last_seq in s.reached:
            return True
        at_end = s.current_seq >= self.last_seq
        landed_on_the_last = self.furthest_seq >= self.last_seq and s.epoch == 0
        if (
            (at_end or landed_on_the_last)
            and self.lands
            and (s.landed_state == LandedState.ON_GROUND or not s.armed)
        ):
            # down on the last item of a mission that ends on the ground: that item is the
            # landing (or the return that lands), and it is done; the vehicle's word that the
            # mission is complete may come after its disarm (ArduPilot disarms on touchdown)
            return s.flew
        return at_end and s.mode is not None and s.mode.kind in (ModeKind.RETURN, ModeKind.LAND)

    def _expected(self, mode: FlightMode | None) -> bool:
        """A mode the mission itself leads to where the vehicle is in it."""
        if mode is None:
            return False
        s = self.state
        kind = mode.kind
        if kind is ModeKind.MISSION:
            return True
        done = self.mission_done
        if kind is ModeKind.RETURN:
            return done or (self.return_seq is not None and s.current_seq >= self.return_seq)
        if kind is ModeKind.LAND:
            return done or (self.land_seq is not None and s.current_seq >= self.land_seq)
        if kind is ModeKind.HOLD:
            return done  # PX4 holds once a mission that does not land is done
        return False

    # -- the machine ----------------------------------------------------------------------
    def start(self, now: float) -> list[Message]:
        self._last_message_at = now
        self._set_deadline(now)
        return self._streams()

    def _set_deadline(self, now: float) -> None:
        last = self._last_message_at
        deadline = last + self.timeouts.link_s
        if not self._quiet:
            deadline = min(deadline, last + self.rules.quiet_s)
        if self._fresh_since is not None:
            deadline = min(
                deadline,
                self._fresh_asked_at + self.rules.fresh_retry_s,
                self._fresh_since + self.rules.fresh_wait_s,
            )
        self.deadline = max(deadline, now + 0.01)

    def handle(self, message: Message, now: float) -> list[Message]:
        s = self.state
        out: list[Message] = []
        if s.armed and s.epoch == 0 and s.current_seq is not None:
            self.furthest_seq = max(self.furthest_seq, s.current_seq)
        silent = now - self._last_message_at
        self._last_message_at = now
        if self._quiet or silent >= self.rules.quiet_s:
            self._quiet = False
            self._notice(
                NoticeKind.LINK_BACK, f"the link is back after {silent:.1f} s of silence", now
            )
            out += self._ask_fresh(now)
        if len(s.restarts) > self._restarts_seen:
            self._restarts_seen = len(s.restarts)
            r = s.restarts[-1]
            self._notice(
                NoticeKind.RESTART,
                f"the vehicle restarted: its clock went back from {r.before_s:.1f} s to "
                f"{r.after_s:.1f} s since boot",
                now,
            )
            self._pending = self._pending or MonitorEnd.RESTARTED
            out += self._ask_fresh(now, restart=True)
        while self._gaps_seen < len(s.gaps):
            start, end = s.gaps[self._gaps_seen]
            self._gaps_seen += 1
            self._notice(
                NoticeKind.GAP,
                f"no telemetry from {flight_clock(s.since_origin(start))} to "
                f"{flight_clock(s.since_origin(end))} into the flight ({end - start:.1f} s)",
                now,
            )
            if self._gaps_seen > self._gaps_before:
                out += self._ask_fresh(now)
        if isinstance(message, Heartbeat):
            out += self._on_heartbeat(now)
        elif isinstance(message, MissionCurrent):
            out += self._on_mission_current(message, now)
        elif isinstance(message, HomePosition):
            self._on_home(now)
        if self._fresh_since is not None and now - self._fresh_asked_at >= self.rules.fresh_retry_s:
            self._fresh_asked_at = -math.inf
            out += self._ask_fresh(now)
        self._decide(message, now)
        self._set_deadline(now)
        return out

    def on_overheard(self, received: Received, now: float) -> list[Message]:
        m = received.message
        if isinstance(m, CommandAck):
            if m.command in _MODE_COMMANDS and m.result in (MavResult.ACCEPTED, 5):
                # 5: MAV_RESULT_IN_PROGRESS
                self._others.append((now, m.command, m.target_system, m.target_component))
                del self._others[:-8]
                late = self._unattributed
                if late is not None and now - late[0] <= self.rules.other_command_s:
                    _when, mode, name, then = late
                    if mode is not None and mode == self.foreign_mode:
                        self._notice(
                            NoticeKind.MODE_CHANGED,
                            f"the vehicle switched to {name}, {self._who(now)}; {then}",
                            now,
                        )
                self._unattributed = None
            return []
        if isinstance(m, MissionAck) and m.type == MissionResult.ACCEPTED:
            who = (
                f"another ground station (system {m.target_system}, component {m.target_component})"
            )
            if m.mission_type == 0:
                if self._pending is None and self.finished is None:
                    self._notice(
                        NoticeKind.MISSION_CHANGED,
                        f"{who} replaced the vehicle's mission (its upload or clear was "
                        "accepted): the vehicle no longer flies this one",
                        now,
                    )
                    self._pending = MonitorEnd.MISSION_CHANGED
                    return self._ask_fresh(now)
            else:
                what = "geofence" if m.mission_type == 1 else "rally points"
                self._notice(NoticeKind.PLAN_CHANGED, f"{who} replaced the vehicle's {what}", now)
        return []

    def _on_heartbeat(self, now: float) -> list[Message]:
        s = self.state
        out: list[Message] = []
        custom, armed = s.custom_mode, s.armed
        # a change counts once two heartbeats in a row say it (a late copy of an old one
        # says nothing new)
        if custom == self._last_hb_custom and custom != self._stable_custom:
            self._stable_custom = custom
            self._mode_changed(now)
        self._last_hb_custom = custom
        if self._armed_stable is None:
            self._armed_stable = armed  # the first word on it
        elif armed == self._last_hb_armed and armed != self._armed_stable:
            self._armed_stable = armed
            if not armed and s.flew:
                # where did it disarm: on the ground (a landing) or in the air? ask
                self._disarm_check = True
                out += self._ask_fresh(now)
        self._last_hb_armed = armed
        return out

    def _mode_changed(self, now: float) -> None:
        s = self.state
        mode = s.mode
        if (self.mission_done and s.on_ground) or s.epoch != 0:
            return  # the flight is over, or the vehicle restarted: a new boot's mode
        if self._expected(mode):
            if self.foreign_mode is not None and mode is not None:
                self._notice(
                    NoticeKind.MISSION_RESUMED,
                    f"the vehicle is back in {mode.name}: the mission goes on",
                    now,
                )
            self.foreign_mode = None
            self.held_since_s = None
            return
        name = mode.name if mode is not None else f"custom mode {s.custom_mode}"
        kind = None if mode is None else mode.kind
        self.foreign_mode = mode
        if kind in (ModeKind.RETURN, ModeKind.LAND):
            self.held_since_s = None
            then = "watching it to the ground"
        else:
            self.held_since_s = s.newest_s
            then = (
                f"waiting up to {self.rules.takeover_wait_s:g} s of the vehicle's time for "
                "the mission to go on"
            )
        who = self._who(now)
        self._notice(NoticeKind.MODE_CHANGED, f"the vehicle switched to {name}, {who}; {then}", now)
        self._unattributed = None if self._others_recent(now) else (now, mode, name, then)

    def _others_recent(self, now: float) -> bool:
        return any(now - o[0] <= self.rules.other_command_s for o in self._others)

    def _on_mission_current(self, message: MissionCurrent, now: float) -> list[Message]:
        total = message.total
        if self.state.epoch != 0:
            return []  # a restarted vehicle's count: the restart says it all
        if self._total is None:
            self._total = total
            return []
        if total == self._total:
            self._new_total = None
            return []
        if total != self._new_total:
            self._new_total = total  # once more before it counts: not a late copy
            return []
        if self._pending is not None or self.finished is not None:
            return []
        self._notice(
            NoticeKind.MISSION_CHANGED,
            f"the vehicle holds another mission now (MISSION_CURRENT counts {total} items "
            f"where it counted {self._total}), {self._who(now)}: it no longer flies this one",
            now,
        )
        self._pending = MonitorEnd.MISSION_CHANGED
        return self._ask_fresh(now)

    def _on_home(self, now: float) -> None:
        home = self.state.home
        if home is None or self.state.epoch != 0:
            return
        if self._home is None:
            self._home = home
            return
        horizontal, vertical = _home_offset_m(self._home, home)
        limit_h, limit_v = self.rules.home_moved_m
        if horizontal <= limit_h and abs(vertical) <= limit_v:
            self._new_home = None
            return
        if self._new_home != home:
            self._new_home = home  # once more before it counts
            return
        self._notice(
            NoticeKind.HOME_MOVED,
            f"the vehicle's home moved {horizontal:.1f} m ({vertical:+.1f} m) to "
            f"{home[0]:.7f}, {home[1]:.7f}, {home[2]:.1f} m AMSL, {self._who(now)}: a return "
            "to launch now flies there",
            now,
        )
        self._home = home
        self._new_home = None

    def _decide(self, message: Message | None, now: float) -> None:
        s = self.state
        if self.finished is not None or not self._fresh(now):
            return
        if self._pending is not None:
            self.finished = self._pending
            return
        if self._disarm_check:
            self._disarm_check = False
            high = s.position is not None and s.position.relative_alt_m > 2.0
            if not s.armed and (
                s.landed_state == LandedState.IN_AIR
                or (high and s.landed_state != LandedState.ON_GROUND)
            ):
                self._notice(
                    NoticeKind.DISARMED,
                    f"the vehicle disarmed in the air, {self._who(now)}: it was last "
                    f"{s.describe()}",
                    now,
                )
                self.finished = MonitorEnd.DISARMED_IN_AIR
                return
        held = self.held_since_s
        if held is not None and s.newest_s is not None and s.epoch == 0:
            if s.newest_s - held >= self.rules.takeover_wait_s:
                self.finished = MonitorEnd.HELD
                return
        if not s.flew:
            return
        # down: the vehicle says it is on the ground, or two heartbeats say it disarmed and
        # the state asked for since says it is not in the air
        disarmed = self._armed_stable is False and not self._disarm_check
        down = s.landed_state == LandedState.ON_GROUND or disarmed
        if self.lands and self.mission_done and down:
            # done once a position report shows where it came down (the track's last sample,
            # which the take-off-to-touchdown time reads), or a few messages on without one
            self._settling += 1
            if isinstance(message, GlobalPositionInt) or self._settling > SETTLE_MESSAGES:
                self.finished = MonitorEnd.COMPLETE
        elif not self.lands and self.mission_done:
            self.finished = MonitorEnd.COMPLETE_IN_AIR if not down else MonitorEnd.COMPLETE
        elif disarmed:
            self.finished = MonitorEnd.LANDED_EARLY

    def on_timeout(self, now: float) -> list[Message]:
        s = self.state
        out: list[Message] = []
        silent = now - self._last_message_at
        if silent >= self.timeouts.link_s:
            self.finished = MonitorEnd.LINK_LOST
            return []
        if not self._quiet and silent >= self.rules.quiet_s:
            self._quiet = True
            self._notice(
                NoticeKind.LINK_QUIET,
                f"nothing heard from the vehicle for {silent:.1f} s (the link counts as lost "
                f"after {self.timeouts.link_s:g} s); it was last {s.describe()}",
                now,
            )
        if self._fresh_since is not None and now - self._fresh_asked_at >= self.rules.fresh_retry_s:
            self._fresh_asked_at = -math.inf
            out += self._ask_fresh(now)
        self._decide(None, now)
        self._set_deadline(now)
        return out
