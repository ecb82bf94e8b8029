"""Real autopilot firmware as a test vehicle: ArduPilot Copter SITL and PX4 SIH.

A helper for tests and tools, never part of the product. It starts the firmware standing at
a given home with a chosen speed-up on ports no other run uses, waits until the vehicle is
ready to arm, watches it through a link of its own (an observer independent of uavplan), and
stops it cleanly.

Where the firmware is
    ``UAVPLAN_SITL_DIR`` (default ``../shared/sitl`` from the repository root) holds
    ``ardupilot/arducopter`` with ``ardupilot/copter.parm``, and ``px4/bin/px4`` with
    ``px4/etc/`` (shared/sitl/README.md says how each was built). Where a binary is missing
    the tests that need it skip, naming the path and the variable; with
    ``UAVPLAN_REQUIRE_SITL=1`` (CI) they fail instead.

Ports
    ArduPilot: ``-I N`` puts SERIAL0 on TCP 5760+10N, SERIAL1 on 5762+10N, SERIAL2 on
    5763+10N and the RC input on UDP 5501+10N (libraries/AP_HAL_SITL/SITL_cmdline.cpp,
    ``_base_port += instance*10`` and the other ports alike). PX4: ``px4 -i N`` offsets its
    MAVLink ports (etc/init.d-posix/px4-rc.mavlink: the offboard link sends from 14580+N to
    14540+N, the GCS link listens on 18570+N) and its daemon socket. An instance is taken
    under a lock file (so runs of this helper never share one) after checking that its ports
    are free (so a SITL started by hand is not disturbed); instances 0 and 1 are left to
    hand-started runs.

Readiness (shared/sitl/README.md)
    SYS_STATUS's pre-arm check bit (MAV_SYS_STATUS_PREARM_CHECK) healthy, GPS_RAW_INT with a
    3-D fix, and a home position: ArduPilot's EKF_STATUS_REPORT with an absolute horizontal
    position and no constant-position mode; PX4's HOME_POSITION (its commander sets home once
    the global position is valid).

The observer
    ArduPilot waits for a connection on SERIAL0 before its simulation starts: the observer
    holds SERIAL0 and ``uavplan`` connects to SERIAL1 (``tcp:127.0.0.1:5762+10N``). PX4: the
    observer talks to the GCS link (``udpout`` to 18570+N; PX4 answers the address it hears
    from) and ``uavplan`` listens where the offboard link sends (``udpin:127.0.0.1:14540+N``),
    as docs/flying.md tells a user to. The observer records every position, mode, STATUSTEXT
    and the vehicle's own clock (``time_boot_ms``: simulated milliseconds), so tests assert
    on simulated time only.
"""

from __future__ import annotations

import contextlib
import fcntl
import math
import os
import shutil
import signal
import socket
import struct
import subprocess
import tempfile
import threading
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from uavplan.flavour import Autopilot
from uavplan.geo import GeoPoint

ROOT = Path(__file__).resolve().parents[2]
SITL_DIR_ENV = "UAVPLAN_SITL_DIR"
REQUIRE_ENV = "UAVPLAN_REQUIRE_SITL"
DEFAULT_SITL_DIR = ROOT.parent / "shared" / "sitl"

