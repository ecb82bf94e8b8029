"""The I/O loop around :class:`~uavplan.sim.vehicle.SimVehicle`: a simulated vehicle on a real
MAVLink endpoint.

:class:`MockVehicle` opens any connection string of :mod:`uavplan.mavlink.transport` (UDP,
TCP, serial), so QGroundControl, MAVProxy, MAVSDK, pymavlink or our own ground station can
talk to it, and drives the sans-I/O vehicle with the monotonic clock: each received message
goes to :meth:`~uavplan.sim.vehicle.SimVehicle.receive`, the quiet moments to
:meth:`~uavplan.sim.vehicle.SimVehicle.tick`, and what they return is encoded and sent. Use it
as a context manager (or :meth:`start` / :meth:`stop`) to run it in a background thread, or
:meth:`run` in the foreground until a :class:`threading.Event` is set.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from uavplan.autopilot.model import FlightEvent
from uavplan.mavlink.connection import MavlinkConnection
from uavplan.mavlink.messages import Message, MissionItemInt
from uavplan.mavlink.modes import FlightMode
from uavplan.mavlink.transport import ConnectionSpec
from uavplan.mission.items import Autopilot, MissionItem, MissionType
from uavplan.sim.faults import Faults
from uavplan.sim.vehicle import SimConfig
from uavplan.sim.vehicles import new_vehicle

__all__ = ["MockVehicle", "VehicleSnapshot", "VehicleStats"]

#: the loop wakes at least this often (seconds)
_MAX_SLEEP_S = 0.05


@dataclass(frozen=True)
class VehicleStats:
    uploads_accepted: int
    uploads_failed: int
    downloads_served: int
    clears: int
    dropped_in: int
    dropped_out: int
    duplicated: int
    reordered: int


@dataclass(frozen=True)
class VehicleSnapshot:
    """The vehicle's state at one moment (for tests and the command's log)."""

    armed: bool
    mode: FlightMode
    landed: bool
    lat_deg: float
    lon_deg: float
    alt_amsl_m: float
    relative_alt_m: float
    current_seq: int
    mission_state: int
    sim_time_s: float
    battery_remaining_pct: float
    link_lost: bool
    #: (armed at, disarmed at or None while armed) in simulated seconds, oldest first
    armed_periods: tuple[tuple[float, float | None], ...]


class MockVehicle:
    """A simulated PX4 or ArduPilot vehicle on a real MAVLink endpoint."""

    def __init__(self, conn: str | ConnectionSpec, config: SimConfig | None = None) -> None:
        self.config = config or SimConfig()
        c = self.config
        self.connection = MavlinkConnection.open(
            conn, system_id=c.system_id, component_id=c.component_id
        )
        self._lock = threading.RLock()
        #: notified after every message and timer pass, for :meth:`wait_for`
        self._changed = threading.Condition(self._lock)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.vehicle = new_vehicle(c, time.monotonic())
        self.error: BaseException | None = None

    # -- public ---------------------------------------------------------------------------
    @property
    def address(self) -> tuple[str, int]:
        """(host, port) the vehicle listens on (port chosen by the OS for port 0)."""
        addr = self.connection.local_address
        if addr is None:
            raise RuntimeError("this endpoint does not listen")
        host = "127.0.0.1" if addr[0] in ("0.0.0.0", "") else addr[0]
        return host, addr[1]

    @property
    def autopilot(self) -> Autopilot:
        return self.config.autopilot

    def wire_items(self, mission_type: MissionType) -> list[MissionItemInt]:
        """What the vehicle stores for that plan type, as received."""
        with self._lock:
            return self.vehicle.wire_items(mission_type)

    def items(self, mission_type: MissionType) -> list[MissionItem]:
        """The stored plan type as MissionItems (seq = index; ArduPilot's home included)."""
        with self._lock:
            return self.vehicle.items(mission_type)

    def preload(self, mission_type: MissionType, items: list[MissionItem]) -> None:
        """Store a plan as if it had been uploaded."""
        with self._lock:
            self.vehicle.preload(mission_type, items)

    def set_faults(self, faults: Faults) -> None:
        """Change the faults while running (the packet generators keep their state)."""
        with self._lock:
            self.vehicle.set_faults(faults)

    def snapshot(self) -> VehicleSnapshot:
        with self._lock:
            v = self.vehicle
            lat, lon, alt, rel = v.position()
            return VehicleSnapshot(
                armed=v.armed,
                mode=v.mode,
                landed=v.flight.landed,
                lat_deg=lat,
                lon_deg=lon,
                alt_amsl_m=alt,
                relative_alt_m=rel,
                current_seq=v.server.current_seq,
                mission_state=int(v.mission_state),
                sim_time_s=v.sim_time_s,
                battery_remaining_pct=100.0 * v.battery.remaining_fraction,
                link_lost=v.link_lost,
                armed_periods=tuple(v.armed_periods),
            )

    def wait_for(self, predicate: Callable[[MockVehicle], bool], timeout_s: float) -> bool:
        """Block until ``predicate(self)`` holds (checked after each message the vehicle
        handles and each timer pass) or ``timeout_s`` passes; returns whether it holds.
        Tests wait for a state this way instead of sleeping."""
        with self._changed:
            return self._changed.wait_for(lambda: predicate(self), timeout_s)

    @property
    def busy(self) -> bool:
        with self._lock:
            return self.vehicle.busy

    @property
    def rejected_messages(self) -> int:
        return self.vehicle.rejected_messages

    @property
    def last_rejection(self) -> str | None:
        return self.vehicle.last_rejection

    def flight_events(self) -> tuple[FlightEvent, ...]:
        """What the flight model reported so far (simulated times), oldest first."""
        with self._lock:
            return tuple(self.vehicle.flight_events)

    def stats(self) -> VehicleStats:
        with self._lock:
            accepted, failed, downloads, clears = self.vehicle.server.counters()
            f = self.vehicle.injector
            return VehicleStats(
                accepted,
                failed,
                downloads,
                clears,
                f.dropped_in,
                f.dropped_out,
                f.duplicated,
                f.reordered,
            )

    def start(self) -> MockVehicle:
        if self._thread is not None:
            raise RuntimeError("already started")
        self._thread = threading.Thread(target=self._run_guarded, name="mock-vehicle", daemon=True)
        self._thread.start()
        return self

    def stop(self, timeout_s: float = 5.0) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout_s)
            self._thread = None
        self.connection.close()

    def __enter__(self) -> MockVehicle:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def run(self, stop: threading.Event | None = None) -> None:
        """Serve in the calling thread until ``stop`` (or :meth:`stop`) is set."""
        if stop is not None:
            self._stop = stop
        self._serve()

    # -- the loop -------------------------------------------------------------------------
    def _run_guarded(self) -> None:
        try:
            self._serve()
        except BaseException as err:  # surfaced to tests through .error
            self.error = err

    def _send(self, messages: list[Message]) -> None:
        for message in messages:
            self.connection.send_bytes(self.connection.encode(message))

    def _serve(self) -> None:
        vehicle = self.vehicle
        while not self._stop.is_set():
            now = time.monotonic()
            with self._changed:
                out = vehicle.tick(now)
                wake = min(vehicle.next_wakeup(now), now + _MAX_SLEEP_S)
                self._changed.notify_all()
            self._send(out)
            received = self.connection.recv(max(0.0, wake - time.monotonic()))
            with self._changed:
                if received is None:
                    out = vehicle.tick(time.monotonic(), link_idle=True)
                else:
                    out = vehicle.receive(received, time.monotonic())
                self._changed.notify_all()
            self._send(out)
