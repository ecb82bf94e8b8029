"""Fuzz the real-world inputs: OpenStreetMap and GIS files (``import`` and ``obstacle_files``),
DEM GeoTIFFs (``terrain:``) and a QGroundControl ``.plan`` given to ``plan`` (rerouting).

Each input is broken the way real files are: coordinates NaN, infinite, huge, beyond the poles
or in metres of an undeclared projected CRS; rings of two points or not closed; heights such
as ``9999999`` or ``building:levels=1e308``; DEMs with a zero pixel size, south-up, a single
post, the float32 maximum as an undeclared nodata; fence polygons of tens of thousands of
vertices. Invariant, everywhere: exit 0 with a correct result, or exit 2 with a message naming
the file; never exit 1, a traceback or a hang. And what ``import`` writes, the map reader
accepts, with the same obstacles as the same file read through ``obstacle_files``.

The fixed cases at the top are the defects found by hand (each failed before its fix). The
property tests below them run a seeded (derandomized) sequence by default; longer runs:
``UAVPLAN_FUZZ_EXAMPLES=2000 UAVPLAN_FUZZ_RANDOM=1 pytest -q tests/sources/test_fuzz_sources.py``
(``UAVPLAN_FUZZ_EXAMPLES`` is shared with tests/mission/test_fuzz_mission_files.py; here each
property test runs a tenth of it, at least 25).
"""

from __future__ import annotations

