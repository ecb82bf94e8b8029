"""Scenario and map files (SPEC §2): good files load into the right values, bad files are
rejected with one ``ScenarioError`` naming the file, the key path and the reason (exit 2)."""

from __future__ import annotations

import itertools
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from click.testing import CliRunner

from uavplan.cli import main
from uavplan.config import (
    EnergyWeights,
    GridSpec,
    PostParams,
    SearchParams,
    SpsaParams,
)
from uavplan.errors import EXIT_INPUT, ScenarioError
from uavplan.geo import GeoPoint
from uavplan.mission.items import Autopilot
from uavplan.obstacles import Bounds, BoxObstacle, CylinderObstacle, PrismObstacle
from uavplan.planning import build_world
from uavplan.scenario import (
    MissionConfig,
    PlannerConfig,
    Scenario,
    VehicleConfig,
    load_scenario,
)

# A small valid scenario; the bad files below are this one with one thing broken. It has one
# obstacle far from start and goal (see test_scenario_without_obstacles_loads for why).
BASE = """\
name: base
origin: {lat: 47.0, lon: 8.0, alt: 400}
bounds: {x: [0, 1000], y: [-500, 500], z: [0, 200]}
start: [0, 0, 30]
goal: [1000, 0, 40]
obstacles:
  - {type: cylinder, center: [500, 300], radius: 20, height: 100}
"""

FULL = """\
name: harbour
origin: {lat: 47.397742, lon: 8.545594, alt: 488.0}
bounds: {x: [0, 2000], y: [-600, 600], z: [0, 250]}
start: [0, 0, 30]
goal: [2000, 150, 40]
obstacles:
  - {type: box, center: [400, 50], size: [160, 120], height: 180, yaw: 15}
  - {type: cylinder, center: [900, -120], radius: 90, height: 220}
  # clockwise on purpose: the loader turns it counter-clockwise
  - {type: prism, polygon: [[1200, 0], [1300, 200], [1350, 40]], height: 150}
safety_margin: 12.5
vehicle: {cruise_speed: 12, takeoff_altitude: 25}
planner: {algorithm: pso, population: 40, iterations: 200, seed: 7}
mission: {autopilot: px4, spacing: 80, end: land}
"""

MAP = """\
name: the-map
origin: {lat: 47.5, lon: 8.5, alt: 420}
bounds: {x: [0, 1000], y: [-400, 400], z: [0, 150]}
obstacles:
  - {type: box, center: [300, 200], size: [50, 50], height: 100}
  - {type: cylinder, center: [600, -200], radius: 30, height: 100}
"""


def write(directory: Path, name: str, text: str) -> Path:
    path = directory / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(textwrap.dedent(text), encoding="utf-8")
    return path


def rejected(path: Path) -> ScenarioError:
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    err = info.value
    assert err.exit_code == EXIT_INPUT == 2
    assert "\n" not in str(err)
    return err


def assert_rejected(path: Path, key: str, reason: str, *, file: Path | None = None) -> None:
    """The message is exactly ``file: key: reason...`` with ``reason`` a substring."""
    err = rejected(path)
    file_name = str(file if file is not None else path)
    assert err.file == file_name
    assert err.key == key
    assert reason in err.reason
    assert str(err) == f"{file_name}: {key}: {err.reason}"


# --- good files -------------------------------------------------------------------------------


def test_full_scenario_with_all_three_obstacle_types(tmp_path: Path) -> None:
    scn = load_scenario(write(tmp_path, "full.yaml", FULL))
    assert isinstance(scn, Scenario)
    assert scn.name == "harbour"
    assert scn.origin == GeoPoint(47.397742, 8.545594, 488.0)
    assert scn.bounds == Bounds((0.0, 2000.0), (-600.0, 600.0), (0.0, 250.0))
    assert scn.start_m == (0.0, 0.0, 30.0)
    assert scn.goal_m == (2000.0, 150.0, 40.0)
    assert all(isinstance(v, float) for v in scn.start_m + scn.goal_m)
    box, cyl, prism = scn.obstacles
    assert box == BoxObstacle((400.0, 50.0), (160.0, 120.0), 180.0, 15.0)
    assert cyl == CylinderObstacle((900.0, -120.0), 90.0, 220.0)
    # same vertices, now counter-clockwise (positive shoelace area)
    assert isinstance(prism, PrismObstacle)
    assert prism.height_m == 150.0
    assert sorted(prism.polygon_m) == [(1200.0, 0.0), (1300.0, 200.0), (1350.0, 40.0)]
    p = prism.polygon_m
    area2 = sum(
        p[i][0] * p[(i + 1) % 3][1] - p[(i + 1) % 3][0] * p[i][1] for i in range(3)
    )  # 2 × signed area
    assert area2 > 0
    assert scn.safety_margin_m == 12.5
    assert scn.vehicle == VehicleConfig(cruise_speed_m_s=12.0, takeoff_altitude_m=25.0)
    assert scn.planner.algorithm == "pso"
    assert scn.planner.search == SearchParams(population=40, iterations=200, seed=7)
    assert scn.mission == MissionConfig(Autopilot.PX4, 80.0, "land")
    assert scn.source == str(tmp_path / "full.yaml")
    assert Scenario.from_file(tmp_path / "full.yaml") == scn


