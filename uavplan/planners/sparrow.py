"""Sparrow search (SSA, Xue & Shen 2020) and the Sparrow Particle Swarm Algorithm (SPSA).

SPSA is SSA with the paper's five contributions (section 4, Algorithm 3):
  1. path initialisation toward the target (eq. 8–10) — shared by every planner here;
  2. producers pulled toward the start-end line (eq. 11 replaces eq. 3);
  3. adaptive variable-speed escape for scroungers stuck on an unreachable node (eq. 12);
  4. adaptive oscillation optimisation of every individual each iteration (eq. 13);
  5. node simplification and cubic-spline smoothing of the best path (post-processing,
     :mod:`uavplan.path.post`).
One class implements both; :meth:`SpsaParams.ssa` switches SPSA's contributions off and
restores SSA's own parameters.

Selection is greedy per individual: a candidate replaces its parent only when it is better.
The paper does not state it; Xue & Shen's reference code does the same (updates start from
the personal best ``pX``, which is replaced only by a better position).
"""

from __future__ import annotations

import numpy as np

from uavplan.planners import _kernels as K
from uavplan.planners.base import PathProblem, Population, SwarmPlanner, empty_refs
from uavplan.planners.params import SearchParams, SpsaParams

EPS = 1e-50  # ε of eq. 5, as in the reference code


