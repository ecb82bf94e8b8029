"""Issue 33 on the real firmware: the bundled DEM survey
(missions/surveys/survey-jacksboro-ridge.yaml) flown by ``uavplan fly`` on ArduPilot SITL
and PX4 SIH. Its lanes climb and descend the ridge; at every lane's first photo positions
the firmware's altitude stays within the survey's height tolerance of the lane (so its
photos' heights above the ground do), the flight model's within ``MODEL_GAP_M`` of the
firmware's, and the flight time within ±3 % of the model's (tools/sitl_survey.py prints the
same table).

The firmware varies from run to run, and most at the first lane's first photo position, where
the vehicle has just climbed 68 m from the take-off and turns onto a lane that climbs 7.3 m in
15 m. On PX4 SIH it was -0.95 m off the lane in one CI run and -0.53 m in another (whose two
flights missed the model by 1.07 and 1.11 m), and +0.31, +0.11, -0.27 and -0.06 m in four runs
on an idle machine (2026-11-29); the model says +0.58 m. The firmware's own spread there (1.26
m) is wider than the 1 m this test asked of the model before, so the model is held to issue
32's 2 m track-deviation target (``MODEL_GAP_M``), and the bias at that corner stays in issue
32's notes. A flight whose comparison with the model misses is flown once more, and that one
must hold; every flight must keep the photos' heights within the survey's tolerance.

SITL's world is flat at home: the firmware flies the mission's AMSL altitudes as written,
which is what is compared (the DEM is the model's, and the independent sampler's in
tests/survey/test_survey_terrain.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers import sitl
from helpers import sitl_flight as sf

from uavplan.app.feedback import Feedback
from uavplan.app.plan import PlanRequest, plan
from uavplan.mission.io import load_mission
from uavplan.mission.items import Autopilot, MavCmd
from uavplan.surveying import HAG_TOLERANCE_M

pytestmark = [pytest.mark.sitl, pytest.mark.timeout(1200)]

# issue 32's target for the model's track against the firmware's (m)
MODEL_GAP_M = sf.DEVIATION_M

RIDGE = Path(__file__).resolve().parents[2] / "missions" / "surveys" / "survey-jacksboro-ridge.yaml"


@pytest.mark.parametrize("autopilot", [Autopilot.ARDUPILOT, Autopilot.PX4], ids=lambda a: a.label)
def test_the_dem_survey_flies_on_the_firmware_as_planned(
    autopilot: Autopilot, tmp_path: Path
) -> None:
    sitl.need(autopilot)
    variant = sitl.scenario_variant(RIDGE, autopilot, "bundled", tmp_path, amsl=True)
    plan_path = tmp_path / "ridge.plan"
    plan(PlanRequest(str(variant), str(plan_path), autopilot=autopilot.label), Feedback())
    mission = load_mission(plan_path)
    assert mission.home is not None
    model = sf.model_flight(mission, autopilot, sf.plan_params(mission, autopilot))
    trig = next(
        it.param1
        for it in mission.items
        if it.command == int(MavCmd.DO_SET_CAM_TRIGG_DIST) and (it.param1 or 0) > 0
    )
    marks = (0.5, 0.5 + trig, 0.5 + 2 * trig)
    model_path = sf.FlownPath.from_model(model)
    md = sf.lane_errors(plan_path, model_path, marks)
    md_err = np.array([e for *_, errs in md for e in errs])
    takeoff_seq, end_seq = sf.marks(mission, autopilot)
    landing = sf.landing_height(mission)
    md_s = sf.phases(model_path, takeoff_seq, end_seq, landing).flight_s
    tries = []
    for _attempt in range(2):
        flight = sf.fly(
            plan_path,
            autopilot,
            speedup=8.0,
            params=dict(sitl.FLIGHT_PARAMS[autopilot]),
            model_s=model.flight_time_s,
            extra_args=("--set-params",) if mission.parameters else (),
        )
        assert flight.exit_code == 0, flight.output
        fw_path = flight.path(mission.home)
        fw = sf.lane_errors(plan_path, fw_path, marks)
        assert len(fw) >= 9  # every lane, both ways up and down the ridge
        fw_err = np.array([e for *_, errs in fw for e in errs])
        seen = np.isfinite(fw_err)
        # every flight: the photos' heights within the survey's tolerance
        assert np.abs(fw_err[seen]).max() <= HAG_TOLERANCE_M, fw
        gap = float(np.abs(fw_err[seen] - md_err[seen]).max())
        fw_s = sf.phases(fw_path, takeoff_seq, end_seq, landing).flight_s
        tries.append((round(gap, 2), round(fw_s / md_s - 1.0, 4)))
        if gap <= MODEL_GAP_M and abs(fw_s / md_s - 1.0) <= sf.TIME_TOLERANCE:
            break
    # the model against the firmware: a flight that misses is flown once more (module doc)
    assert gap <= MODEL_GAP_M, (tries, fw, md)
    assert abs(fw_s / md_s - 1.0) <= sf.TIME_TOLERANCE, (tries, fw_s, md_s)
