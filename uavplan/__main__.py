"""Where the command line starts: ``python -m uavplan`` and the ``uavplan`` console script.

Start-up builds some hundred thousand objects that live as long as the process (modules,
classes, functions); the cyclic collector would walk them over and over while they are made,
and once more at exit. So :func:`run` pauses the collector before the first import; when the
command starts, what start-up built is frozen out of later collections and the collector runs
again (:func:`uavplan.cli.startup_done`); at exit everything is frozen, since the
process is ending and its memory goes back to the system anyway. Together about 3 % of the
instructions of a whole ``uavplan plan`` on a paper environment, 12 % of ``uavplan --help``
(callgrind). Calling :data:`uavplan.cli.main` directly (tests, other programs) leaves the
collector alone.
"""

from __future__ import annotations

import atexit
import gc


def run() -> None:
    """Run the ``uavplan`` command line on ``sys.argv``."""
    gc.disable()
    atexit.register(gc.freeze)
    from uavplan import cli

    cli.resume_collector_at_start()
    cli.main()


if __name__ == "__main__":
    run()
