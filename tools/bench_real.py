#!/usr/bin/env python3
"""Real-world scenarios: load (import) time, world build and planner core time; prints a table.

Rows: the bundled OpenStreetMap scenario (``missions/helsinki-centre.yaml``), the bundled DEM
scenario (``missions/jacksboro-ridge.yaml``), and a synthetic district of ``--buildings``
OpenStreetMap buildings (written to a temporary .osm.pbf by ``tools/bench_import.py``'s
generator and read through ``obstacle_files``, as a user's would be), flown corner to corner
over the roofs. The last row plans the same district route with only the buildings within
300 m of the start→goal line: if the world's index and the kernels do not slow down with far
obstacles, its core time matches the full district's.

``load s`` is :func:`uavplan.scenario.load_scenario` (YAML + OSM/DEM reading), ``world s``
builds the world, ``core s`` is the report's ``runtime_s`` (search + post-processing, kernels
already compiled), median over ``--seeds`` seeds.

    python tools/bench_real.py                  # 3 seeds, 5,000 buildings
    python tools/bench_real.py --seeds 5 --buildings 10000
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tools"))

from bench_import import ORIGIN, district, write_pbf  # noqa: E402

from uavplan.planning import build_world, plan_route  # noqa: E402
from uavplan.scenario import Scenario, load_scenario  # noqa: E402


def district_scenario(folder: Path, n: int) -> Path:
    pbf = folder / "district.osm.pbf"
    write_pbf(district(n), pbf)
    half = 40.0 * (int(np.ceil(np.sqrt(n))) / 2 + 1)
    corner = 40.0 * (int(np.ceil(np.sqrt(n))) // 2 - 1)  # a street crossing near each corner
    path = folder / "district.yaml"
    path.write_text(
        f"name: district-{n}\n"
        f"origin: {{lat: {ORIGIN.lat_deg}, lon: {ORIGIN.lon_deg}, alt: {ORIGIN.alt_m}}}\n"
        f"bounds: {{x: [{-half}, {half}], y: [{-half}, {half}], z: [0, 120]}}\n"
        f"obstacle_files: [{{file: {pbf.name}}}]\n"
        f"start: [{-corner}, {-corner}, 40]\ngoal: [{corner}, {corner}, 40]\n"
        "safety_margin: 5\n"
        "planner: {seed: 1, grid: {dx: 50, dy: 10, dz: 5}}\n"
        "mission: {spacing: 50}\n",
        encoding="utf-8",
    )
    return path


def near_line(scn: Scenario, width_m: float) -> Scenario:
    """``scn`` with only the obstacles whose centre is within ``width_m`` of start→goal."""
    a = np.array(scn.start_m[:2])
    b = np.array(scn.goal_m[:2])
    ab = b - a
    keep = []
    for o in scn.obstacles:
        c = np.mean(o.polygon_m, axis=0) if hasattr(o, "polygon_m") else np.array(o.center_m)
        t = np.clip(np.dot(c - a, ab) / np.dot(ab, ab), 0.0, 1.0)
        if np.linalg.norm(c - (a + t * ab)) <= width_m:
            keep.append(o)
    return replace(scn, obstacles=tuple(keep))


def measure(name: str, scn: Scenario, load_s: float, seeds: int) -> dict:
    t0 = time.perf_counter()
    world = build_world(scn)
    world_s = time.perf_counter() - t0
    search = scn.planner.search
    plan_route(scn.with_planner(search=replace(search, iterations=3)), world=world)  # warm-up
    core, energy, iters, clear, free = [], [], [], [], 0
    for seed in range(1, seeds + 1):
        r = plan_route(scn.with_planner(search=replace(search, seed=seed)), world=world)
        core.append(r.runtime_s)
        energy.append(r.energy)
        iters.append(r.planner.iterations)
        clear.append(r.min_clearance_m)
        free += bool(r.collision_free)
    return {
        "scenario": name,
        "obstacles": len(scn.obstacles),
        # the terrain's height field: its cells (each quad of posts cut s x s)
        "ground": 0 if scn.site.ground is None else int(scn.site.ground.field.slope.size),
        "load_s": load_s,
        "world_s": world_s,
        "core_s": statistics.median(core),
        "iterations": statistics.median(iters),
        "energy": statistics.mean(energy),
        "clearance": min(clear),
        "free": f"{free}/{seeds}",
    }


def timed_load(path: Path) -> tuple[Scenario, float]:
    t0 = time.perf_counter()
    scn = load_scenario(path)
    return scn, time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--buildings", type=int, default=5000)
    args = parser.parse_args()
    rows = []
    for mission in ("helsinki-centre", "jacksboro-ridge"):
        scn, load_s = timed_load(ROOT / "missions" / f"{mission}.yaml")
        rows.append(measure(mission, scn, load_s, args.seeds))
    with tempfile.TemporaryDirectory() as tmp:
        scn, load_s = timed_load(district_scenario(Path(tmp), args.buildings))
        rows.append(measure(scn.name, scn, load_s, args.seeds))
        near = near_line(scn, 300.0)
        rows.append(measure(f"{scn.name} (≤300 m of the line)", near, 0.0, args.seeds))
    load = os.getloadavg()
    print(f"# {args.seeds} seeds; load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    cols = ["scenario", "obstacles", "ground", "load_s", "world_s", "core_s", "iterations"]
    cols += ["energy", "clearance", "free"]
    print("| " + " | ".join(c.replace("_", " ") for c in cols) + " |")
    print("|" + "---|" * len(cols))
    for row in rows:
        cells = [f"{row[c]:.2f}" if isinstance(row[c], float) else str(row[c]) for c in cols]
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
