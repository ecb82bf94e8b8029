"""A geofence for a planned route: obstacles as exclusion zones, the bounds as an inclusion zone.

A MAVLink geofence is two-dimensional: an exclusion polygon or circle forbids its area at
*every* altitude. So an obstacle can go into the fence only if nothing the vehicle flies
passes over it; an obstacle the route flies over cannot, or the vehicle would breach its own
fence on the way. What the vehicle flies is more than the straight legs between the
waypoints (issue 37): the track the autopilot flies (it cuts the corners, PX4 swings back
onto the next leg), the mission's end (the return to launch, a planned return) and, where the
mission relies on the autopilot's return, the failsafe returns from every point of the
flight. :func:`build_geofence` takes them all as ``route_enu`` (a polyline) and ``also``
(segments), and decides per obstacle from their horizontal distance to its footprint:

* every line keeps at least the safety margin from the footprint → the vehicle flies
  **around** it: it becomes an exclusion zone (``ZoneStatus.EXCLUDED``) that keeps the
  margin from every line, so the mission checked against its own fence (``validate`` /
  ``simulate`` / ``render`` of the ``.plan`` alone, and a second ``plan`` of it, which treat
  the zones as obstacles with the margin) keeps it too. The zone is the footprint grown by
  ``offset``: the margin where the lines are far, less where they pass closer than twice the
  margin plus :data:`ROUTE_GAP_M` (the gap is kept for the tracking error), down to the
  footprint itself;
* a line comes horizontally closer than the margin → over the footprint (or its margin
  ring) it is above the obstacle's top: it flies **over** it (``FLOWN_OVER``). Its lowest
  height above the top is reported. Were it below the top, the route would not be
  collision-free (``TOO_CLOSE``); no zone either.

Zones (ENU metres, then WGS84): a cylinder is a circle of radius ``r + offset``; a box or
prism footprint is offset outward with its corners cut by tangents to the rounded offset, so
the polygon *contains* the footprint grown by ``offset`` in every direction (conservative).
:attr:`ObstacleZone.offset_m` says what was used; :meth:`FenceBuild.notes` names the zones
that reach less than the margin. A corner is one mitre where the lines are far, and is cut
finer (down to :data:`MIN_CORNER_STEP_DEG` per cut) where they come close, to keep the item
count low. A concave prism whose offset would fold over itself is fenced by its convex hull.

The bounds' horizontal rectangle, grown by the margin and :data:`ROUTE_GAP_M` (at least
:data:`INCLUSION_BUFFER_M`), is the inclusion polygon: a route inside the bounds keeps the
margin from its edge, a start on the bounds' edge included.

Autopilots hold few fence items (one per polygon vertex, one per circle): PX4 releases
before 1.15 keep 63 (:data:`DEFAULT_MAX_ITEMS`; their first of 64 slots holds statistics).
Zones closest to the route come first; the rest are left out (``OVER_LIMIT``) and counted.
A zone is built only while the budget could still hold it, so the thousands of obstacles of
a city map that cannot be fenced cost one vectorised distance each (:func:`route_distances`).

This module is fence *policy*; the polygon geometry is :mod:`uavplan.geometry2d`. Nothing
here plans or reads a scenario: the inputs are plain values (obstacles or footprints, the
flown polyline in ENU or the :class:`~uavplan.route.PlannedRoute` carrying it, its
:class:`~uavplan.geo.EnuFrame`, the margin and the bounds).
"""

from __future__ import annotations

import enum
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uavplan import geometry2d as g2
from uavplan.geo import EnuFrame
from uavplan.mission.items import FenceCircle, FencePolygon, GeoFence
from uavplan.obstacles import Bounds, CylinderObstacle, Obstacle
from uavplan.route import PlannedRoute, densify

_Arr = NDArray[np.float64]

