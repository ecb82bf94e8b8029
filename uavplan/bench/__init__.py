"""Experiment runner for the paper's comparison (section 6, Table 2) and SPSA's ablation.

A benchmark is a list of :class:`BenchJob` — plain picklable specs, one per (scenario,
algorithm variant, seed) — run by :func:`run_jobs` serially, on local processes
(``workers > 1``) or on a Dask distributed cluster (``dask=ADDRESS``), with the same result:
one :class:`RunRecord` per job, in job order. :func:`summarise` aggregates them into the
Table-2 statistics (mean / worst / best / std of the final energy), success rate and runtime;
:func:`write_outputs` writes CSV, JSON, a Markdown table and convergence plots (both in
:mod:`uavplan.bench.report`, re-exported here).

Each run goes through :func:`uavplan.planning.plan_route`, the same pipeline as
``uavplan plan``: every algorithm's best path goes through the same post-processing chain
(node simplification, spline, waypoint resampling; SPSA's refinement, string pulling and
choice among its final population are SPSA's variant). A record keeps both numbers apart:
``search_fitness``, the best fitness the search reached (the paper's Table-2 protocol), and
``route_energy``, E of the post-processed route. Every algorithm gets the same seeds, so for a
given seed every algorithm starts from the same initial population (eq. 8–10).

Budgets: by default every algorithm runs the scenario's M iterations; with an evaluation
budget (``budget=N``, ``uavplan bench --budget evaluations=N``) every algorithm stops once it
made N fitness evaluations (individuals scored), its iteration count only a generous cap.
Records count evaluations and reachability checks either way.

Reference rows (:mod:`uavplan.bench.reference`): ``astar-los`` (grid A* + line of sight) and,
with the optional ``ompl`` package, ``ompl-rrtstar``, ``ompl-informed-rrtstar``,
``ompl-bitstar``, solved for SPSA's mean wall time on the same scenario (or ``time_s=``).

An algorithm *variant* is a label: a registered algorithm (``spsa``, ``pso``, …) or SPSA with
one contribution switched off (``spsa-no-escape``, …, see :data:`ABLATIONS`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import pickle
import re
import threading
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from uavplan.config import (
    PLANNERS,
    ConfigError,
    PostParams,
    SearchParams,
    build,
    build_params,
    override,
    paper_algorithms,
    planner_entry,
    resolved_planner,
    user_keys,
)
from uavplan.scenario import Scenario, check_limits
from uavplan.scenario import resolved_config as scenario_config

from .reference import ASTAR, OMPL_PLANNERS, REFERENCES, ompl_available
from .report import RunRecord as RunRecord
from .report import Summary as Summary
from .report import _jsonable
from .report import format_table as format_table
from .report import format_tables as format_tables
from .report import mean_convergence as mean_convergence
from .report import output_files as output_files
from .report import plot_convergence as plot_convergence
from .report import summarise as summarise
from .report import write_outputs as write_outputs

#: SPSA's contributions (paper section 4), each as the change that switches it off:
#: label suffix → (SpsaParams changes, PostParams changes). Contribution 1, the
#: initialisation, is shared by every algorithm. Our own post-processing steps (``refine``,
#: ``tighten``) act on the simplified polyline, so "no-simplify" switches them off too;
#: variants such as ``spsa(refine=false)`` measure them on their own.
ABLATIONS: dict[str, tuple[dict[str, Any], dict[str, Any]]] = {
    "no-start-end": ({"start_end_producer": False}, {}),
    "no-escape": ({"escape": False}, {}),
    "no-oscillation": ({"oscillation": False}, {}),
    "no-simplify": ({}, {"simplify": False, "refine": False, "tighten": False}),
    "no-smooth": ({}, {"smooth": False}),
}


def default_algorithms() -> tuple[str, ...]:
    """Every registered planner of the paper's comparison, in table order (the bench
    default; derived from :data:`uavplan.config.PLANNERS`)."""
    return paper_algorithms()


#: the paper's six algorithms, in the order tables list them (a snapshot at import; use
#: :func:`default_algorithms` to include planners registered later)
DEFAULT_ALGORITHMS: tuple[str, ...] = default_algorithms()

#: how long to wait for a Dask scheduler before giving up (seconds)
DASK_CONNECT_TIMEOUT_S = 10

#: with an evaluation budget N, the iteration cap is this many times N / G: an algorithm that
#: scores fewer than G / ITERATION_CAP_FACTOR individuals per iteration on average stops at
#: the cap (its record says ``termination = "iterations"``) instead of running for ever
ITERATION_CAP_FACTOR = 20
MAX_ITERATIONS = 1_000_000

ProgressCallback = Callable[[int, int, "RunRecord"], None]  # (done, total, record)


@dataclass(frozen=True)
class Variant:
    """An algorithm and the changes to its configuration.

    Labels: a registered algorithm (``pso``); SPSA with one contribution off
    (``spsa-no-escape``, see :data:`ABLATIONS`); either with parameters in parentheses,
    ``de(cr=0.1)``, ``pso(v_max_fraction=0.1; c1=1.5)``, ``spsa(oscillation_window=4)``
    (``;`` or ``,`` between them; values read as YAML scalars). A parameter is one of the
    algorithm's own (the keys of its scenario section ``planner.<name>``), a
    :class:`PostParams` field for a planner the protocol post-processes, or a
    :class:`SearchParams` field (``fitness_smoothing``, ``t_max``, …, any algorithm). Every
    value goes through :func:`uavplan.config.build`, the validator scenario files use.
    """

    label: str
    algorithm: str
    params_changes: tuple[tuple[str, Any], ...] = ()  # the algorithm's own parameters
    post_changes: tuple[tuple[str, Any], ...] = ()
    search_changes: tuple[tuple[str, Any], ...] = ()  # SearchParams fields, any algorithm

    @property
    def reference(self) -> bool:
        """Is this a reference planner row (A*, OMPL), not a swarm algorithm?"""
        return self.algorithm in REFERENCES

    @property
    def time_s(self) -> float | None:
        """An OMPL row's fixed solve time (None: SPSA's mean wall time on the scenario)."""
        value = dict(self.params_changes).get("time_s")
        return None if value is None else float(value)

    @property
    def spsa_changes(self) -> tuple[tuple[str, Any], ...]:
        """SPSA's parameter changes (empty for other algorithms)."""
        return self.params_changes if self.algorithm == "spsa" else ()

    @property
    def options(self) -> tuple[tuple[str, Any], ...]:
        """A baseline's parameter changes (empty for SPSA, see :attr:`spsa_changes`)."""
        return () if self.algorithm == "spsa" else self.params_changes

    @classmethod
    def parse(cls, label: str) -> Variant:
        """A variant from its label; ValueError names what is wrong."""
        label = label.strip()
        head, params = label, ""
        if label.endswith(")") and "(" in label:
            head, _, params = label[:-1].partition("(")
        head = head.strip().lower()
        base, _, suffix = head.partition("-")
        if head in PLANNERS or head in REFERENCES:
            v = cls(head, head)
        elif base == "spsa" and suffix in ABLATIONS:
            spsa, post = ABLATIONS[suffix]
            v = cls(head, "spsa", tuple(spsa.items()), tuple(post.items()))
        else:
            known = [*PLANNERS, *(f"spsa-{s}" for s in ABLATIONS), *REFERENCES]
            raise ValueError(f"unknown algorithm {head!r} (known: {', '.join(known)})")
        if not params.strip():
            return v
        return v._with_params(_parse_params(params), label)

    def _with_params(self, params: dict[str, Any], label: str) -> Variant:
        if "seed" in params:
            raise ValueError(f"{label}: seeds come from --seed0 and --runs")
        if self.reference:
            return self._reference_params(params, label)
        entry = planner_entry(self.algorithm)
        search_keys = set(user_keys(SearchParams))
        post_keys = set(user_keys(PostParams)) if entry.postprocess else set()
        search = {**dict(self.search_changes)}
        post = {**dict(self.post_changes)}
        own = {**dict(self.params_changes)}
        for k, value in params.items():
            if k in search_keys:
                search[k] = value
            elif k in post_keys:
                post[k] = value
            else:
                own[k] = value
        try:
            build(SearchParams, search)
            build(PostParams, post)
            build_params(self.algorithm, own)
        except ConfigError as err:
            raise ValueError(f"{label}: {err}") from None
        return dataclasses.replace(
            self,
            label=label,
            params_changes=tuple(own.items()),
            post_changes=tuple(post.items()),
            search_changes=tuple(search.items()),
        )

    def _reference_params(self, params: dict[str, Any], label: str) -> Variant:
        allowed = {"time_s"} if self.algorithm in OMPL_PLANNERS else set()
        for key, value in params.items():
            if key not in allowed:
                known = ", ".join(sorted(allowed)) or "none"
                raise ValueError(f"{label}: unknown parameter {key!r} (known: {known})")
            if (
                not isinstance(value, int | float)
                or isinstance(value, bool)
                or not 0 < value <= 3600
            ):
                raise ValueError(f"{label}: time_s must be a number of seconds in (0, 3600]")
        return dataclasses.replace(self, label=label, params_changes=tuple(params.items()))


