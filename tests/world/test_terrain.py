"""Planning over terrain (issue 10 item 2): a DEM GeoTIFF in a projected CRS with a known
slope (and a known hill) is written here; scenarios on it must keep the margin from the
ground on the flown straight legs, checked independently of the product's DEM code (the
known surface is evaluated analytically at the file's lat/lon through a pyproj UTM transform).
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

rasterio = pytest.importorskip("rasterio")

from click.testing import CliRunner  # noqa: E402
from helpers.terrain_helpers import independent_ground_check  # noqa: E402
from pyproj import Transformer  # noqa: E402
from rasterio.transform import Affine  # noqa: E402

from uavplan.cli import main  # noqa: E402
from uavplan.errors import ScenarioError  # noqa: E402
from uavplan.geo import EnuFrame  # noqa: E402
from uavplan.mission.builder import build_mission, mission_polyline_enu  # noqa: E402
from uavplan.mission.io import load_mission  # noqa: E402
from uavplan.mission.items import Autopilot, MavFrame  # noqa: E402
from uavplan.obstacles import Bounds  # noqa: E402
from uavplan.planning import build_world  # noqa: E402
from uavplan.route import densify  # noqa: E402
from uavplan.scenario import load_scenario  # noqa: E402
from uavplan.world import GROUND  # noqa: E402

LAT0, LON0 = 47.0, 9.2
UTM = "EPSG:32632"
TO_UTM = Transformer.from_crs("EPSG:4326", UTM, always_xy=True)
E0, N0 = (float(v) for v in TO_UTM.transform(LON0, LAT0))
CELL_M = 25.0
WEST, NORTH = round(E0) - 1500.0, round(N0) + 1500.0
ROWS = COLS = 120


def slope(e: np.ndarray, n: np.ndarray) -> np.ndarray:
    """The known ground: 500 m at (E0, N0), rising 12 % to the east and 4 % to the south."""
    return 500.0 + 0.12 * (e - E0) - 0.04 * (n - N0)


def hill(e: np.ndarray, n: np.ndarray) -> np.ndarray:
    """The slope with a 70 m hill on the straight line between the test's start and goal."""
    return slope(e, n) + 70.0 * np.exp(-((e - E0 - 100.0) ** 2 + (n - N0) ** 2) / (2 * 160.0**2))


def write_dem(path: Path, z: np.ndarray) -> Path:
    profile = {
        "driver": "GTiff",
        "height": z.shape[0],
        "width": z.shape[1],
        "count": 1,
        "dtype": "float64",
        "crs": UTM,
        # what rasterio.transform.from_origin returns, without its `*` (affine 3.0 deprecates it)
        "transform": Affine(CELL_M, 0.0, WEST, 0.0, -CELL_M, NORTH),
    }
    with rasterio.open(path, "w", **profile) as dst:
        dst.write(z.astype(np.float64), 1)
    return path


def posts() -> tuple[np.ndarray, np.ndarray]:
    cols, rows = np.meshgrid(np.arange(COLS) + 0.5, np.arange(ROWS) + 0.5)
    return WEST + cols * CELL_M, NORTH - rows * CELL_M


@pytest.fixture
def slope_dem(tmp_path: Path) -> Path:
    e, n = posts()
    return write_dem(tmp_path / "slope.tif", slope(e, n))


@pytest.fixture
def hill_dem(tmp_path: Path) -> Path:
    e, n = posts()
    return write_dem(tmp_path / "hill.tif", hill(e, n))


def scenario_file(tmp_path: Path, dem: str, body: str) -> Path:
    path = tmp_path / "scn.yaml"
    path.write_text(
        f"name: over-the-slope\norigin: {{lat: {LAT0}, lon: {LON0}}}\nterrain: {dem}\n" + body,
        encoding="utf-8",
    )
    return path


