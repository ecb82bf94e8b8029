"""Compiled kernels shared by every planner: the reachability rule, the initialisation, the
generic proposal-and-repair step, the moving-average repair (eq. 13) and feasibility checks.

Encoding (PAPER-NOTES "Path model"): an individual is ``nodes[j] = (y, z)`` in grid units
for the inner columns ``j = 1..D−1`` (array index ``j − 1``); start and goal are fixed.
A node is *reachable* when the straight segment from the previous node to it is inside the
bounds and keeps the margin from every obstacle (for the last node, also the segment to the
goal). Every planner proposes nodes through one :class:`~uavplan.planners.proposal.Proposal`
(its own update rule, computed in its own module) and :func:`rebuild` repairs them the same
way for all, so differences between algorithms come from their update rules alone.

Everything the reachability rule reads travels in one :class:`Reach` value (named fields,
no positional slots). Randomness comes only from seeds drawn from the caller's
``numpy.random.Generator``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from uavplan._geom import point_piece_dist, segment_free, vertical_gap

#: how a proposal draws its random term for every attempt (``Proposal.draw``)
DRAW_NONE = 0  # no random term
DRAW_UNIFORM = 1  # U[0, 1)
DRAW_SYMMETRIC = 2  # U[−1, 1): 2·U − 1
DRAW_NORMAL = 3  # N(0, 1)


class Reach(NamedTuple):
    """Everything the reachability rule of one path problem reads (built by PathProblem).

    ``world``: the world tuple of :mod:`uavplan._geom` (``World.kernel_args``, path frame);
    ``cols`` (D + 1, 4): every column's origin on the guide and its unit normal (cx, cy, nx,
    ny; a straight guide has (j·dx, 0, 0, 1));
    ``memo``: the reachability memo (see :func:`new_memo`); ``table`` (D + 1, ny, nz): node
    clearances over the grid, −1 outside the bounds; ``table_off`` (2,) int64: grid index of
    ``table[:, 0, 0]`` in (y, z); ``steps`` (3,): column spacing dx and the grid's dy, dz (m);
    ``start_m`` / ``goal_m`` (3,): the fixed ends in the path frame (m); ``margin``: metres to
    keep; ``counts`` (2,) int64, incremented by the kernels: reachability checks made and
    exact segment tests among them (the evaluation budget of the rule).
    """

    world: tuple
    cols: np.ndarray
    memo: np.ndarray
    table: np.ndarray
    table_off: np.ndarray
    steps: np.ndarray
    start_m: np.ndarray
    goal_m: np.ndarray
    margin: float
    counts: np.ndarray


@njit(cache=True, inline="always")
def _round(v):
    """Round half up to the grid, clamped so wild proposals (huge steps) stay finite."""
    if not v < 1e6:  # also catches NaN
        v = 1e6
    elif v < -1e6:
        v = -1e6
    return math.floor(v + 0.5)


#: memo table for node reachability (open addressing, linear probing)
MEMO_BITS = 21
#: probes per lookup; a full neighbourhood means no memo entry (the exact test runs)
MEMO_PROBES = 16
_EMPTY = -1
_MIX1 = np.int64(-4658895280553007687)  # splitmix64 finaliser constants as int64
_MIX2 = np.int64(-7723592293110705685)


def new_memo() -> np.ndarray:
    """An empty reachability memo. Reachability of a node is a pure function of (column,
    previous node, node) for a fixed world, so it is computed once per run. Entries pack
    ``key·2 + free`` into one int64, so a reader on another thread sees either nothing or a
    whole entry."""
    return np.full(1 << MEMO_BITS, _EMPTY, dtype=np.int64)


@njit(cache=True, inline="always")
def _memo_key(j, y0, z0, y1, z1):
    """Pack (column, y0, z0, y1, z1) into 60 bits; −1 when a value does not fit. The first
    column's segment starts at the fixed start, so its previous node is not part of the key."""
    if j == 1:
        y0 = 0.0
        z0 = 0.0
    a = int(y0) + 2048
    b = int(z0) + 2048
    c = int(y1) + 2048
    d = int(z1) + 2048
    if j < 0 or j >= 4096 or a < 0 or a >= 4096 or b < 0 or b >= 4096:
        return -1
    if c < 0 or c >= 4096 or d < 0 or d >= 4096:
        return -1
    return (((((j << 12) | a) << 12 | b) << 12 | c) << 12) | d


