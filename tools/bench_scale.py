#!/usr/bin/env python3
"""How ``uavplan plan`` scales with route length and obstacle count (issue 13); prints two
tables with fitted exponents.

Synthetic scenarios are written to a temporary folder:

* **route length** L (default 2, 5, 10, 20, 50 km): a 1.6 km wide strip from (0, 0) to
  (L, 0) with a box or tower about every 400 m near the line (60-180 m tall, ceiling 200 m),
  so the route weaves or climbs all along;
* **obstacle count** N (default 10 ... 20,000): the paper's 2 km route over a 2.2 × 2 km
  area with N boxes and towers at random places covering 8 % of it (smaller as N grows),
  10-100 m tall under a 150 m ceiling.

Each is measured like ``tools/bench_plan.py`` (phases in one process, then the whole
``uavplan plan -q`` process and its peak RSS), and every column is fitted as
``t ≈ a · x^b`` by least squares on log-log (``b`` printed under the table).

    python tools/bench_scale.py                        # both tables
    python tools/bench_scale.py --lengths 2,5 --counts 10,1000 --no-reference
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

HEAD = "origin: {lat: 47.3769, lon: 8.5417, alt: 408.0}\n"


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


COLUMNS = ("load", "build", "search", "post", "process_s")


def table(label: str, xs: list[float], rows: list[dict[str, Any]]) -> None:
    head = (
        f"{label:>8} {'obst':>6} {'load s':>7} {'build s':>7} {'search s':>8} {'post s':>6} "
        f"{'process s':>9} {'RSS MiB':>7} {'iter':>5} {'E':>9} {'ref':>6} {'exit':>4}"
    )
    print(head)
    print("-" * len(head))
    for x, r in zip(xs, rows, strict=True):
        print(
            f"{x:>8g} {r['obstacles']:>6} {r['load']:7.3f} {r['build']:7.3f} {r['search']:8.2f} "
            f"{r['post']:6.2f} {r['process_s']:9.2f} {r['rss_mib']:7.0f} {r['iterations']:>5} "
            f"{r['energy']:9.1f} {r['ratio']:6.3f} {r['exit']:>4}"
        )
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
            print(f"  {label} {x:g}: {r.get('status')}: {r.get('message')}")
    print()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--lengths", default="2,5,10,20,50", help="route lengths, km")
    ap.add_argument("--counts", default="10,100,1000,5000,20000", help="obstacle counts")
    ap.add_argument("--repeat", type=int, default=1, help="runs per scenario (medians)")
    ap.add_argument("--no-reference", action="store_true", help="skip the A* reference")
    ap.add_argument("--keep", type=Path, help="write the scenarios here instead of a temp dir")
    args = ap.parse_args()
    lengths = [float(v) for v in args.lengths.split(",") if v]
    counts = [int(v) for v in args.counts.split(",") if v]
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        for label, xs, make in (("km", lengths, strip), ("obstacles", counts, field)):
            if not xs:
                continue
            rows = []
            for x in xs:
                path = folder / f"{label}-{x:g}.yaml"
                path.write_text(make(x), encoding="utf-8")  # type: ignore[operator]
                rows.append(measure(path, args.repeat, 0, not args.no_reference))
            table(label, xs, rows)
    print(
        "seconds; phases as tools/bench_plan.py (default early stop, seed 1); ref = E / "
        "(A* + line of sight)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
