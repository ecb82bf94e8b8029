"""Ground-station side of the MAVLink mission protocol: upload, download and clear.

One :class:`MissionClient` drives one transfer at a time over a
:class:`~uavplan.mavlink.link.VehicleLink`, for any plan type (mission, fence, rally). Each
operation returns a :class:`TransferOutcome`: a status enum naming what happened, the
protocol step where it happened, the vehicle's MAV_MISSION_RESULT by name, and counters.
:meth:`TransferOutcome.raise_for_status` turns a failure into a
:class:`MissionTransferError` (a :class:`~uavplan.errors.LinkError`, exit 4).

The protocol itself (states, retries, which answer ends what) lives in
:mod:`uavplan.mavlink.machines` as state machines that do no I/O and take the time as an
argument. :class:`MissionClient` is the thin loop around them: it owns the link and the
clock, feeds each received message or expired deadline to the machine and sends what the
machine returns (reference §1, §7, §8 for the protocol; the machines' docstrings for the
state diagrams).

Timeouts: the spec/QGC values are the defaults, the ceilings and the total budgets. Within
a budget, re-sends follow the measured round trip (RFC 6298: ``srtt + 4 x rttvar``, seeded
by the AUTOPILOT_VERSION request made on connecting and updated by every clean exchange),
so a fast link does not wait 250 ms or 1.5 s per lost packet while a slow radio link still
gets the spec timing. Per-item download re-requests use a 10 ms floor: a re-sent
REQUEST_INT for the item the vehicle just sent is the "repeat of the last one" every
firmware accepts. Control messages (COUNT, REQUEST_LIST, CLEAR_ALL) use a 200 ms floor
and back off (:class:`~uavplan.mavlink.machines.ControlSchedule`).
"""

from __future__ import annotations

import enum
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from uavplan.errors import LinkError
from uavplan.mavlink.link import VehicleLink
from uavplan.mavlink.machines import (
    BUSY_ACK_REPEATS,
    RETRY_BACKOFF,
    ClearMachine,
    ControlSchedule,
    Counters,
    DownloadMachine,
    Machine,
    ProgressCallback,
    ProtocolTimeouts,
    RoundTripEstimator,
    TransferStatus,
    UploadMachine,
    describe_item,
    item_from_wire,
    type_label,
)
from uavplan.mavlink.messages import (
    Message,
    MissionAck,
    MissionItemInt,
    MissionResult,
    Received,
    result_label,
)
from uavplan.mission.items import MissionItem, MissionType

__all__ = [
    "BUSY_ACK_REPEATS",
    "RETRY_BACKOFF",
    "ControlSchedule",
    "MissionClient",
    "MissionTransferError",
    "Operation",
    "ProgressCallback",
    "ProtocolTimeouts",
    "RoundTripEstimator",
    "TransferOutcome",
    "TransferStats",
    "TransferStatus",
    "describe_item",
    "item_from_wire",
    "item_to_wire",
    "type_label",
    "wire_range_problem",
]

#: the clock a client reads: seconds, monotonic
Clock = Callable[[], float]

# ---------------------------------------------------------------------------------------------
# Outcomes


class Operation(enum.Enum):
    UPLOAD = "upload"
    DOWNLOAD = "download"
    CLEAR = "clear"
    VERIFY = "verify"


@dataclass(frozen=True)
class TransferStats:
    elapsed_s: float = 0.0
    sent: int = 0  # protocol messages we sent
    received: int = 0  # protocol messages we took from the vehicle
    resent: int = 0  # our re-sends after a timeout
    repeat_requests: int = 0  # upload: requests for a seq we had already sent
    ignored: int = 0  # stale, duplicate or out-of-sequence messages dropped
    srtt_ms: float | None = None


@dataclass(frozen=True)
class TransferOutcome:
    """The result of one upload / download / clear of one plan type."""

    operation: Operation
    mission_type: MissionType
    status: TransferStatus
    step: str = ""  # the protocol step: "MISSION_COUNT", "MISSION_ITEM_INT seq 17", ...
    detail: str = ""  # why, in words
    vehicle_result: MissionResult | int | None = None
    seq: int | None = None
    items: tuple[MissionItem, ...] = ()
    stats: TransferStats = field(default_factory=TransferStats)
    statustext: str | None = None

    @property
    def ok(self) -> bool:
        return self.status is TransferStatus.SUCCESS

    @property
    def interrupted(self) -> bool:
        """Never: a Ctrl-C stops the caller's loop, not the transfer's machine (a vehicle's
        cancel is ``TransferStatus.CANCELLED``)."""
        return False

    @property
    def reason(self) -> TransferStatus | None:
        """How it failed (:class:`~uavplan.outcome.Ended`); None: it succeeded."""
        return None if self.ok else self.status

    @property
    def where(self) -> str:
        """``"upload mission: MISSION_COUNT"``: the operation, plan type and step."""
        head = f"{self.operation.value} {type_label(self.mission_type)}"
        return f"{head}: {self.step}" if self.step else head

    @property
    def message(self) -> str:
        parts = [self.detail or self.status.value]
        if self.vehicle_result is not None and result_label(self.vehicle_result) not in (
            self.detail
        ):
            parts.append(f"({result_label(self.vehicle_result)})")
        if self.statustext:
            parts.append(f'[vehicle: "{self.statustext}"]')
        return " ".join(parts)

    def raise_for_status(self) -> TransferOutcome:
        if not self.ok:
            raise MissionTransferError(self)
        return self


