"""Every SPSA stage on small hand-made cases (paper sections 4.1–4.5).

Worlds here are tiny (a few hundred metres, one or two obstacles) so each test runs in
milliseconds once the kernels are compiled.
"""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pytest

from uavplan.config import EnergyWeights, GridSpec, SearchParams, SpsaParams
from uavplan.obstacles import BoxObstacle, CylinderObstacle
from uavplan.outcome import SearchEnd
from uavplan.path import post
from uavplan.path.energy import energy_terms
from uavplan.path.post import refine, resample_waypoints, simplify, smooth_route, tighten
from uavplan.planners import _kernels as K
from uavplan.planners.base import PathProblem
from uavplan.planners.proposal import Draw, Proposal
from uavplan.planners.sparrow import SparrowPlanner, SsaPlanner, oscillate
from uavplan.world import World

GRID = GridSpec(20.0, 20.0, 10.0)
W = EnergyWeights()


def make_problem(
    *obstacles, length: float = 400.0, margin: float = 10.0, smoothing: int = 0
) -> PathProblem:
    world = World.build(
        list(obstacles),
        bounds_xyz=((-50.0, length + 50.0), (-300.0, 300.0), (0.0, 200.0)),
        margin_m=margin,
    )
    return PathProblem.build(world, (0.0, 0.0, 30.0), (length, 0.0, 30.0), GRID, W, smoothing)


OPEN = make_problem()
WALL = make_problem(BoxObstacle((200.0, 0.0), (40.0, 200.0), 150.0))


def dense_clearance(world: World, points: np.ndarray, step: float = 0.5) -> float:
    """Smallest exact point clearance sampled every ``step`` metres along a polyline."""
    samples = []
    for a, b in itertools.pairwise(points):
        n = max(2, int(np.ceil(np.linalg.norm(b - a) / step)) + 1)
        samples.append(a + np.linspace(0.0, 1.0, n)[:, None] * (b - a))
    dist, _ = world.points_clearance(np.vstack(samples))
    return float(dist.min())


# --- 4.1 path initialisation (eq. 8–10) -----------------------------------------------------


def test_initial_paths_are_feasible_and_stay_in_the_eq9_window() -> None:
    search = SearchParams(population=20, init_half_window=3.0)
    nodes, ok, _ = WALL.initial_population(20, search, np.random.default_rng(4))
    assert ok.all()
    assert WALL.feasible(nodes).all()
    # eq. 8–10: |P_{a+1} − P_t| <= Δh (+ rounding) with P_t = P_a + (P_goal − P_a)/m
    prev = np.repeat(WALL.start_u[None], nodes.shape[0], axis=0)
    n_inner = nodes.shape[1]
    for j in range(n_inner):
        m = n_inner + 1 - j
        target = prev + (WALL.goal_u - prev) / m
        assert np.all(np.abs(nodes[:, j] - target) <= 3.0 + 0.5 + 1e-9)
        prev = nodes[:, j]
    assert np.all(nodes == np.round(nodes))  # on the grid


def test_initialisation_is_seeded() -> None:
    search = SearchParams(population=10)
    a = WALL.initial_population(10, search, np.random.default_rng(7))[0]
    b = WALL.initial_population(10, search, np.random.default_rng(7))[0]
    c = WALL.initial_population(10, search, np.random.default_rng(8))[0]
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


def test_walled_in_goal_deadlocks_and_reports_no_path() -> None:
    ring = [
        BoxObstacle((400.0, 60.0), (140.0, 20.0), 190.0),
        BoxObstacle((400.0, -60.0), (140.0, 20.0), 190.0),
        BoxObstacle((340.0, 0.0), (20.0, 140.0), 190.0),
    ]
    world = World.build(
        ring, bounds_xyz=((-50.0, 460.0), (-300.0, 300.0), (0.0, 200.0)), margin_m=10.0
    )
    problem = PathProblem.build(world, (0.0, 0.0, 30.0), (420.0, 0.0, 30.0), GRID, W)
    result = SparrowPlanner(SearchParams(population=6, iterations=5)).solve(problem)
    assert result.termination is SearchEnd.NO_PATH and not result.solved
    assert result.deadlocks > 0
    assert "deadlocked" in result.message


