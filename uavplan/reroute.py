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
  the exclusion zones grown by :data:`VOLUME_PAD_M` plus the margin, with a ceiling
  :data:`VOLUME_PAD_M` above the highest position (a ``--scenario``'s own bounds, when one is
  given). Fence obstacles stand :data:`VOLUME_PAD_M` above the ceiling.
* DO_JUMP is refused: a loop's legs cannot be rerouted without guessing.

Errors the user can cause raise :class:`~uavplan.errors.InputError` (exit 2); a leg that no
route can fly raises :class:`~uavplan.errors.NoPathError` (exit 3) naming the two positions
of the failed leg (the planner's :class:`~uavplan.outcome.LegFailure` says which) and why. A
Ctrl-C is a value: the result says it was interrupted. Every stretch of legs is planned as a
checked :class:`~uavplan.scenario.Scenario` that begins in the air (no take-off climb of its
own) and ends without a landing: the plan's own take-off, landing and straight segments are
checked here. The flown line of the result is checked by :func:`uavplan.flight.check_flight`,
as ``validate`` checks a mission. This module is wiring: it knows the mission model, the
scenario values and the planning adapters, and nothing of the CLI.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from uavplan.errors import InputError, NoPathError
from uavplan.flight import FlightPrediction, check_flight, flight_of_mission
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.geometry2d import orient_ccw, polygon_problem
from uavplan.limits import MAX_FENCE_POLYGON_VERTICES, MAX_FENCE_ZONES, MAX_HORIZONTAL_M
from uavplan.mission.items import (
    MavCmd,
    MavFrame,
    MissionItem,
    MissionPlan,
    canonical_frame,
)
from uavplan.obstacles import Bounds, CylinderObstacle, Obstacle, PrismObstacle
from uavplan.planners.base import ProgressFn
from uavplan.planning import RouteResult, plan_route
from uavplan.route import EndAction, keeps_margin
from uavplan.scenario import MissionConfig, PlannerConfig, Scenario, VehicleConfig
from uavplan.world import World

#: the flight volume's pad: around home, the positions and the zones (plus the safety margin)
#: and above the highest position; fence obstacles stand this much above the ceiling
VOLUME_PAD_M = 50.0
#: the safety margin when no scenario gives one (the scenario format's default)
DEFAULT_MARGIN_M = 10.0
#: consecutive positions closer than this horizontally are joined by a straight segment
#: (checked, not planned: the planner needs a horizontal leg)
MIN_LEG_M = 1.0
#: a straight leg is kept when it clears the margin by this much (a file rounds positions to
#: about a centimetre; the planner keeps the same pad)
CLEARANCE_PAD_M = 0.02
#: a circle of the fence becomes a polygon with this many vertices on the circle (inclusion)
CIRCLE_SEGMENTS = 64
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


@dataclass
class RerouteResult:
    """The rerouted plan and how it was made (``interrupted``: a Ctrl-C ended the planning;
    ``plan`` is then the user's, unchanged)."""

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
    #: the flight the model predicts for the plan (uavplan.rehearsal), if rehearsed
    flight: FlightPrediction | None = None

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

    def report(self) -> dict[str, Any]:
        """A JSON-able summary: totals, the legs of every planning run, the notes."""
        return {
            "input": "qgc-plan",
            "scenario": self.name,
            "items_in": len(self.plan.items) - self.inserted,
            "items_out": len(self.plan.items),
            "inserted_waypoints": self.inserted,
            "energy_rerouted_legs": self.energy,
            "length_m": self.length_m,
            "runtime_s": self.runtime_s,
            "min_clearance_m": self.min_clearance_m,
            "safety_margin_m": self.safety_margin_m,
            "collision_free": keeps_margin(self.min_clearance_m, self.safety_margin_m),
            "end": self.end,
            "notes": list(self.notes),
            "runs": [r.report(scn) for scn, r in self.runs],
            **(
                {}
                if self.flight is None
                else {
                    "flight_time_s": round(self.flight.flight_time_s, 1),
                    "flight": self.flight.summary(),
                }
            ),
        }


# ---------------------------------------------------------------------------------------------
# Reading the route


def read_user_route(plan: MissionPlan, frame: EnuFrame, *, file: str | None = None) -> UserRoute:
    """The plan's positions in flight order (ENU in ``frame``) and its end action.

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
        if frame_id in _RELATIVE_FRAMES:
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


# ---------------------------------------------------------------------------------------------
# The flight volume and the obstacles


@dataclass(frozen=True)
class Airspace:
    """Bounds and obstacles (with a name for each, for messages) of a reroute."""

    bounds: Bounds
    obstacles: tuple[Obstacle, ...]
    names: tuple[str, ...]
    inclusion: Any  # the shapely union of the inclusion zones in ENU, or None


def _ring_xy(frame: EnuFrame, vertices: Sequence[tuple[float, float]]) -> NDArray[np.float64]:
    lat = [v[0] for v in vertices]
    lon = [v[1] for v in vertices]
    return frame.to_enu_xy(lat, lon)


def build_airspace(
    plan: MissionPlan,
    route: UserRoute,
    frame: EnuFrame,
    *,
    margin_m: float,
    base: Scenario | None = None,
    file: str | None = None,
) -> Airspace:
    """The flight volume and obstacles for ``plan`` (see the module doc)."""
    import shapely

    fence = plan.fence
    exclusion_rings: list[tuple[NDArray[np.float64], str]] = []
    exclusion_circles: list[tuple[tuple[float, float], float, str]] = []
    inclusion_shapes: list[Any] = []
    n_poly = n_circ = 0
    zones = len(fence.polygons) + len(fence.circles)
    if zones > MAX_FENCE_ZONES:
        raise InputError(
            f"the geofence has {zones:,} polygons and circles; rerouting takes at most "
            f"{MAX_FENCE_ZONES:,}",
            file=file,
        )
    for i, poly in enumerate(fence.polygons):
        kind = "inclusion" if poly.inclusion else "exclusion"
        if len(poly.vertices) > MAX_FENCE_POLYGON_VERTICES:
            # the polygon checks and the convex pieces grow with the square of the vertices
            raise InputError(
                f"{kind} polygon {i + 1} of the geofence has {len(poly.vertices):,} vertices; "
                f"rerouting takes at most {MAX_FENCE_POLYGON_VERTICES:,} per polygon "
                "(simplify it, e.g. in QGroundControl's polygon editor)",
                file=file,
            )
        ring = _ring_xy(frame, poly.vertices)
        problem = polygon_problem(ring)
        if problem is not None:
            raise InputError(f"{kind} polygon {i + 1} of the geofence: {problem}", file=file)
        if poly.inclusion:
            inclusion_shapes.append(shapely.Polygon(ring))
        else:
            n_poly += 1
            exclusion_rings.append((orient_ccw(ring), f"exclusion polygon {n_poly} of the fence"))
    for circle in fence.circles:
        c = _ring_xy(frame, [circle.center])[0]
        center = (float(c[0]), float(c[1]))
        if circle.inclusion:
            # vertices on the circle, chords inside it: the polygon lies inside the circle,
            # so the outside we make into obstacles covers the true outside (conservative)
            quad = CIRCLE_SEGMENTS // 4
            inclusion_shapes.append(shapely.Point(center).buffer(circle.radius_m, quad_segs=quad))
        else:
            n_circ += 1
            exclusion_circles.append(
                (center, circle.radius_m, f"exclusion circle {n_circ} of the fence")
            )
    inclusion = shapely.union_all(inclusion_shapes) if inclusion_shapes else None

    pts = np.array([p.point_m for p in route.positions])
    top_m = float(pts[:, 2].max())
    if base is not None:
        z_hi = max(base.bounds.z_m[1], 0.0)
        z_lo = base.bounds.z_m[0]
    else:
        z_hi, z_lo = top_m + VOLUME_PAD_M, 0.0
    if inclusion is not None:
        x0, y0, x1, y1 = (float(v) for v in inclusion.bounds)
    elif base is not None:
        (x0, x1), (y0, y1) = base.bounds.x_m, base.bounds.y_m
    else:
        home_xy = frame.to_enu_xy([plan.home.lat_deg], [plan.home.lon_deg]) if plan.home else None
        xs = [*pts[:, 0]] + ([float(home_xy[0, 0])] if home_xy is not None else [])
        ys = [*pts[:, 1]] + ([float(home_xy[0, 1])] if home_xy is not None else [])
        for ring, _ in exclusion_rings:
            xs.extend(ring[:, 0])
            ys.extend(ring[:, 1])
        for (cx, cy), r, _ in exclusion_circles:
            xs.extend((cx - r, cx + r))
            ys.extend((cy - r, cy + r))
        pad = VOLUME_PAD_M + margin_m
        x0, x1, y0, y1 = min(xs) - pad, max(xs) + pad, min(ys) - pad, max(ys) + pad
    bounds = Bounds((x0, x1), (y0, y1), (z_lo, z_hi))
    height_m = z_hi + VOLUME_PAD_M

    obstacles: list[Obstacle] = []
    names: list[str] = []
    if base is not None:
        obstacles.extend(base.obstacles)
        source = base.source or base.name
        names.extend(f"obstacles[{i}] of scenario {source}" for i in range(len(base.obstacles)))
    for ring, name in exclusion_rings:
        obstacles.append(PrismObstacle(tuple((float(x), float(y)) for x, y in ring), height_m))
        names.append(name)
    for center, radius, name in exclusion_circles:
        obstacles.append(CylinderObstacle(center, radius, height_m))
        names.append(name)
    if inclusion is not None:
        box = shapely.box(x0, y0, x1, y1)
        for piece in _simple_pieces(box.difference(inclusion)):
            ring = orient_ccw(np.asarray(piece.exterior.coords)[:-1])
            obstacles.append(PrismObstacle(tuple((float(x), float(y)) for x, y in ring), height_m))
            names.append("the area outside the inclusion fence")
    return Airspace(bounds, tuple(obstacles), tuple(names), inclusion)


def _check_volume(bounds: Bounds, file: str | None) -> None:
    """The flight volume the plan spans (its fence, its items) within the horizontal limit of
    any scenario."""
    far = max(abs(v) for v in (*bounds.x_m, *bounds.y_m))
    if far > MAX_HORIZONTAL_M:
        raise InputError(
            f"the plan and its geofence reach {far / 1000:,.0f} km from home, beyond the "
            f"{MAX_HORIZONTAL_M / 1000:,.0f} km a flight volume may span",
            file=file,
        )


def _simple_pieces(geometry: Any) -> list[Any]:
    """Polygons without holes covering ``geometry`` (a box minus the inclusion zones): a
    piece with a hole is split by a vertical line through the hole, until none is left."""
    import shapely
    from shapely.ops import split

    todo = list(getattr(geometry, "geoms", [geometry]))
    done: list[Any] = []
    while todo:
        piece = todo.pop()
        if piece.geom_type != "Polygon" or piece.area < 1e-6:
            if piece.geom_type in ("MultiPolygon", "GeometryCollection"):
                todo.extend(piece.geoms)
            continue
        if not piece.interiors:
            done.append(piece)
            continue
        hx = shapely.Polygon(piece.interiors[0]).representative_point().x
        _, ymin, _, ymax = piece.bounds
        cut = shapely.LineString([(hx, ymin - 1.0), (hx, ymax + 1.0)])
        todo.extend(split(piece, cut).geoms)
    return done


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
        if index >= 0 and clearance < margin_m - 1e-9:
            inside = "inside" if clearance <= 0 else f"{clearance:.1f} m from"
            raise InputError(
                f"{where} is {inside} {airspace.names[index]} (needs {margin_m:g} m safety margin)",
                file=file,
            )


def _straight_segments(
    route: UserRoute, home_xy: tuple[float, float]
) -> list[tuple[NDArray[np.float64], NDArray[np.float64], str]]:
    """The flown segments no planner touches: the take-off climb (or the approach from home
    without a take-off), hops between positions closer than MIN_LEG_M and the landing."""
    pos = route.positions
    first = np.array(pos[0].point_m)
    ground = np.array([home_xy[0], home_xy[1], 0.0])
    what = "take-off climb above home" if route.has_takeoff else "flight from home"
    segments = [(ground, first, f"the {what} to {pos[0].what}")]
    for a, b in itertools.pairwise(pos):
        pa, pb = np.array(a.point_m), np.array(b.point_m)
        if math.hypot(*(pb[:2] - pa[:2])) < MIN_LEG_M:
            segments.append((pa, pb, f"the climb or descent from {a.what} to {b.what}"))
    if route.end == "land":
        last = np.array(pos[-1].point_m)
        segments.append((last, np.array([last[0], last[1], 0.0]), f"the landing of {pos[-1].what}"))
    return segments


def _check_segments(
    segments: list[tuple[NDArray[np.float64], NDArray[np.float64], str]],
    airspace: Airspace,
    world: World,
    margin_m: float,
    file: str | None,
) -> None:
    for a, b, what in segments:
        if np.allclose(a, b):
            continue
        dist, which = world.segments_clearance(a[None, :], b[None, :])
        if which[0] >= 0 and dist[0] < margin_m - 1e-9:
            raise InputError(
                f"{what} passes {max(float(dist[0]), 0.0):.1f} m from "
                f"{airspace.names[int(which[0])]} (needs {margin_m:g} m safety margin)",
                file=file,
            )


# ---------------------------------------------------------------------------------------------
# Rerouting


def reroute_plan(
    plan: MissionPlan,
    *,
    base: Scenario | None = None,
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
    planner settings). ``file`` labels messages. ``margin_pad_m``: the legs are planned (and
    judged straight) with the margin this much wider, so that the track an autopilot flies
    through them keeps it (:func:`uavplan.rehearsal.reroute_safe_as_flown`).

    Raises :class:`InputError` (exit 2) for what the user can fix in the plan and
    :class:`NoPathError` (exit 3) when a leg has no route. When ``should_stop`` ends the
    search the result says ``interrupted`` (and holds the plan unchanged).
    """
    if plan.home is None:
        raise InputError("the plan has no planned home position (plannedHomePosition)", file=file)
    if base is not None and base.terrain is not None:
        raise InputError(
            "rerouting a plan over a scenario with terrain (a DEM) is not supported yet: the "
            "plan's heights are read over flat ground",
            file=base.source,
            key="terrain",
        )
    home = plan.home
    origin = base.origin if base is not None else GeoPoint(home.lat_deg, home.lon_deg, home.alt_m)
    frame = EnuFrame.at(origin)
    route = read_user_route(plan, frame, file=file)
    margin_m = base.safety_margin_m if base is not None else DEFAULT_MARGIN_M
    airspace = build_airspace(plan, route, frame, margin_m=margin_m, base=base, file=file)
    _check_volume(airspace.bounds, file)
    b = airspace.bounds
    world = World.build(airspace.obstacles, bounds_xyz=(b.x_m, b.y_m, b.z_m), margin_m=margin_m)
    hxy = frame.to_enu_xy([home.lat_deg], [home.lon_deg])[0]
    home_xy = (float(hxy[0]), float(hxy[1]))
    if not airspace.bounds.contains((*home_xy, max(0.0, airspace.bounds.z_m[0]))):
        raise InputError(
            f"the planned home at [{home_xy[0]:.1f}, {home_xy[1]:.1f}] m is outside the flight "
            "volume" + (" of the scenario" if base is not None else ""),
            file=file,
        )
    _check_points(route, airspace, world, margin_m, file)
    _check_segments(_straight_segments(route, home_xy), airspace, world, margin_m, file)
    plan_margin_m = margin_m + max(0.0, margin_pad_m)
    plan_world = world
    if plan_margin_m != margin_m:
        plan_world = World.build(
            airspace.obstacles, bounds_xyz=(b.x_m, b.y_m, b.z_m), margin_m=plan_margin_m
        )

    # one planning run (one world, one seed stream) per chain of consecutive legs that need
    # a route; a leg that keeps the margin as drawn stays straight (nothing is inserted)
    points = [p.point_m for p in route.positions]
    chains: list[list[int]] = [[0]]
    straight = 0
    for k in range(1, len(points)):
        a, b_ = points[k - 1], points[k]
        if math.hypot(b_[0] - a[0], b_[1] - a[1]) < MIN_LEG_M or _clear_as_drawn(
            plan_world, a, b_, plan_margin_m
        ):
            straight += 1
            chains.append([k])
        else:
            chains[-1].append(k)
    settings = _stretch_settings(plan, base, planner)
    insert_before: dict[int, NDArray[np.float64]] = {}  # item index → planned waypoints
    runs: list[tuple[Scenario, RouteResult]] = []
    notes = list(route.notes)
    for chain in chains:
        if len(chain) < 2:
            continue
        # a stretch of the user's flight: it begins in the air and ends without a landing
        scn = Scenario(
            name=name,
            origin=origin,
            bounds=airspace.bounds,
            start_m=points[chain[0]],
            goal_m=points[chain[-1]],
            via_m=tuple(points[k] for k in chain[1:-1]),
            obstacles=airspace.obstacles,
            safety_margin_m=plan_margin_m,
            source=file,
            **settings,
        )
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
                f"{name}: no collision-free route from {a_what} (start) to {b_what} (goal): "
                f"{result.failure.detail}"
            )
        runs.append((scn, result))
        notes.extend(result.notes)
        for leg, k in zip(result.legs, chain[1:], strict=True):
            insert_before[route.positions[k].item_index] = leg.waypoints_enu[1:-1]

    items: list[MissionItem] = []
    inserted = 0
    for index, item in enumerate(plan.items):
        planned = insert_before.get(index)
        if planned is not None and len(planned):
            items.extend(_waypoints(frame, planned))
            inserted += len(planned)
        items.append(item)
    out = replace(plan, items=tuple(items))
    if straight:
        notes.append(
            f"{straight} of {len(points) - 1} legs keep the {margin_m:g} m margin as drawn "
            "and stay straight"
        )

    flight = flight_of_mission(out, frame)
    check = check_flight(world, flight, name_of=lambda i: airspace.names[i], margin_m=margin_m)
    problem = check.problem()
    if problem is not None:
        raise NoPathError(f"{name}: the rerouted flight: {problem}")
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
    )


