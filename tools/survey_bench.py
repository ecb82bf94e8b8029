#!/usr/bin/env python3
"""uavplan's surveys against the lane patterns of the ground stations operators use (issue 33);
prints a table.

Three methods plan the same fields at the same lane angle (the one uavplan chooses), the
same spacing and trigger distance (QGroundControl's CameraCalc for the camera below), and
the same altitude; every mission is built by the same mission builder and flown by the same
flight model, judged by the same check and estimated by the same power model:

* ``uavplan``: ``uavplan plan`` on the survey scenario (holes for buildings above the
  altitude minus the margin and for ``exclude`` polygons, lanes split at every crossing,
  transitions routed around obstacles);
* ``qgc``: QGroundControl's transect rule, re-implemented from its published behaviour
  (SurveyComplexItem: each lane clipped to the polygon at the two crossings farthest apart,
  so it flies straight across concave notches; no holes, no obstacles; lanes flown in turn
  back and forth, straight between them; without the turnaround extension, which QGC's
  multirotor default sets to 10 m past each lane end (TransectStyle.SettingsGroup.json) and
  which would only lengthen its path outside the area). Over a DEM, its "follow terrain"
  (TransectStyleComplexItem, "calc above terrain", :func:`qgc_terrain_rows`): AMSL waypoints
  at the lane ends and at every terrain sample kept by its 10 m tolerance;
* ``mp``: Mission Planner's grid (ExtLibs/Utilities/Grid.cs: each lane split at every
  crossing of the polygon; no holes, no obstacles), pieces flown lane by lane back and
  forth, straight between them. Over a DEM, the lane ends in ArduPilot's terrain frame
  (Mission Planner's altitude mode "Terrain"): the autopilot follows the ground.

Over a DEM, qgc and mp take off as uavplan does and fly straight from there to their first
lane and from their last lane back (nothing routes their transitions).

Fields (seeded): convex, concave, with ``exclude`` holes, with buildings inside (some taller
than the altitude), the bundled survey of a real OpenStreetMap block of Helsinki
(missions/surveys/survey-helsinki-kamppi.yaml), fields on the ridge of the bundled DEM, and
the bundled ridge survey (missions/surveys/survey-jacksboro-ridge.yaml).

Per field and method: the length of the pattern (first lane start to last lane end) outside
the area and over the ``exclude`` (no-fly) polygons (m), the least clearance of the flight as
flown from the obstacles and the no-fly polygons (and whether it breaks the margin), the
share of the area outside the holes inside the photos' footprints,
flight time, Wh, the planning time (uavplan: the whole ``plan``, the flight model and
the verdict included; qgc and mp: the lanes only), the GSD of the photos the flight model
took (from their height above the ground as flown) and how many of them are more than 2 m
above or below the survey altitude.

    python tools/survey_bench.py            # all fields
    python tools/survey_bench.py --fields 6 # the first six
    python tools/survey_bench.py --only DEM # the fields over the DEM
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import shapely
import yaml
from shapely.geometry import LineString, Polygon
from survey_timing import CAMERA  # the same camera as the timing fields

from uavplan.survey.camera import Camera

ROOT = Path(__file__).resolve().parent.parent
KAMPPI = ROOT / "missions" / "surveys" / "survey-helsinki-kamppi.yaml"
RIDGE = ROOT / "missions" / "surveys" / "survey-jacksboro-ridge.yaml"
ALTITUDE_M = 50.0
#: where the generated DEM fields lie on the ridge (site m): 130-230 m of relief each
DEM_OFFSETS = ((-3300.0, 300.0), (-2900.0, 1100.0), (-1300.0, 300.0), (-900.0, 1500.0))
#: QGroundControl's "follow terrain" tolerance (TransectStyle.SettingsGroup.json,
#: TerrainAdjustTolerance, default 10 m; its climb and descent rate limits default to 0, off)
QGC_TERRAIN_TOLERANCE_M = 10.0


def _convex(rng: np.random.Generator) -> list[list[float]]:
    pts = rng.uniform([0, 0], [420, 320], (9, 2))
    hull = shapely.MultiPoint(pts).convex_hull
    return np.asarray(hull.exterior.coords)[:-1].round(1).tolist()


def _concave(rng: np.random.Generator, k: int) -> list[list[float]]:
    if k % 2 == 0:  # an L, a U or a C, scaled and turned
        shapes = [
            [(0, 0), (400, 0), (400, 120), (150, 120), (150, 300), (0, 300)],
            [(0, 0), (420, 0), (420, 300), (300, 300), (300, 110), (120, 110), (120, 300),
             (0, 300)],
            [(0, 0), (400, 0), (400, 90), (130, 90), (130, 210), (400, 210), (400, 300),
             (0, 300)],
        ]  # fmt: skip
        poly = Polygon(shapes[(k // 2) % 3])
        poly = shapely.affinity.rotate(poly, float(rng.uniform(0, 90)), origin="centroid")
    else:  # a star-like polygon: random radii around a centre
        n = 11
        ang = np.sort(rng.uniform(0, 2 * math.pi, n))
        r = rng.uniform(90, 200, n)
        poly = Polygon(np.column_stack([200 + r * np.cos(ang), 160 + r * np.sin(ang)]))
        if not poly.is_valid:
            poly = poly.buffer(0)
    return np.asarray(poly.exterior.coords)[:-1].round(1).tolist()


def _inside_boxes(
    rng: np.random.Generator, area: Polygon, n: int, size: tuple[float, float]
) -> list[Polygon]:
    boxes: list[Polygon] = []
    for _ in range(200):
        if len(boxes) == n:
            break
        x0, y0, x1, y1 = area.bounds
        c = rng.uniform([x0, y0], [x1, y1])
        w, h = rng.uniform(*size, 2)
        box = shapely.box(c[0] - w / 2, c[1] - h / 2, c[0] + w / 2, c[1] + h / 2)
        if area.buffer(-15).contains(box) and all(box.distance(b) > 40 for b in boxes):
            boxes.append(box)
    return boxes


def fields() -> list[tuple[str, str, dict[str, Any] | Path]]:
    """(name, kind, scenario dict or bundled file), seeded."""
    rng = np.random.default_rng(33)
    out: list[tuple[str, str, dict[str, Any] | Path]] = []
    for k in range(8):
        out.append((f"convex-{k + 1}", "convex", _scenario(_convex(rng))))
    for k in range(8):
        out.append((f"concave-{k + 1}", "concave", _scenario(_concave(rng, k))))
    for k in range(8):
        area = _convex(rng) if k % 2 == 0 else _concave(rng, k)
        holes = _inside_boxes(rng, Polygon(area), 1 + k % 3, (30, 70))
        exclude = [np.asarray(h.exterior.coords)[:-1].round(1).tolist() for h in holes]
        out.append((f"holes-{k + 1}", "holes", _scenario(area, exclude=exclude)))
    for k in range(7):
        area = _convex(rng) if k % 2 == 0 else _concave(rng, k)
        boxes = _inside_boxes(rng, Polygon(area), 2 + k % 3, (15, 35))
        obstacles = []
        for j, b in enumerate(boxes):
            (x0, y0, x1, y1) = b.bounds
            obstacles.append({
                "type": "box",
                "center": [round((x0 + x1) / 2, 1), round((y0 + y1) / 2, 1)],
                "size": [round(x1 - x0, 1), round(y1 - y0, 1)],
                "height": 80 if j % 2 == 0 else 20,  # every other one below the altitude
            })  # fmt: skip
        out.append((f"buildings-{k + 1}", "buildings", _scenario(area, obstacles=obstacles)))
    out.append(("helsinki-kamppi", "OSM block", KAMPPI))
    for k, offset in enumerate(DEM_OFFSETS):
        area = _convex(rng) if k % 2 == 0 else _concave(rng, k)
        moved = (np.asarray(area) + offset).round(1).tolist()
        out.append((f"dem-{k + 1}", "DEM", _dem_scenario(moved, offset)))
    out.append(("jacksboro-ridge", "DEM", RIDGE))
    return out


def _scenario(
    area: list[list[float]],
    *,
    exclude: list[list[list[float]]] | None = None,
    obstacles: list[dict[str, Any]] | None = None,
) -> dict[str, Any]:
    survey: dict[str, Any] = {
        "area": area,
        "altitude": ALTITUDE_M,
        "camera": CAMERA,
        "front_overlap_pct": 70,
        "side_overlap_pct": 60,
        "angle_deg": "auto",
    }
    if exclude:
        survey["exclude"] = exclude
    return {
        "name": "field",
        "origin": {"lat": 60.0, "lon": 25.0},
        "bounds": {"x": [-400, 800], "y": [-400, 700], "z": [0, 150]},
        "start": [-60, -60, 20],
        "safety_margin": 10,
        "vehicle": {"profile": "x500", "cruise_speed": 10},
        "obstacles": obstacles or [],
        "survey": survey,
    }


def _dem_scenario(area: list[list[float]], offset: tuple[float, float]) -> dict[str, Any]:
    """A field over the bundled DEM's ridge (the bundled ridge survey's site: its origin,
    terrain, bounds and masts), started 60 m off its corner."""
    data = _scenario(area)
    ridge = yaml.safe_load(RIDGE.read_text(encoding="utf-8"))
    data.update(
        origin=ridge["origin"],
        terrain=str((RIDGE.parent / ridge["terrain"]).resolve()),
        bounds=ridge["bounds"],
        start=[offset[0] - 60.0, offset[1] - 60.0, 20],
        obstacles=ridge["obstacles"],
    )
    return data


def _lane_lines(area: Polygon, angle_deg: float, spacing_m: float) -> list[LineString]:
    """The lane lines over ``area`` as uavplan spaces them (coverage.lane_offsets_m)."""
    from uavplan.survey import coverage

    a = math.radians(angle_deg)
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    corners = np.asarray(area.exterior.coords) @ rot
    u0, v0 = corners.min(axis=0) - 1.0
    u1, v1 = corners.max(axis=0) + 1.0
    vs = v0 + 1.0 + coverage.lane_offsets_m(v1 - v0 - 2.0, spacing_m)
    return [LineString(np.array([[u0, v], [u1, v]]) @ rot.T) for v in vs]


def _ends(geom: Any) -> list[np.ndarray]:
    parts = [p for p in shapely.get_parts(geom) if isinstance(p, LineString) and p.length > 0]
    return [np.asarray(p.coords)[[0, -1]] for p in parts]


def qgc_pieces(area: Polygon, angle_deg: float, spacing_m: float) -> np.ndarray:
    """Each lane from the first crossing of the polygon to the last (the two farthest)."""
    a = math.radians(angle_deg)
    along = np.array([math.cos(a), math.sin(a)])
    out = []
    for k, line in enumerate(_lane_lines(Polygon(area.exterior), angle_deg, spacing_m)):
        ends = _ends(line.intersection(Polygon(area.exterior)))
        if not ends:
            continue
        pts = np.vstack(ends)
        u = pts @ along
        piece = np.array([pts[np.argmin(u)], pts[np.argmax(u)]])
        out.append(piece if k % 2 == 0 else piece[::-1])
    return np.array(out)


def mp_pieces(area: Polygon, angle_deg: float, spacing_m: float) -> np.ndarray:
    """Each lane split at every crossing of the polygon (Grid.cs), flown lane by lane back
    and forth."""
    a = math.radians(angle_deg)
    along = np.array([math.cos(a), math.sin(a)])
    out = []
    for k, line in enumerate(_lane_lines(Polygon(area.exterior), angle_deg, spacing_m)):
        ends = _ends(line.intersection(Polygon(area.exterior)))
        pieces = [e if e[0] @ along <= e[1] @ along else e[::-1] for e in ends]
        pieces.sort(key=lambda e: float(e[0] @ along))
        if k % 2 == 1:
            pieces = [e[::-1] for e in reversed(pieces)]
        out.extend(pieces)
    return np.array(out)


def qgc_terrain_rows(
    pieces: np.ndarray, height: Any, step_m: float
) -> tuple[list[np.ndarray], list[bool], list[bool]]:
    """QGroundControl's "follow terrain" over ``pieces`` (TransectStyleComplexItem, altitude
    mode "calc above terrain"): every lane end at ``height`` (the survey altitude above the
    ground); a point at every terrain sample between them and along each turn to the next
    lane; then walking forward, a sample is kept only where its altitude differs from the last
    point kept by more than the tolerance (_adjustForTolerance). The ground is sampled every
    ``step_m`` (uavplan's own step, so both read the same terrain). Rows, lane-start and
    lane-end flags."""
    pts: list[np.ndarray] = []
    added: list[bool] = []
    start: list[bool] = []
    end: list[bool] = []

    def segment(a: np.ndarray, b: np.ndarray, lane: bool) -> None:
        n = max(2, math.ceil(float(np.hypot(*(b - a))) / step_m) + 1)
        xy = a + np.linspace(0.0, 1.0, n)[:, None] * (b - a)
        z = height(xy)
        inner = range(1, n - 1)
        for k in inner:
            pts.append(np.array([xy[k, 0], xy[k, 1], z[k]]))
            added.append(True)
            start.append(False)
            end.append(False)
        if lane:
            pts.append(np.array([xy[-1, 0], xy[-1, 1], z[-1]]))
            added.append(False)
            start.append(False)
            end.append(True)

    for j, (a, b) in enumerate(pieces):
        if j > 0:
            segment(pieces[j - 1][1], a, lane=False)
        pts.append(np.array([a[0], a[1], float(height(a[None])[0])]))
        added.append(False)
        start.append(True)
        end.append(False)
        segment(a, b, lane=True)
    rows, starts, ends = [pts[0]], [start[0]], [end[0]]
    last = pts[0][2]
    for p, was_added, s0, e0 in zip(pts[1:], added[1:], start[1:], end[1:], strict=True):
        if not was_added or abs(p[2] - last) > QGC_TERRAIN_TOLERANCE_M:
            rows.append(p)
            starts.append(s0)
            ends.append(e0)
            last = p[2]
    return rows, starts, ends


def _fly(
    scn: Any, spec: Any, pieces: np.ndarray, free: Any, angle: float, method: str, ends: Any
) -> dict[str, Any]:
    """A straight-line mission over ``pieces`` built, flown and judged as uavplan's are."""
    from uavplan.estimate import estimate_flown
    from uavplan.rehearsal import CheckSite, conditions_of
    from uavplan.survey import coverage
    from uavplan.survey.sweep import Sweep
    from uavplan.surveying import PROFILE_STEP_M, SurveyRoute, survey_height, survey_mission
    from uavplan.verdict import judge_flight

    start = np.asarray(scn.start_m, dtype=np.float64)
    alt = spec.altitude_m
    lane_end = None
    if scn.site.ground is None:
        above = np.array([start[0], start[1], alt])
        rows = [start, above]
        starts = [False, False]
        for a, b in pieces:
            rows += [np.array([a[0], a[1], alt]), np.array([b[0], b[1], alt])]
            starts += [True, False]
        rows += [above, start]
        starts += [False, False]
    else:
        # over a DEM: the lanes at the survey's height above the ground, each method its way
        # (``ends``: uavplan's start, take-off altitude above it, and its last two rows)
        height = survey_height(scn, alt)
        if method == "qgc":
            lane_rows, starts, lane_ends = qgc_terrain_rows(pieces, height, PROFILE_STEP_M)
        else:  # mp: the lane ends; the terrain frame makes the autopilot follow the ground
            lane_rows, starts, lane_ends = [], [], []
            for a, b in pieces:
                za, zb = height(np.array([a, b]))
                lane_rows += [np.array([a[0], a[1], za]), np.array([b[0], b[1], zb])]
                starts += [True, False]
                lane_ends += [False, True]
        # QGC's and MP's missions fly straight from the take-off to the first lane and from
        # the last lane back: nothing routes them over the ground in between (climbing above
        # the start to the first lane's altitude instead leaves the flight volume's ceiling)
        rows = [*ends[:2], *lane_rows, *ends[2:]]
        starts = [False, False, *starts, False, False]
        lane_end = np.array([False, False, *lane_ends, False, False])
    lengths = np.hypot(*(pieces[:, 1] - pieces[:, 0]).T)
    trig = spec.spacing.trigger_distance_m
    sweep = Sweep(angle, pieces, coverage.path_xy(pieces, start[:2]), math.nan,
                  coverage.photo_count(pieces, trig), float(lengths.sum()))  # fmt: skip
    route = SurveyRoute(sweep, free, np.vstack(rows), np.array(starts), 0, math.nan, lane_end)
    mission = survey_mission(scn, spec, route, over_terrain="terrain" if method == "mp" else "amsl")
    site = CheckSite.of_scenario(scn)
    verdict = judge_flight(mission, site, failsafe=False, **conditions_of(scn))
    assert verdict.rehearsal is not None
    estimate = estimate_flown(scn, verdict.rehearsal.flown, reserve_pct=20.0)
    return {"route": route, "verdict": verdict, "estimate": estimate}


#: a photo's height above the ground counts as off when it misses the survey altitude by more
#: than uavplan's stated tolerance (uavplan.surveying.HAG_TOLERANCE_M, 2 m)
HAG_TOLERANCE_M = 2.0


def photo_heights(scn: Any, flown: Any) -> np.ndarray:
    """The height above the ground (m) of every photo the flight model took."""
    from uavplan.autopilot.camera import photo_positions
    from uavplan.geo import EnuFrame

    photos = photo_positions(flown)  # ENU at home, z above home
    home = EnuFrame.at(flown.home)
    lat, lon, _ = home.to_geodetic(np.column_stack([photos[:, :2], np.zeros(len(photos))]))
    xy = np.asarray(EnuFrame.at(scn.site.origin).to_enu_xy(lat, lon)).reshape(-1, 2)
    site_z = flown.home.alt_m + photos[:, 2] - scn.site.origin.alt_m
    ground = scn.site.ground
    return site_z - (0.0 if ground is None else np.asarray(ground.z_at(xy), dtype=np.float64))


def _metrics(scn: Any, area: Polygon, free: Any, spec: Any, route: Any, verdict: Any,
             estimate: Any, plan_s: float) -> dict[str, Any]:  # fmt: skip
    from uavplan.survey import coverage

    w = route.waypoints_enu
    lane_rows = np.flatnonzero(route.lane_start)
    first, last = int(lane_rows[0]), int(lane_rows[-1]) + 1
    pattern = LineString(w[first : last + 1, :2])
    outside = float(pattern.difference(area.buffer(0.5)).length)
    nofly = shapely.union_all([Polygon(p) for p in spec.exclude_m]) if spec.exclude_m else None
    in_holes = 0.0 if nofly is None else float(pattern.intersection(nofly).length)
    s = spec.spacing
    photos = coverage.photo_positions(route.sweep.pieces_xy, s.trigger_distance_m)
    fp = coverage.footprints(photos, route.sweep.angle_deg, s.footprint_side_m, s.footprint_front_m)
    worst = verdict.flight_worst
    hag = photo_heights(scn, verdict.rehearsal.flown)
    gsd = Camera(**CAMERA).gsd_cm(1.0) * hag
    return {
        "gsd": (float(gsd.min()), float(gsd.mean()), float(gsd.max())),
        "hag": (float(hag.min()), float(hag.max())),
        "photos": len(hag),
        "off": int(np.sum(np.abs(hag - spec.altitude_m) > HAG_TOLERANCE_M)),
        "outside_m": outside,
        "in_holes_m": in_holes,
        "clearance_m": worst.clearance_m,
        "breach": not verdict.flight_ok,
        # what it came closest to: an obstacle's name, "the terrain", "the ceiling", ...
        "nearest": worst.nearest.split(" at ")[0].split(" (")[0].removeprefix("the "),
        "covered": coverage.covered_fraction(free, fp),
        "time_s": estimate.energy.time_s,
        "wh": estimate.energy.energy_wh,
        "plan_s": plan_s,
    }


def bench(name: str, source: dict[str, Any] | Path, work: Path) -> dict[str, dict[str, Any]]:
    from uavplan.app.feedback import Feedback
    from uavplan.app.plan import PlanRequest, plan
    from uavplan.app.survey import with_no_fly
    from uavplan.scenario.values import load_survey_scenario

    if isinstance(source, Path):
        path = source
    else:
        path = work / f"{name}.yaml"
        path.write_text(yaml.safe_dump(source))
    t0 = time.perf_counter()
    outcome = plan(
        PlanRequest(str(path), str(work / f"{name}.plan"), allow_over_battery=True), Feedback()
    )
    uav_s = time.perf_counter() - t0
    scn, spec = load_survey_scenario(path)
    scn = with_no_fly(scn, spec)  # every method judged against the same no-fly holes
    area = Polygon(spec.area_m)
    route = outcome.route  # type: ignore[union-attr]
    free = route.free
    angle = route.sweep.angle_deg
    verdict, estimate = outcome.verdict, outcome.estimate  # type: ignore[union-attr]
    rows = {"uavplan": _metrics(scn, area, free, spec, route, verdict, estimate, uav_s)}
    spacing = spec.spacing.lane_spacing_m
    for method, maker in (("qgc", qgc_pieces), ("mp", mp_pieces)):
        t0 = time.perf_counter()
        pieces = maker(area, angle, spacing)
        lanes_s = time.perf_counter() - t0
        w = route.waypoints_enu
        flown = _fly(scn, spec, pieces, free, angle, method, [w[0], w[1], w[-2], w[-1]])
        rows[method] = _metrics(scn, area, free, spec, flown["route"], flown["verdict"],
                                flown["estimate"], lanes_s)  # fmt: skip
    return rows


def _clear(m: dict[str, Any]) -> str:
    c = m["clearance_m"]
    text = "-" if not math.isfinite(c) else f"{c:.1f}"
    return text + (f" **breach** ({m['nearest']})" if m["breach"] else "")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--fields", type=int, default=None, help="only the first N fields")
    ap.add_argument("--only", default="", help="comma-separated field names or kinds")
    args = ap.parse_args()
    only = {n for n in args.only.split(",") if n}
    chosen = [f for f in fields()[: args.fields] if not only or only & {f[0], f[1]}]
    results = []
    with tempfile.TemporaryDirectory() as d:
        for name, kind, source in chosen:
            results.append((name, kind, bench(name, source, Path(d))))
            print(f"  {name} done", file=sys.stderr)
    methods = ("uavplan", "qgc", "mp")
    print(f"`python tools/survey_bench.py`, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    print()
    print("| field | kind | outside m (uavplan / qgc / mp) | over no-fly holes m (uavplan / "
          "qgc / mp) | least clearance as flown m "
          "(uavplan / qgc / mp) | covered % (uavplan / qgc / mp) | flight s (uavplan / qgc / "
          "mp) | Wh (uavplan / qgc / mp) | plan s (uavplan / qgc / mp) | GSD cm as flown, "
          "min-max (uavplan / qgc / mp) | photos off the altitude by > 2 m (uavplan / qgc / "
          "mp) |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for name, kind, r in results:
        cells = [
            " / ".join(f"{r[m]['outside_m']:.0f}" for m in methods),
            " / ".join(f"{r[m]['in_holes_m']:.0f}" for m in methods),
            " / ".join(_clear(r[m]) for m in methods),
            " / ".join(f"{100 * r[m]['covered']:.1f}" for m in methods),
            " / ".join(f"{r[m]['time_s']:.0f}" for m in methods),
            " / ".join(f"{r[m]['wh']:.1f}" for m in methods),
            " / ".join(f"{r[m]['plan_s']:.2f}" for m in methods),
            " / ".join(f"{r[m]['gsd'][0]:.2f}-{r[m]['gsd'][2]:.2f}" for m in methods),
            " / ".join(f"{r[m]['off']} of {r[m]['photos']}" for m in methods),
        ]
        print(f"| {name} | {kind} | " + " | ".join(cells) + " |")
    print()
    print("| method | fields | fields with the pattern outside the area | outside m in all | "
          "over no-fly holes m in all | margin breaches as flown | least covered % | "
          "flight time / uavplan's | Wh / uavplan's | GSD cm as flown min / mean / max | "
          "photos off the altitude by > 2 m |")  # fmt: skip
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for m in methods:
        outside = [r[m]["outside_m"] for _, _, r in results]
        t = [r[m]["time_s"] / r["uavplan"]["time_s"] for _, _, r in results]
        e = [r[m]["wh"] / r["uavplan"]["wh"] for _, _, r in results]
        print(
            f"| {m} | {len(results)} | {sum(o > 0.5 for o in outside)} | {sum(outside):.0f} | "
            f"{sum(r[m]['in_holes_m'] for _, _, r in results):.0f} | "
            f"{sum(r[m]['breach'] for _, _, r in results)} | "
            f"{100 * min(r[m]['covered'] for _, _, r in results):.1f} | "
            f"{min(t):.2f}-{max(t):.2f} (mean {np.mean(t):.2f}) | "
            f"{min(e):.2f}-{max(e):.2f} (mean {np.mean(e):.2f}) | "
            f"{min(r[m]['gsd'][0] for _, _, r in results):.2f} / "
            f"{np.mean([r[m]['gsd'][1] for _, _, r in results]):.2f} / "
            f"{max(r[m]['gsd'][2] for _, _, r in results):.2f} | "
            f"{sum(r[m]['off'] for _, _, r in results)} of "
            f"{sum(r[m]['photos'] for _, _, r in results)} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
