"""A QGroundControl plan as input: reroute a user's mission around its own exclusion zones.

:func:`reroute_plan` reads the route out of a :class:`~uavplan.mission.items.MissionPlan`
(take-off, navigation waypoints, landing, in order), turns the plan's geofence into obstacles
of a flight volume, plans every leg between consecutive user positions with the project's
planner (:func:`uavplan.planning.plan_route`) and returns the same plan with planned
intermediate NAV_WAYPOINTs inserted between the user's positions. Every item the user made
stays, unchanged and in order: speed changes, camera and gimbal commands, loiters, ROI, the
fence, the rally points, the home and the autopilot flavour.

How the plan is read (docs/reroute.md tells the user the same):

* ENU frame: the planned home on flat ground (or the ``--scenario``'s origin, when one is
  given: the home's ground is then taken as that scenario's ground, z = 0).
* Heights: relative frames (3/6) are heights above home; AMSL frames (0/5) are converted with
  the home's altitude; terrain frames (10/11) are treated as relative (flat ground; a note
  says so).
* NAV_TAKEOFF climbs above home (the vehicle takes off where it stands, as the autopilots
  fly it): the route starts at (home x, y, take-off altitude). NAV_LAND flies to its point at
  the current height and descends there (``end = "land"``; at lat/lon 0 it lands where the
  vehicle is); NAV_RETURN_TO_LAUNCH ends the route (``end = "rtl"``; the flight home is the
  autopilot's and is only checked, not planned); otherwise the end is ``"none"``.
* The geofence: exclusion polygons and circles become prisms / cylinders taller than the
  flight volume; inclusion polygons and circles (their union) bound the route: the bounds
  are the union's bounding box and the part of that box outside the union becomes prisms.
  The route keeps the safety margin from the inclusion fence's edge too.
* Without an inclusion fence the flight volume is the bounding box of home, the positions and
  the exclusion zones grown by ``VOLUME_PAD_M`` plus the margin, with a ceiling
  ``VOLUME_PAD_M`` above the highest position (a ``--scenario``'s own bounds, when one is
  given). Fence obstacles stand ``VOLUME_PAD_M`` above the ceiling (:mod:`uavplan.airspace`).
* Over a scenario with terrain: the plan read as the autopilot flies it over the DEM, the
  planned waypoints in the frame of the item they lead to, terrain-frame legs flown over the
  ground (:func:`reroute_plan`).
* DO_JUMP is refused: a loop's legs cannot be rerouted without guessing.

Errors the user can cause raise :class:`~uavplan.errors.InputError` (exit 2); a leg that no
route can fly raises :class:`~uavplan.errors.NoPathError` (exit 3) naming the two positions
of the failed leg (the planner's :class:`~uavplan.outcome.LegFailure` says which) and why. A
Ctrl-C is a value: the result says it was interrupted. Every stretch of legs is planned as a
checked :class:`~uavplan.scenario.Scenario` that begins in the air (no take-off climb of its
own) and ends without a landing: the plan's own take-off, landing and straight segments are
checked here. The flown line of the result is checked by :func:`uavplan.flightcheck.check_flight`,
as ``validate`` checks a mission. This module is wiring: it knows the mission model, the
scenario values and the planning adapters, and nothing of the CLI.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from uavplan.airspace import (
    Airspace,
    held_bounds,
    stretch_obstacles,
)
from uavplan.errors import InputError, NoPathError
from uavplan.geo import EnuFrame
from uavplan.ground import Ground
from uavplan.mission.items import (
    MavCmd,
    MavFrame,
    MissionItem,
    MissionPlan,
    canonical_frame,
)
from uavplan.outcome import RouteFailure
from uavplan.planners.base import ProgressFn
from uavplan.planning import RouteResult, over_ground, plan_route
from uavplan.route import EndAction, Follow
from uavplan.scenario import MissionConfig, PlannerConfig, Scenario, Surroundings, VehicleConfig
from uavplan.world import CEILING, World
from uavplan.worlds import plan_frame, world_of_plan

#: consecutive positions closer than this horizontally are joined by a straight segment
#: (checked, not planned: the planner needs a horizontal leg)
MIN_LEG_M = 1.0
#: a straight leg is kept when it clears the margin by this much (a file rounds positions to
#: about a centimetre; the planner keeps the same pad)
CLEARANCE_PAD_M = 0.02
#: MAV_CMD values below this are NAV commands (the vehicle flies to their position)
_FIRST_NON_NAV_COMMAND = 100
_RELATIVE_FRAMES = frozenset({int(MavFrame.GLOBAL_RELATIVE_ALT)})
_TERRAIN_FRAMES = frozenset({int(MavFrame.GLOBAL_TERRAIN_ALT)})


#: names of the NAV commands a QGroundControl plan commonly holds beyond :class:`MavCmd`
_NAV_NAMES = {
    18: "NAV_LOITER_TURNS",
    19: "NAV_LOITER_TIME",
    31: "NAV_LOITER_TO_ALT",
    82: "NAV_SPLINE_WAYPOINT",
    84: "NAV_VTOL_TAKEOFF",
    85: "NAV_VTOL_LAND",
}


def command_name(command: int) -> str:
    """``NAV_WAYPOINT`` for 16, ``command 203`` for a value this project has no name for."""
    try:
        return MavCmd(command).name
    except ValueError:
        return _NAV_NAMES.get(command, f"command {command}")


@dataclass(frozen=True)
class UserPosition:
    """A point of the user's route: the item it comes from and where it is (ENU metres)."""

    item_index: int
    point_m: tuple[float, float, float]
    what: str  # e.g. "mission item 3 (NAV_WAYPOINT)"


