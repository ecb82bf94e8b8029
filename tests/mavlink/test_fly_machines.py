"""The flight machines without I/O: scripted messages and a fake clock.

- a command is re-sent with a growing ``confirmation`` until its COMMAND_ACK comes, then
  confirmed by the HEARTBEAT; a refusal keeps the STATUSTEXT that explains it (also one that
  trails the ACK), and a command that is accepted but never takes effect is reported so;
- an arm the vehicle TEMPORARILY_REJECTED is asked again (a new try) until ``busy_s``, then
  reported with every reason it gave; other commands are not asked again;
- the start sequences are QGroundControl's (PX4: Mission mode, arm; ArduPilot: GUIDED, arm,
  MISSION_START with param1 = param2 = 0);
- the pre-flight machine re-asks what is missing and reports the pre-arm bit and texts;
- the monitor ends when the mission is complete and the vehicle is down, and on silence.
"""

from __future__ import annotations

import pytest

from uavplan.mavlink.flightmachines import (
    CommandSequence,
    FlightTimeouts,
    MonitorEnd,
    MonitorMachine,
    NoticeKind,
    Preflight,
    PreflightMachine,
    VehicleState,
    WatchRules,
    arm_step,
    mode_steps,
    start_steps,
)
from uavplan.mavlink.messages import (
    SYS_STATUS_PREARM_CHECK,
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
    MissionCurrent,
    MissionItemReached,
    MissionState,
    StatusText,
    SysStatus,
)
from uavplan.mavlink.modes import ModeKind, mode_named
from uavplan.mission.items import Autopilot

AP, PX4 = Autopilot.ARDUPILOT, Autopilot.PX4
T = FlightTimeouts(ack_s=1.0, retries=2, confirm_s=2.0, text_grace_s=0.2, link_s=3.0)
TARGET = (1, 1)


def heartbeat(autopilot: Autopilot, kind: ModeKind, armed: bool) -> Heartbeat:
    mode = mode_named(autopilot, kind)
    base = MavModeFlag.CUSTOM_MODE_ENABLED | (MavModeFlag.SAFETY_ARMED if armed else 0)
    return Heartbeat(type=2, autopilot=12 if autopilot == PX4 else 3, base_mode=int(base),
                     custom_mode=mode.custom_mode)  # fmt: skip


def test_the_start_sequences_are_qgroundcontrols() -> None:
    px4 = start_steps(PX4)
    assert [s.command for s in px4] == [MavCommand.DO_SET_MODE, MavCommand.COMPONENT_ARM_DISARM]
    assert px4[0].params[1:3] == (4.0, 4.0)  # AUTO (main 4), MISSION (sub 4)
    ap = start_steps(AP)
    assert [s.command for s in ap] == [
        MavCommand.DO_SET_MODE,
        MavCommand.COMPONENT_ARM_DISARM,
        MavCommand.MISSION_START,
    ]
    assert ap[0].params[1] == 4.0  # GUIDED
    assert ap[2].params[:2] == (0.0, 0.0)
    # BRAKE: LOITER follows the throttle stick and, with none (SITL), lands (issue 32)
    assert mode_steps(AP, ModeKind.HOLD)[0].params[1] == 17.0  # BRAKE
    assert mode_steps(PX4, ModeKind.HOLD)[0].params[1:3] == (4.0, 3.0)  # AUTO.LOITER (Hold)


def test_a_command_is_resent_with_a_growing_confirmation_then_confirmed() -> None:
    state = VehicleState(PX4)
    machine = CommandSequence(state, TARGET, T, [arm_step()])
    (first,) = machine.start(0.0)
    assert isinstance(first, CommandLong) and first.confirmation == 0 and first.param1 == 1.0
    (again,) = machine.on_timeout(1.0)
    assert isinstance(again, CommandLong) and again.confirmation == 1
    assert machine.on_message(CommandAck(400, MavResult.ACCEPTED), 1.1) == []
    assert machine.finished is None  # accepted, not yet seen armed
    machine.on_message(heartbeat(PX4, ModeKind.HOLD, armed=True), 1.5)
    assert machine.finished is not None and machine.finished.ok  # type: ignore[attr-defined]


