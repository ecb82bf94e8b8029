"""``uavplan import``: obstacles from an OpenStreetMap or GIS file → an editable map file."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import click

from uavplan.cli import main
from uavplan.cli.common import handle_errors
from uavplan.errors import InputError
from uavplan.limits import MAX_ALTITUDE_M, MAX_HORIZONTAL_M

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


def _floats(text: str, option: str, counts: tuple[int, ...]) -> list[float]:
    try:
        values = [float(v) for v in text.replace(" ", "").split(",")]
    except ValueError:
        raise InputError(f"{option}: expected comma-separated numbers, got {text!r}") from None
    if len(values) not in counts or not all(math.isfinite(v) for v in values):
        want = " or ".join(str(c) for c in counts)
        raise InputError(f"{option}: expected {want} numbers, got {text!r}")
    return values


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
    from uavplan.fileio import atomic_write_text
    from uavplan.geo import EnuFrame, GeoPoint
    from uavplan.obstacles import Bounds
    from uavplan.sources import (
        ObstacleFileSpec,
        SourceError,
        features_extent_lonlat,
        features_to_obstacles,
        read_features,
    )

    if Path(output).suffix.lower() not in (".yaml", ".yml"):
        raise InputError("the map is YAML: name the output *.yaml", file=output)
    option_of = {"layer": "--layer", "height_attribute": "--height-attribute"}
    option_of |= {"default_height": "--default-height", "min_height": "--min-height"}
    result = None
    try:
        spec = ObstacleFileSpec(Path(source), layer, height_attribute, default_height, min_height)
        features, result = read_features(spec)
        if origin is not None:
            o = _floats(origin, "--origin", (2, 3))
            try:
                geo = GeoPoint(o[0], o[1], o[2] if len(o) == 3 else 0.0)
            except ValueError as err:
                raise InputError(f"--origin: {err}") from None
        else:
            west, south, east, north = features_extent_lonlat(features)
            geo = GeoPoint(round((south + north) / 2, 6), round((west + east) / 2, 6), 0.0)
        frame = EnuFrame.at(geo)
        box = None
        if bounds is not None:
            b = _floats(bounds, "--bounds", (4,))
            if not (b[0] < b[1] and b[2] < b[3]):
                raise InputError(f"--bounds: needs XMIN < XMAX and YMIN < YMAX, got {bounds!r}")
            if max(abs(v) for v in b) > MAX_HORIZONTAL_M:
                raise InputError(
                    f"--bounds: every value within ±{MAX_HORIZONTAL_M:,.0f} m of the origin, "
                    f"got {bounds!r}"
                )
            box = Bounds((b[0], b[1]), (b[2], b[3]), (0.0, ceiling))
        features_to_obstacles(features, frame, box, result)
    except SourceError as err:
        if result is not None and (result.skipped or result.kept):
            for line in result.summary_lines():  # what was read, and why it was skipped
                click.echo(line, err=True)
        where = option_of.get(err.key or "", "")
        raise InputError(f"{where + ': ' if where else ''}{err.reason}", file=source) from None
    if not result.obstacles:
        for line in result.summary_lines():
            click.echo(line, err=True)
        raise InputError("no obstacles left to write (see the counts above)", file=source)
    if box is None:
        box = _fitted_bounds(result.obstacles, ceiling)
    text = map_yaml(Path(output).stem, geo, box, result.obstacles, Path(source), spec.is_osm)
    for line in result.summary_lines():
        click.echo(line)
    try:
        atomic_write_text(output, text)
    except OSError as err:
        raise InputError(f"cannot write the map: {err.strerror or err}", file=output) from None
    click.echo(
        f"wrote {output}: {len(result.obstacles)} obstacles, origin "
        f"{geo.lat_deg:.6f},{geo.lon_deg:.6f}"
    )


def _fitted_bounds(obstacles: Any, ceiling: float) -> Any:
    from uavplan.obstacles import Bounds, CylinderObstacle

    xs: list[float] = []
    ys: list[float] = []
    for ob in obstacles:
        if isinstance(ob, CylinderObstacle):
            xs += [ob.center_m[0] - ob.radius_m, ob.center_m[0] + ob.radius_m]
            ys += [ob.center_m[1] - ob.radius_m, ob.center_m[1] + ob.radius_m]
        else:
            xs += [p[0] for p in ob.footprint()]
            ys += [p[1] for p in ob.footprint()]

    def out(lo: float, hi: float) -> tuple[float, float]:
        return (10.0 * math.floor(lo / 10.0) - 10.0, 10.0 * math.ceil(hi / 10.0) + 10.0)

    return Bounds(out(min(xs), max(xs)), out(min(ys), max(ys)), (0.0, ceiling))


def map_yaml(
    name: str, origin: Any, bounds: Any, obstacles: Any, source: Path, is_osm: bool
) -> str:
    """The map file text: a provenance header, origin, bounds and one obstacle per line."""
    from uavplan.obstacles import CylinderObstacle

    def num(v: float) -> str:
        return f"{v:.3f}".rstrip("0").rstrip(".")

    lines = [f"# Imported by `uavplan import` from {source.name}."]
    if is_osm:
        lines.append(
            "# Map data (c) OpenStreetMap contributors, available under the Open Database "
            "License (ODbL 1.0): https://www.openstreetmap.org/copyright"
        )
    lines += [
        f"name: {name}",
        f"origin: {{lat: {origin.lat_deg:.7f}, lon: {origin.lon_deg:.7f}, "
        f"alt: {num(origin.alt_m)}}}",
        f"bounds: {{x: [{num(bounds.x_m[0])}, {num(bounds.x_m[1])}], "
        f"y: [{num(bounds.y_m[0])}, {num(bounds.y_m[1])}], "
        f"z: [{num(bounds.z_m[0])}, {num(bounds.z_m[1])}]}}",
        "obstacles:",
    ]
    for ob in obstacles:
        if isinstance(ob, CylinderObstacle):
            lines.append(
                f"  - {{type: cylinder, center: [{num(ob.center_m[0])}, {num(ob.center_m[1])}], "
                f"radius: {num(ob.radius_m)}, height: {num(ob.height_m)}}}"
            )
        else:
            pts = ", ".join(f"[{num(x)}, {num(y)}]" for x, y in ob.footprint())
            lines.append(f"  - {{type: prism, height: {num(ob.height_m)}, polygon: [{pts}]}}")
    return "\n".join(lines) + "\n"