import json
import math
import os
from datetime import timedelta
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from click.testing import CliRunner, Result
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from uavplan.cli import main
from uavplan.limits import (
    MAX_ALTITUDE_M,
    MAX_FENCE_POLYGON_VERTICES,
    MAX_GROUND_AMSL_M,
    MAX_POLYGON_VERTICES,
)
from uavplan.scenario import load_map

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = max(25, int(os.environ.get("UAVPLAN_FUZZ_EXAMPLES", "500")) // 10)
RANDOM = os.environ.get("UAVPLAN_FUZZ_RANDOM", "") not in ("", "0")
FUZZ = settings(
    max_examples=EXAMPLES,
    derandomize=not RANDOM,
    database=None,
    deadline=timedelta(seconds=30),  # a hang, not a slow machine
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)

LAT0, LON0 = 60.17, 24.94  # a block of Helsinki
#: the whole test's limit grows with the examples; one example's hang is hypothesis's deadline
pytestmark = pytest.mark.timeout(max(120, 3 * EXAMPLES))


def run(*args: str) -> Result:
    return CliRunner().invoke(main, list(args), catch_exceptions=False)


def assert_clean(result: Result, file: Path, allowed: tuple[int, ...] = (0, 2)) -> None:
    """exit in ``allowed``; a refusal is one message naming the file, never a traceback."""
    out = result.output
    assert result.exit_code in allowed, out
    assert "Traceback" not in out and "internal error" not in out, out
    if result.exit_code != 0:
        assert file.name in out, out


# =============================================================================================
# Inputs


def osm_xml(nodes: list[tuple[int, str, str]], ways: list[tuple[int, list[int], dict]]) -> str:
    lines = ['<?xml version="1.0" encoding="UTF-8"?>', '<osm version="0.6" generator="test">']
    for i, lat, lon in nodes:
        lines.append(f'  <node id="{i}" version="1" lat="{lat}" lon="{lon}"/>')
    for i, refs, tags in ways:
        lines.append(f'  <way id="{i}" version="1">')
        lines += [f'    <nd ref="{r}"/>' for r in refs]
        lines += [f'    <tag k="{k}" v="{v}"/>' for k, v in tags.items()]
        lines.append("  </way>")
    lines.append("</osm>")
    return "\n".join(lines) + "\n"


def square_nodes(first_id: int, dlat: float, dlon: float) -> list[tuple[int, str, str]]:
    lat, lon = LAT0 + dlat, LON0 + dlon
    corners = [(lat, lon), (lat, lon + 2e-4), (lat + 1e-4, lon + 2e-4), (lat + 1e-4, lon)]
    return [(first_id + k, f"{a:.7f}", f"{b:.7f}") for k, (a, b) in enumerate(corners)]


def two_buildings(tags_a: dict, tags_b: dict) -> str:
    a = square_nodes(1, 0.0, 0.0)
    b = square_nodes(11, 3e-4, 0.0)
    return osm_xml(a + b, [(100, [1, 2, 3, 4, 1], tags_a), (101, [11, 12, 13, 14, 11], tags_b)])


def geojson(features: list[tuple[Any, dict]], crs: str | None = None) -> str:
    doc: dict[str, Any] = {
        "type": "FeatureCollection",
        "features": [
            {"type": "Feature", "properties": props, "geometry": geom} for geom, props in features
        ],
    }
    if crs is not None:
        doc["crs"] = {"type": "name", "properties": {"name": crs}}
    return json.dumps(doc, allow_nan=True)


def square_ring(dlat: float = 0.0, dlon: float = 0.0) -> list[list[float]]:
    lat, lon = LAT0 + dlat, LON0 + dlon
    return [[lon, lat], [lon + 2e-4, lat], [lon + 2e-4, lat + 1e-4], [lon, lat + 1e-4], [lon, lat]]


def polygon(ring: list[list[float]]) -> dict:
    return {"type": "Polygon", "coordinates": [ring]}


def write_dem(
    path: Path,
    data: np.ndarray,
    transform: Any,
    crs: str | None = "EPSG:4326",
    nodata: float | None = None,
) -> Path:
    import rasterio

    with rasterio.open(
        path, "w", driver="GTiff", height=data.shape[0], width=data.shape[1], count=1,
        dtype="float32", crs=crs, transform=transform, nodata=nodata,
    ) as dst:  # fmt: skip
        dst.write(data.astype("float32"), 1)
    return path


DEM_SCENARIO = """\
name: dem-fuzz
origin: {{lat: 47.397742, lon: 8.545594}}
terrain: {dem}
bounds: {{x: [-300, 300], y: [-300, 300], z: [0, 120]}}
start: [0, 0, 40]
goal: [200, 100, 40]
safety_margin: 10
planner: {{iterations: 20, population: 10, stall_iterations: null}}
"""


def ridge(n: int = 60) -> np.ndarray:
    return 400.0 + 20.0 * np.sin(np.linspace(0.0, 3.0, n))[None, :] + np.zeros((n, n))


def north_up(res: float = 5e-4) -> Any:
    from rasterio.transform import Affine

    # what rasterio.transform.from_origin returns, without its `*` (affine 3.0 deprecates it)
    return Affine(res, 0.0, 8.53, 0.0, -res, 47.41)


# =============================================================================================
# The defects found by hand


def test_osm_node_with_nan_latitude_is_refused_naming_the_file(tmp_path: Path) -> None:
    nodes = square_nodes(1, 0.0, 0.0)
    nodes[2] = (3, "nan", nodes[2][2])
    src = tmp_path / "broken.osm"
    src.write_text(osm_xml(nodes, [(100, [1, 2, 3, 4, 1], {"building": "yes"})]))
    result = run("import", str(src), "-o", str(tmp_path / "m.yaml"))
    assert result.exit_code == 2, result.output
    assert "broken.osm" in result.output and "location" in result.output
    assert not (tmp_path / "m.yaml").exists()


@pytest.mark.parametrize(
    ("name", "bad"),
    [("nan", math.nan), ("inf", math.inf), ("huge", 1e308), ("pole", None)],
)
def test_geojson_with_unusable_coordinates_is_refused(tmp_path: Path, name: str, bad: Any) -> None:
    ring = square_ring()
    if bad is None:
        for p in ring:
            p[1] = 95.5  # beyond the pole
    else:
        ring[1][0] = bad
        ring[2][1] = bad
    src = tmp_path / f"{name}.geojson"
    src.write_text(geojson([(polygon(ring), {"height": 12})]))
    result = run("import", str(src), "-o", str(tmp_path / "m.yaml"))
    assert_clean(result, src, (2,))
    assert "coordinates" in result.output


def test_projected_metres_without_a_crs_say_so(tmp_path: Path) -> None:
    x, y = 2776000.0, 8438262.9  # EPSG:3857 metres of Helsinki, in a GeoJSON naming no CRS
    ring = [[x, y], [x + 30, y], [x + 30, y + 25], [x, y + 25], [x, y]]
    src = tmp_path / "mercator.geojson"
    src.write_text(geojson([(polygon(ring), {"height": 12})]))
    result = run("import", str(src), "-o", str(tmp_path / "m.yaml"))
    assert_clean(result, src, (2,))
    assert "not longitude/latitude" in result.output and "reference system" in result.output
    # the same file naming its CRS imports
    src.write_text(geojson([(polygon(ring), {"height": 12})], crs="EPSG:3857"))
    assert_clean(run("import", str(src), "-o", str(tmp_path / "m.yaml")), src, (0,))


def test_one_bad_feature_among_good_ones_is_skipped_and_counted(tmp_path: Path) -> None:
    bad = square_ring(0.0, 5e-4)
    bad[1][0] = math.nan
    src = tmp_path / "mixed.geojson"
    src.write_text(geojson([(polygon(square_ring()), {}), (polygon(bad), {})]))
    result = run("import", str(src), "-o", str(tmp_path / "m.yaml"))
    assert_clean(result, src, (0,))
    assert "coordinates not finite" in result.output
    _, _, obstacles = load_map(tmp_path / "m.yaml")
    assert len(obstacles) == 1


def test_a_two_point_ring_is_counted_not_a_crash(tmp_path: Path) -> None:
    two = {"type": "Polygon", "coordinates": [[[LON0, LAT0], [LON0 + 2e-4, LAT0]]]}
    src = tmp_path / "two.geojson"
    src.write_text(geojson([(two, {})]))
    result = run("import", str(src), "-o", str(tmp_path / "m.yaml"))
    assert_clean(result, src, (2,))
    assert "invalid geometry" in result.output  # what was skipped, and why


def test_no_obstacles_left_prints_the_counts(tmp_path: Path) -> None:
    src = tmp_path / "far.geojson"
    src.write_text(geojson([(polygon(square_ring()), {})]))
    result = run(
        "import", str(src), "-o", str(tmp_path / "m.yaml"), "--origin", "0,0",
        "--bounds", "-100,100,-100,100",
    )  # fmt: skip
    assert result.exit_code == 2
    assert "skipped" in result.output and "outside the bounds" in result.output


@pytest.mark.parametrize(
    "tags",
    [{"building": "yes", "building:levels": "1e308"}, {"building": "yes", "height": "9999999"}],
)
def test_absurd_heights_round_trip_through_the_map(tmp_path: Path, tags: dict) -> None:
    """import writes a map the reader accepts, with the same obstacles obstacle_files reads."""
    src = tmp_path / "tall.osm"
    src.write_text(two_buildings(tags, {"building": "yes", "height": "12"}))
    out = tmp_path / "m.yaml"
    result = run("import", str(src), "-o", str(out))
    assert_clean(result, src, (0,))
    origin, _, imported = load_map(out)
    assert max(o.height_m for o in imported) == MAX_ALTITUDE_M
    # the same file through obstacle_files: the same obstacles, and the scenario validates
    assert origin is not None
    scenario = tmp_path / "s.yaml"
    scenario.write_text(
        f"name: s\norigin: {{lat: {origin.lat_deg}, lon: {origin.lon_deg}}}\n"
        "bounds: {x: [-100, 100], y: [-100, 100], z: [0, 120]}\n"
        "start: [-80, -80, 30]\ngoal: [80, -80, 30]\n"
        f"obstacle_files: [{{file: {src.name}}}]\n"
    )
    assert_clean(run("validate", str(scenario)), scenario, (0,))


@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("--ceiling", "nan"),
        ("--ceiling", "inf"),
        ("--ceiling", "1e308"),
        ("--bounds", "-1e308,1,0,1"),
    ],
)
def test_import_options_beyond_the_limits_are_refused(
    tmp_path: Path, option: str, value: str
) -> None:
    src = tmp_path / "ok.osm"
    src.write_text(two_buildings({"building": "yes"}, {"building": "yes"}))
    out = tmp_path / "m.yaml"
    result = run("import", str(src), "-o", str(out), option, value)
    assert result.exit_code == 2, result.output
    assert option in result.output
    assert not out.exists()


