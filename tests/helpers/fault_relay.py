"""A seeded UDP fault relay between a ground station and a vehicle, for tests and tools.

:class:`FaultRelay` listens on 127.0.0.1 (an OS-assigned port) for the ground station
(``udpout:127.0.0.1:<port>``) and forwards to the vehicle's UDP address, applying
:class:`RelayFaults` to each datagram in each direction: drop, duplicate, reorder (a datagram
held back behind the next ``reorder_depth`` ones of its direction, or ``max_hold_s`` at
most), delay (up to ``max_delay_s``). On top of the
random faults, :meth:`FaultRelay.outage` drops everything both ways for a while, and
:meth:`FaultRelay.retarget` points it at another vehicle address (a vehicle restarted on a
new port). Every decision comes from one ``random.Random`` per direction seeded from
``seed``: a run's fault pattern depends only on the seed and the traffic.

It also keeps the truth: every position (GLOBAL_POSITION_INT), HEARTBEAT and MISSION_ACK the
vehicle sent, decoded before any fault (:attr:`FaultRelay.truth`, :attr:`FaultRelay.events`),
with the wall time it passed. That is what the vehicle really did, against which what the
ground station says can be judged.

This lives with the tests, not in the product (issue 36: test harnesses leave the package).
``tests/helpers/faultproxy.py`` does part of this for the upload tests; this relay adds
what watching a flight needs: outages, a longer reordering, a restarted vehicle, the truth.
"""

from __future__ import annotations

import heapq
import random
import select
import socket
import struct
import threading
import time
from collections import deque
from dataclasses import dataclass, field

_MAX_DATAGRAM = 65535
#: MAVLink message ids the relay decodes
_HEARTBEAT, _GLOBAL_POSITION_INT, _MISSION_ACK, _STATUSTEXT = 0, 33, 47, 253


@dataclass(frozen=True)
class RelayFaults:
    """Per-datagram fault probabilities, applied independently in each direction."""

    drop_rate: float = 0.0
    duplicate_rate: float = 0.0
    reorder_rate: float = 0.0
    reorder_depth: int = 3
    max_hold_s: float = 0.05
    delay_rate: float = 0.0
    max_delay_s: float = 0.05
    seed: int = 0
    #: the random faults apply to the vehicle's datagrams only (its telemetry), not to the
    #: ground station's (outages apply both ways regardless)
    down_only: bool = False

    def __post_init__(self) -> None:
        for name in ("drop_rate", "duplicate_rate", "reorder_rate", "delay_rate"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name} must be within [0, 1], got {value!r}")
        if not 1 <= self.reorder_depth <= 100:
            raise ValueError("reorder_depth must be within 1..100")
        if not 0.0 <= self.max_delay_s <= 10.0:
            raise ValueError("max_delay_s must be within [0, 10] s")


@dataclass(frozen=True)
class Position:
    """A GLOBAL_POSITION_INT as the vehicle sent it, with the wall time it passed."""

    wall_s: float
    time_s: float  # time_boot_ms / 1000
    lat_deg: float
    lon_deg: float
    alt_amsl_m: float
    relative_alt_m: float
    epoch: int  # which vehicle process (0, then 1 after a retarget ...)


@dataclass(frozen=True)
class Event:
    """Something else the vehicle sent: a HEARTBEAT (``custom_mode``, ``armed``), a
    MISSION_ACK (``target``, ``result``, ``mission_type``) or a STATUSTEXT (``text``)."""

    wall_s: float
    kind: str
    detail: dict[str, object]
    epoch: int


@dataclass
class DirectionStats:
    forwarded: int = 0
    dropped: int = 0
    duplicated: int = 0
    reordered: int = 0
    delayed: int = 0
    outage_dropped: int = 0


@dataclass
class _Direction:
    rng: random.Random
    stats: DirectionStats = field(default_factory=DirectionStats)
    #: (datagrams still to let by, release time at the latest, data)
    held: deque[tuple[int, float, bytes]] = field(default_factory=deque)


def _frames(datagram: bytes) -> list[tuple[int, bytes]]:
    """The (message id, payload) of each MAVLink 2 frame in ``datagram`` (v1 frames too)."""
    out = []
    i = 0
    while i < len(datagram):
        magic = datagram[i]
        if magic == 0xFD and i + 10 <= len(datagram):
            n = datagram[i + 1]
            signed = datagram[i + 2] & 0x01
            msgid = datagram[i + 7] | (datagram[i + 8] << 8) | (datagram[i + 9] << 16)
            out.append((msgid, datagram[i + 10 : i + 10 + n]))
            i += 12 + n + (13 if signed else 0)
        elif magic == 0xFE and i + 6 <= len(datagram):
            n = datagram[i + 1]
            out.append((datagram[i + 5], datagram[i + 6 : i + 6 + n]))
            i += 8 + n
        else:
            break
    return out


