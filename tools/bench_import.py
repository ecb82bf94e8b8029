"""Import benchmark (issue 10): time to read obstacles from real and synthetic files.

Prints a table: the bundled central-Helsinki extract (``maps/helsinki-centre.osm.pbf``) and a
synthetic district of N buildings (default 5,000) generated here, written both as an OSM PBF
(with pyosmium) and as a GeoPackage (with pyogrio), each read through
:func:`uavplan.sources.read_obstacle_file` (parse + lon/lat → ENU + clip + simplify + split).
Also prints the cold import time of each field library (a fresh interpreter each).

Run: ``python tools/bench_import.py [--buildings 5000] [--repeat 3]``. Times are the best of
``--repeat`` runs after one warm-up; the machine's other load shows in them.
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from uavplan.geo import EnuFrame, GeoPoint  # noqa: E402
from uavplan.obstacles import Bounds  # noqa: E402
from uavplan.sources import ObstacleFileSpec, read_obstacle_file  # noqa: E402

ORIGIN = GeoPoint(47.3769, 8.5417, 408.0)  # a synthetic district in Zurich's frame
FRAME = EnuFrame.at(ORIGIN)


def district(n: int, seed: int = 1) -> list[dict[str, Any]]:
    """``n`` buildings on a street grid: rotated rectangles and L shapes, every 20th a
    courtyard block; heights as tags in metres, feet or levels, some missing."""
    rng = np.random.default_rng(seed)
    side = math.ceil(math.sqrt(n))
    pitch = 40.0  # 40 m plots: 25 m streets between 15-30 m buildings
    out = []
    for k in range(n):
        cx = (k % side - side / 2) * pitch
        cy = (k // side - side / 2) * pitch
        w, d = rng.uniform(10, 30), rng.uniform(10, 30)
        yaw = rng.uniform(-0.3, 0.3)
        if k % 7 == 3:  # an L shape
            ring = [
                (-w / 2, -d / 2),
                (w / 2, -d / 2),
                (w / 2, 0),
                (0, 0),
                (0, d / 2),
                (-w / 2, d / 2),
            ]
        else:
            ring = [(-w / 2, -d / 2), (w / 2, -d / 2), (w / 2, d / 2), (-w / 2, d / 2)]
        c, s = math.cos(yaw), math.sin(yaw)
        outer = [(cx + c * u - s * v, cy + s * u + c * v) for u, v in ring]
        inner = None
        if k % 20 == 0 and len(ring) == 4:  # courtyard blocks are rectangles
            inner = [
                (cx + c * u * 0.4 - s * v * 0.4, cy + s * u * 0.4 + c * v * 0.4)
                for u, v in ring[::-1]
            ]
        tags = {"building": "yes"}
        r = k % 4
        if r == 0:
            tags["height"] = f"{rng.uniform(6, 60):.1f}"
        elif r == 1:
            tags["height"] = f"{rng.uniform(20, 200):.0f}'"
        elif r == 2:
            tags["building:levels"] = str(int(rng.integers(1, 15)))
        out.append({"outer": outer, "inner": inner, "tags": tags})
    return out


def lonlat(ring: list[tuple[float, float]]) -> list[tuple[float, float]]:
    pts = np.array([[x, y, 0.0] for x, y in ring])
    lat, lon, _ = FRAME.to_geodetic(pts)
    return list(zip(lon.tolist(), lat.tolist(), strict=True))


def write_pbf(buildings: list[dict[str, Any]], path: Path) -> None:
    import osmium
    from osmium.osm.mutable import Node, Relation, Way

    writer = osmium.SimpleWriter(str(path))
    next_id = 1
    ways: list[Any] = []
    relations: list[Any] = []
    try:
        for b in buildings:
            rings = [b["outer"]] + ([b["inner"]] if b["inner"] else [])
            way_ids = []
            for ring in rings:
                ids = []
                for lon, lat in lonlat(ring):
                    writer.add_node(Node(id=next_id, location=(lon, lat)))
                    ids.append(next_id)
                    next_id += 1
                way_ids.append(next_id)
                tags = b["tags"] if b["inner"] is None else {}
                ways.append(Way(id=next_id, nodes=[*ids, ids[0]], tags=tags))
                next_id += 1
            if b["inner"]:
                members = [("w", way_ids[0], "outer"), ("w", way_ids[1], "inner")]
                relations.append(
                    Relation(
                        id=next_id, members=members, tags={"type": "multipolygon", **b["tags"]}
                    )
                )
                next_id += 1
        for w in ways:
            writer.add_way(w)
        for r in relations:
            writer.add_relation(r)
    finally:
        writer.close()


def write_gpkg(buildings: list[dict[str, Any]], path: Path) -> None:
    import pyogrio.raw
    import shapely

    from uavplan.sources import parse_height_m

    polys = [
        shapely.Polygon(lonlat(b["outer"]), [lonlat(b["inner"])] if b["inner"] else None)
        for b in buildings
    ]
    heights = np.array(
        [parse_height_m(b["tags"].get("height")) or np.nan for b in buildings], dtype=float
    )
    pyogrio.raw.write(
        path,
        shapely.to_wkb(np.array(polys, dtype=object)),
        [heights],
        ["height_m"],
        layer="buildings",
        driver="GPKG",
        geometry_type="Polygon",
        crs="EPSG:4326",
    )


def best_time(spec: ObstacleFileSpec, bounds: Bounds | None, repeat: int) -> tuple[float, Any]:
    read_obstacle_file(spec, spec_frame(spec), bounds)  # warm-up
    best, result = math.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        result = read_obstacle_file(spec, spec_frame(spec), bounds)
        best = min(best, time.perf_counter() - t0)
    return best, result


def spec_frame(spec: ObstacleFileSpec) -> EnuFrame:
    if "helsinki" in spec.path.name:
        return EnuFrame.at(GeoPoint(60.171586, 24.94429, 10.0))
    return FRAME


def cold_import_s(module: str) -> float:
    code = f"import time; t = time.perf_counter(); import {module}; print(time.perf_counter() - t)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return float(out.stdout.strip())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--buildings", type=int, default=5000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        buildings = district(args.buildings)
        pbf = Path(tmp) / f"district-{args.buildings}.osm.pbf"
        gpkg = Path(tmp) / f"district-{args.buildings}.gpkg"
        write_pbf(buildings, pbf)
        write_gpkg(buildings, gpkg)
        gen_s = time.perf_counter() - t0
        helsinki = ObstacleFileSpec(ROOT / "maps" / "helsinki-centre.osm.pbf", default_height_m=20)
        cases = [
            ("helsinki-centre.osm.pbf (bundled)", helsinki, None),
            (
                "helsinki-centre.osm.pbf, scenario bounds",
                helsinki,
                Bounds((-450.0, 450.0), (-600.0, 600.0), (0.0, 60.0)),
            ),
            (f"synthetic {args.buildings} buildings .osm.pbf", ObstacleFileSpec(pbf), None),
            (
                f"synthetic {args.buildings} buildings .gpkg",
                ObstacleFileSpec(gpkg, height_attribute="height_m"),
                None,
            ),
        ]
        for label, spec, bounds in cases:
            seconds, result = best_time(spec, bounds, args.repeat)
            size_kb = spec.path.stat().st_size / 1024
            rows.append(
                (
                    label,
                    size_kb,
                    sum(result.kept.values()),
                    sum(result.skipped.values()),
                    len(result.obstacles),
                    seconds,
                )
            )

    print(
        f"import benchmark (best of {args.repeat} after a warm-up; district generated "
        f"in {gen_s:.1f} s)"
    )
    print(
        f"{'file':44s} {'size kB':>8s} {'kept':>6s} {'skipped':>8s} {'obstacles':>10s} "
        f"{'import s':>9s}"
    )
    for label, size_kb, kept, skipped, n_obs, seconds in rows:
        print(f"{label:44s} {size_kb:8.0f} {kept:6d} {skipped:8d} {n_obs:10d} {seconds:9.2f}")
    print()
    print(f"{'library (cold import, fresh interpreter)':44s} {'s':>9s}")
    for module in ("osmium", "pyogrio", "rasterio", "shapely", "pyproj"):
        print(f"{module:44s} {cold_import_s(module):9.2f}")


if __name__ == "__main__":
    main()
