"""Write maps/zurich-north-synthetic-dem.tif: a *made-up* DEM for the bundled airspace
scenario (missions/zurich-airspace.yaml), reproducibly.

The elevations are a formula, not a survey: a plain at 430 m AMSL rising gently to the
north-east, and one smooth hill (130 m high, 550 m wide) standing in for a wooded hill such
as the Zürichberg, under the AGL zone of the scenario. The grid is WGS84 longitude/latitude
(EPSG:4326), 0.0003° posts (about 33 m north-south, 23 m east-west) over lon 8.49…8.60,
lat 47.385…47.43, north of Zürich, Switzerland. Do not use it for anything but tests.

Run: ``python tools/make_synthetic_dem.py [OUTPUT]`` (needs rasterio).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

WEST, EAST, SOUTH, NORTH = 8.49, 8.60, 47.385, 47.43
STEP_DEG = 0.0003
#: the hill: centre (lon, lat), height above the plain (m), radius of the Gaussian (m)
HILL = (8.5630, 47.4075, 130.0, 550.0)


def elevations() -> tuple[np.ndarray, float, float]:
    """Posts (rows from north to south, columns from west to east) in metres AMSL, and the
    grid's column and row counts."""
    cols = round((EAST - WEST) / STEP_DEG)
    rows = round((NORTH - SOUTH) / STEP_DEG)
    lon = WEST + (np.arange(cols) + 0.5) * STEP_DEG
    lat = NORTH - (np.arange(rows) + 0.5) * STEP_DEG
    lon_g, lat_g = np.meshgrid(lon, lat)
    east_m = (lon_g - WEST) * 111_320.0 * np.cos(np.radians(lat_g))
    north_m = (lat_g - SOUTH) * 111_320.0
    plain = 430.0 + 0.004 * east_m + 0.006 * north_m
    hx = (lon_g - HILL[0]) * 111_320.0 * np.cos(np.radians(lat_g))
    hy = (lat_g - HILL[1]) * 111_320.0
    hill = HILL[2] * np.exp(-(hx**2 + hy**2) / (2.0 * HILL[3] ** 2))
    return np.round(plain + hill, 1).astype(np.float32), cols, rows


def main(out: Path) -> None:
    import rasterio
    from rasterio.transform import from_origin

    z, cols, rows = elevations()
    profile = {
        "driver": "GTiff",
        "height": rows,
        "width": cols,
        "count": 1,
        "dtype": "float32",
        "crs": "EPSG:4326",
        "transform": from_origin(WEST, NORTH, STEP_DEG, STEP_DEG),
        "compress": "deflate",
        "predictor": 3,
    }
    with rasterio.open(out, "w", **profile) as dst:
        dst.write(z, 1)
        dst.units = ("metre",)
        dst.update_tags(SOURCE="tools/make_synthetic_dem.py: made-up elevations, not a survey")
    print(f"wrote {out}: {cols} x {rows} posts, {z.min():.1f}..{z.max():.1f} m")


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "maps/zurich-north-synthetic-dem.tif"))
