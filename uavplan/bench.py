"""Experiment runner for the paper's comparison (section 6, Table 2) and SPSA's ablation.

A benchmark is a list of :class:`BenchJob` — plain picklable specs, one per (scenario,
algorithm variant, seed) — run by :func:`run_jobs` serially, on local processes
(``workers > 1``) or on a Dask distributed cluster (``dask=ADDRESS``), with the same result:
one :class:`RunRecord` per job, in job order. :func:`summarise` aggregates them into the
Table-2 statistics (mean / worst / best / std of the final energy), success rate and runtime;
:func:`write_outputs` writes CSV, JSON, a Markdown table and convergence plots.

Each run goes through :func:`uavplan.planning.plan_route`, the same pipeline as
``uavplan plan``: the paper's protocol post-processes SPSA's best path only, baselines report
their raw best path on its spline. Every algorithm gets the same seeds, so for a given seed
every algorithm starts from the same initial population (eq. 8–10).

An algorithm *variant* is a label: a registered algorithm (``spsa``, ``pso``, …) or SPSA with
one contribution switched off (``spsa-no-escape``, …, see :data:`ABLATIONS`).
"""

from __future__ import annotations

import csv
import dataclasses
import hashlib
import io
import json
import math
import pickle
import re
import threading
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
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
from uavplan.fileio import atomic_write_bytes, atomic_write_text
from uavplan.scenario import Scenario, check_limits
from uavplan.scenario import resolved_config as scenario_config

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
        if head in PLANNERS:
            v = cls(head, head)
        elif base == "spsa" and suffix in ABLATIONS:
            spsa, post = ABLATIONS[suffix]
            v = cls(head, "spsa", tuple(spsa.items()), tuple(post.items()))
        else:
            known = [*PLANNERS, *(f"spsa-{s}" for s in ABLATIONS)]
            raise ValueError(f"unknown algorithm {head!r} (known: {', '.join(known)})")
        if not params.strip():
            return v
        return v._with_params(_parse_params(params), label)

    def _with_params(self, params: dict[str, Any], label: str) -> Variant:
        if "seed" in params:
            raise ValueError(f"{label}: seeds come from --seed0 and --runs")
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


@dataclass
class RunRecord:
    """The outcome of one run. ``energy`` is E (eq. 1) of the final path, the Table-2 value;
    ``search_fitness`` is the best fitness the search itself reached (before SPSA's
    post-processing); ``convergence`` is the best fitness after each iteration."""

    index: int
    scenario: str
    algorithm: str
    seed: int
    status: str
    energy: float
    search_fitness: float
    collision_free: bool
    min_clearance_m: float
    length_m: float
    runtime_s: float
    iterations: int
    deadlocks: int
    stats: dict[str, float] = field(default_factory=dict)  # the planner's counters
    convergence: np.ndarray = field(repr=False, default_factory=lambda: np.empty(0))

    def row(self) -> dict[str, Any]:
        """The record without its convergence curve (a CSV / JSON row)."""
        d = dataclasses.asdict(self)
        d.pop("convergence")
        return d


