"""Real ground-station software flies the simulated vehicle over UDP on 127.0.0.1.

- MAVSDK (Action, MissionRaw, Telemetry): a bundled scenario's mission flown to completion on
  each flavour, its flight time the one ``simulate`` predicts, the modes, positions and
  landed states MAVSDK decodes from our telemetry; MAVSDK's Param plugin over our table;
- pymavlink's mode and arming helpers (``set_mode``, ``arducopter_arm``) and MISSION_START;
- each firmware refusal as a client sees it: the COMMAND_ACK result and the STATUSTEXT;
- the ``uavplan mock-vehicle`` process with ``--speedup`` flown by pymavlink.

The vehicle runs at a ``speedup`` so a flight of minutes takes seconds; every assertion is on
simulated time or on what was said, never on the wall clock.
"""

from __future__ import annotations

import importlib.util
import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from helpers.mavlink_helpers import client_conn, planned_scenario, running_mock, synthetic_mission

from uavplan.autopilot.model import EventKind, FlightEvent
from uavplan.autopilot.simulate import simulate
from uavplan.mavlink.transfer import plan_wire_items
from uavplan.mission.io import save_mission
from uavplan.mission.items import Autopilot, MissionPlan, MissionType
from uavplan.sim.mock import MockVehicle
from uavplan.sim.vehicle import SimConfig

pytestmark = pytest.mark.timeout(120)

AP, PX4 = Autopilot.ARDUPILOT, Autopilot.PX4
AUTOPILOTS = [PX4, AP]
ROOT = Path(__file__).resolve().parents[2]
#: simulated seconds per wall second: a five-minute mission flies in a few seconds
SPEEDUP = 100.0
#: PX4 disarms COM_DISARM_LAND (2 s) after touchdown; ArduPilot at touchdown
DISARM_DELAY_S = {PX4: 2.0, AP: 0.0}
#: how long a test waits for the flight (wall seconds): a bound, not a measurement
FLIGHT_TIMEOUT_S = 60.0


def ids(autopilot: Autopilot) -> str:
    return autopilot.label


def event_time(events: tuple[FlightEvent, ...] | list[FlightEvent], kind: EventKind) -> float:
    return next(e.t_s for e in events if e.kind is kind)


def airborne_s(events: tuple[FlightEvent, ...] | list[FlightEvent]) -> float:
    """Simulated seconds from leaving the ground to touching down."""
    return event_time(events, EventKind.LANDED) - event_time(events, EventKind.TAKEOFF)


def loaded(plan: MissionPlan, autopilot: Autopilot, **config: Any) -> SimConfig:
    return SimConfig(autopilot=autopilot, home=plan.home, **config)


# ---------------------------------------------------------------------------------------------
# MAVSDK


mavsdk = pytest.importorskip("mavsdk")

from helpers.mavsdk_offline import to_mavsdk  # noqa: E402
from mavsdk import ComponentType, Configuration, Mavsdk  # noqa: E402
from mavsdk.plugins.action import Action, ActionError  # noqa: E402
from mavsdk.plugins.mission_raw import MissionRaw  # noqa: E402
from mavsdk.plugins.param import Param  # noqa: E402
from mavsdk.plugins.telemetry import FlightMode, LandedState, Telemetry  # noqa: E402


def _quiet(level: Any, message: str, file: str | None, line: int) -> bool:
    return level < mavsdk.LogLevel.WARN


mavsdk.log_subscribe(_quiet)


@contextmanager
def mavsdk_system(vehicle: MockVehicle) -> Iterator[Any]:
    """A MAVSDK ground station connected to ``vehicle``; its System."""
    sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    try:
        sdk.add_any_connection(client_conn(vehicle).replace("udpout:", "udpout://", 1))
        system = sdk.first_autopilot(10.0)
        assert system is not None, "MAVSDK never saw the vehicle's heartbeat"
        yield system
    finally:
        sdk.destroy()


