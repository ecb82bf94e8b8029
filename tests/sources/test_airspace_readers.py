"""The zone readers (OpenAir, ED-269, ED-318) against hand-computed answers: every OpenAir
record kind (arcs in both directions, by bearings and by points, circles, every altitude
reference), ED-269 and ED-318 circles and polygons, activation windows, and one message per
bad file naming the file and the line or the feature."""

from __future__ import annotations

import itertools
import json
import math
from datetime import UTC, datetime
from pathlib import Path

import pytest
from pyproj import Geod

from uavplan.sources.openair import parse_altitude, parse_openair
from uavplan.sources.zonefiles import read_zone_file
from uavplan.sources.zones import (
    CHORD_ERROR_M,
    FOOT_M,
    NAUTICAL_MILE_M,
    Reference,
    ZoneFileError,
)

GEOD = Geod(ellps="WGS84")
CENTRE = (8.5, 47.5)  # lon, lat of 47:30:00N 008:30:00E


def _polar(points, centre=CENTRE):
    """(bearing deg in [0, 360), distance m) of each (lon, lat) from ``centre``."""
    out = []
    for lon, lat in points:
        az, _, d = GEOD.inv(centre[0], centre[1], lon, lat)
        out.append((az % 360.0, d))
    return out


def _one(text: str):
    zones = parse_openair(text, "t.txt")
    assert len(zones) == 1
    return zones[0]


# ---------------------------------------------------------------------------------------------
# OpenAir altitudes: every reference, feet and metres


@pytest.mark.parametrize(
    ("text", "value_m", "reference"),
    [
        ("GND", 0.0, Reference.GND),
        ("SFC", 0.0, Reference.GND),
        ("0", 0.0, Reference.GND),
        ("UNL", math.inf, Reference.UNL),
        ("UNLIMITED", math.inf, Reference.UNL),
        ("FL65", 6500 * 0.3048, Reference.STD),  # 1981.2 m
        ("FL 100", 10000 * 0.3048, Reference.STD),
        ("FL065", 6500 * 0.3048, Reference.STD),
        ("3000 STD", 3000 * 0.3048, Reference.STD),  # 914.4 m
        ("3000ft STD", 3000 * 0.3048, Reference.STD),
        ("2500ft MSL", 762.0, Reference.AMSL),
        ("2500 ft AMSL", 762.0, Reference.AMSL),
        ("2500", 762.0, Reference.AMSL),  # legacy: feet, above mean sea level
        ("2500F", 762.0, Reference.AMSL),
        ("1500m AMSL", 1500.0, Reference.AMSL),
        ("1500 M MSL", 1500.0, Reference.AMSL),
        ("4500.5ft", 4500.5 * 0.3048, Reference.AMSL),
        ("1000ft AGL", 304.8, Reference.AGL),
        ("1000 ft GND", 304.8, Reference.AGL),  # legacy "above ground"
        ("1000ft SFC", 304.8, Reference.AGL),
        ("150m AGL", 150.0, Reference.AGL),
        ("MSL", 0.0, Reference.AMSL),
    ],
)
def test_altitudes(text: str, value_m: float, reference: Reference) -> None:
    limit = parse_altitude(text)
    assert limit.reference is reference
    if math.isinf(value_m):
        assert math.isinf(limit.value_m)
    else:
        assert limit.value_m == pytest.approx(value_m, abs=1e-9)
    assert limit.text == text


@pytest.mark.parametrize(
    "text", ["", "high", "FL", "100 furlongs", "-5 ft", "1e9 ft", "10ft AGL/50m"]
)
def test_bad_altitudes(text: str) -> None:
    with pytest.raises(ValueError, match=r"altitude|within"):
        parse_altitude(text)


# ---------------------------------------------------------------------------------------------
# OpenAir shapes


def test_polygon_and_coordinates() -> None:
    z = _one(
        "AC R\nAN A\nAL GND\nAH 1000ft AGL\n"
        "DP 47:30:00N 008:30:00E\n"
        "DP 47:30.5N 008:30:00E\n"  # decimal minutes
        "DP 47:30:30 N, 008:31:00.0 E\n"  # spaces and a comma
        "DP 47.5N 8.5166666667E\n"  # decimal degrees
        "DP 47:30:00N 008:30:00E\n"  # closing point dropped
    )
    assert z.circle is None
    expected = [8.5, 47.5, 8.5, 47.508333333, 8.516666667, 47.508333333, 8.5166666667, 47.5]
    assert [v for p in z.ring_lonlat for v in p] == pytest.approx(expected, abs=1e-8)
    assert z.chord_error_m == 0.0
    assert z.classes == ("R",) and z.label == "R, restricted"
    assert z.floor.reference is Reference.GND and z.ceiling.value_m == pytest.approx(304.8)


