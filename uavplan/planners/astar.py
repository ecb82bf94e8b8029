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

The search is one compiled function (numba) with an indexed binary heap in arrays; node
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
from numba import njit

from uavplan._geom import point_piece_dist, segment_free
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


@njit(cache=True)
def _node_clearance(px, py, pz, W, cap):
    """Distance from a point to the nearest piece, capped at ``cap``; −1 outside the bounds."""
    poly_xy, poly_n, poly_h, circ, box, hp, zlim = W[0], W[1], W[2], W[3], W[4], W[5], W[6]
    eps = 1e-9
    if pz < zlim[0] - eps or pz > zlim[1] + eps:
        return -1.0
    for i in range(hp.shape[0]):
        if hp[i, 0] * px + hp[i, 1] * py > hp[i, 2] + eps:
            return -1.0
    best = cap
    for k in range(box.shape[0]):
        gx = max(0.0, box[k, 0] - px, px - box[k, 1])
        gy = max(0.0, box[k, 2] - py, py - box[k, 3])
        gz = max(0.0, pz - box[k, 4], -pz)
        if gx * gx + gy * gy + gz * gz >= best * best:
            continue
        d = point_piece_dist(px, py, pz, k, poly_xy, poly_n, poly_h, circ)
        if d < best:
            best = d
    return best


@njit(cache=True, inline="always")
def _before(a, b, f, h):
    """Heap order: smaller f, ties to smaller h (deeper nodes first)."""
    if f[a] != f[b]:
        return f[a] < f[b]
    return h[a] < h[b]


@njit(cache=True)
def _sift_up(heap, pos, i, f, h):
    v = heap[i]
    while i > 0:
        p = (i - 1) >> 1
        if not _before(v, heap[p], f, h):
            break
        heap[i] = heap[p]
        pos[heap[i]] = i
        i = p
    heap[i] = v
    pos[v] = i


@njit(cache=True)
def _pop(heap, pos, size, f, h):
    """Remove and return the heap's first item; ``size`` is the size before the pop."""
    top = heap[0]
    pos[top] = -1
    size -= 1
    if size > 0:
        v = heap[size]
        i = 0
        while True:
            c = 2 * i + 1
            if c >= size:
                break
            if c + 1 < size and _before(heap[c + 1], heap[c], f, h):
                c += 1
            if not _before(heap[c], v, f, h):
                break
            heap[i] = heap[c]
            pos[heap[i]] = i
            i = c
        heap[i] = v
        pos[v] = i
    return top


@njit(cache=True)
def _links(px, py, pz, radius, lo, shape, steps, W, margin, cap, clear, out_node, out_cost, k0, k2):
    """Valid grid nodes within ``radius`` steps per axis of point p with a free segment to p.

    Fills ``out_node``/``out_cost`` (cost ``k0·L + k2·|Δz|``) and returns how many."""
    lim = max(margin - 1e-9, 1e-9)
    ny = shape[1]
    nz = shape[2]
    u = (px / steps[0], py / steps[1], pz / steps[2])
    rng_lo = np.empty(3, np.int64)
    rng_hi = np.empty(3, np.int64)
    for ax in range(3):
        rng_lo[ax] = max(int(math.ceil(u[ax] - radius - 1e-9)) - lo[ax], 0)
        rng_hi[ax] = min(int(math.floor(u[ax] + radius + 1e-9)) - lo[ax], shape[ax] - 1)
    n = 0
    for a in range(rng_lo[0], rng_hi[0] + 1):
        x = (a + lo[0]) * steps[0]
        for b in range(rng_lo[1], rng_hi[1] + 1):
            y = (b + lo[1]) * steps[1]
            for c in range(rng_lo[2], rng_hi[2] + 1):
                z = (c + lo[2]) * steps[2]
                v = (a * ny + b) * nz + c
                if math.isnan(clear[v]):
                    clear[v] = _node_clearance(x, y, z, W, cap)
                if clear[v] < lim:
                    continue
                if not segment_free(px, py, pz, x, y, z, W, margin):
                    continue
                if n < out_node.shape[0]:
                    ex = x - px
                    ey = y - py
                    ez = z - pz
                    out_node[n] = v
                    out_cost[n] = k0 * math.sqrt(ex * ex + ey * ey + ez * ez) + k2 * abs(ez)
                    n += 1
    return n


