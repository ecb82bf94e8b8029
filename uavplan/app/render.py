"""``render``: a picture of a scenario alone, of a route planned as ``plan`` plans it (same
options, same seed, same route), or of a mission file's flight (checked against the scenario
by the one mission check, :func:`uavplan.app.check.check_flight_in`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

from uavplan.app.check import check_flight_in, read_mission_flight
from uavplan.app.feedback import Feedback, PlannerOptions, require_route
from uavplan.errors import InputError, NoPathError
from uavplan.fileio import check_writable
from uavplan.planning import enu_frame, plan_route, scene_for
from uavplan.render import RouteLayers, render_scene, route_subtitle
from uavplan.route import keeps_margin
from uavplan.scenario import Scenario, load_scenario


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
    """Draw what ``request`` asks for into its PNG output."""
    if Path(request.output).suffix.lower() != ".png":
        raise InputError("render writes a PNG picture; name the file *.png", file=request.output)
    check_writable(request.output)
    scn = load_scenario(request.scenario)
    if request.mission is not None:
        return _render_mission(scn, request)
    if request.no_plan:
        subtitle = (
            f"{len(scn.obstacles)} obstacles, safety margin {scn.safety_margin_m:g} m, "
            f"start {list(scn.start_m)}, goal {list(scn.goal_m)}"
        )
        _draw(scn, request, None, subtitle)
        return _outcome(request, "scenario only")
    return _render_planned(request.options.apply(scn), request, feedback)


def _draw(scn: Scenario, request: RenderRequest, layers: RouteLayers | None, subtitle: str) -> str:
    """Draw the picture; the subtitle it carries (with a flown track's clearance)."""
    if request.track is not None:
        layers, subtitle = _with_track(scn, request, layers, subtitle)
    render_scene(
        scene_for(scn),
        request.output,
        layers,
        subtitle=subtitle,
        width_px=request.width_px,
        height_px=request.height_px,
        dpi=request.dpi,
    )
    return subtitle


def _with_track(
    scn: Scenario, request: RenderRequest, layers: RouteLayers | None, subtitle: str
) -> tuple[RouteLayers, str]:
    """``layers`` with the flown track of ``request.track`` (placed in the scenario's site)
    and, in the subtitle, its clearance by the one check: with ``request.mission`` the
    mission's part apart from the autopilot's return to launch."""
    import numpy as np

    from uavplan.mission.io import load_mission
    from uavplan.mission.track import Track
    from uavplan.rehearsal import CheckSite, return_seq

    assert request.track is not None
    track = Track.load(request.track)
    layers = layers or RouteLayers()
    if len(track) < 2:
        return layers, subtitle
    site = CheckSite.of_scenario(scn)
    cut = len(track)
    if request.mission is not None:
        plan = load_mission(request.mission)
        rtl = return_seq(plan, plan.autopilot)
        if rtl is not None:
            hits = np.flatnonzero(track.current_seq >= rtl)
            cut = int(hits[0]) + 1 if hits.size else cut
    whole = site.check(track, lands=bool(track.relative_alt_m[-1] < 0.5))
    text = f"flown track {Path(request.track).name}: min clearance "
    if cut < len(track):
        part = site.check(track.until(cut), lands=False)
        text += f"{part.min_clearance_m:.2f} m to the return, {whole.min_clearance_m:.2f} m with it"
    else:
        text += f"{whole.min_clearance_m:.2f} m"
    layers = replace(layers, track_enu=whole.check.flight.points_enu)
    return layers, f"{subtitle}; {text}" if subtitle else text


def _outcome(
    request: RenderRequest,
    summary: str,
    *,
    interrupted: bool = False,
    min_clearance_m: float | None = None,
) -> RenderOutcome:
    return RenderOutcome(
        request.output,
        request.width_px,
        request.height_px,
        summary,
        interrupted=interrupted,
        min_clearance_m=min_clearance_m,
    )


def _render_mission(scn: Scenario, request: RenderRequest) -> RenderOutcome:
    assert request.mission is not None
    plan, flight = read_mission_flight(request.mission, scn)
    try:
        layers = RouteLayers.from_mission(plan, enu_frame(scn), flight.points_enu)
    except ValueError as err:
        raise InputError(str(err), file=request.mission) from None
    name = Path(request.mission).name
    clearance = None
    if len(flight.points_enu) < 2:
        subtitle = f"{name}: {len(plan.items)} items, nothing to fly"
    else:
        subtitle = f"{name}: {len(plan.items)} items, {flight.length_m:.0f} m flown"
        check = check_flight_in(scn, flight)
        if math.isfinite(check.min_clearance_m):
            clearance = check.min_clearance_m
            close = not keeps_margin(clearance, scn.safety_margin_m)
            subtitle += f", min clearance {clearance:.2f} m (margin {scn.safety_margin_m:g} m)" + (
                "  (closer than the margin!)" if close else ""
            )
    subtitle = _draw(scn, request, layers, subtitle)
    return _outcome(request, subtitle, min_clearance_m=clearance)


def _render_planned(scn: Scenario, request: RenderRequest, feedback: Feedback) -> RenderOutcome:
    bar = feedback.progress
    if bar is not None:
        bar.start(f"{scn.planner.algorithm} {scn.name}")
    try:
        result = plan_route(scn, progress=bar, should_stop=feedback.should_stop)
    finally:
        if bar is not None:
            bar.close()
    if not result.ok and not result.interrupted:
        _draw(scn, request, None, f"no collision-free path: {result.message}")
        raise NoPathError(
            f"{scn.name}: no collision-free path: {result.message} (drew the scenario alone "
            f"in {request.output})"
        )
    subtitle = ""
    if result.route is not None:  # drawn even when it comes too close: the picture shows where
        subtitle = route_subtitle(
            result.route, algorithm=result.algorithm, seed=result.seed, energy=result.energy
        )
        _draw(scn, request, RouteLayers.from_route(result.route), subtitle)
    if result.interrupted:
        return _outcome(request, subtitle, interrupted=True)
    require_route(scn, result)  # closer than the margin: exit 3
    return _outcome(request, subtitle)
