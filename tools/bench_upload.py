#!/usr/bin/env python3
"""Upload-time benchmark: uavplan's mission client vs MAVSDK's mission_raw, same mock vehicle.

For each packet-loss rate a mock vehicle is started as its own process
(``uavplan mock-vehicle --loss P --seed S``, loss applied to every packet, each way). Then
our client uploads the mission ``--runs`` times over one connection, followed by MAVSDK's
``MissionRaw.upload_mission`` uploading the same items ``--runs`` times to the same vehicle.
Times are the transfer alone (MISSION_COUNT until the final MISSION_ACK), medians over the
runs; connecting is not timed for either. For our client the time including the read-back
verification (``upload_plan`` with verify) is reported too.

After a failed transfer the vehicle may still be inside it (PX4 drops a silent upload only
after 5 s), so the next run waits that out: no client is blamed for the other's mess.

Usage::

    python tools/bench_upload.py                       # 200 items; 0, 10, 30 % loss; 7 runs
    python tools/bench_upload.py --runs 11 --json out.json
    python tools/bench_upload.py --extra 100@0.05      # also MAVSDK's weak spot
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import signal
import statistics
import subprocess
import sys
import time
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

from uavplan.mavlink.link import VehicleLink
from uavplan.mavlink.protocol import MissionClient, ProtocolTimeouts, TransferStatus, item_to_wire
from uavplan.mavlink.transfer import upload_plan
from uavplan.mission.items import (
    Autopilot,
    GeoPoint,
    MavCmd,
    MavFrame,
    MissionItem,
    MissionPlan,
    MissionType,
)

#: PX4's protocol timeout: a vehicle left inside a failed upload is idle again after this
VEHICLE_IDLE_AFTER_FAILURE_S = 5.5
HOME = GeoPoint(47.397742, 8.545594, 488.0)


def mission(n_items: int, seed: int = 1) -> MissionPlan:
    """``n_items`` items: takeoff, DO_CHANGE_SPEED, a winding 3-D path, RTL."""
    import numpy as np

    rng = np.random.default_rng(seed)
    n_wp = max(1, n_items - 3)
    latlon = np.array([HOME.lat_deg, HOME.lon_deg]) + np.cumsum(
        rng.normal(0.0, 4e-4, size=(n_wp, 2)) + np.array([3e-4, 1e-4]), axis=0
    )
    alt = 30.0 + np.abs(np.cumsum(rng.normal(0.0, 3.0, size=n_wp)))
    items = [
        MissionItem(MavCmd.NAV_TAKEOFF, x=HOME.lat_deg, y=HOME.lon_deg, z=30.0),
        MissionItem(MavCmd.DO_CHANGE_SPEED, MavFrame.MISSION, param1=1.0, param2=12.0, param3=-1),
        *(
            MissionItem(MavCmd.NAV_WAYPOINT, x=float(la), y=float(lo), z=float(z))
            for (la, lo), z in zip(latlon, alt, strict=True)
        ),
        MissionItem(MavCmd.NAV_RETURN_TO_LAUNCH, MavFrame.MISSION),
    ]
    return MissionPlan(items=tuple(items[:n_items]), autopilot=Autopilot.PX4, home=HOME)


@contextmanager
def mock_process(loss: float, seed: int, autopilot: str, firmware_timing: bool) -> Iterator[str]:
    """``uavplan mock-vehicle`` in its own process; yields the client connection string."""
    cmd = [
        sys.executable,
        "-c",
        "from uavplan.cli import main; main()",
        "mock-vehicle",
        "--conn",
        "udpin:127.0.0.1:0",
        "--autopilot",
        autopilot,
        "--loss",
        str(loss),
        "--seed",
        str(seed),
    ]
    if firmware_timing:
        cmd.append("--firmware-timing")
    proc = subprocess.Popen(
        cmd,
        stderr=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    try:
        assert proc.stderr is not None
        line = proc.stderr.readline()
        match = re.search(r"serving on udpin:127\.0\.0\.1:(\d+)", line)
        if not match:
            raise RuntimeError(f"mock vehicle did not start: {line!r}")
        yield f"udpout:127.0.0.1:{match.group(1)}"
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.communicate(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()


@dataclass
class Series:
    times_s: list[float] = field(default_factory=list)  # successful runs
    failures: Counter[str] = field(default_factory=Counter)

    @property
    def runs(self) -> int:
        return len(self.times_s) + sum(self.failures.values())

    def median(self) -> float:
        return statistics.median(self.times_s) if self.times_s else math.nan

    def summary(self) -> dict[str, object]:
        return {
            "median_s": None if not self.times_s else self.median(),
            "min_s": min(self.times_s, default=None),
            "max_s": max(self.times_s, default=None),
            "successes": len(self.times_s),
            "runs": self.runs,
            "failures": dict(self.failures),
            "times_s": self.times_s,
        }


def bench_ours(conn: str, plan: MissionPlan, runs: int) -> tuple[Series, Series]:
    upload, verified = Series(), Series()
    items = plan.wire_items(MissionType.MISSION)
    with VehicleLink.connect(conn, heartbeat_timeout_s=10.0) as link:
        client = MissionClient(link, ProtocolTimeouts())
        for _ in range(runs):
            started = time.perf_counter()
            outcome = client.upload(MissionType.MISSION, items)
            elapsed = time.perf_counter() - started
            if outcome.ok:
                upload.times_s.append(elapsed)
            elif outcome.status is TransferStatus.NO_FINAL_ACK:
                # resolved by a read-back, as upload_plan does: count the time it takes
                check = client.download(MissionType.MISSION)
                if check.ok and len(check.items) == len(items):
                    upload.times_s.append(time.perf_counter() - started)
                else:
                    upload.failures[f"{outcome.where}: {outcome.status.value}"] += 1
            else:
                upload.failures[f"{outcome.where}: {outcome.status.value}"] += 1
                time.sleep(VEHICLE_IDLE_AFTER_FAILURE_S)
        for _ in range(runs):
            started = time.perf_counter()
            try:
                upload_plan(client, plan, verify=True)
            except Exception as err:  # a failed run is data here, not an error
                verified.failures[f"{type(err).__name__}: {err}"] += 1
                time.sleep(VEHICLE_IDLE_AFTER_FAILURE_S)
                continue
            verified.times_s.append(time.perf_counter() - started)
    return upload, verified


def bench_mavsdk(conn: str, plan: MissionPlan, runs: int) -> Series:
    from mavsdk import ComponentType, Configuration, Mavsdk, log_subscribe
    from mavsdk.plugins.mission_raw import MissionItem as RawItem
    from mavsdk.plugins.mission_raw import MissionRaw, MissionRawError

    log_subscribe(lambda level, *_: level < 2)  # keep MAVSDK's warnings, drop its chatter
    series = Series()
    raw_items = []
    for seq, item in enumerate(plan.wire_items(MissionType.MISSION)):
        w = item_to_wire(item, seq, MissionType.MISSION, 1, 1)
        raw_items.append(
            RawItem(
                seq=seq,
                frame=w.frame,
                command=w.command,
                current=w.current,
                autocontinue=w.autocontinue,
                param1=w.param1,
                param2=w.param2,
                param3=w.param3,
                param4=w.param4,
                x=w.x,
                y=w.y,
                z=w.z,
                mission_type=0,
            )
        )
    sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    try:
        sdk.add_any_connection(conn.replace("udpout:", "udpout://", 1))
        system = sdk.first_autopilot(10.0)
        if system is None:
            series.failures["no system"] = runs
            return series
        mission_raw = MissionRaw(system)
        for _ in range(runs):
            started = time.perf_counter()
            try:
                mission_raw.upload_mission(raw_items)
            except MissionRawError as err:
                series.failures[err.result.name] += 1
                time.sleep(VEHICLE_IDLE_AFTER_FAILURE_S)
                continue
            series.times_s.append(time.perf_counter() - started)
    finally:
        sdk.destroy()
    return series


def fmt(series: Series) -> str:
    ok = f"{len(series.times_s)}/{series.runs}"
    if not series.times_s:
        return f"{'—':>7}  {ok:>5}"
    return f"{series.median():7.3f}  {ok:>5}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--items", type=int, default=200)
    parser.add_argument("--losses", default="0,0.1,0.3", help="comma-separated loss rates")
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--autopilot", choices=["px4", "ardupilot"], default="px4")
    parser.add_argument("--firmware-timing", action="store_true")
    parser.add_argument(
        "--extra", action="append", default=[], metavar="N@P",
        help="an extra row: N items at loss P (for example 100@0.05)",
    )  # fmt: skip
    parser.add_argument("--no-mavsdk", action="store_true")
    parser.add_argument("--json", metavar="FILE", help="also write all times as JSON")
    args = parser.parse_args(argv)

    rows = [(args.items, float(p)) for p in args.losses.split(",")]
    for extra in args.extra:
        n, p = extra.split("@")
        rows.append((int(n), float(p)))

    print(
        f"upload benchmark: {args.runs} runs per cell, median seconds, loss each way, "
        f"mock {args.autopilot}{' (firmware timing)' if args.firmware_timing else ''}, "
        f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs"
    )
    header = (
        f"{'items':>5} {'loss':>5} | {'uavplan':>7} {'ok':>5} | {'+verify':>7} {'ok':>5} | "
        f"{'MAVSDK':>7} {'ok':>5} | MAVSDK failures"
    )
    print(header)
    print("-" * len(header))
    results = []
    for n_items, loss in rows:
        plan = mission(n_items, seed=args.seed)
        with mock_process(loss, args.seed, args.autopilot, args.firmware_timing) as conn:
            ours, verified = bench_ours(conn, plan, args.runs)
            theirs = Series() if args.no_mavsdk else bench_mavsdk(conn, plan, args.runs)
        failures = ", ".join(f"{k} x{v}" for k, v in theirs.failures.items()) or "-"
        cells = f"{fmt(ours)} | {fmt(verified)} | {fmt(theirs)}"
        print(f"{n_items:5d} {loss:5.0%} | {cells} | {failures}", flush=True)
        if ours.failures or verified.failures:
            print(f"      uavplan failures: {dict(ours.failures)} {dict(verified.failures)}")
        results.append(
            {
                "items": n_items,
                "loss": loss,
                "uavplan": ours.summary(),
                "uavplan_with_verify": verified.summary(),
                "mavsdk": theirs.summary(),
            }
        )
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump({"args": vars(args), "results": results}, fh, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
