"""Terrain from a DEM GeoTIFF (issue 10 item 2, data side): a raster in a projected CRS with a
known slope, written here with rasterio, read back at known points to 1 cm."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

rasterio = pytest.importorskip("rasterio")

from pyproj import Transformer  # noqa: E402
from rasterio.transform import Affine  # noqa: E402

from uavplan.geo import EnuFrame, GeoPoint  # noqa: E402
from uavplan.sources.dem import Terrain, TerrainError  # noqa: E402

ORIGIN = GeoPoint(47.0, 9.2, 400.0)
FRAME = EnuFrame.at(ORIGIN)
UTM = "EPSG:32632"
TO_UTM = Transformer.from_crs("EPSG:4326", UTM, always_xy=True)
FROM_UTM = Transformer.from_crs(UTM, "EPSG:4326", always_xy=True)
E0, N0 = (float(v) for v in TO_UTM.transform(ORIGIN.lon_deg, ORIGIN.lat_deg))
CELL_M = 25.0
# pixel-edge origin of the raster: 2 km x 2 km around the scenario origin
WEST, NORTH = round(E0) - 1000.0, round(N0) + 1000.0
ROWS = COLS = 80


def plane(e: np.ndarray, n: np.ndarray) -> np.ndarray:
    """The known ground: 500 m at (E0, N0), rising 10 % to the east and 5 % to the south."""
    return 500.0 + 0.10 * (e - E0) - 0.05 * (n - N0)


def write_dem(
    path: Path, z: np.ndarray, *, nodata: float | None = None, units: str | None = None
) -> Path:
    profile = {
        "driver": "GTiff",
        "height": z.shape[0],
        "width": z.shape[1],
        "count": 1,
        "dtype": "float32",
        "crs": UTM,
        # what rasterio.transform.from_origin returns, without its `*` (affine 3.0 deprecates it)
        "transform": Affine(CELL_M, 0.0, WEST, 0.0, -CELL_M, NORTH),
    }
    if nodata is not None:
        profile["nodata"] = nodata
    with rasterio.open(path, "w", **profile) as dst:
        dst.write(z.astype(np.float32), 1)
        if units:
            dst.units = (units,)
    return path


def post_grid() -> tuple[np.ndarray, np.ndarray]:
    cols, rows = np.meshgrid(np.arange(COLS) + 0.5, np.arange(ROWS) + 0.5)
    return WEST + cols * CELL_M, NORTH - rows * CELL_M


@pytest.fixture
def slope_dem(tmp_path: Path) -> Path:
    e, n = post_grid()
    return write_dem(tmp_path / "slope.tif", plane(e, n))


def enu_of_utm(e: np.ndarray, n: np.ndarray) -> np.ndarray:
    # as lists: pyproj < 3.7 turns a one-element array into a float (NumPy deprecates it)
    lon, lat = FROM_UTM.transform(np.atleast_1d(e).tolist(), np.atleast_1d(n).tolist())
    return FRAME.to_enu_xy(np.asarray(lat), np.asarray(lon))


def test_height_at_known_points_to_a_centimetre(slope_dem: Path) -> None:
    terrain = Terrain.from_file(slope_dem, FRAME)
    # known UTM points (not on posts), taken to ENU independently of the DEM code
    rng = np.random.default_rng(3)
    e = E0 + rng.uniform(-900, 900, 200)
    n = N0 + rng.uniform(-900, 900, 200)
    got = terrain.height_m(enu_of_utm(e, n))
    assert np.max(np.abs(got - plane(e, n))) < 0.01
    # the origin itself: 500 m; 100 m east (ENU): about +10 m (UTM is rotated slightly)
    h0, h_east = terrain.height_m([[0.0, 0.0], [100.0, 0.0]])
    assert h0 == pytest.approx(500.0, abs=0.01)
    assert h_east - h0 == pytest.approx(10.0, abs=0.1)


def test_one_point_at_a_time_gives_the_array_height(slope_dem: Path, tmp_path: Path) -> None:
    """``height_at`` (the simulated flight's ground, a point per step) is ``height_m`` for
    one point, to 1e-6 m, on a sloping and on a rough DEM, in the DEM's frame and another;
    and it refuses a point the DEM does not cover as ``height_m`` does."""
    rng = np.random.default_rng(5)
    e, n = post_grid()
    rough = write_dem(tmp_path / "rough.tif", plane(e, n) + rng.normal(0.0, 8.0, e.shape))
    other = EnuFrame.at(GeoPoint(47.001, 9.199, 0.0))
    for path in (slope_dem, rough):
        for frame in (FRAME, other):
            terrain = Terrain.from_file(path, frame)
            xy = rng.uniform(-800.0, 800.0, (300, 2))
            xy[0] = (0.0, 0.0)
            want = terrain.height_m(xy)
            got = np.array([terrain.height_at(x, y) for x, y in xy])
            assert np.max(np.abs(got - want)) < 1e-6
    with pytest.raises(TerrainError, match="does not cover"):
        Terrain.from_file(slope_dem, FRAME).height_at(5000.0, 0.0)


def test_feet_units_are_converted(tmp_path: Path) -> None:
    e, n = post_grid()
    path = write_dem(tmp_path / "feet.tif", plane(e, n) / 0.3048, units="ft")
    assert Terrain.from_file(path, FRAME).height_m([[0.0, 0.0]])[0] == pytest.approx(
        500.0, abs=0.01
    )


def test_coverage_is_checked(slope_dem: Path, tmp_path: Path) -> None:
    terrain = Terrain.from_file(slope_dem, FRAME, area_xy_m=((-500, 500), (-500, 500)))
    assert terrain.posts_amsl_m.shape[0] < ROWS  # only the window around the area was read
    assert terrain.covers([[0.0, 0.0], [5000.0, 0.0]]).tolist() == [True, False]
    with pytest.raises(TerrainError, match=r"does not cover ENU point \(5000.0, 0.0\)"):
        terrain.height_m([[0.0, 0.0], [5000.0, 0.0]])
    with pytest.raises(TerrainError, match="does not cover"):
        Terrain.from_file(slope_dem, FRAME, area_xy_m=((-500, 1500), (-500, 500)))
    with pytest.raises(TerrainError, match="no overlap"):
        Terrain.from_file(slope_dem, FRAME, area_xy_m=((5000, 6000), (5000, 6000)))
    # a nodata hole is not covered either
    e, n = post_grid()
    z = plane(e, n)
    z[40, 40] = -9999.0
    holed = Terrain.from_file(write_dem(tmp_path / "holed.tif", z, nodata=-9999.0), FRAME)
    x, y = enu_of_utm(np.array([WEST + 40.5 * CELL_M]), np.array([NORTH - 40.5 * CELL_M]))[0]
    assert not holed.covers([[x, y]])[0]
    with pytest.raises(TerrainError, match="not found"):
        Terrain.from_file(tmp_path / "none.tif", FRAME)


def test_max_grid_bounds_the_surface_from_above(tmp_path: Path) -> None:
    e, n = post_grid()
    rng = np.random.default_rng(7)
    z = plane(e, n) + rng.normal(0.0, 5.0, e.shape)  # rough ground
    terrain = Terrain.from_file(write_dem(tmp_path / "rough.tif", z), FRAME)
    grid = terrain.max_grid((-600.0, 600.0), (-600.0, 600.0), 40.0, lipschitz_pad=False)
    assert grid.max_amsl_m.shape == (30, 30)
    # an independent dense sampling of the interpolated surface never exceeds its cell maximum
    pts = rng.uniform(-600.0, 600.0, (20000, 2))
    assert np.all(terrain.height_m(pts) <= grid.at(pts) + 1e-9)
    padded = terrain.max_grid((-600.0, 600.0), (-600.0, 600.0), 40.0)
    pad = padded.max_amsl_m - grid.max_amsl_m
    assert np.all(pad > 0)
    # the pad is the documented L·d: at most √2 × steepest post slope × half the post diagonal
    assert np.max(pad) <= np.sqrt(2) * np.max(terrain.post_slopes()) * CELL_M + 1e-6


def test_scenario_terrain_key_is_checked_to_cover_the_bounds(
    slope_dem: Path, tmp_path: Path
) -> None:
    from uavplan.errors import ScenarioError
    from uavplan.scenario import load_scenario

    def scenario(extent: int, dem: str) -> Path:
        path = tmp_path / "scn.yaml"
        path.write_text(
            "origin: {lat: 47.0, lon: 9.2, alt: 500}\n"
            f"bounds: {{x: [-{extent}, {extent}], y: [-{extent}, {extent}], z: [0, 120]}}\n"
            f"start: [-100, -100, 30]\ngoal: [100, 100, 30]\nterrain: {dem}\n",
            encoding="utf-8",
        )
        return path

    # a DEM that covers the bounds is read and the scenario moved onto it
    scn = load_scenario(scenario(800, slope_dem.name))
    assert scn.site.ground is not None and scn.terrain_file is not None
    path = scenario(1500, slope_dem.name)
    with pytest.raises(
        ScenarioError, match=r"scn.yaml: terrain: slope.tif: the DEM does not cover"
    ):
        load_scenario(path)
    with pytest.raises(ScenarioError, match=r"terrain: none.tif: DEM file not found"):
        load_scenario(scenario(800, "none.tif"))


def test_a_windowed_read_warns_nothing_and_keeps_rasterios_transform(slope_dem: Path) -> None:
    """The window's transform is rasterio's ``window_transform`` to the bit, computed without
    affine's deprecated ``*`` (it warned on every windowed DEM read)."""
    import warnings

    from rasterio.windows import Window

    from uavplan.sources.dem import _window_transform

    with rasterio.open(slope_dem) as src:
        for window in (Window(0, 0, 3, 3), Window(7, 11, 5, 5), Window(-2, 3, 4, 4)):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                expected = tuple(src.window_transform(window))
            assert tuple(_window_transform(src.transform, window)) == expected
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        terrain = Terrain.from_file(slope_dem, FRAME, area_xy_m=((-500, 500), (-500, 500)))
    assert terrain.height_m(np.array([[0.0, 0.0]]))[0] == pytest.approx(500.0, abs=0.01)
