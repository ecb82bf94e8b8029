"""The one check of a flown mission against a scenario (issue 25): ``validate MISSION
--scenario S``, ``render --mission`` and the rerouting's check of its output measure a
mission the same way, and over a DEM they read it as the autopilot flies it (home on the
ground, each item's altitude frame).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from helpers.terrain_helpers import independent_ground_check

from uavplan.app.check import check_flight_in, mission_flight, validate
from uavplan.app.feedback import Feedback
from uavplan.app.render import RenderRequest, render
from uavplan.cli import main
from uavplan.errors import NoPathError
from uavplan.flightcheck import Flight, check_flight
from uavplan.geo import EnuFrame
from uavplan.mission.io import load_mission, save_mission
from uavplan.planning import build_world
from uavplan.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]
CLEARANCE = re.compile(r"min clearance (\d+\.\d\d) m")

SCENARIO = """\
name: check
origin: {lat: 47.0, lon: 8.0, alt: 400}
bounds: {x: [0, 1200], y: [-400, 400], z: [0, 150]}
start: [0, 0, 40]
goal: [1200, 60, 40]
safety_margin: 10
obstacles:
  - {type: box, center: [400, 20], size: [120, 160], height: 120, yaw: 10}
  - {type: cylinder, center: [800, -40], radius: 60, height: 130}
planner: {seed: 2, iterations: 80}
mission: {autopilot: px4, spacing: 80, end: land}
"""


def run(*args: str) -> str:
    result = CliRunner().invoke(main, list(args))
    assert result.exit_code == 0, result.output
    return result.output


@pytest.mark.slow
def test_validate_render_and_reroute_report_the_same_clearance(tmp_path: Path) -> None:
    scenario = tmp_path / "s.yaml"
    scenario.write_text(SCENARIO, encoding="utf-8")
    planned, rerouted = tmp_path / "p.plan", tmp_path / "r.plan"
    run("plan", str(scenario), "-o", str(planned), "-q")
    report = tmp_path / "r.json"
    out = run(
        "plan", str(planned), "-o", str(rerouted), "--scenario", str(scenario),
        "--report", str(report),
    )  # fmt: skip
    from_reroute = CLEARANCE.findall(out)[-1]
    from_validate = CLEARANCE.findall(run("validate", str(rerouted), "--scenario", str(scenario)))
    picture = tmp_path / "m.png"
    from_render = CLEARANCE.findall(
        run("render", str(scenario), "--mission", str(rerouted), "-o", str(picture))
    )
    assert from_validate == from_render == [from_reroute]
    # and to the last bit, through the use cases
    checked = validate(str(rerouted), str(scenario))
    drawn = render(RenderRequest(str(scenario), str(picture), mission=str(rerouted)), Feedback())
    assert checked.min_clearance_m == drawn.min_clearance_m
    assert checked.min_clearance_m == json.loads(report.read_text())["min_clearance_m"]


@pytest.mark.slow
def test_simulate_and_render_report_the_same_clearance_of_the_flown_track(
    tmp_path: Path,
) -> None:
    """``simulate`` checks the track it flies by the one check; ``render --track`` draws that
    track file and measures it by the same check: the same clearance, to the centimetre
    printed (the file holds the samples rounded, so not to the bit)."""
    scenario = tmp_path / "s.yaml"
    scenario.write_text(SCENARIO, encoding="utf-8")
    planned, track = tmp_path / "p.plan", tmp_path / "t.csv"
    run("plan", str(scenario), "-o", str(planned), "-q")
    flown = re.compile(r"min clearance (\d+\.\d\d) m from")
    simulated = flown.findall(
        run("simulate", str(planned), "--scenario", str(scenario), "--track", str(track))
    )
    drawn = re.findall(
        r"flown track t\.csv: min clearance (\d+\.\d\d) m",
        run("render", str(scenario), "--track", str(track), "-o", str(tmp_path / "t.png")),
    )
    assert len(simulated) == 1 and drawn == simulated
    # the track is not the straight legs: validate measures those, and the flight rounds them
    straight = CLEARANCE.findall(run("validate", str(planned), "--scenario", str(scenario)))
    assert straight and straight != simulated


def test_a_flight_too_close_is_refused_with_the_obstacle_named(tmp_path: Path) -> None:
    """Any flown line can be checked, not only a mission file's."""
    scenario = tmp_path / "s.yaml"
    scenario.write_text(SCENARIO, encoding="utf-8")
    scn = load_scenario(scenario)
    # a straight line through the box, at 40 m
    flight = Flight.from_polyline(
        np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 40.0], [1200.0, 60.0, 40.0]]),
        from_ground=True,
        to_ground=False,
    )
    check = check_flight_in(scn, flight)
    assert not check.ok and check.worst == 1 and check.nearest == "obstacles[0]"
    assert "leg 1 of the flown path comes within 0.00 m of obstacles[0]" in str(check.problem())


