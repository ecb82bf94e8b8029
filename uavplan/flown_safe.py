"""Plan routes that stay safe as flown: rehearse the planned mission (:mod:`uavplan.rehearsal`)
and, while the track the flight model predicts breaks the margin, plan (or reroute) again with
the margin grown by what it lacked.

Why a wider planning margin, and not per-item acceptance radii or stops at the corners: see
:mod:`uavplan.rehearsal` and docs/flying.md ("Plans that stay safe as flown"). This is the one
part of the rehearsal that plans, so it lives apart: ``fly``, ``simulate`` and ``validate``
rehearse without importing the planners.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Generic, TypeVar

from uavplan.errors import InputError, NoPathError, ScenarioError
from uavplan.flavour import Autopilot
from uavplan.flightcheck import FlightPrediction, TrackCheck
from uavplan.mission.items import MissionPlan
from uavplan.planners.base import ProgressFn
from uavplan.planning import RouteResult, mission_for, plan_route
from uavplan.rehearsal import CheckSite, Rehearsal, conditions_of, rehearse
from uavplan.reroute import RerouteResult, reroute_plan
from uavplan.scenario import PlannerConfig, Scenario, Surroundings
from uavplan.world import World
from uavplan.worlds import padded_world

__all__ = [
    "MAX_REPLANS",
    "Flown",
    "Widened",
    "corner_pad_m",
    "grown_pad",
    "padded_scenario",
    "plan_padded",
    "plan_safe_as_flown",
    "refresh_flight",
    "reroute_safe_as_flown",
    "widened_until_flown_safe",
]

#: how often ``plan`` plans again with a wider margin before it gives up
MAX_REPLANS = 4
#: added to what the track lacked, each time the margin grows (m)
PAD_STEP_M = 0.1
#: what the margin grows by when the track leaves the flight volume (m)
VOLUME_PAD_M = 1.0


_R = TypeVar("_R", RouteResult, RerouteResult)


@dataclass(frozen=True)
class Flown(Generic[_R]):
    """A route (planned, or a rerouted plan) and what the flight model predicts for its
    mission: ``flight``, the mission flown as its autopilot flies it (None for an autopilot
    the model does not fly, a route that was not had, or an interrupted one). The planning
    layer's result knows nothing of the flight; this record is what the use cases carry."""

    result: _R
    flight: FlightPrediction | None = None


def corner_pad_m(autopilot: Autopilot) -> float:
    """How much wider than the margin ``plan`` searches first for ``autopilot``'s missions: the
    firmware's default waypoint radius (ArduPilot's WPNAV_RADIUS, PX4's NAV_ACC_RAD, 2 m
    each), which bounds how far the flight model cuts a corner inside it. 0 for an autopilot
    the flight model does not fly.

    Known before the search, it spares the second search that a route planned at the bare
    margin needs whenever a corner's cut brings the track inside it (issue 36: on the bundled
    scenarios, 10 of 11 plans then need one search instead of two, for 0 to 3.5 % more
    energy). :func:`plan_safe_as_flown` widens on from it where a corner still cuts deeper."""
    if autopilot not in (Autopilot.PX4, Autopilot.ARDUPILOT):
        return 0.0
    from uavplan.autopilot.params import Parameters, guidance_limits

    return guidance_limits(Parameters.defaults(autopilot)).acceptance_radius_m


def plan_padded(
    scenario: Scenario,
    pad_m: float,
    world: World,
    *,
    progress: ProgressFn | None = None,
    should_stop: Callable[[], bool] | None = None,
) -> RouteResult | str:
    """``scenario``'s route planned ``pad_m`` wider than its margin (:func:`padded_scenario`)
    in its ``world`` (the scenario's, at the bare margin: padded here), given back at the
    scenario's own margin; an interrupted result as it came; a string saying why when no
    route keeps the wider margin (a narrow gap, a low ceiling: the bare margin may still)."""
    try:
        padded = padded_scenario(scenario, pad_m)
    except ScenarioError as err:
        return f"a margin {pad_m:.2f} m wider cannot be planned: {err.reason}"
    again = plan_route(
        padded, world=padded_world(world, padded), progress=progress, should_stop=should_stop
    )
    if again.interrupted:
        return again
    if again.route is None or not again.collision_free:
        return f"no route keeps a margin {pad_m:.2f} m wider"
    route = replace(again.route, safety_margin_m=scenario.safety_margin_m)
    return replace(again, route=route)