def _padded(payload: bytes, size: int) -> bytes:
    # MAVLink 2 drops trailing zero bytes of a payload
    return payload + bytes(max(0, size - len(payload)))


class FaultRelay:
    """UDP relay from a ground station to ``vehicle_address`` with seeded faults."""

    def __init__(self, vehicle_address: tuple[str, int], faults: RelayFaults) -> None:
        self.vehicle_address = vehicle_address
        self.faults = faults
        self._gcs_side = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._gcs_side.bind(("127.0.0.1", 0))
        self._vehicle_side = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._vehicle_side.bind(("127.0.0.1", 0))
        for sock in (self._gcs_side, self._vehicle_side):
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
        self._gcs_peer: tuple[str, int] | None = None
        seeds = random.Random(faults.seed)
        self._up = _Direction(random.Random(seeds.getrandbits(64)))  # GCS -> vehicle
        self._down = _Direction(random.Random(seeds.getrandbits(64)))  # vehicle -> GCS
        self._delayed: list[tuple[float, int, bool, bytes]] = []
        self._order = 0
        self._outage_until = -1.0
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.epoch = 0
        #: message ids the ground station sent, counted (before any fault)
        self.uplink_ids: dict[int, int] = {}
        self.truth: list[Position] = []
        self.events: list[Event] = []
        self.error: BaseException | None = None

    # -- set-up -------------------------------------------------------------------------
    @property
    def port(self) -> int:
        return int(self._gcs_side.getsockname()[1])

    @property
    def conn(self) -> str:
        """Where the ground station sends: ``udpout:127.0.0.1:<port>``."""
        return f"udpout:127.0.0.1:{self.port}"

    @property
    def uplink(self) -> DirectionStats:
        return self._up.stats

    @property
    def downlink(self) -> DirectionStats:
        return self._down.stats

    def outage(self, duration_s: float) -> None:
        """Drop every datagram, both ways, for ``duration_s`` from now (wall seconds)."""
        with self._lock:
            self._outage_until = time.monotonic() + duration_s

    @property
    def in_outage(self) -> bool:
        return time.monotonic() < self._outage_until

    def retarget(self, vehicle_address: tuple[str, int]) -> None:
        """Forward to another vehicle address from now on (a restarted vehicle); its
        messages are recorded under the next ``epoch``."""
        with self._lock:
            self.vehicle_address = vehicle_address
            self.epoch += 1

    def start(self) -> FaultRelay:
        self._thread = threading.Thread(target=self._run_guarded, name="fault-relay", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5.0)
            self._thread = None
        self._gcs_side.close()
        self._vehicle_side.close()

    def __enter__(self) -> FaultRelay:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # -- what the vehicle did -----------------------------------------------------------
    def positions(self, epoch: int = 0) -> list[Position]:
        with self._lock:
            return [p for p in self.truth if p.epoch == epoch]

    def last_position(self) -> Position | None:
        with self._lock:
            return self.truth[-1] if self.truth else None

    def heartbeats(self) -> list[Event]:
        with self._lock:
            return [e for e in self.events if e.kind == "heartbeat"]

    def last_event(self, kind: str) -> Event | None:
        with self._lock:
            for event in reversed(self.events):
                if event.kind == kind:
                    return event
        return None

    def vehicle_time_at(self, wall_s: float) -> float | None:
        """The vehicle's clock (its newest position sent) at wall time ``wall_s``, on the
        clock of the epoch then."""
        with self._lock:
            best = None
            for p in self.truth:
                if p.wall_s > wall_s:
                    break
                best = p.time_s
            return best

    def _record(self, data: bytes) -> None:
        now = time.monotonic()
        for msgid, payload in _frames(data):
            if msgid == _GLOBAL_POSITION_INT:
                t, lat, lon, alt, rel = struct.unpack_from("<Iiiii", _padded(payload, 28))
                position = Position(now, t / 1000.0, lat / 1e7, lon / 1e7, alt / 1e3, rel / 1e3,
                                    self.epoch)  # fmt: skip
                with self._lock:
                    self.truth.append(position)
            elif msgid == _HEARTBEAT:
                custom, mav_type, _autopilot, base, _status = struct.unpack_from(
                    "<IBBBB", _padded(payload, 9)
                )
                if mav_type == 6:  # another ground station's heartbeat: not the vehicle's
                    continue
                detail: dict[str, object] = {"custom_mode": custom, "armed": bool(base & 0x80)}
                with self._lock:
                    self.events.append(Event(now, "heartbeat", detail, self.epoch))
            elif msgid == _MISSION_ACK:
                ts, tc, result, mission_type = struct.unpack_from("<BBBB", _padded(payload, 4))
                detail = {"target": (ts, tc), "result": result, "mission_type": mission_type}
                with self._lock:
                    self.events.append(Event(now, "mission_ack", detail, self.epoch))
            elif msgid == _STATUSTEXT:
                text = _padded(payload, 51)[1:51].split(b"\0", 1)[0].decode("utf-8", "replace")
                with self._lock:
                    self.events.append(Event(now, "statustext", {"text": text}, self.epoch))

    # -- running --------------------------------------------------------------------------
    def _run_guarded(self) -> None:
        try:
            self._run()
        except BaseException as err:  # surfaced to the caller through .error
            self.error = err

    def _run(self) -> None:
        sockets = [self._gcs_side, self._vehicle_side]
        while not self._stop.is_set():
            now = time.monotonic()
            while self._delayed and self._delayed[0][0] <= now:
                _, _, up, data = heapq.heappop(self._delayed)
                self._emit(up, data)
            wait = 0.02
            if self._delayed:
                wait = max(0.0, min(wait, self._delayed[0][0] - now))
            readable, _, _ = select.select(sockets, [], [], wait)
            for sock in readable:
                try:
                    data, peer = sock.recvfrom(_MAX_DATAGRAM)
                except OSError:  # ICMP port unreachable from a peer that went away
                    continue
                if sock is self._gcs_side:
                    self._gcs_peer = peer
                    for msgid, _ in _frames(data):
                        self.uplink_ids[msgid] = self.uplink_ids.get(msgid, 0) + 1
                    self._forward(True, data)
                else:
                    if peer != self.vehicle_address:
                        continue  # a vehicle that was replaced: not heard any more
                    self._record(data)
                    self._forward(False, data)
            if not readable:
                self._flush_held()
            else:
                for up, direction in ((True, self._up), (False, self._down)):
                    self._release_held(up, direction, went_by=0)

    def _forward(self, up: bool, data: bytes) -> None:
        f = self.faults
        direction = self._up if up else self._down
        rng, stats = direction.rng, direction.stats
        # every decision is drawn, whatever happens to the datagram: the pattern of the
        # random faults does not depend on when an outage falls
        drop = rng.random() < f.drop_rate
        duplicate = rng.random() < f.duplicate_rate
        delay = rng.random() < f.delay_rate
        delay_s = rng.uniform(0.0, f.max_delay_s)
        reorder = rng.random() < f.reorder_rate
        if up and f.down_only:
            drop = duplicate = delay = reorder = False
        if self.in_outage:
            stats.outage_dropped += 1
            return
        if drop:
            stats.dropped += 1
            return
        copies = 2 if duplicate else 1
        stats.duplicated += duplicate
        if delay:
            stats.delayed += 1
            release = time.monotonic() + delay_s
            for _ in range(copies):
                self._order += 1
                heapq.heappush(self._delayed, (release, self._order, up, data))
            return
        if reorder:
            stats.reordered += 1
            direction.held.append((f.reorder_depth, time.monotonic() + f.max_hold_s, data))
            copies -= 1
        for _ in range(copies):
            self._emit(up, data)
            self._release_held(up, direction)

    def _release_held(self, up: bool, direction: _Direction, *, went_by: int = 1) -> None:
        """``went_by`` datagrams went by: those held back that waited long enough (in
        datagrams, or in time) go now."""
        now = time.monotonic()
        ready = []
        for _ in range(len(direction.held)):
            left, until, data = direction.held.popleft()
            if left <= went_by or now >= until:
                ready.append(data)
            else:
                direction.held.append((left - went_by, until, data))
        for data in ready:
            self._emit(up, data)

    def _flush_held(self) -> None:
        for up, direction in ((True, self._up), (False, self._down)):
            while direction.held:
                _, _, data = direction.held.popleft()
                self._emit(up, data)

    def _emit(self, up: bool, data: bytes) -> None:
        if self.in_outage:
            (self._up if up else self._down).stats.outage_dropped += 1
            return
        try:
            if up:
                self._vehicle_side.sendto(data, self.vehicle_address)
                self._up.stats.forwarded += 1
            elif self._gcs_peer is not None:
                self._gcs_side.sendto(data, self._gcs_peer)
                self._down.stats.forwarded += 1
        except OSError:
            pass
