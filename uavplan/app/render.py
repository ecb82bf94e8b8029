"""``render``: a picture of a scenario alone, of a route planned as ``plan`` plans it (same
options, same seed, same route), or of a mission file's flight (checked against the scenario
by the one mission check, :func:`uavplan.app.check.check_flight_in`, and judged as a whole
flight, :func:`uavplan.app.check.judged`: the same verdict ``plan``, ``validate`` and
``simulate`` print; a flight that breaks the margin is drawn, then exit 3)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from uavplan.app.check import check_flight_in, judged, no_fence, read_mission_flight
from uavplan.app.feedback import Feedback, PlannerOptions, plural, require_route
from uavplan.app.inputs import load_scenario_file, mission_kind
from uavplan.app.outputs import OutputSet
from uavplan.app.reroute import fence_scene
from uavplan.errors import InputError, NoPathError, ScenarioError
from uavplan.geo import EnuFrame
from uavplan.planning import enu_frame, plan_route
from uavplan.render import RouteLayers, Scene, render_png, route_subtitle, scene_around, scene_for
from uavplan.route import keeps_margin
from uavplan.scenario import Scenario, load_surroundings
from uavplan.scenario.values import is_survey_file
from uavplan.worlds import fence_world

if TYPE_CHECKING:
    from uavplan.verdict import FlightVerdict


@dataclass(frozen=True)
class RenderRequest:
    """``uavplan render SCENARIO -o OUTPUT``: with ``mission`` that file's flight, with
    ``no_plan`` the scenario alone, else a planned route (``options``)."""

    scenario: str
    output: str
    mission: str | None = None
    no_plan: bool = False
    options: PlannerOptions = field(default_factory=PlannerOptions)
    width_px: int = 1600
    height_px: int = 800
    dpi: int = 100
    #: a flown track (.csv / .geojson, ``simulate`` or ``fly --track``) drawn over it
    track: str | None = None


@dataclass(frozen=True)
class RenderOutcome:
    """The picture written (``summary`` says what it shows), or an interrupted planning."""

    output: str
    width_px: int
    height_px: int
    summary: str
    interrupted: bool = False
    #: the mission's clearance (a mission picture over obstacles or terrain), or None
    min_clearance_m: float | None = None

    def line(self) -> str:
        return f"{Path(self.output).name}: {self.width_px}x{self.height_px} px, {self.summary}"


def render(request: RenderRequest, feedback: Feedback) -> RenderOutcome:
    """Draw what ``request`` asks for into its PNG output (written as the command's one
    output: complete, or not at all)."""
    if Path(request.output).suffix.lower() != ".png":
        raise InputError("render writes a PNG picture; name the file *.png", file=request.output)
    outputs = OutputSet(feedback.interrupts)
    outputs.reads(request.scenario, role="the scenario (or mission) to draw")
    outputs.reads(request.mission, role="the mission of --mission")
    outputs.reads(request.track, role="the track of --track")
    picture = outputs.file(request.output)
    outputs.check()
    with outputs:
        if mission_kind(request.scenario) == "plan" and request.mission is None:
            outcome = _render_plan(request, feedback)
        elif request.no_plan and request.mission is None:
            outcome = _render_scenario(request, feedback, outputs)
        else:
            scn = load_scenario_file(request.scenario, "render", site=request.mission is not None)
            outputs.reads(*scn.files)
            if request.mission is not None:
                outcome = _render_mission(scn, request, feedback)
            else:
                outcome = _render_planned(request.options.apply(scn), request, feedback)
        if outcome.outcome.interrupted:
            return outcome.outcome
        picture.write_bytes(outcome.png)
        outputs.commit()
    if outcome.failure is not None:
        raise outcome.failure
    return outcome.outcome


@dataclass(frozen=True, eq=False)
class _Drawn:
    """A picture made (``png``), what it shows and, for a route that failed, the error to
    raise once the picture is written."""

    outcome: RenderOutcome
    png: bytes = b""
    failure: NoPathError | None = None


def _draw(
    scene: Scene,
    request: RenderRequest,
    layers: RouteLayers | None,
    subtitle: str,
    *,
    failure: NoPathError | None = None,
    min_clearance_m: float | None = None,
    summary: str | None = None,
    scenario: Scenario | None = None,
) -> _Drawn:
    """The picture of ``scene`` with ``layers``; with ``request.track`` the flown track over
    it, measured in ``scenario``'s site (the subtitle gives its clearance)."""
    if request.track is not None:
        if scenario is None:
            raise InputError(
                "--track draws a flown track over a scenario: give a scenario file (a "
                "QGroundControl plan's own geofence is not one)",
                file=request.track,
            )
        layers, subtitle = _with_track(scenario, request, layers, subtitle)
    png = render_png(
        scene,
        layers,
        subtitle=subtitle,
        width_px=request.width_px,
        height_px=request.height_px,
        dpi=request.dpi,
    )
    outcome = RenderOutcome(
        request.output,
        request.width_px,
        request.height_px,
        subtitle if summary is None else summary,
        min_clearance_m=min_clearance_m,
    )
    return _Drawn(outcome, png, failure)


