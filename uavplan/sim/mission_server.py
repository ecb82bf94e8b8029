"""The vehicle side of the MAVLink mission protocol, sans-I/O: messages in, messages out.

:class:`MissionServer` holds a vehicle's mission, geofence and rally points and serves
their upload, download and clear exactly as PX4 or ArduPilot does where they differ
(reference §4). It does no I/O and reads no clock: :meth:`MissionServer.handle` takes one
message and the time, :meth:`MissionServer.timers` the time alone, and both return the
messages to send. The simulated vehicle (:mod:`.vehicle`) owns one.

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
clear while busy               ignored + STATUSTEXT            from the uploader: ends the
                                                               upload and clears; from
                                                               another: DENIED, ERROR
cancel (OPERATION_CANCELLED)   honoured: idle at once, the     ignored: busy until 8 s after
                               old plan kept                   the last item (then its own
                                                               OPERATION_CANCELLED)
mission seq 0                  first item                      home: downloads return
                                                               the vehicle's home when set
stored and sent back           the firmware's form (mavlink/stored_form.py stored_form): params
                               dropped or reduced, frames renamed, altitudes quantised;
                               ``_INT`` frame spellings        0/3/10 spellings, z truncated
                                                               to cm, autocontinue 1 (fence
                                                               and rally 0)
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

The protocol misbehaviour of :class:`~uavplan.sim.faults.Faults` (error ACK at an item,
out-of-range request, early ACCEPTED, falling silent) is applied here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from uavplan.geo import GeoPoint
from uavplan.mavlink.messages import (
    MalformedMessage,
    Message,
    MissionAck,
    MissionClearAll,
    MissionCount,
    MissionItemInt,
    MissionRequest,
    MissionRequestList,
    MissionResult,
    MissionSetCurrent,
    StatusText,
)
from uavplan.mavlink.protocol import RoundTripEstimator, item_from_wire, item_to_wire
from uavplan.mavlink.stored_form import (
    PX4_GLOBAL_FRAME_COMMANDS,
    PX4_MISSION_FRAME_COMMANDS,
    stored_form,
)
from uavplan.mission.items import (
    Autopilot,
    MavCmd,
    MavFrame,
    MissionItem,
    MissionType,
    canonical_frame,
    deg_to_e7,
)
from uavplan.sim.faults import Faults

__all__ = ["FIRMWARE_RETRY_S", "FIRMWARE_TRANSFER_TIMEOUT_S", "ITEM_LIMITS", "MissionServer"]

#: (mission, fence, rally) capacity per flavour
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
#: the frames PX4 sends back for a global item in int mode (mavlink_mission.cpp
#: format_mavlink_mission_item): MAV_FRAME_GLOBAL_INT, MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
_PX4_INT_FRAMES = {0: 5, 3: 6}
#: ArduPilot allows NaN only in param4 (yaw) of these commands (AP_Mission::sanity_check_params)
_ARDUPILOT_NAN_PARAM4 = frozenset({16, 17, 21, 22, 84})

# STATUSTEXT severities
_CRITICAL, _WARNING, _INFO = 2, 4, 6

MISSION_MESSAGES = (
    MissionCount,
    MissionItemInt,
    MissionRequestList,
    MissionRequest,
    MissionAck,
    MissionClearAll,
    MissionSetCurrent,
)


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


class MissionServer:
    """One vehicle's mission, geofence and rally points and the protocol serving them.

    ``home``: for ArduPilot, what a download returns as mission seq 0 (the vehicle's home),
    when set. ``faults``: the protocol misbehaviour to apply (read on every message, so it
    may be changed while serving). ``current_seq`` is the current mission item; the server
    sets it on MISSION_SET_CURRENT and resets it when the mission changes, and raises
    ``current_changed`` / ``mission_version`` for the vehicle to act on.
    """

    def __init__(
        self,
        autopilot: Autopilot,
        *,
        system_id: int = 1,
        component_id: int = 1,
        home: GeoPoint | None = None,
        firmware_timing: bool = False,
        faults: Faults | None = None,
    ) -> None:
        if autopilot not in ITEM_LIMITS:
            raise ValueError("the simulated vehicle is px4 or ardupilot")
        self.autopilot = autopilot
        self.system_id = system_id
        self.component_id = component_id
        self.home = home
        self.firmware_timing = firmware_timing
        self.faults = faults or Faults()
        self._storage: dict[int, list[MissionItemInt]] = {0: [], 1: [], 2: []}
        self._receiving: _Receiving | None = None
        self._sending: _Sending | None = None
        self._last_completed: tuple[tuple[int, int], int, int] | None = None
        self.current_seq = 0
        self.current_changed = False
        #: bumped whenever the stored mission changes (upload, clear)
        self.mission_version = 0
        self._rtt = RoundTripEstimator()
        self._now = 0.0
        self._out: list[Message] = []
        self._uploads_accepted = self._uploads_failed = self._downloads = self._clears = 0
        #: messages whose fields could not be stored, and the last reason
        self.rejected_messages = 0
        self.last_rejection: str | None = None

    # -- storage --------------------------------------------------------------------------
    def wire_items(self, mission_type: MissionType) -> list[MissionItemInt]:
        return list(self._storage[int(mission_type)])

    def items(self, mission_type: MissionType) -> list[MissionItem]:
        """The stored plan type as MissionItems (seq = index; ArduPilot's home included)."""
        return [item_from_wire(w) for w in self.wire_items(mission_type)]

    def preload(self, mission_type: MissionType, items: list[MissionItem]) -> None:
        """Store a plan as if it had been uploaded (in the firmware's form)."""
        wire = [
            self._stored(
                item_to_wire(it, seq, mission_type, self.system_id, self.component_id),
                int(mission_type),
            )
            for seq, it in enumerate(items)
        ]
        self._storage[int(mission_type)] = wire
        if int(mission_type) == 0:
            self._mission_changed()

    def _mission_changed(self) -> None:
        self.current_seq = 0
        self.mission_version += 1

    @property
    def busy(self) -> bool:
        return self._receiving is not None or self._sending is not None

    def counters(self) -> tuple[int, int, int, int]:
        """(uploads accepted, uploads failed, downloads served, clears)."""
        return (self._uploads_accepted, self._uploads_failed, self._downloads, self._clears)

    # -- the sans-I/O interface -----------------------------------------------------------
    def handle(self, partner: tuple[int, int], message: Message, now: float) -> list[Message]:
        """One mission-protocol message (or MISSION_SET_CURRENT) from ``partner``; the
        messages to send back."""
        self._now = now
        self._out = []
        if self.faults.ignore_requests and isinstance(
            message, MissionCount | MissionRequestList | MissionClearAll
        ):
            return []
        if isinstance(message, MissionSetCurrent):
            self._on_set_current(message.seq)
        elif isinstance(message, MissionCount):
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
        return self._out

    def timers(self, now: float) -> list[Message]:
        """Re-requests and transfer timeouts due at ``now``; the messages to send."""
        self._now = now
        self._out = []
        self._timers(now)
        return self._out

    def next_timer(self, now: float) -> float:
        """When :meth:`timers` next has something to do."""
        return self._next_timer(now)

    def _ack(self, partner: tuple[int, int], result: MissionResult, mission_type: int) -> None:
        self._out.append(MissionAck(partner[0], partner[1], int(result), mission_type))

    def _text(self, severity: int, text: str) -> None:
        self._out.append(StatusText(severity, text))

    def _on_set_current(self, seq: int) -> None:
        if self.busy:
            self._text(_CRITICAL, "WPM: IGN WP CURR CMD: Busy")
        elif 0 <= seq < len(self._storage[0]):
            self.current_seq = seq
            self.current_changed = True
        elif self.autopilot == Autopilot.PX4:
            self._text(_CRITICAL, "WPM: WP CURR CMD: Not in list")

    def _limit(self, mission_type: int) -> int:
        return ITEM_LIMITS[self.autopilot][mission_type]

    def _on_count(self, partner: tuple[int, int], msg: MissionCount) -> None:
        px4 = self.autopilot == Autopilot.PX4
        now = self._now
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
            self._storage[msg.mission_type] = []
            if msg.mission_type == 0:
                self._mission_changed()
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
        rx.last_request = self._now
        rx.request_is_retry = retry
        int_form = rx.int_mode and self.autopilot == Autopilot.PX4
        self._out.append(
            MissionRequest(
                rx.partner[0], rx.partner[1], rx.requested_seq, rx.mission_type, int_form=int_form
            )
        )

    def _validate(self, mission_type: int, item: MissionItemInt) -> MissionResult:
        """The checks a real autopilot makes that matter for a planner (reference §1.7, §4)."""
        px4 = self.autopilot == Autopilot.PX4
        cmd, frame = item.command, item.frame
        if mission_type == 0 and (cmd in _FENCE_COMMANDS or cmd == MavCmd.NAV_RALLY_POINT):
            return MissionResult.ERROR if px4 else MissionResult.UNSUPPORTED
        if mission_type == 1 and cmd not in _FENCE_COMMANDS:
            return MissionResult.UNSUPPORTED
        if mission_type == 2 and cmd not in _RALLY_COMMANDS[self.autopilot]:
            return MissionResult.UNSUPPORTED
        if frame not in (_PX4_FRAMES if px4 else _ARDUPILOT_FRAMES):
            return MissionResult.UNSUPPORTED_FRAME
        if px4 and mission_type == 0:
            # mavlink_mission.cpp parse_mavlink_mission_item: a command is accepted only in
            # the frame branch that lists it (NAV_RETURN_TO_LAUNCH in a global frame, or a
            # waypoint in MAV_FRAME_MISSION: MAV_MISSION_UNSUPPORTED)
            listed = PX4_MISSION_FRAME_COMMANDS if frame == 2 else PX4_GLOBAL_FRAME_COMMANDS
            if cmd not in listed:
                return MissionResult.UNSUPPORTED
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
        px4 = self.autopilot == Autopilot.PX4
        faults = self.faults
        rx = self._receiving
        now = self._now
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
        rx.items.append(self._stored(item, rx.mission_type))
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
        if rx.mission_type == 1 and self.autopilot == Autopilot.ARDUPILOT:
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
        self._storage[rx.mission_type] = wire
        if rx.mission_type == 0:
            self._mission_changed()
        self._receiving = None
        self._last_completed = (rx.partner, rx.mission_type, rx.count)
        self._uploads_accepted += 1
        self._ack(rx.partner, MissionResult.ACCEPTED, rx.mission_type)

    def _stored(self, item: MissionItemInt, mission_type: int) -> MissionItemInt:
        """What the firmware keeps of ``item`` and sends back (:func:`uavplan.mavlink.
        storage.stored_form`: ArduPilot drops a waypoint's acceptance radius and yaw, keeps
        whole seconds of hold time and centimetres of altitude, puts commands without a
        location in frame 0; PX4 wraps yaw to [0, 360) and drops what its mission item has
        no field for). ArduPilot's ``mission_cmd_to_mavlink_int`` sends autocontinue 1 for
        every mission item, its fence and rally loaders 0; PX4 keeps what was sent."""
        kind = MissionType(mission_type)
        try:
            kept = stored_form(item_from_wire(item), self.autopilot, kind)
        except ValueError:
            return item
        wire = item_to_wire(kept, item.seq, kind, item.target_system, item.target_component)
        if self.autopilot == Autopilot.ARDUPILOT:
            autocontinue = 1 if kind == MissionType.MISSION else 0
        else:
            autocontinue = item.autocontinue
        return replace(wire, autocontinue=autocontinue, legacy_float=item.legacy_float)

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
        """A MISSION_ACK from a ground station. During an upload (the vehicle receiving):

        - ArduPilot handles no MISSION_ACK at all: ``MissionItemProtocol`` has no handler
          for it (libraries/GCS_MAVLink/MissionItemProtocol.cpp), so a cancel changes
          nothing; the transfer ends when no item came for ``upload_timeout_ms`` (8000 ms,
          MissionItemProtocol.h), in ``MissionItemProtocol::update``, which then sends its
          own OPERATION_CANCELLED (our :meth:`_timers`). Measured on ArduCopter 4.7.0-dev
          SITL (2026-11-28): REQUEST_LIST answered DENIED until then.
        - PX4 (``MavlinkMissionManager::handle_mission_ack``, src/modules/mavlink/
          mavlink_mission.cpp): from the transfer partner, in the GETLIST state,
          OPERATION_CANCELLED switches to idle at once (``switch_to_idle_state``,
          ``_transfer_in_progress = false``); the upload went to the inactive storage, so
          the old plan stays. UNSUPPORTED flips the request form (int / float)."""
        px4 = self.autopilot == Autopilot.PX4
        rx, tx = self._receiving, self._sending
        if rx is not None and partner == rx.partner and ack.mission_type == rx.mission_type:
            if not px4:
                return  # ArduPilot: see above
            rx.last_recv = self._now
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
        ap = self.autopilot
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
        ceiling = FIRMWARE_RETRY_S[self.autopilot]
        if self.firmware_timing:
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
        px4 = self.autopilot == Autopilot.PX4
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
            self._sending = _Sending(partner, msg.mission_type, count, 0, self._now)
        self._downloads += 1
        self._out.append(MissionCount(partner[0], partner[1], count, msg.mission_type))

    def _on_request(self, partner: tuple[int, int], msg: MissionRequest) -> None:
        px4 = self.autopilot == Autopilot.PX4
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
            tx.last_recv = self._now
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
            self._out.append(self._outgoing(stored[msg.seq], partner))
            return
        if msg.seq >= len(stored):
            self._out.append(MissionCount(partner[0], partner[1], len(stored), msg.mission_type))
            self._ack(partner, MissionResult.ERROR, msg.mission_type)
            return
        self._out.append(self._outgoing(stored[msg.seq], partner))

    def _outgoing(self, item: MissionItemInt, partner: tuple[int, int]) -> MissionItemInt:
        out = replace(
            item,
            target_system=partner[0],
            target_component=partner[1],
            current=1 if (item.mission_type == 0 and item.seq == self.current_seq) else 0,
        )
        if self.autopilot == Autopilot.PX4:
            # format_mavlink_mission_item in int mode: the _INT spelling of a global frame
            out = replace(out, frame=_PX4_INT_FRAMES.get(out.frame, out.frame))
        if self.autopilot == Autopilot.ARDUPILOT:
            out = replace(out, frame=canonical_frame(out.frame))
            if out.mission_type == 0 and out.seq == 0 and self.home is not None:
                home = self.home
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
        px4 = self.autopilot == Autopilot.PX4
        rx = self._receiving
        if not px4 and rx is not None and msg.mission_type == rx.mission_type:
            # ArduPilot's MissionItemProtocol::handle_mission_clear_all calls cancel_upload:
            # the uploading ground station's clear ends its upload and clears (the only way
            # it has to end one at once); another's is DENIED, then the clear answers ERROR
            # (MissionItemProtocol.cpp; measured on ArduCopter 4.7.0-dev SITL, 2026-11-28)
            if partner != rx.partner:
                self._ack(partner, MissionResult.DENIED, msg.mission_type)
                self._ack(partner, MissionResult.ERROR, msg.mission_type)
                return
            self._receiving = None
            self._uploads_failed += 1
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
        for mission_type in types:
            self._storage[mission_type] = []
        if 0 in types:
            self._mission_changed()
        self._last_completed = None
        self._clears += 1
        self._ack(partner, MissionResult.ACCEPTED, msg.mission_type)
