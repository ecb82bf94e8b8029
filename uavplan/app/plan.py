"""``plan``: plan a scenario into a mission file, or reroute a QGroundControl plan.

:func:`recognise` is the one place that decides what an input is; :func:`plan` dispatches
on it to :func:`plan_scenario` or :func:`uavplan.app.reroute.reroute_file`.
"""

from __future__ import annotations

import enum
import json
import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from uavplan.app.feedback import Feedback, PlannerOptions, flight_text, plural, require_route
from uavplan.app.inputs import load_scenario_file
from uavplan.app.outputs import Output, OutputSet, check_report_name
from uavplan.app.reports import export_extras, route_report
from uavplan.app.reroute import RerouteOutcome, RerouteRequest, reroute_file
from uavplan.errors import InputError, NoPathError
from uavplan.estimate import DEFAULT_RESERVE_PCT, BatteryEstimate, estimate_flown, estimate_route
from uavplan.flown_safe import (
    MAX_REPLANS,
    Flown,
    corner_pad_m,
    plan_padded,
    plan_safe_as_flown,
    refresh_flight,
    widened_until_flown_safe,
)
from uavplan.geo import import_in_background
from uavplan.mission.io import format_for, mission_text
from uavplan.mission.items import Autopilot, MissionPlan
from uavplan.planning import RouteResult, fence_for, mission_for, plan_route
from uavplan.rehearsal import CheckSite
from uavplan.scenario import Scenario
from uavplan.scenario.values import is_survey_file

if TYPE_CHECKING:
    from uavplan.app.survey import SurveyOutcome
    from uavplan.autopilot.simulate import FlownTrack
    from uavplan.flightcheck import FlightPrediction, TrackCheck
    from uavplan.mission.fence import FenceBuild
    from uavplan.route import PlannedRoute
    from uavplan.verdict import FlightVerdict
    from uavplan.wayhome.home import WayHome
    from uavplan.world import World


class InputKind(enum.Enum):
    """What ``plan`` was given."""

    SCENARIO = "scenario"  # a scenario file (YAML): plan it
    QGC_PLAN = "qgc-plan"  # a QGroundControl .plan: reroute it around its exclusion zones


def recognise(path: str) -> InputKind:
    """What the input ``path`` is, from its name: a ``.plan`` is a QGroundControl plan,
    anything else is read as a scenario (whose reader says so if it is not one)."""
    return InputKind.QGC_PLAN if path.lower().endswith(".plan") else InputKind.SCENARIO


@dataclass(frozen=True)
class PlanRequest:
    """``uavplan plan SOURCE -o OUTPUT ...``: ``scenario`` only with a .plan source (its
    obstacles and settings join the rerouting)."""

    source: str
    output: str
    options: PlannerOptions = field(default_factory=PlannerOptions)
    autopilot: str | None = None
    report: str | None = None
    plot: str | None = None
    fence: bool = False
    scenario: str | None = None
    #: ``--reserve``: % of the usable battery left on landing (None: the default, 20 %)
    reserve_pct: float | None = None
    #: ``--view``: the interactive page of the mission written (HTML, uavplan.app.view)
    view: str | None = None
    #: ``--allow-over-battery``: write a mission that does not leave the reserve (a warning)
    allow_over_battery: bool = False
    #: ``--legal-ceiling``: the highest a return may fly above the ground (m), "none" for no
    #: limit (None: the scenario's mission.legal_ceiling, default 120 m)
    legal_ceiling: str | None = None