@njit(cache=True, inline="always")
def _memo_slot(keys, key):
    """Index of ``key``'s entry, or of the empty slot where it would go; −1 when the probe
    neighbourhood is full. The one probe loop of the memo (lookups and inserts)."""
    mask = keys.shape[0] - 1
    h = key ^ (key >> 30)
    h = (h * _MIX1) ^ ((h * _MIX1) >> 27)
    h = (h * _MIX2) ^ ((h * _MIX2) >> 31)
    h &= mask
    for _probe in range(MEMO_PROBES):
        k = keys[h]
        if k == _EMPTY or (k >> 1) == key:
            return h
        h = (h + 1) & mask
    return -1


@njit(cache=True, inline="always")
def node_x(j, y, cols, dy):
    """x (path frame, m) of column ``j``'s node at lateral offset ``y`` (grid units):
    ``cols[j] = (cx, cy, nx, ny)``, the column's origin on the guide and its unit normal."""
    return cols[j, 0] + y * dy * cols[j, 2]


@njit(cache=True, inline="always")
def node_y(j, y, cols, dy):
    """y (path frame, m) of column ``j``'s node at lateral offset ``y`` (grid units)."""
    return cols[j, 1] + y * dy * cols[j, 3]


@njit(cache=True)
def _segment_to_node_free(j, y0, z0, y1, z1, cols, dy, dz, start_m, goal_m, world, margin):
    if j == 1:
        ax = start_m[0]
        ay = start_m[1]
        az = start_m[2]
    else:
        ax = node_x(j - 1, y0, cols, dy)
        ay = node_y(j - 1, y0, cols, dy)
        az = z0 * dz
    bx = node_x(j, y1, cols, dy)
    by = node_y(j, y1, cols, dy)
    bz = z1 * dz
    if not segment_free(ax, ay, az, bx, by, bz, world, margin):
        return False
    if j == cols.shape[0] - 2:
        return segment_free(bx, by, bz, goal_m[0], goal_m[1], goal_m[2], world, margin)
    return True


#: clearance is tabulated exactly up to this far beyond the margin (metres)
TABLE_REACH_M = 60.0