#: fence items we write at most: PX4 releases before 1.15 reserve 64 fence slots in dataman
#: and keep their statistics in the first, so 63 items fit (1.15 and later, and ArduPilot,
#: hold more). The inclusion polygon's 4 vertices count too.
DEFAULT_MAX_ITEMS = 63
#: rally points the same PX4 releases store (8 slots, the first holds the statistics); we
#: write none, the constant is here so the limit is written down next to the fence's
PX4_MAX_RALLY_POINTS = 7
#: beyond the safety margin, a zone leaves the lines this much more room where there is room
#: for it (about a multirotor's GNSS tracking error, and ArduPilot's default FENCE_MARGIN)
ROUTE_GAP_M = 2.0
#: the inclusion polygon is the bounds rectangle grown by at least this (GPS noise at a start
#: on the edge; it grows by the margin and ROUTE_GAP_M when that is more)
INCLUSION_BUFFER_M = 5.0
#: a corner is cut by tangents covering at most 90 degrees of turn each (a box corner: one
#: mitre) and, where the route passes close, down to this angle (more vertices, closer fit)
MIN_CORNER_STEP_DEG = 22.5
#: two horizontal distances closer than this are equal (the route may touch the margin exactly)
DISTANCE_TOL_M = 1e-6
#: spacing of the samples used to measure the route's height over a flown-over obstacle
SAMPLE_STEP_M = 1.0


# ---------------------------------------------------------------------------------------------
# Inputs


@dataclass(frozen=True)
class Footprint:
    """An obstacle as the fence and the exporters see it: a ground shape and a height.

    Either ``ring_enu`` (a simple polygon, counter-clockwise, ENU metres, not closed) or
    ``center_enu`` + ``radius_m`` (a circle). ``kind`` is ``"box"``, ``"prism"`` or
    ``"cylinder"``; ``index`` is the obstacle's position in the scenario.
    """

    index: int
    kind: str
    height_m: float
    ring_enu: tuple[tuple[float, float], ...] | None = None
    center_enu: tuple[float, float] | None = None
    radius_m: float | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.height_m) and self.height_m > 0):
            raise ValueError(f"footprint height must be > 0 m, got {self.height_m!r}")
        if self.ring_enu is not None:
            ring = tuple((float(x), float(y)) for x, y in self.ring_enu)
            if len(ring) < 3:
                raise ValueError("a footprint polygon needs at least 3 vertices")
            if g2.signed_area(ring) < 0:
                ring = ring[::-1]
            object.__setattr__(self, "ring_enu", ring)
        elif self.center_enu is None or self.radius_m is None or not self.radius_m > 0:
            raise ValueError("a footprint is a polygon (ring_enu) or a circle (center, radius)")

    @property
    def is_circle(self) -> bool:
        return self.ring_enu is None

    def outline_enu(self, segments: int = 48) -> NDArray[np.float64]:
        """The ground outline as a counter-clockwise ring ``(k, 2)`` (circles as polygons)."""
        if self.ring_enu is not None:
            return np.asarray(self.ring_enu, dtype=np.float64)
        assert self.center_enu is not None and self.radius_m is not None
        return g2.circle_ring(self.center_enu, self.radius_m, segments)


def footprints_of(obstacles: Iterable[Obstacle | Footprint]) -> tuple[Footprint, ...]:
    """Footprints of obstacle values (:mod:`uavplan.obstacles`), in order; footprints pass
    through unchanged (their ``index`` kept)."""
    out: list[Footprint] = []
    for index, obstacle in enumerate(obstacles):
        if isinstance(obstacle, Footprint):
            out.append(obstacle)
        elif isinstance(obstacle, CylinderObstacle):
            cx, cy = obstacle.center_m
            out.append(
                Footprint(
                    index,
                    obstacle.kind,
                    float(obstacle.height_m),
                    center_enu=(float(cx), float(cy)),
                    radius_m=float(obstacle.radius_m),
                )
            )
        else:
            ring = tuple(obstacle.footprint())
            out.append(Footprint(index, obstacle.kind, float(obstacle.height_m), ring_enu=ring))
    return tuple(out)


# ---------------------------------------------------------------------------------------------
# Results


class ZoneStatus(enum.Enum):
    EXCLUDED = "excluded"  # in the fence as an exclusion zone
    FLOWN_OVER = "flown_over"  # the route passes above it; a 2-D zone would contain the route
    TOO_CLOSE = "too_close"  # no room for a zone beside the route (or the route hits it)
    OVER_LIMIT = "over_limit"  # left out: the fence would hold more than max_items


