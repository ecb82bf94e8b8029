"""The flight model against hand-computed values: leg and climb times from the firmware's
speeds and accelerations, landing speeds, corners bounded by the flavour's radius, wind
through the wind triangle, DO_CHANGE_SPEED, hold times, each firmware's RTL; and
``simulate`` on the bundled scenarios."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from helpers.mavlink_helpers import HOME, planned_scenario, synthetic_mission

from uavplan.airframe import air_density_kg_m3, electrical_power_w, hover_power_w
from uavplan.autopilot.kinematics import Profile, SCurve
from uavplan.autopilot.model import EventKind, FlightModel
from uavplan.autopilot.nav import NavItem
from uavplan.autopilot.params import ARDUPILOT_PARAMS, PX4_PARAMS, Parameters, UnknownParameter
from uavplan.autopilot.power import X500
from uavplan.autopilot.simulate import MissionRefused, distance_to_polyline, simulate
from uavplan.flavour import Autopilot
from uavplan.mission.items import MavCmd, MissionItem

AP, PX4 = Autopilot.ARDUPILOT, Autopilot.PX4
DT = 0.1


def fly(
    autopilot: Autopilot,
    waypoints: list[tuple[float, float, float]],
    *,
    params: dict[str, float] | None = None,
    wind: tuple[float, float] = (0.0, 0.0),
    takeoff_m: float = 30.0,
    extra: list[NavItem] | None = None,
    hold_s: float = 0.0,
    acceptance_m: float = 0.0,
    end: int | None = None,
) -> tuple[np.ndarray, dict[int, float], FlightModel]:
    """Take off to ``takeoff_m``, fly ``waypoints`` (after the items of ``extra``), end with
    ``end`` (a NAV command without a position) if given. Returns the track (t, x, y, z,
    vx, vy, vz per row), {seq: time reached} and the model."""
    model = FlightModel(Parameters(autopilot, params or {}), wind_en_m_s=wind, dt_s=DT)
    items: list[NavItem] = [NavItem(0, 16, (0.0, 0.0, 0.0))] if autopilot == AP else []
    items.append(NavItem(len(items), int(MavCmd.NAV_TAKEOFF), (0.0, 0.0, takeoff_m)))
    for item in extra or []:
        items.append(replace(item, seq=len(items)))
    for point in waypoints:
        items.append(NavItem(len(items), 16, point, param1=hold_s, param2=acceptance_m))
    if end is not None:
        items.append(NavItem(len(items), end))
    model.set_mission(items)
    model.start_mission()
    rows = [(0.0, *model.position, *model.velocity)]
    reached: dict[int, float] = {}
    while not model.mission_complete and model.t_s < 3600:
        for event in model.step():
            if event.kind is EventKind.REACHED and event.seq is not None:
                reached[event.seq] = event.t_s
        rows.append((model.t_s, *model.position, *model.velocity))
    assert model.mission_complete, "the mission did not end"
    return np.array(rows), reached, model


def first_seq(autopilot: Autopilot) -> int:
    """The take-off's seq (ArduPilot's seq 0 is home)."""
    return 1 if autopilot == AP else 0


# ---------------------------------------------------------------------------------------------
# Speed profiles and leg times


def test_a_trapezoidal_profile_covers_its_distance_in_length_over_speed_plus_speed_over_accel():
    profile = Profile(500.0, 0.0, 10.0, 2.5)
    assert profile.duration == pytest.approx(500.0 / 10.0 + 10.0 / 2.5)
    assert profile.at(profile.duration / 2)[1] == pytest.approx(10.0)
    assert profile.at(1e9)[0] == 500.0
    # too short to reach the top speed: a triangle, 2 sqrt(L / a)
    short = Profile(20.0, 0.0, 10.0, 2.5)
    assert short.duration == pytest.approx(2.0 * math.sqrt(20.0 / 2.5))
    assert max(short.at(t)[1] for t in np.linspace(0, short.duration, 101)) < 10.0


def scurve_leg_s(length: float, speed: float, accel: float, jerk: float, tc: float) -> float:
    """A rest-to-rest S-curve leg long enough to reach ``speed`` and ``accel``
    (SCurve.cpp): each speed change takes ``speed/accel + accel/jerk + tj``, its raised-cosine
    jerk ramps ``tj = π·jerk / (2·snap) = 2·max(ATC_INPUT_TC, 0.1)`` long (snap from
    AC_WPNav::calc_scurve_jerk_and_snap); the two cover ``speed`` times that, so the leg is
    ``L/speed`` plus one of them."""
    return length / speed + speed / accel + accel / jerk + 2.0 * max(tc, 0.1)


def test_an_s_curve_profile_reaches_its_speed_through_jerk_limited_acceleration() -> None:
    snap = 1.0 * math.pi / (4.0 * 0.15)  # WPNAV_JERK 1, ATC_INPUT_TC 0.15
    profile = SCurve(500.0, 0.0, 10.0, 2.5, 1.0, snap)
    assert profile.duration == pytest.approx(scurve_leg_s(500.0, 10.0, 2.5, 1.0, 0.15))
    times = np.linspace(0.0, profile.duration, 2001)
    states = np.array([profile.at(t) for t in times])
    assert states[:, 1].max() == pytest.approx(10.0)
    assert states[:, 2].max() == pytest.approx(2.5, rel=1e-6)
    assert np.all(np.diff(states[:, 0]) >= -1e-9)  # never backwards
    jerk = np.diff(states[:, 2]) / np.diff(times)
    assert np.abs(jerk).max() <= 1.0 + 0.05
    assert profile.at(1e9) == (500.0, 0.0, 0.0)
    # the 59 m legs: WPNAV_JERK keeps them from WPNAV_SPEED (SITL: 8.7-9.6 m/s)
    short = SCurve(59.0, 0.0, 10.0, 2.5, 1.0, snap)
    peak = max(short.at(t)[1] for t in np.linspace(0.0, short.duration, 501))
    assert 8.7 < peak < 9.6


@pytest.mark.parametrize(
    ("params", "speed", "accel"),
    [({}, 10.0, 2.5), ({"WPNAV_SPEED": 500.0, "WPNAV_ACCEL": 100.0}, 5.0, 1.0)],
    ids=["defaults", "WPNAV_SPEED=500,WPNAV_ACCEL=100"],
)
def test_ardupilot_flies_a_straight_leg_in_the_time_its_speed_and_acceleration_give(
    params: dict[str, float], speed: float, accel: float
) -> None:
    _, reached, _ = fly(AP, [(400.0, 300.0, 30.0)], params=params)
    leg_s = reached[2] - reached[1]
    assert leg_s == pytest.approx(scurve_leg_s(500.0, speed, accel, 1.0, 0.15), abs=2 * DT)
    # WPNAV_JERK and ATC_INPUT_TC change it as the S-curve says
    _, reached, _ = fly(AP, [(400.0, 300.0, 30.0)], params={**params, "WPNAV_JERK": 4.0})
    expected = scurve_leg_s(500.0, speed, accel, 4.0, 0.15)
    assert reached[2] - reached[1] == pytest.approx(expected, abs=2 * DT)


def test_ardupilot_climbs_at_wpnav_speed_up_and_px4_at_its_take_off_then_auto_speed():
    # ArduPilot: a vertical S-curve leg at WPNAV_SPEED_UP with WPNAV_ACCEL_Z and WPNAV_JERK
    _, reached, _ = fly(AP, [(0.0, 100.0, 30.0)])
    assert reached[1] == pytest.approx(scurve_leg_s(30.0, 2.5, 1.0, 1.0, 0.15), abs=2 * DT)
    _, reached, _ = fly(AP, [(0.0, 100.0, 30.0)], params={"WPNAV_SPEED_UP": 500.0})
    snap = math.pi / (4.0 * 0.15)
    assert reached[1] == pytest.approx(SCurve(30.0, 0.0, 5.0, 1.0, 1.0, snap).duration, abs=2 * DT)
    # PX4: MPC_TKO_SPEED below MPC_LAND_ALT1, MPC_Z_V_AUTO_UP above it
    track, _, _ = fly(PX4, [(0.0, 100.0, 40.0)], takeoff_m=40.0)
    climb = track[:, 6]
    z = track[:, 3]
    assert climb[(z > 3) & (z < 8)] == pytest.approx(1.5, abs=0.01)
    assert climb[(z > 15) & (z < 30)] == pytest.approx(3.0, abs=0.01)


def test_each_flavour_lands_at_its_landing_speeds() -> None:
    track, _, model = fly(AP, [(50.0, 0.0, 30.0)], end=int(MavCmd.NAV_LAND))
    sink = -track[:, 6]
    z = track[:, 3]
    descending = track[:, 0] > 20.0
    assert model.landed and z[-1] == pytest.approx(0.0)
    # WPNAV_SPEED_DN (LAND_SPEED_HIGH 0) above LAND_ALT_LOW, then LAND_SPEED
    assert sink[descending & (z > 15) & (z < 25)] == pytest.approx(1.5, abs=0.01)
    assert sink[descending & (z > 0.5) & (z < 9)] == pytest.approx(0.5, abs=0.01)
    track, _, model = fly(PX4, [(50.0, 0.0, 30.0)], end=int(MavCmd.NAV_LAND))
    sink = -track[:, 6]
    z = track[:, 3]
    descending = track[:, 0] > 20.0
    assert model.landed
    # MPC_Z_V_AUTO_DN above MPC_LAND_ALT1, MPC_LAND_SPEED below MPC_LAND_ALT2
    assert sink[descending & (z > 12) & (z < 25)] == pytest.approx(1.5, abs=0.01)
    assert sink[descending & (z > 0.5) & (z < 4.5)] == pytest.approx(0.7, abs=0.01)


def test_px4_cruises_at_mpc_xy_cruise_and_accepts_a_waypoint_at_its_acceptance_radius() -> None:
    track, reached, _ = fly(PX4, [(300.0, 0.0, 30.0), (300.0, 300.0, 30.0)])
    speed = np.hypot(track[:, 4], track[:, 5])
    assert speed.max() == pytest.approx(5.0, abs=1e-6)
    at = track[np.searchsorted(track[:, 0], reached[1] - 1e-9)]
    # NAV_ACC_RAD: 2 m, as rc.mc_defaults sets it for every multicopter
    assert math.hypot(at[1] - 300.0, at[2]) == pytest.approx(2.0, abs=0.6)


# ---------------------------------------------------------------------------------------------
# Corners


def corner(angle_deg: float) -> list[tuple[float, float, float]]:
    """Two 300 m legs meeting at ``angle_deg`` (180: straight on)."""
    a = math.radians(angle_deg)
    return [(300.0, 0.0, 30.0), (300.0 - 300.0 * math.cos(a), 300.0 * math.sin(a), 30.0)]


def max_deviation(track: np.ndarray, waypoints: list[tuple[float, float, float]]) -> float:
    legs = np.array([(0.0, 0.0, 0.0), (0.0, 0.0, 30.0), *waypoints])
    return float(distance_to_polyline(track[:, 1:4], legs).max())


@pytest.mark.parametrize("angle", [30, 60, 90, 120, 150])
@pytest.mark.parametrize("radius_cm", [200.0, 500.0])
def test_ardupilot_cuts_a_corner_by_at_most_wpnav_radius(angle: int, radius_cm: float) -> None:
    waypoints = corner(angle)
    track, _, _ = fly(AP, waypoints, params={"WPNAV_RADIUS": radius_cm})
    deviation = max_deviation(track, waypoints)
    assert 0.2 < deviation <= radius_cm / 100.0 + 1e-6


@pytest.mark.parametrize("angle", [30, 60, 90, 120, 150])
@pytest.mark.parametrize(
    ("param2", "radius"), [(0.0, 10.0), (3.0, 3.0)], ids=["NAV_ACC_RAD", "item"]
)
def test_px4_cuts_a_corner_by_at_most_its_acceptance_radius(
    angle: int, param2: float, radius: float
) -> None:
    waypoints = corner(angle)
    track, _, _ = fly(PX4, waypoints, acceptance_m=param2)
    deviation = max_deviation(track, waypoints)
    assert 0.2 < deviation <= radius


def test_a_corner_slows_the_vehicle_the_more_the_sharper() -> None:
    def slowest_in_corner(autopilot: Autopilot, angle: int) -> float:
        track, reached, _ = fly(autopilot, corner(angle))
        cruising = (track[:, 0] > reached[first_seq(autopilot)] + 30.0) & (
            track[:, 0] < reached[max(reached)] - 30.0
        )
        return float(np.hypot(track[cruising, 4], track[cruising, 5]).min())

    for autopilot in (AP, PX4):
        speeds = [slowest_in_corner(autopilot, angle) for angle in (150, 90, 30)]
        assert speeds[0] > speeds[1] > speeds[2]


# ---------------------------------------------------------------------------------------------
# Wind, speed changes, hold times


@pytest.mark.parametrize("wind", [(3.0, 0.0), (-3.0, 0.0), (0.0, 3.0), (2.0, -2.0)])
def test_wind_changes_the_ground_speed_as_the_wind_triangle_gives(
    wind: tuple[float, float],
) -> None:
    # independently: the air velocity a has |a| = V and a + w points along the track d
    east = np.array([1.0, 0.0])
    w = np.array(wind)
    cross = w - (w @ east) * east
    ground = float(w @ east + math.sqrt(10.0**2 - cross @ cross))
    _, reached, _ = fly(AP, [(500.0, 0.0, 30.0)], wind=wind)
    expected = scurve_leg_s(500.0, ground, 2.5, 1.0, 0.15)
    assert reached[2] - reached[1] == pytest.approx(expected, abs=2 * DT)
    # the commanded speed is through the air
    assert np.linalg.norm(ground * east - w) == pytest.approx(10.0)
    px4_ground = float(w @ east + math.sqrt(5.0**2 - cross @ cross))
    track, _, _ = fly(PX4, [(500.0, 0.0, 30.0)], wind=wind)
    assert np.hypot(track[:, 4], track[:, 5]).max() == pytest.approx(px4_ground, abs=1e-6)


def test_do_change_speed_changes_the_speed_of_the_legs_after_it() -> None:
    change = NavItem(0, int(MavCmd.DO_CHANGE_SPEED), None, param1=1.0, param2=4.0)
    for autopilot, accel in ((AP, 2.5), (PX4, 3.0)):
        track, reached, _ = fly(autopilot, [(500.0, 0.0, 30.0)], extra=[change])
        assert np.hypot(track[:, 4], track[:, 5]).max() == pytest.approx(4.0, abs=1e-6)
        if autopilot == AP:
            leg = reached[3] - reached[1]
            assert leg == pytest.approx(scurve_leg_s(500.0, 4.0, accel, 1.0, 0.15), abs=2 * DT)


def test_a_hold_time_keeps_the_vehicle_at_the_waypoint_that_long() -> None:
    for autopilot in (AP, PX4):
        _, plain, _ = fly(autopilot, [(200.0, 0.0, 30.0)])
        _, held, _ = fly(autopilot, [(200.0, 0.0, 30.0)], hold_s=8.0)
        last = max(plain)
        assert held[last] - plain[last] == pytest.approx(8.0, abs=DT + 1e-9)


def test_a_changed_parameter_changes_the_flight() -> None:
    _, default, _ = fly(PX4, [(500.0, 0.0, 30.0)])
    track, faster, _ = fly(PX4, [(500.0, 0.0, 30.0)], params={"MPC_XY_CRUISE": 10.0})
    assert np.hypot(track[:, 4], track[:, 5]).max() == pytest.approx(10.0, abs=1e-6)
    assert faster[1] - faster[0] < default[1] - default[0] - 40.0


# ---------------------------------------------------------------------------------------------
# Return to launch


def return_track(track: np.ndarray, reached: dict[int, float], seq: int) -> np.ndarray:
    """Rows after the item ``seq`` was reached."""
    return track[track[:, 0] > reached[seq]]


@pytest.mark.parametrize(
    ("altitude", "where", "expected"),
    [
        (10.0, (200.0, 0.0), 15.0),  # climbs to RTL_ALT
        (40.0, (200.0, 0.0), 40.0),  # already higher: stays there
        (5.0, (3.0, 0.0), 9.0),  # near home the cone (3.0 x 3 m) lowers RTL_ALT
    ],
)
def test_ardupilot_rtl_flies_home_at_rtl_alt_or_higher_lowered_by_the_cone(
    altitude: float, where: tuple[float, float], expected: float
) -> None:
    track, reached, model = fly(
        AP, [(*where, altitude)], takeoff_m=altitude, end=int(MavCmd.NAV_RETURN_TO_LAUNCH)
    )
    home = return_track(track, reached, 2)
    assert home[:, 3].max() == pytest.approx(expected, abs=0.01)
    assert model.landed and np.hypot(home[-1, 1], home[-1, 2]) < 0.05
    # the hover over home (still, at the return altitude) lasts RTL_LOIT_TIME
    still = np.hypot(np.hypot(home[:, 4], home[:, 5]), home[:, 6]) < 1e-6
    over_home = home[
        (np.hypot(home[:, 1], home[:, 2]) < 0.01) & (np.abs(home[:, 3] - expected) < 1e-6) & still
    ]
    assert over_home[-1, 0] - over_home[0, 0] == pytest.approx(5.0, abs=0.3)


def test_px4_rtl_climbs_to_rtl_return_alt_returns_descends_to_rtl_descend_alt_and_lands() -> None:
    # RTL_RETURN_ALT (30 m: rc.mc_defaults), within NAV_MC_ALT_RAD
    track, reached, model = fly(
        PX4, [(300.0, 0.0, 20.0)], takeoff_m=20.0, end=int(MavCmd.NAV_RETURN_TO_LAUNCH)
    )
    home = return_track(track, reached, 1)
    assert home[:, 3].max() == pytest.approx(30.0, abs=0.85)
    assert model.landed and np.hypot(home[-1, 1], home[-1, 2]) < 0.5
    # over home it descends to RTL_DESCEND_ALT (10 m) before landing: at 20 m it sinks at
    # MPC_Z_V_AUTO_DN, and it is over home by then
    sinking = home[home[:, 6] < -0.5]
    at_20 = sinking[np.argmin(np.abs(sinking[:, 3] - 20.0))]
    assert np.hypot(at_20[1], at_20[2]) < 2.0 and -at_20[6] == pytest.approx(1.5, abs=0.01)
    # within RTL_MIN_DIST of home the cone lowers the return altitude: 30 m away, at most
    # 30 m / tan 45°
    track, reached, _ = fly(
        PX4,
        [(30.0, 0.0, 5.0)],
        takeoff_m=5.0,
        end=20,
        acceptance_m=0.5,
        params={"RTL_MIN_DIST": 50.0},
    )
    assert return_track(track, reached, 1)[:, 3].max() == pytest.approx(30.0, abs=0.85)
    # ... and at least twice NAV_ACC_RAD: 15 m away with NAV_ACC_RAD 10, 20 m
    track, reached, _ = fly(
        PX4,
        [(15.0, 0.0, 5.0)],
        takeoff_m=5.0,
        end=20,
        acceptance_m=0.5,
        params={"RTL_MIN_DIST": 50.0, "NAV_ACC_RAD": 10.0},
    )
    assert return_track(track, reached, 1)[:, 3].max() == pytest.approx(20.0, abs=0.85)


# ---------------------------------------------------------------------------------------------
# Terrain-frame legs (ArduPilot follows the ground: AC_WPNav with terrain_alt)

#: ArduPilot's defaults, in SI units, as the firmware's parameter table gives them
AP_SPEED, AP_ACCEL, AP_UP, AP_DOWN, AP_ACCEL_Z, TER_MARGIN = 10.0, 2.5, 2.5, 1.5, 1.0, 10.0
Ground = Callable[[float, float], float]


def bump(height: float, sigma: float, at: float = 500.0) -> Ground:
    """A valley (``height`` < 0) or a ridge across the x axis, the ground's height above
    home at (x, y): zero at home, a Gaussian of ``height`` at x = ``at``."""

    def ground(x: float, y: float) -> float:
        return height * math.exp(-((x - at) ** 2) / (2.0 * sigma * sigma))

    return ground


def slope(gradient: float, start: float = 200.0, run: float = 600.0) -> Ground:
    """Flat, then a uniform slope of ``gradient`` (rise over run) for ``run`` m, then flat."""

    def ground(x: float, y: float) -> float:
        return gradient * min(max(x - start, 0.0), run)

    return ground


def fly_terrain(
    autopilot: Autopilot,
    ground: Ground,
    waypoints: list[tuple[float, float, float]],
    *,
    terrain: bool = True,
    params: dict[str, float] | None = None,
) -> np.ndarray:
    """Take off to 30 m, fly ``waypoints`` (x, y, height above the ground in a terrain
    frame, else above home) over ``ground``. The track: t, x, y, z, vx, vy, vz per row."""
    model = FlightModel(Parameters(autopilot, params or {}), dt_s=DT, ground_z=ground)
    items: list[NavItem] = [NavItem(0, 16, (0.0, 0.0, 0.0))] if autopilot == AP else []
    items.append(NavItem(len(items), int(MavCmd.NAV_TAKEOFF), (0.0, 0.0, 30.0)))
    for x, y, h in waypoints:
        if terrain:  # as nav_items places a terrain-frame item
            items.append(NavItem(len(items), 16, (x, y, h + ground(x, y)), terrain_m=h))
        else:
            items.append(NavItem(len(items), 16, (x, y, h)))
    model.set_mission(items)
    model.start_mission()
    rows = [(0.0, *model.position, *model.velocity)]
    while not model.mission_complete and model.t_s < 3600:
        model.step()
        rows.append((model.t_s, *model.position, *model.velocity))
    assert model.mission_complete, "the mission did not end"
    return np.array(rows)


def height_above(track: np.ndarray, ground: Ground) -> np.ndarray:
    return track[:, 3] - np.array([ground(x, y) for x, y in track[:, 1:3]])


def steepest(ground: Ground, x0: float = 0.0, x1: float = 1000.0) -> float:
    """The ground's steepest gradient along the x axis, by finite differences."""
    x = np.linspace(x0, x1, 20001)
    z = np.array([ground(v, 0.0) for v in x])
    return float(np.max(np.abs(np.diff(z) / np.diff(x))))


