"""The vehicle side of issue 37: the parameters a mission relies on enforced by ``upload`` and
``fly`` (items 3), the vehicle's mission storage and the empty upload (item 6).

The vehicle is the simulated one (:class:`~uavplan.sim.mock.MockVehicle`) over real UDP
sockets on 127.0.0.1 with OS-assigned ports; it starts with the firmware's defaults unless a
test gives it values, as ``mock-vehicle`` without ``--param`` does. What is asserted is what
the vehicle holds and did (its parameters, its mission, whether it armed), never the clock.

The scene of the ``--accept-vehicle-params`` tests is made here, independent of the
planner: a wall 100 m high between home and the goal, a route around it ending in RTL. The
autopilot's return straight home crosses the wall unless it flies above 110 m (the wall and
the 10 m margin), so RTL_ALT 1500 (ArduPilot's default, 15 m) fails the proof and 13000
(130 m) keeps it.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner, Result
from helpers.mavlink_helpers import HOME, client_conn, running_mock, synthetic_mission

from uavplan.autopilot.params import Parameters, param_table
from uavplan.cli import main
from uavplan.errors import InputError
from uavplan.geo import EnuFrame
from uavplan.mavlink.messages import ParamRequestRead, ParamSet, ParamValue, Received
from uavplan.mavlink.parameters import ParamMachine, ParamRequest, ParamStatus
from uavplan.mission.builder import build_mission
from uavplan.mission.io import save_mission
from uavplan.mission.items import Autopilot, MissionPlan, MissionType, VehicleParameter
from uavplan.sim.vehicle import SimConfig
from uavplan.sim.vehicles import new_vehicle

pytestmark = pytest.mark.timeout(180)

AP, PX4 = Autopilot.ARDUPILOT, Autopilot.PX4
ROOT = Path(__file__).resolve().parents[2]
SPEEDUP = 100.0
#: what paper-env1's plan relies on (README, "The way home")
RTL_23000 = VehicleParameter("RTL_ALT", 23000, 23000, 24800, "cm", "the way home")


def run(*args: str) -> Result:
    return CliRunner().invoke(main, list(args))


def with_parameters(plan: MissionPlan, *parameters: VehicleParameter) -> MissionPlan:
    return replace(plan, parameters=parameters)


def saved(tmp_path: Path, plan: MissionPlan, name: str = "m.plan") -> Path:
    path = tmp_path / name
    save_mission(plan, path)
    return path


def config(plan: MissionPlan, autopilot: Autopilot, **kw: object) -> SimConfig:
    kw.setdefault("speedup", SPEEDUP)
    return SimConfig(autopilot=autopilot, home=plan.home, **kw)  # type: ignore[arg-type]


# ---------------------------------------------------------------------------------------------
# The parameter machine reads without setting


def test_reading_only_reports_a_differing_value_and_sends_no_param_set() -> None:
    machine = ParamMachine(
        (1, 1), [ParamRequest("RTL_ALT", 23000, 23000, 24800)], bytewise=False, set_values=False
    )
    assert machine.start(0.0) == [ParamRequestRead(1, 1, "RTL_ALT", -1)]
    assert machine.on_message(ParamValue("RTL_ALT", 1500.0, 6, 20, 7), 0.01) == []
    (result,) = machine.results
    assert result.status is ParamStatus.DIFFERS and not result.ok
    assert result.describe() == ("RTL_ALT is 1500 on the vehicle, the mission needs 23000..24800")


# ---------------------------------------------------------------------------------------------
# upload


def test_set_params_on_a_mission_relying_on_none_says_so_and_succeeds(tmp_path: Path) -> None:
    """The README Quick start's `upload --set-params` on a mission that ends in a planned
    return (narrow-gap): it relies on no parameter, which is no error."""
    plan = synthetic_mission(8, seed=3, autopilot=AP)
    assert not plan.parameters
    path = saved(tmp_path, plan)
    with running_mock(config(plan, AP)) as vehicle:
        result = run("upload", str(path), "--conn", client_conn(vehicle), "--set-params")
        assert vehicle.items(MissionType.MISSION)
    assert result.exit_code == 0, result.output
    assert "relies on no vehicle parameter" in result.output
    assert "uploaded 8" in result.output or "uploaded" in result.output


def test_upload_refuses_a_vehicle_holding_another_value_and_sends_nothing(
    tmp_path: Path,
) -> None:
    plan = with_parameters(synthetic_mission(8, seed=3, autopilot=AP), RTL_23000)
    path = saved(tmp_path, plan)
    with running_mock(config(plan, AP)) as vehicle:
        result = run("upload", str(path), "--conn", client_conn(vehicle))
        assert not vehicle.items(MissionType.MISSION)  # nothing sent
        assert vehicle.vehicle.params["RTL_ALT"] == 1500.0  # nothing changed
    assert result.exit_code == 4, result.output
    assert "RTL_ALT is 1500 on the vehicle, the mission needs 23000..24800" in result.stderr
    assert "--set-params" in result.stderr
    with running_mock(config(plan, AP)) as vehicle:
        result = run("upload", str(path), "--conn", client_conn(vehicle), "--set-params")
        assert vehicle.vehicle.params["RTL_ALT"] == 23000.0
        assert vehicle.items(MissionType.MISSION)
    assert result.exit_code == 0, result.output
    assert "RTL_ALT 1500 → 23000" in result.output


def test_upload_accepts_a_vehicle_already_holding_the_values(tmp_path: Path) -> None:
    plan = with_parameters(synthetic_mission(8, seed=3, autopilot=AP), RTL_23000)
    path = saved(tmp_path, plan)
    with running_mock(config(plan, AP, params={"RTL_ALT": 24000})) as vehicle:
        result = run("upload", str(path), "--conn", client_conn(vehicle))
        assert vehicle.items(MissionType.MISSION)
    assert result.exit_code == 0, result.output
    assert "RTL_ALT 24000 (kept)" in result.output


def test_an_empty_mission_is_refused_without_clear(tmp_path: Path) -> None:
    """`upload` of a .plan with no items used to say "uploaded 0 mission items ... verified"
    and wipe the vehicle's mission."""
    held = synthetic_mission(6, seed=2)
    empty = saved(tmp_path, replace(held, items=()), "empty.plan")
    with running_mock(config(held, PX4)) as vehicle:
        vehicle.preload(MissionType.MISSION, held.wire_items())
        result = run("upload", str(empty), "--conn", client_conn(vehicle))
        assert len(vehicle.items(MissionType.MISSION)) == len(held.items)  # kept
        assert result.exit_code == 2, result.output
        assert "--clear" in result.stderr
        result = run("upload", str(empty), "--conn", client_conn(vehicle), "--clear")
        assert result.exit_code == 0, result.output
        assert vehicle.items(MissionType.MISSION) == []