#: MAV_SYS_STATUS_PREARM_CHECK in SYS_STATUS's sensor bitmasks
PREARM_CHECK = 0x10000000
#: EKF_STATUS_REPORT flags: EKF_POS_HORIZ_ABS, EKF_CONST_POS_MODE
EKF_POS_HORIZ_ABS = 0x10
EKF_CONST_POS_MODE = 0x80
#: ArduPilot's TCP / UDP ports for instance N: base + 10 N
AP_SERIAL0, AP_SERIAL1, AP_SERIAL2, AP_RC_IN = 5760, 5762, 5763, 5501
#: PX4's UDP ports for instance N: base + N (etc/init.d-posix/px4-rc.mavlink)
PX4_OFFBOARD_REMOTE, PX4_OFFBOARD_LOCAL, PX4_GCS_LOCAL = 14540, 14580, 18570
PX4_OTHER_LOCAL = (14280, 13030, 19450)  # payload, gimbal and SIH display links
#: instances this helper may use (0 and 1 are left to SITL runs started by hand)
AP_INSTANCES = range(2, 60)
PX4_INSTANCES = range(2, 10)  # px4-rc.mavlink shares 14549 from instance 10 on
#: what the observer asks for (Hz): SYS_STATUS, GPS_RAW_INT, GLOBAL_POSITION_INT,
#: EKF_STATUS_REPORT, HOME_POSITION, SYSTEM_TIME, MISSION_CURRENT, EXTENDED_SYS_STATE
STREAMS = {1: 2.0, 24: 2.0, 33: 10.0, 193: 2.0, 242: 0.5, 2: 1.0, 42: 5.0, 245: 5.0}
#: PX4's GCS link streams these at up to 50 Hz by default (etc/init.d-posix/px4-rc.mavlink),
#: hundreds a second at a speed-up of 8: the observer turns them off (ATTITUDE,
#: ATTITUDE_QUATERNION, LOCAL_POSITION_NED, SERVO_OUTPUT_RAW, RC_CHANNELS, ATTITUDE_TARGET,
#: POSITION_TARGET_LOCAL_NED, OPTICAL_FLOW_RAD)
PX4_QUIET = {30: -1.0, 31: -1.0, 32: -1.0, 36: -1.0, 65: -1.0, 83: -1.0, 85: -1.0, 106: -1.0}
_PX4_INT_TYPES = frozenset({1, 2, 3, 4, 5, 6})
#: a "port" that is never free (an instance known to be in use)
_NEVER = -1


#: parameters the firmware is started with for flights compared with the model. PX4 SIH's
#: airframe: its linear drag (SIH_KDV 1 N·s/m on a 1 kg quad) caps the speed at
#: g·tan(MPC_TILTMAX_AIR)/SIH_KDV = 9.8 m/s, below the missions' 12 m/s; a vehicle that
#: cannot reach the commanded speed flies slower than PX4's guidance asks, which no guidance
#: model predicts (it knows no airframe's drag). Half the drag lifts the cap to 19.6 m/s.
FLIGHT_PARAMS: dict[Autopilot, dict[str, float]] = {
    Autopilot.ARDUPILOT: {},
    Autopilot.PX4: {"SIH_KDV": 0.5},
}


def sitl_dir() -> Path:
    return Path(os.environ.get(SITL_DIR_ENV) or DEFAULT_SITL_DIR).resolve()


def required() -> bool:
    return os.environ.get(REQUIRE_ENV, "") not in ("", "0")


def arducopter_binary() -> Path:
    return sitl_dir() / "ardupilot" / "arducopter"


def px4_binary() -> Path:
    return sitl_dir() / "px4" / "bin" / "px4"


def missing(autopilot: Autopilot) -> str | None:
    """Why the firmware of ``autopilot`` cannot run here, or None."""
    path = arducopter_binary() if autopilot == Autopilot.ARDUPILOT else px4_binary()
    if not (path.is_file() and os.access(path, os.X_OK)):
        return (
            f"no {autopilot.label} SITL binary at {path} (set {SITL_DIR_ENV} to the directory "
            f"holding ardupilot/arducopter and px4/bin/px4)"
        )
    return None


def need(autopilot: Autopilot) -> None:
    """Skip the calling test (fail it with ``UAVPLAN_REQUIRE_SITL=1``) without the firmware."""
    why = missing(autopilot)
    if why is None:
        return
    if required():
        pytest.fail(f"{why}; {REQUIRE_ENV}=1 makes this a failure", pytrace=False)
    pytest.skip(why)


# ---------------------------------------------------------------------------------------------
# Instances and ports


def _port_free(port: int, kind: int) -> bool:
    if kind == _NEVER:
        return False
    with socket.socket(socket.AF_INET, kind) as sock:
        if kind == socket.SOCK_STREAM:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind(("0.0.0.0", port))
        except OSError:
            return False
    return True