# --- the shared update kernel: reachability, producers, scroungers, escape ------------------


def _population(problem: PathProblem, n: int = 12, seed: int = 3) -> np.ndarray:
    return problem.initial_population(n, SearchParams(population=n), np.random.default_rng(seed))[0]


def _proposal(x: np.ndarray, **fields) -> Proposal:
    """All individuals active, with the given Proposal fields set."""
    prop = Proposal.for_population(x)
    prop.active[:] = True
    for name, value in fields.items():
        getattr(prop, name)[...] = value
    return prop


def _producer_rule(x: np.ndarray, e: float, rule: str) -> Proposal:
    """SPSA's eq. 11 as SparrowPlanner.producers states it, with e = exp(−i/(α·M))."""
    line = OPEN.line_u[1:-1]
    if rule == "best":
        return _proposal(x, anchor=x, spread=line - x, draw=Draw.UNIFORM)
    if rule == "literal":
        return _proposal(x, anchor=x + e, spread=line - x, draw=Draw.UNIFORM)
    d = x - line
    return _proposal(x, anchor=line + d * e, spread=-d, draw=Draw.UNIFORM)


def test_producer_pulls_deviation_toward_the_start_end_line() -> None:
    x = _population(OPEN)
    cand, ok, _ = OPEN.propose(x, _producer_rule(x, 1.0, "best"), 10, np.random.default_rng(0))
    assert ok.all()
    dev_before = np.abs(x - OPEN.line_u[1:-1])
    dev_after = np.abs(cand - OPEN.line_u[1:-1])
    assert np.all(dev_after <= dev_before + 0.5)  # rounding may keep a node where it was
    assert dev_after.sum() < 0.8 * dev_before.sum()


def test_deviation_producer_rule_contracts_and_literal_rule_drifts() -> None:
    x = _population(OPEN, seed=5)
    rng = np.random.default_rng(1)
    dev, _, _ = OPEN.propose(x, _producer_rule(x, 1.0, "deviation"), 10, rng)
    lit, _, _ = OPEN.propose(x, _producer_rule(x, 1.0, "literal"), 10, rng)
    line = OPEN.line_u[1:-1]
    assert np.abs(dev - line).sum() < np.abs(x - line).sum()
    # the literal "+ exp(...)" adds about +1 to every coordinate: a drift upward and left
    assert (lit - x).mean() > (dev - x).mean()


def test_updates_respect_reachability_and_failed_updates_keep_the_old_path() -> None:
    x = _population(WALL, n=16)
    line = WALL.line_u[1:-1]
    prop = _proposal(x, anchor=x, spread=line - x, draw=Draw.UNIFORM)  # into the wall
    cand, ok, _ = WALL.propose(x, prop, 10, np.random.default_rng(2))
    assert WALL.feasible(cand).all()
    assert np.array_equal(cand[~ok], x[~ok])


def test_scrounger_escape_search_finds_reachable_nodes() -> None:
    x = _population(WALL, n=16, seed=11)
    # Q·exp(~0) about the start-end line: onto the line, into the wall
    prop = _proposal(x, anchor=WALL.line_u[1:-1], spread=1.0, draw=Draw.NORMAL)
    rng = np.random.default_rng(3)
    _, ok_off, esc_off = WALL.propose(x, prop, 10, rng)
    prop.escape[:] = True
    cand, ok_on, esc_on = WALL.propose(x, prop, 10, rng)
    assert esc_off == 0 and esc_on > 0
    assert ok_on.sum() >= ok_off.sum()
    assert WALL.feasible(cand).all()


