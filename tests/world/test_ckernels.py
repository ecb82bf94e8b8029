"""The compiled C kernels (uavplan._ckernels) against small pure-Python references: the
geometry primitives, the cell grid, the random streams, the energy, and that a whole
``uavplan plan`` runs on the extension without numba."""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from uavplan import _ckernels, _geom
from uavplan.obstacles import BoxObstacle, CylinderObstacle, PrismObstacle
from uavplan.path import energy
from uavplan.planners import _kernels as K
from uavplan.planners.proposal import Draw
from uavplan.world import World

ROOT = Path(__file__).resolve().parents[2]
BOUNDS = ((-300.0, 300.0), (-300.0, 300.0), (0.0, 200.0))


def sample_world(margin_m: float = 5.0) -> World:
    return World.build(
        [
            BoxObstacle((0.0, 0.0), (40.0, 20.0), 50.0),
            CylinderObstacle((100.0, 50.0), 15.0, 80.0),
            PrismObstacle(((-150.0, -100.0), (-90.0, -110.0), (-100.0, -40.0)), 35.0),
        ],
        bounds_xyz=BOUNDS,
        margin_m=margin_m,
    )


# -- pure-Python references --------------------------------------------------------------------


def ref_point_polygon(px: float, py: float, verts: list[tuple[float, float]]) -> float:
    inside = True
    best = math.inf
    n = len(verts)
    for i in range(n):
        (ax, ay), (bx, by) = verts[i], verts[(i + 1) % n]
        if (bx - ax) * (py - ay) - (by - ay) * (px - ax) < 0.0:
            inside = False
        ex, ey = bx - ax, by - ay
        den = ex * ex + ey * ey
        t = 0.0 if den <= 0 else min(1.0, max(0.0, ((px - ax) * ex + (py - ay) * ey) / den))
        best = min(best, (px - ax - t * ex) ** 2 + (py - ay - t * ey) ** 2)
    return 0.0 if inside else math.sqrt(best)


def ref_splitmix(seed: int, n: int) -> list[int]:
    mask = (1 << 64) - 1
    out = []
    st = seed
    for _ in range(n):
        st = (st + 0x9E3779B97F4A7C15) & mask
        z = st
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & mask
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & mask
        out.append(z ^ (z >> 31))
    return out


def ref_polyline_energy(p: np.ndarray, k0: float, k1: float, mu0: float, k2: float):
    length = turn = climb = 0.0
    prev = None
    for i in range(1, len(p)):
        d = p[i] - p[i - 1]
        seg = math.sqrt(float(d @ d))
        if seg <= 1e-12:
            continue
        length += seg
        climb += abs(d[2])
        if prev is not None:
            turn += 1.0 - float(prev[0] @ d) / (prev[1] * seg)
        prev = (d, seg)
    return k0 * length, k1 * mu0 * turn, k2 * climb


# -- geometry ----------------------------------------------------------------------------------


def test_point_polygon_distance_matches_reference() -> None:
    rng = np.random.default_rng(1)
    verts = [(0.0, 0.0), (30.0, -5.0), (40.0, 20.0), (5.0, 25.0)]
    arr = np.array(verts + [(0.0, 0.0)] * 3)  # padded like the world's arrays
    for _ in range(300):
        px, py = rng.uniform(-30, 70, 2)
        assert _geom.point_polygon_dist2d(px, py, arr, 4) == pytest.approx(
            ref_point_polygon(px, py, verts), abs=1e-12
        )


@pytest.mark.slow
def test_point_and_segment_piece_distances_match_dense_sampling() -> None:
    w = sample_world()
    rng = np.random.default_rng(2)
    n_pieces = w.box.shape[0]
    for _ in range(60):
        a = rng.uniform((-250, -250, 0), (250, 250, 150))
        b = rng.uniform((-250, -250, 0), (250, 250, 150))
        k = int(rng.integers(n_pieces))
        args = (w.poly_xy, w.poly_n, w.poly_h, w.circ)
        ts = np.linspace(0.0, 1.0, 2001)
        sampled = min(_geom.point_piece_dist(*(a + t * (b - a)), k, *args) for t in ts)
        exact = _geom.seg_piece_dist(*a, *b, k, *args, w.box, -1.0)
        # golden section on a convex function: never above the samples, and close to them
        assert exact <= sampled + 1e-6
        assert exact >= sampled - np.linalg.norm(b - a) / 2000
        # the yes/no form answers on the right side of the threshold
        thr = 10.0
        early = _geom.seg_piece_dist(*a, *b, k, *args, w.box, thr)
        assert (early < thr) == (exact < thr - 1e-6) or abs(exact - thr) < 1e-6


