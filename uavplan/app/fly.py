"""``fly``: fly a mission file on a vehicle, from the pre-flight checks to the landing.

Before the flight (nothing moves until each passes): with ``--scenario``, the mission against
the scenario exactly as ``validate`` checks it (a mission from elsewhere is exit 2, one that
breaks the margin exit 3); the vehicle's heartbeat and autopilot; whether it can arm
(SYS_STATUS's pre-arm check and MAV_CMD_RUN_PREARM_CHECKS, whose STATUSTEXT is quoted); its
home against the plan's planned home (:data:`HOME_TOLERANCE_M`); its onboard mission against
the file (downloaded and compared item by item), uploaded and verified when it differs or with
``--upload``. A Ctrl-C during the upload cancels it as the protocol says and then says what
the vehicle holds (:func:`_upload_interrupted`). The flight model's prediction for the
vehicle's flavour is the reference the flight is compared with.

Then it starts the mission the way the firmware expects
(:func:`uavplan.mavlink.flightmachines.start_steps`) and follows it
(:class:`~uavplan.mavlink.flightmachines.MonitorMachine`), with the live watch
(:class:`~uavplan.app.watch.Watch`): the telemetry in the vehicle's own time order, a progress
line, the vehicle's warnings as they come, every change behind its back as it is noticed, the
cross-track error from the planned legs and, with a scenario, the clearance of every stretch
flown.

Endings: the mission complete and the vehicle down (or the last item done, for a mission
that does not land), the whole flight observed and (with a scenario) the whole observed track
keeping the margin is the one success (exit 0); a track closer than the margin is exit 3; a
lost link, a refusal, a landing before the end, a restart, another ground station's takeover,
no progress for ``stall_s``, a stretch of the flight not observed is exit 4 saying what the
vehicle last did or said, on state asked for after the last gap. Ctrl-C puts the vehicle into
``on_interrupt`` mode and confirms it (outcome ``interrupted``). The flown track is written
(atomically) whatever the ending.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from uavplan.app.feedback import Feedback
from uavplan.app.outputs import check_output
from uavplan.app.watch import Watch, airborne_time, owner_name, predicted_airborne
from uavplan.autopilot.simulate import refusal_of
from uavplan.errors import InputError, LinkError, NoPathError
from uavplan.fileio import InputFile
from uavplan.flavour import Autopilot
from uavplan.flightcheck import Flight, TrackCheck, flight_clearance, flight_of_track
from uavplan.geo import EnuFrame
from uavplan.mavlink.flightclient import FlightClient
from uavplan.mavlink.flightmachines import (
    GAP_S,
    CommandOutcome,
    FlightTimeouts,
    MonitorEnd,
    NoticeKind,
    VehicleState,
    WatchRules,
    disarm_step,
    flight_clock,
)
from uavplan.mavlink.link import VehicleLink
from uavplan.mavlink.machines import TransferStatus
from uavplan.mavlink.messages import LandedState, MissionState
from uavplan.mavlink.modes import ModeKind
from uavplan.mavlink.protocol import MissionClient, ProtocolTimeouts
from uavplan.mavlink.transfer import compare_items, plan_wire_items, upload_plan
from uavplan.mission.io import load_mission
from uavplan.mission.items import MavCmd, MissionItem, MissionPlan, MissionType
from uavplan.mission.track import Track, check_track_path, observed_stretches
from uavplan.rehearsal import CheckSite, Rehearsal, rehearse, return_seq
from uavplan.scenario import Scenario, load_site

#: how far the vehicle's home may be from the plan's planned home before ``fly`` refuses
#: (horizontal m, vertical m): about a GPS's horizontal error and a few metres of height, so
#: the take-off stands where the route was planned to begin and the relative altitudes mean
#: what they were planned to mean (docs/flying.md)
HOME_TOLERANCE_M = (10.0, 3.0)
#: ``--on-interrupt`` → the mode a Ctrl-C asks for
ON_INTERRUPT = {"hold": ModeKind.HOLD, "rtl": ModeKind.RETURN, "land": ModeKind.LAND}
#: how long, after a Ctrl-C during the upload, ``fly`` waits to learn what the vehicle holds
#: (wall s): ArduPilot ignores the cancel and leaves the transfer 8 s after the last item
#: (libraries/GCS_MAVLink/MissionItemProtocol.h, upload_timeout_ms; MissionItemProtocol::update),
#: PX4 leaves it at once (src/modules/mavlink/mavlink_mission.cpp,
#: MavlinkMissionManager::handle_mission_ack)
UPLOAD_SETTLE_S = 10.0
#: how long the verdict waits for the state asked for after the flight (wall s)
REFRESH_S = 2.0


class VehicleRefused(LinkError):
    """The vehicle said no (a pre-arm check, a mode, an arming, a home, a mission): exit 4,
    the message quoting what it said."""


class FlightUnsafe(NoPathError):
    """The flown track came closer than the margin (or left the flight volume): exit 3."""


@dataclass(frozen=True)
class FlyRequest:
    """``uavplan fly MISSION --conn CONN``."""

    mission: str
    conn: str
    scenario: str | None = None
    track: str | None = None
    upload: bool = False
    max_deviation_m: float = 10.0
    on_interrupt: str = "hold"
    home_tolerance_m: tuple[float, float] = HOME_TOLERANCE_M
    #: ``--set-params``: set the parameters the mission relies on (read back) before it flies
    set_params: bool = False
    #: ``--accept-vehicle-params``: fly with the vehicle's values once the flight, proven
    #: again with them in ``scenario``, keeps the margin
    accept_vehicle_params: bool = False
    target_system: int | None = None
    heartbeat_timeout_s: float = 5.0
    link_timeout_s: float = 5.0
    #: no progress for this long (vehicle seconds) ends the watch (docs/flying.md)
    stall_s: float = 60.0
    #: a mode ``fly`` did not command may last this long (vehicle seconds)
    takeover_wait_s: float = 30.0
    timeouts: ProtocolTimeouts = field(default_factory=ProtocolTimeouts)


@dataclass(frozen=True, eq=False)
class ObservedCheck:
    """The whole observed flight measured by the one check, stretch by stretch: ``checks``
    one :class:`~uavplan.flightcheck.TrackCheck` per stretch of two samples or more (no line is
    drawn across a gap: :data:`~uavplan.mavlink.flightmachines.GAP_S`), ``unobserved`` the
    gaps between the stretches, (from, to) in the track's seconds."""

    checks: tuple[TrackCheck, ...]
    unobserved: tuple[tuple[float, float], ...]
    margin_m: float
    site: CheckSite | None = None

    @property
    def worst(self) -> TrackCheck | None:
        if not self.checks:
            return None
        outside = [c for c in self.checks if c.outside is not None]
        if outside:
            return outside[0]
        return min(self.checks, key=lambda c: c.min_clearance_m)

    @property
    def min_clearance_m(self) -> float:
        worst = self.worst
        return math.inf if worst is None else worst.min_clearance_m

    @property
    def nearest(self) -> str:
        worst = self.worst
        return "nothing" if worst is None else worst.nearest

    @property
    def ok(self) -> bool:
        return all(c.ok for c in self.checks)

    @property
    def unobserved_s(self) -> float:
        return float(sum(b - a for a, b in self.unobserved))

    def problem(self) -> str | None:
        worst = self.worst
        if worst is None or worst.ok:
            return None
        if worst.outside is not None or self.site is None:
            return worst.problem()
        # the check measured the line thinned to within THIN_TOL_M: say when the vehicle was
        # nearest on the samples of its worst segment, not when that segment began
        sample, what = _nearest_sample(worst, self.site)
        return (
            f"{worst.when(sample)} the track comes within {worst.min_clearance_m:.2f} m of "
            f"{what} (safety margin {worst.margin_m:g} m)"
        )


