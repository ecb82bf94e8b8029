#!/usr/bin/env python3
"""The bundled DEM survey flown on the real firmware against the flight model (issues 32, 33);
prints a table.

``uavplan plan`` plans missions/surveys/survey-jacksboro-ridge.yaml for the flavour, then
``uavplan fly --upload`` flies it on SITL (tests/helpers/sitl.py starts the firmware; the cache in
``--flights`` keeps a flight for the same mission, flavour, speed-up and binary) and
``simulate``'s flight model flies the same plan. The lanes over the ridge climb and descend:
per lane, the altitude of each track against the lane's planned line at the first photo
positions (0.5 m, then one and two trigger distances after the lane's first waypoint; a
photo's height above the ground is off by as much), and the flight times.

SITL's own world is flat at home: the firmware flies the mission's AMSL altitudes as
written, which is all the comparison needs (the model flies them over the DEM).

    python tools/sitl_survey.py --autopilot px4 --flights /tmp/survey-flights
    python tools/sitl_survey.py --autopilot px4 --flights /tmp/survey-flights --replay
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from helpers import sitl  # noqa: E402  (the SITL helpers live with the tests)
from helpers import sitl_flight as sf  # noqa: E402

from uavplan.mission.io import load_mission  # noqa: E402
from uavplan.mission.items import Autopilot, MavCmd  # noqa: E402

RIDGE = ROOT / "missions" / "surveys" / "survey-jacksboro-ridge.yaml"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--autopilot", choices=["ardupilot", "px4"], default="px4")
    ap.add_argument("--speedup", type=float, default=8.0)
    ap.add_argument("--flights", type=Path, required=True, help="cache of flights")
    ap.add_argument("--replay", action="store_true", help="the cached flight, no flying")
    args = ap.parse_args()
    flavour = Autopilot.from_name(args.autopilot)
    args.flights.mkdir(parents=True, exist_ok=True)
    cached = args.flights / f"ridge-{flavour.label}.plan"
    flight_file = cached.with_suffix(".json")
    if args.replay:
        if not flight_file.exists():
            print(f"no cached flight at {flight_file}", file=sys.stderr)
            return 2
        plan_path = cached
    else:
        why = sitl.missing(flavour)
        if why is not None:
            print(why, file=sys.stderr)
            return 2
        work = Path(tempfile.mkdtemp(prefix="sitl-survey-"))
        variant = sitl.scenario_variant(RIDGE, flavour, "bundled", work, amsl=True)
        plan_path = work / "ridge.plan"
        from uavplan.app.feedback import Feedback
        from uavplan.app.plan import PlanRequest, plan

        plan(PlanRequest(str(variant), str(plan_path), autopilot=flavour.label), Feedback())
    mission = load_mission(plan_path)
    model = sf.model_flight(mission, flavour, sf.plan_params(mission, flavour))
    if not args.replay:
        print(f"flying the ridge survey on {flavour.label} SITL ...", file=sys.stderr)
        flight = sf.fly(
            plan_path,
            flavour,
            speedup=args.speedup,
            params=dict(sitl.FLIGHT_PARAMS[flavour]),
            model_s=model.flight_time_s,
            extra_args=("--set-params",) if mission.parameters else (),
        )
        flight.save(flight_file)
        cached.write_bytes(plan_path.read_bytes())
    flight = sf.Flight.load(flight_file)
    assert mission.home is not None
    trig = next(
        it.param1
        for it in mission.items
        if it.command == int(MavCmd.DO_SET_CAM_TRIGG_DIST) and it.param1 > 0
    )
    marks = (0.5, 0.5 + trig, 0.5 + 2 * trig)
    fw_path = flight.path(mission.home)
    takeoff_seq, end_seq = sf.marks(mission, flavour)
    landing_z = sf.landing_height(mission)
    fw_phases = sf.phases(fw_path, takeoff_seq, end_seq, landing_z)
    model_path = sf.FlownPath.from_model(model)
    m_phases = sf.phases(model_path, takeoff_seq, end_seq, landing_z)
    rows_m = sf.lane_errors(plan_path, model_path, marks)
    rows_f = sf.lane_errors(plan_path, fw_path, marks)
    print(
        f"`python tools/sitl_survey.py --autopilot {flavour.label}`: {RIDGE.name}, "
        f"{flavour.label} SITL (exit {flight.exit_code}) at speed-up {flight.speedup:g}; "
        f"take-off to touchdown model {m_phases.flight_s:.1f} s, SITL "
        f"{fw_phases.flight_s:.1f} s ({fw_phases.flight_s / m_phases.flight_s - 1:+.1%})"
    )
    print()
    at = " / ".join(f"{d:.1f}" for d in marks)
    print(f"| lane (items) | climb over length | model: altitude - lane m at {at} m | SITL |")
    print("|---|---|---|---|")

    def cells(errs: list[float]) -> str:
        return " / ".join("-" if np.isnan(e) else f"{e:+.1f}" for e in errs)

    worst = [0.0, 0.0]
    for (a, b, dz, length, em), (_, _, _, _, ef) in zip(rows_m, rows_f, strict=True):
        print(f"| {a} → {b} | {dz:+.1f} m over {length:.0f} m | {cells(em)} | {cells(ef)} |")
        worst[0] = max(worst[0], float(np.nanmax(np.abs(em))))
        worst[1] = max(worst[1], float(np.nanmax(np.abs(ef))))
    print()
    print(f"largest |altitude - lane|: model {worst[0]:.1f} m, SITL {worst[1]:.1f} m")
    return 0


if __name__ == "__main__":
    sys.exit(main())