def test_southern_western_hemispheres() -> None:
    z = _one(
        "AC P\nAN S\nAL GND\nAH UNL\nDP 33:52:00S 151:12:00E\nDP 33:53:00S 151:12:00E\n"
        "DP 33:53:00S 151:13:00W\n"
    )
    assert list(z.ring_lonlat[0]) == pytest.approx([151.2, -33.866666667])
    assert list(z.ring_lonlat[2]) == pytest.approx([-151.216666667, -33.883333333])


def test_circle_radius_in_nautical_miles() -> None:
    z = _one("AC R\nAN C\nAL GND\nAH FL65\nV X=47:30:00N 008:30:00E\nDC 2.5\n")
    assert z.ring_lonlat is None
    assert z.circle == pytest.approx((8.5, 47.5, 2.5 * 1852.0))
    assert z.chord_error_m == 0.0  # a circle stays a circle


def _steps_outside(r: float, sweep_rad: float, e: float = CHORD_ERROR_M) -> int:
    return math.ceil(sweep_rad / (2.0 * math.acos(r / (r + e))))


def test_da_clockwise_convex_arc_edges_outside() -> None:
    # a clockwise ring (east → south → west → north) with a clockwise arc from bearing 90 to
    # 180: the arc bulges out of the zone, so its edges are tangents outside the circle
    r = 1852.0
    z = _one(
        "AC R\nAN ARC\nAL GND\nAH 1000ft AGL\nV X=47:30:00N 008:30:00E\n"
        "DA 1, 90, 180\n"
        "DP 47:29:00N 008:28:00E\nDP 47:31:00N 008:28:00E\n"
    )
    n = _steps_outside(r, math.pi / 2)  # hand-computed: ceil(1.5708 / (2 acos(1852/1854))) = 17
    assert n == 17
    arc = z.ring_lonlat[: n + 2]
    polar = _polar(arc)
    # ends on the circle at exactly the bearings; between them the tangent crossings at odd
    # multiples of the half step, at r / cos(half step)
    half = (math.pi / 2) / (2 * n)
    assert list(polar[0]) == pytest.approx([90.0, r], abs=1e-6)
    assert list(polar[-1]) == pytest.approx([180.0, r], abs=1e-6)
    for k, (bearing, dist) in enumerate(polar[1:-1]):
        assert bearing == pytest.approx(90.0 + math.degrees(half * (2 * k + 1)), abs=1e-6)
        assert dist == pytest.approx(r / math.cos(half), abs=1e-6)
    # the chord error: the vertices stray r (1/cos h - 1) <= 2 m outside the arc, never inside
    assert r / math.cos(half) - r <= CHORD_ERROR_M
    assert z.chord_error_m == CHORD_ERROR_M


def test_da_counter_clockwise() -> None:
    # V D=- : from bearing 180 counter-clockwise to 90 (through 135), in a clockwise ring
    # drawn the other way round: the arc turns against the ring, bulging into the zone's
    # outside... here the ring west → south-east arc → north is counter-clockwise
    z = _one(
        "AC R\nAN CCW\nAL GND\nAH 1000ft AGL\nV X=47:30:00N 008:30:00E\nV D=-\n"
        "DA 1, 180, 90\n"
        "DP 47:31:00N 008:32:00E\nDP 47:31:00N 008:28:00E\nDP 47:29:00N 008:28:00E\n"
    )
    polar = _polar(z.ring_lonlat)
    arc = [p for p in polar if abs(p[1] - 1852.0) < 10.0]
    bearings = [b for b, _ in arc]
    assert bearings[0] == pytest.approx(180.0, abs=1e-6)
    assert bearings[-1] == pytest.approx(90.0, abs=1e-6)
    assert all(a > b for a, b in itertools.pairwise(bearings))  # decreasing