@dataclass(frozen=True)
class ObstacleZone:
    """What the fence does with one obstacle.

    ``route_distance_m``: smallest horizontal distance from the flown route to the footprint.
    ``offset_m``: how far the zone reaches beyond the footprint (EXCLUDED; for OVER_LIMIT
    the most it could have reached: a zone left out is not built, so it has no polygon).
    ``height_above_top_m``: FLOWN_OVER / TOO_CLOSE: the route's lowest height above the
    obstacle top where it is horizontally within the margin of the footprint.
    ``polygon_enu`` (``(k, 2)``, counter-clockwise) or ``circle_enu`` (x, y, radius): the zone.
    """

    index: int
    status: ZoneStatus
    route_distance_m: float
    offset_m: float | None = None
    height_above_top_m: float | None = None
    polygon_enu: NDArray[np.float64] | None = None
    circle_enu: tuple[float, float, float] | None = None

    @property
    def item_count(self) -> int:
        if self.polygon_enu is not None:
            return int(self.polygon_enu.shape[0])
        return 1 if self.circle_enu is not None else 0


@dataclass(frozen=True)
class FenceBuild:
    """The fence and how it was made (one :class:`ObstacleZone` per obstacle, in order)."""

    fence: GeoFence
    inclusion_enu: NDArray[np.float64]  # (4, 2) counter-clockwise
    zones: tuple[ObstacleZone, ...]
    margin_m: float
    max_items: int
    ceiling_m: float | None = None  # bounds' top: a .plan fence has no altitude limit

    @property
    def item_count(self) -> int:
        return len(self.fence.wire_items())

    def with_status(self, status: ZoneStatus) -> list[int]:
        return [z.index for z in self.zones if z.status is status]

    def summary(self) -> str:
        """One line: what went into the fence and what did not, as counts and sizes (how
        far from the route the fenced and the nearest left-out obstacles are, how high above
        the flown-over ones the route passes), never a list of obstacles: a district of
        thousands of buildings gets the same short line as a field of five."""
        by = {status: [z for z in self.zones if z.status is status] for status in ZoneStatus}
        fenced = by[ZoneStatus.EXCLUDED]
        circles = sum(z.circle_enu is not None for z in fenced)
        kinds = [
            _count(len(fenced) - circles, "polygon"),
            _count(circles, "circle"),
        ]
        parts = [f"{_count(len(fenced), 'exclusion zone')}"]
        if fenced:
            farthest = max(z.route_distance_m for z in fenced)
            parts[0] += f" ({', '.join(k for k in kinds if not k.startswith('0 '))}, up to "
            parts[0] += f"{farthest:.1f} m from the route)"
        over = by[ZoneStatus.FLOWN_OVER]
        if over:
            lowest = min(z.height_above_top_m or 0.0 for z in over)
            parts.append(
                f"{_count(len(over), 'obstacle')} flown over (the route at least "
                f"{lowest:.1f} m above {'its top' if len(over) == 1 else 'their tops'})"
            )
        left = by[ZoneStatus.OVER_LIMIT]
        if left:
            nearest = min(z.route_distance_m for z in left)
            parts.append(
                f"{_count(len(left), 'obstacle')} left out (over the {self.max_items}-item "
                f"limit; the nearest {nearest:.1f} m from the route)"
            )
        close = by[ZoneStatus.TOO_CLOSE]
        if close:
            parts.append(f"{_count(len(close), 'obstacle')} too close to the route to fence")
        return (
            f"geofence: inclusion polygon + {'; '.join(parts)}; "
            f"{self.item_count} of at most {self.max_items} fence items"
        )

    def notes(self) -> list[str]:
        """Things an operator must know before flying with this fence."""
        notes: list[str] = []
        shrunk = [
            z.offset_m
            for z in self.zones
            if z.status is ZoneStatus.EXCLUDED
            and z.offset_m is not None
            and z.offset_m < self.margin_m - 1e-9
        ]
        if shrunk:
            lo, hi = min(shrunk), max(shrunk)
            reach = f"{lo:.1f}-{hi:.1f}" if f"{lo:.1f}" != f"{hi:.1f}" else f"{hi:.1f}"
            notes.append(
                f"the flight passes close to {_count(len(shrunk), 'fenced obstacle')}: "
                f"{'their zones reach' if len(shrunk) > 1 else 'its zone reaches'} {reach} m "
                f"beyond the footprint, less than the {self.margin_m:g} m margin (a zone keeps "
                "the margin from the flown track)"
            )
        if self.ceiling_m is not None:
            notes.append(
                f"a .plan fence has no altitude: its ceiling, {self.ceiling_m:g} m, is the "
                "autopilot's maximum altitude (PX4 GF_MAX_VER_DIST, ArduPilot FENCE_ALT_MAX), "
                "which upload --set-params sets"
            )
        return notes