@dataclass(frozen=True, eq=False)
class PlanOutcome:
    """A planned scenario: the route, the mission written to ``output`` (None when the
    search was interrupted: nothing was written). ``elapsed_s``: the whole use case, from
    reading the scenario to the last output in place."""

    scenario: Scenario
    result: RouteResult
    output: str
    mission: MissionPlan | None = None
    elapsed_s: float = math.nan
    #: the flight's time, energy and battery (docs/energy.md)
    estimate: BatteryEstimate | None = None
    #: how the route gets home (the RTL proof, a planned return, the parameters)
    way: WayHome | None = None
    #: the whole flight judged with the parameters the mission relies on
    verdict: FlightVerdict | None = None
    #: what the flight model predicts for the mission (the whole flight judged), if rehearsed
    flight: FlightPrediction | None = None

    @property
    def interrupted(self) -> bool:
        return self.result.interrupted or (self.way is not None and self.way.interrupted)

    def summary(self) -> str:
        """One line: the mission, the route (its length: the planned path from the start to
        the goal, without the take-off climb and the landing) and the times."""
        route, result = self.result.route, self.result
        assert route is not None and self.mission is not None
        e_path, e_turn, e_climb = result.energy_terms
        return (
            f"{Path(self.output).name}: {len(self.mission.items)} items, "
            f"{route.waypoints_enu.shape[0]} waypoints, {route.length_m:.0f} m from start to "
            f"goal, energy {result.energy:.1f} (path {e_path:.1f}, turning {fixed(e_turn, 2)}, "
            f"climb {e_climb:.1f}), min clearance {route.min_clearance_m:.2f} m, planned in "
            f"{result.runtime_s:.2f} s ({self.elapsed_s:.2f} s in all, reading and writing "
            f"included){flight_text(self.flight)}"
        )


def fixed(value: float, digits: int) -> str:
    """``value`` with ``digits`` decimals, never ``-0.00`` (a tiny negative rounds to 0)."""
    text = f"{value:.{digits}f}"
    return text[1:] if text.startswith("-") and float(text) == 0.0 else text


def plan(request: PlanRequest, feedback: Feedback) -> PlanOutcome | RerouteOutcome | SurveyOutcome:
    """Plan ``request.source`` as what it is (:func:`recognise`; a scenario with a
    ``survey:`` section is a survey, :mod:`uavplan.app.survey`)."""
    kind = recognise(request.source)
    if kind is InputKind.QGC_PLAN:
        if request.view is not None:
            raise InputError(
                "--view goes with a scenario; view a rerouted plan with uavplan view OUT.plan "
                "--scenario S -o page.html"
            )
        if request.reserve_pct is not None:
            raise InputError("--reserve goes with a scenario (a rerouted plan is not estimated)")
        return reroute_file(
            RerouteRequest(
                request.source,
                request.output,
                scenario=request.scenario,
                options=request.options,
                report=request.report,
                autopilot=request.autopilot,
                plot=request.plot,
                fence=request.fence,
            ),
            feedback,
        )
    if request.scenario is not None:
        raise InputError("--scenario goes with a .plan input (the SCENARIO argument is one)")
    if is_survey_file(request.source):
        from uavplan.app.survey import plan_survey_file

        return plan_survey_file(request, feedback)
    return plan_scenario(request, feedback)


