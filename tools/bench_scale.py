#!/usr/bin/env python3
"""How ``uavplan plan`` scales with route length, obstacle count, terrain area and map size
(issues 13, 26); prints a table for each, the first two with fitted exponents.

Scenarios are written to a temporary folder, all at the default grid (which is fitted to the
flight volume: docs/scenario-format.md, "Limits"):

* **route length** L (default 2, 5, 10, 20, 50 km): a 1.6 km wide strip from (0, 0) to
  (L, 0) with a box or tower about every 400 m near the line (60-180 m tall, ceiling 200 m),
  so the route weaves or climbs all along;
* **obstacle count** N (default 10 ... 20,000): the paper's 2 km route over a 2.2 × 2 km
  area with N boxes and towers at random places covering 8 % of it (smaller as N grows),
  10-100 m tall under a 150 m ceiling;
* **terrain**: crossings of the Jacksboro ridge on the bundled DEM (maps/jacksboro-fault-dem.tif,
  150 m ceiling above the ground, 15 m margin): 13 km across a 14 × 7 km area, and 25 km
  corner to corner of a 20 × 20 km area (the largest terrain area the limits promise);
* **district**: ``tools/make_district.py``'s 5,000 buildings (default ``--district 5000``),
  planned with ``--fence``: the ``fence`` column is building the geofence, ``process`` the
  whole ``uavplan plan --fence`` run; its fence summary line is printed under the table.

Each is measured like ``tools/bench_plan.py`` (phases in one process, then the whole
``uavplan plan -q`` process and its peak RSS), and every column is fitted as
``t ≈ a · x^b`` by least squares on log-log (``b`` printed under the table).

    python tools/bench_scale.py                        # every table
    python tools/bench_scale.py --lengths 2,5 --counts 10,1000 --no-reference
    python tools/bench_scale.py --lengths "" --counts "" --terrain "" --district 5000

``core CPU`` is the CPU time of search and post-processing (every thread), ``load`` the
machine's 1-minute load average when the row was measured.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_plan import measure
from make_district import district_yaml

ROOT = Path(__file__).resolve().parent.parent
HEAD = "origin: {lat: 47.3769, lon: 8.5417, alt: 408.0}\n"
#: the terrain crossings: name → (bounds x, bounds y, start, goal), metres from the ridge
#: scenario's origin (missions/jacksboro-ridge.yaml), heights above the ground (the 20 km
#: area's goal at 60 m: at 40 m it is within the margin of today's ground solids, DEM cells
#: up to their highest post)
RIDGES = {
    "13km": ((-7000, 7000), (-4000, 3000), (6000, -3000, 40), (-6000, 2000, 40)),
    "20x20km": ((-10000, 10000), (-10000, 10000), (9000, -9000, 60), (-9000, 9000, 60)),
}


def _obstacle(rng: np.random.Generator, x: float, y: float, size_m: float, h: float) -> str:
    if rng.random() < 0.35:
        return f"  - {{type: cylinder, center: [{x:.1f}, {y:.1f}], radius: {size_m / 2:.1f}, height: {h:.0f}}}"  # noqa: E501
    w, d = size_m * rng.uniform(0.7, 1.3), size_m * rng.uniform(0.7, 1.3)
    yaw = rng.uniform(-40, 40)
    return (
        f"  - {{type: box, center: [{x:.1f}, {y:.1f}], size: [{w:.1f}, {d:.1f}], "
        f"height: {h:.0f}, yaw: {yaw:.1f}}}"
    )


def strip(length_km: float, seed: int = 1) -> str:
    """A straight corridor of ``length_km`` with an obstacle about every 400 m."""
    rng = np.random.default_rng(seed)
    length = length_km * 1000.0
    lines = [
        f"name: strip-{length_km:g}km",
        HEAD.rstrip(),
        f"bounds: {{x: [-300, {length + 300:.0f}], y: [-800, 800], z: [0, 200]}}",
        "start: [0, 0, 30]",
        f"goal: [{length:.0f}, 0, 40]",
        "safety_margin: 10",
        "obstacles:",
    ]
    for x in np.arange(300.0, length - 250.0, 400.0):
        xo = x + rng.uniform(-100, 100)
        lines.append(
            _obstacle(rng, xo, rng.uniform(-150, 150), rng.uniform(80, 200), rng.uniform(60, 180))
        )
    return "\n".join(lines) + "\n"


def field(count: int, seed: int = 1) -> str:
    """The 2 km route over N random obstacles covering 8 % of the area."""
    rng = np.random.default_rng(seed)
    x0, x1, y0, y1 = -100.0, 2100.0, -1000.0, 1000.0
    side = min(150.0, max(3.0, math.sqrt(0.08 * (x1 - x0) * (y1 - y0) / count)))
    lines = [
        f"name: field-{count}",
        HEAD.rstrip(),
        f"bounds: {{x: [{x0:g}, {x1:g}], y: [{y0:g}, {y1:g}], z: [0, 150]}}",
        "start: [0, 0, 30]",
        "goal: [2000, 100, 40]",
        "safety_margin: 5",
        "obstacles:",
    ]
    keep = side + 20.0  # clear of the take-off and landing columns
    n = 0
    while n < count:
        x, y = rng.uniform(x0 + side, x1 - side), rng.uniform(y0 + side, y1 - side)
        if math.hypot(x, y) < keep or math.hypot(x - 2000, y - 100) < keep:
            continue
        lines.append(_obstacle(rng, x, y, side, rng.uniform(10, 100)))
        n += 1
    return "\n".join(lines) + "\n"


def ridge(name: str) -> str:
    """A crossing of the Jacksboro ridge (see :data:`RIDGES`), at the defaults."""
    (x0, x1), (y0, y1), (sx, sy, sz), (gx, gy, gz) = RIDGES[name]
    return (
        f"name: ridge-{name}\n"
        "origin: {lat: 36.59, lon: -84.25}\n"
        f"terrain: {ROOT / 'maps' / 'jacksboro-fault-dem.tif'}\n"
        f"bounds: {{x: [{x0}, {x1}], y: [{y0}, {y1}], z: [0, 150]}}\n"
        f"start: [{sx}, {sy}, {sz}]\ngoal: [{gx}, {gy}, {gz}]\n"
        "safety_margin: 15\n"
        "vehicle: {cruise_speed: 12, takeoff_altitude: 40}\n"
        "mission: {autopilot: ardupilot, spacing: 100, end: rtl, altitude: terrain}\n"
    )


COLUMNS = ("load", "build", "search", "post", "process_s")


def _label(x: Any) -> str:
    return f"{x:g}" if isinstance(x, float) else str(x)


def table(label: str, xs: list[Any], rows: list[dict[str, Any]], *, fit: bool = True) -> None:
    head = (
        f"{label:>9} {'obst':>6} {'grid m':>14} {'load s':>7} {'build s':>7} {'search s':>8} "
        f"{'post s':>6} {'core CPU':>8} {'fence s':>7} {'process s':>9} {'RSS MiB':>7} "
        f"{'iter':>5} {'E':>9} {'ref':>6} {'exit':>4} {'load':>5}"
    )
    print(head)
    print("-" * len(head))
    for x, r in zip(xs, rows, strict=True):
        grid = "×".join(f"{v:g}" for v in r["grid"])
        print(
            f"{_label(x):>9} {r['obstacles']:>6} {grid:>14} {r['load']:7.3f} {r['build']:7.3f} "
            f"{r['search']:8.2f} {r['post']:6.2f} {r['core_cpu']:8.2f} {r['fence']:7.2f} "
            f"{r['process_s']:9.2f} {r['rss_mib']:7.0f} {r['iterations']:>5} "
            f"{r['energy']:9.1f} {r['ratio']:6.3f} {r['exit']:>4} {r['loadavg']:5.2f}"
        )
    if fit:
        fits = []
        for col in COLUMNS:
            pts = [(x, r[col]) for x, r in zip(xs, rows, strict=True) if r[col] > 0 and x > 0]
            if len(pts) >= 2:
                lx, ly = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
                b = float(np.polyfit(lx, ly, 1)[0])
                fits.append(f"{col.removesuffix('_s')} {b:.2f}")
        print(f"fitted exponents b (t ~ {label}^b): " + ", ".join(fits))
    for x, r in zip(xs, rows, strict=True):
        if r.get("status") != "ok":
            print(f"  {label} {_label(x)}: {r.get('status')}: {r.get('message')}")
        if r.get("fence_summary"):
            summary = r["fence_summary"]
            print(f"  {label} {_label(x)}: {summary} ({len(summary)} characters)")
    print()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--lengths", default="2,5,10,20,50", help="route lengths, km")
    ap.add_argument("--counts", default="10,100,1000,5000,20000", help="obstacle counts")
    ap.add_argument("--terrain", default=",".join(RIDGES), help="ridge crossings")
    ap.add_argument("--district", default="5000", help="district sizes (buildings)")
    ap.add_argument("--repeat", type=int, default=1, help="runs per scenario (medians)")
    ap.add_argument("--no-reference", action="store_true", help="skip the A* reference")
    ap.add_argument("--keep", type=Path, help="write the scenarios here instead of a temp dir")
    args = ap.parse_args()
    lengths = [float(v) for v in args.lengths.split(",") if v]
    counts = [int(v) for v in args.counts.split(",") if v]
    ridges = [v for v in args.terrain.split(",") if v]
    districts = [int(v) for v in args.district.split(",") if v]
    tables: list[tuple[str, list[Any], Any, bool, bool]] = [
        ("km", lengths, strip, True, False),
        ("obstacles", counts, field, True, False),
        ("terrain", ridges, ridge, False, False),
        ("buildings", districts, district_yaml, False, True),
    ]
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        for label, xs, make, fit, fence in tables:
            if not xs:
                continue
            rows = []
            for x in xs:
                path = folder / f"{label}-{_label(x)}.yaml"
                path.write_text(make(x), encoding="utf-8")
                rows.append(measure(path, args.repeat, 0, not args.no_reference, fence))
            table(label, xs, rows, fit=fit)
    print(
        "seconds; phases as tools/bench_plan.py (default early stop, seed 1, the default grid "
        "fitted to the volume); core CPU = CPU s of search + post (all threads); ref = E / "
        "(A* + line of sight on the same grid); load = 1-minute load average"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
