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
  back and forth, the turnaround distance 0 of a multirotor);
* ``mp``: Mission Planner's grid (ExtLibs/Utilities/Grid.cs: each lane split at every
  crossing of the polygon; no holes, no obstacles), pieces flown lane by lane back and
  forth, straight between them.

Fields (seeded): convex, concave, with ``exclude`` holes, with buildings inside (some taller
than the altitude), and the bundled survey of a real OpenStreetMap block of Helsinki
(missions/surveys/survey-helsinki-kamppi.yaml). None is over a DEM: a survey over a DEM is
refused by uavplan today, so there is nothing to compare there.

Per field and method: the length of the pattern (first lane start to last lane end) outside
the area and over the ``exclude`` (no-fly) polygons (m), the least clearance of the flight as
flown from the obstacles and the no-fly polygons (and whether it breaks the margin), the
share of the area outside the holes inside the photos' footprints,
flight time, Wh, and the planning time (uavplan: the whole ``plan``, the flight model and
the verdict included; qgc and mp: the lanes only). GSD is the same everywhere over flat
ground (one altitude), so it is not a column.

    python tools/survey_bench.py            # all fields
    python tools/survey_bench.py --fields 6 # the first six
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

ROOT = Path(__file__).resolve().parent.parent
KAMPPI = ROOT / "missions" / "surveys" / "survey-helsinki-kamppi.yaml"
ALTITUDE_M = 50.0


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


def _fly(scn: Any, spec: Any, pieces: np.ndarray, free: Any, angle: float) -> dict[str, Any]:
    """A straight-line mission over ``pieces`` built, flown and judged as uavplan's are."""
    from uavplan.estimate import estimate_flown
    from uavplan.rehearsal import CheckSite, conditions_of
    from uavplan.survey import coverage
    from uavplan.survey.sweep import Sweep
    from uavplan.surveying import SurveyRoute, survey_mission
    from uavplan.verdict import judge_flight

    start = np.asarray(scn.start_m, dtype=np.float64)
    alt = spec.altitude_m
    above = np.array([start[0], start[1], alt])
    rows = [start, above]
    starts = [False, False]
    for a, b in pieces:
        rows += [np.array([a[0], a[1], alt]), np.array([b[0], b[1], alt])]
        starts += [True, False]
    rows += [above, start]
    starts += [False, False]
    lengths = np.hypot(*(pieces[:, 1] - pieces[:, 0]).T)
    trig = spec.spacing.trigger_distance_m
    sweep = Sweep(angle, pieces, coverage.path_xy(pieces, start[:2]), math.nan,
                  coverage.photo_count(pieces, trig), float(lengths.sum()))  # fmt: skip
    route = SurveyRoute(sweep, free, np.vstack(rows), np.array(starts), 0, math.nan)
    mission = survey_mission(scn, spec, route)
    site = CheckSite.of_scenario(scn)
    verdict = judge_flight(mission, site, failsafe=False, **conditions_of(scn))
    assert verdict.rehearsal is not None
    estimate = estimate_flown(scn, verdict.rehearsal.flown, reserve_pct=20.0)
    return {"route": route, "verdict": verdict, "estimate": estimate}


def _metrics(area: Polygon, free: Any, spec: Any, route: Any, verdict: Any, estimate: Any,
             plan_s: float) -> dict[str, Any]:  # fmt: skip
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
    return {
        "outside_m": outside,
        "in_holes_m": in_holes,
        "clearance_m": worst.clearance_m,
        "breach": not verdict.flight_ok,
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
    rows = {"uavplan": _metrics(area, free, spec, route, verdict, estimate, uav_s)}
    spacing = spec.spacing.lane_spacing_m
    for method, maker in (("qgc", qgc_pieces), ("mp", mp_pieces)):
        t0 = time.perf_counter()
        pieces = maker(area, angle, spacing)
        lanes_s = time.perf_counter() - t0
        flown = _fly(scn, spec, pieces, free, angle)
        rows[method] = _metrics(area, free, spec, flown["route"], flown["verdict"],
                                flown["estimate"], lanes_s)  # fmt: skip
    return rows


def _clear(m: dict[str, Any]) -> str:
    c = m["clearance_m"]
    text = "-" if not math.isfinite(c) else f"{c:.1f}"
    return text + (" **breach**" if m["breach"] else "")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--fields", type=int, default=None, help="only the first N fields")
    args = ap.parse_args()
    chosen = fields()[: args.fields]
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
          "mp) | Wh (uavplan / qgc / mp) | plan s (uavplan / qgc / mp) |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|")
    for name, kind, r in results:
        cells = [
            " / ".join(f"{r[m]['outside_m']:.0f}" for m in methods),
            " / ".join(f"{r[m]['in_holes_m']:.0f}" for m in methods),
            " / ".join(_clear(r[m]) for m in methods),
            " / ".join(f"{100 * r[m]['covered']:.1f}" for m in methods),
            " / ".join(f"{r[m]['time_s']:.0f}" for m in methods),
            " / ".join(f"{r[m]['wh']:.1f}" for m in methods),
            " / ".join(f"{r[m]['plan_s']:.2f}" for m in methods),
        ]
        print(f"| {name} | {kind} | " + " | ".join(cells) + " |")
    print()
    print("| method | fields | fields with the pattern outside the area | outside m in all | "
          "over no-fly holes m in all | margin breaches as flown | least covered % | "
          "flight time / uavplan's | Wh / uavplan's |")  # fmt: skip
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
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
            f"{min(e):.2f}-{max(e):.2f} (mean {np.mean(e):.2f}) |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
