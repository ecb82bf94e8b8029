"""What the CLI commands share: error → exit code mapping, the Ctrl-C flag, progress on
stderr and the :class:`~uavplan.app.feedback.Feedback` a use case talks through.

Commands import this module and :mod:`uavplan.cli.options`; neither imports a command module,
and no command module imports another (tests/test_layering.py)."""

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
from uavplan.errors import EXIT_INTERNAL, EXIT_INTERRUPTED, UavplanError
from uavplan.fileio import check_writable

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
            click.echo("interrupted", err=True)
            sys.exit(EXIT_INTERRUPTED)
        except (click.ClickException, click.exceptions.Exit, click.exceptions.Abort):
            raise
        except Exception as err:  # pragma: no cover - the last line of defence
            if os.environ.get("UAVPLAN_DEBUG"):
                raise
            click.echo(f"internal error: {type(err).__name__}: {err}", err=True)
            sys.exit(EXIT_INTERNAL)

    return wrapper  # type: ignore[return-value]


def exit_interrupted() -> NoReturn:
    """A use case stopped on Ctrl-C: say so and exit 130 (nothing else was written)."""
    click.echo("interrupted", err=True)
    sys.exit(EXIT_INTERRUPTED)


def _say(line: str) -> None:
    click.echo(line, err=True)


def _nothing(_line: str) -> None:
    pass


def feedback(
    quiet: bool, *, should_stop: Callable[[], bool] | None = None, progress: bool = True
) -> Feedback:
    """The use case's feedback on stderr: notes unless ``quiet``, warnings always, a
    progress bar on a terminal (not ``quiet``), and the Ctrl-C flag ``should_stop``."""
    return Feedback(
        say=_nothing if quiet else _say,
        warn=_say,
        progress=Progress(show_progress(quiet)) if progress else None,
        should_stop=should_stop,
    )


def show_progress(quiet: bool) -> bool:
    """Progress goes to stderr only when it is a terminal and the user did not ask quiet."""
    return not quiet and sys.stderr.isatty()


def check_output_paths(*paths: str | None) -> None:
    """Fail before any long work when an output file cannot be written (its folder is
    missing or not writable, the path is a folder, ...): one message naming the user's path,
    exit 2. See :func:`uavplan.fileio.check_writable`."""
    for path in paths:
        if path:
            check_writable(path)


@contextlib.contextmanager
def interruptible() -> Iterator[Callable[[], bool]]:
    """While planning, Ctrl-C (SIGINT) sets a flag instead of raising inside a compiled kernel
    (where the interrupt would only surface after the kernel returns, mid-update); the
    planner polls the flag every iteration and stops, and the command exits 130. Yields the
    poll function. A second Ctrl-C raises KeyboardInterrupt at once."""
    hit = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield hit.is_set
        return

    def on_sigint(_signum: int, _frame: object) -> None:
        if hit.is_set():
            raise KeyboardInterrupt
        hit.set()

    previous = signal.signal(signal.SIGINT, on_sigint)
    try:
        yield hit.is_set
        if hit.is_set():
            raise KeyboardInterrupt
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
