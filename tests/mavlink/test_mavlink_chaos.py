"""Link chaos through the seeded fault proxy (issue 12): a reduced count of
``tools/link_chaos.py``'s runs. ``UAVPLAN_CHAOS_RUNS=50 UAVPLAN_CHAOS_ITEMS=200``: the full one.

Invariants on every run: exit 0 means the vehicle holds exactly the mission sent; a failure
is exit 4 and names the step; the vehicle never holds a mixture of the old and the new
mission. (The time bound of a dead link is checked with a fake clock in
``test_mavlink_machines.py`` and measured by the tool.)
"""

from __future__ import annotations

import os
import socket

import pytest
from helpers.chaos import invariant_problem, run_upload
from helpers.faultproxy import (
    MISSION_MESSAGE_IDS,
    FaultProxy,
    ProxyFaults,
    message_id,
)
from helpers.mavlink_helpers import FAST

from uavplan.mavlink.connection import MavlinkConnection
from uavplan.mavlink.messages import Heartbeat, MissionCount
from uavplan.mission.items import Autopilot

RUNS = int(os.environ.get("UAVPLAN_CHAOS_RUNS", "1"))
N_ITEMS = int(os.environ.get("UAVPLAN_CHAOS_ITEMS", "100"))
AUTOPILOTS = [Autopilot.PX4, Autopilot.ARDUPILOT]

pytestmark = pytest.mark.timeout(120 + 40 * RUNS)


@pytest.mark.parametrize("autopilot", AUTOPILOTS, ids=lambda a: a.label)
@pytest.mark.parametrize("run", range(RUNS))
@pytest.mark.slow
def test_upload_through_loss_duplicates_and_reordering_verifies(
    autopilot: Autopilot, run: int
) -> None:
    faults = ProxyFaults(drop_rate=0.2, duplicate_rate=0.05, reorder_rate=0.05, seed=97 + run)
    result = run_upload(faults, autopilot=autopilot, n_items=N_ITEMS)
    assert invariant_problem(result) is None, result
    assert result.ok, result.message
    assert result.holds == "new"


@pytest.mark.slow
def test_upload_through_bit_flips_and_delays_keeps_the_invariants() -> None:
    faults = ProxyFaults(
        drop_rate=0.1,
        duplicate_rate=0.05,
        reorder_rate=0.05,
        bitflip_rate=0.02,
        delay_rate=0.1,
        max_delay_s=0.03,
        seed=5,
    )
    result = run_upload(faults, n_items=60)
    assert invariant_problem(result) is None, result


@pytest.mark.slow
def test_dead_link_is_exit_4_naming_the_step_and_keeps_the_old_mission() -> None:
    faults = ProxyFaults(drop_rate=1.0, only=MISSION_MESSAGE_IDS, seed=3)
    result = run_upload(faults, n_items=20, timeouts=FAST)
    assert invariant_problem(result) is None, result
    assert result.exit_code == 4
    assert result.message.startswith("upload mission: MISSION_COUNT: no MISSION_REQUEST")
    assert result.holds == "old"


# ---------------------------------------------------------------------------------------------
# the proxy itself


def _frames(n: int) -> list[bytes]:
    conn = MavlinkConnection.open("udpin:127.0.0.1:0", system_id=255, component_id=190)
    try:
        return [conn.encode(MissionCount(1, 1, i)) for i in range(n)]
    finally:
        conn.close()


def test_message_id_reads_mavlink_2_headers() -> None:
    conn = MavlinkConnection.open("udpin:127.0.0.1:0", system_id=255, component_id=190)
    try:
        assert message_id(conn.encode(MissionCount(1, 1, 3))) == 44
        assert message_id(conn.encode(Heartbeat(6, 8))) == 0
    finally:
        conn.close()
    assert message_id(b"\x00\x01") is None


def test_same_seed_same_faults() -> None:
    """The fault pattern depends only on the seed and the traffic."""
    faults = ProxyFaults(
        drop_rate=0.3, duplicate_rate=0.2, reorder_rate=0.2, bitflip_rate=0.2, seed=11
    )
    frames = _frames(200)
    sink = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.bind(("127.0.0.1", 0))
    patterns = []
    try:
        for _ in range(2):
            proxy = FaultProxy(sink.getsockname(), faults)  # not started: fed by hand
            try:
                for frame in frames:
                    proxy._forward(True, frame)
                patterns.append(proxy.uplink)
            finally:
                proxy.stop()
    finally:
        sink.close()
    assert patterns[0] == patterns[1]
    stats = patterns[0]
    assert stats.dropped > 30 and stats.duplicated > 10 and stats.flipped > 10
    assert stats.reordered > 10


def test_total_loss_forwards_nothing_and_only_limits_the_faults() -> None:
    frames = _frames(20)
    sink = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.bind(("127.0.0.1", 0))
    try:
        dead = FaultProxy(sink.getsockname(), ProxyFaults(drop_rate=1.0))
        only_hb = FaultProxy(sink.getsockname(), ProxyFaults(drop_rate=1.0, only=frozenset({0})))
        try:
            for frame in frames:
                dead._forward(True, frame)
                only_hb._forward(True, frame)
            assert dead.uplink.forwarded == 0 and dead.uplink.dropped == 20
            assert only_hb.uplink.forwarded == 20  # COUNT is not in ``only``
        finally:
            dead.stop()
            only_hb.stop()
    finally:
        sink.close()