@pytest.mark.parametrize(
    ("height", "sigma"),
    [(-80.0, 120.0), (80.0, 120.0), (120.0, 60.0)],
    ids=["valley", "ridge", "steep-ridge"],
)
def test_ardupilot_follows_the_ground_on_terrain_frame_legs_within_the_bound(
    height: float, sigma: float
) -> None:
    """Two terrain-frame legs across a valley or a ridge, the height above the ground going
    from 30 m to 50 m along the second: the vehicle holds the height interpolated along the
    legs within the bound docs/flight-model.md gives, WPNAV_TER_MARGIN plus the ground it
    passes while it slows (gradient · v² / 2·WPNAV_ACCEL) plus a reversal of its climb
    (v_z² / 2·WPNAV_ACCEL_Z). Flown straight between the items' altitudes (the model
    before), it would be off by the whole valley or ridge."""
    ground = bump(height, sigma)
    track = fly_terrain(AP, ground, [(500.0, 0.0, 30.0), (1000.0, 0.0, 50.0)])
    x = track[:, 1]
    wanted = np.where(x <= 500.0, 30.0, 30.0 + 20.0 * (x - 500.0) / 500.0)
    on_legs = (track[:, 0] > 1.0) & (x > 1.0)  # after the take-off
    lag = height_above(track, ground)[on_legs] - wanted[on_legs]
    bound = (
        TER_MARGIN
        + steepest(ground) * AP_SPEED**2 / (2.0 * AP_ACCEL)
        + max(AP_UP, AP_DOWN) ** 2 / (2.0 * AP_ACCEL_Z)
    )
    assert np.max(np.abs(lag)) <= bound
    assert abs(height) > bound  # a straight leg would break it
    assert height_above(track, ground)[-1] == pytest.approx(50.0, abs=2.0)  # WPNAV_RADIUS


