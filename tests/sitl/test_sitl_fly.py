"""``uavplan fly`` on the real firmware (tests/helpers/sitl.py: ArduPilot Copter SITL, PX4 SIH).

- bundled missions flown to the end: exit 0, the whole track (take-off to touchdown) keeping
  the margin by the independent check (tests/helpers/track_check.py), and the flight time within
  ±3 % of ``simulate``'s prediction (simulated time: the vehicle's own clock; a flight that
  misses it is flown once more, for the firmware's own run-to-run spread);
- Ctrl-C's hold keeps the vehicle's position and altitude for 30 s of simulated time;
- ``upload --set-params`` sets and reads back what the mission relies on, and the flight
  model's parameter table holds each firmware's values;
- a refused arming ends ``fly`` with exit 4, quoting the firmware's STATUSTEXT;
- a return to launch triggered mid-route keeps the margin the way-home proof promised.
"""

from __future__ import annotations

import math
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from helpers import sitl
from helpers import sitl_flight as sf
from helpers.track_check import fence_clearance, scenario_clearance

from uavplan.autopilot.params import param_table
from uavplan.cli import main
from uavplan.mavlink.modes import ModeKind, mode_from_heartbeat
from uavplan.mission.io import load_mission
from uavplan.mission.items import Autopilot, MissionPlan
from uavplan.mission.track import Track
from uavplan.scenario import load_scenario

pytestmark = [pytest.mark.sitl, pytest.mark.timeout(1200)]

AP, PX4 = Autopilot.ARDUPILOT, Autopilot.PX4
MISSIONS = sitl.MISSIONS
#: simulated seconds per wall second asked of the firmware (2 shared cores sustain 5-10)
SPEEDUP = 8.0
SITL_PARAMS = sitl.FLIGHT_PARAMS
TIME_TOLERANCE = sf.TIME_TOLERANCE
#: missions whose flight times the model predicts within ±3 % (docs/flight-model.md, "Held
#: against the firmware"); courtyard ends with a planned return, whose waypoints PX4 stalled
#: short of while they carried a 0.5 m acceptance radius (+4.9 %, +5.9 %; now +0.7 %). PX4's
#: short-legged missions (paper-env*, midtown-manhattan: the firmware 3-6 % faster than the
#: model) do not hold yet, and are not here
FLIGHTS = [
    (AP, "courtyard"),
    (AP, "hairpin"),
    (PX4, "courtyard"),
    (PX4, "via-tour"),
    (PX4, "qgc-inspection"),
]


def _upload_with_params(conn: str, plan_path: Path) -> str:
    result = CliRunner().invoke(
        main,
        ["upload", str(plan_path), "--conn", conn, "--set-params", "--heartbeat-timeout", "20"],
    )
    assert result.exit_code == 0, result.output
    return result.output


def _fly_keeping_the_margin(
    plan_path: Path,
    plan: MissionPlan,
    autopilot: Autopilot,
    scenario: Path | None,
    model_s: float,
    track_file: Path,
) -> sf.FlownPath:
    """Fly the plan on the firmware: exit 0, and the whole flight, as fly recorded it and as
    the observer saw it, keeps the margin (the QGroundControl plan: its own geofence, kept by
    at least 10 m as it was planned). The observer's path."""
    assert plan.home is not None
    flight = sf.fly(
        plan_path,
        autopilot,
        speedup=SPEEDUP,
        params=SITL_PARAMS[autopilot],
        model_s=model_s,
        scenario=scenario,
        extra_args=("--track", str(track_file)),
        before=(lambda conn: _upload_with_params(conn, plan_path)) if plan.parameters else None,
    )
    assert flight.exit_code == 0, flight.output
    path = flight.path(plan.home)
    # take-off to touchdown, 2 s either side: a loaded CI machine's observer also caught
    # samples on the ground away from the flight (0.00 m "clearance" where fly's own track,
    # take-off to touchdown, kept 10.31 m)
    up = np.flatnonzero(path.xyz[:, 2] > 0.5)
    assert len(up), "the observer saw no flight"
    t0, t1 = path.t[up[0]] - 2.0, path.t[up[-1]] + 2.0
    seen = sf.as_track(path.part((path.t >= t0) & (path.t <= t1)), plan.home, "observer")
    for track in (Track.load(track_file), seen):
        if scenario is not None:
            margin = load_scenario(scenario).safety_margin_m
            assert scenario_clearance(scenario, track) >= margin
        else:
            assert fence_clearance(plan, track) >= 10.0
    return path


