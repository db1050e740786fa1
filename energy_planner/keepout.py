"""Keep-out areas: read (with their CRS), put on the working grid, rasterized, checked.

Keep-out areas come from a GeoJSON file (Polygon / MultiPolygon geometries, Features or a
FeatureCollection) in longitude/latitude as RFC 7946 says, or in the CRS the file declares
(``crs`` member); Python callers may give shapely geometries in the DEM's CRS. They are
reprojected to the working grid and

* rasterized onto the terrain grid as the ``blocked`` mask of
  :class:`energy_planner.energy.MotionCost` (a cell is blocked when its centre lies
  within one cell diagonal of a polygon, so a motion sampled at sub-cell steps cannot
  slip through a corner), which is what the planners see
  (:attr:`energy_planner.problem.Problem.cost`); and
* checked exactly with shapely on a path's segments (:func:`keep_out_violation`).

This module sits below planning: :class:`energy_planner.problem.Problem` builds its
motion cost from it.

Examples
--------
>>> from shapely.geometry import box
>>> class T:  # a 4 x 4 grid of 1 m cells, centre of cell (0, 0) at (0.5, 3.5)
...     grid = (0.5, 3.5, 1.0, -1.0)
...     elevation = np.zeros((4, 4))
>>> rasterize_keep_out([box(2.2, 2.2, 2.8, 2.8)], T()).astype(int)
array([[0, 1, 1, 1],
       [0, 1, 1, 1],
       [0, 1, 1, 1],
       [0, 0, 0, 0]])
>>> keep_out_violation(np.array([[0.5, 0.5, 0.0], [3.5, 0.5, 0.0]]), [box(2.2, 2.2, 2.8, 2.8)])
>>> keep_out_violation(np.array([[0.5, 2.5, 0.0], [3.5, 2.5, 0.0]]), [box(2.2, 2.2, 2.8, 2.8)])
'segment 0 from (0.50, 2.50) to (3.50, 2.50) crosses keep-out area 0'
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.errors import PlanningConfigError

__all__ = [
    "load_keep_out",
    "check_valid_geometries",
    "to_work_geometries",
    "keep_out_geometries",
    "rasterize_keep_out",
    "keep_out_violation",
]


def load_keep_out(path: str | Path) -> list[Any]:
    """Read keep-out polygons from a GeoJSON file, with their CRS.

    The file follows RFC 7946: longitude, latitude (WGS 84) unless it declares another
    CRS (the 2008 ``crs`` member that GDAL and QGIS write, or ``properties.crs``); see
    :func:`energy_planner.io.read_geometries`. :func:`to_work_geometries` reprojects them.

    Parameters
    ----------
    path : str or Path
        GeoJSON FeatureCollection, Feature or bare geometry; Polygon or MultiPolygon.

    Returns
    -------
    energy_planner.io.Geometries
        A list of shapely geometries in the file's coordinates; ``.crs`` names their CRS.

    Raises
    ------
    PlanningConfigError
        If the file is missing, is not JSON/GeoJSON, holds no polygon, an invalid one,
        or coordinates that are not longitude/latitude without a declared CRS.
    """
    from energy_planner.io import read_geometries

    out = read_geometries(path, what="keep-out")
    check_valid_geometries(out, str(path))
    return out


def check_valid_geometries(geoms: Sequence[Any], source: str = "keep_out") -> None:
    """Raise :class:`PlanningConfigError` naming the first invalid polygon and why.

    A self-intersecting ("bow-tie") polygon has no well-defined inside: shapely's
    ``explain_validity`` says where it breaks. ``source`` is the file (or a name).

    Examples
    --------
    >>> from shapely.geometry import Polygon
    >>> check_valid_geometries([Polygon([(0, 0), (2, 2), (2, 0), (0, 2)])], "ko.geojson")
    Traceback (most recent call last):
    ...
    energy_planner.errors.PlanningConfigError: keep-out geometry 0 in 'ko.geojson' is not a valid polygon: Self-intersection[1 1]; redraw it without crossing edges (or split it in two)
    """  # noqa: E501
    from shapely.validation import explain_validity

    for k, g in enumerate(geoms):
        if not g.is_valid:
            why = explain_validity(g)
            raise PlanningConfigError(
                f"keep-out geometry {k} in {source!r} is not a valid polygon: {why}; "
                "redraw it without crossing edges (or split it in two)",
                path=source,
                value=k,
                param="keep_out",
                expected="a valid (non-self-intersecting) polygon",
                hint=why,
            )


def to_work_geometries(geoms: Sequence[Any], terrain) -> list[Any]:
    """Transform keep-out geometries to the terrain's working CRS.

    Geometries read from a file (:func:`load_keep_out`) carry their CRS (``.crs``) and
    are reprojected from it; plain shapely geometries are in the DEM's own CRS. A
    geometry wholly outside the map is reported with a
    :class:`~energy_planner.errors.GeometryOutsideMapWarning` (it cannot keep the plan
    out of anything, and most often means the wrong CRS), never dropped silently.

    Raises
    ------
    PlanningConfigError
        A vertex has no position in the working CRS.
    """
    import shapely

    crs = getattr(geoms, "crs", None)
    source = getattr(geoms, "source", "") or "keep_out"
    if crs is not None and terrain.crs is not None:
        from energy_planner.io import reproject_geometries

        out = reproject_geometries(geoms, crs, terrain.crs)
        for k, g in enumerate(out):
            if not np.isfinite(shapely.get_coordinates(g)).all():
                raise PlanningConfigError(
                    f"keep-out geometry {k} in {source!r} ({crs}) has no position in the "
                    f"map's CRS {terrain.crs}: are its coordinates in {crs}?",
                    path=source, value=k, param="keep_out", crs=str(crs),
                )  # fmt: skip
    else:

        def fwd(coords: np.ndarray) -> np.ndarray:
            x, y = terrain.to_work(coords[:, 0], coords[:, 1])
            return np.column_stack([np.atleast_1d(x), np.atleast_1d(y)])

        out = [shapely.transform(g, fwd) for g in geoms]
    _warn_outside(out, geoms, crs, source, terrain)
    return out


def keep_out_geometries(keep_out: str | Path | Sequence[Any] | None, terrain) -> list[Any]:
    """A request's keep-out areas (``Limits.keep_out``) in the terrain's working CRS.

    A path is read with :func:`load_keep_out` (RFC 7946 unless the file declares a CRS);
    geometries are checked and taken in their ``.crs`` or the DEM's own CRS
    (:func:`to_work_geometries`). ``None`` gives an empty list.
    """
    if keep_out is None:
        return []
    if isinstance(keep_out, str | Path):
        raw = load_keep_out(keep_out)
    else:
        raw = keep_out if hasattr(keep_out, "crs") else list(keep_out)
        check_valid_geometries(raw)
    return to_work_geometries(raw, terrain)


def _warn_outside(work: list[Any], given: Sequence[Any], crs: Any, source: str, terrain) -> None:
    """A :class:`GeometryOutsideMapWarning` for each geometry wholly off the map."""
    import warnings

    from shapely.geometry import box

    from energy_planner.errors import GeometryOutsideMapWarning, extent_text, fmt_num

    bounds = getattr(terrain, "bounds", None)
    if bounds is None:
        return
    frame = box(*bounds)
    src_crs = crs if crs is not None else getattr(terrain, "source_crs", None)
    src_bounds = getattr(terrain, "source_bounds", bounds)
    for k, g in enumerate(work):
        if g.intersects(frame):
            continue
        gb = ", ".join(fmt_num(v) for v in given[k].bounds)
        warnings.warn(
            f"keep-out geometry {k} in {source!r} lies wholly outside the map and is not "
            f"used: its bounds ({gb}) in {src_crs}; the map covers "
            f"{extent_text(src_bounds, getattr(terrain, 'source_crs', None))}. A GeoJSON file "
            "without a 'crs' member is longitude/latitude (RFC 7946)",
            GeometryOutsideMapWarning,
            stacklevel=3,
        )


def rasterize_keep_out(geoms: Sequence[Any], terrain) -> np.ndarray:
    """Boolean mask on the terrain grid: cells within one cell diagonal of a polygon.

    Parameters
    ----------
    geoms : sequence of shapely geometries
        In the working CRS.
    terrain : Terrain
        Supplies ``grid`` and the grid shape (``elevation``).
    """
    import shapely
    from shapely.ops import unary_union

    rows, cols = np.shape(terrain.elevation)
    if not geoms:
        return np.zeros((rows, cols), dtype=bool)
    x0, y0, dx, dy = terrain.grid
    margin = math.hypot(dx, dy)
    zone = unary_union(list(geoms)).buffer(margin)
    shapely.prepare(zone)
    yy, xx = np.mgrid[0:rows, 0:cols]
    return shapely.contains_xy(zone, x0 + xx * dx, y0 + yy * dy)


def keep_out_violation(states: np.ndarray, geoms: Sequence[Any]) -> str | None:
    """The first path segment that crosses a keep-out polygon (exact check), or None.

    Parameters
    ----------
    states : ndarray, shape (n, 3)
        Path poses in the working CRS.
    geoms : sequence of shapely geometries
        Keep-out polygons in the working CRS.
    """
    from shapely.geometry import LineString, Point

    if not geoms:
        return None
    xy = np.asarray(states, float)[:, :2]
    for k, g in enumerate(geoms):
        if len(xy) == 1 or not g.intersects(LineString(xy)):
            if len(xy) == 1 and g.intersects(Point(xy[0])):
                return f"pose ({xy[0, 0]:.2f}, {xy[0, 1]:.2f}) is in keep-out area {k}"
            continue
        for s in range(len(xy) - 1):
            seg = LineString(xy[s : s + 2]) if np.any(xy[s] != xy[s + 1]) else Point(xy[s])
            if g.intersects(seg):
                return (
                    f"segment {s} from ({xy[s, 0]:.2f}, {xy[s, 1]:.2f}) to "
                    f"({xy[s + 1, 0]:.2f}, {xy[s + 1, 1]:.2f}) crosses keep-out area {k}"
                )
    return None