def _nearest_sample(check: TrackCheck, site: CheckSite) -> tuple[int, str]:
    """The track sample after the stretch between two samples that comes nearest to what
    ``check``'s worst segment (of its thinned line) comes closest to, and what that is."""
    segment = check.check.worst
    first, last = int(check.samples[segment]), int(check.samples[segment + 1])
    if last - first < 2:
        return last, check.nearest
    part = check.track.between(first, last + 1)
    points = flight_of_track(part, site.frame, datum_amsl_m=site.datum_amsl_m, lands=False)
    dist, owner, _ = flight_clearance(site.world, Flight(points.points_enu, (0, last - first)))
    k = int(np.argmin(dist))
    return first + k + 1, owner_name(int(owner[k]), site)


def check_observed_flight(track: Track, site: CheckSite, *, lands: bool) -> ObservedCheck:
    """``track`` from its first sample to its last (take-off, route, return and landing
    alike) measured by the one check (:meth:`CheckSite.check`), each observed stretch on its
    own: the first from the ground (its take-off), the last to the ground when the flight
    ended there (``lands``), those between wholly in the air. This is the one call to rewire
    when the whole-flight verdict moves (issue 37)."""
    stretches = observed_stretches(track.time_s, GAP_S)
    checks: list[TrackCheck] = []
    last = len(stretches) - 1
    for i, (start, stop) in enumerate(stretches):
        if stop - start < 2:
            continue
        part = track.between(start, stop)
        checks.append(site.check(part, takes_off=i == 0, lands=lands and i == last))
    return ObservedCheck(tuple(checks), tuple(track.gaps(GAP_S)), site.margin_m, site)


