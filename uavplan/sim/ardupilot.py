"""The simulated vehicle as ArduPilot Copter (ArduCopter, GCS_MAVLink, AP_Arming): the rules
of :class:`~uavplan.sim.vehicle.SimVehicle` where ArduPilot differs from PX4, each with the
source it comes from."""

from __future__ import annotations

import math

from uavplan.autopilot.params import ParamSpec
from uavplan.autopilot.simulate import start_refusal
from uavplan.mavlink.messages import (
    Capability,
    CommandAck,
    CommandInt,
    CommandLong,
    MavAutopilotId,
    MavResult,
    Message,
    MessageId,
    RequestDataStream,
    SetMode,
    Severity,
)
from uavplan.mavlink.modes import FlightMode, ModeKind, ardupilot_mode, mode_named
from uavplan.mission.items import Autopilot, MissionType
from uavplan.sim.vehicle import SimVehicle

__all__ = ["ArduPilotVehicle"]

#: ArduPilot's REQUEST_DATA_STREAM groups → the streamed messages the simulation has
DATA_STREAMS: dict[int, tuple[int, ...]] = {
    2: (MessageId.SYS_STATUS, MessageId.MISSION_CURRENT, MessageId.EXTENDED_SYS_STATE),
    6: (MessageId.GLOBAL_POSITION_INT,),
    12: (MessageId.BATTERY_STATUS,),
}
#: ModeAuto::init refused (ArduCopter/mode.cpp set_mode)
_AUTO_FAILED = "Mode change to AUTO failed: init failed"


