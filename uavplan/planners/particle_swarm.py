"""Particle swarm optimisation (Kennedy & Eberhart 1995) with a linearly decreasing inertia
weight (Shi & Eberhart 1998, 1999), on the paper's path encoding.

Every particle proposes all its nodes through the shared kernel rule ``R_PSO``
(v ← w·v + c1·r1·(pbest − x) + c2·r2·(gbest − x), clamped to ±Vmax, x ← x + v) under the
reachability rule every planner follows: an unreachable node is re-proposed with fresh
r1, r2 up to T_max times, then the old node is kept (paper section 6). Positions are not
selected greedily (PSO has no selection); memory lives in the personal and global bests.
The velocity carried forward is the displacement the particle actually made.
"""

from __future__ import annotations

import numpy as np

from uavplan.planners import _kernels as K
from uavplan.planners.base import PathProblem, Population, SwarmPlanner, empty_refs
from uavplan.planners.params import PsoParams, SearchParams


def axis_ranges_units(problem: PathProblem) -> np.ndarray:
    """(2,) extent of the flight volume across the path, in grid units: (y, z)."""
    tab = problem.table[0]  # (D + 1, ny, nz) node clearance over the bounds' grid
    return np.array([tab.shape[1] - 1, tab.shape[2] - 1], dtype=float)


class ParticleSwarmPlanner(SwarmPlanner):
    name = "pso"

    def __init__(self, search: SearchParams, params: PsoParams | None = None) -> None:
        super().__init__(search)
        self.params = params or PsoParams()

    def setup(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> None:
        i = pop.best_index
        pop.extra["velocity"] = np.zeros_like(pop.x)
        pop.extra["pbest"] = pop.x.copy()
        pop.extra["pbest_f"] = pop.f.copy()
        pop.extra["gbest"] = pop.x[i].copy()
        pop.extra["gbest_f"] = float(pop.f[i])
        frac = self.params.v_max_fraction
        pop.extra["v_max"] = (
            np.zeros(2) if frac is None else np.maximum(1.0, frac * axis_ranges_units(problem))
        )
        pop.extra["failed_updates"] = 0

    def inertia(self, pop: Population) -> float:
        """w, linear from ``w_start`` at the first iteration to ``w_end`` at the last."""
        prm = self.params
        frac = pop.iteration / max(1, pop.iterations - 1)
        return prm.w_start + (prm.w_end - prm.w_start) * frac

    def step(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> None:
        prm, ex = self.params, pop.extra
        x = pop.x
        n_pop, n_inner = x.shape[0], x.shape[1]
        rules = np.full(n_pop, K.R_PSO, dtype=np.int64)
        refs, scal = empty_refs(n_pop, n_inner)
        refs[:, 0] = ex["velocity"]
        refs[:, 1] = ex["pbest"]
        refs[:, 2] = ex["gbest"]
        refs[:, 3] = ex["v_max"]
        scal[:, 0] = self.inertia(pop)
        scal[:, 1] = prm.c1
        scal[:, 2] = prm.c2
        no_escape = np.zeros(n_pop, dtype=np.bool_)
        cand, ok, _ = problem.rebuild(x, rules, refs, scal, no_escape, self.search.t_max, rng)
        ex["velocity"] = cand - x
        pop.x = cand
        pop.f = problem.fitness_of_changed(cand, x, pop.f)
        better = pop.f < ex["pbest_f"]
        ex["pbest"][better] = cand[better]
        ex["pbest_f"][better] = pop.f[better]
        i = int(np.argmin(ex["pbest_f"]))
        if ex["pbest_f"][i] < ex["gbest_f"]:
            ex["gbest"] = ex["pbest"][i].copy()
            ex["gbest_f"] = float(ex["pbest_f"][i])
        ex["failed_updates"] += int((~ok).sum())

    def best(self, pop: Population) -> tuple[np.ndarray, float]:
        return pop.extra["gbest"], pop.extra["gbest_f"]
