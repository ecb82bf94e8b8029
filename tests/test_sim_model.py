"""The flight model against hand-computed values: leg and climb times from the firmware's
speeds and accelerations, landing speeds, corners bounded by the flavour's radius, wind
through the wind triangle, DO_CHANGE_SPEED, hold times, each firmware's RTL; and
``simulate`` on the bundled scenarios."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from mavlink_helpers import HOME, planned_scenario, synthetic_mission

from uavplan.config import Autopilot
from uavplan.mission.items import MavCmd, MissionItem
from uavplan.sim.kinematics import Profile
from uavplan.sim.model import EventKind, FlightModel, NavItem
from uavplan.sim.params import ARDUPILOT_PARAMS, PX4_PARAMS, Parameters, UnknownParameter
from uavplan.sim.power import X500
from uavplan.sim.simulate import MissionRefused, distance_to_polyline, simulate
from uavplan.vehicle import air_density_kg_m3, electrical_power_w, hover_power_w

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
    assert leg_s == pytest.approx(500.0 / speed + speed / accel, abs=2 * DT)


def test_ardupilot_climbs_at_wpnav_speed_up_and_px4_at_its_take_off_then_auto_speed():
    # ArduPilot: a vertical leg at WPNAV_SPEED_UP with WPNAV_ACCEL_Z
    _, reached, _ = fly(AP, [(0.0, 100.0, 30.0)])
    assert reached[1] == pytest.approx(30.0 / 2.5 + 2.5 / 1.0, abs=2 * DT)
    _, reached, _ = fly(AP, [(0.0, 100.0, 30.0)], params={"WPNAV_SPEED_UP": 500.0})
    assert reached[1] == pytest.approx(30.0 / 5.0 + 5.0 / 1.0, abs=2 * DT)
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
    assert math.hypot(at[1] - 300.0, at[2]) == pytest.approx(10.0, abs=0.6)  # NAV_ACC_RAD


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
    assert reached[2] - reached[1] == pytest.approx(500.0 / ground + ground / 2.5, abs=2 * DT)
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
            assert leg == pytest.approx(500.0 / 4.0 + 4.0 / accel, abs=2 * DT)


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
    # the hover over home lasts RTL_LOIT_TIME
    over_home = home[
        (np.hypot(home[:, 1], home[:, 2]) < 0.01) & (np.abs(home[:, 3] - expected) < 1e-6)
    ]
    assert over_home[-1, 0] - over_home[0, 0] == pytest.approx(5.0, abs=0.3)


def test_px4_rtl_climbs_to_rtl_return_alt_returns_descends_to_rtl_descend_alt_and_lands() -> None:
    track, reached, model = fly(PX4, [(300.0, 0.0, 30.0)], end=int(MavCmd.NAV_RETURN_TO_LAUNCH))
    home = return_track(track, reached, 1)
    assert home[:, 3].max() == pytest.approx(60.0, abs=0.85)  # RTL_RETURN_ALT, NAV_MC_ALT_RAD
    assert model.landed and np.hypot(home[-1, 1], home[-1, 2]) < 0.5
    # over home it descends to RTL_DESCEND_ALT (30 m) before landing: at 40 m it sinks at
    # MPC_Z_V_AUTO_DN, and it is over home by then
    at_40 = home[np.argmin(np.abs(home[:, 3] - 40.0))]
    assert np.hypot(at_40[1], at_40[2]) < 10.0 and -at_40[6] == pytest.approx(1.5, abs=0.01)
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
    # ... and at least twice NAV_ACC_RAD: 15 m away, 20 m
    track, reached, _ = fly(
        PX4,
        [(15.0, 0.0, 5.0)],
        takeoff_m=5.0,
        end=20,
        acceptance_m=0.5,
        params={"RTL_MIN_DIST": 50.0},
    )
    assert return_track(track, reached, 1)[:, 3].max() == pytest.approx(20.0, abs=0.85)


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
    text = (Path(__file__).resolve().parent.parent / "docs" / "flight-model.md").read_text()
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
