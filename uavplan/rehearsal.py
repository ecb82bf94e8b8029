"""Rehearse a mission: fly it through the flight model where a scenario is planned, check the
flown track with the one mission check (:mod:`uavplan.flown_safe` plans the routes that stay
safe as flown).

:func:`rehearse` flies a :class:`~uavplan.mission.items.MissionPlan` through
:func:`uavplan.autopilot.simulate.simulate` (the same model the simulated vehicle flies) and, with
a scenario, measures the track with :func:`uavplan.flightcheck.check_flight`: the mission's part
(take-off to where the autopilot's return to launch begins, or the landing) against the
scenario's margin, and the return leg apart (the autopilot flies it at its RTL altitude, it
is not planned). ``uavplan simulate`` reports it; ``uavplan plan`` uses
:func:`uavplan.flown_safe.plan_safe_as_flown` so that the track the model predicts keeps the margin.

Why a wider planning margin, and not per-item acceptance radii or stops at the corners:
docs/flying.md ("Plans that stay safe as flown") has the measurements on every bundled
scenario (tools/safe_as_flown.py). In short: the flown track leaves the straight legs not
only at the corners (the cut) but also after them (PX4 swings back onto the next leg), so a
planned clearance of exactly the margin cannot survive any flight; growing the margin by
what the track lacked and planning again keeps it on 20 of 20 scenario-flavour pairs at a
cost of seconds of flight time, where smaller acceptance radii keep it on 15 and stops on
11, costing up to 22 s of flight.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Any

import numpy as np

from uavplan.autopilot.model import EventKind
from uavplan.autopilot.params import Parameters
from uavplan.autopilot.power import VehicleSpec
from uavplan.autopilot.simulate import FlightEnd, FlownTrack, distance_to_polyline, simulate
from uavplan.flavour import Autopilot
from uavplan.flightcheck import FlightPrediction, TrackCheck, check_track
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.ground import Ground
from uavplan.mavlink.modes import ModeKind, mode_named
from uavplan.mission.items import MavCmd, MissionPlan, MissionType
from uavplan.mission.track import Track
from uavplan.obstacles import Obstacle
from uavplan.scenario import Scenario, Surroundings
from uavplan.scenario.settings import DEFAULT_LEGAL_CEILING_M
from uavplan.world import World
from uavplan.worlds import build_world, enu_frame, fence_world, return_world

__all__ = [
    "TRACKING_ALLOWANCE_M",
    "CheckSite",
    "Rehearsal",
    "max_deviation_m",
    "rehearsal_of",
    "rehearse",
    "rtl_start",
    "track_of",
]


#: what a flight the model predicts keeps beyond the margin, per firmware (m): the firmware's
#: tracking error, which the model does not fly (it puts the vehicle exactly where its guidance
#: does). PX4 SIH trails its trajectory by about a metre and flew closer to obstacles than the
#: model predicted (issue 32, tools/sitl_compare.py at speed-up 8): 0.45-0.53 m on paper-env3,
#: paper-env2 and helsinki-centre (tracks 9.57 / 10, 9.63 / 10 and 4.53 / 5 m), and up to
#: 0.70 m once the plans kept a 0.6 m allowance (paper-env2: 10.77 m predicted, 10.07 m
#: flown). ArduPilot SITL never came more than 0.07 m closer than the model, within the
#: position's noise. ``fly`` judges its flown track against the margin alone: the allowance is
#: for predictions.
TRACKING_ALLOWANCE_M: dict[Autopilot, float] = {Autopilot.PX4: 1.0, Autopilot.ARDUPILOT: 0.0}


def tracking_allowance_m(autopilot: Autopilot) -> float:
    """What a predicted flight of ``autopilot`` keeps beyond the margin
    (:data:`TRACKING_ALLOWANCE_M`; 0 for a flavour the model does not fly)."""
    return TRACKING_ALLOWANCE_M.get(autopilot, 0.0)


@dataclass(frozen=True, eq=False)
class Rehearsal:
    """A mission flown through the flight model.

    ``flown``: the model's record; ``track``: its samples as a file writes them;
    ``return_start``: the first sample of the autopilot's return to launch (None: the
    mission has none, or it was never reached); ``check`` / ``return_check``: the mission's
    part and the return leg measured in the scenario (None without a scenario, or without a
    return leg); ``mission``: the mission flown (None: a flight given as it was flown)."""

    flown: FlownTrack
    track: Track
    max_deviation_m: float
    return_start: int | None = None
    check: TrackCheck | None = None
    return_check: TrackCheck | None = None
    mission: MissionPlan | None = None

    @property
    def autopilot(self) -> Autopilot:
        return self.flown.autopilot

    @property
    def flight_time_s(self) -> float:
        return self.flown.flight_time_s

    @property
    def airborne_s(self) -> float | None:
        """Take-off to touchdown (None: the flight did not both take off and land)."""
        times = {e.kind: e.t_s for e in reversed(self.flown.events)}
        up, down = times.get(EventKind.TAKEOFF), times.get(EventKind.LANDED)
        if up is None or down is None:
            return None
        return down - up

    def prediction(self, margin_pad_m: float = 0.0, gave_up: str = "") -> FlightPrediction:
        """The summary ``plan`` and its report give (needs a scenario's check)."""
        if self.check is None:
            raise ValueError("a rehearsal without a scenario has no clearance to report")
        return FlightPrediction(
            autopilot=self.autopilot.label,
            flight_time_s=self.flight_time_s,
            max_deviation_m=self.max_deviation_m,
            check=self.check,
            return_check=self.return_check,
            margin_pad_m=margin_pad_m,
            gave_up=gave_up,
            flown=self.flown,
            mission=self.mission,
        )


@dataclass(frozen=True, eq=False)
class CheckSite:
    """Where a track is checked: the world (obstacles, bounds, margin, terrain), its frame,
    the datum of its heights over terrain (None: flat ground, heights above home's ground),
    how its obstacles are named, and what it is (``label``, for messages)."""

    world: World
    frame: EnuFrame
    name_of: Callable[[int], str]
    label: str
    datum_amsl_m: float | None = None
    ground: Ground | None = None
    #: what a failsafe return must clear (uavplan.verdict): the obstacles standing on the
    #: ground, the flight volume's horizontal extent and its top (site z)
    obstacles: tuple[Obstacle, ...] = ()
    bounds_xy_m: tuple[tuple[float, float], tuple[float, float]] | None = None
    top_z_m: float | None = None
    #: the highest a return may fly above the ground (m; None: no limit), for the advice
    legal_ceiling_m: float | None = DEFAULT_LEGAL_CEILING_M

    @property
    def margin_m(self) -> float:
        return self.world.margin_m

    @cached_property
    def floor(self) -> World:
        """What a failsafe return must clear here (:func:`~uavplan.worlds.return_world`):
        built once, for the way home and the verdict."""
        if self.bounds_xy_m is None:
            raise ValueError(f"{self.label}: no flight volume to check a failsafe return in")
        return return_world(self.world, self.bounds_xy_m)

    @classmethod
    def of_scenario(cls, scenario: Scenario, world: World | None = None) -> CheckSite:
        """Where ``scenario`` is planned (its site: over a DEM, the terrain too)."""
        site = scenario.site
        return cls(
            world if world is not None else build_world(scenario),
            enu_frame(site),
            scenario.obstacle_name,
            f"scenario {scenario.name}",
            site.datum_amsl_m,
            site.ground,
            tuple(site.obstacles),
            (site.bounds.x_m, site.bounds.y_m),
            float(site.bounds.z_m[1]),
            scenario.mission.legal_ceiling_m,
        )

    @classmethod
    def of_plan(
        cls,
        plan: MissionPlan,
        *,
        base: Scenario | Surroundings | None = None,
        file: str | None = None,
    ) -> CheckSite | None:
        """A QGroundControl plan's own airspace, as ``plan`` reroutes it (docs/reroute.md,
        :func:`uavplan.worlds.fence_world`): its exclusion zones (and ``base``'s obstacles and
        ground) as obstacles, its inclusion fence (or ``base``'s bounds) as the flight volume,
        ``base``'s margin or the default one. None when there is nothing to keep clear of (no
        exclusion zone, no ``base``) or no home."""
        fence = plan.fence
        excluded = any(not p.inclusion for p in fence.polygons) or any(
            not c.inclusion for c in fence.circles
        )
        if plan.home is None or not (excluded or base is not None):
            return None
        pw, _ = fence_world(plan, base=base, file=file)
        names = pw.airspace.names
        label = "the plan's geofence" if base is None else f"the plan's geofence and {base.name}"
        datum = None if pw.ground is None else pw.frame.origin.alt_m
        b = pw.airspace.bounds
        legal = DEFAULT_LEGAL_CEILING_M
        if isinstance(base, Scenario):
            legal = base.mission.legal_ceiling_m  # type: ignore[assignment]
        return cls(
            pw.world,
            pw.frame,
            lambda i: names[i],
            label,
            datum,
            pw.ground,
            tuple(pw.airspace.obstacles),
            (b.x_m, b.y_m),
            float(b.z_m[1]),
            legal,
        )

    def ground_for(self, home: GeoPoint) -> Callable[[float, float], float] | None:
        """The ground's height above ``home`` at ENU (x, y) in the frame at home (None over
        flat ground): what :func:`simulate` flies terrain-frame altitudes and landings
        over."""
        ground = self.ground
        if ground is None:
            return None
        frame = self.frame
        home_frame = EnuFrame.at(home)
        home_z = float(ground.z_at(frame.to_enu_xy([home.lat_deg], [home.lon_deg]))[0])
        # keyed by the point to the cm as one complex (a 25 km flight asks some 30,000
        # points: a tuple of two floats per key held twice the memory, left in the arenas)
        cache: dict[complex, float] = {}

        def ground_z(x: float, y: float) -> float:
            key = complex(round(x, 2), round(y, 2))
            if key not in cache:
                # one point per simulation step: the scalar conversions (the same steps as
                # the array ones, to about 1e-9 m; 20 µs instead of 0.5 ms a point)
                lat, lon, _ = home_frame.to_geodetic_point(x, y, 0.0)
                gx, gy = frame.to_enu_xy_point(lat, lon)
                cache[key] = ground.z_at_point(gx, gy) - home_z
            return cache[key]

        return ground_z

    def check(
        self, track: Track, *, takes_off: bool = True, lands: bool, allowance_m: float = 0.0
    ) -> TrackCheck:
        """``track`` measured here by the one check (:func:`uavplan.flightcheck.check_track`);
        ``allowance_m``: kept beyond the margin (a predicted track:
        :func:`tracking_allowance_m`)."""
        return check_track(
            self.world,
            track,
            self.frame,
            name_of=self.name_of,
            datum_amsl_m=self.datum_amsl_m,
            takes_off=takes_off,
            lands=lands,
            allowance_m=allowance_m,
        )


def track_of(flown: FlownTrack, source: str) -> Track:
    """The model's record as a :class:`Track` (its mode column is the mode the vehicle
    reports: PX4 Mission, then Return from its RTL; ArduPilot AUTO throughout)."""
    autopilot = flown.autopilot
    return Track(
        time_s=flown.t_s,
        lat_deg=flown.lat_deg,
        lon_deg=flown.lon_deg,
        alt_amsl_m=flown.alt_amsl_m,
        relative_alt_m=flown.z_m,
        speed_m_s=flown.speed_m_s,
        current_seq=flown.current_seq,
        mode=modes_of(flown),
        source=source,
        autopilot=autopilot.label,
    )


def modes_of(flown: FlownTrack) -> tuple[str, ...]:
    """The flight mode the vehicle reports at each sample of ``flown``: PX4 Mission, then
    Return from its RTL item; ArduPilot AUTO throughout (it flies the mission's RTL inside
    AUTO)."""
    mission = mode_named(flown.autopilot, ModeKind.MISSION).name
    rtl_at = [e.t_s for e in flown.events if e.kind is EventKind.RTL]
    if flown.autopilot != Autopilot.PX4 or not rtl_at:
        return (mission,) * len(flown.t_s)
    back = mode_named(flown.autopilot, ModeKind.RETURN).name
    return tuple(back if t >= rtl_at[0] - 1e-9 else mission for t in flown.t_s)


def rtl_start(flown: FlownTrack) -> int | None:
    """The first sample of ``flown`` flying the mission's NAV_RETURN_TO_LAUNCH (None: the
    mission has none, or it was never reached)."""
    seqs = [item.seq for item in flown.nav if item.command == int(MavCmd.NAV_RETURN_TO_LAUNCH)]
    if not seqs:
        return None
    hits = np.flatnonzero(flown.current_seq >= min(seqs))
    return int(hits[0]) if hits.size else None


def return_seq(plan: MissionPlan, autopilot: Autopilot) -> int | None:
    """The wire seq of the mission's first NAV_RETURN_TO_LAUNCH (None: it has none)."""
    wire = replace(plan, autopilot=autopilot).wire_items(MissionType.MISSION)
    for seq, item in enumerate(wire):
        if item.command == MavCmd.NAV_RETURN_TO_LAUNCH:
            return seq
    return None


def conditions_of(scenario: Scenario) -> dict[str, Any]:
    """How ``scenario``'s vehicle flies: its power model (the profile it names, default x500)
    and its wind as one (east, north) vector, at the mean height of the flight volume above
    the ground (the flight model's wind does not vary with height)."""
    from uavplan.autopilot.power import spec_for

    out: dict[str, Any] = {"vehicle": spec_for(scenario.vehicle.profile)}
    wind = scenario.wind
    if wind is not None:
        z0, z1 = scenario.bounds.z_m
        east, north = (float(v) for v in np.asarray(wind.velocity_at((z0 + z1) / 2)).ravel()[:2])
        out["wind_en_m_s"] = (east, north)
    return out


def rehearse(
    plan: MissionPlan,
    site: CheckSite | None = None,
    *,
    autopilot: Autopilot | None = None,
    params: Parameters | Mapping[str, float] | None = None,
    wind_en_m_s: tuple[float, float] = (0.0, 0.0),
    vehicle: VehicleSpec | None = None,
    check: bool = True,
) -> Rehearsal:
    """Fly ``plan`` (as ``autopilot``, default its own) through the flight model and, with
    ``site``, check the track there: the mission's part against the margin, the return leg
    apart (``check`` false: the flight only, over ``site``'s ground; the whole flight's
    verdict, :func:`uavplan.verdict.judge_flight`, checks it as one).

    Raises :class:`~uavplan.autopilot.simulate.MissionRefused` (exit 2) when the autopilot would
    refuse to start the mission, ``ValueError`` for a plan without a home."""
    flavour = autopilot or plan.autopilot
    if plan.home is None:
        raise ValueError("the plan has no home: the vehicle must stand somewhere")
    ground = None if site is None else site.ground_for(plan.home)
    if site is not None and site.ground is not None and site.datum_amsl_m is not None:
        # over a DEM home stands on the ground (as the one reading of a mission places it):
        # the vehicle's AMSL altitudes are its relative ones above that ground, whatever
        # altitude the file gives its planned home
        home = plan.home
        xy = site.frame.to_enu_xy([home.lat_deg], [home.lon_deg])
        ground_amsl = float(site.ground.z_at(xy)[0]) + site.datum_amsl_m
        plan = replace(plan, home=GeoPoint(home.lat_deg, home.lon_deg, ground_amsl))
    if vehicle is None:
        flown = simulate(
            plan, autopilot=flavour, params=params, wind_en_m_s=wind_en_m_s, ground_z=ground
        )
    else:
        flown = simulate(
            plan,
            autopilot=flavour,
            params=params,
            wind_en_m_s=wind_en_m_s,
            ground_z=ground,
            vehicle=vehicle,
        )
    track = track_of(flown, f"simulate {flown.autopilot.label}")
    rtl = return_seq(plan, flown.autopilot)
    start = None
    if rtl is not None:
        hits = np.flatnonzero(flown.current_seq >= rtl)
        start = int(hits[0]) if hits.size else None
    end = len(track) if start is None else start + 1
    planned = flown.planned_polyline_enu()
    deviation = max_deviation_m(flown.enu_m[:end], planned)
    if site is None or not check:
        return Rehearsal(flown, track, deviation, start, mission=plan)
    allowance = tracking_allowance_m(flown.autopilot)
    part = site.check(track.until(end), lands=start is None, allowance_m=allowance)
    return_check = None
    if start is not None and len(track) - start >= 2:
        back = track.since(start)
        return_check = site.check(
            back, takes_off=False, lands=flown.ended is FlightEnd.LANDED, allowance_m=allowance
        )
    return Rehearsal(flown, track, deviation, start, part, return_check, plan)


def rehearsal_of(flown: FlownTrack) -> Rehearsal:
    """A flight the model already flew, as an unchecked :class:`Rehearsal` (its track, its
    largest deviation from the legs up to its return to launch)."""
    track = track_of(flown, f"simulate {flown.autopilot.label}")
    start = rtl_start(flown)
    end = len(track) if start is None else start + 1
    deviation = max_deviation_m(flown.enu_m[:end], flown.planned_polyline_enu())
    return Rehearsal(flown, track, deviation, start)


#: track points measured together by :func:`max_deviation_m` (about 30 s of flight)
DEVIATION_CHUNK = 256


def max_deviation_m(points: np.ndarray, polyline: np.ndarray) -> float:
    """The largest distance of ``points`` ``(n, 3)`` from the polyline ``(m, 3)``: the
    maximum of :func:`~uavplan.autopilot.simulate.distance_to_polyline`, the same value, in memory
    and time that grow with n (0.0 for no points).

    That function measures every point against every segment at once, n × (m − 1) triples of
    floats: 2 GB for a 50 km flight. Here the points go in runs of :data:`DEVIATION_CHUNK`
    consecutive ones (a track's run spans a few hundred metres), and a run is measured only
    against the segments that can hold its points' nearest: a segment whose bounding box is
    farther from the run's box than some segment's endpoint is from the farthest corner of
    that box (a bound on every point's distance) is skipped. The rest are measured by
    ``distance_to_polyline`` itself, each run of consecutive segments as one polyline."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    line = np.asarray(polyline, dtype=np.float64).reshape(-1, 3)
    if len(p) == 0:
        return 0.0
    if len(line) <= 2:
        return float(distance_to_polyline(p, line).max())
    a, b = line[:-1], line[1:]
    seg_lo, seg_hi = np.minimum(a, b), np.maximum(a, b)
    worst = 0.0
    for i in range(0, len(p), DEVIATION_CHUNK):
        run = p[i : i + DEVIATION_CHUNK]
        lo, hi = run.min(axis=0), run.max(axis=0)
        # every point of the run is within `bound` of segment s's first endpoint ...
        bound = np.sqrt((np.maximum(np.abs(a - lo), np.abs(a - hi)) ** 2).sum(axis=1)).min()
        # ... and at least `gap` from any point of segment s
        gap = np.sqrt((np.maximum(0.0, np.maximum(seg_lo - hi, lo - seg_hi)) ** 2).sum(axis=1))
        near = np.flatnonzero(gap <= bound * (1.0 + 1e-9) + 1e-9)
        # consecutive candidate segments [first, last] form one polyline line[first:last + 2]
        breaks = np.flatnonzero(np.diff(near) > 1)
        firsts = np.concatenate([near[:1], near[breaks + 1]])
        lasts = np.concatenate([near[breaks], near[-1:]])
        d = np.full(len(run), np.inf)
        for first, last in zip(firsts, lasts, strict=True):
            np.minimum(d, distance_to_polyline(run, line[first : last + 2]), out=d)
        worst = max(worst, float(d.max()))
    return worst
