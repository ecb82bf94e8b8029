"""Grid A* (uavplan.planners.astar) on small hand-made worlds."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from uavplan.config import EnergyWeights, GridSpec
from uavplan.geo import GeoPoint
from uavplan.obstacles import Bounds, BoxObstacle, CylinderObstacle, Obstacle
from uavplan.path.energy import energy_terms
from uavplan.path.frame import PathFrame
from uavplan.path.post import simplify
from uavplan.planners.astar import GridRoute, GridStatus, astar
from uavplan.planning import build_world, reference_energy, reference_route
from uavplan.scenario import PlannerConfig, Scenario
from uavplan.world import World

BOUNDS = ((0.0, 400.0), (-100.0, 100.0), (0.0, 100.0))
GRID = GridSpec(20.0, 20.0, 10.0)
WEIGHTS = EnergyWeights()
MARGIN = 5.0
TALL = 150.0  # above the 100 m ceiling: cannot be overflown


def search(
    obstacles: list[Obstacle],
    start: tuple[float, float, float],
    goal: tuple[float, float, float],
    bounds=BOUNDS,
    energy: EnergyWeights = WEIGHTS,
) -> tuple[World, GridRoute]:
    world = World.build(obstacles, bounds_xyz=bounds, margin_m=MARGIN)
    frame = PathFrame.build(start, goal, GRID)
    return world, astar(world.in_frame(frame.origin_xy, frame.heading_rad), frame, energy)


def scenario(obstacles, start, goal, bounds=BOUNDS) -> Scenario:
    return Scenario(
        name="test",
        origin=GeoPoint(47.0, 8.0, 400.0),
        bounds=Bounds(*bounds),
        start_m=start,
        goal_m=goal,
        obstacles=tuple(obstacles),
        safety_margin_m=MARGIN,
        planner=PlannerConfig(grid=GRID),
    )


def assert_keeps_margin(world: World, path: np.ndarray) -> None:
    """Independent check: exact segment clearance of every edge, and inside the bounds."""
    dist, _ = world.segments_clearance(path[:-1], path[1:])
    assert dist.min() >= MARGIN - 1e-6
    assert world.points_inside_bounds(path).all()


def line_cost(a, b, w: EnergyWeights = WEIGHTS) -> float:
    d = np.subtract(b, a)
    return w.k0 * float(np.linalg.norm(d)) + w.k2 * abs(float(d[2]))


def wall_with_gap(gap_lo: float, gap_hi: float, x: float = 200.0) -> list[Obstacle]:
    """A wall across the corridor at ``x``, open for gap_lo < y < gap_hi."""
    lo, hi = BOUNDS[1]
    return [
        BoxObstacle((x, (lo - 20 + gap_lo) / 2), (20.0, gap_lo - lo + 20), TALL),
        BoxObstacle((x, (gap_hi + hi + 20) / 2), (20.0, hi + 20 - gap_hi), TALL),
    ]


# ---------------------------------------------------------------------------------------------


def test_open_space_on_the_grid_line_is_the_straight_line() -> None:
    start, goal = (0.0, 0.0, 30.0), (400.0, 0.0, 30.0)
    _, route = search([], start, goal)
    assert route.found
    np.testing.assert_allclose(route.path_enu[0], start)
    np.testing.assert_allclose(route.path_enu[-1], goal)
    assert route.cost == pytest.approx(400.0)
    assert sum(energy_terms(route.path_enu, WEIGHTS)) == pytest.approx(400.0)


def test_open_space_off_grid_is_straight_up_to_grid_effects() -> None:
    start, goal = (0.0, 0.0, 30.0), (400.0, 0.0, 60.0)
    world, route = search([], start, goal)
    straight = line_cost(start, goal)
    # admissible lower bound, and only a few diagonal steps above it
    assert straight - 1e-9 <= route.cost <= 1.03 * straight
    assert route.cost == pytest.approx(sum(energy_terms(route.path_enu, EnergyWeights(k1=0))))
    shortcut = route.path_enu[simplify(route.path_enu, world)]
    assert shortcut.shape[0] == 2
    assert sum(energy_terms(shortcut, WEIGHTS)) == pytest.approx(straight)


def test_wall_with_a_gap_goes_through_the_gap() -> None:
    world, route = search(wall_with_gap(30.0, 70.0), (0.0, 0.0, 30.0), (400.0, 0.0, 30.0))
    assert route.found
    path = route.path_enu
    at_wall = path[np.abs(path[:, 0] - 200.0) <= 10.0 + MARGIN]
    assert at_wall.size and np.all((at_wall[:, 1] > 30.0) & (at_wall[:, 1] < 70.0))
    assert_keeps_margin(world, path)
    assert_keeps_margin(world, path[simplify(path, world)])


def test_walled_in_goal_has_no_path() -> None:
    walls = [
        BoxObstacle((260.0, 0.0), (10.0, 90.0), TALL),
        BoxObstacle((340.0, 0.0), (10.0, 90.0), TALL),
        BoxObstacle((300.0, 40.0), (90.0, 10.0), TALL),
        BoxObstacle((300.0, -40.0), (90.0, 10.0), TALL),
    ]
    start, goal = (0.0, 0.0, 30.0), (300.0, 0.0, 30.0)
    _, route = search(walls, start, goal)
    assert route.status is GridStatus.NO_PATH
    assert route.path_enu is None and route.expanded > 0
    scn = scenario(walls, start, goal)
    assert not reference_route(scn).found
    assert math.isnan(reference_energy(scn))
    assert reference_route(scenario(walls[:3], start, goal)).found  # one wall gone: open


def test_end_points_within_the_margin_are_reported() -> None:
    post = [CylinderObstacle((300.0, 0.0), 10.0, TALL)]
    _, route = search(post, (0.0, 0.0, 30.0), (300.0, 13.0, 30.0))
    assert route.status is GridStatus.INVALID_GOAL
    post = [CylinderObstacle((0.0, 13.0), 10.0, TALL)]
    _, route = search(post, (0.0, 0.0, 30.0), (300.0, 0.0, 30.0))
    assert route.status is GridStatus.INVALID_START


def test_route_may_go_backwards_out_of_a_cul_de_sac() -> None:
    """Start inside a cup open toward −x: the route must first fly away from the goal,
    which the one-node-per-column encoding cannot express."""
    cup = [
        BoxObstacle((150.0, 0.0), (10.0, 110.0), TALL),
        BoxObstacle((100.0, 50.0), (110.0, 10.0), TALL),
        BoxObstacle((100.0, -50.0), (110.0, 10.0), TALL),
    ]
    bounds = ((0.0, 400.0), (-150.0, 150.0), (0.0, 100.0))
    world, route = search(cup, (100.0, 0.0, 30.0), (380.0, 0.0, 30.0), bounds=bounds)
    assert route.found
    path = route.path_pf
    assert path[:, 0].min() < 45.0 - MARGIN  # left the cup through its mouth
    assert np.any(np.diff(path[:, 0]) < 0)
    assert_keeps_margin(world, route.path_enu)


def test_rotated_frame_off_grid_end_points() -> None:
    """Start/goal not on any axis or grid level; the route ends exactly at them."""
    obstacles = [CylinderObstacle((200.0, 0.0), 40.0, TALL), BoxObstacle((120, -60), (40, 40), 60)]
    start, goal = (30.0, -80.0, 27.0), (370.0, 70.0, 43.0)
    world, route = search(obstacles, start, goal)
    assert route.found
    np.testing.assert_allclose(route.path_enu[0], start, atol=1e-9)
    np.testing.assert_allclose(route.path_enu[-1], goal, atol=1e-9)
    assert_keeps_margin(world, route.path_enu)
    assert route.cost >= line_cost(start, goal) - 1e-9


def test_same_cost_as_dijkstra_over_the_whole_grid() -> None:
    """Optimality: an independent Dijkstra (scipy) over every edge of the same grid."""
    obstacles = [
        *wall_with_gap(-60.0, -20.0, x=120.0),
        *wall_with_gap(20.0, 60.0, x=260.0),
        BoxObstacle((190.0, 0.0), (30.0, 60.0), 45.0),  # can be overflown
    ]
    energy = EnergyWeights(k0=1.0, k1=1.0, mu0=1.0, k2=2.5)
    start, goal = (0.0, 0.0, 30.0), (400.0, 0.0, 30.0)
    world, route = search(obstacles, start, goal, energy=energy)
    assert route.found

    (x0, x1), (y0, y1), (z0, z1) = BOUNDS
    gx, gy, gz = np.meshgrid(
        np.arange(x0, x1 + 1, GRID.dx_m),
        np.arange(y0, y1 + 1, GRID.dy_m),
        np.arange(z0, z1 + 1, GRID.dz_m),
        indexing="ij",
    )
    shape = gx.shape
    nodes = np.stack([gx, gy, gz], axis=-1).reshape(-1, 3)
    valid = world.points_clearance(nodes)[0] >= MARGIN
    idx = np.arange(nodes.shape[0]).reshape(shape)
    src, dst = [], []
    for d in np.ndindex(3, 3, 3):
        d = np.array(d) - 1
        if not d.any():
            continue
        sl_a = tuple(slice(max(0, -k), n - max(0, k)) for k, n in zip(d, shape, strict=True))
        sl_b = tuple(slice(max(0, k), n - max(0, -k)) for k, n in zip(d, shape, strict=True))
        src.append(idx[sl_a].ravel())
        dst.append(idx[sl_b].ravel())
    a, b = np.concatenate(src), np.concatenate(dst)
    keep = valid[a] & valid[b]
    a, b = a[keep], b[keep]
    free = world.segments_free(nodes[a], nodes[b])
    a, b = a[free], b[free]
    step = nodes[b] - nodes[a]
    w = energy.k0 * np.linalg.norm(step, axis=1) + energy.k2 * np.abs(step[:, 2])
    graph = coo_matrix((w, (a, b)), shape=(nodes.shape[0],) * 2).tocsr()
    s = int(np.flatnonzero(np.all(nodes == start, axis=1))[0])
    t = int(np.flatnonzero(np.all(nodes == goal, axis=1))[0])
    best = dijkstra(graph, indices=s)[t]
    assert math.isfinite(best)
    assert route.cost == pytest.approx(best, rel=1e-9)
    assert route.cost > 1.05 * line_cost(start, goal)  # the walls do bend the route
    assert_keeps_margin(world, route.path_enu)


def test_bundled_scenario_has_a_reference_route_that_keeps_the_margin() -> None:
    from pathlib import Path

    from uavplan.planning import build_world
    from uavplan.scenario import load_scenario

    root = Path(__file__).resolve().parents[2]
    scn = load_scenario(root / "missions" / "paper-env3.yaml")
    route = reference_route(scn)
    assert route.found
    assert_keeps_margin(build_world(scn), route.path_enu)


def test_reference_energy_is_the_line_of_sight_route_over_every_leg() -> None:
    """One A* per leg, each shortened by line of sight, joined: the turn at a via point
    counts, as in the polyline the drone would fly (the repeated via point is a zero-length
    step, which the energy skips)."""
    from dataclasses import replace

    walls = wall_with_gap(30.0, 70.0)
    start, via, goal = (0.0, 0.0, 30.0), (200.0, 50.0, 30.0), (400.0, 0.0, 30.0)
    one = scenario(walls, start, goal)
    route = reference_route(one)
    world = build_world(one)
    los = route.path_enu[simplify(route.path_enu, world)]
    assert reference_energy(one, world) == pytest.approx(sum(energy_terms(los, WEIGHTS)))
    assert reference_energy(one) >= line_cost(start, goal)
    toured = replace(one, via_m=(via,))
    legs = [reference_route(toured, start_m=a, goal_m=b) for a, b in ((start, via), (via, goal))]
    joined = np.vstack([r.path_enu[simplify(r.path_enu, world)] for r in legs])
    assert reference_energy(toured) == pytest.approx(sum(energy_terms(joined, WEIGHTS)))
