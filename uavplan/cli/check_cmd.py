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
@handle_errors
def validate_command(file: str, scenario_path: str | None) -> None:
    """Check a scenario file, or a mission file against a scenario."""
    click.echo(validate(file, scenario_path).summary())
