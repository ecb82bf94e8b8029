"""``uavplan fly`` through a seeded fault relay, against a ``mock-vehicle`` process: every
defect of issue 31, the live clearance of issue 32 and the whole-flight check of issue 37.

Each test flies the bundled narrow-gap mission (planned return, margin 10 m) through
:class:`fault_relay.FaultRelay` with one case of :mod:`fly_faults` and asserts what ``fly``
said and did against what the vehicle really did (the relay's truth). The same cases, for
both flavours and three seeds, make the table of ``tools/fly_faults.py``
(docs/reliability.md). Simulated time runs 60 times faster than the wall clock here; nothing
asserts the wall clock.
"""

from __future__ import annotations

import re
import subprocess
from dataclasses import replace
from pathlib import Path

import pytest
from helpers.fly_faults import (
    CASES,
    ROOT,
    SCENARIO,
    UAVPLAN,
    CaseResult,
    VehicleProcess,
    gaps_of,
    other_ground_station,
    plan_for,
    run_case,
)

from uavplan.mission.io import load_mission, save_mission
from uavplan.mission.items import Autopilot, MavCmd
from uavplan.mission.track import Track

pytestmark = [pytest.mark.slow, pytest.mark.timeout(300)]

AP, PX4 = Autopilot.ARDUPILOT, Autopilot.PX4
SPEEDUP = 60.0


