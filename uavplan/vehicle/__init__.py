"""The vehicle's physics: a multirotor power model, wind, the battery, bundled vehicle profiles.

A vocabulary-level package (numpy only; nothing of files, MAVLink or planners), so the
planner, the report, the simulated vehicle and the CLI can all use it:

* :mod:`~uavplan.vehicle.profile` — :class:`VehicleProfile`, validated, with overrides;
* :mod:`~uavplan.vehicle.profiles` — the bundled ``small-quad``, ``x500`` and ``heavy-lift``
  profiles and the source of every figure;
* :mod:`~uavplan.vehicle.power` — electrical power in hover, forward flight, climb and descent;
* :mod:`~uavplan.vehicle.wind` — wind by meteorological direction, optionally by height;
* :mod:`~uavplan.vehicle.legs` — time, energy and battery use of a flown path, leg by leg;
* :mod:`~uavplan.vehicle.constants` — every generic constant, with its source.

docs/energy.md describes the model, its limits and its sources.
"""

from uavplan.vehicle.legs import (
    DEFAULT_RESERVE_PCT,
    EnergyBudgetError,
    FlightEnergy,
    Legs,
    WindTooStrongError,
    flight_energy,
)
from uavplan.vehicle.power import (
    air_density_kg_m3,
    electrical_power_w,
    hover_power_w,
    hover_time_s,
    power_terms,
)
from uavplan.vehicle.profile import VehicleProfile
from uavplan.vehicle.profiles import PROFILES, resolve
from uavplan.vehicle.wind import Wind

__all__ = [
    "DEFAULT_RESERVE_PCT",
    "PROFILES",
    "EnergyBudgetError",
    "FlightEnergy",
    "Legs",
    "VehicleProfile",
    "Wind",
    "WindTooStrongError",
    "air_density_kg_m3",
    "electrical_power_w",
    "flight_energy",
    "hover_power_w",
    "hover_time_s",
    "power_terms",
    "resolve",
]