def _count(n: int, noun: str) -> str:
    """``3 obstacles``, ``1 obstacle``, ``4,909 obstacles``."""
    return f"{n:,} {noun}" if n == 1 else f"{n:,} {noun}s"


# ---------------------------------------------------------------------------------------------
# Building


def build_geofence(
    obstacles: Sequence[Obstacle | Footprint],
    route_enu: ArrayLike,
    frame: EnuFrame,
    *,
    bounds_xy_m: tuple[tuple[float, float], tuple[float, float]],
    margin_m: float,
    ceiling_m: float | None = None,
    max_items: int = DEFAULT_MAX_ITEMS,
    inclusion_buffer_m: float = INCLUSION_BUFFER_M,
    route_gap_m: float = ROUTE_GAP_M,
    also: tuple[ArrayLike, ArrayLike] | None = None,
) -> FenceBuild:
    """The geofence for a route flown through obstacles.

    ``obstacles``: :mod:`uavplan.obstacles` values or :class:`Footprint`\\ s, ENU metres in
    ``frame``. ``route_enu``: ``(n, 3)`` the flown polyline (the take-off climb from the
    ground, the straight legs between waypoints; :attr:`PlannedRoute.flown_enu`).
    ``also``: more lines the vehicle flies, as segments ``(a, b)`` each ``(m, 3)``: the
    autopilot's track, the failsafe returns. ``bounds_xy_m``: ``((x_min, x_max), (y_min,
    y_max))``. ``max_items`` counts every fence item (polygon vertices, circles) including the
    4 of the inclusion polygon.
    """
    footprints = footprints_of(obstacles)
    route = np.asarray(route_enu, dtype=np.float64)
    if route.ndim != 2 or route.shape[1] != 3 or route.shape[0] < 1:
        raise ValueError(f"route_enu must have shape (n >= 1, 3), got {route.shape}")
    if not np.all(np.isfinite(route)):
        raise ValueError("route_enu must be finite")
    if not (math.isfinite(margin_m) and margin_m >= 0):
        raise ValueError(f"margin must be >= 0 m, got {margin_m!r}")
    if max_items < 4:
        raise ValueError("max_items must leave room for the 4-vertex inclusion polygon")
    (x0, x1), (y0, y1) = bounds_xy_m
    b = max(float(inclusion_buffer_m), float(margin_m) + float(route_gap_m))
    inclusion = np.array([[x0 - b, y0 - b], [x1 + b, y0 - b], [x1 + b, y1 + b], [x0 - b, y1 + b]])

    seg_a, seg_b = g2.polyline_segments(route)
    samples_3d = [route]
    if also is not None:
        more_a = np.asarray(also[0], dtype=np.float64).reshape(-1, 3)
        more_b = np.asarray(also[1], dtype=np.float64).reshape(-1, 3)
        if len(more_a):
            seg_a = np.vstack([seg_a, more_a[:, :2]])
            seg_b = np.vstack([seg_b, more_b[:, :2]])
            samples_3d.append(_segment_samples(more_a, more_b, SAMPLE_STEP_M))
    distances = route_distances(footprints, seg_a, seg_b)
    zones: list[ObstacleZone | None] = [None] * len(footprints)
    near = distances < margin_m - DISTANCE_TOL_M
    if near.any():
        # where the lines' height over a top is read
        samples = np.vstack([densify(route, SAMPLE_STEP_M), *samples_3d[1:]])
        for i in np.flatnonzero(near):
            fp, distance = footprints[i], float(distances[i])
            lowest = _height_above_top(fp, samples, margin_m)
            status = ZoneStatus.FLOWN_OVER if lowest >= -DISTANCE_TOL_M else ZoneStatus.TOO_CLOSE
            zones[i] = ObstacleZone(fp.index, status, distance, height_above_top_m=lowest)

    # The fence item budget: zones nearest the route first (they matter most). A zone is
    # built only while the budget could still hold it (a circle is one item, a box's polygon
    # at least four, any polygon at least three); the rest are left out unbuilt.
    budget = max_items - inclusion.shape[0]
    far = np.flatnonzero(~near)
    for i in far[np.lexsort((far, distances[far]))]:
        fp, distance = footprints[i], float(distances[i])
        # the fewest items its zone can take (a circle 1, a polygon its footprint's convex
        # hull's corners): a zone that cannot fit is left out unbuilt
        if budget < _fewest_items(fp, budget):
            zones[i] = _left_out(fp, distance, margin_m, route_gap_m)
            continue
        zone = _zone(fp, distance, seg_a, seg_b, margin_m, route_gap_m)
        if zone.status is ZoneStatus.EXCLUDED:
            if zone.item_count <= budget:
                budget -= zone.item_count
            else:
                zone = _replace_status(zone, ZoneStatus.OVER_LIMIT)
        zones[i] = zone
    done = tuple(z for z in zones if z is not None)
    fence = _to_geofence(inclusion, [z for z in done if z.status is ZoneStatus.EXCLUDED], frame)
    return FenceBuild(fence, inclusion, done, float(margin_m), int(max_items), ceiling_m)


