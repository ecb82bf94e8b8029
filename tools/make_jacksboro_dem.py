"""Write maps/jacksboro-fault-dem.tif from matplotlib's bundled sample DEM (reproducible).

matplotlib ships ``mpl-data/sample_data/jacksboro_fault_dem.npz``: int16 elevations (metres)
on a 3 arc-second grid, with its georeferencing as numbers in the file (``xmin``, ``xmax``,
``ymin``, ``ymax``, ``dx``, ``dy``, degrees). The extent is exactly ``cols·dx`` by
``rows·dy``, so those are pixel *edges*; ``ymin`` holds the northern edge (36.7329°) and row 0
is the northern row, as matplotlib's own examples use it (``np.linspace(ymin, ymax, rows)``).
The file names no datum; we write it as WGS84 longitude/latitude (EPSG:4326); NAD83, the
likely datum of US elevation data, differs from it by about a metre here.

Run: ``python tools/make_jacksboro_dem.py [OUTPUT]`` (needs matplotlib and rasterio).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np


def main(out: Path) -> None:
    import rasterio
    from matplotlib import cbook
    from rasterio.transform import from_origin

    dem: Any = cbook.get_sample_data("jacksboro_fault_dem.npz")
    z = np.asarray(dem["elevation"], dtype=np.int16)
    rows, cols = z.shape
    west, east = float(dem["xmin"]), float(dem["xmax"])
    north, south = float(dem["ymin"]), float(dem["ymax"])  # sic: ymin is the northern edge
    dx, dy = float(dem["dx"]), float(dem["dy"])
    assert abs((east - west) - cols * dx) < 1e-6 and abs((north - south) - rows * dy) < 1e-6
    profile = {
        "driver": "GTiff",
        "height": rows,
        "width": cols,
        "count": 1,
        "dtype": "int16",
        "crs": "EPSG:4326",
        "transform": from_origin(west, north, dx, dy),
        "compress": "deflate",
        "predictor": 2,
    }
    with rasterio.open(out, "w", **profile) as dst:
        dst.write(z, 1)
        dst.units = ("metre",)
        dst.update_tags(
            SOURCE="matplotlib mpl-data/sample_data/jacksboro_fault_dem.npz",
            AREA="Jacksboro fault, Campbell County, Tennessee, USA",
        )
    print(
        f"wrote {out}: {cols} x {rows} posts, {z.min()}..{z.max()} m, "
        f"lon {west:.5f}..{east:.5f}, lat {south:.5f}..{north:.5f}"
    )


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "maps/jacksboro-fault-dem.tif"))
