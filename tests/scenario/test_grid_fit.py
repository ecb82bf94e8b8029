"""Grids that fit the problem (issue 26, item 3): a scenario that sets no grid is planned on
the default grid scaled just enough for its flight volume, so long routes and large terrain
areas plan without flags; a grid the user sets is used as given and still checked."""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from uavplan.cli import main
from uavplan.config import GridSpec
from uavplan.errors import ScenarioError
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.mission.builder import mission_polyline_enu
from uavplan.mission.io import load_mission
from uavplan.obstacles import Bounds
from uavplan.scenario import Scenario, load_scenario, problem_size
from uavplan.scenario.limits import FIT_GRID_CELLS
from uavplan.scenario.size import (
    DEFAULT_GRID,
    FIT_FACTORS,
    MIN_BAND_LEVELS,
    fitted_grid,
    path_grid,
    scaled,
)

ROOT = Path(__file__).resolve().parents[2]
DEM = ROOT / "maps" / "jacksboro-fault-dem.tif"


def _flat(length_m: float, width_m: float, height_m: float = 200.0, **changes: object) -> Scenario:
    values: dict[str, object] = {
        "name": "long",
        "origin": GeoPoint(47.0, 8.0, 400.0),
        "bounds": Bounds((-100.0, length_m + 100.0), (-width_m / 2, width_m / 2), (0, height_m)),
        "start_m": (0.0, 0.0, 30.0),
        "goal_m": (length_m, 0.0, 40.0),
        "obstacles": (),
        "source": "made-in-code",
    }
    values.update(changes)
    return Scenario(**values)  # type: ignore[arg-type]


def test_a_small_volume_keeps_the_default_grid() -> None:
    scn = _flat(2000.0, 1200.0)
    assert scn.grid_fitted and scn.grid == DEFAULT_GRID and not scn.grid_coarsened
    # every bundled scenario that sets no grid plans on the default one, as before
    for mission in sorted((ROOT / "missions").glob("*.yaml")):
        bundled = load_scenario(mission)
        if bundled.planner.grid is None:
            assert bundled.grid == DEFAULT_GRID, mission.name


@pytest.mark.parametrize(("length_km", "width_km"), [(50, 1.6), (50, 50), (200, 20), (1, 400)])
def test_a_large_volume_gets_the_finest_grid_that_fits(length_km: float, width_km: float) -> None:
    scn = _flat(length_km * 1000.0, width_km * 1000.0)
    points = [scn.start_m, scn.goal_m]
    grid = scn.grid
    assert scn.grid_coarsened and grid.dx_m == grid.dy_m > DEFAULT_GRID.dx_m
    assert path_grid(scn.volume, points, grid)[0] <= FIT_GRID_CELLS
    assert problem_size(scn)["grid_cells"] <= FIT_GRID_CELLS
    # the next finer factor would not fit: the grid is no coarser than it must be
    factor = grid.dx_m / DEFAULT_GRID.dx_m
    finer = max(f for f in FIT_FACTORS if f < factor)
    finer_grid = scaled(DEFAULT_GRID, finer, min(finer, grid.dz_m / DEFAULT_GRID.dz_m))
    assert path_grid(scn.volume, points, finer_grid)[0] > FIT_GRID_CELLS
    # and the route keeps at least eight vertical levels in the 200 m it may fly through
    assert 200.0 / grid.dz_m >= MIN_BAND_LEVELS or grid.dz_m == DEFAULT_GRID.dz_m


def test_a_tall_volume_coarsens_vertically_a_shallow_one_does_not() -> None:
    volume = Bounds((0.0, 60000.0), (-3000.0, 3000.0), (0.0, 150.0))
    shallow = fitted_grid(volume, [(0, 0), (60000, 0)], band_m=150.0)
    assert shallow.dx_m > DEFAULT_GRID.dx_m and shallow.dz_m <= 150.0 / MIN_BAND_LEVELS
    tall = Bounds((0.0, 60000.0), (-3000.0, 3000.0), (0.0, 5000.0))
    grid = fitted_grid(tall, [(0, 0), (60000, 0)], band_m=5000.0)
    assert grid.dz_m / DEFAULT_GRID.dz_m == grid.dx_m / DEFAULT_GRID.dx_m > 1


