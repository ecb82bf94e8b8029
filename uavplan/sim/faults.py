"""The simulated vehicle's one fault model: its link, its mission protocol and its flight.

:class:`Faults` is everything the vehicle does wrong on purpose, all off by default, from one
seed:

- **the link**: packets dropped, duplicated or reordered, per direction, with a seeded
  ``numpy.random.Generator`` per direction (``only`` restricts them to some message names,
  e.g. :data:`MISSION_PROTOCOL_MESSAGES`, to keep heartbeats flowing);
- **the mission protocol**: an error ACK at an item, an out-of-range request, an early
  ACCEPTED, falling silent, ignoring requests (the fault-matrix tests);
- **the flight**: the link lost for good some simulated seconds after the vehicle armed
  (the vehicle keeps flying, as PX4 and ArduPilot do with their ground-station failsafe at
  its default, disabled); a pre-arm check that fails (the vehicle will not arm, and says
  why).

:class:`FaultInjector` applies the packet faults to messages (the vehicle is sans-I/O: its
messages pass through the injector before the I/O loop encodes them). (The fault proxy of
``tests/helpers/faultproxy.py`` does the same between two endpoints, at the byte level.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from uavplan.mavlink.messages import Message, MissionResult, message_name

__all__ = ["MISSION_PROTOCOL_MESSAGES", "FaultInjector", "Faults"]

MISSION_PROTOCOL_MESSAGES = frozenset(
    {
        "MISSION_COUNT",
        "MISSION_REQUEST",
        "MISSION_REQUEST_INT",
        "MISSION_REQUEST_LIST",
        "MISSION_ITEM",
        "MISSION_ITEM_INT",
        "MISSION_ACK",
        "MISSION_CLEAR_ALL",
    }
)


@dataclass(frozen=True)
class Faults:
    """Deliberate misbehaviour of the simulated vehicle (all off by default).

    Packet faults: each rate is a probability per packet and direction; ``only`` restricts
    them to those message names (``None``: every packet); ``reorder_rate`` holds an outgoing
    packet back until after the next one; ``direction`` is "both", "in" (what the vehicle
    receives) or "out" (what it sends).

    Mission protocol: ``reject_at_seq`` answers that item with ``reject_result`` and aborts;
    ``out_of_range_after_seq`` requests seq = count + 2 after that item;
    ``accept_early_after_seq`` sends ACCEPTED after that item and stops; ``silent_after_seq``
    stops requesting after that item (no ACK either); ``ignore_requests`` never answers
    COUNT / REQUEST_LIST / CLEAR_ALL.

    Flight: ``link_lost_after_s`` simulated seconds after the vehicle arms, it neither sends
    nor hears anything any more (and keeps flying). ``prearm_failure``: a pre-arm check
    fails with this reason (``"Need Position Estimate"``): SYS_STATUS reports the pre-arm
    check unhealthy, and arming is refused with the reason in the firmware's words
    (ArduPilot ``PreArm: <reason>``, PX4 ``Preflight Fail: <reason>``).
    ``arm_flickers``: the first that many arm commands are refused although SYS_STATUS said
    the pre-arm checks pass, as PX4 refuses them while an estimator check flickers just after
    it passed ("Preflight Fail: vertical velocity unstable", TEMPORARILY_REJECTED); PX4
    only.

    Parameters: ``refuse_param_set`` names parameters the vehicle will not write (as a
    read-only one): a PARAM_SET of one is answered with the value it keeps.
    """

    drop_rate: float = 0.0
    duplicate_rate: float = 0.0
    reorder_rate: float = 0.0
    only: frozenset[str] | None = None
    direction: str = "both"
    reject_at_seq: int | None = None
    reject_result: MissionResult = MissionResult.INVALID_PARAM1
    out_of_range_after_seq: int | None = None
    accept_early_after_seq: int | None = None
    silent_after_seq: int | None = None
    ignore_requests: bool = False
    link_lost_after_s: float | None = None
    prearm_failure: str | None = None
    arm_flickers: int = 0
    refuse_param_set: frozenset[str] = frozenset()
    seed: int | None = 0

    def __post_init__(self) -> None:
        for name in ("drop_rate", "duplicate_rate", "reorder_rate"):
            value = getattr(self, name)
            if not (0.0 <= value <= 1.0):
                raise ValueError(f"{name} must be within [0, 1], got {value!r}")
        if self.direction not in ("both", "in", "out"):
            raise ValueError(f"direction must be both, in or out, got {self.direction!r}")
        if self.link_lost_after_s is not None and not self.link_lost_after_s >= 0.0:
            raise ValueError(f"link_lost_after_s must be >= 0, got {self.link_lost_after_s!r}")
        if self.arm_flickers < 0:
            raise ValueError(f"arm_flickers must be >= 0, got {self.arm_flickers!r}")
        if self.prearm_failure is not None and not self.prearm_failure.strip():
            raise ValueError("prearm_failure must name the failing check")

    @property
    def packet_faults(self) -> bool:
        return self.drop_rate > 0 or self.duplicate_rate > 0 or self.reorder_rate > 0


class FaultInjector:
    """The packet faults of one :class:`Faults` on both directions of the vehicle's link.

    ``inbound_copies`` says how often a received message is handled (0: lost, 2:
    duplicated); ``outbound`` turns the messages the vehicle wants to send into those that
    go on the wire (lost, doubled, or held back until after the next one); ``flush``
    releases a held-back message when the link goes quiet.
    """

    def __init__(self, faults: Faults) -> None:
        self.faults = faults
        seeds = np.random.SeedSequence(faults.seed).spawn(2)
        self.rng_in = np.random.default_rng(seeds[0])
        self.rng_out = np.random.default_rng(seeds[1])
        self.dropped_in = self.dropped_out = self.duplicated = self.reordered = 0
        self._held: list[Message] = []

    def applies(self, message: Message) -> bool:
        only = self.faults.only
        return self.faults.packet_faults and (only is None or message_name(message) in only)

    def inbound_copies(self, message: Message) -> int:
        """How many times to handle a received message: 0 (lost), 1 or 2 (duplicated)."""
        if not self.applies(message) or self.faults.direction == "out":
            return 1
        if self.faults.drop_rate and self.rng_in.random() < self.faults.drop_rate:
            self.dropped_in += 1
            return 0
        if self.faults.duplicate_rate and self.rng_in.random() < self.faults.duplicate_rate:
            self.duplicated += 1
            return 2
        return 1

    def outbound(self, messages: list[Message]) -> list[Message]:
        """The messages to put on the wire, in order, for ``messages`` the vehicle sends."""
        wire: list[Message] = []
        for message in messages:
            copies, hold = self._outbound_one(message)
            if copies == 0:
                continue
            if hold and not self._held:
                self._held = [message] * copies
                continue
            wire.extend([message] * copies)
            wire.extend(self.flush())
        return wire

    def _outbound_one(self, message: Message) -> tuple[int, bool]:
        if not self.applies(message) or self.faults.direction == "in":
            return 1, False
        if self.faults.drop_rate and self.rng_out.random() < self.faults.drop_rate:
            self.dropped_out += 1
            return 0, False
        copies = 1
        if self.faults.duplicate_rate and self.rng_out.random() < self.faults.duplicate_rate:
            self.duplicated += 1
            copies = 2
        hold = bool(self.faults.reorder_rate) and self.rng_out.random() < self.faults.reorder_rate
        if hold:
            self.reordered += 1
        return copies, hold

    def flush(self) -> list[Message]:
        """A held-back message, released (the link went quiet or another message passed)."""
        held, self._held = self._held, []
        return held