def test_scrounger_near_rule_copies_the_best_producer_with_one_offset() -> None:
    x = _population(OPEN, n=8)
    prop = _proposal(x, anchor=x[0] + np.array([2.0, -1.0]))
    cand, ok, _ = OPEN.propose(x, prop, 10, np.random.default_rng(0))
    assert ok.all()
    assert np.array_equal(cand, np.broadcast_to(x[0] + [2.0, -1.0], cand.shape))


def test_explicit_attempts_are_taken_in_order_until_one_is_reachable() -> None:
    x = _population(WALL, n=4, seed=2)
    prop = Proposal.for_population(x, n_explicit=2)
    prop.active[:] = True
    prop.n_explicit[:] = 2
    prop.explicit[0] = WALL.line_u[1:-1]  # onto the line: into the wall, unreachable
    prop.explicit[1] = x  # the old path: reachable
    cand, ok, _ = WALL.propose(x, prop, 10, np.random.default_rng(0))
    line = np.broadcast_to(WALL.line_u[1:-1], x.shape)
    assert ((cand == x) | (cand == line)).all(axis=-1).all()  # nothing else was proposed
    assert (cand != line).any(axis=(1, 2)).all()  # the line itself is blocked by the wall
    assert WALL.feasible(cand).all() and np.array_equal(cand[~ok], x[~ok])
    counts_before = WALL.reach_checks
    WALL.propose(x, prop, 10, np.random.default_rng(0))
    assert WALL.reach_checks[0] > counts_before[0]  # the budget is counted


# --- 4.4 adaptive oscillation optimisation (eq. 13) -----------------------------------------


def roughness(nodes: np.ndarray) -> float:
    return float((np.diff(nodes, n=2, axis=-2) ** 2).sum())


def test_oscillation_optimisation_smooths_a_zigzag() -> None:
    n = OPEN.n_inner
    zig = np.zeros((1, n, 2))
    zig[0, :, 0] = np.where(np.arange(n) % 2 == 0, 2.0, -2.0)
    zig[0, :, 1] = 3.0
    before = roughness(zig)
    moved = oscillate(OPEN, zig, 5)
    assert moved.sum() > 0
    assert roughness(zig) < 0.2 * before
    assert OPEN.feasible(zig).all()


def test_oscillation_fixed_points_stay_put_and_skipped_paths_are_untouched() -> None:
    x = _population(WALL, n=6, seed=4)
    y = x.copy()
    for _ in range(30):  # iterate eq. 13 to its fixed points
        if oscillate(WALL, y, 5).sum() == 0:
            break
    z = y.copy()
    assert oscillate(WALL, z, 5).sum() == 0 and np.array_equal(z, y)
    w = x.copy()
    skip = np.zeros(6, dtype=bool)
    skip[::2] = True
    moved = oscillate(WALL, w, 5, skip)
    assert np.array_equal(w[skip], x[skip]) and np.all(moved[skip] == 0)


def test_oscillation_keeps_a_path_that_hugs_an_obstacle_feasible() -> None:
    x = _population(WALL, n=10, seed=9)
    y = x.copy()
    oscillate(WALL, y, 5)
    assert WALL.feasible(y).all()
    # and it lowers the fitness of the jagged initial paths
    assert WALL.fitness(y).mean() < WALL.fitness(x).mean()


