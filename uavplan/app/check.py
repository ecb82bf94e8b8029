"""``validate``: check a scenario file, or a flight against a scenario.

:func:`check_flight_in` is the one check of a flight against a scenario: a mission file read
the way the autopilot flies it (:func:`mission_flight`: over a DEM from home's ground AMSL and
each item's altitude frame), or any flown polyline or track as a
:class:`~uavplan.flightcheck.Flight`. ``validate MISSION --scenario S`` and ``render --mission``
both use it (and the rerouting checks its result with the same
:func:`uavplan.flightcheck.check_flight`), so they report the same clearance.

Checking a scenario alone needs no numpy (a scenario of a few obstacles is checked in plain
Python: ``uavplan validate`` starts in a tenth of a second); the mission check imports the
world and the mission readers where it runs.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

from uavplan.app.feedback import plural
from uavplan.app.inputs import load_scenario_file, mission_kind
from uavplan.errors import InputError, NoPathError, ScenarioError
from uavplan.scenario import Scenario, Surroundings, load_site, load_surroundings

if TYPE_CHECKING:
    from uavplan.estimate import BatteryEstimate
    from uavplan.flightcheck import Flight, FlightCheck
    from uavplan.mission.items import MissionPlan
    from uavplan.rehearsal import CheckSite
    from uavplan.verdict import FlightVerdict


@dataclass(frozen=True, eq=False)
class ScenarioCheck:
    """A scenario file that passed every check."""

    file: str
    scenario: Scenario
    #: the straight route's flight time, energy and battery (the least the flight needs)
    estimate: BatteryEstimate | None = None
    #: a flight over the battery budget with no vehicle named (not refused), or None
    warning: str | None = None

    def summary(self) -> str:
        scn = self.scenario
        line = (
            f"{self.file}: ok — {scn.name}, {len(scn.obstacles)} obstacles, "
            f"margin {scn.safety_margin_m:g} m"
        )
        if scn.airspace is not None:  # the zones read and why each is a constraint or not
            line = "\n".join([line, *scn.airspace.summary_lines()])
        return line if self.estimate is None else f"{line}\n{self.estimate.summary()}"


@dataclass(frozen=True, eq=False)
class MissionCheck:
    """A mission file's flight checked against a scenario."""

    file: str
    plan: MissionPlan
    check: FlightCheck
    #: the mission's flight time, energy and battery with the scenario's vehicle and wind
    estimate: BatteryEstimate | None = None
    #: a flight over the battery budget let through by --allow-over-battery, or None
    warning: str | None = None
    #: the whole flight judged (None: the flight model does not fly this mission)
    verdict: FlightVerdict | None = None

    @property
    def min_clearance_m(self) -> float:
        return self.check.min_clearance_m

    @property
    def warnings(self) -> tuple[str, ...]:
        found = () if self.verdict is None else tuple(self.verdict.warnings())
        return (*found, *(() if self.warning is None else (self.warning,)))

    def summary(self) -> str:
        margin = self.check.margin_m
        line = (
            f"{self.file}: ok — {len(self.plan.items)} items, min clearance "
            f"{self.min_clearance_m:.2f} m (margin {margin:g} m)"
        )
        if self.verdict is not None:
            line += f"\n{self.verdict.summary()}"
        return line if self.estimate is None else f"{line}\n{self.estimate.summary()}"


@dataclass(frozen=True, eq=False)
class FenceCheck:
    """A QGroundControl plan's flight checked against its own geofence, as its rerouting
    plans it (the exclusion zones and the outside of the inclusion fence as obstacles)."""

    file: str
    plan: MissionPlan
    check: FlightCheck
    #: what else the world holds, for the summary (" and scenario S's 12 obstacles")
    also: str = ""
    #: the whole flight judged in the plan's own airspace (None: not flown)
    verdict: FlightVerdict | None = None

    @property
    def min_clearance_m(self) -> float:
        return self.check.min_clearance_m

    @property
    def warnings(self) -> tuple[str, ...]:
        return () if self.verdict is None else tuple(self.verdict.warnings())

    def summary(self) -> str:
        zones = len(self.plan.fence.polygons) + len(self.plan.fence.circles)
        line = (
            f"{self.file}: ok — {len(self.plan.items)} items, min clearance from its geofence "
            f"({plural(zones, 'zone')}){self.also} {self.min_clearance_m:.2f} m (margin "
            f"{self.check.margin_m:g} m)"
        )
        return line if self.verdict is None else f"{line}\n{self.verdict.summary()}"


