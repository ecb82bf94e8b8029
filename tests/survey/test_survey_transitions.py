"""Issue 33: a survey's transitions stay inside the area (QGroundControl and Mission Planner
fly straight across concave notches) and never over a no-fly ``exclude`` polygon, as planned
and as flown (checked here with shapely, not with the library's world)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from shapely.geometry import LineString, Polygon
from shapely.ops import unary_union

from uavplan.app.feedback import Feedback
from uavplan.app.plan import PlanRequest, plan
from uavplan.app.survey import SurveyOutcome
from uavplan.geo import EnuFrame, GeoPoint

U_SHAPE = [[0, 0], [420, 0], [420, 300], [300, 300], [300, 110], [120, 110], [120, 300], [0, 300]]
#: tools/survey_bench.py's field holes-5: a quadrilateral with two no-fly boxes, over which
#: the straight transitions between lane pieces flew before (54 m)
HOLES_AREA = [[290.7, 2.3], [151.3, 54.1], [12.4, 298.7], [297.5, 284.2]]
NO_FLY = [
    [[243.6, 73.8], [243.6, 138.1], [197.3, 138.1], [197.3, 73.8]],
    [[243.4, 179.5], [243.4, 221.1], [193.6, 221.1], [193.6, 179.5]],
]


def _plan(tmp_path: Path, survey: dict[str, Any], autopilot: str | None = None) -> SurveyOutcome:
    src = tmp_path / "field.yaml"
    src.write_text(yaml.safe_dump({
        "name": "field",
        "origin": {"lat": 60.0, "lon": 25.0},
        "bounds": {"x": [-300, 700], "y": [-300, 600], "z": [0, 150]},
        "start": [-60, -60, 20],
        "safety_margin": 10,
        "vehicle": {"profile": "x500", "cruise_speed": 10},
        "survey": {"altitude": 50, "lane_spacing_m": 30, "angle_deg": 0, **survey},
    }))  # fmt: skip
    outcome = plan(PlanRequest(str(src), str(tmp_path / "f.plan"), autopilot=autopilot), Feedback())
    assert isinstance(outcome, SurveyOutcome)
    return outcome


def _pattern(outcome: SurveyOutcome) -> LineString:
    """The planned flight from the first lane's start to the last lane's end."""
    w = outcome.route.waypoints_enu
    rows = np.flatnonzero(outcome.route.lane_start)
    return LineString(w[rows[0] : rows[-1] + 2, :2])


def _flown_xy(outcome: SurveyOutcome) -> np.ndarray:
    assert outcome.verdict is not None and outcome.verdict.rehearsal is not None
    track = outcome.verdict.track
    frame = EnuFrame.at(GeoPoint(60.0, 25.0, 0.0))
    return np.asarray(frame.to_enu_xy(track.lat_deg, track.lon_deg))


@pytest.mark.parametrize("autopilot", ["ardupilot", "px4"])
def test_transitions_between_lanes_stay_inside_a_concave_area(
    tmp_path: Path, autopilot: str
) -> None:
    outcome = _plan(tmp_path, {"area": U_SHAPE}, autopilot)
    area = Polygon(U_SHAPE)
    # lanes above y = 110 are split by the notch: a straight transition would cross it
    ys = outcome.route.sweep.pieces_xy[:, 0, 1].round(3)
    assert len(ys) > len(np.unique(ys))
    assert _pattern(outcome).difference(area.buffer(0.5)).length == pytest.approx(0.0, abs=1e-6)
    assert outcome.verdict is not None and outcome.verdict.flight_ok


@pytest.mark.parametrize("autopilot", ["ardupilot", "px4"])
def test_no_transition_crosses_a_no_fly_hole_as_planned_or_as_flown(
    tmp_path: Path, autopilot: str
) -> None:
    survey = {"area": HOLES_AREA, "exclude": NO_FLY, "angle_deg": "auto"}
    outcome = _plan(tmp_path, survey, autopilot)
    hole = unary_union([Polygon(p) for p in NO_FLY])
    w = outcome.route.waypoints_enu
    assert not LineString(w[:, :2]).intersects(hole)
    flown = _flown_xy(outcome)
    from shapely import distance, points

    least = float(np.min(distance(points(flown), hole)))
    assert least >= 10.0 - 0.05, least  # the margin from the no-fly polygon, as flown
    assert outcome.verdict is not None and outcome.verdict.flight_ok
