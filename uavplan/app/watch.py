"""The live watch of ``fly`` (:class:`Watch`): it follows the vehicle's samples as they come
and keeps the flown track, the cross-track error from the planned legs, the clearance of every
stretch flown (each new breach of the margin and each metre closer), the progress line (item
k/N, distance to go, ETA, altitude, speed, battery; off a terminal a status line every
:data:`STATUS_EVERY_S` of the vehicle's time), the vehicle's warnings, what the monitor
noticed, and whether the vehicle still makes progress. ``fly`` (:mod:`uavplan.app.fly`)
drives it and judges the flight with what it kept.
"""

from __future__ import annotations

import itertools
import math
import time
from collections import deque
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from uavplan.app.feedback import Feedback
from uavplan.autopilot.simulate import distance_to_polyline
from uavplan.flavour import Autopilot
from uavplan.flightcheck import Flight, flight_clearance, flight_of_track
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.mavlink.flightmachines import (
    GAP_S,
    MonitorEnd,
    Notice,
    NoticeKind,
    TelemetrySample,
    VehicleState,
    flight_clock,
)
from uavplan.mavlink.messages import LandedState, Severity
from uavplan.mavlink.modes import ModeKind
from uavplan.mavlink.transfer import plan_wire_items
from uavplan.mission.items import MavCmd, MissionItem, MissionPlan, MissionType
from uavplan.mission.track import Track, observed_stretches
from uavplan.rehearsal import CheckSite, Rehearsal, return_seq
from uavplan.route import keeps_margin
from uavplan.world import CEILING, GROUND


class WatchedRequest(Protocol):
    """What the watch reads of ``fly``'s request (:class:`uavplan.app.fly.FlyRequest`)."""

    @property
    def max_deviation_m(self) -> float: ...
    @property
    def stall_s(self) -> float: ...
    @property
    def link_timeout_s(self) -> float: ...
    @property
    def takeover_wait_s(self) -> float: ...


#: the progress line is redrawn at most this often (wall seconds)
PROGRESS_EVERY_S = 0.2
#: new samples are measured (cross-track, clearance, progress) at most this often (wall s)
PROCESS_EVERY_S = 0.1
#: off a terminal, a status line this often (vehicle seconds), so a log never goes quiet
STATUS_EVERY_S = 30.0
#: the vehicle makes no progress when its distance to go shrank by less than this over
#: ``stall_s`` (m) and its current item did not move on
STALL_PROGRESS_M = 10.0
#: the ETA against the battery uses the progress over this long (vehicle seconds)
BATTERY_WINDOW_S = 30.0
#: a breach of the margin is said again each time the track comes this much closer (m)
CLOSER_STEP_M = 1.0
#: the same STATUSTEXT again within this long (wall s) is not printed twice
TEXT_REPEAT_S = 5.0


def predicted_airborne(reference: Rehearsal | None) -> float | None:
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


@dataclass(frozen=True)
class _Progress:
    """Where the vehicle stood at one moment, for the judgement of its progress."""

    time_s: float
    to_go_m: float
    seq: int
    alt_m: float
    returning: bool


def _progressed(window: deque[_Progress] | list[_Progress], by_m: float) -> bool:
    """Over ``window``: the distance to go shrank, or the altitude changed, by ``by_m``, or
    the current item moved on."""
    first, last = window[0], window[-1]
    if first.seq != last.seq:
        return True
    if first.to_go_m - min(p.to_go_m for p in window) >= by_m:
        return True
    alts = [p.alt_m for p in window]
    return max(alts) - min(alts) >= by_m


@dataclass
class _Breach:
    """One stretch of the track inside the margin, as the live watch saw it."""

    since_s: float
    worst_m: float
    worst_what: str
    worst_at_s: float
    worst_seq: int
    said_m: float
    said_what: str


