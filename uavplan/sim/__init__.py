"""The simulated vehicle: a kinematic multirotor flying missions as PX4 or ArduPilot Copter.

Layers (each module imports only the ones above it, and the vocabulary, mission and
mavlink layers of the package; nothing below :mod:`uavplan.sim` imports it):

- :mod:`.params` - each flavour's parameter table (name, default, unit, source) and the SI
  limits the flight model reads from it;
- :mod:`.kinematics` - vectors, speed profiles, wind, the firmwares' trajectory maths;
- :mod:`.model` - the flight model (:class:`~.model.FlightModel`): take-off, waypoints with
  each flavour's corners, landing, RTL, DO_CHANGE_SPEED, hold times, in simulated time;
- :mod:`.power` - the battery and the one function that says how much power is drawn;
- :mod:`.simulate` - :func:`~.simulate.simulate`: a mission plan → the flown track, no link;
- :mod:`.faults` - the one fault model (link, mission protocol, flight);
- :mod:`.mission_server` - the vehicle side of the mission protocol, sans-I/O;
- :mod:`.vehicle` - :class:`~.vehicle.SimVehicle`, the whole vehicle as a sans-I/O state
  machine (modes, arming, telemetry, parameters, the mission server, the flight model);
- :mod:`.mock` - :class:`~.mock.MockVehicle`, the thin I/O loop that puts it on a real
  MAVLink endpoint (``uavplan mock-vehicle``);

What the flight model covers and what it leaves out, with every parameter's source:
docs/flight-model.md.
"""

from __future__ import annotations

import importlib
from typing import Any

#: public name -> module that defines it; imported on first use
_EXPORTS = {
    "Faults": "faults",
    "FlightModel": "model",
    "FlownTrack": "simulate",
    "MockVehicle": "mock",
    "Parameters": "params",
    "SimVehicle": "vehicle",
    "VehicleConfig": "vehicle",
    "simulate": "simulate",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{module}"), name)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
