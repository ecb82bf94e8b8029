"""The dependency rules of the architecture (STYLE.md, docs/architecture.md), checked on the
source.

Every module of the package belongs to one layer; a layer may import only the layers listed
for it in :data:`ALLOWED`. Every import counts: module level, inside functions and under
``if TYPE_CHECKING:`` alike (a type-only import still couples the layers). From the bottom:

* vocabulary — errors, geo (EnuFrame, GeoPoint), obstacles, ground (the terrain's solids),
  route (PlannedRoute), outcome (how a search ended, why a route failed), config (parameters
  and the planner table), geometry2d, fileio: imports nothing above it;
* world (+ the _geom kernels) → path → planners: know nothing of files, missions or MAVLink;
* mission (items, builder, files, fence, exports): knows nothing of optimisers or MAVLink;
* mavlink: the mission vocabulary only; pymavlink lives in one module of it;
* autopilot (the firmware's parameters, kinematics, RTL, the flight model and the offline
  flight, ``simulate``): the vocabulary and the mission layer only, no wire vocabulary;
* sim (the simulated MAVLink vehicle, its mission server, faults and I/O loop): vocabulary,
  mission, mavlink and autopilot; nothing but the CLI (``mock-vehicle``) imports it;
* sources (OSM, GIS and DEM readers): vocabulary only;
* survey (camera arithmetic, lanes around holes, the sweep of least energy): vocabulary only,
  pure geometry that knows nothing of files, the world, missions or MAVLink;
* scenario (the YAML reader and the checked scenario values): vocabulary, sources and
  survey (the ``survey:`` section's camera arithmetic);
* the wiring, in four ordered tiers, each importing the layers below it and the tiers
  before it, never a later one:

  - site (worlds, airspace, flight): the World a scenario makes and a track's clearance in it;
  - flying (estimate, rehearsal, the way-home proof, verdict): how the autopilot flies a
    mission there, and whether that keeps the margin;
  - planning (planning, reroute, surveying, the way home's planning, flown_safe): the
    searches and the routes made safe as flown;
  - presentation (render, view/, bench/): pictures, the page, the comparison tables;
* app (the use cases): everything but the CLI;
* cli: thin; nothing imports it.

Two more rules: no CLI command module imports another (the shared support, ``cli/common.py``
and ``cli/options.py``, is imported by commands and imports no command), and the modules
import each other without a cycle. Each rule has a test of the test that shows it can fail.
"""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[2] / "uavplan"

#: layer → the files in it (globs relative to the package)
LAYERS: dict[str, tuple[str, ...]] = {
    "vocabulary": (
        "__init__.py",
        "errors.py",
        "geo.py",
        "obstacles.py",
        "ground.py",
        "route.py",
        "outcome.py",
        "config.py",
        "flavour.py",
        "geometry2d.py",
        "fileio.py",
        "airframe/*.py",
        "limits.py",
        "lazy.py",
    ),
    "world": ("world.py", "_geom.py"),
    "path": ("path/*.py",),
    "planners": ("planners/*.py", "warmup.py"),
    "mission": ("mission/*.py",),
    "mavlink": ("mavlink/*.py",),
    "autopilot": ("autopilot/*.py",),
    "sim": ("sim/*.py",),
    "sources": ("sources/*.py", "sources/**/*.py"),
    "survey": ("survey/*.py",),
    "scenario": ("scenario/*.py",),
    "site": ("worlds.py", "airspace.py", "flightcheck.py"),
    "flying": (
        "estimate.py",
        "rehearsal.py",
        "wayhome/__init__.py",
        "wayhome/proof.py",
        "verdict.py",
    ),
    "planning": ("planning.py", "reroute.py", "surveying.py", "wayhome/home.py", "flown_safe.py"),
    "presentation": ("render.py", "view/*.py", "bench/*.py"),
    "app": ("app/*.py",),
    "cli": ("cli/*.py", "__main__.py"),
}

#: the layers below the wiring that the wiring may use (not the simulated vehicle)
_BELOW_WIRING = {
    "vocabulary",
    "world",
    "path",
    "planners",
    "mission",
    "mavlink",
    "autopilot",
    "sources",
    "survey",
    "scenario",
}

#: the wiring's tiers, in order: each may import the ones before it, never a later one
WIRING = ("site", "flying", "planning", "presentation")

