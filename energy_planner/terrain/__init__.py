"""Terrain: DEM -> metric working grid, Horn gradient, slope/aspect, sampling.

>>> from energy_planner.terrain import Terrain, load_dem
>>> t = Terrain.from_function(lambda x, y: 0.2 * x, size=(20, 20))
>>> round(float(t.sample(10.0, 10.0).dzdx), 12)
0.2

Conventions: x east, y north (metres); ``slope = atan(|grad z|)``; uphill azimuth
``psi = atan2(dz/dy, dz/dx)`` counter-clockwise from east; "aspect" is the GIS aspect
(downslope, degrees clockwise from north, as gdaldem). See ``docs/terrain.md``.
rasterio is imported only by :func:`load_dem` and CRS handling.
"""

from energy_planner.terrain.dem import Terrain, utm_epsg
from energy_planner.terrain.horn import aspect, gradient, hillshade, slope
from energy_planner.terrain.memory import MEMORY_CAP_ENV, check_memory, memory_cap
from energy_planner.terrain.sample import TerrainSample


def __getattr__(name: str):
    """``load_dem``, imported on first use.

    Its module (and GDAL's value rules) is not needed by a Terrain built from numbers or
    read back (:mod:`energy_planner.terrain.stored`).
    """
    if name == "load_dem":
        from energy_planner.terrain.load import load_dem

        globals()["load_dem"] = load_dem
        return load_dem
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "Terrain",
    "TerrainSample",
    "MEMORY_CAP_ENV",
    "aspect",
    "check_memory",
    "gradient",
    "hillshade",
    "load_dem",
    "memory_cap",
    "slope",
    "utm_epsg",
]