@pytest.mark.parametrize("altitude", ["relative", "amsl", "terrain"])
@pytest.mark.parametrize("suffix", [".plan", ".waypoints"])
@pytest.mark.slow
def test_terrain_missions_pass_validate_in_every_altitude_frame(
    ridge_frames: dict[str, Path], altitude: str, suffix: str
) -> None:
    """``plan`` then ``validate`` of the same terrain scenario passed only in one frame:
    the check read every mission over flat ground, under the terrain (issue 25)."""
    scenario = ridge_frames[altitude]
    mission = scenario.with_suffix(suffix)
    if suffix != ".plan":
        run("convert", str(scenario.with_suffix(".plan")), str(mission), "-q")
    out = run("validate", str(mission), "--scenario", str(scenario))
    assert "ok" in out
    assert float(CLEARANCE.findall(out)[0]) >= 15.0
    picture = mission.with_suffix(".png")
    drawn = run("render", str(scenario), "--mission", str(mission), "-o", str(picture))
    assert CLEARANCE.findall(drawn) == CLEARANCE.findall(out)
    # the independent ground check: the flight rebuilt by the tests, over scipy's surface
    scn = load_scenario(scenario)
    low, _ = independent_ground_check(mission, scn.terrain_file, EnuFrame.at(scn.site.origin))
    assert low >= 15.0 - 0.02


@pytest.mark.slow
def test_the_three_frames_fly_the_same_waypoints(ridge_frames: dict[str, Path]) -> None:
    """Relative and AMSL altitudes fly the same straight legs; terrain-frame legs pass their
    waypoints but are flown over the ground between them (ArduPilot), so their flight is
    denser and follows the ground. (The terrain-frame plan may be another route: its
    rehearsal flies ArduPilot's lag behind the ground and can widen the margin.)"""
    from uavplan.flightcheck import flight_of_mission
    from uavplan.planning import enu_frame

    flights = {}
    for altitude, scenario in ridge_frames.items():
        scn = load_scenario(scenario)
        plan = load_mission(scenario.with_suffix(".plan"))
        flights[altitude] = mission_flight(plan, scn).points_enu
    relative, amsl, over = flights["relative"], flights["amsl"], flights["terrain"]
    assert amsl.shape == relative.shape and np.max(np.abs(amsl - relative)) < 0.02
    scn = load_scenario(ridge_frames["terrain"])
    plan = load_mission(ridge_frames["terrain"].with_suffix(".plan"))
    assert scn.site.ground is not None
    site = scn.site
    straight = flight_of_mission(plan, enu_frame(site), site.ground.z_at).points_enu
    assert len(over) > 10 * len(straight)
    gap = np.min(np.linalg.norm(straight[:, None, :] - over[None, :, :], axis=2), axis=1)
    assert gap.max() < 0.02  # every waypoint of the straight line is on the flown one


@pytest.mark.slow
def test_a_mission_below_the_ridge_names_the_ground(
    ridge_frames: dict[str, Path], tmp_path: Path
) -> None:
    """Flown 40 m lower, the relative mission goes into the ground: exit 3, and the message
    names the ground and where, not an internal obstacle index."""
    from dataclasses import replace

    scenario = ridge_frames["relative"]
    plan = load_mission(scenario.with_suffix(".plan"))
    items = tuple(
        replace(i, z=i.z - 40.0) if i.is_global and i.command == 16 else i for i in plan.items
    )
    low = tmp_path / "low.plan"
    save_mission(replace(plan, items=items), low)
    result = CliRunner().invoke(main, ["validate", str(low), "--scenario", str(scenario)])
    assert result.exit_code == 3, result.output
    assert re.search(r"comes within \d+\.\d\d m of the terrain at \(-?\d+, -?\d+\)", result.output)
    assert "obstacles[-" not in result.output
    with pytest.raises(NoPathError, match="the terrain at"):
        validate(str(low), str(scenario))


@pytest.mark.slow
def test_the_climb_from_home_is_checked_against_obstacles_only(
    ridge_frames: dict[str, Path],
) -> None:
    """Home stands on the ground: the take-off climb touches the terrain's solids by design,
    so it is measured against the obstacles; the same line measured all the way against the
    terrain would come within 0 m of it."""
    scn = load_scenario(ridge_frames["terrain"])
    flight = mission_flight(load_mission(ridge_frames["terrain"].with_suffix(".plan")), scn)
    assert flight.airborne[0] >= 1
    world = build_world(scn)
    checked = check_flight(world, flight, name_of=scn.obstacle_name)
    assert checked.keeps_margin
    everywhere = Flight(flight.points_enu, (0, len(flight.points_enu) - 1))
    assert check_flight(world, everywhere, name_of=scn.obstacle_name).min_clearance_m < 1.0
