"""A ground station with a clock for the simulated vehicle as a state machine (no sockets):
feeds it messages and time and keeps what it says; a vehicle holding a mission; the start
as QGroundControl / MAVSDK do it."""

from __future__ import annotations

from helpers.mavlink_helpers import synthetic_mission
from uavplan.mavlink.messages import (
    CommandAck,
    CommandLong,
    Heartbeat,
    MavCommand,
    MavResult,
    Message,
    Received,
    StatusText,
)
from uavplan.mavlink.transfer import plan_wire_items
from uavplan.mission.items import Autopilot, MissionPlan, MissionType
from uavplan.sim.vehicle import SimConfig
from uavplan.sim.vehicles import new_vehicle

PX4 = Autopilot.PX4
#: the ground station's (system, component)
GCS = (255, 190)


class Driver:
    """A ground station with a clock: feeds the vehicle messages and time, keeps what it says."""

    def __init__(self, config: SimConfig) -> None:
        self.vehicle = new_vehicle(config, now=0.0)
        self.now = 0.0
        self.heard: list[Message] = []

    def send(self, message: Message) -> list[Message]:
        out = self.vehicle.receive(Received(message, *GCS), self.now)
        self.heard.extend(out)
        return out

    def command(self, command: int, *params: float) -> tuple[CommandAck, list[str]]:
        """Send a COMMAND_LONG; its ACK and the STATUSTEXTs that came with it."""
        values = [float(p) for p in params] + [0.0] * (7 - len(params))
        out = self.send(CommandLong(1, 1, int(command), 0, *values))
        acks = [m for m in out if isinstance(m, CommandAck) and m.command == int(command)]
        assert len(acks) == 1, out
        return acks[0], [m.text for m in out if isinstance(m, StatusText)]

    def run(self, seconds: float, step: float = 0.05) -> list[Message]:
        """Let ``seconds`` of link time pass."""
        out: list[Message] = []
        end = self.now + seconds
        while self.now < end - 1e-12:
            self.now = min(end, self.now + step)
            out.extend(self.vehicle.tick(self.now))
        self.heard.extend(out)
        return out

    def run_until(self, predicate, limit_s: float, step: float = 0.05) -> float:  # type: ignore[no-untyped-def]
        start = self.now
        while not predicate():
            assert self.now - start < limit_s, "the vehicle never got there"
            self.run(step, step)
        return self.now - start

    def heartbeat(self) -> Heartbeat:
        return next(m for m in reversed(self.heard) if isinstance(m, Heartbeat))


def with_mission(autopilot: Autopilot, plan: MissionPlan | None = None, **config: object) -> Driver:
    plan = plan or synthetic_mission(5, seed=7, autopilot=autopilot)
    driver = Driver(SimConfig(autopilot=autopilot, home=plan.home, **config))  # type: ignore[arg-type]
    driver.vehicle.preload(
        MissionType.MISSION, plan_wire_items(plan, MissionType.MISSION, autopilot)
    )
    return driver


def start(driver: Driver) -> None:
    """Start the mission as QGroundControl / MAVSDK do for that autopilot."""
    if driver.vehicle.autopilot == PX4:
        ack, texts = driver.command(MavCommand.MISSION_START, 0, 0)  # arms and starts
    else:
        assert driver.command(MavCommand.DO_SET_MODE, 1, 4)[0].result == MavResult.ACCEPTED
        assert driver.command(MavCommand.COMPONENT_ARM_DISARM, 1)[0].result == MavResult.ACCEPTED
        ack, texts = driver.command(MavCommand.MISSION_START, 0, 0)
    assert ack.result == MavResult.ACCEPTED, texts
