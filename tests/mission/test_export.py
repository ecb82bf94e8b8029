"""GeoJSON (RFC 7946) and KML exports: structure, coordinate order, altitudes, and the
``plan -o x.geojson`` / ``convert IN OUT`` commands that write them."""

from __future__ import annotations

import itertools
import json
import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from click.testing import CliRunner

from uavplan.cli import main
from uavplan.errors import MissionFileError
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.mission.builder import build_mission, mission_polyline_enu
from uavplan.mission.export import (
    ALTITUDE_REFERENCE,
    ExportExtras,
    geojson_dumps,
    kml_dumps,
    to_geojson,
)
from uavplan.mission.fence import build_geofence, footprints_of
from uavplan.mission.io import FORMATS, load_mission, save_mission
from uavplan.mission.items import Autopilot, MissionPlan
from uavplan.obstacles import BoxObstacle, CylinderObstacle
from uavplan.route import PlannedRoute, flown_polyline

ORIGIN = GeoPoint(47.397742, 8.545594, 488.0)
FRAME = EnuFrame.at(ORIGIN)
WAYPOINTS = np.array(
    [[0.0, 0.0, 30.0], [150.0, -60.0, 35.0], [300.0, -60.0, 42.5], [450.0, 20.0, 40.0]]
)
OBSTACLES = (
    BoxObstacle((200.0, 60.0), (80.0, 60.0), 90.0, 15.0),
    CylinderObstacle((350, 90), 25, 70),
)
KML = "{http://www.opengis.net/kml/2.2}"


def mission(autopilot: Autopilot = Autopilot.ARDUPILOT, *, fence: bool = False) -> MissionPlan:
    plan = build_mission(WAYPOINTS, FRAME, autopilot=autopilot, end="land", cruise_speed_m_s=8.0)
    if fence:
        built = build_geofence(
            footprints_of(OBSTACLES),
            mission_polyline_enu(plan, FRAME),
            FRAME,
            bounds_xy_m=((0.0, 500.0), (-200.0, 200.0)),
            margin_m=10.0,
        )
        plan = MissionPlan(
            plan.items, plan.autopilot, plan.home, built.fence, (), cruise_speed_m_s=8.0
        )
    return plan


def extras() -> ExportExtras:
    planned = np.vstack([np.linspace(a, b, 20) for a, b in itertools.pairwise(WAYPOINTS)])
    return ExportExtras(
        frame=FRAME,
        obstacles=footprints_of(OBSTACLES),
        planned_path_enu=planned,
        name="test route",
        safety_margin_m=10.0,
        properties={"algorithm": "spsa", "seed": 7},
    )


# ---------------------------------------------------------------------------------------------
# RFC 7946 structure, as a reader would check it


def rfc7946_errors(doc: Any) -> list[str]:
    """Violations of RFC 7946's structure (sections 3, 3.1, 3.2, 3.3, 4)."""
    errors: list[str] = []
    if not isinstance(doc, dict) or doc.get("type") != "FeatureCollection":
        return ["top level is not a FeatureCollection"]
    if "crs" in doc:
        errors.append("'crs' was removed in RFC 7946")
    if not isinstance(doc.get("features"), list):
        return [*errors, "features is not an array"]
    for i, feature in enumerate(doc["features"]):
        where = f"features[{i}]"
        if not isinstance(feature, dict) or feature.get("type") != "Feature":
            errors.append(f"{where}: not a Feature")
            continue
        if "geometry" not in feature or "properties" not in feature:
            errors.append(f"{where}: a Feature has 'geometry' and 'properties' members")
        props = feature.get("properties")
        if props is not None and not isinstance(props, dict):
            errors.append(f"{where}: properties must be an object or null")
        geometry = feature.get("geometry")
        if geometry is not None:
            errors.extend(f"{where}: {e}" for e in _geometry_errors(geometry))
    return errors


def _position_errors(pos: Any) -> list[str]:
    if not isinstance(pos, list) or len(pos) not in (2, 3):
        return [f"position {pos!r} is not [lon, lat] or [lon, lat, alt]"]
    if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in pos):
        return [f"position {pos!r} holds a non-number"]
    if not all(math.isfinite(v) for v in pos):
        return [f"position {pos!r} is not finite"]
    lon, lat = pos[0], pos[1]
    out = []
    if not -180 <= lon <= 180:
        out.append(f"longitude {lon} out of range")
    if not -90 <= lat <= 90:
        out.append(f"latitude {lat} out of range")
    return out


