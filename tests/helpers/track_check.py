"""An independent check of a flown track, for tests/app/test_fly.py and tools/fly_all.py.

The distances are the end-to-end test's own (tests/app/test_end_to_end.py: polygons and cylinders
computed here, scipy over the raw DEM posts), not the library's kernels. They measure whatever
track they are given: the whole flight (issue 37: take-off to touchdown, the return to launch
included), or :func:`mission_part`, the track up to where the return to launch begins.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from helpers.independent import (
    _edge_distance,
    _inside,
    densify,
    independent_clearance,
    independent_ground,
)
from uavplan.geo import EnuFrame
from uavplan.mission.items import Autopilot, MissionPlan
from uavplan.mission.track import Track
from uavplan.obstacles import CylinderObstacle, PrismObstacle
from uavplan.rehearsal import return_seq
from uavplan.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]


def scenario_for(source: Path, autopilot: Autopilot, work: Path) -> Path:
    """The scenario to plan ``source`` as, for a flight against the simulated vehicle:
    jacksboro-ridge with AMSL altitudes (a copy in ``work``, the DEM beside it). PX4 flies no
    terrain frames, and the simulated vehicle has no terrain database: it would fly
    ArduPilot's terrain-frame altitudes over flat ground (``simulate`` and ``plan`` fly them
    over the DEM)."""
    del autopilot  # both flavours: see above
    if source.stem != "jacksboro-ridge":
        return source
    shutil.copy(ROOT / "maps" / "jacksboro-fault-dem.tif", work / "dem.tif")
    text = source.read_text(encoding="utf-8").replace("../maps/jacksboro-fault-dem.tif", "dem.tif")
    copy = work / "jacksboro-ridge-amsl.yaml"
    copy.write_text(text.replace("altitude: terrain", "altitude: amsl"), encoding="utf-8")
    return copy


def mission_part(track: Track, plan: MissionPlan, autopilot: Autopilot) -> Track:
    """The track up to where the autopilot's return to launch begins."""
    rtl = return_seq(plan, autopilot)
    if rtl is None:
        return track
    hits = np.flatnonzero(track.current_seq >= rtl)
    return track.until(int(hits[0]) + 1 if hits.size else len(track))


def scenario_clearance(scenario_path: Path, track: Track) -> float:
    """The least distance from the track's samples (joined, 0.5 m apart) to the scenario's
    obstacles and, over a DEM, to the ground from where the take-off has climbed the margin
    to where the landing descends below it (the take-off and the landing touch the ground)."""
    scenario = load_scenario(scenario_path)
    site = scenario.site
    frame = EnuFrame.at(site.origin)
    xy = frame.to_enu_xy(track.lat_deg, track.lon_deg)
    z = track.relative_alt_m if site.ground is None else track.alt_amsl_m - site.origin.alt_m
    points = np.column_stack((xy, z))
    keep = np.concatenate(([True], np.any(np.diff(points, axis=0) != 0, axis=1)))
    dense = densify(points[keep], 0.5)
    best = float(independent_clearance(scenario, dense).min())
    if site.ground is not None:
        agl = dense[:, 2] - independent_ground(scenario, frame)(dense[:, :2])
        climbed = np.flatnonzero(agl >= scenario.safety_margin_m)
        if climbed.size:
            best = min(best, float(agl[climbed[0] : climbed[-1] + 1].min()))
    return best


def fence_clearance(plan: MissionPlan, track: Track) -> float:
    """The least distance from the track to the plan's exclusion zones and to the edge of its
    inclusion fence (negative outside it)."""
    assert plan.home is not None
    frame = EnuFrame.at(plan.home)
    xy = frame.to_enu_xy(track.lat_deg, track.lon_deg)
    points = densify(np.column_stack((xy, track.relative_alt_m)), 0.5)
    obstacles: list[object] = []
    inclusion = []
    for poly in plan.fence.polygons:
        ring = frame.to_enu_xy([v[0] for v in poly.vertices], [v[1] for v in poly.vertices])
        if poly.inclusion:
            inclusion.append(np.asarray(ring))
        else:
            obstacles.append(PrismObstacle(tuple((float(x), float(y)) for x, y in ring), 1e4))
    for circle in plan.fence.circles:
        ((cx, cy),) = frame.to_enu_xy([circle.center[0]], [circle.center[1]])
        obstacles.append(CylinderObstacle((float(cx), float(cy)), circle.radius_m, 1e4))
    fake = SimpleNamespace(site=SimpleNamespace(obstacles=obstacles))
    best = float(independent_clearance(fake, points).min()) if obstacles else float("inf")
    for ring in inclusion:
        px, py = points[:, 0], points[:, 1]
        edge = _edge_distance(px, py, ring)
        best = min(best, float(np.where(_inside(px, py, ring), edge, -edge).min()))
    return best
