"""Reading and writing files: atomic outputs, one GeoTIFF writer, GeoJSON with its CRS.

Every file the project writes goes through this package:

* :func:`atomic_path` - a temporary file (on Linux unnamed, elsewhere a hidden one beside
  the destination) renamed over the destination when complete; the destination's folder
  is created if missing; the destination keeps its previous content when the write fails
  or the process gets SIGTERM or SIGKILL, and a SIGKILL leaves nothing beside it but
  what the next write removes (:func:`remove_stale`). :func:`atomic_dir` does the same
  for a whole folder (built in a private folder on the same mount, swapped in one step).
  :func:`write_text`, :func:`write_bytes`, :func:`write_json` use it.
* :func:`write_geotiff` / :func:`open_geotiff` - the one GeoTIFF writer (NaN nodata for
  floats, GDAL band units and descriptions, tags).
* :func:`write_geojson` / :func:`feature_collection` - RFC 7946 (WGS 84 lon/lat) by
  default, or the data's own CRS declared with the ``crs`` member.
* :func:`read_geometries` - GeoJSON geometries with their CRS (RFC 7946 lon/lat unless
  the file declares one), to be reprojected with :func:`reproject_geometries`.

Submodules for robots: :mod:`~energy_planner.io.bag` (ROS bag readers and writers),
:mod:`~energy_planner.io.ros2` (paths as ``nav_msgs/Path`` bags in a map frame, and back)
and :mod:`~energy_planner.io.nav2` (Nav2 Route Server graphs).
"""

from __future__ import annotations

from energy_planner.io.atomic import (
    atomic_dir,
    atomic_path,
    check_folder_output,
    content_id,
    output_error,
    remove_stale,
    save_figure,
    scratch_path,
    write_bytes,
    write_json,
    write_text,
)
from energy_planner.io.geojson import (
    RFC7946_CRS,
    Geometries,
    crs_name,
    declared_crs,
    feature_collection,
    is_lonlat,
    read_geometries,
    reproject_geometries,
    reproject_xy,
    write_geojson,
    x_axis_angle,
)
from energy_planner.io.geotiff import (
    COMPRESSIONS,
    NODATA,
    compression_options,
    describe_band,
    geotiff_profile,
    open_geotiff,
    write_geotiff,
)

__all__ = [
    "COMPRESSIONS",
    "NODATA",
    "RFC7946_CRS",
    "Geometries",
    "atomic_dir",
    "atomic_path",
    "check_folder_output",
    "compression_options",
    "content_id",
    "crs_name",
    "declared_crs",
    "describe_band",
    "feature_collection",
    "geotiff_profile",
    "is_lonlat",
    "open_geotiff",
    "output_error",
    "read_geometries",
    "remove_stale",
    "reproject_geometries",
    "reproject_xy",
    "save_figure",
    "scratch_path",
    "write_bytes",
    "write_geojson",
    "write_geotiff",
    "write_json",
    "write_text",
    "x_axis_angle",
]
