"""Uploads to the real firmware (tests/helpers/sitl.py): what each firmware keeps of a mission.

- ``uavplan upload`` verifies every bundled plan (the ten scenarios and the QGroundControl
  plan; each scenario with its own ending and with a planned return) on ArduPilot SITL and
  on PX4 SIH: the read-back compares what the firmware really stores
  (uavplan/mavlink/stored_form.py). Before that module, ArduPilot refused every one of them
  ("another upload took over ... frame 2 became 0").
- The simulated vehicle keeps and sends back exactly what the firmware does, for every
  bundled plan and for items of every kind and form uavplan or another ground station may
  send, so the project's own tests catch a read-back that expects the wrong form.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner
from helpers import sitl
from helpers.mavlink_helpers import FAST, connected_client, running_mock

from uavplan.cli import main
from uavplan.geo import GeoPoint
from uavplan.mavlink.link import VehicleLink
from uavplan.mavlink.protocol import MissionClient
from uavplan.mavlink.stored_form import stored_form
from uavplan.mavlink.transfer import plan_wire_items, upload_plan
from uavplan.mission.io import load_mission
from uavplan.mission.items import Autopilot, MissionItem, MissionPlan, MissionType
from uavplan.sim.vehicle import SimConfig

pytestmark = [pytest.mark.sitl, pytest.mark.timeout(900)]

AP, PX4 = Autopilot.ARDUPILOT, Autopilot.PX4
HOME = GeoPoint(47.397742, 8.545594, 488.0)
CASES = [
    (source, end)
    for source in sitl.bundled_sources()
    for end in (sitl.ENDS if source.suffix == ".yaml" else ("bundled",))
]


@pytest.fixture(scope="module", params=[AP, PX4], ids=lambda a: a.label)
def firmware(request: pytest.FixtureRequest) -> Iterator[sitl.Sitl]:
    sitl.need(request.param)
    with sitl.running(request.param, HOME, speedup=5) as vehicle:
        yield vehicle


def _download(conn: str, mission_type: MissionType) -> list[MissionItem]:
    with VehicleLink.connect(conn, heartbeat_timeout_s=20) as link:
        return list(MissionClient(link, FAST).download(mission_type).raise_for_status().items)


def _mock_download(
    plan: MissionPlan, autopilot: Autopilot, types: tuple[MissionType, ...]
) -> dict[MissionType, list[MissionItem]]:
    with (
        running_mock(SimConfig(autopilot=autopilot, home=HOME)) as mock,
        connected_client(mock) as client,
    ):
        upload_plan(client, plan)
        return {t: list(client.download(t).raise_for_status().items) for t in types}


def _same(a: MissionItem, b: MissionItem) -> bool:
    """Field for field, frames as spelled, params as float32, z to 1 mm."""

    def close(p: float | None, q: float | None) -> bool:
        if p is None or q is None or math.isnan(p) or math.isnan(q):
            return (p is None or math.isnan(p)) == (q is None or math.isnan(q))
        return math.isclose(p, q, rel_tol=1e-6, abs_tol=1e-6)

    return (
        a.command == b.command
        and a.frame == b.frame
        and all(close(p, q) for p, q in zip(a.params, b.params, strict=True))
        and abs(a.x - b.x) < 1.5e-7
        and abs(a.y - b.y) < 1.5e-7
        and abs(a.z - b.z) < 1e-3
    )


def _first_difference(got: list[MissionItem], want: list[MissionItem], skip: int) -> str | None:
    if len(got) != len(want):
        return f"{len(got)} items, expected {len(want)}"
    for seq, (a, b) in enumerate(zip(got, want, strict=True)):
        if seq >= skip and not _same(a, b):
            return f"item {seq}: firmware {a}, simulated vehicle {b}"
    return None


@pytest.mark.parametrize(("source", "end"), CASES, ids=[f"{s.stem}-{e}" for s, e in CASES])
def test_upload_verifies_every_bundled_plan(firmware: sitl.Sitl, source: Path, end: str) -> None:
    autopilot = firmware.autopilot
    path = sitl.planned(source, autopilot, end)
    result = CliRunner().invoke(
        main,
        # the parameters the mission relies on (PX4: RTL_TYPE 2) are set and read back first
        ["upload", str(path), "--conn", firmware.conn, "--heartbeat-timeout", "20", "--set-params"],
    )
    assert result.exit_code == 0, result.output
    assert "verified by read-back" in result.output, result.output
    # what the firmware holds is what the simulated vehicle holds for the same upload
    plan = load_mission(path)
    types = (MissionType.MISSION,)
    types += (MissionType.FENCE,) if not plan.fence.is_empty else ()
    types += (MissionType.RALLY,) if plan.rally else ()
    simulated = _mock_download(plan, autopilot, types)
    for mission_type in types:
        held = _download(firmware.conn, mission_type)
        # ArduPilot's mission item 0 is its home: the vehicle's own
        skip = 1 if autopilot == AP and mission_type == MissionType.MISSION else 0
        difference = _first_difference(held, simulated[mission_type], skip)
        assert difference is None, (mission_type, difference)


def _kinds_of_items() -> list[MissionItem]:
    """One item of every kind and form uavplan, QGroundControl or Mission Planner write."""
    lat, lon = 47.3980, 8.5460

    def item(cmd: int, frame: int, params: tuple, x: float = 0.0, y: float = 0.0, z: float = 0.0):
        p = [None if v is None else float(v) for v in params]
        return MissionItem(cmd, frame, p[0], p[1], p[2], p[3], x, y, z)

    return [
        item(22, 3, (0, 0, 0, None), lat, lon, 30.0),  # take-off
        item(16, 3, (0, 0.5, 0, None), lat, lon + 1e-4, 30.017),  # waypoint, radius 0.5
        item(16, 3, (1.5, 0, 0.3, 45), lat, lon + 2e-4, 31.0),  # hold 1.5 s, yaw 45
        item(16, 3, (0, 0, 0, -90), lat, lon + 3e-4, 31.0),  # yaw -90
        item(16, 0, (0, 0, 0, None), lat, lon + 4e-4, 520.004),  # AMSL
        item(178, 2, (1, 8, -1, 0)),  # DO_CHANGE_SPEED as uavplan and QGC write it
        item(178, 3, (1, 9, -1, 0)),  # ... as Mission Planner writes it
        item(19, 3, (10, 0, 0, 0), lat + 1e-4, lon, 30.0),  # LOITER_TIME
        item(19, 3, (5, 1, -5, 1), lat + 2e-4, lon, 30.0),
        item(17, 3, (0, 0, 0, None), lat + 3e-4, lon, 30.0),  # LOITER_UNLIM (the end)
        item(177, 2, (2, 1, 0, 0)),  # DO_JUMP
        item(205, 2, (-45, 0, 0, 0), 0, 0, 2),  # DO_MOUNT_CONTROL (mount mode 2 in z)
        item(203, 2, (0, 0, 0, 0)),  # DO_DIGICAM_CONTROL
        item(189, 3, (0, 0, 0, 0), lat, lon, 0.0),  # DO_LAND_START with a position
        item(20, 2, (0, 0, 0, 0)),  # RETURN_TO_LAUNCH as uavplan and QGC write it
        item(20, 3, (0, 0, 0, 0)),  # ... as Mission Planner writes it
        item(21, 3, (0, 0, 0, None), lat, lon, 0.0),  # LAND, yaw NaN
        item(21, 3, (2, 1, 0, 90), lat, lon, 0.0),  # LAND with abort altitude, yaw 90
    ]


def test_the_simulated_vehicle_keeps_every_kind_of_item_as_the_firmware(
    firmware: sitl.Sitl,
) -> None:
    autopilot = firmware.autopilot
    plan = MissionPlan(items=tuple(_kinds_of_items()), home=HOME, autopilot=autopilot)
    with VehicleLink.connect(firmware.conn, heartbeat_timeout_s=20) as link:
        report = upload_plan(MissionClient(link, FAST), plan)  # verified against storage.py
    assert report.verified
    held = _download(firmware.conn, MissionType.MISSION)
    skip = 1 if autopilot == AP else 0
    # the firmware holds what storage.py says it does ...
    wire = plan_wire_items(plan, MissionType.MISSION, autopilot)
    kept = [stored_form(i, autopilot, MissionType.MISSION) for i in wire]
    spelled = [_spelled(i, autopilot) for i in kept]
    assert _first_difference(held, spelled, skip) is None
    # ... and so does the simulated vehicle
    simulated = _mock_download(plan, autopilot, (MissionType.MISSION,))[MissionType.MISSION]
    assert _first_difference(held, simulated, skip) is None


def _spelled(item: MissionItem, autopilot: Autopilot) -> MissionItem:
    """PX4 sends a global frame back in its _INT spelling (format_mavlink_mission_item)."""
    from dataclasses import replace

    if autopilot == PX4 and item.frame in (0, 3):
        return replace(item, frame={0: 5, 3: 6}[item.frame])
    return item
