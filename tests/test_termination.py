"""The default early stop and the ways to force the paper's fixed iteration count (issue 13)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

from click.testing import CliRunner

from uavplan import bench
from uavplan.cli import main
from uavplan.cli.plan_cmd import overridden
from uavplan.config import DEFAULT_STALL_ITERATIONS, SearchParams
from uavplan.planning import plan_route
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
    forced = overridden(scn, None, None, 60, None)
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