def test_segments_free_agrees_with_exact_clearance() -> None:
    w = sample_world(margin_m=5.0)
    rng = np.random.default_rng(3)
    p0 = rng.uniform((-280, -280, 1), (280, 280, 190), (400, 3))
    p1 = rng.uniform((-280, -280, 1), (280, 280, 190), (400, 3))
    free = _geom.segments_free(p0, p1, w.kernel_args, 5.0)
    dist, _ = _geom.segments_clearance(p0, p1, w.kernel_args)
    clear = np.abs(dist - 5.0) > 1e-6  # away from the boundary case
    assert np.array_equal(free[clear], (dist >= 5.0)[clear])
    one = [_geom.segment_free(*p0[i], *p1[i], w.kernel_args, 5.0) for i in range(20)]
    assert one == list(free[:20])


def cylinders(rng: np.random.Generator, count: int) -> list[CylinderObstacle]:
    """``count`` cylinders 3-12 m in radius, 60 m tall, anywhere in the sample bounds."""
    centres = rng.uniform(-260.0, 260.0, (count, 2))
    return [CylinderObstacle(tuple(c), float(rng.uniform(3.0, 12.0)), 60.0) for c in centres]


def cylinder_field(rng: np.random.Generator, count: int) -> World:
    return World.build(cylinders(rng, count), bounds_xyz=BOUNDS, margin_m=5.0)


def test_segments_free_long_and_short_legs_in_a_crowded_world() -> None:
    """Many pieces on a cell grid: short segments go through the cells, long ones (a box
    over more cells than there are pieces) through the pieces; both agree with the exact
    clearance."""
    rng = np.random.default_rng(11)
    w = cylinder_field(rng, 80)
    assert w.kernel_args.gmeta[3] > 1  # a cell grid is in use
    p0 = rng.uniform((-280, -280, 1), (280, 280, 100), (600, 3))
    p1 = np.vstack([rng.uniform((-280, -280, 1), (280, 280, 100), (300, 3)),
                    p0[300:] + rng.normal(0.0, 15.0, (300, 3))])  # fmt: skip
    p1 = np.clip(p1, (-290, -290, 1), (290, 290, 190))
    free = _geom.segments_free(p0, p1, w.kernel_args, 5.0)
    dist, _ = _geom.segments_clearance(p0, p1, w.kernel_args)
    clear = np.abs(dist - 5.0) > 1e-6
    assert np.array_equal(free[clear], (dist >= 5.0)[clear])
    assert free[:300].any() and not free[:300].all() and free[300:].any()


def test_segment_clearances_are_the_least_over_every_piece_and_name_the_first_of_them() -> None:
    """The exact clearance starts from the pieces in the segment's own cells: the distance
    and the nearest piece (the first in index order among equal ones, here a row of equal
    boxes) are still the least over every piece, short and long segments alike."""
    rng = np.random.default_rng(13)
    row = [BoxObstacle((x, 290.0), (10.0, 10.0), 55.0) for x in (-200.0, -100.0, 0.0, 100.0)]
    w = World.build([*row, *cylinders(rng, 120)], bounds_xyz=BOUNDS, margin_m=5.0)
    p0 = rng.uniform((-280, -280, 1), (280, 280, 100), (150, 3))
    p1 = np.vstack([p0[:75] + rng.normal(0.0, 20.0, (75, 3)),
                    rng.uniform((-280, -280, 1), (280, 280, 100), (75, 3))])  # fmt: skip
    # a segment high over the row of equal boxes, as far from each of them
    p0 = np.vstack([p0, [[-250.0, 290.0, 70.0]]])
    p1 = np.vstack([p1, [[250.0, 290.0, 70.0]]])
    dist, which = _geom.segments_clearance(p0, p1, w.kernel_args)
    args = (w.poly_xy, w.poly_n, w.poly_h, w.circ, w.box)
    for i in range(len(p0)):
        d = [_geom.seg_piece_dist(*p0[i], *p1[i], k, *args, -1.0) for k in range(len(w.box))]
        assert dist[i] == min(d)
        assert which[i] == int(np.argmin(d))
    assert dist[-1] == pytest.approx(15.0) and w.owner[which[-1]] == 0


