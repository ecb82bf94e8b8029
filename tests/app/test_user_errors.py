"""Every user mistake of issue 12 ends in one clear line and the SPEC's exit code.

One test per path that ended in "internal error" (or a hang, or a traceback) when tried as a
new user would: Ctrl-C during ``plan``, a start or goal on the ground, a take-off altitude
above the ceiling, output files into a missing folder, planner options for another algorithm,
and the scenario values that passed loading and then crashed or hung the planner. Each runs
through the CLI (click's CliRunner in-process, or a real process where a signal, a hang or
a memory blow-up is possible) and checks the exit code, that the message is one line naming
the file, that no traceback is shown, and that nothing is written when a command fails.
"""

from __future__ import annotations

import os
import queue
import signal
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

import pytest
import yaml
from click.testing import CliRunner, Result

from uavplan.cli import main

ROOT = Path(__file__).resolve().parents[2]
#: a small scenario that plans in well under a second with the options below
BASE: dict[str, Any] = {
    "name": "user-errors",
    "origin": {"lat": 47.397, "lon": 8.545, "alt": 488},
    "bounds": {"x": [-100, 700], "y": [-300, 300], "z": [0, 120]},
    "start": [0, 0, 20],
    "goal": [500, 0, 30],
    "safety_margin": 5,
    "obstacles": [{"type": "box", "center": [250, 0], "size": [60, 60], "height": 50}],
}
FAST = ["--iterations", "5", "--population", "4", "--seed", "1", "-q"]
#: an obstacle wall across the whole flight volume: planning ends in exit 3 (no path), so a
#: command that exits 2 on a bad output path must have checked it before planning
WALL = [{"type": "box", "center": [250, 0], "size": [40, 1000], "height": 500}]
#: how long a real process may take before the run counts as a hang
HANG_S = 120.0
#: address space of a real process: a memory blow-up fails fast instead of swapping the host
MEMORY_LIMIT_BYTES = 4 * 2**30


def _limit_memory() -> None:
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT_BYTES, MEMORY_LIMIT_BYTES))


def write_scenario(tmp_path: Path, name: str = "s.yaml", **changes: Any) -> Path:
    doc = {**BASE, **changes}
    path = tmp_path / name
    path.write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
    return path


def run(args: list[Any]) -> Result:
    return CliRunner().invoke(main, [str(a) for a in args])


def assert_one_line_error(result: Result, code: int, *names: object) -> str:
    """Exit ``code``, one line on stderr starting with "error:" and naming each of ``names``."""
    stderr = result.stderr
    assert result.exit_code == code, f"exit {result.exit_code}, stderr: {stderr[-800:]}"
    if isinstance(result.exception, BaseException) and not isinstance(result.exception, SystemExit):
        pytest.fail(f"exception escaped: {result.exception!r}")
    message = stderr.strip()
    assert "Traceback" not in stderr and "internal error" not in stderr, stderr[-800:]
    assert message.count("\n") == 0, f"not one line: {message[:800]!r}"
    assert message.startswith("error: "), message[:300]
    assert "[Errno" not in message, message[:300]
    for name in names:
        assert str(name) in message, f"{name} not in {message[:300]!r}"
    return message


