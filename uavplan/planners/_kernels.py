"""Kernels shared by every planner: the reachability rule, the initialisation, the
generic proposal-and-repair step, the moving-average repair (eq. 13) and feasibility checks.

Encoding (PAPER-NOTES "Path model"): an individual is ``nodes[j] = (y, z)`` in grid units
for the inner columns ``j = 1..D−1`` (array index ``j − 1``); start and goal are fixed.
A node is *reachable* when the straight segment from the previous node to it is inside the
bounds and keeps the margin from every obstacle (for the last node, also the segment to the
goal). Every planner proposes nodes through one :class:`~uavplan.planners.proposal.Proposal`
(its own update rule, computed in its own module) and :func:`rebuild` repairs them the same
way for all, so differences between algorithms come from their update rules alone.

Everything the reachability rule reads travels in one :class:`Reach` value, and the fused
SPSA step's arguments in a :class:`StepSetup` and a :class:`StepDraws`: named fields the
kernels read by name (``_ckernels.FIELDS`` lists them), no positional slots. Randomness
comes only from seeds drawn from the caller's ``numpy.random.Generator``.

The loops are compiled C (:mod:`uavplan._ckernels`, built by pip at install time); the
functions here allocate their outputs and hand the arrays over. The constants below (draw
kinds, the memo's size, the step's switches and thread limit) are the kernels' own, read
from the module.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from uavplan import _geom
from uavplan._geom import KernelWorld, _c, kernel_fields
from uavplan.path.energy import EnergyArgs

#: how a proposal draws its random term for every attempt (``Proposal.draw``)
DRAW_NONE: int = _c.DRAW_NONE  # no random term
DRAW_UNIFORM: int = _c.DRAW_UNIFORM  # U[0, 1)
DRAW_SYMMETRIC: int = _c.DRAW_SYMMETRIC  # U[−1, 1): 2·U − 1
DRAW_NORMAL: int = _c.DRAW_NORMAL  # N(0, 1)


@dataclass(frozen=True, slots=True, eq=False)
class Reach:
    """Everything the reachability rule of one path problem reads (built by PathProblem).

    ``world``: the world in the path frame (``World.kernel_args``);
    ``cols`` (D + 1, 4): every column's origin on the guide and its unit normal (cx, cy, nx,
    ny; a straight guide has (j·dx, 0, 0, 1));
    ``memo``: the reachability memo (see :func:`new_memo`); ``table`` (D + 1, ny, nz): node
    clearances over the grid, −1 outside the bounds; ``table_off`` (2,) int64: grid index of
    ``table[:, 0, 0]`` in (y, z); ``steps`` (3,): column spacing dx and the grid's dy, dz (m);
    ``start_m`` / ``goal_m`` (3,): the fixed ends in the path frame (m); ``margin``: metres to
    keep; ``counts`` (2,) int64, incremented by the kernels: reachability checks made and
    exact segment tests among them (the evaluation budget of the rule).
    """

    world: KernelWorld
    cols: np.ndarray
    memo: np.ndarray
    table: np.ndarray
    table_off: np.ndarray
    steps: np.ndarray
    start_m: np.ndarray
    goal_m: np.ndarray
    margin: float
    counts: np.ndarray

    def __post_init__(self) -> None:
        kernel_fields(self, "reach")


def _round(v: float) -> float:
    """Round half up to the grid, clamped so wild proposals (huge steps) stay finite."""
    if not v < 1e6:  # also catches NaN
        v = 1e6
    elif v < -1e6:
        v = -1e6
    return float(math.floor(v + 0.5))


#: memo table for node reachability (open addressing, linear probing): 2^MEMO_BITS slots
MEMO_BITS: int = _c.MEMO_BITS
#: probes per lookup; a full neighbourhood means no memo entry (the exact test runs)
MEMO_PROBES: int = _c.MEMO_PROBES


def new_memo() -> np.ndarray:
    """An empty reachability memo. Reachability of a node is a pure function of (column,
    previous node, node) for a fixed world, so it is computed once per run. Entries pack
    ``key·2 + free`` into one int64, so a reader on another thread sees either nothing or a
    whole entry. A key is at least 2⁴⁸ (its column is >= 1), so 0 marks an empty slot: the
    table is ``np.zeros``, whose pages the OS maps on first touch, instead of 16 MB written
    before the search starts."""
    return np.zeros(1 << MEMO_BITS, dtype=np.int64)


def node_x(j: int, y: float, cols: np.ndarray, dy: float) -> float:
    """x (path frame, m) of column ``j``'s node at lateral offset ``y`` (grid units):
    ``cols[j] = (cx, cy, nx, ny)``, the column's origin on the guide and its unit normal."""
    return float(cols[j, 0] + y * dy * cols[j, 2])


