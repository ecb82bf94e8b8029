"""The compiled SPSA / SSA iteration against its numpy formulation
(uavplan/planners/sparrow_numpy.py, the planner ``spsa_numpy``).

The product's step (:meth:`SparrowPlanner.step`) draws its random numbers from the Generator
and runs the whole iteration in the C kernel; the reference computes every update rule with
numpy and the shared rebuild kernel, as the step was written before it was fused. Given the
same seed the two must give the same run: the same convergence curve, population, fitness
and counters, for SPSA, SSA and every switch of the ablation study, on a straight and on a
curved (guide-path) frame.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from uavplan.cli import main
from uavplan.config import EnergyWeights, GridSpec, SearchParams, SpsaParams
from uavplan.obstacles import BoxObstacle, CylinderObstacle
from uavplan.planners import _kernels as K
from uavplan.planners.base import PathProblem, Population, Termination
from uavplan.planners.sparrow import SparrowPlanner
from uavplan.planners.sparrow_numpy import NumpySparrowPlanner as ReferenceSparrow
from uavplan.world import World

GRID = GridSpec(20.0, 20.0, 10.0)


def _problem(curved: bool) -> PathProblem:
    world = World.build(
        [
            BoxObstacle((300.0, 20.0), (60.0, 160.0), 120.0),
            CylinderObstacle((520.0, -60.0), 50.0, 90.0),
            BoxObstacle((650.0, 90.0), (40.0, 80.0), 60.0),
        ],
        bounds_xyz=((-50.0, 850.0), (-300.0, 300.0), (0.0, 200.0)),
        margin_m=10.0,
    )
    problem = PathProblem.build(world, (0.0, 0.0, 30.0), (800.0, 0.0, 40.0), GRID, EnergyWeights())
    if curved:
        problem = problem.along(np.array([[0.0, 0.0], [300.0, -200.0], [800.0, 0.0]]))
    return problem


VARIANTS = {
    "spsa": SpsaParams(),
    "ssa": SpsaParams.ssa(),
    "literal": SpsaParams(producer_rule="literal"),
    "population-index": SpsaParams(scrounger_index="population"),
    "no-escape": SpsaParams(escape=False),
    "no-oscillation": SpsaParams(oscillation=False),
    "no-start-end": SpsaParams(start_end_producer=False),
    "alarm-always": SpsaParams(warning_value=0.0),
    "small-swarm": SpsaParams(restarts=1),
}


@pytest.mark.parametrize("curved", [False, True], ids=["straight", "curved"])
@pytest.mark.parametrize("variant", list(VARIANTS))
def test_compiled_step_equals_the_numpy_formulation(variant: str, curved: bool) -> None:
    params = VARIANTS[variant]
    population = 7 if variant == "small-swarm" else 16
    search = SearchParams(population=population, iterations=60, seed=5, fitness_smoothing=2)
    problem = _problem(curved).with_fitness_smoothing(2)
    runs = []
    for cls in (SparrowPlanner, ReferenceSparrow):
        p = problem.with_fresh_memo()
        res = cls(search, params).solve(p, np.random.default_rng(5), None, Termination(60))
        runs.append((res, p))
    (fast, p_fast), (ref, p_ref) = runs
    assert fast.solved and ref.solved
    assert np.array_equal(fast.convergence, ref.convergence)
    assert np.array_equal(fast.best_nodes, ref.best_nodes)
    assert np.array_equal(fast.population, ref.population)
    assert np.array_equal(fast.population_fitness, ref.population_fitness)
    assert fast.stats == ref.stats
    # the same reachability checks; the compiled step re-uses a producer's fitness when its
    # candidate did not move after it was evaluated, so it never evaluates more
    assert p_fast.counters[1] == p_ref.counters[1]
    assert p_fast.counters[0] <= p_ref.counters[0]
    # the run is not trivial: candidates were rejected, some updates failed or escaped
    assert fast.convergence[0] > fast.convergence[-1]


class CachedSparrow(SparrowPlanner):
    """The product's step with a fitness cache of a given size (0: none)."""

    slots = 0

    def setup(self, problem, pop, rng):  # type: ignore[no-untyped-def]
        super().setup(problem, pop, rng)
        pop.state["energy_cache"] = K.new_energy_cache(pop.x.shape[1], self.slots)


@pytest.mark.parametrize("slots", [0, 1, 8])
def test_recalled_fitness_is_the_computed_fitness(slots: int) -> None:
    """With no cache, a one-slot cache (every path shares the slot: only the stored path
    decides a hit) or a small one, the run is the oracle's to the bit."""
    search = SearchParams(population=16, iterations=40, seed=3, fitness_smoothing=2)
    problem = _problem(True).with_fitness_smoothing(2)
    CachedSparrow.slots = slots
    fast = CachedSparrow(search).solve(
        problem.with_fresh_memo(), np.random.default_rng(3), None, Termination(40)
    )
    ref = ReferenceSparrow(search).solve(
        problem.with_fresh_memo(), np.random.default_rng(3), None, Termination(40)
    )
    assert np.array_equal(fast.convergence, ref.convergence)
    assert np.array_equal(fast.population, ref.population)
    assert np.array_equal(fast.population_fitness, ref.population_fitness)


