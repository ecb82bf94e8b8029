"""The default early stop and the ways to force the paper's fixed iteration count (issue 13)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
from click.testing import CliRunner

from uavplan import bench
from uavplan.app.feedback import PlannerOptions
from uavplan.cli import main
from uavplan.config import DEFAULT_RESTART_STALL_ITERATIONS, DEFAULT_STALL_ITERATIONS, SearchParams
from uavplan.planners.base import SwarmPlanner, Termination
from uavplan.planning import build_problem, make_planner, plan_route
from uavplan.scenario import load_scenario

SCENARIO = """\
name: small
origin: {lat: 47.397742, lon: 8.545594, alt: 488.0}
bounds: {x: [0, 600], y: [-200, 200], z: [0, 120]}
start: [0, 0, 30]
goal: [600, 20, 40]
obstacles:
  - {type: box, center: [300, 0], size: [80, 80], height: 100}
planner: {population: 8, iterations: 400, seed: 3, stall_iterations: 10}
"""


def write(tmp_path: Path, text: str = SCENARIO) -> Path:
    path = tmp_path / "small.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def test_the_default_is_the_stated_rule() -> None:
    assert SearchParams().stall_iterations == DEFAULT_STALL_ITERATIONS == 100
    assert SearchParams().restart_stall_iterations == DEFAULT_RESTART_STALL_ITERATIONS == 25


def searches(tmp_path: Path, term: Termination) -> tuple[list[float], list[int]]:
    """The run's convergence and the iteration at which each search (restart) began."""
    scn = load_scenario(write(tmp_path))
    planner = make_planner("spsa", scn.planner)
    starts: list[int] = []
    done = [0]
    setup = planner.setup

    def record(problem, pop, rng):  # type: ignore[no-untyped-def]
        starts.append(done[0])
        setup(problem, pop, rng)

    def progress(it: int, _total: int, _best: float) -> None:
        done[0] = it

    planner.setup = record  # type: ignore[method-assign]
    res = SwarmPlanner.solve(planner, build_problem(scn), np.random.default_rng(5), progress, term)
    return list(res.convergence), starts


def expected_end(conv: list[float], start: int, length: int, limit: int | None) -> int:
    """Where a search that began at ``start`` must end under the stated rule: ``limit``
    iterations in a row without improving the run's best, or its share of M."""
    best = conv[start - 1] if start > 0 else float("inf")
    stalled = 0
    for t in range(start, start + length):
        if conv[t] < best:
            best, stalled = conv[t], 0
        else:
            stalled += 1
        if limit is not None and stalled >= limit:
            return t + 1
    return start + length


def test_restarts_stop_after_their_own_stall_limit(tmp_path: Path) -> None:
    term = Termination(400, stall_iterations=12, restart_stall_iterations=4)
    conv, starts = searches(tmp_path, term)
    assert len(starts) == 4  # SPSA's four restarts of 100 iterations each
    ends = [*starts[1:], len(conv)]
    for r, (s, e) in enumerate(zip(starts, ends, strict=True)):
        assert e == expected_end(conv, s, 100, 12 if r == 0 else 4)
    assert any(e - s < 12 for s, e in zip(starts[1:], ends[1:], strict=True))


def test_restart_limit_null_means_the_first_search_limit(tmp_path: Path) -> None:
    conv, starts = searches(tmp_path, Termination(400, stall_iterations=6))
    ends = [*starts[1:], len(conv)]
    for s, e in zip(starts, ends, strict=True):
        assert e == expected_end(conv, s, 100, 6)
    assert Termination(9, 6).stall_limit(2) == 6
    assert Termination(9, None, restart_stall_iterations=3).stall_limit(1) is None


def test_a_run_stops_once_the_best_stalls(tmp_path: Path) -> None:
    scn = load_scenario(write(tmp_path))
    assert scn.planner.search.stall_iterations == 10
    res = plan_route(scn)
    assert res.ok
    pr = res.planner
    assert pr.termination == "stalled"
    assert pr.iterations < 400
    # each restart ends 10 iterations after the last improvement of the run's best
    conv = pr.convergence
    assert all(conv[i] >= conv[i + 1] for i in range(len(conv) - 1))


def test_iterations_on_the_command_line_force_m(tmp_path: Path) -> None:
    scn = load_scenario(write(tmp_path))
    forced = PlannerOptions(iterations=60).apply(scn)
    assert forced.planner.search.iterations == 60
    assert forced.planner.search.stall_iterations is None
    report = tmp_path / "r.json"
    out = tmp_path / "m.plan"
    args = ["plan", str(write(tmp_path)), "-o", str(out), "-q", "--iterations", "60"]
    result = CliRunner().invoke(main, [*args, "--report", str(report)])
    assert result.exit_code == 0, result.output
    doc = json.loads(report.read_text())
    assert doc["iterations"] == 60 and doc["termination"] == "iterations"


def test_null_in_the_scenario_runs_all_m(tmp_path: Path) -> None:
    text = SCENARIO.replace("stall_iterations: 10", "iterations: 30, stall_iterations: null")
    text = text.replace("iterations: 400, ", "")
    scn = load_scenario(write(tmp_path, text))
    assert scn.planner.search.stall_iterations is None
    res = plan_route(scn)
    assert res.planner.iterations == 30 and res.planner.termination == "iterations"


def test_the_bench_protocol_runs_every_iteration(tmp_path: Path) -> None:
    scn = load_scenario(write(tmp_path))
    jobs = bench.make_jobs([scn], ["spsa"], runs=1)
    assert jobs[0].scenario.planner.search.stall_iterations is None
    again = dataclasses.replace(scn, planner=scn.planner)
    assert again.planner.search.stall_iterations == 10  # the scenario itself is untouched