@dataclass(frozen=True)
class UserRoute:
    """The route read out of a plan: its positions in flight order and how it ends."""

    positions: tuple[UserPosition, ...]
    end: EndAction
    has_takeoff: bool
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class RerouteResult:
    """The rerouted plan and how it was made (``interrupted``: a Ctrl-C ended the planning;
    ``plan`` is then the user's, unchanged). A route that cannot be had is an error
    (:func:`reroute_plan` raises), so the only end besides ``ok`` is the interrupt
    (:class:`~uavplan.outcome.Ended`)."""

    plan: MissionPlan
    name: str
    safety_margin_m: float
    end: EndAction
    #: one planning run per stretch of consecutive legs, with the scenario it planned
    runs: tuple[tuple[Scenario, RouteResult], ...]
    inserted: int  # planned NAV_WAYPOINTs added
    min_clearance_m: float  # of the whole flown line (take-off to landing)
    flown_enu: NDArray[np.float64]  # that line, ENU metres (home on the ground first)
    notes: tuple[str, ...] = ()
    obstacle_names: tuple[str, ...] = field(default_factory=tuple)
    interrupted: bool = False
    #: where it was planned (None when interrupted): the airspace and its ENU frame
    airspace: Airspace | None = None
    frame: EnuFrame | None = None
    #: the user's positions in flight order (ENU metres)
    positions_enu: tuple[tuple[float, float, float], ...] = ()

    @property
    def ok(self) -> bool:
        return not self.interrupted

    @property
    def reason(self) -> RouteFailure | None:
        return RouteFailure.INTERRUPTED if self.interrupted else None

    @property
    def message(self) -> str:
        return "interrupted" if self.interrupted else ""

    @property
    def step(self) -> str:
        return ""

    @property
    def routes(self) -> tuple[RouteResult, ...]:
        return tuple(r for _, r in self.runs)

    @property
    def energy(self) -> float:
        """E (eq. 1) of the rerouted legs (the straight legs are not counted)."""
        return float(sum(r.energy for r in self.routes))

    @property
    def length_m(self) -> float:
        """Length of the whole flown line (take-off climb to the last position or the
        landing; without the autopilot's return to launch)."""
        return float(np.linalg.norm(np.diff(self.flown_enu, axis=0), axis=1).sum())

    @property
    def runtime_s(self) -> float:
        return float(sum(r.runtime_s for r in self.routes))


# ---------------------------------------------------------------------------------------------
# Reading the route


