"""``uavplan import``: parse, call :func:`uavplan.app.importing.import_map`, print."""

from __future__ import annotations

import math

import click

from uavplan.app.importing import ImportRequest, import_map
from uavplan.cli import main
from uavplan.cli.common import feedback, handle_errors, interruptible
from uavplan.limits import MAX_ALTITUDE_M

_EPILOG = """\b
Examples:
  uavplan import town.osm.pbf -o maps/town.yaml
  uavplan import town.osm.pbf -o maps/town.yaml --origin 60.1699,24.9384 \\
      --bounds -400,400,-300,300 --ceiling 120
  uavplan import blocks.gpkg --layer buildings --height-attribute HEIGHT_M \\
      --default-height 8 -o maps/blocks.yaml

The map keeps origin, bounds and every obstacle as plain YAML (prisms and cylinders) for
editing; a scenario names it with `map:`. To keep the source file as the truth instead, name
it in the scenario with `obstacle_files: [{file: town.osm.pbf}]`.
"""


def _finite(value: float, option: str) -> float:
    if not math.isfinite(value):  # click's FloatRange lets NaN through
        raise click.BadParameter(f"{value!r} is not a number", param_hint=option)
    return value


@main.command("import", epilog=_EPILOG)
@click.argument("source", type=click.Path(dir_okay=False))
@click.option(
    "-o", "--output", required=True, type=click.Path(dir_okay=False), help="Map file to write."
)
@click.option(
    "--origin",
    help="LAT,LON[,ALT] of the map's ENU origin (default: the centre of the data, alt 0).",
)
@click.option(
    "--bounds",
    help="XMIN,XMAX,YMIN,YMAX in metres around the origin: keep obstacles within 50 m of "
    "this box, clipped (default: everything, bounds fitted around it).",
)
@click.option(
    "--ceiling",
    type=click.FloatRange(min=0, min_open=True, max=MAX_ALTITUDE_M),
    callback=lambda _ctx, _param, value: _finite(value, "--ceiling"),
    default=120.0,
    show_default=True,
    help="Top of the map's bounds (bounds.z), metres above the ground.",
)
@click.option("--layer", help="Layer of a multi-layer GIS file (default: the first).")
@click.option("--height-attribute", help="GIS attribute holding heights (m, or '40 ft').")
@click.option(
    "--default-height",
    type=float,
    default=10.0,
    show_default=True,
    help="Height of features with no height information (metres).",
)
@click.option("--min-height", type=float, help="Base height of every feature (metres).")
@handle_errors
def import_command(
    source: str,
    output: str,
    origin: str | None,
    bounds: str | None,
    ceiling: float,
    layer: str | None,
    height_attribute: str | None,
    default_height: float,
    min_height: float | None,
) -> None:
    """Read buildings and tall structures from SOURCE (.osm, .osm.pbf, GeoJSON, GeoPackage,
    Shapefile, KML, ...) and write them as an editable map file (YAML)."""
    request = ImportRequest(
        source,
        output,
        origin=origin,
        bounds=bounds,
        ceiling_m=ceiling,
        layer=layer,
        height_attribute=height_attribute,
        default_height_m=default_height,
        min_height_m=min_height,
    )
    with interruptible() as interrupts:
        outcome = import_map(request, feedback(False, interrupts, progress=False))
        for line in outcome.result.summary_lines():
            click.echo(line)
        click.echo(outcome.summary())
