"""``plan user.plan -o safe.plan [--scenario S]``: reroute a QGroundControl plan around its
exclusion zones (the rerouting itself is :mod:`uavplan.reroute`)."""

from __future__ import annotations

import json
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from uavplan.airspace import OUTSIDE_INCLUSION, Airspace
from uavplan.app.feedback import Feedback, PlannerOptions, flight_text, plural
from uavplan.app.outputs import OutputSet, check_report_name
from uavplan.app.reports import reroute_report
from uavplan.config import PlannerConfig
from uavplan.errors import InputError, NoPathError
from uavplan.flown_safe import Flown, reroute_safe_as_flown
from uavplan.mission.io import load_mission, mission_text
from uavplan.reroute import RerouteResult, reroute_plan
from uavplan.scenario import Surroundings, load_surroundings

if TYPE_CHECKING:
    from uavplan.flightcheck import FlightPrediction
    from uavplan.mission.items import MissionPlan
    from uavplan.render import Scene
    from uavplan.verdict import FlightVerdict


@dataclass(frozen=True)
class RerouteRequest:
    """A QGroundControl plan ``source`` to reroute into ``output`` (a .plan), with the
    obstacles and settings of ``scenario`` if given (a scenario or a map: its start and goal,
    if any, are not used; the plan has the route); ``plot`` draws the rerouted plan.
    ``autopilot`` and ``fence`` are refused: the plan keeps its own."""

    source: str
    output: str
    scenario: str | None = None
    options: PlannerOptions = field(default_factory=PlannerOptions)
    report: str | None = None
    autopilot: str | None = None
    plot: str | None = None
    fence: bool = False


@dataclass(frozen=True, eq=False)
class RerouteOutcome:
    """The rerouted plan, written to ``output`` unless the planning was interrupted.
    ``elapsed_s``: the whole use case, reading, checking and writing included."""

    result: RerouteResult
    output: str
    elapsed_s: float = math.nan
    #: what the flight model predicts for the rerouted plan, if rehearsed
    flight: FlightPrediction | None = None

    @property
    def interrupted(self) -> bool:
        return self.result.interrupted

    def summary(self) -> str:
        r = self.result
        return (
            f"{Path(self.output).name}: {len(r.plan.items)} items "
            f"({plural(r.inserted, 'planned waypoint')} added to the plan's "
            f"{len(r.plan.items) - r.inserted}), {r.length_m:.0f} m flown from take-off, "
            f"min clearance {r.min_clearance_m:.2f} m "
            f"(margin {r.safety_margin_m:g} m), rerouted in {self.elapsed_s:.2f} s "
            f"(the search {r.runtime_s:.2f} s of it){flight_text(self.flight)}"
        )


def reroute_file(request: RerouteRequest, feedback: Feedback) -> RerouteOutcome:
    """Read the plan, reroute it and write the output (and the report, the picture) as one
    set of outputs; the notes go to ``feedback.say`` once they are written."""
    t0 = time.perf_counter()
    if Path(request.output).suffix.lower() != ".plan":
        raise InputError(
            "a rerouted QGroundControl plan is written as a .plan (it keeps the fence and "
            "the rally points); name the output *.plan",
            file=request.output,
        )
    for flag, value in (("--autopilot", request.autopilot), ("--fence", request.fence)):
        if value:
            raise InputError(
                f"{flag} does not apply to a .plan input: the plan keeps its own autopilot "
                "flavour and geofence"
            )
    if request.plot and Path(request.plot).suffix.lower() != ".png":
        raise InputError("--plot writes a PNG picture; name the file *.png", file=request.plot)
    check_report_name(request.report)
    outputs = OutputSet(feedback.interrupts)
    outputs.reads(request.source, role="the mission to reroute")
    outputs.reads(request.scenario, role="the scenario of --scenario")
    plan_out = outputs.file(request.output)
    report_out = outputs.file(request.report) if request.report else None
    plot_out = outputs.file(request.plot) if request.plot else None
    outputs.check()
    plan = load_mission(request.source)
    base = None if request.scenario is None else load_surroundings(request.scenario)
    if base is not None:
        outputs.reads(*base.files)
    if base is not None:
        base = replace(base, planner=request.options.apply_to(base.planner))
    planner = base.planner if base is not None else request.options.apply_to(PlannerConfig())
    if base is not None and base.airspace is not None:  # each zone the plan as written infringes
        for line in written_infringements(plan, base):
            feedback.say(line)
    name = Path(request.source).stem
    bar = feedback.progress
    if bar is not None:
        bar.start(f"{planner.algorithm} {name}")
    with outputs:
        try:
            with feedback.polled():
                result = reroute_plan(
                    plan,
                    base=base,
                    planner=planner,
                    name=name,
                    file=request.source,
                    progress=bar,
                    should_stop=feedback.should_stop,
                )
                flown = Flown(result)
                if not result.interrupted:  # the track the flight model predicts keeps it too
                    flown = reroute_safe_as_flown(
                        plan,
                        result,
                        base=base,
                        planner=planner,
                        name=name,
                        file=request.source,
                        should_stop=feedback.should_stop,
                    )
        finally:
            if bar is not None:
                bar.close()
        result, flight = flown.result, flown.flight
        if result.interrupted:
            return RerouteOutcome(result, request.output)
        problem = None if flight is None else flight.problem()
        if problem is not None:
            raise NoPathError(f"{request.source}: {problem}")
        verdict = _judged(result, base, request.source)
        if verdict is not None and verdict.problem() is not None:
            raise NoPathError(f"{request.source}: {verdict.problem()}")
        plan_out.write_text(mission_text(result.plan, request.output))
        if report_out is not None:
            report_out.write_text(json.dumps(reroute_report(result, flight), indent=2) + "\n")
        if plot_out is not None:
            plot_out.write_bytes(_picture(result, name))
        outputs.commit()
    for note in result.notes:
        feedback.say(f"note: {note}")
    if verdict is not None:
        feedback.say(verdict.summary())
        for line in verdict.warnings():
            feedback.warn(line)
    return RerouteOutcome(result, request.output, time.perf_counter() - t0, flight)