def test_a_command_without_an_answer_fails_after_its_retries() -> None:
    machine = CommandSequence(VehicleState(PX4), TARGET, T, [arm_step()])
    machine.start(0.0)
    sent = [machine.on_timeout(t) for t in (1.0, 2.0, 3.0)]
    assert [len(s) for s in sent] == [1, 1, 0]
    outcome = machine.finished
    assert outcome is not None and not outcome.ok  # type: ignore[attr-defined]
    assert "no COMMAND_ACK after 3 tries" in outcome.message  # type: ignore[attr-defined]


def test_a_refusal_quotes_the_text_that_trails_its_ack() -> None:
    state = VehicleState(AP)
    machine = CommandSequence(state, TARGET, T, start_steps(AP))
    machine.start(0.0)
    machine.on_message(CommandAck(176, MavResult.ACCEPTED), 0.1)
    out = machine.on_message(heartbeat(AP, ModeKind.GUIDED, armed=False), 0.2)
    assert isinstance(out[0], CommandLong) and out[0].command == 400
    machine.on_message(CommandAck(400, MavResult.ACCEPTED), 0.3)
    out = machine.on_message(heartbeat(AP, ModeKind.GUIDED, armed=True), 0.4)
    assert out[0].command == MavCommand.MISSION_START  # type: ignore[union-attr]
    machine.on_message(CommandAck(300, MavResult.FAILED), 0.5)
    machine.on_message(StatusText(2, "Auto: Missing Takeoff Cmd"), 0.55)  # after the ACK
    assert machine.finished is None
    machine.on_timeout(0.7)
    outcome = machine.finished
    assert outcome is not None and not outcome.ok  # type: ignore[attr-defined]
    text = outcome.message  # type: ignore[attr-defined]
    assert '"Auto: Missing Takeoff Cmd"' in text and "MAV_RESULT_FAILED" in text
    assert "MISSION_START" in text


BUSY = FlightTimeouts(ack_s=1.0, retries=2, confirm_s=2.0, text_grace_s=0.2, busy_s=3.0)


def test_an_arm_temporarily_rejected_is_asked_again_and_goes_on_once_accepted() -> None:
    state = VehicleState(PX4)
    machine = CommandSequence(state, TARGET, BUSY, [arm_step()])
    machine.start(0.0)
    machine.on_message(StatusText(2, "Preflight Fail: vertical velocity unstable"), 0.05)
    assert machine.on_message(CommandAck(400, MavResult.TEMPORARILY_REJECTED), 0.1) == []
    assert machine.finished is None and machine.deadline == pytest.approx(1.1)
    # a late copy of the refusal while waiting changes nothing
    assert machine.on_message(CommandAck(400, MavResult.TEMPORARILY_REJECTED), 0.5) == []
    (again,) = machine.on_timeout(1.1)
    assert isinstance(again, CommandLong) and again.command == 400 and again.confirmation == 0
    machine.on_message(CommandAck(400, MavResult.ACCEPTED), 1.2)
    machine.on_message(heartbeat(PX4, ModeKind.MISSION, armed=True), 1.4)
    assert machine.finished is not None and machine.finished.ok  # type: ignore[attr-defined]


def test_an_arm_refused_for_longer_than_busy_s_is_reported_with_its_reasons() -> None:
    state = VehicleState(PX4)
    machine = CommandSequence(state, TARGET, BUSY, [arm_step()])
    machine.start(0.0)
    sent = 1
    now = 0.0
    while machine.finished is None and now < 10.0:
        machine.on_message(StatusText(2, "Preflight Fail: High Accelerometer Bias"), now + 0.05)
        machine.on_message(CommandAck(400, MavResult.TEMPORARILY_REJECTED), now + 0.1)
        now = machine.deadline
        sent += len(machine.on_timeout(now))
    outcome = machine.finished
    assert outcome is not None and not outcome.ok  # type: ignore[attr-defined]
    assert sent == 3  # at 0, 1.1 and 2.2 s; a fourth try would come after busy_s
    text = outcome.message  # type: ignore[attr-defined]
    assert "asked 3 times over 2.5 s" in text and "MAV_RESULT_TEMPORARILY_REJECTED" in text
    assert text.count("High Accelerometer Bias") == 1  # said three times, quoted once


