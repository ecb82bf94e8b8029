"""Issue 33: ``survey: area_file:`` reads the survey area from a GIS file (GeoJSON, KML, a
GeoPackage in a projected CRS) with the libraries the project already uses; the polygon's
holes are no-fly holes; a file with no polygon, several separate polygons or no such file is
one message and exit 2."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import shapely
import yaml
from click.testing import CliRunner
from pyproj import Transformer

from uavplan.cli import main
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.scenario.values import load_survey_scenario

ORIGIN = GeoPoint(60.0, 25.0, 0.0)
#: the field in ENU metres, and a hole in it
FIELD = [(0.0, 0.0), (400.0, 0.0), (400.0, 250.0), (0.0, 250.0)]
HOLE = [(150.0, 100.0), (230.0, 100.0), (230.0, 160.0), (150.0, 160.0)]


def _lonlat(ring: list[tuple[float, float]]) -> list[list[float]]:
    xy = np.asarray(ring, dtype=np.float64)
    lat, lon, _ = EnuFrame.at(ORIGIN).to_geodetic(np.column_stack([xy, np.zeros(len(xy))]))
    pts = [[float(a), float(b)] for a, b in zip(lon, lat, strict=True)]
    return [*pts, pts[0]]


def _scenario(tmp_path: Path, area_file: str, **survey: Any) -> Path:
    data = {
        "name": "field",
        "origin": {"lat": ORIGIN.lat_deg, "lon": ORIGIN.lon_deg},
        "bounds": {"x": [-100, 500], "y": [-100, 350], "z": [0, 120]},
        "start": [-40, -40, 20],
        "safety_margin": 10,
        "survey": {"area_file": area_file, "altitude": 50, "lane_spacing_m": 30, **survey},
    }
    path = tmp_path / "field.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _geojson(tmp_path: Path, rings: list[list[list[float]]], name: str = "field.geojson") -> str:
    feature = {"type": "Feature", "properties": {},
               "geometry": {"type": "Polygon", "coordinates": rings}}  # fmt: skip
    (tmp_path / name).write_text(json.dumps({"type": "FeatureCollection", "features": [feature]}))
    return name


def _close(got: tuple[tuple[float, float], ...], want: list[tuple[float, float]]) -> None:
    assert len(got) == len(want)
    assert np.abs(np.asarray(got) - np.asarray(want)).max() < 0.01


def test_a_geojson_field_with_a_hole(tmp_path: Path) -> None:
    name = _geojson(tmp_path, [_lonlat(FIELD), _lonlat(HOLE)])
    scn, spec = load_survey_scenario(_scenario(tmp_path, name))
    _close(spec.area_m, FIELD)
    assert len(spec.exclude_m) == 1
    _close(spec.exclude_m[0], HOLE)
    # the file is one of the scenario's inputs (an output may not overwrite it)
    assert any(Path(f.path).name == name for f in scn.files)


def test_a_kml_field(tmp_path: Path) -> None:
    coords = " ".join(f"{lon},{lat},0" for lon, lat in _lonlat(FIELD))
    (tmp_path / "field.kml").write_text(
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<kml xmlns="http://www.opengis.net/kml/2.2"><Document><Placemark><name>field</name>'
        "<Polygon><outerBoundaryIs><LinearRing><coordinates>"
        f"{coords}</coordinates></LinearRing></outerBoundaryIs></Polygon></Placemark>"
        "</Document></kml>\n"
    )
    _, spec = load_survey_scenario(_scenario(tmp_path, "field.kml"))
    _close(spec.area_m, FIELD)
    assert spec.exclude_m == ()


def test_a_geopackage_in_a_projected_crs(tmp_path: Path) -> None:
    import pyogrio.raw  # no geopandas here: the raw writer

    to_utm = Transformer.from_crs("EPSG:4326", "EPSG:32635", always_xy=True)
    ring = np.asarray(_lonlat(FIELD))
    e, n = to_utm.transform(ring[:, 0], ring[:, 1])
    geom = shapely.Polygon(np.column_stack([e, n]))
    path = tmp_path / "field.gpkg"
    pyogrio.raw.write(
        str(path),
        np.array([shapely.to_wkb(geom)], dtype=object),
        field_data=[np.array(["field"], dtype=object)],
        fields=["name"],
        crs="EPSG:32635",
        driver="GPKG",
        geometry_type="Polygon",
    )
    _, spec = load_survey_scenario(_scenario(tmp_path, "field.gpkg"))
    _close(spec.area_m, FIELD)


def test_plan_surveys_the_file_s_field_around_its_hole(tmp_path: Path) -> None:
    from uavplan.app.feedback import Feedback
    from uavplan.app.plan import PlanRequest, plan

    name = _geojson(tmp_path, [_lonlat(FIELD), _lonlat(HOLE)])
    out = tmp_path / "field.plan"
    outcome: Any = plan(PlanRequest(str(_scenario(tmp_path, name)), str(out)), Feedback())
    assert out.exists() and outcome.verdict.flight_ok
    # no leg of the flight comes within the margin of the file's hole
    flight = shapely.LineString(outcome.route.waypoints_enu[:, :2])
    assert flight.distance(shapely.Polygon(HOLE)) >= 10.0 - 1e-6
    # and the photos cover the field outside it
    assert outcome.covered is None or outcome.covered >= 0.99
    items = json.loads(out.read_text())["mission"]["items"]
    assert any(i["command"] == 206 for i in items)


@pytest.mark.parametrize(
    ("content", "expected"),
    [
        (None, "no such file"),
        ("two", "2 separate polygons"),
        ("line", "holds no polygon"),
    ],
)
def test_a_bad_area_file_is_one_message(tmp_path: Path, content: str | None, expected: str) -> None:
    name = "field.geojson"
    if content == "two":
        far = [(x + 1000.0, y) for x, y in FIELD]
        features = [
            {"type": "Feature", "properties": {},
             "geometry": {"type": "Polygon", "coordinates": [_lonlat(r)]}}
            for r in (FIELD, far)
        ]  # fmt: skip
        (tmp_path / name).write_text(
            json.dumps({"type": "FeatureCollection", "features": features})
        )
    elif content == "line":
        feature = {"type": "Feature", "properties": {},
                   "geometry": {"type": "LineString", "coordinates": _lonlat(FIELD)}}  # fmt: skip
        (tmp_path / name).write_text(
            json.dumps({"type": "FeatureCollection", "features": [feature]})
        )
    src = _scenario(tmp_path, name)
    result = CliRunner().invoke(main, ["plan", str(src), "-o", str(tmp_path / "f.plan")])
    assert result.exit_code == 2, result.output
    assert expected in result.output
    assert "survey.area_file" in result.output
    assert "Traceback" not in result.output
    assert not (tmp_path / "f.plan").exists()


def test_area_and_area_file_together_are_refused(tmp_path: Path) -> None:
    name = _geojson(tmp_path, [_lonlat(FIELD)])
    src = _scenario(tmp_path, name, area=[list(p) for p in FIELD])
    result = CliRunner().invoke(main, ["plan", str(src), "-o", str(tmp_path / "f.plan")])
    assert result.exit_code == 2
    assert "not both" in result.output
