"""``uavplan view``: parse, call :func:`uavplan.app.view.view`, print."""

from __future__ import annotations

import click

from uavplan.app.view import ViewRequest, view
from uavplan.cli import main
from uavplan.cli.common import feedback, handle_errors, interruptible


@main.command("view")
@click.argument("source", type=click.Path(dir_okay=False))
@click.option(
    "-o", "--output", required=True, type=click.Path(dir_okay=False), help="HTML page to write."
)
@click.option(
    "--scenario",
    "scenario_path",
    type=click.Path(dir_okay=False),
    help="The scenario the mission flies in (its obstacles, terrain and margin).",
)
@click.option(
    "--track",
    "track_path",
    type=click.Path(dir_okay=False),
    help="Show this flown track (.csv / .geojson from `fly --track` or `simulate --track`) "
    "as the flight as flown, instead of the flight model's.",
)
@click.option("--quiet", "-q", is_flag=True, help="Only the result.")
@handle_errors
def view_command(
    source: str, output: str, scenario_path: str | None, track_path: str | None, quiet: bool
) -> None:
    """Write one interactive page of MISSION (with --scenario) or of a SCENARIO alone.

    The page (HTML, works offline) shows the scene in 3-D, the planned route with numbered
    waypoints, the flight as flown (the flight model, or --track) and the way home, a
    profile along the route with every leg under the margin in red, and a slider that
    replays the flight. It needs the optional extra: pip install 'uavplan[view]'.

    \b
    Examples:
      uavplan view env1.plan --scenario missions/paper-env1.yaml -o env1.html
      uavplan view env1.plan --scenario missions/paper-env1.yaml --track flown.csv -o flown.html
      uavplan view missions/jacksboro-ridge.yaml -o ridge.html
    """
    request = ViewRequest(source, output, scenario=scenario_path, track=track_path)
    with interruptible() as interrupts:
        outcome = view(request, feedback(quiet, interrupts, progress=False))
    for problem in outcome.problems:
        click.echo(f"warning: {problem}", err=True)
    click.echo(outcome.summary())