def _parse_params(text: str) -> dict[str, Any]:
    import yaml  # type: ignore[import-untyped]

    out: dict[str, Any] = {}
    for item in re.split(r"[;,]", text):
        if not item.strip():
            continue
        key, eq, value = item.partition("=")
        if not eq or not key.strip():
            raise ValueError(f"parameter {item.strip()!r} is not KEY=VALUE")
        out[key.strip()] = yaml.safe_load(value.strip())
    return out


def split_labels(text: str) -> list[str]:
    """Split a comma-separated algorithm list, keeping commas inside parentheses."""
    labels: list[str] = []
    depth = 0
    cur: list[str] = []
    for ch in text:
        depth += (ch == "(") - (ch == ")")
        if ch == "," and depth == 0:
            labels.append("".join(cur))
            cur = []
        else:
            cur.append(ch)
    labels.append("".join(cur))
    return [label.strip() for label in labels if label.strip()]


def reference_variants() -> list[Variant]:
    """The reference rows: grid A* + line of sight, and the OMPL planners when the optional
    ``ompl`` package is installed."""
    labels = [ASTAR, *(OMPL_PLANNERS if ompl_available() else ())]
    return [Variant.parse(label) for label in labels]


def parse_budget(text: str) -> int:
    """An evaluation budget from ``evaluations=N`` (N ≥ 1 fitness evaluations per run);
    ValueError says what is wrong."""
    key, eq, value = text.strip().partition("=")
    if not eq or key.strip().lower() != "evaluations":
        raise ValueError(f"expected evaluations=N, got {text.strip()!r}")
    try:
        n = int(value.strip())
    except ValueError:
        raise ValueError(f"evaluations must be a whole number, got {value.strip()!r}") from None
    if not 1 <= n <= 10**9:
        raise ValueError(f"evaluations must be in 1..1000000000, got {n}")
    return n


