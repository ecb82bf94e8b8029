"""Airspace zones in the vehicle's geofence: their outlines simplified outward so each fits a
few fence items, and what the fence could and could not express of each zone.

A zone's solid (:mod:`uavplan.scenario.zones`) may have hundreds of vertices (arcs become
polygon edges). An autopilot holds few fence items (PX4 before 1.15: 63 in all,
:data:`uavplan.mission.fence.DEFAULT_MAX_ITEMS`), so before the fence is built
(:func:`uavplan.mission.fence.build_geofence`) each zone outline with more than
:data:`ZONE_FENCE_VERTICES` vertices is replaced by one that *contains* it with at most that
many (:func:`simplify_outward`); the fence then keeps its margin and its gap to the route
from the simplified outline, as from any obstacle. The error stated is the largest distance
from the simplified outline to the zone (the Hausdorff distance, shapely).

A MAVLink fence's exclusion polygon or circle has no floor and no ceiling: it forbids its
area at every altitude. A zone the route flies *over* (an AGL ceiling under the flight
volume's) cannot be expressed: its exclusion zone would forbid the route itself
(:func:`zone_fence_lines` names each).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from uavplan.mission.fence import FenceBuild, Footprint, ZoneStatus, footprints_of
from uavplan.obstacles import Obstacle

#: a zone outline fenced with more vertices than this is simplified outward first
ZONE_FENCE_VERTICES = 12
#: the outward simplification tries tolerances from this (metres), growing by half each time
FIRST_TOLERANCE_M = 1.0


def simplify_outward(
    ring: NDArray[np.float64], max_vertices: int = ZONE_FENCE_VERTICES
) -> tuple[NDArray[np.float64], float]:
    """A counter-clockwise ring ``(k, 2)`` with at most ``max_vertices`` vertices that
    contains ``ring`` (ENU metres), and the largest distance from it to ``ring`` (0 when
    ``ring`` is small enough already). Grow by a tolerance, then Douglas-Peucker by the same
    tolerance, kept only when the result covers the ring; the tolerance grows until the
    result is small enough; the convex hull's turn if it never is."""
    import shapely

    from uavplan.geometry2d import orient_ccw

    ring = np.asarray(ring, dtype=np.float64)
    if len(ring) <= max_vertices:
        return ring, 0.0
    poly = shapely.Polygon(ring)
    if not poly.is_valid:
        poly = shapely.make_valid(poly).convex_hull
    tol = FIRST_TOLERANCE_M
    size = max(np.ptp(ring[:, 0]), np.ptp(ring[:, 1]))
    while tol < 4.0 * size:
        grown = poly.buffer(tol, join_style="mitre", mitre_limit=4.0)
        simple = grown.simplify(tol, preserve_topology=True)
        if (
            simple.geom_type == "Polygon"
            and not simple.interiors
            and len(simple.exterior.coords) - 1 <= max_vertices
            and simple.covers(poly)
        ):
            out = orient_ccw(np.asarray(simple.exterior.coords)[:-1])
            return out, float(shapely.hausdorff_distance(simple.exterior, poly.exterior))
        tol *= 1.5
    hull = poly.convex_hull  # pragma: no cover - the growing tolerance ends in a few vertices
    out = orient_ccw(np.asarray(hull.exterior.coords)[:-1])
    return out, float(shapely.hausdorff_distance(hull.exterior, poly.exterior))


def zone_footprints(
    obstacles: Sequence[Obstacle],
    groups: Sequence[Sequence[int]],
    max_vertices: int = ZONE_FENCE_VERTICES,
) -> tuple[Footprint, ...]:
    """The footprints the fence is built from: the obstacles' own, but each zone's solids
    (``groups``: the obstacle indices of one zone; a zone over a DEM is several tiles) as
    one outline, their union, simplified outward (:func:`simplify_outward`), as tall as the
    tallest of them, under the index of the zone's first solid."""
    out = list(footprints_of(obstacles))
    drop: set[int] = set()
    for indices in groups:
        if not indices:
            continue
        first = indices[0]
        ring = _union_ring(out, indices)
        if ring is None:
            for i in indices:  # a circle, or pieces apart: each its own (simplified)
                fp = out[i]
                if fp.ring_enu is not None and len(fp.ring_enu) > max_vertices:
                    r, _ = simplify_outward(np.asarray(fp.ring_enu), max_vertices)
                    out[i] = Footprint(fp.index, fp.kind, fp.height_m, ring_enu=_tuples(r))
            continue
        ring, _ = simplify_outward(ring, max_vertices)
        height = max(out[i].height_m for i in indices)
        out[first] = Footprint(first, out[first].kind, height, ring_enu=_tuples(ring))
        drop.update(indices[1:])
    return tuple(fp for i, fp in enumerate(out) if i not in drop)


