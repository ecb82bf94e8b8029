"""The airspace of a rerouted QGroundControl plan (:mod:`uavplan.reroute`): its flight volume
and its obstacles, from the plan's geofence and an optional scenario (over terrain, the
scenario's site: z above its datum, obstacles standing on the ground), and the obstacles as a
stretch of the route holds them. Wiring: it knows the mission model and the scenario values.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from uavplan.errors import InputError
from uavplan.geo import EnuFrame
from uavplan.geometry2d import orient_ccw, polygon_problem
from uavplan.ground import Ground
from uavplan.limits import MAX_FENCE_POLYGON_VERTICES, MAX_FENCE_ZONES, MAX_HORIZONTAL_M
from uavplan.mission.items import MissionPlan
from uavplan.obstacles import Bounds, CylinderObstacle, Obstacle, PrismObstacle
from uavplan.scenario import Scenario, Surroundings

#: the flight volume's pad: around home, the positions and the zones (plus the safety margin)
#: and above the highest position; fence obstacles stand this much above the ceiling
VOLUME_PAD_M = 50.0
#: how messages name the obstacles that stand for the outside of the inclusion fence
OUTSIDE_INCLUSION = "the area outside the inclusion fence"
#: a circle of the fence becomes a polygon with this many vertices on the circle (inclusion)
CIRCLE_SEGMENTS = 64


@dataclass(frozen=True)
class Airspace:
    """Bounds and obstacles (with a name for each, for messages) of a reroute."""

    bounds: Bounds
    obstacles: tuple[Obstacle, ...]
    names: tuple[str, ...]
    inclusion: Any  # the shapely union of the inclusion zones in ENU, or None


def _ring_xy(frame: EnuFrame, vertices: Sequence[tuple[float, float]]) -> NDArray[np.float64]:
    lat = [v[0] for v in vertices]
    lon = [v[1] for v in vertices]
    return frame.to_enu_xy(lat, lon)


def build_airspace(
    plan: MissionPlan,
    points: NDArray[np.float64],
    frame: EnuFrame,
    *,
    margin_m: float,
    base: Scenario | Surroundings | None = None,
    file: str | None = None,
) -> Airspace:
    """The flight volume and obstacles for ``plan`` whose route flies through ``points``
    ``(n, 3)`` (ENU in ``frame``; see :mod:`uavplan.reroute`'s doc)."""
    import shapely

    fence = plan.fence
    exclusion_rings: list[tuple[NDArray[np.float64], str]] = []
    exclusion_circles: list[tuple[tuple[float, float], float, str]] = []
    inclusion_shapes: list[Any] = []
    n_poly = n_circ = 0
    zones = len(fence.polygons) + len(fence.circles)
    if zones > MAX_FENCE_ZONES:
        raise InputError(
            f"the geofence has {zones:,} polygons and circles; rerouting takes at most "
            f"{MAX_FENCE_ZONES:,}",
            file=file,
        )
    for i, poly in enumerate(fence.polygons):
        kind = "inclusion" if poly.inclusion else "exclusion"
        if len(poly.vertices) > MAX_FENCE_POLYGON_VERTICES:
            # the polygon checks and the convex pieces grow with the square of the vertices
            raise InputError(
                f"{kind} polygon {i + 1} of the geofence has {len(poly.vertices):,} vertices; "
                f"rerouting takes at most {MAX_FENCE_POLYGON_VERTICES:,} per polygon "
                "(simplify it, e.g. in QGroundControl's polygon editor)",
                file=file,
            )
        ring = _ring_xy(frame, poly.vertices)
        problem = polygon_problem(ring)
        if problem is not None:
            raise InputError(f"{kind} polygon {i + 1} of the geofence: {problem}", file=file)
        if poly.inclusion:
            inclusion_shapes.append(shapely.Polygon(ring))
        else:
            n_poly += 1
            exclusion_rings.append((orient_ccw(ring), f"exclusion polygon {n_poly} of the fence"))
    for circle in fence.circles:
        c = _ring_xy(frame, [circle.center])[0]
        center = (float(c[0]), float(c[1]))
        if circle.inclusion:
            # vertices on the circle, chords inside it: the polygon lies inside the circle,
            # so the outside we make into obstacles covers the true outside (conservative)
            quad = CIRCLE_SEGMENTS // 4
            inclusion_shapes.append(shapely.Point(center).buffer(circle.radius_m, quad_segs=quad))
        else:
            n_circ += 1
            exclusion_circles.append(
                (center, circle.radius_m, f"exclusion circle {n_circ} of the fence")
            )
    inclusion = shapely.union_all(inclusion_shapes) if inclusion_shapes else None

    pts = np.asarray(points, dtype=np.float64)
    top_m = float(pts[:, 2].max())
    # over terrain the scenario's site: z above its datum, obstacles standing on the ground
    ref = None if base is None else (base.site if base.terrain is not None else base)
    if ref is not None:
        z_hi = max(ref.bounds.z_m[1], 0.0)
        z_lo = 0.0 if base is not None and base.terrain is not None else ref.bounds.z_m[0]
    else:
        z_hi, z_lo = top_m + VOLUME_PAD_M, 0.0
        # the altitude fence the plan relies on (plan --fence writes it: FENCE_ALT_MAX,
        # GF_MAX_VER_DIST) is its ceiling: its return to launch may climb up to it
        for param in plan.parameters:
            if param.name in ("FENCE_ALT_MAX", "GF_MAX_VER_DIST") and param.value > 0:
                z_hi = max(z_hi, float(param.value))
    if inclusion is not None:
        x0, y0, x1, y1 = (float(v) for v in inclusion.bounds)
    elif ref is not None:
        (x0, x1), (y0, y1) = ref.bounds.x_m, ref.bounds.y_m
    else:
        home_xy = frame.to_enu_xy([plan.home.lat_deg], [plan.home.lon_deg]) if plan.home else None
        xs = [*pts[:, 0]] + ([float(home_xy[0, 0])] if home_xy is not None else [])
        ys = [*pts[:, 1]] + ([float(home_xy[0, 1])] if home_xy is not None else [])
        for ring, _ in exclusion_rings:
            xs.extend(ring[:, 0])
            ys.extend(ring[:, 1])
        for (cx, cy), r, _ in exclusion_circles:
            xs.extend((cx - r, cx + r))
            ys.extend((cy - r, cy + r))
        pad = VOLUME_PAD_M + margin_m
        x0, x1, y0, y1 = min(xs) - pad, max(xs) + pad, min(ys) - pad, max(ys) + pad
    bounds = Bounds((x0, x1), (y0, y1), (z_lo, z_hi))
    height_m = z_hi + VOLUME_PAD_M

    obstacles: list[Obstacle] = []
    names: list[str] = []
    if base is not None and ref is not None:
        obstacles.extend(ref.obstacles)
        source = base.source or base.name
        names.extend(
            f"{base.obstacle_name(i)} of scenario {source}" for i in range(len(base.obstacles))
        )
    for ring, name in exclusion_rings:
        obstacles.append(PrismObstacle(tuple((float(x), float(y)) for x, y in ring), height_m))
        names.append(name)
    for center, radius, name in exclusion_circles:
        obstacles.append(CylinderObstacle(center, radius, height_m))
        names.append(name)
    if inclusion is not None:
        box = shapely.box(x0, y0, x1, y1)
        for piece in simple_pieces(box.difference(inclusion)):
            ring = orient_ccw(np.asarray(piece.exterior.coords)[:-1])
            obstacles.append(PrismObstacle(tuple((float(x), float(y)) for x, y in ring), height_m))
            names.append(OUTSIDE_INCLUSION)
    return Airspace(bounds, tuple(obstacles), tuple(names), inclusion)


def check_volume(bounds: Bounds, file: str | None) -> None:
    """The flight volume the plan spans (its fence, its items) within the horizontal limit of
    any scenario."""
    far = max(abs(v) for v in (*bounds.x_m, *bounds.y_m))
    if far > MAX_HORIZONTAL_M:
        raise InputError(
            f"the plan and its geofence reach {far / 1000:,.0f} km from home, beyond the "
            f"{MAX_HORIZONTAL_M / 1000:,.0f} km a flight volume may span",
            file=file,
        )


def simple_pieces(geometry: Any) -> list[Any]:
    """Polygons without holes covering ``geometry`` (a box minus the inclusion zones): a
    piece with a hole is split by a vertical line through the hole, until none is left."""
    import shapely
    from shapely.ops import split

    todo = list(getattr(geometry, "geoms", [geometry]))
    done: list[Any] = []
    while todo:
        piece = todo.pop()
        if piece.geom_type != "Polygon" or piece.area < 1e-6:
            if piece.geom_type in ("MultiPolygon", "GeometryCollection"):
                todo.extend(piece.geoms)
            continue
        if not piece.interiors:
            done.append(piece)
            continue
        hx = shapely.Polygon(piece.interiors[0]).representative_point().x
        _, ymin, _, ymax = piece.bounds
        cut = shapely.LineString([(hx, ymin - 1.0), (hx, ymax + 1.0)])
        todo.extend(split(piece, cut).geoms)
    return done


def stretch_obstacles(
    obstacles: tuple[Obstacle, ...], ground: Ground | None
) -> tuple[Obstacle, ...]:
    """The airspace's obstacles as a stretch's scenario holds them: over terrain their
    heights above the ground at their centre (the scenario stands them there again)."""
    if ground is None:
        return obstacles
    out: list[Obstacle] = []
    for o in obstacles:
        if isinstance(o, PrismObstacle):
            xs, ys = zip(*o.polygon_m, strict=True)
            centre = (sum(xs) / len(xs), sum(ys) / len(ys))
        else:
            centre = o.center_m
        under = float(ground.z_at(np.array([centre]))[0])
        out.append(replace(o, height_m=o.height_m - under))
    return tuple(out)


def held_bounds(airspace: Bounds, base: Bounds) -> Bounds:
    """A stretch's bounds over terrain: the airspace's x, y and the scenario's own z (above
    the ground)."""
    return Bounds(airspace.x_m, airspace.y_m, base.z_m)
