"""Every example command in README.md and docs/*.md runs, as the documents show it.

The commands are taken from the documents' fenced code blocks (lines starting with
``uavplan``, ``python``, ``python3``, ``nice``, ``kill``, ``cd``, ``git``, ``make``,
``sim_vehicle.py``, ``pip`` or ``pytest``; in a transcript, the lines starting with ``$ ``)
and from the inline code of a table's ``example`` column (README's "Commands" table). Each
document's commands run in order, through ``bash``, in one temporary directory holding
``missions/``, ``maps/`` and ``tools/`` (a directory of links to the repository's files, so a
command may write beside them without touching the repository), so that later commands see
what earlier ones wrote; ``uavplan`` and ``python`` are those of the environment running the
tests.

A document says in an HTML comment before a block (or table) what the test cannot do as is:

- ``<!-- docs-test: skip (reason) -->``: not run (PX4 / ArduPilot SITL, a radio, a clone or a
  build, the network, a synopsis); listed with the reason;
- ``<!-- docs-test: slow (reason) -->``: run only with ``UAVPLAN_SLOW=1``;
- ``<!-- docs-test: exit N -->``: an error example: the command must exit N, and its first
  printed line must start with the line the document shows after it;
- ``<!-- docs-test: file NAME -->``: the block is the content of NAME, written before the
  document's commands run (a file an example names).

A marker with a command prefix in backticks (``<!-- docs-test: skip `uavplan fly` (...) -->``)
applies only to the block's commands starting with it. Every other command must exit 0, and
in a transcript (``$ command`` and what it printed) every line shown after a command must
still be printed by it, with its numbers: each number shown must agree with the one printed
in its place within one unit of its last digit or 0.2 % of it, whichever is more (issue 37: a
document's figures are checked, not masked). A number the document writes with a ``~`` in
front (``planned in ~0.50 s``) is one that varies from run to run (a time on the wall
clock): only its place is compared. ``...`` stands for lines left out.

MAVLink: ``uavplan mock-vehicle`` (``&`` or not) starts in the background and serves the
document's later commands; ``kill %N`` stops it. A command whose ``--conn`` no such vehicle
serves gets one started for it (``udp:``/``udpin:`` → a vehicle sending with ``udpout:``,
``udpout:`` → ``udpin:``, ``tcp:`` → ``tcpin:``), flying the autopilot and at the home of the
mission file the command names. Every port a document names is replaced, consistently within
the document, by a free port the OS gives, and the simulated vehicles run at
``--speedup`` ``UAVPLAN_DOCS_SPEEDUP`` (default 100; a document's 20 makes its flights 5 times
longer) so that a flight of minutes takes seconds (``fly`` reports simulated times).

``python tests/architecture/test_docs_examples.py`` prints, per document, the commands this test
runs and those it skips, with the reason (``--run`` also runs them, as the test does).

Slow (``UAVPLAN_SLOW=1``): README's ``uavplan bench ... --runs 10`` (30 planning runs of all
1000 iterations: 40 s on the 2-core build machine at load 4.5). The default run costs about
62 s of CPU (56 commands, each a fresh ``uavplan`` process; the four simulated flights take
5-8 s each at speedup 100): 69 s of wall time at load 0.7 on the shared 2-core machine, 2 min
at load 6-8.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import select
import shlex
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
SLOW = os.environ.get("UAVPLAN_SLOW") == "1"
SPEEDUP = os.environ.get("UAVPLAN_DOCS_SPEEDUP", "100")
#: per command, in seconds (a flight at the default speedup takes well under 30)
COMMAND_TIMEOUT = float(os.environ.get("UAVPLAN_DOCS_TIMEOUT", "240"))

COMMAND_WORDS = (
    "uavplan",
    "python",
    "python3",
    "nice",
    "kill",
    "cd",
    "git",
    "make",
    "sim_vehicle.py",
    "pip",
    "pytest",
)
NOT_COMMANDS = {"yaml", "json", "python", "csv", "toml"}  # code block languages: not shell
MARKER = re.compile(
    r"<!--\s*docs-test:\s*(?P<kind>skip|slow|exit\s+\d+|file\s+\S+)"
    r"(?:\s+`(?P<prefix>[^`]+)`)?\s*(?:\((?P<reason>.*?)\))?\s*-->"
)
CONN = re.compile(
    r"\b(?P<scheme>udpin|udpout|udp|tcpin|tcp)(?P<sep>://|:)"
    r"(?P<host>127\.0\.0\.1|localhost|0\.0\.0\.0):(?P<port>\d+)"
)
SPEEDUP_OPT = re.compile(r"--speedup\s+\S+")


@dataclass(frozen=True)
class Marker:
    kind: str  # skip | slow | exit | file
    prefix: str | None
    reason: str
    value: str = ""  # the exit code, or the file name


@dataclass
class Example:
    doc: str
    line: int
    command: str
    shown: list[str] = field(default_factory=list)  # a transcript's lines after the command
    skip: str | None = None  # the reason, if not run
    slow: str | None = None
    exit_code: int = 0

    @property
    def where(self) -> str:
        return f"{self.doc}:{self.line}"


@dataclass
class DocExamples:
    doc: str
    examples: list[Example]
    files: dict[str, str]  # name → content, from `file` markers


def _marker(match: re.Match[str]) -> Marker:
    words = match["kind"].split()
    return Marker(words[0], match["prefix"], match["reason"] or "", " ".join(words[1:]))


def _is_command(line: str) -> bool:
    word = line.split(maxsplit=1)[0] if line.strip() else ""
    return word in COMMAND_WORDS


def _block_commands(body: list[tuple[int, str]]) -> list[tuple[int, str, list[str]]]:
    """The commands of one fenced block: (line number, command, the transcript's output)."""
    out: list[tuple[int, str, list[str]]] = []
    transcript = any(text.startswith("$ ") for _, text in body)
    pending: tuple[int, str] | None = None
    for number, text in body:
        if pending is not None:  # a continued line
            start, joined = pending
            joined = joined[:-1] + " " + text.strip()
            pending = (start, joined) if joined.endswith("\\") else None
            if pending is None:
                out.append((start, joined, []))
            continue
        if transcript:
            if text.startswith("$ "):
                command = text[2:].strip()
            else:
                if out and text.strip() and text.strip() != "...":
                    out[-1][2].append(text.strip())
                continue
        elif _is_command(text.strip()):
            command = text.strip()
        else:
            continue
        if command.endswith("\\"):
            pending = (number, command)
        else:
            out.append((number, command, []))
    return out


def _table_commands(rows: list[tuple[int, str]]) -> list[tuple[int, str, list[str]]]:
    """The inline code of the `example` column of a table, where it is a command."""
    header = [cell.strip().lower() for cell in rows[0][1].strip().strip("|").split("|")]
    if "example" not in header:
        return []
    column = header.index("example")
    out: list[tuple[int, str, list[str]]] = []
    for number, text in rows[2:]:
        cells = re.split(r"(?<!\\)\|", text.strip().strip("|"))
        if column >= len(cells):
            continue
        for code in re.findall(r"`([^`]+)`", cells[column]):
            if _is_command(code):
                out.append((number, code.strip(), []))
    return out


def _apply(
    markers: list[Marker], found: list[tuple[int, str, list[str]]], doc: str
) -> list[Example]:
    examples = []
    for number, command, shown in found:
        ex = Example(doc, number, command, shown)
        for m in markers:
            if m.prefix is not None and not command.startswith(m.prefix):
                continue
            if m.kind == "skip":
                ex.skip = m.reason or "marked skip"
            elif m.kind == "slow":
                ex.slow = m.reason or "marked slow"
            elif m.kind == "exit":
                ex.exit_code = int(m.value)
        examples.append(ex)
    return examples


def doc_examples(path: Path) -> DocExamples:
    """Every example command of one document, with its markers."""
    doc = path.name if path.parent == ROOT else f"{path.parent.name}/{path.name}"
    lines = path.read_text(encoding="utf-8").split("\n")
    examples: list[Example] = []
    files: dict[str, str] = {}
    markers: list[Marker] = []
    i = 0
    while i < len(lines):
        text = lines[i]
        found = MARKER.search(text)
        if found:
            markers.append(_marker(found))
            i += 1
            continue
        if text.startswith("```"):
            lang = text[3:].strip().lower()
            body: list[tuple[int, str]] = []
            i += 1
            while i < len(lines) and not lines[i].startswith("```"):
                body.append((i + 1, lines[i]))
                i += 1
            i += 1
            for m in markers:
                if m.kind == "file":
                    files[m.value] = "\n".join(t for _, t in body) + "\n"
            if lang not in NOT_COMMANDS and not any(m.kind == "file" for m in markers):
                examples += _apply(markers, _block_commands(body), doc)
            markers = []
            continue
        if (
            text.startswith("|")
            and i + 1 < len(lines)
            and re.match(r"\|[-| :]+\|\s*$", lines[i + 1])
        ):
            rows: list[tuple[int, str]] = []
            while i < len(lines) and lines[i].startswith("|"):
                rows.append((i + 1, lines[i]))
                i += 1
            examples += _apply(markers, _table_commands(rows), doc)
            markers = []
            continue
        i += 1
    return DocExamples(doc, examples, files)


# ---------------------------------------------------------------------------------------------
# Running them


def _free_port() -> int:
    """A port free for both UDP and TCP on 127.0.0.1, as the OS assigns it."""
    for _ in range(50):
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as udp:
            udp.bind(("127.0.0.1", 0))
            port = int(udp.getsockname()[1])
            with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as tcp:
                try:
                    tcp.bind(("127.0.0.1", port))
                except OSError:
                    continue
        return port
    raise RuntimeError("no free port")


#: the vehicle's side of each client connection scheme
VEHICLE_SIDE = {
    "udp": "udpout",
    "udpin": "udpout",
    "udpout": "udpin",
    "tcp": "tcpin",
    "tcpin": "tcp",
}


@dataclass
class Outcome:
    example: Example
    command: str  # as run
    code: int | None
    output: str
    problem: str | None


class DocRunner:
    """Runs one document's examples in order in one directory."""

    def __init__(self, workdir: Path) -> None:
        self.workdir = workdir
        self.ports: dict[str, int] = {}  # the document's port → ours
        #: the document's background commands still running, in order, with the port served
        self.jobs: list[tuple[subprocess.Popen[bytes], int | None]] = []
        self.served: set[int] = set()  # our ports a vehicle serves
        self.helpers: list[subprocess.Popen[bytes]] = []  # vehicles started for a command
        bindir = str(Path(sys.executable).parent)
        self.env = dict(os.environ, PATH=bindir + os.pathsep + os.environ.get("PATH", ""))
        self.env["PYTHONUNBUFFERED"] = "1"
        self.env.pop("UAVPLAN_THREADS", None)

    @staticmethod
    def prepare(workdir: Path, files: dict[str, str]) -> None:
        for name in ("missions", "maps", "tools"):
            (workdir / name).mkdir()
            for src in (ROOT / name).iterdir():
                if src.is_file() or src.is_dir():  # missions/surveys/ too
                    (workdir / name / src.name).symlink_to(src)
        for name, content in files.items():
            (workdir / name).write_text(content, encoding="utf-8")

    def _port(self, port: str) -> int:
        if port not in self.ports:
            self.ports[port] = _free_port()
        return self.ports[port]

    def rewrite(self, command: str) -> str:
        def sub(m: re.Match[str]) -> str:
            return f"{m['scheme']}{m['sep']}127.0.0.1:{self._port(m['port'])}"

        command = CONN.sub(sub, command)
        if command.split()[:2] == ["uavplan", "mock-vehicle"]:
            command = SPEEDUP_OPT.sub("", command).rstrip(" &") + f" --speedup {SPEEDUP}"
        return command

    def _start(self, command: str) -> subprocess.Popen[bytes]:
        return subprocess.Popen(
            ["bash", "-c", "exec " + command],
            cwd=self.workdir,
            env=self.env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )

    def _vehicle_for(self, command: str) -> None:
        """Start a simulated vehicle for a command whose --conn nothing serves yet."""
        m = CONN.search(command)
        if m is None or int(m["port"]) in self.served:
            return
        args = [
            "uavplan",
            "mock-vehicle",
            "--conn",
            f"{VEHICLE_SIDE[m['scheme']]}:127.0.0.1:{m['port']}",
        ]
        for word in shlex.split(command)[2:]:
            path = self.workdir / word
            if word.endswith(".plan") and path.is_file():
                plan = json.loads(path.read_text(encoding="utf-8"))
                home = plan["mission"]["plannedHomePosition"]
                autopilot = "ardupilot" if plan["mission"].get("firmwareType") == 3 else "px4"
                args += ["--autopilot", autopilot, "--home", ",".join(str(v) for v in home)]
                break
        args += ["--speedup", SPEEDUP]
        helper = self._start(shlex.join(args))
        self.helpers.append(helper)
        self.served.add(int(m["port"]))
        _serving(helper)

    def run(self, ex: Example) -> Outcome:
        command = self.rewrite(ex.command)
        words = command.split()
        if words[0] == "kill":
            number = int(words[1].lstrip("%")) if len(words) > 1 else 1
            job, port = self.jobs.pop(number - 1)  # bash numbers the jobs still running
            if port is not None:
                self.served.discard(port)
            alive = job.poll() is None
            _stop(job)
            problem = None if alive else "the background command had already ended"
            return Outcome(ex, command, job.returncode, _read(job), problem)
        if words[:2] == ["uavplan", "mock-vehicle"]:
            job = self._start(command)
            m = CONN.search(command)
            port = int(m["port"]) if m is not None else None
            self.jobs.append((job, port))
            if port is not None:
                self.served.add(port)
            if not _serving(job):
                return Outcome(
                    ex, command, job.returncode, _read(job), "the vehicle did not keep running"
                )
            return Outcome(ex, command, None, "", None)
        if "--conn" in words:
            self._vehicle_for(command)
        try:
            done = subprocess.run(
                ["bash", "-c", command],
                cwd=self.workdir,
                env=self.env,
                stdout=subprocess.PIPE,
                stderr=subprocess.STDOUT,
                timeout=COMMAND_TIMEOUT,
                check=False,
            )
        except subprocess.TimeoutExpired as err:
            output = (err.stdout or b"").decode(errors="replace")
            return Outcome(ex, command, None, output, f"no end within {COMMAND_TIMEOUT:.0f} s")
        output = done.stdout.decode(errors="replace")
        problem = None
        if done.returncode != ex.exit_code:
            problem = f"exit {done.returncode}, expected {ex.exit_code}"
        elif ex.exit_code != 0 and ex.shown:
            first = next((ln.strip() for ln in output.splitlines() if ln.strip()), "")
            if not first.startswith(ex.shown[0]):
                problem = f"printed {first!r}, the document shows {ex.shown[0]!r}"
        else:
            printed = output.splitlines()
            stale = [ln for ln in ex.shown if not any(_matches(ln, got) for got in printed)]
            if stale:
                problem = f"the document shows a line it no longer prints: {stale[0]!r}"
        return Outcome(ex, command, done.returncode, output, problem)

    def close(self) -> None:
        for job in [*(job for job, _ in self.jobs), *self.helpers]:
            _stop(job)


def _serving(job: subprocess.Popen[bytes], timeout: float = 60.0) -> bool:
    """Wait until a started vehicle says it is serving (its first line); False if it ended."""
    assert job.stdout is not None
    ready, _, _ = select.select([job.stdout], [], [], timeout)
    if not ready:
        return job.poll() is None
    line = job.stdout.readline()
    return bool(line) and job.poll() is None


#: a number as the documents and uavplan print it (a thousands comma allowed)
NUMBER = re.compile(r"(?P<vary>~?)(?P<value>-?\d+(?:[.,]\d+)*)")


def _shape(line: str) -> str:
    """A printed line with its numbers masked (and a document's ``~`` marks dropped)."""
    return NUMBER.sub("#", line.strip())


def _matches(shown: str, printed: str) -> bool:
    """Does ``printed`` say what the document ``shown`` says: the same words, and every
    number within one unit of its last digit or 0.2 % (``~`` numbers: their place only)?"""
    if _shape(shown) != _shape(printed):
        return False
    ours = NUMBER.finditer(shown.strip())
    theirs = NUMBER.finditer(printed.strip())
    for doc, got in zip(ours, theirs, strict=True):
        if doc["vary"]:
            continue
        if not _agree(doc["value"], got["value"]):
            return False
    return True


def _agree(doc: str, got: str) -> bool:
    """``got`` within one unit of ``doc``'s last digit or 0.2 % of ``doc``."""
    if "," in doc and "." not in doc and re.fullmatch(r"-?\d{1,3}(,\d{3})+", doc):
        doc, got = doc.replace(",", ""), got.replace(",", "")  # thousands
    doc, got = doc.replace(",", "."), got.replace(",", ".")
    try:
        a, b = float(doc), float(got)
    except ValueError:  # pragma: no cover - a version string such as 1.2.3
        return doc == got
    decimals = len(doc.rpartition(".")[2]) if "." in doc else 0
    return abs(a - b) <= max(10.0**-decimals, 0.002 * abs(a)) + 1e-9


def _stop(job: subprocess.Popen[bytes]) -> None:
    if job.poll() is None:
        os.killpg(job.pid, signal.SIGINT)
        try:
            job.wait(timeout=10)
        except subprocess.TimeoutExpired:
            os.killpg(job.pid, signal.SIGKILL)
            job.wait()


def _read(job: subprocess.Popen[bytes]) -> str:
    return job.stdout.read().decode(errors="replace") if job.stdout is not None else ""


def run_document(found: DocExamples, workdir: Path) -> Iterator[Outcome]:
    """Run a document's examples (skips and, unless UAVPLAN_SLOW=1, slow ones left out)."""
    DocRunner.prepare(workdir, found.files)
    runner = DocRunner(workdir)
    try:
        for ex in found.examples:
            if ex.skip is None and (ex.slow is None or SLOW):
                yield runner.run(ex)
    finally:
        runner.close()


def listing(found: DocExamples) -> str:
    lines = [f"{found.doc}:"]
    for ex in found.examples:
        how = (
            "run " if ex.skip is None and ex.slow is None else "slow" if ex.skip is None else "skip"
        )
        why = f"  [{ex.skip or ex.slow}]" if how != "run " else ""
        code = f"  (exit {ex.exit_code})" if ex.exit_code else ""
        lines.append(f"  {how} {ex.line:4d}  {ex.command}{code}{why}")
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# The tests

ALL = [doc_examples(path) for path in DOCS]


@pytest.mark.timeout(900)
@pytest.mark.parametrize("found", [f for f in ALL if f.examples], ids=lambda f: f.doc)
@pytest.mark.slow
def test_document_examples_run(found: DocExamples, tmp_path: Path) -> None:
    print(listing(found))
    failures = [o for o in run_document(found, tmp_path) if o.problem]
    assert not failures, "\n\n".join(
        f"{o.example.where}: {o.command}\n  {o.problem}\n" + o.output[-1500:] for o in failures
    )


def test_every_block_of_commands_is_known() -> None:
    """A block's commands are either run or marked; no document lost its examples."""
    examples = [ex for f in ALL for ex in f.examples]
    run = [ex for ex in examples if ex.skip is None]
    assert len(run) >= 40
    for ex in examples:
        assert ex.skip is None or ex.skip.strip(), ex.where
    docs = {ex.doc for ex in run}
    assert {"README.md", "docs/flying.md", "docs/exports.md", "docs/pictures.md"} <= docs


BROKEN = """\
# A page

```
uavplan validate missions/paper-env1.yaml
uavplan plan missions/paper-env1.yaml -o a.plan --sed 3
```

<!-- docs-test: skip (needs PX4 SITL) -->
```
uavplan fly a.plan --conn udp:127.0.0.1:14540
```

<!-- docs-test: exit 2 -->
```
$ uavplan validate missing.yaml
error: something else
```

```
$ uavplan validate missions/paper-env1.yaml
...
missions/paper-env1.yaml: a line uavplan never printed, 12 m
```

```
$ uavplan validate missions/paper-env1.yaml
missions/paper-env1.yaml: ok — paper-env1, 5 obstacles, margin 12 m
```

```
$ uavplan validate missions/paper-env1.yaml
missions/paper-env1.yaml: ok — paper-env1, 5 obstacles, margin ~12 m
```
"""


@pytest.mark.slow
def test_a_broken_example_fails(tmp_path: Path) -> None:
    """A misspelled option, or an error message the document misquotes, is reported."""
    page = tmp_path / "page.md"
    page.write_text(BROKEN, encoding="utf-8")
    found = doc_examples(page)
    assert [(ex.command.split()[1], ex.skip, ex.exit_code) for ex in found.examples] == [
        ("validate", None, 0),
        ("plan", None, 0),
        ("fly", "needs PX4 SITL", 0),
        ("validate", None, 2),
        ("validate", None, 0),
        ("validate", None, 0),
        ("validate", None, 0),
    ]
    work = tmp_path / "work"
    work.mkdir()
    outcomes = list(run_document(found, work))
    assert [o.problem is None for o in outcomes] == [True, False, False, False, False, True]
    assert outcomes[1].code == 2
    assert "the document shows 'error: something else'" in (outcomes[2].problem or "")
    assert "no longer prints" in (outcomes[3].problem or "")
    # a figure off by more than its tolerance is a stale line (the margin is 10 m, not 12);
    # marked as varying (~12) only its place is compared
    assert "margin 12 m" in (outcomes[4].problem or "")


def test_numbers_agree_within_their_last_digit_or_a_fifth_of_a_percent() -> None:
    assert _matches("min clearance 10.52 m", "min clearance 10.53 m")
    assert not _matches("min clearance 10.52 m", "min clearance 10.55 m")
    assert _matches("flight 456.5 s", "flight 457.3 s")  # 0.2 %
    assert not _matches("flight 456.5 s", "flight 460.0 s")
    assert _matches("from 5,665 of 7,241 points", "from 5,667 of 7,241 points")
    assert not _matches("from 5,665 of 7,241 points", "from 6,665 of 7,241 points")
    assert _matches("planned in ~0.50 s", "planned in 3.20 s")
    assert not _matches("77 items", "77 waypoints")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--run", action="store_true", help="also run them, as the test does")
    parser.add_argument("--show", action="store_true", help="with --run: print every output")
    parser.add_argument("docs", nargs="*", help="only these (README.md, docs/flying.md, ...)")
    args = parser.parse_args()
    bad = 0
    for found in ALL:
        if (args.docs and found.doc not in args.docs) or not found.examples:
            continue
        print(listing(found))
        if args.run:
            with tempfile.TemporaryDirectory() as tmp:
                began = time.monotonic()
                for o in run_document(found, Path(tmp)):
                    status = "ok" if o.problem is None else f"FAILED: {o.problem}"
                    now = time.monotonic()
                    print(f"    {o.example.line:4d} {status} ({now - began:.1f} s)")
                    began = now
                    if o.problem:
                        bad += 1
                    if o.problem or args.show:
                        print(o.output[-1500:])
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