def test_a_thin_band_in_a_vast_tall_volume_still_gets_a_grid_that_fits() -> None:
    """2,000 km of ground with 9 km of relief under a 50 m band: keeping 8 levels in the band
    cannot fit, so the vertical step grows too; the grid still fits (and is within the
    limits a grid step may have)."""
    volume = Bounds((-1e6, 1e6), (-1e6, 1e6), (0.0, 9050.0))
    grid = fitted_grid(volume, [(-9e5, -9e5), (9e5, 9e5)], band_m=50.0)
    assert path_grid(volume, [(-9e5, -9e5), (9e5, 9e5)], grid)[0] <= FIT_GRID_CELLS
    assert grid.dz_m > DEFAULT_GRID.dz_m and max(vars(grid).values()) <= 10_000


def test_a_grid_the_user_sets_is_respected_and_still_checked() -> None:
    scn = _flat(50_000.0, 1600.0)
    mine = GridSpec(20.0, 20.0, 10.0)
    given = scn.with_planner(grid=mine)
    assert given.grid == mine and not given.grid_fitted  # not fitted, though larger
    assert not given.grid_coarsened
    assert problem_size(given)["grid_cells"] > FIT_GRID_CELLS
    with pytest.raises(ScenarioError) as info:
        scn.with_planner(grid=GridSpec(2.0, 2.0, 1.0))
    assert info.value.key == "planner.grid" and "too large to plan" in info.value.reason
    assert "leave planner.grid out" in info.value.reason


def test_the_size_counts_every_leg_and_the_largest_grid() -> None:
    via = ((20_000.0, 0.0, 40.0),)
    scn = _flat(40_000.0, 1600.0, via_m=via)
    one = _flat(20_000.0, 1600.0)
    cells, columns, length = path_grid(scn.volume, [(0, 0), (20000, 0), (40000, 0)], scn.grid)
    assert length == pytest.approx(40_000.0) and columns == 2 * round(20000 / scn.grid.dx_m)
    assert problem_size(scn)["columns"] == columns
    assert problem_size(scn)["route_samples"] == pytest.approx(2 * 40_000.0 / 5.0)
    assert cells == path_grid(scn.volume, [(0, 0), (40000, 0)], scn.grid)[0]
    assert problem_size(one)["columns"] == round(20000 / one.grid.dx_m)


# ---------------------------------------------------------------------------------------------
# The 13 km crossing of the Jacksboro ridge, at the defaults

RIDGE = f"""\
name: ridge-13km
origin: {{lat: 36.59, lon: -84.25}}
terrain: {DEM}
bounds: {{x: [-7000, 7000], y: [-4000, 3000], z: [0, 150]}}
start: [6000, -3000, 40]
goal: [-6000, 2000, 40]
safety_margin: 15
vehicle: {{cruise_speed: 12, takeoff_altitude: 40}}
mission: {{autopilot: ardupilot, spacing: 100, end: rtl, altitude: terrain}}
"""


