"""What the physical fitness saves: the bundled scenarios planned with the paper's fitness
and with ``planner: {energy: physical}`` (same seeds), in calm air and in wind, each whole
flight (take-off, route, the scenario's end) estimated in watt-hours by the same estimate
``plan`` prints (issue 27; docs/energy.md "The physical fitness").

The wind blows from the goal towards the start (the outbound route flies into it, an RTL
home flies with it), 6 m/s at 10 m above the ground and growing with height by the power law
(exponent 1/7): the physical fitness may fly lower where the air is slower, the paper's does
not know there is wind.

    python tools/energy_savings.py                       # seeds 1,2,3, every bundled scenario
    python tools/energy_savings.py --seeds 1 --scenarios paper-env1,hairpin --json out.json
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

from uavplan.airframe import Wind
from uavplan.estimate import estimate_route
from uavplan.planning import plan_route
from uavplan.scenario import load_scenario

ROOT = Path(__file__).resolve().parent.parent
WIND_M_S = 6.0
SHEAR = 1 / 7


def headwind(scenario_path: Path) -> Wind:
    """A wind from the goal's bearing as seen from the start (the outbound is upwind)."""
    scn = load_scenario(scenario_path)
    (sx, sy, _), (gx, gy, _) = scn.start_m, scn.goal_m
    bearing = math.degrees(math.atan2(gx - sx, gy - sy)) % 360.0
    return Wind.power_law(WIND_M_S, round(bearing, 1), exponent=SHEAR)


def run(path: Path, seed: int, fitness: str, wind: Wind | None) -> dict:
    scn = load_scenario(path)
    search = replace(scn.planner.search, seed=seed)
    scn = replace(scn, planner=replace(scn.planner, search=search, fitness=fitness), wind=wind)
    t0 = time.process_time()
    result = plan_route(scn, threads=1)
    cpu = time.process_time() - t0
    if result.route is None:
        return {"ok": False, "cpu_s": cpu}
    est = estimate_route(scn, result.route.flown_enu)
    return {
        "ok": True,
        "wh": est.energy.energy_wh,
        "time_s": est.energy.time_s,
        "length_m": result.route.length_m,
        "paper_energy": result.energy,
        "cpu_s": cpu,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="1,2,3")
    parser.add_argument("--scenarios", default="", help="names (default: every bundled one)")
    parser.add_argument("--json", help="write every run here")
    args = parser.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    paths = sorted((ROOT / "missions").glob("*.yaml"))
    if args.scenarios:
        wanted = set(args.scenarios.split(","))
        paths = [p for p in paths if p.stem in wanted]
    runs = []
    rows = [
        "| scenario | wind | paper Wh | physical Wh | saved | paper m | physical m "
        "| CPU paper s | CPU physical s |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for path in paths:
        for label, wind in (("calm", None), ("6 m/s head, sheared", headwind(path))):
            by = {}
            for fitness in ("paper", "physical"):
                by[fitness] = [run(path, seed, fitness, wind) for seed in seeds]
                for seed, r in zip(seeds, by[fitness], strict=True):
                    runs.append({"scenario": path.stem, "wind": label, "fitness": fitness,
                                 "seed": seed, **r})  # fmt: skip
            if not all(r["ok"] for f in by.values() for r in f):
                rows.append(f"| {path.stem} | {label} | no route for a seed | | | | | | |")
                continue

            def mean(fitness: str, key: str, by: dict = by) -> float:
                return sum(r[key] for r in by[fitness]) / len(seeds)

            paper, phys = mean("paper", "wh"), mean("physical", "wh")
            rows.append(
                f"| {path.stem} | {label} | {paper:.2f} | {phys:.2f} | "
                f"{100 * (paper - phys) / paper:+.1f} % | {mean('paper', 'length_m'):.0f} | "
                f"{mean('physical', 'length_m'):.0f} | {mean('paper', 'cpu_s'):.2f} | "
                f"{mean('physical', 'cpu_s'):.2f} |"
            )
            print(rows[-1], file=sys.stderr, flush=True)
    print("\n".join(rows))
    load = os.getloadavg()
    print(
        f"\nseeds {args.seeds}; means over the seeds; one thread; load {load[0]:.2f} "
        f"{load[1]:.2f} {load[2]:.2f}"
    )
    if args.json:
        Path(args.json).write_text(json.dumps(runs, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
