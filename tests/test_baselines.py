"""The baseline planners (PSO, GWO, DE, CSO) and their kernel rules.

A contract suite runs every registered planner on one small scenario: it improves on its
initial population, it is reproducible from its seed, and every path it keeps obeys the
reachability rule. The update rules are checked by hand in open space, where nothing is
repaired and each proposal can be computed directly.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from uavplan.planners import _kernels as K
from uavplan.planners.base import PathProblem, Population, empty_refs
from uavplan.planners.chicken_swarm import ChickenSwarmPlanner
from uavplan.planners.differential_evolution import distinct_others
from uavplan.planners.grey_wolf import best_distinct
from uavplan.planners.params import CsoParams, PsoParams, SearchParams
from uavplan.planners.particle_swarm import ParticleSwarmPlanner
from uavplan.planners.registry import available, make_planner, options_class
from uavplan.scenario import load_scenario
from uavplan.world import World

BASELINES = ("pso", "gwo", "de", "cso")

# 400 m, 20 columns, one tower across the direct line: small enough for a 40-iteration run
SMALL = """\
name: small
origin: {lat: 47.0, lon: 8.0, alt: 400}
bounds: {x: [0, 400], y: [-160, 160], z: [0, 120]}
start: [0, 0, 30]
goal: [400, 20, 40]
obstacles:
  - {type: box, center: [200, 10], size: [60, 80], height: 100}
"""

# the same corridor with its only obstacle far off to the side: every short hop is reachable
OPEN = """\
name: open
origin: {lat: 47.0, lon: 8.0, alt: 400}
bounds: {x: [0, 400], y: [-400, 400], z: [0, 400]}
start: [0, 0, 100]
goal: [400, 0, 100]
obstacles:
  - {type: cylinder, center: [200, 380], radius: 5, height: 20}
