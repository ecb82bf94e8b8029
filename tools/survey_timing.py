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

Both are larger than one x500 battery: they are planned with ``--allow-over-battery`` (a
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

FIELDS = ("1km2-20holes", "2000-photos", "2000-hover")
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


def run(field: str, work: Path) -> dict[str, Any]:
    src = work / f"{field}.yaml"
    src.write_text(yaml.safe_dump(scenario(field)))
    out = work / f"{field}.plan"
    cmd = [sys.executable, "-m", "uavplan", "plan", str(src), "-o", str(out)]
    cmd.append("--allow-over-battery")
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    assert proc.stdout is not None
    text = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    code = os.waitstatus_to_exitcode(status)
    line = next((ln for ln in text.splitlines() if ln.startswith(f"{field}.plan:")), "")
    flight = re.search(r"flight (\d+) min (\d+) s", text)
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

    src = work / f"{field}.yaml"
    src.write_text(yaml.safe_dump(scenario(field)))
    request = PlanRequest(str(src), str(work / f"{field}.plan"), allow_over_battery=True)
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
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        work = Path(d)
        if args.profile:
            profile(args.profile, work)
            return 0
        rows = [run(f, work) for f in FIELDS]
    print(f"`python tools/survey_timing.py`, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
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
