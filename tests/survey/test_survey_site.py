"""A survey scenario is the site its mission is checked in: ``validate``, ``simulate``,
``render --mission`` (and ``fly``, ``convert``) take it as ``--scenario``, its ``exclude``
polygons standing as no-fly obstacles as ``plan`` judged them; a mission through a no-fly
hole fails there (exit 3) where the survey's map alone would pass it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from uavplan.cli import main
from uavplan.scenario import load_site, load_surroundings

SURVEY = {
    "name": "field",
    "origin": {"lat": 60.0, "lon": 25.0},
    "bounds": {"x": [-100, 500], "y": [-100, 350], "z": [0, 120]},
    "start": [-40, -40, 20],
    "safety_margin": 10,
    "survey": {
        "area": [[0, 0], [400, 0], [400, 250], [0, 250]],
        "exclude": [[[150, 100], [230, 100], [230, 160], [150, 160]]],
        "altitude": 50,
        "lane_spacing_m": 30,
    },
}


@pytest.fixture(scope="module")
def planned(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    d = tmp_path_factory.mktemp("site")
    src = d / "field.yaml"
    src.write_text(yaml.safe_dump(SURVEY))
    out = d / "field.plan"
    result = CliRunner().invoke(main, ["plan", str(src), "-o", str(out)])
    assert result.exit_code == 0, result.output
    return src, out


def test_the_site_has_the_no_fly_holes(planned: tuple[Path, Path]) -> None:
    src, _ = planned
    site = load_site(src)
    assert site.obstacle_name(len(site.obstacles) - 1) == "survey.exclude[0] (no-fly)"
    around = load_surroundings(src)
    assert len(around.obstacles) == len(site.obstacles) and around.goal_m is None


@pytest.mark.parametrize("command", ["validate", "simulate"])
def test_the_survey_mission_checks_in_its_scenario(
    planned: tuple[Path, Path], command: str
) -> None:
    src, plan = planned
    result = CliRunner().invoke(main, [command, str(plan), "--scenario", str(src)])
    assert result.exit_code == 0, result.output
    if command == "simulate":
        assert "taken as flown" in result.output


def test_render_draws_the_survey_mission_in_its_scenario(
    planned: tuple[Path, Path], tmp_path: Path
) -> None:
    src, plan = planned
    png = tmp_path / "f.png"
    result = CliRunner().invoke(main, ["render", str(src), "--mission", str(plan), "-o", str(png)])
    assert result.exit_code == 0, result.output
    assert png.stat().st_size > 10_000


def test_the_picture_s_survey_layers(planned: tuple[Path, Path]) -> None:
    """The area, and every photo the flight model took with its footprint, in the scenario's
    frame: inside the area (a photo is taken on a lane)."""

    import shapely

    from uavplan.app.check import judged, read_mission_flight
    from uavplan.app.render import survey_layers
    from uavplan.planning import enu_frame
    from uavplan.rehearsal import CheckSite
    from uavplan.render import RouteLayers

    src, plan = planned
    scn = load_site(src)
    mission, flight = read_mission_flight(str(plan), scn)
    verdict = judged(mission, CheckSite.of_scenario(scn), scn)
    layers = survey_layers(
        RouteLayers.from_mission(mission, enu_frame(scn), flight.points_enu), str(src), scn, verdict
    )
    assert layers.survey_area_xy is not None and len(layers.survey_area_xy) == 4
    assert layers.photos_xy is not None and len(layers.photos_xy) > 20
    area = shapely.Polygon(layers.survey_area_xy).buffer(1.0)
    assert all(area.contains(shapely.Point(p)) for p in layers.photos_xy)
    # without a camera the lanes' spacing is the footprint: no footprint is drawn
    assert layers.photo_footprints_xy is None
    assert np.isfinite(layers.photos_xy).all()


def test_a_mission_through_the_no_fly_hole_fails_in_the_survey_s_scenario(
    planned: tuple[Path, Path], tmp_path: Path
) -> None:
    """The planned mission with one lane waypoint moved into the middle of the hole: the
    survey scenario refuses it, naming the hole; the same scenario without its survey
    section (the map alone) has nothing there and passes it."""
    src, plan = planned
    data = json.loads(plan.read_text())
    items = data["mission"]["items"]
    moved = next(i for i in items if i["command"] == 16 and i["params"][4] > 60.0)
    site = load_site(src)
    from uavplan.geo import EnuFrame

    lat, lon, _ = EnuFrame.at(site.origin).to_geodetic([[190.0, 130.0, 0.0]])
    moved["params"][4], moved["params"][5] = float(lat[0]), float(lon[0])
    bad = tmp_path / "through.plan"
    bad.write_text(json.dumps(data))
    result = CliRunner().invoke(main, ["validate", str(bad), "--scenario", str(src)])
    assert result.exit_code in (2, 3), result.output
    assert "survey.exclude[0] (no-fly)" in result.output
    plain = {k: v for k, v in SURVEY.items() if k != "survey"}
    plain["goal"] = [400, 250, 50]
    map_only = tmp_path / "map.yaml"
    map_only.write_text(yaml.safe_dump(plain))
    result = CliRunner().invoke(main, ["validate", str(bad), "--scenario", str(map_only)])
    assert "survey.exclude" not in result.output


@pytest.fixture(scope="module")
def power_line(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, str]:
    """The bundled camera survey planned once for the module: (scenario, plan, what plan
    printed). The tests only read them."""
    src = Path(__file__).resolve().parents[2] / "missions" / "surveys" / "survey-power-line.yaml"
    plan = tmp_path_factory.mktemp("line") / "line.plan"
    result = CliRunner().invoke(main, ["plan", str(src), "-o", str(plan)])
    assert result.exit_code == 0, result.output
    return src, plan, result.output


def test_a_camera_survey_s_picture_has_a_footprint_per_photo(
    power_line: tuple[Path, Path, str],
) -> None:
    from uavplan.app.check import judged, read_mission_flight
    from uavplan.app.render import survey_layers
    from uavplan.planning import enu_frame
    from uavplan.rehearsal import CheckSite
    from uavplan.render import RouteLayers

    src, out, _ = power_line
    scn = load_site(src)
    mission, flight = read_mission_flight(str(out), scn)
    verdict = judged(mission, CheckSite.of_scenario(scn), scn)
    base = RouteLayers.from_mission(mission, enu_frame(scn), flight.points_enu)
    layers = survey_layers(base, str(src), scn, verdict)
    assert layers.photos_xy is not None and layers.photo_footprints_xy is not None
    assert layers.photo_footprints_xy.shape == (len(layers.photos_xy), 4, 2)
    # each footprint is the camera's (50.8 m across the lane at 40 m, 33.8 m along it)
    fp = layers.photo_footprints_xy[len(layers.photos_xy) // 2]
    sides = np.hypot(*np.diff(np.vstack([fp, fp[:1]]), axis=0).T)
    assert sorted(np.round(sides, 1))[::2] == [33.8, 50.8]


def test_the_exports_carry_the_area_photos_and_footprints(
    power_line: tuple[Path, Path, str], tmp_path: Path
) -> None:
    """convert --scenario SURVEY to GeoJSON and KML: the area, one footprint per photo and
    the photos the mission's camera items ask for (as many as plan counted), each inside
    the area."""
    import shapely

    src, plan, printed = power_line
    photos = int(printed.split(" photos,")[0].rsplit(" ", 1)[1])
    out = tmp_path / "line.geojson"
    result = CliRunner().invoke(main, ["convert", str(plan), str(out), "--scenario", str(src)])
    assert result.exit_code == 0, result.output
    features = json.loads(out.read_text())["features"]
    kinds = [f["properties"]["kind"] for f in features]
    assert kinds.count("survey_area") == 1 and kinds.count("photos") == 1
    shot = next(f for f in features if f["properties"]["kind"] == "photos")
    assert shot["properties"]["count"] == photos == kinds.count("photo_footprint")
    area = next(f for f in features if f["properties"]["kind"] == "survey_area")
    ring = shapely.Polygon(area["geometry"]["coordinates"][0]).buffer(1e-5)  # about 1 m
    assert all(ring.contains(shapely.Point(p)) for p in shot["geometry"]["coordinates"])
    kml = tmp_path / "line.kml"
    result = CliRunner().invoke(main, ["convert", str(plan), str(kml), "--scenario", str(src)])
    assert result.exit_code == 0, result.output
    text = kml.read_text()
    assert "<name>Survey</name>" in text and f"photos ({photos})" in text


def test_mission_photos_follow_the_camera_items() -> None:
    """Distance triggering counts path through a waypoint (a photo every 30 m of the L,
    not restarting at its corner), starts with a photo, and stops; a capture is one photo."""
    from uavplan.geo import EnuFrame, GeoPoint
    from uavplan.mission.builder import build_mission
    from uavplan.mission.camera import mission_photos
    from uavplan.mission.items import MavCmd, MavFrame, MissionItem

    frame = EnuFrame.at(GeoPoint(60.0, 25.0, 0.0))
    start = MissionItem(command=MavCmd.DO_SET_CAM_TRIGG_DIST, frame=MavFrame.MISSION,
                        param1=30.0, param2=0.0, param3=1.0)  # fmt: skip
    stop = MissionItem(command=MavCmd.DO_SET_CAM_TRIGG_DIST, frame=MavFrame.MISSION,
                       param1=0.0, param2=0.0, param3=0.0)  # fmt: skip
    shot = MissionItem(command=MavCmd.IMAGE_START_CAPTURE, frame=MavFrame.MISSION,
                       param1=0.0, param2=0.0, param3=1.0)  # fmt: skip
    rows = np.array([[0, 0, 20], [0, 0, 25], [100, 0, 25], [100, 100, 25], [150, 100, 25],
                     [0, 0, 25]], dtype=float)  # fmt: skip
    plan = build_mission(rows, frame, autopilot="ardupilot", end="land",
                         row_items={1: [start], 3: [stop], 4: [shot]})  # fmt: skip
    xy = mission_photos(plan, frame)
    # 0, 30, ..., 180 m along the L from (0, 0): 7 photos, then the capture at (150, 100)
    assert len(xy) == 8
    assert np.allclose(xy[4], [100.0, 20.0], atol=0.05)
    assert np.allclose(xy[6], [100.0, 80.0], atol=0.05)
    assert np.allclose(xy[7], [150.0, 100.0], atol=0.05)
