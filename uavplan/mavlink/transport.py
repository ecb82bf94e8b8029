"""Connection strings and byte transports (UDP, TCP, serial), independent of MAVLink.

Two spellings are accepted (SPEC §3):

=============================  ===================================  =======================
pymavlink                      MAVSDK-style URL                     meaning
=============================  ===================================  =======================
``udpin:HOST:PORT``            ``udpin://HOST:PORT``                listen on a UDP port
``udp:HOST:PORT``              ``udp://HOST:PORT`` (``udp://:P``)   listen (legacy spelling)
``udpout:HOST:PORT``           ``udpout://HOST:PORT``               send to a UDP port
``tcp:HOST:PORT``              ``tcp://`` / ``tcpout://HOST:PORT``  connect to a TCP server
``tcpin:HOST:PORT``            ``tcpin://HOST:PORT``                accept TCP clients
``DEVICE[,BAUD]``              ``serial://DEVICE[:BAUD]``           serial port
=============================  ===================================  =======================

A listening UDP/TCP endpoint may use port 0: the OS picks a free port, which
:attr:`Transport.local_address` reports. A listening endpoint talks to every peer it has
heard from (as pymavlink's ``udpin`` does), so several ground stations can share a mock
vehicle.
"""

from __future__ import annotations

import contextlib
import errno
import os
import select
import socket
import sys
import time
from dataclasses import dataclass
from typing import Literal

from uavplan.errors import InputError, LinkError

Kind = Literal["udpin", "udpout", "tcpout", "tcpin", "serial"]

DEFAULT_BAUD = 57600
#: a listening UDP endpoint forgets a peer it has not heard from for this long (if it has others)
UDP_PEER_TIMEOUT_S = 10.0
_UDP_MAX_DATAGRAM = 65535


@dataclass(frozen=True)
class ConnectionSpec:
    """A parsed connection string. ``str(spec)`` is the pymavlink spelling."""

    kind: Kind
    host: str = ""
    port: int = 0
    device: str = ""
    baud: int = DEFAULT_BAUD

    def __str__(self) -> str:
        if self.kind == "serial":
            return f"{self.device},{self.baud}"
        prefix = "tcp" if self.kind == "tcpout" else self.kind
        return f"{prefix}:{self.host}:{self.port}"

    @classmethod
    def parse(cls, text: str) -> ConnectionSpec:
        """Parse a pymavlink connection string or a MAVSDK-style URL.

        Raises :class:`InputError` naming the string and what is wrong with it.
        """
        raw = text.strip()
        if not raw:
            raise InputError("empty connection string", key="--conn")
        url_kinds: dict[str, Kind] = {
            "udp": "udpin",
            "udpin": "udpin",
            "udpout": "udpout",
            "tcp": "tcpout",
            "tcpout": "tcpout",
            "tcpin": "tcpin",
        }
        if "://" in raw:
            scheme, rest = raw.split("://", 1)
            scheme = scheme.lower()
            if scheme == "serial":
                return cls._serial(raw, rest, sep=":")
            if scheme not in url_kinds:
                raise _bad(raw, f"unknown scheme {scheme!r}")
            return cls._network(raw, url_kinds[scheme], rest)
        head, _, rest = raw.partition(":")
        plain_kinds: dict[str, Kind] = {
            "udpin": "udpin",
            "udp": "udpin",
            "udpout": "udpout",
            "tcp": "tcpout",
            "tcpin": "tcpin",
        }
        if head.lower() in plain_kinds and rest:
            return cls._network(raw, plain_kinds[head.lower()], rest)
        if head.lower() in ("serial",) and rest:
            return cls._serial(raw, rest, sep=",")
        return cls._serial(raw, raw, sep=",")

    @classmethod
    def _network(cls, raw: str, kind: Kind, rest: str) -> ConnectionSpec:
        host, sep, port_text = rest.rpartition(":")
        if not sep:
            raise _bad(raw, "expected HOST:PORT")
        host = host.strip("[]")
        try:
            port = int(port_text)
        except ValueError:
            raise _bad(raw, f"port {port_text!r} is not a number") from None
        if not 0 <= port <= 65535:
            raise _bad(raw, f"port {port} is outside 0..65535")
        listens = kind in ("udpin", "tcpin")
        if not host:
            if not listens:
                raise _bad(raw, "a host is needed to send to or connect to")
            host = "0.0.0.0"
        if port == 0 and not listens:
            raise _bad(raw, "port 0 is only valid for a listening endpoint")
        return cls(kind=kind, host=host, port=port)

    @classmethod
    def _serial(cls, raw: str, rest: str, *, sep: str) -> ConnectionSpec:
        device, baud = rest, DEFAULT_BAUD
        for candidate in (sep, "," if sep == ":" else ":"):
            head, found, tail = rest.rpartition(candidate)
            if found and tail.isdigit():
                device, baud = head, int(tail)
                break
        if not device or not (device.startswith(("/", ".")) or device.upper().startswith("COM")):
            raise _bad(
                raw,
                "not a known connection string (udpin:/udpout:/tcp:/tcpin:, "
                "udp:// udpin:// udpout:// tcp:// tcpin:// serial://, or a serial device path)",
            )
        if baud <= 0:
            raise _bad(raw, f"baud rate {baud} must be positive")
        return cls(kind="serial", device=device, baud=baud)


