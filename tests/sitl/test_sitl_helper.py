"""The SITL helper itself (tests/helpers/sitl.py), without the firmware: where it looks, what a
missing binary does (a skip naming the path and the variable; a failure in CI), and that two
runs never share an instance."""

from __future__ import annotations

import socket
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from helpers import sitl

from uavplan.flavour import Autopilot


def _run_need(tmp_path: Path, **env: str) -> subprocess.CompletedProcess[str]:
    test = tmp_path / "test_need.py"
    test.write_text(
        textwrap.dedent(
            """
            from helpers import sitl
            from uavplan.flavour import Autopilot

            def test_it():
                sitl.need(Autopilot.ARDUPILOT)
            """
        )
    )
    tests = Path(__file__).resolve().parents[1]
    return subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-rs", "-p", "no:cacheprovider", str(test)],
        capture_output=True,
        text=True,
        env={"PYTHONPATH": str(tests), "PATH": "/usr/bin:/bin", **env},
        cwd=tmp_path,
        timeout=120,
    )


def test_a_missing_firmware_skips_naming_the_path_and_the_variable(tmp_path: Path) -> None:
    empty = tmp_path / "nothing"
    empty.mkdir()
    done = _run_need(tmp_path, UAVPLAN_SITL_DIR=str(empty))
    assert done.returncode == 0, done.stdout
    assert "1 skipped" in done.stdout
    assert f"no ardupilot SITL binary at {empty}/ardupilot/arducopter" in done.stdout
    assert "UAVPLAN_SITL_DIR" in done.stdout


def test_in_ci_a_missing_firmware_fails(tmp_path: Path) -> None:
    empty = tmp_path / "nothing"
    empty.mkdir()
    done = _run_need(tmp_path, UAVPLAN_SITL_DIR=str(empty), UAVPLAN_REQUIRE_SITL="1")
    assert done.returncode == 1, done.stdout
    assert "1 failed" in done.stdout and "UAVPLAN_REQUIRE_SITL=1" in done.stdout


def test_the_default_is_shared_sitl_beside_the_repository(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(sitl.SITL_DIR_ENV, raising=False)
    root = Path(__file__).resolve().parents[2]
    assert sitl.sitl_dir() == (root.parent / "shared" / "sitl").resolve()
    assert sitl.arducopter_binary() == sitl.sitl_dir() / "ardupilot" / "arducopter"
    assert sitl.px4_binary() == sitl.sitl_dir() / "px4" / "bin" / "px4"


def test_two_runs_never_share_an_instance_and_a_busy_port_is_passed_over() -> None:
    with (
        sitl._instance("selftest", range(40, 44), lambda n: []) as first,
        sitl._instance("selftest", range(40, 44), lambda n: []) as second,
    ):
        assert first != second
    # an instance whose ports another program holds is not taken
    with socket.socket() as busy:
        busy.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        busy.bind(("0.0.0.0", 0))
        busy.listen()
        port = busy.getsockname()[1]
        ports = {40: [(port, socket.SOCK_STREAM)], 41: []}
        with sitl._instance("selftest2", range(40, 42), lambda n: ports[n]) as n:
            assert n == 41


def test_an_int_parameter_of_px4_is_read_as_the_firmware_sends_it() -> None:
    """PX4 sends integer parameters bytewise (the float's bytes are the int32's)."""
    import struct
    from types import SimpleNamespace

    observer = sitl.Observer.__new__(sitl.Observer)
    observer.autopilot = Autopilot.PX4
    observer.seen = sitl.Observation()
    observer.target_system = 1
    import threading

    observer._lock = threading.Lock()
    raw = struct.unpack("<f", struct.pack("<i", 45))[0]
    message = SimpleNamespace(
        get_type=lambda: "PARAM_VALUE", param_id="RTL_CONE_ANG", param_value=raw, param_type=6
    )
    observer._take(message)
    assert observer.seen.params["RTL_CONE_ANG"] == 45.0
