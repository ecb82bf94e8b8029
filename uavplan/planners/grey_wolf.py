"""Grey wolf optimiser (Mirjalili, Mirjalili & Lewis 2014) on the paper's path encoding.

The leaders α, β, δ are the three best distinct positions found so far. Every wolf proposes
each node through the shared kernel rule ``R_GWO``: the mean over the leaders of
X_k − A·|C·X_k − X| with A = 2a·r1 − a, C = 2·r2 drawn per node, axis and leader (redrawn on
each retry of the reachability rule), ``a`` falling linearly 2 → 0. Wolves move without
selection, as in the original; the leaders are the memory.
"""

from __future__ import annotations

import functools

import numpy as np

from uavplan.planners import _kernels as K
from uavplan.planners.base import PathProblem, Population, SwarmPlanner, empty_refs
from uavplan.planners.params import GwoParams, SearchParams

N_LEADERS = 3  # α, β, δ


def best_distinct(x: np.ndarray, f: np.ndarray, k: int) -> np.ndarray:
    """Indices of the ``k`` best rows of ``x`` (G, n, 2) with distinct positions, best first
    (fewer when fewer distinct positions exist)."""
    flat = x.reshape(x.shape[0], -1)
    # rows are integer grid nodes: a dot product with fixed random weights tells them apart
    # (far cheaper than np.unique over rows); the weights are not the search's randomness
    key = flat @ _row_weights(flat.shape[1])
    _, first = np.unique(key, return_index=True)
    return first[np.argsort(f[first], kind="stable")][:k]


@functools.cache
def _row_weights(n: int) -> np.ndarray:
    return np.random.default_rng(0x5EED).uniform(1.0, 2.0, n)


class GreyWolfPlanner(SwarmPlanner):
    name = "gwo"

    def __init__(self, search: SearchParams, params: GwoParams | None = None) -> None:
        super().__init__(search)
        self.params = params or GwoParams()

    def setup(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> None:
        lead = best_distinct(pop.x, pop.f, N_LEADERS)
        pop.extra["leaders"] = pop.x[lead].copy()
        pop.extra["leaders_f"] = pop.f[lead].copy()
        pop.extra["failed_updates"] = 0

    def a(self, pop: Population) -> float:
        """a, linear from ``a_start`` (first iteration) toward ``a_end`` (a = 2 − 2·t/M)."""
        prm = self.params
        return prm.a_start + (prm.a_end - prm.a_start) * pop.iteration / pop.iterations

    def step(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> None:
        ex = pop.extra
        x = pop.x
        n_pop, n_inner = x.shape[0], x.shape[1]
        leaders = ex["leaders"]
        # with fewer than three distinct leaders so far, the last one stands in for the rest
        pick = np.minimum(np.arange(N_LEADERS), leaders.shape[0] - 1)
        rules = np.full(n_pop, K.R_GWO, dtype=np.int64)
        refs, scal = empty_refs(n_pop, n_inner)
        refs[:, :N_LEADERS] = leaders[pick]
        scal[:, 0] = self.a(pop)
        no_escape = np.zeros(n_pop, dtype=np.bool_)
        cand, ok, _ = problem.rebuild(x, rules, refs, scal, no_escape, self.search.t_max, rng)
        pop.x = cand
        pop.f = problem.fitness_of_changed(cand, x, pop.f)
        pool_x = np.concatenate([leaders, cand])
        pool_f = np.concatenate([ex["leaders_f"], pop.f])
        lead = best_distinct(pool_x, pool_f, N_LEADERS)
        ex["leaders"] = pool_x[lead].copy()
        ex["leaders_f"] = pool_f[lead].copy()
        ex["failed_updates"] += int((~ok).sum())

    def best(self, pop: Population) -> tuple[np.ndarray, float]:
        return pop.extra["leaders"][0], float(pop.extra["leaders_f"][0])
