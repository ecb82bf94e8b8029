"""Upload -> download round trips over loopback UDP against the mock vehicle (no faults)."""

from __future__ import annotations

import socket
from dataclasses import replace

import pytest
from helpers.mavlink_helpers import (
    DEFAULT,
    FAST,
    PlanSource,
    bundled_plans,
    connected_client,
    for_autopilot,
    running_mock,
    synthetic_mission,
)

from uavplan.errors import InputError
from uavplan.geo import GeoPoint
from uavplan.mavlink.link import VehicleLink
from uavplan.mavlink.messages import Capability, MissionResult
from uavplan.mavlink.protocol import (
    MissionClient,
    MissionTransferError,
    TransferStatus,
    item_from_wire,
)
from uavplan.mavlink.stored_form import stored_form
from uavplan.mavlink.transfer import (
    clear_plan,
    compare_items,
    download_plan,
    plan_wire_items,
    retarget,
    upload_plan,
)
from uavplan.mission.items import (
    Autopilot,
    MavCmd,
    MavFrame,
    MissionItem,
    MissionPlan,
    MissionType,
    items_equal,
)
from uavplan.sim.mock import MockVehicle
from uavplan.sim.vehicle import SimConfig

pytestmark = pytest.mark.timeout(30)

AUTOPILOTS = [Autopilot.PX4, Autopilot.ARDUPILOT]
PLANS = list(bundled_plans())


def assert_plans_match(sent: MissionPlan, got: MissionPlan, autopilot: Autopilot) -> None:
    """``got`` (downloaded) holds ``sent`` in the form the firmware keeps it."""
    wire = plan_wire_items(sent, MissionType.MISSION, autopilot)
    kept = [stored_form(item, autopilot, MissionType.MISSION) for item in wire]
    if autopilot == Autopilot.ARDUPILOT:
        kept = kept[1:]  # home
    assert len(got.items) == len(kept)
    for index, (a, b) in enumerate(zip(kept, got.items, strict=True)):
        assert items_equal(a, b), (index, a, b)
    assert got.fence == sent.fence or _fence_close(sent, got, autopilot)
    assert len(got.rally) == len(sent.rally)
    for a, b in zip(sent.rally, got.rally, strict=True):
        assert abs(a.lat_deg - b.lat_deg) < 2e-7 and abs(a.lon_deg - b.lon_deg) < 2e-7
        assert abs(a.alt_m - b.alt_m) < 0.01


def _fence_close(sent: MissionPlan, got: MissionPlan, autopilot: Autopilot) -> bool:
    """The downloaded fence, as a plan written out again, holds what the firmware kept of
    the sent one (the plan's fence writes its own frames: compare both in stored form)."""
    held = [stored_form(i, autopilot, MissionType.FENCE) for i in got.fence.wire_items()]
    return compare_items(sent.fence.wire_items(), held, MissionType.FENCE, autopilot) is None


@pytest.mark.parametrize("autopilot", AUTOPILOTS, ids=lambda a: a.label)
@pytest.mark.parametrize(("name", "source"), PLANS, ids=[name for name, _ in PLANS])
def test_upload_then_download_round_trips_every_mission(
    name: str, source: PlanSource, autopilot: Autopilot
) -> None:
    plan = for_autopilot(source(), autopilot)
    with (
        running_mock(SimConfig(autopilot=autopilot)) as vehicle,
        connected_client(vehicle) as client,
    ):
        assert client.link.vehicle.autopilot == autopilot
        report = upload_plan(client, plan)
        assert report.verified and report.autopilot == autopilot
        assert all(o.ok for o in report.outcomes)
        # what the vehicle stores is exactly the firmware layout of the plan
        stored = vehicle.items(MissionType.MISSION)
        expected = plan_wire_items(plan, MissionType.MISSION, autopilot)
        assert compare_items(expected, stored, MissionType.MISSION, autopilot) is None
        if autopilot == Autopilot.ARDUPILOT:
            assert stored[0].command == MavCmd.NAV_WAYPOINT and stored[0].frame == 0
            assert plan.home is not None
            assert abs(stored[0].x - plan.home.lat_deg) < 1e-7  # planned home in seq 0
        assert vehicle.wire_items(MissionType.MISSION)[0].current == 1
        assert sum(w.current for w in vehicle.wire_items(MissionType.MISSION)) == 1
        back = download_plan(client).plan
    assert back.autopilot == autopilot
    assert_plans_match(plan, back, autopilot)
    if autopilot == Autopilot.ARDUPILOT:
        assert back.home is not None and plan.home is not None
        assert abs(back.home.lat_deg - plan.home.lat_deg) < 1e-7