@dataclass(frozen=True, eq=False)
class FlyOutcome:
    """A flight that ended on the ground (or done in the air) with the whole flight
    observed and kept clear, or an interrupted one."""

    file: str
    vehicle: str
    autopilot: Autopilot
    end: MonitorEnd  # INTERRUPTED: a Ctrl-C (during the upload or the flight)
    track: Track
    uploaded: bool
    airborne_s: float | None
    predicted_airborne_s: float | None
    max_cross_track_m: float
    check: ObservedCheck | None = None
    interrupt_mode: str | None = None
    #: what an interrupted upload left on the vehicle, in words (None: not interrupted there)
    holds: str | None = None

    @property
    def interrupted(self) -> bool:
        return self.end is MonitorEnd.INTERRUPTED

    # the outcome protocol (uavplan.outcome.Ended): a FlyOutcome is a flight that ended as
    # the mission asks, or an interrupted one; every other end is an error fly raises
    @property
    def ok(self) -> bool:
        return not self.interrupted

    @property
    def reason(self) -> MonitorEnd | None:
        return self.end if self.interrupted else None

    @property
    def message(self) -> str:
        return self.summary()

    @property
    def step(self) -> str:
        if not self.interrupted:
            return ""
        return "upload" if self.holds is not None else "flight"

    def summary(self) -> str:
        name = Path(self.file).name
        if self.holds is not None:
            return f"{name}: interrupted during the upload; {self.vehicle} {self.holds}"
        if self.interrupted:
            return (
                f"{name}: interrupted; {self.vehicle} is in {self.interrupt_mode} "
                f"after {len(self.track)} samples"
            )
        text = f"{name}: mission complete on {self.vehicle}"
        if self.end is MonitorEnd.COMPLETE_IN_AIR:
            text += " (in the air: the mission does not land)"
        if self.airborne_s is not None:
            text += f", {flight_clock(self.airborne_s)} take-off to touchdown"
            if self.predicted_airborne_s:
                diff = 100.0 * (self.airborne_s / self.predicted_airborne_s - 1.0)
                text += f" (flight model {flight_clock(self.predicted_airborne_s)}, {diff:+.1f} %)"
        text += f", largest cross-track error {self.max_cross_track_m:.2f} m"
        if self.check is not None:
            text += (
                f", min clearance {self.check.min_clearance_m:.2f} m from {self.check.nearest} "
                f"(margin {self.check.margin_m:g} m, the whole flight observed)"
            )
        return text


# ---------------------------------------------------------------------------------------------


def fly(request: FlyRequest, feedback: Feedback) -> FlyOutcome:
    """Fly ``request.mission`` on the vehicle at ``request.conn`` (see the module doc)."""
    kind = ON_INTERRUPT.get(request.on_interrupt)
    if kind is None:
        raise InputError(f"--on-interrupt is hold, rtl or land, not {request.on_interrupt!r}")
    if request.track:
        check_track_path(request.track)
        check_output(request.track, InputFile(request.mission, "the mission to fly"))
    plan = load_mission(request.mission)
    if plan.home is None:
        raise InputError(
            "the mission has no planned home (plannedHomePosition): fly compares it with the "
            "vehicle's home before the flight",
            file=request.mission,
        )
    site = None
    if request.scenario is not None:
        scenario = load_site(request.scenario)
        if request.track:  # nor any file of the scenario
            check_output(request.track, *scenario.files)
        check_scenario_matches(request.mission, plan, request.scenario, scenario)
        site = CheckSite.of_scenario(scenario)
    link = VehicleLink.connect(
        request.conn,
        target_system=request.target_system,
        heartbeat_timeout_s=request.heartbeat_timeout_s,
    )
    with link:
        return _fly_on(link, plan, site, kind, request, feedback)


def check_scenario_matches(file: str, plan: MissionPlan, path: str, scenario: Scenario) -> None:
    """The mission against ``--scenario`` before anything is sent, as ``validate MISSION
    --scenario S`` checks it: a mission whose home is not in the scenario's area is another
    place's (exit 2); then :func:`uavplan.app.check.validate` itself (a mission that breaks
    the margin or leaves the flight volume is exit 3, one over the battery budget exit 2)."""
    from uavplan.app.check import validate

    assert plan.home is not None
    site = CheckSite.of_scenario(scenario)
    ((x, y),) = site.frame.to_enu_xy([plan.home.lat_deg], [plan.home.lon_deg])
    (x0, x1), (y0, y1) = scenario.bounds.x_m, scenario.bounds.y_m
    away = math.hypot(max(x0 - x, 0.0, x - x1), max(y0 - y, 0.0, y - y1))
    if away > HOME_TOLERANCE_M[0]:
        distance = f"{away / 1000.0:.1f} km" if away >= 1000.0 else f"{away:.0f} m"
        raise InputError(
            f"the mission's home ({plan.home.lat_deg:.6f}, {plan.home.lon_deg:.6f}) is "
            f"{distance} outside scenario {scenario.name}'s area: this mission was not planned "
            "for it (give the scenario it was planned in, as validate does)",
            file=file,
        )
    validate(file, path)