#: layer → the layers its modules may import
ALLOWED: dict[str, set[str]] = {
    "vocabulary": {"vocabulary"},
    "world": {"vocabulary", "world"},
    "path": {"vocabulary", "world", "path"},
    "planners": {"vocabulary", "world", "path", "planners"},
    "mission": {"vocabulary", "mission"},
    "mavlink": {"vocabulary", "mission", "mavlink"},
    "autopilot": {"vocabulary", "mission", "autopilot"},
    "sim": {"vocabulary", "mission", "mavlink", "autopilot", "sim"},
    "sources": {"vocabulary", "sources"},
    "survey": {"vocabulary", "survey"},
    "scenario": {"vocabulary", "sources", "survey", "scenario"},
    **{tier: _BELOW_WIRING | set(WIRING[: i + 1]) for i, tier in enumerate(WIRING)},
    "app": _BELOW_WIRING | set(WIRING) | {"app"},
    "cli": _BELOW_WIRING | set(WIRING) | {"sim", "app", "cli"},
}

#: the CLI's shared support: commands import it, it imports no command
CLI_SUPPORT = ("__init__.py", "common.py", "options.py")

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


def command_imports(root: Path) -> list[str]:
    """Every import of a CLI command module by a module under ``cli/``: a command importing
    another command, or the shared support (:data:`CLI_SUPPORT`) importing one."""
    cli = root / "cli"
    commands = {
        module_name(path, root) for path in cli.glob("*.py") if path.name not in CLI_SUPPORT
    }
    found = []
    for path in sorted(cli.glob("*.py")):
        for name in sorted(imports_of(path, root) & commands):
            if name != module_name(path, root):
                found.append(f"cli/{path.name} imports {name}")
    return found


def import_cycles(root: Path) -> list[list[str]]:
    """The import cycles among the package's modules (every import counts, as above): each
    strongly connected component of more than one module, sorted."""
    paths = {module_name(p, root): p for p in root.rglob("*.py") if "__pycache__" not in p.parts}
    graph = {
        m: sorted(i for i in imports_of(p, root) if i in paths and i != m) for m, p in paths.items()
    }
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []

    def visit(v: str) -> None:  # Tarjan's algorithm
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for module in sorted(graph):
        if module not in index:
            visit(module)
    return sorted(cycles)


@pytest.mark.slow
def test_every_import_follows_the_layers() -> None:
    assert violations(PKG) == []


@pytest.mark.slow
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
    assert "geo.py (vocabulary) imports uavplan.planning (planning)" in found
    assert len(found) == 2


#: (file, planted import, the line the checker must print): one per rule of the autopilot
#: layer, the simulated vehicle and the wiring's order
PLANTED = [
    (
        "autopilot/simulate.py",
        "from uavplan.mavlink.modes import ModeKind",
        "autopilot/simulate.py (autopilot) imports uavplan.mavlink.modes (mavlink)",
    ),
    (
        "autopilot/model.py",
        "from uavplan.sim.vehicle import SimVehicle",
        "autopilot/model.py (autopilot) imports uavplan.sim.vehicle (sim)",
    ),
    (
        "app/fly.py",
        "from uavplan.sim.vehicle import SimVehicle",
        "app/fly.py (app) imports uavplan.sim.vehicle (sim)",
    ),
    (
        "rehearsal.py",
        "from uavplan.sim.faults import Faults",
        "rehearsal.py (flying) imports uavplan.sim.faults (sim)",
    ),
    (
        "flightcheck.py",
        "from uavplan.rehearsal import simulate",
        "flightcheck.py (site) imports uavplan.rehearsal (flying)",
    ),
    (
        "estimate.py",
        "from uavplan.planning import plan_route",
        "estimate.py (flying) imports uavplan.planning (planning)",
    ),
    (
        "planning.py",
        "from uavplan.render import Scene",
        "planning.py (planning) imports uavplan.render (presentation)",
    ),
]


@pytest.mark.parametrize(("rel", "planted", "expected"), PLANTED, ids=[p[0] for p in PLANTED])
@pytest.mark.slow
def test_the_checker_catches_each_new_rule(
    tmp_path: Path, rel: str, planted: str, expected: str
) -> None:
    """A test of the test: in a copy of the package, one import inside a function that breaks
    one rule (the autopilot below the wire and the vehicle; only the CLI imports the vehicle;
    the wiring's tiers in order), and the checker names exactly it."""
    root = tmp_path / "uavplan"
    shutil.copytree(PKG, root, ignore=shutil.ignore_patterns("__pycache__"))
    target = root / rel
    target.write_text(
        target.read_text(encoding="utf-8") + f"\n\ndef _late():\n    {planted}\n",
        encoding="utf-8",
    )
    assert violations(root) == [expected]


def test_the_wiring_tiers_are_ordered() -> None:
    """Each tier may use the ones before it and none after it; the application uses them all
    and the simulated vehicle only through the CLI."""
    for i, tier in enumerate(WIRING):
        assert set(WIRING[: i + 1]) <= ALLOWED[tier]
        assert not set(WIRING[i + 1 :]) & ALLOWED[tier]
        assert "sim" not in ALLOWED[tier]
    assert "sim" not in ALLOWED["app"] and "sim" in ALLOWED["cli"]
    assert ALLOWED["autopilot"] == {"vocabulary", "mission", "autopilot"}


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


