#!/usr/bin/env python3
"""Write a reproducible synthetic city district: ``n`` buildings on a street grid, and a route
across it (issue 26: the large-map benchmark of ``tools/bench_scale.py``).

Buildings stand on 40 m plots (streets between them): rotated rectangles (boxes) 10-26 m a
side and every seventh an L-shaped prism; most are 6-45 m tall, one in ten a tower of
60-110 m, under a 120 m ceiling with a 5 m margin. The route runs at 40 m from a street
crossing near one corner to the crossing near the opposite corner, so it flies over the low
blocks, around the towers, and passes thousands of buildings a geofence has to sort.
The same ``n`` and ``--seed`` always give the same file.

    python tools/make_district.py -o district.yaml                 # 5,000 buildings
    python tools/make_district.py -n 20000 --seed 2 -o big.yaml
    uavplan plan district.yaml -o district.plan --fence
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

#: the plot pitch (m): buildings at most 26 m wide leave streets of at least 14 m
PITCH_M = 40.0


def district_yaml(n: int = 5000, seed: int = 1) -> str:
    """The scenario file's text: ``n`` buildings (see the module doc)."""
    rng = np.random.default_rng(seed)
    side = math.ceil(math.sqrt(n))
    half = PITCH_M * side / 2
    lines = [
        f"name: district-{n}",
        "origin: {lat: 47.3769, lon: 8.5417, alt: 408.0}",
        f"bounds: {{x: [{-half - 40:g}, {half + 40:g}], y: [{-half - 40:g}, {half + 40:g}], "
        "z: [0, 120]}",
    ]
    # street crossings near two opposite corners (a plot corner: clear of every building)
    corner = (side // 2 - 1) * PITCH_M - PITCH_M / 2
    lines += [f"start: [{-corner:g}, {-corner:g}, 40]", f"goal: [{corner:g}, {corner:g}, 40]"]
    lines += ["safety_margin: 5", "mission: {spacing: 50}", "obstacles:"]
    for k in range(n):
        cx = (k % side - side / 2 + 0.5) * PITCH_M
        cy = (k // side - side / 2 + 0.5) * PITCH_M
        w, d = rng.uniform(10, 26), rng.uniform(10, 26)
        yaw = rng.uniform(-17, 17)
        tower = rng.random() < 0.1
        h = rng.uniform(60, 110) if tower else rng.uniform(6, 45)
        if k % 7 == 3:  # an L shape
            ring = [(-w / 2, -d / 2), (w / 2, -d / 2), (w / 2, 0), (0, 0), (0, d / 2),
                    (-w / 2, d / 2)]  # fmt: skip
            c, s = math.cos(math.radians(yaw)), math.sin(math.radians(yaw))
            xy = [(cx + c * u - s * v, cy + s * u + c * v) for u, v in ring]
            pts = ", ".join(f"[{x:.2f}, {y:.2f}]" for x, y in xy)
            lines.append(f"  - {{type: prism, polygon: [{pts}], height: {h:.1f}}}")
        else:
            lines.append(
                f"  - {{type: box, center: [{cx:.2f}, {cy:.2f}], size: [{w:.2f}, {d:.2f}], "
                f"height: {h:.1f}, yaw: {yaw:.1f}}}"
            )
    return "\n".join(lines) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("-n", type=int, default=5000, help="buildings (default 5000)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("-o", "--output", type=Path, required=True)
    args = ap.parse_args()
    args.output.write_text(district_yaml(args.n, args.seed), encoding="utf-8")
    print(f"wrote {args.output}: {args.n} buildings")
    return 0


if __name__ == "__main__":
    sys.exit(main())