def written_infringements(plan: MissionPlan, base: Surroundings) -> list[str]:
    """``airspace: the plan as written enters zone '…' (…) of FILE`` for each airspace zone of
    ``base`` its flight (as the autopilot flies it, in the scenario's site) enters or comes
    within the margin of: what the rerouting goes around."""
    from uavplan.flightcheck import flight_of_mission
    from uavplan.scenario.zones import infringements, zone_title
    from uavplan.worlds import enu_frame

    zset = base.airspace
    assert zset is not None
    site = base.site
    ground = site.ground
    try:
        flight = flight_of_mission(
            plan,
            enu_frame(site),
            None if ground is None else ground.z_at,
            None if ground is None else ground.follow,
        )
    except ValueError:  # an item that cannot be placed: the rerouting says so itself
        return []
    hits = infringements(zset, site.obstacles, flight.points_enu, base.safety_margin_m)
    return [f"airspace: the plan as written {_how_close(dist)} {zone_title(d)}" for d, dist in hits]


def _how_close(distance_m: float) -> str:
    return "enters" if distance_m <= 0 else f"comes {distance_m:.1f} m from"


def _judged(result: RerouteResult, base: Surroundings | None, file: str) -> FlightVerdict | None:
    """The rerouted plan's whole flight in its own airspace (uavplan.verdict: take-off to
    touchdown with the parameters it relies on, and a failsafe return from every point)."""
    from uavplan.app.check import judged
    from uavplan.rehearsal import CheckSite

    site = CheckSite.of_plan(result.plan, base=base, file=file)
    return None if site is None else judged(result.plan, site)


def fence_scene(
    name: str,
    airspace: Airspace,
    margin_m: float,
    positions_enu: Sequence[tuple[float, float, float]],
) -> Scene:
    """A picture's scene of a plan in its rerouting world: the exclusion zones (and the
    scenario's obstacles) as solids, the flight volume, the first and last position as start
    and goal, the positions between as via points. The outside of an inclusion fence is left
    out (the fence's outline is drawn; walls around the volume would hide it)."""
    from uavplan.render import Scene  # matplotlib loads only when drawing

    first, last = positions_enu[0], positions_enu[-1]
    solids = [
        ob
        for ob, what in zip(airspace.obstacles, airspace.names, strict=True)
        if what != OUTSIDE_INCLUSION
    ]
    return Scene(
        name=name,
        bounds=airspace.bounds,
        obstacles=solids,
        safety_margin_m=margin_m,
        start_enu=first,
        goal_enu=last,
        via_enu=tuple(positions_enu[1:-1]),
    )


def _picture(result: RerouteResult, name: str) -> bytes:
    """The rerouted plan drawn in the world it was planned in (PNG bytes)."""
    from uavplan.render import RouteLayers, render_png

    assert result.airspace is not None and result.frame is not None
    layers = RouteLayers.from_mission(result.plan, result.frame, result.flown_enu)
    subtitle = (
        f"{len(result.plan.items)} items ({plural(result.inserted, 'planned waypoint')} "
        f"added), {result.length_m:.0f} m flown from take-off, min clearance "
        f"{result.min_clearance_m:.2f} m (margin {result.safety_margin_m:g} m)"
    )
    scene = fence_scene(name, result.airspace, result.safety_margin_m, result.positions_enu)
    return render_png(scene, layers, subtitle=subtitle)
