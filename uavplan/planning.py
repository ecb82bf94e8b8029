"""The one wiring module: scenario → world → planner → post-processing → PlannedRoute.

:func:`plan_route` wires the layers (world, path frame, planner, post-processing) and returns
one :class:`RouteResult`: the planner's record, the energy of the final path and the
:class:`~uavplan.route.PlannedRoute` every consumer takes (mission builder, geofence, map
exports, pictures). The adapters from a :class:`~uavplan.scenario.Scenario` to the layers
(its world, its path problem, its mission settings) live here and nowhere else. It does no
file I/O and knows nothing of MAVLink.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from uavplan.config import MARGIN_PAD_M, EndAction, PostParams, Selection, planner_entry
from uavplan.flightcheck import Flight, flight_clearance
from uavplan.ground import Ground
from uavplan.obstacles import Obstacle
from uavplan.outcome import LegFailure, RouteFailure, SearchEnd
from uavplan.path.energy import PhysicalFitness, energy_terms
from uavplan.path.frame import PathFrame
from uavplan.path.post import (
    dedupe,
    refine,
    refine_best,
    resample_waypoints,
    simplify,
    smooth_route,
    tighten,
)
from uavplan.planners.base import PathProblem, PlannerResult, ProgressFn, Termination
from uavplan.planners.registry import make_planner
from uavplan.route import PlannedRoute, densify, flown_polyline
from uavplan.scenario import Scenario
from uavplan.warmup import warm_up
from uavplan.world import World
from uavplan.worlds import build_world, enu_frame

if TYPE_CHECKING:
    from uavplan.mission.fence import FenceBuild, Footprint
    from uavplan.mission.items import MissionPlan
    from uavplan.planners.astar import GridRoute


_Point = tuple[float, float, float]


@dataclass(frozen=True)
class RouteResult:
    """A planning run: the planner's record and, when it found one, the planned route.

    ``energy`` is E (eq. 1) of the final smoothed path; ``runtime_s`` covers the planner and
    the post-processing, no start-up or I/O. ``failure`` says which leg failed and why (None:
    the route was planned).
    """

    algorithm: str
    seed: int
    planner: PlannerResult
    post: PostParams
    route: PlannedRoute | None = None
    energy: float = math.inf
    energy_terms: tuple[float, float, float] = (math.inf, math.inf, math.inf)
    runtime_s: float = 0.0
    failure: LegFailure | None = None
    #: what the user should know about how the route was found (guide frame, fallback)
    notes: tuple[str, ...] = ()
    #: seconds of ``runtime_s`` spent in the global (guide) search; 0 when it did not run
    guide_s: float = 0.0
    #: the legs between consecutive route points (one without via points)
    legs: tuple[Leg, ...] = ()

    @property
    def ok(self) -> bool:
        return self.failure is None

    @property
    def interrupted(self) -> bool:
        """Did a Ctrl-C (``should_stop``) end the planning?"""
        return self.failure is not None and self.failure.reason is RouteFailure.INTERRUPTED

    @property
    def status(self) -> str:
        """The report's ``status``: ``ok``, ``no_path`` or ``interrupted``."""
        return "ok" if self.failure is None else self.failure.reason.status

    @property
    def message(self) -> str:
        """Why there is no route (the failed leg's message), or ``""``."""
        return "" if self.failure is None else self.failure.message

    @property
    def reason(self) -> RouteFailure | None:
        """Why there is no route (:class:`~uavplan.outcome.Ended`); None: planned."""
        return None if self.failure is None else self.failure.reason

    @property
    def step(self) -> str:
        """The leg that failed, ``leg 2 of 3`` (:class:`~uavplan.outcome.Ended`); "": planned."""
        f = self.failure
        return "" if f is None else f"leg {f.leg + 1} of {f.legs}"

    @property
    def collision_free(self) -> bool:
        return self.route is not None and self.route.collision_free

    @property
    def min_clearance_m(self) -> float:
        return -math.inf if self.route is None else self.route.min_clearance_m

    @property
    def length_m(self) -> float:
        return math.inf if self.route is None else self.route.length_m

    @property
    def waypoints_enu(self) -> np.ndarray | None:
        return None if self.route is None else self.route.waypoints_enu

    @property
    def path_enu(self) -> np.ndarray | None:
        return None if self.route is None else self.route.path_enu

    @property
    def raw_path_enu(self) -> np.ndarray | None:
        return None if self.route is None else self.route.raw_path_enu