def test_fast_upload_of_200_items_on_loopback() -> None:
    """A clean link needs no retries. At the firmware's re-request interval (PX4: 250 ms) and
    the protocol's default timeouts: the mock's RTT-adaptive interval (10 ms floor) and the
    scaled test timeouts turned a scheduler stall of a loaded machine into a "retry"."""
    plan = synthetic_mission(200, seed=9)
    with (
        running_mock(SimConfig(firmware_timing=True)) as vehicle,
        connected_client(vehicle, DEFAULT) as client,
    ):
        outcome = client.upload(MissionType.MISSION, plan_wire_items(plan, 0, Autopilot.PX4))
    assert outcome.ok and outcome.stats.resent == 0 and outcome.stats.repeat_requests == 0


@pytest.mark.parametrize("autopilot", AUTOPILOTS, ids=lambda a: a.label)
def test_fence_and_rally_round_trip(autopilot: Autopilot) -> None:
    plan = synthetic_mission(10, seed=11, autopilot=autopilot, with_fence=True, with_rally=True)
    with (
        running_mock(SimConfig(autopilot=autopilot)) as vehicle,
        connected_client(vehicle) as client,
    ):
        report = upload_plan(client, plan)
        assert report.item_counts == {
            MissionType.MISSION: len(plan.items) + (autopilot == Autopilot.ARDUPILOT),
            MissionType.FENCE: 4 + 3 + 1 + 1,
            MissionType.RALLY: 2,
        }
        fence_wire = vehicle.wire_items(MissionType.FENCE)
        assert [w.command for w in fence_wire] == [5001] * 4 + [5002] * 3 + [5004, 5000]
        assert all(w.mission_type == MissionType.FENCE for w in fence_wire)
        assert [w.command for w in vehicle.wire_items(MissionType.RALLY)] == [5100, 5100]
        back = download_plan(client).plan
    assert back.fence.polygons == plan.fence.polygons or _fence_close(plan, back, autopilot)
    assert [c.inclusion for c in back.fence.circles] == [False]
    assert back.fence.breach_return is not None
    assert_plans_match(plan, back, autopilot)


def test_a_plan_for_px4_is_laid_out_for_an_ardupilot_vehicle() -> None:
    jump_target = 3  # PX4 seq of the third waypoint
    plan = synthetic_mission(6, seed=12)
    items = (
        *plan.items,
        MissionItem(MavCmd.DO_JUMP, MavFrame.MISSION, param1=jump_target, param2=1),
    )
    plan = replace(plan, items=items)
    with running_mock(SimConfig(autopilot=Autopilot.ARDUPILOT)) as vehicle:
        with connected_client(vehicle) as client:
            report = upload_plan(client, plan)
        stored = vehicle.items(MissionType.MISSION)
    assert report.autopilot == Autopilot.ARDUPILOT
    assert any("laid out for the vehicle's ardupilot" in n for n in report.notes)
    assert len(stored) == len(plan.items) + 1  # home placeholder at seq 0
    assert stored[1].command == MavCmd.NAV_TAKEOFF
    assert stored[-1].command == MavCmd.DO_JUMP and stored[-1].param1 == jump_target + 1
    # ArduPilot rejects NaN params except yaw of NAV commands: unset params were sent as 0
    speed = next(i for i in stored if i.command == MavCmd.DO_CHANGE_SPEED)
    assert speed.param4 == 0.0
    assert stored[3].command == MavCmd.NAV_WAYPOINT
    sent = plan_wire_items(plan, MissionType.MISSION, Autopilot.ARDUPILOT)
    assert sent[3].param4 is None  # NAV_WAYPOINT yaw goes as NaN ("keep heading") ...
    assert stored[3].param4 == 0.0  # ... and Copter does not store it (AP_Mission.cpp)