class Watch:
    """Follows the samples: the track, the cross-track error, the clearance, the progress
    line, the vehicle's warnings, what the monitor noticed, and whether the vehicle still
    makes progress (:meth:`tick` returns :attr:`MonitorEnd.STALLED` when it does not)."""

    def __init__(
        self,
        plan: MissionPlan,
        autopilot: Autopilot,
        site: CheckSite | None,
        request: WatchedRequest,
        feedback: Feedback,
        state: VehicleState,
    ) -> None:
        self.plan = plan
        self.state = state
        self.autopilot = autopilot
        self.site = site
        self.request = request
        self.max_deviation_m = request.max_deviation_m
        self.feedback = feedback
        self.uploaded = False
        self.samples: list[TelemetrySample] = []
        self.processed = 0
        self.last_processed = -math.inf
        self.moving_sum = 0.0
        self.moving_n = 0
        #: samples after a restart of the vehicle (a clock of their own: not the track)
        self.after_restart: list[TelemetrySample] = []
        self.max_cross_track_m = 0.0
        #: where the vehicle was farthest off the planned legs: (metres, when, item)
        self.farthest_off_route: tuple[float, str, int] | None = None
        assert plan.home is not None
        self.home = plan.home
        self.frame = EnuFrame.at(plan.home)
        self.legs, self.leg_seqs = _planned_legs(plan, autopilot)
        self.rtl = return_seq(plan, autopilot)
        wire = plan_wire_items(plan, MissionType.MISSION, autopilot)
        #: the first NAV_LAND's seq (None: the mission does not land on its own)
        self.land = next(
            (q for q, item in enumerate(wire) if item.command == MavCmd.NAV_LAND), None
        )
        self.total = len(wire)
        self.hold_s = [_hold_time_s(item) for item in wire]
        self.off_route = False
        self.breach: _Breach | None = None
        self.last_drawn = -math.inf
        self.next_status_s: float | None = None
        self.notices_seen = 0
        self.texts_seen = 0
        self.said_texts: dict[str, float] = {}
        self.progress_window: deque[_Progress] = deque()
        self.battery_warned = False
        self.battery_warned_at = -math.inf
        self.saved: Track | None = None
        self.saved_len = -1
        if feedback.progress is not None:
            feedback.progress.start("item")

    # -- what the vehicle reports ----------------------------------------------------------
    def tell(self, state: VehicleState) -> None:
        """Say what the vehicle said and what changed, as it comes: while the start waits
        (an arm asked again for up to FlightTimeouts.busy_s) the operator hears why."""
        self._notices(state)
        self._texts(state)

    def tick(self, state: VehicleState, *, final: bool = False) -> MonitorEnd | None:
        self.tell(state)
        new = state.take_samples()
        self.samples.extend(s for s in new if s.epoch == 0)
        self.after_restart.extend(s for s in new if s.epoch != 0)
        now = time.monotonic()
        if not final and now - self.last_processed < PROCESS_EVERY_S:
            return None
        self.last_processed = now
        fresh = self.samples[self.processed :]
        if fresh:
            start = max(self.processed - 1, 0)
            self.processed = len(self.samples)
            for sample in fresh:
                if sample.speed_m_s > 1.0:
                    self.moving_sum += sample.speed_m_s
                    self.moving_n += 1
            returning = state.mode is not None and state.mode.kind in (
                ModeKind.RETURN,
                ModeKind.LAND,
            )
            self._cross_track(fresh, returning)
            if self.site is not None:
                self._clearance(start)
        if final and self.breach is not None and self.samples:
            self._breach_over(self.samples[-1], ended=True)
        if not self.samples:
            return None
        to_go, returning = self._progress(state, final)
        if final:
            return None
        return self._judge(state, to_go, returning)

    def _notices(self, state: VehicleState) -> None:
        for notice in state.notices[self.notices_seen :]:
            good_news = notice.kind in (NoticeKind.LINK_BACK, NoticeKind.MISSION_RESUMED)
            self._warn(("fly: " if good_news else "warning: ") + notice.line())
        self.notices_seen = len(state.notices)

    def _texts(self, state: VehicleState) -> None:
        """The vehicle's STATUSTEXT of severity WARNING and above, as they come."""
        for when, severity, text in state.texts[self.texts_seen :]:
            if severity > Severity.WARNING:
                continue
            last = self.said_texts.get(text)
            self.said_texts[text] = when
            if last is not None and when - last < TEXT_REPEAT_S:
                continue
            try:
                level = Severity(severity).name
            except ValueError:
                level = str(severity)
            self._warn(f"vehicle ({level}): {text}")
        self.texts_seen = len(state.texts)

    def takeovers(self) -> list[Notice]:
        """What changed behind ``fly``'s back (the notices that are takeovers)."""
        return [n for n in self.state.notices if n.takeover]

    def gaps_in_air(self) -> list[tuple[float, float]]:
        """Stretches of the flight without telemetry where the vehicle was (or may have
        been) in the air: (from, to) in seconds into the flight."""
        out: list[tuple[float, float]] = []
        samples = self.samples
        if len(samples) < 2:
            return out
        t0 = samples[0].time_s
        for a, b in itertools.pairwise(samples):
            if b.time_s - a.time_s <= GAP_S:
                continue
            if _airborne(a) or _airborne(b):
                out.append((a.time_s - t0, b.time_s - t0))
        return out

    def _enu(self, samples: list[TelemetrySample]) -> np.ndarray:
        xy = self.frame.to_enu_xy([s.lat_deg for s in samples], [s.lon_deg for s in samples])
        z = np.array([s.relative_alt_m for s in samples])
        return np.column_stack((xy, z))

    def _when(self, sample: TelemetrySample) -> str:
        return flight_clock(sample.time_s - self.samples[0].time_s)

    def _cross_track(self, new: list[TelemetrySample], returning: bool) -> None:
        if len(self.legs) < 2:
            return
        mission = [
            s for s in new if not returning and (self.rtl is None or s.current_seq < self.rtl)
        ]
        if not mission:
            return
        enu = self._enu(mission)
        error = distance_to_polyline(enu, self.legs)
        if self.land is not None:
            # a NAV_LAND is flown over its position at the altitude the vehicle has, then
            # down to wherever the ground is: across the approach only, the descent is the
            # autopilot's (a landing on a hillside ends below or above its planned altitude)
            landing = np.array([s.current_seq >= self.land for s in mission])
            if landing.any():
                flat = np.column_stack((enu[landing, :2], np.zeros(int(landing.sum()))))
                legs = np.column_stack((self.legs[:, :2], np.zeros(len(self.legs))))
                error[landing] = distance_to_polyline(flat, legs)
        worst = int(np.argmax(error))
        if float(error[worst]) > self.max_cross_track_m:
            s = mission[worst]
            self.max_cross_track_m = float(error[worst])
            self.farthest_off_route = (self.max_cross_track_m, self._when(s), s.current_seq)
        over = float(error[worst]) > self.max_deviation_m
        if over and not self.off_route:
            s = mission[worst]
            self._warn(
                f"warning: {self._when(s)} into the flight (item {s.current_seq}) the vehicle "
                f"is {error[worst]:.1f} m off the planned route "
                f"(--max-deviation {self.max_deviation_m:g} m)"
            )
        self.off_route = over

    # -- the live clearance: each breach, each metre closer, the worst of each --------------
    def _clearance(self, start: int) -> None:
        site = self.site
        assert site is not None
        samples = self.samples[start:]
        for run in _runs(samples):
            if len(run) < 2:
                continue
            track = _track_of(run, self.home)
            points = flight_of_track(
                track, site.frame, datum_amsl_m=site.datum_amsl_m, lands=False
            ).points_enu
            airborne = all(s.landed_state == LandedState.IN_AIR for s in run)
            n = len(points)
            flight = Flight(points, (0, n - 1) if airborne else (n - 1, n - 1))
            dist, owner, _ = flight_clearance(site.world, flight)
            for k, d in enumerate(dist):
                self._segment(float(d), int(owner[k]), run[k + 1], site)

    def _segment(self, d: float, owner: int, sample: TelemetrySample, site: CheckSite) -> None:
        margin = site.margin_m
        if keeps_margin(d, margin):
            if self.breach is not None:
                self._breach_over(sample, ended=False)
            return
        what = owner_name(owner, site)
        b = self.breach
        where = f"{self._when(sample)} into the flight (item {sample.current_seq})"
        if b is None:
            seq = sample.current_seq
            self.breach = _Breach(sample.time_s, d, what, sample.time_s, seq, d, what)
            self._warn(
                f"warning: {where} the vehicle is {d:.1f} m from {what} (margin {margin:g} m)"
            )
            return
        if d < b.worst_m:
            b.worst_m, b.worst_what = d, what
            b.worst_at_s, b.worst_seq = sample.time_s, sample.current_seq
        if d <= b.said_m - CLOSER_STEP_M or what != b.said_what:
            b.said_m, b.said_what = d, what
            self._warn(
                f"warning: {where} the vehicle is {d:.1f} m from {what}, closer still "
                f"(margin {margin:g} m)"
            )

    def _breach_over(self, sample: TelemetrySample, *, ended: bool) -> None:
        b = self.breach
        assert b is not None and self.site is not None
        self.breach = None
        worst_at = flight_clock(b.worst_at_s - self.samples[0].time_s)
        lasted = sample.time_s - b.since_s
        if ended:
            head = "the track ends inside the margin"
        else:
            head = f"{self._when(sample)} into the flight the vehicle is outside the margin again"
        self._warn(
            f"warning: {head} after {lasted:.0f} s inside it: the closest was {b.worst_m:.2f} m "
            f"from {b.worst_what}, {worst_at} into the flight (item {b.worst_seq}; margin "
            f"{self.site.margin_m:g} m)"
        )

    def _warn(self, text: str) -> None:
        """A warning on a line of its own (the progress line, if drawn, ends first)."""
        if self.feedback.progress is not None:
            self.feedback.progress.close()
        self.feedback.warn(text)

    # -- progress -------------------------------------------------------------------------
    def _to_go(self, state: VehicleState, s: TelemetrySample) -> tuple[float, bool]:
        here = self._enu([s])[0]
        returning = (state.mode is not None and state.mode.kind is ModeKind.RETURN) or (
            self.rtl is not None and s.current_seq >= self.rtl
        )
        if returning:  # the autopilot's own way home: no planned legs left
            return float(math.hypot(here[0], here[1], here[2])), True
        # the leg flown is the one that ends at the current item
        ahead = np.flatnonzero(self.leg_seqs >= s.current_seq)
        first = int(ahead[0]) - 1 if ahead.size else len(self.legs) - 2
        return _distance_to_go(here, self.legs, first), False

    @property
    def mean_speed_m_s(self) -> float:
        """The average ground speed while moving (over 1 m/s), so far."""
        return self.moving_sum / self.moving_n if self.moving_n else 0.0

    def _progress(self, state: VehicleState, final: bool) -> tuple[float, bool]:
        s = self.samples[-1]
        to_go, returning = self._to_go(state, s)
        speed = self.mean_speed_m_s
        where = f"{to_go / 1000.0:.2f} km {'from home' if returning else 'to go'}"
        eta = f"ETA {flight_clock(to_go / speed)}" if speed > 1.0 else "ETA -"
        battery = "-" if state.battery_pct is None else f"{state.battery_pct:.0f} %"
        mode = "?" if state.mode is None else state.mode.name
        detail = (
            f"{mode}, {where}, {eta}, alt {s.relative_alt_m:.0f} m, "
            f"{s.speed_m_s:.1f} m/s, battery {battery}"
        )
        item = max(0, s.current_seq)
        bar = self.feedback.progress
        drawn = bar is not None and bool(getattr(bar, "enabled", False))
        if drawn and bar is not None:
            now = time.monotonic()
            if now - self.last_drawn >= PROGRESS_EVERY_S or final:
                self.last_drawn = now
                bar.show(min(item, self.total), max(self.total, 1), detail)
            if final:
                bar.close()
        elif not final:
            # off a terminal (a log, a pipe): a status line now and then, never silence
            if self.next_status_s is None or s.time_s >= self.next_status_s:
                self.next_status_s = s.time_s + STATUS_EVERY_S
                self.feedback.say(
                    f"{self._when(s)} into the flight: item {item}/{self.total}, {detail}"
                )
        return to_go, returning

    def _judge(self, state: VehicleState, to_go: float, returning: bool) -> MonitorEnd | None:
        """No progress for ``stall_s`` of the vehicle's time, and the ETA against the
        battery. Progress over that time: the distance to go (along the planned legs; to
        home on the way home) shrinking by :data:`STALL_PROGRESS_M`, the altitude changing by
        as much (a return's climb, a landing), or the current item moving on."""
        s = self.samples[-1]
        window = self.progress_window
        if window and state.gaps and state.gaps[-1][1] > window[-1].time_s:
            window.clear()  # nothing is judged across a gap: the time without progress restarts
        if not (state.armed and state.flew and s.relative_alt_m > 0.5) or (
            window and window[-1].returning != returning
        ):
            window.clear()  # on the ground, or the measure changed (the return began)
            if not (state.armed and state.flew and s.relative_alt_m > 0.5):
                return None
        window.append(_Progress(s.time_s, to_go, s.current_seq, s.relative_alt_m, returning))
        seq = s.current_seq
        hold = self.hold_s[seq] if 0 <= seq < len(self.hold_s) else 0.0
        if hold == math.inf:
            window.clear()  # a loiter without end: no progress is what it asked for
            return None
        limit = self.request.stall_s + hold
        while len(window) > 1 and window[1].time_s <= s.time_s - limit:
            window.popleft()
        self._battery(state, window)
        if s.time_s - window[0].time_s < limit or _progressed(window, STALL_PROGRESS_M):
            return None
        self._notice(
            state,
            NoticeKind.NO_PROGRESS,
            f"no progress for {limit:g} s of the vehicle's time: {to_go:.0f} m to go "
            f"{'home' if returning else 'along the route'}, {s.speed_m_s:.1f} m/s, item {seq}",
        )
        return MonitorEnd.STALLED

    def _battery(self, state: VehicleState, window: deque[_Progress]) -> None:
        """Warn (once, until it clears) when the time to go passes what the battery has left
        by the vehicle's estimate (BATTERY_STATUS.time_remaining). The time to go is the
        distance to go at the average speed so far, or "never" when over the last
        :data:`BATTERY_WINDOW_S` the vehicle got no nearer, and climbed or descended no more
        than :data:`STALL_PROGRESS_M` (a vehicle the wind holds back)."""
        left = state.battery_time_s
        speed = self.mean_speed_m_s
        # the average speed means something once the vehicle has been under way a while
        if left is None or speed <= 1.0 or self.moving_n * 0.2 < BATTERY_WINDOW_S:
            return
        last = window[-1]
        eta = last.to_go_m / speed
        recent = [p for p in window if p.time_s >= last.time_s - BATTERY_WINDOW_S]
        if last.time_s - recent[0].time_s >= BATTERY_WINDOW_S * 0.9 and not _progressed(
            recent, STALL_PROGRESS_M
        ):
            eta = math.inf
        quiet_since = last.time_s - self.battery_warned_at
        if eta > left and not self.battery_warned and quiet_since >= BATTERY_WINDOW_S * 2:
            self.battery_warned = True
            self.battery_warned_at = last.time_s
            when = "never at this rate" if math.isinf(eta) else flight_clock(eta)
            self._notice(
                state,
                NoticeKind.BATTERY,
                f"the time to go ({when}, {last.to_go_m:.0f} m) is past what the battery has "
                f"left ({flight_clock(left)} by the vehicle's estimate)",
            )
        elif eta < 0.9 * left:
            self.battery_warned = False

    def _notice(self, state: VehicleState, kind: NoticeKind, text: str) -> None:
        into = self.samples[-1].time_s - self.samples[0].time_s
        state.notices.append(Notice(kind, text, time.monotonic(), into))
        self._notices(state)

    # -- the track --------------------------------------------------------------------------
    def track(self) -> Track:
        track = _track_of(self.samples, self.home, self.autopilot)
        gaps = track.gaps(GAP_S)
        if gaps:
            track.extra["unobserved_s"] = [[round(a, 3), round(b, 3)] for a, b in gaps]
        return track

    def save(self, path: str | None) -> Track:
        if self.saved is not None and self.saved_len == len(self.samples):
            return self.saved
        track = self.track()
        self.saved, self.saved_len = track, len(self.samples)
        if path:
            track.save(path)
            self.feedback.say(f"track: {len(track)} samples written to {path}")
        return track


