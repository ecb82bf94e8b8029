"""Differential evolution DE/rand/1/bin (Storn & Price 1997) on the paper's path encoding.

For every target x_i: three distinct others r1, r2, r3 ≠ i, mutant x_r1 + F·(x_r2 − x_r3),
binomial crossover with rate CR and one forced coordinate j_rand (a node axis). Reachability
(paper section 6: an unreachable node is proposed again, up to T_max times): the T_max
attempts are T_max independent trials (fresh donors, coin and j_rand), given to the shared
kernel explicitly; after T_max unreachable values the old node is kept. Greedy one-to-one
selection.
"""

from __future__ import annotations

import numpy as np

from uavplan.config import DeParams, SearchParams
from uavplan.planners.base import PathProblem, Population, SwarmPlanner
from uavplan.planners.proposal import Proposal


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
        pop.count("failed_updates", 0)

    def rule(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> Proposal:
        """Every target: T_max trials, each a fresh DE/rand/1/bin trial — new donors r1, r2,
        r3, mutant x_r1 + F·(x_r2 − x_r3), binomial crossover CR with its own j_rand — given
        to the kernel as explicit attempts: a node whose trial value is unreachable is retried
        with the next trial's value (redrawing only the crossover coin, as before, retried a
        blocked mutant node against itself, and DE accepted almost no trial)."""
        prm = self.params
        x = pop.x
        n_pop, n_inner = x.shape[0], x.shape[1]
        t_max = self.search.t_max
        r = np.stack([distinct_others(n_pop, 3, rng) for _ in range(t_max)])  # (t, G, 3)
        mutant = x[r[..., 0]] + prm.f * (x[r[..., 1]] - x[r[..., 2]])  # (t, G, n, 2)
        coin = (rng.random((t_max, n_pop, n_inner, 2)) < prm.cr).reshape(t_max, n_pop, -1)
        j_rand = rng.integers(0, 2 * n_inner, size=(t_max, n_pop))
        coin[np.arange(t_max)[:, None], np.arange(n_pop)[None, :], j_rand] = True
        cross = coin.reshape(t_max, n_pop, n_inner, 2)
        prop = Proposal.for_population(x, n_explicit=t_max)
        prop.active[:] = True
        prop.explicit = np.where(cross, mutant, x[None])
        prop.n_explicit[:] = t_max
        return prop

    def step(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> None:
        x, f = pop.x, pop.f
        cand, ok, _ = problem.propose(x, self.rule(problem, pop, rng), self.search.t_max, rng)
        f_cand = problem.fitness_of_changed(cand, x, f)
        better = f_cand < f
        x[better] = cand[better]
        f[better] = f_cand[better]
        pop.count("failed_updates", int((~ok).sum()))