def test_dem_with_a_zero_pixel_size_is_refused(tmp_path: Path) -> None:
    from rasterio.transform import Affine

    dem = write_dem(tmp_path / "flat.tif", ridge(), Affine(5e-4, 0, 8.53, 0, 0.0, 47.41))
    scenario = tmp_path / "s.yaml"
    scenario.write_text(DEM_SCENARIO.format(dem=dem.name))
    result = run("validate", str(scenario))
    assert_clean(result, scenario, (2,))
    assert "flat.tif" in result.output and "pixel size" in result.output


def test_a_single_post_dem_names_the_file(tmp_path: Path) -> None:
    from rasterio.transform import Affine

    # what rasterio.transform.from_origin returns, without its `*` (affine 3.0 deprecates it)
    dem = write_dem(
        tmp_path / "post.tif", np.array([[400.0]]), Affine(0.1, 0.0, 8.5, 0.0, -0.1, 47.45)
    )
    scenario = tmp_path / "s.yaml"
    scenario.write_text(DEM_SCENARIO.format(dem=dem.name))
    result = run("validate", str(scenario))
    assert_clean(result, scenario, (2,))
    assert "post.tif" in result.output and "2 x 2" in result.output


def test_float32_max_heights_are_refused_by_validate_as_by_plan(tmp_path: Path) -> None:
    z = ridge()
    z[25:35, 25:35] = np.finfo(np.float32).max  # an undeclared nodata value under the area
    dem = write_dem(tmp_path / "max.tif", z, north_up())
    scenario = tmp_path / "s.yaml"
    scenario.write_text(DEM_SCENARIO.format(dem=dem.name))
    for command in (
        ["validate", str(scenario)],
        ["plan", str(scenario), "-o", str(tmp_path / "p.plan")],
    ):
        result = run(*command)
        assert_clean(result, scenario, (2,))
        assert "max.tif" in result.output and f"{MAX_GROUND_AMSL_M:g}" in result.output