class MissionTransferError(LinkError):
    """A transfer failed; ``outcome`` says where and why. Exit code 4."""

    def __init__(self, outcome: TransferOutcome) -> None:
        self.outcome = outcome
        super().__init__(outcome.message, step=outcome.where)


# ---------------------------------------------------------------------------------------------
# Wire conversion


#: the largest finite float32, the type of MISSION_ITEM_INT's params and z
FLOAT32_MAX = 3.4028234663852886e38
INT32_RANGE = (-(2**31), 2**31 - 1)


def wire_range_problem(item: MissionItem) -> str | None:
    """Why ``item`` cannot be carried by MISSION_ITEM_INT (a param or z beyond float32, x/y
    beyond int32), or ``None`` when it can."""
    for name, value in zip(("param1", "param2", "param3", "param4"), item.params, strict=True):
        if value is not None and math.isfinite(value) and abs(value) > FLOAT32_MAX:
            return f"{name} = {value!r} does not fit the wire's 32-bit float"
    if math.isfinite(item.z) and abs(item.z) > FLOAT32_MAX:
        return f"z (altitude) = {item.z!r} does not fit the wire's 32-bit float"
    for name, value in (("x", item.x), ("y", item.y)):
        if not math.isfinite(value):
            return f"{name} = {value!r} is not a number the wire can carry"
    x, y = item.wire_xy()
    for name, value in (("x", x), ("y", y)):
        if not INT32_RANGE[0] <= value <= INT32_RANGE[1]:
            shown = getattr(item, name)
            return f"{name} = {shown!r} does not fit the wire's 32-bit integer"
    return None


def item_to_wire(
    item: MissionItem,
    seq: int,
    mission_type: MissionType,
    target_system: int,
    target_component: int,
) -> MissionItemInt:
    """MissionItem -> MISSION_ITEM_INT; ``current`` is 1 on seq 0 only (reference §4.4).

    Raises ValueError for an item the wire cannot carry (:func:`wire_range_problem`)."""
    problem = wire_range_problem(item)
    if problem is not None:
        raise ValueError(f"item {seq}: {problem}")
    x, y = item.wire_xy()
    params = [math.nan if p is None else float(p) for p in item.params]
    return MissionItemInt(
        target_system=target_system,
        target_component=target_component,
        seq=seq,
        frame=item.frame,
        command=item.command,
        current=1 if seq == 0 else 0,
        autocontinue=1 if item.autocontinue else 0,
        param1=params[0],
        param2=params[1],
        param3=params[2],
        param4=params[3],
        x=x,
        y=y,
        z=float(item.z),
        mission_type=int(mission_type),
    )


# ---------------------------------------------------------------------------------------------


#: how long a failed transfer waits for the STATUSTEXT that may explain the vehicle's refusal
STATUSTEXT_GRACE_S = 0.1
_VEHICLE_REFUSALS = frozenset(
    {
        TransferStatus.REJECTED,
        TransferStatus.NO_SPACE,
        TransferStatus.BUSY,
        TransferStatus.CANCELLED,
    }
)


