"""``uavplan upload``, ``download``, ``clear`` and ``mock-vehicle``: missions over MAVLink.

Thin: parse the options, call one use case of :mod:`uavplan.app.link` (``mock-vehicle``: the
simulated vehicle of :mod:`uavplan.sim`), print one summary line. Failures of the vehicle or
the link exit 4 with the step that failed; bad files or options exit 2. The MAVLink package
is imported by the use cases when they run, so ``uavplan --help`` stays fast.
"""

from __future__ import annotations

import math
import signal
import threading
from collections.abc import Callable
from typing import Any

import click

from uavplan.app.link import (
    CLEAR_TYPES,
    ClearRequest,
    DownloadRequest,
    LinkOptions,
    UploadRequest,
    clear,
    download,
    upload,
)
from uavplan.cli import main
from uavplan.cli.common import feedback, handle_errors, interruptible
from uavplan.cli.options import ITEM_LIMITS, PARAM
from uavplan.errors import InputError

_CONN_HELP = (
    "connection: udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT, tcpin:HOST:PORT, "
    "DEVICE[,BAUD], or udp:// udpin:// udpout:// tcp:// serial://DEV:BAUD"
)


def _link_options(fn: Callable[..., Any]) -> Callable[..., Any]:
    """--conn, --timeout, --retries, --target-system, --heartbeat-timeout, --quiet."""
    options = [
        click.option("--conn", required=True, metavar="CONN", help=_CONN_HELP),
        click.option(
            "--timeout",
            "timeout_s",
            type=click.FloatRange(min=0.01, max=600),
            default=1.5,
            show_default=True,
            help="Per-step protocol timeout in seconds (QGC's 1.5 by default). A download "
            "item waits 1/6 of it, an upload waits twice it for the vehicle's next request; "
            "re-sends come sooner on a link whose round trip is measured shorter.",
        ),
        click.option(
            "--retries",
            type=click.IntRange(0, 100),
            default=5,
            show_default=True,
            help="Retry budget: a step fails after 1 + N timeouts without an answer.",
        ),
        click.option(
            "--target-system",
            type=click.IntRange(1, 255),
            default=None,
            help="Talk to this system id (default: the first vehicle heard).",
        ),
        click.option(
            "--heartbeat-timeout",
            "heartbeat_timeout_s",
            type=click.FloatRange(min=0.1, max=600),
            default=5.0,
            show_default=True,
            help="How long to wait for the vehicle's HEARTBEAT.",
        ),
        click.option(
            "--source-system",
            type=click.IntRange(1, 255),
            default=255,
            show_default=True,
            help="Our MAVLink system id (255: a ground station).",
        ),
        click.option(
            "--source-component",
            type=click.IntRange(1, 255),
            default=None,
            help="Our MAVLink component id. Default: one drawn per run from 25..99 "
            "(MAV_COMP_ID_USER*), so two ground stations never share an identity; give "
            "190 to look exactly like QGroundControl.",
        ),
        click.option("--quiet", "-q", is_flag=True, help="No progress output."),
    ]
    for option in reversed(options):
        fn = option(fn)
    return fn


def _link(
    conn: str,
    timeout_s: float,
    retries: int,
    target_system: int | None,
    heartbeat_timeout_s: float,
    source_system: int,
    source_component: int | None,
) -> LinkOptions:
    return LinkOptions(
        conn,
        timeout_s,
        retries,
        target_system,
        heartbeat_timeout_s,
        source_system,
        source_component,
    )


