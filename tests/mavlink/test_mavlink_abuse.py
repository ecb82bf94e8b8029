"""Hostile and impossible input on the link: the mock keeps serving, the client says why.

Each test here is a crash path of issue 12 that failed before its fix: a packet that
stopped ``uavplan mock-vehicle`` ("ValueError: cannot convert float NaN to integer"), a
download that exited 1 on such an item, values the wire cannot carry (exit 1 instead of
2), a second process silently sharing one ``udpin`` port, NaN in reserved fence params.
Everything runs on 127.0.0.1 with OS-assigned ports; waits are bounded by a timeout and
end as soon as the awaited message arrives.
"""

from __future__ import annotations

import math
import socket
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from click.testing import CliRunner, Result
from helpers.mavlink_helpers import (
    FAST,
    client_conn,
    connected_client,
    running_mock,
    synthetic_mission,
)
from pymavlink.dialects.v20 import common as mav_common

from uavplan.cli import main
from uavplan.errors import LinkError
from uavplan.mavlink.connection import MavlinkConnection
from uavplan.mavlink.messages import (
    CommandAck,
    CommandLong,
    Heartbeat,
    MavCommand,
    MavResult,
    Message,
    MissionAck,
    MissionCount,
    MissionRequest,
    MissionRequestList,
    MissionResult,
    Received,
)
from uavplan.mavlink.transfer import compare_items, plan_wire_items, upload_plan
from uavplan.mission.io import save_mission
from uavplan.mission.items import (
    Autopilot,
    GeoFence,
    GeoPoint,
    MavCmd,
    MavFrame,
    MissionPlan,
    MissionType,
    RallyPoint,
)
from uavplan.sim.mock import MockVehicle
from uavplan.sim.vehicle import SimConfig

pytestmark = pytest.mark.timeout(60)
AUTOPILOTS = [Autopilot.PX4, Autopilot.ARDUPILOT]


def run(*args: str) -> Result:
    return CliRunner().invoke(main, list(args), catch_exceptions=False)


def _raw_frame(
    build: Callable[[mav_common.MAVLink], mav_common.MAVLink_message],
    source: tuple[int, int] = (255, 190),
) -> bytes:
    """A frame pymavlink packs but our message types cannot express (a float MISSION_ITEM)."""
    mav = mav_common.MAVLink(None, srcSystem=source[0], srcComponent=source[1])
    return bytes(build(mav).pack(mav))


def _nan_item(
    seq: int, *, system: int = 1, component: int = 1, source: tuple[int, int] = (255, 190)
) -> bytes:
    return _raw_frame(
        lambda m: m.mission_item_encode(
            system, component, seq, 3, 16, 0, 1, 0.0, 0.0, 0.0, 0.0, math.nan, 8.5, 30.0, 0
        ),
        source,
    )


def _await(
    conn: MavlinkConnection, wanted: Callable[[Message], bool], timeout_s: float = 5.0
) -> Message | None:
    """The first received message ``wanted`` accepts, or None after ``timeout_s``."""
    import time

    deadline = time.monotonic() + timeout_s
    while (left := deadline - time.monotonic()) > 0:
        received = conn.recv(left)
        if received is not None and wanted(received.message):
            return received.message
    return None


def _ask(
    conn: MavlinkConnection,
    message: Message,
    wanted: Callable[[Message], bool],
    attempts: int = 20,
) -> Message | None:
    """Send ``message`` until an answer ``wanted`` accepts arrives (a flood may have filled
    the vehicle's socket buffer: UDP drops, so a ground station re-sends)."""
    for _attempt in range(attempts):
        conn.send(message)
        answer = _await(conn, wanted, 0.25)
        if answer is not None:
            return answer
    return None


@contextmanager
def _gcs(
    vehicle: MockVehicle, system_id: int = 255, component_id: int = 190
) -> Iterator[MavlinkConnection]:
    conn = MavlinkConnection.open(
        client_conn(vehicle),
        system_id=system_id,
        component_id=component_id,
        heartbeat=Heartbeat(type=6, autopilot=8),
    )
    try:
        yield conn
    finally:
        conn.close()


