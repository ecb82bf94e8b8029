"""The bundled missions' way home: what RTL altitude each needs, under which ceilings, what
``plan`` did with it, and what a failsafe return flies (issue 37, Must show).

Each bundled scenario is planned in both flavours by ``uavplan plan -q --report`` in a fresh
process; the table comes from the reports (``way_home``, ``whole_flight``):

- *needs*: the lowest RTL altitude above home from which the autopilot's return, braking
  before it turns home, keeps the margin from every point of the flight (``-``: none up to
  the ceiling);
- *ceiling*: the flight volume's top above home; *legal*: the legal ceiling above home
  (``mission.legal_ceiling``, 120 m above the ground by default);
- *plan did*: the RTL altitude it relies on, or the planned return (or the landing) the
  mission ends with;
- *failsafe*: what a return from mid-flight flies with the parameters written: ``proven``
  (the RTL at that altitude, from every point), ``the mission`` (PX4 RTL_TYPE 2: on to the
  planned landing, the flight itself), or ``warning`` (the straight return is not safe from
  every point: ``plan`` says so as a warning).

    python tools/rtl_advice.py [--only paper-env1] [--markdown]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def row(source: Path, autopilot: str, work: Path) -> dict[str, object]:
    out, report = work / f"{source.stem}-{autopilot}.plan", work / f"{source.stem}.json"
    done = subprocess.run(
        [sys.executable, "-m", "uavplan", "plan", str(source), "-o", str(out), "-q",
         "--report", str(report), "--autopilot", autopilot],
        capture_output=True, text=True, timeout=1200, check=False,
    )  # fmt: skip
    result: dict[str, object] = {"scenario": source.stem, "autopilot": autopilot}
    if done.returncode != 0:
        result["plan"] = f"exit {done.returncode}: {done.stderr.strip().splitlines()[-1]}"
        return result
    data = json.loads(report.read_text())
    way = data["way_home"]
    whole = data.get("whole_flight") or {}
    params = {p["name"]: p for p in way["parameters"]}
    needs = way.get("rtl_safe_altitude_m")
    result["needs_m"] = needs
    result["ceiling_m"] = way.get("rtl_ceiling_m")
    result["legal_m"] = way.get("rtl_legal_ceiling_m")
    result["brake_m"] = way.get("rtl_brake_m")
    rtl = params.get("RTL_ALT") or params.get("RTL_RETURN_ALT")
    if rtl is not None:
        metres = rtl["value"] / (100.0 if rtl["unit"] == "cm" else 1.0)
        result["plan"] = f"RTL at {metres:g} m ({rtl['name']} {rtl['value']:g} {rtl['unit']})"
    elif way["planned_return"]:
        result["plan"] = "planned return" + (
            " (replaces the RTL)" if way["return_replaces_rtl"] else ""
        )
    else:
        result["plan"] = f"ends with {way['end']}"
    if "RTL_TYPE" in params:
        result["plan"] = f"{result['plan']}, RTL_TYPE 2"
    failsafe = whole.get("failsafe") or {}
    kind = failsafe.get("kind")
    result["failsafe"] = (
        "the mission" if kind == "mission" else "proven" if failsafe.get("ok") else "warning"
    )
    return result


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", help="one scenario (file stem)")
    args = parser.parse_args()
    sources = sorted(ROOT.glob("missions/*.yaml"))
    if args.only:
        sources = [s for s in sources if s.stem == args.only]
    print("| scenario | flavour | needs m | ceiling m | legal m | brake m | plan did | failsafe |")
    print("|---|---|---:|---:|---:|---:|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for source in sources:
            for autopilot in ("ardupilot", "px4"):
                r = row(source, autopilot, Path(tmp))

                def num(key: str, r: dict[str, object] = r) -> str:
                    v = r.get(key)
                    return "-" if v is None else f"{float(v):.2f}".rstrip("0").rstrip(".")  # type: ignore[arg-type]

                print(
                    f"| {r['scenario']} | {r['autopilot']} | {num('needs_m')} | "
                    f"{num('ceiling_m')} | {num('legal_m')} | {num('brake_m')} | {r.get('plan')} | "
                    f"{r.get('failsafe', '-')} |",
                    flush=True,
                )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
