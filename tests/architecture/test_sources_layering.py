"""uavplan.sources sits above the vocabulary and below the scenario reader, and its field
libraries are imported lazily: only the import command and scenarios naming such files pay."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

PKG = Path(__file__).resolve().parents[2] / "uavplan"
ALLOWED = (
    "uavplan.errors",
    "uavplan.geo",
    "uavplan.limits",
    "uavplan.obstacles",
    "uavplan.sources",
)
HEAVY = ("osmium", "pyogrio", "rasterio", "shapely")


def top_level_and_all_imports(path: Path) -> tuple[set[str], set[str]]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    top: set[str] = set()
    every: set[str] = set()
    for node in ast.walk(tree):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module]
        every.update(names)
        if node in tree.body:
            top.update(names)
    return top, every


def test_sources_import_only_the_vocabulary() -> None:
    for path in sorted((PKG / "sources").glob("*.py")):
        _, every = top_level_and_all_imports(path)
        ours = {n for n in every if n.startswith("uavplan")}
        assert all(n.startswith(ALLOWED) for n in ours), (path.name, sorted(ours))


def test_field_libraries_are_imported_lazily() -> None:
    for path in sorted((PKG / "sources").glob("*.py")):
        top, _ = top_level_and_all_imports(path)
        assert not {n for n in top if n.split(".")[0] in HEAVY}, path.name
    code = (
        "import sys, uavplan.sources, uavplan.sources.dem, uavplan.scenario, uavplan.cli; "
        f"print(sorted(m for m in {HEAVY!r} if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
