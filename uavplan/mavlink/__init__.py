"""MAVLink for missions: connections, the mission protocol client, and a mock vehicle.

Layers (each module imports only the ones above it):

- :mod:`.messages` - our own message dataclasses and MAVLink enums (no pymavlink);
- :mod:`.transport` - connection strings (pymavlink and MAVSDK spellings) and byte
  transports (UDP, TCP, serial);
- :mod:`.connection` - MAVLink 2 framing through pymavlink, the only module importing it;
- :mod:`.link` - one vehicle found by HEARTBEAT, traffic filtered to it;
- :mod:`.protocol` - upload / download / clear state machines with outcomes as values;
- :mod:`.transfer` - whole plans: firmware layout, mission + fence + rally, read-back;
- :mod:`.mock_vehicle` - the vehicle side, PX4 or ArduPilot flavoured, with fault injection.

Typical use::

    with VehicleLink.connect("udpin:0.0.0.0:14550") as link:
        report = upload_plan(MissionClient(link), plan)

Nothing outside :mod:`uavplan.mavlink` and :mod:`uavplan.cli` imports this package.
"""

from uavplan.mavlink.link import VehicleInfo, VehicleLink
from uavplan.mavlink.messages import Capability, MissionResult
from uavplan.mavlink.mock_vehicle import LinkFaults, MissionFaults, MockConfig, MockVehicle
from uavplan.mavlink.protocol import (
    MissionClient,
    MissionTransferError,
    Operation,
    ProtocolTimeouts,
    TransferOutcome,
    TransferStatus,
)
from uavplan.mavlink.transfer import (
    PlanDownload,
    PlanTransferReport,
    clear_plan,
    compare_items,
    download_plan,
    upload_plan,
)
from uavplan.mavlink.transport import ConnectionSpec

__all__ = [
    "Capability",
    "ConnectionSpec",
    "LinkFaults",
    "MissionClient",
    "MissionFaults",
    "MissionResult",
    "MissionTransferError",
    "MockConfig",
    "MockVehicle",
    "Operation",
    "PlanDownload",
    "PlanTransferReport",
    "ProtocolTimeouts",
    "TransferOutcome",
    "TransferStatus",
    "VehicleInfo",
    "VehicleLink",
    "clear_plan",
    "compare_items",
    "download_plan",
    "upload_plan",
]
