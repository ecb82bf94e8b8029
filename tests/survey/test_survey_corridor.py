"""Issue 33, Deliver 5: a corridor scan (``survey: {corridor: [...], width_m: ...}``) covers a
strip along a polyline with lanes that follow it through its bends, with the same hole,
camera, verdict and battery handling as an area survey (the bundled
missions/surveys/survey-power-line.yaml: pylons taller than the survey altitude)."""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import shapely
import yaml
from click.testing import CliRunner

from uavplan.app.feedback import Feedback
from uavplan.app.plan import PlanRequest, plan
from uavplan.app.survey import SurveyOutcome
from uavplan.cli import main
from uavplan.scenario.values import load_survey_scenario
from uavplan.survey import coverage

ROOT = Path(__file__).resolve().parents[2]
LINE = ROOT / "missions" / "surveys" / "survey-power-line.yaml"


@pytest.fixture(scope="module")
def whole(tmp_path_factory: pytest.TempPathFactory) -> SurveyOutcome:
    out = tmp_path_factory.mktemp("line") / "line.plan"
    outcome = plan(PlanRequest(str(LINE), str(out)), Feedback())
    assert isinstance(outcome, SurveyOutcome) and out.exists() and outcome.parts == ()
    return outcome


def test_the_lanes_follow_the_corridor_inside_its_strip(whole: SurveyOutcome) -> None:
    _, spec = load_survey_scenario(LINE)
    assert spec.corridor_m is not None and spec.width_m == 60.0
    line = shapely.LineString(spec.corridor_m)
    seg = np.diff(np.asarray(spec.corridor_m), axis=0)
    seg_dir = np.degrees(np.arctan2(seg[:, 1], seg[:, 0]))
    w = whole.route.waypoints_enu
    bends = 0
    for a, b in whole.route.lane_rows():
        lane = w[a : b + 1, :2]
        bends += len(lane) - 2
        # every lane point inside the strip
        assert max(line.distance(shapely.Point(p)) for p in lane) <= 30.0 + 1e-6
        for p, q in itertools.pairwise(lane):
            # each straight piece runs parallel to the corridor's segment beside it
            mid = shapely.Point((p + q) / 2.0)
            k = int(np.argmin([shapely.LineString(spec.corridor_m[i : i + 2]).distance(mid)
                               for i in range(len(seg))]))  # fmt: skip
            heading = np.degrees(np.arctan2(*(q - p)[::-1]))
            off = (heading - seg_dir[k] + 90.0) % 180.0 - 90.0
            assert abs(off) < 0.5, (heading, seg_dir[k])
    assert bends > 0  # lanes go on through the corridor's bends: no turn, no camera stop
    # three lanes across 60 m (RX100 at 40 m, 60 % side overlap: 20.3 m apart); the one over
    # the line stops at every pylon
    assert whole.route.lanes >= 3


def test_the_pylons_are_holes_and_the_flight_keeps_the_margin(whole: SurveyOutcome) -> None:
    assert whole.verdict is not None and whole.verdict.flight_ok
    scn = whole.scenario
    flight = shapely.LineString(whole.route.waypoints_enu[:, :2])
    for ob in scn.obstacles:
        centre = shapely.Point(ob.center_m[:2]) if hasattr(ob, "center_m") else None
        if centre is not None:
            assert flight.distance(centre) >= 4.0 + scn.safety_margin_m - 1e-6


def test_the_photos_cover_the_strip_and_the_camera_runs_per_lane(whole: SurveyOutcome) -> None:
    assert whole.covered is not None and whole.covered >= 0.99
    starts = [i for i in whole.mission.items if i.command == 206 and i.param1 > 0]
    stops = [i for i in whole.mission.items if i.command == 206 and i.param1 == 0]
    assert len(starts) == len(stops) == whole.route.lanes


def test_photos_are_counted_along_a_bent_lane() -> None:
    """An L of two 100 m pieces, one lane: a photo every 30 m of path, 0 ... 180 (7); two
    lanes would start their count again at the corner (4 + 4)."""
    pieces = np.array([[[0.0, 0.0], [100.0, 0.0]], [[100.0, 0.0], [100.0, 100.0]]])
    xy, heading = coverage.photos_along(pieces, 30.0, np.array([False, True]))
    assert len(xy) == 7 == coverage.photo_count(pieces, 30.0, np.array([False, True]))
    assert np.allclose(xy[4], [100.0, 20.0]) and heading[4] == pytest.approx(90.0)
    assert coverage.photo_count(pieces, 30.0) == 8


@pytest.mark.slow
def test_a_long_corridor_is_split_across_batteries(tmp_path: Path) -> None:
    """The line 400 m longer (one more bend and pylon): more than one battery."""
    data = yaml.safe_load(LINE.read_text())
    data["survey"]["corridor"].append([1500, 420])
    data["obstacles"].append({"type": "cylinder", "center": [1500, 420], "radius": 4,
                              "height": 45})  # fmt: skip
    data["bounds"] = {"x": [-200, 1700], "y": [-250, 600], "z": [0, 120]}
    src = tmp_path / "long.yaml"
    src.write_text(yaml.safe_dump(data))
    out = tmp_path / "line.plan"
    outcome = plan(PlanRequest(str(src), str(out)), Feedback())
    assert isinstance(outcome, SurveyOutcome)
    assert len(outcome.parts) >= 2 and not out.exists()
    assert sum(p.route.lanes for p in outcome.parts) == outcome.route.lanes
    for part in outcome.parts:
        assert Path(part.output).exists()
        assert part.estimate.fits
        assert part.verdict is not None and part.verdict.flight_ok


def _scenario(tmp_path: Path, **survey: Any) -> Path:
    data = yaml.safe_load(LINE.read_text())
    data["survey"] = {"altitude": 40, "lane_spacing_m": 20, **survey}
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize(
    ("survey", "key", "words"),
    [
        ({"corridor": [[0, 0]], "width_m": 60}, "survey.corridor", "at least 2"),
        ({"corridor": [[0, 0], [500, 0]]}, "survey.width_m", "missing required"),
        ({"corridor": [[0, 0], [500, 0]], "width_m": 60, "angle_deg": 30}, "survey.angle_deg",
         "follow the corridor"),
        ({"corridor": [[0, 0], [500, 0], [500, 200], [250, -100]], "width_m": 20},
         "survey.corridor", "cross itself"),
        ({"corridor": [[0, 0], [500, 0], [500, 30], [0, 30]], "width_m": 60},
         "survey.corridor", "overlaps itself"),
        ({"area": [[0, 0], [10, 0], [10, 10]], "width_m": 60}, "survey.width_m", "give corridor"),
        ({"area": [[0, 0], [10, 0], [10, 10]], "corridor": [[0, 0], [9, 9]], "width_m": 6},
         "survey.corridor", "not both"),
        ({"corridor": [[0, 0], [0.5, 0], [500, 0]], "width_m": 60}, "survey.corridor[1]",
         "less than 1 m"),
        ({"corridor": [[0, 0], [1600, 0]], "width_m": 60}, "survey.corridor", "outside the bounds"),
    ],
)  # fmt: skip
def test_a_malformed_corridor_is_one_message(
    tmp_path: Path, survey: dict[str, Any], key: str, words: str
) -> None:
    src = _scenario(tmp_path, **survey)
    result = CliRunner().invoke(main, ["plan", str(src), "-o", str(tmp_path / "s.plan")])
    assert result.exit_code == 2, result.output
    assert key in result.output and words in result.output, result.output
    assert "Traceback" not in result.output
