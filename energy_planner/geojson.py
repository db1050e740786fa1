"""The one GeoJSON path format: write and read a path with its CRS and yaw frame.

Every path the project writes (``plan --out``, route comparisons, ...) and reads
(``energy --waypoints``) uses this format, so that a planned path read back gives the
same energy.

Format (``energy_planner/path``, version 1), RFC 7946 by default::

    {"type": "FeatureCollection",
     "features": [{"type": "Feature",
                   "geometry": {"type": "LineString", "coordinates": [[lon, lat], ...]},
                   "properties": {"format": "energy_planner/path", "format_version": 1,
                                  "crs": "OGC:CRS84", "yaw_frame": "crs_x_ccw",
                                  "yaw_deg": [...], "t": [...], ...}}]}

- ``coordinates``: WGS 84 longitude, latitude (RFC 7946: what QGIS, geopandas and web
  maps expect), converted from the DEM's CRS. With ``native=True`` (``--geojson-crs
  dem``) they stay in the DEM's own CRS, named by the 2008 ``crs`` member (what GDAL and
  QGIS read for projected data). ``properties.crs`` names the CRS either way, for
  readers that drop unknown members. A DEM without a CRS (local metres) is written as is.
- ``yaw_deg`` (optional): body yaw per vertex, degrees counter-clockwise from the +x
  axis of that CRS *at the vertex* (``yaw_frame = "crs_x_ccw"``). For longitude,
  latitude that is local east (along the parallel), with north at +90. On the working
  UTM grid the same direction is turned by the meridian convergence, which
  :func:`yaw_to_work` / :func:`yaw_from_work` (and
  :func:`energy_planner.io.x_axis_angle` for any two CRSs) apply.
- ``t`` (optional): seconds, strictly increasing. Other properties (``energy_j``,
  ``planner``, ...) are free.
- A pose that repeats the previous one (a zero-length segment) is not written.

:func:`read_path` also reads any LineString GeoJSON (bare geometry, Feature, or a
FeatureCollection with exactly one LineString feature), taking ``yaw_deg`` in the CRS's
frame; without a ``crs`` member the coordinates are longitude, latitude (RFC 7946), or,
when they cannot be, the DEM's CRS (with a note). The older planner output (a bare
Feature with ``properties.planner`` and no ``format``) has ``yaw_deg`` in the *working
grid's* frame: it is read as such, with a note.

Writers: :func:`write_path` (coordinates and yaw in a given CRS) and
:func:`write_path_from_work` (poses on a :class:`~energy_planner.terrain.Terrain`'s
working grid, converted here). :func:`path_document` / :func:`path_document_from_work`
return the dict instead of writing it; the file is written atomically
(:func:`energy_planner.io.write_geojson`).

Examples
--------
>>> import tempfile, pathlib
>>> p = pathlib.Path(tempfile.mkdtemp()) / "p.geojson"
>>> _ = write_path(p, [[500000.0, 0.0], [500003.0, 4.0]], [0.9273, 0.9273],
...                crs="EPSG:32631", properties={"energy_j": 12.5})
>>> w = read_path(p)                        # RFC 7946: longitude, latitude
>>> w.xy.round(6).tolist(), w.yaw_rad.round(4).tolist(), w.declared_crs
([[3.0, 0.0], [3.000027, 3.6e-05]], [0.9273, 0.9273], 'OGC:CRS84')
>>> _ = write_path(p, [[500000.0, 0.0], [500003.0, 4.0]], crs="EPSG:32631", native=True)
>>> w = read_path(p)                        # the DEM's CRS, declared
>>> w.xy.tolist(), w.declared_crs
([[500000.0, 0.0], [500003.0, 4.0]], 'EPSG:32631')
"""

from __future__ import annotations

from energy_planner.io import path_format as _path_format
from energy_planner.io.geojson import crs_name
from energy_planner.io.path_format import *  # noqa: F403 (its __all__, re-exported)
from energy_planner.io.path_read import check_path, parse_path, read_path
from energy_planner.io.yaw import radians_suspect, warn_if_radians, yaw_from_work, yaw_to_work

__all__ = [
    *_path_format.__all__,
    "check_path",
    "crs_name",
    "parse_path",
    "radians_suspect",
    "read_path",
    "warn_if_radians",
    "yaw_from_work",
    "yaw_to_work",
]