def test_a_long_batch_of_segment_tests_shared_among_threads_gives_the_same_answers() -> None:
    rng = np.random.default_rng(12)
    w = cylinder_field(rng, 300)
    p0 = rng.uniform((-280, -280, 1), (280, 280, 100), (1001, 3))
    p1 = rng.uniform((-280, -280, 1), (280, 280, 100), (1001, 3))
    one = _geom.segments_free(p0, p1, w.kernel_args, 5.0, 1)
    assert one.any() and not one.all()
    for threads in (2, 3, 8, 50):
        assert np.array_equal(_geom.segments_free(p0, p1, w.kernel_args, 5.0, threads), one)
    assert np.array_equal(w.segments_free(p0, p1), one)
    short = _geom.segments_free(p0[:10], p1[:10], w.kernel_args, 5.0, 4)
    assert np.array_equal(short, one[:10])


def _placed_beside(a: np.ndarray, b: np.ndarray, rng: np.random.Generator, gap: float):
    """A box of random size and yaw beside the leg a→b (plan view), ``gap`` from it."""
    from shapely.geometry import LineString, Polygon

    size = (float(rng.uniform(4.0, 90.0)), float(rng.uniform(4.0, 30.0)))
    yaw = float(rng.uniform(0.0, 180.0))
    run = b[:2] - a[:2]
    normal = np.array([-run[1], run[0]]) / np.linalg.norm(run) * rng.choice([-1.0, 1.0])
    at = a[:2] + rng.uniform(0.0, 1.0) * run
    leg = LineString([tuple(a[:2]), tuple(b[:2])])

    def box(shift: float) -> BoxObstacle:
        c = at + shift * normal
        return BoxObstacle((float(c[0]), float(c[1])), size, 60.0, yaw)

    lo, hi = 0.0, 200.0  # the footprint's distance from the leg grows with the shift
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        d = leg.distance(Polygon(box(mid).footprint()))
        lo, hi = (mid, hi) if d < gap else (lo, mid)
    return box(hi)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.slow
def test_a_long_leg_walks_its_corridor_and_misses_no_piece_within_the_margin(seed: int) -> None:
    """A long leg over a crowded grid (its box spans far more cells than the pieces near it)
    is tested against the cells along it only: a piece the leg passes within the margin,
    just inside it on either side anywhere along the leg, in any direction and spanning
    several cells, is still found; one just outside it is not (the leg keeps the margin).
    The exact clearance over every piece (no grid) is the reference."""
    rng = np.random.default_rng(100 + seed)
    margin = 5.0
    for _ in range(40):
        a = rng.uniform((-280, -280, 20), (-150, 280, 40))
        b = rng.uniform((150, -280, 20), (280, 280, 40))
        if rng.random() < 0.5:
            a, b = b, a
        if rng.random() < 0.2:
            b[0] = a[0] + rng.normal(0.0, 0.5)  # nearly north-south
        run = b[:2] - a[:2]
        gap = rng.uniform(0.5, 0.99) * margin if rng.random() < 0.5 else 1.01 * margin
        near = _placed_beside(a, b, rng, gap)
        # clutter away from the leg: small pieces everywhere, so the leg's box spans
        # hundreds of cells while its corridor holds a few dozen
        clutter = []
        while len(clutter) < 1500:
            c = rng.uniform(-290.0, 290.0, 2)
            s = a[:2] + np.clip(np.dot(c - a[:2], run) / np.dot(run, run), 0, 1) * run
            if np.linalg.norm(c - s) > 3 * margin + 4.0:
                clutter.append(CylinderObstacle((float(c[0]), float(c[1])), 2.0, 60.0))
        w = World.build([*clutter, near], bounds_xyz=BOUNDS, margin_m=margin)
        assert w.kernel_args.gmeta[3] > 20 and w.kernel_args.gmeta[4] > 20
        free = bool(_geom.segments_free(a[None, :], b[None, :], w.kernel_args, margin)[0])
        dist, _ = _geom.segments_clearance(a[None, :], b[None, :], w.kernel_args)
        assert dist[0] == pytest.approx(gap, abs=1e-6)
        assert free == (gap >= margin), (a, b, gap)