@njit(cache=True)
def clearance_table(cols, ylim, iy_lo, iy_hi, iz_lo, iz_hi, dy, dz, world, cap):
    """Distance from every grid node (column, y, z) to the nearest piece, capped at ``cap``;
    −1 for nodes outside the bounds or outside their column's lateral window ``ylim[j]``
    (grid units; where columns of a curved guide would fold over each other). Shape
    (D + 1, iy_hi − iy_lo + 1, iz_hi − iz_lo + 1). A piece only visits the nodes of the
    columns whose lateral line passes within ``cap`` of its bounding box."""
    poly_xy, poly_n, poly_h, circ, box, hp, zlim = world[:7]
    n_cols = cols.shape[0] - 1
    ny = iy_hi - iy_lo + 1
    nz = iz_hi - iz_lo + 1
    tab = np.full((n_cols + 1, ny, nz), cap)
    t_lo = iy_lo * dy
    t_hi = iy_hi * dy
    for j in range(n_cols + 1):
        cx, cy, nxx, nyy = cols[j, 0], cols[j, 1], cols[j, 2], cols[j, 3]
        # the column's lateral line c + t·n, t in [t_lo, t_hi]: its bounding box
        x_a = cx + t_lo * nxx
        x_b = cx + t_hi * nxx
        y_a = cy + t_lo * nyy
        y_b = cy + t_hi * nyy
        for k in range(box.shape[0]):
            x0 = box[k, 0] - cap
            x1 = box[k, 1] + cap
            y0 = box[k, 2] - cap
            y1 = box[k, 3] + cap
            if max(x_a, x_b) < x0 or min(x_a, x_b) > x1 or max(y_a, y_b) < y0 or min(y_a, y_b) > y1:
                continue
            # slab test: the t-interval of the line inside the grown box
            lo = t_lo
            hi = t_hi
            if abs(nxx) < 1e-12:
                if cx < x0 or cx > x1:
                    continue
            else:
                ta = (x0 - cx) / nxx
                tb = (x1 - cx) / nxx
                lo = max(lo, min(ta, tb))
                hi = min(hi, max(ta, tb))
            if abs(nyy) < 1e-12:
                if cy < y0 or cy > y1:
                    continue
            else:
                ta = (y0 - cy) / nyy
                tb = (y1 - cy) / nyy
                lo = max(lo, min(ta, tb))
                hi = min(hi, max(ta, tb))
            if lo > hi:
                continue
            a0 = max(0, int(math.floor(lo / dy)) - iy_lo)
            a1 = min(ny - 1, int(math.ceil(hi / dy)) - iy_lo)
            h = poly_h[k] if k < poly_n.shape[0] else circ[k - poly_n.shape[0], 3]
            if h < 0.0:  # a ceiling piece from −h up: nodes from −h − cap
                c0 = max(0, int(math.floor((-h - cap) / dz)) - iz_lo)
                c1 = nz - 1
                z_on = -h
            else:
                c0 = 0
                c1 = min(nz - 1, int(math.ceil((h + cap) / dz)) - iz_lo)
                z_on = h
            for a in range(a0, a1 + 1):
                px = node_x(j, a + iy_lo, cols, dy)
                py = node_y(j, a + iy_lo, cols, dy)
                # the horizontal distance is the same at every height: one 2-D test per node
                # column, then sqrt(dh² + dz²) (what point_piece_dist computes) per height
                dh = point_piece_dist(px, py, z_on, k, poly_xy, poly_n, poly_h, circ)
                if dh >= cap:
                    continue
                for c in range(c0, c1 + 1):
                    vz = vertical_gap((c + iz_lo) * dz, h)
                    d = math.sqrt(dh * dh + vz * vz)
                    if d < tab[j, a, c]:
                        tab[j, a, c] = d
    eps = 1e-9
    for j in range(n_cols + 1):
        for a in range(ny):
            yu = a + iy_lo
            px = node_x(j, yu, cols, dy)
            py = node_y(j, yu, cols, dy)
            lateral_ok = ylim[j, 0] - eps <= yu <= ylim[j, 1] + eps
            for c in range(nz):
                z = (c + iz_lo) * dz
                inside = lateral_ok and zlim[0] - eps <= z <= zlim[1] + eps
                for i in range(hp.shape[0]):
                    if hp[i, 0] * px + hp[i, 1] * py > hp[i, 2] + eps:
                        inside = False
                if not inside:
                    tab[j, a, c] = -1.0
    return tab