def test_ardupilot_follows_gentle_ground_at_full_speed_within_half_the_margin() -> None:
    """Where the ground rises and falls under the vehicle slower than it climbs and descends,
    the vehicle does not slow down and stays within half of WPNAV_TER_MARGIN."""
    ground = bump(-40.0, 200.0)
    assert steepest(ground) * AP_SPEED < AP_DOWN
    track = fly_terrain(AP, ground, [(1000.0, 0.0, 30.0)])
    cruise = (track[:, 1] > 200.0) & (track[:, 1] < 800.0)
    assert np.hypot(track[cruise, 4], track[cruise, 5]).min() == pytest.approx(AP_SPEED)
    lag = height_above(track, ground)[track[:, 1] > 1.0] - 30.0
    assert 0.5 < np.max(np.abs(lag)) <= TER_MARGIN / 2.0


@pytest.mark.parametrize(
    ("gradient", "margin"),
    [(0.5, 10.0), (-0.5, 10.0), (1.0, 10.0), (0.5, 20.0)],
    ids=["up", "down", "up-steep", "up-margin-20"],
)
def test_ardupilot_slows_along_the_leg_where_the_ground_outruns_its_climb(
    gradient: float, margin: float
) -> None:
    """On a long slope the ground rises (falls) under the vehicle at gradient · speed. Where
    that is faster than WPNAV_SPEED_UP (WPNAV_SPEED_DN), the lag behind the ground grows
    past half of WPNAV_TER_MARGIN and AC_PosControl's pos_offset_z_scaler slows the vehicle
    along the track until the climb keeps up: at speed v_z / |gradient|, the lag where the
    scaler 1 − (lag − M/2) / (M/2) gives that share of WPNAV_SPEED."""
    ground = slope(gradient)
    track = fly_terrain(AP, ground, [(1000.0, 0.0, 30.0)], params={"WPNAV_TER_MARGIN": margin})
    climb = AP_UP if gradient > 0 else AP_DOWN
    share = climb / (abs(gradient) * AP_SPEED)
    settled = (track[:, 1] > 550.0) & (track[:, 1] < 750.0)  # well up the slope
    speed = np.hypot(track[settled, 4], track[settled, 5])
    assert speed == pytest.approx(climb / abs(gradient), abs=0.01)
    lag = 30.0 - height_above(track, ground)[settled]  # behind the ground: below it uphill
    expected = margin / 2.0 * (2.0 - share)
    assert np.abs(lag) == pytest.approx(expected, abs=0.01)
    assert np.sign(lag).min() == np.sign(gradient)
    # off the slope it speeds up again and takes up the lag
    after = (track[:, 1] > 800.0) & (track[:, 1] < 980.0)
    assert np.hypot(track[after, 4], track[after, 5]).max() > 1.5 * climb / abs(gradient)
    assert np.abs(30.0 - height_above(track, ground)[track[:, 1] > 980.0]).max() < 2.0


