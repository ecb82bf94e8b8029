"""The simulated vehicle drains its battery by the power model (issue 27 item 5).

``simulate`` and the MAVLink vehicle draw the power of :mod:`uavplan.airframe` for their
profile at each step of the flight, so a simulated flight's energy is the estimate's for the
same legs, up to what only the simulation flies: accelerations, braking and corners (the
estimate flies every leg at constant speed), and a few tenths of a second of idle on the
ground. On a straight leg that is under 5 %, on a planned route with its corners under 8 %,
and the simulation never needs less."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers.mavlink_helpers import synthetic_mission

from uavplan.airframe import hover_power_w, resolve
from uavplan.app.check import read_mission_flight
from uavplan.autopilot.power import X500, Battery, PowerState, spec_for
from uavplan.autopilot.simulate import simulate
from uavplan.estimate import estimate_flight, estimate_mission, mission_limits
from uavplan.flavour import Autopilot
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.mavlink.messages import BatteryStatus, SysStatus
from uavplan.mavlink.transfer import plan_wire_items
from uavplan.mission.builder import build_mission, mission_polyline_enu
from uavplan.mission.io import mission_text
from uavplan.mission.items import MissionPlan, MissionType
from uavplan.planning import mission_for, plan_route
from uavplan.scenario import load_scenario
from uavplan.sim.vehicle import SimConfig, SimVehicle

ROOT = Path(__file__).resolve().parents[2]
AP, PX4 = Autopilot.ARDUPILOT, Autopilot.PX4
HOME = GeoPoint(47.4, 8.5, 400.0)


@pytest.mark.parametrize("end", ["land", "rtl"])
@pytest.mark.parametrize("autopilot", [AP, PX4], ids=lambda a: a.label)
def test_a_straight_flight_draws_what_the_estimate_says(autopilot: Autopilot, end: str) -> None:
    frame = EnuFrame.at(HOME)
    waypoints = np.array([[0.0, 0.0, 30.0], [1500.0, 200.0, 45.0]])
    plan = build_mission(
        waypoints, frame, autopilot=autopilot, end=end, takeoff_altitude_m=None, cruise_speed_m_s=10
    )
    track = simulate(plan)
    assert track.ended == "landed"
    energy, _ = estimate_flight(
        mission_polyline_enu(plan, frame),
        profile=X500.profile,
        limits=mission_limits(autopilot, 10.0),
        from_ground=True,
        end=end,
        datum_amsl_m=HOME.alt_m,
    )
    # the legs estimate (the fallback for a mission the flight model does not fly) knows
    # trapezoidal legs; ArduPilot flies jerk-limited S-curves (issue 32, held against SITL),
    # which take longer: measured 5.5-5.9 % here. It stays a lower bound.
    band = 1.08 if autopilot == AP else 1.05
    assert energy.energy_wh <= track.energy_wh <= band * energy.energy_wh
    assert energy.time_s <= track.flight_time_s <= band * energy.time_s
    assert track.battery_used_pct == pytest.approx(100 * track.energy_wh / X500.usable_wh)


@pytest.mark.parametrize("name", ["paper-env1", "via-tour"])
def test_a_planned_mission_draws_what_the_estimate_says_within_8_percent(
    tmp_path: Path, name: str
) -> None:
    scn = load_scenario(ROOT / "missions" / f"{name}.yaml")
    result = plan_route(scn)
    assert result.route is not None
    plan = mission_for(scn, result.route)
    out = tmp_path / "m.plan"
    out.write_text(mission_text(plan, str(out)))
    plan, flight = read_mission_flight(str(out), scn)
    # what plan and validate print: the whole flight the verdict judged, through the flight
    # model with the scenario's vehicle and wind (app.check); the legs estimate only bounds it
    # from below (ArduPilot's S-curves on short legs: paper-env1 draws 17 % more)
    from uavplan.app.check import judged
    from uavplan.estimate import estimate_flown
    from uavplan.rehearsal import CheckSite

    verdict = judged(plan, CheckSite.of_scenario(scn), scn)
    assert verdict is not None and verdict.rehearsal is not None
    printed = estimate_flown(scn, verdict.rehearsal.flown)
    legs = estimate_mission(scn, plan, flight)
    track = simulate(plan)
    assert track.ended == "landed"
    ratio = track.energy_wh / printed.energy.energy_wh
    assert 0.98 <= ratio <= 1.02, ratio
    assert legs.energy.energy_wh <= track.energy_wh


def fly(autopilot: Autopilot, *, profile: str = "x500") -> tuple[SimVehicle, Any, MissionPlan]:
    """Fly a synthetic mission through the sans-I/O vehicle to its disarm, at speedup 20."""
    from helpers.vehicle_driver import Driver, start

    plan = synthetic_mission(5, seed=4, autopilot=autopilot)
    driver = Driver(
        SimConfig(
            autopilot=autopilot,
            home=plan.home,
            speedup=20,
            vehicle=spec_for(resolve({"profile": profile})),
        )
    )
    driver.vehicle.preload(
        MissionType.MISSION, plan_wire_items(plan, MissionType.MISSION, autopilot)
    )
    driver.run(0.3)
    start(driver)
    driver.run_until(lambda: not driver.vehicle.armed, limit_s=120, step=0.005)
    return driver.vehicle, driver, plan


@pytest.mark.parametrize("autopilot", [AP, PX4], ids=lambda a: a.label)
def test_the_vehicle_reports_the_model_s_battery(autopilot: Autopilot) -> None:
    vehicle, driver, plan = fly(autopilot)
    predicted = simulate(plan)
    battery = vehicle.battery
    # the same model over the same flight; the vehicle also idles armed on the ground
    # (PX4 disarms 2 s after landing)
    idle_wh = 0.1 * hover_power_w(X500.profile) * (2.5 if autopilot == PX4 else 0.5) / 3600
    assert battery.used_wh == pytest.approx(predicted.energy_wh, abs=idle_wh + 0.02)
    status = [m for m in driver.heard if isinstance(m, BatteryStatus)][-1]
    sys_status = [m for m in driver.heard if isinstance(m, SysStatus)][-1]
    assert status.energy_consumed == pytest.approx(battery.used_wh * 36.0, abs=1)  # hJ
    used_pct = 100 * battery.used_wh / X500.usable_wh
    assert status.battery_remaining == pytest.approx(100 - used_pct, abs=1)
    assert sys_status.battery_remaining == status.battery_remaining
    assert 1 < used_pct < 60


@pytest.mark.parametrize("profile", ["small-quad", "x500", "heavy-lift"])
def test_the_profile_sets_the_hover_draw(profile: str) -> None:
    spec = spec_for(resolve({"profile": profile}))
    battery = Battery(spec)
    battery.drain(PowerState(True, True, 0.0, 0.0, altitude_amsl_m=0.0), 1.0)
    hover = hover_power_w(spec.profile)
    assert battery.used_wh == pytest.approx(hover / 3600.0, rel=1e-9)
    assert battery.current_a == pytest.approx(hover / (spec.cells * 4.2), rel=1e-9)
    # climbing draws more, forward flight at 8 m/s less (the bucket), disarmed nothing
    climb = Battery(spec)
    climb.drain(PowerState(True, True, 0.0, 2.5), 1.0)
    cruise = Battery(spec)
    cruise.drain(PowerState(True, True, 8.0, 0.0), 1.0)
    off = Battery(spec)
    off.drain(PowerState(False, False), 1.0)
    assert climb.used_wh > battery.used_wh > cruise.used_wh > off.used_wh == 0.0


def test_a_simulated_track_prints_and_reports_like_the_estimate() -> None:
    """The seam for ``simulate`` and ``fly``: the flown track as a EnergyUse."""
    from uavplan.estimate import flown_energy

    track = simulate(synthetic_mission(4, seed=5, autopilot=AP))
    flown = flown_energy(track)
    assert flown.energy_wh == pytest.approx(track.energy_wh, rel=1e-12)
    assert flown.time_s == track.flight_time_s
    assert flown.battery_used_pct == pytest.approx(track.battery_used_pct, rel=1e-12)
    minutes, seconds = divmod(round(track.flight_time_s), 60)
    assert flown.summary().startswith(f"flight {minutes} min {seconds:02d} s, ")
    assert flown.report_fields()["energy_wh"] == round(track.energy_wh, 2)
