"""Every bundled scenario, in both flavours, with and without ``upload --set-params``: plan it,
simulate it, fly it, check the whole flown track (issue 37).

For each of missions/*.yaml and missions/qgc-inspection.plan, as PX4 and as ArduPilot:

1. ``uavplan plan --fence`` (the .plan is rerouted in its own geofence; jacksboro-ridge is
   flown with AMSL altitudes: PX4 flies no terrain frames, and the simulated vehicle has no terrain
   database, so it would fly ArduPilot's terrain-frame altitudes over flat ground; the
   bundled terrain-frame mission is planned and simulated over the DEM in a row of its own);
2. ``uavplan simulate --scenario``: the whole flight's verdict (exit 0: the flight keeps the
   margin with the parameters the mission relies on);
3. ``uavplan mock-vehicle --speedup 20`` (a process standing at the plan's home, holding
   nothing and the firmware's default parameters), then either ``uavplan upload
   --set-params`` (the parameters the mission relies on, then the mission) or nothing, and
   ``uavplan fly --scenario --track``;
4. the whole track file, take-off to touchdown, checked by the end-to-end test's independent
   distance computation (tests/helpers/track_check.py), and the flown time against the model's.

Each flight's outcome is one of: ``flown safely`` (fly exit 0, the track keeps the margin),
``refused before take-off`` (fly names what it refused, nothing flown), ``unsafe, reported``
(fly exit 3: the track broke the margin and fly said so), or ``UNSAFE REPORTED AS SUCCESS``
(fly exit 0 on a track that broke the margin: the defect issue 37 is about). One more pair
of rows flies paper-env1 planned without the legal ceiling (``--legal-ceiling none``: its
mission relies on RTL_ALT 230 m), where flying without ``--set-params`` matters.

Prints one table row per flight and exits 1 if any row is unsafe and reported as success,
or a safe plan did not fly safely. Simulated time runs 20 times faster than the wall clock,
so the whole matrix takes about three quarters of an hour.

    python tools/fly_all.py [--speedup 20] [--only paper-env1] [--autopilot px4] [--json rows.json]
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

from helpers.track_check import (  # noqa: E402  (the independent check lives with the tests)
    fence_clearance,
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
    source: Path,
    autopilot: Autopilot,
    speedup: float,
    work: Path,
    *,
    set_params: bool,
    as_bundled: bool = False,
    extra: tuple[str, ...] = (),
    label: str = "",
) -> dict[str, object]:
    """Plan, simulate, fly and check one scenario; ``set_params``: ``upload --set-params``
    before ``fly``; ``as_bundled``: plan and simulate the scenario file as it is, and fly
    nothing (the terrain-frame row); ``extra``: more ``plan`` options."""
    name = source.stem + (" (terrain frames)" if as_bundled else "") + label
    row: dict[str, object] = {
        "scenario": name,
        "autopilot": autopilot.label,
        "set_params": set_params,
    }
    planned = work / f"{source.stem}-{autopilot.label}.plan"
    report = work / f"{source.stem}-{autopilot.label}.json"
    is_qgc = source.suffix == ".plan"
    scenario = None if is_qgc else (source if as_bundled else scenario_for(source, autopilot, work))
    args = ["plan", str(source if is_qgc else scenario), "-o", str(planned), "-q",
            "--report", str(report), *extra]  # fmt: skip
    if not is_qgc:  # a .plan keeps its own flavour and geofence
        args += ["--autopilot", autopilot.label, "--fence"]
    code, out = sh(*args)
    row["plan"] = code
    if code != 0:
        row["error"] = out.strip().splitlines()[-1]
        return row
    plan = load_mission(planned)
    row["relies_on"] = ", ".join(p.name for p in plan.parameters) or "-"
    sim_args = ["simulate", str(planned), "--autopilot", autopilot.label]
    if scenario is not None:
        sim_args += ["--scenario", str(scenario)]
    code, out = sh(*sim_args)
    row["simulate"] = code
    sim = re.search(r"\((\d+\.\d) s, take-off", out)
    row["sim_airborne_s"] = None
    if as_bundled:  # over the DEM: simulate's own time (mission start to touchdown)
        row["sim_airborne_s"] = float(sim.group(1)) if sim else None
        return row
    from uavplan.rehearsal import rehearse
    from uavplan.verdict import held_parameters

    held, _, _ = held_parameters(plan, autopilot)
    row["sim_airborne_s"] = rehearse(plan, autopilot=autopilot, params=held).airborne_s
    proc, port = start_vehicle(autopilot, plan, speedup)
    track = work / f"{source.stem}-{autopilot.label}.csv"
    conn = f"udpout:127.0.0.1:{port}"
    try:
        if set_params:
            code, out = sh("upload", str(planned), "--conn", conn, "--set-params")
            row["upload"] = code
        fly_args = ["fly", str(planned), "--conn", conn, "--track", str(track), "-q"]
        if scenario is not None:
            fly_args += ["--scenario", str(scenario)]
        started = time.monotonic()
        code, out = sh(*fly_args, timeout=3600)
        row["fly_wall_s"] = round(time.monotonic() - started, 1)
    finally:
        stop_vehicle(proc)
    row["fly"] = code
    lines = [line for line in out.strip().splitlines() if line.startswith("error:")]
    if lines:
        row["error"] = lines[-1]
    flown = TIME.search(out)
    if flown:
        row["fly_airborne_s"] = 60 * int(flown.group(1)) + int(flown.group(2))
    flown_track = Track.load(track) if track.exists() else None
    if flown_track is None or len(flown_track) < 2 or max(flown_track.relative_alt_m) < 1.0:
        row["outcome"] = "refused before take-off" if code != 0 else "not flown"
        return row
    if scenario is not None:
        row["margin_m"] = load_scenario(scenario).safety_margin_m
        row["track_clearance_m"] = scenario_clearance(scenario, flown_track)
    else:
        from uavplan.worlds import DEFAULT_MARGIN_M

        row["margin_m"] = DEFAULT_MARGIN_M
        row["track_clearance_m"] = fence_clearance(plan, flown_track)
    safe = float(row["track_clearance_m"]) >= float(row["margin_m"]) - 0.05  # type: ignore[arg-type]
    if code == 0:
        row["outcome"] = "flown safely" if safe else "UNSAFE REPORTED AS SUCCESS"
    else:
        row["outcome"] = f"unsafe, reported (exit {code})" if not safe else f"exit {code}"
    return row


def verdict(row: dict[str, object]) -> bool:
    """A row holds: the terrain-frame row simulates; a flight either flew safely (on time,
    within 5 % of the model) or was refused or reported; none is unsafe called success; and
    a mission planned safe (simulate exit 0) with its parameters set flies safely."""
    if "(terrain frames)" in str(row["scenario"]):
        return row.get("simulate") == 0
    outcome = str(row.get("outcome", ""))
    if outcome == "UNSAFE REPORTED AS SUCCESS":
        return False
    if row.get("set_params") and row.get("simulate") == 0 and outcome != "flown safely":
        return False
    if outcome == "flown safely":
        try:
            flown = float(row["fly_airborne_s"])  # type: ignore[arg-type]
            model = float(row["sim_airborne_s"])  # type: ignore[arg-type]
        except (KeyError, TypeError, ValueError):
            return False
        return abs(flown / model - 1.0) <= 0.05
    return outcome.startswith(("refused", "unsafe, reported"))


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
    header = (f"{'scenario':34} {'flavour':9} {'--set-params':12} {'relies on':34} {'sim':>3} "
              f"{'fly':>3} {'model s':>8} {'flown s':>7} {'diff':>6} {'clear':>6} {'margin':>6}  "
              "outcome")  # fmt: skip
    print(header)
    runs: list[tuple[Path, Autopilot, bool, bool, tuple[str, ...], str]] = [
        (source, autopilot, set_params, False, (), "")
        for source in sources
        for autopilot in flavours
        for set_params in (True, False)
    ]
    env1 = ROOT / "missions" / "paper-env1.yaml"
    if env1 in sources:
        for autopilot in flavours:
            for set_params in (True, False):
                runs.append((env1, autopilot, set_params, False, ("--legal-ceiling", "none"),
                             " (no legal ceiling)"))  # fmt: skip
    if any(s.stem == "jacksboro-ridge" for s in sources) and Autopilot.ARDUPILOT in flavours:
        runs.append((ROOT / "missions" / "jacksboro-ridge.yaml", Autopilot.ARDUPILOT, False,
                     True, (), ""))  # fmt: skip
    with tempfile.TemporaryDirectory() as tmp:
        for k, (source, autopilot, set_params, as_bundled, extra, label) in enumerate(runs):
            work = Path(tmp) / f"{k}-{source.stem}-{autopilot.label}"
            work.mkdir()
            row = one(source, autopilot, args.speedup, work, set_params=set_params,
                      as_bundled=as_bundled, extra=extra, label=label)  # fmt: skip
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
                f"{row['scenario']:34} {row['autopilot']:9} "
                f"{('-' if as_bundled else ('yes' if set_params else 'no')):12} "
                f"{str(row.get('relies_on', '-'))[:34]:34} {row.get('simulate', '-')!s:>3} "
                f"{row.get('fly', '-')!s:>3} "
                f"{(f'{model:.1f}' if model else '-'):>8} "
                f"{(f'{flown:.0f}' if flown else '-'):>7} {diff:>6} "
                f"{(f'{clear:.2f}' if clear is not None else '-'):>6} "
                f"{row.get('margin_m', '-')!s:>6}  {row.get('outcome', '-')}"
                + ("" if row["ok"] else "  NOT OK")
                + (f"  {row['error']}" if "error" in row else ""),
                flush=True,
            )
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1, default=str))
    failed = [r for r in rows if not r["ok"]]
    unsafe_ok = [r for r in rows if r.get("outcome") == "UNSAFE REPORTED AS SUCCESS"]
    print(
        f"{len(rows) - len(failed)} of {len(rows)} rows hold; {len(unsafe_ok)} unsafe flights "
        "reported as success"
    )
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
