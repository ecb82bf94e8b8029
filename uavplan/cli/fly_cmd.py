"""``uavplan fly``: parse, call :func:`uavplan.app.fly.fly`, print.

Ctrl-C does not stop the program at once: the first one asks the vehicle to hold (or
``--on-interrupt``), waits until it reports that mode, writes the track and exits 130; a
second one exits at once.
"""

from __future__ import annotations

import click

from uavplan.app.fly import HOME_TOLERANCE_M, ON_INTERRUPT, FlyRequest, fly
from uavplan.cli import main
from uavplan.cli.common import exit_interrupted, feedback, handle_errors, interruptible

_CONN_HELP = (
    "connection: udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT, tcpin:HOST:PORT, "
    "DEVICE[,BAUD], or udp:// udpin:// udpout:// tcp:// serial://DEV:BAUD"
)


def _tolerance(_ctx: object, _param: object, value: str) -> tuple[float, float]:
    try:
        horizontal, vertical = (float(v) for v in value.split(","))
    except ValueError:
        raise click.BadParameter(f"expected H,V in metres, got {value!r}") from None
    if not (horizontal >= 0 and vertical >= 0):
        raise click.BadParameter(f"the tolerances must be >= 0 m, got {value!r}")
    return (horizontal, vertical)


@main.command("fly")
@click.argument("mission", type=click.Path(dir_okay=False))
@click.option("--conn", required=True, metavar="CONN", help=_CONN_HELP)
@click.option(
    "--scenario",
    "scenario_path",
    type=click.Path(dir_okay=False),
    help="Watch the clearance from this scenario's obstacles and terrain while flying.",
)
@click.option(
    "--track",
    "track_path",
    type=click.Path(dir_okay=False),
    help="Write the flown track here: .csv (a table) or .geojson (a line).",
)
@click.option(
    "--upload",
    is_flag=True,
    help="Upload and verify the mission even if the vehicle already holds it.",
)
@click.option(
    "--max-deviation",
    "max_deviation_m",
    type=click.FloatRange(min=0.0),
    default=10.0,
    show_default=True,
    help="Warn when the vehicle is farther than this from the planned legs (m).",
)
@click.option(
    "--on-interrupt",
    type=click.Choice(sorted(ON_INTERRUPT)),
    default="hold",
    show_default=True,
    help="What Ctrl-C asks the vehicle to do: hold (PX4 Hold, ArduPilot BRAKE), rtl, land.",
)
@click.option(
    "--home-tolerance",
    "home_tolerance",
    default=f"{HOME_TOLERANCE_M[0]:g},{HOME_TOLERANCE_M[1]:g}",
    show_default=True,
    callback=_tolerance,
    metavar="H,V",
    help="Refuse to fly when the vehicle's home is farther than H m (horizontally) or V m "
    "(vertically) from the plan's planned home.",
)
@click.option(
    "--set-params",
    is_flag=True,
    help="Before the flight, set the vehicle parameters the .plan says the mission relies "
    "on (RTL altitude, fence, ...), each read back. Without it (or --accept-vehicle-params) "
    "fly refuses a vehicle that holds another value of one (exit 4).",
)
@click.option(
    "--accept-vehicle-params",
    is_flag=True,
    help="Fly with the vehicle's own values of those parameters, once the flight proven "
    "again with them (in --scenario) still keeps the margin; else exit 4.",
)
@click.option(
    "--target-system",
    type=click.IntRange(1, 255),
    default=None,
    help="Fly this system id (default: the first vehicle heard).",
)
@click.option(
    "--heartbeat-timeout",
    "heartbeat_timeout_s",
    type=click.FloatRange(min=0.1, max=600),
    default=5.0,
    show_default=True,
    help="How long to wait for the vehicle's HEARTBEAT.",
)
@click.option(
    "--link-timeout",
    "link_timeout_s",
    type=click.FloatRange(min=0.5, max=600),
    default=5.0,
    show_default=True,
    help="In flight, the link counts as lost after this long without a message (s).",
)
@click.option(
    "--stall-timeout",
    "stall_s",
    type=click.FloatRange(min=5.0, max=3600.0),
    default=60.0,
    show_default=True,
    help="In flight, no progress for this long (the vehicle's seconds) ends the watch: the "
    "vehicle is put into the --on-interrupt mode and fly exits 4.",
)
@click.option(
    "--takeover-wait",
    "takeover_wait_s",
    type=click.FloatRange(min=1.0, max=3600.0),
    default=30.0,
    show_default=True,
    help="A mode fly did not command (another ground station's hold, ...) may last this long "
    "(the vehicle's seconds) before fly stops watching with exit 4.",
)
@click.option("--quiet", "-q", is_flag=True, help="No progress line and no notes.")
@handle_errors
def fly_command(
    mission: str,
    conn: str,
    scenario_path: str | None,
    track_path: str | None,
    upload: bool,
    max_deviation_m: float,
    on_interrupt: str,
    home_tolerance: tuple[float, float],
    set_params: bool,
    accept_vehicle_params: bool,
    target_system: int | None,
    heartbeat_timeout_s: float,
    link_timeout_s: float,
    stall_s: float,
    takeover_wait_s: float,
    quiet: bool,
) -> None:
    """Fly MISSION on the vehicle at CONN: check it, start it, follow it to the landing.

    Before the flight it checks the mission against --scenario as validate does, that the
    vehicle can arm, that its home is the plan's, that it holds the parameters the mission
    relies on (--set-params sets them, --accept-vehicle-params proves the flight with the
    vehicle's) and that it holds this mission (uploading and verifying it if not). It starts
    the mission the way PX4 or ArduPilot expects, shows the progress, the vehicle's warnings
    and every change it did not command, and warns when the vehicle strays from the route or,
    with --scenario, comes closer than the margin. Exit 0: mission complete and landed, the
    whole flight observed and, with --scenario, keeping the margin; 3: the flown track broke
    the margin; 4: the vehicle refused, the link was lost, part of the flight was not
    observed, or something changed behind fly's back; 130: Ctrl-C (the vehicle holds).

    \b
    Examples:
      uavplan fly env1.plan --conn udpout:127.0.0.1:14560 --scenario missions/paper-env1.yaml
      uavplan fly env1.plan --conn udp:127.0.0.1:14540 --track flown.csv --on-interrupt rtl
    """
    if set_params and accept_vehicle_params:
        raise click.UsageError("--set-params and --accept-vehicle-params exclude each other")
    if accept_vehicle_params and scenario_path is None:
        raise click.UsageError(
            "--accept-vehicle-params proves the flight again with the vehicle's parameter "
            "values, in the scenario it was planned for: give --scenario"
        )
    request = FlyRequest(
        mission,
        conn,
        scenario=scenario_path,
        track=track_path,
        upload=upload,
        max_deviation_m=max_deviation_m,
        on_interrupt=on_interrupt,
        home_tolerance_m=home_tolerance,
        set_params=set_params,
        accept_vehicle_params=accept_vehicle_params,
        target_system=target_system,
        heartbeat_timeout_s=heartbeat_timeout_s,
        link_timeout_s=link_timeout_s,
        stall_s=stall_s,
        takeover_wait_s=takeover_wait_s,
    )
    with interruptible() as stop_requested:
        outcome = fly(request, feedback(quiet, stop_requested))
    click.echo(outcome.summary())
    if outcome.interrupted:
        exit_interrupted()
