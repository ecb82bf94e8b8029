"""``uavplan convert``: parse, call :func:`uavplan.app.convert.convert`, print."""

from __future__ import annotations

import click

from uavplan.app.convert import ConvertRequest, convert
from uavplan.cli import main
from uavplan.cli.common import feedback, handle_errors, interruptible


@main.command("convert")
@click.argument("input_path", metavar="IN", type=click.Path(dir_okay=False))
@click.argument("output", metavar="OUT", type=click.Path(dir_okay=False))
@click.option(
    "--scenario",
    "scenario_path",
    type=click.Path(dir_okay=False),
    help="Add this scenario's obstacles to a .geojson / .kml export.",
)
@click.option(
    "--autopilot",
    type=click.Choice(["px4", "ardupilot"]),
    help="Read IN as this autopilot's mission (a .waypoints file does not say; "
    "default ardupilot there, the file's firmwareType for a .plan).",
)
@click.option("--quiet", "-q", is_flag=True, help="No summary line.")
@handle_errors
def convert_command(
    input_path: str, output: str, scenario_path: str | None, autopilot: str | None, quiet: bool
) -> None:
    """Convert mission file IN to OUT; the formats come from the extensions.

    IN: .plan or .waypoints. OUT: .plan, .waypoints, .geojson or .kml (the map exports
    draw the flown route, the waypoints, the geofence and, with --scenario, the obstacles).
    """
    request = ConvertRequest(input_path, output, scenario_path, autopilot)
    with interruptible() as interrupts:
        outcome = convert(request, feedback(quiet, interrupts, progress=False))
        for note in outcome.notes:
            click.echo(f"note: {note}", err=True)
        if not quiet:
            click.echo(outcome.summary(), err=True)
