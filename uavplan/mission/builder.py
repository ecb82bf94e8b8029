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
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace

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
from uavplan.route import ALTITUDE_TOLERANCE_M, END_ACTIONS, EndAction, Follow, drop_repeats

__all__ = [
    "ALTITUDE_TOLERANCE_M",
    "END_ACTIONS",
    "EndAction",
    "build_mission",
    "mission_polyline_enu",
]

#: NAV_WAYPOINT param1 (hold time, s) where the vehicle must fly to a stop rather than cut the
#: corner: both firmwares stop at a waypoint with a hold time (ArduPilot keeps whole seconds)
CORNER_HOLD_S = 1.0
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
    ground_z_m: ArrayLike | None = None,
    altitude: str = "relative",
    return_enu: ArrayLike | None = None,
    return_ground_z_m: ArrayLike | None = None,
    return_stops: tuple[int, ...] = (),
    row_items: Mapping[int, Sequence[MissionItem]] | None = None,
    row_hold_s: Mapping[int, float] | None = None,
) -> MissionPlan:
    """Turn a planned path into mission items.

    ``waypoints_enu``: ``(n, 3)`` ENU metres in ``frame``, n >= 2; row 0 is the start (the
    takeoff x, y and the height to reach there), the last row the goal.

    Items: NAV_TAKEOFF above the start to ``takeoff_altitude_m`` (default: the start's z);
    DO_CHANGE_SPEED (ground speed) if ``cruise_speed_m_s`` is given; a NAV_WAYPOINT at the
    start's height if that differs from the takeoff altitude; a NAV_WAYPOINT per later row;
    then NAV_RETURN_TO_LAUNCH (``end="rtl"``), NAV_LAND at the goal (``"land"``), nothing
    (``"none"``), or (``"return"``) the planned return ``return_enu`` ``(r, 3)`` (the goal
    first, the point above home last; ``return_ground_z_m`` the ground under each): a
    DO_LAND_START at the goal that marks it as the mission's landing sequence, a
    NAV_WAYPOINT per later row and NAV_LAND at home; the rows ``return_stops`` (0: the goal)
    get a hold time of :data:`CORNER_HOLD_S`, so the autopilot flies to a stop there
    instead of cutting the corner. Every waypoint leaves param 2 (the acceptance radius) at 0,
    the autopilot's own (PX4's NAV_ACC_RAD; ArduPilot Copter ignores it): PX4 SITL, held to
    0.5 m, stalled for up to a minute short of a waypoint it trailed by more than that
    (docs/flight-model.md, "Held against the firmware"). Home is the ground point below the
    start, with an AMSL altitude.

    ``ground_z_m`` ``(n,)``: the ground's z under each waypoint (terrain; default flat ground
    at z = 0); home is on the ground under row 0. ``altitude``: ``"relative"`` (above home,
    MAV_FRAME_GLOBAL_RELATIVE_ALT), ``"amsl"`` (MAV_FRAME_GLOBAL) or ``"terrain"`` (above
    the ground beneath each waypoint, MAV_FRAME_GLOBAL_TERRAIN_ALT); the take-off climbs
    ``takeoff_altitude_m`` above home in every mode.

    ``row_items``: command items (no position, e.g. camera triggering) placed right after
    the NAV_WAYPOINT of a row (rows >= 1); ``row_hold_s``: a hold time (s) at a row's
    waypoint (rows >= 1). Both default to none, which leaves every other mission unchanged.

    Raises ``ValueError`` for malformed input (wrong shape, non-finite values, a waypoint
    at or below the ground, a non-positive speed or takeoff altitude, an unknown ``end``).
    """
    points = np.asarray(waypoints_enu, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] < 2:
        raise ValueError(f"waypoints_enu must have shape (n >= 2, 3), got {points.shape}")
    if not np.all(np.isfinite(points)):
        raise ValueError("waypoints_enu must be finite")
    under = (
        np.zeros(len(points))
        if ground_z_m is None
        else np.asarray(ground_z_m, dtype=np.float64).reshape(-1)
    )
    if under.shape != (len(points),) or not np.all(np.isfinite(under)):
        raise ValueError(f"ground_z_m must hold one finite height per waypoint ({len(points)})")
    agl = points[:, 2] - under
    if np.any(agl <= 0.0):
        row = int(np.argmax(agl <= 0.0))
        raise ValueError(f"waypoint {row} is not above the ground ({agl[row]} m above it)")
    if altitude not in ALTITUDE_FRAMES:
        raise ValueError(f"altitude must be one of {', '.join(ALTITUDE_FRAMES)}; got {altitude!r}")
    if end not in END_ACTIONS:
        raise ValueError(f"end must be one of {', '.join(END_ACTIONS)}; got {end!r}")
    back = None
    if end == "return":
        if return_enu is None:
            raise ValueError('end="return" needs the planned return (return_enu)')
        back = np.asarray(return_enu, dtype=np.float64)
        if back.ndim != 2 or back.shape[1] != 3 or len(back) < 2 or not np.isfinite(back).all():
            raise ValueError(f"return_enu must be finite, shape (r >= 2, 3), got {back.shape}")
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
    home_z = float(under[0])
    # over flat ground home is the ground point below the start (its altitude includes the
    # tangent plane's rise over the ellipsoid there, a few cm per km); over terrain z is
    # metres above the datum, the frame's origin altitude, so AMSL = datum + z exactly
    ref_alt = float(alt_m[0]) if ground_z_m is None else float(frame.origin.alt_m)
    home = GeoPoint(float(lat_deg[0]), float(lon_deg[0]), ref_alt + home_z)
    item_frame = ALTITUDE_FRAMES[altitude]
    if altitude == "relative":
        item_z = points[:, 2] - home_z
    elif altitude == "amsl":
        item_z = points[:, 2] + ref_alt
    else:
        item_z = agl

    start_agl = float(points[0, 2]) - home_z  # above home
    takeoff_agl = start_agl if takeoff_altitude_m is None else float(takeoff_altitude_m)
    takeoff_z = takeoff_agl + (home.alt_m if altitude == "amsl" else 0.0)

    items: list[MissionItem] = [
        MissionItem(
            command=MavCmd.NAV_TAKEOFF,
            frame=item_frame,
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
    if abs(takeoff_agl - start_agl) > ALTITUDE_TOLERANCE_M:
        first_row = 0
    extra = dict(row_items or {})
    holds = dict(row_hold_s or {})
    for row in (*extra, *holds):
        if not 1 <= row < len(points):
            raise ValueError(
                f"row_items / row_hold_s row {row} is not a waypoint row (1..{len(points) - 1})"
            )
    for i in range(first_row, len(points)):
        wp = _waypoint(float(lat_deg[i]), float(lon_deg[i]), float(item_z[i]), item_frame)
        if i in holds:
            wp = replace(wp, param1=float(holds[i]))
        items.append(wp)
        items.extend(extra.get(i, ()))
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
                frame=item_frame,
                param1=0.0,  # abort altitude: default
                param2=0.0,  # precision landing: off
                param3=0.0,
                param4=None,  # yaw: keep the current heading
                x=float(lat_deg[-1]),
                y=float(lon_deg[-1]),
                z=ref_alt + float(under[-1]) if altitude == "amsl" else 0.0,
            )
        )

    if back is not None:
        if 0 in return_stops:
            goal = next(i for i in range(len(items) - 1, -1, -1) if items[i].command == 16)
            items[goal] = replace(items[goal], param1=CORNER_HOLD_S)
        items.extend(
            _planned_return(
                back, frame, ref_alt, home_z, under[-1], return_ground_z_m, altitude, home,
                return_stops,
            )
        )  # fmt: skip

    return MissionPlan(
        items=tuple(items),
        autopilot=autopilot,
        home=home,
        vehicle_type=int(vehicle_type),
        cruise_speed_m_s=None if cruise_speed_m_s is None else float(cruise_speed_m_s),
        hover_speed_m_s=None if cruise_speed_m_s is None else float(cruise_speed_m_s),
    )


