"""The mission protocol's pure core: scripted message orders, a fake clock, no sockets.

Each test feeds an :mod:`uavplan.mavlink.machines` state machine the exact sequence of
vehicle messages and timer expiries of one case (reordering, duplicates, stale answers of an
earlier transfer) and checks what it sends and how it ends. Nothing sleeps or reads a clock.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest

from uavplan.mavlink.machines import (
    ENDED_AFTER_RESENDS,
    SILENT_END_RESENDS,
    ClearMachine,
    DownloadMachine,
    Machine,
    ProtocolTimeouts,
    RoundTripEstimator,
    TransferStatus,
    UploadMachine,
)
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
)
from uavplan.mavlink.protocol import item_to_wire
from uavplan.mission.items import MavCmd, MavFrame, MissionItem, MissionType

TARGET = (1, 1)
GCS = (255, 190)
T = ProtocolTimeouts()  # the spec defaults: ack 1.5 s, item 0.25 s, silence 3 s, 5 retries
MISSION = MissionType.MISSION


def _items(n: int) -> list[MissionItem]:
    return [
        MissionItem(
            MavCmd.NAV_WAYPOINT,
            MavFrame.GLOBAL_RELATIVE_ALT,
            param1=0.0,
            x=47.0 + i * 1e-4,
            y=8.0,
            z=30.0 + i,
        )
        for i in range(n)
    ]


def _wire(items: list[MissionItem]) -> list[MissionItemInt]:
    return [item_to_wire(it, seq, MISSION, *TARGET) for seq, it in enumerate(items)]


def request(seq: int) -> MissionRequest:
    return MissionRequest(*GCS, seq, int(MISSION), int_form=True)


def ack(result: MissionResult) -> MissionAck:
    return MissionAck(*GCS, int(result), int(MISSION))


class Script:
    """Drives a machine with a fake clock; collects everything it sends."""

    def __init__(self, machine: Machine, now: float = 100.0) -> None:
        self.machine = machine
        self.now = now
        self.sent: list[Message] = list(machine.start(now))

    def tick(self, dt_s: float = 0.001) -> None:
        self.now += dt_s

    def give(self, message: Message, dt_s: float = 0.001) -> list[Message]:
        self.tick(dt_s)
        out = self.machine.on_message(message, self.now)
        self.sent += out
        return out

    def expire(self) -> list[Message]:
        """Nothing arrives until the machine's deadline."""
        self.now = max(self.now, self.machine.deadline)
        out = self.machine.on_timeout(self.now)
        self.sent += out
        return out


def _upload(n: int) -> tuple[Script, list[MissionItemInt]]:
    items = _items(n)
    wire = _wire(items)
    machine = UploadMachine(TARGET, MISSION, items, wire, T, RoundTripEstimator())
    return Script(machine), wire


# ---------------------------------------------------------------------------------------------
# upload


def test_upload_sends_count_then_answers_each_request() -> None:
    s, wire = _upload(3)
    assert s.sent == [MissionCount(*TARGET, 3, int(MISSION))]
    for seq in range(3):
        assert s.give(request(seq)) == [wire[seq]]
    s.give(ack(MissionResult.ACCEPTED))
    assert s.machine.finished is not None
    assert s.machine.finished.status is TransferStatus.SUCCESS


def test_upload_ignores_a_stale_error_ack_when_the_vehicle_keeps_requesting() -> None:
    """Reordered + duplicated: DENIED/ERROR answering a late duplicate of an earlier
    transfer's message lands mid-upload; the next request proves it was not ours."""
    s, wire = _upload(4)
    s.give(request(0))
    s.give(request(1))
    assert s.give(ack(MissionResult.DENIED)) == []  # stale: no reaction yet
    assert s.machine.finished is None
    assert s.give(request(2)) == [wire[2]]
    s.give(ack(MissionResult.ERROR))  # and another, in the final phase
    s.give(request(3))
    s.give(ack(MissionResult.ACCEPTED))
    finished = s.machine.finished
    assert finished is not None and finished.status is TransferStatus.SUCCESS
    assert s.machine.counters.ignored == 2


