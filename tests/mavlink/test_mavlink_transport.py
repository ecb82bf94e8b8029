"""Connection strings, transports, the MAVLink 2 codec, and the package's import rules."""

from __future__ import annotations

import ast
import math
import os
import socket
import time
from pathlib import Path

import pytest

from uavplan.errors import InputError, LinkError
from uavplan.mavlink.connection import MavlinkConnection
from uavplan.mavlink.messages import (
    AutopilotVersion,
    CommandAck,
    CommandLong,
    Heartbeat,
    MissionAck,
    MissionClearAll,
    MissionCount,
    MissionCurrent,
    MissionItemInt,
    MissionRequest,
    MissionRequestList,
    MissionSetCurrent,
    StatusText,
    UnknownMessage,
    message_name,
)
from uavplan.mavlink.transport import ConnectionSpec, SerialPort, open_transport

pytestmark = pytest.mark.timeout(30)

ROOT = Path(__file__).resolve().parents[2]


# ---------------------------------------------------------------------------------------------
# Connection strings


@pytest.mark.parametrize(
    ("text", "kind", "host", "port"),
    [
        ("udpin:0.0.0.0:14550", "udpin", "0.0.0.0", 14550),
        ("udp:127.0.0.1:14550", "udpin", "127.0.0.1", 14550),
        ("udpout:10.0.0.2:14555", "udpout", "10.0.0.2", 14555),
        ("tcp:127.0.0.1:5760", "tcpout", "127.0.0.1", 5760),
        ("tcpin:0.0.0.0:5760", "tcpin", "0.0.0.0", 5760),
        ("udp://:14540", "udpin", "0.0.0.0", 14540),
        ("udp://127.0.0.1:14540", "udpin", "127.0.0.1", 14540),
        ("udpin://0.0.0.0:14550", "udpin", "0.0.0.0", 14550),
        ("udpout://192.168.1.5:14550", "udpout", "192.168.1.5", 14550),
        ("tcp://127.0.0.1:5760", "tcpout", "127.0.0.1", 5760),
        ("tcpout://127.0.0.1:5760", "tcpout", "127.0.0.1", 5760),
        ("tcpin://0.0.0.0:5761", "tcpin", "0.0.0.0", 5761),
        ("UDPIN:127.0.0.1:0", "udpin", "127.0.0.1", 0),
    ],
)
def test_network_connection_strings(text: str, kind: str, host: str, port: int) -> None:
    spec = ConnectionSpec.parse(text)
    assert (spec.kind, spec.host, spec.port) == (kind, host, port)
    assert ConnectionSpec.parse(str(spec)) == spec  # str() is the pymavlink spelling


@pytest.mark.parametrize(
    ("text", "device", "baud"),
    [
        ("/dev/ttyUSB0", "/dev/ttyUSB0", 57600),
        ("/dev/ttyACM0,115200", "/dev/ttyACM0", 115200),
        ("serial:///dev/ttyUSB0:921600", "/dev/ttyUSB0", 921600),
        (
            "serial:///dev/serial/by-id/usb-Hex_ProfiCNC:57600",
            "/dev/serial/by-id/usb-Hex_ProfiCNC",
            57600,
        ),
        ("COM3,57600", "COM3", 57600),
    ],
)
def test_serial_connection_strings(text: str, device: str, baud: int) -> None:
    spec = ConnectionSpec.parse(text)
    assert (spec.kind, spec.device, spec.baud) == ("serial", device, baud)


@pytest.mark.parametrize(
    ("text", "reason"),
    [
        ("", "empty"),
        ("udpout::14550", "a host is needed"),
        ("udpout:127.0.0.1:0", "port 0"),
        ("udpin:127.0.0.1:70000", "outside 0..65535"),
        ("udpin:127.0.0.1:abc", "not a number"),
        ("http://127.0.0.1:80", "unknown scheme"),
        ("udp://127.0.0.1", "HOST:PORT"),
        ("localhost", "not a known connection string"),
    ],
)
def test_bad_connection_strings_name_the_problem(text: str, reason: str) -> None:
    with pytest.raises(InputError) as info:
        ConnectionSpec.parse(text)
    assert reason in str(info.value)
    assert info.value.exit_code == 2


