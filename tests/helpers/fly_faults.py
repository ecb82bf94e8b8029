"""``uavplan fly`` under faults: one flight per case, judged against what the vehicle did.

One run (:func:`run_case`): a ``uavplan mock-vehicle`` process standing at the plan's home,
a seeded :class:`~fault_relay.FaultRelay` in front of it, ``uavplan fly --scenario --track``
as a process connected through the relay, and the case's event during the flight (an
outage, a restart of the vehicle process, another ground station's command or mission,
Ctrl-C during the upload, wind the vehicle cannot beat ...). The relay keeps every position
and heartbeat the vehicle sent before any fault, so the result is judged against the truth:

- never exit 1, never a hang (the run has a wall-clock bound), never a traceback;
- exit 0 only when the vehicle really completed the mission and landed, the whole flight
  was observed (the track has no gap in the air) and the vehicle's own track (the truth,
  all of it) keeps the margin, by the independent check of tests/helpers/track_check.py;
- the track file is whole: it loads, its samples are the vehicle's own (time and place) in
  the vehicle's order, from the ground before take-off to the last sample received, and a
  gap in it is one ``fly`` reported;
- how long ``fly`` took to say each event, in the vehicle's (simulated) seconds.

Used by tests/app/test_fly_faults.py (each case once or twice) and tools/fly_faults.py (the
table: each case, both flavours, three seeds).
"""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

from helpers.fault_relay import FaultRelay, RelayFaults
from uavplan.mavlink.flightclient import FlightClient
from uavplan.mavlink.flightmachines import FlightTimeouts
from uavplan.mavlink.link import VehicleLink
from uavplan.mavlink.modes import ModeKind, mode_from_heartbeat
from uavplan.mavlink.protocol import MissionClient, ProtocolTimeouts
from uavplan.mavlink.transfer import compare_items, plan_wire_items
from uavplan.mission.io import load_mission
from uavplan.mission.items import Autopilot, MissionPlan, MissionType
from uavplan.mission.track import Track, TrackFileError

ROOT = Path(__file__).resolve().parents[2]
UAVPLAN = [sys.executable, "-m", "uavplan"]
#: the bundled mission the cases fly: a planned return (no RTL altitude to trust), about
#: 4.5 (ArduPilot) and 8 (PX4) simulated minutes
SCENARIO = ROOT / "missions" / "narrow-gap.yaml"
WRONG_SCENARIO = ROOT / "missions" / "midtown-manhattan.yaml"
#: the wall-clock bound of one run beyond the flight itself: longer is a hang
HANG_MARGIN_S = 90.0
#: a stretch of the vehicle's time without a position longer than this is not observed (the
#: judge's own figure: it is fly's GAP_S, stated here so the judgement does not lean on it)
GAP_S = 2.0


def gaps_of(track: Track) -> list[tuple[float, float]]:
    """Where ``track`` has no sample for longer than :data:`GAP_S`: (from, to), its seconds."""
    t = track.time_s
    return [(float(t[i]), float(t[i + 1])) for i in range(len(t) - 1) if t[i + 1] - t[i] > GAP_S]


# ---------------------------------------------------------------------------------------------
# Processes


class VehicleProcess:
    """``uavplan mock-vehicle`` standing at ``home``, on an OS-assigned UDP port."""

    def __init__(self, autopilot: Autopilot, plan: MissionPlan, speedup: float,
                 extra: tuple[str, ...] = ()) -> None:  # fmt: skip
        assert plan.home is not None
        self.autopilot, self.plan, self.speedup, self.extra = autopilot, plan, speedup, extra
        home = f"{plan.home.lat_deg:.8f},{plan.home.lon_deg:.8f},{plan.home.alt_m:.3f}"
        args = [*UAVPLAN, "mock-vehicle", "--conn", "udpin:127.0.0.1:0", "--autopilot",
                autopilot.label, "--speedup", f"{speedup:g}", "--home", home, *extra]  # fmt: skip
        self.proc = subprocess.Popen(
            args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True
        )
        assert self.proc.stderr is not None
        line = self.proc.stderr.readline()
        match = re.search(r"serving on udpin:127\.0\.0\.1:(\d+)", line)
        if not match:
            self.proc.kill()
            raise RuntimeError(f"the mock vehicle did not start: {line!r}")
        self.address = ("127.0.0.1", int(match.group(1)))
        # keep reading its standard error so it never blocks on a full pipe
        threading.Thread(target=self.proc.stderr.read, daemon=True).start()

    def again(self) -> VehicleProcess:
        """A new vehicle process set up as this one (a restart: a fresh boot on its own
        port, holding nothing)."""
        return VehicleProcess(self.autopilot, self.plan, self.speedup, self.extra)

    def stop(self, *, hard: bool = False) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGKILL if hard else signal.SIGINT)
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


