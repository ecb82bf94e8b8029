"""ENU waypoints → an autopilot-neutral :class:`MissionPlan` (SPEC §4), and back to a polyline.

The scenario's world is flat ground at z = 0 in a local ENU frame. A waypoint ``(x, y, z)``
becomes a NAV_WAYPOINT in MAV_FRAME_GLOBAL_RELATIVE_ALT at the latitude/longitude of the
ground point ``(x, y, 0)`` with altitude ``z`` above home (home is the ground point below
the start). Taking lat/lon from the ground point keeps the model's verticals vertical: a
building at ENU (x, y) stands on the ellipsoid normal through that ground point, and so does
the waypoint. :func:`mission_polyline_enu` inverts this exactly: for a mission built from
waypoints it is :func:`uavplan.route.flown_polyline` of them (to well under a millimetre).
It is for mission *files*; a route that was just planned carries its flown polyline in its
:class:`~uavplan.route.PlannedRoute`.

The items are the same for every autopilot; ArduPilot's home at seq 0 is added by
:meth:`MissionPlan.wire_items`, never here.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uavplan.geo import EnuFrame, GeoPoint
from uavplan.mission.items import (
    Autopilot,
    MavCmd,
    MavFrame,
    MissionItem,
    MissionPlan,
    canonical_frame,
)
from uavplan.route import ALTITUDE_TOLERANCE_M, END_ACTIONS, EndAction, drop_repeats

__all__ = [
    "ALTITUDE_TOLERANCE_M",
    "END_ACTIONS",
    "EndAction",
    "build_mission",
    "mission_polyline_enu",
]

#: DO_CHANGE_SPEED param1: speed type 1 = ground speed (common.xml SPEED_TYPE_GROUNDSPEED)
SPEED_TYPE_GROUND = 1.0
#: DO_CHANGE_SPEED param3: -1 = leave the throttle unchanged
THROTTLE_NO_CHANGE = -1.0


def build_mission(
    waypoints_enu: ArrayLike,
    frame: EnuFrame,
    *,
    autopilot: Autopilot,
    end: EndAction = "rtl",
    takeoff_altitude_m: float | None = None,
    cruise_speed_m_s: float | None = None,
    vehicle_type: int = 2,
) -> MissionPlan:
    """Turn a planned path into mission items.

    ``waypoints_enu``: ``(n, 3)`` ENU metres in ``frame``, n >= 2; row 0 is the start (the
    takeoff x, y and the height to reach there), the last row the goal.

    Items: NAV_TAKEOFF above the start to ``takeoff_altitude_m`` (default: the start's z);
    DO_CHANGE_SPEED (ground speed) if ``cruise_speed_m_s`` is given; a NAV_WAYPOINT at the
    start's height if that differs from the takeoff altitude; a NAV_WAYPOINT per later row;
    then NAV_RETURN_TO_LAUNCH (``end="rtl"``), NAV_LAND at the goal (``"land"``) or nothing
    (``"none"``). Home is the ground point below the start, with an AMSL altitude.

    Raises ``ValueError`` for malformed input (wrong shape, non-finite values, a waypoint
    at or below the ground, a non-positive speed or takeoff altitude, an unknown ``end``).
    """
    points = np.asarray(waypoints_enu, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] < 2:
        raise ValueError(f"waypoints_enu must have shape (n >= 2, 3), got {points.shape}")
    if not np.all(np.isfinite(points)):
        raise ValueError("waypoints_enu must be finite")
    if np.any(points[:, 2] <= 0.0):
        row = int(np.argmax(points[:, 2] <= 0.0))
        raise ValueError(f"waypoint {row} is not above the ground (z = {points[row, 2]} m)")
    if end not in END_ACTIONS:
        raise ValueError(f"end must be one of {', '.join(END_ACTIONS)}; got {end!r}")
    if takeoff_altitude_m is not None and not (
        math.isfinite(takeoff_altitude_m) and takeoff_altitude_m > 0.0
    ):
        raise ValueError(f"takeoff altitude must be > 0 m, got {takeoff_altitude_m!r}")
    if cruise_speed_m_s is not None and not (
        math.isfinite(cruise_speed_m_s) and cruise_speed_m_s > 0.0
    ):
        raise ValueError(f"cruise speed must be > 0 m/s, got {cruise_speed_m_s!r}")

    ground = points.copy()
    ground[:, 2] = 0.0
    lat_deg, lon_deg, alt_m = frame.to_geodetic(ground)
    home = GeoPoint(float(lat_deg[0]), float(lon_deg[0]), float(alt_m[0]))

    start_z = float(points[0, 2])
    takeoff_z = start_z if takeoff_altitude_m is None else float(takeoff_altitude_m)

    items: list[MissionItem] = [
        MissionItem(
            command=MavCmd.NAV_TAKEOFF,
            frame=MavFrame.GLOBAL_RELATIVE_ALT,
            param1=0.0,
            param2=0.0,
            param3=0.0,
            param4=None,  # yaw: keep the current heading
            x=home.lat_deg,
            y=home.lon_deg,
            z=takeoff_z,
        )
    ]
    if cruise_speed_m_s is not None:
        items.append(
            MissionItem(
                command=MavCmd.DO_CHANGE_SPEED,
                frame=MavFrame.MISSION,
                param1=SPEED_TYPE_GROUND,
                param2=float(cruise_speed_m_s),
                param3=THROTTLE_NO_CHANGE,
                param4=0.0,
            )
        )
    first_row = 1
    if abs(takeoff_z - start_z) > ALTITUDE_TOLERANCE_M:
        first_row = 0
    items.extend(
        _waypoint(float(lat_deg[i]), float(lon_deg[i]), float(points[i, 2]))
        for i in range(first_row, len(points))
    )
    if end == "rtl":
        items.append(
            MissionItem(
                command=MavCmd.NAV_RETURN_TO_LAUNCH,
                frame=MavFrame.MISSION,
                param1=0.0,
                param2=0.0,
                param3=0.0,
                param4=0.0,
            )
        )
    elif end == "land":
        items.append(
            MissionItem(
                command=MavCmd.NAV_LAND,
                frame=MavFrame.GLOBAL_RELATIVE_ALT,
                param1=0.0,  # abort altitude: default
                param2=0.0,  # precision landing: off
                param3=0.0,
                param4=None,  # yaw: keep the current heading
                x=float(lat_deg[-1]),
                y=float(lon_deg[-1]),
                z=0.0,
            )
        )

    return MissionPlan(
        items=tuple(items),
        autopilot=autopilot,
        home=home,
        vehicle_type=int(vehicle_type),
        cruise_speed_m_s=None if cruise_speed_m_s is None else float(cruise_speed_m_s),
        hover_speed_m_s=None if cruise_speed_m_s is None else float(cruise_speed_m_s),
    )


def _waypoint(lat_deg: float, lon_deg: float, alt_m: float) -> MissionItem:
    return MissionItem(
        command=MavCmd.NAV_WAYPOINT,
        frame=MavFrame.GLOBAL_RELATIVE_ALT,
        param1=0.0,  # hold time s
        param2=0.0,  # acceptance radius: autopilot default
        param3=0.0,  # pass through
        param4=None,  # yaw: autopilot decides
        x=lat_deg,
        y=lon_deg,
        z=alt_m,
    )


#: MAV_CMD values below this are NAV commands (positions the vehicle flies to)
_FIRST_NON_NAV_COMMAND = 100

_RELATIVE_FRAMES = frozenset(
    {int(MavFrame.GLOBAL_RELATIVE_ALT), int(MavFrame.GLOBAL_TERRAIN_ALT)}
)  # canonical spellings; terrain height = height above the flat ground


def mission_polyline_enu(plan: MissionPlan, frame: EnuFrame) -> NDArray[np.float64]:
    """The path the vehicle flies through ``plan``'s items, as ENU points ``(n, 3)``.

    Starts at home on the ground (or, without a home, at the first positional item), climbs
    vertically on NAV_TAKEOFF, flies straight to each positional NAV item, and for NAV_LAND
    flies to the landing point at its current height and descends. Items without a position
    (frame MAV_FRAME_MISSION: speed changes, jumps) do not move the vehicle; DO_JUMP loops
    are not unrolled. The polyline ends at NAV_RETURN_TO_LAUNCH: the return leg is the
    autopilot's (its height comes from RTL parameters), not part of the plan.

    Relative and terrain altitudes are heights above the flat ground (z); AMSL altitudes are
    taken relative to home. NAV_LAND at lat/lon 0 lands where the vehicle is, as the
    autopilots read it.
    """
    home_alt_m = plan.home.alt_m if plan.home is not None else None
    flown: list[MissionItem] = []
    for item in plan.items:
        if item.command == MavCmd.NAV_RETURN_TO_LAUNCH:
            break
        if item.is_global and item.command < _FIRST_NON_NAV_COMMAND:
            flown.append(item)
        if item.command == MavCmd.NAV_LAND:
            break

    lat_deg = [item.lat_deg for item in flown]
    lon_deg = [item.lon_deg for item in flown]
    if plan.home is not None:
        lat_deg.insert(0, plan.home.lat_deg)
        lon_deg.insert(0, plan.home.lon_deg)
    xy = frame.to_enu_xy(lat_deg, lon_deg) if lat_deg else np.empty((0, 2))

    points: list[tuple[float, float, float]] = []
    if plan.home is not None:
        points.append((float(xy[0, 0]), float(xy[0, 1]), 0.0))
        xy = xy[1:]
    for item, (x, y) in zip(flown, xy, strict=True):
        z = _height_above_ground(item, home_alt_m)
        if points and (
            item.command == MavCmd.NAV_TAKEOFF  # takeoff climbs where the vehicle is
            or (item.command == MavCmd.NAV_LAND and item.x == 0.0 and item.y == 0.0)
        ):
            x, y = points[-1][0], points[-1][1]
        if item.command == MavCmd.NAV_LAND and points:
            points.append((float(x), float(y), points[-1][2]))
        points.append((float(x), float(y), z))
    return drop_repeats(np.array(points, dtype=np.float64).reshape(-1, 3))


def _height_above_ground(item: MissionItem, home_alt_m: float | None) -> float:
    frame = canonical_frame(item.frame)
    if frame in _RELATIVE_FRAMES:
        return item.alt_m
    if frame == MavFrame.GLOBAL:
        if home_alt_m is None:
            raise ValueError("an AMSL (frame 0) item needs the plan's home altitude")
        return item.alt_m - home_alt_m
    raise ValueError(f"frame {item.frame} is not a global frame")  # pragma: no cover
