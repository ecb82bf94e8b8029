"""``fly``: fly a mission file on a vehicle, from the pre-flight checks to the landing.

Before the flight (nothing moves until each passes): the vehicle's heartbeat and autopilot;
whether it can arm (SYS_STATUS's pre-arm check and MAV_CMD_RUN_PREARM_CHECKS, whose
STATUSTEXT is quoted); its home against the plan's planned home (:data:`HOME_TOLERANCE_M`);
its onboard mission against the file (downloaded and compared item by item), uploaded and
verified when it differs or with ``--upload``. The flight model's prediction for the vehicle's
flavour is the reference the flight is compared with.

Then it starts the mission the way the firmware expects
(:func:`uavplan.mavlink.flightmachines.start_steps`) and follows it: a progress line (item
k/N, distance to go, ETA, altitude, speed, battery), the cross-track error from the planned
legs and, with a scenario, the clearance from obstacles and terrain of every stretch flown
(the one check, :func:`uavplan.flight.check_flight`), warning when either crosses its limit.

Endings: the mission complete and the vehicle down (or the last item done, for a mission
that does not land) is the outcome; Ctrl-C puts the vehicle into ``on_interrupt`` mode and
confirms it (outcome ``interrupted``); a lost link, a refusal and a landing before the end
raise :class:`~uavplan.errors.LinkError` (exit 4) saying what the vehicle last did or said.
The flown track is written (atomically) whatever the ending.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from uavplan.app.feedback import Feedback
from uavplan.app.outputs import check_output
from uavplan.config import Autopilot
from uavplan.errors import InputError, LinkError
from uavplan.fileio import InputFile
from uavplan.flight import Flight, TrackCheck, check_flight
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.mavlink.flightclient import FlightClient
from uavplan.mavlink.flightmachines import (
    CommandOutcome,
    FlightTimeouts,
    MonitorEnd,
    TelemetrySample,
    VehicleState,
    disarm_step,
)
from uavplan.mavlink.link import VehicleLink
from uavplan.mavlink.messages import LandedState
from uavplan.mavlink.modes import ModeKind
from uavplan.mavlink.protocol import MissionClient, ProtocolTimeouts
from uavplan.mavlink.transfer import compare_items, plan_wire_items, upload_plan
from uavplan.mission.io import load_mission
from uavplan.mission.items import MavCmd, MissionPlan, MissionType
from uavplan.mission.track import Track, check_track_path
from uavplan.rehearsal import CheckSite, Rehearsal, rehearse, return_seq
from uavplan.scenario import load_scenario
from uavplan.sim.simulate import MissionRefused, distance_to_polyline

#: how far the vehicle's home may be from the plan's planned home before ``fly`` refuses
#: (horizontal m, vertical m): about a GPS's horizontal error and a few metres of height, so
#: the take-off stands where the route was planned to begin and the relative altitudes mean
#: what they were planned to mean (docs/flying.md)
HOME_TOLERANCE_M = (10.0, 3.0)
#: ``--on-interrupt`` → the mode a Ctrl-C asks for
ON_INTERRUPT = {"hold": ModeKind.HOLD, "rtl": ModeKind.RETURN, "land": ModeKind.LAND}
#: the progress line is redrawn at most this often (wall seconds)
PROGRESS_EVERY_S = 0.2


class VehicleRefused(LinkError):
    """The vehicle said no (a pre-arm check, a mode, an arming, a home, a mission): exit 4,
    the message quoting what it said."""


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
    timeouts: ProtocolTimeouts = field(default_factory=ProtocolTimeouts)


@dataclass(frozen=True, eq=False)
class FlyOutcome:
    """A flight that ended on the ground (or done in the air), or an interrupted one."""

    file: str
    vehicle: str
    autopilot: Autopilot
    end: MonitorEnd | None  # None: interrupted
    track: Track
    uploaded: bool
    airborne_s: float | None
    predicted_airborne_s: float | None
    max_cross_track_m: float
    check: TrackCheck | None = None
    interrupt_mode: str | None = None

    @property
    def interrupted(self) -> bool:
        return self.end is None

    def summary(self) -> str:
        name = Path(self.file).name
        if self.interrupted:
            return (
                f"{name}: interrupted; {self.vehicle} is in {self.interrupt_mode} "
                f"after {len(self.track)} samples"
            )
        text = f"{name}: mission complete on {self.vehicle}"
        if self.end is MonitorEnd.COMPLETE_IN_AIR:
            text += " (in the air: the mission does not land)"
        if self.airborne_s is not None:
            text += f", {_minutes(self.airborne_s)} take-off to touchdown"
            if self.predicted_airborne_s:
                diff = 100.0 * (self.airborne_s / self.predicted_airborne_s - 1.0)
                text += f" (flight model {_minutes(self.predicted_airborne_s)}, {diff:+.1f} %)"
        text += f", largest cross-track error {self.max_cross_track_m:.2f} m"
        if self.check is not None:
            text += (
                f", min clearance {self.check.min_clearance_m:.2f} m from {self.check.nearest} "
                f"(margin {self.check.margin_m:g} m)"
            )
        return text


def _minutes(seconds: float) -> str:
    minutes, rest = divmod(round(seconds), 60)
    return f"{minutes} min {rest:02d} s"


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
    scenario = None if request.scenario is None else load_scenario(request.scenario)
    if scenario is not None and request.track:  # nor any file of the scenario
        check_output(request.track, *scenario.files)
    site = None if scenario is None else CheckSite.of_scenario(scenario)
    link = VehicleLink.connect(
        request.conn,
        target_system=request.target_system,
        heartbeat_timeout_s=request.heartbeat_timeout_s,
    )
    with link:
        return _fly_on(link, plan, site, kind, request, feedback)


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
    uploaded = _mission_on_board(link, plan, autopilot, request, feedback)

    # the reference: the flight model flying this mission as this vehicle's flavour
    reference: Rehearsal | None = None
    try:
        reference = rehearse(plan, site, autopilot=autopilot)
    except MissionRefused:
        reference = None  # the vehicle will refuse it, in its own words, at the start
    if reference is not None and reference.check is not None and not reference.check.ok:
        feedback.warn(
            f"warning: the flight model predicts: {reference.check.problem()} (plan the "
            "mission again: `uavplan plan` keeps the margin as flown)"
        )

    # -- start ------------------------------------------------------------------------------
    # from here a Ctrl-C is polled (the vehicle is put into --on-interrupt's mode); a second
    # one stops at once
    watch = _Watch(plan, autopilot, site, request.max_deviation_m, feedback, reference)
    with feedback.polled():
        return _fly_started(
            client, plan, site, kind, request, feedback, watch, reference, who, uploaded
        )


def _fly_started(
    client: FlightClient,
    plan: MissionPlan,
    site: CheckSite | None,
    kind: ModeKind,
    request: FlyRequest,
    feedback: Feedback,
    watch: _Watch,
    reference: Rehearsal | None,
    who: str,
    uploaded: bool,
) -> FlyOutcome:
    autopilot = client.link.vehicle.autopilot
    should_stop = feedback.should_stop
    started = client.start_mission(should_stop=should_stop)
    if started is None:  # Ctrl-C during the start
        return _interrupted(client, kind, watch, request, who)
    if not started.ok:
        watch.tick(client.state, final=True)
        watch.save(request.track)
        if client.state.armed and client.state.on_ground:
            # armed on the ground by the refused start: leave it disarmed, as it was
            client.commands([disarm_step()])
        raise VehicleRefused(f"{who} did not start the mission: {started.message()}", step="start")
    feedback.say("mission started")

    # -- the flight -------------------------------------------------------------------------
    wire = plan_wire_items(plan, MissionType.MISSION, autopilot)
    end = client.monitor(
        last_seq=len(wire) - 1,
        lands=_lands(wire),
        should_stop=should_stop,
        on_tick=watch.tick,
    )
    watch.tick(client.state, final=True)
    if end is None:
        return _interrupted(client, kind, watch, request, who)
    track = watch.save(request.track)
    if end is MonitorEnd.LINK_LOST:
        raise LinkError(
            f"lost the link to {who}: nothing heard for {request.link_timeout_s:g} s; the "
            f"vehicle was last {client.state.describe()}" + _last_words(client.state),
            step="flight",
        )
    if end is MonitorEnd.LANDED_EARLY:
        raise VehicleRefused(
            f"{who} landed and disarmed before the mission was complete: it was last "
            f"{client.state.describe()}" + _last_words(client.state),
            step="flight",
        )
    check = None
    if site is not None and len(track) >= 2:
        # the whole observed flight, take-off to touchdown, its return to launch included
        # (issue 37: the check stopped where the return began and passed a return that flew
        # through buildings)
        check = site.check(track, lands=bool(track.relative_alt_m[-1] <= 1.0))
    return FlyOutcome(
        request.mission,
        who,
        autopilot,
        end,
        track,
        uploaded,
        airborne_time(track),
        _predicted_airborne(reference),
        watch.max_cross_track_m,
        check,
    )


def _last_words(state: VehicleState) -> str:
    if not state.texts:
        return ""
    return f'; its last message: "{state.texts[-1][2]}"'


def _lands(wire: list) -> bool:
    return any(item.command in (MavCmd.NAV_LAND, MavCmd.NAV_RETURN_TO_LAUNCH) for item in wire)


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


def _mission_on_board(
    link: VehicleLink,
    plan: MissionPlan,
    autopilot: Autopilot,
    request: FlyRequest,
    feedback: Feedback,
) -> bool:
    """Compare the vehicle's mission with the file's; upload and verify when they differ
    (or with ``--upload``). Returns whether it uploaded."""
    client = MissionClient(link, request.timeouts)
    wire = plan_wire_items(plan, MissionType.MISSION, autopilot)
    if not request.upload:
        onboard = client.download(MissionType.MISSION).raise_for_status()
        difference = compare_items(wire, onboard.items, MissionType.MISSION, autopilot)
        if difference is None:
            feedback.say(f"the vehicle holds this mission ({len(wire)} items)")
            return False
        feedback.say(f"the vehicle holds another mission ({difference}): uploading this one")
    report = upload_plan(client, plan, verify=True)
    for note in report.notes:
        feedback.say(f"note: {note}")
    feedback.say(f"uploaded {len(wire)} mission items, verified by read-back")
    return True


def _interrupted(
    client: FlightClient, kind: ModeKind, watch: _Watch, request: FlyRequest, who: str
) -> FlyOutcome:
    """Ctrl-C: a vehicle that is armed goes into ``kind`` mode and is seen in it (one armed on
    the ground by the start, not yet flown, is disarmed instead)."""
    state = client.state
    mode_name = "its mode" if state.mode is None else state.mode.name
    if state.armed and state.on_ground and not state.flew:
        # stopped during the start, still on the ground: disarm rather than hold there
        client.commands([disarm_step()])
        mode_name = f"{mode_name}, disarmed" if not state.armed else mode_name
        watch.tick(state, final=True)
        watch.save(request.track)
    elif state.armed:
        changed: CommandOutcome = client.change_mode(kind)
        watch.tick(state, final=True)
        watch.save(request.track)
        if not changed.ok:
            raise VehicleRefused(
                f"interrupted, but {who} did not change mode: {changed.message()}",
                step="interrupt",
            )
        mode_name = "the new mode" if state.mode is None else state.mode.name
    else:
        watch.save(request.track)
    return FlyOutcome(
        request.mission,
        who,
        state.autopilot,
        None,
        watch.track(),
        False,
        None,
        None,
        watch.max_cross_track_m,
        interrupt_mode=mode_name,
    )


def _predicted_airborne(reference: Rehearsal | None) -> float | None:
    return None if reference is None else reference.airborne_s


def airborne_time(track: Track) -> float | None:
    """Take-off to touchdown: from the last sample on the ground before the vehicle climbs
    to the first one after which its altitude stays where it came to rest (None: it did not
    both take off and land)."""
    z = track.relative_alt_m
    if len(z) < 2 or float(np.max(z)) < 0.5:
        return None
    up = np.flatnonzero(z > 0.05)
    first_up = int(up[0])
    takeoff = max(first_up - 1, 0)
    rest = z[-1]
    moving = np.flatnonzero(np.abs(z - rest) > 0.05)
    if not moving.size or float(rest) > 0.5:
        return None  # still in the air
    touchdown = min(int(moving[-1]) + 1, len(z) - 1)
    return float(track.time_s[touchdown] - track.time_s[takeoff])


# ---------------------------------------------------------------------------------------------


class _Watch:
    """Follows the samples: the track, the cross-track error, the clearance, the progress
    line, the warnings."""

    def __init__(
        self,
        plan: MissionPlan,
        autopilot: Autopilot,
        site: CheckSite | None,
        max_deviation_m: float,
        feedback: Feedback,
        reference: Rehearsal | None,
    ) -> None:
        self.plan = plan
        self.autopilot = autopilot
        self.site = site
        self.max_deviation_m = max_deviation_m
        self.feedback = feedback
        self.samples: list[TelemetrySample] = []
        self.max_cross_track_m = 0.0
        assert plan.home is not None
        self.home = plan.home
        self.frame = EnuFrame.at(plan.home)
        self.legs = _planned_legs(plan, autopilot, reference)
        self.rtl = return_seq(plan, autopilot)
        wire = plan_wire_items(plan, MissionType.MISSION, autopilot)
        self.total = len(wire)
        self.off_route = False
        self.too_close = False
        self.last_drawn = -math.inf
        self.speeds: list[float] = []
        if feedback.progress is not None:
            feedback.progress.start("item")

    def tick(self, state: VehicleState, *, final: bool = False) -> None:
        new = state.take_samples()
        if not new:
            return
        start = max(len(self.samples) - 1, 0)
        self.samples.extend(new)
        returning = state.mode is not None and state.mode.kind in (ModeKind.RETURN, ModeKind.LAND)
        self._cross_track(new, returning)
        if self.site is not None:
            self._clearance(start)
        self._progress(state, final)

    def _enu(self, samples: list[TelemetrySample]) -> np.ndarray:
        xy = self.frame.to_enu_xy([s.lat_deg for s in samples], [s.lon_deg for s in samples])
        z = np.array([s.relative_alt_m for s in samples])
        return np.column_stack((xy, z))

    def _cross_track(self, new: list[TelemetrySample], returning: bool) -> None:
        if len(self.legs) < 2:
            return
        mission = [
            s for s in new if not returning and (self.rtl is None or s.current_seq < self.rtl)
        ]
        if not mission:
            return
        error = distance_to_polyline(self._enu(mission), self.legs)
        worst = int(np.argmax(error))
        self.max_cross_track_m = max(self.max_cross_track_m, float(error[worst]))
        over = float(error[worst]) > self.max_deviation_m
        if over and not self.off_route:
            s = mission[worst]
            self._warn(
                f"warning: {s.time_s - self.samples[0].time_s:.0f} s into the flight (item "
                f"{s.current_seq}) the vehicle is {error[worst]:.1f} m off the planned route "
                f"(--max-deviation {self.max_deviation_m:g} m)"
            )
        self.off_route = over

    def _clearance(self, start: int) -> None:
        site = self.site
        assert site is not None
        samples = self.samples[start:]
        if len(samples) < 2:
            return
        track = _track_of(samples, self.home)
        flight_points = _site_points(track, site)
        airborne = all(s.landed_state == LandedState.IN_AIR for s in samples)
        n = len(flight_points)
        flight = Flight(flight_points, (0, n - 1) if airborne else (n - 1, n - 1))
        check = check_flight(site.world, flight, name_of=site.name_of, volume_tol_m=0.5)
        close = not check.keeps_margin
        if close and not self.too_close:
            s = samples[min(check.worst + 1, len(samples) - 1)]
            self._warn(
                f"warning: {s.time_s - self.samples[0].time_s:.0f} s into the flight (item "
                f"{s.current_seq}) the vehicle is {check.min_clearance_m:.1f} m from "
                f"{check.nearest} (margin {site.margin_m:g} m)"
            )
        self.too_close = close

    def _warn(self, text: str) -> None:
        """A warning on a line of its own (the progress line, if drawn, ends first)."""
        if self.feedback.progress is not None:
            self.feedback.progress.close()
        self.feedback.warn(text)

    def _progress(self, state: VehicleState, final: bool) -> None:
        bar = self.feedback.progress
        if bar is None:
            return
        now = time.monotonic()
        if now - self.last_drawn < PROGRESS_EVERY_S and not final:
            return
        self.last_drawn = now
        s = self.samples[-1]
        self.speeds.append(s.speed_m_s)
        here = self._enu([s])[0]
        returning = (state.mode is not None and state.mode.kind is ModeKind.RETURN) or (
            self.rtl is not None and s.current_seq >= self.rtl
        )
        if returning:  # the autopilot's own way home: no planned legs left
            to_go = float(math.hypot(here[0], here[1]))
            where = f"{to_go / 1000.0:.2f} km from home"
        else:
            to_go = _distance_to_go(here, self.legs)
            where = f"{to_go / 1000.0:.2f} km to go"
        moving = [v for v in self.speeds if v > 1.0]
        speed = sum(moving) / len(moving) if moving else 0.0
        eta = f"ETA {_minutes(to_go / speed)}" if speed > 1.0 else "ETA -"
        battery = "-" if state.battery_pct is None else f"{state.battery_pct:.0f} %"
        mode = "?" if state.mode is None else state.mode.name
        detail = (
            f"{mode}, {where}, {eta}, alt {s.relative_alt_m:.0f} m, "
            f"{s.speed_m_s:.1f} m/s, battery {battery}"
        )
        item = max(0, s.current_seq)
        bar.show(min(item, self.total), max(self.total, 1), detail)
        if final:
            bar.close()

    def track(self) -> Track:
        return _track_of(self.samples, self.home, self.autopilot)

    def save(self, path: str | None) -> Track:
        track = self.track()
        if path:
            track.save(path)
            self.feedback.say(f"track: {len(track)} samples written to {path}")
        return track


def _track_of(
    samples: list[TelemetrySample], home: GeoPoint, autopilot: Autopilot | None = None
) -> Track:
    t0 = samples[0].time_s if samples else 0.0
    return Track(
        time_s=np.array([s.time_s - t0 for s in samples], dtype=np.float64),
        lat_deg=np.array([s.lat_deg for s in samples], dtype=np.float64),
        lon_deg=np.array([s.lon_deg for s in samples], dtype=np.float64),
        alt_amsl_m=np.array([s.alt_amsl_m for s in samples], dtype=np.float64),
        relative_alt_m=np.array([s.relative_alt_m for s in samples], dtype=np.float64),
        speed_m_s=np.array([s.speed_m_s for s in samples], dtype=np.float64),
        current_seq=np.array([s.current_seq for s in samples], dtype=np.int64),
        mode=tuple(s.mode for s in samples),
        source="fly",
        autopilot="" if autopilot is None else autopilot.label,
    )


def _site_points(track: Track, site: CheckSite) -> np.ndarray:
    from uavplan.flight import flight_of_track

    return flight_of_track(
        track, site.frame, datum_amsl_m=site.datum_amsl_m, lands=False
    ).points_enu


def _planned_legs(
    plan: MissionPlan, autopilot: Autopilot, reference: Rehearsal | None
) -> np.ndarray:
    """The planned route (home, then each positional item) in the ENU frame at home."""
    if reference is not None:
        return reference.flown.planned_polyline_enu()
    from uavplan.sim.model import nav_items

    assert plan.home is not None
    nav = nav_items(plan_wire_items(plan, MissionType.MISSION, autopilot), plan.home)
    points = [(0.0, 0.0, 0.0)]
    for item in nav:
        if item.is_position and item.position is not None and not math.isnan(item.position[0]):
            points.append(item.position)
    return np.array(points, dtype=np.float64)


def _distance_to_go(point: np.ndarray, legs: np.ndarray) -> float:
    """Along the planned legs, from the point's nearest place on them to their end."""
    if len(legs) < 2:
        return 0.0
    a, b = legs[:-1], legs[1:]
    d = b - a
    length = np.linalg.norm(d, axis=1)
    t = np.clip(np.einsum("ij,ij->i", point - a, d) / np.maximum(length**2, 1e-12), 0.0, 1.0)
    dist = np.linalg.norm(a + t[:, None] * d - point, axis=1)
    k = int(np.argmin(dist))
    return float((1.0 - t[k]) * length[k] + length[k + 1 :].sum())