def test_box_footprint_follows_yaw() -> None:
    # 20 × 10 box at (100, 50) turned 90°: its x side now runs north.
    corners = BoxObstacle((100.0, 50.0), (20.0, 10.0), 5.0, 90.0).footprint()
    expected = [(105.0, 40.0), (105.0, 60.0), (95.0, 60.0), (95.0, 40.0)]
    for got, want in zip(corners, expected, strict=True):
        assert got == pytest.approx(want, abs=1e-12)


def test_closed_polygon_ring_is_accepted(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        "ring.yaml",
        BASE + "  - {type: prism, polygon: [[400, 100], [500, 100], [500, 200], [400, 100]],"
        " height: 20}\n",
    )
    assert load_scenario(path).obstacles[1].polygon_m == (
        (400.0, 100.0),
        (500.0, 100.0),
        (500.0, 200.0),
    )


def test_scenario_inherits_origin_bounds_and_obstacles_from_its_map(tmp_path: Path) -> None:
    write(tmp_path, "maps/city.yaml", MAP)
    path = write(
        tmp_path,
        "scenarios/s.yaml",
        """\
        map: ../maps/city.yaml
        start: [0, 0, 30]
        goal: [1000, 0, 40]
        obstacles:
          - {type: cylinder, center: [800, 300], radius: 10, height: 50}
        """,
    )
    scn = load_scenario(path)
    assert scn.name == "s"  # the map's name is not the scenario's
    assert scn.origin == GeoPoint(47.5, 8.5, 420.0)
    assert scn.bounds == Bounds((0.0, 1000.0), (-400.0, 400.0), (0.0, 150.0))
    # the map's obstacles first, then the scenario's own
    assert scn.obstacles == (
        BoxObstacle((300.0, 200.0), (50.0, 50.0), 100.0),
        CylinderObstacle((600.0, -200.0), 30.0, 100.0),
        CylinderObstacle((800.0, 300.0), 10.0, 50.0),
    )


def test_scenario_keys_override_the_map(tmp_path: Path) -> None:
    write(tmp_path, "maps/city.yaml", MAP)
    path = write(
        tmp_path,
        "s.yaml",
        """\
        map: maps/city.yaml
        origin: {lat: 10, lon: 20}
        bounds: {x: [-10, 1200], y: [-500, 500], z: [5, 300]}
        start: [0, 0, 30]
        goal: [1100, 0, 250]
        """,
    )
    scn = load_scenario(path)
    assert scn.origin == GeoPoint(10.0, 20.0, 0.0)  # alt defaults to 0
    assert scn.bounds == Bounds((-10.0, 1200.0), (-500.0, 500.0), (5.0, 300.0))
    assert len(scn.obstacles) == 2


def test_defaults(tmp_path: Path) -> None:
    scn = load_scenario(write(tmp_path, "plain-name.yaml", BASE.replace("name: base\n", "")))
    assert scn.name == "plain-name"  # the file's stem
    assert scn.safety_margin_m == 10.0
    assert scn.vehicle == VehicleConfig(None, None)
    assert scn.mission == MissionConfig(Autopilot.ARDUPILOT, 60.0, "rtl")
    assert scn.planner == PlannerConfig()
    assert scn.planner.algorithm == "spsa"
    assert scn.planner.search == SearchParams(
        population=30, iterations=1000, seed=1, t_max=10, init_half_window=10.0
    )
    assert scn.planner.grid is None  # not set: fitted to the flight volume
    assert scn.grid == GridSpec(20.0, 20.0, 10.0) and not scn.grid_coarsened  # a small one
    assert scn.planner.energy == EnergyWeights(1.0, 1.0, 1.0, 1.0)
    assert scn.planner.spsa == SpsaParams()
    assert scn.planner.post == PostParams()
    assert dict(scn.planner.options) == {}


def test_planner_overrides(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        "p.yaml",
        BASE
        + """\
planner:
  algorithm: pso
  population: 12
  iterations: 50
  seed: 0
  t_max: 3
  init_half_window: 4.5
  grid: {dx: 25, dy: 15, dz_m: 5}
  energy: {k0: 1, k1: 2.5, mu0: 0.5, k2: 3}
  spsa: {producer_ratio: 0.6, scrounger_ratio: 0.4, producer_rule: literal, oscillation: false,
         v_max: 3}
  post: {smooth: false, sample_step_m: 2.5}
  options: {w_start: 0.7}
""",
    )
    cfg = load_scenario(path).planner
    assert cfg.algorithm == "pso"
    assert cfg.search == SearchParams(
        population=12, iterations=50, seed=0, t_max=3, init_half_window=4.5
    )
    assert cfg.grid == GridSpec(dx_m=25.0, dy_m=15.0, dz_m=5.0)
    assert cfg.energy == EnergyWeights(k0=1.0, k1=2.5, mu0=0.5, k2=3.0)
    assert cfg.spsa == SpsaParams(
        producer_ratio=0.6,
        scrounger_ratio=0.4,
        producer_rule="literal",
        oscillation=False,
        v_max=3,
    )
    assert cfg.post == PostParams(smooth=False, sample_step_m=2.5)
    assert dict(cfg.options) == {"w_start": 0.7}


