"""Every expected end speaks one small protocol (issue 36): :class:`uavplan.outcome.Ended`.

Each end below is made the way its producer makes it (a real search, a real rerouting, the
start check on real items) or, for the MAVLink ends whose machines need a vehicle, built as
their machines build them. mypy checks this file too (pyproject.toml): ``_speaks`` takes an
``Ended``, so a type that stopped speaking the protocol fails the type check as well as the
test.
"""

from __future__ import annotations

import enum
from pathlib import Path

import numpy as np
import pytest

from uavplan.app.fly import FlyOutcome
from uavplan.autopilot.simulate import StartRefused, start_refusal
from uavplan.mavlink.flightmachines import CommandEnd, CommandOutcome, MonitorEnd
from uavplan.mavlink.messages import MavResult
from uavplan.mavlink.parameters import ParamResult, ParamStatus
from uavplan.mavlink.protocol import Operation, TransferOutcome, TransferStatus
from uavplan.mission.io import load_mission
from uavplan.mission.items import Autopilot, MissionType
from uavplan.mission.track import Track
from uavplan.outcome import Ended, RouteFailure
from uavplan.planning import plan_route
from uavplan.reroute import reroute_plan
from uavplan.scenario import load_scenario

MISSIONS = Path(__file__).resolve().parents[2] / "missions"


def _speaks(end: Ended) -> Ended:
    """Statically (mypy) and at run time: ``end`` speaks the protocol."""
    assert isinstance(end, Ended)
    return end


def _stopped() -> bool:
    return True


def _empty_track() -> Track:
    e = np.empty(0)
    return Track(e, e, e, e, e, e, np.empty(0, dtype=np.int64), source="fly")


def _ends() -> list[tuple[str, Ended, enum.Enum | None]]:
    """(what, the end, the reason it must give)."""
    scn = load_scenario(MISSIONS / "narrow-gap.yaml")
    planned = plan_route(scn)
    interrupted = plan_route(scn, should_stop=_stopped)
    rerouted = reroute_plan(
        load_mission(str(MISSIONS / "qgc-inspection.plan")), name="qgc", should_stop=_stopped
    )
    transfer = TransferOutcome(
        Operation.UPLOAD, MissionType.MISSION, TransferStatus.TIMEOUT, "MISSION_COUNT", "silent"
    )
    done = TransferOutcome(Operation.UPLOAD, MissionType.MISSION, TransferStatus.SUCCESS)
    refused_param = ParamResult("RTL_ALT", ParamStatus.REFUSED, 1500.0, 1500.0, "PARAM_SET")
    kept_param = ParamResult("RTL_ALT", ParamStatus.KEPT, 4500.0, 4500.0)
    denied = CommandOutcome(False, "arm", int(MavResult.DENIED), ("PreArm: GPS",))
    unanswered = CommandOutcome(False, "mode Mission", None, (), "no COMMAND_ACK after 7 tries")
    unseen = CommandOutcome(False, "mode Hold", int(MavResult.ACCEPTED), (), "still Mission")
    flown = FlyOutcome(
        "m.plan", "the vehicle", Autopilot.PX4, MonitorEnd.COMPLETE, _empty_track(),
        True, 300.0, 299.0, 0.4,
    )  # fmt: skip
    stopped = FlyOutcome(
        "m.plan", "the vehicle", Autopilot.PX4, MonitorEnd.INTERRUPTED, _empty_track(),
        True, None, None, 0.4, interrupt_mode="Hold",
    )  # fmt: skip
    refusal = start_refusal([], Autopilot.PX4)
    assert refusal is not None
    return [
        ("a planned route", _speaks(planned), None),
        ("an interrupted search", _speaks(interrupted), RouteFailure.INTERRUPTED),
        ("an interrupted rerouting", _speaks(rerouted), RouteFailure.INTERRUPTED),
        ("a transfer that timed out", _speaks(transfer), TransferStatus.TIMEOUT),
        ("a transfer done", _speaks(done), None),
        ("a parameter refused", _speaks(refused_param), ParamStatus.REFUSED),
        ("a parameter kept", _speaks(kept_param), None),
        ("a command denied", _speaks(denied), CommandEnd.REFUSED),
        ("a command unanswered", _speaks(unanswered), CommandEnd.UNANSWERED),
        ("a command never seen to act", _speaks(unseen), CommandEnd.UNCONFIRMED),
        ("a command sequence done", _speaks(CommandOutcome(True)), None),
        ("a flight flown", _speaks(flown), None),
        ("an interrupted flight", _speaks(stopped), MonitorEnd.INTERRUPTED),
        ("a start refused", _speaks(refusal), StartRefused.NO_POSITION),
    ]


@pytest.fixture(scope="module")
def ends() -> list[tuple[str, Ended, enum.Enum | None]]:
    return _ends()


def test_each_end_gives_its_reason_as_an_enum_value(
    ends: list[tuple[str, Ended, enum.Enum | None]],
) -> None:
    for what, end, reason in ends:
        assert end.reason is reason, what
        assert end.ok == (reason is None), what


def test_an_end_that_is_not_ok_says_why_and_where_and_an_ok_one_has_no_step(
    ends: list[tuple[str, Ended, enum.Enum | None]],
) -> None:
    for what, end, _ in ends:
        assert isinstance(end.message, str) and isinstance(end.step, str), what
        if end.ok:
            assert not end.interrupted and end.step == "", what
        else:
            assert end.message, what
    steps = {what: end.step for what, end, _ in ends if not end.ok}
    assert steps["a transfer that timed out"] == "MISSION_COUNT"
    assert steps["a command denied"] == "arm"
    assert steps["a start refused"] == "start"
    assert steps["an interrupted flight"] == "flight"


def test_interrupted_is_never_ok_and_only_a_ctrl_c_is_interrupted(
    ends: list[tuple[str, Ended, enum.Enum | None]],
) -> None:
    interrupted = {what for what, end, _ in ends if end.interrupted}
    assert interrupted == {
        "an interrupted search",
        "an interrupted rerouting",
        "an interrupted flight",
    }
    for what, end, _ in ends:
        assert not (end.interrupted and end.ok), what


def test_something_that_lacks_a_member_does_not_speak_it() -> None:
    """The test of the test: the run-time check refuses a near miss."""

    class NoStep:
        ok = True
        interrupted = False
        reason = None
        message = ""

    assert not isinstance(NoStep(), Ended)
