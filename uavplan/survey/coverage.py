"""Area coverage around holes: parallel lanes clipped to the free area, in flying order.

Pure plane geometry in local ENU metres (numpy + shapely): no files, no MAVLink, no world.

* :func:`holes` — every ``exclude`` polygon and every obstacle whose top reaches above the
  survey altitude minus the margin, each buffered by the margin;
* :func:`lanes` — parallel lane lines at the sweep angle, spaced so the first and the last lie
  at most half a spacing inside the area, each clipped against (area − holes); every piece is
  kept (Mission Planner's rule: a lane split by a hole becomes two pieces), so no piece crosses
  a hole and every piece runs to the boundary;
* :func:`order` — the pieces in flying order from a start point: nearest free end first
  (boustrophedon on a convex area), each piece flown from its nearer end;
* :func:`photo_positions` / :func:`covered_fraction` — where distance triggering takes photos
  and how much of the free area their footprints cover.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray
from shapely.geometry import LineString, MultiPolygon, Point, Polygon
from shapely.geometry.base import BaseGeometry

from uavplan.obstacles import CylinderObstacle, Obstacle

#: pieces shorter than this (m) are dropped: a lane grazing a corner of the free area
MIN_PIECE_M = 1e-6

#: what a hole keeps beyond the margin (m): a lane ends exactly on the grown hole, so a
#: transition that leaves that end at a slant would otherwise graze the margin
HOLE_SLACK_M = 0.1

#: segments per quarter circle of a buffered hole or a cylinder
QUAD_SEGS = 8


def _outer_buffer(geom: BaseGeometry, distance_m: float) -> BaseGeometry:
    """``geom`` grown by at least ``distance_m`` everywhere: shapely's round joins are chords
    inside the circle, so the radius is raised until the chords' midpoints lie on it."""
    if distance_m <= 0:
        return geom
    return geom.buffer(distance_m / math.cos(math.pi / (4 * QUAD_SEGS)), quad_segs=QUAD_SEGS)


def polygon(points_m: ArrayLike, key: str = "polygon") -> Polygon:
    """A valid shapely polygon from ``(n, 2)`` ENU points (n ≥ 3, non-zero area)."""
    p = np.asarray(points_m, dtype=np.float64)
    if p.ndim != 2 or p.shape[0] < 3 or p.shape[1] != 2 or not np.all(np.isfinite(p)):
        raise ValueError(f"{key} must be a list of at least 3 finite [x, y] points")
    poly = Polygon(p)
    if not poly.is_valid or poly.area <= 0:
        raise ValueError(f"{key} must be a simple polygon with an area (no self-crossing)")
    return poly


def _footprint(obstacle: Obstacle) -> BaseGeometry:
    if isinstance(obstacle, CylinderObstacle):
        return _outer_buffer(Point(obstacle.center_m), obstacle.radius_m)
    return Polygon(obstacle.footprint())


def holes(
    obstacles: Sequence[Obstacle],
    exclude: Sequence[Polygon],
    *,
    altitude_m: float,
    margin_m: float,
) -> BaseGeometry:
    """The union of every ``exclude`` polygon and every obstacle footprint whose top is above
    ``altitude_m − margin_m`` (heights above the ground), each grown by ``margin_m`` and
    :data:`HOLE_SLACK_M`."""
    shapes: list[BaseGeometry] = list(exclude)
    shapes += [_footprint(o) for o in obstacles if o.height_m > altitude_m - margin_m]
    if not shapes:
        return Polygon()
    return shapely.union_all([_outer_buffer(s, margin_m + HOLE_SLACK_M) for s in shapes])


def free_area(area: Polygon, hole: BaseGeometry) -> BaseGeometry:
    """``area`` minus ``hole``: where lanes may run."""
    return area.difference(hole) if not hole.is_empty else area


def _rotation(angle_deg: float) -> NDArray[np.float64]:
    a = math.radians(angle_deg)
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def lane_offsets_m(width_m: float, spacing_m: float) -> NDArray[np.float64]:
    """Offsets (m) of the lane lines across an extent of ``width_m`` from its low edge: the
    fewest lanes ``spacing_m`` apart whose outer lanes lie at most half a spacing inside."""
    if not spacing_m > 0:
        raise ValueError("lane spacing must be > 0")
    n = max(1, math.ceil(width_m / spacing_m - 1e-9))
    first = (width_m - (n - 1) * spacing_m) / 2.0
    return first + spacing_m * np.arange(n, dtype=np.float64)


