"""Reading paths: the project's path format, any LineString GeoJSON, older planner files.

See :mod:`energy_planner.geojson`; the checks name the file, the vertex and the value.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.errors import WaypointError, WaypointIOError
from energy_planner.io.geojson import RFC7946_CRS, declared_crs
from energy_planner.io.path_format import LEGACY_YAW_FRAME, YAW_FRAME, Waypoints
from energy_planner.io.yaw import warn_if_radians

__all__ = ["check_path", "parse_path", "read_path"]


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
    return parse_path(read_text(p, "path file", "a GeoJSON LineString"), p)


def read_text(p: Path, what: str, form: str, expected: str | None = None) -> str:
    """The UTF-8 text (BOM dropped) of the file ``p``, a ``what`` in the form ``form``.

    Raises
    ------
    WaypointIOError
        The file does not exist (naming ``form`` and, as the error's ``expected``,
        ``expected``) or cannot be read.
    """
    try:
        return p.read_text(encoding="utf-8-sig")
    except FileNotFoundError as exc:
        raise WaypointIOError(
            f"{what} {str(p)!r} does not exist (expected {form})", path=p, expected=expected
        ) from exc
    except (OSError, UnicodeDecodeError) as exc:
        raise WaypointIOError(f"cannot read {what} {str(p)!r}: {exc}", path=p) from exc


def parse_path(text: str, p: Path | None = None) -> Waypoints:
    """Parse GeoJSON text as a path (see :func:`read_path`); ``p`` names it in messages."""
    where_file = f"waypoint file {str(p)!r}" if p is not None else "GeoJSON path"
    doc = _load_doc(text, where_file, p)
    notes: list[str] = []
    geom, props = _line_feature(doc, where_file, p, notes)
    xy = _coordinates(geom, where_file, p, notes)
    n = xy.shape[0]
    yaw = _prop_list(props, "yaw_deg", n, where_file, p)
    t = _prop_list(props, "t", n, where_file, p)
    check_path(where_file, xy, t, [f"vertex {i}" for i in range(n)], p)
    declared, note = _crs_of(doc, props, xy, notes)
    frame = _yaw_frame(props, doc["type"], yaw is not None, where_file, p, notes)
    suspect = False
    if yaw is not None and frame == YAW_FRAME:
        geographic = _is_geographic_name(declared)
        suspect = warn_if_radians(yaw, xy, where_file, notes, geographic)
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


def _load_doc(text: str, where_file: str, p: Path | None) -> dict[str, Any]:
    """The JSON object with a ``type`` member."""
    try:
        doc = json.loads(text)
    except (json.JSONDecodeError, RecursionError) as exc:
        raise WaypointError(
            f"{where_file} is not valid JSON: {exc}", path=p, expected="a GeoJSON LineString"
        ) from exc
    if not isinstance(doc, dict) or "type" not in doc:
        raise WaypointError(
            f"{where_file}: not a GeoJSON object (no 'type' member)",
            path=p,
            expected="a GeoJSON object",
        )
    return doc


def _gtype(f: Any) -> Any:
    g = f.get("geometry") if isinstance(f, dict) else None
    return g.get("type") if isinstance(g, dict) else None


def _member_list(obj: dict[str, Any], key: str, kind: str, where_file: str, p: Path | None) -> list:
    """``obj[key]``, which must be a list (``WaypointError`` naming the ``kind`` otherwise)."""
    value = obj.get(key)
    if not isinstance(value, list):
        raise WaypointError(
            f"{where_file}: {kind} without a {key!r} list", path=p, expected=f"a {key!r} list"
        )
    return value


def _line_feature(
    doc: dict[str, Any], where_file: str, p: Path | None, notes: list[str]
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The one LineString geometry and its properties (a geometry, Feature or collection)."""
    kind = doc["type"]
    props: Any = {}
    if kind == "FeatureCollection":
        feats = _member_list(doc, "features", "FeatureCollection", where_file, p)
        lines = [(i, f) for i, f in enumerate(feats) if _gtype(f) == "LineString"]
        if len(lines) != 1:
            kinds = [_gtype(f) if isinstance(f, dict) else type(f).__name__ for f in feats]
            raise WaypointError(
                f"{where_file}: a FeatureCollection must hold exactly one LineString "
                f"feature; found {len(lines)} among geometries {kinds}",
                path=p,
                value=len(lines),
                expected="exactly one LineString feature",
            )
        if len(feats) > 1:
            notes.append(
                f"used feature {lines[0][0]} (the LineString); ignored {len(feats) - 1} other "
                "feature(s)"
            )
        geom = lines[0][1]["geometry"]
        props = lines[0][1].get("properties") or {}
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
            path=p,
            value=gkind,
            expected="a LineString",
        )
    if not isinstance(props, dict):
        raise WaypointError(
            f"{where_file}: 'properties' is not an object", path=p, value=props,
            expected="an object",
        )  # fmt: skip
    return geom, props