def plan_safe_as_flown(
    scenario: Scenario,
    result: RouteResult,
    *,
    site: CheckSite | None = None,
    pad_m: float = 0.0,
    should_stop: Callable[[], bool] | None = None,
) -> Flown[RouteResult]:
    """``result`` (a planned route of ``scenario``) with its predicted flight
    (:attr:`Flown.flight`): the mission flown as the scenario's autopilot flies it. When that
    track comes closer than the margin, the route is planned again with the margin grown by
    what it lacked (plus :data:`PAD_STEP_M`), up to :data:`MAX_REPLANS` times; the result's
    notes say so. A result whose track still breaks the margin has ``flight.keeps_margin``
    false (``plan`` then exits 3). An interrupted replanning returns the interrupted result.
    ``site``: the scenario's check site when the caller built it (``plan`` builds it once);
    ``pad_m``: how much wider than the margin ``result`` was planned (:func:`plan_padded`).
    """
    autopilot = scenario.mission.autopilot
    if result.route is None or autopilot not in (Autopilot.PX4, Autopilot.ARDUPILOT):
        return Flown(result)
    site = site or CheckSite.of_scenario(scenario)
    flying = conditions_of(scenario)
    runtime_s = result.runtime_s

    def fly(planned: RouteResult) -> Rehearsal:
        assert planned.route is not None
        return rehearse(mission_for(scenario, planned.route), site, **flying)

    def plan_again(pad: float) -> RouteResult | str:
        nonlocal runtime_s
        again = plan_padded(scenario, pad, site.world, should_stop=should_stop)
        if isinstance(again, str) or again.interrupted:
            return again
        runtime_s += again.runtime_s
        return replace(again, runtime_s=runtime_s)

    return _widened_until_flown_safe(result, fly, plan_again, autopilot, "planned", pad_m)


def refresh_flight(
    scenario: Scenario, flown: Flown[RouteResult], site: CheckSite | None = None
) -> Flown[RouteResult]:
    """``flown`` with its predicted flight flown again (its route changed after
    :func:`plan_safe_as_flown`: a planned return added by the way home), keeping how much
    wider the margin was planned. A route without a prediction is returned as it is."""
    before, route = flown.flight, flown.result.route
    if before is None or route is None:
        return flown
    site = site or CheckSite.of_scenario(scenario)
    rehearsal = rehearse(mission_for(scenario, route), site, **conditions_of(scenario))
    flight = rehearsal.prediction(margin_pad_m=before.margin_pad_m, gave_up=before.gave_up)
    return Flown(flown.result, flight)


def reroute_safe_as_flown(
    source: MissionPlan,
    result: RerouteResult,
    *,
    base: Scenario | Surroundings | None,
    planner: PlannerConfig,
    name: str,
    file: str | None,
    should_stop: Callable[[], bool] | None = None,
) -> Flown[RerouteResult]:
    """:func:`plan_safe_as_flown` for a rerouted QGroundControl plan: ``result`` (the
    reroute of ``source``) with its predicted flight, rerouted again with a wider margin
    (up to :data:`MAX_REPLANS` times) while the track breaks the margin of its airspace."""
    autopilot = result.plan.autopilot
    site = CheckSite.of_plan(result.plan, base=base, file=file)
    if site is None or autopilot not in (Autopilot.PX4, Autopilot.ARDUPILOT):
        return Flown(result)

    def fly(rerouted: RerouteResult) -> Rehearsal:
        return rehearse(rerouted.plan, site)

    def reroute_again(pad: float) -> RerouteResult | str:
        try:
            return reroute_plan(source, base=base, planner=planner, name=name, file=file,
                                should_stop=should_stop, margin_pad_m=pad)  # fmt: skip
        except (InputError, NoPathError) as err:
            return f"no reroute keeps a margin {pad:.2f} m wider: {err}"

    return _widened_until_flown_safe(result, fly, reroute_again, autopilot, "rerouted")


_T = TypeVar("_T")


@dataclass(frozen=True)
class Widened(Generic[_T]):
    """How :func:`widened_until_flown_safe` ended.

    ``value``: the last attempt (the first one when it kept the margin); ``pad_m``: how much
    wider than the margin it was made; ``notes``: one line per widening, why and by how much;
    ``gave_up``: why the margin could not be widened further while the flight still breaks
    it ("" when it keeps the margin, or the attempt was stopped); ``stopped``: the last
    attempt was interrupted (Ctrl-C), and ``value`` is that attempt as it came back."""

    value: _T
    pad_m: float
    notes: tuple[str, ...] = ()
    gave_up: str = ""
    stopped: bool = False


