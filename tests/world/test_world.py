"""World geometry (uavplan.world, uavplan._geom): clearances against hand-computed values,
the margin rule of ``segments_free``, frame changes and a 300-obstacle brute-force check."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uavplan.obstacles import BoxObstacle, CylinderObstacle, PrismObstacle
from uavplan.world import World

BOUNDS = ((-1000.0, 1000.0), (-1000.0, 1000.0), (0.0, 500.0))
SQ2 = math.sqrt(2.0)

# x ∈ [-10, 10], y ∈ [-5, 5], z ∈ [0, 30]
BOX = BoxObstacle(center_m=(0.0, 0.0), size_m=(20.0, 10.0), height_m=30.0)
# axis at (200, 0), r = 20, z ∈ [0, 50]
CYL = CylinderObstacle(center_m=(200.0, 0.0), radius_m=20.0, height_m=50.0)
# an L, counter-clockwise: the square notch x > 10, y > 10 is outside it
L_SHAPE = PrismObstacle(((0.0, 0.0), (40.0, 0.0), (40.0, 10.0), (10.0, 10.0), (10.0, 40.0),
                         (0.0, 40.0)), 20.0)  # fmt: skip
# a U, counter-clockwise: notch x ∈ [20, 40], y > 15
U_SHAPE = PrismObstacle(((0.0, 0.0), (60.0, 0.0), (60.0, 40.0), (40.0, 40.0), (40.0, 15.0),
                         (20.0, 15.0), (20.0, 40.0), (0.0, 40.0)), 25.0)  # fmt: skip


def world(*obstacles, margin_m: float = 10.0) -> World:
    return World.build(obstacles, bounds_xyz=BOUNDS, margin_m=margin_m)


def clearance(w: World, point) -> float:
    dist, _ = w.points_clearance(np.array([point], dtype=float))
    return float(dist[0])


def seg_clearance(w: World, a, b) -> float:
    dist, _ = w.segments_clearance(np.array([a], dtype=float), np.array([b], dtype=float))
    return float(dist[0])


def free(w: World, a, b, margin_m: float | None = None) -> bool:
    out = w.segments_free(np.array([a], dtype=float), np.array([b], dtype=float), margin_m)
    return bool(out[0])


# --- points: hand-computed distances ---------------------------------------------------------


@pytest.mark.parametrize(
    ("point", "expected"),
    [
        ((15.0, 0.0, 10.0), 5.0),  # side x = 10: 15 − 10
        ((0.0, -8.0, 29.0), 3.0),  # side y = −5: 8 − 5
        ((15.0, 10.0, 10.0), math.sqrt(50.0)),  # vertical edge (10, 5): √(5² + 5²)
        ((15.0, 10.0, 40.0), math.sqrt(150.0)),  # top corner (10, 5, 30): √(5² + 5² + 10²)
        ((0.0, 0.0, 35.0), 5.0),  # roof: 35 − 30
        ((15.0, 0.0, 34.0), math.sqrt(41.0)),  # roof edge x = 10, z = 30: √(5² + 4²)
        ((3.0, 2.0, 10.0), 0.0),  # inside
        ((10.0, 0.0, 30.0), 0.0),  # on the roof's edge
    ],
)
def test_point_to_box(point, expected) -> None:
    dist, which = world(BOX).points_clearance(np.array([point]))
    assert dist[0] == pytest.approx(expected, abs=1e-12)
    assert which[0] == 0


def test_point_to_yawed_box() -> None:
    # 40 × 20 box at (100, 50) turned 30°: in its own axes (u, v) the half sizes are 20, 10.
    box = BoxObstacle((100.0, 50.0), (40.0, 20.0), 30.0, yaw_deg=30.0)
    w = world(box)
    c, s = math.cos(math.radians(30.0)), math.sin(math.radians(30.0))

    def enu(u, v, z):
        return (100.0 + c * u - s * v, 50.0 + s * u + c * v, z)

    # (u, v) = (30, 0): 30 − 20 = 10 from the short side; in ENU (125.98, 65.00)
    assert clearance(w, enu(30.0, 0.0, 10.0)) == pytest.approx(10.0, abs=1e-9)
    # (u, v) = (23, 14): corner (20, 10) is (3, 4) away → 5
    assert clearance(w, enu(23.0, 14.0, 10.0)) == pytest.approx(5.0, abs=1e-9)
    # (u, v) = (0, −16): 16 − 10 = 6 from the long side, and 6 above the roof → √72
    assert clearance(w, enu(0.0, -16.0, 36.0)) == pytest.approx(math.sqrt(72.0), abs=1e-9)
    # (u, v) = (19, 9) is inside even though ENU (110.95, 67.29) is outside the unyawed box
    assert clearance(w, enu(19.0, 9.0, 5.0)) == 0.0
    # the unyawed box's corner region: ENU (121, 61) is (u, v) = (23.69, −0.97) → 3.69
    u = c * 21.0 + s * 11.0  # = 18.187 + 5.5 = 23.687
    assert clearance(w, (121.0, 61.0, 10.0)) == pytest.approx(u - 20.0, abs=1e-9)


@pytest.mark.parametrize(
    ("point", "expected"),
    [
        ((230.0, 0.0, 25.0), 10.0),  # side: 30 − 20
        ((224.0, 18.0, 10.0), 10.0),  # side, diagonal: √(24² + 18²) − 20 = 30 − 20
        ((230.0, 0.0, 60.0), math.sqrt(200.0)),  # rim: 10 out, 10 up
        ((205.0, -3.0, 58.0), 8.0),  # top: 58 − 50
        ((200.0, 0.0, 10.0), 0.0),  # on the axis
        ((219.0, 0.0, 50.0), 0.0),  # on the top face
    ],
)
def test_point_to_cylinder(point, expected) -> None:
    assert clearance(world(CYL), point) == pytest.approx(expected, abs=1e-12)


@pytest.mark.parametrize(
    ("point", "expected"),
    [
        ((20.0, 20.0, 5.0), 10.0),  # notch centre: 10 from y = 10 and from x = 10
        ((25.0, 15.0, 5.0), 5.0),  # 5 above the notch's floor y = 10
        ((12.0, 12.0, 5.0), 2.0),  # near the inner corner (the convex hull would say 0)
        ((30.0, 30.0, 25.0), math.sqrt(425.0)),  # 20 across, 5 above the roof
        ((5.0, 30.0, 5.0), 0.0),  # inside the upright arm
        ((30.0, 5.0, 5.0), 0.0),  # inside the lower arm
        ((45.0, 45.0, 5.0), math.sqrt(25.0 + 1225.0)),  # nearest (40, 10): √(5² + 35²)
    ],
)
def test_point_to_non_convex_l_prism(point, expected) -> None:
    assert clearance(world(L_SHAPE), point) == pytest.approx(expected, abs=1e-12)


@pytest.mark.parametrize(
    ("point", "expected"),
    [
        ((30.0, 30.0, 10.0), 10.0),  # notch middle: 10 to both walls, 15 to the floor
        ((30.0, 20.0, 10.0), 5.0),  # 5 above the notch floor y = 15
        ((30.0, 50.0, 10.0), math.sqrt(200.0)),  # above the notch: corners (20|40, 40)
        ((10.0, 30.0, 10.0), 0.0),  # inside the left arm
    ],
)
def test_point_to_notched_u_prism(point, expected) -> None:
    assert clearance(world(U_SHAPE), point) == pytest.approx(expected, abs=1e-12)


def test_nearest_obstacle_index() -> None:
    w = world(BOX, CYL, PrismObstacle(tuple((x + 500, y) for x, y in L_SHAPE.polygon_m), 20))
    dist, which = w.points_clearance(np.array([[15.0, 0, 10], [230.0, 0, 25], [520.0, 20, 5]]))
    assert dist == pytest.approx([5.0, 10.0, 10.0], abs=1e-12)
    assert which.tolist() == [0, 1, 2]  # obstacle indices, not piece indices
    assert w.nearest_obstacle((230.0, 0.0, 25.0)) == (pytest.approx(10.0), 1)


# --- segments: the minimum in the middle ------------------------------------------------------


def test_segment_passing_a_cylinder_tangentially() -> None:
    w = world(CylinderObstacle((0.0, 0.0), 20.0, 50.0))
    # along y = 30: nearest at x = 0, 30 − 20 = 10; the ends are √(100² + 30²) − 20 = 84.4 away
    assert seg_clearance(w, (-100, 30, 25), (100, 30, 25)) == pytest.approx(10.0, abs=1e-6)
    # along x + y = 35√2 (distance 35 from the axis): 35 − 20 = 15
    c = 35.0 * SQ2
    a, b = (c + 60.0, -60.0, 20.0), (-60.0, c + 60.0, 20.0)
    assert seg_clearance(w, a, b) == pytest.approx(15.0, abs=1e-6)


def test_segment_over_a_box_roof() -> None:
    w = world(BOX)
    # level at z = 38 over the 30 m roof: 8
    assert seg_clearance(w, (-50, 0, 38), (50, 0, 38)) == pytest.approx(8.0, abs=1e-6)
    # descending z = 40 − 0.16·x: nearest to the roof edge (x, z) = (10, 30), the line's
    # distance |0.16·10 + 30 − 40| / √(1 + 0.16²) = 8.4 / √1.0256 = 8.2945, reached at
    # x = 11.31 (in the middle of the segment, just past the roof)
    expected = 8.4 / math.sqrt(1.0256)
    assert seg_clearance(w, (-50, 0, 48), (50, 0, 32)) == pytest.approx(expected, abs=1e-6)


def test_segment_in_the_notch_of_a_non_convex_prism() -> None:
    w = world(L_SHAPE)
    # y = 13 from x = 15 to 35: 3 above the notch floor y = 10 all along
    assert seg_clearance(w, (15, 13, 5), (35, 13, 5)) == pytest.approx(3.0, abs=1e-6)
    assert free(w, (15, 13, 5), (35, 13, 5), margin_m=2.9)
    assert not free(w, (15, 13, 5), (35, 13, 5), margin_m=3.1)
    # across the notch diagonally on x + y = 60: nearest to the corners (40, 10) and (10, 40),
    # |40 + 10 − 60| / √2 = 5√2, at the feet (45, 15) and (15, 45) inside the segment
    assert seg_clearance(w, (5, 55, 5), (55, 5, 5)) == pytest.approx(5.0 * SQ2, abs=1e-6)


def test_segment_through_an_obstacle_is_zero() -> None:
    w = world(BOX, CYL)
    p0 = np.array([[-50.0, 0.0, 10.0], [150.0, 0.0, 10.0], [0.0, 0.0, 100.0]])
    p1 = np.array([[50.0, 0.0, 10.0], [250.0, 0.0, 10.0], [0.0, 0.0, 10.0]])
    dist, which = w.segments_clearance(p0, p1)
    assert dist.tolist() == [0.0, 0.0, 0.0]
    assert which.tolist() == [0, 1, 0]
    assert not w.segments_free(p0, p1).any()


def test_degenerate_segment_is_a_point() -> None:
    w = world(BOX)
    assert seg_clearance(w, (15, 0, 10), (15, 0, 10)) == pytest.approx(5.0, abs=1e-12)
    assert free(w, (15, 0, 10), (15, 0, 10), margin_m=4.9)
    assert not free(w, (15, 0, 10), (15, 0, 10), margin_m=5.1)


def test_polyline_clearance() -> None:
    w = world(BOX)
    # legs: 10 m beside the box, then over the roof at 38 m (8 m)
    pts = np.array([[-50.0, 15.0, 20.0], [50.0, 15.0, 20.0], [50.0, 0.0, 38.0], [-50, 0, 38]])
    assert w.polyline_clearance(pts) == pytest.approx(8.0, abs=1e-6)


# --- segments_free: the margin rule and the bounds --------------------------------------------


def test_free_at_exactly_the_margin_and_not_1_mm_inside() -> None:
    w = world(BOX, CYL, margin_m=10.0)
    # box side y = 5: a segment on y = 15 is 10 away everywhere along x ∈ [-10, 10]
    assert free(w, (-40, 15, 10), (40, 15, 10))
    assert not free(w, (-40, 14.999, 10), (40, 14.999, 10))
    # roof z = 30: a level segment at z = 40 is exactly 10 above it
    assert free(w, (-40, 0, 40), (40, 0, 40))
    assert not free(w, (-40, 0, 39.999), (40, 0, 39.999))
    # cylinder r = 20: the tangent line y = 30 touches the margin at x = 200 only
    assert free(w, (150, 30, 25), (250, 30, 25))
    assert not free(w, (150, 29.999, 25), (250, 29.999, 25))


def test_margin_zero_still_forbids_touching() -> None:
    w = world(BOX, margin_m=0.0)
    assert not free(w, (-40, 5, 10), (40, 5, 10))  # slides along the face y = 5
    assert not free(w, (10, -20, 10), (10, 20, 10))  # grazes the edge x = 10
    assert not free(w, (-40, 0, 30), (40, 0, 30))  # slides along the roof
    assert free(w, (-40, 5.001, 10), (40, 5.001, 10))
    assert free(w, (-40, 0, 30.001), (40, 0, 30.001))


def test_margin_override_per_call() -> None:
    w = world(BOX, margin_m=10.0)
    a, b = (-40, 12, 10), (40, 12, 10)  # 7 from the side y = 5
    assert not free(w, a, b)
    assert free(w, a, b, margin_m=6.9)
    assert not free(w, a, b, margin_m=7.1)


@pytest.mark.parametrize(
    ("a", "b"),
    [
        ((-500, 0, 100), (1000.001, 0, 100)),  # past x max
        ((-1000.001, 0, 100), (0, 0, 100)),  # past x min
        ((0, 500, 100), (0, 1001, 100)),  # past y max
        ((0, 0, 100), (0, 0, 500.01)),  # above the ceiling
        ((0, 300, -0.01), (0, 400, 100)),  # below the floor
    ],
)
def test_outside_the_bounds_is_not_free(a, b) -> None:
    w = world(BOX)
    assert not free(w, a, b)
    assert free(w, (0, 300, 100), (0, 400, 100))


def test_the_bounds_themselves_are_inside() -> None:
    w = world(BOX)
    assert free(w, (-1000, -1000, 0), (1000, -1000, 0))  # along the floor's southern edge
    assert free(w, (1000, 1000, 500), (1000, -1000, 500))  # along the ceiling's eastern edge
    assert w.points_inside_bounds(np.array([[1000, -1000, 0], [1000.1, 0, 1]])).tolist() == [
        True,
        False,
    ]


def test_batch_of_mixed_segments() -> None:
    w = world(BOX, CYL, PrismObstacle(tuple((x, y + 300) for x, y in L_SHAPE.polygon_m), 20))
    cases = [
        # (a, b, free?, clearance)
        ((-40, 15, 10), (40, 15, 10), True, 10.0),  # at the margin of the box
        ((-40, 14, 10), (40, 14, 10), False, 9.0),  # 1 m inside the margin
        ((150, 35, 25), (250, 35, 25), True, 15.0),  # beside the cylinder
        ((150, 0, 10), (250, 0, 10), False, 0.0),  # through the cylinder
        ((0, 0, 45), (0, 100, 45), True, 15.0),  # over the roof
        ((20, 320, 5), (30, 320, 5), True, 10.0),  # in the L's notch, 10 from both walls
        ((20, 312, 5), (30, 312, 5), False, 2.0),  # near the L notch's floor
        ((0, 0, 100), (0, 0, 600), False, 70.0),  # clear of obstacles, above the ceiling
        ((600, 600, 100), (700, 700, 100), True, None),  # nowhere near anything
    ]
    p0 = np.array([c[0] for c in cases], dtype=float)
    p1 = np.array([c[1] for c in cases], dtype=float)
    assert w.segments_free(p0, p1).tolist() == [c[2] for c in cases]
    dist, _ = w.segments_clearance(p0, p1)
    for d, c in zip(dist, cases, strict=True):
        if c[3] is not None:
            assert d == pytest.approx(c[3], abs=1e-6)
    assert w.segments_free(p0[:0], p1[:0]).shape == (0,)


def test_world_without_obstacles() -> None:
    w = world()
    assert free(w, (0, 0, 10), (100, 0, 10))
    dist, which = w.points_clearance(np.array([[0.0, 0.0, 10.0]]))
    assert dist.tolist() == [math.inf] and which.tolist() == [-1]
    dist, which = w.segments_clearance(np.array([[0.0, 0, 10]]), np.array([[100.0, 0, 10]]))
    assert dist.tolist() == [math.inf] and which.tolist() == [-1]


def test_world_without_obstacles_segments_free() -> None:
    w = world()
    assert free(w, (0, 0, 10), (100, 0, 10))
    assert not free(w, (0, 0, 10), (100, 0, 600))


def test_clockwise_prism_given_directly_is_still_an_obstacle() -> None:
    cw = PrismObstacle(tuple(reversed(L_SHAPE.polygon_m)), 20.0)
    w = world(cw, CYL)  # CYL keeps `owner` non-empty
    assert clearance(w, (5.0, 30.0, 5.0)) == 0.0  # inside the upright arm
    assert clearance(w, (12.0, 12.0, 5.0)) == pytest.approx(2.0)


# --- frames: World.in_frame -------------------------------------------------------------------


def to_frame(points: np.ndarray, origin_xy, heading_rad: float) -> np.ndarray:
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    dx, dy = points[:, 0] - origin_xy[0], points[:, 1] - origin_xy[1]
    return np.stack([c * dx + s * dy, -s * dx + c * dy, points[:, 2]], axis=1)


def test_in_frame_by_hand() -> None:
    # frame at (200, 0) heading north: the cylinder's axis is the new origin, and ENU
    # (230, 0) is 30 to the right of +x (north), i.e. (u, v) = (0, −30)
    w = world(CYL).in_frame((200.0, 0.0), math.pi / 2)
    assert clearance(w, (0.0, -30.0, 25.0)) == pytest.approx(10.0, abs=1e-9)
    # the old x max bound (1000) is now 800 m to the right: v = −800
    assert w.points_inside_bounds(np.array([[0, -799.9, 1], [0, -800.1, 1]])).tolist() == [
        True,
        False,
    ]


@functools.cache
def frame_world() -> World:
    yawed = BoxObstacle((-300.0, 200.0), (80.0, 30.0), 60.0, 25.0)
    return world(BOX, yawed, CYL, L_SHAPE, PrismObstacle(((400.0, -400.0), (500.0, -380.0),
                 (450.0, -300.0)), 90.0), margin_m=10.0)  # fmt: skip


coords = st.floats(-900.0, 900.0, allow_nan=False)


@settings(max_examples=40, deadline=None)
@given(
    origin=st.tuples(coords, coords),
    heading=st.floats(-math.pi, math.pi),
    seed=st.integers(0, 2**32 - 1),
)
def test_in_frame_gives_the_same_clearances(origin, heading, seed) -> None:
    w = frame_world()
    moved = w.in_frame(origin, heading)
    rng = np.random.default_rng(seed)
    n = 40
    # half the points near the obstacles, half anywhere in the bounds
    a = np.concatenate(
        [
            rng.uniform([-400, -450, 0], [550, 300, 120], (n // 2, 3)),
            rng.uniform([-1000, -1000, 0], [1000, 1000, 500], (n // 2, 3)),
        ]
    )
    b = a + rng.normal(0.0, 80.0, a.shape)
    b[:, 2] = np.clip(b[:, 2], 0.0, 500.0)
    fa, fb = to_frame(a, origin, heading), to_frame(b, origin, heading)
    d0, i0 = w.points_clearance(a)
    d1, i1 = moved.points_clearance(fa)
    assert d1 == pytest.approx(d0, abs=1e-6)
    assert (i1[d0 > 1e-6] == i0[d0 > 1e-6]).all()
    s0, _ = w.segments_clearance(a, b)
    s1, _ = moved.segments_clearance(fa, fb)
    assert s1 == pytest.approx(s0, abs=1e-6)
    clear_cut = np.abs(s0 - w.margin_m) > 1e-6
    inside = w.points_inside_bounds(a) & w.points_inside_bounds(b)
    assert (moved.points_inside_bounds(fa) == w.points_inside_bounds(a)).all()
    ok0 = w.segments_free(a, b)
    ok1 = moved.segments_free(fa, fb)
    assert (ok0 == ok1)[clear_cut].all()
    assert (ok0 == (inside & (s0 >= w.margin_m)))[clear_cut].all()


# --- many obstacles: the grid against brute force ---------------------------------------------


@functools.cache
def crowded() -> tuple[World, list]:
    """300 small yawed boxes in a 2 km square, plus a few large pieces spanning many cells."""
    rng = np.random.default_rng(20240601)
    obstacles: list = []
    for _ in range(300):
        obstacles.append(
            BoxObstacle(
                tuple(rng.uniform(-950, 950, 2)),
                tuple(rng.uniform(5, 30, 2)),
                float(rng.uniform(10, 200)),
                float(rng.uniform(-180, 180)),
            )
        )
    obstacles.append(BoxObstacle((0.0, 0.0), (600.0, 15.0), 80.0, 10.0))
    obstacles.append(CylinderObstacle((400.0, -400.0), 150.0, 120.0))
    obstacles.append(PrismObstacle(U_SHAPE.polygon_m, 60.0))
    return world(*obstacles, margin_m=10.0), obstacles


def box_distance_oracle(points: np.ndarray, boxes: list[BoxObstacle]) -> np.ndarray:
    """Independent numpy distance from points (n, 3) to boxes: rotate into each box, clamp."""
    best = np.full(points.shape[0], np.inf)
    for box in boxes:
        c, s = math.cos(math.radians(box.yaw_deg)), math.sin(math.radians(box.yaw_deg))
        dx, dy = points[:, 0] - box.center_m[0], points[:, 1] - box.center_m[1]
        u, v = c * dx + s * dy, -s * dx + c * dy
        gu = np.maximum(np.abs(u) - box.size_m[0] / 2, 0.0)
        gv = np.maximum(np.abs(v) - box.size_m[1] / 2, 0.0)
        gz = np.maximum(points[:, 2] - box.height_m, 0.0) + np.maximum(-points[:, 2], 0.0)
        best = np.minimum(best, np.sqrt(gu * gu + gv * gv + gz * gz))
    return best


def test_points_clearance_of_300_boxes_matches_an_oracle() -> None:
    w, obstacles = crowded()
    rng = np.random.default_rng(7)
    pts = rng.uniform([-1000, -1000, 0], [1000, 1000, 250], (2000, 3))
    boxes = [o for o in obstacles if isinstance(o, BoxObstacle)]
    expected = box_distance_oracle(pts, boxes)
    # the cylinder and the U prism can only make the clearance smaller
    got, _ = w.points_clearance(pts)
    cyl_d = np.maximum(np.hypot(pts[:, 0] - 400, pts[:, 1] + 400) - 150, 0)
    cyl_d = np.hypot(cyl_d, np.maximum(pts[:, 2] - 120, 0))
    far_from_u = (np.abs(pts[:, 0] - 30) > 100) | (np.abs(pts[:, 1] - 20) > 100)
    expected = np.minimum(expected, cyl_d)
    assert got[far_from_u] == pytest.approx(expected[far_from_u], abs=1e-9)
    assert (got <= expected + 1e-9).all()


def test_segments_clearance_of_300_boxes_against_dense_samples() -> None:
    w, _ = crowded()
    rng = np.random.default_rng(11)
    a = rng.uniform([-1000, -1000, 0], [1000, 1000, 250], (150, 3))
    b = np.clip(a + rng.normal(0, 60, a.shape), [-1000, -1000, 0], [1000, 1000, 500])
    got, _ = w.segments_clearance(a, b)
    n = 401
    t = np.linspace(0.0, 1.0, n)
    for i in range(a.shape[0]):
        samples = a[i] + t[:, None] * (b[i] - a[i])
        d, _ = w.points_clearance(samples)
        step = np.linalg.norm(b[i] - a[i]) / (n - 1)
        # the true minimum is at most the sampled one, and (1-Lipschitz) at least it − step/2
        assert got[i] <= d.min() + 1e-9
        assert got[i] >= d.min() - step / 2 - 1e-9


@pytest.mark.slow
@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), scale=st.sampled_from([5.0, 40.0, 300.0, 1500.0]))
def test_segments_free_matches_brute_force_among_300_boxes(seed, scale) -> None:
    w, _ = crowded()
    rng = np.random.default_rng(seed)
    n = 300
    a = rng.uniform([-1050, -1050, 0], [1050, 1050, 260], (n, 3))
    b = a + rng.normal(0.0, scale, (n, 3))
    b[:, 2] = np.clip(b[:, 2], 0.0, 520.0)
    for margin in (10.0, 0.0, 35.0):
        got = w.segments_free(a, b, margin)
        dist, _ = w.segments_clearance(a, b)
        inside = w.points_inside_bounds(a) & w.points_inside_bounds(b)
        expected = inside & (dist >= margin) & (dist > 0)
        decided = np.abs(dist - margin) > 1e-6  # leave exact ties to the tests above
        assert (got == expected)[decided].all(), np.flatnonzero((got != expected) & decided)


def test_largest_free_fraction_is_the_bisection_over_segments_free() -> None:
    """The compiled bisection behind post.tighten gives the value the numpy loop it replaced
    gives (the same bend points, the same tests, to the bit), on bends that are free, blocked
    at the end, or blocked at every fraction."""
    w = world(
        CylinderObstacle((100.0, 0.0), 20.0, 80.0),
        BoxObstacle((180.0, 40.0), (30.0, 60.0), 120.0, yaw_deg=20.0),
        PrismObstacle([(40.0, -80.0), (90.0, -60.0), (60.0, -20.0)], 60.0),
    )

    def reference(p, step, a, b, bisections):
        def ok(f):
            c = p + f * step
            return bool(w.segments_free(np.stack([a, c]), np.stack([c, b])).all())

        if ok(1.0):
            return 1.0
        lo, hi = 0.0, 1.0
        for _ in range(bisections):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if ok(mid) else (lo, mid)
        return lo

    rng = np.random.default_rng(11)
    kinds = set()
    for _ in range(300):
        a = np.array([rng.uniform(0, 250), rng.uniform(-150, 150), rng.uniform(20, 150)])
        b = np.array([rng.uniform(0, 250), rng.uniform(-150, 150), rng.uniform(20, 150)])
        p = np.array([rng.uniform(0, 250), rng.uniform(-150, 150), rng.uniform(20, 150)])
        step = (a + b) / 2.0 - p
        got = w.largest_free_fraction(p, step, a, b, 24)
        assert got == reference(p, step, a, b, 24)
        kinds.add(0.0 if got == 0.0 else 1.0 if got == 1.0 else 0.5)
    assert kinds == {0.0, 0.5, 1.0}


def test_a_world_with_other_limits_shares_its_pieces_and_answers_as_one_built_so() -> None:
    """``plan`` builds its world once and widens it (the margin, the ceiling) or opens it
    (a return's world) with :meth:`World.with_limits`: the pieces are shared, read-only, and
    every answer is the one a world built with those limits gives."""
    obstacles = (BOX, CYL, L_SHAPE, U_SHAPE)
    a = World.build(obstacles, bounds_xyz=BOUNDS, margin_m=10.0)
    assert not a.poly_xy.flags.writeable and not a.circ.flags.writeable
    with pytest.raises(ValueError):
        a.poly_h[0] = 1.0
    rng = np.random.default_rng(5)
    p0 = rng.uniform((-300.0, -150.0, 0.0), (400.0, 150.0, 80.0), size=(4000, 3))
    p1 = p0 + rng.normal(0.0, 60.0, size=p0.shape)
    cases: list[tuple[float | None, tuple | None]] = [
        (14.5, None),
        (None, ((-250.0, 300.0), (-120.0, 160.0), (5.0, 45.0))),
        (3.0, ((-1e3, 1e3), (-1e3, 1e3), (-1e7, 1e7))),
    ]
    for margin, bounds in cases:
        b = a.with_limits(margin_m=margin, bounds_xyz=bounds)
        built = World.build(
            obstacles, bounds_xyz=bounds or BOUNDS, margin_m=10.0 if margin is None else margin
        )
        assert b.poly_xy is a.poly_xy and b.cells is a.cells
        assert b.margin_m == built.margin_m
        assert np.array_equal(b.hp, built.hp) and np.array_equal(b.zlim, built.zlim)
        free = built.segments_free(p0, p1)
        assert 0 < free.mean() < 1 and np.array_equal(b.segments_free(p0, p1), free)
        assert np.array_equal(b.points_clearance(p0)[0], built.points_clearance(p0)[0])
        assert np.array_equal(b.points_inside_bounds(p1), built.points_inside_bounds(p1))
    assert a.margin_m == 10.0  # the first world is unchanged
