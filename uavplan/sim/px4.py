"""The simulated vehicle as PX4 (commander, navigator, mavlink_parameters): the rules of
:class:`~uavplan.sim.vehicle.SimVehicle` where PX4 differs from ArduPilot Copter, each with
the source it comes from."""

from __future__ import annotations

import math
import struct

from uavplan.autopilot.params import ParamSpec, ParamType
from uavplan.autopilot.simulate import start_refusal
from uavplan.mavlink.messages import (
    Capability,
    CommandAck,
    CommandInt,
    CommandLong,
    MavAutopilotId,
    MavCommand,
    MavResult,
    Message,
    SetMode,
    Severity,
)
from uavplan.mavlink.modes import FlightMode, ModeKind, mode_named, px4_mode
from uavplan.mission.items import Autopilot, MissionType
from uavplan.sim.vehicle import PX4_DISARM_AFTER_LANDING_S, SimConfig, SimVehicle, whole_number

__all__ = ["Px4Vehicle"]

#: "Arming denied: ..." (commander/Commander.cpp arm())
_ARMING_DENIED = "Arming denied: Resolve system health failures first"
#: the estimator check (EKF2 preflight checks) that flickers after start-up: Faults.arm_flickers
_FLICKER = "vertical velocity unstable"


class Px4Vehicle(SimVehicle):
    """PX4: MISSION_START arms and starts, Mission mode needs a valid mission, integers
    travel bytewise, the MAV_COMP_ID_MISSIONPLANNER component is answered as the
    autopilot."""

    FIRST_SEQ = 0
    DISARM_IN_AIR_REFUSED = MavResult.TEMPORARILY_REJECTED
    BAD_ARM_PARAM = MavResult.DENIED
    PREARM_PREFIX = "Preflight Fail: "
    REPEATS_PREARM = False
    ALSO_ANSWERS = frozenset({190})  # MAV_COMP_ID_MISSIONPLANNER: PX4 answers it as itself
    MAV_AUTOPILOT = MavAutopilotId.PX4
    PARAM_ENCODING = Capability.PARAM_ENCODE_BYTEWISE
    FLIGHT_SW_VERSION = (1 << 24) | (15 << 16) | (0 << 8) | 255  # v1.15.0 official

    def __init__(self, config: SimConfig | None = None, now: float = 0.0) -> None:
        super().__init__(config, now)
        self._arm_refusals = 0  # arm commands refused for Faults.arm_flickers

    def _initial_mode(self) -> FlightMode:
        return mode_named(Autopilot.PX4, ModeKind.HOLD)

    def _on_mission_done(self) -> None:
        if not self.flight.landed:
            self.mode = mode_named(Autopilot.PX4, ModeKind.HOLD)  # mission done: Hold

    def _on_landed(self) -> None:
        self._disarm_at_s = self.flight.t_s + PX4_DISARM_AFTER_LANDING_S

    def _mission_valid(self) -> bool:
        """A mission with a position item."""
        return start_refusal(self.server.items(MissionType.MISSION), Autopilot.PX4) is None

    def _arm_refused(self, out: list[Message], *, forced: bool) -> MavResult | None:
        if self.faults.prearm_failure is not None and not forced:
            # a failing pre-arm check: PX4 reports the health failure, then "Arming denied:
            # Resolve system health failures first", TEMPORARILY_REJECTED
            out.extend(self._prearm_report())
            out.append(self._say(Severity.CRITICAL, _ARMING_DENIED))
            return MavResult.TEMPORARILY_REJECTED
        if not forced and self._arm_refusals < self.faults.arm_flickers:
            self._arm_refusals += 1
            out.append(self._say(Severity.CRITICAL, self.PREARM_PREFIX + _FLICKER))
            out.append(self._say(Severity.CRITICAL, _ARMING_DENIED))
            return MavResult.TEMPORARILY_REJECTED
        # HealthAndArmingChecks: COM_ARM_MIS_REQ makes a valid mission an arming requirement,
        # and Return / Land prevent arming ("Mode not suitable for arming"); Commander::arm
        # reports "Arming denied: Resolve system health failures first" and the command is
        # TEMPORARILY_REJECTED
        needs_mission = self.params["COM_ARM_MIS_REQ"] >= 1 or self.mode.kind is ModeKind.MISSION
        unsuitable = self.mode.kind in (ModeKind.RETURN, ModeKind.LAND)
        if not forced and ((needs_mission and not self._mission_valid()) or unsuitable):
            out.append(self._say(Severity.CRITICAL, _ARMING_DENIED))
            return MavResult.TEMPORARILY_REJECTED
        return None

    def _switch_to(self, mode: FlightMode, out: list[Message]) -> MavResult:
        # Commander: a mode whose requirements fail is refused with
        # "Switching to %s is currently not available" (printRejectMode) and
        # TEMPORARILY_REJECTED; Mission mode requires a valid mission (ModeChecks)
        unavailable = mode.kind is ModeKind.OFFBOARD or (
            mode.kind is ModeKind.MISSION and not self._mission_valid()
        )
        if unavailable:
            out.append(
                self._say(Severity.CRITICAL, f"Switching to {mode.name} is currently not available")
            )
            return MavResult.TEMPORARILY_REJECTED
        self._enter(mode)
        return MavResult.ACCEPTED

    def _do_set_mode(
        self, base_mode: float, custom: float, sub: float, out: list[Message]
    ) -> MavResult:
        main = self._custom_mode(base_mode, custom)
        if main is None:
            return MavResult.DENIED
        mode = px4_mode(main, whole_number(sub) or 0)
        if mode is None:
            return MavResult.DENIED
        return self._switch_to(mode, out)

    def _on_set_mode_message(self, partner: tuple[int, int], msg: SetMode) -> list[Message]:
        """PX4 turns SET_MODE into MAV_CMD_DO_SET_MODE (main mode in bits 16-23, sub mode in
        24-31) and acknowledges that command."""
        out: list[Message] = []
        main = (msg.custom_mode >> 16) & 0xFF
        sub = (msg.custom_mode >> 24) & 0xFF
        result = self._do_set_mode(msg.base_mode, main, sub, out)
        command = int(MavCommand.DO_SET_MODE)
        return [*out, CommandAck(command, int(result), partner[0], partner[1])]

    def _mission_start(self, first: float, last: float, out: list[Message]) -> MavResult:
        # commander/Commander.cpp VEHICLE_CMD_MISSION_START: no valid mission → DENIED and
        # "Mission start denied! No valid mission"; a first item out of range → DENIED;
        # else Mission mode and arm, or TEMPORARILY_REJECTED
        if not self._mission_valid():
            out.append(self._say(Severity.CRITICAL, "Mission start denied! No valid mission"))
            return MavResult.DENIED
        count = len(self.server.wire_items(MissionType.MISSION))
        if not (math.isfinite(first) and -1 <= first < count):
            return MavResult.DENIED
        mission = mode_named(Autopilot.PX4, ModeKind.MISSION)
        if self._switch_to(mission, out) != MavResult.ACCEPTED:
            return MavResult.TEMPORARILY_REJECTED
        if not self.armed and self._arm(out) != MavResult.ACCEPTED:
            return MavResult.TEMPORARILY_REJECTED
        return MavResult.ACCEPTED

    def _takeoff_command(self, cmd: CommandLong | CommandInt, out: list[Message]) -> MavResult:
        """PX4 enters its Takeoff mode (to MIS_TAKEOFF_ALT) whatever the command's altitude."""
        return self._switch_to(mode_named(Autopilot.PX4, ModeKind.TAKEOFF), out)

    def _param_to_wire(self, spec: ParamSpec, value: float) -> float:
        if spec.type == ParamType.REAL32:
            return float(value)
        # PX4 sends integers bytewise (MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE)
        return float(struct.unpack("<f", struct.pack("<i", int(value)))[0])

    def _param_from_wire(self, spec: ParamSpec, wire: float) -> float:
        if spec.type == ParamType.REAL32:
            return float(wire)
        return float(struct.unpack("<i", struct.pack("<f", wire))[0])

    def _unknown_param_index(self, index: int) -> list[Message]:
        # mavlink_parameters.cpp: "[pm] unknown param ID: %u"
        return [self._say(Severity.INFO, f"[pm] unknown param ID: {index}")]

    def _unknown_param_set(self, name: str) -> list[Message]:
        # mavlink_parameters.cpp PARAM_SET: "[pm] unknown param: %s"
        return [self._say(Severity.INFO, f"[pm] unknown param: {name}")]

    def _mission_total(self, count: int) -> int:
        return count if count else 65535
