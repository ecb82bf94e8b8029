"""The energy fitness (eq. 1–2) and its natural cubic spline (uavplan.path.energy)."""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import CubicSpline

from uavplan.config import EnergyWeights
from uavplan.path.energy import (
    N_SUB,
    EnergyArgs,
    column_spline,
    energy_bounds,
    energy_of,
    energy_terms,
    population_energy,
)

UNIT = EnergyWeights(k0=1.0, k1=1.0, mu0=1.0, k2=1.0)


def terms(points, weights: EnergyWeights = UNIT) -> tuple[float, float, float]:
    return energy_terms(np.array(points, dtype=float), weights)


# --- energy_terms on hand-made polylines ------------------------------------------------------


def test_flat_straight_line() -> None:
    # (0,0) → (30,40) → (60,80): two collinear 50 m legs (3-4-5 triangles) at z = 10
    path, turning, climb = terms([[0, 0, 10], [30, 40, 10], [60, 80, 10]])
    assert path == 100.0
    assert turning == pytest.approx(0.0, abs=1e-15)
    assert climb == 0.0


def test_sloped_straight_line() -> None:
    # 3 equal legs of (20, 0, 15): each 25 m long, 15 m up
    pts = [[0, 0, 0], [20, 0, 15], [40, 0, 30], [60, 0, 45]]
    path, turning, climb = terms(pts)
    assert path == pytest.approx(75.0, abs=1e-12)
    assert turning == pytest.approx(0.0, abs=1e-15)
    assert climb == 45.0


def test_right_angle_corner_costs_k1_mu0() -> None:
    # θ = 90° between the legs: 1 + cos θ = 1 exactly
    corner = [[0, 0, 5], [10, 0, 5], [10, 10, 5]]
    assert terms(corner)[1] == 1.0
    w = EnergyWeights(k0=1.0, k1=3.0, mu0=0.7, k2=1.0)
    assert terms(corner, w)[1] == 3.0 * 0.7 * 1.0
    # a vertical right angle too: level, then straight up
    assert terms([[0, 0, 5], [10, 0, 5], [10, 0, 15]])[1] == 1.0


def test_u_turns_cost_two() -> None:
    # two right angles: 1 + 1
    assert terms([[0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0]])[1] == 2.0
    # straight back: θ = 0, 1 + cos 0 = 2
    assert terms([[0, 0, 0], [10, 0, 0], [0, 0, 0]])[1] == 2.0


def test_45_degree_turn() -> None:
    # heading east, then north-east: θ = 135°, 1 + cos 135° = 1 − √2/2
    turning = terms([[0, 0, 0], [10, 0, 0], [20, 10, 0]])[1]
    assert turning == pytest.approx(1.0 - math.sqrt(2.0) / 2.0, abs=1e-15)


def test_climb_of_a_zigzag_is_the_sum_of_abs_dz() -> None:
    z = [10.0, 25.0, 5.0, 5.0, 40.0, 12.0]
    pts = [[20.0 * i, 0.0, zi] for i, zi in enumerate(z)]
    # |15| + |−20| + 0 + |35| + |−28| = 98
    assert terms(pts)[2] == 98.0
    # the length is the sum of the legs' hypotenuses
    expected = sum(math.hypot(20.0, b - a) for a, b in itertools.pairwise(z))
    assert terms(pts)[0] == pytest.approx(expected, abs=1e-12)


def test_repeated_points_are_skipped() -> None:
    # a zero-length leg has no direction: the corner is still one right angle, and no NaN
    path, turning, climb = terms([[0, 0, 0], [10, 0, 0], [10, 0, 0], [10, 10, 0]])
    assert (path, turning, climb) == (20.0, 1.0, 0.0)
    assert terms([[3, 4, 5]]) == (0.0, 0.0, 0.0)  # one point: nothing flown


