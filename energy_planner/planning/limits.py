"""Planning limits: start/goal checks against the motion cost's limits.

Keep-out polygons are read, reprojected and rasterized by :mod:`energy_planner.keepout`
(re-exported here), and the motion cost with every limit is
:attr:`energy_planner.problem.Problem.cost`; this module says which limit a pose breaks,
in words and in the structured fields of :class:`~energy_planner.errors.InvalidStateError`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from energy_planner.errors import InvalidStateError, PlanningConfigError
from energy_planner.keepout import (
    check_valid_geometries,
    keep_out_geometries,
    keep_out_violation,
    load_keep_out,
    rasterize_keep_out,
    to_work_geometries,
)

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
    "outside_map",
    "make_motion_cost",
    "keep_out_geometries",
]


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


def outside_map(which: str, x: float, y: float, where: str) -> InvalidStateError:
    """The error of endpoint ``which`` at ``(x, y)`` off the map; ``where`` names the extent."""
    return InvalidStateError(
        f"{which} ({x:.2f}, {y:.2f}) is outside {where}", endpoint=which, limit="map", value=(x, y)
    )


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
            elif hasattr(terrain, "invalid_reason"):  # inside: say which cell is missing
                reason = terrain.invalid_reason(x, y) or reason
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
    """The motion cost with all limits, and the keep-out polygons (working CRS).

    :attr:`energy_planner.problem.Problem.cost` and
    :attr:`~energy_planner.problem.Problem.keep_out` of ``Problem(terrain, model,
    request)``; the flat keywords (older callers) make the request, not together with
    ``request``.

    Returns
    -------
    cost : MotionCost
    geoms : list of shapely geometries
    """
    from energy_planner.problem import Problem
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
    problem = Problem(terrain, model, request)
    return problem.cost, problem.keep_out
