"""Geometry kernels: distances from points and segments to vertical solids.

Every obstacle is split into convex *pieces* standing on the ground: convex polygons
(boxes, convex prisms, triangles of non-convex prisms) and circles (cylinders), each with a
height. The distance from a point to a piece ``C × [0, h]`` is
``sqrt(d2(p_xy, C)² + dz²)`` with ``dz`` the distance of ``z`` to ``[0, h]``; along a segment
that distance is a convex function of the segment parameter, so its minimum is found by a
golden-section search whose Lipschitz bound also lets a yes/no test stop early.

The loops are compiled C (:mod:`uavplan._ckernels`, built by pip at install time); the
functions here check and shape the arrays. All arrays are float64 (counts and indices int64);
nothing here knows about files, YAML or MAVLink.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Any

import numpy as np

try:
    from uavplan import _ckernels as _c
except ImportError as exc:  # pragma: no cover - a source tree that was never built
    raise ImportError(
        "uavplan's compiled kernels (uavplan._ckernels) are not built: install the package "
        "with `pip install .` (a source checkout: `pip install -e .`), which compiles them "
        "with the system's C compiler"
    ) from exc

#: the golden-section search's ratio, the distance tolerance (m) and "no piece near": the
#: kernels' own constants, read from the module
GOLD: float = _c.GOLD
DIST_TOL_M: float = _c.DIST_TOL_M
FAR: float = _c.FAR

#: the most threads :func:`kernel_threads` picks on its own (the SPSA step's phases are
#: short: more threads were not measured)
THREADS_AUTO_MAX = 2
#: the most threads a kernel runs (the kernels' own limit)
THREADS_MAX: int = _c.STEP_MAX_THREADS
#: whether this build of the kernels has helper threads (POSIX threads and gcc's / clang's
#: atomics); without them every kernel runs on its caller's thread alone
HAVE_THREADS: bool = bool(_c.HAVE_THREADS)


def kernel_threads() -> int:
    """Threads for the kernels that share their work (the SPSA step, long batches of segment
    tests): ``UAVPLAN_THREADS`` when it is set to a whole number (1 turns threading off; at
    most :data:`THREADS_MAX`), else the CPUs this process may run on, at most
    :data:`THREADS_AUTO_MAX` (one CPU, e.g. under ``taskset -c 0``: 1). Always 1 on a build
    without threads (:data:`HAVE_THREADS`)."""
    if not HAVE_THREADS:
        return 1
    text = os.environ.get("UAVPLAN_THREADS", "").strip()
    if text.isdigit() and int(text) >= 1:
        return min(int(text), THREADS_MAX)
    try:
        cpus = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # not on Linux
        cpus = os.cpu_count() or 1
    return max(1, min(cpus, THREADS_AUTO_MAX))


def _f64(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def _i64(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.int64)


def kernel_fields(value: Any, structure: str) -> None:
    """Check a named structure the kernels read (``_ckernels.FIELDS[structure]``: its fields,
    their kinds and dimensions, whether the kernels write them) and bring every array it
    reads to the kernels' dtype, C-contiguous (no copy when it already is). For the
    ``__post_init__`` of a frozen dataclass. An array the kernels write must already be so
    (a copy would take the kernels' results away): TypeError when it is not."""
    for name, kind, ndim, writable in _c.FIELDS[structure]:
        if ndim == 0:
            continue
        a = getattr(value, name)
        ok = isinstance(a, np.ndarray) and a.dtype == np.dtype(kind) and a.flags.c_contiguous
        if writable:
            if not (ok and a.flags.writeable):
                raise TypeError(f"{structure}.{name}: a writable C-contiguous {kind} array")
        elif not ok:
            object.__setattr__(value, name, np.ascontiguousarray(a, dtype=kind))


@dataclass(frozen=True, slots=True, eq=False)
class KernelWorld:
    """The world as the kernels read it (:attr:`uavplan.world.World.kernel_args`), by name.

    Pieces: ``poly_xy`` (npoly, vmax, 2) convex CCW polygons, ``poly_n`` (npoly,) their vertex
    counts, ``poly_h`` (npoly,) heights (negative: a ceiling piece from −h up), ``circ``
    (ncirc, 4) circles (x, y, r, h), ``box`` (npieces, 5) every piece's (xmin, xmax, ymin,
    ymax, zmax); bounds: half-planes ``hp`` (nhp, 3) and ``zlim`` (2,); the cell grid of
    :func:`build_cells`: ``gmeta``, ``cell_start``, ``cell_items``, ``piece_cells``; the
    terrain's height field (:class:`uavplan.ground.HeightField`): ``hf_xy`` (nr, nc, 2),
    ``hf_z`` (nr, nc), ``hf_slope`` (nr − 1, nc − 1), ``hf_meta`` (``FIELD_META``,),
    ``hf_blocks`` (nbr, nbc, 2) (:attr:`~uavplan.ground.HeightField.blocks`): empty arrays
    over flat ground. Arrays are brought to the kernels' dtypes once, here
    (:func:`kernel_fields`)."""

    poly_xy: np.ndarray
    poly_n: np.ndarray
    poly_h: np.ndarray
    circ: np.ndarray
    box: np.ndarray
    hp: np.ndarray
    zlim: np.ndarray
    gmeta: np.ndarray
    cell_start: np.ndarray
    cell_items: np.ndarray
    piece_cells: np.ndarray
    hf_xy: np.ndarray
    hf_z: np.ndarray
    hf_slope: np.ndarray
    hf_meta: np.ndarray
    hf_blocks: np.ndarray

    def __post_init__(self) -> None:
        kernel_fields(self, "world")


def point_polygon_dist2d(px: float, py: float, verts: np.ndarray, n: int) -> float:
    """Distance from (px, py) to a convex CCW polygon ``verts[:n]``; 0 inside."""
    return _c.point_polygon_dist2d(float(px), float(py), _f64(verts), int(n))


def point_piece_dist(
    px: float,
    py: float,
    pz: float,
    k: int,
    poly_xy: np.ndarray,
    poly_n: np.ndarray,
    poly_h: np.ndarray,
    circ: np.ndarray,
) -> float:
    """Distance from a point to piece ``k`` (polygons first, then circles)."""
    return _c.point_piece_dist(
        float(px), float(py), float(pz), int(k), _f64(poly_xy), _i64(poly_n), _f64(poly_h),
        _f64(circ),
    )  # fmt: skip


def seg_piece_dist(
    ax: float,
    ay: float,
    az: float,
    bx: float,
    by: float,
    bz: float,
    k: int,
    poly_xy: np.ndarray,
    poly_n: np.ndarray,
    poly_h: np.ndarray,
    circ: np.ndarray,
    box: np.ndarray,
    thr: float,
) -> float:
    """Minimum distance between segment a→b and piece ``k``, with an early stop.

    If the true minimum is below ``thr`` the result is below ``thr``; otherwise it is
    ``>= thr``. With ``thr < 0`` the exact minimum (to ``DIST_TOL_M``) is returned.
    ``box[k]`` = (xmin, xmax, ymin, ymax, zmax) of the piece.
    """
    return _c.seg_piece_dist(
        float(ax), float(ay), float(az), float(bx), float(by), float(bz), int(k),
        _f64(poly_xy), _i64(poly_n), _f64(poly_h), _f64(circ), _f64(box), float(thr),
    )  # fmt: skip


def segment_free(
    ax: float, ay: float, az: float, bx: float, by: float, bz: float, W: KernelWorld, margin: float
) -> bool:
    """True when segment a→b lies inside the bounds and keeps ``margin`` from every piece.

    ``W``: the world (:attr:`uavplan.world.World.kernel_args`). The bounds are convex:
    half-planes ``hp[i, 0]·x + hp[i, 1]·y <= hp[i, 2]`` and ``zlim[0] <= z <= zlim[1]``, so
    checking both endpoints suffices. Pieces are found through a uniform grid of cells; a
    piece spanning several cells is tested once (in the first cell it shares with the
    segment's box).
    """
    return _c.segment_free(
        float(ax), float(ay), float(az), float(bx), float(by), float(bz), W,
        float(margin),
    )  # fmt: skip


def segments_free(
    p0: np.ndarray, p1: np.ndarray, W: KernelWorld, margin: float, threads: int = 1
) -> np.ndarray:
    """Batch of :func:`segment_free`; ``p0``, ``p1``: (n, 3). A long batch is shared among
    ``threads`` threads (the same answers)."""
    p0 = _f64(p0)
    out = np.empty(p0.shape[0], dtype=np.bool_)
    _c.segments_free(p0, _f64(p1), W, float(margin), out, int(threads))
    return out


def largest_free_fraction(
    p: np.ndarray,
    step: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    W: KernelWorld,
    margin: float,
    bisections: int,
) -> float:
    """The largest f in [0, 1] with a → p + f·step → b free (both segments): 1.0 when it is,
    else ``bisections`` halvings of [0, 1] that keep the free end."""
    return float(
        _c.largest_free_fraction(
            _f64(p), _f64(step), _f64(a), _f64(b), W, float(margin), int(bisections)
        )
    )


def farthest_visible(p: np.ndarray, W: KernelWorld, margin: float) -> np.ndarray:
    """Indices of the greedy farthest-reachable chain through the polyline ``p`` (n, 3):
    from each kept node the last later node whose segment is free (the next one when none
    is), starting at 0 and ending at n − 1."""
    p = _f64(p)
    keep = np.empty(max(p.shape[0], 1), dtype=np.int64)
    count = _c.farthest_visible(p, W, float(margin), keep)
    return keep[:count].copy()


def points_clearance(p: np.ndarray, W: KernelWorld) -> tuple[np.ndarray, np.ndarray]:
    """Exact distance from each point (n, 3) to the nearest piece, and that piece's index."""
    p = _f64(p)
    dist = np.full(p.shape[0], np.inf)
    which = np.full(p.shape[0], -1, dtype=np.int64)
    _c.points_clearance(p, W, dist, which)
    return dist, which


def segments_clearance(
    p0: np.ndarray, p1: np.ndarray, W: KernelWorld
) -> tuple[np.ndarray, np.ndarray]:
    """Exact minimum distance from each segment p0[i]→p1[i] to the nearest piece."""
    p0 = _f64(p0)
    dist = np.full(p0.shape[0], np.inf)
    which = np.full(p0.shape[0], -1, dtype=np.int64)
    _c.segments_clearance(p0, _f64(p1), W, dist, which)
    return dist, which


#: at most about this many cells in a world's lookup grid (8 bytes each, plus the items)
MAX_GRID_CELLS = 4_000_000


def build_cells(
    box: np.ndarray, pad: float, cell: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Uniform grid over the pieces' boxes grown by ``pad``: (gmeta, cell_start, cell_items,
    piece_cells). gmeta = (x0, y0, cell, nx, ny, pad). A query grows its own box by the
    margin, so ``pad`` may be 0: a piece within the margin shares a cell with the query."""
    box = _f64(box)
    npieces = box.shape[0]
    gmeta = np.zeros(6)
    if npieces == 0:
        return gmeta, np.zeros(1, np.int64), np.zeros(0, np.int64), np.zeros((0, 4), np.int64)
    x0 = float(box[:, 0].min()) - pad
    y0 = float(box[:, 2].min()) - pad
    x1 = float(box[:, 1].max()) + pad
    y1 = float(box[:, 3].max()) + pad
    # pieces scattered over a wide area (obstacles far outside the flight volume, a fence
    # polygon thousands of km long) would need billions of cells: coarser cells instead,
    # which only makes a query test more pieces
    cell = max(cell, math.sqrt((x1 - x0) * (y1 - y0) / MAX_GRID_CELLS))
    nx = math.floor((x1 - x0) / cell) + 1
    ny = math.floor((y1 - y0) / cell) + 1
    piece_cells = np.empty((npieces, 4), np.int64)
    counts = np.zeros(nx * ny + 1, np.int64)
    _c.cells_count(box, float(pad), x0, y0, float(cell), nx, ny, piece_cells, counts)
    cell_start = np.cumsum(counts)
    cell_items = np.empty(int(cell_start[-1]), np.int64)
    _c.cells_fill(piece_cells, ny, cell_start, cell_items)
    gmeta[:] = (x0, y0, cell, nx, ny, pad)
    return gmeta, cell_start, cell_items, piece_cells