class SparrowPlanner(SwarmPlanner):
    name = "spsa"
    postprocess = True
    default_fitness_smoothing = 2  # ours (see SearchParams.fitness_smoothing)

    def __init__(self, search: SearchParams, params: SpsaParams | None = None) -> None:
        super().__init__(search)
        self.params = params or SpsaParams()
        self.rounds = self.params.restarts

    def setup(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> None:
        if self.params.oscillation:
            # Algorithm 3: "Oscillation optimization of all individuals trajectories"
            moved = problem.oscillate(pop.x, self.params.oscillation_window)
            pop.f = problem.fitness(pop.x)
            pop.extra["oscillated_nodes"] = int(moved.sum())
            # a path the oscillation left unchanged is a fixed point of it (eq. 13 has no
            # randomness): it need not be oscillated again until it changes
            pop.extra["osc_fixed"] = moved == 0
        pop.extra.setdefault("escapes", 0)
        pop.extra.setdefault("failed_updates", 0)

    @staticmethod
    def _buffers(pop: Population) -> tuple[np.ndarray, np.ndarray]:
        """Reference-path and scalar arrays reused across calls; a rule reads only the
        entries its own update sets, so they need no clearing."""
        if "refs" not in pop.extra:
            pop.extra["refs"], pop.extra["scal"] = empty_refs(pop.x.shape[0], pop.x.shape[1])
        return pop.extra["refs"], pop.extra["scal"]

    def step(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> None:
        prm, search = self.params, self.search
        x, f = pop.x, pop.f
        n_pop, n_inner = x.shape[0], x.shape[1]
        order = np.argsort(f, kind="stable")
        best_i, worst_i = order[0], order[-1]
        n_prod = min(n_pop - 1, max(1, round(prm.producer_ratio * n_pop)))
        producers, scroungers = order[:n_prod], order[n_prod:]
        v_range = (prm.v_min, prm.v_max)

        # --- producers: eq. 11 (SPSA) or eq. 3 (SSA) ---------------------------------------
        rules = np.full(n_pop, -1, dtype=np.int64)
        refs, scal = self._buffers(pop)
        if rng.random() < prm.warning_value:
            ranks = np.arange(1, n_prod + 1)
            alpha = 1.0 - rng.random(n_prod)  # α in (0, 1]
            scal[producers, 0] = np.exp(-ranks / (alpha * pop.iterations))
            if prm.start_end_producer:
                literal = prm.producer_rule == "literal"
                rules[producers] = K.R_SPSA_PRODUCER_LITERAL if literal else K.R_SPSA_PRODUCER
                rules[best_i] = K.R_SPSA_PRODUCER_BEST
            else:
                rules[producers] = K.R_SSA_PRODUCER
        else:
            rules[producers] = K.R_ALARM
            scal[producers, 0] = rng.standard_normal(n_prod)
        no_escape = np.zeros(n_pop, dtype=np.bool_)
        cand, ok_p, _ = problem.rebuild(x, rules, refs, scal, no_escape, search.t_max, rng, v_range)
        f_prod = problem.fitness_of_changed(cand[producers], x[producers], f[producers])
        p_best = cand[producers[int(np.argmin(f_prod))]]

        # --- scroungers (eq. 4, escape of eq. 12) and danger-aware sparrows (eq. 5) ---------
        # One kernel call: a danger-aware sparrow's new position replaces whatever its role
        # would have given it, so a scrounger picked as danger-aware skips its eq. 4 update
        # (a producer's update above still counts: it may be the best producer).
        rules = np.full(n_pop, -1, dtype=np.int64)
        if prm.scrounger_index == "scrounger":
            index, half = np.arange(1, scroungers.size + 1), scroungers.size / 2.0
        else:
            index, half = np.arange(n_prod + 1, n_pop + 1), n_pop / 2.0
        far = index > half
        rules[scroungers[far]] = K.R_SCROUNGER_FAR
        refs[scroungers[far], 0] = x[worst_i]
        scal[scroungers[far], 0] = index[far].astype(float) ** 2
        near = scroungers[~far]
        if near.size:
            rules[near] = K.R_SCROUNGER_NEAR
            refs[near, 0] = p_best
            # |P − P_p|·A⁺·L with A a random ±1 row: A⁺ = Aᵀ/d, the same offset on every node
            signs = 2.0 * rng.integers(0, 2, size=(near.size, n_inner, 2)) - 1.0
            scal[near, :2] = (np.abs(x[near] - p_best) * signs).sum(axis=1) / n_inner
        escape = np.zeros(n_pop, dtype=np.bool_)
        escape[scroungers] = prm.escape
        n_danger = min(n_pop, round(prm.danger_ratio * n_pop))
        aware = rng.permutation(n_pop)[:n_danger]
        if n_danger:
            escape[aware] = False
            is_best = f[aware] <= f[best_i]
            rules[aware[~is_best]] = K.R_DANGER
            refs[aware[~is_best], 0] = x[best_i]
            rules[aware[is_best]] = K.R_DANGER_BEST
            refs[aware[is_best], 0] = x[worst_i]
            scal[aware[is_best], 0] = 1.0 / (f[aware[is_best]] - f[worst_i] + EPS)
        cand_s, ok_s, escapes = problem.rebuild(
            x, rules, refs, scal, escape, search.t_max, rng, v_range
        )
        moved = rules >= 0
        cand[moved] = cand_s[moved]

        # --- adaptive oscillation optimisation: eq. 13 -----------------------------------
        unchanged = ~(cand != x).any(axis=(1, 2))
        if prm.oscillation:
            fixed = pop.extra["osc_fixed"]
            skip = unchanged & fixed
            moved = problem.oscillate(cand, prm.oscillation_window, skip)
            fixed[unchanged & ~skip] = moved[unchanged & ~skip] == 0

        # --- greedy selection ---------------------------------------------------------------
        f_cand = problem.fitness_of_changed(cand, x, f)
        better = f_cand < f
        x[better] = cand[better]
        f[better] = f_cand[better]
        if prm.oscillation:
            pop.extra["osc_fixed"][better] = False
        pop.extra["escapes"] += escapes
        pop.extra["failed_updates"] += int((~ok_p).sum() + (~ok_s).sum())


class SsaPlanner(SparrowPlanner):
    """The original sparrow search: SPSA's machinery with its contributions switched off."""

    name = "ssa"
    postprocess = False
    default_fitness_smoothing = 0

    def __init__(self, search: SearchParams, params: SpsaParams | None = None) -> None:
        super().__init__(search, params or SpsaParams.ssa())
