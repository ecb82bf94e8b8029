"""The bundled vehicle profiles, every figure with its source.

Only spec-sheet figures differ between the profiles (mass, rotors, battery, top speed); the
aerodynamic and electrical constants are the generic ones of :mod:`uavplan.airframe.constants`
for all three. :data:`CITED_HOVER_TIME_S` holds the hover time each manufacturer publishes, which
the model's prediction is compared with (tests/airframe/test_power_model.py, docs/energy.md). The
x500's hover power is also checked against the kit's motor bench table (a cross-check: the
profile does not use it, it agrees with the generic model within 1 %).

* ``small-quad`` — DJI Mavic 2 Pro (a folding camera quad of under 1 kg);
* ``x500`` — Holybro X500 V2 (the PX4 development kit: 500 mm frame, 10-inch props, 4S 5000 mAh);
* ``heavy-lift`` — DJI Matrice 600 Pro with six TB47S batteries (hexacopter, 21-inch props).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

from uavplan.airframe.profile import VehicleProfile
from uavplan.errors import InputError

INCH_M = 0.0254


@dataclass(frozen=True)
class Citation:
    """Where a profile's figure comes from: the field, the value used, the page, what it says.

    ``checked`` is False for a figure read from the manufacturer's page that could not be
    re-checked against a stored copy of it when the profile was written (docs/energy.md †).
    """

    field: str
    value: str
    url: str
    says: str
    checked: bool = True


_MAVIC2 = "https://www.dji.com/mavic-2/info#specs"
_MAVIC2_DRONESPEC = "https://dronespec.dronedesk.io/part2toword?id=3"
_MAVIC2_MANUAL = "https://manualslib.mx/manual/19397/Djl-Mavic-2-Pro.html?page=34"
_X500 = "https://holybro.com/products/x500-v2-kits"
_X500_AMC = (
    "https://github.com/ArduPilot/MethodicConfigurator/blob/master/ardupilot_methodic_configurator/"
    "vehicle_templates/ArduCopter/Holybro_X500_V2/vehicle_components.json"
)
_X500_PX4 = "https://docs.px4.io/main/en/frames_multicopter/holybro_x500V2_pixhawk5x.html"
_X500_MOTOR_SHEET = "https://cdn.shopify.com/s/files/1/0604/5905/7341/files/X500MotorSpec.png"
_PX4_PARAMS = "https://docs.px4.io/main/en/advanced_config/parameter_reference.html#MPC_XY_VEL_MAX"
_M600 = "https://www.dji.com/matrice600-pro/info#specs"

PROFILES: Mapping[str, VehicleProfile] = MappingProxyType(
    {
        "small-quad": VehicleProfile(
            name="small-quad",
            mass_kg=0.907,
            rotor_count=4,
            rotor_diameter_m=8.7 * INCH_M,
            battery_wh=59.29,
            max_airspeed_m_s=20.0,
        ),
        "x500": VehicleProfile(
            name="x500",
            mass_kg=1.09 + 0.5,
            rotor_count=4,
            rotor_diameter_m=10.0 * INCH_M,
            battery_wh=5.0 * 4 * 3.7,
            max_airspeed_m_s=12.0,
        ),
        "heavy-lift": VehicleProfile(
            name="heavy-lift",
            mass_kg=9.5,
            rotor_count=6,
            rotor_diameter_m=21.0 * INCH_M,
            battery_wh=6 * 99.9,
            max_airspeed_m_s=18.0,
        ),
    }
)

#: the hover time each profile's source publishes (s), with no payload, in calm air
CITED_HOVER_TIME_S: Mapping[str, float] = MappingProxyType(
    {"small-quad": 29 * 60.0, "x500": 18 * 60.0, "heavy-lift": 32 * 60.0}
)

SOURCES: Mapping[str, tuple[Citation, ...]] = MappingProxyType(
    {
        "small-quad": (
            Citation(
                "mass_kg",
                "0.907",
                _MAVIC2_DRONESPEC,
                "DJI Mavic 2 spec sheet (as reproduced there): 'Takeoff Weight: Mavic 2 Pro: "
                "907 g'",
            ),
            Citation(
                "rotor_count, rotor_diameter_m",
                "4 × 8.7 in (0.221 m)",
                _MAVIC2,
                "quadcopter with 8743F low-noise propellers (8.7-inch diameter, 4.3-inch pitch)",
                checked=False,
            ),
            Citation(
                "battery_wh",
                "59.29",
                _MAVIC2,
                "Intelligent Flight Battery: 3850 mAh, 15.4 V, LiPo 4S, energy 59.29 Wh (the "
                "user manual, " + _MAVIC2_MANUAL + ": '15,4 V y 3850 mAh')",
            ),
            Citation(
                "max_airspeed_m_s",
                "20",
                _MAVIC2_DRONESPEC,
                "'Max Speed (near sea level, no wind): 72 kph (S-mode)'",
            ),
            Citation(
                "hover time",
                "29 min",
                _MAVIC2,
                "'Max Hovering Time (no wind): 29 minutes'; max flight time 31 minutes at a "
                "consistent 25 kph",
                checked=False,
            ),
        ),
        "x500": (
            Citation(
                "mass_kg",
                "1.59 = 1.09 + 0.5",
                _X500_AMC,
                "ArduPilot Methodic Configurator's X500 V2 template: frame 'TOW min Kg: 1.09' "
                "and battery 'Gens Ace 4S1P 5000mAh ... Normal battery 0.5 kg'. We read 1.09 kg "
                "as the kit without its battery (Holybro's 610 g frame, motors, ESCs, props, "
                "Pixhawk 6C, GNSS, power module, radio); the template does not say",
            ),
            Citation(
                "rotor_count, rotor_diameter_m",
                "4 × 10 in (0.254 m)",
                _X500_PX4,
                "PX4's build log: 'Holybro Motors - 2216 KV880 x4', 'Propellers - 1045 x4'",
            ),
            Citation(
                "battery_wh",
                "74.0 = 5 Ah × 4 × 3.7 V",
                _X500,
                "Holybro: 'Flight time: ~18 minutes hover with no additional payload. Tested "
                "with 5000mAh Battery'; recommended battery 4S; 3.7 V is a LiPo cell's nominal "
                "voltage",
            ),
            Citation(
                "max_airspeed_m_s",
                "12",
                _PX4_PARAMS,
                "PX4 MPC_XY_VEL_MAX, the maximum horizontal velocity, default 12 m/s",
                checked=False,
            ),
            Citation(
                "hover time",
                "18 min",
                _X500,
                "'Flight time: ~18 minutes hover with no additional payload. Tested with "
                "5000mAh Battery'",
            ),
            Citation(
                "hover power (a cross-check, not an input)",
                "209.9 W at 1.59 kg (4 × 49.97 W + 10 W avionics); the model: 208.6 W",
                _X500_MOTOR_SHEET,
                "Holybro's motor sheet, linked from the kit's page: the current kit's AIR2216II "
                "KV920 motor with the T1045II propeller at 16 V, per motor 373 g of thrust at "
                "46 W and 447 g at 58 W (T-Motor's Air Gear 450 II table). Read in two public "
                "transcriptions that agree row for row, not in the image itself "
                "(tests/airframe/test_power_model.py, docs/energy.md)",
                checked=False,
            ),
        ),
        "heavy-lift": (
            Citation(
                "mass_kg",
                "9.5",
                _M600,
                "'Weight (with six TB47S batteries): 9.5 kg'; max takeoff weight 15.5 kg",
                checked=False,
            ),
            Citation(
                "rotor_count, rotor_diameter_m",
                "6 × 21 in (0.533 m)",
                _M600,
                "hexacopter; 'Propeller Model: 2170R' (21-inch diameter, 7.0-inch pitch)",
                checked=False,
            ),
            Citation(
                "battery_wh",
                "599.4 = 6 × 99.9",
                _M600,
                "six TB47S Intelligent Flight Batteries: 4500 mAh, 22.2 V, 6S LiPo, 99.9 Wh each",
                checked=False,
            ),
            Citation(
                "max_airspeed_m_s",
                "18",
                _M600,
                "'Max Speed: 65 km/h (no payload, no wind)'",
                checked=False,
            ),
            Citation(
                "hover time",
                "32 min",
                _M600,
                "'Hovering Time (with six TB47S batteries): No payload: 32 min, 6 kg payload: "
                "16 min'",
                checked=False,
            ),
        ),
    }
)


def names() -> tuple[str, ...]:
    return tuple(PROFILES)


def get(name: str) -> VehicleProfile:
    """The bundled profile ``name``; :class:`InputError` lists the names otherwise."""
    try:
        return PROFILES[name]
    except (KeyError, TypeError):
        raise InputError(
            f"unknown vehicle profile {name!r}; bundled: {', '.join(PROFILES)}", key="profile"
        ) from None


def resolve(raw: Mapping[str, Any]) -> VehicleProfile:
    """A profile from a scenario's ``vehicle:`` mapping: ``profile: <name>`` and any fields of
    :class:`VehicleProfile` to override (``{profile: x500, mass_kg: 2.1}``). Without ``profile``
    every required field must be given (a vehicle of the user's own)."""
    if not isinstance(raw, Mapping):
        raise InputError("must be a mapping such as {profile: x500}", key="vehicle")
    rest = {str(k): v for k, v in raw.items() if k != "profile"}
    if "profile" in raw:
        return get(raw["profile"]).with_overrides(**rest)
    names_ = VehicleProfile.field_names()
    unknown = sorted(set(rest) - set(names_))
    if unknown:
        raise InputError(f"unknown vehicle field; valid: {', '.join(names_)}", key=unknown[0])
    required = ("mass_kg", "rotor_count", "rotor_diameter_m", "battery_wh", "max_airspeed_m_s")
    missing = [k for k in required if k not in rest]
    if missing:
        raise InputError(
            f"needs profile: <{'|'.join(PROFILES)}>, or all of {', '.join(required)}",
            key=missing[0],
        )
    base = VehicleProfile(
        name=str(rest.get("name", "custom")),
        mass_kg=1.0,
        rotor_count=4,
        rotor_diameter_m=0.25,
        battery_wh=1.0,
        max_airspeed_m_s=10.0,
    )
    return base.with_overrides(**rest)
