"""``uavplan plan`` of a scenario with a ``survey:`` section: the lanes around the holes
(:mod:`uavplan.surveying`), the mission with its camera items, the same whole-flight verdict
(uavplan.verdict: the flight model flies the mission with the parameters it relies on) and
the same flight-model estimate as any planned route; the mission is written only when the
flight keeps the margin."""

from __future__ import annotations

import itertools
import json
import math
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple, Protocol

import numpy as np

from uavplan.airframe import EnergyBudgetError
from uavplan.app.feedback import Feedback
from uavplan.app.outputs import OutputSet, check_report_name
from uavplan.errors import InputError, NoPathError
from uavplan.estimate import DEFAULT_RESERVE_PCT, BatteryEstimate, estimate_flown
from uavplan.flown_safe import MAX_REPLANS, padded_scenario, widened_until_flown_safe
from uavplan.mission.io import format_for, mission_text
from uavplan.mission.items import Autopilot, MissionPlan
from uavplan.rehearsal import CheckSite, tracking_allowance_m
from uavplan.scenario.survey import with_no_fly
from uavplan.scenario.values import load_survey_scenario
from uavplan.survey import coverage
from uavplan.surveying import SurveyRoute, lane_energy, part_of, plan_survey, survey_mission
from uavplan.worlds import padded_world

if TYPE_CHECKING:
    from uavplan.scenario import Scenario
    from uavplan.scenario.survey import SurveySpec
    from uavplan.verdict import FlightVerdict
    from uavplan.world import World


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
    estimate: BatteryEstimate | None = None
    verdict: FlightVerdict | None = None
    #: the missions a survey larger than one battery was split into (written instead of
    #: ``output``), each from the start and back to it; empty: one mission
    parts: tuple[SurveyPart, ...] = ()

    @property
    def interrupted(self) -> bool:
        return False

    def summary(self) -> str:
        cover = "" if self.covered is None else f" ({100 * self.covered:.1f} % covered)"
        if self.parts:
            head = (
                f"{Path(self.output).name}: split into {len(self.parts)} missions, one battery "
                f"each: {self.route.lanes} lanes {_direction(self.route)}, "
                f"{self.photos} photos, {self.area_m2 / 1e4:.2f} ha{cover}, planned in "
                f"{self.elapsed_s:.2f} s"
            )
            return "\n".join([head, *(p.summary() for p in self.parts)])
        return (
            f"{Path(self.output).name}: {len(self.mission.items)} items, "
            f"{self.route.lanes} lanes {_direction(self.route)}, {self.photos} photos, "
            f"{self.area_m2 / 1e4:.2f} ha{cover}, {self.route.rerouted} transitions routed "
            f"around obstacles, {_clearance(self.route.min_clearance_m)}, in "
            f"{self.elapsed_s:.2f} s"
        )


def _lanes(n: int) -> str:
    return f"{n} lane" if n == 1 else f"{n} lanes"


def _direction(route: SurveyRoute) -> str:
    """``at 35°``, or ``along the corridor`` for a corridor scan's bending lanes."""
    angle = route.sweep.angle_deg
    return "along the corridor" if math.isnan(angle) else f"at {angle:g}°"


def _finite(value: float) -> float | None:
    """``value`` for a JSON report (rounded), None when infinite (JSON has no infinity)."""
    return round(value, 3) if math.isfinite(value) else None


def _clearance(clearance_m: float) -> str:
    """``min clearance 5.02 m planned``, or that nothing stands near the flight."""
    if not math.isfinite(clearance_m):
        return "nothing to keep clear of"
    return f"min clearance {clearance_m:.2f} m planned"


@dataclass(frozen=True)
class SurveyPart:
    """One mission of a survey split across batteries: its lanes (``route``, from the start
    and back), the mission written to ``output``, its whole-flight verdict and its estimate
    (within the battery and the reserve); ``area_m2``: the free area its lanes sweep."""

    output: str
    route: SurveyRoute
    mission: MissionPlan
    verdict: FlightVerdict | None
    estimate: BatteryEstimate
    area_m2: float

    def summary(self) -> str:
        e = self.estimate
        return (
            f"  {Path(self.output).name}: {_lanes(self.route.lanes)}, {self.route.sweep.photos} "
            f"photos, {self.area_m2 / 1e4:.2f} ha, {_clearance(self.route.min_clearance_m)}; "
            f"{e.energy.summary(e.reserve_pct)}"
        )

    def report(self) -> dict[str, object]:
        return {
            "output": self.output,
            "lanes": self.route.lanes,
            "photos": self.route.sweep.photos,
            "area_m2": round(self.area_m2, 1),
            "min_clearance_m": _finite(self.route.min_clearance_m),
            **self.estimate.report_fields(),
            "whole_flight": None if self.verdict is None else self.verdict.report(),
        }


_NOT_FOR_SURVEYS = {
    "plot": "--plot",
    "view": "--view",
    "fence": "--fence",
    "legal_ceiling": "--legal-ceiling",
}