def run_process(args: list[Any], timeout_s: float = HANG_S) -> subprocess.CompletedProcess[str]:
    """``python -m uavplan ARGS`` in a real process; a hang fails the test, it does not hang it."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    env.pop("UAVPLAN_DEBUG", None)
    try:
        return subprocess.run(
            [sys.executable, "-m", "uavplan", *map(str, args)],
            capture_output=True,
            text=True,
            timeout=timeout_s,
            env=env,
            cwd=ROOT,
            preexec_fn=_limit_memory,
        )
    except subprocess.TimeoutExpired:
        pytest.fail(f"uavplan {' '.join(map(str, args))} still running after {timeout_s:.0f} s")


def assert_process_error(proc: subprocess.CompletedProcess[str], code: int, *names: object) -> None:
    stderr = proc.stderr
    assert proc.returncode == code, f"exit {proc.returncode}, stderr: {stderr[-800:]}"
    assert "Traceback" not in stderr and "internal error" not in stderr, stderr[-800:]
    lines = [line for line in stderr.splitlines() if line.startswith("error:")]
    assert len(lines) == 1, stderr[-800:]
    for name in names:
        assert str(name) in lines[0], f"{name} not in {lines[0][:300]!r}"


# =============================================================================================
# Ctrl-C


@pytest.mark.timeout(600)
def test_ctrl_c_during_plan_exits_130_interrupted(tmp_path: Path) -> None:
    """SIGINT once the planner runs: exit 130, "interrupted", no traceback, no output file.

    Waits (bounded) for the line on stderr that says planning has started, then interrupts;
    a long run (many iterations) makes sure the signal lands inside the search.
    """
    scenario = ROOT / "missions" / "paper-env3.yaml"
    out = tmp_path / "m.plan"
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    env.pop("UAVPLAN_DEBUG", None)
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "uavplan",
            "plan",
            str(scenario),
            "-o",
            str(out),
            "--iterations",
            "100000",
            "--seed",
            "1",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        cwd=ROOT,
    )
    lines: queue.Queue[str | None] = queue.Queue()

    def pump() -> None:
        assert proc.stderr is not None
        for line in proc.stderr:
            lines.put(line)
        lines.put(None)

    reader = threading.Thread(target=pump, daemon=True)
    reader.start()
    seen: list[str] = []
    try:
        while True:
            try:
                line = lines.get(timeout=HANG_S)
            except queue.Empty:
                pytest.fail(f"no 'planning' line on stderr within {HANG_S:.0f} s: {seen}")
            if line is None:
                pytest.fail(f"plan ended before it said it was planning: {seen}")
            seen.append(line)
            if "planning" in line.lower():
                break
        proc.send_signal(signal.SIGINT)
        code = proc.wait(timeout=HANG_S)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    reader.join(timeout=10)
    while True:
        try:
            line = lines.get_nowait()
        except queue.Empty:
            break
        if line is not None:
            seen.append(line)
    stderr = "".join(seen)
    assert code == 130, f"exit {code}: {stderr[-800:]}"
    assert "interrupted" in stderr, stderr[-800:]
    assert "Traceback" not in stderr and "SystemError" not in stderr, stderr[-800:]
    assert not out.exists()
    assert [p.name for p in tmp_path.iterdir()] == []


# =============================================================================================
# Start, goal and take-off altitude: validate and plan agree


@pytest.mark.parametrize(
    "changes",
    [{"start": [0, 0, 0]}, {"goal": [500, 0, 0]}],
    ids=["start-z0", "goal-z0"],
)
def test_start_or_goal_on_the_ground_exit_2_from_validate_and_plan(
    tmp_path: Path, changes: dict[str, Any]
) -> None:
    scenario = write_scenario(tmp_path, **changes)
    key = next(iter(changes))
    assert_one_line_error(run(["validate", scenario]), 2, scenario, key)
    out = tmp_path / "m.plan"
    assert_one_line_error(run(["plan", scenario, "-o", out, *FAST]), 2, scenario, key)
    assert not out.exists()


def test_takeoff_above_the_ceiling_exit_2_from_validate_and_plan(tmp_path: Path) -> None:
    scenario = write_scenario(tmp_path, vehicle={"takeoff_altitude": 200})  # ceiling 120 m
    assert_one_line_error(run(["validate", scenario]), 2, scenario, "takeoff_altitude")
    out = tmp_path / "m.plan"
    result = run(["plan", scenario, "-o", out, *FAST])
    assert_one_line_error(result, 2, scenario, "takeoff_altitude")
    assert not out.exists()


# =============================================================================================
# Output paths: checked before planning, nothing written when one fails


def _outputs(tmp_path: Path) -> list[str]:
    return sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*") if p.name != "s.yaml")


@pytest.mark.parametrize(
    "option",
    ["-o", "--report", "--plot"],
)
def test_plan_output_into_a_missing_folder_exit_2_before_planning_and_writes_nothing(
    tmp_path: Path, option: str
) -> None:
    scenario = write_scenario(tmp_path, obstacles=WALL)  # planning would exit 3
    missing = tmp_path / "no-such-folder"
    paths = {
        "-o": tmp_path / "m.plan",
        "--report": tmp_path / "r.json",
        "--plot": tmp_path / "p.png",
    }
    suffix = {"-o": "m.plan", "--report": "r.json", "--plot": "p.png"}[option]
    paths[option] = missing / suffix
    args: list[Any] = ["plan", scenario, *FAST]
    for name, path in paths.items():
        args += [name, path]
    message = assert_one_line_error(run(args), 2, paths[option])
    assert ".tmp" not in message, message  # the user's path, not a temporary file's
    assert _outputs(tmp_path) == [], "a failed plan wrote files"


def test_plan_report_into_a_missing_folder_does_not_write_the_mission(tmp_path: Path) -> None:
    scenario = write_scenario(tmp_path)  # plans: the report is the only bad path
    out = tmp_path / "m.plan"
    report = tmp_path / "missing" / "r.json"
    message = assert_one_line_error(
        run(["plan", scenario, "-o", out, "--report", report, *FAST]), 2, report
    )
    assert "folder" in message or "directory" in message, message
    assert not out.exists()


def test_render_into_a_missing_folder_exit_2_and_writes_nothing(tmp_path: Path) -> None:
    scenario = write_scenario(tmp_path)
    picture = tmp_path / "missing" / "p.png"
    result = run(["render", scenario, "-o", picture, "--no-plan", "-q"])
    message = assert_one_line_error(result, 2, picture)
    assert ".tmp" not in message
    assert _outputs(tmp_path) == []


def test_unwritable_output_folder_exit_2(tmp_path: Path) -> None:
    if os.geteuid() == 0:
        pytest.skip("root writes into read-only folders")
    scenario = write_scenario(tmp_path, obstacles=WALL)
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o500)
    try:
        out = locked / "m.plan"
        assert_one_line_error(run(["plan", scenario, "-o", out, *FAST]), 2, out)
        assert not out.exists()
    finally:
        locked.chmod(0o700)


# =============================================================================================
# Planner options and --algorithm


def test_planner_options_for_another_algorithm_with_algorithm_run_that_algorithm(
    tmp_path: Path,
) -> None:
    """The scenario tunes PSO (its section, or ``options`` of ``algorithm: pso``);
    ``--algorithm gwo`` runs GWO with GWO's own section or defaults: PSO's ``w_start`` is not
    GWO's business (docs/scenario-format.md). It used to die with a ValueError (exit 1)."""
    scenario = write_scenario(tmp_path, planner={"algorithm": "pso", "options": {"w_start": 0.9}})
    out = tmp_path / "m.plan"
    report = tmp_path / "r.json"
    result = run(["plan", scenario, "-o", out, "--report", report, "--algorithm", "gwo", *FAST])
    assert result.exit_code == 0, result.stderr[-800:]
    assert out.is_file()
    import json

    assert json.loads(report.read_text())["algorithm"] == "gwo"


