"""The global search behind the guide-path frame, and the honest "no path" answer.

The paper's encoding lays its columns along the straight start→goal line, so a route can
never move backwards and the eq. 8–10 random walk rarely threads a narrow gap. When the
swarm cannot even initialise along that line, :func:`find_guide` runs a grid A* over the
whole flight volume (:mod:`uavplan.planners.astar`, every obstacle inflated by the margin,
26-connected, so it may turn back), coarse first and finer when the coarse grid finds
nothing. Its route, shortened by line of sight, becomes the guide the columns stand along
(:meth:`~uavplan.path.frame.PathFrame.along`), and it is also the route to fly if the swarm
still fails. When no grid route exists at the finest resolution tried, the answer says why
in the user's terms: the start is enclosed, the goal is enclosed, or no gap wide enough for
the margin connects them.

Measured choice: the grid A* was already our independent reference; on the paper
environments it takes 0.1–0.3 s at the planner's grid (2 km, 100 × 64 × 26 nodes), a coarse
grid (twice the steps) an eighth of the nodes. It runs only when the straight frame fails,
so routes with no topological problem pay nothing for it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from uavplan.config import MARGIN_PAD_M, EnergyWeights
from uavplan.outcome import RouteFailure
from uavplan.path.energy import PhysicalFitness
from uavplan.path.frame import PathFrame
from uavplan.path.post import simplify
from uavplan.planners.astar import GridRoute, GridStatus, _grid_extent, astar
from uavplan.planners.base import PathProblem
from uavplan.world import World

#: grid refinements tried, as multiples of the planner's grid steps (coarse first)
GUIDE_SCALES = (2.0, 1.0, 0.5)
#: a grid search holds 37 bytes a node (uavplan/_csrc/astar.c): no grid of more nodes than
#: this is searched (about 74 MB). The first, coarsest grid is coarsened further until it
#: fits; a finer one is not tried when it would not fit.
MAX_GUIDE_NODES = 2_000_000


@dataclass(frozen=True, eq=False)
class Guide:
    """Outcome of the global search. ``route_pf`` (n, 3): the line-of-sight route in the
    path frame (start to goal, keeps the margin), ``guide_xy`` its horizontal polyline;
    ``steps_m`` the grid spacing that decided; when nothing was found, ``failure`` says why
    and ``message`` says it to the user."""

    failure: RouteFailure | None
    route_pf: np.ndarray | None
    steps_m: tuple[float, float, float]
    runtime_s: float
    message: str = ""

    @property
    def found(self) -> bool:
        return self.failure is None

    @property
    def guide_xy(self) -> np.ndarray:
        assert self.route_pf is not None
        return self.route_pf[:, :2]

    @property
    def is_straight(self) -> bool:
        """Does the route only move forward along the start→goal line? Then the paper's
        straight columns can hold it."""
        return self.found and bool(np.all(np.diff(self.guide_xy[:, 0]) > 0))


@dataclass(frozen=True, eq=False)
class GuideSpace:
    """What the global search needs of a path problem: its world in the path frame, the
    frame and the energy weights; not its node table or memo, so a caller can let those go
    before the search builds its own grid (:meth:`of`)."""

    world: World
    frame: PathFrame
    energy: EnergyWeights
    fitness_smoothing: int = 0
    physical: PhysicalFitness | None = None

    @classmethod
    def of(cls, problem: PathProblem) -> GuideSpace:
        return cls(
            problem.world,
            problem.frame,
            problem.energy,
            problem.fitness_smoothing,
            problem.physical,
        )


def _nodes(problem: PathProblem | GuideSpace, steps: tuple[float, float, float]) -> int:
    """Nodes of the A* grid over the flight volume at ``steps``."""
    _, shape = _grid_extent(problem.world, steps)
    return int(np.prod(shape))


def find_guide(problem: PathProblem | GuideSpace) -> Guide:
    """Grid A* from start to goal over the whole flight volume of ``problem`` (its world in
    the path frame, its margin), coarse to fine; the first route found, shortened by line of
    sight, or why there is none."""
    t0 = time.perf_counter()
    frame, world = problem.frame, problem.world
    base = (frame.dx_m, frame.grid.dy_m, frame.grid.dz_m)
    last: GridRoute | None = None
    steps = base
    first = GUIDE_SCALES[0]
    while _nodes(problem, tuple(b * first for b in base)) > MAX_GUIDE_NODES:  # type: ignore[arg-type]
        first *= 1.25
    for scale in (first, *(s for s in GUIDE_SCALES if s < first)):
        steps = (base[0] * scale, base[1] * scale, base[2] * scale)
        if last is not None and _nodes(problem, steps) > MAX_GUIDE_NODES:
            break
        last = astar(world, frame, problem.energy, steps)
        if last.found:
            assert last.path_pf is not None
            route = last.path_pf[simplify(last.path_pf, world)]
            return Guide(None, route, steps, time.perf_counter() - t0)
    assert last is not None
    return _why_not(problem, last, steps, time.perf_counter() - t0)


def _why_not(problem: PathProblem | GuideSpace, route: GridRoute, steps: tuple[float, float, float],
             runtime_s: float) -> Guide:  # fmt: skip
    margin = problem.world.margin_m - MARGIN_PAD_M  # the user's margin (planning pads it)
    res = f"{steps[0]:g} × {steps[1]:g} × {steps[2]:g} m"
    failure: RouteFailure
    if route.status is GridStatus.INVALID_START:
        failure, why = RouteFailure.START_ENCLOSED, "the start is enclosed: no free straight line"
        why += f" leads from it to the free space ({margin:g} m margin kept)"
    elif route.status is GridStatus.INVALID_GOAL:
        failure, why = RouteFailure.GOAL_ENCLOSED, "the goal is enclosed: no free straight line"
        why += f" leads from the free space to it ({margin:g} m margin kept)"
    else:
        # both ends touch free space that does not connect: the side whose free space is the
        # smaller is the enclosed one (a full search from each side counts it)
        back = astar(problem.world, problem.frame, problem.energy, steps, reverse=True)
        if back.expanded < 0.5 * route.expanded:
            failure, who = RouteFailure.GOAL_ENCLOSED, "the goal is enclosed"
        elif route.expanded < 0.5 * back.expanded:
            failure, who = RouteFailure.START_ENCLOSED, "the start is enclosed"
        else:
            failure, who = RouteFailure.SEPARATED, "start and goal are separated"
        why = (
            f"{who}: no gap wide enough for the {margin:g} m safety margin connects start and "
            "goal inside the flight bounds"
        )
    message = f"{why} (grid search over the whole flight volume at {res})"
    return Guide(failure, None, steps, runtime_s, message)


def guided_problem(problem: PathProblem, guide: Guide) -> PathProblem:
    """``problem`` with its columns along ``guide``'s route (a straight route keeps the
    paper's straight columns)."""
    if guide.is_straight or not guide.found:
        return problem
    return problem.along(guide.guide_xy)


def problem_along(space: GuideSpace, guide: Guide) -> PathProblem:
    """The path problem of ``space`` with its columns along ``guide``'s route (not
    straight: a straight route keeps the problem the caller has)."""
    frame = space.frame.along(guide.guide_xy)
    return PathProblem.in_frame(
        space.world, frame, space.energy, space.fitness_smoothing, space.physical
    )