# ---------------------------------------------------------------------------------------------
# Adapters: a Scenario's pieces for the layers


def build_problem(scenario: Scenario, world: World | None = None) -> PathProblem:
    """The path-frame problem of ``scenario`` (reusable across runs and algorithms; each run
    sets its own fitness smoothing)."""
    cfg = scenario.planner
    site = scenario.site
    return PathProblem.build(
        world or build_world(scenario),
        site.start_m,
        site.goal_m,
        scenario.grid,
        cfg.energy,
        physical=physical_fitness(scenario),
    )


def physical_fitness(scenario: Scenario) -> PhysicalFitness | None:
    """The physical fitness of ``scenario`` (``planner: {energy: physical}``): its vehicle and
    wind, the mission's speed and the autopilot's climb and descent rates, as the flight
    estimate flies the route (:func:`uavplan.estimate.mission_limits`). None: the paper's."""
    if scenario.planner.fitness != "physical":
        return None
    from uavplan.estimate import mission_limits

    limits = mission_limits(scenario.mission.autopilot, scenario.vehicle.cruise_speed_m_s)
    return PhysicalFitness(
        profile=scenario.vehicle.profile,
        wind=scenario.wind,
        speed_m_s=limits.speed_xy_m_s,
        climb_rate_m_s=limits.speed_up_m_s,
        descent_rate_m_s=limits.speed_down_m_s,
        datum_amsl_m=scenario.site.origin.alt_m,
    )


def reference_route(
    scenario: Scenario,
    *,
    world: World | None = None,
    start_m: tuple[float, float, float] | None = None,
    goal_m: tuple[float, float, float] | None = None,
) -> GridRoute:
    """The grid A* route of ``scenario`` (its grid, margin and energy weights) in the path
    frame of its start and goal (or of ``start_m`` → ``goal_m``, one leg): the independent
    reference (``route.found`` tells)."""
    from uavplan.planners.astar import astar

    world = world or build_world(scenario)
    start = scenario.site.start_m if start_m is None else start_m
    goal = scenario.site.goal_m if goal_m is None else goal_m
    frame = PathFrame.build(start, goal, scenario.grid)
    world_pf = world.in_frame(frame.origin_xy, frame.heading_rad)
    return astar(world_pf, frame, scenario.planner.energy)


def reference_energy(scenario: Scenario, world: World | None = None) -> float:
    """E (eq. 1) of the independent reference route: one grid A* per leg (start, via points,
    goal), each shortened by line of sight (:func:`simplify`), joined into one polyline; NaN
    when A* finds no path for a leg."""
    world = world or build_world(scenario)
    legs: list[np.ndarray] = []
    for a, b in itertools.pairwise(route_points(scenario)):
        route = reference_route(scenario, world=world, start_m=a, goal_m=b)
        if not route.found or route.path_enu is None:
            return math.nan
        leg = route.path_enu[simplify(route.path_enu, world)]
        legs.append(leg if not legs else leg[1:])
    return float(sum(energy_terms(np.vstack(legs), scenario.planner.energy)))


