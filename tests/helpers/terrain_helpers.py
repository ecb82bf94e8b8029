"""What the terrain tests share: synthetic DEMs in a UTM zone, and the independent ground check
(issue 26): the DEM's surface by scipy from the raw band (not uavplan's DEM code), and the
flown path of a mission file rebuilt here from its items, terrain-frame legs as ArduPilot flies
them (the track straight over the ground, the height above the ground linear between the
waypoints' own: AC_WPNav converts the leg's origin to an altitude above terrain), sampled
densely and measured against that surface.

The mutation check: ``UAVPLAN_TEST_LOWER_GROUND_M=5 pytest -p helpers.terrain_helpers tests/...``
loads this module as a plugin, whose autouse fixture lowers every DEM the product reads by
5 m (the independent surface is read from the file itself): the terrain tests must fail.
"""

from __future__ import annotations

import itertools
import math
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

from uavplan.geo import EnuFrame
from uavplan.mission.items import MavCmd, MavFrame, MissionPlan

UTM = "EPSG:32632"
#: the altitude frames a terrain scenario is planned in (tests/conftest.py's ridge plans)
RIDGE_FRAMES = ("relative", "amsl", "terrain")
LAT0, LON0 = 47.0, 9.2
#: how far apart the independent check samples the flown path (m)
SAMPLE_M = 1.0

LOWER_GROUND_M = float(os.environ.get("UAVPLAN_TEST_LOWER_GROUND_M", "0") or 0.0)


def utm_origin() -> tuple[float, float]:
    from pyproj import Transformer

    e, n = Transformer.from_crs("EPSG:4326", UTM, always_xy=True).transform(LON0, LAT0)
    return float(e), float(n)


def write_utm_dem(
    path: Path, surface: Callable[[NDArray, NDArray], NDArray], *, cell_m: float, size: int
) -> Path:
    """A float64 GeoTIFF in UTM 32N centred near (LAT0, LON0): ``size`` × ``size`` posts
    ``cell_m`` apart, each the value of ``surface(east, north)`` at its pixel centre."""
    import rasterio
    from rasterio.transform import Affine

    e0, n0 = utm_origin()
    west = round(e0) - size * cell_m / 2.0
    north = round(n0) + size * cell_m / 2.0
    cols, rows = np.meshgrid(np.arange(size) + 0.5, np.arange(size) + 0.5)
    z = surface(west + cols * cell_m, north - rows * cell_m)
    # what rasterio.transform.from_origin returns, without its `*` (affine 3.0 deprecates it)
    profile = {
        "driver": "GTiff", "height": size, "width": size, "count": 1, "dtype": "float64",
        "crs": UTM, "transform": Affine(cell_m, 0.0, west, 0.0, -cell_m, north),
    }  # fmt: skip
    with rasterio.open(path, "w", **profile) as dst:
        dst.write(z.astype(np.float64), 1)
    return path


def raw_ground(terrain_file: str | Path, frame: EnuFrame) -> Callable[[NDArray], NDArray]:
    """The DEM's surface as AMSL heights at ENU points ``(n, 2)`` of ``frame``: bilinear
    between the posts (pixel centres) in the raster's own CRS, by scipy from the raw band."""
    import rasterio
    from pyproj import Transformer
    from scipy.interpolate import RegularGridInterpolator

    with rasterio.open(terrain_file) as src:
        z = src.read(1).astype(float)
        t = src.transform
        to_crs = Transformer.from_crs("EPSG:4326", src.crs.to_wkt(), always_xy=True)
    interp = RegularGridInterpolator(
        (np.arange(z.shape[0]) + 0.5, np.arange(z.shape[1]) + 0.5), z, method="linear"
    )

    def amsl(xy: NDArray) -> NDArray:
        xy = np.atleast_2d(np.asarray(xy, dtype=float))
        lat, lon, _ = frame.to_geodetic(np.column_stack([xy[:, :2], np.zeros(len(xy))]))
        # as lists: pyproj < 3.7 turns a one-element array into a float (NumPy deprecates it)
        x, y = (np.asarray(v) for v in to_crs.transform(list(lon), list(lat)))
        inv = ~t  # by its coefficients: affine deprecates `*` on a point, `@` is newer
        x, y = np.asarray(x), np.asarray(y)
        col, row = inv.a * x + inv.b * y + inv.c, inv.d * x + inv.e * y + inv.f
        return np.asarray(interp(np.column_stack([row, col])))

    return amsl