def test_weights_scale_each_term() -> None:
    rng = np.random.default_rng(3)
    pts = np.cumsum(rng.normal(0.0, 20.0, (12, 3)), axis=0)
    base = energy_terms(pts, UNIT)
    assert all(t > 0 for t in base)
    w = EnergyWeights(k0=2.0, k1=3.0, mu0=0.5, k2=4.0)
    scaled = energy_terms(pts, w)
    assert scaled[0] == pytest.approx(2.0 * base[0], rel=1e-15)
    assert scaled[1] == pytest.approx(1.5 * base[1], rel=1e-15)
    assert scaled[2] == pytest.approx(4.0 * base[2], rel=1e-15)
    # a zero weight switches its term off
    assert energy_terms(pts, EnergyWeights(k0=0.0, k1=1.0, mu0=0.0, k2=0.0)) == (0.0, 0.0, 0.0)


# --- the natural cubic spline -----------------------------------------------------------------


def random_knots(rng: np.random.Generator, n: int) -> np.ndarray:
    return np.stack([rng.uniform(-200, 200, n), rng.uniform(0, 250, n)], axis=1)


@pytest.mark.parametrize("n_knots", [2, 3, 4, 7, 40])
def test_spline_matches_scipy_natural_cubic_spline(n_knots: int) -> None:
    rng = np.random.default_rng(n_knots)
    knots = random_knots(rng, n_knots)
    dx = 17.5
    samples = column_spline(knots, dx, n_sub=5)
    assert samples.shape == ((n_knots - 1) * 5 + 1, 3)
    x = samples[:, 0]
    assert x == pytest.approx(np.arange(samples.shape[0]) * dx / 5, abs=1e-12)
    x_knots = np.arange(n_knots) * dx
    for axis in (0, 1):
        ref = CubicSpline(x_knots, knots[:, axis], bc_type="natural")
        assert samples[:, axis + 1] == pytest.approx(ref(x), abs=1e-9)


def test_spline_passes_through_the_knots() -> None:
    knots = random_knots(np.random.default_rng(5), 12)
    samples = column_spline(knots, 20.0)
    assert samples[::N_SUB, 1:] == pytest.approx(knots, abs=1e-9)
    assert samples[-1, 1:].tolist() == knots[-1].tolist()


def test_spline_has_zero_second_derivative_at_the_ends() -> None:
    knots = random_knots(np.random.default_rng(9), 9)
    dx = 25.0
    samples = column_spline(knots, dx, n_sub=4)
    for axis in (1, 2):
        # each interval is one cubic: the 4 samples at u = 0, ¼, ½, ¾ determine it exactly
        # (x measured from the end it describes, to keep the fit well conditioned)
        head = np.polyfit(samples[:4, 0], samples[:4, axis], 3)
        tail = np.polyfit(samples[-4:, 0] - samples[-1, 0], samples[-4:, axis], 3)
        curvature_scale = np.abs(np.diff(knots[:, axis - 1], 2)).max() / dx**2
        assert np.polyval(np.polyder(head, 2), 0.0) == pytest.approx(
            0.0, abs=1e-6 * curvature_scale
        )
        assert np.polyval(np.polyder(tail, 2), 0.0) == pytest.approx(
            0.0, abs=1e-6 * curvature_scale
        )
        # ... and inside it is not zero (the ends are special)
        inner = np.polyfit(samples[12:16, 0], samples[12:16, axis], 3)
        assert abs(np.polyval(np.polyder(inner, 2), samples[12, 0])) > 1e-3 * curvature_scale
        ref = CubicSpline(np.arange(9) * dx, knots[:, axis - 1], bc_type="natural")
        assert ref(0.0, 2) == pytest.approx(0.0, abs=1e-12)


def test_spline_of_collinear_knots_is_the_line() -> None:
    knots = np.stack([np.linspace(-40, 60, 8), np.linspace(30, 100, 8)], axis=1)
    samples = column_spline(knots, 20.0)
    x = samples[:, 0]
    assert samples[:, 1] == pytest.approx(-40.0 + 100.0 * x / 140.0, abs=1e-9)
    assert samples[:, 2] == pytest.approx(30.0 + 70.0 * x / 140.0, abs=1e-9)


# --- population_energy ------------------------------------------------------------------------


