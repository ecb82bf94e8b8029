"""The planner contract: a problem, a result record, and the population loop every
algorithm shares (STYLE: Problem, Algorithm and Termination kept apart, outcomes as values).

A :class:`PathProblem` is the world in the path frame plus the encoding; an algorithm
subclasses :class:`SwarmPlanner` and supplies ``setup`` and ``step``: how it turns the current
population into candidates. Initialisation (eq. 8–10), the reachability rule, fitness,
convergence recording and progress reporting are shared, so differences between algorithms
come from their update rules alone (the paper's protocol, section 6).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any

import numpy as np

from uavplan.config import MARGIN_PAD_M, EnergyWeights, GridSpec, SearchParams
from uavplan.outcome import SearchEnd
from uavplan.path.energy import N_SUB, NO_PHYSICS, EnergyArgs, PhysicalFitness, energy_of
from uavplan.path.frame import PathFrame
from uavplan.planners import _kernels as K
from uavplan.planners.proposal import Proposal
from uavplan.world import World

#: starts per individual before the initialisation gives up on it
INIT_MAX_ATTEMPTS = 25
#: a search needs at least this share of its population initialised: the deadlocked
#: individuals are replaced by copies of the initialised ones, and a population of copies of
#: a few paths does not search (over terrain, one wandering path of 30 flew a 25 km crossing
#: 8 % above the grid search's route: docs/algorithm.md, "Long routes and large volumes").
#: The bundled scenarios initialise 17 or more of 30 (narrow-gap, seeds 1-20), the failing
#: terrain cases 0-4
INIT_MIN_SHARE = 0.25
#: the clearance table is exact below the margin + this (m); the terrain's clearances above
#: it may be lower bounds (see ``K.clearance_table``)
TABLE_EXACT_PAD_M = 1.0

ProgressFn = Callable[[int, int, float], None]  # (iteration, iterations, best fitness)


@dataclass(frozen=True, eq=False)
class PathProblem:
    """World in the path frame + path encoding + fitness weights."""

    frame: PathFrame
    world: World  # in the path frame
    energy: EnergyWeights
    start_m: np.ndarray  # (3,) path frame
    goal_m: np.ndarray  # (3,)
    start_u: np.ndarray  # (2,) grid units (y, z)
    goal_u: np.ndarray  # (2,)
    line_u: np.ndarray  # (D + 1, 2) start-end line in grid units
    table: tuple[np.ndarray, np.ndarray]  # node clearance table (D+1, ny, nz), (y, z) offsets
    #: (D + 1, 4) per column the valid node range in grid units: y_lo, y_hi, z_lo, z_hi
    window: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    fitness_smoothing: int = 0  # see population_energy: 0 = the paper's fitness
    memo: np.ndarray = field(default_factory=K.new_memo)
    #: evaluation budget used so far: fitness evaluations, reachability checks, exact tests
    counters: np.ndarray = field(default_factory=lambda: np.zeros(3, dtype=np.int64))
    #: a search on this problem stops once it made this many fitness evaluations (None: no
    #: limit), like ``Termination.max_evaluations``; carried by the problem so a caller that
    #: hands the problem to a pipeline (the bench) can share one budget among algorithms
    max_evaluations: int | None = None
    #: the physical fitness (``planner: {energy: physical}``): the fitness is the power
    #: model's watt-hours of the path, not eq. 1-2 with ``energy``'s weights (None: the paper's)
    physical: PhysicalFitness | None = None

    @classmethod
    def build(
        cls,
        world_enu: World,
        start_enu: tuple[float, float, float],
        goal_enu: tuple[float, float, float],
        grid: GridSpec,
        energy: EnergyWeights,
        fitness_smoothing: int = 0,
        physical: PhysicalFitness | None = None,
    ) -> PathProblem:
        """The problem from ``start_enu`` to ``goal_enu`` in ``world_enu``, in the paper's
        straight frame. The route keeps the margin from the ground too: it never flies lower
        than the margin, or than the start or goal when they are lower (the flight volume's
        floor, if higher, stands)."""
        frame = PathFrame.build(start_enu, goal_enu, grid)
        floor = min(world_enu.margin_m, float(start_enu[2]), float(goal_enu[2]))
        world = world_enu.in_frame(
            frame.origin_xy, frame.heading_rad, world_enu.margin_m + MARGIN_PAD_M, floor
        )
        return cls.in_frame(world, frame, energy, fitness_smoothing, physical)

    @classmethod
    def in_frame(
        cls,
        world: World,
        frame: PathFrame,
        energy: EnergyWeights,
        fitness_smoothing: int = 0,
        physical: PhysicalFitness | None = None,
    ) -> PathProblem:
        """The problem of ``frame``'s columns in ``world`` (already in the path frame)."""
        start_m = np.array([0.0, 0.0, float(frame.start_enu[2])])
        goal_m = np.array([frame.length_m, 0.0, float(frame.goal_enu[2])])
        line = np.zeros((frame.n_cols + 1, 2))
        line[:, 1] = frame.line_z_units
        table, window = _clearance_table(world, frame)
        return cls(
            frame,
            world,
            energy,
            start_m,
            goal_m,
            np.array(frame.start_units),
            np.array(frame.goal_units),
            line,
            table,
            window,
            fitness_smoothing,
            physical=physical,
        )

    def along(self, guide_xy: np.ndarray) -> PathProblem:
        """The same problem with its columns along ``guide_xy`` (k, 2), a polyline in the path
        frame from the start to the goal (see :meth:`PathFrame.along`); fresh memo."""
        frame = self.frame.along(guide_xy)
        return PathProblem.in_frame(
            self.world, frame, self.energy, self.fitness_smoothing, self.physical
        )

    def with_fresh_memo(self) -> PathProblem:
        """The same problem with an empty reachability memo (the memo is pure, but one that
        earlier runs filled only slows lookups down)."""
        return replace(self, memo=K.new_memo(), counters=np.zeros(3, dtype=np.int64))

    def with_budget(self, max_evaluations: int | None) -> PathProblem:
        """The same problem (sharing its memo) with an evaluation budget (None: none)."""
        return replace(self, max_evaluations=max_evaluations)

    def with_fitness_smoothing(self, smoothing: int) -> PathProblem:
        """The same problem (sharing its memo) with another fitness smoothing."""
        if smoothing == self.fitness_smoothing:
            return self
        return replace(self, fitness_smoothing=smoothing)

    @property
    def n_inner(self) -> int:
        return self.frame.n_cols - 1

    @cached_property
    def reach(self) -> K.Reach:
        """Everything the kernels' reachability rule reads, by name (built once per problem:
        its arrays are the problem's own, the memo and the counters shared)."""
        dx, dy, dz = self.steps
        return K.Reach(
            world=self.world.kernel_args,
            cols=self.frame.cols,
            memo=self.memo,
            table=self.table[0],
            table_off=self.table[1],
            steps=np.array([dx, dy, dz]),
            start_m=self.start_m,
            goal_m=self.goal_m,
            margin=float(self.margin_m),
            counts=self.counters[1:],
        )

    @property
    def evaluations(self) -> int:
        """Fitness evaluations (individuals) made on this problem so far."""
        return int(self.counters[0])

    @property
    def reach_checks(self) -> tuple[int, int]:
        """(reachability checks, exact segment tests among them) made so far."""
        return int(self.counters[1]), int(self.counters[2])

    @property
    def margin_m(self) -> float:
        return self.world.margin_m

    @property
    def steps(self) -> tuple[float, float, float]:
        g = self.frame.grid
        return (self.frame.dx_m, g.dy_m, g.dz_m)

    @cached_property
    def energy_args(self) -> EnergyArgs:
        """The fitness's fixed arguments as the kernels read them (see
        :func:`~uavplan.path.energy.energy_of`)."""
        w = self.energy
        dx, dy, dz = self.steps
        return EnergyArgs(
            start_yz=self.start_m[1:],
            goal_yz=self.goal_m[1:],
            cols=self.frame.cols,
            dx=float(dx),
            dy=float(dy),
            dz=float(dz),
            n_sub=N_SUB,
            k0=float(w.k0),
            k1=float(w.k1),
            mu0=float(w.mu0),
            k2=float(w.k2),
            smooth=int(self.fitness_smoothing),
            straight=bool(self.frame.straight),
            phys=NO_PHYSICS
            if self.physical is None
            else self.physical.table(self.frame.heading_rad, *self.world.zlim),
        )

    def fitness(self, nodes: np.ndarray) -> np.ndarray:
        """Energy (G,) of individuals (G, D − 1, 2) on their cubic splines (eq. 1–2, or the
        physical fitness's watt-hours)."""
        self.counters[0] += nodes.shape[0]
        return energy_of(nodes, self.energy_args)

    def fitness_of_changed(
        self, cand: np.ndarray, parent: np.ndarray, parent_f: np.ndarray
    ) -> np.ndarray:
        """Fitness of candidates, evaluating only those that differ from their parent."""
        changed = (cand != parent).any(axis=(1, 2))
        out = parent_f.copy()
        if changed.any():
            out[changed] = self.fitness(cand[changed])
        return out

    def feasible(self, nodes: np.ndarray) -> np.ndarray:
        return K.paths_feasible(np.ascontiguousarray(nodes), self.reach)

    def node_points(self, nodes: np.ndarray) -> np.ndarray:
        """One individual's column polyline (D + 1, 3) in path-frame metres, with the ends."""
        return self.frame.nodes_to_points(nodes)

    def initial_population(
        self, n_pop: int, search: SearchParams, rng: np.random.Generator
    ) -> tuple[np.ndarray, np.ndarray, int]:
        return K.init_population(
            n_pop,
            self.n_inner,
            self.start_u,
            self.goal_u,
            float(search.init_half_window),
            search.t_max,
            INIT_MAX_ATTEMPTS,
            self.window,
            self.reach,
            rng,
        )

    def propose(
        self,
        base: np.ndarray,
        proposal: Proposal,
        t_max: int,
        rng: np.random.Generator,
        v_range: tuple[int, int] = (1, 5),
    ) -> tuple[np.ndarray, np.ndarray, int]:
        """New positions for ``base`` (G, n, 2) from ``proposal`` under the shared
        reachability rule (:func:`~uavplan.planners._kernels.rebuild`): (positions, ok per
        individual, escapes used). ``rng`` seeds one random stream per individual;
        ``v_range`` is eq. 12's speed range for individuals that may escape."""
        p = proposal
        return K.rebuild(
            base,
            p.active,
            p.anchor,
            p.offset,
            p.spread,
            p.draw,
            p.spread2,
            p.draw2,
            p.clamp,
            p.first,
            p.use_first,
            p.explicit,
            p.n_explicit,
            p.escape,
            t_max,
            v_range[0],
            v_range[1],
            self.reach,
            K.stream_seeds(rng, base.shape[0]),
        )


