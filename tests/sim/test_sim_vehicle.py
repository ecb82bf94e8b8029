"""The simulated vehicle as a state machine (no sockets): modes and arming as the firmware
has them, each refusal with the firmware's own words, telemetry, parameters, speedup, the
link-loss fault, and a flight through the vehicle that takes as long as ``simulate``."""

from __future__ import annotations

import math
import struct
from dataclasses import replace

import pytest
from helpers.mavlink_helpers import HOME, synthetic_mission
from helpers.vehicle_driver import Driver, start, with_mission

from uavplan.autopilot.simulate import simulate
from uavplan.mavlink.messages import (
    BatteryStatus,
    CommandAck,
    CommandLong,
    ExtendedSysState,
    GlobalPositionInt,
    Heartbeat,
    HomePosition,
    LandedState,
    MavCommand,
    MavModeFlag,
    MavResult,
    MavState,
    MavType,
    Message,
    MessageId,
    MissionCurrent,
    MissionItemReached,
    MissionState,
    ParamRequestList,
    ParamRequestRead,
    ParamSet,
    ParamValue,
    RequestDataStream,
    SetMode,
    Severity,
    SysStatus,
)
from uavplan.mavlink.modes import px4_custom_mode
from uavplan.mission.items import Autopilot
from uavplan.sim.faults import Faults
from uavplan.sim.vehicle import MAX_CATCH_UP_S, SimConfig

AP, PX4 = Autopilot.ARDUPILOT, Autopilot.PX4
GCS = (255, 190)

PX4_MISSION = (1, 4, 4)  # (base mode flag, main, sub) of MAV_CMD_DO_SET_MODE
PX4_HOLD = (1, 4, 3)


def of_type(messages: list[Message], kind: type) -> list:  # type: ignore[type-arg]
    return [m for m in messages if isinstance(m, kind)]


# ---------------------------------------------------------------------------------------------
# Modes and arming


def test_px4_heartbeat_packs_main_and_sub_mode_and_shows_the_armed_bit() -> None:
    driver = with_mission(PX4)
    driver.run(1.0)
    hb = driver.heartbeat()
    assert hb.custom_mode == (3 << 24) | (4 << 16) == px4_custom_mode(4, 3)  # AUTO.LOITER
    assert hb.type == MavType.QUADROTOR and hb.system_status == MavState.STANDBY
    assert not hb.base_mode & MavModeFlag.SAFETY_ARMED
    ack, _ = driver.command(MavCommand.MISSION_START, 0, 0)
    assert ack.result == MavResult.ACCEPTED
    hb = driver.send(Heartbeat(type=MavType.GCS, autopilot=8))[0]
    assert isinstance(hb, Heartbeat)
    assert hb.custom_mode == (4 << 24) | (4 << 16)  # AUTO.MISSION
    assert hb.base_mode & MavModeFlag.SAFETY_ARMED and hb.system_status == MavState.ACTIVE


def test_px4_mission_start_without_a_mission_is_denied_in_px4s_words() -> None:
    driver = Driver(SimConfig(autopilot=PX4))
    ack, texts = driver.command(MavCommand.MISSION_START, 0, 0)
    assert ack.result == MavResult.DENIED
    assert texts == ["Mission start denied! No valid mission"]
    assert not driver.vehicle.armed


def test_px4_refuses_mission_mode_without_a_mission() -> None:
    driver = Driver(SimConfig(autopilot=PX4))
    ack, texts = driver.command(MavCommand.DO_SET_MODE, *PX4_MISSION)
    assert ack.result == MavResult.TEMPORARILY_REJECTED
    assert texts == ["Switching to Mission is currently not available"]


def test_px4_refuses_to_arm_without_a_mission_when_com_arm_mis_req_says_so() -> None:
    driver = Driver(SimConfig(autopilot=PX4, params={"COM_ARM_MIS_REQ": 1}))
    ack, texts = driver.command(MavCommand.COMPONENT_ARM_DISARM, 1)
    assert ack.result == MavResult.TEMPORARILY_REJECTED
    assert texts == ["Arming denied: Resolve system health failures first"]
    assert not driver.vehicle.armed
    # the default arms without a mission
    driver = Driver(SimConfig(autopilot=PX4))
    ack, _ = driver.command(MavCommand.COMPONENT_ARM_DISARM, 1)
    assert ack.result == MavResult.ACCEPTED and driver.vehicle.armed


