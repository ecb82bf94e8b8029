"""Flight modes as PX4 and ArduPilot Copter put them in HEARTBEAT.custom_mode.

- **PX4** packs a main mode and a sub mode into ``custom_mode``:
  ``union px4_custom_mode { struct { uint16_t reserved; uint8_t main_mode; uint8_t sub_mode; };
  uint32_t data; }`` (src/modules/commander/px4_custom_mode.h), so on a little-endian
  autopilot ``custom_mode = sub_mode << 24 | main_mode << 16``; MAV_CMD_DO_SET_MODE carries
  the main mode in param2 and the sub mode in param3.
- **ArduPilot Copter** puts its mode number in ``custom_mode`` (ArduCopter/mode.h
  ``Mode::Number``): STABILIZE 0, ALT_HOLD 2, AUTO 3, GUIDED 4, LOITER 5, RTL 6, LAND 9,
  POSHOLD 16, BRAKE 17; MAV_CMD_DO_SET_MODE carries it in param2.

The names are the firmware's own: PX4's ``nav_state_names`` (commander/ModeUtil), which its
"Switching to %s is currently not available" message quotes, and ArduPilot's mode names
(``Mode::name()``), which "Arm: %s mode not armable" and "Mode change to %s failed" quote.
Ground stations and the simulated vehicle both use this table.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from uavplan.mission.items import Autopilot

__all__ = [
    "ARDUPILOT_MODES",
    "PX4_MODES",
    "FlightMode",
    "ModeKind",
    "ardupilot_mode",
    "mode_from_heartbeat",
    "px4_custom_mode",
    "px4_mode",
]


class ModeKind(enum.Enum):
    """What a mode makes the vehicle do, flavour aside."""

    MANUAL = "manual"  # a pilot flies (the simulation has none: holds)
    MISSION = "mission"
    HOLD = "hold"  # holds its position with no pilot (PX4 Hold, ArduPilot BRAKE)
    RETURN = "return"
    LAND = "land"
    TAKEOFF = "takeoff"
    GUIDED = "guided"  # waits for position targets (holds)
    OFFBOARD = "offboard"


@dataclass(frozen=True)
class FlightMode:
    """One mode of one autopilot: its ``custom_mode`` value, name and kind."""

    autopilot: Autopilot
    custom_mode: int
    name: str
    kind: ModeKind
    #: PX4: (main, sub); ArduPilot: (mode number, 0)
    numbers: tuple[int, int]


def px4_custom_mode(main: int, sub: int = 0) -> int:
    """PX4's ``custom_mode`` for main mode ``main`` and sub mode ``sub``."""
    return (sub & 0xFF) << 24 | (main & 0xFF) << 16


def _px4(main: int, sub: int, name: str, kind: ModeKind) -> FlightMode:
    return FlightMode(Autopilot.PX4, px4_custom_mode(main, sub), name, kind, (main, sub))


#: PX4 main modes: MANUAL 1, ALTCTL 2, POSCTL 3, AUTO 4, ACRO 5, OFFBOARD 6, STABILIZED 7;
#: AUTO sub modes: READY 1, TAKEOFF 2, LOITER 3, MISSION 4, RTL 5, LAND 6
PX4_MODES: tuple[FlightMode, ...] = (
    _px4(1, 0, "Manual", ModeKind.MANUAL),
    _px4(2, 0, "Altitude", ModeKind.MANUAL),
    _px4(3, 0, "Position", ModeKind.MANUAL),
    _px4(4, 2, "Takeoff", ModeKind.TAKEOFF),
    _px4(4, 3, "Hold", ModeKind.HOLD),
    _px4(4, 4, "Mission", ModeKind.MISSION),
    _px4(4, 5, "Return", ModeKind.RETURN),
    _px4(4, 6, "Land", ModeKind.LAND),
    _px4(5, 0, "Acro", ModeKind.MANUAL),
    _px4(6, 0, "Offboard", ModeKind.OFFBOARD),
    _px4(7, 0, "Stabilized", ModeKind.MANUAL),
)


def _ap(number: int, name: str, kind: ModeKind) -> FlightMode:
    return FlightMode(Autopilot.ARDUPILOT, number, name, kind, (number, 0))


ARDUPILOT_MODES: tuple[FlightMode, ...] = (
    _ap(0, "STABILIZE", ModeKind.MANUAL),
    _ap(2, "ALT_HOLD", ModeKind.MANUAL),
    _ap(3, "AUTO", ModeKind.MISSION),
    _ap(4, "GUIDED", ModeKind.GUIDED),
    # LOITER and POSHOLD hold position only with a pilot on the sticks: the throttle stick
    # sets the climb rate (ArduCopter/mode_loiter.cpp ModeLoiter::run,
    # get_pilot_desired_climb_rate). On SITL, whose throttle input rests low, LOITER descended
    # at 2.5 m/s and landed (issue 32). BRAKE holds the stopping point with no pilot
    # (ArduCopter/mode_brake.cpp ModeBrake::run: zero velocity, pos_control's z target kept).
    _ap(5, "LOITER", ModeKind.MANUAL),
    _ap(6, "RTL", ModeKind.RETURN),
    _ap(9, "LAND", ModeKind.LAND),
    _ap(16, "POSHOLD", ModeKind.MANUAL),
    _ap(17, "BRAKE", ModeKind.HOLD),
)


def px4_mode(main: int, sub: int = 0) -> FlightMode | None:
    """The PX4 mode with main mode ``main`` and sub mode ``sub`` (sub ignored outside AUTO)."""
    if main != 4:
        sub = 0
    for mode in PX4_MODES:
        if mode.numbers == (main, sub):
            return mode
    return None


def ardupilot_mode(number: int) -> FlightMode | None:
    """The ArduPilot Copter mode with this number (those the simulation flies)."""
    for mode in ARDUPILOT_MODES:
        if mode.numbers[0] == number:
            return mode
    return None


def mode_from_heartbeat(autopilot: Autopilot, custom_mode: int) -> FlightMode | None:
    """The mode a HEARTBEAT's ``custom_mode`` names, for that autopilot (``None``: unknown)."""
    if autopilot == Autopilot.PX4:
        return px4_mode((custom_mode >> 16) & 0xFF, (custom_mode >> 24) & 0xFF)
    if autopilot == Autopilot.ARDUPILOT:
        return ardupilot_mode(custom_mode)
    return None


def mode_named(autopilot: Autopilot, kind: ModeKind) -> FlightMode:
    """The mode of ``kind`` for ``autopilot`` (PX4 Hold / ArduPilot BRAKE for HOLD...)."""
    table = PX4_MODES if autopilot == Autopilot.PX4 else ARDUPILOT_MODES
    for mode in table:
        if mode.kind is kind:
            return mode
    raise ValueError(f"{autopilot.label} has no {kind.value} mode")