class _Planned(NamedTuple):
    """One attempt of the survey's widen loop: the scenario it was planned in (the margin
    widened), its world, the route, the mission and the verdict on its whole flight."""

    planned_in: Scenario
    world: World
    route: SurveyRoute
    mission: MissionPlan
    verdict: FlightVerdict | None


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
        scn = replace(
            scn, mission=replace(scn.mission, autopilot=Autopilot.from_name(request.autopilot))
        )
    scn = with_no_fly(scn, spec)

    # the lanes and transitions keep the firmware's tracking allowance beyond the margin, as
    # the verdict below asks of a predicted flight (uavplan.rehearsal.TRACKING_ALLOWANCE_M);
    # while the flight as flown breaks it, the holes and transitions keep a wider margin (the
    # widen loop of uavplan.flown_safe: what the track lacked, plus a step)
    site = CheckSite.of_scenario(scn)  # the world, once: each pass widens its margin

    def planned_with(pad: float) -> _Planned:
        planned_in = padded_scenario(scn, pad) if pad else scn
        world = padded_world(site.world, planned_in)
        route = plan_survey(planned_in, spec, world=world)
        mission = survey_mission(scn, spec, route)
        return _Planned(planned_in, world, route, mission, _judge(scn, site, mission))

    label = scn.mission.autopilot.label
    ended = widened_until_flown_safe(
        planned_with(tracking_allowance_m(scn.mission.autopilot)),
        lambda planned: None if planned.verdict is None else planned.verdict.check,
        planned_with,
        stopped=lambda planned: False,
        noted=lambda why, pad: (
            f"{label} flight model: {why}; planned again with the margin {pad:.2f} m wider"
        ),
        exhausted=lambda pad: (
            f"planned {MAX_REPLANS} more times, the margin up to {pad:.2f} m wider"
        ),
        pad_m=tracking_allowance_m(scn.mission.autopilot),
    )
    for note in ended.notes:
        feedback.say(note)
    planned_in, world, route, mission, verdict = ended.value
    if ended.gave_up:
        assert verdict is not None
        raise NoPathError(f"{verdict.problem()} ({ended.gave_up})")
    reserve = DEFAULT_RESERVE_PCT if request.reserve_pct is None else request.reserve_pct
    estimate = None
    parts: tuple[SurveyPart, ...] = ()
    if verdict is not None and verdict.rehearsal is not None:
        estimate = estimate_flown(scn, verdict.rehearsal.flown, reserve_pct=reserve)
        if not estimate.fits and not request.allow_over_battery:
            feedback.say(
                f"the survey needs {estimate.energy.energy_wh:.1f} Wh, more than one battery "
                f"leaves above the {reserve:g} % reserve: splitting it into missions that "
                "each start and end at the start"
            )
            parts = _split(scn, site, planned_in, spec, route, world, estimate, request.output)
        else:
            warning = estimate.check(allow_over_battery=request.allow_over_battery)
            if warning is not None:
                feedback.warn(warning)
    covered = None
    s = spec.spacing
    if s.footprint_side_m is not None and s.footprint_front_m is not None:
        photos_xy, heading = coverage.photos_along(
            route.sweep.pieces_xy, s.trigger_distance_m, route.sweep.joined
        )
        fp = coverage.footprints(photos_xy, heading, s.footprint_side_m, s.footprint_front_m)
        covered = coverage.covered_fraction(route.free, fp)
    report: dict[str, object] = {
        "survey": {
            "lanes": route.lanes,
            "angle_deg": _finite(route.sweep.angle_deg),
            "corridor": spec.corridor_m is not None,
            "photos": route.sweep.photos,
            "lane_length_m": round(route.sweep.lane_length_m, 1),
            "area_m2": round(float(route.free.area), 1),
            "covered": None if covered is None else round(covered, 4),
            "transitions_routed": route.rerouted,
            "min_clearance_m": _finite(route.min_clearance_m),
            "altitude_m": spec.altitude_m,
            "lane_spacing_m": s.lane_spacing_m,
            "trigger_distance_m": s.trigger_distance_m,
            "trigger": spec.trigger,
        },
    }
    if parts:
        # the parts are written instead of the one mission, all of them or none
        outputs = OutputSet(feedback.interrupts)
        outputs.reads(request.source, role="the scenario")
        outputs.reads(*scn.files)
        part_outs = [outputs.file(p.output) for p in parts]
        report_out = outputs.file(request.report) if request.report else None
        outputs.check()
        report["missions"] = [p.report() for p in parts]
        with outputs:
            for out, part in zip(part_outs, parts, strict=True):
                out.write_text(mission_text(part.mission, part.output))
            if report_out is not None:
                report_out.write_text(json.dumps(report, indent=2) + "\n")
            outputs.commit()
        for k, part in enumerate(parts, start=1):
            if part.verdict is not None:
                feedback.say(f"mission {k}: {part.verdict.summary()}")
                for line in part.verdict.warnings():
                    feedback.warn(f"mission {k}: {line}")
        estimate = None  # each part has its own (SurveyPart.summary)
    else:
        with outputs:
            mission_out.write_text(mission_text(mission, request.output))
            if report_out is not None:
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
        parts,
    )