def validate(
    file: str,
    scenario_path: str | None = None,
    *,
    reserve_pct: float | None = None,
    allow_over_battery: bool = False,
) -> ScenarioCheck | MissionCheck | FenceCheck:
    """Check the scenario ``file``, or with ``scenario_path`` the mission ``file`` against
    that scenario; a QGroundControl ``.plan`` without a scenario is checked against its own
    geofence. A scenario's problem raises ScenarioError (exit 2).

    A mission is checked twice, by the one mission check: its straight legs, and its whole
    flight as the autopilot flies it with the parameters it relies on (the flight model:
    :func:`uavplan.verdict.judge_flight`, take-off to touchdown, the return to launch
    included, and a failsafe return from every point). A flight that leaves the flight
    volume or comes closer than the margin raises NoPathError (exit 3); a failsafe return
    that would is a warning (:attr:`MissionCheck.warnings`).

    A scenario, and a mission against one, are also estimated (flight time, energy, battery:
    :mod:`uavplan.estimate`; a scenario alone by its straight route, a mission as the flight
    model flew it). A flight that does not leave ``reserve_pct`` (default 20 %) of the
    battery raises EnergyBudgetError (exit 2) unless ``allow_over_battery`` (a warning)."""
    if scenario_path is None:
        kind = mission_kind(file)
        if kind == "plan":
            if reserve_pct is not None:
                raise InputError("--reserve needs a scenario (--scenario) to estimate against")
            return _check_against_fence(file)
        scn = load_scenario_file(file, "validate")
        from uavplan.estimate import DEFAULT_RESERVE_PCT, estimate_straight_route  # numpy

        reserve = DEFAULT_RESERVE_PCT if reserve_pct is None else reserve_pct
        estimate = estimate_straight_route(scn, reserve_pct=reserve)
        try:
            warning = estimate.check(allow_over_battery=allow_over_battery)
        except InputError as err:  # one message that names the file it is about
            if err.file is not None:
                raise
            raise type(err)(err.reason, key=err.key, file=file) from None
        return ScenarioCheck(file, scn, estimate, warning)
    try:
        scenario = load_site(scenario_path)
    except ScenarioError as err:
        if mission_kind(file) == "plan" and err.key in ("start", "goal"):
            # a map or a scenario without a route (as `plan X.plan --scenario S` takes one):
            # the plan in its rerouting's world, its fence and the scenario's obstacles
            return _check_against_fence(file, load_surroundings(scenario_path))
        raise
    plan, flight = read_mission_flight(file, scenario)
    if len(flight.points_enu) < 2:
        raise InputError("the mission has fewer than two positions to fly", file=file)
    checked = MissionCheck(file, plan, check_flight_in(scenario, flight))
    problem = checked.check.problem()
    if problem is not None:
        if scenario.airspace is not None:  # every zone the flight enters or comes too close to
            from uavplan.scenario.zones import infringement_text

            problem += infringement_text(scenario, flight.points_enu)
        raise NoPathError(f"{file}: the straight legs: {problem}")
    from uavplan.estimate import DEFAULT_RESERVE_PCT

    reserve = DEFAULT_RESERVE_PCT if reserve_pct is None else reserve_pct
    from uavplan.rehearsal import CheckSite

    verdict = judged(plan, CheckSite.of_scenario(scenario), scenario)
    if verdict is not None:
        problem = verdict.problem()
        if problem is not None:
            raise NoPathError(f"{file}: {problem}")
    estimate = _mission_estimate(scenario, plan, flight, reserve, verdict)
    warning = estimate.check(allow_over_battery=allow_over_battery)
    return replace(checked, estimate=estimate, warning=warning, verdict=verdict)


def judged(
    plan: MissionPlan, site: CheckSite, scenario: Scenario | None = None
) -> FlightVerdict | None:
    """The whole flight of ``plan`` in ``site`` (:func:`uavplan.verdict.judge_flight`; with
    ``scenario`` as its vehicle flies it through its wind), or None when the flight model
    does not fly it (an autopilot it does not know, no home, a mission the autopilot would
    refuse to start: those are checked by their straight legs only)."""
    from uavplan.autopilot.simulate import refusal_of
    from uavplan.mission.items import Autopilot
    from uavplan.rehearsal import conditions_of
    from uavplan.verdict import judge_flight

    if plan.autopilot not in (Autopilot.PX4, Autopilot.ARDUPILOT) or plan.home is None:
        return None
    if refusal_of(plan) is not None:
        return None
    conditions = {} if scenario is None else conditions_of(scenario)
    return judge_flight(plan, site, **conditions)


