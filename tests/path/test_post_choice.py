"""The post-processing's choices by energy (issue 26, the dense fields): which of the final
population's routes the refinement keeps, and how much of the spline each leg flies."""

from __future__ import annotations

import itertools

import numpy as np

from uavplan.config import EnergyWeights
from uavplan.obstacles import BoxObstacle
from uavplan.path import post
from uavplan.path.energy import energy_terms
from uavplan.world import World

W = EnergyWeights()
#: a wall 200 m wide and 60 m tall across the route (0, 0, 30) → (300, 0, 30), margin 10 m
WALL = World.build(
    [BoxObstacle((120.0, 0.0), (40.0, 200.0), 60.0)],
    bounds_xyz=((-50.0, 350.0), (-400.0, 400.0), (0.0, 200.0)),
    margin_m=10.0,
)
OPEN = World.build([], bounds_xyz=((-50.0, 700.0), (-400.0, 400.0), (0.0, 200.0)), margin_m=10.0)
#: over the wall: the lower energy as it stands (409)
OVER = np.array([[0.0, 0.0, 30.0], [80.0, 0.0, 75.0], [160.0, 0.0, 75.0], [300.0, 0.0, 30.0]])
#: around it, wide (427): refined, it is the lower (386 against 404)
AROUND = np.array([[0.0, 0.0, 30.0], [120.0, 150.0, 30.0], [300.0, 0.0, 30.0]])


def energy(v: np.ndarray) -> float:
    return float(sum(energy_terms(v, W)))


def assert_keeps_margin(world: World, v: np.ndarray) -> None:
    assert world.segments_free(v[:-1], v[1:]).all()
    dist, _ = world.segments_clearance(v[:-1], v[1:])
    assert dist.min() >= world.margin_m - 1e-6


def test_the_refinement_keeps_the_candidate_it_brings_lowest() -> None:
    assert energy(OVER) < energy(AROUND)  # the lowest as simplified comes first
    alone = post.refine(OVER, WALL, W)
    chosen, v = post.refine_best([OVER, AROUND], WALL, W)
    assert chosen == 1
    assert np.array_equal(v, post.refine(AROUND, WALL, W))
    assert energy(v) < energy(alone) - 10.0
    assert_keeps_margin(WALL, v)
    assert np.array_equal(v[0], OVER[0]) and np.array_equal(v[-1], OVER[-1])


def test_the_refinement_budget_and_duplicates() -> None:
    first = post.subdivide(OVER, post.REFINE_LEG_M).shape[0]
    # a budget for the first candidate only: it is refined, the second is not looked at
    chosen, v = post.refine_best([OVER, AROUND], WALL, W, budget_vertices=first)
    assert chosen == 0 and np.array_equal(v, post.refine(OVER, WALL, W))
    # a candidate equal to an earlier one costs nothing: the third still fits
    both = first + post.subdivide(AROUND, post.REFINE_LEG_M).shape[0]
    chosen, _ = post.refine_best([OVER, OVER.copy(), AROUND], WALL, W, budget_vertices=both)
    assert chosen == 2


def test_the_pattern_search_moves_a_vertex_by_tens_of_metres() -> None:
    """Its first step is 64 m: a route 75 m too high over the wall comes down to it (steps of
    16, 4 and 1 m, three passes each, moved a vertex at most 63 m: it stayed at 107 m)."""
    high = np.array([[0.0, 0.0, 30.0], [80.0, 0.0, 150.0], [160.0, 0.0, 150.0], [300.0, 0.0, 30.0]])
    v = post.refine(high, WALL, W)
    assert v[:, 2].max() < 90.0  # the wall's top and the margin: 70 m
    assert energy(v) < 430.0  # 495 with the old steps
    assert_keeps_margin(WALL, v)


def test_a_leg_flies_straight_where_the_spline_would_climb() -> None:
    """Unevenly spaced vertices: the spline through them overshoots the 90 m level by tens of
    metres over the long leg, which the polyline flies level."""
    v = np.array([[0.0, 0.0, 30.0], [20.0, 0.0, 90.0], [600.0, 0.0, 90.0], [620.0, 0.0, 40.0]])
    margin_only = post.smooth_route(v, OPEN, step_m=5.0)
    assert margin_only.samples[:, 2].max() > 120.0
    assert energy(margin_only.samples) > energy(v) + 100.0
    by_energy = post.smooth_route(v, OPEN, step_m=5.0, weights=W)
    assert by_energy.blend[1] == 0.0  # the long leg is straight
    assert by_energy.samples[:, 2].max() <= 90.0 + 1e-9
    assert energy(by_energy.samples) <= energy(v) + 1e-9
    assert np.allclose(by_energy.samples[by_energy.vertex_index], v)


def test_smoothing_by_energy_never_costs_more_and_keeps_the_margin() -> None:
    rng = np.random.default_rng(3)
    for _ in range(20):
        # routes beside and over the wall through random vertices, made feasible by refining
        mid = np.column_stack(
            [np.sort(rng.uniform(20.0, 280.0, 3)), rng.uniform(-160.0, 160.0, 3), [30.0] * 3]
        )
        mid[np.abs(mid[:, 1]) < 115.0, 2] = 76.0  # over the wall where it is not beside it
        v = np.vstack([[0.0, 0.0, 30.0], mid, [300.0, 0.0, 30.0]])
        if not WALL.segments_free(v[:-1], v[1:]).all():
            continue
        margin_only = post.smooth_route(v, WALL, step_m=5.0)
        by_energy = post.smooth_route(v, WALL, step_m=5.0, weights=W)
        assert energy(by_energy.samples) <= energy(margin_only.samples) + 1e-9
        assert energy(by_energy.samples) <= energy(v) + 1e-9
        assert_keeps_margin(WALL, by_energy.samples)
        for a, b in itertools.pairwise(by_energy.vertex_index):
            assert b > a  # every leg is sampled