def read_user_route(
    plan: MissionPlan, frame: EnuFrame, *, file: str | None = None, ground: Ground | None = None
) -> UserRoute:
    """The plan's positions in flight order (ENU in ``frame``) and its end action.

    Over ``ground`` (a scenario's terrain; ``frame`` its site's, z above its datum) the plan
    is read as the autopilot flies it: home on the ground there, relative altitudes above
    home, AMSL ones through the datum, terrain-frame ones above the ground beneath the item.

    Raises :class:`InputError` for what cannot be rerouted without guessing: DO_JUMP, no
    planned home, positions after the landing or the RTL, a position on or below the ground.
    """
    if plan.home is None:
        raise InputError("the plan has no planned home position (plannedHomePosition)", file=file)
    home_alt_m = plan.home.alt_m
    notes: list[str] = []
    raw: list[tuple[int, MissionItem, float]] = []  # (index, item, height above home)
    end: EndAction = "none"
    ended_by: str | None = None
    has_takeoff = False
    terrain = False
    for index, item in enumerate(plan.items):
        what = f"mission item {index + 1} ({command_name(item.command)})"
        if item.command == MavCmd.DO_JUMP:
            raise InputError(
                f"{what}: DO_JUMP is not supported: a loop's legs cannot be rerouted without "
                "guessing how often it runs; unroll the loop in QGroundControl and try again",
                file=file,
            )
        positional = item.is_global and item.command < _FIRST_NON_NAV_COMMAND
        if ended_by is not None:
            if positional:
                raise InputError(
                    f"{what} comes after the mission's {ended_by}: positions after a landing "
                    "or a return to launch are not supported",
                    file=file,
                )
            continue
        if item.command == MavCmd.NAV_RETURN_TO_LAUNCH:
            end, ended_by = "rtl", "NAV_RETURN_TO_LAUNCH"
            continue
        if not positional:
            continue
        frame_id = canonical_frame(item.frame)
        if ground is not None:
            z = math.inf  # placed over the ground beneath it below, where its x, y are known
        elif frame_id in _RELATIVE_FRAMES:
            z = item.alt_m
        elif frame_id in _TERRAIN_FRAMES:
            z, terrain = item.alt_m, True
        else:  # MAV_FRAME_GLOBAL (AMSL)
            z = item.alt_m - home_alt_m
        if item.command == MavCmd.NAV_TAKEOFF:
            if raw:
                raise InputError(f"{what}: a take-off after the first position", file=file)
            has_takeoff = True
        if item.command == MavCmd.NAV_LAND:
            end, ended_by = "land", "NAV_LAND"
        elif item.command != MavCmd.NAV_TAKEOFF and (item.x, item.y) == (0.0, 0.0):
            raise InputError(f"{what} has no position (latitude and longitude 0)", file=file)
        if item.command != MavCmd.NAV_LAND and not z > 0.0:
            raise InputError(
                f"{what} at {z:g} m is not above the ground (home's height); heights must be "
                "> 0 m above home",
                file=file,
            )
        raw.append((index, item, z))
    if terrain:
        notes.append(
            "terrain-relative altitudes (frame 10/11) are treated as heights above home: the "
            "ground is taken as flat"
        )

    lat = [plan.home.lat_deg, *(it.lat_deg for _, it, _ in raw)]
    lon = [plan.home.lon_deg, *(it.lon_deg for _, it, _ in raw)]
    xy = frame.to_enu_xy(lat, lon)
    home_xy = (float(xy[0, 0]), float(xy[0, 1]))
    home_z = 0.0 if ground is None else float(ground.z_at(np.array([home_xy]))[0])
    positions: list[UserPosition] = []
    for (index, item, z), (x, y) in zip(raw, xy[1:], strict=True):
        what = f"mission item {index + 1} ({command_name(item.command)})"
        px, py, pz = float(x), float(y), float(z)
        if item.command == MavCmd.NAV_TAKEOFF:
            px, py = home_xy  # the vehicle climbs where it stands
        if item.command == MavCmd.NAV_LAND:
            if not positions:
                raise InputError(f"{what}: a landing before any position to fly", file=file)
            prev = positions[-1].point_m
            if (item.x, item.y) == (0.0, 0.0):
                px, py = prev[0], prev[1]  # lands where the vehicle is
            pz = prev[2]  # flies there at its height, then descends
        elif ground is not None:
            pz = _over_ground(item, (px, py), ground, home_z, what, file)
        positions.append(UserPosition(index, (px, py, pz), what))
    if len(positions) < 2 or all(
        math.hypot(p.point_m[0] - positions[0].point_m[0], p.point_m[1] - positions[0].point_m[1])
        < MIN_LEG_M
        for p in positions
    ):
        raise InputError(
            "the plan has no route to reroute: it needs a take-off and at least one position "
            "to fly to (or two positions)",
            file=file,
        )
    if not has_takeoff:
        notes.append(
            "the plan has no NAV_TAKEOFF: the route starts at its first position; the flight "
            "from home to it is checked, not planned"
        )
    return UserRoute(tuple(positions), end, has_takeoff, tuple(notes))