def ref_oscillate(problem: PathProblem, nodes: np.ndarray, window: int) -> np.ndarray:
    """Eq. 13's repair written out from its description (K.moving_average_repair): node j
    becomes round(mean(P_{j-1}, P_j, ..., P_{j+N_p-2})), the previous node already replaced
    (the start for j = 0), the window cut at the goal; N_p drops by one while the result is
    unreachable, and below 3 the node is kept; an individual whose kept node became
    unreachable is left as it was. In place; returns the nodes moved per individual."""
    reach = problem.reach
    start_y = float(reach.start_m[1]) / float(reach.steps[1])
    start_z = float(reach.start_m[2]) / float(reach.steps[2])
    gy, gz = float(problem.goal_u[0]), float(problem.goal_u[1])
    n = nodes.shape[1]
    moved = np.zeros(nodes.shape[0], dtype=np.int64)
    for g in range(nodes.shape[0]):
        old = nodes[g].copy()
        new = old.copy()
        py = pz = 0.0
        same, ok, count = True, True, 0
        for j in range(n):
            placed = False
            for n_p in range(window, 2, -1):
                ys = [py if j > 0 else start_y]
                zs = [pz if j > 0 else start_z]
                for k in range(j, j + n_p - 1):
                    if k >= n:
                        ys.append(gy)
                        zs.append(gz)
                        break
                    ys.append(old[k, 0])
                    zs.append(old[k, 1])
                sy, sz = ys[0], zs[0]
                for a, b in zip(ys[1:], zs[1:], strict=True):  # left to right, as the kernel
                    sy += a
                    sz += b
                ny, nz = K._round(sy / len(ys)), K._round(sz / len(zs))
                if same and ny == old[j, 0] and nz == old[j, 1]:
                    placed = True
                    break
                if K.node_free(j + 1, py, pz, ny, nz, reach):
                    placed = True
                    break
            if not placed:
                ny, nz = old[j]
                if not same and not K.node_free(j + 1, py, pz, ny, nz, reach):
                    ok = False
                    break
            same = ny == old[j, 0] and nz == old[j, 1]
            count += not same
            new[j] = (ny, nz)
            py, pz = ny, nz
        if ok:
            nodes[g] = new
            moved[g] = count
    return moved


CROWDED = make_problem(
    *[CylinderObstacle((x, y), 18.0, 120.0) for x, y in [(90, 30), (150, -40), (210, 10),
                                                          (270, -20), (330, 40)]]
)  # fmt: skip


@pytest.mark.parametrize("window", [3, 4, 5, 7])
@pytest.mark.parametrize("name", ["wall", "crowded"])
def test_oscillation_kernel_matches_the_equation_written_out(name: str, window: int) -> None:
    problem = {"wall": WALL, "crowded": CROWDED}[name]
    rng = np.random.default_rng(window)
    x = _population(problem, n=16, seed=window)
    # jagged variants too: some nodes pushed off by a few cells
    x[8:] += rng.integers(-3, 4, x[8:].shape)
    got, want = x.copy(), x.copy()
    moved = oscillate(problem, got, window)
    moved_ref = ref_oscillate(problem, want, window)
    assert np.array_equal(got, want)
    assert np.array_equal(moved, moved_ref)
    assert moved.sum() > 0


# --- the whole search: greedy, convergence, seeds, SSA vs SPSA ------------------------------


def test_convergence_is_monotone_and_improves_on_the_initial_population() -> None:
    planner = SparrowPlanner(
        SearchParams(population=12, iterations=60, seed=2), SpsaParams(restarts=1)
    )
    result = planner.solve(WALL, np.random.default_rng(2))
    c = result.convergence
    assert c.shape == (60,)
    assert np.all(np.diff(c) <= 1e-9)
    x0, _, _ = WALL.initial_population(12, planner.search, np.random.default_rng(2))
    assert result.best_fitness < WALL.fitness(x0).min()
    assert WALL.feasible(result.best_nodes[None]).all()


@pytest.mark.parametrize("planner_cls", [SparrowPlanner, SsaPlanner])
def test_search_is_seeded(planner_cls) -> None:
    def run(seed: int):
        return planner_cls(SearchParams(population=10, iterations=30, seed=seed)).solve(
            WALL, np.random.default_rng(seed)
        )

    a, b, c = run(5), run(5), run(6)
    assert np.array_equal(a.best_nodes, b.best_nodes) and a.best_fitness == b.best_fitness
    assert np.array_equal(a.convergence, b.convergence)
    assert not np.array_equal(a.convergence, c.convergence)


def test_restarts_split_the_iterations_and_pool_the_final_populations() -> None:
    planner = SparrowPlanner(SearchParams(population=8, iterations=40), SpsaParams(restarts=4))
    result = planner.solve(WALL, np.random.default_rng(0))
    assert result.stats["rounds"] == 4
    assert result.population.shape[0] == 4 * 8
    assert result.convergence.shape == (40,)
    assert np.all(np.diff(result.convergence) <= 1e-9)


