"""The ground under a world over terrain, and the one place that builds it from a DEM.

A world over terrain is held in a vertical frame whose z is metres above a *datum* just
below the lowest ground of the DEM (:func:`datum_below`; the frame's origin altitude from
then on). :func:`build_ground` turns the DEM's surface into a :class:`HeightField`: the DEM's
posts at their exact positions in that frame with their heights, each quad cut into ``s × s``
sub-quads on the DEM's own bilinear surface. The compiled kernels measure exact distances
from points and segments to two triangulated surfaces over that lattice
(``uavplan/_csrc/heightfield.c``):

* the **ground**: each cell cut along the diagonal that puts its two triangles on or above
  the bilinear patch (for ``z = a + b·u + c·v + d·u·v`` on the unit square, the diagonal
  through (0, 0) and (1, 1) when the twist ``d ≥ 0``, else the other one: each triangle's
  plane then exceeds the patch by ``|d|·v·(1 − u)`` or ``|d|·u·(1 − v)``, never less than 0
  and never more than ``|d| / 4``). The route keeps the margin from the solid below it, so it
  keeps at least the margin from the DEM's bilinear surface, and a point refused is at most
  :attr:`HeightField.twist_gap_m` closer to the triangles than to that surface;
* the **ceiling**: the other diagonal (on or below the patch) raised by ``bounds.z`` max and
  the margin; the route keeps the margin from the solid above it, so it flies at most
  ``bounds.z`` max above the ground beneath.

``s`` is the smallest subdivision whose largest twist gives a gap of at most
:data:`TWIST_TOL_M` (a sub-quad of a bilinear patch is the bilinear patch of its corners, with
its twist divided by ``s²``), within :data:`MAX_FIELD_CELLS`. The margin and the flight
volume's floor are arguments, so a scenario copied with another margin gets another ground.
"""

from __future__ import annotations

import hashlib
import itertools
import math
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from uavplan.geo import EnuFrame
    from uavplan.obstacles import Bounds

#: the triangulated ground lies at most this far (m) above the DEM's bilinear surface (the
#: subdivision is chosen for it; fewer where that would exceed MAX_FIELD_CELLS)
TWIST_TOL_M = 0.25
#: the height field holds at most this many cells (about 32 bytes each)
MAX_FIELD_CELLS = 1_000_000
#: and cuts a DEM quad into at most this many sub-quads per side
MAX_SUBDIVISION = 12
#: lattice cells the field's construction computes together (its interpolation, slopes and
#: fit take some ten temporary arrays a cell: over a million cells, 240 MB at once)
BLOCK_CELLS = 32_768
#: the kernels' metadata vector's length (kernels.h FIELD_META)
FIELD_META = 16
#: the side, in cells, of the blocks whose highest and lowest corner the kernels hold
#: (kernels.h FIELD_BLOCK): a segment well clear of a block's corners skips its cells
FIELD_BLOCK = 8
#: a leg flown over the ground (a terrain-frame leg) is checked as the polyline through
#: samples of it: at every crossing of a row or column of DEM posts, where the ground's slope
#: jumps, and between them so close that the flown curve departs from the chords by at most
#: this (m)
FOLLOW_TOL_M = 0.001


class Surface(Protocol):
    """What the ground needs of a DEM (:class:`uavplan.sources.dem.Terrain` is one): heights
    AMSL at ENU points of its frame, its posts, and the posts around an area at their exact
    positions."""

    @property
    def source(self) -> str: ...

    @property
    def posts_amsl_m(self) -> Any: ...

    def height_m(self, points_xy: Any) -> Any: ...

    def height_at(self, x: float, y: float) -> float: ...

    def posts_around(
        self, x_m: tuple[float, float], y_m: tuple[float, float], pad_m: float
    ) -> tuple[Any, Any, Any]: ...

    def in_frame(self, frame: EnuFrame) -> Surface: ...


