"""What every obstacle reader shares: the file entry, errors, heights, and footprint → solid.

Readers (:mod:`~uavplan.sources.osm`, :mod:`~uavplan.sources.vector`) turn a file into
:class:`Feature` values (a shapely footprint in longitude/latitude degrees, a height, where the
height came from) and count what they skip and why. :func:`features_to_obstacles` then does the
geometry every source needs, in this order:

1. longitude/latitude → the scenario's ENU metres (:meth:`uavplan.geo.EnuFrame.to_enu_xy`);
2. repair (``shapely.make_valid``) and clip to the bounds grown by :data:`CLIP_PAD_M`
   (an obstacle just outside the flight box still matters to the safety margin);
3. conservative simplification of footprints with many vertices: grow by
   :data:`SIMPLIFY_TOLERANCE_M`, then Douglas-Peucker by the same tolerance, and keep the result
   only if it *covers* the original footprint (checked with ``shapely.covers``), else keep the
   original;
4. holes (courtyards) are **kept**: a polygon with holes is cut by vertical lines through its
   holes until no piece has a hole; the pieces tile the polygon exactly, so their union is the
   original footprint (``test_sources_geometry`` checks it);
5. each hole-free piece becomes a :class:`~uavplan.obstacles.PrismObstacle` (counter-clockwise,
   without the closing point, vertices rounded to 1 mm as a map file stores them; a piece
   whose rounded outline is not simple, being pinched thinner than a millimetre somewhere, is
   replaced by its convex hull, which contains it); point features become
   :class:`~uavplan.obstacles.CylinderObstacle` values.

Our obstacles stand on the ground (z = 0). A feature whose base is lifted (OSM ``min_height``,
``building:min_level``, or an entry's ``min_height``) is still modelled down to the ground:
conservative, and counted in the report as ``base lifted: modelled down to the ground``.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from uavplan.errors import InputError
from uavplan.limits import MAX_ALTITUDE_M, MAX_HORIZONTAL_M, MAX_OBSTACLES, MAX_POLYGON_VERTICES
from uavplan.obstacles import Bounds, CylinderObstacle, Obstacle, PrismObstacle

if TYPE_CHECKING:
    from shapely.geometry.base import BaseGeometry

    from uavplan.geo import EnuFrame

#: height of a feature with no usable height information (metres)
DEFAULT_HEIGHT_M = 10.0
#: height of one storey when only ``building:levels`` is known (metres)
LEVEL_HEIGHT_M = 3.0
#: obstacles are kept when they reach within this distance of the bounds (metres)
CLIP_PAD_M = 50.0
#: footprints with more vertices than this are simplified (conservatively)
SIMPLIFY_MIN_VERTICES = 16
#: growth and Douglas-Peucker tolerance of the conservative simplification (metres)
SIMPLIFY_TOLERANCE_M = 0.5
#: footprints smaller than this after clipping are dropped (m²): slivers, not buildings
MIN_AREA_M2 = 0.5
#: pieces of a courtyard split smaller than this are numerical slivers and dropped (m²)
MIN_PIECE_AREA_M2 = 1e-4

OSM_SUFFIXES = (".osm", ".osm.pbf", ".pbf", ".osm.bz2", ".osm.gz", ".o5m", ".opl")


class SourceError(InputError):
    """A data file or its entry is unusable. ``key`` is the entry key at fault
    (``file``, ``layer``, ``height_attribute``, ...), ``index`` the entry's position."""

    def __init__(
        self,
        reason: str,
        *,
        file: str | None = None,
        key: str | None = None,
        index: int | None = None,
    ) -> None:
        self.index = index
        super().__init__(reason, file=file, key=key)

    def key_path(self, list_key: str = "obstacle_files") -> str:
        """``obstacle_files[1].layer`` for the entry at fault."""
        head = f"{list_key}[{self.index}]" if self.index is not None else list_key
        return f"{head}.{self.key}" if self.key else head