def _over_ground(
    item: MissionItem,
    xy: tuple[float, float],
    ground: Ground,
    home_z: float,
    what: str,
    file: str | None,
) -> float:
    """An item's z over terrain (above the datum): relative above home (on the ground at
    ``home_z``), AMSL as it is, terrain-frame above the ground beneath; above that ground."""
    under = float(ground.z_at(np.array([xy]))[0])
    frame_id = canonical_frame(item.frame)
    if frame_id in _RELATIVE_FRAMES:
        z = home_z + item.alt_m
    elif frame_id in _TERRAIN_FRAMES:
        z = under + item.alt_m
    else:  # MAV_FRAME_GLOBAL (AMSL)
        z = item.alt_m - ground.datum_amsl_m
    if not z - under > 0.0:
        raise InputError(
            f"{what} at {z - under:.1f} m above the ground is not above it (over the "
            "scenario's terrain)",
            file=file,
        )
    return z


# ---------------------------------------------------------------------------------------------
# Checks of the user's positions and of the segments that are flown straight


def _check_points(
    route: UserRoute, airspace: Airspace, world: World, margin_m: float, file: str | None
) -> None:
    import shapely

    for pos in route.positions:
        p = pos.point_m
        where = f"{pos.what} at [{p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f}] m"
        if airspace.inclusion is not None and not shapely.covers(
            airspace.inclusion, shapely.Point(p[0], p[1])
        ):
            raise InputError(f"{where} is outside the inclusion fence", file=file)
        if not airspace.bounds.contains(p):
            b = airspace.bounds
            raise InputError(
                f"{where} is outside the flight volume (x {b.x_m[0]:.0f}..{b.x_m[1]:.0f}, "
                f"y {b.y_m[0]:.0f}..{b.y_m[1]:.0f}, z {b.z_m[0]:.0f}..{b.z_m[1]:.0f} m)",
                file=file,
            )
        clearance, index = world.nearest_obstacle(p)
        if index != -1 and clearance < margin_m - 1e-9:
            inside = "inside" if clearance <= 0 else f"{clearance:.1f} m from"
            thing = _name(world, airspace, index, np.array(p), np.array(p))
            raise InputError(
                f"{where} is {inside} {thing} (needs {margin_m:g} m safety margin)", file=file
            )


def _straight_segments(
    route: UserRoute, home_xy: tuple[float, float], ground: Ground | None = None
) -> list[tuple[NDArray[np.float64], NDArray[np.float64], str, bool]]:
    """The flown segments no planner touches: the take-off climb (or the approach from home
    without a take-off), hops between positions closer than MIN_LEG_M and the landing; each
    with whether it is in the air (the climb from home and the landing touch the ground, and
    are measured against the obstacles only)."""
    pos = route.positions

    def on_ground(xy: Any) -> float:
        return 0.0 if ground is None else float(ground.z_at(np.array([xy[:2]]))[0])

    first = np.array(pos[0].point_m)
    home = np.array([home_xy[0], home_xy[1], on_ground(home_xy)])
    what = "take-off climb above home" if route.has_takeoff else "flight from home"
    segments = [(home, first, f"the {what} to {pos[0].what}", False)]
    for a, b in itertools.pairwise(pos):
        pa, pb = np.array(a.point_m), np.array(b.point_m)
        if math.hypot(*(pb[:2] - pa[:2])) < MIN_LEG_M:
            segments.append((pa, pb, f"the climb or descent from {a.what} to {b.what}", True))
    if route.end == "land":
        last = np.array(pos[-1].point_m)
        down = np.array([last[0], last[1], on_ground(last)])
        segments.append((last, down, f"the landing of {pos[-1].what}", False))
    return segments


