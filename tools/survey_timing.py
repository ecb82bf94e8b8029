#!/usr/bin/env python3
"""How long a large survey takes to plan (issue 33); prints a table.

Two generated fields, seeded, planned by ``uavplan plan`` in a fresh process each, the whole
plan included (the coverage, the transitions, the mission, the whole-flight verdict with the
flight model's rehearsal and the failsafe returns, the battery estimate, writing the file):

* ``1km2-20holes``: a 1 km × 1 km field with 20 buildings inside, 25-45 m wide and 80 m tall
  (above the survey altitude: holes), lanes 30 m apart at 50 m, margin 10 m;
* ``2000-photos``: the same square with the RX100-class camera of the bundled survey at 60 m
  (70 % front, 60 % side overlap): about 2,000 photo positions and an hour of flight;
* ``2000-hover``: the same with ``trigger: hover``: a waypoint, a 1 s hold and a capture at
  each of the 2,000 positions (some 6,500 mission items, hours of flight).

and, for the issue's "long missions scale" (a QGC plan of 877 items rerouted):

* ``qgc-873``: a QGroundControl plan of 873 items (take-off, speed 5 m/s, 870 waypoints 90 m
  apart in 29 rows, RTL: 78 km, about 270 minutes of flight) rerouted by ``uavplan plan
  long.plan --scenario site.yaml`` around 18 boxes placed on its legs (none on the straight
  way home from the last waypoint).

All are larger than one x500 battery: they are planned with ``--allow-over-battery`` (a
survey is not split across batteries yet), so the estimate is printed as a warning.

Per field: lanes, photos, flight minutes, the child's CPU seconds (user + system, every
thread: ``os.wait4``), its wall seconds, its peak memory, and the load average. ``--profile
FIELD`` prints where the CPU of one field's plan goes instead (cProfile, the 25 functions
with the most cumulative time).

    python tools/survey_timing.py
    python tools/survey_timing.py --profile 2000-photos
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

FIELDS = ("1km2-20holes", "2000-photos", "2000-hover", "qgc-873")
CAMERA = {
    "sensor_width_mm": 13.2,
    "sensor_height_mm": 8.8,
    "image_width_px": 5472,
    "image_height_px": 3648,
    "focal_length_mm": 10.4,
    "orientation": "landscape",
}


def _buildings(n: int, seed: int) -> list[dict[str, Any]]:
    """``n`` boxes inside the field, apart from each other by at least 60 m (seeded)."""
    rng = np.random.default_rng(seed)
    placed: list[np.ndarray] = []
    out = []
    while len(out) < n:
        c = rng.uniform(80.0, 920.0, 2)
        if any(np.hypot(*(c - p)) < 60.0 for p in placed):
            continue
        placed.append(c)
        size = rng.uniform(25.0, 45.0, 2).round(1)
        out.append(
            {"type": "box", "center": c.round(1).tolist(), "size": size.tolist(), "height": 80}
        )
    return out


def scenario(field: str) -> dict[str, Any]:
    """The scenario of ``field`` (one of :data:`FIELDS`)."""
    survey: dict[str, Any] = {
        "area": [[0, 0], [1000, 0], [1000, 1000], [0, 1000]],
        "angle_deg": "auto",
        "trigger": "distance",
    }
    if field == "1km2-20holes":
        survey.update(altitude=50, lane_spacing_m=30)
    elif field in ("2000-photos", "2000-hover"):
        survey.update(altitude=60, camera=CAMERA, front_overlap_pct=70, side_overlap_pct=60)
        if field == "2000-hover":
            survey["trigger"] = "hover"
    else:
        raise SystemExit(f"unknown field {field!r}: one of {', '.join(FIELDS)}")
    return {
        "name": field,
        "origin": {"lat": 60.0, "lon": 25.0},
        "bounds": {"x": [-300, 1300], "y": [-300, 1300], "z": [0, 150]},
        "start": [-100, -100, 20],
        "safety_margin": 10,
        "vehicle": {"profile": "x500", "cruise_speed": 12},
        "obstacles": _buildings(20, seed=33) if field == "1km2-20holes" else [],
        "survey": survey,
    }


def long_qgc_plan(work: Path) -> tuple[Path, Path]:
    """The ``qgc-873`` field: a QGroundControl plan and the scenario it is rerouted in."""
    lat0, lon0 = 47.40, 8.50
    per_lat = 111_132.0
    per_lon = 111_320.0 * math.cos(math.radians(lat0))
    pts = []
    for r in range(29):
        xs = 100.0 + np.arange(30) * 90.0
        pts += [(float(x), 100.0 + 90.0 * r) for x in (xs[::-1] if r % 2 else xs)]

    def simple(command: int, frame: int, params: list[Any]) -> dict[str, Any]:
        return {"autoContinue": True, "command": command, "frame": frame, "params": params,
                "type": "SimpleItem"}  # fmt: skip

    items = [simple(22, 3, [0, 0, 0, None, lat0, lon0, 40.0])]
    items.append(simple(178, 2, [1, 5.0, -1, 0, 0, 0, 0]))
    items += [simple(16, 3, [0, 0, 0, None, lat0 + y / per_lat, lon0 + x / per_lon, 40.0])
              for x, y in pts]  # fmt: skip
    items.append(simple(20, 2, [0, 0, 0, 0, 0, 0, 0]))
    for k, item in enumerate(items):
        item["doJumpId"] = k + 1
    plan = {"fileType": "Plan", "groundStation": "QGroundControl", "version": 1,
            "geoFence": {"circles": [], "polygons": [], "version": 2},
            "rallyPoints": {"points": [], "version": 2},
            "mission": {"cruiseSpeed": 5.0, "firmwareType": 3, "globalPlanAltitudeMode": 1,
                        "hoverSpeed": 5.0, "plannedHomePosition": [lat0, lon0, 400.0],
                        "vehicleType": 2, "version": 2, "items": items}}  # fmt: skip
    rng = np.random.default_rng(1)
    home, last = np.zeros(2), np.array(pts[-1])
    u = (last - home) / np.linalg.norm(last - home)
    boxes = []
    for _ in range(20):  # on a leg, half-way between two waypoints; not on the way home
        i, r = rng.integers(0, 29, 2)
        c = np.array([145.0 + 90.0 * i, 100.0 + 90.0 * r])
        if abs(u[0] * c[1] - u[1] * c[0]) > 80.0:
            boxes.append({"type": "box", "center": c.tolist(), "size": [12, 12], "height": 80})
    site = {"name": "qgc-873", "origin": {"lat": lat0, "lon": lon0, "alt": 400.0},
            "bounds": {"x": [-300, 3200], "y": [-300, 3000], "z": [0, 150]},
            "start": [0, 0, 0], "goal": [100, 100, 40], "safety_margin": 10,
            "obstacles": boxes, "vehicle": {"profile": "x500"}}  # fmt: skip
    plan_path, site_path = work / "long.plan", work / "site.yaml"
    plan_path.write_text(json.dumps(plan))
    site_path.write_text(yaml.safe_dump(site))
    return plan_path, site_path


def command(field: str, work: Path) -> list[str]:
    """``uavplan plan``'s arguments for ``field`` (its inputs written to ``work``)."""
    out = work / f"{field}.plan"
    if field == "qgc-873":
        plan_path, site = long_qgc_plan(work)
        return ["plan", str(plan_path), "--scenario", str(site), "-o", str(out),
                "--allow-over-battery"]  # fmt: skip
    src = work / f"{field}.yaml"
    src.write_text(yaml.safe_dump(scenario(field)))
    return ["plan", str(src), "-o", str(out), "--allow-over-battery"]


