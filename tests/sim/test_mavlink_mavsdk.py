"""Interoperability with an independent implementation: MAVSDK 4 (native binding).

- our client uploads to a vehicle made of MAVSDK's ``MissionRawServer``;
- MAVSDK's ``mission_raw`` client uploads to, downloads from and clears our mock vehicle;
- a ``.plan`` we write, imported by MAVSDK's ``import_qgroundcontrol_mission`` and uploaded
  by MAVSDK to our mock, comes back to us unchanged.

(That MAVSDK's importers accept our ``.plan`` / ``.waypoints`` files field by field is
tested with the file formats, in ``test_qgc_plan.py`` and ``test_waypoints_file.py``.)
"""

from __future__ import annotations

import math
import socket
import struct
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from helpers.mavlink_helpers import FAST, client_conn, running_mock, synthetic_mission
from helpers.mavsdk_offline import to_mavsdk

from uavplan.mavlink.link import VehicleLink
from uavplan.mavlink.protocol import MissionClient, item_to_wire
from uavplan.mavlink.stored_form import stored_form
from uavplan.mavlink.transfer import (
    compare_items,
    download_plan,
    plan_wire_items,
    sanitise_item,
    upload_plan,
)
from uavplan.mission.io import save_mission
from uavplan.mission.items import (
    Autopilot,
    GeoFence,
    MissionItem,
    MissionPlan,
    MissionType,
    items_equal,
)
from uavplan.sim.vehicle import SimConfig

mavsdk = pytest.importorskip("mavsdk")

from mavsdk import ComponentType, Configuration, Mavsdk  # noqa: E402
from mavsdk.plugins.mission_raw import MissionRaw  # noqa: E402
from mavsdk.plugins.mission_raw_server import MissionRawServer  # noqa: E402

pytestmark = pytest.mark.timeout(60)

AUTOPILOTS = [Autopilot.PX4, Autopilot.ARDUPILOT]


def _quiet(level: Any, message: str, file: str | None, line: int) -> bool:
    return level < mavsdk.LogLevel.WARN  # drop MAVSDK's debug/info chatter on stdout


mavsdk.log_subscribe(_quiet)


def _free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@contextmanager
def mavsdk_instance(component: ComponentType) -> Iterator[Mavsdk]:
    sdk = Mavsdk(Configuration.create_with_component_type(component))
    try:
        yield sdk
    finally:
        sdk.destroy()


def from_mavsdk(raw: Any) -> MissionItem:
    return MissionItem.from_wire(
        command=raw.command,
        frame=raw.frame,
        params=(raw.param1, raw.param2, raw.param3, raw.param4),
        x=raw.x,
        y=raw.y,
        z=raw.z,
        autocontinue=raw.autocontinue,
    )