@njit(cache=True, inline="always")
def node_status(j, y0, z0, y1, z1, cols, dy, dz, lim, tab, off, keys):
    """Reachability of the node of column ``j`` (1-based) at (y1, z1) from the node before it
    at (y0, z0), both in grid units, from the cheap sources only: 1 free, 0 blocked, −1
    unknown (then :func:`node_resolve` decides). ``lim`` is the margin (see
    :func:`margin_limit`).

    Interior columns: a node closer than the margin (or outside the bounds) is unreachable;
    the segment between nodes with clearances d0, d1 keeps the margin when
    (d0 + d1 − length)/2 >= margin (distance is 1-Lipschitz). Otherwise the memo answers if
    this segment was resolved before.

    The hot kernels pass the table, offsets and memo as separate arrays and call this
    inline; handing numba the whole world tuple per call costs more than the test itself.
    """
    ny = tab.shape[1]
    nz = tab.shape[2]
    c = int(y1) - off[0]
    d = int(z1) - off[1]
    if c < 0 or c >= ny or d < 0 or d >= nz:
        return 0  # outside the bounds' bounding box
    d1 = tab[j, c, d]
    if d1 < lim:
        return 0  # too close, outside the bounds or outside the column's window
    if 1 < j < tab.shape[0] - 2:
        a = int(y0) - off[0]
        b = int(z0) - off[1]
        if a < 0 or a >= ny or b < 0 or b >= nz:
            return 0
        d0 = tab[j - 1, a, b]
        if d0 < lim:
            return 0
        ex = (cols[j, 0] + y1 * dy * cols[j, 2]) - (cols[j - 1, 0] + y0 * dy * cols[j - 1, 2])
        ey = (cols[j, 1] + y1 * dy * cols[j, 3]) - (cols[j - 1, 1] + y0 * dy * cols[j - 1, 3])
        ez = (z1 - z0) * dz
        length = math.sqrt(ex * ex + ey * ey + ez * ez)
        if d0 + d1 - length >= 2.0 * lim:
            return 1
    key = _memo_key(j, y0, z0, y1, z1)
    if key < 0:
        return -1
    slot = _memo_slot(keys, key)
    if slot < 0 or keys[slot] == _EMPTY:
        return -1
    return keys[slot] & 1


@njit(cache=True)
def node_resolve(j, y0, z0, y1, z1, cols, dy, dz, start_m, goal_m, world, margin, keys):
    """The exact reachability test behind :func:`node_status`, memoised."""
    free = _segment_to_node_free(j, y0, z0, y1, z1, cols, dy, dz, start_m, goal_m, world, margin)
    key = _memo_key(j, y0, z0, y1, z1)
    if key >= 0:
        slot = _memo_slot(keys, key)
        if slot >= 0:
            keys[slot] = 2 * key + (1 if free else 0)
    return 1 if free else 0


@njit(cache=True, inline="always")
def margin_limit(margin):
    """The clearance a node must have: the margin (less a nanometre for rounding); a zero
    margin still means not touching."""
    lim = margin - 1e-9
    return lim if lim >= 1e-9 else 1e-9


@njit(cache=True, inline="always")
def _reachable(
    j, y0, z0, y1, z1, cols, dy, dz, lim, tab, off, keys, start_m, goal_m, world, margin
):
    """:func:`node_status`, then :func:`node_resolve` when the cheap sources cannot tell.
    Returns 1 (reachable) or 0, plus 2 when the exact test ran. Callers count checks in local
    scalars and store them once: a store into an array inside the hot loop would make the
    compiler assume every other array may have changed (it doubled the kernels' run time)."""
    r = node_status(j, y0, z0, y1, z1, cols, dy, dz, lim, tab, off, keys)
    if r < 0:
        r = 2 + node_resolve(j, y0, z0, y1, z1, cols, dy, dz, start_m, goal_m, world, margin, keys)
    return r


@njit(cache=True)
def node_free(j, y0, z0, y1, z1, reach):
    """Is the node of column ``j`` at (y1, z1) reachable from (y0, z0)? (Off the hot path.)"""
    cols, dy, dz = reach.cols, reach.steps[1], reach.steps[2]
    return (
        _reachable(
            j,
            y0,
            z0,
            y1,
            z1,
            cols,
            dy,
            dz,
            margin_limit(reach.margin),
            reach.table,
            reach.table_off,
            reach.memo,
            reach.start_m,
            reach.goal_m,
            reach.world,
            reach.margin,
            reach.counts,
        )
        & 1
    ) == 1


