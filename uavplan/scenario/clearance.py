"""Exact clearances between points and obstacles, for the scenario's checks: no world, no
compiled kernels.

Obstacles are vertical solids from the ground up to their height, so the distance from a
point is the hypotenuse of the horizontal distance to the footprint and the height above the
top. The footprint distance is computed once, vectorised over every footprint
(:class:`Footprints`, with :func:`uavplan.geometry2d.point_rings_distance` for the polygons).
A scenario of a few obstacles is decided without it when it can be: a point whose distance to
every obstacle's bounding box is at least the margin is clear, and that is plain Python, so
``uavplan validate`` of a small scenario does not import numpy (about 0.13 s, more than the
rest of the command).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

from uavplan.obstacles import BoxObstacle, CylinderObstacle, Obstacle, PrismObstacle

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

#: up to this many obstacles, bounding boxes in plain Python decide first (see the module doc)
SMALL_OBSTACLE_COUNT = 64


class Footprints:
    """Every obstacle's footprint as flat numpy arrays, built once per obstacle tuple: the
    cylinders' centres and radii, the polygon edges (box corners computed vectorised) with
    the obstacle each belongs to, and the heights."""

    def __init__(self, obstacles: Sequence[Obstacle]) -> None:
        import numpy as np

        self.n = len(obstacles)
        self.heights = np.array([o.height_m for o in obstacles], dtype=np.float64)
        cyl = [i for i, o in enumerate(obstacles) if isinstance(o, CylinderObstacle)]
        self.cyl = np.array(cyl, dtype=np.int64)
        cylinders = [o for o in obstacles if isinstance(o, CylinderObstacle)]
        self.centres = np.array([o.center_m for o in cylinders], dtype=np.float64).reshape(-1, 2)
        self.radii = np.array([o.radius_m for o in cylinders], dtype=np.float64)
        boxes = [i for i, o in enumerate(obstacles) if isinstance(o, BoxObstacle)]
        box_values = [o for o in obstacles if isinstance(o, BoxObstacle)]
        prisms = [(i, o) for i, o in enumerate(obstacles) if isinstance(o, PrismObstacle)]
        starts: list[NDArray[np.float64]] = []
        owners: list[NDArray[np.int64]] = []
        if boxes:
            c = np.array([o.center_m for o in box_values], dtype=np.float64)
            h = np.array([o.size_m for o in box_values], dtype=np.float64) / 2.0
            yaw = np.radians(np.array([o.yaw_deg for o in box_values], dtype=np.float64))
            cs, sn = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
            u = np.array([-1.0, 1.0, 1.0, -1.0]) * h[:, :1]
            v = np.array([-1.0, -1.0, 1.0, 1.0]) * h[:, 1:]
            corners = np.stack([c[:, :1] + cs * u - sn * v, c[:, 1:] + sn * u + cs * v], axis=-1)
            starts.append(corners.reshape(-1, 2))
            owners.append(np.repeat(np.array(boxes, dtype=np.int64), 4))
        counts = [4] * len(boxes)
        for i, prism in prisms:
            starts.append(np.asarray(prism.polygon_m, dtype=np.float64))
            owners.append(np.full(len(prism.polygon_m), i, dtype=np.int64))
            counts.append(len(prism.polygon_m))
        if starts:
            a = np.concatenate(starts)
            k = np.array(counts, dtype=np.int64)
            first = np.repeat(np.cumsum(k) - k, k)
            local = np.arange(len(a)) - first
            self.a = a
            self.b = a[first + (local + 1) % np.repeat(k, k)]
            self.owner = np.concatenate(owners)
        else:
            self.a = self.b = np.empty((0, 2))
            self.owner = np.empty(0, dtype=np.int64)

    def horizontal(self, xy: Sequence[float]) -> NDArray[np.float64]:
        """Horizontal distance (metres, shape (n,)) from ``xy`` to every footprint; 0 inside."""
        import numpy as np

        from uavplan.geometry2d import point_rings_distance

        out = point_rings_distance(xy, self.a, self.b, self.owner, self.n)
        if self.cyl.size:
            px, py = float(xy[0]), float(xy[1])
            d = np.hypot(self.centres[:, 0] - px, self.centres[:, 1] - py) - self.radii
            out[self.cyl] = np.maximum(d, 0.0)
        return out


_FOOTPRINTS: dict[int, tuple[Sequence[Obstacle], Footprints]] = {}


def footprints(obstacles: Sequence[Obstacle]) -> Footprints:
    """The :class:`Footprints` of ``obstacles`` (the last tuple's are kept: a scenario is
    checked point after point against the same obstacles)."""
    hit = _FOOTPRINTS.get(id(obstacles))
    if hit is not None and hit[0] is obstacles:
        return hit[1]
    fp = Footprints(obstacles)
    _FOOTPRINTS.clear()
    _FOOTPRINTS[id(obstacles)] = (obstacles, fp)
    return fp


def _box_xy(obstacle: Obstacle) -> tuple[float, float, float, float]:
    """(x min, x max, y min, y max) of the obstacle's footprint."""
    if isinstance(obstacle, CylinderObstacle):
        (cx, cy), r = obstacle.center_m, obstacle.radius_m
        return cx - r, cx + r, cy - r, cy + r
    ring = obstacle.footprint()
    xs = [p[0] for p in ring]
    ys = [p[1] for p in ring]
    return min(xs), max(xs), min(ys), max(ys)


def _clear_by_boxes(
    obstacles: Sequence[Obstacle], point: Sequence[float], reach_m: float, column: bool
) -> bool:
    """True when every obstacle's bounding box (its solid from the ground up, or with
    ``column`` its footprint alone) is at least ``reach_m`` from ``point``: then no obstacle
    is closer. False: undecided."""
    if len(obstacles) > SMALL_OBSTACLE_COUNT:
        return False
    px, py = float(point[0]), float(point[1])
    for o in obstacles:
        x0, x1, y0, y1 = _box_xy(o)
        d = math.hypot(max(x0 - px, 0.0, px - x1), max(y0 - py, 0.0, py - y1))
        if not column:
            d = math.hypot(d, max(float(point[2]) - o.height_m, 0.0))
        if d < reach_m:
            return False
    return True


def point_clearance(
    obstacles: Sequence[Obstacle], point: Sequence[float], *, within_m: float | None = None
) -> tuple[float, int]:
    """(distance, index) of the obstacle nearest to the 3-D ``point``; (inf, -1) without
    obstacles, or when ``within_m`` is given and no obstacle is that close."""
    if not obstacles or (
        within_m is not None and _clear_by_boxes(obstacles, point, within_m, column=False)
    ):
        return math.inf, -1
    import numpy as np

    fp = footprints(obstacles)
    dist = np.hypot(fp.horizontal(point[:2]), np.maximum(float(point[2]) - fp.heights, 0.0))
    index = int(np.argmin(dist))
    return float(dist[index]), index


def column_clearance(
    obstacles: Sequence[Obstacle], xy: Sequence[float], *, within_m: float | None = None
) -> tuple[float, int]:
    """(distance, index) of the obstacle nearest to the vertical line from the ground up at
    ``xy``: obstacles stand on the ground, so it is the horizontal distance. (inf, -1) as
    :func:`point_clearance` says."""
    if not obstacles or (
        within_m is not None and _clear_by_boxes(obstacles, xy, within_m, column=True)
    ):
        return math.inf, -1
    import numpy as np

    horizontal = footprints(obstacles).horizontal(xy)
    index = int(np.argmin(horizontal))
    return float(horizontal[index]), index
