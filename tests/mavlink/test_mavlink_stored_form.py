"""The read-back expects what each firmware keeps of an item (uavplan/mavlink/stored_form.py), and
the simulated vehicle keeps items the way the firmware does (tests/sitl/test_sitl_storage.py holds
both against ArduPilot SITL and PX4 SIH).

Issue 32: ``upload`` failed on real ArduPilot for every bundled plan ("read-back: another
upload took over ... frame 2 became 0"), blaming another ground station; PX4 refuses a
NAV_RETURN_TO_LAUNCH or DO_LAND_START in a global frame.
"""

from __future__ import annotations

import math

import pytest
from helpers.mavlink_helpers import FAST, connected_client, running_mock
from hypothesis import given, settings
from hypothesis import strategies as st

from uavplan.geo import GeoPoint
from uavplan.mavlink.protocol import MissionTransferError, TransferStatus
from uavplan.mavlink.stored_form import stored_form, upload_form
from uavplan.mavlink.transfer import compare_items, plan_wire_items, upload_plan
from uavplan.mission.items import Autopilot, MissionItem, MissionPlan, MissionType
from uavplan.sim.vehicle import SimConfig

pytestmark = pytest.mark.timeout(60)

AP, PX4 = Autopilot.ARDUPILOT, Autopilot.PX4
HOME = GeoPoint(47.397742, 8.545594, 488.0)
LAT, LON = 47.398, 8.546


def _item(cmd: int, frame: int, params: tuple, x: float = 0.0, y: float = 0.0, z: float = 0.0):
    p = [None if v is None else float(v) for v in params]
    return MissionItem(cmd, frame, p[0], p[1], p[2], p[3], x, y, z)


def _plan(autopilot: Autopilot) -> MissionPlan:
    """What uavplan writes, in the forms the firmware changes: a waypoint's acceptance
    radius, NaN yaws, DO_CHANGE_SPEED and RTL in frame 2, a planned return's DO_LAND_START
    with a position, an altitude with a fraction of a centimetre."""
    items = (
        _item(22, 3, (0, 0, 0, None), LAT, LON, 30.0),
        _item(178, 2, (1, 12, -1, None)),
        _item(16, 3, (0, 0.5, 0, None), LAT, LON + 2e-4, 31.0179),
        _item(16, 3, (1.5, 0, 0, -90), LAT, LON + 4e-4, 31.0),
        _item(189, 3, (0, 0, 0, 0), LAT, LON, 0.0),
        _item(16, 3, (0, 0.5, 0, None), LAT, LON, 20.0),
        _item(21, 3, (0, 0, 0, None), LAT, LON, 0.0),
        _item(20, 2, (0, 0, 0, 0)),
    )
    return MissionPlan(items=items, autopilot=autopilot, home=HOME)


@pytest.mark.parametrize("autopilot", [AP, PX4], ids=lambda a: a.label)
def test_an_upload_verifies_against_what_the_firmware_keeps(autopilot: Autopilot) -> None:
    plan = _plan(autopilot)
    with (
        running_mock(SimConfig(autopilot=autopilot, home=HOME)) as vehicle,
        connected_client(vehicle, FAST) as client,
    ):
        report = upload_plan(client, plan)
        held = vehicle.items(MissionType.MISSION)
    assert report.verified
    sent = plan_wire_items(plan, MissionType.MISSION, autopilot)
    if autopilot == AP:
        # the simulated ArduPilot keeps what AP_Mission keeps (measured on SITL) ...
        assert held[2].frame == 0  # DO_CHANGE_SPEED: no location, frame 0
        assert held[3].param2 == 0.0  # no acceptance radius on a Copter waypoint
        assert held[4].param1 == 1.0  # the hold time in whole seconds
        assert held[7].param4 == 1.0  # NAV_LAND's yaw comes back 1
        assert held[8].frame == 0  # NAV_RETURN_TO_LAUNCH
        assert held[3].z == pytest.approx(31.01)  # centimetres, truncated
        # ... so a comparison that expects the upload back as sent would refuse it
        assert [i.frame for i in sent[1:]] != [i.frame for i in held[1:]]
    else:
        assert held[6].param4 is None and held[3].param4 == pytest.approx(270.0)
        assert sent[1].frame == sent[4].frame == sent[7].frame == 2  # MAV_FRAME_MISSION