@main.command("upload")
@click.argument("mission", type=click.Path(dir_okay=False))
@_link_options
@click.option("--no-verify", is_flag=True, help="Skip the read-back comparison.")
@click.option(
    "--set-params",
    is_flag=True,
    help="First set the vehicle parameters the .plan says the mission relies on (RTL "
    "altitude, fence ceiling, fence on: written by plan), each read back; prints old → new. "
    "Without it a parameter the vehicle holds another value of refuses the upload (exit 4).",
)
@click.option(
    "--accept-vehicle-params",
    is_flag=True,
    help="Keep the vehicle's values of the parameters the mission relies on, once the "
    "flight proven again with them (in --scenario) still keeps the margin.",
)
@click.option(
    "--scenario",
    "scenario_path",
    type=click.Path(dir_okay=False),
    help="The scenario the mission was planned in (for --accept-vehicle-params).",
)
@click.option(
    "--clear",
    "clear_empty",
    is_flag=True,
    help="Allow a mission with no items: uploading it clears the vehicle's mission.",
)
@click.option(
    "--max-items",
    "max_items",
    type=ITEM_LIMITS,
    default=None,
    metavar="M[,F,R]",
    help="The vehicle's storage: M mission items (ArduPilot's home included), and F fence "
    "items and R rally points (default: the flavour's, PX4 500,63,7, ArduPilot 650,70,46).",
)
@handle_errors
def upload_cmd(
    mission: str,
    conn: str,
    timeout_s: float,
    retries: int,
    target_system: int | None,
    heartbeat_timeout_s: float,
    source_system: int,
    source_component: int | None,
    quiet: bool,
    no_verify: bool,
    set_params: bool,
    accept_vehicle_params: bool,
    scenario_path: str | None,
    clear_empty: bool,
    max_items: tuple[int, ...] | None,
) -> None:
    """Upload a .plan / .waypoints MISSION (with the .plan's geofence and rally points).

    First it reads the vehicle parameters the .plan says the mission relies on: one the
    vehicle holds another value of refuses the upload (exit 4) unless --set-params sets it
    or --accept-vehicle-params keeps it (the flight proven again with it in --scenario).
    Succeeds only when the vehicle accepts every plan type and, unless --no-verify, the
    read-back matches item for item. A mission larger than the vehicle's storage, or an
    empty one without --clear, is refused before anything is sent (exit 2).
    """
    if set_params and accept_vehicle_params:
        raise click.UsageError("--set-params and --accept-vehicle-params exclude each other")
    link = _link(
        conn, timeout_s, retries, target_system, heartbeat_timeout_s, source_system,
        source_component,
    )  # fmt: skip
    with interruptible() as interrupts:
        request = UploadRequest(
            mission,
            link,
            not no_verify,
            set_params,
            accept_vehicle_params=accept_vehicle_params,
            scenario=scenario_path,
            clear=clear_empty,
            max_items=max_items,
        )
        outcome = upload(request, feedback(quiet, interrupts))
        for note in outcome.report.notes:
            click.echo(f"note: {note}", err=True)
        for line in outcome.parameter_lines():
            click.echo(line, err=line.startswith("warning:"))
        click.echo(outcome.summary())


@main.command("download")
@_link_options
@click.option(
    "-o",
    "--output",
    "output",
    required=True,
    type=click.Path(dir_okay=False),
    help="Mission file to write (.plan with geofence and rally points, or .waypoints).",
)
@handle_errors
def download_cmd(
    conn: str,
    timeout_s: float,
    retries: int,
    target_system: int | None,
    heartbeat_timeout_s: float,
    source_system: int,
    source_component: int | None,
    quiet: bool,
    output: str,
) -> None:
    """Read the vehicle's mission (and geofence / rally points for a .plan) into a file."""
    link = _link(
        conn, timeout_s, retries, target_system, heartbeat_timeout_s, source_system,
        source_component,
    )  # fmt: skip
    with interruptible() as interrupts:
        outcome = download(DownloadRequest(output, link), feedback(quiet, interrupts))
        for note in outcome.notes:
            click.echo(f"note: {note}", err=True)
        click.echo(outcome.summary())


