"""``uavplan render`` (a picture of a scenario and a route) and ``uavplan convert`` (mission
file → another mission format or a map export).

``render SCENARIO -o FIG.png`` plans the scenario exactly as ``uavplan plan`` would with the
same options (same seed, same route) and draws it; ``--mission FILE`` draws that mission's
route instead and plans nothing; ``--no-plan`` draws the scenario alone.
"""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path
from typing import Any

import click

from uavplan.cli import main
from uavplan.cli.common import (
    Progress,
    check_output_paths,
    handle_errors,
    interruptible,
    show_progress,
)
from uavplan.cli.options import ALGORITHM
from uavplan.errors import InputError, NoPathError

_SIZE = re.compile(r"^\s*(\d+)\s*[xX×]\s*(\d+)\s*$")


def _parse_size(_ctx: Any, _param: Any, value: str) -> tuple[int, int]:
    match = _SIZE.match(value)
    if not match:
        raise click.BadParameter(f"{value!r} is not WIDTHxHEIGHT in pixels, e.g. 1600x800")
    width, height = int(match.group(1)), int(match.group(2))
    if width < 200 or height < 150 or width > 10000 or height > 10000:
        raise click.BadParameter(f"{width}x{height}: width 200..10000, height 150..10000 px")
    return width, height


def _require_png(path: str, option: str) -> None:
    if Path(path).suffix.lower() != ".png":
        raise InputError(f"{option} writes a PNG picture; name the file *.png", file=path)


@main.command("render")
@click.argument("scenario", type=click.Path(dir_okay=False))
@click.option(
    "-o", "--output", required=True, type=click.Path(dir_okay=False), help="PNG file to write."
)
@click.option(
    "--mission",
    "mission_path",
    type=click.Path(dir_okay=False),
    help="Draw this mission file's route (.plan, .waypoints) instead of planning.",
)
@click.option("--no-plan", is_flag=True, help="Draw the scenario alone, without a route.")
@click.option(
    "--algorithm",
    type=ALGORITHM,
    help="Planner (default: the scenario's, else spsa).",
)
@click.option("--seed", type=click.IntRange(min=0), help="Random seed (default: the scenario's).")
@click.option(
    "--iterations", type=click.IntRange(min=1), help="Iterations (fewer: quicker, rougher)."
)
@click.option("--population", type=click.IntRange(min=4), help="Population size.")
@click.option(
    "--size",
    default="1600x800",
    show_default=True,
    callback=_parse_size,
    help="Picture size in pixels, WIDTHxHEIGHT.",
)
@click.option(
    "--dpi", type=click.IntRange(30, 600), default=100, show_default=True, help="Resolution."
)
@click.option("--quiet", "-q", is_flag=True, help="No progress output.")
@handle_errors
def render_command(
    scenario: str,
    output: str,
    mission_path: str | None,
    no_plan: bool,
    algorithm: str | None,
    seed: int | None,
    iterations: int | None,
    population: int | None,
    size: tuple[int, int],
    dpi: int,
    quiet: bool,
) -> None:
    """Draw SCENARIO in 3-D and from above, with a planned route or a mission's route.

    Without --mission it plans first, exactly as `uavplan plan` does with the same options,
    and draws the raw best path, the smoothed path and the mission waypoints.
    """
    from uavplan.scenario import load_scenario

    _require_png(output, "render")
    check_output_paths(output)
    if mission_path is not None and (no_plan or algorithm or seed is not None or iterations):
        raise click.UsageError("--mission draws a mission file; it takes no planner options")
    scn = load_scenario(scenario)
    width, height = size
    picture: dict[str, Any] = {"width_px": width, "height_px": height, "dpi": dpi}
    if mission_path is not None:
        summary = _render_mission(scn, mission_path, output, picture)
    elif no_plan:
        from uavplan.planning import scene_for
        from uavplan.render import render_scene

        render_scene(scene_for(scn), output, subtitle=_scenario_line(scn), **picture)
        summary = "scenario only"
    else:
        summary = _render_planned(
            scn, output, picture, algorithm, seed, iterations, population, quiet
        )
    if not quiet:
        click.echo(f"{Path(output).name}: {width}x{height} px, {summary}", err=True)


