"""A ground station's view of one vehicle: find it by HEARTBEAT, then talk only to it.

:class:`VehicleLink` wraps a :class:`~uavplan.mavlink.connection.MavlinkConnection` that
sends our GCS heartbeat, waits for the vehicle's HEARTBEAT (reference §7.14: never start a
transfer before it), picks the target system/component from it (or from
``target_system``), and then filters everything received down to messages from that
vehicle addressed to us or broadcast (reference §7.10, §7.13). It keeps what the vehicle
tells in passing: its capabilities (AUTOPILOT_VERSION) and its last STATUSTEXT, which
failure messages quote, and what it answers other ground stations on the same link
(:attr:`VehicleLink.overheard`: COMMAND_ACK and MISSION_ACK addressed to someone else), which
tells a monitor who changed the vehicle's mode or mission behind its back.
"""

from __future__ import annotations

import itertools
import secrets
import time
from collections import deque
from dataclasses import dataclass

from uavplan.errors import LinkError
from uavplan.mavlink.connection import MavlinkConnection
from uavplan.mavlink.messages import (
    AUTOPILOT_VERSION_ID,
    COMP_ID_MISSIONPLANNER,
    AutopilotVersion,
    Capability,
    CommandAck,
    CommandLong,
    Heartbeat,
    MavAutopilotId,
    MavCommand,
    MavResult,
    MavType,
    Message,
    MissionAck,
    Received,
    StatusText,
)
from uavplan.mavlink.transport import ConnectionSpec
from uavplan.mission.items import Autopilot

#: default wait for the vehicle's first HEARTBEAT (vehicles send 1 Hz; allow for some loss)
HEARTBEAT_TIMEOUT_S = 5.0
#: how long connecting waits for AUTOPILOT_VERSION (a vehicle may not answer at all)
CAPABILITY_WAIT_S = 0.5
#: our identity on the link: QGroundControl's system id; the component id is per client
GCS_SYSTEM_ID = 255
#: MAV_COMP_ID_MISSIONPLANNER, what QGroundControl uses (pass it to look like QGC)
GCS_COMPONENT_ID = COMP_ID_MISSIONPLANNER
#: the default component ids of our clients: MAV_COMP_ID_USER1..USER75, which no autopilot
#: or ground station claims. Two ground stations with one identity cannot be told apart:
#: the vehicle would take both for one partner and each would answer the other's requests.
SOURCE_COMPONENT_RANGE = range(25, 100)
_PROCESS_OFFSET = secrets.randbelow(len(SOURCE_COMPONENT_RANGE))
_CLIENTS = itertools.count()


def unique_component_id() -> int:
    """A component id for a new client: random per process, distinct for the next 75
    clients of this process (two processes collide with probability 1/75: pass
    ``--source-component`` to rule that out)."""
    n = len(SOURCE_COMPONENT_RANGE)
    # 44 is coprime to 75: successive clients walk the whole range before repeating
    return SOURCE_COMPONENT_RANGE[(_PROCESS_OFFSET + 44 * next(_CLIENTS)) % n]


@dataclass(frozen=True)
class VehicleInfo:
    """Who answered: ids to address, and the autopilot flavour that decides the mission layout."""

    system_id: int
    component_id: int
    mav_autopilot: int
    mav_type: int

    @property
    def autopilot(self) -> Autopilot:
        """PX4 or ArduPilot from HEARTBEAT.autopilot (reference §7.24); GENERIC otherwise."""
        if self.mav_autopilot == MavAutopilotId.ARDUPILOTMEGA:
            return Autopilot.ARDUPILOT
        if self.mav_autopilot == MavAutopilotId.PX4:
            return Autopilot.PX4
        return Autopilot.GENERIC


_CAPABILITY_COMMANDS = (MavCommand.REQUEST_MESSAGE, MavCommand.REQUEST_AUTOPILOT_CAPABILITIES)
#: how many of the vehicle's answers to other ground stations are kept
OVERHEARD_KEPT = 32


def _is_vehicle_heartbeat(hb: Heartbeat) -> bool:
    return hb.type != MavType.GCS and hb.autopilot != MavAutopilotId.INVALID