def test_a_relative_frame_leg_over_the_ground_flies_straight_as_before() -> None:
    """A relative-frame leg (and a PX4 terrain-frame one: PX4 does not follow the ground)
    flies the straight line between the items' altitudes, whatever the ground does, in the
    time the flat leg takes."""
    ground = bump(-80.0, 120.0)
    home = ground(0.0, 0.0)  # the take-off climbs from the ground at home

    def level(x: float, y: float) -> float:
        return home

    relative = fly_terrain(AP, ground, [(1000.0, 0.0, 30.0)], terrain=False)
    assert np.array_equal(relative, fly_terrain(AP, level, [(1000.0, 0.0, 30.0)], terrain=False))
    on_leg = relative[:, 1] > 1.0
    line = home + 30.0 + (30.0 - (home + 30.0)) * relative[on_leg, 1] / 1000.0
    assert np.abs(relative[on_leg, 3] - line).max() < 1e-6
    # PX4: the item's altitude is the ground under it plus its height, flown straight
    px4 = fly_terrain(PX4, ground, [(1000.0, 0.0, 30.0)])
    on_leg = (px4[:, 1] > 100.0) & (px4[:, 1] < 900.0)
    end_z = ground(1000.0, 0.0) + 30.0
    assert np.abs(px4[on_leg, 3] - end_z).max() < 1.0
    assert height_above(px4, ground)[on_leg].max() > 100.0  # over the valley: not followed


