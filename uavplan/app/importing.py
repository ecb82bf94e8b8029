"""``import``: buildings and tall structures from an OpenStreetMap or GIS file → an editable
map file (YAML) that a scenario names with ``map:``."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from uavplan.app.feedback import Feedback
from uavplan.app.outputs import OutputSet
from uavplan.errors import InputError
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.limits import MAX_HORIZONTAL_M
from uavplan.obstacles import Bounds, CylinderObstacle, Obstacle
from uavplan.sources import (
    ImportResult,
    ObstacleFileSpec,
    SourceError,
    features_extent_lonlat,
    features_to_obstacles,
    read_features,
)


@dataclass(frozen=True)
class ImportRequest:
    """``uavplan import SOURCE -o OUTPUT``; ``origin`` ``LAT,LON[,ALT]`` and ``bounds``
    ``XMIN,XMAX,YMIN,YMAX`` as given on the command line (None: from the data)."""

    source: str
    output: str
    origin: str | None = None
    bounds: str | None = None
    ceiling_m: float = 120.0
    layer: str | None = None
    height_attribute: str | None = None
    default_height_m: float = 10.0
    min_height_m: float | None = None


@dataclass(frozen=True, eq=False)
class ImportOutcome:
    """What was read (``result``: counts of kept and skipped features) and written."""

    output: str
    origin: GeoPoint
    result: ImportResult

    def summary(self) -> str:
        return (
            f"wrote {self.output}: {len(self.result.obstacles)} obstacles, origin "
            f"{self.origin.lat_deg:.6f},{self.origin.lon_deg:.6f}"
        )


#: the option that sets each of the reader's keys (for messages)
_OPTION_OF = {
    "layer": "--layer",
    "height_attribute": "--height-attribute",
    "default_height": "--default-height",
    "min_height": "--min-height",
}


def import_map(request: ImportRequest, feedback: Feedback | None = None) -> ImportOutcome:
    """Read the source, convert its features to obstacles in the map's ENU frame and write
    the map (checked before the source is read; written whole or not at all)."""
    source, output = request.source, request.output
    if Path(output).suffix.lower() not in (".yaml", ".yml"):
        raise InputError("the map is YAML: name the output *.yaml", file=output)
    outputs = OutputSet(None if feedback is None else feedback.interrupts)
    outputs.reads(source, role="the file to import")
    map_file = outputs.file(output)
    outputs.check()
    result: ImportResult | None = None
    try:
        spec = ObstacleFileSpec(
            Path(source),
            request.layer,
            request.height_attribute,
            request.default_height_m,
            request.min_height_m,
        )
        features, result = read_features(spec)
        if request.origin is not None:
            o = _floats(request.origin, "--origin", (2, 3))
            try:
                geo = GeoPoint(o[0], o[1], o[2] if len(o) == 3 else 0.0)
            except ValueError as err:
                raise InputError(f"--origin: {err}") from None
        else:
            west, south, east, north = features_extent_lonlat(features)
            geo = GeoPoint(round((south + north) / 2, 6), round((west + east) / 2, 6), 0.0)
        frame = EnuFrame.at(geo)
        box = None
        if request.bounds is not None:
            b = _floats(request.bounds, "--bounds", (4,))
            if not (b[0] < b[1] and b[2] < b[3]):
                raise InputError(
                    f"--bounds: needs XMIN < XMAX and YMIN < YMAX, got {request.bounds!r}"
                )
            if max(abs(v) for v in b) > MAX_HORIZONTAL_M:
                raise InputError(
                    f"--bounds: every value within ±{MAX_HORIZONTAL_M:,.0f} m of the origin, "
                    f"got {request.bounds!r}"
                )
            box = Bounds((b[0], b[1]), (b[2], b[3]), (0.0, request.ceiling_m))
        features_to_obstacles(features, frame, box, result)
    except SourceError as err:
        where = _OPTION_OF.get(err.key or "", "")
        counts = f" ({_skipped(result)})" if result is not None and result.skipped else ""
        raise InputError(
            f"{where + ': ' if where else ''}{err.reason}{counts}", file=source
        ) from None
    if not result.obstacles:
        raise InputError(f"no obstacles left to write ({_skipped(result)})", file=source)
    if box is None:
        box = _fitted_bounds(result.obstacles, request.ceiling_m)
    text = map_yaml(Path(output).stem, geo, box, result.obstacles, Path(source), spec.is_osm)
    with outputs:
        map_file.write_text(text)
        outputs.commit()
    return ImportOutcome(output, geo, result)


def _skipped(result: ImportResult) -> str:
    """What was read and why it was left out, in one line for a message."""
    read = sum(result.kept.values()) + sum(result.skipped.values())
    reasons = ", ".join(
        f"{n} {reason}" for reason, n in sorted(result.skipped.items(), key=lambda kv: -kv[1])
    )
    return f"{read} features read; skipped: {reasons or 'none'}"


def _floats(text: str, option: str, counts: tuple[int, ...]) -> list[float]:
    try:
        values = [float(v) for v in text.replace(" ", "").split(",")]
    except ValueError:
        raise InputError(f"{option}: expected comma-separated numbers, got {text!r}") from None
    if len(values) not in counts or not all(math.isfinite(v) for v in values):
        want = " or ".join(str(c) for c in counts)
        raise InputError(f"{option}: expected {want} numbers, got {text!r}")
    return values


def _fitted_bounds(obstacles: Sequence[Obstacle], ceiling: float) -> Bounds:
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
    name: str,
    origin: GeoPoint,
    bounds: Bounds,
    obstacles: Sequence[Obstacle],
    source: Path,
    is_osm: bool,
) -> str:
    """The map file text: a provenance header, origin, bounds and one obstacle per line."""

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
