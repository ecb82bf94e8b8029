"""Obstacle and bounds values: vertical solids standing on the ground (flat at z = 0 unless
the world holds a :class:`~uavplan.ground.Ground`).

Plain frozen dataclasses in local ENU metres; the scenario layer builds them from YAML and the
world layer turns them into geometry. They know nothing of files.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass


@dataclass(frozen=True)
class BoxObstacle:
    center_m: tuple[float, float]
    size_m: tuple[float, float]  # along x, y before yaw
    height_m: float
    yaw_deg: float = 0.0  # counter-clockwise from +x (east toward north)

    kind = "box"

    def footprint(self) -> list[tuple[float, float]]:
        """Corners, counter-clockwise, ENU metres."""
        cx, cy = self.center_m
        hx, hy = self.size_m[0] / 2.0, self.size_m[1] / 2.0
        c, s = math.cos(math.radians(self.yaw_deg)), math.sin(math.radians(self.yaw_deg))
        corners = [(-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy)]
        return [(cx + c * u - s * v, cy + s * u + c * v) for u, v in corners]


@dataclass(frozen=True)
class CylinderObstacle:
    center_m: tuple[float, float]
    radius_m: float
    height_m: float

    kind = "cylinder"


@dataclass(frozen=True)
class PrismObstacle:
    polygon_m: tuple[tuple[float, float], ...]  # counter-clockwise after loading
    height_m: float

    kind = "prism"

    def footprint(self) -> list[tuple[float, float]]:
        return list(self.polygon_m)


Obstacle = BoxObstacle | CylinderObstacle | PrismObstacle


@dataclass(frozen=True)
class Bounds:
    x_m: tuple[float, float]
    y_m: tuple[float, float]
    z_m: tuple[float, float]

    def contains(self, point: Sequence[float], tol: float = 1e-9) -> bool:
        return all(
            lo - tol <= float(v) <= hi + tol
            for v, (lo, hi) in zip(point, (self.x_m, self.y_m, self.z_m), strict=True)
        )