def test_retarget_is_its_own_inverse() -> None:
    plan = replace(
        synthetic_mission(5, seed=1),
        items=(*synthetic_mission(5, seed=1).items, MissionItem(MavCmd.DO_JUMP, 2, param1=2.0)),
    )
    there = retarget(plan, Autopilot.ARDUPILOT)
    assert there.items[-1].param1 == 3.0
    assert retarget(there, Autopilot.PX4) == plan


def test_terrain_frame_is_refused_for_px4_before_anything_is_sent() -> None:
    items = (MissionItem(MavCmd.NAV_WAYPOINT, MavFrame.GLOBAL_TERRAIN_ALT, x=47.0, y=8.0, z=20),)
    plan = MissionPlan(items=items, autopilot=Autopilot.PX4)
    with pytest.raises(InputError, match="px4 does not accept frame 10"):
        plan_wire_items(plan, MissionType.MISSION, Autopilot.PX4)
    assert plan_wire_items(plan, MissionType.MISSION, Autopilot.ARDUPILOT)[1].frame == 10


@pytest.mark.parametrize("autopilot", AUTOPILOTS, ids=lambda a: a.label)
def test_clear_each_type_and_all(autopilot: Autopilot) -> None:
    plan = synthetic_mission(8, seed=13, autopilot=autopilot, with_fence=True, with_rally=True)
    with (
        running_mock(SimConfig(autopilot=autopilot)) as vehicle,
        connected_client(vehicle) as client,
    ):
        upload_plan(client, plan, verify=False)
        clear_plan(client, [MissionType.FENCE])
        assert vehicle.items(MissionType.FENCE) == []
        assert vehicle.items(MissionType.MISSION) != []
        clear_plan(client, [MissionType.MISSION, MissionType.FENCE, MissionType.RALLY])
        for mission_type in (MissionType.MISSION, MissionType.FENCE, MissionType.RALLY):
            assert vehicle.items(mission_type) == []
        empty = client.download(MissionType.MISSION)
        assert empty.ok and empty.items == ()
        # MISSION_TYPE_ALL: PX4 clears everything, ArduPilot answers UNSUPPORTED (ref. §1.3)
        outcome = client.clear(MissionType.ALL)
        if autopilot == Autopilot.PX4:
            assert outcome.ok
        else:
            assert outcome.status is TransferStatus.REJECTED
            assert outcome.vehicle_result == MissionResult.UNSUPPORTED


def test_empty_upload_clears_the_type() -> None:
    with running_mock() as vehicle, connected_client(vehicle) as client:
        vehicle.preload(MissionType.RALLY, [MissionItem(MavCmd.NAV_RALLY_POINT, x=47, y=8, z=30)])
        outcome = client.upload(MissionType.RALLY, [])
        assert outcome.ok
        assert vehicle.items(MissionType.RALLY) == []


def test_ardupilot_download_returns_the_vehicles_home_as_seq_0() -> None:
    vehicle_home = GeoPoint(47.4, 8.55, 500.25)
    plan = synthetic_mission(5, seed=14, autopilot=Autopilot.ARDUPILOT)
    config = SimConfig(autopilot=Autopilot.ARDUPILOT, home=vehicle_home)
    with running_mock(config) as vehicle, connected_client(vehicle) as client:
        report = upload_plan(client, plan)  # verification skips seq 0, which the vehicle owns
        assert report.verified
        back = download_plan(client).plan
    assert back.home == vehicle_home
    assert_plans_match(plan, back, Autopilot.ARDUPILOT)


def test_vehicle_capabilities_are_learnt_from_autopilot_version() -> None:
    with running_mock() as vehicle, connected_client(vehicle) as client:
        caps = client.link.wait_capabilities(2.0)
    assert caps is not None
    assert Capability.MISSION_INT in caps and Capability.MISSION_FENCE in caps
    assert Capability.MISSION_RALLY in caps


