"""The ``--report`` JSON of ``plan`` (SPEC §3) and of a rerouted QGroundControl plan, and
what a .geojson / .kml export draws beyond the mission: the application presents what the
planning layers return (they build no JSON and draw nothing)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from uavplan.route import keeps_margin
from uavplan.scenario import resolved_config
from uavplan.worlds import enu_frame

if TYPE_CHECKING:
    from uavplan.flightcheck import FlightPrediction
    from uavplan.mission.export import ExportExtras
    from uavplan.mission.items import MissionPlan
    from uavplan.planning import RouteResult
    from uavplan.reroute import RerouteResult
    from uavplan.route import PlannedRoute
    from uavplan.scenario import Scenario


def route_report(
    result: RouteResult, scenario: Scenario, flight: FlightPrediction | None = None
) -> dict[str, Any]:
    """The report of one planned route (SPEC §3 keys, the run's budget and the resolved
    configuration), with its predicted ``flight`` when it was rehearsed."""
    path, turning, climb = result.energy_terms
    pr = result.planner
    route = result.route
    return {
        "scenario": scenario.name,
        "algorithm": result.algorithm,
        "seed": result.seed,
        "status": result.status,
        "energy": result.energy,
        "energy_terms": {"path": path, "turning": turning, "climb": climb},
        "search_fitness": pr.best_fitness,
        "length_m": result.length_m,
        "runtime_s": result.runtime_s,
        "iterations": pr.iterations,
        "termination": pr.termination,
        "evaluations": pr.evaluations,
        "reach_checks": pr.reach_checks,
        "exact_reach_checks": pr.exact_checks,
        "convergence": [float(v) for v in pr.convergence],
        "waypoints": 0 if route is None else int(route.waypoints_enu.shape[0]),
        "min_clearance_m": result.min_clearance_m,
        "safety_margin_m": scenario.safety_margin_m,
        "collision_free": result.collision_free,
        "deadlocks": pr.deadlocks,
        "planner_stats": pr.stats,
        "message": result.message,
        "notes": list(result.notes),
        "guide_s": result.guide_s,
        "legs": [leg.summary() for leg in result.legs],
        **_flight_entries(flight),
        **({} if scenario.airspace is None else {"airspace": scenario.airspace.report()}),
        "config": {
            **resolved_config(scenario, result.algorithm),
            "post_applied": vars(result.post),
        },
    }


def reroute_report(result: RerouteResult, flight: FlightPrediction | None = None) -> dict[str, Any]:
    """The report of a rerouted plan: totals, the legs of every planning run, the notes, and
    its predicted ``flight`` when it was rehearsed."""
    return {
        "input": "qgc-plan",
        "scenario": result.name,
        "items_in": len(result.plan.items) - result.inserted,
        "items_out": len(result.plan.items),
        "inserted_waypoints": result.inserted,
        "energy_rerouted_legs": result.energy,
        "length_m": result.length_m,
        "runtime_s": result.runtime_s,
        "min_clearance_m": result.min_clearance_m,
        "safety_margin_m": result.safety_margin_m,
        "collision_free": keeps_margin(result.min_clearance_m, result.safety_margin_m),
        "end": result.end,
        "notes": list(result.notes),
        "runs": [route_report(r, scn) for scn, r in result.runs],
        **_flight_entries(flight),
    }


def _flight_entries(flight: FlightPrediction | None) -> dict[str, Any]:
    """``flight_time_s`` and ``flight`` (the predicted flight) when it was rehearsed."""
    if flight is None:
        return {}
    return {"flight_time_s": round(flight.flight_time_s, 1), "flight": flight.summary()}


def export_extras(
    scenario: Scenario,
    route: PlannedRoute | None = None,
    properties: Mapping[str, Any] | None = None,
    plan: MissionPlan | None = None,
) -> ExportExtras:
    """What a .geojson / .kml export draws beyond the mission: ``scenario``'s obstacles, name
    and margin, and with a just-planned ``route`` its smoothed path and flown line. Over
    terrain: altitudes AMSL, the obstacles' heights above the ground, and (with the mission
    ``plan`` of a file) its flight as the autopilot flies it over the ground."""
    from uavplan.mission.export import ExportExtras

    site = scenario.site
    ground = site.ground
    terrain: dict[str, Any] = {}
    if ground is not None:
        frame = enu_frame(site)
        datum = ground.datum_amsl_m

        def ground_amsl(lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
            return np.asarray(ground.z_at(frame.to_enu_xy(lat, lon))) + datum

        terrain = {
            "heights_agl_m": tuple(float(o.height_m) for o in scenario.obstacles),
            "ground_amsl_m": ground_amsl,
        }
    labels = {} if scenario.airspace is None else scenario.airspace.labels()
    if route is not None:
        return ExportExtras.for_route(
            route,
            site.obstacles,
            name=scenario.name,
            properties=properties,
            obstacle_labels=labels,
            **terrain,
        )
    flown = None
    if ground is not None and plan is not None:  # the one reading of a mission over terrain
        from uavplan.flightcheck import flight_of_mission

        flown = flight_of_mission(plan, enu_frame(site), ground.z_at, ground.follow).points_enu
    return ExportExtras(
        frame=enu_frame(site),
        obstacles=site.obstacles,
        flown_enu=flown,
        name=scenario.name,
        safety_margin_m=scenario.safety_margin_m,
        properties=dict(properties or {}),
        datum_amsl_m=site.datum_amsl_m,
        obstacle_labels=labels,
        **terrain,
    )


__all__ = ["export_extras", "reroute_report", "route_report"]