def test_energy_cache_size() -> None:
    cache = K.new_energy_cache(99)
    assert cache.filled.shape == cache.values.shape == (1024,)
    assert cache.paths.shape == (1024, 198)
    big = K.new_energy_cache(2499).paths  # a 50 km route: 2 MiB of stored paths at most
    assert big.shape[0] & (big.shape[0] - 1) == 0 and big.nbytes <= K.ENERGY_CACHE_BYTES
    assert K.new_energy_cache(5, 0).filled.size == 0
    with pytest.raises(ValueError):
        K.new_energy_cache(5, 3)


def test_the_reference_is_not_the_product() -> None:
    """The oracle must be independent: a change to one update rule shows up as a difference."""
    search = SearchParams(population=16, iterations=30, seed=2)
    problem = _problem(False)
    ref = ReferenceSparrow(search).solve(
        problem.with_fresh_memo(), np.random.default_rng(2), None, Termination(30)
    )
    other = ReferenceSparrow(search, replace(SpsaParams(), danger_ratio=0.3)).solve(
        problem.with_fresh_memo(), np.random.default_rng(2), None, Termination(30)
    )
    assert not np.array_equal(ref.population, other.population)
    assert ReferenceSparrow.step is not SparrowPlanner.step


@pytest.mark.parametrize("shape", [(0, 5, 2), (1, 1, 1), (3, 99, 2), (7, 13, 2)])
def test_sign_draws_are_numpys_integers(shape: tuple[int, ...]) -> None:
    """The kernel's ±1 draws are numpy's ``2·integers(0, 2) − 1``, and leave the Generator
    where numpy leaves it (odd counts included: the next 32-bit half stays buffered)."""
    a, b = np.random.default_rng(11), np.random.default_rng(11)
    a.random()
    b.random()
    fast = K.sign_draws(a, shape)
    ref = 2.0 * b.integers(0, 2, size=shape) - 1.0
    assert np.array_equal(fast, ref)
    assert np.array_equal(a.integers(0, 2, size=9), b.integers(0, 2, size=9))
    assert a.random() == b.random()


@pytest.mark.parametrize("variant", ["spsa", "ssa", "alarm-always"])
def test_the_step_gives_the_same_run_on_any_number_of_threads(variant: str) -> None:
    """The fused step shares its per-individual work among threads (individuals taken one at
    a time, the fitness cache split between them, the reachability memo shared): the run is
    the same to the bit on 1, 2, 3 and 8 threads, and so are the fitness evaluations and the
    reachability checks (only the count of exact tests may differ: a lost race on the memo
    repeats a test)."""
    search = SearchParams(population=16, iterations=50, seed=4, fitness_smoothing=2)
    problem = _problem(True).with_fitness_smoothing(2)
    runs = []
    for threads in (1, 2, 3, 8):
        planner = SparrowPlanner(search, VARIANTS[variant])
        planner.threads = threads
        p = problem.with_fresh_memo()
        res = planner.solve(p, np.random.default_rng(4), None, Termination(50))
        runs.append((res, p))
    (one, p_one), *others = runs
    assert one.solved and one.convergence[0] > one.convergence[-1]
    for res, p in others:
        assert np.array_equal(res.convergence, one.convergence)
        assert np.array_equal(res.population, one.population)
        assert np.array_equal(res.population_fitness, one.population_fitness)
        assert res.stats == one.stats
        assert p.counters[0] == p_one.counters[0] and p.counters[1] == p_one.counters[1]


def test_step_threads_follows_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(K, "HAVE_THREADS", True)
    monkeypatch.setenv("UAVPLAN_THREADS", "1")
    assert K.step_threads() == 1
    monkeypatch.setenv("UAVPLAN_THREADS", "3")
    assert K.step_threads() == 3
    assert K.step_threads_note() == "SPSA step threads: 3"
    monkeypatch.setenv("UAVPLAN_THREADS", "500")
    assert K.step_threads() == K.STEP_THREADS_MAX
    for junk in ("", "0", "-2", "two"):
        monkeypatch.setenv("UAVPLAN_THREADS", junk)
        assert 1 <= K.step_threads() <= K.STEP_THREADS_AUTO_MAX


def test_a_build_without_threads_says_so(monkeypatch: pytest.MonkeyPatch) -> None:
    """A build without helper threads (MSVC, MinGW: ``_ckernels.HAVE_THREADS`` is 0) runs
    the step on one thread whatever is asked, and the reports say why."""
    monkeypatch.setattr(K, "HAVE_THREADS", False)
    for asked in ("4", ""):
        monkeypatch.setenv("UAVPLAN_THREADS", asked)
        assert K.step_threads() == 1
        assert "no helper threads" in K.step_threads_note()