@dataclass(frozen=True)
class Summary:
    """Table-2 statistics of one (scenario, algorithm) over its runs. Energy statistics are
    over the runs that returned a path; ``std`` is the sample standard deviation."""

    scenario: str
    algorithm: str
    runs: int
    solved: int
    collision_free: int
    mean: float
    worst: float
    best: float
    std: float
    median_runtime_s: float
    mean_search_fitness: float

    @property
    def success_rate(self) -> float:
        return self.collision_free / self.runs if self.runs else 0.0


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
        cfg.grid,
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
) -> list[BenchJob]:
    """Every (scenario, variant, seed) with seeds ``seed0 .. seed0 + runs − 1``.
    ``iterations``, ``population`` and the :class:`SearchParams` fields in ``search`` (for
    example ``{"fitness_smoothing": 0}``) override the scenarios' own settings for every
    algorithm. Jobs are ordered scenario, seed, variant, so slow and fast algorithms
    interleave across workers."""
    if runs < 1:
        raise ValueError("runs must be >= 1")
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
                jobs.append(BenchJob(len(jobs), scn, key, v, seed))
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
        from uavplan.planning import build_world

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
    """Run one job through :func:`uavplan.planning.plan_route` and record the outcome."""
    from uavplan.planning import plan_route

    scn = job_scenario(job)
    world, problem = _world_and_problem(job, scn)
    res = plan_route(scn, world=world, problem=problem)
    pr = res.planner
    return RunRecord(
        index=job.index,
        scenario=scn.name,
        algorithm=job.variant.label,
        seed=job.seed,
        status=res.status.value,
        energy=float(res.energy),
        search_fitness=float(pr.best_fitness),
        collision_free=bool(res.collision_free),
        min_clearance_m=float(res.min_clearance_m),
        length_m=float(res.length_m),
        runtime_s=float(res.runtime_s),
        iterations=int(pr.iterations),
        deadlocks=int(pr.deadlocks),
        stats={k: float(v) for k, v in pr.stats.items() if isinstance(v, int | float)},
        convergence=np.asarray(pr.convergence, dtype=float),
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
    polled between jobs (a Ctrl-C flag): the run then raises KeyboardInterrupt.
    """
    stop = should_stop or (lambda: False)
    jobs = list(jobs)
    total = len(jobs)
    done: list[RunRecord] = []

    def finished(rec: RunRecord) -> None:
        done.append(rec)
        if progress is not None:
            progress(len(done), total, rec)

    if dask is not None:
        _run_dask(jobs, dask, finished)
    elif workers > 1 and total > 1:
        _run_processes(jobs, min(workers, total), finished, stop)
    else:
        for job in jobs:
            if stop():
                raise KeyboardInterrupt
            finished(run_job(job))
    return sorted(done, key=lambda r: r.index)


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
                    raise KeyboardInterrupt
        except BaseException:
            for fut in futures:
                fut.cancel()
            raise


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


# ---------------------------------------------------------------------------------------------
# Aggregation


def summarise(records: Iterable[RunRecord]) -> list[Summary]:
    """Table-2 statistics per (scenario, algorithm), in first-seen order."""
    groups: dict[tuple[str, str], list[RunRecord]] = {}
    for r in records:
        groups.setdefault((r.scenario, r.algorithm), []).append(r)
    out = []
    nan = math.nan
    for (scn, alg), rs in groups.items():
        e = np.array([r.energy for r in rs if r.status == "ok" and math.isfinite(r.energy)])
        s = np.array([r.search_fitness for r in rs if math.isfinite(r.search_fitness)])
        out.append(
            Summary(
                scenario=scn,
                algorithm=alg,
                runs=len(rs),
                solved=int(e.size),
                collision_free=sum(r.collision_free for r in rs),
                mean=float(e.mean()) if e.size else nan,
                worst=float(e.max()) if e.size else nan,
                best=float(e.min()) if e.size else nan,
                std=float(e.std(ddof=1)) if e.size > 1 else (0.0 if e.size else nan),
                median_runtime_s=float(np.median([r.runtime_s for r in rs])),
                mean_search_fitness=float(s.mean()) if s.size else nan,
            )
        )
    return out


def mean_convergence(records: Iterable[RunRecord]) -> dict[str, dict[str, np.ndarray]]:
    """scenario → algorithm → mean best fitness after each iteration (over runs that have a
    full curve)."""
    curves: dict[str, dict[str, list[np.ndarray]]] = {}
    for r in records:
        if r.convergence.size:
            curves.setdefault(r.scenario, {}).setdefault(r.algorithm, []).append(r.convergence)
    out: dict[str, dict[str, np.ndarray]] = {}
    for scn, by_alg in curves.items():
        out[scn] = {}
        for alg, cs in by_alg.items():
            n = min(c.size for c in cs)
            out[scn][alg] = np.mean([c[:n] for c in cs], axis=0)
    return out


def _fmt(v: float, digits: int = 2) -> str:
    return "—" if not math.isfinite(v) else f"{v:.{digits}f}"


def format_table(summaries: Sequence[Summary], scenario: str) -> str:
    """One scenario's results in the layout of the paper's Table 2 (Markdown): rows mean,
    worst, best, std of the final energy, then success rate, median runtime and, when SPSA is
    in the table, SPSA's mean as a fraction of each algorithm's."""
    rows = [s for s in summaries if s.scenario == scenario]
    if not rows:
        return ""
    head = f"| {scenario} | " + " | ".join(s.algorithm for s in rows) + " |"
    sep = "|---|" + "---:|" * len(rows)
    lines = [head, sep]

    def line(name: str, cells: Iterable[str]) -> None:
        lines.append(f"| {name} | " + " | ".join(cells) + " |")

    line("mean", (_fmt(s.mean) for s in rows))
    line("worst", (_fmt(s.worst) for s in rows))
    line("best", (_fmt(s.best) for s in rows))
    line("std", (_fmt(s.std) for s in rows))
    line("collision-free", (f"{s.collision_free}/{s.runs}" for s in rows))
    line("median runtime (s)", (_fmt(s.median_runtime_s) for s in rows))
    spsa = next((s for s in rows if s.algorithm == "spsa"), None)
    if spsa is not None and math.isfinite(spsa.mean):
        ratios = [
            _fmt(spsa.mean / s.mean, 3) if s.mean and math.isfinite(s.mean) else "—" for s in rows
        ]
        line("SPSA mean ÷ mean", ratios)
    return "\n".join(lines)


def format_tables(summaries: Sequence[Summary]) -> str:
    scenarios = list(dict.fromkeys(s.scenario for s in summaries))
    return "\n\n".join(format_table(summaries, scn) for scn in scenarios)


# ---------------------------------------------------------------------------------------------
# Outputs


def plot_convergence(curves: Mapping[str, np.ndarray], title: str, path: str | Path) -> None:
    """Mean best fitness against iteration, one line per algorithm (paper Figures 10–12)."""
    from matplotlib.figure import Figure  # no pyplot: no global backend state, Agg for PNG

    fig = Figure(figsize=(7.5, 4.5), dpi=120)
    ax = fig.add_subplot()
    for alg, curve in curves.items():
        style = "--" if alg.startswith("spsa-") else "-"
        ax.plot(np.arange(1, curve.size + 1), curve, style, label=alg, linewidth=1.4)
    ax.set_xlabel("iteration")
    ax.set_ylabel("mean best fitness (energy)")
    ax.set_yscale("log")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="small", ncols=2)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    atomic_write_bytes(path, buf.getvalue())


def _safe_name(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in name)


def write_outputs(
    out_dir: str | Path,
    records: Sequence[RunRecord],
    *,
    config: Mapping[str, Any] | None = None,
    plots: bool = True,
) -> list[Path]:
    """Write ``runs.csv`` (one row per run), ``summary.csv``, ``bench.json`` (configuration,
    summary and mean convergence curves), ``summary.md`` (the tables) and one
    ``convergence-<scenario>.png`` per scenario. Every file is written atomically. Returns
    the paths written."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    summaries = summarise(records)
    curves = mean_convergence(records)
    written: list[Path] = []

    def put(name: str, text: str) -> None:
        atomic_write_text(out / name, text)
        written.append(out / name)

    rows = [r.row() for r in records]
    columns = [c for c in RunRecord.__dataclass_fields__ if c != "convergence"]
    put("runs.csv", _csv([{**r, "stats": json.dumps(r["stats"])} for r in rows], columns))
    srows = [{**dataclasses.asdict(s), "success_rate": s.success_rate} for s in summaries]
    put("summary.csv", _csv(srows, [*Summary.__dataclass_fields__, "success_rate"]))
    doc = {
        "config": dict(config or {}),
        "summary": srows,
        "mean_convergence": {
            scn: {alg: [round(float(v), 2) for v in c] for alg, c in by.items()}
            for scn, by in curves.items()
        },
    }
    # one line per top-level key: the convergence curves (thousands of numbers) stay compact
    parts = [f"{json.dumps(k)}: {json.dumps(v)}" for k, v in _jsonable(doc).items()]
    put("bench.json", "{\n" + ",\n".join(parts) + "\n}\n")
    put("summary.md", format_tables(summaries) + "\n")
    if plots:
        for scn, by_alg in curves.items():
            path = out / f"convergence-{_safe_name(scn)}.png"
            plot_convergence(by_alg, f"{scn}: mean best fitness over runs", path)
            written.append(path)
    return written


def _csv(rows: Sequence[Mapping[str, Any]], columns: Sequence[str]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(columns), lineterminator="\n")
    w.writeheader()
    for row in rows:
        w.writerow({k: _jsonable(row.get(k)) for k in columns})
    return buf.getvalue()


def _jsonable(value: Any) -> Any:
    """Plain JSON values: NaN/inf become None (JSON has neither)."""
    if isinstance(value, float | np.floating):
        v = float(value)
        return v if math.isfinite(v) else None
    if isinstance(value, np.integer | np.bool_):
        return value.item()
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    return value


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
        if job.variant.label not in entry["algorithms"]:
            run = job_scenario(job).planner
            resolved = resolved_planner(run)
            resolved["search"].pop("seed", None)
            if job.variant.search_changes:
                resolved["search_changes"] = dict(job.variant.search_changes)
            entry["algorithms"][job.variant.label] = resolved
            out["algorithms"].setdefault(job.variant.label, resolved)
    out["seeds"] = sorted({job.seed for job in jobs})
    return _jsonable(out)


def as_search(search: SearchParams) -> dict[str, Any]:
    """The scenario's search values without the seed (each run has its own)."""
    return {k: v for k, v in dataclasses.asdict(search).items() if k != "seed"}