# ---------------------------------------------------------------------------------------------
# the mock vehicle under abuse


@pytest.mark.parametrize("autopilot", AUTOPILOTS, ids=lambda a: a.label)
def test_mock_keeps_serving_through_hostile_packets(autopilot: Autopilot) -> None:
    old = synthetic_mission(6, seed=401, autopilot=autopilot)
    new = synthetic_mission(9, seed=402, autopilot=autopilot)
    with running_mock(SimConfig(autopilot=autopilot)) as vehicle:
        vehicle.preload(MissionType.MISSION, plan_wire_items(old, MissionType.MISSION, autopilot))
        stored_before = vehicle.wire_items(MissionType.MISSION)
        host, port = vehicle.address
        raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            valid = _raw_frame(lambda m: m.mission_count_encode(1, 1, 3, 0))
            for junk in (
                b"\x00" * 40,
                bytes(range(256)),
                b"\xfd\xff" + b"\x01" * 20,  # a v2 start byte and a length it does not have
                valid[: len(valid) // 2],  # truncated frame
                valid[:-1] + bytes([valid[-1] ^ 0xFF]),  # bad CRC
            ):
                raw.sendto(junk, (host, port))
        finally:
            raw.close()
        with _gcs(vehicle, system_id=77, component_id=5) as other:
            # another system's traffic addressed elsewhere, and a flood
            for _ in range(300):
                other.send(MissionCount(99, 1, 5))
                other.send(MissionRequestList(1, 1, 0))
            other.send(MissionAck(1, 1, MissionResult.ACCEPTED, 0))  # ends its download
            for param1 in (math.nan, math.inf, -math.inf, 2.5, 1e30):
                for command in (MavCommand.REQUEST_MESSAGE, MavCommand.DO_SET_MISSION_CURRENT):
                    answer = _ask(
                        other,
                        CommandLong(1, 1, command, param1=param1),
                        lambda m, c=command: isinstance(m, CommandAck) and m.command == c,
                    )
                    assert isinstance(answer, CommandAck), (command, param1)
                    assert answer.result != MavResult.ACCEPTED
        with _gcs(vehicle) as gcs:
            # an upload whose first item is a float MISSION_ITEM with x = NaN
            # PX4 may still be busy with the flooding system's download (its end ACK may
            # have been lost in the flood) until its 5 s transfer timeout: "busy" till then
            assert _ask(
                gcs, MissionCount(1, 1, 3), lambda m: isinstance(m, MissionRequest), attempts=40
            )
            refusal = None
            for _attempt in range(20):  # re-sent like any lost item
                gcs.send_bytes(_nan_item(0))
                refusal = _await(
                    gcs,
                    lambda m: isinstance(m, MissionAck) and m.type != MissionResult.ACCEPTED,
                    0.25,
                )
                if refusal is not None:
                    break
            assert isinstance(refusal, MissionAck)
            assert refusal.type == MissionResult.INVALID_PARAM5_X
        assert vehicle.error is None
        assert vehicle.rejected_messages >= 1
        assert vehicle.wire_items(MissionType.MISSION) == stored_before  # untouched
        with connected_client(vehicle, FAST) as client:
            report = upload_plan(client, new)
        assert report.verified
        assert vehicle.error is None


@pytest.mark.slow
def test_mock_vehicle_process_survives_a_nan_command(tmp_path: Path) -> None:
    """The CLI process, not just the class: one NaN COMMAND_LONG used to end it (exit 1)."""
    import subprocess
    import sys

    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()
    process = subprocess.Popen(
        [sys.executable, "-m", "uavplan", "mock-vehicle", "--conn", f"udpin:127.0.0.1:{port}"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        conn = MavlinkConnection.open(
            f"udpout:127.0.0.1:{port}",
            system_id=255,
            component_id=190,
            heartbeat=Heartbeat(type=6, autopilot=8),
        )
        try:
            assert _await(conn, lambda m: isinstance(m, Heartbeat), 20.0) is not None
            conn.send(CommandLong(1, 1, MavCommand.REQUEST_MESSAGE, param1=math.nan))
            conn.send(CommandLong(1, 1, MavCommand.DO_SET_MISSION_CURRENT, param1=math.inf))
            conn.send_bytes(_nan_item(0))
            conn.send(MissionRequestList(1, 1, 0))
            count = _await(conn, lambda m: isinstance(m, MissionCount), 10.0)
            assert isinstance(count, MissionCount)  # still serving
            assert process.poll() is None
        finally:
            conn.close()
    finally:
        process.terminate()
        _out, err = process.communicate(timeout=20)
    assert "internal error" not in err, err


# ---------------------------------------------------------------------------------------------
# a fake vehicle sending an item nobody can store


@contextmanager
def _vehicle_sending_a_nan_item() -> Iterator[str]:
    conn = MavlinkConnection.open(
        "udpin:127.0.0.1:0", system_id=1, component_id=1, heartbeat=Heartbeat(2, 12)
    )
    stop = threading.Event()

    def serve() -> None:
        while not stop.is_set():
            received: Received | None = conn.recv(0.05)
            if received is None:
                continue
            msg, partner = received.message, (received.system_id, received.component_id)
            if isinstance(msg, Heartbeat):
                conn.send(Heartbeat(2, 12))
            elif isinstance(msg, CommandLong):
                conn.send(CommandAck(msg.command, MavResult.UNSUPPORTED, *partner))
            elif isinstance(msg, MissionRequestList):
                conn.send(MissionCount(*partner, 1 if msg.mission_type == 0 else 0, 0))
            elif isinstance(msg, MissionRequest):
                frame = _nan_item(msg.seq, system=partner[0], component=partner[1], source=(1, 1))
                conn.send_bytes(frame)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield f"udpout:127.0.0.1:{conn.local_address[1]}"  # type: ignore[index]
    finally:
        stop.set()
        thread.join(5.0)
        conn.close()


def test_download_of_an_item_with_nan_x_is_a_clear_link_error(tmp_path: Path) -> None:
    with _vehicle_sending_a_nan_item() as conn:
        result = run(
            "download", "--conn", conn, "-o", str(tmp_path / "got.plan"), "--timeout", "0.3"
        )
    assert result.exit_code == 4, result.output
    assert "internal error" not in result.output
    assert "download mission: MISSION_ITEM_INT seq 0" in result.output
    assert "NaN" in result.output or "nan" in result.output
    assert not (tmp_path / "got.plan").exists()


# ---------------------------------------------------------------------------------------------
# values the wire cannot hold


def _plan_file_with(tmp_path: Path, field: str, value: float, frame: int | None = None) -> Path:
    """A .plan whose third mission item carries ``value`` in ``field`` (written as JSON: the
    mission model itself refuses such an item)."""
    import json

    from uavplan.mission.qgc_plan import plan_to_json

    base = synthetic_mission(3, seed=403)
    doc = json.loads(plan_to_json(MissionPlan(items=base.items, autopilot=Autopilot.PX4)))
    item = doc["mission"]["items"][2]
    if frame is not None:
        item["frame"] = frame
    if field == "param1":
        item["params"][0] = value
    elif field == "z":
        item["params"][6] = value
        item["Altitude"] = value
    else:
        item["params"][4] = value
    path = tmp_path / "big.plan"
    path.write_text(json.dumps(doc), encoding="utf-8")
    return path


@pytest.mark.parametrize(
    ("field", "value", "frame"),
    [("param1", 1e39, None), ("z", 1e39, None), ("x", 3e9, int(MavFrame.MISSION))],
    ids=["param1", "altitude", "frame-2-x"],
)
def test_upload_of_a_value_the_wire_cannot_hold_is_an_input_error(
    tmp_path: Path, field: str, value: float, frame: int | None
) -> None:
    path = _plan_file_with(tmp_path, field, value, frame)
    result = run("upload", str(path), "--conn", "udpout:127.0.0.1:9", "--heartbeat-timeout", "0.2")
    assert result.exit_code == 2, result.output
    assert str(path) in result.output
    assert "internal error" not in result.output and "Traceback" not in result.output


# ---------------------------------------------------------------------------------------------
# one process per udpin port


def test_a_second_vehicle_on_the_same_udpin_port_fails_clearly() -> None:
    first = MockVehicle("udpin:127.0.0.1:0")
    try:
        port = first.address[1]
        with pytest.raises(LinkError, match="already in use"):
            MockVehicle(f"udpin:127.0.0.1:{port}")
        result = run("mock-vehicle", "--conn", f"udpin:127.0.0.1:{port}")
        assert result.exit_code == 4, result.output
        assert "already in use" in result.output
    finally:
        first.stop()


# ---------------------------------------------------------------------------------------------
# reserved params


def test_reserved_fence_and_rally_params_are_zero_on_the_wire() -> None:
    plan = synthetic_mission(4, seed=404, with_fence=True, with_rally=True)
    for mission_type in (MissionType.FENCE, MissionType.RALLY):
        for item in plan_wire_items(plan, mission_type, Autopilot.PX4):
            assert None not in item.params, (mission_type, item)
    with running_mock() as vehicle, connected_client(vehicle, FAST) as client:
        upload_plan(client, plan)
        for mission_type in (MissionType.FENCE, MissionType.RALLY):
            for wire in vehicle.wire_items(mission_type):
                params = (wire.param1, wire.param2, wire.param3, wire.param4)
                assert not any(math.isnan(p) for p in params), wire
                if wire.command in (MavCmd.NAV_RALLY_POINT, MavCmd.NAV_FENCE_RETURN_POINT):
                    assert params == (0.0, 0.0, 0.0, 0.0)


def test_a_fence_and_rally_point_still_round_trip() -> None:
    fence = GeoFence(breach_return=GeoPoint(47.4, 8.5, 40.0))
    point = RallyPoint(47.41, 8.51, 35.0)
    assert fence.wire_items()[0].params == (0.0, 0.0, 0.0, 0.0)
    assert point.wire_item().params == (0.0, 0.0, 0.0, 0.0)
    assert (
        compare_items([point.wire_item()], [point.wire_item()], MissionType.RALLY, Autopilot.PX4)
        is None
    )


# ---------------------------------------------------------------------------------------------
# what an upload leaves on the vehicle


def test_uploading_a_mission_without_a_fence_says_the_old_fence_stays(tmp_path: Path) -> None:
    with_fence = synthetic_mission(5, seed=405, with_fence=True, with_rally=True)
    mission_only = synthetic_mission(6, seed=406)
    path = tmp_path / "mission.waypoints"
    save_mission(mission_only, path)
    with running_mock() as vehicle:
        for mission_type in (MissionType.FENCE, MissionType.RALLY):
            vehicle.preload(mission_type, plan_wire_items(with_fence, mission_type, Autopilot.PX4))
        n_fence = len(vehicle.wire_items(MissionType.FENCE))
        result = run("upload", str(path), "--conn", client_conn(vehicle))
        assert result.exit_code == 0, result.output
        assert len(vehicle.wire_items(MissionType.FENCE)) == n_fence  # left as it was
    assert (
        f"the plan has no geofence; the vehicle's geofence ({n_fence} items) was left unchanged"
        in result.output
    )
    assert "the vehicle's rally points (2 items) were left unchanged" in result.output


def test_no_note_when_the_vehicle_holds_no_fence(tmp_path: Path) -> None:
    path = tmp_path / "mission.waypoints"
    save_mission(synthetic_mission(6, seed=407), path)
    with running_mock() as vehicle:
        result = run("upload", str(path), "--conn", client_conn(vehicle))
    assert result.exit_code == 0, result.output
    assert "geofence" not in result.output
