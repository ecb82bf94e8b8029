"""The figures of docs/energy.md, from the bundled vehicle profiles (issue 27).

Prints, as Markdown tables: each profile's predicted hover time against the one its source
publishes; the power-speed table of one profile (default ``x500``); the time and energy of a
straight level leg (default 2 km) at a cruise speed (default 10 m/s, ArduPilot's
WPNAV_SPEED) in calm air and with a 5 m/s head- and tailwind; and the climb/descent powers.
With ``--simulated``: the bundled missions flown by ``simulate`` against their estimates.

    python tools/energy_figures.py
    python tools/energy_figures.py --profile heavy-lift --speed 8 --length 5000
    python tools/energy_figures.py --simulated   # the bundled missions: simulate vs estimate
"""

from __future__ import annotations

import argparse

import numpy as np

from uavplan.airframe import legs, power, profiles
from uavplan.airframe.legs import Legs, flight_energy
from uavplan.airframe.wind import Wind


def hover_table() -> list[str]:
    rows = [
        "| profile | mass kg | rotors | battery Wh | hover W | predicted min | cited min | error |",
        "|---|---:|---|---:|---:|---:|---:|---:|",
    ]
    for name, p in profiles.PROFILES.items():
        predicted = power.hover_time_s(p) / 60
        cited = profiles.CITED_HOVER_TIME_S[name] / 60
        rows.append(
            f"| {name} | {p.mass_kg:g} | {p.rotor_count} × {p.rotor_diameter_m:.3f} m "
            f"| {p.battery_wh:g} | {power.hover_power_w(p):.1f} | {predicted:.1f} | {cited:g} "
            f"| {100 * (predicted / cited - 1):+.1f} % |"
        )
    return rows


def speed_table(p: profiles.VehicleProfile, top_m_s: float) -> list[str]:
    rows = [
        "| airspeed m/s | blade profile W | induced W | parasite W | electrical W | vs hover |",
        "|---:|---:|---:|---:|---:|---:|",
    ]
    speeds = np.arange(0.0, top_m_s + 0.5, 1.0)
    t = power.power_terms(p, speeds)
    hover = float(t.total_w[0])
    for v, b, i, d, e in zip(
        speeds, t.profile_w, t.induced_w, t.parasite_w, t.total_w, strict=True
    ):
        rows.append(
            f"| {v:g} | {b:.1f} | {i:.1f} | {d:.1f} | {e:.1f} | {100 * (e / hover - 1):+.1f} % |"
        )
    v_min = power.minimum_power_speed_m_s(p)
    rows.append("")
    least = float(power.electrical_power_w(p, v_min))
    rows.append(
        f"Least power at {v_min:.1f} m/s: {least:.1f} W (max airspeed {p.max_airspeed_m_s:g} m/s)."
    )
    return rows


def vertical_table(p: profiles.VehicleProfile) -> list[str]:
    rows = ["| vertical m/s | at 0 m/s airspeed W | at 10 m/s airspeed W |", "|---:|---:|---:|"]
    for vz in (-3.0, -1.5, -0.5, 0.0, 1.0, 2.5, 5.0):
        a = float(power.electrical_power_w(p, 0.0, vz))
        b = float(power.electrical_power_w(p, 10.0, vz))
        rows.append(f"| {vz:+g} | {a:.1f} | {b:.1f} |")
    return rows


def leg_table(p: profiles.VehicleProfile, length_m: float, speed_m_s: float) -> list[str]:
    rows = [
        "| wind | ground m/s | airspeed m/s | time s | energy Wh | battery % |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    legs = Legs.from_path([[0, 0, 30], [0, length_m, 30]], speed_m_s=speed_m_s)
    for label, wind in (
        ("calm", Wind.calm()),
        ("5 m/s headwind", Wind.uniform(5, 0)),
        ("5 m/s tailwind", Wind.uniform(5, 180)),
    ):
        r = flight_energy(p, legs, wind)
        rows.append(
            f"| {label} | {float(r.legs.ground_speed_m_s[0]):.1f} "
            f"| {float(r.legs.airspeed_m_s[0]):.1f} | {r.time_s:.0f} | {r.energy_wh:.2f} "
            f"| {r.battery_used_pct:.1f} |"
        )
    return rows


def simulated_table() -> list[str]:
    """Each flat bundled scenario planned (its own seed), its mission flown by ``simulate``
    (calm air, the x500) and estimated: what the simulation adds (accelerations, corners)."""
    import tempfile
    from pathlib import Path

    from uavplan.app.check import read_mission_flight
    from uavplan.autopilot.simulate import simulate
    from uavplan.estimate import estimate_mission
    from uavplan.mission.io import mission_text
    from uavplan.planning import mission_for, plan_route
    from uavplan.scenario import load_scenario

    rows = [
        "| scenario | autopilot | end | estimate s | simulated s | estimate Wh | simulated Wh "
        "| simulated − estimate |",
        "|---|---|---|---:|---:|---:|---:|---:|",
    ]
    root = Path(__file__).resolve().parent.parent / "missions"
    for path in sorted(root.glob("*.yaml")):
        scn = load_scenario(path)
        if scn.terrain is not None:
            continue  # simulate flies over flat ground unless given the DEM's ground_z
        result = plan_route(scn, threads=1)
        if result.route is None:
            continue
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "m.plan"
            out.write_text(mission_text(mission_for(scn, result.route), str(out)))
            plan, flight = read_mission_flight(str(out), scn)
        est = estimate_mission(scn, plan, flight).energy
        track = simulate(plan)
        rows.append(
            f"| {path.stem} | {plan.autopilot.name.lower()} | {scn.mission.end} "
            f"| {est.time_s:.0f} | {track.flight_time_s:.0f} | {est.energy_wh:.2f} "
            f"| {track.energy_wh:.2f} | {100 * (track.energy_wh / est.energy_wh - 1):+.1f} % |"
        )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--profile", default="x500", choices=list(profiles.PROFILES))
    ap.add_argument("--speed", type=float, default=10.0, help="cruise ground speed (m/s)")
    ap.add_argument("--length", type=float, default=2000.0, help="leg length (m)")
    ap.add_argument(
        "--simulated",
        action="store_true",
        help="only the table of the bundled missions simulated against their estimates",
    )
    args = ap.parse_args()
    if args.simulated:
        print("\n".join(simulated_table()))
        return
    p = profiles.get(args.profile)
    out = ["## Hover time: predicted and published", "", *hover_table(), ""]
    out += [f"## {args.profile}: power against airspeed (sea level, calm)", ""]
    out += [*speed_table(p, p.max_airspeed_m_s), ""]
    out += [f"## {args.profile}: climb and descent", "", *vertical_table(p), ""]
    title = f"## {args.profile}: a {args.length:g} m level leg at {args.speed:g} m/s, 30 m up"
    out += [title, "", *leg_table(p, args.length, args.speed)]
    out += ["", f"(reserve default {legs.DEFAULT_RESERVE_PCT:g} %)"]
    print("\n".join(out))


if __name__ == "__main__":
    main()