def test_ardupilot_stops_at_a_waypoint_where_the_altitude_frame_changes() -> None:
    """AC_WPNav::set_wp_destination_next blends a corner only into a leg of the same frame:
    a relative-frame waypoint followed by a terrain-frame one is flown to a stop."""
    ground = slope(0.0)
    model = FlightModel(Parameters(AP), dt_s=DT, ground_z=ground)
    items = [
        NavItem(0, 16, (0.0, 0.0, 0.0)),
        NavItem(1, int(MavCmd.NAV_TAKEOFF), (0.0, 0.0, 30.0)),
        NavItem(2, 16, (300.0, 0.0, 30.0)),
    ]
    for terrain_m in (30.0, None):
        third = NavItem(3, 16, (300.0, 300.0, 30.0), terrain_m=terrain_m)
        model = FlightModel(Parameters(AP), dt_s=DT, ground_z=ground)
        model.set_mission([*items, third])
        model.start_mission()
        slowest = math.inf
        while not model.mission_complete and model.t_s < 600:
            model.step()
            if 250.0 < model.position[0] and model.position[1] < 50.0:
                slowest = min(slowest, math.hypot(*model.velocity[:2]))
        assert model.mission_complete
        if terrain_m is None:
            assert slowest > 1.0  # the corner is blended
        else:
            assert slowest < 0.05  # to a stop