#: modules the flight-side use cases must not load: they check and fly, they never plan
PLANNING_MODULES = ("uavplan.planners", "uavplan.planning", "uavplan.reroute")
#: the use cases that fly, simulate or check a mission (``fly``, ``simulate``, ``validate``)
FLIGHT_SIDE = ("uavplan.app.fly", "uavplan.app.simulate", "uavplan.app.check")


def planning_loaded(modules: list[str]) -> list[str]:
    """The modules of ``modules`` (names as in ``sys.modules``) that belong to the planning
    side (:data:`PLANNING_MODULES` and the modules under them), sorted."""
    return sorted(
        m for m in modules if any(m == p or m.startswith(p + ".") for p in PLANNING_MODULES)
    )


def modules_after_import(module: str) -> list[str]:
    """The uavplan modules a fresh interpreter holds after ``import module``."""
    code = (
        f"import sys, {module}; "
        "print('\\n'.join(m for m in sys.modules if m.split('.')[0] == 'uavplan'))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return out.stdout.split()


@pytest.mark.parametrize("module", FLIGHT_SIDE)
def test_the_flight_side_does_not_load_the_planners(module: str) -> None:
    """``fly``, ``simulate`` and ``validate`` rehearse and check against the worlds of
    :mod:`uavplan.worlds`; planning again lives in :mod:`uavplan.flown_safe`. Importing them
    loads no planner (issue 36: fly loaded 77 modules, the planners and their kernels)."""
    loaded = modules_after_import(module)
    assert module in loaded  # the subprocess did import it
    assert planning_loaded(loaded) == []


def test_the_checker_catches_a_planner_loaded() -> None:
    """A test of the test: a module list as ``fly`` loaded before the fix (the planners'
    base, planning and reroute) is flagged, and names that only start alike are not."""
    before = [
        "uavplan",
        "uavplan.app.fly",
        "uavplan.rehearsal",
        "uavplan.planners",
        "uavplan.planners.base",
        "uavplan.planning",
        "uavplan.reroute",
        "uavplan.rerouted",
        "uavplan.planning_notes",
    ]
    assert planning_loaded(before) == [
        "uavplan.planners",
        "uavplan.planners.base",
        "uavplan.planning",
        "uavplan.reroute",
    ]
    assert planning_loaded(["uavplan", "uavplan.rehearsal", "uavplan.worlds"]) == []


def test_no_command_imports_another() -> None:
    assert command_imports(PKG) == []


@pytest.mark.slow
def test_the_checker_catches_a_command_importing_a_command(tmp_path: Path) -> None:
    """A test of the test: in a copy of the package, a command imports another inside a
    function (as render took plan's helpers) and the shared support imports a command."""
    root = tmp_path / "uavplan"
    shutil.copytree(PKG, root, ignore=shutil.ignore_patterns("__pycache__"))
    render = root / "cli" / "render_cmd.py"
    render.write_text(
        render.read_text(encoding="utf-8")
        + "\n\ndef _late():\n    from uavplan.cli.plan_cmd import plan_command\n",
        encoding="utf-8",
    )
    common = root / "cli" / "common.py"
    common.write_text(
        common.read_text(encoding="utf-8") + "\n\nfrom uavplan.cli import check_cmd\n",
        encoding="utf-8",
    )
    assert command_imports(root) == [
        "cli/common.py imports uavplan.cli.check_cmd",
        "cli/render_cmd.py imports uavplan.cli.plan_cmd",
    ]
    assert violations(root) == []  # the layers alone would not see it


@pytest.mark.slow
def test_no_import_cycle() -> None:
    assert import_cycles(PKG) == []


@pytest.mark.slow
def test_the_checker_catches_an_import_cycle(tmp_path: Path) -> None:
    """A test of the test: in a copy of the package, the scenario's loader imports its values
    inside a function, which import the loader: a cycle within one layer, which the layer
    rules allow and this check must catch."""
    root = tmp_path / "uavplan"
    shutil.copytree(PKG, root, ignore=shutil.ignore_patterns("__pycache__"))
    load = root / "scenario" / "load.py"
    load.write_text(
        load.read_text(encoding="utf-8")
        + "\n\ndef _late():\n    from uavplan.scenario.values import Scenario\n",
        encoding="utf-8",
    )
    assert import_cycles(root) == [["uavplan.scenario.load", "uavplan.scenario.values"]]
    assert violations(root) == []
