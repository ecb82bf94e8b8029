"""Camera arithmetic against numbers worked by hand with QGroundControl's CameraCalc
formulas, for a Sony RX100 (13.2 × 8.8 mm sensor, 5472 × 3648 px, 10.4 mm)."""

from __future__ import annotations

import pytest

from uavplan.survey.camera import Camera, camera_spacing, plain_spacing

RX100 = Camera(13.2, 8.8, 5472, 3648, 10.4, "landscape")


def test_rx100_at_60_m_landscape() -> None:
    # footprint = sensor · altitude / focal: 13.2 · 60 / 10.4 = 76.1538 m, 8.8 · 60 / 10.4
    s = camera_spacing(RX100, altitude_m=60.0)
    assert s.gsd_cm == pytest.approx(76.153846 / 5472 * 100, rel=1e-6)  # 1.39170 cm/px
    assert s.footprint_side_m == pytest.approx(76.153846, rel=1e-6)
    assert s.footprint_front_m == pytest.approx(50.769231, rel=1e-6)
    assert s.lane_spacing_m == pytest.approx(22.846154, rel=1e-6)  # 70 % side overlap
    assert s.trigger_distance_m == pytest.approx(15.230769, rel=1e-6)  # 70 % front overlap


def test_rx100_altitude_from_gsd_is_the_inverse() -> None:
    # 2 cm/px: altitude = 2 · 10.4 · 5472 / (13.2 · 100) = 86.2255 m
    s = camera_spacing(RX100, gsd_cm=2.0, front_overlap_pct=80, side_overlap_pct=60)
    assert s.altitude_m == pytest.approx(86.225455, rel=1e-6)
    assert s.gsd_cm == pytest.approx(2.0)
    assert s.footprint_side_m == pytest.approx(2.0 * 5472 / 100)
    assert s.lane_spacing_m == pytest.approx(2.0 * 5472 / 100 * 0.4)
    assert s.trigger_distance_m == pytest.approx(2.0 * 3648 / 100 * 0.2)


def test_portrait_swaps_the_footprint() -> None:
    portrait = Camera(13.2, 8.8, 5472, 3648, 10.4, "portrait")
    s = camera_spacing(portrait, altitude_m=60.0)
    # QGC: portrait takes the GSD on the sensor height / image height
    assert s.gsd_cm == pytest.approx(8.8 * 60 * 100 / (10.4 * 3648))
    assert s.footprint_side_m == pytest.approx(50.769231, rel=1e-6)
    assert s.footprint_front_m == pytest.approx(76.153846, rel=1e-6)


def test_without_a_camera_the_trigger_distance_is_the_lane_spacing() -> None:
    s = plain_spacing(60.0, 30.0)
    assert (s.altitude_m, s.lane_spacing_m, s.trigger_distance_m) == (60.0, 30.0, 30.0)


@pytest.mark.parametrize(
    "kwargs",
    [
        {},
        {"altitude_m": 60.0, "gsd_cm": 2.0},
        {"altitude_m": -1.0},
        {"altitude_m": 60.0, "side_overlap_pct": 100},
        {"altitude_m": 60.0, "front_overlap_pct": -5},
    ],
)
def test_bad_values_are_refused(kwargs: dict[str, float]) -> None:
    with pytest.raises(ValueError):
        camera_spacing(RX100, **kwargs)


def test_bad_camera_is_refused() -> None:
    with pytest.raises(ValueError, match="focal_length_mm"):
        Camera(13.2, 8.8, 5472, 3648, 0.0)
    with pytest.raises(ValueError, match="orientation"):
        Camera(13.2, 8.8, 5472, 3648, 10.4, "sideways")  # type: ignore[arg-type]