def _mission_estimate(
    scenario: Scenario,
    plan: MissionPlan,
    flight: Flight,
    reserve_pct: float,
    verdict: FlightVerdict | None = None,
) -> BatteryEstimate:
    """The mission's flight time, energy and battery as ``plan`` estimates what it writes:
    the whole flight the verdict judged (the flight model, the parameters the mission relies
    on, the scenario's vehicle and wind: :func:`uavplan.estimate.estimate_flown`); a mission
    the model does not fly (not PX4 or ArduPilot, or one the autopilot would refuse to
    start) by its legs (:func:`uavplan.estimate.estimate_mission`)."""
    from uavplan.estimate import estimate_flown, estimate_mission

    if verdict is not None and verdict.rehearsal is not None:
        return estimate_flown(scenario, verdict.rehearsal.flown, reserve_pct=reserve_pct)
    return estimate_mission(scenario, plan, flight, reserve_pct=reserve_pct)


def no_fence(file: str, command: str) -> InputError:
    """A .plan without a geofence given where a scenario is expected."""
    how = {
        "validate": f"check it against a scenario: uavplan validate {file} --scenario S",
        "render": f"draw it over a scenario: uavplan render S --mission {file} -o picture.png",
    }[command]
    return InputError(
        f"this mission has no geofence to check it against, and it is not a scenario: {how}",
        file=file,
    )


def _check_against_fence(file: str, base: Surroundings | None = None) -> FenceCheck:
    """``validate PLAN``: the plan's flight against its own geofence (and ``base``'s
    obstacles) in the world of its rerouting (:func:`uavplan.worlds.fence_world`; the one
    check, :func:`uavplan.flightcheck.check_flight`)."""
    # the mission readers, numpy and the world: only for a mission
    from uavplan.mission.io import load_mission
    from uavplan.worlds import fence_world

    plan = load_mission(file)
    if not (plan.fence.polygons or plan.fence.circles) and base is None:
        raise no_fence(file, "validate")
    world, flight = fence_world(plan, base=base, file=file)
    also = ""
    if base is not None:
        also = f" and {base.source}'s {plural(len(base.obstacles), 'obstacle')}"
    checked = FenceCheck(file, plan, world.check(flight), also)
    problem = checked.check.problem()
    if problem is not None:
        raise NoPathError(f"{file}: the straight legs: {problem}")
    from uavplan.rehearsal import CheckSite

    site = CheckSite.of_plan(plan, base=base, file=file)
    verdict = None if site is None else judged(plan, site)
    if verdict is not None:
        problem = verdict.problem()
        if problem is not None:
            raise NoPathError(f"{file}: {problem}")
    return replace(checked, verdict=verdict)


def mission_flight(plan: MissionPlan, scenario: Scenario, *, file: str | None = None) -> Flight:
    """The flight of ``plan`` where ``scenario`` is planned (its site's frame; over a DEM on
    the ground: home on the ground there, each item's altitude in its frame, terrain-frame
    legs flown over the ground as ArduPilot flies them)."""
    # numpy, pyproj and the world's kernels: not for `validate` of a scenario (test_startup)
    from uavplan.flightcheck import flight_of_mission
    from uavplan.worlds import enu_frame

    site = scenario.site
    ground_z = None if site.ground is None else site.ground.z_at
    follow = None if site.ground is None else site.ground.follow
    try:
        return flight_of_mission(plan, enu_frame(site), ground_z, follow)
    except ValueError as err:
        raise InputError(str(err), file=file) from None


def check_flight_in(scenario: Scenario, flight: Flight) -> FlightCheck:
    """``flight`` (in the scenario's site frame) checked against ``scenario``'s world: its
    clearance, what is nearest, and whether it stays in the flight volume."""
    # numpy and the world's kernels: not for `validate` of a scenario (test_startup)
    from uavplan.flightcheck import check_flight
    from uavplan.worlds import build_world

    return check_flight(build_world(scenario), flight, name_of=scenario.obstacle_name)


def read_mission_flight(file: str, scenario: Scenario) -> tuple[MissionPlan, Flight]:
    """The mission file ``file`` and its flight where ``scenario`` is planned."""
    from uavplan.mission.io import load_mission  # the mission readers: only with a mission

    plan = load_mission(file)
    return plan, mission_flight(plan, scenario, file=file)
