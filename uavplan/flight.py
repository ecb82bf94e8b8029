"""The check of a flown line against a world: one implementation for every command.

A :class:`Flight` is what a vehicle flies (or flew): ENU points in a site's frame, and which
of them are in the air. The take-off climb from the ground and the landing descent to it
start or end on the ground, so they are checked against the obstacles only; everything in
between is checked against the whole world, the terrain and its ceiling included. A flight
comes from a route that was just planned (:meth:`Flight.from_polyline`), from a mission file
(:func:`flight_of_mission`: the autopilot's reading of its items, through
:func:`uavplan.mission.builder.mission_polyline_enu`, the one reconstruction) or from a
flown track (any polyline, with the points where it left and reached the ground).

:func:`check_flight` measures it: the clearance of every segment, what is nearest, and the
first point outside the flight volume. ``plan`` reports its clearance, and ``validate
MISSION --scenario``, ``render --mission`` and the rerouting of a QGroundControl plan all
check through it, so they agree to the last digit.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from uavplan.geo import EnuFrame
from uavplan.mission.builder import mission_polyline_enu
from uavplan.mission.items import MavCmd, MissionPlan
from uavplan.route import Follow, keeps_margin
from uavplan.world import CEILING, GROUND, World

#: consecutive points closer than this horizontally are "the same place" (a climb or a
#: descent): files round positions to about a centimetre
VERTICAL_TOL_M = 0.05
#: a flown point may be this far outside the flight volume (files round positions)
VOLUME_TOL_M = 0.05


@dataclass(frozen=True, eq=False)
class Flight:
    """A flown line ``points_enu`` ``(n, 3)``; ``points_enu[airborne[0]]`` to
    ``points_enu[airborne[1]]`` are in the air, the segments before them (the take-off climb)
    and after them (the landing descent) touch the ground."""

    points_enu: NDArray[np.float64]
    airborne: tuple[int, int]

    def __post_init__(self) -> None:
        p = self.points_enu
        if p.ndim != 2 or p.shape[1] != 3 or not np.all(np.isfinite(p)):
            raise ValueError(f"a flight is finite ENU points (n, 3), got shape {p.shape}")
        first, last = self.airborne
        if len(p) and not 0 <= first <= last < len(p):
            raise ValueError(f"airborne {self.airborne} is not within {len(p)} points")

    @classmethod
    def from_polyline(
        cls, points_enu: NDArray[np.float64], *, from_ground: bool, to_ground: bool
    ) -> Flight:
        """The flight of a polyline that, with ``from_ground``, begins with a vertical climb
        from the ground (every leading point above the first: the take-off, and a climb to
        the first waypoint's height) and, with ``to_ground``, ends with a vertical descent to
        it (the landing)."""
        p = np.asarray(points_enu, dtype=np.float64).reshape(-1, 3)
        n = len(p)
        first, last = 0, max(n - 1, 0)
        if from_ground:
            while first + 1 < n and _same_place(p[first + 1], p[0]):
                first += 1
        if to_ground:
            while last - 1 > first and _same_place(p[last - 1], p[-1]):
                last -= 1
        return cls(p, (first, last))

    @property
    def length_m(self) -> float:
        return float(np.linalg.norm(np.diff(self.points_enu, axis=0), axis=1).sum())


def _same_place(a: NDArray[np.float64], b: NDArray[np.float64]) -> bool:
    return math.hypot(float(a[0] - b[0]), float(a[1] - b[1])) <= VERTICAL_TOL_M


def flight_of_mission(
    plan: MissionPlan,
    frame: EnuFrame,
    ground_z: Callable[[NDArray[np.float64]], NDArray[np.float64]] | None = None,
    follow: Follow | None = None,
) -> Flight:
    """The flight the autopilot flies through ``plan`` in ``frame``, over the ground
    ``ground_z`` (ENU ``(n, 2)`` → z; None: flat at z = 0): from home on the ground, to the
    return to launch or the landing, terrain-frame legs flown over the ground as ``follow``
    says (:meth:`uavplan.ground.Ground.follow`). Raises ``ValueError`` when an item's
    altitude cannot be placed."""
    points = mission_polyline_enu(plan, frame, ground_z, follow)
    return Flight.from_polyline(points, from_ground=plan.home is not None, to_ground=_lands(plan))


def _lands(plan: MissionPlan) -> bool:
    """Does the flown part of ``plan`` end with a landing (NAV_LAND before any RTL)?"""
    for item in plan.items:
        if item.command == MavCmd.NAV_RETURN_TO_LAUNCH:
            return False
        if item.command == MavCmd.NAV_LAND:
            return True
    return False


@dataclass(frozen=True, eq=False)
class FlightCheck:
    """A flight measured against a world that keeps ``margin_m``.

    ``clearance_m`` ``(n - 1,)``: each segment's distance to the nearest thing it must keep
    clear of; ``worst`` the segment with the least and ``nearest`` what that is (in words:
    ``obstacles[3]``, ``the terrain at (120, -40)``, ...); ``outside`` the first point outside
    the flight volume (None: none)."""

    flight: Flight
    clearance_m: NDArray[np.float64]
    worst: int
    nearest: str
    margin_m: float
    outside: int | None

    @property
    def min_clearance_m(self) -> float:
        return float(self.clearance_m[self.worst]) if self.clearance_m.size else math.inf

    @property
    def keeps_margin(self) -> bool:
        return keeps_margin(self.min_clearance_m, self.margin_m)

    @property
    def ok(self) -> bool:
        """Inside the flight volume and never closer than the margin."""
        return self.outside is None and self.keeps_margin

    def problem(self) -> str | None:
        """What is wrong with the flight, in words (None: nothing)."""
        if self.outside is not None:
            point = self.flight.points_enu[self.outside].round(1).tolist()
            return f"point {self.outside} of the flown path {point} is outside the flight volume"
        if not self.keeps_margin:
            return (
                f"leg {self.worst} of the flown path comes within {self.min_clearance_m:.2f} m "
                f"of {self.nearest} (safety margin {self.margin_m:g} m)"
            )
        return None


def flight_clearance(
    world: World, flight: Flight
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
    """Per segment of ``flight``: (distance, obstacle index or :data:`~uavplan.world.GROUND`
    / :data:`~uavplan.world.CEILING` or -1, nearest piece of ``world`` or -1). Airborne
    segments are measured against the whole world, the climb and the descent against its
    obstacles only (over flat ground the world holds nothing else)."""
    p = flight.points_enu
    if len(p) < 2:
        empty = np.empty(0, dtype=np.int64)
        return np.empty(0), empty, empty
    if not world.has_ground:
        dist, piece = world.segments_nearest(p[:-1], p[1:])
        return dist, world.owner_of(piece), piece
    obstacles = world.without_ground()
    dist, piece = obstacles.segments_nearest(p[:-1], p[1:])
    owner = obstacles.owner_of(piece)
    first, last = flight.airborne
    if last > first:
        d_air, p_air = world.segments_nearest(p[first:last], p[first + 1 : last + 1])
        closer = d_air < dist[first:last]
        dist[first:last] = np.where(closer, d_air, dist[first:last])
        owner[first:last] = np.where(closer, world.owner_of(p_air), owner[first:last])
        piece[first:last] = np.where(closer, p_air, piece[first:last])
    return dist, owner, piece


def check_flight(
    world: World, flight: Flight, *, name_of: Callable[[int], str], margin_m: float | None = None
) -> FlightCheck:
    """Measure ``flight`` in ``world`` (see :class:`FlightCheck`); ``name_of(i)`` names
    obstacle ``i`` of the world for the message; ``margin_m`` defaults to the world's."""
    margin = world.margin_m if margin_m is None else float(margin_m)
    dist, owner, _ = flight_clearance(world, flight)
    p = flight.points_enu
    first, last = flight.airborne
    lifted = p.copy()  # the ground below the take-off and the landing is not "outside"
    grounded = np.ones(len(p), dtype=bool)
    grounded[first : last + 1] = False
    lifted[grounded, 2] = np.maximum(lifted[grounded, 2], world.zlim[0])
    inside = world.points_inside_bounds(lifted, tol_m=VOLUME_TOL_M)
    outside = None if inside.all() else int(np.flatnonzero(~inside)[0])
    worst = int(np.argmin(dist)) if dist.size else 0
    nearest = "nothing"
    if dist.size and owner[worst] != -1:
        nearest = _describe(world, int(owner[worst]), p[worst], p[worst + 1], name_of)
    return FlightCheck(flight, dist, worst, nearest, margin, outside)


def _describe(
    world: World,
    owner: int,
    a: NDArray[np.float64],
    b: NDArray[np.float64],
    name_of: Callable[[int], str],
) -> str:
    """What segment a→b comes nearest, in words: an obstacle's name, or the terrain and
    where (the closest point of its surface)."""
    if owner not in (GROUND, CEILING):
        return name_of(owner)
    _, _, where = world.terrain_nearest(a, b)
    x, y = (float(v) for v in where[0])
    if owner == CEILING:
        return f"the ceiling (bounds.z max above the ground) over ({x:.0f}, {y:.0f})"
    return f"the terrain at ({x:.0f}, {y:.0f})"