def _bad(raw: str, reason: str) -> InputError:
    return InputError(f"connection string {raw!r}: {reason}", key="--conn")


# ---------------------------------------------------------------------------------------------


class Transport:
    """A byte pipe. ``recv`` returns the chunks that arrived within ``timeout_s``."""

    description: str = ""

    def send(self, data: bytes) -> None:
        raise NotImplementedError

    def recv(self, timeout_s: float) -> list[bytes]:
        raise NotImplementedError

    def close(self) -> None:
        raise NotImplementedError

    @property
    def local_address(self) -> tuple[str, int] | None:
        return None


def open_transport(spec: ConnectionSpec, *, connect_timeout_s: float = 5.0) -> Transport:
    """Open the endpoint ``spec`` describes. Failures raise :class:`LinkError` (exit 4)."""
    try:
        if spec.kind == "udpin":
            return UdpServer(spec.host, spec.port)
        if spec.kind == "udpout":
            return UdpClient(spec.host, spec.port)
        if spec.kind == "tcpout":
            return TcpClient(spec.host, spec.port, connect_timeout_s=connect_timeout_s)
        if spec.kind == "tcpin":
            return TcpServer(spec.host, spec.port)
        return SerialPort(spec.device, spec.baud)
    except OSError as err:
        raise LinkError(f"cannot open {spec}: {err.strerror or err}", step="connect") from None


def _wait_readable(socks: list[socket.socket] | list[int], timeout_s: float) -> list:
    if timeout_s < 0:
        timeout_s = 0.0
    try:
        readable, _, _ = select.select(socks, [], [], timeout_s)
    except InterruptedError:  # pragma: no cover - PEP 475 retries select for us
        return []
    return readable


#: the receive buffer asked for on a UDP socket (bytes; the system may give less: Linux caps it
#: at net.core.rmem_max). A simulated vehicle at 100 times real time sends hundreds of
#: telemetry messages a second; on a loaded machine a reader that pauses for a second
#: overflowed the default 208 KiB and lost positions (gaps in a flown track)
UDP_RECEIVE_BUFFER_BYTES = 4 * 1024 * 1024


def _roomy(sock: socket.socket) -> None:
    """Ask for a receive buffer of :data:`UDP_RECEIVE_BUFFER_BYTES` (what the system allows)."""
    with contextlib.suppress(OSError):
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, UDP_RECEIVE_BUFFER_BYTES)


