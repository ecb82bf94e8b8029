"""``uavplan plan user.plan -o safe.plan [--scenario S]``: reroute a QGroundControl plan
around its exclusion zones (the wiring is :mod:`uavplan.reroute`; this is the thin CLI)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click

from uavplan.cli.common import Progress, check_output_paths, interruptible, show_progress
from uavplan.errors import InputError
from uavplan.fileio import atomic_write_text


def reroute_command(
    plan_path: str,
    output: str,
    *,
    scenario_path: str | None,
    overrides: Any,
    autopilot: str | None,
    report: str | None,
    plot: str | None,
    fence: bool,
    quiet: bool,
) -> None:
    """Read ``plan_path``, reroute it and write ``output`` (a .plan).

    ``overrides(scenario)`` applies the planner options given on the command line.
    """
    from uavplan.mission.io import load_mission, save_mission
    from uavplan.reroute import reroute_plan

    if Path(output).suffix.lower() != ".plan":
        raise InputError(
            "a rerouted QGroundControl plan is written as a .plan (it keeps the fence and "
            "the rally points); name the output *.plan",
            file=output,
        )
    for flag, given in (("--autopilot", autopilot), ("--plot", plot), ("--fence", fence)):
        if given:
            raise InputError(
                f"{flag} does not apply to a .plan input: the plan keeps its own autopilot "
                "flavour and geofence"
            )
    check_output_paths(output, report)
    plan = load_mission(plan_path)
    base = None
    if scenario_path is not None:
        from uavplan.scenario import load_scenario

        base = load_scenario(scenario_path)
    template = overrides(_default_scenario() if base is None else base)
    name = Path(plan_path).stem
    progress = Progress(show_progress(quiet), f"{template.planner.algorithm} {name}")
    with interruptible() as stop_requested:
        try:
            result = reroute_plan(
                plan,
                base=template if base is not None else None,
                planner=template.planner,
                name=name,
                file=plan_path,
                progress=progress,
                should_stop=stop_requested,
            )
        finally:
            progress.close()
    save_mission(result.plan, output)
    if report:
        atomic_write_text(report, json.dumps(result.report(), indent=2) + "\n")
    if not quiet:
        for note in result.notes:
            click.echo(f"note: {note}", err=True)
        click.echo(
            f"{Path(output).name}: {len(result.plan.items)} items "
            f"({result.inserted} planned waypoints added to the plan's "
            f"{len(result.plan.items) - result.inserted}), {result.length_m:.0f} m flown, "
            f"min clearance {result.min_clearance_m:.2f} m "
            f"(margin {result.scenario.safety_margin_m:g} m), planned in "
            f"{result.runtime_s:.2f} s",
            err=True,
        )


def _default_scenario() -> Any:
    """A placeholder scenario carrying only the default planner settings (for overrides)."""
    from uavplan.geo import GeoPoint
    from uavplan.obstacles import Bounds
    from uavplan.scenario import Scenario

    return Scenario(
        name="plan",
        origin=GeoPoint(0.0, 0.0),
        bounds=Bounds((0.0, 1.0), (0.0, 1.0), (0.0, 1.0)),
        start_m=(0.0, 0.0, 1.0),
        goal_m=(1.0, 1.0, 1.0),
        obstacles=(),
    )
