"""``uavplan render`` and ``plan --plot``: a PNG of the requested size for every bundled
scenario, with the route drawn; mission files drawn without planning; bad options exit 2.

Pictures are small and low-DPI to keep the suite fast; what they look like is checked by
eye (README, docs/images), here only that they are complete and hold the route's colour.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from uavplan.cli import main
from uavplan.geo import EnuFrame
from uavplan.geometry2d import orient_ccw
from uavplan.mission.builder import build_mission
from uavplan.mission.fence import build_geofence, geofence_for_route
from uavplan.mission.io import save_mission
from uavplan.mission.items import Autopilot
from uavplan.render import RouteLayers, Scene, render_scene, scene_for
from uavplan.route import PlannedRoute, flown_polyline
from uavplan.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]
BUNDLED = sorted((ROOT / "missions").glob("*.yaml"))
FLOWN_RGB = (0xFF, 0x7F, 0x0E)  # the route / waypoint colour
SMALL = ["--size", "480x240", "--dpi", "40"]


def png_ok(path: Path, size: tuple[int, int]) -> Image.Image:
    assert path.stat().st_size > 0
    with Image.open(path) as image:
        assert image.format == "PNG"
        assert image.size == size
        rgb = image.convert("RGB")
    pixels = np.asarray(rgb).reshape(-1, 3)
    assert len(np.unique(pixels, axis=0)) > 50, "the picture is (nearly) blank"
    return rgb


def colour_pixels(image: Image.Image, rgb: tuple[int, int, int], tol: int = 40) -> int:
    pixels = np.asarray(image).reshape(-1, 3).astype(int)
    return int((np.abs(pixels - np.array(rgb)).max(axis=1) <= tol).sum())


def run(*args: str):
    return CliRunner().invoke(main, list(args))


@pytest.mark.parametrize("scenario", BUNDLED, ids=lambda p: p.stem)
@pytest.mark.slow
def test_render_every_bundled_scenario(scenario: Path, tmp_path: Path) -> None:
    out = tmp_path / f"{scenario.stem}.png"
    result = run("render", str(scenario), "-o", str(out), "--iterations", "3", "-q", *SMALL)
    # a 3-iteration route may miss the margin (exit 3), but the picture is drawn either way
    assert result.exit_code in (0, 3), result.output
    image = png_ok(out, (480, 240))
    assert colour_pixels(image, FLOWN_RGB) > 20, "no route drawn"


def test_bundled_scenarios_are_there() -> None:
    assert {p.stem for p in BUNDLED} >= {
        "paper-env1",
        "paper-env2",
        "paper-env3",
        "midtown-manhattan",
    }


@pytest.mark.slow
def test_render_a_mission_file_plans_nothing(tmp_path: Path, monkeypatch) -> None:
    scenario = ROOT / "missions" / "paper-env1.yaml"
    scn = load_scenario(scenario)
    frame = EnuFrame.at(scn.origin)
    waypoints = np.array([[0, 0, 30], [300, 300, 40], [1700, 300, 40], [2000, 100, 40.0]])
    # it lands at the goal: PX4's return to launch at 60 m would cross obstacle #0 (exit 3)
    plan = build_mission(waypoints, frame, autopilot=Autopilot.PX4, end="land")
    mission = tmp_path / "m.plan"
    save_mission(plan, mission)

    import uavplan.planning

    def no_planning(*_a, **_k):
        raise AssertionError("render --mission must not plan")

    monkeypatch.setattr(uavplan.planning, "plan_route", no_planning)
    out = tmp_path / "m.png"
    result = run("render", str(scenario), "--mission", str(mission), "-o", str(out), *SMALL)
    assert result.exit_code == 0, result.output
    assert "m.plan: 5 items" in result.output and "min clearance" in result.output
    png_ok(out, (480, 240))


@pytest.mark.slow
def test_render_scenario_only_and_exact_sizes(tmp_path: Path) -> None:
    scenario = ROOT / "missions" / "paper-env1.yaml"
    for size, dpi in (("500x500", "50"), ("731x333", "37")):
        out = tmp_path / f"s{size}.png"
        result = run(
            "render", str(scenario), "--no-plan", "-o", str(out), "--size", size, "--dpi", dpi
        )
        assert result.exit_code == 0, result.output
        width, height = (int(v) for v in size.split("x"))
        image = png_ok(out, (width, height))
        assert colour_pixels(image, FLOWN_RGB) == 0  # no route


@pytest.mark.slow
def test_plan_plot_draws_the_planned_route(tmp_path: Path) -> None:
    scenario = tmp_path / "tiny.yaml"
    scenario.write_text(
        "origin: {lat: 40.7, lon: -74.0, alt: 10}\n"
        "bounds: {x: [0, 400], y: [-100, 100], z: [0, 80]}\n"
        "start: [0, 0, 20]\ngoal: [400, 0, 20]\n"
        "obstacles: [{type: cylinder, center: [200, 0], radius: 30, height: 70}]\n"
        "planner: {population: 12, iterations: 30, seed: 4}\n"
    )
    out = tmp_path / "plot.png"
    result = run("plan", str(scenario), "-o", str(tmp_path / "m.plan"), "--plot", str(out), "-q")
    assert result.exit_code == 0, result.output
    image = png_ok(out, (1600, 800))
    assert colour_pixels(image, FLOWN_RGB) > 100


def test_route_layers_from_a_mission_with_fence() -> None:
    scn = load_scenario(ROOT / "missions" / "paper-env1.yaml")
    frame = EnuFrame.at(scn.origin)
    waypoints = np.array([[0, 0, 30], [300, 300, 40], [1700, 300, 40], [2000, 100, 40.0]])
    plan = build_mission(waypoints, frame, autopilot=Autopilot.ARDUPILOT)
    from dataclasses import replace

    from uavplan.mission.builder import mission_polyline_enu

    built = build_geofence(
        scn.obstacles,
        mission_polyline_enu(plan, frame),
        frame,
        bounds_xy_m=(scn.bounds.x_m, scn.bounds.y_m),
        margin_m=scn.safety_margin_m,
    )
    plan = replace(plan, fence=built.fence)
    layers = RouteLayers.from_mission(plan, frame)
    assert layers.flown_enu is not None and layers.waypoints_enu is not None
    np.testing.assert_allclose(layers.flown_enu[0], [0, 0, 0], atol=1e-6)
    np.testing.assert_allclose(layers.waypoints_enu[1:], waypoints[1:], atol=1e-3)
    assert layers.fence[0].inclusion
    assert layers.fence[0].polygon_enu is not None
    # the bounds grown by the margin and the 2 m gap: a route on their edge keeps the margin
    np.testing.assert_allclose(layers.fence[0].polygon_enu.min(axis=0), [-12, -612], atol=1e-3)


def test_route_layers_from_a_planned_route_use_its_own_lines_and_fence() -> None:
    """A just-planned route is drawn from its PlannedRoute and the fence built for it, in
    ENU, nothing traced back from mission items; the same picture as from its mission."""
    scn = load_scenario(ROOT / "missions" / "paper-env1.yaml")
    frame = EnuFrame.at(scn.origin)
    waypoints = np.array([[0, 0, 30], [300, 300, 40], [1700, 300, 40], [2000, 100, 40.0]])
    raw = waypoints + np.array([0.0, 5.0, 0.0])
    route = PlannedRoute(
        frame=frame,
        waypoints_enu=waypoints,
        path_enu=waypoints,
        vertices_enu=waypoints,
        raw_path_enu=raw,
        flown_enu=flown_polyline(waypoints),
        min_clearance_m=20.0,
        safety_margin_m=scn.safety_margin_m,
        inside_bounds=True,
    )
    built = geofence_for_route(route, scn.obstacles, scn.bounds)
    layers = RouteLayers.from_route(route, built)
    assert layers.flown_enu is route.flown_enu and layers.raw_path_enu is raw
    assert layers.smoothed_path_enu is route.path_enu
    assert layers.fence[0].inclusion and layers.fence[0].polygon_enu is built.inclusion_enu
    excluded = [z for z in built.zones if z.polygon_enu is not None or z.circle_enu is not None]
    excluded = [z for z in excluded if z.status.value == "excluded"]
    assert len(layers.fence) == 1 + len(excluded)
    # the mission built from it draws the same line and the same fence (to < 1 mm)
    from dataclasses import replace

    plan = replace(build_mission(waypoints, frame, autopilot=Autopilot.PX4), fence=built.fence)
    traced = RouteLayers.from_mission(plan, frame)
    assert traced.flown_enu is not None and layers.flown_enu is not None
    assert traced.waypoints_enu is not None and layers.waypoints_enu is not None
    np.testing.assert_allclose(traced.flown_enu, layers.flown_enu, atol=1e-3)
    np.testing.assert_allclose(traced.waypoints_enu, layers.waypoints_enu, atol=1e-3)
    for a, b in zip(traced.fence, layers.fence, strict=True):
        assert a.inclusion == b.inclusion
        if a.polygon_enu is not None:
            assert b.polygon_enu is not None
            # the file keeps QGC's clockwise order; the fence build is counter-clockwise
            np.testing.assert_allclose(orient_ccw(a.polygon_enu), b.polygon_enu, atol=1e-3)
        else:
            assert a.circle_enu == pytest.approx(b.circle_enu, abs=1e-3)


@pytest.mark.slow
def test_render_a_scene_of_plain_values(tmp_path: Path) -> None:
    from uavplan.obstacles import Bounds, BoxObstacle, CylinderObstacle

    scene = Scene(
        name="plain values",
        bounds=Bounds((0.0, 400.0), (-100.0, 100.0), (0.0, 80.0)),
        obstacles=(
            BoxObstacle((150.0, 0.0), (40.0, 60.0), 50.0, 20.0),
            CylinderObstacle((300.0, 40.0), 15.0, 70.0),
        ),
        safety_margin_m=5.0,
        start_enu=(0.0, 0.0, 30.0),
        goal_enu=(400.0, 0.0, 30.0),
    )
    line = np.array([[0.0, 0.0, 30.0], [150.0, -60.0, 30.0], [400.0, 0.0, 30.0]])
    layers = RouteLayers(flown_enu=line, waypoints_enu=line)
    out = tmp_path / "plain.png"
    render_scene(scene, out, layers, width_px=800, height_px=400, dpi=50)
    image = png_ok(out, (800, 400))
    without = tmp_path / "without.png"
    render_scene(scene, without, width_px=800, height_px=400, dpi=50)
    # the route's colour appears only with the route drawn
    drawn = colour_pixels(image, FLOWN_RGB)
    assert drawn >= 20 > colour_pixels(png_ok(without, (800, 400)), FLOWN_RGB)
    assert [fp.kind for fp in scene.footprints] == ["box", "cylinder"]


def test_scene_for_a_scenario_is_its_plain_values() -> None:
    scn = load_scenario(ROOT / "missions" / "paper-env1.yaml")
    scene = scene_for(scn)
    assert scene.name == scn.name and scene.bounds == scn.bounds
    assert scene.safety_margin_m == scn.safety_margin_m
    assert scene.start_enu == tuple(scn.start_m) and scene.goal_enu == tuple(scn.goal_m)
    assert len(scene.footprints) == len(scn.obstacles)


def test_render_rejects_bad_input(tmp_path: Path) -> None:
    scenario = str(ROOT / "missions" / "paper-env1.yaml")
    out = str(tmp_path / "x.png")
    cases = [
        (["render", scenario, "-o", str(tmp_path / "x.jpg")], "PNG"),
        (["render", scenario, "-o", out, "--size", "big"], "WIDTHxHEIGHT"),
        (["render", scenario, "-o", out, "--size", "100x50"], "width 200"),
        (["render", scenario, "-o", out, "--mission", out, "--seed", "1"], "no planner options"),
        (["render", str(tmp_path / "none.yaml"), "-o", out], "not found"),
        (
            ["plan", scenario, "-o", str(tmp_path / "m.plan"), "--plot", str(tmp_path / "p.pdf")],
            "PNG",
        ),
    ]
    for args, message in cases:
        result = run(*args)
        assert result.exit_code == 2, (args, result.output)
        assert message in result.output, (args, result.output)
    assert not list(tmp_path.iterdir())


def test_render_size_must_be_sane() -> None:
    scn = load_scenario(ROOT / "missions" / "paper-env1.yaml")
    with pytest.raises(ValueError, match="at least"):
        render_scene(scene_for(scn), "/nonexistent/x.png", width_px=100, height_px=100)


def test_importing_render_needs_no_matplotlib() -> None:
    code = "import sys, uavplan.render, uavplan.cli; print('matplotlib' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