def geofence_for_route(
    route: PlannedRoute,
    obstacles: Sequence[Obstacle | Footprint],
    bounds: Bounds,
    *,
    max_items: int = DEFAULT_MAX_ITEMS,
    also: tuple[ArrayLike, ArrayLike] | None = None,
) -> FenceBuild:
    """The geofence for a planned route: its flown polyline (and ``also``, the other lines
    the vehicle flies: :func:`build_geofence`), frame and safety margin, the obstacles it
    was planned through and the flight volume ``bounds`` (its top becomes the altitude
    note)."""
    return build_geofence(
        obstacles,
        route.flown_enu,
        route.frame,
        bounds_xy_m=(bounds.x_m, bounds.y_m),
        margin_m=route.safety_margin_m,
        ceiling_m=bounds.z_m[1],
        max_items=max_items,
        also=also,
    )


def _replace_status(zone: ObstacleZone, status: ZoneStatus) -> ObstacleZone:
    return replace(zone, status=status)


def _fewest_items(fp: Footprint, budget: int) -> int:
    """A lower bound on the fence items ``fp``'s zone takes: 1 for a circle; for a polygon
    3, and, once the budget is small, its convex hull's corner count (an offset ring has at
    least its ring's corners, the hull fallback the hull's)."""
    if fp.is_circle:
        return 1
    if fp.kind == "box":
        return 4
    if budget >= 8 or fp.ring_enu is None:
        return 3
    return len(g2.convex_hull(fp.outline_enu()))


def _segment_samples(a: _Arr, b: _Arr, step_m: float) -> _Arr:
    """Points ``(k, 3)`` at most ``step_m`` apart along each segment ``a[i]`` → ``b[i]``."""
    span = np.linalg.norm(b - a, axis=1)
    k = np.maximum(1, np.ceil(span / step_m).astype(np.int64))
    seg = np.repeat(np.arange(len(a)), k + 1)
    t = (np.arange(int((k + 1).sum())) - np.repeat(np.cumsum(k + 1) - (k + 1), k + 1)) / np.repeat(
        k, k + 1
    )
    return a[seg] + t[:, None] * (b[seg] - a[seg])


def _offset_for(distance: float, margin_m: float, gap_m: float) -> float | None:
    """How far a zone may reach beyond a footprint ``distance`` from the lines and still
    keep the margin from them (the gap too where there is room): between 0 (the footprint
    itself) and the margin; None where the lines pass within the margin."""
    room = distance - margin_m
    if room < -DISTANCE_TOL_M:
        return None
    return min(margin_m, max(0.0, room - gap_m))


def _left_out(fp: Footprint, distance: float, margin_m: float, gap_m: float) -> ObstacleZone:
    """The zone of an obstacle the route flies around that the item budget cannot hold, not
    built: left out (``OVER_LIMIT``), or ``TOO_CLOSE`` where :func:`_zone` would find no room
    for a zone beside the lines (they pass within the margin of the footprint)."""
    offset = _offset_for(distance, margin_m, gap_m)
    if offset is None:
        return ObstacleZone(fp.index, ZoneStatus.TOO_CLOSE, distance)
    return ObstacleZone(fp.index, ZoneStatus.OVER_LIMIT, distance, offset_m=offset)