def node_y(j: int, y: float, cols: np.ndarray, dy: float) -> float:
    """y (path frame, m) of column ``j``'s node at lateral offset ``y`` (grid units)."""
    return float(cols[j, 1] + y * dy * cols[j, 3])


#: clearance is tabulated exactly up to this far beyond the margin (metres)
TABLE_REACH_M = 60.0


def _f64(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def clearance_table(
    cols: np.ndarray,
    ylim: np.ndarray,
    iy_lo: int,
    iy_hi: int,
    iz_lo: int,
    iz_hi: int,
    dy: float,
    dz: float,
    world: KernelWorld,
    cap: float,
    exact_m: float | None = None,
) -> np.ndarray:
    """Distance from every grid node (column, y, z) to the nearest piece, capped at ``cap``;
    −1 for nodes outside the bounds or outside their column's lateral window ``ylim[j]``
    (grid units; where columns of a curved guide would fold over each other). Shape
    (D + 1, iy_hi − iy_lo + 1, iz_hi − iz_lo + 1). A piece only visits the nodes of the
    columns whose lateral line passes within ``cap`` of its bounding box. With ``exact_m``,
    the terrain's distances at or above it may be lower bounds (never above the distance):
    exact where the reachability rule's node test needs them, cheap elsewhere."""
    cols = _f64(cols)
    tab = np.full((cols.shape[0], iy_hi - iy_lo + 1, iz_hi - iz_lo + 1), float(cap))
    exact = math.inf if exact_m is None else float(exact_m)
    _c.clearance_table(
        cols, _f64(ylim), int(iy_lo), int(iy_hi), int(iz_lo), int(iz_hi), float(dy), float(dz),
        world, float(cap), tab, exact,
    )  # fmt: skip
    return tab


def node_status(
    j: int,
    y0: float,
    z0: float,
    y1: float,
    z1: float,
    cols: np.ndarray,
    dy: float,
    dz: float,
    lim: float,
    tab: np.ndarray,
    off: np.ndarray,
    keys: np.ndarray,
) -> int:
    """Reachability of the node of column ``j`` (1-based) at (y1, z1) from the node before it
    at (y0, z0), both in grid units, from the cheap sources only: 1 free, 0 blocked, −1
    unknown (then :func:`node_resolve` decides). ``lim`` is the margin (see
    :func:`margin_limit`).

    Interior columns: a node closer than the margin (or outside the bounds) is unreachable;
    the segment between nodes with clearances d0, d1 keeps the margin when
    (d0 + d1 − length)/2 >= margin (distance is 1-Lipschitz). Otherwise the memo answers if
    this segment was resolved before.
    """
    return _c.node_status(
        int(j), float(y0), float(z0), float(y1), float(z1), cols, float(dy), float(dz),
        float(lim), tab, off, keys,
    )  # fmt: skip


def node_resolve(
    j: int,
    y0: float,
    z0: float,
    y1: float,
    z1: float,
    cols: np.ndarray,
    dy: float,
    dz: float,
    start_m: np.ndarray,
    goal_m: np.ndarray,
    world: KernelWorld,
    margin: float,
    keys: np.ndarray,
) -> int:
    """The exact reachability test behind :func:`node_status`, memoised."""
    return _c.node_resolve(
        int(j), float(y0), float(z0), float(y1), float(z1), cols, float(dy), float(dz), start_m,
        goal_m, world, float(margin), keys,
    )  # fmt: skip


def margin_limit(margin: float) -> float:
    """The clearance a node must have: the margin (less a nanometre for rounding); a zero
    margin still means not touching."""
    lim = margin - 1e-9
    return lim if lim >= 1e-9 else 1e-9


def node_free(j: int, y0: float, z0: float, y1: float, z1: float, reach: Reach) -> bool:
    """Is the node of column ``j`` at (y1, z1) reachable from (y0, z0)? (Off the hot path;
    not counted in ``reach.counts``.)"""
    return (_c.reachable(int(j), float(y0), float(z0), float(y1), float(z1), reach) & 1) == 1


def init_population(
    n_pop: int,
    n_inner: int,
    start_u: np.ndarray,
    goal_u: np.ndarray,
    half_window: float,
    t_max: int,
    max_attempts: int,
    window: np.ndarray,
    reach: Reach,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray, int]:
    """Path initialisation of section 4.1 (eq. 8–10) for ``n_pop`` individuals.

    From the current node P_a the next is round(P_t + U(−Δh, Δh)) per axis with
    P_t = P_a + (P_goal − P_a)/m, m the columns left; an unreachable node is reselected up to
    ``t_max`` times, after which the individual is deadlocked and started again (at most
    ``max_attempts`` starts per individual). Returns (nodes, ok, deadlocks).

    The window fits the flight volume: where [P_t − Δh, P_t + Δh] leaves a column's valid
    range ``window[j]`` = (y_lo, y_hi, z_lo, z_hi) (grid units), the draw is uniform over
    the part of the window inside that range, so a shallow volume or a long route does not
    send every draw outside the bounds; inside the range the draw is the paper's. The
    uniform draws come from ``rng``'s bit generator (``Generator.random``'s stream).
    """
    nodes = np.zeros((n_pop, n_inner, 2))
    ok = np.zeros(n_pop, dtype=np.bool_)
    # numpy's stubs before 2.0 do not declare BitGenerator.capsule (it is there since 1.17)
    bitgen: Any = rng.bit_generator
    with bitgen.lock:
        deadlocks = _c.init_population(
            int(n_pop), int(n_inner), _f64(start_u), _f64(goal_u), float(half_window),
            int(t_max), int(max_attempts), _f64(window), reach, bitgen.capsule, nodes, ok,
        )  # fmt: skip
    return nodes, ok, deadlocks


def _ziggurat_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tables of Marsaglia & Tsang's ziggurat (2000) for the standard normal, 128 layers (the
    C kernels compute the same tables; kept here as their reference)."""
    m1 = 2147483648.0
    dn = 3.442619855899
    tn = dn
    vn = 9.91256303526217e-3
    kn = np.zeros(128)
    wn = np.zeros(128)
    fn = np.zeros(128)
    q = vn / math.exp(-0.5 * dn * dn)
    kn[0] = (dn / q) * m1
    kn[1] = 0.0
    wn[0] = q / m1
    wn[127] = dn / m1
    fn[0] = 1.0
    fn[127] = math.exp(-0.5 * dn * dn)
    for i in range(126, 0, -1):
        dn = math.sqrt(-2.0 * math.log(vn / dn + math.exp(-0.5 * dn * dn)))
        kn[i + 1] = (dn / tn) * m1
        tn = dn
        fn[i] = math.exp(-0.5 * dn * dn)
        wn[i] = dn / m1
    return kn, wn, fn


def sign_draws(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """±1.0 of ``shape`` drawn from ``rng``: the same numbers, in the same order, as
    ``2.0 * rng.integers(0, 2, size=shape) - 1.0`` (tests/planners/test_spsa_step.py holds the two
    together), without numpy's per-element overhead."""
    out = np.empty(shape)
    # numpy's stubs before 2.0 do not declare BitGenerator.capsule (it is there since 1.17)
    bitgen: Any = rng.bit_generator
    with bitgen.lock:
        _c.sign_draws(bitgen.capsule, out)
    return out


