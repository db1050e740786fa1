"""Planning limits: keep-out polygons, start/goal checks, the motion cost with limits.

Keep-out areas come from a GeoJSON file (Polygon / MultiPolygon geometries, Features or a
FeatureCollection) in longitude/latitude as RFC 7946 says, or in the CRS the file declares
(``crs`` member); Python callers may give shapely geometries in the DEM's CRS. They are
reprojected to the working grid and

* rasterized onto the terrain grid as the ``blocked`` mask of
  :class:`energy_planner.energy.MotionCost` (a cell is blocked when its centre lies
  within one cell diagonal of a polygon, so a motion sampled at sub-cell steps cannot
  slip through a corner), which is what the planners see; and
* checked exactly with shapely on the final path's segments.

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
import re
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from energy_planner.errors import InvalidStateError, PlanningConfigError

if TYPE_CHECKING:
    from energy_planner.request import Request

__all__ = [
    "load_keep_out",
    "to_work_geometries",
    "rasterize_keep_out",
    "keep_out_violation",
    "pose_violation",
    "pose_limit",
    "check_endpoint",
    "check_valid_geometries",
    "fmt_xy",
    "make_motion_cost",
    "keep_out_geometries",
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


def pose_violation(cost, x: float, y: float, yaw: float | None, geoms=()) -> str | None:
    """Which limit a pose breaks, or None (yaw None: valid if some heading is valid)."""
    v = pose_limit(cost, x, y, yaw, geoms)
    return None if v is None else v[1]


#: Kernel violation codes -> the request's limit names (structured error fields).
_LIMIT_OF_CODE = {
    1: "map", 2: "max_slope_deg", 3: "max_cross_slope_deg", 4: "keep_out",
    6: "max_backward_slope_deg", 7: "max_crab_deg",
}  # fmt: skip


def pose_limit(
    cost, x: float, y: float, yaw: float | None, geoms=()
) -> tuple[str, str, float | None] | None:
    """The limit a pose breaks as ``(limit, reason, value)``, or None if it is valid.

    ``limit`` is ``"map"`` (outside the map or on nodata), ``"max_slope_deg"``,
    ``"max_cross_slope_deg"`` or ``"keep_out"``; ``value`` the slope or cross-slope in
    degrees (None otherwise). With ``yaw`` None the pose is valid if some heading is.
    """
    from shapely.geometry import Point

    for k, g in enumerate(geoms):
        if g.intersects(Point(x, y)):
            return ("keep_out", f"inside keep-out area {k}", None)
    yaws = [float(yaw)] if yaw is not None else np.linspace(-np.pi, np.pi, 16, endpoint=False)
    first = None
    for th in yaws:
        out = cost.details([x, x], [y, y], [th, th], [1.0])[0]
        code = int(out[12])
        if code == 0:
            return None
        if first is None:
            first = (code, th)
    code, th = first
    reason = cost.violation(x, y, th) or "breaks a limit"
    if yaw is None:
        reason += " (at every heading)"
    value = None
    if code in (2, 3):
        m = re.search(r"([-0-9.]+) deg >", reason)
        value = float(m.group(1)) if m else None
    return (_LIMIT_OF_CODE.get(code, "map"), reason, value)


def fmt_xy(terrain, x: float, y: float) -> str:
    """``(x, y)`` in the DEM's CRS: 6 decimals for degrees, 2 for metres."""
    sx, sy = terrain.from_work(x, y)
    geographic = bool(getattr(getattr(terrain, "source_crs", None), "is_geographic", False))
    nd = 6 if geographic else 2
    return f"({float(sx):.{nd}f}, {float(sy):.{nd}f})"


def check_endpoint(
    cost, terrain, which: str, pose: tuple[float, float, float | None], geoms=()
) -> None:
    """Raise :class:`InvalidStateError` if the start/goal ``pose`` breaks a limit.

    The message names the pose in the DEM's CRS and the limit with its value; the error's
    fields are ``endpoint`` (``which``), ``limit`` (see :func:`pose_limit`), ``value`` (the
    slope in degrees for a slope limit, else the pose ``(x, y)`` in the DEM's CRS).
    """
    x, y, yaw = pose
    v = pose_limit(cost, x, y, yaw, geoms)
    if v is not None:
        limit, reason, value = v
        yaw_txt = "" if yaw is None else f" yaw {math.degrees(yaw):.1f} deg"
        sx, sy = terrain.from_work(x, y)
        extra: dict[str, Any] = {}
        where = f"choose a {which} on valid terrain within the limits"
        if limit == "map":
            where, extra = _map_hint(terrain, which, float(sx), float(sy))
            if extra["outside"]:
                reason = "outside the map"
        raise InvalidStateError(
            f"{which} {fmt_xy(terrain, x, y)}{yaw_txt} is invalid: {reason}; {where}",
            endpoint=which,
            limit=limit,
            value=value if value is not None else (float(sx), float(sy)),
            param=which,
            **{k: v for k, v in extra.items() if k != "outside"},
        )


