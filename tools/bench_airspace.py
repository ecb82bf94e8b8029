#!/usr/bin/env python3
"""How long a scenario with a national zone file takes to read and plan (issue 34): a made-up
500-zone OpenAir file for a 400 × 300 km country, and a 20 km route through its middle.

The file (:func:`national_openair`, seeded) holds the kinds of zones national files publish,
with their shapes: control zones (circles of 3-8 NM around an aerodrome, or a half circle
by ``DA`` closed by points), TMAs (polygons with a ``DB`` arc, floors from 2,500 ft AMSL to
FL95), restricted, prohibited and danger areas (circles and polygons, AGL, AMSL and FL
limits, some with ``AA`` windows), temporary reserved areas, class E / G, RMZ, TMZ and
gliding sectors (not avoided by default), and small zones around heliports, a dozen of them
near the route so that it has to weave. Nothing in it is real.

Each row is measured in a child process: ``read`` the CPU seconds of reading the scenario
(the zone file parsed, every zone decided, the constraints made solids), ``plan`` those of
planning the route (``plan_route``: search and post-processing), ``read+plan`` their sum
(the target is 3 s), and ``process`` the CPU seconds of the whole ``uavplan plan -q``
(interpreter, imports, rehearsal, writing). ``load`` is the 1-minute load average.

    python tools/bench_airspace.py                 # 500 zones, 20 km, 3 runs
    python tools/bench_airspace.py --zones 500,2000 --repeat 5
"""

from __future__ import annotations

import argparse
import json
import math
import os
import random
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CENTRE = (46.80, 8.20)  # lat, lon of the made-up country's middle (the route starts here)
ROUTE_KM = 20.0


def _dms(value: float, pos: str, neg: str) -> str:
    h = pos if value >= 0 else neg
    v = abs(value)
    d = int(v)
    m = int((v - d) * 60)
    s = (v - d - m / 60) * 3600
    if s >= 59.995:
        m, s = m + 1, 0.0
    return f"{d:02d}:{m:02d}:{s:05.2f}{h}"


def _pos(lat: float, lon: float) -> str:
    return f"{_dms(lat, 'N', 'S')} {_dms(lon, 'E', 'W')}"


def _offset(lat: float, lon: float, east_m: float, north_m: float) -> tuple[float, float]:
    return (
        lat + north_m / 111_320.0,
        lon + east_m / (111_320.0 * math.cos(math.radians(lat))),
    )


