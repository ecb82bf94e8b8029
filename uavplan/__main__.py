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

Ctrl-C is exit 130 with the one line ``interrupted`` from the first statement of :func:`run`
on, before anything else is imported: a ``KeyboardInterrupt`` while the command line loads
(click, the command's module, numpy ...) is caught here, one inside a command by the command
line itself (:mod:`uavplan.cli`, which also covers calling it directly). Once the command has
ended, a Ctrl-C while the interpreter shuts down ends the process at once with the command's
exit status (no traceback from an exit handler). A parent that started the process with
SIGINT ignored keeps it ignored (Python then installs no handler, and neither does this).
Before :func:`run` the interpreter is starting (its ``site`` module, the editable install's
import hook): a Ctrl-C there is the interpreter's, a traceback or the signal's default action.
"""

import atexit
import gc
import os
import sys

# nothing else at the top: these are loaded with the interpreter, and ``signal`` (whose
# import builds its enums, a millisecond or two) loads inside run(), where a Ctrl-C is caught

#: the thread switch interval while the command line runs (see the module doc), seconds
SWITCH_INTERVAL_S = 1e-4
#: new containers between two collections of the collector's youngest generation
GC_GEN0_THRESHOLD = 20_000


#: the exit status of an interrupted command (uavplan.errors.EXIT_INTERRUPTED, not imported:
#: nothing is imported before the first Ctrl-C can be answered)
EXIT_INTERRUPTED = 130


class _EarlyCtrlC:
    """SIGINT before a command installs its own handler (:func:`uavplan.cli.common.
    interruptible`): raised as Python's own handler does, and remembered. Some compiled code
    that runs while the command line loads swallows any exception raised in Python it calls
    (a C-level ``hasattr`` clears whatever it meets, a KeyboardInterrupt too): a Ctrl-C that
    lands there would be lost and the command run to its end. The command's handler reads
    :attr:`seen` when it takes over and ends the command as interrupted."""

    seen = False

    def __call__(self, _signum: int, _frame: object) -> None:
        self.seen = True
        raise KeyboardInterrupt


def run() -> None:
    """Run the ``uavplan`` command line on ``sys.argv``."""
    try:
        try:
            import signal

            if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
                signal.signal(signal.SIGINT, _EarlyCtrlC())
            gc.disable()
            gc.set_threshold(GC_GEN0_THRESHOLD, *gc.get_threshold()[1:])
            atexit.register(gc.freeze)
            os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
            sys.setswitchinterval(min(sys.getswitchinterval(), SWITCH_INTERVAL_S))
            from uavplan import cli

            cli.resume_collector_at_start()
            cli.main()
        except (KeyboardInterrupt, Exception) as exc:
            if not _interrupt_in(exc):
                raise
            print("interrupted", file=sys.stderr, flush=True)
            raise SystemExit(EXIT_INTERRUPTED) from None
    except SystemExit as done:
        code = done.code
        status = 0 if code is None else code if isinstance(code, int) else 1
        if status == EXIT_INTERRUPTED:
            # Interrupted: end now. A Ctrl-C that lands while a compiled module runs Python
            # source of its own (Cython's module set-up does, through PyRun_String, while it
            # is imported) marks the interpreter as ending on an unhandled
            # KeyboardInterrupt, even though it was handled; the interpreter would then end
            # the process by SIGINT after its shutdown instead of with this status.
            _flush()
            os._exit(status)
        _end_on_ctrl_c(status)
        raise


def _interrupt_in(exc: BaseException) -> bool:
    """``exc`` is a KeyboardInterrupt, or one caused it (``uavplan.cli.caused_by_interrupt``,
    which may not be loaded yet)."""
    link: BaseException | None = exc
    for _ in range(100):
        if link is None:
            return False
        if isinstance(link, KeyboardInterrupt):
            return True
        link = link.__cause__ or link.__context__
    return False


def _flush() -> None:
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except Exception:  # a closed stream: nothing left to say
            pass


def _end_on_ctrl_c(status: int) -> None:
    """The command has ended with ``status``: a Ctrl-C from now on (the interpreter shuts
    down) ends the process at once with the same status, without a traceback."""

    import signal

    def end(_signum: int, _frame: object) -> None:
        _flush()
        os._exit(status)

    if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
        signal.signal(signal.SIGINT, end)


if __name__ == "__main__":
    run()
