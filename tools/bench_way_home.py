"""Time the proof of the way home (``uavplan.wayhome.home.way_home``) on the bundled scenarios.

Plans each scenario as ``uavplan plan`` does (its own settings and seed), then times the way
home after it: the RTL proof from every point of the route, and the planned return where one
is needed. Prints one row per scenario and firmware, with the machine's load:

    python tools/bench_way_home.py [missions/courtyard.yaml ...]
"""

from __future__ import annotations

import argparse
import os
import time
from dataclasses import replace
from pathlib import Path

from uavplan.flavour import Autopilot
from uavplan.planning import plan_route
from uavplan.scenario import load_scenario
from uavplan.wayhome.home import way_home

ROOT = Path(__file__).resolve().parent.parent


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenarios", nargs="*", default=sorted(ROOT.glob("missions/*.yaml")))
    args = parser.parse_args()
    print(f"load {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    print("scenario | firmware | samples | evaluations | proof s | lowest safe RTL altitude m")
    for path in args.scenarios:
        scenario = load_scenario(path)
        route = plan_route(scenario).route
        if route is None:
            print(f"{Path(path).stem} | no route")
            continue
        for autopilot in (Autopilot.ARDUPILOT, Autopilot.PX4):
            flavoured = replace(scenario, mission=replace(scenario.mission, autopilot=autopilot))
            started = time.perf_counter()
            way = way_home(flavoured, route)
            elapsed = time.perf_counter() - started
            proof = way.proof
            assert proof is not None
            safe = "none" if proof.safe_altitude_m is None else f"{proof.safe_altitude_m:.2f}"
            if way.planned_return:
                safe += " (planned return)"
            print(
                f"{Path(path).stem} | {autopilot.label} | {proof.samples} | {proof.evaluations} "
                f"| {elapsed:.2f} | {safe}"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
