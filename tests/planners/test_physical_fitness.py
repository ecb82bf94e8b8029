"""The physical fitness (``planner: {energy: physical}``): the power model's watt-hours of a
path, wind included, in the shared compiled fitness, so every planner minimises it.

The kernel is held to its numpy reference (:meth:`PhysicalFitness.polyline_wh`, which flies
the same spline samples through :func:`uavplan.airframe.flight_energy`); every registered
planner runs on it, reproducibly; and the paper's fitness is what it was when the physical
one is not asked for."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from uavplan.airframe import Wind, resolve
from uavplan.config import PLANNERS
from uavplan.path.energy import N_SUB, EnergyArgs, PhysicalFitness, column_spline, energy_of
from uavplan.planning import build_problem, physical_fitness, plan_route
from uavplan.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]
X500 = resolve({"profile": "x500"})
D, DX, DY, DZ = 24, 20.0, 20.0, 10.0


def population(seed: int, g: int = 6) -> np.ndarray:
    rng = np.random.default_rng(seed)
    nodes = rng.integers(-4, 5, size=(g, D - 1, 2)).astype(float)
    nodes[..., 1] = np.abs(nodes[..., 1]) + 3  # 30-70 m up
    return nodes


def kernel_and_reference(
    fitness: PhysicalFitness, heading: float, nodes: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    start, goal = np.array([0.0, 30.0]), np.array([0.0, 40.0])
    args = EnergyArgs(
        start, goal, np.zeros((D + 1, 4)), DX, DY, DZ, N_SUB, 1.0, 1.0, 1.0, 1.0, 0, True,
        fitness.table(heading, 0.0, 150.0),
    )  # fmt: skip
    kernel = energy_of(nodes, args)
    ref = []
    for individual in nodes:
        knots = np.vstack([start, individual * [DY, DZ], goal])
        ref.append(fitness.polyline_wh(column_spline(knots, DX), heading))
    return kernel, np.array(ref)


@pytest.mark.parametrize(
    ("wind", "rtol"),
    [
        (None, 1e-8),
        (Wind.uniform(6.0, 250.0), 1e-8),
        (Wind.uniform(10.0, 10.0), 1e-8),
        # the kernel interpolates a sheared wind in a table 1 m apart
        (Wind.power_law(7.0, 120.0), 1e-5),
        (Wind.from_table([0, 40, 100], [1, 8, 4], 300.0), 1e-8),
    ],
    ids=["calm", "uniform", "strong", "power-law", "table"],
)
@pytest.mark.parametrize("heading", [0.0, 0.7, -2.5])
def test_the_kernel_is_the_power_model_on_the_spline(
    wind: Wind | None, rtol: float, heading: float
) -> None:
    fitness = PhysicalFitness(X500, wind, 10.0, 2.5, 1.5, datum_amsl_m=420.0)
    kernel, ref = kernel_and_reference(fitness, heading, population(1))
    np.testing.assert_allclose(kernel, ref, rtol=rtol)
    assert np.all(kernel > 0)


def test_a_measured_vehicle_is_flown_with_its_calibration() -> None:
    measured = X500.with_overrides(hover_power_w=240.0, cruise_power_w=215.0, cruise_speed_m_s=10)
    fitness = PhysicalFitness(measured, Wind.uniform(4, 0), 9.0, 2.0, 1.0)
    kernel, ref = kernel_and_reference(fitness, 1.0, population(2))
    np.testing.assert_allclose(kernel, ref, rtol=1e-8)


def test_a_headwind_costs_more_and_a_climb_costs_more() -> None:
    """Along +x (heading 0: east), a wind from the east (90°) is a headwind."""
    level = np.zeros((1, D - 1, 2))
    level[..., 1] = 3.0
    hill = level.copy()
    hill[0, 8:16, 1] = 7.0
    calm = PhysicalFitness(X500, None, 10.0, 2.5, 1.5)
    head = replace(calm, wind=Wind.uniform(6.0, 90.0))
    nodes = np.vstack([level, hill])
    e_calm, _ = kernel_and_reference(calm, 0.0, nodes)
    e_head, _ = kernel_and_reference(head, 0.0, nodes)
    assert e_head[0] > e_calm[0] * 1.1
    assert e_calm[1] > e_calm[0]


def moving_average(knots: np.ndarray, half: int) -> np.ndarray:
    """The fitness's centred moving average of the knots (half-width shrinking at the ends)."""
    n = len(knots)
    out = np.empty_like(knots)
    for i in range(n):
        h = min(half, i, n - 1 - i)
        out[i] = knots[i - h : i + h + 1].mean(axis=0)
    return out


