"""Name → planner class. Imports are lazy so that reading a scenario stays cheap."""

from __future__ import annotations

import dataclasses
import importlib
from collections.abc import Mapping
from typing import Any

from uavplan.planners import params as P
from uavplan.planners.params import ALGORITHMS, SearchParams, SpsaParams

# name → (module, class)
_REGISTRY: dict[str, tuple[str, str]] = {
    "spsa": ("uavplan.planners.sparrow", "SparrowPlanner"),
    "ssa": ("uavplan.planners.sparrow", "SsaPlanner"),
    "pso": ("uavplan.planners.particle_swarm", "ParticleSwarmPlanner"),
    "gwo": ("uavplan.planners.grey_wolf", "GreyWolfPlanner"),
    "de": ("uavplan.planners.differential_evolution", "DifferentialEvolutionPlanner"),
    "cso": ("uavplan.planners.chicken_swarm", "ChickenSwarmPlanner"),
}

# name → the dataclass its ``options`` (scenario ``planner.options``) fill
_OPTIONS: dict[str, type] = {
    "pso": P.PsoParams,
    "gwo": P.GwoParams,
    "de": P.DeParams,
    "cso": P.CsoParams,
}


def planner_class(name: str) -> type:
    if name not in _REGISTRY:
        known = ", ".join(n for n in ALGORITHMS if n in _REGISTRY)
        raise ValueError(f"unknown algorithm {name!r} (available: {known})")
    module, cls = _REGISTRY[name]
    return getattr(importlib.import_module(module), cls)


def available() -> tuple[str, ...]:
    return tuple(n for n in ALGORITHMS if n in _REGISTRY)


def options_class(name: str) -> type | None:
    """The parameter dataclass that algorithm ``name``'s options fill (None: takes none)."""
    return _OPTIONS.get(name)


def make_options(name: str, options: Mapping[str, Any] | None) -> Any:
    """Algorithm ``name``'s parameters from an options mapping; ValueError names a bad key."""
    cls = options_class(name)
    options = dict(options or {})
    if cls is None:
        if options:
            raise ValueError(f"algorithm {name!r} takes no options (got {', '.join(options)})")
        return None
    known = P.field_names(cls)
    unknown = sorted(set(options) - set(known))
    if unknown:
        raise ValueError(
            f"unknown {name} option(s) {', '.join(unknown)} (known: {', '.join(known)})"
        )
    return dataclasses.replace(cls(), **options)


def make_planner(
    name: str,
    search: SearchParams,
    spsa: SpsaParams | None = None,
    options: Mapping[str, Any] | None = None,
) -> Any:
    """Build planner ``name``. SPSA takes ``spsa``; the baselines take ``options`` (the fields
    of their parameter dataclass, see :func:`options_class`)."""
    cls = planner_class(name)
    if name == "spsa":
        return cls(search, spsa or SpsaParams())
    if name == "ssa":
        return cls(search)
    return cls(search, make_options(name, options))
