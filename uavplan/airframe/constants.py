"""Every physical constant of the power model that is not on a vehicle's spec sheet, in one place.

These are *generic*: the bundled profiles all use them unchanged, and none was chosen to make
one vehicle's hover time come out right (docs/energy.md compares the results with each
vehicle's published figure). A profile may still override any of them (a measured figure of
merit, a real avionics load); the bundled ones do not.

Sources (docs/energy.md gives the full list):

* [Leishman] J. G. Leishman, *Principles of Helicopter Aerodynamics*, 2nd ed., Cambridge
  University Press, 2006: momentum theory in hover, climb and descent (ch. 2), the induced
  power factor κ and the empirical fit through the vortex-ring state (§2.14).
* [Zeng] Y. Zeng, J. Xu, R. Zhang, "Energy Minimization for Wireless Communication With
  Rotary-Wing UAV", IEEE Trans. Wireless Communications 18(4), 2019, eq. 12 and Table I: the
  forward-flight power of a rotary-wing vehicle (blade profile, induced, parasite).
* [Hein] B. R. Hein, I. Chopra, "Hover Performance of a Micro Air Vehicle: Rotors at Low
  Reynolds Number", Journal of the American Helicopter Society, 2007: small rotors reach a
  figure of merit of about 0.5-0.6, well below a full-scale rotor's 0.7-0.8 [Leishman §2.6].
* [Brandt] J. B. Brandt, M. S. Selig, "Propeller Performance Data at Low Reynolds Numbers",
  AIAA 2011-1255 (UIUC propeller database): static thrust coefficients of small fixed-pitch
  propellers around C_T = T/(ρ n² D⁴) ≈ 0.1.
* [ISA] ISO 2533:1975, the International Standard Atmosphere (troposphere, below 11 km).
"""

from __future__ import annotations

#: standard gravity (m/s²)
GRAVITY_M_S2 = 9.80665

# --- International Standard Atmosphere (troposphere) [ISA] ---------------------------------
#: sea-level density (kg/m³), temperature (K) and lapse rate (K/m)
ISA_SEA_LEVEL_DENSITY_KG_M3 = 1.225
ISA_SEA_LEVEL_TEMPERATURE_K = 288.15
ISA_LAPSE_RATE_K_M = 0.0065
#: specific gas constant of dry air (J/(kg·K))
AIR_GAS_CONSTANT_J_KG_K = 287.05287
#: the ISA formula here holds up to the tropopause
ISA_MAX_ALTITUDE_M = 11_000.0

# --- rotor aerodynamics ----------------------------------------------------------------------
#: κ, induced power over ideal (momentum-theory) induced power: tip losses, non-uniform
#: inflow. [Leishman] §2.6 gives 1.15 as typical; the vortex-ring fit below is written with it.
INDUCED_POWER_FACTOR = 1.15

#: FM, the hover figure of merit: ideal induced power over the rotor's shaft power in hover.
#: Small fixed-pitch rotors at low Reynolds number: 0.5-0.6 [Hein]; we take the middle.
FIGURE_OF_MERIT = 0.55

#: shaft power over electrical power drawn from the battery: brushless motor (0.8-0.9 in its
#: operating range) times ESC (0.9-0.95); we take 0.80 for the product
MOTOR_ESC_EFFICIENCY = 0.80

#: thrust coefficient of a fixed-pitch propeller near hover, in the rotorcraft convention
#: C_T = T / (ρ A (ΩR)²). [Brandt]'s static C_T ≈ 0.1 is in the propeller convention
#: T / (ρ n² D⁴); the two differ by π³/4 ≈ 7.75, so C_T ≈ 0.1 / 7.75 ≈ 0.013. It sets the
#: blade tip speed, U = sqrt(T / (ρ A C_T)), that scales the blade profile power with
#: airspeed in [Zeng] eq. 12.
THRUST_COEFFICIENT = 0.013

#: equivalent flat-plate drag area f of the airframe over the rotors' total disc area A.
#: [Zeng] Table I gives d0·s = 0.6 × 0.05 = 0.03 (fuselage drag ratio times rotor solidity),
#: a helicopter-like airframe; a multirotor's arms, motors, gimbal and landing gear drag far
#: more. We derive the ratio from one published pair of figures instead: the DJI Mavic 2 hovers
#: 29 min and flies 18 km at a constant 50 km/h (21.6 min), so its power at 13.9 m/s is
#: 29 / 21.6 = 1.34 times its hover power; with the constants above that takes
#: f = 0.031 m², f/A = 0.20 (docs/energy.md "Drag"). Its other figure, 31 min at 25 km/h,
#: then comes out within 6 %. Hover power does not depend on it. The same ratio is used for
#: every profile; a profile with a measured drag area sets ``drag_area_m2``.
DRAG_AREA_PER_DISC_AREA = 0.20

#: [Leishman] §2.14's fit of the induced velocity through the vortex-ring state, for
#: -2 ≤ V_c/v_h ≤ 0: v_i/v_h = κ + k1 x + k2 x² + k3 x³ + k4 x⁴, x = V_c/v_h
VORTEX_RING_FIT = (-1.125, -1.372, -1.718, -0.655)

# --- electrical and battery -----------------------------------------------------------------
#: flight controller, GNSS, radios, companion computer: an assumption (no spec sheet gives it);
#: a camera or gimbal payload adds to it (override ``avionics_power_w``)
AVIONICS_POWER_W = 10.0

#: share of the rated energy (capacity × nominal voltage) a pack delivers between full and the
#: vehicle's own "empty" (its critical-battery landing). At the ~1 C of a multirotor a LiPo
#: gives close to its rated energy down to 3.3-3.5 V per cell; 5 % allows for that cut-off
#: and for ageing. The operator's reserve comes on top (``legs.DEFAULT_RESERVE_PCT``).
BATTERY_USABLE_FRACTION = 0.95

# --- wind -----------------------------------------------------------------------------------
#: the height a wind report refers to (m above ground): the WMO standard for surface wind
WIND_REFERENCE_HEIGHT_M = 10.0
