"""The planner core alone: ``SwarmPlanner.solve`` on a scenario's problem, timed in-process;
prints a table (issue 13).

For every scenario and mode (``default``: the scenario's early stop; ``fixed``: all M
iterations, the paper's protocol) the search runs ``--repeat`` times from the scenario's seed
on a fresh problem; the table gives the fastest and the median time, the iterations, the
fitness evaluations and the best fitness (the same in every repeat: runs are seeded). The
minimum is the number to compare between two builds on a machine whose speed drifts; run the
two back to back.

    python tools/bench_core.py                                   # paper-env1..3, both modes
    python tools/bench_core.py missions/midtown-manhattan.yaml --repeat 5 --modes fixed
    UAVPLAN_THREADS=1 python tools/bench_core.py                 # SPSA's step on one thread
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # as `uavplan` itself does: before numpy

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PAPER = [ROOT / "missions" / f"paper-env{k}.yaml" for k in (1, 2, 3)]


def run(path: Path, mode: str, repeat: int) -> dict[str, float]:
    from uavplan import planning
    from uavplan.planners.base import Termination
    from uavplan.scenario import load_scenario

    scn = load_scenario(path)
    search = scn.planner.search
    stall = search.stall_iterations if mode == "default" else None
    again = search.restart_stall_iterations if mode == "default" else None
    world = planning.build_world(scn)
    times = []
    for _ in range(repeat):
        problem = planning.build_problem(scn, world)
        planner = planning.make_planner(scn.planner.algorithm, scn.planner)
        problem = problem.with_fitness_smoothing(planner.fitness_smoothing())
        rng = np.random.default_rng(search.seed)
        t0 = time.perf_counter()
        term = Termination(search.iterations, stall, restart_stall_iterations=again)
        res = planner.solve(problem, rng, None, term)
        times.append(time.perf_counter() - t0)
    return {
        "min": min(times),
        "median": statistics.median(times),
        "iterations": res.iterations,
        "evaluations": res.evaluations,
        "fitness": res.best_fitness,
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenarios", nargs="*", type=Path, default=PAPER)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--modes", default="default,fixed", help="default, fixed or both")
    args = ap.parse_args()
    modes = [m for m in args.modes.split(",") if m]
    if not set(modes) <= {"default", "fixed"}:
        ap.error("--modes: default and/or fixed")
    print(f"{'scenario':<22} {'mode':<8} {'min s':>7} {'median s':>9} {'iter':>6} {'evals':>7} "
          f"{'fitness':>11}")  # fmt: skip
    print("-" * 76)
    for path in args.scenarios:
        for mode in modes:
            r = run(path, mode, args.repeat)
            print(f"{path.stem:<22} {mode:<8} {r['min']:7.3f} {r['median']:9.3f} "
                  f"{r['iterations']:6.0f} {r['evaluations']:7.0f} {r['fitness']:11.4f}",
                  flush=True)  # fmt: skip
    from uavplan.planners._kernels import step_threads_note

    print(
        f"seconds of SwarmPlanner.solve, {args.repeat} runs each (seeded: same result each); "
        f"{step_threads_note()}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