def _simplified_candidates(
    problem: PathProblem, population: np.ndarray, nodes_pf: np.ndarray, vertices: np.ndarray
) -> list[tuple[np.ndarray, np.ndarray]]:
    """The best individual and the distinct final individuals, each as (its column polyline,
    its simplified vertices), ordered by the energy of the simplified polyline (the
    problem's fitness: eq. 1-2, or the physical watt-hours), lowest first; equal energies
    keep the best individual first, then the individuals' lexicographic order."""
    w, physical = problem.energy, problem.physical
    heading = problem.frame.heading_rad

    def energy_of(v: np.ndarray) -> float:
        if physical is not None:
            return physical.polyline_wh(v, heading)
        return sum(energy_terms(v, w))

    found = [(energy_of(vertices), nodes_pf, vertices)]
    # the distinct individuals in np.unique(rows, axis=0)'s order (lexicographic), without
    # np.unique, which imports numpy.ma (about 20 ms of every plan)
    rows = population.reshape(population.shape[0], -1)
    rows = rows[np.lexsort(rows.T[::-1])]
    distinct = np.ones(rows.shape[0], dtype=bool)
    distinct[1:] = (rows[1:] != rows[:-1]).any(axis=1)
    for nodes in rows[distinct]:
        pts = problem.node_points(nodes.reshape(-1, 2))
        v = pts[simplify(pts, problem.world)]
        found.append((energy_of(v), pts, v))
    found.sort(key=lambda c: c[0])  # stable: ties keep the order above
    return [(pts, v) for _, pts, v in found]


@dataclass(frozen=True, eq=False)
class Leg:
    """One planned leg between consecutive route points (start, via points, goal), ENU."""

    start_m: tuple[float, float, float]
    goal_m: tuple[float, float, float]
    planner: PlannerResult
    path_enu: np.ndarray  # dense smoothed curve
    waypoints_enu: np.ndarray
    vertices_enu: np.ndarray
    raw_path_enu: np.ndarray
    energy_terms: tuple[float, float, float]
    min_clearance_m: float
    guide_s: float = 0.0
    notes: tuple[str, ...] = ()

    @property
    def energy(self) -> float:
        return float(sum(self.energy_terms))

    @property
    def length_m(self) -> float:
        return float(np.linalg.norm(np.diff(self.path_enu, axis=0), axis=1).sum())

    def summary(self) -> dict[str, Any]:
        pr = self.planner
        return {
            "start": list(self.start_m),
            "goal": list(self.goal_m),
            "energy": self.energy,
            "length_m": self.length_m,
            "min_clearance_m": self.min_clearance_m,
            "iterations": pr.iterations,
            "termination": pr.termination,
            "evaluations": pr.evaluations,
            "guide_s": self.guide_s,
            "notes": list(self.notes),
        }


@dataclass(frozen=True, eq=False)
class _Unplanned:
    """A leg with no route: why (``reason``, ``message``), and what the search did."""

    reason: RouteFailure
    message: str
    planner: PlannerResult
    guide_s: float


def route_points(scenario: Scenario) -> list[tuple[float, float, float]]:
    """Start, the via points in order, goal: the points the route passes through exactly
    (where the planner flies them: :attr:`Scenario.site`)."""
    return scenario.site.route_points()


