"""What a benchmark's runs produced: one :class:`RunRecord` per run, the Table-2 statistics
(:func:`summarise`, :func:`format_tables`) and the files (:func:`write_outputs`: CSV, JSON, a
Markdown table and convergence plots)."""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from uavplan.fileio import atomic_write_bytes


@dataclass
class RunRecord:
    """The outcome of one run.

    ``search_fitness``: the best fitness the search itself reached, on its own node path —
    the paper's Table-2 protocol (for a reference row: E of its raw polyline);
    ``route_energy``: E (eq. 1) of the route after the shared post-processing chain;
    ``evaluations``: fitness evaluations (individuals scored); ``reach_checks`` /
    ``exact_checks``: reachability checks and the exact segment tests among them;
    ``termination``: why the search stopped (``iterations``, ``budget``, ...);
    ``convergence``: the best fitness after each iteration."""

    index: int
    scenario: str
    algorithm: str
    seed: int
    status: str
    route_energy: float
    search_fitness: float
    collision_free: bool
    min_clearance_m: float
    length_m: float
    runtime_s: float
    iterations: int
    deadlocks: int
    evaluations: int = 0
    reach_checks: int = 0
    exact_checks: int = 0
    termination: str = ""
    message: str = ""
    stats: dict[str, float] = field(default_factory=dict)  # the planner's counters
    convergence: np.ndarray = field(repr=False, default_factory=lambda: np.empty(0))

    def row(self) -> dict[str, Any]:
        """The record without its convergence curve (a CSV / JSON row)."""
        d = dataclasses.asdict(self)
        d.pop("convergence")
        return d


@dataclass(frozen=True)
class Summary:
    """Table-2 statistics of one (scenario, algorithm) over its runs, twice: ``search_*`` of
    the raw search result (the paper's protocol) and ``route_*`` of the post-processed route's
    energy. Statistics are over the runs that returned a path; ``*_std`` is the sample
    standard deviation. Budget columns are means per run."""

    scenario: str
    algorithm: str
    runs: int
    solved: int
    collision_free: int
    search_mean: float
    search_worst: float
    search_best: float
    search_std: float
    route_mean: float
    route_worst: float
    route_best: float
    route_std: float
    mean_evaluations: float
    mean_reach_checks: float
    mean_iterations: float
    mean_runtime_s: float
    median_runtime_s: float
    budget_stops: int  # runs that ended because the evaluation budget was spent

    @property
    def success_rate(self) -> float:
        return self.collision_free / self.runs if self.runs else 0.0


# ---------------------------------------------------------------------------------------------
# Aggregation


def summarise(records: Iterable[RunRecord]) -> list[Summary]:
    """Table-2 statistics per (scenario, algorithm), in first-seen order."""
    groups: dict[tuple[str, str], list[RunRecord]] = {}
    for r in records:
        groups.setdefault((r.scenario, r.algorithm), []).append(r)
    out = []
    for (scn, alg), rs in groups.items():
        ok = [r for r in rs if r.status == "ok"]
        e = np.array([r.route_energy for r in ok if math.isfinite(r.route_energy)])
        s = np.array([r.search_fitness for r in ok if math.isfinite(r.search_fitness)])
        out.append(
            Summary(
                scn,
                alg,
                len(rs),
                int(e.size),
                sum(r.collision_free for r in rs),
                *_stats(s),
                *_stats(e),
                float(np.mean([r.evaluations for r in rs])),
                float(np.mean([r.reach_checks for r in rs])),
                float(np.mean([r.iterations for r in rs])),
                float(np.mean([r.runtime_s for r in rs])),
                float(np.median([r.runtime_s for r in rs])),
                sum(r.termination == "budget" for r in rs),
            )
        )
    return out


def _stats(v: np.ndarray) -> tuple[float, float, float, float]:
    """(mean, worst, best, sample std) of ``v``; NaN when empty, std 0 for one value."""
    if not v.size:
        return (math.nan,) * 4
    std = float(v.std(ddof=1)) if v.size > 1 else 0.0
    return float(v.mean()), float(v.max()), float(v.min()), std


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


def _count(v: float) -> str:
    return "—" if not math.isfinite(v) else f"{v:,.0f}"