def _check_segments(
    segments: list[tuple[NDArray[np.float64], NDArray[np.float64], str, bool]],
    airspace: Airspace,
    world: World,
    margin_m: float,
    file: str | None,
) -> None:
    for a, b, what, airborne in segments:
        if np.allclose(a, b):
            continue
        measured = world if airborne else world.without_ground()
        dist, which = measured.segments_clearance(a[None, :], b[None, :])
        if which[0] != -1 and dist[0] < margin_m - 1e-9:
            thing = _name(measured, airspace, int(which[0]), a, b)
            raise InputError(
                f"{what} passes {max(float(dist[0]), 0.0):.1f} m from {thing} (needs "
                f"{margin_m:g} m safety margin)",
                file=file,
            )


def _name(
    world: World, airspace: Airspace, index: int, a: NDArray[np.float64], b: NDArray[np.float64]
) -> str:
    """What obstacle ``index`` of the airspace is, or the terrain and where."""
    if index >= 0:
        return airspace.names[index]
    _, kind, where = world.terrain_nearest(a[None, :], b[None, :])
    x, y = (float(v) for v in where[0])
    if kind[0] == CEILING:
        return f"the ceiling (bounds.z max above the ground) over ({x:.0f}, {y:.0f})"
    return f"the terrain at ({x:.0f}, {y:.0f})"


# ---------------------------------------------------------------------------------------------
# Rerouting


