"""Issue 33: a QGroundControl plan holding a Survey complex item (QGC's plan format, version
5 survey with its ``TransectStyleComplexItem.Items``) is read, rerouted around an obstacle
placed on one of its lanes, written back, and imported by MAVSDK."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from helpers.independent import densify, independent_clearance
from helpers.mavsdk_offline import mavsdk_mission_raw

from uavplan.cli import main
from uavplan.errors import MissionFileError
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.mission.io import load_mission
from uavplan.mission.items import Autopilot, MavCmd
from uavplan.mission.qgc_plan import plan_from_json
from uavplan.mission.track import Track
from uavplan.obstacles import PrismObstacle

HOME = GeoPoint(47.397742, 8.545594, 488.0)
ALT = 40.0
#: six transects 300 m long, 40 m apart, flown east and west in turn (ENU m from home)
LANES = [((50.0, 50.0 + 40.0 * k), (350.0, 50.0 + 40.0 * k)) for k in range(6)]


def _simple(seq: int, command: int, frame: int, params: list[Any]) -> dict[str, Any]:
    item: dict[str, Any] = {
        "autoContinue": True,
        "command": command,
        "doJumpId": seq,
        "frame": frame,
        "params": params,
        "type": "SimpleItem",
    }
    if frame == 3:
        item.update(AMSLAltAboveTerrain=None, Altitude=params[6], AltitudeMode=1)
    return item


def qgc_survey_plan() -> dict[str, Any]:
    """A plan in the layout QGroundControl saves (plan version 1, mission version 2, a
    version-5 Survey whose TransectStyleComplexItem carries the generated Items: per
    transect a waypoint, DO_SET_CAM_TRIGG_DIST on, a waypoint, trigger off)."""
    frame = EnuFrame.at(HOME)
    seq = 1
    items: list[dict[str, Any]] = [_simple(seq, 22, 3, [0, 0, 0, None, 0, 0, ALT])]
    transect: list[dict[str, Any]] = []
    visual = []
    for k, (a, b) in enumerate(LANES):
        a, b = (a, b) if k % 2 == 0 else (b, a)
        for (x, y), trigger in ((a, 25.0), (b, 0.0)):
            lat, lon, _ = frame.to_geodetic_point(x, y, 0.0)
            seq += 1
            transect.append(_simple(seq, 16, 3, [0, 0, 0, None, lat, lon, ALT]))
            seq += 1
            transect.append(_simple(seq, 206, 2, [trigger, 0, 1, 0, 0, 0, 0]))
            visual.append([lat, lon])
    corners = [frame.to_geodetic_point(x, y, 0.0)[:2] for x, y in
               ((40, 40), (360, 40), (360, 260), (40, 260))]  # fmt: skip
    survey = {
        "TransectStyleComplexItem": {
            "CameraCalc": {
                "AdjustedFootprintFrontal": 25,
                "AdjustedFootprintSide": 40,
                "CameraName": "Manual (no camera specs)",
                "DistanceMode": 1,
                "DistanceToSurface": ALT,
                "version": 2,
            },
            "CameraShots": 78,
            "CameraTriggerInTurnAround": False,
            "HoverAndCapture": False,
            "Items": transect,
            "Refly90Degrees": False,
            "TurnAroundDistance": 0,
            "VisualTransectPoints": visual,
            "version": 2,
        },
        "angle": 90,
        "complexItemType": "survey",
        "entryLocation": 0,
        "flyAlternateTransects": False,
        "polygon": [list(c) for c in corners],
        "splitConcavePolygons": False,
        "type": "ComplexItem",
        "version": 5,
    }
    items.append(survey)
    seq += 1
    items.append(_simple(seq, 20, 2, [0, 0, 0, 0, 0, 0, 0]))
    return {
        "fileType": "Plan",
        "geoFence": {"circles": [], "polygons": [], "version": 2},
        "groundStation": "QGroundControl",
        "mission": {
            "cruiseSpeed": 15,
            "firmwareType": 12,
            "globalPlanAltitudeMode": 1,
            "hoverSpeed": 8,
            "items": items,
            "plannedHomePosition": [HOME.lat_deg, HOME.lon_deg, HOME.alt_m],
            "vehicleType": 2,
            "version": 2,
        },
        "rallyPoints": {"points": [], "version": 2},
        "version": 1,
    }


def tower_clearance(track: Track) -> float:
    """The least distance from the track (0.5 m apart) to the tower, by the end-to-end test's
    own distances (not the library's)."""
    frame = EnuFrame.at(HOME)
    xy = frame.to_enu_xy(track.lat_deg, track.lon_deg)
    dense = densify(np.column_stack((xy, track.relative_alt_m)), 0.5)
    tower = PrismObstacle(((190.0, 120.0), (210.0, 120.0), (210.0, 140.0), (190.0, 140.0)), 60.0)
    fake = SimpleNamespace(site=SimpleNamespace(obstacles=[tower]))
    return float(independent_clearance(fake, dense).min())


def test_the_survey_items_are_read_in_order() -> None:
    plan = plan_from_json(json.dumps(qgc_survey_plan()), file="survey.plan")
    commands = [i.command for i in plan.items]
    assert commands[0] == MavCmd.NAV_TAKEOFF and commands[-1] == MavCmd.NAV_RETURN_TO_LAUNCH
    assert commands[1:-1] == [MavCmd.NAV_WAYPOINT, MavCmd.DO_SET_CAM_TRIGG_DIST] * 12
    triggers = [i.param1 for i in plan.items if i.command == MavCmd.DO_SET_CAM_TRIGG_DIST]
    assert triggers == [25.0, 0.0] * 6


@pytest.mark.parametrize(
    ("change", "key", "match"),
    [
        ({"complexItemType": "StructureScan"}, "mission.items[1]", "StructureScan"),
        ({"TransectStyleComplexItem": {"Items": []}},
         "mission.items[1].TransectStyleComplexItem.Items", "holds no mission items"),
        ({"TransectStyleComplexItem": None},
         "mission.items[1].TransectStyleComplexItem", "needs its TransectStyleComplexItem"),
    ],
)  # fmt: skip
def test_complex_items_we_cannot_fly_are_refused_naming_the_key(
    change: dict[str, Any], key: str, match: str
) -> None:
    doc = qgc_survey_plan()
    doc["mission"]["items"][1].update(change)
    with pytest.raises(MissionFileError, match=match) as info:
        plan_from_json(json.dumps(doc), file="survey.plan")
    assert info.value.key == key


@pytest.mark.timeout(300)
@pytest.mark.slow
def test_a_survey_is_rerouted_around_a_building_on_a_lane_and_mavsdk_imports_it(
    tmp_path: Path,
) -> None:
    src = tmp_path / "survey.plan"
    src.write_text(json.dumps(qgc_survey_plan(), indent=2))
    # a 60 m tower in the middle of the third transect (y = 130), 20 m across
    scenario = tmp_path / "site.yaml"
    scenario.write_text(yaml.safe_dump({
        "name": "site",
        "origin": {"lat": HOME.lat_deg, "lon": HOME.lon_deg, "alt": HOME.alt_m},
        "bounds": {"x": [-100, 500], "y": [-100, 400], "z": [0, 100]},
        "safety_margin": 10,
        "obstacles": [{"type": "box", "center": [200, 130], "size": [20, 20], "height": 60}],
    }))  # fmt: skip
    out = tmp_path / "safe.plan"
    run = CliRunner().invoke(main, ["plan", str(src), "--scenario", str(scenario), "-o", str(out)])
    assert run.exit_code == 0, run.output
    before, after = load_mission(src), load_mission(out)
    # every item of the survey kept, in order; waypoints added around the tower only
    kept = [i for i in after.items if i.command != MavCmd.NAV_WAYPOINT]
    assert [i.command for i in kept] == [
        i.command for i in before.items if i.command != MavCmd.NAV_WAYPOINT
    ]
    added = sum(i.command == MavCmd.NAV_WAYPOINT for i in after.items) - 12
    assert added >= 1
    # as flown (the flight model), the independent distances keep the margin from the tower
    track_csv = tmp_path / "flown.csv"
    sim = CliRunner().invoke(
        main, ["simulate", str(out), "--scenario", str(scenario), "--track", str(track_csv)]
    )
    assert sim.exit_code == 0, sim.output
    assert tower_clearance(Track.load(track_csv)) >= 10.0 - 0.05
    # MAVSDK's importer reads the written plan, every item
    with mavsdk_mission_raw(Autopilot.PX4) as mission_raw:
        data = mission_raw.import_qgroundcontrol_mission(str(out))
    assert [int(i.command) for i in data.mission_items] == [int(i.command) for i in after.items]
    # the straight third transect would have passed through the tower
    frame = EnuFrame.at(HOME)
    pts = np.array([frame.to_enu_xy([i.x], [i.y])[0] for i in after.items
                    if i.command == MavCmd.NAV_WAYPOINT])  # fmt: skip
    assert np.any((np.abs(pts[:, 1] - 130.0) > 20.0) & (np.abs(pts[:, 0] - 200.0) < 60.0))