def plan_route(
    scenario: Scenario,
    *,
    progress: ProgressFn | None = None,
    world: World | None = None,
    problem: PathProblem | None = None,
    should_stop: Callable[[], bool] | None = None,
    threads: int | None = None,
) -> RouteResult:
    """Plan ``scenario`` with its planner configuration (apply CLI overrides first with
    :meth:`Scenario.with_planner`): one leg per pair of consecutive route points (start, via
    points, goal), in one world and one random stream. ``world``/``problem`` may be passed to
    reuse them (``problem`` only for a single leg); ``should_stop`` is polled every
    iteration (a Ctrl-C flag): the run then ends with ``RouteFailure.INTERRUPTED`` (a value:
    nothing is raised).
    ``threads``: threads the planner may use (None: its default; the route is the same on
    any number)."""
    cfg = scenario.planner
    world = world or build_world(scenario)
    planner = make_planner(cfg.algorithm, cfg)
    planner.threads = threads
    entry = planner_entry(cfg.algorithm)
    smoothing = cfg.fitness_smoothing(cfg.algorithm)
    post = cfg.post
    if not entry.postprocess:
        # every algorithm's best path goes through the same chain (node simplification,
        # spline, waypoints); our own additions (refinement, string pulling, choosing among
        # the final population) are SPSA's variant. The paper's protocol compares the raw
        # search result: PlannerResult.best_fitness, reported apart as "search_fitness".
        post = replace(post, refine=False, tighten=False, select=Selection.BEST)
    points = route_points(scenario)
    n_legs = len(points) - 1
    physical = physical_fitness(scenario)

    warm_up()  # compilation is not planning time
    t0 = time.perf_counter()
    rng = np.random.default_rng(cfg.search.seed)
    termination = Termination(
        cfg.search.iterations,
        stall_iterations=cfg.search.stall_iterations,
        should_stop=should_stop,
        restart_stall_iterations=cfg.search.restart_stall_iterations,
    )
    legs: list[Leg] = []
    for i in range(n_legs):

        def leg_problem(
            a: _Point = points[i],
            b: _Point = points[i + 1],
            given: PathProblem | None = problem if n_legs == 1 else None,
        ) -> PathProblem:
            # built where it is used, so only the leg holds it (and can let it go)
            if given is None:
                given = PathProblem.build(world, a, b, scenario.grid, cfg.energy, 0, physical)
            return given.with_fitness_smoothing(smoothing)

        leg_progress = None
        if progress is not None:
            done, total = i * cfg.search.iterations, n_legs * cfg.search.iterations

            def leg_progress(it: int, _n: int, best: float, done: int = done, total: int = total):
                progress(done + it, total, best)

        leg = _plan_leg(scenario, world, leg_problem, planner, post, rng, termination,
                        leg_progress)  # fmt: skip
        if isinstance(leg, _Unplanned):
            return RouteResult(
                cfg.algorithm, cfg.search.seed, leg.planner, post,
                runtime_s=time.perf_counter() - t0, guide_s=leg.guide_s,
                failure=LegFailure(i, n_legs, leg.reason, leg.message),
            )  # fmt: skip
        legs.append(leg)
    runtime = time.perf_counter() - t0

    waypoints_enu = np.vstack([legs[0].waypoints_enu, *(leg.waypoints_enu[1:] for leg in legs[1:])])
    path_enu = np.vstack([legs[0].path_enu, *(leg.path_enu[1:] for leg in legs[1:])])
    takeoff = scenario.vehicle.takeoff_altitude_m
    end = cast(EndAction, scenario.mission.end)
    site = scenario.site
    ground = site.ground
    follow = None
    notes = [n for leg in legs for n in leg.notes]
    if ground is not None and scenario.mission.altitude == "terrain":
        follow = ground.follow
        waypoints_enu, added = over_ground(waypoints_enu, world, follow)
        if added:
            notes.append(
                f"terrain: {added} waypoint{'s' * (added > 1)} added where a terrain-frame leg, "
                "flown over the ground, would have come closer than the margin"
            )
    under = None if ground is None else ground.z_at(waypoints_enu)
    ends = (0.0, 0.0) if under is None else (float(under[0]), float(under[-1]))
    flown = flown_polyline(
        waypoints_enu,
        takeoff_altitude_m=takeoff,
        end=end,
        ground_z_m=ends,
        takeoff=scenario.mission.takeoff,
        follow=follow,
    )
    flight = Flight.from_polyline(
        flown, from_ground=scenario.mission.takeoff, to_ground=end == "land"
    )
    if scenario.grid_coarsened:
        notes.append(grid_note(scenario))
    if ground is not None:
        first, last = flight.airborne
        over = flight.points_enu[first : last + 1] if follow is not None else waypoints_enu
        notes += _terrain_notes(ground, over, dense=follow is not None)
    route = PlannedRoute(
        frame=enu_frame(scenario),
        waypoints_enu=waypoints_enu,
        path_enu=path_enu,
        vertices_enu=np.vstack([legs[0].vertices_enu, *(g.vertices_enu[1:] for g in legs[1:])]),
        raw_path_enu=np.vstack([legs[0].raw_path_enu, *(g.raw_path_enu[1:] for g in legs[1:])]),
        flown_enu=flown,
        min_clearance_m=_min_clearance(world, flight),
        safety_margin_m=scenario.safety_margin_m,
        inside_bounds=bool(world.points_inside_bounds(waypoints_enu).all()),
        takeoff_altitude_m=takeoff,
        end=end,
        waypoint_ground_z_m=under,
        datum_amsl_m=None if ground is None else ground.datum_amsl_m,
    )
    terms = tuple(float(sum(leg.energy_terms[k] for leg in legs)) for k in range(3))
    return RouteResult(
        cfg.algorithm,
        cfg.search.seed,
        legs[0].planner,
        post,
        route=route,
        energy=float(sum(terms)),
        energy_terms=(terms[0], terms[1], terms[2]),
        runtime_s=runtime,
        notes=tuple(notes),
        guide_s=sum(leg.guide_s for leg in legs),
        legs=tuple(legs),
    )


