#!/usr/bin/env python3
"""Long routes: what a coarser grid and split legs buy against the default grid (issue 26,
item 4); prints a table behind docs/algorithm.md, "Long routes".

On ``tools/bench_scale.py``'s straight corridors (``--lengths``, default 20 and 50 km), each
seed is planned in-process with:

* ``20 m``: the default grid 20 × 20 × 10 m (what every route had before grids were fitted);
* ``fitted``: the grid the scenario gets at the defaults (docs/scenario-format.md, "Limits");
* ``40 m``: coarse to fine: the swarm on a 40 × 40 × 20 m grid, the post-processing's
  pattern search (16, 4, 1 m) then moving the vertices off the grid;
* ``split``: the route cut into legs of about ``--leg-km`` (via points on the start→goal line,
  moved sideways until they keep the margin), each leg planned on the default grid.

Columns: CPU seconds of ``plan_route`` (search and post-processing, every thread), its wall
time, iterations (summed over legs), and the energy over the A* + line-of-sight reference on
the default 20 m grid (one reference for every variant, so the grids compete on equal terms).
Means over ``--seeds``.

    python tools/long_route_study.py                       # 20 and 50 km, seeds 1-3
    python tools/long_route_study.py --lengths 50 --seeds 1,2,3,4,5
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_scale import strip

from uavplan import planning
from uavplan.config import GridSpec
from uavplan.errors import ScenarioError
from uavplan.scenario import Scenario, load_scenario
from uavplan.warmup import warm_up


def split(scn: Scenario, leg_m: float) -> Scenario:
    """``scn`` with via points about every ``leg_m`` on its start→goal line (moved sideways
    in 25 m steps until the scenario accepts them)."""
    (sx, sy, sz), (gx, gy, gz) = scn.start_m, scn.goal_m
    n = max(1, round(math.hypot(gx - sx, gy - sy) / leg_m))
    via: list[tuple[float, float, float]] = []
    for k in range(1, n):
        t = k / n
        x, y, z = sx + t * (gx - sx), sy + t * (gy - sy), sz + t * (gz - sz)
        for dy in (0, 25, -25, 50, -50, 75, -75, 100, -100, 150, -150, 200, -200):
            try:
                dataclasses.replace(scn, via_m=(*via, (x, y + dy, z)))
            except ScenarioError:
                continue
            via.append((x, y + dy, z))
            break
    return dataclasses.replace(scn, via_m=tuple(via))


def run(scn: Scenario, world: object, seed: int) -> tuple[float, float, int, float]:
    scn = scn.with_planner(search=dataclasses.replace(scn.planner.search, seed=seed))
    c0, t0 = time.process_time(), time.perf_counter()
    res = planning.plan_route(scn, world=world)  # type: ignore[arg-type]
    cpu, wall = time.process_time() - c0, time.perf_counter() - t0
    iters = int(sum(leg.planner.iterations for leg in res.legs))
    return cpu, wall, iters, res.energy


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--lengths", default="20,50", help="route lengths, km")
    ap.add_argument("--seeds", default="1,2,3")
    ap.add_argument("--leg-km", type=float, default=10.0, help="leg length of 'split', km")
    args = ap.parse_args()
    seeds = [int(s) for s in args.seeds.split(",") if s]
    warm_up()
    print(f"{'km':>4} {'variant':<8} {'grid m':>14} {'legs':>4} {'CPU s':>6} {'wall s':>6} "
          f"{'iter':>5} {'E / ref':>8} {'worst':>6} {'load':>5}")  # fmt: skip
    with tempfile.TemporaryDirectory() as tmp:
        for km in (float(v) for v in args.lengths.split(",") if v):
            path = Path(tmp) / f"km-{km:g}.yaml"
            path.write_text(strip(km), encoding="utf-8")
            base = load_scenario(path)
            default = base.with_planner(grid=GridSpec())
            world = planning.build_world(base)
            ref = planning.reference_energy(default, world)
            variants = {
                "20 m": default,
                "fitted": base,
                "40 m": base.with_planner(grid=GridSpec(40.0, 40.0, 20.0)),
                "split": split(default, args.leg_km * 1000.0),
            }
            for name, scn in variants.items():
                load = os.getloadavg()[0]
                rows = [run(scn, world, seed) for seed in seeds]
                ratios = [r[3] / ref for r in rows]
                grid = "×".join(f"{v:g}" for v in vars(scn.grid).values())
                print(
                    f"{km:>4g} {name:<8} {grid:>14} {len(scn.via_m) + 1:>4} "
                    f"{statistics.mean(r[0] for r in rows):6.2f} "
                    f"{statistics.mean(r[1] for r in rows):6.2f} "
                    f"{statistics.mean(r[2] for r in rows):5.0f} {statistics.mean(ratios):8.4f} "
                    f"{max(ratios):6.4f} {load:5.2f}",
                    flush=True,
                )
    print(f"means over seeds {args.seeds}; ref = A* + line of sight on the 20 m grid")
    return 0


if __name__ == "__main__":
    sys.exit(main())
