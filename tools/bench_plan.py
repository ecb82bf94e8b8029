#!/usr/bin/env python3
"""Where the time of a ``uavplan plan`` goes, per scenario; prints a table (issue 13).

Each scenario is planned in a fresh interpreter that times its phases:

* ``import``: importing the CLI and the planning wiring (uavplan, numpy, the kernels' modules);
* ``load``: reading and validating the scenario (:func:`uavplan.scenario.load_scenario`);
* ``kernels``: loading (or compiling) the compiled kernels (:func:`uavplan.warmup.warm_up`);
* ``build``: the world and the path problem;
* ``search``: the planner (and the guide search where it runs);
* ``post``: post-processing into waypoints (``runtime_s`` minus the search);
* ``cpu``: the CPU time of search and post together, every thread of the process counted
  (``time.process_time``): the planner core's cost on a shared machine, where wall time is
  noisy;
* ``write``: building the mission and writing the .plan (pyproj, which it needs, is imported
  on a thread during the search, as ``uavplan plan`` does: with a second core that import
  costs the write nothing, on one core it is paid inside ``search`` instead);

* ``fence`` (with ``--fence``): building the geofence (:func:`uavplan.planning.fence_for`);

then the whole ``plan`` command in one process after its imports (``plan``: the search, each
widening, the way home, the rehearsals, the verdict and the writing; ``planCPU`` its CPU
seconds), with how many routes it searched (``srch``: the first and each widening), how many
legs (``legs``: a planned return's too) and how many flights the flight model flew (``fly``);
then, apart, the whole ``uavplan plan SCENARIO -o x.plan -q`` process (``--fence`` too with
``--fence``): wall time and peak resident memory (``os.wait4`` of that child). ``core CPU``
is the CPU time of the process while it planned (search and post-processing, every thread:
with two step threads it can exceed the wall time), the number to compare on a machine
whose load changes; ``load`` the 1-minute load average when the row was measured. ``E`` is
the final energy (seed 1, the scenario's settings: the default early stop), ``ref`` the
ratio to the A* + line-of-sight reference on the same grid (``--no-reference`` skips the
A*). Medians over ``--repeat`` runs.

    python tools/bench_plan.py                                  # the bundled scenarios
    python tools/bench_plan.py missions/paper-env1.yaml --repeat 5
    python tools/bench_plan.py --iterations 1000 missions/paper-env*.yaml   # fixed M
    python tools/bench_plan.py --fence district.yaml       # tools/make_district.py's district
    taskset -c 0 python tools/bench_plan.py missions/paper-env*.yaml      # one core (issue 13)
    UAVPLAN_THREADS=1 python tools/bench_plan.py missions/paper-env*.yaml # SPSA on one thread
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
PHASES = ("import", "load", "kernels", "build", "search", "post", "write", "fence", "core_cpu")

#: the child: runs one plan phase by phase and prints one JSON line
CHILD = r"""
import time
t0 = time.perf_counter()
import json, sys
from pathlib import Path
import uavplan.cli
from uavplan import planning
from uavplan.app.reports import export_extras
from uavplan.scenario import load_scenario
from uavplan.warmup import warm_up
from uavplan.mission.io import save_mission
from uavplan.geo import import_in_background
t1 = time.perf_counter()
import_in_background()  # as `uavplan plan` does: pyproj loads during the search
path, out, iterations, reference = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4] == "1"
fence = sys.argv[5] == "1"
scn = load_scenario(path)
if iterations:
    from uavplan.app.feedback import PlannerOptions

    scn = PlannerOptions(iterations=iterations).apply(scn)
t2 = time.perf_counter()
warm_up()
t3 = time.perf_counter()
# as `plan` searches (uavplan.app.plan._search): the margin wider by the corner the
# autopilot cuts first, the bare margin where no route keeps that
from dataclasses import replace
from uavplan.flown_safe import padded_scenario
from uavplan.worlds import padded_world
try:
    from uavplan.flown_safe import corner_pad_m
    pad = corner_pad_m(scn.mission.autopilot)
except ImportError:  # a commit before the padded search (to measure before and after)
    pad = 0.0
world = planning.build_world(scn)
searched = padded_scenario(scn, pad) if pad else scn
searched_world = padded_world(world, searched) if pad else world
problem = planning.build_problem(searched, searched_world) if not scn.via_m else None
t4 = time.perf_counter()
c4 = time.process_time()
res = planning.plan_route(searched, world=searched_world, problem=problem)
if pad and (res.route is None or not res.collision_free):
    res = planning.plan_route(scn, world=world)
elif pad:
    res = replace(res, route=replace(res.route, safety_margin_m=scn.safety_margin_m))
