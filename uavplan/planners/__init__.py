"""Planners: SPSA and the baselines behind one small interface (:mod:`.base`).

Planners know nothing of files or MAVLink; :func:`make_planner` is the registry.
"""

from uavplan.planners.registry import make_planner, planner_class

__all__ = ["make_planner", "planner_class"]
