"""A scenario's vehicle and mission settings and where its obstacles came from: small
frozen values, checked when they are made."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any

from uavplan.config import ALTITUDE_MODES, END_ACTIONS
from uavplan.flavour import Autopilot
from uavplan.scenario.limits import MAX_ALTITUDE_M, MAX_CRUISE_SPEED_M_S, SPACING_RANGE_M

if TYPE_CHECKING:
    from uavplan.airframe import VehicleProfile

#: the power model's vehicle when a scenario names none (the simulated vehicle's too)
DEFAULT_PROFILE = "x500"


@dataclass(frozen=True)
class VehicleConfig:
    """``vehicle:``. The two short keys are what the mission tells the autopilot
    (``cruise_speed``: the DO_CHANGE_SPEED of the mission, ``takeoff_altitude``); every other
    key is a field of the power model's vehicle (:class:`~uavplan.airframe.VehicleProfile`,
    units in their names), ``profile`` the bundled profile they override.
    ``profile_spec`` holds those as the file gave them (empty: the scenario names no
    vehicle and the estimates use :data:`DEFAULT_PROFILE`); :attr:`profile` resolves them.
    """

    cruise_speed_m_s: float | None = None
    takeoff_altitude_m: float | None = None  # None: the start point's height
    profile_spec: tuple[tuple[str, Any], ...] = field(default=())

    def __post_init__(self) -> None:
        speed, takeoff = self.cruise_speed_m_s, self.takeoff_altitude_m
        if speed is not None and not (math.isfinite(speed) and 0 < speed <= MAX_CRUISE_SPEED_M_S):
            raise ValueError(f"cruise speed must be in (0, {MAX_CRUISE_SPEED_M_S:g}] m/s")
        if takeoff is not None and not (math.isfinite(takeoff) and 0 < takeoff <= MAX_ALTITUDE_M):
            raise ValueError(f"take-off altitude must be in (0, {MAX_ALTITUDE_M:g}] m")
        if self.profile_spec:
            _ = self.profile  # resolve once: a bad field raises InputError naming it

    @property
    def named(self) -> bool:
        """Does the scenario name its vehicle (a profile or its figures)? Without one the
        estimates use :data:`DEFAULT_PROFILE` and the battery is advice, not a refusal."""
        return bool(self.profile_spec)

    @cached_property
    def profile(self) -> VehicleProfile:
        """The power model's vehicle: the bundled profile named (default
        :data:`DEFAULT_PROFILE`) with the scenario's fields. numpy loads here: a scenario
        that names no vehicle is read without it."""
        from uavplan.airframe.profiles import resolve

        spec = dict(self.profile_spec)
        if not spec:
            return resolve({"profile": DEFAULT_PROFILE})
        return resolve(spec)


#: the default legal ceiling (m above the ground): EU Regulation 2019/947's open category
#: (120 m) and the FAA's Part 107 (400 ft, 121.9 m)
DEFAULT_LEGAL_CEILING_M = 120.0


@dataclass(frozen=True)
class MissionConfig:
    autopilot: Autopilot = Autopilot.ARDUPILOT
    spacing_m: float = 60.0
    end: str = "rtl"  # rtl | land | none | return
    #: waypoint altitudes: relative (above home, MAV_FRAME_GLOBAL_RELATIVE_ALT), amsl
    #: (MAV_FRAME_GLOBAL) or terrain (above the ground beneath, MAV_FRAME_GLOBAL_TERRAIN_ALT)
    altitude: str = "relative"
    #: the route begins with the take-off climb from the ground below the start; False: it
    #: begins in the air at the start (a rerouted stretch of a user's plan). Not a file key.
    takeoff: bool = True
    #: the vehicle's mission storage: the most mission items it holds (ArduPilot's home
    #: included); None: the autopilot's default (uavplan.mavlink.transfer.DEFAULT_STORAGE)
    max_items: int | None = None
    #: ``legal_ceiling``: the highest a return to launch may fly above the ground (m): the
    #: RTL altitude ``plan`` advises stays under it, else the mission ends with a planned
    #: return (EU open category and FAA Part 107: 120 m / 400 ft; None: no limit)
    legal_ceiling_m: float | None = DEFAULT_LEGAL_CEILING_M

    def __post_init__(self) -> None:
        if self.max_items is not None and not 1 <= self.max_items <= 65534:
            raise ValueError("mission max_items must be within 1..65534")
        if self.end not in END_ACTIONS:
            raise ValueError(f"mission end must be one of {', '.join(END_ACTIONS)}")
        if self.altitude not in ALTITUDE_MODES:
            raise ValueError(f"mission altitude must be one of {', '.join(ALTITUDE_MODES)}")
        lo, hi = SPACING_RANGE_M
        if not (math.isfinite(self.spacing_m) and lo <= self.spacing_m <= hi):
            raise ValueError(f"waypoint spacing must be in [{lo:g}, {hi:g}] m")
        ceiling = self.legal_ceiling_m
        if ceiling is not None and not (math.isfinite(ceiling) and ceiling > 0):
            raise ValueError("the legal ceiling must be > 0 m")


@dataclass(frozen=True)
class ObstacleSources:
    """Where a scenario's obstacles came from, to name one in a message: the first ``n_map``
    from the map ``map_ref``, then ``n_inline`` from ``obstacles:``, the rest from
    ``obstacle_files`` (``n_inline`` None: all after the map's are ``obstacles[i]``), and
    from ``zones_from`` on the solids of the ``airspace:`` zones, named ``zone_titles``."""

    n_map: int = 0
    map_ref: str | None = None
    n_inline: int | None = None
    zones_from: int | None = None
    zone_titles: tuple[str, ...] = ()

    def name(self, index: int) -> str:
        if self.zones_from is not None and 0 <= index - self.zones_from < len(self.zone_titles):
            return self.zone_titles[index - self.zones_from]
        if index < self.n_map:
            return f"obstacle #{index} of map {self.map_ref}"
        if self.n_inline is not None and index >= self.n_map + self.n_inline:
            return f"obstacle #{index - self.n_map - self.n_inline} of obstacle_files"
        return f"obstacles[{index - self.n_map}]"
