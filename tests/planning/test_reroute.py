"""A QGroundControl plan as input: ``uavplan plan user.plan -o safe.plan`` reroutes the legs
between the user's positions around the plan's exclusion zones and keeps every item.

The plans are written here as .plan JSON from local metre offsets (a simple spherical
conversion); the clearance is checked independently: pyproj's azimuthal equidistant
projection at home and shapely distances to the zones, not the project's world or frames.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import shapely
from click.testing import CliRunner
from pyproj import Proj

from uavplan.cli import main
from uavplan.mission.items import MavCmd
from uavplan.mission.qgc_plan import plan_from_json

ROOT = Path(__file__).resolve().parents[2]
BUNDLED = ROOT / "missions" / "qgc-inspection.plan"

HOME = (47.3977, 8.5456, 488.0)  # lat, lon, AMSL
MARGIN_M = 10.0  # the default safety margin
FAST = ["--iterations", "150", "--seed", "3", "--quiet"]

# commands the test plan uses
NAV_WAYPOINT, NAV_LOITER_TIME, NAV_TAKEOFF, NAV_LAND, RTL = 16, 19, 22, 21, 20
DO_CHANGE_SPEED, DO_SET_ROI_LOCATION, DO_MOUNT_CONTROL = 178, 195, 205
DO_SET_CAM_TRIGG_DIST, DO_DIGICAM_CONTROL, DO_JUMP = 206, 203, 177
NAV_COMMANDS = {NAV_WAYPOINT, NAV_LOITER_TIME, NAV_TAKEOFF, NAV_LAND}


def latlon(east_m: float, north_m: float) -> list[float]:
    lat0, lon0, _ = HOME
    r = 6371008.8
    return [
        lat0 + math.degrees(north_m / r),
        lon0 + math.degrees(east_m / (r * math.cos(math.radians(lat0)))),
    ]


def item(
    command: int,
    params: list[float | None],
    *,
    at: tuple[float, float, float] | None = None,
    frame: int = 3,
) -> dict[str, Any]:
    pos = [*latlon(at[0], at[1]), at[2]] if at is not None else [0.0, 0.0, 0.0]
    out: dict[str, Any] = {
        "autoContinue": True,
        "command": command,
        "doJumpId": 0,
        "frame": frame if at is not None else 2,
        "params": [*params, *pos],
        "type": "SimpleItem",
    }
    if at is not None:
        out.update(AltitudeMode=1, Altitude=at[2], AMSLAltAboveTerrain=None)
    return out


def square(cx: float, cy: float, half: float) -> list[list[float]]:
    return [latlon(cx + dx, cy + dy) for dx, dy in ((-half, -half), (half, -half),
                                                     (half, half), (-half, half))]  # fmt: skip


def user_items(end: str = "land") -> list[dict[str, Any]]:
    items = [
        item(NAV_TAKEOFF, [0, 0, 0, None], at=(0.0, 0.0, 30.0)),
        item(DO_CHANGE_SPEED, [1, 6.0, -1, 0]),
        item(NAV_WAYPOINT, [0, 0, 0, None], at=(0.0, 60.0, 30.0)),
        item(DO_MOUNT_CONTROL, [-45.0, 0, 0, 0]),
        item(DO_SET_CAM_TRIGG_DIST, [15.0, 0, 1, 0]),
        item(NAV_WAYPOINT, [5.0, 0, 0, None], at=(0.0, 300.0, 40.0)),  # hold 5 s
        item(DO_SET_ROI_LOCATION, [0, 0, 0, 0], at=(20.0, 320.0, 0.0)),
        item(DO_DIGICAM_CONTROL, [0, 0, 0, 0]),
        item(NAV_LOITER_TIME, [12.0, 0, 0, None], at=(250.0, 300.0, 40.0)),
        item(DO_SET_CAM_TRIGG_DIST, [0.0, 0, 0, 0]),
        item(DO_CHANGE_SPEED, [1, 10.0, -1, 0]),
    ]
    if end == "land":
        items.append(item(NAV_LAND, [0, 0, 0, None], at=(250.0, 20.0, 0.0)))
    else:
        items.append(item(NAV_WAYPOINT, [0, 0, 0, None], at=(250.0, 20.0, 35.0)))
        items.append(item(RTL, [0, 0, 0, 0]))
    for k, it in enumerate(items):
        it["doJumpId"] = k + 1
    return items


def plan_doc(
    items: list[dict[str, Any]],
    *,
    polygons: list[dict[str, Any]] | None = None,
    circles: list[dict[str, Any]] | None = None,
) -> dict[str, Any]:
    if polygons is None:  # a block across the first long leg
        polygons = [{"inclusion": False, "polygon": square(0.0, 180.0, 30.0), "version": 1}]
    if circles is None:  # a circle across the leg from the loiter to the landing
        circles = [
            {"circle": {"center": latlon(250.0, 160.0), "radius": 35.0}, "inclusion": False,
             "version": 1}
        ]  # fmt: skip
    return {
        "fileType": "Plan",
        "geoFence": {
            "circles": circles,
            "polygons": polygons,
            "breachReturn": [*latlon(-20.0, -20.0), 30.0],
            "version": 2,
        },
        "groundStation": "QGroundControl",
        "mission": {
            "cruiseSpeed": 8,
            "firmwareType": 12,
            "globalPlanAltitudeMode": 1,
            "hoverSpeed": 5,
            "items": items,
            "plannedHomePosition": list(HOME),
            "vehicleType": 2,
            "version": 2,
        },
        "rallyPoints": {"points": [[*latlon(-30.0, 10.0), 25.0]], "version": 2},
        "version": 1,
    }


def write(tmp_path: Path, doc: dict[str, Any], name: str = "user.plan") -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(doc, indent=2))
    return path


def reroute(src: Path, out: Path, *extra: str) -> Any:
    return CliRunner().invoke(main, ["plan", str(src), "-o", str(out), *FAST, *extra])


# ---------------------------------------------------------------------------------------------
# independent check


class Local:
    """Azimuthal equidistant metres around home (pyproj), independent of uavplan.geo."""

    def __init__(self, lat: float, lon: float) -> None:
        self.proj = Proj(proj="aeqd", lat_0=lat, lon_0=lon, datum="WGS84")

    def xy(self, lat: float, lon: float) -> tuple[float, float]:
        x, y = self.proj(lon, lat)
        return float(x), float(y)


def flown_line(doc: dict[str, Any], local: Local) -> list[tuple[float, float, float]]:
    """Home on the ground, the take-off climb, then every NAV position (land: fly over at
    the current height, then down); stop at RTL."""
    home = doc["mission"]["plannedHomePosition"]
    hx, hy = local.xy(home[0], home[1])
    line = [(hx, hy, 0.0)]
    for it in doc["mission"]["items"]:
        cmd, (lat, lon, alt) = it["command"], it["params"][4:]
        if cmd == RTL:
            break
        if cmd not in NAV_COMMANDS:
            continue
        if cmd == NAV_TAKEOFF:
            line.append((hx, hy, alt))
            continue
        x, y = local.xy(lat, lon)
        if cmd == NAV_LAND:
            line.append((x, y, line[-1][2]))
            line.append((x, y, 0.0))
            break
        line.append((x, y, alt))
    return line


def zones(doc: dict[str, Any], local: Local) -> list[Any]:
    fence = doc["geoFence"]
    out = [
        shapely.Polygon([local.xy(*v) for v in p["polygon"]])
        for p in fence["polygons"]
        if not p["inclusion"]
    ]
    for c in fence["circles"]:
        if not c["inclusion"]:
            out.append(shapely.Point(local.xy(*c["circle"]["center"])).buffer(
                c["circle"]["radius"], quad_segs=256))  # fmt: skip
    return out


def min_zone_distance(doc: dict[str, Any]) -> float:
    """Horizontal distance from the flown line to the nearest exclusion zone (they are
    infinitely tall), densified so the distance is of the whole segments."""
    home = doc["mission"]["plannedHomePosition"]
    local = Local(home[0], home[1])
    line = shapely.LineString([(x, y) for x, y, _ in flown_line(doc, local)])
    return min(line.distance(z) for z in zones(doc, local))


def is_nav(it: dict[str, Any]) -> bool:
    return it["command"] in NAV_COMMANDS


def key(it: dict[str, Any]) -> tuple[Any, ...]:
    return (it["command"], it["frame"], *it["params"])


# ---------------------------------------------------------------------------------------------


def test_the_straight_plan_crosses_its_zones(tmp_path: Path) -> None:
    """The test plan is a real test: flown as drawn, it crosses both exclusion zones."""
    doc = plan_doc(user_items())
    assert min_zone_distance(doc) == 0.0


@pytest.mark.parametrize("end", ["land", "rtl"])
def test_reroute_keeps_every_item_and_the_margin(tmp_path: Path, end: str) -> None:
    doc = plan_doc(user_items(end))
    src, out = write(tmp_path, doc), tmp_path / "safe.plan"
    result = reroute(src, out)
    assert result.exit_code == 0, result.output
    new = json.loads(out.read_text())
    old_items, new_items = doc["mission"]["items"], new["mission"]["items"]
    # every item the user made, in order, unchanged; only NAV_WAYPOINTs were added
    kept = [it for it in new_items if key(it) in {key(o) for o in old_items}]
    assert [key(it) for it in kept] == [key(it) for it in old_items]
    added = [it for it in new_items if key(it) not in {key(o) for o in old_items}]
    assert added and all(it["command"] == NAV_WAYPOINT for it in added)

    # non-navigation items sit right after the same navigation item as before
    def anchors(items: list[dict[str, Any]]) -> list[tuple[Any, ...]]:
        out, last = [], None
        for it in items:
            if is_nav(it):
                last = key(it)
            else:
                out.append((last, key(it)))
        return out

    assert anchors([it for it in new_items if it in kept or not is_nav(it)]) == anchors(old_items)
    assert anchors(new_items) == anchors(old_items)
    # the fence, the rally points, home, flavour and speeds are unchanged
    assert new["geoFence"] == doc["geoFence"]
    assert new["rallyPoints"] == doc["rallyPoints"]
    assert new["mission"]["plannedHomePosition"] == doc["mission"]["plannedHomePosition"]
    assert new["mission"]["firmwareType"] == 12
    assert new["mission"]["cruiseSpeed"] == 8
    # the flown line keeps the margin from every exclusion zone (independent check)
    assert min_zone_distance(new) >= MARGIN_M - 0.05
    # the output loads back
    plan = plan_from_json(out.read_text())
    assert plan.fence.polygons and plan.fence.circles and len(plan.rally) == 1


def test_waypoint_inside_an_exclusion_zone_is_exit_2(tmp_path: Path) -> None:
    items = user_items()
    items[2] = item(NAV_WAYPOINT, [0, 0, 0, None], at=(5.0, 180.0, 30.0))
    result = reroute(write(tmp_path, plan_doc(items)), tmp_path / "o.plan")
    assert result.exit_code == 2, result.output
    assert "mission item 3 (NAV_WAYPOINT)" in result.output
    assert "inside exclusion polygon 1 of the fence" in result.output
    assert "Traceback" not in result.output


def test_waypoint_outside_the_inclusion_fence_is_exit_2(tmp_path: Path) -> None:
    polygons = [
        {"inclusion": True, "polygon": square(100.0, 150.0, 200.0), "version": 1},
    ]
    items = user_items()
    items[8] = item(NAV_LOITER_TIME, [12.0, 0, 0, None], at=(400.0, 300.0, 40.0))
    result = reroute(write(tmp_path, plan_doc(items, polygons=polygons)), tmp_path / "o.plan")
    assert result.exit_code == 2, result.output
    assert "mission item 9 (NAV_LOITER_TIME)" in result.output
    assert "outside the inclusion fence" in result.output


def test_inclusion_fence_bounds_the_route(tmp_path: Path) -> None:
    """An L-shaped inclusion fence whose notch sits on the straight leg: the route goes
    round the notch and stays the margin inside the fence."""
    l_shape = [latlon(x, y) for x, y in ((-60, -40), (120, -40), (120, 220), (320, 220),
                                         (320, 380), (-60, 380))]  # fmt: skip
    polygons = [{"inclusion": True, "polygon": l_shape, "version": 1}]
    items = [
        item(NAV_TAKEOFF, [0, 0, 0, None], at=(0.0, 0.0, 30.0)),
        item(NAV_WAYPOINT, [0, 0, 0, None], at=(0.0, 40.0, 30.0)),
        item(DO_DIGICAM_CONTROL, [0, 0, 0, 0]),
        item(NAV_WAYPOINT, [0, 0, 0, None], at=(280.0, 300.0, 30.0)),
        item(RTL, [0, 0, 0, 0]),
    ]
    doc = plan_doc(items, polygons=polygons, circles=[])
    out = tmp_path / "o.plan"
    result = reroute(write(tmp_path, doc), out)
    assert result.exit_code == 0, result.output
    new = json.loads(out.read_text())
    local = Local(HOME[0], HOME[1])
    fence = shapely.Polygon([local.xy(*v) for v in l_shape])
    drawn = shapely.LineString([(x, y) for x, y, _ in flown_line(doc, local)])
    assert not fence.contains(drawn)  # as drawn, the route cuts across the notch
    line = shapely.LineString([(x, y) for x, y, _ in flown_line(new, local)])
    assert fence.contains(line)
    assert fence.exterior.distance(line) >= MARGIN_M - 0.05


def test_do_jump_is_refused_with_exit_2(tmp_path: Path) -> None:
    items = user_items()
    jump = item(DO_JUMP, [3, 2, 0, 0])
    items.insert(9, jump)
    for k, it in enumerate(items):
        it["doJumpId"] = k + 1
    result = reroute(write(tmp_path, plan_doc(items)), tmp_path / "o.plan")
    assert result.exit_code == 2, result.output
    assert "DO_JUMP is not supported" in result.output


def test_plan_without_positions_is_exit_2(tmp_path: Path) -> None:
    items = [item(DO_CHANGE_SPEED, [1, 6.0, -1, 0]), item(RTL, [0, 0, 0, 0])]
    result = reroute(write(tmp_path, plan_doc(items)), tmp_path / "o.plan")
    assert result.exit_code == 2, result.output
    assert "no route to reroute" in result.output


def test_enclosed_waypoint_is_exit_3(tmp_path: Path) -> None:
    """A waypoint clear of every zone but walled in by four of them: no route reaches it."""
    walls = [
        [latlon(x, y) for x, y in poly]
        for poly in (
            ((100, 100), (200, 100), (200, 110), (100, 110)),
            ((100, 190), (200, 190), (200, 200), (100, 200)),
            ((100, 110), (110, 110), (110, 190), (100, 190)),
            ((190, 110), (200, 110), (200, 190), (190, 190)),
        )
    ]
    polygons = [{"inclusion": False, "polygon": w, "version": 1} for w in walls]
    items = [
        item(NAV_TAKEOFF, [0, 0, 0, None], at=(0.0, 0.0, 30.0)),
        item(NAV_WAYPOINT, [0, 0, 0, None], at=(150.0, 250.0, 30.0)),  # round the walls
        item(NAV_WAYPOINT, [0, 0, 0, None], at=(150.0, 150.0, 30.0)),  # inside them
        item(RTL, [0, 0, 0, 0]),
    ]
    doc = plan_doc(items, polygons=polygons, circles=[])
    result = reroute(write(tmp_path, doc), tmp_path / "o.plan")
    assert result.exit_code == 3, result.output
    assert (
        "no collision-free route from mission item 2 (NAV_WAYPOINT) (start) to mission item 3 "
        "(NAV_WAYPOINT) (goal): the goal is enclosed"
    ) in result.output
    assert not (tmp_path / "o.plan").exists()


def test_amsl_items_are_heights_above_home(tmp_path: Path) -> None:
    items = user_items()
    amsl = item(NAV_WAYPOINT, [0, 0, 0, None], at=(0.0, 60.0, 30.0 + HOME[2]), frame=0)
    items[2] = amsl
    doc = plan_doc(items)
    out = tmp_path / "o.plan"
    result = reroute(write(tmp_path, doc), out)
    assert result.exit_code == 0, result.output
    new = json.loads(out.read_text())
    assert key(amsl) in [key(it) for it in new["mission"]["items"]]


@pytest.mark.slow
def test_bundled_inspection_plan_reroutes_clear_of_its_zones(tmp_path: Path) -> None:
    out = tmp_path / "safe.plan"
    result = CliRunner().invoke(
        main, ["plan", str(BUNDLED), "-o", str(out), "--iterations", "300", "--quiet"]
    )
    assert result.exit_code == 0, result.output
    doc, new = json.loads(BUNDLED.read_text()), json.loads(out.read_text())
    old_items = doc["mission"]["items"]
    non_nav = [key(it) for it in old_items if not is_nav(it)]
    assert non_nav and any(it["command"] in (DO_SET_CAM_TRIGG_DIST, DO_DIGICAM_CONTROL)
                           for it in old_items)  # fmt: skip
    assert [key(it) for it in new["mission"]["items"] if not is_nav(it)] == non_nav
    new_keys = [key(it) for it in new["mission"]["items"]]
    positions = iter(new_keys)
    assert all(k in positions for k in (key(it) for it in old_items))  # in order
    assert min_zone_distance(doc) < MARGIN_M  # the plan as drawn does not keep the margin
    assert min_zone_distance(new) >= MARGIN_M - 0.05
    assert new["geoFence"] == doc["geoFence"]
    assert new["rallyPoints"] == doc["rallyPoints"]


def test_report_and_scenario_obstacles(tmp_path: Path) -> None:
    """--scenario adds its obstacles (a tower on the first leg) and --report writes JSON."""
    scenario = tmp_path / "extra.yaml"
    scenario.write_text(
        f"""
