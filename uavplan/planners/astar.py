"""A* on the 3-D path-frame grid: an independent reference planner (grid A* + line of sight)
and a cheap "does any path exist" check.

The grid is the planner's (PAPER-NOTES "Path model"): nodes at ``(j·dx, iy·dy, iz·dz)`` in
the path frame, ``dx`` the frame's column spacing (``PathFrame.dx_m``), ``dy``/``dz`` the
scenario grid's, covering the whole flight bounds (columns before the start and past the goal
included). Unlike the SPSA encoding (one node per column, x strictly increasing) the search
moves to all 26 neighbours, so a route may step sideways, climb in place or go back in x.

* A node is valid when it is inside the bounds and at least the margin from every obstacle.
* An edge is valid when its straight segment is free (exact test of :mod:`uavplan._geom`;
  skipped when the two node clearances d0, d1 already prove it: ``(d0 + d1 − L)/2 ≥ margin``,
  distance being 1-Lipschitz).
* Edge cost ``k0·L + k2·|Δz|``: the path and climb terms of eq. 1. The turning term is *not*
  part of the cost: it depends on the previous move, so it cannot be a node-local cost without
  expanding the state to (node, incoming direction) — 26× the nodes. Shortcutting afterwards
  removes most turns anyway; score the final polyline with :func:`energy_terms` for the full E.
* Heuristic ``k0·|p − goal| + k2·|z − z_goal|``: admissible and consistent (both terms obey
  the triangle inequality), so every node is expanded at most once.
* The exact start and goal points are linked by free straight segments to their nearest valid
  grid nodes (within one grid step per axis, widened to three if none is free). There is no
  direct start→goal link: the route always runs through the grid, even in open space.

The search is one compiled function (C, :mod:`uavplan._ckernels`) with an indexed binary heap
in arrays; node
clearances are computed lazily, only for nodes the search touches. No edge memo is needed:
an edge is only tested from a node being expanded toward one not yet closed, and with a
consistent heuristic closed nodes never reopen, so each edge is tested at most once.
"""

from __future__ import annotations

import enum
import math
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from uavplan._geom import KernelWorld, _c
from uavplan.config import EnergyWeights
from uavplan.path.frame import PathFrame
from uavplan.world import World

if TYPE_CHECKING:
    from uavplan.planners.base import PathProblem

#: node clearances are computed up to margin + this (enough for the Lipschitz edge shortcut)
CLEARANCE_REACH_M = 60.0
#: start/goal link search: grid steps per axis around the point, widened until a link is free
LINK_RADII = (1.0, 2.0, 3.0)

_FOUND, _NO_PATH, _INVALID_START, _INVALID_GOAL = 0, 1, 2, 3


class GridStatus(enum.Enum):
    FOUND = "found"
    NO_PATH = "no_path"  # start and goal linked to the grid, but not to each other
    INVALID_START = "invalid_start"  # no free segment from the start to a valid grid node
    INVALID_GOAL = "invalid_goal"  # no free segment from a valid grid node to the goal


_STATUS = {
    _FOUND: GridStatus.FOUND,
    _NO_PATH: GridStatus.NO_PATH,
    _INVALID_START: GridStatus.INVALID_START,
    _INVALID_GOAL: GridStatus.INVALID_GOAL,
}


@dataclass(frozen=True, eq=False)
class GridRoute:
    """Outcome of one grid search. Paths include the exact start and goal points.

    ``cost`` is the A* objective ``k0·length + k2·Σ|Δz|`` of ``path_pf`` (no turning term);
    ``expanded`` counts nodes taken off the heap; ``grid_shape`` is (columns, y, z) nodes.
    """

    status: GridStatus
    frame: PathFrame
    path_pf: np.ndarray | None  # (n, 3) path frame, metres
    path_enu: np.ndarray | None  # (n, 3) ENU, metres
    cost: float
    expanded: int
    runtime_s: float
    grid_steps_m: tuple[float, float, float]
    grid_shape: tuple[int, int, int]

    @property
    def found(self) -> bool:
        return self.status is GridStatus.FOUND


# ---------------------------------------------------------------------------------------------
# Kernels


def _neighbour_offsets() -> np.ndarray:
    """The 26 moves (dj, diy, diz), shape (26, 3)."""
    d = np.array([-1, 0, 1])
    moves = np.stack(np.meshgrid(d, d, d, indexing="ij"), axis=-1).reshape(-1, 3)
    return np.ascontiguousarray(moves[np.any(moves != 0, axis=1)], dtype=np.int64)


_MOVES = _neighbour_offsets()


def _node_clearance(px: float, py: float, pz: float, W: KernelWorld, cap: float) -> float:
    """Distance from a point to the nearest piece, capped at ``cap``; −1 outside the bounds."""
    return _c.node_clearance(float(px), float(py), float(pz), W, float(cap))