def _scipy_ground(scenario: Scenario, frame: EnuFrame):
    """The DEM's surface as z in ``frame``, bilinear between the posts in the raster's CRS by
    scipy from the raw band (not uavplan's DEM code)."""
    rasterio = pytest.importorskip("rasterio")
    from pyproj import Transformer
    from scipy.interpolate import RegularGridInterpolator

    with rasterio.open(scenario.terrain_file) as src:
        z = src.read(1).astype(float)
        t = src.transform
        to_crs = Transformer.from_crs("EPSG:4326", src.crs.to_wkt(), always_xy=True)
    rows, cols = np.arange(z.shape[0]) + 0.5, np.arange(z.shape[1]) + 0.5
    interp = RegularGridInterpolator((rows, cols), z, method="linear")
    datum = scenario.site.origin.alt_m

    def ground_z(xy: np.ndarray) -> np.ndarray:
        xy = np.atleast_2d(xy)
        lat, lon, _ = frame.to_geodetic(np.column_stack([xy[:, :2], np.zeros(len(xy))]))
        # as lists: pyproj < 3.7 turns a one-element array into a float (NumPy deprecates it)
        x, y = (np.asarray(v) for v in to_crs.transform(list(lon), list(lat)))
        inv = ~t  # by its coefficients: affine deprecates `*` on a point, `@` is newer
        x, y = np.asarray(x), np.asarray(y)
        col, row = inv.a * x + inv.b * y + inv.c, inv.d * x + inv.e * y + inv.f
        return interp(np.column_stack([row, col])) - datum

    return ground_z


@pytest.mark.timeout(300)
@pytest.mark.slow
def test_a_13_km_ridge_crossing_plans_at_the_defaults(tmp_path: Path) -> None:
    """Refused or hundreds of MB at the default 20 m grid (its path grid over the ridge's
    volume holds about 4e7 cells); planned at the defaults on a fitted grid, and the written
    mission keeps the margin above the DEM surface computed independently."""
    pytest.importorskip("rasterio")
    path = tmp_path / "ridge.yaml"
    path.write_text(RIDGE, encoding="utf-8")
    scn = load_scenario(path)
    assert scn.planner.grid is None and scn.grid_coarsened
    assert problem_size(scn)["grid_cells"] <= FIT_GRID_CELLS
    default = problem_size(scn.with_planner(grid=DEFAULT_GRID))["grid_cells"]
    assert default > 5 * FIT_GRID_CELLS  # what the default grid would have held
    assert scn.grid.dz_m <= 150.0 / MIN_BAND_LEVELS  # the ground is followed finely

    out, report = tmp_path / "ridge.waypoints", tmp_path / "r.json"
    result = CliRunner().invoke(
        main, ["plan", str(path), "-o", str(out), "--report", str(report), "--allow-over-battery"]
    )  # 13 km there and back is not an x500 flight (issue 37: over the battery is exit 2)
    assert result.exit_code == 0, result.output
    assert "grid fitted to the flight volume" in result.output
    rep = json.loads(report.read_text())
    grid = rep["config"]["planner"]["grid"]
    assert rep["config"]["planner"]["grid_fitted"] is True
    assert (grid["dx"], grid["dy"], grid["dz"]) == (scn.grid.dx_m, scn.grid.dy_m, scn.grid.dz_m)
    assert rep["collision_free"] is True

    site = scn.site
    frame = EnuFrame.at(site.origin)
    ground_z = _scipy_ground(scn, frame)
    flown = mission_polyline_enu(load_mission(out), frame, ground_z)
    assert (
        math.dist(flown[-1][:2], site.goal_m[:2]) < 1.0
        or np.min(np.linalg.norm(flown - np.array(site.goal_m), axis=1)) < 0.05
    )
    # the take-off climb and, where the mission lands (a planned return home, issue 37), the
    # landing descent touch the ground
    landed = flown[-1][2] <= float(ground_z(flown[-1:, :2])[0]) + 0.01
    end = len(flown) - 1 if landed else len(flown)
    legs = np.vstack(
        [a + np.linspace(0, 1, max(2, int(math.dist(a, b) / 2.0) + 1))[:, None] * (b - a)
         for a, b in itertools.pairwise(flown[2:end])]
    )  # fmt: skip
    agl = legs[:, 2] - ground_z(legs[:, :2])
    assert agl.min() >= scn.safety_margin_m - 0.02
    assert agl.max() <= 150.0 + 0.5  # the ceiling above the ground, as the planner holds it