def _with_track(
    scn: Scenario, request: RenderRequest, layers: RouteLayers | None, subtitle: str
) -> tuple[RouteLayers, str]:
    """``layers`` with the flown track of ``request.track`` (placed in the scenario's site)
    and, in the subtitle, its clearance by the one check: the whole track, take-off to
    touchdown, its return to launch included (issue 37)."""
    from uavplan.mission.track import Track
    from uavplan.rehearsal import CheckSite

    assert request.track is not None
    track = Track.load(request.track)
    layers = layers or RouteLayers()
    if len(track) < 2:
        return layers, subtitle
    site = CheckSite.of_scenario(scn)
    whole = site.check(track, lands=bool(track.relative_alt_m[-1] < 0.5))
    text = f"flown track {Path(request.track).name}: min clearance {whole.min_clearance_m:.2f} m"
    if not whole.ok:
        text += "  (closer than the margin!)"
    layers = replace(layers, track_enu=whole.check.flight.points_enu)
    return layers, f"{subtitle}; {text}" if subtitle else text


def _render_scenario(request: RenderRequest, feedback: Feedback, outputs: OutputSet) -> _Drawn:
    """``--no-plan``: the scenario alone, also when its route points are not valid (the
    picture is how a user finds valid ones): then the subtitle and a warning say why."""
    try:
        scn = load_scenario_file(request.scenario, "render")
    except ScenarioError as err:
        if not _about_the_route(err):
            raise
        around = load_surroundings(request.scenario)
        outputs.reads(*around.files)
        if around.start_m is None or around.goal_m is None:
            raise
        feedback.warn(f"warning: {err}; drawn as it is")
        subtitle = (
            f"{plural(len(around.obstacles), 'obstacle')}, safety margin "
            f"{around.safety_margin_m:g} m, start {list(around.start_m)}, goal "
            f"{list(around.goal_m)}: NOT PLANNABLE: {err.key}: {err.reason}"
        )
        return _draw(scene_around(around), request, None, subtitle, summary="scenario only")
    outputs.reads(*scn.files)
    subtitle = (
        f"{plural(len(scn.obstacles), 'obstacle')}, safety margin {scn.safety_margin_m:g} m, "
        f"start {list(scn.start_m)}, goal {list(scn.goal_m)}"
    )
    return _draw(scene_for(scn), request, None, subtitle, summary="scenario only", scenario=scn)


#: the keys of a scenario's route: a problem there does not keep --no-plan from drawing it
_ROUTE_KEYS = ("start", "goal", "via", "vehicle.takeoff_altitude")


def _about_the_route(err: ScenarioError) -> bool:
    key = err.key or ""
    return any(key == k or key.startswith((f"{k}[", f"{k}.")) for k in _ROUTE_KEYS)


def _render_plan(request: RenderRequest, feedback: Feedback) -> _Drawn:
    """A QGroundControl plan without a scenario: drawn in the world its rerouting plans in
    (its geofence's zones as obstacles), with its clearance from them and its whole flight's
    verdict there."""
    from uavplan.mission.io import load_mission  # the mission readers: only with a mission
    from uavplan.rehearsal import CheckSite

    plan = load_mission(request.scenario)
    if not (plan.fence.polygons or plan.fence.circles):
        raise no_fence(request.scenario, "render")
    world, flight = fence_world(plan, file=request.scenario)
    layers = RouteLayers.from_mission(plan, world.frame, flight.points_enu)
    check = world.check(flight)
    site = CheckSite.of_plan(plan, file=request.scenario)
    verdict = None if site is None else judged(plan, site)
    failure = _judged(verdict, request.scenario, feedback)
    close = check.problem() is not None or (verdict is not None and not verdict.flight_ok)
    name = Path(request.scenario).name
    subtitle = (
        f"{name}: {len(plan.items)} items, {flight.length_m:.0f} m flown from take-off, "
        f"min clearance from its geofence {check.min_clearance_m:.2f} m (margin "
        f"{world.margin_m:g} m){_flown(verdict)}" + ("  (too close!)" if close else "")
    )
    # start and goal: the first and last position flown (every position is a waypoint of
    # the flown route already; which were the user's the plan does not say)
    first, last = (tuple(float(v) for v in flight.points_enu[k]) for k in (1, -1))
    ends = [(first[0], first[1], first[2]), (last[0], last[1], last[2])]
    scene = fence_scene(Path(request.scenario).stem, world.airspace, world.margin_m, ends)
    return _draw(
        scene, request, layers, subtitle, min_clearance_m=check.min_clearance_m, failure=failure
    )


def _flown(verdict: FlightVerdict | None) -> str:
    """``; as flown 10.52 m``: the whole flight's least clearance, for a subtitle."""
    if verdict is None:
        return ""
    return f"; as flown {verdict.flight_worst.clearance_m:.2f} m"