def _fly_on(
    link: VehicleLink,
    plan: MissionPlan,
    site: CheckSite | None,
    kind: ModeKind,
    request: FlyRequest,
    feedback: Feedback,
) -> FlyOutcome:
    vehicle = link.vehicle
    autopilot = vehicle.autopilot
    who = f"system {vehicle.system_id} ({autopilot.label}) on {link.connection.description}"
    if autopilot not in (Autopilot.PX4, Autopilot.ARDUPILOT):
        raise LinkError(
            f"{who}: fly starts PX4 and ArduPilot vehicles; this one's HEARTBEAT names "
            f"autopilot {vehicle.mav_autopilot}",
            step="connect",
        )
    feedback.say(f"connected to {who}")
    timeouts = FlightTimeouts(link_s=request.link_timeout_s)
    client = FlightClient(link, timeouts)

    # -- before the flight ------------------------------------------------------------------
    pre = client.preflight()
    if pre.armed or pre.landed_state in (LandedState.IN_AIR, LandedState.LANDING):
        mode = "an unknown mode" if pre.mode is None else pre.mode.name
        raise VehicleRefused(
            f"{who} is already armed (in {mode}): fly starts a mission from the ground",
            step="pre-flight",
        )
    if pre.prearm_ready is False:
        said = "; ".join(f'"{t}"' for t in pre.texts) or "no reason given"
        raise VehicleRefused(
            f"the vehicle cannot arm (SYS_STATUS: pre-arm checks fail): it said {said}",
            step="pre-flight: pre-arm checks",
        )
    if pre.home is None:
        raise VehicleRefused(
            "the vehicle reports no home (no HOME_POSITION): it has no position to take off from",
            step="pre-flight: home",
        )
    _check_home(plan, pre.home, request.home_tolerance_m)
    feedback.say("pre-flight: ready to arm, home matches the plan")
    _vehicle_parameters(link, plan, request, feedback)
    try:
        uploaded = _mission_on_board(link, plan, autopilot, request, feedback)
    except _UploadInterrupted as stopped:
        return _upload_interrupted(link, plan, autopilot, request, feedback, who, stopped)

    # the reference: the flight model flying this mission as this vehicle's flavour
    reference: Rehearsal | None = None
    if refusal_of(plan, autopilot) is None:  # else the vehicle refuses it, in its words
        reference = rehearse(plan, site, autopilot=autopilot)
    if reference is not None and reference.check is not None and not reference.check.ok:
        feedback.warn(
            f"warning: the flight model predicts: {reference.check.problem()} (plan the "
            "mission again: `uavplan plan` keeps the margin as flown)"
        )

    # -- start ------------------------------------------------------------------------------
    # from here a Ctrl-C is polled (the vehicle is put into --on-interrupt's mode); a second
    # one stops at once. The track is written however this ends.
    watch = Watch(plan, autopilot, site, request, feedback, client.state)
    watch.uploaded = uploaded
    try:
        with feedback.polled():
            return _fly_started(client, plan, site, kind, request, feedback, watch, reference, who)
    finally:
        watch.tick(client.state, final=True)
        watch.save(request.track)


def _fly_started(
    client: FlightClient,
    plan: MissionPlan,
    site: CheckSite | None,
    kind: ModeKind,
    request: FlyRequest,
    feedback: Feedback,
    watch: Watch,
    reference: Rehearsal | None,
    who: str,
) -> FlyOutcome:
    autopilot = client.link.vehicle.autopilot
    should_stop = feedback.should_stop
    started = client.start_mission(should_stop=should_stop, on_tick=watch.tell)
    if started is None:  # Ctrl-C during the start
        return _interrupted(client, kind, watch, request, who)
    if not started.ok:
        watch.tick(client.state, final=True)
        if client.state.armed and client.state.on_ground:
            # armed on the ground by the refused start: leave it disarmed, as it was
            client.commands([disarm_step()])
        raise VehicleRefused(f"{who} did not start the mission: {started.message}", step="start")
    feedback.say("mission started")

    # -- the flight -------------------------------------------------------------------------
    wire = plan_wire_items(plan, MissionType.MISSION, autopilot)
    end = client.monitor(
        last_seq=len(wire) - 1,
        lands=_lands(wire),
        return_seq=return_seq(plan, autopilot),
        land_seq=_land_seq(wire),
        rules=WatchRules(takeover_wait_s=request.takeover_wait_s),
        should_stop=should_stop,
        on_tick=watch.tick,
    )
    watch.tick(client.state)
    if end is None:
        return _interrupted(client, kind, watch, request, who)
    return _verdict(client, end, kind, watch, request, reference, who)


