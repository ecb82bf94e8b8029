"""``uavplan bench``: parse, call :func:`uavplan.app.bench.run_bench`, print."""

from __future__ import annotations

from typing import Any

import click

from uavplan.app.bench import BenchRequest, run_bench
from uavplan.cli import main
from uavplan.cli.common import (
    check_threads_variable,
    exit_interrupted,
    feedback,
    handle_errors,
    interruptible,
    warn,
)
from uavplan.cli.options import ALGORITHMS


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
    if dask_address and workers != 1:
        raise click.UsageError("--workers and --dask are exclusive (Dask sizes its own workers)")
    request = BenchRequest(
        scenarios,
        variants,
        runs=runs,
        iterations=iterations,
        population=population,
        fitness_smoothing=fitness_smoothing,
        seed0=seed0,
        workers=workers,
        dask=dask_address,
        budget=budget_text,
        references=references,
        ablation=ablation,
        out_dir=out_dir,
    )
    check_threads_variable(warn)
    with interruptible() as interrupts:
        outcome = run_bench(request, feedback(quiet, interrupts))
        if outcome.interrupted:
            exit_interrupted()
        click.echo(outcome.tables())
        if out_dir and not quiet:
            click.echo(f"wrote {len(outcome.written)} files to {out_dir}", err=True)
        if not quiet:
            click.echo(f"{len(outcome.records)} runs in {outcome.wall_s:.1f} s", err=True)
