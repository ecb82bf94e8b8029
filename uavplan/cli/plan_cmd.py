"""``uavplan plan``: parse the options, call :func:`uavplan.app.plan.plan`, print."""

from __future__ import annotations

import click

from uavplan.app.feedback import PlannerOptions
from uavplan.app.plan import PlanRequest, plan
from uavplan.cli import main
from uavplan.cli.common import (
    check_threads_variable,
    exit_interrupted,
    feedback,
    handle_errors,
    interruptible,
    warn,
)
from uavplan.cli.options import ALGORITHM


@main.command("plan")
@click.argument("scenario", type=click.Path(dir_okay=False))
@click.option(
    "-o",
    "--output",
    "output",
    required=True,
    type=click.Path(dir_okay=False),
    help="File to write: .plan, .waypoints, or a .geojson / .kml map export (format from "
    "the extension).",
)
@click.option(
    "--algorithm",
    type=ALGORITHM,
    help="Planner (default: the scenario's, else spsa).",
)
@click.option("--seed", type=click.IntRange(min=0), help="Random seed (reproducible runs).")
@click.option(
    "--iterations",
    type=click.IntRange(min=1),
    help="Run exactly this many iterations M (the paper's protocol). Default: the scenario's M "
    "(1000) as a budget: the first search stops once the best has not improved for "
    "planner.stall_iterations (100), each further restart after planner.restart_stall_iterations "
    "(25).",
)
@click.option("--population", type=click.IntRange(min=4), help="Population size G (default 30).")
@click.option(
    "--autopilot",
    type=click.Choice(["px4", "ardupilot"]),
    help="Mission flavour (default: the scenario's, else ardupilot).",
)
@click.option("--report", type=click.Path(dir_okay=False), help="Write a JSON report here.")
@click.option(
    "--plot", type=click.Path(dir_okay=False), help="Draw the route into this PNG picture."
)
@click.option(
    "--fence",
    is_flag=True,
    help="Add a geofence: the bounds as inclusion, obstacles the route flies around as "
    "exclusion zones (.plan, .geojson, .kml).",
)
@click.option(
    "--scenario",
    "scenario_path",
    type=click.Path(dir_okay=False),
    help="With a .plan input: add this scenario's obstacles and use its planner and mission "
    "settings.",
)
@click.option(
    "--reserve",
    "reserve_pct",
    type=click.FloatRange(0, 100, max_open=True),
    help="Battery (%% of the usable energy) that must be left on landing; a mission that "
    "needs more exits 2 (default 20).",
)
@click.option(
    "--allow-over-battery",
    is_flag=True,
    help="Write a mission that needs more than the usable battery minus the reserve "
    "(a warning instead of exit 2).",
)
@click.option(
    "--legal-ceiling",
    metavar="M|none",
    help="The highest a return to launch may fly above the ground (m; default: the "
    "scenario's mission.legal_ceiling, 120): a safe RTL altitude above it is not advised, "
    "the mission ends with a planned return instead. 'none': no limit.",
)
@click.option(
    "--view",
    "view_path",
    type=click.Path(dir_okay=False),
    help="Also write the interactive page of the mission (HTML, offline; needs the view "
    "extra: pip install 'uavplan[view]').",
)
@click.option("--quiet", "-q", is_flag=True, help="No progress output.")
@handle_errors
def plan_command(
    scenario: str,
    output: str,
    algorithm: str | None,
    seed: int | None,
    iterations: int | None,
    population: int | None,
    autopilot: str | None,
    report: str | None,
    plot: str | None,
    fence: bool,
    scenario_path: str | None,
    reserve_pct: float | None,
    view_path: str | None,
    allow_over_battery: bool,
    legal_ceiling: str | None,
    quiet: bool,
) -> None:
    """Plan a collision-free route for SCENARIO and write it as a mission file.

    A QGroundControl .plan as SCENARIO is rerouted around its own exclusion zones: every
    item is kept and planned waypoints are inserted between its positions (docs/reroute.md).

    \b
    Examples:
      uavplan plan missions/paper-env1.yaml -o env1.plan
      uavplan plan missions/paper-env3.yaml -o env3.plan --fence --plot env3.png
      uavplan plan missions/paper-env2.yaml -o env2.waypoints --seed 7 --autopilot px4
      uavplan plan missions/qgc-inspection.plan -o safe.plan
    """
    request = PlanRequest(
        scenario,
        output,
        PlannerOptions(algorithm, seed, iterations, population),
        autopilot=autopilot,
        report=report,
        plot=plot,
        fence=fence,
        scenario=scenario_path,
        reserve_pct=reserve_pct,
        view=view_path,
        allow_over_battery=allow_over_battery,
        legal_ceiling=legal_ceiling,
    )
    check_threads_variable(warn)
    with interruptible() as interrupts:
        outcome = plan(request, feedback(quiet, interrupts))
        if outcome.interrupted:
            exit_interrupted()
        if not quiet:
            click.echo(outcome.summary(), err=True)
            # a planned route's or a survey's (uavplan.app.survey) estimate; none on a reroute
            estimate = getattr(outcome, "estimate", None)
            if estimate is not None:
                click.echo(estimate.summary(), err=True)