def owner_name(owner: int, site: CheckSite) -> str:
    """What a segment came nearest (an obstacle index, or the terrain, or the ceiling)."""
    if owner == GROUND:
        return "the terrain"
    if owner == CEILING:
        return "the ceiling"
    return "nothing" if owner < 0 else site.name_of(owner)


def _airborne(sample: TelemetrySample) -> bool:
    return sample.landed_state == LandedState.IN_AIR or sample.relative_alt_m > 0.5


def _runs(samples: list[TelemetrySample]) -> list[list[TelemetrySample]]:
    """``samples`` cut where nothing was observed for longer than GAP_S."""
    if not samples:
        return []
    stretches = observed_stretches([s.time_s for s in samples], GAP_S)
    return [samples[a:b] for a, b in stretches]


#: MAV_CMD_NAV_LOITER_TIME: param1 the time to loiter (s)
NAV_LOITER_TIME = 19


def _hold_time_s(item: MissionItem) -> float:
    """How long an item keeps the vehicle where it is (s; inf: without end)."""
    if item.command == MavCmd.NAV_LOITER_UNLIM:
        return math.inf
    if item.command in (MavCmd.NAV_WAYPOINT, NAV_LOITER_TIME):
        value = item.param1
        return float(value) if value is not None and math.isfinite(value) and value > 0 else 0.0
    return 0.0


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


