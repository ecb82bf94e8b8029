"""Fault matrix: lossy, duplicating and reordering links, and vehicles that misbehave.

Loss is injected by the mock vehicle with a seeded generator, on what it receives and on
what it sends. Each test states the behaviour the MAVLink mission protocol (and
reference §7) asks of the client.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import pytest
from helpers.mavlink_helpers import (
    DEFAULT,
    FAST,
    client_conn,
    connected_client,
    running_mock,
    synthetic_mission,
)

from uavplan.errors import LinkError
from uavplan.mavlink.connection import MavlinkConnection
from uavplan.mavlink.link import VehicleLink
from uavplan.mavlink.messages import (
    Capability,
    CommandAck,
    CommandLong,
    Heartbeat,
    MissionAck,
    MissionCount,
    MissionItemInt,
    MissionRequest,
    MissionRequestList,
    MissionResult,
    Received,
)
from uavplan.mavlink.protocol import (
    MissionClient,
    MissionTransferError,
    Operation,
    ProtocolTimeouts,
    TransferOutcome,
    TransferStatus,
    item_to_wire,
)
from uavplan.mavlink.transfer import compare_items, plan_wire_items, upload_plan
from uavplan.mission.items import Autopilot, MissionItem, MissionPlan, MissionType
from uavplan.sim.faults import MISSION_PROTOCOL_MESSAGES, Faults
from uavplan.sim.vehicle import SimConfig

pytestmark = pytest.mark.timeout(60)

AUTOPILOTS = [Autopilot.PX4, Autopilot.ARDUPILOT]


def lossy(rate: float, seed: int, autopilot: Autopilot = Autopilot.PX4, **kw: object) -> SimConfig:
    # heartbeats at 5 Hz so that discovery is quick even when 30 % of them are lost
    return SimConfig(
        autopilot=autopilot,
        heartbeat_period_s=0.2,
        faults=Faults(drop_rate=rate, seed=seed, **kw),  # type: ignore[arg-type]
    )


def assert_vehicle_holds(vehicle: object, plan: MissionPlan, autopilot: Autopilot) -> None:
    for mission_type in (MissionType.MISSION, MissionType.FENCE, MissionType.RALLY):
        expected = plan_wire_items(plan, mission_type, autopilot)
        stored = vehicle.items(mission_type)  # type: ignore[attr-defined]
        assert compare_items(expected, stored, mission_type, autopilot) is None, mission_type


# ---------------------------------------------------------------------------------------------
# Lossy links


@pytest.mark.parametrize("autopilot", AUTOPILOTS, ids=lambda a: a.label)
@pytest.mark.parametrize(("rate", "seed"), [(0.1, 101), (0.3, 303)], ids=["10%", "30%"])
@pytest.mark.slow
def test_upload_succeeds_and_verifies_through_packet_loss_each_way(
    rate: float, seed: int, autopilot: Autopilot
) -> None:
    plan = synthetic_mission(40, seed=seed, autopilot=autopilot, with_fence=True, with_rally=True)
    with running_mock(lossy(rate, seed, autopilot)) as vehicle:
        with connected_client(vehicle, DEFAULT) as client:
            report = upload_plan(client, plan)
        stats = vehicle.stats()
        assert report.verified
        assert_vehicle_holds(vehicle, plan, autopilot)
    assert stats.dropped_in > 0 and stats.dropped_out > 0
    # the loss really hit the transfers: requests were repeated and items re-sent
    assert sum(o.stats.repeat_requests + o.stats.resent for o in report.outcomes) > 0


@pytest.mark.slow
def test_download_re_requests_lost_items_quickly() -> None:
    """The GCS drives a download: a lost item is re-requested after the measured round
    trip, not after a fixed 250 ms, and strictly in order."""
    plan = synthetic_mission(100, seed=7)
    item_phase = frozenset({"MISSION_REQUEST_INT", "MISSION_ITEM_INT"})
    with running_mock(lossy(0.3, 7, only=item_phase)) as vehicle:
        vehicle.preload(MissionType.MISSION, list(plan.items))
        with connected_client(vehicle, DEFAULT) as client:
            outcome = client.download(MissionType.MISSION)
    assert outcome.ok, outcome.message
    assert (
        compare_items(list(plan.items), outcome.items, MissionType.MISSION, Autopilot.PX4) is None
    )
    assert outcome.stats.resent > 40  # about 103 x (1 / 0.49 - 1) = 107 expected
    # lost ones are re-sent after the measured round trip, not QGC's fixed 250 ms (the
    # time itself is checked with a fake clock in test_mavlink_machines.py)
    assert client.rtt.timeout(DEFAULT.item_s, DEFAULT.min_retry_s) < DEFAULT.item_s


@pytest.mark.parametrize("operation", ["upload", "download", "clear"])
@pytest.mark.slow
def test_total_loss_fails_within_the_retry_budget_and_names_the_step(operation: str) -> None:
    """100 % loss of mission messages (heartbeats still pass): the first step is re-sent
    1 + retries times, ack_s apart, then the operation fails naming it; exit code 4."""
    timeouts = ProtocolTimeouts.scaled(0.25, retries=3)
    config = lossy(1.0, 0, only=MISSION_PROTOCOL_MESSAGES)
    with running_mock(config) as vehicle, connected_client(vehicle, timeouts) as client:
        if operation == "upload":
            outcome = client.upload(MissionType.MISSION, list(synthetic_mission(5, seed=1).items))
            step = "upload mission: MISSION_COUNT"
        elif operation == "download":
            outcome = client.download(MissionType.FENCE)
            step = "download fence: MISSION_REQUEST_LIST"
        else:
            outcome = client.clear(MissionType.RALLY)
            step = "clear rally: MISSION_CLEAR_ALL"
    assert outcome.status is TransferStatus.TIMEOUT
    assert outcome.where == step
    assert outcome.stats.sent >= 4 and outcome.stats.received == 0
    assert outcome.stats.resent >= 3  # 1 + retries sends at least (time: a fake clock)
    with pytest.raises(MissionTransferError) as info:
        outcome.raise_for_status()
    assert info.value.exit_code == 4 and str(info.value).startswith(step)


@pytest.mark.slow
def test_total_loss_of_everything_means_no_heartbeat() -> None:
    with running_mock(lossy(1.0, 0)) as vehicle:
        with pytest.raises(LinkError) as info:
            VehicleLink.connect(client_conn(vehicle), heartbeat_timeout_s=0.8)
    assert info.value.exit_code == 4
    assert info.value.step == "connect: waiting for HEARTBEAT"
    assert "no HEARTBEAT within 0.8 s" in str(info.value)


@pytest.mark.slow
def test_no_heartbeat_with_the_default_timeout() -> None:
    """A vehicle that never sends HEARTBEAT: the default 5 s wait, then a clear error."""
    config = SimConfig(send_heartbeats=False)
    with running_mock(config) as vehicle:
        with pytest.raises(LinkError) as info:
            VehicleLink.connect(client_conn(vehicle))
    assert "no HEARTBEAT within 5 s" in str(info.value)


@pytest.mark.slow
def test_target_system_picks_that_vehicle_only() -> None:
    with running_mock(SimConfig(system_id=7)) as vehicle:
        link = VehicleLink.connect(client_conn(vehicle), target_system=7)
        link.close()
        with pytest.raises(LinkError, match=r"from system 3 .*heard only from system\(s\) \[7\]"):
            VehicleLink.connect(client_conn(vehicle), target_system=3, heartbeat_timeout_s=1.5)


# ---------------------------------------------------------------------------------------------
# Duplicated and reordered packets


@pytest.mark.parametrize("autopilot", AUTOPILOTS, ids=lambda a: a.label)
def test_duplicated_packets_each_way_are_ignored(autopilot: Autopilot) -> None:
    plan = synthetic_mission(80, seed=21, autopilot=autopilot)
    config = SimConfig(autopilot=autopilot, faults=Faults(duplicate_rate=0.3, seed=21))
    with running_mock(config) as vehicle:
        with connected_client(vehicle, DEFAULT) as client:
            report = upload_plan(client, plan)
        assert vehicle.stats().duplicated > 20
        assert_vehicle_holds(vehicle, plan, autopilot)  # every item exactly once
    upload, verify = report.outcomes
    assert upload.stats.repeat_requests > 0  # duplicated requests answered again
    if autopilot == Autopilot.ARDUPILOT:
        # duplicated items draw INVALID_SEQUENCE from ArduPilot, which is not fatal
        assert upload.stats.ignored > 0
    assert verify.stats.ignored > 0  # duplicated items in the download dropped


@pytest.mark.slow
def test_reordered_packets() -> None:
    plan = synthetic_mission(80, seed=22)
    config = SimConfig(faults=Faults(reorder_rate=0.3, duplicate_rate=0.1, seed=22))
    with running_mock(config) as vehicle:
        with connected_client(vehicle, DEFAULT) as client:
            upload_plan(client, plan)
        assert vehicle.stats().reordered > 10
        assert_vehicle_holds(vehicle, plan, Autopilot.PX4)


def _stale_refusal(mission_type: MissionType) -> TransferOutcome:
    """What the read-back's machine reports when two stale "no transfer" ACKs (the vehicle's
    answers to late duplicates of our own items) beat the vehicle's COUNT."""
    return TransferOutcome(
        Operation.DOWNLOAD,
        mission_type,
        TransferStatus.BUSY,
        step="MISSION_REQUEST_LIST",
        detail="vehicle refused the download with MAV_MISSION_ERROR (another transfer running?)",
        vehicle_result=MissionResult.ERROR,
    )