class UdpServer(Transport):
    """Listen on HOST:PORT; answer every peer heard from recently."""

    def __init__(self, host: str, port: int) -> None:
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            # no SO_REUSEADDR / SO_REUSEPORT: two processes on one UDP port would split the
            # datagrams between them; the second one must fail to open instead
            self._sock.bind((host, port))
        except OSError as err:
            self._sock.close()
            if err.errno == errno.EADDRINUSE:
                raise OSError(
                    err.errno,
                    f"UDP port {port} is already in use by another process "
                    "(a second vehicle or ground station on one udpin port would steal its "
                    "packets)",
                ) from None
            raise
        _roomy(self._sock)
        self._sock.setblocking(False)
        self._peers: dict[tuple[str, int], float] = {}
        bound = self._sock.getsockname()
        self.description = f"udpin:{bound[0]}:{bound[1]}"

    @property
    def local_address(self) -> tuple[str, int]:
        host, port = self._sock.getsockname()[:2]
        return host, port

    def send(self, data: bytes) -> None:
        now = time.monotonic()
        if len(self._peers) > 1:
            stale = [p for p, seen in self._peers.items() if now - seen > UDP_PEER_TIMEOUT_S]
            for peer in stale[: len(self._peers) - 1]:
                del self._peers[peer]
        for peer in list(self._peers):
            with contextlib.suppress(OSError):
                self._sock.sendto(data, peer)

    def recv(self, timeout_s: float) -> list[bytes]:
        chunks: list[bytes] = []
        if not _wait_readable([self._sock], timeout_s):
            return chunks
        while True:
            try:
                data, peer = self._sock.recvfrom(_UDP_MAX_DATAGRAM)
            except (BlockingIOError, InterruptedError):
                break
            except OSError as err:  # ICMP port unreachable from a peer that went away
                if err.errno in (errno.ECONNREFUSED, errno.ECONNRESET):
                    continue
                raise
            self._peers[peer] = time.monotonic()
            chunks.append(data)
        return chunks

    def close(self) -> None:
        self._sock.close()


class UdpClient(Transport):
    """Send to HOST:PORT from an OS-assigned port; accept datagrams from anyone."""

    def __init__(self, host: str, port: int) -> None:
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self._dest = (socket.gethostbyname(host), port)
            self._sock.bind(("0.0.0.0", 0))
        except OSError:
            self._sock.close()
            raise
        _roomy(self._sock)
        self._sock.setblocking(False)
        self.description = f"udpout:{host}:{port}"

    @property
    def local_address(self) -> tuple[str, int]:
        host, port = self._sock.getsockname()[:2]
        return host, port

    def send(self, data: bytes) -> None:
        with contextlib.suppress(OSError):
            self._sock.sendto(data, self._dest)

    def recv(self, timeout_s: float) -> list[bytes]:
        chunks: list[bytes] = []
        if not _wait_readable([self._sock], timeout_s):
            return chunks
        while True:
            try:
                data, _peer = self._sock.recvfrom(_UDP_MAX_DATAGRAM)
            except (BlockingIOError, InterruptedError):
                break
            except OSError as err:
                if err.errno in (errno.ECONNREFUSED, errno.ECONNRESET):
                    continue  # nobody listening (yet) at the destination
                raise
            chunks.append(data)
        return chunks

    def close(self) -> None:
        self._sock.close()


def _recv_stream(sock: socket.socket) -> bytes | None:
    """Read what is available; ``None`` means the peer closed the connection."""
    try:
        data = sock.recv(65536)
    except (BlockingIOError, InterruptedError):
        return b""
    except OSError:
        return None
    return data or None


class TcpClient(Transport):
    def __init__(self, host: str, port: int, *, connect_timeout_s: float) -> None:
        self.description = f"tcp:{host}:{port}"
        self._sock = socket.create_connection((host, port), timeout=connect_timeout_s)
        self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._sock.setblocking(False)
        self._closed = False

    def send(self, data: bytes) -> None:
        if self._closed:
            raise LinkError(f"{self.description}: the vehicle closed the TCP connection")
        try:
            self._sock.sendall(data)
        except BlockingIOError:  # pragma: no cover - a full socket buffer on loopback
            self._sock.setblocking(True)
            try:
                self._sock.sendall(data)
            finally:
                self._sock.setblocking(False)
        except OSError as err:
            self._closed = True
            raise LinkError(f"{self.description}: {err.strerror or err}") from None

    def recv(self, timeout_s: float) -> list[bytes]:
        if self._closed:
            raise LinkError(f"{self.description}: the vehicle closed the TCP connection")
        if not _wait_readable([self._sock], timeout_s):
            return []
        data = _recv_stream(self._sock)
        if data is None:
            self._closed = True
            raise LinkError(f"{self.description}: the vehicle closed the TCP connection")
        return [data] if data else []

    def close(self) -> None:
        self._sock.close()