def test_smoothed_fitness_ignores_grid_staircase() -> None:
    """A straight diagonal rounded to the grid is a staircase: the paper's fitness charges it
    for the wiggles of its spline, the smoothed fitness (ours) much less."""
    paper = OPEN
    ours = make_problem(smoothing=2)
    n = OPEN.n_inner
    stair = np.zeros((1, n, 2))
    stair[0, :, 0] = np.round(np.linspace(0, 6, n + 2)[1:-1])
    stair[0, :, 1] = 3.0
    straight = np.hypot(400.0, 120.0)
    assert paper.fitness(stair)[0] - straight > 2 * (ours.fitness(stair)[0] - straight)


# --- 4.5 node simplification, refinement, smoothing -----------------------------------------


def test_simplification_jumps_to_the_farthest_reachable_node() -> None:
    """Figure 4(b): A' sees B', C', D' and F' but not E': it jumps to F' directly."""
    world = World.build(
        [CylinderObstacle((250.0, 60.0), 15.0, 100.0)],
        bounds_xyz=((-10.0, 500.0), (-200.0, 200.0), (0.0, 100.0)),
        margin_m=5.0,
    )
    # E' sits behind the cylinder as seen from A'; F' is visible again
    pts = np.array(
        [[0, 0, 30], [100, 10, 30], [200, 20, 30], [250, 30, 30], [400, 120, 30], [450, 0, 30]],
        dtype=float,
    )
    assert not world.segments_free(pts[:1], pts[4:5])[0]
    assert world.segments_free(pts[:1], pts[5:6])[0]
    assert simplify(pts, world).tolist() == [0, 5]


def test_simplification_figure_4a() -> None:
    """Figure 4(a): A reaches B, C, D only; from D, E and F: A → D → F."""
    world = World.build(
        [BoxObstacle((250.0, 40.0), (60.0, 60.0), 100.0)],
        bounds_xyz=((-10.0, 600.0), (-200.0, 200.0), (0.0, 100.0)),
        margin_m=5.0,
    )
    pts = np.array(
        [[0, 0, 30], [80, 0, 30], [160, 0, 30], [240, -10, 30], [340, 10, 30], [420, 20, 30]],
        dtype=float,
    )
    assert world.segments_free(pts[3:4], pts[4:5])[0]  # D sees E and F ...
    assert not world.segments_free(pts[:1], pts[4:5])[0]  # ... A sees neither
    assert simplify(pts, world).tolist() == [0, 3, 5]


def test_tighten_and_refine_never_raise_energy_and_keep_the_margin() -> None:
    rng = np.random.default_rng(1)
    x = _population(WALL, n=6, seed=21)
    for nodes in x:
        pts = WALL.node_points(nodes)
        v = pts[simplify(pts, WALL.world)]
        e0 = sum(energy_terms(v, W))
        t = tighten(v, WALL.world)
        r = refine(v, WALL.world, W)
        for poly in (t, r):
            assert sum(energy_terms(poly, W)) <= e0 + 1e-6
            assert dense_clearance(WALL.world, poly) >= 10.0 - 1e-3
            assert np.allclose(poly[0], v[0]) and np.allclose(poly[-1], v[-1])
    del rng


def ref_window_energy(p: np.ndarray, w: EnergyWeights) -> np.ndarray:
    """Energy of polylines p (..., k, 3) as the numpy pattern search computed it."""
    d = np.diff(p, axis=-2)
    length = np.linalg.norm(d, axis=-1)
    dots = (d[..., :-1, :] * d[..., 1:, :]).sum(-1)
    turn = 1.0 - dots / np.maximum(length[..., :-1] * length[..., 1:], 1e-12)
    return w.k0 * length.sum(-1) + w.k1 * w.mu0 * turn.sum(-1) + w.k2 * np.abs(d[..., 2]).sum(-1)


