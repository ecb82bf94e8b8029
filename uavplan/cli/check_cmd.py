"""``uavplan validate``: parse, call :func:`uavplan.app.check.validate`, print."""

from __future__ import annotations

import click

from uavplan.app.check import ScenarioCheck, validate
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
    "needs more exits 2 (default 20).",
)
@click.option(
    "--allow-over-battery",
    is_flag=True,
    help="A flight over the usable battery minus the reserve is a warning, not exit 2.",
)
@handle_errors
def validate_command(
    file: str, scenario_path: str | None, reserve_pct: float | None, allow_over_battery: bool
) -> None:
    """Check a scenario file, or a mission file against a scenario.

    A mission is checked by its straight legs and by its whole flight as the autopilot
    flies it (the flight model, with the parameters the mission relies on: take-off to
    touchdown, the return to launch included): exit 3 when either comes closer than the
    margin or leaves the flight volume; a failsafe return from some point that would is a
    warning. A scenario is also estimated along its straight route (the least the flight
    needs), a mission along its flight: flight time, energy, battery used and the reserve."""
    checked = validate(
        file, scenario_path, reserve_pct=reserve_pct, allow_over_battery=allow_over_battery
    )
    if isinstance(checked, ScenarioCheck):
        if checked.warning:
            click.echo(checked.warning, err=True)
    else:
        for line in checked.warnings:
            click.echo(line, err=True)
    click.echo(checked.summary())