@contextlib.contextmanager
def _instance(kind: str, candidates: range, ports: Callable[[int], list[tuple[int, int]]]):
    """Hold the lock of a free instance of ``kind`` whose ``ports(n)`` are all free."""
    locks = Path(tempfile.gettempdir()) / "uavplan-sitl-locks"
    locks.mkdir(exist_ok=True)
    for n in candidates:
        handle = open(locks / f"{kind}-{n}.lock", "w")
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.close()
            continue
        if all(_port_free(port, sock) for port, sock in ports(n)):
            try:
                yield n
            finally:
                handle.close()
            return
        handle.close()
    raise RuntimeError(f"no free {kind} SITL instance in {candidates}")


def _ap_ports(n: int) -> list[tuple[int, int]]:
    tcp, udp = socket.SOCK_STREAM, socket.SOCK_DGRAM
    k = 10 * n
    return [
        (AP_SERIAL0 + k, tcp),
        (AP_SERIAL1 + k, tcp),
        (AP_SERIAL2 + k, tcp),
        (AP_RC_IN + k, udp),
    ]


def _px4_ports(n: int) -> list[tuple[int, int]]:
    udp = socket.SOCK_DGRAM
    ports = [PX4_OFFBOARD_REMOTE, PX4_OFFBOARD_LOCAL, PX4_GCS_LOCAL, *PX4_OTHER_LOCAL]
    taken = Path(tempfile.gettempdir()) / f"px4-sock-{n}"
    if taken.exists() and _px4_socket_alive(taken):
        return [(0, _NEVER)]  # a PX4 of this instance runs
    return [(base + n, udp) for base in ports]


def _px4_socket_alive(path: Path) -> bool:
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
        try:
            sock.connect(str(path))
        except OSError:
            return False
    return True


# ---------------------------------------------------------------------------------------------
# The observer: an independent MAVLink link to the vehicle


@dataclass(frozen=True)
class Sample:
    """One GLOBAL_POSITION_INT as the observer received it."""

    time_s: float  # the vehicle's clock (time_boot_ms, simulated)
    lat_deg: float
    lon_deg: float
    alt_amsl_m: float
    relative_alt_m: float
    vx_m_s: float
    vy_m_s: float
    vz_m_s: float


@dataclass
class Observation:
    samples: list[Sample] = field(default_factory=list)
    texts: list[tuple[float, str]] = field(default_factory=list)
    modes: list[tuple[float, int, bool]] = field(default_factory=list)  # (t, custom_mode, armed)
    boot_s: float = 0.0
    prearm_ok: bool = False
    fix_type: int = 0
    ekf_flags: int = 0
    home: GeoPoint | None = None
    params: dict[str, float] = field(default_factory=dict)
    #: (time, seq) at each change of MISSION_CURRENT's seq
    current: list[tuple[float, int]] = field(default_factory=list)
    #: (time, landed state) at each change of EXTENDED_SYS_STATE's (1 ground, 2 air, ...)
    landed: list[tuple[float, int]] = field(default_factory=list)


