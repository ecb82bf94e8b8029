"""The ``airspace:`` key: which zones become constraints and why, the vertical conversions,
plan / validate / fence with zones, and the bundled scenario near Zurich checked by an
independent construction of its zone volumes with shapely."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import shapely
from click.testing import CliRunner
from pyproj import Geod

from uavplan.cli import main
from uavplan.errors import ScenarioError
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.scenario import Scenario
from uavplan.scenario.zones import (
    DEFAULT_AVOID,
    STD_CEILING_RISE_M,
    STD_FLOOR_DROP_M,
    ZoneUse,
)

ROOT = Path(__file__).resolve().parents[2]
ORIGIN = (47.395, 8.545, 488.0)
FRAME = EnuFrame.at(GeoPoint(*ORIGIN))


def _latlon(x: float, y: float) -> tuple[float, float]:
    lat, lon, _ = FRAME.to_geodetic([[x, y, 0.0]])
    return float(lat[0]), float(lon[0])


def _dms(value: float, pos: str, neg: str) -> str:
    h = pos if value >= 0 else neg
    v = abs(value)
    d = int(v)
    m = int((v - d) * 60)
    s = (v - d - m / 60) * 3600
    return f"{d:02d}:{m:02d}:{s:06.3f}{h}"


def _box(x0: float, y0: float, x1: float, y1: float) -> str:
    lines = []
    for x, y in ((x0, y0), (x1, y0), (x1, y1), (x0, y1)):
        lat, lon = _latlon(x, y)
        lines.append(f"DP {_dms(lat, 'N', 'S')} {_dms(lon, 'E', 'W')}")
    return "\n".join(lines) + "\n"


def _zone(name: str, cls: str, floor: str, ceiling: str, box: tuple, extra: str = "") -> str:
    return f"AC {cls}\nAN {name}\nAL {floor}\nAH {ceiling}\n{extra}" + _box(*box)


def _scenario(tmp_path: Path, zones: str, airspace: str = "", **keys: str) -> Path:
    (tmp_path / "zones.txt").write_text(zones)
    text = (
        "name: zt\n"
        f"origin: {{lat: {ORIGIN[0]}, lon: {ORIGIN[1]}, alt: {ORIGIN[2]}}}\n"
        "bounds: {x: [-600, 1600], y: [-500, 500], z: [0, 120]}\n"
        "start: [-400, 0, 30]\ngoal: [1400, 0, 30]\n"
        f"airspace: {{files: [zones.txt]{airspace}}}\n"
        "planner: {seed: 1, iterations: 200}\n"
    )
    for k, v in keys.items():
        text += f"{k}: {v}\n"
    path = tmp_path / "s.yaml"
    path.write_text(text)
    return path


def _decision(scn: Scenario, name: str):
    assert scn.airspace is not None
    return next(d for d in scn.airspace.decisions if d.zone.name == name)


# ---------------------------------------------------------------------------------------------
# Decisions


def test_decisions_each_with_its_reason(tmp_path: Path) -> None:
    zones = (
        _zone("CROSS", "R", "GND", "500ft AGL", (400, -700, 600, 700))
        + _zone("HIGH", "R", "FL95", "FL195", (0, -700, 200, 700))
        + _zone("CLASS E", "E", "GND", "FL95", (800, -700, 900, 700))
        + _zone("FAR", "P", "GND", "UNL", (50000, 0, 50100, 100))
        + _zone("ABOVE AGL", "R", "500ft AGL", "FL95", (-300, -700, -200, 700))
        + _zone("UNDER", "R", "100m AGL", "FL95", (1000, -700, 1100, 700))
    )
    scn = Scenario.from_file(_scenario(tmp_path, zones))
    cross, high = _decision(scn, "CROSS"), _decision(scn, "HIGH")
    assert cross.use is ZoneUse.CONSTRAINT and "overlaps the flight band" in cross.reason
    assert high.use is ZoneUse.ABOVE and "950 hPa" in high.reason
    assert _decision(scn, "CLASS E").use is ZoneUse.NOT_AVOIDED
    far = _decision(scn, "FAR")
    assert far.use is ZoneUse.OUTSIDE and "km from the flight area" in far.reason
    # 500 ft = 152.4 m >= the 120 m ceiling plus the 10 m margin
    assert _decision(scn, "ABOVE AGL").use is ZoneUse.ABOVE
    under = _decision(scn, "UNDER")  # 100 m AGL < 130 m: in the band, modelled from the ground
    assert under.use is ZoneUse.CONSTRAINT and "modelled from the ground" in under.reason
    # the constraints are obstacles, named after their zones
    names = [scn.obstacle_name(i) for i in range(len(scn.obstacles))]
    assert names == [
        "zone 'CROSS' (R, restricted) of zones.txt",
        "zone 'UNDER' (R, restricted) of zones.txt",
    ]
    # flat ground: an AGL ceiling of 152.4 m is cut at the ceiling + margin + 10 m pad
    assert scn.obstacles[0].height_m == pytest.approx(120 + 10 + 10)
    report = scn.airspace.report()
    assert report["zones_read"] == 6 and report["constraints"] == 2
    assert {z["name"]: z["use"] for z in report["zones"]}["HIGH"] == "floor above the flight volume"


def test_flight_level_allowance_hand_computed() -> None:
    # ICAO standard atmosphere: h(p) = 44330.77 (1 - (p / 1013.25)^0.190263)
    assert STD_FLOOR_DROP_M == pytest.approx(540.3, abs=0.1)
    assert STD_CEILING_RISE_M == pytest.approx(301.5, abs=0.2)


def test_flight_level_floor_near_the_band_is_a_constraint(tmp_path: Path) -> None:
    # FL20 = 609.6 m pressure altitude, at least 69.3 m AMSL with 950 hPa: below the flight
    # volume's top (488 + 120 m) plus the margin
    zones = _zone("LOW FL", "R", "FL20", "FL50", (400, -700, 600, 700))
    scn = Scenario.from_file(_scenario(tmp_path, zones))
    d = _decision(scn, "LOW FL")
    assert d.use is ZoneUse.CONSTRAINT
    assert d.floor_amsl_m == pytest.approx(609.6 - STD_FLOOR_DROP_M)
    assert d.ceiling_amsl_m == pytest.approx(5000 * 0.3048 + STD_CEILING_RISE_M)
    # FL21 = 640.08 m: at least 99.8 m AMSL ... still a constraint; FL40 (1219.2 m → 678.9 m
    # AMSL) is above 488 + 120 + 10 = 618 m: not
    zones = _zone("FL40", "R", "FL40", "FL50", (400, -700, 600, 700))
    scn = Scenario.from_file(_scenario(tmp_path, zones))
    assert _decision(scn, "FL40").use is ZoneUse.ABOVE


def test_amsl_ceiling_height_over_flat_ground(tmp_path: Path) -> None:
    # 2000 ft AMSL = 609.6 m; the ground is at 488 m: 121.6 m above it
    zones = _zone("CTR", "D", "GND", "2000ft AMSL", (400, -700, 600, 700))
    scn = Scenario.from_file(_scenario(tmp_path, zones))
    assert scn.obstacles[0].height_m == pytest.approx(121.6)


def test_avoid_and_at(tmp_path: Path) -> None:
    window = "AA 2026-12-05T08:00Z/2026-12-05T16:00Z\n"
    zones = _zone("TRA", "TRA", "GND", "500ft AGL", (400, -700, 600, 700), window)
    # without `at` every zone is active (and the reason says why)
    scn = Scenario.from_file(_scenario(tmp_path, zones))
    d = _decision(scn, "TRA")
    assert d.use is ZoneUse.CONSTRAINT and "no airspace.at" in d.reason
    # at another day: inactive for the whole flight (the battery's longest flight)
    scn = Scenario.from_file(_scenario(tmp_path, zones, ", at: 2026-12-01T09:00:00Z"))
    assert _decision(scn, "TRA").use is ZoneUse.INACTIVE
    # taking off 20 minutes before it activates: active during the flight
    scn = Scenario.from_file(_scenario(tmp_path, zones, ", at: '2026-12-05T07:40:00Z'"))
    assert _decision(scn, "TRA").use is ZoneUse.CONSTRAINT
    # a list that leaves TRA out: not avoided
    scn = Scenario.from_file(_scenario(tmp_path, zones, ", avoid: [R, P]"))
    assert _decision(scn, "TRA").use is ZoneUse.NOT_AVOIDED
    assert "TRA" in DEFAULT_AVOID


def test_start_inside_a_zone_is_refused_naming_it(tmp_path: Path) -> None:
    zones = _zone("HOME CTR", "CTR", "GND", "2500ft MSL", (-500, -100, -300, 100))
    with pytest.raises(ScenarioError) as err:
        Scenario.from_file(_scenario(tmp_path, zones))
    assert "start" in str(err.value) and "zone 'HOME CTR' (CTR, control zone)" in str(err.value)


@pytest.mark.parametrize(
    ("airspace", "words"),
    [
        (", avoid: 5", "airspace.avoid"),
        (", at: tomorrow", "airspace.at"),
        (", at: 2026-12-01", "time of day"),
        (", colour: red", "unknown key"),
    ],
)
def test_key_errors(tmp_path: Path, airspace: str, words: str) -> None:
    with pytest.raises(ScenarioError, match=words):
        Scenario.from_file(
            _scenario(tmp_path, _zone("A", "R", "GND", "UNL", (0, 0, 1, 1)), airspace)
        )


def test_bad_zone_file_is_one_message(tmp_path: Path) -> None:
    path = _scenario(tmp_path, "AC R\nAN A\nAL GND\nAH 100ft AGL\nDP 47:30:00N nowhere\n")
    result = CliRunner().invoke(main, ["validate", str(path)])
    assert result.exit_code == 2
    assert result.stderr.strip() == (
        f"error: {path}: airspace.files[0]: {tmp_path / 'zones.txt'}: line 5: cannot read the "
        "position '47:30:00N nowhere' (47:30:00N 008:30:00E)"
    )
    missing = tmp_path / "s2.yaml"
    missing.write_text(path.read_text().replace("zones.txt", "nope.txt"))
    result = CliRunner().invoke(main, ["validate", str(missing)])
    assert result.exit_code == 2 and "nope.txt: file not found" in result.stderr


# ---------------------------------------------------------------------------------------------
# Plan, validate, fence


@pytest.mark.slow
def test_route_flies_over_a_low_agl_zone_where_the_ceiling_allows(tmp_path: Path) -> None:
    # a zone across the whole flight area up to 50 m above the ground: no way round, so the
    # route climbs over it and keeps the margin above its ceiling
    zones = _zone("WIDE LOW", "R", "GND", "50m AGL", (400, -700, 600, 700))
    path = _scenario(tmp_path, zones)
    out, report = tmp_path / "o.plan", tmp_path / "r.json"
    result = CliRunner().invoke(
        main, ["plan", str(path), "-o", str(out), "--report", str(report), "--fence"]
    )
    assert result.exit_code == 0, result.output + result.stderr
    r = json.loads(report.read_text())
    assert r["collision_free"] and r["min_clearance_m"] >= 10.0
    assert r["airspace"]["constraints"] == 1
    scn = Scenario.from_file(path)
    from uavplan.app.check import read_mission_flight

    _, flight = read_mission_flight(str(out), scn)
    pts = flight.points_enu
    over = (pts[:, 0] > 390) & (pts[:, 0] < 610)
    assert over.any() and pts[over, 2].min() >= 60.0 - 1e-6  # 50 m + the 10 m margin
    # the fence cannot hold a zone that is flown over, and says so
    assert "cannot be expressed in the fence" in result.output + result.stderr


def test_validate_names_each_infringed_zone(tmp_path: Path) -> None:
    zones = _zone("FIRST", "R", "GND", "500ft AGL", (300, -100, 400, 100)) + _zone(
        "SECOND", "P", "GND", "500ft AGL", (900, -100, 1000, 100)
    )
    path = _scenario(tmp_path, zones)
    # a straight mission through both zones, planned without them
    plain = tmp_path / "plain.yaml"
    plain.write_text(path.read_text().replace("airspace: {files: [zones.txt]}\n", ""))
    mission = tmp_path / "straight.plan"
    result = CliRunner().invoke(main, ["plan", str(plain), "-o", str(mission), "-q"])
    assert result.exit_code == 0, result.stderr
    result = CliRunner().invoke(main, ["validate", str(mission), "--scenario", str(path)])
    assert result.exit_code == 3
    assert (
        "airspace infringed: zone 'FIRST' (R, restricted) of zones.txt entered; zone 'SECOND'"
        " (P, prohibited) of zones.txt entered" in result.stderr
    )


def test_plan_prints_the_zones_and_why(tmp_path: Path) -> None:
    zones = _zone("CROSS", "R", "GND", "500ft AGL", (400, -300, 600, 300)) + _zone(
        "HIGH", "R", "FL95", "FL195", (0, -700, 200, 700)
    )
    path = _scenario(tmp_path, zones)
    result = CliRunner().invoke(main, ["validate", str(path)])
    assert result.exit_code == 0, result.stderr
    assert "airspace: 2 zone(s) read from zones.txt; 1 constraint(s)" in result.output
    assert "zone 'HIGH' (R, restricted) FL95–FL195: not a constraint: floor FL95" in result.output


@pytest.mark.slow
def test_fence_simplifies_a_round_zone_outward(tmp_path: Path) -> None:
    lat, lon = _latlon(500, 300)
    zones = (
        "AC R\nAN ROUND\nAL GND\nAH 500ft AGL\n"
        f"V X={_dms(lat, 'N', 'S')} {_dms(lon, 'E', 'W')}\nDA 0.1, 0, 180\nDA 0.1, 180, 360\n"
    )
    path = _scenario(tmp_path, zones)
    scn = Scenario.from_file(path)
    assert len(scn.obstacles[0].footprint()) > 12
    result = CliRunner().invoke(
        main, ["plan", str(path), "-o", str(tmp_path / "o.plan"), "--fence"]
    )
    assert result.exit_code == 0, result.stderr
    line = next(x for x in result.output.splitlines() if "ROUND" in x and "fenced" in x)
    assert "simplified outward to at most 12 vertices" in line
    from uavplan.mission.zonefence import simplify_outward

    ring = np.asarray(scn.obstacles[0].footprint())
    simple, error = simplify_outward(ring)
    assert len(simple) <= 12 and 0 < error < 30
    assert shapely.Polygon(simple).covers(shapely.Polygon(ring))


# ---------------------------------------------------------------------------------------------
# The bundled scenario, checked independently


BUNDLED = ROOT / "missions" / "zurich-airspace.yaml"
GEOD = Geod(ellps="WGS84")
ARP = (8 + 32 / 60 + 57 / 3600, 47 + 27 / 60 + 53 / 3600)  # LSZH, lon, lat


@pytest.fixture(scope="module")
def bundled(tmp_path_factory: pytest.TempPathFactory) -> tuple[Scenario, np.ndarray, dict]:
    out = tmp_path_factory.mktemp("zurich")
    plan, report = out / "z.plan", out / "z.json"
    result = CliRunner().invoke(
        main, ["plan", str(BUNDLED), "-o", str(plan), "--report", str(report), "-q"]
    )
    assert result.exit_code == 0, result.stderr
    scn = Scenario.from_file(BUNDLED)
    from uavplan.app.check import read_mission_flight

    _, flight = read_mission_flight(str(plan), scn)
    return scn, flight.points_enu, json.loads(report.read_text())


def _enu_ring(frame: EnuFrame, lonlat: np.ndarray) -> shapely.Polygon:
    xy = frame.to_enu_xy(lonlat[:, 1], lonlat[:, 0])
    return shapely.Polygon(xy)


def _independent_ctr(frame: EnuFrame) -> shapely.Polygon:
    """The test CTR built without our reader: the true southern half circle of 3.5 NM
    around the ARP (geodesic points every 0.25°: inside the true arc by at most
    r (1 - cos 0.125°) = 0.015 m) and the two points to the north."""
    bearings = np.arange(90.0, 270.0 + 1e-9, 0.25)
    lon, lat, _ = GEOD.fwd(
        np.full(len(bearings), ARP[0]),
        np.full(len(bearings), ARP[1]),
        bearings,
        np.full(len(bearings), 3.5 * 1852.0),
    )
    north = np.array([[8 + 27 / 60 + 50 / 3600, 47.55], [8 + 38 / 60 + 5 / 3600, 47.55]])
    ring = np.vstack([np.column_stack([lon, lat]), north])
    return _enu_ring(frame, ring)


@pytest.mark.slow
def test_bundled_zone_decisions(bundled) -> None:
    _, _, report = bundled
    use = {z["name"]: z["use"] for z in report["airspace"]["zones"]}
    assert use == {
        "ZURICH CTR (test)": "constraint",
        "LS-R TEST (made up)": "floor above the flight volume",
        "TRA EVENT (test)": "inactive during the flight",
        "ZUERICHBERG RESERVE (test)": "constraint",
        "MODEL FLYING FIELD (test)": "not avoided",
    }
    assert report["collision_free"]


@pytest.mark.slow
def test_bundled_route_keeps_the_margin_from_the_ctr_independently(bundled) -> None:
    scn, points, _ = bundled
    site = scn.site
    frame = EnuFrame.at(site.origin)
    ctr = _independent_ctr(frame)
    # the CTR's ceiling, 2500 ft AMSL = 762 m, is above anything the route can reach (the
    # highest ground plus 120 m, plus the margin): the route must keep the margin sideways
    top_site = 762.0 - site.origin.alt_m
    assert points[:, 2].max() + scn.safety_margin_m < top_site
    track = shapely.LineString(points[:, :2])
    assert track.distance(ctr) >= scn.safety_margin_m - 1e-6


@pytest.mark.slow
def test_bundled_route_keeps_the_margin_from_the_reserve_independently(bundled) -> None:
    """The reserve, 0-50 m above the ground, as the true volume: every point above the
    polygon up to the DEM's surface plus 50 m (the DEM read with rasterio, bilinear), sampled
    on a 1 m grid; the sampled distance overstates the true one by at most the grid's half
    diagonal (0.71 m) plus the bilinear surface between the samples."""
    import rasterio
    from scipy.interpolate import RegularGridInterpolator
    from scipy.spatial import cKDTree

    scn, points, _ = bundled
    site = scn.site
    frame = EnuFrame.at(site.origin)
    doc = json.loads((ROOT / "missions" / "zurich-zones.json").read_text())
    coords = np.asarray(doc["features"][0]["geometry"][0]["horizontalProjection"]["coordinates"][0])
    reserve = _enu_ring(frame, coords)
    with rasterio.open(ROOT / "maps" / "zurich-north-synthetic-dem.tif") as src:
        z = src.read(1).astype(float)
        t = src.transform
    lons = t.c + (np.arange(z.shape[1]) + 0.5) * t.a
    lats = t.f + (np.arange(z.shape[0]) + 0.5) * t.e
    dem = RegularGridInterpolator((lats[::-1], lons), z[::-1])

    def ground_site(xy: np.ndarray) -> np.ndarray:
        lat, lon, _ = frame.to_geodetic(np.column_stack([xy, np.zeros(len(xy))]))
        return dem(np.column_stack([lat, lon])) - site.origin.alt_m

    # only the route's part near the reserve matters
    near = np.array([reserve.distance(shapely.Point(p[:2])) < 40.0 for p in points])
    if not near.any():
        assert shapely.LineString(points[:, :2]).distance(reserve) >= scn.safety_margin_m
        return
    x0, y0, x1, y1 = reserve.bounds
    gx, gy = np.meshgrid(np.arange(x0, x1 + 1, 1.0), np.arange(y0, y1 + 1, 1.0))
    grid = np.column_stack([gx.ravel(), gy.ravel()])
    inside = shapely.contains_xy(reserve, grid[:, 0], grid[:, 1])
    grid = grid[inside]
    top = ground_site(grid) + 50.0
    samples = np.column_stack([grid, top])
    # densify the route near the reserve (0.5 m steps) and measure to the top surface
    seg = [
        (a, b) for a, b, n in zip(points[:-1], points[1:], near[:-1] | near[1:], strict=True) if n
    ]
    dense = np.vstack(
        [
            a + (b - a) * s
            for a, b in seg
            for s in np.linspace(0, 1, max(2, int(np.linalg.norm(b - a) / 0.5)))[:, None]
        ]
    )
    dist, _ = cKDTree(samples).query(dense)
    above = dense[:, 2] >= ground_site(dense[:, :2]) + 50.0  # no point is inside the volume
    inside_xy = shapely.contains_xy(reserve, dense[:, 0], dense[:, 1])
    assert np.all(above | ~inside_xy)
    assert dist.min() - 0.71 - 0.5 >= scn.safety_margin_m - 1e-6, dist.min()


@pytest.mark.slow
def test_bundled_route_crosses_the_zones_that_do_not_bind(bundled) -> None:
    """'Exactly the ones it must': the route flies through the footprints of the restricted
    area (its floor far above) and of the reserved area (inactive at the take-off time)."""
    scn, points, _ = bundled
    frame = EnuFrame.at(scn.site.origin)
    track = shapely.LineString(points[:, :2])

    def dms(text: str) -> float:
        d, m, s = (float(v) for v in text[:-1].split(":"))
        return d + m / 60 + s / 3600

    r_area = _enu_ring(
        frame,
        np.array(
            [
                [dms("008:31:40E"), dms("47:24:58N")],
                [dms("008:31:40E"), dms("47:24:14N")],
                [dms("008:32:10E"), dms("47:24:14N")],
                [dms("008:32:10E"), dms("47:24:58N")],
            ]
        ),
    )
    tra_c = frame.to_enu_xy([dms("47:24:27.5N")], [dms("008:32:25.1E")])[0]
    tra = shapely.Point(*tra_c).buffer(0.2 * 1852.0)
    assert track.intersects(r_area)
    assert track.intersects(tra)
    assert math.isfinite(track.length)


@pytest.mark.slow
def test_exports_and_pictures_name_the_zones(tmp_path: Path) -> None:
    zones = _zone("CROSS", "R", "GND", "500ft AGL", (400, -300, 600, 300))
    path = _scenario(tmp_path, zones)
    out = tmp_path / "o.geojson"
    result = CliRunner().invoke(main, ["plan", str(path), "-o", str(out), "-q"])
    assert result.exit_code == 0, result.stderr
    features = json.loads(out.read_text())["features"]
    zone = next(f["properties"] for f in features if f["properties"].get("kind") == "obstacle")
    assert (zone["zone"], zone["zone_class"], zone["floor"], zone["ceiling"]) == (
        "CROSS",
        "R, restricted",
        "GND",
        "500ft AGL",
    )
    kml = tmp_path / "o.kml"
    assert CliRunner().invoke(main, ["plan", str(path), "-o", str(kml), "-q"]).exit_code == 0
    assert "<name>CROSS (R, restricted, GND–500ft AGL)</name>" in kml.read_text()
    from uavplan.render import scene_for

    assert scene_for(Scenario.from_file(path)).zone_labels == {0: "CROSS\nGND–500ft AGL"}
    png = tmp_path / "o.png"
    result = CliRunner().invoke(main, ["render", str(path), "-o", str(png), "--iterations", "50"])
    assert result.exit_code == 0, result.stderr


def test_rerouting_a_plan_names_the_zones_it_crossed(tmp_path: Path) -> None:
    zones = _zone("FIRST", "R", "GND", "500ft AGL", (300, -100, 400, 100)) + _zone(
        "SECOND", "P", "GND", "500ft AGL", (900, -100, 1000, 100)
    )
    path = _scenario(tmp_path, zones)
    plain = tmp_path / "plain.yaml"
    text = path.read_text().replace("airspace: {files: [zones.txt]}\n", "")
    # landing at the goal: a return to launch from there would be the autopilot's straight
    # line home through both zones (the next test)
    plain.write_text(text + "mission: {spacing: 5000, end: land}\n")
    straight = tmp_path / "straight.plan"
    assert CliRunner().invoke(main, ["plan", str(plain), "-o", str(straight), "-q"]).exit_code == 0
    out = tmp_path / "rerouted.plan"
    result = CliRunner().invoke(
        main, ["plan", str(straight), "--scenario", str(path), "-o", str(out)]
    )
    assert result.exit_code == 0, result.stderr
    lines = result.output.splitlines()
    assert "airspace: the plan as written enters zone 'FIRST' (R, restricted) of zones.txt" in lines
    assert (
        "airspace: the plan as written enters zone 'SECOND' (P, prohibited) of zones.txt" in lines
    )
    result = CliRunner().invoke(main, ["validate", str(out), "--scenario", str(path)])
    assert result.exit_code == 0, result.stderr


def test_a_rerouted_plan_whose_return_crosses_a_zone_is_refused(tmp_path: Path) -> None:
    """The plan's own return to launch is the autopilot's straight line home, which a reroute
    does not change: through a restricted zone, the whole flight is refused (exit 3), the
    zone and the return named, and nothing is written."""
    zones = _zone("FIRST", "R", "GND", "500ft AGL", (300, -100, 400, 100))
    path = _scenario(tmp_path, zones)
    plain = tmp_path / "plain.yaml"
    text = path.read_text().replace("airspace: {files: [zones.txt]}\n", "")
    plain.write_text(text + "mission: {spacing: 5000, end: rtl}\n")
    straight = tmp_path / "straight.plan"
    assert CliRunner().invoke(main, ["plan", str(plain), "-o", str(straight), "-q"]).exit_code == 0
    out = tmp_path / "rerouted.plan"
    result = CliRunner().invoke(
        main, ["plan", str(straight), "--scenario", str(path), "-o", str(out)]
    )
    assert result.exit_code == 3, result.output
    assert "during the return to launch" in result.stderr
    assert "zone 'FIRST' (R, restricted)" in result.stderr
    assert not out.exists()


def test_fly_and_simulate_check_name_the_zones(tmp_path: Path) -> None:
    """``fly --scenario`` and ``simulate`` check the track in the scenario's CheckSite, whose
    names are the scenario's: a zone's solid is named after its zone, so the live warning
    ("the vehicle is 4.2 m from zone 'CROSS' (R, restricted) of zones.txt") names it."""
    from uavplan.flightcheck import Flight, check_flight
    from uavplan.rehearsal import CheckSite

    zones = _zone("CROSS", "R", "GND", "500ft AGL", (400, -300, 600, 300))
    scn = Scenario.from_file(_scenario(tmp_path, zones))
    site = CheckSite.of_scenario(scn)
    assert site.name_of(0) == "zone 'CROSS' (R, restricted) of zones.txt"
    line = np.array([[0.0, 0.0, 30.0], [395.0, 0.0, 30.0]])
    check = check_flight(site.world, Flight(line, (0, 1)), name_of=site.name_of)
    assert not check.keeps_margin
    assert check.nearest == "zone 'CROSS' (R, restricted) of zones.txt"