def test_ardupilot_refuses_to_arm_in_auto_in_its_words() -> None:
    driver = with_mission(AP)
    ack, _ = driver.command(MavCommand.DO_SET_MODE, 1, 3)  # AUTO, disarmed: allowed
    assert ack.result == MavResult.ACCEPTED
    ack, texts = driver.command(MavCommand.COMPONENT_ARM_DISARM, 1)
    assert ack.result == MavResult.FAILED
    assert texts == ["Arm: AUTO mode not armable"]
    assert not driver.vehicle.armed


def test_ardupilot_refuses_auto_from_the_ground_without_a_take_off_in_its_words() -> None:
    plan = synthetic_mission(5, seed=8, autopilot=AP)
    driver = with_mission(AP, replace(plan, items=plan.items[1:]))  # no NAV_TAKEOFF
    assert driver.command(MavCommand.DO_SET_MODE, 1, 4)[0].result == MavResult.ACCEPTED  # GUIDED
    assert driver.command(MavCommand.COMPONENT_ARM_DISARM, 1)[0].result == MavResult.ACCEPTED
    ack, texts = driver.command(MavCommand.DO_SET_MODE, 1, 3)
    assert ack.result == MavResult.FAILED
    assert texts == ["Auto: Missing Takeoff Cmd", "Mode change to AUTO failed: init failed"]
    ack, texts = driver.command(MavCommand.MISSION_START, 0, 0)
    assert ack.result == MavResult.FAILED and texts[0] == "Auto: Missing Takeoff Cmd"
    assert driver.vehicle.mode.name == "GUIDED"


def test_ardupilot_armed_in_auto_on_the_ground_waits_for_mission_start() -> None:
    # no pilot raises the throttle, so ap.auto_armed stays false until MISSION_START
    driver = with_mission(AP)
    assert driver.command(MavCommand.DO_SET_MODE, 1, 4)[0].result == MavResult.ACCEPTED  # GUIDED
    assert driver.command(MavCommand.COMPONENT_ARM_DISARM, 1)[0].result == MavResult.ACCEPTED
    assert driver.command(MavCommand.DO_SET_MODE, 1, 3)[0].result == MavResult.ACCEPTED  # AUTO
    driver.run(5.0)
    assert driver.vehicle.armed and driver.vehicle.flight.landed
    assert driver.vehicle.flight.position[2] == 0.0
    assert driver.command(MavCommand.MISSION_START, 0, 0)[0].result == MavResult.ACCEPTED
    driver.run(3.0)
    assert not driver.vehicle.flight.landed and driver.vehicle.flight.position[2] > 1.0


def test_ardupilot_mission_start_needs_param1_and_param2_zero() -> None:
    driver = with_mission(AP)
    for first, last in ((1, 0), (0, 3)):
        ack, texts = driver.command(MavCommand.MISSION_START, first, last)
        assert ack.result == MavResult.DENIED and texts == []
    assert driver.command(MavCommand.MISSION_START, 0, 0)[0].result == MavResult.ACCEPTED
    assert driver.vehicle.mode.name == "AUTO"


def test_ardupilot_names_a_mode_it_does_not_have() -> None:
    driver = Driver(SimConfig(autopilot=AP))
    ack, texts = driver.command(MavCommand.DO_SET_MODE, 1, 42)
    assert ack.result == MavResult.FAILED
    assert texts == ["No such mode 42"]


def test_set_mode_messages_are_acknowledged_as_each_firmware_does() -> None:
    driver = with_mission(AP)
    out = driver.send(SetMode(1, 1, 5))  # LOITER
    assert of_type(out, CommandAck)[0].command == 11  # ArduPilot: the message id
    assert driver.vehicle.mode.name == "LOITER"
    driver = with_mission(PX4)
    out = driver.send(SetMode(1, 1, px4_custom_mode(4, 4)))
    ack = of_type(out, CommandAck)[0]
    assert ack.command == MavCommand.DO_SET_MODE and ack.result == MavResult.ACCEPTED
    assert driver.vehicle.mode.name == "Mission"