def ablation_variants() -> list[Variant]:
    """SPSA in full, then with each contribution switched off in turn."""
    return [Variant.parse("spsa"), *(Variant.parse(f"spsa-{s}") for s in ABLATIONS)]


@dataclass(frozen=True)
class BenchJob:
    """One run: everything a worker needs, picklable, no open files or handles.

    ``scenario`` already carries the run's search settings (population, iterations);
    ``scenario_key`` identifies its geometry so a worker builds the world once.
    """

    index: int
    scenario: Scenario
    scenario_key: str
    variant: Variant
    seed: int
    #: stop after this many fitness evaluations (None: the scenario's iterations)
    max_evaluations: int | None = None
    #: an OMPL row's solve time, filled in from SPSA's runs when the variant has none
    time_s: float | None = None


# ---------------------------------------------------------------------------------------------
# Jobs


def scenario_key(scenario: Scenario) -> str:
    """A digest of what the world and the path problem depend on."""
    cfg = scenario.planner
    parts = (
        scenario.bounds,
        scenario.obstacles,
        scenario.safety_margin_m,
        scenario.start_m,
        scenario.goal_m,
        scenario.grid,
        cfg.energy,
    )
    return hashlib.sha256(pickle.dumps(parts)).hexdigest()[:16]


def make_jobs(
    scenarios: Sequence[Scenario],
    variants: Sequence[Variant | str],
    *,
    runs: int = 30,
    seed0: int = 1,
    iterations: int | None = None,
    population: int | None = None,
    search: Mapping[str, Any] | None = None,
    budget: int | None = None,
) -> list[BenchJob]:
    """Every (scenario, variant, seed) with seeds ``seed0 .. seed0 + runs − 1``.
    ``iterations``, ``population`` and the :class:`SearchParams` fields in ``search`` (for
    example ``{"fitness_smoothing": 0}``) override the scenarios' own settings for every
    algorithm. ``budget``: every algorithm stops after that many fitness evaluations; the
    iterations become a cap (``iterations`` if given, else ITERATION_CAP_FACTOR · N / G).
    The A* reference is deterministic: one run per scenario (the first seed). Jobs are
    ordered scenario, seed, variant, so slow and fast algorithms interleave across
    workers."""
    if runs < 1:
        raise ValueError("runs must be >= 1")
    if budget is not None and budget < 1:
        raise ValueError("the evaluation budget must be >= 1")
    vs = [v if isinstance(v, Variant) else Variant.parse(v) for v in variants]
    if not vs:
        raise ValueError("no algorithms to run")
    labels = [v.label for v in vs]
    if len(set(labels)) != len(labels):
        raise ValueError(f"algorithms listed twice: {', '.join(labels)}")
    jobs: list[BenchJob] = []
    names: set[str] = set()
    for scn in scenarios:
        changes: dict[str, Any] = {"stall_iterations": None}  # the paper's protocol: all M
        changes.update(
            (k, v) for k, v in (("iterations", iterations), ("population", population)) if v
        )
        changes.update(search or {})
        if budget is not None and not iterations:
            g = population or scn.planner.search.population
            cap = ITERATION_CAP_FACTOR * math.ceil(budget / g)
            changes["iterations"] = min(MAX_ITERATIONS, max(scn.planner.search.iterations, cap))
        if changes:
            scn = scn.with_planner(search=override(scn.planner.search, changes))
            check_limits(scn)
        name = scn.name
        k = 2
        while name in names:  # two files with the same scenario name stay apart
            name, k = f"{scn.name}#{k}", k + 1
        names.add(name)
        scn = dataclasses.replace(scn, name=name)
        key = scenario_key(scn)
        for seed in range(seed0, seed0 + runs):
            for v in vs:
                if v.algorithm == ASTAR and seed != seed0:
                    continue
                jobs.append(BenchJob(len(jobs), scn, key, v, seed, budget))
    return jobs


