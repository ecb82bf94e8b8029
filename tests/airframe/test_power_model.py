"""The multirotor power model, the bundled profiles, wind and the battery (uavplan.airframe).

Expected values are computed here by hand from the textbook formulas (momentum theory,
Leishman's climb and vortex-ring results, the kinematics of a straight leg in wind), not by
calling the code under test a second way.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from uavplan.airframe import constants as C
from uavplan.airframe import power
from uavplan.airframe.legs import (
    EnergyBudgetError,
    Legs,
    WindTooStrongError,
    flight_energy,
    still_air_time_s,
)
from uavplan.airframe.power import (
    air_density_kg_m3,
    electrical_power_w,
    hover_power_w,
    hover_time_s,
    minimum_power_speed_m_s,
    power_terms,
    rotor_state,
)
from uavplan.airframe.profile import VehicleProfile
from uavplan.airframe.profiles import CITED_HOVER_TIME_S, PROFILES, SOURCES, resolve
from uavplan.airframe.wind import Wind
from uavplan.errors import EXIT_INPUT, InputError

RHO0 = 1.225
G = 9.80665
X500 = PROFILES["x500"]
SMALL = PROFILES["small-quad"]
HEAVY = PROFILES["heavy-lift"]

# --- bundled profiles against their sources -------------------------------------------------------

_X500_REASON = (
    "Holybro's ~18 min hover is 12 % shorter than the generic model predicts for a 1.59 kg "
    "X500 V2 with a 74 Wh pack, and the kit's own motor bench table predicts the same; no "
    "sourced all-up weight closes it, and tuning to the 18 min would be fitting (docs/energy.md)"
)


@pytest.mark.parametrize(
    "name",
    [
        "small-quad",
        pytest.param("x500", marks=pytest.mark.xfail(strict=True, reason=_X500_REASON)),
        "heavy-lift",
    ],
)
def test_hover_time_is_within_10_percent_of_the_cited_one(name: str) -> None:
    predicted = hover_time_s(PROFILES[name])
    cited = CITED_HOVER_TIME_S[name]
    assert abs(predicted / cited - 1.0) <= 0.10, (name, predicted / 60, cited / 60)


def test_the_x500_miss_is_the_documented_one() -> None:
    """The X500's xfail above is for this size of miss, not for anything else; and the
    better-sourced hover power of the kit's motor bench table (below) misses by as much."""
    ratio = hover_time_s(X500) / CITED_HOVER_TIME_S["x500"]
    assert 1.10 < ratio < 1.15
    bench = X500.with_overrides(hover_power_w=_x500_bench_hover_power_w(X500.mass_kg))
    assert 1.10 < hover_time_s(bench) / CITED_HOVER_TIME_S["x500"] < 1.15


# The X500 V2 kit's propulsion bench test: Holybro's motor sheet, linked from the kit's page
# (https://cdn.shopify.com/s/files/1/0604/5905/7341/files/X500MotorSpec.png), the table T-Motor
# publishes for its Air Gear 450 II (AIR2216II KV920 motor, T1045II 10 x 4.5 in propeller,
# BLHeli S 20A ESC) at 16 V. Per motor: thrust (g) and electrical power drawn from the battery (W),
# 30 % to 100 % throttle. Read in two public transcriptions of the sheet that agree row for row
# (not in the image itself): docs/energy.md, "Hover time: predicted and published".
_X500_BENCH = (
    (210, 23),
    (259, 30),
    (309, 37),
    (373, 46),
    (447, 58),
    (536, 72),
    (628, 90),
    (729, 108),
    (814, 126),
    (906, 147),
    (993, 169),
    (1087, 193),
    (1191, 219),
    (1289, 249),
    (1332, 260),
)
_X500_BENCH_THRUST_G, _X500_BENCH_POWER_W = np.array(_X500_BENCH, dtype=float).T