def test_a_mode_change_temporarily_rejected_is_reported_at_once() -> None:
    machine = CommandSequence(VehicleState(PX4), TARGET, BUSY, start_steps(PX4))
    machine.start(0.0)
    machine.on_message(CommandAck(176, MavResult.TEMPORARILY_REJECTED), 0.1)
    machine.on_timeout(0.3)
    outcome = machine.finished
    assert outcome is not None and not outcome.ok  # type: ignore[attr-defined]
    assert "asked" not in outcome.message  # type: ignore[attr-defined]


def test_an_accepted_command_that_never_shows_is_reported() -> None:
    state = VehicleState(PX4)
    machine = CommandSequence(state, TARGET, T, mode_steps(PX4, ModeKind.HOLD))
    machine.start(0.0)
    machine.on_message(CommandAck(176, MavResult.ACCEPTED), 0.1)
    machine.on_message(heartbeat(PX4, ModeKind.MISSION, armed=True), 1.0)
    machine.on_timeout(2.2)
    outcome = machine.finished
    assert outcome is not None and not outcome.ok  # type: ignore[attr-defined]
    assert "still reports Mission, armed (expected mode Hold)" in outcome.message  # type: ignore[attr-defined]


def test_preflight_reasks_what_is_missing_and_reports_the_prearm_bit() -> None:
    state = VehicleState(AP)
    machine = PreflightMachine(state, TARGET, FlightTimeouts(preflight_s=3.0, text_grace_s=0.2))
    first = machine.start(0.0)
    assert {m.param1 for m in first if m.command == MavCommand.REQUEST_MESSAGE} == {242, 1, 245}  # type: ignore[union-attr]
    assert any(m.command == MavCommand.RUN_PREARM_CHECKS for m in first)  # type: ignore[union-attr]
    machine.on_message(HomePosition(473977420, 85455940, 488000), 0.1)
    again = machine.on_timeout(1.0)  # SYS_STATUS and the checks' answer are missing
    assert {m.param1 for m in again if m.command == MavCommand.REQUEST_MESSAGE} == {1, 245}  # type: ignore[union-attr]
    sensors = 0x2F | SYS_STATUS_PREARM_CHECK
    machine.on_message(SysStatus(sensors, sensors, 0x2F, 0, 16000, 0, 90), 1.1)
    machine.on_message(CommandAck(401, MavResult.ACCEPTED), 1.2)
    machine.on_message(StatusText(2, "PreArm: Need Position Estimate"), 1.25)
    machine.on_timeout(1.5)
    result = machine.finished
    assert isinstance(result, Preflight)
    assert result.home == pytest.approx((47.397742, 8.545594, 488.0))
    assert result.prearm_ready is False
    assert result.texts == ("PreArm: Need Position Estimate",)


def _position(t_s: float, alt_m: float) -> GlobalPositionInt:
    return GlobalPositionInt(int(t_s * 1000), 473977420, 85455940, int((488 + alt_m) * 1000),
                             int(alt_m * 1000))  # fmt: skip


def test_the_monitor_ends_when_the_mission_is_complete_and_the_vehicle_down() -> None:
    state = VehicleState(PX4)
    machine = MonitorMachine(state, TARGET, T, last_seq=5, lands=True)
    streams = machine.start(0.0)
    assert {m.param1 for m in streams} >= {33.0, 42.0, 245.0}  # type: ignore[union-attr]
    state.recording = True
    machine.on_message(heartbeat(PX4, ModeKind.MISSION, armed=True), 0.1)
    machine.on_message(ExtendedSysState(0, LandedState.IN_AIR), 0.2)
    machine.on_message(_position(10.0, 30.0), 0.3)
    machine.on_message(MissionItemReached(5), 0.4)
    machine.on_message(heartbeat(PX4, ModeKind.RETURN, armed=True), 0.5)
    assert machine.finished is None  # the mission's last item, but still flying home
    machine.on_message(ExtendedSysState(0, LandedState.ON_GROUND), 0.6)
    assert machine.finished is None  # down: it waits for the report of where it came down
    machine.on_message(_position(11.0, 0.0), 0.7)
    assert machine.finished is MonitorEnd.COMPLETE
    assert [s.relative_alt_m for s in state.take_samples()] == [30.0, 0.0]