def _geometry_errors(geometry: dict[str, Any]) -> list[str]:
    kind, coords = geometry.get("type"), geometry.get("coordinates")
    if kind == "Point":
        return _position_errors(coords)
    if kind == "LineString":
        if not isinstance(coords, list) or len(coords) < 2:
            return ["a LineString has two or more positions"]
        return [e for p in coords for e in _position_errors(p)]
    if kind == "Polygon":
        out: list[str] = []
        if not isinstance(coords, list) or not coords:
            return ["a Polygon is an array of linear rings"]
        for k, ring in enumerate(coords):
            if not isinstance(ring, list) or len(ring) < 4:
                out.append(f"ring {k} has fewer than 4 positions")
                continue
            if ring[0] != ring[-1]:
                out.append(f"ring {k} is not closed")
            out.extend(e for p in ring for e in _position_errors(p))
            x, y = np.asarray(ring)[:, 0], np.asarray(ring)[:, 1]
            area = np.dot(x[:-1], y[1:]) - np.dot(x[1:], y[:-1])
            if (area > 0) != (k == 0):
                out.append(f"ring {k} winds the wrong way (exterior counter-clockwise)")
        return out
    return [f"unexpected geometry type {kind!r}"]


def strict_json(text: str) -> Any:
    def reject(name: str) -> None:
        raise AssertionError(f"{name} is not JSON")

    return json.loads(text, parse_constant=reject)


def by_kind(doc: dict[str, Any], kind: str) -> list[dict[str, Any]]:
    return [f for f in doc["features"] if f["properties"]["kind"] == kind]


# ---------------------------------------------------------------------------------------------
# GeoJSON


@pytest.mark.parametrize("autopilot", [Autopilot.PX4, Autopilot.ARDUPILOT])
def test_geojson_is_rfc7946_with_lon_lat_alt(autopilot: Autopilot) -> None:
    plan = mission(autopilot, fence=True)
    doc = strict_json(geojson_dumps(plan, extras()))
    assert rfc7946_errors(doc) == []

    (route,) = by_kind(doc, "route")
    coords = np.asarray(route["geometry"]["coordinates"])
    flown = mission_polyline_enu(plan, FRAME)
    assert coords.shape == (len(flown), 3)
    # [lon, lat, height]: the first position is home, on the ground
    assert coords[0] == pytest.approx([ORIGIN.lon_deg, ORIGIN.lat_deg, 0.0], abs=1e-8)
    back = FRAME.to_enu_xy(coords[:, 1], coords[:, 0])
    np.testing.assert_allclose(back, flown[:, :2], atol=0.01)
    np.testing.assert_allclose(coords[:, 2], flown[:, 2], atol=1e-3)
    props = route["properties"]
    assert props["altitude_reference"] == ALTITUDE_REFERENCE
    assert props["home_amsl_m"] == pytest.approx(488.0)
    assert props["algorithm"] == "spsa" and props["seed"] == 7
    assert props["autopilot"] == autopilot.label
    assert props["route_length_m"] == pytest.approx(
        float(np.linalg.norm(np.diff(flown, axis=0), axis=1).sum()), abs=1e-3
    )

    waypoints = by_kind(doc, "waypoint")
    positional = [i for i in plan.items if i.is_global]
    assert len(waypoints) == len(positional)
    first_seq = 1 if autopilot == Autopilot.ARDUPILOT else 0
    assert waypoints[0]["properties"]["seq"] == first_seq
    assert waypoints[0]["properties"]["command_name"] == "NAV_TAKEOFF"
    assert waypoints[-1]["properties"]["command_name"] == "NAV_LAND"
    for feature, item in zip(waypoints, positional, strict=True):
        assert feature["geometry"]["coordinates"] == pytest.approx(
            [item.lon_deg, item.lat_deg, item.alt_m], abs=1e-6
        )
    (home,) = by_kind(doc, "home")
    assert home["properties"]["altitude_amsl_m"] == pytest.approx(488.0)