def lanes(
    area: Polygon, free: BaseGeometry, *, angle_deg: float, spacing_m: float
) -> NDArray[np.float64]:
    """Lane pieces ``(n, 2, 2)`` (piece, end, xy) along ``angle_deg`` (CCW from east), the
    lane lines spaced over ``area`` and clipped against ``free``; ordered lane by lane across
    the area, pieces of one lane in the sweep direction."""
    rot = _rotation(angle_deg)
    # the area in the lane frame: lanes run along +u, spaced along v
    corners = np.asarray(area.exterior.coords, dtype=np.float64) @ rot
    u0, v0 = corners.min(axis=0) - 1.0
    u1, v1 = corners.max(axis=0) + 1.0
    vs = v0 + 1.0 + lane_offsets_m(v1 - v0 - 2.0, spacing_m)
    lines_uv = np.stack(
        [np.column_stack([np.full_like(vs, u0), vs]), np.column_stack([np.full_like(vs, u1), vs])],
        axis=1,
    )
    lines_xy = lines_uv @ rot.T
    clipped = shapely.intersection(shapely.linestrings(lines_xy), free)
    pieces: list[NDArray[np.float64]] = []
    for geom in clipped:
        for part in shapely.get_parts(geom):
            if not isinstance(part, LineString) or part.length < MIN_PIECE_M:
                continue
            xy = np.asarray(part.coords, dtype=np.float64)
            ends = np.array([xy[0], xy[-1]])
            if (ends @ rot)[0, 0] > (ends @ rot)[1, 0]:
                ends = ends[::-1]
            pieces.append(ends)
    if not pieces:
        return np.zeros((0, 2, 2))
    out = np.array(pieces)
    # lane by lane (v), then along the lane (u)
    uv = out[:, 0, :] @ rot
    keys = np.lexsort((uv[:, 0], np.round(uv[:, 1], 6)))
    return out[keys]


def order(pieces: NDArray[np.float64], start_xy: ArrayLike) -> NDArray[np.float64]:
    """``pieces`` ``(n, 2, 2)`` in flying order from ``start_xy``: each next piece is the one
    with the free end nearest to where the last ended, flown from that end."""
    rest = np.asarray(pieces, dtype=np.float64).copy()
    at = np.asarray(start_xy, dtype=np.float64)[:2]
    out = np.empty_like(rest)
    alive = np.ones(len(rest), dtype=bool)
    for k in range(len(rest)):
        d = np.linalg.norm(rest - at, axis=2)  # (n, 2)
        d[~alive] = np.inf
        i, end = np.unravel_index(int(np.argmin(d)), d.shape)
        piece = rest[i] if end == 0 else rest[i][::-1]
        out[k] = piece
        alive[i] = False
        at = piece[1]
    return out


def path_xy(ordered: NDArray[np.float64], start_xy: ArrayLike) -> NDArray[np.float64]:
    """The straight-line flight ``(m, 2)``: start, every piece end to end, back to start."""
    s = np.asarray(start_xy, dtype=np.float64)[:2]
    return np.vstack([s, ordered.reshape(-1, 2), s])


def runs(n: int, joined: ArrayLike | None) -> list[tuple[int, int]]:
    """The lanes of ``n`` pieces as ``[first, last)`` piece ranges: a piece whose ``joined``
    flag is set continues the lane of the piece before it (a corridor's lane bends); without
    flags every piece is a lane."""
    if joined is None:
        return [(k, k + 1) for k in range(n)]
    j = np.asarray(joined, dtype=bool).copy()
    if n:
        j[0] = False
    starts = np.flatnonzero(~j)
    return [(int(a), int(b)) for a, b in zip(starts, [*starts[1:], n], strict=True)]