def test_start_and_goal_exactly_at_the_margin_are_accepted(tmp_path: Path) -> None:
    # cylinder r = 20 at (1000, 30): the goal (1000, 0) is 30 − 20 = 10 m away = the margin
    path = write(
        tmp_path,
        "edge.yaml",
        BASE + "  - {type: cylinder, center: [1000, 30], radius: 20, height: 100}\n",
    )
    assert len(load_scenario(path).obstacles) == 2


def test_scenario_without_obstacles_loads(tmp_path: Path) -> None:
    # SPEC §2: `obstacles` is optional and a map is optional
    text = BASE.split("obstacles:")[0]
    scn = load_scenario(write(tmp_path, "empty-sky.yaml", text))
    assert scn.obstacles == ()


# --- bad files: the file, the exact key path and the reason -----------------------------------


BAD = [
    # (id, text, key, reason substring)
    ("missing-start", BASE.replace("start: [0, 0, 30]\n", ""), "start", "missing required key"),
    ("missing-origin", BASE.replace("origin: {lat: 47.0, lon: 8.0, alt: 400}\n", ""), "origin",
     "missing required key"),
    ("missing-origin-lat", BASE.replace("lat: 47.0, ", ""), "origin.lat", "missing required key"),
    ("unknown-top-level-key", BASE + "speed: 3\n", "speed", "unknown key"),
    ("unknown-obstacle-key",
     BASE + "  - {type: cylinder, center: [500, -300], radius: 10, height: 20, colour: red}\n",
     "obstacles[1].colour", "unknown key"),
    ("obstacle-without-type", BASE + "  - {center: [500, -300], radius: 10, height: 20}\n",
     "obstacles[1].type", "missing required key"),
    ("unknown-obstacle-type",
     BASE + "  - {type: sphere, center: [500, -300], radius: 10, height: 20}\n",
     "obstacles[1].type", "must be one of box, cylinder, prism"),
    ("box-without-height", BASE + "  - {type: box, center: [500, -300], size: [10, 10]}\n",
     "obstacles[1].height", "missing required key"),
    ("string-for-a-number", BASE + "safety_margin: ten\n", "safety_margin",
     "must be a number, got a string"),
    ("bool-for-a-number",
     BASE + "  - {type: cylinder, center: [500, -300], radius: true, height: 20}\n",
     "obstacles[1].radius", "must be a number, got a boolean"),
    ("string-in-a-vector", BASE.replace("goal: [1000, 0, 40]", "goal: [1000, '0', 40]"),
     "goal[1]", "must be a number, got a string"),
    ("vector-too-short", BASE.replace("start: [0, 0, 30]", "start: [0, 0]"), "start",
     "must be a list of 3 numbers"),
    ("nan-margin", BASE + "safety_margin: .nan\n", "safety_margin", "finite"),
    ("negative-margin", BASE + "safety_margin: -1\n", "safety_margin", "must be >= 0"),
    ("start-outside-bounds", BASE.replace("start: [0, 0, 30]", "start: [-5, 0, 30]"), "start",
     "outside the bounds"),
    ("goal-above-bounds", BASE.replace("goal: [1000, 0, 40]", "goal: [1000, 0, 201]"), "goal",
     "outside the bounds"),
    ("goal-inside-an-obstacle",
     BASE + "  - {type: box, center: [1000, 0], size: [40, 40], height: 100}\n", "goal",
     "is inside obstacles[1]"),
    # cylinder r = 10 at (1000, 15): the goal is 15 − 10 = 5 m from it, margin 10
    ("goal-within-the-margin",
     BASE + "  - {type: cylinder, center: [1000, 15], radius: 10, height: 100}\n", "goal",
     "5.0 m from obstacles[1] (needs 10 m safety margin)"),
    # box roof at 25 m under the start at 30 m: 5 m < the 10 m margin
    ("start-within-the-margin-of-a-roof",
     BASE + "  - {type: box, center: [0, 0], size: [40, 40], height: 25}\n", "start",
     "5.0 m from obstacles[1]"),
    ("start-equals-goal-horizontally",
     BASE.replace("goal: [1000, 0, 40]", "goal: [0, 0, 60]"), "goal", "at least 1 m"),
    ("origin-latitude-95", BASE.replace("lat: 47.0", "lat: 95"), "origin.lat",
     "within [-90, 90]"),
    ("origin-longitude-200", BASE.replace("lon: 8.0", "lon: 200"), "origin.lon",
     "within [-180, 180]"),
    ("negative-box-size",
     BASE + "  - {type: box, center: [500, -300], size: [-10, 10], height: 20}\n",
     "obstacles[1].size[0]", "must be > 0"),
    ("zero-cylinder-radius",
     BASE + "  - {type: cylinder, center: [500, -300], radius: 0, height: 20}\n",
     "obstacles[1].radius", "must be > 0"),
    ("zero-height", BASE + "  - {type: box, center: [500, -300], size: [5, 5], height: 0}\n",
     "obstacles[1].height", "must be > 0"),
    ("polygon-with-2-points",
     BASE + "  - {type: prism, polygon: [[400, -100], [500, -100]], height: 20}\n",
     "obstacles[1].polygon", "at least 3"),
    ("self-intersecting-polygon",
     BASE + "  - {type: prism, polygon: [[400, -100], [500, -200], [500, -100], [400, -150]],"
     " height: 20}\n", "obstacles[1].polygon", "edges cross"),
    ("collinear-polygon",
     BASE + "  - {type: prism, polygon: [[400, -100], [450, -100], [500, -100]], height: 20}\n",
     "obstacles[1].polygon", "zero area"),
    ("polygon-point-not-a-pair",
     BASE + "  - {type: prism, polygon: [[400, -100], [450, -100, 3], [500, -50]], height: 20}\n",
     "obstacles[1].polygon[1]", "must be a list of 2 numbers"),
    ("bounds-min-greater-than-max", BASE.replace("x: [0, 1000]", "x: [1000, 0]"), "bounds.x",
     "needs min < max"),
    ("bounds-below-ground", BASE.replace("z: [0, 200]", "z: [-5, 200]"), "bounds.z",
     "below the ground"),
    ("obstacles-not-a-list", BASE.split("obstacles:")[0] + "obstacles: {type: box}\n",
     "obstacles", "must be a list"),
    ("obstacle-is-null", BASE + "  - null\n", "obstacles[1]", "must be a mapping"),
    ("unknown-algorithm", BASE + "planner: {algorithm: astar}\n", "planner.algorithm",
     "unknown algorithm 'astar' (available: spsa, ssa, pso, gwo, de, cso, spsa_numpy)"),
    ("float-population", BASE + "planner: {population: 30.5}\n", "planner.population",
     "must be an integer"),
    ("unknown-planner-key", BASE + "planner: {swarm: 3}\n", "planner.swarm", "unknown key"),
    ("unknown-grid-key", BASE + "planner: {grid: {dw: 3}}\n", "planner.grid.dw", "unknown key"),
    ("string-energy-weight", BASE + "planner: {energy: {k1: high}}\n", "planner.energy.k1",
     "must be a number"),
    ("spsa-ratios-not-summing-to-1", BASE + "planner: {spsa: {producer_ratio: 0.5}}\n",
     "planner.spsa.scrounger_ratio", "producer_ratio + scrounger_ratio must be 1"),
    ("unknown-mission-end", BASE + "mission: {end: loiter}\n", "mission.end",
     "must be one of rtl, land, none, return"),
    ("unknown-autopilot", BASE + "mission: {autopilot: betaflight}\n", "mission.autopilot",
     "must be one of px4, ardupilot"),
    ("vehicle-speed-string", BASE + "vehicle: {cruise_speed: fast}\n", "vehicle.cruise_speed",
     "must be a number"),
    ("top-level-list", "- 1\n- 2\n", "(top level)", "must be a mapping, got a list"),
]  # fmt: skip


