"""``uavplan upload / download / clear / mock-vehicle``: exit codes, messages, files, signals."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner, Result
from helpers.mavlink_helpers import client_conn, running_mock, synthetic_mission

from uavplan.cli import main
from uavplan.mavlink.messages import MissionResult
from uavplan.mavlink.stored_form import stored_form
from uavplan.mavlink.transfer import compare_items, plan_wire_items
from uavplan.mission.io import load_mission, save_mission
from uavplan.mission.items import Autopilot, MissionPlan, MissionType, items_equal
from uavplan.sim.faults import MISSION_PROTOCOL_MESSAGES, Faults
from uavplan.sim.vehicle import SimConfig

pytestmark = pytest.mark.timeout(60)


def run(*args: str) -> Result:
    return CliRunner().invoke(main, list(args), catch_exceptions=False)


@pytest.fixture
def plan_file(tmp_path: Path) -> tuple[Path, MissionPlan]:
    plan = synthetic_mission(45, seed=91, with_fence=True, with_rally=True)
    path = tmp_path / "mission.plan"
    save_mission(plan, path)
    return path, load_mission(path)


def test_upload_a_plan_with_fence_and_rally(plan_file: tuple[Path, MissionPlan]) -> None:
    path, plan = plan_file
    with running_mock() as vehicle:
        result = run("upload", str(path), "--conn", client_conn(vehicle))
        assert result.exit_code == 0, result.output
        for mission_type in (MissionType.MISSION, MissionType.FENCE, MissionType.RALLY):
            expected = plan_wire_items(plan, mission_type, Autopilot.PX4)
            stored = vehicle.items(mission_type)
            assert compare_items(expected, stored, mission_type, Autopilot.PX4) is None
    assert re.search(
        r"uploaded 48 mission items, 9 fence items, 2 rally points to system 1 \(px4\) on "
        r"udpout:127\.0\.0\.1:\d+; verified by read-back",
        result.stdout,
    )


def test_upload_waypoints_to_ardupilot_with_mavsdk_url(tmp_path: Path) -> None:
    plan = synthetic_mission(30, seed=92, autopilot=Autopilot.ARDUPILOT)
    path = tmp_path / "mission.waypoints"
    save_mission(plan, path)
    with running_mock(SimConfig(autopilot=Autopilot.ARDUPILOT)) as vehicle:
        url = client_conn(vehicle).replace("udpout:", "udpout://")
        result = run("upload", str(path), "--conn", url, "--no-verify", "--target-system", "1")
        assert result.exit_code == 0, result.output
        assert "not verified" in result.stdout
        assert len(vehicle.items(MissionType.MISSION)) == len(plan.items) + 1


def test_upload_and_download_count_an_ardupilot_mission_the_same_way(tmp_path: Path) -> None:
    """ArduPilot keeps home as mission item 0: upload used to count it (41 items) and
    download not (40) for the same mission. Both now count the plan's items and name the
    home."""
    plan = synthetic_mission(30, seed=94, autopilot=Autopilot.ARDUPILOT)
    path = tmp_path / "mission.waypoints"
    save_mission(plan, path)
    n = len(load_mission(path).items)
    with running_mock(SimConfig(autopilot=Autopilot.ARDUPILOT)) as vehicle:
        up = run("upload", str(path), "--conn", client_conn(vehicle))
        back = tmp_path / "back.waypoints"
        down = run("download", "--conn", client_conn(vehicle), "-o", str(back))
        stored = len(vehicle.items(MissionType.MISSION))
    assert up.exit_code == 0 and down.exit_code == 0, up.output + down.output
    assert stored == n + 1  # the home on the vehicle
    home = "(and home, ArduPilot's mission item 0)"
    assert f"uploaded {n} mission items {home} to system 1" in up.stdout
    assert f"downloaded {n} mission items {home} from system 1" in down.stdout
    assert len(load_mission(back).items) == n


def test_a_download_that_fails_leaves_no_file(tmp_path: Path) -> None:
    out = tmp_path / "onboard.plan"
    with running_mock(SimConfig(send_heartbeats=False)) as vehicle:
        result = run(
            "download", "--conn", client_conn(vehicle), "-o", str(out), "--heartbeat-timeout",
            "0.3",
        )  # fmt: skip
    assert result.exit_code == 4, result.output
    assert list(tmp_path.iterdir()) == []


def test_download_into_a_missing_folder_is_exit_2_before_connecting(tmp_path: Path) -> None:
    """The output is checked first: no vehicle is needed to be told."""
    result = run("download", "--conn", "udpout:127.0.0.1:9", "-o", str(tmp_path / "no" / "x.plan"))
    assert result.exit_code == 2, result.output
    assert "does not exist" in result.stderr and "HEARTBEAT" not in result.stderr


@pytest.mark.parametrize("command", ["upload", "convert", "mock-vehicle"])
@pytest.mark.parametrize("suffix", [".geojson", ".kml", ".xyz"])
def test_mission_readers_list_only_the_formats_they_read(
    tmp_path: Path, command: str, suffix: str
) -> None:
    """upload, convert and mock-vehicle --mission listed .geojson and .kml among the files
    to give them, then refused those: a map export is written, not read."""
    source = tmp_path / f"m{suffix}"
    source.write_text("{}")
    args = {
        "upload": ["upload", str(source), "--conn", "udpout:127.0.0.1:9"],
        "convert": ["convert", str(source), str(tmp_path / "o.plan")],
        "mock-vehicle": ["mock-vehicle", "--conn", "udpin:127.0.0.1:0", "--mission", str(source)],
    }[command]
    result = run(*args)
    assert result.exit_code == 2, result.output
    line = result.stderr.strip()
    assert line.startswith(f"error: {source}") and len(line.splitlines()) == 1
    listed = line.rsplit("one of ", 1)[1]
    assert ".plan" in listed and ".waypoints" in listed
    assert ".geojson" not in listed and ".kml" not in listed
    if suffix != ".xyz":
        assert "map export" in line


@pytest.mark.parametrize("suffix", [".plan", ".waypoints"])
def test_download_into_a_file(suffix: str, tmp_path: Path) -> None:
    plan = synthetic_mission(
        33, seed=93, autopilot=Autopilot.ARDUPILOT, with_fence=True, with_rally=True
    )
    out = tmp_path / f"back{suffix}"
    with running_mock(SimConfig(autopilot=Autopilot.ARDUPILOT)) as vehicle:
        for mission_type in (MissionType.MISSION, MissionType.FENCE, MissionType.RALLY):
            vehicle.preload(mission_type, plan_wire_items(plan, mission_type, Autopilot.ARDUPILOT))
        result = run("download", "--conn", client_conn(vehicle), "-o", str(out))
    assert result.exit_code == 0, result.output
    back = load_mission(out)
    assert back.autopilot == Autopilot.ARDUPILOT
    assert back.home is not None and abs(back.home.lat_deg - plan.home.lat_deg) < 1e-7  # type: ignore[union-attr]
    assert len(back.items) == len(plan.items)
    kept = [stored_form(i, Autopilot.ARDUPILOT, MissionType.MISSION) for i in plan.items]
    assert all(items_equal(a, b) for a, b in zip(kept, back.items, strict=True))
    if suffix == ".plan":
        assert len(back.rally) == 2 and len(back.fence.polygons) == 2
        assert f"{len(plan.items)} mission items, 9 fence items, 2 rally points" in result.stdout
    else:
        assert back.fence.is_empty and back.rally == ()


def test_clear_all(plan_file: tuple[Path, MissionPlan]) -> None:
    path, _ = plan_file
    with running_mock() as vehicle:
        assert run("upload", str(path), "--conn", client_conn(vehicle)).exit_code == 0
        result = run("clear", "--conn", client_conn(vehicle), "--type", "all")
        assert result.exit_code == 0, result.output
        assert "cleared mission, fence, rally" in result.stdout
        for mission_type in (MissionType.MISSION, MissionType.FENCE, MissionType.RALLY):
            assert vehicle.items(mission_type) == []


@pytest.mark.slow
def test_no_heartbeat_exits_4_with_one_clear_line(plan_file: tuple[Path, MissionPlan]) -> None:
    path, _ = plan_file
    with running_mock(SimConfig(send_heartbeats=False)) as vehicle:
        result = run(
            "upload", str(path), "--conn", client_conn(vehicle), "--heartbeat-timeout", "0.5"
        )
    assert result.exit_code == 4
    assert result.stderr.startswith("error: connect: waiting for HEARTBEAT: no HEARTBEAT within")
    assert "Traceback" not in result.output and len(result.stderr.splitlines()) == 1


@pytest.mark.slow
def test_total_loss_exits_4_in_bounded_time_naming_the_step(
    plan_file: tuple[Path, MissionPlan],
) -> None:
    path, _ = plan_file
    config = SimConfig(faults=Faults(drop_rate=1.0, only=MISSION_PROTOCOL_MESSAGES))
    with running_mock(config) as vehicle:
        result = run(
            "upload",
            str(path),
            "--conn",
            client_conn(vehicle),
            "--timeout",
            "0.3",
            "--retries",
            "2",
        )
    assert result.exit_code == 4
    assert result.stderr.startswith("error: upload mission: MISSION_COUNT: no MISSION_REQUEST")


def test_rejected_item_exits_4_naming_the_item_and_result(
    plan_file: tuple[Path, MissionPlan],
) -> None:
    path, _ = plan_file
    faults = Faults(reject_at_seq=5, reject_result=MissionResult.INVALID_PARAM4)
    with running_mock(SimConfig(faults=faults)) as vehicle:
        result = run("upload", str(path), "--conn", client_conn(vehicle))
    assert result.exit_code == 4
    line = result.stderr.strip()
    assert line.startswith("error: upload mission: MISSION_ITEM_INT seq 5: item 5:")
    assert "MAV_MISSION_INVALID_PARAM4" in line and "param4 = " in line


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["upload", "{missing}", "--conn", "udpout:127.0.0.1:9"], "cannot read"),
        (["upload", "{plan}", "--conn", "bogus"], "connection string 'bogus'"),
        (["download", "--conn", "udpout:127.0.0.1:9", "-o", "{tmp}/x.xyz"], "unknown mission"),
        (["mock-vehicle", "--conn", "udpin:127.0.0.1:0", "--loss", "1.5"], "1.5"),
        (["mock-vehicle", "--conn", "udpin:127.0.0.1:0", "--home", "47,8"], "LAT,LON,ALT"),
        (["mock-vehicle", "--conn", "udpin:127.0.0.1:0", "--wind", "3"], "E,N"),
        (["mock-vehicle", "--conn", "udpin:127.0.0.1:0", "--param", "NOPE=1"], "'NOPE'"),
        (["mock-vehicle", "--conn", "udpin:127.0.0.1:0", "--param", "WPNAV_SPEED"], "NAME=VALUE"),
        (
            ["mock-vehicle", "--conn", "udpin:127.0.0.1:0", "--param", "MPC_XY_CRUISE=99"],
            "maximum",
        ),
        (["mock-vehicle", "--conn", "udpin:127.0.0.1:0", "--speedup", "0"], "--speedup"),
    ],
)
def test_bad_input_exits_2(
    args: list[str], message: str, plan_file: tuple[Path, MissionPlan], tmp_path: Path
) -> None:
    path, _ = plan_file
    filled = [a.format(missing=tmp_path / "nope.plan", plan=path, tmp=tmp_path) for a in args]
    result = run(*filled)
    assert result.exit_code == 2, result.output
    assert message in result.output
    assert "Traceback" not in result.output


def test_progress_is_drawn_per_phase_on_a_terminal(
    plan_file: tuple[Path, MissionPlan], monkeypatch: pytest.MonkeyPatch
) -> None:
    import uavplan.cli.common as common

    monkeypatch.setattr(common, "show_progress", lambda quiet: not quiet)
    path, _ = plan_file
    with running_mock() as vehicle:
        loud = run("upload", str(path), "--conn", client_conn(vehicle))
        quiet = run("upload", str(path), "--conn", client_conn(vehicle), "--quiet")
    assert loud.exit_code == 0 and quiet.exit_code == 0
    for phase in ("upload mission", "upload fence", "upload rally", "verify mission"):
        assert phase in loud.stderr
    assert "upload mission" not in quiet.stderr


# ---------------------------------------------------------------------------------------------
# The mock vehicle as a process: a real endpoint other programs use, stopped by signals


#: the ``uavplan`` console script, without relying on the venv's bin/ being on PATH
UAVPLAN = [sys.executable, "-c", "from uavplan.cli import main; main()"]


def _start_mock(*extra: str) -> tuple[subprocess.Popen[str], str]:
    proc = subprocess.Popen(
        [*UAVPLAN, "mock-vehicle", "--conn", "udpin:127.0.0.1:0", *extra],
        stderr=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    assert proc.stderr is not None
    line = proc.stderr.readline()
    match = re.search(r"serving on udpin:127\.0\.0\.1:(\d+)", line)
    assert match, line
    return proc, f"udpout:127.0.0.1:{match.group(1)}"


@pytest.mark.slow
def test_mock_vehicle_process_serves_and_stops_on_sigint(
    plan_file: tuple[Path, MissionPlan], tmp_path: Path
) -> None:
    path, plan = plan_file
    proc, conn = _start_mock("--autopilot", "ardupilot", "--loss", "0.05", "--seed", "7")
    try:
        upload = subprocess.run(
            [*UAVPLAN, "upload", str(path), "--conn", conn],
            capture_output=True,
            text=True,
            timeout=30,
        )
        assert upload.returncode == 0, upload.stderr
        out = tmp_path / "back.plan"
        assert run("download", "--conn", conn, "-o", str(out)).exit_code == 0
        assert len(load_mission(out).items) == len(plan.items)
    finally:
        stderr = _stop(proc, signal.SIGINT)
    assert proc.returncode == 0
    assert "mock vehicle stopped: 3 uploads accepted" in stderr
    assert "Traceback" not in stderr


def test_mock_vehicle_process_stops_cleanly_on_sigterm() -> None:
    proc, _conn = _start_mock()
    stderr = _stop(proc, signal.SIGTERM)  # bounded: _stop waits with a timeout
    assert proc.returncode == 0
    assert "mock vehicle stopped: 0 uploads accepted" in stderr


def _stop(proc: subprocess.Popen[str], signum: signal.Signals) -> str:
    proc.send_signal(signum)
    try:
        _, stderr = proc.communicate(timeout=5)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    return stderr
