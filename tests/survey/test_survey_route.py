"""A survey flown in the world: lanes keep the margin from every obstacle, transitions that
a tall building blocks are routed around it, the photo footprints cover the free area."""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from shapely.geometry import LineString, Polygon

from uavplan.errors import InputError
from uavplan.mission.io import load_mission, save_mission
from uavplan.mission.items import MavCmd
from uavplan.planning import build_world
from uavplan.scenario import load_scenario
from uavplan.scenario.checker import Checker
from uavplan.scenario.survey import read_survey
from uavplan.survey import coverage
from uavplan.surveying import plan_survey, survey_mission

TOWER = {"type": "box", "center": [400, 250], "size": [120, 80], "height": 90}
SHED = {"type": "box", "center": [150, 100], "size": [20, 20], "height": 20}
SCN: dict[str, Any] = {
    "origin": {"lat": 60.0, "lon": 25.0},
    "bounds": {"x": [-200, 1000], "y": [-200, 700], "z": [0, 150]},
    "start": [-60, 250, 20],
    "goal": [-60, 200, 30],  # a route scenario: the survey is passed on its own
    "safety_margin": 10,
    "obstacles": [TOWER, SHED],
}
RX100 = {
    "sensor_width_mm": 13.2,
    "sensor_height_mm": 8.8,
    "image_width_px": 5472,
    "image_height_px": 3648,
    "focal_length_mm": 10.4,
}
SURVEY = {
    "area": [[0, 0], [800, 0], [800, 500], [0, 500]],
    "camera": RX100,
    "altitude": 60,
    "angle_deg": 0,
}


def _scenario(tmp_path: Path, **extra: Any) -> Any:
    f = tmp_path / "s.yaml"
    f.write_text(yaml.safe_dump({**SCN, **extra}))
    return load_scenario(f)


def test_lanes_and_transitions_keep_the_margin_and_go_around_the_tower(tmp_path: Path) -> None:
    scn = _scenario(tmp_path)
    spec = read_survey(Checker("s"), SURVEY)
    r = plan_survey(scn, spec)
    world = build_world(scn)
    w = r.waypoints_enu
    assert np.all(world.segments_free(w[:-1], w[1:]))
    assert r.min_clearance_m >= 10.0 - 1e-6
    assert np.allclose(w[0], scn.start_m) and np.allclose(w[-1], scn.start_m)
    # independent check: no horizontal leg at survey height crosses the tower's footprint
    tower = Polygon([(340, 210), (460, 210), (460, 290), (340, 290)])
    for p, q in itertools.pairwise(w):
        assert LineString([p[:2], q[:2]]).distance(tower) >= 10.0 - 1e-6
    # the shed (20 m, below 60 − 10) is flown over: a lane within its margin crosses it whole
    over_shed = [
        (a, b) for a, b in r.sweep.pieces_xy
        if abs(a[1] - 100) < 20 and min(a[0], b[0]) < 140 and max(a[0], b[0]) > 160
    ]  # fmt: skip
    assert over_shed
    # the lane pieces split by the tower: the tower's lanes come in two pieces
    ys = np.round(r.sweep.pieces_xy[:, 0, 1], 6)
    assert any(np.sum(ys == y) == 2 for y in np.unique(ys))
    assert r.lane_start.sum() == r.lanes


def test_a_blocked_way_home_is_routed(tmp_path: Path) -> None:
    # the start east of the field, the tower between the last lane's end and home: routed
    scn = _scenario(tmp_path, start=[400, 330, 20], goal=[380, 330, 30])
    spec = read_survey(Checker("s"), {**SURVEY, "area": [[0, 0], [800, 0], [800, 200], [0, 200]]})
    r = plan_survey(scn, spec)
    world = build_world(scn)
    w = r.waypoints_enu
    assert r.rerouted >= 1
    assert np.all(world.segments_free(w[:-1], w[1:]))
    assert r.min_clearance_m >= 10.0 - 1e-6
    # the straight way home from the last lane's end would cross the tower
    last = r.sweep.pieces_xy[-1, 1]
    assert LineString([last, (400, 330)]).intersects(
        Polygon([(340, 210), (460, 210), (460, 290), (340, 290)])
    )


def test_photos_cover_the_free_area(tmp_path: Path) -> None:
    scn = _scenario(tmp_path)
    spec = read_survey(Checker("s"), SURVEY)
    r = plan_survey(scn, spec)
    photos = coverage.photo_positions(r.sweep.pieces_xy, spec.spacing.trigger_distance_m)
    assert spec.spacing.footprint_side_m and spec.spacing.footprint_front_m
    fp = coverage.footprints(
        photos, r.sweep.angle_deg, spec.spacing.footprint_side_m, spec.spacing.footprint_front_m
    )
    assert coverage.covered_fraction(r.free, fp) >= 0.99


def test_an_area_all_hole_is_a_user_error(tmp_path: Path) -> None:
    scn = _scenario(tmp_path)
    spec = read_survey(
        Checker("s"),
        {"area": [[380, 240], [420, 240], [420, 260]], "altitude": 60, "lane_spacing_m": 10},
    )
    with pytest.raises(InputError, match="no lane"):
        plan_survey(scn, spec)


@pytest.mark.parametrize("suffix", [".plan", ".waypoints", ".geojson", ".kml"])
def test_distance_trigger_mission_starts_and_stops_the_camera_per_lane(
    tmp_path: Path, suffix: str
) -> None:
    scn = _scenario(tmp_path)
    spec = read_survey(Checker("s"), SURVEY)
    r = plan_survey(scn, spec)
    plan = survey_mission(scn, spec, r)
    cams = [it for it in plan.items if it.command == MavCmd.DO_SET_CAM_TRIGG_DIST]
    assert len(cams) == 2 * r.lanes
    on = [it.param1 for it in cams[0::2]]
    off = [it.param1 for it in cams[1::2]]
    assert (
        on == pytest.approx([spec.spacing.trigger_distance_m] * r.lanes) and off == [0.0] * r.lanes
    )
    # every start follows a waypoint at a lane's start, every stop one at its end
    idx = [i for i, it in enumerate(plan.items) if it.command == MavCmd.DO_SET_CAM_TRIGG_DIST]
    assert all(plan.items[i - 1].command == MavCmd.NAV_WAYPOINT for i in idx)
    out = tmp_path / f"m{suffix}"
    save_mission(plan, out)
    if suffix in (".plan", ".waypoints"):
        back = load_mission(out, plan.autopilot)
        assert [it.command for it in back.items] == [it.command for it in plan.items]
        got = [it.param1 for it in back.items if it.command == MavCmd.DO_SET_CAM_TRIGG_DIST]
        assert got == pytest.approx([it.param1 for it in cams], abs=1e-4)
    else:
        assert out.stat().st_size > 0


def test_hover_mission_holds_and_captures_once_per_photo(tmp_path: Path) -> None:
    scn = _scenario(tmp_path)
    spec = read_survey(Checker("s"), {**SURVEY, "trigger": "hover"})
    r = plan_survey(scn, spec)
    plan = survey_mission(scn, spec, r)
    caps = [i for i, it in enumerate(plan.items) if it.command == MavCmd.IMAGE_START_CAPTURE]
    assert len(caps) == r.sweep.photos
    for i in caps:
        wp = plan.items[i - 1]
        assert wp.command == MavCmd.NAV_WAYPOINT and wp.param1 == 1.0
        assert plan.items[i].param3 == 1.0
    assert not any(it.command == MavCmd.DO_SET_CAM_TRIGG_DIST for it in plan.items)
