"""The mission protocol's pure core: scripted message orders, a fake clock, no sockets.

Each test feeds an :mod:`uavplan.mavlink.machines` state machine the exact sequence of
vehicle messages and timer expiries of one case (reordering, duplicates, stale answers of an
earlier transfer) and checks what it sends and how it ends. Nothing sleeps or reads a clock.
"""

from __future__ import annotations

import math

import pytest

from uavplan.mavlink.machines import (
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


def test_a_late_duplicate_request_that_ends_the_download_restarts_it() -> None:
    """PX4 ends a download on an out-of-order request ("Req. WP was unexpected"), which a
    late duplicate of our own request can cause: the read-back starts over, not fails."""
    wire = _wire(_items(3))
    s = _download()
    s.give(_count(3))
    s.give(_item_from_vehicle(wire, 0))
    s.give(_item_from_vehicle(wire, 1))
    s.give(ack(MissionResult.ERROR))  # the vehicle really ended it
    s.expire()  # ... so our repeated request for item 2 draws nothing
    assert s.sent[-1] == MissionRequestList(*TARGET, int(MISSION))
    s.give(_count(3))
    for seq in range(3):
        s.give(_item_from_vehicle(wire, seq))
    finished = s.machine.finished
    assert finished is not None and finished.status is TransferStatus.SUCCESS
    assert len(finished.items) == 3


def _interval_of_next_re_request(s: Script) -> float:
    """Let the pending request go unanswered: how long the machine waits after re-sending it."""
    s.expire()
    return s.machine.deadline - s.now


def test_an_item_that_comes_again_late_leaves_re_requests_fast() -> None:
    """A late second copy of an item is no reason to slow down: a vehicle that takes
    duplicate requests in its stride (ArduPilot) would only pay for it on every lost packet.
    Only a vehicle that ends the download raises the interval (next test)."""
    wire = _wire(_items(3))
    s = _download()
    s.give(_count(3))
    s.give(_item_from_vehicle(wire, 0))  # 1 ms round trips: the estimate is small
    assert _interval_of_next_re_request(s) == pytest.approx(T.min_retry_s)
    s.give(_item_from_vehicle(wire, 1))  # the answer to the re-request
    s.give(_item_from_vehicle(wire, 1), dt_s=0.040)  # ... and the late answer to the first
    assert _interval_of_next_re_request(s) == pytest.approx(T.min_retry_s)
    s.give(_item_from_vehicle(wire, 2))
    finished = s.machine.finished
    assert finished is not None and finished.status is TransferStatus.SUCCESS


def _ended_by_the_vehicle(s: Script) -> None:
    s.give(ack(MissionResult.ERROR))
    s.give(ack(MissionResult.ERROR))
    assert s.sent[-1] == MissionRequestList(*TARGET, int(MISSION))


def test_each_end_of_the_download_by_the_vehicle_makes_re_requests_wait_longer() -> None:
    """PX4 ends a download when a late copy of a request we sent twice reaches it after it
    moved on. The copy was at most as late as the time from our first request of that item
    to our first request of the item the vehicle no longer answered: after starting over,
    re-requests wait a quarter longer than that (at most four times as long as before), and
    each further end doubles the wait, never beyond item_s."""
    wire = _wire(_items(3))
    s = _download()
    s.give(_count(3))
    s.give(_item_from_vehicle(wire, 0))
    asked_1 = s.now
    assert _interval_of_next_re_request(s) == pytest.approx(T.min_retry_s)
    s.give(_item_from_vehicle(wire, 1), dt_s=0.015)  # request 2 goes out 25 ms after 1's
    late_s = s.now - asked_1
    _ended_by_the_vehicle(s)  # our first request for item 1 arrived late
    s.give(_count(3))
    s.give(_item_from_vehicle(wire, 0))
    first = _interval_of_next_re_request(s)
    assert first == pytest.approx(1.25 * late_s)
    _ended_by_the_vehicle(s)  # again, with nothing asked twice since the restart
    s.give(_count(3))
    assert _interval_of_next_re_request(s) == pytest.approx(2.0 * first)
    for _ in range(3):
        _ended_by_the_vehicle(s)
        s.give(_count(3))
    assert _interval_of_next_re_request(s) == pytest.approx(T.item_s)
    for seq in range(3):
        s.give(_item_from_vehicle(wire, seq))
    finished = s.machine.finished
    assert finished is not None and finished.status is TransferStatus.SUCCESS


def test_a_vehicle_that_keeps_ending_the_download_is_rejected_after_the_retry_budget() -> None:
    s = _download()
    wire = _wire(_items(2))
    attempts = 0
    while s.machine.finished is None:
        attempts += 1
        s.give(_count(2))
        s.give(_item_from_vehicle(wire, 0))
        s.give(ack(MissionResult.ERROR))
        s.give(ack(MissionResult.ERROR))
    finished = s.machine.finished
    assert finished.status is TransferStatus.REJECTED
    assert attempts == T.retries + 1
    assert "ended the download at item 1" in finished.detail


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
