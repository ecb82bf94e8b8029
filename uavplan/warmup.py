"""Compile (or load from numba's cache) every kernel before anything is timed.

The first run after installation compiles the kernels, which takes tens of seconds; later
runs load them from the cache next to the installed modules in a fraction of a second.
:func:`warm_up` runs a tiny planning problem through every kernel with the argument types
real runs use, so that neither ``runtime_s`` nor a benchmark ever includes compilation, and
:func:`kernels_cached` lets the CLI say why the first run is slow.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np


def kernels_cached() -> bool:
    """True when numba's on-disk cache already holds the planner kernels."""
    from uavplan.planners import _kernels

    cache_dir = Path(_kernels.__file__).parent / "__pycache__"
    return any(cache_dir.glob("_kernels.*.nbi"))


@functools.cache
def warm_up() -> None:
    """Run every compiled kernel once on a tiny problem (once per process)."""
    from uavplan.config import EnergyWeights, GridSpec, SearchParams
    from uavplan.obstacles import BoxObstacle, CylinderObstacle
    from uavplan.path.post import refine, resample_waypoints, simplify, smooth_route
    from uavplan.planners.base import PathProblem
    from uavplan.planners.proposal import Draw, Proposal
    from uavplan.planners.sparrow import oscillate
    from uavplan.world import World

    world = World.build(
        [BoxObstacle((100.0, 0.0), (20.0, 20.0), 50.0), CylinderObstacle((60.0, 40.0), 5.0, 30.0)],
        bounds_xyz=((-10.0, 210.0), (-100.0, 100.0), (0.0, 100.0)),
        margin_m=5.0,
    )
    problem = PathProblem.build(
        world, (0.0, 0.0, 20.0), (200.0, 0.0, 20.0), GridSpec(), EnergyWeights(), 2
    )
    rng = np.random.default_rng(0)
    x, _, _ = problem.initial_population(4, SearchParams(population=4), rng)
    prop = Proposal.for_population(x, n_explicit=1)
    prop.active[:] = True
    prop.draw[:] = Draw.NORMAL
    prop.escape[:] = True
    cand, _, _ = problem.propose(x, prop, 10, rng)
    oscillate(problem, cand, 5)
    problem.fitness_of_changed(cand, x, problem.fitness(x))
    problem.feasible(cand)
    pts = problem.node_points(cand[0])
    v = refine(pts[simplify(pts, problem.world)], problem.world, EnergyWeights())
    resample_waypoints(smooth_route(v, problem.world), problem.world, 30.0)
    world.points_clearance(pts)
    world.segments_clearance(pts[:-1], pts[1:])