def test_neither_firmware_disarms_in_the_air_without_force() -> None:
    for autopilot in (PX4, AP):
        driver = with_mission(autopilot, speedup=10)
        start(driver)
        driver.run_until(lambda d=driver: d.vehicle.flight.position[2] > 10.0, 60)
        ack, _ = driver.command(MavCommand.COMPONENT_ARM_DISARM, 0)
        assert ack.result in (MavResult.TEMPORARILY_REJECTED, MavResult.FAILED)
        assert driver.vehicle.armed
        ack, _ = driver.command(MavCommand.COMPONENT_ARM_DISARM, 0, 21196)
        assert ack.result == MavResult.ACCEPTED and not driver.vehicle.armed


# ---------------------------------------------------------------------------------------------
# Flying


@pytest.mark.parametrize("autopilot", [PX4, AP], ids=lambda a: a.label)
def test_a_mission_flown_by_the_vehicle_takes_as_long_as_simulate_says(
    autopilot: Autopilot,
) -> None:
    plan = synthetic_mission(6, seed=9, autopilot=autopilot)
    driver = with_mission(autopilot, plan, speedup=20)
    driver.run(0.3)
    start(driver)
    started = driver.vehicle.flight.t_s
    # steps of one flight step (0.1 s simulated at speedup 20)
    driver.run_until(lambda: not driver.vehicle.armed, limit_s=120, step=0.005)
    flown = driver.vehicle.flight.t_s - started
    predicted = simulate(plan)
    disarm_delay = 2.0 if autopilot == PX4 else 0.0
    assert flown == pytest.approx(predicted.flight_time_s + disarm_delay, abs=0.25)
    # every item reported reached in order, the mission complete, on the ground
    reached = [m.seq for m in of_type(driver.heard, MissionItemReached)]
    assert reached == [seq for seq, _ in predicted.reached()]
    states = of_type(driver.heard, ExtendedSysState)
    assert {s.landed_state for s in states} >= {LandedState.IN_AIR, LandedState.ON_GROUND}
    assert driver.vehicle.landed_state == LandedState.ON_GROUND
    current = of_type(driver.heard, MissionCurrent)[-1]
    assert current.mission_state == MissionState.COMPLETE


def test_the_position_stream_follows_the_flight_in_degrees_and_millimetres() -> None:
    driver = with_mission(AP, speedup=20)
    start(driver)
    driver.run_until(lambda: driver.vehicle.flight.position[2] > 20.0, 30)
    driver.run(0.2)
    fix = of_type(driver.heard, GlobalPositionInt)[-1]
    *_, rel = driver.vehicle.position()
    assert fix.relative_alt == pytest.approx(rel * 1000.0, abs=2000)  # one stream period
    assert fix.alt - fix.relative_alt == round(HOME.alt_m * 1000.0)
    assert fix.lat == pytest.approx(HOME.lat_deg * 1e7, abs=2)  # still climbing over home
    home = of_type(driver.heard, HomePosition)[-1]
    assert (home.latitude, home.altitude) == (round(HOME.lat_deg * 1e7), round(HOME.alt_m * 1000))


def test_rtl_and_hold_commands_take_over_the_flight() -> None:
    driver = with_mission(PX4, speedup=20)
    start(driver)
    driver.run_until(lambda: len(of_type(driver.heard, MissionItemReached)) >= 3, 60)
    ack, _ = driver.command(MavCommand.DO_SET_MODE, *PX4_HOLD)
    assert ack.result == MavResult.ACCEPTED
    driver.run(1.0)
    x1, y1, _ = driver.vehicle.flight.position
    driver.run(1.0)
    x2, y2, _ = driver.vehicle.flight.position
    assert math.hypot(x2 - x1, y2 - y1) < 0.01  # holding
    ack, _ = driver.command(MavCommand.NAV_RETURN_TO_LAUNCH)
    assert ack.result == MavResult.ACCEPTED and driver.vehicle.mode.name == "Return"
    driver.run_until(lambda: not driver.vehicle.armed, 120)
    x, y, z = driver.vehicle.flight.position
    assert math.hypot(x, y) < 0.5 and z == 0.0
    assert of_type(driver.heard, MissionCurrent)[-1].mission_state == MissionState.PAUSED


