"""The world: obstacles as vertical solids, the terrain, the flight bounds and the margin.

Everything is in a local metric frame (ENU metres unless the world was moved into another
frame with :meth:`World.in_frame`). The heavy lifting is in :mod:`uavplan._geom`; this module
builds the flat arrays those kernels read and offers vectorised, documented entry points:

* :meth:`World.segments_free` — are these straight segments inside the bounds and at least
  ``margin`` from every obstacle? (batches of segments at once)
* :meth:`World.points_clearance` / :meth:`World.segments_clearance` — exact distances.

Over terrain the world carries the :class:`~uavplan.ground.Ground` (its height field) and the
map from its own frame to the field's: every query above measures the ground and the ceiling
over it exactly, in the kernels (``uavplan/_csrc/heightfield.c``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Any

import numpy as np

from uavplan import _geom
from uavplan.geometry2d import COLLINEAR_TOL, convex_pieces
from uavplan.ground import FIELD_META, Ground
from uavplan.obstacles import BoxObstacle, CylinderObstacle, Obstacle, PrismObstacle

MAX_VERTS = 16  # convex pieces with more vertices are split into triangles
GROUND = -2  # what the terrain's ground is, where an obstacle index would be
CEILING = -3  # and the ceiling above it (bounds.z max above the ground)
CEILING_TOP = 1e300  # bounding-box top of a ceiling piece (height −b: solid from b up)
#: the kernels' empty height field (a world over flat ground)
_NO_FIELD = (
    np.zeros((0, 0, 2)),
    np.zeros((0, 0)),
    np.zeros((0, 0)),
    np.zeros(FIELD_META),
    np.zeros((0, 0, 2)),
)


def _cell_size(box: np.ndarray) -> float:
    """Grid cell edge: about the typical piece size, never below 25 m."""
    if box.shape[0] == 0:
        return 100.0
    sizes = np.sort(np.maximum(box[:, 1] - box[:, 0], box[:, 3] - box[:, 2]))
    # the median, as np.median gives it (which would import numpy.ma: 20-50 ms per plan)
    n = sizes.shape[0]
    median = sizes[n // 2] if n % 2 else (sizes[n // 2 - 1] + sizes[n // 2]) / 2.0
    return float(max(25.0, 1.5 * median))


def _convex_pieces(obstacle: BoxObstacle | PrismObstacle) -> list[list[tuple[float, float]]]:
    """Counter-clockwise convex pieces of a box or prism footprint (the kernels' polygons)."""
    return convex_pieces(obstacle.footprint(), MAX_VERTS)


def _box_footprints(boxes: Sequence[BoxObstacle]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The footprints of ``boxes`` at once: corners x and y ``(n, 4)`` with the arithmetic of
    :meth:`BoxObstacle.footprint` (the same floats), and whether each is, as
    :func:`~uavplan.geometry2d.convex_pieces` would find it, its own single convex
    counter-clockwise piece (a degenerate box is not: it takes the general path)."""
    n = len(boxes)
    cx = np.array([o.center_m[0] for o in boxes], dtype=float).reshape(n)
    cy = np.array([o.center_m[1] for o in boxes], dtype=float).reshape(n)
    hx = np.array([o.size_m[0] / 2.0 for o in boxes], dtype=float).reshape(n)
    hy = np.array([o.size_m[1] / 2.0 for o in boxes], dtype=float).reshape(n)
    yaw = [math.radians(o.yaw_deg) for o in boxes]
    c = np.array([math.cos(a) for a in yaw], dtype=float).reshape(n, 1)
    s = np.array([math.sin(a) for a in yaw], dtype=float).reshape(n, 1)
    u = np.stack([-hx, hx, hx, -hx], axis=1)
    v = np.stack([-hy, -hy, hy, hy], axis=1)
    x = cx[:, None] + c * u - s * v
    y = cy[:, None] + s * u + c * v
    # convex_pieces' tests, term by term: the signed area's sign, then every turn
    nx, ny = np.roll(x, -1, axis=1), np.roll(y, -1, axis=1)
    terms = x * ny - nx * y
    twice_area = terms[:, 0] + terms[:, 1] + terms[:, 2] + terms[:, 3]
    ax, ay = np.roll(x, -2, axis=1), np.roll(y, -2, axis=1)
    turns = (nx - x) * (ay - ny) - (ny - y) * (ax - nx)
    whole = (twice_area >= 0) & np.all(turns >= -COLLINEAR_TOL, axis=1)
    return x, y, whole


def _pieces_of(
    obstacles: Sequence[Obstacle],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The kernels' piece arrays of ``obstacles``: (poly_xy, poly_n, poly_h, circ, owner),
    read-only (worlds share them: :meth:`World.with_limits`)."""
    boxes = [o for o in obstacles if isinstance(o, BoxObstacle)]
    box_x, box_y, box_whole = _box_footprints(boxes)
    # each piece: a row of the box footprints (an int), or a list of vertices
    pieces: list[int | list[tuple[float, float]]] = []
    heights: list[float] = []
    owner: list[int] = []
    circles: list[tuple[float, float, float, float, int]] = []
    box_row = iter(range(len(boxes)))
    for i, obs in enumerate(obstacles):
        if isinstance(obs, CylinderObstacle):
            circles.append((*obs.center_m, obs.radius_m, obs.height_m, i))
            continue
        if isinstance(obs, BoxObstacle):
            row = next(box_row)
            if box_whole[row]:
                pieces.append(row)
                heights.append(obs.height_m)
                owner.append(i)
                continue
        elif not isinstance(obs, PrismObstacle):  # pragma: no cover - only these three exist
            raise TypeError(f"unknown obstacle {obs!r}")
        for piece in _convex_pieces(obs):
            pieces.append(piece)
            heights.append(obs.height_m)
            owner.append(i)
    poly_xy = np.zeros((len(pieces), MAX_VERTS, 2))
    poly_n = np.zeros(len(pieces), dtype=np.int64)
    poly_h = np.array(heights, dtype=float).reshape(-1)
    rows = [k for k, piece in enumerate(pieces) if isinstance(piece, int)]
    which = [piece for piece in pieces if isinstance(piece, int)]
    poly_xy[rows, :4, 0] = box_x[which]
    poly_xy[rows, :4, 1] = box_y[which]
    poly_n[rows] = 4
    for k, ring in enumerate(pieces):
        if not isinstance(ring, int):
            poly_xy[k, : len(ring)] = ring
            poly_n[k] = len(ring)
    circ = np.array([c[:4] for c in circles], dtype=float).reshape(-1, 4)
    owner.extend(c[4] for c in circles)
    arrays = (poly_xy, poly_n, poly_h, circ, np.array(owner, dtype=np.int64))
    for a in arrays:
        a.setflags(write=False)
    return arrays  # type: ignore[return-value]


def _box_planes(x: tuple[float, float], y: tuple[float, float]) -> np.ndarray:
    """The half-planes a·x + b·y <= c of the box ``x`` × ``y``."""
    (x0, x1), (y0, y1) = x, y
    return np.array([[1.0, 0.0, x1], [-1.0, 0.0, -x0], [0.0, 1.0, y1], [0.0, -1.0, -y0]])


@dataclass(frozen=True, eq=False)
class World:
    """Obstacles split into convex pieces, plus convex bounds, in one metric frame.

    Arrays (read by the kernels):
      ``poly_xy`` (P, MAX_VERTS, 2), ``poly_n`` (P,), ``poly_h`` (P,): convex polygons
      (a piece spans z in [0, h]; a negative ``h`` is a ceiling piece spanning [−h, ∞));
      ``circ`` (C, 4): circles (cx, cy, r, h); ``box`` (P + C, 5): piece bounding boxes
      (xmin, xmax, ymin, ymax, zmax); ``owner`` (P + C,): index of the obstacle of each piece;
      ``hp`` (m, 3): bounds half-planes a·x + b·y <= c; ``zlim`` (2,).
      ``ground``: the terrain (None: flat ground at z = 0), and ``field_frame`` (ox, oy, c, s)
      the map from this frame to the ground's (X = ox + c·x − s·y, Y = oy + s·x + c·y).
    """

    poly_xy: np.ndarray
    poly_n: np.ndarray
    poly_h: np.ndarray
    circ: np.ndarray
    box: np.ndarray
    owner: np.ndarray
    hp: np.ndarray
    zlim: np.ndarray
    margin_m: float
    n_obstacles: int
    cells: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    ground: Ground | None = None
    field_frame: tuple[float, float, float, float] = (0.0, 0.0, 1.0, 0.0)

    # -- construction ------------------------------------------------------------------
    @classmethod
    def build(
        cls,
        obstacles: Sequence[Obstacle],
        *,
        bounds_xyz: tuple[tuple[float, float], tuple[float, float], tuple[float, float]],
        margin_m: float,
        ground: Ground | None = None,
    ) -> World:
        """The world of ``obstacles`` (each from below the ground up to its height) inside
        the bounds, keeping ``margin_m``; with ``ground``, the margin holds from the terrain
        (its height field) as from any obstacle, and from the ceiling over it."""
        poly_xy, poly_n, poly_h, circ, owner = _pieces_of(obstacles)
        x, y, z = bounds_xyz
        return cls._assemble(
            poly_xy,
            poly_n,
            poly_h,
            circ,
            owner,
            _box_planes(x, y),
            np.array(z, dtype=float),
            float(margin_m),
            len(obstacles),
            ground,
        )

    def with_limits(
        self,
        *,
        margin_m: float | None = None,
        bounds_xyz: tuple[tuple[float, float], tuple[float, float], tuple[float, float]]
        | None = None,
        ground: Ground | None = None,
    ) -> World:
        """This world's obstacles (their pieces and cells shared, not split again) with
        another margin, other box bounds or another ground (each None: this world's). Only
        for a world made by :meth:`build` (its bounds a box in this frame)."""
        changes: dict[str, Any] = {}
        if bounds_xyz is not None:
            x, y, z = bounds_xyz
            changes.update(hp=_box_planes(x, y), zlim=np.array(z, dtype=float))
        if margin_m is not None:
            changes["margin_m"] = float(margin_m)
        if ground is not None:
            changes["ground"] = ground
        return replace(self, **changes)

    @classmethod
    def _assemble(
        cls, poly_xy, poly_n, poly_h, circ, owner, hp, zlim, margin_m, n_obs, ground=None,
        field_frame=(0.0, 0.0, 1.0, 0.0),
    ) -> World:  # fmt: skip
        npoly = poly_n.shape[0]
        box = np.zeros((npoly + circ.shape[0], 5))
        if npoly:
            used = np.arange(MAX_VERTS)[None, :] < poly_n[:, None]
            px = np.where(used, poly_xy[:, :, 0], np.nan)
            py = np.where(used, poly_xy[:, :, 1], np.nan)
            box[:npoly, 0], box[:npoly, 1] = np.nanmin(px, axis=1), np.nanmax(px, axis=1)
            box[:npoly, 2], box[:npoly, 3] = np.nanmin(py, axis=1), np.nanmax(py, axis=1)
            box[:npoly, 4] = np.where(poly_h < 0.0, CEILING_TOP, poly_h)
        if circ.shape[0]:
            cx, cy, r, h = circ.T
            box[npoly:] = np.stack([cx - r, cx + r, cy - r, cy + r, h], axis=1)
        cells = _geom.build_cells(box, 0.0, _cell_size(box))
        return cls(
            np.ascontiguousarray(poly_xy),
            poly_n,
            poly_h,
            np.ascontiguousarray(circ),
            box,
            owner,
            np.ascontiguousarray(hp),
            zlim,
            margin_m,
            n_obs,
            cells,
            ground,
            field_frame,
        )

    def in_frame(
        self,
        origin_xy: Sequence[float],
        heading_rad: float,
        margin_m: float | None = None,
        floor_m: float | None = None,
    ) -> World:
        """The same world expressed in a frame whose origin is ``origin_xy`` and whose +x axis
        points along ``heading_rad`` (counter-clockwise from this frame's +x), optionally
        with another margin and a higher floor (lowest z allowed)."""
        c, s = math.cos(heading_rad), math.sin(heading_rad)
        ox, oy = float(origin_xy[0]), float(origin_xy[1])

        def to_frame(x, y):
            dx, dy = x - ox, y - oy
            return c * dx + s * dy, -s * dx + c * dy

        poly_xy = self.poly_xy.copy()
        used = np.arange(MAX_VERTS)[None, :] < self.poly_n[:, None]
        u, v = to_frame(self.poly_xy[:, :, 0], self.poly_xy[:, :, 1])
        poly_xy[:, :, 0] = np.where(used, u, self.poly_xy[:, :, 0])
        poly_xy[:, :, 1] = np.where(used, v, self.poly_xy[:, :, 1])
        circ = self.circ.copy()
        if circ.shape[0]:
            circ[:, 0], circ[:, 1] = to_frame(self.circ[:, 0], self.circ[:, 1])
        # a·x + b·y <= k  with x = ox + c·u − s·v, y = oy + s·u + c·v
        a, b, rhs = self.hp[:, 0], self.hp[:, 1], self.hp[:, 2]
        hp = np.stack([a * c + b * s, -a * s + b * c, rhs - a * ox - b * oy], axis=1)
        return World._assemble(
            poly_xy,
            self.poly_n.copy(),
            self.poly_h.copy(),
            circ,
            self.owner.copy(),
            hp,
            self.zlim.copy()
            if floor_m is None
            else np.array([max(self.zlim[0], floor_m), self.zlim[1]]),
            self.margin_m if margin_m is None else float(margin_m),
            self.n_obstacles,
            self.ground,
            _compose(self.field_frame, ox, oy, c, s),
        )

    @property
    def has_ground(self) -> bool:
        return self.ground is not None

    def without_ground(self) -> World:
        """The same world without the terrain (e.g. for the take-off climb, which starts on
        the ground)."""
        return self if self.ground is None else replace(self, ground=None)

    # -- queries -----------------------------------------------------------------------
    @cached_property
    def kernel_args(self) -> _geom.KernelWorld:
        """The world as the kernels of :mod:`uavplan._geom` read it, by name (checked once)."""
        gmeta, cell_start, cell_items, piece_cells = self.cells
        hf_xy, hf_z, hf_slope, hf_meta, hf_blocks = _NO_FIELD
        if self.ground is not None:
            ox, oy, c, s = self.field_frame
            field = self.ground.field
            hf_xy, hf_z, hf_slope, hf_blocks = field.xy, field.z, field.slope, field.blocks
            hf_meta = self.ground.kernel_meta((ox, oy), (c, s))
        return _geom.KernelWorld(
            poly_xy=self.poly_xy,
            poly_n=self.poly_n,
            poly_h=self.poly_h,
            circ=self.circ,
            box=self.box,
            hp=self.hp,
            zlim=self.zlim,
            gmeta=gmeta,
            cell_start=cell_start,
            cell_items=cell_items,
            piece_cells=piece_cells,
            hf_xy=hf_xy,
            hf_z=hf_z,
            hf_slope=hf_slope,
            hf_meta=hf_meta,
            hf_blocks=hf_blocks,
        )

    def segments_free(
        self, p0: np.ndarray, p1: np.ndarray, margin_m: float | None = None
    ) -> np.ndarray:
        """(n,) bool: segment p0[i]→p1[i] inside the bounds and ≥ margin from all obstacles
        (a long batch shared among :func:`~uavplan._geom.kernel_threads` threads; the kernel
        keeps a short one on the caller's)."""
        p0 = np.ascontiguousarray(np.atleast_2d(p0), dtype=float)
        p1 = np.ascontiguousarray(np.atleast_2d(p1), dtype=float)
        margin = self.margin_m if margin_m is None else float(margin_m)
        return _geom.segments_free(p0, p1, self.kernel_args, margin, _geom.kernel_threads())

    def farthest_visible(self, points: np.ndarray, margin_m: float | None = None) -> np.ndarray:
        """Indices of the greedy farthest-reachable chain through the polyline ``points``
        (n, 3): from each kept point jump to the last later one whose segment is free
        (:meth:`segments_free`; the next point when none is); 0 first, n − 1 last."""
        p = np.ascontiguousarray(np.atleast_2d(points), dtype=float)
        margin = self.margin_m if margin_m is None else float(margin_m)
        return _geom.farthest_visible(p, self.kernel_args, margin)

    def largest_free_fraction(
        self, p: np.ndarray, step: np.ndarray, a: np.ndarray, b: np.ndarray, bisections: int
    ) -> float:
        """The largest f in [0, 1] for which a → p + f·step → b keeps the margin (both
        segments, :meth:`segments_free`): 1.0 when it does, else found by ``bisections``
        halvings of [0, 1]."""
        return _geom.largest_free_fraction(
            p, step, a, b, self.kernel_args, self.margin_m, bisections
        )

    def points_inside_bounds(self, points: np.ndarray, tol_m: float = 1e-9) -> np.ndarray:
        """(n,) bool: inside the bounds, allowing ``tol_m`` outside (e.g. for positions that
        went through float32 / 1e-7° rounding)."""
        p = np.atleast_2d(np.asarray(points, dtype=float))
        ok = (p[:, 2] >= self.zlim[0] - tol_m) & (p[:, 2] <= self.zlim[1] + tol_m)
        for a, b, k in self.hp:
            ok &= a * p[:, 0] + b * p[:, 1] <= k + tol_m * math.hypot(a, b)
        return ok

    def points_clearance(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Exact distance (n,) from each point to the nearest obstacle and its index (-1: none)."""
        p = np.ascontiguousarray(np.atleast_2d(points), dtype=float)
        dist, piece = _geom.points_clearance(p, self.kernel_args)
        return dist, self._owners(piece)

    def segments_clearance(self, p0: np.ndarray, p1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Exact minimum distance (n,) from each segment to the nearest obstacle and its index."""
        p0 = np.ascontiguousarray(np.atleast_2d(p0), dtype=float)
        p1 = np.ascontiguousarray(np.atleast_2d(p1), dtype=float)
        dist, piece = _geom.segments_clearance(p0, p1, self.kernel_args)
        return dist, self._owners(piece)

    def segments_nearest(self, p0: np.ndarray, p1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Exact minimum distance (n,) from each segment to the nearest piece, and that piece
        (−1: none; :meth:`owner_of` gives its obstacle)."""
        p0 = np.ascontiguousarray(np.atleast_2d(p0), dtype=float)
        p1 = np.ascontiguousarray(np.atleast_2d(p1), dtype=float)
        return _geom.segments_clearance(p0, p1, self.kernel_args)

    def owner_of(self, piece: np.ndarray) -> np.ndarray:
        """The obstacle index of each piece index (−1 stays −1; the terrain's ground
        :data:`GROUND`, its ceiling :data:`CEILING`)."""
        return self._owners(np.asarray(piece))

    def terrain_nearest(
        self, p0: np.ndarray, p1: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per segment p0[i]→p1[i] (a point when equal): the exact distance to the nearer of
        the terrain's solids (inf without terrain), which (:data:`GROUND`, :data:`CEILING`,
        −1: none) and the closest point of its surface, (x, y) in the ground's frame (the
        site's ENU frame)."""
        p0 = np.ascontiguousarray(np.atleast_2d(p0), dtype=float)
        p1 = np.ascontiguousarray(np.atleast_2d(p1), dtype=float)
        n = p0.shape[0]
        dist, kind, where = np.empty(n), np.empty(n, dtype=np.int64), np.empty((n, 2))
        _geom._c.field_nearest(p0, p1, self.kernel_args, dist, kind, where)
        return dist, np.where(kind == 0, GROUND, np.where(kind == 1, CEILING, -1)), where

    def _owners(self, piece: np.ndarray) -> np.ndarray:
        """Obstacle index of each piece index (−1 stays −1: no obstacle at all; the
        terrain's: :data:`GROUND`, :data:`CEILING`)."""
        npieces = self.box.shape[0]
        out = np.full(piece.shape, -1, dtype=np.int64)
        if self.owner.size:
            mine = (piece >= 0) & (piece < npieces)
            out = np.where(mine, self.owner[np.clip(piece, 0, max(npieces - 1, 0))], out)
        out = np.where(piece == npieces, GROUND, out)
        return np.where(piece == npieces + 1, CEILING, out)

    def polyline_clearance(self, points: np.ndarray) -> float:
        """Smallest distance between the polyline through ``points`` (n, 3) and any obstacle."""
        p = np.asarray(points, dtype=float)
        if p.shape[0] < 2:
            return float(self.points_clearance(p)[0].min()) if p.shape[0] else math.inf
        dist, _ = self.segments_clearance(p[:-1], p[1:])
        return float(dist.min()) if dist.size else math.inf

    def nearest_obstacle(self, point: Sequence[float]) -> tuple[float, int]:
        dist, idx = self.points_clearance(np.asarray(point, dtype=float).reshape(1, 3))
        return float(dist[0]), int(idx[0])


def _compose(
    frame: tuple[float, float, float, float], ox: float, oy: float, c: float, s: float
) -> tuple[float, float, float, float]:
    """The map to the field's frame from a frame whose origin is (ox, oy) and whose axes are
    turned by (c, s) = (cos, sin) in the frame ``frame`` maps from."""
    fx, fy, fc, fs = frame
    return (fx + fc * ox - fs * oy, fy + fs * ox + fc * oy, fc * c - fs * s, fs * c + fc * s)