def reroute_plan(
    plan: MissionPlan,
    *,
    base: Scenario | Surroundings | None = None,
    planner: PlannerConfig | None = None,
    name: str = "plan",
    file: str | None = None,
    progress: ProgressFn | None = None,
    should_stop: Callable[[], bool] | None = None,
    margin_pad_m: float = 0.0,
) -> RerouteResult:
    """``plan`` with planned NAV_WAYPOINTs inserted between the user's positions so that the
    flown line keeps the safety margin from the fence's exclusion zones (and from ``base``'s
    obstacles, whose planner and mission settings are used; ``planner`` overrides the
    planner settings). ``file`` labels messages (``name`` when there is none).
    ``margin_pad_m``: the legs are planned (and judged straight) with the margin this much
    wider, so that the track an autopilot flies through them keeps it
    (:func:`uavplan.flown_safe.reroute_safe_as_flown`); over terrain the same ground serves,
    so the ceiling comes down by the pad too.

    Raises :class:`InputError` (exit 2) for what the user can fix in the plan and
    :class:`NoPathError` (exit 3) when a leg has no route. When ``should_stop`` ends the
    search the result says ``interrupted`` (and holds the plan unchanged).
    """
    frame, ground = plan_frame(plan, base, file)
    origin = frame.origin
    route = read_user_route(plan, frame, file=file, ground=ground)
    points_m = np.array([p.point_m for p in route.positions])
    pw = world_of_plan(plan, points_m, frame, ground, base, file)
    airspace, world, margin_m, home_xy = pw.airspace, pw.world, pw.margin_m, pw.home_xy
    if not airspace.bounds.contains((*home_xy, max(0.0, airspace.bounds.z_m[0]))):
        raise InputError(
            f"the planned home at [{home_xy[0]:.1f}, {home_xy[1]:.1f}] m is outside the flight "
            "volume" + (" of the scenario" if base is not None else ""),
            file=file,
        )
    who = file or name
    _check_points(route, airspace, world, margin_m, file)
    _check_segments(_straight_segments(route, home_xy, ground), airspace, world, margin_m, file)
    plan_margin_m = margin_m + max(0.0, margin_pad_m)
    plan_world = world if plan_margin_m == margin_m else world.with_limits(margin_m=plan_margin_m)

    # a leg into a terrain-frame item is flown over the ground (ArduPilot): as drawn and as
    # planned, it is measured so, and waypoints are added where it would come too close
    over: dict[int, Follow] = {}
    if ground is not None:
        for k, pos in enumerate(route.positions):
            if canonical_frame(plan.items[pos.item_index].frame) in _TERRAIN_FRAMES:
                over[k] = ground.follow
    # one planning run (one world, one seed stream) per chain of consecutive legs that need
    # a route; a leg that keeps the margin as drawn stays straight (nothing is inserted)
    points = [p.point_m for p in route.positions]
    chains: list[list[int]] = [[0]]
    straight = 0
    for k in range(1, len(points)):
        a, b_ = points[k - 1], points[k]
        if math.hypot(b_[0] - a[0], b_[1] - a[1]) < MIN_LEG_M or _clear_as_drawn(
            plan_world, a, b_, plan_margin_m, over.get(k)
        ):
            straight += 1
            chains.append([k])
        else:
            chains[-1].append(k)
    settings = _stretch_settings(plan, base, planner)
    insert_before: dict[int, NDArray[np.float64]] = {}  # item index → planned waypoints
    runs: list[tuple[Scenario, RouteResult]] = []
    notes = list(route.notes)
    lifted = stretch_obstacles(airspace.obstacles, ground)
    for chain in chains:
        if len(chain) < 2:
            continue

        # a stretch of the user's flight: it begins in the air and ends without a landing;
        # over terrain its points and obstacles as a scenario holds them (above the ground)
        def held(point: tuple[float, float, float]) -> tuple[float, float, float]:
            if ground is None:
                return point
            under = float(ground.z_at(np.array([point[:2]]))[0])
            return (point[0], point[1], point[2] - under)

        scn = Scenario(
            name=name,
            origin=origin if base is None or base.terrain is None else base.origin,
            bounds=airspace.bounds if ground is None or base is None else held_bounds(
                airspace.bounds, base.bounds
            ),
            start_m=held(points[chain[0]]),
            goal_m=held(points[chain[-1]]),
            via_m=tuple(held(points[k]) for k in chain[1:-1]),
            obstacles=lifted,
            safety_margin_m=plan_margin_m,
            source=file,
            terrain=None if base is None else base.terrain,
            **settings,
        )  # fmt: skip
        result = plan_route(scn, progress=progress, world=plan_world, should_stop=should_stop)
        if result.interrupted:
            return RerouteResult(
                plan, name, margin_m, route.end, tuple(runs), 0, math.nan,
                np.empty((0, 3)), interrupted=True,
            )  # fmt: skip
        if result.failure is not None:
            failed = result.failure.leg
            a_what = route.positions[chain[failed]].what
            b_what = route.positions[chain[failed + 1]].what
            raise NoPathError(
                f"{who}: no collision-free route from {a_what} (start) to {b_what} (goal): "
                f"{result.failure.detail}"
            )
        runs.append((scn, result))
        notes.extend(result.notes)
        for leg, k in zip(result.legs, chain[1:], strict=True):
            waypoints = leg.waypoints_enu
            if k in over:  # flown over the ground: keep the margin so, adding waypoints
                waypoints, _ = over_ground(waypoints, plan_world, over[k])
            insert_before[route.positions[k].item_index] = waypoints[1:-1]

    items: list[MissionItem] = []
    inserted = 0
    for index, item in enumerate(plan.items):
        planned = insert_before.get(index)
        if planned is not None and len(planned):
            items.extend(_waypoints(frame, planned, item, ground, home_xy))
            inserted += len(planned)
        items.append(item)
    out = replace(plan, items=tuple(items))
    if straight:
        notes.append(
            f"{straight} of {len(points) - 1} legs keep the {margin_m:g} m margin as drawn "
            "and stay straight"
        )

    flight = pw.flight_of(out)
    check = pw.check(flight)
    problem = check.problem()
    if problem is not None:
        raise NoPathError(f"{who}: the rerouted flight: {problem}")
    notes.extend(_rtl_note(route, home_xy, world, airspace, margin_m))
    return RerouteResult(
        plan=out,
        name=name,
        safety_margin_m=margin_m,
        end=route.end,
        runs=tuple(runs),
        inserted=inserted,
        min_clearance_m=check.min_clearance_m,
        flown_enu=flight.points_enu,
        notes=tuple(notes),
        obstacle_names=airspace.names,
        airspace=airspace,
        frame=frame,
        positions_enu=tuple(p.point_m for p in route.positions),
    )


