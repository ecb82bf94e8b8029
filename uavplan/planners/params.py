"""Re-export shim: the planner parameter classes live in :mod:`uavplan.config` (the bottom
layer). Kept so that existing imports work while the code moves; import from
``uavplan.config``."""

from __future__ import annotations

from uavplan.config import (
    PLANNERS,
    CsoParams,
    DeParams,
    EnergyWeights,
    GridSpec,
    GwoParams,
    PostParams,
    PsoParams,
    SearchParams,
    SpsaParams,
    field_names,
)

#: Every algorithm the ``--algorithm`` option accepts (a snapshot of the planner table at
#: import time; use ``uavplan.config.PLANNERS`` for planners registered later).
ALGORITHMS: tuple[str, ...] = tuple(PLANNERS)

__all__ = [
    "ALGORITHMS",
    "CsoParams",
    "DeParams",
    "EnergyWeights",
    "GridSpec",
    "GwoParams",
    "PostParams",
    "PsoParams",
    "SearchParams",
    "SpsaParams",
    "field_names",
]