def test_a_south_up_dem_reads_the_same_ground(tmp_path: Path) -> None:
    from rasterio.transform import Affine

    from uavplan.geo import EnuFrame, GeoPoint
    from uavplan.sources.dem import Terrain

    z = ridge()
    res = 5e-4
    up = write_dem(tmp_path / "north.tif", z, north_up(res))
    down = write_dem(
        tmp_path / "south.tif", z[::-1], Affine(res, 0, 8.53, 0, res, 47.41 - len(z) * res)
    )
    frame = EnuFrame.at(GeoPoint(47.397742, 8.545594, 0.0))
    area = ((-300.0, 300.0), (-300.0, 300.0))
    a = Terrain.from_file(up, frame, area_xy_m=area)
    b = Terrain.from_file(down, frame, area_xy_m=area)
    pts = np.random.default_rng(1).uniform(-300, 300, (500, 2))
    np.testing.assert_allclose(a.height_m(pts), b.height_m(pts), atol=1e-9)
    scenario = tmp_path / "s.yaml"
    scenario.write_text(DEM_SCENARIO.format(dem=down.name))
    assert_clean(run("validate", str(scenario)), scenario, (0,))


@pytest.mark.timeout(60)
@pytest.mark.slow
def test_a_fence_polygon_of_50000_vertices_is_refused_at_once(tmp_path: Path) -> None:
    plan = json.loads((ROOT / "missions" / "qgc-inspection.plan").read_text())
    ring = plan["geoFence"]["polygons"][1]["polygon"]
    lat0 = sum(v[0] for v in ring) / len(ring)
    lon0 = sum(v[1] for v in ring) / len(ring)
    n = 50_000
    k = np.arange(n) * 2 * math.pi / n
    plan["geoFence"]["polygons"][1]["polygon"] = np.column_stack(
        (lat0 + 1e-4 * np.sin(k), lon0 + 1.3e-4 * np.cos(k))
    ).tolist()
    src = tmp_path / "huge-fence.plan"
    src.write_text(json.dumps(plan))
    out = tmp_path / "out.plan"
    result = run("plan", str(src), "-o", str(out))
    assert_clean(result, src, (2,))
    assert f"{MAX_FENCE_POLYGON_VERTICES:,}" in result.output
    assert not out.exists()


