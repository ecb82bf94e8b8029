"""Our own MAVLink message types: what the mission protocol needs, nothing from pymavlink.

Every message the client and the mock vehicle exchange is one of the small frozen dataclasses
below; :mod:`uavplan.mavlink.connection` is the only place that turns them into bytes and
back (through pymavlink's MAVLink 2 ``common`` dialect). Field names follow common.xml so a
reader can check them against the spec; units are those of the wire (x/y of
``MISSION_ITEM_INT`` are degrees × 1e7 for global frames).

The ``opaque_id`` extension of MISSION_COUNT / MISSION_ACK and the plan ids of
MISSION_CURRENT are not modelled: pymavlink 2.4.50's ``common.xml`` predates them, so they
could be neither sent nor read (peers that send them are still understood; the extra
extension bytes are ignored).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from uavplan.mission.items import MissionType

# ---------------------------------------------------------------------------------------------
# Enumerations (values from common.xml / minimal.xml)


class MissionResult(enum.IntEnum):
    """MAV_MISSION_RESULT: the ``type`` of a MISSION_ACK."""

    ACCEPTED = 0
    ERROR = 1
    UNSUPPORTED_FRAME = 2
    UNSUPPORTED = 3
    NO_SPACE = 4
    INVALID = 5
    INVALID_PARAM1 = 6
    INVALID_PARAM2 = 7
    INVALID_PARAM3 = 8
    INVALID_PARAM4 = 9
    INVALID_PARAM5_X = 10
    INVALID_PARAM6_Y = 11
    INVALID_PARAM7 = 12
    INVALID_SEQUENCE = 13
    DENIED = 14
    OPERATION_CANCELLED = 15

    @classmethod
    def from_wire(cls, value: int) -> MissionResult | int:
        """The enum member, or the raw number when a vehicle sends a value we do not know."""
        try:
            return cls(value)
        except ValueError:
            return value

    @property
    def label(self) -> str:
        return f"MAV_MISSION_{self.name}"


def result_label(value: MissionResult | int) -> str:
    """``MAV_MISSION_<NAME>`` for a known result, ``MAV_MISSION_RESULT <n>`` otherwise."""
    if isinstance(value, MissionResult):
        return value.label
    return f"MAV_MISSION_RESULT {value}"


class MavResult(enum.IntEnum):
    """MAV_RESULT: the ``result`` of a COMMAND_ACK."""

    ACCEPTED = 0
    TEMPORARILY_REJECTED = 1
    DENIED = 2
    UNSUPPORTED = 3
    FAILED = 4
    IN_PROGRESS = 5
    CANCELLED = 6


class MavType(enum.IntEnum):
    """The MAV_TYPE values this package meets."""

    GENERIC = 0
    FIXED_WING = 1
    QUADROTOR = 2
    GCS = 6
    ONBOARD_CONTROLLER = 18


class MavAutopilotId(enum.IntEnum):
    """MAV_AUTOPILOT numbers; the flavours we plan for are :class:`.items.Autopilot`."""

    GENERIC = 0
    ARDUPILOTMEGA = 3
    INVALID = 8
    PX4 = 12


class Capability(enum.IntFlag):
    """MAV_PROTOCOL_CAPABILITY bits of AUTOPILOT_VERSION.capabilities that mission clients read."""

    MISSION_FLOAT = 1
    PARAM_FLOAT = 2
    MISSION_INT = 4
    COMMAND_INT = 8
    MAVLINK2 = 8192
    MISSION_FENCE = 16384
    MISSION_RALLY = 32768


class MavCommand(enum.IntEnum):
    """MAV_CMD numbers used outside mission items."""

    DO_SET_MISSION_CURRENT = 224
    REQUEST_AUTOPILOT_CAPABILITIES = 520
    REQUEST_MESSAGE = 512


#: MAVLink message id of AUTOPILOT_VERSION (param1 of MAV_CMD_REQUEST_MESSAGE)
AUTOPILOT_VERSION_ID = 148

#: MAV_COMP_ID_MISSIONPLANNER, the component id ground stations use
COMP_ID_MISSIONPLANNER = 190

# ---------------------------------------------------------------------------------------------
# Messages


@dataclass(frozen=True, slots=True)
class Heartbeat:
    type: int
    autopilot: int
    base_mode: int = 0
    custom_mode: int = 0
    system_status: int = 4  # MAV_STATE_ACTIVE
    mavlink_version: int = 3


@dataclass(frozen=True, slots=True)
class MissionCount:
    target_system: int
    target_component: int
    count: int
    mission_type: int = MissionType.MISSION


@dataclass(frozen=True, slots=True)
class MissionRequest:
    """MISSION_REQUEST_INT (``int_form``) or the deprecated float MISSION_REQUEST."""

    target_system: int
    target_component: int
    seq: int
    mission_type: int = MissionType.MISSION
    int_form: bool = True


@dataclass(frozen=True, slots=True)
class MissionRequestList:
    target_system: int
    target_component: int
    mission_type: int = MissionType.MISSION


@dataclass(frozen=True, slots=True)
class MissionItemInt:
    """MISSION_ITEM_INT exactly as on the wire (params are float32 values, NaN = unset).

    ``legacy_float`` marks an item that arrived as the deprecated MISSION_ITEM and was
    converted (x/y rounded to degrees × 1e7); it is never sent that way.
    """

    target_system: int
    target_component: int
    seq: int
    frame: int
    command: int
    current: int
    autocontinue: int
    param1: float
    param2: float
    param3: float
    param4: float
    x: int
    y: int
    z: float
    mission_type: int = MissionType.MISSION
    legacy_float: bool = False


@dataclass(frozen=True, slots=True)
class MissionAck:
    target_system: int
    target_component: int
    type: int
    mission_type: int = MissionType.MISSION


@dataclass(frozen=True, slots=True)
class MissionClearAll:
    target_system: int
    target_component: int
    mission_type: int = MissionType.MISSION


@dataclass(frozen=True, slots=True)
class MissionCurrent:
    seq: int
    total: int = 0
    mission_state: int = 0
    mission_mode: int = 0


@dataclass(frozen=True, slots=True)
class MissionSetCurrent:
    target_system: int
    target_component: int
    seq: int


@dataclass(frozen=True, slots=True)
class CommandLong:
    target_system: int
    target_component: int
    command: int
    confirmation: int = 0
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    param5: float = 0.0
    param6: float = 0.0
    param7: float = 0.0


@dataclass(frozen=True, slots=True)
class CommandAck:
    command: int
    result: int
    target_system: int = 0
    target_component: int = 0


@dataclass(frozen=True, slots=True)
class AutopilotVersion:
    capabilities: int
    flight_sw_version: int = 0
    middleware_sw_version: int = 0
    os_sw_version: int = 0
    board_version: int = 0
    vendor_id: int = 0
    product_id: int = 0
    uid: int = 0


@dataclass(frozen=True, slots=True)
class StatusText:
    severity: int
    text: str


@dataclass(frozen=True, slots=True)
class UnknownMessage:
    """Any message this package does not model; kept so a receiver can see the link is alive."""

    msg_id: int
    name: str


@dataclass(frozen=True, slots=True)
class MalformedMessage:
    """A frame that parsed (CRC good) but whose fields cannot be represented, such as a
    float MISSION_ITEM with x = NaN in a global frame. The addressing fields of the frame
    are kept so receivers can filter it like the message it claimed to be."""

    msg_id: int
    name: str
    reason: str
    target_system: int = 0
    target_component: int = 0
    mission_type: int | None = None
    seq: int | None = None


Message = (
    Heartbeat
    | MissionCount
    | MissionRequest
    | MissionRequestList
    | MissionItemInt
    | MissionAck
    | MissionClearAll
    | MissionCurrent
    | MissionSetCurrent
    | CommandLong
    | CommandAck
    | AutopilotVersion
    | StatusText
    | UnknownMessage
    | MalformedMessage
)


@dataclass(frozen=True, slots=True)
class Received:
    """A decoded message with the MAVLink header fields a receiver filters on."""

    message: Message
    system_id: int
    component_id: int


def message_name(message: Message) -> str:
    """The MAVLink name of a message (``MISSION_REQUEST_INT``, ``HEARTBEAT``...)."""
    if isinstance(message, UnknownMessage | MalformedMessage):
        return message.name
    if isinstance(message, MissionRequest):
        return "MISSION_REQUEST_INT" if message.int_form else "MISSION_REQUEST"
    if isinstance(message, MissionItemInt):
        return "MISSION_ITEM" if message.legacy_float else "MISSION_ITEM_INT"
    return _NAMES[type(message)]


_NAMES: dict[type, str] = {
    Heartbeat: "HEARTBEAT",
    MissionCount: "MISSION_COUNT",
    MissionRequestList: "MISSION_REQUEST_LIST",
    MissionAck: "MISSION_ACK",
    MissionClearAll: "MISSION_CLEAR_ALL",
    MissionCurrent: "MISSION_CURRENT",
    MissionSetCurrent: "MISSION_SET_CURRENT",
    CommandLong: "COMMAND_LONG",
    CommandAck: "COMMAND_ACK",
    AutopilotVersion: "AUTOPILOT_VERSION",
    StatusText: "STATUSTEXT",
}
