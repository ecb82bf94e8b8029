"""The flight estimate of plan and validate (issue 27): flight time, watt-hours, battery used
and the reserve, from the scenario's vehicle and wind; the report's keys; the refusal of a
flight that needs more than the usable battery minus the reserve (exit 2, nothing written).

Times and energies are recomputed here by hand from the autopilot's documented defaults and
the power model's electrical power at each state, so the leg bookkeeping is checked, not
restated."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from uavplan.airframe import air_density_kg_m3, electrical_power_w, resolve
from uavplan.cli import main
from uavplan.estimate import estimate_straight_route, mission_limits
from uavplan.mission.items import Autopilot
from uavplan.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]

#: a flat, empty 1.2 km route east at 30 m: the straight route is the planned one
OPEN_FIELD = """\
name: open-field
origin: {{lat: 47.4, lon: 8.5, alt: 400}}
bounds: {{x: [-100, 1400], y: [-200, 200], z: [0, 120]}}
start: [0, 0, 30]
goal: [1200, 0, 30]
obstacles: []
mission: {{autopilot: ardupilot, spacing: 200, end: {end}}}
planner: {{seed: 1}}
{extra}
"""


def scenario_file(tmp_path: Path, *, end: str = "land", extra: str = "") -> Path:
    path = tmp_path / "open-field.yaml"
    path.write_text(OPEN_FIELD.format(end=end, extra=extra))
    return path


def run(*args: object) -> object:
    return CliRunner().invoke(main, [str(a) for a in args])


def power(profile_name: str, airspeed: float, vertical: float, height: float) -> float:
    profile = resolve({"profile": profile_name})
    rho = float(air_density_kg_m3(400.0 + height))
    return float(electrical_power_w(profile, airspeed, vertical, air_density_kg_m3=rho))


def test_the_straight_route_is_timed_and_costed_leg_by_leg(tmp_path: Path) -> None:
    """ArduPilot defaults: take-off at WPNAV_SPEED_UP 2.5 m/s, the leg at the scenario's
    10 m/s, the landing at WPNAV_SPEED_DN 1.5 m/s down to LAND_ALT_LOW 10 m, then LAND_SPEED
    0.5 m/s."""
    path = scenario_file(tmp_path, extra="vehicle: {cruise_speed: 10, profile: x500}")
    est = estimate_straight_route(load_scenario(path))
    legs = [  # (duration s, airspeed, vertical speed, mean height)
        (30 / 2.5, 0.0, 2.5, 15.0),
        (1200 / 10, 10.0, 0.0, 30.0),
        (20 / 1.5, 0.0, -1.5, 20.0),
        (10 / 0.5, 0.0, -0.5, 5.0),
    ]
    time_s = sum(t for t, *_ in legs)
    wh = sum(t * power("x500", v, vz, h) for t, v, vz, h in legs) / 3600
    assert est.energy.time_s == pytest.approx(time_s, rel=1e-9)
    assert est.energy.energy_wh == pytest.approx(wh, rel=1e-6)
    usable = 74.0 * 0.95
    assert est.energy.battery_used_pct == pytest.approx(100 * wh / usable, rel=1e-6)


def test_rtl_flies_home_at_the_rtl_altitude_and_lands_there(tmp_path: Path) -> None:
    """end: rtl: from the goal's 30 m at PX4's RTL_RETURN_ALT (30 m on a multicopter,
    rc.mc_defaults: no climb left), home at the RTL speed (MPC_XY_CRUISE 5 m/s), then
    MPC_Z_V_AUTO_DN to MPC_LAND_ALT1... MPC_LAND_SPEED below the slow-down height."""
    extra = "vehicle: {cruise_speed: 10}"
    text = OPEN_FIELD.format(end="rtl", extra=extra).replace("ardupilot", "px4")
    path = tmp_path / "rtl.yaml"
    path.write_text(text)
    est = estimate_straight_route(load_scenario(path))
    lim = mission_limits(Autopilot.PX4, 10.0)
    assert lim.rtl_altitude_m == 30.0 and est.rtl_altitude_m == 30.0
    slow = lim.land_slow_below_m
    takeoff = (
        lim.takeoff_slow_below_m / lim.takeoff_speed_m_s
        + (30 - lim.takeoff_slow_below_m) / lim.speed_up_m_s
    )
    expected = (
        takeoff
        + 1200 / 10
        + 1200 / lim.rtl_speed_m_s
        + lim.rtl_loiter_s
        + (30 - slow) / lim.land_speed_high_m_s
        + slow / lim.land_speed_m_s
    )
    assert est.energy.time_s == pytest.approx(expected, rel=1e-9)
    assert est.end == "rtl"


@pytest.mark.parametrize(("wind_from", "sign"), [(90, +1), (270, -1)], ids=["head", "tail"])
def test_wind_moves_time_and_energy_by_what_the_wind_triangle_says(
    tmp_path: Path, wind_from: float, sign: int
) -> None:
    """The x500 told to fly 15 m/s flies 12 m/s through calm air (its top airspeed). A 5 m/s
    headwind (from the east, the route flies east) slows it to 12 - 5 = 7 m/s over the ground
    at 12 m/s through the air; a tailwind lets it fly the 15 m/s it was told, at 10 m/s
    through the air. Take-off and landing hold position: airspeed = the wind speed."""
    calm = scenario_file(tmp_path, extra="vehicle: {cruise_speed: 15, profile: x500}")
    windy = tmp_path / "windy.yaml"
    windy.write_text(calm.read_text() + f"wind: {{speed: 5, from: {wind_from}}}\n")
    e_calm = estimate_straight_route(load_scenario(calm)).energy
    e_wind = estimate_straight_route(load_scenario(windy)).energy

    ground, air = (7.0, 12.0) if sign > 0 else (15.0, 10.0)
    vertical = [(12.0, 2.5, 15.0), (20 / 1.5, -1.5, 20.0), (20.0, -0.5, 5.0)]
    t_calm = 1200 / 12 + sum(t for t, *_ in vertical)
    t_wind = 1200 / ground + sum(t for t, *_ in vertical)
    wh_calm = (1200 / 12 * power("x500", 12, 0, 30) + sum(
        t * power("x500", 0, vz, h) for t, vz, h in vertical
    )) / 3600  # fmt: skip
    wh_wind = (1200 / ground * power("x500", air, 0, 30) + sum(
        t * power("x500", 5, vz, h) for t, vz, h in vertical
    )) / 3600  # fmt: skip
    assert e_calm.time_s == pytest.approx(t_calm, rel=1e-9)
    assert e_wind.time_s == pytest.approx(t_wind, rel=1e-9)
    assert e_wind.energy_wh == pytest.approx(wh_wind, rel=1e-6)
    assert e_calm.energy_wh == pytest.approx(wh_calm, rel=1e-6)
    # up against the wind, down with it
    assert sign * (e_wind.time_s - e_calm.time_s) > 10
    assert sign * (e_wind.energy_wh - e_calm.energy_wh) > 0.3


def test_plan_prints_the_estimate_and_reports_its_keys(tmp_path: Path) -> None:
    path = scenario_file(tmp_path, extra="vehicle: {cruise_speed: 10, profile: small-quad}")
    report = tmp_path / "r.json"
    result = run("plan", path, "-o", tmp_path / "m.plan", "--report", report)
    assert result.exit_code == 0, result.output
    line = [s for s in result.output.splitlines() if "Wh" in s]
    assert len(line) == 1 and "small-quad" in line[0] and "reserve 20 %" in line[0]
    data = json.loads(report.read_text())
    # the plan's estimate is the mission as the flight model flies it (corners, speeding up
    # and slowing down): at least the straight route's, by legs, and not much more
    est = estimate_straight_route(load_scenario(path))
    assert est.energy.time_s <= data["flight_time_s"] <= 1.1 * est.energy.time_s
    assert est.energy.energy_wh <= data["energy_wh"] <= 1.1 * est.energy.energy_wh
    assert data["flight_time_s"] == pytest.approx(data["flight"]["flight_time_s"], abs=0.05)
    detail = data["energy_estimate"]
    assert detail["vehicle"] == "small-quad" and detail["vehicle_named"] is True
    assert detail["fits"] is True and detail["reserve_pct"] == 20.0
    assert sum(leg["duration_s"] for leg in detail["legs"]) == pytest.approx(
        data["flight_time_s"], abs=0.5
    )
    # minutes and seconds of the summary line are the report's
    minutes, seconds = divmod(int(data["flight_time_s"] + 0.5), 60)  # as printed: half up
    assert f"flight {minutes} min {seconds:02d} s" in line[0]


def test_a_flight_over_the_battery_is_refused_with_its_numbers(tmp_path: Path) -> None:
    """A named vehicle with a 10 Wh pack: the flight needs more than 80 % of it."""
    path = scenario_file(tmp_path, extra="vehicle: {profile: x500, battery_wh: 10}")
    out = tmp_path / "m.plan"
    result = run("plan", path, "-o", out, "--report", tmp_path / "r.json")
    assert result.exit_code == 2, result.output
    est = estimate_straight_route(load_scenario(path))
    needs = re.search(r"needs (\d+\.\d) Wh", result.output)
    assert needs is not None and float(needs[1]) >= round(est.energy.energy_wh, 1)
    assert "9.5 Wh usable" in result.output and "may use 7.6 Wh (80 %)" in result.output
    assert "Traceback" not in result.output
    assert not out.exists() and not (tmp_path / "r.json").exists()
    # validate says the same about the scenario alone
    result = run("validate", path)
    assert result.exit_code == 2 and "may use 7.6 Wh" in result.output


def test_the_reserve_option_moves_the_limit(tmp_path: Path) -> None:
    path = scenario_file(tmp_path, extra="vehicle: {profile: x500}")
    used = estimate_straight_route(load_scenario(path)).energy.battery_used_pct
    assert 5 < used < 90
    below = run("validate", path, "--reserve", f"{100 - used - 2:.1f}")
    above = run("validate", path, "--reserve", f"{100 - used + 2:.1f}")
    assert below.exit_code == 0, below.output
    assert above.exit_code == 2 and "reserve" in above.output
    assert run("validate", path, "--reserve", "100").exit_code == 2  # out of range


@pytest.mark.slow
def test_an_over_budget_flight_is_refused_unless_allowed(tmp_path: Path) -> None:
    """Issue 37: a flight over the usable battery minus the reserve is exit 2 (nothing
    written) whether or not the scenario names its vehicle; --allow-over-battery writes it
    with a warning (shown with -q)."""
    long = OPEN_FIELD.format(end="land", extra="").replace("1400]", "16000]")
    long = long.replace("goal: [1200, 0, 30]", "goal: [15000, 0, 30]")
    path = tmp_path / "long.yaml"
    path.write_text(long)
    out = tmp_path / "m.plan"
    result = run("plan", path, "-o", out)
    assert result.exit_code == 2, result.output
    assert "x500, the default vehicle" in result.output and "--allow-over-battery" in result.output
    assert not out.exists()
    result = run("plan", path, "-o", out, "-q", "--allow-over-battery")
    assert result.exit_code == 0, result.output
    assert "warning:" in result.output and "(--allow-over-battery)" in result.output
    assert out.exists()
    for extra in ([], ["--allow-over-battery"]):
        result = run("validate", out, "--scenario", path, *extra)
        assert result.exit_code == (0 if extra else 2), result.output


def test_validate_estimates_a_mission_as_plan_estimated_its_route(tmp_path: Path) -> None:
    path = scenario_file(tmp_path, end="rtl", extra="vehicle: {cruise_speed: 8}")
    report = tmp_path / "r.json"
    assert run("plan", path, "-o", tmp_path / "m.plan", "--report", report).exit_code == 0
    result = run("validate", tmp_path / "m.plan", "--scenario", path)
    assert result.exit_code == 0, result.output
    data = json.loads(report.read_text())
    minutes, seconds = divmod(int(data["flight_time_s"] + 0.5), 60)  # as printed: half up
    assert (
        f"the mission as ardupilot flies it, x500 (default vehicle): flight {minutes} min "
        f"{seconds:02d} s" in result.output
    )
    assert f"{data['energy_wh']:.1f} Wh" in result.output


@pytest.mark.parametrize(
    ("extra", "key"),
    [
        ("vehicle: {profile: x501}", "vehicle.profile"),
        ("vehicle: {profile: x500, mass_kg: 0}", "vehicle.mass_kg"),
        ("vehicle: {profile: x500, battery_wh: fast}", "vehicle.battery_wh"),
        ("vehicle: {weight: 2}", "vehicle.weight"),
        ("vehicle: {profile: x500, cruise_speed_m_s: 9}", "vehicle.cruise_speed_m_s"),
        ("wind: {speed: 5}", "wind.from"),
        ("wind: {speed: -1, from: 0}", "wind.speed"),
        ("wind: {speed: 12, from: 0}", "wind.speed"),  # the x500's top airspeed
        ("wind: {from: 0, profile: {heights: [0, 50], speeds: [1]}}", "wind.profile"),
        ("planner: {energy: physics}", "planner.energy"),
    ],
)
def test_a_bad_vehicle_or_wind_is_exit_2_naming_the_key(
    tmp_path: Path, extra: str, key: str
) -> None:
    text = OPEN_FIELD.format(end="land", extra=extra).replace("planner: {seed: 1}\n", "")
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    result = run("validate", path)
    assert result.exit_code == 2, result.output
    assert f"{path}: {key}:" in result.output and "Traceback" not in result.output


def test_the_bundled_scenarios_fit_the_default_vehicle() -> None:
    """Every bundled scenario's straight route is estimated; the paper's environments fit an
    x500 with the 20 % reserve."""
    for name in ("paper-env1", "paper-env2", "paper-env3", "via-tour"):
        est = estimate_straight_route(load_scenario(ROOT / "missions" / f"{name}.yaml"))
        assert est.fits and math.isfinite(est.energy.energy_wh) and est.energy.energy_wh > 0
