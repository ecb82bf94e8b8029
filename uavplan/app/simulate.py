"""``simulate``: rehearse a mission file without a link.

The mission flies through the flight model (the model the simulated vehicle flies) in
simulated time, with the parameters the vehicle would hold: the firmware's defaults, the
plan's parameters, and ``--param`` values over them. The outcome gives the flight time, the
largest deviation from the planned legs and, where a scenario (or the plan's own geofence)
says what is in the way, the whole flight's verdict (:func:`uavplan.verdict.judge_flight`:
take-off to touchdown, the return to launch included, and a failsafe return from every
point). A flight that comes closer than the margin or leaves the flight volume is exit 3; a
failsafe return that would is a warning.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from uavplan.app.feedback import Feedback
from uavplan.app.inputs import mission_kind
from uavplan.app.outputs import check_output
from uavplan.autopilot.params import ParameterValueError, parameters_from
from uavplan.autopilot.simulate import FlightEnd
from uavplan.errors import InputError, NoPathError, ScenarioError
from uavplan.fileio import InputFile
from uavplan.flavour import Autopilot
from uavplan.flightcheck import TrackCheck
from uavplan.mission.io import load_mission
from uavplan.mission.items import MissionPlan
from uavplan.mission.track import check_track_path
from uavplan.rehearsal import CheckSite, Rehearsal, conditions_of, rehearse
from uavplan.scenario import Scenario, load_site, load_surroundings
from uavplan.verdict import FlightVerdict, held_parameters, judge_flight


@dataclass(frozen=True)
class SimulateRequest:
    """``uavplan simulate MISSION``: fly it as ``autopilot`` (default: the file's) with these
    parameter changes and wind (default: the scenario's, else none); check it against
    ``scenario`` (default: the plan's own geofence, if it has exclusion zones); write the
    track to ``track``."""

    mission: str
    scenario: str | None = None
    autopilot: str | None = None
    track: str | None = None
    wind_en_m_s: tuple[float, float] | None = None
    params: Mapping[str, float] = field(default_factory=dict)
    #: ``--view``: the interactive page of the flight (HTML, needs ``scenario``)
    view: str | None = None


@dataclass(frozen=True, eq=False)
class SimulateOutcome:
    """A rehearsed mission file; ``checked_in`` says against what (None: nothing)."""

    file: str
    plan: MissionPlan
    rehearsal: Rehearsal
    checked_in: str | None = None
    track: str | None = None
    #: the whole flight judged (None: nothing to check it against)
    verdict: FlightVerdict | None = None

    @property
    def check(self) -> TrackCheck | None:
        return None if self.verdict is None else self.verdict.check

    def summary(self) -> str:
        r = self.rehearsal
        minutes, seconds = divmod(round(r.flight_time_s), 60)
        ended = {
            FlightEnd.LANDED: "to touchdown",
            FlightEnd.MISSION_COMPLETE: "to the end of the mission (in the air)",
            FlightEnd.NO_HEADWAY: "until the wind stopped it",
            FlightEnd.TIMEOUT: "until the simulation gave up",
        }[r.flown.ended]
        text = (
            f"{Path(self.file).name}: flown as {r.autopilot.label} in {minutes} min "
            f"{seconds:02d} s ({r.flight_time_s:.1f} s, take-off {ended}), largest deviation "
            f"from the planned legs {r.max_deviation_m:.2f} m"
        )
        check = self.check
        if check is not None:
            text += (
                f", min clearance {check.min_clearance_m:.2f} m from {check.nearest} "
                f"(margin {check.margin_m:g} m, {self.checked_in})"
            )
        return text


def simulate_file(request: SimulateRequest, feedback: Feedback) -> SimulateOutcome:
    """Rehearse ``request.mission``; write the track; raise NoPathError (exit 3) when the
    mission's part of the track comes closer than the margin or leaves the flight volume."""
    if request.track:
        check_track_path(request.track)
        check_output(request.track, InputFile(request.mission, "the mission to fly"))
    if request.view:
        _check_view(request)
    plan = load_mission(request.mission)
    if plan.home is None:
        raise InputError(
            "the mission has no planned home (plannedHomePosition): the vehicle must stand "
            "somewhere to fly it",
            file=request.mission,
        )
    autopilot = plan.autopilot
    if request.autopilot:
        autopilot = Autopilot.from_name(request.autopilot)
    if autopilot not in (Autopilot.PX4, Autopilot.ARDUPILOT):
        raise InputError("the file names no autopilot: give --autopilot px4 or ardupilot")
    try:  # the one reading of --param, as mock-vehicle's (names and ranges checked)
        parameters_from(autopilot, request.params)
        held, _, _ = held_parameters(plan, autopilot, request.params)
    except ParameterValueError as err:
        raise InputError(str(err), key="--param") from None
    except ValueError as err:  # a parameter of the plan out of the firmware's range
        raise InputError(str(err), key="--param") from None
    site: CheckSite | None = None
    scenario: Scenario | None = None
    conditions: dict[str, object] = {}
    if request.scenario is not None:
        try:
            scenario = load_site(request.scenario)
        except ScenarioError as err:
            if mission_kind(request.mission) != "plan" or err.key not in ("start", "goal"):
                raise
            # a map or a scenario without a route (as `plan X.plan --scenario S` takes one):
            # the plan in its rerouting's world, its fence and the scenario's obstacles
            base = load_surroundings(request.scenario)
            for out in (request.track, request.view):
                if out:
                    check_output(out, *base.files)
            site = CheckSite.of_plan(plan, base=base, file=request.mission)
        else:
            if request.track:  # nor any file of the scenario
                check_output(request.track, *scenario.files)
            if request.view:
                check_output(request.view, *scenario.files)
            site = CheckSite.of_scenario(scenario)
            conditions = conditions_of(scenario)
    else:
        site = CheckSite.of_plan(plan, file=request.mission)
    if request.wind_en_m_s is not None:
        conditions["wind_en_m_s"] = request.wind_en_m_s
    if site is not None:
        feedback.say(f"checking the track against {site.label} (margin {site.margin_m:g} m)")
    verdict = None
    if site is not None:
        verdict = judge_flight(plan, site, autopilot=autopilot, params=request.params, **conditions)  # type: ignore[arg-type]
        assert verdict.rehearsal is not None
        rehearsal = verdict.rehearsal
    else:
        rehearsal = rehearse(plan, None, autopilot=autopilot, params=held, **conditions)  # type: ignore[arg-type]
    from uavplan.autopilot.camera import has_camera_items, photo_positions

    if has_camera_items(rehearsal.flown):  # a survey: its camera items executed as flown
        feedback.say(f"photos: {len(photo_positions(rehearsal.flown))} taken as flown")
    if request.track:
        rehearsal.track.save(request.track)
        feedback.say(f"track: {len(rehearsal.track)} samples written to {request.track}")
    outcome = SimulateOutcome(
        request.mission,
        plan,
        rehearsal,
        None if site is None else site.label,
        request.track,
        verdict,
    )
    if request.view and scenario is not None:  # written before a verdict of exit 3: it shows where
        _write_view(request.view, scenario, plan, rehearsal, request.mission)
        feedback.say(f"view: {request.view}")
    if verdict is None:
        if not rehearsal.flown.ended.finished:
            feedback.warn(f"warning: the flight did not finish ({rehearsal.flown.ended})")
        return outcome
    feedback.say(verdict.summary())
    for line in verdict.warnings():
        feedback.warn(line)
    problem = verdict.problem()
    if problem is not None:
        raise NoPathError(f"{request.mission}: {problem}")
    return outcome


def _check_view(request: SimulateRequest) -> None:
    """``--view``: a page name, a scenario to show it in, the drawing library; before any
    flying."""
    from uavplan.app.view import check_page_path
    from uavplan.view.page import plotly_script

    assert request.view is not None
    check_page_path(request.view)
    if request.scenario is None:
        raise InputError("--view shows the flight in a scenario: give --scenario S")
    check_output(request.view, InputFile(request.mission, "the mission to fly"))
    if request.track:
        check_output(request.view, request.track)  # two outputs that are one file
    plotly_script()


def _write_view(
    path: str, scenario: Scenario, plan: MissionPlan, rehearsal: Rehearsal, source: str
) -> None:
    """The page of this rehearsal (uavplan.app.view), written atomically."""
    from uavplan.app.view import mission_page
    from uavplan.fileio import atomic_write_text
    from uavplan.view.build import FIRMWARE, flown_of_rehearsal

    name = FIRMWARE.get(rehearsal.autopilot, rehearsal.autopilot.label)
    label = f"flight model: {name} as simulated"
    flown = flown_of_rehearsal(rehearsal, label)
    atomic_write_text(path, mission_page(scenario, plan, source=source, flown=flown))