def test_upload_error_ack_followed_by_silence_is_the_vehicles_refusal_of_that_item() -> None:
    s, _wire_items = _upload(5)
    s.give(request(0))
    s.give(request(1))
    s.give(request(2))
    s.give(ack(MissionResult.ERROR))
    before = s.now
    s.expire()
    finished = s.machine.finished
    assert finished is not None
    assert finished.status is TransferStatus.REJECTED
    assert finished.step == "MISSION_ITEM_INT seq 2"
    assert finished.vehicle_result == MissionResult.ERROR
    assert s.now - before == pytest.approx(T.ack_s)  # the confirmation wait, not 3 s silence


def test_upload_specific_error_result_rejects_at_once() -> None:
    s, _ = _upload(5)
    s.give(request(0))
    s.give(request(1))
    s.give(ack(MissionResult.INVALID_PARAM1))
    finished = s.machine.finished
    assert finished is not None and finished.status is TransferStatus.REJECTED
    assert "item 1" in finished.detail and "param1" in finished.detail


def test_upload_count_lost_every_time_times_out_within_the_spec_budget() -> None:
    s, _ = _upload(3)
    started = s.now
    while s.machine.finished is None:
        s.expire()
    finished = s.machine.finished
    assert finished.status is TransferStatus.TIMEOUT
    assert finished.step == "MISSION_COUNT"
    counts = [m for m in s.sent if isinstance(m, MissionCount)]
    assert len(counts) == 1 + T.retries
    assert s.now - started == pytest.approx((1 + T.retries) * T.ack_s, abs=T.ack_s)
    assert isinstance(s.sent[-1], MissionAck)  # cancelled
    assert s.sent[-1].type == MissionResult.OPERATION_CANCELLED


def test_upload_to_a_busy_vehicle_retries_count_then_says_busy() -> None:
    s, _ = _upload(3)
    while s.machine.finished is None:
        s.give(ack(MissionResult.ERROR))
        if s.machine.finished is None:
            s.expire()
    finished = s.machine.finished
    assert finished.status is TransferStatus.BUSY
    assert "another" in finished.detail


def test_upload_ignores_an_accepted_ack_before_its_first_request() -> None:
    """PX4 re-acks a late duplicate of our previous upload's last item with ACCEPTED."""
    s, _wire_items = _upload(2)
    s.give(ack(MissionResult.ACCEPTED))
    assert s.machine.finished is None
    s.give(request(0))
    s.give(request(1))
    s.give(ack(MissionResult.ACCEPTED))
    assert s.machine.finished is not None
    assert s.machine.finished.status is TransferStatus.SUCCESS


def test_upload_vehicle_that_stops_requesting_times_out_after_the_silence_budget() -> None:
    s, _ = _upload(10)
    for seq in range(5):
        s.give(request(seq))
    last = s.now
    s.expire()
    finished = s.machine.finished
    assert finished is not None and finished.status is TransferStatus.TIMEOUT
    assert finished.step == "MISSION_REQUEST seq 5"
    assert s.now - last == pytest.approx(T.upload_silence_s)


def test_upload_lost_final_ack_re_sends_the_last_item_then_asks_for_a_read_back() -> None:
    s, wire = _upload(2)
    s.give(request(0))
    s.give(request(1))
    assert s.expire() == [wire[1]]
    assert s.expire() == [wire[1]]
    s.expire()
    finished = s.machine.finished
    assert finished is not None and finished.status is TransferStatus.NO_FINAL_ACK


def test_a_late_request_after_the_last_item_ends_in_a_read_back_not_a_refusal() -> None:
    """Every item was asked for and sent; the final ACK was lost, and a late copy of the
    vehicle's request for an earlier item arrives. We answer it, the vehicle (done) says
    "no transfer" and goes quiet: not a refusal of that item, but a case for reading the
    plan back (PX4 kept the new plan)."""
    s, wire = _upload(4)
    for seq in range(4):
        s.give(request(seq))
    assert s.give(request(2), dt_s=0.030) == [wire[2]]  # a late duplicate
    s.give(ack(MissionResult.ERROR))  # PX4 "IGN MISSION_ITEM: No transfer"
    s.expire()
    finished = s.machine.finished
    assert finished is not None and finished.status is TransferStatus.NO_FINAL_ACK
    assert "all 4 items were sent" in finished.detail