def _x500_bench_hover_power_w(mass_kg: float) -> float:
    """Hover power from the bench table: each of the 4 motors carries a quarter of the weight
    (thrust in grams-force = mass in grams / 4), its power interpolated linearly between the
    table's rows, plus the flight controller, GNSS and radios (the 10 W avionics constant: the
    table is the propulsion alone)."""
    per_motor_w = float(np.interp(mass_kg * 1000 / 4, _X500_BENCH_THRUST_G, _X500_BENCH_POWER_W))
    return 4 * per_motor_w + C.AVIONICS_POWER_W


def test_the_x500_hover_power_agrees_with_the_kits_motor_bench_table() -> None:
    # 1.59 kg: 397.5 g per motor, between 373 g at 46 W and 447 g at 58 W: 49.97 W each,
    # 199.9 W for four, 209.9 W with the avionics; the generic model gives 208.6 W. The
    # bench is a static test of one propeller in free air at 16 V, so agreement within 5 %
    # is what it can confirm; it is an independent check of the model, not an input to it
    assert _x500_bench_hover_power_w(1.59) == pytest.approx(10 + 4 * (46 + 12 * 24.5 / 74))
    assert hover_power_w(X500) == pytest.approx(_x500_bench_hover_power_w(X500.mass_kg), rel=0.05)
    # and the bench table's X500 would need 435 g per motor (1.74 kg) to hover 18 minutes
    # on the usable 70.3 Wh: 234.3 W, 56.1 W per motor
    needed_w = 74.0 * 0.95 * 3600 / CITED_HOVER_TIME_S["x500"]
    per_motor_g = np.interp((needed_w - 10) / 4, _X500_BENCH_POWER_W, _X500_BENCH_THRUST_G)
    assert 4 * per_motor_g / 1000 == pytest.approx(1.74, abs=0.005)


def test_heavy_lift_with_its_cited_payload_and_bigger_batteries() -> None:
    """DJI's page gives two more hover times for the same airframe: 6 kg payload (16 min) and
    six TB48S packs (10 kg, 779.8 Wh: 38 min). The model, unchanged, is within 10 % of both."""
    payload = HEAVY.with_overrides(mass_kg=9.5 + 6.0)
    tb48s = HEAVY.with_overrides(mass_kg=10.0, battery_wh=6 * 129.96)
    assert hover_time_s(payload) == pytest.approx(16 * 60, rel=0.10)
    assert hover_time_s(tb48s) == pytest.approx(38 * 60, rel=0.10)


def test_every_bundled_profile_uses_the_same_generic_constants() -> None:
    generic = {
        "battery_usable_fraction": C.BATTERY_USABLE_FRACTION,
        "avionics_power_w": C.AVIONICS_POWER_W,
        "figure_of_merit": C.FIGURE_OF_MERIT,
        "induced_power_factor": C.INDUCED_POWER_FACTOR,
        "motor_esc_efficiency": C.MOTOR_ESC_EFFICIENCY,
        "thrust_coefficient": C.THRUST_COEFFICIENT,
        "drag_area_m2": None,
        "hover_power_w": None,
        "cruise_power_w": None,
    }
    for profile in PROFILES.values():
        assert {k: getattr(profile, k) for k in generic} == generic, profile.name


def test_every_spec_figure_of_every_profile_is_cited() -> None:
    for name in PROFILES:
        cited = {c.field for c in SOURCES[name]}
        for needed in ("mass_kg", "battery_wh", "max_airspeed_m_s", "hover time"):
            assert needed in cited, (name, needed)
        assert any("rotor_diameter_m" in field for field in cited), name
        assert all(c.url.startswith("https://") and c.says for c in SOURCES[name])


# --- momentum theory by hand ----------------------------------------------------------------------


def _vehicle(**kw: float) -> VehicleProfile:
    base = {
        "name": "test",
        "mass_kg": 10.0 / G,  # 10 N of weight
        "rotor_count": 4,
        "rotor_diameter_m": 2.0 * math.sqrt(0.5 / (4 * math.pi)),  # 0.5 m² in all
        "battery_wh": 100.0,
        "max_airspeed_m_s": 15.0,
    }
    base.update(kw)
    return VehicleProfile(**base)  # type: ignore[arg-type]