c5 = time.process_time()
t5 = time.perf_counter()
search = sum(leg.planner.runtime_s + leg.guide_s for leg in res.legs) or res.planner.runtime_s
row = {"import": t1 - t0, "load": t2 - t1, "kernels": t3 - t2, "build": t4 - t3,
       "search": search, "post": max(res.runtime_s - search, 0.0), "status": res.status,
       "core_cpu": c5 - c4, "grid": list(vars(scn.grid).values()),
       "energy": res.energy, "iterations": int(sum(l.planner.iterations for l in res.legs)),
       "obstacles": len(scn.obstacles), "length_m": res.length_m, "notes": list(res.notes),
       "message": res.message}
if res.ok:
    mission = planning.mission_for(scn, res.route)
    if fence:
        t6 = time.perf_counter()
        mission, built = planning.fence_for(scn, res.route, mission)
        row["fence"] = time.perf_counter() - t6
        row["fence_summary"] = built.summary()
    save_mission(mission, out, extras=export_extras(scn, res.route, {}))
row["write"] = time.perf_counter() - t5 - row.get("fence", 0.0)
if reference and res.ok:
    t6 = time.perf_counter()
    total = planning.reference_energy(scn, world)
    row["reference_energy"] = total
    row["reference_s"] = time.perf_counter() - t6
print(json.dumps(row))
"""


#: the child: runs the whole ``uavplan plan`` in one process after its imports, counting the
#: searches (whole routes planned: the route, each widening), the legs searched (the planned
#: return's included) and the flights the flight model flew; prints one JSON line
PLAN_CHILD = r"""
import time
t0 = time.perf_counter()
import json, sys
import uavplan.cli
import uavplan.cli.plan_cmd
from uavplan import planning
from uavplan.autopilot import simulate as simulate_module
from uavplan.planners.base import SwarmPlanner
t1 = time.perf_counter()
counts = {"searches": 0, "legs": 0, "flights": 0}

def counted(fn, key):
    def wrapper(*args, **kwargs):
        counts[key] += 1
        return fn(*args, **kwargs)
    return wrapper

for name, key, original in (
    ("plan_route", "searches", planning.plan_route),
    ("simulate", "flights", simulate_module.simulate),
):
    wrapped = counted(original, key)
    for module in list(sys.modules.values()):
        if getattr(module, "__name__", "").startswith("uavplan") and (
            getattr(module, name, None) is original
        ):
            setattr(module, name, wrapped)
SwarmPlanner.solve = counted(SwarmPlanner.solve, "legs")
path, out, iterations = sys.argv[1], sys.argv[2], int(sys.argv[3])
args = ["plan", path, "-o", out, "-q"] + (["--iterations", str(iterations)] if iterations else [])
t2, c2 = time.perf_counter(), time.process_time()
try:
    uavplan.cli.main(args, standalone_mode=False)
except SystemExit:
    pass
row = {"plan_import": t1 - t0, "plan_s": time.perf_counter() - t2,
       "plan_cpu": time.process_time() - c2, **counts}
print(json.dumps(row))
"""


def run_child(args: list[str], env: dict[str, str] | None = None) -> tuple[float, float, str]:
    """(wall seconds, peak RSS MiB, stdout) of one child process."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    assert proc.stdout is not None and proc.stderr is not None
    out = proc.stdout.read().decode()
    err = proc.stderr.read().decode()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode not in (0, 3):
        raise RuntimeError(f"{' '.join(args)} exited {proc.returncode}: {err.strip()[-500:]}")
    return wall, usage.ru_maxrss / 1024.0, out


def phases(path: Path, iterations: int, reference: bool, fence: bool = False) -> dict[str, Any]:
    # as `uavplan plan` runs (its entry point keeps numpy's OpenBLAS on one thread, whose
    # idle helper threads would otherwise spin and count in the CPU column)
    env = {**os.environ, "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS", "1")}
    with tempfile.TemporaryDirectory() as tmp:
        args = [sys.executable, "-c", CHILD, str(path), str(Path(tmp) / "m.plan")]
        flags = ["1" if reference else "0", "1" if fence else "0"]
        _, _, out = run_child([*args, str(iterations), *flags], env)
    return json.loads(out.strip().splitlines()[-1])


def whole_plan(path: Path, iterations: int) -> dict[str, Any]:
    """The whole ``plan`` in one process (:data:`PLAN_CHILD`): its time after the imports,
    and how many searches, legs and flights it made."""
    env = {**os.environ, "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS", "1")}
    with tempfile.TemporaryDirectory() as tmp:
        args = [sys.executable, "-c", PLAN_CHILD, str(path), str(Path(tmp) / "m.plan")]
        _, _, out = run_child([*args, str(iterations)], env)
    return json.loads(out.strip().splitlines()[-1])