def test_concave_arc_vertices_on_the_circle() -> None:
    # a clockwise ring whose arc turns counter-clockwise: the zone lies outside the circle
    # there, so the arc's vertices sit on the circle and its chords cut into the circle
    # (outside the zone): the polygon still contains the zone
    z = _one(
        "AC R\nAN NOTCH\nAL GND\nAH 1000ft AGL\nV X=47:30:00N 008:30:00E\n"
        "DP 47:28:00N 008:28:00E\n"
        "DP 47:32:00N 008:28:00E\n"
        "DP 47:32:00N 008:32:00E\n"
        "V D=-\n"
        "DA 1, 90, 270\n"  # counter-clockwise from east through north... to west? no: 90 → 270
    )
    polar = _polar(z.ring_lonlat)
    on_circle = [d for _, d in polar if abs(d - 1852.0) < 20.0]
    assert len(on_circle) >= 10
    assert all(d == pytest.approx(1852.0, abs=1e-6) for d in on_circle)


def test_db_arc_both_directions_ends_exact() -> None:
    a, b = "47:29:00N 008:30:00E", "47:30:00N 008:31:28.6E"
    text = (
        "AC R\nAN DB\nAL GND\nAH 1000ft AGL\nV X=47:30:00N 008:30:00E\n{d}DB {a}, {b}\n"
        "DP 47:28:00N 008:32:00E\n"
    )
    cw = _one(text.format(d="", a=a, b=b))
    ccw = _one(text.format(d="V D=-\n", a=a, b=b))
    for z in (cw, ccw):
        assert list(z.ring_lonlat[0]) == pytest.approx([8.5, 29 / 60 + 47.0])
        end = (8 + 31 / 60 + 28.6 / 3600, 47.5)
        assert end in z.ring_lonlat
    # clockwise from south (180) to east (90) goes the long way, through west and north
    bearings_cw = [b for b, _ in _polar(cw.ring_lonlat[: len(cw.ring_lonlat) - 1])]
    assert any(250 < b < 290 for b in bearings_cw) and any(b < 20 or b > 340 for b in bearings_cw)
    bearings_ccw = [b for b, _ in _polar(ccw.ring_lonlat[: len(ccw.ring_lonlat) - 1])]
    assert all(85 < b < 185 for b in bearings_ccw)  # the short way, through south-east


def test_direction_resets_at_each_zone() -> None:
    zones = parse_openair(
        "AC R\nAN A\nAL GND\nAH 100ft AGL\nV X=47:30:00N 008:30:00E\nV D=-\nDA 1, 180, 90\n"
        "DP 47:31:00N 008:32:00E\n"
        "AC R\nAN B\nAL GND\nAH 100ft AGL\nV X=47:30:00N 008:30:00E\nDA 1, 90, 180\n"
        "DP 47:31:00N 008:32:00E\n",
        "t.txt",
    )
    second = [b for b, d in _polar(zones[1].ring_lonlat) if abs(d - 1852.0) < 30.0]
    assert second[0] == pytest.approx(90.0) and second[-1] == pytest.approx(180.0)


def test_line_zone_becomes_a_corridor() -> None:
    z = _one(
        "AC Q\nAN KABEL\nAL 6627 ft\nAH 6627 ft\nDP 47:14:18 N 009:24:49 E\n"
        "DP 47:14:13 N 009:24:42 E\n"
    )
    assert len(z.ring_lonlat) == 4
    assert any("corridor" in n for n in z.notes)


def test_classes_types_names_comments() -> None:
    z = _one(
        "*VERSION: 2.0\n* a comment line\nAC D\nAY CTR\nAN EDDF CTR * part of the name\n"
        "AF 118.500\nAG Frankfurt Tower\nAL GND   * floor\nAH 2500ft MSL\n"
        "SP 0,1,0,0,255\nAT 50:00:00N 008:30:00E\n"
        "DP 50:00:00N 008:30:00E\nDP 50:01:00N 008:30:00E\nDP 50:01:00N 008:31:00E\n"
    )
    assert z.name == "EDDF CTR * part of the name"
    assert z.classes == ("D", "CTR")
    assert z.label == "class D, type CTR"
    assert z.title == "zone 'EDDF CTR * part of the name' (class D, type CTR)"
    assert z.where == "line 3"


