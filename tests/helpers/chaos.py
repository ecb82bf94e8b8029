"""Link chaos: upload through a :class:`faultproxy.FaultProxy` (tests/helpers/faultproxy.py) to a
simulated vehicle and check the invariants of issue 12 on every run.

One run (:func:`run_upload`): a fresh mock vehicle holding an *old* mission, a seeded fault
proxy in front of it, our ground station connecting through the proxy and uploading a new
mission with read-back verification, exactly as ``uavplan upload`` does. Checked:

- exit 0 means the vehicle holds exactly the mission sent;
- any failure is exit 4 (never 1) and its message names the step;
- the vehicle never holds a mixture: it holds the old mission or the new one, whole;
- every run ends within the stated bound (:func:`time_bound_s`).

Used by ``tests/mavlink/test_mavlink_chaos.py`` (a few runs) and ``tools/link_chaos.py`` (the full
table). Nothing in the product imports it, so it lives with the tests (``tools/link_chaos.py``
puts ``tests/`` on ``sys.path``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

from helpers.faultproxy import FaultProxy, ProxyFaults
from uavplan.errors import UavplanError
from uavplan.mavlink.link import HEARTBEAT_TIMEOUT_S, VehicleLink
from uavplan.mavlink.protocol import MissionClient, ProtocolTimeouts
from uavplan.mavlink.transfer import compare_items, plan_wire_items, upload_plan
from uavplan.mission.items import (
    Autopilot,
    MavCmd,
    MavFrame,
    MissionItem,
    MissionPlan,
    MissionType,
)
from uavplan.sim.mock import MockVehicle
from uavplan.sim.vehicle import SimConfig


def chaos_mission(n_items: int, *, seed: int, autopilot: Autopilot = Autopilot.PX4) -> MissionPlan:
    """``n_items`` items: a takeoff, waypoints on a seeded random walk with cm-odd
    altitudes, RTL (no numpy: a tool can build it anywhere)."""
    import random

    rng = random.Random(seed)
    lat, lon = 47.397742, 8.545594
    items = [
        MissionItem(
            MavCmd.NAV_TAKEOFF,
            MavFrame.GLOBAL_RELATIVE_ALT,
            param1=0.0,
            x=lat,
            y=lon,
            z=30.0,
        )
    ]
    for _ in range(max(0, n_items - 2)):
        lat += rng.gauss(3e-4, 4e-4)
        lon += rng.gauss(1e-4, 4e-4)
        items.append(
            MissionItem(
                MavCmd.NAV_WAYPOINT,
                MavFrame.GLOBAL_RELATIVE_ALT,
                param1=0.0,
                param2=2.0,
                param3=0.0,
                x=lat,
                y=lon,
                z=round(30.0 + abs(rng.gauss(0.0, 20.0)), 2) + 0.003,
            )
        )
    items.append(MissionItem(MavCmd.NAV_RETURN_TO_LAUNCH, MavFrame.MISSION))
    return MissionPlan(items=tuple(items[:n_items]), autopilot=autopilot)


@dataclass(frozen=True)
class RunResult:
    exit_code: int
    message: str  # "" on success
    elapsed_s: float  # connect + upload + verify
    holds: str  # "new", "old" or "mixture"

    @property
    def ok(self) -> bool:
        return self.exit_code == 0


def time_bound_s(timeouts: ProtocolTimeouts, n_items: int) -> float:
    """The stated bound of one run that fails: connecting (``HEARTBEAT_TIMEOUT_S`` plus the
    AUTOPILOT_VERSION wait), then one transfer step's whole retry budget
    ``(1 + retries) x ack_s`` plus the final ACK's wait and the STATUSTEXT grace. A run
    that makes progress is bounded by the vehicle's per-item budget on top; this is the
    bound for a dead link, the one a user waits out."""
    del n_items
    return HEARTBEAT_TIMEOUT_S + 1.0 + (timeouts.retries + 2) * timeouts.ack_s + 0.5


def run_upload(
    faults: ProxyFaults,
    *,
    autopilot: Autopilot = Autopilot.PX4,
    n_items: int = 200,
    timeouts: ProtocolTimeouts | None = None,
    heartbeat_timeout_s: float = HEARTBEAT_TIMEOUT_S,
) -> RunResult:
    """One upload of an ``n_items`` mission through ``faults``; see the module docstring."""
    timeouts = timeouts or ProtocolTimeouts()
    old = chaos_mission(max(2, n_items // 2), seed=faults.seed + 1_000_000, autopilot=autopilot)
    new = chaos_mission(n_items, seed=faults.seed, autopilot=autopilot)
    vehicle = MockVehicle("udpin:127.0.0.1:0", SimConfig(autopilot=autopilot))
    vehicle.preload(MissionType.MISSION, plan_wire_items(old, MissionType.MISSION, autopilot))
    vehicle.start()
    started = time.monotonic()
    exit_code, message = 0, ""
    try:
        with FaultProxy(vehicle.address, faults) as proxy:
            try:
                with VehicleLink.connect(
                    proxy.conn, heartbeat_timeout_s=heartbeat_timeout_s
                ) as link:
                    upload_plan(MissionClient(link, timeouts), new)
            except UavplanError as err:
                exit_code, message = err.exit_code, str(err)
            except Exception as err:  # an internal error: what the invariants rule out
                exit_code, message = 1, f"internal error: {type(err).__name__}: {err}"
            elapsed = time.monotonic() - started
            if proxy.error is not None:
                raise RuntimeError(f"fault proxy failed: {proxy.error!r}")
        if vehicle.error is not None:
            raise RuntimeError(f"mock vehicle failed: {vehicle.error!r}")
        held = vehicle.items(MissionType.MISSION)
    finally:
        vehicle.stop()
    holds = "mixture"
    for name, plan in (("new", new), ("old", old)):
        wire = plan_wire_items(plan, MissionType.MISSION, autopilot)
        if compare_items(wire, held, MissionType.MISSION, autopilot) is None:
            holds = name
            break
    return RunResult(exit_code, message, elapsed, holds)


def invariant_problem(result: RunResult, bound_s: float | None = None) -> str | None:
    """Which invariant ``result`` breaks, or ``None``."""
    if result.ok and result.holds != "new":
        return f"exit 0 but the vehicle holds the {result.holds} mission"
    if not result.ok and result.exit_code != 4:
        return f"exit {result.exit_code}: {result.message}"
    if not result.ok and ":" not in result.message:
        return f"the failure names no step: {result.message}"
    if result.holds == "mixture":
        return "the vehicle holds a mixture"
    if bound_s is not None and not result.ok and result.elapsed_s > bound_s:
        return f"took {result.elapsed_s:.1f} s, over the bound of {bound_s:.1f} s"
    if not math.isfinite(result.elapsed_s):
        return "no elapsed time"
    return None
