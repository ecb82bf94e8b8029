"""uavplan.geometry2d against hand-computed values: areas, orientation, convexity, crossings,
hull, point in polygon, distances, the conservative tangent-cut offset, convex pieces."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uavplan import geometry2d as g2

SQUARE = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])  # ccw, area 100
# an L, counter-clockwise: the square notch x > 10, y > 10 is outside it; area 40*10 + 10*30
L_RING = np.array([[0, 0], [40, 0], [40, 10], [10, 10], [10, 40], [0, 40]], dtype=float)
BOWTIE = np.array([[0.0, 0.0], [10.0, 10.0], [10.0, 0.0], [0.0, 10.0]])  # edges 0 and 2 cross


# ---------------------------------------------------------------------------------------------
# area, orientation, convexity, turns


def test_signed_area_and_orientation() -> None:
    assert g2.signed_area(SQUARE) == 100.0
    assert g2.signed_area(SQUARE[::-1]) == -100.0
    assert g2.signed_area(L_RING) == 700.0
    assert g2.signed_area([[0, 0], [4, 0], [0, 3]]) == 6.0  # the 3-4-5 triangle
    np.testing.assert_array_equal(g2.orient_ccw(SQUARE[::-1]), SQUARE[::-1][::-1])
    np.testing.assert_array_equal(g2.orient_ccw(SQUARE), SQUARE)
    with pytest.raises(ValueError, match=r"\(k, 2\)"):
        g2.signed_area([1.0, 2.0, 3.0])


def test_convexity() -> None:
    assert g2.is_convex_ccw(SQUARE)
    assert not g2.is_convex_ccw(SQUARE[::-1])  # clockwise: every turn is a right turn
    assert not g2.is_convex_ccw(L_RING)  # the reflex corner at (10, 10)
    # a collinear vertex (5, 0) is still convex
    assert g2.is_convex_ccw([[0, 0], [5, 0], [10, 0], [10, 10], [0, 10]])


def test_turn_angles() -> None:
    np.testing.assert_allclose(g2.turn_angles(SQUARE), [math.pi / 2] * 4)
    turns = g2.turn_angles(L_RING)
    np.testing.assert_allclose(turns, np.radians([90, 90, 90, -90, 90, 90]), atol=1e-12)
    assert turns.sum() == pytest.approx(2 * math.pi)  # a simple ccw ring turns once


def test_convex_hull() -> None:
    hull = g2.convex_hull(L_RING)
    np.testing.assert_array_equal(hull, [[0, 0], [40, 0], [40, 10], [10, 40], [0, 40]])
    assert g2.signed_area(hull) == 700.0 + 0.5 * 30 * 30  # the notch's triangle is added
    # collinear and interior points are dropped; duplicates too
    pts = [[0, 0], [5, 0], [10, 0], [10, 10], [0, 10], [5, 5], [0, 0]]
    np.testing.assert_array_equal(g2.convex_hull(pts), SQUARE)
    assert g2.convex_hull([[1, 1], [1, 1]]).shape == (1, 2)


def test_circle_ring() -> None:
    ring = g2.circle_ring((3.0, 4.0), 2.0, 4)
    np.testing.assert_allclose(ring, [[5, 4], [3, 6], [1, 4], [3, 2]], atol=1e-12)
    assert g2.signed_area(ring) == pytest.approx(8.0)  # the inscribed square: d²/2


# ---------------------------------------------------------------------------------------------
# crossings and simplicity


def test_segments_intersect_proper_and_touching() -> None:
    a0, a1 = np.array([0.0, 0.0]), np.array([10.0, 0.0])
    assert g2.segments_intersect(a0, a1, np.array([5.0, -5.0]), np.array([5.0, 5.0]))
    # a T: the second segment ends on the first
    t0, t1 = np.array([5.0, 0.0]), np.array([5.0, 5.0])
    assert g2.segments_intersect(a0, a1, t0, t1)
    assert not g2.segments_intersect(a0, a1, t0, t1, touching=False)
    # parallel, apart
    assert not g2.segments_intersect(a0, a1, np.array([0.0, 1.0]), np.array([10.0, 1.0]))
    # collinear, overlapping
    assert g2.segments_intersect(a0, a1, np.array([8.0, 0.0]), np.array([12.0, 0.0]))
    # collinear, disjoint
    assert not g2.segments_intersect(a0, a1, np.array([11.0, 0.0]), np.array([12.0, 0.0]))


def test_self_intersection() -> None:
    assert not g2.self_intersects(SQUARE)
    assert not g2.self_intersects(L_RING)
    assert g2.self_intersects(BOWTIE)
    assert g2.self_intersects(BOWTIE, touching=False)
    # two vertices meet at (5, 5): touching only
    pinched = np.array([[0, 0], [5, 5], [10, 0], [10, 10], [5, 5], [0, 10]], dtype=float)
    assert g2.self_intersects(pinched)
    assert not g2.self_intersects(pinched, touching=False)


def test_polygon_problem_names_the_place() -> None:
    assert g2.polygon_problem(SQUARE) is None
    assert g2.polygon_problem(L_RING) is None
    problem = g2.polygon_problem(BOWTIE)
    assert problem is not None and "Self-intersection" in problem and "5 5" in problem
    assert g2.polygon_problem([[0, 0], [1, 1], [2, 2]]) is not None  # collinear: folds on itself
    assert "at least 3" in str(g2.polygon_problem([[0, 0], [1, 1]]))


def test_covers() -> None:
    assert g2.covers(SQUARE, SQUARE * 0.5 + 2.5)
    assert g2.covers(SQUARE, SQUARE)  # equal boundaries count
    assert not g2.covers(SQUARE, SQUARE + 0.1)
    assert g2.covers(SQUARE, np.array([[0.0, 0.0], [10.0, 5.0]]))  # points on the boundary
    assert not g2.covers(L_RING, np.array([[20.0, 20.0]]))  # in the notch


# ---------------------------------------------------------------------------------------------
# point in polygon, distances


def test_points_in_polygon() -> None:
    pts = np.array([[5, 5], [20, 5], [5, 20], [20, 20], [-1, 5], [41, 5]], dtype=float)
    np.testing.assert_array_equal(
        g2.points_in_polygon(pts, L_RING), [True, True, True, False, False, False]
    )


def test_point_segment_distance() -> None:
    a, b = np.array([0.0, 0.0]), np.array([10.0, 0.0])
    p = np.array([[5.0, 3.0], [-3.0, 4.0], [13.0, -4.0], [10.0, 0.0]])
    np.testing.assert_allclose(g2.point_segment_distance(p, a, b), [3.0, 5.0, 5.0, 0.0])
    # a zero-length segment is a point
    assert g2.point_segment_distance(np.array([3.0, 4.0]), a, a) == 5.0


def test_points_polygon_distance() -> None:
    pts = np.array([[5, 5], [20, 20], [50, 10], [-3, -4]], dtype=float)
    np.testing.assert_allclose(g2.points_polygon_distance(pts, L_RING), [0.0, 10.0, 10.0, 5.0])


def test_segments_polygon_distance() -> None:
    seg_a = np.array([[20.0, 20.0], [-5.0, 5.0], [50.0, 0.0], [25.0, 45.0]])
    seg_b = np.array([[30.0, 30.0], [5.0, 5.0], [50.0, 10.0], [45.0, 45.0]])
    # 1: in the notch, its end (20, 20) 10 m from both arms' inner faces; 2: crosses the L;
    # 3: 10 m east of it; 4: above the notch, nearest the left arm's corner (10, 40)
    np.testing.assert_allclose(
        g2.segments_polygon_distance(seg_a, seg_b, L_RING),
        [10.0, 0.0, 10.0, math.hypot(15.0, 5.0)],
    )
    a, b = g2.polyline_segments(np.array([[0, 0, 1], [1, 0, 2], [1, 1, 3]], dtype=float))
    np.testing.assert_array_equal(a, [[0, 0], [1, 0]])
    np.testing.assert_array_equal(b, [[1, 0], [1, 1]])


# ---------------------------------------------------------------------------------------------
# the tangent-cut offset: contains the exact offset, and no more than the cut allows


def test_square_offset_by_hand() -> None:
    # a mitre per corner: each vertex moves out by (d, d)
    grown = g2.inflate_polygon(SQUARE, 2.0)
    np.testing.assert_allclose(grown, [[-2, -2], [12, -2], [12, 12], [-2, 12]], atol=1e-12)
    # two cuts per corner (45 degrees each): vertices at d / cos(22.5 deg) from the corner
    grown = g2.inflate_polygon(SQUARE, 2.0, max_step_deg=45.0)
    assert len(grown) == 8
    reach = 2.0 / math.cos(math.radians(22.5))
    d = np.hypot(*(grown[:2] - SQUARE[0]).T)
    np.testing.assert_allclose(d, reach)
    k = 2.0 * math.tan(math.radians(22.5))  # how far along each side the cut begins
    np.testing.assert_allclose(grown[:2], [[-2.0, -k], [-k, -2.0]], atol=1e-12)
    # the cut's edges touch the rounded offset: their midpoints are exactly d from the corner
    mid = (grown[0] + grown[1]) / 2
    assert np.hypot(*(mid - SQUARE[0])) == pytest.approx(2.0)


def test_l_offset_keeps_its_notch() -> None:
    grown = g2.inflate_polygon(L_RING, 5.0)
    np.testing.assert_allclose(
        grown, [[-5, -5], [45, -5], [45, 15], [15, 15], [15, 45], [-5, 45]], atol=1e-12
    )


def test_folding_offset_is_none_and_inflate_uses_the_hull() -> None:
    # a 4 m wide slot: a 10 m offset closes it and folds over
    u_ring = np.array(
        [[0, 0], [50, 0], [50, 50], [27, 50], [27, 10], [23, 10], [23, 50], [0, 50]], float
    )
    steps = g2.cut_steps(g2.turn_angles(u_ring), math.pi / 2)
    assert g2.offset_ring(u_ring, 10.0, steps) is None
    assert g2.offset_ring(u_ring, 1.0, steps) is not None  # 1 m leaves the slot open
    grown = g2.inflate_polygon(u_ring, 10.0)
    np.testing.assert_allclose(grown, [[-10, -10], [60, -10], [60, 60], [-10, 60]], atol=1e-12)


def test_cut_steps_and_angles() -> None:
    turns = np.radians([90.0, 45.0, 100.0, -30.0])
    np.testing.assert_array_equal(g2.cut_steps(turns, math.radians(45.0)), [2, 1, 3, 1])
    np.testing.assert_allclose(
        np.degrees(g2.cut_step_angles(turns, math.radians(45.0))), [45, 45, 100 / 3, 30]
    )


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    offset=st.floats(0.5, 20.0),
    step=st.sampled_from([90.0, 45.0, 22.5]),
)
def test_offset_contains_the_exact_offset(seed: int, offset: float, step: float) -> None:
    """Random star-shaped rings: the exact offset boundary (edges moved out, arcs at the
    corners) is covered, and no vertex reaches beyond offset / cos(step / 2)."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(3, 9))
    angles = np.sort(rng.uniform(0, 2 * math.pi, n))
    radii = rng.uniform(20.0, 60.0, n)
    ring = np.column_stack((radii * np.cos(angles), radii * np.sin(angles)))
    if abs(g2.signed_area(ring)) < 1.0 or g2.self_intersects(ring):
        return
    grown = g2.inflate_polygon(ring, offset, max_step_deg=step)
    # the exact offset's boundary, densely: each vertex's disc of radius `offset`
    circle = np.column_stack(
        (np.cos(np.linspace(0, 2 * math.pi, 256)), np.sin(np.linspace(0, 2 * math.pi, 256)))
    )
    discs = (ring[:, None, :] + offset * (1 - 1e-9) * circle[None]).reshape(-1, 2)
    edges = np.roll(ring, -1, axis=0) - ring
    normals = np.column_stack((edges[:, 1], -edges[:, 0])) / np.hypot(*edges.T)[:, None]
    t = np.linspace(0, 1, 64)[None, :, None]
    moved = ring[:, None] + t * edges[:, None] + offset * (1 - 1e-9) * normals[:, None]
    boundary = np.vstack((discs, moved.reshape(-1, 2)))
    outside = g2.points_polygon_distance(boundary, ring) >= offset * (1 - 1e-6)
    assert g2.points_in_polygon(boundary[outside], grown).all() or g2.covers(
        grown, boundary[outside]
    )
    assert g2.covers(grown, ring)
    reach = g2.points_polygon_distance(grown, ring)
    assert reach.max() <= offset / math.cos(math.radians(step) / 2) + 1e-6


