"""Scenario and map files (SPEC §2): the only YAML reader of the project, and the checked
scenario values.

:func:`load_scenario` (:meth:`Scenario.from_file`) reads a scenario, merges the map it names,
checks every key and returns a frozen :class:`Scenario` that checks itself as a whole when it
is made (so no unchecked scenario exists). Any problem raises
:class:`~uavplan.errors.ScenarioError` naming the file, the key path (``obstacles[2].radius``)
and the reason. The planner's own values are checked by :func:`uavplan.config.build`, the
project's one configuration validator.

Modules: :mod:`~uavplan.scenario.limits` (the documented limits),
:mod:`~uavplan.scenario.yamlfile` (bytes → document, with its fast path),
:mod:`~uavplan.scenario.fields` (each section, key by key), :mod:`~uavplan.scenario.load`
(files, maps, obstacle files, the DEM), :mod:`~uavplan.scenario.settings` and
:mod:`~uavplan.scenario.values` (the values and their checks),
:mod:`~uavplan.scenario.clearance` (exact clearances without the world) and
:mod:`~uavplan.scenario.site` (where the planner flies a scenario: over a DEM, on the ground).
"""

from __future__ import annotations

from uavplan.config import ALTITUDE_MODES, PlannerConfig
from uavplan.scenario.load import load_map
from uavplan.scenario.settings import MissionConfig, ObstacleSources, VehicleConfig
from uavplan.scenario.site import Site
from uavplan.scenario.values import (
    Scenario,
    Surroundings,
    check_limits,
    load_scenario,
    load_site,
    load_surroundings,
    problem_size,
    resolved_config,
    with_search,
)

__all__ = [
    "ALTITUDE_MODES",
    "MissionConfig",
    "ObstacleSources",
    "PlannerConfig",
    "Scenario",
    "Site",
    "Surroundings",
    "VehicleConfig",
    "check_limits",
    "load_map",
    "load_scenario",
    "load_site",
    "load_surroundings",
    "problem_size",
    "resolved_config",
    "with_search",
]