# ---------------------------------------------------------------------------------------------
# simulate()


def test_the_model_is_deterministic() -> None:
    a, _, _ = fly(AP, corner(70), wind=(1.0, 2.0))
    b, _, _ = fly(AP, corner(70), wind=(1.0, 2.0))
    assert np.array_equal(a, b)


@pytest.mark.parametrize("autopilot", [AP, PX4], ids=lambda a: a.label)
def test_simulate_flies_a_bundled_scenario_to_the_ground_through_every_item(
    autopilot: Autopilot,
) -> None:
    plan = planned_scenario("missions/paper-env1.yaml")
    track = simulate(plan, autopilot=autopilot)
    assert track.ended == "landed" and track.completed
    # every NAV item is done once, in order (ArduPilot's seq 0 is home, never flown)
    expected = [i.seq for i in track.nav if i.is_nav and not (autopilot == AP and i.seq == 0)]
    done = [seq for seq, _ in track.reached()]
    assert done == expected
    assert track.nav[done[-1]].command == MavCmd.NAV_RETURN_TO_LAUNCH
    assert track.z_m[0] == 0.0 and track.z_m[-1] == pytest.approx(0.0)
    # until the return begins the vehicle stays within the flavour's radius of the legs
    return_starts = dict(track.reached())[done[-2]]
    before = track.t_s <= return_starts
    deviation = track.deviation_from(track.planned_polyline_enu())[before]
    assert deviation.max() <= (2.0 if autopilot == AP else 10.0) + 1e-6
    # the geodetic track matches the ENU one at home
    assert track.lat_deg[0] == pytest.approx(plan.home.lat_deg, abs=1e-9)
    assert np.all(np.diff(track.t_s) > 0)