#: the planned return draws from its own random stream: the seed's, spawned with this key,
#: so that planning it leaves the outbound route exactly as a plan without it
RETURN_STREAM = 27


@dataclass(frozen=True, eq=False)
class PlannedReturn:
    """The return planned from the goal to the point above home: the route with it
    (``route.return_enu`` set, ``route.flown_enu`` flying it and landing at home), the leg,
    or why there is none (``failure``)."""

    route: PlannedRoute | None
    leg: Leg | None = None
    failure: LegFailure | None = None

    @property
    def interrupted(self) -> bool:
        return self.failure is not None and self.failure.reason is RouteFailure.INTERRUPTED


def plan_return(
    scenario: Scenario,
    route: PlannedRoute,
    *,
    world: World | None = None,
    progress: ProgressFn | None = None,
    should_stop: Callable[[], bool] | None = None,
) -> PlannedReturn:
    """Plan the way home of ``route``: one leg from its goal to the start (above home, at the
    start's height) with ``scenario``'s planner, in its own random stream (the seed with
    :data:`RETURN_STREAM`); the route that flies it (``end="return"``). ``should_stop`` is
    polled as in :func:`plan_route`."""
    cfg = scenario.planner
    world = world or build_world(scenario)
    planner = make_planner(cfg.algorithm, cfg)
    post = cfg.post
    if not planner_entry(cfg.algorithm).postprocess:
        post = replace(post, refine=False, tighten=False, select=Selection.BEST)
    goal = tuple(float(v) for v in route.waypoints_enu[-1])
    start = tuple(float(v) for v in route.waypoints_enu[0])
    a: _Point = (goal[0], goal[1], goal[2])
    b: _Point = (start[0], start[1], start[2])
    smoothing = cfg.fitness_smoothing(cfg.algorithm)

    def make_problem() -> PathProblem:
        return PathProblem.build(world, a, b, scenario.grid, cfg.energy).with_fitness_smoothing(
            smoothing
        )

    termination = Termination(
        cfg.search.iterations,
        stall_iterations=cfg.search.stall_iterations,
        should_stop=should_stop,
        restart_stall_iterations=cfg.search.restart_stall_iterations,
    )
    rng = np.random.default_rng([cfg.search.seed, RETURN_STREAM])
    leg = _plan_leg(scenario, world, make_problem, planner, post, rng, termination, progress)
    if isinstance(leg, _Unplanned):
        return PlannedReturn(None, failure=LegFailure(0, 1, leg.reason, leg.message))
    return PlannedReturn(with_return(scenario, route, leg.waypoints_enu, world), leg)