@pytest.mark.parametrize("autopilot", AUTOPILOTS, ids=ids)
@pytest.mark.slow
def test_mavsdk_flies_a_bundled_mission_to_completion(autopilot: Autopilot) -> None:
    plan = planned_scenario(str(ROOT / "missions" / "helsinki-centre.yaml"))
    wire = plan_wire_items(plan, MissionType.MISSION, autopilot)
    predicted = simulate(plan, autopilot=autopilot)
    with (
        running_mock(loaded(plan, autopilot, speedup=SPEEDUP)) as vehicle,
        mavsdk_system(vehicle) as system,
    ):
        mission, action, telemetry = MissionRaw(system), Action(system), Telemetry(system)
        progress: list[tuple[int, int]] = []
        positions: list[Any] = []
        modes: set[FlightMode] = set()
        landed: set[LandedState] = set()
        try:
            mission.upload_mission(
                [to_mavsdk(it, seq, MissionType.MISSION) for seq, it in enumerate(wire)]
            )
            mission.subscribe_mission_progress(lambda p, _: progress.append((p.current, p.total)))
            telemetry.subscribe_position(lambda p, _: positions.append(p))
            telemetry.subscribe_flight_mode(lambda m, _: modes.add(m))
            telemetry.subscribe_landed_state(lambda s, _: landed.add(s))
            action.arm()
            mission.start_mission()

            def finished(v: MockVehicle) -> bool:
                snap = v.snapshot()
                done = bool(progress) and progress[-1][0] == progress[-1][1]
                return done and snap.landed and not snap.armed and bool(snap.armed_periods)

            assert vehicle.wait_for(finished, FLIGHT_TIMEOUT_S), (progress[-3:], vehicle.snapshot())
            # the next EXTENDED_SYS_STATE after touchdown tells MAVSDK it is down
            assert vehicle.wait_for(lambda _: LandedState.ON_GROUND in landed, 10.0), landed
        finally:
            for plugin in (mission, action, telemetry):
                plugin.destroy()
        events = vehicle.flight_events()
        (_, disarmed_at), *_ = vehicle.snapshot().armed_periods

    # MAVSDK counted every item done; the vehicle flew as long as simulate() said
    assert progress[-1] == (len(wire), len(wire))
    assert airborne_s(events) == pytest.approx(airborne_s(predicted.events), abs=0.25)
    assert disarmed_at is not None
    assert disarmed_at - event_time(events, EventKind.LANDED) == pytest.approx(
        DISARM_DELAY_S[autopilot], abs=0.15
    )
    # what MAVSDK decoded from our telemetry: where it flew, its modes, in the air and down
    assert positions[0].latitude_deg == pytest.approx(plan.home.lat_deg, abs=1e-6)
    highest = max(p.relative_altitude_m for p in positions)
    assert highest == pytest.approx(float(predicted.z_m.max()), abs=1.0)
    assert FlightMode.MISSION in modes
    # the mission's last item is RTL: PX4's navigator switches to its Return mode, ArduPilot
    # flies it as a sub-mode of AUTO (ModeAuto::do_RTL) and its HEARTBEAT stays AUTO
    assert (FlightMode.RETURN_TO_LAUNCH in modes) == (autopilot == PX4)
    assert LandedState.IN_AIR in landed


def test_mavsdk_arm_in_auto_is_refused_by_ardupilot_with_its_words() -> None:
    # MAVSDK's start_mission switches to AUTO; ArduPilot will not arm in AUTO
    plan = synthetic_mission(4, seed=2, autopilot=AP)
    with running_mock(loaded(plan, AP, speedup=SPEEDUP)) as vehicle:
        vehicle.preload(MissionType.MISSION, plan_wire_items(plan, MissionType.MISSION, AP))
        with mavsdk_system(vehicle) as system:
            mission, action, telemetry = MissionRaw(system), Action(system), Telemetry(system)
            texts: list[str] = []
            try:
                telemetry.subscribe_status_text(lambda t, _: texts.append(t.text))
                mission.start_mission()
                assert vehicle.wait_for(lambda v: v.snapshot().mode.name == "AUTO", 10.0)
                with pytest.raises(ActionError):
                    action.arm()
                    # MAVSDK hands STATUSTEXT over through its gRPC server: seconds late on a loaded
                    # machine (CI: 10 s was not enough once)
                    assert vehicle.wait_for(lambda v: "Arm: AUTO mode not armable" in texts, 30.0)
            finally:
                for plugin in (mission, action, telemetry):
                    plugin.destroy()
        assert not vehicle.snapshot().armed


@pytest.mark.parametrize(
    ("autopilot", "name", "default", "changed"),
    [(PX4, "MPC_XY_CRUISE", 5.0, 8.0), (AP, "WPNAV_SPEED", 1000.0, 500.0)],
    ids=["px4", "ardupilot"],
)
def test_mavsdk_param_plugin_reads_and_sets_the_flavours_table(
    autopilot: Autopilot, name: str, default: float, changed: float
) -> None:
    with (
        running_mock(SimConfig(autopilot=autopilot)) as vehicle,
        mavsdk_system(vehicle) as system,
    ):
        param = Param(system)
        try:
            assert param.get_param_float(name) == pytest.approx(default)
            param.set_param_float(name, changed)
            assert param.get_param_float(name) == pytest.approx(changed)
            if autopilot == PX4:
                # an INT32 parameter, which PX4 sends bytewise: MAVSDK reads the integer back
                assert param.get_param_int("COM_ARM_MIS_REQ") == 0
        finally:
            param.destroy()
        assert vehicle.vehicle.params[name] == pytest.approx(changed)


