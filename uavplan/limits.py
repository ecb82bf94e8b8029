"""The documented limits on what a scenario, a map or a source file may hold.

One place for the limits every reader applies, so a map written by ``uavplan import``, a file
read through ``obstacle_files`` and an obstacle typed into a scenario pass the same checks
(docs/scenario-format.md, "Limits"; docs/real-world.md). Plain numbers: importing this module
costs nothing.
"""

from __future__ import annotations

#: every x and y (bounds, points, obstacle centres and vertices) within ± this, metres
MAX_HORIZONTAL_M = 1_000_000.0
#: the flight ceiling (bounds.z max), obstacle heights and sizes at most this, metres
MAX_ALTITUDE_M = 20_000.0
MAX_SIZE_M = 2 * MAX_HORIZONTAL_M
#: at most this many obstacles (map and scenario together)
MAX_OBSTACLES = 200_000
#: at most this many vertices per prism polygon
MAX_POLYGON_VERTICES = 1_000
#: at most this many vertices per geofence polygon read from a QGroundControl .plan
#: (QGroundControl draws fences by hand; a PX4 vehicle stores a few hundred fence vertices)
MAX_FENCE_POLYGON_VERTICES = 1_000
#: at most this many geofence polygons and circles in one .plan
MAX_FENCE_ZONES = 10_000
#: ground heights of a DEM within this range, metres above mean sea level (the Dead Sea shore
#: is at -430 m, Everest at 8,849 m): anything outside is an undeclared nodata value or a
#: file in other units
MIN_GROUND_AMSL_M = -1_000.0
MAX_GROUND_AMSL_M = 9_000.0
#: a DEM window read for a scenario at most this many posts
MAX_DEM_POSTS = 50_000_000