@dataclass(frozen=True)
class ObstacleFileSpec:
    """One ``obstacle_files`` entry. ``path`` is resolved (absolute or relative to the cwd)."""

    path: Path
    layer: str | None = None
    height_attribute: str | None = None
    default_height_m: float = DEFAULT_HEIGHT_M
    min_height_m: float | None = None  # a base for every feature of the file (metres)

    def __post_init__(self) -> None:
        default = self.default_height_m
        if not (math.isfinite(default) and 0 < default <= MAX_ALTITUDE_M):
            raise SourceError(
                f"must be a number > 0 and <= {MAX_ALTITUDE_M:g}, got {self.default_height_m!r}",
                key="default_height",
            )
        if self.min_height_m is not None and not (
            math.isfinite(self.min_height_m) and 0 <= self.min_height_m <= MAX_ALTITUDE_M
        ):
            raise SourceError(
                f"must be a number >= 0 and <= {MAX_ALTITUDE_M:g}, got {self.min_height_m!r}",
                key="min_height",
            )

    @property
    def is_osm(self) -> bool:
        name = self.path.name.lower()
        return name.endswith(OSM_SUFFIXES)

    @classmethod
    def from_mapping(cls, raw: Any, base_dir: Path) -> ObstacleFileSpec:
        """Check one entry as written in a scenario or map (keys as the user spells them)."""
        if isinstance(raw, str):
            raw = {"file": raw}
        if not isinstance(raw, Mapping):
            raise SourceError(f"must be a mapping with a 'file' key, got {type(raw).__name__}")
        allowed = {"file", "layer", "height_attribute", "default_height", "min_height"}
        for k in raw:
            if k not in allowed:
                raise SourceError(f"unknown key (allowed: {', '.join(sorted(allowed))})", key=k)
        if "file" not in raw:
            raise SourceError("missing required key", key="file")
        file = raw["file"]
        if not isinstance(file, str) or not file:
            raise SourceError("must be a file name", key="file")
        layer = raw.get("layer")
        if layer is not None and not isinstance(layer, str | int):
            raise SourceError("must be a layer name", key="layer")
        attr = raw.get("height_attribute")
        if attr is not None and not isinstance(attr, str):
            raise SourceError("must be an attribute name", key="height_attribute")
        default = _number(raw.get("default_height", DEFAULT_HEIGHT_M), "default_height")
        min_h = raw.get("min_height")
        min_height = None if min_h is None else _number(min_h, "min_height")
        path = Path(file).expanduser()
        if not path.is_absolute():
            path = (base_dir / path).resolve()
        return cls(path, None if layer is None else str(layer), attr, default, min_height)


