"""Start-up loads only what a command needs (issue 13).

``uavplan --help`` imports no command module and none of the heavy libraries;
``uavplan validate`` of a scenario needs neither the planner's kernels (numba) nor scipy,
matplotlib or pyproj. Checked in a fresh interpreter each (``sys.modules`` after the command),
never by wall time.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

ROOT = Path(__file__).resolve().parents[2]
HEAVY = ("numba", "llvmlite", "scipy", "matplotlib", "pyproj", "pymavlink", "osmium", "rasterio")


def loaded_after(*args: str) -> tuple[int, set[str], str]:
    """(exit code, every module loaded, stderr) of ``uavplan ARGS`` run in a fresh
    interpreter."""
    code = (
        "import sys, json\n"
        "from uavplan.cli import main\n"
        "try:\n"
        f"    main({list(args)!r})\n"
        "except SystemExit as exc:\n"
        "    rc = exc.code or 0\n"
        "print(json.dumps([rc, sorted(sys.modules)]))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=ROOT
    )
    rc, mods = json.loads(out.stdout.strip().splitlines()[-1])
    return rc, set(mods), out.stderr


def modules_after(*args: str) -> tuple[int, set[str]]:
    """(exit code, top-level modules and uavplan modules loaded) of ``uavplan ARGS`` run in a
    fresh interpreter."""
    rc, mods, _ = loaded_after(*args)
    return rc, {m.split(".")[0] for m in mods} | {m for m in mods if m.startswith("uavplan")}


def test_help_imports_no_command_and_no_heavy_library() -> None:
    rc, mods = modules_after("--help")
    assert rc == 0
    assert not {m for m in mods if m.startswith("uavplan.cli.")}, mods
    assert not mods & {*HEAVY, "numpy", "yaml"}, mods & {*HEAVY, "numpy", "yaml"}


def test_validate_needs_no_kernels_and_no_heavy_library() -> None:
    rc, mods = modules_after("validate", str(ROOT / "missions" / "paper-env1.yaml"))
    assert rc == 0
    # a small scenario is checked in plain Python; its flight estimate (issue 27) is the
    # power model's, in numpy, but needs no world, no kernels and no heavy library
    assert not mods & {*HEAVY}, mods & {*HEAVY}
    assert "uavplan.world" not in mods and "uavplan.planners" not in mods
    assert "uavplan._ckernels" not in mods


def test_the_command_table_matches_the_commands() -> None:
    """``uavplan --help`` lists the commands from :data:`uavplan.cli.COMMANDS` without
    importing them: every command is in the table, in its module, with its own help line,
    and the listing is the one click prints with every command loaded."""
    import click

    from uavplan.cli import COMMANDS, load_all_commands, main

    lazy = CliRunner().invoke(main, ["--help"], prog_name="uavplan").output
    commands = load_all_commands()
    assert set(commands) == set(COMMANDS)
    for name, cmd in commands.items():
        module, short = COMMANDS[name]
        assert cmd.callback is not None
        assert f"uavplan.cli.{module}" in {cmd.callback.__module__, *_wrapped_modules(cmd)}
        assert cmd.get_short_help_str(10_000) == short, name
    eager = click.Group(
        "uavplan", commands=commands, context_settings=main.context_settings, help=main.help
    )
    eager.params = main.params
    assert lazy == CliRunner().invoke(eager, ["--help"], prog_name="uavplan").output


def _wrapped_modules(cmd: object) -> set[str]:
    fn = getattr(cmd, "callback", None)
    out = set()
    while fn is not None:
        out.add(getattr(fn, "__module__", ""))
        fn = getattr(fn, "__wrapped__", None)
    return out


def test_an_unknown_command_is_still_refused() -> None:
    from uavplan.cli import main

    result = CliRunner().invoke(main, ["nonsense"])
    assert result.exit_code == 2
    assert "No such command" in result.output


def _loaded_by_importing_numpy() -> set[str]:
    out = subprocess.run(
        [sys.executable, "-c", "import sys, numpy; print(' '.join(sys.modules))"],
        capture_output=True, text=True, check=True, timeout=60,
    )  # fmt: skip
    return set(out.stdout.split())


@pytest.mark.slow
def test_plan_loads_only_what_planning_needs(tmp_path: Path) -> None:
    """A plan needs numpy, PyYAML, the kernels and pyproj (for the geodetic mission), not
    scipy, matplotlib, MAVLink or the GIS readers, and not numpy.ma (np.median and np.unique
    would pull it in: 20 ms of every plan). A .plan needs neither the map exports nor the
    .waypoints format, and a route the straight columns hold needs no grid search (together
    about 25 ms of imports)."""
    rc, loaded, err = loaded_after(
        "plan", str(ROOT / "missions" / "paper-env1.yaml"), "-o", str(tmp_path / "p.plan"), "-q",
        "--iterations", "20",
    )  # fmt: skip
    assert rc == 0, err
    assert {"numpy", "yaml", "pyproj", "uavplan._ckernels"} <= loaded
    unwanted = {*HEAVY, "shapely", "pyogrio", "numpy.ma"} - {"pyproj"}
    unwanted -= _loaded_by_importing_numpy()  # numpy 1.26 imports numpy.ma itself
    unwanted |= {f"uavplan.mission.{m}" for m in ("export", "fence", "waypoints_file")}
    unwanted |= {"uavplan.planners.astar", "uavplan.planners.guide"}
    assert not loaded & unwanted, loaded & unwanted


def test_background_import_loads_the_module_and_fails_silently() -> None:
    """``plan`` imports pyproj on a daemon thread during the search: the thread really
    imports it (a second call has nothing to do), and a module that cannot be imported
    prints nothing (its import where it is used reports it)."""
    code = (
        "import sys\n"
        "from uavplan.geo import import_in_background\n"
        "assert 'pyproj' not in sys.modules\n"
        "t = import_in_background()\n"
        "t.join(60)\n"
        "assert 'pyproj' in sys.modules and import_in_background() is None\n"
        "assert sys.getswitchinterval() == 0.005, sys.getswitchinterval()  # untouched\n"
        "import_in_background('uavplan_no_such_module').join(60)\n"
        "print('ok')\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=ROOT
    )
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr
    assert out.stderr == ""


GC_PROBE = """
import gc, json, sys
import click
from uavplan.cli import main

