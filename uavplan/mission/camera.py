"""Where a mission's camera items ask for photos, on its straight legs: the photos it plans
(the flight model's, taken along the track as flown, are :mod:`uavplan.autopilot.camera`'s).

* MAV_CMD_DO_SET_CAM_TRIGG_DIST (206): a distance > 0 starts distance triggering (param3 = 1:
  one photo at once), a photo every ``distance`` metres of horizontal path after that; 0
  stops it;
* MAV_CMD_IMAGE_START_CAPTURE (2000) of n > 0 images: a photo where it runs.

The legs are straight lines between the mission's positioned NAV items from home (the
waypoints a survey flies), in a given ENU frame.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from uavplan.geo import EnuFrame
from uavplan.mission.items import MavCmd, MissionPlan

#: the first MAV_CMD that is not a NAV command (NAV commands are below 93)
_FIRST_NON_NAV = 93


def mission_photos(plan: MissionPlan, frame: EnuFrame) -> NDArray[np.float64]:
    """The photos ``plan`` asks for, ``(k, 2)`` ENU metres in ``frame``, in order."""
    positioned = [
        i for i, item in enumerate(plan.items) if item.is_global and item.command < _FIRST_NON_NAV
    ]
    if not positioned:
        return np.zeros((0, 2))
    lat = [plan.items[i].lat_deg for i in positioned]
    lon = [plan.items[i].lon_deg for i in positioned]
    xy_of = dict(zip(positioned, np.asarray(frame.to_enu_xy(lat, lon)).reshape(-1, 2), strict=True))
    if plan.home is not None:
        pos = np.asarray(frame.to_enu_xy([plan.home.lat_deg], [plan.home.lon_deg])).reshape(2)
    else:
        pos = xy_of[positioned[0]]
    out: list[NDArray[np.float64]] = []
    spacing = 0.0  # the distance trigger in force (0: off)
    since = 0.0  # path flown since its last photo
    for i, item in enumerate(plan.items):
        if item.command == MavCmd.DO_SET_CAM_TRIGG_DIST:
            spacing = max(float(item.param1 or 0.0), 0.0)
            if spacing > 0.0 and item.param3 == 1.0:
                out.append(pos[None])
            since = 0.0
        elif item.command == MavCmd.IMAGE_START_CAPTURE and (item.param3 or 0.0) >= 1.0:
            out.append(pos[None])
        elif i in xy_of:
            b = xy_of[i]
            length = float(np.hypot(*(b - pos)))
            if spacing > 0.0 and length > 0.0:
                s = np.arange(spacing - since, length + 1e-9, spacing)
                if len(s):
                    out.append(pos + (s / length)[:, None] * (b - pos))
                    since = length - float(s[-1])
                else:
                    since += length
            pos = b
    return np.vstack(out) if out else np.zeros((0, 2))


__all__ = ["mission_photos"]