# ---------------------------------------------------------------------------------------------
# Running one job (in whatever process or thread executes it)

_CACHE_SIZE = 8
_cache: dict[str, tuple[Any, Any]] = {}
_cache_lock = threading.Lock()


def _world_and_problem(job: BenchJob, scn: Scenario) -> tuple[Any, Any]:
    """The scenario's world and path problem as :func:`uavplan.planning.plan_route` would
    build them for ``scn`` (the job's effective scenario), the geometry built once per
    process. Each run gets its own reachability memo: the memo is pure, but one that earlier
    runs filled up only slows lookups down (it holds 2^20 entries and a GWO or DE run alone
    nearly fills it)."""
    from uavplan.planning import build_problem

    with _cache_lock:
        hit = _cache.get(job.scenario_key)
    if hit is None:
        scn = job.scenario
        from uavplan.worlds import build_world

        world = build_world(scn)
        problem = build_problem(scn, world)
        hit = (world, problem)
        with _cache_lock:
            if len(_cache) >= _CACHE_SIZE:
                _cache.pop(next(iter(_cache)))
            _cache[job.scenario_key] = hit
    world, problem = hit
    return world, problem.with_fresh_memo()


def job_scenario(job: BenchJob) -> Scenario:
    """The scenario as the job runs it: its variant's algorithm and changes, its seed. The
    algorithm's parameters start from the scenario's section for it (or its defaults)."""
    scn, v = job.scenario, job.variant
    cfg = scn.planner
    if v.reference:  # not a swarm planner: the scenario as it is, with the seed
        return scn.with_planner(search=override(cfg.search, {"seed": job.seed}))
    params = cfg.params_for(v.algorithm)
    if v.params_changes:
        params = override(params, dict(v.params_changes))
    cfg = dataclasses.replace(
        cfg,
        algorithm=v.algorithm,
        search=override(cfg.search, {**dict(v.search_changes), "seed": job.seed}),
        post=override(cfg.post, dict(v.post_changes)),
    )
    if params is not None:
        cfg = cfg.with_params(v.algorithm, params)
    return dataclasses.replace(scn, planner=cfg)


