"""The ``uavplan`` command line: a thin click layer over the library.

Each command lives in its own module under :mod:`uavplan.cli` and registers itself on
:data:`main`; this module only assembles them. Nothing in the library imports the CLI.
"""

from __future__ import annotations

import click

from uavplan import __version__


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="uavplan")
def main() -> None:
    """Plan obstacle-avoiding UAV missions and move them over MAVLink."""


def _register() -> None:
    # Imported for their side effect of adding commands to ``main``.
    from uavplan.cli import (  # noqa: F401
        bench_cmd,
        import_cmd,
        link_cmd,
        plan_cmd,
        render_cmd,
    )


_register()