def test_geojson_obstacles_planned_path_and_fence() -> None:
    plan = mission(fence=True)
    doc = to_geojson(plan, extras())
    obstacles = by_kind(doc, "obstacle")
    assert [o["properties"]["shape"] for o in obstacles] == ["box", "cylinder"]
    assert obstacles[0]["properties"]["height_m"] == 90.0
    assert obstacles[1]["properties"]["radius_m"] == 25.0
    ring = np.asarray(obstacles[0]["geometry"]["coordinates"][0])
    back = FRAME.to_enu_xy(ring[:-1, 1], ring[:-1, 0])
    np.testing.assert_allclose(back, OBSTACLES[0].footprint(), atol=0.01)
    cyl = np.asarray(obstacles[1]["geometry"]["coordinates"][0])
    radius = np.hypot(*(FRAME.to_enu_xy(cyl[:, 1], cyl[:, 0]) - [350, 90]).T)
    np.testing.assert_allclose(radius, 25.0, atol=0.01)

    (planned,) = by_kind(doc, "planned_path")
    assert len(planned["geometry"]["coordinates"]) == 60
    fences = by_kind(doc, "fence")
    assert len(fences) == len(plan.fence.polygons) + len(plan.fence.circles)
    assert [f["properties"]["inclusion"] for f in fences].count(True) == 1


def test_mission_only_geojson_through_save_mission(tmp_path: Path) -> None:
    plan = mission()
    save_mission(plan, tmp_path / "m.geojson")
    doc = strict_json((tmp_path / "m.geojson").read_text())
    assert rfc7946_errors(doc) == []
    kinds = {f["properties"]["kind"] for f in doc["features"]}
    assert kinds == {"route", "home", "waypoint"}
    with pytest.raises(MissionFileError, match="can be written but not read"):
        load_mission(tmp_path / "m.geojson")


def test_plan_without_home_or_positions_still_exports() -> None:
    from uavplan.mission.items import MavCmd, MissionItem

    rtl_only = MissionPlan(items=(MissionItem(MavCmd.NAV_RETURN_TO_LAUNCH, frame=2),))
    doc = strict_json(geojson_dumps(rtl_only))
    assert doc["features"] == []
    no_home = MissionPlan(items=mission().items, home=None)
    doc = strict_json(geojson_dumps(no_home))
    assert rfc7946_errors(doc) == []
    assert by_kind(doc, "route")  # traced from the first positioned item


def test_export_formats_are_registered_write_only() -> None:
    assert FORMATS[".geojson"].loads is None and FORMATS[".kml"].loads is None
    assert FORMATS[".geojson"].dumps_extras is not None
    assert FORMATS[".plan"].dumps_extras is None


def test_extras_need_a_frame_for_enu_layers() -> None:
    with pytest.raises(ValueError, match="frame"):
        ExportExtras(obstacles=footprints_of(OBSTACLES))


def planned_route() -> PlannedRoute:
    planned = np.vstack([np.linspace(a, b, 20) for a, b in itertools.pairwise(WAYPOINTS)])
    return PlannedRoute(
        frame=FRAME,
        waypoints_enu=WAYPOINTS,
        path_enu=planned,
        vertices_enu=WAYPOINTS,
        raw_path_enu=None,
        flown_enu=flown_polyline(WAYPOINTS, takeoff_altitude_m=12.0, end="land"),
        min_clearance_m=10.0,
        safety_margin_m=10.0,
        inside_bounds=True,
        takeoff_altitude_m=12.0,
        end="land",
    )


