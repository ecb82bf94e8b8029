# Type stub of the C extension built from uavplan/_csrc/*.c (kernels.h there: the contract).
# Array arguments are C-contiguous numpy arrays (float64 / int64 / bool / uint64); outputs are
# allocated by the caller and filled in place.
from typing import Any

import numpy as np

_A = np.ndarray[Any, Any]
# The named structures (read by field name, see FIELDS), built by the layers above:
KernelWorld = Any  # uavplan._geom.KernelWorld
EnergyArgs = Any  # uavplan.path.energy.EnergyArgs
Reach = Any  # uavplan.planners._kernels.Reach
StepSetup = Any  # uavplan.planners._kernels.StepSetup
StepDraws = Any  # uavplan.planners._kernels.StepDraws

# The constants the Python side reads (kernels.h)
SPSA_START_END: int
SPSA_LITERAL: int
SPSA_POP_INDEX: int
SPSA_ESCAPE: int
SPSA_OSCILLATE: int
SPSA_EPS: float
DRAW_NONE: int
DRAW_UNIFORM: int
DRAW_SYMMETRIC: int
DRAW_NORMAL: int
MEMO_BITS: int
MEMO_PROBES: int
STEP_MAX_THREADS: int
HAVE_THREADS: int
FIELD_META: int
GOLD: float
DIST_TOL_M: float
FAR: float
# {structure: ((field, kind, ndim, writable), ...)}: the named structures' fields (args.c)
FIELDS: dict[str, tuple[tuple[str, str, int, bool], ...]]

def point_polygon_dist2d(px: float, py: float, verts: _A, n: int) -> float: ...
def point_piece_dist(
    px: float, py: float, pz: float, k: int, poly_xy: _A, poly_n: _A, poly_h: _A, circ: _A
) -> float: ...
def seg_piece_dist(
    ax: float, ay: float, az: float, bx: float, by: float, bz: float, k: int,
    poly_xy: _A, poly_n: _A, poly_h: _A, circ: _A, box: _A, thr: float,
) -> float: ...  # fmt: skip
def segment_free(
    ax: float, ay: float, az: float, bx: float, by: float, bz: float, world: KernelWorld,
    margin: float,
) -> bool: ...  # fmt: skip
def segments_free(
    p0: _A, p1: _A, world: KernelWorld, margin: float, out: _A, threads: int = ...
) -> None: ...
def farthest_visible(p: _A, world: KernelWorld, margin: float, keep: _A) -> int: ...
def refine_vertices(
    v: _A,
    moves: _A,
    steps: _A,
    passes: int,
    world: KernelWorld,
    margin: float,
    weights: tuple[float, float, float],
) -> None: ...
def points_clearance(p: _A, world: KernelWorld, dist: _A, which: _A) -> None: ...
def segments_clearance(p0: _A, p1: _A, world: KernelWorld, dist: _A, which: _A) -> None: ...
def cells_count(
    box: _A, pad: float, x0: float, y0: float, cell: float, nx: int, ny: int,
    piece_cells: _A, counts: _A,
) -> None: ...  # fmt: skip
def cells_fill(piece_cells: _A, ny: int, cell_start: _A, cell_items: _A) -> None: ...
def node_status(
    j: int, y0: float, z0: float, y1: float, z1: float, cols: _A, dy: float, dz: float,
    lim: float, tab: _A, off: _A, keys: _A,
) -> int: ...  # fmt: skip
def node_resolve(
    j: int, y0: float, z0: float, y1: float, z1: float, cols: _A, dy: float, dz: float,
    start_m: _A, goal_m: _A, world: KernelWorld, margin: float, keys: _A,
) -> int: ...  # fmt: skip
def reachable(j: int, y0: float, z0: float, y1: float, z1: float, reach: Reach) -> int: ...
def clearance_table(
    cols: _A, ylim: _A, iy_lo: int, iy_hi: int, iz_lo: int, iz_hi: int, dy: float, dz: float,
    world: KernelWorld, cap: float, tab: _A, exact: float = ...,
) -> None: ...  # fmt: skip
def init_population(
    n_pop: int, n_inner: int, start_u: _A, goal_u: _A, half_window: float, t_max: int,
    max_attempts: int, window: _A, reach: Reach, bitgen: object, nodes: _A, ok: _A,
) -> int: ...  # fmt: skip
def rebuild(
    base: _A, active: _A, anchor: _A, offset: _A, spread: _A, draw: _A, spread2: _A,
    draw2: _A, clamp: _A, first: _A, use_first: _A, explicit: _A, n_explicit: _A,
    escape: _A, t_max: int, v_min: int, v_max: int, reach: Reach, seeds: _A,
    out: _A, ok: _A,
) -> int: ...  # fmt: skip
def moving_average_repair(
    nodes: _A, goal_u: _A, window: int, reach: Reach, skip: _A, moved: _A
) -> None: ...
def paths_feasible(nodes: _A, reach: Reach, out: _A) -> None: ...
def ziggurat_tables() -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]: ...
def stream_draws(seed: int, kind: int, n: int) -> list[Any]: ...
def polyline_energy(
    points: _A, k0: float, k1: float, mu0: float, k2: float
) -> tuple[float, float, float]: ...
def spline_points(ys: _A, zs: _A, dx: float, n_sub: int, cp: _A, den: _A, out: _A) -> None: ...
def population_energy(nodes: _A, energy: EnergyArgs, out: _A) -> None: ...
def energy_bounds(nodes: _A, energy: EnergyArgs, out: _A) -> None: ...
def round_grid(values: _A, out: _A) -> None: ...
def largest_free_fraction(
    p: _A, step: _A, a: _A, b: _A, world: KernelWorld, margin: float, bisections: int
) -> float: ...
def sign_draws(capsule: Any, out: _A) -> None: ...
def spsa_step(
    x: _A, f: _A, osc_fixed: _A, counts: _A, setup: StepSetup, draws: StepDraws
) -> None: ...
def node_clearance(px: float, py: float, pz: float, world: KernelWorld, cap: float) -> float: ...
def field_heights(p: _A, world: KernelWorld, kind: int, out: _A) -> None: ...
def field_nearest(p0: _A, p1: _A, world: KernelWorld, dist: _A, kind: _A, where: _A) -> None: ...
def astar_kernel(
    lo: _A, shape: _A, steps: _A, start: _A, goal: _A, world: KernelWorld, margin: float,
    cap: float, k0: float, k2: float, moves: _A,
) -> tuple[int, bytes, int, float]: ...  # fmt: skip