@main.command("probe-gc")
def probe_gc() -> None:
    click.echo(json.dumps([gc.isenabled(), gc.get_freeze_count()]))

sys.argv = ["uavplan", *sys.argv[1:]]
{start}
"""


def test_the_entry_point_pauses_the_collector_only_for_start_up() -> None:
    """``uavplan`` / ``python -m uavplan`` start with the cyclic collector paused; a command
    runs with it on again and start-up's objects frozen out of its collections."""
    code = GC_PROBE.format(start="from uavplan.__main__ import run\nrun()")
    out = subprocess.run(
        [sys.executable, "-c", code, "probe-gc"], capture_output=True, text=True, timeout=60
    )
    assert out.returncode == 0, out.stderr
    enabled, frozen = json.loads(out.stdout)
    assert enabled and frozen > 1000, (enabled, frozen)
    # --help runs no command: the collector stays paused until exit (nothing to resume)
    code = GC_PROBE.format(
        start="from uavplan.__main__ import run\ntry:\n    run()\nexcept SystemExit:\n    pass\n"
        "print(json.dumps([gc.isenabled(), gc.get_freeze_count(),"
        " sorted(m for m in sys.modules if m.startswith('uavplan.cli.'))]))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code, "--help"], capture_output=True, text=True, timeout=60
    )
    # ... and the entry point itself loads no command module for it
    assert json.loads(out.stdout.strip().splitlines()[-1]) == [False, 0, []]


def test_calling_the_cli_directly_leaves_the_collector_alone() -> None:
    """Tests and other programs call :data:`uavplan.cli.main` directly: their collector is
    their business."""
    import gc

    from uavplan.cli import main

    before = (gc.isenabled(), gc.get_freeze_count())
    result = CliRunner().invoke(main, ["validate", str(ROOT / "missions" / "paper-env1.yaml")])
    assert result.exit_code == 0, result.output
    assert (gc.isenabled(), gc.get_freeze_count()) == before


def test_the_console_script_is_the_entry_point() -> None:
    import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert project["scripts"]["uavplan"] == "uavplan.__main__:run"


@pytest.mark.slow
def test_importing_and_reading_change_nothing_in_the_process() -> None:
    """Importing the command line and the library, reading a scenario and starting a
    background import leave the process as it was: no environment variable set, the thread
    switch interval and the garbage collector untouched (start-up tweaks are the entry
    point's alone)."""
    code = (
        "import gc, json, os, sys\n"
        "os.environ.pop('OPENBLAS_NUM_THREADS', None)\n"
        "switch = sys.getswitchinterval()\n"
        "paused = []\n"
        "real_disable = gc.disable\n"
        "gc.disable = lambda: (paused.append(1), real_disable())\n"
        "import uavplan.cli, uavplan.geo, uavplan.scenario, uavplan.app.check\n"
        "from uavplan.cli import load_all_commands\n"
        "load_all_commands()\n"
        f"uavplan.scenario.load_scenario({str(ROOT / 'missions' / 'via-tour.yaml')!r})\n"
        "uavplan.geo.import_in_background('pyproj').join(60)\n"
        "print(json.dumps([os.environ.get('OPENBLAS_NUM_THREADS'),\n"
        "                  sys.getswitchinterval() == switch, paused, gc.isenabled(),\n"
        "                  gc.get_threshold()[0]]))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=ROOT
    )
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout.strip().splitlines()[-1]) == [None, True, [], True, 700]


def test_the_entry_point_makes_the_start_up_tweaks() -> None:
    """``uavplan`` (the entry point) sets OPENBLAS_NUM_THREADS unless the user did, lowers
    the thread switch interval and raises the collector's youngest threshold."""
    probe = GC_PROBE.replace(
        "click.echo(json.dumps([gc.isenabled(), gc.get_freeze_count()]))",
        "import os\n    click.echo(json.dumps([os.environ.get('OPENBLAS_NUM_THREADS'),"
        " sys.getswitchinterval(), gc.get_threshold()[0]]))",
    )
    from uavplan.__main__ import GC_GEN0_THRESHOLD, SWITCH_INTERVAL_S

    code = probe.format(start="from uavplan.__main__ import run\nrun()")
    for env, expected in (({}, "1"), ({"OPENBLAS_NUM_THREADS": "3"}, "3")):
        environ = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
        out = subprocess.run(
            [sys.executable, "-c", code, "probe-gc"],
            capture_output=True, text=True, timeout=60, env={**environ, **env},
        )  # fmt: skip
        assert out.returncode == 0, out.stderr
        blas, switch, threshold = json.loads(out.stdout)
        assert (blas, threshold) == (expected, GC_GEN0_THRESHOLD)
        assert switch == pytest.approx(SWITCH_INTERVAL_S)  # stored in microseconds