def test_a_mission_larger_than_the_vehicles_storage_is_refused_before_connecting(
    tmp_path: Path,
) -> None:
    big = saved(tmp_path, synthetic_mission(520, seed=4, end="land"))  # PX4 stores 500
    # nothing listens on port 9: the refusal comes before any connection
    result = run("upload", str(big), "--conn", "udpout:127.0.0.1:9", "--heartbeat-timeout", "1")
    assert result.exit_code == 2, result.output
    assert "523 mission items do not fit the vehicle's storage: px4 holds 500" in result.stderr
    result = run(
        "upload", str(big), "--conn", "udpout:127.0.0.1:9", "--heartbeat-timeout", "0.2",
        "--max-items", "2000",
    )  # fmt: skip
    assert result.exit_code == 4  # past the check: no heartbeat on port 9


def test_the_writer_refuses_a_mission_over_the_storage_before_writing(tmp_path: Path) -> None:
    scenario = tmp_path / "s.yaml"
    text = (ROOT / "missions" / "paper-env1.yaml").read_text()
    text = text.replace("../maps/", str(ROOT / "maps") + "/")
    scenario.write_text(text + "\n" if "mission:" in text else text)
    doc = scenario.read_text()
    if "mission:" in doc:
        doc = doc.replace("mission: {", "mission: {max_items: 5, ", 1)
    else:
        doc += "mission: {max_items: 5}\n"
    scenario.write_text(doc)
    out = tmp_path / "v.plan"
    result = run("plan", str(scenario), "-o", str(out), "--iterations", "5", "-q")
    assert result.exit_code == 2, result.output
    assert "do not fit the vehicle's storage" in result.stderr
    assert "mission.max_items" in result.stderr
    assert not out.exists()


