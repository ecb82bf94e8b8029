"""GIS vector obstacles (issue 10 item 1): files written here, read with pyogrio (GDAL).

A GeoJSON in a projected CRS (UTM 32N) holds a building with a hole and a height in feet;
a GeoPackage has two layers. Errors name the entry key (``obstacle_files[1].layer``).
"""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pyogrio")
shapely = pytest.importorskip("shapely")

from pyproj import Transformer  # noqa: E402
from shapely.geometry import Point, Polygon  # noqa: E402

from uavplan.errors import ScenarioError  # noqa: E402
from uavplan.geo import EnuFrame, GeoPoint  # noqa: E402
from uavplan.obstacles import Bounds, PrismObstacle  # noqa: E402
from uavplan.scenario import load_scenario  # noqa: E402
from uavplan.sources import ObstacleFileSpec, SourceError, read_obstacle_file  # noqa: E402

ORIGIN = GeoPoint(47.0, 9.2, 400.0)
FRAME = EnuFrame.at(ORIGIN)
BOUNDS = Bounds((-500.0, 500.0), (-500.0, 500.0), (0.0, 120.0))
TO_UTM = Transformer.from_crs("EPSG:4326", "EPSG:32632", always_xy=True)


def ring_utm(pts: list[tuple[float, float]]) -> list[list[float]]:
    """ENU ring → closed UTM ring (via the frame and pyproj)."""
    enu = np.array([[x, y, 0.0] for x, y in pts])
    lat, lon, _ = FRAME.to_geodetic(enu)
    e, n = TO_UTM.transform(list(lon), list(lat))  # lists: pyproj < 3.7 and NumPy ≥ 1.25
    coords = [[float(a), float(b)] for a, b in zip(e, n, strict=True)]
    return [*coords, coords[0]]


def square(cx: float, cy: float, half: float) -> list[tuple[float, float]]:
    return [
        (cx - half, cy - half),
        (cx + half, cy - half),
        (cx + half, cy + half),
        (cx - half, cy + half),
    ]


OUTER = [(-40.0, -20.0), (40.0, -20.0), (40.0, 30.0), (-40.0, 30.0)]
HOLE = square(10.0, 5.0, 8.0)


@pytest.fixture
def blocks(tmp_path: Path) -> Path:
    features = [
        {
            "type": "Feature",
            "properties": {"name": "ring block", "height": "40 ft"},
            "geometry": {"type": "Polygon", "coordinates": [ring_utm(OUTER), ring_utm(HOLE[::-1])]},
        },
        {
            "type": "Feature",
            "properties": {"name": "tower", "height": 55.5},
            "geometry": {"type": "Polygon", "coordinates": [ring_utm(square(200, 200, 5))]},
        },
        {
            "type": "Feature",
            "properties": {"name": "no height", "height": None},
            "geometry": {"type": "Polygon", "coordinates": [ring_utm(square(-200, 200, 5))]},
        },
        {
            "type": "Feature",
            "properties": {"name": "a bench", "height": 1},
            "geometry": {"type": "Point", "coordinates": ring_utm([(0.0, -200.0)])[0]},
        },
    ]
    doc = {
        "type": "FeatureCollection",
        "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32632"}},
        "features": features,
    }
    path = tmp_path / "blocks.geojson"
    path.write_text(json.dumps(doc), encoding="utf-8")
    return path


def test_geojson_with_a_hole_and_feet_in_utm(blocks: Path) -> None:
    spec = ObstacleFileSpec(blocks, height_attribute="height", default_height_m=6.0)
    result = read_obstacle_file(spec, FRAME, BOUNDS)
    ring = [o for o in result.obstacles if o.height_m == pytest.approx(40 * 0.3048)]
    assert len(ring) >= 2  # the hole is kept: hole-free prisms
    for ob in ring:
        assert isinstance(ob, PrismObstacle)
        poly = Polygon(ob.polygon_m)
        assert poly.is_valid and not poly.interiors and poly.exterior.is_ccw
    union = shapely.union_all([Polygon(o.polygon_m) for o in ring])
    original = Polygon(OUTER, [HOLE])
    assert union.buffer(1e-3).covers(original)  # UTM -> lon/lat -> ENU round trip: sub-mm
    assert union.symmetric_difference(original).area < 1e-2
    assert not union.contains(Point(10.0, 5.0))  # the hole is open air
    heights = sorted(round(o.height_m, 3) for o in result.obstacles)
    assert 55.5 in heights and 6.0 in heights  # attribute, and default for a null
    assert result.skipped == {"point geometry (no footprint)": 1}
    assert result.kept["polygon of layer blocks"] == 3


def test_without_height_attribute_every_feature_takes_the_default(blocks: Path) -> None:
    result = read_obstacle_file(ObstacleFileSpec(blocks, default_height_m=8.0), FRAME, BOUNDS)
    assert {o.height_m for o in result.obstacles} == {8.0}


