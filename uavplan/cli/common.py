"""Helpers shared by the CLI commands: error → exit code mapping, progress on stderr."""

from __future__ import annotations

import functools
import sys
from collections.abc import Callable
from typing import Any, TypeVar

import click

from uavplan.errors import EXIT_INTERNAL, UavplanError

F = TypeVar("F", bound=Callable[..., Any])


def handle_errors(fn: F) -> F:
    """Turn a :class:`UavplanError` into one message on stderr and its exit code.

    Anything else is an internal error: one line naming it, exit 1 (a traceback only with
    ``UAVPLAN_DEBUG=1``).
    """

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except UavplanError as err:
            click.echo(f"error: {err}", err=True)
            sys.exit(err.exit_code)
        except KeyboardInterrupt:
            click.echo("interrupted", err=True)
            sys.exit(130)
        except (click.ClickException, click.exceptions.Exit, click.exceptions.Abort):
            raise
        except Exception as err:  # pragma: no cover - the last line of defence
            import os

            if os.environ.get("UAVPLAN_DEBUG"):
                raise
            click.echo(f"internal error: {type(err).__name__}: {err}", err=True)
            sys.exit(EXIT_INTERNAL)

    return wrapper  # type: ignore[return-value]


def show_progress(quiet: bool) -> bool:
    """Progress goes to stderr only when it is a terminal and the user did not ask quiet."""
    return not quiet and sys.stderr.isatty()