@pytest.fixture(scope="module")
def work(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("fly-faults")


def flown(
    case: str, autopilot: Autopilot, work: Path, seed: int = 1, speedup: float = SPEEDUP
) -> CaseResult:
    result = run_case(CASES[case], autopilot, seed, work, speedup=speedup)
    assert result.exit_code is not None, f"fly hung:\n{result.output}"
    assert "Traceback" not in result.output and result.exit_code != 1, result.output
    assert result.held, f"{result.problems}\n{result.output}"
    return result


@pytest.mark.parametrize("autopilot", [AP, PX4], ids=["ardupilot", "px4"])
def test_reordered_and_duplicated_telemetry_is_ordered_by_the_vehicles_clock(
    work: Path, autopilot: Autopilot
) -> None:
    """Issue 31: any reordering crashed fly ("track times must not go backwards", exit 1)."""
    result = flown("reorder", autopilot, work)
    assert result.exit_code == 0 and "mission complete" in result.output
    assert result.track_whole == "yes"


def test_a_lossy_link_still_flies_to_the_end(work: Path) -> None:
    result = flown("lossy", AP, work)
    assert result.exit_code == 0 and result.track_whole == "yes"


@pytest.mark.parametrize("autopilot", [AP, PX4], ids=["ardupilot", "px4"])
def test_a_restarted_vehicle_is_said_and_the_flight_ends_on_its_fresh_state(
    work: Path, autopilot: Autopilot
) -> None:
    """Issue 31: a restarted ArduPilot crashed fly; a restarted PX4 went unnoticed."""
    result = flown("restart", autopilot, work)
    out = result.output
    assert result.exit_code == 4
    assert re.search(r"the vehicle restarted: its clock went back from [\d.]+ s to", out)
    # the state it ends on is the new boot's, asked for again: on the ground, disarmed
    assert re.search(r"after the restart disarmed, in \w+, .*on the ground", out), out
    assert result.track_whole == "yes"
    assert result.noticed_after_s is not None and result.noticed_after_s <= 5.0


def test_a_gap_is_a_gap_and_no_clearance_is_claimed_over_it(work: Path) -> None:
    """Issue 31: a 5 s outage was straight-lined ("0.0 m from obstacle #2" inside an exit-0
    "mission complete")."""
    result = flown("outage-5s", AP, work)
    out = result.output
    assert result.exit_code == 4 and "mission complete on" not in out
    assert re.search(r"nothing heard from the vehicle for 2\.\d s", out)
    assert re.search(r"the link is back after [\d.]+ s of silence", out)
    gap = re.search(r"no telemetry from (\d+) min (\d+) s to (\d+) min (\d+) s", out)
    assert gap, out
    assert re.search(r"not observed in the air: [\d.]+ s", out)
    assert "where it was observed, the track kept the margin" in out
    track = Track.load(work / "outage-5s-ardupilot-1.csv")
    assert len(gaps_of(track)) == 1


def test_after_a_long_gap_the_verdict_rests_on_fresh_state(work: Path) -> None:
    """Issue 31: after a 20 s gap ArduPilot's finished, landed flight was reported as
    "landed and disarmed before the mission was complete ... at mission item 13/41, 40 m
    above home, 11.7 m/s, in the air"."""
    result = flown("outage-20s", AP, work)
    out = result.output
    assert result.exit_code == 4
    assert "landed and disarmed before the mission was complete" not in out
    assert "the mission completed and the vehicle landed" in out
    assert "not observed in the air" in out


@pytest.mark.parametrize(
    ("case", "mode"), [("gcs-hold", "BRAKE"), ("gcs-rtl", "RTL")], ids=["hold", "rtl"]
)
def test_another_ground_stations_mode_is_said_at_once(work: Path, case: str, mode: str) -> None:
    """Issue 31: a hold from a second ground station: fly said nothing and never ended; RTL:
    reported only at touchdown, as "landed early". (20 times the wall clock: the other ground
    station's command must come well before the end of the flight on a loaded machine.)"""
    result = flown(case, AP, work, speedup=20.0)
    out = result.output
    assert result.exit_code in ((4,) if case == "gcs-hold" else (3, 4))
    assert re.search(
        rf"switched to {mode}, commanded by another ground station \(system 255, component \d+\)",
        out,
    ), out
    # two heartbeats (1 s apart) make a change; the rest is the wall clock's latency
    assert result.noticed_after_s is not None and result.noticed_after_s <= 10.0
    if case == "gcs-hold":
        assert "the vehicle stayed in BRAKE for 30 s of its time" in out
    else:
        assert "landed and disarmed before the mission was complete" in out


def test_a_mission_uploaded_by_another_ground_station_ends_the_watch(work: Path) -> None:
    """Issue 31: "mission complete", exit 0, with a 121 m cross-track error."""
    result = flown("gcs-mission", PX4, work, speedup=20.0)
    out = result.output
    assert result.exit_code == 4 and "mission complete on" not in out
    assert re.search(r"another ground station \(system 255, component \d+\) replaced", out)
    assert "the vehicle was given another mission during the flight" in out
    assert result.noticed_after_s is not None and result.noticed_after_s <= 10.0


def test_wind_the_vehicle_cannot_beat_is_said_and_ends_the_watch(work: Path) -> None:
    """Issue 31: with --wind 20,0 fly printed nothing and never ended; the vehicle's
    STATUSTEXT was never shown."""
    result = flown("wind", AP, work)
    out = result.output
    assert result.exit_code == 4
    assert "vehicle (WARNING): Wind: cannot hold the track" in out
    assert "no progress for 60 s of the vehicle's time" in out
    assert "fly switched it to BRAKE (--on-interrupt)" in out
    assert result.final_state.startswith("BRAKE, armed")
    # noticed after the stated time (and what the judgement's 0.1 s of wall clock between
    # looks is at 60 times the wall clock)
    assert result.noticed_after_s is not None and 58.0 <= result.noticed_after_s <= 80.0


def test_the_wrong_scenario_is_refused_before_anything_is_sent(work: Path) -> None:
    """Issue 31: fly env1.plan --scenario midtown-manhattan.yaml flew the whole mission
    and exited 0 with "min clearance 9771468.50 m"."""
    result = flown("wrong-scenario", AP, work)
    assert result.exit_code == 2
    assert "outside scenario midtown-manhattan's area" in result.output
    assert result.final_state == "not contacted"


def test_a_mission_that_breaks_the_margin_against_validate_is_refused(work: Path) -> None:
    """fly --scenario checks the mission as validate does: waypoints moved into the walls
    are exit 3 before the vehicle is contacted (nothing listens on the port given)."""
    plan = load_mission(plan_for(AP, work))
    moved = [
        replace(item, x=item.x + 0.0005) if item.command == MavCmd.NAV_WAYPOINT else item
        for item in plan.items
    ]
    crooked = work / "crooked.plan"
    save_mission(replace(plan, items=tuple(moved)), crooked)
    done = subprocess.run(
        [*UAVPLAN, "fly", str(crooked), "--conn", "udpout:127.0.0.1:9", "--scenario",
         str(SCENARIO), "--heartbeat-timeout", "1"], capture_output=True, text=True,
        timeout=120,
    )  # fmt: skip
    assert done.returncode == 3, done.stderr
    assert "comes within" in done.stderr and "no HEARTBEAT" not in done.stderr


@pytest.mark.parametrize(
    ("autopilot", "busy"), [(AP, True), (PX4, False)], ids=["ardupilot", "px4"]
)
def test_ctrl_c_during_the_upload_cancels_it_and_says_what_the_vehicle_holds(
    work: Path, autopilot: Autopilot, busy: bool
) -> None:
    """Issue 31: fly only said "interrupted", and the ArduPilot vehicle stayed in the
    transfer. ArduPilot ignores the cancel and leaves the transfer 8 s after the last item
    (MissionItemProtocol.cpp); PX4 leaves it on the cancel (mavlink_mission.cpp)."""
    result = flown("ctrl-c-upload", autopilot, work)
    out = result.output
    assert result.exit_code == 130
    assert "cancelled (MISSION_ACK OPERATION_CANCELLED)" in out
    assert re.search(r"holds its previous mission \(0 items\), unchanged", out), out
    waited = re.search(r"busy with the transfer for ([\d.]+) s", out)
    if busy:
        assert waited and 6.0 <= float(waited.group(1)) <= 10.0, out
    else:
        assert waited is None, out


# ---------------------------------------------------------------------------------------------
# Issues 32 and 37: the live clearance, the whole flight


def _lower_rtl_alt_once_armed(address: tuple[str, int], rtl_alt_cm: float) -> str:
    """Another ground station waits until the vehicle is armed, then sets RTL_ALT: the
    parameter the mission relies on, changed behind fly's back after its pre-flight check."""
    import time

    from uavplan.mavlink.messages import Heartbeat
    from uavplan.mavlink.parameters import ParamClient, ParamRequest

    with other_ground_station(address) as link:
        deadline = time.monotonic() + 120.0
        while time.monotonic() < deadline:
            got = link.recv(0.5)
            if got is not None and isinstance(got.message, Heartbeat):
                if got.message.base_mode & 128:  # MAV_MODE_FLAG_SAFETY_ARMED
                    break
        else:
            return "the vehicle never armed"
        (result,) = ParamClient(link).apply([ParamRequest("RTL_ALT", rtl_alt_cm)])
        return result.describe()


@pytest.fixture(scope="module")
def unsafe_return(work: Path) -> tuple[int, str, Path]:
    """paper-env1 planned for ArduPilot with no legal ceiling, so that its mission ends with a
    return to launch at the RTL altitude it relies on (RTL_ALT 23100 cm, above every tower),
    flown with --set-params; once the vehicle is armed another ground station sets RTL_ALT
    back to the firmware's 1500 cm. The return at 15 m flies through obstacles #2, #1 and #0:
    only the live check of the whole flown track can see it."""
    import threading

    scenario = ROOT / "missions" / "paper-env1.yaml"
    plan = work / "env1.plan"
    done = subprocess.run(
        [*UAVPLAN, "plan", str(scenario), "-o", str(plan), "--autopilot", "ardupilot", "-q",
         "--legal-ceiling", "none"],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    vehicle = VehicleProcess(AP, load_mission(plan), SPEEDUP)
    track = work / "env1-flown.csv"
    said: list[str] = []
    try:
        host, port = vehicle.address
        other = threading.Thread(
            target=lambda: said.append(_lower_rtl_alt_once_armed(vehicle.address, 1500.0)),
            daemon=True,
        )
        other.start()
        flown = subprocess.run(
            [*UAVPLAN, "fly", str(plan), "--conn", f"udpout:{host}:{port}", "--scenario",
             str(scenario), "--track", str(track), "--set-params"], capture_output=True,
            text=True, timeout=300,
        )  # fmt: skip
        other.join(30.0)
    finally:
        vehicle.stop()
    assert said and "1500" in said[0], said
    return flown.returncode, flown.stdout + flown.stderr, track


def test_a_return_through_obstacles_is_not_a_success(unsafe_return: tuple[int, str, Path]) -> None:
    """Issue 37: fly exited 0 ("mission complete ... min clearance 10.69 m") because its
    check stopped where the return began."""
    code, out, track = unsafe_return
    assert code == 3, out
    assert "mission complete on" not in out
    assert re.search(r"the flown track breaks the margin: .* the track comes within 0\.00 m", out)
    assert "the mission completed and the vehicle landed" in out
    assert len(Track.load(track)) > 100  # written whole all the same


def test_the_live_clearance_says_each_breach_and_its_worst(
    unsafe_return: tuple[int, str, Path],
) -> None:
    """Issue 32: fly printed 8.3, 9.4 and 9.6 m, then nothing, while the return went
    40 m inside a building."""
    _, out, _ = unsafe_return
    for obstacle in ("#2", "#1", "#0"):
        entered = re.search(rf"the vehicle is [\d.]+ m from obstacle {obstacle} ", out)
        assert entered, (obstacle, out)
        worst = re.search(
            rf"outside the margin again after \d+ s inside it: the closest was ([\d.]+) m from "
            rf"obstacle {obstacle} ",
            out,
        )
        assert worst and float(worst.group(1)) < 1.0, (obstacle, out)
    assert "closer still" in out