@dataclass(frozen=True, eq=False)
class HeightField:
    """The terrain as the kernels hold it: a lattice of points at their exact ``xy``
    ``(nr, nc, 2)`` in the site's frame with their ground ``z`` ``(nr, nc)`` (metres above
    the datum); the DEM's posts, each quad cut into ``subdivision²`` sub-quads on its bilinear
    surface.

    ``twist_gap_m``: how far the ground's triangles may lie above the bilinear surface (the
    largest cell twist / 4); ``warp_m``: how far a point of a DEM quad may lie from where the
    lattice puts it (the bilinear interpolation of the corners' positions, measured at every
    quad's centre) times the steepest slope, by which the ground is raised and the ceiling
    lowered. ``lattice`` ``(6,)``: the affine map from the frame to lattice coordinates
    (column = l0 + l1·x + l2·y, row = l3 + l4·x + l5·y) fitted to the points; ``slack``: how
    far (lattice units, per axis) a point lies from where that map puts it; ``per_m``: lattice
    units per metre at most. ``slope`` ``(nr − 1, nc − 1)``: the steepest slope of each cell's
    triangles (either diagonal); the kernels read a cell's highest and lowest corner from
    ``z``."""

    xy: NDArray[Any]
    z: NDArray[Any]
    subdivision: int
    twist_gap_m: float
    warp_m: float
    lattice: NDArray[Any]
    slack: float
    per_m: float
    slope: NDArray[Any]

    @classmethod
    def from_posts(
        cls,
        xy: NDArray[Any],
        z: NDArray[Any],
        centres_xy: NDArray[Any],
        *,
        tol_m: float = TWIST_TOL_M,
        max_cells: int = MAX_FIELD_CELLS,
    ) -> HeightField:
        """The field of DEM posts at ``xy`` ``(r, c, 2)`` with heights ``z`` ``(r, c)``;
        ``centres_xy`` ``(r − 1, c − 1, 2)``: the exact positions of the quads' centres (where
        the DEM's grid maps to the frame least like a bilinear interpolation of the corners)."""
        import numpy as np

        xy = np.asarray(xy, dtype=np.float64)
        z = np.asarray(z, dtype=np.float64)
        rows, cols = z.shape
        twist = np.abs(z[:-1, :-1] + z[1:, 1:] - z[:-1, 1:] - z[1:, :-1])
        worst = float(twist.max()) if twist.size else 0.0
        s = max(1, math.ceil(math.sqrt(worst / (4.0 * tol_m)) - 1e-9)) if worst > 0 else 1
        budget = max(1, int(math.sqrt(max_cells / max((rows - 1) * (cols - 1), 1))))
        s = max(1, min(s, MAX_SUBDIVISION, budget))
        rr = np.arange((rows - 1) * s + 1) / s
        cc = np.arange((cols - 1) * s + 1) / s
        fz = _bilinear_grid(z, rr, cc)
        fxy = np.stack([_bilinear_grid(xy[..., k], rr, cc) for k in (0, 1)], axis=-1)
        # how far the quads' centres lie from the bilinear interpolation of their corners
        mid = 0.25 * (xy[:-1, :-1] + xy[:-1, 1:] + xy[1:, :-1] + xy[1:, 1:])
        off = float(np.max(np.hypot(*np.moveaxis(centres_xy - mid, -1, 0)))) if mid.size else 0.0
        warp = off * _steepest(fxy, fz)
        lattice, slack, per_m = _fit_lattice(fxy)
        # each cell's steepest triangle (its highest and lowest corner are not held: the
        # kernels take them from z, 16 bytes a cell less)
        slope = _cell_slopes(fxy, fz)
        return cls(
            xy=np.ascontiguousarray(fxy),
            z=np.ascontiguousarray(fz),
            subdivision=s,
            twist_gap_m=worst / (4.0 * s * s),
            warp_m=warp,
            lattice=lattice,
            slack=slack,
            per_m=per_m,
            slope=np.ascontiguousarray(slope),
        )

    @property
    def shape(self) -> tuple[int, int]:
        return (int(self.z.shape[0]), int(self.z.shape[1]))

    @cached_property
    def blocks(self) -> NDArray[Any]:
        """``(nbr, nbc, 2)``: the highest and the lowest ``z`` of the corners of each block of
        :data:`FIELD_BLOCK` × :data:`FIELD_BLOCK` cells (the last ones cut short), for the
        kernels' walk along a segment to skip a block its cells could not come near."""
        import numpy as np

        z = self.z
        nr, nc = z.shape
        b = FIELD_BLOCK
        nbr, nbc = max(0, -(-(nr - 1) // b)), max(0, -(-(nc - 1) // b))
        out = np.empty((nbr, nbc, 2))
        if nbr == 0 or nbc == 0:
            return out
        starts = np.arange(nbc) * b
        last = np.minimum(starts + b, nc - 1)
        for bi in range(nbr):
            # the corners of block (bi, bj): rows bi*b .. bi*b + b, columns bj*b .. bj*b + b
            rows = z[bi * b : bi * b + b + 1]
            top, bottom = rows.max(axis=0), rows.min(axis=0)
            out[bi, :, 0] = np.maximum(np.maximum.reduceat(top[: nc - 1], starts), top[last])
            out[bi, :, 1] = np.minimum(np.minimum.reduceat(bottom[: nc - 1], starts), bottom[last])
        return out

    @property
    def zmax(self) -> float:
        return float(self.z.max())

    @property
    def zmin(self) -> float:
        return float(self.z.min())

    def kinks(self, a_xy: Any, b_xy: Any) -> NDArray[Any]:
        """The parameters t in (0, 1), sorted, where the horizontal segment a → b crosses a
        row or a column of the DEM's posts (every ``subdivision``-th lattice line): the lines
        along which the bilinear surface's slope jumps. Exact (the segment against each
        post-to-post edge)."""
        import numpy as np

        a = np.asarray(a_xy, dtype=np.float64)[:2]
        b = np.asarray(b_xy, dtype=np.float64)[:2]
        s = self.subdivision
        nr, nc = self.shape
        lat = self.lattice
        ua, ub = (lat[0] + lat[1] * p[0] + lat[2] * p[1] for p in (a, b))
        va, vb = (lat[3] + lat[4] * p[0] + lat[5] * p[1] for p in (a, b))
        r = self.slack + 1.0
        starts, ends = [], []
        for lines_of, lo, hi, n_lines, n_along, (o_lo, o_hi) in (
            ("col", min(ua, ub), max(ua, ub), nc, nr, (min(va, vb), max(va, vb))),
            ("row", min(va, vb), max(va, vb), nr, nc, (min(ua, ub), max(ua, ub))),
        ):
            k0 = max(0, math.ceil((lo - r) / s))
            k1 = min((n_lines - 1) // s, math.floor((hi + r) / s))
            i0 = max(0, math.floor(o_lo - r))
            i1 = min(n_along - 1, math.ceil(o_hi + r))
            if k1 < k0 or i1 <= i0:
                continue
            idx = np.arange(k0, k1 + 1) * s
            if lines_of == "col":
                pts = self.xy[i0 : i1 + 1][:, idx]  # (along, lines, 2)
            else:
                pts = self.xy[idx][:, i0 : i1 + 1].transpose(1, 0, 2)
            starts.append(pts[:-1].reshape(-1, 2))
            ends.append(pts[1:].reshape(-1, 2))
        if not starts:
            return np.empty(0)
        p0, p1 = np.concatenate(starts), np.concatenate(ends)
        d, e = b - a, p1 - p0
        den = d[0] * e[:, 1] - d[1] * e[:, 0]
        w = p0 - a
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]) / den
            q = (w[:, 0] * d[1] - w[:, 1] * d[0]) / den
        hit = (den != 0) & (t > 0.0) & (t < 1.0) & (q >= 0.0) & (q <= 1.0)
        return np.unique(t[hit])

    def follow_step_m(self, tol_m: float = FOLLOW_TOL_M) -> float:
        """How far apart (m) samples of a leg over the ground may lie, between two crossings
        of post lines, for the flown curve to stay within ``tol_m`` of the chords: along a
        line the bilinear surface of a cell is a parabola of second derivative at most
        2·|twist|·per_m² (twist in lattice units), whose chord over a length h departs from
        it by at most that · h² / 8."""
        curvature = 2.0 * 4.0 * self.twist_gap_m * self.per_m**2
        return math.inf if curvature <= 0.0 else math.sqrt(8.0 * tol_m / curvature)

    def kernel_meta(
        self,
        *,
        origin_xy: tuple[float, float],
        cos_sin: tuple[float, float],
        lift: float,
        roof: float,
    ) -> NDArray[Any]:
        """The kernels' metadata vector (kernels.h ``Field``): the map from a world's frame to
        the field's (``X = ox + c·x − s·y``, ``Y = oy + s·x + c·y``), the lattice map, its
        slack and scale, the ground's ``lift`` and the ceiling's ``roof`` (inf: none, both
        already padded by :attr:`warp_m`), the highest and lowest point."""
        import numpy as np

        c, s = cos_sin
        return np.array(
            [origin_xy[0], origin_xy[1], c, s, *self.lattice, self.slack, self.per_m, lift,
             roof, self.zmax, self.zmin],
            dtype=np.float64,
        )  # fmt: skip

    def surface_z(self, points_xy: Any, *, upper: bool = True) -> NDArray[Any]:
        """The triangulated surface's z over ENU points ``(n, 2)`` of the field's frame:
        the ground's (``upper``, on or above the DEM's bilinear surface) or the ceiling's
        (below it); NaN outside the field. numpy: the kernels do the same in C."""
        import numpy as np

        p = np.atleast_2d(np.asarray(points_xy, dtype=np.float64))[:, :2]
        out = np.full(len(p), np.nan)
        idx, tri = self._candidates(p, upper=upper)
        h, inside = _plane_height(tri, p[idx])
        out[idx[inside]] = h[inside]
        return out

    def distance(
        self, points: Any, *, lift: float, roof: float, reach: float
    ) -> tuple[NDArray[Any], NDArray[Any], NDArray[Any]]:
        """Exact distances from points ``(n, 3)`` to the ground's solid (below the upper
        surface + ``lift``) and the ceiling's (above the lower surface + ``roof``), looked for
        within ``reach``: (distance (inf when farther), 0 ground / 1 ceiling / −1 neither,
        the closest surface point (n, 2)). numpy, for a few points (the scenario's checks)."""
        import numpy as np

        p = np.atleast_2d(np.asarray(points, dtype=np.float64))
        n = len(p)
        dist = np.full(n, np.inf)
        kind = np.full(n, -1, dtype=np.int64)
        where = np.full((n, 2), np.nan)
        for k, (upper, sign, off) in enumerate(((True, 1.0, lift), (False, -1.0, roof))):
            if not math.isfinite(off):
                continue
            under = self.surface_z(p[:, :2], upper=upper) + off
            inside = sign * (p[:, 2] - under) < 0.0
            hit = inside & (dist > 0.0)
            dist[hit], kind[hit], where[hit] = 0.0, k, p[hit, :2]
            for idx in np.flatnonzero(~inside):
                d, q = self._nearest(p[idx], upper=upper, off=off, reach=reach)
                if d < dist[idx]:
                    dist[idx], kind[idx], where[idx] = d, k, q
        return dist, kind, where

    # -- numpy geometry (the scenario's checks; tests hold the kernels to it) ----------------
    def _cell_triangles(self, i: Any, j: Any, *, upper: bool) -> Any:
        """Triangles ``(m, 2, 3, 3)`` of cells (i, j) (each ``(m,)``), as the kernels cut
        them (the ceiling: the lower diagonal)."""
        import numpy as np

        def corner(di: int, dj: int) -> Any:
            return np.concatenate(
                [self.xy[i + di, j + dj], self.z[i + di, j + dj][:, None]], axis=1
            )

        p00, p01, p10, p11 = corner(0, 0), corner(0, 1), corner(1, 0), corner(1, 1)
        twist = p00[:, 2] + p11[:, 2] - p01[:, 2] - p10[:, 2]
        main = (twist >= 0.0) if upper else (twist <= 0.0)
        t_main = np.stack([np.stack([p00, p01, p11], 1), np.stack([p00, p11, p10], 1)], 1)
        t_other = np.stack([np.stack([p00, p01, p10], 1), np.stack([p01, p11, p10], 1)], 1)
        return np.where(main[:, None, None, None], t_main, t_other)

    def _candidates(self, p: Any, *, upper: bool, reach: float = 0.0) -> Any:
        """(point index (m,), triangle (m, 3, 3)) for both triangles of every cell within
        ``reach`` of each point (its lattice neighbourhood grown by the slack)."""
        import numpy as np

        nr, nc = self.shape
        u = self.lattice[0] + self.lattice[1] * p[:, 0] + self.lattice[2] * p[:, 1]
        v = self.lattice[3] + self.lattice[4] * p[:, 0] + self.lattice[5] * p[:, 1]
        r = reach * self.per_m + self.slack + 1e-9
        near = (u + r >= 0) & (u - r <= nc - 1) & (v + r >= 0) & (v - r <= nr - 1)
        j0 = np.clip(np.floor(u - r), 0, nc - 2).astype(np.int64)
        j1 = np.clip(np.floor(u + r), 0, nc - 2).astype(np.int64)
        i0 = np.clip(np.floor(v - r), 0, nr - 2).astype(np.int64)
        i1 = np.clip(np.floor(v + r), 0, nr - 2).astype(np.int64)
        which, ii, jj = [], [], []
        for k in np.flatnonzero(near):
            gi, gj = np.meshgrid(np.arange(i0[k], i1[k] + 1), np.arange(j0[k], j1[k] + 1))
            which.append(np.full(gi.size, k))
            ii.append(gi.ravel())
            jj.append(gj.ravel())
        if not which:
            return np.empty(0, dtype=np.int64), np.empty((0, 3, 3))
        idx, ci, cj = np.concatenate(which), np.concatenate(ii), np.concatenate(jj)
        tris = self._cell_triangles(ci, cj, upper=upper)
        return np.concatenate([idx, idx]), np.concatenate([tris[:, 0], tris[:, 1]])

    def _nearest(self, point: Any, *, upper: bool, off: float, reach: float) -> tuple[float, Any]:
        """Distance from one point (outside the solid) to the triangles of one surface
        (raised by ``off``) within ``reach``, and the closest point's (x, y)."""
        import numpy as np

        _, tri = self._candidates(point[None, :2], upper=upper, reach=reach)
        if not len(tri):
            return math.inf, np.array([np.nan, np.nan])
        tri = tri.copy()
        tri[..., 2] += off
        c = _closest_on_triangles(point[None, :], tri)
        d = np.linalg.norm(c - point[None, :], axis=1)
        k = int(np.argmin(d))
        return float(d[k]), c[k, :2]


@dataclass(frozen=True, eq=False)
class Ground:
    """Terrain under a world whose z is metres above ``datum_amsl_m`` (not above the ground).

    ``field``: the DEM as a :class:`HeightField` (the kernels' ground and ceiling);
    ``height_fn`` maps ENU ``(n, 2)`` points to the ground's z in this frame (the DEM's
    bilinear surface): for heights above the ground, home altitudes and independent checks;
    ``point_fn`` the same for one point ``(x, y)``, without numpy's per-call cost.
    ``ceiling_agl_m``: the highest a route may fly above the ground beneath it (the bounds' z
    maximum), ``floor_agl_m`` the lowest (the bounds' z minimum; the margin holds in any case),
    ``margin_m`` the margin the solids are built for.
    """

    datum_amsl_m: float
    field: HeightField
    height_fn: Callable[[Any], Any]
    point_fn: Callable[[float, float], float]
    ceiling_agl_m: float
    margin_m: float
    floor_agl_m: float = 0.0
    source: str = ""

    @property
    def lift_m(self) -> float:
        """How far the ground's solid stands above the triangulated surface: the floor above
        the margin, if higher, and the :attr:`HeightField.warp_m` pad."""
        return max(0.0, self.floor_agl_m - self.margin_m) + self.field.warp_m

    @property
    def roof_m(self) -> float:
        """Where the ceiling's solid starts above the lower triangulated surface: the ceiling
        and the margin, less the :attr:`HeightField.warp_m` pad."""
        return self.ceiling_agl_m + self.margin_m - self.field.warp_m

    @property
    def top_m(self) -> float:
        """The highest z a route can reach: the highest ground plus the ceiling."""
        return self.field.zmax + self.ceiling_agl_m

    def z_at(self, points_xy: Any) -> Any:
        """Ground z (metres above the datum) at ENU points ``(n, 2)`` (or ``(n, 3)``): the
        DEM's bilinear surface."""
        import numpy as np

        p = np.atleast_2d(np.asarray(points_xy, dtype=np.float64))[:, :2]
        return np.asarray(self.height_fn(p), dtype=np.float64)

    def z_at_point(self, x: float, y: float) -> float:
        """Ground z at one ENU point: :meth:`z_at` for one point, without numpy's per-call
        cost (a simulated flight asks one point per step)."""
        return float(self.point_fn(x, y))

    def kernel_meta(self, origin_xy: tuple[float, float], cos_sin: tuple[float, float]) -> Any:
        """The field's metadata for the kernels, seen from a world frame (see
        :meth:`HeightField.kernel_meta`)."""
        return self.field.kernel_meta(
            origin_xy=origin_xy, cos_sin=cos_sin, lift=self.lift_m, roof=self.roof_m
        )

    def follow(self, a: Any, b: Any) -> Any:
        """The leg a → b as ArduPilot flies it into a terrain-frame waypoint: the track
        straight over the ground, the height above the ground going linearly along it from
        a's to b's (AC_WPNav turns the leg's origin into an altitude above terrain), over the
        DEM's bilinear surface. Points ``(k, 3)`` after a, b last: at every crossing of a
        post row or column and between them :meth:`HeightField.follow_step_m` apart, so the
        flown curve departs from the polyline by at most :data:`FOLLOW_TOL_M`."""
        import numpy as np

        a = np.asarray(a, dtype=np.float64)
        b = np.asarray(b, dtype=np.float64)
        run = float(np.hypot(*(b[:2] - a[:2])))
        if run < 1e-9:
            return b[None, :].copy()
        knots = np.concatenate([[0.0], self.field.kinks(a, b), [1.0]])
        step = self.field.follow_step_m() / run
        pieces = [np.array([0.0])]
        for t0, t1 in itertools.pairwise(knots):
            n = max(1, math.ceil((t1 - t0) / step - 1e-9)) if math.isfinite(step) else 1
            pieces.append(t0 + (t1 - t0) * np.arange(1, n + 1) / n)
        t = np.concatenate(pieces)
        xy = a[:2] + t[:, None] * (b[:2] - a[:2])
        g = self.z_at(xy)
        agl = (a[2] - g[0]) + t * ((b[2] - g[-1]) - (a[2] - g[0]))
        out = np.column_stack([xy, g + agl])[1:]
        out[-1] = b  # the waypoint itself, to the last bit
        return out

    def clearance(self, points: Any) -> tuple[Any, Any, Any]:
        """Exact distances from ENU points ``(n, 3)`` to the ground's and the ceiling's
        solids (see :meth:`HeightField.distance`); a point within ``reach`` of neither gets
        inf."""
        return self.field.distance(
            points, lift=self.lift_m, roof=self.roof_m, reach=2.0 * self.margin_m + 1.0
        )


def datum_below(surface: Surface) -> float:
    """The datum of a world over ``surface``: a whole metre at least 1 m below its lowest
    post (metres AMSL)."""
    import numpy as np

    return math.floor(float(np.nanmin(surface.posts_amsl_m))) - 1.0


def build_ground(
    on_datum: Surface, *, datum_amsl_m: float, bounds: Bounds, margin_m: float
) -> Ground:
    """The ground of ``on_datum`` (the DEM in the frame whose z is metres above
    ``datum_amsl_m``) over ``bounds`` (x, y; z above the ground: floor and ceiling), for a
    world keeping ``margin_m``: the posts within the bounds and the margin around them (fewer
    where the DEM stops) as a :class:`HeightField`. Raises the surface's own error (a
    :class:`~uavplan.sources.dem.TerrainError`) where the DEM does not cover the bounds."""
    xy, z_amsl, centres = on_datum.posts_around(bounds.x_m, bounds.y_m, margin_m)
    datum = datum_amsl_m
    field = _field_of(xy, z_amsl - datum, centres)

    def ground_z(points_xy: Any) -> Any:
        return on_datum.height_m(points_xy) - datum

    def ground_z_at(x: float, y: float) -> float:
        return on_datum.height_at(x, y) - datum

    return Ground(
        datum_amsl_m=datum,
        field=field,
        height_fn=ground_z,
        point_fn=ground_z_at,
        ceiling_agl_m=bounds.z_m[1],
        margin_m=margin_m,
        floor_agl_m=bounds.z_m[0],
        source=str(on_datum.source),
    )


#: the height fields alive, by a digest of the posts they were built from: a copy of a
#: scenario with another margin or ceiling (``plan`` plans again with a wider margin while
#: the first scenario is still held) gets the same field when its posts are the same, instead
#: of a second one (some 45 MB for a 20 km × 20 km area) built beside it
_FIELDS: weakref.WeakValueDictionary[bytes, HeightField] = weakref.WeakValueDictionary()


def _field_of(xy: Any, z: Any, centres: Any) -> HeightField:
    """:meth:`HeightField.from_posts` of these posts, shared with a field of the very same
    posts still alive (the field is a pure function of them)."""
    import numpy as np

    digest = hashlib.blake2b(digest_size=32)
    for a in (xy, z, centres):
        a = np.ascontiguousarray(a, dtype=np.float64)
        digest.update(repr(a.shape).encode())
        digest.update(a.data)
    key = digest.digest()
    field = _FIELDS.get(key)
    if field is None:
        field = HeightField.from_posts(xy, z, centres)
        _FIELDS[key] = field
    return field


# ---------------------------------------------------------------------------------------------
# numpy helpers


def _bilinear_grid(values: Any, rows: Any, cols: Any) -> Any:
    """``values`` interpolated bilinearly at fractional row / column indices → a grid
    ``(len(rows), len(cols))``."""
    import numpy as np

    nrows, ncols = values.shape
    i0 = np.clip(np.floor(rows).astype(np.int64), 0, nrows - 2)
    j0 = np.clip(np.floor(cols).astype(np.int64), 0, ncols - 2)
    tu = (cols - j0)[None, :]
    out = np.empty((len(rows), len(cols)))
    step = max(1, BLOCK_CELLS // max(len(cols), 1))  # a block of rows at a time
    for r0 in range(0, len(rows), step):
        i = i0[r0 : r0 + step, None]
        tv = (rows[r0 : r0 + step] - i0[r0 : r0 + step])[:, None]
        a = values[i, j0[None, :]]
        b = values[i, j0[None, :] + 1]
        c = values[i + 1, j0[None, :]]
        d = values[i + 1, j0[None, :] + 1]
        out[r0 : r0 + step] = (
            a * (1 - tu) * (1 - tv) + b * tu * (1 - tv) + c * (1 - tu) * tv + d * tu * tv
        )
    return out


def _steepest(xy: Any, z: Any) -> float:
    """A bound on the slope of the bilinear surface over the lattice: √2 × the steepest
    slope between neighbouring points (a bilinear patch's gradient has its two components
    between the slopes of its opposite edges)."""
    import numpy as np

    steep = 0.0
    step = max(2, BLOCK_CELLS // max(z.shape[1], 1))  # a block of rows at a time
    for r0 in range(0, max(z.shape[0] - 1, 1), step - 1):
        bxy, bz = xy[r0 : r0 + step], z[r0 : r0 + step]  # rows r0 .. r0 + step - 1
        for axis in (0, 1):
            if bz.shape[axis] > 1:
                run = np.hypot(*np.moveaxis(np.diff(bxy, axis=axis), -1, 0))
                steep = max(steep, float(np.max(np.abs(np.diff(bz, axis=axis)) / run)))
    return math.sqrt(2.0) * steep


def _cell_slopes(xy: Any, z: Any) -> Any:
    """The steepest slope of the four triangles of each cell (both diagonals), computed a
    block of rows at a time (the same arithmetic, cell by cell)."""
    import numpy as np

    rows, cols = z.shape[0] - 1, z.shape[1] - 1
    steep = np.zeros((rows, cols))
    step = max(1, BLOCK_CELLS // max(cols, 1))
    for r0 in range(0, rows, step):
        r1 = min(rows, r0 + step)
        p = np.concatenate([xy[r0 : r1 + 1], z[r0 : r1 + 1, :, None]], axis=-1)
        p00, p01, p10, p11 = p[:-1, :-1], p[:-1, 1:], p[1:, :-1], p[1:, 1:]
        out = steep[r0:r1]
        for a, b, c in ((p00, p01, p11), (p00, p11, p10), (p00, p01, p10), (p01, p11, p10)):
            n = np.cross(b - a, c - a)
            with np.errstate(divide="ignore", invalid="ignore"):
                g = np.hypot(n[..., 0], n[..., 1]) / np.abs(n[..., 2])
            np.fmax(out, g, out=out)
    return steep


def _fit_lattice(xy: Any) -> tuple[Any, float, float]:
    """The affine map from the frame to lattice (column, row) coordinates fitted to the
    lattice points ``xy`` ``(nr, nc, 2)``, the largest per-axis distance of a point from where
    it maps, and the map's largest singular value (lattice units per metre). The distances
    are measured a block of rows at a time (a million points at once held 100 MB)."""
    import numpy as np

    nr, nc = xy.shape[:2]
    # centred for a well-conditioned fit; a lattice of millions of points is subsampled
    step = max(1, math.ceil(math.sqrt(nr * nc / 250_000)))
    sub = np.zeros((nr, nc), dtype=bool)
    sub[::step, ::step] = True
    sub[-1, :] = sub[:, -1] = True
    rows, cols = np.nonzero(sub)  # row-major, as the lattice's ravel
    a = np.column_stack([np.ones(rows.size), xy[rows, cols, 0], xy[rows, cols, 1]])
    target = np.column_stack([cols.astype(np.float64), rows.astype(np.float64)])
    coef, *_ = np.linalg.lstsq(a, target, rcond=None)
    lattice = np.array([coef[0, 0], coef[1, 0], coef[2, 0], coef[0, 1], coef[1, 1], coef[2, 1]])
    slack = 0.0
    block = max(1, BLOCK_CELLS // max(nc, 1))
    col_index = np.arange(nc, dtype=np.float64)
    for r0 in range(0, nr, block):
        part = xy[r0 : r0 + block]
        n = part.shape[0] * nc
        a = np.column_stack([np.ones(n), part[..., 0].ravel(), part[..., 1].ravel()])
        mapped = a @ coef
        row_index = np.repeat(np.arange(r0, r0 + part.shape[0], dtype=np.float64), nc)
        err = np.maximum(
            np.abs(mapped[:, 0] - np.tile(col_index, part.shape[0])),
            np.abs(mapped[:, 1] - row_index),
        )
        slack = max(slack, float(err.max()))
    per_m = float(np.linalg.svd(coef[1:, :].T, compute_uv=False)[0])
    return lattice, slack, per_m


def _plane_height(tri: Any, p: Any) -> tuple[Any, Any]:
    """z of each triangle ``(m, 3, 3)``'s plane over points ``(m, 2)``, and whether the point
    lies in its outline (the kernels' tolerance)."""
    import numpy as np

    x0, y0 = tri[:, 0, 0], tri[:, 0, 1]
    ex1, ey1 = tri[:, 1, 0] - x0, tri[:, 1, 1] - y0
    ex2, ey2 = tri[:, 2, 0] - x0, tri[:, 2, 1] - y0
    det = ex1 * ey2 - ex2 * ey1
    with np.errstate(divide="ignore", invalid="ignore"):
        l1 = ((p[:, 0] - x0) * ey2 - ex2 * (p[:, 1] - y0)) / det
        l2 = (ex1 * (p[:, 1] - y0) - (p[:, 0] - x0) * ey1) / det
    l0 = 1.0 - l1 - l2
    inside = (det != 0) & (l0 >= -1e-9) & (l1 >= -1e-9) & (l2 >= -1e-9)
    return l0 * tri[:, 0, 2] + l1 * tri[:, 1, 2] + l2 * tri[:, 2, 2], inside


def _closest_on_triangles(p: Any, tri: Any) -> Any:
    """The closest point of each triangle ``(m, 3, 3)`` to ``p`` ``(1, 3)`` (or ``(m, 3)``):
    the projection onto the plane when it falls inside, else the closest point of the three
    edges."""
    import numpy as np

    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = np.cross(b - a, c - a)
    nn = np.einsum("ij,ij->i", n, n)
    proj = p - (np.einsum("ij,ij->i", p - a, n) / nn)[:, None] * n
    inside = np.ones(len(tri), dtype=bool)
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("ij,ij->i", np.cross(v - u, proj - u), n) >= 0.0
    best = proj.copy()
    best_d = np.where(inside, np.einsum("ij,ij->i", proj - p, proj - p), np.inf)
    for u, v in ((a, b), (b, c), (c, a)):
        e = v - u
        t = np.clip(np.einsum("ij,ij->i", p - u, e) / np.einsum("ij,ij->i", e, e), 0.0, 1.0)
        q = u + t[:, None] * e
        d = np.einsum("ij,ij->i", q - p, q - p)
        take = (d < best_d) & ~inside
        best[take], best_d[take] = q[take], d[take]
    return best
