"""Plane geometry in one place: polygons, segments and offsets in local metres (ENU x, y).

Conventions: a *ring* is a polygon's vertices ``(k, 2)``, not closed (the last vertex is not a
copy of the first); "counter-clockwise" is positive signed area. Functions are vectorised
over numpy arrays and pure (no state, no I/O). Used by the scenario checks, the world's convex
decomposition, the geofence, the map exports and the pictures.

The small kernels (areas, orientation, crossings, distances, the tangent-cut offset) are numpy:
they run on a handful of vertices and their exact floating-point behaviour is part of the
planner's and the fence's reproducible results. shapely 2 is used where a full geometry
engine earns its keep: :func:`polygon_problem` (why a ring is not a valid polygon, and where),
:func:`covers` (a containment check, used to verify offsets) and :func:`round_offset_outline`
(the exact rounded offset of any polygon, concave ones included, for pictures). It is
imported lazily (``python -X importtime -c "import numpy; import shapely"``: shapely adds
85-105 ms to numpy's 400-500 ms on the busy 2-core build machine), so importing this module
costs only numpy.

The offset (:func:`offset_ring`, :func:`inflate_polygon`) is conservative: the polygon it
returns *contains* the ring grown by the offset in every direction (the Minkowski sum with a
disc). Edges move out by the offset; a convex corner is cut by tangents to the rounded
offset, each tangent point ``offset`` away from the corner and the cut's vertices
``offset / cos(step / 2)`` away (``step`` the turn each cut covers). A buffer with round
joins would cut corners *inside* the true offset, so it is not used for that.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

if TYPE_CHECKING:
    from shapely import Polygon  # type: ignore[import-untyped]

_Arr = NDArray[np.float64]
Point2 = tuple[float, float]

#: a cross product (twice a triangle's area, m²) below this is "collinear"
COLLINEAR_TOL = 1e-12
#: rings of up to this many vertices, given as sequences, take the plain-Python paths of
#: :func:`signed_area` and :func:`self_intersects` (a map of 20,000 small prisms is checked in
#: a tenth of the time the array paths take, each call's numpy overhead being the cost)
SMALL_RING_VERTICES = 16


# ---------------------------------------------------------------------------------------------
# Rings: area, orientation, convexity


def as_ring(ring: ArrayLike) -> _Arr:
    """``ring`` as a float array ``(k, 2)``; raises ``ValueError`` for another shape."""
    r = np.asarray(ring, dtype=np.float64)
    if r.ndim != 2 or r.shape[1] != 2:
        raise ValueError(f"a ring must have shape (k, 2), got {r.shape}")
    return r


def _small_pairs(ring: ArrayLike) -> bool:
    """Is ``ring`` a short sequence (not an array) of (x, y) pairs? (the plain-Python paths)"""
    return (
        isinstance(ring, list | tuple)
        and 0 < len(ring) <= SMALL_RING_VERTICES
        and all(isinstance(p, list | tuple) and len(p) == 2 for p in ring)
    )


def signed_area(ring: ArrayLike) -> float:
    """Signed area (m²) of the ring (shoelace): > 0 counter-clockwise, < 0 clockwise. A ring
    of a few vertices given as a sequence of pairs is summed in plain Python (a map of
    20,000 small prisms is read 0.1 s sooner); an array goes through numpy."""
    if _small_pairs(ring):
        pts: Sequence[Sequence[float]] = ring  # type: ignore[assignment]
        nxt = [*pts[1:], pts[0]]
        return 0.5 * sum(a[0] * b[1] - b[0] * a[1] for a, b in zip(pts, nxt, strict=True))
    r = as_ring(ring)
    x, y = r[:, 0], r[:, 1]
    # np.concatenate((v[1:], v[:1])) is np.roll(v, -1), several times cheaper on a few vertices
    y1, x1 = np.concatenate((y[1:], y[:1])), np.concatenate((x[1:], x[:1]))
    return 0.5 * float(np.dot(x, y1) - np.dot(x1, y))


def orient_ccw(ring: ArrayLike) -> _Arr:
    """The ring, reversed if it is clockwise (a copy)."""
    r = as_ring(ring)
    return r[::-1].copy() if signed_area(r) < 0 else r.copy()


def is_convex_ccw(ring: ArrayLike, tol: float = COLLINEAR_TOL) -> bool:
    """Is the counter-clockwise ring convex (no right turn beyond ``tol``; collinear is fine)?"""
    r = as_ring(ring)
    a, b, c = r, np.concatenate((r[1:], r[:1])), np.concatenate((r[2:], r[:2]))  # rolls
    turn = (b[:, 0] - a[:, 0]) * (c[:, 1] - b[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - b[:, 0])
    return bool(np.all(turn >= -tol))


def turn_angles(ring: ArrayLike) -> _Arr:
    """Turn at each vertex of a counter-clockwise ring, radians in [-pi, pi) (> 0: convex).

    Entry ``i`` is the turn from edge ``i - 1`` (into vertex ``i``) to edge ``i``.
    """
    r = as_ring(ring)
    edges = np.roll(r, -1, axis=0) - r
    heading = np.arctan2(edges[:, 1], edges[:, 0])
    return (heading - np.roll(heading, 1) + math.pi) % (2 * math.pi) - math.pi


def convex_hull(points: ArrayLike) -> _Arr:
    """Counter-clockwise convex hull ``(k, 2)`` of ``points`` (Andrew's monotone chain).

    Collinear points on the hull are dropped; fewer than 3 distinct points come back as they
    are (sorted).
    """
    pts = sorted({(float(x), float(y)) for x, y in np.asarray(points, dtype=np.float64)})
    if len(pts) < 3:
        return np.asarray(pts, dtype=np.float64).reshape(-1, 2)

    def cross(o: Point2, a: Point2, b: Point2) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[Point2] = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list[Point2] = []
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.asarray(lower[:-1] + upper[:-1], dtype=np.float64)


def circle_ring(center: Sequence[float], radius_m: float, segments: int) -> _Arr:
    """A circle's inscribed regular polygon, counter-clockwise, first vertex due east."""
    angles = np.linspace(0.0, 2 * math.pi, segments, endpoint=False)
    return np.column_stack(
        (center[0] + radius_m * np.cos(angles), center[1] + radius_m * np.sin(angles))
    )


# ---------------------------------------------------------------------------------------------
# Crossings and simplicity


def cross2(u: _Arr, v: _Arr) -> _Arr:
    """z of the cross product of 2-D vectors (broadcast over leading axes)."""
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def segments_intersect(
    p0: _Arr, p1: _Arr, q0: _Arr, q1: _Arr, *, touching: bool = True
) -> NDArray[np.bool_]:
    """Element-wise (broadcast): does segment p0-p1 meet segment q0-q1?

    ``touching=True``: an end point on the other segment (or collinear overlap) counts;
    ``False``: only proper crossings (each segment strictly splits the other's ends) count.
    """
    d1 = cross2(q1 - q0, p0 - q0)
    d2 = cross2(q1 - q0, p1 - q0)
    d3 = cross2(p1 - p0, q0 - p0)
    d4 = cross2(p1 - p0, q1 - p0)
    proper = (d1 * d2 < 0) & (d3 * d4 < 0)
    if not touching:
        return proper
    eps = COLLINEAR_TOL
    touch = (
        ((np.abs(d1) <= eps) & _on_segment(q0, q1, p0))
        | ((np.abs(d2) <= eps) & _on_segment(q0, q1, p1))
        | ((np.abs(d3) <= eps) & _on_segment(p0, p1, q0))
        | ((np.abs(d4) <= eps) & _on_segment(p0, p1, q1))
    )
    return proper | touch


def _on_segment(a: _Arr, b: _Arr, p: _Arr) -> NDArray[np.bool_]:
    """Is ``p`` (known collinear with a-b) within the segment's bounding box?"""
    lo, hi = np.minimum(a, b) - 1e-12, np.maximum(a, b) + 1e-12
    return np.all((p >= lo) & (p <= hi), axis=-1)


def self_intersects(ring: ArrayLike, *, touching: bool = True) -> bool:
    """Do two non-adjacent edges of the closed ring cross (or, with ``touching``, touch)?"""
    if not touching and _small_pairs(ring):
        return _crosses_itself_small(ring)  # type: ignore[arg-type]
    r = as_ring(ring)
    n = len(r)
    if n < 4:
        return False
    a, b = r, np.roll(r, -1, axis=0)
    i, j = np.triu_indices(n, k=2)
    adjacent = (i == 0) & (j == n - 1)
    i, j = i[~adjacent], j[~adjacent]
    return bool(segments_intersect(a[i], b[i], a[j], b[j], touching=touching).any())


def _crosses_itself_small(ring: Sequence[Sequence[float]]) -> bool:
    """:func:`self_intersects` with ``touching=False`` for a few vertices given as a sequence:
    the same products as :func:`segments_intersect`, in the same order, so the same answer."""
    n = len(ring)
    if n < 4:
        return False
    for i in range(n):
        (ax, ay), (bx, by) = ring[i], ring[(i + 1) % n]
        for j in range(i + 2, n - 1 if i == 0 else n):
            (cx, cy), (dx, dy) = ring[j], ring[(j + 1) % n]
            d1 = (dx - cx) * (ay - cy) - (dy - cy) * (ax - cx)
            d2 = (dx - cx) * (by - cy) - (dy - cy) * (bx - cx)
            if d1 * d2 < 0:
                d3 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
                d4 = (bx - ax) * (dy - ay) - (by - ay) * (dx - ax)
                if d3 * d4 < 0:
                    return True
    return False


def polygon_problem(ring: ArrayLike) -> str | None:
    """Why ``ring`` is not a valid simple polygon (shapely's reason, with the place), or None.

    E.g. ``"Self-intersection[5 5]"``, ``"Ring Self-intersection[0 0]"``, ``"Too few
    points[...]"``. Zero area counts as a problem.
    """
    import shapely  # type: ignore[import-untyped]

    r = as_ring(ring)
    if len(r) < 3 or not np.all(np.isfinite(r)):
        return "a polygon needs at least 3 finite vertices"
    polygon = _shapely_polygon(r)
    reason = str(shapely.is_valid_reason(polygon))
    if reason != "Valid Geometry":
        return reason
    if abs(signed_area(r)) <= 1e-9:
        return "zero area"
    return None


def covers(outer_ring: ArrayLike, inner: ArrayLike, tol_m: float = 1e-9) -> bool:
    """Does the polygon ``outer_ring`` cover the polygon (or points ``(n, 2)``) ``inner``?

    ``tol_m`` grows ``outer`` by a mitred buffer (itself conservative) so that boundaries
    touching within rounding count as covered.
    """
    import shapely  # type: ignore[import-untyped]

    outer = _shapely_polygon(as_ring(outer_ring))
    if tol_m > 0:
        outer = shapely.buffer(outer, tol_m, join_style="mitre", mitre_limit=10.0)
    pts = as_ring(inner)
    target = _shapely_polygon(pts) if len(pts) >= 3 else shapely.multipoints(pts)
    return bool(shapely.covers(outer, target))


def round_offset_outline(ring: ArrayLike, offset_m: float, *, quad_segs: int = 8) -> list[_Arr]:
    """The ring grown by ``offset_m`` with round corners, as shapely buffers it: the outer
    ring(s) ``(k, 2)`` of the result, counter-clockwise.

    For *drawing* the true offset (a concave footprint keeps its notch, where
    :func:`inflate_polygon` falls back to the hull). Its vertices lie on the rounded offset
    and its chords inside it, by up to ``offset_m * (1 - cos(pi / (4 * quad_segs)))``: it is
    not conservative, so a fence never uses it.
    """
    import shapely

    grown = shapely.buffer(_shapely_polygon(orient_ccw(ring)), offset_m, quad_segs=quad_segs)
    parts = getattr(grown, "geoms", [grown])
    return [orient_ccw(np.asarray(part.exterior.coords)[:-1]) for part in parts]


def _shapely_polygon(ring: _Arr) -> Polygon:
    import shapely  # type: ignore[import-untyped]

    return shapely.Polygon(ring)


# ---------------------------------------------------------------------------------------------
# Point in polygon and distances


def points_in_polygon(points: ArrayLike, ring: ArrayLike) -> NDArray[np.bool_]:
    """Even-odd rule: which of ``points`` ``(n, 2)`` lie inside ``ring`` ``(k, 2)``.

    Points exactly on an edge may fall either way.
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    r = as_ring(ring)
    a, b = r, np.roll(r, -1, axis=0)
    px, py = p[:, None, 0], p[:, None, 1]
    straddles = (a[None, :, 1] > py) != (b[None, :, 1] > py)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_cross = a[None, :, 0] + (py - a[None, :, 1]) * (b[None, :, 0] - a[None, :, 0]) / (
            b[None, :, 1] - a[None, :, 1]
        )
    hits = straddles & (px < x_cross)
    return (np.count_nonzero(hits, axis=1) % 2) == 1


def point_segment_distance(p: _Arr, a: _Arr, b: _Arr) -> _Arr:
    """Broadcast distance from points ``p`` to segments ``a``-``b`` (zero-length allowed)."""
    ab = b - a
    denom = np.sum(ab * ab, axis=-1)
    safe = np.where(denom > 0, denom, 1.0)
    t = np.where(denom > 0, np.sum((p - a) * ab, axis=-1) / safe, 0.0)
    t = np.clip(t, 0.0, 1.0)
    closest = a + t[..., None] * ab
    return np.sqrt(np.sum((p - closest) ** 2, axis=-1))


def points_polygon_distance(points: ArrayLike, ring: ArrayLike) -> _Arr:
    """Per point ``(n,)``: distance to the polygon region (0 inside it)."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    r = as_ring(ring)
    e0, e1 = r[None, :, :], np.roll(r, -1, axis=0)[None, :, :]
    d = point_segment_distance(p[:, None, :], e0, e1).min(axis=1)
    d[points_in_polygon(p, r)] = 0.0
    return d


def point_rings_distance(
    xy: Sequence[float], edge_a: _Arr, edge_b: _Arr, owner: NDArray[np.int64], n: int
) -> _Arr:
    """Distance ``(n,)`` from the point ``xy`` to each of ``n`` polygon regions given by their
    edges ``edge_a[k]`` → ``edge_b[k]`` ``(E, 2)`` of polygon ``owner[k]`` (0 inside, even-odd
    rule; a polygon without edges is ``inf`` away): many polygons at once, where
    :func:`points_polygon_distance` takes many points and one polygon."""
    out = np.full(n, np.inf)
    if not owner.size:
        return out
    p = np.array([float(xy[0]), float(xy[1])])
    np.minimum.at(out, owner, point_segment_distance(p, edge_a, edge_b))
    ay, by = edge_a[:, 1], edge_b[:, 1]
    straddles = (ay > p[1]) != (by > p[1])
    with np.errstate(divide="ignore", invalid="ignore"):
        x_cross = edge_a[:, 0] + (edge_b[:, 0] - edge_a[:, 0]) * (p[1] - ay) / np.where(
            straddles, by - ay, 1.0
        )
    hits = np.zeros(n, dtype=np.int64)
    np.add.at(hits, owner, (straddles & (p[0] < x_cross)).astype(np.int64))
    out[hits % 2 == 1] = 0.0
    return out


def segments_polygon_distance(seg_a: _Arr, seg_b: _Arr, ring: ArrayLike) -> _Arr:
    """Per segment ``seg_a[i]``-``seg_b[i]`` ``(n,)``: distance to the polygon region (0 if
    it enters it)."""
    r = as_ring(ring)
    e0, e1 = r, np.roll(r, -1, axis=0)
    a, b = seg_a[:, None, :], seg_b[:, None, :]
    f0, f1 = e0[None, :, :], e1[None, :, :]
    dist = np.minimum.reduce(
        [
            point_segment_distance(a, f0, f1),
            point_segment_distance(b, f0, f1),
            point_segment_distance(f0, a, b),
            point_segment_distance(f1, a, b),
        ]
    ).min(axis=1)
    crossing = segments_intersect(a, b, f0, f1).any(axis=1)
    inside = points_in_polygon(seg_a, r)
    return np.where(crossing | inside, 0.0, dist)


#: rings (or circles) whose candidate segments are found at once in
#: :func:`segments_rings_distance`: bounds its work arrays to this × the segments
RINGS_PER_CHUNK = 2048


def _seg_dist(px: _Arr, py: _Arr, ax: _Arr, ay: _Arr, bx: _Arr, by: _Arr) -> _Arr:
    """Broadcast distance from points (px, py) to segments a-b, by components (the x, y
    arrays apart: about twice as fast as :func:`point_segment_distance` on large arrays)."""
    ux, uy = bx - ax, by - ay
    denom = ux * ux + uy * uy
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(denom > 0, ((px - ax) * ux + (py - ay) * uy) / denom, 0.0)
    t = np.clip(t, 0.0, 1.0)
    return np.hypot(px - (ax + t * ux), py - (ay + t * uy))


def segments_rings_distance(
    seg_a: _Arr, seg_b: _Arr, edge_a: _Arr, edge_b: _Arr, owner: NDArray[np.int64], n: int
) -> _Arr:
    """Distance ``(n,)`` from a polyline, given by its segments ``seg_a[s]`` → ``seg_b[s]``
    ``(S, 2)``, to each of ``n`` polygon regions given by their edges ``edge_a[k]`` →
    ``edge_b[k]`` ``(E, 2)`` of polygon ``owner[k]`` (sorted: each polygon's edges together;
    0 where the polyline enters or crosses the region, even-odd rule; a polygon without edges
    is ``inf`` away). The same distances as :func:`segments_polygon_distance` polygon by
    polygon, for thousands of polygons at once.

    Only the (segment, polygon) pairs that can hold the nearest point are measured exactly:
    every polygon lies within ``r`` of its first vertex ``v``, so a segment at distance ``d``
    from ``v`` is at least ``d − r`` from the polygon, while the polygon is at most the
    smallest such ``d`` from the polyline; a segment whose ``d − r`` exceeds that bound is
    skipped. A polygon's distance is then the smallest over its remaining segments (0 if one
    crosses an edge or starts inside)."""
    out = np.full(n, np.inf)
    if not owner.size or not len(seg_a):
        return out
    owner = np.asarray(owner, dtype=np.int64)
    first = np.full(n, -1, dtype=np.int64)
    starts = np.flatnonzero(np.r_[True, owner[1:] != owner[:-1]])
    first[owner[starts]] = starts
    counts = np.bincount(owner, minlength=n)
    has = counts > 0
    anchor = np.zeros((n, 2))
    anchor[has] = edge_a[first[has]]
    radius = np.zeros(n)
    np.maximum.at(radius, owner, np.hypot(*(edge_a - anchor[owner]).T))
    sax, say, sbx, sby = seg_a[:, 0], seg_a[:, 1], seg_b[:, 0], seg_b[:, 1]
    pair_ring, pair_seg = [], []
    for lo in range(0, n, RINGS_PER_CHUNK):
        rings = np.arange(lo, min(n, lo + RINGS_PER_CHUNK))
        rings = rings[has[rings]]
        if not rings.size:
            continue
        vx, vy = anchor[rings, 0, None], anchor[rings, 1, None]
        d = _seg_dist(vx, vy, sax[None], say[None], sbx[None], sby[None])  # (rings, S)
        bound = d.min(axis=1, keepdims=True)
        r_idx, s_idx = np.nonzero(d - radius[rings, None] <= bound)
        pair_ring.append(rings[r_idx])
        pair_seg.append(s_idx)
    if not pair_ring:
        return out
    p_ring, p_seg = np.concatenate(pair_ring), np.concatenate(pair_seg)
    # every (pair, edge of the pair's polygon): the pair index repeated over the edges
    per_pair = counts[p_ring]
    pair_of = np.repeat(np.arange(len(p_ring)), per_pair)
    edge = np.repeat(first[p_ring] - np.cumsum(per_pair) + per_pair, per_pair) + np.arange(
        int(per_pair.sum())
    )
    seg = p_seg[pair_of]
    ax, ay, bx, by = sax[seg], say[seg], sbx[seg], sby[seg]
    cx, cy = edge_a[edge, 0], edge_a[edge, 1]
    ex, ey = edge_b[edge, 0], edge_b[edge, 1]
    dist = np.minimum(
        np.minimum(_seg_dist(ax, ay, cx, cy, ex, ey), _seg_dist(bx, by, cx, cy, ex, ey)),
        np.minimum(_seg_dist(cx, cy, ax, ay, bx, by), _seg_dist(ex, ey, ax, ay, bx, by)),
    )
    # a proper crossing (a touching one is at distance 0 already)
    ux, uy, wx, wy = bx - ax, by - ay, ex - cx, ey - cy
    d1 = wx * (ay - cy) - wy * (ax - cx)
    d2 = wx * (by - cy) - wy * (bx - cx)
    d3 = ux * (cy - ay) - uy * (cx - ax)
    d4 = ux * (ey - ay) - uy * (ex - ax)
    dist[(d1 * d2 < 0) & (d3 * d4 < 0)] = 0.0
    # the segment's start inside the polygon (even-odd rule over the polygon's edges)
    straddles = (cy > ay) != (ey > ay)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_cross = cx + (ay - cy) * wx / np.where(straddles, wy, 1.0)
    hits = np.bincount(pair_of, weights=straddles & (ax < x_cross), minlength=len(p_ring))
    pair_dist = np.full(len(p_ring), np.inf)
    np.minimum.at(pair_dist, pair_of, dist)
    pair_dist[hits.astype(np.int64) % 2 == 1] = 0.0
    np.minimum.at(out, p_ring, pair_dist)
    return out


def segments_circles_distance(seg_a: _Arr, seg_b: _Arr, centres: _Arr, radii: _Arr) -> _Arr:
    """Distance ``(n,)`` from a polyline's segments ``(S, 2)`` to each of ``n`` discs (0 where
    the polyline enters one)."""
    out = np.full(len(centres), np.inf)
    if not len(seg_a):
        return out
    sax, say, sbx, sby = (v[None] for v in (seg_a[:, 0], seg_a[:, 1], seg_b[:, 0], seg_b[:, 1]))
    for lo in range(0, len(centres), RINGS_PER_CHUNK):
        c = centres[lo : lo + RINGS_PER_CHUNK]
        d = _seg_dist(c[:, 0, None], c[:, 1, None], sax, say, sbx, sby).min(axis=1)
        out[lo : lo + len(c)] = np.maximum(d - radii[lo : lo + len(c)], 0.0)
    return out


def polyline_segments(polyline: ArrayLike) -> tuple[_Arr, _Arr]:
    """The x, y of a polyline ``(n, >= 2)`` as segment ends ``(m, 2)`` each (one point: a
    zero-length segment)."""
    xy = np.asarray(polyline, dtype=np.float64)[:, :2]
    if len(xy) == 1:
        return xy, xy
    return xy[:-1], xy[1:]


# ---------------------------------------------------------------------------------------------
# Conservative offset (tangent cuts)


def cut_steps(turns_rad: _Arr, max_step_rad: float) -> NDArray[np.int_]:
    """Cuts per corner when each cut covers at most ``max_step_rad`` of turn (>= 1)."""
    steps = np.where(turns_rad > COLLINEAR_TOL, np.ceil(turns_rad / max_step_rad - 1e-9), 1)
    return np.maximum(steps.astype(int), 1)


def cut_step_angles(turns_rad: _Arr, max_step_rad: float) -> _Arr:
    """The turn each cut covers when ``|turn|`` is split into cuts of at most ``max_step_rad``."""
    n = np.maximum(np.ceil(np.abs(turns_rad) / max_step_rad - 1e-9), 1.0)
    return np.abs(turns_rad) / n


def offset_ring(ring: ArrayLike, offset_m: float, steps: ArrayLike) -> _Arr | None:
    """Offset the counter-clockwise ``ring`` outward by ``offset_m``, cutting convex corner
    ``i`` with ``steps[i]`` tangents to the rounded offset; a reflex corner is where the two
    moved edges meet.

    The result contains the ring grown by ``offset_m`` in every direction, and every point of
    it lies within ``offset_m / cos(step_i / 2)`` of the ring (``step_i``: corner i's turn
    divided by its cuts). None when the result folds over itself (an edge reverses or two
    edges cross), which a concave ring's offset can do; a convex ring's never does.
    """
    r = as_ring(ring)
    cuts = np.asarray(steps)
    edges = np.roll(r, -1, axis=0) - r  # edge i: ring[i] -> ring[i+1]
    normal = np.arctan2(-edges[:, 0], edges[:, 1])  # outward normal (dy, -dx) of each edge
    turns = turn_angles(r)
    vertices: list[Point2] = []
    starts: list[int] = []
    ends: list[int] = []
    n = len(r)
    for i in range(n):
        count = int(cuts[i]) if turns[i] > COLLINEAR_TOL else 1
        delta = float(turns[i]) / count
        reach = offset_m / math.cos(delta / 2.0)
        starts.append(len(vertices))
        for j in range(count):
            angle = normal[i - 1] + (j + 0.5) * delta
            vertices.append((r[i, 0] + reach * math.cos(angle), r[i, 1] + reach * math.sin(angle)))
        ends.append(len(vertices) - 1)
    out = np.asarray(vertices, dtype=np.float64)
    # Edge i now runs from the last cut of corner i to the first of corner i+1; if it
    # points backwards, the offset has folded over itself.
    for i in range(n):
        p, q = out[ends[i]], out[starts[(i + 1) % n]]
        if float(np.dot(q - p, edges[i])) < -1e-9:
            return None
    if self_intersects(out):
        return None
    return out


def inflate_polygon(ring: ArrayLike, offset_m: float, *, max_step_deg: float = 90.0) -> _Arr:
    """A counter-clockwise polygon containing ``ring`` grown by ``offset_m`` everywhere.

    Each convex corner is cut by tangents to the rounded offset, one per ``max_step_deg`` of
    turn (90: a box's corner is one mitre). If the offset of a concave ring folds over itself,
    the convex hull is offset instead (it still contains the exact offset). ``offset_m <= 0``
    returns the ring itself (counter-clockwise).
    """
    r = orient_ccw(ring)
    if offset_m <= 0:
        return r
    step = math.radians(max_step_deg)
    for outline in (r, convex_hull(r)):
        out = offset_ring(outline, offset_m, cut_steps(turn_angles(outline), step))
        if out is not None:
            return out
    raise AssertionError("the offset of a convex ring cannot fold")  # pragma: no cover


# ---------------------------------------------------------------------------------------------
# Convex decomposition (the world's obstacle pieces)


def triangulate(ring: Sequence[Point2]) -> list[list[Point2]]:
    """Ear clipping of a simple counter-clockwise polygon into counter-clockwise triangles.

    Degenerate (collinear) ears are skipped; a numerically degenerate remainder is fanned.
    """
    pts = [(float(x), float(y)) for x, y in ring]
    idx = list(range(len(pts)))
    tris: list[list[Point2]] = []

    def cross(o: Point2, a: Point2, b: Point2) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    def inside(p: Point2, a: Point2, b: Point2, c: Point2) -> bool:
        return cross(a, b, p) >= 0 and cross(b, c, p) >= 0 and cross(c, a, p) >= 0

    guard = 0
    while len(idx) > 3 and guard < 10_000:
        guard += 1
        for k in range(len(idx)):
            i0, i1, i2 = idx[k - 1], idx[k], idx[(k + 1) % len(idx)]
            a, b, c = pts[i0], pts[i1], pts[i2]
            if cross(a, b, c) <= COLLINEAR_TOL:
                continue
            if any(inside(pts[j], a, b, c) for j in idx if j not in (i0, i1, i2)):
                continue
            tris.append([a, b, c])
            idx.pop(k)
            break
        else:  # numerically degenerate remainder: fan it
            break
    if len(idx) >= 3:
        for k in range(1, len(idx) - 1):
            a, b, c = pts[idx[0]], pts[idx[k]], pts[idx[k + 1]]
            if cross(a, b, c) > COLLINEAR_TOL:
                tris.append([a, b, c])
    return tris


def convex_pieces(ring: Sequence[Point2], max_vertices: int) -> list[list[Point2]]:
    """Counter-clockwise convex pieces covering the simple polygon ``ring``.

    The polygon itself if it is convex and has at most ``max_vertices`` vertices, otherwise
    its ear-clipping triangles.
    """
    poly = [(float(x), float(y)) for x, y in ring]
    # plain Python for the small rings of buildings: numpy's per-call overhead dominated
    # (thousands of footprints); the same arithmetic as signed_area / is_convex_ccw
    n = len(poly)
    twice_area = 0.0
    for i in range(n):
        (x0, y0), (x1, y1) = poly[i], poly[(i + 1) % n]
        twice_area += x0 * y1 - x1 * y0
    if twice_area < 0:
        poly = poly[::-1]
    if n <= max_vertices and _convex_ccw_small(poly):
        return [poly]
    return triangulate(poly)


def _convex_ccw_small(poly: list[Point2], tol: float = COLLINEAR_TOL) -> bool:
    """:func:`is_convex_ccw` for a short list of points, without numpy."""
    n = len(poly)
    for i in range(n):
        (ax, ay), (bx, by), (cx, cy) = poly[i], poly[(i + 1) % n], poly[(i + 2) % n]
        if (bx - ax) * (cy - by) - (by - ay) * (cx - bx) < -tol:
            return False
    return True