def stream_seeds(rng: np.random.Generator, n: int) -> np.ndarray:
    """One seed per individual for the kernels' random streams, drawn from ``rng``.

    Per-individual random streams: each individual gets its own splitmix64 stream seeded from
    the caller's numpy Generator, so individuals are independent of each other and of the
    order they are processed in. Normal draws use Marsaglia & Tsang's ziggurat (one 64-bit
    draw on the fast path)."""
    return np.asarray(rng.bit_generator.random_raw(n), dtype=np.uint64)


def rebuild(
    base: np.ndarray,
    active: np.ndarray,
    anchor: np.ndarray,
    offset: np.ndarray,
    spread: np.ndarray,
    draw: np.ndarray,
    spread2: np.ndarray,
    draw2: np.ndarray,
    clamp: np.ndarray,
    first: np.ndarray,
    use_first: np.ndarray,
    explicit: np.ndarray,
    n_explicit: np.ndarray,
    escape: np.ndarray,
    t_max: int,
    v_min: int,
    v_max: int,
    reach: Reach,
    seeds: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, int]:
    """Propose new nodes for every active individual, node by node from start to goal, under
    the reachability rule (the generic step of every planner; see ``Proposal`` for the
    meaning of the arrays).

    Attempt ``t`` (0 ≤ t < ``t_max``) at node j, axis a of individual g proposes
    ``explicit[t, g, j, a]`` when t < ``n_explicit[g]``; else ``first[g, j, a]`` when t = 0 and
    ``use_first[g]``; else ``anchor + clip(offset + spread·X + spread2·Y, ±clamp[a])`` with X, Y
    fresh draws of kinds ``draw[g]``, ``draw2[g]`` (y axis first). The value is rounded to the
    grid; the first reachable attempt is taken. After ``t_max`` failures an individual with
    ``escape[g]`` tries the adaptive variable-speed escape (eq. 12, Algorithm 2):
    P + (2·rand − 1)·V around the old node for V = ``v_min..v_max``, ``t_max`` tries per speed.
    If nothing is reachable the old node is kept when it is reachable from the new previous
    node; otherwise the individual's update fails (``ok[g] = False``) and it keeps its old
    path. ``seeds`` (G,) uint64: each individual's random stream (see :func:`stream_seeds`).
    Returns (new positions, ok, escapes used).
    """
    base = _f64(base)
    out = np.empty_like(base)
    ok = np.ones(base.shape[0], dtype=np.bool_)
    b = np.ascontiguousarray
    esc = _c.rebuild(
        base, b(active, np.bool_), _f64(anchor), _f64(offset), _f64(spread), b(draw, np.int64),
        _f64(spread2), b(draw2, np.int64), _f64(clamp), _f64(first), b(use_first, np.bool_),
        _f64(explicit), b(n_explicit, np.int64), b(escape, np.bool_), int(t_max), int(v_min),
        int(v_max), reach, b(seeds, np.uint64), out, ok,
    )  # fmt: skip
    return out, ok, esc


