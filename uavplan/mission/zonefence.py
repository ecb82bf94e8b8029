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
    obstacles: Sequence[Obstacle], first_zone: int, max_vertices: int = ZONE_FENCE_VERTICES
) -> tuple[Footprint, ...]:
    """The footprints the fence is built from: the obstacles' own, with the zones' (from
    index ``first_zone`` on) simplified outward (:func:`simplify_outward`)."""
    out = list(footprints_of(obstacles))
    for i in range(first_zone, len(out)):
        fp = out[i]
        if fp.ring_enu is None or len(fp.ring_enu) <= max_vertices:
            continue
        ring, _ = simplify_outward(np.asarray(fp.ring_enu), max_vertices)
        out[i] = Footprint(fp.index, fp.kind, fp.height_m, ring_enu=tuple(map(tuple, ring)))
    return tuple(out)


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
            for i in indices:
                ring = prints[i].ring_enu
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
        over = [z for z in got if z.status is ZoneStatus.FLOWN_OVER]
        if over:
            lowest = min(z.height_above_top_m or 0.0 for z in over)
            lines.append(
                f"airspace: {title} cannot be expressed in the fence: the route flies over it "
                f"(at least {lowest:.1f} m above its top) and an autopilot's exclusion zone has "
                "no floor or ceiling: it would forbid the route's own airspace"
            )
        if any(z.status is ZoneStatus.OVER_LIMIT for z in got):
            lines.append(
                f"airspace: {title} left out of the fence: the {built.max_items}-item limit is "
                "full (zones nearer the route come first)"
            )
        if any(z.status is ZoneStatus.TOO_CLOSE for z in got):
            lines.append(
                f"airspace: {title} not in the fence: no room for an exclusion zone between it "
                "and the route"
            )
        if any(z.status is ZoneStatus.EXCLUDED for z in got):
            lines.append(f"airspace: {title} partly fenced ({_parts(got)})")
    return lines


def _parts(zones: Sequence[Any]) -> str:
    counts: dict[str, int] = {}
    for z in zones:
        counts[z.status.value] = counts.get(z.status.value, 0) + 1
    return ", ".join(f"{n} {k.replace('_', ' ')}" for k, n in counts.items())


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"
