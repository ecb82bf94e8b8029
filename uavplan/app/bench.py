"""``bench``: the paper's comparison (Table 2) and SPSA's ablation over :mod:`uavplan.bench`."""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

from uavplan import bench
from uavplan.app.feedback import Feedback
from uavplan.app.inputs import load_scenario_file
from uavplan.app.outputs import OutputSet
from uavplan.bench.reference import OMPL_MISSING, OMPL_PLANNERS, ompl_available
from uavplan.errors import InputError


@dataclass(frozen=True)
class BenchRequest:
    """``uavplan bench SCENARIO... [options]`` (None: the scenarios' own values)."""

    scenarios: tuple[str, ...]
    variants: Sequence[bench.Variant] | None = None
    runs: int = 30
    iterations: int | None = None
    population: int | None = None
    fitness_smoothing: int | None = None
    seed0: int = 1
    workers: int = 1
    dask: str | None = None
    budget: str | None = None
    references: bool = False
    ablation: bool = False
    out_dir: str | None = None


@dataclass(frozen=True, eq=False)
class BenchOutcome:
    """The records of every run (those finished when ``interrupted``), the tables and the
    files written."""

    records: tuple[bench.RunRecord, ...]
    wall_s: float
    written: tuple[str, ...] = ()
    interrupted: bool = False

    def tables(self) -> str:
        return bench.format_tables(bench.summarise(list(self.records)))


def run_bench(request: BenchRequest, feedback: Feedback) -> BenchOutcome:
    """Run every job of ``request`` (progress per finished job; ``feedback.should_stop`` is
    polled between jobs) and write the outputs into ``out_dir``: checked before the first
    run, written as one set once every run is done (an interrupt leaves nothing)."""
    outputs = OutputSet(feedback.interrupts)
    outputs.reads(*request.scenarios, role="a scenario to bench")
    folder = outputs.folder(request.out_dir) if request.out_dir else None
    outputs.check()
    budget = None
    if request.budget is not None:
        try:
            budget = bench.parse_budget(request.budget)
        except ValueError as err:
            raise InputError(str(err), key="--budget") from None
    variants = list(request.variants or [])
    if request.variants is None:
        variants = [bench.Variant.parse(name) for name in bench.default_algorithms()]
    if request.ablation:
        have = {v.label for v in variants}
        variants += [v for v in bench.ablation_variants() if v.label not in have]
    if request.references:
        have = {v.label for v in variants}
        variants += [v for v in bench.reference_variants() if v.label not in have]
        if not ompl_available():
            feedback.say(f"note: {OMPL_MISSING}")
    if any(v.algorithm in OMPL_PLANNERS for v in variants) and not ompl_available():
        raise InputError(OMPL_MISSING.removesuffix("; they were skipped"), key="--algorithms")
    loaded = [load_scenario_file(path, "bench") for path in request.scenarios]
    for scn in loaded:
        outputs.reads(*scn.files)
    for path, scn in zip(request.scenarios, loaded, strict=True):
        if scn.planner.fitness != "paper":  # the references and tables are eq. 1-2's
            raise InputError(
                "bench runs the paper's comparison on its fitness (eq. 1-2); planner.energy: "
                f"{scn.planner.fitness} is for plan (tools/energy_savings.py compares the two)",
                file=str(path),
                key="planner.energy",
            )
    smoothing = request.fitness_smoothing
    try:
        jobs = bench.make_jobs(
            loaded,
            variants,
            runs=request.runs,
            seed0=request.seed0,
            iterations=request.iterations,
            population=request.population,
            search=None if smoothing is None else {"fitness_smoothing": smoothing},
            budget=budget,
        )
    except InputError:
        raise
    except ValueError as err:
        raise InputError(str(err), key="--algorithms") from None

    bar = feedback.progress
    if bar is not None:
        bar.start("bench")

    def progress(done: int, total: int, rec: bench.RunRecord) -> None:
        if bar is not None:
            bar.show(done, total, f"{rec.scenario} {rec.algorithm}")

    stop = feedback.should_stop or (lambda: False)
    t0 = time.perf_counter()
    try:
        with feedback.polled():
            records = bench.run_jobs(
                jobs,
                workers=request.workers,
                dask=request.dask,
                progress=progress,
                should_stop=stop,
            )
    except ConnectionError as err:
        raise InputError(str(err), key="--dask") from None
    except RuntimeError as err:
        if "uavplan[dask]" in str(err):
            raise InputError(str(err), key="--dask") from None
        raise
    finally:
        if bar is not None:
            bar.close()
    wall = time.perf_counter() - t0
    if stop():
        return BenchOutcome(tuple(records), wall, interrupted=True)
    written: tuple[str, ...] = ()
    if folder is not None:
        config = bench.resolved_config(jobs)
        config["runs"] = request.runs
        config["workers"] = None if request.dask else request.workers
        config["dask"] = request.dask
        config["wall_time_s"] = round(wall, 2)
        with outputs:
            for name, data in bench.output_files(records, config=config).items():
                folder.file(name).write_bytes(data)
            written = outputs.commit()
    return BenchOutcome(tuple(records), wall, written)