def plan_scenario(request: PlanRequest, feedback: Feedback) -> PlanOutcome:
    """Plan the scenario file ``request.source`` and write the mission (and the report, the
    picture) as one set of outputs: all of them, or (no route, an unsafe flight, an error,
    Ctrl-C) none. Notes go to ``feedback.say``, findings to ``feedback.warn``; no route, or a
    whole flight (uavplan.verdict) that breaks the margin, raises NoPathError."""
    t0 = time.perf_counter()
    outputs, mission_out, report_out, plot_out = _outputs(request, feedback)
    view_out = _view_output(request, outputs)
    import_in_background()  # the mission writer's pyproj loads on another core during the search
    scn = request.options.apply(load_scenario_file(request.source, "plan"))
    outputs.reads(*scn.files)  # its map, obstacle files, DEM: no output may overwrite one
    if request.autopilot:
        autopilot = Autopilot.from_name(request.autopilot)
        scn = replace(scn, mission=replace(scn.mission, autopilot=autopilot))
    if request.legal_ceiling is not None:
        legal = legal_ceiling_option(request.legal_ceiling)
        scn = replace(scn, mission=replace(scn.mission, legal_ceiling_m=legal))
    if scn.mission.altitude == "terrain" and scn.mission.autopilot is Autopilot.PX4:
        feedback.warn(
            "warning: mission.altitude terrain writes MAV_FRAME_GLOBAL_TERRAIN_ALT items, "
            "which PX4 missions do not fly (ArduPilot does); use relative or amsl for PX4"
        )
    feedback.say(_announce(scn))
    if scn.airspace is not None:  # the zones considered and why each is a constraint or not
        for line in scn.airspace.summary_lines():
            feedback.say(line)
    # the site, once: the world the search, the rehearsals, the way home and the verdict
    # measure in, with its frame
    site = CheckSite.of_scenario(scn)
    with outputs:
        with feedback.polled():
            found, pad = _search(scn, feedback, site.world)
            planned = Flown(found)
            if found.collision_free:  # and the track the flight model predicts keeps it too
                planned = plan_safe_as_flown(
                    scn, found, site=site, pad_m=pad, should_stop=feedback.should_stop
                )
            result, flight = planned.result, planned.flight
            way = (
                None
                if result.route is None
                else _way_home(scn, site, result.route, request, feedback, flown=_flown(flight))
            )
        if result.interrupted or (way is not None and way.interrupted):
            return PlanOutcome(scn, result, request.output, way=way)
        route = require_route(scn, result, flight)
        if way is not None and way.route is not route:
            # the route as flown with its planned return: the flight model flies that mission
            way, planned = _return_safe_as_flown(scn, site, planned, way, request, feedback)
            result, flight = planned.result, planned.flight
            if result.interrupted or way.interrupted:
                return PlanOutcome(scn, result, request.output, way=way)
            route = require_route(scn, result, flight)
            if not way.switched and flight is not None and flight.flown is not None:
                # end: return: the failsafe from every point of that mission, its planned
                # return included (a switched return replaces an RTL the outbound flight
                # already proved unusable: more points cannot make it usable)
                way = way.proven_on(scn, flight.flown, site)
        # the mission its prediction flew is the route's: built once
        mission = None if flight is None else flight.mission
        if mission is None:
            mission = mission_for(scn, route)
        if way is not None:
            mission = replace(mission, parameters=way.parameters)
        verdict = _judge(scn, site, mission, _flown(flight))
        if verdict is not None:
            problem = verdict.problem()
            if problem is not None:
                raise NoPathError(problem)
            flight = _predicted(verdict, flight, mission)
        mission, built = _fenced(scn, route, mission, request, verdict)
        from uavplan.mavlink.storage import check_storage  # the vehicle's storage

        check_storage(mission, scn.mission.max_items, file=request.output)
        flown = _flown(flight)
        estimate = flight_estimate(
            scn,
            route,
            request.reserve_pct,
            feedback,
            flown,
            allow_over_battery=request.allow_over_battery,
        )
        summary = {"algorithm": result.algorithm, "seed": result.seed, "energy": result.energy}
        mission_out.write_text(
            mission_text(mission, request.output, extras=lambda: export_extras(scn, route, summary))
        )
        if report_out is not None:
            report = {**route_report(result, scn, flight), **estimate.report_fields()}
            if way is not None:
                report.update(way.report())
            if verdict is not None:
                report["whole_flight"] = verdict.report()
            report_out.write_text(json.dumps(report, indent=2) + "\n")
        if plot_out is not None:
            # matplotlib (and the fence's outlines) load only for a picture
            from uavplan.render import RouteLayers, render_png, route_subtitle, scene_for

            subtitle = route_subtitle(
                route, algorithm=result.algorithm, seed=result.seed, energy=result.energy
            )
            layers = RouteLayers.from_route(route, built)
            plot_out.write_bytes(render_png(scene_for(scn), layers, subtitle=subtitle))
        if view_out is not None:
            from uavplan.app.view import mission_page

            view_out.write_text(mission_page(scn, mission, source=request.output))
        outputs.commit()
    for note in result.notes:
        feedback.say(f"note: {note}")
    if built is not None:
        for line in (built.summary(), *(f"note: {n}" for n in built.notes())):
            feedback.say(line)
        if scn.airspace is not None:
            from uavplan.mission.zonefence import zone_fence_lines

            groups = scn.airspace.fence_groups()
            for line in zone_fence_lines(built, groups, scn.site.obstacles):
                feedback.say(line)
    if way is not None:
        for line in way.lines():
            feedback.say(line)
        if way.parameters and not _holds_parameters(request.output):
            feedback.warn(
                f"warning: a {Path(request.output).suffix} file holds no parameters: the "
                "mission relies on "
                + ", ".join(p.describe() for p in way.parameters)
                + "; set them on the vehicle by hand"
            )
    if verdict is not None:
        feedback.say(verdict.summary())
        for line in verdict.warnings():
            feedback.warn(line)
    return PlanOutcome(
        scn,
        result,
        request.output,
        mission,
        time.perf_counter() - t0,
        estimate=estimate,
        way=way,
        verdict=verdict,
        flight=flight,
    )