def test_round_offset_outline_for_pictures() -> None:
    (outline,) = g2.round_offset_outline(SQUARE, 2.0, quad_segs=8)
    # every vertex on the rounded offset, exactly 2 m from the square
    np.testing.assert_allclose(g2.points_polygon_distance(outline, SQUARE), 2.0, atol=1e-9)
    # area: the square, four 10 x 2 strips, and a disc of radius 2 (a 32-gon, slightly less)
    exact = 100.0 + 4 * 20.0 + math.pi * 4.0
    inscribed = 100.0 + 4 * 20.0 + 0.5 * 32 * 4.0 * math.sin(2 * math.pi / 32)
    assert g2.signed_area(outline) == pytest.approx(inscribed, abs=1e-9) and inscribed < exact
    # a concave footprint keeps its notch (inflate_polygon would take the hull at 16 m)
    (grown,) = g2.round_offset_outline(L_RING, 5.0)
    assert not g2.points_in_polygon(np.array([[25.0, 25.0]]), grown)[0]
    assert g2.points_in_polygon(np.array([[14.0, 14.0]]), grown)[0]


# ---------------------------------------------------------------------------------------------
# convex pieces (the world's decomposition)


def test_convex_pieces() -> None:
    # a convex polygon within the vertex limit is its own piece (made counter-clockwise)
    assert g2.convex_pieces([tuple(p) for p in SQUARE[::-1]], 16) == [
        [tuple(p) for p in SQUARE[::-1][::-1]]
    ]
    # over the limit or concave: ear-clipping triangles covering the area exactly
    pieces = g2.convex_pieces([tuple(p) for p in L_RING], 16)
    assert len(pieces) == len(L_RING) - 2
    assert sum(g2.signed_area(p) for p in pieces) == pytest.approx(700.0)
    assert all(g2.signed_area(p) > 0 for p in pieces)
    octagon = [tuple(p) for p in g2.circle_ring((0, 0), 10.0, 8)]
    assert len(g2.convex_pieces(octagon, 6)) == 6
    assert len(g2.convex_pieces(octagon, 8)) == 1


def test_importing_geometry2d_needs_no_shapely() -> None:
    code = "import sys, uavplan.geometry2d; print('shapely' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
