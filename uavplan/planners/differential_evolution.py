"""Differential evolution DE/rand/1/bin (Storn & Price 1997) on the paper's path encoding.

For every target x_i: three distinct others r1, r2, r3 ≠ i, mutant x_r1 + F·(x_r2 − x_r3),
binomial crossover with rate CR and one forced coordinate j_rand (a node axis), all through
the shared kernel rule ``R_DE``; when a trial node is unreachable the crossover draw is
repeated (up to T_max times) before the old node is kept. Greedy one-to-one selection.
"""

from __future__ import annotations

import numpy as np

from uavplan.planners import _kernels as K
from uavplan.planners.base import PathProblem, Population, SwarmPlanner, empty_refs
from uavplan.planners.params import DeParams, SearchParams


def distinct_others(n_pop: int, k: int, rng: np.random.Generator) -> np.ndarray:
    """(n_pop, k) indices: for each row i, ``k`` distinct indices drawn uniformly from the
    population without i (needs n_pop > k)."""
    keys = rng.random((n_pop, n_pop))
    np.fill_diagonal(keys, np.inf)
    return np.argsort(keys, axis=1)[:, :k]


class DifferentialEvolutionPlanner(SwarmPlanner):
    name = "de"

    def __init__(self, search: SearchParams, params: DeParams | None = None) -> None:
        super().__init__(search)
        self.params = params or DeParams()

    def setup(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> None:
        pop.extra["failed_updates"] = 0

    def step(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> None:
        prm = self.params
        x, f = pop.x, pop.f
        n_pop, n_inner = x.shape[0], x.shape[1]
        r = distinct_others(n_pop, 3, rng)
        rules = np.full(n_pop, K.R_DE, dtype=np.int64)
        refs, scal = empty_refs(n_pop, n_inner)
        refs[:, 0] = x[r[:, 0]]
        refs[:, 1] = x[r[:, 1]]
        refs[:, 2] = x[r[:, 2]]
        scal[:, 0] = prm.f
        scal[:, 1] = prm.cr
        scal[:, 2] = rng.integers(0, 2 * n_inner, size=n_pop)
        no_escape = np.zeros(n_pop, dtype=np.bool_)
        cand, ok, _ = problem.rebuild(x, rules, refs, scal, no_escape, self.search.t_max, rng)
        f_cand = problem.fitness_of_changed(cand, x, f)
        better = f_cand < f
        x[better] = cand[better]
        f[better] = f_cand[better]
        pop.extra["failed_updates"] += int((~ok).sum())
