"""Plan every bundled scenario (and the bundled QGroundControl plan) for several seeds and
print a table of what came out: a digest of the mission items, the energy and the length.

A refactoring that must not change results runs this before and after and compares:

    python tools/plan_digest.py --seeds 1,2,3 --json before.json
    ... change ...
    python tools/plan_digest.py --seeds 1,2,3 --json after.json --compare before.json

``--compare`` prints which plans differ (items, energy or report fields) and exits 1 if any
does. Each plan runs ``uavplan plan`` in a fresh process, so it is the command line's result
that is compared, on whatever build is installed.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: report fields that must not move in a refactoring (runtime and wall-clock fields excluded)
FIELDS = ("status", "energy", "energy_terms", "length_m", "iterations", "termination",
          "evaluations", "waypoints", "min_clearance_m", "collision_free")  # fmt: skip


def inputs() -> list[Path]:
    return sorted(ROOT.glob("missions/*.yaml")) + sorted(ROOT.glob("missions/*.plan"))


def plan_one(source: Path, seed: int, workdir: Path) -> dict:
    out = workdir / f"{source.stem}-{seed}.plan"
    report = workdir / f"{source.stem}-{seed}.json"
    cmd = [sys.executable, "-m", "uavplan", "plan", str(source), "-o", str(out), "--quiet",
           "--seed", str(seed), "--report", str(report)]  # fmt: skip
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    row: dict = {"exit": done.returncode}
    if out.exists():
        plan = json.loads(out.read_text())
        items = plan["mission"]["items"]
        row["items"] = len(items)
        row["items_sha"] = hashlib.sha256(json.dumps(items, sort_keys=True).encode()).hexdigest()[
            :16
        ]
        row["fence_sha"] = hashlib.sha256(
            json.dumps(plan.get("geoFence"), sort_keys=True).encode()
        ).hexdigest()[:16]
    if report.exists():
        data = json.loads(report.read_text())
        row["report"] = {k: data.get(k) for k in FIELDS if k in data}
    return row


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="1,2,3")
    parser.add_argument("--json", help="write the results here")
    parser.add_argument("--compare", help="a --json file of an earlier run to compare with")
    args = parser.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    results: dict[str, dict] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for source in inputs():
            for seed in seeds:
                key = f"{source.name}#{seed}"
                results[key] = plan_one(source, seed, Path(tmp))
                row = results[key]
                energy = row.get("report", {}).get("energy")
                print(f"{key:32} exit {row['exit']}  items {row.get('items', '-'):>4}  "
                      f"sha {row.get('items_sha', '-'):16}  energy {energy}")  # fmt: skip
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1, sort_keys=True))
    if args.compare:
        before = json.loads(Path(args.compare).read_text())
        differ = [k for k in sorted(set(before) | set(results)) if before.get(k) != results.get(k)]
        for key in differ:
            print(f"DIFFERS {key}:\n  before {before.get(key)}\n  after  {results.get(key)}")
        print(f"{len(results) - len(differ)} of {len(results)} plans identical")
        return 1 if differ else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
