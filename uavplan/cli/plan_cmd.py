"""``uavplan plan`` and ``uavplan validate``: thin wiring of scenario → planner → mission file."""

from __future__ import annotations

import json
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


def _load_scenario(path: str):
    from uavplan.scenario import load_scenario

    return load_scenario(path)


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
    if scenario.lower().endswith(".plan"):
        from uavplan.cli.reroute_cmd import reroute_command

        def _overrides(scn: Any) -> Any:
            return overridden(scn, algorithm, seed, iterations, population)

        reroute_command(
            scenario, output, scenario_path=scenario_path, overrides=_overrides,
            autopilot=autopilot, report=report, plot=plot, fence=fence, quiet=quiet,
        )  # fmt: skip
        return
    if scenario_path is not None:
        raise InputError("--scenario goes with a .plan input (the SCENARIO argument is one)")
    from uavplan.planning import plan_route

    _check_outputs(output, report, plot, fence)
    # the mission writer's geodetic library loads on another core while the search runs
    from uavplan.geo import import_in_background

    import_in_background()
    scn = overridden(_load_scenario(scenario), algorithm, seed, iterations, population)
    if autopilot:
        from uavplan.mission.items import Autopilot

        scn = replace(scn, mission=replace(scn.mission, autopilot=Autopilot.from_name(autopilot)))
    if scn.mission.altitude == "terrain" and scn.mission.autopilot.name == "PX4":
        click.echo(
            "warning: mission.altitude terrain writes MAV_FRAME_GLOBAL_TERRAIN_ALT items, "
            "which PX4 missions do not fly (ArduPilot does); use relative or amsl for PX4",
            err=True,
        )
    progress = Progress(show_progress(quiet), f"{scn.planner.algorithm} {scn.name}")
    with interruptible() as stop_requested:
        if not quiet:
            search = scn.planner.search
            budget = f"{search.iterations} iterations"
            if search.stall_iterations is not None:
                again = search.restart_stall_iterations
                budget = (
                    f"at most {search.iterations} iterations, stopping after "
                    f"{search.stall_iterations} without improvement"
                    + ("" if again is None else f" ({again} in a restart)")
                )
            click.echo(
                f"planning {scn.name} with {scn.planner.algorithm} (population "
                f"{search.population}, {budget}, seed {search.seed}); Ctrl-C stops",
                err=True,
            )
        try:
            result = plan_route(scn, progress=progress, should_stop=stop_requested)
        finally:
            progress.close()
    if report:
        from uavplan.fileio import atomic_write_text

        atomic_write_text(report, json.dumps(result.report(scn), indent=2) + "\n")
    route = require_route(scn, result)
    if not quiet:
        for note in result.notes:
            click.echo(f"note: {note}", err=True)
    mission, built = _write_mission(scn, result, route, output, fence, quiet)
    if plot:
        from uavplan.planning import scene_for
        from uavplan.render import RouteLayers, render_scene, route_subtitle

        subtitle = route_subtitle(
            route, algorithm=result.algorithm, seed=result.seed, energy=result.energy
        )
        render_scene(scene_for(scn), plot, RouteLayers.from_route(route, built), subtitle=subtitle)
    if not quiet:
        e_path, e_turn, e_climb = result.energy_terms
        click.echo(
            f"{Path(output).name}: {len(mission.items)} items, {route.waypoints_enu.shape[0]} "
            f"waypoints, {route.length_m:.0f} m, energy {result.energy:.1f} "
            f"(path {e_path:.1f}, turning {e_turn:.2f}, climb {e_climb:.1f}), "
            f"min clearance {route.min_clearance_m:.2f} m, planned in {result.runtime_s:.2f} s",
            err=True,
        )


def _check_outputs(output: str, report: str | None, plot: str | None, fence: bool) -> None:
    """Everything about the outputs that can fail, checked before any planning."""
    from uavplan.mission.io import format_for

    out_format = format_for(output)  # fail on an unknown extension before planning
    if plot and Path(plot).suffix.lower() != ".png":
        raise InputError("--plot writes a PNG picture; name the file *.png", file=plot)
    if fence and out_format.dumps_extras is None and Path(output).suffix.lower() != ".plan":
        raise InputError("a geofence needs a .plan (or .geojson / .kml) output", file=output)
    check_output_paths(output, report, plot)


