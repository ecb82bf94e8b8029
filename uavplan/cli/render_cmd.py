"""``uavplan render``: parse, call :func:`uavplan.app.render.render`, print.

``render SCENARIO -o FIG.png`` plans the scenario exactly as ``uavplan plan`` would with the
same options (same seed, same route) and draws it; ``--mission FILE`` draws that mission's
route instead and plans nothing; ``--no-plan`` draws the scenario alone.
"""

from __future__ import annotations

import re
from typing import Any

import click

from uavplan.app.feedback import PlannerOptions
from uavplan.app.render import RenderRequest, render
from uavplan.cli import main
from uavplan.cli.common import (
    check_threads_variable,
    exit_interrupted,
    feedback,
    handle_errors,
    interruptible,
    warn,
)
from uavplan.cli.options import ALGORITHM

_SIZE = re.compile(r"^\s*(\d+)\s*[xX×]\s*(\d+)\s*$")


def _parse_size(_ctx: Any, _param: Any, value: str) -> tuple[int, int]:
    match = _SIZE.match(value)
    if not match:
        raise click.BadParameter(f"{value!r} is not WIDTHxHEIGHT in pixels, e.g. 1600x800")
    width, height = int(match.group(1)), int(match.group(2))
    if width < 200 or height < 150 or width > 10000 or height > 10000:
        raise click.BadParameter(f"{width}x{height}: width 200..10000, height 150..10000 px")
    return width, height


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
    "--track",
    "track_path",
    type=click.Path(dir_okay=False),
    help="Also draw this flown track (.csv / .geojson from `simulate --track` or `fly --track`).",
)
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
    track_path: str | None,
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
    if mission_path is not None and (no_plan or algorithm or seed is not None or iterations):
        raise click.UsageError("--mission draws a mission file; it takes no planner options")
    width, height = size
    request = RenderRequest(
        scenario,
        output,
        mission=mission_path,
        no_plan=no_plan,
        options=PlannerOptions(algorithm, seed, iterations, population),
        width_px=width,
        height_px=height,
        dpi=dpi,
        track=track_path,
    )
    check_threads_variable(warn)
    with interruptible() as interrupts:
        outcome = render(request, feedback(quiet, interrupts))
        if outcome.interrupted:
            exit_interrupted()
        if not quiet:
            click.echo(outcome.line(), err=True)