class MissionClient:
    """Mission protocol client for one vehicle. Not thread-safe: one transfer at a time.

    ``clock``: the monotonic clock the timeouts are measured with (``time.monotonic``).
    """

    def __init__(
        self,
        link: VehicleLink,
        timeouts: ProtocolTimeouts | None = None,
        *,
        clock: Clock = time.monotonic,
    ) -> None:
        self.link = link
        self.timeouts = timeouts or ProtocolTimeouts()
        self.clock = clock
        self.rtt = RoundTripEstimator()
        if link.handshake_rtt_s is not None:
            self.rtt.add(link.handshake_rtt_s)
        #: the final ACK of our last download, kept to repeat if the vehicle says busy
        self._download_ack: MissionAck | None = None

    # -- helpers --------------------------------------------------------------------------
    @property
    def _target(self) -> tuple[int, int]:
        return self.link.vehicle.system_id, self.link.vehicle.component_id

    def _cancel(self, mission_type: MissionType) -> None:
        """MISSION_ACK(OPERATION_CANCELLED): the vehicle goes idle now, not after its timeout."""
        try:
            self.link.send(
                MissionAck(*self._target, MissionResult.OPERATION_CANCELLED, int(mission_type))
            )
        except LinkError:
            pass

    def _recv(self, timeout_s: float, mission_type: MissionType) -> Received | None:
        """Next protocol message of this plan type (stale ones of another type are dropped)."""
        deadline = self.clock() + max(0.0, timeout_s)
        while True:
            received = self.link.recv(max(0.0, deadline - self.clock()))
            if received is None:
                return None
            message = received.message
            message_type = getattr(message, "mission_type", None)
            if message_type is not None and message_type == int(mission_type):
                return received
            if self.clock() >= deadline:
                return None

    def _send_all(self, machine: Machine, messages: list[Message]) -> None:
        for message in messages:
            if machine.finished is not None and isinstance(message, MissionAck):
                try:  # a cancel or final ACK on the way out: the outcome stands regardless
                    self.link.send(message)
                except LinkError:
                    pass
            else:
                self.link.send(message)

    def _drive(self, operation: Operation, machine: Machine) -> TransferOutcome:
        """Run ``machine`` to its end over the link: the only place with I/O and a clock."""
        started = self.clock()
        self._send_all(machine, machine.start(started))
        while machine.finished is None:
            received = self._recv(machine.deadline - self.clock(), machine.mission_type)
            now = self.clock()
            if received is not None:
                actions = machine.on_message(received.message, now)
            elif now >= machine.deadline:
                actions = machine.on_timeout(now)
            else:
                continue
            self._send_all(machine, actions)
        return self._outcome(operation, machine, started)

    def _outcome(self, operation: Operation, machine: Machine, started: float) -> TransferOutcome:
        finished = machine.finished
        assert finished is not None
        counters: Counters = machine.counters
        stats = TransferStats(
            elapsed_s=self.clock() - started,
            sent=counters.sent,
            received=counters.received,
            resent=counters.resent,
            repeat_requests=counters.repeat_requests,
            ignored=counters.ignored,
            srtt_ms=None if self.rtt.srtt_s is None else self.rtt.srtt_s * 1e3,
        )
        if finished.status in _VEHICLE_REFUSALS and self.link.last_statustext is None:
            # a vehicle often explains a refusal right after its ACK ("Only 700 items are
            # supported"): give that STATUSTEXT a moment to arrive
            deadline = self.clock() + STATUSTEXT_GRACE_S
            while self.link.last_statustext is None and self.clock() < deadline:
                self.link.recv(deadline - self.clock())
        ok = finished.status is TransferStatus.SUCCESS
        return TransferOutcome(
            operation,
            machine.mission_type,
            finished.status,
            step=finished.step,
            detail=finished.detail,
            vehicle_result=finished.vehicle_result,
            seq=finished.seq,
            items=finished.items,
            stats=stats,
            statustext=None if ok else self.link.last_statustext,
        )

    # -- operations -----------------------------------------------------------------------
    def upload(
        self,
        mission_type: MissionType,
        items: Sequence[MissionItem],
        *,
        progress: ProgressCallback | None = None,
    ) -> TransferOutcome:
        """Upload ``items`` (seq = index) as plan type ``mission_type``.

        An empty list uploads count 0, which clears that plan type (reference §1.1.5).
        """
        mission_type = MissionType(mission_type)
        if mission_type == MissionType.ALL:
            raise ValueError("MAV_MISSION_TYPE_ALL is only valid for clear")
        self.link.last_statustext = None
        sysid, compid = self._target
        wire = [item_to_wire(it, seq, mission_type, sysid, compid) for seq, it in enumerate(items)]
        machine = UploadMachine(
            self._target,
            mission_type,
            items,
            wire,
            self.timeouts,
            self.rtt,
            download_ack=self._download_ack,
            progress=progress,
        )
        try:
            return self._drive(Operation.UPLOAD, machine)
        except KeyboardInterrupt:
            self._cancel(mission_type)
            raise
        finally:
            self._download_ack = None

    def download(
        self, mission_type: MissionType, *, progress: ProgressCallback | None = None
    ) -> TransferOutcome:
        """Read plan type ``mission_type`` from the vehicle; ``outcome.items`` holds it."""
        mission_type = MissionType(mission_type)
        if mission_type == MissionType.ALL:
            raise ValueError("MAV_MISSION_TYPE_ALL is only valid for clear")
        self.link.last_statustext = None
        machine = DownloadMachine(
            self._target, mission_type, self.timeouts, self.rtt, progress=progress
        )
        try:
            outcome = self._drive(Operation.DOWNLOAD, machine)
        except KeyboardInterrupt:
            self._cancel(mission_type)
            raise
        if machine.final_ack is not None:
            self._download_ack = machine.final_ack
        return outcome

    def clear(self, mission_type: MissionType) -> TransferOutcome:
        """MISSION_CLEAR_ALL for one plan type (or ALL, which ArduPilot does not support)."""
        mission_type = MissionType(mission_type)
        self.link.last_statustext = None
        machine = ClearMachine(self._target, mission_type, self.timeouts, self.rtt)
        return self._drive(Operation.CLEAR, machine)