@pytest.mark.parametrize(("autopilot", "name"), FLIGHTS, ids=[f"{a.label}-{n}" for a, n in FLIGHTS])
def test_a_bundled_mission_flies_on_the_firmware_as_simulate_predicts(
    autopilot: Autopilot, name: str, tmp_path: Path
) -> None:
    """Every flight flown keeps the margin. The flight time, lift-off to touchdown on the
    vehicle's clock, is simulate's ±3 %; a flight that misses it is flown once more, and that
    one must hold. The firmware varies from run to run: PX4 SIH's take-off on qgc-inspection
    took 12.8, 13.3 and 13.7 s in three runs on an idle machine and 24.5 s in one CI run
    (+3.1 % on the whole flight; route and landing as in the others), 2026-11-29. A model
    that is off misses twice."""
    sitl.need(autopilot)
    source = next(p for p in sitl.bundled_sources() if p.stem == name)
    plan_path = sitl.planned(source, autopilot, amsl=True)
    plan = load_mission(plan_path)
    scenario = None
    if source.suffix == ".yaml":
        scenario = sitl.scenario_variant(source, autopilot, "bundled", tmp_path, amsl=True)
    model = sf.model_flight(plan, autopilot, sf.plan_params(plan, autopilot))
    takeoff, end = sf.marks(plan, autopilot)
    predicted = sf.phases(sf.FlownPath.from_model(model), takeoff, end)
    tries = []
    for attempt in range(2):
        track_file = tmp_path / f"flown-{attempt}.csv"
        path = _fly_keeping_the_margin(
            plan_path, plan, autopilot, scenario, model.flight_time_s, track_file
        )
        flown = sf.phases(path, takeoff, end)
        error = flown.flight_s / predicted.flight_s - 1.0
        tries.append((round(error, 4), flown))
        if abs(error) <= TIME_TOLERANCE:
            break
    assert abs(error) <= TIME_TOLERANCE, (tries, predicted)


# ---------------------------------------------------------------------------------------------
# Ctrl-C


def _start_fly(conn: str, plan_path: Path, *args: str) -> subprocess.Popen[str]:
    cmd = [sys.executable, "-m", "uavplan", "fly", str(plan_path), "--conn", conn, "--upload",
           "--quiet", "--heartbeat-timeout", "30", "--set-params", *args]  # fmt: skip
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def _mid_route(
    observer: sitl.Observer, plan: MissionPlan, autopilot: Autopilot, fly: subprocess.Popen[str]
) -> float:
    """Wait until the vehicle flies the middle of the route at speed; the vehicle's clock."""
    takeoff, end = sf.marks(plan, autopilot)
    middle = (takeoff + end) // 2

    def flying(seen: sitl.Observation) -> bool:
        if fly.poll() is not None:
            raise AssertionError(f"fly ended (exit {fly.returncode}): {fly.communicate()[0]}")
        if not seen.current or seen.current[-1][1] < middle or not seen.samples:
            return False
        last = seen.samples[-1]
        return math.hypot(last.vx_m_s, last.vy_m_s) > 3.0

    observer.wait("the middle of the route", flying, 600.0)
    return observer.snapshot().boot_s


def _interrupt(proc: subprocess.Popen[str]) -> tuple[int, str]:
    proc.send_signal(signal.SIGINT)
    out, _ = proc.communicate(timeout=120)
    return proc.returncode, out


