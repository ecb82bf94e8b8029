"""Messages and options that tell the truth (issue 23, item 4): one test per defect, each
failing before its fix.

The QGroundControl plans are test_reroute.py's: a take-off, waypoints and a landing whose
straight legs cross an exclusion polygon and an exclusion circle.
"""

from __future__ import annotations

import json
import re
import types
from pathlib import Path
from typing import Any

import pytest
import yaml
from click.testing import CliRunner, Result
from test_reroute import (
    HOME,
    NAV_TAKEOFF,
    NAV_WAYPOINT,
    item,
    latlon,
    plan_doc,
    user_items,
    write,
)

from uavplan.cli import main

ROOT = Path(__file__).resolve().parents[2]
FAST = ["--iterations", "150", "--seed", "3", "--quiet"]


def run(*args: Any, env: dict[str, str] | None = None) -> Result:
    return CliRunner().invoke(main, [str(a) for a in args], env=env)


def one_error(result: Result, code: int) -> str:
    assert result.exit_code == code, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    assert "Traceback" not in result.output
    return lines[0]


@pytest.fixture
def user_plan(tmp_path: Path) -> Path:
    return write(tmp_path, plan_doc(user_items("land")))


@pytest.fixture(scope="module")
def safe_plan(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The user's plan rerouted, once for the module: the tests only read it."""
    folder = tmp_path_factory.mktemp("safe")
    out = folder / "safe.plan"
    result = run("plan", write(folder, plan_doc(user_items("land"))), "-o", out, *FAST)
    assert result.exit_code == 0, result.output
    return out


def waypoints_file(tmp_path: Path, name: str = "q.waypoints") -> Path:
    path = tmp_path / name
    path.write_text(
        "QGC WPL 110\n"
        "0\t1\t0\t16\t0\t0\t0\t0\t47.3977\t8.5456\t488\t1\n"
        "1\t0\t3\t22\t0\t0\t0\t0\t47.3977\t8.5456\t30\t1\n"
        "2\t0\t3\t16\t0\t0\t0\t0\t47.3987\t8.5456\t30\t1\n"
    )
    return path


# =============================================================================================
# --scenario for a reroute: a map is enough


def test_a_reroute_takes_a_scenario_file_without_start_and_goal(
    tmp_path: Path, user_plan: Path
) -> None:
    """docs/reroute.md: the plan supplies start, goal and via points. A file with origin,
    bounds and obstacles only used to fail with "goal: missing required key"."""
    extra = tmp_path / "extra.yaml"
    extra.write_text(
        yaml.safe_dump(
            {
                "origin": {"lat": HOME[0], "lon": HOME[1], "alt": HOME[2]},
                "bounds": {"x": [-150, 400], "y": [-100, 450], "z": [0, 120]},
                "obstacles": [{"type": "cylinder", "center": [125, 300], "radius": 20,
                               "height": 100}],
                "safety_margin": 8,
            }
        )
    )  # fmt: skip
    out = tmp_path / "safe.plan"
    result = run("plan", user_plan, "-o", out, "--scenario", extra, *FAST)
    assert result.exit_code == 0, result.output
    # the scenario's obstacle is in the world: validate with the same file agrees
    check = run("validate", out, "--scenario", extra)
    assert check.exit_code == 0, check.output
    assert "and " in check.stdout and "1 obstacle" in check.stdout and "margin 8 m" in check.stdout


# =============================================================================================
# A mission file where a scenario is expected


@pytest.mark.parametrize(
    ("args", "hint"),
    [
        (["validate", "{wp}"], "--scenario"),
        (["plan", "{wp}", "-o", "{tmp}/o.plan"], "--scenario"),
        (["render", "{wp}", "-o", "{tmp}/o.png"], "--mission"),
        (["bench", "{wp}", "--runs", "1"], "scenarios (YAML)"),
    ],
    ids=["validate", "plan", "render", "bench"],
)
def test_a_waypoints_file_given_as_a_scenario_says_what_it_is(
    tmp_path: Path, args: list[str], hint: str
) -> None:
    """It used to say "(top level): must be a mapping"."""
    wp = waypoints_file(tmp_path)
    result = run(*(a.format(wp=wp, tmp=tmp_path) for a in args))
    line = one_error(result, 2)
    assert "is a mission file (QGC WPL waypoints), not a scenario" in line
    assert hint in line and "must be a mapping" not in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["q.waypoints"]


def test_a_qgc_plan_under_another_name_is_recognised(tmp_path: Path) -> None:
    """A .plan saved as .json used to get "fileType: unknown key (allowed: bounds, ...)"."""
    doc = plan_doc(user_items("land"))
    source = write(tmp_path, doc, "mission.json")
    line = one_error(run("plan", source, "-o", tmp_path / "o.plan"), 2)
    assert "a QGroundControl plan" in line and "mission.plan" in line and "--scenario" in line
    line = one_error(run("validate", source), 2)
    assert "a QGroundControl plan" in line and "--scenario" in line


def test_a_map_export_is_not_read_as_a_scenario(tmp_path: Path) -> None:
    export = tmp_path / "m.geojson"
    export.write_text('{"type": "FeatureCollection", "features": []}')
    line = one_error(run("validate", export), 2)
    assert "map export" in line and "--scenario" in line


def test_validate_a_plan_without_a_fence_and_without_a_scenario_names_the_option(
    tmp_path: Path,
) -> None:
    doc = plan_doc(user_items("land"), polygons=[], circles=[])
    line = one_error(run("validate", write(tmp_path, doc, "bare.plan")), 2)
    assert "no geofence" in line and "--scenario" in line


# =============================================================================================
# A rerouted plan against its own geofence


def test_validate_checks_a_plan_against_its_own_geofence(user_plan: Path, safe_plan: Path) -> None:
    """The rerouted plan keeps the margin from its zones; the user's, flown as drawn, does
    not (exit 3, naming the zone). Without --scenario it used to be read as a scenario
    ("fileType: unknown key")."""
    ok = run("validate", safe_plan)
    assert ok.exit_code == 0, ok.output
    assert "min clearance from its geofence (2 zones)" in ok.stdout and "margin 10 m" in ok.stdout
    line = one_error(run("validate", user_plan), 3)
    assert str(user_plan) in line and "of the fence" in line


def test_render_draws_a_plan_with_its_own_geofence(tmp_path: Path, safe_plan: Path) -> None:
    out = tmp_path / "safe.png"
    result = run("render", safe_plan, "-o", out, "--size", "800x400")
    assert result.exit_code == 0, result.output
    assert out.read_bytes().startswith(b"\x89PNG")
    assert "min clearance from its geofence" in result.stderr


@pytest.mark.slow
def test_plan_of_a_qgc_plan_draws_the_rerouted_plan(tmp_path: Path, user_plan: Path) -> None:
    """--plot used to be refused "about the autopilot flavour and geofence"."""
    out, picture = tmp_path / "safe.plan", tmp_path / "safe.png"
    result = run("plan", user_plan, "-o", out, "--plot", picture, *FAST)
    assert result.exit_code == 0, result.output
    assert out.exists() and picture.read_bytes().startswith(b"\x89PNG")
    for flag in (["--fence"], ["--autopilot", "px4"]):
        line = one_error(run("plan", user_plan, "-o", out, *flag, *FAST), 2)
        assert "keeps its own autopilot flavour and geofence" in line


# =============================================================================================
# render --no-plan of a scenario whose start is not valid


def test_render_no_plan_draws_a_scenario_whose_start_is_inside_an_obstacle(
    tmp_path: Path,
) -> None:
    """The picture is how a user finds a valid start: drawn, with the reason in a warning
    (and the subtitle); it used to be refused."""
    doc = yaml.safe_load((ROOT / "missions" / "paper-env1.yaml").read_text())
    doc["map"] = str(ROOT / "maps" / "paper-env1.yaml")
    scenario = tmp_path / "s.yaml"
    scenario.write_text(yaml.safe_dump(doc))
    first = yaml.safe_load((ROOT / "maps" / "paper-env1.yaml").read_text())["obstacles"][0]
    doc["start"] = [*first["center"], 10]
    scenario.write_text(yaml.safe_dump(doc))
    assert run("validate", scenario).exit_code == 2  # not plannable
    out = tmp_path / "s.png"
    result = run("render", scenario, "-o", out, "--no-plan", "--size", "800x400")
    assert result.exit_code == 0, result.output
    assert out.read_bytes().startswith(b"\x89PNG")
    warning = [line for line in result.stderr.splitlines() if line.startswith("warning:")]
    assert len(warning) == 1 and "start" in warning[0] and "inside" in warning[0]


# =============================================================================================
# Odd text


def test_no_negative_zero_in_the_summary() -> None:
    from uavplan.app.plan import fixed

    assert fixed(-0.001, 2) == "0.00" and fixed(-0.0, 2) == "0.00"
    assert fixed(-0.006, 2) == "-0.01" and fixed(0.031, 2) == "0.03"


def test_one_iteration_is_singular(tmp_path: Path) -> None:
    result = run(
        "plan", ROOT / "missions" / "paper-env1.yaml", "-o", tmp_path / "m.plan",
        "--iterations", "1", "--population", "6",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "population 6, 1 iteration, seed" in result.stderr


def test_one_exclusion_zone_is_singular(tmp_path: Path) -> None:
    """A tower taller than the flight volume between start and goal: the route goes around,
    and it is the fence's one exclusion zone."""
    scenario = tmp_path / "tower.yaml"
    scenario.write_text(
        yaml.safe_dump(
            {
                "name": "tower",
                "origin": {"lat": HOME[0], "lon": HOME[1], "alt": HOME[2]},
                "bounds": {"x": [0, 600], "y": [-200, 200], "z": [0, 80]},
                "start": [20, 0, 30],
                "goal": [580, 0, 30],
                "obstacles": [{"type": "cylinder", "center": [300, 0], "radius": 40,
                               "height": 200}],
            }
        )
    )  # fmt: skip
    result = run("plan", scenario, "-o", tmp_path / "t.plan", "--fence", "--seed", "1")
    assert result.exit_code == 0, result.output
    assert re.search(r"inclusion polygon \+ 1 exclusion zone\b(?!s)", result.stderr), result.stderr


def test_the_home_at_the_origin_is_written_as_the_origin(tmp_path: Path) -> None:
    """paper-env1 starts at its origin (47.397742, 8.545594): the home was written as
    47.397742000000015 (the ECEF round trip's last bits)."""
    from uavplan.geo import EnuFrame, GeoPoint

    origin = GeoPoint(47.397742, 8.545594, 488.0)
    lat, lon, alt = EnuFrame.at(origin).to_geodetic([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0]])
    assert (lat[0], lon[0], alt[0]) == (47.397742, 8.545594, 488.0)
    assert lat[1] != 47.397742 or lon[1] != 8.545594
    out = tmp_path / "m.plan"
    result = run(
        "plan", ROOT / "missions" / "paper-env1.yaml", "-o", out, "--iterations", "2",
        "--population", "6", "-q",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    home = json.loads(out.read_text())["mission"]["plannedHomePosition"]
    assert home[:2] == [47.397742, 8.545594]
    assert "47.397742000000015" not in out.read_text()


@pytest.mark.slow
def test_each_length_says_what_it_measures(tmp_path: Path) -> None:
    """plan printed 2071 m and render 2100 m for the same route without saying that one is
    the planned path from start to goal and the other the flight with the take-off climb."""
    out = tmp_path / "m.plan"
    planned = run(
        "plan", ROOT / "missions" / "paper-env1.yaml", "-o", out, "--iterations", "3",
        "--population", "6",
    )  # fmt: skip
    assert planned.exit_code == 0, planned.output
    assert " m from start to goal, energy" in planned.stderr
    drawn = run(
        "render", ROOT / "missions" / "paper-env1.yaml", "--mission", out, "-o",
        tmp_path / "m.png", "--size", "800x400",
    )  # fmt: skip
    assert drawn.exit_code == 0, drawn.output
    assert " m flown from take-off, min clearance" in drawn.stderr


@pytest.mark.parametrize("value", ["abc", "0", "-2", "2.5"])
def test_a_bad_threads_variable_is_exit_2_naming_it(tmp_path: Path, value: str) -> None:
    """UAVPLAN_THREADS=abc used to be ignored without a word."""
    result = run(
        "plan", ROOT / "missions" / "paper-env1.yaml", "-o", tmp_path / "m.plan",
        env={"UAVPLAN_THREADS": value},
    )  # fmt: skip
    line = one_error(result, 2)
    assert line.startswith("error: UAVPLAN_THREADS:") and repr(value) in line
    assert list(tmp_path.iterdir()) == []


def test_too_many_threads_is_a_warning_and_the_limit_is_the_kernels() -> None:
    from uavplan.cli.common import MAX_STEP_THREADS
    from uavplan.planners._kernels import STEP_THREADS_MAX

    assert MAX_STEP_THREADS == STEP_THREADS_MAX
    result = run("validate", ROOT / "missions" / "paper-env1.yaml", env={"UAVPLAN_THREADS": "abc"})
    assert result.exit_code == 0  # only the commands that plan read it
    result = run(
        "render", ROOT / "missions" / "paper-env1.yaml", "-o", "/nonexistent/x.png",
        env={"UAVPLAN_THREADS": "64"},
    )  # fmt: skip
    assert "warning: UAVPLAN_THREADS=64" in result.stderr


# =============================================================================================
# A reroute's messages: the file, and the time of the whole command


def test_a_reroute_without_a_route_names_the_file(tmp_path: Path) -> None:
    """The last waypoint stands in a closed ring of exclusion zones. The message used to
    name the plan's name ("fuzz: no collision-free route ...")."""
    ring = [
        {"inclusion": False, "polygon": [latlon(*p) for p in poly], "version": 1}
        for poly in (
            [(100, 100), (300, 100), (300, 130), (100, 130)],
            [(100, 270), (300, 270), (300, 300), (100, 300)],
            [(100, 100), (130, 100), (130, 300), (100, 300)],
            [(270, 100), (300, 100), (300, 300), (270, 300)],
        )
    ]
    items = [
        item(NAV_TAKEOFF, [0, 0, 0, None], at=(0.0, 0.0, 30.0)),
        item(NAV_WAYPOINT, [0, 0, 0, None], at=(200.0, 200.0, 30.0)),
    ]
    source = write(tmp_path, plan_doc(items, polygons=ring, circles=[]), "fuzz.plan")
    line = one_error(run("plan", source, "-o", tmp_path / "o.plan", *FAST), 3)
    assert line.startswith(f"error: {source}: no collision-free route")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fuzz.plan"]


def test_a_reroute_prints_the_time_of_the_whole_command(
    tmp_path: Path, user_plan: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A plan with a huge fence polygon took 254 s and said "planned in 2.24 s": the time
    was the search's alone. The clock of the use case is replaced: 254 s pass between its
    start and its end."""
    import uavplan.app.reroute as reroute

    ticks = iter([1000.0, 1254.0])
    monkeypatch.setattr(reroute, "time", types.SimpleNamespace(perf_counter=lambda: next(ticks)))
    result = run("plan", user_plan, "-o", tmp_path / "safe.plan", "--iterations", "150",
                 "--seed", "3")  # fmt: skip
    assert result.exit_code == 0, result.output
    summary = result.stderr.strip().splitlines()[-1]
    assert "rerouted in 254.00 s (the search " in summary and "planned in" not in summary