SLOPE_BODY = """\
bounds: {x: [-800, 800], y: [-800, 800], z: [0, 150]}
start: [-600, -500, 30]
goal: [600, 500, 30]
safety_margin: 12
obstacles:
  - {type: box, center: [0, 0], size: [60, 60], height: 40}
  - {type: cylinder, center: [-350, -250], radius: 10, height: 60}
vehicle: {takeoff_altitude: 30}
planner: {seed: 3, iterations: 60, grid: {dx: 40, dy: 20, dz: 5}}
mission: {spacing: 50, end: land}
"""


def _lists(*arrays: np.ndarray) -> list[list[float]]:
    """Coordinates for pyproj as lists: pyproj < 3.7 turns a one-element array into a float,
    which NumPy 1.25+ deprecates (a warning per call with the lowest declared pyproj)."""
    return [np.atleast_1d(np.asarray(a, dtype=float)).tolist() for a in arrays]


def ground_amsl(lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
    """The known surface at geodetic positions: independent of uavplan's DEM code."""
    e, n = TO_UTM.transform(*_lists(lon, lat))
    return slope(np.asarray(e), np.asarray(n))


def hill_amsl(lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
    """The hill DEM's surface, bilinear between its posts, by scipy in the DEM's own CRS:
    independent of uavplan's DEM code."""
    from scipy.interpolate import RegularGridInterpolator

    e, n = posts()
    interp = RegularGridInterpolator((n[::-1, 0], e[0]), hill(e, n)[::-1], method="linear")
    ee, nn = TO_UTM.transform(*_lists(lon, lat))
    return np.asarray(interp(np.column_stack([nn, ee])))


def test_heights_are_above_the_ground_beneath(slope_dem: Path, tmp_path: Path) -> None:
    scn = load_scenario(scenario_file(tmp_path, slope_dem.name, SLOPE_BODY))
    # the scenario keeps the file's values: heights above the ground, the file's origin
    assert scn.start_m == (-600.0, -500.0, 30.0) and scn.obstacles[0].height_m == 40.0
    assert scn.origin.alt_m == 0.0 and scn.bounds.z_m == (0.0, 150.0)
    # where the planner flies it: on the ground, z above a datum below the lowest ground
    site = scn.site
    assert site.ground is not None
    datum = site.origin.alt_m
    frame = EnuFrame.at(site.origin)
    for point, above in ((site.start_m, 30.0), (site.goal_m, 30.0)):
        lat, lon, _ = frame.to_geodetic(np.array([[point[0], point[1], 0.0]]))
        assert point[2] + datum == pytest.approx(ground_amsl(lat, lon)[0] + above, abs=0.01)
    # the box stands on the ground at its centre: its top is 40 m above that ground
    lat, lon, _ = frame.to_geodetic(np.array([[0.0, 0.0, 0.0]]))
    assert site.obstacles[0].height_m + datum == pytest.approx(
        ground_amsl(lat, lon)[0] + 40, abs=0.01
    )
    # bounds: from below the lowest ground to the highest ground + the ceiling
    assert site.bounds.z_m[0] == 0.0
    assert site.ground.ceiling_agl_m == 150.0


def test_a_copy_with_another_margin_gets_its_own_ground(slope_dem: Path, tmp_path: Path) -> None:
    """The ground's solids are built for the margin when the site is made: a scenario copied
    with another margin (or floor) cannot keep the old solids."""
    scn = load_scenario(scenario_file(tmp_path, slope_dem.name, SLOPE_BODY))
    wider = replace(scn, safety_margin_m=20.0)
    g12, g20 = scn.site.ground, wider.site.ground
    assert g12 is not None and g20 is not None and g12 is not g20
    assert g20.roof_m - g12.roof_m == pytest.approx(8.0)  # the ceiling's solid: margin above
    raised = replace(scn, bounds=Bounds(scn.bounds.x_m, scn.bounds.y_m, (14.0, 150.0)))
    g14 = raised.site.ground
    assert g14 is not None
    assert g14.lift_m - g12.lift_m == pytest.approx(14.0 - 12.0)  # the floor, above the margin
    assert build_world(wider).margin_m == 20.0


def test_the_exact_ground_is_the_dem_surface(tmp_path: Path) -> None:
    """Random rough terrain: every point of the DEM's bilinear surface (scipy, not the
    product's DEM code) is in the ground (clearance 0), and above it the world's distance to
    the ground is the distance to that surface (brute force over it, sampled every 0.5 m):
    never more, and less by at most the field's stated twist gap."""
    from scipy.interpolate import RegularGridInterpolator

    rng = np.random.default_rng(5)
    e, n = posts()
    z = slope(e, n) + rng.uniform(-15, 15, e.shape)
    dem = write_dem(tmp_path / "rough.tif", z)
    scn = load_scenario(
        scenario_file(
            tmp_path,
            dem.name,
            "bounds: {x: [-500, 500], y: [-500, 500], z: [0, 150]}\n"
            "start: [-400, -400, 60]\ngoal: [400, 400, 60]\nsafety_margin: 5\n",
        )
    )
    world = build_world(scn)
    ground = scn.site.ground
    assert ground is not None
    frame = EnuFrame.at(scn.site.origin)
    datum = scn.site.origin.alt_m
    interp = RegularGridInterpolator((n[::-1, 0], e[0]), z[::-1], method="linear")

    def bilinear_z(xy: np.ndarray) -> np.ndarray:
        lat, lon, _ = frame.to_geodetic(np.column_stack([xy, np.zeros(len(xy))]))
        ee, nn = TO_UTM.transform(*_lists(lon, lat))
        return np.asarray(interp(np.column_stack([nn, ee]))) - datum

    xy = rng.uniform(-480, 480, (400, 2))
    surface = bilinear_z(xy)
    dist, owner = world.points_clearance(np.column_stack([xy, surface]))
    assert np.all(dist == 0.0) and np.all(owner == GROUND)
    # 1.5 to 12 m above the surface: the distance to it, by brute force around the point
    gap = ground.field.twist_gap_m + ground.field.warp_m
    gx, gy = np.meshgrid(np.arange(-14.0, 14.01, 0.5), np.arange(-14.0, 14.01, 0.5))
    disc = np.column_stack([gx.ravel(), gy.ravel()])
    for p, h in zip(xy[:60], rng.uniform(1.5, 12.0, 60), strict=True):
        point = np.array([p[0], p[1], bilinear_z(p[None, :])[0] + h])
        around = disc + p
        brute = np.min(np.linalg.norm(
            np.column_stack([around, bilinear_z(around)]) - point, axis=1
        ))  # fmt: skip
        d, _ = world.points_clearance(point[None, :])
        assert d[0] <= brute + 0.05  # never farther than the surface (0.5 m sampling)
        assert d[0] >= brute - gap - 0.05


def test_route_point_within_the_margin_of_the_terrain_is_a_clear_error(
    slope_dem: Path, tmp_path: Path
) -> None:
    body = SLOPE_BODY.replace("start: [-600, -500, 30]", "start: [-600, -500, 5]")
    with pytest.raises(ScenarioError, match=r"start: 5.0 m above the ground there is .* from the"):
        load_scenario(scenario_file(tmp_path, slope_dem.name, body))


@pytest.mark.parametrize("altitude", ["relative", "amsl", "terrain"])
@pytest.mark.slow
def test_mission_over_a_hill_keeps_the_margin(
    hill_dem: Path, tmp_path: Path, altitude: str
) -> None:
    body = SLOPE_BODY.replace("end: land}", f"end: land, altitude: {altitude}}}")
    path = scenario_file(tmp_path, hill_dem.name, body)
    out = tmp_path / "m.plan"
    result = CliRunner().invoke(
        main, ["plan", str(path), "-o", str(out), "--report", str(tmp_path / "r.json"), "-q"]
    )
    assert result.exit_code == 0, result.output
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["collision_free"] and report["min_clearance_m"] >= 12.0 - 1e-6

    # read the file back: home on the known ground, items in the asked frame
    plan = load_mission(out)
    expected_frame = {
        "relative": MavFrame.GLOBAL_RELATIVE_ALT,
        "amsl": MavFrame.GLOBAL,
        "terrain": MavFrame.GLOBAL_TERRAIN_ALT,
    }[altitude]
    assert {int(i.frame) for i in plan.items if i.is_global} == {int(expected_frame)}
    assert plan.home is not None
    home_ground = hill_amsl(np.array([plan.home.lat_deg]), np.array([plan.home.lon_deg]))[0]
    assert plan.home.alt_m == pytest.approx(home_ground, abs=0.01)

    # independent check: the straight legs the vehicle flies, from the file's items, against
    # the DEM's surface computed by scipy (not the product's DEM code), every metre
    scn = load_scenario(path)
    frame = EnuFrame.at(scn.site.origin)
    datum = scn.site.origin.alt_m

    def known_ground_z(xy: np.ndarray) -> np.ndarray:
        lat, lon, _ = frame.to_geodetic(np.column_stack([xy, np.zeros(len(xy))]))
        return hill_amsl(lat, lon) - datum

    flown = mission_polyline_enu(plan, frame, known_ground_z)
    # the legs as flown (terrain-frame ones over the ground), rebuilt by the tests' own code;
    # the climb from home and the landing descent touch the ground by design
    low, _ = independent_ground_check(out, hill_dem, frame)
    assert low >= 12.0 - 0.05, f"{low:.2f} m above the ground"
    # the hill is in the way: the route had to climb over or go round it
    straight = np.linspace(flown[2], flown[-2], 200)
    assert np.min(straight[:, 2] - known_ground_z(straight[:, :2])) < 0.0
    assert flown[0, 2] == pytest.approx(known_ground_z(flown[:1, :2])[0], abs=0.01)
    assert flown[-1, 2] == pytest.approx(known_ground_z(flown[-1:, :2])[0], abs=0.01)


def test_altitude_modes_describe_the_same_flight(slope_dem: Path, tmp_path: Path) -> None:
    """The three altitude frames of one route read back to the same ENU polyline (< 1 cm)."""
    scn = load_scenario(scenario_file(tmp_path, slope_dem.name, SLOPE_BODY))
    assert scn.site.ground is not None
    frame = EnuFrame.at(scn.site.origin)
    waypoints = np.array([[-600, -500, 0.0], [0, 300, 0.0], [600, 500, 0.0]])
    under = scn.site.ground.z_at(waypoints)
    waypoints[:, 2] = under + np.array([30.0, 80.0, 45.0])
    lines = []
    for altitude in ("relative", "amsl", "terrain"):
        plan = build_mission(
            waypoints,
            frame,
            autopilot=Autopilot.ARDUPILOT,
            end="land",
            takeoff_altitude_m=20.0,
            ground_z_m=under,
            altitude=altitude,
        )
        lines.append(mission_polyline_enu(plan, frame, scn.site.ground.z_at))
    for line in lines[1:]:
        assert line.shape == lines[0].shape
        assert np.max(np.abs(line - lines[0])) < 0.01
    # take-off from the ground at the start, 20 m above it, then the waypoints
    assert lines[0][0, 2] == pytest.approx(under[0])
    assert lines[0][1, 2] == pytest.approx(under[0] + 20.0)


def test_terrain_altitude_with_px4_warns(slope_dem: Path, tmp_path: Path) -> None:
    body = SLOPE_BODY.replace("end: land}", "end: land, altitude: terrain, autopilot: px4}")
    path = scenario_file(tmp_path, slope_dem.name, body)
    result = CliRunner().invoke(main, ["plan", str(path), "-o", str(tmp_path / "m.plan")])
    assert result.exit_code == 0, result.output
    assert "warning: mission.altitude terrain" in result.output
    frame = EnuFrame.at(load_scenario(path).site.origin)
    low, _ = independent_ground_check(tmp_path / "m.plan", slope_dem, frame)
    assert low >= 12.0 - 0.05


def valley(e: np.ndarray, n: np.ndarray) -> np.ndarray:
    """The slope with a 120 m deep valley across the line between start and goal."""
    return slope(e, n) - 120.0 * np.exp(-((e - E0) ** 2) / (2 * 120.0**2))


def test_route_stays_under_the_ceiling_above_the_ground(tmp_path: Path) -> None:
    """bounds.z max is a height above the ground: crossing a valley the route must follow it
    down instead of flying straight across 150 m above its floor (independent check with
    scipy's bilinear surface of the posts)."""
    from scipy.interpolate import RegularGridInterpolator

    e, n = posts()
    dem = write_dem(tmp_path / "valley.tif", valley(e, n))
    body = (
        "bounds: {x: [-700, 700], y: [-300, 300], z: [0, 70]}\n"
        "start: [-600, 0, 30]\ngoal: [600, 0, 30]\nsafety_margin: 10\n"
        "planner: {seed: 2, iterations: 80, grid: {dx: 40, dy: 20, dz: 5}}\n"
        # the route across the valley, ending at the goal (an RTL there would become a
        # planned return home, issue 37, and the flown line would end on the ground)
        "mission: {spacing: 40, end: none}\n"
    )
    path = scenario_file(tmp_path, dem.name, body)
    out = tmp_path / "v.plan"
    result = CliRunner().invoke(main, ["plan", str(path), "-o", str(out), "-q"])
    assert result.exit_code == 0, result.output
    scn = load_scenario(path)
    frame = EnuFrame.at(scn.site.origin)
    datum = scn.site.origin.alt_m
    interp = RegularGridInterpolator((n[::-1, 0], e[0]), valley(e, n)[::-1], method="linear")

    def ground_z(xy: np.ndarray) -> np.ndarray:
        lat, lon, _ = frame.to_geodetic(np.column_stack([xy, np.zeros(len(xy))]))
        ee, nn = TO_UTM.transform(*_lists(lon, lat))
        return np.asarray(interp(np.column_stack([nn, ee]))) - datum

    flown = mission_polyline_enu(load_mission(out), frame, ground_z)
    samples = densify(flown[2:], 1.0)
    agl = samples[:, 2] - ground_z(samples[:, :2])
    assert agl.min() >= 10.0 - 0.05
    assert agl.max() <= 70.0 + 0.05, f"{agl.max():.1f} m above the ground"
    # flying straight across would have been far above the valley floor
    straight = np.linspace(flown[2], flown[-1], 200)
    assert np.max(straight[:, 2] - ground_z(straight[:, :2])) > 100.0


@pytest.mark.slow
def test_exports_over_terrain_give_amsl_altitudes(hill_dem: Path, tmp_path: Path) -> None:
    """GeoJSON and KML of a route over terrain carry AMSL altitudes (KML ``absolute``): the
    route's altitudes stand at least the margin above the DEM surface under them."""
    path = scenario_file(tmp_path, hill_dem.name, SLOPE_BODY)
    gj, kml = tmp_path / "m.geojson", tmp_path / "m.kml"
    for out in (gj, kml):
        result = CliRunner().invoke(main, ["plan", str(path), "-o", str(out), "-q"])
        assert result.exit_code == 0, result.output
    doc = json.loads(gj.read_text())
    route = next(f for f in doc["features"] if f["properties"]["kind"] == "route")
    assert "above mean sea level" in route["properties"]["altitude_reference"]
    lon, lat, alt = np.array(route["geometry"]["coordinates"]).T
    agl = alt - hill_amsl(lat, lon)
    assert agl[0] == pytest.approx(0.0, abs=0.01)  # home, on the ground
    assert agl[2:-1].min() >= 12.0 - 0.5  # vertices of the flown legs (margin kept)
    home = next(f for f in doc["features"] if f["properties"]["kind"] == "home")
    assert home["geometry"]["coordinates"][2] == pytest.approx(
        hill_amsl(np.array([lat[0]]), np.array([lon[0]]))[0], abs=0.01
    )
    text = kml.read_text()
    assert "<altitudeMode>absolute</altitudeMode>" in text
    assert "relativeToGround" not in text.split("<name>Waypoints</name>")[0]
