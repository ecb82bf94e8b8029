"""Time and energy of a flown profile, leg by leg, with wind; the battery's bookkeeping.

A flight is a sequence of legs (:class:`Legs`): each has a horizontal length and a course over
the ground, a height change, the height it is flown at (for the wind profile), the speeds the
autopilot is told to fly, and an optional hover at its end. Build them from a flown polyline
(:meth:`Legs.from_path`, ENU points) or from segments of horizontal speed, vertical speed and
duration (:meth:`Legs.from_segments`).

How a leg is flown (ArduPilot AUTO and PX4 Mission mode alike):

* the autopilot holds the straight line between the waypoints and flies it at the commanded
  horizontal *ground* speed (ArduPilot ``WPNAV_SPEED``, PX4 ``MPC_XY_CRUISE``), its vertical
  part no faster than the climb or descent rate (``WPNAV_SPEED_UP``/``_DN``,
  ``MPC_Z_V_AUTO_UP``/``_DN``): a leg takes max(length / speed, climb / rate) and its two parts
  end together;
* wind: the vehicle keeps its ground track, so its velocity through the air is the ground
  velocity minus the wind. A headwind raises the airspeed at the commanded ground speed (and the
  power with it); only when the airspeed would exceed the vehicle's ``max_airspeed_m_s`` (its
  tilt limit) does the ground speed drop, to the speed at which the airspeed is that maximum.
  Both autopilots fly a ground speed in AUTO and lean into the wind up to their tilt limit,
  which is why the model is "fixed ground speed, capped airspeed". A wind the vehicle cannot
  make headway against (or hold position in) raises :class:`WindTooStrongError`;
* a hover, or a vertical leg, is flown holding position: the airspeed is the wind speed.

The battery (docs/energy.md "Battery"): ``battery_wh`` is the pack's rated energy; the vehicle
draws ``usable_wh = battery_wh × battery_usable_fraction`` before its own "empty". *Battery used*
is the flight's energy as a percentage of ``usable_wh``; the *reserve* is the percentage of
``usable_wh`` that must still be in the pack on landing (default 20 %), so a flight fits when
``battery_used_pct <= 100 − reserve_pct``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uavplan.airframe.power import air_density_kg_m3, electrical_power_w
from uavplan.airframe.profile import VehicleProfile
from uavplan.airframe.wind import Wind
from uavplan.errors import InputError

#: default vertical speeds of a mission leg: ArduPilot's WPNAV_SPEED_UP (250 cm/s) and
#: WPNAV_SPEED_DN (150 cm/s) defaults
DEFAULT_CLIMB_RATE_M_S = 2.5
DEFAULT_DESCENT_RATE_M_S = 1.5
#: the share of the usable energy kept for landing, unless the user says otherwise (issue 27)
DEFAULT_RESERVE_PCT = 20.0


class WindTooStrongError(InputError):
    """The wind is stronger than the vehicle can fly against on some leg (exit 2)."""


class EnergyBudgetError(InputError):
    """The flight needs more than the usable battery minus the reserve (exit 2)."""


def _vec(value: ArrayLike, n: int, key: str) -> NDArray[np.float64]:
    arr = np.asarray(value, dtype=np.float64)
    try:
        arr = np.broadcast_to(arr, (n,)).copy()
    except ValueError:
        raise InputError(f"must be one value or one per leg ({n})", key=key) from None
    if not np.all(np.isfinite(arr)):
        raise InputError("must be finite numbers", key=key)
    return arr


@dataclass(frozen=True)
class Legs:
    """The legs of a flight, arrays of shape ``(n,)``.

    ``course_deg`` is the direction of travel over the ground (clockwise from north; ignored on
    a leg without horizontal length), ``height_m`` the height above the ground the leg is flown
    at (its mean), ``speed_m_s`` the commanded horizontal ground speed, ``hold_s`` a hover at the
    leg's end.
    """

    horizontal_m: NDArray[np.float64]
    vertical_m: NDArray[np.float64]
    course_deg: NDArray[np.float64]
    height_m: NDArray[np.float64]
    speed_m_s: NDArray[np.float64]
    climb_rate_m_s: NDArray[np.float64]
    descent_rate_m_s: NDArray[np.float64]
    hold_s: NDArray[np.float64]

    def __post_init__(self) -> None:
        n = np.asarray(self.horizontal_m).reshape(-1).shape[0]
        for name in self.__dataclass_fields__:
            object.__setattr__(self, name, _vec(getattr(self, name), n, name))
        if np.any(self.horizontal_m < 0):
            raise InputError("must be >= 0", key="horizontal_m")
        for name in ("speed_m_s", "climb_rate_m_s", "descent_rate_m_s"):
            if np.any(getattr(self, name) <= 0):
                raise InputError("must be > 0", key=name)
        if np.any(self.hold_s < 0):
            raise InputError("must be >= 0", key="hold_s")

    def __len__(self) -> int:
        return int(self.horizontal_m.shape[0])

    @classmethod
    def from_path(
        cls,
        points_enu: ArrayLike,
        *,
        speed_m_s: ArrayLike,
        climb_rate_m_s: ArrayLike = DEFAULT_CLIMB_RATE_M_S,
        descent_rate_m_s: ArrayLike = DEFAULT_DESCENT_RATE_M_S,
        hold_s: ArrayLike | None = None,
        heights_agl_m: ArrayLike | None = None,
    ) -> Legs:
        """The legs between consecutive points of a flown polyline ``(n, 3)`` (ENU metres).

        ``speed_m_s`` and the rates are one value or one per leg (n − 1). ``hold_s`` (one per
        point) hovers on arrival at each point; a hold at the first point becomes a leading leg
        of zero length. ``heights_agl_m`` (one per point) are the heights above the ground for
        the wind profile; by default the points' z (ground at z = 0).
        """
        p = np.asarray(points_enu, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 3 or len(p) < 1 or not np.all(np.isfinite(p)):
            raise InputError("must be finite (n, 3) ENU points", key="points_enu")
        agl = p[:, 2] if heights_agl_m is None else _vec(heights_agl_m, len(p), "heights_agl_m")
        d = np.diff(p, axis=0)
        m = len(d)
        legs = cls(
            horizontal_m=np.hypot(d[:, 0], d[:, 1]),
            vertical_m=d[:, 2],
            course_deg=np.degrees(np.arctan2(d[:, 0], d[:, 1])) % 360.0,
            height_m=(agl[:-1] + agl[1:]) / 2.0,
            speed_m_s=_vec(speed_m_s, m, "speed_m_s"),
            climb_rate_m_s=_vec(climb_rate_m_s, m, "climb_rate_m_s"),
            descent_rate_m_s=_vec(descent_rate_m_s, m, "descent_rate_m_s"),
            hold_s=np.zeros(m),
        )
        if hold_s is None:
            return legs
        holds = _vec(hold_s, len(p), "hold_s")
        legs = cls(**{**legs.__dict__, "hold_s": holds[1:]})
        if holds[0] > 0:
            first = cls.hover(float(holds[0]), height_m=float(agl[0]))
            return cls.concat(first, legs)
        return legs

    @classmethod
    def from_segments(
        cls,
        horizontal_speed_m_s: ArrayLike,
        vertical_speed_m_s: ArrayLike,
        duration_s: ArrayLike,
        *,
        course_deg: ArrayLike = 0.0,
        height_m: ArrayLike = 0.0,
    ) -> Legs:
        """Segments flown at a horizontal ground speed (≥ 0) and a vertical speed (+ up) for a
        duration each; a segment with both speeds 0 is a hover. In still air each leg takes
        exactly its duration."""
        t = np.asarray(duration_s, dtype=np.float64).reshape(-1)
        n = len(t)
        t = _vec(t, n, "duration_s")
        h = _vec(horizontal_speed_m_s, n, "horizontal_speed_m_s")
        v = _vec(vertical_speed_m_s, n, "vertical_speed_m_s")
        if np.any(t < 0) or np.any(h < 0):
            raise InputError("durations and horizontal speeds must be >= 0", key="duration_s")
        moving = (h > 0) | (v != 0)
        rate = np.where(v != 0, np.abs(v), 1.0)
        return cls(
            horizontal_m=np.where(moving, h * t, 0.0),
            vertical_m=np.where(moving, v * t, 0.0),
            course_deg=_vec(course_deg, n, "course_deg"),
            height_m=_vec(height_m, n, "height_m"),
            speed_m_s=np.where(h > 0, h, 1.0),
            climb_rate_m_s=rate,
            descent_rate_m_s=rate,
            hold_s=np.where(moving, 0.0, t),
        )

    @classmethod
    def hover(cls, duration_s: float, *, height_m: float = 0.0) -> Legs:
        """One hover in place."""
        return cls.from_segments(0.0, 0.0, [duration_s], height_m=height_m)

    @classmethod
    def concat(cls, *parts: Legs) -> Legs:
        names = cls.__dataclass_fields__
        return cls(**{k: np.concatenate([getattr(p, k) for p in parts]) for k in names})


@dataclass(frozen=True)
class LegFigures:
    """Per-leg results, arrays ``(n,)``: what Mission Planner shows as the energy profile."""

    duration_s: NDArray[np.float64]  # travel + hold
    energy_wh: NDArray[np.float64]
    power_w: NDArray[np.float64]  # mean electrical power over the leg
    ground_speed_m_s: NDArray[np.float64]  # horizontal, while travelling
    airspeed_m_s: NDArray[np.float64]  # horizontal, while travelling
    vertical_speed_m_s: NDArray[np.float64]


@dataclass(frozen=True)
class EnergyUse:
    """Time and energy of a flight, and what they mean for the battery."""

    profile_name: str
    time_s: float
    energy_wh: float
    battery_wh: float
    usable_wh: float
    legs: LegFigures

    @property
    def battery_used_pct(self) -> float:
        """The flight's energy as a percentage of the usable energy."""
        return 100.0 * self.energy_wh / self.usable_wh

    @property
    def remaining_pct(self) -> float:
        """Usable energy left on landing, in percent (negative: the battery runs out)."""
        return 100.0 - self.battery_used_pct

    def fits(self, reserve_pct: float = DEFAULT_RESERVE_PCT) -> bool:
        """True when at least ``reserve_pct`` of the usable energy is left on landing."""
        return self.battery_used_pct <= 100.0 - _reserve(reserve_pct) + 1e-9

    def require_reserve(self, reserve_pct: float = DEFAULT_RESERVE_PCT) -> None:
        """Raise :class:`EnergyBudgetError` (exit 2) with the numbers when the flight does not
        leave ``reserve_pct`` of the usable energy."""
        if self.fits(reserve_pct):
            return
        allowed_wh = self.usable_wh * (100.0 - _reserve(reserve_pct)) / 100.0
        raise EnergyBudgetError(
            f"the flight needs {self.energy_wh:.1f} Wh ({self.battery_used_pct:.0f} % of the "
            f"{self.usable_wh:.1f} Wh usable of {self.profile_name}'s {self.battery_wh:g} Wh "
            f"battery); with a {reserve_pct:g} % reserve it may use {allowed_wh:.1f} Wh "
            f"({100.0 - reserve_pct:g} %)"
        )

    def summary(self, reserve_pct: float = DEFAULT_RESERVE_PCT) -> str:
        """One line for the user: time, energy, battery used and what is left."""
        minutes, seconds = divmod(round(self.time_s), 60)
        return (
            f"flight {minutes} min {seconds:02d} s, {self.energy_wh:.1f} Wh, battery "
            f"{self.battery_used_pct:.0f} % used, {self.remaining_pct:.0f} % left "
            f"(reserve {reserve_pct:g} %)"
        )

    def report_fields(self) -> dict[str, Any]:
        """The report's keys (issue 27): ``flight_time_s``, ``energy_wh``,
        ``battery_used_pct``, and the per-leg figures."""
        lg = self.legs
        return {
            "flight_time_s": round(self.time_s, 1),
            "energy_wh": round(self.energy_wh, 2),
            "battery_used_pct": round(self.battery_used_pct, 1),
            "legs": [
                {
                    "duration_s": round(float(t), 1),
                    "energy_wh": round(float(e), 3),
                    "power_w": round(float(p), 1),
                    "ground_speed_m_s": round(float(g), 2),
                    "airspeed_m_s": round(float(a), 2),
                }
                for t, e, p, g, a in zip(
                    lg.duration_s,
                    lg.energy_wh,
                    lg.power_w,
                    lg.ground_speed_m_s,
                    lg.airspeed_m_s,
                    strict=True,
                )
            ],
        }


