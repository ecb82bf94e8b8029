"""One exception hierarchy for everything a user can cause.

Each class carries the process exit code the CLI maps it to (SPEC §3):
0 success · 1 internal error · 2 bad input or usage · 3 no collision-free path ·
4 vehicle/link failure · 130 interrupted (Ctrl-C; nothing written).
"""

from __future__ import annotations

EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_INPUT = 2
EXIT_NO_PATH = 3
EXIT_LINK = 4
EXIT_INTERRUPTED = 130  # Ctrl-C, as shells report SIGINT (128 + 2)


class UavplanError(Exception):
    """Base class. ``str(err)`` is the one-line message shown to the user."""

    exit_code: int = EXIT_INTERNAL


class InputError(UavplanError):
    """Bad input: a file, a key or an option the user gave (exit 2)."""

    exit_code = EXIT_INPUT

    def __init__(self, reason: str, *, file: str | None = None, key: str | None = None) -> None:
        self.reason = reason
        self.file = file
        self.key = key
        where = ": ".join(part for part in (file, key) if part)
        super().__init__(f"{where}: {reason}" if where else reason)


class ScenarioError(InputError):
    """A scenario or map file is invalid."""


class MissionFileError(InputError):
    """A mission file (.plan, .waypoints, ...) cannot be read or is invalid."""


class NoPathError(UavplanError):
    """No collision-free path between start and goal was found (exit 3)."""

    exit_code = EXIT_NO_PATH


class LinkError(UavplanError):
    """The vehicle or the link failed: no heartbeat, timeout, rejection, mismatch (exit 4).

    ``step`` names the protocol step that failed (for example ``"upload: MISSION_COUNT"``).
    """

    exit_code = EXIT_LINK

    def __init__(self, message: str, *, step: str | None = None) -> None:
        self.step = step
        super().__init__(f"{step}: {message}" if step else message)
