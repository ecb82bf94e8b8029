"""Measure how many items a vehicle stores of each plan type (mission, fence, rally).

For each plan type it sends MISSION_COUNT N and reads the answer: a MISSION_REQUEST for item 0
(N fits: the transfer is cancelled and left to time out) or MISSION_ACK NO_SPACE (it does
not), and bisects N between a count that fits and one that does not. Nothing is stored: no
item is ever sent. This is how docs/flying.md's SITL rows ("Before you fly", the storage
table) were measured:

    python tools/storage_limits.py --conn udpin:127.0.0.1:14540      # PX4 SITL
    python tools/storage_limits.py --conn tcp:127.0.0.1:5760         # ArduPilot SITL

A vehicle keeps an abandoned upload open until its own timeout (PX4 5 s, ArduPilot 8 s), so
``--settle`` seconds pass between two probes; a bisection over 1..65,534 takes about 16
probes per plan type.
"""

from __future__ import annotations

import argparse
import time

from uavplan.mavlink.link import VehicleLink
from uavplan.mavlink.messages import MissionAck, MissionCount, MissionRequest, MissionResult
from uavplan.mission.items import MissionType

#: MISSION_ACK type that cancels a transfer (MAV_MISSION_OPERATION_CANCELLED)
CANCELLED = 24


def quiet(link: VehicleLink, settle_s: float) -> None:
    """Wait until no mission-protocol message has come for ``settle_s`` seconds (an earlier
    transfer timed out), dropping what comes meanwhile."""
    last = time.monotonic()
    while time.monotonic() - last < settle_s:
        received = link.recv(0.2)
        if received is not None and isinstance(received.message, MissionRequest | MissionAck):
            last = time.monotonic()


def probe(link: VehicleLink, mission_type: MissionType, count: int, settle_s: float) -> bool:
    """Does the vehicle take ``count`` items of ``mission_type``? A request for item 0: yes;
    MISSION_ACK NO_SPACE: no; anything else (busy, no answer) is asked again."""
    vehicle = link.vehicle
    for _ in range(5):
        quiet(link, settle_s)
        link.send(MissionCount(vehicle.system_id, vehicle.component_id, count, int(mission_type)))
        end = time.monotonic() + 3.0
        while time.monotonic() < end:
            received = link.recv(0.5)
            if received is None:
                continue
            message = received.message
            if isinstance(message, MissionRequest) and message.mission_type == mission_type:
                if message.seq != 0:
                    continue
                cancel = MissionAck(
                    vehicle.system_id, vehicle.component_id, CANCELLED, mission_type
                )
                link.send(cancel)
                return True
            if isinstance(message, MissionAck) and message.mission_type == mission_type:
                if message.type == MissionResult.NO_SPACE:
                    return False
                break  # busy or another refusal: ask again once the vehicle is quiet
    raise SystemExit(f"no clear answer to MISSION_COUNT {count} ({mission_type.name.lower()})")


def limit(link: VehicleLink, mission_type: MissionType, settle_s: float) -> int:
    """The largest count the vehicle takes (bisection over 1..65,534)."""
    low, high = 1, 65535  # low fits (checked), high does not (MISSION_COUNT's 16 bits)
    if not probe(link, mission_type, low, settle_s):
        return 0
    while high - low > 1:
        middle = (low + high) // 2
        if probe(link, mission_type, middle, settle_s):
            low = middle
        else:
            high = middle
        print(f"  {mission_type.name.lower()}: {low} fits, {high} does not", flush=True)
    return low


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--conn", required=True, help="connection string (uavplan's)")
    parser.add_argument("--settle", type=float, default=9.0, help="seconds between probes")
    parser.add_argument("--heartbeat-timeout", type=float, default=60.0)
    args = parser.parse_args()
    with VehicleLink.connect(args.conn, heartbeat_timeout_s=args.heartbeat_timeout) as link:
        print(f"vehicle: system {link.vehicle.system_id} ({link.vehicle.autopilot.label})")
        found = {t: limit(link, t, args.settle) for t in MissionType if t.name != "ALL"}
    print("| mission items | fence items | rally points |")
    print("|---:|---:|---:|")
    print("| " + " | ".join(f"{n:,}" for n in found.values()) + " |")


if __name__ == "__main__":
    main()
