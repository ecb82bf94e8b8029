"""A mission flown by ``uavplan fly`` on real firmware (tests/helpers/sitl.py), held against
``simulate``.

Used by the SITL flight tests (tests/sitl/test_sitl_fly.py) and by ``tools/sitl_compare.py``. The
flown track is the observer's (GLOBAL_POSITION_INT on its own link, stamped with the vehicle's
clock: simulated seconds); the model's is :func:`uavplan.autopilot.simulate.simulate`'s. Both are
measured the same way:

- **phases**: lift-off and touchdown where the altitude above home crosses
  :data:`AIRBORNE_M` (interpolated between samples); the take-off ends when the current item
  passes the NAV_TAKEOFF; the route ends (and the end phase, return or landing, begins) when
  the current item reaches the mission's first NAV_RETURN_TO_LAUNCH, DO_LAND_START or
  NAV_LAND;
- **track deviation**: the distance from each airborne sample of the firmware's track to the
  model's track (3-D, the model's densified to 0.25 m);
- **corner cut**: at each waypoint where the route turns, how far inside the corner a track
  passes (the least horizontal distance to the waypoint of the samples flown to it and from
  it, positive inside the turn);
- **altitude error**: on the route, the firmware's altitude less the model's at the
  horizontally nearest point of the model's route;
- **clearance**: the independent distance check of tests/helpers/track_check.py, take-off to where
  the autopilot's return begins.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from helpers import sitl
from helpers.track_check import scenario_clearance
from uavplan.autopilot.params import param_table
from uavplan.autopilot.simulate import FlownTrack, simulate
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.mission.io import load_mission
from uavplan.mission.items import Autopilot, MavCmd, MissionPlan, MissionType
from uavplan.mission.track import Track

#: issue 32's targets for the flight model against the firmware: flight time within ±3 %,
#: the return and landing within ±5 %, the track within 2 m
TIME_TOLERANCE = 0.03
END_TOLERANCE = 0.05
DEVIATION_M = 2.0
#: above this height over home the vehicle counts as in the air (both tracks alike)
AIRBORNE_M = 0.5
#: a waypoint where the route turns by less than this is no corner
MIN_TURN_DEG = 5.0
#: simulated seconds a flight may take beyond the model's before it is abandoned
EXTRA_S = 600.0


@dataclass
class FlownPath:
    """A track in the ENU frame at home: times (s), positions (m), the current item."""

    t: np.ndarray
    xyz: np.ndarray
    seq: np.ndarray
    lat: np.ndarray
    lon: np.ndarray

    def part(self, keep: np.ndarray) -> FlownPath:
        return FlownPath(
            self.t[keep], self.xyz[keep], self.seq[keep], self.lat[keep], self.lon[keep]
        )

    @classmethod
    def from_model(cls, flown: FlownTrack) -> FlownPath:
        xyz = np.column_stack((flown.x_m, flown.y_m, flown.z_m))
        return cls(
            np.asarray(flown.t_s, float),
            xyz,
            np.asarray(flown.current_seq, int),
            np.asarray(flown.lat_deg, float),
            np.asarray(flown.lon_deg, float),
        )

    @classmethod
    def from_samples(
        cls, samples: list[sitl.Sample], current: list[tuple[float, int]], home: GeoPoint
    ) -> FlownPath:
        t = np.array([s.time_s for s in samples])
        order = np.argsort(t, kind="stable")
        t = t[order]
        frame = EnuFrame.at(home)
        lat = np.array([s.lat_deg for s in samples])[order]
        lon = np.array([s.lon_deg for s in samples])[order]
        xy = np.asarray(frame.to_enu_xy(lat, lon))
        z = np.array([s.relative_alt_m for s in samples])[order]
        seq = np.full(len(t), -1, dtype=int)
        for when, value in sorted(current):
            seq[t >= when] = value
        return cls(t, np.column_stack((xy, z)), seq, lat, lon)


@dataclass(frozen=True)
class Phases:
    """Times (s, the track's clock) of lift-off, end of take-off, end of route, touchdown."""

    liftoff: float
    takeoff_done: float
    route_done: float
    touchdown: float

    @property
    def flight_s(self) -> float:
        return self.touchdown - self.liftoff

    @property
    def takeoff_s(self) -> float:
        return self.takeoff_done - self.liftoff

    @property
    def route_s(self) -> float:
        return self.route_done - self.takeoff_done

    @property
    def end_s(self) -> float:
        return self.touchdown - self.route_done


def marks(plan: MissionPlan, autopilot: Autopilot) -> tuple[int, int]:
    """The wire seq of the NAV_TAKEOFF and of the first item of the end (RTL, DO_LAND_START
    or NAV_LAND; past the last item when there is none)."""
    wire = plan.wire_items(MissionType.MISSION) if plan.autopilot == autopilot else None
    if wire is None:
        from dataclasses import replace

        wire = replace(plan, autopilot=autopilot).wire_items(MissionType.MISSION)
    takeoff = next(i for i, it in enumerate(wire) if it.command == MavCmd.NAV_TAKEOFF)
    ends = (MavCmd.NAV_RETURN_TO_LAUNCH, MavCmd.DO_LAND_START, MavCmd.NAV_LAND)
    end = next((i for i, it in enumerate(wire) if i > takeoff and it.command in ends), len(wire))
    return takeoff, end


def _crossing(t: np.ndarray, z: np.ndarray, start: int, up: bool, level: float = 0.0) -> float:
    """When ``z`` first crosses ``level`` + AIRBORNE_M upward (``up``) or downward from index
    ``start``."""
    z = z - level
    above = z > AIRBORNE_M
    idx = np.flatnonzero(above[start:] if up else ~above[start:])
    if not idx.size:
        return math.nan
    i = start + int(idx[0])
    if i == 0:
        return float(t[0])
    z0, z1 = z[i - 1], z[i]
    k = (AIRBORNE_M - z0) / (z1 - z0) if z1 != z0 else 1.0
    return float(t[i - 1] + k * (t[i] - t[i - 1]))


def landing_height(plan: MissionPlan) -> float:
    """The height above home (m) of the ground where the mission lands: its last NAV_LAND's
    altitude when that is AMSL (MAV_FRAME_GLOBAL) and not home's, else 0."""
    assert plan.home is not None
    lands = [it for it in plan.items if it.command == MavCmd.NAV_LAND]
    if not lands or lands[-1].frame != 0:
        return 0.0
    height = lands[-1].alt_m - plan.home.alt_m
    return height if abs(height) > 1.0 else 0.0


def phases(path: FlownPath, takeoff_seq: int, end_seq: int, landing_z: float = 0.0) -> Phases:
    """The phases of ``path``; touchdown where it comes down to ``landing_z`` (the ground's
    height above home where the mission lands: SITL's world is flat at home's height, so a
    vehicle landing on a hillside flies on down through it)."""
    t, z, seq = path.t, path.xyz[:, 2], path.seq
    liftoff = _crossing(t, z, 0, up=True)
    after = np.flatnonzero((seq > takeoff_seq) & (t >= liftoff))
    takeoff_done = float(t[after[0]]) if after.size else math.nan
    ending = np.flatnonzero((seq >= end_seq) & (t >= liftoff))
    route_done = float(t[ending[0]]) if ending.size else math.nan
    start = int(ending[0]) if ending.size else int(np.searchsorted(t, liftoff))
    touchdown = _crossing(t, z, start, up=False, level=landing_z)
    return Phases(liftoff, takeoff_done, route_done, touchdown)


def _dense(xyz: np.ndarray, step: float = 0.25) -> np.ndarray:
    d = np.linalg.norm(np.diff(xyz, axis=0), axis=1)
    n = np.maximum(1, np.ceil(d / step).astype(int))
    k = np.concatenate([np.arange(m) / m for m in n])
    i = np.repeat(np.arange(len(d)), n)
    return np.vstack((xyz[i] + k[:, None] * (xyz[i + 1] - xyz[i]), xyz[-1:]))


def deviation(firmware: FlownPath, model: FlownPath) -> tuple[float, float]:
    """(max, mean) distance (m) of the firmware's airborne samples from the model's track."""
    air = firmware.xyz[firmware.xyz[:, 2] > AIRBORNE_M]
    model_air = model.xyz[model.xyz[:, 2] > 0.0]
    if not len(air) or len(model_air) < 2:
        return math.nan, math.nan
    dist, _ = cKDTree(_dense(model_air)).query(air)
    return float(dist.max()), float(dist.mean())


@dataclass(frozen=True)
class Corner:
    seq: int
    turn_deg: float
    model_cut_m: float
    firmware_cut_m: float


def corners(plan: MissionPlan, autopilot: Autopilot, model: FlownPath, firmware: FlownPath):
    """The cut of each track at each corner of the route (see the module docstring)."""
    from dataclasses import replace

    wire = replace(plan, autopilot=autopilot).wire_items(MissionType.MISSION)
    assert plan.home is not None
    frame = EnuFrame.at(plan.home)
    located = [
        (seq, item)
        for seq, item in enumerate(wire)
        if item.command == MavCmd.NAV_WAYPOINT
        and item.is_global
        and (seq > 0 or autopilot == Autopilot.PX4)
    ]
    if not located:
        return []
    xy = np.asarray(frame.to_enu_xy([i.x for _, i in located], [i.y for _, i in located]))
    out: list[Corner] = []
    for k in range(1, len(located) - 1):
        seq = located[k][0]
        if located[k + 1][0] != seq + 1 and any(
            wire[j].command < 80 for j in range(seq + 1, located[k + 1][0])
        ):
            continue  # another NAV command between: no blended corner
        a, w, b = xy[k - 1], xy[k], xy[k + 1]
        u, v = w - a, b - w
        nu, nv = np.linalg.norm(u), np.linalg.norm(v)
        if nu < 1e-6 or nv < 1e-6:
            continue
        turn = math.degrees(math.acos(max(-1.0, min(1.0, float(u @ v / (nu * nv))))))
        if turn < MIN_TURN_DEG:
            continue
        inward = v / nv - u / nu  # points into the turn
        inward /= np.linalg.norm(inward)
        next_seq = located[k + 1][0]

        out.append(
            Corner(
                seq,
                turn,
                _cut(model, w, inward, seq, next_seq),
                _cut(firmware, w, inward, seq, next_seq),
            )
        )
    return out


def _cut(path: FlownPath, w: np.ndarray, inward: np.ndarray, seq: int, next_seq: int) -> float:
    """How far inside the corner ``w`` the samples flown to it and from it pass (m)."""
    near = (path.seq >= seq) & (path.seq <= next_seq) & (path.xyz[:, 2] > AIRBORNE_M)
    pts = path.xyz[near, :2]
    if not len(pts):
        return math.nan
    d = np.hypot(pts[:, 0] - w[0], pts[:, 1] - w[1])
    i = int(np.argmin(d))
    side = float((pts[i] - w) @ inward)
    return float(d[i]) if side >= 0 else -float(d[i])


def altitude_error(
    firmware: FlownPath, model: FlownPath, fw_phases: Phases, model_phases: Phases
) -> tuple[float, float]:
    """(max, mean) |altitude difference| (m) on the route (see the module docstring)."""
    f = firmware.xyz[(firmware.t >= fw_phases.takeoff_done) & (firmware.t <= fw_phases.route_done)]
    m = model.xyz[(model.t >= model_phases.takeoff_done) & (model.t <= model_phases.route_done)]
    if not len(f) or not len(m):
        return math.nan, math.nan
    _, idx = cKDTree(m[:, :2]).query(f[:, :2])
    dz = np.abs(f[:, 2] - m[idx, 2])
    return float(dz.max()), float(dz.mean())


def as_track(path: FlownPath, home: GeoPoint, source: str) -> Track:
    z = path.xyz[:, 2]
    return Track(
        time_s=path.t,
        lat_deg=path.lat,
        lon_deg=path.lon,
        alt_amsl_m=home.alt_m + z,
        relative_alt_m=z,
        speed_m_s=np.zeros(len(z)),
        current_seq=path.seq,
        source=source,
    )


def route_part(path: FlownPath, phases: Phases) -> FlownPath:
    """The track from lift-off to where the end (return or landing) begins."""
    return path.part((path.t >= phases.liftoff) & (path.t <= phases.route_done))


def clearance(scenario: Path, path: FlownPath, home: GeoPoint, phases: Phases) -> float:
    """The independent clearance (m) from lift-off to where the end (return or landing)
    begins."""
    part = route_part(path, phases)
    if len(part.t) < 2:
        return math.nan
    return scenario_clearance(scenario, as_track(part, home, "compare"))


# ---------------------------------------------------------------------------------------------
# Flying


@dataclass
class Flight:
    """One ``uavplan fly`` on SITL: its exit code and output, and what the observer saw."""

    exit_code: int
    output: str
    samples: list[sitl.Sample]
    current: list[tuple[float, int]]
    texts: list[tuple[float, str]]
    wall_s: float
    speedup: float
    params: dict[str, float] = field(default_factory=dict)

    def path(self, home: GeoPoint) -> FlownPath:
        return FlownPath.from_samples(self.samples, self.current, home)

    def save(self, path: Path) -> None:
        data = asdict(self)
        data["samples"] = [asdict(s) for s in self.samples]
        path.write_text(json.dumps(data), encoding="utf-8")

    @classmethod
    def load(cls, path: Path) -> Flight:
        data = json.loads(path.read_text(encoding="utf-8"))
        data["samples"] = [sitl.Sample(**s) for s in data["samples"]]
        data["current"] = [tuple(c) for c in data["current"]]
        data["texts"] = [tuple(c) for c in data["texts"]]
        return cls(**data)


def fly(
    plan_path: Path,
    autopilot: Autopilot,
    *,
    speedup: float = 8.0,
    scenario: Path | None = None,
    params: dict[str, float] | None = None,
    model_s: float | None = None,
    extra_args: tuple[str, ...] = (),
    before: Callable[[str], object] | None = None,
) -> Flight:
    """Start ``autopilot``'s SITL at the plan's home (``params`` at boot), run ``uavplan fly
    PLAN --upload`` against it to the end, stop it. ``model_s``: the model's flight time,
    which bounds how long the flight may take (simulated); ``before(conn)`` runs first (an
    ``upload --set-params``)."""
    plan = load_mission(plan_path)
    assert plan.home is not None
    budget_s = (model_s or 1800.0) * 1.5 + EXTRA_S
    started = time.monotonic()
    with sitl.running(autopilot, plan.home, speedup=speedup, params=params) as vehicle:
        if before is not None:
            before(vehicle.conn)
        cmd = [sys.executable, "-m", "uavplan", "fly", str(plan_path), "--conn", vehicle.conn,
               "--upload", "--quiet", "--heartbeat-timeout", "30", *extra_args]  # fmt: skip
        if scenario is not None:
            cmd += ["--scenario", str(scenario)]
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        observer = vehicle.observer
        assert observer is not None
        start_boot = observer.snapshot().boot_s
        try:
            while proc.poll() is None:
                seen = observer.snapshot()
                if seen.boot_s - start_boot > budget_s:
                    proc.kill()
                    break
                if time.monotonic() - started > budget_s:  # a wall-clock safety net only
                    proc.kill()
                    break
                time.sleep(0.5)
            out, _ = proc.communicate(timeout=60)
        finally:
            if proc.poll() is None:
                proc.kill()
        seen = observer.snapshot()
        return Flight(
            exit_code=proc.returncode,
            output=out,
            samples=seen.samples,
            current=seen.current,
            texts=seen.texts,
            wall_s=time.monotonic() - started,
            speedup=speedup,
            params=dict(params or {}),
        )


def model_flight(
    plan: MissionPlan,
    autopilot: Autopilot,
    params: dict[str, float] | None = None,
    ground_z: Callable[[float, float], float] | None = None,
) -> FlownTrack:
    return simulate(plan, autopilot=autopilot, params=params or None, ground_z=ground_z)


def plan_params(plan: MissionPlan, autopilot: Autopilot) -> dict[str, float]:
    """The plan's parameters that the flight model has: what ``--set-params`` makes the vehicle
    hold (each within the plan's bounds)."""
    names = {spec.name for spec in param_table(autopilot)}
    return {p.name: p.value for p in plan.parameters if p.name in names}


def lane_errors(
    plan_path: Path, path: FlownPath, marks: tuple[float, ...]
) -> list[tuple[int, int, float, float, list[float]]]:
    """Per photographed lane (the waypoint before a DO_SET_CAM_TRIGG_DIST > 0 to the next
    waypoint): (first item, next item, climb m, length m, the track's altitude minus the
    lane's line at each of ``marks`` metres along it)."""
    plan = load_mission(plan_path)
    assert plan.home is not None
    home = EnuFrame.at(plan.home)
    wire = plan.wire_items(MissionType.MISSION)  # the seq the tracks record
    wp = {i: it for i, it in enumerate(wire) if it.command == int(MavCmd.NAV_WAYPOINT)}
    seqs = sorted(wp)
    lat = np.array([wp[i].x for i in seqs])
    lon = np.array([wp[i].y for i in seqs])
    xy = np.asarray(home.to_enu_xy(lat, lon)).reshape(-1, 2)
    at = {s: np.array([*xy[k], wp[s].z - plan.home.alt_m]) for k, s in enumerate(seqs)}
    out = []
    for i, it in enumerate(wire):
        if it.command != int(MavCmd.DO_SET_CAM_TRIGG_DIST) or it.param1 <= 0:
            continue
        a = max(s for s in seqs if s < i)
        b = min(s for s in seqs if s > i)
        A, B = at[a], at[b]
        length = float(np.hypot(*(B[:2] - A[:2])))
        u = (B[:2] - A[:2]) / length
        pts = path.xyz[path.seq >= b]
        along = (pts[:, :2] - A[:2]) @ u
        line_z = A[2] + np.clip(along / length, 0.0, 1.0) * (B[2] - A[2])
        errs = []
        for d in marks:
            if d > length:
                errs.append(float("nan"))
                continue
            k = int(np.argmax(along >= d))
            errs.append(float(pts[k, 2] - line_z[k]))
        out.append((a, b, float(B[2] - A[2]), length, errs))
    return out