def test_simulate_refuses_what_the_firmware_refuses() -> None:
    plan = synthetic_mission(5, seed=1, autopilot=AP)
    no_takeoff = replace(plan, items=plan.items[1:])
    with pytest.raises(MissionRefused) as info:
        simulate(no_takeoff)
    assert info.value.firmware_text == "Auto: Missing Takeoff Cmd"
    empty = replace(
        plan, autopilot=PX4, items=(MissionItem(int(MavCmd.DO_CHANGE_SPEED), 2, 1.0, 5.0),)
    )
    with pytest.raises(MissionRefused) as info:
        simulate(empty)
    assert info.value.firmware_text == "Mission start denied! No valid mission"


def test_simulate_drains_the_battery_by_the_power_model() -> None:
    plan = synthetic_mission(8, seed=2, autopilot=PX4)
    track = simulate(plan)
    # each step drains the power model's power of the state it ended in, recomputed here
    # from the track itself (ground speed = airspeed in calm air; idle on the ground)
    rho = air_density_kg_m3(track.alt_amsl_m[1:])
    flying = electrical_power_w(X500.profile, track.speed_m_s[1:], track.climb_m_s[1:],
                                air_density_kg_m3=rho)  # fmt: skip
    idle = 0.1 * hover_power_w(X500.profile)
    watts = np.where(track.z_m[1:] > 1e-9, flying, idle)
    dt = np.diff(track.t_s)
    assert track.energy_wh == pytest.approx(float(np.sum(watts * dt)) / 3600.0, rel=2e-3)
    # not a constant: forward flight draws less than hover, a climb more
    assert watts.max() > hover_power_w(X500.profile) > watts[track.z_m[1:] > 1.0].min()
    assert track.battery_used_pct == pytest.approx(100 * track.energy_wh / X500.usable_wh)
    assert X500.capacity_mah == pytest.approx(5000.0)