def _zone(
    fp: Footprint,
    distance: float,
    seg_a: _Arr,
    seg_b: _Arr,
    margin_m: float,
    gap_m: float,
) -> ObstacleZone:
    """The exclusion zone of an obstacle the lines fly around (``distance`` from them, at
    least the margin): the footprint grown by what keeps the margin (and the gap, where
    there is room) from every line; ``TOO_CLOSE`` when not even the footprint does."""
    offset = _offset_for(distance, margin_m, gap_m)
    if offset is None:
        return ObstacleZone(fp.index, ZoneStatus.TOO_CLOSE, distance)
    if fp.is_circle:
        assert fp.center_enu is not None and fp.radius_m is not None
        cx, cy = fp.center_enu
        return ObstacleZone(
            fp.index,
            ZoneStatus.EXCLUDED,
            distance,
            offset_m=offset,
            circle_enu=(cx, cy, fp.radius_m + offset),
        )

    ring = fp.outline_enu()
    keep = margin_m + gap_m  # what a grown zone leaves the lines
    for outline in (ring, g2.convex_hull(ring)):  # the hull if the ring's offset folds
        made = _polygon_zone(outline, margin_m, seg_a, seg_b, keep)
        if made is None:
            break  # no room to grow it: the footprint itself, below
        polygon, grown = made
        if polygon is None:
            continue
        if g2.segments_polygon_distance(seg_a, seg_b, polygon).min() < keep - 1e-6:
            break  # pragma: no cover - the construction guarantees the gap
        return ObstacleZone(
            fp.index, ZoneStatus.EXCLUDED, distance, offset_m=grown, polygon_enu=polygon
        )
    # the footprint itself keeps the margin from the lines (distance >= margin)
    return ObstacleZone(fp.index, ZoneStatus.EXCLUDED, distance, offset_m=0.0, polygon_enu=ring)


def _polygon_zone(
    ring: _Arr, margin_m: float, seg_a: _Arr, seg_b: _Arr, gap_m: float
) -> tuple[_Arr | None, float] | None:
    """The exclusion polygon for ``ring`` and its offset, keeping ``gap_m`` to the route.

    Every point of an offset polygon lies within ``offset`` of the ring, or within
    ``offset / cos(step / 2)`` of a convex corner (its tangent cut, ``step`` the angle per
    cut). So the offset is at most the route's distance minus the gap, and each corner gets
    as few cuts as its own distance to the route allows (a mitre when the route is far).
    Returns None if no positive offset fits, ``(None, offset)`` if the offset folds over.
    """
    distance = float(g2.segments_polygon_distance(seg_a, seg_b, ring).min())
    offset = min(margin_m, distance - gap_m)
    if offset <= 0:
        return None
    turns = g2.turn_angles(ring)
    corner_room = g2.point_segment_distance(ring[:, None, :], seg_a[None], seg_b[None]).min(axis=1)
    corner_room = corner_room - gap_m  # how far each corner's cuts may reach
    finest = math.radians(MIN_CORNER_STEP_DEG)
    convex = turns > 1e-12
    # Corners the route passes so close that even the finest cuts reach too far set the offset.
    worst = np.where(convex, corner_room * np.cos(g2.cut_step_angles(turns, finest) / 2.0), np.inf)
    offset = float(min(offset, worst.min()))
    if offset <= 0:
        return None
    with np.errstate(divide="ignore", invalid="ignore"):
        allowed = 2.0 * np.arccos(np.clip(offset / corner_room, -1.0, 1.0))
    allowed = np.clip(np.nan_to_num(allowed, nan=finest), finest, math.radians(90.0))
    steps = np.where(convex, np.ceil(turns / allowed - 1e-9), 1).astype(int)
    steps = np.maximum(steps, 1)
    return g2.offset_ring(ring, offset, steps), offset


