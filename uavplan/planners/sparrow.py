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

from uavplan.config import ProducerRule, ScroungerIndex, SearchParams, SpsaParams
from uavplan.planners import _kernels as K
from uavplan.planners.base import PathProblem, Population, SwarmPlanner


def oscillate(
    problem: PathProblem, nodes: np.ndarray, window: int, skip: np.ndarray | None = None
) -> np.ndarray:
    """Adaptive oscillation optimisation (section 4.4, eq. 13) of ``nodes`` (G, n, 2) in
    place, individuals with ``skip`` set left alone; returns the nodes moved per individual.
    Node j becomes the rounded mean of the window P_{j−1} .. P_{j+N_p−2}, N_p shrinking from
    ``window`` to 3 while that node is unreachable (the kernel's moving-average repair)."""
    if skip is None:
        skip = np.zeros(nodes.shape[0], dtype=np.bool_)
    return K.moving_average_repair(nodes, problem.goal_u, window, problem.reach, skip)


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
            moved = oscillate(problem, pop.x, self.params.oscillation_window)
            pop.f = problem.fitness(pop.x)
            pop.count("oscillated_nodes", int(moved.sum()))
            # a path the oscillation left unchanged is a fixed point of it (eq. 13 has no
            # randomness): it need not be oscillated again until it changes
            pop.state["osc_fixed"] = moved == 0
        pop.count("escapes", 0)
        pop.count("failed_updates", 0)
        pop.state["threads"] = self.threads or K.step_threads()  # read once per search

    def step(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> None:
        """One iteration (Algorithm 3), fused in the compiled kernel
        (:func:`uavplan.planners._kernels.spsa_step`); this method draws its random numbers
        from ``rng``, in the order the numpy formulation
        (:class:`~uavplan.planners.sparrow_numpy.NumpySparrowPlanner`, ``spsa_numpy``) draws
        them (the tests hold the two to the same results).

        Ranks: the ``PD·G`` fittest are producers, the rest scroungers. δ = P − P_ST, P_ST
        the start-end line at every inner column.

        * Producers, R2 < ST (eq. 11, SPSA): the best producer P + rand·(P_ST − P); the
          others, "deviation" reading, P_ST + δ·e − rand·δ (literal reading: P + e +
          rand·(P_ST − P)), e = exp(−i/(α·M)), i the producer's rank, α ~ U(0, 1]; SSA's
          eq. 3: P_ST + δ·e. R2 >= ST (alarm): P + Q·L on the first attempt, Q ~ N(0, 1)
          shared by the nodes, P + N(0, 1) on retries.
        * Scroungers (eq. 4): i > n/2: Q·exp((P_worst − P)/i²) about the line; otherwise
          P_p + |P − P_p|·A⁺·L with A a random ±1 row (A⁺ = Aᵀ/d: one offset per path), P_p
          the best producer's new position. With SPSA's escape (eq. 12) a scrounger that
          cannot place a node tries the adaptive variable-speed escape.
        * Danger-aware sparrows (eq. 5, ``SD·G`` drawn at random; their move replaces their
          role's): not the best, P_best + β·|P − P_best|, β ~ N(0, 1); the best,
          P + K·|P − P_worst|/(f_i − f_w + ε), K ~ U(−1, 1).
        * Every candidate is rebuilt under the reachability rule, then (SPSA) the adaptive
          oscillation optimisation (eq. 13) runs on every candidate that is not a known
          fixed point of it, and greedy selection keeps a candidate only when it is better.
        """
        prm = self.params
        n_pop, n_inner = pop.x.shape[0], pop.x.shape[1]
        sizes = pop.state.get("sizes")
        if sizes is None:
            sizes = pop.state["sizes"] = self._sizes(n_pop)
        n_prod, n_near, n_danger, flags = sizes
        setup = pop.state.get("step_setup")
        if setup is None:  # what every step of this search shares, built once
            setup = pop.state["step_setup"] = self._step_setup(problem, pop, n_prod, flags)
        warn = rng.random()
        if warn < prm.warning_value:
            pdraw = 1.0 - rng.random(n_prod)  # α in (0, 1]
        else:
            pdraw = rng.standard_normal(n_prod)  # Q
        seeds1 = K.stream_seeds(rng, n_pop)
        signs = K.sign_draws(rng, (n_near, n_inner, 2))  # 2·rng.integers(0, 2) − 1
        aware = rng.permutation(n_pop)[:n_danger].astype(np.int64, copy=False)
        seeds2 = K.stream_seeds(rng, n_pop)
        draws = K.StepDraws(warn, pdraw, signs, aware, seeds1, seeds2)
        fixed = pop.state.get("osc_fixed")
        if fixed is None:
            fixed = pop.state["osc_fixed"] = np.zeros(n_pop, dtype=np.bool_)
        counts = np.zeros(3, dtype=np.int64)
        K.spsa_step(pop.x, pop.f, fixed, counts, setup, draws)
        problem.counters[0] += counts[0]
        pop.count("escapes", int(counts[1]))
        pop.count("failed_updates", int(counts[2]))

    def _step_setup(
        self, problem: PathProblem, pop: Population, n_prod: int, flags: int
    ) -> K.StepSetup:
        """What every fused step of this search shares (the fitness cache: ``setup``'s, or a
        new one of the default size)."""
        prm = self.params
        cache = pop.state.get("energy_cache")
        if cache is None:
            cache = pop.state["energy_cache"] = K.new_energy_cache(pop.x.shape[1])
        return K.StepSetup(
            reach=problem.reach,
            energy=problem.energy_args,
            line=self._line(problem),
            goal_u=problem.goal_u,
            n_prod=n_prod,
            iterations=pop.iterations,
            t_max=self.search.t_max,
            v_min=prm.v_min,
            v_max=prm.v_max,
            window=prm.oscillation_window,
            flags=flags,
            warning_value=prm.warning_value,
            cache=cache,
            threads=pop.state.get("threads", 1),
        )

    def _sizes(self, n_pop: int) -> tuple[int, int, int, int]:
        """(producers, scroungers with i <= n/2, danger-aware sparrows, the kernel's flags)
        for a population of ``n_pop``."""
        prm = self.params
        n_prod = min(n_pop - 1, max(1, round(prm.producer_ratio * n_pop)))
        n_scr = n_pop - n_prod
        if prm.scrounger_index == ScroungerIndex.SCROUNGER:
            n_near = sum(1 for i in range(1, n_scr + 1) if i <= n_scr / 2.0)
        else:
            n_near = sum(1 for i in range(n_prod + 1, n_pop + 1) if i <= n_pop / 2.0)
        n_danger = min(n_pop, round(prm.danger_ratio * n_pop))
        flags = (
            (K.SPSA_START_END if prm.start_end_producer else 0)
            | (K.SPSA_LITERAL if prm.producer_rule == ProducerRule.LITERAL else 0)
            | (K.SPSA_POP_INDEX if prm.scrounger_index == ScroungerIndex.POPULATION else 0)
            | (K.SPSA_ESCAPE if prm.escape else 0)
            | (K.SPSA_OSCILLATE if prm.oscillation else 0)
        )
        return n_prod, n_near, n_danger, flags

    @staticmethod
    def _line(problem: PathProblem) -> np.ndarray:
        """The start-end line P_ST at the inner columns (n, 2), contiguous."""
        return np.ascontiguousarray(problem.line_u[1:-1])


class SsaPlanner(SparrowPlanner):
    """The original sparrow search: SPSA's machinery with its contributions switched off."""

    name = "ssa"
    postprocess = False
    default_fitness_smoothing = 0

    def __init__(self, search: SearchParams, params: SpsaParams | None = None) -> None:
        super().__init__(search, params or SpsaParams.ssa())