def _flown(flight: FlightPrediction | None) -> FlownTrack | None:
    """The track of a predicted flight (None: not rehearsed)."""
    return None if flight is None else flight.flown


def legal_ceiling_option(text: str) -> float | None:
    """``--legal-ceiling M`` (metres above the ground, > 0) or ``none`` (no legal limit)."""
    if text.strip().lower() == "none":
        return None
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise InputError(
            f"must be a height in metres above the ground (> 0) or 'none', got {text!r}",
            key="--legal-ceiling",
        )
    return value


def _judge(
    scn: Scenario, site: CheckSite, mission: MissionPlan, flown: FlownTrack | None
) -> FlightVerdict | None:
    """The whole flight of ``mission`` (uavplan.verdict) with the parameters it relies on,
    as the scenario's vehicle flies it through its wind (``flown``: the same mission's
    flight, reused when it was flown with those parameters); None for an autopilot the
    flight model does not fly."""
    if mission.autopilot not in (Autopilot.PX4, Autopilot.ARDUPILOT) or mission.home is None:
        return None
    from uavplan.rehearsal import conditions_of
    from uavplan.verdict import judge_flight

    return judge_flight(mission, site, flown=flown, **conditions_of(scn))


def _predicted(
    verdict: FlightVerdict, before: FlightPrediction | None, mission: MissionPlan
) -> FlightPrediction:
    """The predicted flight the report and the summary give: the whole flight judged (of
    ``mission``, with the parameters it relies on), keeping how much wider than the margin
    the route was planned (``before``: the prediction that widened it)."""
    from uavplan.flightcheck import FlightPrediction

    rehearsal = verdict.rehearsal
    assert rehearsal is not None
    return FlightPrediction(
        autopilot=verdict.autopilot.label,
        flight_time_s=rehearsal.flight_time_s,
        max_deviation_m=rehearsal.max_deviation_m,
        check=verdict.check,
        margin_pad_m=0.0 if before is None else before.margin_pad_m,
        gave_up="" if before is None else before.gave_up,
        flown=rehearsal.flown,
        mission=mission,
    )


def _fenced(
    scn: Scenario,
    route: PlannedRoute,
    mission: MissionPlan,
    request: PlanRequest,
    verdict: FlightVerdict | None,
) -> tuple[MissionPlan, FenceBuild | None]:
    """The mission with its geofence (``--fence``): the zones keep the margin from the
    straight legs, from the track the flight model flew and, where the mission relies on the
    autopilot's return, from the failsafe returns from every point (issue 37)."""
    if not request.fence:
        return mission, None
    import numpy as np

    also = None
    if verdict is not None:
        points = verdict.check.check.flight.points_enu
        a, b = [points[:-1]], [points[1:]]
        failsafe = verdict.failsafe
        if failsafe is not None and failsafe.ok:
            ra, rb = failsafe.paths()
            a.append(ra)
            b.append(rb)
        also = (np.vstack(a), np.vstack(b))
    return fence_for(scn, route, mission, also=also)


