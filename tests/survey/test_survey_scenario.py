"""The ``survey:`` section of a scenario: read and checked key by key; both goal and
survey, neither, and every malformed value is one clear message and exit 2 (SPEC §3)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import yaml
from click.testing import CliRunner

from uavplan.cli import main
from uavplan.errors import ScenarioError
from uavplan.scenario.checker import Checker
from uavplan.scenario.survey import read_survey

BASE: dict[str, Any] = {
    "origin": {"lat": 60.0, "lon": 25.0},
    "bounds": {"x": [-100, 900], "y": [-100, 600], "z": [0, 120]},
    "start": [0, 0, 30],
}
AREA = [[0, 0], [800, 0], [800, 500], [0, 500]]
RX100 = {
    "sensor_width_mm": 13.2,
    "sensor_height_mm": 8.8,
    "image_width_px": 5472,
    "image_height_px": 3648,
    "focal_length_mm": 10.4,
}


def read(raw: Any) -> Any:
    return read_survey(Checker("f.yaml"), raw)


def test_plain_survey() -> None:
    s = read({"area": AREA, "altitude": 60, "lane_spacing_m": 30, "angle_deg": 15})
    assert s.altitude_m == 60.0
    assert s.spacing.lane_spacing_m == 30.0 and s.spacing.trigger_distance_m == 30.0
    assert s.angle_deg == 15.0 and s.trigger == "distance" and s.exclude_m == ()
    assert s.area_m[1] == (800.0, 0.0)


def test_camera_survey_with_gsd_uses_qgc_defaults() -> None:
    s = read({"area": AREA, "camera": RX100, "gsd_cm": 2.0, "trigger": "hover"})
    assert s.angle_deg is None  # auto
    assert s.altitude_m == pytest.approx(86.225455, rel=1e-6)
    assert s.spacing.lane_spacing_m == pytest.approx(2.0 * 5472 / 100 * 0.3)
    assert s.spacing.trigger_distance_m == pytest.approx(2.0 * 3648 / 100 * 0.3)
    assert s.trigger == "hover"


BAD: dict[str, tuple[dict[str, Any], str, str]] = {
    "no-area": ({"altitude": 60, "lane_spacing_m": 30}, "survey.area", "missing required"),
    "two-points": ({"area": AREA[:2]}, "survey.area", "at least 3"),
    "bow-tie": (
        {"area": [[0, 0], [10, 10], [10, 0], [0, 10]], "altitude": 60, "lane_spacing_m": 30},
        "survey.area",
        "simple polygon",
    ),
    "no-spacing": ({"area": AREA, "altitude": 60}, "survey.lane_spacing_m", "missing"),
    "zero-spacing": (
        {"area": AREA, "altitude": 60, "lane_spacing_m": 0},
        "survey.lane_spacing_m",
        "> 0",
    ),
    "gsd-without-camera": (
        {"area": AREA, "gsd_cm": 2, "altitude": 60, "lane_spacing_m": 30},
        "survey.gsd_cm",
        "needs a camera",
    ),
    "camera-and-spacing": (
        {"area": AREA, "camera": RX100, "altitude": 60, "lane_spacing_m": 30},
        "survey.lane_spacing_m",
        "one or the other",
    ),
    "camera-gsd-and-altitude": (
        {"area": AREA, "camera": RX100, "altitude": 60, "gsd_cm": 2},
        "survey",
        "exactly one of altitude and gsd_cm",
    ),
    "camera-missing-focal": (
        {"area": AREA, "camera": {k: v for k, v in RX100.items() if k != "focal_length_mm"},
         "altitude": 60},
        "survey.camera.focal_length_mm",
        "missing required",
    ),
    "fractional-pixels": (
        {"area": AREA, "camera": {**RX100, "image_width_px": 5472.5}, "altitude": 60},
        "survey.camera.image_width_px",
        "whole number",
    ),
    "orientation": (
        {"area": AREA, "camera": {**RX100, "orientation": "sideways"}, "altitude": 60},
        "survey.camera.orientation",
        "landscape, portrait",
    ),
    "overlap-100": (
        {"area": AREA, "camera": RX100, "altitude": 60, "side_overlap_pct": 100},
        "survey.side_overlap_pct",
        "<= 99",
    ),
    "angle-word": (
        {"area": AREA, "altitude": 60, "lane_spacing_m": 30, "angle_deg": "north"},
        "survey.angle_deg",
        "auto or a number",
    ),
    "trigger": (
        {"area": AREA, "altitude": 60, "lane_spacing_m": 30, "trigger": "video"},
        "survey.trigger",
        "distance, hover",
    ),
    "exclude-not-list": (
        {"area": AREA, "altitude": 60, "lane_spacing_m": 30, "exclude": 3},
        "survey.exclude",
        "list of polygons",
    ),
    "exclude-point": (
        {"area": AREA, "altitude": 60, "lane_spacing_m": 30, "exclude": [[[1, 2], [3]]]},
        "survey.exclude[0]",
        "at least 3",
    ),
    "unknown-key": (
        {"area": AREA, "altitude": 60, "lane_spacing_m": 30, "speed": 5},
        "survey.speed",
        "unknown key",
    ),
    "gsd-too-high": (
        {"area": AREA, "camera": RX100, "gsd_cm": 500},
        "survey.gsd_cm",
        "needs an altitude",
    ),
}  # fmt: skip


@pytest.mark.parametrize("case", sorted(BAD))
def test_malformed_values_name_the_key(case: str) -> None:
    raw, key, reason = BAD[case]
    with pytest.raises(ScenarioError) as err:
        read(raw)
    assert err.value.key == key
    assert reason in err.value.reason


def _run(tmp_path: Path, extra: dict[str, Any], command: str = "validate") -> Any:
    f = tmp_path / "s.yaml"
    f.write_text(yaml.safe_dump({**BASE, **extra}))
    args = [command, str(f)] + (["-o", str(tmp_path / "s.plan")] if command == "plan" else [])
    return CliRunner().invoke(main, args)


@pytest.mark.parametrize("command", ["validate", "plan"])
@pytest.mark.parametrize(
    ("extra", "expected"),
    [
        (
            {"goal": [500, 0, 30], "survey": {"area": AREA, "altitude": 60, "lane_spacing_m": 30}},
            "survey: a scenario has a goal or a survey, not both",
        ),
        ({}, "goal: missing required key"),
        ({"survey": {"area": AREA, "altitude": 60}}, "survey.lane_spacing_m: missing"),
    ],
    ids=["goal-and-survey", "neither", "malformed"],
)
def test_cli_exit_2_with_one_message(
    tmp_path: Path, command: str, extra: dict[str, Any], expected: str
) -> None:
    result = _run(tmp_path, extra, command)
    assert result.exit_code == 2, result.output
    assert expected in result.output
    assert "Traceback" not in result.output
    assert not (tmp_path / "s.plan").exists()


@pytest.mark.parametrize("command", ["validate", "render"])
def test_commands_other_than_plan_refuse_a_valid_survey_clearly(
    tmp_path: Path, command: str
) -> None:
    f = tmp_path / "s.yaml"
    f.write_text(
        yaml.safe_dump({**BASE, "survey": {"area": AREA, "altitude": 60, "lane_spacing_m": 30}})
    )
    args = [command, str(f)] + (["-o", str(tmp_path / "s.png")] if command == "render" else [])
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2, result.output
    assert "uavplan plan plans a survey" in result.output and "give a goal" in result.output
    assert "Traceback" not in result.output
