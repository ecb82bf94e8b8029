"""The path frame (PAPER-NOTES "Path model"): x along the horizontal start→goal direction,
y across it (to the left), z up, origin at the start's ground point.

A path is one node per x-column: column ``j`` at ``x = j·dx`` for ``j = 0..D`` with the start
at ``j = 0`` and the goal at ``j = D``. ``dx`` is the grid's ``dx`` stretched slightly so the
goal falls exactly on the last column.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from uavplan.planners.params import GridSpec


@dataclass(frozen=True)
class PathFrame:
    start_enu: tuple[float, float, float]
    goal_enu: tuple[float, float, float]
    heading_rad: float  # of +x, counter-clockwise from east
    length_m: float  # horizontal start→goal distance
    n_cols: int  # D: number of column steps
    dx_m: float  # actual column spacing (length / D)
    grid: GridSpec

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
        return cls(
            (sx, sy, sz),
            (gx, gy, gz),
            math.atan2(dy, dx),
            length,
            n_cols,
            length / n_cols,
            grid,
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
    def column_x_m(self) -> np.ndarray:
        """x of every column, start (0) to goal (D): shape (D + 1,)."""
        return np.arange(self.n_cols + 1) * self.dx_m

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
        pts = np.empty((self.n_cols + 1, 3))
        pts[:, 0] = self.column_x_m
        pts[0, 1:] = (0.0, self.start_enu[2])
        pts[-1, 1:] = (0.0, self.goal_enu[2])
        pts[1:-1, 1] = n[:, 0] * self.grid.dy_m
        pts[1:-1, 2] = n[:, 1] * self.grid.dz_m
        return pts