# ---------------------------------------------------------------------------------------------
# pymavlink


@pytest.fixture
def mavutil(monkeypatch: pytest.MonkeyPatch) -> Iterator[Any]:
    """pymavlink's ``mavutil`` speaking MAVLink 2 with the common dialect, as a ground
    station script sets it up; its global dialect is restored afterwards."""
    from pymavlink import mavutil as module

    saved = (module.mavlink, module.current_dialect)
    monkeypatch.setenv("MAVLINK20", "1")
    module.set_dialect("common")
    try:
        yield module
    finally:
        module.mavlink, module.current_dialect = saved


@contextmanager
def pymavlink_gcs(mavutil: Any, conn: str) -> Iterator[Any]:
    """A pymavlink connection to the vehicle at ``conn`` (``udpout:host:port``), past its
    first heartbeat (the vehicle answers whoever spoke last, so the GCS speaks first)."""
    master = mavutil.mavlink_connection(conn, source_system=255, source_component=190)
    try:
        gcs, invalid = mavutil.mavlink.MAV_TYPE_GCS, mavutil.mavlink.MAV_AUTOPILOT_INVALID
        deadline = time.monotonic() + 10.0
        heartbeat = None
        while heartbeat is None and time.monotonic() < deadline:
            master.mav.heartbeat_send(gcs, invalid, 0, 0, 0)
            heartbeat = master.wait_heartbeat(timeout=0.5)
        assert heartbeat is not None, "no heartbeat from the vehicle"
        yield master
    finally:
        master.close()


def wait_ack(master: Any, command: int, timeout_s: float = 10.0) -> tuple[int, list[str]]:
    """The COMMAND_ACK result for ``command`` and the STATUSTEXTs that came before it."""
    texts: list[str] = []
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        msg = master.recv_match(type=["COMMAND_ACK", "STATUSTEXT"], blocking=True, timeout=0.5)
        if msg is None:
            continue
        if msg.get_type() == "STATUSTEXT":
            texts.append(msg.text)
        elif msg.command == command:
            return msg.result, texts
    raise AssertionError(f"no COMMAND_ACK for command {command}")


def command(master: Any, mav_cmd: int, *params: float) -> tuple[int, list[str]]:
    values = [float(p) for p in params] + [0.0] * (7 - len(params))
    master.mav.command_long_send(master.target_system, master.target_component, mav_cmd, 0, *values)
    return wait_ack(master, mav_cmd)


def fly_with_pymavlink(mavutil: Any, master: Any, autopilot: Autopilot, last_seq: int) -> list[int]:
    """Arm and start as a pymavlink script does for that autopilot; wait until the vehicle
    is down and disarmed. The MISSION_ITEM_REACHED seqs heard."""
    m = mavutil.mavlink
    if autopilot == PX4:
        master.set_mode("MISSION")  # MAV_CMD_DO_SET_MODE (1|..., AUTO, MISSION)
        assert wait_ack(master, m.MAV_CMD_DO_SET_MODE) == (m.MAV_RESULT_ACCEPTED, [])
        master.arducopter_arm()  # arming in Mission mode starts the mission
        assert wait_ack(master, m.MAV_CMD_COMPONENT_ARM_DISARM)[0] == m.MAV_RESULT_ACCEPTED
    else:
        master.set_mode("GUIDED")
        assert wait_ack(master, m.MAV_CMD_DO_SET_MODE)[0] == m.MAV_RESULT_ACCEPTED
        master.arducopter_arm()
        assert wait_ack(master, m.MAV_CMD_COMPONENT_ARM_DISARM)[0] == m.MAV_RESULT_ACCEPTED
        assert command(master, m.MAV_CMD_MISSION_START, 0, 0)[0] == m.MAV_RESULT_ACCEPTED
    reached: list[int] = []
    armed_seen = False
    deadline = time.monotonic() + FLIGHT_TIMEOUT_S
    while time.monotonic() < deadline:
        msg = master.recv_match(
            type=["MISSION_ITEM_REACHED", "HEARTBEAT"], blocking=True, timeout=0.5
        )
        if msg is None:
            continue
        if msg.get_type() == "MISSION_ITEM_REACHED":
            reached.append(msg.seq)
        elif msg.get_srcSystem() == master.target_system:
            armed = bool(msg.base_mode & m.MAV_MODE_FLAG_SAFETY_ARMED)
            armed_seen |= armed
            if armed_seen and not armed and reached and reached[-1] == last_seq:
                return reached
    raise AssertionError(f"the flight did not end: reached {reached}")