def test_hover_momentum_theory_against_hand_computed_numbers() -> None:
    # T = 10 N, A = 0.5 m², ρ = 1.225: v_h = sqrt(10 / (2·1.225·0.5)) = 2.857143 m/s,
    # P_ideal = T·v_h = 28.57143 W
    vehicle = _vehicle()
    state = rotor_state(vehicle, RHO0)
    assert power.disc_area_m2(vehicle) == pytest.approx(0.5, rel=1e-12)
    assert float(state.hover_induced_velocity_m_s) == pytest.approx(2.857143, rel=1e-6)
    assert float(state.ideal_power_w) == pytest.approx(28.57143, rel=1e-6)
    # electrical: 10 W avionics + 28.57143 / 0.55 / 0.80 = 74.93506 W
    assert hover_power_w(vehicle) == pytest.approx(10.0 + 28.57143 / 0.55 / 0.80, rel=1e-6)
    # blade profile power: P_ideal·(1/FM − κ) = 28.57143·(1.818182 − 1.15) = 19.09091 W
    assert float(state.profile_power_w) == pytest.approx(19.09091, rel=1e-6)
    # an ideal rotor (FM = 1/κ = 1, no losses, no avionics) draws exactly T·v_h
    ideal = _vehicle(
        figure_of_merit=1.0,
        induced_power_factor=1.0,
        motor_esc_efficiency=1.0,
        avionics_power_w=0.0,
    )
    assert hover_power_w(ideal) == pytest.approx(28.57143, rel=1e-6)


def test_the_x500_hover_power_by_hand() -> None:
    # T = 1.59·9.80665 = 15.59257 N, A = 4·π·0.127² = 0.2026830 m²
    t, a = 15.59257, 0.2026830
    ideal = t**1.5 / math.sqrt(2 * 1.225 * a)
    assert ideal == pytest.approx(87.374, rel=1e-4)
    assert hover_power_w(X500) == pytest.approx(10 + ideal / 0.55 / 0.80, rel=1e-5)


def test_thinner_air_costs_more_power() -> None:
    # ISA: 1.225 kg/m³ at sea level, 1.1117 at 1000 m, 0.9093 at 3000 m (standard tables)
    assert float(air_density_kg_m3(0.0)) == pytest.approx(1.225, rel=1e-9)
    assert float(air_density_kg_m3(1000.0)) == pytest.approx(1.1117, abs=2e-4)
    assert float(air_density_kg_m3(3000.0)) == pytest.approx(0.9093, abs=2e-4)
    rho = air_density_kg_m3(np.array([0.0, 1000.0, 3000.0]))
    p = electrical_power_w(X500, 0.0, 0.0, air_density_kg_m3=rho)
    assert np.all(np.diff(p) > 0)
    # induced and profile power go as 1/sqrt(ρ) at fixed pitch
    shaft = (p - 10.0) * 0.8
    assert shaft[2] / shaft[0] == pytest.approx(math.sqrt(1.225 / float(rho[2])), rel=1e-9)
    with pytest.raises(InputError):
        air_density_kg_m3(20_000.0)


def test_power_grows_with_mass() -> None:
    masses = np.linspace(0.8, 3.0, 12)
    hover = [hover_power_w(X500.with_overrides(mass_kg=m)) for m in masses]
    cruise = [float(electrical_power_w(X500.with_overrides(mass_kg=m), 10.0)) for m in masses]
    assert np.all(np.diff(hover) > 0) and np.all(np.diff(cruise) > 0)
    # hover power over avionics goes as m^1.5
    ratio = (hover[-1] - 10) / (hover[0] - 10)
    assert ratio == pytest.approx((3.0 / 0.8) ** 1.5, rel=1e-9)


# --- climb and descent ----------------------------------------------------------------------------


def test_axial_climb_against_leishman_by_hand() -> None:
    # hovering vehicle of the hand example (T = 10 N, v_h = 2.857143 m/s), climbing at 2 m/s:
    # x = 0.7, induced + climb = T·V_c + κ·T·v_h·(−x/2 + sqrt(x²/4 + 1))
    vehicle = _vehicle()
    v_h, x = 2.857143, 2.0 / 2.857143
    induced = 10 * 2.0 + 1.15 * 10 * v_h * (-x / 2 + math.sqrt(x * x / 4 + 1))
    terms = power_terms(vehicle, 0.0, 2.0)
    assert float(terms.induced_w) == pytest.approx(induced, rel=1e-6)
    assert float(terms.profile_w) == pytest.approx(19.09091, rel=1e-6)  # unchanged by the climb