class Observer:
    """A pymavlink link to the vehicle, read in a thread; what it saw in :attr:`seen`."""

    def __init__(self, conn: str, autopilot: Autopilot) -> None:
        from pymavlink import mavutil

        self.autopilot = autopilot
        self.seen = Observation()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self.link = mavutil.mavlink_connection(
            conn, source_system=254, source_component=190, autoreconnect=False
        )
        self._thread = threading.Thread(target=self._run, name="sitl-observer", daemon=True)
        self.target_system = 1
        self._thread.start()

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        with contextlib.suppress(Exception):
            self.link.close()

    def _run(self) -> None:
        last_hello = 0.0
        while not self._stop.is_set():
            now = time.monotonic()
            if now - last_hello > 1.0:
                last_hello = now
                with contextlib.suppress(OSError):
                    # a ground station's heartbeat: PX4 learns our address from it
                    self.link.mav.heartbeat_send(6, 8, 0, 0, 0)
            try:
                msg = self.link.recv_match(blocking=True, timeout=0.2)
            except (OSError, ConnectionError):
                if self._stop.is_set():
                    return
                time.sleep(0.1)
                continue
            if msg is None:
                continue
            self._take(msg)

    def _take(self, msg) -> None:
        kind = msg.get_type()
        with self._lock:
            seen = self.seen
            if hasattr(msg, "time_boot_ms"):
                seen.boot_s = max(seen.boot_s, msg.time_boot_ms / 1000.0)
            if kind == "HEARTBEAT" and msg.get_srcComponent() == 1 and msg.type != 6:
                self.target_system = msg.get_srcSystem()
                armed = bool(msg.base_mode & 0x80)
                if not seen.modes or seen.modes[-1][1:] != (msg.custom_mode, armed):
                    seen.modes.append((seen.boot_s, msg.custom_mode, armed))
            elif kind == "GLOBAL_POSITION_INT":
                seen.samples.append(
                    Sample(
                        msg.time_boot_ms / 1000.0,
                        msg.lat / 1e7,
                        msg.lon / 1e7,
                        msg.alt / 1000.0,
                        msg.relative_alt / 1000.0,
                        msg.vx / 100.0,
                        msg.vy / 100.0,
                        msg.vz / 100.0,
                    )
                )
            elif kind == "STATUSTEXT":
                seen.texts.append((seen.boot_s, msg.text))
            elif kind == "SYS_STATUS":
                seen.prearm_ok = bool(msg.onboard_control_sensors_health & PREARM_CHECK)
            elif kind == "GPS_RAW_INT":
                seen.fix_type = msg.fix_type
            elif kind == "EKF_STATUS_REPORT":
                seen.ekf_flags = msg.flags
            elif kind == "HOME_POSITION":
                seen.home = GeoPoint(msg.latitude / 1e7, msg.longitude / 1e7, msg.altitude / 1e3)
            elif kind == "PARAM_VALUE":
                value = float(msg.param_value)
                if self.autopilot == Autopilot.PX4 and msg.param_type in _PX4_INT_TYPES:
                    # PX4 sends integers bytewise (MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE)
                    value = float(struct.unpack("<i", struct.pack("<f", msg.param_value))[0])
                seen.params[msg.param_id] = value
            elif kind == "MISSION_CURRENT":
                if not seen.current or seen.current[-1][1] != msg.seq:
                    seen.current.append((seen.boot_s, msg.seq))
            elif kind == "EXTENDED_SYS_STATE":
                if not seen.landed or seen.landed[-1][1] != msg.landed_state:
                    seen.landed.append((seen.boot_s, msg.landed_state))

    def snapshot(self) -> Observation:
        with self._lock:
            seen = self.seen
            return Observation(
                list(seen.samples),
                list(seen.texts),
                list(seen.modes),
                seen.boot_s,
                seen.prearm_ok,
                seen.fix_type,
                seen.ekf_flags,
                seen.home,
                dict(seen.params),
                list(seen.current),
                list(seen.landed),
            )

    def ask_streams(self, rates_hz: Mapping[int, float]) -> None:
        """MAV_CMD_SET_MESSAGE_INTERVAL for each message id (a rate below 0: off)."""
        rates = dict(rates_hz)
        if self.autopilot == Autopilot.PX4:
            rates.update(PX4_QUIET)
        for message_id, hz in rates.items():
            interval = 1e6 / hz if hz > 0 else -1
            self.link.mav.command_long_send(
                self.target_system, 1, 511, 0, message_id, interval, 0, 0, 0, 0, 0
            )

    def request_home(self) -> None:
        self.link.mav.command_long_send(self.target_system, 1, 512, 0, 242, 0, 0, 0, 0, 0, 0)

    def read_param(self, name: str, timeout_s: float = 10.0) -> float:
        """PARAM_REQUEST_READ ``name``; its value (raises TimeoutError)."""
        deadline = time.monotonic() + timeout_s
        with self._lock:
            self.seen.params.pop(name, None)
        while time.monotonic() < deadline:
            self.link.mav.param_request_read_send(self.target_system, 1, name.encode(), -1)
            end = min(deadline, time.monotonic() + 1.0)
            while time.monotonic() < end:
                with self._lock:
                    if name in self.seen.params:
                        return self.seen.params[name]
                time.sleep(0.05)
        raise TimeoutError(f"no PARAM_VALUE for {name}")

    def wait(self, what: str, test: Callable[[Observation], bool], timeout_s: float) -> None:
        """Wait (wall clock, a safety net only) until ``test`` holds for what was seen."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if test(self.snapshot()):
                return
            time.sleep(0.1)
        seen = self.snapshot()
        texts = "; ".join(t for _, t in seen.texts[-8:])
        raise TimeoutError(
            f"SITL: {what} not seen within {timeout_s:g} s (wall): boot {seen.boot_s:.1f} s, "
            f"pre-arm {seen.prearm_ok}, fix {seen.fix_type}, EKF {seen.ekf_flags:#x}, "
            f"home {seen.home}; last texts: {texts}"
        )

    def wait_sim(self, seconds: float, timeout_s: float) -> float:
        """Wait until ``seconds`` of the vehicle's clock have passed; the clock then."""
        start = self.snapshot().boot_s
        self.wait(
            f"{seconds:g} s of simulated time", lambda s: s.boot_s >= start + seconds, timeout_s
        )
        return self.snapshot().boot_s