def _reserve(reserve_pct: float) -> float:
    if isinstance(reserve_pct, bool) or not (0.0 <= float(reserve_pct) < 100.0):
        raise InputError("must be between 0 and 100 (% of the usable energy)", key="reserve")
    return float(reserve_pct)


def _ground_speed_cap(
    course_unit: NDArray[np.float64], wind_enu: NDArray[np.float64], max_airspeed_m_s: float
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """The fastest ground speed along each course whose airspeed is ``max_airspeed_m_s``:
    the positive root of |g·t − w| = V_max, g = t·w + sqrt(V_max² − (cross wind)²); and
    whether there is one (the cross wind is below V_max and the root is positive)."""
    along = np.einsum("ij,ij->i", course_unit, wind_enu)
    cross_sq = np.einsum("ij,ij->i", wind_enu, wind_enu) - along**2
    disc = max_airspeed_m_s**2 - cross_sq
    root = along + np.sqrt(np.maximum(disc, 0.0))
    return root, (disc > 0) & (root > 1e-9)


def flight_energy(
    profile: VehicleProfile,
    legs: Legs,
    wind: Wind | None = None,
    *,
    home_altitude_amsl_m: float = 0.0,
    altitude_amsl_m: ArrayLike | None = None,
) -> EnergyUse:
    """Fly ``legs`` with ``profile`` in ``wind`` (default calm) from a home at
    ``home_altitude_amsl_m`` (the air density of each leg is the ISA's at home altitude plus
    the leg's height; ``altitude_amsl_m``, one per leg, gives each leg's altitude instead,
    over terrain where the ground is not at home's altitude). Raises
    :class:`WindTooStrongError` when the wind beats the vehicle."""
    wind = Wind.calm() if wind is None else wind
    n = len(legs)
    if altitude_amsl_m is None:
        rho = air_density_kg_m3(home_altitude_amsl_m + legs.height_m)
    else:
        rho = air_density_kg_m3(_vec(altitude_amsl_m, n, "altitude_amsl_m"))
    w = wind.velocity_at(legs.height_m).reshape(n, 2)
    wind_speed = np.hypot(w[:, 0], w[:, 1])
    v_max = profile.max_airspeed_m_s

    course = np.radians(legs.course_deg)
    unit = np.stack([np.sin(course), np.cos(course)], axis=1)
    moving = legs.horizontal_m > 0
    cap, ok = _ground_speed_cap(unit, w, v_max)
    need_cap = np.hypot(*(legs.speed_m_s[:, None] * unit - w).T) > v_max
    bad = moving & need_cap & ~ok
    holding = (legs.hold_s > 0) | (~moving & (legs.vertical_m != 0))
    bad |= holding & (wind_speed > v_max)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise WindTooStrongError(
            f"leg {i + 1}: a wind of {wind_speed[i]:.1f} m/s from {wind.from_deg:g}° is more "
            f"than {profile.name} can fly against (max airspeed {v_max:g} m/s)",
            key="wind",
        )
    ground = np.where(moving & need_cap, np.minimum(legs.speed_m_s, cap), legs.speed_m_s)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_h = np.where(moving, legs.horizontal_m / ground, 0.0)
        rate = np.where(legs.vertical_m > 0, legs.climb_rate_m_s, legs.descent_rate_m_s)
        t_v = np.abs(legs.vertical_m) / rate
        travel = np.maximum(t_h, t_v)
        safe = np.where(travel > 0, travel, 1.0)
        g_speed = np.where(travel > 0, legs.horizontal_m / safe, 0.0)
        v_speed = np.where(travel > 0, legs.vertical_m / safe, 0.0)
    air = g_speed[:, None] * unit - w
    airspeed = np.hypot(air[:, 0], air[:, 1])

    p_travel = electrical_power_w(profile, airspeed, v_speed, air_density_kg_m3=rho)
    p_hold = electrical_power_w(profile, wind_speed, 0.0, air_density_kg_m3=rho)
    energy_j = p_travel * travel + p_hold * legs.hold_s
    duration = travel + legs.hold_s
    with np.errstate(divide="ignore", invalid="ignore"):
        mean_power = np.where(duration > 0, energy_j / np.where(duration > 0, duration, 1.0), 0.0)
    figures = LegFigures(
        duration_s=duration,
        energy_wh=energy_j / 3600.0,
        power_w=mean_power,
        ground_speed_m_s=g_speed,
        airspeed_m_s=np.where(travel > 0, airspeed, wind_speed),
        vertical_speed_m_s=v_speed,
    )
    return EnergyUse(
        profile_name=profile.name,
        time_s=float(duration.sum()),
        energy_wh=float(energy_j.sum() / 3600.0),
        battery_wh=profile.battery_wh,
        usable_wh=profile.usable_wh,
        legs=figures,
    )


def still_air_time_s(legs: Legs) -> float:
    """How long the legs take in calm air (the commanded speeds, no cap): a check value."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t_h = np.where(legs.horizontal_m > 0, legs.horizontal_m / legs.speed_m_s, 0.0)
    rate = np.where(legs.vertical_m > 0, legs.climb_rate_m_s, legs.descent_rate_m_s)
    return float(np.sum(np.maximum(t_h, np.abs(legs.vertical_m) / rate) + legs.hold_s))


def level_leg_energy_wh(
    profile: VehicleProfile,
    length_m: float,
    speed_m_s: float,
    *,
    headwind_m_s: float = 0.0,
    height_m: float = 0.0,
) -> float:
    """Energy (Wh) of a straight level leg flown at ``speed_m_s`` over the ground into a
    ``headwind_m_s`` (negative: tailwind) — the small case of :func:`flight_energy`."""
    legs = Legs(
        horizontal_m=np.array([length_m]),
        vertical_m=np.array([0.0]),
        course_deg=np.array([0.0]),
        height_m=np.array([height_m]),
        speed_m_s=np.array([speed_m_s]),
        climb_rate_m_s=np.array([DEFAULT_CLIMB_RATE_M_S]),
        descent_rate_m_s=np.array([DEFAULT_DESCENT_RATE_M_S]),
        hold_s=np.array([0.0]),
    )
    wind = Wind.uniform(abs(headwind_m_s), 0.0 if headwind_m_s >= 0 else 180.0)
    return flight_energy(profile, legs, wind).energy_wh


__all__ = [
    "DEFAULT_CLIMB_RATE_M_S",
    "DEFAULT_DESCENT_RATE_M_S",
    "DEFAULT_RESERVE_PCT",
    "EnergyBudgetError",
    "EnergyUse",
    "LegFigures",
    "Legs",
    "WindTooStrongError",
    "flight_energy",
    "level_leg_energy_wh",
    "still_air_time_s",
]