def test_nothing_listening_on_tcp_is_a_link_error() -> None:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]  # closed again: nobody listens there
    with pytest.raises(LinkError) as info:
        open_transport(ConnectionSpec.parse(f"tcp:127.0.0.1:{port}"))
    assert info.value.exit_code == 4
    assert "cannot open" in str(info.value)


# ---------------------------------------------------------------------------------------------
# Codec: every message type we model survives encode -> bytes -> decode


ALL_MESSAGES = [
    Heartbeat(type=2, autopilot=12, base_mode=1, custom_mode=65536, system_status=3),
    MissionCount(1, 1, 205, 2),
    MissionRequest(255, 190, 17, 1, int_form=True),
    MissionRequest(255, 190, 18, 0, int_form=False),
    MissionRequestList(1, 1, 2),
    MissionItemInt(1, 1, 3, 6, 16, 0, 1, 0.0, 2.5, math.nan, 90.0, 473977420, -85455940, 30.25, 0),
    MissionAck(255, 190, 13, 1),
    MissionClearAll(1, 1, 255),
    MissionCurrent(4, 20, 2, 0),
    MissionSetCurrent(1, 1, 9),
    CommandLong(1, 1, 512, 0, 148.0, 0, 0, 0, 0, 0, 0),
    CommandAck(512, 0, 255, 190),
    AutopilotVersion(capabilities=57348, flight_sw_version=0x010F00FF, uid=42),
    StatusText(4, "Only 700 items are supported"),
]


def _same(a: object, b: object) -> bool:
    for name in a.__slots__:  # type: ignore[attr-defined]
        x, y = getattr(a, name), getattr(b, name)
        if isinstance(x, float) and math.isnan(x):
            if not (isinstance(y, float) and math.isnan(y)):
                return False
        elif x != y:
            return False
    return True


def test_every_modelled_message_round_trips_through_mavlink2_bytes() -> None:
    sender = MavlinkConnection.open("udpin:127.0.0.1:0", system_id=7, component_id=1)
    receiver = MavlinkConnection.open("udpin:127.0.0.1:0", system_id=255, component_id=190)
    try:
        stream = b"".join(sender.encode(m) for m in ALL_MESSAGES)
        assert stream[0] == 0xFD  # MAVLink 2 magic
        receiver._parse(stream)
        got = [receiver.recv(0.0) for _ in ALL_MESSAGES]
        assert all(r is not None and (r.system_id, r.component_id) == (7, 1) for r in got)
        for sent, received in zip(ALL_MESSAGES, got, strict=True):
            assert received is not None
            assert type(received.message) is type(sent)
            assert _same(sent, received.message), (sent, received.message)
            assert message_name(received.message) == message_name(sent)
    finally:
        sender.close()
        receiver.close()


def test_float_mission_item_is_converted_with_rounding() -> None:
    """A peer sending the deprecated MISSION_ITEM is understood (x/y rounded to 1e-7 deg)."""
    from pymavlink.dialects.v20 import common as mavlink2

    mav = mavlink2.MAVLink(None, srcSystem=9, srcComponent=1)
    legacy = mav.mission_item_encode(1, 1, 0, 3, 16, 1, 1, 0, 0, 0, 0, 47.3977421, 8.5455949, 30, 0)
    receiver = MavlinkConnection.open("udpin:127.0.0.1:0", system_id=1, component_id=1)
    try:
        receiver._parse(legacy.pack(mav))
        received = receiver.recv(0.0)
        assert received is not None and isinstance(received.message, MissionItemInt)
        assert received.message.legacy_float
        # float32 carries ~7 significant digits: the position is kept to ~1 m, as expected
        assert abs(received.message.x - 473977421) < 20
        assert message_name(received.message) == "MISSION_ITEM"
    finally:
        receiver.close()


