"""Compiled kernels shared by every planner: initialisation, per-node update with the
reachability rule, adaptive escape and oscillation optimisation.

Encoding (PAPER-NOTES "Path model"): an individual is ``nodes[j] = (y, z)`` in grid units
for the inner columns ``j = 1..D−1`` (array index ``j − 1``); start and goal are fixed.
A node is *reachable* when the straight segment from the previous node to it is inside the
bounds and keeps the margin from every obstacle (for the last node, also the segment to the
goal). Every algorithm proposes nodes through :func:`propose` and repairs them the same way
(:func:`rebuild`), so differences between algorithms come from the search rules alone.

Randomness comes only from the ``numpy.random.Generator`` passed in.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from uavplan._geom import point_piece_dist, segment_free

# Update rules (one per individual and call). Reference paths ``refs[g, r]`` and scalars
# ``scal[g, s]`` carry what each rule needs; "δ" is the deviation from the start-end line.
R_SPSA_PRODUCER_BEST = 0  # eq. 11, f_i = f_g:  P + rand·(P_ST − P)
R_SPSA_PRODUCER = 1  # eq. 11 "deviation" reading: δ·e − rand·δ,  scal0 = e
R_SPSA_PRODUCER_LITERAL = 2  # eq. 11 as printed: P + e + rand·(P_ST − P),  scal0 = e
R_SSA_PRODUCER = 3  # eq. 3, R2 < ST: δ·e,  scal0 = e
R_ALARM = 4  # eq. 3, R2 >= ST: P + Q·L,  scal0 = Q
R_SCROUNGER_FAR = 5  # eq. 4, i > n/2: Q·exp((δ_worst − δ)/i²),  ref0 = worst, scal0 = i²
R_SCROUNGER_NEAR = 6  # eq. 4 else: P_p + |P − P_p|·A⁺·L,  ref0 = P_p, scal0/1 = offset y/z
R_DANGER = 7  # eq. 5, f_i > f_g: P_best + β·|P − P_best|,  ref0 = best
R_DANGER_BEST = 8  # eq. 5, f_i = f_g: P + K·|P − P_w|/(f_i − f_w + ε),  ref0 = worst, scal0
R_PSO = 9  # ref0 = velocity, ref1 = pbest, ref2 = gbest, ref3 = Vmax; scal0..2 = w, c1, c2
R_GWO = 10  # ref0..2 = alpha, beta, delta; scal0 = a
R_DE = 11  # ref0..2 = x_r1, x_r2, x_r3; scal0 = F, scal1 = CR, scal2 = j_rand (flat index)
R_CSO_ROOSTER = 12  # δ·(1 + σ²·N(0, 1)),  scal0 = σ² (Meng: "Randn(0, σ²), standard deviation σ²")
R_CSO_HEN = 13  # P + S1·rand·(R1 − P) + S2·rand·(R2 − P); ref0 = R1, ref1 = R2; scal0/1 = S1/S2
R_CSO_CHICK = 14  # P + FL·(M − P); ref0 = mother, scal0 = FL

N_REFS = 4
N_SCAL = 4


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


def new_memo() -> tuple[np.ndarray, np.ndarray]:
    """An empty reachability memo. Reachability of a node is a pure function of (column,
    previous node, node) for a fixed world, so it is computed once per run. Entries pack
    ``key·2 + free`` into one int64, so a reader on another thread sees either nothing or a
    whole entry. The second array is unused (kept so the kernels' argument layout is fixed)."""
    return np.full(1 << MEMO_BITS, _EMPTY, dtype=np.int64), np.zeros(1, np.int8)


@njit(cache=True, inline="always")
def _memo_key(j, y0, z0, y1, z1):
    """Pack (column, y0, z0, y1, z1) into 60 bits; −1 when a value does not fit."""
    a = int(y0) + 2048
    b = int(z0) + 2048
    c = int(y1) + 2048
    d = int(z1) + 2048
    if j < 0 or j >= 4096 or a < 0 or a >= 4096 or b < 0 or b >= 4096:
        return -1
    if c < 0 or c >= 4096 or d < 0 or d >= 4096:
        return -1
    return (((((j << 12) | a) << 12 | b) << 12 | c) << 12) | d


@njit(cache=True)
def _segment_to_node_free(j, y0, z0, y1, z1, dx, dy, dz, start_m, goal_m, geo, margin):
    W = geo[:11]
    if j == 1:
        ax = start_m[0]
        ay = start_m[1]
        az = start_m[2]
    else:
        ax = (j - 1) * dx
        ay = y0 * dy
        az = z0 * dz
    bx = j * dx
    by = y1 * dy
    bz = z1 * dz
    if not segment_free(ax, ay, az, bx, by, bz, W, margin):
        return False
    if j == int(round(goal_m[0] / dx)) - 1:
        return segment_free(bx, by, bz, goal_m[0], goal_m[1], goal_m[2], W, margin)
    return True


#: clearance is tabulated exactly up to this far beyond the margin (metres)
TABLE_REACH_M = 60.0


@njit(cache=True)
def clearance_table(n_cols, iy_lo, iy_hi, iz_lo, iz_hi, dx, dy, dz, geo, cap):
    """Distance from every grid node (column, y, z) to the nearest piece, capped at ``cap``;
    −1 for nodes outside the bounds. Shape (n_cols + 1, iy_hi − iy_lo + 1, iz_hi − iz_lo + 1).
    Each piece only visits the nodes of its bounding box grown by ``cap``."""
    poly_xy, poly_n, poly_h, circ, box, hp, zlim = geo[:7]
    ny = iy_hi - iy_lo + 1
    nz = iz_hi - iz_lo + 1
    tab = np.full((n_cols + 1, ny, nz), cap)
    for k in range(box.shape[0]):
        j0 = max(0, int(math.floor((box[k, 0] - cap) / dx)))
        j1 = min(n_cols, int(math.ceil((box[k, 1] + cap) / dx)))
        a0 = max(0, int(math.floor((box[k, 2] - cap) / dy)) - iy_lo)
        a1 = min(ny - 1, int(math.ceil((box[k, 3] + cap) / dy)) - iy_lo)
        c1 = min(nz - 1, int(math.ceil((box[k, 4] + cap) / dz)) - iz_lo)
        for j in range(j0, j1 + 1):
            for a in range(a0, a1 + 1):
                for c in range(0, c1 + 1):
                    d = point_piece_dist(
                        j * dx, (a + iy_lo) * dy, (c + iz_lo) * dz, k, poly_xy, poly_n, poly_h, circ
                    )
                    if d < tab[j, a, c]:
                        tab[j, a, c] = d
    eps = 1e-9
    for j in range(n_cols + 1):
        for a in range(ny):
            y = (a + iy_lo) * dy
            for c in range(nz):
                z = (c + iz_lo) * dz
                inside = zlim[0] - eps <= z <= zlim[1] + eps
                for i in range(hp.shape[0]):
                    if hp[i, 0] * j * dx + hp[i, 1] * y > hp[i, 2] + eps:
                        inside = False
                if not inside:
                    tab[j, a, c] = -1.0
    return tab


@njit(cache=True, inline="always")
def node_status(j, y0, z0, y1, z1, dx, dy, dz, lim, tab, off, keys):
    """Reachability of the node of column ``j`` (1-based) at (y1, z1) from the node before it
    at (y0, z0), both in grid units, from the cheap sources only: 1 free, 0 blocked, −1
    unknown (call :func:`node_resolve`). ``lim`` is the margin (see :func:`margin_limit`).

    Interior columns: a node closer than the margin (or outside the bounds) is unreachable;
    the segment between nodes with clearances d0, d1 keeps the margin when
    (d0 + d1 − length)/2 >= margin (distance is 1-Lipschitz). Otherwise the memo answers if
    this segment was resolved before.

    The hot kernels take the table, offsets and memo as separate arrays and call this
    inline; handing numba the whole world tuple per call costs more than the test itself.
    """
    if 1 < j < tab.shape[0] - 2:
        a = int(y0) - off[0]
        b = int(z0) - off[1]
        c = int(y1) - off[0]
        d = int(z1) - off[1]
        ny = tab.shape[1]
        nz = tab.shape[2]
        if a < 0 or a >= ny or c < 0 or c >= ny or b < 0 or b >= nz or d < 0 or d >= nz:
            return 0  # outside the bounds' bounding box
        d0 = tab[j - 1, a, b]
        d1 = tab[j, c, d]
        if d0 < lim or d1 < lim:
            return 0
        ey = (y1 - y0) * dy
        ez = (z1 - z0) * dz
        length = math.sqrt(dx * dx + ey * ey + ez * ez)
        if d0 + d1 - length >= 2.0 * lim:
            return 1
    key = _memo_key(j, 0, 0, y1, z1) if j == 1 else _memo_key(j, y0, z0, y1, z1)
    if key < 0:
        return -1
    mask = keys.shape[0] - 1
    h = key ^ (key >> 30)
    h = (h * _MIX1) ^ ((h * _MIX1) >> 27)
    h = (h * _MIX2) ^ ((h * _MIX2) >> 31)
    h &= mask
    for _probe in range(MEMO_PROBES):
        k = keys[h]
        if k == _EMPTY:
            return -1
        if (k >> 1) == key:
            return k & 1
        h = (h + 1) & mask
    return -1


@njit(cache=True)
def node_resolve(j, y0, z0, y1, z1, dx, dy, dz, start_m, goal_m, geo, margin):
    """The exact reachability test behind :func:`node_status`, memoised. Entries pack
    ``key·2 + free`` into one int64 (a reader sees a whole entry or none)."""
    free = _segment_to_node_free(j, y0, z0, y1, z1, dx, dy, dz, start_m, goal_m, geo, margin)
    key = _memo_key(j, 0, 0, y1, z1) if j == 1 else _memo_key(j, y0, z0, y1, z1)
    if key >= 0:
        keys = geo[11]
        mask = keys.shape[0] - 1
        h = key ^ (key >> 30)
        h = (h * _MIX1) ^ ((h * _MIX1) >> 27)
        h = (h * _MIX2) ^ ((h * _MIX2) >> 31)
        h &= mask
        for _probe in range(MEMO_PROBES):
            k = keys[h]
            if k == _EMPTY or (k >> 1) == key:
                keys[h] = 2 * key + (1 if free else 0)
                break
            h = (h + 1) & mask
    return 1 if free else 0


@njit(cache=True, inline="always")
def margin_limit(margin):
    """The clearance a node must have: the margin (less a nanometre for rounding); a zero
    margin still means not touching."""
    lim = margin - 1e-9
    return lim if lim >= 1e-9 else 1e-9


@njit(cache=True)
def node_free(j, y0, z0, y1, z1, dx, dy, dz, start_m, goal_m, geo, margin):
    """:func:`node_status` then, if needed, :func:`node_resolve` (for callers off the hot
    path)."""
    r = node_status(j, y0, z0, y1, z1, dx, dy, dz, margin_limit(margin), geo[13], geo[14], geo[11])
    if r < 0:
        r = node_resolve(j, y0, z0, y1, z1, dx, dy, dz, start_m, goal_m, geo, margin)
    return r == 1


@njit(cache=True)
def init_population(
    n_pop,
    n_inner,
    start_u,
    goal_u,
    half_window,
    t_max,
    max_attempts,
    dx,
    dy,
    dz,
    start_m,
    goal_m,
    geo,
    margin,
    rng,
):
    """Path initialisation of section 4.1 (eq. 8–10) for ``n_pop`` individuals.

    From the current node P_a the next is round(P_t + U(−Δh, Δh)) per axis with
    P_t = P_a + (P_goal − P_a)/m, m the columns left; an unreachable node is reselected up to
    ``t_max`` times, after which the individual is deadlocked and started again (at most
    ``max_attempts`` starts per individual). Returns (nodes, ok, deadlocks).
    """
    tab, off, keys, lim = geo[13], geo[14], geo[11], margin_limit(margin)
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
                    ny = _round(ty + (2.0 * rng.random() - 1.0) * half_window)
                    nz = _round(tz + (2.0 * rng.random() - 1.0) * half_window)
                    r = node_status(j, py, pz, ny, nz, dx, dy, dz, lim, tab, off, keys)
                    if r < 0:
                        r = node_resolve(
                            j, py, pz, ny, nz, dx, dy, dz, start_m, goal_m, geo, margin
                        )
                    if r == 1:
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
def propose(rule, p, ln, r0, r1, r2, r3, s0, s1, s2, flat, attempt, st):
    """One proposal (before rounding) for one axis of one node.

    ``p``: the node's current value; ``ln``: the start-end line there; ``r0..r3``: the
    rule's reference paths at this node and axis; ``s0..s2``: the rule's scalars (for the
    near-scrounger rule ``s1`` is this axis' offset ``scal[g, a]``, see :func:`rebuild`);
    ``flat``: node·2 + axis. Scalars only: handing numba arrays here costs more than the
    arithmetic.
    """
    if rule == R_SPSA_PRODUCER_BEST:
        return p + _rand(st) * (ln - p)
    if rule == R_SPSA_PRODUCER:
        d = p - ln
        return ln + d * s0 - _rand(st) * d
    if rule == R_SPSA_PRODUCER_LITERAL:
        return p + s0 + _rand(st) * (ln - p)
    if rule == R_SSA_PRODUCER:
        return ln + (p - ln) * s0
    if rule == R_ALARM:
        q = s0 if attempt == 0 else _randn(st)
        return p + q
    if rule == R_SCROUNGER_FAR:
        dw = r0 - ln
        d = p - ln
        return ln + _randn(st) * math.exp(min((dw - d) / s0, 50.0))
    if rule == R_SCROUNGER_NEAR:
        return r0 + s1  # s1 carries scal[g, a], the offset of this axis
    if rule == R_DANGER:
        b = r0
        return b + _randn(st) * abs(p - b)
    if rule == R_DANGER_BEST:
        return p + (2.0 * _rand(st) - 1.0) * abs(p - r0) * s0
    if rule == R_PSO:
        v = s0 * r0 + s1 * _rand(st) * (r1 - p) + s2 * _rand(st) * (r2 - p)
        v_max = r3
        if v_max > 0.0:
            v = min(max(v, -v_max), v_max)
        return p + v
    if rule == R_GWO:
        acc = 0.0
        for lead in (r0, r1, r2):
            big_a = 2.0 * s0 * _rand(st) - s0
            big_c = 2.0 * _rand(st)
            acc += lead - big_a * abs(big_c * lead - p)
        return acc / 3.0
    if rule == R_DE:
        if _rand(st) < s1 or (attempt == 0 and flat == int(s2)):
            return r0 + s0 * (r1 - r2)
        return p
    if rule == R_CSO_ROOSTER:
        return ln + (p - ln) * (1.0 + s0 * _randn(st))
    if rule == R_CSO_HEN:
        return p + s0 * _rand(st) * (r0 - p) + s1 * _rand(st) * (r1 - p)
    if rule == R_CSO_CHICK:
        return p + s0 * (r0 - p)
    return p


@njit(cache=True)
def rebuild(
    base,
    rules,
    refs,
    scal,
    escape,
    line,
    t_max,
    v_min,
    v_max,
    dx,
    dy,
    dz,
    start_m,
    goal_m,
    geo,
    margin,
    seeds,
):
    """Apply each individual's rule node by node, start to goal, with the reachability rule.

    base (G, n, 2) current positions; rules (G,) rule ids (−1: leave unchanged);
    refs (G, N_REFS, n, 2); scal (G, N_SCAL); escape (G,) bool: after ``t_max`` failed
    proposals try the adaptive variable-speed escape (eq. 12, Algorithm 2): P + (2·rand − 1)·V
    for V = v_min..v_max, ``t_max`` tries per speed. If nothing is reachable the old node is
    kept when it is reachable; otherwise the individual's update fails (``ok[g] = False``)
    and it keeps its old path. ``line`` (D + 1, 2): the start-end line in grid units.
    ``seeds`` (G,) uint64: each individual's random stream (see :func:`stream_seeds`).
    Returns (new positions, ok, escapes used).
    """
    tab, off, keys, lim = geo[13], geo[14], geo[11], margin_limit(margin)
    n_pop = base.shape[0]
    n_inner = base.shape[1]
    out = base.copy()
    ok = np.ones(n_pop, dtype=np.bool_)
    esc = np.zeros(n_pop, dtype=np.int64)
    for g in range(n_pop):
        rule = rules[g]
        if rule < 0:
            continue
        st = np.empty(1, dtype=np.uint64)
        st[0] = seeds[g]
        py = 0.0
        pz = 0.0
        same = True  # the previous node equals the base path's, whose segments are known free
        s0 = scal[g, 0]
        s2 = scal[g, 2]
        # the near-scrounger rule reads a per-axis offset scal[g, a]; others read scal[g, 1]
        sy = scal[g, 0] if rule == R_SCROUNGER_NEAR else scal[g, 1]
        sz = scal[g, 1]
        for j in range(n_inner):
            placed = False
            ny = 0.0
            nz = 0.0
            by = base[g, j, 0]
            bz = base[g, j, 1]
            ly = line[j + 1, 0]
            lz = line[j + 1, 1]
            ry0 = refs[g, 0, j, 0]
            ry1 = refs[g, 1, j, 0]
            ry2 = refs[g, 2, j, 0]
            ry3 = refs[g, 3, j, 0]
            rz0 = refs[g, 0, j, 1]
            rz1 = refs[g, 1, j, 1]
            rz2 = refs[g, 2, j, 1]
            rz3 = refs[g, 3, j, 1]
            for attempt in range(t_max):
                ny = _round(
                    propose(rule, by, ly, ry0, ry1, ry2, ry3, s0, sy, s2, 2 * j, attempt, st)
                )
                nz = _round(
                    propose(rule, bz, lz, rz0, rz1, rz2, rz3, s0, sz, s2, 2 * j + 1, attempt, st)
                )
                if same and ny == base[g, j, 0] and nz == base[g, j, 1]:
                    placed = True
                    break
                r = node_status(j + 1, py, pz, ny, nz, dx, dy, dz, lim, tab, off, keys)
                if r < 0:
                    r = node_resolve(
                        j + 1, py, pz, ny, nz, dx, dy, dz, start_m, goal_m, geo, margin
                    )
                if r == 1:
                    placed = True
                    break
            if not placed and escape[g]:
                for v in range(v_min, v_max + 1):
                    for _t in range(t_max):
                        ny = _round(base[g, j, 0] + (2.0 * _rand(st) - 1.0) * v)
                        nz = _round(base[g, j, 1] + (2.0 * _rand(st) - 1.0) * v)
                        r = node_status(j + 1, py, pz, ny, nz, dx, dy, dz, lim, tab, off, keys)
                        if r < 0:
                            r = node_resolve(
                                j + 1, py, pz, ny, nz, dx, dy, dz, start_m, goal_m, geo, margin
                            )
                        if r == 1:
                            placed = True
                            break
                    if placed:
                        esc[g] += 1
                        break
            if not placed:
                ny = base[g, j, 0]
                nz = base[g, j, 1]
                placed = same
                if not placed:
                    r = node_status(j + 1, py, pz, ny, nz, dx, dy, dz, lim, tab, off, keys)
                    if r < 0:
                        r = node_resolve(
                            j + 1, py, pz, ny, nz, dx, dy, dz, start_m, goal_m, geo, margin
                        )
                    placed = r == 1
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
    return out, ok, esc.sum()


@njit(cache=True)
def oscillate(nodes, goal_u, window, dx, dy, dz, start_m, goal_m, geo, margin, skip):
    """Adaptive oscillation optimisation (section 4.4, eq. 13), in place, every individual
    except those with ``skip[g]`` (callers skip paths known to be fixed points).

    Node j becomes round(mean(P_{j−1}, P_j, …, P_{j+N_p−2})) with N_p = ``window``, the
    previous node already optimised; when that node is unreachable N_p drops by one, and
    below 3 the node is kept. Windows are cut at the goal. An individual whose kept node
    became unreachable is left as it was. Returns the nodes moved per individual (G,).
    """
    tab, off, keys, lim = geo[13], geo[14], geo[11], margin_limit(margin)
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
                r = node_status(j + 1, py, pz, ny, nz, dx, dy, dz, lim, tab, off, keys)
                if r < 0:
                    r = node_resolve(
                        j + 1, py, pz, ny, nz, dx, dy, dz, start_m, goal_m, geo, margin
                    )
                if r == 1:
                    placed = True
                    break
            if not placed:
                ny = nodes[g, j, 0]
                nz = nodes[g, j, 1]
                if not same:
                    r = node_status(j + 1, py, pz, ny, nz, dx, dy, dz, lim, tab, off, keys)
                    if r < 0:
                        r = node_resolve(
                            j + 1, py, pz, ny, nz, dx, dy, dz, start_m, goal_m, geo, margin
                        )
                    if r != 1:
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
    return moved


@njit(cache=True)
def paths_feasible(nodes, dx, dy, dz, start_m, goal_m, geo, margin):
    """(G,) bool: every segment of every individual reachable (start → nodes → goal)."""
    tab, off, keys, lim = geo[13], geo[14], geo[11], margin_limit(margin)
    n_pop = nodes.shape[0]
    n_inner = nodes.shape[1]
    out = np.ones(n_pop, dtype=np.bool_)
    for g in range(n_pop):
        py = 0.0
        pz = 0.0
        for j in range(n_inner):
            ny = nodes[g, j, 0]
            nz = nodes[g, j, 1]
            r = node_status(j + 1, py, pz, ny, nz, dx, dy, dz, lim, tab, off, keys)
            if r < 0:
                r = node_resolve(j + 1, py, pz, ny, nz, dx, dy, dz, start_m, goal_m, geo, margin)
            if r != 1:
                out[g] = False
                break
            py = ny
            pz = nz
    return out
