"""Footprint geometry of uavplan.sources: hole splitting, conservative simplification, KML."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

shapely = pytest.importorskip("shapely")

from shapely.geometry import Point, Polygon  # noqa: E402

from uavplan.geo import EnuFrame, GeoPoint  # noqa: E402
from uavplan.obstacles import PrismObstacle  # noqa: E402
from uavplan.sources import ObstacleFileSpec, SourceError, read_obstacle_file  # noqa: E402
from uavplan.sources.common import conservative_simplify, split_holes  # noqa: E402


def test_split_holes_tiles_the_polygon_with_hole_free_pieces() -> None:
    holes = [
        [(10, 10), (20, 10), (20, 20), (10, 20)],
        [(40, 40), (55, 40), (55, 45), (40, 45)],
        [(70, 10), (80, 10), (75, 30)],
    ]
    poly = Polygon([(0, 0), (100, 0), (100, 60), (0, 60)], holes)
    pieces = split_holes(poly)
    assert len(pieces) > 3
    assert all(not p.interiors and p.is_valid for p in pieces)
    union = shapely.union_all(pieces)
    assert union.symmetric_difference(poly).area < 1e-9
    for hole in holes:
        assert not union.contains(Polygon(hole).representative_point())
    # pieces do not overlap: their areas add up to the polygon's
    assert sum(p.area for p in pieces) == pytest.approx(poly.area)


def test_conservative_simplify_covers_the_original() -> None:
    circle = Point(0, 0).buffer(20.0, quad_segs=32)  # 128 vertices
    simple = conservative_simplify(circle)
    assert len(simple.exterior.coords) < len(circle.exterior.coords) / 2
    assert simple.covers(circle)
    assert simple.area - circle.area < 0.6 * circle.length  # grown by at most ~0.5 m
    small = Polygon([(0, 0), (10, 0), (10, 10), (0, 10)])
    assert conservative_simplify(small) is small  # few vertices: kept as it is


def test_conservative_simplify_of_a_jagged_outline() -> None:
    rng = np.random.default_rng(5)
    angles = np.sort(rng.uniform(0, 2 * math.pi, 60))
    radii = rng.uniform(15, 25, 60)
    jagged = Polygon(np.column_stack((radii * np.cos(angles), radii * np.sin(angles))))
    simple = conservative_simplify(jagged)
    assert simple.covers(jagged)


KML = """<?xml version="1.0" encoding="UTF-8"?>
<kml xmlns="http://www.opengis.net/kml/2.2"><Document><Placemark>
<name>hangar</name>
<ExtendedData><Data name="roof_m"><value>14.5</value></Data></ExtendedData>
<Polygon><outerBoundaryIs><LinearRing><coordinates>
{coords}
</coordinates></LinearRing></outerBoundaryIs></Polygon>
</Placemark></Document></kml>
"""


def test_kml_drawn_in_google_earth(tmp_path: Path) -> None:
    frame = EnuFrame.at(GeoPoint(46.5, 7.0, 500.0))
    square = np.array([[0, 0, 0], [30, 0, 0], [30, 20, 0], [0, 20, 0], [0, 0, 0]], dtype=float)
    lat, lon, _ = frame.to_geodetic(square)
    coords = " ".join(f"{a:.8f},{b:.8f},512" for a, b in zip(lon, lat, strict=True))
    path = tmp_path / "hangar.kml"
    path.write_text(KML.format(coords=coords), encoding="utf-8")
    result = read_obstacle_file(ObstacleFileSpec(path, height_attribute="roof_m"), frame)
    (ob,) = result.obstacles
    assert isinstance(ob, PrismObstacle) and ob.height_m == 14.5
    assert Polygon(ob.polygon_m).symmetric_difference(Polygon(square[:4, :2])).area < 0.05


@pytest.mark.filterwarnings("ignore:'crs' was not provided")
def test_shapefile_without_prj_is_an_error(tmp_path: Path) -> None:
    import pyogrio.raw

    geom = shapely.to_wkb(np.array([Polygon([(0, 0), (1, 0), (1, 1)])]))
    shp = tmp_path / "lots.shp"
    pyogrio.raw.write(shp, geom, [], [], driver="ESRI Shapefile", geometry_type="Polygon")
    (tmp_path / "lots.prj").unlink(missing_ok=True)
    frame = EnuFrame.at(GeoPoint(46.5, 7.0, 500.0))
    with pytest.raises(SourceError, match=r"no coordinate reference system"):
        read_obstacle_file(ObstacleFileSpec(shp), frame)
