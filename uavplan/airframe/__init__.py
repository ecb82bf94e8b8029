"""The vehicle's physics: a multirotor power model, wind, the battery, bundled vehicle profiles.

A vocabulary-level package (numpy only; nothing of files, MAVLink or planners), so the
planner, the report, the simulated vehicle and the CLI can all use it:

* :mod:`~uavplan.airframe.profile` — :class:`VehicleProfile`, validated, with overrides;
* :mod:`~uavplan.airframe.profiles` — the bundled ``small-quad``, ``x500`` and ``heavy-lift``
  profiles and the source of every figure;
* :mod:`~uavplan.airframe.power` — electrical power in hover, forward flight, climb and descent;
* :mod:`~uavplan.airframe.wind` — wind by meteorological direction, optionally by height;
* :mod:`~uavplan.airframe.legs` — time, energy and battery use of a flown path, leg by leg;
* :mod:`~uavplan.airframe.constants` — every generic constant, with its source.

docs/energy.md describes the model, its limits and its sources.
"""

from uavplan.airframe.legs import (
    DEFAULT_RESERVE_PCT,
    EnergyBudgetError,
    EnergyUse,
    Legs,
    WindTooStrongError,
    flight_energy,
)
from uavplan.airframe.power import (
    air_density_kg_m3,
    electrical_power_w,
    hover_power_w,
    hover_time_s,
    power_terms,
)
from uavplan.airframe.profile import VehicleProfile
from uavplan.airframe.profiles import PROFILES, resolve
from uavplan.airframe.wind import Wind

__all__ = [
    "DEFAULT_RESERVE_PCT",
    "PROFILES",
    "EnergyBudgetError",
    "EnergyUse",
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
