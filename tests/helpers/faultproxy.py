"""A seeded UDP fault proxy: put a bad link between a ground station and a vehicle.

:class:`FaultProxy` listens on 127.0.0.1 (OS-assigned port) for the ground station
(``udpout:127.0.0.1:<proxy port>``) and forwards to the vehicle's UDP address, applying
:class:`ProxyFaults` to each datagram in each direction: drop, duplicate, reorder (hold a
datagram back until after the next one), delay (hold it for a random time up to
``max_delay_s``) and flip one random bit (the receiver's CRC check then rejects the frame).
Every decision comes from one ``random.Random`` per direction seeded from ``seed``, so a
run's fault pattern depends only on the seed and the traffic.

``only``: restrict faults to MAVLink message ids (e.g. :data:`MISSION_MESSAGE_IDS`, so
heartbeats pass and a 100 % loss run measures the mission protocol, not discovery).

It runs in a background thread (a context manager) and is used by the link-chaos tests and
``tools/link_chaos.py``. Nothing in the product imports it, so it lives with the tests.
"""

from __future__ import annotations

import heapq
import random
import select
import socket
import threading
import time
from dataclasses import dataclass, field

#: MAVLink ids of the mission protocol messages (COUNT, REQUEST, REQUEST_INT, REQUEST_LIST,
#: ITEM, ITEM_INT, ACK, CLEAR_ALL)
MISSION_MESSAGE_IDS = frozenset({44, 40, 51, 43, 39, 73, 47, 45})

_MAX_DATAGRAM = 65535


@dataclass(frozen=True)
class ProxyFaults:
    """Per-datagram fault probabilities, applied independently in each direction."""

    drop_rate: float = 0.0
    duplicate_rate: float = 0.0
    reorder_rate: float = 0.0
    delay_rate: float = 0.0
    max_delay_s: float = 0.05
    bitflip_rate: float = 0.0
    seed: int = 0
    only: frozenset[int] | None = None

    def __post_init__(self) -> None:
        for name in ("drop_rate", "duplicate_rate", "reorder_rate", "delay_rate", "bitflip_rate"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name} must be within [0, 1], got {value!r}")
        if not 0.0 <= self.max_delay_s <= 10.0:
            raise ValueError("max_delay_s must be within [0, 10] s")


def message_id(datagram: bytes) -> int | None:
    """The MAVLink message id of the first frame in ``datagram`` (v1 or v2), if any."""
    if len(datagram) >= 10 and datagram[0] == 0xFD:
        return datagram[7] | (datagram[8] << 8) | (datagram[9] << 16)
    if len(datagram) >= 6 and datagram[0] == 0xFE:
        return datagram[5]
    return None


@dataclass
class DirectionStats:
    forwarded: int = 0
    dropped: int = 0
    duplicated: int = 0
    reordered: int = 0
    delayed: int = 0
    flipped: int = 0


@dataclass
class _Direction:
    rng: random.Random
    stats: DirectionStats = field(default_factory=DirectionStats)
    held: bytes | None = None


class FaultProxy:
    """UDP proxy from a ground station to ``vehicle_address`` with seeded faults."""

    def __init__(self, vehicle_address: tuple[str, int], faults: ProxyFaults) -> None:
        self.vehicle_address = vehicle_address
        self.faults = faults
        self._gcs_side = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._gcs_side.bind(("127.0.0.1", 0))
        self._vehicle_side = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._vehicle_side.bind(("127.0.0.1", 0))
        self._gcs_peer: tuple[str, int] | None = None
        seeds = random.Random(faults.seed)
        self._up = _Direction(random.Random(seeds.getrandbits(64)))  # GCS -> vehicle
        self._down = _Direction(random.Random(seeds.getrandbits(64)))  # vehicle -> GCS
        self._delayed: list[tuple[float, int, bool, bytes]] = []
        self._order = 0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.error: BaseException | None = None

    @property
    def port(self) -> int:
        """Where the ground station sends: ``udpout:127.0.0.1:<port>``."""
        return int(self._gcs_side.getsockname()[1])

    @property
    def conn(self) -> str:
        return f"udpout:127.0.0.1:{self.port}"

    @property
    def uplink(self) -> DirectionStats:
        return self._up.stats

    @property
    def downlink(self) -> DirectionStats:
        return self._down.stats

    def set_faults(self, faults: ProxyFaults) -> None:
        """Change the fault rates while running (the generators keep their state)."""
        self.faults = faults

    # -- running ------------------------------------------------------------------------
    def start(self) -> FaultProxy:
        self._thread = threading.Thread(target=self._run_guarded, name="fault-proxy", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5.0)
            self._thread = None
        self._gcs_side.close()
        self._vehicle_side.close()

    def __enter__(self) -> FaultProxy:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

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
            wait = 0.05
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
                    self._forward(True, data)
                else:
                    self._forward(False, data)
            if not readable:
                self._flush_held()

    # -- faults -------------------------------------------------------------------------
    def _forward(self, up: bool, data: bytes) -> None:
        f = self.faults
        direction = self._up if up else self._down
        rng, stats = direction.rng, direction.stats
        if f.only is not None and message_id(data) not in f.only:
            self._emit(up, data)
            return
        if rng.random() < f.drop_rate:
            stats.dropped += 1
            return
        copies = 1
        if rng.random() < f.duplicate_rate:
            stats.duplicated += 1
            copies = 2
        if rng.random() < f.bitflip_rate:
            stats.flipped += 1
            bit = rng.randrange(len(data) * 8)
            flipped = bytearray(data)
            flipped[bit // 8] ^= 1 << (bit % 8)
            data = bytes(flipped)
        if rng.random() < f.delay_rate:
            stats.delayed += 1
            release = time.monotonic() + rng.uniform(0.0, f.max_delay_s)
            for _ in range(copies):
                self._order += 1
                heapq.heappush(self._delayed, (release, self._order, up, data))
            return
        if direction.held is None and rng.random() < f.reorder_rate:
            stats.reordered += 1
            direction.held = data
            copies -= 1
        for _ in range(copies):
            self._emit(up, data)
        if direction.held is not None and direction.held is not data:
            held, direction.held = direction.held, None
            self._emit(up, held)

    def _flush_held(self) -> None:
        for up, direction in ((True, self._up), (False, self._down)):
            if direction.held is not None:
                held, direction.held = direction.held, None
                self._emit(up, held)

    def _emit(self, up: bool, data: bytes) -> None:
        try:
            if up:
                self._vehicle_side.sendto(data, self.vehicle_address)
                self._up.stats.forwarded += 1
            elif self._gcs_peer is not None:
                self._gcs_side.sendto(data, self._gcs_peer)
                self._down.stats.forwarded += 1
        except OSError:
            pass