#: how often a split survey is cut again, each time by an allowance this much smaller
SPLIT_TRIES = 12
SPLIT_SHRINK = 0.93


def _split(
    scn: Scenario,
    site: CheckSite,
    planned_in: Scenario,
    spec: SurveySpec,
    route: SurveyRoute,
    world: World,
    whole: BatteryEstimate,
    output: str,
) -> tuple[SurveyPart, ...]:
    """``route``'s lanes split, in their order, into consecutive groups whose missions (each
    from the start and back) keep the margin as flown and fit the battery with its reserve.

    Each group takes lanes while the energy of its path (start, its lanes, start; the
    vehicle's power model, scaled by what the flight model's whole flight needed over that
    path's estimate) stays within one battery's allowance; every group's mission is then
    judged and estimated like any other. While one does not fit, the allowance the groups are
    cut by shrinks by :data:`SPLIT_SHRINK` and they are cut again. Raises EnergyBudgetError
    when one lane alone does not fit, NoPathError when a mission breaks the margin."""
    e = whole.energy
    allowed = e.usable_wh * (100.0 - whole.reserve_pct) / 100.0
    pieces = route.sweep.pieces_xy
    start = np.asarray(scn.start_m, dtype=np.float64)[:2]
    energy = lane_energy(planned_in, spec)
    scale = e.energy_wh / max(energy(route.sweep.path_xy), 1e-9)

    # the groups are cut between lanes: ``first[i]`` is lane i's first piece (a corridor's
    # bent lane is several straight pieces)
    first = [a for a, _ in coverage.runs(len(pieces), route.sweep.joined)] + [len(pieces)]
    lanes = len(first) - 1

    def cost(a: int, b: int) -> float:
        return scale * energy(coverage.path_xy(pieces[first[a] : first[b]], start))

    path = Path(output)
    budget = allowed
    for _ in range(SPLIT_TRIES):
        bounds = [0]
        while bounds[-1] < lanes:
            a = b = bounds[-1]
            while b < lanes and (b == a or cost(a, b + 1) <= budget):
                b += 1
            if cost(a, b) > allowed and b - a == 1:
                raise EnergyBudgetError(
                    f"the survey cannot be split into missions that fit the battery: lane "
                    f"{a + 1} alone, flown from the start and back, needs about "
                    f"{cost(a, b):.1f} Wh where {allowed:.1f} Wh are allowed with the "
                    f"{whole.reserve_pct:g} % reserve; --allow-over-battery plans it as one "
                    "mission",
                    key="survey",
                )
            bounds.append(b)
        parts: list[SurveyPart] = []
        for k, (a, b) in enumerate(itertools.pairwise(bounds), start=1):
            part = part_of(planned_in, spec, route, slice(first[a], first[b]), world=world)
            mission = survey_mission(scn, spec, part)
            verdict = _judge(scn, site, mission)
            if verdict is not None and verdict.problem() is not None:
                raise NoPathError(f"mission {k} of the split survey: {verdict.problem()}")
            if verdict is None or verdict.rehearsal is None:
                raise InputError("a survey is split only for a vehicle the flight model flies")
            estimate = estimate_flown(scn, verdict.rehearsal.flown, reserve_pct=whole.reserve_pct)
            if not estimate.fits:
                break
            out = str(path.with_name(f"{path.stem}-{k}{path.suffix}"))
            swept = coverage.swept_area(part.sweep.pieces_xy, spec.spacing.lane_spacing_m)
            area = float(swept.intersection(route.free).area)
            parts.append(SurveyPart(out, part, mission, verdict, estimate, area))
        else:
            return tuple(parts)
        budget *= SPLIT_SHRINK
    raise EnergyBudgetError(
        f"the survey could not be split into missions that fit the battery in {SPLIT_TRIES} "
        "tries; --allow-over-battery plans it as one mission",
        key="survey",
    )


def _judge(scn: Scenario, site: CheckSite, mission: MissionPlan) -> FlightVerdict | None:
    """The whole flight of ``mission`` as the scenario's vehicle flies it in its ``site``
    (None for an autopilot the flight model does not fly), as :mod:`uavplan.app.plan`
    judges a route."""
    if mission.autopilot not in (Autopilot.PX4, Autopilot.ARDUPILOT) or mission.home is None:
        return None
    from uavplan.rehearsal import conditions_of
    from uavplan.verdict import judge_flight

    return judge_flight(mission, site, **conditions_of(scn))


__all__ = ["SurveyOutcome", "SurveyPart", "plan_survey_file", "with_no_fly"]
