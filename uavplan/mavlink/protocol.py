"""Ground-station side of the MAVLink mission protocol: upload, download and clear.

One :class:`MissionClient` drives one transfer at a time over a
:class:`~uavplan.mavlink.link.VehicleLink`, for any plan type (mission, fence, rally). Each
operation returns a :class:`TransferOutcome`: a status enum naming what happened, the
protocol step where it happened, the vehicle's MAV_MISSION_RESULT by name, and counters.
:meth:`TransferOutcome.raise_for_status` turns a failure into a
:class:`MissionTransferError` (a :class:`~uavplan.errors.LinkError`, exit 4).

State machines (reference §1, §7, §8)
-------------------------------------
Upload (the vehicle drives and retries)::

    WAIT_FIRST_REQUEST --REQUEST(0..n-1)--> SENDING --REQUEST(n-1)--> WAIT_FINAL_ACK
      | timeout: re-send COUNT (ControlSchedule), then TIMEOUT
      | ERROR/DENIED before any request: "busy", re-send COUNT later (same budget); if our
      |   own last download may be the cause (its final ACK lost: PX4 then refuses uploads
      |   for 5 s), repeat that ACK first
      | NO_SPACE: fail at once
    SENDING: answer every in-range REQUEST / REQUEST_INT with MISSION_ITEM_INT (duplicates
      and older seqs too); seq >= count -> PROTOCOL_ERROR; no request for
      upload_silence_s -> TIMEOUT; one seq requested more than 6 x retries times -> TIMEOUT;
      INVALID_SEQUENCE ack -> ignored (ArduPilot sends it for duplicates; the spec says an
      out-of-sequence item is not an error); any other error ack -> REJECTED naming the item.
    WAIT_FINAL_ACK: ACCEPTED -> SUCCESS only if every seq was sent (else PROTOCOL_ERROR);
      silence -> re-send the last item twice (PX4 re-acks it), then NO_FINAL_ACK, which the
      caller resolves by reading the plan back (reference §7.6).

Download (the GCS drives and retries)::

    WAIT_COUNT --COUNT(n)--> WAIT_ITEM(0) --ITEM(0)--> ... WAIT_ITEM(n-1) --> ACK ACCEPTED
      REQUEST_LIST re-sent per ControlSchedule; count 0 -> ACK and done;
      REQUEST_INT strictly in order (PX4 aborts on a skipped seq); items of any other seq
      are dropped; a missing item is re-requested, then TIMEOUT after item_s x (1 + retries).

Clear: MISSION_CLEAR_ALL re-sent per ControlSchedule until a MISSION_ACK.

Every failure we detect ourselves sends MISSION_ACK(OPERATION_CANCELLED) so the vehicle
goes idle at once (reference §1.5); a failure the vehicle reported needs no cancel.

Timeouts: the spec/QGC values are the defaults, the ceilings and the total budgets. Within
a budget, re-sends follow the measured round trip (RFC 6298: ``srtt + 4 x rttvar``, seeded
by the AUTOPILOT_VERSION request made on connecting and updated by every clean exchange),
so a fast link does not wait 250 ms or 1.5 s per lost packet while a slow radio link still
gets the spec timing. Per-item download re-requests use a 10 ms floor: a re-sent
REQUEST_INT for the item the vehicle just sent is the "repeat of the last one" every
firmware accepts. Control messages (COUNT, REQUEST_LIST, CLEAR_ALL) use a 200 ms floor
and back off (:class:`ControlSchedule`).
"""

from __future__ import annotations

import enum
import math
import time
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from uavplan.errors import LinkError
from uavplan.mavlink.link import VehicleLink
from uavplan.mavlink.messages import (
    MissionAck,
    MissionClearAll,
    MissionCount,
    MissionItemInt,
    MissionRequest,
    MissionRequestList,
    MissionResult,
    Received,
    result_label,
)
from uavplan.mission.items import MavCmd, MissionItem, MissionType

ProgressCallback = Callable[[int, int], None]

# ---------------------------------------------------------------------------------------------
# Configuration


