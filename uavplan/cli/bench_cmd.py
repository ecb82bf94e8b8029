"""``uavplan bench``: the paper's comparison (Table 2) and SPSA's ablation, as thin wiring
over :mod:`uavplan.bench`."""

from __future__ import annotations

import time
from typing import Any

import click

from uavplan.cli import main
from uavplan.cli.common import Progress, handle_errors, interruptible, show_progress
from uavplan.cli.options import ALGORITHMS
from uavplan.errors import InputError


@main.command("bench")
@click.argument("scenarios", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option(
    "--algorithms",
    "variants",
    type=ALGORITHMS,
    default=None,
    help="Comma-separated algorithms; also SPSA ablations (spsa-no-escape) and parameter "
    "variants such as 'de(cr=0.1)' or 'spsa(oscillation_window=4)'. Default: every "
    "registered algorithm of the paper's comparison (spsa, ssa, pso, gwo, de, cso).",
)
@click.option("--runs", type=click.IntRange(min=1), default=30, show_default=True)
@click.option(
    "--iterations", type=click.IntRange(min=1), help="Iterations M (default: scenario's)."
)
@click.option(
    "--population", type=click.IntRange(min=4), help="Population G (default: scenario's)."
)
@click.option(
    "--fitness-smoothing",
    type=click.IntRange(min=0),
    help="Search fitness for every algorithm: 0 = the paper's (spline through the nodes), "
    "N = through their moving average of half-width N (default: scenario's).",
)
@click.option(
    "--seed0",
    type=click.IntRange(min=0),
    default=1,
    show_default=True,
    help="Seeds are SEED0 .. SEED0+RUNS-1, the same for every algorithm.",
)
@click.option(
    "--workers",
    type=click.IntRange(min=1),
    default=1,
    show_default=True,
    help="Local worker processes.",
)
@click.option(
    "--dask",
    "dask_address",
    metavar="ADDRESS",
    help="Run the jobs on this Dask scheduler (e.g. tcp://host:8786) instead of locally.",
)
@click.option(
    "--budget",
    "budget_text",
    metavar="evaluations=N",
    help="Stop every algorithm after N fitness evaluations (individuals scored) instead of "
    "after M iterations; the iterations become a cap (--iterations, or 20·N/G).",
)
@click.option(
    "--references",
    is_flag=True,
    help="Also run the reference planners: grid A* + line of sight and, with the optional "
    "'ompl' package, OMPL's RRT*, Informed RRT* and BIT* for SPSA's mean wall time.",
)
@click.option(
    "--ablation",
    is_flag=True,
    help="Also run SPSA with each of its contributions switched off in turn.",
)
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False),
    help="Write runs.csv, summary.csv, bench.json, summary.md and convergence PNGs here.",
)
@click.option("--quiet", "-q", is_flag=True, help="No progress output.")
@handle_errors
def bench_command(
    scenarios: tuple[str, ...],
    variants: list[Any] | None,
    runs: int,
    iterations: int | None,
    population: int | None,
    fitness_smoothing: int | None,
    seed0: int,
    workers: int,
    dask_address: str | None,
    budget_text: str | None,
    references: bool,
    ablation: bool,
    out_dir: str | None,
    quiet: bool,
) -> None:
    """Run every algorithm RUNS times on each SCENARIO and print the paper's Table 2 twice:
    mean / worst / best / std of the raw search result and of the post-processed route
    energy, with collision-free runs, evaluations, reachability checks and wall time per
    run."""
    from uavplan import bench
    from uavplan.bench.reference import OMPL_MISSING, OMPL_PLANNERS, ompl_available
    from uavplan.scenario import load_scenario

    if dask_address and workers != 1:
        raise click.UsageError("--workers and --dask are exclusive (Dask sizes its own workers)")
    budget = None
    if budget_text is not None:
        try:
            budget = bench.parse_budget(budget_text)
        except ValueError as err:
            raise InputError(str(err), key="--budget") from None
    if variants is None:
        variants = [bench.Variant.parse(name) for name in bench.default_algorithms()]
    if ablation:
        have = {v.label for v in variants}
        variants += [v for v in bench.ablation_variants() if v.label not in have]
    if references:
        have = {v.label for v in variants}
        variants += [v for v in bench.reference_variants() if v.label not in have]
        if not ompl_available() and not quiet:
            click.echo(f"note: {OMPL_MISSING}", err=True)
    if any(v.algorithm in OMPL_PLANNERS for v in variants) and not ompl_available():
        raise InputError(OMPL_MISSING.removesuffix("; they were skipped"), key="--algorithms")
    loaded = [load_scenario(path) for path in scenarios]
    try:
        jobs = bench.make_jobs(
            loaded,
            variants,
            runs=runs,
            seed0=seed0,
            iterations=iterations,
            population=population,
            search=None if fitness_smoothing is None else {"fitness_smoothing": fitness_smoothing},
            budget=budget,
        )
    except InputError:
        raise
    except ValueError as err:
        raise InputError(str(err), key="--algorithms") from None

    bar = Progress(show_progress(quiet), "bench")

    def progress(done: int, total: int, rec: bench.RunRecord) -> None:
        bar.show(done, total, f"{rec.scenario} {rec.algorithm}")

    t0 = time.perf_counter()
    try:
        with interruptible() as stop_requested:
            records = bench.run_jobs(
                jobs,
                workers=workers,
                dask=dask_address,
                progress=progress,
                should_stop=stop_requested,
            )
    except ConnectionError as err:
        raise InputError(str(err), key="--dask") from None
    except RuntimeError as err:
        if "uavplan[dask]" in str(err):
            raise InputError(str(err), key="--dask") from None
        raise
    finally:
        bar.close()
    wall = time.perf_counter() - t0

    click.echo(bench.format_tables(bench.summarise(records)))
    if out_dir:
        config = bench.resolved_config(jobs)
        config["runs"] = runs
        config["workers"] = None if dask_address else workers
        config["dask"] = dask_address
        config["wall_time_s"] = round(wall, 2)
        written = bench.write_outputs(out_dir, records, config=config)
        if not quiet:
            click.echo(f"wrote {len(written)} files to {out_dir}", err=True)
    if not quiet:
        click.echo(f"{len(records)} runs in {wall:.1f} s", err=True)
