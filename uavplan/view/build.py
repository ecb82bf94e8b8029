"""What the page shows, as plain values: the scene, the mission's legs and waypoints, the
flight as flown, the way home, the profile along the route and the verdict.

Everything measured here comes from the project's own checks, never measured again another
way: the planned legs' clearances are the one mission check's per-segment clearances
(:func:`uavplan.flightcheck.check_flight`, which the caller runs through
``uavplan.app.check``), the flown legs' those of the flight model's track (or a track from
``fly``) measured by :func:`uavplan.flightcheck.check_track` (:class:`uavplan.rehearsal.CheckSite`),
the way home the flight model's return and the proof of :func:`uavplan.wayhome.prove_rtl`.
This module groups those values by leg, places them in the scene's frame and writes them out
as a JSON-ready document (:func:`mission_document`, :func:`scenario_document`) that
:mod:`uavplan.view.page` puts in the page.

A **leg** is the flight into one positional mission item (the take-off climb, a waypoint,
the landing: the items the autopilot flies to, in order), numbered from 1. A leg is red
when its planned line or its flown track comes closer than the margin; the planned legs'
segments are those of the mission check's line (:func:`leg_of_segments`), the flown track's
samples belong to the leg of the item the vehicle reports flying to (``current_seq``).
"""

from __future__ import annotations

import base64
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from uavplan.flavour import Autopilot
from uavplan.flightcheck import (
    VERTICAL_TOL_M,
    Flight,
    FlightCheck,
    TrackCheck,
    flight_clearance,
    flight_of_track,
    thin_polyline,
)
from uavplan.geo import EnuFrame
from uavplan.mission.fence import Footprint, footprints_of
from uavplan.mission.items import MavCmd, MissionPlan
from uavplan.mission.track import Track
from uavplan.rehearsal import CheckSite, Rehearsal, conditions_of, rehearse, return_seq
from uavplan.route import keeps_margin
from uavplan.scenario import Scenario
from uavplan.view.mesh import Mesh, closed_rings, footprint_rings, prism_mesh
from uavplan.world import World
from uavplan.worlds import enu_frame

__all__ = [
    "FIRMWARE",
    "Flown",
    "flown_of_rehearsal",
    "flown_of_track",
    "fly_mission",
    "leg_of_segments",
    "mission_document",
    "mission_waypoints",
    "scenario_document",
]

#: the terrain surface is drawn on at most this many posts a side
TERRAIN_POSTS = 120
#: the slider replays at most this many positions of a flight
MAX_FRAMES = 1500
#: a flown line is drawn thinned to within this distance (m): far below a pixel
DRAW_TOL_M = 0.05
#: the profile samples the ground and the obstacles' tops at most this many points ...
PROFILE_SAMPLES = 3000
#: ... and no closer than this (m)
PROFILE_STEP_M = 0.5
#: how the page names each firmware
FIRMWARE = {Autopilot.ARDUPILOT: "ArduPilot", Autopilot.PX4: "PX4"}
#: commands from here on are not navigation (they do not move the vehicle)
_FIRST_NON_NAV_COMMAND = 100


@dataclass(frozen=True, eq=False)
class Flown:
    """A flight as flown: the flight model's (:func:`flown_of_rehearsal`) or a track from
    ``fly`` (:func:`flown_of_track`). ``check``: its mission part measured by the one
    check, ``return_check``: the autopilot's return after ``return_start`` (the first sample
    of it), ``battery_left_pct``: the share of the usable battery left at each sample (None:
    the track does not say), ``autopilot``: as which firmware it numbers its items."""

    track: Track
    label: str
    autopilot: Autopilot
    check: TrackCheck | None = None
    return_check: TrackCheck | None = None
    return_start: int | None = None
    battery_left_pct: NDArray[np.float64] | None = None
    rtl_altitude_m: float | None = None


def fly_mission(
    scenario: Scenario,
    plan: MissionPlan,
    site: CheckSite,
    *,
    autopilot: Autopilot | None = None,
    params: Mapping[str, float] | None = None,
) -> Flown:
    """``plan`` flown through the flight model in ``scenario`` (its vehicle and wind) with
    the parameters the plan relies on (its RTL altitude: what ``upload --set-params`` sets)
    and ``params`` over them. Raises :class:`~uavplan.autopilot.simulate.MissionRefused` when the
    autopilot would not start it."""
    from uavplan.autopilot.params import param_table

    flavour = autopilot or plan.autopilot
    known = {spec.name for spec in param_table(flavour)}
    values = {p.name: float(p.value) for p in plan.parameters if p.name in known}
    values.update(params or {})
    rehearsal = rehearse(plan, site, autopilot=flavour, params=values, **conditions_of(scenario))
    where = "the plan's parameters" if values else "its default parameters"
    name = FIRMWARE.get(flavour, flavour.label)
    return flown_of_rehearsal(rehearsal, f"flight model: {name} with {where}")