def test_fifteen_thousand_items_are_refused_by_the_storage_check() -> None:
    """The issue's 900 km route wrote 15,002 items: no flavour's default storage holds
    them, so the writer's check (and upload's) refuses them."""
    from uavplan.mavlink.transfer import check_storage

    plan = synthetic_mission(14_999, seed=9, autopilot=AP, speed_m_s=None)
    with pytest.raises(InputError, match=r"15,002 mission items \(home included\) do not fit"):
        check_storage(plan, file="route-900km.plan")
    with pytest.raises(InputError, match="do not fit"):
        check_storage(replace(plan, autopilot=PX4))
    check_storage(plan, 20_000)  # a vehicle that stores more, given


# ---------------------------------------------------------------------------------------------
# fly


@pytest.mark.slow
def test_fly_refuses_default_rtl_alt_naming_it_then_flies_after_set_params(
    tmp_path: Path,
) -> None:
    """A mock vehicle started without --param holds ArduPilot's RTL_ALT 1500 (15 m); the
    plan relies on 23000..24800."""
    plan = with_parameters(synthetic_mission(6, seed=7, autopilot=AP), RTL_23000)
    path = saved(tmp_path, plan)
    with running_mock(config(plan, AP)) as vehicle:
        result = run("fly", str(path), "--conn", client_conn(vehicle), "-q")
        snap = vehicle.snapshot()
        assert not snap.armed and not snap.armed_periods  # nothing moved
        assert vehicle.stats().uploads_accepted == 0  # nothing uploaded
        assert vehicle.vehicle.params["RTL_ALT"] == 1500.0
    assert result.exit_code == 4, result.output
    assert "pre-flight: parameters" in result.stderr
    assert "RTL_ALT is 1500 on the vehicle, the mission needs 23000..24800" in result.stderr
    with running_mock(config(plan, AP)) as vehicle:
        result = run("fly", str(path), "--conn", client_conn(vehicle), "--set-params")
        assert vehicle.vehicle.params["RTL_ALT"] == 23000.0
    assert result.exit_code == 0, result.output
    assert "RTL_ALT 1500 → 23000" in result.output
    assert "mission complete" in result.output


def wall_scene(tmp_path: Path) -> tuple[Path, MissionPlan]:
    """A scenario with a 100 m wall between home and the goal, and an ArduPilot mission
    around it that ends in RTL (see the module doc)."""
    scenario = tmp_path / "wall.yaml"
    scenario.write_text(
        "name: wall\n"
        f"origin: {{lat: {HOME.lat_deg}, lon: {HOME.lon_deg}, alt: {HOME.alt_m}}}\n"
        "bounds: {x: [-50, 700], y: [-200, 250], z: [0, 250]}\n"
        "start: [0, 0, 30]\n"
        "goal: [600, 0, 30]\n"
        "obstacles:\n"
        "  - {type: box, center: [300, 0], size: [40, 200], height: 100}\n"
        "mission: {autopilot: ardupilot}\n"
    )
    route = np.array([[0, 0, 30], [0, 160, 30], [600, 160, 30], [600, 0, 30]], dtype=np.float64)
    plan = build_mission(
        route, EnuFrame.at(HOME), autopilot=AP, end="rtl", takeoff_altitude_m=30.0,
        cruise_speed_m_s=12.0,
    )  # fmt: skip
    wanted = VehicleParameter("RTL_ALT", 15000, 15000, 20000, "cm", "clears the wall")
    return scenario, with_parameters(plan, wanted)


@pytest.mark.slow
def test_accept_vehicle_params_is_refused_when_the_reproof_fails(tmp_path: Path) -> None:
    scenario, plan = wall_scene(tmp_path)
    path = saved(tmp_path, plan)
    with running_mock(config(plan, AP)) as vehicle:  # RTL_ALT 1500: home through the wall
        result = run("fly", str(path), "--conn", client_conn(vehicle), "--scenario",
                     str(scenario), "--accept-vehicle-params", "-q")  # fmt: skip
        snap = vehicle.snapshot()
        assert not snap.armed and not snap.armed_periods
        assert vehicle.stats().uploads_accepted == 0
    assert result.exit_code == 4, result.output
    assert "with the vehicle's RTL_ALT 1500 the flight does not keep the margin" in result.stderr
    assert "obstacles[0]" in result.stderr
    # upload re-proves the same way
    with running_mock(config(plan, AP)) as vehicle:
        result = run("upload", str(path), "--conn", client_conn(vehicle), "--scenario",
                     str(scenario), "--accept-vehicle-params")  # fmt: skip
        assert not vehicle.items(MissionType.MISSION)
    assert result.exit_code == 4, result.output


