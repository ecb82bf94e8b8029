"""SPSA / SSA with its iteration written in numpy: the readable formulation, and the oracle
the compiled step (:func:`uavplan.planners._kernels.spsa_step`, which
:class:`~uavplan.planners.sparrow.SparrowPlanner` runs) is held to.

This is the step as it was written before it was fused into C: every update rule computed
with numpy over the whole population and handed to the shared rebuild kernel as a
:class:`~uavplan.planners.proposal.Proposal`, the oscillation and the fitness through the
same kernels every planner uses. It draws its random numbers from the Generator in the order
the compiled step does, so the two give the same populations, fitness and convergence, bit
for bit (tests/planners/test_spsa_step.py; registered as ``spsa_numpy``, so the contract tests of
every planner run it too). Slower: the compiled step recalls a producer's fitness when its
candidate did not move after it was evaluated and caches the fitness of paths seen before,
so it counts as many or fewer fitness evaluations than this one.
"""

from __future__ import annotations

import numpy as np

from uavplan.config import ProducerRule, ScroungerIndex
from uavplan.planners import _kernels as K
from uavplan.planners.base import PathProblem, Population
from uavplan.planners.proposal import Draw, Proposal
from uavplan.planners.sparrow import SparrowPlanner, oscillate


class NumpySparrowPlanner(SparrowPlanner):
    """:class:`SparrowPlanner` (SPSA, or SSA with :meth:`SpsaParams.ssa
    <uavplan.config.SpsaParams.ssa>`) with its step written in numpy."""

    name = "spsa_numpy"

    def producers(
        self, problem: PathProblem, pop: Population, producers: np.ndarray, best_i: int,
        rng: np.random.Generator,
    ) -> Proposal:  # fmt: skip
        """Eq. 11 (SPSA: pulled toward the start-end line P_ST) or eq. 3 (SSA). δ = P − P_ST.

        R2 < ST: the best producer P + rand·(P_ST − P); the others, "deviation" reading,
        P_ST + δ·e − rand·δ (literal reading: P + e + rand·(P_ST − P)), e = exp(−i/(α·M)),
        i the producer's rank; SSA's eq. 3: P_ST + δ·e. R2 >= ST (alarm): P + Q·L on the first
        attempt, Q ~ N(0, 1) shared by the nodes, P + N(0, 1) on retries.
        """
        prm = self.params
        x = pop.x
        line = problem.line_u[1:-1]  # (n, 2) P_ST at every inner column
        prop = Proposal.for_population(x)
        prop.active[producers] = True
        n_prod = producers.size
        if rng.random() < prm.warning_value:
            ranks = np.arange(1, n_prod + 1)
            alpha = 1.0 - rng.random(n_prod)  # α in (0, 1]
            e = np.exp(-ranks / (alpha * pop.iterations))[:, None, None]
            p = x[producers]
            if prm.start_end_producer:
                if prm.producer_rule == ProducerRule.LITERAL:
                    prop.anchor[producers] = p + e
                    prop.spread[producers] = line - p
                else:
                    d = p - line
                    prop.anchor[producers] = line + d * e
                    prop.spread[producers] = -d
                prop.draw[producers] = Draw.UNIFORM
                prop.anchor[best_i] = x[best_i]
                prop.spread[best_i] = line - x[best_i]
            else:
                prop.anchor[producers] = line + (p - line) * e
        else:
            q = rng.standard_normal(n_prod)[:, None, None]
            prop.anchor[producers] = x[producers]
            prop.spread[producers] = 1.0
            prop.draw[producers] = Draw.NORMAL
            prop.first[producers] = x[producers] + q
            prop.use_first[producers] = True
        return prop

    def followers(
        self, problem: PathProblem, pop: Population, scroungers: np.ndarray, n_prod: int,
        p_best: np.ndarray, order: np.ndarray, rng: np.random.Generator,
    ) -> Proposal:  # fmt: skip
        """Scroungers (eq. 4, with eq. 12's escape) and danger-aware sparrows (eq. 5).

        A danger-aware sparrow's move replaces whatever its role would have given it, so a
        scrounger picked as danger-aware skips its eq. 4 update (a producer's update still
        counts: it may be the best producer).
        """
        prm = self.params
        x, f = pop.x, pop.f
        n_pop, n_inner = x.shape[0], x.shape[1]
        best_i, worst_i = order[0], order[-1]
        line = problem.line_u[1:-1]
        prop = Proposal.for_population(x)
        if prm.scrounger_index == ScroungerIndex.SCROUNGER:
            index, half = np.arange(1, scroungers.size + 1), scroungers.size / 2.0
        else:
            index, half = np.arange(n_prod + 1, n_pop + 1), n_pop / 2.0
        far = index > half
        # i > n/2: Q·exp((P_worst − P)/i²) about the line, Q ~ N(0, 1)
        fs = scroungers[far]
        prop.active[fs] = True
        prop.anchor[fs] = line
        dw = x[worst_i] - line
        d = x[fs] - line
        i2 = (index[far].astype(float) ** 2)[:, None, None]
        prop.spread[fs] = np.exp(np.minimum((dw - d) / i2, 50.0))
        prop.draw[fs] = Draw.NORMAL
        near = scroungers[~far]
        if near.size:
            # P_p + |P − P_p|·A⁺·L with A a random ±1 row: A⁺ = Aᵀ/d, one offset per path
            prop.active[near] = True
            signs = 2.0 * rng.integers(0, 2, size=(near.size, n_inner, 2)) - 1.0
            shift = (np.abs(x[near] - p_best) * signs).sum(axis=1) / n_inner
            prop.anchor[near] = p_best + shift[:, None, :]
        prop.escape[scroungers] = prm.escape
        n_danger = min(n_pop, round(prm.danger_ratio * n_pop))
        aware = rng.permutation(n_pop)[:n_danger]
        if n_danger:
            prop.active[aware] = True
            prop.escape[aware] = False
            is_best = f[aware] <= f[best_i]
            others, best = aware[~is_best], aware[is_best]
            # not the best: P_best + β·|P − P_best|, β ~ N(0, 1)
            prop.anchor[others] = x[best_i]
            prop.spread[others] = np.abs(x[others] - x[best_i])
            prop.draw[others] = Draw.NORMAL
            # the best: P + K·|P − P_worst|/(f_i − f_w + ε), K ~ U(−1, 1)
            k = (1.0 / (f[best] - f[worst_i] + K.SPSA_EPS))[:, None, None]
            prop.anchor[best] = x[best]
            prop.spread[best] = np.abs(x[best] - x[worst_i]) * k
            prop.draw[best] = Draw.SYMMETRIC
        return prop

    def step(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> None:
        """One iteration (Algorithm 3; the update rules are :meth:`producers` and
        :meth:`followers`): producers proposed and rebuilt, their fitness, the best producer's
        new position; scroungers and danger-aware sparrows proposed and rebuilt; SPSA's
        oscillation of every candidate that is not a known fixed point of it; greedy
        selection."""
        prm, search = self.params, self.search
        x, f = pop.x, pop.f
        n_pop = x.shape[0]
        order = np.argsort(f, kind="stable")
        best_i = order[0]
        n_prod = min(n_pop - 1, max(1, round(prm.producer_ratio * n_pop)))
        producers, scroungers = order[:n_prod], order[n_prod:]
        v_range = (prm.v_min, prm.v_max)

        prop = self.producers(problem, pop, producers, best_i, rng)
        cand, ok_p, _ = problem.propose(x, prop, search.t_max, rng, v_range)
        f_prod = problem.fitness_of_changed(cand[producers], x[producers], f[producers])
        p_best = cand[producers[int(np.argmin(f_prod))]]

        prop = self.followers(problem, pop, scroungers, n_prod, p_best, order, rng)
        cand_s, ok_s, escapes = problem.propose(x, prop, search.t_max, rng, v_range)
        moved = prop.active
        cand[moved] = cand_s[moved]

        # --- adaptive oscillation optimisation: eq. 13 -----------------------------------
        unchanged = ~(cand != x).any(axis=(1, 2))
        if prm.oscillation:
            fixed = pop.state["osc_fixed"]
            skip = unchanged & fixed
            moved = oscillate(problem, cand, prm.oscillation_window, skip)
            fixed[unchanged & ~skip] = moved[unchanged & ~skip] == 0

        # --- greedy selection ---------------------------------------------------------------
        f_cand = problem.fitness_of_changed(cand, x, f)
        better = f_cand < f
        x[better] = cand[better]
        f[better] = f_cand[better]
        if prm.oscillation:
            pop.state["osc_fixed"][better] = False
        pop.count("escapes", escapes)
        pop.count("failed_updates", int((~ok_p).sum() + (~ok_s).sum()))
