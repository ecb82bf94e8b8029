"""What the CLI commands share: error → exit code mapping, the Ctrl-C flag, progress on
stderr and the :class:`~uavplan.app.feedback.Feedback` a use case talks through.

Commands import this module and :mod:`uavplan.cli.options`; neither imports a command module,
and no command module imports another (tests/architecture/test_layering.py)."""

from __future__ import annotations

import contextlib
import functools
import os
import signal
import sys
import threading
import time
import warnings
from collections.abc import Callable, Iterator
from typing import Any, NoReturn, TypeVar

import click

from uavplan.app.feedback import Feedback
from uavplan.cli import caused_by_interrupt, interrupted
from uavplan.errors import EXIT_INTERNAL, InputError, UavplanError

F = TypeVar("F", bound=Callable[..., Any])


def handle_errors(fn: F) -> F:
    """Turn a :class:`UavplanError` into one message on stderr and its exit code.

    Anything else is an internal error: one line naming it, exit 1 (a traceback only with
    ``UAVPLAN_DEBUG=1``).
    """

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            with warnings.catch_warnings():
                if not os.environ.get("UAVPLAN_DEBUG"):
                    # numerical noise (overflow in a wild proposal, 0/0 in a degenerate
                    # leg) is handled where it matters; it is not the user's business
                    warnings.simplefilter("ignore", RuntimeWarning)
                return fn(*args, **kwargs)
        except UavplanError as err:
            click.echo(f"error: {err}", err=True)
            sys.exit(err.exit_code)
        except KeyboardInterrupt:
            interrupted()
        except (click.ClickException, click.exceptions.Exit, click.exceptions.Abort):
            raise
        except Exception as err:  # pragma: no cover - the last line of defence
            if caused_by_interrupt(err):
                interrupted()
            if os.environ.get("UAVPLAN_DEBUG"):
                raise
            click.echo(f"internal error: {type(err).__name__}: {err}", err=True)
            sys.exit(EXIT_INTERNAL)

    return wrapper  # type: ignore[return-value]


def exit_interrupted() -> NoReturn:
    """A use case stopped on Ctrl-C: say so and exit 130 (nothing was written)."""
    interrupted()


#: the most threads UAVPLAN_THREADS may give the SPSA step (the kernels' limit,
#: uavplan.planners._kernels.STEP_THREADS_MAX, not imported here: tests/app/test_user_errors.py
#: holds the two equal)
MAX_STEP_THREADS = 8


def check_threads_variable(warn: Callable[[str], None]) -> None:
    """``UAVPLAN_THREADS``, read by the planner, must be a whole number of threads: anything
    else is exit 2 naming the variable (it used to be ignored without a word); more than the
    step runs on is a warning."""
    text = os.environ.get("UAVPLAN_THREADS")
    if text is None or not text.strip():
        return
    value = text.strip()
    if not (value.isdigit() and int(value) >= 1):
        raise InputError(
            f"expected a whole number of threads for the planner, 1 to {MAX_STEP_THREADS} "
            f"(1: one thread), got {text!r}",
            key="UAVPLAN_THREADS",
        )
    if int(value) > MAX_STEP_THREADS:
        warn(
            f"warning: UAVPLAN_THREADS={value}: the planner's step runs on at most "
            f"{MAX_STEP_THREADS} threads"
        )


def _say(line: str) -> None:
    click.echo(line, err=True)


def warn(line: str) -> None:
    """A warning on stderr (shown with --quiet too)."""
    click.echo(line, err=True)


def _nothing(_line: str) -> None:
    pass


def feedback(
    quiet: bool, interrupts: Interrupts | None = None, *, progress: bool = True
) -> Feedback:
    """The use case's feedback on stderr: notes unless ``quiet``, warnings always, a
    progress bar on a terminal (not ``quiet``), and Ctrl-C (``interrupts``, from
    :func:`interruptible`: its flag is ``should_stop``)."""
    return Feedback(
        say=_nothing if quiet else _say,
        warn=_say,
        progress=Progress(show_progress(quiet)) if progress else None,
        should_stop=None if interrupts is None else interrupts.should_stop,
        interrupts=interrupts,
    )


def show_progress(quiet: bool) -> bool:
    """Progress goes to stderr only when it is a terminal and the user did not ask quiet."""
    return not quiet and sys.stderr.isatty()