def whole_process(path: Path, iterations: int, fence: bool = False) -> tuple[float, float, int]:
    """(wall s, peak RSS MiB, exit code) of ``uavplan plan PATH -o x.plan -q`` (and
    ``--fence``)."""
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "uavplan", "plan", str(path), "-o", str(Path(tmp) / "x.plan")]
        cmd += ["-q", *(["--iterations", str(iterations)] if iterations else [])]
        cmd += ["--fence"] if fence else []
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        assert proc.stderr is not None
        proc.stderr.read()
        _, status, usage = os.wait4(proc.pid, 0)
        return time.perf_counter() - t0, usage.ru_maxrss / 1024.0, os.waitstatus_to_exitcode(status)


def measure(
    path: Path, repeat: int, iterations: int, reference: bool, fence: bool = False
) -> dict[str, Any]:
    """Median phases over ``repeat`` children (the reference once), then ``repeat`` whole
    processes; ``load`` the 1-minute load average before the first."""
    load = os.getloadavg()[0]
    rows = [phases(path, iterations, reference and k == 0, fence) for k in range(repeat)]
    out: dict[str, Any] = {
        p: statistics.median(r.get(p, float("nan")) for r in rows) for p in PHASES
    }
    first = rows[0]
    out.update({k: first[k] for k in first if k not in PHASES})
    out["loadavg"] = load
    plans = [whole_plan(path, iterations) for _ in range(repeat)]
    for key in ("plan_s", "plan_cpu"):
        out[key] = statistics.median(p[key] for p in plans)
    out.update({k: plans[0][k] for k in ("searches", "legs", "flights")})
    procs = [whole_process(path, iterations, fence) for _ in range(repeat)]
    out["process_s"] = statistics.median(p[0] for p in procs)
    out["rss_mib"] = max(p[1] for p in procs)
    out["exit"] = procs[0][2]
    ref = first.get("reference_energy")
    out["ratio"] = first["energy"] / ref if ref else float("nan")
    return out


HEADER = (
    f"{'scenario':<22} {'obst':>6} {'import':>6} {'load':>6} {'kernels':>7} {'build':>6} "
    f"{'search':>6} {'post':>6} {'coreCPU':>7} {'write':>6} {'fence':>6} {'plan':>6} "
    f"{'planCPU':>7} {'srch':>4} {'legs':>4} {'fly':>3} {'process':>7} "
    f"{'RSS MiB':>7} {'iter':>5} {'E':>9} {'ref':>6} {'loadavg':>7}"
)


def format_row(name: str, r: dict[str, Any]) -> str:
    return (
        f"{name:<22} {r['obstacles']:>6} {r['import']:6.2f} {r['load']:6.2f} {r['kernels']:7.2f} "
        f"{r['build']:6.2f} {r['search']:6.2f} {r['post']:6.2f} {r['core_cpu']:7.2f} "
        f"{r['write']:6.2f} {r['fence']:6.2f} {r['plan_s']:6.2f} {r['plan_cpu']:7.2f} "
        f"{r['searches']:>4} {r['legs']:>4} {r['flights']:>3} {r['process_s']:7.2f} "
        f"{r['rss_mib']:7.0f} "
        f"{r['iterations']:>5} {r['energy']:9.1f} {r['ratio']:6.3f} {r['loadavg']:7.2f}"
    )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument(
        "scenarios", nargs="*", type=Path, default=sorted((ROOT / "missions").glob("*.yaml"))
    )
    ap.add_argument("--repeat", type=int, default=3, help="runs per scenario (medians)")
    ap.add_argument(
        "--iterations", type=int, default=0, help="force M iterations (default: early stop)"
    )
    ap.add_argument("--no-reference", action="store_true", help="skip the A* reference")
    ap.add_argument("--fence", action="store_true", help="plan with --fence (a 'fence' phase)")
    args = ap.parse_args()
    print(HEADER)
    print("-" * len(HEADER))
    summaries = []
    for path in args.scenarios:
        r = measure(path, args.repeat, args.iterations, not args.no_reference, args.fence)
        print(format_row(path.stem, r), flush=True)
        if r.get("fence_summary"):
            summaries.append(f"{path.stem}: {r['fence_summary']}")
    print(
        "seconds; medians of the phases in one process (search includes the guide search), "
        "coreCPU = CPU seconds of search + post (all threads); 'plan' = the whole plan "
        "command in one process after its imports (search, widening, way home, rehearsals, "
        "verdict, writing), planCPU its CPU seconds, srch the routes searched (the first and "
        "each widening), legs the legs searched (a planned return's included), fly the "
        "flights the flight model flew; 'process' = the whole "
        "`uavplan plan -q` wall time, RSS its peak; E seed 1, ref = E / (A* + line of sight); "
        "loadavg = 1-minute load average"
    )
    print(*summaries, sep="\n")
    from uavplan.planners._kernels import step_threads_note

    print(f"{step_threads_note()} (UAVPLAN_THREADS, or the CPUs available, <= 2)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
