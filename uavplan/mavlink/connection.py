"""A MAVLink 2 connection speaking our own message types. The only pymavlink importer.

pymavlink is used as a codec only: its generated MAVLink 2 ``common`` dialect module is
imported directly (``pymavlink.dialects.v20.common``), so nothing depends on the
``MAVLINK20`` / ``MAVLINK_DIALECT`` environment variables or on ``mavutil``'s global dialect
state, and no environment is changed at import. Transports are ours
(:mod:`uavplan.mavlink.transport`), which gives OS-assigned ports, several peers on a
listening endpoint and clean closing.

A :class:`MavlinkConnection` optionally emits its own HEARTBEAT at 1 Hz from inside
:meth:`~MavlinkConnection.recv` / :meth:`~MavlinkConnection.send`, as every ground station
does: a vehicle listening on UDP learns our address from it, and PX4/ArduPilot treat a link
without GCS heartbeats as lost.
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable
from typing import Any

from pymavlink.dialects.v20 import common as _mav  # type: ignore[import-untyped]

from uavplan.errors import LinkError
from uavplan.mavlink.messages import (
    AutopilotVersion,
    BatteryStatus,
    CommandAck,
    CommandInt,
    CommandLong,
    ExtendedSysState,
    GlobalPositionInt,
    Heartbeat,
    HomePosition,
    MalformedMessage,
    Message,
    MissionAck,
    MissionClearAll,
    MissionCount,
    MissionCurrent,
    MissionItemInt,
    MissionItemReached,
    MissionRequest,
    MissionRequestList,
    MissionSetCurrent,
    ParamRequestList,
    ParamRequestRead,
    ParamSet,
    ParamValue,
    Received,
    RequestDataStream,
    SetMode,
    StatusText,
    SysStatus,
    UnknownMessage,
)
from uavplan.mavlink.transport import ConnectionSpec, Transport, open_transport
from uavplan.mission.items import GLOBAL_FRAMES, deg_to_e7

#: our heartbeat period while a connection is open
HEARTBEAT_PERIOD_S = 1.0

_NAN = math.nan

# ---------------------------------------------------------------------------------------------
# Encoding: our dataclass -> pymavlink message object


def _encode(mav: _mav.MAVLink, msg: Message) -> _mav.MAVLink_message:
    if isinstance(msg, MissionItemInt):
        return mav.mission_item_int_encode(
            msg.target_system,
            msg.target_component,
            msg.seq,
            msg.frame,
            msg.command,
            msg.current,
            msg.autocontinue,
            msg.param1,
            msg.param2,
            msg.param3,
            msg.param4,
            msg.x,
            msg.y,
            msg.z,
            msg.mission_type,
        )
    if isinstance(msg, MissionRequest):
        encode = mav.mission_request_int_encode if msg.int_form else mav.mission_request_encode
        return encode(msg.target_system, msg.target_component, msg.seq, msg.mission_type)
    if isinstance(msg, Heartbeat):
        return mav.heartbeat_encode(
            msg.type,
            msg.autopilot,
            msg.base_mode,
            msg.custom_mode,
            msg.system_status,
            msg.mavlink_version,
        )
    if isinstance(msg, MissionCount):
        return mav.mission_count_encode(
            msg.target_system, msg.target_component, msg.count, msg.mission_type
        )
    if isinstance(msg, MissionAck):
        return mav.mission_ack_encode(
            msg.target_system, msg.target_component, msg.type, msg.mission_type
        )
    if isinstance(msg, MissionRequestList):
        return mav.mission_request_list_encode(
            msg.target_system, msg.target_component, msg.mission_type
        )
    if isinstance(msg, MissionClearAll):
        return mav.mission_clear_all_encode(
            msg.target_system, msg.target_component, msg.mission_type
        )
    if isinstance(msg, MissionCurrent):
        return mav.mission_current_encode(msg.seq, msg.total, msg.mission_state, msg.mission_mode)
    if isinstance(msg, MissionSetCurrent):
        return mav.mission_set_current_encode(msg.target_system, msg.target_component, msg.seq)
    if isinstance(msg, CommandLong):
        return mav.command_long_encode(
            msg.target_system,
            msg.target_component,
            msg.command,
            msg.confirmation,
            msg.param1,
            msg.param2,
            msg.param3,
            msg.param4,
            msg.param5,
            msg.param6,
            msg.param7,
        )
    if isinstance(msg, CommandAck):
        return mav.command_ack_encode(
            msg.command, msg.result, 0, 0, msg.target_system, msg.target_component
        )
    if isinstance(msg, AutopilotVersion):
        return mav.autopilot_version_encode(
            msg.capabilities,
            msg.flight_sw_version,
            msg.middleware_sw_version,
            msg.os_sw_version,
            msg.board_version,
            [0] * 8,
            [0] * 8,
            [0] * 8,
            msg.vendor_id,
            msg.product_id,
            msg.uid,
        )
    if isinstance(msg, StatusText):
        return mav.statustext_encode(msg.severity, msg.text.encode("utf-8")[:50])
    encoder = _MORE_ENCODERS.get(type(msg))
    if encoder is None:
        raise TypeError(f"cannot send {type(msg).__name__}")
    return encoder(mav, msg)


def _param_id(name: str) -> bytes:
    return name.encode("ascii", errors="replace")[:16]


#: the vehicle-side messages (telemetry, parameters, modes), by type
_MORE_ENCODERS: dict[type, Callable[[_mav.MAVLink, Any], _mav.MAVLink_message]] = {
    GlobalPositionInt: lambda mav, m: mav.global_position_int_encode(
        m.time_boot_ms, m.lat, m.lon, m.alt, m.relative_alt, m.vx, m.vy, m.vz, m.hdg
    ),
    MissionItemReached: lambda mav, m: mav.mission_item_reached_encode(m.seq),
    HomePosition: lambda mav, m: mav.home_position_encode(
        m.latitude, m.longitude, m.altitude, m.x, m.y, m.z, [1.0, 0.0, 0.0, 0.0], 0.0, 0.0, 0.0
    ),
    ExtendedSysState: lambda mav, m: mav.extended_sys_state_encode(m.vtol_state, m.landed_state),
    SysStatus: lambda mav, m: mav.sys_status_encode(
        m.onboard_control_sensors_present,
        m.onboard_control_sensors_enabled,
        m.onboard_control_sensors_health,
        m.load,
        m.voltage_battery,
        m.current_battery,
        m.battery_remaining,
        m.drop_rate_comm,
        m.errors_comm,
        0,
        0,
        0,
        0,
    ),
    BatteryStatus: lambda mav, m: mav.battery_status_encode(
        m.id,
        m.battery_function,
        m.type,
        m.temperature,
        list(m.voltages),
        m.current_battery,
        m.current_consumed,
        m.energy_consumed,
        m.battery_remaining,
        m.time_remaining,
        m.charge_state,
    ),
    ParamRequestList: lambda mav, m: mav.param_request_list_encode(
        m.target_system, m.target_component
    ),
    ParamRequestRead: lambda mav, m: mav.param_request_read_encode(
        m.target_system, m.target_component, _param_id(m.param_id), m.param_index
    ),
    ParamSet: lambda mav, m: mav.param_set_encode(
        m.target_system, m.target_component, _param_id(m.param_id), m.param_value, m.param_type
    ),
    ParamValue: lambda mav, m: mav.param_value_encode(
        _param_id(m.param_id), m.param_value, m.param_type, m.param_count, m.param_index
    ),
    SetMode: lambda mav, m: mav.set_mode_encode(m.target_system, m.base_mode, m.custom_mode),
    CommandInt: lambda mav, m: mav.command_int_encode(
        m.target_system,
        m.target_component,
        m.frame,
        m.command,
        m.current,
        m.autocontinue,
        m.param1,
        m.param2,
        m.param3,
        m.param4,
        m.x,
        m.y,
        m.z,
    ),
    RequestDataStream: lambda mav, m: mav.request_data_stream_encode(
        m.target_system, m.target_component, m.req_stream_id, m.req_message_rate, m.start_stop
    ),
}


# ---------------------------------------------------------------------------------------------
# Decoding: pymavlink message object -> our dataclass


def _item_from_float(m: _mav.MAVLink_mission_item_message) -> MissionItemInt:
    """The deprecated MISSION_ITEM, converted as ArduPilot does (x/y rounded to 1e-7 deg)."""
    global_frame = m.frame in GLOBAL_FRAMES
    x = deg_to_e7(m.x) if global_frame else round(m.x)
    y = deg_to_e7(m.y) if global_frame else round(m.y)
    return MissionItemInt(
        m.target_system,
        m.target_component,
        m.seq,
        m.frame,
        m.command,
        m.current,
        m.autocontinue,
        m.param1,
        m.param2,
        m.param3,
        m.param4,
        x,
        y,
        m.z,
        m.mission_type,
        legacy_float=True,
    )


def _text(raw: bytes | str) -> str:
    if isinstance(raw, bytes):
        raw = raw.decode("utf-8", errors="replace")
    return raw.rstrip("\x00")


_DECODERS: dict[int, Callable[[_mav.MAVLink_message], Message]] = {
    _mav.MAVLINK_MSG_ID_HEARTBEAT: lambda m: Heartbeat(
        m.type, m.autopilot, m.base_mode, m.custom_mode, m.system_status, m.mavlink_version
    ),
    _mav.MAVLINK_MSG_ID_MISSION_COUNT: lambda m: MissionCount(
        m.target_system, m.target_component, m.count, m.mission_type
    ),
    _mav.MAVLINK_MSG_ID_MISSION_REQUEST_INT: lambda m: MissionRequest(
        m.target_system, m.target_component, m.seq, m.mission_type, int_form=True
    ),
    _mav.MAVLINK_MSG_ID_MISSION_REQUEST: lambda m: MissionRequest(
        m.target_system, m.target_component, m.seq, m.mission_type, int_form=False
    ),
    _mav.MAVLINK_MSG_ID_MISSION_REQUEST_LIST: lambda m: MissionRequestList(
        m.target_system, m.target_component, m.mission_type
    ),
    _mav.MAVLINK_MSG_ID_MISSION_ITEM_INT: lambda m: MissionItemInt(
        m.target_system,
        m.target_component,
        m.seq,
        m.frame,
        m.command,
        m.current,
        m.autocontinue,
        m.param1,
        m.param2,
        m.param3,
        m.param4,
        m.x,
        m.y,
        m.z,
        m.mission_type,
    ),
    _mav.MAVLINK_MSG_ID_MISSION_ITEM: _item_from_float,
    _mav.MAVLINK_MSG_ID_MISSION_ACK: lambda m: MissionAck(
        m.target_system, m.target_component, m.type, m.mission_type
    ),
    _mav.MAVLINK_MSG_ID_MISSION_CLEAR_ALL: lambda m: MissionClearAll(
        m.target_system, m.target_component, m.mission_type
    ),
    _mav.MAVLINK_MSG_ID_MISSION_CURRENT: lambda m: MissionCurrent(
        m.seq, m.total, m.mission_state, m.mission_mode
    ),
    _mav.MAVLINK_MSG_ID_MISSION_SET_CURRENT: lambda m: MissionSetCurrent(
        m.target_system, m.target_component, m.seq
    ),
    _mav.MAVLINK_MSG_ID_COMMAND_LONG: lambda m: CommandLong(
        m.target_system,
        m.target_component,
        m.command,
        m.confirmation,
        m.param1,
        m.param2,
        m.param3,
        m.param4,
        m.param5,
        m.param6,
        m.param7,
    ),
    _mav.MAVLINK_MSG_ID_COMMAND_ACK: lambda m: CommandAck(
        m.command, m.result, m.target_system, m.target_component
    ),
    _mav.MAVLINK_MSG_ID_AUTOPILOT_VERSION: lambda m: AutopilotVersion(
        m.capabilities,
        m.flight_sw_version,
        m.middleware_sw_version,
        m.os_sw_version,
        m.board_version,
        m.vendor_id,
        m.product_id,
        m.uid,
    ),
    _mav.MAVLINK_MSG_ID_STATUSTEXT: lambda m: StatusText(m.severity, _text(m.text)),
    _mav.MAVLINK_MSG_ID_COMMAND_INT: lambda m: CommandInt(
        m.target_system,
        m.target_component,
        m.command,
        m.frame,
        m.current,
        m.autocontinue,
        m.param1,
        m.param2,
        m.param3,
        m.param4,
        m.x,
        m.y,
        m.z,
    ),
    _mav.MAVLINK_MSG_ID_SET_MODE: lambda m: SetMode(m.target_system, m.base_mode, m.custom_mode),
    _mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: lambda m: GlobalPositionInt(
        m.time_boot_ms, m.lat, m.lon, m.alt, m.relative_alt, m.vx, m.vy, m.vz, m.hdg
    ),
    _mav.MAVLINK_MSG_ID_MISSION_ITEM_REACHED: lambda m: MissionItemReached(m.seq),
    _mav.MAVLINK_MSG_ID_HOME_POSITION: lambda m: HomePosition(
        m.latitude, m.longitude, m.altitude, m.x, m.y, m.z
    ),
    _mav.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: lambda m: ExtendedSysState(
        m.vtol_state, m.landed_state
    ),
    _mav.MAVLINK_MSG_ID_SYS_STATUS: lambda m: SysStatus(
        m.onboard_control_sensors_present,
        m.onboard_control_sensors_enabled,
        m.onboard_control_sensors_health,
        m.load,
        m.voltage_battery,
        m.current_battery,
        m.battery_remaining,
        m.drop_rate_comm,
        m.errors_comm,
    ),
    _mav.MAVLINK_MSG_ID_BATTERY_STATUS: lambda m: BatteryStatus(
        m.id,
        m.battery_function,
        m.type,
        m.temperature,
        tuple(m.voltages),
        m.current_battery,
        m.current_consumed,
        m.energy_consumed,
        m.battery_remaining,
        m.time_remaining,
        m.charge_state,
    ),
    _mav.MAVLINK_MSG_ID_PARAM_REQUEST_LIST: lambda m: ParamRequestList(
        m.target_system, m.target_component
    ),
    _mav.MAVLINK_MSG_ID_PARAM_REQUEST_READ: lambda m: ParamRequestRead(
        m.target_system, m.target_component, _text(m.param_id), m.param_index
    ),
    _mav.MAVLINK_MSG_ID_PARAM_SET: lambda m: ParamSet(
        m.target_system, m.target_component, _text(m.param_id), m.param_value, m.param_type
    ),
    _mav.MAVLINK_MSG_ID_PARAM_VALUE: lambda m: ParamValue(
        _text(m.param_id), m.param_value, m.param_type, m.param_count, m.param_index
    ),
    _mav.MAVLINK_MSG_ID_REQUEST_DATA_STREAM: lambda m: RequestDataStream(
        m.target_system, m.target_component, m.req_stream_id, m.req_message_rate, m.start_stop
    ),
}


def _decode(m: _mav.MAVLink_message) -> Message:
    """Our message for a parsed frame; a :class:`MalformedMessage` when its fields cannot
    be represented (a float MISSION_ITEM with x = NaN): one hostile packet must not stop a
    receiver."""
    decoder = _DECODERS.get(m.get_msgId())
    if decoder is None:
        return UnknownMessage(m.get_msgId(), m.get_type())
    try:
        return decoder(m)
    except (ValueError, OverflowError, TypeError, UnicodeError) as err:
        mission_type = getattr(m, "mission_type", None)
        seq = getattr(m, "seq", None)
        return MalformedMessage(
            m.get_msgId(),
            m.get_type(),
            str(err),
            target_system=_int_field(m, "target_system"),
            target_component=_int_field(m, "target_component"),
            mission_type=mission_type if isinstance(mission_type, int) else None,
            seq=seq if isinstance(seq, int) else None,
        )


def _int_field(m: _mav.MAVLink_message, name: str) -> int:
    value = getattr(m, name, 0)
    return value if isinstance(value, int) else 0


# ---------------------------------------------------------------------------------------------


class MavlinkConnection:
    """MAVLink 2 over one transport, with our own message types in and out.

    ``heartbeat``: when given, that HEARTBEAT is sent right away and then every
    :data:`HEARTBEAT_PERIOD_S` while the caller sends or receives.
    """

    def __init__(
        self,
        transport: Transport,
        *,
        system_id: int,
        component_id: int,
        heartbeat: Heartbeat | None = None,
    ) -> None:
        if not (1 <= system_id <= 255 and 0 <= component_id <= 255):
            raise ValueError("system id must be 1..255 and component id 0..255")
        self.transport = transport
        self.system_id = system_id
        self.component_id = component_id
        self._mav = _mav.MAVLink(None, srcSystem=system_id, srcComponent=component_id)
        self._mav.robust_parsing = True
        self._pending: deque[Received] = deque()
        self._heartbeat = heartbeat
        self._next_heartbeat = 0.0
        self._closed = False
        self.sent_count = 0
        self.received_count = 0
        self.bad_data_count = 0
        if heartbeat is not None:
            self._maybe_heartbeat()

    @classmethod
    def open(
        cls,
        conn: str | ConnectionSpec,
        *,
        system_id: int = 255,
        component_id: int = 190,
        heartbeat: Heartbeat | None = None,
    ) -> MavlinkConnection:
        """Open a connection string (pymavlink or MAVSDK spelling); see :mod:`.transport`."""
        spec = conn if isinstance(conn, ConnectionSpec) else ConnectionSpec.parse(conn)
        transport = open_transport(spec)
        return cls(transport, system_id=system_id, component_id=component_id, heartbeat=heartbeat)

    @property
    def description(self) -> str:
        return self.transport.description

    @property
    def local_address(self) -> tuple[str, int] | None:
        return self.transport.local_address

    def encode(self, msg: Message) -> bytes:
        """The bytes of one MAVLink 2 frame carrying ``msg`` (advances our sequence number)."""
        frame = _encode(self._mav, msg)
        data = frame.pack(self._mav)
        self._mav.seq = (self._mav.seq + 1) % 256
        return data

    def send(self, msg: Message) -> None:
        if self._closed:
            raise LinkError("the connection is closed")
        self._maybe_heartbeat()
        self.transport.send(self.encode(msg))
        self.sent_count += 1

    def send_bytes(self, data: bytes) -> None:
        """Send pre-encoded frames (the mock vehicle uses this to replay or reorder)."""
        self.transport.send(data)

    def recv(self, timeout_s: float) -> Received | None:
        """The next message, waiting at most ``timeout_s`` (``None`` on timeout)."""
        deadline = time.monotonic() + max(0.0, timeout_s)
        while True:
            if self._pending:
                return self._pending.popleft()
            self._maybe_heartbeat()
            now = time.monotonic()
            wait = deadline - now
            if self._heartbeat is not None:
                wait = min(wait, max(0.0, self._next_heartbeat - now))
            for chunk in self.transport.recv(max(0.0, wait)):
                self._parse(chunk)
            if not self._pending and time.monotonic() >= deadline:
                return None

    def _parse(self, chunk: bytes) -> None:
        try:
            frames = self._mav.parse_buffer(chunk) or []
        except Exception:  # a corrupt frame: pymavlink raises MAVError subclasses
            self.bad_data_count += 1
            return
        for frame in frames:
            if frame.get_type() == "BAD_DATA":
                self.bad_data_count += 1
                continue
            self.received_count += 1
            self._pending.append(
                Received(_decode(frame), frame.get_srcSystem(), frame.get_srcComponent())
            )

    def _maybe_heartbeat(self) -> None:
        if self._heartbeat is None or self._closed:
            return
        now = time.monotonic()
        if now >= self._next_heartbeat:
            self._next_heartbeat = now + HEARTBEAT_PERIOD_S
            self.transport.send(self.encode(self._heartbeat))

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self.transport.close()

    def __enter__(self) -> MavlinkConnection:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