def test_activation_windows() -> None:
    z = _one(
        "AC UNC\nAY TRA\nAN T\nAL GND\nAH 1000ft AGL\n"
        "AA 2026-12-05T08:00Z/2026-12-05T16:00Z\n"
        "AA 2026-12-06T00:00Z/2026-12-06T24:00Z   ; the whole day\n"
        "V X=47:30:00N 008:30:00E\nDC 1\n"
    )
    t = lambda s: datetime.fromisoformat(s).replace(tzinfo=UTC)  # noqa: E731
    act = z.activity
    assert not act.active_during(t("2026-12-01T09:00"), t("2026-12-01T09:30"))
    assert act.active_during(t("2026-12-05T07:50"), t("2026-12-05T08:10"))
    assert not act.active_during(t("2026-12-05T16:01"), t("2026-12-05T23:59"))
    assert act.active_during(t("2026-12-06T23:00"), t("2026-12-06T23:10"))
    assert not act.active_during(t("2026-12-07T00:00:01"), t("2026-12-07T01:00"))
    unknown = _one("AC R\nAN N\nAL GND\nAH 100ft AGL\nAA NONE\nV X=47:30:00N 008:30:00E\nDC 1\n")
    assert unknown.activity.unknown and unknown.activity.active_during(
        t("2000-01-01T00:00"), t("2000-01-01T00:01")
    )
    open_end = _one(
        "AC R\nAN O\nAL GND\nAH 100ft AGL\nAA 2026-12-05T08:00Z/NONE\n"
        "V X=47:30:00N 008:30:00E\nDC 1\n"
    )
    assert open_end.activity.active_during(t("2030-01-01T00:00"), t("2030-01-01T00:01"))
    assert not open_end.activity.active_during(t("2026-12-05T07:00"), t("2026-12-05T07:59"))


# ---------------------------------------------------------------------------------------------
# OpenAir errors: the file, the line, the problem


@pytest.mark.parametrize(
    ("text", "line", "words"),
    [
        (
            "AC R\nAN A\nAL GND\nAH 1000ft AGL\nDP 47:30:00N garbage\n",
            5,
            "cannot read the position",
        ),
        ("AC R\nAN A\nAL GND\nAH 1000ft AGL\nDA 1, 90, 180\n", 5, "needs a centre"),
        ("AC R\nAN A\nAL GND\nAH high\n", 4, "cannot read the altitude"),
        ("AC R\nAN A\nAL GND\nDP 47:30:00N 008:30:00E\n", 1, "no ceiling"),
        ("AC R\nAN A\nAH UNL\nDP 47:30:00N 008:30:00E\n", 1, "no floor"),
        ("AC R\nAN A\nAL UNL\nAH UNL\n", 3, "cannot be unlimited"),
        ("AC R\nAN A\nAL GND\nAH UNL\n", 1, "no shape"),
        ("AN A\nAC R\n", 1, "before the first AC"),
        ("AC R\nAN A\nAL GND\nAH UNL\nXX 1\n", 5, "unknown record"),
        ("AC R\nAN A\nAL GND\nAH UNL\nV X=47:30:00N 008:30:00E\nDC -1\n", 6, "radius"),
        ("AC R\nAN A\nAL GND\nAH UNL\nV X=47:30:00N 008:30:00E\nDC 5000\n", 6, "radius"),
        ("AC R\nAN A\nAL GND\nAH UNL\nDP 95:00:00N 008:30:00E\n", 5, "beyond"),
        ("AC R\nAN A\nAL GND\nAH UNL\nV D=x\n", 5, "V D="),
        ("AC R\nAN A\nAL GND\nAH UNL\nAA tomorrow\n", 5, "AA"),
        (
            "AC R\nAN A\nAL GND\nAH UNL\nDP 47:30:00N 008:30:00E\nDP 47:30:00N 008:30:00E\n",
            1,
            "distinct",
        ),
        ("AC R\nAN A\nAL GND\nAH UNL\nDY 1\n", 5, "DY"),
    ],
)
def test_openair_errors_name_the_line(tmp_path: Path, text: str, line: int, words: str) -> None:
    f = tmp_path / "bad.txt"
    f.write_text(text)
    with pytest.raises(ZoneFileError) as err:
        read_zone_file(f)
    msg = str(err.value)
    assert msg.startswith(f"{f}: line {line}: "), msg
    assert words in msg