def _verdict(
    client: FlightClient,
    end: MonitorEnd,
    kind: ModeKind,
    watch: Watch,
    request: FlyRequest,
    reference: Rehearsal | None,
    who: str,
) -> FlyOutcome:
    """The one verdict on the flight: success only when the mission completed, nothing
    changed behind ``fly``'s back, the whole flight was observed, the vehicle kept within
    ``--max-deviation`` of the planned legs and (with a scenario) the whole observed track
    kept the margin."""
    state = client.state
    action = ""
    if end is MonitorEnd.STALLED:
        action = _on_stall(client, kind, watch)
    machine = client.monitor_machine
    if end is not MonitorEnd.LINK_LOST and (watch.gaps_in_air() or watch.takeovers()):
        missing = client.refresh(REFRESH_S)  # the last word rests on fresh state
        if missing:
            action += f" (not confirmed since the last gap: {', '.join(missing)})"
    elif machine is not None and machine.unconfirmed:
        action += f" (not confirmed since the last gap: {', '.join(machine.unconfirmed)})"
    watch.tick(state, final=True)
    track = watch.save(request.track)
    landed = state.landed_state == LandedState.ON_GROUND or (
        not state.armed and end is not MonitorEnd.LINK_LOST
    )
    check = None
    if watch.site is not None and len(track) >= 2:
        check = check_observed_flight(track, watch.site, lands=landed)
    problems = _problems(end, state, watch, action)
    if check is not None and not check.ok:
        raise FlightUnsafe(_verdict_text(who, end, state, watch, check, problems, unsafe=True))
    if problems:
        raise LinkError(
            _verdict_text(who, end, state, watch, check, problems, unsafe=False), step="flight"
        )
    return FlyOutcome(
        request.mission,
        who,
        state.autopilot,
        end,
        track,
        watch.uploaded,
        airborne_time(track),
        predicted_airborne(reference),
        watch.max_cross_track_m,
        check,
    )


def _problems(end: MonitorEnd, state: VehicleState, watch: Watch, action: str) -> list[str]:
    """Why the flight is not a success, in words (empty: it is one)."""
    out: list[str] = []
    last = f"it was last {state.describe()}" + _last_words(state)
    match end:
        case MonitorEnd.COMPLETE | MonitorEnd.COMPLETE_IN_AIR:
            pass
        case MonitorEnd.LINK_LOST:
            out.append(
                f"lost the link: nothing heard for {watch.request.link_timeout_s:g} s; the "
                f"vehicle goes on without this ground station; {last}"
            )
        case MonitorEnd.LANDED_EARLY:
            out.append(f"the vehicle landed and disarmed before the mission was complete: {last}")
        case MonitorEnd.RESTARTED:
            out.append(
                "the vehicle restarted during the flight: the mission it was flying was "
                f"interrupted; after the restart {state.describe()}{_holds(state)}"
                + _last_words(state)
            )
        case MonitorEnd.MISSION_CHANGED:
            out.append(
                "the vehicle was given another mission during the flight: this one is no longer "
                f"flown and fly stops watching; {state.describe()}"
            )
        case MonitorEnd.HELD:
            mode = "a mode fly did not command" if state.mode is None else state.mode.name
            out.append(
                f"the vehicle stayed in {mode} for {watch.request.takeover_wait_s:g} s of its "
                f"time: it is no longer flying this mission and fly stops watching; "
                f"{state.describe()}"
            )
        case MonitorEnd.DISARMED_IN_AIR:
            out.append(f"the vehicle disarmed in the air: {last}")
        case MonitorEnd.INTERRUPTED:  # fly's own end, handled before a verdict: never a success
            out.append(f"the watch was interrupted: {last}")
        case MonitorEnd.STALLED:
            out.append(
                f"no progress for {watch.request.stall_s:g} s of the vehicle's time{action}; "
                f"{state.describe()}" + _last_words(state)
            )
    off = watch.farthest_off_route
    if off is not None and off[0] > watch.max_deviation_m:
        # the route was proven within the margin of the planned legs; farther off it, nothing
        # says the vehicle kept clear (without --scenario fly cannot see the obstacles)
        metres, when, seq = off
        out.append(
            f"the vehicle left the planned route: {metres:.1f} m off it at most, {when} into "
            f"the flight (item {seq}), beyond --max-deviation {watch.max_deviation_m:g} m"
        )
    changes = [n.line() for n in watch.takeovers()]
    if changes:
        out.append("changed behind fly's back: " + "; ".join(changes))
    gaps = watch.gaps_in_air()
    if gaps:
        spans = ", ".join(f"{flight_clock(a)} to {flight_clock(b)}" for a, b in gaps)
        total = sum(b - a for a, b in gaps)
        out.append(f"not observed in the air: {total:.1f} s ({spans} into the flight)")
    if end is not MonitorEnd.STALLED and action:
        out.append(action.strip())
    return out