def national_openair(zones: int = 500, seed: int = 34) -> str:
    """A made-up national OpenAir file of ``zones`` zones (see the module doc)."""
    rng = random.Random(seed)
    lat0, lon0 = CENTRE
    start = (0.0, 0.0)
    goal = (ROUTE_KM * 1000.0, 0.0)
    out = ["*VERSION: 2.0", "*WRITTEN_BY: tools/bench_airspace.py (made up, not real airspace)"]

    def clear_of_ends(x: float, y: float, r: float) -> bool:
        return all(math.hypot(x - a, y - b) > r + 1500.0 for a, b in (start, goal))

    def place(r: float, near_route: bool = False) -> tuple[float, float]:
        for _ in range(1000):
            if near_route:
                x, y = rng.uniform(2000, ROUTE_KM * 1000 - 2000), rng.uniform(-1500, 1500)
            else:
                x, y = rng.uniform(-200_000, 200_000), rng.uniform(-150_000, 150_000)
            if clear_of_ends(x, y, r):
                return x, y
        raise RuntimeError("no room")

    def head(cls: str, name: str, floor: str, ceiling: str, typ: str | None = None) -> None:
        out.append("")
        out.append(f"AC {cls}")
        if typ:
            out.append(f"AY {typ}")
        out.extend([f"AN {name}", f"AL {floor}", f"AH {ceiling}"])

    def circle(x: float, y: float, r_nm: float) -> None:
        out.append(f"V X={_pos(*_offset(lat0, lon0, x, y))}")
        out.append(f"DC {r_nm:.2f}")

    def polygon(x: float, y: float, r: float, n: int, arc: bool = False) -> None:
        angles = sorted(rng.uniform(0, 2 * math.pi) for _ in range(n))
        pts = [
            (
                x + r * rng.uniform(0.6, 1.0) * math.sin(a),
                y + r * rng.uniform(0.6, 1.0) * math.cos(a),
            )
            for a in angles
        ]  # clockwise (bearings increase)
        for px, py in pts:
            out.append(f"DP {_pos(*_offset(lat0, lon0, px, py))}")
        if arc:  # back to the first point along an arc around the centre
            out.append(f"V X={_pos(*_offset(lat0, lon0, x, y))}")
            first, last = pts[0], pts[-1]
            out.append(
                f"DB {_pos(*_offset(lat0, lon0, *last))}, {_pos(*_offset(lat0, lon0, *first))}"
            )

    counts = {"ctr": 40, "tma": 60, "rpq": 130, "tra": 70, "other": 100, "heli": 100}
    scale = zones / sum(counts.values())
    made = 0
    for k in range(round(counts["ctr"] * scale)):
        r_nm = rng.uniform(3, 8)
        x, y = place(r_nm * 1852)
        head("D", f"CTR {k:03d}", "GND", f"{rng.choice([2000, 2500, 3000, 4500])}ft AMSL", "CTR")
        if rng.random() < 0.5:
            circle(x, y, r_nm)
        else:
            out.append(f"V X={_pos(*_offset(lat0, lon0, x, y))}")
            out.append(f"DA {r_nm:.2f}, 90, 270")
            out.append(f"DP {_pos(*_offset(lat0, lon0, x - r_nm * 1852, y + 3000))}")
            out.append(f"DP {_pos(*_offset(lat0, lon0, x + r_nm * 1852, y + 3000))}")
        made += 1
    for k in range(round(counts["tma"] * scale)):
        x, y = place(30_000)
        floor = rng.choice(["2500ft AMSL", "FL65", "FL75", "FL95", "4500ft MSL"])
        head(rng.choice(["C", "D"]), f"TMA {k:03d}", floor, rng.choice(["FL95", "FL195"]), "TMA")
        polygon(x, y, rng.uniform(15_000, 40_000), rng.randint(6, 12), arc=True)
        made += 1
    for k in range(round(counts["rpq"] * scale)):
        cls = rng.choice(["R", "P", "Q"])
        r = rng.uniform(900, 6000)
        x, y = place(r)
        floor = rng.choice(["GND", "GND", "SFC", "1000ft AGL", "FL50"])
        ceiling = rng.choice(["1000ft AGL", "3000ft AMSL", "FL100", "UNL", "2000 m AMSL"])
        head(cls, f"{cls}-{k:03d}", floor, ceiling)
        if rng.random() < 0.3:
            day = rng.randint(1, 28)
            out.append(f"AA 2026-12-{day:02d}T08:00Z/2026-12-{day:02d}T18:00Z")
        if rng.random() < 0.5:
            circle(x, y, r / 1852)
        else:
            polygon(x, y, r, rng.randint(4, 8))
        made += 1
    for k in range(round(counts["tra"] * scale)):
        x, y = place(10_000)
        head("UNC", f"TRA {k:03d}", rng.choice(["FL65", "GND", "3000ft AGL"]), "FL195", "TRA")
        out.append("AA 2026-12-02T07:00Z/2026-12-02T17:00Z")
        polygon(x, y, rng.uniform(5000, 15000), rng.randint(4, 7))
        made += 1
    for k in range(round(counts["other"] * scale)):
        x, y = place(20_000)
        cls, typ = rng.choice(
            [("E", None), ("G", None), ("E", "RMZ"), ("E", "TMZ"), ("UNC", "GSEC")]
        )
        head(cls, f"{typ or cls} {k:03d}", "GND", rng.choice(["FL65", "2000ft AGL"]), typ)
        polygon(x, y, rng.uniform(5000, 20000), rng.randint(4, 9))
        made += 1
    heli = zones - made
    for k in range(heli):
        near = k < 12
        x, y = place(600, near_route=near)
        if near:  # across the route, leaving gaps to weave through
            y = rng.choice([-1, 1]) * rng.uniform(0, 500)
        head("R", f"HELI {k:03d}", "GND", rng.choice(["500ft AGL", "1000ft AGL"]))
        circle(x, y, rng.uniform(0.15, 0.3))
    return "\n".join(out) + "\n"