def _threaded_run(threads: int) -> np.ndarray:
    search = SearchParams(population=16, iterations=25, seed=6, fitness_smoothing=2)
    planner = SparrowPlanner(search)
    planner.threads = threads
    problem = _problem(False).with_fitness_smoothing(2).with_fresh_memo()
    return planner.solve(problem, np.random.default_rng(6), None, Termination(25)).population


def _child(queue) -> None:  # type: ignore[no-untyped-def]
    queue.put(_threaded_run(2))


def test_the_step_threads_survive_fork() -> None:
    """The step's helper threads are a process-wide pool; a child forked after the parent used
    them has none, starts its own and plans the same run (no hang: the bench forks workers)."""
    import multiprocessing

    expected = _threaded_run(2)
    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    child = ctx.Process(target=_child, args=(queue,))
    child.start()
    got = queue.get(timeout=60)
    child.join(timeout=60)
    assert child.exitcode == 0
    assert np.array_equal(got, expected)


def test_two_python_threads_plan_at_once() -> None:
    """Two planning threads at once: one step holds the helper pool, the other runs on its
    caller's thread alone; both give the single-threaded run."""
    import threading

    expected = _threaded_run(1)
    results: list[np.ndarray] = []
    workers = [threading.Thread(target=lambda: results.append(_threaded_run(2))) for _ in "ab"]
    for w in workers:
        w.start()
    for w in workers:
        w.join(timeout=60)
    assert not any(w.is_alive() for w in workers)
    assert len(results) == 2 and all(np.array_equal(r, expected) for r in results)


@pytest.mark.slow
def test_the_numpy_planner_plans_the_compiled_planners_route(tmp_path: Path) -> None:
    """``--algorithm spsa_numpy`` takes SPSA's numpy formulation through the whole pipeline
    (search, post-processing, mission): the mission is the compiled planner's, item for item,
    with the same energy; only the count of fitness evaluations may be lower for the compiled
    step (it recalls fitness values instead of recomputing them)."""
    missions = Path(__file__).resolve().parents[2] / "missions"
    runs = {}
    for algorithm in ("spsa", "spsa_numpy"):
        route, report = tmp_path / f"{algorithm}.plan", tmp_path / f"{algorithm}.json"
        args = ["plan", str(missions / "paper-env1.yaml"), "-o", str(route), "--algorithm",
                algorithm, "--iterations", "30", "--population", "12", "--seed", "4",
                "--report", str(report), "-q"]  # fmt: skip
        result = CliRunner().invoke(main, args)
        assert result.exit_code == 0, result.output
        items = json.loads(route.read_text())["mission"]["items"]
        runs[algorithm] = (items, json.loads(report.read_text()))
    (items, fast), (items_numpy, slow) = runs["spsa"], runs["spsa_numpy"]
    assert slow["algorithm"] == "spsa_numpy" and len(items) > 2
    assert items == items_numpy
    for key in ("energy", "energy_terms", "length_m", "iterations", "termination", "convergence"):
        assert fast[key] == slow[key], key
    assert fast["evaluations"] <= slow["evaluations"]


def test_the_step_checks_what_it_is_given() -> None:
    """The step reads its setup and draws by field name and checks every array: a wrong dtype,
    shape or a missing field is an error naming it, never a crash or a silent copy."""
    problem = _problem(False)
    planner = SparrowPlanner(SearchParams(population=8, iterations=2, seed=1))
    rng = np.random.default_rng(1)
    x, _ok, _dead = problem.initial_population(8, planner.search, rng)
    pop = Population(x, problem.fitness(x), 0, 2)
    planner.setup(problem, pop, rng)
    planner.step(problem, pop, rng)
    setup: K.StepSetup = pop.state["step_setup"]
    n_prod, n_near, _n_danger, _flags = pop.state["sizes"]
    seeds = K.stream_seeds(rng, 8)
    signs = np.ones((n_near, x.shape[1], 2))
    good = K.StepDraws(0.3, np.full(n_prod, 0.5), signs, np.arange(1), seeds, seeds)
    counts = np.zeros(3, np.int64)
    fixed = pop.state["osc_fixed"]
    K.spsa_step(pop.x, pop.f, fixed, counts, setup, good)
    assert counts[0] > 0
    with pytest.raises(TypeError, match=r"draws\.pdraw"):
        bad = good._replace(pdraw=good.pdraw.astype(np.float32))
        K.spsa_step(pop.x, pop.f, fixed, counts, setup, bad)
    with pytest.raises(ValueError, match=r"draws\.pdraw"):
        K.spsa_step(pop.x, pop.f, fixed, counts, setup, good._replace(pdraw=good.pdraw[:, None]))
    with pytest.raises(TypeError, match=r"draws\.aware"):
        bad = good._replace(aware=np.arange(1, dtype=np.int32))
        K.spsa_step(pop.x, pop.f, fixed, counts, setup, bad)
    with pytest.raises(TypeError, match="warn"):
        K.spsa_step(pop.x, pop.f, fixed, counts, setup, setup)  # type: ignore[arg-type]