def _astar_kernel(
    lo: np.ndarray,
    shape: np.ndarray,
    steps: np.ndarray,
    start: np.ndarray,
    goal: np.ndarray,
    W: KernelWorld,
    margin: float,
    cap: float,
    k0: float,
    k2: float,
    moves: np.ndarray,
) -> tuple[int, np.ndarray, int, float]:
    """A* from ``start`` to ``goal`` (path-frame points) over the grid ``lo``/``shape``/``steps``
    (node (a, b, c) at ((lo + (a, b, c))·steps)). Returns (status, nodes (k, 3) of the grid
    part of the path, expanded count, cost). The start and goal are linked to the grid within
    ``LINK_RADII`` steps; nodes are expanded in order of f, ties to the smaller h."""
    i64 = np.int64
    status, path, expanded, cost = _c.astar_kernel(
        np.ascontiguousarray(lo, i64), np.ascontiguousarray(shape, i64),
        np.ascontiguousarray(steps, np.float64), np.ascontiguousarray(start, np.float64),
        np.ascontiguousarray(goal, np.float64), W, float(margin), float(cap),
        float(k0), float(k2), np.ascontiguousarray(moves, i64),
    )  # fmt: skip
    nodes = np.frombuffer(path, dtype=np.float64).reshape(-1, 3).copy()
    return status, nodes, expanded, cost


# ---------------------------------------------------------------------------------------------
# Public API


def _grid_extent(world: World, steps: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Index of the first node and node counts per axis covering the bounds (world frame)."""
    hp = world.hp
    xs, ys = [], []
    for i in range(hp.shape[0]):
        for k in range(i + 1, hp.shape[0]):
            m = np.array([hp[i, :2], hp[k, :2]])
            if abs(np.linalg.det(m)) > 1e-12:
                x, y = np.linalg.solve(m, [hp[i, 2], hp[k, 2]])
                if world.points_inside_bounds(np.array([[x, y, world.zlim[0]]]))[0]:
                    xs.append(x)
                    ys.append(y)
    lo_m = (min(xs), min(ys), float(world.zlim[0]))
    hi_m = (max(xs), max(ys), float(world.zlim[1]))
    lo = np.array([math.ceil(a / s - 1e-9) for a, s in zip(lo_m, steps, strict=True)])
    hi = np.array([math.floor(b / s + 1e-9) for b, s in zip(hi_m, steps, strict=True)])
    return lo.astype(np.int64), np.maximum(hi - lo + 1, 1).astype(np.int64)


def astar(
    world: World,
    frame: PathFrame,
    energy: EnergyWeights,
    steps: tuple[float, float, float] | None = None,
    *,
    reverse: bool = False,
) -> GridRoute:
    """A* from ``frame``'s start to its goal (``reverse``: from the goal to the start);
    ``world`` must be in the path frame (``world_enu.in_frame(frame.origin_xy,
    frame.heading_rad)``). ``steps``: grid spacing (default: the frame's dx and the grid's
    dy, dz)."""
    t0 = time.perf_counter()
    steps = steps or (frame.dx_m, frame.grid.dy_m, frame.grid.dz_m)
    lo, shape = _grid_extent(world, steps)
    start = np.array([0.0, 0.0, frame.start_enu[2]])
    goal = np.array([frame.length_m, 0.0, frame.goal_enu[2]])
    if reverse:
        start, goal = goal, start
    code, nodes, expanded, cost = _astar_kernel(
        lo,
        shape,
        np.array(steps),
        start,
        goal,
        world.kernel_args,
        world.margin_m,
        world.margin_m + CLEARANCE_REACH_M,
        energy.k0,
        energy.k2,
        _MOVES,
    )
    status = _STATUS[int(code)]
    path_pf = path_enu = None
    if status is GridStatus.FOUND:
        path_pf = _dedupe(np.vstack([start, nodes, goal]))
        path_enu = frame.to_enu(path_pf)
    return GridRoute(
        status,
        frame,
        path_pf,
        path_enu,
        float(cost),
        int(expanded),
        time.perf_counter() - t0,
        steps,
        (int(shape[0]), int(shape[1]), int(shape[2])),
    )


def astar_problem(problem: PathProblem) -> GridRoute:
    """:func:`astar` on a planner's :class:`~uavplan.planners.base.PathProblem` (same grid,
    world and energy weights as the swarm planners)."""
    return astar(problem.world, problem.frame, problem.energy)


def _dedupe(points: np.ndarray, tol_m: float = 1e-9) -> np.ndarray:
    keep = np.concatenate([[True], np.linalg.norm(np.diff(points, axis=0), axis=1) > tol_m])
    return points[keep]