def photos_along(
    ordered: NDArray[np.float64], trigger_m: float, joined: ArrayLike | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Where distance triggering takes photos ``(k, 2)`` and the lane's direction there
    (degrees CCW from east, ``(k,)``): at each lane's start and then every ``trigger_m`` of
    path along it (the autopilots take the first photo when triggering starts, and count the
    distance flown along a lane through its bends)."""
    if not trigger_m > 0:
        raise ValueError("trigger distance must be > 0")
    pos: list[NDArray[np.float64]] = []
    head: list[NDArray[np.float64]] = []
    for a, b in runs(len(ordered), joined):
        lane = ordered[a:b]
        seg = lane[:, 1] - lane[:, 0]
        lengths = np.hypot(seg[:, 0], seg[:, 1])
        cum = np.concatenate(([0.0], np.cumsum(lengths)))
        s = np.arange(0.0, cum[-1] + 1e-9, trigger_m)
        k = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(lane) - 1)
        t = np.where(lengths[k] > 0, (s - cum[k]) / np.maximum(lengths[k], 1e-12), 0.0)
        pos.append(lane[k, 0] + t[:, None] * seg[k])
        head.append(np.degrees(np.arctan2(seg[k, 1], seg[k, 0])))
    if not pos:
        return np.zeros((0, 2)), np.zeros(0)
    return np.vstack(pos), np.concatenate(head)


def photo_positions(
    ordered: NDArray[np.float64], trigger_m: float, joined: ArrayLike | None = None
) -> NDArray[np.float64]:
    """Where distance triggering takes photos ``(k, 2)`` (see :func:`photos_along`)."""
    return photos_along(ordered, trigger_m, joined)[0]


def photo_count(
    ordered: NDArray[np.float64], trigger_m: float, joined: ArrayLike | None = None
) -> int:
    """How many photos distance triggering takes over ``ordered`` (see :func:`photos_along`)."""
    lengths = np.hypot(*(ordered[:, 1] - ordered[:, 0]).T) if len(ordered) else np.zeros(0)
    per_lane = np.array([lengths[a:b].sum() for a, b in runs(len(ordered), joined)])
    return int(np.sum(np.floor(per_lane / trigger_m + 1e-9) + 1)) if len(per_lane) else 0


def footprints(
    positions_xy: ArrayLike, angle_deg: ArrayLike, side_m: float, front_m: float
) -> NDArray[np.float64]:
    """Image footprints ``(k, 4, 2)`` at ``positions_xy``: ``front_m`` along the lane
    direction ``angle_deg`` (one for all, or one per position), ``side_m`` across it."""
    p = np.asarray(positions_xy, dtype=np.float64).reshape(-1, 2)
    half = (
        np.array([[-front_m, -side_m], [front_m, -side_m], [front_m, side_m], [-front_m, side_m]])
        / 2.0
    )
    a = np.radians(np.broadcast_to(np.asarray(angle_deg, dtype=np.float64), (len(p),)))
    c, s = np.cos(a)[:, None], np.sin(a)[:, None]
    x = half[None, :, 0] * c - half[None, :, 1] * s
    y = half[None, :, 0] * s + half[None, :, 1] * c
    return p[:, None, :] + np.stack([x, y], axis=2)


def photo_headings(photos_xy: ArrayLike, trigger_m: float) -> NDArray[np.float64]:
    """Each photo's lane direction (degrees CCW from east) from the photos alone: toward the
    next photo when it is on the same lane (within 1.5 trigger distances), else from the one
    before (a lane's last photo)."""
    xy = np.asarray(photos_xy, dtype=np.float64).reshape(-1, 2)
    if len(xy) < 2:
        return np.zeros(len(xy))
    step = np.diff(xy, axis=0)
    near = np.hypot(step[:, 0], step[:, 1]) <= 1.5 * trigger_m
    ahead = np.vstack([step, step[-1:]])
    behind = np.vstack([step[:1], step])
    d = np.where(np.append(near, False)[:, None], ahead, behind)
    return np.degrees(np.arctan2(d[:, 1], d[:, 0]))


def covered_fraction(free: BaseGeometry, footprints_xy: NDArray[np.float64]) -> float:
    """The share of ``free``'s area that the footprints ``(k, 4, 2)`` cover."""
    if free.is_empty or free.area <= 0:
        return 1.0
    union = shapely.union_all(shapely.polygons(footprints_xy))
    return float(free.intersection(union).area / free.area)


def swept_area(ordered: NDArray[np.float64], spacing_m: float) -> BaseGeometry:
    """What the lanes ``ordered`` ``(n, 2, 2)`` sweep: each a strip ``spacing_m`` wide,
    flat at its ends (one lane's share of the area between its neighbours)."""
    strips = [LineString(piece).buffer(spacing_m / 2.0, cap_style="flat") for piece in ordered]
    return shapely.union_all(strips)


def candidate_angles_deg(area: Polygon, step_deg: float = 5.0) -> NDArray[np.float64]:
    """Sweep angles to try: every ``step_deg`` over [0, 180) and the longest edge's direction."""
    xy = np.asarray(area.exterior.coords, dtype=np.float64)
    d = np.diff(xy, axis=0)
    k = int(np.argmax(np.hypot(d[:, 0], d[:, 1])))
    edge = math.degrees(math.atan2(d[k, 1], d[k, 0])) % 180.0
    grid = np.arange(0.0, 180.0, step_deg)
    return np.unique(np.append(grid, round(edge, 9)))


def as_multipolygon(geom: BaseGeometry) -> MultiPolygon:
    """``geom``'s polygons as one MultiPolygon (empty when it holds none)."""
    parts = [p for p in shapely.get_parts(geom) if isinstance(p, Polygon) and not p.is_empty]
    return MultiPolygon(parts)


__all__ = [
    "MIN_PIECE_M",
    "as_multipolygon",
    "candidate_angles_deg",
    "covered_fraction",
    "footprints",
    "free_area",
    "holes",
    "lane_offsets_m",
    "lanes",
    "order",
    "path_xy",
    "photo_count",
    "photo_positions",
    "polygon",
    "swept_area",
]
