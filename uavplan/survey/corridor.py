"""A corridor scan: lanes along a polyline (a power line, a pipeline, a road) across a strip
``width_m`` wide, each lane bending with the corridor (QGroundControl's CorridorScan flies its
transects the same way: parallel to the polyline, back and forth).

The lanes are the corridor's offset curves (mitred at the bends), as many as
:func:`uavplan.survey.coverage.lane_offsets_m` spaces across the width; each is clipped to
the free area (the strip minus the holes), so a lane stops at a hole's margin and resumes
past it. The lanes are flown back and forth from the end and side whose straight-line flight
costs the least energy. Every lane becomes straight pieces; a piece that continues its lane
through a bend is flagged ``joined`` (no transition, no camera stop between them).
"""

from __future__ import annotations

import itertools

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray
from shapely.geometry import LineString
from shapely.geometry.base import BaseGeometry

from . import coverage
from .sweep import EnergyFn, Sweep

#: how far a mitred bend of an offset lane may reach, in lane offsets (then it is bevelled)
MITRE_LIMIT = 2.0
#: lane parts shorter than this (m) are dropped: no photo line worth a turn
MIN_PART_M = 1.0


def strip(corridor_xy: ArrayLike, width_m: float) -> BaseGeometry:
    """The corridor's strip: the polyline grown by half the width each side, flat at its ends,
    mitred at its bends."""
    line = LineString(np.asarray(corridor_xy, dtype=np.float64))
    return line.buffer(width_m / 2.0, cap_style="flat", join_style="mitre", mitre_limit=MITRE_LIMIT)


def _parts(curve: LineString, free: BaseGeometry) -> list[NDArray[np.float64]]:
    """``curve`` clipped to ``free``: its pieces in order along it, each in its direction."""
    clipped = curve.intersection(free)
    out = []
    for g in shapely.get_parts(clipped):
        if not isinstance(g, LineString) or g.length < MIN_PART_M:
            continue
        xy = np.asarray(g.coords, dtype=np.float64)
        if curve.project(shapely.Point(xy[-1])) < curve.project(shapely.Point(xy[0])):
            xy = xy[::-1]
        out.append(xy)
    out.sort(key=lambda xy: curve.project(shapely.Point(xy[0])))
    return out


def corridor_lanes(
    corridor_xy: ArrayLike, width_m: float, free: BaseGeometry, spacing_m: float
) -> list[list[NDArray[np.float64]]]:
    """Per lane (across the corridor, from its right side), its parts in the free area, each a
    polyline ``(k, 2)`` in the corridor's direction."""
    line = LineString(np.asarray(corridor_xy, dtype=np.float64))
    offsets = coverage.lane_offsets_m(width_m, spacing_m) - width_m / 2.0
    lanes = []
    for off in offsets:
        curve = (
            line
            if abs(off) < 1e-9
            else line.offset_curve(float(off), join_style="mitre", mitre_limit=MITRE_LIMIT)
        )
        if not isinstance(curve, LineString) or curve.is_empty:
            continue
        xy = np.asarray(curve.coords, dtype=np.float64)
        start = np.asarray(line.coords[0])
        if np.hypot(*(xy[-1] - start)) < np.hypot(*(xy[0] - start)):
            curve = LineString(xy[::-1])  # in the corridor's direction
        lanes.append(_parts(curve, free))
    return lanes


def _pieces(
    lanes: list[list[NDArray[np.float64]]], forward_first: bool
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """The lanes flown back and forth, the first one forward or not: straight pieces in
    flying order and their ``joined`` flags."""
    pieces: list[NDArray[np.float64]] = []
    joined: list[bool] = []
    for k, parts in enumerate(lanes):
        forward = (k % 2 == 0) == forward_first
        seq = parts if forward else [p[::-1] for p in reversed(parts)]
        for xy in seq:
            seg = np.stack([xy[:-1], xy[1:]], axis=1)
            seg = seg[np.hypot(*(seg[:, 1] - seg[:, 0]).T) > 1e-6]
            pieces.extend(seg)
            joined.extend([False] + [True] * (len(seg) - 1))
    if not pieces:
        return np.zeros((0, 2, 2)), np.zeros(0, dtype=bool)
    return np.asarray(pieces), np.asarray(joined, dtype=bool)


def plan_corridor(
    corridor_xy: ArrayLike,
    width_m: float,
    free: BaseGeometry,
    *,
    spacing_m: float,
    trigger_m: float,
    start_xy: ArrayLike,
    energy: EnergyFn,
) -> Sweep:
    """The corridor's lanes over ``free`` from and back to ``start_xy``, flown from the end
    and side of least ``energy``. Raises ValueError when no lane fits in the free area."""
    start = np.asarray(start_xy, dtype=np.float64)[:2]
    lanes = corridor_lanes(corridor_xy, width_m, free, spacing_m)
    best: Sweep | None = None
    for side, forward_first in itertools.product((1, -1), (True, False)):
        pieces, joined = _pieces(lanes[::side], forward_first)
        if not len(pieces):
            continue
        path = coverage.path_xy(pieces, start)
        lengths = np.hypot(*(pieces[:, 1] - pieces[:, 0]).T)
        sweep = Sweep(
            angle_deg=float("nan"),
            pieces_xy=pieces,
            path_xy=path,
            energy_wh=float(energy(path)),
            photos=coverage.photo_count(pieces, trigger_m, joined),
            lane_length_m=float(lengths.sum()),
            joined=joined,
        )
        if best is None or sweep.energy_wh < best.energy_wh - 1e-12:
            best = sweep
    if best is None:
        raise ValueError("no lane fits in the corridor outside the holes")
    return best


__all__ = ["corridor_lanes", "plan_corridor", "strip"]