def test_extras_for_a_planned_route_draw_its_own_flown_line() -> None:
    """A just-planned route is drawn from its PlannedRoute (nothing rebuilt from items), and
    that is the line the items trace, to the 1e-8 degree the file keeps."""
    route = planned_route()
    plan = build_mission(
        WAYPOINTS, FRAME, autopilot=Autopilot.PX4, end="land", takeoff_altitude_m=12.0
    )
    extras_ = ExportExtras.for_route(route, OBSTACLES, name="r", properties={"seed": 3})
    assert extras_.safety_margin_m == 10.0 and extras_.frame is FRAME
    doc = to_geojson(plan, extras_)
    assert rfc7946_errors(doc) == []
    (line,) = by_kind(doc, "route")
    coords = np.asarray(line["geometry"]["coordinates"])
    lat, lon, _ = FRAME.to_geodetic(
        np.column_stack((route.flown_enu[:, :2], np.zeros(len(coords))))
    )
    np.testing.assert_allclose(coords[:, 0], lon, rtol=0, atol=1e-8)
    np.testing.assert_allclose(coords[:, 1], lat, rtol=0, atol=1e-8)
    np.testing.assert_allclose(coords[:, 2], route.flown_enu[:, 2], rtol=0, atol=1e-3)
    assert line["properties"]["seed"] == 3
    # traced from the items instead (what `convert` does): the same line
    (traced,) = by_kind(to_geojson(plan), "route")
    np.testing.assert_allclose(traced["geometry"]["coordinates"], coords, rtol=0, atol=2e-8)
    assert line["properties"]["route_length_m"] == pytest.approx(
        traced["properties"]["route_length_m"], abs=2e-3
    )


def test_extras_take_obstacle_values_or_footprints() -> None:
    a = ExportExtras(frame=FRAME, obstacles=OBSTACLES)
    b = ExportExtras(frame=FRAME, obstacles=footprints_of(OBSTACLES))
    assert a.footprints == b.footprints
    assert to_geojson(mission(), a) == to_geojson(mission(), b)


def test_export_module_knows_no_scenario() -> None:
    import uavplan.mission.export as export

    text = Path(export.__file__).read_text(encoding="utf-8")
    assert "uavplan.scenario" not in text and "from_scenario" not in text


# ---------------------------------------------------------------------------------------------
# KML


def test_kml_parses_and_flies_relative_to_ground() -> None:
    plan = mission(fence=True)
    text = kml_dumps(plan, extras())
    assert text.startswith('<?xml version="1.0" encoding="UTF-8"?>')
    root = ET.fromstring(text.encode("utf-8"))
    assert root.tag == f"{KML}kml"
    doc = root.find(f"{KML}Document")
    assert doc is not None and doc.findtext(f"{KML}name") == "test route"

    lines = doc.findall(f".//{KML}LineString")
    assert len(lines) == 2  # flown route, planned path
    route = lines[0]
    assert route.findtext(f"{KML}altitudeMode") == "relativeToGround"
    assert route.findtext(f"{KML}extrude") == "1"
    text = route.findtext(f"{KML}coordinates") or ""
    coords = np.array([[float(v) for v in t.split(",")] for t in text.split()])
    flown = mission_polyline_enu(plan, FRAME)
    assert coords.shape == (len(flown), 3)
    assert coords[0] == pytest.approx([ORIGIN.lon_deg, ORIGIN.lat_deg, 0.0], abs=1e-8)
    np.testing.assert_allclose(coords[:, 2], flown[:, 2], atol=1e-3)

    placemarks = doc.findall(f".//{KML}Placemark")
    names = [p.findtext(f"{KML}name") for p in placemarks]
    assert "home" in names and "1 NAV_TAKEOFF" in names
    points = doc.findall(f".//{KML}Point")
    assert len(points) == 1 + sum(1 for i in plan.items if i.is_global)
    assert all(p.findtext(f"{KML}altitudeMode") == "relativeToGround" for p in points)
    obstacles = [p for p in placemarks if (p.findtext(f"{KML}name") or "").startswith("obstacle")]
    assert len(obstacles) == 2
    poly = obstacles[0].find(f"{KML}Polygon")
    assert poly is not None and poly.findtext(f"{KML}extrude") == "1"
    ring = (poly.findtext(f".//{KML}coordinates") or "").split()
    assert ring[0] == ring[-1] and all(t.endswith(",90.000") for t in ring)
    fences = [p for p in placemarks if (p.findtext(f"{KML}name") or "").startswith("fence")]
    assert len(fences) == len(plan.fence.polygons) + len(plan.fence.circles)
    style_ids = {s.get("id") for s in doc.findall(f"{KML}Style")}
    assert {(p.findtext(f"{KML}styleUrl") or "")[1:] for p in placemarks} <= style_ids


