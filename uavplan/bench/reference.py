"""Independent reference planners for the bench: grid A* + line of sight, and OMPL's
sampling-based optimal planners (RRT*, Informed RRT*, BIT*).

A reference row answers "where does the swarm stand against a planner that does not share
its encoding?". Every reference works on the same problem as the swarm planners:

* the same flight volume and rule: a point is valid when it is inside the scenario's bounds,
  not below the floor the swarm uses (the margin, or the start / goal when lower) and at
  least the safety margin (+ the swarm's margin pad) from every obstacle — exactly
  :meth:`World.points_clearance` / :meth:`World.segments_free` of the world the swarm's
  :class:`~uavplan.planners.base.PathProblem` checks against, here in ENU;
* the same yardstick: the raw polyline is scored with E (eq. 1, :func:`energy_terms`), and the
  route with the same post-processing chain every baseline gets in
  :func:`uavplan.planning.plan_route` (node simplification, cubic spline blended back where
  it would cut the margin, waypoint resampling), then E of the smoothed curve.

OMPL is optional (``pip install 'uavplan[ompl]'``) and imported only here, lazily; nothing
else in the package needs it. OMPL minimises path *length* (its standard objective), not E;
E's turning and climb terms are not visible to it — a difference in the reference's favour
for length and against it for smoothness; the post-processing chain smooths it like every
other path.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from uavplan.config import MARGIN_PAD_M, EnergyWeights, PostParams
from uavplan.path.energy import energy_terms
from uavplan.path.post import dedupe, simplify, smooth_route
from uavplan.scenario import Scenario
from uavplan.world import World

#: reference label → the OMPL planner class name in ``ompl.geometric``
OMPL_PLANNERS: dict[str, str] = {
    "ompl-rrtstar": "RRTstar",
    "ompl-informed-rrtstar": "InformedRRTstar",
    "ompl-bitstar": "BITstar",
}
#: the grid A* + line-of-sight reference (deterministic: one run per scenario)
ASTAR = "astar-los"
REFERENCES: tuple[str, ...] = (*OMPL_PLANNERS, ASTAR)
#: the solve time of an OMPL row when no SPSA time is known, seconds
DEFAULT_TIME_S = 1.0


def ompl_available() -> bool:
    """Is the optional ``ompl`` package importable?"""
    try:
        import ompl.geometric  # type: ignore[import-untyped,import-not-found,unused-ignore]  # noqa: F401
    except ImportError:
        return False
    return True


OMPL_MISSING = (
    "the OMPL reference rows need the optional extra: pip install 'uavplan[ompl]' "
    "(the ompl package); they were skipped"
)


@dataclass(frozen=True)
class ReferenceRun:
    """One reference planner's outcome on one scenario, scored on the swarm's yardstick.

    ``raw_energy``: E of the planner's own polyline; ``route_energy``: E after the shared
    post-processing chain; ``runtime_s``: the planner's solve time plus the chain."""

    found: bool
    raw_energy: float
    route_energy: float
    length_m: float
    min_clearance_m: float
    collision_free: bool
    runtime_s: float
    stats: dict[str, float]
    message: str = ""


def reference_world(scenario: Scenario, world: World) -> World:
    """``world`` (ENU) with the margin and floor the swarm's path problem uses."""
    start, goal = scenario.start_m, scenario.goal_m
    floor = min(world.margin_m, float(start[2]), float(goal[2]))
    return world.in_frame((0.0, 0.0), 0.0, world.margin_m + MARGIN_PAD_M, floor)


def postprocess(
    raw: np.ndarray, world: World, energy: EnergyWeights, post: PostParams
) -> tuple[float, np.ndarray]:
    """The baselines' chain of :func:`uavplan.planning.plan_route` on a feasible polyline:
    (E of the smoothed route, its samples). Simplification when ``post.simplify``; no
    refinement or string pulling (those are SPSA's variant)."""
    vertices = dedupe(raw)
    if post.simplify:
        vertices = vertices[simplify(vertices, world)]
    smoothed = smooth_route(
        vertices, world, smooth=post.smooth, step_m=post.sample_step_m, weights=energy
    )
    samples = dedupe(smoothed.samples)
    return float(sum(energy_terms(samples, energy))), samples


def _score(
    raw: np.ndarray,
    world: World,
    scenario: Scenario,
    runtime_s: float,
    stats: dict[str, float],
) -> ReferenceRun:
    cfg = scenario.planner
    t0 = time.perf_counter()
    route_e, samples = postprocess(raw, world, cfg.energy, cfg.post)
    runtime_s += time.perf_counter() - t0
    clearance = world.polyline_clearance(samples)
    inside = bool(world.points_inside_bounds(samples).all())
    length = float(np.linalg.norm(np.diff(samples, axis=0), axis=1).sum())
    return ReferenceRun(
        True,
        float(sum(energy_terms(raw, cfg.energy))),
        route_e,
        length,
        clearance,
        inside and clearance >= scenario.safety_margin_m - 1e-6,
        runtime_s,
        stats,
    )