@main.command("clear")
@_link_options
@click.option(
    "--type",
    "plan_type",
    type=click.Choice(list(CLEAR_TYPES)),
    default="mission",
    show_default=True,
    help="Plan type to clear; 'all' clears the three one after another.",
)
@handle_errors
def clear_cmd(
    conn: str,
    timeout_s: float,
    retries: int,
    target_system: int | None,
    heartbeat_timeout_s: float,
    source_system: int,
    source_component: int | None,
    quiet: bool,
    plan_type: str,
) -> None:
    """Clear the vehicle's mission, geofence, rally points, or all three."""
    link = _link(
        conn, timeout_s, retries, target_system, heartbeat_timeout_s, source_system,
        source_component,
    )  # fmt: skip
    with interruptible() as interrupts:
        outcome = clear(ClearRequest(plan_type, link), feedback(quiet, interrupts))
        click.echo(outcome.summary())


def _parse_home(text: str | None) -> Any:
    if text is None:
        return None
    from uavplan.geo import GeoPoint

    try:
        lat, lon, alt = (float(v) for v in text.split(","))
        return GeoPoint(lat, lon, alt)
    except ValueError as err:
        raise InputError(
            f"expected LAT,LON,ALT in degrees and metres ({err})", key="--home"
        ) from None


def _parse_wind(text: str | None) -> tuple[float, float]:
    if text is None:
        return (0.0, 0.0)
    try:
        east, north = (float(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"expected E,N in m/s, got {text!r}", key="--wind") from None
    if not (math.isfinite(east) and math.isfinite(north)):
        raise InputError(f"the wind must be finite, got {text!r}", key="--wind")
    return (east, north)


@main.command("mock-vehicle")
@click.option("--conn", required=True, metavar="CONN", help=_CONN_HELP)
@click.option(
    "--autopilot",
    type=click.Choice(["px4", "ardupilot"]),
    default="px4",
    show_default=True,
    help="Which firmware to imitate: mission protocol, modes, arming, parameters, flight.",
)
@click.option(
    "--loss",
    type=click.FloatRange(0.0, 1.0),
    default=0.0,
    show_default=True,
    help="Fraction of packets dropped, each way.",
)
@click.option(
    "--duplicate",
    type=click.FloatRange(0.0, 1.0),
    default=0.0,
    show_default=True,
    help="Fraction of packets duplicated, each way.",
)
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the fault RNG.")
@click.option("--system-id", type=click.IntRange(1, 255), default=1, show_default=True)
@click.option(
    "--home",
    metavar="LAT,LON,ALT",
    default=None,
    help="Where the vehicle stands (AMSL metres); ArduPilot returns it as mission seq 0. "
    "Default: the home of --mission, else PX4 SITL's default home.",
)
@click.option(
    "--speedup",
    type=click.FloatRange(min=0.01, max=1000.0),
    default=1.0,
    show_default=True,
    help="Simulated time runs this many times faster than wall time (flight and telemetry; "
    "the mission protocol keeps real time).",
)
@click.option(
    "--wind",
    metavar="E,N",
    default=None,
    help="Wind blowing toward east and north, m/s: it changes the ground speed.",
)
@click.option(
    "--profile",
    "profile_name",
    type=click.Choice(["small-quad", "x500", "heavy-lift"]),
    default="x500",
    show_default=True,
    help="The vehicle whose power model drains the battery (docs/energy.md).",
)
@click.option(
    "--param",
    "param_pairs",
    type=PARAM,
    multiple=True,
    help="Start with this autopilot parameter changed (repeatable; WPNAV_SPEED=500, "
    "MPC_XY_CRUISE=8, RTL_ALT=23000, ...: docs/flight-model.md lists them). Without it the "
    "vehicle holds the firmware's defaults.",
)
@click.option(
    "--firmware-timing",
    is_flag=True,
    help="Re-request missing items at the firmware's interval (PX4 250 ms, ArduPilot 1 s) "
    "instead of adapting to the link's round trip.",
)
@click.option(
    "--mission",
    "preload",
    type=click.Path(dir_okay=False),
    default=None,
    help="Start holding this .plan / .waypoints (mission, fence and rally).",
)
@handle_errors
def mock_vehicle_cmd(
    conn: str,
    autopilot: str,
    loss: float,
    duplicate: float,
    seed: int,
    system_id: int,
    home: str | None,
    speedup: float,
    wind: str | None,
    profile_name: str,
    param_pairs: tuple[tuple[str, float], ...],
    firmware_timing: bool,
    preload: str | None,
) -> None:
    """Run a simulated vehicle on CONN until SIGINT / SIGTERM.

    It speaks MAVLink as PX4 or ArduPilot Copter: heartbeats and telemetry, mission /
    geofence / rally upload, download and clear, parameters, modes and arming, and it flies
    the mission it holds once armed and started (docs/flight-model.md). --loss and
    --duplicate inject packet faults deterministically.
    """
    from uavplan.airframe import resolve
    from uavplan.autopilot.params import ParameterValueError, parameters_from
    from uavplan.autopilot.power import spec_for
    from uavplan.mavlink.transfer import check_plan_fits_wire, plan_wire_items
    from uavplan.mission.io import load_mission
    from uavplan.mission.items import Autopilot, MissionType
    from uavplan.sim.faults import Faults
    from uavplan.sim.mock import MockVehicle
    from uavplan.sim.vehicle import SimConfig

    flavour = Autopilot.from_name(autopilot)
    plan = load_mission(preload) if preload else None
    if plan is not None:
        check_plan_fits_wire(plan, file=preload)
    stand_at = _parse_home(home)
    if stand_at is None and plan is not None:
        stand_at = plan.home
    try:  # the one reading of --param, as simulate's
        params = parameters_from(flavour, param_pairs)
    except ParameterValueError as err:
        raise InputError(str(err), key="--param") from None
    config = SimConfig(
        autopilot=flavour,
        system_id=system_id,
        home=stand_at,
        firmware_timing=firmware_timing,
        faults=Faults(drop_rate=loss, duplicate_rate=duplicate, seed=seed),
        params=dict(params.values),
        speedup=speedup,
        wind_en_m_s=_parse_wind(wind),
        vehicle=spec_for(resolve({"profile": profile_name})),
    )
    vehicle = MockVehicle(conn, config)
    try:
        if plan is not None:
            for mission_type in (MissionType.MISSION, MissionType.FENCE, MissionType.RALLY):
                vehicle.preload(mission_type, plan_wire_items(plan, mission_type, flavour))
        stop = threading.Event()

        def on_signal(signum: int, _frame: object) -> None:
            stop.set()

        previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
        try:
            where = vehicle.connection.description
            faults = (
                f", loss {loss:g}, duplicate {duplicate:g}, seed {seed}"
                if (loss or duplicate)
                else ""
            )
            at = config.standing_at
            extra = f", speedup {speedup:g}" if speedup != 1.0 else ""
            extra += f", {profile_name}"
            if wind:
                extra += f", wind {config.wind_en_m_s[0]:g},{config.wind_en_m_s[1]:g} m/s"
            click.echo(
                f"mock {flavour.label} vehicle, system {system_id}, at "
                f"{at.lat_deg:.7f},{at.lon_deg:.7f},{at.alt_m:.1f}, serving on {where}"
                f"{faults}{extra}; Ctrl-C to stop",
                err=True,
            )
            vehicle.run(stop)
        finally:
            for signum, handler in previous.items():
                signal.signal(signum, handler)
        stats = vehicle.stats()
        click.echo(
            f"mock vehicle stopped: {stats.uploads_accepted} uploads accepted, "
            f"{stats.uploads_failed} failed, {stats.downloads_served} downloads, "
            f"{stats.clears} clears",
            err=True,
        )
    finally:
        vehicle.stop()