@dataclass(frozen=True)
class ProtocolTimeouts:
    """Per-step timeouts and retry counts. Defaults: QGroundControl / the MAVLink devguide.

    - ``ack_s``: wait for the answer to COUNT, REQUEST_LIST, CLEAR_ALL and for the final
      upload ACK (QGC ``_ackTimeoutMilliseconds`` 1500; devguide default 1500 ms).
    - ``item_s``: download, wait for an item before re-requesting it (QGC
      ``_retryTimeoutMilliseconds`` 250; devguide 250 ms for plan items). The ceiling of
      the RTT-adaptive re-request interval.
    - ``upload_silence_s``: upload, longest wait for the vehicle's next request. It must
      exceed the vehicle's re-request interval a few times over: ArduPilot re-requests
      once a second, PX4 every 250 ms (reference §2, "Timing consequences").
    - ``retries``: the retry budget. A GCS-driven step (COUNT, REQUEST_LIST, CLEAR_ALL, a
      download item) fails once it has been sent ``1 + retries`` times *and*
      ``(1 + retries) x`` its timeout has passed: the spec's budget (devguide: at most 5
      retries). Within it, re-sends follow the measured round trip.
    - ``min_retry_s``: floor of the adaptive item re-request interval.
    - ``min_control_s``: floor of the adaptive re-send interval of control messages.
    """

    ack_s: float = 1.5
    item_s: float = 0.25
    upload_silence_s: float = 3.0
    retries: int = 5
    min_retry_s: float = 0.01
    min_control_s: float = 0.2

    def __post_init__(self) -> None:
        for name in ("ack_s", "item_s", "upload_silence_s", "min_retry_s", "min_control_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number of seconds, got {value!r}")
        if not 0 <= self.retries <= 100:
            raise ValueError(f"retries must be within 0..100, got {self.retries!r}")

    @classmethod
    def scaled(cls, timeout_s: float, retries: int = 5) -> ProtocolTimeouts:
        """All timeouts from one ``--timeout`` value (the ack timeout), keeping the spec's
        ratios: item = ack / 6, upload silence = 2 x ack."""
        return cls(
            ack_s=timeout_s,
            item_s=timeout_s / 6.0,
            upload_silence_s=2.0 * timeout_s,
            retries=retries,
            min_retry_s=min(0.01, timeout_s / 6.0),
            min_control_s=min(0.2, timeout_s),
        )

    @property
    def request_repeat_limit(self) -> int:
        """Upload: how often one seq may be requested before we call it hopeless."""
        return 6 * max(1, self.retries)


class RoundTripEstimator:
    """Smoothed round-trip time (RFC 6298). Only first-attempt exchanges are sampled (Karn)."""

    ALPHA = 0.125
    BETA = 0.25

    def __init__(self) -> None:
        self.srtt_s: float | None = None
        self.rttvar_s = 0.0
        self.samples = 0

    def add(self, sample_s: float) -> None:
        sample_s = max(0.0, sample_s)
        if self.srtt_s is None:
            self.srtt_s, self.rttvar_s = sample_s, sample_s / 2.0
        else:
            self.rttvar_s = (1 - self.BETA) * self.rttvar_s + self.BETA * abs(
                self.srtt_s - sample_s
            )
            self.srtt_s = (1 - self.ALPHA) * self.srtt_s + self.ALPHA * sample_s
        self.samples += 1

    def timeout(self, ceiling_s: float, floor_s: float) -> float:
        """The re-send interval: ``srtt + 4 rttvar`` within [floor, ceiling]; ceiling first."""
        if self.srtt_s is None:
            return ceiling_s
        return min(ceiling_s, max(floor_s, self.srtt_s + 4.0 * self.rttvar_s))


class ControlSchedule:
    """When to re-send a control message (COUNT, REQUEST_LIST, CLEAR_ALL) and when to quit.

    First wait: ``srtt + 4 rttvar`` of the link, within [``min_control_s``, ``ack_s``]
    (``ack_s`` while the round trip is unknown); doubled after each re-send up to ``ack_s``.
    Give up after ``1 + retries`` sends once ``(1 + retries) x ack_s`` have passed, the
    devguide's budget: a fast link retries sooner, a dead one fails no sooner than the spec
    says. The floor keeps a premature duplicate rare: it would restart a PX4 download, and
    the MAVSDK server starts a second incoming transfer on a second COUNT.
    """

    def __init__(self, timeouts: ProtocolTimeouts, rtt: RoundTripEstimator) -> None:
        self._timeouts = timeouts
        self._interval = rtt.timeout(timeouts.ack_s, min(timeouts.min_control_s, timeouts.ack_s))
        self.started = time.monotonic()
        self.sends = 0
        self.deadline = self.started

    def sent(self) -> None:
        """Record a send; :attr:`deadline` is when to give up waiting for its answer."""
        now = time.monotonic()
        if self.sends:
            self._interval = min(self._timeouts.ack_s, 2.0 * self._interval)
        self.sends += 1
        self.deadline = now + self._interval

    @property
    def exhausted(self) -> bool:
        t = self._timeouts
        spent = time.monotonic() - self.started
        return self.sends > t.retries and spent >= (t.retries + 1) * t.ack_s - 1e-3

    def describe(self, what: str, answer: str) -> str:
        spent = time.monotonic() - self.started
        return f"no {answer} after {self.sends} {what} messages over {spent:.1f} s"


# ---------------------------------------------------------------------------------------------
# Outcomes