def with_return(
    scenario: Scenario, route: PlannedRoute, return_enu: np.ndarray, world: World | None = None
) -> PlannedRoute:
    """``route`` ending with the planned return ``return_enu`` (the goal first, the point
    above home last) and the landing at home: its flown line and clearance remade."""
    world = world or build_world(scenario)
    back = np.asarray(return_enu, dtype=np.float64)
    ground = scenario.site.ground
    under = None if ground is None else ground.z_at(back)
    home_z = 0.0 if route.waypoint_ground_z_m is None else float(route.waypoint_ground_z_m[0])
    flown = flown_polyline(
        route.waypoints_enu,
        takeoff_altitude_m=route.takeoff_altitude_m,
        end="return",
        ground_z_m=(home_z, home_z),
        takeoff=scenario.mission.takeoff,
        return_enu=back,
    )
    flight = Flight.from_polyline(flown, from_ground=scenario.mission.takeoff, to_ground=True)
    return replace(
        route,
        flown_enu=flown,
        min_clearance_m=_min_clearance(world, flight),
        inside_bounds=route.inside_bounds and bool(world.points_inside_bounds(back).all()),
        end="return",
        return_enu=back,
        return_ground_z_m=under,
    )


def grid_note(scenario: Scenario) -> str:
    """What the user should know of a grid fitted to a large flight volume."""
    from uavplan.scenario.size import DEFAULT_GRID

    g, d = scenario.grid, DEFAULT_GRID
    return (
        f"grid fitted to the flight volume: {g.dx_m:g} × {g.dy_m:g} × {g.dz_m:g} m (the "
        f"default {d.dx_m:g} × {d.dy_m:g} × {d.dz_m:g} m is for smaller volumes; set "
        "planner.grid to choose one)"
    )


def _min_clearance(world: World, flight: Flight) -> float:
    """Clearance of the flown line (:func:`uavplan.flightcheck.flight_clearance`: the take-off
    climb and the landing descent from the obstacles only)."""
    dist, _, _ = flight_clearance(world, flight)
    return float(dist.min()) if dist.size else math.inf


#: the flown legs are sampled this finely (m) for the check against the DEM's own surface
TERRAIN_SAMPLE_M = 2.0
#: a terrain-frame leg is split at most this many times over (each time where it comes
#: closest) before it is left as it is (and the route's clearance says so)
MAX_OVER_GROUND_SPLITS = 24


def over_ground(
    waypoints_enu: np.ndarray, world: World, follow: Callable[[np.ndarray, np.ndarray], np.ndarray]
) -> tuple[np.ndarray, int]:
    """Waypoints for a mission whose legs are flown over the ground (terrain-frame altitudes:
    ArduPilot holds the height above the terrain, going linearly from one waypoint's to the
    next, instead of the straight leg the planner checked). Each leg is flown as ``follow``
    says and measured; where it comes closer than the margin (+ the planning pad) or leaves
    the volume, a waypoint is added on the planned straight leg where it comes closest, and
    the two halves are measured again, until every leg keeps the margin (split at most
    :data:`MAX_OVER_GROUND_SPLITS` times). Returns the waypoints and how many were added."""
    need = world.margin_m + MARGIN_PAD_M
    w = [np.asarray(p, dtype=np.float64) for p in waypoints_enu]
    out = [w[0]]
    added = 0
    pending = [(a, b, 0) for a, b in itertools.pairwise(w)][::-1]
    while pending:
        a, b, depth = pending.pop()
        line = np.vstack([a[None, :], follow(a, b)])
        free = world.segments_free(line[:-1], line[1:], need)  # the bounds too
        if free.all() or depth >= MAX_OVER_GROUND_SPLITS:
            out.append(b)
            continue
        dist, _ = world.segments_clearance(line[:-1], line[1:])
        worst = int(np.argmin(dist)) if dist.min() < need else int(np.argmin(free))
        run = float(np.hypot(*(b[:2] - a[:2])))
        t = float(np.hypot(*(line[worst, :2] - a[:2]))) / run if run > 0 else 0.5
        t = min(max(t, 0.05), 0.95)
        mid = a + t * (b - a)
        added += 1
        pending.append((mid, b, depth + 1))
        pending.append((a, mid, depth + 1))
    return np.array(out), added


