"""Packet faults of the mock vehicle's link: the transport half of the mock, kept apart
from its protocol half (:mod:`.mock_vehicle`).

:class:`LinkFaults` says how often packets are dropped, duplicated or reordered in each
direction; :class:`FaultInjector` applies them with a seeded ``numpy.random.Generator``
per direction. (The fault proxy of :mod:`.faultproxy` does the same between two
endpoints, at the byte level.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from uavplan.mavlink.connection import MavlinkConnection
from uavplan.mavlink.messages import Message, message_name

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
class LinkFaults:
    """Packet faults applied by the vehicle to what it receives and what it sends.

    Each rate is a probability per packet and per direction. ``only`` restricts the faults
    to those message names (e.g. :data:`MISSION_PROTOCOL_MESSAGES` to keep heartbeats
    flowing); ``None`` means every packet. ``reorder_rate`` holds an outgoing packet back
    until after the next one.
    """

    drop_rate: float = 0.0
    duplicate_rate: float = 0.0
    reorder_rate: float = 0.0
    seed: int | None = 0
    only: frozenset[str] | None = None
    #: "both", or only what the vehicle receives ("in") or sends ("out")
    direction: str = "both"

    def __post_init__(self) -> None:
        for name in ("drop_rate", "duplicate_rate", "reorder_rate"):
            value = getattr(self, name)
            if not (0.0 <= value <= 1.0):
                raise ValueError(f"{name} must be within [0, 1], got {value!r}")
        if self.direction not in ("both", "in", "out"):
            raise ValueError(f"direction must be both, in or out, got {self.direction!r}")

    @property
    def active(self) -> bool:
        return self.drop_rate > 0 or self.duplicate_rate > 0 or self.reorder_rate > 0


class FaultInjector:
    """Seeded packet faults on both directions of one endpoint (:class:`LinkFaults`)."""

    def __init__(self, faults: LinkFaults) -> None:
        self.faults = faults
        seeds = np.random.SeedSequence(faults.seed).spawn(2)
        self.rng_in = np.random.default_rng(seeds[0])
        self.rng_out = np.random.default_rng(seeds[1])
        self.dropped_in = self.dropped_out = self.duplicated = self.reordered = 0
        self._held: bytes | None = None

    def applies(self, message: Message) -> bool:
        only = self.faults.only
        return self.faults.active and (only is None or message_name(message) in only)

    def inbound_copies(self, message: Message) -> int:
        """How many times to process a received message: 0 (lost), 1 or 2 (duplicated)."""
        if not self.applies(message) or self.faults.direction == "out":
            return 1
        if self.faults.drop_rate and self.rng_in.random() < self.faults.drop_rate:
            self.dropped_in += 1
            return 0
        if self.faults.duplicate_rate and self.rng_in.random() < self.faults.duplicate_rate:
            self.duplicated += 1
            return 2
        return 1

    def outbound(self, message: Message) -> tuple[int, bool]:
        """(copies to send, hold back for reordering)."""
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

    def send(self, connection: MavlinkConnection, message: Message) -> None:
        """Send ``message`` with the outbound faults: lost, doubled, or held back until
        after the next packet (reordering)."""
        copies, hold = self.outbound(message)
        if copies == 0:
            return
        data = connection.encode(message)
        if hold and self._held is None:
            self._held = data * copies
            return
        for _ in range(copies):
            connection.send_bytes(data)
        self.flush(connection)

    def flush(self, connection: MavlinkConnection) -> None:
        """Release a held-back packet (called when the link goes quiet)."""
        if self._held is not None:
            held, self._held = self._held, None
            connection.send_bytes(held)
