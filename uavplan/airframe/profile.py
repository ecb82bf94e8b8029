"""A vehicle profile: the figures the power model needs, validated on construction.

Units are in the field names. The aerodynamic and electrical constants default to the generic
values of :mod:`uavplan.airframe.constants` (the same for every bundled profile); the measured
figures (``hover_power_w``, ``cruise_power_w``) are unset (``None``) unless the user has them.
:meth:`VehicleProfile.with_overrides` changes any field and validates the result, so a scenario's
``vehicle: {profile: x500, mass_kg: 2.1}`` is one call (:func:`uavplan.airframe.profiles.resolve`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

import uavplan.airframe.constants as C
from uavplan.airframe.power import calibration
from uavplan.errors import InputError


def _number(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InputError(f"must be a number, not {value!r}", key=name)
    out = float(value)
    if not math.isfinite(out):
        raise InputError("must be a finite number", key=name)
    return out


@dataclass(frozen=True)
class VehicleProfile:
    """A multirotor as the power model sees it.

    ``battery_wh`` is the rated energy (capacity × nominal voltage); ``battery_usable_fraction``
    the share of it the vehicle draws before its own "empty" (see :attr:`usable_wh` and
    docs/energy.md "Battery"). ``max_airspeed_m_s`` is the fastest the vehicle flies through the
    air (its tilt limit); against a headwind it then slows down over the ground.
    """

    name: str
    mass_kg: float
    rotor_count: int
    rotor_diameter_m: float
    battery_wh: float
    max_airspeed_m_s: float
    battery_usable_fraction: float = C.BATTERY_USABLE_FRACTION
    avionics_power_w: float = C.AVIONICS_POWER_W
    figure_of_merit: float = C.FIGURE_OF_MERIT
    induced_power_factor: float = C.INDUCED_POWER_FACTOR
    motor_esc_efficiency: float = C.MOTOR_ESC_EFFICIENCY
    thrust_coefficient: float = C.THRUST_COEFFICIENT
    drag_area_m2: float | None = None  # None: DRAG_AREA_PER_DISC_AREA × disc area
    hover_power_w: float | None = None  # measured electrical power in hover, if known
    cruise_power_w: float | None = None  # measured electrical power at cruise_speed_m_s
    cruise_speed_m_s: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise InputError("must be a non-empty string", key="name")
        if isinstance(self.rotor_count, bool) or not isinstance(self.rotor_count, int):
            raise InputError(f"must be a whole number, not {self.rotor_count!r}", key="rotor_count")
        if self.rotor_count < 1:
            raise InputError("must be at least 1", key="rotor_count")
        positive = (
            "mass_kg",
            "rotor_diameter_m",
            "battery_wh",
            "max_airspeed_m_s",
            "figure_of_merit",
            "motor_esc_efficiency",
            "thrust_coefficient",
        )
        for name in positive:
            if _number(name, getattr(self, name)) <= 0:
                raise InputError("must be > 0", key=name)
        for name in ("battery_usable_fraction", "motor_esc_efficiency"):
            if _number(name, getattr(self, name)) > 1:
                raise InputError("must be at most 1", key=name)
        if _number("avionics_power_w", self.avionics_power_w) < 0:
            raise InputError("must be >= 0", key="avionics_power_w")
        if _number("battery_usable_fraction", self.battery_usable_fraction) <= 0:
            raise InputError("must be > 0", key="battery_usable_fraction")
        if _number("induced_power_factor", self.induced_power_factor) < 1:
            raise InputError(
                "must be >= 1 (1 is ideal momentum theory)", key="induced_power_factor"
            )
        if self.figure_of_merit * self.induced_power_factor > 1:
            raise InputError(
                f"must be at most 1/induced_power_factor = {1 / self.induced_power_factor:.3f} "
                "(the induced power alone would exceed the rotors' power)",
                key="figure_of_merit",
            )
        if self.drag_area_m2 is not None and _number("drag_area_m2", self.drag_area_m2) < 0:
            raise InputError("must be >= 0", key="drag_area_m2")
        for name in ("hover_power_w", "cruise_power_w", "cruise_speed_m_s"):
            value = getattr(self, name)
            if value is not None and _number(name, value) <= 0:
                raise InputError("must be > 0", key=name)
        if self.cruise_power_w is not None:
            if self.hover_power_w is None:
                raise InputError("needs hover_power_w too", key="cruise_power_w")
            if self.cruise_speed_m_s is None:
                raise InputError(
                    "needs cruise_speed_m_s (the speed it was measured at)", key="cruise_power_w"
                )
            if self.drag_area_m2 is not None:
                raise InputError(
                    "give either drag_area_m2 or a measured cruise_power_w, not both "
                    "(the cruise power determines the drag area)",
                    key="cruise_power_w",
                )
        if self.hover_power_w is not None:
            calibration(self)  # raises InputError when the measured figures cannot hold

    @property
    def usable_wh(self) -> float:
        """Energy (Wh) the vehicle can draw before its own "empty": rated × usable fraction.
        "Battery used %" is a share of this; the reserve is kept out of it."""
        return self.battery_wh * self.battery_usable_fraction

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))

    def with_overrides(self, **values: Any) -> VehicleProfile:
        """This profile with some fields changed, validated (:class:`InputError` names the field).

        Integral numbers are accepted for float fields, ``None`` for the optional ones; a field
        that is not one of :meth:`field_names` is rejected with the list of valid ones.
        """
        names = self.field_names()
        changes: dict[str, Any] = {}
        for key, value in values.items():
            if key not in names:
                raise InputError(f"unknown vehicle field; valid: {', '.join(names)}", key=key)
            if key == "name":
                changes[key] = value
            elif key == "rotor_count":
                if isinstance(value, float) and value.is_integer():
                    value = int(value)
                changes[key] = value
            elif value is None and key in _OPTIONAL:
                changes[key] = None
            else:
                changes[key] = _number(key, value)
        return dataclasses.replace(self, **changes)

    def with_mapping(self, raw: Mapping[str, Any]) -> VehicleProfile:
        """:meth:`with_overrides` from a mapping (a scenario's ``vehicle:`` section)."""
        return self.with_overrides(**{str(k): v for k, v in raw.items()})


_OPTIONAL = frozenset({"drag_area_m2", "hover_power_w", "cruise_power_w", "cruise_speed_m_s"})