@pytest.mark.parametrize("second", ["answers", "busy"])
def test_a_refused_read_back_is_asked_once_more(
    second: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A read-back refused right after our upload is asked again before the upload is called
    taken over: stale refusals on a duplicating, reordering link must not fail a good upload
    (seen once in the suite, test_reordered_packets); a vehicle still busy fails as before."""
    plan = synthetic_mission(12, seed=23)
    with running_mock() as vehicle:
        with connected_client(vehicle, DEFAULT) as client:
            real = client.download
            calls: list[MissionType] = []

            def download(mission_type: MissionType, **kwargs: object) -> TransferOutcome:
                calls.append(mission_type)
                if len(calls) == 1 or second == "busy":
                    return _stale_refusal(mission_type)
                return real(mission_type, **kwargs)  # type: ignore[arg-type]

            monkeypatch.setattr(client, "download", download)
            if second == "answers":
                report = upload_plan(client, plan)
                # (then the plan types it has not, to see what the vehicle keeps)
                assert calls[:2] == [MissionType.MISSION, MissionType.MISSION], calls
                assert report.verified and report.outcomes[2].ok, report.outcomes
            else:
                with pytest.raises(MissionTransferError, match="another upload took over"):
                    upload_plan(client, plan)
                assert calls == [MissionType.MISSION, MissionType.MISSION], calls
        assert_vehicle_holds(vehicle, plan, Autopilot.PX4)


# ---------------------------------------------------------------------------------------------
# Vehicles that answer with errors or break the protocol


@pytest.mark.parametrize(
    ("result", "expected_text"),
    [
        (MissionResult.INVALID_PARAM7, "z = "),
        (MissionResult.UNSUPPORTED_FRAME, "does not support frame 3"),
        (MissionResult.ERROR, "with MAV_MISSION_ERROR"),
        (MissionResult.DENIED, "with MAV_MISSION_DENIED"),
        (MissionResult.INVALID_PARAM2, "param2 = 2.0"),
    ],
    ids=lambda v: getattr(v, "name", None),
)
@pytest.mark.parametrize("autopilot", AUTOPILOTS, ids=lambda a: a.label)
def test_error_ack_mid_upload_aborts_and_keeps_the_old_plan(
    autopilot: Autopilot, result: MissionResult, expected_text: str
) -> None:
    old = synthetic_mission(10, seed=31, autopilot=autopilot)
    new = synthetic_mission(30, seed=32, autopilot=autopilot)
    faults = Faults(reject_at_seq=17, reject_result=result)
    with running_mock(SimConfig(autopilot=autopilot, faults=faults)) as vehicle:
        with connected_client(vehicle, FAST) as client:
            upload_plan(client, old)  # 10 items: never reaches seq 17
            with pytest.raises(MissionTransferError) as info:
                upload_plan(client, new)
        assert_vehicle_holds(vehicle, old, autopilot)
    outcome = info.value.outcome
    assert outcome.status is TransferStatus.REJECTED
    assert outcome.vehicle_result == result
    assert outcome.seq == 17 and outcome.where == "upload mission: MISSION_ITEM_INT seq 17"
    message = str(info.value)
    assert f"MAV_MISSION_{result.name}" in message and expected_text in message
    # COUNT and items 0..17, plus re-sends of items the vehicle asked for again; no cancel
    assert outcome.stats.sent == 1 + 18 + outcome.stats.resent


@pytest.mark.parametrize("autopilot", AUTOPILOTS, ids=lambda a: a.label)
def test_request_for_an_out_of_range_seq_is_a_protocol_error(autopilot: Autopilot) -> None:
    plan = synthetic_mission(8, seed=41, autopilot=autopilot)
    faults = Faults(out_of_range_after_seq=4)
    config = SimConfig(autopilot=autopilot, faults=faults)
    with running_mock(config) as vehicle, connected_client(vehicle, FAST) as client:
        wire = plan_wire_items(plan, MissionType.MISSION, autopilot)
        outcome = client.upload(MissionType.MISSION, wire)
        if autopilot == Autopilot.PX4:  # PX4 honours our cancel at once
            assert vehicle.wait_for(lambda v: not v.busy, 5.0)
        assert vehicle.items(MissionType.MISSION) == []
    bad = len(wire) + 2
    assert outcome.status is TransferStatus.PROTOCOL_ERROR
    assert outcome.step == f"MISSION_REQUEST seq {bad}"
    assert f"requested item {bad} but the plan has {len(wire)} items" in outcome.detail
    assert outcome.stats.resent == outcome.stats.repeat_requests  # no timeout: fails at once


def test_accepted_before_all_items_were_requested_is_a_protocol_error() -> None:
    plan = synthetic_mission(12, seed=42)
    config = SimConfig(faults=Faults(accept_early_after_seq=3))
    with running_mock(config) as vehicle, connected_client(vehicle, FAST) as client:
        outcome = client.upload(MissionType.MISSION, list(plan.items))
    assert outcome.status is TransferStatus.PROTOCOL_ERROR
    assert "after only 4 of 15 items" in outcome.detail


@pytest.mark.slow
def test_vehicle_that_stops_requesting_times_out_after_the_silence_budget() -> None:
    plan = synthetic_mission(12, seed=43)
    timeouts = ProtocolTimeouts.scaled(0.3, retries=2)  # silence budget 0.6 s
    config = SimConfig(faults=Faults(silent_after_seq=4))
    with running_mock(config) as vehicle, connected_client(vehicle, timeouts) as client:
        outcome = client.upload(MissionType.MISSION, list(plan.items))
    assert outcome.status is TransferStatus.TIMEOUT
    assert outcome.where == "upload mission: MISSION_REQUEST seq 5"
    assert outcome.stats.resent == outcome.stats.repeat_requests  # silence ends it, no retry


def test_too_many_items_is_no_space_without_retrying() -> None:
    items = [MissionItem(16, x=47.0 + i * 1e-5, y=8.0, z=30.0) for i in range(501)]
    with running_mock() as vehicle, connected_client(vehicle, FAST) as client:
        outcome = client.upload(MissionType.MISSION, items)
    assert outcome.status is TransferStatus.NO_SPACE
    assert outcome.where == "upload mission: MISSION_COUNT"
    assert "no room for 501 mission items" in outcome.message
    assert outcome.stats.sent == 1


def test_ardupilot_no_space_quotes_the_vehicles_statustext() -> None:
    items = [MissionItem(5100, x=47.0, y=8.0, z=30.0)] * 101
    with running_mock(SimConfig(autopilot=Autopilot.ARDUPILOT)) as vehicle:
        with connected_client(vehicle, FAST) as client:
            outcome = client.upload(MissionType.RALLY, items)
    assert outcome.status is TransferStatus.NO_SPACE
    assert 'vehicle: "Only 100 items are supported"' in outcome.message


@pytest.mark.slow
def test_vehicle_busy_with_another_ground_station() -> None:
    """PX4 answers ERROR to a second uploader; we retry COUNT, then report BUSY."""
    with running_mock() as vehicle:
        other = MavlinkConnection.open(client_conn(vehicle), system_id=200, component_id=190)
        try:
            other.send(MissionCount(1, 1, 3))  # opens an upload the other GCS never finishes
            assert vehicle.wait_for(lambda v: v.busy, 5.0)
            with connected_client(vehicle, ProtocolTimeouts.scaled(0.2, retries=2)) as client:
                outcome = client.upload(
                    MissionType.MISSION, list(synthetic_mission(3, seed=1).items)
                )
        finally:
            other.close()
    assert outcome.status is TransferStatus.BUSY
    assert outcome.vehicle_result == MissionResult.ERROR
    assert "another upload took over" in outcome.message
    assert "through 3 MISSION_COUNT attempts" in outcome.message
    assert "MAV_MISSION_ERROR" in outcome.message


@pytest.mark.parametrize("autopilot", AUTOPILOTS, ids=lambda a: a.label)
@pytest.mark.parametrize("verify", [True, False], ids=["verify", "no-verify"])
@pytest.mark.slow
def test_lost_final_ack_is_resolved_by_reading_back(autopilot: Autopilot, verify: bool) -> None:
    """The vehicle's final ACK never arrives: re-send the last item (PX4 re-acks; ArduPilot
    does not), and if still nothing, download and compare before declaring failure."""
    plan = synthetic_mission(15, seed=51, autopilot=autopilot)
    config = SimConfig(
        autopilot=autopilot, faults=Faults(drop_rate=1.0, only=frozenset({"MISSION_ACK"}))
    )
    with running_mock(config) as vehicle, connected_client(vehicle, FAST) as client:
        report = upload_plan(client, plan, verify=verify)
        assert_vehicle_holds(vehicle, plan, autopilot)
    upload = report.outcomes[0]
    assert upload.status is TransferStatus.NO_FINAL_ACK
    assert upload.where == "upload mission: final MISSION_ACK"
    assert report.verified and report.outcomes[-1].ok
    assert any("checked by reading back" in note for note in report.notes)


def test_upload_right_after_a_download_whose_final_ack_was_lost() -> None:
    """PX4 keeps a download open for 5 s when our final ACK is lost and answers a new
    MISSION_COUNT with ERROR ("Busy"). We repeat that ACK and go on at once."""
    plan = synthetic_mission(10, seed=54)
    faults = Faults(drop_rate=1.0, only=frozenset({"MISSION_ACK"}), direction="in")
    with running_mock(SimConfig(faults=faults)) as vehicle:
        vehicle.preload(MissionType.MISSION, list(plan.items))
        with connected_client(vehicle, DEFAULT) as client:
            assert client.download(MissionType.MISSION).ok
            # wait until the vehicle has lost our final ACK
            assert vehicle.wait_for(lambda v: v.stats().dropped_in >= 1, 5.0)
            assert vehicle.busy  # still sending, as far as the vehicle knows
            # from now on the vehicle hears our ACKs again
            vehicle.set_faults(Faults())
            outcome = client.upload(MissionType.MISSION, list(plan.items))
    assert outcome.ok, outcome.message
    assert outcome.stats.resent >= 2


def test_a_read_back_that_differs_is_a_mismatch() -> None:
    """The vehicle stores something else than was sent (here: another GCS's plan landed in
    between); verification reports the first differing item."""
    plan = synthetic_mission(10, seed=52)
    with running_mock() as vehicle, connected_client(vehicle, FAST) as client:
        original_download = client.download

        def tampered(mission_type: MissionType, **kw: object):  # type: ignore[no-untyped-def]
            vehicle.preload(MissionType.MISSION, [*plan.items[:4], plan.items[5], *plan.items[5:]])
            return original_download(mission_type, **kw)  # type: ignore[arg-type]

        client.download = tampered  # type: ignore[method-assign]
        with pytest.raises(MissionTransferError) as info:
            upload_plan(client, plan)
    assert info.value.outcome.status is TransferStatus.MISMATCH
    message = str(info.value)
    assert message.startswith("verify mission: read-back: another upload took over")
    assert "read-back differs: item 4" in message


def test_fence_upload_to_a_vehicle_without_fence_support_is_refused() -> None:
    plan = synthetic_mission(5, seed=53, with_fence=True)
    config = SimConfig(capabilities=int(Capability.MISSION_INT | Capability.MAVLINK2))
    with running_mock(config) as vehicle, connected_client(vehicle, FAST) as client:
        with pytest.raises(LinkError) as info:
            upload_plan(client, plan)
    assert info.value.step == "upload fence: capabilities"
    assert "MISSION_FENCE" in str(info.value)


@pytest.mark.slow
def test_ardupilot_firmware_timing_with_loss() -> None:
    """With ArduPilot's real 1 s re-request interval the client must wait longer than one
    interval for the next request (upload silence budget 3 s), and it does."""
    plan = synthetic_mission(8, seed=61, autopilot=Autopilot.ARDUPILOT, speed_m_s=None)
    config = SimConfig(
        autopilot=Autopilot.ARDUPILOT,
        firmware_timing=True,
        heartbeat_period_s=0.2,
        faults=Faults(drop_rate=0.15, seed=4, only=MISSION_PROTOCOL_MESSAGES),
    )
    with running_mock(config) as vehicle, connected_client(vehicle, DEFAULT) as client:
        outcome = client.upload(
            MissionType.MISSION, plan_wire_items(plan, MissionType.MISSION, Autopilot.ARDUPILOT)
        )
    assert outcome.ok, outcome.message
    assert outcome.stats.repeat_requests >= 1  # a 1 s re-request happened and was answered


# ---------------------------------------------------------------------------------------------
# A scripted vehicle for what the mock never does on its own


@contextmanager
def scripted_vehicle(
    script: Callable[[MavlinkConnection, threading.Event], None],
) -> Iterator[str]:
    """A vehicle endpoint whose mission side is ``script``; heartbeats are sent for it."""
    conn = MavlinkConnection.open(
        "udpin:127.0.0.1:0",
        system_id=1,
        component_id=1,
        heartbeat=Heartbeat(type=2, autopilot=12),
    )
    stop = threading.Event()
    errors: list[BaseException] = []

    def recv(timeout_s: float) -> Received | None:
        """Answer the GCS's heartbeat at once and refuse its commands (no AUTOPILOT_VERSION);
        hand everything else to the script."""
        while True:
            received = MavlinkConnection.recv(conn, timeout_s)
            if received is None:
                return None
            if isinstance(received.message, Heartbeat):
                conn.send(Heartbeat(type=2, autopilot=12))
                continue
            if isinstance(received.message, CommandLong):
                conn.send(CommandAck(received.message.command, 3, 255, 190))  # UNSUPPORTED
                continue
            return received

    conn.recv = recv  # type: ignore[method-assign]

    def run() -> None:
        try:
            script(conn, stop)
        except BaseException as err:  # reported by the test
            errors.append(err)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    try:
        yield f"udpout:127.0.0.1:{conn.local_address[1]}"  # type: ignore[index]
    finally:
        stop.set()
        thread.join(5.0)
        conn.close()
    assert not errors, errors


def test_download_keeps_only_the_requested_item() -> None:
    """Duplicates, stale seqs, another plan type and items for another GCS are all dropped."""
    items = list(synthetic_mission(4, seed=71).items)
    wire = [item_to_wire(it, seq, MissionType.MISSION, 255, 190) for seq, it in enumerate(items)]
    acks: list[MissionAck] = []
    acked = threading.Event()

    def script(conn: MavlinkConnection, stop: threading.Event) -> None:
        while not stop.is_set():
            received = conn.recv(0.05)
            if received is None:
                continue
            msg = received.message
            if isinstance(msg, MissionRequestList):
                conn.send(MissionCount(255, 190, len(wire), 0))
            elif isinstance(msg, MissionRequest):
                seq = msg.seq
                noise: list[MissionItemInt] = [
                    wire[max(0, seq - 1)],  # stale
                    MissionItemInt(**{**_fields(wire[seq]), "mission_type": 1}),  # other type
                    MissionItemInt(**{**_fields(wire[seq]), "target_system": 42, "x": 0}),
                ]
                for message in noise:
                    conn.send(message)
                conn.send(wire[seq])
                conn.send(wire[seq])  # duplicate
            elif isinstance(msg, MissionAck):
                acks.append(msg)
                acked.set()

    with scripted_vehicle(script) as conn_str:
        link = VehicleLink.connect(conn_str, component_id=190)  # the identity it addresses
        try:
            outcome = MissionClient(link, FAST).download(MissionType.MISSION)
            assert acked.wait(5.0)  # the final ACK reached the vehicle
        finally:
            link.close()
    assert outcome.ok
    assert compare_items(items, outcome.items, MissionType.MISSION, Autopilot.PX4) is None
    assert outcome.stats.ignored >= 2 * len(items) - 1  # stale + duplicate (seq 0: no stale)
    assert acks and acks[0].type == MissionResult.ACCEPTED and acks[0].mission_type == 0


def _fields(item: MissionItemInt) -> dict[str, object]:
    return {name: getattr(item, name) for name in item.__slots__}


def test_upload_answers_float_requests_with_item_int_and_ignores_other_types() -> None:
    """MISSION_REQUEST (float, as ArduPilot sends) gets MISSION_ITEM_INT; a request of
    another mission_type (a late duplicate from an earlier transfer) is ignored."""
    items = list(synthetic_mission(3, seed=72).items)
    got: list[MissionItemInt] = []

    def script(conn: MavlinkConnection, stop: threading.Event) -> None:
        while not stop.is_set():
            received = conn.recv(0.05)
            if received is None:
                continue
            msg = received.message
            if isinstance(msg, MissionCount):
                conn.send(MissionRequest(255, 190, 0, 2, int_form=True))  # stale rally request
                conn.send(MissionRequest(255, 190, 0, 0, int_form=False))
            elif isinstance(msg, MissionItemInt):
                got.append(msg)
                if msg.seq + 1 < len(items):
                    conn.send(MissionRequest(255, 190, msg.seq + 1, 0, int_form=False))
                else:
                    conn.send(MissionAck(255, 190, MissionResult.ACCEPTED, 0))

    with scripted_vehicle(script) as conn_str:
        link = VehicleLink.connect(conn_str, component_id=190)  # the identity it addresses
        try:
            outcome = MissionClient(link, FAST).upload(MissionType.MISSION, items)
        finally:
            link.close()
    assert outcome.ok
    assert [m.seq for m in got] == list(range(len(items)))
    assert not any(m.legacy_float for m in got)
    assert [m.current for m in got] == [1] + [0] * (len(items) - 1)