def test_descent_through_the_vortex_ring_fit_by_hand() -> None:
    # descending at V_c = −v_h (x = −1): v_i/v_h = κ − k1 + k2 − k3 + k4
    #   = 1.15 + 1.125 − 1.372 + 1.718 − 0.655 = 1.966; induced + climb = T·v_h·(−1 + 1.966)
    vehicle = _vehicle()
    v_h = 2.857143
    terms = power_terms(vehicle, 0.0, -v_h)
    assert float(terms.induced_w) == pytest.approx(10 * v_h * 0.966, rel=1e-5)
    # deep in the windmill-brake state the rotors would give power back: clamped at 0
    assert float(power_terms(vehicle, 0.0, -4 * v_h).induced_w) == 0.0


@pytest.mark.parametrize("name", list(PROFILES))
def test_climb_costs_more_and_descent_less_than_level_flight(name: str) -> None:
    profile = PROFILES[name]
    for airspeed in (0.0, 5.0, 10.0):
        level = float(electrical_power_w(profile, airspeed))
        rates = np.array([1.0, 1.5, 2.5, 3.0, 5.0])
        climb = electrical_power_w(profile, airspeed, rates)
        descent = electrical_power_w(profile, airspeed, -rates)
        assert np.all(climb > level) and np.all(np.diff(climb) > 0), airspeed
        assert np.all(descent < level) and np.all(np.diff(descent) < 0), airspeed


@pytest.mark.parametrize("name", list(PROFILES))
def test_power_is_never_negative_and_never_below_the_floor(name: str) -> None:
    profile = PROFILES[name]
    v, vz = np.meshgrid(np.linspace(0, 25, 26), np.linspace(-30, 0, 31))
    terms = power_terms(profile, v, vz)
    floor = profile.avionics_power_w + (terms.profile_w + terms.parasite_w) / 0.8
    assert np.all(terms.induced_w >= 0)
    assert np.all(terms.total_w >= floor - 1e-9) and np.all(terms.total_w > 0)


# --- forward flight -------------------------------------------------------------------------------


@pytest.mark.parametrize("name", list(PROFILES))
def test_forward_flight_power_has_the_bucket_shape(name: str) -> None:
    profile = PROFILES[name]
    v_min = minimum_power_speed_m_s(profile)
    assert 0.0 < v_min < profile.max_airspeed_m_s
    speeds = np.linspace(0.0, profile.max_airspeed_m_s, 200)
    p = electrical_power_w(profile, speeds)
    falling, rising = p[speeds <= v_min], p[speeds >= v_min]
    assert np.all(np.diff(falling) < 0) and np.all(np.diff(rising) > 0)
    assert p[0] > p.min() and p[-1] > p.min()


def test_power_is_vectorised_over_states() -> None:
    v = np.array([[0.0, 4.0, 8.0], [12.0, 2.0, 6.0]])
    vz = np.array([[0.0, 1.0, -1.0], [2.0, -3.0, 0.5]])
    out = electrical_power_w(X500, v, vz)
    assert out.shape == (2, 3)
    pairs = zip(v.ravel(), vz.ravel(), strict=True)
    one_by_one = np.array([float(electrical_power_w(X500, a, b)) for a, b in pairs])
    np.testing.assert_allclose(out.ravel(), one_by_one, rtol=1e-12)


def test_zeng_eq12_is_the_zero_drag_level_case() -> None:
    # with f = 0 the thrust is the weight, and the level power is Zeng et al.'s eq. 12:
    # P0·(1 + 3V²/U²) + κ·P_id·sqrt(sqrt(1 + V⁴/(4v0⁴)) − V²/(2v0²))
    vehicle = _vehicle(drag_area_m2=0.0)
    p_id, v0, p0 = 28.57143, 2.857143, 19.09091
    u2 = 10 / (1.225 * 0.5 * C.THRUST_COEFFICIENT)
    for v in (3.0, 7.0, 15.0):
        r = math.sqrt(math.sqrt(1 + v**4 / (4 * v0**4)) - v**2 / (2 * v0**2))
        shaft = p0 * (1 + 3 * v * v / u2) + 1.15 * p_id * r
        assert float(electrical_power_w(vehicle, v)) == pytest.approx(10 + shaft / 0.8, rel=1e-5)


