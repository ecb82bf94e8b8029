"""OpenStreetMap obstacles (issue 10 item 1): an OSM XML file written here, read with pyosmium.

Every footprint is laid out in ENU metres, converted to lon/lat with the frame, written as
OSM nodes (libosmium keeps 1e-7 degrees, about 1 cm), read back and compared.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("osmium")
shapely = pytest.importorskip("shapely")

from shapely.geometry import Point, Polygon  # noqa: E402

from uavplan.geo import EnuFrame, GeoPoint  # noqa: E402
from uavplan.obstacles import Bounds, CylinderObstacle, PrismObstacle  # noqa: E402
from uavplan.sources import (  # noqa: E402
    ObstacleFileSpec,
    SourceError,
    parse_height_m,
    read_obstacle_file,
)

ORIGIN = GeoPoint(47.0, 8.0, 400.0)
FRAME = EnuFrame.at(ORIGIN)
BOUNDS = Bounds((-300.0, 300.0), (-300.0, 300.0), (0.0, 120.0))
TOL_M = 0.03  # OSM stores 1e-7 degrees


def square(cx: float, cy: float, half: float) -> list[tuple[float, float]]:
    return [
        (cx - half, cy - half),
        (cx + half, cy - half),
        (cx + half, cy + half),
        (cx - half, cy + half),
    ]


class OsmWriter:
    """Builds a tiny OSM XML document from ENU coordinates."""

    def __init__(self) -> None:
        self.nodes: list[str] = []
        self.ways: list[str] = []
        self.relations: list[str] = []
        self.next_id = 1

    def _id(self) -> int:
        self.next_id += 1
        return self.next_id

    def node(self, x: float, y: float, tags: dict[str, str] | None = None) -> int:
        lat, lon, _ = FRAME.to_geodetic([x, y, 0.0])
        nid = self._id()
        body = "".join(f'<tag k="{k}" v="{v}"/>' for k, v in (tags or {}).items())
        self.nodes.append(
            f'<node id="{nid}" version="1" lat="{lat[0]:.7f}" lon="{lon[0]:.7f}">{body}</node>'
        )
        return nid

    def way(self, pts: list[tuple[float, float]], tags: dict[str, str], closed: bool = True) -> int:
        ids = [self.node(x, y) for x, y in pts]
        if closed:
            ids.append(ids[0])
        wid = self._id()
        refs = "".join(f'<nd ref="{i}"/>' for i in ids)
        body = "".join(f'<tag k="{k}" v="{v}"/>' for k, v in tags.items())
        self.ways.append(f'<way id="{wid}" version="1">{refs}{body}</way>')
        return wid

    def multipolygon(self, outer: list, inners: list, tags: dict[str, str]) -> int:
        members = [("outer", self.way(outer, {}))] + [("inner", self.way(r, {})) for r in inners]
        rid = self._id()
        body = "".join(f'<member type="way" ref="{w}" role="{role}"/>' for role, w in members)
        body += '<tag k="type" v="multipolygon"/>'
        body += "".join(f'<tag k="{k}" v="{v}"/>' for k, v in tags.items())
        self.relations.append(f'<relation id="{rid}" version="1">{body}</relation>')
        return rid

    def write(self, path: Path) -> Path:
        text = "\n".join(
            [
                '<?xml version="1.0" encoding="UTF-8"?>',
                '<osm version="0.6" generator="test">',
                *self.nodes,
                *self.ways,
                *self.relations,
                "</osm>",
            ]
        )
        path.write_text(text, encoding="utf-8")
        return path


@pytest.fixture
def town(tmp_path: Path) -> Path:
    osm = OsmWriter()
    osm.way(square(-100, 0, 10), {"building": "yes", "height": "12 m"})  # metres with unit
    osm.way(square(-50, 0, 10), {"building": "house", "height": "40'"})  # feet
    osm.way(square(0, 0, 10), {"building": "apartments", "building:levels": "4"})  # 4 x 3 m
    osm.way(square(50, 0, 10), {"building": "shed"})  # no height: the entry default
    osm.way(square(100, 0, 10), {"building:part": "yes", "height": "30", "min_height": "20"})
    # a block with a courtyard: 60 m square, 20 m hole
    osm.multipolygon(square(0, 150, 30), [square(0, 150, 10)], {"building": "yes", "height": "18"})
    osm.node(-150, -150, {"man_made": "tower", "height": "50"})  # a cylinder
    osm.node(-150, -100, {"man_made": "mast", "diameter": "3"})  # default height, d = 3 m
    # skipped, each with its reason
    osm.way([(150, -150), (170, -150), (170, -130)], {"building": "yes"}, closed=False)
    osm.way(square(150, 150, 10), {"building": "no"})
    osm.way(square(200, -200, 10), {"building": "yes", "location": "underground"})
    osm.way(square(2000, 2000, 10), {"building": "yes"})  # far outside the bounds
    osm.node(0, -200, {"man_made": "surveillance"})  # not a tall structure: ignored
    # an inner ring poking out of its outer ring: libosmium refuses the area
    osm.multipolygon(square(200, 0, 10), [square(208, 0, 5)], {"building": "yes"})
    return osm.write(tmp_path / "town.osm")


def prisms_of(result, height: float) -> list[PrismObstacle]:
    return [o for o in result.obstacles if isinstance(o, PrismObstacle) and o.height_m == height]


def footprint_close(prism: PrismObstacle, expected: list[tuple[float, float]]) -> bool:
    got = Polygon(prism.polygon_m)
    want = Polygon(expected)
    return got.symmetric_difference(want).area < 4 * TOL_M * want.length


def test_heights_from_tags_feet_levels_and_default(town: Path) -> None:
    result = read_obstacle_file(ObstacleFileSpec(town, default_height_m=7.5), FRAME, BOUNDS)
    row = {
        round(Polygon(o.polygon_m).centroid.x): o
        for o in result.obstacles
        if isinstance(o, PrismObstacle) and abs(Polygon(o.polygon_m).centroid.y) < 1
    }
    assert sorted(row) == [-100, -50, 0, 50, 100]
    for x, ob in row.items():
        assert footprint_close(ob, square(x, 0, 10))
    assert row[-100].height_m == pytest.approx(12.0)  # "12 m"
    assert row[-50].height_m == pytest.approx(40 * 0.3048)  # "40'"
    assert row[0].height_m == pytest.approx(12.0)  # 4 levels x 3 m
    assert row[50].height_m == pytest.approx(7.5)  # the entry's default_height
    assert row[100].height_m == pytest.approx(30.0)  # lifted base, modelled to the ground
    assert result.notes["base lifted: modelled down to the ground"] == 1
    assert result.notes["no height information: default height used"] == 2  # shed and mast


def test_prisms_are_ccw_simple_and_without_holes(town: Path) -> None:
    result = read_obstacle_file(ObstacleFileSpec(town), FRAME, BOUNDS)
    for ob in result.obstacles:
        if isinstance(ob, PrismObstacle):
            poly = Polygon(ob.polygon_m)
            assert poly.is_valid and not poly.interiors
            assert poly.exterior.is_ccw
            assert ob.polygon_m[0] != ob.polygon_m[-1]


def test_courtyard_is_kept_as_open_air_and_the_block_is_covered(town: Path) -> None:
    result = read_obstacle_file(ObstacleFileSpec(town), FRAME, BOUNDS)
    pieces = prisms_of(result, 18.0)
    assert len(pieces) >= 2  # split into hole-free prisms
    union = shapely.union_all([Polygon(p.polygon_m) for p in pieces])
    block = Polygon(square(0, 150, 30), [square(0, 150, 10)])
    assert union.buffer(TOL_M).covers(block)  # the union contains the original solid
    assert not union.contains(Point(0, 150))  # the courtyard stays open
    assert union.area == pytest.approx(block.area, rel=1e-3)
    assert result.notes["courtyard kept: outline split into hole-free prisms"] == 1
    assert result.kept["building (multipolygon relation)"] == 1


def test_tall_structures_become_cylinders(town: Path) -> None:
    result = read_obstacle_file(ObstacleFileSpec(town), FRAME, BOUNDS)
    cylinders = {
        round(o.center_m[1]): o for o in result.obstacles if isinstance(o, CylinderObstacle)
    }
    tower, mast = cylinders[-150], cylinders[-100]
    assert tower.height_m == 50.0 and tower.radius_m == 5.0
    assert np.allclose(tower.center_m, (-150, -150), atol=TOL_M)
    assert mast.radius_m == 1.5 and mast.height_m == 10.0
    assert result.kept["tower (node)"] == 1 and result.kept["mast (node)"] == 1


def test_skipped_features_are_counted_by_reason(town: Path) -> None:
    result = read_obstacle_file(ObstacleFileSpec(town), FRAME, BOUNDS)
    assert result.skipped == {
        "building way not closed (not an outline)": 1,
        "building=no": 1,
        "underground or indoor": 1,
        "outside the bounds": 1,
        "invalid outline (rings touch or cross)": 1,
    }
    assert sum(result.kept.values()) == 8
    text = "\n".join(result.summary_lines())
    assert "skipped       1  building=no" in text


def test_without_bounds_nothing_is_clipped(town: Path) -> None:
    result = read_obstacle_file(ObstacleFileSpec(town), FRAME, None)
    assert "outside the bounds" not in result.skipped
    assert sum(result.kept.values()) == 9


def test_clipping_keeps_the_part_near_the_bounds(tmp_path: Path) -> None:
    osm = OsmWriter()
    osm.way([(0, -20), (1000, -20), (1000, 20), (0, 20)], {"building": "yes", "height": "9"})
    path = osm.write(tmp_path / "long.osm")
    result = read_obstacle_file(ObstacleFileSpec(path), FRAME, BOUNDS)
    (prism,) = result.obstacles
    xs = [p[0] for p in prism.polygon_m]
    assert max(xs) == pytest.approx(300 + 50, abs=1e-6)  # bounds + the 50 m clip pad
    assert result.notes["clipped at the bounds"] == 1


@pytest.mark.parametrize(
    ("text", "metres"),
    [
        ("12", 12.0),
        ("12 m", 12.0),
        ("12.5m", 12.5),
        ("12,5", 12.5),
        ("40'", 12.192),
        ("40 ft", 12.192),
        ("12'6\"", 3.81),
        ("12;15 m", 15.0),
        (7, 7.0),
        ("tall", None),
        ("-3", None),
        ("0", None),
        (None, None),
    ],
)
def test_parse_height(text: object, metres: float | None) -> None:
    got = parse_height_m(text)
    assert got == (None if metres is None else pytest.approx(metres))


def test_errors_name_the_key(tmp_path: Path, town: Path) -> None:
    with pytest.raises(SourceError) as err:
        read_obstacle_file(ObstacleFileSpec(tmp_path / "nope.osm"), FRAME, BOUNDS)
    assert err.value.key == "file" and "not found" in err.value.reason
    with pytest.raises(SourceError) as err:
        read_obstacle_file(ObstacleFileSpec(town, layer="buildings"), FRAME, BOUNDS)
    assert err.value.key == "layer"
    broken = tmp_path / "broken.osm"
    broken.write_text("<osm><node id='1' lat='x'", encoding="utf-8")
    with pytest.raises(SourceError) as err:
        read_obstacle_file(ObstacleFileSpec(broken), FRAME, BOUNDS)
    assert err.value.key == "file" and "broken.osm" in err.value.reason
