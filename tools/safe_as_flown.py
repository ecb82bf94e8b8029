"""Measure the ways to make a planned mission keep its margin as the autopilot flies it.

For every bundled scenario, as PX4 and as ArduPilot, the route is planned as ``plan``
planned it before issue 24 item 4, its mission flown through the flight model
(:func:`uavplan.rehearsal.rehearse`) and checked against the scenario; then each option is
applied to the waypoints the track came too close near, up to four rounds:

- ``radius``: a smaller acceptance radius on those waypoints (PX4's param 2, halved each
  round from NAV_ACC_RAD; ArduPilot Copter has no per-item radius, so it stops there);
- ``stop``: no pass-through: a 1 s hold (param 1) makes both firmwares stop at the waypoint;
- ``margin``: plan again with the margin grown by what the track lacked
  (:func:`uavplan.flown_safe.plan_safe_as_flown`, what ``plan`` does).

Prints, per scenario and flavour, the track's least clearance and the flight time as planned
and after each option, and whether the margin is kept. docs/flying.md quotes the table.

    python tools/safe_as_flown.py [--only paper-env1]
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from uavplan.flavour import Autopilot
from uavplan.flown_safe import MAX_REPLANS, plan_safe_as_flown
from uavplan.mission.items import MavCmd, MissionPlan
from uavplan.planning import mission_for, plan_route
from uavplan.rehearsal import CheckSite, Rehearsal, rehearse
from uavplan.scenario import Scenario, load_scenario

ROOT = Path(__file__).resolve().parent.parent


def offending_waypoints(plan: MissionPlan, rehearsal: Rehearsal, site: CheckSite) -> set[int]:
    """Indices into ``plan.items`` of the waypoints nearest to where the track came closer
    than the margin."""
    check = rehearsal.check
    assert check is not None
    inner = check.check
    bad = np.flatnonzero(inner.clearance_m < inner.margin_m - 1e-6)
    if not bad.size:
        return set()
    points = inner.flight.points_enu[bad]
    items = [i for i, it in enumerate(plan.items) if it.command == MavCmd.NAV_WAYPOINT]
    xy = site.frame.to_enu_xy([plan.items[i].x for i in items], [plan.items[i].y for i in items])
    near = set()
    for p in points:
        near.add(items[int(np.argmin(np.hypot(xy[:, 0] - p[0], xy[:, 1] - p[1])))])
    return near


def applied(plan: MissionPlan, indices: set[int], option: str) -> MissionPlan:
    items = list(plan.items)
    for i in indices:
        item = items[i]
        if option == "radius" and plan.autopilot == Autopilot.PX4:
            items[i] = replace(item, param2=max(0.5, (item.param2 or 10.0) / 2.0))
        else:
            items[i] = replace(item, param1=1.0)
    return replace(plan, items=tuple(items))


def repaired(plan: MissionPlan, site: CheckSite, option: str) -> Rehearsal:
    rehearsal = rehearse(plan, site)
    for _ in range(MAX_REPLANS):
        assert rehearsal.check is not None
        if rehearsal.check.ok:
            break
        near = offending_waypoints(plan, rehearsal, site)
        if not near:
            break
        plan = applied(plan, near, option)
        rehearsal = rehearse(plan, site)
    return rehearsal


def scenario_for(path: Path, autopilot: Autopilot, work: Path) -> Scenario:
    scenario = load_scenario(path)
    if path.stem == "jacksboro-ridge" and autopilot == Autopilot.PX4:
        # PX4 flies no terrain frames: the same route in AMSL altitudes
        shutil.copy(ROOT / "maps" / "jacksboro-fault-dem.tif", work / "dem.tif")
        text = path.read_text(encoding="utf-8").replace(
            "../maps/jacksboro-fault-dem.tif", "dem.tif"
        )
        copy = work / "jacksboro-amsl.yaml"
        copy.write_text(text.replace("altitude: terrain", "altitude: amsl"), encoding="utf-8")
        scenario = load_scenario(copy)
    return replace(scenario, mission=replace(scenario.mission, autopilot=autopilot))


def cell(rehearsal: Rehearsal) -> str:
    check = rehearsal.check
    assert check is not None
    mark = "ok" if check.ok else "NO"
    return f"{check.min_clearance_m:6.2f} {rehearsal.flight_time_s:6.1f} {mark}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", help="one scenario (file stem)")
    args = parser.parse_args()
    paths = sorted(ROOT.glob("missions/*.yaml"))
    if args.only:
        paths = [p for p in paths if p.stem == args.only]
    group = f"{'clear m':>6} {'time s':>6} ok"
    print(f"{'scenario':18} {'flavour':9} {'margin':>6} | as planned: {group} | radius: "
          f"{group} | stop: {group} | margin: {group}  pad m  +plan s")  # fmt: skip
    kept = {"radius": 0, "stop": 0, "margin": 0}
    rows = 0
    with tempfile.TemporaryDirectory() as tmp:
        for path in paths:
            for autopilot in (Autopilot.PX4, Autopilot.ARDUPILOT):
                work = Path(tmp) / f"{path.stem}-{autopilot.label}"
                work.mkdir()
                scenario = scenario_for(path, autopilot, work)
                site = CheckSite.of_scenario(scenario)
                result = plan_route(scenario)
                assert result.route is not None
                plan = mission_for(scenario, result.route)
                before = rehearse(plan, site)
                radius = repaired(plan, site, "radius")
                stop = repaired(plan, site, "stop")
                started = time.perf_counter()
                safe = plan_safe_as_flown(scenario, result)
                extra_s = time.perf_counter() - started
                assert safe.result.route is not None and safe.flight is not None
                after = rehearse(mission_for(scenario, safe.result.route), site)
                rows += 1
                for name, r in (("radius", radius), ("stop", stop), ("margin", after)):
                    kept[name] += bool(r.check is not None and r.check.ok)
                print(
                    f"{path.stem:18} {autopilot.label:9} {scenario.safety_margin_m:6g} | "
                    f"{'':12}{cell(before)} | {'':8}{cell(radius)} | {'':6}{cell(stop)} | "
                    f"{'':8}{cell(after)} "
                    f"{safe.flight.margin_pad_m:6.2f} {extra_s:7.1f}",
                    flush=True,
                )
    print(", ".join(f"{name}: {n} of {rows} keep the margin" for name, n in kept.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
