"""A mission read the way the flight model flies it: wire-ordered items as :class:`NavItem`,
positions in ENU metres in the frame at home."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from uavplan.autopilot.kinematics import Vec
from uavplan.geo import GeoPoint
from uavplan.mission.items import MavCmd, MavFrame, MissionItem, canonical_frame

#: MAV_CMD values below this are NAV commands
FIRST_DO_COMMAND = 80


@dataclass(frozen=True)
class NavItem:
    """A mission item as the model flies it: ``seq`` as on the wire, position in ENU metres
    in the frame at home (``None`` for items without one, or at lat/lon 0: "here").

    ``terrain_m``: for an item in a terrain frame, its height above the ground (its
    ``position`` z is that height over the ground beneath it); ArduPilot follows the ground
    on the leg to it. ``None`` for the other frames. ``here_alt_m``: the altitude of a NAV
    item at lat/lon 0 (a take-off "where the vehicle is"), which has no ``position``."""

    seq: int
    command: int
    position: Vec | None = None
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    terrain_m: float | None = None
    here_alt_m: float | None = None

    @property
    def altitude_m(self) -> float | None:
        """The item's altitude above home (its position's z, or ``here_alt_m``)."""
        return self.position[2] if self.position is not None else self.here_alt_m

    @property
    def is_nav(self) -> bool:
        return self.command < FIRST_DO_COMMAND

    @property
    def is_position(self) -> bool:
        return self.is_nav and self.position is not None


def nav_items(
    items: Sequence[MissionItem],
    home: GeoPoint,
    *,
    ground_z: Callable[[float, float], float] | None = None,
) -> tuple[NavItem, ...]:
    """Wire-ordered mission items (ArduPilot's home at seq 0 included) → :class:`NavItem`.

    Positions go into the ENU frame at ``home`` exactly as the mission builder made them
    (:mod:`uavplan.mission.builder`): x/y where the ellipsoid normal through lat/lon meets
    the ground plane, z the altitude above home (relative frames), AMSL minus home's
    altitude (frame 0), or above the ground (terrain frames: ``ground_z(x, y)``, the
    ground's height above home; flat ground without it). Vectorised: one conversion for all
    items.
    """
    from uavplan.geo import EnuFrame

    frame = EnuFrame.at(home)
    located = [
        i
        for i, item in enumerate(items)
        if item.is_global and item.command < FIRST_DO_COMMAND and (item.x, item.y) != (0.0, 0.0)
    ]
    where: dict[int, tuple[float, float]] = {}
    if located:
        xy = frame.to_enu_xy([items[i].x for i in located], [items[i].y for i in located])
        where = {index: (float(xy[k][0]), float(xy[k][1])) for k, index in enumerate(located)}
    out: list[NavItem] = []
    for seq, item in enumerate(items):
        position: Vec | None = None
        terrain_m: float | None = None
        here_alt_m: float | None = None
        if seq in where:
            x, y = where[seq]
            frame_id = canonical_frame(item.frame)
            if frame_id == MavFrame.GLOBAL:
                z = item.z - home.alt_m
            elif frame_id == MavFrame.GLOBAL_TERRAIN_ALT:
                terrain_m = float(item.z)
                z = item.z if ground_z is None else item.z + ground_z(x, y)
            else:
                z = item.z
            position = (x, y, z)
        elif item.is_global and item.command < FIRST_DO_COMMAND:
            here_alt_m = float(item.z)  # lat/lon 0: "where the vehicle is", at this altitude
        out.append(
            NavItem(
                seq=seq,
                command=int(item.command),
                position=position,
                param1=item.param1 or 0.0,
                param2=item.param2 or 0.0,
                param3=item.param3 or 0.0,
                param4=item.param4 or 0.0,
                terrain_m=terrain_m,
                here_alt_m=here_alt_m,
            )
        )
    return tuple(out)


def planned_legs(nav: Sequence[NavItem]) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The mission's straight legs as the flight model draws them: home, the take-off's
    climb, each positional item, as ENU points ``(m, 3)`` in the frame at home; and the wire
    seq of the item each point is (-1: home)."""
    points = [(0.0, 0.0, 0.0)]
    seqs = [-1]
    for item in nav:
        if item.is_position:
            assert item.position is not None
            points.append(item.position)
            seqs.append(item.seq)
        elif item.command == MavCmd.NAV_TAKEOFF and item.altitude_m is not None:
            points.append((points[-1][0], points[-1][1], item.altitude_m))
            seqs.append(item.seq)
    return np.array(points, dtype=np.float64), np.array(seqs, dtype=np.int64)