# --- measured figures -----------------------------------------------------------------------------


def test_a_profile_calibrated_to_measured_hover_and_cruise_power() -> None:
    measured = X500.with_overrides(hover_power_w=240.0, cruise_power_w=215.0, cruise_speed_m_s=10.0)
    assert hover_power_w(measured) == pytest.approx(240.0, rel=1e-9)
    assert float(electrical_power_w(measured, 10.0)) == pytest.approx(215.0, rel=1e-9)
    # the usable energy over the measured hover power is the hover time
    assert hover_time_s(measured) == pytest.approx(74.0 * 0.95 * 3600 / 240.0, rel=1e-9)
    with pytest.raises(InputError) as err:
        X500.with_overrides(hover_power_w=240.0, cruise_power_w=60.0, cruise_speed_m_s=10.0)
    assert err.value.key == "cruise_power_w"
    with pytest.raises(InputError) as err:
        X500.with_overrides(cruise_power_w=215.0, cruise_speed_m_s=10.0)
    assert err.value.key == "cruise_power_w"


# --- overrides ------------------------------------------------------------------------------------

_NEW_VALUES = {
    "name": "my-x500",
    "mass_kg": 2.2,
    "rotor_count": 6,
    "rotor_diameter_m": 0.3,
    "battery_wh": 99.0,
    "max_airspeed_m_s": 15.0,
    "battery_usable_fraction": 0.8,
    "avionics_power_w": 25.0,
    "figure_of_merit": 0.6,
    "induced_power_factor": 1.2,
    "motor_esc_efficiency": 0.85,
    "thrust_coefficient": 0.015,
    "drag_area_m2": 0.05,
    "hover_power_w": 250.0,
    "cruise_power_w": None,
    "cruise_speed_m_s": 9.0,
}


def test_the_override_table_covers_every_field() -> None:
    assert set(_NEW_VALUES) == set(VehicleProfile.field_names())


@pytest.mark.parametrize("field", sorted(_NEW_VALUES))
def test_any_field_can_be_overridden(field: str) -> None:
    value = _NEW_VALUES[field]
    changed = X500.with_overrides(**{field: value})
    assert getattr(changed, field) == value
    for other in VehicleProfile.field_names():
        if other != field:
            assert getattr(changed, other) == getattr(X500, other), other


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("mass_kg", 0),
        ("mass_kg", -1.0),
        ("mass_kg", "heavy"),
        ("mass_kg", True),
        ("mass_kg", float("nan")),
        ("rotor_count", 0),
        ("rotor_count", 2.5),
        ("battery_usable_fraction", 1.2),
        ("motor_esc_efficiency", 1.1),
        ("figure_of_merit", 0.95),  # above 1/κ
        ("induced_power_factor", 0.9),
        ("drag_area_m2", -0.1),
        ("hover_power_w", 5.0),  # below the avionics power
        ("avionics_power_w", -1.0),
        ("name", ""),
        ("wingspan_m", 2.0),
    ],
)
def test_a_bad_override_names_the_field(field: str, value: object) -> None:
    with pytest.raises(InputError) as err:
        X500.with_overrides(**{field: value})
    assert err.value.key == field
    assert err.value.exit_code == EXIT_INPUT


def test_profiles_are_frozen() -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        X500.mass_kg = 3.0  # type: ignore[misc]