class Interrupts:
    """The CLI's Ctrl-C for one command (:class:`uavplan.app.feedback.Interrupts`).

    Three states: *armed* (the default): a Ctrl-C raises ``KeyboardInterrupt`` at once, so
    reading, drawing or building a fence stops where it is and the use case's output set
    removes what it made; *polled* (inside :meth:`polled`, a planner's search): the first
    Ctrl-C only sets the flag :meth:`should_stop` reads, the search stops at its next
    iteration and its result says so (never inside a compiled step, mid-update), a second
    one raises at once; *closed* (from :meth:`commit_point` on): the outputs are being moved
    into place, or are; a Ctrl-C is too late to undo the command and is ignored."""

    ARMED, POLLED, CLOSED = "armed", "polled", "closed"

    def __init__(self) -> None:
        self.hit = threading.Event()
        self.state = self.ARMED

    def should_stop(self) -> bool:
        return self.hit.is_set()

    def on_sigint(self, _signum: int, _frame: object) -> None:
        if self.state == self.CLOSED:
            return
        first = not self.hit.is_set()
        self.hit.set()
        if self.state == self.POLLED and first:
            return
        raise KeyboardInterrupt

    @contextlib.contextmanager
    def polled(self) -> Iterator[None]:
        if self.state != self.ARMED:
            yield
            return
        self.state = self.POLLED
        try:
            yield
        finally:
            if self.state == self.POLLED:
                self.state = self.ARMED

    def commit_point(self) -> None:
        self.state = self.CLOSED  # first: a Ctrl-C from here on is ignored ...
        if self.hit.is_set():  # ... and one that came before is honoured
            self.state = self.ARMED
            raise KeyboardInterrupt


@contextlib.contextmanager
def interruptible() -> Iterator[Interrupts]:
    """Ctrl-C (SIGINT) for the command that runs in the block: :class:`Interrupts`, whose
    :meth:`~Interrupts.should_stop` is the planners' poll. A command calls its use case and
    prints the outcome inside the block, so that once the outputs are in place a Ctrl-C stays
    ignored until the command returns. After a Ctrl-C, whatever the block ends with is the
    interrupt (exit 130). Off the main thread (where no signal handler can be set) a Ctrl-C is
    the caller's business; the flag then stays unset."""
    gate = Interrupts()
    if threading.current_thread() is not threading.main_thread():
        yield gate
        return
    previous = signal.signal(signal.SIGINT, gate.on_sigint)
    try:
        if getattr(previous, "seen", False):
            # a Ctrl-C came while the command line loaded and was lost on the way (the
            # entry point's handler remembers it: uavplan.__main__._EarlyCtrlC)
            gate.hit.set()
            raise KeyboardInterrupt
        yield gate
    except (KeyboardInterrupt, Exception) as exc:
        # after a Ctrl-C, whatever the command ends with is the interrupt (a library that
        # caught the KeyboardInterrupt and raised something else, or failed for want of it)
        if gate.hit.is_set() or caused_by_interrupt(exc):
            interrupted()
        raise
    finally:
        signal.signal(signal.SIGINT, previous)


class Progress:
    """The one progress bar of the CLI (plan, render, bench, transfers): on stderr, throttled
    to about 10 updates a second, drawn only when ``enabled`` (a terminal, not ``--quiet``).

    ``show(done, total, detail)`` moves it; a new ``label`` starts a new bar (a transfer's
    phases). Called as ``progress(iteration, total, best)`` it is a planner's progress
    function (the label shows the best energy)."""

    def __init__(self, enabled: bool, label: str = "") -> None:
        self.enabled = enabled
        self.label = label
        self.bar: Any = None  # a click progress bar once the first update arrives
        self.last = 0.0
        self.done = 0

    def show(self, done: int, total: int, detail: str = "", label: str | None = None) -> None:
        if not self.enabled:
            return
        if label is not None and label != self.label:
            self.close()
            self.label = label
        if self.bar is None:
            self.bar = click.progressbar(
                length=max(total, 1), label=self.label, file=sys.stderr, show_pos=True, width=30
            )
            self.bar.__enter__()
            self.done = 0
        now = time.monotonic()
        if now - self.last >= 0.1 or done >= total:
            self.bar.label = f"{self.label} {detail}".rstrip()
            self.bar.update(done - self.done)
            self.done = done
            self.last = now

    def __call__(self, iteration: int, total: int, best: float) -> None:
        self.show(iteration, total, f"E={best:.1f}")

    def start(self, label: str) -> None:
        """Start a new bar labelled ``label`` (the current one, if any, ends)."""
        self.close()
        self.label = label

    def close(self) -> None:
        if self.bar is not None:
            self.bar.__exit__(None, None, None)
            self.bar = None
