"""An upload cancelled half-way, on the simulated vehicle, as each firmware answers it
(issue 31, Deliver 6).

- PX4 (``MavlinkMissionManager::handle_mission_ack``, src/modules/mavlink/mavlink_mission.cpp):
  MISSION_ACK(OPERATION_CANCELLED) from the uploading ground station ends the transfer at
  once; the old plan stays (the upload went to the inactive storage).
- ArduPilot (libraries/GCS_MAVLink/MissionItemProtocol.cpp): no MISSION_ACK is handled during
  an upload, so the cancel changes nothing; the vehicle answers DENIED until 8 s after the
  last item (``upload_timeout_ms``, ``MissionItemProtocol::update``), then sends its own
  OPERATION_CANCELLED. The uploading ground station's MISSION_CLEAR_ALL ends it at once
  (``handle_mission_clear_all`` calls ``cancel_upload``) and clears; another's is DENIED.
  Measured on ArduCopter 4.7.0-dev SITL (2026-11-28): DENIED for 8 simulated seconds after
  the cancel, then OPERATION_CANCELLED; a clear from the uploader ACCEPTED.
"""

from __future__ import annotations

import pytest
from helpers.mavlink_helpers import synthetic_mission

from uavplan.mavlink.messages import (
    MissionAck,
    MissionClearAll,
    MissionCount,
    MissionRequest,
    MissionRequestList,
    MissionResult,
    StatusText,
)
from uavplan.mavlink.protocol import item_to_wire
from uavplan.mavlink.transfer import plan_wire_items
from uavplan.mission.items import Autopilot, MissionType
from uavplan.sim.mission_server import FIRMWARE_TRANSFER_TIMEOUT_S, MissionServer

GCS, OTHER = (255, 190), (255, 191)


def _half_upload(autopilot: Autopilot) -> tuple[MissionServer, list]:
    """A server holding an old mission, with a new one half uploaded by GCS."""
    server = MissionServer(autopilot)
    old = plan_wire_items(
        synthetic_mission(4, seed=1, autopilot=autopilot), MissionType.MISSION, autopilot
    )
    server.preload(MissionType.MISSION, old)
    new = plan_wire_items(
        synthetic_mission(10, seed=2, autopilot=autopilot), MissionType.MISSION, autopilot
    )
    wire = [item_to_wire(it, seq, MissionType.MISSION, 1, 1) for seq, it in enumerate(new)]
    out = server.handle(GCS, MissionCount(1, 1, len(wire)), 0.0)
    for seq in range(4):
        assert isinstance(out[-1], MissionRequest) and out[-1].seq == seq
        out = server.handle(GCS, wire[seq], 0.01 * (seq + 1))
    return server, old


def _answers_request_list(server: MissionServer, now: float) -> list:
    return server.handle(GCS, MissionRequestList(1, 1), now)


def test_px4_leaves_the_transfer_on_the_cancel_and_keeps_the_old_mission() -> None:
    server, old = _half_upload(Autopilot.PX4)
    server.handle(GCS, MissionAck(1, 1, MissionResult.OPERATION_CANCELLED), 0.1)
    assert not server.busy
    (count,) = _answers_request_list(server, 0.2)
    assert isinstance(count, MissionCount) and count.count == len(old)


def test_ardupilot_ignores_the_cancel_and_leaves_the_transfer_8_s_after_the_last_item() -> None:
    server, _old = _half_upload(Autopilot.ARDUPILOT)
    server.handle(GCS, MissionAck(1, 1, MissionResult.OPERATION_CANCELLED), 0.1)
    assert server.busy
    (denied,) = _answers_request_list(server, 0.2)
    assert isinstance(denied, MissionAck) and denied.type == MissionResult.DENIED
    timeout = FIRMWARE_TRANSFER_TIMEOUT_S[Autopilot.ARDUPILOT]
    assert timeout == 8.0  # MissionItemProtocol.h upload_timeout_ms
    assert not any(
        isinstance(m, MissionAck) for m in server.timers(0.04 + timeout - 0.1)
    )  # still in it
    out = server.timers(0.04 + timeout + 0.1)
    acks = [m for m in out if isinstance(m, MissionAck)]
    assert [a.type for a in acks] == [MissionResult.OPERATION_CANCELLED]
    assert any(isinstance(m, StatusText) and "upload timeout" in m.text for m in out)
    assert not server.busy
    (count,) = _answers_request_list(server, 9.0)
    assert isinstance(count, MissionCount)


@pytest.mark.parametrize("who", [GCS, OTHER], ids=["the-uploader", "another"])
def test_ardupilots_clear_ends_the_uploaders_transfer_and_is_denied_to_another(
    who: tuple[int, int],
) -> None:
    server, old = _half_upload(Autopilot.ARDUPILOT)
    out = server.handle(who, MissionClearAll(1, 1), 0.1)
    results = [m.type for m in out if isinstance(m, MissionAck)]
    if who == GCS:
        assert results == [MissionResult.ACCEPTED]
        assert not server.busy and server.wire_items(MissionType.MISSION) == []
    else:
        assert results == [MissionResult.DENIED, MissionResult.ERROR]
        assert server.busy and len(server.wire_items(MissionType.MISSION)) == len(old)