def test_latin1_and_bom(tmp_path: Path) -> None:
    f = tmp_path / "de.txt"
    f.write_bytes(
        b"\xef\xbb\xbfAC R\nAN M\xfcnchen\nAL GND\nAH UNL\nV X=48:00:00N 011:00:00E\nDC 1\n"
    )
    assert read_zone_file(f)[0].name == "München" or read_zone_file(f)[0].name.startswith("M")
    g = tmp_path / "bin.txt"
    g.write_bytes(b"AC R\x00\x01")
    with pytest.raises(ZoneFileError, match="binary"):
        read_zone_file(g)


# ---------------------------------------------------------------------------------------------
# ED-269


def _ed269(volume: dict, **extra) -> dict:
    feature = {
        "identifier": "TST9",
        "country": "CHE",
        "name": "Zone nine",
        "type": "COMMON",
        "restriction": "PROHIBITED",
        "applicability": [{"permanent": "YES"}],
        "zoneAuthority": [{"name": "x"}],
        "geometry": [volume],
        **extra,
    }
    return {"title": "t", "features": [feature]}


def _read(tmp_path: Path, doc: dict, name: str = "z.json"):
    f = tmp_path / name
    f.write_text(json.dumps(doc))
    return read_zone_file(f)


def test_ed269_circle_in_feet(tmp_path: Path) -> None:
    (z,) = _read(
        tmp_path,
        _ed269(
            {
                "uomDimensions": "FT",
                "lowerLimit": 0,
                "lowerVerticalReference": "AGL",
                "upperLimit": 400,
                "upperVerticalReference": "AGL",
                "horizontalProjection": {"type": "Circle", "center": [8.5, 47.5], "radius": 500},
            }
        ),
    )
    assert z.circle == (8.5, 47.5, 500.0)  # the radius is metres whatever uomDimensions says
    assert z.floor.reference is Reference.GND
    assert z.ceiling.reference is Reference.AGL and z.ceiling.value_m == pytest.approx(121.92)
    assert z.classes == ("PROHIBITED",) and z.name == "Zone nine"


def test_ed269_polygon_amsl_metres(tmp_path: Path) -> None:
    (z,) = _read(
        tmp_path,
        _ed269(
            {
                "uomDimensions": "M",
                "lowerLimit": 300,
                "lowerVerticalReference": "AMSL",
                "upperLimit": 900,
                "upperVerticalReference": "AMSL",
                "horizontalProjection": {
                    "type": "Polygon",
                    "coordinates": [[[8.5, 47.5], [8.6, 47.5], [8.6, 47.6], [8.5, 47.5]]],
                },
            },
            restriction="REQ_AUTHORISATION",
            applicability=[
                {
                    "permanent": "NO",
                    "startDateTime": "2026-12-01T08:00:00.00Z",
                    "endDateTime": "2026-12-31T18:00:00.00Z",
                    "schedule": [
                        {
                            "day": ["MON", "TUE"],
                            "startTime": "08:00:00.00Z",
                            "endTime": "12:00:00.00Z",
                        }
                    ],
                }
            ],
        ),
    )
    assert z.ring_lonlat == ((8.5, 47.5), (8.6, 47.5), (8.6, 47.6))
    assert (z.floor.value_m, z.floor.reference) == (300.0, Reference.AMSL)
    assert (z.ceiling.value_m, z.ceiling.reference) == (900.0, Reference.AMSL)
    t = lambda s: datetime.fromisoformat(s).replace(tzinfo=UTC)  # noqa: E731
    # 2026-12-01 is a Tuesday: active 08:00-12:00; Wednesday 2 December not
    assert z.activity.active_during(t("2026-12-01T09:00"), t("2026-12-01T09:30"))
    assert not z.activity.active_during(t("2026-12-01T12:30"), t("2026-12-01T13:00"))
    assert not z.activity.active_during(t("2026-12-02T09:00"), t("2026-12-02T10:00"))
    assert z.activity.active_during(t("2026-12-07T11:59"), t("2026-12-07T12:30"))  # Monday


