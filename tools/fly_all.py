"""Every bundled scenario, in both flavours: plan it, simulate it, fly it, check the track.

For each of missions/*.yaml and missions/qgc-inspection.plan, as PX4 and as ArduPilot:

1. ``uavplan plan`` (the .plan is rerouted; jacksboro-ridge flies AMSL altitudes as PX4,
   which flies no terrain frames);
2. ``uavplan simulate --scenario``: the flight model's track keeps the margin (exit 0) and
   its take-off-to-touchdown time;
3. ``uavplan mock-vehicle --speedup 20`` (a process, standing at the plan's home, holding
   nothing) and ``uavplan fly --scenario --track``: exit 0;
4. the track file checked by the end-to-end test's independent distance computation
   (tests/test_end_to_end.py: its own polygon and cylinder distances, and scipy over the
   raw DEM posts for the terrain), from take-off to where the autopilot's return to launch
   begins; and the flown time against the simulated one (within 5 %).

Prints one table row per flight and exits 1 if any row fails. Simulated time runs 20 times
faster than the wall clock, so the whole matrix takes about a quarter of an hour.

    python tools/fly_all.py [--speedup 20] [--only paper-env1] [--autopilot px4]
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from test_end_to_end import (  # noqa: E402  (the independent check lives with the tests)
    _edge_distance,
    _inside,
    densify,
    independent_clearance,
    independent_ground,
)

from uavplan.geo import EnuFrame  # noqa: E402
from uavplan.mission.io import load_mission  # noqa: E402
from uavplan.mission.items import Autopilot, MissionPlan  # noqa: E402
from uavplan.mission.track import Track  # noqa: E402
from uavplan.obstacles import CylinderObstacle, PrismObstacle  # noqa: E402
from uavplan.rehearsal import return_seq  # noqa: E402
from uavplan.scenario import load_scenario  # noqa: E402

UAVPLAN = [sys.executable, "-m", "uavplan"]
TIME = re.compile(r"(\d+) min (\d+) s take-off to touchdown")
QGC = ROOT / "missions" / "qgc-inspection.plan"


def sh(*args: str, timeout: float = 1200) -> tuple[int, str]:
    done = subprocess.run([*UAVPLAN, *args], capture_output=True, text=True, timeout=timeout)
    return done.returncode, done.stdout + done.stderr


def scenario_for(source: Path, autopilot: Autopilot, work: Path) -> Path:
    """The scenario to plan: jacksboro-ridge flies AMSL altitudes as PX4."""
    if source.stem != "jacksboro-ridge" or autopilot != Autopilot.PX4:
        return source
    text = source.read_text(encoding="utf-8")
    dem = (source.parent / "../maps/jacksboro-fault-dem.tif").resolve()
    shutil.copy(dem, work / "dem.tif")
    text = text.replace("../maps/jacksboro-fault-dem.tif", "dem.tif")
    copy = work / "jacksboro-ridge-amsl.yaml"
    copy.write_text(text.replace("altitude: terrain", "altitude: amsl"), encoding="utf-8")
    return copy


def mission_part(track: Track, plan: MissionPlan, autopilot: Autopilot) -> Track:
    rtl = return_seq(plan, autopilot)
    if rtl is None:
        return track
    hits = np.flatnonzero(track.current_seq >= rtl)
    return track.until(int(hits[0]) + 1 if hits.size else len(track))


def independent_scenario_clearance(scenario_path: Path, track: Track) -> float:
    """The least distance from the track (take-off climb included, the landing's last
    metre to the ground excluded) to the scenario's obstacles and, over a DEM, to the
    ground (from where the take-off has climbed the margin), by the end-to-end check."""
    scenario = load_scenario(scenario_path)
    site = scenario.site
    frame = EnuFrame.at(site.origin)
    xy = frame.to_enu_xy(track.lat_deg, track.lon_deg)
    if site.ground is None:
        z = track.relative_alt_m
    else:
        z = track.alt_amsl_m - site.origin.alt_m
    points = np.column_stack((xy, z))
    keep = np.concatenate(([True], np.any(np.diff(points, axis=0) != 0, axis=1)))
    points = points[keep]
    dense = densify(points, 0.5)
    best = float(independent_clearance(scenario, dense).min())
    if site.ground is not None:
        ground = independent_ground(scenario, frame)
        agl = dense[:, 2] - ground(dense[:, :2])
        climbed = np.flatnonzero(agl >= scenario.safety_margin_m)
        if climbed.size:  # from the first point the take-off has raised above the margin
            best = min(best, float(agl[climbed[0] :].min()))
    return best


def independent_fence_clearance(plan: MissionPlan, track: Track, margin_m: float) -> float:
    """The least distance from the track to the plan's exclusion zones and to the edge of
    its inclusion fence (inside it), computed here like the end-to-end check does."""
    assert plan.home is not None
    frame = EnuFrame.at(plan.home)
    xy = frame.to_enu_xy(track.lat_deg, track.lon_deg)
    points = densify(np.column_stack((xy, track.relative_alt_m)), 0.5)
    obstacles: list[object] = []
    inclusion = []
    for poly in plan.fence.polygons:
        ring = frame.to_enu_xy([v[0] for v in poly.vertices], [v[1] for v in poly.vertices])
        if poly.inclusion:
            inclusion.append(ring)
        else:
            obstacles.append(PrismObstacle(tuple(map(tuple, ring)), 10_000.0))
    for circle in plan.fence.circles:
        (cx, cy), = frame.to_enu_xy([circle.center[0]], [circle.center[1]])  # fmt: skip
        obstacles.append(CylinderObstacle((float(cx), float(cy)), circle.radius_m, 10_000.0))
    fake = SimpleNamespace(site=SimpleNamespace(obstacles=obstacles))
    best = float(independent_clearance(fake, points).min()) if obstacles else np.inf
    for ring in inclusion:
        px, py = points[:, 0], points[:, 1]
        edge = _edge_distance(px, py, np.asarray(ring))
        edge = np.where(_inside(px, py, np.asarray(ring)), edge, -edge)
        best = min(best, float(edge.min()))
    return best


def start_vehicle(
    autopilot: Autopilot, plan: MissionPlan, speedup: float
) -> tuple[subprocess.Popen[str], int]:
    assert plan.home is not None
    home = f"{plan.home.lat_deg:.8f},{plan.home.lon_deg:.8f},{plan.home.alt_m:.3f}"
    args = [*UAVPLAN, "mock-vehicle", "--conn", "udpin:127.0.0.1:0", "--autopilot",
            autopilot.label, "--speedup", f"{speedup:g}", "--home", home]  # fmt: skip
    proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    assert proc.stderr is not None
    line = proc.stderr.readline()
    match = re.search(r"serving on udpin:127\.0\.0\.1:(\d+)", line)
    if not match:
        proc.kill()
        raise RuntimeError(f"the mock vehicle did not start: {line}")
    return proc, int(match.group(1))


def stop_vehicle(proc: subprocess.Popen[str]) -> None:
    proc.send_signal(signal.SIGINT)
    try:
        proc.communicate(timeout=20)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()


def one(source: Path, autopilot: Autopilot, speedup: float, work: Path) -> dict[str, object]:
    row: dict[str, object] = {"scenario": source.stem, "autopilot": autopilot.label}
    planned = work / f"{source.stem}-{autopilot.label}.plan"
    report = work / f"{source.stem}-{autopilot.label}.json"
    is_qgc = source.suffix == ".plan"
    scenario = None if is_qgc else scenario_for(source, autopilot, work)
    args = ["plan", str(source if is_qgc else scenario), "-o", str(planned), "-q",
            "--report", str(report)]  # fmt: skip
    if not is_qgc:
        args += ["--autopilot", autopilot.label]
    code, out = sh(*args)
    row["plan"] = code
    if code != 0:
        row["error"] = out.strip().splitlines()[-1]
        return row
    plan = load_mission(planned)
    sim_args = ["simulate", str(planned), "--autopilot", autopilot.label]
    if scenario is not None:
        sim_args += ["--scenario", str(scenario)]
    code, out = sh(*sim_args)
    row["simulate"] = code
    sim = re.search(r"\((\d+\.\d) s, take-off .*?min clearance (\d+\.\d\d) m", out)
    if sim:
        row["sim_clearance_m"] = float(sim.group(2))
    from uavplan.rehearsal import rehearse

    predicted = rehearse(plan, autopilot=autopilot).airborne_s
    row["sim_airborne_s"] = predicted
    proc, port = start_vehicle(autopilot, plan, speedup)
    track = work / f"{source.stem}-{autopilot.label}.csv"
    try:
        fly_args = ["fly", str(planned), "--conn", f"udpout:127.0.0.1:{port}", "--track",
                    str(track), "-q"]  # fmt: skip
        if scenario is not None:
            fly_args += ["--scenario", str(scenario)]
        started = time.monotonic()
        code, out = sh(*fly_args, timeout=3600)
        row["fly_wall_s"] = round(time.monotonic() - started, 1)
    finally:
        stop_vehicle(proc)
    row["fly"] = code
    flown = TIME.search(out)
    if code != 0 or not flown:
        row["error"] = out.strip().splitlines()[-1] if out.strip() else "no output"
        return row
    row["fly_airborne_s"] = 60 * int(flown.group(1)) + int(flown.group(2))
    flown_track = Track.load(track)
    part = mission_part(flown_track, plan, autopilot)
    if scenario is not None:
        row["margin_m"] = load_scenario(scenario).safety_margin_m
        row["track_clearance_m"] = independent_scenario_clearance(scenario, part)
    else:
        from uavplan.reroute import DEFAULT_MARGIN_M

        row["margin_m"] = DEFAULT_MARGIN_M
        row["track_clearance_m"] = independent_fence_clearance(plan, part, DEFAULT_MARGIN_M)
    return row


def verdict(row: dict[str, object]) -> bool:
    try:
        margin = float(row["margin_m"])  # type: ignore[arg-type]
        clear = float(row["track_clearance_m"])  # type: ignore[arg-type]
        flown = float(row["fly_airborne_s"])  # type: ignore[arg-type]
        model = float(row["sim_airborne_s"])  # type: ignore[arg-type]
    except (KeyError, TypeError, ValueError):
        return False
    on_time = abs(flown / model - 1.0) <= 0.05
    return row["simulate"] == 0 and row["fly"] == 0 and clear >= margin - 0.05 and on_time


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--speedup", type=float, default=20.0)
    parser.add_argument("--only", help="one scenario (file stem)")
    parser.add_argument("--autopilot", choices=["px4", "ardupilot"])
    parser.add_argument("--json", help="write the rows here")
    args = parser.parse_args()
    sources = [*sorted(ROOT.glob("missions/*.yaml")), QGC]
    if args.only:
        sources = [s for s in sources if s.stem == args.only]
    flavours = [Autopilot.PX4, Autopilot.ARDUPILOT]
    if args.autopilot:
        flavours = [Autopilot.from_name(args.autopilot)]
    rows = []
    header = (f"{'scenario':18} {'flavour':9} {'simulate':>8} {'fly':>4} {'model s':>8} "
              f"{'flown s':>8} {'diff':>6} {'track clear':>11} {'margin':>6}  ok")  # fmt: skip
    print(header)
    with tempfile.TemporaryDirectory() as tmp:
        for source in sources:
            for autopilot in flavours:
                work = Path(tmp) / f"{source.stem}-{autopilot.label}"
                work.mkdir()
                row = one(source, autopilot, args.speedup, work)
                row["ok"] = verdict(row)
                rows.append(row)
                model, flown = row.get("sim_airborne_s"), row.get("fly_airborne_s")
                diff = (
                    f"{100.0 * (float(flown) / float(model) - 1.0):+5.1f}%"  # type: ignore[arg-type]
                    if model and flown
                    else "-"
                )
                clear = row.get("track_clearance_m")
                print(
                    f"{row['scenario']:18} {row['autopilot']:9} {row.get('simulate', '-')!s:>8} "
                    f"{row.get('fly', '-')!s:>4} "
                    f"{(f'{model:.1f}' if model else '-'):>8} "
                    f"{(f'{flown:.0f}' if flown else '-'):>8} {diff:>6} "
                    f"{(f'{clear:.2f}' if clear is not None else '-'):>11} "
                    f"{row.get('margin_m', '-')!s:>6}  {'yes' if row['ok'] else 'NO'}"
                    + (f"  {row['error']}" if "error" in row else ""),
                    flush=True,
                )
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1, default=str))
    failed = [r for r in rows if not r["ok"]]
    print(f"{len(rows) - len(failed)} of {len(rows)} flights ok")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
