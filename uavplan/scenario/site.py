"""A scenario's geometry in the frame the planner flies it in (:class:`Site`).

A scenario file gives every height above the ground beneath the point (over flat ground:
above z = 0). Over flat ground the site is the scenario's own values. Over a DEM the site is
the same scenario moved onto the terrain: every z becomes metres above a datum just below the
lowest ground (:func:`uavplan.ground.datum_below`, the site's origin altitude), obstacles
stand on the ground at their centre and reach down into it, the flight volume spans from the
datum to the highest ground plus the ceiling, and the ground (the DEM as an exact height
field) is built for the scenario's margin (:func:`uavplan.ground.build_ground`). The scenario
itself keeps the file's values and the DEM; a site is derived from them whenever it is
needed (:attr:`uavplan.scenario.Scenario.site`), so it can never be stale.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from uavplan.geo import EnuFrame, GeoPoint
from uavplan.ground import Ground, Surface, build_ground, datum_below
from uavplan.obstacles import Bounds, Obstacle, PrismObstacle

Point3 = tuple[float, float, float]


@dataclass(frozen=True, eq=False)
class Site:
    """Where a scenario is flown: its origin (over terrain at the datum), bounds, route
    points (start, via points, goal), obstacles and margin in one vertical frame, and the
    ground's solids over terrain (None over flat ground at z = 0)."""

    origin: GeoPoint
    bounds: Bounds
    start_m: Point3
    goal_m: Point3
    via_m: tuple[Point3, ...]
    obstacles: tuple[Obstacle, ...]
    safety_margin_m: float
    ground: Ground | None = None
    #: with terrain: the ground's z under the route points, in route order
    ground_under_m: tuple[float, ...] = ()

    @property
    def datum_amsl_m(self) -> float | None:
        """The datum (metres AMSL) of a site over terrain; None over flat ground."""
        return None if self.ground is None else self.ground.datum_amsl_m

    def route_points(self) -> list[Point3]:
        """Start, the via points in order, goal."""
        return [self.start_m, *self.via_m, self.goal_m]

    def frame(self) -> EnuFrame:
        """The site's local ENU frame (at its origin; over terrain at the datum)."""
        return EnuFrame.at(self.origin)

    def ground_z(self, points_xy: Any) -> Any:
        """The ground's z under ENU points ``(n, 2)`` (zeros over flat ground)."""
        import numpy as np

        if self.ground is None:
            return np.zeros(len(np.atleast_2d(points_xy)))
        return self.ground.z_at(points_xy)


def flat_site(
    origin: GeoPoint,
    bounds: Bounds,
    start_m: Point3,
    goal_m: Point3,
    via_m: tuple[Point3, ...],
    obstacles: tuple[Obstacle, ...],
    margin_m: float,
) -> Site:
    """The site over flat ground: the values as they are."""
    return Site(origin, bounds, start_m, goal_m, via_m, obstacles, margin_m)


def terrain_site(
    origin: GeoPoint,
    bounds: Bounds,
    start_m: Point3,
    goal_m: Point3,
    via_m: tuple[Point3, ...],
    obstacles: tuple[Obstacle, ...],
    margin_m: float,
    terrain: Surface,
) -> Site:
    """The site over ``terrain`` (heights above the ground beneath each point moved onto
    it, see the module doc). Raises the DEM's error where it does not cover a point."""
    import numpy as np

    datum = datum_below(terrain)
    site_origin = GeoPoint(origin.lat_deg, origin.lon_deg, datum)
    on_datum = terrain.in_frame(EnuFrame.at(site_origin))
    ground = build_ground(on_datum, datum_amsl_m=datum, bounds=bounds, margin_m=margin_m)
    points = np.array([start_m, *via_m, goal_m], dtype=np.float64)
    under = ground.z_at(points[:, :2])
    centres = np.array([_centre(o) for o in obstacles], dtype=np.float64).reshape(-1, 2)
    obstacle_ground = ground.z_at(centres) if len(centres) else np.empty(0)
    moved = points.copy()
    moved[:, 2] += under
    standing = tuple(
        replace(o, height_m=float(g + o.height_m))
        for o, g in zip(obstacles, obstacle_ground, strict=True)
    )
    return Site(
        origin=site_origin,
        bounds=Bounds(bounds.x_m, bounds.y_m, (0.0, ground.top_m)),
        start_m=_xyz(moved[0]),
        goal_m=_xyz(moved[-1]),
        via_m=tuple(_xyz(p) for p in moved[1:-1]),
        obstacles=standing,
        safety_margin_m=margin_m,
        ground=ground,
        ground_under_m=tuple(float(u) for u in under),
    )


def _xyz(p: Any) -> Point3:
    return (float(p[0]), float(p[1]), float(p[2]))


def _centre(o: Obstacle) -> tuple[float, float]:
    if isinstance(o, PrismObstacle):
        xs, ys = zip(*o.polygon_m, strict=True)
        return (sum(xs) / len(xs), sum(ys) / len(ys))
    return o.center_m
