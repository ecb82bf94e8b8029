"""The energy fitness of the paper (eq. 1–2), compiled.

``E = k0·Σ|segment| + k1·Σ μ0·(1 + cos θ) + k2·Σ|Δz|`` over a polyline, with θ the angle at a
vertex between its two segments (straight: θ = 180°, term 0). The search evaluates it on the
natural cubic spline through a path's column nodes, sampled ``n_sub`` times per column
(section 2.2: "the fitness is performed by cubic spline interpolation"). With uniform columns
the spline is a linear map of the node values, solved here by one tridiagonal sweep per
individual and axis, so a whole population costs O(G·D).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from uavplan.config import EnergyWeights

#: spline samples per column interval used by the search fitness
N_SUB = 3


@njit(cache=True)
def polyline_energy(points, k0, k1, mu0, k2):
    """(E_path, E_turning, E_climb) of the polyline ``points`` (n, 3), weights applied."""
    n = points.shape[0]
    length = 0.0
    turn = 0.0
    climb = 0.0
    pdx = 0.0
    pdy = 0.0
    pdz = 0.0
    plen = 0.0
    for i in range(1, n):
        dx = points[i, 0] - points[i - 1, 0]
        dy = points[i, 1] - points[i - 1, 1]
        dz = points[i, 2] - points[i - 1, 2]
        seg = math.sqrt(dx * dx + dy * dy + dz * dz)
        if seg <= 1e-12:
            continue
        length += seg
        climb += abs(dz)
        if plen > 0.0:
            # 1 + cos θ, θ the angle between the two segments at the vertex
            turn += 1.0 - (pdx * dx + pdy * dy + pdz * dz) / (plen * seg)
        pdx = dx
        pdy = dy
        pdz = dz
        plen = seg
    return k0 * length, k1 * mu0 * turn, k2 * climb


@njit(cache=True)
def _thomas_factors(n):
    """Forward-sweep factors of tridiag(1, 4, 1) of size n (natural spline, uniform knots)."""
    cp = np.empty(n)
    den = np.empty(n)
    prev = 0.0
    for i in range(n):
        den[i] = 4.0 - prev
        cp[i] = 1.0 / den[i]
        prev = cp[i]
    return cp, den


@njit(cache=True)
def _second_derivs(vals, h, cp, den, out):
    """Natural cubic spline second derivatives M (len D + 1) of knot values ``vals``."""
    n = vals.shape[0] - 2
    out[0] = 0.0
    out[n + 1] = 0.0
    if n <= 0:
        return
    scale = 6.0 / (h * h)
    # forward sweep, storing d' in out[1..n]
    prev = 0.0
    for i in range(n):
        r = scale * (vals[i] - 2.0 * vals[i + 1] + vals[i + 2])
        prev = (r - prev) / den[i]
        out[i + 1] = prev
    for i in range(n - 2, -1, -1):
        out[i + 1] -= cp[i] * out[i + 2]


@njit(cache=True)
def spline_points(ys, zs, dx, n_sub, cp, den, out):
    """Sample the natural cubic splines y(x), z(x) through knots at x = j·dx.

    ``ys``, ``zs``: knot values (D + 1,) in metres. ``out``: (D·n_sub + 1, 3) filled.
    """
    nk = ys.shape[0]
    my = np.empty(nk)
    mz = np.empty(nk)
    _second_derivs(ys, dx, cp, den, my)
    _second_derivs(zs, dx, cp, den, mz)
    h2 = dx * dx / 6.0
    row = 0
    for i in range(nk - 1):
        for k in range(n_sub):
            u = k / n_sub
            a = 1.0 - u
            c = h2 * (a * a * a - a)
            d = h2 * (u * u * u - u)
            out[row, 0] = (i + u) * dx
            out[row, 1] = a * ys[i] + u * ys[i + 1] + c * my[i] + d * my[i + 1]
            out[row, 2] = a * zs[i] + u * zs[i + 1] + c * mz[i] + d * mz[i + 1]
            row += 1
    out[row, 0] = (nk - 1) * dx
    out[row, 1] = ys[nk - 1]
    out[row, 2] = zs[nk - 1]


@njit(cache=True)
def _moving_average(vals, half, out):
    """Centred moving average over 2·half + 1 knots, the window shrunk symmetrically near
    the ends so the end knots stay where they are."""
    n = vals.shape[0]
    for i in range(n):
        h = min(half, i, n - 1 - i)
        acc = 0.0
        for k in range(i - h, i + h + 1):
            acc += vals[k]
        out[i] = acc / (2 * h + 1)


@njit(cache=True)
def population_energy(nodes, start_yz, goal_yz, dx, dy, dz, n_sub, k0, k1, mu0, k2, smooth,
                      cols, straight):  # fmt: skip
    """Energy (G,) of every individual: nodes (G, D − 1, 2) in grid units (y, z).

    ``start_yz`` / ``goal_yz`` are the fixed end points in metres. ``smooth`` > 0 evaluates
    the spline through a centred moving average of the knots (half-width ``smooth``) instead
    of the knots themselves: the grid rounding of the encoding then no longer shows up as
    staircase wiggles in the fitness (ours; 0 is the paper's fitness). The spline samples
    are summed as they are produced (same result as :func:`spline_points` followed by
    :func:`polyline_energy`, without storing them).

    ``cols`` (D + 1, 4): the columns' origins and unit normals (see the path frame). With a
    ``straight`` guide the columns are x = j·dx and the splines are y(x), z(x), as in the
    paper; along a curved guide every knot is placed in the plane (origin + y·normal) and
    x, y and z are splines of the column index.
    """
    g_count = nodes.shape[0]
    inner = nodes.shape[1]
    nk = inner + 2
    cp, den = _thomas_factors(max(inner, 1))
    out = np.empty(g_count)
    ys = np.empty(nk)
    zs = np.empty(nk)
    sy = np.empty(nk)
    sz = np.empty(nk)
    sx = np.empty(nk)
    my = np.empty(nk)
    mz = np.empty(nk)
    mx = np.zeros(nk)
    h2 = dx * dx / 6.0
    for g in range(g_count):
        ys[0] = start_yz[0]
        zs[0] = start_yz[1]
        ys[nk - 1] = goal_yz[0]
        zs[nk - 1] = goal_yz[1]
        for j in range(inner):
            ys[j + 1] = nodes[g, j, 0] * dy
            zs[j + 1] = nodes[g, j, 1] * dz
        if smooth > 0:
            _moving_average(ys, smooth, sy)
            _moving_average(zs, smooth, sz)
        else:
            sy[:] = ys
            sz[:] = zs
        if not straight:
            for j in range(nk):  # lateral offsets → positions in the plane
                lat = sy[j]
                sx[j] = cols[j, 0] + lat * cols[j, 2]
                sy[j] = cols[j, 1] + lat * cols[j, 3]
            _second_derivs(sx, dx, cp, den, mx)
        _second_derivs(sy, dx, cp, den, my)
        _second_derivs(sz, dx, cp, den, mz)
        length = 0.0
        turn = 0.0
        climb = 0.0
        px = 0.0 if straight else sx[0]
        py = sy[0]
        pz = sz[0]
        pdx = 0.0
        pdy = 0.0
        pdz = 0.0
        plen = 0.0
        for i in range(nk - 1):
            for k in range(n_sub):
                if i == 0 and k == 0:
                    continue
                u = k / n_sub
                a = 1.0 - u
                c = h2 * (a * a * a - a)
                d = h2 * (u * u * u - u)
                if straight:
                    x = (i + u) * dx
                else:
                    x = a * sx[i] + u * sx[i + 1] + c * mx[i] + d * mx[i + 1]
                y = a * sy[i] + u * sy[i + 1] + c * my[i] + d * my[i + 1]
                z = a * sz[i] + u * sz[i + 1] + c * mz[i] + d * mz[i + 1]
                ex = x - px
                ey = y - py
                ez = z - pz
                seg = math.sqrt(ex * ex + ey * ey + ez * ez)
                if seg > 1e-12:
                    length += seg
                    climb += abs(ez)
                    if plen > 0.0:
                        turn += 1.0 - (pdx * ex + pdy * ey + pdz * ez) / (plen * seg)
                    pdx = ex
                    pdy = ey
                    pdz = ez
                    plen = seg
                px = x
                py = y
                pz = z
        # the last sample: the goal knot
        ex = ((nk - 1) * dx if straight else sx[nk - 1]) - px
        ey = sy[nk - 1] - py
        ez = sz[nk - 1] - pz
        seg = math.sqrt(ex * ex + ey * ey + ez * ez)
        if seg > 1e-12:
            length += seg
            climb += abs(ez)
            if plen > 0.0:
                turn += 1.0 - (pdx * ex + pdy * ey + pdz * ez) / (plen * seg)
        out[g] = k0 * length + k1 * mu0 * turn + k2 * climb
    return out


def energy_terms(points: np.ndarray, weights: EnergyWeights) -> tuple[float, float, float]:
    """(path, turning, climb) energy of a polyline (n, 3) in metres."""
    p = np.ascontiguousarray(points, dtype=float)
    e = polyline_energy(p, weights.k0, weights.k1, weights.mu0, weights.k2)
    return float(e[0]), float(e[1]), float(e[2])


def column_spline(knots_yz_m: np.ndarray, dx_m: float, n_sub: int = N_SUB) -> np.ndarray:
    """Dense samples ((D·n_sub + 1), 3) in the path frame of the natural cubic spline through
    knots (D + 1, 2) = (y, z) in metres at x = j·dx."""
    k = np.ascontiguousarray(knots_yz_m, dtype=float)
    cp, den = _thomas_factors(max(k.shape[0] - 2, 1))
    out = np.empty(((k.shape[0] - 1) * n_sub + 1, 3))
    spline_points(
        np.ascontiguousarray(k[:, 0]), np.ascontiguousarray(k[:, 1]), dx_m, n_sub, cp, den, out
    )
    return out