def test_unknown_messages_and_garbage_do_not_break_the_stream() -> None:
    from pymavlink.dialects.v20 import common as mavlink2

    mav = mavlink2.MAVLink(None, srcSystem=3, srcComponent=1)
    ping = mav.ping_encode(1, 2, 0, 0).pack(mav)
    conn = MavlinkConnection.open("udpin:127.0.0.1:0", system_id=1, component_id=1)
    try:
        count = conn.encode(MissionCount(1, 1, 5))
        conn._parse(b"\x00\x13garbage" + ping + count)
        first, second = conn.recv(0.0), conn.recv(0.0)
        assert first is not None and isinstance(first.message, UnknownMessage)
        assert first.message.name == "PING"
        assert second is not None and second.message == MissionCount(1, 1, 5)
    finally:
        conn.close()


# ---------------------------------------------------------------------------------------------
# Transports over real sockets


def _exchange(server_conn: str, client_template: str) -> None:
    server = MavlinkConnection.open(server_conn, system_id=1, component_id=1)
    try:
        _host, port = server.local_address  # type: ignore[misc]
        client = MavlinkConnection.open(
            client_template.format(port=port),
            heartbeat=Heartbeat(type=6, autopilot=8),
        )
        try:
            received = None
            deadline = time.monotonic() + 3.0
            while received is None and time.monotonic() < deadline:
                received = server.recv(0.1)
            assert received is not None and isinstance(received.message, Heartbeat)
            assert (received.system_id, received.component_id) == (255, 190)
            server.send(MissionCount(255, 190, 42))
            reply = None
            while reply is None or isinstance(reply.message, Heartbeat):
                reply = client.recv(2.0)
                assert reply is not None
            assert reply.message == MissionCount(255, 190, 42)
        finally:
            client.close()
    finally:
        server.close()


def test_udp_listener_on_an_os_assigned_port_answers_its_peer() -> None:
    _exchange("udpin:127.0.0.1:0", "udpout:127.0.0.1:{port}")


def test_mavsdk_style_urls_open_the_same_endpoints() -> None:
    _exchange("udp://127.0.0.1:0", "udpout://127.0.0.1:{port}")


def test_tcp_server_and_client() -> None:
    _exchange("tcpin:127.0.0.1:0", "tcp:127.0.0.1:{port}")


def test_udp_listener_talks_to_every_peer() -> None:
    server = MavlinkConnection.open("udpin:127.0.0.1:0", system_id=1, component_id=1)
    port = server.local_address[1]  # type: ignore[index]
    clients = [
        MavlinkConnection.open(f"udpout:127.0.0.1:{port}", system_id=s, heartbeat=Heartbeat(6, 8))
        for s in (250, 251)
    ]
    try:
        seen: set[int] = set()
        deadline = time.monotonic() + 3.0
        while len(seen) < 2 and time.monotonic() < deadline:
            received = server.recv(0.1)
            if received is not None:
                seen.add(received.system_id)
        assert seen == {250, 251}
        server.send(StatusText(6, "hello both"))
        for client in clients:
            received = client.recv(2.0)
            assert received is not None and received.message == StatusText(6, "hello both")
    finally:
        for client in clients:
            client.close()
        server.close()


@pytest.mark.skipif(not hasattr(os, "openpty"), reason="needs a pseudo-terminal")
def test_serial_transport_over_a_pseudo_terminal() -> None:
    master, slave = os.openpty()
    try:
        port = SerialPort(os.ttyname(slave), 57600)
        try:
            port.send(b"\xfdabc")
            assert os.read(master, 16) == b"\xfdabc"
            os.write(master, b"xyz")
            chunks: list[bytes] = []
            deadline = time.monotonic() + 2.0
            while b"".join(chunks) != b"xyz" and time.monotonic() < deadline:
                chunks += port.recv(0.1)
            assert b"".join(chunks) == b"xyz"
        finally:
            port.close()
    finally:
        os.close(master)
        os.close(slave)


