"""The way home: the autopilot's return proven from every point of a route (:mod:`.proof`),
and a planned scenario's way home with the parameters its mission relies on (:mod:`.home`).
See docs/way-home.md."""

from __future__ import annotations

from uavplan.wayhome.home import (
    LANDING,
    WayHome,
    corner_stops,
    fence_parameters,
    floor_world,
    rtl_parameter,
    way_home,
)
from uavplan.wayhome.proof import (
    RTL_PARAMETERS,
    RtlProof,
    firmware_rtl,
    prove_rtl,
    return_samples,
    sample_step_m,
    unsafe_returns,
)

__all__ = [
    "LANDING",
    "RTL_PARAMETERS",
    "RtlProof",
    "WayHome",
    "corner_stops",
    "fence_parameters",
    "firmware_rtl",
    "floor_world",
    "prove_rtl",
    "return_samples",
    "rtl_parameter",
    "sample_step_m",
    "unsafe_returns",
    "way_home",
]