def test_upload_is_atomic_when_the_vehicle_rejects_an_item() -> None:
    """A firmware-invalid item (NaN param for ArduPilot) fails the upload; the old plan stays."""
    old = synthetic_mission(5, seed=15, autopilot=Autopilot.ARDUPILOT)
    bad_item = MissionItem(MavCmd.NAV_WAYPOINT, x=47.0, y=8.0, z=20.0)  # params unset
    with running_mock(SimConfig(autopilot=Autopilot.ARDUPILOT)) as vehicle:
        with connected_client(vehicle) as client:
            upload_plan(client, old)
            before = vehicle.wire_items(MissionType.MISSION)
            wire = [*plan_wire_items(old, MissionType.MISSION, Autopilot.ARDUPILOT), bad_item]
            outcome = client.upload(MissionType.MISSION, wire)
        assert outcome.status is TransferStatus.REJECTED
        assert outcome.vehicle_result == MissionResult.INVALID_PARAM1
        assert outcome.step == f"MISSION_ITEM_INT seq {len(wire) - 1}"
        assert "param1 = None" in outcome.message
        assert vehicle.wire_items(MissionType.MISSION) == before


def test_item_round_trip_through_the_wire_keeps_precision() -> None:
    plan = synthetic_mission(30, seed=16)
    with running_mock() as vehicle, connected_client(vehicle) as client:
        client.upload(MissionType.MISSION, list(plan.items)).raise_for_status()
        raw = vehicle.wire_items(MissionType.MISSION)
    for sent, wire in zip(plan.items, raw, strict=True):
        back = item_from_wire(wire)
        assert abs(back.x - sent.x) <= 0.5e-7 and abs(back.y - sent.y) <= 0.5e-7
        assert abs(back.z - sent.z) < 1e-5  # float32 altitude


def test_download_into_plan_skips_unsupported_types() -> None:
    """A vehicle without fence/rally capability is not asked for them (as QGC does)."""
    config = SimConfig(capabilities=Capability.MISSION_INT | Capability.MAVLINK2)
    with running_mock(config) as vehicle, connected_client(vehicle, FAST) as client:
        result = download_plan(client)
    assert result.plan.fence.is_empty and result.plan.rally == ()
    assert [o.mission_type for o in result.outcomes] == [MissionType.MISSION]
    assert any("does not support fence" in n for n in result.notes)


def test_mission_transfer_error_names_the_step_and_exits_4() -> None:
    with running_mock() as vehicle, connected_client(vehicle) as client:
        outcome = client.upload(
            MissionType.FENCE, [MissionItem(MavCmd.NAV_WAYPOINT, x=47.0, y=8.0, z=10.0)]
        )
    assert outcome.status is TransferStatus.REJECTED
    with pytest.raises(MissionTransferError) as info:
        outcome.raise_for_status()
    err = info.value
    assert err.exit_code == 4
    assert str(err).startswith("upload fence: MISSION_ITEM_INT seq 0:")
    assert "MAV_MISSION_UNSUPPORTED" in str(err)


def test_mock_sending_to_a_listening_ground_station_like_qgroundcontrol() -> None:
    """QGroundControl listens on UDP 14550 and vehicles send to it: the mock on
    ``udpout:`` reaches a ground station listening on ``udpin:``."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    vehicle = MockVehicle(f"udpout:127.0.0.1:{port}", SimConfig(heartbeat_period_s=0.1))
    vehicle.start()
    try:
        with VehicleLink.connect(f"udpin:127.0.0.1:{port}") as link:
            plan = synthetic_mission(12, seed=17)
            report = upload_plan(MissionClient(link, FAST), plan)
        assert report.verified
        assert len(vehicle.items(MissionType.MISSION)) == len(plan.items)
    finally:
        vehicle.stop()


def test_tcp_vehicle_like_mavproxy_or_sitl() -> None:
    """A vehicle serving TCP (as SITL does on 5760); the ground station connects."""
    plan = synthetic_mission(25, seed=18, with_fence=True)
    with running_mock(conn="tcpin:127.0.0.1:0") as vehicle:
        host, port = vehicle.address
        with VehicleLink.connect(f"tcp://{host}:{port}") as link:
            upload_plan(MissionClient(link, FAST), plan)
            back = download_plan(MissionClient(link, FAST)).plan
    assert_plans_match(plan, back, Autopilot.PX4)