class Operation(enum.Enum):
    UPLOAD = "upload"
    DOWNLOAD = "download"
    CLEAR = "clear"
    VERIFY = "verify"


class TransferStatus(enum.Enum):
    """How a transfer ended (MAVSDK's ``MissionRawResult`` in spirit)."""

    SUCCESS = "success"
    TIMEOUT = "timeout"  # the other side went silent for the whole retry budget
    REJECTED = "rejected"  # the vehicle answered an error MISSION_ACK
    BUSY = "busy"  # ERROR/DENIED before the transfer started: another transfer is running
    NO_SPACE = "no space"  # the vehicle cannot hold that many items
    PROTOCOL_ERROR = "protocol error"  # the vehicle broke the protocol
    CANCELLED = "cancelled"  # the vehicle cancelled the transfer
    NO_FINAL_ACK = "no final ack"  # every item sent, the final ACK never came: verify
    MISMATCH = "mismatch"  # the read-back differs from what was uploaded


def type_label(mission_type: MissionType | int) -> str:
    try:
        return MissionType(mission_type).name.lower()
    except ValueError:
        return f"mission type {mission_type}"


@dataclass(frozen=True)
class TransferStats:
    elapsed_s: float = 0.0
    sent: int = 0  # protocol messages we sent
    received: int = 0  # protocol messages we took from the vehicle
    resent: int = 0  # our re-sends after a timeout
    repeat_requests: int = 0  # upload: requests for a seq we had already sent
    ignored: int = 0  # stale, duplicate or out-of-sequence messages dropped
    srtt_ms: float | None = None


@dataclass(frozen=True)
class TransferOutcome:
    """The result of one upload / download / clear of one plan type."""

    operation: Operation
    mission_type: MissionType
    status: TransferStatus
    step: str = ""  # the protocol step: "MISSION_COUNT", "MISSION_ITEM_INT seq 17", ...
    detail: str = ""  # why, in words
    vehicle_result: MissionResult | int | None = None
    seq: int | None = None
    items: tuple[MissionItem, ...] = ()
    stats: TransferStats = field(default_factory=TransferStats)
    statustext: str | None = None

    @property
    def ok(self) -> bool:
        return self.status is TransferStatus.SUCCESS

    @property
    def where(self) -> str:
        """``"upload mission: MISSION_COUNT"``: the operation, plan type and step."""
        head = f"{self.operation.value} {type_label(self.mission_type)}"
        return f"{head}: {self.step}" if self.step else head

    @property
    def message(self) -> str:
        parts = [self.detail or self.status.value]
        if self.vehicle_result is not None and result_label(self.vehicle_result) not in (
            self.detail
        ):
            parts.append(f"({result_label(self.vehicle_result)})")
        if self.statustext:
            parts.append(f'[vehicle: "{self.statustext}"]')
        return " ".join(parts)

    def raise_for_status(self) -> TransferOutcome:
        if not self.ok:
            raise MissionTransferError(self)
        return self


class MissionTransferError(LinkError):
    """A transfer failed; ``outcome`` says where and why. Exit code 4."""

    def __init__(self, outcome: TransferOutcome) -> None:
        self.outcome = outcome
        super().__init__(outcome.message, step=outcome.where)


# ---------------------------------------------------------------------------------------------
# Wire conversion


#: the largest finite float32, the type of MISSION_ITEM_INT's params and z
FLOAT32_MAX = 3.4028234663852886e38
INT32_RANGE = (-(2**31), 2**31 - 1)


def wire_range_problem(item: MissionItem) -> str | None:
    """Why ``item`` cannot be carried by MISSION_ITEM_INT (a param or z beyond float32, x/y
    beyond int32), or ``None`` when it can."""
    for name, value in zip(("param1", "param2", "param3", "param4"), item.params, strict=True):
        if value is not None and math.isfinite(value) and abs(value) > FLOAT32_MAX:
            return f"{name} = {value!r} does not fit the wire's 32-bit float"
    if math.isfinite(item.z) and abs(item.z) > FLOAT32_MAX:
        return f"z (altitude) = {item.z!r} does not fit the wire's 32-bit float"
    for name, value in (("x", item.x), ("y", item.y)):
        if not math.isfinite(value):
            return f"{name} = {value!r} is not a number the wire can carry"
    x, y = item.wire_xy()
    for name, value in (("x", x), ("y", y)):
        if not INT32_RANGE[0] <= value <= INT32_RANGE[1]:
            shown = getattr(item, name)
            return f"{name} = {shown!r} does not fit the wire's 32-bit integer"
    return None