def _stretch_settings(
    plan: MissionPlan, base: Scenario | None, planner: PlannerConfig | None
) -> dict[str, Any]:
    """The vehicle, planner and mission settings every stretch is planned with: ``base``'s
    (its take-off altitude unused), ``planner`` over them, the plan's autopilot; a stretch
    begins in the air and ends without a landing."""
    mission = base.mission if base is not None else MissionConfig()
    mission = replace(mission, autopilot=plan.autopilot, end="none", takeoff=False)
    vehicle = VehicleConfig() if base is None else replace(base.vehicle, takeoff_altitude_m=None)
    cfg = planner if planner is not None else (base.planner if base is not None else None)
    out: dict[str, Any] = {"mission": mission, "vehicle": vehicle}
    if cfg is not None:
        out["planner"] = cfg
    return out


def _clear_as_drawn(
    world: World, a: tuple[float, float, float], b: tuple[float, float, float], margin_m: float
) -> bool:
    """Does the straight leg a→b stay inside the volume and keep the margin (plus the
    planner's pad, so rounding in the file cannot take it below)?"""
    pa, pb = np.array([a]), np.array([b])
    if not world.points_inside_bounds(np.vstack([pa, pb])).all():
        return False
    dist, _ = world.segments_clearance(pa, pb)
    return bool(dist[0] >= margin_m + CLEARANCE_PAD_M)


def _waypoints(frame: EnuFrame, points_enu: NDArray[np.float64]) -> list[MissionItem]:
    """Planned NAV_WAYPOINTs (relative altitude above home at the ground point below)."""
    ground = np.array(points_enu, dtype=np.float64)
    ground[:, 2] = 0.0
    lat, lon, _ = frame.to_geodetic(ground)
    return [
        MissionItem(
            command=MavCmd.NAV_WAYPOINT,
            frame=MavFrame.GLOBAL_RELATIVE_ALT,
            param1=0.0,  # hold time s
            param2=0.0,  # acceptance radius: autopilot default
            param3=0.0,  # pass through
            param4=None,  # yaw: autopilot decides
            x=float(lat[i]),
            y=float(lon[i]),
            z=float(points_enu[i, 2]),
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
