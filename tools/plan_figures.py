"""What ``uavplan plan`` reports for the bundled scenarios: the figures the docs quote from it.

Each scenario (default: every ``missions/*.yaml`` and ``missions/qgc-inspection.plan``) is
planned with each seed by the command line, in a fresh process, exactly as a user would run
``uavplan plan SCENARIO -o OUT --seed S --report R.json``; the table gives what the report says:
the exit code, the waypoints, the length, the least clearance, the iterations and why the
search ended, the planner's ``runtime_s`` and the whole command's wall time, with the date and
the machine's load (times on a shared machine vary with it; the rest is seeded).

    python tools/plan_figures.py                                  # every bundled scenario, seed 1
    python tools/plan_figures.py missions/qgc-inspection.plan --seeds 0-19
    python tools/plan_figures.py missions/helsinki-centre.yaml --seeds 1,2

A line per scenario sums the seeds up (ranges) when there is more than one; the last line
gives the range of iterations over every row (README, "When planning stops").
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def seeds_of(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        if "-" in part:
            low, high = part.split("-")
            out += range(int(low), int(high) + 1)
        else:
            out.append(int(part))
    return out


def plan_once(scenario: Path, seed: int, workdir: Path) -> dict[str, object]:
    out = workdir / f"{scenario.stem}-{seed}.plan"
    report = workdir / f"{scenario.stem}-{seed}.json"
    command = ["uavplan", "plan", str(scenario), "-o", str(out), "--seed", str(seed)]
    command += ["--report", str(report), "-q"]
    began = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - began
    row: dict[str, object] = {"scenario": scenario.stem, "seed": seed, "exit": done.returncode}
    row["wall_s"] = wall
    if report.is_file():
        data = json.loads(report.read_text(encoding="utf-8"))
        for key in ("waypoints", "length_m", "min_clearance_m", "iterations", "termination"):
            row[key] = data.get(key)
        row["runtime_s"] = data.get("runtime_s")
    else:
        row["error"] = (done.stderr or done.stdout).strip().splitlines()[-1:]
    return row


def fmt(value: object, digits: int = 2) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.{digits}f}"
    return str(value)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("scenarios", nargs="*", type=Path)
    parser.add_argument("--seeds", default="1", help="1,2,3 or 0-19 (default 1)")
    args = parser.parse_args()
    scenarios = args.scenarios or [
        *sorted((ROOT / "missions").glob("*.yaml")),
        ROOT / "missions" / "qgc-inspection.plan",
    ]
    seeds = seeds_of(args.seeds)
    load_before = os.getloadavg()[0]
    print(
        "| scenario | seed | exit | waypoints | length m | min clearance m | iterations "
        "| ended | planner s | whole command s |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for scenario in scenarios:
            for seed in seeds:
                row = plan_once(scenario, seed, Path(tmp))
                rows.append(row)
                print(
                    f"| {row['scenario']} | {seed} | {row['exit']} | {fmt(row.get('waypoints'))} "
                    f"| {fmt(row.get('length_m'), 0)} | {fmt(row.get('min_clearance_m'))} "
                    f"| {fmt(row.get('iterations'))} | {fmt(row.get('termination'))} "
                    f"| {fmt(row.get('runtime_s'))} | {fmt(row['wall_s'])} |",
                    flush=True,
                )
    if len(seeds) > 1:
        print()
        for scenario in scenarios:
            mine = [r for r in rows if r["scenario"] == scenario.stem and "runtime_s" in r]
            if not mine:
                continue
            runtimes = [float(r["runtime_s"]) for r in mine]  # type: ignore[arg-type]
            same = len({(fmt(r["length_m"], 0), fmt(r["min_clearance_m"])) for r in mine}) == 1
            print(
                f"{scenario.stem}: {len(mine)} seeds, planner {min(runtimes):.2f}-"
                f"{max(runtimes):.2f} s, "
                + ("the same length and clearance every time" if same else "routes differ")
            )
    iterations = [n for r in rows if isinstance(n := r.get("iterations"), int)]
    if iterations:
        print(f"\niterations: {min(iterations)}-{max(iterations)} over {len(iterations)} plans")
    load_after = os.getloadavg()[0]
    print(
        f"\n{dt.date.today().isoformat()}, load {load_before:.1f}-{load_after:.1f} on "
        f"{os.cpu_count()} CPUs; command: python tools/plan_figures.py " + " ".join(sys.argv[1:])
    )
    return 0 if all(r["exit"] == 0 for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
