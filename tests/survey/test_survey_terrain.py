"""Issue 33: a survey over the bundled DEM (missions/surveys/survey-jacksboro-ridge.yaml)
keeps its height above the ground within :data:`uavplan.surveying.HAG_TOLERANCE_M` along
every lane and at every photo as flown, by an independent DEM sampler (the end-to-end test's:
scipy over the raw GeoTIFF posts, not uavplan's DEM code)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers.independent import independent_ground

from uavplan.app.feedback import Feedback
from uavplan.app.plan import PlanRequest, plan
from uavplan.app.survey import SurveyOutcome
from uavplan.autopilot.camera import photo_positions
from uavplan.geo import EnuFrame
from uavplan.mission.items import MavFrame
from uavplan.surveying import HAG_TOLERANCE_M, lane_profile

ROOT = Path(__file__).resolve().parents[2]
RIDGE = ROOT / "missions" / "surveys" / "survey-jacksboro-ridge.yaml"
ALTITUDE = 60.0


@pytest.fixture(scope="module", params=["ardupilot", "px4"])
def surveyed(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> SurveyOutcome:
    out = tmp_path_factory.mktemp("ridge") / "ridge.plan"
    outcome = plan(PlanRequest(str(RIDGE), str(out), autopilot=request.param), Feedback())
    assert isinstance(outcome, SurveyOutcome) and outcome.parts == ()
    return outcome


def _ground(outcome: SurveyOutcome):  # type: ignore[no-untyped-def]
    scn = outcome.scenario
    return independent_ground(scn, EnuFrame.at(scn.site.origin))


def test_every_lane_keeps_the_height_above_the_ground(surveyed: SurveyOutcome) -> None:
    """Every metre of every lane as planned (straight between its waypoints)."""
    ground = _ground(surveyed)
    w = surveyed.route.waypoints_enu
    worst = 0.0
    for a, b in surveyed.route.lane_rows():
        lane = w[a : b + 1]
        along = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(lane[:, :2], axis=0).T))))
        s = np.linspace(0.0, along[-1], int(along[-1]) + 2)
        xy = np.column_stack([np.interp(s, along, lane[:, 0]), np.interp(s, along, lane[:, 1])])
        hag = np.interp(s, along, lane[:, 2]) - ground(xy)
        worst = max(worst, float(np.abs(hag - ALTITUDE).max()))
    assert worst <= HAG_TOLERANCE_M, worst
    # the ridge is not flat: the lanes needed waypoints between their ends
    assert len(w) > 2 * surveyed.route.lanes + 4
    # every lane waypoint is written with its own AMSL altitude (docs/survey.md)
    frames = {i.frame for i in surveyed.mission.items if i.command == 16}
    assert frames == {MavFrame.GLOBAL}


def _flown_photo_hag(outcome: SurveyOutcome) -> np.ndarray:
    assert outcome.verdict is not None and outcome.verdict.rehearsal is not None
    flown = outcome.verdict.rehearsal.flown
    photos = photo_positions(flown)  # ENU at home, z above home
    assert outcome.mission.home is not None
    home = EnuFrame.at(outcome.mission.home)
    lat, lon, _ = home.to_geodetic(np.column_stack([photos[:, :2], np.zeros(len(photos))]))
    scn = outcome.scenario
    xy = np.asarray(EnuFrame.at(scn.site.origin).to_enu_xy(lat, lon))
    amsl = outcome.mission.home.alt_m + photos[:, 2]
    return amsl - scn.site.origin.alt_m - _ground(outcome)(xy)


def test_every_photo_is_taken_within_the_tolerance_as_flown(surveyed: SurveyOutcome) -> None:
    """Both flavours, every photo the flight model takes. PX4 turning onto a lane that
    descends aims at a point on the lane's slope (PositionSmoothing's L1 point is 3-D), as
    PX4 SIH flew the same mission: before the model did so, it dropped up to 6.6 m below the
    lane at the first photos of the lanes that descend from a turn."""
    hag = _flown_photo_hag(surveyed)
    assert len(hag) >= surveyed.route.sweep.photos - surveyed.route.lanes
    assert np.abs(hag - ALTITUDE).max() <= HAG_TOLERANCE_M


def test_a_lane_over_a_slope_with_its_ends_only_breaks_the_tolerance(
    surveyed: SurveyOutcome,
) -> None:
    """The check can fail: the longest lane flown straight between its two ends alone leaves
    the tolerance over the ridge, while lane_profile's waypoints keep it."""
    ground = _ground(surveyed)
    scn = surveyed.scenario
    pieces = surveyed.route.sweep.pieces_xy
    k = int(np.argmax(np.hypot(*(pieces[:, 1] - pieces[:, 0]).T)))
    piece = pieces[k]
    s = np.linspace(0.0, 1.0, 400)
    xy = piece[0] + s[:, None] * (piece[1] - piece[0])
    ends = ground(piece) + ALTITUDE
    straight = ends[0] + s * (ends[1] - ends[0]) - ground(xy)
    assert np.abs(straight - ALTITUDE).max() > HAG_TOLERANCE_M
    from uavplan.surveying import survey_height

    lane = lane_profile(piece, survey_height(scn, ALTITUDE))
    along = np.hypot(*(lane[:, :2] - piece[0]).T)
    total = float(np.hypot(*(piece[1] - piece[0])))
    planned = np.interp(s * total, along, lane[:, 2]) - ground(xy)
    assert np.abs(planned - ALTITUDE).max() <= HAG_TOLERANCE_M