def _number(value: Any, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SourceError(f"must be a number, got {value!r}", key=key)
    return float(value)


@dataclass
class Feature:
    """A footprint in longitude/latitude degrees (shapely), its height and provenance."""

    geometry: BaseGeometry
    height_m: float
    height_source: str  # "height", "levels", "attribute", "default"
    kind: str  # "building", "tower", ...
    base_m: float = 0.0
    radius_m: float | None = None  # point features only


@dataclass
class ImportResult:
    """Obstacles read from one file, with what was kept, skipped and why.

    ``kept`` counts source features by kind, ``skipped`` by reason, ``notes`` counts things
    the reader did to kept features (a default height, a lifted base modelled to the ground,
    a courtyard split, a simplified outline).
    """

    path: Path
    obstacles: tuple[Obstacle, ...] = ()
    kept: Counter[str] = field(default_factory=Counter)
    skipped: Counter[str] = field(default_factory=Counter)
    notes: Counter[str] = field(default_factory=Counter)
    seconds: float = 0.0

    def summary_lines(self) -> list[str]:
        """Human-readable report lines (the ``import`` command prints these)."""
        lines = [
            f"{self.path.name}: kept {sum(self.kept.values())} features as "
            f"{len(self.obstacles)} obstacles, skipped {sum(self.skipped.values())}"
        ]
        for kind, n in sorted(self.kept.items(), key=lambda kv: (-kv[1], kv[0])):
            lines.append(f"  kept     {n:6d}  {kind}")
        for reason, n in sorted(self.skipped.items(), key=lambda kv: (-kv[1], kv[0])):
            lines.append(f"  skipped  {n:6d}  {reason}")
        for note, n in sorted(self.notes.items(), key=lambda kv: (-kv[1], kv[0])):
            lines.append(f"  note     {n:6d}  {note}")
        return lines


# ---------------------------------------------------------------------------------------------
# Heights

_HEIGHT_RE = re.compile(
    r"^\s*(?P<num>[+]?\d+(?:[.,]\d+)?)\s*(?P<unit>m|meters?|metres?|ft|feet|foot|')?\s*$",
    re.IGNORECASE,
)
_FEET_INCHES_RE = re.compile(r"^\s*(?P<ft>\d+)\s*'\s*(?P<inch>\d+(?:\.\d+)?)\s*(?:\"|'')\s*$")
FOOT_M = 0.3048


def parse_height_m(value: Any) -> float | None:
    """A height in metres from an OSM ``height`` tag or an attribute value, or ``None``.

    Accepts numbers, ``"12"``, ``"12.5 m"``, ``"12,5"``, ``"40'"``, ``"40 ft"`` and
    ``"12'6\\""`` (feet and inches); of OSM multiple values (``"12;15"``) the tallest.
    Anything else, zero or negative → ``None``.
    """
    if value is None or isinstance(value, bool):
        return None
    if isinstance(value, int | float):
        out = float(value)
    elif ";" in str(value):  # OSM multiple values: the tallest one (conservative)
        heights = [h for h in (parse_height_m(v) for v in str(value).split(";")) if h is not None]
        return max(heights) if heights else None
    else:
        text = str(value)
        m = _FEET_INCHES_RE.match(text)
        if m:
            out = (int(m["ft"]) + float(m["inch"]) / 12.0) * FOOT_M
        else:
            m = _HEIGHT_RE.match(text)
            if not m:
                return None
            out = float(m["num"].replace(",", "."))
            unit = (m["unit"] or "m").lower()
            if unit in ("ft", "feet", "foot", "'"):
                out *= FOOT_M
    if not math.isfinite(out) or out <= 0:
        return None
    return out


def parse_levels(value: Any) -> float | None:
    """``building:levels`` → a positive number of storeys, or ``None``."""
    if value is None:
        return None
    try:
        out = float(str(value).strip().replace(",", "."))
    except ValueError:
        return None
    return out if math.isfinite(out) and out > 0 else None


# ---------------------------------------------------------------------------------------------
# Entry points


def read_obstacle_file(
    spec: ObstacleFileSpec, frame: EnuFrame, bounds: Bounds | None = None
) -> ImportResult:
    """Read one file into obstacles in ``frame``'s ENU metres, clipped near ``bounds``."""
    import time

    t0 = time.perf_counter()
    features, result = read_features(spec, _lonlat_window(frame, bounds))
    features_to_obstacles(features, frame, bounds, result)
    result.seconds = time.perf_counter() - t0
    return result


def read_features(
    spec: ObstacleFileSpec, window_lonlat: tuple[float, float, float, float] | None = None
) -> tuple[list[Feature], ImportResult]:
    """The file's features in lon/lat (and a result holding the counts so far)."""
    if not spec.path.exists():
        raise SourceError(f"file not found: {spec.path}", key="file")
    if not spec.path.is_file():
        raise SourceError(f"not a file: {spec.path}", key="file")
    result = ImportResult(spec.path)
    if spec.is_osm:
        from uavplan.sources.osm import read_osm_features

        if spec.layer is not None:
            raise SourceError("OpenStreetMap files have no layers", key="layer")
        if spec.height_attribute is not None:
            raise SourceError(
                "OpenStreetMap heights come from the height and building:levels tags",
                key="height_attribute",
            )
        features = read_osm_features(spec, result.skipped, window_lonlat, result.notes)
    else:
        from uavplan.sources.vector import read_vector_features

        features = read_vector_features(spec, result.skipped, result.notes)
    return _with_valid_coordinates(features, result), result


def _with_valid_coordinates(features: list[Feature], result: ImportResult) -> list[Feature]:
    """The features whose every coordinate is a finite longitude/latitude; the others are
    counted as skipped. If none is valid the file is refused: when its numbers are finite but
    not degrees (metres of a projected CRS the file does not declare), the message says so."""
    import numpy as np
    import shapely

    if not features:
        return features
    coords, owner = shapely.get_coordinates([f.geometry for f in features], return_index=True)
    finite = np.isfinite(coords).all(axis=1)
    with np.errstate(invalid="ignore"):
        degrees = finite & (np.abs(coords[:, 0]) <= 180.0) & (np.abs(coords[:, 1]) <= 90.0)
    bad = np.zeros(len(features), dtype=bool)
    np.logical_or.at(bad, owner, ~degrees)
    if not bad.any():
        return features
    if bad.all():
        projected = finite & ~degrees
        if projected.any():
            x, y = coords[int(np.argmax(projected))]
            raise SourceError(
                f"coordinates such as ({x:.10g}, {y:.10g}) are not longitude/latitude "
                "degrees: the file's coordinate reference system is missing or wrong (GeoJSON "
                "holds longitude/latitude unless it names another CRS)",
                key="file",
            )
        raise SourceError("no feature has usable coordinates (non-finite numbers)", key="file")
    result.skipped["coordinates not finite, or not longitude/latitude degrees"] += int(bad.sum())
    return [f for f, b in zip(features, bad.tolist(), strict=True) if not b]


def features_extent_lonlat(features: Sequence[Feature]) -> tuple[float, float, float, float]:
    """(west, south, east, north) degrees of all features (for a default origin)."""
    import shapely

    if not features:
        raise SourceError("no buildings or tall structures found", key="file")
    return tuple(shapely.total_bounds([f.geometry for f in features]).tolist())  # type: ignore[return-value]


def obstacles_from_entries(
    raw: Any, base_dir: Path, frame: EnuFrame, bounds: Bounds | None
) -> tuple[Obstacle, ...]:
    """All obstacles of an ``obstacle_files`` list; a :class:`SourceError` names the entry."""
    if raw is None:
        return ()
    if not isinstance(raw, list):
        raise SourceError(f"must be a list of files, got {type(raw).__name__}")
    out: list[Obstacle] = []
    for i, item in enumerate(raw):
        try:
            spec = ObstacleFileSpec.from_mapping(item, base_dir)
            out.extend(read_obstacle_file(spec, frame, bounds).obstacles)
        except SourceError as err:
            err.index = i
            raise
    return tuple(out)


# ---------------------------------------------------------------------------------------------
# Geometry


def _padded_xy(bounds: Bounds | None) -> tuple[float, float, float, float] | None:
    if bounds is None:
        return None
    return (
        bounds.x_m[0] - CLIP_PAD_M,
        bounds.y_m[0] - CLIP_PAD_M,
        bounds.x_m[1] + CLIP_PAD_M,
        bounds.y_m[1] + CLIP_PAD_M,
    )


def _lonlat_window(
    frame: EnuFrame, bounds: Bounds | None
) -> tuple[float, float, float, float] | None:
    """A lon/lat box that surely contains the padded bounds (for a cheap pre-filter)."""
    box = _padded_xy(bounds)
    if box is None:
        return None
    import numpy as np

    x0, y0, x1, y1 = box
    xs = np.linspace(x0, x1, 9)
    ys = np.linspace(y0, y1, 9)
    gx, gy = np.meshgrid(xs, ys)
    pts = np.column_stack((gx.ravel(), gy.ravel(), np.zeros(gx.size)))
    lat, lon, _ = frame.to_geodetic(pts)
    dlat, dlon = 0.1 * (lat.max() - lat.min()) + 1e-4, 0.1 * (lon.max() - lon.min()) + 1e-4
    return (lon.min() - dlon, lat.min() - dlat, lon.max() + dlon, lat.max() + dlat)


def lonlat_to_enu(geom: Any, frame: EnuFrame) -> Any:
    """Shapely geometries (one or a sequence) in (lon, lat) degrees → ENU (x, y) metres."""
    import shapely

    def fn(coords: Any) -> Any:
        return frame.to_enu_xy(coords[:, 1], coords[:, 0])

    return shapely.transform(geom, fn)


def split_holes(poly: Any) -> list[Any]:
    """Hole-free polygons that tile ``poly`` exactly (cut vertically through each hole)."""
    from shapely.geometry import box

    if not poly.interiors:
        return [poly]
    hole = poly.interiors[0]
    from shapely.geometry import Polygon

    x_cut = Polygon(hole).representative_point().x
    minx, miny, maxx, maxy = poly.bounds
    out: list[Any] = []
    for half in (
        box(minx - 1.0, miny - 1.0, x_cut, maxy + 1.0),
        box(x_cut, miny - 1.0, maxx + 1.0, maxy + 1.0),
    ):
        for piece in _polygons(poly.intersection(half)):
            out.extend(split_holes(piece))
    return out


def _polygons(geom: Any) -> list[Any]:
    """The polygons inside any shapely geometry (collections exploded, others dropped)."""
    kind = geom.geom_type
    if kind == "Polygon":
        return [] if geom.is_empty else [geom]
    if kind in ("MultiPolygon", "GeometryCollection"):
        return [p for g in geom.geoms for p in _polygons(g)]
    return []


def conservative_simplify(poly: Any) -> Any:
    """Fewer vertices and a footprint that covers ``poly`` (else ``poly`` unchanged)."""
    if len(poly.exterior.coords) - 1 <= SIMPLIFY_MIN_VERTICES:
        return poly
    grown = poly.buffer(SIMPLIFY_TOLERANCE_M, join_style="mitre", mitre_limit=2.0)
    candidate = grown.simplify(SIMPLIFY_TOLERANCE_M, preserve_topology=True)
    pieces = _polygons(candidate)
    if len(pieces) != 1:
        return poly
    simple = pieces[0]
    if len(simple.exterior.coords) >= len(poly.exterior.coords) or not simple.covers(poly):
        return poly
    return simple


def features_to_obstacles(
    features: Sequence[Feature], frame: EnuFrame, bounds: Bounds | None, result: ImportResult
) -> None:
    """Turn features into obstacles in ``result`` (see the module docstring for the steps)."""
    import shapely
    from shapely.geometry import box

    window = _padded_xy(bounds)
    clip_box = box(*window) if window is not None else None
    obstacles: list[Obstacle] = []
    # one vectorised lon/lat -> ENU call for every coordinate of every feature
    enu_geoms = lonlat_to_enu([f.geometry for f in features], frame) if features else []
    for feat, geom in zip(features, enu_geoms, strict=True):
        if feat.height_source == "default" and feat.base_m > 0:
            feat.height_m += feat.base_m  # a default-height part standing on a lifted base
        if feat.height_m > MAX_ALTITUDE_M:  # a data error (height=9999999, levels=1e308)
            feat.height_m = MAX_ALTITUDE_M
            result.notes[f"height above {MAX_ALTITUDE_M:g} m: held at {MAX_ALTITUDE_M:g} m"] += 1
        # to the millimetre, as a map file stores heights and outlines (so a map written by
        # `import` and the same file read through obstacle_files hold the same obstacles)
        feat.height_m = round(feat.height_m, 3)
        if feat.height_m <= feat.base_m:
            result.skipped["top not above its base (min_height >= height)"] += 1
            continue
        if geom.geom_type == "Point":
            radius = feat.radius_m or 1.0
            x, y = geom.x, geom.y
            if clip_box is not None and not clip_box.intersects(geom.buffer(radius)):
                result.skipped["outside the bounds"] += 1
                continue
            obstacles.append(CylinderObstacle((float(x), float(y)), float(radius), feat.height_m))
            _count_kept(result, feat)
            continue
        if not geom.is_valid:
            geom = shapely.make_valid(geom)
            result.notes["invalid outline repaired"] += 1
        polys = _polygons(geom)
        if not polys:
            result.skipped["no area (not a polygon)"] += 1
            continue
        if clip_box is not None:
            if not clip_box.intersects(geom):
                result.skipped["outside the bounds"] += 1
                continue
            if not clip_box.contains(geom):
                polys = [p for poly in polys for p in _polygons(poly.intersection(clip_box))]
                result.notes["clipped at the bounds"] += 1
        polys = [p for p in polys if p.area >= MIN_AREA_M2]
        if not polys:
            result.skipped[f"smaller than {MIN_AREA_M2:g} m²"] += 1
            continue
        for poly in polys:
            simple = conservative_simplify(poly)
            if simple is not poly:
                result.notes["outline simplified (grown ≤ 0.5 m, covers the original)"] += 1
            pieces = split_holes(simple)
            if len(pieces) > 1:
                result.notes["courtyard kept: outline split into hole-free prisms"] += 1
            for piece in pieces:
                if piece.area < MIN_PIECE_AREA_M2:
                    continue  # a cut sliver thinner than the outline's rounding
                ring = _mm_ring(piece)
                if ring is None:  # thinner than a millimetre somewhere: fill conservatively
                    ring = _mm_ring(piece.convex_hull)
                    result.notes["outline pinched to < 1 mm: its convex hull used"] += 1
                if ring is not None and len(ring) > MAX_POLYGON_VERTICES:
                    ring = _mm_ring(_fewer_vertices(piece))
                    result.notes[
                        f"outline of more than {MAX_POLYGON_VERTICES} vertices: a covering "
                        "outline with fewer used"
                    ] += 1
                if ring is not None:
                    obstacles.append(PrismObstacle(ring, feat.height_m))
        _count_kept(result, feat)
    if clip_box is None:  # clipped obstacles lie within the (checked) bounds
        _check_extent(obstacles)
    result.obstacles = result.obstacles + tuple(obstacles)
    if len(result.obstacles) > MAX_OBSTACLES:
        raise SourceError(
            f"more than {MAX_OBSTACLES:,} obstacles ({len(result.obstacles):,}): narrow the bounds",
            key="file",
        )


def _fewer_vertices(poly: Any) -> Any:
    """A polygon covering ``poly`` with at most :data:`MAX_POLYGON_VERTICES` vertices: the
    conservative simplification at growing tolerances, else the minimum rotated rectangle."""
    import shapely

    tolerance = SIMPLIFY_TOLERANCE_M
    for _ in range(12):
        tolerance *= 2.0
        grown = poly.buffer(tolerance, join_style="mitre", mitre_limit=2.0)
        pieces = _polygons(grown.simplify(tolerance, preserve_topology=True))
        if len(pieces) == 1 and not pieces[0].interiors and pieces[0].covers(poly):
            if len(pieces[0].exterior.coords) - 1 <= MAX_POLYGON_VERTICES:
                return pieces[0]
    return shapely.minimum_rotated_rectangle(poly)


def _check_extent(obstacles: Sequence[Obstacle]) -> None:
    """Refuse obstacles beyond the horizontal limit of every map (data spread over a continent
    read without bounds)."""
    far = 0.0
    for ob in obstacles:
        if isinstance(ob, CylinderObstacle):
            far = max(far, max(abs(ob.center_m[0]), abs(ob.center_m[1])) + ob.radius_m)
        else:
            far = max(far, max(max(abs(x), abs(y)) for x, y in ob.footprint()))
    if far > MAX_HORIZONTAL_M:
        raise SourceError(
            f"the data reaches {far / 1000:,.0f} km from the origin, beyond the "
            f"{MAX_HORIZONTAL_M / 1000:,.0f} km a map may span: give bounds around the area",
            key="file",
        )


def _mm_ring(poly: Any) -> tuple[tuple[float, float], ...] | None:
    """The CCW outline rounded to millimetres (as a map file stores it), or ``None`` if the
    rounded outline is not a simple polygon of positive area."""
    from shapely.geometry import Polygon
    from shapely.geometry.polygon import orient

    ring = [(round(float(x), 3), round(float(y), 3)) for x, y, *_ in orient(poly).exterior.coords]
    ring = [p for i, p in enumerate(ring[:-1]) if p != ring[i - 1] or i == 0]
    if len(ring) < 3:
        return None
    rounded = Polygon(ring)
    if not rounded.is_valid or rounded.area < MIN_PIECE_AREA_M2:
        return None
    return tuple(ring)


def _count_kept(result: ImportResult, feat: Feature) -> None:
    result.kept[feat.kind] += 1
    if feat.height_source == "default":
        result.notes["no height information: default height used"] += 1
    if feat.base_m > 0:
        result.notes["base lifted: modelled down to the ground"] += 1