def straight_cols(n_nodes: int, dx: float) -> np.ndarray:
    """The paper's straight columns: origins (j·dx, 0), normals (0, 1)."""
    cols = np.zeros((n_nodes + 2, 4))
    cols[:, 0] = np.arange(n_nodes + 2) * dx
    cols[:, 3] = 1.0
    return cols


def pop_energy(
    nodes, start_yz, goal_yz, dx, dy, dz, w: EnergyWeights = UNIT, n_sub=N_SUB, straight=True
):
    cols = straight_cols(np.shape(nodes)[1], dx)
    return population_energy(
        np.ascontiguousarray(nodes, dtype=float),
        np.array(start_yz, dtype=float),
        np.array(goal_yz, dtype=float),
        dx,
        dy,
        dz,
        n_sub,
        w.k0,
        w.k1,
        w.mu0,
        w.k2,
        0,
        cols,
        straight,
    )


def test_the_curved_formula_on_straight_columns_is_the_straight_formula() -> None:
    """A guide that happens to be straight gives the paper's energy (to rounding)."""
    rng = np.random.default_rng(5)
    nodes = rng.integers(-3, 4, size=(6, 9, 2)).astype(float)
    a = pop_energy(nodes, (0.0, 30.0), (10.0, 40.0), 20.0, 20.0, 10.0)
    b = pop_energy(nodes, (0.0, 30.0), (10.0, 40.0), 20.0, 20.0, 10.0, straight=False)
    np.testing.assert_allclose(a, b, rtol=1e-9)


def test_population_energy_of_a_straight_path_is_its_length() -> None:
    # D = 10 columns of 20 m; all nodes on the line y = 0, z = 30 m (3 units of dz = 10)
    nodes = np.zeros((1, 9, 2))
    nodes[:, :, 1] = 3.0
    e = pop_energy(nodes, (0.0, 30.0), (0.0, 30.0), 20.0, 20.0, 10.0)
    assert e[0] == pytest.approx(200.0, abs=1e-9)


def test_population_energy_of_a_sloped_straight_path() -> None:
    # from (y, z) = (0, 30) to (90, 130) over 200 m: nodes on the line, in grid units
    d = 10
    t = np.arange(1, d) / d
    nodes = np.stack([90.0 * t / 15.0, (30.0 + 100.0 * t) / 10.0], axis=1)[None]
    e = pop_energy(nodes, (0.0, 30.0), (90.0, 130.0), 20.0, 15.0, 10.0)
    length = math.sqrt(200.0**2 + 90.0**2 + 100.0**2)
    # turning 0, climb 100 m
    assert e[0] == pytest.approx(length + 100.0, abs=1e-9)


def test_population_energy_is_per_individual() -> None:
    rng = np.random.default_rng(0)
    nodes = rng.uniform(-5, 5, (6, 14, 2))
    nodes[:, :, 1] += 10
    whole = pop_energy(nodes, (0.0, 40.0), (0.0, 60.0), 20.0, 20.0, 10.0)
    for g in range(6):
        alone = pop_energy(nodes[g : g + 1], (0.0, 40.0), (0.0, 60.0), 20.0, 20.0, 10.0)
        assert alone[0] == whole[g]
    assert len(set(whole.tolist())) == 6


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    g=st.integers(1, 5),
    d=st.integers(2, 40),
    n_sub=st.integers(1, 6),
    dx=st.floats(1.0, 60.0),
    dy=st.floats(1.0, 30.0),
    dz=st.floats(1.0, 20.0),
    weights=st.tuples(*[st.floats(0.0, 5.0)] * 4),
)
def test_population_energy_matches_energy_of_column_spline(
    seed, g, d, n_sub, dx, dy, dz, weights
) -> None:
    rng = np.random.default_rng(seed)
    w = EnergyWeights(*weights)
    nodes = rng.uniform(-10.0, 10.0, (g, d - 1, 2))
    start_yz = (0.0, rng.uniform(0.0, 100.0))
    goal_yz = (0.0, rng.uniform(0.0, 100.0))
    got = pop_energy(nodes, start_yz, goal_yz, dx, dy, dz, w, n_sub)
    assert got.shape == (g,)
    for i in range(g):
        knots = np.empty((d + 1, 2))
        knots[0], knots[-1] = start_yz, goal_yz
        knots[1:-1, 0] = nodes[i, :, 0] * dy
        knots[1:-1, 1] = nodes[i, :, 1] * dz
        expected = sum(energy_terms(column_spline(knots, dx, n_sub), w))
        assert got[i] == pytest.approx(expected, rel=1e-12, abs=1e-9)


