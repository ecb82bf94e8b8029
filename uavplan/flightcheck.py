"""The check of a flown line against a world: one implementation for every command.

A :class:`Flight` is what a vehicle flies (or flew): ENU points in a site's frame, and which
of them are in the air. The take-off climb from the ground and the landing descent to it
start or end on the ground, so they are checked against the obstacles only; everything in
between is checked against the whole world, the terrain and its ceiling included. A flight
comes from a route that was just planned (:meth:`Flight.from_polyline`), from a mission file
(:func:`flight_of_mission`: the autopilot's reading of its items, through
:func:`uavplan.mission.builder.mission_polyline_enu`, the one reconstruction) or from a
flown track (:func:`flight_of_track`: a simulated or flown
:class:`~uavplan.mission.track.Track`, with the samples where it left and reached the
ground).

:func:`check_flight` measures it: the clearance of every segment, what is nearest, and the
first point outside the flight volume. ``plan`` reports its clearance, and ``validate
MISSION --scenario``, ``render --mission`` and the rerouting of a QGroundControl plan all
check through it, so they agree to the last digit.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from uavplan.geo import EnuFrame
from uavplan.mission.builder import mission_polyline_enu
from uavplan.mission.items import MavCmd, MissionPlan
from uavplan.mission.track import Track
from uavplan.route import Follow, keeps_margin
from uavplan.world import CEILING, GROUND, World

if TYPE_CHECKING:
    from uavplan.autopilot.simulate import FlownTrack

#: consecutive points closer than this horizontally are "the same place" (a climb or a
#: descent): files round positions to about a centimetre
VERTICAL_TOL_M = 0.05
#: a flown point may be this far outside the flight volume (files round positions)
VOLUME_TOL_M = 0.05
#: ... and a flown track's sample this far: a vehicle overshoots a waypoint by a step or so
#: (PX4 settles onto a landing point at the edge of the volume 0.1 m past it in the model),
#: and a firmware's position estimate wanders while it holds: PX4 SIH, taking off from a
#: start on the edge of the bounds (the bundled scenarios start at x = 0), drifted 0.5 m and
#: more outside it at the top of its climb (CI, tests/sitl/test_sitl_fly.py, via-tour; 0.5 m
#: had been the tolerance). The volume is the operator's box, not the obstacles' margin; a
#: geofence keeps the margin and 2 m more beyond it (uavplan.mission.fence)
TRACK_VOLUME_TOL_M = 1.0


@dataclass(frozen=True, eq=False)
class Flight:
    """A flown line ``points_enu`` ``(n, 3)``; ``points_enu[airborne[0]]`` to
    ``points_enu[airborne[1]]`` are in the air, the segments before them (the take-off climb)
    and after them (the landing descent) touch the ground."""

    points_enu: NDArray[np.float64]
    airborne: tuple[int, int]

    def __post_init__(self) -> None:
        p = self.points_enu
        if p.ndim != 2 or p.shape[1] != 3 or not np.all(np.isfinite(p)):
            raise ValueError(f"a flight is finite ENU points (n, 3), got shape {p.shape}")
        first, last = self.airborne
        if len(p) and not 0 <= first <= last < len(p):
            raise ValueError(f"airborne {self.airborne} is not within {len(p)} points")

    @classmethod
    def from_polyline(
        cls, points_enu: NDArray[np.float64], *, from_ground: bool, to_ground: bool
    ) -> Flight:
        """The flight of a polyline that, with ``from_ground``, begins with a vertical climb
        from the ground (every leading point above the first: the take-off, and a climb to
        the first waypoint's height) and, with ``to_ground``, ends with a vertical descent to
        it (the landing)."""
        p = np.asarray(points_enu, dtype=np.float64).reshape(-1, 3)
        n = len(p)
        first, last = 0, max(n - 1, 0)
        if from_ground:
            while first + 1 < n and _same_place(p[first + 1], p[0]):
                first += 1
        if to_ground:
            while last - 1 > first and _same_place(p[last - 1], p[-1]):
                last -= 1
        return cls(p, (first, last))

    @property
    def length_m(self) -> float:
        return float(np.linalg.norm(np.diff(self.points_enu, axis=0), axis=1).sum())


def _same_place(a: NDArray[np.float64], b: NDArray[np.float64]) -> bool:
    return math.hypot(float(a[0] - b[0]), float(a[1] - b[1])) <= VERTICAL_TOL_M


def flight_of_mission(
    plan: MissionPlan,
    frame: EnuFrame,
    ground_z: Callable[[NDArray[np.float64]], NDArray[np.float64]] | None = None,
    follow: Follow | None = None,
) -> Flight:
    """The flight the autopilot flies through ``plan`` in ``frame``, over the ground
    ``ground_z`` (ENU ``(n, 2)`` → z; None: flat at z = 0): from home on the ground, to the
    return to launch or the landing, terrain-frame legs flown over the ground as ``follow``
    says (:meth:`uavplan.ground.Ground.follow`). Raises ``ValueError`` when an item's
    altitude cannot be placed."""
    points = mission_polyline_enu(plan, frame, ground_z, follow)
    return Flight.from_polyline(points, from_ground=plan.home is not None, to_ground=_lands(plan))


#: a landed vehicle's altitude estimate wanders by this much while it settles: samples this
#: close to the track's final altitude are the landing, not a climb (PX4 SIH, landed in CI,
#: reported 0.5 m, and on a later run 0.6 m, below home inside what the check took for the
#: flight, "outside the flight volume", tests/sitl/test_sitl_fly.py)
LANDED_NOISE_M = 1.0

#: a flown landing drifts onto its landing point while it descends (PX4 starts the descent
#: once within its acceptance radius): the final descent may begin this far from touchdown
LANDING_DRIFT_M = 15.0


def flight_of_track(
    track: Track,
    frame: EnuFrame,
    *,
    datum_amsl_m: float | None = None,
    takes_off: bool = True,
    lands: bool,
) -> Flight:
    """The flight of a flown ``track`` in ``frame`` (a site's): x/y where the ellipsoid
    normal through each sample meets the ground plane (as mission items are placed), z the
    height above home's ground over flat ground (``datum_amsl_m`` None: the relative
    altitude) or, over terrain, the altitude above the site's datum (AMSL minus the datum).

    With ``takes_off`` (the track starts on the ground) the take-off climb is the leading
    samples that climb where the track starts; with ``lands``, the landing is the trailing
    samples that only descend (or rest within :data:`LANDED_NOISE_M` of the last one's
    height), ending on the ground within :data:`LANDING_DRIFT_M` of where they touch down."""
    xy = frame.to_enu_xy(track.lat_deg, track.lon_deg) if len(track) else np.empty((0, 2))
    z = track.relative_alt_m if datum_amsl_m is None else track.alt_amsl_m - datum_amsl_m
    points = np.column_stack((xy, z)).astype(np.float64).reshape(-1, 3)
    n = len(points)
    if n == 0:
        return Flight(points, (0, 0))
    first = 0
    while (
        takes_off
        and first + 1 < n
        and _same_place(points[first + 1], points[0])
        and points[first + 1, 2] >= points[first, 2] - 1e-6
    ):
        first += 1
    last = n - 1
    if lands:
        end = points[-1]
        while (
            last - 1 > first
            and (
                points[last - 1, 2] >= points[last, 2] - 1e-6
                or abs(points[last - 1, 2] - end[2]) <= LANDED_NOISE_M
            )
            and math.hypot(*(points[last - 1, :2] - end[:2])) <= LANDING_DRIFT_M
        ):
            last -= 1
    return Flight(points, (first, last))


#: a track is thinned to within this distance before it is measured (1 cm: far below what a
#: position report resolves; a terrain world measures thousands of samples slowly)
THIN_TOL_M = 0.01


def thin_polyline(points: NDArray[np.float64], tol_m: float = THIN_TOL_M) -> NDArray[np.int64]:
    """The indices of the points of ``points`` ``(n, 3)`` to keep so that every dropped
    point lies within ``tol_m`` of the polyline through the kept ones (Douglas-Peucker; the
    first and last points are kept). A polyline's clearance then differs from the thinned
    one's by at most ``tol_m``."""
    n = len(points)
    if n <= 2:
        return np.arange(n, dtype=np.int64)
    keep = np.zeros(n, dtype=bool)
    keep[0] = keep[-1] = True
    stack = [(0, n - 1)]
    while stack:
        i, j = stack.pop()
        if j - i < 2:
            continue
        a, b = points[i], points[j]
        inner = points[i + 1 : j]
        ab = b - a
        length2 = float(ab @ ab)
        if length2 <= 1e-18:
            dist = np.linalg.norm(inner - a, axis=1)
        else:
            t = np.clip((inner - a) @ ab / length2, 0.0, 1.0)
            dist = np.linalg.norm(inner - (a + t[:, None] * ab), axis=1)
        k = int(np.argmax(dist))
        if dist[k] > tol_m:
            mid = i + 1 + k
            keep[mid] = True
            stack.append((i, mid))
            stack.append((mid, j))
    return np.flatnonzero(keep).astype(np.int64)


def _lands(plan: MissionPlan) -> bool:
    """Does the flown part of ``plan`` end with a landing (NAV_LAND before any RTL)?"""
    for item in plan.items:
        if item.command == MavCmd.NAV_RETURN_TO_LAUNCH:
            return False
        if item.command == MavCmd.NAV_LAND:
            return True
    return False


@dataclass(frozen=True, eq=False)
class FlightCheck:
    """A flight measured against a world that keeps ``margin_m``.

    ``clearance_m`` ``(n - 1,)``: each segment's distance to the nearest thing it must keep
    clear of; ``worst`` the segment with the least and ``nearest`` what that is (in words:
    ``obstacles[3]``, ``the terrain at (120, -40)``, ...); ``outside`` the first point outside
    the flight volume (None: none)."""

    flight: Flight
    clearance_m: NDArray[np.float64]
    worst: int
    nearest: str
    margin_m: float
    outside: int | None
    #: kept beyond the margin by a flight the flight model predicts, for the firmware's
    #: tracking error the model does not fly (:data:`uavplan.rehearsal.TRACKING_ALLOWANCE_M`)
    allowance_m: float = 0.0

    @property
    def min_clearance_m(self) -> float:
        return float(self.clearance_m[self.worst]) if self.clearance_m.size else math.inf

    @property
    def required_m(self) -> float:
        """The clearance the flight must keep: the margin and the allowance."""
        return self.margin_m + self.allowance_m

    @property
    def keeps_margin(self) -> bool:
        return keeps_margin(self.min_clearance_m, self.required_m)

    def margin_words(self) -> str:
        """``10 m`` or ``10 m, and 0.6 m for the autopilot's tracking error``."""
        return margin_words(self.margin_m, self.allowance_m)

    @property
    def ok(self) -> bool:
        """Inside the flight volume and never closer than the margin."""
        return self.outside is None and self.keeps_margin

    def problem(self) -> str | None:
        """What is wrong with the flight, in words (None: nothing)."""
        if self.outside is not None:
            point = self.flight.points_enu[self.outside].round(1).tolist()
            return f"point {self.outside} of the flown path {point} is outside the flight volume"
        if not self.keeps_margin:
            return (
                f"leg {self.worst} of the flown path comes within {self.min_clearance_m:.2f} m "
                f"of {self.nearest} (safety margin {self.margin_words()})"
            )
        return None


def margin_words(margin_m: float, allowance_m: float) -> str:
    """The clearance a check asks for, in words: the margin, and the tracking allowance
    kept beyond it when there is one."""
    if allowance_m <= 0.0:
        return f"{margin_m:g} m"
    return f"{margin_m:g} m, and {allowance_m:g} m for the autopilot's tracking error"


def flight_clearance(
    world: World, flight: Flight
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
    """Per segment of ``flight``: (distance, obstacle index or :data:`~uavplan.world.GROUND`
    / :data:`~uavplan.world.CEILING` or -1, nearest piece of ``world`` or -1). Airborne
    segments are measured against the whole world, the climb and the descent against its
    obstacles only (over flat ground the world holds nothing else)."""
    p = flight.points_enu
    if len(p) < 2:
        empty = np.empty(0, dtype=np.int64)
        return np.empty(0), empty, empty
    if not world.has_ground:
        dist, piece = world.segments_nearest(p[:-1], p[1:])
        return dist, world.owner_of(piece), piece
    obstacles = world.without_ground()
    dist, piece = obstacles.segments_nearest(p[:-1], p[1:])
    owner = obstacles.owner_of(piece)
    first, last = flight.airborne
    if last > first:
        d_air, p_air = world.segments_nearest(p[first:last], p[first + 1 : last + 1])
        closer = d_air < dist[first:last]
        dist[first:last] = np.where(closer, d_air, dist[first:last])
        owner[first:last] = np.where(closer, world.owner_of(p_air), owner[first:last])
        piece[first:last] = np.where(closer, p_air, piece[first:last])
    return dist, owner, piece


def check_flight(
    world: World,
    flight: Flight,
    *,
    name_of: Callable[[int], str],
    margin_m: float | None = None,
    volume_tol_m: float = VOLUME_TOL_M,
    allowance_m: float = 0.0,
) -> FlightCheck:
    """Measure ``flight`` in ``world`` (see :class:`FlightCheck`); ``name_of(i)`` names
    obstacle ``i`` of the world for the message; ``margin_m`` defaults to the world's; a
    point up to ``volume_tol_m`` outside the flight volume counts as inside;
    ``allowance_m``: kept beyond the margin (a predicted flight's tracking allowance)."""
    margin = world.margin_m if margin_m is None else float(margin_m)
    dist, owner, _ = flight_clearance(world, flight)
    p = flight.points_enu
    first, last = flight.airborne
    lifted = p.copy()  # the ground below the take-off and the landing is not "outside"
    grounded = np.ones(len(p), dtype=bool)
    grounded[first : last + 1] = False
    lifted[grounded, 2] = np.maximum(lifted[grounded, 2], world.zlim[0])
    inside = world.points_inside_bounds(lifted, tol_m=volume_tol_m)
    outside = None if inside.all() else int(np.flatnonzero(~inside)[0])
    worst = int(np.argmin(dist)) if dist.size else 0
    nearest = "nothing"
    if dist.size and owner[worst] != -1:
        nearest = _describe(world, int(owner[worst]), p[worst], p[worst + 1], name_of)
    return FlightCheck(flight, dist, worst, nearest, margin, outside, allowance_m)


def _describe(
    world: World,
    owner: int,
    a: NDArray[np.float64],
    b: NDArray[np.float64],
    name_of: Callable[[int], str],
) -> str:
    """What segment a→b comes nearest, in words: an obstacle's name, or the terrain and
    where (the closest point of its surface)."""
    if owner not in (GROUND, CEILING):
        return name_of(owner)
    _, _, where = world.terrain_nearest(a, b)
    x, y = (float(v) for v in where[0])
    if owner == CEILING:
        return f"the ceiling (bounds.z max above the ground) over ({x:.0f}, {y:.0f})"
    return f"the terrain at ({x:.0f}, {y:.0f})"


@dataclass(frozen=True, eq=False)
class TrackCheck:
    """A flown :class:`~uavplan.mission.track.Track` measured by :func:`check_flight`:
    ``check`` measured its line thinned to within :data:`THIN_TOL_M` (``samples``: the track
    sample of each point of that line), so its messages can say when and where."""

    check: FlightCheck
    samples: NDArray[np.int64]
    track: Track

    @property
    def min_clearance_m(self) -> float:
        return self.check.min_clearance_m

    @property
    def margin_m(self) -> float:
        return self.check.margin_m

    @property
    def required_m(self) -> float:
        return self.check.required_m

    def margin_words(self) -> str:
        return self.check.margin_words()

    @property
    def nearest(self) -> str:
        return self.check.nearest

    @property
    def outside(self) -> int | None:
        """The first sample outside the flight volume (None: none)."""
        out = self.check.outside
        return None if out is None else int(self.samples[out])

    @property
    def ok(self) -> bool:
        return self.check.ok

    def when(self, sample: int) -> str:
        """``3 min 05.2 s into the flight, flying to item 12,`` (the track's time)."""
        track = self.track
        minutes, seconds = divmod(float(track.time_s[sample]), 60.0)
        text = f"{int(minutes)} min {seconds:04.1f} s into the flight"
        seq = int(track.current_seq[sample])
        return text + (f", flying to item {seq}," if seq >= 0 else "")

    def problem(self) -> str | None:
        """What is wrong with the track, in words (None: nothing)."""
        check = self.check
        if check.outside is not None:
            sample = int(self.samples[check.outside])
            point = check.flight.points_enu[check.outside].round(1).tolist()
            return f"{self.when(sample)} the track is outside the flight volume at {point}"
        if not check.keeps_margin:
            sample = int(self.samples[check.worst])
            return (
                f"{self.when(sample)} the track comes within {check.min_clearance_m:.2f} m "
                f"of {check.nearest} (safety margin {check.margin_words()})"
            )
        return None


def check_track(
    world: World,
    track: Track,
    frame: EnuFrame,
    *,
    name_of: Callable[[int], str],
    datum_amsl_m: float | None = None,
    takes_off: bool = True,
    lands: bool,
    allowance_m: float = 0.0,
) -> TrackCheck:
    """``track`` (see :func:`flight_of_track`) measured in ``world`` by the one check, its
    line thinned to within :data:`THIN_TOL_M` first (the take-off and landing's ends kept);
    a sample up to :data:`TRACK_VOLUME_TOL_M` outside the volume counts as inside;
    ``allowance_m``: kept beyond the margin (a predicted track's tracking allowance)."""
    flight = flight_of_track(
        track, frame, datum_amsl_m=datum_amsl_m, takes_off=takes_off, lands=lands
    )
    first, last = flight.airborne
    # sorted and unique without np.union1d (np.unique imports numpy.ma:
    # tests/architecture/test_startup.py)
    ends = np.array([first, last], dtype=np.int64)
    kept: np.ndarray = np.sort(np.concatenate((thin_polyline(flight.points_enu), ends)))
    kept = kept[np.concatenate(([True], kept[1:] != kept[:-1]))].astype(np.int64)
    kept = kept[kept < len(flight.points_enu)]
    if len(kept):
        where = np.searchsorted(kept, [first, last])
        thinned = Flight(flight.points_enu[kept], (int(where[0]), int(where[1])))
    else:
        thinned = flight
    check = check_flight(
        world, thinned, name_of=name_of, volume_tol_m=TRACK_VOLUME_TOL_M, allowance_m=allowance_m
    )
    return TrackCheck(check, kept, track)


@dataclass(frozen=True, eq=False)
class FlightPrediction:
    """What the flight model predicts for a mission where a scenario is planned
    (:mod:`uavplan.rehearsal`): the mission flown as ``autopilot`` flies it. While ``plan``
    widens the margin it is the mission's part with the firmware's default parameters; the
    prediction ``plan`` reports is the whole flight its verdict judged
    (:mod:`uavplan.verdict`: the parameters the mission relies on, take-off to touchdown).

    ``check``: the track measured by :func:`check_flight` (the mission's part, take-off to
    where the return to launch begins, or the whole flight); ``return_check``: the return
    leg the autopilot flies on its own (None without one); ``max_deviation_m``: the largest
    distance of the mission's part from the straight legs between the items;
    ``margin_pad_m``: how much wider than the scenario's margin the route was planned so
    that the track keeps it (0: as planned). Issue 27's energy estimate joins here.
    """

    autopilot: str
    flight_time_s: float
    max_deviation_m: float
    check: TrackCheck
    return_check: TrackCheck | None = None
    margin_pad_m: float = 0.0
    #: why a wider margin could not be planned (when the track still breaks the margin)
    gave_up: str = ""
    #: the flight model's record of that flight (its energy: the vehicle's power model)
    flown: FlownTrack | None = None
    #: the mission that flight flew (built once: ``plan`` writes it)
    mission: MissionPlan | None = None

    def problem(self) -> str | None:
        """What is wrong with the predicted flight (None: nothing), with what was tried."""
        problem = self.check.problem()
        if problem is None:
            return None
        tried = f" ({self.gave_up})" if self.gave_up else ""
        return f"as {self.autopilot} flies it (the flight model): {problem}{tried}"

    @property
    def keeps_margin(self) -> bool:
        return self.check.ok

    def summary(self) -> dict[str, object]:
        """The report's ``flight`` entry."""
        ret = self.return_check
        return {
            "autopilot": self.autopilot,
            "flight_time_s": round(self.flight_time_s, 1),
            "max_deviation_m": round(self.max_deviation_m, 3),
            "min_clearance_m": _finite_or_none(self.check.min_clearance_m),
            "keeps_margin": self.keeps_margin,
            "margin_pad_m": round(self.margin_pad_m, 3),
            "return_min_clearance_m": None if ret is None else _finite_or_none(ret.min_clearance_m),
            "return_keeps_margin": None if ret is None else ret.ok,
        }


def _finite_or_none(value: float) -> float | None:
    return round(value, 3) if math.isfinite(value) else None