def ref_farthest_visible(p: np.ndarray, w: World) -> list[int]:
    """Node simplification as first written: test every later node, jump to the largest
    free one (the next node when none is)."""
    keep, i, n = [0], 0, p.shape[0]
    while i < n - 1:
        later = np.arange(i + 1, n)
        free = w.segments_free(np.repeat(p[i : i + 1], later.size, axis=0), p[later])
        i = int(later[free].max()) if free.any() else i + 1
        keep.append(i)
    return keep


@pytest.mark.parametrize("seed", range(6))
def test_farthest_visible_matches_testing_every_later_node(seed: int) -> None:
    w = sample_world(margin_m=5.0)
    rng = np.random.default_rng(seed)
    # random walks through the obstacles, some with blocked steps (the guard case)
    n = int(rng.integers(1, 60))
    steps = rng.normal(0.0, 30.0, (n, 3)) * (1.0, 1.0, 0.3)
    p = np.clip(rng.uniform((-250, -250, 10), (250, 250, 150)) + np.cumsum(steps, axis=0),
                (-290, -290, 1), (290, 290, 190))  # fmt: skip
    got = w.farthest_visible(p).tolist()
    assert got == ref_farthest_visible(p, w)
    assert got[0] == 0 and got[-1] == n - 1


def test_cell_grid_lists_every_piece_in_every_cell_it_overlaps() -> None:
    rng = np.random.default_rng(4)
    lo = rng.uniform(-500, 400, (50, 2))
    size = rng.uniform(1, 120, (50, 2))
    box = np.column_stack([lo[:, 0], lo[:, 0] + size[:, 0], lo[:, 1], lo[:, 1] + size[:, 1],
                           rng.uniform(5, 50, 50)])  # fmt: skip
    gmeta, start, items, piece_cells = _geom.build_cells(box, 2.0, 37.0)
    x0, y0, cell, nx, ny = gmeta[0], gmeta[1], gmeta[2], int(gmeta[3]), int(gmeta[4])
    assert x0 == box[:, 0].min() - 2.0 and y0 == box[:, 2].min() - 2.0
    assert start.shape == (nx * ny + 1,) and start[-1] == items.shape[0]
    expected: dict[int, list[int]] = {c: [] for c in range(nx * ny)}
    for k in range(box.shape[0]):
        a0 = max(0, math.floor((box[k, 0] - 2.0 - x0) / cell))
        a1 = min(nx - 1, math.floor((box[k, 1] + 2.0 - x0) / cell))
        b0 = max(0, math.floor((box[k, 2] - 2.0 - y0) / cell))
        b1 = min(ny - 1, math.floor((box[k, 3] + 2.0 - y0) / cell))
        assert list(piece_cells[k]) == [a0, a1, b0, b1]
        for cx in range(a0, a1 + 1):
            for cy in range(b0, b1 + 1):
                expected[cx * ny + cy].append(k)
    for c, ks in expected.items():
        assert list(items[start[c] : start[c + 1]]) == ks


def test_points_clearance_is_the_minimum_over_pieces() -> None:
    w = sample_world()
    rng = np.random.default_rng(5)
    p = rng.uniform((-250, -250, 0), (250, 250, 150), (100, 3))
    dist, which = _geom.points_clearance(p, w.kernel_args)
    args = (w.poly_xy, w.poly_n, w.poly_h, w.circ)
    for i in range(p.shape[0]):
        each = [_geom.point_piece_dist(*p[i], k, *args) for k in range(w.box.shape[0])]
        assert dist[i] == min(each)
        assert which[i] == int(np.argmin(each))


