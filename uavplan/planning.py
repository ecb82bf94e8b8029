"""The main job as a library call: scenario → planner → post-processing → waypoints.

:func:`plan_route` wires the layers (world, path frame, planner, post-processing) and returns
one :class:`RouteResult` with everything the CLI, the report and the benchmarks need. It
does no file I/O and knows nothing of MAVLink; building mission items is the caller's step.
"""

from __future__ import annotations

import enum
import math
import time
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from uavplan.path.energy import energy_terms
from uavplan.path.post import (
    dedupe,
    refine,
    resample_waypoints,
    simplify,
    smooth_route,
    tighten,
)
from uavplan.planners.base import PathProblem, PlannerResult, ProgressFn
from uavplan.planners.params import PostParams
from uavplan.planners.registry import make_planner
from uavplan.scenario import Scenario
from uavplan.warmup import warm_up
from uavplan.world import World


class RouteStatus(enum.Enum):
    OK = "ok"
    NO_PATH = "no_path"


@dataclass
class RouteResult:
    """A planned route. Points are ENU metres; ``energy`` is E (eq. 1) of ``path_enu``."""

    status: RouteStatus
    algorithm: str
    seed: int
    planner: PlannerResult
    post: PostParams
    raw_path_enu: np.ndarray | None = None  # best individual's column polyline
    vertices_enu: np.ndarray | None = None  # after simplification / tightening
    path_enu: np.ndarray | None = None  # final (smoothed) curve, dense
    waypoints_enu: np.ndarray | None = None  # what the autopilot flies between
    energy: float = math.inf
    energy_terms: tuple[float, float, float] = (math.inf, math.inf, math.inf)
    length_m: float = math.inf
    min_clearance_m: float = -math.inf  # of the flown polyline (takeoff column included)
    collision_free: bool = False
    runtime_s: float = 0.0  # planner + post-processing, no start-up or I/O
    message: str = ""

    @property
    def ok(self) -> bool:
        return self.status is RouteStatus.OK

    def report(self, scenario: Scenario) -> dict[str, Any]:
        """The ``--report`` JSON (SPEC §3 keys, plus the resolved configuration)."""
        path, turning, climb = self.energy_terms
        cfg = scenario.planner
        return {
            "scenario": scenario.name,
            "algorithm": self.algorithm,
            "seed": self.seed,
            "status": self.status.value,
            "energy": self.energy,
            "energy_terms": {"path": path, "turning": turning, "climb": climb},
            "search_fitness": self.planner.best_fitness,
            "length_m": self.length_m,
            "runtime_s": self.runtime_s,
            "iterations": self.planner.iterations,
            "convergence": [float(v) for v in self.planner.convergence],
            "waypoints": 0 if self.waypoints_enu is None else int(self.waypoints_enu.shape[0]),
            "min_clearance_m": self.min_clearance_m,
            "safety_margin_m": scenario.safety_margin_m,
            "collision_free": self.collision_free,
            "deadlocks": self.planner.deadlocks,
            "planner_stats": self.planner.stats,
            "message": self.message,
            "config": {
                "population": cfg.search.population,
                "iterations": cfg.search.iterations,
                "t_max": cfg.search.t_max,
                "init_half_window": cfg.search.init_half_window,
                "grid": {"dx": cfg.grid.dx_m, "dy": cfg.grid.dy_m, "dz": cfg.grid.dz_m},
                "energy": vars(cfg.energy),
                "spsa": vars(cfg.spsa) if self.algorithm == "spsa" else None,
                "post": vars(self.post),
                "mission_spacing_m": scenario.mission.spacing_m,
            },
        }