# =============================================================================================
# Property tests

NUMBERS = st.sampled_from(
    ["nan", "inf", "-inf", "1e308", "-1e308", "95.5", "-200", "abc", "", "0", "1e-320", "  60.17"]
)
HEIGHT_TEXT = st.one_of(
    st.sampled_from(["1e308", "9999999", "-5", "nan", "inf", "0", "12 m", "40'", "12;1e400", ""]),
    st.text(max_size=8),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
)


def _xml_safe(text: str) -> str:
    return (
        "".join(c for c in text if c.isprintable())
        .replace("&", "&amp;")
        .replace('"', "&quot;")
        .replace("<", "&lt;")
    )


@FUZZ
@given(
    data=st.data(),
    n_buildings=st.integers(1, 4),
    with_bounds=st.booleans(),
)
def test_fuzz_osm_import(tmp_path: Path, data: Any, n_buildings: int, with_bounds: bool) -> None:
    nodes: list[tuple[int, str, str]] = []
    ways = []
    for b in range(n_buildings):
        sq = square_nodes(10 * b + 1, 2e-4 * b, 0.0)
        nodes += sq
        refs = [n[0] for n in sq] + [sq[0][0]]
        tags = {"building": "yes"}
        if data.draw(st.booleans()):
            tags[data.draw(st.sampled_from(["height", "building:levels", "min_height"]))] = (
                _xml_safe(data.draw(HEIGHT_TEXT))
            )
        if data.draw(st.integers(0, 4)) == 0:
            refs = refs[: data.draw(st.integers(0, len(refs)))]  # open or degenerate way
        ways.append((100 + b, refs, tags))
    for _ in range(data.draw(st.integers(0, 3))):  # break some coordinates
        i = data.draw(st.integers(0, len(nodes) - 1))
        nid, lat, lon = nodes[i]
        value = data.draw(NUMBERS)
        nodes[i] = (nid, value, lon) if data.draw(st.booleans()) else (nid, lat, value)
    if data.draw(st.integers(0, 5)) == 0 and nodes:
        nodes.pop(data.draw(st.integers(0, len(nodes) - 1)))  # a node missing from the extract
    src = tmp_path / "fuzz.osm"
    text = osm_xml(nodes, ways)
    if data.draw(st.integers(0, 9)) == 0:
        text = text[: data.draw(st.integers(0, len(text)))]  # truncated download
    src.write_text(text)
    out = tmp_path / "m.yaml"
    out.unlink(missing_ok=True)
    args = ["import", str(src), "-o", str(out)]
    if with_bounds:
        args += ["--origin", f"{LAT0},{LON0}", "--bounds", "-200,200,-200,200"]
    result = run(*args)
    assert_clean(result, src)
    if result.exit_code == 0:
        _check_written_map(out)
    else:
        assert not out.exists()


