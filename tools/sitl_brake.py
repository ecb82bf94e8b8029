"""Where a return to launch from mid-route turns home, on the real firmware (issue 32).

The way-home proof checks a straight return from each point of the route; the firmware
first stops (ArduPilot: the S-curve from where it is to its stopping point, climbing;
PX4: the navigator's RTL climb, the position setpoint smoothed to a stop) and turns only
then. This flies, for each speed, a straight 800 m leg east at 30 m on SITL (tests/helpers/sitl.py),
switches to RTL (``uavplan fly --on-interrupt rtl``, Ctrl-C) once the vehicle has held the
speed for 200 m, and prints how far past that point the vehicle went along the leg before
turning home, how long that took, and its altitude there; next to ``v²/(2a)`` with the
flavour's acceleration (WPNAV_ACCEL 2.5 m/s², MPC_ACC_HOR 3 m/s²).

    python tools/sitl_brake.py [--autopilot ardupilot|px4] [--speeds 4,8,12] [--rtl-alt 50]

Needs the firmware (UAVPLAN_SITL_DIR, default ../shared/sitl).
"""

from __future__ import annotations

import argparse
import math
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from helpers import sitl  # noqa: E402  (the SITL helpers live with the tests)

from uavplan.geo import EnuFrame, GeoPoint  # noqa: E402
from uavplan.mission.io import save_mission  # noqa: E402
from uavplan.mission.items import Autopilot, MissionItem, MissionPlan  # noqa: E402

HOME = GeoPoint(47.397742, 8.545594, 488.0)
LEG_M = 800.0
STEADY_M = 200.0
ALT_M = 30.0
ACCEL = {Autopilot.ARDUPILOT: 2.5, Autopilot.PX4: 3.0}


def _plan(autopilot: Autopilot, speed: float) -> MissionPlan:
    frame = EnuFrame.at(HOME)
    lat, lon, _ = frame.to_geodetic([[LEG_M, 0.0, 0.0]])
    items = (
        MissionItem(22, 3, 0.0, 0.0, 0.0, None, HOME.lat_deg, HOME.lon_deg, ALT_M),
        MissionItem(178, 2, 1.0, speed, -1.0, 0.0),
        MissionItem(16, 3, 0.0, 0.0, 0.0, None, float(lat[0]), float(lon[0]), ALT_M),
        MissionItem(21, 3, 0.0, 0.0, 0.0, None, float(lat[0]), float(lon[0]), 0.0),
    )
    return MissionPlan(items=items, autopilot=autopilot, home=HOME)


def measure(autopilot: Autopilot, speed: float, rtl_alt: float | None) -> str:
    work = Path(tempfile.mkdtemp(prefix="sitl-brake-"))
    path = work / "leg.plan"
    save_mission(_plan(autopilot, speed), path)
    params: dict[str, float] = {}
    if rtl_alt is not None:
        params = (
            {"RTL_ALT": rtl_alt * 100.0}
            if autopilot == Autopilot.ARDUPILOT
            else {"RTL_RETURN_ALT": rtl_alt}
        )
    if autopilot == Autopilot.PX4:
        params["SIH_KDV"] = 0.5
    frame = EnuFrame.at(HOME)
    with sitl.running(autopilot, HOME, speedup=8.0, params=params) as vehicle:
        observer = vehicle.observer
        assert observer is not None
        cmd = [sys.executable, "-m", "uavplan", "fly", str(path), "--conn", vehicle.conn,
               "--upload", "--quiet", "--on-interrupt", "rtl"]  # fmt: skip
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)

        def east(s: sitl.Sample) -> float:
            return float(frame.to_enu_xy([s.lat_deg], [s.lon_deg])[0][0])

        def steady(seen: sitl.Observation) -> bool:
            return bool(seen.samples) and east(seen.samples[-1]) > STEADY_M + speed * speed / 2

        observer.wait("steady speed", steady, 600.0)
        trigger = observer.snapshot().samples[-1]
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=120)

        def turned(seen: sitl.Observation) -> bool:
            last = seen.samples[-1]
            return last.vx_m_s < -0.5 or seen.boot_s > trigger.time_s + 120  # heading home

        observer.wait("the turn home", turned, 600.0)
        seen = observer.snapshot()
    after = [s for s in seen.samples if s.time_s >= trigger.time_s]
    xs = [east(s) for s in after]
    far = max(range(len(xs)), key=lambda i: xs[i])
    v0 = math.hypot(trigger.vx_m_s, trigger.vy_m_s)
    return (
        f"| {autopilot.label} | {speed:g} | {v0:.1f} | {xs[far] - xs[0]:.1f} | "
        f"{after[far].time_s - trigger.time_s:.1f} | {after[far].relative_alt_m:.1f} | "
        f"{v0 * v0 / (2 * ACCEL[autopilot]):.1f} |"
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--autopilot", choices=["ardupilot", "px4"], action="append")
    parser.add_argument("--speeds", default="4,8,12")
    parser.add_argument("--rtl-alt", type=float, default=None, help="return altitude, m")
    args = parser.parse_args()
    flavours = [Autopilot.from_name(a) for a in (args.autopilot or ["ardupilot", "px4"])]
    print(
        "| flavour | speed asked m/s | speed at the switch m/s | went on m | in s "
        "| altitude there m | v²/(2a) m |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|")
    for flavour in flavours:
        why = sitl.missing(flavour)
        if why is not None:
            print(why, file=sys.stderr)
            return 2
        for speed in (float(s) for s in args.speeds.split(",")):
            print(measure(flavour, speed, args.rtl_alt), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
