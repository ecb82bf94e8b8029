"""Compiled geometry kernels (numba): distances from points and segments to vertical solids.

Every obstacle is split into convex *pieces* standing on the ground: convex polygons
(boxes, convex prisms, triangles of non-convex prisms) and circles (cylinders), each with a
height. The distance from a point to a piece ``C × [0, h]`` is
``sqrt(d2(p_xy, C)² + dz²)`` with ``dz`` the distance of ``z`` to ``[0, h]``; along a segment
that distance is a convex function of the segment parameter, so its minimum is found by a
golden-section search whose Lipschitz bound also lets a yes/no test stop early.

All arrays are float64; nothing here knows about files, YAML or MAVLink.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

GOLD = 0.6180339887498949
#: distances are resolved to this many metres
DIST_TOL_M = 1e-7
FAR = 1e300


@njit(cache=True, inline="always")
def _point_seg2d_sq(px, py, ax, ay, bx, by):
    ex = bx - ax
    ey = by - ay
    den = ex * ex + ey * ey
    t = 0.0
    if den > 0.0:
        t = ((px - ax) * ex + (py - ay) * ey) / den
        if t < 0.0:
            t = 0.0
        elif t > 1.0:
            t = 1.0
    dx = px - (ax + t * ex)
    dy = py - (ay + t * ey)
    return dx * dx + dy * dy


@njit(cache=True)
def point_polygon_dist2d(px, py, verts, n):
    """Distance from (px, py) to a convex CCW polygon ``verts[:n]``; 0 inside."""
    inside = True
    best = FAR
    for i in range(n):
        ax = verts[i, 0]
        ay = verts[i, 1]
        j = i + 1
        if j == n:
            j = 0
        bx = verts[j, 0]
        by = verts[j, 1]
        if (bx - ax) * (py - ay) - (by - ay) * (px - ax) < 0.0:
            inside = False
        d = _point_seg2d_sq(px, py, ax, ay, bx, by)
        if d < best:
            best = d
    if inside:
        return 0.0
    return math.sqrt(best)


@njit(cache=True, inline="always")
def vertical_gap(pz, h):
    """Vertical distance from height ``pz`` to a piece spanning z in [0, h]; a negative ``h``
    is a ceiling piece spanning [−h, ∞) (the terrain-following ceiling)."""
    if h < 0.0:
        if pz < -h:
            return -h - pz
        return 0.0
    if pz > h:
        return pz - h
    if pz < 0.0:
        return -pz
    return 0.0


@njit(cache=True)
def point_piece_dist(px, py, pz, k, poly_xy, poly_n, poly_h, circ):
    """Distance from a point to piece ``k`` (polygons first, then circles)."""
    npoly = poly_n.shape[0]
    if k < npoly:
        dh = point_polygon_dist2d(px, py, poly_xy[k], poly_n[k])
        dz = vertical_gap(pz, poly_h[k])
    else:
        c = k - npoly
        dh = math.hypot(px - circ[c, 0], py - circ[c, 1]) - circ[c, 2]
        if dh < 0.0:
            dh = 0.0
        dz = vertical_gap(pz, circ[c, 3])
    return math.sqrt(dh * dh + dz * dz)


@njit(cache=True)
def seg_piece_dist(ax, ay, az, bx, by, bz, k, poly_xy, poly_n, poly_h, circ, box, thr):
    """Minimum distance between segment a→b and piece ``k``, with an early stop.

    If the true minimum is below ``thr`` the result is below ``thr``; otherwise it is
    ``>= thr``. With ``thr < 0`` the exact minimum (to ``DIST_TOL_M``) is returned.
    ``box[k]`` = (xmin, xmax, ymin, ymax, zmax) of the piece.
    """
    if thr >= 0.0:
        # bounding boxes, the piece's inflated by thr
        if max(ax, bx) < box[k, 0] - thr or min(ax, bx) > box[k, 1] + thr:
            return FAR
        if max(ay, by) < box[k, 2] - thr or min(ay, by) > box[k, 3] + thr:
            return FAR
        if min(az, bz) > box[k, 4] + thr:
            return FAR
        if k < poly_n.shape[0] and poly_h[k] < 0.0 and max(az, bz) < -poly_h[k] - thr:
            return FAR  # wholly below a ceiling piece
    dx = bx - ax
    dy = by - ay
    dz = bz - az
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    fa = point_piece_dist(ax, ay, az, k, poly_xy, poly_n, poly_h, circ)
    if fa < thr:
        return fa
    fb = point_piece_dist(bx, by, bz, k, poly_xy, poly_n, poly_h, circ)
    best = min(fa, fb)
    if fb < thr or length <= 0.0:
        return best
    if thr >= 0.0 and 0.5 * (fa + fb - length) >= thr:
        return 0.5 * (fa + fb - length)
    lo = 0.0
    hi = 1.0
    x1 = hi - GOLD
    x2 = GOLD
    f1 = point_piece_dist(
        ax + x1 * dx, ay + x1 * dy, az + x1 * dz, k, poly_xy, poly_n, poly_h, circ
    )
    f2 = point_piece_dist(
        ax + x2 * dx, ay + x2 * dy, az + x2 * dz, k, poly_xy, poly_n, poly_h, circ
    )
    for _ in range(200):
        fm = min(f1, f2)
        if fm < best:
            best = fm
        if best < thr:
            return best
        width = (hi - lo) * length
        if thr >= 0.0 and fm - width >= thr:
            return fm - width
        if width < DIST_TOL_M:
            break
        if f1 < f2:
            hi = x2
            x2 = x1
            f2 = f1
            x1 = hi - GOLD * (hi - lo)
            f1 = point_piece_dist(
                ax + x1 * dx, ay + x1 * dy, az + x1 * dz, k, poly_xy, poly_n, poly_h, circ
            )
        else:
            lo = x1
            x1 = x2
            f1 = f2
            x2 = lo + GOLD * (hi - lo)
            f2 = point_piece_dist(
                ax + x2 * dx, ay + x2 * dy, az + x2 * dz, k, poly_xy, poly_n, poly_h, circ
            )
    return best


@njit(cache=True, inline="always")
def _inside(px, py, pz, hp, zlim):
    eps = 1e-9
    if pz < zlim[0] - eps or pz > zlim[1] + eps:
        return False
    for i in range(hp.shape[0]):
        if hp[i, 0] * px + hp[i, 1] * py > hp[i, 2] + eps:
            return False
    return True


@njit(cache=True, inline="always")
def _cell_range(lo, hi, origin, cell, n):
    a = int(math.floor((lo - origin) / cell))
    b = int(math.floor((hi - origin) / cell))
    if a < 0:
        a = 0
    if b > n - 1:
        b = n - 1
    return a, b


@njit(cache=True)
def segment_free(ax, ay, az, bx, by, bz, W, margin):
    """True when segment a→b lies inside the bounds and keeps ``margin`` from every piece.

    ``W`` is the world tuple (see :class:`uavplan.world.World`). The bounds are convex:
    half-planes ``hp[i, 0]·x + hp[i, 1]·y <= hp[i, 2]`` and ``zlim[0] <= z <= zlim[1]``, so
    checking both endpoints suffices. Pieces are found through a uniform grid of cells; a
    piece spanning several cells is tested once (in the first cell it shares with the
    segment's box).
    """
    poly_xy, poly_n, poly_h, circ, box, hp, zlim, gmeta, cell_start, cell_items, piece_cells = W
    if not (_inside(ax, ay, az, hp, zlim) and _inside(bx, by, bz, hp, zlim)):
        return False
    thr = margin - 1e-9
    if thr < 1e-9:
        thr = 1e-9  # margin 0 still means "not touching"
    npieces = box.shape[0]
    gx0 = gmeta[0]
    gy0 = gmeta[1]
    cell = gmeta[2]
    nx = int(gmeta[3])
    ny = int(gmeta[4])
    if npieces == 0:
        return True
    if nx == 0:
        for k in range(npieces):
            if (
                seg_piece_dist(ax, ay, az, bx, by, bz, k, poly_xy, poly_n, poly_h, circ, box, thr)
                < thr
            ):
                return False
        return True
    cx0, cx1 = _cell_range(min(ax, bx) - margin, max(ax, bx) + margin, gx0, cell, nx)
    cy0, cy1 = _cell_range(min(ay, by) - margin, max(ay, by) + margin, gy0, cell, ny)
    for cx in range(cx0, cx1 + 1):
        for cy in range(cy0, cy1 + 1):
            c = cx * ny + cy
            for t in range(cell_start[c], cell_start[c + 1]):
                k = cell_items[t]
                # test each piece once: in the first cell of its overlap with the query
                if cx != max(cx0, piece_cells[k, 0]) or cy != max(cy0, piece_cells[k, 2]):
                    continue
                if (
                    seg_piece_dist(
                        ax, ay, az, bx, by, bz, k, poly_xy, poly_n, poly_h, circ, box, thr
                    )
                    < thr
                ):
                    return False
    return True


@njit(cache=True)
def segments_free(p0, p1, W, margin):
    """Batch of :func:`segment_free`; ``p0``, ``p1``: (n, 3)."""
    n = p0.shape[0]
    out = np.empty(n, dtype=np.bool_)
    for i in range(n):
        out[i] = segment_free(p0[i, 0], p0[i, 1], p0[i, 2], p1[i, 0], p1[i, 1], p1[i, 2], W, margin)
    return out


@njit(cache=True, inline="always")
def _box_gap(x0, x1, y0, y1, z0, z1, box, k, poly_h):
    """Distance between an axis-aligned box and piece k's box (z from 0 to its height, or
    from a ceiling piece's bottom up)."""
    gx = max(0.0, box[k, 0] - x1, x0 - box[k, 1])
    gy = max(0.0, box[k, 2] - y1, y0 - box[k, 3])
    gz = max(0.0, z0 - box[k, 4], -z1)
    if k < poly_h.shape[0] and poly_h[k] < 0.0:
        gz = max(gz, -poly_h[k] - z1)
    return math.sqrt(gx * gx + gy * gy + gz * gz)


@njit(cache=True)
def points_clearance(p, W):
    """Exact distance from each point (n, 3) to the nearest piece, and that piece's index."""
    poly_xy, poly_n, poly_h, circ, box = W[0], W[1], W[2], W[3], W[4]
    n = p.shape[0]
    npieces = box.shape[0]
    dist = np.full(n, np.inf)
    which = np.full(n, -1, dtype=np.int64)
    for i in range(n):
        for k in range(npieces):
            if (
                _box_gap(p[i, 0], p[i, 0], p[i, 1], p[i, 1], p[i, 2], p[i, 2], box, k, poly_h)
                >= dist[i]
            ):
                continue
            d = point_piece_dist(p[i, 0], p[i, 1], p[i, 2], k, poly_xy, poly_n, poly_h, circ)
            if d < dist[i]:
                dist[i] = d
                which[i] = k
    return dist, which


@njit(cache=True)
def segments_clearance(p0, p1, W):
    """Exact minimum distance from each segment p0[i]→p1[i] to the nearest piece."""
    poly_xy, poly_n, poly_h, circ, box = W[0], W[1], W[2], W[3], W[4]
    n = p0.shape[0]
    npieces = box.shape[0]
    dist = np.full(n, np.inf)
    which = np.full(n, -1, dtype=np.int64)
    for i in range(n):
        ax, ay, az = p0[i, 0], p0[i, 1], p0[i, 2]
        bx, by, bz = p1[i, 0], p1[i, 1], p1[i, 2]
        x0, x1 = min(ax, bx), max(ax, bx)
        y0, y1 = min(ay, by), max(ay, by)
        z0, z1 = min(az, bz), max(az, bz)
        for k in range(npieces):
            if _box_gap(x0, x1, y0, y1, z0, z1, box, k, poly_h) >= dist[i]:
                continue
            d = seg_piece_dist(ax, ay, az, bx, by, bz, k, poly_xy, poly_n, poly_h, circ, box, -1.0)
            if d < dist[i]:
                dist[i] = d
                which[i] = k
    return dist, which


@njit(cache=True)
def build_cells(box, pad, cell):
    """Uniform grid over the pieces' boxes grown by ``pad``: (gmeta, cell_start, cell_items,
    piece_cells). gmeta = (x0, y0, cell, nx, ny, pad). A query grows its own box by the
    margin, so ``pad`` may be 0: a piece within the margin shares a cell with the query."""
    npieces = box.shape[0]
    gmeta = np.zeros(6)
    if npieces == 0:
        return gmeta, np.zeros(1, np.int64), np.zeros(0, np.int64), np.zeros((0, 4), np.int64)
    x0 = box[:, 0].min() - pad
    y0 = box[:, 2].min() - pad
    x1 = box[:, 1].max() + pad
    y1 = box[:, 3].max() + pad
    nx = int(math.floor((x1 - x0) / cell)) + 1
    ny = int(math.floor((y1 - y0) / cell)) + 1
    piece_cells = np.empty((npieces, 4), np.int64)
    counts = np.zeros(nx * ny + 1, np.int64)
    for k in range(npieces):
        a0, a1 = _cell_range(box[k, 0] - pad, box[k, 1] + pad, x0, cell, nx)
        b0, b1 = _cell_range(box[k, 2] - pad, box[k, 3] + pad, y0, cell, ny)
        piece_cells[k, 0] = a0
        piece_cells[k, 1] = a1
        piece_cells[k, 2] = b0
        piece_cells[k, 3] = b1
        for cx in range(a0, a1 + 1):
            for cy in range(b0, b1 + 1):
                counts[cx * ny + cy + 1] += 1
    cell_start = np.cumsum(counts)
    fill = cell_start[:-1].copy()
    cell_items = np.empty(cell_start[-1], np.int64)
    for k in range(npieces):
        for cx in range(piece_cells[k, 0], piece_cells[k, 1] + 1):
            for cy in range(piece_cells[k, 2], piece_cells[k, 3] + 1):
                c = cx * ny + cy
                cell_items[fill[c]] = k
                fill[c] += 1
    gmeta[0] = x0
    gmeta[1] = y0
    gmeta[2] = cell
    gmeta[3] = nx
    gmeta[4] = ny
    gmeta[5] = pad
    return gmeta, cell_start, cell_items, piece_cells