STRUCTURES = {
    "world": _geom.KernelWorld,
    "reach": K.Reach,
    "energy": energy.EnergyArgs,
    "cache": K.EnergyCache,
    "setup": K.StepSetup,
    "draws": K.StepDraws,
}


@pytest.mark.parametrize("name", sorted(STRUCTURES))
def test_every_named_structure_has_the_fields_the_kernels_read(name: str) -> None:
    """The kernels read their structures by field name (``_ckernels.FIELDS``, the tables of
    uavplan/_csrc/args.c); the Python class of each has exactly those fields."""
    read = {field for field, _kind, _ndim, _writable in _ckernels.FIELDS[name]}
    cls = STRUCTURES[name]
    fields = cls._fields if issubclass(cls, tuple) else [f.name for f in dataclasses.fields(cls)]
    assert read == set(fields)
    assert set(_ckernels.FIELDS) == set(STRUCTURES)


def test_the_world_is_read_by_name_not_by_position() -> None:
    """Any object with the world's fields will do, in any order; no tuple slot is read."""
    w = sample_world()
    names = [f.name for f in dataclasses.fields(_geom.KernelWorld)]
    shuffled = SimpleNamespace(**{n: getattr(w.kernel_args, n) for n in reversed(names)})
    rng = np.random.default_rng(2)
    p0, p1 = rng.uniform(-200.0, 200.0, (2, 30, 3)) * [1.0, 1.0, 0.3] + [0.0, 0.0, 60.0]
    out = np.empty(30, np.bool_)
    _ckernels.segments_free(p0, p1, shuffled, 5.0, out)
    assert np.array_equal(out, _geom.segments_free(p0, p1, w.kernel_args, 5.0))
    assert 0 < out.sum() < 30


def test_structures_bring_arrays_to_the_kernels_dtypes_but_never_copy_an_output() -> None:
    w = sample_world()
    world = dataclasses.replace(w.kernel_args, zlim=[0.0, 150.0])  # a list: converted once
    assert world.zlim.dtype == np.float64 and world.zlim.flags.c_contiguous
    cache = K.new_energy_cache(4, 8)
    with pytest.raises(TypeError, match=r"cache\.values"):  # a copy would lose the kernel's writes
        K.EnergyCache(cache.filled, cache.values.astype(np.float32), cache.paths)
    with pytest.raises(TypeError, match=r"cache\.filled"):
        K.EnergyCache(cache.filled[::2], cache.values, cache.paths)


def test_the_constants_are_the_kernels_own() -> None:
    """Read from the module, never written down twice (kernels.h is their one place)."""
    assert (K.SPSA_START_END, K.SPSA_LITERAL, K.SPSA_POP_INDEX, K.SPSA_ESCAPE,
            K.SPSA_OSCILLATE) == (1, 2, 4, 8, 16)  # fmt: skip
    assert [int(d) for d in Draw] == [K.DRAW_NONE, K.DRAW_UNIFORM, K.DRAW_SYMMETRIC,
                                      K.DRAW_NORMAL] == [0, 1, 2, 3]  # fmt: skip
    assert K.new_memo().size == 1 << _ckernels.MEMO_BITS
    assert K.STEP_THREADS_MAX == _ckernels.STEP_MAX_THREADS >= K.STEP_THREADS_AUTO_MAX
    assert K.SPSA_EPS == 1e-50 and _geom.DIST_TOL_M == 1e-7
    assert K.HAVE_THREADS == bool(_ckernels.HAVE_THREADS)


def test_wrong_arrays_raise_clear_errors_not_crashes() -> None:
    w = sample_world()
    p = np.zeros((3, 3), dtype=np.float32)
    with pytest.raises(TypeError, match="float64"):
        _ckernels.segments_free(p, p, w.kernel_args, 1.0, np.empty(3, np.bool_))
    with pytest.raises(ValueError, match="segments_free"):
        _ckernels.segments_free(np.zeros((3, 3)), np.zeros((2, 3)), w.kernel_args, 1.0,
                                np.empty(3, np.bool_))  # fmt: skip
    with pytest.raises(IndexError):
        _geom.point_piece_dist(0.0, 0.0, 0.0, 99, w.poly_xy, w.poly_n, w.poly_h, w.circ)
    with pytest.raises(TypeError, match="world"):
        _ckernels.segment_free(0.0, 0.0, 0.0, 1.0, 1.0, 1.0, (w.poly_xy,), 1.0)
    with pytest.raises(TypeError, match="poly_n"):  # a field missing: named in the message
        _ckernels.segment_free(
            0.0, 0.0, 0.0, 1.0, 1.0, 1.0, SimpleNamespace(poly_xy=w.poly_xy), 1.0
        )