def _terrain_notes(ground: Ground, waypoints_enu: np.ndarray, *, dense: bool = False) -> list[str]:
    """What the user should know about the route over the terrain: its lowest height above
    the DEM surface, and any stretch above the ceiling (bounds.z max above the ground).
    ``dense``: the points are a flown line sampled finely already (legs over the ground)."""
    samples = waypoints_enu if dense else densify(waypoints_enu, TERRAIN_SAMPLE_M)
    agl = samples[:, 2] - ground.z_at(samples)
    notes = [f"terrain: the route flies {agl.min():.1f} to {agl.max():.1f} m above the DEM surface"]
    over = agl > ground.ceiling_agl_m + 1e-6
    if np.any(over):
        worst = int(np.argmax(agl))
        step = np.hypot(*np.diff(samples[:, :2], axis=0).T)
        stretch = float(step[over[1:] | over[:-1]].sum())
        notes.append(
            f"terrain: the route rises to {agl[worst]:.0f} m above the ground at "
            f"({samples[worst, 0]:.0f}, {samples[worst, 1]:.0f}), above the ceiling "
            f"(bounds.z max {ground.ceiling_agl_m:g} m above the ground) over {stretch:.0f} m"
        )
    return notes


def _plan_leg(
    scenario: Scenario,
    world: World,
    make_problem: Callable[[], PathProblem],
    planner: Any,
    post: PostParams,
    rng: np.random.Generator,
    termination: Termination,
    progress: ProgressFn | None,
) -> Leg | _Unplanned:
    """Search one leg (straight frame first, a guide frame when that cannot hold a path,
    the grid route when the swarm still fails) and post-process it into waypoints; or why
    there is none. ``make_problem`` builds the leg's path problem (the caller keeps no
    reference: when the straight frame fails, its node table and memo are let go before the
    global search and the guide frame build their own)."""
    cfg = scenario.planner
    problem = make_problem()
    res = planner.solve(problem, rng, progress, termination)
    notes: list[str] = []
    guide_s = 0.0
    route_pf: np.ndarray | None = None
    if not res.solved:
        # the straight start→goal columns hold no path to start the swarm from (none, or too
        # few: base.INIT_MIN_SHARE): search the whole volume
        straight_why = res.message
        from uavplan.planners.guide import GuideSpace, find_guide, problem_along

        space = GuideSpace.of(problem)
        del problem  # its node table and memo: tens of MB on a large volume
        guide = find_guide(space)
        guide_s = guide.runtime_s
        if guide.failure is not None:
            return _Unplanned(guide.failure, guide.message, res, guide_s)
        assert guide.route_pf is not None
        problem = make_problem() if guide.is_straight else problem_along(space, guide)
        res = planner.solve(problem, rng, progress, termination)
        if res.solved:
            notes.append(
                f"planned along a guide route from a grid search ({len(guide.route_pf)} "
                f"vertices): on the straight start→goal columns {straight_why}"
            )
        else:
            route_pf = guide.route_pf
            notes.append(
                f"{cfg.algorithm} could not start along the guide either "
                f"({res.message}); flying the grid search's route "
                "(shortened, smoothed and clearance-checked)"
            )
    if res.termination is SearchEnd.INTERRUPTED:
        return _Unplanned(RouteFailure.INTERRUPTED, "interrupted", res, guide_s)
    wpf = problem.world
    candidates: list[tuple[np.ndarray, np.ndarray]] = []
    if route_pf is None:
        nodes_pf = problem.node_points(res.best_nodes)
        vertices = nodes_pf
        if post.simplify:
            vertices = nodes_pf[simplify(nodes_pf, wpf)]
            if post.select == Selection.POPULATION and res.population is not None:
                candidates = _simplified_candidates(problem, res.population, nodes_pf, vertices)
                nodes_pf, vertices = candidates[0]
    else:
        nodes_pf = vertices = route_pf
    if post.refine and problem.physical is None:
        # a pattern search on eq. 1-2; with the population selection, of every candidate
        if candidates:
            chosen, vertices = refine_best([v for _, v in candidates], wpf, cfg.energy)
            nodes_pf = candidates[chosen][0]
        else:
            vertices = refine(vertices, wpf, cfg.energy)
    elif post.tighten or post.refine or route_pf is not None:
        vertices = tighten(vertices, wpf)
    smoothed = smooth_route(
        vertices, wpf, smooth=post.smooth, step_m=post.sample_step_m,
        weights=cfg.energy if problem.physical is None else None,
    )  # fmt: skip
    waypoints_pf = resample_waypoints(smoothed, wpf, scenario.mission.spacing_m)
    frame = problem.frame
    path_enu = dedupe(frame.to_enu(smoothed.samples))
    waypoints_enu = dedupe(frame.to_enu(waypoints_pf))
    return Leg(
        start_m=frame.start_enu,
        goal_m=frame.goal_enu,
        planner=res,
        path_enu=path_enu,
        waypoints_enu=waypoints_enu,
        vertices_enu=frame.to_enu(smoothed.vertices),
        raw_path_enu=frame.to_enu(nodes_pf),
        energy_terms=energy_terms(path_enu, cfg.energy),
        min_clearance_m=world.polyline_clearance(waypoints_enu),
        guide_s=guide_s,
        notes=tuple(notes),
    )


