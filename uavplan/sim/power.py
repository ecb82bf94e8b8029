"""The simulated vehicle's battery: drained by one power function of the flight state.

:func:`power_w` is the only place that says how much power the vehicle draws; issue 27
replaces its constant hover-class figure with a power model (hover, forward flight, climb
and descent). :class:`Battery` integrates it over simulated time and reports what
SYS_STATUS and BATTERY_STATUS carry.

The default vehicle is an X500-class quadcopter: the PX4 Gazebo ``x500`` model's mass,
2.0 kg (PX4-gazebo-models ``models/x500_base/model.sdf``), four 10-inch rotors (the Holybro
X500 V2 kit's 1045 propellers) and a 4S LiPo (16.8 V full, 13.2 V empty: ArduPilot's
``Tools/Frame_params/Holybro-X500v2-bdshot.param`` MOT_BAT_VOLT_MAX / MOT_BAT_VOLT_MIN) of
5000 mAh. Its hover power is momentum theory's ideal power ``sqrt(T³ / (2 ρ A))`` for that
weight and disc area, divided by an overall efficiency of 0.5 (rotor figure of merit times
motor and ESC efficiency): about 245 W, a hover of about 15 minutes on 80 % of the pack. An
estimate, not a measurement; docs/flight-model.md says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["X500", "Battery", "PowerState", "VehicleSpec", "hover_power_w", "power_w"]

GRAVITY_M_S2 = 9.80665
AIR_DENSITY_KG_M3 = 1.225


@dataclass(frozen=True)
class VehicleSpec:
    """The physical vehicle the battery belongs to."""

    mass_kg: float
    rotor_diameter_m: float
    rotors: int
    efficiency: float
    cells: int
    capacity_mah: float
    full_cell_v: float = 4.2
    empty_cell_v: float = 3.3

    def __post_init__(self) -> None:
        for name in ("mass_kg", "rotor_diameter_m", "efficiency", "capacity_mah"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"{name} must be > 0")
        if not (0.0 < self.efficiency <= 1.0):
            raise ValueError("efficiency must be within (0, 1]")
        if self.rotors < 1 or self.cells < 1:
            raise ValueError("a vehicle needs rotors and cells")


#: the PX4 x500 model's mass, the X500 V2 kit's 10-inch rotors, a 4S 5000 mAh pack
X500 = VehicleSpec(
    mass_kg=2.0, rotor_diameter_m=0.254, rotors=4, efficiency=0.5, cells=4, capacity_mah=5000.0
)


def hover_power_w(spec: VehicleSpec) -> float:
    """Electrical hover power: momentum theory's ideal power over ``spec.efficiency``."""
    thrust = spec.mass_kg * GRAVITY_M_S2
    area = spec.rotors * math.pi * (spec.rotor_diameter_m / 2.0) ** 2
    return math.sqrt(thrust**3 / (2.0 * AIR_DENSITY_KG_M3 * area)) / spec.efficiency


@dataclass(frozen=True)
class PowerState:
    """What the power draw depends on: motors spinning, in the air, speeds (m/s)."""

    armed: bool
    airborne: bool
    speed_xy_m_s: float = 0.0
    climb_m_s: float = 0.0


def power_w(state: PowerState, spec: VehicleSpec = X500) -> float:
    """Electrical power the vehicle draws (W). For now the hover power whenever it is in the
    air (speed and climb do not change it: issue 27's power model will), 10 % of it while
    the motors idle armed on the ground, nothing disarmed (avionics are not counted)."""
    if not state.armed:
        return 0.0
    hover = hover_power_w(spec)
    return hover if state.airborne else 0.1 * hover


class Battery:
    """A pack drained by :func:`power_w`: remaining charge, voltage (linear in the charge
    between the cell's full and empty voltage), current."""

    def __init__(self, spec: VehicleSpec = X500) -> None:
        self.spec = spec
        self.used_mah = 0.0
        self.used_wh = 0.0
        self.current_a = 0.0

    @property
    def remaining_fraction(self) -> float:
        return max(0.0, 1.0 - self.used_mah / self.spec.capacity_mah)

    @property
    def cell_voltage_v(self) -> float:
        s = self.spec
        return s.empty_cell_v + (s.full_cell_v - s.empty_cell_v) * self.remaining_fraction

    @property
    def voltage_v(self) -> float:
        return self.cell_voltage_v * self.spec.cells

    def drain(self, state: PowerState, dt_s: float) -> None:
        """Draw ``power_w(state)`` for ``dt_s`` seconds."""
        watts = power_w(state, self.spec)
        volts = self.voltage_v
        self.current_a = watts / volts if volts > 0 else 0.0
        self.used_wh += watts * dt_s / 3600.0
        self.used_mah += self.current_a * dt_s / 3.6

    def time_remaining_s(self, state: PowerState) -> float | None:
        """Seconds until empty at the current draw, or ``None`` when nothing is drawn."""
        watts = power_w(state, self.spec)
        if watts <= 0.0:
            return None
        remaining_wh = self.remaining_fraction * self.spec.capacity_mah / 1000.0 * self.voltage_v
        return remaining_wh * 3600.0 / watts
