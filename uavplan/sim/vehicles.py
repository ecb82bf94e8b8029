"""The one way to make a simulated vehicle: the flavour's subclass of
:class:`~uavplan.sim.vehicle.SimVehicle` for ``config.autopilot``."""

from __future__ import annotations

from uavplan.mission.items import Autopilot
from uavplan.sim.ardupilot import ArduPilotVehicle
from uavplan.sim.px4 import Px4Vehicle
from uavplan.sim.vehicle import SimConfig, SimVehicle

__all__ = ["new_vehicle"]


def new_vehicle(config: SimConfig | None = None, now: float = 0.0) -> SimVehicle:
    """A simulated vehicle set up by ``config`` (the default: PX4 at PX4 SITL's home), its
    link clock at ``now``."""
    c = config or SimConfig()
    flavour = Px4Vehicle if c.autopilot == Autopilot.PX4 else ArduPilotVehicle
    return flavour(c, now)