def flown_samples(
    plan: MissionPlan, frame: EnuFrame, amsl: Callable[[NDArray], NDArray], step_m: float
) -> tuple[NDArray, NDArray]:
    """The flown path of ``plan`` (home on the ground, the take-off climb, the legs, a landing
    descent) sampled every ``step_m``: AMSL points ``(n, 3)`` (x, y in ``frame``) and whether
    each sample is on a leg in the air (not the climb from home or the landing descent)."""
    home = plan.home
    assert home is not None
    hxy = frame.to_enu_xy([home.lat_deg], [home.lon_deg])[0]
    points = [np.array([hxy[0], hxy[1], home.alt_m])]
    air = [False]
    for item in plan.items:
        if item.command == MavCmd.NAV_RETURN_TO_LAUNCH:
            break
        if not item.is_global or item.command >= 80:
            continue
        last = points[-1]
        frame_id = int(item.frame)
        if item.command == MavCmd.NAV_TAKEOFF:  # climbs where it is, to its altitude
            if frame_id == int(MavFrame.GLOBAL):
                alt = item.alt_m
            elif frame_id in (int(MavFrame.GLOBAL_TERRAIN_ALT), 11):
                alt = float(amsl(last[None, :2])[0]) + item.alt_m
            else:
                alt = home.alt_m + item.alt_m
            points.append(np.array([last[0], last[1], alt]))
            air.append(False)
            continue
        xy = frame.to_enu_xy([item.lat_deg], [item.lon_deg])[0]
        if item.command == MavCmd.NAV_LAND:
            if item.lat_deg == 0.0 and item.lon_deg == 0.0:
                xy = last[:2]
            ground = float(amsl(xy[None, :])[0])
            points.append(np.array([xy[0], xy[1], last[2]]))
            air.append(True)
            points.append(np.array([xy[0], xy[1], ground]))
            air.append(False)
            break
        if frame_id in (int(MavFrame.GLOBAL_TERRAIN_ALT), 11):
            # ArduPilot: the track straight, the height above the ground linear along it
            a_agl = last[2] - float(amsl(last[None, :2])[0])
            b_agl = item.alt_m
            n = max(2, math.ceil(float(np.hypot(*(xy - last[:2]))) / step_m) + 1)
            t = np.linspace(0.0, 1.0, n)[1:]
            txy = last[:2] + t[:, None] * (xy - last[:2])
            z = amsl(txy) + a_agl + t * (b_agl - a_agl)
            for p, zz in zip(txy, z, strict=True):
                points.append(np.array([p[0], p[1], zz]))
                air.append(True)
            continue
        alt = item.alt_m if frame_id == int(MavFrame.GLOBAL) else home.alt_m + item.alt_m
        points.append(np.array([xy[0], xy[1], alt]))
        air.append(True)
    line = np.array(points)
    flags = np.array(air)
    out, out_air = [line[:1]], [flags[:1]]
    for (a, b), in_air in zip(itertools.pairwise(line), flags[1:], strict=True):
        n = max(1, math.ceil(float(np.linalg.norm(b - a)) / step_m))
        t = np.arange(1, n + 1)[:, None] / n
        out.append(a + t * (b - a))
        out_air.append(np.full(n, in_air))
    return np.vstack(out), np.concatenate(out_air)


def independent_ground_check(
    mission_file: str | Path, terrain_file: str | Path, frame: EnuFrame, *, step_m: float = SAMPLE_M
) -> tuple[float, float]:
    """(lowest, highest) height above the DEM's surface (scipy, raw band) of the flown path's
    samples in the air, every ``step_m`` (the climb from home and a landing descent excluded:
    they touch the ground by design)."""
    from uavplan.mission.io import load_mission

    plan = load_mission(mission_file)
    amsl = raw_ground(terrain_file, frame)
    samples, air = flown_samples(plan, frame, amsl, step_m)
    agl = samples[air, 2] - amsl(samples[air, :2])
    return float(agl.min()), float(agl.max())


def lower_the_ground(monkeypatch: object) -> None:
    """Apply ``LOWER_GROUND_M`` to the DEMs the product reads (see the module doc)."""
    if not LOWER_GROUND_M:
        return
    from uavplan.sources import dem

    original = dem.Terrain.from_file.__func__  # type: ignore[attr-defined]

    def lowered(cls: type, *args: object, **kwargs: object) -> dem.Terrain:
        terrain = original(cls, *args, **kwargs)
        object.__setattr__(terrain, "posts_amsl_m", terrain.posts_amsl_m - LOWER_GROUND_M)
        return terrain

    monkeypatch.setattr(dem.Terrain, "from_file", classmethod(lowered))  # type: ignore[attr-defined]


@pytest.fixture(autouse=True)
def _lowered_ground(monkeypatch: pytest.MonkeyPatch) -> None:
    """Active only when this module is loaded as a plugin (``-p helpers.terrain_helpers``)."""
    lower_the_ground(monkeypatch)