def test_the_upload_times_the_link_for_the_read_back_that_follows() -> None:
    """COUNT answered at its first send is a clean round trip: the read-back's REQUEST_LIST
    is re-sent after the short control interval, not after ack_s, if it is lost."""
    rtt = RoundTripEstimator()
    items = _items(2)
    upload = Script(UploadMachine(TARGET, MISSION, items, _wire(items), T, rtt))
    upload.give(request(0), dt_s=0.002)
    upload.give(request(1))
    upload.give(ack(MissionResult.ACCEPTED))
    assert rtt.srtt_s == pytest.approx(0.002)
    download = Script(DownloadMachine(TARGET, MISSION, T, rtt))
    assert download.machine.deadline - download.now == pytest.approx(T.min_control_s)


def test_a_lost_control_message_is_re_sent_twice_at_its_first_interval_then_backs_off() -> None:
    """A link losing a third of its exchanges loses three in a row one time in twenty: the
    first re-sends keep the round trip's interval, later ones double up to ack_s."""
    rtt = RoundTripEstimator()
    rtt.add(0.001)
    s = Script(ClearMachine(TARGET, MISSION, T, rtt))
    waits = []
    for _ in range(7):
        before = s.now
        s.expire()
        waits.append(round(s.now - before, 3))
    assert waits == [0.2, 0.2, 0.2, 0.4, 0.8, 1.5, 1.5]


# ---------------------------------------------------------------------------------------------
# download


def _download() -> Script:
    return Script(DownloadMachine(TARGET, MISSION, T, RoundTripEstimator()))


def _count(n: int) -> MissionCount:
    return MissionCount(*GCS, n, int(MISSION))


def _item_from_vehicle(wire: list[MissionItemInt], seq: int) -> MissionItemInt:
    w = wire[seq]
    return MissionItemInt(*GCS, *(getattr(w, f) for f in _ITEM_FIELDS))


_ITEM_FIELDS = (
    "seq",
    "frame",
    "command",
    "current",
    "autocontinue",
    "param1",
    "param2",
    "param3",
    "param4",
    "x",
    "y",
    "z",
    "mission_type",
)


def _requests(sent: list[Message]) -> list[int]:
    return [m.seq for m in sent if isinstance(m, MissionRequest)]


def test_reordered_packets_stale_error_ack_does_not_end_the_read_back() -> None:
    """The old flake, as a script: right after an upload the vehicle answers a late
    duplicate of our last item with ERROR ("No transfer"); that ACK reaches the verifying
    download, first before the COUNT, then again mid-download. Neither ends it."""
    wire = _wire(_items(4))
    s = _download()
    assert s.sent == [MissionRequestList(*TARGET, int(MISSION))]
    # the stale ACK overtakes the COUNT: we ask again rather than give up
    s.give(ack(MissionResult.ERROR))
    assert s.machine.finished is None
    assert s.sent[-1] == MissionRequestList(*TARGET, int(MISSION))
    s.give(_count(4))
    s.give(_item_from_vehicle(wire, 0))
    # another stale ERROR arrives mid-download: the request is repeated, the item follows
    out = s.give(ack(MissionResult.ERROR))
    assert _requests(out) == [1]
    s.give(_item_from_vehicle(wire, 1))
    s.give(_count(4))  # a duplicate COUNT: ignored
    s.give(_item_from_vehicle(wire, 1))  # duplicate item: ignored
    s.give(_item_from_vehicle(wire, 2))
    s.give(_item_from_vehicle(wire, 3))
    finished = s.machine.finished
    assert finished is not None and finished.status is TransferStatus.SUCCESS
    assert [it.z for it in finished.items] == [w.z for w in wire]
    assert s.sent[-1] == MissionAck(*TARGET, int(MissionResult.ACCEPTED), int(MISSION))


def _ended_by_the_vehicle(s: Script, *, behind_s: float = 0.020) -> None:
    """The vehicle ends the download: its error ACK comes ``behind_s`` after the last item,
    and our re-requests draw nothing until we start over."""
    s.give(ack(MissionResult.ERROR), dt_s=behind_s)
    _ended_by_the_vehicle_after_its_ack(s)