class TcpServer(Transport):
    """Accept any number of TCP clients; send to all of them."""

    def __init__(self, host: str, port: int) -> None:
        self._listen = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            self._listen.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            self._listen.bind((host, port))
            self._listen.listen(8)
        except OSError:
            self._listen.close()
            raise
        self._listen.setblocking(False)
        self._clients: list[socket.socket] = []
        bound = self._listen.getsockname()
        self.description = f"tcpin:{bound[0]}:{bound[1]}"

    @property
    def local_address(self) -> tuple[str, int]:
        host, port = self._listen.getsockname()[:2]
        return host, port

    def send(self, data: bytes) -> None:
        for client in list(self._clients):
            try:
                client.sendall(data)
            except OSError:
                self._drop(client)

    def recv(self, timeout_s: float) -> list[bytes]:
        readable = _wait_readable([self._listen, *self._clients], timeout_s)
        chunks: list[bytes] = []
        for sock in readable:
            if sock is self._listen:
                with contextlib.suppress(BlockingIOError, InterruptedError):
                    client, _addr = self._listen.accept()
                    client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                    client.setblocking(False)
                    self._clients.append(client)
                continue
            data = _recv_stream(sock)
            if data is None:
                self._drop(sock)
            elif data:
                chunks.append(data)
        return chunks

    def _drop(self, client: socket.socket) -> None:
        if client in self._clients:
            self._clients.remove(client)
        client.close()

    def close(self) -> None:
        for client in self._clients:
            client.close()
        self._clients.clear()
        self._listen.close()


class SerialPort(Transport):
    """A serial device in raw mode (POSIX termios; pyserial is used instead when installed)."""

    def __init__(self, device: str, baud: int) -> None:
        self.description = f"{device},{baud}"
        self._serial = None
        self._fd: int | None = None
        try:
            import serial  # type: ignore[import-not-found,import-untyped,unused-ignore]
        except ImportError:
            serial = None
        if serial is not None:
            self._serial = serial.Serial(device, baud, timeout=0)
            return
        if sys.platform.startswith("win"):  # pragma: no cover - no termios on Windows
            raise OSError(errno.ENOSYS, "serial links on Windows need the pyserial package")
        import termios
        import tty

        fd = os.open(device, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        try:
            tty.setraw(fd)
            attrs = termios.tcgetattr(fd)
            speed = getattr(termios, f"B{baud}", None)
            if speed is None:
                raise OSError(errno.EINVAL, f"baud rate {baud} is not supported by termios")
            attrs[4] = attrs[5] = speed
            termios.tcsetattr(fd, termios.TCSANOW, attrs)
        except (OSError, termios.error) as err:
            os.close(fd)
            if isinstance(err, OSError):
                raise
            raise OSError(errno.EIO, f"cannot configure {device}: {err}") from None
        self._fd = fd

    def send(self, data: bytes) -> None:
        if self._serial is not None:
            self._serial.write(data)
            return
        assert self._fd is not None
        view = memoryview(data)
        while view:
            try:
                written = os.write(self._fd, view)
            except BlockingIOError:
                select.select([], [self._fd], [], 1.0)
                continue
            view = view[written:]

    def recv(self, timeout_s: float) -> list[bytes]:
        if self._serial is not None:
            deadline = time.monotonic() + max(0.0, timeout_s)
            while True:
                data = self._serial.read(self._serial.in_waiting or 1)
                if data or time.monotonic() >= deadline:
                    return [data] if data else []
                time.sleep(0.001)
        assert self._fd is not None
        if not _wait_readable([self._fd], timeout_s):
            return []
        try:
            data = os.read(self._fd, 4096)
        except BlockingIOError:
            return []
        return [data] if data else []

    def close(self) -> None:
        if self._serial is not None:
            self._serial.close()
        elif self._fd is not None:
            os.close(self._fd)
            self._fd = None
