"""A survey flown in the world: the lanes of :mod:`uavplan.survey` from the scenario's start
and back, every lane checked against the world at the margin, and every transition whose
straight line is blocked routed around the obstacles by the grid A* planner
(:func:`uavplan.planning.reference_route`).

The lanes are flown at the survey altitude above the ground: on flat ground two waypoints a
lane; over a DEM the lane gets waypoints where the ground's slope changes
(:func:`lane_profile`), so its height above the ground stays within
:data:`HAG_TOLERANCE_M`, and every waypoint is written with its own AMSL altitude. The flight
climbs vertically over the start to that height and comes back down over it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import shapely
import shapely.geometry.polygon
from numpy.typing import NDArray
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

from uavplan.errors import InputError, NoPathError
from uavplan.mission.builder import build_mission
from uavplan.mission.items import MavCmd, MavFrame, MissionItem, MissionPlan
from uavplan.planning import build_world, enu_frame, reference_route
from uavplan.scenario.survey import SurveySpec
from uavplan.scenario.values import Scenario
from uavplan.survey import coverage
from uavplan.survey.corridor import plan_corridor
from uavplan.survey.sweep import Sweep, energy_of, plan_sweep
from uavplan.world import World

#: the hover before each photo of ``trigger: hover`` (s)
HOVER_HOLD_S = 1.0

#: the lanes' ground speed (m/s) when the scenario sets no cruise speed, for the energy
#: that ranks sweep angles
DEFAULT_SURVEY_SPEED_M_S = 8.0


@dataclass(frozen=True)
class SurveyRoute:
    """A survey as flown: the pattern, the flight through the world and its figures."""

    sweep: Sweep
    #: area minus holes (ENU m): what the photos must cover
    free: BaseGeometry
    #: the whole flight (m, 3), start to start, transitions routed
    waypoints_enu: NDArray[np.float64]
    #: per waypoint: True where a photographed lane starts (the next leg is a lane)
    lane_start: NDArray[np.bool_]
    #: transitions (of len(pieces) + 1) whose straight line was blocked and were routed
    rerouted: int
    #: smallest distance from the flight's polyline to any obstacle (m), as planned
    min_clearance_m: float
    #: per waypoint: True where a photographed lane ends (None: the point after each start;
    #: over a DEM a lane has waypoints in between, where the ground's slope changes)
    lane_end: NDArray[np.bool_] | None = None

    def lane_rows(self) -> list[tuple[int, int]]:
        """Each lane's first and last waypoint index, in flying order."""
        starts = np.flatnonzero(self.lane_start)
        if self.lane_end is None:
            return [(int(k), int(k) + 1) for k in starts]
        ends = np.flatnonzero(self.lane_end)
        return [(int(a), int(ends[np.searchsorted(ends, a + 1)])) for a in starts]

    @property
    def lanes(self) -> int:
        return self.sweep.lanes