def test_a_late_duplicate_request_that_ends_the_download_restarts_it() -> None:
    """PX4 ends a download on an out-of-order request ("Req. WP was unexpected"), which a
    late duplicate of our own request can cause: the read-back starts over, not fails.
    The end is taken as such once three re-requests after the error ACK drew nothing."""
    wire = _wire(_items(3))
    s = _download()
    s.give(_count(3))
    s.give(_item_from_vehicle(wire, 0))
    s.give(_item_from_vehicle(wire, 1))
    s.give(ack(MissionResult.ERROR))  # the vehicle really ended it
    assert _requests(s.sent[-1:]) == [2]  # asked again at once
    for _ in range(ENDED_AFTER_RESENDS - 1):
        assert _requests(s.expire()) == [2]
    s.expire()
    assert s.sent[-1] == MissionRequestList(*TARGET, int(MISSION))
    s.give(_count(3))
    for seq in range(3):
        s.give(_item_from_vehicle(wire, seq))
    finished = s.machine.finished
    assert finished is not None and finished.status is TransferStatus.SUCCESS
    assert len(finished.items) == 3


def test_a_stale_error_ack_and_a_lost_re_request_do_not_restart_the_download() -> None:
    """On a lossy link the re-request after a stale error ACK (the vehicle answering a late
    copy of something older) is itself lost a third of the time: one silence is no end."""
    wire = _wire(_items(3))
    s = _download()
    s.give(_count(3))
    s.give(_item_from_vehicle(wire, 0))
    s.give(ack(MissionResult.ERROR), dt_s=0.005)
    s.give(ack(MissionResult.ERROR))  # the link duplicated it: still no end
    s.expire()  # the re-request was lost
    s.give(_item_from_vehicle(wire, 1))  # ... the next one is answered: the ACK was stale
    s.give(_item_from_vehicle(wire, 2))
    finished = s.machine.finished
    assert finished is not None and finished.status is TransferStatus.SUCCESS
    assert not any(isinstance(m, MissionRequestList) for m in s.sent[1:])


def test_a_silent_end_is_noticed_after_ten_unanswered_re_requests() -> None:
    """PX4's error ACK for the end was lost: the download starts over once
    SILENT_END_RESENDS re-requests in a row drew nothing, well within item_s x (1 + retries)
    (the budget after which a dead link gives up)."""
    wire = _wire(_items(3))
    s = _download()
    s.give(_count(3))
    s.give(_item_from_vehicle(wire, 0))
    silent_from = s.now
    while not isinstance(s.sent[-1], MissionRequestList):
        s.expire()
    assert _requests(s.sent).count(1) == 1 + SILENT_END_RESENDS
    assert s.now - silent_from < T.item_s * (T.retries + 1) / 2


def _interval_of_next_re_request(s: Script) -> float:
    """Let the pending request go unanswered: how long the machine waits after re-sending it."""
    s.expire()
    return s.machine.deadline - s.now


def test_a_link_without_delayed_duplicates_keeps_the_fast_re_request_interval() -> None:
    """A link that loses, duplicates and reorders packets, but delays none: lost requests,
    late second copies of items (a held packet released by the next one), and the ends that
    a reordered duplicate request causes on PX4, whose error ACK comes right behind the item
    the releasing request drew. No wait would prevent such an end, so every re-request,
    before and after it, keeps the round trip's interval (the 10 ms floor)."""
    n = 30
    wire = _wire(_items(n))
    s = _download()
    s.give(_count(n))
    intervals = []
    for attempt in range(2):
        for seq in range(n):
            if seq % 3 == 1:
                intervals.append(_interval_of_next_re_request(s))  # its request was lost
            s.give(_item_from_vehicle(wire, seq))
            if seq % 5 == 3:
                # a duplicate of the item before, held back and released behind this one
                s.give(_item_from_vehicle(wire, seq - 1), dt_s=0.0001)
            if attempt == 0 and seq == 20:
                # a duplicate of request 19 released behind request 20: PX4 ends it
                _ended_by_the_vehicle(s, behind_s=0.0002)
                s.give(_count(n))
                break
    finished = s.machine.finished
    assert finished is not None and finished.status is TransferStatus.SUCCESS
    assert len(intervals) > 15
    assert intervals == pytest.approx([T.min_retry_s] * len(intervals))
    assert s.machine.late_floor_s == 0.0


