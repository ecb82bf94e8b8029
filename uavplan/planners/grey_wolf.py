"""Grey wolf optimiser (Mirjalili, Mirjalili & Lewis 2014) on the paper's path encoding.

The leaders α, β, δ are the three best distinct positions found so far. Every wolf proposes
each node as the mean over the leaders of X_k − A·|C·X_k − X| with A = 2a·r1 − a, C = 2·r2
drawn per node, axis and leader, redrawn for each retry of the reachability rule (the T_max
attempts are given to the shared kernel explicitly), ``a`` falling linearly 2 → 0. Wolves move
without selection, as in the original; the leaders are the memory.
"""

from __future__ import annotations

import functools

import numpy as np

from uavplan.config import GwoParams, SearchParams
from uavplan.planners.base import PathProblem, Population, SwarmPlanner
from uavplan.planners.proposal import Proposal

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
        pop.state["leaders"] = pop.x[lead].copy()
        pop.state["leaders_f"] = pop.f[lead].copy()
        pop.count("failed_updates", 0)

    def a(self, pop: Population) -> float:
        """a, linear from ``a_start`` (first iteration) toward ``a_end`` (a = 2 − 2·t/M)."""
        prm = self.params
        return prm.a_start + (prm.a_end - prm.a_start) * pop.iteration / pop.iterations

    def rule(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> Proposal:
        """Every wolf: T_max attempts of mean_k(X_k − A·|C·X_k − X|), fresh A, C each."""
        st = pop.state
        x = pop.x
        t_max = self.search.t_max
        leaders = st["leaders"]
        # with fewer than three distinct leaders so far, the last one stands in for the rest
        pick = np.minimum(np.arange(N_LEADERS), leaders.shape[0] - 1)
        lead = leaders[pick][:, None, None]  # (3, 1, 1, n, 2)
        a = self.a(pop)
        shape = (N_LEADERS, t_max, *x.shape)
        big_a = 2.0 * a * rng.random(shape) - a
        big_c = 2.0 * rng.random(shape)
        attempts = (lead - big_a * np.abs(big_c * lead - x[None, None])).mean(axis=0)
        prop = Proposal.for_population(x, n_explicit=t_max)
        prop.active[:] = True
        prop.explicit = attempts
        prop.n_explicit[:] = t_max
        return prop

    def step(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> None:
        st, x = pop.state, pop.x
        leaders = st["leaders"]
        cand, ok, _ = problem.propose(x, self.rule(problem, pop, rng), self.search.t_max, rng)
        pop.x = cand
        pop.f = problem.fitness_of_changed(cand, x, pop.f)
        pool_x = np.concatenate([leaders, cand])
        pool_f = np.concatenate([st["leaders_f"], pop.f])
        best = best_distinct(pool_x, pool_f, N_LEADERS)
        st["leaders"] = pool_x[best].copy()
        st["leaders_f"] = pool_f[best].copy()
        pop.count("failed_updates", int((~ok).sum()))

    def best(self, pop: Population) -> tuple[np.ndarray, float]:
        return pop.state["leaders"][0], float(pop.state["leaders_f"][0])