def scenario_yaml(zone_file: str) -> str:
    lat0, lon0 = CENTRE
    length = ROUTE_KM * 1000.0
    return (
        f"name: national-{ROUTE_KM:g}km\n"
        f"origin: {{lat: {lat0}, lon: {lon0}, alt: 500}}\n"
        f"bounds: {{x: [-1000, {length + 1000:.0f}], y: [-3000, 3000], z: [0, 120]}}\n"
        f"start: [0, 0, 40]\ngoal: [{length:.0f}, 0, 40]\n"
        f"airspace: {{files: [{zone_file}], at: 2026-12-01T09:00:00Z}}\n"
        "planner: {seed: 1}\n"
    )


_CHILD = """
import json, sys, time
t0 = time.process_time()
from uavplan.scenario import Scenario
from uavplan.planning import plan_route
from uavplan.sources.zonefiles import read_zone_file
t1 = time.process_time()
scn = Scenario.from_file(sys.argv[1])
t2 = time.process_time()
result = plan_route(scn)
t3 = time.process_time()
print(json.dumps({"imports": t1 - t0, "read": t2 - t1, "plan": t3 - t2,
                  "zones": len(scn.airspace.decisions),
                  "constraints": len(scn.airspace.constraints),
                  "solids": len(scn.obstacles), "length_m": result.length_m,
                  "collision_free": bool(result.collision_free)}))
"""


def child(path: Path) -> dict:
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, str(path)], capture_output=True, text=True, check=True
    )
    return json.loads(out.stdout)


def whole_process(path: Path, out: Path) -> float:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(
        [sys.executable, "-m", "uavplan", "plan", str(path), "-o", str(out), "-q"],
        check=True,
        capture_output=True,
    )
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--zones", default="500", help="zone counts, comma-separated")
    ap.add_argument("--repeat", type=int, default=3, help="runs per row (medians)")
    ap.add_argument("--keep", type=Path, help="also write the zone file here")
    args = ap.parse_args()
    print(
        f"{time.strftime('%Y-%m-%d %H:%M')}, {os.cpu_count()} CPUs, python {sys.version.split()[0]}"
    )
    header = (
        f"{'zones':>6} {'constr':>6} {'solids':>6} {'read':>6} {'plan':>6} {'read+plan':>9} "
        f"{'process':>7} {'length m':>8} {'free':>5} {'load':>5}"
    )
    print(header)
    print("-" * len(header))
    with tempfile.TemporaryDirectory() as tmp:
        for n in (int(v) for v in args.zones.split(",") if v):
            zone_file = Path(tmp) / f"national-{n}.txt"
            zone_file.write_text(national_openair(n))
            if args.keep:
                args.keep.write_text(zone_file.read_text())
            scn = Path(tmp) / f"national-{n}.yaml"
            scn.write_text(scenario_yaml(zone_file.name))
            load = os.getloadavg()[0]
            rows = [child(scn) for _ in range(args.repeat)]
            procs = [whole_process(scn, Path(tmp) / "o.plan") for _ in range(args.repeat)]
            read = statistics.median(r["read"] for r in rows)
            plan = statistics.median(r["plan"] for r in rows)
            both = statistics.median(r["read"] + r["plan"] for r in rows)
            r0 = rows[0]
            print(
                f"{r0['zones']:>6} {r0['constraints']:>6} {r0['solids']:>6} {read:6.2f} "
                f"{plan:6.2f} {both:9.2f} {statistics.median(procs):7.2f} {r0['length_m']:8.0f} "
                f"{'yes' if r0['collision_free'] else 'NO':>5} {load:5.2f}",
                flush=True,
            )
    print(
        "CPU seconds, medians of the runs; read = Scenario.from_file (zones parsed, decided, "
        "made solids), plan = plan_route, process = the whole `uavplan plan -q`"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