def _route_leg(
    scn: Scenario, world: World, a: NDArray[np.float64], b: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Interior points of the transition a → b: none when the straight line is free, else the
    grid A* route around the obstacles."""
    if bool(world.segments_free(a[None], b[None])[0]):
        return np.zeros((0, 3))
    ta = (float(a[0]), float(a[1]), float(a[2]))
    tb = (float(b[0]), float(b[1]), float(b[2]))
    route = reference_route(scn, world=world, start_m=ta, goal_m=tb)
    if not route.found or route.path_enu is None:
        raise NoPathError(
            f"no route for the survey transition from ({a[0]:.0f}, {a[1]:.0f}) to "
            f"({b[0]:.0f}, {b[1]:.0f}) around the obstacles"
        )
    path = np.asarray(route.path_enu, dtype=np.float64)
    if not np.all(world.segments_free(path[:-1], path[1:])):
        raise NoPathError(
            f"the survey transition from ({a[0]:.0f}, {a[1]:.0f}) to ({b[0]:.0f}, "
            f"{b[1]:.0f}) breaks the margin"
        )
    return path[1:-1]


def plan_survey(scn: Scenario, spec: SurveySpec, *, world: World | None = None) -> SurveyRoute:
    """Plan ``spec`` over ``scn`` (its obstacles, margin, vehicle, wind) from ``scn``'s start
    and back. Raises InputError for what the user must change (terrain, a survey with no
    lane outside the holes), NoPathError when a lane or a transition cannot keep the margin."""
    world = world or build_world(scn)
    margin = scn.safety_margin_m
    alt = spec.altitude_m
    area = Polygon(spec.area_m)
    hole = coverage.holes(
        scn.obstacles, [Polygon(p) for p in spec.exclude_m], altitude_m=alt, margin_m=margin
    )
    free = coverage.free_area(area, hole)
    energy = lane_energy(scn, spec)
    start = np.asarray(scn.site.start_m, dtype=np.float64)
    try:
        if spec.corridor_m is not None and spec.width_m is not None:
            sweep = plan_corridor(
                spec.corridor_m,
                spec.width_m,
                free,
                spacing_m=spec.spacing.lane_spacing_m,
                trigger_m=spec.spacing.trigger_distance_m,
                start_xy=start[:2],
                energy=energy,
            )
        else:
            sweep = plan_sweep(
                area,
                free,
                spacing_m=spec.spacing.lane_spacing_m,
                trigger_m=spec.spacing.trigger_distance_m,
                start_xy=start[:2],
                energy=energy,
                angle_deg=spec.angle_deg,
            )
    except ValueError as err:
        raise InputError(str(err), key="survey") from None
    return _flown_over(scn, world, sweep, free, alt)


def part_of(
    scn: Scenario, spec: SurveySpec, route: SurveyRoute, lanes: slice, *, world: World | None = None
) -> SurveyRoute:
    """The survey of ``route``'s lanes ``lanes`` alone (in their order), from ``scn``'s start
    and back to it: one mission of a survey split across batteries. Raises NoPathError as
    :func:`plan_survey` does."""
    world = world or build_world(scn)
    pieces = route.sweep.pieces_xy[lanes]
    if not len(pieces):
        raise ValueError("a survey part needs at least one lane")
    joined = None
    if route.sweep.joined is not None:
        joined = route.sweep.joined[lanes].copy()
        joined[0] = False  # a part starts a lane (a split falls between lanes)
    start = np.asarray(scn.site.start_m, dtype=np.float64)
    lengths = np.hypot(*(pieces[:, 1] - pieces[:, 0]).T)
    path = coverage.path_xy(pieces, start[:2])
    sweep = replace(
        route.sweep,
        pieces_xy=pieces,
        path_xy=path,
        energy_wh=float(lane_energy(scn, spec)(path)),
        photos=coverage.photo_count(pieces, spec.spacing.trigger_distance_m, joined),
        lane_length_m=float(lengths.sum()),
        joined=joined,
    )
    return _flown_over(scn, world, sweep, route.free, spec.altitude_m)


def lane_energy(scn: Scenario, spec: SurveySpec) -> Callable[[NDArray[np.float64]], float]:
    """The energy of a path at the survey altitude (what ranks the sweep angles)."""
    speed = scn.vehicle.cruise_speed_m_s or DEFAULT_SURVEY_SPEED_M_S
    return energy_of(
        scn.vehicle.profile, altitude_m=spec.altitude_m, speed_m_s=speed, wind=scn.wind
    )


def _flown_over(
    scn: Scenario, world: World, sweep: Sweep, free: BaseGeometry, alt: float
) -> SurveyRoute:
    """The flight from ``scn``'s start over ``sweep``'s lanes at ``alt`` above the ground and
    back, every lane checked and every blocked transition routed. Over a DEM each lane gets
    waypoints where the ground's slope changes (:func:`lane_profile`)."""
    start = np.asarray(scn.site.start_m, dtype=np.float64)
    height = survey_height(scn, alt)
    lanes = [lane_profile(piece, height) for piece in sweep.pieces_xy]
    for k, lane in enumerate(lanes):
        free_legs = world.segments_free(lane[:-1], lane[1:])
        if not np.all(free_legs):
            a, b = lane[0], lane[-1]
            raise NoPathError(
                f"survey lane {k + 1} from ({a[0]:.0f}, {a[1]:.0f}) to ({b[0]:.0f}, "
                f"{b[1]:.0f}) at {alt:g} m breaks the margin or leaves the bounds"
            )
    above = np.array([start[0], start[1], float(height(start[None, :2])[0])])
    points: list[NDArray[np.float64]] = [start[None], above[None]]
    starts: list[bool] = [False, False]
    ends: list[bool] = [False, False]
    at = above
    rerouted = 0
    inside = _Inside(free, height)
    joined = sweep.joined if sweep.joined is not None else np.zeros(len(lanes), dtype=bool)
    for k, lane in enumerate(lanes):
        if k and joined[k]:  # the lane goes on through a bend: its next straight piece
            ends[-1] = False
            points.append(lane[1:])
            starts += [False] * (len(lane) - 1)
            ends += [False] * (len(lane) - 2) + [True]
            at = lane[-1]
            continue
        # between lanes: inside the area where the straight line would leave it
        via = _route_leg(scn, world, at, lane[0]) if k == 0 else inside.route(world, at, lane[0])
        if via is None:
            via = _route_leg(scn, world, at, lane[0])
        rerouted += bool(len(via))
        points += [via, lane]
        starts += [False] * len(via) + [True] + [False] * (len(lane) - 1)
        ends += [False] * len(via) + [False] * (len(lane) - 1) + [True]
        at = lane[-1]
    via = _route_leg(scn, world, at, above)
    rerouted += bool(len(via))
    points += [via, above[None], start[None]]
    starts += [False] * len(via) + [False, False]
    ends += [False] * len(via) + [False, False]
    waypoints = np.vstack(points)
    free_legs = world.segments_free(waypoints[:-1], waypoints[1:])
    if not np.all(free_legs):  # the climb over the start or the descent onto it
        k = int(np.argmin(free_legs))
        raise NoPathError(f"survey leg {k + 1} (the climb or descent over the start) is blocked")
    return SurveyRoute(
        sweep=sweep,
        free=free,
        waypoints_enu=waypoints,
        lane_start=np.array(starts, dtype=bool),
        rerouted=rerouted,
        min_clearance_m=world.polyline_clearance(waypoints),
        lane_end=np.array(ends, dtype=bool),
    )


#: over a DEM: the most the planned height above the ground may differ from the survey
#: altitude anywhere along a lane, between its waypoints (m; QGroundControl's terrain
#: following allows 10 m), and the step the ground is sampled at along a lane (m, well under
#: the bundled DEM's 3 arc-second, about 70-90 m, posts)
HAG_TOLERANCE_M = 2.0
PROFILE_STEP_M = 5.0


def survey_height(
    scn: Scenario, alt: float
) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
    """The survey's height (site z) over points ``(n, 2)``: ``alt`` above the ground (the
    DEM's surface over terrain, z = 0 on flat ground)."""
    ground = scn.site.ground
    if ground is None:
        return lambda xy: np.full(len(xy), float(alt))
    return lambda xy: np.asarray(ground.z_at(np.asarray(xy, dtype=np.float64)), float) + alt


def lane_profile(
    piece: NDArray[np.float64], height: Callable[[NDArray[np.float64]], NDArray[np.float64]]
) -> NDArray[np.float64]:
    """A lane ``(2, 2)`` as waypoints ``(m, 3)`` at ``height``: its two ends on flat ground;
    over a DEM, the ground sampled every :data:`PROFILE_STEP_M` and the fewest samples kept
    (Douglas-Peucker on the profile) so that the straight legs between them stay within half
    of :data:`HAG_TOLERANCE_M` of the height at every sample."""
    a, b = piece
    length = float(np.hypot(*(b - a)))
    n = max(2, math.ceil(length / PROFILE_STEP_M) + 1)
    s = np.linspace(0.0, length, n)
    xy = a + (s / max(length, 1e-9))[:, None] * (b - a)
    z = height(xy)
    if np.ptp(z) == 0.0:
        return np.column_stack([xy[[0, -1]], z[[0, -1]]])
    keep = _profile_breaks(s, z, HAG_TOLERANCE_M / 2.0)
    return np.column_stack([xy[keep], z[keep]])


def _profile_breaks(
    s: NDArray[np.float64], z: NDArray[np.float64], tol: float
) -> NDArray[np.int64]:
    """Douglas-Peucker on the profile (s, z): the indices to keep so that the straight line
    between kept neighbours is within ``tol`` of every z between them (vertically)."""
    keep = np.zeros(len(s), dtype=bool)
    keep[[0, -1]] = True
    stack = [(0, len(s) - 1)]
    while stack:
        i, j = stack.pop()
        if j - i < 2:
            continue
        t = (s[i + 1 : j] - s[i]) / (s[j] - s[i])
        err = np.abs(z[i + 1 : j] - (z[i] + t * (z[j] - z[i])))
        k = int(np.argmax(err))
        if err[k] > tol:
            m = i + 1 + k
            keep[m] = True
            stack += [(i, m), (m, j)]
    return np.flatnonzero(keep)


#: how far inside the free area (the area minus the holes) a transition between lanes bends
#: round a corner (m): more than the flight model cuts a corner (up to 2 m,
#: docs/flight-model.md), so the flown turn keeps the holes' margin too; and how far outside
#: the free area a transition's line may pass (its lane ends lie on the boundary)
INSIDE_INSET_M = 2.5
INSIDE_TOL_M = 0.05


class _Inside:
    """Transitions between lanes that stay inside the free area: the straight line where it
    does, else the shortest path through the free area's reflex corners (inset by
    :data:`INSIDE_INSET_M`; a visibility graph built once per survey), as QGroundControl's
    and Mission Planner's straight transitions do not (they cross concave notches and the
    holes)."""

    def __init__(
        self, free: BaseGeometry, height: Callable[[NDArray[np.float64]], NDArray[np.float64]]
    ) -> None:
        self.height = height
        self.tol = free.buffer(INSIDE_TOL_M)
        shapely.prepare(self.tol)
        inset = free.buffer(-INSIDE_INSET_M, join_style="mitre").simplify(0.5)
        nodes = []
        for poly in shapely.get_parts(inset):
            if poly.is_empty:
                continue
            poly = shapely.geometry.polygon.orient(poly, sign=1.0)
            for ring in (poly.exterior, *poly.interiors):
                nodes.append(_reflex(np.asarray(ring.coords)[:-1]))
        self.nodes = np.vstack(nodes) if nodes else np.zeros((0, 2))
        self._graph: NDArray[np.float64] | None = None

    def _within(self, p: NDArray[np.float64], q: NDArray[np.float64]) -> NDArray[np.bool_]:
        lines = shapely.linestrings(np.stack([p, q], axis=1))
        return np.asarray(shapely.within(lines, self.tol), dtype=bool)

    def _edges(self, p: NDArray[np.float64], q: NDArray[np.float64]) -> NDArray[np.float64]:
        """The lengths of the lines p → q that stay in the free area (inf: the others)."""
        ok = self._within(p, q)
        return np.where(ok, np.hypot(*(q - p).T), np.inf)

    def graph(self) -> NDArray[np.float64]:
        """Corner to corner: the visibility graph's weights (built on first use)."""
        if self._graph is None:
            n = len(self.nodes)
            w = np.full((n, n), np.inf)
            i, j = np.triu_indices(n, k=1)
            if len(i):
                w[i, j] = self._edges(self.nodes[i], self.nodes[j])
                w[j, i] = w[i, j]
            self._graph = w
        return self._graph

    def route(
        self, world: World, a: NDArray[np.float64], b: NDArray[np.float64]
    ) -> NDArray[np.float64] | None:
        """Interior points of a transition a → b (empty: the straight line) that stays in the
        free area and keeps the margin in ``world``; None when there is none (the caller
        routes around the obstacles instead)."""
        if bool(self._within(a[None, :2], b[None, :2])[0]):
            return np.zeros((0, 3)) if bool(world.segments_free(a[None], b[None])[0]) else None
        n = len(self.nodes)
        if n == 0:
            return None
        weight = np.full((n + 2, n + 2), np.inf)
        weight[2:, 2:] = self.graph()
        for k, end in ((0, a[:2]), (1, b[:2])):
            e = self._edges(np.repeat(end[None], n, axis=0), self.nodes)
            weight[k, 2:] = e
            weight[2:, k] = e
        prev = _shortest_from_first(weight)
        if prev[1] < 0:
            return None
        order = []
        k = int(prev[1])
        while k > 0:
            order.append(k)
            k = int(prev[k])
        via = self.nodes[np.array(order[::-1]) - 2]
        via3 = np.column_stack([via, self.height(via)])
        path = np.vstack([a, via3, b])
        if not np.all(world.segments_free(path[:-1], path[1:])):
            return None
        return via3


def _reflex(ring: NDArray[np.float64]) -> NDArray[np.float64]:
    """The corners of a ring (the free area on its left) where a shortest path can bend:
    those that turn right."""
    if len(ring) < 3:
        return ring
    before = ring - np.roll(ring, 1, axis=0)
    after = np.roll(ring, -1, axis=0) - ring
    cross = before[:, 0] * after[:, 1] - before[:, 1] * after[:, 0]
    return ring[cross < 0]


def _shortest_from_first(weight: NDArray[np.float64]) -> NDArray[np.int64]:
    """Dijkstra from node 0 over the dense symmetric ``weight`` matrix (inf: no edge): each
    node's predecessor (-1: unreached; node 0's is 0). One vectorised relaxation per node of
    the graph (the free area's corners: tens to a few hundred)."""
    n = len(weight)
    dist = np.full(n, np.inf)
    dist[0] = 0.0
    prev = np.full(n, -1, dtype=np.int64)
    prev[0] = 0
    done = np.zeros(n, dtype=bool)
    for _ in range(n):
        open_dist = np.where(done, np.inf, dist)
        u = int(np.argmin(open_dist))
        if not np.isfinite(open_dist[u]):
            break
        done[u] = True
        if u == 1:
            break
        alt = dist[u] + weight[u]
        better = (alt < dist) & ~done
        dist[better] = alt[better]
        prev[better] = u
    return prev


def _trigger_distance(distance_m: float) -> MissionItem:
    """MAV_CMD_DO_SET_CAM_TRIGG_DIST: ``distance_m`` > 0 starts distance triggering (param3 = 1:
    one photo at once), 0 stops it. Both autopilots run it from a mission: PX4's
    drivers/camera_trigger (CameraTrigger::Run handles VEHICLE_CMD_DO_SET_CAM_TRIGG_DIST),
    ArduPilot's AP_Mission::start_command_camera → AP_Camera::handle_command, which sets
    the distance and takes the first photo for param3 = 1."""
    return MissionItem(
        command=MavCmd.DO_SET_CAM_TRIGG_DIST,
        frame=MavFrame.MISSION,
        param1=float(distance_m),
        param2=0.0,  # shutter integration time: camera default
        param3=1.0 if distance_m > 0 else 0.0,  # trigger once immediately
        param4=0.0,
    )


def _capture_one() -> MissionItem:
    """MAV_CMD_IMAGE_START_CAPTURE of one image (param3 = 1) by every camera (param1 = 0):
    ArduPilot's AP_Camera::handle_command takes one picture; PX4 sends it on to a MAVLink
    camera (docs/survey.md)."""
    return MissionItem(
        command=MavCmd.IMAGE_START_CAPTURE,
        frame=MavFrame.MISSION,
        param1=0.0,
        param2=0.0,  # interval: none, one image
        param3=1.0,  # total images
        param4=0.0,  # sequence number: none
    )


def survey_mission(
    scn: Scenario, spec: SurveySpec, route: SurveyRoute, *, over_terrain: str = "amsl"
) -> MissionPlan:
    """The mission of ``route`` with ``scn``'s mission and vehicle settings: take-off over the
    start, the lanes with camera items, back over the start and down (``mission.end`` rtl,
    land or none; a planned ``return`` is the survey's own way back, so it lands).

    ``over_terrain``: the altitude frame of every waypoint over a DEM, ``"amsl"`` (what
    ``plan`` writes, below) or ``"terrain"`` (ArduPilot's terrain frame, as Mission Planner
    writes a survey: tools/survey_bench.py compares them).

    ``trigger: distance``: DO_SET_CAM_TRIGG_DIST (the trigger distance) after each lane's
    first waypoint and (0) after its last. ``trigger: hover``: a waypoint per photo along
    each lane, a hold of :data:`HOVER_HOLD_S` there and IMAGE_START_CAPTURE of one image."""
    w = route.waypoints_enu
    rows: list[NDArray[np.float64]] = []
    items: dict[int, list[MissionItem]] = {}
    holds: dict[int, float] = {}
    d = spec.spacing.trigger_distance_m
    lane_at = dict(route.lane_rows())
    k = 0
    while k < len(w):
        if k in lane_at:
            lane = w[k : lane_at[k] + 1]
            if spec.trigger == "distance":
                items[len(rows)] = [_trigger_distance(d)]
                rows.extend(lane[:-1])
                items[len(rows)] = [_trigger_distance(0.0)]
                rows.append(lane[-1])
            else:
                # a photo every d metres along the lane (through a corridor's bends), its
                # height on the lane's profile there
                along = np.concatenate(
                    ([0.0], np.cumsum(np.hypot(*np.diff(lane[:, :2], axis=0).T)))
                )
                at = np.arange(0.0, along[-1] + 1e-9, d)
                xyz = np.column_stack([np.interp(at, along, lane[:, i]) for i in range(3)])
                for p in xyz:
                    items[len(rows)] = [_capture_one()]
                    holds[len(rows)] = HOVER_HOLD_S
                    rows.append(p)
            k = lane_at[k] + 1
        else:
            rows.append(w[k])
            k += 1
    end = scn.mission.end if scn.mission.end != "return" else "land"
    points = np.vstack(rows)
    ground = scn.site.ground
    altitude = scn.mission.altitude
    under = None
    if ground is None:
        altitude = "relative" if altitude == "terrain" else altitude
    else:
        # over a DEM every waypoint gets its own AMSL altitude, for both flavours: the lanes'
        # waypoints already follow the ground's profile (lane_profile); PX4 flies no terrain
        # frames, and ArduPilot's terrain following lags on a slope (the flight model: 7 m
        # on the bundled ridge survey, docs/survey.md) and needs a terrain database
        under = np.asarray(ground.z_at(points[:, :2]), dtype=np.float64)
        altitude = over_terrain
    return build_mission(
        points,
        enu_frame(scn),
        autopilot=scn.mission.autopilot,
        end=end,  # type: ignore[arg-type]
        takeoff_altitude_m=scn.vehicle.takeoff_altitude_m,
        cruise_speed_m_s=scn.vehicle.cruise_speed_m_s,
        ground_z_m=under,
        altitude=altitude,
        row_items=items,
        row_hold_s=holds,
    )


__all__ = [
    "DEFAULT_SURVEY_SPEED_M_S",
    "HAG_TOLERANCE_M",
    "HOVER_HOLD_S",
    "SurveyRoute",
    "lane_energy",
    "lane_profile",
    "part_of",
    "plan_survey",
    "survey_height",
    "survey_mission",
]