COORD = st.one_of(
    st.floats(-180, 180),
    st.sampled_from([math.nan, math.inf, -math.inf, 1e308, 95.5, -91.0, 2776000.0, 8438262.9]),
)


@FUZZ
@given(data=st.data(), n=st.integers(1, 3), crs=st.sampled_from([None, "EPSG:4326", "EPSG:3857"]))
def test_fuzz_geojson_import(tmp_path: Path, data: Any, n: int, crs: str | None) -> None:
    features = []
    for k in range(n):
        ring = square_ring(2e-4 * k, 0.0)
        for _ in range(data.draw(st.integers(0, 2))):
            ring[data.draw(st.integers(0, 4))][data.draw(st.integers(0, 1))] = data.draw(COORD)
        cut = data.draw(st.integers(0, 6))
        if cut < 5 and data.draw(st.booleans()):
            ring = ring[:cut]  # too few points, or not closed
        geom: Any = polygon(ring)
        if data.draw(st.integers(0, 6)) == 0:
            geom = data.draw(st.sampled_from([None, {"type": "Point", "coordinates": ring[0]}
                                               if ring else None]))  # fmt: skip
        props: dict[str, Any] = {}
        if data.draw(st.booleans()):
            props["h"] = data.draw(
                st.one_of(HEIGHT_TEXT, st.floats(allow_nan=True, allow_infinity=True))
            )
        features.append((geom, props))
    src = tmp_path / "fuzz.geojson"
    src.write_text(geojson(features, crs=crs))
    out = tmp_path / "m.yaml"
    out.unlink(missing_ok=True)
    result = run("import", str(src), "-o", str(out), "--height-attribute", "h")
    if "no attribute 'h'" in result.output:  # no feature carried it: a clear refusal
        assert result.exit_code == 2
        return
    assert_clean(result, src)
    if result.exit_code == 0:
        _check_written_map(out)


def _check_written_map(out: Path) -> None:
    """What import wrote, the map reader accepts, within the limits."""
    _, bounds, obstacles = load_map(out)
    assert obstacles and bounds is not None
    for ob in obstacles:
        assert 0 < ob.height_m <= MAX_ALTITUDE_M
        assert len(ob.footprint()) <= MAX_POLYGON_VERTICES


