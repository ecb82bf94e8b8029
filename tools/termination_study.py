"""Route quality against iterations for early-stop rules (issue 13): prints a table.

For every scenario and rule ``N/R`` (the first search stops after N iterations without
improving the run's best, every further restart after R; ``all``: every one of the M
iterations), ``uavplan.planning.plan_route`` runs with seeds 1..runs and the scenario's other
settings. Each cell is the final route's energy E over the A* + line-of-sight reference
(``tools/reference_astar.py``'s reference, one A* per leg): mean and worst over the seeds,
and the mean number of iterations.

    python tools/termination_study.py                          # paper-env1..3, midtown, helsinki
    python tools/termination_study.py missions/paper-env1.yaml --runs 5 --rules 100/25,all
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # as `uavplan` itself does: before numpy

import numpy as np

from uavplan.planning import build_world, plan_route, reference_energy
from uavplan.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = [
    ROOT / "missions" / f"{name}.yaml"
    for name in ("paper-env1", "paper-env2", "paper-env3", "midtown-manhattan", "helsinki-centre")
]


def parse_rule(text: str) -> tuple[int | None, int | None]:
    if text == "all":
        return None, None
    first, _, again = text.partition("/")
    return int(first), int(again or first)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenarios", nargs="*", type=Path, default=SCENARIOS)
    ap.add_argument("--runs", type=int, default=10, help="seeds 1..runs (default 10)")
    ap.add_argument("--rules", default="all,100/100,100/50,100/25,50/50", help="N/R or all")
    args = ap.parse_args()
    rules = [(r, parse_rule(r)) for r in args.rules.split(",") if r]
    print(f"{'scenario':<20} {'rule':>8} {'E/ref mean':>10} {'worst':>7} {'iterations':>10}")
    print("-" * 59)
    for path in args.scenarios:
        scenario = load_scenario(path)
        world = build_world(scenario)
        ref = reference_energy(scenario, world)
        if not ref == ref:  # NaN
            raise SystemExit(f"{scenario.name}: A* found no reference path")
        for name, (first, again) in rules:
            ratios, iterations = [], []
            for seed in range(1, args.runs + 1):
                search = dataclasses.replace(
                    scenario.planner.search,
                    seed=seed,
                    stall_iterations=first,
                    restart_stall_iterations=again,
                )
                res = plan_route(scenario.with_planner(search=search), world=world)
                ratios.append(res.energy / ref if res.ok else np.inf)
                iterations.append(res.planner.iterations)
            print(
                f"{scenario.name:<20} {name:>8} {np.mean(ratios):>10.4f} {np.max(ratios):>7.4f}"
                f" {np.mean(iterations):>10.0f}",
                flush=True,
            )
    print(f"E: eq. 1 energy of the final route; ref: A* + line of sight; seeds 1..{args.runs}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