def test_a_vehicle_down_on_the_last_item_of_a_landing_mission_has_completed_it() -> None:
    """ArduPilot disarms on touchdown at the final NAV_LAND; its word that the mission is
    complete may come after the disarm: that is the end of the mission, not an early
    landing. Down on an earlier item still is one."""
    for current, end in ((9, MonitorEnd.COMPLETE), (8, MonitorEnd.LANDED_EARLY)):
        state = VehicleState(AP)
        machine = MonitorMachine(state, TARGET, T, last_seq=9, lands=True)
        machine.start(0.0)
        state.recording = True
        machine.on_message(heartbeat(AP, ModeKind.MISSION, armed=True), 0.1)
        machine.on_message(ExtendedSysState(0, LandedState.IN_AIR), 0.2)
        machine.on_message(_position(10.0, 30.0), 0.3)
        machine.on_message(MissionCurrent(current, 10, MissionState.ACTIVE), 0.4)
        machine.on_message(heartbeat(AP, ModeKind.MISSION, armed=False), 0.5)
        machine.on_message(heartbeat(AP, ModeKind.MISSION, armed=False), 0.55)
        # where it disarmed is asked for again; the answers come
        machine.on_message(ExtendedSysState(0, LandedState.ON_GROUND), 0.56)
        machine.on_message(MissionCurrent(current, 10, MissionState.ACTIVE), 0.57)
        machine.on_message(_position(11.0, 0.0), 0.6)
        assert machine.finished is end


def test_the_first_item_ardupilot_sets_on_its_disarm_is_no_early_landing() -> None:
    """ArduPilot SITL (issue 32's hairpin flight, under load): the vehicle landed on the last
    item (the final NAV_LAND) and disarmed, and its MISSION_CURRENT back at item 1 (it resets
    the mission on disarm) came before the heartbeats that said it disarmed: fly said "landed
    and disarmed before the mission was complete ... at mission item 1/57". The furthest item
    it flew to while armed decides. A vehicle that never got that far still landed early."""
    for furthest, end in ((9, MonitorEnd.COMPLETE), (8, MonitorEnd.LANDED_EARLY)):
        state = VehicleState(AP)
        machine = MonitorMachine(state, TARGET, T, last_seq=9, lands=True)
        machine.start(0.0)
        state.recording = True
        machine.on_message(heartbeat(AP, ModeKind.MISSION, armed=True), 0.1)
        machine.on_message(ExtendedSysState(0, LandedState.IN_AIR), 0.2)
        machine.on_message(_position(10.0, 30.0), 0.3)
        machine.on_message(MissionCurrent(furthest, 10, MissionState.ACTIVE), 0.4)
        machine.on_message(_position(20.0, 0.5), 0.45)
        machine.on_message(MissionCurrent(1, 10, MissionState.ACTIVE), 0.5)  # reset, first
        machine.on_message(heartbeat(AP, ModeKind.MISSION, armed=False), 0.55)
        machine.on_message(heartbeat(AP, ModeKind.MISSION, armed=False), 0.6)
        machine.on_message(ExtendedSysState(0, LandedState.ON_GROUND), 0.61)
        machine.on_message(MissionCurrent(1, 10, MissionState.ACTIVE), 0.62)
        machine.on_message(_position(21.0, 0.0), 0.65)
        assert machine.finished is end, (furthest, machine.finished)


def test_the_monitor_reports_silence_as_a_lost_link_and_an_early_landing() -> None:
    state = VehicleState(AP)
    machine = MonitorMachine(state, TARGET, T, last_seq=9, lands=True)
    machine.start(0.0)
    machine.on_message(heartbeat(AP, ModeKind.MISSION, armed=True), 1.0)
    assert machine.deadline == pytest.approx(3.0)  # quiet for WatchRules.quiet_s: said
    machine.on_timeout(3.0)
    assert machine.finished is None
    assert [n.kind for n in state.notices] == [NoticeKind.LINK_QUIET]
    assert machine.deadline == pytest.approx(4.0)
    machine.on_timeout(4.0)
    assert machine.finished is MonitorEnd.LINK_LOST
    early = MonitorMachine(VehicleState(AP, armed=True), TARGET, T, last_seq=9, lands=True)
    early.start(0.0)
    early.on_message(ExtendedSysState(0, LandedState.IN_AIR), 0.1)
    early.on_message(MissionCurrent(4, 9, MissionState.ACTIVE), 0.2)
    early.on_message(_position(5.0, 20.0), 0.25)
    early.on_message(heartbeat(AP, ModeKind.LAND, armed=False), 0.3)
    early.on_message(heartbeat(AP, ModeKind.LAND, armed=False), 0.4)
    assert early.finished is None  # where did it disarm? asked
    early.on_message(ExtendedSysState(0, LandedState.ON_GROUND), 0.5)
    early.on_message(_position(6.0, 0.0), 0.6)
    early.on_message(MissionCurrent(4, 9, MissionState.ACTIVE), 0.7)
    assert early.finished is MonitorEnd.LANDED_EARLY
    assert "disarmed, in LAND, at mission item 4/9" in early.state.describe()