def _map_hint(terrain, which: str, sx: float, sy: float) -> tuple[str, dict[str, Any]]:
    """The map's extent and CRS for an endpoint off the map, with a lon/lat hint.

    Returns the text and the error fields (``crs``, ``bounds``, ``hint``, ``outside``).
    """
    from energy_planner.errors import extent_text, fmt_num

    crs = getattr(terrain, "source_crs", None)
    bounds = tuple(float(b) for b in terrain.source_bounds)
    outside = not (bounds[0] <= sx <= bounds[2] and bounds[1] <= sy <= bounds[3])
    text = f"the map covers {extent_text(bounds, crs)}"
    hint = f"give a {which} inside the map, on valid terrain"
    geographic = bool(getattr(crs, "is_geographic", False))
    if outside and crs is not None and not geographic and abs(sx) <= 180 and abs(sy) <= 90:
        from energy_planner.io import reproject_xy

        try:
            px, py = (float(v[0]) for v in reproject_xy("OGC:CRS84", crs, [sx], [sy]))
        except Exception:  # noqa: BLE001 - PROJ cannot place it: no lon/lat hint
            px = py = math.nan
        if math.isfinite(px) and math.isfinite(py):
            inside = bounds[0] <= px <= bounds[2] and bounds[1] <= py <= bounds[3]
            hint = (
                f"({fmt_num(sx)}, {fmt_num(sy)}) looks like longitude, latitude; that point is "
                f"x {fmt_num(px)}, y {fmt_num(py)} in {crs}"
                + (": give that" if inside else ", also outside the map")
            )
    return (f"{text}. Hint: {hint}", {"crs": str(crs), "bounds": bounds, "hint": hint,
                                      "outside": outside})  # fmt: skip


def make_motion_cost(
    terrain,
    model,
    request: Request | None = None,
    *,
    speed: float | None = None,
    yaw_rate: float | None = None,
    max_slope_deg: float | None = None,
    max_cross_slope_deg: float | None = None,
    keep_out: str | Path | Sequence[Any] | None = None,
):
    """The :class:`~energy_planner.energy.MotionCost` with all limits, and the keep-out polygons.

    All limits of ``request.limits`` go into the one motion kernel: slope, cross-slope,
    keep-out mask and the gait limits (``max_backward_slope_deg``, ``max_crab_deg``), so
    that every planner, reach, compare-routes and path energy priced with this cost
    honours them.

    Parameters
    ----------
    terrain : Terrain
    model : EnergyModel
    request : Request, optional
        Robot speed and yaw rate, limits, channels (:class:`energy_planner.request.Request`).
    speed, yaw_rate, max_slope_deg, max_cross_slope_deg, keep_out
        The same as flat keywords (older callers); not together with ``request``.
        ``keep_out`` is a GeoJSON file or geometries, both in the DEM's CRS.

    Returns
    -------
    cost : MotionCost
    geoms : list of shapely geometries
        Keep-out polygons in the working CRS (empty without ``keep_out``).
    """
    from energy_planner.energy import MotionCost
    from energy_planner.request import Request

    flat = {
        "speed": speed, "yaw_rate": yaw_rate, "max_slope_deg": max_slope_deg,
        "max_cross_slope_deg": max_cross_slope_deg, "keep_out": keep_out,
    }  # fmt: skip
    given = {k: v for k, v in flat.items() if v is not None}
    if request is None:
        request = Request.make(**given)
    elif given:
        raise PlanningConfigError(
            f"give the limits and robot either as request= or as keywords, not both "
            f"(got request= and {', '.join(given)})",
            param=next(iter(given)),
        )
    lim = request.limits
    geoms = keep_out_geometries(lim.keep_out, terrain)
    blocked = rasterize_keep_out(geoms, terrain) if geoms else None
    kwargs: dict[str, Any] = {}
    ch = request.channels
    if ch is not None:
        kwargs["channels"] = ch
    cost = MotionCost(
        terrain,
        model,
        speed=request.robot.speed,
        yaw_rate=request.robot.yaw_rate,
        max_slope_deg=lim.max_slope_deg,
        max_cross_slope_deg=lim.max_cross_slope_deg,
        max_backward_slope_deg=lim.max_backward_slope_deg,
        max_crab_deg=lim.max_crab_deg,
        blocked=blocked,
        **kwargs,
    )
    cost.request = request
    return cost, geoms