def moving_average_repair(
    nodes: np.ndarray, goal_u: np.ndarray, window: int, reach: Reach, skip: np.ndarray
) -> np.ndarray:
    """Replace every node by the rounded mean of a window of its path, under the
    reachability rule, in place (SPSA's adaptive oscillation optimisation, section 4.4,
    eq. 13); individuals with ``skip[g]`` are left alone (callers skip known fixed points).

    Node j becomes round(mean(P_{j−1}, P_j, …, P_{j+N_p−2})) with N_p = ``window``, the
    previous node already replaced; when that node is unreachable N_p drops by one, and
    below 3 the node is kept. Windows are cut at the goal. An individual whose kept node
    became unreachable is left as it was. Returns the nodes moved per individual (G,).
    """
    work = nodes
    if not (
        isinstance(nodes, np.ndarray)
        and nodes.dtype == np.float64
        and nodes.flags.c_contiguous
        and nodes.flags.writeable
    ):
        work = np.array(nodes, dtype=np.float64)
    moved = np.zeros(work.shape[0], dtype=np.int64)
    _c.moving_average_repair(
        work, _f64(goal_u), int(window), reach, np.ascontiguousarray(skip, np.bool_), moved
    )
    if work is not nodes:
        nodes[...] = work
    return moved


def paths_feasible(nodes: np.ndarray, reach: Reach) -> np.ndarray:
    """(G,) bool: every segment of every individual reachable (start → nodes → goal)."""
    nodes = _f64(nodes)
    out = np.ones(nodes.shape[0], dtype=np.bool_)
    _c.paths_feasible(nodes, reach, out)
    return out


