"""Terrain from a DEM GeoTIFF (any CRS, metres above mean sea level), read with rasterio.

:meth:`Terrain.from_file` reads band 1 (nodata → not covered) of a raster whose posts are
*pixel centres* (GDAL's convention), optionally only the window around an ENU area.
:meth:`Terrain.height_m` gives the ground height AMSL at ENU ``(x, y)`` points by bilinear
interpolation between the four surrounding posts (vectorised; ENU → lon/lat with the
scenario's :class:`~uavplan.geo.EnuFrame` → DEM CRS with pyproj → pixel coordinates with the
raster's affine transform). In the outer half-cell along the raster's edge the nearest row or
column is held constant. A point outside the raster, or next to a nodata post, is not covered:
:meth:`Terrain.height_m` then raises :class:`TerrainError` naming the point
(:meth:`Terrain.covers` tells without raising).

Band units ``ft``/``foot``/``feet`` (GDAL unit type) are converted to metres; anything else
is taken as metres.

Conservative maximum grid (:meth:`Terrain.max_grid`), for clearance checks: the ground's
maximum over each square ENU cell, bounded from above in two parts:

1. the interpolated surface: bilinear interpolation within a quad of posts never exceeds its
   four corners, so the maximum of the surface over a cell is at most the largest post whose
   quad touches the cell. We take every post within ``R`` of the cell (``R`` = the largest
   ENU distance between diagonal neighbour posts, so all quad corners are included);
2. a Lipschitz pad for the real ground between posts, which the DEM does not resolve: if the
   ground has slope at most ``L`` near a post, any point lies within ``d`` (half the post
   diagonal) of a post, so the ground there is at most that post's height + ``L·d``. ``L`` is
   estimated per post as √2 × the steepest slope to its four neighbours (√2 bounds the
   gradient of a bilinear surface from its two axis slopes), and each post contributes
   ``z + L·d``.

So ``max_grid`` value ≥ the interpolated surface everywhere in the cell (exactly, by 1), and ≥
the real ground under the stated Lipschitz assumption (2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uavplan.errors import InputError
from uavplan.geo import transform_arrays
from uavplan.limits import MAX_DEM_POSTS, MAX_GROUND_AMSL_M, MIN_GROUND_AMSL_M

if TYPE_CHECKING:
    from pyproj import Transformer

    from uavplan.geo import EnuFrame

_FEET_UNITS = ("ft", "foot", "feet", "us survey foot", "ft_us")
#: points of a coverage check (:meth:`Terrain.check_covers`) projected together
COVER_BLOCK_POINTS = 65_536


class TerrainError(InputError):
    """A DEM cannot be read or does not cover a requested point (exit 2)."""


@dataclass(frozen=True)
class TerrainMaxGrid:
    """Conservative ground maxima (metres AMSL) over square ENU cells.

    Cell ``[iy, ix]`` spans ``x0_m + ix·cell_m .. + cell_m`` and ``y0_m + iy·cell_m .. +
    cell_m``; ``max_amsl_m`` has shape ``(ny, nx)``.
    """

    x0_m: float
    y0_m: float
    cell_m: float
    max_amsl_m: NDArray[np.float64]

    def at(self, points_xy: ArrayLike) -> NDArray[np.float64]:
        """The maximum of the cell holding each point ``(n, 2)`` → ``(n,)`` (NaN outside)."""
        p = np.atleast_2d(np.asarray(points_xy, dtype=np.float64))
        ix = np.floor((p[:, 0] - self.x0_m) / self.cell_m).astype(np.int64)
        iy = np.floor((p[:, 1] - self.y0_m) / self.cell_m).astype(np.int64)
        ny, nx = self.max_amsl_m.shape
        ok = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
        out = np.full(len(p), np.nan)
        out[ok] = self.max_amsl_m[iy[ok], ix[ok]]
        return out


@dataclass(frozen=True, eq=False)
class Terrain:
    """Ground heights (metres AMSL) of a DEM, queried at ENU points of ``frame``."""

    frame: EnuFrame
    posts_amsl_m: NDArray[np.float64]  # (rows, cols), NaN where the DEM has no data
    transform: Any  # affine.Affine: pixel (col, row) -> DEM CRS (x, y), of the posts read
    crs_wkt: str
    source: str

    # -- construction ------------------------------------------------------------------------
    @classmethod
    def from_file(
        cls,
        path: str | Path,
        frame: EnuFrame,
        *,
        area_xy_m: tuple[tuple[float, float], tuple[float, float]] | None = None,
    ) -> Terrain:
        """Read a DEM. With ``area_xy_m = ((x0, x1), (y0, y1))`` only the window around that
        ENU area is read, and a DEM that does not cover it is a :class:`TerrainError`."""
        import rasterio
        from rasterio.errors import RasterioError, WindowError
        from rasterio.windows import Window

        path = Path(path)
        if not path.is_file():
            raise TerrainError("DEM file not found", file=str(path))
        try:
            with rasterio.open(path) as src:
                if src.crs is None:
                    raise TerrainError(
                        "the DEM declares no coordinate reference system", file=str(path)
                    )
                crs_wkt = src.crs.to_wkt()
                _check_transform(src.transform, str(path))
                full = Window(0, 0, src.width, src.height)
                window = full
                if area_xy_m is not None:
                    box = _area_in_crs(frame, crs_wkt, area_xy_m)
                    window = _pixel_window(src.transform, box)
                    try:
                        window = window.intersection(full)
                    except WindowError:  # no overlap at all
                        raise TerrainError(
                            "the DEM does not cover the area (no overlap)", file=str(path)
                        ) from None
                if window.width * window.height > MAX_DEM_POSTS:
                    raise TerrainError(
                        f"the DEM holds {int(window.width * window.height):,} posts over the "
                        f"area, more than {MAX_DEM_POSTS:,}: resample it coarser",
                        file=str(path),
                    )
                data = src.read(1, window=window, masked=True).astype(np.float64)
                posts = np.ma.filled(data, np.nan)
                unit = (src.units[0] or "").strip().lower() if src.units else ""
                transform = _window_transform(src.transform, window)
        except RasterioError as err:
            raise TerrainError(f"cannot read the DEM: {err}", file=str(path)) from None
        if unit in _FEET_UNITS:
            posts = posts * 0.3048
        _check_posts(posts, str(path))
        terrain = cls(frame, posts, transform, crs_wkt, str(path))
        if area_xy_m is not None:
            terrain.check_covers(area_xy_m)
        return terrain

    def in_frame(self, frame: EnuFrame) -> Terrain:
        """The same DEM queried at ENU points of ``frame`` (one per frame origin, so what it
        computes once, the posts' positions, is computed once per frame)."""
        if frame.origin == self.frame.origin:
            return self
        hit = self._frames_memo.get(frame.origin)
        if hit is None:
            hit = self._frames_memo[frame.origin] = replace(self, frame=frame)
        return hit

    @cached_property
    def _frames_memo(self) -> dict[Any, Terrain]:
        return {}

    # -- coordinates -------------------------------------------------------------------------
    @cached_property
    def _to_crs(self) -> Transformer:
        from pyproj import Transformer

        return Transformer.from_crs("EPSG:4326", self.crs_wkt, always_xy=True)

    @cached_property
    def _from_crs(self) -> Transformer:
        from pyproj import Transformer

        return Transformer.from_crs(self.crs_wkt, "EPSG:4326", always_xy=True)

    def _pixels(self, points_xy: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """ENU ``(n, 2)`` → fractional (col, row) pixel coordinates of the posts read."""
        p = np.atleast_2d(np.asarray(points_xy, dtype=np.float64))[:, :2]
        enu = np.column_stack((p, np.zeros(len(p))))
        lat, lon, _ = self.frame.to_geodetic(enu)
        x, y = transform_arrays(self._to_crs, lon, lat)
        col, row = _apply(self._to_pixel, np.asarray(x), np.asarray(y))
        return np.asarray(col, dtype=np.float64), np.asarray(row, dtype=np.float64)

    # -- queries -----------------------------------------------------------------------------
    def _bilinear(self, points_xy: ArrayLike) -> NDArray[np.float64]:
        """Heights (NaN where not covered)."""
        col, row = self._pixels(points_xy)
        z = self.posts_amsl_m
        nrows, ncols = z.shape
        inside = (col >= 0) & (col <= ncols) & (row >= 0) & (row <= nrows)
        u = np.clip(col - 0.5, 0.0, ncols - 1.0)  # post-centred coordinates, edges held
        v = np.clip(row - 0.5, 0.0, nrows - 1.0)
        j0 = np.clip(np.floor(u).astype(np.int64), 0, max(ncols - 2, 0))
        i0 = np.clip(np.floor(v).astype(np.int64), 0, max(nrows - 2, 0))
        j1 = np.minimum(j0 + 1, ncols - 1)
        i1 = np.minimum(i0 + 1, nrows - 1)
        tu = u - j0
        tv = v - i0
        out = (
            z[i0, j0] * (1 - tu) * (1 - tv)
            + z[i0, j1] * tu * (1 - tv)
            + z[i1, j0] * (1 - tu) * tv
            + z[i1, j1] * tu * tv
        )
        out[~inside] = np.nan
        return np.asarray(out, dtype=np.float64)

    @cached_property
    def _to_pixel(self) -> Any:
        return ~self.transform

    def height_at(self, x: float, y: float) -> float:
        """Ground height AMSL at one ENU point: :meth:`height_m` in scalar arithmetic, for
        callers that ask one point at a time (a simulated flight's ground); the same value to
        about 1e-9 m (tests/sources/test_sources_dem.py)."""
        lat, lon, _ = self.frame.to_geodetic_point(float(x), float(y), 0.0)
        cx, cy = self._to_crs.transform(lon, lat)
        t = self._to_pixel
        col, row = t.a * cx + t.b * cy + t.c, t.d * cx + t.e * cy + t.f
        z = self.posts_amsl_m
        nrows, ncols = z.shape
        h = math.nan
        if 0.0 <= col <= ncols and 0.0 <= row <= nrows:
            u = min(max(col - 0.5, 0.0), ncols - 1.0)
            v = min(max(row - 0.5, 0.0), nrows - 1.0)
            j0 = min(max(math.floor(u), 0), max(ncols - 2, 0))
            i0 = min(max(math.floor(v), 0), max(nrows - 2, 0))
            j1, i1 = min(j0 + 1, ncols - 1), min(i0 + 1, nrows - 1)
            tu, tv = u - j0, v - i0
            h = float(
                z[i0, j0] * (1 - tu) * (1 - tv)
                + z[i0, j1] * tu * (1 - tv)
                + z[i1, j0] * (1 - tu) * tv
                + z[i1, j1] * tu * tv
            )
        if not math.isfinite(h):
            raise self._not_covered(x, y, 1, 1)
        return h

    def _not_covered(self, x: float, y: float, bad: int, of: int) -> TerrainError:
        return TerrainError(
            f"the DEM does not cover ENU point ({x:.1f}, {y:.1f}) m "
            f"({bad} of {of} points outside it or on nodata)",
            file=self.source,
        )

    def covers(self, points_xy: ArrayLike) -> NDArray[np.bool_]:
        """Whether the DEM gives a height at each ENU point ``(n, 2)``."""
        return np.isfinite(self._bilinear(points_xy))

    def height_m(self, points_xy: ArrayLike) -> NDArray[np.float64]:
        """Ground height AMSL at ENU points ``(n, 2)`` (or ``(n, 3)``, z ignored) → ``(n,)``."""
        h = self._bilinear(points_xy)
        bad = ~np.isfinite(h)
        if np.any(bad):
            p = np.atleast_2d(np.asarray(points_xy, dtype=np.float64))[np.argmax(bad)]
            raise self._not_covered(p[0], p[1], int(bad.sum()), bad.size)
        return h

    def check_covers(
        self,
        area_xy_m: tuple[tuple[float, float], tuple[float, float]],
        step_m: float | None = None,
    ) -> None:
        """Raise :class:`TerrainError` unless every point of the ENU rectangle is covered
        (checked on a grid finer than the DEM's posts)."""
        (x0, x1), (y0, y1) = area_xy_m
        step = step_m or max(self.post_spacing_m / 2.0, 1e-3)
        nx = max(2, math.ceil((x1 - x0) / step) + 1)
        ny = max(2, math.ceil((y1 - y0) / step) + 1)
        if nx * ny > 4_000_000:  # very large area: the border and a coarse interior suffice
            nx, ny = min(nx, 2000), min(ny, 2000)
        xs, ys = np.linspace(x0, x1, nx), np.linspace(y0, y1, ny)
        # a block of rows at a time (the projection's temporaries for a few million points
        # took hundreds of MB); the message counts every point, as one call would
        rows = max(1, COVER_BLOCK_POINTS // nx)
        first: NDArray[np.float64] | None = None
        bad = 0
        for r0 in range(0, ny, rows):
            gx, gy = np.meshgrid(xs, ys[r0 : r0 + rows])
            points = np.column_stack((gx.ravel(), gy.ravel()))
            missing = ~self.covers(points)
            if first is None and missing.any():
                first = points[np.argmax(missing)]
            bad += int(missing.sum())
        if first is not None:
            raise TerrainError(
                f"the DEM does not cover ENU point ({first[0]:.1f}, {first[1]:.1f}) m "
                f"({bad} of {nx * ny} points outside it or on nodata)",
                file=self.source,
            )

    @cached_property
    def _posts_enu(self) -> NDArray[np.float64]:
        """ENU (x, y) of every post, shape ``(rows, cols, 2)``."""
        nrows, ncols = self.posts_amsl_m.shape
        cols, rows = np.meshgrid(np.arange(ncols) + 0.5, np.arange(nrows) + 0.5)
        x, y = _apply(self.transform, cols.ravel(), rows.ravel())
        lon, lat = transform_arrays(self._from_crs, x, y)
        xy = self.frame.to_enu_xy(np.asarray(lat), np.asarray(lon))
        return xy.reshape(nrows, ncols, 2)

    @cached_property
    def post_spacing_m(self) -> float:
        """The largest ENU distance between neighbouring posts along rows or columns."""
        xy = self._posts_enu
        d = [0.0]
        if xy.shape[1] > 1:
            d.append(float(np.max(np.hypot(*np.moveaxis(np.diff(xy, axis=1), -1, 0)))))
        if xy.shape[0] > 1:
            d.append(float(np.max(np.hypot(*np.moveaxis(np.diff(xy, axis=0), -1, 0)))))
        return max(d)

    def post_slopes(self) -> NDArray[np.float64]:
        """√2 × the steepest slope from each post to its 4 neighbours, ``(rows, cols)``."""
        z = self.posts_amsl_m
        xy = self._posts_enu
        slope = np.zeros_like(z)
        for axis in (0, 1):
            if z.shape[axis] < 2:
                continue
            dz = np.abs(np.diff(z, axis=axis))
            dist = np.hypot(*np.moveaxis(np.diff(xy, axis=axis), -1, 0))
            s = np.nan_to_num(dz / dist, nan=0.0)
            lo = [slice(None)] * 2
            hi = [slice(None)] * 2
            lo[axis] = slice(0, -1)
            hi[axis] = slice(1, None)
            slope[tuple(lo)] = np.maximum(slope[tuple(lo)], s)
            slope[tuple(hi)] = np.maximum(slope[tuple(hi)], s)
        return math.sqrt(2.0) * slope

    def max_grid(
        self,
        x_m: tuple[float, float],
        y_m: tuple[float, float],
        cell_m: float,
        *,
        lipschitz_pad: bool = True,
    ) -> TerrainMaxGrid:
        """Conservative ground maxima over ``cell_m`` squares covering the ENU rectangle (see
        the module docstring for the bound). Raises if the DEM does not cover the rectangle."""
        if not (math.isfinite(cell_m) and cell_m > 0):
            raise ValueError(f"cell_m must be > 0, got {cell_m!r}")
        self.check_covers((x_m, y_m))
        nx = max(1, math.ceil((x_m[1] - x_m[0]) / cell_m))
        ny = max(1, math.ceil((y_m[1] - y_m[0]) / cell_m))
        grid = np.full((ny, nx), -np.inf)
        spacing = self.post_spacing_m
        reach = math.sqrt(2.0) * spacing  # all quad corners of any point in a cell
        half_diagonal = reach / 2.0
        z = self.posts_amsl_m
        value = z + (self.post_slopes() * half_diagonal if lipschitz_pad else 0.0)
        xy = self._posts_enu.reshape(-1, 2)
        value = value.ravel()
        ok = np.isfinite(value)
        xy, value = xy[ok], value[ok]
        ix_lo = np.floor((xy[:, 0] - reach - x_m[0]) / cell_m).astype(np.int64)
        ix_hi = np.floor((xy[:, 0] + reach - x_m[0]) / cell_m).astype(np.int64)
        iy_lo = np.floor((xy[:, 1] - reach - y_m[0]) / cell_m).astype(np.int64)
        iy_hi = np.floor((xy[:, 1] + reach - y_m[0]) / cell_m).astype(np.int64)
        k = int(math.ceil(2.0 * reach / cell_m)) + 1
        for di in range(k):
            ix = ix_lo + di
            okx = (ix <= ix_hi) & (ix >= 0) & (ix < nx)
            for dj in range(k):
                iy = iy_lo + dj
                sel = okx & (iy <= iy_hi) & (iy >= 0) & (iy < ny)
                np.maximum.at(grid, (iy[sel], ix[sel]), value[sel])
        if not np.all(np.isfinite(grid)):  # cannot happen once covered; keep the promise
            raise TerrainError("the DEM has no posts near part of the area", file=self.source)
        return TerrainMaxGrid(float(x_m[0]), float(y_m[0]), float(cell_m), grid)

    def posts_around(
        self, x_m: tuple[float, float], y_m: tuple[float, float], pad_m: float
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """The posts around the ENU rectangle ``x_m`` × ``y_m``: every post within ``pad_m`` +
        one post spacing of it (the DEM's own edge and nodata permitting: at least the posts
        of every quad the rectangle touches), as ``(xy (r, c, 2), z_amsl (r, c), centres
        (r − 1, c − 1, 2))``: their exact ENU positions in this frame, their heights, and the
        exact positions of the quads' centres. Raises :class:`TerrainError` where the DEM does
        not cover the rectangle. Computed once per rectangle and frame."""
        key = (tuple(x_m), tuple(y_m), float(pad_m))
        hit = self._posts_memo.get(key)
        if hit is None:
            hit = self._posts_around(x_m, y_m, pad_m)
            self._posts_memo[key] = hit
        return hit

    @cached_property
    def _posts_memo(self) -> dict[Any, tuple[Any, Any, Any]]:
        return {}

    def _posts_around(
        self, x_m: tuple[float, float], y_m: tuple[float, float], pad_m: float
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        self.check_covers((x_m, y_m))
        xy = self._posts_enu
        z = self.posts_amsl_m
        nrows, ncols = z.shape
        if nrows < 2 or ncols < 2:
            raise TerrainError("the DEM needs at least 2 x 2 posts here", file=self.source)

        def window(pad: float) -> tuple[int, int, int, int]:
            inside = (
                (xy[..., 0] >= x_m[0] - pad)
                & (xy[..., 0] <= x_m[1] + pad)
                & (xy[..., 1] >= y_m[0] - pad)
                & (xy[..., 1] <= y_m[1] + pad)
            )
            rows = np.flatnonzero(inside.any(axis=1))
            cols = np.flatnonzero(inside.any(axis=0))
            if not len(rows) or not len(cols):  # a rectangle inside one quad
                col, row = self._pixels(np.array([[sum(x_m) / 2.0, sum(y_m) / 2.0]]))
                r, c = int(np.floor(row[0] - 0.5)), int(np.floor(col[0] - 0.5))
                return max(r, 0), min(r + 1, nrows - 1), max(c, 0), min(c + 1, ncols - 1)
            r0, r1 = max(int(rows.min()) - 1, 0), min(int(rows.max()) + 1, nrows - 1)
            c0, c1 = max(int(cols.min()) - 1, 0), min(int(cols.max()) + 1, ncols - 1)
            return r0, r1, c0, c1

        r0, r1, c0, c1 = window(pad_m + self.post_spacing_m)
        if not np.all(np.isfinite(z[r0 : r1 + 1, c0 : c1 + 1])):
            r0, r1, c0, c1 = window(0.0)  # nodata in the margin around: the rectangle's own
        posts = z[r0 : r1 + 1, c0 : c1 + 1]
        if not np.all(np.isfinite(posts)) or posts.shape[0] < 2 or posts.shape[1] < 2:
            raise TerrainError("the DEM has nodata posts inside the area", file=self.source)
        cols, rows = np.meshgrid(np.arange(c0, c1) + 1.0, np.arange(r0, r1) + 1.0)
        x, y = _apply(self.transform, cols.ravel(), rows.ravel())
        lon, lat = transform_arrays(self._from_crs, x, y)
        centres = self.frame.to_enu_xy(np.asarray(lat), np.asarray(lon))
        return (
            np.ascontiguousarray(xy[r0 : r1 + 1, c0 : c1 + 1]),
            np.ascontiguousarray(posts),
            centres.reshape(r1 - r0, c1 - c0, 2),
        )


def _check_transform(transform: Any, file: str) -> None:
    """A geotransform that maps pixels to an area: a zero pixel size (or rows parallel to
    columns) has no inverse. Rotated, north-up and south-up rasters are all fine."""
    det = transform.a * transform.e - transform.b * transform.d
    if not (math.isfinite(det) and det != 0.0):
        raise TerrainError(
            "the DEM's pixel size is zero (its geotransform maps every pixel to one line)",
            file=file,
        )


def _pixel_window(transform: Any, box: tuple[float, float, float, float]) -> Any:
    """The window of whole pixels around a box (west, south, east, north) in the DEM's CRS,
    with two pixels to spare on each side, for a raster laid out in any direction (rasterio's
    ``from_bounds`` refuses a south-up raster)."""
    from rasterio.windows import Window

    west, south, east, north = box
    corners_x = np.array([west, east, east, west])
    corners_y = np.array([south, south, north, north])
    cols, rows = _apply(~transform, corners_x, corners_y)
    col_off, row_off = float(np.min(cols)), float(np.min(rows))
    # offsets rounded down and lengths up, as from_bounds(...).round_offsets("floor")
    # .round_lengths("ceil") gives them for a north-up raster
    width = math.ceil(float(np.max(cols)) - col_off)
    height = math.ceil(float(np.max(rows)) - row_off)
    return Window(math.floor(col_off) - 2, math.floor(row_off) - 2, width + 4, height + 4)


def _check_posts(posts: NDArray[np.float64], file: str) -> None:
    """At least 2 x 2 posts, and every height a plausible ground height (else the file holds
    an undeclared nodata value such as the float32 maximum, or is in other units)."""
    if posts.shape[0] < 2 or posts.shape[1] < 2:
        raise TerrainError(
            f"the DEM has {posts.shape[0]} x {posts.shape[1]} posts over the area; it needs at "
            "least 2 x 2 to interpolate between them",
            file=file,
        )
    known = posts[~np.isnan(posts)]  # NaN: nodata; ±inf is a height out of range
    wild = known[(known < MIN_GROUND_AMSL_M) | (known > MAX_GROUND_AMSL_M)]
    if len(wild):
        raise TerrainError(
            f"the DEM holds heights outside {MIN_GROUND_AMSL_M:g}..{MAX_GROUND_AMSL_M:g} m "
            f"AMSL ({len(wild):,} posts, e.g. {float(wild[0]):.6g}): a nodata value the file "
            "does not declare, or heights in other units",
            file=file,
        )
    if not len(known):
        raise TerrainError("the DEM has no data over the area (every post is nodata)", file=file)


def _apply(t: Any, u: NDArray[np.float64], v: NDArray[np.float64]) -> tuple[Any, Any]:
    """An affine transform applied to coordinate arrays."""
    return t.a * u + t.b * v + t.c, t.d * u + t.e * v + t.f


def _window_transform(t: Any, window: Any) -> Any:
    """The affine transform of ``window`` of a raster whose transform is ``t``: the same numbers
    as rasterio's ``window_transform`` (the window's corner, then a translation), computed from
    the coefficients, because rasterio's applies the transform with affine's ``*``, which
    affine deprecates (a PendingDeprecationWarning on every DEM read)."""
    col, row = window.col_off or 0.0, window.row_off or 0.0
    x = col * t.a + row * t.b + t.c
    y = col * t.d + row * t.e + t.f
    return type(t)(t.a, t.b, t.c + (x - t.c), t.d, t.e, t.f + (y - t.f))


def _area_in_crs(
    frame: EnuFrame, crs_wkt: str, area_xy_m: tuple[tuple[float, float], tuple[float, float]]
) -> tuple[float, float, float, float]:
    """(left, bottom, right, top) in the DEM CRS of an ENU rectangle (edges sampled)."""
    from pyproj import Transformer

    (x0, x1), (y0, y1) = area_xy_m
    t = np.linspace(0.0, 1.0, 33)
    xs = np.concatenate(
        [x0 + (x1 - x0) * t, np.full_like(t, x1), x1 - (x1 - x0) * t, np.full_like(t, x0)]
    )
    ys = np.concatenate(
        [np.full_like(t, y0), y0 + (y1 - y0) * t, np.full_like(t, y1), y1 - (y1 - y0) * t]
    )
    lat, lon, _ = frame.to_geodetic(np.column_stack((xs, ys, np.zeros_like(xs))))
    x, y = Transformer.from_crs("EPSG:4326", crs_wkt, always_xy=True).transform(lon, lat)
    x, y = np.asarray(x), np.asarray(y)
    return float(x.min()), float(y.min()), float(x.max()), float(y.max())
