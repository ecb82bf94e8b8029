"""The altitude each firmware's return to launch flies at: one definition, vectorised.

PX4 and ArduPilot Copter both return by climbing where they are to a return altitude, flying
straight home at it and descending there. That altitude depends on the RTL parameters, the
distance from home and the altitude the return starts from; :func:`return_altitude_m` is that
rule, for one point or many at once. The flight model (:mod:`.model`) flies its returns at
it, and the proof of the way home (:mod:`uavplan.wayhome.proof`) checks returns from every point of
a route at it, so the two cannot disagree.

- **ArduPilot Copter** (``ModeRTL::compute_return_target``, ArduCopter/mode_rtl.cpp): at least
  ``RTL_ALT`` and the current altitude plus ``RTL_CLIMB_MIN`` (and ArduCopter's 30 cm
  ``RTL_ALT_MIN``); near home lowered to the cone ``distance x RTL_CONE_SLOPE`` (a slope
  below 0.5 is no cone), never below the current altitude plus ``RTL_CLIMB_MIN``; with an
  altitude fence enabled, at most the fence's ceiling less ``FENCE_MARGIN``; never below the
  current altitude.
- **PX4** (``RTL::calculate_return_alt_from_cone_half_angle``, navigator/rtl.cpp):
  ``RTL_RETURN_ALT``; within ``RTL_MIN_DIST`` of home lowered to the cone of half-angle
  ``RTL_CONE_ANG`` (0: no cone), but at least twice ``NAV_ACC_RAD`` outside the acceptance
  radius and twice the distance inside it; never below the current altitude.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uavplan.autopilot.params import GuidanceLimits

__all__ = ["ARDUPILOT_RTL_ALT_MIN_M", "ARDUPILOT_RTL_MIN_CONE_SLOPE", "return_altitude_m"]

#: ArduPilot's lowest return altitude (ArduCopter/config.h RTL_ALT_MIN, 30 cm)
ARDUPILOT_RTL_ALT_MIN_M = 0.3
#: ArduPilot ignores a cone flatter than this (ArduCopter/config.h RTL_MIN_CONE_SLOPE)
ARDUPILOT_RTL_MIN_CONE_SLOPE = 0.5


def return_altitude_m(
    limits: GuidanceLimits, distance_m: ArrayLike, altitude_m: ArrayLike
) -> NDArray[np.float64]:
    """The altitude above home (m) a return flies home at, from points ``distance_m``
    (horizontally) from home at ``altitude_m`` above home (arrays broadcast together; see
    the module docstring for each firmware's rule). Non-decreasing in the RTL altitude
    parameter and in the starting altitude."""
    d = np.asarray(distance_m, dtype=np.float64)
    z = np.asarray(altitude_m, dtype=np.float64)
    d, z = np.broadcast_arrays(d, z)
    lim = limits
    if not lim.is_px4:
        floor = np.maximum(ARDUPILOT_RTL_ALT_MIN_M, z + lim.rtl_climb_min_m)
        target = np.maximum(lim.rtl_altitude_m, floor)
        if lim.rtl_cone >= ARDUPILOT_RTL_MIN_CONE_SLOPE:
            target = np.minimum(target, np.maximum(d * lim.rtl_cone, floor))
        if lim.fence_ceiling_m is not None:
            target = np.minimum(target, lim.fence_ceiling_m - lim.fence_margin_m)
        return np.maximum(target, z)
    ret = np.full(d.shape, lim.rtl_altitude_m)
    if lim.rtl_cone > 0.0:
        accept = lim.acceptance_radius_m
        half = math.radians(min(89.0, max(1.0, lim.rtl_cone)))
        coned = np.where(d <= lim.rtl_min_dist_m, np.minimum(d / math.tan(half), ret), ret)
        ret = np.where(d <= accept, 2.0 * d, np.maximum(coned, 2.0 * accept))
    return np.maximum(ret, z)