def test_an_end_that_shows_a_late_request_makes_re_requests_wait_longer_than_it() -> None:
    """The evidence: the vehicle ended the download, its error ACK not right behind the
    last item, and we had asked for an earlier item twice. That item's first request can
    have been late by the time from it to the ACK: re-requests now wait a quarter longer.
    A vehicle that takes duplicate requests in its stride never gives this evidence."""
    wire = _wire(_items(6))
    s = _download()
    s.give(_count(6))
    s.give(_item_from_vehicle(wire, 0))
    asked_1 = s.now
    assert _interval_of_next_re_request(s) == pytest.approx(T.min_retry_s)  # asked twice
    s.give(_item_from_vehicle(wire, 1))
    s.give(_item_from_vehicle(wire, 2))
    s.give(ack(MissionResult.ERROR), dt_s=0.020)  # our first request 1 came late
    late_s = s.now - asked_1
    _ended_by_the_vehicle_after_its_ack(s)
    s.give(_count(6))
    s.give(_item_from_vehicle(wire, 0))
    assert _interval_of_next_re_request(s) == pytest.approx(1.25 * late_s)
    assert 1.25 * late_s > 3 * T.min_retry_s
    for seq in range(1, 6):
        s.give(_item_from_vehicle(wire, seq))
    finished = s.machine.finished
    assert finished is not None and finished.status is TransferStatus.SUCCESS


def _ended_by_the_vehicle_after_its_ack(s: Script) -> None:
    while s.machine.finished is None and not isinstance(s.sent[-1], MissionRequestList):
        s.expire()


def _intervals_after_each_end(ended_by: Callable[[Script], None]) -> tuple[list[int], Script]:
    """End a 3-item download after item 1, again and again; the re-request interval (ms)
    at the start of each new attempt."""
    wire = _wire(_items(3))
    s = _download()
    s.give(_count(3))
    intervals = []
    while s.machine.finished is None:
        s.give(_item_from_vehicle(wire, 0))
        s.give(_item_from_vehicle(wire, 1))
        ended_by(s)
        if s.machine.finished is None:
            s.give(_count(3))
            intervals.append(round(1e3 * _interval_of_next_re_request(s)))
    return intervals, s


def test_ends_behind_a_held_back_copy_never_slow_the_re_requests() -> None:
    """However often a reordered duplicate ends the download, its error ACK comes right
    behind the item the releasing request drew: no wait would help, none is added."""
    intervals, s = _intervals_after_each_end(lambda s: _ended_by_the_vehicle(s, behind_s=0.0002))
    assert intervals == [10] * 11  # then the restart budget is spent
    assert s.machine.finished is not None
    assert s.machine.finished.status is TransferStatus.REJECTED


def test_ends_whose_ack_was_lost_double_the_re_request_interval_from_the_third() -> None:
    """An end whose error ACK was lost cannot be read: the first two leave the interval,
    from the third on each doubles it (the lateness may hide from us), up to item_s."""

    def silently(s: Script) -> None:
        _ended_by_the_vehicle_after_its_ack(s)

    intervals, s = _intervals_after_each_end(silently)
    assert intervals == [10, 10, 20, 40, 80, 160] + [250] * 5
    assert s.machine.finished is not None
    assert s.machine.finished.status is TransferStatus.TIMEOUT  # no budget left to restart


def test_a_vehicle_that_keeps_ending_the_download_is_rejected_after_the_retry_budget() -> None:
    """Ending the download at the same item every time spends the restart budget
    (2 x retries); only the first attempt got further than any before it (that restart is
    free)."""
    s = _download()
    wire = _wire(_items(2))
    attempts = 0
    while s.machine.finished is None:
        attempts += 1
        s.give(_count(2))
        s.give(_item_from_vehicle(wire, 0))
        _ended_by_the_vehicle(s)
    finished = s.machine.finished
    assert finished.status is TransferStatus.REJECTED
    assert attempts == 2 * T.retries + 2
    assert "ended the download at item 1" in finished.detail