@pytest.mark.parametrize(("text", "key", "reason"), [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_file_is_rejected_with_file_key_and_reason(
    tmp_path: Path, text: str, key: str, reason: str
) -> None:
    assert_rejected(write(tmp_path, "bad.yaml", text), key, reason)


def test_bad_yaml_syntax_names_the_line(tmp_path: Path) -> None:
    # the flow mapping opened on line 8 is never closed: the parser notices at the stream end
    path = write(tmp_path, "syntax.yaml", BASE + "  - {type: box, center: [1, 2]\n")
    err = rejected(path)
    assert err.file == str(path)
    assert err.key is None  # no key can be named in a file that does not parse
    assert str(err).startswith(f"{path}: invalid YAML: line 9, column 1: ")
    # an error in the middle of the file names that line
    broken = BASE.replace("start: [0, 0, 30]", "start: [0, 0, 30")
    err = rejected(write(tmp_path, "syntax2.yaml", broken))
    assert "invalid YAML: line 5" in str(err)


def test_tab_indentation_is_a_yaml_error(tmp_path: Path) -> None:
    err = rejected(write(tmp_path, "tabs.yaml", "start:\n\t- 1\n"))
    assert str(err).startswith(f"{tmp_path / 'tabs.yaml'}: invalid YAML: line 2")


@pytest.mark.parametrize("text", ["", "\n\n", "# only a comment\n"])
def test_empty_file_is_rejected(tmp_path: Path, text: str) -> None:
    path = write(tmp_path, "empty.yaml", text)
    err = rejected(path)
    assert err.file == str(path)
    assert str(err) == f"{path}: the scenario file is empty"


def test_missing_scenario_file(tmp_path: Path) -> None:
    err = rejected(tmp_path / "nowhere.yaml")
    assert str(err) == f"{tmp_path / 'nowhere.yaml'}: scenario file not found"


def test_missing_map_file(tmp_path: Path) -> None:
    path = write(tmp_path, "s.yaml", BASE + "map: ../maps/absent.yaml\n")
    assert_rejected(path, "map", "map file '../maps/absent.yaml' not found")
    assert str((tmp_path.parent / "maps" / "absent.yaml").resolve()) in rejected(path).reason


def test_error_inside_the_map_names_the_map_file(tmp_path: Path) -> None:
    map_path = write(
        tmp_path,
        "maps/broken.yaml",
        MAP + "  - {type: cylinder, center: [10, 10], radius: -3, height: 100}\n",
    )
    scn_path = write(tmp_path, "scenarios/s.yaml", BASE + "map: ../maps/broken.yaml\n")
    assert_rejected(scn_path, "obstacles[2].radius", "must be > 0", file=map_path.resolve())


def test_scenario_only_key_in_a_map_is_rejected(tmp_path: Path) -> None:
    map_path = write(tmp_path, "maps/m.yaml", MAP + "start: [0, 0, 30]\n")
    scn_path = write(tmp_path, "s.yaml", BASE + "map: maps/m.yaml\n")
    assert_rejected(scn_path, "start", "unknown key", file=map_path.resolve())


def test_bad_yaml_in_the_map_names_the_map_file(tmp_path: Path) -> None:
    map_path = write(tmp_path, "maps/m.yaml", "obstacles: [\n")
    scn_path = write(tmp_path, "s.yaml", BASE + "map: maps/m.yaml\n")
    err = rejected(scn_path)
    assert err.file == str(map_path.resolve())
    assert "invalid YAML: line 2" in err.reason


def test_population_below_four_is_rejected(tmp_path: Path) -> None:
    err = rejected(write(tmp_path, "pop.yaml", BASE + "planner: {population: 2}\n"))
    assert "must be an integer >= 4" in err.reason
    assert err.key == "planner.population"


@pytest.mark.parametrize(
    ("planner", "key", "reason"),
    [
        ("{population: 2}", "planner.population", ">= 4"),
        ("{seed: -1}", "planner.seed", ">= 0"),
        ("{grid: {dx: 0}}", "planner.grid.dx", "must be a number >= 0.1"),
    ],
)
def test_planner_value_errors_name_the_key(
    tmp_path: Path, planner: str, key: str, reason: str
) -> None:
    path = write(tmp_path, "pop.yaml", BASE + f"planner: {planner}\n")
    assert_rejected(path, key, reason)
    assert "dx_m" not in rejected(path).reason


def test_unknown_algorithm_options_are_rejected_at_load(tmp_path: Path) -> None:
    assert_rejected(
        write(tmp_path, "opt.yaml", BASE + "planner: {algorithm: pso, options: {inertia: 1}}\n"),
        "planner.options.inertia",
        "unknown key (allowed: c1, c2, v_max_fraction, w_end, w_start)",
    )
    assert_rejected(
        write(tmp_path, "opt2.yaml", BASE + "planner: {algorithm: ssa, options: {w: 1}}\n"),
        "planner.options",
        "takes no parameters",
    )


def test_options_that_are_not_a_mapping_are_rejected(tmp_path: Path) -> None:
    assert_rejected(
        write(tmp_path, "opt.yaml", BASE + "planner: {options: 3}\n"),
        "planner.options",
        "must be a mapping",
    )


def test_obstacle_index_in_geometry_errors_refers_to_the_scenario_file(tmp_path: Path) -> None:
    write(tmp_path, "maps/city.yaml", MAP)
    path = write(
        tmp_path,
        "s.yaml",
        """\
        map: maps/city.yaml
        start: [0, 0, 30]
        goal: [1000, 0, 40]
        obstacles:
          - {type: cylinder, center: [1000, 0], radius: 5, height: 100}
        """,
    )
    assert_rejected(path, "goal", "inside obstacles[0]")


# --- the command line -------------------------------------------------------------------------


def test_cli_validate_good_file_exits_0(tmp_path: Path) -> None:
    path = write(tmp_path, "full.yaml", FULL)
    result = CliRunner().invoke(main, ["validate", str(path)])
    assert result.exit_code == 0, result.output
    assert "ok" in result.stdout
    assert "3 obstacles" in result.stdout


def _cli_bad_file(tmp_path: Path) -> Path:
    return write(tmp_path, "bad.yaml", BASE.replace("lat: 47.0", "lat: 95"))


def test_cli_validate_bad_file_exits_2_with_one_line(tmp_path: Path) -> None:
    path = _cli_bad_file(tmp_path)
    result = CliRunner().invoke(main, ["validate", str(path)])
    assert result.exit_code == 2
    assert result.stdout == ""
    lines = result.stderr.splitlines()
    assert len(lines) == 1
    assert f"{path}: origin.lat: must be within [-90, 90] degrees, got 95" in lines[0]
    assert "Traceback" not in result.stderr
    assert result.exception is None or isinstance(result.exception, SystemExit)


@pytest.mark.parametrize(
    "text",
    ["", "key: [\n", "- 1\n", BASE + "speed: 3\n"],
    ids=["empty", "syntax", "list", "unknown-key"],
)
def test_cli_validate_other_bad_files_exit_2(tmp_path: Path, text: str) -> None:
    path = write(tmp_path, "bad.yaml", text)
    result = CliRunner().invoke(main, ["validate", str(path)])
    assert result.exit_code == 2
    assert len(result.stderr.splitlines()) == 1
    assert str(path) in result.stderr


def test_cli_validate_in_a_real_process(tmp_path: Path) -> None:
    path = _cli_bad_file(tmp_path)
    script = Path(sys.executable).with_name("uavplan")  # the installed console script
    if script.is_file():
        command = [str(script)]
    else:  # pragma: no cover - not installed as a script: call what it calls
        command = [sys.executable, "-c", "from uavplan.cli import main; main()"]
    proc = subprocess.run(
        [*command, "validate", str(path)], capture_output=True, text=True, timeout=60
    )
    assert proc.returncode == 2, proc.stderr
    assert proc.stdout == ""
    assert len(proc.stderr.splitlines()) == 1
    assert "origin.lat" in proc.stderr
    assert "Traceback" not in proc.stderr


# --- hostile and oversized input (issue 12) ---------------------------------------------------


def write_bytes(directory: Path, name: str, data: bytes) -> Path:
    path = directory / name
    path.write_bytes(data)
    return path


@pytest.mark.parametrize(
    ("change", "key", "reason"),
    [
        ("safety_margin: " + "9" * 400 + "\n", "safety_margin", "out of range"),
        ("planner: {population: 1099511627776}\n", "planner.population", "<= 10000"),
        ("planner: {post: {sample_step_m: 1.0e-9}}\n", "planner.post.sample_step_m", ">= 0.1"),
        ("planner: {energy: {k0: 1.0e+308}}\n", "planner.energy.k0", "<= 1e+06"),
        ("planner: {t_max: 1000000000}\n", "planner.t_max", "<= 1000"),
        ("planner: {spsa: {oscillation_window: 1000000000}}\n",
         "planner.spsa.oscillation_window", "<= 1000"),
        ("planner: {iterations: 1000000, population: 10000}\n", "planner.iterations",
         "too large to plan"),
        ("safety_margin: 1.0e+300\n", "safety_margin", "must be <= 10000"),
    ],
)  # fmt: skip
def test_values_that_crashed_or_hung_are_refused(
    tmp_path: Path, change: str, key: str, reason: str
) -> None:
    assert_rejected(write(tmp_path, "s.yaml", BASE + change), key, reason)


def test_overlong_name_is_refused(tmp_path: Path) -> None:
    path = write(tmp_path, "s.yaml", BASE.replace("name: base", "name: " + "n" * 300))
    assert_rejected(path, "name", "1 to 200 characters")


def test_cylinder_centre_far_away_is_refused(tmp_path: Path) -> None:
    text = BASE + "  - {type: cylinder, center: [-1.0e+308, 0], radius: 5, height: 10}\n"
    assert_rejected(write(tmp_path, "s.yaml", text), "obstacles[1].center[0]", "within ±1e+06")


def test_huge_integer_beyond_python_conversion_limit(tmp_path: Path) -> None:
    path = write(tmp_path, "s.yaml", BASE + "safety_margin: " + "7" * 5000 + "\n")
    assert "invalid YAML" in rejected(path).reason


def test_deeply_nested_lists_are_refused(tmp_path: Path) -> None:
    deep = "[" * 1000 + "]" * 1000
    err = rejected(write(tmp_path, "s.yaml", BASE.replace("[0, 0, 30]", deep)))
    assert "nested more than 64 levels deep" in err.reason


@pytest.mark.parametrize(
    "depth",
    [65, 999, 1000, pytest.param(5000, marks=pytest.mark.slow)],  # 5000: over 0.5 s
)
def test_nesting_is_refused_in_our_words_at_any_depth(tmp_path: Path, depth: int) -> None:
    """Flow and block nesting past our limit get our message whether or not the YAML parser
    has a limit of its own (libyaml's, 1,000 in PyYAML 6.0.4, is reported in its words)."""
    flow = "[" * depth + "]" * depth
    err = rejected(write(tmp_path, "f.yaml", BASE.replace("[0, 0, 30]", flow)))
    assert "nested more than 64 levels deep" in err.reason
    block = "".join(" " * i + "-\n" for i in range(depth))
    err = rejected(write(tmp_path, "b.yaml", BASE + "extra:\n" + block))
    assert "nested more than 64 levels deep" in err.reason


def test_billion_laughs_alias_is_refused_quickly(tmp_path: Path) -> None:
    lines = ['a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    names = "abcdefghi"
    for prev, cur in itertools.pairwise(names):
        lines.append(f"{cur}: &{cur} [" + ",".join([f"*{prev}"] * 9) + "]")
    text = "\n".join(lines) + "\nstart: *i\n"
    assert len(text.encode()) < 700
    err = rejected(write(tmp_path, "s.yaml", text))
    assert "once its aliases are expanded" in err.reason
    assert len(str(err)) < 300


def test_an_alias_inside_itself_is_refused(tmp_path: Path) -> None:
    err = rejected(write(tmp_path, "s.yaml", BASE + "vehicle: &v [1, *v]\n"))
    assert "refers to its own anchor" in err.reason
    err = rejected(write(tmp_path, "t.yaml", BASE + "vehicle: &v {x: *v}\n"))
    assert "recursive" in err.reason


def test_error_messages_render_big_values_briefly(tmp_path: Path) -> None:
    text = BASE.replace("[0, 0, 30]", "[" + ", ".join(["[1, 2, 3]"] * 5000) + "]")
    err = rejected(write(tmp_path, "s.yaml", text))
    assert err.key == "start" and len(err.reason) < 120


def test_duplicate_keys_are_refused_naming_the_key(tmp_path: Path) -> None:
    err = rejected(write(tmp_path, "s.yaml", BASE + "safety_margin: 5\nsafety_margin: 6\n"))
    assert "duplicate key 'safety_margin'" in err.reason and "line 9" in err.reason
    err = rejected(write(tmp_path, "t.yaml", BASE + "planner: {seed: 1, seed: 2}\n"))
    assert "duplicate key 'seed'" in err.reason


def test_merge_keys_still_work(tmp_path: Path) -> None:
    text = BASE + "vehicle: {<<: {cruise_speed: 5}, takeoff_altitude: 30}\n"
    assert load_scenario(write(tmp_path, "s.yaml", text)).vehicle.cruise_speed_m_s == 5


def test_encodings(tmp_path: Path) -> None:
    scn = load_scenario(write_bytes(tmp_path, "bom.yaml", b"\xef\xbb\xbf" + BASE.encode()))
    assert scn.name == "base"
    err = rejected(write_bytes(tmp_path, "u16.yaml", BASE.encode("utf-16")))
    assert "UTF-16 encoded; save it as UTF-8" in err.reason
    err = rejected(
        write_bytes(tmp_path, "latin.yaml", BASE.replace("base", "bäse").encode("latin-1"))
    )
    assert "not UTF-8 text (byte 0xe4 on line 1)" in err.reason


@pytest.mark.parametrize(
    ("ref", "reason"),
    [("maps/a\\0b.yaml", "no NUL character"), ("m" * 300 + ".yaml", "path is too long")],
)
def test_bad_map_paths(tmp_path: Path, ref: str, reason: str) -> None:
    assert_rejected(write(tmp_path, "s.yaml", BASE + f'map: "{ref}"\n'), "map", reason)


def test_map_that_is_a_directory(tmp_path: Path) -> None:
    (tmp_path / "maps").mkdir()
    assert_rejected(write(tmp_path, "s.yaml", BASE + "map: maps\n"), "map", "not found")


def test_start_or_goal_on_the_ground_is_an_input_error(tmp_path: Path) -> None:
    err = rejected(write(tmp_path, "s.yaml", BASE.replace("[0, 0, 30]", "[0, 0, 0]")))
    assert err.key == "start[2]" and "must be above the ground" in err.reason
    assert "take-off climb" in err.reason
    err = rejected(write(tmp_path, "g.yaml", BASE.replace("[1000, 0, 40]", "[1000, 0, 0]")))
    assert err.key == "goal[2]" and "mission.end: land" in err.reason


def test_takeoff_altitude_above_the_ceiling_is_refused(tmp_path: Path) -> None:
    path = write(tmp_path, "s.yaml", BASE + "vehicle: {takeoff_altitude: 250}\n")
    assert_rejected(path, "vehicle.takeoff_altitude", "above the ceiling")
    ok = write(tmp_path, "ok.yaml", BASE + "vehicle: {takeoff_altitude: 200}\n")
    assert load_scenario(ok).vehicle.takeoff_altitude_m == 200


def test_too_large_a_grid_is_refused_by_validate_and_plan_alike(tmp_path: Path) -> None:
    text = BASE.replace("x: [0, 1000], y: [-500, 500]", "x: [0, 100000], y: [-50000, 50000]")
    path = write(tmp_path, "big.yaml", text + "planner: {grid: {dx: 1, dy: 1, dz: 1}}\n")
    assert_rejected(path, "planner.grid", "too large to plan")
    for args in (["validate", str(path)], ["plan", str(path), "-o", str(tmp_path / "o.plan")]):
        result = CliRunner().invoke(main, args)
        assert result.exit_code == 2, result.output
        assert "too large to plan" in result.output
    assert not (tmp_path / "o.plan").exists()


def test_problem_size_estimate() -> None:
    from uavplan.scenario import problem_size

    scn = Scenario(
        "s",
        GeoPoint(47.0, 8.0, 0.0),
        Bounds((0.0, 1000.0), (-500.0, 500.0), (0.0, 200.0)),
        (0.0, 0.0, 30.0),
        (1000.0, 0.0, 40.0),
        (),
    )
    size = problem_size(scn)
    assert size["columns"] == 50
    assert size["grid_cells"] == 51 * 51 * 21
    assert size["search_work"] == 30 * 1000 * 50
    assert size["route_samples"] == 2 * 1000 / 5


def test_validate_does_not_load_numba(tmp_path: Path) -> None:
    path = write(tmp_path, "full.yaml", FULL)
    code = (
        "import sys; from click.testing import CliRunner; from uavplan.cli import main; "
        f"r = CliRunner().invoke(main, ['validate', {str(path)!r}]); "
        "print(r.exit_code, 'numba' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.stdout.split() == ["0", "False"], out.stderr


def test_plain_numpy_clearances_match_the_world(tmp_path: Path) -> None:
    """The validation's exact distances (no compiled kernels) agree with the world's."""
    import numpy as np

    from uavplan.scenario.clearance import column_clearance, point_clearance

    scn = load_scenario(write(tmp_path, "full.yaml", FULL))
    world = build_world(scn)
    rng = np.random.default_rng(3)
    for _ in range(200):
        p = (rng.uniform(-100, 2100), rng.uniform(-700, 700), rng.uniform(1, 260))
        dist, index = point_clearance(scn.obstacles, p)
        ref, ref_index = world.nearest_obstacle(p)
        if ref > 0:
            assert dist == pytest.approx(ref, abs=1e-6)
            assert index == ref_index
        else:
            assert dist == 0.0
        column, _ = column_clearance(scn.obstacles, p[:2])
        ground = np.array([[p[0], p[1], 0.0]])
        top = np.array([p])
        ref_col, _ = world.segments_clearance(ground, top)
        assert column == pytest.approx(max(float(ref_col[0]), 0.0), abs=1e-6)


def test_large_polygons_are_checked_and_capped(tmp_path: Path) -> None:
    import math

    def ring(n: int, r: float = 50.0) -> list[list[float]]:
        return [
            [round(500 + r * math.cos(2 * math.pi * i / n), 6),
             round(-300 + r * math.sin(2 * math.pi * i / n), 6)]
            for i in range(n)
        ]  # fmt: skip

    def prism(points: list[list[float]]) -> str:
        return BASE + f"  - {{type: prism, polygon: {points}, height: 20}}\n"

    assert len(load_scenario(write(tmp_path, "ok.yaml", prism(ring(1000)))).obstacles) == 2
    crossed = ring(1000)
    crossed[10], crossed[500] = crossed[500], crossed[10]
    assert_rejected(write(tmp_path, "x.yaml", prism(crossed)), "obstacles[1].polygon", "cross")
    assert_rejected(
        write(tmp_path, "big.yaml", prism(ring(1002))), "obstacles[1].polygon", "at most 1000"
    )


# --- no unchecked scenario (issue 25) ---------------------------------------------------------


def _plain(**changes: object) -> Scenario:
    values: dict[str, object] = {
        "name": "made",
        "origin": GeoPoint(47.0, 8.0, 400.0),
        "bounds": Bounds((0.0, 1000.0), (-500.0, 500.0), (0.0, 200.0)),
        "start_m": (0.0, 0.0, 30.0),
        "goal_m": (1000.0, 0.0, 40.0),
        "obstacles": (CylinderObstacle((500.0, 0.0), 40.0, 100.0),),
        "source": "made-in-code",
    }
    values.update(changes)
    return Scenario(**values)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("changes", "key", "reason"),
    [
        ({"start_m": (500.0, 10.0, 30.0)}, "start", "is inside obstacles[0]"),
        ({"goal_m": (1200.0, 0.0, 40.0)}, "goal", "outside the bounds"),
        ({"via_m": ((0.5, 0.0, 40.0),)}, "via[0]", "at least 1 m away"),
        ({"start_m": (545.0, 0.0, 130.0)}, "start", "take-off climb above [545.0, 0.0]"),
        ({"safety_margin_m": -1.0}, "safety_margin", "within [0, 10000] m"),
        ({"bounds": Bounds((0.0, 1000.0), (-500.0, 500.0), (-5.0, 200.0))}, "bounds.z", "below"),
        ({"origin": GeoPoint(89.95, 8.0)}, "origin.lat", "too close to a pole"),
    ],
)
def test_a_scenario_made_in_code_is_checked_like_a_file(
    changes: dict[str, object], key: str, reason: str
) -> None:
    with pytest.raises(ScenarioError) as info:
        _plain(**changes)
    assert info.value.file == "made-in-code" and info.value.key == key
    assert reason in info.value.reason


def test_a_copy_is_checked_too() -> None:
    from dataclasses import replace

    scn = _plain()
    with pytest.raises(ScenarioError, match=r"start: .* is inside obstacles\[0\]"):
        replace(scn, start_m=(505.0, 0.0, 60.0))
    with pytest.raises(ScenarioError, match=r"planner\.grid: the scenario is too large"):
        scn.with_planner(grid=GridSpec(dx_m=1.0, dy_m=1.0, dz_m=1.0))


def test_a_stretch_that_begins_in_the_air_has_no_take_off_climb() -> None:
    """A stretch of a user's flight (the rerouting plans those) starts at a position in the
    air: above a low obstacle is fine for it, not for a scenario that takes off there."""
    from dataclasses import replace

    above = {"start_m": (505.0, 0.0, 130.0)}
    with pytest.raises(ScenarioError, match="take-off climb"):
        _plain(**above)
    airborne = replace(MissionConfig(), takeoff=False, end="none")
    assert _plain(**above, mission=airborne).start_m == (505.0, 0.0, 130.0)
