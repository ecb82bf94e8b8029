"""The simulated vehicle: a multirotor that speaks MAVLink as PX4 or ArduPilot Copter does and
flies the missions it holds with the flight model of :mod:`uavplan.autopilot`.

Only the I/O loop's command (``uavplan mock-vehicle``) and the tests use it; nothing in
planning, the way home, the estimate or ``fly`` imports it. Its modules, each importing only
the ones above it (and the vocabulary, mission, mavlink and autopilot layers):

- :mod:`.faults` - the one fault model (link, mission protocol, flight);
- :mod:`.mission_server` - the vehicle side of the mission protocol, sans-I/O;
- :mod:`.vehicle` - :class:`~.vehicle.SimVehicle`, the whole vehicle as a sans-I/O state
  machine (modes, arming, telemetry, parameters, the mission server, the flight model);
- :mod:`.px4` and :mod:`.ardupilot` - where each firmware's rules differ (modes, arming,
  MISSION_START, parameter encoding);
- :mod:`.vehicles` - :func:`~.vehicles.new_vehicle`, the flavour's vehicle for a config;
- :mod:`.mock` - :class:`~.mock.MockVehicle`, the thin I/O loop that puts it on a real
  MAVLink endpoint (``uavplan mock-vehicle``).
"""

from __future__ import annotations

from uavplan.lazy import lazy_exports

#: public name -> module that defines it; imported on first use
_EXPORTS = {
    "Faults": "faults",
    "MockVehicle": "mock",
    "SimVehicle": "vehicle",
    "SimConfig": "vehicle",
    "new_vehicle": "vehicles",
}

__all__ = sorted(_EXPORTS)


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