def _planned_return(
    back: NDArray[np.float64],
    frame: EnuFrame,
    ref_alt: float,
    home_z: float,
    goal_ground_z: float,
    ground_z_m: ArrayLike | None,
    altitude: str,
    home: GeoPoint,
    stops: tuple[int, ...] = (),
) -> list[MissionItem]:
    """DO_LAND_START at the goal (the landing sequence begins there), the return's
    waypoints after the goal (a hold time at ``stops``), NAV_LAND at home (see
    :func:`build_mission`)."""
    under = (
        np.full(len(back), home_z)
        if ground_z_m is None
        else np.asarray(ground_z_m, dtype=np.float64).reshape(-1)
    )
    if under.shape != (len(back),) or not np.all(np.isfinite(under)):
        raise ValueError(f"return_ground_z_m must hold one height per return row ({len(back)})")
    if ground_z_m is None:
        under[0] = goal_ground_z
    if np.any(back[:, 2] - under <= 0.0):
        raise ValueError("a return waypoint is not above the ground")
    ground = back.copy()
    ground[:, 2] = 0.0
    lat_deg, lon_deg, _ = frame.to_geodetic(ground)
    # the last row is above home: written as home's own position, to the last bit (a batch
    # of conversions can differ from home's in the last bits: 47.397742000000015)
    lat_deg, lon_deg = np.array(lat_deg, dtype=np.float64), np.array(lon_deg, dtype=np.float64)
    lat_deg[-1], lon_deg[-1] = home.lat_deg, home.lon_deg
    item_frame = ALTITUDE_FRAMES[altitude]
    if altitude == "relative":
        item_z = back[:, 2] - home_z
    elif altitude == "amsl":
        item_z = back[:, 2] + ref_alt
    else:
        item_z = back[:, 2] - under
    items = [
        MissionItem(
            command=MavCmd.DO_LAND_START,
            frame=item_frame,
            param1=0.0,
            param2=0.0,
            param3=0.0,
            param4=0.0,
            x=float(lat_deg[0]),
            y=float(lon_deg[0]),
            z=float(item_z[0]),
        )
    ]
    for i in range(1, len(back)):
        item = _waypoint(float(lat_deg[i]), float(lon_deg[i]), float(item_z[i]), item_frame)
        hold = CORNER_HOLD_S if i in stops else 0.0
        items.append(replace(item, param1=hold))
    items.append(
        MissionItem(
            command=MavCmd.NAV_LAND,
            frame=item_frame,
            param1=0.0,  # abort altitude: default
            param2=0.0,  # precision landing: off
            param3=0.0,
            param4=None,  # yaw: keep the current heading
            x=home.lat_deg,
            y=home.lon_deg,
            z=home.alt_m if altitude == "amsl" else 0.0,
        )
    )
    return items