def _to_geofence(
    inclusion: NDArray[np.float64], zones: Sequence[ObstacleZone], frame: EnuFrame
) -> GeoFence:
    polygons = [FencePolygon(_latlon_clockwise(inclusion, frame), inclusion=True)]
    circles = []
    for zone in zones:
        if zone.polygon_enu is not None:
            polygons.append(
                FencePolygon(_latlon_clockwise(zone.polygon_enu, frame), inclusion=False)
            )
        elif zone.circle_enu is not None:
            cx, cy, radius = zone.circle_enu
            lat, lon, _ = frame.to_geodetic([cx, cy, 0.0])
            circles.append(FenceCircle((float(lat[0]), float(lon[0])), radius, inclusion=False))
    return GeoFence(tuple(polygons), tuple(circles))


def _latlon_clockwise(ring_enu: NDArray[np.float64], frame: EnuFrame) -> tuple:
    """A counter-clockwise ENU ring as (lat, lon) vertices, clockwise (QGC's convention)."""
    ring = ring_enu[::-1]
    lat, lon, _ = frame.to_geodetic(np.column_stack((ring, np.zeros(len(ring)))))
    return tuple((float(a), float(o)) for a, o in zip(lat, lon, strict=True))


# ---------------------------------------------------------------------------------------------
# Distances and heights between a footprint and the flown route


def route_distances(
    footprints: Sequence[Footprint], seg_a: NDArray[np.float64], seg_b: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Smallest horizontal distance ``(n,)`` from the route's segments to each footprint's
    region (0 where the route enters it), for all footprints at once
    (:func:`~uavplan.geometry2d.segments_rings_distance`, circles apart)."""
    n = len(footprints)
    out = np.empty(n)
    circles = [i for i, fp in enumerate(footprints) if fp.is_circle]
    polygons = [i for i, fp in enumerate(footprints) if not fp.is_circle]
    if circles:
        centres = np.array([footprints[i].center_enu for i in circles], dtype=np.float64)
        radii = np.array([footprints[i].radius_m for i in circles], dtype=np.float64)
        out[circles] = g2.segments_circles_distance(seg_a, seg_b, centres, radii)
    if polygons:
        rings = [footprints[i].ring_enu or () for i in polygons]
        sizes = np.fromiter((len(r) for r in rings), dtype=np.int64, count=len(rings))
        edge_a = np.array([xy for r in rings for xy in r], dtype=np.float64)
        ends = np.cumsum(sizes)
        after = np.arange(1, len(edge_a) + 1)
        after[ends - 1] = ends - sizes  # each ring's last vertex closes on its first
        edge_b = edge_a[after]
        owner = np.repeat(np.arange(len(rings), dtype=np.int64), sizes)
        out[polygons] = g2.segments_rings_distance(seg_a, seg_b, edge_a, edge_b, owner, len(rings))
    return out


def _height_above_top(fp: Footprint, samples: NDArray[np.float64], margin_m: float) -> float:
    """Lowest ``z - height`` of the route (``samples`` ``(n, 3)`` along it) where it is
    horizontally within the margin of the footprint."""
    xy = samples[:, :2]
    if fp.is_circle:
        assert fp.center_enu is not None and fp.radius_m is not None
        lo = np.asarray(fp.center_enu) - fp.radius_m
        hi = np.asarray(fp.center_enu) + fp.radius_m
    else:
        ring = np.asarray(fp.ring_enu)
        lo, hi = ring.min(axis=0), ring.max(axis=0)
    # the samples within the margin lie in the footprint's box grown by it
    box = np.all((xy >= lo - margin_m) & (xy <= hi + margin_m), axis=1)
    d = _sample_distances(fp, xy[box])
    near = d < margin_m - DISTANCE_TOL_M
    if near.any():
        return float((samples[box][near, 2] - fp.height_m).min())
    d = _sample_distances(fp, xy)  # only a segment interior comes close: its nearer end
    return float((samples[d <= d.min() + 1e-9, 2] - fp.height_m).min())


def _sample_distances(fp: Footprint, xy: NDArray[np.float64]) -> NDArray[np.float64]:
    if fp.is_circle:
        assert fp.center_enu is not None and fp.radius_m is not None
        return np.hypot(*(xy - np.asarray(fp.center_enu)).T) - fp.radius_m
    return g2.points_polygon_distance(xy, fp.outline_enu())
