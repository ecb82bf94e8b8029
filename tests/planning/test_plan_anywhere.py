"""Plan anywhere a route exists (issue "Plan anywhere"): routes that double back, narrow gaps,
shallow volumes, long routes and via points never end in a false "no path"; exit 3 comes only
when the grid search proves the start or the goal enclosed, and says which.

The seed sweeps use a small iteration budget: whether a path is found does not depend on it
(the initialisation and the guide search decide), only how good it is.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from uavplan.cli import main
from uavplan.planning import plan_route
from uavplan.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]
SEEDS = range(1, 21)

ENCLOSED = """
name: enclosed-{which}
origin: {{lat: 47.397742, lon: 8.545594, alt: 488.0}}
bounds: {{x: [0, 1000], y: [-500, 500], z: [0, 120]}}
start: {start}
goal: {goal}
obstacles:   # a closed courtyard, taller than the ceiling, around the point at (600, 0)
  - {{type: box, center: [490, 0], size: [20, 320], height: 200}}
  - {{type: box, center: [710, 0], size: [20, 320], height: 200}}
  - {{type: box, center: [600, 150], size: [240, 20], height: 200}}
  - {{type: box, center: [600, -150], size: [240, 20], height: 200}}
"""


def quick(scn, seed: int, iterations: int = 20, population: int = 8):
    search = replace(scn.planner.search, seed=seed, iterations=iterations, population=population)
    return scn.with_planner(search=search)


@pytest.mark.parametrize(
    ("which", "start", "goal"),
    [("goal", "[0, 0, 30]", "[600, 0, 30]"), ("start", "[600, 0, 30]", "[0, 0, 30]")],
)
def test_exit_3_only_for_an_enclosed_end_and_it_says_which(
    tmp_path: Path, which: str, start: str, goal: str
) -> None:
    path = tmp_path / f"enclosed-{which}.yaml"
    path.write_text(ENCLOSED.format(which=which, start=start, goal=goal), encoding="utf-8")
    out = tmp_path / "x.plan"
    res = CliRunner().invoke(main, ["plan", str(path), "-o", str(out), "-q", "--iterations", "20"])
    assert res.exit_code == 3, res.output
    assert f"the {which} is enclosed" in res.output
    assert "Traceback" not in res.output and not out.exists()


@pytest.mark.parametrize("name", ["courtyard", "hairpin", "narrow-gap", "via-tour"])
@pytest.mark.slow
def test_routes_that_double_back_or_thread_a_gap_are_found_for_every_seed(name: str) -> None:
    scn = load_scenario(ROOT / "missions" / f"{name}.yaml")
    for seed in SEEDS:
        res = plan_route(quick(scn, seed))
        assert res.ok and res.status == "ok", (seed, res.message)
        assert res.collision_free, (seed, res.min_clearance_m)


def test_the_courtyard_route_flies_past_the_goal_and_comes_back() -> None:
    scn = load_scenario(ROOT / "missions" / "courtyard.yaml")
    res = plan_route(quick(scn, 1))
    assert res.route is not None
    x = res.route.waypoints_enu[:, 0]
    assert x.max() > 760  # round the courtyard's far side (its opening faces away)
    assert res.notes and "guide" in res.notes[0]


def _open(length_m: float, ceiling_m: float) -> str:
    return f"""
name: open-{length_m:g}
origin: {{lat: 47.397742, lon: 8.545594, alt: 488.0}}
bounds: {{x: [0, {length_m}], y: [-600, 600], z: [0, {ceiling_m}]}}
start: [0, 0, 30]
goal: [{length_m}, 0, 30]
safety_margin: 5
obstacles:
  - {{type: box, center: [{length_m / 2}, 0], size: [60, 60], height: 15}}
"""


@pytest.mark.parametrize(("length_m", "ceiling_m"), [(2000.0, 40.0), (50000.0, 150.0)])
def test_a_shallow_volume_or_a_long_route_is_no_reason_to_fail(
    tmp_path: Path, length_m: float, ceiling_m: float
) -> None:
    path = tmp_path / "open.yaml"
    path.write_text(_open(length_m, ceiling_m), encoding="utf-8")
    scn = load_scenario(path)
    for seed in (1, 2, 3):
        res = plan_route(quick(scn, seed, iterations=5, population=4))
        assert res.ok and res.status == "ok", (seed, res.message)
        assert res.collision_free
        assert res.route is not None and res.route.waypoints_enu[:, 2].max() <= ceiling_m


def test_via_points_are_waypoints_exactly_and_legs_are_reported() -> None:
    scn = quick(load_scenario(ROOT / "missions" / "paper-env1.yaml"), 3, 30)
    via = ((700.0, 300.0, 60.0), (1400.0, -200.0, 40.0))
    scn = replace(scn, via_m=via)
    res = plan_route(scn)
    assert res.ok and res.collision_free and len(res.legs) == 3
    w = res.route.waypoints_enu
    for p in via:
        assert np.min(np.linalg.norm(w - np.array(p), axis=1)) < 1e-6
    assert res.energy == pytest.approx(sum(leg.energy for leg in res.legs))
    assert [leg.goal_m for leg in res.legs[:2]] == list(via)


@pytest.mark.slow
def test_the_bundled_qgroundcontrol_plan_reroutes_for_every_seed() -> None:
    from uavplan.config import PlannerConfig, SearchParams
    from uavplan.mission.io import load_mission
    from uavplan.reroute import reroute_plan

    plan = load_mission(ROOT / "missions" / "qgc-inspection.plan")
    for seed in SEEDS:
        search = SearchParams(seed=seed, iterations=20, population=8)
        out = reroute_plan(plan, planner=PlannerConfig(search=search))
        assert out.inserted > 0 and out.min_clearance_m >= out.safety_margin_m, seed