# -- random streams ----------------------------------------------------------------------------


def test_splitmix_stream_matches_reference() -> None:
    for seed in (0, 1, 2**63 + 12345, 2**64 - 1):
        assert _ckernels.stream_draws(seed, -1, 50) == ref_splitmix(seed, 50)
        uniform = _ckernels.stream_draws(seed, K.DRAW_UNIFORM, 50)
        assert uniform == [(z >> 11) * (1.0 / 9007199254740992.0) for z in ref_splitmix(seed, 50)]


def test_ziggurat_tables_match_the_python_construction() -> None:
    kn, wn, fn = K._ziggurat_tables()
    ckn, cwn, cfn = _ckernels.ziggurat_tables()
    assert list(kn) == list(ckn) and list(wn) == list(cwn) and list(fn) == list(cfn)


def test_normal_draws_look_standard_normal() -> None:
    x = np.array(_ckernels.stream_draws(99, K.DRAW_NORMAL, 200_000))
    assert abs(x.mean()) < 0.01 and abs(x.std() - 1.0) < 0.01
    assert abs(np.mean(np.abs(x) > 3.442619855899) - 5.76e-4) < 3e-4  # the tail is sampled
    sym = np.array(_ckernels.stream_draws(5, K.DRAW_SYMMETRIC, 10_000))
    assert sym.min() >= -1.0 and sym.max() < 1.0
    assert _ckernels.stream_draws(5, K.DRAW_NONE, 3) == [0.0, 0.0, 0.0]


# -- energy ------------------------------------------------------------------------------------


def test_polyline_energy_matches_reference() -> None:
    rng = np.random.default_rng(6)
    p = np.cumsum(rng.normal(0, 10, (40, 3)), axis=0)
    p[10] = p[9]  # a zero-length segment is skipped
    got = energy.polyline_energy(p, 1.0, 2.0, 0.5, 3.0)
    assert got == pytest.approx(ref_polyline_energy(p, 1.0, 2.0, 0.5, 3.0), rel=1e-12)
    assert energy.polyline_energy(np.zeros((0, 3)), 1.0, 1.0, 1.0, 1.0) == (0.0, 0.0, 0.0)


def test_thomas_factors_solve_the_spline_system() -> None:
    cp, den = energy._thomas_factors(6)
    assert den[0] == 4.0 and cp[0] == 0.25
    assert all(den[i] == 4.0 - cp[i - 1] for i in range(1, 6))


# -- the whole command -------------------------------------------------------------------------


@pytest.mark.slow
def test_plan_runs_on_the_extension_without_numba(tmp_path: Path) -> None:
    out = tmp_path / "env1.plan"
    code = (
        "import sys; from click.testing import CliRunner; from uavplan.cli import main; "
        f"r = CliRunner().invoke(main, ['plan', {str(ROOT / 'missions/paper-env1.yaml')!r}, "
        f"'-o', {str(out)!r}, '--iterations', '20', '--quiet']); "
        "import uavplan._ckernels as c; "
        "print(r.exit_code, 'numba' in sys.modules, 'uavplan._ckernels' in sys.modules, "
        "c.__file__.endswith('.so'))"
    )
    res = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=tmp_path
    )
    assert res.stdout.split() == ["0", "False", "True", "True"], res.stdout + res.stderr
    assert out.stat().st_size > 0