def test_px4_gets_commands_without_a_position_in_frame_mission() -> None:
    """PX4's parse_mavlink_mission_item takes RTL, DO_CHANGE_SPEED and DO_LAND_START only in
    MAV_FRAME_MISSION (measured: MAV_MISSION_UNSUPPORTED otherwise); a file from Mission
    Planner writes them in frame 3."""
    rtl = _item(20, 3, (0, 0, 0, 0))
    land_start = _item(189, 3, (0, 0, 0, 0), LAT, LON, 0.0)
    assert upload_form(rtl, PX4).frame == 2
    assert upload_form(land_start, PX4) == _item(189, 2, (0, 0, 0, 0))
    assert upload_form(land_start, AP) == land_start  # ArduPilot keeps it with its location
    plan = MissionPlan(
        items=(_item(22, 3, (0, 0, 0, None), LAT, LON, 30.0), land_start, rtl), autopilot=PX4
    )
    with (
        running_mock(SimConfig(autopilot=PX4)) as vehicle,
        connected_client(vehicle, FAST) as client,
    ):
        assert upload_plan(client, plan).verified
        # the simulated PX4 refuses them in a global frame, as the firmware does
        outcome = client.upload(MissionType.MISSION, list(plan.items))
    assert not outcome.ok and "MAV_MISSION_UNSUPPORTED" in outcome.message


def test_a_field_the_vehicle_changed_is_named_without_blaming_another_ground_station() -> None:
    plan = _plan(AP)
    with running_mock(SimConfig(autopilot=AP, home=HOME)) as vehicle:
        with connected_client(vehicle, FAST) as client:
            download = client.download

            def changed(mission_type: MissionType, **kw: object):  # type: ignore[no-untyped-def]
                held = vehicle.items(MissionType.MISSION)
                held[3] = MissionItem(**{**held[3].__dict__, "param1": 7.0})
                vehicle.preload(MissionType.MISSION, held)
                return download(mission_type, **kw)  # type: ignore[arg-type]

            client.download = changed  # type: ignore[method-assign]
            with pytest.raises(MissionTransferError) as info:
                upload_plan(client, plan)
    assert info.value.outcome.status is TransferStatus.MISMATCH
    message = str(info.value)
    assert "another upload" not in message
    assert "item 3 (command 16 (NAV_WAYPOINT), frame 3): param1: uploaded 0" in message
    assert "the vehicle holds 7" in message


def test_another_mission_on_the_vehicle_is_said_to_be_one() -> None:
    plan = _plan(AP)
    with running_mock(SimConfig(autopilot=AP, home=HOME)) as vehicle:
        with connected_client(vehicle, FAST) as client:
            download = client.download

            def replaced(mission_type: MissionType, **kw: object):  # type: ignore[no-untyped-def]
                vehicle.preload(MissionType.MISSION, vehicle.items(MissionType.MISSION)[:-1])
                return download(mission_type, **kw)  # type: ignore[arg-type]

            client.download = replaced  # type: ignore[method-assign]
            with pytest.raises(MissionTransferError) as info:
                upload_plan(client, plan)
    assert "another upload took over" in str(info.value)
    assert "the vehicle holds 8 items, 9 were uploaded" in str(info.value)


_PARAM = st.one_of(st.none(), st.floats(-1000, 1000, allow_nan=False, width=32))


@settings(max_examples=200, deadline=None)
@given(
    command=st.sampled_from([16, 17, 19, 20, 21, 22, 177, 178, 189, 195, 201, 203, 205]),
    frame=st.sampled_from([0, 2, 3, 5, 6]),
    params=st.tuples(_PARAM, _PARAM, _PARAM, _PARAM),
    z=st.floats(-500, 5000, allow_nan=False),
    autopilot=st.sampled_from([AP, PX4]),
)
def test_what_the_firmware_keeps_is_kept_again(
    command: int, frame: int, params: tuple, z: float, autopilot: Autopilot
) -> None:
    """Uploading what came back changes nothing more: the stored form is a fixed point, and
    the comparison accepts it."""
    x, y = (LAT, LON) if frame != 2 else (0.0, 0.0)
    item = upload_form(_item(command, frame, params, x, y, z), autopilot)
    once = stored_form(item, autopilot, MissionType.MISSION)
    twice = stored_form(once, autopilot, MissionType.MISSION)
    assert compare_items([once], [twice], MissionType.MISSION, autopilot) is None
    assert compare_items([item], [once], MissionType.MISSION, autopilot) is None
    for value in once.params:
        assert value is None or not math.isinf(value)