# ---------------------------------------------------------------------------------------------
# Import rules (STYLE.md): pymavlink lives in one module; only mavlink/ and cli/ use mavlink/


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
    return names


@pytest.mark.slow
def test_pymavlink_is_imported_only_by_the_connection_module() -> None:
    importers = {
        str(path.relative_to(ROOT))
        for path in (ROOT / "uavplan").rglob("*.py")
        if any(name.split(".")[0] == "pymavlink" for name in _imports(path))
    }
    assert importers == {"uavplan/mavlink/connection.py"}


@pytest.mark.slow
def test_only_the_use_cases_the_cli_the_simulator_and_the_package_import_uavplan_mavlink() -> None:
    # uavplan.sim is the vehicle end of the link, a layer above it; the use cases of upload,
    # download and clear (uavplan/app/link.py) and of fly (uavplan/app/fly.py) are the ground
    # end, called by the CLI. The one exception is the table of each firmware's flight modes
    # (uavplan.mavlink.modes, data without I/O): the rehearsal names the mode the vehicle
    # reports along a flight the model predicts, as fly records it from the heartbeats.
    shared = {"uavplan.mavlink.modes"}
    offenders = []
    for path in (ROOT / "uavplan").rglob("*.py"):
        rel = path.relative_to(ROOT).as_posix()
        if rel.startswith(("uavplan/mavlink/", "uavplan/cli/", "uavplan/sim/", "uavplan/app/")):
            continue
        if any(
            name.startswith("uavplan.mavlink") and name not in shared for name in _imports(path)
        ):
            offenders.append(rel)
    assert offenders == []


def test_the_mavlink_package_imports_only_the_mission_model_and_errors() -> None:
    allowed = (
        "uavplan.mavlink",
        "uavplan.mission.items",
        "uavplan.errors",
        "uavplan.geo",
        "uavplan.lazy",
    )
    for path in (ROOT / "uavplan" / "mavlink").glob("*.py"):
        ours = {n for n in _imports(path) if n.startswith("uavplan")}
        assert all(n.startswith(allowed) for n in ours), (path.name, ours)


def _rmem_max() -> int:
    try:
        return int(Path("/proc/sys/net/core/rmem_max").read_text())
    except (OSError, ValueError):
        return 0


@pytest.mark.skipif(_rmem_max() < 2 * 1024 * 1024, reason="the system caps UDP buffers lower")
@pytest.mark.parametrize("kind", ["udpin", "udpout"])
def test_a_udp_endpoint_keeps_a_burst_it_has_not_read_yet(kind: str) -> None:
    """A reader that pauses (a loaded machine, a simulated vehicle at 100 times real time)
    finds every datagram of a 2,000-message burst waiting: the default 208 KiB buffer kept
    a few hundred of them and the rest were lost."""
    if kind == "udpin":
        endpoint = open_transport(ConnectionSpec("udpin", "127.0.0.1", 0))
        port = endpoint.local_address[1]  # type: ignore[attr-defined]
        sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        target = ("127.0.0.1", port)
    else:
        sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sender.bind(("127.0.0.1", 0))
        endpoint = open_transport(ConnectionSpec("udpout", "127.0.0.1", sender.getsockname()[1]))
        endpoint.send(b"hello")  # the endpoint's own port, as the sender sees it
        sender.settimeout(5.0)
        _, target = sender.recvfrom(64)
        target = ("127.0.0.1", target[1])
    try:
        burst = 2000
        for k in range(burst):
            sender.sendto(k.to_bytes(4, "big") + bytes(60), target)
        got: list[bytes] = []
        deadline = time.monotonic() + 5.0
        while len(got) < burst and time.monotonic() < deadline:
            got += endpoint.recv(0.2)
        assert len(got) == burst
    finally:
        sender.close()
        endpoint.close()