def scenario(tmp_path: Path, algorithm: str, extra: str = "") -> Path:
    text = (ROOT / "missions" / "paper-env1.yaml").read_text()
    text = text.replace("../maps/", f"{ROOT}/maps/")
    text = text.replace(
        "planner: {algorithm: spsa, population: 30, iterations: 1000, seed: 1}",
        f"planner: {{algorithm: {algorithm}, population: 12, iterations: 15, seed: 3, "
        "stall_iterations: null, energy: physical}",
    )
    path = tmp_path / f"{algorithm}.yaml"
    path.write_text(text + extra)
    return path


@pytest.mark.parametrize("algorithm", sorted(PLANNERS))
def test_every_planner_minimises_the_physical_watt_hours(tmp_path: Path, algorithm: str) -> None:
    scn = load_scenario(scenario(tmp_path, algorithm, "wind: {speed: 4, from: 200}\n"))
    problem = build_problem(scn)
    assert problem.physical is not None and problem.energy_args.phys.size > 0
    result = plan_route(scn, problem=problem, threads=1)
    assert result.ok, result.message
    pr = result.planner
    # the search's best fitness is the watt-hours of its best path, as numpy computes them
    # (on the spline through the knots' moving average when the planner smooths its fitness)
    knots = np.vstack(
        [problem.start_m[1:], pr.best_nodes * [*problem.steps[1:]], problem.goal_m[1:]]
    )
    knots = moving_average(knots, scn.planner.fitness_smoothing())
    samples = column_spline(knots, problem.frame.dx_m)
    wh = problem.physical.polyline_wh(samples, problem.frame.heading_rad)
    assert pr.best_fitness == pytest.approx(wh, rel=1e-6)
    assert 5.0 < pr.best_fitness < 500.0  # watt-hours of a 2 km route, not its ~2000 m
    # and it only goes down
    conv = np.asarray(pr.convergence)
    assert np.all(np.diff(conv) <= 1e-12)
    again = plan_route(
        load_scenario(scenario(tmp_path, algorithm, "wind: {speed: 4, from: 200}\n"))
    )
    assert again.planner.best_fitness == pr.best_fitness  # seeded: the same run


def test_the_paper_fitness_stays_the_default() -> None:
    scn = load_scenario(ROOT / "missions" / "paper-env1.yaml")
    assert scn.planner.fitness == "paper" and physical_fitness(scn) is None
    problem = build_problem(scn)
    assert problem.physical is None and problem.energy_args.phys.size == 0
    nodes = population(4, g=3)[:, : problem.n_inner]
    # eq. 1-2: k0·length + turning + k2·climb of the spline, whatever the wind would be
    windy = replace(scn, wind=Wind.uniform(5, 90))
    assert np.array_equal(build_problem(windy).fitness(nodes), problem.fitness(nodes))


def test_the_physical_fitness_flies_the_scenario_speeds(tmp_path: Path) -> None:
    scn = load_scenario(scenario(tmp_path, "spsa", "wind: {speed: 3, from: 10}\n"))
    fitness = physical_fitness(scn)
    assert fitness is not None
    assert fitness.speed_m_s == 12.0  # the scenario's cruise_speed
    assert (fitness.climb_rate_m_s, fitness.descent_rate_m_s) == (2.5, 1.5)  # WPNAV_SPEED_UP/DN
    assert fitness.profile.name == "x500" and fitness.wind == scn.wind
    assert math.isclose(fitness.datum_amsl_m, scn.site.origin.alt_m)


def test_bench_keeps_the_paper_s_comparison(tmp_path: Path) -> None:
    from click.testing import CliRunner

    from uavplan.cli import main

    path = scenario(tmp_path, "spsa")
    result = CliRunner().invoke(main, ["bench", str(path), "--runs", "1"])
    assert result.exit_code == 2, result.output
    assert "planner.energy" in result.output and "Traceback" not in result.output
