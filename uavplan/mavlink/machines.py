"""The mission protocol's ground-station side as state machines that do no I/O.

Each machine (:class:`UploadMachine`, :class:`DownloadMachine`, :class:`ClearMachine`)
takes events and returns the messages to send:

- ``start(now)``: the first messages;
- ``on_message(message, now)``: a protocol message of this plan type from the vehicle;
- ``on_timeout(now)``: called once ``now >= machine.deadline`` with nothing received.

``now`` is any monotonic clock in seconds: the driver (:class:`~.protocol.MissionClient`)
passes ``time.monotonic()``, a test passes a fake clock and a scripted message order, which
makes reordering, duplicates and stale answers deterministic to test. A machine is done
when :attr:`Machine.finished` is set; it says how (:class:`Finished`). Nothing here reads a
clock, sleeps or touches a socket.

Every MISSION_ACK is tied to the running transfer before it can end it: an error ACK that
may answer an earlier transfer (a late duplicate of one of our messages reaching the
vehicle after that transfer ended) is held as a *suspect* and only becomes the outcome when
the vehicle's next behaviour confirms it (:class:`UploadMachine`: no further request;
:class:`DownloadMachine`: the re-sent request or REQUEST_LIST is refused again, or the item
never comes). A download the vehicle really ended (PX4 ends one on an out-of-order
request, which a late duplicate of our own request can cause) is restarted from
MISSION_REQUEST_LIST within the retry budget.
"""

from __future__ import annotations

import enum
import math
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass

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
    result_label,
)
from uavplan.mission.items import MavCmd, MissionItem, MissionType

ProgressCallback = Callable[[int, int], None]

