"""Planning limits: keep-out polygons, start/goal checks, the motion cost with limits.

Keep-out areas come from a GeoJSON file (Polygon / MultiPolygon geometries, Features or a
FeatureCollection) whose coordinates are in the DEM's CRS, like ``--start``/``--goal``.
They are

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

import json
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
]


def load_keep_out(path: str | Path) -> list[Any]:
    """Read keep-out polygons from a GeoJSON file (coordinates in the DEM's CRS).

    Parameters
    ----------
    path : str or Path
        GeoJSON FeatureCollection, Feature or bare geometry; Polygon or MultiPolygon.

    Returns
    -------
    list of shapely geometries
        In the file's coordinates.

    Raises
    ------
    PlanningError
        If the file is missing, is not JSON/GeoJSON or holds no polygon.
    """
    import shapely
    from shapely.geometry import shape

    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except OSError as exc:
        raise PlanningConfigError(f"cannot read keep-out file {str(path)!r}: {exc}") from exc
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise PlanningConfigError(
            f"keep-out file {str(path)!r} is not JSON ({exc}); expected a GeoJSON "
            "FeatureCollection of Polygons"
        ) from exc
    if isinstance(data, dict) and data.get("type") == "FeatureCollection":
        features = data.get("features")
        if not isinstance(features, list) or not all(isinstance(f, dict) for f in features):
            raise PlanningConfigError(
                f"keep-out file {str(path)!r}: 'features' is {type(features).__name__}, "
                "expected a list of GeoJSON Feature objects",
                path=path,
                param="keep_out",
                expected="a list of Features",
            )
        geoms = [f.get("geometry") for f in features]
    elif isinstance(data, dict) and data.get("type") == "Feature":
        geoms = [data.get("geometry")]
    else:
        geoms = [data]
    out = []
    for k, g in enumerate(geoms):
        try:
            geom = shape(g)
        except Exception as exc:  # shapely raises several types for bad GeoJSON
            raise PlanningConfigError(
                f"keep-out file {str(path)!r}: geometry {k} is not valid GeoJSON ({exc})",
                path=path,
                value=k,
                param="keep_out",
                expected="GeoJSON Polygon or MultiPolygon",
            ) from exc
        if geom.geom_type not in ("Polygon", "MultiPolygon"):
            raise PlanningConfigError(
                f"keep-out file {str(path)!r}: geometry {k} is a {geom.geom_type}; "
                "expected Polygon or MultiPolygon",
                path=path,
                value=k,
                param="keep_out",
                expected="Polygon or MultiPolygon",
            )
        coords = shapely.get_coordinates(geom)
        if not np.isfinite(coords).all():
            raise PlanningConfigError(
                f"keep-out file {str(path)!r}: geometry {k} has a vertex that is not a finite "
                "number (NaN or infinity)",
                path=path,
                value=k,
                param="keep_out",
                expected="finite coordinates in the DEM's CRS",
            )
        out.append(geom)
    if not out:
        raise PlanningConfigError(
            f"keep-out file {str(path)!r} holds no polygon", path=path, param="keep_out"
        )
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
    """Transform geometries from the DEM's CRS to the terrain's working CRS."""
    import shapely

    def fwd(coords: np.ndarray) -> np.ndarray:
        x, y = terrain.to_work(coords[:, 0], coords[:, 1])
        return np.column_stack([np.atleast_1d(x), np.atleast_1d(y)])

    return [shapely.transform(g, fwd) for g in geoms]


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
_LIMIT_OF_CODE = {1: "map", 2: "max_slope_deg", 3: "max_cross_slope_deg", 4: "keep_out"}


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
        raise InvalidStateError(
            f"{which} {fmt_xy(terrain, x, y)}{yaw_txt} is invalid: {reason}; "
            f"choose a {which} on valid terrain within the limits",
            endpoint=which,
            limit=limit,
            value=value if value is not None else (float(sx), float(sy)),
            param=which,
        )


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
    geoms: list[Any] = []
    if lim.keep_out is not None:
        if isinstance(lim.keep_out, str | Path):
            raw = load_keep_out(lim.keep_out)
        else:
            raw = list(lim.keep_out)
            check_valid_geometries(raw)
        geoms = to_work_geometries(raw, terrain)
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
        blocked=blocked,
        **kwargs,
    )
    cost.request = request
    return cost, geoms