def write_gpkg(path: Path) -> Path:
    import pyogrio.raw

    for layer, pts, h in (("roads", square(0, 0, 3), 1.0), ("buildings", square(100, 0, 10), 21.0)):
        enu = np.array([[x, y, 0.0] for x, y in pts])
        lat, lon, _ = FRAME.to_geodetic(enu)
        geom = shapely.to_wkb(np.array([Polygon(list(zip(lon, lat, strict=True)))]))
        pyogrio.raw.write(
            path,
            geom,
            [np.array([h])],
            ["HEIGHT_M"],
            layer=layer,
            driver="GPKG",
            geometry_type="Polygon",
            crs="EPSG:4326",
            append=path.exists(),
        )
    return path


def test_geopackage_layer_and_attribute(tmp_path: Path) -> None:
    gpkg = write_gpkg(tmp_path / "city.gpkg")
    spec = ObstacleFileSpec(gpkg, layer="buildings", height_attribute="HEIGHT_M")
    (ob,) = read_obstacle_file(spec, FRAME, BOUNDS).obstacles
    assert ob.height_m == 21.0
    assert Polygon(ob.polygon_m).symmetric_difference(Polygon(square(100, 0, 10))).area < 1e-3
    with pytest.raises(SourceError) as err:
        read_obstacle_file(ObstacleFileSpec(gpkg, layer="houses"), FRAME, BOUNDS)
    assert err.value.key == "layer" and "buildings" in err.value.reason
    with pytest.raises(SourceError) as err:
        read_obstacle_file(ObstacleFileSpec(gpkg, height_attribute="H"), FRAME, BOUNDS)
    assert err.value.key == "height_attribute" and "HEIGHT_M" in err.value.reason


SCENARIO = """\
name: files
origin: {lat: 47.0, lon: 9.2, alt: 400}
bounds: {x: [-500, 500], y: [-500, 500], z: [0, 120]}
start: [-400, -400, 30]
goal: [400, 400, 30]
obstacles:
  - {type: cylinder, center: [300, -300], radius: 5, height: 20}
obstacle_files:
"""


def scenario_with(tmp_path: Path, entries: str) -> Path:
    path = tmp_path / "scn.yaml"
    path.write_text(SCENARIO + textwrap.indent(entries, "  "), encoding="utf-8")
    return path


def test_scenario_adds_file_obstacles_to_inline_ones(tmp_path: Path, blocks: Path) -> None:
    write_gpkg(tmp_path / "city.gpkg")
    scn = load_scenario(
        scenario_with(
            tmp_path,
            "- {file: blocks.geojson, height_attribute: height}\n"
            "- {file: city.gpkg, layer: buildings, height_attribute: HEIGHT_M}\n",
        )
    )
    assert scn.obstacles[0].height_m == 20.0  # inline first
    assert len(scn.obstacles) >= 1 + 4 + 1
    assert scn.obstacles[-1].height_m == 21.0


@pytest.mark.parametrize(
    ("entries", "key", "words"),
    [
        ("- {file: missing.geojson}\n", "obstacle_files[0].file", "not found"),
        (
            "- {file: blocks.geojson}\n- {file: blocks.geojson, layer: roofs}\n",
            "obstacle_files[1].layer",
            "no layer 'roofs'",
        ),
        (
            "- {file: blocks.geojson, height_attribute: HGT}\n",
            "obstacle_files[0].height_attribute",
            "no attribute 'HGT'",
        ),
        ("- {file: blocks.geojson, colour: red}\n", "obstacle_files[0].colour", "unknown key"),
        ("- {file: blocks.geojson, default_height: -1}\n", "obstacle_files[0].default_height", ">"),
        ("- {file: notes.txt}\n", "obstacle_files[0].file", "cannot read notes.txt"),
    ],
)
def test_scenario_errors_name_file_and_key(
    tmp_path: Path, blocks: Path, entries: str, key: str, words: str
) -> None:
    (tmp_path / "notes.txt").write_text("not a map\n", encoding="utf-8")
    path = scenario_with(tmp_path, entries)
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    message = str(err.value)
    assert message.startswith(f"{path}: {key}: "), message
    assert words in message


def test_a_start_too_close_to_a_file_obstacle_names_it(tmp_path: Path, blocks: Path) -> None:
    path = scenario_with(tmp_path, "- {file: blocks.geojson, height_attribute: height}\n")
    path.write_text(
        path.read_text(encoding="utf-8").replace(
            "start: [-400, -400, 30]", "start: [200, 212, 30]"
        ),
        encoding="utf-8",
    )
    with pytest.raises(
        ScenarioError, match=r"start: .* is 7\.0 m from obstacle #\d+ of obstacle_files"
    ):
        load_scenario(path)