def _verdict_text(
    who: str,
    end: MonitorEnd,
    state: VehicleState,
    watch: Watch,
    check: ObservedCheck | None,
    problems: list[str],
    *,
    unsafe: bool,
) -> str:
    head = f"{who}: "
    parts: list[str] = []
    if unsafe and check is not None:
        parts.append(f"the flown track breaks the margin: {check.problem()}")
    if end in (MonitorEnd.COMPLETE, MonitorEnd.COMPLETE_IN_AIR):
        parts.append(
            "the mission completed" + (" and the vehicle landed" if state.on_ground else "")
        )
    parts.extend(problems)
    if check is not None:
        if check.unobserved:
            seen = "where it was observed"
        elif end in (MonitorEnd.COMPLETE, MonitorEnd.COMPLETE_IN_AIR, MonitorEnd.LANDED_EARLY):
            seen = "the whole flight"
        else:
            seen = "as far as it was watched"
        if check.ok:
            parts.append(
                f"{seen}, the track kept the margin (min clearance {check.min_clearance_m:.2f} m "
                f"from {check.nearest}, margin {check.margin_m:g} m)"
            )
        elif not unsafe:
            parts.append(f"{seen}: {check.problem()}")
    return head + "; ".join(parts)


def _on_stall(client: FlightClient, kind: ModeKind, watch: Watch) -> str:
    """No progress: the vehicle is put into the ``--on-interrupt`` mode (what the operator
    asked for when ``fly`` lets go), unless it is in it already or another ground station
    took it over (``fly`` does not fight one). What was done, in words."""
    state = client.state
    if any(n.kind is NoticeKind.MODE_CHANGED for n in watch.takeovers()):
        return "; fly left it as another ground station or the vehicle set it"
    if state.mode is not None and state.mode.kind is kind:
        return f"; it is in {state.mode.name} already"
    if not state.armed:
        return ""
    changed = client.change_mode(kind)
    mode = "the new mode" if state.mode is None else state.mode.name
    if changed.ok:
        return f"; fly switched it to {mode} (--on-interrupt)"
    return f"; fly could not switch it to the --on-interrupt mode: {changed.message}"


def _holds(state: VehicleState) -> str:
    """What a restarted vehicle holds, as it said after the restart."""
    parts = []
    total = state.mission_total
    if total == 65535 or state.mission_state == MissionState.NO_MISSION:
        parts.append("it holds no mission (MISSION_CURRENT)")  # common.xml: UINT16_MAX
    elif total is not None:
        parts.append(f"its MISSION_CURRENT counts {total} mission items")
    if state.home is not None:
        lat, lon, alt = state.home
        parts.append(f"its home is {lat:.7f}, {lon:.7f}, {alt:.1f} m AMSL")
    return "; " + ", ".join(parts) if parts else ""


def _last_words(state: VehicleState) -> str:
    if not state.texts:
        return ""
    return f'; its last message: "{state.texts[-1][2]}"'


def _lands(wire: list[MissionItem]) -> bool:
    return any(item.command in (MavCmd.NAV_LAND, MavCmd.NAV_RETURN_TO_LAUNCH) for item in wire)


def _land_seq(wire: list[MissionItem]) -> int | None:
    for seq, item in enumerate(wire):
        if item.command == MavCmd.NAV_LAND:
            return seq
    return None