# ---------------------------------------------------------------------------------------------
# Telemetry as it really arrives (issue 31)


def _recording(autopilot: Autopilot = AP) -> VehicleState:
    state = VehicleState(autopilot, armed=True)
    state.recording = True
    return state


def test_samples_are_taken_in_the_vehicles_time_order_duplicates_and_late_copies_dropped() -> None:
    state = _recording()
    for t in (1.0, 1.2, 1.2, 1.4, 1.1, 1.6, 1.4, 1.8):  # a duplicate, two late copies
        state.update(_position(t, 30.0), 0.0)
    assert [s.time_s for s in state.take_samples()] == [1.0, 1.2, 1.4, 1.6, 1.8]
    assert (state.duplicates, state.late) == (1, 2)
    assert state.restarts == [] and state.gaps == []


def test_a_clock_that_goes_back_and_stays_back_is_a_restart() -> None:
    state = _recording()
    for t in (100.0, 100.2, 100.4):
        state.update(_position(t, 30.0), 1.0)
    state.update(_position(3.0, 0.0), 2.0)
    state.update(_position(3.2, 0.0), 2.1)
    assert state.restarts == []  # two samples could be late copies of a delayed burst
    state.update(_position(3.4, 0.0), 2.2)
    (restart,) = state.restarts
    assert (restart.before_s, restart.after_s) == (100.4, 3.0)
    samples = state.take_samples()
    assert [(s.time_s, s.epoch) for s in samples] == [
        (100.0, 0), (100.2, 0), (100.4, 0), (3.0, 1), (3.2, 1), (3.4, 1)
    ]  # fmt: skip


def test_a_stretch_without_positions_is_a_gap() -> None:
    state = _recording()
    for t in (10.0, 10.2, 10.4, 12.4, 16.0, 16.2):  # 2.0 s is still observed, 3.6 s is not
        state.update(_position(t, 30.0), 0.0)
    assert state.gaps == [(12.4, 16.0)]


def _flying(autopilot: Autopilot = AP, **kw: object) -> tuple[VehicleState, MonitorMachine]:
    state = VehicleState(autopilot, armed=True)
    machine = MonitorMachine(state, TARGET, T, last_seq=9, lands=True, return_seq=9, **kw)  # type: ignore[arg-type]
    machine.start(0.0)
    state.recording = True
    machine.on_message(heartbeat(autopilot, ModeKind.MISSION, armed=True), 0.01)
    machine.on_message(ExtendedSysState(0, LandedState.IN_AIR), 0.02)
    machine.on_message(MissionCurrent(4, 9, MissionState.ACTIVE), 0.03)
    machine.on_message(_position(50.0, 30.0), 0.04)
    return state, machine


def test_a_mode_another_ground_station_commanded_is_said_at_once_and_ends_the_watch() -> None:
    from uavplan.mavlink.messages import Received

    state, machine = _flying(rules=WatchRules(takeover_wait_s=10.0))
    ack = CommandAck(MavCommand.DO_SET_MODE, MavResult.ACCEPTED, 255, 191)
    machine.on_overheard(Received(ack, 1, 1), 0.05)
    machine.on_message(heartbeat(AP, ModeKind.HOLD, armed=True), 0.06)
    assert not state.notices  # one heartbeat could be a late copy
    machine.on_message(heartbeat(AP, ModeKind.HOLD, armed=True), 0.07)
    (notice,) = state.notices
    assert notice.kind is NoticeKind.MODE_CHANGED and notice.takeover
    assert "BRAKE, commanded by another ground station (system 255, component 191)" in notice.text
    for k in range(1, 50):  # 9.8 s of the vehicle's time, holding
        machine.on_message(_position(50.0 + 0.2 * k, 30.0), 0.1 + k / 1000)
    assert machine.finished is None  # it waits the stated time for the mission to go on
    machine.on_message(_position(60.0, 30.0), 0.2)
    assert machine.finished is MonitorEnd.HELD