def _column_ranges_m(world: World, frame: PathFrame) -> np.ndarray:
    """(D + 1, 2) lateral offsets (m) of each column's line inside the bounds and inside its
    fold window."""
    cols = frame.cols
    lo = frame.lateral_limits_m[:, 0].copy()
    hi = frame.lateral_limits_m[:, 1].copy()
    for a, b, k in world.hp:  # a·x + b·y <= k along c + t·n
        rate = a * cols[:, 2] + b * cols[:, 3]
        room = k - a * cols[:, 0] - b * cols[:, 1]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = room / rate
        hi = np.where(rate > 1e-12, np.minimum(hi, t), hi)
        lo = np.where(rate < -1e-12, np.maximum(lo, t), lo)
    return np.column_stack([lo, hi])


def _clearance_table(
    world: World, frame: PathFrame
) -> tuple[tuple[np.ndarray, np.ndarray], np.ndarray]:
    """Node clearances over the grid that covers the bounds (see ``K.clearance_table``) and
    every column's valid node range in grid units (y_lo, y_hi, z_lo, z_hi)."""
    g = frame.grid
    ranges = _column_ranges_m(world, frame)
    if frame.straight:
        # corners of the bounds polygon: intersect consecutive half-planes (a box: 4 corners)
        ys = []
        hp = world.hp
        for i in range(hp.shape[0]):
            for k in range(i + 1, hp.shape[0]):
                m = np.array([hp[i, :2], hp[k, :2]])
                if abs(np.linalg.det(m)) > 1e-12:
                    x, y = np.linalg.solve(m, [hp[i, 2], hp[k, 2]])
                    if world.points_inside_bounds(np.array([[x, y, world.zlim[0]]]))[0]:
                        ys.append(y)
        y_min, y_max = min(ys), max(ys)
    else:
        y_min, y_max = float(ranges[:, 0].min()), float(ranges[:, 1].max())
    iy_lo, iy_hi = int(np.floor(y_min / g.dy_m)), int(np.ceil(y_max / g.dy_m))
    iz_lo, iz_hi = int(np.floor(world.zlim[0] / g.dz_m)), int(np.ceil(world.zlim[1] / g.dz_m))
    ylim = np.column_stack(
        [np.ceil(ranges[:, 0] / g.dy_m - 1e-9), np.floor(ranges[:, 1] / g.dy_m + 1e-9)]
    )
    ylim = np.clip(ylim, iy_lo, iy_hi)
    cap = world.margin_m + K.TABLE_REACH_M
    tab = K.clearance_table(
        frame.cols,
        ylim,
        iy_lo,
        iy_hi,
        iz_lo,
        iz_hi,
        g.dy_m,
        g.dz_m,
        world.kernel_args,
        cap,
        world.margin_m + TABLE_EXACT_PAD_M,
    )
    window = np.empty((frame.n_cols + 1, 4))
    window[:, :2] = ylim
    window[:, 2] = math.ceil(world.zlim[0] / g.dz_m - 1e-9)
    window[:, 3] = math.floor(world.zlim[1] / g.dz_m + 1e-9)
    return (tab, np.array([iy_lo, iz_lo], dtype=np.int64)), window


