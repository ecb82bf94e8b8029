"""How a use case talks to the user while it runs, and the planner options every planning
use case takes."""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Protocol

from uavplan.config import ConfigError, PlannerConfig, override, planner_entry
from uavplan.errors import NoPathError
from uavplan.scenario import Scenario

if TYPE_CHECKING:  # planning loads numpy and the kernels: `validate` needs neither
    from uavplan.flightcheck import FlightPrediction
    from uavplan.planning import RouteResult
    from uavplan.route import PlannedRoute


class ProgressBar(Protocol):
    """A progress display the planner drives (``bar(iteration, total, best)``)."""

    def __call__(self, iteration: int, total: int, best: float) -> None: ...

    def show(self, done: int, total: int, detail: str = "", label: str | None = None) -> None: ...

    def start(self, label: str) -> None: ...

    def close(self) -> None: ...


class Interrupts(Protocol):
    """How Ctrl-C reaches a running use case (the CLI's is ``cli.common.Interrupts``).

    Outside :meth:`polled` blocks a Ctrl-C interrupts at once (the caller's business: a
    ``KeyboardInterrupt``, which an :class:`~uavplan.app.outputs.OutputSet` answers by
    removing what it made). Inside one it only sets the flag ``Feedback.should_stop`` reads:
    the block polls it (a planner's search, whose compiled steps must not be cut in the
    middle) and returns a value saying it was interrupted."""

    def polled(self) -> AbstractContextManager[None]:
        """A block that polls ``should_stop`` itself."""
        ...

    def commit_point(self) -> None:
        """The outputs are about to be committed: raise ``KeyboardInterrupt`` if a Ctrl-C
        came and was not acted on; from here on a Ctrl-C is too late to undo the command
        and is ignored."""
        ...


def _nothing(_line: str) -> None:
    pass


@dataclass(frozen=True)
class Feedback:
    """``say``: lines about the run (the CLI drops them with ``--quiet``); ``warn``: warnings
    (always shown); ``progress``: a bar for long work, or None; ``should_stop``: polled during
    long work (a Ctrl-C flag), or None; ``interrupts``: how Ctrl-C reaches the use case
    (:class:`Interrupts`), or None (then nothing is polled but ``should_stop``)."""

    say: Callable[[str], None] = _nothing
    warn: Callable[[str], None] = _nothing
    progress: ProgressBar | None = None
    should_stop: Callable[[], bool] | None = None
    interrupts: Interrupts | None = None

    def polled(self) -> AbstractContextManager[None]:
        """A block that polls ``should_stop`` (see :class:`Interrupts`)."""
        return nullcontext() if self.interrupts is None else self.interrupts.polled()


@dataclass(frozen=True)
class PlannerOptions:
    """Planner options given on the command line (None: the scenario's)."""

    algorithm: str | None = None
    seed: int | None = None
    iterations: int | None = None
    population: int | None = None

    def apply_to(self, planner: PlannerConfig) -> PlannerConfig:
        """``planner`` with these options, each validated like a scenario's own value
        (ConfigError naming the option). ``iterations`` forces that many iterations: no
        early stop."""
        cfg = planner
        for option, value in (
            ("--seed", self.seed),
            ("--iterations", self.iterations),
            ("--population", self.population),
        ):
            if value is None:
                continue
            try:
                search = override(cfg.search, {option.lstrip("-"): value})
            except ConfigError as err:
                raise ConfigError(err.reason, key=option) from None
            cfg = replace(cfg, search=search)
        if self.iterations is not None:
            cfg = replace(cfg, search=replace(cfg.search, stall_iterations=None))
        if self.algorithm:
            planner_entry(self.algorithm, "--algorithm")
            cfg = replace(cfg, algorithm=self.algorithm)
        return cfg

    def apply(self, scenario: Scenario) -> Scenario:
        """``scenario`` with these options (:meth:`apply_to`); the copy is checked like any
        scenario, the size limits included."""
        return replace(scenario, planner=self.apply_to(scenario.planner))


def require_route(
    scenario: Scenario, result: RouteResult, flight: FlightPrediction | None = None
) -> PlannedRoute:
    """The planned route, or the error that says why there is none (exit 3): none found, one
    closer than the margin, or one whose predicted ``flight`` breaks it. An interrupted result
    is the caller's to report before it asks."""
    if not result.ok or result.route is None:
        raise NoPathError(f"{scenario.name}: no collision-free path: {result.message}")
    if not result.collision_free:
        raise NoPathError(
            f"{scenario.name}: the route comes within {result.min_clearance_m:.2f} m of an "
            f"obstacle (safety margin {scenario.safety_margin_m:g} m)"
        )
    problem = None if flight is None else flight.problem()
    if problem is not None:
        raise NoPathError(f"{scenario.name}: {problem}")
    return result.route


def plural(count: int, noun: str, nouns: str | None = None) -> str:
    """``1 iteration``, ``2 iterations`` (``nouns``: an irregular plural)."""
    return f"{count} {noun if count == 1 else (nouns or noun + 's')}"


def flight_text(flight: FlightPrediction | None) -> str:
    """``, flight 7 min 36 s (ardupilot flight model)``: the predicted flight's time, for a
    summary line ("" when the route was not rehearsed)."""
    if flight is None:
        return ""
    minutes, seconds = divmod(round(flight.flight_time_s), 60)
    return f", flight {minutes} min {seconds:02d} s ({flight.autopilot} flight model)"