def flown_of_rehearsal(rehearsal: Rehearsal, label: str) -> Flown:
    """A rehearsed flight: its track, checks and the battery at every step."""
    from uavplan.wayhome import RTL_PARAMETERS

    flown = rehearsal.flown
    power = np.asarray(flown.power_w, dtype=np.float64)
    battery = None
    if len(power) == len(flown.t_s) and len(power):
        used_wh = np.concatenate(([0.0], np.cumsum(power[1:] * np.diff(flown.t_s)) / 3600.0))
        battery = 100.0 - 100.0 * used_wh / flown.vehicle.usable_wh
    rtl = None
    spec = RTL_PARAMETERS.get(rehearsal.autopilot)
    if spec is not None:
        rtl = float(flown.params[spec.name]) / spec.per_m
    return Flown(
        rehearsal.track,
        label,
        rehearsal.autopilot,
        rehearsal.check,
        rehearsal.return_check,
        rehearsal.return_start,
        battery,
        rtl,
    )


def flown_of_track(track: Track, plan: MissionPlan, site: CheckSite, label: str) -> Flown:
    """A track flown by ``fly`` (or written by ``simulate``) placed in ``site`` and checked
    as ``render --track`` checks it: the mission's part apart from the autopilot's return."""
    autopilot = plan.autopilot
    for flavour in (Autopilot.PX4, Autopilot.ARDUPILOT):
        if track.autopilot.lower() == flavour.label.lower():
            autopilot = flavour
    start = None
    rtl = return_seq(plan, autopilot)
    if rtl is not None:
        hits = np.flatnonzero(track.current_seq >= rtl)
        start = int(hits[0]) if hits.size else None
    lands = bool(len(track) and track.relative_alt_m[-1] < 0.5)
    if len(track) < 2:
        return Flown(track, label, autopilot)
    end = len(track) if start is None else start + 1
    check = site.check(track.until(end), lands=lands and start is None)
    back = None
    if start is not None and len(track) - start >= 2:
        back = site.check(track.since(start), takes_off=False, lands=lands)
    return Flown(track, label, autopilot, check, back, start)


# ---------------------------------------------------------------------------------------------
# legs and waypoints


def mission_waypoints(plan: MissionPlan) -> list[tuple[int, int]]:
    """The items the autopilot flies to, in order, as (index in ``plan.items``, command): the
    positional navigation items up to a landing or a return to launch (the mission check's
    line, :func:`uavplan.mission.builder.mission_polyline_enu`, flies exactly these)."""
    out: list[tuple[int, int]] = []
    for index, item in enumerate(plan.items):
        if item.command == MavCmd.NAV_RETURN_TO_LAUNCH:
            break
        if item.is_global and item.command < _FIRST_NON_NAV_COMMAND:
            out.append((index, int(item.command)))
        if item.command == MavCmd.NAV_LAND:
            break
    return out