def test_ed269_several_volumes(tmp_path: Path) -> None:
    v = {
        "uomDimensions": "M",
        "lowerLimit": 0,
        "lowerVerticalReference": "AGL",
        "upperLimit": 50,
        "upperVerticalReference": "AGL",
        "horizontalProjection": {"type": "Circle", "center": [8.5, 47.5], "radius": 100},
    }
    doc = _ed269(v)
    doc["features"][0]["geometry"].append({**v, "lowerLimit": 50, "upperLimit": 120})
    a, b = _read(tmp_path, doc)
    assert a.name == "Zone nine volume 1" and b.name == "Zone nine volume 2"
    assert b.floor.value_m == 50.0


@pytest.mark.parametrize(
    ("change", "words"),
    [
        ({"restriction": 5}, "restriction"),
        ({"geometry": []}, "geometry"),
        ({"geometry": [{"uomDimensions": "KM"}]}, "uomDimensions"),
        (
            {
                "geometry": [
                    {
                        "uomDimensions": "M",
                        "lowerLimit": "low",
                        "lowerVerticalReference": "AGL",
                        "horizontalProjection": {"type": "Circle", "center": [1, 2], "radius": 5},
                    }
                ]
            },
            "lowerLimit",
        ),
        (
            {
                "geometry": [
                    {
                        "uomDimensions": "M",
                        "upperLimit": 5,
                        "upperVerticalReference": "QNH",
                        "horizontalProjection": {"type": "Circle", "center": [1, 2], "radius": 5},
                    }
                ]
            },
            "upperVerticalReference",
        ),
        (
            {
                "geometry": [
                    {
                        "uomDimensions": "M",
                        "horizontalProjection": {"type": "Circle", "center": [1, 2], "radius": -5},
                    }
                ]
            },
            "radius",
        ),
        (
            {
                "geometry": [
                    {
                        "uomDimensions": "M",
                        "horizontalProjection": {"type": "Circle", "center": [1, 200], "radius": 5},
                    }
                ]
            },
            "center",
        ),
        (
            {
                "geometry": [
                    {
                        "uomDimensions": "M",
                        "horizontalProjection": {
                            "type": "Polygon",
                            "coordinates": [[[1, 2], [1, 2]]],
                        },
                    }
                ]
            },
            "3 distinct",
        ),
        (
            {"geometry": [{"uomDimensions": "M", "horizontalProjection": {"type": "Line"}}]},
            "Circle or Polygon",
        ),
        ({"applicability": [{"permanent": "NO", "startDateTime": "soon"}]}, "startDateTime"),
    ],
)
def test_ed269_errors_name_the_feature(tmp_path: Path, change: dict, words: str) -> None:
    doc = _ed269(
        {
            "uomDimensions": "M",
            "horizontalProjection": {"type": "Circle", "center": [1, 2], "radius": 5},
        }
    )
    doc["features"].insert(0, doc["features"][0])
    doc["features"][1] = {**doc["features"][1], **change}
    f = tmp_path / "bad.json"
    f.write_text(json.dumps(doc))
    with pytest.raises(ZoneFileError) as err:
        read_zone_file(f)
    assert str(err.value).startswith(f"{f}: feature 1 (ID 'TST9'): "), str(err.value)
    assert words in str(err.value)


def test_bad_json(tmp_path: Path) -> None:
    f = tmp_path / "x.json"
    f.write_text('{"features": [1, 2')
    with pytest.raises(ZoneFileError, match=r"x.json: invalid JSON"):
        read_zone_file(f)
    f.write_text('{"features": [{"restriction": NaN}]}')
    with pytest.raises(ZoneFileError, match="invalid JSON"):
        read_zone_file(f)
    f.write_text("[" * 100000)
    with pytest.raises(ZoneFileError):
        read_zone_file(f)


# ---------------------------------------------------------------------------------------------
# ED-318


def _ed318(geometry: dict, **props) -> dict:
    return {
        "type": "FeatureCollection",
        "features": [
            {
                "type": "Feature",
                "properties": {
                    "identifier": "A1",
                    "country": "FIN",
                    "name": [{"text": "Prison", "lang": "en-GB"}],
                    "type": "PROHIBITED",
                    "variant": "COMMON",
                    **props,
                },
                "geometry": geometry,
            }
        ],
    }


