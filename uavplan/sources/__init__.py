"""Real-world data readers: obstacles from OpenStreetMap and GIS vector files, terrain from DEMs.

This package turns files into the project's vocabulary values (``uavplan.obstacles`` in the
scenario's local ENU frame, :class:`~uavplan.sources.dem.Terrain`). It sits above the
vocabulary layer and below the scenario reader; it knows nothing of planners, missions or
MAVLink. The heavy field libraries (pyosmium, pyogrio, rasterio, shapely) are imported lazily
inside the functions that need them, so ``import uavplan.sources`` stays cheap and only the
``import`` command and scenarios that name such files pay for them.

Entry points:

* :func:`read_obstacle_file` — one file (OSM ``.osm``/``.osm.pbf``/``.osm.bz2`` or anything
  GDAL reads) → :class:`ImportResult` (obstacles plus counts of what was kept and skipped).
* :func:`obstacles_from_entries` — the ``obstacle_files`` list of a scenario or map.
* :mod:`uavplan.sources.dem` — :class:`~uavplan.sources.dem.Terrain` from a GeoTIFF DEM.
"""

from __future__ import annotations

from uavplan.sources.common import (
    DEFAULT_HEIGHT_M,
    ImportResult,
    ObstacleFileSpec,
    SourceError,
    features_extent_lonlat,
    features_to_obstacles,
    obstacles_from_entries,
    parse_height_m,
    read_features,
    read_obstacle_file,
)

__all__ = [
    "DEFAULT_HEIGHT_M",
    "ImportResult",
    "ObstacleFileSpec",
    "SourceError",
    "features_extent_lonlat",
    "features_to_obstacles",
    "obstacles_from_entries",
    "parse_height_m",
    "read_features",
    "read_obstacle_file",
]
