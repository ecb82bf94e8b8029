"""The dependency rules of the architecture (STYLE.md), checked on the source.

Every module of the package belongs to one layer; a layer may import only the layers listed
for it in :data:`ALLOWED`. Every import counts: module level, inside functions and under
``if TYPE_CHECKING:`` alike (a type-only import still couples the layers). From the bottom:

* vocabulary — errors, geo (EnuFrame, GeoPoint), obstacles, route (PlannedRoute), config
  (parameters and the planner table), geometry2d, fileio: imports nothing above it;
* world (+ the _geom kernels) → path → planners: know nothing of files, missions or MAVLink;
* mission (items, builder, files, fence, exports): knows nothing of optimisers or MAVLink;
* mavlink: the mission vocabulary only; pymavlink lives in one module of it;
* sim (the simulated vehicle and its flight model): vocabulary, mission and mavlink;
* sources (OSM, GIS and DEM readers): vocabulary only;
* scenario (the YAML reader): vocabulary and sources;
* wiring (planning, bench, render): everything but the CLI;
* cli: thin; nothing imports it.

``test_the_checker_catches_an_upward_import`` shows the check can fail.
"""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parent.parent / "uavplan"

#: layer → the files in it (globs relative to the package)
LAYERS: dict[str, tuple[str, ...]] = {
    "vocabulary": (
        "__init__.py",
        "errors.py",
        "geo.py",
        "obstacles.py",
        "route.py",
        "config.py",
        "geometry2d.py",
        "fileio.py",
    ),
    "world": ("world.py", "_geom.py"),
    "path": ("path/*.py",),
    "planners": ("planners/*.py", "warmup.py"),
    "mission": ("mission/*.py",),
    "mavlink": ("mavlink/*.py",),
    "sim": ("sim/*.py",),
    "sources": ("sources/*.py", "sources/**/*.py"),
    "scenario": ("scenario.py",),
    "wiring": ("planning.py", "bench/*.py", "render.py", "reroute.py"),
    "cli": ("cli/*.py", "__main__.py"),
}

_BELOW_WIRING = {"vocabulary", "world", "path", "planners", "mission", "mavlink", "sim", "sources"}

#: layer → the layers its modules may import
ALLOWED: dict[str, set[str]] = {
    "vocabulary": {"vocabulary"},
    "world": {"vocabulary", "world"},
    "path": {"vocabulary", "world", "path"},
    "planners": {"vocabulary", "world", "path", "planners"},
    "mission": {"vocabulary", "mission"},
    "mavlink": {"vocabulary", "mission", "mavlink"},
    "sim": {"vocabulary", "mission", "mavlink", "sim"},
    "sources": {"vocabulary", "sources"},
    "scenario": {"vocabulary", "sources", "scenario"},
    "wiring": _BELOW_WIRING | {"scenario", "wiring"},
    "cli": _BELOW_WIRING | {"scenario", "wiring", "cli"},
}

#: third-party modules allowed only in these files (relative to the package)
CONFINED = {"pymavlink": ("mavlink/connection.py",)}


def module_name(path: Path, root: Path) -> str:
    rel = path.relative_to(root.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imports_of(path: Path, root: Path) -> set[str]:
    """Every module ``path`` imports, wherever the import statement stands (function bodies
    and ``if TYPE_CHECKING:`` blocks included); relative imports resolved."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = module_name(path, root)
    if path.name != "__init__.py":
        package = package.rpartition(".")[0]
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.split(".")
                parent = parent[: len(parent) - (node.level - 1)]
                base = ".".join([*parent, base] if base else parent)
            names.add(base)
            # "from uavplan.mission import fence" imports the module uavplan.mission.fence
            names.update(f"{base}.{alias.name}" for alias in node.names)
    return names


def layer_of(path: Path, root: Path) -> str | None:
    for layer, globs in LAYERS.items():
        for pattern in globs:
            if path in set(root.glob(pattern)):
                return layer
    return None


def module_layers(root: Path) -> dict[str, str]:
    """Dotted module name → layer, for every module of the package under ``root``."""
    out = {}
    for path in root.rglob("*.py"):
        layer = layer_of(path, root)
        if layer is not None:
            out[module_name(path, root)] = layer
    return out


def violations(root: Path) -> list[str]:
    """Every import that breaks :data:`ALLOWED` or :data:`CONFINED`, as readable lines."""
    layers = module_layers(root)
    found = []
    for path in sorted(root.rglob("*.py")):
        if "__pycache__" in path.parts:
            continue
        rel = path.relative_to(root).as_posix()
        layer = layer_of(path, root)
        if layer is None:
            found.append(f"{rel}: belongs to no layer (add it to LAYERS)")
            continue
        for name in sorted(imports_of(path, root)):
            target = layers.get(name)
            if target is not None and target not in ALLOWED[layer]:
                found.append(f"{rel} ({layer}) imports {name} ({target})")
            for lib, where in CONFINED.items():
                if (name == lib or name.startswith(lib + ".")) and rel not in where:
                    found.append(f"{rel} imports {lib} (allowed only in {', '.join(where)})")
    return found


def test_every_import_follows_the_layers() -> None:
    assert violations(PKG) == []


def test_the_checker_catches_an_upward_import(tmp_path: Path) -> None:
    """A test of the test: plant upward imports in a copy of the package, one type-only and
    one inside a function, and the checker must name both."""
    root = tmp_path / "uavplan"
    shutil.copytree(PKG, root, ignore=shutil.ignore_patterns("__pycache__"))
    world = root / "world.py"
    world.write_text(
        world.read_text(encoding="utf-8")
        + "\n\nif TYPE_CHECKING:\n    from uavplan.mission.items import MissionPlan\n",
        encoding="utf-8",
    )
    geo = root / "geo.py"
    geo.write_text(
        geo.read_text(encoding="utf-8") + "\n\ndef _late():\n    from . import planning\n",
        encoding="utf-8",
    )
    found = violations(root)
    assert "world.py (world) imports uavplan.mission.items (mission)" in found
    assert "geo.py (vocabulary) imports uavplan.planning (wiring)" in found
    assert len(found) == 2


@pytest.mark.parametrize("layer", sorted(LAYERS))
def test_every_layer_has_files(layer: str) -> None:
    if layer == "sources" and not (PKG / "sources").is_dir():
        pytest.skip("no sources package")
    assert any(any(PKG.glob(g)) for g in LAYERS[layer]), layer


def test_import_uavplan_is_light() -> None:
    code = (
        "import sys, uavplan, uavplan.scenario, uavplan.mission.items; "
        "heavy = [m for m in ('numba', 'matplotlib', 'pymavlink', 'scipy') if m in sys.modules]; "
        "print(','.join(heavy))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""