def test_a_headwind_stronger_than_the_speed_stops_the_simulation_with_no_headway() -> None:
    plan = synthetic_mission(4, seed=3, autopilot=AP, speed_m_s=None)
    far_east = MissionItem(16, 3, 0.0, 0.0, 0.0, None, HOME.lat_deg, HOME.lon_deg + 0.01, 30.0)
    plan = replace(plan, items=(plan.items[0], far_east))
    track = simulate(plan, wind_en_m_s=(-12.0, 0.0))
    assert track.ended == "no_headway" and not track.completed


# ---------------------------------------------------------------------------------------------
# Parameters


def test_every_parameter_has_a_source_and_a_default_within_its_range() -> None:
    for table in (ARDUPILOT_PARAMS, PX4_PARAMS):
        names = [spec.name for spec in table]
        assert len(names) == len(set(names))
        for spec in table:
            assert spec.source.startswith("https://"), spec.name
            spec.check(spec.default)


def test_parameters_refuse_unknown_names_and_values_out_of_range() -> None:
    with pytest.raises(UnknownParameter):
        Parameters(PX4, {"WPNAV_SPEED": 500.0})
    with pytest.raises(ValueError, match="WPNAV_SPEED"):
        Parameters(AP, {"WPNAV_SPEED": 5.0})
    # what a PARAM_SET does: stored as sent, the flight model clamps to the range
    odd = Parameters(AP).with_values({"WPNAV_SPEED": 5.0}, checked=False)
    assert odd["WPNAV_SPEED"] == 5.0


def test_the_docs_list_every_parameter_with_its_default_unit_and_source() -> None:
    text = (Path(__file__).resolve().parents[2] / "docs" / "flight-model.md").read_text()
    rows = {
        line.split("`")[1]: [cell.strip() for cell in line.strip().strip("|").split("|")]
        for line in text.splitlines()
        if line.startswith("| `")
    }
    for spec in (*ARDUPILOT_PARAMS, *PX4_PARAMS):
        _, default, unit, _what, source = rows[spec.name]
        assert float(default) == spec.default, spec.name
        assert unit == (spec.unit or "-"), spec.name
        assert f"({spec.source})" in source, spec.name


def test_px4_keeps_climbing_through_a_waypoint_when_the_next_leg_climbs_too() -> None:
    """PositionSmoothing::_getMaxZSpeed: the vertical speed at a waypoint is the corner
    speed of the turn to the next leg (0 only when the next one is level); before, the
    model stopped every climb at every waypoint (jacksboro-ridge on PX4 SIH: its route took
    the model 26 % longer than the firmware)."""
    legs = [(100.0 * k, 0.0, 30.0 + 15.0 * k) for k in range(1, 6)]
    track, reached, _ = fly(PX4, legs)
    climb = track[:, 6]
    at = [int(np.searchsorted(track[:, 0], reached[seq])) for seq in range(1, 5)]
    # 5 m/s along 15 % slopes: 0.75 m/s up, kept through each waypoint (braked: < 0.4 m/s)
    assert all(climb[i] > 0.6 for i in at), [climb[i] for i in at]
    level, flat_reached, _ = fly(PX4, [(100.0, 0.0, 45.0), (200.0, 0.0, 45.0)])
    i = int(np.searchsorted(level[:, 0], flat_reached[1]))
    assert abs(level[i, 6]) < 0.5  # the next leg is level: the climb ends at the waypoint


def test_px4_takes_off_at_its_take_off_speed_after_the_motor_ramp() -> None:
    """FlightTaskAuto::_updateTrajConstraints: below MPC_LAND_ALT1 a take-off climbs at
    MPC_TKO_SPEED, accelerating at most MPC_TKO_SPEED / MPC_TKO_RAMP_T (0.5 m/s²)."""
    track, _, _ = fly(PX4, [(0.0, 100.0, 30.0)])
    t, z, vz = track[:, 0], track[:, 3], track[:, 6]
    lifting = np.flatnonzero(vz > 0.01)[0]
    reach = np.flatnonzero(vz >= 1.5 - 1e-6)[0]
    assert t[reach] - t[lifting] == pytest.approx(1.5 / 0.5, abs=2 * DT)
    assert z[reach] < 10.0
