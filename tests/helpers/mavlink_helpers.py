"""Shared pieces of the MAVLink tests: realistic plans, a running mock vehicle, fast timeouts.

Everything runs over real sockets on 127.0.0.1 with OS-assigned ports. The mock runs in a
background thread (``running_mock``) and is always stopped and its socket closed, even
when a test fails.
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Callable, Iterator
from dataclasses import replace
from pathlib import Path

import numpy as np

from uavplan.mavlink.link import VehicleLink
from uavplan.mavlink.protocol import MissionClient, ProtocolTimeouts
from uavplan.mission.items import (
    Autopilot,
    FenceCircle,
    FencePolygon,
    GeoFence,
    GeoPoint,
    MavCmd,
    MavFrame,
    MissionItem,
    MissionPlan,
    RallyPoint,
)
from uavplan.sim.mock import MockVehicle
from uavplan.sim.vehicle import SimConfig

#: timeouts for tests whose point is not the timing: short enough to fail fast
FAST = ProtocolTimeouts.scaled(0.3, retries=3)
#: timeouts for lossy-link tests: the defaults, which the protocol is specified with
DEFAULT = ProtocolTimeouts()

HOME = GeoPoint(47.397742, 8.545594, 488.0)


def synthetic_mission(
    n_waypoints: int,
    *,
    seed: int,
    autopilot: Autopilot = Autopilot.PX4,
    speed_m_s: float | None = 12.0,
    end: str = "rtl",
    with_fence: bool = False,
    with_rally: bool = False,
) -> MissionPlan:
    """A plan shaped like the planner's output: takeoff, DO_CHANGE_SPEED, a winding 3-D
    path of ``n_waypoints`` NAV_WAYPOINTs (full-precision lat/lon, cm-odd altitudes), RTL."""
    rng = np.random.default_rng(seed)
    steps = rng.normal(0.0, 1.0, size=(n_waypoints, 2)) * 4e-4 + np.array([3e-4, 1e-4])
    latlon = np.array([HOME.lat_deg, HOME.lon_deg]) + np.cumsum(steps, axis=0)
    altitudes = 30.0 + np.abs(np.cumsum(rng.normal(0.0, 3.0, size=n_waypoints))) + 0.123
    items = [
        MissionItem(
            MavCmd.NAV_TAKEOFF,
            MavFrame.GLOBAL_RELATIVE_ALT,
            param1=0.0,
            param2=0.0,
            param3=0.0,
            param4=None,
            x=HOME.lat_deg,
            y=HOME.lon_deg,
            z=30.0,
        )
    ]
    if speed_m_s is not None:
        items.append(
            MissionItem(
                MavCmd.DO_CHANGE_SPEED, MavFrame.MISSION, param1=1.0, param2=speed_m_s, param3=-1.0
            )
        )
    for (lat, lon), alt in zip(latlon, altitudes, strict=True):
        items.append(
            MissionItem(
                MavCmd.NAV_WAYPOINT,
                MavFrame.GLOBAL_RELATIVE_ALT,
                param1=0.0,
                param2=2.0,
                param3=0.0,
                param4=None,
                x=float(lat),
                y=float(lon),
                z=float(alt),
            )
        )
    if end == "rtl":
        items.append(MissionItem(MavCmd.NAV_RETURN_TO_LAUNCH, MavFrame.MISSION))
    elif end == "land":
        lat, lon = latlon[-1]
        items.append(MissionItem(MavCmd.NAV_LAND, x=float(lat), y=float(lon), z=0.0))
    fence = GeoFence()
    if with_fence:
        lat0, lon0 = HOME.lat_deg, HOME.lon_deg
        fence = GeoFence(
            polygons=(
                FencePolygon(
                    (
                        (lat0 - 0.02, lon0 - 0.02),
                        (lat0 + 0.05, lon0 - 0.02),
                        (lat0 + 0.05, lon0 + 0.04),
                        (lat0 - 0.02, lon0 + 0.04),
                    ),
                    inclusion=True,
                ),
                FencePolygon(
                    (
                        (lat0 + 0.01, lon0 + 0.01),
                        (lat0 + 0.012, lon0 + 0.01),
                        (lat0 + 0.011, lon0 + 0.013),
                    ),
                    inclusion=False,
                ),
            ),
            circles=(FenceCircle((lat0 + 0.02, lon0 + 0.005), 45.5, inclusion=False),),
            breach_return=GeoPoint(lat0 + 0.001, lon0 + 0.001, 35.0),
        )
    rally: tuple[RallyPoint, ...] = ()
    if with_rally:
        rally = (
            RallyPoint(HOME.lat_deg + 0.003, HOME.lon_deg - 0.002, 40.0),
            RallyPoint(HOME.lat_deg + 0.011, HOME.lon_deg + 0.004, 55.5),
        )
    return MissionPlan(
        items=tuple(items),
        autopilot=autopilot,
        home=HOME,
        fence=fence,
        rally=rally,
        cruise_speed_m_s=speed_m_s,
    )


PlanSource = Callable[[], MissionPlan]


def bundled_plans() -> Iterator[tuple[str, PlanSource]]:
    """Every mission the round-trip tests cover, as (name, plan source): realistic synthetic
    ones, then the planner's output for each bundled scenario under ``missions/``.

    Scenarios are planned lazily (once per session, few iterations: the point is the shape
    of real planner output, not its quality), so listing them costs nothing.
    """
    for name, plan in (
        ("short-40", synthetic_mission(40, seed=1)),
        ("medium-120-land", synthetic_mission(120, seed=2, end="land")),
        ("long-200", synthetic_mission(200, seed=3)),
        ("no-speed-57", synthetic_mission(57, seed=4, speed_m_s=None, end="none")),
        ("with-fence-rally-60", synthetic_mission(60, seed=5, with_fence=True, with_rally=True)),
    ):
        yield name, (lambda plan=plan: plan)
    for path in sorted((Path(__file__).resolve().parents[2] / "missions").glob("*.yaml")):
        yield f"scenario-{path.stem}", functools.partial(planned_scenario, str(path))


@functools.cache
def planned_scenario(path: str) -> MissionPlan:
    """``uavplan plan SCENARIO`` in-process, with a short search (2 iterations, 4 birds)."""
    import pytest

    try:
        from uavplan.geo import EnuFrame
        from uavplan.mission.builder import build_mission
        from uavplan.planning import plan_route
        from uavplan.scenario import load_scenario
    except ImportError as err:  # pragma: no cover - the planner is another issue's work
        pytest.skip(f"planner not available: {err}")
    scenario = load_scenario(path)
    search = replace(scenario.planner.search, iterations=2, population=4, seed=1)
    scenario = scenario.with_planner(search=search)
    route = plan_route(scenario)
    if not route.ok:
        pytest.skip(f"{Path(path).name}: no path with a 2-iteration search")
    return build_mission(
        route.waypoints_enu,
        EnuFrame.at(scenario.origin),
        autopilot=scenario.mission.autopilot,
        end=scenario.mission.end,
        takeoff_altitude_m=scenario.vehicle.takeoff_altitude_m,
        cruise_speed_m_s=scenario.vehicle.cruise_speed_m_s,
    )


def for_autopilot(plan: MissionPlan, autopilot: Autopilot) -> MissionPlan:
    return replace(plan, autopilot=autopilot)


@contextlib.contextmanager
def running_mock(
    config: SimConfig | None = None, *, conn: str = "udpin:127.0.0.1:0"
) -> Iterator[MockVehicle]:
    """A mock vehicle serving in a background thread; stopped and closed on exit."""
    vehicle = MockVehicle(conn, config)
    vehicle.start()
    try:
        yield vehicle
    finally:
        vehicle.stop()
        assert vehicle.error is None, f"the mock vehicle crashed: {vehicle.error!r}"


def client_conn(vehicle: MockVehicle) -> str:
    host, port = vehicle.address
    return f"udpout:{host}:{port}"


@contextlib.contextmanager
def connected_client(
    vehicle: MockVehicle,
    timeouts: ProtocolTimeouts = FAST,
    *,
    heartbeat_timeout_s: float = 5.0,
) -> Iterator[MissionClient]:
    """Our ground station connected to ``vehicle``; closed on exit."""
    link = VehicleLink.connect(client_conn(vehicle), heartbeat_timeout_s=heartbeat_timeout_s)
    try:
        yield MissionClient(link, timeouts)
    finally:
        link.close()