def _judged(verdict: FlightVerdict | None, file: str, feedback: Feedback) -> NoPathError | None:
    """Print the whole flight's verdict (its findings as warnings); the error to raise once
    the picture is written when the flight breaks the margin."""
    if verdict is None:
        return None
    feedback.say(verdict.summary())
    for line in verdict.warnings():
        feedback.warn(line)
    problem = verdict.problem()
    return None if problem is None else NoPathError(f"{file}: {problem}")


def _render_mission(scn: Scenario, request: RenderRequest, feedback: Feedback) -> _Drawn:
    from uavplan.rehearsal import CheckSite

    assert request.mission is not None
    plan, flight = read_mission_flight(request.mission, scn)
    try:
        layers = RouteLayers.from_mission(plan, enu_frame(scn), flight.points_enu)
    except ValueError as err:
        raise InputError(str(err), file=request.mission) from None
    name = Path(request.mission).name
    clearance = None
    failure = None
    if len(flight.points_enu) < 2:
        subtitle = f"{name}: {len(plan.items)} items, nothing to fly"
    else:
        subtitle = f"{name}: {len(plan.items)} items, {flight.length_m:.0f} m flown from take-off"
        check = check_flight_in(scn, flight)
        verdict = judged(plan, CheckSite.of_scenario(scn), scn)
        failure = _judged(verdict, request.mission, feedback)
        if is_survey_file(request.scenario):
            layers = survey_layers(layers, request.scenario, scn, verdict)
        if math.isfinite(check.min_clearance_m):
            clearance = check.min_clearance_m
            close = not keeps_margin(clearance, scn.safety_margin_m) or failure is not None
            subtitle += (
                f", min clearance {clearance:.2f} m{_flown(verdict)} (margin "
                f"{scn.safety_margin_m:g} m)" + ("  (closer than the margin!)" if close else "")
            )
    scene = scene_for(scn)
    if layers.survey_area_xy is not None:  # a survey starts and ends at its start
        scene = replace(scene, has_goal=False)
    return _draw(
        scene,
        request,
        layers,
        subtitle,
        min_clearance_m=clearance,
        scenario=scn,
        failure=failure,
    )


def survey_layers(
    layers: RouteLayers, source: str, scn: Scenario, verdict: FlightVerdict | None
) -> RouteLayers:
    """``layers`` with the survey layers of the survey scenario ``source``: its area, and
    the photos the flight model took flying the mission (``verdict``'s rehearsal) with their
    footprints (with a camera), in ``scn``'s frame."""
    import numpy as np

    from uavplan.autopilot.camera import photo_positions
    from uavplan.scenario.values import load_survey_scenario
    from uavplan.survey import coverage

    _, spec = load_survey_scenario(source)
    area = np.asarray(spec.area_m, dtype=np.float64)
    if verdict is None or verdict.rehearsal is None:
        return replace(layers, survey_area_xy=area)
    flown = verdict.rehearsal.flown
    photos = photo_positions(flown)
    if not len(photos):
        return replace(layers, survey_area_xy=area)
    lat, lon, _ = EnuFrame.at(flown.home).to_geodetic(
        np.column_stack([photos[:, :2], np.zeros(len(photos))])
    )
    xy = np.asarray(enu_frame(scn).to_enu_xy(lat, lon)).reshape(-1, 2)
    footprints = None
    side, front = spec.spacing.footprint_side_m, spec.spacing.footprint_front_m
    if side is not None and front is not None:
        heading = coverage.photo_headings(xy, spec.spacing.trigger_distance_m)
        footprints = coverage.footprints(xy, heading, side, front)
    return replace(layers, survey_area_xy=area, photos_xy=xy, photo_footprints_xy=footprints)


def _render_planned(scn: Scenario, request: RenderRequest, feedback: Feedback) -> _Drawn:
    bar = feedback.progress
    if bar is not None:
        bar.start(f"{scn.planner.algorithm} {scn.name}")
    try:
        with feedback.polled():
            result = plan_route(scn, progress=bar, should_stop=feedback.should_stop)
    finally:
        if bar is not None:
            bar.close()
    if result.interrupted:
        size = (request.width_px, request.height_px)
        return _Drawn(RenderOutcome(request.output, *size, "", interrupted=True))
    if not result.ok:
        no_route = NoPathError(
            f"{scn.name}: no collision-free path: {result.message} (drew the scenario alone "
            f"in {request.output})"
        )
        subtitle = f"no collision-free path: {result.message}"
        return _draw(scene_for(scn), request, None, subtitle, failure=no_route, scenario=scn)
    assert result.route is not None
    subtitle = route_subtitle(
        result.route, algorithm=result.algorithm, seed=result.seed, energy=result.energy
    )
    failure: NoPathError | None = None
    try:
        require_route(scn, result)  # closer than the margin: drawn (it shows where), exit 3
    except NoPathError as err:
        failure = err
    layers = RouteLayers.from_route(result.route)
    return _draw(scene_for(scn), request, layers, subtitle, failure=failure, scenario=scn)
