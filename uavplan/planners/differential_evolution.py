"""Differential evolution DE/rand/1/bin (Storn & Price 1997) on the paper's path encoding.

For every target x_i: three distinct others r1, r2, r3 ≠ i, mutant x_r1 + F·(x_r2 − x_r3),
binomial crossover with rate CR and one forced coordinate j_rand (a node axis). The trial is
given to the shared kernel as explicit attempts: when a trial node is unreachable the
crossover draw is repeated (up to T_max times; j_rand forced on the first only) before the
old node is kept. Greedy one-to-one selection.
"""

from __future__ import annotations

import numpy as np

from uavplan.planners.base import PathProblem, Population, SwarmPlanner
from uavplan.planners.params import DeParams, SearchParams
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
        """Every target: its T_max trials x_r1 + F·(x_r2 − x_r3) crossed with x (binomial CR;
        j_rand forced on the first), as explicit attempts."""
        prm = self.params
        x = pop.x
        n_pop, n_inner = x.shape[0], x.shape[1]
        t_max = self.search.t_max
        r = distinct_others(n_pop, 3, rng)
        mutant = x[r[:, 0]] + prm.f * (x[r[:, 1]] - x[r[:, 2]])
        j_rand = rng.integers(0, 2 * n_inner, size=n_pop)
        cross = rng.random((t_max, n_pop, n_inner, 2)) < prm.cr
        forced = np.zeros((n_pop, n_inner * 2), dtype=bool)
        forced[np.arange(n_pop), j_rand] = True
        cross[0] |= forced.reshape(n_pop, n_inner, 2)
        prop = Proposal.for_population(x, n_explicit=t_max)
        prop.active[:] = True
        prop.explicit = np.where(cross, mutant[None], x[None])
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