class Termination:
    """When a run stops (STYLE: termination kept apart from the algorithm).

    ``iterations``: the budget M of iterations (the paper's protocol runs all of them);
    ``stall_iterations``: stop a search early once the run's best fitness has not improved
    for that many iterations (None: never); ``restart_stall_iterations``: the same for every
    restart after the first (SPSA's restarts; None: ``stall_iterations``); ``should_stop``:
    polled once per iteration, e.g. a Ctrl-C flag (the run then ends as
    ``SearchEnd.INTERRUPTED`` and returns what it has); ``max_evaluations``: stop once this
    many fitness evaluations were made (a budget every algorithm can share).
    """

    def __init__(
        self,
        iterations: int,
        stall_iterations: int | None = None,
        should_stop: Callable[[], bool] | None = None,
        max_evaluations: int | None = None,
        restart_stall_iterations: int | None = None,
    ) -> None:
        self.iterations = iterations
        self.stall_iterations = stall_iterations
        self.restart_stall_iterations = restart_stall_iterations
        self.should_stop = should_stop
        self.max_evaluations = max_evaluations

    def stall_limit(self, search_index: int) -> int | None:
        """The early stop of search ``search_index`` (0: the first; later ones are restarts);
        None: no early stop."""
        if self.stall_iterations is None:
            return None
        if search_index > 0 and self.restart_stall_iterations is not None:
            return self.restart_stall_iterations
        return self.stall_iterations