def _check_home(
    plan: MissionPlan, home: tuple[float, float, float], tolerance: tuple[float, float]
) -> None:
    planned = plan.home
    assert planned is not None
    lat, lon, alt = home
    xy = EnuFrame.at(planned).to_enu_xy([lat], [lon])[0]
    distance = float(math.hypot(xy[0], xy[1]))
    rise = alt - planned.alt_m
    horizontal, vertical = tolerance
    if distance > horizontal or abs(rise) > vertical:
        raise VehicleRefused(
            f"the vehicle's home (HOME_POSITION {lat:.7f}, {lon:.7f}, {alt:.1f} m AMSL) is "
            f"{distance:.1f} m from the plan's planned home ({planned.lat_deg:.7f}, "
            f"{planned.lon_deg:.7f}, {planned.alt_m:.1f} m) and {rise:+.1f} m above it; the "
            f"take-off and the relative altitudes would not be the planned ones (tolerance "
            f"{horizontal:g} m, {vertical:g} m): move the vehicle or plan from where it stands",
            step="pre-flight: home",
        )


#: what ``fly`` says to do about a parameter the vehicle holds another value of
FLY_PARAMS_ADVICE = (
    "Nothing was moved. Set them with --set-params (each read back), or fly with the "
    "vehicle's values once the flight is proven again with them: --accept-vehicle-params "
    "(with --scenario)"
)


def _vehicle_parameters(
    link: VehicleLink, plan: MissionPlan, request: FlyRequest, feedback: Feedback
) -> None:
    """The pre-flight parameter step (issue 37): the vehicle must hold every parameter the
    plan relies on before anything is uploaded or armed. Read each one; one that differs
    refuses the flight (exit 4, naming it, the vehicle's value and what the mission needs)
    unless ``--set-params`` (set, read back) or ``--accept-vehicle-params`` (the flight
    proven again with the vehicle's values must keep the margin):
    :func:`uavplan.app.vehicle_params.enforce_parameters`."""
    from uavplan.app.vehicle_params import ParamPolicy, enforce_parameters
    from uavplan.mavlink.parameters import ParamTimeouts

    policy = ParamPolicy.CHECK
    if request.set_params:
        policy = ParamPolicy.SET
    elif request.accept_vehicle_params:
        policy = ParamPolicy.ACCEPT
    check = enforce_parameters(
        link,
        plan,
        policy,
        timeouts=ParamTimeouts(),
        advice=FLY_PARAMS_ADVICE,
        step="pre-flight: parameters",
        file=request.mission,
        scenario=request.scenario,
    )
    for line in check.lines():
        if line.startswith("warning:"):
            feedback.warn(line)
        else:
            feedback.say(f"pre-flight: {line}")


# ---------------------------------------------------------------------------------------------
# The mission on board, and an upload interrupted by Ctrl-C


class _UploadInterrupted(Exception):
    """Ctrl-C while the mission was being put on board: ``before`` what the vehicle held
    (None: not read), ``sent`` how far the transfer got (label, done, total)."""

    def __init__(self, before: list[MissionItem] | None, sent: tuple[str, int, int] | None):
        super().__init__("interrupted during the upload")
        self.before = before
        self.sent = sent


def _mission_on_board(
    link: VehicleLink,
    plan: MissionPlan,
    autopilot: Autopilot,
    request: FlyRequest,
    feedback: Feedback,
) -> bool:
    """Compare the vehicle's mission with the file's; upload and verify when they differ
    (or with ``--upload``). Returns whether it uploaded; a Ctrl-C on the way (the transfer
    cancelled by :class:`MissionClient`) raises :class:`_UploadInterrupted`."""
    client = MissionClient(link, request.timeouts)
    wire = plan_wire_items(plan, MissionType.MISSION, autopilot)
    before: list[MissionItem] | None = None
    sent: list[tuple[str, int, int]] = []
    try:
        if not request.upload:
            onboard = client.download(MissionType.MISSION).raise_for_status()
            before = list(onboard.items)
            difference = compare_items(wire, before, MissionType.MISSION, autopilot)
            if difference is None:
                feedback.say(f"the vehicle holds this mission ({len(wire)} items)")
                return False
            feedback.say(f"the vehicle holds another mission ({difference}): uploading this one")
        report = upload_plan(
            client,
            plan,
            verify=True,
            progress=lambda label, done, total: sent.append((label, done, total)),
        )
    except KeyboardInterrupt:
        raise _UploadInterrupted(before, sent[-1] if sent else None) from None
    for note in report.notes:
        feedback.say(f"note: {note}")
    feedback.say(f"uploaded {len(wire)} mission items, verified by read-back")
    return True