# =============================================================================================
# Scenario values that passed loading and then crashed or hung


def _yaml_with(tmp_path: Path, line: str, name: str = "s.yaml") -> Path:
    """The base scenario with one top-level key replaced by a raw YAML line."""
    key = line.split(":", 1)[0]
    doc = {k: v for k, v in BASE.items() if k != key}
    text = yaml.safe_dump(doc, sort_keys=False) + line + "\n"
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def _billion_laughs() -> str:
    levels = ['&a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    for prev, cur in zip("abcdefgh", "bcdefghi", strict=True):
        levels.append(f"&{cur} [" + ",".join([f"*{prev}"] * 9) + "]")
    return "start: [" + ", ".join(levels) + "]"


#: the raw YAML line, and the key the message must name
LOADING_CRASHES = {
    "safety-margin-400-digits": ("safety_margin: " + "9" * 400, "safety_margin"),
    # refused by the YAML reader before any key is read: the message names the YAML problem
    "start-nested-1000-deep": ("start: " + "[" * 1000 + "]" * 1000, "YAML"),
    "map-nul-byte": ('map: "maps/a\\0b.yaml"', "map"),
    "map-longer-than-name-max": ("map: " + "m" * 300 + ".yaml", "map"),
    "cylinder-centre-minus-1e308": (
        "obstacles: [{type: cylinder, center: [-1.0e+308, 0], radius: 10, height: 10}]",
        "obstacles",
    ),
    "billion-laughs-start": (_billion_laughs(), "aliases"),
}


@pytest.mark.timeout(300)
@pytest.mark.parametrize("case", sorted(LOADING_CRASHES))
@pytest.mark.slow
def test_scenario_values_that_crashed_loading_exit_2_from_validate_and_plan(
    tmp_path: Path, case: str
) -> None:
    line, key = LOADING_CRASHES[case]
    scenario = _yaml_with(tmp_path, line)
    proc = run_process(["validate", scenario])
    assert_process_error(proc, 2, scenario, key)
    assert len(proc.stderr) < 2000, f"{len(proc.stderr)} characters of message"
    out = tmp_path / "m.plan"
    proc = run_process(["plan", scenario, "-o", out, *FAST])
    assert_process_error(proc, 2, scenario, key)
    assert not out.exists()


#: planner values that made ``plan`` run out of memory, index out of range or hang, and
#: whether the dense paper-env3 map is needed to show it (the hangs need unreachable nodes)
PLANNER_BLOWUPS: dict[str, tuple[dict[str, Any], str, bool]] = {
    "population-2-to-the-40": ({"population": 2**40}, "population", False),
    "post-sample-step-1e-9": ({"post": {"sample_step_m": 1e-9}}, "sample_step_m", False),
    "energy-weights-1e308": (
        {"energy": {"k0": 1e308, "k1": 1e308, "mu0": 1e308, "k2": 1e308}},
        "energy",
        False,
    ),
    "t-max-1e9": ({"t_max": 10**9}, "t_max", True),
    "oscillation-window-1e9": (
        {"spsa": {"oscillation_window": 10**9}},
        "oscillation_window",
        True,
    ),
}


def dense_scenario(tmp_path: Path, planner: dict[str, Any]) -> Path:
    """missions/paper-env3.yaml (20 iterations plan it in seconds) with ``planner`` merged."""
    doc = yaml.safe_load((ROOT / "missions" / "paper-env3.yaml").read_text(encoding="utf-8"))
    doc["map"] = str(ROOT / "maps" / "paper-env3.yaml")
    doc["planner"] = {**doc.get("planner", {}), "iterations": 20, "seed": 1, **planner}
    path = tmp_path / "dense.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
    return path


@pytest.mark.timeout(600)
@pytest.mark.parametrize("case", sorted(PLANNER_BLOWUPS))
def test_planner_values_are_refused_or_planned_and_validate_agrees(
    tmp_path: Path, case: str
) -> None:
    """Refused up front by both commands (exit 2 naming the key), or accepted by both and
    planned within the hang bound (exit 0 or 3): never exit 1, a hang or a memory blow-up."""
    planner, key, dense = PLANNER_BLOWUPS[case]
    if dense:
        scenario = dense_scenario(tmp_path, planner)
    else:
        scenario = write_scenario(tmp_path, planner={"iterations": 5, "seed": 1, **planner})
    checked = run_process(["validate", scenario])
    out = tmp_path / "m.plan"
    args: list[Any] = ["plan", scenario, "-o", out, "-q"]
    if "population" not in planner and not dense:
        args += ["--population", "4"]
    planned = run_process(args)
    if checked.returncode == 2:
        assert_process_error(checked, 2, scenario, key)
        assert_process_error(planned, 2, scenario, key)
        assert not out.exists()
    else:
        assert checked.returncode == 0, checked.stderr[-800:]
        assert planned.returncode in (0, 3), f"exit {planned.returncode}: {planned.stderr[-800:]}"
        assert "Traceback" not in planned.stderr and "internal error" not in planned.stderr
        assert out.exists() == (planned.returncode == 0)
