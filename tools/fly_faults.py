"""``uavplan fly`` under faults: every case of issue 31, both flavours, three seeds.

Each run flies the bundled narrow-gap mission (planned for the flavour) on a
``uavplan mock-vehicle`` process through a seeded UDP fault relay, with ``fly --scenario
--track`` as a process, and judges it against what the vehicle really sent (the relay's
record, before any fault): tests/helpers/fly_faults.py (the cases, the judgement) and
tests/helpers/fault_relay.py (the relay). Prints one row per run (exit code, verdict, whether the
track file is whole, the vehicle's final state, how long ``fly`` took to say the case's
event in simulated seconds) and a summary of the times to notice, and exits 1 when any
invariant broke: an exit 1, a hang, a traceback, an exit other than the case's, a track not
whole, or a "complete" over an unobserved or breached stretch.

    python tools/fly_faults.py [--speedup 20] [--seeds 1,2,3] [--case gcs-hold ...]
                               [--autopilot px4|ardupilot] [--markdown]
"""

from __future__ import annotations

import argparse
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from datetime import UTC, datetime
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from helpers.fly_faults import CASES, CaseResult, run_case  # noqa: E402  (the harness lives with the tests)

from uavplan.mission.items import Autopilot  # noqa: E402


class LoadSampler:
    """The 1-minute load average, sampled every 30 s while the runs go."""

    def __init__(self) -> None:
        self.samples = [os.getloadavg()[0]]
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(30.0):
            self.samples.append(os.getloadavg()[0])

    def stop(self) -> str:
        self._stop.set()
        self.samples.append(os.getloadavg()[0])
        return f"{min(self.samples):.1f}-{max(self.samples):.1f}"


def _cell(value: object) -> str:
    return str(value).replace("|", "/")


def main(argv: list[str] | None = None) -> int:
    # a SIGTERM ends the run through the harness's clean-ups (no vehicle left running)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--speedup", type=float, default=20.0)
    parser.add_argument("--seeds", default="1,2,3")
    parser.add_argument("--case", action="append", choices=sorted(CASES), default=None)
    parser.add_argument("--autopilot", choices=["px4", "ardupilot"], default=None)
    parser.add_argument("--markdown", action="store_true", help="print Markdown tables")
    args = parser.parse_args(argv)
    seeds = [int(s) for s in args.seeds.split(",")]
    cases = args.case or list(CASES)
    flavours = (
        [Autopilot.from_name(args.autopilot)]
        if args.autopilot
        else [Autopilot.PX4, Autopilot.ARDUPILOT]
    )
    command = "python tools/fly_faults.py " + " ".join(argv if argv is not None else sys.argv[1:])
    commit = subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=ROOT
    ).stdout.strip()
    started = time.monotonic()
    when = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    load = LoadSampler()
    results: list[CaseResult] = []
    with tempfile.TemporaryDirectory(prefix="fly-faults-") as tmp:
        work = Path(tmp)
        for name in cases:
            for autopilot in flavours:
                for seed in seeds:
                    result = run_case(CASES[name], autopilot, seed, work, speedup=args.speedup)
                    results.append(result)
                    noticed = (
                        "-" if result.noticed_after_s is None else f"{result.noticed_after_s:.1f}"
                    )
                    print(
                        f"# {name} {autopilot.label} seed {seed}: exit {result.exit_code}, "
                        f"{result.verdict}, noticed {noticed}"
                        + ("" if result.held else f", BROKEN: {'; '.join(result.problems)}"),
                        file=sys.stderr,
                        flush=True,
                    )
                    if not result.held:
                        print(result.output, file=sys.stderr, flush=True)
    loads = load.stop()
    minutes = (time.monotonic() - started) / 60.0
    broken = [r for r in results if not r.held]
    header = (
        f"`{command.strip()}` (commit {commit}, {when}, {minutes:.0f} min, load {loads} on "
        f"{os.cpu_count()} cores; simulated time {args.speedup:g} times the wall clock)"
    )
    print(header)
    print()
    cols = ["case", "flavour", "seed", "exit", "verdict", "track whole", "vehicle's final state",
            "noticed after: sim s (wall s)", "held"]  # fmt: skip
    print("| " + " | ".join(cols) + " |")
    print("|" + "---|" * len(cols))
    for r in results:
        noticed = "-" if r.noticed_after_s is None else f"{r.noticed_after_s:.1f}"
        if r.noticed_after_wall_s is not None:
            noticed += f" ({r.noticed_after_wall_s:.2f})"
        held = "yes" if r.held else "NO: " + "; ".join(r.problems)
        code = "hang" if r.exit_code is None else str(r.exit_code)
        row = [r.case, r.autopilot.label, str(r.seed), code, r.verdict, r.track_whole,
               r.final_state, noticed, held]  # fmt: skip
        print("| " + " | ".join(_cell(v) for v in row) + " |")
    print()
    print("Cases: " + "; ".join(f"`{c}`: {CASES[c].says}" for c in cases) + ".")
    print()
    print("| event | flavour | runs | noticed after, sim s: min | median | max | wall s: median |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for name in cases:
        for autopilot in flavours:
            times = [
                r.noticed_after_s
                for r in results
                if r.case == name and r.autopilot == autopilot and r.noticed_after_s is not None
            ]
            walls = [
                r.noticed_after_wall_s
                for r in results
                if (r.case, r.autopilot) == (name, autopilot) and r.noticed_after_wall_s is not None
            ]
            if not times or not walls:
                continue
            print(
                f"| {name} ({CASES[name].notice.split('|')[0]}) | {autopilot.label} | "
                f"{len(times)} | {min(times):.1f} | {statistics.median(times):.1f} | "
                f"{max(times):.1f} | {statistics.median(walls):.2f} |"
            )
    print()
    exit1 = sum(r.exit_code == 1 for r in results)
    hangs = sum(r.exit_code is None for r in results)
    false_complete = sum(any("exit 0" in p for p in r.problems) for r in results)
    print(
        f'{len(results)} runs: {exit1} exit 1, {hangs} hangs, {false_complete} "complete" '
        f"over an unobserved or breached stretch, {len(broken)} runs broke an invariant."
    )
    return 1 if broken else 0


if __name__ == "__main__":
    raise SystemExit(main())