def test_restarts_that_get_further_each_time_do_not_spend_the_retry_budget() -> None:
    """Late requests end downloads at random places while the interval is learnt: an
    attempt that got further than every one before it is progress, not a refusal."""
    n = 15
    wire = _wire(_items(n))
    s = _download()
    for reach in range(1, n):
        s.give(_count(n))
        for seq in range(reach):
            s.give(_item_from_vehicle(wire, seq))
        _ended_by_the_vehicle(s, behind_s=0.0002)
        assert s.machine.finished is None, reach
    s.give(_count(n))
    for seq in range(n):
        s.give(_item_from_vehicle(wire, seq))
    finished = s.machine.finished
    assert finished is not None and finished.status is TransferStatus.SUCCESS
    assert s.machine.restarts == n - 1 > 2 * T.retries


def test_download_refused_twice_is_busy() -> None:
    s = _download()
    s.give(ack(MissionResult.DENIED))
    assert s.machine.finished is None
    s.give(ack(MissionResult.DENIED))
    assert s.machine.finished is not None
    assert s.machine.finished.status is TransferStatus.BUSY


def test_download_item_that_cannot_be_read_is_a_protocol_error() -> None:
    s = _download()
    s.give(_count(2))
    s.give(
        MalformedMessage(
            39,
            "MISSION_ITEM",
            "cannot convert float NaN to integer",
            *GCS,
            mission_type=int(MISSION),
            seq=0,
        )
    )
    finished = s.machine.finished
    assert finished is not None and finished.status is TransferStatus.PROTOCOL_ERROR
    assert "NaN" in finished.detail and finished.step == "MISSION_ITEM_INT seq 0"


def test_download_item_lost_every_time_times_out_within_the_budget() -> None:
    s = _download()
    s.give(_count(2))
    asked = s.now
    while s.machine.finished is None:
        s.expire()
    finished = s.machine.finished
    assert finished.status is TransferStatus.TIMEOUT
    assert finished.step == "MISSION_REQUEST_INT seq 0"
    assert s.now - asked <= T.item_s * (T.retries + 2)
    assert len(_requests(s.sent)) >= 1 + T.retries


def test_download_of_an_empty_plan_acks_the_count() -> None:
    s = _download()
    s.give(_count(0))
    assert s.machine.finished is not None
    assert s.machine.finished.status is TransferStatus.SUCCESS
    assert isinstance(s.sent[-1], MissionAck)


# ---------------------------------------------------------------------------------------------
# clear


def test_clear_resends_until_acknowledged() -> None:
    s = Script(ClearMachine(TARGET, MISSION, T, RoundTripEstimator()))
    s.expire()
    s.expire()
    s.give(ack(MissionResult.ACCEPTED))
    assert [type(m) for m in s.sent] == [MissionClearAll] * 3
    assert s.machine.finished is not None
    assert s.machine.finished.status is TransferStatus.SUCCESS


def test_machines_never_read_a_clock() -> None:
    """The same script at two different clock origins sends the same messages."""

    def run(origin: float) -> list[Message]:
        items = _items(3)
        machine = UploadMachine(TARGET, MISSION, items, _wire(items), T, RoundTripEstimator())
        s = Script(machine, now=origin)
        s.expire()
        for seq in range(3):
            s.give(request(seq))
        s.expire()
        s.give(ack(MissionResult.ACCEPTED))
        return s.sent

    assert run(0.0) == run(1e6)
    assert not math.isnan(T.ack_s)


def test_a_download_that_goes_silent_mid_way_starts_over_then_ends_on_a_dead_link() -> None:
    """PX4 ended the download and its error ACK was lost: our re-requests draw nothing.
    We start over from REQUEST_LIST; if the link is dead, that step's budget ends it."""
    wire = _wire(_items(3))
    s = _download()
    s.give(_count(3))
    s.give(_item_from_vehicle(wire, 0))
    silent_from = s.now
    while not isinstance(s.sent[-1], MissionRequestList):
        s.expire()
    assert s.machine.finished is None
    while s.machine.finished is None:
        s.expire()
    finished = s.machine.finished
    assert finished.status is TransferStatus.TIMEOUT
    assert finished.step == "MISSION_REQUEST_LIST"
    # bound: one item budget, then one REQUEST_LIST budget
    assert s.now - silent_from <= T.item_s * (T.retries + 2) + (T.retries + 2) * T.ack_s
