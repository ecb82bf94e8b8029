#!/usr/bin/env python3
"""Planner speed and route quality on the bundled scenarios; prints a table.

For every scenario: the median wall time of the planner core (search + post-processing, as
``runtime_s`` in the report; start-up and file I/O excluded) over ``--runs`` seeds with the
scenario's settings (default G = 30, M = 1000), the median of the search alone, the median
wall time of the whole ``uavplan plan`` process, and the energy statistics over the seeds
(mean, std / mean, collision-free count). ``guide s`` is the part of the core spent in the
global (guide) search, which runs only where the straight start→goal columns cannot hold a
path; ``search s`` is the first leg's swarm search.

    python tools/bench_plan.py                    # 5 seeds, 3 process runs per scenario
    python tools/bench_plan.py --runs 30 missions/paper-env*.yaml   # the 30-seed protocol
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def bench_core(path: Path, runs: int) -> dict:
    from uavplan.planning import build_world, plan_route
    from uavplan.scenario import load_scenario

    scn = load_scenario(path)
    cfg = scn.planner
    world = build_world(scn)
    # warm-up: compile (or load) the kernels once
    plan_route(scn.with_planner(search=replace(cfg.search, iterations=5)), world=world)
    core, search, guide, energy, free = [], [], [], [], 0
    for seed in range(1, runs + 1):
        # every leg's problem is built afresh: its reachability memo starts empty, as in a run
        result = plan_route(scn.with_planner(search=replace(cfg.search, seed=seed)), world=world)
        core.append(result.runtime_s)
        guide.append(result.guide_s)
        search.append(result.planner.runtime_s)
        energy.append(result.energy)
        free += bool(result.collision_free)
    e = np.array(energy)
    return {
        "core_s": statistics.median(core),
        "search_s": statistics.median(search),
        "guide_s": statistics.median(guide),
        "energy_mean": float(e.mean()),
        "energy_min": float(e.min()),
        "energy_max": float(e.max()),
        "spread_pct": float(100.0 * e.std() / e.mean()),
        "free": free,
        "runs": runs,
    }


def bench_process(path: Path, runs: int) -> float:
    exe = [sys.executable, "-m", "uavplan"]
    times = []
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "m.plan"
        for _ in range(runs):
            t0 = time.perf_counter()
            subprocess.run([*exe, "plan", str(path), "-o", str(out), "--quiet"], check=True)
            times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument(
        "scenarios", nargs="*", type=Path, default=sorted((ROOT / "missions").glob("*.yaml"))
    )
    ap.add_argument("--runs", type=int, default=5, help="seeds per scenario for the core")
    ap.add_argument("--process-runs", type=int, default=3, help="whole-process runs")
    args = ap.parse_args()
    header = (
        f"{'scenario':<20} {'core s':>7} {'search s':>8} {'guide s':>7} {'process s':>9} "
        f"{'E mean':>8} {'E min':>8} {'E max':>8} {'std %':>6} {'free':>6}"
    )
    print(header)
    print("-" * len(header))
    for path in args.scenarios:
        r = bench_core(path, args.runs)
        proc = bench_process(path, args.process_runs) if args.process_runs else float("nan")
        print(
            f"{path.stem:<20} {r['core_s']:7.2f} {r['search_s']:8.2f} {r['guide_s']:7.3f} "
            f"{proc:9.2f} "
            f"{r['energy_mean']:8.1f} {r['energy_min']:8.1f} {r['energy_max']:8.1f} "
            f"{r['spread_pct']:6.2f} {r['free']:>3}/{r['runs']:<2}",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