name: extra
origin: {{lat: {HOME[0]}, lon: {HOME[1]}, alt: {HOME[2]}}}
bounds: {{x: [-200, 500], y: [-200, 600], z: [0, 120]}}
start: [0, 0, 30]
goal: [250, 20, 30]
safety_margin: 12
obstacles:
  - {{type: cylinder, center: [0, 110], radius: 15, height: 80}}
"""
    )
    report = tmp_path / "r.json"
    out = tmp_path / "o.plan"
    result = reroute(
        write(tmp_path, plan_doc(user_items())),
        out,
        "--scenario",
        str(scenario),
        "--report",
        str(report),
    )
    assert result.exit_code == 0, result.output
    rep = json.loads(report.read_text())
    assert rep["collision_free"] is True
    assert rep["safety_margin_m"] == 12
    assert rep["min_clearance_m"] >= 12 - 1e-6
    new = json.loads(out.read_text())
    local = Local(HOME[0], HOME[1])
    line = shapely.LineString([(x, y) for x, y, _ in flown_line(new, local)])
    tower = shapely.Point(local.xy(*latlon(0.0, 110.0))).buffer(15.0, quad_segs=256)
    assert line.distance(tower) >= 12 - 0.05


def test_other_outputs_and_flags_are_refused(tmp_path: Path) -> None:
    src = write(tmp_path, plan_doc(user_items()))
    result = reroute(src, tmp_path / "o.waypoints")
    assert result.exit_code == 2 and "name the output *.plan" in result.output
    result = reroute(src, tmp_path / "o.plan", "--fence")
    assert result.exit_code == 2 and "--fence does not apply" in result.output
    assert MavCmd.NAV_TAKEOFF == NAV_TAKEOFF
    assert np.isfinite(MARGIN_M)


def test_rtl_across_a_zone_gets_a_note_and_terrain_frames_are_relative() -> None:
    """The autopilot's return home is not planned: crossing a zone is said in a note. A
    terrain-frame waypoint is read as a height above home, with a note."""
    from uavplan.config import SearchParams
    from uavplan.mission.qgc_plan import plan_from_json
    from uavplan.reroute import reroute_plan
    from uavplan.scenario import PlannerConfig

    items = user_items("rtl")
    items[-2] = item(NAV_WAYPOINT, [0, 0, 0, None], at=(0.0, 330.0, 35.0), frame=10)
    plan = plan_from_json(json.dumps(plan_doc(items)))
    planner = PlannerConfig(search=SearchParams(iterations=150, seed=2))
    result = reroute_plan(plan, planner=planner)
    notes = " ".join(result.notes)
    assert "return to launch" in notes and "exclusion polygon 1 of the fence" in notes
    assert "terrain-relative altitudes" in notes
    assert result.min_clearance_m >= MARGIN_M - 1e-6
    assert result.plan.items[-1].command == RTL


def _no_home(doc: dict[str, Any]) -> None:
    doc["mission"]["plannedHomePosition"] = [0.0, 0.0, 0.0]


def _after_land(doc: dict[str, Any]) -> None:
    items = doc["mission"]["items"]
    items.append(item(NAV_WAYPOINT, [0, 0, 0, None], at=(10.0, 10.0, 30.0)))
    items[-1]["doJumpId"] = len(items)


def _on_the_ground(doc: dict[str, Any]) -> None:
    doc["mission"]["items"][2]["params"][6] = 0.0


def _takeoff_in_a_zone(doc: dict[str, Any]) -> None:
    doc["geoFence"]["circles"][0]["circle"]["center"] = latlon(5.0, 5.0)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (_no_home, "the plan has no planned home position"),
        (_after_land, "mission item 13 (NAV_WAYPOINT) comes after the mission's NAV_LAND"),
        (_on_the_ground, "mission item 3 (NAV_WAYPOINT) at 0 m is not above the ground"),
        (_takeoff_in_a_zone, "mission item 1 (NAV_TAKEOFF) at [0.0, 0.0, 30.0] m is inside "
                             "exclusion circle 1 of the fence"),
    ],
)  # fmt: skip
def test_plans_that_cannot_be_rerouted_are_exit_2(
    tmp_path: Path, change: Any, message: str
) -> None:
    doc = plan_doc(user_items())
    change(doc)
    result = reroute(write(tmp_path, doc), tmp_path / "o.plan")
    assert result.exit_code == 2, result.output
    assert message in result.output
    assert "Traceback" not in result.output and "internal error" not in result.output


def test_ardupilot_plan_keeps_its_flavour(tmp_path: Path) -> None:
    doc = plan_doc(user_items())
    doc["mission"]["firmwareType"] = 3
    out = tmp_path / "o.plan"
    result = reroute(write(tmp_path, doc), out)
    assert result.exit_code == 0, result.output
    new = json.loads(out.read_text())
    assert new["mission"]["firmwareType"] == 3
    assert min_zone_distance(new) >= MARGIN_M - 0.05


def test_scenario_option_needs_a_plan_input(tmp_path: Path) -> None:
    yaml_input = ROOT / "missions" / "paper-env1.yaml"
    result = reroute(yaml_input, tmp_path / "o.plan", "--scenario", str(yaml_input))
    assert result.exit_code == 2, result.output
    assert "--scenario goes with a .plan input" in result.output
    missing = reroute(tmp_path / "nothing.plan", tmp_path / "o.plan")
    assert missing.exit_code == 2 and "cannot read" in missing.output
