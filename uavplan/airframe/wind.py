"""Wind: a speed, the meteorological direction it comes *from*, and an optional profile by height.

``from_deg`` is the direction the wind blows from, in degrees clockwise from north (a wind
"from 270" is a westerly, blowing towards the east). The air's velocity in the local ENU frame
is therefore ``speed · (−sin(from), −cos(from))``.

The speed may change with height above the ground:

* uniform (the default): the same at every height;
* a power law, V(z) = V_ref · (z / z_ref)^α, the usual engineering profile of the surface
  layer; α ≈ 1/7 over open level ground, more over towns. ``speed_m_s`` is then the speed at
  ``reference_height_m`` (10 m, the height of a standard surface-wind report) and the speed
  is zero at the ground;
* a table of heights and speeds, linear between them and constant beyond its ends.

Vertical wind (thermals, slope lift, downdrafts) and gusts are not modelled.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

import uavplan.airframe.constants as C
from uavplan.errors import InputError


def _num(value: Any, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise InputError(f"must be a finite number, not {value!r}", key=key)
    return float(value)


@dataclass(frozen=True)
class Wind:
    """Horizontal wind; see the module docstring. Build with :meth:`uniform`,
    :meth:`power_law`, :meth:`from_table` or :meth:`from_mapping`."""

    from_deg: float
    speed_m_s: float | None = None  # at reference_height_m; None with a table
    shear_exponent: float = 0.0  # α of the power law; 0: uniform
    reference_height_m: float = C.WIND_REFERENCE_HEIGHT_M
    heights_m: tuple[float, ...] | None = None
    speeds_m_s: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        _num(self.from_deg, "wind.from")
        if _num(self.reference_height_m, "wind.reference_height") <= 0:
            raise InputError("must be > 0", key="wind.reference_height")
        alpha = _num(self.shear_exponent, "wind.exponent")
        if not 0.0 <= alpha <= 1.0:
            raise InputError("must be between 0 and 1 (1/7 over open ground)", key="wind.exponent")
        if self.heights_m is None and self.speeds_m_s is None:
            if self.speed_m_s is None:
                raise InputError("is required (m/s)", key="wind.speed")
            if _num(self.speed_m_s, "wind.speed") < 0:
                raise InputError("must be >= 0", key="wind.speed")
            return
        if self.heights_m is None or self.speeds_m_s is None:
            raise InputError("a wind table needs both heights and speeds", key="wind.profile")
        if self.speed_m_s is not None or alpha != 0.0:
            raise InputError(
                "give either a speed (with an optional exponent) or a table of heights and "
                "speeds, not both",
                key="wind.profile",
            )
        if len(self.heights_m) != len(self.speeds_m_s) or not self.heights_m:
            raise InputError(
                "heights and speeds must be non-empty lists of the same length",
                key="wind.profile",
            )
        heights = [_num(h, "wind.profile.heights") for h in self.heights_m]
        speeds = [_num(s, "wind.profile.speeds") for s in self.speeds_m_s]
        if any(b <= a for a, b in itertools.pairwise(heights)) or heights[0] < 0:
            raise InputError(
                "must be ascending heights above the ground (m, >= 0)", key="wind.profile.heights"
            )
        if any(s < 0 for s in speeds):
            raise InputError("must be >= 0 (m/s)", key="wind.profile.speeds")

    # --- named constructors -------------------------------------------------------------
    @classmethod
    def uniform(cls, speed_m_s: float, from_deg: float) -> Wind:
        """The same wind at every height."""
        return cls(from_deg=from_deg, speed_m_s=speed_m_s)

    @classmethod
    def power_law(
        cls,
        speed_m_s: float,
        from_deg: float,
        *,
        exponent: float = 1 / 7,
        reference_height_m: float = C.WIND_REFERENCE_HEIGHT_M,
    ) -> Wind:
        """``speed_m_s`` at ``reference_height_m``, scaled by (z / z_ref)^exponent."""
        return cls(
            from_deg=from_deg,
            speed_m_s=speed_m_s,
            shear_exponent=exponent,
            reference_height_m=reference_height_m,
        )

    @classmethod
    def from_table(
        cls, heights_m: Sequence[float], speeds_m_s: Sequence[float], from_deg: float
    ) -> Wind:
        """Speeds at heights above the ground, linear in between."""
        return cls(from_deg=from_deg, heights_m=tuple(heights_m), speeds_m_s=tuple(speeds_m_s))

    @classmethod
    def calm(cls) -> Wind:
        return cls.uniform(0.0, 0.0)

    @classmethod
    def from_mapping(cls, raw: Mapping[str, Any]) -> Wind:
        """From a scenario's ``wind:`` section: ``{speed: m/s, from: deg}`` plus an optional
        ``profile: {exponent: a, reference_height: m}`` or
        ``profile: {heights: [m, ...], speeds: [m/s, ...]}``."""
        if not isinstance(raw, Mapping):
            raise InputError("must be a mapping such as {speed: 5, from: 270}", key="wind")
        unknown = set(raw) - {"speed", "from", "profile"}
        if unknown:
            raise InputError(
                f"unknown key {sorted(map(str, unknown))[0]!r}; valid: speed, from, profile",
                key="wind",
            )
        if "from" not in raw:
            raise InputError("is required (degrees clockwise from north)", key="wind.from")
        from_deg = _num(raw["from"], "wind.from")
        prof = raw.get("profile")
        if prof is None:
            if "speed" not in raw:
                raise InputError("is required (m/s)", key="wind.speed")
            return cls.uniform(_num(raw["speed"], "wind.speed"), from_deg)
        if not isinstance(prof, Mapping):
            raise InputError("must be a mapping", key="wind.profile")
        if "heights" in prof or "speeds" in prof:
            extra = set(prof) - {"heights", "speeds"}
            if extra or "speed" in raw:
                raise InputError(
                    "a table profile takes heights and speeds only, and no wind.speed",
                    key="wind.profile",
                )
            heights, speeds = prof.get("heights"), prof.get("speeds")
            if not isinstance(heights, list) or not isinstance(speeds, list):
                raise InputError("heights and speeds must be lists", key="wind.profile")
            return cls.from_table(heights, speeds, from_deg)
        extra = set(prof) - {"exponent", "reference_height"}
        if extra:
            raise InputError(
                f"unknown key {sorted(map(str, extra))[0]!r}; valid: exponent, "
                "reference_height, or heights and speeds",
                key="wind.profile",
            )
        if "speed" not in raw:
            raise InputError("is required (m/s)", key="wind.speed")
        return cls.power_law(
            _num(raw["speed"], "wind.speed"),
            from_deg,
            exponent=_num(prof.get("exponent", 1 / 7), "wind.profile.exponent"),
            reference_height_m=_num(
                prof.get("reference_height", C.WIND_REFERENCE_HEIGHT_M),
                "wind.profile.reference_height",
            ),
        )

    # --- evaluation -------------------------------------------------------------------------
    def speed_at(self, height_m: ArrayLike) -> NDArray[np.float64]:
        """Wind speed (m/s) at heights above the ground (negative heights count as 0)."""
        h = np.maximum(np.asarray(height_m, dtype=np.float64), 0.0)
        if self.heights_m is not None and self.speeds_m_s is not None:
            return np.interp(h, np.asarray(self.heights_m), np.asarray(self.speeds_m_s))
        assert self.speed_m_s is not None
        if self.shear_exponent == 0.0:
            return np.full(h.shape, self.speed_m_s)
        return self.speed_m_s * (h / self.reference_height_m) ** self.shear_exponent

    def velocity_at(self, height_m: ArrayLike) -> NDArray[np.float64]:
        """The air's horizontal velocity (m/s, east and north), shape ``(..., 2)``."""
        speed = self.speed_at(height_m)
        rad = math.radians(self.from_deg)
        return np.stack([-speed * math.sin(rad), -speed * math.cos(rad)], axis=-1)