def run_job(job: BenchJob) -> RunRecord:
    """Run one job through :func:`uavplan.planning.plan_route` (a reference row through
    :mod:`uavplan.bench.reference`) and record the outcome."""
    from uavplan.planning import plan_route

    scn = job_scenario(job)
    world, problem = _world_and_problem(job, scn)
    if job.variant.reference:
        return _run_reference(job, scn, world)
    if job.max_evaluations is not None:
        problem = problem.with_budget(job.max_evaluations)
    # one thread per run: baselines have no threaded kernel, the bench runs jobs side by side
    # (--workers), and its exact-test counts stay reproducible
    res = plan_route(scn, world=world, problem=problem, threads=1)
    pr = res.planner
    return RunRecord(
        index=job.index,
        scenario=scn.name,
        algorithm=job.variant.label,
        seed=job.seed,
        status=res.status,
        route_energy=float(res.energy),
        search_fitness=float(pr.best_fitness),
        collision_free=bool(res.collision_free),
        min_clearance_m=float(res.min_clearance_m),
        length_m=float(res.length_m),
        runtime_s=float(res.runtime_s),
        iterations=int(pr.iterations),
        deadlocks=int(pr.deadlocks),
        evaluations=int(pr.evaluations),
        reach_checks=int(pr.reach_checks),
        exact_checks=int(pr.exact_checks),
        termination=str(pr.termination),
        message=res.message,
        stats={k: float(v) for k, v in pr.stats.items() if isinstance(v, int | float)},
        convergence=np.asarray(pr.convergence, dtype=float),
    )


def _run_reference(job: BenchJob, scn: Scenario, world: Any) -> RunRecord:
    from . import reference

    label = job.variant.algorithm
    if label == ASTAR:
        out = reference.run_astar(scn, world)
    else:
        time_s = job.time_s if job.time_s is not None else job.variant.time_s
        out = reference.run_ompl(
            scn, world, label, reference.DEFAULT_TIME_S if time_s is None else time_s, job.seed
        )
    return RunRecord(
        index=job.index,
        scenario=scn.name,
        algorithm=job.variant.label,
        seed=job.seed,
        status="ok" if out.found else "no_path",
        route_energy=out.route_energy,
        search_fitness=out.raw_energy,
        collision_free=out.collision_free,
        min_clearance_m=out.min_clearance_m,
        length_m=out.length_m,
        runtime_s=out.runtime_s,
        iterations=0,
        deadlocks=0,
        termination="time" if label in OMPL_PLANNERS else "complete",
        message=out.message,
        stats=out.stats,
    )


def _worker_init() -> None:
    """Ctrl-C is the parent's to handle (it stops the pool); a worker ignores it, so it never
    raises inside a compiled kernel. (The C kernels are single-threaded.)"""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


# ---------------------------------------------------------------------------------------------
# Backends


def run_jobs(
    jobs: Sequence[BenchJob],
    *,
    workers: int = 1,
    dask: Any = None,
    progress: ProgressCallback | None = None,
    should_stop: Callable[[], bool] | None = None,
) -> list[RunRecord]:
    """Run ``jobs`` and return their records in job order.

    ``dask``: a scheduler address (``tcp://host:8786``, or a ``LocalCluster``'s) or a
    ``distributed.Client``; the jobs then run on that cluster and ``workers`` is ignored.
    Otherwise ``workers`` > 1 runs them on that many local processes, 1 runs them here.
    ``progress(done, total, record)`` is called as each job finishes. ``should_stop`` is
    polled between jobs (a Ctrl-C flag): the run then stops and returns the records finished
    so far (the caller, who owns the flag, knows why there are fewer).
    """
    stop = should_stop or (lambda: False)
    jobs = list(jobs)
    total = len(jobs)
    done: list[RunRecord] = []

    def finished(rec: RunRecord) -> None:
        done.append(rec)
        if progress is not None:
            progress(len(done), total, rec)

    # OMPL rows without a fixed time run last, for SPSA's mean wall time on their scenario
    timed = [j for j in jobs if j.variant.algorithm in OMPL_PLANNERS and j.variant.time_s is None]
    timed_ids = {j.index for j in timed}
    first = [j for j in jobs if j.index not in timed_ids]
    for phase in (first, timed):
        if phase is timed and timed:
            times = spsa_times(done)
            phase = [dataclasses.replace(j, time_s=times.get(j.scenario.name)) for j in timed]
        if not phase:
            continue
        if dask is not None:
            _run_dask(phase, dask, finished)
        elif workers > 1 and len(phase) > 1:
            _run_processes(phase, min(workers, len(phase)), finished, stop)
        else:
            for job in phase:
                if stop():
                    break
                finished(run_job(job))
        if stop():
            break
    return sorted(done, key=lambda r: r.index)