def test_an_acknowledgement_after_the_mode_change_still_names_the_other_station() -> None:
    """The other station's COMMAND_ACK can reach fly just after the heartbeats that show the
    mode (seen in CI under load): the change is said at once, and said again with its author
    when the acknowledgement comes."""
    from uavplan.mavlink.messages import Received

    state, machine = _flying(rules=WatchRules(takeover_wait_s=10.0))
    machine.on_message(heartbeat(AP, ModeKind.HOLD, armed=True), 0.06)
    machine.on_message(heartbeat(AP, ModeKind.HOLD, armed=True), 0.07)
    (first,) = state.notices
    assert "BRAKE, not commanded by this ground station" in first.text
    ack = CommandAck(MavCommand.DO_SET_MODE, MavResult.ACCEPTED, 255, 191)
    machine.on_overheard(Received(ack, 1, 1), 0.08)
    assert len(state.notices) == 2
    again = state.notices[1]
    assert again.kind is NoticeKind.MODE_CHANGED
    assert "BRAKE, commanded by another ground station (system 255, component 191)" in again.text
    machine.on_overheard(Received(ack, 1, 1), 0.09)  # a second copy says nothing more
    assert len(state.notices) == 2


def test_the_mission_resuming_in_time_goes_on() -> None:
    state, machine = _flying(rules=WatchRules(takeover_wait_s=10.0))
    for t in (0.1, 0.2):
        machine.on_message(heartbeat(AP, ModeKind.HOLD, armed=True), t)
    for t in (0.3, 0.4):
        machine.on_message(heartbeat(AP, ModeKind.MISSION, armed=True), t)
    machine.on_message(_position(51.0, 30.0), 0.5)
    assert machine.finished is None
    assert [n.kind for n in state.notices] == [NoticeKind.MODE_CHANGED, NoticeKind.MISSION_RESUMED]


def test_the_missions_own_return_is_no_change() -> None:
    state, machine = _flying()
    machine.on_message(MissionCurrent(9, 9, MissionState.ACTIVE), 0.1)
    for t in (0.2, 0.3):
        machine.on_message(heartbeat(AP, ModeKind.RETURN, armed=True), t)
    assert not state.notices


def test_a_new_mission_count_is_said_and_ends_the_watch_a_lone_late_copy_is_not() -> None:
    state, machine = _flying()
    machine.on_message(MissionCurrent(5, 4, MissionState.ACTIVE), 0.1)  # once: maybe stale
    machine.on_message(MissionCurrent(5, 9, MissionState.ACTIVE), 0.2)
    assert not state.notices
    machine.on_message(MissionCurrent(0, 6, MissionState.ACTIVE), 0.3)
    machine.on_message(MissionCurrent(0, 6, MissionState.ACTIVE), 0.4)
    assert [n.kind for n in state.notices] == [NoticeKind.MISSION_CHANGED]
    assert machine.finished is None  # the state is asked for again before the end
    machine.on_message(heartbeat(AP, ModeKind.MISSION, armed=True), 0.5)
    machine.on_message(ExtendedSysState(0, LandedState.IN_AIR), 0.6)
    machine.on_message(_position(51.0, 30.0), 0.7)
    assert machine.finished is MonitorEnd.MISSION_CHANGED


def test_a_home_that_moves_is_said() -> None:
    state, machine = _flying()
    machine.on_message(HomePosition(473977420, 85455940, 488000), 0.1)
    moved = HomePosition(473987420, 85455940, 488000)  # 111 m north
    machine.on_message(moved, 0.2)
    machine.on_message(moved, 0.3)
    (notice,) = state.notices
    assert notice.kind is NoticeKind.HOME_MOVED and "moved 111.2 m" in notice.text


def test_a_disarm_in_the_air_ends_the_watch_on_fresh_state() -> None:
    state, machine = _flying()
    for t in (0.1, 0.2):
        machine.on_message(heartbeat(AP, ModeKind.MISSION, armed=False), t)
    assert machine.finished is None
    machine.on_message(ExtendedSysState(0, LandedState.IN_AIR), 0.3)
    machine.on_message(MissionCurrent(4, 9, MissionState.ACTIVE), 0.35)
    machine.on_message(_position(51.0, 25.0), 0.4)
    assert machine.finished is MonitorEnd.DISARMED_IN_AIR
    assert state.notices[-1].kind is NoticeKind.DISARMED


