#!/usr/bin/env python3
"""Link chaos table: uploads of a 200-item mission through a seeded fault proxy.

Each run starts a fresh mock vehicle holding an old mission, puts a
:class:`FaultProxy` (tests/helpers/faultproxy.py) in front of it and uploads a new mission
with read-back verification, as ``uavplan upload`` does (see tests/helpers/chaos.py).
Cases:

- ``lossy``: 20 % loss each way, 5 % duplicates, 5 % reordering, on every packet;
- ``lossy+flip``: the same plus 1 % bit flips and 5 % delays of up to 50 ms;
- ``dead``: 100 % loss of the mission protocol messages each way (heartbeats pass, so the
  failure is in the transfer), which must end in exit 4 within the stated bound.

Invariants checked on every run: exit 0 means the vehicle holds exactly the mission sent;
a failure is exit 4 and names the step; the vehicle never holds a mixture; a failing run
ends within ``HEARTBEAT_TIMEOUT_S + 1 + (retries + 2) x ack_s + 0.5`` s (17 s with the
default timeouts).

Usage::

    python tools/link_chaos.py                     # 50 runs per case and flavour
    python tools/link_chaos.py --runs 5 --autopilot px4
    python tools/link_chaos.py --markdown --runs 50   # the table for docs/reliability.md

Exit status 0 when every invariant held, 1 otherwise.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from helpers.chaos import RunResult, invariant_problem, run_upload, time_bound_s  # noqa: E402  (the harness lives with the tests)
from helpers.faultproxy import MISSION_MESSAGE_IDS, ProxyFaults  # noqa: E402

from uavplan.mavlink.protocol import ProtocolTimeouts  # noqa: E402
from uavplan.mission.items import Autopilot  # noqa: E402

N_ITEMS = 200


@dataclass(frozen=True)
class Case:
    name: str
    description: str
    faults: ProxyFaults
    expect_success: bool
    runs_divisor: int = 1  # the dead case is slow by design: fewer runs


CASES = (
    Case(
        "lossy",
        "20 % loss each way, 5 % duplicates, 5 % reordering",
        ProxyFaults(drop_rate=0.2, duplicate_rate=0.05, reorder_rate=0.05),
        True,
    ),
    Case(
        "lossy+flip",
        "as lossy, plus 1 % bit flips and 5 % delays up to 50 ms",
        ProxyFaults(
            drop_rate=0.2,
            duplicate_rate=0.05,
            reorder_rate=0.05,
            bitflip_rate=0.01,
            delay_rate=0.05,
            max_delay_s=0.05,
        ),
        True,
    ),
    Case(
        "dead",
        "100 % loss of mission messages each way",
        ProxyFaults(drop_rate=1.0, only=MISSION_MESSAGE_IDS),
        False,
        runs_divisor=10,
    ),
)


@dataclass
class Row:
    case: Case
    autopilot: Autopilot
    results: list[RunResult] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)


def run_case(case: Case, autopilot: Autopilot, runs: int, timeouts: ProtocolTimeouts) -> Row:
    row = Row(case, autopilot)
    bound = time_bound_s(timeouts, N_ITEMS)
    for index in range(runs):
        faults = ProxyFaults(**{**case.faults.__dict__, "seed": 1000 * index + 7})
        result = run_upload(faults, autopilot=autopilot, n_items=N_ITEMS, timeouts=timeouts)
        row.results.append(result)
        problem = invariant_problem(result, bound)
        if problem is None and case.expect_success and not result.ok:
            problem = f"failed: {result.message}"
        if problem is None and not case.expect_success and result.ok:
            problem = "succeeded through a dead link"
        if problem is not None:
            row.problems.append(f"run {index}: {problem}")
        print(
            f"  {case.name:<10} {autopilot.label:<9} run {index + 1}/{runs}: exit "
            f"{result.exit_code}, holds {result.holds}, {result.elapsed_s:.1f} s"
            + (f": {result.message}" if result.message else ""),
            file=sys.stderr,
        )
    return row


def percentile(values: list[float], fraction: float) -> float:
    """Nearest-rank percentile: the smallest value with at least ``fraction`` of the values
    at or below it (the 90th of 50 runs is the 45th smallest)."""
    ordered = sorted(values)
    return ordered[max(0, math.ceil(fraction * len(ordered)) - 1)]


def _cells(row: Row, bound_s: float) -> list[str]:
    results = row.results
    ok = sum(r.ok for r in results)
    exit4 = sum(r.exit_code == 4 for r in results)
    other = len(results) - ok - exit4
    times = [r.elapsed_s for r in results]
    return [
        row.case.name,
        row.autopilot.label,
        str(len(results)),
        str(ok),
        str(exit4),
        str(other),
        str(sum(r.holds == "mixture" for r in results)),
        f"{statistics.median(times):.1f}" if times else "-",
        f"{percentile(times, 0.9):.1f}" if times else "-",
        f"{max(times):.1f}" if times else "-",
        f"{bound_s:.1f}" if not row.case.expect_success else "-",
        "yes" if not row.problems else "NO",
    ]


HEADER = [
    "case",
    "vehicle",
    "runs",
    "exit 0 verified",
    "exit 4",
    "other exit",
    "mixtures",
    "median s",
    "p90 s",
    "max s",
    "bound s",
    "invariants held",
]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=50, help="runs per case and flavour")
    parser.add_argument("--autopilot", choices=("px4", "ardupilot", "both"), default="both")
    parser.add_argument("--markdown", action="store_true", help="print a Markdown table")
    parser.add_argument(
        "--case", choices=[c.name for c in CASES], action="append", help="only these cases"
    )
    args = parser.parse_args(argv)
    if args.runs < 1:
        parser.error("--runs must be at least 1")
    flavours = {
        "px4": [Autopilot.PX4],
        "ardupilot": [Autopilot.ARDUPILOT],
        "both": [Autopilot.PX4, Autopilot.ARDUPILOT],
    }[args.autopilot]
    timeouts = ProtocolTimeouts()
    bound = time_bound_s(timeouts, N_ITEMS)
    rows = []
    for case in CASES:
        if args.case and case.name not in args.case:
            continue
        runs = max(1, args.runs // case.runs_divisor)
        for autopilot in flavours:
            rows.append(run_case(case, autopilot, runs, timeouts))

    table = [_cells(row, bound) for row in rows]
    command = f"python tools/link_chaos.py --markdown --runs {args.runs}"
    if args.autopilot != "both":
        command += f" --autopilot {args.autopilot}"
    for name in args.case or ():
        command += f" --case {name}"
    if args.markdown:
        print(f"Uploads of a {N_ITEMS}-item mission with read-back through a seeded fault proxy")
        print(f"(`{command}`; default protocol timeouts).\n")
        print("| " + " | ".join(HEADER) + " |")
        print("|" + "|".join("---" for _ in HEADER) + "|")
        for cells in table:
            print("| " + " | ".join(cells) + " |")
        print()
        for case in CASES:
            print(f"- `{case.name}`: {case.description}")
    else:
        widths = [max(len(h), *(len(c[i]) for c in table)) for i, h in enumerate(HEADER)]
        print("  ".join(h.ljust(w) for h, w in zip(HEADER, widths, strict=True)))
        for cells in table:
            print("  ".join(c.ljust(w) for c, w in zip(cells, widths, strict=True)))
    problems = [f"{r.case.name} {r.autopilot.label} {p}" for r in rows for p in r.problems]
    for problem in problems:
        print(f"INVARIANT BROKEN: {problem}", file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