@njit(cache=True, inline="always")
def _window_draw(t, h, lo, hi, rng):
    """t + U(−h, h) (eq. 9), the window cut to the valid range [lo, hi]; a window entirely
    outside the range is moved to its nearest edge (the walk drifted out of the volume)."""
    u = rng.random()
    if t - h >= lo and t + h <= hi:
        return t + (2.0 * u - 1.0) * h
    a = max(t - h, lo)
    b = min(t + h, hi)
    if a > b:  # no overlap: the part of the range nearest the window, as wide as it allows
        if t + h < lo:
            a = lo
            b = min(hi, lo + h)
        else:
            b = hi
            a = max(lo, hi - h)
    return a + u * (b - a)


@njit(cache=True)
def init_population(
    n_pop, n_inner, start_u, goal_u, half_window, t_max, max_attempts, window, reach, rng
):
    """Path initialisation of section 4.1 (eq. 8–10) for ``n_pop`` individuals.

    From the current node P_a the next is round(P_t + U(−Δh, Δh)) per axis with
    P_t = P_a + (P_goal − P_a)/m, m the columns left; an unreachable node is reselected up to
    ``t_max`` times, after which the individual is deadlocked and started again (at most
    ``max_attempts`` starts per individual). Returns (nodes, ok, deadlocks).

    The window fits the flight volume: where [P_t − Δh, P_t + Δh] leaves a column's valid
    range ``window[j]`` = (y_lo, y_hi, z_lo, z_hi) (grid units), the draw is uniform over
    the part of the window inside that range, so a shallow volume or a long route does not
    send every draw outside the bounds; inside the range the draw is the paper's.
    """
    cols, dy, dz = reach.cols, reach.steps[1], reach.steps[2]
    tab, off, keys, lim = reach.table, reach.table_off, reach.memo, margin_limit(reach.margin)
    world, margin, counts = reach.world, reach.margin, reach.counts
    n_chk = 0
    n_exact = 0
    start_m, goal_m = reach.start_m, reach.goal_m
    nodes = np.zeros((n_pop, n_inner, 2))
    ok = np.zeros(n_pop, dtype=np.bool_)
    deadlocks = 0
    for g in range(n_pop):
        for _attempt in range(max_attempts):
            py = start_u[0]
            pz = start_u[1]
            alive = True
            for j in range(1, n_inner + 1):
                m = n_inner + 1 - (j - 1)
                ty = py + (goal_u[0] - py) / m
                tz = pz + (goal_u[1] - pz) / m
                placed = False
                for _t in range(t_max):
                    ny = _round(_window_draw(ty, half_window, window[j, 0], window[j, 1], rng))
                    nz = _round(_window_draw(tz, half_window, window[j, 2], window[j, 3], rng))
                    code = node_status(j, py, pz, ny, nz, cols, dy, dz, lim, tab, off, keys)
                    if code < 0:
                        code = 2 + node_resolve(
                            j, py, pz, ny, nz, cols, dy, dz, start_m, goal_m, world, margin, keys
                        )
                    n_chk += 1
                    n_exact += code >> 1
                    if code & 1:
                        placed = True
                        break
                if not placed:
                    alive = False
                    break
                nodes[g, j - 1, 0] = ny
                nodes[g, j - 1, 1] = nz
                py = ny
                pz = nz
            if alive:
                ok[g] = True
                break
            deadlocks += 1
    counts[0] += n_chk
    counts[1] += n_exact
    return nodes, ok, deadlocks


# Per-individual random streams: each individual gets its own splitmix64 stream seeded from
# the caller's numpy Generator, so individuals are independent of each other and of the order
# they are processed in (the kernels could run them on several threads unchanged).
_SM_GAMMA = np.uint64(0x9E3779B97F4A7C15)
_SM_M1 = np.uint64(0xBF58476D1CE4E5B9)
_SM_M2 = np.uint64(0x94D049BB133111EB)


@njit(cache=True, inline="always")
def _next_u64(st):
    st[0] += _SM_GAMMA
    z = st[0]
    z = (z ^ (z >> np.uint64(30))) * _SM_M1
    z = (z ^ (z >> np.uint64(27))) * _SM_M2
    return z ^ (z >> np.uint64(31))