@dataclass(frozen=True)
class PlannerResult:
    """What a planner returns: one record (STYLE: x, fun, nit, success, message).

    ``iterations`` counts the iterations actually run; ``termination`` says why the run
    ended (:class:`~uavplan.outcome.SearchEnd`; ``NO_PATH``: nothing could be initialised);
    ``evaluations`` counts fitness evaluations (individuals) and ``reach_checks`` /
    ``exact_checks`` the reachability tests of the run (its budget); ``stats`` holds the
    planner's own counters (escapes, failed updates, ...), numbers only.
    """

    algorithm: str
    seed: int
    best_nodes: np.ndarray | None  # (D − 1, 2) grid units
    best_fitness: float
    convergence: np.ndarray  # best fitness after each iteration run
    iterations: int
    runtime_s: float
    deadlocks: int = 0
    stats: dict[str, float] = field(default_factory=dict)
    message: str = ""
    population: np.ndarray | None = None  # final positions (G, D − 1, 2)
    population_fitness: np.ndarray | None = None
    termination: SearchEnd = SearchEnd.ITERATIONS
    evaluations: int = 0
    reach_checks: int = 0
    exact_checks: int = 0

    @property
    def solved(self) -> bool:
        return self.termination.solved


@dataclass
class Population:
    """The state a step works on: positions ``x`` (G, n, 2) and their fitness ``f`` (G,).

    ``state`` is the algorithm's own memory (velocities, personal bests, leaders, ...);
    ``counters`` its numeric counters, summed over restarts into ``PlannerResult.stats``.
    """

    x: np.ndarray
    f: np.ndarray
    iteration: int = 0
    iterations: int = 1
    state: dict[str, Any] = field(default_factory=dict)
    counters: dict[str, int] = field(default_factory=dict)

    @property
    def best_index(self) -> int:
        return int(self.f.argmin())  # the method: np.argmin's dispatch costs 2 µs a call

    def count(self, name: str, n: int) -> None:
        self.counters[name] = self.counters.get(name, 0) + int(n)