def _waypoint(
    lat_deg: float, lon_deg: float, alt_m: float, frame: MavFrame = MavFrame.GLOBAL_RELATIVE_ALT
) -> MissionItem:
    return MissionItem(
        command=MavCmd.NAV_WAYPOINT,
        frame=frame,
        param1=0.0,  # hold time s
        param2=0.0,  # acceptance radius: autopilot default
        param3=0.0,  # pass through
        param4=None,  # yaw: autopilot decides
        x=lat_deg,
        y=lon_deg,
        z=alt_m,
    )


#: mission.altitude → the frame of every positional item
ALTITUDE_FRAMES = {
    "relative": MavFrame.GLOBAL_RELATIVE_ALT,
    "amsl": MavFrame.GLOBAL,
    "terrain": MavFrame.GLOBAL_TERRAIN_ALT,
}

#: MAV_CMD values below this are NAV commands (positions the vehicle flies to)
_FIRST_NON_NAV_COMMAND = 100

_RELATIVE_FRAMES = frozenset(
    {int(MavFrame.GLOBAL_RELATIVE_ALT), int(MavFrame.GLOBAL_TERRAIN_ALT)}
)  # canonical spellings; terrain height = height above the flat ground


def mission_polyline_enu(
    plan: MissionPlan,
    frame: EnuFrame,
    ground_z: Callable[[NDArray[np.float64]], NDArray[np.float64]] | None = None,
    follow: Follow | None = None,
) -> NDArray[np.float64]:
    """The path the vehicle flies through ``plan``'s items, as ENU points ``(n, 3)``.

    Starts at home on the ground (or, without a home, at the first positional item), climbs
    vertically on NAV_TAKEOFF, flies straight to each positional NAV item, and for NAV_LAND
    flies to the landing point at its current height and descends. Items without a position
    (frame MAV_FRAME_MISSION: speed changes, jumps) do not move the vehicle; DO_JUMP loops
    are not unrolled. The polyline ends at NAV_RETURN_TO_LAUNCH: the return leg is the
    autopilot's (its height comes from RTL parameters), not part of the plan.

    Over flat ground (``ground_z`` None) relative and terrain altitudes are heights above
    the ground (z); AMSL altitudes are taken relative to home. With ``ground_z`` (ENU
    ``(n, 2)`` → the ground's z in ``frame``, e.g. from a DEM) home stands on the ground
    there, relative altitudes are above home, AMSL ones are placed through home's AMSL
    altitude, terrain ones are above the ground beneath the item, and a landing descends to
    the ground. NAV_LAND at lat/lon 0 lands where the vehicle is, as the autopilots read it.
    With ``follow`` as well, a leg into a terrain-frame item is flown as ArduPilot flies it,
    over the ground (``follow(a, b)``: the flown points after a, b last); without it, straight.
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

    def ground_at(x: float, y: float) -> float:
        if ground_z is None:
            return 0.0
        return float(np.asarray(ground_z(np.array([[x, y]], dtype=np.float64))).reshape(-1)[0])

    points: list[tuple[float, float, float]] = []
    home_z = 0.0
    if plan.home is not None:
        home_z = ground_at(float(xy[0, 0]), float(xy[0, 1]))
        points.append((float(xy[0, 0]), float(xy[0, 1]), home_z))
        xy = xy[1:]
    for item, (x, y) in zip(flown, xy, strict=True):
        if points and (
            item.command == MavCmd.NAV_TAKEOFF  # takeoff climbs where the vehicle is
            or (item.command == MavCmd.NAV_LAND and item.x == 0.0 and item.y == 0.0)
        ):
            x, y = points[-1][0], points[-1][1]
        if ground_z is None:
            z = _height_above_ground(item, home_alt_m)
        elif item.command == MavCmd.NAV_LAND:
            z = ground_at(float(x), float(y))
        else:
            z = _on_terrain(item, home_alt_m, home_z, ground_at(float(x), float(y)))
        if item.command == MavCmd.NAV_LAND and points:
            points.append((float(x), float(y), points[-1][2]))
        over_ground = (
            follow is not None
            and ground_z is not None
            and points
            and item.command not in (MavCmd.NAV_TAKEOFF, MavCmd.NAV_LAND)
            and canonical_frame(item.frame) == MavFrame.GLOBAL_TERRAIN_ALT
        )
        if over_ground:
            assert follow is not None
            leg = follow(np.array(points[-1]), np.array([float(x), float(y), z]))
            points.extend((float(p[0]), float(p[1]), float(p[2])) for p in leg[:-1])
        points.append((float(x), float(y), z))
    return drop_repeats(np.array(points, dtype=np.float64).reshape(-1, 3))


def _on_terrain(item: MissionItem, home_alt_m: float | None, home_z: float, ground: float) -> float:
    """An item's z over terrain: home stands on the ground at ``home_z``."""
    frame = canonical_frame(item.frame)
    if frame == MavFrame.GLOBAL_TERRAIN_ALT:
        return ground + item.alt_m
    return home_z + _height_above_ground(item, home_alt_m)


def _height_above_ground(item: MissionItem, home_alt_m: float | None) -> float:
    frame = canonical_frame(item.frame)
    if frame in _RELATIVE_FRAMES:
        return item.alt_m
    if frame == MavFrame.GLOBAL:
        if home_alt_m is None:
            raise ValueError("an AMSL (frame 0) item needs the plan's home altitude")
        return item.alt_m - home_alt_m
    raise ValueError(f"frame {item.frame} is not a global frame")  # pragma: no cover