def flight_estimate(
    scn: Scenario,
    route: PlannedRoute,
    reserve_pct: float | None,
    feedback: Feedback,
    flown: FlownTrack | None = None,
    *,
    allow_over_battery: bool = False,
) -> BatteryEstimate:
    """The planned route's flight time, energy and battery (issue 27): of ``flown``, the
    mission as the flight model flew it with the parameters it relies on (the vehicle's
    power model at every step, the return included), else of the route's flown line. A
    flight that does not leave the reserve raises EnergyBudgetError (exit 2, nothing
    written) unless ``allow_over_battery``, which makes it a warning."""
    reserve = DEFAULT_RESERVE_PCT if reserve_pct is None else reserve_pct
    if flown is not None:  # the mission as the flight model flies it: one time for both lines
        estimate = estimate_flown(scn, flown, reserve_pct=reserve)
    else:
        estimate = estimate_route(scn, route.flown_enu, reserve_pct=reserve)
    warning = estimate.check(allow_over_battery=allow_over_battery)
    if warning is not None:
        feedback.warn(warning)
    return estimate


def _holds_parameters(output: str) -> bool:
    """Does the mission file keep the parameters the mission relies on? (A .plan does.)"""
    return Path(output).suffix.lower() == ".plan"


def _way_home(
    scn: Scenario,
    site: CheckSite,
    route: PlannedRoute,
    request: PlanRequest,
    feedback: Feedback,
    allowance_m: float = 0.0,
    flown: FlownTrack | None = None,
) -> WayHome:
    """The way home of ``route`` (:func:`uavplan.wayhome.home.way_home`): a return planned with
    the feedback's progress bar and Ctrl-C flag when the mission needs one."""
    from uavplan.wayhome.home import way_home

    bar = feedback.progress
    started = False

    def progress(iteration: int, total: int, best: float) -> None:
        nonlocal started
        assert bar is not None
        if not started:  # only when a return is planned
            bar.start(f"{scn.planner.algorithm} {scn.name}: the way home")
            started = True
        bar(iteration, total, best)

    try:
        return way_home(
            scn,
            route,
            fence=request.fence,
            progress=None if bar is None else progress,
            should_stop=feedback.should_stop,
            allowance_m=allowance_m,
            flown=flown,
            site=site,
        )
    finally:
        if bar is not None and started:
            bar.close()


def _return_safe_as_flown(
    scn: Scenario,
    site: CheckSite,
    planned: Flown[RouteResult],
    way: WayHome,
    request: PlanRequest,
    feedback: Feedback,
) -> tuple[WayHome, Flown[RouteResult]]:
    """The planned return (``way``) flown with the route by the flight model; where the
    autopilot's flight of it comes closer than the margin (it cuts the return's corners as
    it cuts the route's), the return is planned again keeping what it lacked more: the widen
    loop of :func:`~uavplan.flown_safe.widened_until_flown_safe`. The flight returned is
    that mission's; a return that could not be made safe says why in its ``gave_up``."""
    result = planned.result
    route = result.route
    assert route is not None

    def flown(home: WayHome) -> tuple[WayHome, Flown[RouteResult]]:
        with_return = Flown(replace(result, route=home.route), planned.flight)
        return home, refresh_flight(scn, with_return, site)

    def again(allowance: float) -> tuple[WayHome, Flown[RouteResult]]:
        home = _way_home(scn, site, route, request, feedback, allowance)
        if home.interrupted or home.route is route:  # stopped, or no planned return now
            return home, planned
        return flown(home)

    def check_of(value: tuple[WayHome, Flown[RouteResult]]) -> TrackCheck | None:
        flight = value[1].flight
        return None if flight is None else flight.check

    ended = widened_until_flown_safe(
        flown(way),
        check_of,
        again,
        stopped=lambda value: value[0].interrupted or value[0].route is route,
        noted=lambda why, pad: (
            f"the planned return as flown: {why}; planned again keeping {pad:.2f} m more"
        ),
        exhausted=lambda pad: (
            f"the return planned {MAX_REPLANS} more times, keeping up to {pad:.2f} m more"
        ),
    )
    way, refreshed = ended.value
    if ended.stopped:
        return way, refreshed
    flight = refreshed.flight
    if ended.gave_up and flight is not None:
        gave_up = "; ".join(part for part in (flight.gave_up, ended.gave_up) if part)
        flight = replace(flight, gave_up=gave_up)
    noted = replace(refreshed.result, notes=(*refreshed.result.notes, *ended.notes))
    return way, Flown(noted, flight)


