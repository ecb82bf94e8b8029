"""``fly``'s final check of the flown track, without a vehicle: the whole observed flight,
stretch by stretch, never a line drawn across a gap (issues 31 and 37)."""

from __future__ import annotations

import numpy as np
import pytest

from uavplan.app.fly import check_observed_flight
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.mission.track import Track, observed_stretches
from uavplan.rehearsal import CheckSite
from uavplan.scenario import load_scenario

ORIGIN = GeoPoint(47.397742, 8.545594, 488.0)


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> CheckSite:
    """A cylinder of radius 20 m at (100, 0), margin 10 m."""
    path = tmp_path_factory.mktemp("verdict") / "s.yaml"
    path.write_text(
        "name: one-post\n"
        f"origin: {{lat: {ORIGIN.lat_deg}, lon: {ORIGIN.lon_deg}, alt: {ORIGIN.alt_m}}}\n"
        "bounds: {x: [-50, 250], y: [-100, 100], z: [0, 120]}\n"
        "start: [0, 50, 30]\ngoal: [200, 50, 30]\nsafety_margin: 10\n"
        "obstacles:\n  - {type: cylinder, center: [100, 0], radius: 20, height: 100}\n",
        encoding="utf-8",
    )
    return CheckSite.of_scenario(load_scenario(path))


def _track(x_m: np.ndarray, z_m: np.ndarray) -> Track:
    """Samples 0.2 s apart (a missing one: a longer step) along y = 0."""
    lat, lon, _ = EnuFrame.at(ORIGIN).to_geodetic(np.column_stack((x_m, 0 * x_m, 0 * x_m)))
    t = x_m / 10.0  # 10 m/s: one sample each 2 m
    n = len(x_m)
    return Track(t, lat, lon, ORIGIN.alt_m + z_m, z_m, np.full(n, 10.0), np.zeros(n, int))


def _flight(gap: tuple[float, float] | None) -> Track:
    x = np.arange(0.0, 200.0 + 1e-9, 2.0)
    if gap is not None:
        x = x[(x <= gap[0]) | (x >= gap[1])]
    z = np.full(len(x), 30.0)
    z[0] = z[-1] = 0.0  # from the ground, to the ground
    return _track(x, z)


def test_a_track_through_an_obstacle_breaks_the_margin(site: CheckSite) -> None:
    check = check_observed_flight(_flight(None), site, lands=True)
    assert not check.ok and check.min_clearance_m == pytest.approx(0.0)
    assert check.unobserved == ()
    problem = check.problem()
    assert problem is not None and "comes within 0.00 m" in problem


def test_no_line_is_drawn_across_a_gap(site: CheckSite) -> None:
    """Issue 31: a gap was straight-lined ("0.0 m from obstacle #2"). Nothing was observed
    between 64 m and 136 m: the check says so, and measures the two stretches it saw."""
    track = _flight((64.0, 136.0))
    check = check_observed_flight(track, site, lands=True)
    assert check.ok, check.problem()
    assert check.min_clearance_m == pytest.approx(np.hypot(36.0, 0.0) - 20.0, abs=0.1)
    assert check.unobserved == ((6.4, 13.6),)
    assert check.unobserved_s == pytest.approx(7.2)
    assert len(check.checks) == 2


def test_observed_stretches_cut_where_a_step_is_longer_than_the_limit() -> None:
    assert observed_stretches([0.0, 0.2, 0.4, 3.0, 3.2, 9.0], 2.0) == [(0, 3), (3, 5), (5, 6)]
    assert observed_stretches([], 2.0) == []
    track = _flight((64.0, 136.0))
    assert track.gaps(2.0) == [(6.4, 13.6)]
    assert len(track.between(2, 5)) == 3