class FlyProcess:
    """``uavplan fly`` as a process; every line it writes, with the wall time it came."""

    def __init__(self, args: list[str], cwd: Path) -> None:
        self.proc = subprocess.Popen(
            [*UAVPLAN, "fly", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            text=True, cwd=cwd,
        )  # fmt: skip
        self.lines: list[tuple[float, str]] = []
        self._lock = threading.Lock()
        self._readers = [
            threading.Thread(target=self._read, args=(stream,), daemon=True)
            for stream in (self.proc.stdout, self.proc.stderr)
        ]
        for reader in self._readers:
            reader.start()

    def _read(self, stream: object) -> None:
        for line in stream:  # type: ignore[attr-defined]
            with self._lock:
                self.lines.append((time.monotonic(), line.rstrip("\n")))

    def wait(self, timeout_s: float) -> int | None:
        """The exit code, or None when it did not end within ``timeout_s`` (a hang: it is
        killed)."""
        try:
            code = self.proc.wait(timeout_s)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
            code = None
        for reader in self._readers:
            reader.join(5.0)
        return code

    def first(self, pattern: str) -> float | None:
        """The wall time of the first line matching ``pattern`` (None: none)."""
        with self._lock:
            for when, line in self.lines:
                if re.search(pattern, line):
                    return when
        return None

    @property
    def output(self) -> str:
        with self._lock:
            return "\n".join(line for _, line in self.lines)


# ---------------------------------------------------------------------------------------------
# Another ground station


def other_ground_station(address: tuple[str, int]) -> VehicleLink:
    """A second ground station talking straight to the vehicle (its own component id)."""
    host, port = address
    return VehicleLink.connect(f"udpout:{host}:{port}", heartbeat_timeout_s=5.0)


def command_mode(address: tuple[str, int], kind: ModeKind) -> None:
    """Another ground station switches the vehicle to the mode of ``kind``."""
    with other_ground_station(address) as link:
        outcome = FlightClient(link, FlightTimeouts()).change_mode(kind)
        if not outcome.ok:
            raise RuntimeError(f"the other ground station's mode change failed: {outcome.message}")


def upload_other_mission(address: tuple[str, int], plan: MissionPlan) -> int:
    """Another ground station uploads ``plan`` with its last waypoints left out; its
    component id."""
    with other_ground_station(address) as link:
        autopilot = link.vehicle.autopilot
        wire = plan_wire_items(plan, MissionType.MISSION, autopilot)
        shorter = wire[: max(3, len(wire) - 6)] + wire[-1:]
        client = MissionClient(link, ProtocolTimeouts())
        client.upload(MissionType.MISSION, shorter).raise_for_status()
        return link.connection.component_id


def vehicle_mission(address: tuple[str, int]) -> list:
    with other_ground_station(address) as link:
        outcome = MissionClient(link, ProtocolTimeouts()).download(MissionType.MISSION)
        return list(outcome.raise_for_status().items)


# ---------------------------------------------------------------------------------------------
# Cases


@dataclass
class Run:
    """What a case's event needs during the flight."""

    relay: FaultRelay
    vehicle: VehicleProcess
    plan: MissionPlan
    fly: FlyProcess | None = None
    #: wall time of the event (for the time to notice) and what it was
    event_wall: float | None = None
    event: str = ""
    #: vehicles started during the run (a restart), to stop at the end
    spare: list[VehicleProcess] = field(default_factory=list)
    error: str = ""


@dataclass(frozen=True)
class Case:
    name: str
    says: str  # what happens, in words
    faults: RelayFaults = field(default_factory=RelayFaults)
    link_timeout_s: float = 5.0
    vehicle_args: tuple[str, ...] = ()
    scenario: Path = SCENARIO
    #: called in a thread once ``fly`` runs (the case's event)
    during: Callable[[Run], None] | None = None
    #: the exit codes the case may end with
    exits: frozenset[int] = frozenset({0})
    #: a line ``fly`` prints when it notices the event (for the time to notice)
    notice: str = ""


def _airborne(run: Run, height_m: float = 20.0, timeout_s: float = 120.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        last = run.relay.last_position()
        if last is not None and last.relative_alt_m >= height_m:
            return True
        time.sleep(0.02)
    return False


def _after_takeoff(run: Run, seconds: float) -> bool:
    """Airborne, then ``seconds`` more of the vehicle's time."""
    if not _airborne(run):
        return False
    last = run.relay.last_position()
    assert last is not None
    target = last.time_s + seconds
    deadline = time.monotonic() + 120.0
    while time.monotonic() < deadline:
        now = run.relay.last_position()
        if now is not None and now.time_s >= target:
            return True
        time.sleep(0.02)
    return False


def _outage(seconds: float) -> Callable[[Run], None]:
    def act(run: Run) -> None:
        if _after_takeoff(run, 30.0):
            run.event_wall, run.event = time.monotonic(), f"{seconds:g} s outage"
            run.relay.outage(seconds)

    return act


def _restart(run: Run) -> None:
    if not _after_takeoff(run, 30.0):
        return
    # the new boot is started first (a process takes seconds to start on a loaded machine,
    # more than the link timeout), then the old one dies (a power cycle, not a clean stop)
    # and the relay turns to the new one at once: its clock started moments ago
    fresh = run.vehicle.again()
    run.spare.append(fresh)
    run.vehicle.stop(hard=True)
    run.relay.retarget(fresh.address)
    run.event_wall, run.event = time.monotonic(), "restart"


def _other_mode(kind: ModeKind) -> Callable[[Run], None]:
    def act(run: Run) -> None:
        if not _after_takeoff(run, 30.0):
            return
        command_mode(run.vehicle.address, kind)
        run.event = f"{kind.value} from another ground station"
        deadline = time.monotonic() + 5.0  # the relay's thread may not have logged it yet
        while run.event_wall is None and time.monotonic() < deadline:
            run.event_wall = _mode_seen(run)
            time.sleep(0.02)

    return act


def _mode_seen(run: Run) -> float | None:
    """The wall time of the first heartbeat, after the mission began, in another mode."""
    started = False
    for event in run.relay.heartbeats():
        custom = event.detail["custom_mode"]
        assert isinstance(custom, int)
        mode = mode_from_heartbeat(run.vehicle.autopilot, custom)
        if mode is not None and mode.kind is ModeKind.MISSION and event.detail["armed"]:
            started = True
        elif started and (mode is None or mode.kind is not ModeKind.MISSION):
            return event.wall_s
    return None


def _other_mission(run: Run) -> None:
    if not _after_takeoff(run, 30.0):
        return
    component = upload_other_mission(run.vehicle.address, run.plan)
    run.event = "mission uploaded by another ground station"
    deadline = time.monotonic() + 5.0
    while run.event_wall is None and time.monotonic() < deadline:
        for event in run.relay.events:  # the vehicle's final ACK to that ground station
            if event.kind == "mission_ack" and event.detail["target"] == (255, component):
                run.event_wall = event.wall_s
                break
        time.sleep(0.02)


def _wind_stall(run: Run) -> None:
    deadline = time.monotonic() + 300.0
    while time.monotonic() < deadline and run.fly is not None and run.fly.proc.poll() is None:
        event = run.relay.last_event("statustext")
        if event is not None and "Wind" in str(event.detail["text"]):
            run.event_wall, run.event = event.wall_s, "the wind holds the vehicle back"
            return
        time.sleep(0.05)


def _ctrl_c_upload(run: Run) -> None:
    deadline = time.monotonic() + 60.0
    while time.monotonic() < deadline:
        if run.relay.uplink_ids.get(73, 0) >= 5 and run.fly is not None:  # MISSION_ITEM_INT
            run.fly.proc.send_signal(signal.SIGINT)
            run.event_wall, run.event = time.monotonic(), "Ctrl-C during the upload"
            return
        time.sleep(0.005)


CASES: dict[str, Case] = {
    c.name: c
    for c in (
        Case("clean", "no fault"),
        Case(
            "reorder",
            "the vehicle's datagrams: 10 % held back behind the next 3 (50 ms at most), "
            "5 % duplicated",
            RelayFaults(duplicate_rate=0.05, reorder_rate=0.10, reorder_depth=3, down_only=True),
        ),
        Case(
            "lossy",
            "each way: 20 % lost, 5 % duplicated, 5 % held back behind the next one, 5 % "
            "delayed up to 50 ms",
            RelayFaults(
                drop_rate=0.2,
                duplicate_rate=0.05,
                reorder_rate=0.05,
                reorder_depth=1,
                delay_rate=0.05,
            ),
        ),
        Case(
            "outage-5s",
            "a 5 s outage (wall) 30 s after take-off, --link-timeout 10",
            link_timeout_s=10.0,
            during=_outage(5.0),
            exits=frozenset({4}),
            notice="nothing heard from the vehicle",
        ),
        Case(
            "outage-20s",
            "a 20 s outage (wall) 30 s after take-off, --link-timeout 30",
            link_timeout_s=30.0,
            during=_outage(20.0),
            exits=frozenset({4}),
            notice="nothing heard from the vehicle",
        ),
        Case(
            "restart",
            "the vehicle process killed 30 s after take-off and started again",
            during=_restart,
            exits=frozenset({4}),
            notice="the vehicle restarted",
        ),
        Case(
            "gcs-hold",
            "another ground station switches to hold (ArduPilot BRAKE / PX4 Hold)",
            during=_other_mode(ModeKind.HOLD),
            exits=frozenset({4}),
            notice="switched to",
        ),
        Case(
            "gcs-rtl",
            "another ground station switches to RTL (the autopilot's own return: it may "
            "break the margin)",
            during=_other_mode(ModeKind.RETURN),
            exits=frozenset({3, 4}),
            notice="switched to",
        ),
        Case(
            "gcs-mission",
            "another ground station uploads a shorter mission",
            during=_other_mission,
            exits=frozenset({4}),
            notice="replaced the vehicle's mission|holds another mission now",
        ),
        Case(
            "wind",
            "wind 20 m/s from the west (mock-vehicle --wind 20,0)",
            vehicle_args=("--wind", "20,0"),
            during=_wind_stall,
            exits=frozenset({4}),
            notice="no progress for",
        ),
        Case(
            "wrong-scenario",
            "--scenario of another mission (midtown-manhattan)",
            scenario=WRONG_SCENARIO,
            exits=frozenset({2}),
        ),
        Case(
            "ctrl-c-upload",
            "Ctrl-C after the 5th mission item of the upload (every datagram delayed <= 50 ms)",
            RelayFaults(delay_rate=1.0, max_delay_s=0.05),
            during=_ctrl_c_upload,
            exits=frozenset({130}),
        ),
    )
}


# ---------------------------------------------------------------------------------------------
# One run


@dataclass(frozen=True)
class CaseResult:
    case: str
    autopilot: Autopilot
    seed: int
    exit_code: int | None  # None: a hang
    verdict: str
    track_whole: str  # "yes", "no track" (no flight), or what is wrong
    final_state: str
    noticed_after_s: float | None  # the vehicle's seconds from the event to fly's word
    noticed_after_wall_s: float | None  # the same on the ground's clock
    problems: tuple[str, ...]  # broken invariants (empty: held)
    output: str

    @property
    def held(self) -> bool:
        return not self.problems


def plan_for(autopilot: Autopilot, work: Path) -> Path:
    """The bundled scenario planned for ``autopilot`` (cached in ``work``)."""
    out = work / f"mission-{autopilot.label}.plan"
    if not out.exists():
        done = subprocess.run(
            [*UAVPLAN, "plan", str(SCENARIO), "-o", str(out), "--autopilot", autopilot.label, "-q"],
            capture_output=True, text=True, timeout=600,
        )  # fmt: skip
        if done.returncode != 0:
            raise RuntimeError(f"plan failed: {done.stderr}")
    return out


def run_case(
    case: Case,
    autopilot: Autopilot,
    seed: int,
    work: Path,
    *,
    speedup: float = 20.0,
) -> CaseResult:
    """One flight of ``case`` (see the module docstring)."""
    path = plan_for(autopilot, work)
    plan = load_mission(path)
    track = work / f"{case.name}-{autopilot.label}-{seed}.csv"
    track.unlink(missing_ok=True)
    vehicle = VehicleProcess(autopilot, plan, speedup, case.vehicle_args)
    relay = FaultRelay(vehicle.address, replace(case.faults, seed=seed)).start()
    run = Run(relay, vehicle, plan)
    flight_s = 600.0 / speedup * 2.0  # twice the longest flight of the mission, wall
    try:
        args = [str(path), "--conn", relay.conn, "--scenario", str(case.scenario),
                "--track", str(track), "--link-timeout", f"{case.link_timeout_s:g}",
                "--set-params"]  # fmt: skip
        run.fly = FlyProcess(args, work)
        actor = None
        if case.during is not None:
            actor = threading.Thread(target=_guarded, args=(case.during, run), daemon=True)
            actor.start()
        code = run.fly.wait(flight_s + HANG_MARGIN_S)
        ended = time.monotonic()
        if actor is not None:
            actor.join(30.0)
        time.sleep(0.3)  # the vehicle's last words reach the relay
        final = _final_state(run, autopilot)
        if case.name == "ctrl-c-upload":
            final = _held_mission(run, autopilot, path)
    finally:
        if run.fly is not None and run.fly.proc.poll() is None:
            run.fly.proc.kill()  # the harness itself stopped (SIGTERM, Ctrl-C)
        relay.stop()
        for v in (vehicle, *run.spare):
            v.stop()
    output = run.fly.output
    verdict = _verdict_of(code, output)
    whole, track_problems = _track_whole(track, run, code)
    problems = list(track_problems)
    problems += _invariants(case, code, output, track, run, autopilot)
    if run.error:
        problems.append(f"the case's event failed: {run.error}")
    if (
        case.during is not None
        and case.notice
        and (run.event_wall is None or run.event_wall > ended)
    ):
        # the harness's fault, not fly's: on a loaded machine the event came too late
        problems.append("the case's event did not happen during the flight")
    noticed = _noticed_after(case, run)
    said = run.fly.first(case.notice) if case.notice else None
    wall = None if said is None or run.event_wall is None else said - run.event_wall
    return CaseResult(case.name, autopilot, seed, code, verdict, whole, final, noticed, wall,
                      tuple(problems), output)  # fmt: skip


def _guarded(act: Callable[[Run], None], run: Run) -> None:
    try:
        act(run)
    except Exception as err:  # reported as a broken run, never a crash of the harness
        run.error = f"{type(err).__name__}: {err}"


VERDICTS = (
    (r"breaks the margin", "breach"),
    (r"lost the link", "link lost"),
    (r"restarted during the flight", "restarted"),
    (r"given another mission", "mission changed"),
    (r"stayed in", "held by another"),
    (r"no progress for", "no progress"),
    (r"landed and disarmed before", "landed early"),
    (r"disarmed in the air", "disarmed in the air"),
    (r"interrupted during the upload", "upload cancelled"),
    (r"not observed in the air", "not wholly observed"),
    (r"outside scenario|was not planned for it", "wrong scenario refused"),
)
MODIFIERS = (
    (r"not observed in the air: ([\d.]+) s", "{} s"),
    (r"changed behind fly's back", "takeover"),
    (r"the mission completed", "mission completed"),
)


def _verdict_of(code: int | None, output: str) -> str:
    if code is None:
        return "HANG"
    if code == 0:
        return "complete" if "mission complete" in output else "exit 0 without a verdict"
    if code == 1:
        return "INTERNAL ERROR"
    main = next(
        (label for pattern, label in VERDICTS if re.search(pattern, output)), f"exit {code}"
    )
    extra = []
    for pattern, label in MODIFIERS:
        match = re.search(pattern, output)
        if match:
            extra.append(label.format(*match.groups()))
    return main + (f" ({', '.join(extra)})" if extra else "")


def _final_state(run: Run, autopilot: Autopilot) -> str:
    """The vehicle's mode, armed and where it is, from its last words (the truth)."""
    beat = run.relay.last_event("heartbeat")
    last = run.relay.last_position()
    if beat is None or last is None:
        return "not contacted"
    custom = beat.detail["custom_mode"]
    assert isinstance(custom, int)
    mode = mode_from_heartbeat(autopilot, custom)
    name = mode.name if mode is not None else f"mode {beat.detail['custom_mode']}"
    armed = "armed" if beat.detail["armed"] else "disarmed"
    assert run.plan.home is not None
    from uavplan.geo import EnuFrame

    ((x, y),) = EnuFrame.at(run.plan.home).to_enu_xy([last.lat_deg], [last.lon_deg])
    where = (
        f"{last.relative_alt_m:.0f} m up" if last.relative_alt_m > 0.5 else "on the ground"
    ) + f", {((x**2 + y**2) ** 0.5):.0f} m from home"
    restarted = " (restarted)" if beat.epoch else ""
    return f"{name}, {armed}, {where}{restarted}"


def _held_mission(run: Run, autopilot: Autopilot, path: Path) -> str:
    """What the vehicle holds after an interrupted upload, read by another ground station."""
    try:
        held = vehicle_mission(run.vehicle.address)
    except Exception as err:
        return f"mission unreadable: {err}"
    wire = plan_wire_items(load_mission(path), MissionType.MISSION, autopilot)
    if compare_items(wire, held, MissionType.MISSION, autopilot) is None:
        return f"holds this mission ({len(held)} items)"
    if not held:
        return "holds no mission (what it held before)"
    return f"holds {len(held)} other items"


def _track_whole(track: Path, run: Run, code: int | None) -> tuple[str, list[str]]:
    """Is the track file the flight as received: loadable, the vehicle's own samples in its
    order, from the ground to the end, every gap reported?"""
    flew = bool(run.relay.truth) and max(p.relative_alt_m for p in run.relay.truth) > 1.0
    if not track.exists():
        if not flew:
            return "no flight", []  # refused before the start: there is no track to write
        return "MISSING", ["no track file was written"]
    try:
        flown = Track.load(track)
    except TrackFileError as err:
        return "UNREADABLE", [f"the track does not load: {err}"]
    problems = []
    truth = run.relay.positions(0)
    if len(flown) < 2 or not truth:
        return "EMPTY", ["the track is empty"]
    # its samples are the vehicle's: each at a time the vehicle sent, at that place (the
    # track counts from its first sample: found by a sample in the air, which is unique)
    by_time = {round(p.time_s, 3): p for p in truth}
    up = [i for i in range(len(flown)) if flown.relative_alt_m[i] > 5.0]
    if not up and not flew:
        return "yes (on the ground)", []  # nothing to place it by: it never took off
    t0 = None
    if up:
        i = up[0]
        for p in truth:
            same = (
                abs(p.lat_deg - flown.lat_deg[i]) < 2e-7
                and abs(p.lon_deg - flown.lon_deg[i]) < 2e-7
            )
            if same and abs(p.relative_alt_m - flown.relative_alt_m[i]) < 0.01:
                t0 = p.time_s - float(flown.time_s[i])
                break
    if t0 is None:
        problems.append("the track's samples are no positions the vehicle sent")
    else:
        for i in range(0, len(flown), max(1, len(flown) // 200)):
            p = by_time.get(round(t0 + float(flown.time_s[i]), 3))
            if p is None or abs(p.lat_deg - flown.lat_deg[i]) > 2e-7:
                problems.append(f"track sample {i} is no position the vehicle sent then")
                break
    if flown.relative_alt_m[0] > 0.5:
        problems.append("the track does not start on the ground")
    gaps = gaps_of(flown)
    reported = len(re.findall(r"no telemetry from", run.fly.output if run.fly else ""))
    if len(gaps) > reported:
        problems.append(f"{len(gaps)} gaps in the track, {reported} reported")
    return ("yes" if not problems else "NO"), problems


def _invariants(case: Case, code: int | None, output: str, track: Path, run: Run,
                autopilot: Autopilot) -> list[str]:  # fmt: skip
    out = []
    if code is None:
        out.append("fly did not end: a hang")
    elif code == 1:
        out.append("exit 1 (an internal error)")
    if "Traceback" in output:
        out.append("a traceback")
    if code is not None and code not in case.exits:
        out.append(f"exit {code}, expected {sorted(case.exits)}")
    if code == 0:
        out += _complete_is_true(track, run, autopilot)
    return out


def _complete_is_true(track: Path, run: Run, autopilot: Autopilot) -> list[str]:
    """An exit 0 must be true of the flight the vehicle flew: it landed, disarmed; every
    part of it in the air was observed; all of it (the vehicle's own track) keeps the
    margin."""
    out = []
    beat = run.relay.last_event("heartbeat")
    last = run.relay.last_position()
    if beat is None or beat.detail["armed"] or last is None or last.relative_alt_m > 0.5:
        out.append("exit 0, but the vehicle is not down and disarmed")
    if run.relay.epoch:
        out.append("exit 0 after a restart")
    try:
        flown = Track.load(track)
    except TrackFileError:
        return [*out, "exit 0 without a track"]
    airborne = flown.relative_alt_m > 0.5
    for a, b in gaps_of(flown):
        i = int((flown.time_s <= a).sum()) - 1
        if airborne[i] or airborne[min(i + 1, len(flown) - 1)]:
            out.append(f"exit 0 over an unobserved stretch ({a:.1f}-{b:.1f} s)")
    import numpy as np

    from helpers.track_check import scenario_clearance
    from uavplan.scenario import load_scenario

    truth = run.relay.positions(0)
    whole = Track(
        np.array([p.time_s for p in truth]), np.array([p.lat_deg for p in truth]),
        np.array([p.lon_deg for p in truth]), np.array([p.alt_amsl_m for p in truth]),
        np.array([p.relative_alt_m for p in truth]), np.zeros(len(truth)),
        np.full(len(truth), -1),
    )  # fmt: skip
    margin = load_scenario(SCENARIO).safety_margin_m
    clearance = scenario_clearance(SCENARIO, whole)
    if clearance < margin - 0.05:
        out.append(f"exit 0, but the vehicle's own track came within {clearance:.2f} m")
    del autopilot
    return out


def _noticed_after(case: Case, run: Run) -> float | None:
    """The vehicle's seconds between the event and ``fly``'s word of it."""
    if not case.notice or run.event_wall is None or run.fly is None:
        return None
    said = run.fly.first(case.notice)
    if said is None:
        return None
    relay = run.relay
    if case.name == "restart":
        # the new vehicle's own clock, from its first position
        fresh = relay.positions(relay.epoch)
        if not fresh:
            return None
        at = [p.time_s for p in fresh if p.wall_s <= said]
        return (at[-1] - fresh[0].time_s) if at else 0.0
    start, end = relay.vehicle_time_at(run.event_wall), relay.vehicle_time_at(said)
    if start is None or end is None:
        return None
    return end - start