# --- the lower bound greedy selection uses (energy_bounds) -----------------------------------


def energy_args(d, rng, *, dx, dy, dz, n_sub, weights, smooth, straight):
    """The energy's arguments as PathProblem.energy_args builds them: straight columns, or a
    curved guide (origins along a random bend, unit normals)."""
    if straight:
        cols = straight_cols(d - 1, dx)
    else:
        heading = np.cumsum(rng.uniform(-0.4, 0.4, d + 1))
        xy = np.cumsum(np.stack([np.cos(heading), np.sin(heading)], axis=1) * dx, axis=0)
        cols = np.column_stack([xy, -np.sin(heading), np.cos(heading)])
    start_yz = np.array([rng.uniform(-20.0, 20.0), rng.uniform(0.0, 100.0)])
    goal_yz = np.array([rng.uniform(-20.0, 20.0), rng.uniform(0.0, 100.0)])
    k0, k1, mu0, k2 = weights
    return EnergyArgs(start_yz, goal_yz, cols, dx, dy, dz, n_sub, k0, k1, mu0, k2, smooth, straight)


@settings(max_examples=80, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    d=st.integers(2, 40),
    n_sub=st.integers(1, 6),
    smooth=st.integers(0, 3),
    straight=st.booleans(),
    dx=st.floats(1.0, 60.0),
    dy=st.floats(1.0, 30.0),
    dz=st.floats(1.0, 20.0),
    weights=st.tuples(*[st.floats(0.0, 5.0)] * 4),
)
def test_energy_bound_never_exceeds_the_energy(
    seed, d, n_sub, smooth, straight, dx, dy, dz, weights
) -> None:
    """The fused step rejects a candidate when bound·(1 − 1e-9) >= its parent's fitness: that
    must never reject a candidate whose energy is lower. Smoothed knots, curved guides and
    every sub-sampling included."""
    rng = np.random.default_rng(seed)
    energy = energy_args(
        d, rng, dx=dx, dy=dy, dz=dz, n_sub=n_sub, weights=weights, smooth=smooth,
        straight=straight,
    )  # fmt: skip
    nodes = rng.uniform(-10.0, 10.0, (6, d - 1, 2)).round()
    bound = energy_bounds(nodes, energy)
    exact = energy_of(nodes, energy)
    assert (bound >= 0.0).all()
    assert (bound * (1.0 - 1e-9) <= exact).all(), (bound, exact)


def test_energy_bound_is_tight_on_a_straight_path_and_absent_for_negative_weights() -> None:
    rng = np.random.default_rng(3)
    energy = energy_args(
        10, rng, dx=20.0, dy=20.0, dz=10.0, n_sub=3, weights=(1.0, 1.0, 1.0, 1.0), smooth=2,
        straight=True,
    )  # fmt: skip
    start_yz, goal_yz = energy.start_yz, energy.goal_yz
    t = np.arange(1, 10) / 10.0
    nodes = np.stack(
        [(start_yz[0] + (goal_yz[0] - start_yz[0]) * t) / 20.0,
         (start_yz[1] + (goal_yz[1] - start_yz[1]) * t) / 10.0], axis=1,
    )[None]  # fmt: skip
    bound, exact = energy_bounds(nodes, energy)[0], energy_of(nodes, energy)[0]
    assert bound == pytest.approx(exact, rel=1e-9)
    assert bound > 200.0
    negative = dataclasses.replace(energy, k0=1.0, k1=-1.0, mu0=1.0, k2=1.0)
    assert energy_bounds(nodes, negative)[0] == -1.0
