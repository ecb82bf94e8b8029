"""Where the command line starts: ``python -m uavplan`` and the ``uavplan`` console script.

The process-wide tweaks of the command line are made here and nowhere else (importing a
module of the package changes nothing in the process):

* ``OPENBLAS_NUM_THREADS=1`` (unless the user set it): numpy's OpenBLAS starts a thread pool
  at import whose threads spin after every call; the planner's only BLAS calls are 2 × 2
  solves, so the pool is pure cost: 0.1–0.15 s of CPU per run, all of it stolen from the
  planner when the process has one core. It must be set before numpy is imported.
* the thread switch interval, 5 ms → 0.1 ms: ``plan`` imports pyproj on a daemon thread while
  the search runs (:func:`uavplan.geo.import_in_background`), and an import is Python code
  that holds the GIL; the search thread, between two calls of its compiled step, would wait
  up to the interval for each handover. With one Python thread running the interval costs
  nothing.
* the cyclic garbage collector, paused during start-up (below) and, once the command runs,
  collecting its youngest generation every :data:`GC_GEN0_THRESHOLD` new containers instead
  of every 700: reading a large scenario builds hundreds of thousands of short-lived lists
  and dicts that hold no cycles, and the frequent collections cost 10-25 % of the reading
  (CPU time to read a map of 20,000 obstacles, best of 6: 0.40 s at 700, 0.35 s at 20,000,
  0.34 s with the collector off).

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
import os
import sys

#: the thread switch interval while the command line runs (see the module doc), seconds
SWITCH_INTERVAL_S = 1e-4
#: new containers between two collections of the collector's youngest generation
GC_GEN0_THRESHOLD = 20_000


def run() -> None:
    """Run the ``uavplan`` command line on ``sys.argv``."""
    gc.disable()
    gc.set_threshold(GC_GEN0_THRESHOLD, *gc.get_threshold()[1:])
    atexit.register(gc.freeze)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    sys.setswitchinterval(min(sys.getswitchinterval(), SWITCH_INTERVAL_S))
    from uavplan import cli

    cli.resume_collector_at_start()
    cli.main()


if __name__ == "__main__":
    run()