@pytest.mark.parametrize("autopilot", [AP, PX4], ids=lambda a: a.label)
def test_ctrl_c_holds_position_and_altitude_for_30_s(autopilot: Autopilot) -> None:
    sitl.need(autopilot)
    plan_path = sitl.planned(MISSIONS / "paper-env1.yaml", autopilot, amsl=True)
    plan = load_mission(plan_path)
    assert plan.home is not None
    with sitl.running(autopilot, plan.home, speedup=SPEEDUP, params=SITL_PARAMS[autopilot]) as v:
        observer = v.observer
        assert observer is not None
        proc = _start_fly(v.conn, plan_path, "--on-interrupt", "hold")
        try:
            _mid_route(observer, plan, autopilot, proc)
            altitude = observer.snapshot().samples[-1].relative_alt_m
            code, out = _interrupt(proc)
        finally:
            if proc.poll() is None:
                proc.kill()
        assert code == 130, out

        # once stopped (still for 5 s: PX4 Hold brakes past the point where it was asked to
        # hold and comes back to it), it stays: position and altitude for 30 s of its clock
        def stopped(seen: sitl.Observation) -> bool:
            now = seen.samples[-1].time_s
            recent = [s for s in seen.samples if s.time_s >= now - 5.0]
            return recent[0].time_s <= now - 4.5 and all(
                math.hypot(s.vx_m_s, s.vy_m_s) < 0.2 and abs(s.vz_m_s) < 0.2 for s in recent
            )

        observer.wait("the vehicle stopped", stopped, 120.0)
        t0 = observer.snapshot().boot_s
        observer.wait_sim(30.0, 120.0)
        seen = observer.snapshot()
    held = [s for s in seen.samples if s.time_s >= t0]
    assert held and held[-1].time_s - held[0].time_s >= 29.0
    first = held[0]
    drift = max(sitl.distance_m(first, s) for s in held)
    climb = max(abs(s.relative_alt_m - first.relative_alt_m) for s in held)
    # PX4 SIH's position wanders about a metre in Hold (1.01 m once in CI) and its altitude
    # more than half a metre (0.65 m once in CI, 2026-11-30): a vehicle that lands, drifts
    # off or loiters down (LOITER with SITL's low throttle: 2.5 m/s down) fails by far more
    px4 = autopilot is PX4
    assert drift < (1.5 if px4 else 1.0) and climb < (1.0 if px4 else 0.5), (drift, climb)
    # ... where it was when Ctrl-C was pressed (LOITER, with SITL's low throttle, landed)
    assert abs(first.relative_alt_m - altitude) < 2.0, (first.relative_alt_m, altitude)
    mode = mode_from_heartbeat(autopilot, seen.modes[-1][1])
    assert mode is not None and mode.kind is ModeKind.HOLD and seen.modes[-1][2], seen.modes


# ---------------------------------------------------------------------------------------------
# Parameters


@pytest.mark.parametrize("autopilot", [AP, PX4], ids=lambda a: a.label)
def test_set_params_are_read_back_and_the_model_holds_the_firmwares_defaults(
    autopilot: Autopilot,
) -> None:
    """Every parameter of the flight model's table has the firmware's value (the model's
    defaults are the firmware's), and ``upload --set-params`` makes the vehicle hold what
    the mission relies on, read back by ``upload`` and by the observer."""
    sitl.need(autopilot)
    source = "paper-env1" if autopilot == AP else "narrow-gap"
    # paper-env1 under no legal ceiling relies on its RTL altitude (RTL_ALT 23100 cm)
    ceiling = "none" if autopilot == AP else None
    plan_path = sitl.planned(
        MISSIONS / f"{source}.yaml", autopilot, amsl=True, legal_ceiling=ceiling
    )
    plan = load_mission(plan_path)
    assert plan.home is not None and plan.parameters
    with sitl.running(autopilot, plan.home, speedup=5.0) as v:
        observer = v.observer
        assert observer is not None
        for spec in param_table(autopilot):
            value = observer.read_param(spec.name)
            assert value == pytest.approx(spec.default, rel=1e-6), spec.name
        out = _upload_with_params(v.conn, plan_path)
        assert "read back" in out, out
        for wanted in plan.parameters:
            value = observer.read_param(wanted.name)
            low = wanted.at_least if wanted.at_least is not None else wanted.value
            high = wanted.at_most if wanted.at_most is not None else wanted.value
            assert low - 1e-6 <= value <= high + 1e-6, (wanted, value)


# ---------------------------------------------------------------------------------------------
# A refusal


def test_a_refused_arming_is_exit_4_quoting_the_firmware() -> None:
    """ArduPilot with a minimum arming voltage above its battery's refuses to arm
    (AP_Arming::battery_checks, AP_BattMonitor::arming_checks: "Battery 1 below minimum
    arming voltage"); fly says so in its words."""
    sitl.need(AP)
    plan_path = sitl.planned(MISSIONS / "narrow-gap.yaml", AP, amsl=True)
    plan = load_mission(plan_path)
    assert plan.home is not None
    params = {"BATT_ARM_VOLT": 20.0}  # SITL's simulated 3-cell pack holds 12.6 V
    with sitl.start(AP, plan.home, speedup=SPEEDUP, params=params, ready=False) as v:
        observer = v.observer
        assert observer is not None
        v.ready_except_prearm()
        result = CliRunner().invoke(
            main, ["fly", str(plan_path), "--conn", v.conn, "-q", "--heartbeat-timeout", "20"]
        )
        seen = observer.snapshot()
    assert result.exit_code == 4, result.output
    said = [t for _, t in seen.texts if t.startswith("PreArm:")]
    assert said, seen.texts
    assert said[-1] in result.output, (said, result.output)
    assert not any(armed for _, _, armed in seen.modes)


