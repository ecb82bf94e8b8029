"""How large a scenario's planning problem is, and the grid that fits it (docs/scenario-format.md,
"Limits").

The planner holds, for every leg (start → via points → goal), a lattice of nodes in the leg's
path frame: one column every ``dx`` along the leg, nodes every ``dy`` across and every ``dz``
up, over the flight volume (over a DEM from the datum to the highest ground plus the ceiling:
the volume the planner flies, :attr:`uavplan.scenario.Scenario.site`). Every node of the
leg's columns gets an exact clearance (8 bytes each), and a global grid search over the whole
volume (the guide search, the A* reference) holds 37 bytes a node at twice the steps
and more. :func:`path_grid` counts those nodes; :func:`fitted_grid` is the grid a scenario
that does not set ``planner.grid`` is planned on: the default steps, scaled up by the
smallest factor of :data:`FIT_FACTORS` that brings the count under :data:`FIT_GRID_CELLS`,
the vertical step by no more than keeps eight levels in the height the route may fly through
(over a DEM the ceiling's band above the ground: measured on the 20 × 20 km crossing of
tools/bench_scale.py, a 40 m step in the 150 m band cost 17 % more energy than 12.5-20 m).
So a short route keeps the default grid (every bundled scenario does), and a long route or a
large area gets a coarser one instead of being refused or running out of memory. A grid the
user sets is used as given and checked against the hard limits.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

from uavplan.config import GridSpec
from uavplan.obstacles import Bounds
from uavplan.scenario.limits import FIT_GRID_CELLS

#: the grid of a scenario that sets none, before it is fitted (config.py's defaults)
DEFAULT_GRID = GridSpec()
#: the scale factors a fitted grid's steps may take, smallest first: "round" multiples so
#: the steps stay readable (20 × 20 × 10 m, 25 × 25 × 12.5 m, 40 × 40 × 20 m, ...); at the
#: last one the default column spacing is 10 km, the largest a grid step may be
FIT_FACTORS = tuple(
    f
    for f in (m * 10**e for e in range(3) for m in (1, 1.25, 1.5, 2, 2.5, 3, 4, 5, 6, 8))
    if f * DEFAULT_GRID.dx_m <= 10_000
)

#: a fitted grid keeps at least this many vertical levels within the height the route may
#: fly through (dz at most a eighth of it, unless the default's 10 m is more)
MIN_BAND_LEVELS = 8

Point = tuple[float, float, float] | Sequence[float]


def path_grid(bounds: Bounds, points: Sequence[Point], grid: GridSpec) -> tuple[int, int, float]:
    """``(cells, columns, length_m)`` of planning a route through ``points`` (start, via
    points, goal; x, y used) in the flight volume ``bounds`` with ``grid``: ``cells`` is the
    largest over the legs of the path-frame lattice over the whole volume (columns along the
    leg × lateral × vertical nodes of the bounds' box in the leg's frame), ``columns`` the
    path columns of all legs together, ``length_m`` the legs' horizontal length."""
    (x0, x1), (y0, y1), (z0, z1) = bounds.x_m, bounds.y_m, bounds.z_m
    corners = [(x, y) for x in (x0, x1) for y in (y0, y1)]
    vertical = math.floor((z1 - z0) / grid.dz_m) + 1
    cells = columns = 0
    total = 0.0
    for a, b in itertools.pairwise(points):
        dx, dy = float(b[0]) - float(a[0]), float(b[1]) - float(a[1])
        length = math.hypot(dx, dy)
        c, s = (dx / length, dy / length) if length > 0 else (1.0, 0.0)
        along = [c * x + s * y for x, y in corners]
        across = [-s * x + c * y for x, y in corners]
        leg_cells = (
            (math.floor((max(along) - min(along)) / grid.dx_m) + 1)
            * (math.floor((max(across) - min(across)) / grid.dy_m) + 1)
            * vertical
        )
        cells = max(cells, leg_cells)
        columns += max(2, round(length / grid.dx_m))
        total += length
    return cells, columns, total


def scaled(grid: GridSpec, factor: float, vertical: float | None = None) -> GridSpec:
    """``grid`` with ``dx`` and ``dy`` multiplied by ``factor`` and ``dz`` by ``vertical``
    (default: ``factor`` too)."""
    v = factor if vertical is None else vertical
    return GridSpec(grid.dx_m * factor, grid.dy_m * factor, grid.dz_m * v)


def fitted_grid(
    volume: Bounds, points: Sequence[Point], band_m: float, budget: float = FIT_GRID_CELLS
) -> GridSpec:
    """The grid a scenario that sets none is planned on: :data:`DEFAULT_GRID` with ``dx``
    and ``dy`` scaled by the smallest of :data:`FIT_FACTORS` whose :func:`path_grid` cells
    over ``volume`` are at most ``budget`` (the default grid itself when it fits), and ``dz``
    by the same factor or less: at least :data:`MIN_BAND_LEVELS` levels stay within
    ``band_m``, the height the route may fly through (the bounds' z span, over a DEM above
    the ground), so a route that follows the ground or threads under a ceiling keeps its
    vertical resolution while a tall volume still coarsens."""
    keep = max(1.0, band_m / (MIN_BAND_LEVELS * DEFAULT_GRID.dz_m))
    for factor in FIT_FACTORS:
        vertical = max(f for f in FIT_FACTORS if f <= min(factor, keep))
        grid = scaled(DEFAULT_GRID, factor, vertical)
        if path_grid(volume, points, grid)[0] <= budget:
            return grid
    # a volume far taller than its band (a thin band over a DEM of a whole mountain range):
    # the vertical step must grow too
    for factor in FIT_FACTORS:
        grid = scaled(DEFAULT_GRID, factor)
        if path_grid(volume, points, grid)[0] <= budget:
            return grid
    return scaled(DEFAULT_GRID, FIT_FACTORS[-1])  # pragma: no cover - the limits exclude it