def leg_of_segments(
    points_enu: NDArray[np.float64], targets_xy: NDArray[np.float64], *, from_home: bool
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Which leg each segment of a mission's line ``points_enu`` ``(n, 3)`` flies, for the
    legs' target positions ``targets_xy`` ``(k, 2)`` in order (``from_home``: the line starts
    at home, before the first target; else at the first target). Returns each segment's leg
    ``(n - 1,)`` (0-based) and the vertex where each leg ends ``(k,)``.

    A leg ends at the first vertex after the last leg's end that stands over its target,
    and with it the vertical run that follows there (the landing's descent belongs to the
    landing); targets at one place in a row (a climb between two waypoints stacked) end one
    vertex after the other."""
    p = np.asarray(points_enu, dtype=np.float64).reshape(-1, 3)
    targets = np.asarray(targets_xy, dtype=np.float64).reshape(-1, 2)
    n, k = len(p), len(targets)
    ends = np.zeros(k, dtype=np.int64)
    if n < 2 or k == 0:
        return np.zeros(max(n - 1, 0), dtype=np.int64), ends
    vertical = np.hypot(*(p[1:, :2] - p[:-1, :2]).T) <= VERTICAL_TOL_M
    lo = 1 if from_home else 0
    last = 0
    for leg in range(k):
        near = np.hypot(*(p[lo:, :2] - targets[leg]).T) <= VERTICAL_TOL_M
        hits = np.flatnonzero(near)
        if not hits.size:  # not on the line (cannot happen for the line of these items)
            ends[leg] = last
            continue
        end = lo + int(hits[0])
        stacked = leg + 1 < k and math.hypot(*(targets[leg + 1] - targets[leg])) <= VERTICAL_TOL_M
        if not stacked:
            while end < n - 1 and vertical[end]:  # the descent (or climb) that follows there
                end += 1
        ends[leg] = last = end
        lo = end + 1
        if lo >= n:
            ends[leg + 1 :] = end
            break
    seg = np.minimum(np.searchsorted(ends, np.arange(n - 1), side="right"), k - 1)
    return seg.astype(np.int64), ends


def _targets(
    plan: MissionPlan, frame: EnuFrame, waypoints: Sequence[tuple[int, int]]
) -> NDArray[np.float64]:
    """Each waypoint's horizontal position as the mission check's line places it (a take-off
    climbs where the vehicle stands, a landing at 0, 0 lands where it is)."""
    items = [plan.items[i] for i, _ in waypoints]
    xy = frame.to_enu_xy([it.lat_deg for it in items], [it.lon_deg for it in items])
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    prev = None
    if plan.home is not None:
        prev = np.asarray(frame.to_enu_xy([plan.home.lat_deg], [plan.home.lon_deg]))[0]
    for j, item in enumerate(items):
        takeoff = item.command == MavCmd.NAV_TAKEOFF
        here = item.command == MavCmd.NAV_LAND and item.x == 0.0 and item.y == 0.0
        if prev is not None and (takeoff or here):
            xy[j] = prev
        prev = xy[j]
    return xy


def _planned_return_from(plan: MissionPlan) -> int | None:
    """The index in ``plan.items`` of its DO_LAND_START (a planned return follows), or None."""
    for index, item in enumerate(plan.items):
        if item.command == MavCmd.DO_LAND_START:
            return index
    return None


# ---------------------------------------------------------------------------------------------
# the document


class _Z:
    """Site z ↔ altitude AMSL, and the ground's height under points."""

    def __init__(self, scenario: Scenario) -> None:
        site = scenario.site
        self.site = site
        self.datum = site.origin.alt_m if site.datum_amsl_m is None else site.datum_amsl_m

    def amsl(self, z: Any) -> Any:
        return np.asarray(z, dtype=np.float64) + self.datum

    def ground(self, xy: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.asarray(self.site.ground_z(np.asarray(xy).reshape(-1, 2)), dtype=np.float64)


def _b64(values: Any, dtype: str) -> dict[str, str]:
    """A typed array the page decodes (little-endian; ``f4``, ``f8``, ``u4``, ``i4``)."""
    arr = np.ascontiguousarray(np.asarray(values), dtype=np.dtype("<" + dtype))
    return {"dtype": dtype, "bdata": base64.b64encode(arr.tobytes()).decode("ascii")}


def _r(values: Any, digits: int = 2) -> list[Any]:
    """Numbers for the JSON document, rounded (NaN and infinities as None)."""
    arr = np.round(np.asarray(values, dtype=np.float64), digits)
    return [None if not math.isfinite(v) else float(v) for v in arr.ravel()]


def _num(value: float | None, digits: int = 2) -> float | None:
    if value is None or not math.isfinite(value):
        return None
    return round(float(value), digits)


def _mesh_doc(mesh: Mesh, z: _Z) -> dict[str, Any]:
    v = mesh.vertices
    return {
        "x": _b64(v[:, 0], "f4"),
        "y": _b64(v[:, 1], "f4"),
        "z": _b64(z.amsl(v[:, 2]), "f4"),
        "i": _b64(mesh.triangles[:, 0], "u4"),
        "j": _b64(mesh.triangles[:, 1], "u4"),
        "k": _b64(mesh.triangles[:, 2], "u4"),
        "owner": _b64(mesh.owner, "u4"),
        "triangles": len(mesh),
    }


def _scene_doc(scenario: Scenario, z: _Z, plan: MissionPlan | None) -> dict[str, Any]:
    """The ground, the obstacles as one mesh, the fence's zones, the flight bounds."""
    site = scenario.site
    footprints = footprints_of(site.obstacles)
    tops = np.array([fp.height_m for fp in footprints], dtype=np.float64)
    base: Any = 0.0
    if site.ground is not None and footprints:
        xy, ring_of = footprint_rings(footprints)
        base = np.full(len(footprints), np.inf)
        np.minimum.at(base, ring_of, z.ground(xy))
        base = np.where(np.isfinite(base), base, 0.0)
    mesh = prism_mesh(footprints, base, tops)
    heights = [float(o.height_m) for o in scenario.obstacles]
    lat, lon = _centres_geodetic(footprints, enu_frame(site))
    obstacles = [
        {
            "name": scenario.obstacle_name(i),
            "kind": fp.kind,
            "height_m": _num(heights[i] if i < len(heights) else fp.height_m, 1),
            "top_amsl_m": _num(float(z.amsl(fp.height_m)), 1),
            "lat": _num(float(lat[i]), 7),
            "lon": _num(float(lon[i]), 7),
        }
        for i, fp in enumerate(footprints)
    ]
    (x0, x1), (y0, y1), (z0, z1) = site.bounds.x_m, site.bounds.y_m, site.bounds.z_m
    doc: dict[str, Any] = {
        "obstacles": obstacles,
        "mesh": _mesh_doc(mesh, z),
        "bounds": {"x": [x0, x1], "y": [y0, y1], "z": _r(z.amsl([z0, z1]), 2)},
        "terrain": None,
        "fence": [],
        "margin_m": scenario.safety_margin_m,
    }
    if site.ground is not None:
        nx = ny = TERRAIN_POSTS
        xs, ys = np.linspace(x0, x1, nx), np.linspace(y0, y1, ny)
        grid = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
        ground = z.ground(grid).reshape(ny, nx)
        ceiling = ground + float(site.ground.ceiling_agl_m)
        doc["terrain"] = {
            "x": _r(xs, 1),
            "y": _r(ys, 1),
            "z": _b64(z.amsl(ground).ravel(), "f4"),
            "ceiling": _b64(z.amsl(ceiling).ravel(), "f4"),
            "shape": [ny, nx],
            "ceiling_agl_m": float(site.ground.ceiling_agl_m),
        }
    if plan is not None:
        doc["fence"] = _fence_docs(plan, enu_frame(site), z, (z0, z1))
    return doc


def _centres_geodetic(
    footprints: Sequence[Footprint], frame: EnuFrame
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Each footprint's centre (the mean of its outline's vertices) as latitude, longitude."""
    if not footprints:
        return np.empty(0), np.empty(0)
    xy, ring_of = footprint_rings(footprints, tol_m=0.0)
    count = np.bincount(ring_of, minlength=len(footprints)).astype(np.float64)
    cx = np.bincount(ring_of, weights=xy[:, 0], minlength=len(footprints)) / np.maximum(count, 1)
    cy = np.bincount(ring_of, weights=xy[:, 1], minlength=len(footprints)) / np.maximum(count, 1)
    lat, lon, _ = frame.to_geodetic(np.column_stack((cx, cy, np.zeros(len(cx)))))
    return lat, lon


def _fence_docs(
    plan: MissionPlan, frame: EnuFrame, z: _Z, zlim: tuple[float, float]
) -> list[dict[str, Any]]:
    """The plan's geofence zones as volumes, from the ground to the top of the flight
    volume: the inclusion zone (walls and a lid) and the exclusion zones, one mesh each."""
    fence = plan.fence
    zones: dict[bool, list[Footprint]] = {True: [], False: []}
    for poly in fence.polygons:
        lat, lon = np.asarray(poly.vertices, dtype=np.float64).T
        ring = np.asarray(frame.to_enu_xy(lat, lon), dtype=np.float64)
        zones[poly.inclusion].append(
            Footprint(len(zones[poly.inclusion]), "prism", 1.0, ring_enu=tuple(map(tuple, ring)))
        )
    for circle in fence.circles:
        ((cx, cy),) = np.asarray(frame.to_enu_xy([circle.center[0]], [circle.center[1]]))
        zones[circle.inclusion].append(
            Footprint(
                len(zones[circle.inclusion]),
                "cylinder",
                1.0,
                center_enu=(float(cx), float(cy)),
                radius_m=circle.radius_m,
            )
        )
    out = []
    for inclusion, fps in zones.items():
        if not fps:
            continue
        mesh = prism_mesh(fps, zlim[0], np.full(len(fps), zlim[1]), tol_m=0.0)
        out.append({"inclusion": inclusion, "zones": len(fps), "mesh": _mesh_doc(mesh, z)})
    return out


def scenario_document(scenario: Scenario, *, title: str, source: str) -> dict[str, Any]:
    """The page of a scenario alone: its scene, the route's points, no mission."""
    z = _Z(scenario)
    site = scenario.site
    points = np.array(site.route_points(), dtype=np.float64)
    names = ["start", *(f"via {i + 1}" for i in range(len(site.via_m))), "goal"]
    ground = z.ground(points[:, :2])
    return {
        "title": title,
        "source": source,
        "scene": _scene_doc(scenario, z, None),
        "route_points": {
            "x": _r(points[:, 0]),
            "y": _r(points[:, 1]),
            "z": _r(z.amsl(points[:, 2])),
            "text": [
                f"{name}: ({x:.0f}, {y:.0f}) m, {float(z.amsl(zz)):.1f} m AMSL, "
                f"{zz - g:.1f} m above the ground"
                for name, (x, y, zz), g in zip(names, points, ground, strict=True)
            ],
        },
        "mission": None,
        "verdict": {
            "ok": None,
            "problems": [],
            "lines": [
                f"{scenario.name}: {len(scenario.obstacles)} obstacles, safety margin "
                f"{scenario.safety_margin_m:g} m; no mission (plan one: uavplan plan {source} "
                "-o M.plan --view page.html)"
            ],
        },
    }


def mission_document(
    scenario: Scenario,
    plan: MissionPlan,
    flight: Flight,
    check: FlightCheck,
    *,
    world: World,
    flown: Flown | None,
    title: str,
    source: str,
    notes: Sequence[str] = (),
    way_home: Sequence[tuple[str, str]] = (),
) -> dict[str, Any]:
    """The page of a mission file flown in ``scenario``: ``flight`` and ``check`` are the one
    mission check's (``uavplan.app.check.mission_flight`` / ``check_flight_in``), ``world``
    the scenario's world (which obstacle each segment passes nearest), ``flown`` the flight
    as flown (None: not flown), ``way_home`` lines about the way home (the proof)."""
    z = _Z(scenario)
    site = scenario.site
    frame = enu_frame(site)
    margin = scenario.safety_margin_m
    points = flight.points_enu
    wps = mission_waypoints(plan)
    targets = _targets(plan, frame, wps)
    seg_leg, ends = leg_of_segments(points, targets, from_home=plan.home is not None)
    n_legs = len(wps)
    land_start = _planned_return_from(plan)

    # the planned legs: each one's least clearance by the one check
    clearance = check.clearance_m
    planned_min = np.full(n_legs, np.inf)
    if clearance.size and n_legs:
        np.minimum.at(planned_min, seg_leg, clearance)
    _, owner, _ = flight_clearance(world, flight)
    near: dict[int, float] = {}
    _nearest(near, owner, clearance)

    # waypoints: where the line reaches each
    wp_xyz = points[ends] if len(points) else np.zeros((0, 3))
    lat, lon = np.empty(0), np.empty(0)
    if n_legs:  # where the items are placed: on the frame's ground plane (the builder's rule)
        on_plane = np.column_stack((wp_xyz[:, :2], np.zeros(n_legs)))
        lat, lon, _ = frame.to_geodetic(on_plane)
    ground_wp = z.ground(wp_xyz[:, :2]) if n_legs else np.empty(0)

    flown_doc = None
    flown_min = np.full(n_legs, np.inf)
    if flown is not None:
        flown_doc = _flown_doc(flown, frame, z, plan, wps, flown_min, near, world, points, ends)
    red = ~np.array(
        [keeps_margin(min(a, b), margin) for a, b in zip(planned_min, flown_min, strict=True)],
        dtype=bool,
    ).reshape(-1)
    seq_offset = 1 if plan.autopilot == Autopilot.ARDUPILOT else 0
    legs = []
    for k, (item, command) in enumerate(wps):
        legs.append(
            {
                "leg": k + 1,
                "item": item,
                "seq": item + seq_offset,
                "command": _command_name(command),
                "planned_m": _num(planned_min[k]),
                "flown_m": _num(flown_min[k]),
                "red": bool(red[k]),
                "planned_return": land_start is not None and item > land_start,
            }
        )
    waypoints = {
        "x": _r(wp_xyz[:, 0]),
        "y": _r(wp_xyz[:, 1]),
        "z": _r(z.amsl(wp_xyz[:, 2])),
        "lat": _r(lat, 7),
        "lon": _r(lon, 7),
        "agl": _r(wp_xyz[:, 2] - ground_wp),
    }
    obstacles_near = {str(i): _num(d) for i, d in sorted(near.items())}
    planned_doc = {
        "x": _r(points[:, 0]),
        "y": _r(points[:, 1]),
        "z": _r(z.amsl(points[:, 2])),
        "leg": [int(v) for v in seg_leg],
        "clearance": _r(clearance),
    }
    profile = _profile(scenario, z, points, seg_leg, clearance, flown_doc)
    verdict = _verdict(scenario, plan, check, flown, legs, notes, way_home)
    scene = _scene_doc(scenario, z, plan)
    for i, d in near.items():
        if 0 <= i < len(scene["obstacles"]):
            scene["obstacles"][i]["nearest_m"] = _num(d)
    return {
        "title": title,
        "source": source,
        "scene": scene,
        "route_points": None,
        "mission": {
            "autopilot": plan.autopilot.label,
            "items": len(plan.items),
            "legs": legs,
            "red_legs": [leg["leg"] for leg in legs if leg["red"]],
            "waypoints": waypoints,
            "planned": planned_doc,
            "flown": flown_doc,
            "profile": profile,
            "obstacles_near": obstacles_near,
        },
        "verdict": verdict,
    }


_COMMANDS = {
    MavCmd.NAV_WAYPOINT: "waypoint",
    MavCmd.NAV_TAKEOFF: "take-off",
    MavCmd.NAV_LAND: "landing",
}


def _command_name(command: int) -> str:
    for cmd, name in _COMMANDS.items():
        if command == cmd:
            return name
    try:
        return MavCmd(command).name
    except ValueError:
        return f"command {command}"


def _nearest(near: dict[int, float], owner: NDArray[np.int64], dist: NDArray[np.float64]) -> None:
    """Per obstacle, the least distance of the segments it is the nearest thing to."""
    keep = owner >= 0
    if not keep.any():
        return
    ids = owner[keep]
    best = np.full(int(ids.max()) + 1, np.inf)
    np.minimum.at(best, ids, dist[keep])
    for i in np.flatnonzero(np.isfinite(best)):
        near[int(i)] = min(near.get(int(i), math.inf), float(best[i]))


def _flown_doc(
    flown: Flown,
    frame: EnuFrame,
    z: _Z,
    plan: MissionPlan,
    wps: Sequence[tuple[int, int]],
    flown_min: NDArray[np.float64],
    near: dict[int, float],
    world: World,
    planned: NDArray[np.float64],
    ends: NDArray[np.int64],
) -> dict[str, Any]:
    """The flight as flown: its line (thinned to within :data:`DRAW_TOL_M`), the return
    apart, its replay frames, and its least clearance per leg (into ``flown_min``)."""
    track = flown.track
    site = z.site
    placed = flight_of_track(track, frame, datum_amsl_m=site.datum_amsl_m, lands=False)
    p = placed.points_enu
    n = len(p)
    offset = 1 if flown.autopilot == Autopilot.ARDUPILOT else 0
    wp_seq = np.array([i + offset for i, _ in wps], dtype=np.int64)
    # the leg of each sample: the item the vehicle reports flying to (before the first:
    # the first leg; past the last: the return)
    leg = np.searchsorted(wp_seq, np.maximum(track.current_seq, 0), side="left")
    leg = np.where(track.current_seq < 0, 0, leg)
    ret = flown.return_start
    if ret is not None:
        leg[ret:] = len(wps)
    mission_end = n if ret is None else ret + 1

    def measured(check: TrackCheck | None, base: int, by_leg: bool) -> dict[str, Any] | None:
        """The one check's measurement of a part of the track, for the page: its verdict
        as it is; with ``by_leg`` its line split where the vehicle starts a new leg (the
        samples there lie within the check's thinning tolerance of its line, so each leg's
        least clearance is measured on its own segments by the same kernel)."""
        if check is None or not check.check.clearance_m.size:
            return None
        fc = check.check
        samples = check.samples + base
        if by_leg:
            lo, hi = int(samples[0]), int(samples[-1])
            change = np.flatnonzero(np.diff(leg[lo : hi + 1])) + lo + 1
            kept = np.concatenate((samples, change, change - 1))
            kept = np.unique(kept[(kept >= lo) & (kept <= hi)])
            first, last = (int(samples[i]) for i in fc.flight.airborne)
            a, b = (int(v) for v in np.searchsorted(kept, [first, last]))
            split = Flight(p[kept], (a, b))
            dist, owner, _ = flight_clearance(world, split)
            pts = split.points_enu
        else:
            kept = samples
            dist = fc.clearance_m
            _, owner, _ = flight_clearance(world, fc.flight)
            pts = fc.flight.points_enu
        _nearest(near, owner, dist)
        seg_leg = leg[np.minimum(kept[:-1], n - 1)]  # a segment flies its first sample's leg
        return {
            "sample": [int(v) for v in kept],
            "x": _r(pts[:, 0]),
            "y": _r(pts[:, 1]),
            "z": _r(z.amsl(pts[:, 2])),
            "leg": [int(v) for v in seg_leg],
            "clearance": _r(dist),
            "min_m": _num(fc.min_clearance_m),
            "ok": bool(fc.ok),
            "problem": check.problem(),
            "_dist": dist,
        }

    mission = measured(flown.check, 0, True)
    if mission is not None:
        seg_leg_arr = np.array(mission["leg"], dtype=np.int64)
        values = mission.pop("_dist")
        inside = seg_leg_arr < len(wps)
        if inside.any():
            np.minimum.at(flown_min, seg_leg_arr[inside], values[inside])
    back = measured(flown.return_check, 0 if ret is None else ret, False)
    if back is not None:
        back.pop("_dist")
    # the line drawn: thinned, the mission's part and the return's
    keep = thin_polyline(p, DRAW_TOL_M) if n > 2 else np.arange(n)
    if ret is not None:  # the line home starts where the return does
        keep = np.unique(np.concatenate((keep, np.array([ret], dtype=keep.dtype))))
    frames = np.unique(np.linspace(0, n - 1, min(n, MAX_FRAMES)).round().astype(np.int64))
    distance = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))))
    along = _along_planned(planned, ends, leg, distance, len(wps))
    ground = z.ground(p[:, :2])
    battery = flown.battery_left_pct
    modes = track.mode
    return {
        "label": flown.label,
        "samples": n,
        "line": {
            "sample": [int(v) for v in keep],
            "x": _r(p[keep, 0]),
            "y": _r(p[keep, 1]),
            "z": _r(z.amsl(p[keep, 2])),
        },
        "mission_end": int(mission_end),
        "return_start": None if ret is None else int(ret),
        "rtl_altitude_m": _num(flown.rtl_altitude_m),
        "check": mission,
        "return_check": back,
        "frames": {
            "sample": [int(v) for v in frames],
            "t": _r(track.time_s[frames], 1),
            "x": _r(p[frames, 0]),
            "y": _r(p[frames, 1]),
            "z": _r(z.amsl(p[frames, 2])),
            "agl": _r(p[frames, 2] - ground[frames], 1),
            "speed": _r(track.speed_m_s[frames], 1),
            "seq": [int(v) for v in track.current_seq[frames]],
            "leg": [int(v) for v in leg[frames]],
            "battery": None if battery is None else _r(battery[frames], 1),
            "mode": [modes[int(i)] for i in frames] if modes else None,
            "s": _r(along[frames], 1),
        },
        "profile": {
            "s": _r(along[keep], 1),
            "z": _r(z.amsl(p[keep, 2])),
            "sample": [int(v) for v in keep],
        },
    }


