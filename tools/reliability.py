"""Write docs/reliability.md: what was tried against uavplan, and what held.

One command runs everything and writes the document (the command is written at its top):

    python tools/reliability.py --examples 500 --runs 50

* the fuzz suites (``tests/**/test_fuzz_*.py``) with ``UAVPLAN_FUZZ_EXAMPLES`` examples per
  test: examples run and failed per hypothesis test (from hypothesis' statistics), and for
  the mission-file suite the outcome of every command run (exit codes, from
  ``UAVPLAN_FUZZ_REPORT``);
* the user-mistake tests of issue 12 (``tests/app/test_user_errors.py``): each one, held or not;
* the link chaos table: ``python tools/link_chaos.py --markdown --runs N`` (its own
  command; a clear line when the tool is not there);
* the mock-vehicle abuse and race tests (``tests/**/test_*abuse*.py``, ``*race*``, ``*chaos*``):
  trials run and held, per test;
* ``uavplan fly`` under faults: ``python tools/fly_faults.py --markdown`` (its own command:
  every case of issue 31, both flavours, three seeds, judged against the vehicle's own
  positions; a clear line when the tool is not there).

Counts are what this run saw; nothing is copied from an earlier run. Exit status 0 when the
document was written (even when some checks failed: the document says which), 2 on bad
options.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import re
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from collections import Counter, defaultdict
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "reliability.md"
MISSION_FUZZ = "tests/mission/test_fuzz_mission_files.py"
USER_ERRORS = "tests/app/test_user_errors.py"
LINK_CHAOS = "tools/link_chaos.py"
FLY_FAULTS = "tools/fly_faults.py"
#: the fly fault table flies 72 missions of minutes: it gets this long at least
FLY_FAULTS_TIMEOUT_S = 3 * 3600
ABUSE_GLOBS = ("test_*abuse*.py", "test_*race*.py", "test_*chaos*.py")
#: a suite that runs longer than this is stopped and reported as such
SUITE_TIMEOUT_S = 3600

_STATS_TEST = re.compile(r"^(?P<file>tests/\S+\.py)::(?P<test>\S+?):\s*$")
_STATS_COUNTS = re.compile(
    r"(?P<passing>\d+) passing, (?P<failing>\d+) failing, and (?P<invalid>\d+) invalid"
)


@dataclass
class TestCase:
    file: str
    name: str
    outcome: str  # passed | failed | error | skipped
    time_s: float
    message: str


@dataclass
class SuiteRun:
    files: list[str]
    cases: list[TestCase]
    stdout: str
    returncode: int
    timed_out: bool


def run_pytest(files: list[str], env_extra: dict[str, str], timeout_s: float) -> SuiteRun:
    """pytest on ``files`` in a subprocess; per-test outcomes from its JUnit XML."""
    with tempfile.TemporaryDirectory() as tmp:
        junit = Path(tmp) / "junit.xml"
        command = [
            sys.executable,
            "-m",
            "pytest",
            "-q",
            "-p",
            "no:cacheprovider",
            f"--junitxml={junit}",
            "--hypothesis-show-statistics",
            *files,
        ]
        env = {**os.environ, **env_extra}
        env.pop("UAVPLAN_DEBUG", None)
        try:
            proc = subprocess.run(
                command, cwd=ROOT, env=env, capture_output=True, text=True, timeout=timeout_s
            )
            stdout, code, timed_out = proc.stdout + proc.stderr, proc.returncode, False
        except subprocess.TimeoutExpired as err:
            out = err.stdout or b""
            stdout = out.decode(errors="replace") if isinstance(out, bytes) else out
            code, timed_out = -1, True
        cases = _junit_cases(junit) if junit.exists() else []
    return SuiteRun(files, cases, stdout, code, timed_out)


def _junit_cases(path: Path) -> list[TestCase]:
    cases = []
    for case in ET.parse(path).getroot().iter("testcase"):
        outcome, message = "passed", ""
        for tag in ("failure", "error", "skipped"):
            node = case.find(tag)
            if node is not None:
                outcome = {"failure": "failed", "error": "error", "skipped": "skipped"}[tag]
                text = (node.get("message") or "").strip()
                message = text.splitlines()[0][:160] if text else ""
                break
        classname = case.get("classname", "")
        file = classname.replace(".", "/") + ".py" if classname else ""
        cases.append(
            TestCase(file, case.get("name", "?"), outcome, float(case.get("time", 0)), message)
        )
    return cases


def hypothesis_counts(stdout: str) -> dict[str, tuple[int, int, int]]:
    """test name -> (passing, failing, invalid) examples, from --hypothesis-show-statistics."""
    counts: dict[str, tuple[int, int, int]] = {}
    current = None
    for line in stdout.splitlines():
        head = _STATS_TEST.match(line)
        if head:
            current = head["test"]
            continue
        found = _STATS_COUNTS.search(line)
        if found and current is not None:
            old = counts.get(current, (0, 0, 0))
            counts[current] = (
                old[0] + int(found["passing"]),
                old[1] + int(found["failing"]),
                old[2] + int(found["invalid"]),
            )
    return counts


# =============================================================================================
# Sections


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _held(case: TestCase) -> str:
    return {"passed": "held", "skipped": "skipped"}.get(case.outcome, "**FAILED**")


def fuzz_section(examples: int, timeout_s: float) -> list[str]:
    files = sorted(str(p.relative_to(ROOT)) for p in (ROOT / "tests").rglob("test_fuzz_*.py"))
    lines = ["## Fuzzing", ""]
    if not files:
        return [*lines, "No fuzz suite (`tests/**/test_fuzz_*.py`) on this branch.", ""]
    with tempfile.TemporaryDirectory() as tmp:
        report = Path(tmp) / "outcomes.json"
        run = run_pytest(
            files,
            {"UAVPLAN_FUZZ_EXAMPLES": str(examples), "UAVPLAN_FUZZ_REPORT": str(report)},
            timeout_s,
        )
        outcomes = json.loads(report.read_text(encoding="utf-8")) if report.exists() else {}
    stats = hypothesis_counts(run.stdout)
    lines += [
        f"`UAVPLAN_FUZZ_EXAMPLES={examples}` examples per hypothesis test, derandomized "
        "(the sequence CI runs). Invariant: exit 0 with a correct result, or exit 2 with one "
        "line naming the file; never exit 1, a traceback, a hang or a partial output file.",
        "",
        "| suite | test | examples run | failing | invalid (discarded) | held |",
        "|---|---|---:|---:|---:|---|",
    ]
    total = 0
    for case in run.cases:
        passing, failing, invalid = stats.get(case.name.split("[")[0], (0, 0, 0))
        if case.name.split("[")[0] not in stats:
            continue
        total += passing + failing
        lines.append(
            f"| {Path(case.file).name} | `{case.name}` | {passing + failing} | {failing} | "
            f"{invalid} | {_held(case)} |"
        )
    if run.timed_out:
        lines.append(f"| | stopped after {timeout_s:.0f} s | | | | **FAILED** |")
    others = [c for c in run.cases if c.name.split("[")[0] not in stats]
    held = sum(c.outcome == "passed" for c in others)
    lines += [
        "",
        f"{total} generated files in all; besides them {held} of {len(others)} fixed cases "
        "held (named corner cases: values the wire cannot hold, huge inputs, seeds).",
        "",
    ]
    failed = [c for c in run.cases if c.outcome in ("failed", "error")]
    for case in failed:
        lines.append(f"- **{case.name}** failed: {_cell(case.message)}")
    if failed:
        lines.append("")
    if outcomes:
        lines += _outcome_table(outcomes)
    return lines


def _outcome_table(outcomes: dict[str, int]) -> list[str]:
    """suite|command|code -> count, as one table: rows suite × command, columns exit codes."""
    table: dict[tuple[str, str], Counter[int]] = defaultdict(Counter)
    for key, count in outcomes.items():
        suite, command, code = key.split("|")
        table[(suite, command)][int(code)] += count
    codes = sorted({code for counter in table.values() for code in counter} | {0, 1, 2})
    names = {
        0: "exit 0",
        1: "exit 1 (internal)",
        2: "exit 2 (input)",
        3: "exit 3 (no path)",
        4: "exit 4 (link; upload stops before connecting)",
    }
    lines = [
        "Mission-file commands run on the generated files, by exit code:",
        "",
        "| suite | command | " + " | ".join(names.get(c, f"exit {c}") for c in codes) + " |",
        "|---|---|" + "---:|" * len(codes),
    ]
    for (suite, command), counter in sorted(table.items()):
        lines.append(
            f"| {suite} | {command} | " + " | ".join(str(counter[c]) for c in codes) + " |"
        )
    ones = sum(counter[1] for counter in table.values())
    lines += ["", f"Exit 1 (internal error) in {ones} command runs.", ""]
    return lines


def user_error_section(timeout_s: float) -> list[str]:
    lines = ["## User mistakes (issue 12)", ""]
    if not (ROOT / USER_ERRORS).exists():
        return [*lines, f"`{USER_ERRORS}` is not on this branch.", ""]
    run = run_pytest([USER_ERRORS], {}, timeout_s)
    held = sum(c.outcome == "passed" for c in run.cases)
    lines += [
        f"Each mistake run through the CLI: exit code, one line naming the file, no traceback, "
        f"nothing written on failure. {held} of {len(run.cases)} held.",
        "",
        "| mistake | held | what was seen when it did not |",
        "|---|---|---|",
    ]
    for case in run.cases:
        seen = _cell(case.message) if case.outcome in ("failed", "error") else ""
        lines.append(f"| `{case.name}` | {_held(case)} | {seen} |")
    if run.timed_out:
        lines.append(f"| stopped after {timeout_s:.0f} s | **FAILED** | |")
    return [*lines, ""]


def link_chaos_section(runs: int, timeout_s: float) -> list[str]:
    lines = ["## Link chaos", ""]
    tool = ROOT / LINK_CHAOS
    command = f"python {LINK_CHAOS} --markdown --runs {runs}"
    if not tool.exists():
        return [
            *lines,
            f"`{LINK_CHAOS}` is not on this branch: no link chaos table in this run "
            f"(it would be `{command}`).",
            "",
        ]
    try:
        proc = subprocess.run(
            [sys.executable, str(tool), "--markdown", "--runs", str(runs)],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=timeout_s,
        )
    except subprocess.TimeoutExpired:
        return [*lines, f"`{command}` did not finish within {timeout_s:.0f} s.", ""]
    if proc.returncode != 0:
        tail = _cell(proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else "")
        lines += [f"`{command}` exited {proc.returncode}: {tail}", ""]
    lines += [f"From `{command}`:", "", proc.stdout.strip(), ""]
    return lines


def fly_faults_section(timeout_s: float) -> list[str]:
    lines = ["## Flying through faults (issue 31)", ""]
    tool = ROOT / FLY_FAULTS
    command = f"python {FLY_FAULTS} --markdown"
    if not tool.exists():
        return [*lines, f"`{FLY_FAULTS}` is not on this branch (it would be `{command}`).", ""]
    limit = max(timeout_s, FLY_FAULTS_TIMEOUT_S)
    try:
        proc = subprocess.run(
            [sys.executable, str(tool), "--markdown"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=limit,
        )
    except subprocess.TimeoutExpired:
        return [*lines, f"`{command}` did not finish within {limit:.0f} s.", ""]
    lines += [f"`{command}` exited {proc.returncode}:", "", proc.stdout.strip(), ""]
    return lines


def abuse_section(timeout_s: float) -> list[str]:
    lines = ["## Mock vehicle under abuse, races", ""]
    files = sorted(
        {str(p.relative_to(ROOT)) for g in ABUSE_GLOBS for p in (ROOT / "tests").rglob(g)}
    )
    if not files:
        globs = ", ".join(f"`tests/**/{g}`" for g in ABUSE_GLOBS)
        return [*lines, f"No abuse or race tests ({globs}) on this branch.", ""]
    run = run_pytest(files, {}, timeout_s)
    groups: dict[tuple[str, str], list[TestCase]] = defaultdict(list)
    for case in run.cases:
        groups[(Path(case.file).name, case.name.split("[")[0])].append(case)
    lines += ["| file | test | trials | held |", "|---|---|---:|---:|"]
    for (file, name), cases in sorted(groups.items()):
        held = sum(c.outcome == "passed" for c in cases)
        lines.append(f"| {file} | `{name}` | {len(cases)} | {held} |")
    if run.timed_out:
        lines.append(f"| | stopped after {timeout_s:.0f} s | | |")
    return [*lines, ""]


def _commit() -> str:
    try:
        out = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True
        )
    except OSError:
        return "unknown"
    return out.stdout.strip() or "unknown"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=500, help="fuzz examples per test")
    parser.add_argument("--runs", type=int, default=50, help="link chaos runs per row")
    parser.add_argument("--output", type=Path, default=DOC, help="the document to write")
    parser.add_argument(
        "--timeout", type=float, default=SUITE_TIMEOUT_S, help="seconds per suite at most"
    )
    args = parser.parse_args(argv)
    if args.examples < 1 or args.runs < 1:
        parser.error("--examples and --runs must be at least 1")

    command = f"python tools/reliability.py --examples {args.examples} --runs {args.runs}"
    started = dt.datetime.now(dt.UTC)
    body: list[str] = []
    for section in (
        lambda: fuzz_section(args.examples, args.timeout),
        lambda: user_error_section(args.timeout),
        lambda: link_chaos_section(args.runs, args.timeout),
        lambda: abuse_section(args.timeout),
        lambda: fly_faults_section(args.timeout),
    ):
        lines = section()
        print(f"reliability: {lines[0].lstrip('# ')} done", file=sys.stderr)
        body += lines
    took_s = (dt.datetime.now(dt.UTC) - started).total_seconds()
    head = [
        "# Reliability: what was tried, and what held",
        "",
        f"Produced by `{command}` (commit {_commit()}, "
        f"{started:%Y-%m-%d %H:%M} UTC, {took_s / 60:.0f} min). Every number below is from "
        "that run; run the command again to refresh it.",
        "",
    ]
    from uavplan.fileio import atomic_write_text

    atomic_write_text(args.output, "\n".join(head + body).rstrip() + "\n")
    print(f"wrote {args.output}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    raise SystemExit(main())