# ---------------------------------------------------------------------------------------------
# The firmware


@dataclass
class Sitl:
    """A running firmware: ``conn`` is the connection string for uavplan, ``observer`` the
    helper's own link."""

    autopilot: Autopilot
    home: GeoPoint
    speedup: float
    instance: int
    conn: str
    workdir: Path
    process: subprocess.Popen[bytes]
    observer: Observer | None = None
    _release: Callable[[], None] | None = None

    def ready(self, timeout_s: float = 300.0) -> Sitl:
        """Wait until the vehicle can arm (see the module docstring)."""
        observer = self.observer
        assert observer is not None
        ap = self.autopilot == Autopilot.ARDUPILOT
        asked = [0.0]

        def is_ready(seen: Observation) -> bool:
            now = time.monotonic()
            if now - asked[0] > 2.0:  # until the streams flow (an early request is lost)
                asked[0] = now
                observer.ask_streams(STREAMS)
                if seen.home is None:
                    observer.request_home()
            position = (
                seen.ekf_flags & EKF_POS_HORIZ_ABS and not seen.ekf_flags & EKF_CONST_POS_MODE
                if ap
                else seen.home is not None
            )
            return seen.prearm_ok and seen.fix_type >= 3 and bool(position)

        observer.wait("ready to arm", is_ready, timeout_s)
        observer.ask_streams(STREAMS)  # once more, to the system id its HEARTBEAT gave
        return self

    def ready_except_prearm(self, timeout_s: float = 300.0) -> Sitl:
        """Wait until the vehicle has a position (GPS fix, EKF, home) and has said why its
        pre-arm checks fail ("PreArm: ..."): a vehicle kept from arming on purpose."""
        observer = self.observer
        assert observer is not None
        ap = self.autopilot == Autopilot.ARDUPILOT
        asked = [0.0]

        def has_position(seen: Observation) -> bool:
            now = time.monotonic()
            if now - asked[0] > 2.0:
                asked[0] = now
                observer.ask_streams(STREAMS)
            position = (
                seen.ekf_flags & EKF_POS_HORIZ_ABS and not seen.ekf_flags & EKF_CONST_POS_MODE
                if ap
                else seen.home is not None
            )
            said = any(t.startswith(("PreArm:", "Preflight Fail")) for _, t in seen.texts)
            return seen.fix_type >= 3 and bool(position) and not seen.prearm_ok and said

        observer.wait("a position and a failing pre-arm check", has_position, timeout_s)
        return self

    def log_tail(self, lines: int = 30) -> str:
        log = self.workdir / "sitl.log"
        if not log.exists():
            return ""
        return "\n".join(log.read_text(errors="replace").splitlines()[-lines:])

    def stop(self) -> None:
        """Stop the firmware (ArduPilot SIGTERM, PX4 SIGINT, as the README says) and free its
        instance."""
        if self.observer is not None:
            self.observer.close()
            self.observer = None
        proc = self.process
        if proc.poll() is None:
            proc.send_signal(
                signal.SIGTERM if self.autopilot == Autopilot.ARDUPILOT else signal.SIGINT
            )
            try:
                proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(timeout=5)
        if self._release is not None:
            self._release()
            self._release = None

    def __enter__(self) -> Sitl:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