def run(field: str, work: Path, tree: Path | None = None) -> dict[str, Any]:
    cmd = [sys.executable, "-m", "uavplan", *command(field, work)]
    env = dict(os.environ)
    if tree is not None:  # another checkout's uavplan (its C kernels built in place)
        env["PYTHONPATH"] = str(tree)
    t0 = time.perf_counter()
    # run in the work folder: ``python -m`` puts the current folder first on the path, which
    # would shadow ``--tree``
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env, cwd=work
    )
    assert proc.stdout is not None
    text = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    code = os.waitstatus_to_exitcode(status)
    line = next((ln for ln in text.splitlines() if ln.startswith(f"{field}.plan:")), "")
    flight = re.search(r"flight (\d+) min (\d+) s", line) or re.search(
        r"flight (\d+) min (\d+) s", text
    )
    lanes = re.search(r"(\d+) lanes", line)
    photos = re.search(r"(\d+) photos", line)
    return {
        "field": field,
        "exit": code,
        "lanes": lanes[1] if lanes else "-",
        "photos": photos[1] if photos else "-",
        "flight": f"{flight[1]} min {flight[2]} s" if flight else "-",
        "cpu_s": usage.ru_utime + usage.ru_stime,
        "wall_s": wall,
        "rss_mb": usage.ru_maxrss / 1024.0,
        "load": os.getloadavg()[0],
        "text": text,
    }


def profile(field: str, work: Path) -> None:
    import cProfile
    import pstats

    from uavplan.app.feedback import Feedback
    from uavplan.app.plan import PlanRequest, plan

    args = command(field, work)
    scenario_file = args[args.index("--scenario") + 1] if "--scenario" in args else None
    request = PlanRequest(
        args[1], args[args.index("-o") + 1], scenario=scenario_file, allow_over_battery=True
    )
    prof = cProfile.Profile()
    cpu0 = time.process_time()
    prof.enable()
    plan(request, Feedback())
    prof.disable()
    print(f"{field}: {time.process_time() - cpu0:.2f} s of CPU in plan() (imports done)")
    pstats.Stats(prof).sort_stats("cumulative").print_stats(25)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--profile", metavar="FIELD", choices=FIELDS)
    ap.add_argument("--show", action="store_true", help="print each plan's output too")
    ap.add_argument("--only", default="", help="comma-separated fields")
    ap.add_argument("--tree", type=Path, default=None,
                    help="time another checkout's uavplan (e.g. a git worktree of an older "
                         "commit with its C kernels built in place)")  # fmt: skip
    args = ap.parse_args()
    chosen = [f for f in FIELDS if not args.only or f in args.only.split(",")]
    with tempfile.TemporaryDirectory() as d:
        work = Path(d)
        if args.profile:
            profile(args.profile, work)
            return 0
        rows = [run(f, work, args.tree) for f in chosen]
    tree = f" --tree {args.tree}" if args.tree else ""
    when = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    print(f"`python tools/survey_timing.py{tree}`, {when}")
    print()
    print("| field | exit | lanes | photos | flight | CPU s | wall s | peak MB | load |")
    print("|---|---:|---:|---:|---|---:|---:|---:|---:|")
    for r in rows:
        print(
            f"| {r['field']} | {r['exit']} | {r['lanes']} | {r['photos']} | {r['flight']} | "
            f"{r['cpu_s']:.2f} | {r['wall_s']:.2f} | {r['rss_mb']:.0f} | {r['load']:.2f} |"
        )
    if args.show:
        for r in rows:
            print(f"\n--- {r['field']}\n{r['text']}")
    return 0 if all(r["exit"] == 0 for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