"""

SEARCH = SearchParams(population=12, iterations=40, seed=3)


def _problem(tmp_path_factory: pytest.TempPathFactory, text: str) -> PathProblem:
    path = tmp_path_factory.mktemp("scn") / "scenario.yaml"
    path.write_text(text)
    scn = load_scenario(path)
    cfg = scn.planner
    world = World.from_scenario(scn)
    return PathProblem.build(world, scn.start_m, scn.goal_m, cfg.grid, cfg.energy)


@pytest.fixture(scope="module")
def small(tmp_path_factory: pytest.TempPathFactory) -> PathProblem:
    return _problem(tmp_path_factory, SMALL)


@pytest.fixture(scope="module")
def open_space(tmp_path_factory: pytest.TempPathFactory) -> PathProblem:
    return _problem(tmp_path_factory, OPEN)


def _solve(problem: PathProblem, name: str, seed: int = 3, iterations: int = 40):
    planner = make_planner(name, replace(SEARCH, seed=seed, iterations=iterations))
    return planner.solve(problem, np.random.default_rng(seed))


def _initial_best(problem: PathProblem, seed: int) -> float:
    """Best fitness of the initial population a run with ``seed`` starts from."""
    x, ok, _ = problem.initial_population(SEARCH.population, SEARCH, np.random.default_rng(seed))
    return float(problem.fitness(x[ok]).min())


def test_every_paper_algorithm_is_registered() -> None:
    assert set(available()) == {"spsa", "ssa", *BASELINES}


# --- contract suite over every planner ------------------------------------------------------


@pytest.mark.parametrize("name", BASELINES)
def test_improves_on_its_initial_population(small: PathProblem, name: str) -> None:
    res = _solve(small, name)
    assert res.solved
    assert res.best_fitness < _initial_best(small, 3)
    # best-so-far: every baseline keeps its best (greedy selection, pbest/gbest or leaders)
    assert np.all(np.diff(res.convergence) <= 1e-9)
    assert res.convergence[-1] == pytest.approx(res.best_fitness)


@pytest.mark.parametrize("name", available())
def test_seeded_and_reproducible(small: PathProblem, name: str) -> None:
    a = _solve(small, name, seed=5, iterations=15)
    b = _solve(small, name, seed=5, iterations=15)
    c = _solve(small, name, seed=6, iterations=15)
    np.testing.assert_array_equal(a.convergence, b.convergence)
    np.testing.assert_array_equal(a.best_nodes, b.best_nodes)
    np.testing.assert_array_equal(a.population, b.population)
    assert not np.array_equal(a.population, c.population)


@pytest.mark.parametrize("name", available())
def test_respects_reachability(small: PathProblem, name: str) -> None:
    res = _solve(small, name, iterations=25)
    assert problem_feasible(small, res.population).all()
    assert problem_feasible(small, res.best_nodes[None]).all()
    # nodes stay on the grid (eq. 9, 13)
    np.testing.assert_array_equal(res.population, np.round(res.population))
    assert res.best_fitness == pytest.approx(float(small.fitness(res.best_nodes[None])[0]))


def problem_feasible(problem: PathProblem, nodes: np.ndarray) -> np.ndarray:
    return problem.feasible(np.ascontiguousarray(nodes, dtype=float))


# --- the kernel rules, by hand in open space ------------------------------------------------


def _straight(problem: PathProblem, n_pop: int, dy: float = 0.0, dz: float = 0.0) -> np.ndarray:
    """``n_pop`` copies of the start-end line shifted by (dy, dz) grid units."""
    line = problem.line_u[1:-1]
    x = np.repeat(line[None], n_pop, axis=0).copy()
    x[..., 0] += dy
    x[..., 1] += dz
    return np.round(x)


def _rebuild(problem, base, rule, refs, scal, seed=0):
    n_pop = base.shape[0]
    rules = np.full(n_pop, rule, dtype=np.int64)
    out, ok, _ = problem.rebuild(
        base, rules, refs, scal, np.zeros(n_pop, bool), 10, np.random.default_rng(seed)
    )
    assert ok.all()
    return out


def test_pso_rule_is_inertia_plus_attraction_clamped_to_vmax(open_space: PathProblem) -> None:
    base = _straight(open_space, 3)
    n = base.shape[1]
    refs, scal = empty_refs(3, n)
    refs[:, 0] = 1.0  # velocity
    refs[:, 3] = 10.0  # Vmax
    scal[:, 0] = 2.0  # w; c1 = c2 = 0: the move is w·v exactly
    out = _rebuild(open_space, base, K.R_PSO, refs, scal)
    np.testing.assert_array_equal(out - base, 2.0)
    refs[:, 3] = 1.0  # the same velocity clamped to Vmax = 1
    out = _rebuild(open_space, base, K.R_PSO, refs, scal)
    np.testing.assert_array_equal(out - base, 1.0)
    # c1 = 1, pbest 4 units away, no inertia: the move is r·4 with r ~ U(0, 1)
    refs[:, 0] = 0.0
    refs[:, 1] = base + 4.0
    refs[:, 3] = 0.0  # no clamp
    scal[:, 0], scal[:, 1] = 0.0, 1.0
    step = _rebuild(open_space, base, K.R_PSO, refs, scal) - base
    assert step.min() >= 0 and step.max() <= 4 and step.std() > 0.5


def test_gwo_rule_with_a_zero_is_the_mean_of_the_leaders(open_space: PathProblem) -> None:
    base = _straight(open_space, 2)
    n = base.shape[1]
    refs, scal = empty_refs(2, n)
    refs[:, 0] = base + 3.0
    refs[:, 1] = base + 6.0
    refs[:, 2] = base  # α, β, δ; a = 0 → A = 0 → X = (X_α + X_β + X_δ)/3
    out = _rebuild(open_space, base, K.R_GWO, refs, scal)
    np.testing.assert_array_equal(out - base, 3.0)


def test_de_rule_is_rand_1_bin(open_space: PathProblem) -> None:
    base = _straight(open_space, 2)
    n = base.shape[1]
    refs, scal = empty_refs(2, n)
    refs[:, 0] = base + 1.0
    refs[:, 1] = base + 6.0
    refs[:, 2] = base + 2.0
    scal[:, 0] = 0.5  # F
    scal[:, 1] = 1.0  # CR = 1: the trial is the mutant x_r1 + F·(x_r2 − x_r3)
    out = _rebuild(open_space, base, K.R_DE, refs, scal)
    np.testing.assert_array_equal(out - base, 3.0)
    scal[:, 1] = 0.0  # CR = 0: only the j_rand coordinate comes from the mutant
    scal[0, 2] = 7  # node 3, z
    scal[1, 2] = 0  # node 0, y
    out = _rebuild(open_space, base, K.R_DE, refs, scal)
    changed = np.argwhere(out != base)
    np.testing.assert_array_equal(changed, [[0, 3, 1], [1, 0, 0]])


def test_cso_rules(open_space: PathProblem) -> None:
    base = _straight(open_space, 2, dy=4.0)
    n = base.shape[1]
    refs, scal = empty_refs(2, n)
    # rooster with σ² = 0 stays; hen with S1 = S2 = 0 stays
    np.testing.assert_array_equal(_rebuild(open_space, base, K.R_CSO_ROOSTER, refs, scal), base)
    np.testing.assert_array_equal(_rebuild(open_space, base, K.R_CSO_HEN, refs, scal), base)
    # chick: x + FL·(mother − x)
    refs[:, 0] = base + 8.0
    scal[:, 0] = 0.5
    out = _rebuild(open_space, base, K.R_CSO_CHICK, refs, scal)
    np.testing.assert_array_equal(out - base, 4.0)
    # rooster noise is multiplicative in the deviation from the start-end line
    scal[:, 0] = 0.5
    dev = _rebuild(open_space, base, K.R_CSO_ROOSTER, refs, scal) - np.round(
        open_space.line_u[1:-1]
    )
    assert np.abs(dev[..., 1]).max() == 0  # on the line in z: no z noise
    assert dev[..., 0].std() > 0.5


# --- population-level pieces ------------------------------------------------------------------


def test_distinct_others_excludes_self() -> None:
    r = distinct_others(6, 3, np.random.default_rng(0))
    assert r.shape == (6, 3)
    for i, row in enumerate(r):
        assert i not in row and len(set(row)) == 3


def test_best_distinct_skips_duplicates() -> None:
    x = np.zeros((5, 4, 2))
    x[1] += 1
    x[2] += 1  # same position as 1
    x[3] += 2
    f = np.array([5.0, 1.0, 1.0, 3.0, 9.0])
    np.testing.assert_array_equal(best_distinct(x, f, 3), [1, 3, 0])


def test_pso_inertia_falls_linearly() -> None:
    planner = ParticleSwarmPlanner(SearchParams(iterations=11))
    ws = [planner.inertia(Population(np.zeros((4, 1, 2)), np.zeros(4), i, 11)) for i in (0, 5, 10)]
    assert ws == pytest.approx([0.9, 0.65, 0.4])


def test_cso_group_sizes() -> None:
    planner = ChickenSwarmPlanner(SearchParams(), CsoParams())
    assert planner.group_sizes(30) == (6, 18, 6, 3)  # RN = 0.2 N, HN = 0.6 N, MN = 0.1 N
    code = ChickenSwarmPlanner(SearchParams(), CsoParams(0.15, 0.7, 0.5))
    assert code.group_sizes(30) == (5, 21, 4, 11)  # MATLAB rounding, as Meng's code
    r, h, c, m = planner.group_sizes(4)
    assert r >= 1 and h >= 1 and r + h + c == 4 and 1 <= m <= h


def test_options_fill_the_parameter_dataclass() -> None:
    planner = make_planner("pso", SEARCH, options={"c1": 1.5, "v_max_fraction": None})
    assert planner.params == PsoParams(c1=1.5, v_max_fraction=None)
    assert options_class("gwo").__name__ == "GwoParams"
    with pytest.raises(ValueError, match="F: unknown key"):
        make_planner("de", SEARCH, options={"F": 0.5})
    with pytest.raises(ValueError, match="cr: must be"):
        make_planner("de", SEARCH, options={"cr": 2.0})