@pytest.mark.slow
def test_accept_vehicle_params_flies_when_the_reproof_holds(tmp_path: Path) -> None:
    scenario, plan = wall_scene(tmp_path)
    path = saved(tmp_path, plan)
    # 130 m: not what the plan asks (150..200 m), but above the wall and its margin
    with running_mock(config(plan, AP, params={"RTL_ALT": 13000})) as vehicle:
        result = run("fly", str(path), "--conn", client_conn(vehicle), "--scenario",
                     str(scenario), "--accept-vehicle-params")  # fmt: skip
        assert vehicle.vehicle.params["RTL_ALT"] == 13000.0  # kept
    assert result.exit_code == 0, result.output
    assert "--accept-vehicle-params: flying with the vehicle's RTL_ALT 13000" in result.output
    assert "mission complete" in result.output


def test_accept_vehicle_params_needs_a_scenario(tmp_path: Path) -> None:
    plan = with_parameters(synthetic_mission(6, seed=7, autopilot=AP), RTL_23000)
    path = saved(tmp_path, plan)
    result = run("fly", str(path), "--conn", "udpout:127.0.0.1:9", "--accept-vehicle-params")
    assert result.exit_code == 2
    assert "give --scenario" in result.output
    result = run("upload", str(path), "--conn", "udpout:127.0.0.1:9", "--accept-vehicle-params")
    assert result.exit_code == 2
    assert "give --scenario" in result.output


# ---------------------------------------------------------------------------------------------
# One reading of --param; the simulated vehicle answers for every parameter it flies by


@pytest.mark.parametrize("autopilot", [AP, PX4])
def test_the_simulated_vehicle_reads_and_sets_every_parameter_it_flies_by(
    autopilot: Autopilot,
) -> None:
    """PARAM_REQUEST_READ of every row of the flight model's table answers its value, and
    a PARAM_SET of the RTL altitude changes the altitude the model's return flies at."""
    vehicle = new_vehicle(SimConfig(autopilot=autopilot, telemetry=False))

    def replies(message: object, now: float) -> list[ParamValue]:
        out = vehicle.receive(Received(message, 255, 190), now)  # type: ignore[arg-type]
        return [m for m in out if isinstance(m, ParamValue)]

    for i, spec in enumerate(param_table(autopilot)):
        (reply,) = replies(ParamRequestRead(1, 1, spec.name, -1), 0.01 * i)
        assert reply.param_id == spec.name and reply.param_index == i
    rtl, value = ("RTL_ALT", 23000.0) if autopilot is AP else ("RTL_RETURN_ALT", 230.0)
    param_type = 6 if autopilot is AP else 9  # INT32 (a C cast on ArduPilot), REAL32
    (reply,) = replies(ParamSet(1, 1, rtl, value, param_type), 1.0)
    assert reply.param_value == value
    assert vehicle.params[rtl] == value
    assert vehicle.flight.limits.rtl_altitude_m == pytest.approx(230.0)


def test_simulate_and_mock_vehicle_read_param_through_one_parser(tmp_path: Path) -> None:
    plan = saved(tmp_path, synthetic_mission(4, seed=1, autopilot=AP))
    sim = run("simulate", str(plan), "--param", "RTL_ALTITUDE=3", "-q")
    mock = run("mock-vehicle", "--conn", "udpin:127.0.0.1:0", "--autopilot", "ardupilot",
               "--param", "RTL_ALTITUDE=3")  # fmt: skip
    assert sim.exit_code == mock.exit_code == 2
    expected = "ardupilot has no parameter 'RTL_ALTITUDE' (it has WPNAV_SPEED"
    assert expected in sim.stderr and expected in mock.stderr
    sim = run("simulate", str(plan), "--param", "RTL_ALT=5", "-q")
    mock = run("mock-vehicle", "--conn", "udpin:127.0.0.1:0", "--autopilot", "ardupilot",
               "--param", "RTL_ALT=5")  # fmt: skip
    assert sim.exit_code == mock.exit_code == 2
    assert "RTL_ALT 5 is below its minimum 30" in sim.stderr
    assert "RTL_ALT 5 is below its minimum 30" in mock.stderr
    assert Parameters(AP)["RTL_ALT"] == 1500.0  # a vehicle without --param: the defaults