@pytest.mark.parametrize("autopilot", AUTOPILOTS, ids=ids)
@pytest.mark.slow
def test_pymavlink_mode_and_arming_helpers_fly_the_mission(
    mavutil: Any, autopilot: Autopilot
) -> None:
    plan = synthetic_mission(5, seed=11, autopilot=autopilot)
    wire = plan_wire_items(plan, MissionType.MISSION, autopilot)
    predicted = simulate(plan, autopilot=autopilot)
    with running_mock(loaded(plan, autopilot, speedup=SPEEDUP)) as vehicle:
        vehicle.preload(MissionType.MISSION, wire)
        with pymavlink_gcs(mavutil, client_conn(vehicle)) as master:
            # pymavlink reads our HEARTBEAT as the firmware's: its flavour's mode names
            assert master.flightmode == ("LOITER" if autopilot == PX4 else "STABILIZE")
            reached = fly_with_pymavlink(mavutil, master, autopilot, len(wire) - 1)
        events = vehicle.flight_events()
    assert reached == [seq for seq, _ in predicted.reached()]
    assert airborne_s(events) == pytest.approx(airborne_s(predicted.events), abs=0.25)


@pytest.mark.parametrize(
    ("autopilot", "steps", "refused", "result", "texts"),
    [
        pytest.param(
            PX4,
            [],
            ("MISSION_START", 0, 0),
            "MAV_RESULT_DENIED",
            ["Mission start denied! No valid mission"],
            id="px4-mission-start-without-mission",
        ),
        pytest.param(
            PX4,
            [],
            ("DO_SET_MODE", 1, 4, 4),
            "MAV_RESULT_TEMPORARILY_REJECTED",
            ["Switching to Mission is currently not available"],
            id="px4-mission-mode-without-mission",
        ),
        pytest.param(
            AP,
            [("DO_SET_MODE", 1, 3)],
            ("COMPONENT_ARM_DISARM", 1),
            "MAV_RESULT_FAILED",
            ["Arm: AUTO mode not armable"],
            id="ardupilot-arm-in-auto",
        ),
        pytest.param(
            AP,
            [],
            ("MISSION_START", 1, 3),
            "MAV_RESULT_DENIED",
            [],
            id="ardupilot-mission-start-nonzero-params",
        ),
        pytest.param(
            AP,
            [],
            ("DO_SET_MODE", 1, 42),
            "MAV_RESULT_FAILED",
            ["No such mode 42"],
            id="ardupilot-no-such-mode",
        ),
    ],
)
def test_refusals_reach_the_client_with_the_firmwares_words(
    mavutil: Any,
    autopilot: Autopilot,
    steps: list[tuple[Any, ...]],
    refused: tuple[Any, ...],
    result: str,
    texts: list[str],
) -> None:
    m = mavutil.mavlink
    plan = synthetic_mission(4, seed=3, autopilot=autopilot)
    with running_mock(loaded(plan, autopilot)) as vehicle:
        if autopilot == AP:
            vehicle.preload(MissionType.MISSION, plan_wire_items(plan, MissionType.MISSION, AP))
        with pymavlink_gcs(mavutil, client_conn(vehicle)) as master:
            for name, *params in steps:
                assert (
                    command(master, getattr(m, f"MAV_CMD_{name}"), *params)[0]
                    == m.MAV_RESULT_ACCEPTED
                )
            name, *params = refused
            assert command(master, getattr(m, f"MAV_CMD_{name}"), *params) == (
                getattr(m, result),
                texts,
            )
        assert not vehicle.snapshot().armed


def test_ardupilot_missing_take_off_reaches_the_client(mavutil: Any) -> None:
    m = mavutil.mavlink
    plan = synthetic_mission(4, seed=3, autopilot=AP)
    no_takeoff = replace(plan, items=plan.items[1:])
    with running_mock(loaded(plan, AP)) as vehicle:
        vehicle.preload(MissionType.MISSION, plan_wire_items(no_takeoff, MissionType.MISSION, AP))
        with pymavlink_gcs(mavutil, client_conn(vehicle)) as master:
            master.set_mode("GUIDED")
            assert wait_ack(master, m.MAV_CMD_DO_SET_MODE)[0] == m.MAV_RESULT_ACCEPTED
            master.arducopter_arm()
            assert wait_ack(master, m.MAV_CMD_COMPONENT_ARM_DISARM)[0] == m.MAV_RESULT_ACCEPTED
            result, texts = command(master, m.MAV_CMD_MISSION_START, 0, 0)
        assert result == m.MAV_RESULT_FAILED
        assert texts[0] == "Auto: Missing Takeoff Cmd"
        assert vehicle.snapshot().landed