#: how often a "busy" answer to MISSION_COUNT makes us repeat our last download's ACK
BUSY_ACK_REPEATS = 4
#: growth of a repeated item re-request interval (after three misses in a row)
RETRY_BACKOFF = 1.5
#: re-sends of a control message (COUNT, REQUEST_LIST, CLEAR_ALL) at its first interval,
#: before the interval doubles
CONTROL_EVEN_RESENDS = 2
#: download: re-requests after an error ACK that must all go unanswered before we take it
#: that the vehicle ended the download (one lost exchange must not restart it)
ENDED_AFTER_RESENDS = 3
#: download: re-requests in a row that draw nothing, after which we take it that the vehicle
#: ended the download and its error ACK was lost (at 40 % loss per exchange, all ten are
#: lost for one item in 10,000; after the first three they back off, about 0.5 s in all at
#: the 10 ms floor, against item_s x (1 + retries) = 1.5 s)
SILENT_END_RESENDS = 10
#: the error results a vehicle also sends outside a transfer (PX4 "No transfer" / "Busy",
#: ArduPilot "request while receiving"): an ACK with one of these may be stale
AMBIGUOUS_RESULTS = frozenset({MissionResult.ERROR, MissionResult.DENIED})

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
    (``ack_s`` while the round trip is unknown); the first :data:`CONTROL_EVEN_RESENDS`
    re-sends wait as long, then each wait doubles up to ``ack_s``. On a link that loses a
    fifth of the packets each way a third of the exchanges fail, and three failures in a
    row (one in twenty) must not cost seconds; a link that stays silent longer still backs
    off. Give up after ``1 + retries`` sends once ``(1 + retries) x ack_s`` have passed,
    the devguide's budget: a fast link retries sooner, a dead one fails no sooner than the
    spec says. The floor keeps a premature duplicate rare: it would restart a PX4
    download, and the MAVSDK server starts a second incoming transfer on a second COUNT.
    """

    def __init__(self, timeouts: ProtocolTimeouts, rtt: RoundTripEstimator, now: float) -> None:
        self._timeouts = timeouts
        self._interval = rtt.timeout(timeouts.ack_s, min(timeouts.min_control_s, timeouts.ack_s))
        self.started = now
        self.sends = 0
        self.deadline = now

    def sent(self, now: float) -> None:
        """Record a send; :attr:`deadline` is when to give up waiting for its answer."""
        if self.sends > CONTROL_EVEN_RESENDS:
            self._interval = min(self._timeouts.ack_s, 2.0 * self._interval)
        self.sends += 1
        self.deadline = now + self._interval

    def exhausted(self, now: float) -> bool:
        t = self._timeouts
        spent = now - self.started
        return self.sends > t.retries and spent >= (t.retries + 1) * t.ack_s - 1e-3

    def describe(self, what: str, answer: str, now: float) -> str:
        spent = now - self.started
        return f"no {answer} after {self.sends} {what} messages over {spent:.1f} s"


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


# Machines


@dataclass(frozen=True)
class Finished:
    """How a machine ended: a :class:`~.protocol.TransferOutcome` without the statistics."""

    status: TransferStatus
    step: str = ""
    detail: str = ""
    vehicle_result: MissionResult | int | None = None
    seq: int | None = None
    items: tuple[MissionItem, ...] = ()


class Counters:
    """Message counts of one transfer (``TransferStats`` without the timing)."""

    def __init__(self) -> None:
        self.sent = 0
        self.received = 0
        self.resent = 0
        self.repeat_requests = 0
        self.ignored = 0


class Machine:
    """Common parts: the outbox, the deadline, the counters and how a machine ends."""

    def __init__(
        self,
        target: tuple[int, int],
        mission_type: MissionType,
        timeouts: ProtocolTimeouts,
        rtt: RoundTripEstimator,
    ) -> None:
        self.target = target
        self.mission_type = MissionType(mission_type)
        self.timeouts = timeouts
        self.rtt = rtt
        self.counters = Counters()
        self.finished: Finished | None = None
        #: when :meth:`on_timeout` is due if nothing arrives before
        self.deadline = 0.0
        self._outbox: list[Message] = []

    # -- events -----------------------------------------------------------------------------
    def start(self, now: float) -> list[Message]:
        self._start(now)
        return self._take()

    def on_message(self, message: Message, now: float) -> list[Message]:
        if self.finished is None:
            self.counters.received += 1
            self._message(message, now)
        return self._take()

    def on_timeout(self, now: float) -> list[Message]:
        if self.finished is None:
            self._timeout(now)
        return self._take()

    # -- for subclasses ---------------------------------------------------------------------
    def _start(self, now: float) -> None:
        raise NotImplementedError

    def _message(self, message: Message, now: float) -> None:
        raise NotImplementedError

    def _timeout(self, now: float) -> None:
        raise NotImplementedError

    def _take(self) -> list[Message]:
        out, self._outbox = self._outbox, []
        return out

    def _send(self, message: Message, *, resend: bool = False) -> None:
        self._outbox.append(message)
        self.counters.sent += 1
        if resend:
            self.counters.resent += 1

    def _ack(self, result: MissionResult) -> MissionAck:
        return MissionAck(*self.target, int(result), int(self.mission_type))

    def _finish(self, status: TransferStatus, *, cancel: bool = False, **kwargs: object) -> None:
        """End the machine; ``cancel`` sends OPERATION_CANCELLED so the vehicle goes idle
        now rather than after its own timeout (reference §1.5)."""
        if cancel:
            self._send(self._ack(MissionResult.OPERATION_CANCELLED))
        self.finished = Finished(status, **kwargs)  # type: ignore[arg-type]


class UploadMachine(Machine):
    """Upload (the vehicle drives and retries)::

        WAIT_FIRST_REQUEST --REQUEST(0..n-1)--> SENDING --REQUEST(n-1)--> WAIT_FINAL_ACK

    WAIT_FIRST_REQUEST: on timeout re-send COUNT (:class:`ControlSchedule`), then TIMEOUT.
    ERROR/DENIED: another transfer is running ("busy"); COUNT is re-sent when its timer
    runs out, within the same budget, then BUSY. If our own last download may be the cause
    (its final ACK lost: PX4 then refuses uploads for 5 s), that ACK is repeated first.
    NO_SPACE fails at once.

    SENDING: every in-range REQUEST / REQUEST_INT is answered with MISSION_ITEM_INT
    (duplicates and older seqs too); seq >= count is a PROTOCOL_ERROR; no request for
    ``upload_silence_s`` is a TIMEOUT, as is one seq requested more than 6 x retries
    times. INVALID_SEQUENCE is ignored (ArduPilot sends it for duplicates). ERROR/DENIED
    may be stale (the vehicle's answer to a late duplicate of something we sent before):
    it becomes REJECTED only if the vehicle then stops requesting for ``ack_s``; any other
    error result is REJECTED at once, naming the item.

    WAIT_FINAL_ACK: ACCEPTED is SUCCESS only if every seq was sent (else PROTOCOL_ERROR);
    silence re-sends the last item twice (PX4 re-acks it), then NO_FINAL_ACK, which the
    caller resolves by reading the plan back (reference §7.6).
    """

    def __init__(
        self,
        target: tuple[int, int],
        mission_type: MissionType,
        items: Sequence[MissionItem],
        wire: Sequence[MissionItemInt],
        timeouts: ProtocolTimeouts,
        rtt: RoundTripEstimator,
        *,
        download_ack: MissionAck | None = None,
        progress: ProgressCallback | None = None,
    ) -> None:
        super().__init__(target, mission_type, timeouts, rtt)
        if len(items) != len(wire):
            raise ValueError("items and wire items differ in length")
        self.items = list(items)
        self.wire = list(wire)
        self.count = len(wire)
        self.progress = progress
        self.download_ack = download_ack
        self.state = "WAIT_FIRST_REQUEST"
        self.count_message = MissionCount(*target, self.count, int(self.mission_type))
        self.schedule: ControlSchedule | None = None
        self.busy_result: MissionResult | int | None = None
        self.ack_repeats = 0
        self.sent_seqs: set[int] = set()
        self.requests_per_seq: Counter[int] = Counter()
        self.last_sent_seq = -1
        self.last_sent_at = 0.0
        self.last_sent_was_resend = False
        self.final_resends = 0
        self.final_waits = [0.0, 0.0, timeouts.ack_s]
        self.highest_progress = 0
        self.upload_rtt = RoundTripEstimator()
        #: an ERROR/DENIED that may be stale: (result, seq it would refuse, when it came)
        self.suspect: tuple[MissionResult | int, int] | None = None

    def _start(self, now: float) -> None:
        self.schedule = ControlSchedule(self.timeouts, self.rtt, now)
        self._send(self.count_message)
        self.schedule.sent(now)
        self.deadline = self.schedule.deadline

    # -- timers -------------------------------------------------------------------------------
    def _timeout(self, now: float) -> None:
        t = self.timeouts
        schedule = self.schedule
        assert schedule is not None
        if self.state == "SENDING" and len(self.sent_seqs) == self.count:
            # Every item had been asked for and sent: a late copy of an earlier request
            # took us back from waiting for the final ACK, and the vehicle, done (its ACK
            # lost), answers the item we re-sent with "no transfer" or not at all. Whether
            # it holds our plan, only a read-back can tell.
            heard = (
                "" if self.suspect is None else f" (it answered {result_label(self.suspect[0])})"
            )
            self._finish(
                TransferStatus.NO_FINAL_ACK,
                step="final MISSION_ACK",
                detail=f"all {self.count} items were sent, then the vehicle asked again for "
                f"item {self.last_sent_seq} and went quiet{heard}",
                vehicle_result=None if self.suspect is None else self.suspect[0],
                seq=self.last_sent_seq,
            )
            return
        if self.suspect is not None and self.state == "SENDING":
            result, seq = self.suspect
            self._refused(result, seq)  # the vehicle stopped requesting: the ACK was ours
            return
        if self.state == "WAIT_FIRST_REQUEST":
            if schedule.exhausted(now):
                if self.busy_result is not None:
                    self._finish(
                        TransferStatus.BUSY,
                        step="MISSION_COUNT",
                        detail=f"another upload took over: the vehicle stayed busy with "
                        f"another transfer through {schedule.sends} MISSION_COUNT attempts "
                        "and kept its plan",
                        vehicle_result=self.busy_result,
                    )
                    return
                self._finish(
                    TransferStatus.TIMEOUT,
                    cancel=True,
                    step="MISSION_COUNT",
                    detail=schedule.describe("MISSION_COUNT", "MISSION_REQUEST", now),
                )
                return
            self._send(self.count_message, resend=True)
            schedule.sent(now)
            self.deadline = schedule.deadline
            return
        if self.state == "SENDING":
            self._finish(
                TransferStatus.TIMEOUT,
                cancel=True,
                step=f"MISSION_REQUEST seq {self.last_sent_seq + 1}",
                detail=f"vehicle stopped requesting items: nothing for "
                f"{t.upload_silence_s:g} s after item {self.last_sent_seq} of {self.count}",
                seq=self.last_sent_seq + 1,
            )
            return
        # WAIT_FINAL_ACK
        if self.final_resends < 2:
            self._send(self.wire[-1], resend=True)
            self.final_resends += 1
            self.last_sent_was_resend = True
            self.deadline = now + self.final_waits[self.final_resends]
            return
        answered = (
            f" (it answered {result_label(self.suspect[0])} once)"
            if self.suspect is not None
            else ""
        )
        self._finish(
            TransferStatus.NO_FINAL_ACK,
            step="final MISSION_ACK",
            detail=f"all {self.count} items were sent but the vehicle never acknowledged "
            f"the upload{answered}",
            vehicle_result=None if self.suspect is None else self.suspect[0],
            seq=self.count - 1,
        )

    # -- messages -----------------------------------------------------------------------------
    def _message(self, message: Message, now: float) -> None:
        if isinstance(message, MissionRequest):
            self._on_request(message.seq, now)
        elif isinstance(message, MissionAck):
            self._on_ack(MissionResult.from_wire(message.type), now)
        else:
            self.counters.ignored += 1  # COUNT / ITEM / REQUEST_LIST of this type: not ours

    def _on_request(self, seq: int, now: float) -> None:
        t = self.timeouts
        count = self.count
        if count == 0 or seq >= count:
            self._finish(
                TransferStatus.PROTOCOL_ERROR,
                cancel=True,
                step=f"MISSION_REQUEST seq {seq}",
                detail=f"vehicle requested item {seq} but the plan has {count} "
                f"item{'s' if count != 1 else ''} (seq 0..{count - 1})",
                seq=seq,
            )
            return
        if self.suspect is not None:
            self.suspect = None  # the vehicle is still receiving: that error ACK was stale
        schedule = self.schedule
        if self.state == "WAIT_FIRST_REQUEST" and schedule is not None and schedule.sends == 1:
            # COUNT sent once and answered: a clean round trip (Karn), the link's, which the
            # read-back that follows needs (without one it waits ack_s for a lost COUNT)
            self.rtt.add(now - schedule.started)
        self.requests_per_seq[seq] += 1
        if self.requests_per_seq[seq] > 1:
            self.counters.repeat_requests += 1
        if self.requests_per_seq[seq] > t.request_repeat_limit:
            self._finish(
                TransferStatus.TIMEOUT,
                cancel=True,
                step=f"MISSION_ITEM_INT seq {seq}",
                detail=f"vehicle requested item {seq} {self.requests_per_seq[seq]} times "
                "and never accepted it",
                seq=seq,
            )
            return
        if seq == self.last_sent_seq + 1 and not self.last_sent_was_resend:
            if self.last_sent_seq >= 0:
                # item k -> request k+1; may include a vehicle re-request interval, so it
                # only sizes this upload's final-ACK wait, not the download timer
                self.upload_rtt.add(now - self.last_sent_at)
        self.last_sent_was_resend = seq in self.sent_seqs
        self._send(self.wire[seq], resend=self.last_sent_was_resend)
        self.sent_seqs.add(seq)
        self.last_sent_seq, self.last_sent_at = seq, now
        if self.progress is not None and seq + 1 > self.highest_progress:
            self.highest_progress = seq + 1
            self.progress(self.highest_progress, count)
        if seq == count - 1:
            self.state = "WAIT_FINAL_ACK"
            first = min(max(2.0 * self.upload_rtt.timeout(t.ack_s, t.min_retry_s), 0.1), t.ack_s)
            self.final_waits = [first, 2.0 * first, t.ack_s]
            self.final_resends = 0
            self.deadline = now + self.final_waits[0]
        else:
            self.state = "SENDING"
            self.deadline = now + t.upload_silence_s

    def _on_ack(self, result: MissionResult | int, now: float) -> None:
        count = self.count
        if result == MissionResult.ACCEPTED:
            if self.state == "WAIT_FIRST_REQUEST" and count > 0:
                self.counters.ignored += 1  # an ACK of an earlier transfer: not ours
                return
            if len(self.sent_seqs) == count:
                self._finish(TransferStatus.SUCCESS, step="final MISSION_ACK")
                return
            self._finish(
                TransferStatus.PROTOCOL_ERROR,
                cancel=True,
                step="MISSION_ACK",
                detail=f"vehicle accepted the upload after only {len(self.sent_seqs)} of "
                f"{count} items had been requested",
                vehicle_result=result,
            )
            return
        if result == MissionResult.INVALID_SEQUENCE:
            self.counters.ignored += 1  # duplicate/out-of-sequence item dropped: not fatal
            return
        if result == MissionResult.OPERATION_CANCELLED:
            self._finish(
                TransferStatus.CANCELLED,
                step=f"MISSION_ITEM_INT seq {self.last_sent_seq}"
                if self.last_sent_seq >= 0
                else "MISSION_COUNT",
                detail="vehicle cancelled the upload",
                vehicle_result=result,
            )
            return
        if self.state == "WAIT_FIRST_REQUEST":
            self._on_count_refused(result, now)
            return
        if self.state == "WAIT_FINAL_ACK" and self.final_resends > 0:
            # ArduPilot answers a repeated last item with an error after it finished.
            self._finish(
                TransferStatus.NO_FINAL_ACK,
                step="final MISSION_ACK",
                detail=f"the final ACK was lost and the repeated last item drew "
                f"{result_label(result)}",
                vehicle_result=result,
                seq=count - 1,
            )
            return
        if result in AMBIGUOUS_RESULTS:
            # Maybe the vehicle refuses our item, maybe it answers a late duplicate of an
            # earlier transfer's message (PX4 "No transfer", a duplicate COUNT after item 0
            # drawing "Busy", ArduPilot DENIED for a stray request). A vehicle that refused
            # stops requesting; one that did not carries on. Let the next request decide.
            if self.suspect is None:
                self.suspect = (result, max(0, self.last_sent_seq))
                if self.state == "SENDING":
                    self.deadline = min(self.deadline, now + self.timeouts.ack_s)
            self.counters.ignored += 1
            return
        self._refused(result, self.last_sent_seq)

    def _on_count_refused(self, result: MissionResult | int, now: float) -> None:
        schedule = self.schedule
        assert schedule is not None
        if result == MissionResult.NO_SPACE:
            self._finish(
                TransferStatus.NO_SPACE,
                step="MISSION_COUNT",
                detail=f"vehicle has no room for {self.count} {type_label(self.mission_type)} "
                f"items ({result_label(result)})",
                vehicle_result=result,
            )
            return
        if result in AMBIGUOUS_RESULTS:
            # Busy with another transfer (PX4: ERROR, ArduPilot: DENIED). Try again when the
            # COUNT timer runs out, within the same attempt budget.
            self.busy_result = result
            if self.download_ack is not None and self.ack_repeats < BUSY_ACK_REPEATS:
                # Most likely our own last download: its final ACK was lost and PX4 keeps
                # sending for 5 s. Repeat the ACK, then the COUNT (a few times only: if
                # another GCS is the cause, this cannot help).
                self.ack_repeats += 1
                self._send(self.download_ack, resend=True)
                self._send(self.count_message, resend=True)
                schedule.sent(now)
                self.deadline = schedule.deadline
            return
        self._finish(
            TransferStatus.REJECTED,
            step="MISSION_COUNT",
            detail=f"vehicle refused the upload with {result_label(result)}",
            vehicle_result=result,
        )

    def _refused(self, result: MissionResult | int, seq: int) -> None:
        seq = max(0, seq)
        self._finish(
            TransferStatus.REJECTED,
            step=f"MISSION_ITEM_INT seq {seq}",
            detail=f"item {seq}: " + _reason_for_item(result, self.items[seq]),
            vehicle_result=result,
            seq=seq,
        )


class DownloadMachine(Machine):
    """Download (the GCS drives and retries)::

        WAIT_COUNT --COUNT(n)--> WAIT_ITEM(0) --ITEM(0)--> ... WAIT_ITEM(n-1) --> ACK ACCEPTED

    WAIT_COUNT: REQUEST_LIST re-sent per :class:`ControlSchedule`; count 0 -> ACK and done.
    An error ACK is tied to our request before it counts: the first one makes us re-send
    REQUEST_LIST at once (a stale ACK is then followed by the COUNT); a second one is the
    vehicle's answer: BUSY (ERROR/DENIED) or REJECTED.

    WAIT_ITEM: REQUEST_INT strictly in order (PX4 aborts on a skipped seq); items of any
    other seq are dropped; a missing item is re-requested, then TIMEOUT after
    item_s x (1 + retries). An error ACK makes us re-send the request at once: the item
    arriving proves the ACK stale. When :data:`ENDED_AFTER_RESENDS` re-requests after it
    draw nothing, or :data:`SILENT_END_RESENDS` in a row do (the ACK was lost), the vehicle
    ended the download (PX4 does so on a late duplicate of our own request), and the
    download starts over from REQUEST_LIST (:meth:`_may_restart` for the budget), then
    REJECTED. An item whose fields cannot be represented
    (:class:`~.messages.MalformedMessage`) is a PROTOCOL_ERROR.

    Item re-requests wait at least :attr:`late_floor_s`, which grows only on evidence (see
    :meth:`_learn_from_end`). The round-trip estimate alone cannot see a link that delays a
    few packets far beyond its usual round trip (Karn: an item that came after a re-request
    is no sample), and a re-request sent before such a late request arrives is a
    duplicate, which PX4 refuses once it has moved on. But a link that duplicates and
    reorders ends PX4 downloads too, at any interval: there a longer wait only slows every
    lost packet. So the floor stays at zero until an end shows the timing of a late
    request, and then it covers that lateness; only ends that keep coming double it. A
    vehicle that takes duplicates in its stride (ArduPilot) never ends a download for them,
    so its re-requests stay fast.
    """

    def __init__(
        self,
        target: tuple[int, int],
        mission_type: MissionType,
        timeouts: ProtocolTimeouts,
        rtt: RoundTripEstimator,
        *,
        progress: ProgressCallback | None = None,
    ) -> None:
        super().__init__(target, mission_type, timeouts, rtt)
        self.progress = progress
        self.request_list = MissionRequestList(*target, int(self.mission_type))
        self.state = "WAIT_COUNT"
        self.schedule: ControlSchedule | None = None
        self.list_sent_at = 0.0
        self.count = 0
        self.seq = 0
        self.items: list[MissionItem] = []
        self.first_sent = self.last_sent = 0.0
        self.sends = 0
        self.consecutive = 0
        #: an error ACK awaiting confirmation, and how many re-requests followed it
        self.suspect: MissionResult | int | None = None
        self.suspect_at = 0.0
        self.suspect_resends = 0
        self.restarts = 0
        #: restarts after an attempt that got no further than an earlier one: the budget
        self.futile_restarts = 0
        #: the furthest seq any attempt waited for
        self.furthest = 0
        #: the ACK ending the download, once sent (the driver keeps it to repeat)
        self.final_ack: MissionAck | None = None
        #: floor of the item re-request interval, raised when the vehicle ends the download
        #: (see above and :meth:`_learn_from_end`)
        self.late_floor_s = 0.0
        #: ends by the vehicle whose error ACK was lost (they cannot be read)
        self.silent_ends = 0
        #: the fastest round trip of this download
        self.fastest_s: float | None = None
        #: this attempt: when we first requested each seq, the seqs requested again, and
        #: when the last item came
        self.first_asked: dict[int, float] = {}
        self.asked_again: set[int] = set()
        self.item_at = 0.0

    def _start(self, now: float) -> None:
        self.state = "WAIT_COUNT"
        self.suspect = None
        self.schedule = ControlSchedule(self.timeouts, self.rtt, now)
        self._send_list(now)

    def _send_list(self, now: float) -> None:
        schedule = self.schedule
        assert schedule is not None
        self._send(self.request_list, resend=schedule.sends > 0 or self.restarts > 0)
        schedule.sent(now)
        self.list_sent_at = now
        self.deadline = schedule.deadline

    def _request(self) -> MissionRequest:
        return MissionRequest(*self.target, self.seq, int(self.mission_type), int_form=True)

    def _sample(self, round_trip_s: float) -> None:
        self.rtt.add(round_trip_s)
        if self.fastest_s is None or round_trip_s < self.fastest_s:
            self.fastest_s = round_trip_s

    def _base_interval(self) -> float:
        """The item re-request interval before any back-off: the round trip's, or the floor."""
        t = self.timeouts
        return min(max(self.rtt.timeout(t.item_s, t.min_retry_s), self.late_floor_s), t.item_s)

    def _item_interval(self) -> float:
        # gentle back-off after three misses in a row: doubling would make the expected
        # wait per item grow without bound once loss nears 50 % per try
        interval = self._base_interval() * RETRY_BACKOFF ** max(0, self.consecutive - 3)
        return min(interval, self.timeouts.item_s)

    def _learn_from_end(self) -> None:
        """The vehicle ended the download on a request it did not expect (PX4 refuses any
        seq but its next one and the one it just sent): a late copy of one of our requests.

        - An end whose error ACK shows how late that request was (:meth:`_end_lateness`)
          sets the floor a quarter above that lateness: re-requests sent sooner are the
          duplicates that end downloads.
        - An end whose ACK shows a copy the link held back and released behind our next
          request, which no wait prevents, leaves the interval as it is.
        - An end whose ACK was lost cannot be read. From the third such end in one download
          on, each doubles the floor (the lateness hides from us).

        Never beyond ``item_s``, QGroundControl's fixed interval."""
        t = self.timeouts
        if self.suspect is None:
            self.silent_ends += 1
            if self.silent_ends > 2:
                self.late_floor_s = min(t.item_s, 2.0 * self._base_interval())
            return
        late_s = self._end_lateness()
        if late_s > 0.0:
            self.late_floor_s = min(t.item_s, max(self.late_floor_s, 1.25 * late_s))

    def _end_lateness(self) -> float:
        """How late the request that ended the download was, as its error ACK shows (0 if
        it shows none).

        - An ACK that came right behind the last item (within two of the download's fastest
          round trips: sooner than an answer to anything we sent after that item) was sent
          with it: the vehicle refused something that reached it right behind our request
          for that item, as a copy the link held back and released with it does.
        - Otherwise the request the vehicle refused is one we sent twice, its first copy
          late: the vehicle had moved past its seq. Of the seqs we asked twice, the latest
          gives the least lateness that explains the end: from our first request for it to
          the error ACK.
        """
        twice = [k for k in self.asked_again if k < self.seq]
        if not twice:
            return 0.0
        if self.suspect_at - self.item_at < 2.0 * (self.fastest_s or 0.0):
            return 0.0
        return max(0.0, self.suspect_at - self.first_asked[max(twice)])

    def _ask_item(self, seq: int, now: float) -> None:
        self.state = "WAIT_ITEM"
        self.seq = seq
        self.suspect = None
        self._send(self._request())
        self.first_asked[seq] = now
        self.first_sent = self.last_sent = now
        self.sends = 1
        self.consecutive = 0
        self.deadline = now + self._item_interval()

    def _may_restart(self) -> bool:
        """Within the restart budget: ``2 x retries`` restarts after attempts that got no
        further than an earlier one. An attempt that got further than every one before it
        is free. A link that ends PX4 downloads at random places (a held-back or late copy
        of a request, several per 200-item read-back on the lossy+flip link) makes most
        attempts end short of the furthest; a vehicle that refuses at the same item every
        time is given up on after ``1 + 2 x retries`` restarts, one that lets each attempt
        go one item further after at most as many restarts as the plan has items."""
        budget = 2 * self.timeouts.retries
        return self.futile_restarts < budget or self.seq > self.furthest

    def _restart(self, now: float, result: MissionResult | int) -> None:
        """The vehicle ended the download: start over, or give up with its reason."""
        if not self._may_restart():
            self._finish(
                TransferStatus.REJECTED,
                step=f"MISSION_REQUEST_INT seq {self.seq}",
                detail=f"vehicle ended the download at item {self.seq} with "
                f"{result_label(result)} ({self.restarts + 1} attempts)",
                vehicle_result=result,
                seq=self.seq,
            )
            return
        self._start_over(now)

    def _start_over(self, now: float) -> None:
        if self.seq > self.furthest:
            self.furthest = self.seq
        else:
            self.futile_restarts += 1
        self._learn_from_end()
        self.first_asked.clear()
        self.asked_again.clear()
        self.restarts += 1
        self.items = []
        self.state = "WAIT_COUNT"
        self.suspect = None
        self.schedule = ControlSchedule(self.timeouts, self.rtt, now)
        self._send_list(now)

    # -- timers -------------------------------------------------------------------------------
    def _timeout(self, now: float) -> None:
        t = self.timeouts
        if self.state == "WAIT_COUNT":
            schedule = self.schedule
            assert schedule is not None
            if schedule.exhausted(now):
                if self.suspect is not None:
                    self._finish_refused_list(self.suspect)
                    return
                self._finish(
                    TransferStatus.TIMEOUT,
                    cancel=True,
                    step="MISSION_REQUEST_LIST",
                    detail=schedule.describe("MISSION_REQUEST_LIST", "MISSION_COUNT", now),
                )
                return
            self._send_list(now)
            return
        # WAIT_ITEM
        if self.suspect is not None and self.suspect_resends >= ENDED_AFTER_RESENDS:
            self._restart(now, self.suspect)  # refused, and the re-requests drew no item
            return
        resumable = (self.seq > 0 or self.restarts > 0) and self._may_restart()
        if resumable and self.consecutive >= SILENT_END_RESENDS:
            # PX4 ends a download silently for us when its error ACK is lost (a late
            # duplicate of our own request reached it out of order; after a restart, one
            # from the attempt before can end the new one at item 0): start over. On a dead
            # link the REQUEST_LIST budget then ends it.
            self._start_over(now)
            return
        if now - self.first_sent >= t.item_s * (t.retries + 1) and self.sends > t.retries:
            if resumable:
                self._start_over(now)
                return
            self._finish(
                TransferStatus.TIMEOUT,
                cancel=True,
                step=f"MISSION_REQUEST_INT seq {self.seq}",
                detail=f"no MISSION_ITEM_INT seq {self.seq} after {self.sends} requests "
                f"over {now - self.first_sent:.1f} s",
                seq=self.seq,
            )
            return
        self.consecutive += 1
        self._ask_again(now)

    def _ask_again(self, now: float) -> None:
        self._send(self._request(), resend=True)
        self.asked_again.add(self.seq)
        self.sends += 1
        if self.suspect is not None:
            self.suspect_resends += 1
        self.last_sent = now
        self.deadline = now + self._item_interval()

    # -- messages -----------------------------------------------------------------------------
    def _message(self, message: Message, now: float) -> None:
        if self.state == "WAIT_COUNT":
            self._wait_count(message, now)
        else:
            self._wait_item(message, now)

    def _finish_refused_list(self, result: MissionResult | int) -> None:
        busy = result in AMBIGUOUS_RESULTS
        self._finish(
            TransferStatus.BUSY if busy else TransferStatus.REJECTED,
            step="MISSION_REQUEST_LIST",
            detail=f"vehicle refused the download with {result_label(result)}"
            + (" (another transfer running?)" if busy else ""),
            vehicle_result=result,
        )

    def _wait_count(self, message: Message, now: float) -> None:
        schedule = self.schedule
        assert schedule is not None
        if isinstance(message, MissionCount):
            if schedule.sends == 1 and self.restarts == 0:
                self._sample(now - self.list_sent_at)
            self.count = message.count
            if self.count == 0:
                self._send(self._ack(MissionResult.ACCEPTED))
                if self.progress is not None:
                    self.progress(0, 0)
                self._finish(TransferStatus.SUCCESS, step="MISSION_COUNT")
                return
            self.items = []
            self._ask_item(0, now)
            return
        if isinstance(message, MissionAck) and message.type != MissionResult.ACCEPTED:
            result = MissionResult.from_wire(message.type)
            if self.suspect is None:
                # maybe the answer to a late duplicate of an earlier transfer's message:
                # ask again at once; a stale ACK is then followed by the COUNT
                self.suspect = result
                self.counters.ignored += 1
                self._send_list(now)
                return
            self._finish_refused_list(result)
            return
        self.counters.ignored += 1

    def _wait_item(self, message: Message, now: float) -> None:
        if isinstance(message, MissionItemInt):
            if message.seq != self.seq:
                self.counters.ignored += 1  # duplicate or stale item
                return
            if self.sends == 1:
                self._sample(now - self.first_sent)
            try:
                item = item_from_wire(message)
            except ValueError as err:
                self._invalid_item(str(err))
                return
            self._got(item, now)
            return
        if isinstance(message, MalformedMessage):
            if message.name in ("MISSION_ITEM", "MISSION_ITEM_INT") and message.seq == self.seq:
                self._invalid_item(f"{message.name} cannot be read: {message.reason}")
            else:
                self.counters.ignored += 1
            return
        if isinstance(message, MissionAck) and message.type != MissionResult.ACCEPTED:
            self.counters.ignored += 1
            if self.suspect is None:
                # the vehicle ended the download, or answers a late copy of something we
                # sent earlier: ask again at once; the item coming proves the ACK stale
                self.suspect = MissionResult.from_wire(message.type)
                self.suspect_at = now
                self.suspect_resends = 0
                self._ask_again(now)
            return
        self.counters.ignored += 1  # duplicate COUNT, ACCEPTED of something else, ...

    def _invalid_item(self, reason: str) -> None:
        self._finish(
            TransferStatus.PROTOCOL_ERROR,
            cancel=True,
            step=f"MISSION_ITEM_INT seq {self.seq}",
            detail=f"vehicle sent an invalid item {self.seq}: {reason}",
            seq=self.seq,
        )

    def _got(self, item: MissionItem, now: float) -> None:
        self.items.append(item)
        self.item_at = now
        if self.progress is not None:
            self.progress(self.seq + 1, self.count)
        if self.seq + 1 < self.count:
            self._ask_item(self.seq + 1, now)
            return
        self.final_ack = self._ack(MissionResult.ACCEPTED)
        self._send(self.final_ack)
        self._finish(TransferStatus.SUCCESS, step="MISSION_ACK", items=tuple(self.items))


class ClearMachine(Machine):
    """MISSION_CLEAR_ALL re-sent per :class:`ControlSchedule` until a MISSION_ACK."""

    def __init__(
        self,
        target: tuple[int, int],
        mission_type: MissionType,
        timeouts: ProtocolTimeouts,
        rtt: RoundTripEstimator,
    ) -> None:
        super().__init__(target, mission_type, timeouts, rtt)
        self.message_out = MissionClearAll(*target, int(self.mission_type))
        self.schedule: ControlSchedule | None = None

    def _start(self, now: float) -> None:
        self.schedule = ControlSchedule(self.timeouts, self.rtt, now)
        self._send_clear(now)

    def _send_clear(self, now: float) -> None:
        schedule = self.schedule
        assert schedule is not None
        self._send(self.message_out, resend=schedule.sends > 0)
        schedule.sent(now)
        self.deadline = schedule.deadline

    def _timeout(self, now: float) -> None:
        schedule = self.schedule
        assert schedule is not None
        if schedule.exhausted(now):
            self._finish(
                TransferStatus.TIMEOUT,
                step="MISSION_CLEAR_ALL",
                detail=schedule.describe("MISSION_CLEAR_ALL", "MISSION_ACK", now),
            )
            return
        self._send_clear(now)

    def _message(self, message: Message, now: float) -> None:
        if not isinstance(message, MissionAck):
            self.counters.ignored += 1
            return
        result = MissionResult.from_wire(message.type)
        if result == MissionResult.ACCEPTED:
            self._finish(TransferStatus.SUCCESS, step="MISSION_ACK")
            return
        self._finish(
            TransferStatus.REJECTED,
            step="MISSION_CLEAR_ALL",
            detail=f"vehicle refused to clear with {result_label(result)}",
            vehicle_result=result,
        )