def item_to_wire(
    item: MissionItem,
    seq: int,
    mission_type: MissionType,
    target_system: int,
    target_component: int,
) -> MissionItemInt:
    """MissionItem -> MISSION_ITEM_INT; ``current`` is 1 on seq 0 only (reference §4.4).

    Raises ValueError for an item the wire cannot carry (:func:`wire_range_problem`)."""
    problem = wire_range_problem(item)
    if problem is not None:
        raise ValueError(f"item {seq}: {problem}")
    x, y = item.wire_xy()
    params = [math.nan if p is None else float(p) for p in item.params]
    return MissionItemInt(
        target_system=target_system,
        target_component=target_component,
        seq=seq,
        frame=item.frame,
        command=item.command,
        current=1 if seq == 0 else 0,
        autocontinue=1 if item.autocontinue else 0,
        param1=params[0],
        param2=params[1],
        param3=params[2],
        param4=params[3],
        x=x,
        y=y,
        z=float(item.z),
        mission_type=int(mission_type),
    )


def item_from_wire(wire: MissionItemInt) -> MissionItem:
    """MISSION_ITEM_INT -> MissionItem (raises ValueError for an item that is not valid)."""
    return MissionItem.from_wire(
        command=wire.command,
        frame=wire.frame,
        params=(wire.param1, wire.param2, wire.param3, wire.param4),
        x=wire.x,
        y=wire.y,
        z=wire.z,
        autocontinue=wire.autocontinue,
    )


def describe_item(item: MissionItem) -> str:
    try:
        name = MavCmd(item.command).name
    except ValueError:
        name = "MAV_CMD"
    return f"command {item.command} ({name}), frame {item.frame}"


_PARAM_RESULTS = {
    MissionResult.INVALID_PARAM1: "param1",
    MissionResult.INVALID_PARAM2: "param2",
    MissionResult.INVALID_PARAM3: "param3",
    MissionResult.INVALID_PARAM4: "param4",
    MissionResult.INVALID_PARAM5_X: "x",
    MissionResult.INVALID_PARAM6_Y: "y",
    MissionResult.INVALID_PARAM7: "z",
}


def _reason_for_item(result: MissionResult | int, item: MissionItem | None) -> str:
    """QGC-style text: ``item 5 command 16 (NAV_WAYPOINT): param1 = 2.0 rejected``."""
    label = result_label(result)
    if item is None:
        return f"vehicle rejected the transfer with {label}"
    what = describe_item(item)
    attribute = _PARAM_RESULTS.get(result) if isinstance(result, MissionResult) else None
    if attribute is not None:
        return f"vehicle rejected {what}: {attribute} = {getattr(item, attribute)!r} ({label})"
    if result == MissionResult.UNSUPPORTED_FRAME:
        return f"vehicle does not support frame {item.frame} of {what} ({label})"
    if result == MissionResult.UNSUPPORTED:
        return f"vehicle does not support {what} ({label})"
    return f"vehicle rejected {what} with {label}"


# ---------------------------------------------------------------------------------------------


#: how often a "busy" answer to MISSION_COUNT makes us repeat our last download's ACK
BUSY_ACK_REPEATS = 4
#: growth of a repeated item re-request interval (after three misses in a row)
RETRY_BACKOFF = 1.5
#: how long a failed transfer waits for the STATUSTEXT that may explain the vehicle's refusal
STATUSTEXT_GRACE_S = 0.1
_VEHICLE_REFUSALS = frozenset(
    {
        TransferStatus.REJECTED,
        TransferStatus.NO_SPACE,
        TransferStatus.BUSY,
        TransferStatus.CANCELLED,
    }
)


class _Counters:
    def __init__(self) -> None:
        self.sent = 0
        self.received = 0
        self.resent = 0
        self.repeat_requests = 0
        self.ignored = 0


