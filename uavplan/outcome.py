"""How a search ended and why a route failed: the outcome vocabulary of the planners, the
planning wiring and the rerouting (STYLE: expected outcomes are values, not exceptions).

* :class:`SearchEnd`: why a planner's run stopped. Its values are the ``termination``
  strings of the ``--report`` JSON and the bench tables (a contract); a :class:`SearchEnd` is a
  ``str``, so it compares and serialises as those strings.
* :class:`RouteFailure`: why a route between two route points could not be had.
* :class:`LegFailure`: which leg failed (a value, not a regular expression over a message),
  why, and the message for the user.
* :class:`Ended`: the one small protocol every expected end speaks, from the search to the
  transfer, the flight and the start refusal: ``ok``, ``interrupted``, a ``reason`` (an enum
  value), a ``message`` and the ``step``.

An interrupt is one of these values (``SearchEnd.INTERRUPTED`` ends the search,
``RouteFailure.INTERRUPTED`` the route); the command line turns it into exit 130. No library
code raises ``KeyboardInterrupt``.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Protocol, runtime_checkable


class SearchEnd(enum.StrEnum):
    """Why a planner's run stopped (``PlannerResult.termination``)."""

    ITERATIONS = "iterations"  # the iteration budget was spent
    STALLED = "stalled"  # no improvement for the stall limit
    BUDGET = "budget"  # the evaluation budget was spent
    INTERRUPTED = "interrupted"  # should_stop() said so (Ctrl-C)
    NO_PATH = "no_path"  # no individual could be initialised

    @property
    def solved(self) -> bool:
        """Did the run produce a path (every end but :attr:`NO_PATH`)?"""
        return self is not SearchEnd.NO_PATH


class RouteFailure(enum.Enum):
    """Why a route could not be had."""

    START_ENCLOSED = "start_enclosed"  # no free line leads from the start to free space
    GOAL_ENCLOSED = "goal_enclosed"  # no free line leads from free space to the goal
    SEPARATED = "separated"  # both touch free space that does not connect
    INTERRUPTED = "interrupted"  # the search was stopped (Ctrl-C)

    @property
    def status(self) -> str:
        """The report's ``status``: ``"interrupted"`` or ``"no_path"``."""
        return "interrupted" if self is RouteFailure.INTERRUPTED else "no_path"


@dataclass(frozen=True)
class LegFailure:
    """The leg of a route (``leg`` of ``legs``, counted from 0) that failed, why, and what
    the user is told (``detail``, without the leg's place; :attr:`message` adds it)."""

    leg: int
    legs: int
    reason: RouteFailure
    detail: str

    def __post_init__(self) -> None:
        if not 0 <= self.leg < self.legs:
            raise ValueError(f"leg {self.leg} is not one of {self.legs}")

    @property
    def message(self) -> str:
        """``detail``, prefixed with ``leg i of n: `` when the route has several legs."""
        where = f"leg {self.leg + 1} of {self.legs}: " if self.legs > 1 else ""
        return where + self.detail


@runtime_checkable
class Ended(Protocol):
    """How an expected operation ended, in one vocabulary (issue 36): the search and the
    planning (:class:`uavplan.planning.RouteResult`), the rerouting
    (:class:`uavplan.reroute.RerouteResult`), a mission transfer
    (:class:`uavplan.mavlink.protocol.TransferOutcome`), a parameter
    (:class:`uavplan.mavlink.parameters.ParamResult`), a command sequence
    (:class:`uavplan.mavlink.flightmachines.CommandOutcome`), a flight (``fly``'s
    :class:`uavplan.app.fly.FlyOutcome`) and the start refusal
    (:class:`uavplan.autopilot.simulate.StartRefusal`).

    ``ok``: it ended as asked. ``interrupted``: a Ctrl-C ended it (not ok). ``reason``: the
    enum value saying why it is not ok (each operation's own: :class:`RouteFailure`, a
    ``TransferStatus``, ...), None when ok. ``message``: that in words for the user ("" when
    there is nothing to say). ``step``: where it ended (the leg, the protocol step, the
    command), "" when ok or when it has no steps. Errors (what the user or the vehicle got
    wrong beyond an expected end) are exceptions, not these."""

    @property
    def ok(self) -> bool: ...

    @property
    def interrupted(self) -> bool: ...

    @property
    def reason(self) -> enum.Enum | None: ...

    @property
    def message(self) -> str: ...

    @property
    def step(self) -> str: ...
