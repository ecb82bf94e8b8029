"""The simulated vehicle's battery, drained by the power model of :mod:`uavplan.airframe`.

:func:`power_w` is the only place that says how much power the simulated vehicle draws: in
the air, the electrical power of the vehicle's profile (hover, forward flight, climb and
descent, docs/energy.md) at its airspeed (ground velocity minus the wind), vertical speed
and air density; armed on the ground, its idle (a share of the hover power, below); disarmed,
nothing. :func:`power_w_array` is the same, vectorised over a flown track (``simulate``), so a
simulated flight's energy and the estimate's (:mod:`uavplan.estimate`) come from one model.
:class:`Battery` integrates it over simulated time and reports what SYS_STATUS and
BATTERY_STATUS carry.

The battery's energy is the profile's: "remaining" is the share of its *usable* energy
(``battery_wh × battery_usable_fraction``, what the estimate's "battery used %" is a share
of) left, so the vehicle's BATTERY_STATUS and the estimate speak of the same percentage. The
pack's voltage is linear in that share between 4.2 V and 3.3 V per cell (ArduPilot's
``Tools/Frame_params/Holybro-X500v2-bdshot.param``: MOT_BAT_VOLT_MAX 16.8 V / MOT_BAT_VOLT_MIN
13.2 V for the 4S X500), and its charge is the energy over the nominal 3.7 V per cell.

The default vehicle is the ``x500`` profile (Holybro X500 V2 with a 4S 5000 mAh pack);
``uavplan mock-vehicle --profile`` picks another bundled one.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uavplan.airframe import VehicleProfile, air_density_kg_m3, electrical_power_w, resolve
from uavplan.airframe import hover_power_w as _hover_power_w

__all__ = [
    "CELLS",
    "X500",
    "Battery",
    "PowerState",
    "VehicleSpec",
    "hover_power_w",
    "power_w",
    "power_w_array",
    "spec_for",
]

#: a LiPo cell's nominal voltage (V): the pack's charge is its energy over this
NOMINAL_CELL_V = 3.7
#: armed on the ground, the motors idle: this share of the hover power (ArduPilot spins them
#: at MOT_SPIN_ARM, 0.07-0.1 of full throttle: an estimate, the idle is not measured)
IDLE_FRACTION = 0.1
#: cells in series of each bundled profile's pack (docs/energy.md: Mavic 2 and X500 V2 4S
#: LiPo; the Matrice 600 Pro's TB47S packs are 6S, flown in parallel)
CELLS: Mapping[str, int] = MappingProxyType({"small-quad": 4, "x500": 4, "heavy-lift": 6})


@dataclass(frozen=True)
class VehicleSpec:
    """The simulated vehicle's physics: its power model profile and its pack's cells."""

    profile: VehicleProfile
    cells: int = 4
    full_cell_v: float = 4.2
    empty_cell_v: float = 3.3
    idle_fraction: float = IDLE_FRACTION
    _hover_w: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.cells < 1:
            raise ValueError("a pack needs cells")
        if not (0.0 < self.empty_cell_v < self.full_cell_v):
            raise ValueError("the empty cell voltage must be below the full one")
        if not (0.0 <= self.idle_fraction <= 1.0):
            raise ValueError("idle_fraction must be within [0, 1]")
        object.__setattr__(self, "_hover_w", _hover_power_w(self.profile))

    @property
    def name(self) -> str:
        return self.profile.name

    @property
    def usable_wh(self) -> float:
        return self.profile.usable_wh

    @property
    def capacity_mah(self) -> float:
        """The pack's charge: its rated energy over the nominal cell voltage."""
        return self.profile.battery_wh / (self.cells * NOMINAL_CELL_V) * 1000.0

    @property
    def hover_w(self) -> float:
        """Still-air hover power at sea level (W)."""
        return self._hover_w


def spec_for(profile: VehicleProfile, cells: int | None = None) -> VehicleSpec:
    """The simulated vehicle of ``profile``; its pack's cells from :data:`CELLS` (a profile of
    the user's own: 4 unless given)."""
    return VehicleSpec(profile, cells if cells is not None else CELLS.get(profile.name, 4))


#: the default simulated vehicle: the x500 profile, 4S
X500 = spec_for(resolve({"profile": "x500"}))


def hover_power_w(spec: VehicleSpec) -> float:
    """Electrical hover power (W) of the vehicle, still air at sea level."""
    return spec.hover_w