@njit(cache=True, inline="always")
def _rand(st):
    """Uniform in [0, 1)."""
    return float(_next_u64(st) >> np.uint64(11)) * (1.0 / 9007199254740992.0)


def _ziggurat_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tables of Marsaglia & Tsang's ziggurat (2000) for the standard normal, 128 layers."""
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


_ZKN, _ZWN, _ZFN = _ziggurat_tables()
_ZR = 3.442619855899


@njit(cache=True)
def _randn_tail(st, hz, iz):
    """The ziggurat's slow path (rare): wedges and the tail."""
    while True:
        x = hz * _ZWN[iz]
        if iz == 0:
            while True:
                x = -math.log(1.0 - _rand(st)) / _ZR
                y = -math.log(1.0 - _rand(st))
                if y + y >= x * x:
                    break
            return _ZR + x if hz > 0 else -_ZR - x
        if _ZFN[iz] + _rand(st) * (_ZFN[iz - 1] - _ZFN[iz]) < math.exp(-0.5 * x * x):
            return x
        u = _next_u64(st)
        iz = int(u & np.uint64(127))
        hz = float(np.int32(np.uint32(u >> np.uint64(32))))
        if abs(hz) < _ZKN[iz]:
            return hz * _ZWN[iz]


@njit(cache=True, inline="always")
def _randn(st):
    """Standard normal: Marsaglia & Tsang's ziggurat (one 64-bit draw on the fast path)."""
    u = _next_u64(st)
    iz = int(u & np.uint64(127))
    hz = float(np.int32(np.uint32(u >> np.uint64(32))))
    if abs(hz) < _ZKN[iz]:
        return hz * _ZWN[iz]
    return _randn_tail(st, hz, iz)


def stream_seeds(rng: np.random.Generator, n: int) -> np.ndarray:
    """One seed per individual for the kernels' random streams, drawn from ``rng``."""
    return rng.bit_generator.random_raw(n)


@njit(cache=True, inline="always")
def _draw(kind, st):
    """One draw of the given kind (see ``DRAW_*``); ``DRAW_NONE`` draws nothing."""
    if kind == DRAW_UNIFORM:
        return _rand(st)
    if kind == DRAW_SYMMETRIC:
        return 2.0 * _rand(st) - 1.0
    if kind == DRAW_NORMAL:
        return _randn(st)
    return 0.0