# ---------------------------------------------------------------------------------------------
# Telemetry


def test_set_message_interval_and_request_message_are_honoured() -> None:
    driver = Driver(SimConfig(autopilot=PX4))
    ack, _ = driver.command(MavCommand.SET_MESSAGE_INTERVAL, MessageId.GLOBAL_POSITION_INT, 50_000)
    assert ack.result == MavResult.ACCEPTED
    out = driver.run(2.0)
    assert len(of_type(out, GlobalPositionInt)) == pytest.approx(40, abs=2)  # 20 Hz
    ack, _ = driver.command(MavCommand.SET_MESSAGE_INTERVAL, MessageId.GLOBAL_POSITION_INT, -1)
    assert ack.result == MavResult.ACCEPTED and not of_type(driver.run(2.0), GlobalPositionInt)
    ack, _ = driver.command(MavCommand.SET_MESSAGE_INTERVAL, 9999, 100_000)
    assert ack.result == MavResult.FAILED  # not a message it streams
    out = driver.send(CommandLong(1, 1, MavCommand.REQUEST_MESSAGE, 0, MessageId.HOME_POSITION))
    assert of_type(out, CommandAck)[0].result == MavResult.ACCEPTED and of_type(out, HomePosition)
    out = driver.send(CommandLong(1, 1, MavCommand.REQUEST_MESSAGE, 0, 4242))
    assert of_type(out, CommandAck)[0].result == MavResult.UNSUPPORTED


def test_ardupilot_honours_request_data_stream() -> None:
    driver = Driver(SimConfig(autopilot=AP))
    driver.send(RequestDataStream(1, 1, 6, 10, 1))  # MAV_DATA_STREAM_POSITION at 10 Hz
    assert len(of_type(driver.run(2.0), GlobalPositionInt)) == pytest.approx(20, abs=2)
    driver.send(RequestDataStream(1, 1, 0, 0, 0))  # all streams off
    assert not of_type(driver.run(2.0), GlobalPositionInt | SysStatus | BatteryStatus)


def test_speedup_runs_flight_and_telemetry_that_many_times_faster() -> None:
    slow, fast = with_mission(AP), with_mission(AP, speedup=20)
    for driver in (slow, fast):
        start(driver)
        driver.run(1.0)
    assert fast.vehicle.flight.t_s == pytest.approx(20 * slow.vehicle.flight.t_s, rel=0.02)
    assert fast.vehicle.flight.position[2] > 10 * slow.vehicle.flight.position[2]
    fast_fixes = len(of_type(fast.heard, GlobalPositionInt))
    assert fast_fixes == pytest.approx(20 * len(of_type(slow.heard, GlobalPositionInt)), rel=0.1)


def test_a_vehicle_that_looks_late_slows_down_instead_of_sending_a_burst() -> None:
    # its thread starved for 1 s of link time at speedup 100: catching up would put 100 s of
    # flight (500 positions) on the wire at once, more than a ground station's UDP buffer
    # holds (tracks with minutes missing, seen at load 5); it advances MAX_CATCH_UP_S instead
    driver = with_mission(AP, speedup=100)
    start(driver)
    driver.run(0.05)
    before = driver.vehicle.sim_time_s
    burst = driver.run(1.0, step=1.0)
    assert driver.vehicle.sim_time_s - before == pytest.approx(MAX_CATCH_UP_S)
    assert 1 <= len(of_type(burst, GlobalPositionInt)) <= MAX_CATCH_UP_S / 0.2 + 1
    driver.run(0.1, step=0.01)  # looking in time again, it runs at its speedup
    assert driver.vehicle.sim_time_s - before == pytest.approx(MAX_CATCH_UP_S + 10.0)


