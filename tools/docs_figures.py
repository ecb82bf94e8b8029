"""List the measured figures of README.md and docs/*.md and the command behind each; rerun them.

A figure in the documents (a time, a memory, a rate, an energy, a count of runs, a ratio) sits
next to one line saying where it came from:

    Measured with `python tools/bench_plan.py missions/jacksboro-ridge.yaml` on 2026-11-25,
    load 1.2 on the 2-core build machine.

(``Computed with`` for a model's figures that do not depend on the machine; several commands
may be named, each in backticks.) This tool finds those lines and prints, per document, each
one's line, date and commands, and the figure block it stands by: the table right after it
(or right before it), else its own paragraph.

    python tools/docs_figures.py                    # the list, per document
    python tools/docs_figures.py --commands         # each distinct command once, for a rerun
    python tools/docs_figures.py --run docs/flying.md   # rerun that document's commands
    python tools/docs_figures.py --check            # tables of numbers with no such line

``--run`` runs the commands from the repository root, one after the other, and prints their
output with the date and the load; putting the new numbers in the document stays a person's
job (the document's prose says what they mean). ``docs/results.md`` is written by
``tools/make_results.py`` and ``docs/reliability.md`` by ``tools/reliability.py``: each names
its command in its own way, and both are listed too.
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]

#: "Measured with `cmd` [and `cmd`] on 2026-11-25, load ..." (may wrap over lines)
SOURCE = re.compile(
    r"(?P<verb>measured|computed|produced)\s+(?:with|by)\s+"
    r"(?P<commands>`[^`]+`(?:[^`.]{0,40}?`[^`]+`)*)"
    r"\s+(?:on|\((?:commit \w+, )?)\s*(?P<date>\d{4}-\d{2}-\d{2})",
    re.IGNORECASE,
)
LOAD = re.compile(r"load (?:average )?\d+(?:\.\d+)?(?:\s*[-–]\s*\d+(?:\.\d+)?)?")
COMMAND = re.compile(r"`((?:python3? |uavplan |nice )[^`]+)`")
#: tables of settings, not of measurements (their header says so)
SETTINGS = re.compile(
    r"\b(?:default|parameter|constant|key|source|published|regime|symptom|part|example)\b"
    r"|mode_rtl",
    re.I,
)
#: a source line stands by a table this many lines away at most
NEAR = 4
#: written whole by their own tool, which names its commands its own way
GENERATED = {
    "docs/results.md": "tools/make_results.py",
    "docs/reliability.md": "tools/reliability.py",
}
TABLE_RULE = re.compile(r"^\|[-| :]+\|\s*$")
NUMBER = re.compile(r"\d+\.\d+|\b\d+ ?(?:s|ms|MiB|MB|GB|%|Wh|min)\b")


@dataclass(frozen=True)
class Source:
    doc: str
    line: int
    date: str
    commands: list[str]
    load: str
    block: str  # what the figures are: a table's header, or the paragraph's start


def _tables(lines: list[str]) -> list[tuple[int, int]]:
    """(first, last) line indexes of each Markdown table."""
    out = []
    i = 0
    while i < len(lines):
        if lines[i].startswith("|") and i + 1 < len(lines) and TABLE_RULE.match(lines[i + 1]):
            j = i
            while j < len(lines) and lines[j].startswith("|"):
                j += 1
            out.append((i, j - 1))
            i = j
        else:
            i += 1
    return out


def _doc_name(path: Path) -> str:
    return str(path.relative_to(ROOT))


def _block(lines: list[str], line: int, tables: list[tuple[int, int]]) -> str:
    """The figures a source line stands by: the nearest table within NEAR lines, else its text."""
    best = None
    for first, last in tables:
        distance = first - line if first > line else line - last if last < line else 0
        if 0 <= distance <= NEAR and (best is None or distance < best[0]):
            best = (distance, first)
    if best is not None:
        return f"table at line {best[1] + 1}: {lines[best[1]].strip()[:90]}"
    start = line
    while start > 0 and lines[start - 1].strip() and not lines[start - 1].startswith("#"):
        start -= 1
    return f"paragraph at line {start + 1}: {lines[start].strip()[:90]}"


def sources(path: Path) -> list[Source]:
    text = path.read_text(encoding="utf-8")
    lines = text.split("\n")
    tables = _tables(lines)
    out = []
    for m in SOURCE.finditer(text):
        line = text.count("\n", 0, m.start())
        load = LOAD.search(text[m.end() : m.end() + 80].replace("\n", " "))
        out.append(
            Source(
                doc=_doc_name(path),
                line=line + 1,
                date=m["date"],
                commands=COMMAND.findall(m["commands"].replace("\n", " ")),
                load=load.group(0) if load else "",
                block=_block(lines, line, tables),
            )
        )
    return out


def unsourced_tables(path: Path) -> list[str]:
    """Tables holding measured-looking numbers with no source line within NEAR lines."""
    lines = path.read_text(encoding="utf-8").split("\n")
    near = {s.line - 1 for s in sources(path)}
    out = []
    if _doc_name(path) in GENERATED:
        return []
    for first, last in _tables(lines):
        body = "\n".join(lines[first : last + 1])
        if SETTINGS.search(lines[first]) or len(NUMBER.findall(body)) < 4:
            continue
        if not any(first - NEAR <= n <= last + NEAR for n in near):
            out.append(f"{_doc_name(path)}:{first + 1}: {lines[first].strip()[:90]}")
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("docs", nargs="*", help="README.md, docs/flying.md, ... (default: all)")
    parser.add_argument("--commands", action="store_true", help="each distinct command once")
    parser.add_argument("--run", action="store_true", help="rerun the commands, in order")
    parser.add_argument("--check", action="store_true", help="tables of numbers with no source")
    args = parser.parse_args()
    docs = [ROOT / d for d in args.docs] if args.docs else DOCS
    for doc in docs:
        if not doc.is_file():
            parser.error(f"{doc}: no such document")
    if args.check:
        missing = [t for doc in docs for t in unsourced_tables(doc)]
        print("\n".join(missing) or "every table of figures names its command and date")
        return 1 if missing else 0
    found = [s for doc in docs for s in sources(doc)]
    commands: list[str] = []
    for s in found:
        commands += [c for c in s.commands if c not in commands]
    if args.commands:
        print("\n".join(commands))
        return 0
    if args.run:
        failed = 0
        for command in commands:
            print(f"$ {command}   # {dt.date.today()}, load {os.getloadavg()[0]:.1f}", flush=True)
            done = subprocess.run(command, shell=True, cwd=ROOT, check=False)
            failed += done.returncode != 0
        return 1 if failed else 0
    for name, tool in GENERATED.items():
        if ROOT / name in docs:
            print(f"{name}: written by python {tool} (the commands are in the document)")
    doc = None
    for s in found:
        if s.doc != doc:
            doc = s.doc
            print(f"{doc}:")
        load = f", {s.load}" if s.load else ""
        print(f"  line {s.line}, {s.date}{load}: {s.block}")
        for command in s.commands:
            print(f"      {command}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