@njit(cache=True)
def rebuild(
    base,
    active,
    anchor,
    offset,
    spread,
    draw,
    spread2,
    draw2,
    clamp,
    first,
    use_first,
    explicit,
    n_explicit,
    escape,
    t_max,
    v_min,
    v_max,
    reach,
    seeds,
):
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
    cols, dy, dz = reach.cols, reach.steps[1], reach.steps[2]
    tab, off, keys, lim = reach.table, reach.table_off, reach.memo, margin_limit(reach.margin)
    world, margin, counts = reach.world, reach.margin, reach.counts
    n_chk = 0
    n_exact = 0
    start_m, goal_m = reach.start_m, reach.goal_m
    n_pop = base.shape[0]
    n_inner = base.shape[1]
    out = base.copy()
    ok = np.ones(n_pop, dtype=np.bool_)
    esc = np.zeros(n_pop, dtype=np.int64)
    for g in range(n_pop):
        if not active[g]:
            continue
        st = np.empty(1, dtype=np.uint64)
        st[0] = seeds[g]
        kind1 = draw[g]
        kind2 = draw2[g]
        n_exp = n_explicit[g]
        py = 0.0
        pz = 0.0
        same = True  # the previous node equals the base path's, whose segments are known free
        for j in range(n_inner):
            placed = False
            ny = 0.0
            nz = 0.0
            for attempt in range(t_max):
                for a in range(2):
                    if attempt < n_exp:
                        v = explicit[attempt, g, j, a]
                    elif attempt == 0 and use_first[g]:
                        v = first[g, j, a]
                    else:
                        step = offset[g, j, a] + spread[g, j, a] * _draw(kind1, st)
                        step = step + spread2[g, j, a] * _draw(kind2, st)
                        c = clamp[a]
                        if step > c:
                            step = c
                        elif step < -c:
                            step = -c
                        v = anchor[g, j, a] + step
                    if a == 0:
                        ny = _round(v)
                    else:
                        nz = _round(v)
                if same and ny == base[g, j, 0] and nz == base[g, j, 1]:
                    placed = True
                    break
                code = node_status(j + 1, py, pz, ny, nz, cols, dy, dz, lim, tab, off, keys)
                if code < 0:
                    code = 2 + node_resolve(
                        j + 1, py, pz, ny, nz, cols, dy, dz, start_m, goal_m, world, margin, keys
                    )
                n_chk += 1
                n_exact += code >> 1
                if code & 1:
                    placed = True
                    break
            if not placed and escape[g]:
                for v in range(v_min, v_max + 1):
                    for _t in range(t_max):
                        ny = _round(base[g, j, 0] + (2.0 * _rand(st) - 1.0) * v)
                        nz = _round(base[g, j, 1] + (2.0 * _rand(st) - 1.0) * v)
                        code = node_status(j + 1, py, pz, ny, nz, cols, dy, dz, lim, tab, off, keys)
                        if code < 0:
                            code = 2 + node_resolve(
                                j + 1,
                                py,
                                pz,
                                ny,
                                nz,
                                cols,
                                dy,
                                dz,
                                start_m,
                                goal_m,
                                world,
                                margin,
                                keys,
                            )
                        n_chk += 1
                        n_exact += code >> 1
                        if code & 1:
                            placed = True
                            break
                    if placed:
                        esc[g] += 1
                        break
            if not placed:
                ny = base[g, j, 0]
                nz = base[g, j, 1]
                if not same:
                    code = node_status(j + 1, py, pz, ny, nz, cols, dy, dz, lim, tab, off, keys)
                    if code < 0:
                        code = 2 + node_resolve(
                            j + 1,
                            py,
                            pz,
                            ny,
                            nz,
                            cols,
                            dy,
                            dz,
                            start_m,
                            goal_m,
                            world,
                            margin,
                            keys,
                        )
                    n_chk += 1
                    n_exact += code >> 1
                    placed = (code & 1) == 1
                else:
                    placed = True
            if not placed:
                ok[g] = False
                break
            out[g, j, 0] = ny
            out[g, j, 1] = nz
            same = ny == base[g, j, 0] and nz == base[g, j, 1]
            py = ny
            pz = nz
        if not ok[g]:
            for j in range(n_inner):
                out[g, j, 0] = base[g, j, 0]
                out[g, j, 1] = base[g, j, 1]
    counts[0] += n_chk
    counts[1] += n_exact
    return out, ok, esc.sum()


