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
* glibc's malloc maps every block of :data:`MMAP_THRESHOLD_BYTES` or more on its own,
  which goes back to the system when it is freed. Left to itself, glibc raises that
  threshold to the size of the largest mapped block freed so far (up to 32 MB): after the
  first large array is freed, the next ones (a planner's clearance table, a path problem's
  memo, a height field's temporaries, each a few to 25 MB) come from the heap, and what is
  freed there stays resident wherever a smaller block outlives it. Over a 20 km × 20 km
  terrain area that left some 15 MiB more at the peak of ``plan`` (issue 26: 200 MB
  everywhere); a fixed threshold turns the dynamic one off. The values computed are the
  same; only where the memory comes from changes (:func:`fix_mmap_threshold`).

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
import hook): a Ctrl-C there is the interpreter's, a traceback, the signal's default action,
or, in a callback of the import system's locks, "Exception ignored" and the command runs on.
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


#: glibc's malloc maps blocks of at least this many bytes on their own (its initial
#: threshold, held fixed: see the module doc)
MMAP_THRESHOLD_BYTES = 128 * 1024
#: mallopt's parameter number for it (malloc.h M_MMAP_THRESHOLD)
_M_MMAP_THRESHOLD = -3

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


def fix_mmap_threshold() -> bool:
    """Hold glibc's mmap threshold at :data:`MMAP_THRESHOLD_BYTES` (see the module doc);
    False where the C library is not glibc (nothing changed)."""
    try:
        glibc = os.confstr("CS_GNU_LIBC_VERSION")
    except (ValueError, OSError, AttributeError):  # no such name here, or no confstr
        glibc = None
    if not glibc:
        return False
    import ctypes  # 1.5 ms of the start-up

    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    return bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES))


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
            fix_mmap_threshold()
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