@njit(cache=True)
def _astar_kernel(lo, shape, steps, start, goal, W, margin, cap, k0, k2, moves):
    """A* from ``start`` to ``goal`` (path-frame points) over the grid ``lo``/``shape``/``steps``
    (node (a, b, c) at ((lo + (a, b, c))·steps)). Returns (status, nodes (k, 3) of the grid
    part of the path, expanded count, cost)."""
    nj = shape[0]
    ny = shape[1]
    nz = shape[2]
    n_nodes = nj * ny * nz
    goal_id = n_nodes
    start_id = n_nodes + 1
    lim = max(margin - 1e-9, 1e-9)
    dx = steps[0]
    dy = steps[1]
    dz = steps[2]
    clear = np.full(n_nodes, np.nan)
    g = np.full(n_nodes + 1, np.inf)
    f = np.full(n_nodes + 1, np.inf)
    h = np.zeros(n_nodes + 1)
    parent = np.full(n_nodes + 1, -1, np.int64)
    closed = np.zeros(n_nodes + 1, np.uint8)
    heap = np.empty(n_nodes + 1, np.int64)
    pos = np.full(n_nodes + 1, -1, np.int64)
    goal_link = np.full(n_nodes, np.inf)
    size = 0
    no_path = np.empty((0, 3))

    gx = goal[0]
    gy = goal[1]
    gz = goal[2]
    # links of the exact end points to the grid
    buf_node = np.empty(7**3, np.int64)
    buf_cost = np.empty(7**3)
    n_goal = 0
    for r in LINK_RADII:
        n_goal = _links(
            gx, gy, gz, r, lo, shape, steps, W, margin, cap, clear, buf_node, buf_cost, k0, k2
        )
        if n_goal > 0:
            break
    for i in range(n_goal):
        goal_link[buf_node[i]] = buf_cost[i]
    if n_goal == 0:
        return _INVALID_GOAL, no_path, 0, math.inf
    n_start = 0
    for r in LINK_RADII:
        n_start = _links(
            start[0],
            start[1],
            start[2],
            r,
            lo,
            shape,
            steps,
            W,
            margin,
            cap,
            clear,
            buf_node,
            buf_cost,
            k0,
            k2,
        )
        if n_start > 0:
            break
    if n_start == 0:
        return _INVALID_START, no_path, 0, math.inf
    for i in range(n_start):
        v = buf_node[i]
        c = v % nz
        b = (v // nz) % ny
        a = v // (ny * nz)
        ex = (a + lo[0]) * dx - gx
        ey = (b + lo[1]) * dy - gy
        ez = (c + lo[2]) * dz - gz
        g[v] = buf_cost[i]
        h[v] = k0 * math.sqrt(ex * ex + ey * ey + ez * ez) + k2 * abs(ez)
        f[v] = g[v] + h[v]
        parent[v] = start_id
        heap[size] = v
        size += 1
        _sift_up(heap, pos, size - 1, f, h)

    # per-move metric offsets and costs
    n_moves = moves.shape[0]
    mx = np.empty(n_moves)
    my = np.empty(n_moves)
    mz = np.empty(n_moves)
    mcost = np.empty(n_moves)
    mlen = np.empty(n_moves)
    for m in range(n_moves):
        mx[m] = moves[m, 0] * dx
        my[m] = moves[m, 1] * dy
        mz[m] = moves[m, 2] * dz
        mlen[m] = math.sqrt(mx[m] ** 2 + my[m] ** 2 + mz[m] ** 2)
        mcost[m] = k0 * mlen[m] + k2 * abs(mz[m])

    expanded = 0
    found = False
    while size > 0:
        u = _pop(heap, pos, size, f, h)
        size -= 1
        if u == goal_id:
            found = True
            break
        closed[u] = 1
        expanded += 1
        if goal_link[u] < math.inf and g[u] + goal_link[u] < g[goal_id]:
            g[goal_id] = g[u] + goal_link[u]
            f[goal_id] = g[goal_id]
            parent[goal_id] = u
            if pos[goal_id] < 0:
                heap[size] = goal_id
                pos[goal_id] = size
                size += 1
            _sift_up(heap, pos, pos[goal_id], f, h)
        c = u % nz
        b = (u // nz) % ny
        a = u // (ny * nz)
        ux = (a + lo[0]) * dx
        uy = (b + lo[1]) * dy
        uz = (c + lo[2]) * dz
        du = clear[u]
        for m in range(n_moves):
            a2 = a + moves[m, 0]
            b2 = b + moves[m, 1]
            c2 = c + moves[m, 2]
            if a2 < 0 or a2 >= nj or b2 < 0 or b2 >= ny or c2 < 0 or c2 >= nz:
                continue
            v = (a2 * ny + b2) * nz + c2
            if closed[v]:
                continue
            ng = g[u] + mcost[m]
            if ng >= g[v]:
                continue
            vx = ux + mx[m]
            vy = uy + my[m]
            vz = uz + mz[m]
            dv = clear[v]
            if math.isnan(dv):
                dv = _node_clearance(vx, vy, vz, W, cap)
                clear[v] = dv
            if dv < lim:
                closed[v] = 2  # invalid node
                continue
            if du + dv - mlen[m] < 2.0 * lim:
                if not segment_free(ux, uy, uz, vx, vy, vz, W, margin):
                    continue
            g[v] = ng
            parent[v] = u
            if pos[v] < 0:
                ex = vx - gx
                ey = vy - gy
                ez = vz - gz
                h[v] = k0 * math.sqrt(ex * ex + ey * ey + ez * ez) + k2 * abs(ez)
                f[v] = ng + h[v]
                heap[size] = v
                size += 1
                _sift_up(heap, pos, size - 1, f, h)
            else:
                f[v] = ng + h[v]
                _sift_up(heap, pos, pos[v], f, h)
    if not found:
        return _NO_PATH, no_path, expanded, math.inf
    count = 0
    v = parent[goal_id]
    while v != start_id:
        count += 1
        v = parent[v]
    nodes = np.empty((count, 3))
    v = parent[goal_id]
    for i in range(count - 1, -1, -1):
        nodes[i, 0] = (v // (ny * nz) + lo[0]) * dx
        nodes[i, 1] = ((v // nz) % ny + lo[1]) * dy
        nodes[i, 2] = (v % nz + lo[2]) * dz
        v = parent[v]
    return _FOUND, nodes, expanded, g[goal_id]


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