@njit(cache=True)
def moving_average_repair(nodes, goal_u, window, reach, skip):
    """Replace every node by the rounded mean of a window of its path, under the
    reachability rule, in place (SPSA's adaptive oscillation optimisation, section 4.4,
    eq. 13); individuals with ``skip[g]`` are left alone (callers skip known fixed points).

    Node j becomes round(mean(P_{j−1}, P_j, …, P_{j+N_p−2})) with N_p = ``window``, the
    previous node already replaced; when that node is unreachable N_p drops by one, and
    below 3 the node is kept. Windows are cut at the goal. An individual whose kept node
    became unreachable is left as it was. Returns the nodes moved per individual (G,).
    """
    cols, dy, dz = reach.cols, reach.steps[1], reach.steps[2]
    tab, off, keys, lim = reach.table, reach.table_off, reach.memo, margin_limit(reach.margin)
    world, margin, counts = reach.world, reach.margin, reach.counts
    n_chk = 0
    n_exact = 0
    start_m, goal_m = reach.start_m, reach.goal_m
    n_pop = nodes.shape[0]
    n_inner = nodes.shape[1]
    moved = np.zeros(n_pop, dtype=np.int64)
    for g in range(n_pop):
        if skip[g]:
            continue
        new = np.empty((n_inner, 2))
        py = 0.0
        pz = 0.0
        ok = True
        count = 0
        same = True  # previous node unchanged: segments of the current path are known free
        for j in range(n_inner):
            placed = False
            for np_ in range(window, 2, -1):
                # window: previous (optimised) node, then nodes j .. j+np_-2
                sy = py if j > 0 else start_m[1] / dy
                sz = pz if j > 0 else start_m[2] / dz
                cnt = 1
                for k in range(j, j + np_ - 1):
                    if k < n_inner:
                        sy += nodes[g, k, 0]
                        sz += nodes[g, k, 1]
                    else:
                        sy += goal_u[0]
                        sz += goal_u[1]
                    cnt += 1
                    if k >= n_inner:
                        break
                ny = _round(sy / cnt)
                nz = _round(sz / cnt)
                if same and ny == nodes[g, j, 0] and nz == nodes[g, j, 1]:
                    placed = True
                    break
                code = node_status(j + 1, py, pz, ny, nz, cols, dy, dz, lim, tab, off, keys)
                if code < 0:
                    code = 2 + node_resolve(
                        j + 1, py, pz, ny, nz, cols, dy, dz, start_m, goal_m, world, margin, keys
                    )
                n_chk += 1
                n_exact += code >> 1
                if code & 1:
                    placed = True
                    break
            if not placed:
                ny = nodes[g, j, 0]
                nz = nodes[g, j, 1]
                if not same:
                    code = node_status(j + 1, py, pz, ny, nz, cols, dy, dz, lim, tab, off, keys)
                    if code < 0:
                        code = 2 + node_resolve(
                            j + 1,
                            py,
                            pz,
                            ny,
                            nz,
                            cols,
                            dy,
                            dz,
                            start_m,
                            goal_m,
                            world,
                            margin,
                            keys,
                        )
                    n_chk += 1
                    n_exact += code >> 1
                    if not code & 1:
                        ok = False
                        break
            same = ny == nodes[g, j, 0] and nz == nodes[g, j, 1]
            if not same:
                count += 1
            new[j, 0] = ny
            new[j, 1] = nz
            py = ny
            pz = nz
        if ok:
            for j in range(n_inner):
                nodes[g, j, 0] = new[j, 0]
                nodes[g, j, 1] = new[j, 1]
            moved[g] = count
    counts[0] += n_chk
    counts[1] += n_exact
    return moved


@njit(cache=True)
def paths_feasible(nodes, reach):
    """(G,) bool: every segment of every individual reachable (start → nodes → goal)."""
    cols, dy, dz = reach.cols, reach.steps[1], reach.steps[2]
    tab, off, keys, lim = reach.table, reach.table_off, reach.memo, margin_limit(reach.margin)
    world, margin, counts = reach.world, reach.margin, reach.counts
    n_chk = 0
    n_exact = 0
    start_m, goal_m = reach.start_m, reach.goal_m
    n_pop = nodes.shape[0]
    n_inner = nodes.shape[1]
    out = np.ones(n_pop, dtype=np.bool_)
    for g in range(n_pop):
        py = 0.0
        pz = 0.0
        for j in range(n_inner):
            ny = nodes[g, j, 0]
            nz = nodes[g, j, 1]
            code = node_status(j + 1, py, pz, ny, nz, cols, dy, dz, lim, tab, off, keys)
            if code < 0:
                code = 2 + node_resolve(
                    j + 1, py, pz, ny, nz, cols, dy, dz, start_m, goal_m, world, margin, keys
                )
            n_chk += 1
            n_exact += code >> 1
            if not code & 1:
                out[g] = False
                break
            py = ny
            pz = nz
    counts[0] += n_chk
    counts[1] += n_exact
    return out