def _search(scn: Scenario, feedback: Feedback, world: World) -> tuple[RouteResult, float]:
    """Plan ``scn`` in its ``world`` with the feedback's progress bar and Ctrl-C flag: first
    with the margin wider by the corner its autopilot cuts (:func:`corner_pad_m`), then, where
    no route keeps that, at the bare margin. Returns the result and how much wider than the
    margin it was planned."""
    bar = feedback.progress
    if bar is not None:
        bar.start(f"{scn.planner.algorithm} {scn.name}")
    try:
        pad = corner_pad_m(scn.mission.autopilot)
        if pad > 0.0:
            padded = plan_padded(scn, pad, world, progress=bar, should_stop=feedback.should_stop)
            if not isinstance(padded, str):
                return padded, pad
        found = plan_route(scn, progress=bar, world=world, should_stop=feedback.should_stop)
        if pad > 0.0 and found.route is not None:
            why = f"{padded}: planned at the margin itself, then as the autopilot flies it"
            found = replace(found, notes=(*found.notes, why))
        return found, 0.0
    finally:
        if bar is not None:
            bar.close()


def _announce(scn: Scenario) -> str:
    search = scn.planner.search
    budget = plural(search.iterations, "iteration")
    if search.stall_iterations is not None:
        again = search.restart_stall_iterations
        budget = (
            f"at most {plural(search.iterations, 'iteration')}, stopping after "
            f"{search.stall_iterations} without improvement"
            + ("" if again is None else f" ({again} in a restart)")
        )
    return (
        f"planning {scn.name} with {scn.planner.algorithm} (population {search.population}, "
        f"{budget}, seed {search.seed}); Ctrl-C stops"
    )


def _outputs(
    request: PlanRequest, feedback: Feedback
) -> tuple[OutputSet, Output, Output | None, Output | None]:
    """The outputs (mission, report, picture), every one checked before any planning."""
    out_format = format_for(request.output)  # fail on an unknown extension before planning
    if request.plot and Path(request.plot).suffix.lower() != ".png":
        raise InputError("--plot writes a PNG picture; name the file *.png", file=request.plot)
    check_report_name(request.report)
    if (
        request.fence
        and out_format.dumps_extras is None
        and Path(request.output).suffix.lower() != ".plan"
    ):
        raise InputError(
            "a geofence needs a .plan (or .geojson / .kml) output", file=request.output
        )
    outputs = OutputSet(feedback.interrupts)
    outputs.reads(request.source, role="the scenario")
    mission = outputs.file(request.output)
    report = outputs.file(request.report) if request.report else None
    plot = outputs.file(request.plot) if request.plot else None
    outputs.check()
    return outputs, mission, report, plot


def _view_output(request: PlanRequest, outputs: OutputSet) -> Output | None:
    """``--view``: the page, declared and checked with the other outputs, and its drawing
    library found, before any planning."""
    if request.view is None:
        return None
    from uavplan.app.view import check_page_path
    from uavplan.view.page import plotly_script

    check_page_path(request.view)
    plotly_script()
    page = outputs.file(request.view)
    outputs.check()
    return page
