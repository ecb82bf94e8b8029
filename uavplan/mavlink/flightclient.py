"""The thin driver of the flight machines (:mod:`uavplan.mavlink.flightmachines`) over a link.

:class:`FlightClient` owns the clock: it feeds each message from the vehicle and each expired
deadline to the running machine and sends what the machine returns, exactly as
:class:`~uavplan.mavlink.protocol.MissionClient` drives the mission-protocol machines (and
shares the link with one: the mission is checked and uploaded between the pre-flight
checks and the start). ``should_stop`` (a Ctrl-C flag) is polled at least every
:data:`POLL_S`; ``on_tick`` is called as often, for a progress display, and may end the run
(what it returns, when not None, is the run's result). What the vehicle answers other ground
stations (:attr:`VehicleLink.overheard`) goes to the machine too.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TypeVar

from uavplan.mavlink.flightmachines import (
    FRESH_MESSAGES,
    CommandOutcome,
    CommandSequence,
    FlightMachine,
    FlightTimeouts,
    MonitorEnd,
    MonitorMachine,
    Preflight,
    PreflightMachine,
    VehicleState,
    WatchRules,
    mode_steps,
    start_steps,
)
from uavplan.mavlink.link import VehicleLink
from uavplan.mavlink.messages import Message
from uavplan.mavlink.modes import ModeKind

__all__ = ["POLL_S", "FlightClient"]

#: the driver looks at the Ctrl-C flag and the progress display at least this often (s)
POLL_S = 0.1

T = TypeVar("T")


class FlightClient:
    """Fly one vehicle over ``link``; :attr:`state` is what it last reported."""

    def __init__(
        self,
        link: VehicleLink,
        timeouts: FlightTimeouts | None = None,
        *,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.link = link
        self.timeouts = timeouts or FlightTimeouts()
        self.clock = clock
        self.state = VehicleState(link.vehicle.autopilot)
        self.target = (link.vehicle.system_id, link.vehicle.component_id)
        #: the monitor of the last :meth:`monitor` (what it noticed, what it left unconfirmed)
        self.monitor_machine: MonitorMachine | None = None

    def _send(self, messages: list[Message]) -> None:
        for message in messages:
            self.link.send(message)

    def run(
        self,
        machine: FlightMachine,
        *,
        should_stop: Callable[[], bool] | None = None,
        on_tick: Callable[[VehicleState], object | None] | None = None,
    ) -> object | None:
        """Drive ``machine`` to its end; None when ``should_stop`` said stop first; what
        ``on_tick`` returned when it returned something."""
        self._send(machine.start(self.clock()))
        overheard = self.link.overheard
        while machine.finished is None:
            if should_stop is not None and should_stop():
                return None
            now = self.clock()
            wait = min(max(0.0, machine.deadline - now), POLL_S)
            received = self.link.recv(wait)
            now = self.clock()
            out: list[Message] = []
            while overheard:
                out += machine.on_overheard(overheard.popleft(), now)
            if received is not None:
                out += machine.on_message(received.message, now)
            elif now >= machine.deadline:
                out += machine.on_timeout(now)
            self._send(out)
            if on_tick is not None:
                verdict = on_tick(self.state)
                if verdict is not None:
                    return verdict
        return machine.finished

    def preflight(self) -> Preflight:
        """Home, health, pre-arm checks, armed, mode and landed state."""
        result = self.run(PreflightMachine(self.state, self.target, self.timeouts))
        assert isinstance(result, Preflight)
        return result

    def commands(
        self,
        steps: list,
        *,
        should_stop: Callable[[], bool] | None = None,
        on_tick: Callable[[VehicleState], None] | None = None,
    ) -> CommandOutcome | None:
        """Run a command sequence; None when interrupted. ``on_tick`` sees the state as it
        comes (to say what the vehicle says while a step waits)."""
        machine = CommandSequence(self.state, self.target, self.timeouts, steps)
        result = self.run(machine, should_stop=should_stop, on_tick=on_tick)
        assert result is None or isinstance(result, CommandOutcome)
        return result

    def start_mission(
        self,
        *,
        should_stop: Callable[[], bool] | None = None,
        on_tick: Callable[[VehicleState], None] | None = None,
    ) -> CommandOutcome | None:
        """Start the uploaded mission from the ground the way the firmware expects
        (:func:`~uavplan.mavlink.flightmachines.start_steps`)."""
        self.state.recording = True
        steps = start_steps(self.state.autopilot)
        return self.commands(steps, should_stop=should_stop, on_tick=on_tick)

    def change_mode(self, kind: ModeKind) -> CommandOutcome:
        """Switch to the mode of ``kind`` and see the vehicle report it (never interrupted:
        this is what a Ctrl-C asks for)."""
        result = self.commands(mode_steps(self.state.autopilot, kind))
        assert result is not None
        return result

    def monitor(
        self,
        *,
        last_seq: int,
        lands: bool,
        return_seq: int | None = None,
        land_seq: int | None = None,
        rules: WatchRules | None = None,
        should_stop: Callable[[], bool] | None = None,
        on_tick: Callable[[VehicleState], MonitorEnd | None] | None = None,
    ) -> MonitorEnd | None:
        """Follow the flight to its end (:class:`MonitorMachine`); None when interrupted;
        ``on_tick``'s ending when it returns one (its judgement: no progress)."""
        self.state.recording = True
        machine = MonitorMachine(
            self.state,
            self.target,
            self.timeouts,
            last_seq=last_seq,
            lands=lands,
            return_seq=return_seq,
            land_seq=land_seq,
            rules=rules,
        )
        self.monitor_machine = machine
        result = self.run(machine, should_stop=should_stop, on_tick=on_tick)
        assert result is None or isinstance(result, MonitorEnd)
        return result

    def refresh(self, timeout_s: float) -> list[str]:
        """Ask for the vehicle's state again and wait up to ``timeout_s`` for the answers
        (a verdict after the monitor ends rests on them); the kinds that did not come."""
        since = self.clock()
        asking = FlightMachine(self.state, self.target, self.timeouts)
        self._send(asking.request_messages(FRESH_MESSAGES))
        deadline = since + timeout_s
        missing = self.state.not_heard_since(since)
        while missing and (left := deadline - self.clock()) > 0:
            received = self.link.recv(min(left, POLL_S))
            if received is not None:
                self.state.update(received.message, self.clock())
            missing = self.state.not_heard_since(since)
        return missing