def _param_line(name: str, value: float) -> str:
    return f"{name} {value:.9g}\n"


def start(
    autopilot: Autopilot,
    home: GeoPoint,
    *,
    speedup: float = 8.0,
    params: Mapping[str, float] | None = None,
    workdir: Path | None = None,
    heading_deg: float = 0.0,
    ready: bool = True,
) -> Sitl:
    """Start ``autopilot``'s SITL at ``home`` (``params`` set at boot), connect the observer
    and (``ready``) wait until it can arm. Use as a context manager, or call :meth:`Sitl.stop`."""
    need(autopilot)
    work = Path(tempfile.mkdtemp(prefix=f"sitl-{autopilot.label}-", dir=workdir))
    if autopilot == Autopilot.ARDUPILOT:
        sitl = _start_ardupilot(home, speedup, params or {}, work, heading_deg)
    else:
        sitl = _start_px4(home, speedup, params or {}, work)
    try:
        if ready:
            sitl.ready()
    except BaseException:
        tail = sitl.log_tail()
        sitl.stop()
        if tail:
            print(f"--- {work / 'sitl.log'} ---\n{tail}")
        raise
    return sitl


def _held_instance(kind: str, candidates: range, ports: Callable[[int], list[tuple[int, int]]]):
    stack = contextlib.ExitStack()
    n = stack.enter_context(_instance(kind, candidates, ports))
    return n, stack.close


def _start_ardupilot(
    home: GeoPoint, speedup: float, params: Mapping[str, float], work: Path, heading_deg: float
) -> Sitl:
    base = sitl_dir() / "ardupilot"
    extra = work / "uavplan.parm"
    extra.write_text("".join(_param_line(k, v) for k, v in params.items()))
    n, release = _held_instance("ardupilot", AP_INSTANCES, _ap_ports)
    try:
        log = open(work / "sitl.log", "wb")
        cmd = [
            str(base / "arducopter"),
            "--model", "+",
            "--speedup", f"{speedup:g}",
            "--defaults", f"{base / 'copter.parm'},{extra}",
            "--home", f"{home.lat_deg:.8f},{home.lon_deg:.8f},{home.alt_m:.3f},{heading_deg:g}",
            f"-I{n}",
            "-w",
        ]  # fmt: skip
        proc = subprocess.Popen(cmd, cwd=work, stdout=log, stderr=subprocess.STDOUT)
        log.close()
        serial0 = AP_SERIAL0 + 10 * n
        _wait_listening(serial0, proc, work)
        sitl = Sitl(
            Autopilot.ARDUPILOT,
            home,
            speedup,
            n,
            f"tcp:127.0.0.1:{AP_SERIAL1 + 10 * n}",
            work,
            proc,
            _release=release,
        )
        sitl.observer = Observer(f"tcp:127.0.0.1:{serial0}", Autopilot.ARDUPILOT)
        return sitl
    except BaseException:
        release()
        raise


def _wait_listening(port: int, proc: subprocess.Popen[bytes], work: Path) -> None:
    """Wait for SITL's "SERIAL0 on TCP port" line (a probing connection would count as the
    ground station SITL waits for, and close it again)."""
    deadline = time.monotonic() + 30.0
    log = work / "sitl.log"
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"SITL exited ({proc.returncode}): {log.read_text()[-2000:]}")
        if f"SERIAL0 on TCP port {port}" in log.read_text(errors="replace"):
            return
        time.sleep(0.1)
    raise RuntimeError(f"SITL did not listen on TCP {port} within 30 s")


