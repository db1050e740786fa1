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

import json
import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.angles import wrap
from energy_planner.errors import WaypointError, WaypointIOError
from energy_planner.io import (
    RFC7946_CRS,
    crs_name,
    declared_crs,
    is_lonlat,
    reproject_xy,
    write_geojson,
    x_axis_angle,
)

__all__ = [
    "PATH_FORMAT",
    "PATH_FORMAT_VERSION",
    "YAW_FRAME",
    "Waypoints",
    "crs_name",
    "parse_path",
    "path_document",
    "path_document_from_work",
    "radians_suspect",
    "read_path",
    "write_path",
    "write_path_from_work",
    "yaw_from_work",
    "yaw_to_work",
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
    """A path read from a file, in the file's (the DEM's) own CRS.

    Attributes
    ----------
    xy : ndarray, shape (n, 2)
        Coordinates in the DEM's CRS (longitude, latitude for a geographic DEM), n >= 2.
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


# ---------------------------------------------------------------------- writing
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
    path: str | Path,
    xy: Any,
    yaw_rad: Sequence[float] | np.ndarray | None = None,
    *,
    t: Sequence[float] | np.ndarray | None = None,
    crs: Any = None,
    properties: dict[str, Any] | None = None,
    native: bool = False,
) -> Path:
    """Write :func:`path_document` to ``path`` (UTF-8 JSON) and return the path."""
    doc = path_document(xy, yaw_rad, t=t, crs=crs, properties=properties, native=native)
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
) -> dict[str, Any]:
    """The GeoJSON dict of poses on a terrain's working grid.

    Parameters
    ----------
    terrain : Terrain
        Gives ``from_work`` and the CRSs.
    states : array-like, shape (n, 2) or (n, 3)
        ``x, y[, yaw]`` in the working CRS (metres; yaw radians CCW from the grid's +x).
    t, properties
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
        return path_document(xy, yaw, t=t, crs=crs, properties=properties, native=True)
    yaw = s[:, 2] if s.shape[1] == 3 else None
    return path_document(s[:, :2], yaw, t=t, crs=work, properties=properties)


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
    p = Path(path)
    try:
        write_geojson(p, doc)
    except OSError as exc:
        raise WaypointIOError(f"cannot write path file {str(p)!r}: {exc}", path=p) from exc
    return p


# ---------------------------------------------------------------------- reading
def read_path(path: str | Path) -> Waypoints:
    """Read a GeoJSON path (this format, any LineString GeoJSON, older planner output).

    Parameters
    ----------
    path : str or pathlib.Path
        The file.

    Returns
    -------
    Waypoints

    Raises
    ------
    WaypointIOError
        The file does not exist or cannot be read.
    WaypointError
        Not JSON, not one LineString, a bad coordinate, a ``yaw_deg``/``t`` list of the
        wrong length or with a bad value, times not increasing. The message names the
        file, the vertex and the value.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8-sig")
    except FileNotFoundError as exc:
        raise WaypointIOError(
            f"path file {str(p)!r} does not exist (expected a GeoJSON LineString)", path=p
        ) from exc
    except (OSError, UnicodeDecodeError) as exc:
        raise WaypointIOError(f"cannot read path file {str(p)!r}: {exc}", path=p) from exc
    return parse_path(text, p)


def parse_path(text: str, p: Path | None = None) -> Waypoints:
    """Parse GeoJSON text as a path (see :func:`read_path`); ``p`` names it in messages."""
    where_file = f"waypoint file {str(p)!r}" if p is not None else "GeoJSON path"
    fkw = {"path": p}
    try:
        doc = json.loads(text)
    except (json.JSONDecodeError, RecursionError) as exc:
        raise WaypointError(
            f"{where_file} is not valid JSON: {exc}", **fkw, expected="a GeoJSON LineString"
        ) from exc
    if not isinstance(doc, dict) or "type" not in doc:
        raise WaypointError(
            f"{where_file}: not a GeoJSON object (no 'type' member)",
            **fkw,
            expected="a GeoJSON object",
        )
    notes: list[str] = []
    kind = doc["type"]
    props: Any = {}
    if kind == "FeatureCollection":
        feats = doc.get("features")
        if not isinstance(feats, list):
            raise WaypointError(
                f"{where_file}: FeatureCollection without a 'features' list",
                **fkw,
                expected="a 'features' list",
            )

        def gtype(f: Any) -> Any:
            g = f.get("geometry") if isinstance(f, dict) else None
            return g.get("type") if isinstance(g, dict) else None

        lines = [(i, f) for i, f in enumerate(feats) if gtype(f) == "LineString"]
        if len(lines) != 1:
            kinds = [gtype(f) if isinstance(f, dict) else type(f).__name__ for f in feats]
            raise WaypointError(
                f"{where_file}: a FeatureCollection must hold exactly one LineString "
                f"feature; found {len(lines)} among geometries {kinds}",
                **fkw,
                value=len(lines),
                expected="exactly one LineString feature",
            )
        if len(feats) > 1:
            notes.append(
                f"used feature {lines[0][0]} (the LineString); ignored {len(feats) - 1} other "
                "feature(s)"
            )
        feature = lines[0][1]
        geom = feature["geometry"]
        props = feature.get("properties") or {}
    elif kind == "Feature":
        geom = doc.get("geometry") or {}
        props = doc.get("properties") or {}
    else:
        geom = doc
    gkind = geom.get("type") if isinstance(geom, dict) else None
    if gkind != "LineString":
        hint = "; split it into one LineString per file" if gkind == "MultiLineString" else ""
        raise WaypointError(
            f"{where_file}: geometry type {gkind!r} is not a LineString (expected a "
            f"LineString geometry, a Feature or a FeatureCollection with one){hint}",
            **fkw,
            value=gkind,
            expected="a LineString",
        )
    if not isinstance(props, dict):
        raise WaypointError(
            f"{where_file}: 'properties' is not an object", **fkw, value=props, expected="an object"
        )
    coords = geom.get("coordinates")
    if not isinstance(coords, list):
        raise WaypointError(
            f"{where_file}: LineString without a 'coordinates' list",
            **fkw,
            expected="a 'coordinates' list",
        )
    xy = np.zeros((len(coords), 2))
    has_z = False
    for i, c in enumerate(coords):
        where = f"{where_file}, vertex {i}"
        if not isinstance(c, list | tuple) or len(c) < 2:
            raise WaypointError(
                f"{where}: {c!r} is not a position [x, y]",
                **fkw,
                value=c,
                row=i,
                expected="a position [x, y]",
            )
        for k, name in enumerate(("x", "y")):
            xy[i, k] = _json_number(c[k], f"{where}, {name}", p, i, name)
        has_z |= len(c) > 2
    if has_z:
        notes.append("ignored the z coordinate of the vertices (the DEM gives elevation)")
    labels = [f"vertex {i}" for i in range(len(coords))]
    yaw = _prop_list(props, "yaw_deg", len(coords), where_file, p)
    t = _prop_list(props, "t", len(coords), where_file, p)
    check_path(where_file, xy, t, labels, p)
    declared = declared_crs(doc, props)
    rfc = declared is None and bool(np.all((np.abs(xy[:, 0]) <= 180) & (np.abs(xy[:, 1]) <= 90)))
    if rfc:
        declared = RFC7946_CRS
    frame = props.get("yaw_frame")
    if frame is None and "format" not in props and "planner" in props and kind == "Feature":
        frame = LEGACY_YAW_FRAME
        if yaw is not None:
            notes.append(
                "older planner GeoJSON (no 'format' property): yaw_deg read in the "
                "working grid's frame, as that writer used; rewrite it with "
                "energy_planner.geojson.write_path_from_work"
            )
    elif frame is None:
        frame = YAW_FRAME
    if frame not in (YAW_FRAME, LEGACY_YAW_FRAME):
        raise WaypointError(
            f"{where_file}: properties.yaw_frame {frame!r} is not known",
            **fkw,
            value=frame,
            column="yaw_frame",
            expected=f"{YAW_FRAME!r} or {LEGACY_YAW_FRAME!r}",
        )
    suspect = False
    if yaw is not None and frame == YAW_FRAME:
        geographic = _is_geographic_name(declared)
        suspect = warn_if_radians(yaw, xy, where_file, notes, geographic)
    if rfc:
        note = "GeoJSON without a 'crs' member: longitude, latitude (RFC 7946)"
    elif declared:
        note = f"GeoJSON declares CRS {declared}"
    else:
        note = (
            "GeoJSON without a 'crs' member, but its coordinates are not longitude, latitude "
            "(RFC 7946): taken in the DEM's CRS; declare it with a 'crs' member"
        )
        notes.append(note)
    extra = {
        k: v
        for k, v in props.items()
        if k not in ("format", "format_version", "crs", "yaw_frame", "yaw_deg", "t")
    }
    return Waypoints(
        xy=xy,
        yaw_rad=None if yaw is None else np.radians(yaw),
        t=t,
        crs_note=note,
        declared_crs=declared,
        notes=notes,
        path=p,
        yaw_frame=frame,
        properties=extra,
        yaw_radians_suspect=suspect,
    )


def _is_geographic_name(name: str | None) -> bool:
    if not name:
        return False
    if name.upper() in ("EPSG:4326", "OGC:CRS84", "EPSG:4269", "EPSG:4258"):
        return True
    try:
        from rasterio.crs import CRS

        return bool(CRS.from_user_input(name).is_geographic)
    except Exception:  # noqa: BLE001 - an unknown name: treat as projected
        return False


def _json_number(v: Any, where: str, p: Path | None, row: int, column: str) -> float:
    """One JSON number (or numeric string); bools, None, non-finite values are errors."""
    kw = {"path": p, "row": row, "column": column, "value": v, "expected": "a finite number"}
    if isinstance(v, str):
        s = v.strip()
        try:
            f = float(s)
        except ValueError:
            raise WaypointError(f"{where}: {s!r} is not a number", **kw) from None
    elif isinstance(v, bool) or not isinstance(v, int | float):
        raise WaypointError(f"{where}: {v!r} is not a number", **kw)
    else:
        try:
            f = float(v)
        except OverflowError:  # an integer beyond float range
            raise WaypointError(f"{where}: value {v!r} is too large", **kw) from None
    if not math.isfinite(f):
        raise WaypointError(f"{where}: value {v!r} is not finite (NaN or infinite)", **kw)
    return f


def _prop_list(
    props: dict[str, Any], key: str, n: int, where_file: str, p: Path | None
) -> np.ndarray | None:
    if key not in props or props[key] is None:
        return None
    vals = props[key]
    kw = {"path": p, "column": key, "expected": f"a list with one number per vertex ({n})"}
    if not isinstance(vals, list):
        raise WaypointError(
            f"{where_file}: properties.{key} is {vals!r}; expected a list with one number "
            f"per vertex ({n})",
            value=vals,
            **kw,
        )
    if len(vals) != n:
        raise WaypointError(
            f"{where_file}: properties.{key} has {len(vals)} value(s) for {n} vertices "
            "(expected one per vertex)",
            value=len(vals),
            **kw,
        )
    return np.array(
        [
            _json_number(v, f"{where_file}, properties.{key}[{i}]", p, i, key)
            for i, v in enumerate(vals)
        ],
        dtype=float,
    )


def check_path(
    where: str, xy: np.ndarray, t: np.ndarray | None, labels: list[str], p: Path | None = None
) -> None:
    """Checks shared by the path formats: at least two waypoints, times increasing."""
    if xy.shape[0] < 2:
        raise WaypointError(
            f"{where}: {xy.shape[0]} waypoint(s); a path needs at least 2 (one segment)",
            path=p,
            value=int(xy.shape[0]),
            expected="at least 2 waypoints",
        )
    if t is not None:
        dt = np.diff(t)
        bad = np.flatnonzero(~(dt > 0))
        if bad.size:
            i = int(bad[0])
            raise WaypointError(
                f"{where}: time does not increase at {labels[i + 1]}: t = {t[i + 1]:g} s "
                f"after t = {t[i]:g} s at {labels[i]} (times must increase strictly)",
                path=p,
                row=i + 1,
                column="t",
                value=float(t[i + 1]),
                expected=f"t > {t[i]:g} s",
            )


# ---------------------------------------------------------------------- yaw units
def radians_suspect(yaw_deg: Any, xy: Any, geographic: bool = False) -> dict[str, Any] | None:
    """Evidence that a ``yaw_deg`` column holds radians, or None.

    The rule (also in ``docs/terrain.md``, "Paths on the map"): the values are reported
    as radians when

    1. every value lies within +-2 pi (+-6.28) and the largest ``|value|`` is at least
       0.1 (a column of zeros means the same in both units), and
    2. the yaws fit the path's own segment directions better read as radians than read
       as degrees: either the mean angular distance, modulo 90 deg (a legged robot may
       walk forwards, backwards or sideways), is smaller by at least 5 deg, or read as
       radians they point along the segments (mean distance below 10 deg) while read as
       degrees they are off by more than 45 deg on average.

    The distance of a segment is the smaller of those of its two end vertices' yaws (a
    turn in place puts the new yaw on the vertex). Without a segment of non-zero length,
    condition 2 becomes: not every value is a whole number of degrees.

    Parameters
    ----------
    yaw_deg : array-like, shape (n,)
        The column as read.
    xy : array-like, shape (n, 2)
        The vertices, in the same frame as the yaw.
    geographic : bool
        ``xy`` is longitude, latitude (x steps are scaled by ``cos(latitude)``).

    Returns
    -------
    dict or None
        When suspect: ``rule`` (``"axes"``: the modulo-90 test, ``"forward"``: the
        along-the-path test, ``"no_length"``: the whole-degrees fallback) and the mean
        distances ``misfit_deg``, ``misfit_rad`` (degrees) of that rule.

    Examples
    --------
    >>> north = [[0, 0], [0, 10], [0, 20]]
    >>> radians_suspect([1.57, 1.57, 1.57], north) is not None   # radians, path due north
    True
    >>> radians_suspect([90.0, 90.0, 90.0], north) is None       # degrees
    True
    >>> radians_suspect([2.0, 1.0, 0.5], [[0, 0], [10, 0], [20, 0]]) is None  # degrees, east
    True
    """
    v = np.asarray(yaw_deg, dtype=float)
    pts = np.asarray(xy, dtype=float)
    if v.size < 2 or not np.isfinite(v).all():
        return None
    if np.max(np.abs(v)) > 2 * math.pi + 1e-9 or np.max(np.abs(v)) < 0.1:
        return None
    d = np.diff(pts, axis=0)
    if geographic:
        d[:, 0] *= np.cos(np.radians(np.clip(pts[:-1, 1], -89.9, 89.9)))
    ok = np.hypot(d[:, 0], d[:, 1]) > 0
    if not ok.any():
        return (
            None
            if np.allclose(v, np.round(v))
            else {"rule": "no_length", "misfit_deg": None, "misfit_rad": None}
        )
    h = np.arctan2(d[ok, 1], d[ok, 0])

    def misfit(yaw: np.ndarray, period: float) -> float:
        dists = []
        for end in (yaw[:-1][ok], yaw[1:][ok]):
            r = np.abs(np.asarray(wrap(end - h)))
            dists.append(np.abs(r - period * np.round(r / period)))
        return float(np.degrees(np.mean(np.minimum(*dists))))

    as_deg, as_rad = np.radians(v), v
    m90_deg, m90_rad = misfit(as_deg, math.pi / 2), misfit(as_rad, math.pi / 2)
    m360_deg, m360_rad = misfit(as_deg, 2 * math.pi), misfit(as_rad, 2 * math.pi)
    if m90_rad + 5.0 <= m90_deg:
        return {"rule": "axes", "misfit_deg": round(m90_deg, 1), "misfit_rad": round(m90_rad, 1)}
    if m360_rad < 10.0 and m360_deg > 45.0:
        return {
            "rule": "forward",
            "misfit_deg": round(m360_deg, 1),
            "misfit_rad": round(m360_rad, 1),
        }
    return None


def warn_if_radians(
    yaw_deg: np.ndarray, xy: np.ndarray, where_file: str, notes: list[str], geographic: bool = False
) -> bool:
    """Warn (``UserWarning``) and add a note when :func:`radians_suspect` says so.

    Returns True when it did.
    """
    ev = radians_suspect(yaw_deg, xy, geographic)
    if ev is None:
        return False
    if ev["rule"] == "axes":
        fit = (
            f" (read as radians they follow the path's segments, forwards, backwards or "
            f"sideways, within {ev['misfit_rad']:g} deg on average; read as degrees within "
            f"{ev['misfit_deg']:g} deg)"
        )
    elif ev["rule"] == "forward":
        fit = (
            f" (read as radians the robot faces along the path, within {ev['misfit_rad']:g} "
            f"deg on average; read as degrees it faces {ev['misfit_deg']:g} deg away from "
            "it, walking sideways or backwards)"
        )
    else:
        fit = ""
    msg = (
        f"{where_file}: yaw_deg values lie within +-6.28 and look like radians{fit}; "
        "yaw_deg is read as degrees. Convert with degrees = radians * 180 / pi."
    )
    warnings.warn(msg, UserWarning, stacklevel=4)
    notes.append(msg)
    return True


# ---------------------------------------------------------------------- yaw frames
def _xaxis_rotation(terrain: Any, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Angle (rad, CCW) of the DEM's local +x direction in the working CRS at (x, y)."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    src, dst = getattr(terrain, "source_crs", None), getattr(terrain, "crs", None)
    if src is None or dst is None or src == dst:
        return np.zeros(np.broadcast(x, y).shape)
    st = getattr(terrain, "source_transform", None)
    h = 1e-2 * abs(float(st.a)) if st is not None and st.a else 1e-6
    xb, yb = np.broadcast_arrays(x, y)
    wx0, wy0 = terrain.to_work(xb, yb)
    wx1, wy1 = terrain.to_work(xb + h, yb)
    return np.arctan2(np.asarray(wy1) - wy0, np.asarray(wx1) - wx0)


def yaw_to_work(terrain: Any, x: Any, y: Any, yaw_rad: Any) -> np.ndarray:
    """Yaw relative to the DEM's x axis -> yaw relative to the working grid's x axis.

    For a DEM in a metric projected CRS the two are the same. For a geographic DEM the
    map's x axis is the local east (along the parallel), which on the working UTM grid
    is turned by the meridian convergence (about a degree, more far from the zone's
    central meridian); the rotation is measured by transforming a point a hundredth of
    a pixel along +x.

    Parameters
    ----------
    terrain : Terrain
        Provides ``source_crs``, ``crs``, ``source_transform`` and ``to_work``.
    x, y : array-like
        Positions in the DEM's CRS.
    yaw_rad : array-like
        Yaw in radians CCW from the DEM's x axis.

    Returns
    -------
    ndarray
        Yaw in radians CCW from the working CRS's x axis (not wrapped).

    Examples
    --------
    >>> from energy_planner.terrain import Terrain
    >>> t = Terrain.from_function(lambda x, y: 0 * x, size=(10, 10))
    >>> yaw_to_work(t, [5.0], [5.0], [0.3]).tolist()
    [0.3]
    """
    return np.asarray(yaw_rad, dtype=float) + _xaxis_rotation(terrain, x, y)


def yaw_from_work(terrain: Any, x_work: Any, y_work: Any, yaw_rad: Any) -> np.ndarray:
    """Inverse of :func:`yaw_to_work`: working-grid yaw -> yaw from the DEM's x axis.

    Parameters
    ----------
    terrain : Terrain
        As in :func:`yaw_to_work`.
    x_work, y_work : array-like
        Positions in the working CRS.
    yaw_rad : array-like
        Yaw in radians CCW from the working grid's x axis.

    Returns
    -------
    ndarray
        Yaw in radians CCW from the DEM's x axis (not wrapped).
    """
    xs, ys = terrain.from_work(x_work, y_work)
    return np.asarray(yaw_rad, dtype=float) - _xaxis_rotation(terrain, xs, ys)
