"""``plan`` as one forward pipeline (issue 36): the scenario's obstacles are split into the
world's pieces once per plan, and the mission written is the one the flight model flew,
built once from the final route."""

from __future__ import annotations

from pathlib import Path

import pytest

import uavplan.world as world_module
from uavplan.app.feedback import Feedback
from uavplan.app.plan import PlanRequest, plan
from uavplan.mission.io import load_mission
from uavplan.planning import mission_for

MISSIONS = Path(__file__).resolve().parents[2] / "missions"


@pytest.mark.slow
@pytest.mark.parametrize("name", ["paper-env3", "jacksboro-ridge"])
def test_one_plan_splits_its_obstacles_once_and_writes_the_mission_it_flew(
    name: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """paper-env3 plans again with a wider margin and plans a return (its RTL cannot be made
    safe), jacksboro-ridge flies over terrain: every world of either plan (the search's, the
    widened one, the way home's, the failsafe's) shares the one split of the obstacles."""
    splits = []
    split = world_module._pieces_of

    def counted(obstacles):  # type: ignore[no-untyped-def]
        splits.append(len(obstacles))
        return split(obstacles)

    monkeypatch.setattr(world_module, "_pieces_of", counted)
    out = tmp_path / f"{name}.plan"
    outcome = plan(PlanRequest(str(MISSIONS / f"{name}.yaml"), str(out)), Feedback())
    assert outcome.mission is not None and outcome.result.route is not None
    assert len(splits) == 1, splits
    flight = outcome.flight
    assert flight is not None and flight.mission is not None
    # the mission written is the one the prediction flew, and the route's as built afresh
    afresh = mission_for(outcome.scenario, outcome.result.route)
    written = load_mission(str(out))
    for other in (flight.mission, afresh):
        assert [i.command for i in other.items] == [i.command for i in written.items]
        assert [(i.x, i.y, i.z) for i in other.items] == [(i.x, i.y, i.z) for i in written.items]
