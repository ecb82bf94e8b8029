"""Our own MAVLink message types: what the mission protocol needs, nothing from pymavlink.

Every message the client and the simulated vehicle (:mod:`uavplan.sim`) exchange is one of
the small frozen dataclasses below; :mod:`uavplan.mavlink.connection` is the only place that
turns them into bytes and back (through pymavlink's MAVLink 2 ``common`` dialect). Field
names follow common.xml so a reader can check them against the spec; units are those of the
wire (x/y of ``MISSION_ITEM_INT`` are degrees × 1e7 for global frames).

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
    PARAM_ENCODE_BYTEWISE = 16
    MAVLINK2 = 8192
    MISSION_FENCE = 16384
    MISSION_RALLY = 32768
    PARAM_ENCODE_C_CAST = 131072


class MavCommand(enum.IntEnum):
    """MAV_CMD numbers used outside mission items."""

    NAV_RETURN_TO_LAUNCH = 20
    NAV_LAND = 21
    NAV_TAKEOFF = 22
    DO_SET_MODE = 176
    DO_CHANGE_SPEED = 178
    DO_SET_MISSION_CURRENT = 224
    MISSION_START = 300
    COMPONENT_ARM_DISARM = 400
    RUN_PREARM_CHECKS = 401
    GET_HOME_POSITION = 410
    SET_MESSAGE_INTERVAL = 511
    REQUEST_MESSAGE = 512
    REQUEST_AUTOPILOT_CAPABILITIES = 520


class MavModeFlag(enum.IntFlag):
    """MAV_MODE_FLAG: HEARTBEAT.base_mode bits."""

    CUSTOM_MODE_ENABLED = 1
    TEST_ENABLED = 2
    AUTO_ENABLED = 4
    GUIDED_ENABLED = 8
    STABILIZE_ENABLED = 16
    HIL_ENABLED = 32
    MANUAL_INPUT_ENABLED = 64
    SAFETY_ARMED = 128


class MavState(enum.IntEnum):
    """MAV_STATE: HEARTBEAT.system_status."""

    UNINIT = 0
    BOOT = 1
    CALIBRATING = 2
    STANDBY = 3
    ACTIVE = 4
    CRITICAL = 5
    EMERGENCY = 6


class LandedState(enum.IntEnum):
    """MAV_LANDED_STATE: EXTENDED_SYS_STATE.landed_state."""

    UNDEFINED = 0
    ON_GROUND = 1
    IN_AIR = 2
    TAKEOFF = 3
    LANDING = 4


class MissionState(enum.IntEnum):
    """MISSION_STATE: MISSION_CURRENT.mission_state."""

    UNKNOWN = 0
    NO_MISSION = 1
    NOT_STARTED = 2
    ACTIVE = 3
    PAUSED = 4
    COMPLETE = 5


class Severity(enum.IntEnum):
    """MAV_SEVERITY of a STATUSTEXT."""

    EMERGENCY = 0
    ALERT = 1
    CRITICAL = 2
    ERROR = 3
    WARNING = 4
    NOTICE = 5
    INFO = 6
    DEBUG = 7


#: MAV_SYS_STATUS_PREARM_CHECK: the SYS_STATUS sensor bit of the pre-arm checks (healthy:
#: they pass; "always healthy when armed", common.xml). QGroundControl's "Ready To Fly".
SYS_STATUS_PREARM_CHECK = 0x10000000

#: MAVLink message id of AUTOPILOT_VERSION (param1 of MAV_CMD_REQUEST_MESSAGE)
AUTOPILOT_VERSION_ID = 148


class MessageId(enum.IntEnum):
    """MAVLink message ids a vehicle streams or is asked for (SET_MESSAGE_INTERVAL,
    REQUEST_MESSAGE)."""

    HEARTBEAT = 0
    SYS_STATUS = 1
    GLOBAL_POSITION_INT = 33
    MISSION_CURRENT = 42
    MISSION_ITEM_REACHED = 46
    BATTERY_STATUS = 147
    AUTOPILOT_VERSION = 148
    HOME_POSITION = 242
    EXTENDED_SYS_STATE = 245


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
class CommandInt:
    """COMMAND_INT: a command with a position (x/y degrees × 1e7 in global frames)."""

    target_system: int
    target_component: int
    command: int
    frame: int = 0
    current: int = 0
    autocontinue: int = 0
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    x: int = 0
    y: int = 0
    z: float = 0.0


@dataclass(frozen=True, slots=True)
class SetMode:
    """SET_MODE (deprecated for MAV_CMD_DO_SET_MODE, still what pymavlink's set_mode sends)."""

    target_system: int
    base_mode: int
    custom_mode: int


@dataclass(frozen=True, slots=True)
class GlobalPositionInt:
    """GLOBAL_POSITION_INT: lat/lon degrees × 1e7, alt/relative_alt mm, velocity cm/s NED,
    heading centidegrees (65535: unknown)."""

    time_boot_ms: int
    lat: int
    lon: int
    alt: int
    relative_alt: int
    vx: int = 0
    vy: int = 0
    vz: int = 0
    hdg: int = 65535


@dataclass(frozen=True, slots=True)
class MissionItemReached:
    seq: int


@dataclass(frozen=True, slots=True)
class HomePosition:
    """HOME_POSITION: lat/lon degrees × 1e7, altitude mm AMSL, local x/y/z metres."""

    latitude: int
    longitude: int
    altitude: int
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0


@dataclass(frozen=True, slots=True)
class ExtendedSysState:
    vtol_state: int
    landed_state: int


@dataclass(frozen=True, slots=True)
class SysStatus:
    """SYS_STATUS: sensor bitmasks, load (‰), battery voltage mV, current cA (-1 unknown),
    remaining % (-1 unknown)."""

    onboard_control_sensors_present: int
    onboard_control_sensors_enabled: int
    onboard_control_sensors_health: int
    load: int
    voltage_battery: int
    current_battery: int
    battery_remaining: int
    drop_rate_comm: int = 0
    errors_comm: int = 0


@dataclass(frozen=True, slots=True)
class BatteryStatus:
    """BATTERY_STATUS: cell voltages mV (65535: no cell), current cA, consumed mAh and hJ,
    remaining %, time remaining s."""

    id: int
    battery_function: int
    type: int
    temperature: int
    voltages: tuple[int, ...]
    current_battery: int
    current_consumed: int
    energy_consumed: int
    battery_remaining: int
    time_remaining: int = 0
    charge_state: int = 0


@dataclass(frozen=True, slots=True)
class ParamRequestList:
    target_system: int
    target_component: int


@dataclass(frozen=True, slots=True)
class ParamRequestRead:
    """PARAM_REQUEST_READ: by ``param_index``, or by ``param_id`` when the index is -1."""

    target_system: int
    target_component: int
    param_id: str
    param_index: int = -1


@dataclass(frozen=True, slots=True)
class ParamSet:
    target_system: int
    target_component: int
    param_id: str
    param_value: float
    param_type: int


@dataclass(frozen=True, slots=True)
class ParamValue:
    """PARAM_VALUE. ``param_value`` is the float field as on the wire (an integer parameter is
    a C cast on ArduPilot and its bytes on PX4: :attr:`Capability.PARAM_ENCODE_BYTEWISE`)."""

    param_id: str
    param_value: float
    param_type: int
    param_count: int
    param_index: int


@dataclass(frozen=True, slots=True)
class RequestDataStream:
    """REQUEST_DATA_STREAM (deprecated, still sent by pymavlink scripts; ArduPilot honours it)."""

    target_system: int
    target_component: int
    req_stream_id: int
    req_message_rate: int
    start_stop: int


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
    | CommandInt
    | SetMode
    | GlobalPositionInt
    | MissionItemReached
    | HomePosition
    | ExtendedSysState
    | SysStatus
    | BatteryStatus
    | ParamRequestList
    | ParamRequestRead
    | ParamSet
    | ParamValue
    | RequestDataStream
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
    CommandInt: "COMMAND_INT",
    SetMode: "SET_MODE",
    GlobalPositionInt: "GLOBAL_POSITION_INT",
    MissionItemReached: "MISSION_ITEM_REACHED",
    HomePosition: "HOME_POSITION",
    ExtendedSysState: "EXTENDED_SYS_STATE",
    SysStatus: "SYS_STATUS",
    BatteryStatus: "BATTERY_STATUS",
    ParamRequestList: "PARAM_REQUEST_LIST",
    ParamRequestRead: "PARAM_REQUEST_READ",
    ParamSet: "PARAM_SET",
    ParamValue: "PARAM_VALUE",
    RequestDataStream: "REQUEST_DATA_STREAM",
}
