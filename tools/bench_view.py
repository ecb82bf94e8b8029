#!/usr/bin/env python3
"""What the page of ``uavplan view`` weighs and how fast it works: a table.

For each mission (planned first with ``uavplan plan``): the wall time of ``uavplan view
M.plan --scenario S -o M.html`` (the whole command, as a user waits for it), the page's
size and its obstacle mesh, and in headless Chromium (tests/helpers/browser.py; WebGL on the CPU
through SwiftShader, so slower than any browser with a GPU): the time from opening the file
to the page drawn, one step of the replay (the vehicle moved in the 3-D view and the
profile), and one step of turning the 3-D view with the mouse (a drag, the scene redrawn).
Medians of ``--repeat`` runs; the load average is printed with the table (the machine is
shared).

    python tools/bench_view.py                       # paper-env1, helsinki-centre, jacksboro
    python tools/bench_view.py --district 5000       # and a synthetic district of 5,000
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from helpers.browser import Browser, unavailable  # noqa: E402

MISSIONS = ("paper-env1", "helsinki-centre", "jacksboro-ridge")
#: camera steps and replay steps timed in the browser
STEPS = 20


def uavplan(*args: str, cwd: Path) -> tuple[float, subprocess.CompletedProcess[str]]:
    t0 = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "uavplan", *args], capture_output=True, text=True, cwd=cwd
    )
    return time.perf_counter() - t0, done


def timed_in_page(loaded: object, script: str) -> float:
    """Mean ms of one step of ``script`` (an async function of the step number)."""
    page = loaded.page  # type: ignore[attr-defined]
    return float(
        page.evaluate(
            f"""async () => {{
              const step = {script};
              const t0 = performance.now();
              for (let n = 1; n <= {STEPS}; n++) await step(n);
              return (performance.now() - t0) / {STEPS};
            }}"""
        )
    )


def turn_ms(loaded: object) -> float:
    """Mean ms of one step of turning the view with the mouse (a drag of 12 px, then two
    animation frames: the scene redrawn), as a user turns it."""
    page = loaded.page  # type: ignore[attr-defined]
    box = page.locator("#scene3d").bounding_box()
    x, y = box["x"] + box["width"] * 0.5, box["y"] + box["height"] * 0.6
    page.mouse.move(x, y)
    page.mouse.down()
    t0 = time.perf_counter()
    for n in range(1, STEPS + 1):
        page.mouse.move(x + 12 * n, y)
        page.evaluate(
            "() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))"
        )
    elapsed = time.perf_counter() - t0
    page.mouse.up()
    return 1000.0 * elapsed / STEPS


REPLAY = """async (n) => {
  const V = window.uavplanView;
  const last = Number(document.getElementById('replay').max);
  await V.show(Math.round(n * last / 21));
  await new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)));
}"""


def measure(name: str, scenario: Path, folder: Path, browser: Browser, repeat: int) -> dict:
    plan = folder / f"{name}.plan"
    _, done = uavplan("plan", str(scenario), "-o", plan.name, "-q", cwd=folder)
    if done.returncode != 0:
        raise SystemExit(f"plan {scenario}: exit {done.returncode}\n{done.stderr}")
    page = folder / f"{name}.html"
    times = []
    for _ in range(repeat):
        elapsed, done = uavplan(
            "view", plan.name, "--scenario", str(scenario), "-o", page.name, cwd=folder
        )
        if done.returncode not in (0, 3):  # 3: the page shows a problem, written anyway
            raise SystemExit(f"view {plan}: exit {done.returncode}\n{done.stderr}")
        times.append(elapsed)
    html = page.read_text(encoding="utf-8")
    doc = json.loads(
        re.search(
            r'<script id="uavplan-data" type="application/json">(.*?)</script>', html, re.S
        ).group(1)  # type: ignore[union-attr]
    )
    loads, turns, replays = [], [], []
    for _ in range(repeat):
        loaded = browser.open(page)
        try:
            if loaded.errors or loaded.view("V.error"):
                raise SystemExit(f"{page}: {loaded.errors or loaded.view('V.error')}")
            loads.append(loaded.load_s)
            turns.append(turn_ms(loaded))
            replays.append(timed_in_page(loaded, REPLAY))
        finally:
            loaded.page.close()
    return {
        "name": name,
        "obstacles": len(doc["scene"]["obstacles"]),
        "triangles": doc["scene"]["mesh"]["triangles"],
        "mb": os.path.getsize(page) / 1e6,
        "view_s": statistics.median(times),
        "load_s": statistics.median(loads),
        "turn_ms": statistics.median(turns),
        "replay_ms": statistics.median(replays),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("names", nargs="*", default=list(MISSIONS), help="bundled missions")
    parser.add_argument("--district", type=int, help="also a synthetic district of N buildings")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args(argv)
    why = unavailable()
    if why is not None:
        raise SystemExit(f"no browser: {why}")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        browser = Browser()
        try:
            for name in args.names:
                scenario = ROOT / "missions" / f"{name}.yaml"
                rows.append(measure(name, scenario, folder, browser, args.repeat))
            if args.district:
                scenario = folder / f"district-{args.district}.yaml"
                subprocess.run(
                    [sys.executable, str(ROOT / "tools" / "make_district.py"),
                     "-n", str(args.district), "-o", str(scenario)],
                    check=True, capture_output=True,
                )  # fmt: skip
                rows.append(
                    measure(f"district-{args.district}", scenario, folder, browser, args.repeat)
                )
        finally:
            browser.close()
    load = os.getloadavg()
    print(
        f"# {dt.date.today()}, load {load[0]:.1f} {load[1]:.1f} {load[2]:.1f} on "
        f"{os.cpu_count()} cores; medians of {args.repeat}; Chromium headless, WebGL on the "
        "CPU (SwiftShader)"
    )
    print(
        "| mission | obstacles | mesh triangles | page MB | `view` s | page drawn s "
        "| turn step ms | replay step ms |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(
            f"| {r['name']} | {r['obstacles']:,} | {r['triangles']:,} | {r['mb']:.1f} "
            f"| {r['view_s']:.2f} | {r['load_s']:.2f} | {r['turn_ms']:.0f} | "
            f"{r['replay_ms']:.0f} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