class VehicleLink:
    """One vehicle over one connection. Use :meth:`connect` to open and discover."""

    def __init__(self, connection: MavlinkConnection, vehicle: VehicleInfo) -> None:
        self.connection = connection
        self.vehicle = vehicle
        self.capabilities: Capability | None = None
        self.last_statustext: str | None = None
        #: round trip of the AUTOPILOT_VERSION request (its COMMAND_ACK), once measured
        self.handshake_rtt_s: float | None = None
        self._capability_request_at: float | None = None
        self._capability_requests = 0
        self._capability_refused = False
        #: the vehicle's COMMAND_ACK and MISSION_ACK to other ground stations, oldest first
        #: (a consumer takes them with ``popleft``); the last :data:`OVERHEARD_KEPT`
        self.overheard: deque[Received] = deque(maxlen=OVERHEARD_KEPT)

    # -- opening --------------------------------------------------------------------------
    @classmethod
    def connect(
        cls,
        conn: str | ConnectionSpec,
        *,
        target_system: int | None = None,
        heartbeat_timeout_s: float = HEARTBEAT_TIMEOUT_S,
        system_id: int = GCS_SYSTEM_ID,
        component_id: int | None = None,
    ) -> VehicleLink:
        """Open ``conn``, send our heartbeat and wait for a vehicle's.

        ``component_id``: our source component; by default one unique to this client
        (:func:`unique_component_id`), so that two ground stations never share an identity.

        Raises :class:`LinkError` (exit 4) when no vehicle heartbeat (from
        ``target_system``, if given) arrives within ``heartbeat_timeout_s``.
        """
        spec = conn if isinstance(conn, ConnectionSpec) else ConnectionSpec.parse(conn)
        connection = MavlinkConnection.open(
            spec,
            system_id=system_id,
            component_id=unique_component_id() if component_id is None else component_id,
            heartbeat=Heartbeat(type=MavType.GCS, autopilot=MavAutopilotId.INVALID),
        )
        try:
            vehicle = cls._wait_for_vehicle(connection, target_system, heartbeat_timeout_s)
        except BaseException:
            connection.close()
            raise
        link = cls(connection, vehicle)
        # As QGC and MAVSDK do on connecting, ask for AUTOPILOT_VERSION: its capability bits
        # say whether fence and rally transfers exist, and the answer times the link.
        link.wait_capabilities(CAPABILITY_WAIT_S, attempts=2)
        return link

    @staticmethod
    def _wait_for_vehicle(
        connection: MavlinkConnection, target_system: int | None, timeout_s: float
    ) -> VehicleInfo:
        deadline = time.monotonic() + timeout_s
        others: set[int] = set()
        while (remaining := deadline - time.monotonic()) > 0:
            received = connection.recv(remaining)
            if received is None or not isinstance(received.message, Heartbeat):
                continue
            hb = received.message
            if not _is_vehicle_heartbeat(hb):
                continue
            if target_system is not None and received.system_id != target_system:
                others.add(received.system_id)
                continue
            return VehicleInfo(received.system_id, received.component_id, hb.autopilot, hb.type)
        wanted = f"from system {target_system} " if target_system is not None else ""
        seen = f" (heard only from system(s) {sorted(others)})" if others else ""
        raise LinkError(
            f"no HEARTBEAT {wanted}within {timeout_s:g} s on {connection.description}{seen}; "
            "is the vehicle on and the connection string right?",
            step="connect: waiting for HEARTBEAT",
        )

    # -- traffic --------------------------------------------------------------------------
    def send(self, message: Message) -> None:
        self.connection.send(message)

    def recv(self, timeout_s: float) -> Received | None:
        """The next message from the vehicle addressed to us (or broadcast), or ``None``."""
        deadline = time.monotonic() + max(0.0, timeout_s)
        while True:
            received = self.connection.recv(max(0.0, deadline - time.monotonic()))
            if received is None:
                return None
            if self._accept(received):
                return received
            if time.monotonic() >= deadline:
                return None

    def _accept(self, received: Received) -> bool:
        if received.system_id != self.vehicle.system_id:
            return False
        message = received.message
        if isinstance(message, StatusText):
            self.last_statustext = message.text
            return True
        if received.component_id != self.vehicle.component_id:
            return False
        target_system = getattr(message, "target_system", 0)
        target_component = getattr(message, "target_component", 0)
        if target_system not in (0, self.connection.system_id) or target_component not in (
            0,
            self.connection.component_id,
        ):
            if isinstance(message, CommandAck | MissionAck):
                self.overheard.append(received)
            return False
        if isinstance(message, AutopilotVersion):
            self.capabilities = Capability(message.capabilities)
            self._time_handshake()
        elif isinstance(message, CommandAck) and message.command in _CAPABILITY_COMMANDS:
            self._time_handshake()
            if message.result != MavResult.ACCEPTED:
                self._capability_refused = True
        return True

    def _time_handshake(self) -> None:
        # Karn's rule: an answer to a repeated request does not say which one it answers
        if self._capability_requests == 1 and self.handshake_rtt_s is None:
            assert self._capability_request_at is not None
            self.handshake_rtt_s = time.monotonic() - self._capability_request_at

    def send_capability_request(self) -> None:
        """MAV_CMD_REQUEST_MESSAGE(AUTOPILOT_VERSION), as QGC and MAVSDK send on connect."""
        self._capability_request_at = time.monotonic()
        self._capability_requests += 1
        self.send(
            CommandLong(
                self.vehicle.system_id,
                self.vehicle.component_id,
                MavCommand.REQUEST_MESSAGE,
                param1=float(AUTOPILOT_VERSION_ID),
            )
        )

    def wait_capabilities(self, timeout_s: float, *, attempts: int = 3) -> Capability | None:
        """AUTOPILOT_VERSION.capabilities, asking up to ``attempts`` times; ``None`` if silent."""
        if self.capabilities is not None:
            return self.capabilities
        per_attempt = timeout_s / max(1, attempts)
        for _attempt in range(max(1, attempts)):
            self.send_capability_request()
            deadline = time.monotonic() + per_attempt
            while self.capabilities is None and (left := deadline - time.monotonic()) > 0:
                self.recv(left)
                if self._capability_refused:
                    return None
            if self.capabilities is not None:
                break
        return self.capabilities

    def close(self) -> None:
        self.connection.close()

    def __enter__(self) -> VehicleLink:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
