"""build_mission (SPEC §4) and mission_polyline_enu."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from uavplan.geo import EnuFrame
from uavplan.mission.builder import build_mission, mission_polyline_enu
from uavplan.mission.items import (
    Autopilot,
    GeoPoint,
    MavCmd,
    MavFrame,
    MissionItem,
    MissionPlan,
    MissionType,
)
from uavplan.route import flown_polyline

ORIGIN = GeoPoint(47.397742, 8.545594, 488.0)
FRAME = EnuFrame.at(ORIGIN)
PATH = np.array(
    [[0.0, 0.0, 30.0], [400.0, -80.0, 60.0], [1200.0, 40.0, 90.0], [2000.0, 150.0, 40.0]]
)


def commands(plan: MissionPlan) -> list[int]:
    return [item.command for item in plan.items]


def test_default_mission_takeoff_waypoints_rtl() -> None:
    plan = build_mission(PATH, FRAME, autopilot=Autopilot.PX4)
    assert commands(plan) == [22, 16, 16, 16, 20]
    takeoff, *waypoints, rtl = plan.items
    assert takeoff.frame == MavFrame.GLOBAL_RELATIVE_ALT
    assert (takeoff.lat_deg, takeoff.lon_deg) == pytest.approx((ORIGIN.lat_deg, ORIGIN.lon_deg))
    assert takeoff.alt_m == 30.0
    assert takeoff.param4 is None  # yaw unset: NaN on the wire
    for item, row in zip(waypoints, PATH[1:], strict=True):
        assert item.frame == MavFrame.GLOBAL_RELATIVE_ALT
        assert item.alt_m == row[2]  # altitude above home = ENU z
        assert item.params == (0.0, 0.0, 0.0, None)
        assert item.autocontinue
    assert rtl.frame == MavFrame.MISSION
    assert rtl.params == (0.0, 0.0, 0.0, 0.0)  # ArduPilot refuses NaN here
    assert plan.autopilot == Autopilot.PX4
    assert plan.vehicle_type == 2
    assert plan.fence.is_empty and plan.rally == ()


def test_waypoint_positions_are_the_geodetic_ground_points() -> None:
    plan = build_mission(PATH, FRAME, autopilot=Autopilot.PX4, end="none")
    lat, lon, _ = FRAME.to_geodetic(PATH * [1.0, 1.0, 0.0])
    for item, la, lo in zip(plan.items[1:], lat[1:], lon[1:], strict=True):
        assert (item.lat_deg, item.lon_deg) == (la, lo)
    # hand check, 2000 m east and 150 m north of Zurich on the tangent plane 488 m above
    # the ellipsoid: north is y / (M + h), the straight east axis drifts toward the equator
    # by x² tan φ / 2(N + h), and the east step is an angle around the polar axis
    goal = plan.items[-1]
    x, y, h = 2000.0, 150.0, ORIGIN.alt_m
    phi = math.radians(ORIGIN.lat_deg)
    a, e2 = 6378137.0, 0.00669437999014
    n = a / math.sqrt(1 - e2 * math.sin(phi) ** 2) + h
    m = a * (1 - e2) / (1 - e2 * math.sin(phi) ** 2) ** 1.5 + h
    north_m = y - x**2 * math.tan(phi) / (2 * n)
    assert goal.lat_deg == pytest.approx(ORIGIN.lat_deg + math.degrees(north_m / m), abs=2e-8)
    axis_distance_m = n * math.cos(phi) - y * math.sin(phi)
    assert goal.lon_deg == pytest.approx(
        ORIGIN.lon_deg + math.degrees(math.atan(x / axis_distance_m)), abs=2e-8
    )


def test_home_is_the_ground_below_the_start_with_amsl_altitude() -> None:
    plan = build_mission(PATH, FRAME, autopilot=Autopilot.ARDUPILOT)
    assert plan.home is not None
    assert plan.home.lat_deg == pytest.approx(ORIGIN.lat_deg, abs=1e-12)
    assert plan.home.lon_deg == pytest.approx(ORIGIN.lon_deg, abs=1e-12)
    assert plan.home.alt_m == pytest.approx(ORIGIN.alt_m, abs=1e-6)
    shifted = PATH + np.array([500.0, -300.0, 0.0])
    away = build_mission(shifted, FRAME, autopilot=Autopilot.ARDUPILOT)
    lat, lon, alt = FRAME.to_geodetic([[500.0, -300.0, 0.0]])
    assert away.home == GeoPoint(float(lat[0]), float(lon[0]), float(alt[0]))
    # flat ENU ground rises above the ellipsoid by about d² / 2R (2 cm at 583 m)
    assert away.home is not None
    assert away.home.alt_m - ORIGIN.alt_m == pytest.approx(583.1**2 / (2 * 6.37e6), abs=0.005)


def test_ardupilot_home_slot_comes_from_wire_items_not_the_builder() -> None:
    px4 = build_mission(PATH, FRAME, autopilot=Autopilot.PX4)
    ardu = build_mission(PATH, FRAME, autopilot=Autopilot.ARDUPILOT)
    assert px4.items == ardu.items
    wire = ardu.wire_items(MissionType.MISSION)
    assert len(wire) == len(ardu.items) + 1
    assert wire[0].command == MavCmd.NAV_WAYPOINT and wire[0].frame == MavFrame.GLOBAL
    assert ardu.home is not None and wire[0].alt_m == ardu.home.alt_m
    assert wire[1].command == MavCmd.NAV_TAKEOFF
    assert px4.wire_items(MissionType.MISSION)[0].command == MavCmd.NAV_TAKEOFF


def test_takeoff_altitude_and_cruise_speed() -> None:
    plan = build_mission(
        PATH, FRAME, autopilot=Autopilot.PX4, takeoff_altitude_m=15.0, cruise_speed_m_s=12.0
    )
    assert commands(plan) == [22, 178, 16, 16, 16, 16, 20]
    takeoff, speed, to_start = plan.items[:3]
    assert takeoff.alt_m == 15.0
    assert speed.frame == MavFrame.MISSION
    assert speed.params == (1.0, 12.0, -1.0, 0.0)  # ground speed, 12 m/s, throttle unchanged
    assert (speed.x, speed.y, speed.z) == (0.0, 0.0, 0.0)
    assert to_start.command == MavCmd.NAV_WAYPOINT
    assert (to_start.lat_deg, to_start.lon_deg, to_start.alt_m) == (
        takeoff.lat_deg,
        takeoff.lon_deg,
        30.0,
    )
    assert plan.cruise_speed_m_s == 12.0 and plan.hover_speed_m_s == 12.0


def test_takeoff_altitude_equal_to_start_height_adds_no_waypoint() -> None:
    plan = build_mission(PATH, FRAME, autopilot=Autopilot.PX4, takeoff_altitude_m=30.0)
    assert commands(plan) == [22, 16, 16, 16, 20]


def test_land_at_the_goal() -> None:
    plan = build_mission(PATH, FRAME, autopilot=Autopilot.ARDUPILOT, end="land")
    assert commands(plan) == [22, 16, 16, 16, 21]
    goal, land = plan.items[-2:]
    assert (land.lat_deg, land.lon_deg) == (goal.lat_deg, goal.lon_deg)
    assert land.alt_m == 0.0 and land.frame == MavFrame.GLOBAL_RELATIVE_ALT
    assert land.param4 is None


def test_no_end_action() -> None:
    plan = build_mission(PATH, FRAME, autopilot=Autopilot.PX4, end="none")
    assert commands(plan) == [22, 16, 16, 16]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"waypoints_enu": PATH[:1]}, "shape"),
        ({"waypoints_enu": PATH[:, :2]}, "shape"),
        ({"waypoints_enu": PATH * [1, 1, np.nan]}, "finite"),
        ({"waypoints_enu": PATH * [1, 1, 0]}, "above the ground"),
        ({"end": "loiter"}, "end must be"),
        ({"takeoff_altitude_m": 0.0}, "takeoff altitude"),
        ({"cruise_speed_m_s": -3.0}, "cruise speed"),
        ({"cruise_speed_m_s": math.inf}, "cruise speed"),
    ],
)
def test_bad_input_is_rejected(kwargs: dict, match: str) -> None:
    args = {"waypoints_enu": PATH, "frame": FRAME, "autopilot": Autopilot.PX4, **kwargs}
    with pytest.raises(ValueError, match=match):
        build_mission(**args)


# --- the flown polyline -------------------------------------------------------------------------


def test_polyline_home_takeoff_waypoints_and_landing() -> None:
    plan = build_mission(PATH, FRAME, autopilot=Autopilot.PX4, end="land", takeoff_altitude_m=10.0)
    expected = [
        [0.0, 0.0, 0.0],  # home, on the ground
        [0.0, 0.0, 10.0],  # takeoff column
        *PATH.tolist(),  # back to the start height, then the path
        [2000.0, 150.0, 0.0],  # landing descent at the goal
    ]
    np.testing.assert_allclose(mission_polyline_enu(plan, FRAME), expected, atol=1e-6)


def test_polyline_ends_at_rtl_and_skips_non_positional_items() -> None:
    plan = build_mission(PATH, FRAME, autopilot=Autopilot.ARDUPILOT, cruise_speed_m_s=8.0)
    line = mission_polyline_enu(plan, FRAME)
    np.testing.assert_allclose(line, [[0.0, 0.0, 0.0], *PATH.tolist()], atol=1e-6)


def test_polyline_reads_amsl_items_relative_to_home() -> None:
    base = build_mission(PATH[:2], FRAME, autopilot=Autopilot.PX4, end="none")
    lat, lon, _ = FRAME.to_geodetic([[100.0, 100.0, 0.0]])
    assert base.home is not None
    amsl = MissionItem(
        command=MavCmd.NAV_WAYPOINT,
        frame=MavFrame.GLOBAL_INT,
        x=float(lat[0]),
        y=float(lon[0]),
        z=base.home.alt_m + 75.0,
    )
    plan = MissionPlan(items=(*base.items, amsl), autopilot=Autopilot.PX4, home=base.home)
    np.testing.assert_allclose(
        mission_polyline_enu(plan, FRAME)[-1], [100.0, 100.0, 75.0], atol=1e-6
    )
    with pytest.raises(ValueError, match="home"):
        mission_polyline_enu(MissionPlan(items=(amsl,)), FRAME)


def test_polyline_land_at_current_position() -> None:
    base = build_mission(PATH, FRAME, autopilot=Autopilot.PX4, end="none")
    land_here = MissionItem(command=MavCmd.NAV_LAND, frame=MavFrame.GLOBAL_RELATIVE_ALT)
    plan = MissionPlan(items=(*base.items, land_here), home=base.home)
    line = mission_polyline_enu(plan, FRAME)
    np.testing.assert_allclose(line[-2:], [PATH[-1], [*PATH[-1, :2], 0.0]], atol=1e-6)


# whole metres: consecutive points are either the same or at least 1 m apart
paths = hnp.arrays(
    np.float64,
    st.tuples(st.integers(2, 12), st.just(3)),
    elements=st.integers(-20_000, 20_000).map(float),
).map(lambda p: np.column_stack((p[:, 0], p[:, 1], np.abs(p[:, 2]) % 500.0 + 1.0)))


@settings(max_examples=60, deadline=None)
@given(
    path=paths,
    lat0=st.floats(-80.0, 80.0),
    lon0=st.floats(-180.0, 180.0),
    end=st.sampled_from(["rtl", "land", "none"]),
)
def test_polyline_reproduces_the_planned_path(
    path: np.ndarray, lat0: float, lon0: float, end: str
) -> None:
    frame = EnuFrame.at(GeoPoint(lat0, lon0, 100.0))
    plan = build_mission(path, frame, autopilot=Autopilot.ARDUPILOT, end=end)  # type: ignore[arg-type]
    line = mission_polyline_enu(plan, frame)
    expected = [[path[0, 0], path[0, 1], 0.0], *path.tolist()]
    if end == "land":
        expected.append([path[-1, 0], path[-1, 1], 0.0])
    # drop the zero-length legs the polyline drops
    keep = [0] + [i for i in range(1, len(expected)) if expected[i] != expected[i - 1]]
    np.testing.assert_allclose(line, [expected[i] for i in keep], atol=1e-5)


# --- one definition of the flown line: items -> ENU equals route.flown_polyline -----------------


@pytest.mark.parametrize("end", ["rtl", "land", "none"])
@pytest.mark.parametrize("takeoff_altitude_m", [None, 10.0, 30.0, 75.0])
def test_mission_polyline_is_the_routes_flown_polyline(
    end: str, takeoff_altitude_m: float | None
) -> None:
    """build_mission(waypoints) -> items -> ENU is flown_polyline(waypoints) to < 1 mm, for
    every end action and take-off altitudes below, equal to and above the start height (30)."""
    plan = build_mission(
        PATH,
        FRAME,
        autopilot=Autopilot.PX4,
        end=end,  # type: ignore[arg-type]
        takeoff_altitude_m=takeoff_altitude_m,
    )
    from_items = mission_polyline_enu(plan, FRAME)
    flown = flown_polyline(PATH, takeoff_altitude_m=takeoff_altitude_m, end=end)  # type: ignore[arg-type]
    assert from_items.shape == flown.shape
    assert np.abs(from_items - flown).max() < 1e-3
    # and the two really differ where they should: a different take-off height adds a leg
    if takeoff_altitude_m not in (None, 30.0):
        assert len(flown) == len(PATH) + 2 + (end == "land")


@settings(max_examples=40, deadline=None)
@given(
    path=paths,
    takeoff_m=st.one_of(st.none(), st.integers(1, 400).map(float)),
    end=st.sampled_from(["rtl", "land", "none"]),
)
def test_mission_polyline_is_the_flown_polyline_for_any_path(
    path: np.ndarray, takeoff_m: float | None, end: str
) -> None:
    kwargs: dict = {"end": end, "takeoff_altitude_m": takeoff_m}
    plan = build_mission(path, FRAME, autopilot=Autopilot.ARDUPILOT, **kwargs)
    flown = flown_polyline(path, takeoff_altitude_m=takeoff_m, end=end)  # type: ignore[arg-type]
    from_items = mission_polyline_enu(plan, FRAME)
    assert from_items.shape == flown.shape
    assert np.abs(from_items - flown).max() < 1e-3