def test_resolve_a_scenario_vehicle_mapping() -> None:
    assert resolve({"profile": "x500"}) == X500
    heavier = resolve({"profile": "x500", "mass_kg": 2, "rotor_count": 4.0})
    assert heavier.mass_kg == 2.0 and heavier.rotor_count == 4
    with pytest.raises(InputError) as err:
        resolve({"profile": "x5000"})
    assert err.value.key == "profile" and "x500" in str(err.value)
    own = resolve(
        {
            "name": "mine",
            "mass_kg": 1.2,
            "rotor_count": 4,
            "rotor_diameter_m": 0.23,
            "battery_wh": 50,
            "max_airspeed_m_s": 14,
        }
    )
    assert own.name == "mine" and own.figure_of_merit == C.FIGURE_OF_MERIT
    with pytest.raises(InputError) as err:
        resolve({"mass_kg": 1.2})
    assert err.value.key == "rotor_count"


# --- wind -----------------------------------------------------------------------------------------


def test_wind_direction_is_meteorological() -> None:
    # from 270° (a westerly) the air moves east; from 0° it moves south
    np.testing.assert_allclose(Wind.uniform(5, 270).velocity_at(10), [5, 0], atol=1e-12)
    np.testing.assert_allclose(Wind.uniform(5, 0).velocity_at(10), [0, -5], atol=1e-12)


def test_wind_profiles_by_height() -> None:
    law = Wind.power_law(6.0, 90, exponent=1 / 7)
    np.testing.assert_allclose(law.speed_at([0, 10, 40]), [0, 6, 6 * 4 ** (1 / 7)], rtol=1e-12)
    table = Wind.from_table([0, 20, 100], [2, 6, 10], 180)
    np.testing.assert_allclose(table.speed_at([0, 10, 60, 500]), [2, 4, 8, 10], rtol=1e-12)
    parsed = Wind.from_mapping({"speed": 6, "from": 90, "profile": {"exponent": 0.2}})
    assert parsed.shear_exponent == 0.2 and parsed.speed_m_s == 6
    parsed = Wind.from_mapping({"from": 90, "profile": {"heights": [0, 50], "speeds": [1, 3]}})
    assert parsed.speeds_m_s == (1, 3)
    for bad, key in [
        ({"speed": -1, "from": 0}, "wind.speed"),
        ({"speed": 3}, "wind.from"),
        ({"speed": 3, "from": 0, "gust": 9}, "wind"),
        ({"from": 0, "profile": {"heights": [10, 5], "speeds": [1, 2]}}, "wind.profile.heights"),
        ({"speed": 3, "from": 0, "profile": {"exponent": 3}}, "wind.exponent"),
    ]:
        with pytest.raises(InputError) as err:
            Wind.from_mapping(bad)
        assert err.value.key == key, bad


def _straight(length_m: float, speed_m_s: float, course_deg: float = 0.0) -> Legs:
    return Legs.from_path(
        [
            [0, 0, 30],
            [
                length_m * math.sin(math.radians(course_deg)),
                length_m * math.cos(math.radians(course_deg)),
                30,
            ],
        ],
        speed_m_s=speed_m_s,
    )


def _p(profile: VehicleProfile, airspeed: float, height_m: float = 30.0) -> float:
    """Level power at ``height_m`` above a sea-level home (the ISA density there)."""
    rho = air_density_kg_m3(height_m)
    return float(electrical_power_w(profile, airspeed, air_density_kg_m3=rho))


def test_head_and_tail_wind_on_a_straight_leg_by_hand() -> None:
    # 2 km north at 12 m/s over the ground (small quad, max airspeed 20 m/s), wind 5 m/s:
    # the ground speed is held, so the time is 2000/12 s; the airspeed is 12 + 5 into a
    # headwind (from 0°, blowing south) and 12 − 5 with a tailwind (from 180°)
    legs, t = _straight(2000, 12.0), 2000 / 12.0
    calm = flight_energy(SMALL, legs)
    head = flight_energy(SMALL, legs, Wind.uniform(5, 0))
    tail = flight_energy(SMALL, legs, Wind.uniform(5, 180))
    for result, airspeed in ((calm, 12.0), (head, 17.0), (tail, 7.0)):
        assert result.time_s == pytest.approx(t, rel=1e-12)
        assert result.energy_wh == pytest.approx(_p(SMALL, airspeed) * t / 3600, rel=1e-9)
        assert float(result.legs.airspeed_m_s[0]) == pytest.approx(airspeed, rel=1e-12)
    assert head.energy_wh > calm.energy_wh > tail.energy_wh
    # the difference, by hand: (P(17) − P(7)) · t
    diff = (_p(SMALL, 17.0) - _p(SMALL, 7.0)) * t / 3600
    assert head.energy_wh - tail.energy_wh == pytest.approx(diff, rel=1e-9)