# ---------------------------------------------------------------------------------------------
# Adapters: a Scenario's values for the fence, the map exports and the pictures. The layers
# below take plain values and the PlannedRoute; only this wiring module knows Scenario.


def fence_for(
    scenario: Scenario,
    route: PlannedRoute,
    mission: MissionPlan,
    *,
    max_items: int | None = None,
    also: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[MissionPlan, FenceBuild]:
    """``mission`` with the geofence for ``route`` flown through ``scenario``'s obstacles and
    bounds (at most ``max_items`` fence items, default PX4's 63), and how it was built.
    ``also``: the other lines the vehicle flies, as segments ``(a, b)`` in the site frame
    (the autopilot's track, the failsafe returns the mission relies on): the zones keep the
    margin from them too."""
    from uavplan.mission.fence import DEFAULT_MAX_ITEMS, geofence_for_route

    site = scenario.site
    obstacles: Sequence[Obstacle | Footprint] = site.obstacles
    if scenario.airspace is not None:  # zones' outlines simplified outward to fit the items
        from uavplan.mission.zonefence import zone_footprints

        obstacles = zone_footprints(site.obstacles, scenario.airspace.solid_groups())
    built = geofence_for_route(
        route,
        obstacles,
        site.bounds,
        max_items=DEFAULT_MAX_ITEMS if max_items is None else max_items,
        also=also,
    )
    return replace(mission, fence=built.fence), built


def mission_for(scenario: Scenario, route: PlannedRoute) -> MissionPlan:
    """The mission items for ``route`` with ``scenario``'s mission and vehicle settings."""
    from uavplan.mission.builder import build_mission

    end = "return" if route.return_enu is not None else scenario.mission.end
    if end == "return" and route.return_enu is None:
        end = "none"  # a return not (yet) planned: the mission ends at the goal
    return build_mission(
        route.waypoints_enu,
        route.frame,
        autopilot=scenario.mission.autopilot,
        end=cast(EndAction, end),
        takeoff_altitude_m=scenario.vehicle.takeoff_altitude_m,
        cruise_speed_m_s=scenario.vehicle.cruise_speed_m_s,
        ground_z_m=route.waypoint_ground_z_m,
        altitude=scenario.mission.altitude,
        return_enu=route.return_enu,
        return_ground_z_m=route.return_ground_z_m,
        return_stops=route.return_stops,
    )