def spsa_times(records: Iterable[RunRecord]) -> dict[str, float]:
    """scenario → SPSA's mean wall time per run (the OMPL rows' solve time)."""
    times: dict[str, list[float]] = {}
    for r in records:
        if r.algorithm == "spsa" and math.isfinite(r.runtime_s):
            times.setdefault(r.scenario, []).append(r.runtime_s)
    return {scn: float(np.mean(ts)) for scn, ts in times.items()}


def _run_processes(
    jobs: list[BenchJob],
    workers: int,
    finished: Callable[[RunRecord], None],
    stop: Callable[[], bool],
) -> None:
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    # spawn: workers start clean (no inherited threads or locks), the same on every platform
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(workers, mp_context=ctx, initializer=_worker_init) as pool:
        futures = [pool.submit(run_job, job) for job in jobs]
        pending = set(futures)
        try:
            while pending:
                ready, pending = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
                for fut in ready:
                    finished(fut.result())
                if stop():
                    break
        finally:
            for fut in futures:
                fut.cancel()


def _run_dask(jobs: list[BenchJob], dask: Any, finished: Callable[[RunRecord], None]) -> None:
    try:
        from distributed import Client, as_completed
    except ImportError as err:  # pragma: no cover - depends on the environment
        raise RuntimeError(
            "the Dask backend needs the optional extra: pip install 'uavplan[dask]'"
        ) from err
    own = not isinstance(dask, Client)
    if own:
        try:
            client = Client(dask, timeout=DASK_CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError) as err:
            raise ConnectionError(f"cannot reach the Dask scheduler at {dask}: {err}") from err
    else:
        client = dask
    try:
        futures = client.map(run_job, jobs, pure=False)
        for fut in as_completed(futures):
            finished(fut.result())
    finally:
        if own:
            client.close()


def resolved_config(jobs: Sequence[BenchJob]) -> dict[str, Any]:
    """What the runs used (STYLE: echo the configuration): per scenario its resolved
    configuration (:func:`uavplan.scenario.resolved_config`) and, per algorithm label, the
    whole resolved planner configuration the runs used (:func:`uavplan.config.
    resolved_planner`: search values with the effective fitness smoothing, the algorithm's
    parameters, grid, energy, post-processing, margin pad); seeds listed once."""
    out: dict[str, Any] = {"scenarios": {}, "algorithms": {}, "seeds": []}
    for job in jobs:
        scn = job.scenario
        entry = out["scenarios"].get(scn.name)
        if entry is None:
            entry = {k: v for k, v in scenario_config(scn).items() if k != "planner"}
            planner = resolved_planner(scn.planner)
            entry["search"] = {k: v for k, v in as_search(scn.planner.search).items()}
            entry["grid"] = planner["grid"]
            entry["energy"] = planner["energy"]
            entry["algorithms"] = {}
            out["scenarios"][scn.name] = entry
        if job.variant.label not in entry["algorithms"] and job.variant.reference:
            ref: dict[str, Any] = {"reference": job.variant.algorithm}
            if job.variant.algorithm in OMPL_PLANNERS:
                ref["time_s"] = job.variant.time_s or "SPSA's mean wall time on the scenario"
            entry["algorithms"][job.variant.label] = ref
            out["algorithms"].setdefault(job.variant.label, ref)
        if job.variant.label not in entry["algorithms"]:
            run = job_scenario(job).planner
            resolved = resolved_planner(run)
            resolved["search"].pop("seed", None)
            if job.variant.search_changes:
                resolved["search_changes"] = dict(job.variant.search_changes)
            entry["algorithms"][job.variant.label] = resolved
            out["algorithms"].setdefault(job.variant.label, resolved)
    out["seeds"] = sorted({job.seed for job in jobs})
    budgets = {job.max_evaluations for job in jobs}
    out["budget"] = (
        {"evaluations": budgets.pop()} if budgets != {None} else "iterations (the scenario's M)"
    )
    return _jsonable(out)


def as_search(search: SearchParams) -> dict[str, Any]:
    """The scenario's search values without the seed (each run has its own)."""
    return {k: v for k, v in dataclasses.asdict(search).items() if k != "seed"}
