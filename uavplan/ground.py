"""The ground under a world over terrain, and the one place that builds it from a DEM.

A world over terrain is held in a vertical frame whose z is metres above a *datum* just
below the lowest ground of the DEM (:func:`datum_below`; the frame's origin altitude from
then on). :func:`build_ground` turns the DEM's surface into what the world holds: convex
solids that contain the ground (each DEM cell up to its highest post, raised to the flight
volume's floor where that is above the margin) and, over the same outlines, ceiling solids
that keep the route at most the ceiling above the ground. The margin is an argument, so a
scenario copied with another margin gets other solids: nothing is baked into the scenario.

This representation is conservative (a cell is as high as its highest post); issue 26 will
replace it by an exact height field behind the same call.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    from uavplan.geo import EnuFrame
    from uavplan.obstacles import Bounds

#: the terrain is held as solids about this wide (m; fewer where that would exceed 40,000)
TERRAIN_CELL_M = 20.0


class Surface(Protocol):
    """What the ground needs of a DEM (:class:`uavplan.sources.dem.Terrain` is one): heights
    AMSL at ENU points of its frame, its posts, and solids containing its surface."""

    @property
    def source(self) -> str: ...

    @property
    def posts_amsl_m(self) -> Any: ...

    def height_m(self, points_xy: Any) -> Any: ...

    def quad_prisms(
        self, x_m: tuple[float, float], y_m: tuple[float, float], *, cell_m: float | None = ...
    ) -> tuple[Any, Any, Any]: ...

    def in_frame(self, frame: EnuFrame) -> Surface: ...


@dataclass(frozen=True, eq=False)
class Ground:
    """Terrain under a world whose z is metres above ``datum_amsl_m`` (not above the ground).

    ``prisms_xy`` ``(n, 4, 2)`` (convex, counter-clockwise) and ``tops_m`` ``(n,)``: solids
    reaching from below the ground up to ``tops_m`` that together contain the ground surface
    (the world keeps its margin from them as from any obstacle). ``height_fn`` maps ENU
    ``(n, 2)`` points to the ground's z in this frame (the DEM's bilinear surface): for
    heights above the ground, home altitudes and independent checks. ``ceiling_agl_m``: the
    highest a route may fly above the ground beneath it (the bounds' z maximum).
    """

    datum_amsl_m: float
    prisms_xy: Any
    tops_m: Any
    height_fn: Callable[[Any], Any]
    ceiling_agl_m: float
    source: str = ""
    #: bottoms ``(n,)`` of ceiling solids over the same outlines (reaching up forever): the
    #: lowest ground under each outline + ``ceiling_agl_m`` + the margin, so a route keeping
    #: the margin from them stays at most ``ceiling_agl_m`` above the ground; None: no ceiling
    ceilings_m: Any = None

    def z_at(self, points_xy: Any) -> Any:
        """Ground z (metres above the datum) at ENU points ``(n, 2)`` (or ``(n, 3)``)."""
        import numpy as np

        p = np.atleast_2d(np.asarray(points_xy, dtype=np.float64))[:, :2]
        return np.asarray(self.height_fn(p), dtype=np.float64)

    def piece_centre(self, index: int) -> tuple[float, float]:
        """The centre (x, y) of ground solid ``index`` (of :attr:`prisms_xy`; a ceiling
        solid has the index of its outline), for messages."""
        xy = self.prisms_xy[index % len(self.prisms_xy)]
        return float(xy[:, 0].mean()), float(xy[:, 1].mean())


def datum_below(surface: Surface) -> float:
    """The datum of a world over ``surface``: a whole metre at least 1 m below its lowest
    post (metres AMSL)."""
    import numpy as np

    return math.floor(float(np.nanmin(surface.posts_amsl_m))) - 1.0


def build_ground(
    surface: Surface, on_datum: Surface, *, datum_amsl_m: float, bounds: Bounds, margin_m: float
) -> Ground:
    """The ground pieces of ``surface`` over ``bounds`` (x, y; z above the ground: floor and
    ceiling), for a world keeping ``margin_m``, in the frame whose z is metres above
    ``datum_amsl_m``; ``on_datum`` is the surface in that frame (its heights become
    :attr:`Ground.height_fn`). The solids come from ``surface`` in its own frame (the file's
    origin), as they always have: the two frames differ by the origin's height, a relative
    scale of about 1e-4 horizontally, which the exact height field of issue 26 will remove.
    Raises the surface's own error (a :class:`~uavplan.sources.dem.TerrainError`) where the
    DEM does not cover the bounds."""
    prisms, tops_amsl, lows_amsl = surface.quad_prisms(
        bounds.x_m, bounds.y_m, cell_m=TERRAIN_CELL_M
    )
    datum = datum_amsl_m

    def ground_z(xy: Any) -> Any:
        return on_datum.height_m(xy) - datum

    lift = max(0.0, bounds.z_m[0] - margin_m)  # the floor above the ground, if higher
    return Ground(
        datum_amsl_m=datum,
        prisms_xy=prisms,
        tops_m=tops_amsl - datum + lift,
        height_fn=ground_z,
        ceiling_agl_m=bounds.z_m[1],
        source=str(surface.source),
        ceilings_m=lows_amsl - datum + bounds.z_m[1] + margin_m,
    )