#: switches of :func:`spsa_step` (``StepSetup.flags``)
#: contribution 2: producers pulled toward the start-end line (eq. 11)
SPSA_START_END: int = _c.SPSA_START_END
#: eq. 11 read literally (else the deviation reading)
SPSA_LITERAL: int = _c.SPSA_LITERAL
#: eq. 4's i ranked in the whole population (else among the scroungers)
SPSA_POP_INDEX: int = _c.SPSA_POP_INDEX
#: contribution 3: the adaptive variable-speed escape (eq. 12)
SPSA_ESCAPE: int = _c.SPSA_ESCAPE
#: contribution 4: the adaptive oscillation optimisation (eq. 13)
SPSA_OSCILLATE: int = _c.SPSA_OSCILLATE
#: ε of eq. 5 (the danger-aware best sparrow's denominator), as in Xue & Shen's code
SPSA_EPS: float = _c.SPSA_EPS


#: what an energy cache may hold (bytes of stored paths) and its largest number of slots
ENERGY_CACHE_BYTES = 2 << 20
ENERGY_CACHE_SLOTS = 1024


@dataclass(frozen=True, slots=True, eq=False)
class EnergyCache:
    """A fitness cache (:func:`new_energy_cache`): ``filled`` (slots,) bool, ``values``
    (slots,) float64, ``paths`` (slots, 2n) int32; the kernels write all three."""

    filled: np.ndarray
    values: np.ndarray
    paths: np.ndarray

    def __post_init__(self) -> None:
        kernel_fields(self, "cache")