def ref_refine_sweeps(vertices: np.ndarray, world: World, w: EnergyWeights) -> np.ndarray:
    """The pattern search of post.refine as first written in numpy (before the subdivided
    polyline is simplified and tightened); equal gains go to the first move."""
    v = post.subdivide(vertices, post.REFINE_LEG_M)
    for step in post.REFINE_STEPS_M:
        for _ in range(post.REFINE_PASSES):
            improved = False
            for k in range(1, v.shape[0] - 1):
                lo, hi = max(0, k - 2), min(v.shape[0], k + 3)
                window = v[lo:hi]
                cand = v[k] + step * post._MOVES
                trial = np.repeat(window[None], cand.shape[0], axis=0)
                trial[:, k - lo] = cand
                gain = ref_window_energy(window, w) - ref_window_energy(trial, w)
                better = np.flatnonzero(gain > 1e-9)
                if better.size == 0:
                    continue
                better = better[np.argsort(-gain[better], kind="stable")]
                n = better.size
                a = np.repeat(v[k - 1 : k], n, axis=0)
                b = np.repeat(v[k + 1 : k + 2], n, axis=0)
                free = world.segments_free(
                    np.vstack([a, cand[better]]), np.vstack([cand[better], b])
                )
                ok = free[:n] & free[n:]
                if ok.any():
                    v[k] = cand[better[int(np.argmax(ok))]]
                    improved = True
            if not improved:
                break
    return v


@pytest.mark.parametrize("weights", [W, EnergyWeights(k0=1.0, k1=40.0, mu0=0.5, k2=3.0)])
def test_compiled_refine_is_the_numpy_pattern_search(weights: EnergyWeights) -> None:
    problem = make_problem(
        BoxObstacle((200.0, 0.0), (40.0, 200.0), 150.0), CylinderObstacle((120.0, 90.0), 30.0, 80.0)
    )
    for nodes in _population(problem, n=6, seed=5):
        pts = problem.node_points(nodes)
        v = pts[simplify(pts, problem.world)]
        got = refine(v, problem.world, weights)
        want = ref_refine_sweeps(v, problem.world, weights)
        want = tighten(want[simplify(want, problem.world)], problem.world)
        assert got.shape == want.shape and np.array_equal(got, want)  # to the bit


def test_smoothing_and_resampling_keep_the_margin_on_every_leg() -> None:
    x = _population(WALL, n=4, seed=8)
    for nodes in x:
        pts = WALL.node_points(nodes)
        v = tighten(pts[simplify(pts, WALL.world)], WALL.world)
        route = smooth_route(v, WALL.world, smooth=True, step_m=5.0)
        for spacing in (30.0, 60.0, 150.0):
            wps = resample_waypoints(route, WALL.world, spacing)
            assert np.allclose(wps[0], v[0]) and np.allclose(wps[-1], v[-1])
            dist, _ = WALL.world.segments_clearance(wps[:-1], wps[1:])
            assert dist.min() >= 10.0 - 1e-6
            for vert in v:  # every vertex of the simplified path is a waypoint
                assert np.min(np.linalg.norm(wps - vert, axis=1)) < 1e-9


def test_spline_smoothing_passes_through_the_vertices() -> None:
    v = np.array([[0, 0, 30], [150, 80, 40], [300, -60, 35], [400, 0, 30]], dtype=float)
    route = smooth_route(v, OPEN.world, smooth=True, step_m=5.0)
    assert np.allclose(route.samples[route.vertex_index], v)
    assert np.all(route.blend == 1.0)  # nothing to dodge in open space
    flat = smooth_route(v, OPEN.world, smooth=False, step_m=5.0)
    assert np.all(flat.blend == 0.0)


def test_ssa_preset_switches_off_spsa_contributions() -> None:
    ssa = SpsaParams.ssa()
    assert not (ssa.start_end_producer or ssa.escape or ssa.oscillation)
    assert ssa.producer_ratio == pytest.approx(0.2)
    assert replace(ssa, escape=True).escape