def format_table(summaries: Sequence[Summary], scenario: str) -> str:
    """One scenario's results (Markdown), one column per algorithm: the paper's Table-2
    statistics (mean, worst, best, std) of the raw search result, then the same of the
    post-processed route energy, then collision-free runs, the budget used per run
    (evaluations, reachability checks, iterations, wall time) and, when SPSA is in the
    table, SPSA's mean as a fraction of each algorithm's, raw and post-processed."""
    rows = [s for s in summaries if s.scenario == scenario]
    if not rows:
        return ""
    head = f"| {scenario} | " + " | ".join(s.algorithm for s in rows) + " |"
    sep = "|---|" + "---:|" * len(rows)
    lines = [head, sep]

    def line(name: str, cells: Iterable[str]) -> None:
        lines.append(f"| {name} | " + " | ".join(cells) + " |")

    line("search fitness mean (raw, Table 2)", (_fmt(s.search_mean) for s in rows))
    line("search fitness worst", (_fmt(s.search_worst) for s in rows))
    line("search fitness best", (_fmt(s.search_best) for s in rows))
    line("search fitness std", (_fmt(s.search_std) for s in rows))
    line("route energy mean (post-processed)", (_fmt(s.route_mean) for s in rows))
    line("route energy worst", (_fmt(s.route_worst) for s in rows))
    line("route energy best", (_fmt(s.route_best) for s in rows))
    line("route energy std", (_fmt(s.route_std) for s in rows))
    line("collision-free", (f"{s.collision_free}/{s.runs}" for s in rows))
    line("evaluations / run", (_count(s.mean_evaluations) for s in rows))
    line("reachability checks / run", (_count(s.mean_reach_checks) for s in rows))
    line("iterations / run", (_count(s.mean_iterations) for s in rows))
    line("wall time / run (s)", (_fmt(s.mean_runtime_s) for s in rows))
    if any(s.budget_stops for s in rows):
        line("stopped by the budget", (f"{s.budget_stops}/{s.runs}" for s in rows))
    spsa = next((s for s in rows if s.algorithm == "spsa"), None)
    if spsa is not None:
        for name, key in (("raw", "search_mean"), ("post-processed", "route_mean")):
            mine = getattr(spsa, key)
            cells = []
            for s in rows:
                theirs = getattr(s, key)
                ok = math.isfinite(mine) and math.isfinite(theirs) and theirs
                cells.append(_fmt(mine / theirs, 3) if ok else "—")
            line(f"SPSA mean ÷ mean ({name})", cells)
    return "\n".join(lines)


def format_tables(summaries: Sequence[Summary]) -> str:
    scenarios = list(dict.fromkeys(s.scenario for s in summaries))
    return "\n\n".join(format_table(summaries, scn) for scn in scenarios)


# ---------------------------------------------------------------------------------------------
# Outputs


def plot_convergence(curves: Mapping[str, np.ndarray], title: str, path: str | Path) -> None:
    """Mean best fitness against iteration, one line per algorithm (paper Figures 10–12),
    written atomically to the PNG file ``path``."""
    atomic_write_bytes(path, convergence_png(curves, title))


def convergence_png(curves: Mapping[str, np.ndarray], title: str) -> bytes:
    """The picture :func:`plot_convergence` writes, as PNG bytes."""
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
    return buf.getvalue()


def _safe_name(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in name)


def output_files(
    records: Sequence[RunRecord],
    *,
    config: Mapping[str, Any] | None = None,
    plots: bool = True,
) -> dict[str, bytes]:
    """The files of a bench's output folder, name → content: ``runs.csv`` (one row per run),
    ``summary.csv``, ``bench.json`` (configuration, summary and mean convergence curves),
    ``summary.md`` (the tables) and one ``convergence-<scenario>.png`` per scenario."""
    summaries = summarise(records)
    curves = mean_convergence(records)
    files: dict[str, bytes] = {}
    rows = [r.row() for r in records]
    columns = [c for c in RunRecord.__dataclass_fields__ if c != "convergence"]
    runs = _csv([{**r, "stats": json.dumps(r["stats"])} for r in rows], columns)
    files["runs.csv"] = runs.encode()
    srows = [{**dataclasses.asdict(s), "success_rate": s.success_rate} for s in summaries]
    files["summary.csv"] = _csv(srows, [*Summary.__dataclass_fields__, "success_rate"]).encode()
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
    files["bench.json"] = ("{\n" + ",\n".join(parts) + "\n}\n").encode()
    files["summary.md"] = (format_tables(summaries) + "\n").encode()
    if plots:
        for scn, by_alg in curves.items():
            title = f"{scn}: mean best fitness over runs"
            files[f"convergence-{_safe_name(scn)}.png"] = convergence_png(by_alg, title)
    return files


def write_outputs(
    out_dir: str | Path,
    records: Sequence[RunRecord],
    *,
    config: Mapping[str, Any] | None = None,
    plots: bool = True,
) -> list[Path]:
    """Write :func:`output_files` into ``out_dir`` (made if missing), each file atomically.
    Returns the paths written. (``uavplan bench --out`` writes them as one set:
    :mod:`uavplan.app.outputs`.)"""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    for name, data in output_files(records, config=config, plots=plots).items():
        atomic_write_bytes(out / name, data)
        written.append(out / name)
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