def overridden(
    scn: Any,
    algorithm: str | None,
    seed: int | None,
    iterations: int | None,
    population: int | None,
) -> Any:
    """The scenario with the planner options given on the command line (validated like the
    scenario's own values, and the size limits checked again). ``--iterations`` forces that
    many iterations: no early stop."""
    from uavplan.scenario import with_search

    for option, value in (
        ("--seed", seed),
        ("--iterations", iterations),
        ("--population", population),
    ):
        scn = with_search(scn, {option.lstrip("-"): value}, option)
    if iterations is not None:
        scn = scn.with_planner(search=replace(scn.planner.search, stall_iterations=None))
    if algorithm:
        scn = scn.with_planner(algorithm=algorithm)
    return scn


def require_route(scn: Any, result: Any) -> Any:
    """The planned route, or the error that says why there is none (exit 3 / 130)."""
    from uavplan.planning import RouteStatus

    if result.status is RouteStatus.INTERRUPTED:
        raise KeyboardInterrupt
    if not result.ok:
        raise NoPathError(f"{scn.name}: no collision-free path: {result.message}")
    if not result.collision_free:
        raise NoPathError(
            f"{scn.name}: the route comes within {result.min_clearance_m:.2f} m of an obstacle "
            f"(safety margin {scn.safety_margin_m:g} m)"
        )
    return result.route


def _write_mission(
    scn: Any, result: Any, route: Any, output: str, fence: bool, quiet: bool
) -> tuple[Any, Any]:
    """Build the mission, add the geofence if asked and write ``output`` (its format from the
    extension): (the mission, the fence build or None)."""
    from uavplan.mission.io import save_mission
    from uavplan.planning import export_extras, fence_for, mission_for

    mission, built = mission_for(scn, route), None
    if fence:
        mission, built = fence_for(scn, route, mission)
        if not quiet:
            for line in (built.summary(), *(f"note: {n}" for n in built.notes())):
                click.echo(line, err=True)
    summary = {"algorithm": result.algorithm, "seed": result.seed, "energy": result.energy}
    save_mission(mission, output, extras=lambda: export_extras(scn, route, summary))
    return mission, built


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
    if scenario_path is None:
        scn = _load_scenario(file)
        click.echo(
            f"{file}: ok — {scn.name}, {len(scn.obstacles)} obstacles, "
            f"margin {scn.safety_margin_m:g} m"
        )
        return
    import numpy as np

    from uavplan.mission.builder import mission_polyline_enu
    from uavplan.mission.io import load_mission
    from uavplan.planning import build_world, enu_frame
    from uavplan.route import keeps_margin

    scn = _load_scenario(scenario_path)
    plan = load_mission(file)
    frame = enu_frame(scn)
    try:
        poly = mission_polyline_enu(plan, frame)
    except ValueError as err:
        raise InputError(str(err), file=file) from None
    if poly.shape[0] < 2:
        raise InputError("the mission has fewer than two positions to fly", file=file)
    world = build_world(scn)
    dist, which = world.segments_clearance(poly[:-1], poly[1:])
    worst = int(np.argmin(dist))
    inside = world.points_inside_bounds(poly, tol_m=0.05)  # files round to ~1 cm
    if not inside.all():
        k = int(np.flatnonzero(~inside)[0])
        raise NoPathError(
            f"{file}: point {k} of the flown path {poly[k].round(1).tolist()} is outside the "
            "scenario bounds"
        )
    if not keeps_margin(float(dist[worst]), scn.safety_margin_m):
        raise NoPathError(
            f"{file}: leg {worst} of the flown path comes within {dist[worst]:.2f} m of "
            f"obstacles[{which[worst]}] (safety margin {scn.safety_margin_m:g} m)"
        )
    click.echo(
        f"{file}: ok — {len(plan.items)} items, min clearance {dist.min():.2f} m "
        f"(margin {scn.safety_margin_m:g} m)"
    )
