"""Electrical power of a multirotor: hover, level forward flight, climb and descent.

The standard rotary-wing model, vectorised over arrays of flight states (numpy broadcasting:
``airspeed_m_s``, ``vertical_speed_m_s`` and ``air_density_kg_m3`` may be scalars or arrays of
matching shapes). Symbols: weight W = m·g, total disc area A, air density ρ, thrust T.

* Hover (momentum theory): T = W, induced velocity v_h = sqrt(T / (2ρA)), ideal power
  P_id = T·v_h = T^1.5 / sqrt(2ρA). The rotors' shaft power is P_id / FM (figure of merit); of
  it κ·P_id is induced power and the rest, P_0 = P_id·(1/FM − κ), blade profile power. For
  fixed-pitch rotors the tip speed grows as U = sqrt(T / (ρ A C_T)) (constant thrust
  coefficient), so P_0 scales with thrust and density exactly like P_id, and FM is a property
  of the rotor, not of the load.
* Level flight at airspeed V ([Zeng] eq. 12, with the thrust that also carries the drag):
  D = ½ρfV² (f the airframe's equivalent flat-plate drag area), T = sqrt(W² + D²), and
  P(V) = P_0(T)·(1 + 3V²/U(T)²) + κ·P_id(T)·r(V) + D·V, where
  r(V) = v_i/v_h = sqrt(sqrt(1 + V⁴/(4 v_h⁴)) − V²/(2 v_h²)) is Glauert's induced-velocity
  ratio. With T = W this is exactly [Zeng] eq. 12 (D·V = ½ρfV³).
* Climb and descent at vertical speed V_c ([Leishman] §2.13-2.14), at the same airspeed:
  with v_f = v_h·r(V) the induced velocity at that airspeed and x = V_c / v_f, the
  induced-plus-climb power is W·V_c + T·v_f·g(x), where
  g(x) = κ·(−x/2 + sqrt(x²/4 + 1)) in climb (x ≥ 0),
  g(x) = κ + k1·x + k2·x² + k3·x³ + k4·x⁴ through the vortex-ring state (−2 ≤ x < 0, the
  empirical fit of [Leishman] §2.14), and g(x) = κ·(−x/2 − sqrt(x²/4 − 1)) in the windmill
  brake state (x < −2). At V = 0 these are Leishman's axial-flight results; at high airspeed
  v_f → 0 and the vertical term tends to W·V_c, the rate of change of potential energy.
  Fixed-pitch rotors on ESCs do not give energy back: the induced-plus-climb power is
  clamped at zero, so the electrical power never drops below the profile, parasite and
  avionics power (and is never negative).
* Electrical power: P_e = P_avionics + P_shaft / η (motor and ESC efficiency).

A profile with *measured* figures (``hover_power_w``, and optionally ``cruise_power_w`` at
``cruise_speed_m_s``) keeps the shape of the model and is calibrated to them: the shaft power
is scaled so that the hover power is the measured one, and the drag area is the one that makes
the power at the cruise speed the measured one (both at the ISA sea-level density).

The airspeed here is the horizontal speed through the air (ground velocity minus wind, see
:mod:`uavplan.airframe.legs`); vertical wind and the fuselage's vertical drag are ignored.
Sources and constants: :mod:`uavplan.airframe.constants`; docs/energy.md.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

import uavplan.airframe.constants as C
from uavplan.errors import InputError


class Airframe(Protocol):
    """What the power model reads of a vehicle (a
    :class:`~uavplan.airframe.profile.VehicleProfile`; a protocol here, so the profile, which
    checks itself with :func:`calibration`, and this module do not import each other)."""

    @property
    def mass_kg(self) -> float: ...
    @property
    def rotor_count(self) -> int: ...
    @property
    def rotor_diameter_m(self) -> float: ...
    @property
    def max_airspeed_m_s(self) -> float: ...
    @property
    def avionics_power_w(self) -> float: ...
    @property
    def figure_of_merit(self) -> float: ...
    @property
    def induced_power_factor(self) -> float: ...
    @property
    def motor_esc_efficiency(self) -> float: ...
    @property
    def thrust_coefficient(self) -> float: ...
    @property
    def drag_area_m2(self) -> float | None: ...
    @property
    def hover_power_w(self) -> float | None: ...
    @property
    def cruise_power_w(self) -> float | None: ...
    @property
    def cruise_speed_m_s(self) -> float | None: ...
    @property
    def usable_wh(self) -> float: ...


def air_density_kg_m3(altitude_amsl_m: ArrayLike = 0.0) -> NDArray[np.float64]:
    """ISA air density (kg/m³) at ``altitude_amsl_m`` (metres above mean sea level; an array
    gives an array): ρ = ρ0·(1 − L·h/T0)^(g/(R·L) − 1), valid from −500 m to 11 km."""
    h = np.asarray(altitude_amsl_m, dtype=np.float64)
    if not np.all(np.isfinite(h)) or np.any(h < -500.0) or np.any(h > C.ISA_MAX_ALTITUDE_M):
        raise InputError(
            f"altitude must be between -500 and {C.ISA_MAX_ALTITUDE_M:g} m AMSL for the "
            "standard atmosphere",
            key="altitude_amsl_m",
        )
    exponent = C.GRAVITY_M_S2 / (C.AIR_GAS_CONSTANT_J_KG_K * C.ISA_LAPSE_RATE_K_M) - 1.0
    ratio = 1.0 - C.ISA_LAPSE_RATE_K_M * h / C.ISA_SEA_LEVEL_TEMPERATURE_K
    return C.ISA_SEA_LEVEL_DENSITY_KG_M3 * ratio**exponent


@dataclass(frozen=True)
class PowerTerms:
    """The parts of the electrical power (W), arrays of the broadcast shape of the states.

    ``profile_w``, ``induced_w`` (induced plus climb, clamped at 0) and ``parasite_w`` are shaft
    powers; ``total_w`` is the electrical power: avionics + (their sum) / η.
    """

    profile_w: NDArray[np.float64]
    induced_w: NDArray[np.float64]
    parasite_w: NDArray[np.float64]
    avionics_w: float
    total_w: NDArray[np.float64]


@dataclass(frozen=True)
class RotorState:
    """What the model derives from a profile at an air density (SI units). Fields that depend
    on the density are arrays of its shape (0-d for a scalar density)."""

    thrust_n: float
    disc_area_m2: float
    hover_induced_velocity_m_s: NDArray[np.float64]  # v_h
    ideal_power_w: NDArray[np.float64]  # P_id = T·v_h
    profile_power_w: NDArray[np.float64]  # P_0 in hover
    tip_speed_m_s: NDArray[np.float64]  # U
    drag_area_m2: float  # f
    shaft_scale: float  # 1, or the calibration to a measured hover power


def disc_area_m2(profile: Airframe) -> float:
    """Total disc area of the rotors (m²): n·π·(D/2)²."""
    return profile.rotor_count * math.pi * (profile.rotor_diameter_m / 2.0) ** 2


def _density(air_density_kg_m3: ArrayLike) -> NDArray[np.float64]:
    rho = np.asarray(air_density_kg_m3, dtype=np.float64)
    if not (np.all(np.isfinite(rho)) and np.all(rho > 0)):
        raise InputError("air density must be a positive number", key="air_density_kg_m3")
    return rho


def _default_drag_area(profile: Airframe) -> float:
    if profile.drag_area_m2 is not None:
        return float(profile.drag_area_m2)
    return C.DRAG_AREA_PER_DISC_AREA * disc_area_m2(profile)


def _physical_state(profile: Airframe, rho: NDArray[np.float64]) -> RotorState:
    weight = profile.mass_kg * C.GRAVITY_M_S2
    area = disc_area_m2(profile)
    v_h = np.sqrt(weight / (2.0 * rho * area))
    ideal = weight * v_h
    p0 = ideal * (1.0 / profile.figure_of_merit - profile.induced_power_factor)
    tip = np.sqrt(weight / (rho * area * profile.thrust_coefficient))
    return RotorState(weight, area, v_h, ideal, p0, tip, _default_drag_area(profile), 1.0)


def rotor_state(profile: Airframe, air_density_kg_m3: ArrayLike) -> RotorState:
    """The derived hover quantities at ``air_density_kg_m3``, measured figures applied."""
    state = _physical_state(profile, _density(air_density_kg_m3))
    if profile.hover_power_w is None:
        return state
    scale, drag = calibration(profile)
    return dataclasses.replace(state, drag_area_m2=drag, shaft_scale=scale)


def calibration(profile: Airframe) -> tuple[float, float]:
    """(shaft-power scale, drag area m²) that make the model reproduce the profile's measured
    ``hover_power_w`` and ``cruise_power_w`` at sea level. Raises :class:`InputError` when the
    measured figures cannot both hold (a hover power below the avionics power, a cruise power
    below the model's induced and profile power at that speed with no drag at all)."""
    if profile.hover_power_w is None:
        raise ValueError("profile has no measured hover power")
    rho = np.asarray(C.ISA_SEA_LEVEL_DENSITY_KG_M3)
    eta = profile.motor_esc_efficiency
    hover_shaft = (profile.hover_power_w - profile.avionics_power_w) * eta
    if hover_shaft <= 0:
        raise InputError(
            f"{profile.hover_power_w:g} W is not above the avionics power "
            f"({profile.avionics_power_w:g} W)",
            key="hover_power_w",
        )
    ideal = float(_physical_state(profile, rho).ideal_power_w)
    scale = hover_shaft / (ideal / profile.figure_of_merit)
    if profile.cruise_power_w is None:
        return scale, _default_drag_area(profile)
    assert profile.cruise_speed_m_s is not None  # the profile checks this
    v = np.asarray(profile.cruise_speed_m_s)
    target = (profile.cruise_power_w - profile.avionics_power_w) * eta / scale

    def shaft(drag: float) -> float:
        return float(sum(_shaft_terms(profile, v, np.asarray(0.0), rho, drag)))

    if shaft(0.0) > target:
        lowest = profile.avionics_power_w + scale * shaft(0.0) / eta
        raise InputError(
            f"{profile.cruise_power_w:g} W at {float(v):g} m/s is below what this hover power "
            f"allows at that speed ({lowest:.1f} W with no drag at all)",
            key="cruise_power_w",
        )
    low, high = 0.0, 1.0
    while shaft(high) < target:
        high *= 2.0
    for _ in range(60):  # the shaft power grows with the drag area: bisect
        mid = (low + high) / 2.0
        low, high = (mid, high) if shaft(mid) < target else (low, mid)
    return scale, (low + high) / 2.0


def scale_and_drag(profile: Airframe) -> tuple[float, float]:
    """(shaft-power scale, drag area m²) the model flies ``profile`` with: 1 and the profile's
    (or the generic) drag area, or the calibration to its measured figures."""
    if profile.hover_power_w is None:
        return 1.0, _default_drag_area(profile)
    return calibration(profile)


def _induced_ratio(airspeed: NDArray[np.float64], v_h: NDArray[np.float64]) -> NDArray[np.float64]:
    """Glauert's v_i/v_h in level flight, sqrt(sqrt(1 + a²) − a) with a = V²/(2 v_h²), written
    without the cancellation at high speed."""
    a = airspeed**2 / (2.0 * v_h**2)
    return np.sqrt(1.0 / (np.sqrt(1.0 + a * a) + a))


def _vertical_factor(x: NDArray[np.float64], kappa: float) -> NDArray[np.float64]:
    """g(x): induced velocity over v_f in axial flight at x = V_c / v_f (non-ideal, with κ)."""
    k1, k2, k3, k4 = C.VORTEX_RING_FIT
    half = x / 2.0
    with np.errstate(invalid="ignore", divide="ignore"):
        # climb: −x/2 + sqrt(x²/4 + 1) = 1 / (x/2 + sqrt(x²/4 + 1))
        climb = kappa / (half + np.sqrt(half * half + 1.0))
        # windmill brake: −x/2 − sqrt(x²/4 − 1) = 1 / (−x/2 + sqrt(x²/4 − 1))
        windmill = kappa / (-half + np.sqrt(np.maximum(half * half - 1.0, 0.0)))
    ring = kappa + x * (k1 + x * (k2 + x * (k3 + x * k4)))
    return np.where(x >= 0.0, climb, np.where(x >= -2.0, ring, windmill))


def _shaft_terms(
    profile: Airframe,
    airspeed: NDArray[np.float64],
    vertical: NDArray[np.float64],
    rho: NDArray[np.float64],
    drag_area_m2: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """(blade profile, induced + climb, parasite) shaft powers before the calibration scale.

    The rotors carry the weight and the airframe's drag, T = sqrt(W² + D²) with
    D = ½ρfV²; the rotor quantities follow T as in hover (fixed pitch: P_0 ∝ T^1.5)."""
    weight = profile.mass_kg * C.GRAVITY_M_S2
    area = disc_area_m2(profile)
    kappa = profile.induced_power_factor
    drag = 0.5 * rho * drag_area_m2 * airspeed**2
    thrust = np.sqrt(weight**2 + drag**2)
    v_h = np.sqrt(thrust / (2.0 * rho * area))
    p0 = thrust * v_h * (1.0 / profile.figure_of_merit - kappa)
    tip_sq = thrust / (rho * area * profile.thrust_coefficient)
    blade = p0 * (1.0 + 3.0 * airspeed**2 / tip_sq)
    v_f = v_h * _induced_ratio(airspeed, v_h)
    x = vertical / v_f
    induced = np.maximum(weight * vertical + thrust * v_f * _vertical_factor(x, kappa), 0.0)
    parasite = drag * airspeed
    return blade, induced, parasite


def power_terms(
    profile: Airframe,
    airspeed_m_s: ArrayLike = 0.0,
    vertical_speed_m_s: ArrayLike = 0.0,
    *,
    air_density_kg_m3: ArrayLike = C.ISA_SEA_LEVEL_DENSITY_KG_M3,
) -> PowerTerms:
    """The electrical power and its parts at each state (airspeed ≥ 0 horizontal, vertical
    speed positive up, air density), broadcast over the three arrays."""
    v = np.asarray(airspeed_m_s, dtype=np.float64)
    vz = np.asarray(vertical_speed_m_s, dtype=np.float64)
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(vz))):
        raise InputError("speeds must be finite numbers", key="airspeed_m_s")
    if np.any(v < 0):
        raise InputError("an airspeed is a magnitude and cannot be negative", key="airspeed_m_s")
    v, vz, rho = np.broadcast_arrays(v, vz, _density(air_density_kg_m3))
    if profile.hover_power_w is None:
        scale, drag_area = 1.0, _default_drag_area(profile)
    else:
        scale, drag_area = calibration(profile)
    blade, induced, parasite = _shaft_terms(profile, v, vz, rho, drag_area)
    blade, induced, parasite = scale * blade, scale * induced, scale * parasite
    total = profile.avionics_power_w + (blade + induced + parasite) / profile.motor_esc_efficiency
    return PowerTerms(blade, induced, parasite, profile.avionics_power_w, total)