def _along_planned(
    planned: NDArray[np.float64],
    ends: NDArray[np.int64],
    leg: NDArray[np.int64],
    distance: NDArray[np.float64],
    n_legs: int,
) -> NDArray[np.float64]:
    """Each track sample's place along the planned line (m): its progress through its leg
    (by its own distance flown) stretched onto that leg's length on the planned line; the
    return beyond the line's end by the distance flown."""
    seg = np.linalg.norm(np.diff(planned, axis=0), axis=1) if len(planned) > 1 else np.zeros(0)
    s_vertex = np.concatenate(([0.0], np.cumsum(seg)))
    if n_legs == 0 or not len(s_vertex):
        return distance.copy()
    leg_end = s_vertex[ends]
    leg_start = np.concatenate(([0.0], leg_end[:-1]))
    out = np.empty_like(distance)
    in_mission = leg < n_legs
    d0 = np.full(n_legs + 1, np.inf)
    d1 = np.full(n_legs + 1, -np.inf)
    np.minimum.at(d0, leg, distance)
    np.maximum.at(d1, leg, distance)
    k = np.minimum(leg, n_legs - 1)
    span = np.where(d1[k] > d0[k], d1[k] - d0[k], 1.0)
    t = np.clip((distance - d0[k]) / span, 0.0, 1.0)
    out[in_mission] = (leg_start[k] + t * (leg_end[k] - leg_start[k]))[in_mission]
    if (~in_mission).any():
        first = float(d0[n_legs]) if math.isfinite(d0[n_legs]) else 0.0
        out[~in_mission] = s_vertex[-1] + distance[~in_mission] - first
    return out


