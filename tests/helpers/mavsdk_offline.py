"""A MAVSDK MissionRaw plugin without a vehicle, for testing MAVSDK's file importers."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any

from uavplan.mission.items import Autopilot, MissionItem, MissionType


@contextlib.contextmanager
def mavsdk_mission_raw(autopilot: Autopilot) -> Iterator[Any]:
    """A MAVSDK MissionRaw plugin bound to a system that announced ``autopilot``.

    The importer needs a System (it prepends ArduPilot's home itself). No vehicle or socket
    is needed: one HEARTBEAT fed through a ``raw://`` connection creates the system.
    """
    from mavsdk.component_type import ComponentType
    from mavsdk.mavsdk import Configuration, Mavsdk
    from mavsdk.plugins.mission_raw.mission_raw import MissionRaw
    from pymavlink.dialects.v20 import common as mavlink2

    mavsdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    try:
        mavsdk.add_any_connection("raw://")
        mavsdk.subscribe_raw_bytes_to_be_sent(lambda _data: None)
        mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
        heartbeat = mav.heartbeat_encode(
            mavlink2.MAV_TYPE_QUADROTOR, autopilot.value, 0, 0, mavlink2.MAV_STATE_STANDBY
        )
        mavsdk.pass_received_raw_bytes(heartbeat.pack(mav))
        system = mavsdk.first_autopilot(2.0)
        assert system is not None, "MAVSDK did not create a system from the heartbeat"
        plugin = MissionRaw(system)
        try:
            yield plugin
        finally:
            plugin.destroy()
    finally:
        mavsdk.destroy()


def to_mavsdk(item: MissionItem, seq: int, mission_type: MissionType) -> Any:
    """``item`` as MAVSDK's MissionRaw item at ``seq``, its fields as on the wire."""
    from mavsdk.plugins.mission_raw import MissionItem as MavsdkItem

    from uavplan.mavlink.protocol import item_to_wire

    wire = item_to_wire(item, seq, mission_type, 1, 1)
    return MavsdkItem(
        seq=seq,
        frame=wire.frame,
        command=wire.command,
        current=wire.current,
        autocontinue=wire.autocontinue,
        param1=wire.param1,
        param2=wire.param2,
        param3=wire.param3,
        param4=wire.param4,
        x=wire.x,
        y=wire.y,
        z=wire.z,
        mission_type=int(mission_type),
    )