def test_a_headwind_beyond_the_tilt_limit_slows_the_vehicle_down() -> None:
    # x500 (max airspeed 12 m/s) told to fly 10 m/s into 5 m/s of headwind: it can only
    # make 12 − 5 = 7 m/s over the ground, at 12 m/s through the air
    legs = _straight(2000, 10.0)
    calm = flight_energy(X500, legs)
    head = flight_energy(X500, legs, Wind.uniform(5, 0))
    assert head.time_s == pytest.approx(2000 / 7.0, rel=1e-12) and head.time_s > calm.time_s
    assert head.energy_wh == pytest.approx(_p(X500, 12.0) * 2000 / 7.0 / 3600, rel=1e-9)
    assert float(head.legs.ground_speed_m_s[0]) == pytest.approx(7.0, rel=1e-12)


def test_a_tailwind_lets_a_capped_vehicle_reach_its_commanded_speed() -> None:
    # commanded 15 m/s, but only 12 m/s of airspeed: 12 m/s over the ground in calm air,
    # 15 m/s with 5 m/s behind it (airspeed 10): less time and less energy with the wind
    legs = _straight(2000, 15.0)
    calm = flight_energy(X500, legs)
    tail = flight_energy(X500, legs, Wind.uniform(5, 180))
    assert calm.time_s == pytest.approx(2000 / 12.0) and tail.time_s == pytest.approx(2000 / 15.0)
    assert tail.energy_wh == pytest.approx(_p(X500, 10.0) * 2000 / 15.0 / 3600, rel=1e-9)
    assert tail.time_s < calm.time_s and tail.energy_wh < calm.energy_wh


def test_crosswind_by_hand() -> None:
    # course east (90°), wind from the north at 5 m/s: airspeed sqrt(10² + 5²) at 10 m/s;
    # with an 8 m/s crosswind the x500 (12 m/s max) makes sqrt(12² − 8²) over the ground
    legs = _straight(1000, 10.0, course_deg=90.0)
    side = flight_energy(X500, legs, Wind.uniform(5, 0))
    assert float(side.legs.airspeed_m_s[0]) == pytest.approx(math.hypot(10, 5), rel=1e-12)
    strong = flight_energy(X500, legs, Wind.uniform(8, 0))
    assert float(strong.legs.ground_speed_m_s[0]) == pytest.approx(math.sqrt(144 - 64), rel=1e-9)


def test_a_wind_the_vehicle_cannot_beat_is_an_input_error() -> None:
    with pytest.raises(WindTooStrongError) as err:
        flight_energy(X500, _straight(1000, 10.0), Wind.uniform(13, 0))
    assert err.value.exit_code == EXIT_INPUT and "leg 1" in str(err.value)
    with pytest.raises(WindTooStrongError):  # nor hold position in it
        flight_energy(X500, Legs.hover(60.0, height_m=30), Wind.uniform(13, 0))


def test_hovering_in_wind_costs_less_than_in_calm_air() -> None:
    # holding position in a 6 m/s wind is flying at 6 m/s airspeed (translational lift)
    calm = flight_energy(X500, Legs.hover(600.0, height_m=30))
    windy = flight_energy(X500, Legs.hover(600.0, height_m=30), Wind.uniform(6, 45))
    assert calm.time_s == windy.time_s == 600.0
    assert calm.energy_wh == pytest.approx(_p(X500, 0.0) * 600 / 3600, rel=1e-9)
    assert windy.energy_wh == pytest.approx(_p(X500, 6.0) * 600 / 3600, rel=1e-9)
    assert windy.energy_wh < calm.energy_wh