def _tuples(ring: NDArray[np.float64]) -> tuple[tuple[float, float], ...]:
    return tuple((float(x), float(y)) for x, y in ring)


def _union_ring(prints: Sequence[Footprint], indices: Sequence[int]) -> Any:
    """The one hole-free outline of these polygon footprints' union, or None (a circle,
    pieces apart, a hole)."""
    import shapely

    if any(prints[i].ring_enu is None for i in indices):
        return None
    if len(indices) == 1:
        return np.asarray(prints[indices[0]].ring_enu, dtype=np.float64)
    union = shapely.union_all([shapely.Polygon(prints[i].ring_enu) for i in indices])
    union = union.buffer(1e-6).buffer(-1e-6)  # tiles that touch: one outline
    if union.geom_type != "Polygon" or union.interiors:
        return None
    return np.asarray(union.exterior.coords, dtype=np.float64)[:-1]


def zone_fence_lines(
    built: FenceBuild,
    zones: Sequence[tuple[str, Sequence[int]]],
    obstacles: Sequence[Obstacle],
    max_vertices: int = ZONE_FENCE_VERTICES,
) -> list[str]:
    """One line per zone constraint (``(title, obstacle indices)``): fenced (and how far
    the simplified outline strays outside it), or why not."""
    status = {z.index: z for z in built.zones}
    prints = footprints_of(obstacles)
    lines = []
    for title, indices in zones:
        got = [status[i] for i in indices if i in status]
        if not got:
            continue
        kinds = {z.status for z in got}
        if kinds == {ZoneStatus.EXCLUDED}:
            error = 0.0
            whole = _union_ring(prints, indices)
            rings = [whole] if whole is not None else [prints[i].ring_enu for i in indices]
            for ring in rings:
                if ring is not None and len(ring) > max_vertices:
                    error = max(error, simplify_outward(np.asarray(ring), max_vertices)[1])
            shapes = _count(len(got), "exclusion zone")
            extra = (
                f", its outline simplified outward to at most {max_vertices} vertices (at most "
                f"{error:.1f} m outside the zone)"
                if error > 0
                else ""
            )
            lines.append(f"airspace: {title} fenced as {shapes}{extra}")
            continue
        # the route horizontally within the margin of a zone it keeps the margin from in 3-D
        # flies over it (a solid of a tiled zone may stand higher than the part flown over)
        over = [
            z
            for z in got
            if z.status is ZoneStatus.FLOWN_OVER
            or (z.status is ZoneStatus.TOO_CLOSE and z.route_distance_m < built.margin_m)
        ]
        if over:
            lines.append(
                f"airspace: {title} cannot be expressed in the fence: the route flies over it "
                "and an autopilot's exclusion zone has no floor or ceiling: it would forbid the "
                "route's own airspace"
            )
        if any(z.status is ZoneStatus.OVER_LIMIT for z in got):
            lines.append(
                f"airspace: {title} left out of the fence: the {built.max_items}-item limit is "
                "full (zones nearer the route come first)"
            )
        if any(z.status is ZoneStatus.TOO_CLOSE and z not in over for z in got):
            lines.append(
                f"airspace: {title} not in the fence: no room for an exclusion zone between it "
                "and the route"
            )
        if any(z.status is ZoneStatus.EXCLUDED for z in got) and len(kinds) > 1:
            lines.append(f"airspace: {title} partly fenced ({_parts(got)})")
    return lines


def _parts(zones: Sequence[Any]) -> str:
    counts: dict[str, int] = {}
    for z in zones:
        counts[z.status.value] = counts.get(z.status.value, 0) + 1
    return ", ".join(f"{n} {k.replace('_', ' ')}" for k, n in counts.items())


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"
