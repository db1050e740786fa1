"""Vectorized bilinear sampling on a north-up grid.

A grid is described by ``(x0, y0, dx, dy)``: the coordinates of the *centre* of cell
``(0, 0)`` and the signed steps per column and per row (``dx > 0``, ``dy < 0`` for a
north-up raster). Cell ``(r, c)`` has its centre at ``(x0 + c dx, y0 + r dy)``.

Bilinear interpolation runs between cell centres. A point is inside the sampled area when
it lies within the rectangle spanned by the outermost centres and all cells that carry
weight in its interpolation are valid; otherwise the result is NaN (never extrapolated,
never filled). A neighbour with exactly zero weight (a point on a centre line) does not
spoil the result.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

__all__ = ["TerrainSample", "bilinear"]


class TerrainSample(NamedTuple):
    """Terrain at query points (arrays broadcast from the query, or floats for scalars).

    Attributes
    ----------
    elevation : metres.
    slope : radians, ``atan(|grad z|)`` of the interpolated gradient.
    uphill_azimuth : radians, ``atan2(dz/dy, dz/dx)``, counter-clockwise from east.
    dzdx, dzdy : interpolated Horn gradient components (east, north).
    """

    elevation: np.ndarray | float
    slope: np.ndarray | float
    uphill_azimuth: np.ndarray | float
    dzdx: np.ndarray | float
    dzdy: np.ndarray | float


def bilinear(
    arrays: Sequence[np.ndarray],
    grid: tuple[float, float, float, float],
    x: np.ndarray | float,
    y: np.ndarray | float,
) -> list[np.ndarray]:
    """Bilinear interpolation of several same-shape grids at points ``(x, y)``.

    Parameters
    ----------
    arrays : sequence of ndarray, each shape (rows, cols)
        Grids to sample (NaN = invalid).
    grid : (x0, y0, dx, dy)
        Centre of cell (0, 0) and signed steps, see the module docstring.
    x, y : array_like
        Query coordinates (broadcast together).

    Returns
    -------
    list of ndarray of float64
        One array per input grid, shaped like the broadcast query; NaN outside.

    Examples
    --------
    >>> z = np.array([[1.0, 2.0], [3.0, 4.0]])  # row 0 is north (y = 1), row 1 south (y = 0)
    >>> [v.tolist() for v in bilinear([z], (0.0, 1.0, 1.0, -1.0), [0.5, 0.0, 2.0], [0.5, 0.0, 0.0])]
    [[2.5, 3.0, nan]]
    """
    x0, y0, dx, dy = (float(v) for v in grid)
    xb, yb = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
    shape = xb.shape
    xf = xb.ravel()
    yf = yb.ravel()
    rows, cols = arrays[0].shape
    out = [np.full(xf.shape, np.nan) for _ in arrays]
    if rows < 2 or cols < 2:
        return [o.reshape(shape) for o in out]
    fc = (xf - x0) / dx
    fr = (yf - y0) / dy
    inside = (fc >= 0.0) & (fc <= cols - 1) & (fr >= 0.0) & (fr <= rows - 1)
    idx = np.flatnonzero(inside)
    fc = fc[idx]
    fr = fr[idx]
    c0 = np.minimum(np.floor(fc).astype(np.intp), cols - 2)
    r0 = np.minimum(np.floor(fr).astype(np.intp), rows - 2)
    tc = fc - c0
    tr = fr - r0
    weights = (
        (r0, c0, (1.0 - tr) * (1.0 - tc)),
        (r0, c0 + 1, (1.0 - tr) * tc),
        (r0 + 1, c0, tr * (1.0 - tc)),
        (r0 + 1, c0 + 1, tr * tc),
    )
    for arr, o in zip(arrays, out, strict=True):
        acc = np.zeros(idx.size)
        for r, c, w in weights:
            v = arr[r, c]
            acc += np.where(w > 0.0, w * v, 0.0)
        o[idx] = acc
    return [o.reshape(shape) for o in out]
