"""Lanes around holes: no lane piece inside a hole's margin (checked independently with
shapely), lanes run to the edge, photo footprints cover the free area, the sweep of least
energy is chosen."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from shapely.geometry import LineString, Polygon, box

from uavplan.airframe import profiles
from uavplan.obstacles import BoxObstacle, CylinderObstacle, PrismObstacle
from uavplan.survey import coverage
from uavplan.survey.camera import Camera, camera_spacing
from uavplan.survey.sweep import energy_of, plan_sweep

FIELD = box(0, 0, 800, 500)


def test_holes_take_tall_obstacles_and_excludes_with_the_margin() -> None:
    tall = BoxObstacle((100.0, 100.0), (20.0, 20.0), 80.0)
    low = BoxObstacle((300.0, 100.0), (20.0, 20.0), 40.0)  # 40 < 60 − 10: flown over
    near = CylinderObstacle((500.0, 100.0), 5.0, 55.0)  # 55 > 60 − 10: a hole
    prism = PrismObstacle(((600.0, 300.0), (650.0, 300.0), (650.0, 350.0)), 100.0)
    ex = Polygon([(300, 200), (400, 200), (400, 300)])
    h = coverage.holes([tall, low, near, prism], [ex], altitude_m=60.0, margin_m=10.0)
    assert h.contains(shapely.Point(100, 100)) and h.contains(shapely.Point(100, 119))
    assert not h.contains(shapely.Point(300, 100))
    assert h.contains(shapely.Point(500, 114))
    assert h.contains(shapely.Point(640, 320))
    assert h.contains(shapely.Point(395, 210))
    assert not h.contains(shapely.Point(100, 125))


def test_lane_offsets_keep_the_outer_lanes_half_a_spacing_inside() -> None:
    off = coverage.lane_offsets_m(500.0, 30.0)
    assert len(off) == 17  # ceil(500 / 30)
    assert off[0] == pytest.approx(500 - off[-1])
    assert 0 < off[0] <= 15.0
    assert np.allclose(np.diff(off), 30.0)
    assert coverage.lane_offsets_m(20.0, 30.0) == pytest.approx([10.0])


def test_a_lane_split_by_a_hole_becomes_two_pieces_that_reach_the_boundary() -> None:
    hole = coverage.holes([], [box(300, 200, 400, 300)], altitude_m=60.0, margin_m=10.0)
    free = coverage.free_area(FIELD, hole)
    pieces = coverage.lanes(FIELD, free, angle_deg=0.0, spacing_m=50.0)
    ys = pieces[:, 0, 1]
    at_250 = pieces[np.isclose(ys, 225.0)]  # lanes at 25, 75, …, 475
    assert len(at_250) == 2
    assert at_250[0, 0, 0] == pytest.approx(0.0) and at_250[1, 1, 0] == pytest.approx(800.0)
    # the 10 m margin and the 0.1 m slack, rounded outward (the buffer's chords lie outside)
    slack = coverage.HOLE_SLACK_M
    assert 289.8 < at_250[0, 1, 0] + slack <= 290.0 and 410.0 <= at_250[1, 0, 0] - slack < 410.1
    assert len(pieces) == 10 + 2  # two lanes (225, 275) split in two


def test_order_is_boustrophedon_on_a_rectangle() -> None:
    pieces = coverage.lanes(FIELD, FIELD, angle_deg=0.0, spacing_m=100.0)
    ordered = coverage.order(pieces, (0.0, 0.0))
    assert np.allclose(ordered[:, 0, 1], [50, 150, 250, 350, 450])
    assert np.allclose(ordered[::2, 0, 0], 0.0) and np.allclose(ordered[1::2, 0, 0], 800.0)


rect = st.tuples(st.floats(10, 290), st.floats(10, 190), st.floats(5, 60), st.floats(5, 60)).map(
    lambda t: box(t[0], t[1], t[0] + t[2], t[1] + t[3])
)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    w=st.floats(80, 400),
    h=st.floats(80, 300),
    rects=st.lists(rect, min_size=0, max_size=4),
    angle=st.floats(0, 180),
    spacing=st.floats(8, 60),
    margin=st.floats(0, 15),
)
def test_no_lane_piece_enters_a_hole_or_its_margin(
    w: float, h: float, rects: list[Polygon], angle: float, spacing: float, margin: float
) -> None:
    area = box(0, 0, w, h)
    hole = coverage.holes([], rects, altitude_m=50.0, margin_m=margin)
    free = coverage.free_area(area, hole)
    pieces = coverage.lanes(area, free, angle_deg=angle, spacing_m=spacing)
    for a, b in pieces:
        seg = LineString([a, b])
        for r in rects:  # independent check: distance to each raw exclude polygon
            assert seg.distance(r) >= margin - 1e-6
        assert area.buffer(1e-6).contains(seg)
        # the piece ends on the free area's boundary: it is not cut short
        assert free.boundary.distance(shapely.Point(a)) < 1e-6
        assert free.boundary.distance(shapely.Point(b)) < 1e-6


def test_photo_footprints_cover_the_free_area() -> None:
    cam = Camera(13.2, 8.8, 5472, 3648, 10.4)
    sp = camera_spacing(cam, altitude_m=60.0)
    concave = Polygon([(0, 0), (600, 0), (600, 400), (350, 400), (300, 150), (250, 400), (0, 400)])
    hole = coverage.holes(
        [BoxObstacle((150.0, 200.0), (40.0, 30.0), 90.0)], [], altitude_m=60.0, margin_m=10.0
    )
    free = coverage.free_area(concave, hole)
    s = plan_sweep(
        concave,
        free,
        spacing_m=sp.lane_spacing_m,
        trigger_m=sp.trigger_distance_m,
        start_xy=(0.0, 0.0),
        energy=energy_of(profiles.get("x500"), altitude_m=60.0, speed_m_s=8.0),
        angle_deg=30.0,
    )
    photos = coverage.photo_positions(s.pieces_xy, sp.trigger_distance_m)
    assert len(photos) == s.photos
    assert sp.footprint_side_m is not None and sp.footprint_front_m is not None
    fp = coverage.footprints(photos, 30.0, sp.footprint_side_m, sp.footprint_front_m)
    assert coverage.covered_fraction(free, fp) >= 0.99
    # footprints smaller than the lane spacing and trigger distance leave gaps: the check fails
    small = coverage.footprints(photos, 30.0, 0.9 * sp.lane_spacing_m, 0.9 * sp.trigger_distance_m)
    assert coverage.covered_fraction(free, small) < 0.9


def test_auto_angle_picks_the_least_energy_not_another_angle() -> None:
    area = box(0, 0, 1000, 120)  # long and thin: lanes along x need few turns
    energy = energy_of(profiles.get("x500"), altitude_m=60.0, speed_m_s=8.0)
    args = {"spacing_m": 30.0, "trigger_m": 30.0, "start_xy": (0.0, 0.0), "energy": energy}
    best = plan_sweep(area, area, **args)  # type: ignore[arg-type]
    for a in coverage.candidate_angles_deg(area):
        assert best.energy_wh <= plan_sweep(area, area, angle_deg=float(a), **args).energy_wh + 1e-9  # type: ignore[arg-type]
    assert best.angle_deg in (0.0, 180.0) or abs(best.angle_deg % 180) < 1e-6
    across = plan_sweep(area, area, angle_deg=90.0, **args)  # type: ignore[arg-type]
    assert across.energy_wh > best.energy_wh


def test_no_lane_fits_is_an_error() -> None:
    energy = energy_of(profiles.get("x500"), altitude_m=60.0, speed_m_s=8.0)
    with pytest.raises(ValueError, match="no lane"):
        plan_sweep(FIELD, Polygon(), spacing_m=30.0, trigger_m=30.0, start_xy=(0, 0), energy=energy)