class MissionClient:
    """Mission protocol client for one vehicle. Not thread-safe: one transfer at a time."""

    def __init__(self, link: VehicleLink, timeouts: ProtocolTimeouts | None = None) -> None:
        self.link = link
        self.timeouts = timeouts or ProtocolTimeouts()
        self.rtt = RoundTripEstimator()
        if link.handshake_rtt_s is not None:
            self.rtt.add(link.handshake_rtt_s)
        #: the final ACK of our last download, kept to repeat if the vehicle says busy
        self._download_ack: MissionAck | None = None

    # -- helpers --------------------------------------------------------------------------
    @property
    def _target(self) -> tuple[int, int]:
        return self.link.vehicle.system_id, self.link.vehicle.component_id

    def _send(self, counters: _Counters, message: object) -> None:
        self.link.send(message)  # type: ignore[arg-type]
        counters.sent += 1

    def _cancel(self, counters: _Counters, mission_type: MissionType) -> None:
        """MISSION_ACK(OPERATION_CANCELLED): the vehicle goes idle now, not after its timeout."""
        try:
            self._send(
                counters,
                MissionAck(*self._target, MissionResult.OPERATION_CANCELLED, int(mission_type)),
            )
        except LinkError:
            pass

    def _recv(self, timeout_s: float, mission_type: MissionType) -> Received | None:
        """Next protocol message of this plan type (stale ones of another type are dropped)."""
        deadline = time.monotonic() + max(0.0, timeout_s)
        while True:
            received = self.link.recv(max(0.0, deadline - time.monotonic()))
            if received is None:
                return None
            message = received.message
            message_type = getattr(message, "mission_type", None)
            if message_type is not None and message_type == int(mission_type):
                return received
            if time.monotonic() >= deadline:
                return None

    def _outcome(
        self,
        operation: Operation,
        mission_type: MissionType,
        status: TransferStatus,
        counters: _Counters,
        started: float,
        **kwargs: object,
    ) -> TransferOutcome:
        stats = TransferStats(
            elapsed_s=time.monotonic() - started,
            sent=counters.sent,
            received=counters.received,
            resent=counters.resent,
            repeat_requests=counters.repeat_requests,
            ignored=counters.ignored,
            srtt_ms=None if self.rtt.srtt_s is None else self.rtt.srtt_s * 1e3,
        )
        if status in _VEHICLE_REFUSALS and self.link.last_statustext is None:
            # a vehicle often explains a refusal right after its ACK ("Only 700 items are
            # supported"): give that STATUSTEXT a moment to arrive
            deadline = time.monotonic() + STATUSTEXT_GRACE_S
            while self.link.last_statustext is None and time.monotonic() < deadline:
                self.link.recv(deadline - time.monotonic())
        statustext = None if status is TransferStatus.SUCCESS else self.link.last_statustext
        return TransferOutcome(
            operation,
            MissionType(mission_type),
            status,
            stats=stats,
            statustext=statustext,
            **kwargs,  # type: ignore[arg-type]
        )

    # -- upload ---------------------------------------------------------------------------
    def upload(
        self,
        mission_type: MissionType,
        items: Sequence[MissionItem],
        *,
        progress: ProgressCallback | None = None,
    ) -> TransferOutcome:
        """Upload ``items`` (seq = index) as plan type ``mission_type``.

        An empty list uploads count 0, which clears that plan type (reference §1.1.5).
        """
        mission_type = MissionType(mission_type)
        if mission_type == MissionType.ALL:
            raise ValueError("MAV_MISSION_TYPE_ALL is only valid for clear")
        self.link.last_statustext = None
        sysid, compid = self._target
        wire = [item_to_wire(it, seq, mission_type, sysid, compid) for seq, it in enumerate(items)]
        try:
            return self._upload(mission_type, list(items), wire, progress)
        except KeyboardInterrupt:
            self._cancel(_Counters(), mission_type)
            raise
        finally:
            self._download_ack = None

    def _upload(
        self,
        mission_type: MissionType,
        items: list[MissionItem],
        wire: list[MissionItemInt],
        progress: ProgressCallback | None,
    ) -> TransferOutcome:
        t = self.timeouts
        counters = _Counters()
        started = time.monotonic()
        count = len(wire)
        op = Operation.UPLOAD

        def done(status: TransferStatus, **kwargs: object) -> TransferOutcome:
            return self._outcome(op, mission_type, status, counters, started, **kwargs)

        count_message = MissionCount(*self._target, count, int(mission_type))
        schedule = ControlSchedule(t, self.rtt)
        self._send(counters, count_message)
        schedule.sent()
        busy_result: MissionResult | int | None = None
        ack_repeats = 0
        state = "WAIT_FIRST_REQUEST"
        deadline = schedule.deadline
        sent_seqs: set[int] = set()
        requests_per_seq: Counter[int] = Counter()
        last_sent_seq = -1
        last_sent_at = 0.0
        last_sent_was_resend = False
        final_resends = 0
        final_waits = [0.0, 0.0, t.ack_s]
        highest_progress = 0
        upload_rtt = RoundTripEstimator()

        while True:
            received = self._recv(deadline - time.monotonic(), mission_type)
            now = time.monotonic()
            if received is None:
                if now < deadline:
                    continue
                # ---- timeouts ---------------------------------------------------------
                if state == "WAIT_FIRST_REQUEST":
                    if schedule.exhausted:
                        if busy_result is not None:
                            return done(
                                TransferStatus.BUSY,
                                step="MISSION_COUNT",
                                detail=f"vehicle stayed busy through {schedule.sends} "
                                "MISSION_COUNT attempts (another transfer running?)",
                                vehicle_result=busy_result,
                            )
                        self._cancel(counters, mission_type)
                        return done(
                            TransferStatus.TIMEOUT,
                            step="MISSION_COUNT",
                            detail=schedule.describe("MISSION_COUNT", "MISSION_REQUEST"),
                        )
                    self._send(counters, count_message)
                    counters.resent += 1
                    schedule.sent()
                    deadline = schedule.deadline
                    continue
                if state == "SENDING":
                    self._cancel(counters, mission_type)
                    return done(
                        TransferStatus.TIMEOUT,
                        step=f"MISSION_REQUEST seq {last_sent_seq + 1}",
                        detail=f"vehicle stopped requesting items: nothing for "
                        f"{t.upload_silence_s:g} s after item {last_sent_seq} of {count}",
                        seq=last_sent_seq + 1,
                    )
                # WAIT_FINAL_ACK
                if final_resends < 2:
                    self._send(counters, wire[-1])
                    counters.resent += 1
                    final_resends += 1
                    last_sent_was_resend = True
                    deadline = now + final_waits[final_resends]
                    continue
                return done(
                    TransferStatus.NO_FINAL_ACK,
                    step="final MISSION_ACK",
                    detail=f"all {count} items were sent but the vehicle never acknowledged "
                    "the upload",
                    seq=count - 1,
                )

            counters.received += 1
            message = received.message
            # ---- requests -------------------------------------------------------------
            if isinstance(message, MissionRequest):
                seq = message.seq
                if count == 0 or seq >= count:
                    self._cancel(counters, mission_type)
                    return done(
                        TransferStatus.PROTOCOL_ERROR,
                        step=f"MISSION_REQUEST seq {seq}",
                        detail=f"vehicle requested item {seq} but the plan has {count} "
                        f"item{'s' if count != 1 else ''} (seq 0..{count - 1})",
                        seq=seq,
                    )
                requests_per_seq[seq] += 1
                if requests_per_seq[seq] > 1:
                    counters.repeat_requests += 1
                if requests_per_seq[seq] > t.request_repeat_limit:
                    self._cancel(counters, mission_type)
                    return done(
                        TransferStatus.TIMEOUT,
                        step=f"MISSION_ITEM_INT seq {seq}",
                        detail=f"vehicle requested item {seq} {requests_per_seq[seq]} times "
                        "and never accepted it",
                        seq=seq,
                    )
                if seq == last_sent_seq + 1 and not last_sent_was_resend and last_sent_seq >= 0:
                    # item k -> request k+1; may include a vehicle re-request interval, so it
                    # only sizes this upload's final-ACK wait, not the download timer
                    upload_rtt.add(now - last_sent_at)
                self._send(counters, wire[seq])
                last_sent_was_resend = seq in sent_seqs
                if last_sent_was_resend:
                    counters.resent += 1
                sent_seqs.add(seq)
                last_sent_seq, last_sent_at = seq, now
                if progress is not None and seq + 1 > highest_progress:
                    highest_progress = seq + 1
                    progress(highest_progress, count)
                if seq == count - 1:
                    state = "WAIT_FINAL_ACK"
                    first = min(max(2.0 * upload_rtt.timeout(t.ack_s, t.min_retry_s), 0.1), t.ack_s)
                    final_waits = [first, 2.0 * first, t.ack_s]
                    final_resends = 0
                    deadline = now + final_waits[0]
                else:
                    state = "SENDING"
                    deadline = now + t.upload_silence_s
                continue
            # ---- acks -----------------------------------------------------------------
            if isinstance(message, MissionAck):
                result = MissionResult.from_wire(message.type)
                if result == MissionResult.ACCEPTED:
                    if len(sent_seqs) == count:
                        return done(TransferStatus.SUCCESS, step="final MISSION_ACK")
                    self._cancel(counters, mission_type)
                    return done(
                        TransferStatus.PROTOCOL_ERROR,
                        step="MISSION_ACK",
                        detail=f"vehicle accepted the upload after only {len(sent_seqs)} of "
                        f"{count} items had been requested",
                        vehicle_result=result,
                    )
                if result == MissionResult.INVALID_SEQUENCE:
                    counters.ignored += 1  # duplicate/out-of-sequence item dropped: not fatal
                    continue
                if result == MissionResult.OPERATION_CANCELLED:
                    return done(
                        TransferStatus.CANCELLED,
                        step=f"MISSION_ITEM_INT seq {last_sent_seq}"
                        if last_sent_seq >= 0
                        else "MISSION_COUNT",
                        detail="vehicle cancelled the upload",
                        vehicle_result=result,
                    )
                if state == "WAIT_FIRST_REQUEST":
                    if result == MissionResult.NO_SPACE:
                        return done(
                            TransferStatus.NO_SPACE,
                            step="MISSION_COUNT",
                            detail=f"vehicle has no room for {count} {type_label(mission_type)} "
                            f"items ({result_label(result)})",
                            vehicle_result=result,
                        )
                    if result in (MissionResult.ERROR, MissionResult.DENIED):
                        # Busy with another transfer (PX4: ERROR, ArduPilot: DENIED). Try again
                        # when the COUNT timer runs out, within the same attempt budget.
                        busy_result = result
                        if self._download_ack is not None and ack_repeats < BUSY_ACK_REPEATS:
                            # Most likely our own last download: its final ACK was lost and
                            # PX4 keeps sending for 5 s. Repeat the ACK, then the COUNT (a
                            # few times only: if another GCS is the cause, this cannot help).
                            ack_repeats += 1
                            self._send(counters, self._download_ack)
                            self._send(counters, count_message)
                            counters.resent += 2
                            schedule.sent()
                            deadline = schedule.deadline
                        continue
                    return done(
                        TransferStatus.REJECTED,
                        step="MISSION_COUNT",
                        detail=f"vehicle refused the upload with {result_label(result)}",
                        vehicle_result=result,
                    )
                if result == MissionResult.ERROR and schedule.sends > 1 and state == "SENDING":
                    # PX4 answers a duplicate COUNT that reached it after item 0 with ERROR
                    # ("Busy") and carries on (reference §7.2): let the timers decide.
                    counters.ignored += 1
                    continue
                if state == "WAIT_FINAL_ACK" and final_resends > 0:
                    # ArduPilot answers a repeated last item with an error after it finished.
                    return done(
                        TransferStatus.NO_FINAL_ACK,
                        step="final MISSION_ACK",
                        detail=f"the final ACK was lost and the repeated last item drew "
                        f"{result_label(result)}",
                        vehicle_result=result,
                        seq=count - 1,
                    )
                seq = last_sent_seq
                return done(
                    TransferStatus.REJECTED,
                    step=f"MISSION_ITEM_INT seq {seq}",
                    detail=f"item {seq}: " + _reason_for_item(result, items[seq]),
                    vehicle_result=result,
                    seq=seq,
                )
            counters.ignored += 1  # COUNT / ITEM / REQUEST_LIST of this type: not ours to use

    # -- download -------------------------------------------------------------------------
    def download(
        self, mission_type: MissionType, *, progress: ProgressCallback | None = None
    ) -> TransferOutcome:
        """Read plan type ``mission_type`` from the vehicle; ``outcome.items`` holds it."""
        mission_type = MissionType(mission_type)
        if mission_type == MissionType.ALL:
            raise ValueError("MAV_MISSION_TYPE_ALL is only valid for clear")
        self.link.last_statustext = None
        try:
            return self._download(mission_type, progress)
        except KeyboardInterrupt:
            self._cancel(_Counters(), mission_type)
            raise

    def _download(
        self, mission_type: MissionType, progress: ProgressCallback | None
    ) -> TransferOutcome:
        t = self.timeouts
        counters = _Counters()
        started = time.monotonic()
        op = Operation.DOWNLOAD

        def done(status: TransferStatus, **kwargs: object) -> TransferOutcome:
            return self._outcome(op, mission_type, status, counters, started, **kwargs)

        # ---- WAIT_COUNT ---------------------------------------------------------------
        request_list = MissionRequestList(*self._target, int(mission_type))
        count: int | None = None
        schedule = ControlSchedule(t, self.rtt)
        while count is None:
            if schedule.sends and schedule.exhausted:
                self._cancel(counters, mission_type)
                return done(
                    TransferStatus.TIMEOUT,
                    step="MISSION_REQUEST_LIST",
                    detail=schedule.describe("MISSION_REQUEST_LIST", "MISSION_COUNT"),
                )
            self._send(counters, request_list)
            if schedule.sends:
                counters.resent += 1
            schedule.sent()
            list_sent_at = time.monotonic()
            deadline = schedule.deadline
            while (left := deadline - time.monotonic()) > 0:
                received = self._recv(left, mission_type)
                if received is None:
                    break
                counters.received += 1
                message = received.message
                if isinstance(message, MissionCount):
                    count = message.count
                    if schedule.sends == 1:
                        self.rtt.add(time.monotonic() - list_sent_at)
                    break
                if isinstance(message, MissionAck) and message.type != MissionResult.ACCEPTED:
                    result = MissionResult.from_wire(message.type)
                    busy = result in (MissionResult.DENIED, MissionResult.ERROR)
                    return done(
                        TransferStatus.BUSY if busy else TransferStatus.REJECTED,
                        step="MISSION_REQUEST_LIST",
                        detail=f"vehicle refused the download with {result_label(result)}",
                        vehicle_result=result,
                    )
                counters.ignored += 1

        if count == 0:
            self._send(counters, MissionAck(*self._target, MissionResult.ACCEPTED, mission_type))
            if progress is not None:
                progress(0, 0)
            return done(TransferStatus.SUCCESS, step="MISSION_COUNT")

        # ---- WAIT_ITEM(seq) -----------------------------------------------------------
        items: list[MissionItem] = []
        for seq in range(count):
            request = MissionRequest(*self._target, seq, int(mission_type), int_form=True)
            self._send(counters, request)
            first_sent = last_sent = time.monotonic()
            sends = 1
            consecutive = 0
            got: MissionItemInt | None = None
            while got is None:
                # gentle back-off after three misses in a row: doubling would make the
                # expected wait per item grow without bound once loss nears 50 % per try
                interval = self.rtt.timeout(t.item_s, t.min_retry_s) * (
                    RETRY_BACKOFF ** max(0, consecutive - 3)
                )
                wait = min(interval, t.item_s) - (time.monotonic() - last_sent)
                received = self._recv(wait, mission_type)
                now = time.monotonic()
                if received is None:
                    if now - first_sent >= t.item_s * (t.retries + 1) and sends > t.retries:
                        self._cancel(counters, mission_type)
                        return done(
                            TransferStatus.TIMEOUT,
                            step=f"MISSION_REQUEST_INT seq {seq}",
                            detail=f"no MISSION_ITEM_INT seq {seq} after {sends} requests "
                            f"over {now - first_sent:.1f} s",
                            seq=seq,
                        )
                    self._send(counters, request)
                    counters.resent += 1
                    sends += 1
                    consecutive += 1
                    last_sent = now
                    continue
                counters.received += 1
                message = received.message
                if isinstance(message, MissionItemInt):
                    if message.seq == seq:
                        got = message
                        if sends == 1:
                            self.rtt.add(now - first_sent)
                    else:
                        counters.ignored += 1  # duplicate or stale item
                    continue
                if isinstance(message, MissionAck) and message.type != MissionResult.ACCEPTED:
                    result = MissionResult.from_wire(message.type)
                    return done(
                        TransferStatus.REJECTED,
                        step=f"MISSION_REQUEST_INT seq {seq}",
                        detail=f"vehicle ended the download at item {seq} with "
                        f"{result_label(result)}",
                        vehicle_result=result,
                        seq=seq,
                    )
                counters.ignored += 1  # duplicate COUNT, stale ACK, ...
            try:
                items.append(item_from_wire(got))
            except ValueError as err:
                self._cancel(counters, mission_type)
                return done(
                    TransferStatus.PROTOCOL_ERROR,
                    step=f"MISSION_ITEM_INT seq {seq}",
                    detail=f"vehicle sent an invalid item {seq}: {err}",
                    seq=seq,
                )
            if progress is not None:
                progress(seq + 1, count)

        self._download_ack = MissionAck(*self._target, MissionResult.ACCEPTED, mission_type)
        self._send(counters, self._download_ack)
        return done(TransferStatus.SUCCESS, step="MISSION_ACK", items=tuple(items))

    # -- clear ----------------------------------------------------------------------------
    def clear(self, mission_type: MissionType) -> TransferOutcome:
        """MISSION_CLEAR_ALL for one plan type (or ALL, which ArduPilot does not support)."""
        mission_type = MissionType(mission_type)
        self.link.last_statustext = None
        t = self.timeouts
        counters = _Counters()
        started = time.monotonic()
        op = Operation.CLEAR
        message_out = MissionClearAll(*self._target, int(mission_type))
        schedule = ControlSchedule(t, self.rtt)
        while not (schedule.sends and schedule.exhausted):
            self._send(counters, message_out)
            if schedule.sends:
                counters.resent += 1
            schedule.sent()
            deadline = schedule.deadline
            while (left := deadline - time.monotonic()) > 0:
                received = self._recv(left, mission_type)
                if received is None:
                    break
                counters.received += 1
                if not isinstance(received.message, MissionAck):
                    counters.ignored += 1
                    continue
                result = MissionResult.from_wire(received.message.type)
                if result == MissionResult.ACCEPTED:
                    return self._outcome(
                        op,
                        mission_type,
                        TransferStatus.SUCCESS,
                        counters,
                        started,
                        step="MISSION_ACK",
                    )
                return self._outcome(
                    op,
                    mission_type,
                    TransferStatus.REJECTED,
                    counters,
                    started,
                    step="MISSION_CLEAR_ALL",
                    detail=f"vehicle refused to clear with {result_label(result)}",
                    vehicle_result=result,
                )
        return self._outcome(
            op,
            mission_type,
            TransferStatus.TIMEOUT,
            counters,
            started,
            step="MISSION_CLEAR_ALL",
            detail=schedule.describe("MISSION_CLEAR_ALL", "MISSION_ACK"),
        )