def test_population_energy_matches_a_scipy_spline_reference() -> None:
    from scipy.interpolate import CubicSpline

    rng = np.random.default_rng(8)
    dx, dy, dz, n_sub = 20.0, 5.0, 4.0, 3
    nodes = rng.integers(-6, 7, (5, 9, 2)).astype(float)
    start, goal = np.array([0.0, 30.0]), np.array([10.0, 42.0])
    cols = np.zeros((11, 4))  # straight guide: ignored
    got = energy.population_energy(
        nodes, start, goal, dx, dy, dz, n_sub, 1.0, 2.0, 0.5, 3.0, 0, cols, True
    )
    for g in range(nodes.shape[0]):
        ys = np.concatenate([[start[0]], nodes[g, :, 0] * dy, [goal[0]]])
        zs = np.concatenate([[start[1]], nodes[g, :, 1] * dz, [goal[1]]])
        x = np.arange(ys.shape[0]) * dx
        xs = np.linspace(0.0, x[-1], (ys.shape[0] - 1) * n_sub + 1)
        pts = np.column_stack(
            [
                xs,
                CubicSpline(x, ys, bc_type="natural")(xs),
                CubicSpline(x, zs, bc_type="natural")(xs),
            ]
        )
        assert got[g] == pytest.approx(sum(ref_polyline_energy(pts, 1.0, 2.0, 0.5, 3.0)), rel=1e-9)


def test_node_free_agrees_with_the_exact_segment_test() -> None:
    from uavplan.config import EnergyWeights, GridSpec
    from uavplan.planners.base import PathProblem

    w = sample_world(margin_m=5.0)
    problem = PathProblem.build(
        w, (-250.0, 0.0, 20.0), (250.0, 10.0, 30.0), GridSpec(), EnergyWeights(), 0
    )
    reach = problem.reach
    rng = np.random.default_rng(9)
    n_inner = problem.n_inner
    dy, dz = problem.steps[1], problem.steps[2]
    free_count = 0
    for _ in range(300):
        j = int(rng.integers(2, n_inner))  # interior columns: one segment each
        y0, y1 = (float(v) for v in rng.integers(-8, 9, 2))
        z0, z1 = (float(v) for v in rng.integers(1, 12, 2))
        cols = problem.frame.cols
        p0 = [cols[j - 1, 0] + y0 * dy * cols[j - 1, 2], cols[j - 1, 1] + y0 * dy * cols[j - 1, 3],
              z0 * dz]  # fmt: skip
        p1 = [cols[j, 0] + y1 * dy * cols[j, 2], cols[j, 1] + y1 * dy * cols[j, 3], z1 * dz]
        # the problem's world is in the path frame, with the problem's margin
        seg = (np.array([p0]), np.array([p1]))
        free = bool(_geom.segments_free(*seg, reach.world, reach.margin)[0])
        assert K.node_free(j, y0, z0, y1, z1, reach) == free
        status = K.node_status(
            j, y0, z0, y1, z1, reach.cols, dy, dz, K.margin_limit(reach.margin), reach.table,
            reach.table_off, reach.memo,
        )  # fmt: skip
        assert status in (-1, 0, 1)
        if status >= 0:
            assert status == int(free)
        free_count += free
    assert 0 < free_count < 300  # both answers were exercised


def test_grid_rounding_is_floor_of_v_plus_half_to_the_bit() -> None:
    """The kernels round proposals with a truncation-based floor (no library call): it must
    give ``_kernels._round``'s value, sign of zero included, for every input: halves,
    integers, tiny and huge values, the clamp, NaN and infinities."""
    rng = np.random.default_rng(7)
    special = [
        0.0, -0.0, 0.5, -0.5, 1.5, -1.5, 2.5, -2.5, 0.49999999999999994, -0.49999999999999994,
        -1e-300, 1e-300, 3.0, -3.0, 999_999.5, -999_999.5, 1e6, -1e6, 1e6 + 1, -1e6 - 1,
        1e300, -1e300, math.inf, -math.inf, math.nan, -0.5000000000000001, 0.5000000000000001,
    ]  # fmt: skip
    values = np.concatenate([
        special,
        rng.uniform(-50.0, 50.0, 20_000),
        rng.integers(-2000, 2000, 2_000) + 0.5,
        rng.integers(-2000, 2000, 2_000).astype(float),
        rng.uniform(-2e6, 2e6, 2_000),
    ])  # fmt: skip
    got = np.empty_like(values)
    _ckernels.round_grid(values, got)
    want = np.array([K._round(float(v)) for v in values])
    assert got.tobytes() == want.tobytes()
