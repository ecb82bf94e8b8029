"""``uavplan simulate``: parse, call :func:`uavplan.app.simulate.simulate_file`, print."""

from __future__ import annotations

import click

from uavplan.app.simulate import SimulateRequest, simulate_file
from uavplan.cli import main
from uavplan.cli.common import feedback, handle_errors
from uavplan.cli.options import PARAM, WIND


@main.command("simulate")
@click.argument("mission", type=click.Path(dir_okay=False))
@click.option(
    "--scenario",
    "scenario_path",
    type=click.Path(dir_okay=False),
    help="Check the flown track against this scenario's obstacles, terrain and margin "
    "(default: a .plan's own geofence, as `plan` reroutes it).",
)
@click.option(
    "--autopilot",
    type=click.Choice(["px4", "ardupilot"]),
    help="Fly it as this firmware does (default: the file's flavour).",
)
@click.option(
    "--track",
    "track_path",
    type=click.Path(dir_okay=False),
    help="Write the flown track here: .csv (a table) or .geojson (a line).",
)
@click.option(
    "--wind",
    type=WIND,
    default=None,
    help="Wind toward east and north, m/s (default: the scenario's, else none).",
)
@click.option(
    "--param",
    "param_pairs",
    type=PARAM,
    multiple=True,
    help="Fly with this autopilot parameter changed (repeatable; WPNAV_SPEED=500, "
    "RTL_RETURN_ALT=80, ...: docs/flight-model.md lists them).",
)
@click.option(
    "--view",
    "view_path",
    type=click.Path(dir_okay=False),
    help="Also write the interactive page of the flight (HTML, offline; needs --scenario and "
    "the view extra: pip install 'uavplan[view]').",
)
@click.option("--quiet", "-q", is_flag=True, help="No notes, only the result and warnings.")
@handle_errors
def simulate_command(
    mission: str,
    scenario_path: str | None,
    autopilot: str | None,
    track_path: str | None,
    wind: tuple[float, float] | None,
    param_pairs: tuple[tuple[str, float], ...],
    view_path: str | None,
    quiet: bool,
) -> None:
    """Fly MISSION through the flight model, in simulated time, without a vehicle.

    Prints the flight time, the largest deviation from the planned legs and, with a
    scenario (or a .plan's geofence), the flown track's least clearance; exit 3 when the
    track comes closer than the margin. The return to launch is checked apart (a warning).

    \b
    Examples:
      uavplan simulate env1.plan --scenario missions/paper-env1.yaml --track env1.csv
      uavplan simulate env1.plan --autopilot px4 --wind 4,0 --param MPC_XY_CRUISE=8
    """
    request = SimulateRequest(
        mission,
        scenario=scenario_path,
        autopilot=autopilot,
        track=track_path,
        wind_en_m_s=wind,
        params=dict(param_pairs),
        view=view_path,
    )
    outcome = simulate_file(request, feedback(quiet, progress=False))
    click.echo(outcome.summary())
