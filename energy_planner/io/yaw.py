"""Yaw in path files: radians typed into a degrees column, and the frame of the yaw.

- :func:`radians_suspect` / :func:`warn_if_radians`: a ``yaw_deg`` column that looks
  like radians (the rule is in ``docs/terrain.md``, "Paths on the map").
- :func:`yaw_to_work` / :func:`yaw_from_work`: yaw from the DEM's x axis <-> yaw from the
  working grid's x axis (the meridian convergence on a geographic DEM). For any two CRSs
  see :func:`energy_planner.io.x_axis_angle`.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

from energy_planner.angles import wrap

__all__ = ["radians_suspect", "warn_if_radians", "yaw_from_work", "yaw_to_work"]


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
