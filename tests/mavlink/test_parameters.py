"""Vehicle parameters a mission relies on (issue 27 item 4): the sans-I/O parameter machine
against scripted and simulated vehicles, PARAM_SET / PARAM_VALUE against the simulated
vehicle over real UDP (a refused parameter, lost replies, an unknown name), and
``upload --set-params`` end to end."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import pytest
from click.testing import CliRunner, Result
from helpers.mavlink_helpers import client_conn, running_mock, synthetic_mission

from uavplan.cli import main
from uavplan.mavlink.link import VehicleLink
from uavplan.mavlink.messages import Message, ParamRequestRead, ParamSet, ParamValue, Received
from uavplan.mavlink.parameters import (
    ParamClient,
    ParamMachine,
    ParamRequest,
    ParamStatus,
    ParamTimeouts,
    decode_value,
    encode_value,
)
from uavplan.mission.io import load_mission, save_mission
from uavplan.mission.items import Autopilot, MissionType, VehicleParameter
from uavplan.sim.faults import Faults
from uavplan.sim.vehicle import SimConfig, SimVehicle
from uavplan.sim.vehicles import new_vehicle

pytestmark = pytest.mark.timeout(60)

AP, PX4 = Autopilot.ARDUPILOT, Autopilot.PX4
FAST = ParamTimeouts(reply_s=0.2, retries=4)
GCS = (255, 190)

# ---------------------------------------------------------------------------------------------
# The machine, driven by hand (a fake clock, scripted answers)


def test_a_value_within_the_range_is_kept_after_one_read() -> None:
    machine = ParamMachine((1, 1), [ParamRequest("RTL_ALT", 4500, 4500, 11800)], bytewise=False)
    sent = machine.start(0.0)
    assert sent == [ParamRequestRead(1, 1, "RTL_ALT", -1)]
    assert machine.on_message(ParamValue("RTL_ALT", 6000.0, 6, 20, 7), 0.01) == []
    assert machine.finished
    (result,) = machine.results
    assert (result.status, result.old, result.new) == (ParamStatus.KEPT, 6000.0, 6000.0)


def test_a_value_outside_is_set_then_read_back() -> None:
    machine = ParamMachine((1, 1), [ParamRequest("RTL_ALT", 4500, 4500, 11800)], bytewise=False)
    machine.start(0.0)
    (set_,) = machine.on_message(ParamValue("RTL_ALT", 1500.0, 6, 20, 7), 0.01)
    assert set_ == ParamSet(1, 1, "RTL_ALT", 4500.0, 6)  # in the vehicle's own type
    (read_back,) = machine.on_message(ParamValue("RTL_ALT", 4500.0, 6, 20, 7), 0.02)
    assert read_back == ParamRequestRead(1, 1, "RTL_ALT", -1)
    machine.on_message(ParamValue("RTL_ALT", 4500.0, 6, 20, 7), 0.03)
    (result,) = machine.results
    assert (result.status, result.old, result.new) == (ParamStatus.CHANGED, 1500.0, 4500.0)
    assert result.describe() == "RTL_ALT 1500 → 4500"


def test_a_lost_reply_is_asked_for_again_until_the_budget_is_spent() -> None:
    timeouts = ParamTimeouts(reply_s=1.0, retries=2)
    machine = ParamMachine((1, 1), [ParamRequest("FENCE_ENABLE", 1)], bytewise=False,
                           timeouts=timeouts)  # fmt: skip
    sent = machine.start(0.0)
    assert machine.on_timeout(0.5) == []  # not yet
    sent += machine.on_timeout(1.0)
    sent += machine.on_timeout(2.0)
    assert sent == [ParamRequestRead(1, 1, "FENCE_ENABLE", -1)] * 3
    assert machine.on_timeout(3.0) == [] and machine.finished
    (result,) = machine.results
    assert result.status is ParamStatus.UNANSWERED
    assert "FENCE_ENABLE" in result.describe() and "3 × PARAM_REQUEST_READ" in result.describe()


def test_a_refusal_is_set_twice_then_reported_with_the_vehicles_words() -> None:
    from uavplan.mavlink.messages import StatusText

    machine = ParamMachine((1, 1), [ParamRequest("RTL_ALT", 4500, 4500)], bytewise=False)
    machine.start(0.0)
    old = ParamValue("RTL_ALT", 1500.0, 6, 20, 7)
    sets = 0
    for now in (0.01, 0.02, 0.03, 0.04, 0.05):
        machine.on_message(StatusText(4, "Param write denied (RTL_ALT)"), now)
        out = machine.on_message(old, now)
        sets += sum(isinstance(m, ParamSet) for m in out)
        if machine.finished:
            break
    assert sets == 2
    (result,) = machine.results
    assert (result.status, result.old, result.new) == (ParamStatus.REFUSED, 1500.0, 4500.0)
    assert 'vehicle: "Param write denied (RTL_ALT)"' in result.describe()


def test_a_late_read_reply_taken_for_the_sets_answer_is_not_a_refusal() -> None:
    """The read was re-sent, its late reply arrives after the PARAM_SET, which was lost:
    the read-back shows the old value, so the value is set again, and this time it holds."""
    machine = ParamMachine((1, 1), [ParamRequest("RTL_ALT", 4500, 4500)], bytewise=False)
    machine.start(0.0)
    old = ParamValue("RTL_ALT", 1500.0, 6, 20, 7)
    machine.on_message(old, 0.1)  # → PARAM_SET (lost on the way)
    machine.on_message(old, 0.11)  # the late reply to the re-sent read: → read-back
    again = machine.on_message(old, 0.12)  # the read-back: still 1500 → set once more
    assert again == [ParamSet(1, 1, "RTL_ALT", 4500.0, 6)]
    machine.on_message(ParamValue("RTL_ALT", 4500.0, 6, 20, 7), 0.13)
    machine.on_message(ParamValue("RTL_ALT", 4500.0, 6, 20, 7), 0.14)
    assert machine.results[0].status is ParamStatus.CHANGED


def test_integer_parameters_travel_as_each_firmware_encodes_them() -> None:
    # PX4 sends an INT32's bytes in the float (PARAM_ENCODE_BYTEWISE), ArduPilot casts
    wire = encode_value(2, 6, bytewise=True)
    assert struct.pack("<f", wire) == struct.pack("<i", 2)
    assert decode_value(wire, 6, bytewise=True) == 2.0
    assert encode_value(2, 6, bytewise=False) == 2.0
    assert encode_value(2.5, 9, bytewise=True) == 2.5  # REAL32 as it is


# ---------------------------------------------------------------------------------------------
# The machine against the simulated vehicle, sans-I/O (deterministic faults)


def drive(vehicle: SimVehicle, machine: ParamMachine, *, limit_s: float = 30.0) -> None:
    """Run ``machine`` against ``vehicle`` with a fake clock until it is done."""
    now = 0.0
    inbox: list[Message] = []
    outbox = machine.start(now)
    while not machine.finished:
        assert now < limit_s, "the machine never finished"
        for message in outbox:
            inbox.extend(vehicle.receive(Received(message, *GCS), now))
        outbox = []
        for message in inbox:
            outbox.extend(machine.on_message(message, now))
        inbox = []
        now += 0.01
        if not outbox and now >= machine.deadline:
            outbox = machine.on_timeout(now)


@pytest.mark.parametrize("seed", range(6))
def test_replies_lost_by_the_vehicle_are_recovered(seed: int) -> None:
    faults = Faults(drop_rate=0.4, only=frozenset({"PARAM_VALUE"}), direction="out", seed=seed)
    vehicle = new_vehicle(SimConfig(autopilot=AP, faults=faults))
    requests = [ParamRequest("RTL_ALT", 4500, 4500), ParamRequest("FENCE_ENABLE", 1)]
    timeouts = ParamTimeouts(reply_s=0.2, retries=10)  # 11 tries of a 40 % loss each
    machine = ParamMachine((1, 1), requests, bytewise=False, timeouts=timeouts)
    drive(vehicle, machine)
    assert [r.status for r in machine.results] == [ParamStatus.CHANGED] * 2
    assert (vehicle.params["RTL_ALT"], vehicle.params["FENCE_ENABLE"]) == (4500.0, 1.0)
    assert vehicle.injector.dropped_out > 0  # replies really were lost


# ---------------------------------------------------------------------------------------------
# PARAM_SET / PARAM_VALUE with the simulated vehicle over UDP


def apply(vehicle, requests: list[ParamRequest]):  # type: ignore[no-untyped-def]
    link = VehicleLink.connect(client_conn(vehicle), heartbeat_timeout_s=5.0)
    try:
        return ParamClient(link, FAST).apply(requests)
    finally:
        link.close()


def test_ardupilot_parameters_are_set_read_back_and_honoured() -> None:
    with running_mock(SimConfig(autopilot=AP)) as vehicle:
        results = apply(
            vehicle,
            [
                ParamRequest("RTL_ALT", 4500, 4500, 11800),
                ParamRequest("FENCE_ENABLE", 1),
                ParamRequest("FENCE_TYPE", 5),
                ParamRequest("FENCE_ALT_MAX", 120.0),
            ],
        )
        assert [r.describe() for r in results] == [
            "RTL_ALT 1500 → 4500",
            "FENCE_ENABLE 0 → 1",
            "FENCE_TYPE 7 → 5",
            "FENCE_ALT_MAX 100 → 120",
        ]
        limits = vehicle.vehicle.flight.limits  # the flight model flies by them now
        assert (limits.rtl_altitude_m, limits.fence_ceiling_m) == (45.0, 120.0)
        again = apply(vehicle, [ParamRequest("RTL_ALT", 4500, 4500, 11800)])
        assert again[0].status is ParamStatus.KEPT


def test_px4_integer_parameters_go_bytewise() -> None:
    with running_mock(SimConfig(autopilot=PX4)) as vehicle:
        results = apply(
            vehicle,
            [
                ParamRequest("RTL_TYPE", 2),
                ParamRequest("GF_ACTION", 2, 1, 5),
                ParamRequest("GF_MAX_VER_DIST", 120.0),
            ],
        )
        assert [r.status for r in results] == [
            ParamStatus.CHANGED,
            ParamStatus.KEPT,  # PX4's default, Hold, is a fence that acts
            ParamStatus.CHANGED,
        ]
        params = vehicle.vehicle.params
        assert (params["RTL_TYPE"], params["GF_MAX_VER_DIST"]) == (2.0, 120.0)


def test_a_refused_parameter_is_reported_with_the_vehicles_words() -> None:
    faults = Faults(refuse_param_set=frozenset({"RTL_ALT"}))
    with running_mock(SimConfig(autopilot=AP, faults=faults)) as vehicle:
        results = apply(
            vehicle, [ParamRequest("RTL_ALT", 4500, 4500), ParamRequest("FENCE_ENABLE", 1)]
        )
        refused, done = results
        assert refused.status is ParamStatus.REFUSED
        assert (refused.old, refused.new) == (1500.0, 4500.0)
        assert refused.statustext == "Param write denied (RTL_ALT)"
        assert done.status is ParamStatus.CHANGED  # the others still go through
        assert vehicle.vehicle.params["RTL_ALT"] == 1500.0


@pytest.mark.parametrize("autopilot", [AP, PX4], ids=lambda a: a.label)
@pytest.mark.slow
def test_an_unknown_name_is_unanswered(autopilot: Autopilot) -> None:
    with running_mock(SimConfig(autopilot=autopilot)) as vehicle:
        (result,) = apply(vehicle, [ParamRequest("NO_SUCH_PARAM", 1)])
    assert result.status is ParamStatus.UNANSWERED
    assert "NO_SUCH_PARAM" in result.describe()


def test_replies_lost_on_the_link_are_retried_over_udp() -> None:
    faults = Faults(drop_rate=0.5, only=frozenset({"PARAM_VALUE"}), direction="out", seed=11)
    with running_mock(SimConfig(autopilot=AP, faults=faults)) as vehicle:
        results = apply(vehicle, [ParamRequest("RTL_ALT", 6000, 6000)])
        assert results[0].status is ParamStatus.CHANGED
        assert vehicle.vehicle.injector.dropped_out > 0


# ---------------------------------------------------------------------------------------------
# upload --set-params


def run(*args: str) -> Result:
    return CliRunner().invoke(main, list(args), catch_exceptions=False)


@pytest.fixture
def plan_with_parameters(tmp_path: Path) -> Path:
    plan = synthetic_mission(12, seed=5, autopilot=AP)
    plan = type(plan)(
        **{
            **plan.__dict__,
            "parameters": (
                VehicleParameter("RTL_ALT", 6000, 6000, 12000, "cm", "clears the tallest"),
                VehicleParameter("FENCE_ALT_MAX", 120, unit="m", reason="the ceiling"),
            ),
        }
    )
    path = tmp_path / "m.plan"
    save_mission(plan, path)
    assert load_mission(path).parameters == plan.parameters  # the .plan keeps them
    return path


def test_upload_sets_the_parameters_and_prints_what_changed(plan_with_parameters: Path) -> None:
    with running_mock(SimConfig(autopilot=AP)) as vehicle:
        result = run("upload", str(plan_with_parameters), "--conn", client_conn(vehicle),
                     "--set-params")  # fmt: skip
        assert result.exit_code == 0, result.output
        assert vehicle.vehicle.params["RTL_ALT"] == 6000.0
        assert vehicle.items(MissionType.MISSION)  # the mission went up after them
    assert "RTL_ALT 1500 → 6000, FENCE_ALT_MAX 100 → 120" in result.stdout


def test_upload_exits_4_naming_a_refused_parameter(plan_with_parameters: Path) -> None:
    faults = Faults(refuse_param_set=frozenset({"FENCE_ALT_MAX"}))
    with running_mock(SimConfig(autopilot=AP, faults=faults)) as vehicle:
        result = run("upload", str(plan_with_parameters), "--conn", client_conn(vehicle),
                     "--set-params", "--timeout", "0.3")  # fmt: skip
        assert not vehicle.items(MissionType.MISSION)  # nothing relies on what failed
    assert result.exit_code == 4
    assert result.stderr.startswith("error: set parameters: FENCE_ALT_MAX: ")
    assert "refused 120 and kept 100" in result.stderr
    assert "Param write denied (FENCE_ALT_MAX)" in result.stderr


@pytest.mark.slow
def test_upload_exits_4_when_every_reply_is_lost(plan_with_parameters: Path) -> None:
    faults = Faults(drop_rate=1.0, only=frozenset({"PARAM_VALUE"}), direction="out")
    with running_mock(SimConfig(autopilot=AP, faults=faults)) as vehicle:
        result = run("upload", str(plan_with_parameters), "--conn", client_conn(vehicle),
                     "--set-params", "--timeout", "0.1", "--retries", "2")  # fmt: skip
    assert result.exit_code == 4
    assert "RTL_ALT: no PARAM_VALUE answered 3 × PARAM_REQUEST_READ" in result.stderr


def test_upload_set_params_needs_the_right_firmware(
    tmp_path: Path, plan_with_parameters: Path
) -> None:
    with running_mock(SimConfig(autopilot=PX4)) as vehicle:
        result = run("upload", str(plan_with_parameters), "--conn", client_conn(vehicle),
                     "--set-params")  # fmt: skip
    assert result.exit_code == 2 and "the vehicle is px4" in result.stderr


@pytest.mark.slow
def test_plan_writes_the_parameters_it_prints(tmp_path: Path) -> None:
    root = Path(__file__).resolve().parents[2]
    out, report = tmp_path / "env1.plan", tmp_path / "env1.json"
    # without a legal ceiling paper-env1 relies on its proven RTL altitude (with the default
    # 120 m one it ends with a planned return: issue 37)
    result = run("plan", str(root / "missions" / "paper-env1.yaml"), "-o", str(out),
                 "--report", str(report), "--fence", "--iterations", "30",
                 "--legal-ceiling", "none")  # fmt: skip
    assert result.exit_code == 0, result.output
    written = {p.name: p for p in load_mission(out).parameters}
    reported = {p["name"]: p for p in json.loads(report.read_text())["way_home"]["parameters"]}
    assert set(written) == set(reported) == {"RTL_ALT", "FENCE_ENABLE", "FENCE_TYPE",
                                             "FENCE_ALT_MAX"}  # fmt: skip
    assert written["FENCE_ALT_MAX"].value == 250.0  # paper-env1's ceiling
    assert written["RTL_ALT"].at_least == reported["RTL_ALT"]["at_least"]


def test_the_plan_files_parameters_are_checked_and_dropped_with_a_note_elsewhere(
    tmp_path: Path, plan_with_parameters: Path
) -> None:
    doc = json.loads(plan_with_parameters.read_text())
    doc["parameters"]["items"][0]["value"] = "high"
    bad = tmp_path / "bad.plan"
    bad.write_text(json.dumps(doc))
    result = run("validate", str(bad))
    assert result.exit_code == 2
    assert "parameters.items[0].value: must be a number" in result.stderr
    result = run("convert", str(plan_with_parameters), str(tmp_path / "m.waypoints"))
    assert result.exit_code == 0, result.output
    assert "holds no vehicle parameters (RTL_ALT, FENCE_ALT_MAX); left out" in result.stderr