@dataclass(frozen=True)
class PowerState:
    """What the power draw depends on: motors spinning, in the air, speeds (m/s), the air.

    ``airspeed_m_s``: horizontal speed through the air (None: the ground speed, calm air);
    ``altitude_amsl_m``: for the air density (ISA).
    """

    armed: bool
    airborne: bool
    speed_xy_m_s: float = 0.0
    climb_m_s: float = 0.0
    airspeed_m_s: float | None = None
    altitude_amsl_m: float = 0.0


def power_w(state: PowerState, spec: VehicleSpec = X500) -> float:
    """Electrical power the vehicle draws (W): the power model in the air, the idle armed on
    the ground, nothing disarmed."""
    if not state.armed:
        return 0.0
    if not state.airborne:
        return spec.idle_fraction * spec.hover_w
    airspeed = state.speed_xy_m_s if state.airspeed_m_s is None else state.airspeed_m_s
    return float(
        electrical_power_w(
            spec.profile,
            abs(airspeed),
            state.climb_m_s,
            air_density_kg_m3=air_density_kg_m3(_isa_range(state.altitude_amsl_m)),
        )
    )


def power_w_array(
    spec: VehicleSpec,
    *,
    armed: ArrayLike,
    airborne: ArrayLike,
    airspeed_m_s: ArrayLike,
    climb_m_s: ArrayLike,
    altitude_amsl_m: ArrayLike,
) -> NDArray[np.float64]:
    """:func:`power_w` of every state of a track at once (arrays of one shape)."""
    armed_a = np.asarray(armed, dtype=bool)
    air = np.asarray(airborne, dtype=bool) & armed_a
    rho = air_density_kg_m3(_isa_range(np.asarray(altitude_amsl_m, dtype=np.float64)))
    flying = electrical_power_w(
        spec.profile,
        np.abs(np.asarray(airspeed_m_s, dtype=np.float64)),
        np.asarray(climb_m_s, dtype=np.float64),
        air_density_kg_m3=rho,
    )
    idle = np.where(armed_a, spec.idle_fraction * spec.hover_w, 0.0)
    return np.where(air, flying, idle)


def _isa_range(altitude_amsl_m: ArrayLike) -> NDArray[np.float64]:
    """Altitudes clipped to the standard atmosphere's range (a simulated vehicle may fly
    anywhere; the density model holds from -500 m to 11 km)."""
    return np.clip(np.asarray(altitude_amsl_m, dtype=np.float64), -500.0, 11_000.0)


class Battery:
    """A pack drained by :func:`power_w`: energy used, the share of the usable energy left,
    voltage (linear in it between the cell's full and empty voltage), current."""

    def __init__(self, spec: VehicleSpec = X500) -> None:
        self.spec = spec
        self.used_wh = 0.0
        self.used_mah = 0.0
        self.current_a = 0.0

    @property
    def used_pct(self) -> float:
        """Energy used, % of the usable energy (the estimate's "battery used %")."""
        return 100.0 * self.used_wh / self.spec.usable_wh

    @property
    def remaining_fraction(self) -> float:
        return max(0.0, 1.0 - self.used_wh / self.spec.usable_wh)

    @property
    def cell_voltage_v(self) -> float:
        s = self.spec
        return s.empty_cell_v + (s.full_cell_v - s.empty_cell_v) * self.remaining_fraction

    @property
    def voltage_v(self) -> float:
        return self.cell_voltage_v * self.spec.cells

    def drain(self, state: PowerState, dt_s: float) -> None:
        """Draw ``power_w(state)`` for ``dt_s`` seconds."""
        self.drain_w(power_w(state, self.spec), dt_s)

    def drain_w(self, watts: float, dt_s: float) -> None:
        """Draw ``watts`` for ``dt_s`` seconds."""
        volts = self.voltage_v
        self.current_a = watts / volts if volts > 0 else 0.0
        self.used_wh += watts * dt_s / 3600.0
        self.used_mah += self.current_a * dt_s / 3.6

    def time_remaining_s(self, state: PowerState) -> float | None:
        """Seconds until the usable energy is spent at the current draw, or ``None`` when
        nothing is drawn."""
        watts = power_w(state, self.spec)
        if watts <= 0.0 or not math.isfinite(watts):
            return None
        remaining_wh = self.remaining_fraction * self.spec.usable_wh
        return remaining_wh * 3600.0 / watts
