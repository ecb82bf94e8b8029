"""The way home: the autopilot's return proven from every point of a route (:mod:`.proof`),
and a planned scenario's way home with the parameters its mission relies on (:mod:`.home`).
See docs/way-home.md.

Only the proof is re-exported here: :mod:`.home` plans (it imports the planners), and the
proof is what ``fly``, ``simulate`` and ``validate`` need (through :mod:`uavplan.verdict`);
importing the package must not load the planners for them. Import the planned way home from
:mod:`uavplan.wayhome.home`."""

from __future__ import annotations

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
    "RTL_PARAMETERS",
    "RtlProof",
    "firmware_rtl",
    "prove_rtl",
    "return_samples",
    "sample_step_m",
    "unsafe_returns",
]
