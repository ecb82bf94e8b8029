"""The photos a flown mission takes: its camera items executed along the flight model's
track (the model's kinematics are untouched; this reads its record).

* MAV_CMD_DO_SET_CAM_TRIGG_DIST (206): a distance > 0 starts distance triggering (param3 = 1:
  one photo at once), then a photo every ``distance`` metres of horizontal path flown; 0
  stops it (PX4 drivers/camera_trigger, ArduPilot AP_Camera::set_trigger_distance);
* MAV_CMD_IMAGE_START_CAPTURE (2000) with param3 = n > 0 images: n photos there (the
  interval, param2, is not modelled: a hover-and-capture survey asks for one).

A DO item runs when the autopilot moves past it: at the first sample whose current item is
beyond it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from uavplan.mission.items import MavCmd

if TYPE_CHECKING:
    from uavplan.autopilot.simulate import FlownTrack

_TRIGG_DIST = int(MavCmd.DO_SET_CAM_TRIGG_DIST)
_CAPTURE = int(MavCmd.IMAGE_START_CAPTURE)


def has_camera_items(flown: FlownTrack) -> bool:
    """Does the flown mission hold any camera item this module executes?"""
    return any(item.command in (_TRIGG_DIST, _CAPTURE) for item in flown.nav)


def photo_positions(flown: FlownTrack) -> NDArray[np.float64]:
    """Where the photos were taken ``(k, 3)`` (ENU m in the track's frame), in order."""
    seq = np.asarray(flown.current_seq)
    xyz = np.column_stack([flown.x_m, flown.y_m, flown.z_m])
    if len(seq) == 0:
        return np.zeros((0, 3))
    step = np.hypot(np.diff(flown.x_m), np.diff(flown.y_m))
    cum = np.concatenate([[0.0], np.cumsum(step)])  # horizontal path flown at each sample
    events: list[tuple[int, int, float, float]] = []  # (sample, command, param1, param3)
    for item in flown.nav:
        if item.command not in (_TRIGG_DIST, _CAPTURE):
            continue
        past = np.flatnonzero(seq > item.seq)
        if len(past):
            events.append((int(past[0]), item.command, item.param1, item.param3))
    events.sort(key=lambda e: e[0])
    out: list[NDArray[np.float64]] = []
    on: tuple[int, float] | None = None  # (sample, distance) of the triggering in force

    def close(until: int) -> None:
        if on is None:
            return
        start, dist = on
        marks = np.arange(dist, cum[until] - cum[start] + 1e-9, dist) + cum[start]
        rows = np.searchsorted(cum, marks)
        out.append(xyz[np.minimum(rows, len(xyz) - 1)])

    for sample, command, p1, p3 in events:
        if command == _CAPTURE:
            out.append(np.repeat(xyz[sample][None], max(int(round(p3)), 1), axis=0))
            continue
        close(sample)
        on = None
        if p1 > 0:
            on = (sample, p1)
            if p3 >= 1:
                out.append(xyz[sample][None])
    close(len(xyz) - 1)
    return np.vstack(out) if out else np.zeros((0, 3))


__all__ = ["has_camera_items", "photo_positions"]
