"""Chicken swarm optimisation (Meng, Liu, Gao & Zhang 2014) on the paper's path encoding.
(*Chicken* swarm; not the cat swarm that shares the acronym.)

Every G iterations the swarm is ranked and split into roosters (best), hens and chicks; each
hen joins a rooster's group and each chick follows a mother hen. Between updates the roles
stay with the individuals. Per iteration, as one :class:`Proposal`:
  * rooster i: x·(1 + σ²·N(0, 1)) with σ² = 1 if f_i ≤ f_k, else exp((f_k − f_i)/(|f_i| + ε)),
    k another random rooster (the product acts on the deviation from the start-end line, the
    path frame's natural origin, as SSA's eq. 3 does here);
  * hen i: x + S1·rand·(x_r1 − x) + S2·rand·(x_r2 − x), r1 its rooster, r2 a random
    individual ranked no worse than i at the last update, r2 ≠ r1 (Meng's code),
    S1 = exp((f_i − f_r1)/(|f_i| + ε)), S2 = exp(f_r2 − f_i);
  * chick i: x + FL·(x_m − x), m its mother, FL ~ U(fl_min, fl_max).
Updates start from each individual's best position and replace it only when better, as in
the authors' code (personal bests ``pX``), i.e. greedy selection.

S2's exponent is capped at 0: it is meant for r2 ranked better than i (then S2 ≤ 1); when
i has overtaken r2 since the last ranking the raw formula overflows with fitness values in
the thousands.
"""

from __future__ import annotations

import math

import numpy as np

from uavplan.config import CsoParams, SearchParams
from uavplan.planners.base import PathProblem, Population, SwarmPlanner
from uavplan.planners.proposal import Draw, Proposal

EPS = float(np.finfo(float).tiny)  # ε (``realmin`` in the authors' code)


def _round_half_up(v: float) -> int:
    return int(math.floor(v + 0.5))  # MATLAB's round, as in the authors' code


class ChickenSwarmPlanner(SwarmPlanner):
    name = "cso"

    def __init__(self, search: SearchParams, params: CsoParams | None = None) -> None:
        super().__init__(search)
        self.params = params or CsoParams()

    def group_sizes(self, n_pop: int) -> tuple[int, int, int, int]:
        """(roosters, hens, chicks, mothers) for a swarm of ``n_pop``."""
        prm = self.params
        n_r = min(n_pop - 1, max(1, _round_half_up(prm.rooster_ratio * n_pop)))
        n_h = min(n_pop - n_r, max(1, _round_half_up(prm.hen_ratio * n_pop)))
        n_c = n_pop - n_r - n_h
        n_m = min(n_h, max(1, _round_half_up(prm.mother_ratio * n_h)))
        return n_r, n_h, n_c, n_m

    def setup(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> None:
        pop.count("failed_updates", 0)

    def _rank(self, pop: Population, rng: np.random.Generator) -> None:
        """Establish the hierarchy (every G iterations): roles, groups, mothers, FL."""
        prm, ex = self.params, pop.state
        n_r, n_h, n_c, n_m = self.group_sizes(pop.f.size)
        order = np.argsort(pop.f, kind="stable")  # population indices, best first
        ex["order"] = order
        # each hen's rooster (ranks 0..n_r-1): every rooster first, then random ones
        ex["mate_rank"] = np.concatenate(
            [rng.permutation(n_r), rng.integers(0, n_r, size=max(0, n_h - n_r))]
        )[:n_h]
        mothers = n_r + rng.permutation(n_h)[:n_m]  # ranks of the mother hens
        ex["mother_rank"] = mothers[rng.integers(0, n_m, size=n_c)]
        ex["fl"] = rng.uniform(prm.fl_min, prm.fl_max, size=n_c)

    def rule(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> Proposal:
        """Roosters, hens and chicks as the module doc says (ranks from the last update)."""
        ex = pop.state
        x, f = pop.x, pop.f
        n_pop = x.shape[0]
        n_r, n_h, _, _ = self.group_sizes(n_pop)
        order = ex["order"]
        roosters, hens, chicks = order[:n_r], order[n_r : n_r + n_h], order[n_r + n_h :]
        line = problem.line_u[1:-1]
        prop = Proposal.for_population(x)
        prop.active[:] = True

        # roosters: another random rooster k decides the spread σ²: x + (x − P_ST)·σ²·N(0, 1)
        if n_r > 1:
            shift = rng.integers(1, n_r, size=n_r)  # k ≠ i among the roosters
            k = roosters[(np.arange(n_r) + shift) % n_r]
            fi, fk = f[roosters], f[k]
            sigma2 = np.where(fi <= fk, 1.0, np.exp((fk - fi) / (np.abs(fi) + EPS)))
        else:
            sigma2 = np.ones(1)
        prop.spread[roosters] = (x[roosters] - line) * sigma2[:, None, None]
        prop.draw[roosters] = Draw.NORMAL

        # hens: follow their rooster r1 and steal from r2 (rank ≤ own rank, r2 ≠ r1)
        own_rank = np.arange(n_r, n_r + n_h)
        mate_rank = ex["mate_rank"]
        u = np.floor(rng.random(n_h) * own_rank).astype(np.int64)  # 0..own_rank-1
        other_rank = u + (u >= mate_rank)
        r1, r2 = order[mate_rank], order[other_rank]
        fi = f[hens]
        s1 = np.exp((fi - f[r1]) / (np.abs(fi) + EPS))[:, None, None]
        s2 = np.exp(np.minimum(f[r2] - fi, 0.0))[:, None, None]
        prop.spread[hens] = s1 * (x[r1] - x[hens])
        prop.draw[hens] = Draw.UNIFORM
        prop.spread2[hens] = s2 * (x[r2] - x[hens])
        prop.draw2[hens] = Draw.UNIFORM

        # chicks: follow their mother
        if chicks.size:
            mothers = order[ex["mother_rank"]]
            prop.anchor[chicks] = x[chicks] + ex["fl"][:, None, None] * (x[mothers] - x[chicks])
        return prop

    def step(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> None:
        if pop.iteration % self.params.g == 0:
            self._rank(pop, rng)
        x, f = pop.x, pop.f
        cand, ok, _ = problem.propose(x, self.rule(problem, pop, rng), self.search.t_max, rng)
        f_cand = problem.fitness_of_changed(cand, x, f)
        better = f_cand < f
        x[better] = cand[better]
        f[better] = f_cand[better]
        pop.count("failed_updates", int((~ok).sum()))
