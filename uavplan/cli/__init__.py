"""The ``uavplan`` command line: a thin click layer over the library.

Each command lives in a module under :mod:`uavplan.cli` and registers itself on :data:`main`;
this module only assembles them. A command parses its options, calls one use case of
:mod:`uavplan.app` and prints the outcome. Command modules import this package,
:mod:`uavplan.cli.common` and :mod:`uavplan.cli.options`, never each other; nothing in the
library imports the CLI. Importing this package changes nothing in the process: start-up
tweaks are the entry point's (:mod:`uavplan.__main__`).

Start-up is part of the product (``uavplan --help`` in well under a tenth of a second): the
command modules are imported only when their command runs. :data:`COMMANDS` names each
command's module and the one-line help ``uavplan --help`` lists, so listing the commands
imports none of them (tests/architecture/test_startup.py checks the table against the commands).
"""

from __future__ import annotations

import gc
import importlib
import sys
from typing import Any, NoReturn

import click

from uavplan import __version__
from uavplan.errors import EXIT_INTERRUPTED

#: command name → (the module that defines it, its one-line help as ``--help`` lists it)
COMMANDS: dict[str, tuple[str, str]] = {
    "bench": (
        "bench_cmd",
        "Run every algorithm RUNS times on each SCENARIO and print the paper's Table 2 twice: "
        "mean / worst / best / std of the raw search result and of the post-processed route "
        "energy, with collision-free runs, evaluations, reachability checks and wall time per "
        "run.",
    ),
    "clear": ("link_cmd", "Clear the vehicle's mission, geofence, rally points, or all three."),
    "convert": (
        "convert_cmd",
        "Convert mission file IN to OUT; the formats come from the extensions.",
    ),
    "download": (
        "link_cmd",
        "Read the vehicle's mission (and geofence / rally points for a .plan) into a file.",
    ),
    "fly": (
        "fly_cmd",
        "Fly MISSION on the vehicle at CONN: check it, start it, follow it to the landing.",
    ),
    "import": (
        "import_cmd",
        "Read buildings and tall structures from SOURCE (.osm, .osm.pbf, GeoJSON, GeoPackage, "
        "Shapefile, KML, ...) and write them as an editable map file (YAML).",
    ),
    "mock-vehicle": ("link_cmd", "Run a simulated vehicle on CONN until SIGINT / SIGTERM."),
    "plan": (
        "plan_cmd",
        "Plan a collision-free route for SCENARIO and write it as a mission file.",
    ),
    "render": (
        "render_cmd",
        "Draw SCENARIO in 3-D and from above, with a planned route or a mission's route.",
    ),
    "simulate": (
        "simulate_cmd",
        "Fly MISSION through the flight model, in simulated time, without a vehicle.",
    ),
    "upload": (
        "link_cmd",
        "Upload a .plan / .waypoints MISSION (with the .plan's geofence and rally points).",
    ),
    "validate": ("check_cmd", "Check a scenario file, or a mission file against a scenario."),
    "view": (
        "view_cmd",
        "Write one interactive page of MISSION (with --scenario) or of a SCENARIO alone.",
    ),
}


#: set when the entry point paused the cyclic collector for start-up (uavplan.__main__)
_collector_paused = False


def resume_collector_at_start() -> None:
    """Called by the entry point that paused the collector: :func:`startup_done` resumes it."""
    global _collector_paused
    _collector_paused = True


def startup_done() -> None:
    """A command starts (before its module is imported): if the entry point paused the cyclic
    collector for start-up, freeze what start-up built out of later collections and turn the
    collector back on."""
    global _collector_paused
    if _collector_paused:
        _collector_paused = False
        gc.freeze()
        gc.enable()


def interrupted() -> NoReturn:
    """Ctrl-C: the one line ``interrupted`` on stderr and exit 130 (nothing was written)."""
    click.echo("interrupted", err=True)
    sys.exit(EXIT_INTERRUPTED)


def caused_by_interrupt(exc: BaseException) -> bool:
    """Is ``exc`` a KeyboardInterrupt, or did one cause it? (Python wraps one that lands in
    some places: a class attribute's ``__set_name__`` turns it into a RuntimeError.)"""
    seen: set[int] = set()
    link: BaseException | None = exc
    while link is not None and id(link) not in seen:
        if isinstance(link, KeyboardInterrupt):
            return True
        seen.add(id(link))
        link = link.__cause__ or link.__context__
    return False


class _LazyGroup(click.Group):
    """A group whose commands are imported on first use (see :data:`COMMANDS`)."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*COMMANDS, *self.commands})

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name not in self.commands and cmd_name in COMMANDS:
            importlib.import_module(f"uavplan.cli.{COMMANDS[cmd_name][0]}")
        return self.commands.get(cmd_name)

    # click answers a KeyboardInterrupt with a blank line, "Aborted!" and exit 1; ours is
    # one line and exit 130, wherever it lands: parsing, importing the command, running it

    def make_context(
        self,
        info_name: str | None,
        args: list[str],
        parent: click.Context | None = None,
        **extra: Any,
    ) -> click.Context:
        try:
            return super().make_context(info_name, args, parent, **extra)
        except (KeyboardInterrupt, Exception) as exc:
            if caused_by_interrupt(exc):
                interrupted()
            raise

    def invoke(self, ctx: click.Context) -> Any:
        try:
            startup_done()
            return super().invoke(ctx)
        except (KeyboardInterrupt, Exception) as exc:
            if caused_by_interrupt(exc):
                interrupted()
            raise

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        # the listing from the table: no command module is imported to print it
        names = self.list_commands(ctx)
        if not names:
            return
        limit = formatter.width - 6 - max(len(n) for n in names)
        rows = []
        for name in names:
            if name in COMMANDS:
                text = click.Command(name, help=COMMANDS[name][1]).get_short_help_str(limit)
            else:  # registered at run time by someone else
                text = self.commands[name].get_short_help_str(limit)
            rows.append((name, text))
        with formatter.section("Commands"):
            formatter.write_dl(rows)


@click.group(cls=_LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="uavplan")
def main() -> None:
    """Plan obstacle-avoiding UAV missions and move them over MAVLink."""


def load_all_commands() -> dict[str, Any]:
    """Import every command module; the registered commands by name (tests, completion)."""
    for module in sorted({m for m, _ in COMMANDS.values()}):
        importlib.import_module(f"uavplan.cli.{module}")
    return dict(main.commands)