def _stretch_settings(
    plan: MissionPlan, base: Scenario | Surroundings | None, planner: PlannerConfig | None
) -> dict[str, Any]:
    """The vehicle, planner and mission settings every stretch is planned with: ``base``'s
    (its take-off altitude unused), ``planner`` over them, the plan's autopilot; a stretch
    begins in the air and ends without a landing."""
    mission = base.mission if base is not None else MissionConfig()
    # the altitude frames are the plan's own (legs flown over the ground: see reroute_plan)
    mission = replace(
        mission, autopilot=plan.autopilot, end="none", takeoff=False, altitude="relative"
    )
    vehicle = VehicleConfig() if base is None else replace(base.vehicle, takeoff_altitude_m=None)
    cfg = planner if planner is not None else (base.planner if base is not None else None)
    out: dict[str, Any] = {"mission": mission, "vehicle": vehicle}
    if cfg is not None:
        out["planner"] = cfg
    return out


def _clear_as_drawn(
    world: World,
    a: tuple[float, float, float],
    b: tuple[float, float, float],
    margin_m: float,
    follow: Follow | None = None,
) -> bool:
    """Does the leg a→b (straight, or flown as ``follow`` says) stay inside the volume and
    keep the margin (plus the planner's pad, so rounding in the file cannot take it below)?"""
    pa, pb = np.array(a), np.array(b)
    line = np.vstack([pa, pb]) if follow is None else np.vstack([pa, follow(pa, pb)])
    if not world.points_inside_bounds(line).all():
        return False
    dist, _ = world.segments_clearance(line[:-1], line[1:])
    return bool(dist.min() >= margin_m + CLEARANCE_PAD_M)


def _waypoints(
    frame: EnuFrame,
    points_enu: NDArray[np.float64],
    before: MissionItem | None = None,
    ground: Ground | None = None,
    home_xy: tuple[float, float] = (0.0, 0.0),
) -> list[MissionItem]:
    """Planned NAV_WAYPOINTs. Over flat ground: relative altitudes above home at the ground
    point below. Over terrain: in the frame of the item they lead to (``before``): above
    home, AMSL or above the terrain beneath them, so the plan keeps its altitudes."""
    flat = np.array(points_enu, dtype=np.float64)
    flat[:, 2] = 0.0
    lat, lon, _ = frame.to_geodetic(flat)
    item_frame, alt = MavFrame.GLOBAL_RELATIVE_ALT, np.asarray(points_enu[:, 2], dtype=float)
    if ground is not None and before is not None:
        kind = canonical_frame(before.frame)
        if kind in _TERRAIN_FRAMES:
            item_frame = MavFrame.GLOBAL_TERRAIN_ALT
            alt = alt - np.asarray(ground.z_at(points_enu[:, :2]))
        elif kind in _RELATIVE_FRAMES:
            alt = alt - float(ground.z_at(np.array([home_xy]))[0])
        else:
            item_frame = MavFrame.GLOBAL
            alt = alt + ground.datum_amsl_m
    return [
        MissionItem(
            command=MavCmd.NAV_WAYPOINT,
            frame=item_frame,
            param1=0.0,  # hold time s
            param2=0.0,  # acceptance radius: autopilot default
            param3=0.0,  # pass through
            param4=None,  # yaw: autopilot decides
            x=float(lat[i]),
            y=float(lon[i]),
            z=float(alt[i]),
        )
        for i in range(len(points_enu))
    ]


def _rtl_note(
    route: UserRoute,
    home_xy: tuple[float, float],
    world: World,
    airspace: Airspace,
    margin_m: float,
) -> list[str]:
    """A warning when the autopilot's straight return home (not planned) would pass an
    obstacle at the last position's height."""
    if route.end != "rtl":
        return []
    last = np.array(route.positions[-1].point_m)
    home = np.array([home_xy[0], home_xy[1], last[2]])
    dist, which = world.segments_clearance(last[None, :], home[None, :])
    if which[0] < 0 or dist[0] >= margin_m:
        return []
    return [
        f"the return to launch is the autopilot's straight line home: at the last "
        f"position's height it passes {max(float(dist[0]), 0.0):.1f} m from "
        f"{airspace.names[int(which[0])]}; end the plan with a waypoint near home (or a "
        "landing) to have that leg rerouted too"
    ]
