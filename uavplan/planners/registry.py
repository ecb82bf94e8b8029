"""Name → planner class. Imports are lazy so that reading a scenario stays cheap."""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any

from uavplan.planners.params import ALGORITHMS, SearchParams, SpsaParams

# name → (module, class)
_REGISTRY: dict[str, tuple[str, str]] = {
    "spsa": ("uavplan.planners.sparrow", "SparrowPlanner"),
    "ssa": ("uavplan.planners.sparrow", "SsaPlanner"),
}


def planner_class(name: str) -> type:
    if name not in _REGISTRY:
        known = ", ".join(n for n in ALGORITHMS if n in _REGISTRY)
        raise ValueError(f"unknown algorithm {name!r} (available: {known})")
    module, cls = _REGISTRY[name]
    return getattr(importlib.import_module(module), cls)


def available() -> tuple[str, ...]:
    return tuple(n for n in ALGORITHMS if n in _REGISTRY)


def make_planner(
    name: str,
    search: SearchParams,
    spsa: SpsaParams | None = None,
    options: Mapping[str, Any] | None = None,
) -> Any:
    """Build planner ``name``. SPSA takes ``spsa``; other algorithms take ``options``
    (their own keyword parameters)."""
    cls = planner_class(name)
    if name == "spsa":
        return cls(search, spsa or SpsaParams())
    if name == "ssa":
        return cls(search)
    return cls(search, **dict(options or {}))
