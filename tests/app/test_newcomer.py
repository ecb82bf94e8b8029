"""The newcomer's sequence (issue 37, Must show): README's Quick start and docs/flying.md's
workflow followed as written, for both flavours, on every bundled scenario, against the
simulated vehicle over real UDP on 127.0.0.1.

For each: ``plan`` (the Quick start's with ``--fence --plot --report``, flying.md's without),
``render --mission``, ``simulate --scenario``, a simulated vehicle standing at the plan's home,
``upload --set-params``, ``fly --scenario --track``. Then, measured by the independent track
check (tests/helpers/track_check.py: its own polygon and cylinder distances, scipy over the raw
DEM):

- the flown track from take-off to touchdown (the mission's real end: its landing, its
  planned return) keeps the margin, and ``fly`` exits 0 (``fly`` exits 0 only then);
- one failsafe return to launch from mid-route, flown by the same flight model with the
  parameters the vehicle holds after ``--set-params``: where the whole flight's verdict says
  a failsafe return is safe from every point, the one from the middle of the route keeps the
  margin; where it warns, the return from the point it names breaks it (the warning is not a
  false alarm).

The flights are long (minutes of simulated flight each, 20 of them): ``slow``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from helpers.mavlink_helpers import client_conn, running_mock
from helpers.track_check import fence_clearance, scenario_clearance, scenario_for

from uavplan.autopilot.model import FlightModel
from uavplan.autopilot.nav import nav_items
from uavplan.autopilot.params import Parameters
from uavplan.cli import main
from uavplan.geo import EnuFrame
from uavplan.mission.io import load_mission
from uavplan.mission.items import Autopilot, MissionPlan
from uavplan.mission.track import Track
from uavplan.rehearsal import CheckSite, conditions_of
from uavplan.scenario import load_scenario
from uavplan.sim.vehicle import SimConfig
from uavplan.verdict import judge_flight

pytestmark = [pytest.mark.slow, pytest.mark.timeout(900)]

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = sorted(p.stem for p in (ROOT / "missions").glob("*.yaml"))
FLAVOURS = [Autopilot.ARDUPILOT, Autopilot.PX4]
#: simulated seconds per wall second of the vehicle
SPEEDUP = 100.0


def run(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(main, list(args))
    return result.exit_code, result.output


def set_params(plan_path: Path, plan: MissionPlan, conn: str) -> tuple[int, str]:
    """``upload PLAN --conn CONN --set-params``, as both documents write it (a mission that
    relies on no parameter says so and uploads)."""
    code, out = run("upload", str(plan_path), "--conn", conn, "--set-params")
    if not plan.parameters:
        assert "relies on no vehicle parameter" in out, out
    return code, out


def model_track(plan: MissionPlan, params: Parameters, rtl_at_s: float) -> Track:
    """The mission flown by the flight model (the simulated vehicle's) with ``params``, a
    return to launch commanded ``rtl_at_s`` after the start, to touchdown."""
    assert plan.home is not None
    model = FlightModel(params)
    model.set_mission(nav_items(plan.wire_items(), plan.home))
    model.start_mission()
    rows = []
    commanded = False
    for _ in range(200_000):
        model.step()
        x, y, z = model.position
        rows.append((model.t_s, x, y, z, -1 if model.current_seq is None else model.current_seq))
        if not commanded and model.t_s >= rtl_at_s:
            model.rtl()
            commanded = True
        if commanded and model.landed:
            break
    else:  # pragma: no cover - the model always lands
        raise AssertionError("the return never landed")
    t, x, y, z, seq = (np.array(c) for c in zip(*rows, strict=True))
    lat, lon, _ = EnuFrame.at(plan.home).to_geodetic(np.column_stack([x, y, np.zeros_like(z)]))
    return Track(
        time_s=t,
        lat_deg=np.asarray(lat),
        lon_deg=np.asarray(lon),
        alt_amsl_m=plan.home.alt_m + z,
        relative_alt_m=z,
        speed_m_s=np.zeros_like(t),
        current_seq=seq.astype(np.int64),
        mode=tuple("RTL" for _ in t),
        source="test failsafe",
        autopilot=params.autopilot.label,
    )


@pytest.mark.parametrize("document", ["readme", "flying"])
@pytest.mark.parametrize("autopilot", FLAVOURS, ids=lambda a: a.label)
@pytest.mark.parametrize("name", SCENARIOS)
@pytest.mark.slow
def test_the_newcomers_sequence_flies_the_whole_flight_inside_the_margin(
    tmp_path: Path, name: str, autopilot: Autopilot, document: str
) -> None:
    source = ROOT / "missions" / f"{name}.yaml"
    scenario = scenario_for(source, autopilot, tmp_path)  # jacksboro: AMSL (no terrain DB)
    planned, report = tmp_path / "env.plan", tmp_path / "env.json"
    flown = tmp_path / "flown.csv"
    if document == "readme":
        # uavplan plan S -o env1.plan --fence --plot env1.png --report env1.json
        # uavplan render S --mission env1.plan -o env1-check.png
        # uavplan simulate env1.plan --scenario S
        steps = [
            ["plan", str(scenario), "-o", str(planned), "--fence", "--plot",
             str(tmp_path / "env.png"), "--report", str(report)],
            ["render", str(scenario), "--mission", str(planned), "-o",
             str(tmp_path / "check.png")],
            ["simulate", str(planned), "--scenario", str(scenario)],
        ]  # fmt: skip
    else:
        # uavplan plan S -o env1.plan --report env1.json
        # uavplan simulate env1.plan --scenario S --track env1-sim.csv
        steps = [
            ["plan", str(scenario), "-o", str(planned), "--report", str(report)],
            ["simulate", str(planned), "--scenario", str(scenario), "--track",
             str(tmp_path / "sim.csv")],
        ]  # fmt: skip
    steps[0] += ["--autopilot", autopilot.label]  # the flavour (the README's second row)
    said = []
    for step in steps:
        code, out = run(*step)
        assert code == 0, (step[0], out)
        said.append(out)
    plan = load_mission(planned)
    scn = load_scenario(scenario)
    margin = scn.safety_margin_m
    # uavplan mock-vehicle --conn udpin:... --autopilot A --mission env1.plan &
    config = SimConfig(autopilot=autopilot, home=plan.home, speedup=SPEEDUP)
    with running_mock(config) as vehicle:
        conn = client_conn(vehicle)
        # uavplan upload env1.plan --conn udpout:... --set-params
        code, out = set_params(planned, plan, conn)
        assert code == 0, out
        # uavplan fly env1.plan --conn udpout:... --scenario S --track flown.csv
        code, out = run("fly", str(planned), "--conn", conn, "--scenario", str(scenario),
                        "--track", str(flown), "-q")  # fmt: skip
        held = vehicle.vehicle.params
    track = Track.load(flown)
    clearance = scenario_clearance(scenario, track)
    # fly exits 0 only when the whole flight kept the margin, and here it does
    assert (code == 0) is (clearance >= margin - 0.05), (code, clearance, out)
    assert code == 0, out
    assert "mission complete" in out
    assert track.relative_alt_m[-1] < 0.5  # it landed: the whole flight was observed
    for name_, value in ((p.name, p.value) for p in plan.parameters):
        if name_ in held.values:
            assert held[name_] == pytest.approx(value)  # --set-params: the vehicle holds them

    # one failsafe return from mid-route, with the parameters the vehicle holds
    site = CheckSite.of_scenario(scn)
    verdict = judge_flight(plan, site, **conditions_of(scn))
    assert verdict.flight_ok
    assert json.loads(report.read_text())["whole_flight"]["failsafe_ok"] is verdict.failsafe_ok
    rehearsal = verdict.rehearsal
    assert rehearsal is not None and rehearsal.airborne_s is not None
    if verdict.failsafe_ok:
        at = 0.5 * rehearsal.airborne_s
        back = model_track(plan, held, at)
        assert scenario_clearance(scenario, back) >= margin - 0.05, at
    else:
        worst = verdict.failsafe.worst if verdict.failsafe is not None else None
        assert worst is not None and worst.time_s is not None
        assert "warning: failsafe" in said[0]  # plan said so (a warning: -q keeps it)
        if worst.clearance_m < margin - 2.0 and "edge of the flight volume" not in worst.nearest:
            back = model_track(plan, held, worst.time_s)
            assert scenario_clearance(scenario, back) < margin, worst


@pytest.mark.slow
def test_the_bundled_qgroundcontrol_plan_flies_inside_its_own_fence(tmp_path: Path) -> None:
    """The bundled QGroundControl plan, rerouted by ``plan`` and flown without a scenario: its
    whole track keeps the margin from its own geofence."""
    source = ROOT / "missions" / "qgc-inspection.plan"
    planned, flown = tmp_path / "safe.plan", tmp_path / "flown.csv"
    code, out = run("plan", str(source), "-o", str(planned))
    assert code == 0, out
    code, out = run("simulate", str(planned))
    assert code == 0, out
    plan = load_mission(planned)
    config = SimConfig(autopilot=plan.autopilot, home=plan.home, speedup=SPEEDUP)
    with running_mock(config) as vehicle:
        conn = client_conn(vehicle)
        code, out = set_params(planned, plan, conn)
        assert code == 0, out
        code, out = run("fly", str(planned), "--conn", conn, "--track", str(flown), "-q")
    track = Track.load(flown)
    clearance = fence_clearance(plan, track)
    assert (code == 0) is (clearance >= 10.0 - 0.05), (code, clearance, out)
    assert code == 0, out