def test_ed318_polygon_layer(tmp_path: Path) -> None:
    (z,) = _read(
        tmp_path,
        _ed318(
            {
                "type": "Polygon",
                "coordinates": [
                    [[24.9, 60.1], [25.0, 60.1], [25.0, 60.2], [24.9, 60.1]],
                    [[24.95, 60.12], [24.96, 60.12], [24.96, 60.13], [24.95, 60.12]],
                ],
                "layer": {
                    "upper": 120,
                    "upperReference": "AGL",
                    "lower": 0,
                    "lowerReference": "AGL",
                    "uom": "m",
                },
            }
        ),
    )
    assert z.name == "Prison" and z.classes == ("PROHIBITED",)
    assert z.ring_lonlat == ((24.9, 60.1), (25.0, 60.1), (25.0, 60.2))
    assert z.ceiling.value_m == 120.0 and z.ceiling.reference is Reference.AGL
    assert any("hole" in n for n in z.notes)  # the hole is filled, and said


def test_ed318_point_circle_wgs84_feet_and_applicability(tmp_path: Path) -> None:
    (z,) = _read(
        tmp_path,
        _ed318(
            {
                "type": "Point",
                "coordinates": [24.9, 60.1],
                "extent": {"subType": "Circle", "radius": 750},
                "layer": {
                    "upper": 1000,
                    "upperReference": "WGS84",
                    "lower": 200,
                    "lowerReference": "AMSL",
                    "uom": "ft",
                },
            },
            type="REQ_AUTHORIZATION",
            limitedApplicability=[
                {
                    "startDateTime": "2026-12-01T10:00:00Z",
                    "endDateTime": "2026-12-01T11:00:00+01:00",
                }
            ],
        ),
    )
    assert z.circle == (24.9, 60.1, 750.0)
    assert z.floor.value_m == pytest.approx(200 * FOOT_M) and z.floor.reference is Reference.AMSL
    assert z.ceiling.value_m == pytest.approx(1000 * FOOT_M)
    assert z.ceiling.reference is Reference.WGS84
    t = lambda s: datetime.fromisoformat(s).replace(tzinfo=UTC)  # noqa: E731
    # 11:00+01:00 is 10:00Z: the window is empty after 10:00Z
    assert not z.activity.active_during(t("2026-12-01T10:01"), t("2026-12-01T10:30"))
    assert z.activity.active_during(t("2026-12-01T09:50"), t("2026-12-01T10:00"))


def test_ed318_multipolygon_and_errors(tmp_path: Path) -> None:
    layer = {"upper": 50, "upperReference": "AGL", "lower": 0, "lowerReference": "AGL"}
    a, b = _read(
        tmp_path,
        _ed318(
            {
                "type": "MultiPolygon",
                "layer": layer,
                "coordinates": [
                    [[[1, 1], [1.1, 1], [1.1, 1.1], [1, 1]]],
                    [[[2, 2], [2.1, 2], [2.1, 2.1], [2, 2]]],
                ],
            }
        ),
    )
    assert a.name == "Prison part 1" and b.ring_lonlat[0] == (2.0, 2.0)
    with pytest.raises(ZoneFileError, match=r"feature 0 \(ID 'A1'\): geometry.layer"):
        _read(tmp_path, _ed318({"type": "Polygon", "coordinates": [[[1, 1], [2, 1], [2, 2]]]}))
    with pytest.raises(ZoneFileError, match="extent"):
        _read(tmp_path, _ed318({"type": "Point", "coordinates": [1, 1], "layer": layer}))


def test_nautical_mile_and_foot() -> None:
    assert NAUTICAL_MILE_M == 1852.0 and FOOT_M == 0.3048


def test_sixty_seconds_as_real_files_write_them() -> None:
    # France's openAIP export writes 001:25:60 E for 001:26:00 E (it refused the file before)
    z = _one(
        "AC R\nAN S\nAL GND\nAH UNL\nDP 42:41:12 N 001:25:60 E\nDP 42:42:00 N 001:25:00 E\n"
        "DP 42:42:00 N 001:27:00 E\n"
    )
    assert list(z.ring_lonlat[0]) == pytest.approx([1 + 26 / 60, 42 + 41 / 60 + 12 / 3600])
    with pytest.raises(ZoneFileError, match="minutes or seconds"):
        parse_openair("AC R\nAN S\nAL GND\nAH UNL\nDP 42:41:61 N 001:25:00 E\n", "t.txt")