def _planned_legs(plan: MissionPlan, autopilot: Autopilot) -> tuple[np.ndarray, np.ndarray]:
    """The planned route in the ENU frame at home, as the flight model draws it
    (:func:`uavplan.autopilot.nav.planned_legs`), and the wire seq of the item each point is
    (-1: home)."""
    from uavplan.autopilot.nav import nav_items, planned_legs

    assert plan.home is not None
    return planned_legs(nav_items(plan_wire_items(plan, MissionType.MISSION, autopilot), plan.home))


def _distance_to_go(point: np.ndarray, legs: np.ndarray, first: int = 0) -> float:
    """Along the planned legs, from the point's nearest place on legs ``first`` on (the leg
    to the current item and those after it: a route that comes back past its start is not
    taken for done) to their end."""
    if len(legs) < 2:
        return 0.0
    first = min(max(first, 0), len(legs) - 2)
    a, b = legs[first:-1], legs[first + 1 :]
    d = b - a
    length = np.linalg.norm(d, axis=1)
    t = np.clip(np.einsum("ij,ij->i", point - a, d) / np.maximum(length**2, 1e-12), 0.0, 1.0)
    dist = np.linalg.norm(a + t[:, None] * d - point, axis=1)
    k = int(np.argmin(dist))
    return float((1.0 - t[k]) * length[k] + length[k + 1 :].sum())