def _failed(runtime_s: float, message: str, stats: dict[str, float]) -> ReferenceRun:
    nan = math.nan
    return ReferenceRun(False, nan, nan, nan, -math.inf, False, runtime_s, stats, message)


_astar_warm: list[bool] = []


def run_astar(scenario: Scenario, world: World) -> ReferenceRun:
    """Grid A* on the scenario's path-frame grid (26-connected, cost k0·L + k2·|Δz|), then
    the shared chain (its simplification is the line-of-sight shortcutting)."""
    from uavplan.planning import reference_route

    ref_world = reference_world(scenario, world)
    if not _astar_warm:  # the first call in a process loads / compiles the kernel: untimed
        reference_route(scenario, world=world)
        _astar_warm.append(True)
    route = reference_route(scenario, world=world)
    stats = {"expanded": float(route.expanded)}
    if not route.found or route.path_enu is None:
        return _failed(route.runtime_s, "A*: no path on the grid", stats)
    raw = np.asarray(route.path_enu, dtype=float)
    # A* keeps the plain margin; the chain checks with the swarm's (padded) one, so a raw
    # vertex that sits in the pad is kept as it is (simplify only ever drops vertices)
    return _score(raw, ref_world, scenario, route.runtime_s, stats)


def run_ompl(
    scenario: Scenario, world: World, planner: str, time_s: float, seed: int
) -> ReferenceRun:
    """OMPL planner ``planner`` (a key of :data:`OMPL_PLANNERS`) on the scenario for
    ``time_s`` seconds of solve time, path-length objective, seeded with ``seed``.

    State space: the scenario's bounds box (x, y, z, with the swarm's floor). State
    validity: inside the bounds and clearance ≥ margin (+ pad) by
    :meth:`World.points_clearance`; motion validity: :meth:`World.segments_free`, the exact
    segment test the swarm's reachability rule uses."""
    from ompl import base as ob  # type: ignore[import-untyped,import-not-found,unused-ignore]
    from ompl import geometric as og  # type: ignore[import-untyped,import-not-found,unused-ignore]
    from ompl import util as ou  # type: ignore[import-untyped,import-not-found,unused-ignore]

    if hasattr(ou, "setLogLevel"):
        ou.setLogLevel(ou.LogLevel.LOG_NONE)
    if hasattr(ou, "RNG") and hasattr(ou.RNG, "setSeed"):
        ou.RNG.setSeed(int(seed) % (2**31 - 1) + 1)
    ref_world = reference_world(scenario, world)
    margin = ref_world.margin_m
    b = scenario.bounds
    floor = float(ref_world.zlim[0])
    space = ob.RealVectorStateSpace(3)
    bounds = ob.RealVectorBounds(3)
    lows = (b.x_m[0], b.y_m[0], max(b.z_m[0], floor))
    highs = (b.x_m[1], b.y_m[1], b.z_m[1])
    for i in range(3):
        bounds.setLow(i, float(lows[i]))
        bounds.setHigh(i, float(highs[i]))
    space.setBounds(bounds)
    ss = og.SimpleSetup(space)
    counts = {"states_checked": 0, "motions_checked": 0}

    def state_valid(s: object) -> bool:
        counts["states_checked"] += 1
        p = np.array([[s[0], s[1], s[2]]])  # type: ignore[index]
        if not ref_world.points_inside_bounds(p)[0]:
            return False
        return bool(ref_world.points_clearance(p)[0][0] >= margin)

    class Motion(ob.MotionValidator):  # type: ignore[misc, name-defined]
        def checkMotion(self, s1: object, s2: object, *_: object) -> bool:
            counts["motions_checked"] += 1
            p0 = np.array([[s1[0], s1[1], s1[2]]])  # type: ignore[index]
            p1 = np.array([[s2[0], s2[1], s2[2]]])  # type: ignore[index]
            return bool(ref_world.segments_free(p0, p1)[0])

    ss.setStateValidityChecker(state_valid)
    si = ss.getSpaceInformation()
    motion = Motion(si)
    si.setMotionValidator(motion)
    start, goal = space.allocState(), space.allocState()
    start[0:3] = [float(v) for v in scenario.start_m]
    goal[0:3] = [float(v) for v in scenario.goal_m]
    ss.setStartAndGoalStates(start, goal)
    ss.setOptimizationObjective(ob.PathLengthOptimizationObjective(si))
    ss.setPlanner(getattr(og, OMPL_PLANNERS[planner])(si))
    t0 = time.perf_counter()
    ss.solve(float(time_s))
    solve_s = time.perf_counter() - t0
    stats = {**{k: float(v) for k, v in counts.items()}, "time_limit_s": float(time_s)}
    if not ss.haveExactSolutionPath():
        return _failed(solve_s, f"{planner}: no exact solution in {time_s:.2f} s", stats)
    path = ss.getSolutionPath()
    raw = np.array([[s[0], s[1], s[2]] for s in path.getStates()], dtype=float)
    return _score(raw, ref_world, scenario, solve_s, stats)