def _start_px4(home: GeoPoint, speedup: float, params: Mapping[str, float], work: Path) -> Sitl:
    dist = sitl_dir() / "px4"

    n, release = _held_instance("px4", PX4_INSTANCES, _px4_ports)
    try:
        # as run_sih.sh does: a start-up file that runs PX4's own rcS, then sets parameters
        # and stops the flight logger (~15 MB per simulated minute)
        (work / "rcS.local").write_text(
            "#!/bin/sh\n. etc/init.d-posix/rcS\n"
            + "".join(f"param set {k} {v:.9g}\n" for k, v in params.items())
            + "logger stop\ntrue\n"
        )
        # PX4's shell commands (param, commander ...) are links named px4-NAME to the px4
        # binary, which acts on the instance its name says; a copy of the build may hold them
        # as plain files (shared/sitl's does): make the links here, first on the PATH
        links = work / "bin"
        links.mkdir()
        for entry in (dist / "bin").iterdir():
            if entry.name.startswith("px4-") and not entry.name.endswith(".sh"):
                (links / entry.name).symlink_to(dist / "bin" / "px4")
        env = dict(os.environ)
        env["PATH"] = f"{links}{os.pathsep}{dist / 'bin'}{os.pathsep}{env.get('PATH', '')}"
        env.update(
            PX4_SYS_AUTOSTART="10040",  # 10040_sihsim_quadx
            PX4_SIMULATOR="sihsim",
            PX4_SIM_MODEL="sihsim_quadx",
            PX4_HOME_LAT=f"{home.lat_deg:.8f}",
            PX4_HOME_LON=f"{home.lon_deg:.8f}",
            PX4_HOME_ALT=f"{home.alt_m:.3f}",
            PX4_SIM_SPEED_FACTOR=f"{speedup:g}",
        )
        log = open(work / "sitl.log", "wb")
        cmd = [str(dist / "bin" / "px4"), "-d", "-i", str(n), "-w", str(work), "-s", "rcS.local",
               str(dist / "etc")]  # fmt: skip
        proc = subprocess.Popen(
            cmd, cwd=work, env=env, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL
        )
        log.close()
        sitl = Sitl(
            Autopilot.PX4,
            home,
            speedup,
            n,
            f"udpin:127.0.0.1:{PX4_OFFBOARD_REMOTE + n}",
            work,
            proc,
            _release=release,
        )
        sitl.observer = Observer(f"udpout:127.0.0.1:{PX4_GCS_LOCAL + n}", Autopilot.PX4)
        return sitl
    except BaseException:
        release()
        raise


@contextlib.contextmanager
def running(autopilot: Autopilot, home: GeoPoint, **kwargs: object) -> Iterator[Sitl]:
    sitl = start(autopilot, home, **kwargs)  # type: ignore[arg-type]
    try:
        yield sitl
    finally:
        sitl.stop()


def horizontal_m(a: Sample, home: GeoPoint) -> float:
    """Distance (m) on the ground from ``home`` to sample ``a`` (equirectangular)."""
    k = math.pi / 180.0 * 6_378_137.0
    dx = (a.lon_deg - home.lon_deg) * k * math.cos(math.radians(home.lat_deg))
    dy = (a.lat_deg - home.lat_deg) * k
    return math.hypot(dx, dy)


def distance_m(a: Sample, b: Sample) -> float:
    """Horizontal distance (m) between two samples (equirectangular: metres apart)."""
    k = math.pi / 180.0 * 6_378_137.0
    dx = (b.lon_deg - a.lon_deg) * k * math.cos(math.radians(a.lat_deg))
    dy = (b.lat_deg - a.lat_deg) * k
    return math.hypot(dx, dy)


def scratch() -> Path:
    path = Path(tempfile.mkdtemp(prefix="uavplan-sitl-"))
    return path


def remove(path: Path) -> None:
    shutil.rmtree(path, ignore_errors=True)


# ---------------------------------------------------------------------------------------------
# The bundled plans, planned as a user plans them


