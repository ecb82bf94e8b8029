"""Issue 33: a survey larger than one battery is split into missions that each start and end
at the start, each within the battery and its reserve, together flying every lane."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from uavplan.app.feedback import Feedback
from uavplan.app.plan import PlanRequest, plan
from uavplan.app.survey import SurveyOutcome
from uavplan.cli import main
from uavplan.mission.io import load_mission
from uavplan.mission.items import MavCmd

FIELD: dict[str, Any] = {
    "name": "big-field",
    "origin": {"lat": 60.0, "lon": 25.0},
    "bounds": {"x": [-300, 1300], "y": [-300, 900], "z": [0, 150]},
    "start": [-100, -100, 20],
    "safety_margin": 10,
    "vehicle": {"profile": "x500", "cruise_speed": 12},
    "obstacles": [
        {"type": "box", "center": [400, 300], "size": [60, 40], "height": 90},
        {"type": "cylinder", "center": [700, 150], "radius": 8, "height": 80},
    ],
    "survey": {
        "area": [[0, 0], [1000, 0], [1000, 600], [0, 600]],
        "altitude": 50,
        "lane_spacing_m": 30,
        "angle_deg": "auto",
    },
}


def _file(tmp_path: Path, **changes: Any) -> Path:
    f = tmp_path / "field.yaml"
    f.write_text(yaml.safe_dump({**FIELD, **changes}))
    return f


@pytest.mark.slow
def test_a_survey_over_the_battery_is_split_into_missions_that_each_fit(tmp_path: Path) -> None:
    out = tmp_path / "field.plan"
    outcome = plan(PlanRequest(str(_file(tmp_path)), str(out)), Feedback())
    assert isinstance(outcome, SurveyOutcome)
    assert outcome.estimate is None  # the whole survey is no one flight
    parts = outcome.parts
    assert len(parts) >= 2
    assert not out.exists()  # field-1.plan, field-2.plan, ... instead
    assert [Path(p.output).name for p in parts] == [
        f"field-{k}.plan" for k in range(1, len(parts) + 1)
    ]
    # together every lane, in order, once
    lanes = np.concatenate([p.route.sweep.pieces_xy for p in parts])
    np.testing.assert_array_equal(lanes, outcome.route.sweep.pieces_xy)
    assert sum(p.route.sweep.photos for p in parts) == outcome.route.sweep.photos
    start = np.array(FIELD["start"], dtype=float)
    for p in parts:
        # each within the battery and the reserve, as the flight model flies it
        assert p.estimate.fits and p.estimate.energy.battery_used_pct <= 80.0 + 1e-9
        assert p.verdict is not None and p.verdict.flight_ok
        # from the start and back to it
        w = p.route.waypoints_enu
        np.testing.assert_allclose(w[0], start)
        np.testing.assert_allclose(w[-1], start)
        written = load_mission(p.output)
        assert written.items[-1].command in (MavCmd.NAV_LAND, MavCmd.NAV_RETURN_TO_LAUNCH)
        assert sum(i.command == MavCmd.DO_SET_CAM_TRIGG_DIST for i in written.items) == (
            2 * p.route.lanes
        )


@pytest.mark.slow
def test_the_cli_prints_each_mission_and_the_report_lists_them(tmp_path: Path) -> None:
    src = _file(tmp_path)
    result = CliRunner().invoke(
        main,
        ["plan", str(src), "-o", str(tmp_path / "f.plan"), "--report", str(tmp_path / "r.json")],
    )
    assert result.exit_code == 0, result.output
    assert "split into" in result.output and "f-1.plan:" in result.output
    report = json.loads((tmp_path / "r.json").read_text())
    missions = report["missions"]
    assert len(missions) >= 2
    assert all(m["energy_estimate"]["fits"] for m in missions)
    assert all(m["whole_flight"]["flight_ok"] for m in missions)
    assert sum(m["lanes"] for m in missions) == report["survey"]["lanes"]


def test_allow_over_battery_keeps_one_mission(tmp_path: Path) -> None:
    out = tmp_path / "field.plan"
    outcome = plan(PlanRequest(str(_file(tmp_path)), str(out), allow_over_battery=True), Feedback())
    assert isinstance(outcome, SurveyOutcome)
    assert outcome.parts == () and out.exists()
    assert outcome.estimate is not None and not outcome.estimate.fits


@pytest.mark.slow
def test_a_lane_longer_than_a_battery_is_refused_with_one_message(tmp_path: Path) -> None:
    far = dict(FIELD["survey"], area=[[0, 0], [30000, 0], [30000, 60], [0, 60]])
    src = _file(tmp_path, survey=far, obstacles=[],
                bounds={"x": [-300, 30300], "y": [-300, 400], "z": [0, 150]})  # fmt: skip
    result = CliRunner().invoke(main, ["plan", str(src), "-o", str(tmp_path / "f.plan")])
    assert result.exit_code == 2, result.output
    assert "alone" in result.output and "Traceback" not in result.output
    assert not list(tmp_path.glob("f*.plan"))
