"""The path frame (uavplan.path.frame.PathFrame): x along start→goal, y to the left, z up."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uavplan.config import GridSpec
from uavplan.path.frame import PathFrame

GRID = GridSpec(dx_m=20.0, dy_m=20.0, dz_m=10.0)

coords = st.floats(-5000.0, 5000.0, allow_nan=False)
heights = st.floats(0.0, 500.0, allow_nan=False)
bearings = st.floats(-math.pi, math.pi, allow_nan=False)
distances = st.floats(5.0, 5000.0, allow_nan=False)
grids = st.builds(GridSpec, st.floats(1.0, 100.0), st.floats(1.0, 50.0), st.floats(1.0, 50.0))


def frame_at(x, y, z0, bearing, distance, z1, grid=GRID) -> PathFrame:
    goal = (x + distance * math.cos(bearing), y + distance * math.sin(bearing), z1)
    return PathFrame.build((x, y, z0), goal, grid)


# --- by hand ----------------------------------------------------------------------------------


def test_frame_heading_north_by_hand() -> None:
    # start (100, 200), goal 1000 m due north: +x is north, +y (left) is west
    f = PathFrame.build((100.0, 200.0, 30.0), (100.0, 1200.0, 50.0), GRID)
    assert f.heading_rad == pytest.approx(math.pi / 2)
    assert f.length_m == 1000.0
    assert f.n_cols == 50 and f.dx_m == 20.0
    assert f.origin_xy == (100.0, 200.0)
    # 100 m north of the start and 10 m west of the line
    assert f.from_enu([[90.0, 300.0, 7.0]])[0] == pytest.approx([100.0, 10.0, 7.0], abs=1e-9)
    assert f.to_enu([[100.0, 10.0, 7.0]])[0] == pytest.approx([90.0, 300.0, 7.0], abs=1e-9)


def test_frame_heading_south_west_by_hand() -> None:
    # 3-4-5: goal 300 m west and 400 m south of the start, 500 m away
    f = PathFrame.build((0.0, 0.0, 20.0), (-300.0, -400.0, 20.0), GRID)
    assert f.length_m == 500.0
    assert f.heading_rad == pytest.approx(math.atan2(-400.0, -300.0))
    # the unit vector along +x is (−0.6, −0.8); along +y (left of it) is (0.8, −0.6)
    assert f.to_enu([[1.0, 0.0, 0.0]])[0] == pytest.approx([-0.6, -0.8, 0.0], abs=1e-12)
    assert f.to_enu([[0.0, 1.0, 0.0]])[0] == pytest.approx([0.8, -0.6, 0.0], abs=1e-12)
    assert f.n_cols == 25 and f.dx_m == 20.0


def test_column_spacing_is_stretched_so_the_goal_is_on_the_last_column() -> None:
    # 1010 m / 20 m = 50.5 → 50 columns (round half to even) of 20.2 m
    f = PathFrame.build((0.0, 0.0, 10.0), (1010.0, 0.0, 10.0), GRID)
    assert f.n_cols == 50
    assert f.dx_m == pytest.approx(20.2)
    assert f.cols[:, 0].shape == (51,)
    assert f.cols[:, 0][0] == 0.0
    assert f.cols[:, 0][-1] == pytest.approx(1010.0, abs=1e-9)


def test_short_routes_still_have_two_columns() -> None:
    f = PathFrame.build((0.0, 0.0, 10.0), (25.0, 0.0, 10.0), GRID)
    assert f.n_cols == 2
    assert f.dx_m == 12.5
    assert f.nodes_to_points(np.zeros((1, 2))).shape == (3, 3)


def test_start_and_goal_must_differ_horizontally() -> None:
    with pytest.raises(ValueError, match="differ horizontally"):
        PathFrame.build((10.0, 10.0, 0.0), (10.0, 10.0, 100.0), GRID)


def test_start_end_line_z_by_hand() -> None:
    # z from 30 m to 80 m over 5 columns, dz = 10: 3, 4, 5, 6, 7, 8 units
    f = PathFrame.build((0.0, 0.0, 30.0), (100.0, 0.0, 80.0), GRID)
    assert f.n_cols == 5
    assert f.start_units == (0.0, 3.0)
    assert f.goal_units == (0.0, 8.0)
    assert f.line_z_units == pytest.approx([3.0, 4.0, 5.0, 6.0, 7.0, 8.0], abs=1e-12)


def test_nodes_to_points_by_hand() -> None:
    f = PathFrame.build((0.0, 0.0, 30.0), (60.0, 0.0, 50.0), GRID)
    nodes = np.array([[1.0, 4.0], [-2.5, 6.0]])  # (y, z) in grid units
    pts = f.nodes_to_points(nodes)
    assert pts.tolist() == [
        [0.0, 0.0, 30.0],
        [20.0, 20.0, 40.0],
        [40.0, -50.0, 60.0],
        [60.0, 0.0, 50.0],
    ]


# --- properties -------------------------------------------------------------------------------


@settings(max_examples=100, deadline=None)
@given(
    x=coords, y=coords, z0=heights, bearing=bearings, distance=distances, z1=heights,
    points=st.lists(st.tuples(coords, coords, heights), min_size=1, max_size=8),
)  # fmt: skip
def test_round_trip(x, y, z0, bearing, distance, z1, points) -> None:
    f = frame_at(x, y, z0, bearing, distance, z1)
    p = np.array(points)
    assert f.to_enu(f.from_enu(p)) == pytest.approx(p, abs=1e-6)
    assert f.from_enu(f.to_enu(p)) == pytest.approx(p, abs=1e-6)
    # a rotation: horizontal distances between points are kept, heights untouched
    q = f.from_enu(p)
    assert np.hypot(*(q[:, :2] - q[0, :2]).T) == pytest.approx(
        np.hypot(*(p[:, :2] - p[0, :2]).T), abs=1e-6
    )
    assert q[:, 2].tolist() == p[:, 2].tolist()


@settings(max_examples=100, deadline=None)
@given(x=coords, y=coords, z0=heights, bearing=bearings, distance=distances, z1=heights)
def test_x_axis_runs_from_start_to_goal(x, y, z0, bearing, distance, z1) -> None:
    f = frame_at(x, y, z0, bearing, distance, z1)
    assert f.length_m == pytest.approx(distance, rel=1e-9)
    start, goal = f.from_enu(np.array([f.start_enu, f.goal_enu]))
    assert start == pytest.approx([0.0, 0.0, z0], abs=1e-6)
    assert goal == pytest.approx([f.length_m, 0.0, z1], abs=1e-6)
    # +y is the left of the direction of travel: 90° counter-clockwise from the bearing
    left = np.array([[x - 10.0 * math.sin(bearing), y + 10.0 * math.cos(bearing), 0.0]])
    assert f.from_enu(left)[0] == pytest.approx([0.0, 10.0, 0.0], abs=1e-6)


@settings(max_examples=50, deadline=None)
@given(
    x=coords, y=coords, z0=heights, bearing=bearings, distance=distances, z1=heights,
    grid=grids,
)  # fmt: skip
def test_goal_is_on_the_last_column(x, y, z0, bearing, distance, z1, grid) -> None:
    f = frame_at(x, y, z0, bearing, distance, z1, grid)
    assert f.n_cols >= 2
    assert f.n_cols == max(2, round(f.length_m / grid.dx_m))
    assert f.cols[:, 0][-1] == pytest.approx(f.length_m, rel=1e-12)
    np.testing.assert_allclose(np.diff(f.cols[:, 0]), f.dx_m, rtol=1e-9)
    if f.n_cols > 2:  # only stretched, never by more than half a column
        assert abs(f.dx_m - grid.dx_m) <= grid.dx_m / 2 + 1e-9
    # nodes on the start-end line map back onto start and goal and the straight line
    nodes = np.stack([np.zeros(f.n_cols - 1), f.line_z_units[1:-1]], axis=1)
    enu = f.to_enu(f.nodes_to_points(nodes))
    assert enu[0] == pytest.approx(f.start_enu, abs=1e-6)
    assert enu[-1] == pytest.approx(f.goal_enu, abs=1e-6)
    t = np.arange(f.n_cols + 1) / f.n_cols
    line = np.array(f.start_enu) + t[:, None] * (np.array(f.goal_enu) - np.array(f.start_enu))
    np.testing.assert_allclose(enu, line, rtol=0, atol=1e-6)


@settings(max_examples=50, deadline=None)
@given(
    x=coords, y=coords, z0=heights, bearing=bearings, distance=distances, z1=heights,
    grid=grids,
)  # fmt: skip
def test_start_end_line_z(x, y, z0, bearing, distance, z1, grid) -> None:
    f = frame_at(x, y, z0, bearing, distance, z1, grid)
    z = f.line_z_units * grid.dz_m
    assert z.shape == (f.n_cols + 1,)
    assert z[0] == pytest.approx(z0, abs=1e-9)
    assert z[-1] == pytest.approx(z1, abs=1e-9)
    np.testing.assert_allclose(np.diff(z), (z1 - z0) / f.n_cols, rtol=0, atol=1e-9)
    assert f.start_units == (0.0, pytest.approx(z0 / grid.dz_m))
    assert f.goal_units == (0.0, pytest.approx(z1 / grid.dz_m))


def test_columns_along_a_guide_that_turns_back_do_not_fold() -> None:
    """A U-shaped guide (out 400 m, across 200 m, back 300 m): columns stand at equal arc
    lengths on it, their normals turn with it, and each column's lateral window stops
    before the line of a neighbouring column crosses it."""
    f = PathFrame.build((0.0, 0.0, 30.0), (100.0, 200.0, 30.0), GridSpec())
    # the guide in the path frame (x toward the goal): out, across, back
    c, s = math.cos(f.heading_rad), math.sin(f.heading_rad)
    enu = np.array([[0.0, 0.0], [400.0, 0.0], [400.0, 200.0], [100.0, 200.0]])
    pf = np.column_stack([c * enu[:, 0] + s * enu[:, 1], -s * enu[:, 0] + c * enu[:, 1]])
    g = f.along(pf)
    assert not g.straight and g.n_cols == round(900 / 20)
    np.testing.assert_allclose(np.linalg.norm(g.cols[:, 2:], axis=1), 1.0)
    np.testing.assert_allclose(g.cols[0, :2], pf[0], atol=1e-9)
    np.testing.assert_allclose(g.cols[-1, :2], pf[-1], atol=1e-9)
    steps = np.linalg.norm(np.diff(g.cols[:, :2], axis=0), axis=1)
    assert steps.max() <= g.dx_m + 1e-9  # on the guide, at most one arc step apart
    lo, hi = g.lateral_limits_m[:, 0], g.lateral_limits_m[:, 1]
    assert np.isfinite(lo).any() or np.isfinite(hi).any()  # windows cut where it turns
    # within the windows, no two neighbouring columns' segments cross
    for j in range(g.n_cols):
        a0, a1 = (g.cols[j, :2] + t * g.cols[j, 2:] for t in np.clip([lo[j], hi[j]], -300, 300))
        b0, b1 = (
            g.cols[j + 1, :2] + t * g.cols[j + 1, 2:]
            for t in np.clip([lo[j + 1], hi[j + 1]], -300, 300)
        )
        d = np.linalg.det
        crosses = (
            d([a1 - a0, b0 - a0]) * d([a1 - a0, b1 - a0]) < 0
            and d([b1 - b0, a0 - b0]) * d([b1 - b0, a1 - b0]) < 0
        )
        assert not crosses, j
    # a node at lateral offset y sits at origin + y·normal
    nodes = np.zeros((g.n_cols - 1, 2))
    nodes[:, 0] = 1.0
    pts = g.nodes_to_points(nodes)
    np.testing.assert_allclose(pts[1:-1, :2], g.cols[1:-1, :2] + 20.0 * g.cols[1:-1, 2:])