def _profile(
    scenario: Scenario,
    z: _Z,
    points: NDArray[np.float64],
    seg_leg: NDArray[np.int64],
    clearance: NDArray[np.float64],
    flown: dict[str, Any] | None,
) -> dict[str, Any]:
    """Along the planned line: its altitude, the ground beneath, the highest obstacle top
    beneath (sampled), and the clearance of each segment."""
    import shapely

    seg = np.linalg.norm(np.diff(points, axis=0), axis=1) if len(points) > 1 else np.zeros(0)
    s_vertex = np.concatenate(([0.0], np.cumsum(seg)))
    length = float(s_vertex[-1])
    count = int(min(PROFILE_SAMPLES, max(2, math.ceil(length / PROFILE_STEP_M) + 1)))
    s = np.linspace(0.0, length, count)
    xy = np.column_stack(
        [np.interp(s, s_vertex, points[:, 0]), np.interp(s, s_vertex, points[:, 1])]
    )
    ground = z.ground(xy)
    top = np.full(count, np.nan)
    footprints = footprints_of(z.site.obstacles)
    if footprints:
        outline, ring_of = footprint_rings(footprints, tol_m=0.0)
        starts = np.r_[0, np.flatnonzero(ring_of[1:] != ring_of[:-1]) + 1]
        closed, ring_ids = closed_rings(outline, ring_of, starts)
        polys = shapely.polygons(shapely.linearrings(closed, indices=ring_ids))
        heights = np.array([footprints[int(ring_of[a])].height_m for a in starts])
        tree = shapely.STRtree(polys)
        at, which = tree.query(shapely.points(xy), predicate="intersects")
        if at.size:
            best = np.full(count, -np.inf)
            np.maximum.at(best, at, heights[which])
            top = np.where(np.isfinite(best), best, np.nan)
    leg_edges = np.flatnonzero(np.diff(seg_leg)) + 1 if seg_leg.size else np.empty(0, np.int64)
    return {
        "s": _r(s, 1),
        "ground": _r(z.amsl(ground)),
        "obstacle_top": _r(z.amsl(top)),
        "line_s": _r(s_vertex, 2),
        "leg_start_s": _r(s_vertex[leg_edges], 1),
        "margin_m": scenario.safety_margin_m,
        "length_m": _num(length, 1),
        "flown": flown is not None,
    }


