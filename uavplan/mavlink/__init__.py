"""MAVLink for missions: connections and the mission protocol client (the ground side).

Layers (each module imports only the ones above it):

- :mod:`.messages` - our own message dataclasses and MAVLink enums (no pymavlink);
- :mod:`.modes` - PX4's and ArduPilot Copter's flight modes in HEARTBEAT.custom_mode;
- :mod:`.transport` - connection strings (pymavlink and MAVSDK spellings) and byte
  transports (UDP, TCP, serial);
- :mod:`.connection` - MAVLink 2 framing through pymavlink, the only module importing it;
- :mod:`.link` - one vehicle found by HEARTBEAT, traffic filtered to it;
- :mod:`.machines` - upload / download / clear state machines (no I/O, the time passed in);
- :mod:`.protocol` - the client driving them over a link, outcomes as values;
- :mod:`.transfer` - whole plans: firmware layout, mission + fence + rally, read-back;
- :mod:`.flightmachines` - flying a mission: pre-flight checks, command sequences, the
  monitor, as state machines without I/O;
- :mod:`.flightclient` - their driver over a link.

(The seeded UDP fault proxy the link-chaos tests put between two endpoints is test harness:
tests/helpers/faultproxy.py.)

The vehicle side (the simulated PX4 / ArduPilot vehicle, its mission-protocol server and its
faults) is :mod:`uavplan.sim`, a layer above this one.

Typical use::

    with VehicleLink.connect("udpin:0.0.0.0:14550") as link:
        report = upload_plan(MissionClient(link), plan)

Nothing outside :mod:`uavplan.mavlink` and :mod:`uavplan.cli` imports this package.
"""

from __future__ import annotations

from uavplan.lazy import lazy_exports

#: public name -> module that defines it; imported on first use, so that importing one
#: submodule (the CLI's upload path) does not pull in the rest
_EXPORTS = {
    "VehicleInfo": "link",
    "VehicleLink": "link",
    "Capability": "messages",
    "MissionResult": "messages",
    "MissionClient": "protocol",
    "MissionTransferError": "protocol",
    "Operation": "protocol",
    "ProtocolTimeouts": "protocol",
    "TransferOutcome": "protocol",
    "TransferStatus": "protocol",
    "PlanDownload": "transfer",
    "PlanTransferReport": "transfer",
    "clear_plan": "transfer",
    "compare_items": "transfer",
    "download_plan": "transfer",
    "upload_plan": "transfer",
    "ConnectionSpec": "transport",
}

__all__ = sorted(_EXPORTS)


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
