"""Solids as one triangle mesh for the page: every obstacle (or fence zone) a prism from its
base to its top, all of them in one vertex and one triangle array, so a town of thousands of
buildings is one mesh trace for the browser instead of thousands.

What is dropped is what does not show: footprints are simplified to within
:data:`SIMPLIFY_TOL_M` (a vertex that moves a wall by less than that is invisible at any
zoom the page allows over a scene tens of metres wide or more), cylinders get
:data:`CYLINDER_SIDES` sides, and no solid has a floor (it stands on the ground, or reaches
into it). A top is triangulated as the footprint is (concave ones too: GEOS's constrained
Delaunay triangulation, shapely ≥ 2.1; the ``view`` extra asks for it).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from uavplan.mission.fence import Footprint

__all__ = [
    "CYLINDER_SIDES",
    "SIMPLIFY_TOL_M",
    "Mesh",
    "closed_rings",
    "footprint_rings",
    "prism_mesh",
]

#: footprints are simplified to within this distance (m) before they are drawn
SIMPLIFY_TOL_M = 0.25
#: sides of a cylinder drawn as a prism
CYLINDER_SIDES = 24


@dataclass(frozen=True, eq=False)
class Mesh:
    """Triangles over shared vertices: ``vertices`` ``(n, 3)``, ``triangles`` ``(m, 3)``
    (indices into the vertices) and ``owner`` ``(n,)``: the solid (its position in the
    sequence the mesh was built from) each vertex belongs to."""

    vertices: NDArray[np.float64]
    triangles: NDArray[np.int64]
    owner: NDArray[np.int64]

    @classmethod
    def empty(cls) -> Mesh:
        return cls(np.empty((0, 3)), np.empty((0, 3), dtype=np.int64), np.empty(0, np.int64))

    def __len__(self) -> int:
        return len(self.triangles)


def footprint_rings(
    footprints: Sequence[Footprint], tol_m: float = SIMPLIFY_TOL_M
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The footprints' outlines, simplified to within ``tol_m`` (topology kept, so a ring
    never loses its area): the vertices ``(k, 2)`` of every ring, counter-clockwise and not
    closed, and each vertex's footprint (its position in ``footprints``)."""
    import shapely

    if not footprints:
        return np.empty((0, 2)), np.empty(0, dtype=np.int64)
    outlines = [fp.outline_enu(CYLINDER_SIDES) for fp in footprints]
    counts = np.array([len(o) for o in outlines])
    coords = np.concatenate([np.vstack((o, o[:1])) for o in outlines])  # closed rings
    which = np.repeat(np.arange(len(outlines)), counts + 1)
    rings = shapely.linearrings(coords, indices=which)
    polygons = shapely.simplify(shapely.polygons(rings), tol_m, preserve_topology=True)
    polygons = shapely.orient_polygons(polygons)  # counter-clockwise outlines
    xy, index = shapely.get_coordinates(shapely.get_exterior_ring(polygons), return_index=True)
    # drop each ring's closing vertex (the last of its run)
    last = np.r_[index[1:] != index[:-1], True]
    return xy[~last].astype(np.float64), index[~last].astype(np.int64)


def prism_mesh(
    footprints: Sequence[Footprint],
    base_z: NDArray[np.float64] | float,
    top_z: NDArray[np.float64],
    tol_m: float = SIMPLIFY_TOL_M,
) -> Mesh:
    """Every footprint as a prism from ``base_z`` (one value, or one per footprint) to
    ``top_z`` (one per footprint): its walls and its top, no floor."""
    import shapely

    xy, ring_of = footprint_rings(footprints, tol_m)
    if len(xy) == 0:
        return Mesh.empty()
    n_fp = len(footprints)
    base = np.broadcast_to(np.asarray(base_z, dtype=np.float64), (n_fp,))
    top = np.asarray(top_z, dtype=np.float64).reshape(n_fp)
    n = len(xy)
    # walls: vertex v at the bottom (v) and at the top (n + v); each edge v → next(v) two
    # triangles
    starts = np.r_[0, np.flatnonzero(ring_of[1:] != ring_of[:-1]) + 1]
    lengths = np.diff(np.r_[starts, n])
    first_of = np.repeat(starts, lengths)
    local = np.arange(n) - first_of
    nxt = first_of + (local + 1) % np.repeat(lengths, lengths)
    v = np.arange(n)
    walls = np.concatenate(
        (np.column_stack((v, nxt, n + nxt)), np.column_stack((v, n + nxt, n + v)))
    )
    wall_vertices = np.vstack(
        (np.column_stack((xy, base[ring_of])), np.column_stack((xy, top[ring_of])))
    )
    # tops: the constrained Delaunay triangles of each (simplified) footprint, their own
    # vertices (a top shares no vertex with its walls: flat shading, no smoothing across)
    closed = closed_rings(xy, ring_of, starts)
    polygons = shapely.polygons(shapely.linearrings(closed[0], indices=closed[1]))
    tri_geoms, tri_owner = _triangles(polygons)
    tri_xy = shapely.get_coordinates(shapely.get_exterior_ring(tri_geoms)).reshape(-1, 4, 2)[:, :3]
    owners = ring_of[starts][tri_owner] if len(tri_owner) else np.empty(0, dtype=np.int64)
    top_vertices = (
        np.column_stack((tri_xy.reshape(-1, 2), np.repeat(top[owners], 3)))
        if len(owners)
        else np.empty((0, 3))
    )
    m = 2 * n
    caps = m + np.arange(len(top_vertices)).reshape(-1, 3)
    vertices = np.vstack((wall_vertices, top_vertices))
    owner = np.concatenate((ring_of, ring_of, np.repeat(owners, 3)))
    return Mesh(vertices, np.vstack((walls, caps)).astype(np.int64), owner.astype(np.int64))


def _triangles(polygons: NDArray[np.object_]) -> tuple[NDArray[np.object_], NDArray[np.int64]]:
    """Each polygon's triangles and the polygon each belongs to: GEOS's constrained Delaunay
    triangulation (shapely ≥ 2.1), else (shapely 2.0) the Delaunay triangles of its vertices
    whose centre lies inside it (a concave footprint may lose a sliver of its top there)."""
    import shapely

    if hasattr(shapely, "constrained_delaunay_triangles"):
        parts, owner = shapely.get_parts(
            shapely.constrained_delaunay_triangles(polygons), return_index=True
        )
        return parts, owner.astype(np.int64)
    parts, owner = shapely.get_parts(shapely.delaunay_triangles(polygons), return_index=True)
    inside = shapely.contains_properly(polygons[owner], shapely.centroid(parts))
    return parts[inside], owner[inside].astype(np.int64)


def closed_rings(
    xy: NDArray[np.float64], ring_of: NDArray[np.int64], starts: NDArray[np.int64]
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The rings closed again (each run of ``xy`` followed by its first vertex), with a
    running ring index for shapely."""
    n, rings = len(xy), len(starts)
    ends = np.r_[starts[1:], n]
    run = np.repeat(np.arange(rings), ends - starts)  # each vertex's ring number
    out = np.empty((n + rings, 2))
    out[np.arange(n) + run] = xy  # vertex v moves up by the closing vertices before it
    out[ends + np.arange(rings)] = xy[starts]
    return out, np.repeat(np.arange(rings), ends - starts + 1)