MISSIONS = ROOT / "missions"
#: how a bundled scenario may end: the autopilot's return (as bundled; via-tour: land) and
#: the planned return home (end: return)
ENDS = ("bundled", "return")
_PLAN_CACHE: dict[tuple[str, str, str, bool, bool, str], Path] = {}
_PLAN_DIR: list[Path] = []


def bundled_sources() -> list[Path]:
    """Every bundled scenario and the bundled QGroundControl plan (12)."""
    return sorted(MISSIONS.glob("*.yaml")) + sorted(MISSIONS.glob("*.plan"))


def scenario_variant(
    source: Path, autopilot: Autopilot, end: str, work: Path, *, amsl: bool = False
) -> Path:
    """``source`` as a scenario file in ``work`` that plans for ``autopilot`` with the ending
    ``end`` (its paths made absolute; jacksboro-ridge for PX4, or with ``amsl``, with AMSL
    altitudes: PX4 flies no terrain frames, and a SITL without a ground station serving
    terrain data cannot fly ArduPilot's)."""
    import yaml

    data = yaml.safe_load(source.read_text(encoding="utf-8"))
    for key in ("map", "terrain"):
        if isinstance(data.get(key), str):
            data[key] = str((source.parent / data[key]).resolve())
    airspace = data.get("airspace")
    if isinstance(airspace, dict) and isinstance(airspace.get("files"), list):
        airspace["files"] = [
            str((source.parent / f).resolve()) if isinstance(f, str) else f
            for f in airspace["files"]
        ]
    mission = data.setdefault("mission", {})
    mission["autopilot"] = autopilot.label
    if end != "bundled":
        mission["end"] = end
    if (amsl or autopilot == Autopilot.PX4) and mission.get("altitude") == "terrain":
        mission["altitude"] = "amsl"
    out = work / f"{source.stem}-{autopilot.label}-{end}{'-amsl' if amsl else ''}.yaml"
    out.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return out


def planned(
    source: Path,
    autopilot: Autopilot,
    end: str = "bundled",
    *,
    fence: bool = False,
    amsl: bool = False,
    work: Path | None = None,
    legal_ceiling: str | None = None,
) -> Path:
    """``uavplan plan`` of a bundled ``source`` for ``autopilot`` (cached for the session);
    the .plan's path. The bundled QGroundControl plan is rerouted as it is (its own flavour
    and ending: ``end`` must be "bundled"). ``legal_ceiling``: ``plan --legal-ceiling``
    ("none": a return at any altitude may be flown, so the mission relies on its RTL
    altitude instead of ending with a planned return)."""
    key = (str(source), autopilot.label, end, fence, amsl, str(work), legal_ceiling)
    if key in _PLAN_CACHE:
        return _PLAN_CACHE[key]
    from click.testing import CliRunner

    from uavplan.cli import main

    if work is None:
        if not _PLAN_DIR:
            _PLAN_DIR.append(Path(tempfile.mkdtemp(prefix="uavplan-sitl-plans-")))
        work = _PLAN_DIR[0]
    tag = ("-fence" if fence else "") + ("-amsl" if amsl else "")
    tag += "" if legal_ceiling is None else f"-ceiling-{legal_ceiling}"
    out = work / f"{source.stem}-{autopilot.label}-{end}{tag}.plan"
    if source.suffix == ".plan":
        if end != "bundled":
            raise ValueError("a .plan keeps its own ending")
        args = ["plan", str(source), "-o", str(out), "-q"]
    else:
        variant = scenario_variant(source, autopilot, end, work, amsl=amsl)
        args = ["plan", str(variant), "-o", str(out), "-q"]
    if fence:
        args.append("--fence")
    if legal_ceiling is not None:
        args += ["--legal-ceiling", legal_ceiling]
    if end == "return":
        # the long ones (jacksboro-ridge, zurich-airspace) flown there and back need more
        # than the x500's battery with its reserve: these plans are uploaded, never flown
        args.append("--allow-over-battery")
    result = CliRunner().invoke(main, args)
    if result.exit_code != 0:
        raise RuntimeError(f"uavplan {' '.join(args)}: exit {result.exit_code}: {result.output}")
    _PLAN_CACHE[key] = out
    return out
