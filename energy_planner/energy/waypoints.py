r"""Read waypoint files (CSV or GeoJSON LineString, in the DEM's own CRS) and convert them.

Three formats describe a path to evaluate (``energy-planner energy``) or a planned path
(the planner writes the GeoJSON form, :mod:`energy_planner.geojson`):

CSV
    A header row is required. Columns ``x, y`` (the DEM's CRS; longitude, latitude for a
    geographic DEM), optional ``yaw_deg`` (body yaw, degrees counter-clockwise from the
    map's x axis) and optional ``t`` (seconds, strictly increasing). Other columns are
    ignored, with a note. Comma, semicolon or tab separated; blank lines and lines
    starting with ``#`` are skipped.
GeoJSON
    The project's path format (:mod:`energy_planner.geojson`: CRS recorded, yaw frame
    stated), or any ``LineString`` as a bare geometry, a ``Feature`` or a
    ``FeatureCollection`` with exactly one LineString feature, coordinates in the DEM's
    CRS. Optional ``properties.yaw_deg`` and ``properties.t``: lists with one value per
    vertex. Older planner files (yaw in the working grid's frame) are read with a note.
ROS bag
    A ``nav_msgs/msg/Path`` (or ``Odometry`` / ``PoseStamped`` messages, one pose
    each), as ``plan --bag`` writes it (:mod:`energy_planner.io.ros2`: the map frame
    and its CRS in the bag's metadata; without them, the frame's x, y are taken in the
    DEM's CRS).

Yaw is degrees in files and radians in :class:`Waypoints` (design notes: files and the
command line give ``yaw_deg``, the Python API uses radians), counter-clockwise from the
DEM CRS's +x axis at the vertex (local east for a geographic DEM). A ``yaw_deg`` column
that looks like radians gets a ``UserWarning`` and a note
(:func:`energy_planner.geojson.radians_suspect` gives the rule).

Examples
--------
>>> import tempfile, pathlib
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> _ = (d / "p.csv").write_text("x,y,yaw_deg\n0,0,90\n3,4,90\n")
>>> w = read_waypoints(d / "p.csv")
>>> w.xy.tolist(), w.yaw_rad.round(6).tolist(), w.t
([[0.0, 0.0], [3.0, 4.0]], [1.570796, 1.570796], None)
>>> out = write_waypoints_geojson(d / "p.geojson", w.xy, w.yaw_rad)
>>> read_waypoints(out).yaw_rad.round(6).tolist()
[1.570796, 1.570796]
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.errors import WaypointError, WaypointIOError
from energy_planner.geojson import (
    LEGACY_YAW_FRAME,
    Waypoints,
    check_path,
    parse_path,
    warn_if_radians,
    write_path,
    yaw_from_work,
    yaw_to_work,
)
from energy_planner.io.path_format import is_bag
from energy_planner.io.path_read import read_text

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


# ---------------------------------------------------------------------- reading
def read_waypoints(path: str | Path, topic: str | None = None) -> Waypoints:
    """Read waypoints from a CSV file, a GeoJSON LineString or a ROS bag.

    The format is chosen by the extension (``.csv``, ``.txt``, ``.tsv`` -> CSV;
    ``.geojson``, ``.json`` -> GeoJSON; a folder or ``.bag``, ``.mcap``, ``.db3`` -> a
    ROS bag, :func:`energy_planner.io.ros2.read_path_bag`), else by the first character
    (``{`` -> GeoJSON).

    Parameters
    ----------
    path : str or pathlib.Path
        The file (see the module docstring for the formats).
    topic : str, optional
        A ROS bag's topic to read (default: its only path topic).

    Returns
    -------
    Waypoints
        In the file's CRS.

    Raises
    ------
    WaypointIOError
        No such file, or not readable as UTF-8 text.
    WaypointError
        A missing column, a non-numeric, empty or non-finite value, fewer than 2
        waypoints, times not strictly increasing, a ``yaw_deg``/``t`` list whose length
        differs from the number of vertices, or a GeoJSON that is not one LineString.
        The message names the file, the row (CSV line number) or vertex and column, and
        the value.
    """
    p = Path(path)
    if is_bag(p):
        from energy_planner.io.ros2 import read_path_bag

        return read_path_bag(p, topic)
    text = read_text(
        p, "waypoint file", "a CSV with columns x,y[,yaw_deg][,t] or a GeoJSON LineString",
        expected="a CSV x,y[,yaw_deg][,t] or a GeoJSON LineString",
    )  # fmt: skip
    suffix = p.suffix.lower()
    if suffix in (".geojson", ".json") or (
        suffix not in (".csv", ".txt", ".tsv") and text.lstrip().startswith("{")
    ):
        return parse_path(text, p)
    return _read_csv(text, p)


def _number(raw: str, where: str, **fields: Any) -> float:
    """Parse one numeric cell; empty, non-numeric and non-finite values are errors."""
    s = raw.strip()
    kw = {"value": raw, "expected": "a finite number", **fields}
    if s == "":
        raise WaypointError(f"{where}: empty value (expected a number)", **kw)
    try:
        v = float(s)
    except ValueError:
        raise WaypointError(f"{where}: {s!r} is not a number", **kw) from None
    if not math.isfinite(v):
        raise WaypointError(f"{where}: value {s!r} is not finite (NaN or infinite)", **kw)
    return v


def _read_csv(text: str, p: Path) -> Waypoints:
    lines = [
        (i + 1, line)
        for i, line in enumerate(text.splitlines())
        if line.strip() and not line.lstrip().startswith("#")
    ]
    where_file = f"waypoint file {str(p)!r}"
    expected = "a header x,y[,yaw_deg][,t] and at least 2 rows"
    if not lines:
        raise WaypointError(
            f"waypoint file {str(p)!r} is empty (expected a header x,y[,yaw_deg][,t] and "
            "at least 2 rows)",
            path=p,
            expected=expected,
        )
    header_line = lines[0][1]
    delim = max((",", ";", "\t"), key=header_line.count)
    try:
        rows = list(csv.reader([line for _, line in lines], delimiter=delim))
    except csv.Error as exc:  # e.g. a NUL byte, a field beyond the csv field limit
        raise WaypointError(
            f"{where_file} is not a readable CSV: {exc}", path=p, expected=expected
        ) from exc
    header = [h.strip().lower() for h in rows[0]]
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
            f"(line {lines[0][0]}); expected x,y[,yaw_deg][,t]; {hint}",
            path=p,
            value=header,
            column=missing[0],
            expected=expected,
        )
    dup = sorted({h for h in header if header.count(h) > 1 and h in CSV_COLUMNS})
    if dup:
        raise WaypointError(
            f"{where_file}: column(s) {', '.join(map(repr, dup))} appear twice",
            path=p,
            column=dup[0],
            expected="each column once",
        )
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
                f"columns {header}",
                path=p,
                row=lineno,
                value=row,
                expected=f"{len(header)} values",
            )
        for c, j in idx.items():
            data[c].append(
                _number(
                    row[j],
                    f"{where_file}, line {lineno}, column {c!r}",
                    path=p,
                    row=lineno,
                    column=c,
                )
            )
        labels.append(f"line {lineno}")
    xy = np.column_stack([data["x"], data["y"]]) if labels else np.zeros((0, 2))
    yaw_deg = np.asarray(data["yaw_deg"], dtype=float) if "yaw_deg" in data else None
    t = np.asarray(data["t"], dtype=float) if "t" in data else None
    check_path(where_file, xy, t, labels, p)
    suspect = yaw_deg is not None and warn_if_radians(yaw_deg, xy, where_file, notes)
    return Waypoints(
        xy=xy,
        yaw_rad=None if yaw_deg is None else np.radians(yaw_deg),
        t=t,
        crs_note="CSV: x, y taken in the DEM's CRS",
        notes=notes,
        path=p,
        yaw_radians_suspect=suspect,
    )


def _is_float(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return False
    return True


# ---------------------------------------------------------------------- writing
#: The path writer under its older name, kept for existing callers: ``xy`` and ``yaw_rad``
#: in the DEM's own CRS (:func:`energy_planner.geojson.write_path`; for poses on a terrain's
#: working grid, :func:`energy_planner.geojson.write_path_from_work`).
write_waypoints_geojson = write_path


# ---------------------------------------------------------------------- CRS
def waypoints_to_work(terrain: Any, wp: Waypoints) -> tuple[np.ndarray, np.ndarray | None]:
    """Waypoints (DEM CRS) -> ``(xy, yaw)`` in the working CRS for :func:`path_energy`.

    Parameters
    ----------
    terrain : Terrain
        The map (``to_work`` raises :class:`~energy_planner.errors.CoordinateError` for
        coordinates that are not in its CRS).
    wp : Waypoints
        As read; yaw in the CRS's frame is turned by the meridian convergence
        (:func:`yaw_to_work`), yaw of an older planner file (``wp.yaw_frame ==
        "work_x_ccw"``) is already in the working frame.

    Returns
    -------
    xy : ndarray, shape (n, 2)
        Working-CRS coordinates.
    yaw : ndarray, shape (n,), or None
        Yaw in radians CCW from the working grid's +x axis.
    """
    declared = getattr(wp, "declared_crs", None)
    if declared is not None and terrain.crs is not None and not _is_dem_crs(declared, terrain):
        return _declared_to_work(terrain, wp, declared)
    xw, yw = terrain.to_work(wp.xy[:, 0], wp.xy[:, 1])
    xy = np.column_stack([np.atleast_1d(xw), np.atleast_1d(yw)])
    if wp.yaw_rad is None:
        return xy, None
    if wp.yaw_frame == LEGACY_YAW_FRAME:
        return xy, np.asarray(wp.yaw_rad, dtype=float)
    return xy, yaw_to_work(terrain, wp.xy[:, 0], wp.xy[:, 1], wp.yaw_rad)


def _is_dem_crs(declared: str, terrain: Any) -> bool:
    from rasterio.crs import CRS
    from rasterio.errors import CRSError

    try:
        return CRS.from_user_input(declared) == terrain.source_crs
    except CRSError as exc:
        raise WaypointError(
            f"the waypoint file declares CRS {declared!r}, which PROJ does not know ({exc})",
            value=declared,
            expected="an EPSG code or a PROJ CRS name",
        ) from exc


def _declared_to_work(
    terrain: Any, wp: Waypoints, declared: str
) -> tuple[np.ndarray, np.ndarray | None]:
    """Waypoints in the CRS their file declares (not the DEM's) -> the working grid."""
    from energy_planner.errors import CoordinateError, extent_text
    from energy_planner.io import reproject_xy, x_axis_angle

    x, y = reproject_xy(declared, terrain.crs, wp.xy[:, 0], wp.xy[:, 1])
    bad = ~(np.isfinite(x) & np.isfinite(y))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise CoordinateError(
            f"waypoint {i} ({wp.xy[i, 0]:.10g}, {wp.xy[i, 1]:.10g}) has no position on the map: "
            f"the file says its coordinates are in {declared}; the map covers "
            f"{extent_text(terrain.source_bounds, terrain.source_crs)}",
            value=(float(wp.xy[i, 0]), float(wp.xy[i, 1])),
            crs=declared,
            path=wp.path,
        )
    xy = np.column_stack([x, y])
    if wp.yaw_rad is None:
        return xy, None
    if wp.yaw_frame == LEGACY_YAW_FRAME:
        return xy, np.asarray(wp.yaw_rad, dtype=float)
    turn = x_axis_angle(declared, terrain.crs, wp.xy[:, 0], wp.xy[:, 1])
    return xy, np.asarray(wp.yaw_rad, dtype=float) + turn
