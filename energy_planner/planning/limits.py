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
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.errors import InvalidStateError, PlanningConfigError

__all__ = [
    "load_keep_out",
    "to_work_geometries",
    "rasterize_keep_out",
    "keep_out_violation",
    "pose_violation",
    "check_endpoint",
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
    from shapely.geometry import shape

    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except OSError as exc:
        raise PlanningConfigError(f"cannot read keep-out file {str(path)!r}: {exc}") from exc
    except json.JSONDecodeError as exc:
        raise PlanningConfigError(
            f"keep-out file {str(path)!r} is not JSON ({exc}); expected a GeoJSON "
            "FeatureCollection of Polygons"
        ) from exc
    if isinstance(data, dict) and data.get("type") == "FeatureCollection":
        geoms = [f.get("geometry") for f in data.get("features", [])]
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
                f"keep-out file {str(path)!r}: geometry {k} is not valid GeoJSON ({exc})"
            ) from exc
        if geom.geom_type not in ("Polygon", "MultiPolygon"):
            raise PlanningConfigError(
                f"keep-out file {str(path)!r}: geometry {k} is a {geom.geom_type}; "
                "expected Polygon or MultiPolygon"
            )
        out.append(geom)
    if not out:
        raise PlanningConfigError(f"keep-out file {str(path)!r} holds no polygon")
    return out


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
    from shapely.geometry import Point

    for k, g in enumerate(geoms):
        if g.intersects(Point(x, y)):
            return f"inside keep-out area {k}"
    if yaw is not None:
        return cost.violation(x, y, float(yaw))
    reasons = [cost.violation(x, y, th) for th in np.linspace(-np.pi, np.pi, 16, endpoint=False)]
    if any(r is None for r in reasons):
        return None
    return f"{reasons[0]} (at every heading)"


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

    The message names the pose in the DEM's CRS and the limit with its value.
    """
    x, y, yaw = pose
    reason = pose_violation(cost, x, y, yaw, geoms)
    if reason is not None:
        yaw_txt = "" if yaw is None else f" yaw {math.degrees(yaw):.1f} deg"
        raise InvalidStateError(
            f"{which} {fmt_xy(terrain, x, y)}{yaw_txt} is invalid: {reason}; "
            f"choose a {which} on valid terrain within the limits"
        )


def make_motion_cost(
    terrain,
    model,
    *,
    speed: float = 0.3,
    yaw_rate: float = 0.5,
    max_slope_deg: float | None = None,
    max_cross_slope_deg: float | None = None,
    keep_out: str | Path | Sequence[Any] | None = None,
):
    """The :class:`~energy_planner.energy.MotionCost` with all limits, and the keep-out polygons.

    Parameters
    ----------
    keep_out : path, sequence of shapely geometries or None
        A GeoJSON file or geometries, both in the DEM's CRS.

    Returns
    -------
    cost : MotionCost
    geoms : list of shapely geometries
        Keep-out polygons in the working CRS (empty without ``keep_out``).
    """
    from energy_planner.energy import MotionCost

    geoms: list[Any] = []
    if keep_out is not None:
        raw = load_keep_out(keep_out) if isinstance(keep_out, str | Path) else list(keep_out)
        geoms = to_work_geometries(raw, terrain)
    blocked = rasterize_keep_out(geoms, terrain) if geoms else None
    cost = MotionCost(
        terrain,
        model,
        speed=speed,
        yaw_rate=yaw_rate,
        max_slope_deg=max_slope_deg,
        max_cross_slope_deg=max_cross_slope_deg,
        blocked=blocked,
    )
    return cost, geoms