def _verdict(
    scenario: Scenario,
    plan: MissionPlan,
    check: FlightCheck,
    flown: Flown | None,
    legs: Sequence[dict[str, Any]],
    notes: Sequence[str],
    way_home: Sequence[tuple[str, str]],
) -> dict[str, Any]:
    """What could go wrong, first: every problem of the planned line, the flight as flown and
    the return; then what holds."""
    margin = scenario.safety_margin_m
    problems: list[str] = []
    lines: list[str] = []
    problem = check.problem()
    if problem is not None:
        problems.append(f"planned (the mission check): {problem}")
    else:
        lines.append(
            f"planned: min clearance {check.min_clearance_m:.2f} m from {check.nearest} "
            f"(margin {margin:g} m)"
        )
    if flown is not None:
        if flown.check is not None:
            flown_problem = flown.check.problem()
            if flown_problem is not None:
                problems.append(f"as flown ({flown.label}): {flown_problem}")
            else:
                lines.append(
                    f"as flown ({flown.label}): min clearance "
                    f"{flown.check.min_clearance_m:.2f} m from {flown.check.nearest}"
                )
        if flown.return_check is not None:
            back = flown.return_check
            altitude = "" if flown.rtl_altitude_m is None else f" at {flown.rtl_altitude_m:g} m"
            if back.problem() is not None:
                problems.append(f"the return to launch{altitude} ({flown.label}): {back.problem()}")
            else:
                lines.append(
                    f"the return to launch{altitude}: min clearance {back.min_clearance_m:.2f} m"
                )
    red = [leg["leg"] for leg in legs if leg["red"]]
    if red:
        problems.insert(
            0,
            f"{len(red)} leg(s) under the {margin:g} m margin: "
            + ", ".join(f"leg {k}" for k in red),
        )
    warnings: list[str] = []
    for level, line in way_home:  # "ok", "problem" (exit 3) or "warning" (a failsafe's)
        {"ok": lines, "problem": problems, "warning": warnings}[level].append(line)
    lines.extend(notes)
    return {
        "ok": not problems and not warnings,
        "problems": problems,
        "warnings": warnings,
        "lines": lines,
    }
