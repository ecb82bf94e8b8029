"""The end-to-end tests' own geometry, written from scratch (not the library's kernels): a
point's distance to the scenario's obstacles, the DEM's surface read by scipy from the raw
band, a polyline sampled densely. The independent checks of tests/helpers/track_check.py and
the end-to-end tests measure with it."""

from __future__ import annotations

import itertools

import numpy as np

from uavplan.geo import EnuFrame
from uavplan.obstacles import BoxObstacle, CylinderObstacle


def _inside(px: np.ndarray, py: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Even-odd ray casting, vectorised over points."""
    inside = np.zeros(px.shape, dtype=bool)
    n = len(poly)
    for i in range(n):
        (x1, y1), (x2, y2) = poly[i], poly[(i + 1) % n]
        crosses = (y1 > py) != (y2 > py)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_at = x1 + (py - y1) * (x2 - x1) / (y2 - y1)
        inside ^= crosses & (px < x_at)
    return inside


def _edge_distance(px: np.ndarray, py: np.ndarray, poly: np.ndarray) -> np.ndarray:
    best = np.full(px.shape, np.inf)
    n = len(poly)
    for i in range(n):
        a, b = poly[i], poly[(i + 1) % n]
        ab = b - a
        t = np.clip(((px - a[0]) * ab[0] + (py - a[1]) * ab[1]) / (ab @ ab), 0.0, 1.0)
        best = np.minimum(best, np.hypot(px - (a[0] + t * ab[0]), py - (a[1] + t * ab[1])))
    return best


def independent_clearance(scenario, points: np.ndarray) -> np.ndarray:
    """Distance from each point (n, 3) to the nearest obstacle solid (ground to height)."""
    px, py, pz = points[:, 0], points[:, 1], points[:, 2]
    best = np.full(len(points), np.inf)
    for obs in scenario.site.obstacles:  # standing on the ground over terrain
        if isinstance(obs, CylinderObstacle):
            dh = np.maximum(np.hypot(px - obs.center_m[0], py - obs.center_m[1]) - obs.radius_m, 0)
        else:
            poly = np.array(obs.footprint() if isinstance(obs, BoxObstacle) else obs.polygon_m)
            dh = np.where(_inside(px, py, poly), 0.0, _edge_distance(px, py, poly))
        dz = np.maximum(pz - obs.height_m, 0.0) + np.maximum(-pz, 0.0)
        best = np.minimum(best, np.hypot(dh, dz))
    return best


def independent_ground(scenario, frame: EnuFrame):
    """The scenario DEM's surface as z in ``frame``: bilinear between the posts (pixel centres)
    in the raster's own CRS, by scipy from the raw band, not by uavplan's DEM code."""
    import rasterio
    from pyproj import Transformer
    from scipy.interpolate import RegularGridInterpolator

    with rasterio.open(scenario.terrain_file) as src:
        z = src.read(1).astype(float)
        t = src.transform
        to_crs = Transformer.from_crs("EPSG:4326", src.crs.to_wkt(), always_xy=True)
    cols = np.arange(z.shape[1]) + 0.5
    rows = np.arange(z.shape[0]) + 0.5
    interp = RegularGridInterpolator((rows, cols), z, method="linear")
    datum = scenario.site.origin.alt_m

    def ground_z(xy: np.ndarray) -> np.ndarray:
        xy = np.atleast_2d(xy)
        lat, lon, _ = frame.to_geodetic(np.column_stack([xy[:, :2], np.zeros(len(xy))]))
        # as lists: pyproj < 3.7 turns a one-element array into a float (NumPy deprecates it)
        x, y = (np.asarray(v) for v in to_crs.transform(list(lon), list(lat)))
        inv = ~t  # by its coefficients: affine deprecates `*` on a point, `@` is newer
        x, y = np.asarray(x), np.asarray(y)
        col, row = inv.a * x + inv.b * y + inv.c, inv.d * x + inv.e * y + inv.f
        return interp(np.column_stack([row, col])) - datum

    return ground_z


def densify(polyline: np.ndarray, step: float) -> np.ndarray:
    pieces = []
    for a, b in itertools.pairwise(polyline):
        n = max(2, int(np.ceil(np.linalg.norm(b - a) / step)) + 1)
        pieces.append(a + np.linspace(0.0, 1.0, n)[:, None] * (b - a))
    return np.vstack(pieces)