def test_kml_also_parses_with_lxml_and_escapes_names() -> None:
    lxml_etree = pytest.importorskip("lxml.etree")
    plan = mission()
    text = kml_dumps(plan, ExportExtras(name='R&D <north> "hop"'))
    root = lxml_etree.fromstring(text.encode("utf-8"))
    assert root.findtext(f"{KML}Document/{KML}name") == 'R&D <north> "hop"'


# ---------------------------------------------------------------------------------------------
# CLI: plan -o x.geojson / x.kml, convert


SCENARIO = """\
name: export-tiny
origin: {lat: 47.397742, lon: 8.545594, alt: 488.0}
bounds: {x: [0, 500], y: [-150, 150], z: [0, 100]}
start: [0, 0, 25]
goal: [500, 0, 30]
obstacles:
  - {type: box, center: [250, 0], size: [60, 40], height: 90}
safety_margin: 8
planner: {population: 16, iterations: 30, seed: 2}
mission: {autopilot: px4, spacing: 50, end: rtl}
"""


@pytest.mark.parametrize("suffix", [".geojson", ".kml"])
def test_plan_writes_an_export_with_obstacles_and_planned_path(suffix: str, tmp_path: Path) -> None:
    scenario = tmp_path / "s.yaml"
    scenario.write_text(SCENARIO)
    out = tmp_path / f"route{suffix}"
    result = CliRunner().invoke(main, ["plan", str(scenario), "-o", str(out), "-q"])
    assert result.exit_code == 0, result.output
    text = out.read_text()
    if suffix == ".geojson":
        doc = strict_json(text)
        assert rfc7946_errors(doc) == []
        assert len(by_kind(doc, "obstacle")) == 1 and len(by_kind(doc, "planned_path")) == 1
        assert by_kind(doc, "route")[0]["properties"]["algorithm"] == "spsa"
    else:
        root = ET.fromstring(text.encode("utf-8"))
        assert len(root.findall(f".//{KML}LineString")) == 2


def test_convert_between_all_formats(tmp_path: Path) -> None:
    plan = mission(Autopilot.PX4, fence=True)
    src = tmp_path / "m.plan"
    save_mission(plan, src)
    scenario = tmp_path / "s.yaml"
    scenario.write_text(SCENARIO)
    runner = CliRunner()

    result = runner.invoke(main, ["convert", str(src), str(tmp_path / "m.geojson")])
    assert result.exit_code == 0, result.output
    doc = strict_json((tmp_path / "m.geojson").read_text())
    assert rfc7946_errors(doc) == [] and not by_kind(doc, "obstacle") and by_kind(doc, "fence")

    args = ["convert", str(src), str(tmp_path / "m.kml"), "--scenario", str(scenario)]
    result = runner.invoke(main, args)
    assert result.exit_code == 0, result.output
    root = ET.fromstring((tmp_path / "m.kml").read_bytes())
    assert root.findtext(f"{KML}Document/{KML}name") == "export-tiny"

    result = runner.invoke(main, ["convert", str(src), str(tmp_path / "m.waypoints")])
    assert result.exit_code == 0, result.output
    assert "holds no geofence" in result.output
    back = load_mission(tmp_path / "m.waypoints", Autopilot.PX4)
    assert len(back.items) == len(plan.items)

    result = runner.invoke(
        main, ["convert", str(tmp_path / "m.waypoints"), str(tmp_path / "b.plan")]
    )
    assert result.exit_code == 0, result.output
    assert load_mission(tmp_path / "b.plan").autopilot == Autopilot.ARDUPILOT


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["m.plan", "m.svg"], "unknown mission file type"),
        (["m.geojson", "m.plan"], "can be written but not read"),
        (["missing.plan", "m.kml"], "cannot read"),
        (["m.plan", "m.waypoints", "--scenario", "s.yaml"], "--scenario only adds obstacles"),
    ],
)
def test_convert_bad_input_exits_2(args: list[str], message: str, tmp_path: Path) -> None:
    save_mission(mission(), tmp_path / "m.plan")
    save_mission(mission(), tmp_path / "m.geojson")
    (tmp_path / "s.yaml").write_text(SCENARIO)
    result = CliRunner().invoke(
        main, ["convert", *[str(tmp_path / a) if "." in a else a for a in args]]
    )
    assert result.exit_code == 2, result.output
    assert message in result.output
