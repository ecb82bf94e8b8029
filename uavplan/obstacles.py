"""Obstacle, bounds and ground values: vertical solids standing on the ground (flat at z = 0
unless a :class:`Ground` says otherwise).

Plain frozen dataclasses in local ENU metres; the scenario layer builds them from YAML and the
world layer turns them into geometry. They know nothing of files.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any


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


@dataclass(frozen=True, eq=False)
class Ground:
    """Terrain under a world whose z is metres above ``datum_amsl_m`` (not above the ground).

    ``prisms_xy`` ``(n, 4, 2)`` (convex, counter-clockwise) and ``tops_m`` ``(n,)``: solids
    reaching from below the ground up to ``tops_m`` that together contain the ground surface
    (the world keeps its margin from them as from any obstacle). ``height_fn`` maps ENU
    ``(n, 2)`` points to the ground's z in this frame (the DEM's bilinear surface): for
    heights above the ground, home altitudes and independent checks. ``ceiling_agl_m``: the
    highest a route may fly above the ground beneath it (the bounds' z maximum).
    """

    datum_amsl_m: float
    prisms_xy: Any
    tops_m: Any
    height_fn: Callable[[Any], Any]
    ceiling_agl_m: float
    source: str = ""
    #: bottoms ``(n,)`` of ceiling solids over the same outlines (reaching up forever): the
    #: lowest ground under each outline + ``ceiling_agl_m`` + the margin, so a route keeping
    #: the margin from them stays at most ``ceiling_agl_m`` above the ground; None: no ceiling
    ceilings_m: Any = None

    def z_at(self, points_xy: Any) -> Any:
        """Ground z (metres above the datum) at ENU points ``(n, 2)`` (or ``(n, 3)``)."""
        import numpy as np

        p = np.atleast_2d(np.asarray(points_xy, dtype=np.float64))[:, :2]
        return np.asarray(self.height_fn(p), dtype=np.float64)
