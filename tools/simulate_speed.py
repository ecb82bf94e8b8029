"""How long each bundled mission flies in the flight model, and how fast ``simulate`` runs it.

For every scenario (default: every ``missions/*.yaml``) and both flavours, the mission is
planned by the command line as a user would (``uavplan plan S -o M.plan --autopilot F``, the
scenario's own seed), then flown through the flight model in this process
(:func:`uavplan.autopilot.simulate.simulate`, the take-off to the end the mission asks for, calm
air) ``--repeat`` times. The table gives the simulated flight (take-off to touchdown, the same
in every repeat) and the fastest wall time of a run, with the date and the machine's load
(docs/flight-model.md, "How fast, how close"):

    python tools/simulate_speed.py [--repeat 3] [missions/paper-env1.yaml ...]
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from uavplan.autopilot.simulate import simulate
from uavplan.mission.io import load_mission
from uavplan.mission.items import Autopilot

ROOT = Path(__file__).resolve().parent.parent


def fly(scenario: Path, autopilot: Autopilot, workdir: Path, repeat: int) -> tuple[float, float]:
    """(simulated flight s, fastest wall s of ``simulate``)"""
    out = workdir / f"{scenario.stem}-{autopilot.name.lower()}.plan"
    command = [
        "uavplan",
        "plan",
        str(scenario),
        "-o",
        str(out),
        "--autopilot",
        autopilot.name.lower(),
    ]
    subprocess.run([*command, "-q"], check=True, capture_output=True)
    plan = load_mission(out)
    best = float("inf")
    flight = 0.0
    for _ in range(repeat):
        began = time.perf_counter()
        track = simulate(plan, autopilot=autopilot)
        best = min(best, time.perf_counter() - began)
        flight = float(track.t_s[-1] - track.t_s[0])
    return flight, best


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("scenarios", nargs="*", type=Path)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    scenarios = args.scenarios or sorted((ROOT / "missions").glob("*.yaml"))
    load_before = os.getloadavg()[0]
    print("| Scenario | PX4 flight | PX4 simulate | ArduPilot flight | ArduPilot simulate |")
    print("|---|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        for scenario in scenarios:
            cells = []
            for autopilot in (Autopilot.PX4, Autopilot.ARDUPILOT):
                flight, wall = fly(scenario, autopilot, Path(tmp), args.repeat)
                cells += [f"{flight:.0f} s", f"{wall * 1000:.0f} ms"]
            print(f"| {scenario.stem} | " + " | ".join(cells) + " |", flush=True)
    print(
        f"\nbest of {args.repeat}; {dt.date.today().isoformat()}, load {load_before:.1f}-"
        f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
