"""Every bundled scenario, in both flavours: plan it, simulate it, fly it, check the track.

For each of missions/*.yaml and missions/qgc-inspection.plan, as PX4 and as ArduPilot:

1. ``uavplan plan`` (the .plan is rerouted; jacksboro-ridge is flown with AMSL altitudes:
   PX4 flies no terrain frames, and the simulated vehicle has no terrain database, so it
   would fly ArduPilot's terrain-frame altitudes over flat ground; the bundled terrain-frame
   mission is planned and simulated over the DEM in a row of its own);
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
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from track_check import (  # noqa: E402  (the independent check lives with the tests)
    fence_clearance,
    mission_part,
    scenario_clearance,
    scenario_for,
)

from uavplan.mission.io import load_mission  # noqa: E402
from uavplan.mission.items import Autopilot, MissionPlan  # noqa: E402
from uavplan.mission.track import Track  # noqa: E402
from uavplan.scenario import load_scenario  # noqa: E402

UAVPLAN = [sys.executable, "-m", "uavplan"]
TIME = re.compile(r"(\d+) min (\d+) s take-off to touchdown")
QGC = ROOT / "missions" / "qgc-inspection.plan"


def sh(*args: str, timeout: float = 1200) -> tuple[int, str]:
    done = subprocess.run([*UAVPLAN, *args], capture_output=True, text=True, timeout=timeout)
    return done.returncode, done.stdout + done.stderr


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


def one(
    source: Path, autopilot: Autopilot, speedup: float, work: Path, *, as_bundled: bool = False
) -> dict[str, object]:
    """Plan, simulate, fly and check one scenario; ``as_bundled``: plan and simulate the
    scenario file as it is, and fly nothing (the terrain-frame row)."""
    name = source.stem + (" (terrain frames)" if as_bundled else "")
    row: dict[str, object] = {"scenario": name, "autopilot": autopilot.label}
    planned = work / f"{source.stem}-{autopilot.label}.plan"
    report = work / f"{source.stem}-{autopilot.label}.json"
    is_qgc = source.suffix == ".plan"
    scenario = None if is_qgc else (source if as_bundled else scenario_for(source, autopilot, work))
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
    if as_bundled:  # over the DEM: simulate's own time (mission start to touchdown)
        row["sim_airborne_s"] = float(sim.group(1)) if sim else None
        return row
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
        row["track_clearance_m"] = scenario_clearance(scenario, part)
    else:
        from uavplan.reroute import DEFAULT_MARGIN_M

        row["margin_m"] = DEFAULT_MARGIN_M
        row["track_clearance_m"] = fence_clearance(plan, part)
    return row


def verdict(row: dict[str, object]) -> bool:
    if "(terrain frames)" in str(row["scenario"]):
        return row.get("simulate") == 0
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
    header = (f"{'scenario':32} {'flavour':9} {'simulate':>8} {'fly':>4} {'model s':>8} "
              f"{'flown s':>8} {'diff':>6} {'track clear':>11} {'margin':>6}  ok")  # fmt: skip
    print(header)
    runs = [(source, autopilot, False) for source in sources for autopilot in flavours]
    if any(s.stem == "jacksboro-ridge" for s in sources) and Autopilot.ARDUPILOT in flavours:
        runs.append((ROOT / "missions" / "jacksboro-ridge.yaml", Autopilot.ARDUPILOT, True))
    with tempfile.TemporaryDirectory() as tmp:
        for k, (source, autopilot, as_bundled) in enumerate(runs):
            work = Path(tmp) / f"{k}-{source.stem}-{autopilot.label}"
            work.mkdir()
            row = one(source, autopilot, args.speedup, work, as_bundled=as_bundled)
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
                f"{row['scenario']:32} {row['autopilot']:9} {row.get('simulate', '-')!s:>8} "
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
