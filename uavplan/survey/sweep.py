"""One survey pattern, planned: sweep angle, lane pieces in flying order, photos.

:func:`plan_sweep` clips lanes at one angle (or, for ``angle_deg=None``, at each candidate
angle and keeps the one whose straight-line flight costs the least energy by the vehicle's
power model in the given wind — not the fewest lanes). Transitions are straight lines here;
the wiring layer checks them against the world and reroutes the blocked ones.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

from uavplan.airframe.legs import Legs, flight_energy
from uavplan.airframe.profile import VehicleProfile
from uavplan.airframe.wind import Wind

from . import coverage

#: energy (Wh) of a flown straight-line path ``(m, 2)`` at the survey height
EnergyFn = Callable[[NDArray[np.float64]], float]


@dataclass(frozen=True)
class Sweep:
    """A planned survey pattern (ENU metres)."""

    angle_deg: float
    #: lane pieces in flying order, each flown from [k, 0] to [k, 1]: ``(n, 2, 2)``
    pieces_xy: NDArray[np.float64]
    #: start, the pieces end to end, start: ``(2n + 2, 2)``
    path_xy: NDArray[np.float64]
    energy_wh: float
    photos: int
    lane_length_m: float
    #: per piece: True where it continues the lane of the piece before it (a corridor's
    #: lanes bend with the corridor; an area's lanes are straight: None)
    joined: NDArray[np.bool_] | None = None

    @property
    def lanes(self) -> int:
        """How many lanes (a corridor's bent lane is one, its straight pieces several)."""
        return len(coverage.runs(len(self.pieces_xy), self.joined))


def energy_of(
    profile: VehicleProfile,
    *,
    altitude_m: float,
    speed_m_s: float,
    wind: Wind | None = None,
) -> EnergyFn:
    """The energy function :func:`plan_sweep` ranks angles by: level flight at
    ``altitude_m`` and ``speed_m_s`` through ``wind`` with the vehicle's power model."""

    def energy(path: NDArray[np.float64]) -> float:
        xyz = np.column_stack([path, np.full(len(path), altitude_m)])
        legs = Legs.from_path(xyz, speed_m_s=speed_m_s)
        return flight_energy(profile, legs, wind).energy_wh

    return energy


def _one(
    area: Polygon,
    free: BaseGeometry,
    angle_deg: float,
    spacing_m: float,
    trigger_m: float,
    start: NDArray[np.float64],
    energy: EnergyFn,
) -> Sweep:
    pieces = coverage.order(
        coverage.lanes(area, free, angle_deg=angle_deg, spacing_m=spacing_m), start
    )
    path = coverage.path_xy(pieces, start)
    lengths = np.hypot(*(pieces[:, 1] - pieces[:, 0]).T) if len(pieces) else np.zeros(0)
    return Sweep(
        angle_deg=float(angle_deg),
        pieces_xy=pieces,
        path_xy=path,
        energy_wh=float(energy(path)),
        photos=coverage.photo_count(pieces, trigger_m),
        lane_length_m=float(lengths.sum()),
    )


def plan_sweep(
    area: Polygon,
    free: BaseGeometry,
    *,
    spacing_m: float,
    trigger_m: float,
    start_xy: ArrayLike,
    energy: EnergyFn,
    angle_deg: float | None = None,
) -> Sweep:
    """The lanes over ``free`` (``area`` minus the holes) from and back to ``start_xy``:
    at ``angle_deg``, or at the candidate angle of least ``energy`` when it is None (ties:
    the smaller angle). Raises ValueError when no lane fits in the free area."""
    start = np.asarray(start_xy, dtype=np.float64)[:2]
    angles = coverage.candidate_angles_deg(area) if angle_deg is None else np.array([angle_deg])
    best: Sweep | None = None
    for a in angles:
        s = _one(area, free, float(a), spacing_m, trigger_m, start, energy)
        if len(s.pieces_xy) and (best is None or s.energy_wh < best.energy_wh - 1e-12):
            best = s
    if best is None:
        raise ValueError("no lane fits in the survey area outside the holes")
    return best


__all__ = ["EnergyFn", "Sweep", "energy_of", "plan_sweep"]