def test_after_a_gap_the_ending_rests_on_state_asked_for_again() -> None:
    """Issue 31's stale verdict: the vehicle finished during a gap and landed; the first
    messages after it mix a new armed bit with the old item, position and landed state.
    The monitor asks again, and ends with what the answers say."""
    state, machine = _flying()
    out = machine.on_message(heartbeat(AP, ModeKind.MISSION, armed=False), 20.0)  # silence
    kinds = [n.kind for n in state.notices]
    assert kinds == [NoticeKind.LINK_BACK]
    asked = {m.param1 for m in out if m.command == MavCommand.REQUEST_MESSAGE}  # type: ignore[union-attr]
    assert asked >= {0.0, 42.0, 245.0, 33.0, 242.0}
    machine.on_message(heartbeat(AP, ModeKind.MISSION, armed=False), 20.1)
    assert machine.finished is None  # not "landed early at item 4, in the air"
    machine.on_message(ExtendedSysState(0, LandedState.ON_GROUND), 20.2)
    machine.on_message(MissionCurrent(9, 9, MissionState.COMPLETE), 20.3)
    assert machine.finished is None
    machine.on_message(_position(320.0, 0.0), 20.4)
    assert machine.finished is MonitorEnd.COMPLETE
    assert state.gaps == [(50.0, 320.0)]
    assert [n.kind for n in state.notices] == [NoticeKind.LINK_BACK, NoticeKind.GAP]


def test_a_restart_is_said_and_ends_the_watch_once_the_state_is_read_again() -> None:
    state, machine = _flying()
    machine.on_message(HomePosition(473977420, 85455940, 488000), 0.05)
    out: list = []
    for i, t in enumerate((2.0, 2.2, 2.4)):
        out += machine.on_message(_position(t, 0.0), 0.1 + i / 100)
    assert [n.kind for n in state.notices] == [NoticeKind.RESTART]
    commands = {m.command for m in out}  # type: ignore[union-attr]
    assert MavCommand.SET_MESSAGE_INTERVAL in commands  # the new boot forgot the streams
    assert machine.finished is None
    for message in (
        heartbeat(AP, ModeKind.MANUAL, armed=False),
        ExtendedSysState(0, LandedState.ON_GROUND),
        MissionCurrent(0, 0, MissionState.NO_MISSION),
        HomePosition(473977420, 85455940, 488000),
        _position(2.6, 0.0),
    ):
        machine.on_message(message, 0.2)
    assert machine.finished is MonitorEnd.RESTARTED


def test_silence_is_said_before_the_link_counts_as_lost() -> None:
    state, machine = _flying()
    assert machine.deadline == pytest.approx(0.04 + 2.0)
    machine.on_timeout(2.04)
    assert [n.kind for n in state.notices] == [NoticeKind.LINK_QUIET]
    assert "nothing heard from the vehicle for 2.0 s" in state.notices[0].text
    assert machine.finished is None


def test_a_gap_in_the_start_sequence_is_said_once_the_watch_begins() -> None:
    """Stop 43's CI: on a lossy link a gap fell while fly armed and started the mission
    (recording had begun), before the watch; the track held it and nothing said it."""
    state = VehicleState(AP, armed=True)
    state.recording = True
    state.update(_position(10.0, 0.0), 0.0)
    state.update(_position(13.5, 0.0), 0.1)  # 3.5 s without a position, on the ground
    assert state.gaps == [(10.0, 13.5)]
    machine = MonitorMachine(state, TARGET, T, last_seq=9, lands=True, return_seq=9)
    machine.start(0.2)
    out = machine.on_message(heartbeat(AP, ModeKind.MISSION, armed=True), 0.21)
    (notice,) = state.notices
    assert (
        notice.kind is NoticeKind.GAP
        and "no telemetry from 0 min 00 s to 0 min 04 s" in notice.text
    )
    assert not [m for m in out if getattr(m, "command", None) == MavCommand.REQUEST_MESSAGE]
    machine.on_message(_position(14.0, 0.0), 0.3)
    assert len(state.notices) == 1  # said once
