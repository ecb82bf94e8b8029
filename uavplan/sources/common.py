"""The entry points of the obstacle readers, and footprint → solid (the values they share are
in :mod:`~uavplan.sources.base`).

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

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from uavplan.limits import MAX_ALTITUDE_M, MAX_HORIZONTAL_M, MAX_OBSTACLES, MAX_POLYGON_VERTICES
from uavplan.obstacles import Bounds, CylinderObstacle, Obstacle, PrismObstacle
from uavplan.sources.base import (
    DEFAULT_HEIGHT_M,
    LEVEL_HEIGHT_M,
    OSM_SUFFIXES,
    Feature,
    ImportResult,
    ObstacleFileSpec,
    SourceError,
    parse_height_m,
    parse_levels,
)

if TYPE_CHECKING:
    from uavplan.geo import EnuFrame

__all__ = [
    "DEFAULT_HEIGHT_M",
    "LEVEL_HEIGHT_M",
    "OSM_SUFFIXES",
    "Feature",
    "ImportResult",
    "ObstacleFileSpec",
    "SourceError",
    "features_extent_lonlat",
    "features_to_obstacles",
    "obstacles_from_entries",
    "parse_height_m",
    "parse_levels",
    "read_features",
    "read_obstacle_file",
]

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
