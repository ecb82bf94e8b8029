"""Name → planner object, from the planner table :data:`uavplan.config.PLANNERS`.

Classes are imported lazily from each entry's ``"module:Class"`` target, so reading a scenario
or listing the planners never loads the optimisers (or the compiled kernels).
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any

from uavplan.config import (
    PLANNERS,
    PlannerConfig,
    SearchParams,
    SpsaParams,
    build_params,
    planner_entry,
)


def planner_class(name: str) -> type:
    """The class of planner ``name``; ConfigError (a ValueError) for an unknown name."""
    entry = planner_entry(name)
    if isinstance(entry.target, type):
        return entry.target
    module, _, cls = entry.target.partition(":")
    return getattr(importlib.import_module(module), cls)  # type: ignore[no-any-return]


def available() -> tuple[str, ...]:
    """Every registered planner, in table order."""
    return tuple(PLANNERS)


def options_class(name: str) -> type | None:
    """The parameter dataclass of planner ``name``'s section (None: it takes none)."""
    return planner_entry(name).params


def make_options(name: str, options: Mapping[str, Any] | None) -> Any:
    """Planner ``name``'s parameters from a mapping of its keys (validated by
    :func:`uavplan.config.build`; ConfigError, a ValueError, names a bad key)."""
    return build_params(name, dict(options or {}))


def make_planner(
    name: str,
    cfg: PlannerConfig | SearchParams,
    spsa: SpsaParams | None = None,
    options: Mapping[str, Any] | None = None,
) -> Any:
    """Build planner ``name`` as ``Cls(search, params)``.

    ``make_planner(name, cfg)`` with a :class:`PlannerConfig` takes the search values and
    ``cfg.params_for(name)`` (the planner's section or its defaults). The older form
    ``make_planner(name, search, spsa, options)`` is kept while callers move: SPSA takes
    ``spsa``, other planners build their parameters from ``options``.
    """
    cls = planner_class(name)
    entry = planner_entry(name)
    if isinstance(cfg, PlannerConfig):
        return cls(cfg.search, cfg.params_for(name))
    search = cfg
    if entry.params is None:
        return cls(search, None)
    if entry.params is SpsaParams and spsa is not None and not options:
        return cls(search, spsa)
    return cls(search, make_options(name, options))