def _same_float(a: float, b: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or a == b


def _float32(value: float) -> float:
    return struct.unpack("<f", struct.pack("<f", value))[0]


# ---------------------------------------------------------------------------------------------
# Our client -> MAVSDK MissionRawServer


@contextmanager
def mavsdk_vehicle() -> Iterator[tuple[str, list[tuple[Any, Any]]]]:
    """A vehicle made of MAVSDK's MissionRawServer, listening on a free UDP port."""
    port = _free_udp_port()
    with mavsdk_instance(ComponentType.AUTOPILOT) as sdk:
        sdk.add_any_connection(f"udpin://127.0.0.1:{port}")
        server = MissionRawServer(sdk.server_component())
        received: list[tuple[Any, Any]] = []

        def on_mission(result: Any, plan: Any, *_: Any) -> None:
            with _arrived:
                received.append((result, plan))
                _arrived.notify_all()

        server.subscribe_incoming_mission(on_mission)
        yield f"udpout:127.0.0.1:{port}", received


#: notified by MAVSDK's incoming-mission callback (it runs on MAVSDK's own thread)
_arrived = threading.Condition()


def _wait_for(received: list[tuple[Any, Any]], n: int, timeout_s: float = 3.0) -> None:
    """Block until MAVSDK's callback has reported ``n`` missions (bounded; no polling)."""
    with _arrived:
        arrived = _arrived.wait_for(lambda: len(received) >= n, timeout_s)
    assert arrived, "MAVSDK reported no incoming mission"


@pytest.mark.slow
def test_our_upload_is_received_item_for_item_by_mavsdk_mission_raw_server() -> None:
    plan = synthetic_mission(120, seed=81)
    wire = plan_wire_items(plan, MissionType.MISSION, Autopilot.PX4)
    with mavsdk_vehicle() as (conn, received):
        link = VehicleLink.connect(conn)
        try:
            # MAVSDK's server announces MISSION_INT (and fence/rally) in AUTOPILOT_VERSION
            assert link.capabilities is not None
            outcome = MissionClient(link, FAST).upload(MissionType.MISSION, wire)
        finally:
            link.close()
        assert outcome.ok, outcome.message
        _wait_for(received, 1)
    result, mavsdk_plan = received[-1]
    assert result == result.SUCCESS
    raw = mavsdk_plan.mission_items
    assert len(raw) == len(wire)
    for seq, (sent, got) in enumerate(zip(wire, raw, strict=True)):
        expected = item_to_wire(sent, seq, MissionType.MISSION, 1, 1)
        assert got.seq == seq
        assert (got.frame, got.command, got.current, got.autocontinue) == (
            expected.frame,
            expected.command,
            expected.current,
            expected.autocontinue,
        )
        for name in ("param1", "param2", "param3", "param4", "z"):
            # the wire carries float32
            assert _same_float(getattr(got, name), _float32(getattr(expected, name))), name
        assert (got.x, got.y, got.mission_type) == (expected.x, expected.y, 0)


@pytest.mark.slow
def test_whole_plan_with_read_back_against_mavsdk_mission_raw_server() -> None:
    """upload_plan with verification: MAVSDK 4's server also serves downloads of the
    mission, geofence and rally points it was sent."""
    plan = synthetic_mission(30, seed=82, with_fence=True, with_rally=True)
    with mavsdk_vehicle() as (conn, received):
        link = VehicleLink.connect(conn)
        try:
            assert link.vehicle.autopilot == Autopilot.GENERIC  # so the file's layout is used
            report = upload_plan(MissionClient(link, FAST), plan)
        finally:
            link.close()
        _wait_for(received, 3)
    assert report.verified and all(o.ok for o in report.outcomes)
    by_type = {plan_.mission_items[0].mission_type: plan_ for _, plan_ in received}
    assert set(by_type) == {0, 1, 2}
    for mission_type in (MissionType.MISSION, MissionType.FENCE, MissionType.RALLY):
        got = [from_mavsdk(i) for i in by_type[int(mission_type)].mission_items]
        expected = plan_wire_items(plan, mission_type, Autopilot.PX4)
        assert compare_items(expected, got, mission_type, Autopilot.PX4) is None


# ---------------------------------------------------------------------------------------------
# MAVSDK mission_raw client -> our mock vehicle


@contextmanager
def mavsdk_ground_station(vehicle_conn: str) -> Iterator[MissionRaw]:
    url = vehicle_conn.replace("udpout:", "udpout://", 1)
    with mavsdk_instance(ComponentType.GROUND_STATION) as sdk:
        sdk.add_any_connection(url)
        system = sdk.first_autopilot(5.0)
        assert system is not None, "MAVSDK did not discover the mock vehicle"
        yield MissionRaw(system)


@pytest.mark.parametrize("autopilot", AUTOPILOTS, ids=lambda a: a.label)
def test_mavsdk_uploads_downloads_and_clears_on_our_mock_vehicle(autopilot: Autopilot) -> None:
    plan = synthetic_mission(100, seed=83, autopilot=autopilot)
    wire = plan_wire_items(plan, MissionType.MISSION, autopilot)
    with running_mock(SimConfig(autopilot=autopilot)) as vehicle:
        with mavsdk_ground_station(client_conn(vehicle)) as mission_raw:
            mission_raw.upload_mission(
                [to_mavsdk(item, seq, MissionType.MISSION) for seq, item in enumerate(wire)]
            )
            stored = vehicle.items(MissionType.MISSION)
            assert compare_items(wire, stored, MissionType.MISSION, autopilot) is None
            downloaded = [from_mavsdk(i) for i in mission_raw.download_mission()]
            assert compare_items(wire, downloaded, MissionType.MISSION, autopilot) is None
            if autopilot == Autopilot.ARDUPILOT:
                # the mock answers like ArduPilot: non-INT frame spellings on download
                assert {i.frame for i in downloaded} <= {0, 2, 3}
            mission_raw.clear_mission()
            remaining = vehicle.items(MissionType.MISSION)
        assert vehicle.stats().uploads_accepted >= 1 and vehicle.stats().downloads_served == 1
    if autopilot == Autopilot.PX4:
        assert remaining == []
    else:
        # MAVSDK clears an ArduPilot mission by uploading a home-only mission
        assert len(remaining) == 1


def test_mavsdk_sees_our_mock_as_the_autopilot_it_claims() -> None:
    with running_mock(SimConfig(autopilot=Autopilot.ARDUPILOT)) as vehicle:
        url = client_conn(vehicle).replace("udpout:", "udpout://", 1)
        with mavsdk_instance(ComponentType.GROUND_STATION) as sdk:
            sdk.add_any_connection(url)
            system = sdk.first_autopilot(5.0)
            assert system is not None
            assert system.get_system_id() == 1
            assert system.autopilot_type() == mavsdk.Autopilot.ARDUPILOT


def _as_flown_by(plan: MissionPlan, autopilot: Autopilot) -> MissionPlan:
    """The plan with the params ArduPilot cannot take as NaN set to 0 (see below)."""
    items = tuple(sanitise_item(item, autopilot) for item in plan.items)
    return replace(plan, items=items)


def test_mavsdk_refuses_nan_params_for_ardupilot_which_is_why_we_send_zeros(
    tmp_path: Path,
) -> None:
    """MAVSDK applies ArduPilot's rule (NaN only in param4 of NAV commands) before it
    uploads: a .plan whose RTL / DO_CHANGE_SPEED params are null is refused with
    INVALID_ARGUMENT. Our upload path sends 0 there (transfer.sanitise_item)."""
    from mavsdk.plugins.mission_raw import MissionRawError

    plan = synthetic_mission(5, seed=85, autopilot=Autopilot.ARDUPILOT)
    assert plan.items[-1].param1 is None  # RTL with unset params
    for candidate, accepted in ((plan, False), (_as_flown_by(plan, Autopilot.ARDUPILOT), True)):
        path = tmp_path / "m.plan"
        save_mission(candidate, path)
        with running_mock(SimConfig(autopilot=Autopilot.ARDUPILOT)) as vehicle:
            with mavsdk_ground_station(client_conn(vehicle)) as mission_raw:
                imported = mission_raw.import_qgroundcontrol_mission(str(path))
                if accepted:
                    mission_raw.upload_mission(imported.mission_items)
                else:
                    with pytest.raises(MissionRawError, match="INVALID_ARGUMENT"):
                        mission_raw.upload_mission(imported.mission_items)


@pytest.mark.parametrize("autopilot", AUTOPILOTS, ids=lambda a: a.label)
def test_a_plan_file_imported_and_uploaded_by_mavsdk_comes_back_to_us(
    autopilot: Autopilot, tmp_path: Path
) -> None:
    """Our .plan -> MAVSDK import_qgroundcontrol_mission -> MAVSDK upload (mission, fence,
    rally) -> our mock -> our download: the plan survives the round trip."""
    plan: MissionPlan = synthetic_mission(
        25, seed=84, autopilot=autopilot, with_fence=True, with_rally=True
    )
    plan = _as_flown_by(plan, autopilot)
    path = tmp_path / "mission.plan"
    save_mission(plan, path)
    with running_mock(SimConfig(autopilot=autopilot)) as vehicle:
        with mavsdk_ground_station(client_conn(vehicle)) as mission_raw:
            imported = mission_raw.import_qgroundcontrol_mission(str(path))
            mission_raw.upload_mission(imported.mission_items)
            mission_raw.upload_geofence(imported.geofence_items)
            mission_raw.upload_rally_points(imported.rally_items)
        link = VehicleLink.connect(client_conn(vehicle))
        try:
            back = download_plan(MissionClient(link, FAST)).plan
        finally:
            link.close()
    assert len(back.items) == len(plan.items)
    # what comes back is each item as the firmware keeps it (mavlink/stored_form.py)
    kept = [stored_form(i, autopilot, MissionType.MISSION) for i in plan.items]
    assert all(items_equal(a, b) for a, b in zip(kept, back.items, strict=True))
    # MAVSDK's importer ignores the breach return point (reference §5.6)
    without_return = GeoFence(plan.fence.polygons, plan.fence.circles)
    assert back.fence.breach_return is None
    assert (
        compare_items(
            without_return.wire_items(), back.fence.wire_items(), MissionType.FENCE, autopilot
        )
        is None
    )
    assert len(back.rally) == len(plan.rally)
    for a, b in zip(plan.rally, back.rally, strict=True):
        assert abs(a.lat_deg - b.lat_deg) < 2e-7 and abs(a.alt_m - b.alt_m) < 0.01
