"""Write ``maps/jacksboro_fault_dem.tif`` from matplotlib's sample DEM.

Source: ``matplotlib.cbook.get_sample_data("jacksboro_fault_dem.npz")`` (a 3 arc-second
USGS DEM around the Jacksboro fault, Tennessee, shipped with matplotlib for its
hill-shading examples). The npz holds ``elevation`` (int16, 344 x 403, metres) and the
fields ``dx``, ``dy``, ``xmin``, ``xmax``, ``ymin``, ``ymax`` in degrees.

What the fields say, checked below (the script stops if a check fails):

- ``dx == dy == 1/1200`` degree = 3 arc-seconds.
- ``(xmax - xmin) / dx == 403`` and ``|ymax - ymin| / dy == 344`` exactly: the extents are
  the outer *edges* of the grid (cell centres would span 402 and 343 steps).
- ``ymin`` (36.7329) is larger than ``ymax`` (36.4463): the names are swapped; the first
  row is the northern one (matplotlib's examples draw the array with row 0 at the top
  and light it from the north-west, and ``np.linspace(ymin, ymax, nrows)`` in its 3-D
  example puts 36.73 at row 0).

So the geotransform is north-up with its upper-left corner at (xmin, max(ymin, ymax)) and
3" pixels, CRS EPSG:4326 (the sample carries no datum; WGS 84 is assumed, the difference
to NAD83 is about 1 m here, far below the 90 m pixel).

Run: ``python maps/make_jacksboro.py`` (writes next to this script).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import rasterio
from matplotlib import cbook
from rasterio.transform import from_origin

OUT = (  # package data (maps/ at the root links to it)
    Path(__file__).resolve().parents[1]
    / "energy_planner"
    / "data"
    / "maps"
    / "jacksboro_fault_dem.tif"
)


def main() -> None:
    dem = cbook.get_sample_data("jacksboro_fault_dem.npz")
    z = np.asarray(dem["elevation"])
    dx, dy = float(dem["dx"]), float(dem["dy"])
    xmin, xmax = float(dem["xmin"]), float(dem["xmax"])
    ymin, ymax = float(dem["ymin"]), float(dem["ymax"])
    rows, cols = z.shape
    assert z.dtype == np.int16 and (rows, cols) == (344, 403), (z.dtype, z.shape)
    assert abs(dx - 1 / 1200) < 1e-15 and abs(dy - 1 / 1200) < 1e-15, (dx, dy)
    assert abs((xmax - xmin) / dx - cols) < 1e-6, "x extent is not cols * dx (edges)"
    assert abs(abs(ymax - ymin) / dy - rows) < 1e-6, "y extent is not rows * dy (edges)"
    assert ymin > ymax, "expected the swapped ymin/ymax of the matplotlib sample"
    north = max(ymin, ymax)
    transform = from_origin(xmin, north, dx, dy)
    profile = dict(
        driver="GTiff",
        width=cols,
        height=rows,
        count=1,
        dtype="int16",
        crs="EPSG:4326",
        transform=transform,
        compress="deflate",
        predictor=2,
    )
    with rasterio.open(OUT, "w", **profile) as dst:
        dst.write(z, 1)
        dst.update_tags(
            SOURCE='matplotlib.cbook.get_sample_data("jacksboro_fault_dem.npz")',
            UNITS="metres",
        )
    print(f"wrote {OUT} ({rows} x {cols}, bounds {rasterio.open(OUT).bounds})")


if __name__ == "__main__":
    main()