@FUZZ
@given(
    shape=st.tuples(st.integers(1, 40), st.integers(1, 40)),
    res=st.sampled_from([0.0, 1e-9, 2e-4, 5e-4, 0.01, 1.0]),
    flip=st.booleans(),
    crs=st.sampled_from(["EPSG:4326", "EPSG:3857", None]),
    special=st.sampled_from([None, math.nan, math.inf, -math.inf, 3.4e38, -3.4e38, 1e5, -9999.0]),
    nodata=st.sampled_from([None, -9999.0]),
)
def test_fuzz_dem(
    tmp_path: Path,
    shape: tuple[int, int],
    res: float,
    flip: bool,
    crs: str | None,
    special: float | None,
    nodata: float | None,
) -> None:
    from rasterio.transform import Affine

    rows, cols = shape
    z = 400.0 + np.arange(rows * cols, dtype=float).reshape(rows, cols) % 17
    if special is not None:
        z[rows // 2, cols // 2] = special
    if crs == "EPSG:3857":
        x0, y0, step = 950_000.0, 6_010_000.0, res * 1e5
    else:
        x0, y0, step = 8.54, 47.40, res
    south, north = y0 - rows * step / 2, y0 + rows * step / 2
    west = x0 - cols * step / 2
    transform = (
        Affine(step, 0, west, 0, step, south) if flip else Affine(step, 0, west, 0, -step, north)
    )
    dem = write_dem(tmp_path / "fuzz.tif", z, transform, crs=crs, nodata=nodata)
    scenario = tmp_path / "s.yaml"
    scenario.write_text(DEM_SCENARIO.format(dem=dem.name))
    result = run("validate", str(scenario))
    assert_clean(result, scenario)
    if result.exit_code == 2:
        assert "terrain" in result.output or "fuzz.tif" in result.output


@FUZZ
@given(
    data=st.data(),
    vertices=st.sampled_from([3, 5, 40, 999, 1001, 20_000]),
    inclusion=st.booleans(),
)
@pytest.mark.slow
def test_fuzz_plan_fence_polygons(
    tmp_path: Path, data: Any, vertices: int, inclusion: bool
) -> None:
    plan = json.loads((ROOT / "missions" / "qgc-inspection.plan").read_text())
    polys = plan["geoFence"]["polygons"]
    index = data.draw(st.integers(0, len(polys) - 1))
    ring = polys[index]["polygon"]
    lat0 = sum(v[0] for v in ring) / len(ring)
    lon0 = sum(v[1] for v in ring) / len(ring)
    size = data.draw(st.sampled_from([1e-5, 1e-4, 1e-3]))
    k = np.arange(vertices) * 2 * math.pi / vertices
    new = np.column_stack((lat0 + size * np.sin(k), lon0 + 1.3 * size * np.cos(k))).tolist()
    for _ in range(data.draw(st.integers(0, 2))):
        new[data.draw(st.integers(0, vertices - 1))][data.draw(st.integers(0, 1))] = data.draw(
            st.sampled_from([math.nan, 1e308, 95.0, lat0, lon0])
        )
    if data.draw(st.booleans()):
        new.reverse()
    polys[index]["polygon"] = new
    polys[index]["inclusion"] = inclusion
    src = tmp_path / "fuzz.plan"
    src.write_text(json.dumps(plan, allow_nan=True))
    out = tmp_path / "out.plan"
    out.unlink(missing_ok=True)
    result = run("plan", str(src), "-o", str(out), "--iterations", "30")
    assert_clean(result, src, (0, 2, 3))
    assert out.exists() == (result.exit_code == 0)


# ---------------------------------------------------------------------------------------------
# Binary formats: a valid file, then its bytes broken (truncated download, bit flips, a block
# overwritten), through `import` and through a scenario's obstacle_files alike


def _seed_files(folder: Path) -> dict[str, bytes]:
    """Valid small files of each binary format, built with the libraries we read them with."""
    import osmium
    import pyogrio.raw
    import shapely

    out: dict[str, bytes] = {}
    pbf = folder / "seed.osm.pbf"
    osm = folder / "seed.osm"
    osm.write_text(two_buildings({"building": "yes", "height": "15"}, {"building": "yes"}))
    with osmium.SimpleWriter(str(pbf)) as writer:
        for obj in osmium.FileProcessor(str(osm)):
            if isinstance(obj, osmium.osm.Node):
                writer.add_node(obj)
            elif isinstance(obj, osmium.osm.Way):
                writer.add_way(obj)
    out[".osm.pbf"] = pbf.read_bytes()
    rings = [square_ring(), square_ring(3e-4, 0.0)]
    geoms = shapely.to_wkb(np.array([shapely.Polygon(r) for r in rings]))
    heights = np.array([12.0, 30.0])
    for suffix, driver in ((".gpkg", "GPKG"), (".shp", "ESRI Shapefile")):
        path = folder / f"seed{suffix}"
        pyogrio.raw.write(
            path, geoms, [heights], ["h"], driver=driver, geometry_type="Polygon", crs="EPSG:4326"
        )
        out[suffix] = path.read_bytes()
        if suffix == ".shp":  # the shapefile's companions stay intact; the .shp is broken
            for companion in (".shx", ".dbf", ".prj"):
                out[companion] = path.with_suffix(companion).read_bytes()
    return out


class _Seeds(dict[str, bytes]):
    def __repr__(self) -> str:  # hypothesis prints its arguments on a failure
        return f"<seed files {sorted(self)}>"


@pytest.fixture(scope="module")
def seed_files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, bytes]:
    return _Seeds(_seed_files(tmp_path_factory.mktemp("seeds")))


