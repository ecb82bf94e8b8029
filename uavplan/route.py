"""A planned route: the one value carried from the planner to the mission builder, the
geofence, the map exports and the pictures.

Everything in it is in one local ENU frame (x east, y north, z up, metres), and the frame
itself travels with it, so nobody rebuilds ENU points from mission items. The *flown*
polyline is what the autopilot flies through the mission built from the route: the vertical
take-off climb from the ground below the start, the straight legs between the waypoints and,
when the mission ends with a landing, the descent at the goal. :func:`flown_polyline` is the
single definition of it; the mission builder's inverse (items → ENU) produces the same line.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from uavplan.config import END_ACTIONS, EndAction
from uavplan.geo import EnuFrame

__all__ = [
    "ALTITUDE_TOLERANCE_M",
    "END_ACTIONS",
    "EndAction",
    "Follow",
    "PlannedRoute",
    "densify",
    "drop_repeats",
    "flown_polyline",
    "keeps_margin",
]

#: an altitude difference below this is "the same altitude" (ArduPilot stores centimetres)
ALTITUDE_TOLERANCE_M = 0.01

#: how a leg into a waypoint is flown over the ground, when not straight: (a, b) → the flown
#: points after a, b last (:meth:`uavplan.ground.Ground.follow` for terrain-frame legs)
Follow = Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]


def flown_polyline(
    waypoints_enu: NDArray[np.float64],
    *,
    takeoff_altitude_m: float | None = None,
    end: EndAction = "rtl",
    ground_z_m: tuple[float, float] = (0.0, 0.0),
    takeoff: bool = True,
    follow: Follow | None = None,
    return_enu: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
    """The polyline the vehicle flies for these waypoints, ``(n, 3)`` ENU metres.

    Row 0 of ``waypoints_enu`` is the start (the take-off x, y and the height to fly on from),
    the last row the goal. The vehicle climbs vertically from the ground below the start
    (z = ``ground_z_m[0]``) to ``takeoff_altitude_m`` above it (default: the start's height),
    flies to the start's height if that differs, then straight from waypoint to waypoint;
    with ``end="land"`` it descends vertically at the goal to the ground there
    (``ground_z_m[1]``). The RTL leg home is the autopilot's and not part of the line.
    With ``end="return"`` and ``return_enu`` (the planned return's waypoints, the goal first
    and the point above home last) the line flies them and descends vertically to home
    (``ground_z_m[0]``). Without ``takeoff`` the line begins in the air at the start (a
    stretch of a longer flight). With ``follow`` every leg into a waypoint is flown as it says
    (terrain-frame waypoints: over the ground) instead of straight.
    """
    w = np.asarray(waypoints_enu, dtype=np.float64)
    sx, sy, sz = (float(v) for v in w[0])
    home_z, landing_z = float(ground_z_m[0]), float(ground_z_m[1])
    takeoff_z = sz if takeoff_altitude_m is None else home_z + float(takeoff_altitude_m)
    rows = [np.array([[sx, sy, home_z], [sx, sy, takeoff_z]])] if takeoff else []
    legs = w if abs(takeoff_z - sz) > ALTITUDE_TOLERANCE_M or not takeoff else w[1:]
    if follow is None:
        rows.append(legs)
    else:
        last = rows[-1][-1] if rows else None
        for b in legs:
            rows.append(b[None, :] if last is None else follow(last, b))
            last = b
    if end == "land":
        gx, gy, _ = (float(v) for v in w[-1])
        rows.append(np.array([[gx, gy, landing_z]]))
    elif end == "return" and return_enu is not None:
        back = np.asarray(return_enu, dtype=np.float64).reshape(-1, 3)
        hx, hy, _ = (float(v) for v in back[-1])
        rows.extend([back, np.array([[hx, hy, home_z]])])
    return drop_repeats(np.vstack(rows))


def densify(points: NDArray[np.float64], step_m: float) -> NDArray[np.float64]:
    """The polyline sampled at most ``step_m`` apart horizontally, every vertex included (a
    vertical leg keeps just its ends): for checks against things that vary over the ground."""
    p = np.asarray(points, dtype=np.float64)
    if len(p) < 2:
        return p
    pieces = [p[:1]]
    for a, b in itertools.pairwise(p):
        n = max(1, math.ceil(float(np.hypot(*(b[:2] - a[:2]))) / step_m))
        t = np.arange(1, n + 1)[:, None] / n
        pieces.append(a + t * (b - a))
    return np.vstack(pieces)


def drop_repeats(points: NDArray[np.float64], tol_m: float = 1e-9) -> NDArray[np.float64]:
    """Remove consecutive duplicate points (a zero-length leg says nothing about clearance)."""
    p = np.asarray(points, dtype=np.float64)
    if len(p) < 2:
        return p
    keep = np.ones(len(p), dtype=bool)
    keep[1:] = np.any(np.abs(np.diff(p, axis=0)) > tol_m, axis=1)
    return p[keep]


@dataclass(frozen=True, eq=False)
class PlannedRoute:
    """A collision-checked route in the local ENU frame ``frame``.

    ``waypoints_enu`` (w, 3): what the autopilot flies between, start first, goal last.
    ``path_enu`` (k, 3): the dense smoothed curve the waypoints were taken from.
    ``vertices_enu`` (m, 3): the simplified polyline the curve passes through.
    ``raw_path_enu`` (d, 3): the search's best node path (for pictures), or None.
    ``flown_enu`` (f, 3): :func:`flown_polyline` of the waypoints (take-off and landing
    included), the line whose clearance ``min_clearance_m`` is.
    ``inside_bounds``: every flown point is inside the flight volume.
    """

    frame: EnuFrame
    waypoints_enu: NDArray[np.float64]
    path_enu: NDArray[np.float64]
    vertices_enu: NDArray[np.float64]
    raw_path_enu: NDArray[np.float64] | None
    flown_enu: NDArray[np.float64]
    min_clearance_m: float
    safety_margin_m: float
    inside_bounds: bool
    takeoff_altitude_m: float | None = None
    end: EndAction = "rtl"
    #: with terrain: the ground's z under each waypoint (None: flat ground at z = 0)
    waypoint_ground_z_m: NDArray[np.float64] | None = None
    #: with terrain: the z of the datum in metres AMSL (the frame's origin altitude)
    datum_amsl_m: float | None = None
    #: ``end="return"``: the planned return's waypoints (r, 3), the goal first and the point
    #: above home last (its landing descends from there); ``flown_enu`` flies them
    return_enu: NDArray[np.float64] | None = None
    #: with terrain: the ground's z under each return waypoint
    return_ground_z_m: NDArray[np.float64] | None = None
    #: rows of ``return_enu`` (0: the goal) the vehicle must fly to a stop instead of
    #: cutting the corner there (the corner's shortcut would not keep the margin)
    return_stops: tuple[int, ...] = ()

    #: clearance may fall short of the margin by this much (floating point, not rounding:
    #: planning keeps a 2 cm pad so files that round positions still keep the margin)
    CLEARANCE_TOL_M = 1e-6

    @property
    def collision_free(self) -> bool:
        """Inside the bounds and never closer than the safety margin: the one decision."""
        return self.inside_bounds and keeps_margin(self.min_clearance_m, self.safety_margin_m)

    @property
    def length_m(self) -> float:
        """Length of the smoothed path (start to goal)."""
        return float(np.linalg.norm(np.diff(self.path_enu, axis=0), axis=1).sum())


def keeps_margin(clearance_m: float, margin_m: float) -> bool:
    """Does a measured clearance keep the safety margin? (One tolerance for every check.)"""
    return math.isfinite(margin_m) and clearance_m >= margin_m - PlannedRoute.CLEARANCE_TOL_M