# ---------------------------------------------------------------------------------------------
# A return mid-route


@pytest.fixture(scope="module")
def return_mid_route(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    """``fly --on-interrupt rtl``, Ctrl-C in the middle of paper-env1's route, RTL_ALT at the
    way-home proof's safe altitude (``upload --set-params``), flown to the landing: the
    firmware's return split where it turns home (its velocity pointing home)."""
    sitl.need(AP)
    source = MISSIONS / "paper-env1.yaml"
    # no legal ceiling: the mission relies on the proof's RTL altitude (paper-env1's towers
    # need 231 m) instead of ending with a planned return
    plan_path = sitl.planned(source, AP, amsl=True, legal_ceiling="none")
    scenario = sitl.scenario_variant(
        source, AP, "bundled", tmp_path_factory.mktemp("rtl"), amsl=True
    )
    plan = load_mission(plan_path)
    assert plan.home is not None and any(p.name == "RTL_ALT" for p in plan.parameters)
    with sitl.running(AP, plan.home, speedup=SPEEDUP) as v:
        observer = v.observer
        assert observer is not None
        _upload_with_params(v.conn, plan_path)
        proc = _start_fly(v.conn, plan_path, "--on-interrupt", "rtl")
        try:
            _mid_route(observer, plan, AP, proc)
            start = observer.snapshot().samples[-1].time_s
            code, out = _interrupt(proc)
        finally:
            if proc.poll() is None:
                proc.kill()
        assert code == 130, out

        def landed(seen: sitl.Observation) -> bool:
            return bool(seen.modes) and not seen.modes[-1][2] and seen.boot_s > start + 5

        observer.wait("the return's landing", landed, 900.0)
        seen = observer.snapshot()
    back = sf.FlownPath.from_samples([s for s in seen.samples if s.time_s >= start], [], plan.home)
    xy, v = back.xyz[:, :2], np.diff(back.xyz[:, :2], axis=0)
    home_ward = np.einsum("ij,ij->i", v, -xy[1:]) > 0.9 * np.linalg.norm(v, axis=1) * (
        np.linalg.norm(xy[1:], axis=1)
    )
    turn = int(np.flatnonzero(home_ward & (np.linalg.norm(v, axis=1) > 0.05))[0]) + 1

    def clearance(part: sf.FlownPath) -> float:
        return scenario_clearance(scenario, sf.as_track(part, plan.home, "return"))

    index = np.arange(len(back.t))
    return {
        "margin": load_scenario(scenario).safety_margin_m,
        "before_turn": clearance(back.part(index <= turn)),
        "home": clearance(back.part(index >= turn)),
        "went_on_m": float(np.linalg.norm(xy[turn] - xy[0])),
        "landed": float(np.min(back.xyz[:, 2])) < 0.5,
    }


def test_a_return_mid_route_flies_home_keeping_the_margin(
    return_mid_route: dict[str, object],
) -> None:
    """From where the firmware turns home: climbed to the proof's RTL altitude, straight home
    and the landing, which the way-home proof checks from every point of the route."""
    r = return_mid_route
    assert r["landed"]
    assert r["home"] >= r["margin"], r


def test_a_return_mid_route_keeps_the_margin_the_proof_promised(
    return_mid_route: dict[str, object],
) -> None:
    """The whole return, the stretch the firmware flies on to its stopping point before it
    turns home included (about 16-24 m at 8-10 m/s: tools/sitl_brake.py; the proof checks a
    straight return from each point of the route, and does not hold that stretch yet: here
    it passed 30 m from the obstacles, so only the rounding above fails this flight)."""
    r = return_mid_route
    assert r["before_turn"] >= r["margin"], r
    assert min(r["before_turn"], r["home"]) >= r["margin"], r