def test_the_battery_drains_in_flight_and_reports_it() -> None:
    driver = with_mission(PX4, speedup=20)
    driver.run(1.5)
    before = of_type(driver.heard, SysStatus)[-1]
    assert before.battery_remaining == 100
    start(driver)
    driver.run(5.0)  # 100 s of flight
    after = of_type(driver.heard, SysStatus)[-1]
    battery = of_type(driver.heard, BatteryStatus)[-1]
    assert after.battery_remaining < before.battery_remaining
    assert after.voltage_battery < before.voltage_battery
    assert after.current_battery > 1000  # cA: over 10 A in hover
    assert battery.current_consumed > 0 and battery.voltages[:4] == (battery.voltages[0],) * 4


# ---------------------------------------------------------------------------------------------
# Parameters


def test_param_request_list_lists_the_flavours_table() -> None:
    for autopilot in (PX4, AP):
        driver = Driver(SimConfig(autopilot=autopilot))
        values = of_type(driver.send(ParamRequestList(1, 1)), ParamValue)
        count = len(driver.vehicle.params.specs)
        assert [v.param_index for v in values] == list(range(count))
        assert {v.param_count for v in values} == {count}


def test_param_set_changes_the_speed_flown() -> None:
    # no DO_CHANGE_SPEED in the mission, so WPNAV_SPEED is the speed flown
    plan = synthetic_mission(5, seed=7, autopilot=AP, speed_m_s=None)
    driver = with_mission(AP, plan, speedup=20)
    out = driver.send(ParamSet(1, 1, "WPNAV_SPEED", 500.0, 9))
    (value,) = of_type(out, ParamValue)
    assert (value.param_id, value.param_value) == ("WPNAV_SPEED", 500.0)
    start(driver)
    driver.run(6.0)
    fastest = max(math.hypot(f.vx, f.vy) for f in of_type(driver.heard, GlobalPositionInt))
    assert fastest == pytest.approx(500.0, abs=2)  # cm/s


def test_px4_sends_integer_parameters_bytewise() -> None:
    driver = Driver(SimConfig(autopilot=PX4))
    (value,) = of_type(driver.send(ParamRequestRead(1, 1, "RTL_CONE_ANG", -1)), ParamValue)
    assert struct.unpack("<i", struct.pack("<f", value.param_value))[0] == 45
    wire = struct.unpack("<f", struct.pack("<i", 25))[0]
    (value,) = of_type(driver.send(ParamSet(1, 1, "RTL_CONE_ANG", wire, 6)), ParamValue)
    assert driver.vehicle.params["RTL_CONE_ANG"] == 25.0
    # ArduPilot casts them
    driver = Driver(SimConfig(autopilot=AP))
    (value,) = of_type(driver.send(ParamRequestRead(1, 1, "RTL_ALT", -1)), ParamValue)
    assert value.param_value == 1500.0


def test_unknown_parameters_are_refused_as_each_firmware_does() -> None:
    px4 = Driver(SimConfig(autopilot=PX4))
    out = px4.send(ParamSet(1, 1, "NO_SUCH_PARAM", 1.0, 9))
    assert [(m.severity, m.text) for m in out] == [
        (Severity.INFO, "[pm] unknown param: NO_SUCH_PARAM")
    ]
    assert px4.send(ParamRequestRead(1, 1, "NO_SUCH_PARAM", -1)) == []
    out = px4.send(ParamRequestRead(1, 1, "", 999))
    assert [m.text for m in out] == ["[pm] unknown param ID: 999"]
    ardupilot = Driver(SimConfig(autopilot=AP))
    assert ardupilot.send(ParamSet(1, 1, "NO_SUCH_PARAM", 1.0, 9)) == []
    assert ardupilot.send(ParamRequestRead(1, 1, "NO_SUCH_PARAM", -1)) == []


# ---------------------------------------------------------------------------------------------
# Faults


def test_the_link_is_lost_in_flight_and_the_vehicle_flies_on() -> None:
    driver = with_mission(PX4, speedup=20, faults=Faults(link_lost_after_s=30.0))
    start(driver)
    driver.run(1.0)  # 20 s
    assert driver.run(0.5)  # still talking
    driver.run(2.0)  # past 30 s
    assert driver.vehicle.link_lost
    assert driver.run(1.0) == []
    assert driver.send(Heartbeat(type=MavType.GCS, autopilot=8)) == []
    driver.run_until(lambda: not driver.vehicle.armed, 120)  # it landed on its own
