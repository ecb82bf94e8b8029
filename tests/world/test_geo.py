"""EnuFrame: hand-checked values, independent geodesic checks and round-trip properties."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pyproj import Geod

from uavplan.geo import EnuFrame, GeoPoint

WGS84_A_M = 6378137.0
WGS84_F = 1.0 / 298.257223563
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)
GEOD = Geod(ellps="WGS84")


def prime_vertical_radius_m(lat_deg: float) -> float:
    s = math.sin(math.radians(lat_deg))
    return WGS84_A_M / math.sqrt(1.0 - WGS84_E2 * s * s)


# --- hand-checked values ----------------------------------------------------------------------


def test_one_km_east_at_the_equator() -> None:
    frame = EnuFrame.at(GeoPoint(0.0, 0.0, 0.0))
    lat, lon, alt = frame.to_geodetic([[1000.0, 0.0, 0.0]])
    # 1 km along the tangent at the equator: atan(1000 / a) = 0.0089831528° of longitude
    assert lon[0] == pytest.approx(0.0089831528, abs=1e-10)
    assert lon[0] == pytest.approx(math.degrees(math.atan(1000.0 / WGS84_A_M)), abs=1e-12)
    assert lat[0] == pytest.approx(0.0, abs=1e-12)
    # the tangent plane rises above the ellipsoid: sqrt(a² + d²) - a ≈ d² / 2a = 7.84 cm
    assert alt[0] == pytest.approx(math.hypot(WGS84_A_M, 1000.0) - WGS84_A_M, abs=1e-6)
    assert alt[0] == pytest.approx(0.0784, abs=1e-4)


def test_one_km_north_at_the_equator() -> None:
    frame = EnuFrame.at(GeoPoint(0.0, 0.0, 0.0))
    lat, lon, _ = frame.to_geodetic([[0.0, 1000.0, 0.0]])
    # meridian radius of curvature at the equator: a (1 - e²) = 6335439.327 m
    assert lat[0] == pytest.approx(math.degrees(1000.0 / (WGS84_A_M * (1 - WGS84_E2))), abs=1e-8)
    assert lat[0] == pytest.approx(0.0090437, abs=1e-7)
    assert lon[0] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("lat0_deg", [-72.5, -33.9, 0.0, 47.397742, 65.0, 78.2])
@pytest.mark.parametrize("alt0_m", [0.0, 488.0])
def test_east_offset_is_an_exact_longitude_step(lat0_deg: float, alt0_m: float) -> None:
    """A point on the east axis stays in the plane of the origin's parallel circle, so its
    longitude step is atan(d / ((N + h) cos φ)) exactly."""
    lon0_deg = 8.545594
    frame = EnuFrame.at(GeoPoint(lat0_deg, lon0_deg, alt0_m))
    d = 2500.0
    _, lon, _ = frame.to_geodetic([[d, 0.0, 0.0]])
    radius = (prime_vertical_radius_m(lat0_deg) + alt0_m) * math.cos(math.radians(lat0_deg))
    assert lon[0] - lon0_deg == pytest.approx(math.degrees(math.atan(d / radius)), abs=1e-11)


def test_up_axis_is_the_ellipsoid_normal() -> None:
    frame = EnuFrame.at(GeoPoint(-41.29, 174.78, 12.0))
    lat, lon, alt = frame.to_geodetic([[0.0, 0.0, 150.0]])
    assert (lat[0], lon[0]) == pytest.approx((-41.29, 174.78), abs=1e-11)
    assert alt[0] == pytest.approx(162.0, abs=1e-6)


@pytest.mark.parametrize(
    "origin",
    [GeoPoint(47.397742, 8.545594, 488.0), GeoPoint(-33.86, 151.21, 5.0), GeoPoint(69.65, 18.96)],
)
def test_distance_and_bearing_match_an_independent_geodesic(origin: GeoPoint) -> None:
    """Horizontal ENU offsets match pyproj.Geod's geodesic azimuth and distance.

    The geodesic runs on the ellipsoid (h = 0) below the tangent plane: a tangent-plane
    distance d at height h maps to about R·atan(d / (R + h)), R the radius of curvature
    in that azimuth (Euler): 16 mm shorter at 10 km and h = 5 m, 77 cm at h = 488 m.
    """
    frame = EnuFrame.at(origin)
    n = prime_vertical_radius_m(origin.lat_deg)
    s2 = math.sin(math.radians(origin.lat_deg)) ** 2
    m = WGS84_A_M * (1 - WGS84_E2) / (1 - WGS84_E2 * s2) ** 1.5  # meridian radius
    d = 10_000.0
    for bearing_deg in (0.0, 37.0, 90.0, 200.0, 315.0):
        b = math.radians(bearing_deg)
        radius = 1.0 / (math.cos(b) ** 2 / m + math.sin(b) ** 2 / n)
        lat, lon, _ = frame.to_geodetic([[d * math.sin(b), d * math.cos(b), 0.0]])
        az, _, dist = GEOD.inv(origin.lon_deg, origin.lat_deg, lon[0], lat[0])
        assert dist == pytest.approx(radius * math.atan(d / (radius + origin.alt_m)), abs=0.005)
        assert (az - bearing_deg + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=1e-4)


def test_crossing_the_antimeridian_wraps_the_longitude() -> None:
    frame = EnuFrame.at(GeoPoint(-16.5, 179.99, 0.0))
    lat, lon, alt = frame.to_geodetic([[5000.0, 0.0, 100.0]])
    assert -180.0 < lon[0] < -179.9
    back = frame.to_enu(lat, lon, alt)
    np.testing.assert_allclose(back, [[5000.0, 0.0, 100.0]], atol=1e-6)


def test_vectorised_shapes_and_broadcasting() -> None:
    frame = EnuFrame.at(GeoPoint(47.0, 8.0, 400.0))
    points = np.array([[0.0, 0.0, 0.0], [100.0, 200.0, 30.0], [-500.0, 40.0, 10.0]])
    lat, lon, alt = frame.to_geodetic(points)
    assert lat.shape == lon.shape == alt.shape == (3,)
    assert frame.to_enu(lat, lon, alt).shape == (3, 3)
    one = frame.to_geodetic(points[1])  # a single (3,) point
    assert one[0].shape == (1,)
    # scalars broadcast against arrays
    assert frame.to_enu(47.0, [8.0, 8.001], 400.0).shape == (2, 3)
    np.testing.assert_allclose(frame.to_enu(47.0, 8.0, 400.0), [[0.0, 0.0, 0.0]], atol=1e-6)


@pytest.mark.parametrize(
    "bad",
    [np.zeros((3, 2)), np.zeros((2, 3, 1)), [[0.0, np.nan, 0.0]], [[np.inf, 0.0, 0.0]]],
)
def test_bad_points_are_rejected(bad: object) -> None:
    frame = EnuFrame.at(GeoPoint(47.0, 8.0, 400.0))
    with pytest.raises(ValueError, match="points_enu"):
        frame.to_geodetic(bad)  # type: ignore[arg-type]


def test_bad_geodetic_input_is_rejected() -> None:
    frame = EnuFrame.at(GeoPoint(47.0, 8.0, 400.0))
    with pytest.raises(ValueError, match="latitude"):
        frame.to_enu(91.0, 8.0, 0.0)
    with pytest.raises(ValueError, match="finite"):
        frame.to_enu(47.0, np.nan, 0.0)
    with pytest.raises(TypeError):
        EnuFrame.at((47.0, 8.0, 400.0))  # type: ignore[arg-type]


def test_frames_are_values() -> None:
    a = EnuFrame.at(GeoPoint(47.0, 8.0, 400.0))
    a.to_geodetic([[1.0, 2.0, 3.0]])  # builds the cached transformer
    b = EnuFrame.at(GeoPoint(47.0, 8.0, 400.0))
    assert a == b and hash(a) == hash(b)
    with pytest.raises(AttributeError):
        a.origin = GeoPoint(0.0, 0.0)  # type: ignore[misc]


def test_import_has_no_side_effects_and_defers_pyproj() -> None:
    code = "import sys, uavplan.geo; assert 'pyproj' not in sys.modules, 'pyproj imported'"
    subprocess.run([sys.executable, "-c", code], check=True)


def test_written_out_pipeline_is_the_operation_proj_picks() -> None:
    """The frame's transformer is built from GEODETIC_TO_ECEF (no database lookup); it must be
    the operation PROJ itself picks for EPSG:4979 → EPSG:4978, with the same numbers."""
    from pyproj import Transformer

    from uavplan.geo import ECEF_CRS, GEODETIC_CRS, GEODETIC_TO_ECEF

    ours = Transformer.from_pipeline(GEODETIC_TO_ECEF)
    proj = Transformer.from_crs(GEODETIC_CRS, ECEF_CRS, always_xy=True)
    assert ours.definition == proj.definition
    rng = np.random.default_rng(7)
    lon, lat = rng.uniform(-180.0, 180.0, 500), rng.uniform(-90.0, 90.0, 500)
    h = rng.uniform(-500.0, 20_000.0, 500)
    for a, b in zip(ours.transform(lon, lat, h), proj.transform(lon, lat, h), strict=True):
        assert np.array_equal(a, b)
    xyz = proj.transform(lon, lat, h)
    back_ours = ours.transform(*xyz, direction="INVERSE")
    back_proj = proj.transform(*xyz, direction="INVERSE")
    for a, b in zip(back_ours, back_proj, strict=True):
        assert np.array_equal(a, b)


def test_conversions_are_vectorised_over_many_points() -> None:
    """100,000 points in one call each way (speed is measured by tools, not asserted)."""
    frame = EnuFrame.at(GeoPoint(47.397742, 8.545594, 488.0))
    points = np.random.default_rng(1).uniform(-20_000, 20_000, size=(100_000, 3))
    lat, lon, alt = frame.to_geodetic(points)
    assert lat.shape == lon.shape == alt.shape == (100_000,)
    np.testing.assert_allclose(frame.to_enu(lat, lon, alt), points, atol=1e-3)  # 20 km: < 1 mm


# --- properties ---------------------------------------------------------------------------------

origins = st.builds(
    GeoPoint,
    lat_deg=st.one_of(
        st.floats(-85.0, 85.0),
        st.floats(60.0, 85.0),  # high latitudes
        st.floats(-85.0, -60.0),
    ),
    lon_deg=st.one_of(
        st.floats(-180.0, 180.0),
        st.floats(179.5, 180.0),  # at the antimeridian
        st.floats(-180.0, -179.5),
    ),
    alt_m=st.floats(-100.0, 5000.0),
)
offsets_m = st.floats(-50_000.0, 50_000.0)
heights_m = st.floats(-200.0, 3000.0)


@settings(max_examples=100, deadline=None)
@given(origin=origins, x=offsets_m, y=offsets_m, z=heights_m)
def test_enu_geodetic_round_trip_is_better_than_a_centimetre(
    origin: GeoPoint, x: float, y: float, z: float
) -> None:
    frame = EnuFrame.at(origin)
    point = np.array([[x, y, z]])
    lat, lon, alt = frame.to_geodetic(point)
    assert -180.0 <= lon[0] <= 180.0
    back = frame.to_enu(lat, lon, alt)
    assert np.max(np.abs(back - point)) < 1e-4  # far better than the 1 cm required


@settings(max_examples=100, deadline=None)
@given(origin=origins, dlat=st.floats(-0.3, 0.3), dlon=st.floats(-0.3, 0.3), h=heights_m)
def test_geodetic_enu_round_trip(origin: GeoPoint, dlat: float, dlon: float, h: float) -> None:
    frame = EnuFrame.at(origin)
    lat0 = float(np.clip(origin.lat_deg + dlat, -89.0, 89.0))
    lon0 = (origin.lon_deg + dlon + 180.0) % 360.0 - 180.0
    enu = frame.to_enu(lat0, lon0, h)
    lat, lon, alt = frame.to_geodetic(enu)
    assert lat[0] == pytest.approx(lat0, abs=1e-9)
    assert (lon[0] - lon0 + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=1e-9)
    assert alt[0] == pytest.approx(h, abs=1e-4)


@settings(max_examples=100, deadline=None)
@given(origin=origins, x=offsets_m, y=offsets_m)
def test_ground_plane_xy_inverts_to_geodetic(origin: GeoPoint, x: float, y: float) -> None:
    frame = EnuFrame.at(origin)
    lat, lon, _ = frame.to_geodetic([[x, y, 0.0]])
    np.testing.assert_allclose(frame.to_enu_xy(lat, lon), [[x, y]], atol=1e-6)


@settings(max_examples=50, deadline=None)
@given(
    origin=origins,
    a=st.tuples(offsets_m, offsets_m, heights_m),
    b=st.tuples(offsets_m, offsets_m, heights_m),
)
def test_enu_distances_are_ecef_distances(origin: GeoPoint, a: tuple, b: tuple) -> None:
    frame = EnuFrame.at(origin)
    ecef = frame.to_ecef(np.array([a, b]))
    assert np.linalg.norm(ecef[0] - ecef[1]) == pytest.approx(math.dist(a, b), rel=1e-12, abs=1e-6)


@settings(max_examples=60, deadline=None)
@given(
    lat0=st.floats(-80.0, 80.0),
    lon0=st.floats(-179.0, 179.0),
    alt0=st.floats(-100.0, 4000.0),
    enu=st.tuples(
        st.floats(-30_000.0, 30_000.0), st.floats(-30_000.0, 30_000.0), st.floats(-500.0, 3000.0)
    ),
)
def test_one_point_conversions_agree_with_the_array_ones(
    lat0: float, lon0: float, alt0: float, enu: tuple[float, float, float]
) -> None:
    """The scalar conversions (a simulated flight's ground, one point per step) give what the
    array ones give, to a nanometre-scale tolerance, the origin exactly."""
    frame = EnuFrame.at(GeoPoint(lat0, lon0, alt0))
    lat, lon, alt = frame.to_geodetic(np.array(enu))
    one = frame.to_geodetic_point(*enu)
    assert one[0] == pytest.approx(float(lat[0]), abs=1e-12)
    assert one[1] == pytest.approx(float(lon[0]), abs=1e-12)
    assert one[2] == pytest.approx(float(alt[0]), abs=1e-8)
    xy = frame.to_enu_xy(lat, lon)[0]
    assert frame.to_enu_xy_point(float(lat[0]), float(lon[0])) == pytest.approx(
        (float(xy[0]), float(xy[1])), abs=1e-8
    )
    o = frame.origin
    assert frame.to_geodetic_point(0.0, 0.0, 0.0) == (o.lat_deg, o.lon_deg, o.alt_m)