def _coordinates(
    geom: dict[str, Any], where_file: str, p: Path | None, notes: list[str]
) -> np.ndarray:
    """The LineString's positions as an (n, 2) array (a z coordinate is ignored)."""
    coords = _member_list(geom, "coordinates", "LineString", where_file, p)
    xy = np.zeros((len(coords), 2))
    has_z = False
    for i, c in enumerate(coords):
        where = f"{where_file}, vertex {i}"
        if not isinstance(c, list | tuple) or len(c) < 2:
            raise WaypointError(
                f"{where}: {c!r} is not a position [x, y]",
                path=p,
                value=c,
                row=i,
                expected="a position [x, y]",
            )
        for k, name in enumerate(("x", "y")):
            xy[i, k] = _json_number(c[k], f"{where}, {name}", p, i, name)
        has_z |= len(c) > 2
    if has_z:
        notes.append("ignored the z coordinate of the vertices (the DEM gives elevation)")
    return xy


def _crs_of(
    doc: dict[str, Any], props: dict[str, Any], xy: np.ndarray, notes: list[str]
) -> tuple[str | None, str]:
    """The file's CRS (declared; else RFC 7946 lon/lat when the values can be) and a note."""
    declared = declared_crs(doc, props)
    if declared is not None:
        return declared, f"GeoJSON declares CRS {declared}"
    if np.all((np.abs(xy[:, 0]) <= 180) & (np.abs(xy[:, 1]) <= 90)):
        return RFC7946_CRS, "GeoJSON without a 'crs' member: longitude, latitude (RFC 7946)"
    note = (
        "GeoJSON without a 'crs' member, but its coordinates are not longitude, latitude "
        "(RFC 7946): taken in the DEM's CRS; declare it with a 'crs' member"
    )
    notes.append(note)
    return None, note


def _yaw_frame(
    props: dict[str, Any], kind: str, has_yaw: bool, where_file: str, p: Path | None,
    notes: list[str],
) -> str:  # fmt: skip
    """The frame of ``yaw_deg``: the CRS's x axis, or the working grid's (older files)."""
    frame = props.get("yaw_frame")
    if frame is None and "format" not in props and "planner" in props and kind == "Feature":
        if has_yaw:
            notes.append(
                "older planner GeoJSON (no 'format' property): yaw_deg read in the "
                "working grid's frame, as that writer used; rewrite it with "
                "energy_planner.geojson.write_path_from_work"
            )
        return LEGACY_YAW_FRAME
    if frame is None:
        return YAW_FRAME
    if frame not in (YAW_FRAME, LEGACY_YAW_FRAME):
        raise WaypointError(
            f"{where_file}: properties.yaw_frame {frame!r} is not known",
            path=p,
            value=frame,
            column="yaw_frame",
            expected=f"{YAW_FRAME!r} or {LEGACY_YAW_FRAME!r}",
        )
    return frame


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
