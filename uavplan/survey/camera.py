"""Camera footprint arithmetic for area surveys, as QGroundControl's ``CameraCalc`` does it.

The same camera, altitude and overlaps give the same ground sample distance (GSD), lane
spacing and trigger distance here as in QGC (``src/MissionManager/CameraCalc.cc``):

* GSD (cm/px) = sensor_width_mm · altitude_m · 100 / (focal_length_mm · image_width_px)
  (landscape; portrait uses the sensor height and the image height);
* footprint across the lane (m) = GSD · image_width_px / 100, along it = GSD ·
  image_height_px / 100 (landscape; portrait swaps them);
* lane spacing = footprint_side · (1 − side overlap), trigger distance = footprint_front ·
  (1 − front overlap).

Pure arithmetic: no files, no MAVLink.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

Orientation = Literal["landscape", "portrait"]


def _positive(name: str, value: float) -> None:
    if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive number, got {value!r}")


@dataclass(frozen=True)
class Camera:
    """A nadir camera: sensor size (mm), image size (px), focal length (mm), orientation."""

    sensor_width_mm: float
    sensor_height_mm: float
    image_width_px: int
    image_height_px: int
    focal_length_mm: float
    orientation: Orientation = "landscape"

    def __post_init__(self) -> None:
        for name in (
            "sensor_width_mm",
            "sensor_height_mm",
            "image_width_px",
            "image_height_px",
            "focal_length_mm",
        ):
            _positive(name, getattr(self, name))
        if self.orientation not in ("landscape", "portrait"):
            raise ValueError(f"orientation must be landscape or portrait, got {self.orientation!r}")

    def _gsd_axis(self) -> tuple[float, int]:
        """(sensor mm, image px) of the axis QGC computes the GSD on."""
        if self.orientation == "landscape":
            return self.sensor_width_mm, self.image_width_px
        return self.sensor_height_mm, self.image_height_px

    def gsd_cm(self, altitude_m: float) -> float:
        """Ground sample distance (cm per pixel) at ``altitude_m`` above the ground."""
        _positive("altitude_m", altitude_m)
        sensor_mm, image_px = self._gsd_axis()
        return sensor_mm * altitude_m * 100.0 / (self.focal_length_mm * image_px)

    def altitude_m(self, gsd_cm: float) -> float:
        """Height above the ground (m) that gives ``gsd_cm``: the inverse of :meth:`gsd_cm`."""
        _positive("gsd_cm", gsd_cm)
        sensor_mm, image_px = self._gsd_axis()
        return gsd_cm * self.focal_length_mm * image_px / (sensor_mm * 100.0)

    def footprint_m(self, altitude_m: float) -> tuple[float, float]:
        """(across the lane, along the lane) ground size of one image (m) at ``altitude_m``."""
        gsd = self.gsd_cm(altitude_m)
        width_m = gsd * self.image_width_px / 100.0
        height_m = gsd * self.image_height_px / 100.0
        if self.orientation == "landscape":
            return width_m, height_m
        return height_m, width_m


@dataclass(frozen=True)
class Spacing:
    """What a survey flies: height above ground, lane spacing and trigger distance (m)."""

    altitude_m: float
    lane_spacing_m: float
    trigger_distance_m: float
    gsd_cm: float | None = None
    footprint_side_m: float | None = None
    footprint_front_m: float | None = None


def _overlap(name: str, pct: float) -> float:
    if not (isinstance(pct, int | float) and math.isfinite(pct) and 0 <= pct < 100):
        raise ValueError(f"{name} must be a percentage in [0, 100), got {pct!r}")
    return pct / 100.0


def camera_spacing(
    camera: Camera,
    *,
    altitude_m: float | None = None,
    gsd_cm: float | None = None,
    front_overlap_pct: float = 70.0,
    side_overlap_pct: float = 70.0,
) -> Spacing:
    """Lane spacing and trigger distance of ``camera`` at ``altitude_m`` or at the height that
    gives ``gsd_cm`` (exactly one of them)."""
    if (altitude_m is None) == (gsd_cm is None):
        raise ValueError("give exactly one of altitude_m and gsd_cm")
    front = _overlap("front_overlap_pct", front_overlap_pct)
    side = _overlap("side_overlap_pct", side_overlap_pct)
    alt = camera.altitude_m(gsd_cm) if gsd_cm is not None else float(altitude_m)  # type: ignore[arg-type]
    side_m, front_m = camera.footprint_m(alt)
    return Spacing(
        altitude_m=alt,
        lane_spacing_m=side_m * (1.0 - side),
        trigger_distance_m=front_m * (1.0 - front),
        gsd_cm=camera.gsd_cm(alt),
        footprint_side_m=side_m,
        footprint_front_m=front_m,
    )


def plain_spacing(altitude_m: float, lane_spacing_m: float) -> Spacing:
    """A survey without a camera model: the trigger distance is the lane spacing."""
    _positive("altitude_m", altitude_m)
    _positive("lane_spacing_m", lane_spacing_m)
    return Spacing(altitude_m, lane_spacing_m, lane_spacing_m)


__all__ = ["Camera", "Orientation", "Spacing", "camera_spacing", "plain_spacing"]