def test_wind_with_height_reaches_the_leg_at_its_height() -> None:
    low, high = _straight(2000, 12.0), Legs.from_path([[0, 0, 120], [0, 2000, 120]], speed_m_s=12)
    wind = Wind.power_law(5, 0)
    assert flight_energy(SMALL, high, wind).energy_wh > flight_energy(SMALL, low, wind).energy_wh
    expected = 12 + 5 * (120 / 10) ** (1 / 7)
    assert float(flight_energy(SMALL, high, wind).legs.airspeed_m_s[0]) == pytest.approx(expected)


# --- legs and the battery -------------------------------------------------------------------------


def test_legs_from_a_flown_path() -> None:
    # take-off 30 m, 400 m east level, 300 m north climbing 20 m, land from 50 m
    path = [[0, 0, 0], [0, 0, 30], [400, 0, 30], [400, 300, 50], [400, 300, 0]]
    legs = Legs.from_path(path, speed_m_s=10.0, hold_s=[0, 0, 30, 0, 0])
    np.testing.assert_allclose(legs.horizontal_m, [0, 400, 300, 0])
    np.testing.assert_allclose(legs.vertical_m, [30, 0, 20, -50])
    np.testing.assert_allclose(legs.course_deg, [0, 90, 0, 0])
    np.testing.assert_allclose(legs.hold_s, [0, 30, 0, 0])
    # each leg takes max(horizontal / 10, climb / 2.5 or descent / 1.5) by hand
    expected = 30 / 2.5 + 400 / 10 + 30 + max(300 / 10, 20 / 2.5) + 50 / 1.5
    assert still_air_time_s(legs) == pytest.approx(expected)
    result = flight_energy(X500, legs)
    assert result.time_s == pytest.approx(expected)
    np.testing.assert_allclose(result.legs.vertical_speed_m_s, [2.5, 0, 20 / 30, -1.5])
    assert result.energy_wh == pytest.approx(float(result.legs.energy_wh.sum()))
    # a hold at the first point is a leading hover
    first = Legs.from_path(path, speed_m_s=10.0, hold_s=[20, 0, 0, 0, 0])
    assert len(first) == 5 and first.hold_s[0] == 20 and first.horizontal_m[0] == 0


def test_segments_of_speed_and_duration() -> None:
    legs = Legs.from_segments([0, 10, 0, 8], [2.5, 0, 0, -1], [12, 60, 30, 20])
    result = flight_energy(X500, legs)
    np.testing.assert_allclose(result.legs.duration_s, [12, 60, 30, 20])
    p = [float(electrical_power_w(X500, a, b)) for a, b in [(0, 2.5), (10, 0), (0, 0), (8, -1)]]
    expected = (p[0] * 12 + p[1] * 60 + p[2] * 30 + p[3] * 20) / 3600
    assert result.energy_wh == pytest.approx(expected, rel=1e-9)


def test_battery_used_and_the_reserve() -> None:
    # a 10-minute hover of the x500: 208.6 W · 600 s = 34.8 Wh of 74 · 0.95 = 70.3 Wh usable
    result = flight_energy(X500, Legs.hover(600.0, height_m=20))
    used = 100 * _p(X500, 0.0, 20.0) * 600 / 3600 / (74.0 * 0.95)
    assert result.usable_wh == pytest.approx(70.3)
    assert result.battery_used_pct == pytest.approx(used, rel=1e-9)
    assert result.remaining_pct == pytest.approx(100 - used, rel=1e-9)
    assert result.fits(20.0) and result.fits(100 - used - 0.1) and not result.fits(100 - used + 0.1)
    result.require_reserve(20.0)
    long = flight_energy(X500, Legs.hover(1200.0, height_m=20))
    with pytest.raises(EnergyBudgetError) as err:
        long.require_reserve(20.0)
    message = str(err.value)
    assert err.value.exit_code == EXIT_INPUT
    assert f"{long.energy_wh:.1f} Wh" in message and "70.3 Wh usable" in message
    assert "56.2 Wh (80 %)" in message
    report = long.report_fields()
    assert set(report) >= {"flight_time_s", "energy_wh", "battery_used_pct", "legs"}
    assert "min" in long.summary() and "% used" in long.summary()
    with pytest.raises(InputError):
        long.fits(100.0)