def widened_until_flown_safe(
    first: _T,
    check_of: Callable[[_T], TrackCheck | None],
    again_with: Callable[[float], _T | str],
    *,
    stopped: Callable[[_T], bool],
    noted: Callable[[str, float], str],
    exhausted: Callable[[float], str],
    pad_m: float = 0.0,
) -> Widened[_T]:
    """The one widen-until-safe loop (routes, reroutes, the planned return, surveys): while
    the flight of ``first`` (``check_of``: its check as flown; ``None`` or ok: it keeps the
    margin) breaks the margin, make it again with the planning margin grown by what it lacked
    (:func:`grown_pad`): ``again_with(pad)``, a string when no wider margin can be had (why),
    up to :data:`MAX_REPLANS` times. ``first`` was made ``pad_m`` wider than the margin.
    ``noted(why, pad)``: the note of one widening; ``exhausted(pad)``: why the loop stops
    after the last one."""
    value, pad = first, pad_m
    notes: list[str] = []
    for attempt in range(MAX_REPLANS + 1):
        check = check_of(value)
        if check is None or check.ok:
            return Widened(value, pad, tuple(notes))
        if attempt == MAX_REPLANS:
            return Widened(value, pad, tuple(notes), gave_up=exhausted(pad))
        grown = grown_pad(pad, check)
        again = again_with(grown)
        if isinstance(again, str):
            return Widened(value, pad, tuple(notes), gave_up=again)
        if stopped(again):
            return Widened(again, pad, tuple(notes), stopped=True)
        notes.append(noted(check.problem() or "the margin is broken", grown))
        value, pad = again, grown
    raise AssertionError("unreachable: the loop returns on its last attempt")


def _widened_until_flown_safe(
    result: _R,
    fly: Callable[[_R], Rehearsal],
    again_with: Callable[[float], _R | str],
    autopilot: Autopilot,
    verb: str,
    pad_m: float = 0.0,
) -> Flown[_R]:
    """:func:`widened_until_flown_safe` for :func:`plan_safe_as_flown` and
    :func:`reroute_safe_as_flown`: ``result`` flown, planned (rerouted) again while its flight
    breaks the margin. Returns the last result with its predicted flight and the notes saying
    what was done; an interrupted result as it is (without a flight)."""

    # each attempt is a result and its flight (None: it was interrupted)
    def again(pad: float) -> tuple[_R, Rehearsal | None] | str:
        made = again_with(pad)
        if isinstance(made, str):
            return made
        return (made, None) if made.interrupted else (made, fly(made))

    def check_of(flown: tuple[_R, Rehearsal | None]) -> TrackCheck | None:
        assert flown[1] is not None
        return flown[1].check

    first: tuple[_R, Rehearsal | None] = (result, fly(result))
    ended: Widened[tuple[_R, Rehearsal | None]] = widened_until_flown_safe(
        first,
        check_of,
        again,
        stopped=lambda flown: flown[1] is None,
        noted=lambda why, pad: (
            f"{autopilot.label} flight model: {why}; {verb} again with the margin {pad:.2f} m wider"
        ),
        exhausted=lambda pad: (
            f"{verb} {MAX_REPLANS} more times, the margin up to {pad:.2f} m wider"
        ),
        pad_m=pad_m,
    )
    last: _R = ended.value[0]
    rehearsal = ended.value[1]
    if ended.stopped or rehearsal is None:
        return Flown(last)
    # the return to launch at the mission's end is judged with the whole flight, at the RTL
    # altitude the mission relies on (uavplan.verdict), not here
    flight = rehearsal.prediction(margin_pad_m=ended.pad_m, gave_up=ended.gave_up)
    return Flown(replace(last, notes=(*last.notes, *ended.notes)), flight)


def padded_scenario(scenario: Scenario, pad_m: float) -> Scenario:
    """``scenario`` planned ``pad_m`` more carefully: its margin grown by ``pad_m`` and its
    ceiling lowered by as much (over terrain the ceiling's solids stand the margin above it,
    so a wider margin alone would not keep the route further from the ceiling). Raises
    :class:`ScenarioError` when the route points no longer fit."""
    b = scenario.bounds
    lowered = replace(b, z_m=(b.z_m[0], b.z_m[1] - pad_m))
    return replace(scenario, safety_margin_m=scenario.safety_margin_m + pad_m, bounds=lowered)


def grown_pad(pad: float, check: TrackCheck) -> float:
    """The next planning pad: the last one plus what the track lacked, plus
    :data:`PAD_STEP_M` (:data:`VOLUME_PAD_M` when the track left the flight volume)."""
    lack = VOLUME_PAD_M if check.outside is not None else check.required_m - check.min_clearance_m
    return pad + max(lack, 0.0) + PAD_STEP_M