def _break(data: Any, blob: bytes) -> bytes:
    out = bytearray(blob)
    for _ in range(data.draw(st.integers(1, 4))):
        how = data.draw(st.sampled_from(["truncate", "flip", "block"]))
        if not out:
            break
        at = data.draw(st.integers(0, len(out) - 1))
        if how == "truncate":
            del out[at:]
        elif how == "flip":
            out[at] ^= 1 << data.draw(st.integers(0, 7))
        else:
            size = data.draw(st.integers(1, 64))
            out[at : at + size] = data.draw(st.binary(min_size=size, max_size=size))
    return bytes(out)


@FUZZ
@given(data=st.data(), suffix=st.sampled_from([".osm.pbf", ".gpkg", ".shp"]))
def test_fuzz_binary_formats(
    tmp_path: Path, seed_files: dict[str, bytes], data: Any, suffix: str
) -> None:
    folder = tmp_path / data.draw(st.text("abcdef", min_size=4, max_size=8))
    folder.mkdir(exist_ok=True)
    src = folder / f"broken{suffix}"
    src.write_bytes(_break(data, seed_files[suffix]))
    if suffix == ".shp":
        for companion in (".shx", ".dbf", ".prj"):
            src.with_suffix(companion).write_bytes(seed_files[companion])
    extra = [] if suffix == ".osm.pbf" else ["--height-attribute", "h"]
    out = folder / "m.yaml"
    out.unlink(missing_ok=True)
    result = run("import", str(src), "-o", str(out), *extra)
    assert_clean(result, src)
    if result.exit_code == 0:
        _check_written_map(out)
    else:
        assert not out.exists()
    scenario = folder / "s.yaml"
    attribute = "" if suffix == ".osm.pbf" else ", height_attribute: h"
    scenario.write_text(
        f"name: s\norigin: {{lat: {LAT0}, lon: {LON0}}}\n"
        "bounds: {x: [-200, 200], y: [-200, 200], z: [0, 120]}\n"
        "start: [-150, -150, 30]\ngoal: [150, -150, 30]\n"
        f"obstacle_files: [{{file: {src.name}{attribute}}}]\n"
    )
    validated = run("validate", str(scenario))
    assert_clean(validated, scenario)


@pytest.mark.slow
def test_obstacles_thousands_of_km_apart_plan_in_bounded_memory(tmp_path: Path) -> None:
    """The world's lookup grid over pieces 2,000 km apart needed 48 GB (MemoryError, exit 1);
    it now stays bounded and the route is the same as without the far obstacles."""
    base = (
        "name: far\norigin: {lat: 47.397742, lon: 8.545594, alt: 488}\n"
        "bounds: {x: [0, 500], y: [-200, 200], z: [0, 100]}\n"
        "start: [0, 0, 30]\ngoal: [500, 0, 30]\nobstacles:\n"
        "  - {type: cylinder, center: [250, 0], radius: 30, height: 50}\n"
    )
    far = base + (
        "  - {type: cylinder, center: [-999000, -999000], radius: 5, height: 10}\n"
        "  - {type: cylinder, center: [999000, 999000], radius: 5, height: 10}\n"
    )
    reports = []
    for name, text in (("near", base), ("far", far)):
        scenario = tmp_path / f"{name}.yaml"
        scenario.write_text(text)
        report = tmp_path / f"{name}.json"
        result = run("plan", str(scenario), "-o", str(tmp_path / f"{name}.plan"),
                     "--report", str(report))  # fmt: skip
        assert_clean(result, scenario, (0,))
        reports.append(json.loads(report.read_text()))
    assert reports[0]["energy"] == reports[1]["energy"]
