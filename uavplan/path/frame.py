"""The path frame (PAPER-NOTES "Path model"): x along the horizontal start→goal direction,
y across it (to the left), z up, origin at the start's ground point.

A path is one node per column: column ``j`` for ``j = 0..D`` with the start at ``j = 0`` and
the goal at ``j = D``. In the paper's encoding the columns stand along the straight
start→goal line, at ``x = j·dx`` (``dx`` the grid's, stretched slightly so the goal falls
exactly on the last column), and a node's lateral offset is its y. Along a *guide* (a
polyline from start to goal found by a global search, in this frame) the columns stand at
equal arc lengths ``j·ds`` on the guide, across its direction: column j has an origin ``c_j``
on the guide and a unit normal ``n_j``, and the node with lateral offset y sits at
``c_j + y·n_j``. The straight line is the guide with ``c_j = (j·dx, 0)`` and ``n_j = (0, 1)``,
so both encodings are one. Where the guide turns, neighbouring columns would cross on the
inside of the turn: each column's lateral window stops short of that crossing
(``lateral_limits_m``), so no two nodes of different columns coincide.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from uavplan.config import GridSpec


@dataclass(frozen=True)
class PathFrame:
    start_enu: tuple[float, float, float]
    goal_enu: tuple[float, float, float]
    heading_rad: float  # of +x, counter-clockwise from east
    length_m: float  # horizontal start→goal distance
    n_cols: int  # D: number of column steps
    dx_m: float  # actual column spacing along the guide (guide length / D)
    grid: GridSpec
    #: (D + 1, 4) every column's origin and unit normal in this frame: cx, cy, nx, ny
    cols: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)), compare=False)
    #: (D + 1, 2) lateral window of every column in metres (−inf, inf when straight)
    lateral_limits_m: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)), compare=False)
    #: the guide polyline (k, 2) in this frame; None: the straight start→goal line
    guide_xy: np.ndarray | None = field(default=None, compare=False)

    @property
    def straight(self) -> bool:
        return self.guide_xy is None

    @classmethod
    def build(
        cls,
        start_enu: tuple[float, float, float],
        goal_enu: tuple[float, float, float],
        grid: GridSpec,
    ) -> PathFrame:
        dx = goal_enu[0] - start_enu[0]
        dy = goal_enu[1] - start_enu[1]
        length = math.hypot(dx, dy)
        if length <= 0:
            raise ValueError("start and goal must differ horizontally")
        n_cols = max(2, round(length / grid.dx_m))
        sx, sy, sz = (float(v) for v in start_enu)
        gx, gy, gz = (float(v) for v in goal_enu)
        step = length / n_cols
        cols = np.zeros((n_cols + 1, 4))
        cols[:, 0] = np.arange(n_cols + 1) * step
        cols[:, 3] = 1.0
        limits = np.empty((n_cols + 1, 2))
        limits[:, 0], limits[:, 1] = -math.inf, math.inf
        return cls(
            (sx, sy, sz),
            (gx, gy, gz),
            math.atan2(dy, dx),
            length,
            n_cols,
            step,
            grid,
            cols,
            limits,
        )

    def along(self, guide_xy: np.ndarray, smoothing_cols: float = 2.0) -> PathFrame:
        """The same frame with its columns along ``guide_xy`` (k, 2): a polyline in this frame
        from the start (0, 0) to the goal (length, 0). Column j stands at arc length j·ds;
        its normal is that of the guide's direction between arc lengths j·ds ± w, w =
        ``smoothing_cols``·ds (so the columns turn gradually), and its lateral window stops
        at half the distance to where it would cross a neighbouring column."""
        g = np.asarray(guide_xy, dtype=float)
        seg = np.linalg.norm(np.diff(g, axis=0), axis=1)
        keep = np.concatenate([[True], seg > 1e-9])
        g = g[keep]
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(g, axis=0), axis=1))])
        total = float(arc[-1])
        n_cols = max(2, round(total / self.grid.dx_m))
        ds = total / n_cols
        s = np.arange(n_cols + 1) * ds

        def at(t: np.ndarray) -> np.ndarray:
            t = np.clip(t, 0.0, total)
            return np.column_stack([np.interp(t, arc, g[:, 0]), np.interp(t, arc, g[:, 1])])

        origin = at(s)
        origin[0], origin[-1] = g[0], g[-1]
        w = smoothing_cols * ds
        tangent = at(s + w) - at(s - w)
        tangent /= np.maximum(np.linalg.norm(tangent, axis=1), 1e-12)[:, None]
        normal = np.column_stack([-tangent[:, 1], tangent[:, 0]])
        cols = np.column_stack([origin, normal])
        return PathFrame(
            self.start_enu,
            self.goal_enu,
            self.heading_rad,
            self.length_m,
            n_cols,
            ds,
            self.grid,
            cols,
            _fold_limits(cols),
            g,
        )

    @property
    def origin_xy(self) -> tuple[float, float]:
        return (self.start_enu[0], self.start_enu[1])

    def to_enu(self, points: np.ndarray) -> np.ndarray:
        """Path-frame points (n, 3) → ENU (n, 3)."""
        p = np.atleast_2d(np.asarray(points, dtype=float))
        c, s = math.cos(self.heading_rad), math.sin(self.heading_rad)
        out = np.empty_like(p)
        out[:, 0] = self.start_enu[0] + c * p[:, 0] - s * p[:, 1]
        out[:, 1] = self.start_enu[1] + s * p[:, 0] + c * p[:, 1]
        out[:, 2] = p[:, 2]
        return out

    def from_enu(self, points: np.ndarray) -> np.ndarray:
        """ENU points (n, 3) → path frame (n, 3)."""
        p = np.atleast_2d(np.asarray(points, dtype=float))
        c, s = math.cos(self.heading_rad), math.sin(self.heading_rad)
        dx = p[:, 0] - self.start_enu[0]
        dy = p[:, 1] - self.start_enu[1]
        out = np.empty_like(p)
        out[:, 0] = c * dx + s * dy
        out[:, 1] = -s * dx + c * dy
        out[:, 2] = p[:, 2]
        return out

    # -- the grid encoding -------------------------------------------------------------

    @property
    def start_units(self) -> tuple[float, float]:
        """Start (y, z) in grid units (y = 0 on the start-end line)."""
        return (0.0, self.start_enu[2] / self.grid.dz_m)

    @property
    def goal_units(self) -> tuple[float, float]:
        return (0.0, self.goal_enu[2] / self.grid.dz_m)

    @property
    def line_z_units(self) -> np.ndarray:
        """z of the start-end line at every column, grid units, shape (D + 1,)."""
        z0, z1 = self.start_units[1], self.goal_units[1]
        return z0 + (z1 - z0) * np.arange(self.n_cols + 1) / self.n_cols

    def nodes_to_points(self, nodes_units: np.ndarray) -> np.ndarray:
        """Inner nodes (D − 1, 2) in grid units → path-frame points (D + 1, 3) with ends."""
        n = np.asarray(nodes_units, dtype=float)
        lateral = np.zeros(self.n_cols + 1)
        lateral[1:-1] = n[:, 0] * self.grid.dy_m
        c = self.cols
        pts = np.empty((self.n_cols + 1, 3))
        pts[:, 0] = c[:, 0] + lateral * c[:, 2]
        pts[:, 1] = c[:, 1] + lateral * c[:, 3]
        pts[0, 2] = self.start_enu[2]
        pts[-1, 2] = self.goal_enu[2]
        pts[1:-1, 2] = n[:, 1] * self.grid.dz_m
        return pts


def _fold_limits(cols: np.ndarray) -> np.ndarray:
    """(D + 1, 2) lateral windows (m): each column stops at half the distance to where its
    line would cross a neighbouring column's line (none where they are parallel)."""
    n = cols.shape[0]
    lim = np.empty((n, 2))
    lim[:, 0], lim[:, 1] = -math.inf, math.inf
    for j in range(n - 1):
        c0, n0 = cols[j, :2], cols[j, 2:]
        c1, n1 = cols[j + 1, :2], cols[j + 1, 2:]
        den = n0[0] * n1[1] - n0[1] * n1[0]  # cross(n0, n1)
        if abs(den) < 1e-9:
            continue
        d = c1 - c0
        # c0 + t·n0 = c1 + u·n1  →  t = cross(d, n1)/cross(n0, n1), u = cross(d, n0)/cross(n0, n1)
        t = (d[0] * n1[1] - d[1] * n1[0]) / den
        u = (d[0] * n0[1] - d[1] * n0[0]) / den
        for k, v in ((j, t), (j + 1, u)):
            if v > 0:
                lim[k, 1] = min(lim[k, 1], 0.5 * v)
            else:
                lim[k, 0] = max(lim[k, 0], 0.5 * v)
    return lim
