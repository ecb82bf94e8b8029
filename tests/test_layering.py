"""The dependency rules of the architecture, checked on the source (STYLE.md):

* geometry and world know nothing of MAVLink or missions;
* planners know nothing of files, missions or MAVLink;
* the mission layer knows nothing of optimisers or MAVLink;
* pymavlink is imported only inside ``uavplan/mavlink``; nothing imports the CLI;
* ``import uavplan`` pulls in neither numba nor matplotlib nor pymavlink.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parent.parent / "uavplan"


def imports_of(path: Path) -> set[str]:
    """Modules a file imports at run time (``if TYPE_CHECKING:`` blocks left out)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            node.body = []
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
    return names


def modules(pattern: str) -> list[Path]:
    return sorted(PKG.glob(pattern))


RULES = [
    # (files, forbidden import prefixes)
    ("_geom.py", ("uavplan.mission", "uavplan.mavlink", "uavplan.planners", "uavplan.cli")),
    ("world.py", ("uavplan.mission", "uavplan.mavlink", "uavplan.planners", "uavplan.cli")),
    ("obstacles.py", ("uavplan.mission", "uavplan.mavlink", "uavplan.world", "uavplan.cli")),
    ("geo.py", ("uavplan.mavlink", "uavplan.planners", "uavplan.cli", "pymavlink")),
    ("path/*.py", ("uavplan.mission", "uavplan.mavlink", "uavplan.cli", "uavplan.scenario")),
    ("planners/*.py", ("uavplan.mission", "uavplan.mavlink", "uavplan.cli", "uavplan.fileio")),
    ("mission/*.py", ("uavplan.planners", "uavplan.planning", "uavplan.mavlink", "uavplan.cli")),
    ("mavlink/*.py", ("uavplan.planners", "uavplan.planning", "uavplan.cli")),
    ("planning.py", ("uavplan.mission", "uavplan.mavlink", "uavplan.cli")),
]


@pytest.mark.parametrize(("pattern", "forbidden"), RULES, ids=[r[0] for r in RULES])
def test_layer_imports(pattern: str, forbidden: tuple[str, ...]) -> None:
    files = modules(pattern)
    assert files, pattern
    for path in files:
        bad = sorted(name for name in imports_of(path) if name.startswith(forbidden))
        assert not bad, f"{path.relative_to(PKG.parent)} imports {bad}"


def test_pymavlink_lives_only_in_the_mavlink_package() -> None:
    for path in PKG.rglob("*.py"):
        if path.parent.name == "mavlink":
            continue
        assert not any(n.startswith("pymavlink") for n in imports_of(path)), path


def test_nothing_imports_the_cli() -> None:
    for path in PKG.rglob("*.py"):
        if path.parent.name == "cli" or path.name == "__main__.py":
            continue
        assert not any(n.startswith("uavplan.cli") for n in imports_of(path)), path


def test_import_uavplan_is_light() -> None:
    code = (
        "import sys, uavplan, uavplan.scenario, uavplan.mission.items; "
        "heavy = [m for m in ('numba', 'matplotlib', 'pymavlink', 'scipy') if m in sys.modules]; "
        "print(','.join(heavy))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""