def new_energy_cache(n_inner: int, slots: int | None = None) -> EnergyCache:
    """An empty fitness cache for paths of ``n_inner`` nodes (see :func:`spsa_step`): a power
    of two of slots, at most :data:`ENERGY_CACHE_SLOTS` and :data:`ENERGY_CACHE_BYTES` of
    stored paths (``slots=0``: no cache). The fitness of a path is a pure function of the path
    for one problem, so a recalled value is the value a recomputation gives; a cache belongs
    to one problem."""
    m = 2 * max(n_inner, 1)
    if slots is None:
        fit = max(1, ENERGY_CACHE_BYTES // (4 * m))
        slots = min(ENERGY_CACHE_SLOTS, 1 << (fit.bit_length() - 1))
    if slots < 0 or slots & (slots - 1):
        raise ValueError(f"energy cache: {slots} slots, not a power of two")
    return EnergyCache(
        np.zeros(slots, dtype=np.bool_),
        np.zeros(slots, dtype=np.float64),
        np.zeros((slots, m), dtype=np.int32),
    )


@dataclass(frozen=True, slots=True, eq=False)
class StepSetup:
    """What every fused SPSA step of one search shares (built once per search; see
    :meth:`uavplan.planners.sparrow.SparrowPlanner.step`).

    ``reach``: the reachability rule; ``energy``: :attr:`PathProblem.energy_args`; ``line``
    (n, 2): the start-end line P_ST at the inner columns; ``goal_u`` (2,): the goal in grid
    units; ``n_prod``: producers; ``iterations``: the search's M (eq. 11's e = exp(−i/(α·M)));
    ``t_max``: attempts per node; ``v_min``, ``v_max``: eq. 12's escape speeds; ``window``:
    eq. 13's N_p; ``flags``: the ``SPSA_*`` switches; ``warning_value``: ST; ``cache``: a
    fitness cache (:func:`new_energy_cache`) or None; ``threads``: threads to share the
    step's per-individual work (see :func:`step_threads`)."""

    reach: Reach
    energy: EnergyArgs
    line: np.ndarray
    goal_u: np.ndarray
    n_prod: int
    iterations: int
    t_max: int
    v_min: int
    v_max: int
    window: int
    flags: int
    warning_value: float
    cache: EnergyCache | None
    threads: int

    def __post_init__(self) -> None:
        kernel_fields(self, "setup")


class StepDraws(NamedTuple):
    """The random numbers of one fused SPSA step, drawn from the search's Generator (see
    :meth:`uavplan.planners.sparrow.SparrowPlanner.step`): ``warn`` R2; ``pdraw`` (n_prod,)
    float64, α = 1 − U when R2 < ST, else Q ~ N(0, 1); ``signs`` (near, n, 2) float64,
    eq. 4's ±1; ``aware`` int64, the danger-aware sparrows; ``seeds1``, ``seeds2`` (G,)
    uint64, the two rebuilds' random streams (:func:`stream_seeds`). Built for every step,
    so a plain record: the kernel reads its fields by name and checks every array's dtype
    and shape itself (TypeError / ValueError)."""

    warn: float
    pdraw: np.ndarray
    signs: np.ndarray
    aware: np.ndarray
    seeds1: np.ndarray
    seeds2: np.ndarray


def spsa_step(
    x: np.ndarray,
    f: np.ndarray,
    osc_fixed: np.ndarray,
    counts: np.ndarray,
    setup: StepSetup,
    draws: StepDraws,
) -> None:
    """One SPSA / SSA iteration in place on ``x`` (G, n, 2), ``f`` (G,) and ``osc_fixed``
    (G,) (see :meth:`uavplan.planners.sparrow.SparrowPlanner.step`), with what the search's
    steps share in ``setup`` and this step's random numbers in ``draws``. ``counts`` (3,)
    int64 gets += (fitness evaluations, escapes, failed updates): a fitness recalled from
    ``setup.cache`` counts as an evaluation, so evaluation budgets mean the same with and
    without it.

    ``setup.threads``: the step's per-individual work (rebuilds, oscillation, fitness) is
    shared among this many threads (see :func:`step_threads`); every result is the same on
    any number, except the count of exact segment tests in ``reach.counts`` (threads share
    the reachability memo, and a lost race repeats a test)."""
    _c.spsa_step(x, f, osc_fixed, counts, setup, draws)


#: the most threads :func:`step_threads` picks on its own, and the kernels' limit
STEP_THREADS_AUTO_MAX = _geom.THREADS_AUTO_MAX
STEP_THREADS_MAX: int = _geom.THREADS_MAX
#: whether this build of the kernels has helper threads (POSIX threads and gcc's / clang's
#: atomics); without them the step runs on its caller's thread alone and says so
#: (:func:`step_threads` is then 1, and the planner, ``bench`` and ``bench_core`` report it)
HAVE_THREADS: bool = _geom.HAVE_THREADS


def step_threads() -> int:
    """Threads for the fused SPSA step (:func:`uavplan._geom.kernel_threads`):
    ``UAVPLAN_THREADS`` when it is set to a whole number (1 turns threading off; at most
    :data:`STEP_THREADS_MAX`), else the CPUs this process may run on, at most
    :data:`STEP_THREADS_AUTO_MAX`. Always 1 on a build without threads (:data:`HAVE_THREADS`)."""
    if not HAVE_THREADS:
        return 1
    return _geom.kernel_threads()


def step_threads_note() -> str:
    """One line for a report: the threads the fused SPSA step runs on by default
    (:func:`step_threads`), and why it is one on a build without helper threads."""
    if not HAVE_THREADS:
        return "SPSA step threads: 1 (this build of uavplan's kernels has no helper threads)"
    return f"SPSA step threads: {step_threads()}"