def _upload_interrupted(
    link: VehicleLink,
    plan: MissionPlan,
    autopilot: Autopilot,
    request: FlyRequest,
    feedback: Feedback,
    who: str,
    stopped: _UploadInterrupted,
) -> FlyOutcome:
    """Ctrl-C during the upload: the transfer was cancelled (MISSION_ACK
    OPERATION_CANCELLED, as the protocol says); then what the vehicle holds is read back and
    said. PX4 leaves the transfer on the cancel and keeps its previous mission (it writes an
    upload to its inactive storage: mavlink_mission.cpp, handle_mission_ack and
    handle_mission_count). ArduPilot ignores the cancel (MissionItemProtocol.cpp handles no
    MISSION_ACK), stays in the transfer until 8 s after the last item
    (MissionItemProtocol::update, upload_timeout_ms), and keeps the items that arrived in
    place of the old ones. The wait is bounded (:data:`UPLOAD_SETTLE_S`); a second Ctrl-C
    quits at once."""
    where = ""
    if stopped.sent is not None:
        label, done, total = stopped.sent
        where = f" ({label}: {done} of {total})"
    feedback.warn(
        f"interrupted during the upload{where}: cancelled (MISSION_ACK "
        "OPERATION_CANCELLED); reading what the vehicle holds now (Ctrl-C again to quit at once)"
    )
    wire = plan_wire_items(plan, MissionType.MISSION, autopilot)
    try:
        with feedback.polled():
            holds = _what_it_holds(link, wire, stopped.before, autopilot, request)
    except KeyboardInterrupt:
        feedback.warn("interrupted again: what the vehicle holds is not known; download it to see")
        raise
    empty = Track(
        np.empty(0), np.empty(0), np.empty(0), np.empty(0), np.empty(0), np.empty(0),
        np.empty(0, dtype=np.int64), source="fly",
    )  # fmt: skip
    return FlyOutcome(
        request.mission,
        who,
        autopilot,
        MonitorEnd.INTERRUPTED,
        empty,
        False,
        None,
        None,
        0.0,
        interrupt_mode="its previous mode",
        holds=holds,
    )


def _what_it_holds(
    link: VehicleLink,
    wire: list[MissionItem],
    before: list[MissionItem] | None,
    autopilot: Autopilot,
    request: FlyRequest,
) -> str:
    """The vehicle's mission after an interrupted upload, in words, read back as soon as it
    lets the transfer go (at most :data:`UPLOAD_SETTLE_S`)."""
    client = MissionClient(link, request.timeouts)
    deadline = time.monotonic() + UPLOAD_SETTLE_S
    started = time.monotonic()
    while True:
        outcome = client.download(MissionType.MISSION)
        busy = outcome.status in (TransferStatus.BUSY, TransferStatus.REJECTED)
        if outcome.ok or not busy or time.monotonic() >= deadline:
            break
        time.sleep(0.25)
    if not outcome.ok:
        return (
            f"holds a mission that could not be read ({outcome.where}: {outcome.detail}); "
            "download it before flying"
        )
    held = list(outcome.items)
    waited = time.monotonic() - started
    busy_for = f" (it was busy with the transfer for {waited:.1f} s)" if waited >= 0.5 else ""
    count = len(held)
    if compare_items(wire, held, MissionType.MISSION, autopilot) is None:
        return f"holds this mission ({count} items): the upload had finished{busy_for}"
    if before is not None and compare_items(before, held, MissionType.MISSION, autopilot) is None:
        return f"holds its previous mission ({count} items), unchanged{busy_for}"
    known = "" if before is not None else " (what it held before was not read: --upload)"
    return (
        f"holds {count} items that are not this mission{known}: ArduPilot keeps what arrived "
        f"of an interrupted upload in place of the old items; upload again before flying"
        f"{busy_for}"
    )


def _interrupted(
    client: FlightClient, kind: ModeKind, watch: Watch, request: FlyRequest, who: str
) -> FlyOutcome:
    """Ctrl-C: a vehicle that is armed goes into ``kind`` mode and is seen in it (one armed on
    the ground by the start, not yet flown, is disarmed instead)."""
    state = client.state
    mode_name = "its mode" if state.mode is None else state.mode.name
    if state.armed and state.on_ground and not state.flew:
        # stopped during the start, still on the ground: disarm rather than hold there
        client.commands([disarm_step()])
        mode_name = f"{mode_name}, disarmed" if not state.armed else mode_name
    elif state.armed:
        changed: CommandOutcome = client.change_mode(kind)
        watch.tick(state, final=True)
        watch.save(request.track)
        if not changed.ok:
            raise VehicleRefused(
                f"interrupted, but {who} did not change mode: {changed.message}",
                step="interrupt",
            )
        mode_name = "the new mode" if state.mode is None else state.mode.name
    watch.tick(state, final=True)
    return FlyOutcome(
        request.mission,
        who,
        state.autopilot,
        MonitorEnd.INTERRUPTED,
        watch.save(request.track),
        False,
        None,
        None,
        watch.max_cross_track_m,
        interrupt_mode=mode_name,
    )