def _best_simplified(
    problem: PathProblem, population: np.ndarray, nodes_pf: np.ndarray, vertices: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Among the distinct final individuals (and the best one), the one whose simplified
    polyline has the lowest energy: (its column polyline, its simplified vertices)."""
    w = problem.energy
    best = (sum(energy_terms(vertices, w)), nodes_pf, vertices)
    for nodes in np.unique(population.reshape(population.shape[0], -1), axis=0):
        pts = problem.node_points(nodes.reshape(-1, 2))
        v = pts[simplify(pts, problem.world)]
        e = sum(energy_terms(v, w))
        if e < best[0]:
            best = (e, pts, v)
    return best[1], best[2]


def build_problem(scenario: Scenario, world: World | None = None) -> PathProblem:
    """The path-frame problem of ``scenario`` (reusable across runs and algorithms; each run
    sets its own fitness smoothing)."""
    cfg = scenario.planner
    return PathProblem.build(
        world or World.from_scenario(scenario),
        scenario.start_m,
        scenario.goal_m,
        cfg.grid,
        cfg.energy,
    )


def takeoff_column(scenario: Scenario) -> np.ndarray:
    """The vertical climb from the ground to the start point, (2, 3)."""
    sx, sy, sz = scenario.start_m
    return np.array([[sx, sy, 0.0], [sx, sy, sz]])


def plan_route(
    scenario: Scenario,
    *,
    progress: ProgressFn | None = None,
    world: World | None = None,
    problem: PathProblem | None = None,
) -> RouteResult:
    """Plan ``scenario`` with its planner configuration (apply CLI overrides first with
    :meth:`Scenario.with_planner`). ``world``/``problem`` may be passed to reuse them."""
    cfg = scenario.planner
    world = world or World.from_scenario(scenario)
    planner = make_planner(cfg.algorithm, cfg.search, cfg.spsa, cfg.options)
    problem = (problem or build_problem(scenario, world)).with_fitness_smoothing(
        planner.fitness_smoothing()
    )
    post = cfg.post
    if not planner.postprocess:
        # the paper's protocol post-processes SPSA only (section 4.5 is SPSA's contribution 5)
        post = replace(post, simplify=False, refine=False, tighten=False)

    warm_up()  # compilation is not planning time
    t0 = time.perf_counter()
    res = planner.solve(problem, np.random.default_rng(cfg.search.seed), progress)
    if not res.solved:
        return RouteResult(
            RouteStatus.NO_PATH,
            cfg.algorithm,
            cfg.search.seed,
            res,
            post,
            runtime_s=time.perf_counter() - t0,
            message=res.message,
        )
    wpf = problem.world
    nodes_pf = problem.node_points(res.best_nodes)
    vertices = nodes_pf
    if post.simplify:
        vertices = nodes_pf[simplify(nodes_pf, wpf)]
        if post.select == "population" and res.population is not None:
            nodes_pf, vertices = _best_simplified(problem, res.population, nodes_pf, vertices)
    if post.refine:
        vertices = refine(vertices, wpf, cfg.energy)
    elif post.tighten:
        vertices = tighten(vertices, wpf)
    route = smooth_route(vertices, wpf, smooth=post.smooth, step_m=post.sample_step_m)
    waypoints_pf = resample_waypoints(route, wpf, scenario.mission.spacing_m)
    runtime = time.perf_counter() - t0

    frame = problem.frame
    path_enu = dedupe(frame.to_enu(route.samples))
    waypoints_enu = dedupe(frame.to_enu(waypoints_pf))
    terms = energy_terms(path_enu, cfg.energy)
    flown = np.vstack([takeoff_column(scenario)[:1], waypoints_enu])
    clearance = world.polyline_clearance(flown)
    inside = bool(world.points_inside_bounds(waypoints_enu).all())
    collision_free = inside and clearance >= scenario.safety_margin_m - 1e-6
    return RouteResult(
        RouteStatus.OK,
        cfg.algorithm,
        cfg.search.seed,
        res,
        post,
        raw_path_enu=frame.to_enu(nodes_pf),
        vertices_enu=frame.to_enu(route.vertices),
        path_enu=path_enu,
        waypoints_enu=waypoints_enu,
        energy=float(sum(terms)),
        energy_terms=terms,
        length_m=float(np.linalg.norm(np.diff(path_enu, axis=0), axis=1).sum()),
        min_clearance_m=float(clearance),
        collision_free=collision_free,
        runtime_s=runtime,
    )


# ---------------------------------------------------------------------------------------------
# Adapters: a Scenario's values for the fence, the map exports and the pictures. The layers
# below take plain values and the PlannedRoute; only this wiring module knows Scenario.
# (Imported here, not at the top: the lead is rewriting the top of this file.)

from collections.abc import Mapping  # noqa: E402
from typing import TYPE_CHECKING  # noqa: E402

if TYPE_CHECKING:
    from uavplan.mission.export import ExportExtras
    from uavplan.mission.fence import FenceBuild
    from uavplan.mission.items import MissionPlan
    from uavplan.render import Scene
    from uavplan.route import PlannedRoute


def fence_for(
    scenario: Scenario,
    route: PlannedRoute,
    mission: MissionPlan,
    *,
    max_items: int | None = None,
) -> tuple[MissionPlan, FenceBuild]:
    """``mission`` with the geofence for ``route`` flown through ``scenario``'s obstacles and
    bounds (at most ``max_items`` fence items, default PX4's 63), and how it was built."""
    from uavplan.mission.fence import DEFAULT_MAX_ITEMS, geofence_for_route

    built = geofence_for_route(
        route,
        scenario.obstacles,
        scenario.bounds,
        max_items=DEFAULT_MAX_ITEMS if max_items is None else max_items,
    )
    return replace(mission, fence=built.fence), built


def export_extras(
    scenario: Scenario,
    route: PlannedRoute | None = None,
    properties: Mapping[str, Any] | None = None,
) -> ExportExtras:
    """What a .geojson / .kml export draws beyond the mission: ``scenario``'s obstacles, name
    and margin, and with a just-planned ``route`` its smoothed path and flown line."""
    from uavplan.geo import EnuFrame
    from uavplan.mission.export import ExportExtras

    if route is not None:
        return ExportExtras.for_route(
            route, scenario.obstacles, name=scenario.name, properties=properties
        )
    return ExportExtras(
        frame=EnuFrame.at(scenario.origin),
        obstacles=scenario.obstacles,
        name=scenario.name,
        safety_margin_m=scenario.safety_margin_m,
        properties=dict(properties or {}),
    )


def scene_for(scenario: Scenario) -> Scene:
    """The plain values a picture of ``scenario`` draws (obstacles, bounds, margin, ends)."""
    from uavplan.render import Scene

    sx, sy, sz = (float(v) for v in scenario.start_m)
    gx, gy, gz = (float(v) for v in scenario.goal_m)
    return Scene(
        name=scenario.name,
        bounds=scenario.bounds,
        obstacles=scenario.obstacles,
        safety_margin_m=scenario.safety_margin_m,
        start_enu=(sx, sy, sz),
        goal_enu=(gx, gy, gz),
    )