class SwarmPlanner:
    """Shared population loop. Subclasses set ``name`` and implement :meth:`step`."""

    name = "base"
    #: does the paper's protocol post-process this algorithm's best path (section 4.5)?
    postprocess = False
    #: independent searches the iteration budget is split into (fresh initialisation each);
    #: 1 is the paper's protocol
    rounds = 1
    #: the fitness smoothing used when the search settings leave it unset (0: the paper's)
    default_fitness_smoothing = 0

    def fitness_smoothing(self) -> int:
        """The moving-average half-width this planner's fitness uses."""
        s = self.search.fitness_smoothing
        return self.default_fitness_smoothing if s is None else s

    def __init__(self, search: SearchParams) -> None:
        self.search = search
        #: threads a planner with a threaded kernel may use (SPSA / SSA's fused step); None:
        #: the kernel's default (:func:`uavplan.planners._kernels.step_threads`). Results do
        #: not depend on it.
        self.threads: int | None = None

    # hooks -------------------------------------------------------------------------------
    def setup(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> None:
        """Called once after initialisation (e.g. velocities)."""

    def step(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> None:
        """Advance ``pop`` by one iteration in place (positions and fitness)."""
        raise NotImplementedError

    def best(self, pop: Population) -> tuple[np.ndarray, float]:
        """The best solution so far (an algorithm with memory may override)."""
        i = pop.best_index
        return pop.x[i], float(pop.f[i])

    # the loop ----------------------------------------------------------------------------
    def solve(
        self,
        problem: PathProblem,
        rng: np.random.Generator | None = None,
        progress: ProgressFn | None = None,
        termination: Termination | None = None,
    ) -> PlannerResult:
        search = self.search
        rng = rng if rng is not None else np.random.default_rng(search.seed)
        term = termination or Termination(search.iterations)
        budget = term.iterations
        t0 = time.perf_counter()
        start_counts = problem.counters.copy()
        rounds = max(1, min(self.rounds, budget))
        lengths = np.full(rounds, budget // rounds)
        lengths[: budget % rounds] += 1
        limits = [n for n in (term.max_evaluations, problem.max_evaluations) if n is not None]
        max_evals = min(limits) if limits else None
        # an evaluation budget is split over the rounds as the iterations are
        round_evals = (
            None if max_evals is None else [max_evals * int(c) / budget for c in np.cumsum(lengths)]
        )
        convergence: list[float] = []
        finals_x: list[np.ndarray] = []
        finals_f: list[np.ndarray] = []
        best_x: np.ndarray | None = None
        best_f = float("inf")
        deadlocks = 0
        stats: dict[str, float] = {}
        reason = SearchEnd.ITERATIONS

        def record(end: SearchEnd, message: str = "") -> PlannerResult:
            used = problem.counters - start_counts
            return PlannerResult(
                self.name,
                search.seed,
                best_x,
                best_f,
                np.array(convergence),
                len(convergence),
                time.perf_counter() - t0,
                deadlocks,
                {**stats, "rounds": float(rounds)},
                message,
                population=np.concatenate(finals_x) if finals_x else None,
                population_fitness=np.concatenate(finals_f) if finals_f else None,
                termination=end,
                evaluations=int(used[0]),
                reach_checks=int(used[1]),
                exact_checks=int(used[2]),
            )

        need = max(1, math.ceil(INIT_MIN_SHARE * search.population))
        for r, n_iter in enumerate(lengths):
            x, ok, dead = problem.initial_population(search.population, search, rng)
            deadlocks += dead
            n_ok = int(ok.sum())
            if n_ok < need:
                # too few paths to search with (a round of restarts is skipped, as is one
                # where none initialised)
                if best_x is None:
                    return record(
                        SearchEnd.NO_PATH,
                        "every initial path deadlocked: no reachable node sequence "
                        "from start to goal"
                        if n_ok == 0
                        else f"only {n_ok} of {ok.size} initial paths reached the goal "
                        f"(a search needs {need})",
                    )
                convergence.extend([best_f] * int(n_iter))
                continue
            if not ok.all():
                # deadlocked individuals are replaced by copies of initialised ones
                good = np.flatnonzero(ok)
                bad = np.flatnonzero(~ok)
                x[bad] = x[rng.choice(good, size=bad.size)]
            pop = Population(x, problem.fitness(x), 0, int(n_iter))
            self.setup(problem, pop, rng)
            stalled = 0
            stall_limit = term.stall_limit(r)
            for it in range(n_iter):
                pop.iteration = it
                self.step(problem, pop, rng)
                bx, bf = self.best(pop)
                if bf < best_f:
                    best_x, best_f = bx.copy(), bf
                    stalled = 0
                else:
                    stalled += 1
                convergence.append(best_f)
                if progress is not None:
                    progress(len(convergence), budget, best_f)
                if term.should_stop is not None and term.should_stop():
                    reason = SearchEnd.INTERRUPTED
                    break
                if stall_limit is not None and stalled >= stall_limit:
                    reason = SearchEnd.STALLED
                    break
                if round_evals is None:
                    continue
                used = problem.counters[0] - start_counts[0]
                if used >= round_evals[r]:
                    if r == rounds - 1 or used >= max_evals:  # type: ignore[operator]
                        reason = SearchEnd.BUDGET
                    break
            finals_x.append(pop.x.copy())
            finals_f.append(pop.f.copy())
            for k, v in pop.counters.items():
                stats[k] = stats.get(k, 0.0) + float(v)
            if reason in (SearchEnd.INTERRUPTED, SearchEnd.BUDGET):
                break
        return record(reason)
