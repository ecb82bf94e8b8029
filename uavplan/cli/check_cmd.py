"""``uavplan validate``: parse, call :func:`uavplan.app.check.validate`, print."""

from __future__ import annotations

import click

from uavplan.app.check import validate
from uavplan.cli import main
from uavplan.cli.common import handle_errors


@main.command("validate")
@click.argument("file", type=click.Path(dir_okay=False))
@click.option(
    "--scenario",
    "scenario_path",
    type=click.Path(dir_okay=False),
    help="Check the mission FILE against this scenario's obstacles and margin.",
)
@click.option(
    "--reserve",
    "reserve_pct",
    type=click.FloatRange(0, 100, max_open=True),
    help="Battery (%% of the usable energy) that must be left on landing; a flight that "
    "needs more exits 2 (default 20; without it, and without vehicle.profile in the "
    "scenario, only a warning).",
)
@handle_errors
def validate_command(file: str, scenario_path: str | None, reserve_pct: float | None) -> None:
    """Check a scenario file, or a mission file against a scenario.

    A scenario is also estimated along its straight route (the least the flight needs), a
    mission along its flight: flight time, energy, battery used and the reserve."""
    checked = validate(file, scenario_path, reserve_pct=reserve_pct)
    warning = getattr(checked, "warning", None)
    if warning:
        click.echo(warning, err=True)
    click.echo(checked.summary())
