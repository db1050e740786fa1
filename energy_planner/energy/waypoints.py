"""Waypoint files: CSV and GeoJSON LineString, in the DEM's own CRS.

Two formats describe a path to evaluate (``energy-planner energy``) or a planned path
(the planner writes the GeoJSON form, :func:`write_waypoints_geojson`):

CSV
    A header row is required. Columns ``x, y`` (the DEM's CRS; longitude, latitude for a
    geographic DEM), optional ``yaw_deg`` (body yaw, degrees counter-clockwise from the
    map's x axis) and optional ``t`` (seconds, strictly increasing). Other columns are
    ignored, with a note. Comma, semicolon or tab separated; blank lines and lines
    starting with ``#`` are skipped.
GeoJSON
    A ``LineString`` as a bare geometry, a ``Feature`` or a ``FeatureCollection`` with
    exactly one LineString feature, coordinates in the DEM's CRS. Optional
    ``properties.yaw_deg`` and ``properties.t``: lists with one value per vertex.

Yaw is degrees in files and radians in :class:`Waypoints` (design notes: files and the
command line give ``yaw_deg``, the Python API uses radians).

Examples
--------
>>> import tempfile, pathlib
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> _ = (d / "p.csv").write_text("x,y,yaw_deg\\n0,0,90\\n3,4,90\\n")
>>> w = read_waypoints(d / "p.csv")
>>> w.xy.tolist(), w.yaw_rad.round(6).tolist(), w.t
([[0.0, 0.0], [3.0, 4.0]], [1.570796, 1.570796], None)
>>> out = write_waypoints_geojson(d / "p.geojson", w.xy, w.yaw_rad)
>>> read_waypoints(out).yaw_rad.round(6).tolist()
[1.570796, 1.570796]
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.errors import EnergyPlannerError

__all__ = [
    "WaypointError",
    "WaypointIOError",
    "Waypoints",
    "read_waypoints",
    "waypoints_to_work",
    "write_waypoints_geojson",
    "yaw_from_work",
    "yaw_to_work",
]

#: Column names with a meaning in a waypoint CSV.
CSV_COLUMNS = ("x", "y", "yaw_deg", "t")
# column names a user may mean as yaw in other units: ignored, but said so
_YAW_LOOKALIKES = {"yaw", "yaw_rad", "theta", "heading", "heading_deg", "psi"}


class WaypointError(EnergyPlannerError, ValueError):
    """A waypoint file is malformed: missing column, bad value, wrong geometry."""


class WaypointIOError(EnergyPlannerError, OSError):
    """A waypoint file cannot be found or read."""


@dataclass
class Waypoints:
    """Waypoints read from a file, in the DEM's own CRS.

    Attributes
    ----------
    xy : ndarray, shape (n, 2)
        Coordinates in the DEM's CRS (longitude, latitude for a geographic DEM), n >= 2.
    yaw_rad : ndarray, shape (n,), or None
        Body yaw, radians counter-clockwise from the map's x axis, if the file gives it.
    t : ndarray, shape (n,), or None
        Times in seconds (strictly increasing), if the file gives them.
    crs_note : str
        What the file says about its coordinates (the CRS a GeoJSON declares, or that
        they are taken in the DEM's CRS).
    declared_crs : str or None
        The CRS a GeoJSON's legacy ``crs`` member names (e.g. ``"EPSG:32631"``), if any.
    notes : list of str
        Things the reader ignored or assumed (extra columns, a z coordinate, ...).
    path : pathlib.Path or None
        The file.
    """

    xy: np.ndarray
    yaw_rad: np.ndarray | None
    t: np.ndarray | None
    crs_note: str
    declared_crs: str | None = None
    notes: list[str] = field(default_factory=list)
    path: Path | None = None

    def __len__(self) -> int:
        return int(self.xy.shape[0])


# ---------------------------------------------------------------------- reading
def read_waypoints(path: str | Path) -> Waypoints:
    """Read waypoints from a CSV file or a GeoJSON LineString.

    The format is chosen by the extension (``.csv``, ``.txt``, ``.tsv`` -> CSV;
    ``.geojson``, ``.json`` -> GeoJSON), else by the first character (``{`` -> GeoJSON).

    Parameters
    ----------
    path : str or pathlib.Path
        The file (see the module docstring for both formats).

    Returns
    -------
    Waypoints

    Raises
    ------
    WaypointIOError
        The file does not exist or cannot be read.
    WaypointError
        A missing column, a non-numeric, empty or non-finite value, fewer than 2
        waypoints, times not strictly increasing, a ``yaw_deg``/``t`` list whose length
        differs from the number of vertices, or a GeoJSON that is not one LineString.
        The message names the file, the row (CSV line number) or vertex and column, and
        the value.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8-sig")
    except FileNotFoundError as exc:
        raise WaypointIOError(
            f"waypoint file {str(p)!r} does not exist (expected a CSV with columns "
            "x,y[,yaw_deg][,t] or a GeoJSON LineString)"
        ) from exc
    except (OSError, UnicodeDecodeError) as exc:
        raise WaypointIOError(f"cannot read waypoint file {str(p)!r}: {exc}") from exc
    suffix = p.suffix.lower()
    if suffix in (".geojson", ".json") or (
        suffix not in (".csv", ".txt", ".tsv") and text.lstrip().startswith("{")
    ):
        return _read_geojson(text, p)
    return _read_csv(text, p)


def _check_common(where: str, xy: np.ndarray, t: np.ndarray | None, labels: list[str]) -> None:
    """Checks shared by both formats: at least two waypoints, times increasing."""
    if xy.shape[0] < 2:
        raise WaypointError(
            f"{where}: {xy.shape[0]} waypoint(s); a path needs at least 2 (one segment)"
        )
    if t is not None:
        dt = np.diff(t)
        bad = np.flatnonzero(~(dt > 0))
        if bad.size:
            i = int(bad[0])
            raise WaypointError(
                f"{where}: time does not increase at {labels[i + 1]}: t = {t[i + 1]:g} s "
                f"after t = {t[i]:g} s at {labels[i]} (times must increase strictly)"
            )


def _number(raw: str, where: str) -> float:
    """Parse one numeric cell; empty, non-numeric and non-finite values are errors."""
    s = raw.strip()
    if s == "":
        raise WaypointError(f"{where}: empty value (expected a number)")
    try:
        v = float(s)
    except ValueError:
        raise WaypointError(f"{where}: {s!r} is not a number") from None
    if not math.isfinite(v):
        raise WaypointError(f"{where}: value {s!r} is not finite (NaN or infinite)")
    return v


def _read_csv(text: str, p: Path) -> Waypoints:
    lines = [
        (i + 1, line)
        for i, line in enumerate(text.splitlines())
        if line.strip() and not line.lstrip().startswith("#")
    ]
    if not lines:
        raise WaypointError(
            f"waypoint file {str(p)!r} is empty (expected a header x,y[,yaw_deg][,t] and "
            "at least 2 rows)"
        )
    header_line = lines[0][1]
    delim = max((",", ";", "\t"), key=header_line.count)
    rows = list(csv.reader([line for _, line in lines], delimiter=delim))
    header = [h.strip().lower() for h in rows[0]]
    where_file = f"waypoint file {str(p)!r}"
    missing = [c for c in ("x", "y") if c not in header]
    if missing:
        looks_numeric = all(_is_float(h) for h in header if h)
        hint = (
            "the first row looks like numbers: add a header row 'x,y' (optionally yaw_deg, t)"
            if looks_numeric
            else f"found columns {header}"
        )
        raise WaypointError(
            f"{where_file}: missing column(s) {', '.join(map(repr, missing))} in the header "
            f"(line {lines[0][0]}); expected x,y[,yaw_deg][,t]; {hint}"
        )
    dup = sorted({h for h in header if header.count(h) > 1 and h in CSV_COLUMNS})
    if dup:
        raise WaypointError(f"{where_file}: column(s) {', '.join(map(repr, dup))} appear twice")
    idx = {c: header.index(c) for c in CSV_COLUMNS if c in header}
    notes = []
    extra = [h for h in header if h not in CSV_COLUMNS]
    if extra:
        note = f"ignored column(s) {', '.join(map(repr, extra))}"
        odd = sorted(set(extra) & _YAW_LOOKALIKES)
        if odd:
            note += (
                f"; yaw is read only from 'yaw_deg' (degrees CCW from the map's x axis), "
                f"not from {', '.join(map(repr, odd))}"
            )
        notes.append(note)
    data = {c: [] for c in idx}
    labels = []
    for (lineno, _), row in zip(lines[1:], rows[1:], strict=True):
        if len(row) < len(header):
            raise WaypointError(
                f"{where_file}, line {lineno}: {len(row)} value(s) for {len(header)} "
                f"columns {header}"
            )
        for c, j in idx.items():
            data[c].append(_number(row[j], f"{where_file}, line {lineno}, column {c!r}"))
        labels.append(f"line {lineno}")
    xy = np.column_stack([data["x"], data["y"]]) if labels else np.zeros((0, 2))
    yaw = np.radians(np.asarray(data["yaw_deg"], dtype=float)) if "yaw_deg" in data else None
    t = np.asarray(data["t"], dtype=float) if "t" in data else None
    _check_common(where_file, xy, t, labels)
    return Waypoints(
        xy=xy,
        yaw_rad=yaw,
        t=t,
        crs_note="CSV: x, y taken in the DEM's CRS",
        notes=notes,
        path=p,
    )


def _is_float(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return False
    return True


def _read_geojson(text: str, p: Path) -> Waypoints:
    where_file = f"waypoint file {str(p)!r}"
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise WaypointError(f"{where_file} is not valid JSON: {exc}") from exc
    if not isinstance(doc, dict) or "type" not in doc:
        raise WaypointError(f"{where_file}: not a GeoJSON object (no 'type' member)")
    notes: list[str] = []
    declared = _declared_crs(doc)
    kind = doc["type"]
    props: dict[str, Any] = {}
    if kind == "FeatureCollection":
        feats = doc.get("features")
        if not isinstance(feats, list):
            raise WaypointError(f"{where_file}: FeatureCollection without a 'features' list")
        lines = [
            (i, f)
            for i, f in enumerate(feats)
            if isinstance(f, dict) and (f.get("geometry") or {}).get("type") == "LineString"
        ]
        if len(lines) != 1:
            kinds = [
                (f.get("geometry") or {}).get("type") if isinstance(f, dict) else type(f).__name__
                for f in feats
            ]
            raise WaypointError(
                f"{where_file}: a FeatureCollection must hold exactly one LineString "
                f"feature; found {len(lines)} among geometries {kinds}"
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
            f"LineString geometry, a Feature or a FeatureCollection with one){hint}"
        )
    if not isinstance(props, dict):
        raise WaypointError(f"{where_file}: 'properties' is not an object")
    coords = geom.get("coordinates")
    if not isinstance(coords, list):
        raise WaypointError(f"{where_file}: LineString without a 'coordinates' list")
    xy = np.zeros((len(coords), 2))
    has_z = False
    for i, c in enumerate(coords):
        where = f"{where_file}, vertex {i}"
        if not isinstance(c, list | tuple) or len(c) < 2:
            raise WaypointError(f"{where}: {c!r} is not a position [x, y]")
        for k, name in enumerate(("x", "y")):
            xy[i, k] = _json_number(c[k], f"{where}, {name}")
        has_z |= len(c) > 2
    if has_z:
        notes.append("ignored the z coordinate of the vertices (the DEM gives elevation)")
    labels = [f"vertex {i}" for i in range(len(coords))]
    yaw = _prop_list(props, "yaw_deg", len(coords), where_file)
    t = _prop_list(props, "t", len(coords), where_file)
    if yaw is not None:
        yaw = np.radians(yaw)
    _check_common(where_file, xy, t, labels)
    note = (
        f"GeoJSON declares CRS {declared}"
        if declared
        else "GeoJSON: coordinates taken in the DEM's CRS (no 'crs' member)"
    )
    return Waypoints(
        xy=xy, yaw_rad=yaw, t=t, crs_note=note, declared_crs=declared, notes=notes, path=p
    )


def _json_number(v: Any, where: str) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float):
        if isinstance(v, str):
            return _number(v, where)
        raise WaypointError(f"{where}: {v!r} is not a number")
    if not math.isfinite(v):
        raise WaypointError(f"{where}: value {v!r} is not finite (NaN or infinite)")
    return float(v)


def _prop_list(props: dict[str, Any], key: str, n: int, where_file: str) -> np.ndarray | None:
    if key not in props or props[key] is None:
        return None
    vals = props[key]
    if not isinstance(vals, list):
        raise WaypointError(
            f"{where_file}: properties.{key} is {vals!r}; expected a list with one number "
            f"per vertex ({n})"
        )
    if len(vals) != n:
        raise WaypointError(
            f"{where_file}: properties.{key} has {len(vals)} value(s) for {n} vertices "
            "(expected one per vertex)"
        )
    return np.array(
        [_json_number(v, f"{where_file}, properties.{key}[{i}]") for i, v in enumerate(vals)]
    )


def _declared_crs(doc: dict[str, Any]) -> str | None:
    """The CRS named by a GeoJSON 2008 ``crs`` member (as GDAL writes it), if any."""
    crs = doc.get("crs")
    if not isinstance(crs, dict):
        return None
    name = (crs.get("properties") or {}).get("name")
    if not isinstance(name, str):
        return None
    # urn:ogc:def:crs:EPSG::32631 -> EPSG:32631 ; OGC:1.3:CRS84 -> OGC:CRS84
    if name.lower().startswith("urn:ogc:def:crs:"):
        parts = name.split(":")
        auth, code = parts[4], parts[-1]
        return f"{auth}:{code}"
    return name


# ---------------------------------------------------------------------- writing
def write_waypoints_geojson(
    path: str | Path,
    xy: Any,
    yaw_rad: Sequence[float] | np.ndarray | None = None,
    *,
    t: Sequence[float] | np.ndarray | None = None,
    crs: str | None = None,
    properties: dict[str, Any] | None = None,
) -> Path:
    """Write a path as a GeoJSON FeatureCollection with one LineString feature.

    The format :func:`read_waypoints` reads (and the planner writes).

    Parameters
    ----------
    path : str or pathlib.Path
        Output file.
    xy : array-like, shape (n, 2)
        Vertices in the DEM's CRS.
    yaw_rad : array-like, shape (n,), optional
        Body yaw in radians CCW from the map's x axis, written as ``properties.yaw_deg``.
    t : array-like, shape (n,), optional
        Times, written as ``properties.t``.
    crs : str, optional
        A CRS name (e.g. ``"EPSG:32631"``) written as the legacy ``crs`` member that GDAL
        and QGIS read (RFC 7946 GeoJSON is WGS 84 only; a projected path needs it).
    properties : dict, optional
        Extra feature properties (e.g. ``energy_j``).

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    WaypointError
        Bad shapes or non-finite values.
    """
    xy = np.asarray(xy, dtype=float)
    n = xy.shape[0] if xy.ndim == 2 else -1
    if xy.ndim != 2 or xy.shape[1] != 2 or n < 2 or not np.isfinite(xy).all():
        raise WaypointError(f"xy must be a finite (n >= 2, 2) array; got shape {xy.shape}")
    props: dict[str, Any] = dict(properties or {})
    for key, vals, scale in (("yaw_deg", yaw_rad, math.degrees), ("t", t, float)):
        if vals is None:
            continue
        arr = np.asarray(vals, dtype=float)
        if arr.shape != (n,) or not np.isfinite(arr).all():
            raise WaypointError(f"{key}: expected {n} finite values, got shape {arr.shape}")
        props[key] = [scale(float(v)) for v in arr]
    doc: dict[str, Any] = {"type": "FeatureCollection"}
    if crs:
        doc["crs"] = {"type": "name", "properties": {"name": str(crs)}}
    doc["features"] = [
        {
            "type": "Feature",
            "properties": props,
            "geometry": {"type": "LineString", "coordinates": xy.tolist()},
        }
    ]
    p = Path(path)
    p.write_text(json.dumps(doc, indent=1) + "\n")
    return p


# ---------------------------------------------------------------------- CRS
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

    ``x_work, y_work`` are positions in the working CRS.
    """
    xs, ys = terrain.from_work(x_work, y_work)
    return np.asarray(yaw_rad, dtype=float) - _xaxis_rotation(terrain, xs, ys)


def waypoints_to_work(terrain: Any, wp: Waypoints) -> tuple[np.ndarray, np.ndarray | None]:
    """Waypoints (DEM CRS) -> ``(xy, yaw)`` in the working CRS for :func:`path_energy`."""
    xw, yw = terrain.to_work(wp.xy[:, 0], wp.xy[:, 1])
    xy = np.column_stack([np.atleast_1d(xw), np.atleast_1d(yw)])
    yaw = None if wp.yaw_rad is None else yaw_to_work(terrain, wp.xy[:, 0], wp.xy[:, 1], wp.yaw_rad)
    return xy, yaw