def test_pymavlink_param_set_is_echoed_and_unknown_names_refused_as_px4_does(mavutil: Any) -> None:
    with (
        running_mock(SimConfig(autopilot=PX4)) as vehicle,
        pymavlink_gcs(mavutil, client_conn(vehicle)) as master,
    ):
        master.param_set_send("MPC_XY_CRUISE", 7.5)
        value = master.recv_match(type="PARAM_VALUE", blocking=True, timeout=10)
        assert value is not None and (value.param_id, value.param_value) == ("MPC_XY_CRUISE", 7.5)
        master.param_set_send("NO_SUCH_PARAM", 1.0)
        text = master.recv_match(type="STATUSTEXT", blocking=True, timeout=10)
        assert text is not None and text.text == "[pm] unknown param: NO_SUCH_PARAM"
        assert vehicle.vehicle.params["MPC_XY_CRUISE"] == 7.5


# ---------------------------------------------------------------------------------------------
# MAVProxy (not a dependency: its install pulls OpenCV and VTK; run when it is installed)


def test_mavproxy_arms_and_starts_the_mission_headless(tmp_path: Path) -> None:
    if importlib.util.find_spec("MAVProxy") is None:
        pytest.skip("MAVProxy is not installed (pip install MAVProxy)")
    plan = synthetic_mission(4, seed=3, autopilot=AP)
    with running_mock(loaded(plan, AP, speedup=SPEEDUP)) as vehicle:
        vehicle.preload(MissionType.MISSION, plan_wire_items(plan, MissionType.MISSION, AP))
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "MAVProxy.mavproxy",
                f"--master={client_conn(vehicle)}",
                "--non-interactive",
                "--default-modules=link,mode,arm,cmdlong,wp,param,misc",
                f"--state-basedir={tmp_path}",
                # arm in STABILIZE (armable), then MISSION_START switches to AUTO and flies
                "--cmd=arm throttle; long MISSION_START 0 0",
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            text=True,
        )
        try:

            def flown(v: MockVehicle) -> bool:
                periods = v.snapshot().armed_periods
                return bool(periods) and periods[-1][1] is not None

            assert vehicle.wait_for(flown, FLIGHT_TIMEOUT_S), vehicle.snapshot()
        finally:
            proc.terminate()
            try:
                output, _ = proc.communicate(timeout=10)
            finally:
                if proc.poll() is None:
                    proc.kill()
                    proc.communicate()
        events = vehicle.flight_events()
    reached = [e.seq for e in events if e.kind is EventKind.REACHED]
    assert reached == [seq for seq, _ in simulate(plan).reached()], output
    assert "Traceback" not in output


# ---------------------------------------------------------------------------------------------
# The mock-vehicle process

#: the ``uavplan`` console script, without relying on the venv's bin/ being on PATH
UAVPLAN = [sys.executable, "-c", "from uavplan.cli import main; main()"]


@pytest.mark.slow
def test_mock_vehicle_process_flies_its_mission_at_speedup(mavutil: Any, tmp_path: Path) -> None:
    plan = synthetic_mission(4, seed=5, autopilot=AP)
    path = tmp_path / "mission.plan"
    save_mission(plan, path)
    wire = plan_wire_items(plan, MissionType.MISSION, AP)
    proc = subprocess.Popen(
        [
            *UAVPLAN,
            "mock-vehicle",
            "--conn",
            "udpin:127.0.0.1:0",
            "--autopilot",
            "ardupilot",
            "--mission",
            str(path),
            "--speedup",
            str(SPEEDUP),
        ],
        stderr=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    try:
        assert proc.stderr is not None
        line = proc.stderr.readline()
        match = re.search(r"serving on udpin:127\.0\.0\.1:(\d+)", line)
        assert match, line
        with pymavlink_gcs(mavutil, f"udpout:127.0.0.1:{match.group(1)}") as master:
            reached = fly_with_pymavlink(mavutil, master, AP, len(wire) - 1)
        assert reached == [seq for seq, _ in simulate(plan).reached()]
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            _, stderr = proc.communicate(timeout=10)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.communicate()
    assert proc.returncode == 0, stderr
    assert "Traceback" not in stderr
