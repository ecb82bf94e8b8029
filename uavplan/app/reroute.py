"""``plan user.plan -o safe.plan [--scenario S]``: reroute a QGroundControl plan around its
exclusion zones (the rerouting itself is :mod:`uavplan.reroute`)."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from uavplan.app.feedback import Feedback, PlannerOptions
from uavplan.config import PlannerConfig
from uavplan.errors import InputError, NoPathError
from uavplan.fileio import atomic_write_text, check_writable
from uavplan.mission.io import load_mission, save_mission
from uavplan.rehearsal import reroute_safe_as_flown
from uavplan.reroute import RerouteResult, reroute_plan
from uavplan.scenario import load_scenario


@dataclass(frozen=True)
class RerouteRequest:
    """A QGroundControl plan ``source`` to reroute into ``output`` (a .plan), with the
    obstacles and settings of ``scenario`` if given. ``autopilot``, ``plot`` and ``fence``
    are refused: the plan keeps its own."""

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
    """The rerouted plan, written to ``output`` unless the planning was interrupted."""

    result: RerouteResult
    output: str

    @property
    def interrupted(self) -> bool:
        return self.result.interrupted

    def summary(self) -> str:
        r = self.result
        return (
            f"{Path(self.output).name}: {len(r.plan.items)} items "
            f"({r.inserted} planned waypoints added to the plan's "
            f"{len(r.plan.items) - r.inserted}), {r.length_m:.0f} m flown, "
            f"min clearance {r.min_clearance_m:.2f} m "
            f"(margin {r.safety_margin_m:g} m), planned in {r.runtime_s:.2f} s{_flight_text(r)}"
        )


def _flight_text(result: RerouteResult) -> str:
    flight = result.flight
    if flight is None:
        return ""
    minutes, seconds = divmod(round(flight.flight_time_s), 60)
    return f", flight {minutes} min {seconds:02d} s ({flight.autopilot} flight model)"


def reroute_file(request: RerouteRequest, feedback: Feedback) -> RerouteOutcome:
    """Read the plan, reroute it and write the output (and the report); the notes go to
    ``feedback.say`` once the plan is written."""
    if Path(request.output).suffix.lower() != ".plan":
        raise InputError(
            "a rerouted QGroundControl plan is written as a .plan (it keeps the fence and "
            "the rally points); name the output *.plan",
            file=request.output,
        )
    given = (
        ("--autopilot", request.autopilot),
        ("--plot", request.plot),
        ("--fence", request.fence),
    )
    for flag, value in given:
        if value:
            raise InputError(
                f"{flag} does not apply to a .plan input: the plan keeps its own autopilot "
                "flavour and geofence"
            )
    for path in (request.output, request.report):
        if path:
            check_writable(path)
    plan = load_mission(request.source)
    base = None if request.scenario is None else load_scenario(request.scenario)
    if base is not None:
        base = request.options.apply(base)
    planner = base.planner if base is not None else request.options.apply_to(PlannerConfig())
    name = Path(request.source).stem
    bar = feedback.progress
    if bar is not None:
        bar.start(f"{planner.algorithm} {name}")
    try:
        result = reroute_plan(
            plan,
            base=base,
            planner=planner,
            name=name,
            file=request.source,
            progress=bar,
            should_stop=feedback.should_stop,
        )
    finally:
        if bar is not None:
            bar.close()
    if not result.interrupted:  # the track the flight model predicts keeps the margin too
        result = reroute_safe_as_flown(
            plan,
            result,
            base=base,
            planner=planner,
            name=name,
            file=request.source,
            should_stop=feedback.should_stop,
        )
    if result.interrupted:
        return RerouteOutcome(result, request.output)
    problem = None if result.flight is None else result.flight.problem()
    if problem is not None:
        raise NoPathError(f"{name}: {problem}")
    save_mission(result.plan, request.output)
    if request.report:
        atomic_write_text(request.report, json.dumps(result.report(), indent=2) + "\n")
    for note in result.notes:
        feedback.say(f"note: {note}")
    return RerouteOutcome(result, request.output)
