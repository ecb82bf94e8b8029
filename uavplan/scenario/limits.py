"""The documented limits of scenario and map files (docs/scenario-format.md, "Limits").

Every number a file may hold has bounds, and a scenario whose search would be larger than
these is refused before planning, with a message naming the key to change.
"""

from __future__ import annotations

# the limits a source file, a .plan fence and a map obey too live in the vocabulary
from uavplan.limits import MAX_ALTITUDE_M as MAX_ALTITUDE_M
from uavplan.limits import MAX_HORIZONTAL_M as MAX_HORIZONTAL_M
from uavplan.limits import MAX_OBSTACLES as MAX_OBSTACLES
from uavplan.limits import MAX_POLYGON_VERTICES as MAX_POLYGON_VERTICES
from uavplan.limits import MAX_SIZE_M as MAX_SIZE_M

#: largest scenario or map file read, bytes
MAX_FILE_BYTES = 32 * 1024 * 1024
#: most values (scalars, lists, mappings) in one document once aliases are expanded
MAX_YAML_NODES = 5_000_000
#: deepest nesting of lists and mappings
MAX_YAML_DEPTH = 64
#: via points in one scenario
MAX_VIA_POINTS = 1_000
#: safety margin at most this, metres
MAX_SAFETY_MARGIN_M = 10_000.0
#: a name at most this many characters; a map path at most PATH_MAX / NAME_MAX
MAX_NAME_CHARS = 200
MAX_PATH_CHARS = 4096
MAX_PATH_PART_CHARS = 255
#: the path grid over the flight volume (for the largest leg: columns × lateral × vertical
#: nodes of the volume's box in the leg's frame; over a DEM the volume reaches from the datum
#: to the highest ground plus the ceiling) at most this many cells with a grid the scenario
#: sets (the node table alone holds 8 bytes a node of the leg's columns)
MAX_GRID_CELLS = 50_000_000
#: a scenario that sets no grid is planned on the default grid scaled up just enough that its
#: path grid holds at most this many cells (uavplan.scenario.size.fitted_grid): at most 40 MB
#: of node clearances, and a guide search at twice the steps within about 45 MB
FIT_GRID_CELLS = 4_000_000
#: population × iterations × path columns (node updates of one search) at most this many
MAX_SEARCH_WORK = 2_000_000_000
#: samples of the smoothed route (twice the start-goal distance / post.sample_step_m)
MAX_ROUTE_SAMPLES = 10_000_000
#: the origin's altitude within this range, metres AMSL
ORIGIN_ALT_RANGE_M = (-500.0, 10_000.0)
#: origins closer to a pole than this (degrees of latitude) have no usable local ENU frame
MAX_ORIGIN_LAT_DEG = 89.9
#: a vehicle's cruise speed at most this, m/s
MAX_CRUISE_SPEED_M_S = 100.0
#: mission.spacing within this range, metres
SPACING_RANGE_M = (1.0, 100_000.0)