def electrical_power_w(
    profile: Airframe,
    airspeed_m_s: ArrayLike = 0.0,
    vertical_speed_m_s: ArrayLike = 0.0,
    *,
    air_density_kg_m3: ArrayLike = C.ISA_SEA_LEVEL_DENSITY_KG_M3,
) -> NDArray[np.float64]:
    """Electrical power (W) drawn from the battery at each state; see :func:`power_terms`."""
    return power_terms(
        profile, airspeed_m_s, vertical_speed_m_s, air_density_kg_m3=air_density_kg_m3
    ).total_w


def hover_power_w(
    profile: Airframe, *, air_density_kg_m3: float = C.ISA_SEA_LEVEL_DENSITY_KG_M3
) -> float:
    """Electrical power (W) in a still-air hover."""
    return float(electrical_power_w(profile, 0.0, 0.0, air_density_kg_m3=air_density_kg_m3))


def hover_time_s(
    profile: Airframe, *, air_density_kg_m3: float = C.ISA_SEA_LEVEL_DENSITY_KG_M3
) -> float:
    """How long the usable energy lasts in a still-air hover (s)."""
    return profile.usable_wh * 3600.0 / hover_power_w(profile, air_density_kg_m3=air_density_kg_m3)


def minimum_power_speed_m_s(
    profile: Airframe,
    *,
    air_density_kg_m3: float = C.ISA_SEA_LEVEL_DENSITY_KG_M3,
    step_m_s: float = 0.05,
) -> float:
    """The level-flight airspeed of least power (the bottom of the bucket), searched on a
    ``step_m_s`` grid up to the profile's maximum airspeed."""
    speeds = np.arange(0.0, profile.max_airspeed_m_s + step_m_s / 2, step_m_s)
    power = electrical_power_w(profile, speeds, air_density_kg_m3=air_density_kg_m3)
    return float(speeds[int(np.argmin(power))])
