"""The project's GeoJSON path format: constants, :class:`Waypoints` and the writers.

See :mod:`energy_planner.geojson` for the format.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.errors import WaypointError, WaypointIOError
from energy_planner.io.geojson import (
    RFC7946_CRS,
    crs_name,
    is_lonlat,
    reproject_xy,
    write_geojson,
    x_axis_angle,
)
from energy_planner.io.yaw import yaw_from_work

__all__ = [
    "LEGACY_YAW_FRAME",
    "PATH_FORMAT",
    "PATH_FORMAT_VERSION",
    "YAW_FRAME",
    "Waypoints",
    "is_bag",
    "path_document",
    "path_document_from_work",
    "segment_gaits",
    "write_path",
    "write_path_from_work",
]

#: ``properties.format`` of a path written by this module.
PATH_FORMAT = "energy_planner/path"
#: ``properties.format_version``.
PATH_FORMAT_VERSION = 1
#: ``properties.yaw_frame``: degrees counter-clockwise from the CRS's +x axis at the vertex.
YAW_FRAME = "crs_x_ccw"
#: Frame of older planner files: the working grid's +x axis.
LEGACY_YAW_FRAME = "work_x_ccw"


@dataclass
class Waypoints:
    """A path read from a file, in the file's CRS (``declared_crs``; None: the DEM's).

    Attributes
    ----------
    xy : ndarray, shape (n, 2)
        Coordinates in that CRS (longitude, latitude for RFC 7946 GeoJSON), n >= 2.
    yaw_rad : ndarray, shape (n,), or None
        Body yaw, radians counter-clockwise, if the file gives it; its frame is
        ``yaw_frame``.
    t : ndarray, shape (n,), or None
        Times in seconds (strictly increasing), if the file gives them.
    crs_note : str
        What the file says about its coordinates (the CRS a GeoJSON declares, or that
        they are taken in the DEM's CRS).
    declared_crs : str or None
        The CRS the file names (``crs`` member or ``properties.crs``), if any.
    notes : list of str
        Things the reader ignored or assumed (extra columns, a z coordinate, ...).
    path : pathlib.Path or None
        The file.
    yaw_frame : str
        ``"crs_x_ccw"`` (from the CRS's +x axis at the vertex; CSV files, hand-written
        and current GeoJSON) or ``"work_x_ccw"`` (older planner files: from the working
        grid's +x axis).
    properties : dict
        The GeoJSON feature's other properties (``energy_j``, ``planner``, ...).
    yaw_radians_suspect : bool
        True when ``yaw_deg`` looks like radians (see :func:`radians_suspect`); a
        ``UserWarning`` was issued and a note added.
    """

    xy: np.ndarray
    yaw_rad: np.ndarray | None
    t: np.ndarray | None
    crs_note: str
    declared_crs: str | None = None
    notes: list[str] = field(default_factory=list)
    path: Path | None = None
    yaw_frame: str = YAW_FRAME
    properties: dict[str, Any] = field(default_factory=dict)
    yaw_radians_suspect: bool = False

    def __len__(self) -> int:
        return int(self.xy.shape[0])


def _finite_list(vals: Any, n: int, key: str, scale: float = 1.0) -> list[float]:
    try:
        arr = np.asarray(vals, dtype=float)
    except (TypeError, ValueError) as exc:
        raise WaypointError(
            f"{key}: {vals!r} is not numeric",
            value=vals,
            column=key,
            expected=f"{n} finite numbers",
        ) from exc
    if arr.shape != (n,) or not np.isfinite(arr).all():
        raise WaypointError(
            f"{key}: expected {n} finite values, got shape {arr.shape}",
            value=vals,
            column=key,
            expected=f"{n} finite numbers",
        )
    return [float(v) * scale for v in arr]


def path_document(
    xy: Any,
    yaw_rad: Sequence[float] | np.ndarray | None = None,
    *,
    t: Sequence[float] | np.ndarray | None = None,
    crs: Any = None,
    properties: dict[str, Any] | None = None,
    native: bool = False,
    gait: Sequence[str | None] | None = None,
) -> dict[str, Any]:
    """The GeoJSON dict of a path (see the module docstring for the format).

    Parameters
    ----------
    xy : array-like, shape (n, 2)
        Vertices in CRS ``crs``, n >= 2.
    yaw_rad : array-like, shape (n,), optional
        Body yaw, radians counter-clockwise from that CRS's +x axis at each vertex
        (local east for a geographic CRS); written as ``yaw_deg``.
    t : array-like, shape (n,), optional
        Times, s.
    crs : CRS, str or None
        The CRS of ``xy`` (rasterio CRS or a string such as ``"EPSG:32631"``); None for
        a local grid (written as given).
    properties : dict, optional
        Extra feature properties (``energy_j``, ``planner``, ...); JSON-serialisable.
    native : bool
        False (default): RFC 7946, longitude/latitude (yaw from local east), no ``crs``
        member. True: coordinates in ``crs``, declared with the ``crs`` member.
    gait : sequence of str or None, shape (n - 1,), optional
        The gait of each segment (a plan that chose it); written as the vertex property
        ``gait``, the gait of the segment each vertex starts (null at the last vertex).

    Returns
    -------
    dict

    Raises
    ------
    WaypointError
        Bad shapes or non-finite values.
    """
    try:
        arr = np.asarray(xy, dtype=float)
    except (TypeError, ValueError) as exc:
        raise WaypointError(
            f"xy {xy!r} is not numeric", value=xy, expected="a finite (n >= 2, 2) array"
        ) from exc
    n = arr.shape[0] if arr.ndim == 2 else -1
    if arr.ndim != 2 or arr.shape[1] != 2 or n < 2 or not np.isfinite(arr).all():
        raise WaypointError(
            f"xy must be a finite (n >= 2, 2) array; got shape {arr.shape}",
            value=arr.shape,
            expected="a finite (n >= 2, 2) array",
        )
    yaw = None if yaw_rad is None else np.asarray(_finite_list(yaw_rad, n, "yaw_deg"))
    times = None if t is None else np.asarray(_finite_list(t, n, "t"))
    name = crs_name(crs)
    if name is not None and not native:
        arr, yaw = _to_lonlat(arr, yaw, name)
        name = RFC7946_CRS
    keep = _not_repeated(arr, yaw, times)
    props: dict[str, Any] = {
        "format": PATH_FORMAT,
        "format_version": PATH_FORMAT_VERSION,
        "crs": name,
    }
    if yaw is not None:
        props["yaw_frame"] = YAW_FRAME
        props["yaw_deg"] = [math.degrees(v) for v in yaw[keep]]
    if times is not None:
        props["t"] = [float(v) for v in times[keep]]
    if gait is not None:
        props["gait"] = _vertex_gaits(gait, keep)
    for k, v in (properties or {}).items():
        if k in props:
            raise WaypointError(
                f"property {k!r} is set by the path format itself",
                value=k,
                expected=f"a name other than {sorted(props)}",
            )
        props[k] = v
    doc: dict[str, Any] = {"type": "FeatureCollection"}
    if name and native:
        doc["crs"] = {"type": "name", "properties": {"name": name}}
    doc["features"] = [
        {
            "type": "Feature",
            "properties": props,
            "geometry": {"type": "LineString", "coordinates": arr[keep].tolist()},
        }
    ]
    return doc


def _vertex_gaits(gait: Sequence[str | None], keep: np.ndarray) -> list[str | None]:
    """Per kept vertex, the gait of the segment it starts (null at the last).

    A dropped vertex repeats the one before it: the kept vertex then starts the segment
    after the repeat, and takes its gait.
    """
    g = list(gait)
    n = keep.size
    if len(g) != n - 1:
        raise WaypointError(
            f"gait has {len(g)} entries for {n - 1} segments",
            value=len(g),
            expected="one gait per segment",
        )
    per_vertex = [None if v is None else str(v) for v in g] + [None]
    kept = np.flatnonzero(keep).tolist()
    nxt = kept[1:] + [n]
    return [per_vertex[q - 1] if q < n else None for q in nxt]


def segment_gaits(wp: Waypoints) -> list[str | None] | None:
    """The gait of each segment of a path read back (vertex property ``gait``), or None.

    Raises
    ------
    WaypointError
        A ``gait`` list of the wrong length or with a value that is not a gait name
        (naming the file, the vertex and the value).
    """
    g = wp.properties.get("gait")
    if g is None:
        return None
    where = f"waypoint file {str(wp.path)!r}" if wp.path is not None else "GeoJSON path"
    n = len(wp)
    if not isinstance(g, list) or len(g) != n:
        raise WaypointError(
            f"{where}: properties.gait must be a list of one gait name (or null) per vertex "
            f"({n}); got {g!r:.80}",
            path=wp.path,
            value=g if not isinstance(g, list) else len(g),
            expected=f"a list of {n} gait names or nulls",
        )
    for i, v in enumerate(g):
        if v is not None and not (isinstance(v, str) and v.strip()):
            raise WaypointError(
                f"{where}: properties.gait at vertex {i} is {v!r}; expected a gait name "
                "(as the model names them, e.g. 'walk') or null",
                path=wp.path,
                value=v,
                expected="a gait name or null",
            )
    return list(g[:-1])


def _to_lonlat(
    arr: np.ndarray, yaw: np.ndarray | None, name: str
) -> tuple[np.ndarray, np.ndarray | None]:
    """Vertices (and yaw from the CRS's x axis) -> longitude, latitude (yaw from east)."""
    if is_lonlat(name):
        return arr, yaw
    lon, lat = reproject_xy(name, RFC7946_CRS, arr[:, 0], arr[:, 1])
    if not (np.isfinite(lon).all() and np.isfinite(lat).all()):
        raise WaypointError(
            f"xy has no longitude, latitude: are the coordinates in {name}?",
            value=name,
            expected=f"coordinates in {name}",
        )
    if yaw is not None:
        # minus the angle of local east in ``name``: the exact inverse of what a reader
        # adds (waypoints_to_work), so that a written path reads back as the same poses
        yaw = yaw - x_axis_angle(RFC7946_CRS, name, lon, lat)
    return np.column_stack([lon, lat]), yaw  # full precision: read back, the same poses


def _not_repeated(arr: np.ndarray, yaw: np.ndarray | None, t: np.ndarray | None) -> np.ndarray:
    """Mask of the vertices to write: a pose that repeats the previous one is dropped.

    A repeated pose (same position, same yaw, no time or the same time) adds a
    zero-length segment and nothing else.

    Examples
    --------
    >>> _not_repeated(np.array([[0.0, 0], [0, 0], [1, 0], [1, 0]]), None, None).tolist()
    [True, False, True, False]
    """
    cols = [arr] + [v[:, None] for v in (yaw, t) if v is not None]
    full = np.hstack(cols)
    same = np.all(full[1:] == full[:-1], axis=1)
    keep = np.concatenate([[True], ~same])
    if keep.sum() < 2:  # a path that stays in place keeps its two ends
        keep[-1] = True
    return keep


def write_path(
    path: str | Path, xy: Any, yaw_rad: Sequence[float] | np.ndarray | None = None, **options: Any
) -> Path:
    """Write :func:`path_document` to ``path`` (UTF-8 JSON) and return the path.

    ``xy``, ``yaw_rad`` and the keyword ``options`` (``t``, ``crs``, ``properties``,
    ``native``) are those of :func:`path_document`.
    """
    return _write_document(path, path_document(xy, yaw_rad, **options))


def _write_document(path: str | Path, doc: dict[str, Any]) -> Path:
    """Write a path's GeoJSON ``doc`` to ``path`` (atomically); ``WaypointIOError`` if not."""
    p = Path(path)
    try:
        write_geojson(p, doc)
    except OSError as exc:
        raise WaypointIOError(f"cannot write path file {str(p)!r}: {exc}", path=p) from exc
    return p


def path_document_from_work(
    terrain: Any,
    states: Any,
    *,
    t: Sequence[float] | np.ndarray | None = None,
    properties: dict[str, Any] | None = None,
    native: bool = False,
    gait: Sequence[str | None] | None = None,
) -> dict[str, Any]:
    """The GeoJSON dict of poses on a terrain's working grid.

    Parameters
    ----------
    terrain : Terrain
        Gives ``from_work`` and the CRSs.
    states : array-like, shape (n, 2) or (n, 3)
        ``x, y[, yaw]`` in the working CRS (metres; yaw radians CCW from the grid's +x).
    t, properties, gait
        As in :func:`path_document`.
    native : bool
        False (default): RFC 7946 longitude/latitude, yaw from local east. True: the
        DEM's own CRS (``terrain.source_crs``), declared.

    Returns
    -------
    dict

    Examples
    --------
    >>> from energy_planner.terrain import Terrain
    >>> ter = Terrain.from_function(lambda x, y: 0 * x, size=(10, 10))
    >>> d = path_document_from_work(ter, [[1, 1, 0.5], [2, 2, 0.5]], native=True)
    >>> d["features"][0]["properties"]["yaw_deg"][0] == math.degrees(0.5), d["crs"]
    (True, {'type': 'name', 'properties': {'name': 'EPSG:32631'}})
    >>> d = path_document_from_work(ter, [[500000, 0, 0.5], [500001, 1, 0.5]])  # RFC 7946
    >>> np.round(d["features"][0]["geometry"]["coordinates"][0], 9).tolist(), "crs" in d
    ([3.0, 0.0], False)
    """
    s = np.asarray(states, dtype=float)
    if s.ndim != 2 or s.shape[1] not in (2, 3):
        raise WaypointError(
            f"states must have shape (n, 2) or (n, 3); got {s.shape}",
            value=s.shape,
            expected="(n, 2) or (n, 3)",
        )
    work = getattr(terrain, "crs", None)
    if native or work is None:
        x, y = terrain.from_work(s[:, 0], s[:, 1])
        xy = np.column_stack([np.atleast_1d(x), np.atleast_1d(y)])
        yaw = yaw_from_work(terrain, s[:, 0], s[:, 1], s[:, 2]) if s.shape[1] == 3 else None
        crs = getattr(terrain, "source_crs", None)
        return path_document(xy, yaw, t=t, crs=crs, properties=properties, native=True,
                             gait=gait)  # fmt: skip
    yaw = s[:, 2] if s.shape[1] == 3 else None
    return path_document(s[:, :2], yaw, t=t, crs=work, properties=properties, gait=gait)


def write_path_from_work(
    path: str | Path,
    terrain: Any,
    states: Any,
    *,
    t: Sequence[float] | np.ndarray | None = None,
    properties: dict[str, Any] | None = None,
    native: bool = False,
) -> Path:
    """Write :func:`path_document_from_work` to ``path`` and return the path."""
    doc = path_document_from_work(terrain, states, t=t, properties=properties, native=native)
    return _write_document(path, doc)


def is_bag(path: str | Path) -> bool:
    """Whether ``path`` names a ROS bag: a folder, or a ``.bag``, ``.mcap``, ``.db3`` file.

    Here, beside the path format, so that a reader of waypoints tells a bag without
    importing :mod:`energy_planner.io.ros2` (which re-exports it).

    A folder is taken as a ROS 2 bag (its ``metadata.yaml`` is checked on reading).
    """
    p = Path(path)
    return p.is_dir() or p.suffix.lower() in (".bag", ".mcap", ".db3")