class ArduPilotVehicle(SimVehicle):
    """ArduPilot Copter: mission seq 0 is home, AUTO is not armable and waits on the ground
    for MISSION_START (no pilot raises the throttle), a failing pre-arm check is repeated,
    REQUEST_DATA_STREAM sets the streams."""

    FIRST_SEQ = 1
    DISARM_IN_AIR_REFUSED = MavResult.FAILED
    BAD_ARM_PARAM = MavResult.UNSUPPORTED
    PREARM_PREFIX = "PreArm: "
    REPEATS_PREARM = True
    MAV_AUTOPILOT = MavAutopilotId.ARDUPILOTMEGA
    PARAM_ENCODING = Capability.PARAM_ENCODE_C_CAST
    FLIGHT_SW_VERSION = (4 << 24) | (5 << 16) | (0 << 8) | 255  # v4.5.0 official

    def _initial_mode(self) -> FlightMode:
        return mode_named(Autopilot.ARDUPILOT, ModeKind.MANUAL)

    def _on_mission_done(self) -> None:
        pass  # AUTO stays AUTO: the copter holds at the last item

    def _on_landed(self) -> None:
        self._disarm()  # ArduPilot disarms once the landing is complete

    def _mission_valid(self) -> bool:
        """``mission.present()``: an item besides home."""
        return len(self.server.items(MissionType.MISSION)) > 1

    def _arm_refused(self, out: list[Message], *, forced: bool) -> MavResult | None:
        if forced:
            return None
        if self.faults.prearm_failure is not None:
            # a failing pre-arm check: reported, and FAILED (AP_Arming::arm, GCS_Common.cpp)
            out.extend(self._prearm_report())
            return MavResult.FAILED
        # ArduCopter/AP_Arming_Copter.cpp arm_checks: "%s mode not armable" prefixed "Arm: "
        # by AP_Arming::check_failed; GCS_Common.cpp answers MAV_RESULT_FAILED
        not_armable = self.mode.kind in (ModeKind.MISSION, ModeKind.RETURN, ModeKind.LAND)
        if not_armable or self.mode.name == "BRAKE":
            out.append(self._say(Severity.CRITICAL, f"Arm: {self.mode.name} mode not armable"))
            return MavResult.FAILED
        return None

    def _switch_to(self, mode: FlightMode, out: list[Message]) -> MavResult:
        if mode.kind is ModeKind.MISSION and self.armed:
            # ArduCopter/mode_auto.cpp ModeAuto::init (checks only when armed: set_mode's
            # ignore_checks = !armed): no mission, or on the ground without a take-off first
            if not self._mission_valid():
                out.append(self._say(Severity.WARNING, _AUTO_FAILED))
                return MavResult.FAILED
            if self.flight.landed:
                items = self.server.items(MissionType.MISSION)
                refusal = start_refusal(items, Autopilot.ARDUPILOT)
                if refusal is not None:
                    out.append(self._say(Severity.CRITICAL, refusal.firmware_text))
                    out.append(self._say(Severity.WARNING, _AUTO_FAILED))
                    return MavResult.FAILED
        self._enter(mode)
        return MavResult.ACCEPTED

    def _waits_for_mission_start(self) -> bool:
        # ArduCopter: AUTO on the ground runs the take-off only once ap.auto_armed
        # (Copter::update_auto_armed sets it when the pilot raises the throttle, and
        # MISSION_START sets it); with no pilot here, it waits for MISSION_START
        return self.flight.landed and not self._auto_armed

    def _do_set_mode(
        self, base_mode: float, custom: float, sub: float, out: list[Message]
    ) -> MavResult:
        main = self._custom_mode(base_mode, custom)
        if main is None:
            return MavResult.FAILED
        mode = ardupilot_mode(main)
        if mode is None:
            # AP_Vehicle::notify_no_such_mode (libraries/AP_Vehicle/AP_Vehicle.cpp)
            out.append(self._say(Severity.WARNING, f"No such mode {main}"))
            return MavResult.FAILED
        return self._switch_to(mode, out)

    def _on_set_mode_message(self, partner: tuple[int, int], msg: SetMode) -> list[Message]:
        """ArduPilot acknowledges SET_MODE with a COMMAND_ACK whose command is the message id
        11 (GCS_Common.cpp handle_set_mode)."""
        out: list[Message] = []
        result = self._do_set_mode(msg.base_mode, msg.custom_mode, 0.0, out)
        return [*out, CommandAck(11, int(result), partner[0], partner[1])]

    def _mission_start(self, first: float, last: float, out: list[Message]) -> MavResult:
        # ArduCopter/GCS_MAVLink_Copter.cpp handle_MAV_CMD_MISSION_START: "first-item/
        # last item not supported" → DENIED; then set_mode(AUTO) or FAILED
        if first != 0.0 or last != 0.0:
            return MavResult.DENIED
        result = self._switch_to(mode_named(Autopilot.ARDUPILOT, ModeKind.MISSION), out)
        if result == MavResult.ACCEPTED and self.armed:
            self._auto_armed = True  # copter.set_auto_armed(true)
            if not self._mission_active:
                self._start_mission()
        return result

    def _takeoff_command(self, cmd: CommandLong | CommandInt, out: list[Message]) -> MavResult:
        """ArduPilot takes off to param7 in GUIDED, armed, on the ground."""
        altitude = cmd.param7 if isinstance(cmd, CommandLong) else cmd.z
        if self.mode.kind is not ModeKind.GUIDED or not self.armed or not self.flight.landed:
            return MavResult.FAILED
        if not (math.isfinite(altitude) and altitude > 0):
            return MavResult.DENIED
        self._auto_armed = True  # Copter::start_takeoff sets it
        self.flight.takeoff(altitude)
        return MavResult.ACCEPTED

    def _param_write_denied(self, spec: ParamSpec) -> list[Message]:
        # GCS_Param.cpp handle_param_set says so, and sends the value it keeps
        return [self._say(Severity.WARNING, f"Param write denied ({spec.name})")]

    def _on_data_stream(self, msg: RequestDataStream) -> list[Message]:
        """REQUEST_DATA_STREAM (GCS_Common.cpp handle_request_data_stream)."""
        groups = list(DATA_STREAMS) if msg.req_stream_id == 0 else [msg.req_stream_id]
        for group in groups:
            for message_id in DATA_STREAMS.get(group, ()):
                stream = self._streams[message_id]
                if msg.start_stop == 0 or msg.req_message_rate <= 0:
                    stream.interval_s = None
                else:
                    stream.interval_s = 1.0 / msg.req_message_rate
                    stream.next_due_s = self.sim_time_s
        return []

    def _mission_total(self, count: int) -> int:
        return max(0, count - 1)  # home, seq 0, is not a mission item
