"""A simulated vehicle: heartbeats and the vehicle side of the mission protocol.

:class:`MockVehicle` is a real MAVLink 2 endpoint (UDP or TCP, any connection string of
:mod:`.transport`), so QGroundControl, MAVProxy, MAVSDK or our own client can talk to it.
It holds a mission, a geofence and rally points; it sends HEARTBEAT and MISSION_CURRENT at
1 Hz, answers AUTOPILOT_VERSION requests with the MISSION_INT / MISSION_FENCE /
MISSION_RALLY capability bits (MAVSDK refuses transfers without MISSION_INT), and behaves
like PX4 or ArduPilot where they differ (reference §4):

=============================  ==============================  ================================
topic                          ``px4``                         ``ardupilot``
=============================  ==============================  ================================
first upload request           MISSION_REQUEST (float) until   always MISSION_REQUEST (float)
                               it sees an INT message or an
                               UNSUPPORTED ack, then _INT
out-of-sequence item           ignored silently                MISSION_ACK INVALID_SEQUENCE
repeated COUNT                 before item 0: request 0 again; restarts the upload
                               after: ERROR "Busy"
upload while busy              ERROR                           DENIED
download while uploading       ignored + STATUSTEXT            DENIED
download requests              strictly in order (next or      any seq; seq >= count: COUNT
                               repeat), else ERROR + idle      then ERROR
repeated last item after ACK   ACCEPTED again                  ignored
clear while busy               ignored + STATUSTEXT            ERROR; type ALL: UNSUPPORTED
cancel (OPERATION_CANCELLED)   honoured                        ignored (times out after 8 s)
mission seq 0                  first item                      home: downloads return
                                                               ``config.home`` when set
download frames, altitude      as uploaded                     0/3/10 spellings, z to 1 cm,
                                                               autocontinue 1
item limits                    500 / 64 / 32                   700 / 84 / 100
=============================  ==============================  ================================

One deliberate departure from ArduPilot: replacement is atomic for every plan type and both
flavours (the issue's contract: a failed upload keeps the old plan), while real ArduPilot
truncates its mission at MISSION_COUNT (reference §4.8).

Re-request timing: with ``firmware_timing`` the vehicle re-requests a missing item exactly
as the firmware does (PX4 every 250 ms, ArduPilot every 1 s). By default it re-requests
after ``srtt + 4 x rttvar`` of the measured request->item round trip (floor 10 ms), with
the firmware interval as the ceiling: a loopback link is not a 57600-baud radio, and lossy
tests and benchmarks then measure the protocol rather than a radio timer.

Packet faults live apart, in :mod:`.linkfaults` (:class:`~.linkfaults.LinkFaults` drops,
duplicates or reorders packets each way with a seeded ``numpy.random.Generator``); here
:class:`MissionFaults` makes the vehicle misbehave on purpose (error ACK at an item,
out-of-range request, early ACCEPTED, falling silent).
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from struct import error as struct_error

from uavplan.geo import GeoPoint
from uavplan.mavlink.connection import MavlinkConnection
from uavplan.mavlink.linkfaults import MISSION_PROTOCOL_MESSAGES as MISSION_PROTOCOL_MESSAGES
from uavplan.mavlink.linkfaults import FaultInjector, LinkFaults
from uavplan.mavlink.messages import (
    AUTOPILOT_VERSION_ID,
    COMP_ID_MISSIONPLANNER,
    AutopilotVersion,
    Capability,
    CommandAck,
    CommandLong,
    Heartbeat,
    MalformedMessage,
    MavAutopilotId,
    MavCommand,
    MavResult,
    MavType,
    Message,
    MissionAck,
    MissionClearAll,
    MissionCount,
    MissionCurrent,
    MissionItemInt,
    MissionRequest,
    MissionRequestList,
    MissionResult,
    MissionSetCurrent,
    Received,
    StatusText,
    message_name,
)
from uavplan.mavlink.protocol import RoundTripEstimator, item_from_wire, item_to_wire
from uavplan.mavlink.transport import ConnectionSpec
from uavplan.mission.items import (
    Autopilot,
    MavCmd,
    MavFrame,
    MissionItem,
    MissionType,
    canonical_frame,
    deg_to_e7,
)

#: (mission, fence, rally) capacity of the mock per flavour
ITEM_LIMITS: dict[Autopilot, tuple[int, int, int]] = {
    Autopilot.PX4: (500, 64, 32),
    Autopilot.ARDUPILOT: (700, 84, 100),
}
#: firmware re-request interval while receiving (PX4 MAVLINK_MISSION_RETRY_TIMEOUT_DEFAULT,
#: ArduPilot 1000 ms) and the silence after which a transfer is dropped (PX4 5 s, ArduPilot 8 s)
FIRMWARE_RETRY_S = {Autopilot.PX4: 0.25, Autopilot.ARDUPILOT: 1.0}
FIRMWARE_TRANSFER_TIMEOUT_S = {Autopilot.PX4: 5.0, Autopilot.ARDUPILOT: 8.0}
#: adaptive re-requests: floor, interval before the first round-trip sample, back-off factor
MIN_RETRY_S = 0.01
INITIAL_RETRY_S = 0.05
RETRY_BACKOFF = 1.5


_FENCE_COMMANDS = frozenset(range(5000, 5005))
_POLYGON_COMMANDS = frozenset({5001, 5002})
_RALLY_COMMANDS = {Autopilot.PX4: frozenset({5100, 31}), Autopilot.ARDUPILOT: frozenset({5100})}
_PX4_FRAMES = frozenset({0, 2, 3, 5, 6})
_ARDUPILOT_FRAMES = frozenset({0, 2, 3, 5, 6, 10, 11})
#: ArduPilot allows NaN only in param4 (yaw) of these commands (AP_Mission::sanity_check_params)
_ARDUPILOT_NAN_PARAM4 = frozenset({16, 17, 21, 22, 84})

# STATUSTEXT severities
_CRITICAL, _WARNING, _INFO = 2, 4, 6


@dataclass(frozen=True)
class MissionFaults:
    """Deliberate protocol misbehaviour, for the fault-matrix tests (all off by default)."""

    reject_at_seq: int | None = None  # answer this item with ``reject_result`` and abort
    reject_result: MissionResult = MissionResult.INVALID_PARAM1
    out_of_range_after_seq: int | None = None  # after this item, request seq = count + 2
    accept_early_after_seq: int | None = None  # after this item, send ACCEPTED and stop
    silent_after_seq: int | None = None  # after this item, stop requesting (no ACK either)
    ignore_requests: bool = False  # never answer COUNT / REQUEST_LIST / CLEAR_ALL


@dataclass(frozen=True)
class MockConfig:
    autopilot: Autopilot = Autopilot.PX4
    system_id: int = 1
    component_id: int = 1
    heartbeat_period_s: float = 1.0
    send_heartbeats: bool = True
    home: GeoPoint | None = None  # ArduPilot: what a download returns as seq 0
    firmware_timing: bool = False
    #: AUTOPILOT_VERSION.capabilities to report; None: MISSION_FLOAT/INT, COMMAND_INT,
    #: MAVLINK2, MISSION_FENCE and MISSION_RALLY
    capabilities: int | None = None
    link_faults: LinkFaults = field(default_factory=LinkFaults)
    mission_faults: MissionFaults = field(default_factory=MissionFaults)

    def __post_init__(self) -> None:
        if self.autopilot not in ITEM_LIMITS:
            raise ValueError("the mock vehicle is px4 or ardupilot")
        if self.heartbeat_period_s <= 0:
            raise ValueError("heartbeat_period_s must be positive")


@dataclass
class _Receiving:
    partner: tuple[int, int]
    mission_type: int
    count: int
    next_seq: int = 0
    items: list[MissionItemInt] = field(default_factory=list)
    last_recv: float = 0.0
    last_request: float = 0.0
    request_is_retry: bool = False
    consecutive_retries: int = 0
    int_mode: bool = True
    silent: bool = False
    requested_seq: int = 0


@dataclass
class _Sending:
    partner: tuple[int, int]
    mission_type: int
    count: int
    next_seq: int = 0
    last_recv: float = 0.0


@dataclass(frozen=True)
class MockStats:
    uploads_accepted: int
    uploads_failed: int
    downloads_served: int
    clears: int
    dropped_in: int
    dropped_out: int
    duplicated: int
    reordered: int


def _whole_number(value: float) -> int | None:
    """A COMMAND_LONG param that must hold a whole number, or ``None`` (NaN, inf, 2.5)."""
    if not math.isfinite(value) or value != math.floor(value) or abs(value) > 2**31:
        return None
    return int(value)


class MockVehicle:
    """A simulated PX4 or ArduPilot vehicle on a real MAVLink endpoint.

    Use as a context manager (or :meth:`start` / :meth:`stop`) to run it in a background
    thread, or call :meth:`run` in the foreground until a :class:`threading.Event` is set.
    """

    def __init__(self, conn: str | ConnectionSpec, config: MockConfig | None = None) -> None:
        self.config = config or MockConfig()
        c = self.config
        self.connection = MavlinkConnection.open(
            conn, system_id=c.system_id, component_id=c.component_id
        )
        self._faults = FaultInjector(c.link_faults)
        self._lock = threading.Lock()
        #: notified after every message and timer pass, for :meth:`wait_for`
        self._changed = threading.Condition()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._storage: dict[int, list[MissionItemInt]] = {0: [], 1: [], 2: []}
        self._receiving: _Receiving | None = None
        self._sending: _Sending | None = None
        self._last_completed: tuple[tuple[int, int], int, int] | None = None
        self._current_seq = 0
        self._rtt = RoundTripEstimator()
        self._uploads_accepted = self._uploads_failed = self._downloads = self._clears = 0
        self.error: BaseException | None = None
        #: messages whose handling failed (hostile or broken input), and the last reason
        self.rejected_messages = 0
        self.last_rejection: str | None = None

    # -- public ---------------------------------------------------------------------------
    @property
    def address(self) -> tuple[str, int]:
        """(host, port) the vehicle listens on (port chosen by the OS for port 0)."""
        addr = self.connection.local_address
        if addr is None:
            raise RuntimeError("this endpoint does not listen")
        host = "127.0.0.1" if addr[0] in ("0.0.0.0", "") else addr[0]
        return host, addr[1]

    @property
    def autopilot(self) -> Autopilot:
        return self.config.autopilot

    def wire_items(self, mission_type: MissionType) -> list[MissionItemInt]:
        """What the vehicle stores for that plan type, as received."""
        with self._lock:
            return list(self._storage[int(mission_type)])

    def items(self, mission_type: MissionType) -> list[MissionItem]:
        """The stored plan type as MissionItems (seq = index; ArduPilot's home included)."""
        return [item_from_wire(w) for w in self.wire_items(mission_type)]

    def preload(self, mission_type: MissionType, items: list[MissionItem]) -> None:
        """Store a plan as if it had been uploaded (for download tests)."""
        sysid, compid = self.config.system_id, self.config.component_id
        wire = [item_to_wire(it, seq, mission_type, sysid, compid) for seq, it in enumerate(items)]
        with self._lock:
            self._storage[int(mission_type)] = wire

    def set_link_faults(self, faults: LinkFaults) -> None:
        """Change the packet faults while running (the generators keep their state)."""
        self._faults.faults = faults

    def wait_for(self, predicate: Callable[[MockVehicle], bool], timeout_s: float) -> bool:
        """Block until ``predicate(self)`` holds (checked after each message the vehicle
        handles and each timer pass) or ``timeout_s`` passes; returns whether it holds.
        Tests wait for a state this way instead of sleeping."""
        with self._changed:
            return self._changed.wait_for(lambda: predicate(self), timeout_s)

    @property
    def busy(self) -> bool:
        return self._receiving is not None or self._sending is not None

    def stats(self) -> MockStats:
        f = self._faults
        return MockStats(
            self._uploads_accepted,
            self._uploads_failed,
            self._downloads,
            self._clears,
            f.dropped_in,
            f.dropped_out,
            f.duplicated,
            f.reordered,
        )

    def start(self) -> MockVehicle:
        if self._thread is not None:
            raise RuntimeError("already started")
        self._thread = threading.Thread(target=self._run_guarded, name="mock-vehicle", daemon=True)
        self._thread.start()
        return self

    def stop(self, timeout_s: float = 5.0) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout_s)
            self._thread = None
        self.connection.close()

    def __enter__(self) -> MockVehicle:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def run(self, stop: threading.Event | None = None) -> None:
        """Serve in the calling thread until ``stop`` (or :meth:`stop`) is set."""
        if stop is not None:
            self._stop = stop
        self._serve()

    # -- main loop ------------------------------------------------------------------------
    def _run_guarded(self) -> None:
        try:
            self._serve()
        except BaseException as err:  # surfaced to tests through .error
            self.error = err

    def _serve(self) -> None:
        c = self.config
        next_heartbeat = time.monotonic()
        next_current = time.monotonic() + 0.5
        while not self._stop.is_set():
            now = time.monotonic()
            if now >= next_heartbeat:
                self._send_heartbeat()
                next_heartbeat = now + c.heartbeat_period_s
            if now >= next_current:
                self._send_mission_current()
                next_current = now + 1.0
            self._timers(now)
            self._notify()
            wake = min(next_heartbeat, next_current, now + 0.05, self._next_timer(now))
            received = self.connection.recv(max(0.0, wake - time.monotonic()))
            if received is None:
                self._flush_held()
                continue
            copies = self._faults.inbound_copies(received.message)
            for _ in range(copies):
                self._handle_safely(received)
            self._notify()

    def _notify(self) -> None:
        with self._changed:
            self._changed.notify_all()

    def _handle_safely(self, received: Received) -> None:
        """One message; anything it could break is caught here so the vehicle keeps serving
        (a hostile packet costs that packet only, never the stored plans)."""
        try:
            self._handle(received)
        except (ArithmeticError, ValueError, TypeError, struct_error) as err:
            self.rejected_messages += 1
            self.last_rejection = f"{message_name(received.message)}: {err}"

    # -- sending --------------------------------------------------------------------------
    def _send(self, message: Message) -> None:
        self._faults.send(self.connection, message)

    def _flush_held(self) -> None:
        self._faults.flush(self.connection)

    def _send_heartbeat(self) -> None:
        if not self.config.send_heartbeats:
            return
        px4 = self.config.autopilot == Autopilot.PX4
        self._send(
            Heartbeat(
                type=MavType.QUADROTOR,
                autopilot=MavAutopilotId.PX4 if px4 else MavAutopilotId.ARDUPILOTMEGA,
                base_mode=1,  # MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
                system_status=3,  # MAV_STATE_STANDBY
            )
        )

    def _ack(self, partner: tuple[int, int], result: MissionResult, mission_type: int) -> None:
        self._send(MissionAck(partner[0], partner[1], int(result), mission_type))

    def _text(self, severity: int, text: str) -> None:
        self._send(StatusText(severity, text))

    def _send_mission_current(self) -> None:
        count = len(self._storage[0])
        if self.config.autopilot == Autopilot.PX4:
            total = count if count else 65535
        else:
            total = max(0, count - 1)
        state = 2 if count else 1  # MISSION_STATE_NOT_STARTED / NO_MISSION
        self._send(MissionCurrent(self._current_seq, total, state, 0))

    # -- dispatch -------------------------------------------------------------------------
    def _addressed_to_us(self, message: Message) -> bool:
        target_system = getattr(message, "target_system", None)
        if target_system is None:
            return True
        if target_system not in (0, self.config.system_id):
            return False
        target_component = getattr(message, "target_component", 0)
        accepted = {0, self.config.component_id}
        if self.config.autopilot == Autopilot.PX4:
            accepted.add(COMP_ID_MISSIONPLANNER)
        return target_component in accepted

    def _handle(self, received: Received) -> None:
        message = received.message
        partner = (received.system_id, received.component_id)
        if isinstance(message, Heartbeat):
            if message.type == MavType.GCS:
                # answer a ground station's heartbeat at once instead of at the next 1 Hz
                # tick, so connecting takes a round trip, not up to a second (only a GCS's:
                # two vehicles must not echo each other)
                self._send_heartbeat()
            return
        if isinstance(message, StatusText) or not self._addressed_to_us(message):
            return
        if isinstance(message, CommandLong):
            self._on_command(partner, message)
            return
        if isinstance(message, MissionSetCurrent):
            self._on_set_current(message.seq)
            return
        if self.config.mission_faults.ignore_requests and isinstance(
            message, MissionCount | MissionRequestList | MissionClearAll
        ):
            return
        if isinstance(message, MissionCount):
            self._on_count(partner, message)
        elif isinstance(message, MissionItemInt):
            self._on_item(partner, message)
        elif isinstance(message, MalformedMessage):
            self._on_malformed(partner, message)
        elif isinstance(message, MissionRequestList):
            self._on_request_list(partner, message)
        elif isinstance(message, MissionRequest):
            self._on_request(partner, message)
        elif isinstance(message, MissionAck):
            self._on_ack(partner, message)
        elif isinstance(message, MissionClearAll):
            self._on_clear(partner, message)

    def _on_command(self, partner: tuple[int, int], cmd: CommandLong) -> None:
        def ack(result: MavResult) -> None:
            self._send(CommandAck(cmd.command, int(result), partner[0], partner[1]))

        wanted = _whole_number(cmd.param1)
        if cmd.command == MavCommand.REQUEST_MESSAGE and wanted is None:
            ack(MavResult.DENIED)  # param1 NaN / inf / fractional: names no message
        elif (
            cmd.command == MavCommand.REQUEST_MESSAGE and wanted == AUTOPILOT_VERSION_ID
        ) or cmd.command == MavCommand.REQUEST_AUTOPILOT_CAPABILITIES:
            ack(MavResult.ACCEPTED)
            self._send(self._autopilot_version())
        elif cmd.command == MavCommand.DO_SET_MISSION_CURRENT:
            if wanted is None:
                ack(MavResult.DENIED)
                return
            seq = wanted
            count = len(self._storage[0])
            if seq == -1 or 0 <= seq < count:
                if seq >= 0:
                    self._current_seq = seq
                ack(MavResult.ACCEPTED)
                self._send_mission_current()
            else:
                ack(MavResult.FAILED)
        else:
            ack(MavResult.UNSUPPORTED)

    def _autopilot_version(self) -> AutopilotVersion:
        caps = self.config.capabilities
        if caps is None:
            caps = (
                Capability.MISSION_FLOAT
                | Capability.MISSION_INT
                | Capability.COMMAND_INT
                | Capability.MAVLINK2
                | Capability.MISSION_FENCE
                | Capability.MISSION_RALLY
            )
        if self.config.autopilot == Autopilot.PX4:
            version = (1 << 24) | (15 << 16) | (0 << 8) | 255  # v1.15.0 official
        else:
            version = (4 << 24) | (5 << 16) | (0 << 8) | 255  # v4.5.0 official
        return AutopilotVersion(
            capabilities=int(caps),
            flight_sw_version=version,
            vendor_id=0x1209,
            product_id=0x5740,
            uid=0x55A0_0000 + self.config.system_id,
        )

    def _on_set_current(self, seq: int) -> None:
        if self.busy:
            self._text(_CRITICAL, "WPM: IGN WP CURR CMD: Busy")
        elif 0 <= seq < len(self._storage[0]):
            self._current_seq = seq
            self._send_mission_current()
        elif self.config.autopilot == Autopilot.PX4:
            self._text(_CRITICAL, "WPM: WP CURR CMD: Not in list")

    # -- upload (vehicle receives) --------------------------------------------------------
    def _limit(self, mission_type: int) -> int:
        return ITEM_LIMITS[self.config.autopilot][mission_type]

    def _on_count(self, partner: tuple[int, int], msg: MissionCount) -> None:
        px4 = self.config.autopilot == Autopilot.PX4
        now = time.monotonic()
        rx = self._receiving
        if msg.mission_type not in (0, 1, 2):
            self._ack(partner, MissionResult.INVALID if px4 else MissionResult.UNSUPPORTED, 0)
            return
        if rx is not None:
            if partner != rx.partner:
                self._ack(
                    partner, MissionResult.ERROR if px4 else MissionResult.DENIED, msg.mission_type
                )
                return
            if px4:
                rx.last_recv = now
                if rx.next_seq == 0 and msg.mission_type == rx.mission_type:
                    self._request(rx, retry=True)  # our request 0 was lost
                else:
                    self._text(_CRITICAL, "WPM: REJ. CMD: Busy")
                    self._ack(partner, MissionResult.ERROR, msg.mission_type)
                return
            self._receiving = None  # ArduPilot: the same sender restarts the upload
        if self._sending is not None:
            if px4:
                self._text(_CRITICAL, "WPM: IGN MISSION_COUNT: Busy")
                self._ack(partner, MissionResult.ERROR, msg.mission_type)
                return
            self._sending = None
        if msg.count > self._limit(msg.mission_type):
            self._ack(partner, MissionResult.NO_SPACE, msg.mission_type)
            if not px4:
                self._text(_WARNING, f"Only {self._limit(msg.mission_type)} items are supported")
            self._uploads_failed += 1
            return
        if msg.count == 0:
            with self._lock:
                self._storage[msg.mission_type] = []
            if msg.mission_type == 0:
                self._current_seq = 0
            self._ack(partner, MissionResult.ACCEPTED, msg.mission_type)
            self._last_completed = None
            self._uploads_accepted += 1
            return
        self._receiving = _Receiving(
            partner=partner,
            mission_type=msg.mission_type,
            count=msg.count,
            last_recv=now,
            int_mode=False,  # PX4 starts in float mode; ArduPilot always requests float
        )
        self._request(self._receiving, retry=False)

    def _request(self, rx: _Receiving, *, retry: bool, seq: int | None = None) -> None:
        rx.requested_seq = rx.next_seq if seq is None else seq
        rx.last_request = time.monotonic()
        rx.request_is_retry = retry
        int_form = rx.int_mode and self.config.autopilot == Autopilot.PX4
        self._send(
            MissionRequest(
                rx.partner[0], rx.partner[1], rx.requested_seq, rx.mission_type, int_form=int_form
            )
        )

    def _validate(self, mission_type: int, item: MissionItemInt) -> MissionResult:
        """The checks a real autopilot makes that matter for a planner (reference §1.7, §4)."""
        px4 = self.config.autopilot == Autopilot.PX4
        cmd, frame = item.command, item.frame
        if mission_type == 0 and (cmd in _FENCE_COMMANDS or cmd == MavCmd.NAV_RALLY_POINT):
            return MissionResult.ERROR if px4 else MissionResult.UNSUPPORTED
        if mission_type == 1 and cmd not in _FENCE_COMMANDS:
            return MissionResult.UNSUPPORTED
        if mission_type == 2 and cmd not in _RALLY_COMMANDS[self.config.autopilot]:
            return MissionResult.UNSUPPORTED
        if frame not in (_PX4_FRAMES if px4 else _ARDUPILOT_FRAMES):
            return MissionResult.UNSUPPORTED_FRAME
        if mission_type == 1 and cmd in _POLYGON_COMMANDS and not (item.param1 >= 3):
            return MissionResult.ERROR
        params = (item.param1, item.param2, item.param3, item.param4)
        if any(math.isinf(p) for p in params):
            return MissionResult(
                MissionResult.INVALID_PARAM1
                + next(i for i, p in enumerate(params) if math.isinf(p))
            )
        if not px4:
            for index, value in enumerate(params):
                if math.isnan(value) and not (index == 3 and cmd in _ARDUPILOT_NAN_PARAM4):
                    return MissionResult(MissionResult.INVALID_PARAM1 + index)
            if not math.isfinite(item.z):
                return MissionResult.INVALID_PARAM7
        if frame in (0, 3, 5, 6, 10, 11) and not (
            -900_000_000 <= item.x <= 900_000_000 and -1_800_000_000 <= item.y <= 1_800_000_000
        ):
            return MissionResult.INVALID_PARAM5_X
        return MissionResult.ACCEPTED

    def _on_item(self, partner: tuple[int, int], item: MissionItemInt) -> None:
        px4 = self.config.autopilot == Autopilot.PX4
        faults = self.config.mission_faults
        rx = self._receiving
        now = time.monotonic()
        if rx is None or partner != rx.partner:
            if rx is None and px4 and self._last_completed is not None:
                done_partner, done_type, done_count = self._last_completed
                if (partner, item.mission_type, item.seq) == (
                    done_partner,
                    done_type,
                    done_count - 1,
                ):
                    # the GCS missed our final ACK and sent the last item again
                    self._ack(partner, MissionResult.ACCEPTED, item.mission_type)
                    return
            if px4:
                self._text(
                    _CRITICAL,
                    "IGN MISSION_ITEM: No transfer" if rx is None else "IGN MISSION_ITEM: Busy",
                )
                self._ack(partner, MissionResult.ERROR, item.mission_type)
            return
        if item.mission_type != rx.mission_type:
            if px4:
                self._ack(partner, MissionResult.ERROR, item.mission_type)
            return
        rx.last_recv = now
        if item.legacy_float:
            rx.int_mode = False
        elif px4:
            rx.int_mode = True
        if rx.silent:
            return
        if item.seq != rx.next_seq:
            if not px4:
                self._ack(partner, MissionResult.INVALID_SEQUENCE, rx.mission_type)
            return
        if not rx.request_is_retry and rx.requested_seq == item.seq:
            self._rtt.add(now - rx.last_request)
        result = self._validate(rx.mission_type, item)
        if faults.reject_at_seq is not None and item.seq == faults.reject_at_seq:
            result = faults.reject_result
        if result != MissionResult.ACCEPTED:
            self._ack(partner, result, rx.mission_type)
            self._receiving = None  # atomic: the stored plan is untouched
            self._uploads_failed += 1
            return
        stored = item
        if not px4:
            # ArduPilot keeps altitude in centimetres and does not store autocontinue
            stored = replace(item, z=round(item.z * 100.0) / 100.0, autocontinue=1)
        rx.items.append(stored)
        rx.next_seq += 1
        rx.consecutive_retries = 0
        if faults.accept_early_after_seq is not None and item.seq == faults.accept_early_after_seq:
            self._ack(partner, MissionResult.ACCEPTED, rx.mission_type)
            self._receiving = None
            return
        if faults.silent_after_seq is not None and item.seq == faults.silent_after_seq:
            rx.silent = True
            return
        if rx.next_seq == rx.count:
            self._commit(rx)
            return
        if faults.out_of_range_after_seq is not None and item.seq == faults.out_of_range_after_seq:
            self._request(rx, retry=False, seq=rx.count + 2)
            return
        self._request(rx, retry=False)

    def _on_malformed(self, partner: tuple[int, int], msg: MalformedMessage) -> None:
        """A mission item whose fields cannot be stored (x = NaN): the item it stands for is
        invalid, so the running upload from that partner is refused, the stored plan kept."""
        self.rejected_messages += 1
        self.last_rejection = f"{msg.name}: {msg.reason}"
        rx = self._receiving
        if (
            rx is None
            or partner != rx.partner
            or msg.name not in ("MISSION_ITEM", "MISSION_ITEM_INT")
            or msg.mission_type != rx.mission_type
            or msg.seq != rx.next_seq
        ):
            return
        self._ack(partner, MissionResult.INVALID_PARAM5_X, rx.mission_type)
        self._receiving = None  # atomic: the stored plan is untouched
        self._uploads_failed += 1

    def _commit(self, rx: _Receiving) -> None:
        if rx.mission_type == 1 and self.config.autopilot == Autopilot.ARDUPILOT:
            # ArduPilot validates the whole fence at the end
            if not self._fence_complete(rx.items):
                self._ack(rx.partner, MissionResult.ERROR, 1)
                self._receiving = None
                self._uploads_failed += 1
                return
        wire = [
            replace(i, seq=n, current=1 if n == 0 else 0, legacy_float=False)
            for n, i in enumerate(rx.items)
        ]
        with self._lock:
            self._storage[rx.mission_type] = wire
        if rx.mission_type == 0:
            self._current_seq = 0
        self._receiving = None
        self._last_completed = (rx.partner, rx.mission_type, rx.count)
        self._uploads_accepted += 1
        self._ack(rx.partner, MissionResult.ACCEPTED, rx.mission_type)

    @staticmethod
    def _fence_complete(items: list[MissionItemInt]) -> bool:
        remaining = 0
        for item in items:
            if item.command in _POLYGON_COMMANDS:
                if remaining == 0:
                    remaining = round(item.param1)
                remaining -= 1
            elif remaining:
                return False
        return remaining == 0

    def _on_ack(self, partner: tuple[int, int], ack: MissionAck) -> None:
        px4 = self.config.autopilot == Autopilot.PX4
        rx, tx = self._receiving, self._sending
        if rx is not None and partner == rx.partner and ack.mission_type == rx.mission_type:
            if not px4:
                return  # ArduPilot does not honour cancel; it times out instead
            rx.last_recv = time.monotonic()
            if ack.type == MissionResult.UNSUPPORTED:
                rx.int_mode = not rx.int_mode  # the GCS wants the other request form
                self._request(rx, retry=True)
            elif ack.type == MissionResult.OPERATION_CANCELLED:
                self._receiving = None
                self._uploads_failed += 1
            return
        if tx is not None and partner == tx.partner and ack.mission_type == tx.mission_type:
            self._sending = None

    def _timers(self, now: float) -> None:
        rx = self._receiving
        ap = self.config.autopilot
        if rx is not None:
            if now - rx.last_recv > FIRMWARE_TRANSFER_TIMEOUT_S[ap]:
                self._receiving = None
                self._uploads_failed += 1
                if ap == Autopilot.PX4:
                    self._text(_CRITICAL, "Operation timeout")
                else:
                    self._ack(rx.partner, MissionResult.OPERATION_CANCELLED, rx.mission_type)
                    name = ("Mission", "Fence", "Rally")[rx.mission_type]
                    self._text(_WARNING, f"{name} upload timeout")
            elif not rx.silent and now - rx.last_request >= self._retry_interval(rx):
                rx.consecutive_retries += 1
                self._request(rx, retry=True, seq=rx.requested_seq)
        tx = self._sending
        if tx is not None and now - tx.last_recv > FIRMWARE_TRANSFER_TIMEOUT_S[ap]:
            self._sending = None
            self._text(_CRITICAL, "Operation timeout")

    def _retry_interval(self, rx: _Receiving) -> float:
        ceiling = FIRMWARE_RETRY_S[self.config.autopilot]
        if self.config.firmware_timing:
            return ceiling
        base = self._rtt.timeout(min(ceiling, INITIAL_RETRY_S), MIN_RETRY_S)
        # gentle back-off after three misses in a row, so a GCS that stalls for a moment is
        # not flooded (MAVSDK gives up on a seq requested more than 5 times)
        return min(ceiling, base * RETRY_BACKOFF ** max(0, rx.consecutive_retries - 3))

    def _next_timer(self, now: float) -> float:
        rx = self._receiving
        if rx is None or rx.silent:
            return now + 0.05
        return rx.last_request + self._retry_interval(rx)

    # -- download (vehicle sends) ---------------------------------------------------------
    def _on_request_list(self, partner: tuple[int, int], msg: MissionRequestList) -> None:
        px4 = self.config.autopilot == Autopilot.PX4
        if msg.mission_type not in (0, 1, 2):
            self._ack(partner, MissionResult.UNSUPPORTED, msg.mission_type)
            return
        if self._receiving is not None:
            if px4:
                self._text(_INFO, "Mission download request ignored, already active")
            else:
                self._ack(partner, MissionResult.DENIED, msg.mission_type)
            return
        count = len(self._storage[msg.mission_type])
        if px4:
            tx = self._sending
            if tx is not None and tx.next_seq >= tx.count:
                self._sending = tx = None  # all sent, ACK missed: a new request may start
            if tx is not None and (tx.partner != partner or tx.mission_type != msg.mission_type):
                self._text(_INFO, "Mission download request ignored, already active")
                return
            self._sending = _Sending(partner, msg.mission_type, count, 0, time.monotonic())
        self._downloads += 1
        self._send(MissionCount(partner[0], partner[1], count, msg.mission_type))

    def _on_request(self, partner: tuple[int, int], msg: MissionRequest) -> None:
        px4 = self.config.autopilot == Autopilot.PX4
        rx = self._receiving
        if rx is not None:
            # a request while *we* are receiving: nonsense from a GCS's point of view
            if px4:
                self._text(_CRITICAL, "WPM: REJ. CMD: Busy")
            else:
                self._ack(partner, MissionResult.DENIED, msg.mission_type)
            return
        stored = self._storage[msg.mission_type] if msg.mission_type in (0, 1, 2) else []
        if px4:
            tx = self._sending
            if tx is None or tx.partner != partner:
                return  # PX4 ignores requests outside a download silently
            if tx.mission_type != msg.mission_type:
                return
            tx.last_recv = time.monotonic()
            if msg.seq == tx.next_seq and tx.next_seq < tx.count:
                tx.next_seq += 1
            elif msg.seq != tx.next_seq - 1:
                self._sending = None
                self._ack(partner, MissionResult.ERROR, msg.mission_type)
                self._text(_CRITICAL, "WPM: REJ. CMD: Req. WP was unexpected")
                return
            if msg.seq >= len(stored):
                self._sending = None
                self._ack(partner, MissionResult.ERROR, msg.mission_type)
                return
            self._send(self._outgoing(stored[msg.seq], partner))
            return
        if msg.seq >= len(stored):
            self._send(MissionCount(partner[0], partner[1], len(stored), msg.mission_type))
            self._ack(partner, MissionResult.ERROR, msg.mission_type)
            return
        self._send(self._outgoing(stored[msg.seq], partner))

    def _outgoing(self, item: MissionItemInt, partner: tuple[int, int]) -> MissionItemInt:
        out = replace(
            item,
            target_system=partner[0],
            target_component=partner[1],
            current=1 if (item.mission_type == 0 and item.seq == self._current_seq) else 0,
        )
        if self.config.autopilot == Autopilot.ARDUPILOT:
            out = replace(out, frame=canonical_frame(out.frame))
            if out.mission_type == 0 and out.seq == 0 and self.config.home is not None:
                home = self.config.home
                out = replace(
                    out,
                    frame=int(MavFrame.GLOBAL),
                    command=int(MavCmd.NAV_WAYPOINT),
                    x=deg_to_e7(home.lat_deg),
                    y=deg_to_e7(home.lon_deg),
                    z=round(home.alt_m * 100.0) / 100.0,
                )
        return out

    # -- clear ----------------------------------------------------------------------------
    def _on_clear(self, partner: tuple[int, int], msg: MissionClearAll) -> None:
        px4 = self.config.autopilot == Autopilot.PX4
        if self.busy:
            if px4:
                self._text(_CRITICAL, "WPM: IGN CLEAR CMD: Busy")
            else:
                self._ack(partner, MissionResult.ERROR, msg.mission_type)
            return
        if msg.mission_type == MissionType.ALL:
            if not px4:
                self._ack(partner, MissionResult.UNSUPPORTED, msg.mission_type)
                return
            types = [0, 1, 2]
        elif msg.mission_type in (0, 1, 2):
            types = [msg.mission_type]
        else:
            self._ack(partner, MissionResult.UNSUPPORTED, msg.mission_type)
            return
        with self._lock:
            for mission_type in types:
                self._storage[mission_type] = []
        if 0 in types:
            self._current_seq = 0
        self._last_completed = None
        self._clears += 1
        self._ack(partner, MissionResult.ACCEPTED, msg.mission_type)
