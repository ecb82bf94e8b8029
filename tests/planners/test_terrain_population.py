"""A search needs a population (issue 26, the 25 km crossing of the 20 × 20 km terrain area at
1.084 × its reference).

Over rugged terrain under a low ceiling the paper's initialisation (eq. 8-10: a random walk
toward the goal, ±10 grid units a column) rarely stays inside the band between the ground
and the ceiling: of 30 individuals one or two reach the goal, the deadlocked ones are
replaced by copies of them, and the swarm "searches" from copies of one wandering path. It
used to plan such a leg anyway, well above the grid search's route that the planner flies
when the swarm cannot start. Here, on a synthetic ridge field in the same regime (a few
seconds), a search with fewer than a quarter of its population initialised is no search: the
leg goes to the guide search and, when the swarm cannot start along the guide either, flies
the grid search's route.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rasterio")

from helpers.terrain_helpers import utm_origin, write_utm_dem

from uavplan import planning
from uavplan.app.feedback import PlannerOptions
from uavplan.config import SpsaParams
from uavplan.outcome import SearchEnd
from uavplan.planners.base import INIT_MIN_SHARE, Termination
from uavplan.planners.sparrow import SparrowPlanner
from uavplan.scenario import Scenario, load_scenario

E0, N0 = (round(v) for v in utm_origin())


def ridges(e: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Ridges 500 m from crest to trough, about 1.4 km apart, across the route."""
    x, y = e - E0, n - N0
    return 400.0 + 250.0 * np.sin(x / 450.0) * np.cos(y / 360.0)


BODY = """\
name: ridges
origin: {lat: 47.0, lon: 9.2}
terrain: ridges.tif
bounds: {x: [-3000, 3000], y: [-3000, 3000], z: [0, 90]}
start: [-2500, -2500, 40]
goal: [2500, 2500, 40]
safety_margin: 15
vehicle: {takeoff_altitude: 40}
mission: {autopilot: ardupilot, spacing: 100, end: land}
"""


@pytest.fixture(scope="module")
def ridge_scenario(tmp_path_factory: pytest.TempPathFactory) -> Scenario:
    tmp = tmp_path_factory.mktemp("ridges")
    write_utm_dem(tmp / "ridges.tif", ridges, cell_m=90.0, size=80)
    path = Path(tmp / "ridges.yaml")
    path.write_text(BODY, encoding="utf-8")
    return load_scenario(path)


def test_a_search_with_a_few_initial_paths_does_not_start(ridge_scenario: Scenario) -> None:
    scn = ridge_scenario
    world = planning.build_world(scn)
    problem = planning.build_problem(scn, world).with_fitness_smoothing(2)
    search = scn.planner.search
    # the regime of the issue: some individuals initialise, most deadlock
    _, ok, _ = problem.initial_population(search.population, search, np.random.default_rng(1))
    assert 0 < ok.sum() < INIT_MIN_SHARE * search.population
    res = SparrowPlanner(search, SpsaParams()).solve(
        problem, np.random.default_rng(1), None, Termination(search.iterations)
    )
    assert not res.solved
    assert res.termination is SearchEnd.NO_PATH
    assert res.iterations == 0


@pytest.mark.slow
def test_the_ridge_crossing_flies_no_worse_than_its_reference(ridge_scenario: Scenario) -> None:
    # seed 3: the straight columns do not start; along the guide a few paths did, and the
    # swarm of their copies flew 1.05 × the reference; the grid search's route is within 2 %
    scn = PlannerOptions(seed=3).apply(ridge_scenario)
    world = planning.build_world(scn)
    res = planning.plan_route(scn, world=world)
    assert res.ok
    reference = planning.reference_energy(scn, world)
    assert res.energy <= 1.02 * reference
    assert res.legs[0].planner.iterations == 0  # no swarm ran on copies
    # the note says why the swarm did not fly it, in the guide's frame and without the
    # straight frame's direction
    note = next(n for n in res.notes if "grid search's route" in n)
    assert "could not start along the guide" in note and "start→goal direction" not in note
    assert re.search(r"\(only \d+ of \d+ initial paths reached the goal", note), note
