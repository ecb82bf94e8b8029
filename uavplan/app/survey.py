"""``uavplan plan`` of a scenario with a ``survey:`` section: the lanes around the holes
(:mod:`uavplan.surveying`), the mission with its camera items, the same whole-flight verdict
(uavplan.verdict: the flight model flies the mission with the parameters it relies on) and
the same flight-model estimate as any planned route; the mission is written only when the
flight keeps the margin."""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from uavplan.app.feedback import Feedback
from uavplan.app.outputs import OutputSet, check_report_name
from uavplan.errors import InputError, NoPathError
from uavplan.estimate import DEFAULT_RESERVE_PCT, FlightEstimate, estimate_flown
from uavplan.flown_safe import padded_scenario
from uavplan.mission.io import format_for, mission_text
from uavplan.mission.items import Autopilot, MissionPlan
from uavplan.rehearsal import tracking_allowance_m
from uavplan.scenario.values import load_survey_scenario
from uavplan.survey import coverage
from uavplan.surveying import SurveyRoute, plan_survey, survey_mission

if TYPE_CHECKING:
    from uavplan.scenario import Scenario
    from uavplan.verdict import FlightVerdict


class SurveyRequest(Protocol):
    """What a survey takes of ``plan``'s request (:class:`uavplan.app.plan.PlanRequest`)."""

    @property
    def source(self) -> str: ...
    @property
    def output(self) -> str: ...
    @property
    def autopilot(self) -> str | None: ...
    @property
    def reserve_pct(self) -> float | None: ...
    @property
    def allow_over_battery(self) -> bool: ...
    @property
    def report(self) -> str | None: ...
    @property
    def plot(self) -> str | None: ...
    @property
    def view(self) -> str | None: ...
    @property
    def fence(self) -> bool: ...
    @property
    def legal_ceiling(self) -> str | None: ...


@dataclass(frozen=True)
class SurveyOutcome:
    """A planned survey, written to ``output``."""

    scenario: Scenario
    route: SurveyRoute
    output: str
    mission: MissionPlan
    photos: int
    #: the free area (area minus holes), m²
    area_m2: float
    #: the share of the free area the photos' footprints cover (None without a camera)
    covered: float | None
    elapsed_s: float = math.nan
    estimate: FlightEstimate | None = None
    verdict: FlightVerdict | None = None

    @property
    def interrupted(self) -> bool:
        return False

    def summary(self) -> str:
        cover = "" if self.covered is None else f" ({100 * self.covered:.1f} % covered)"
        return (
            f"{Path(self.output).name}: {len(self.mission.items)} items, "
            f"{self.route.lanes} lanes at {self.route.sweep.angle_deg:g}°, {self.photos} photos, "
            f"{self.area_m2 / 1e4:.2f} ha{cover}, {self.route.rerouted} transitions routed "
            f"around obstacles, min clearance {self.route.min_clearance_m:.2f} m planned, in "
            f"{self.elapsed_s:.2f} s"
        )


_NOT_FOR_SURVEYS = {
    "plot": "--plot",
    "view": "--view",
    "fence": "--fence",
    "legal_ceiling": "--legal-ceiling",
}


def plan_survey_file(request: SurveyRequest, feedback: Feedback) -> SurveyOutcome:
    """Plan the survey scenario ``request.source`` and write its mission (all or nothing)."""
    t0 = time.perf_counter()
    for name, option in _NOT_FOR_SURVEYS.items():
        if getattr(request, name):
            raise InputError(f"{option} is not built for survey scenarios yet")
    format_for(request.output)  # an unknown extension fails before planning
    outputs = OutputSet(feedback.interrupts)
    outputs.reads(request.source, role="the scenario")
    check_report_name(request.report)
    mission_out = outputs.file(request.output)
    report_out = outputs.file(request.report) if request.report else None
    outputs.check()
    scn, spec = load_survey_scenario(request.source)
    outputs.reads(*scn.files)
    if request.autopilot:
        from dataclasses import replace

        scn = replace(
            scn, mission=replace(scn.mission, autopilot=Autopilot.from_name(request.autopilot))
        )
    # the lanes and transitions keep the firmware's tracking allowance beyond the margin, as
    # the verdict below asks of a predicted flight (uavplan.rehearsal.TRACKING_ALLOWANCE_M)
    allowance = tracking_allowance_m(scn.mission.autopilot)
    route = plan_survey(padded_scenario(scn, allowance) if allowance else scn, spec)
    mission = survey_mission(scn, spec, route)
    verdict = _judge(scn, mission)
    if verdict is not None and verdict.problem() is not None:
        raise NoPathError(str(verdict.problem()))
    reserve = DEFAULT_RESERVE_PCT if request.reserve_pct is None else request.reserve_pct
    estimate = None
    if verdict is not None and verdict.rehearsal is not None:
        estimate = estimate_flown(scn, verdict.rehearsal.flown, reserve_pct=reserve)
        # a survey over the battery is refused (exit 2) unless --allow-over-battery; it is
        # not split into missions yet
        warning = estimate.check(allow_over_battery=request.allow_over_battery)
        if warning is not None:
            feedback.warn(warning)
    covered = None
    s = spec.spacing
    if s.footprint_side_m is not None and s.footprint_front_m is not None:
        photos_xy = coverage.photo_positions(route.sweep.pieces_xy, s.trigger_distance_m)
        fp = coverage.footprints(
            photos_xy, route.sweep.angle_deg, s.footprint_side_m, s.footprint_front_m
        )
        covered = coverage.covered_fraction(route.free, fp)
    with outputs:
        mission_out.write_text(mission_text(mission, request.output))
        if report_out is not None:
            report: dict[str, object] = {
                "survey": {
                    "lanes": route.lanes,
                    "angle_deg": route.sweep.angle_deg,
                    "photos": route.sweep.photos,
                    "lane_length_m": round(route.sweep.lane_length_m, 1),
                    "area_m2": round(float(route.free.area), 1),
                    "covered": None if covered is None else round(covered, 4),
                    "transitions_routed": route.rerouted,
                    "min_clearance_m": round(route.min_clearance_m, 3),
                    "altitude_m": spec.altitude_m,
                    "lane_spacing_m": s.lane_spacing_m,
                    "trigger_distance_m": s.trigger_distance_m,
                    "trigger": spec.trigger,
                },
            }
            if estimate is not None:
                report.update(estimate.report_fields())
            if verdict is not None:
                report["whole_flight"] = verdict.report()
            report_out.write_text(json.dumps(report, indent=2) + "\n")
        outputs.commit()
    if verdict is not None:
        feedback.say(verdict.summary())
        for line in verdict.warnings():
            feedback.warn(line)
    return SurveyOutcome(
        scn,
        route,
        request.output,
        mission,
        route.sweep.photos,
        float(route.free.area),
        covered,
        time.perf_counter() - t0,
        estimate,
        verdict,
    )


def _judge(scn: Scenario, mission: MissionPlan) -> FlightVerdict | None:
    """The whole flight of ``mission`` as the scenario's vehicle flies it (None for an
    autopilot the flight model does not fly), as :mod:`uavplan.app.plan` judges a route."""
    if mission.autopilot not in (Autopilot.PX4, Autopilot.ARDUPILOT) or mission.home is None:
        return None
    from uavplan.rehearsal import CheckSite, conditions_of
    from uavplan.verdict import judge_flight

    return judge_flight(mission, CheckSite.of_scenario(scn), **conditions_of(scn))


__all__ = ["SurveyOutcome", "plan_survey_file"]