def _scenario_line(scn: Any) -> str:
    return (
        f"{len(scn.obstacles)} obstacles, safety margin {scn.safety_margin_m:g} m, "
        f"start {list(scn.start_m)}, goal {list(scn.goal_m)}"
    )


def _render_mission(scn: Any, mission_path: str, output: str, picture: dict[str, Any]) -> str:
    import numpy as np

    from uavplan.mission.io import load_mission
    from uavplan.planning import build_world, enu_frame, scene_for
    from uavplan.render import RouteLayers, render_scene
    from uavplan.route import keeps_margin

    plan = load_mission(mission_path)
    try:
        layers = RouteLayers.from_mission(plan, enu_frame(scn))
    except ValueError as err:
        raise InputError(str(err), file=mission_path) from None
    flown = layers.flown_enu
    assert flown is not None
    name = Path(mission_path).name
    if len(flown) < 2:
        subtitle = f"{name}: {len(plan.items)} items, nothing to fly"
    else:
        length = float(np.linalg.norm(np.diff(flown, axis=0), axis=1).sum())
        subtitle = f"{name}: {len(plan.items)} items, {length:.0f} m flown"
        if scn.obstacles:
            clearance = build_world(scn).polyline_clearance(flown)
            close = not keeps_margin(clearance, scn.safety_margin_m)
            subtitle += f", min clearance {clearance:.2f} m (margin {scn.safety_margin_m:g} m)" + (
                "  (closer than the margin!)" if close else ""
            )
    render_scene(scene_for(scn), output, layers, subtitle=subtitle, **picture)
    return subtitle


def _render_planned(
    scn: Any,
    output: str,
    picture: dict[str, Any],
    algorithm: str | None,
    seed: int | None,
    iterations: int | None,
    population: int | None,
    quiet: bool,
) -> str:
    from uavplan.cli.plan_cmd import overridden, require_route
    from uavplan.planning import RouteStatus, plan_route, scene_for
    from uavplan.render import RouteLayers, render_scene, route_subtitle

    scn = overridden(scn, algorithm, seed, iterations, population)
    progress = Progress(show_progress(quiet), f"{scn.planner.algorithm} {scn.name}")
    with interruptible() as stop_requested:
        try:
            result = plan_route(scn, progress=progress, should_stop=stop_requested)
        finally:
            progress.close()
    if result.status is RouteStatus.NO_PATH:
        render_scene(
            scene_for(scn), output, subtitle=f"no collision-free path: {result.message}", **picture
        )
        raise NoPathError(
            f"{scn.name}: no collision-free path: {result.message} (drew the scenario alone "
            f"in {output})"
        )
    subtitle = ""
    if result.route is not None:  # drawn even when it comes too close: the picture shows where
        subtitle = route_subtitle(
            result.route, algorithm=result.algorithm, seed=result.seed, energy=result.energy
        )
        layers = RouteLayers.from_route(result.route)
        render_scene(scene_for(scn), output, layers, subtitle=subtitle, **picture)
    require_route(scn, result)  # interrupted: exit 130; closer than the margin: exit 3
    return subtitle


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
    from uavplan.mission.io import format_for, load_mission, save_mission
    from uavplan.mission.items import Autopilot, GeoFence

    out_format = format_for(output)  # an unknown extension fails before reading anything
    plan = load_mission(input_path, Autopilot.from_name(autopilot) if autopilot else None)
    notes = []
    if out_format.dumps_extras is None and out_format.loads is not None:
        if Path(output).suffix.lower() != ".plan" and (not plan.fence.is_empty or plan.rally):
            notes.append(f"{Path(output).suffix} holds no geofence or rally points; left out")
            plan = replace(plan, fence=GeoFence(), rally=())
    extras = None
    if scenario_path is not None:
        from uavplan.planning import export_extras
        from uavplan.scenario import load_scenario

        if out_format.dumps_extras is None:
            raise click.UsageError("--scenario only adds obstacles to a .geojson or .kml")
        extras = export_extras(load_scenario(scenario_path))
    save_mission(plan, output, extras=extras)
    for note in notes:
        click.echo(f"note: {note}", err=True)
    if not quiet:
        click.echo(
            f"{Path(output).name}: {len(plan.items)} mission items from {Path(input_path).name} "
            f"({out_format.name})",
            err=True,
        )
