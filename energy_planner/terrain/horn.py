"""Slope, aspect and gradient by Horn's method.

Conventions (shared with the whole project, see ``docs/terrain.md``):

- World frame: x east, y north, z up, in metres. A grid is stored as a 2-D array
  ``z[row, col]``; the geotransform maps a cell index to coordinates. For the usual
  north-up raster (``transform.e < 0``) row 0 is the northern edge.
- Gradient ``(dz/dx, dz/dy)``: derivative towards east and towards north, dimensionless
  (metres per metre).
- Slope ``alpha = atan(|grad z|)``, 0 on flat ground.
- Uphill azimuth ``psi = atan2(dz/dy, dz/dx)``: direction of steepest ascent, radians,
  counter-clockwise from +x (east), in (-pi, pi]. ``atan2(0, 0) = 0`` on flat cells.
- GIS aspect: direction of steepest *descent*, degrees clockwise from north, in [0, 360),
  as ``gdaldem aspect``. It is undefined on flat cells: gdaldem writes its nodata value
  (-9999) there, these functions give NaN. ``aspect = (90 - degrees(psi) + 180) mod 360``.

Method
------
Horn (1981) estimates the gradient at a cell from its 3 x 3 neighbourhood
``a b c / d e f / g h i`` (``a`` = north-west for a north-up grid) with weights 1-2-1::

    dz/dx = ((c + 2 f + i) - (a + 2 d + g)) / (8 * pixel_width)
    dz/dy = ((a + 2 b + c) - (g + 2 h + i)) / (8 * pixel_height)

It is a central difference smoothed across the other axis; it is exact on planes and
is the default of ``gdaldem slope``/``aspect``. Pixels need not be square: the two
differences use their own spacing, which is what a projected DEM with ``xres != yres``
needs.

Design notes
------------
- Invalid data is never invented. A cell whose 3 x 3 window touches a NaN (nodata) cell,
  or that lies on the grid's outer edge, gets a NaN gradient (so does an invalid cell itself,
  although Horn's stencil does not use the centre). This matches gdaldem's
  default, which leaves the one-cell border nodata (no ``-compute_edges``), and gdaldem's
  rule that any nodata value in the window makes the output nodata.
- The arithmetic is plain NumPy slicing (no SciPy convolution), so NaN propagates by IEEE
  rules without RuntimeWarnings and the result is C-contiguous float64.

References
----------
B. K. P. Horn, "Hill shading and the reflectance map", Proceedings of the IEEE 69(1),
14-47, 1981. doi:10.1109/PROC.1981.11918
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from affine import Affine

from energy_planner.errors import DEMError

__all__ = [
    "aspect",
    "aspect_from_gradient",
    "gradient",
    "hillshade",
    "horn_gradient",
    "pixel_steps",
    "shade",
    "slope",
]

TransformOrResolution = Affine | float | Sequence[float]


def pixel_steps(transform_or_resolution: Any) -> tuple[float, float]:
    """Signed coordinate steps ``(step_x per column, step_y per row)`` of a grid.

    Parameters
    ----------
    transform_or_resolution : affine.Affine, float or (float, float)
        An affine geotransform (north-up or flipped; no rotation), a square pixel size,
        or ``(xres, yres)`` pixel sizes. Plain sizes are positive magnitudes and mean a
        north-up grid (row 0 north), as in xdem and ``rasterio``'s ``res``.

    Returns
    -------
    (float, float)
        Metres per column along x and per row along y (negative for north-up).

    Raises
    ------
    DEMError
        For a rotated/sheared transform, a zero/negative/non-finite size.

    Examples
    --------
    >>> pixel_steps(2.0)
    (2.0, -2.0)
    >>> pixel_steps((1.0, 3.0))
    (1.0, -3.0)
    >>> pixel_steps(Affine(1.5, 0, 100, 0, -2.5, 50))
    (1.5, -2.5)
    """
    if isinstance(transform_or_resolution, Affine):
        t = transform_or_resolution
        if t.b != 0 or t.d != 0:
            raise DEMError(
                f"geotransform {tuple(t)[:6]} is rotated or sheared (b={t.b}, d={t.d}); "
                "expected a north-up grid (b = d = 0). Warp it first, e.g. "
                "`gdalwarp -t_srs <same CRS> in.tif out.tif`."
            )
        sx, sy = float(t.a), float(t.e)
        if not (math.isfinite(sx) and math.isfinite(sy)) or sx == 0 or sy == 0:
            raise DEMError(f"geotransform {tuple(t)[:6]} has a zero or non-finite pixel size")
        return sx, sy
    if isinstance(transform_or_resolution, int | float | np.floating | np.integer):
        sx = sy = float(transform_or_resolution)
    else:
        try:
            sx, sy = (float(v) for v in transform_or_resolution)
        except (TypeError, ValueError) as exc:
            raise DEMError(
                f"resolution {transform_or_resolution!r} is not an Affine transform, a "
                "number or an (xres, yres) pair"
            ) from exc
    if not (sx > 0 and sy > 0 and math.isfinite(sx) and math.isfinite(sy)):
        raise DEMError(
            f"resolution {transform_or_resolution!r} must be positive and finite "
            "(pixel sizes in metres; use an Affine transform for a flipped grid)"
        )
    return sx, -sy


def _per_row(step: float | np.ndarray, rows: int, name: str) -> float | np.ndarray:
    """A scalar step, or per-row steps as a ``(rows - 2, 1)`` column for the interior."""
    if np.ndim(step) == 0:
        return float(step)
    s = np.asarray(step, dtype=np.float64)
    if s.shape != (rows,):
        raise DEMError(
            f"{name} has shape {s.shape}; expected a number or one step per row ({rows})"
        )
    return s[1:-1, None]


def horn_gradient(
    z: np.ndarray,
    step_x: float | np.ndarray,
    step_y: float | np.ndarray,
    out: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Horn gradient of a grid with signed steps (see :func:`pixel_steps`).

    Parameters
    ----------
    z : ndarray, shape (rows, cols)
        Elevation; NaN marks invalid cells.
    step_x, step_y : float or ndarray, shape (rows,)
        Coordinate change per column and per row (``step_y < 0`` for north-up), in
        metres. An array gives one step per row: the spacing of the grid at that row, as
        on a longitude/latitude grid, where a column step is ``cos(latitude)`` times
        shorter towards the poles (see :mod:`energy_planner.terrain.native`). Row ``r``'s
        differences are divided by row ``r``'s steps (the window's centre row).
    out : ndarray of float64, shape (rows, cols, 2), optional
        Where to write the gradient, the two components of a cell side by side (the
        layout the motion-cost kernels read); the results are then views of it, not
        C-contiguous.

    Returns
    -------
    dzdx, dzdy : ndarray of float64
        dz/dx (east) and dz/dy (north), C-contiguous unless ``out`` is given; NaN on the
        border and wherever the 3 x 3 window touches a NaN.

    Examples
    --------
    >>> z = np.array([[2.0, 2.0, 2.0], [1.0, 1.0, 1.0], [0.0, 0.0, 0.0]])  # rises to north
    >>> gx, gy = horn_gradient(z, 1.0, -1.0)
    >>> float(gx[1, 1]), float(gy[1, 1]), bool(np.isnan(gx[0, 0]))
    (0.0, 1.0, True)
    """
    z = np.asarray(z, dtype=np.float64)
    if z.ndim != 2:
        raise DEMError(f"elevation must be a 2-D array, got shape {z.shape}")
    rows, cols = z.shape
    if out is None:
        dzdx = np.empty((rows, cols))
        dzdy = np.empty((rows, cols))
    else:
        if out.shape != (rows, cols, 2) or out.dtype != np.float64:
            raise DEMError(
                f"out has shape {out.shape} and dtype {out.dtype}; expected float64 of "
                f"shape {(rows, cols, 2)}"
            )
        dzdx, dzdy = out[..., 0], out[..., 1]
    if rows < 3 or cols < 3:
        dzdx.fill(np.nan)
        dzdy.fill(np.nan)
        return dzdx, dzdy
    for g in (dzdx, dzdy):  # the border; every interior cell is written below
        g[0] = g[-1] = np.nan
        g[:, 0] = g[:, -1] = np.nan
    sx = _per_row(step_x, rows, "step_x")
    sy = _per_row(step_y, rows, "step_y")
    # by strips of interior rows whose arrays stay in the cache (each cell's arithmetic
    # is the same whatever the strip: the same values)
    step = max(1, _STRIP_CELLS // cols)
    tmp = np.empty((min(step, rows - 2), cols - 2))
    bad = np.empty(tmp.shape, dtype=bool)
    bad2 = np.empty(tmp.shape, dtype=bool)
    for r0 in range(1, rows - 1, step):
        r1 = min(rows - 1, r0 + step)
        n = r1 - r0
        _horn_strip(
            z[r0 - 1 : r1 - 1], z[r0:r1], z[r0 + 1 : r1 + 1],
            dzdx[r0:r1, 1:-1], dzdy[r0:r1, 1:-1],
            sx if np.ndim(sx) == 0 else sx[r0 - 1 : r1 - 1],
            sy if np.ndim(sy) == 0 else sy[r0 - 1 : r1 - 1],
            tmp[:n], bad[:n], bad2[:n],
        )  # fmt: skip
    return dzdx, dzdy


#: Cells of a strip of rows :func:`horn_gradient` works on at a time (its five arrays of
#: that many float64 values, 256 KB each, stay in a core's cache).
_STRIP_CELLS = 32768


def _horn_strip(top, mid, bot, gx, gy, sx, sy, tmp, bad, bad2) -> None:
    """Horn's gradient of the rows of ``mid`` into the interior columns ``gx``, ``gy``.

    ``top``, ``bot``: the rows above and below; ``tmp``, ``bad``, ``bad2``: scratch of
    the strip's shape.
    """
    # column difference (east minus west), weights 1-2-1 over the rows
    np.subtract(top[:, 2:], top[:, :-2], out=gx)
    np.subtract(mid[:, 2:], mid[:, :-2], out=tmp)
    tmp *= 2.0
    gx += tmp
    np.subtract(bot[:, 2:], bot[:, :-2], out=tmp)
    gx += tmp
    gx /= 8.0 * sx
    # row difference (previous row minus next row: north minus south when step_y < 0),
    # weights 1-2-1 over the columns; dividing by -step_y keeps flat cells at +0.0
    np.subtract(top[:, :-2], bot[:, :-2], out=gy)
    np.subtract(top[:, 1:-1], bot[:, 1:-1], out=tmp)
    tmp *= 2.0
    gy += tmp
    np.subtract(top[:, 2:], bot[:, 2:], out=tmp)
    gy += tmp
    gy /= -8.0 * sy
    # dz/dx skips the window's middle column, dz/dy its middle row and neither uses the
    # centre: like gdaldem, any invalid cell among the nine invalidates both components
    np.isnan(gx, out=bad)
    bad |= np.isnan(gy, out=bad2)
    bad |= np.isnan(mid[:, 1:-1], out=bad2)
    if bad.any():  # most strips of a DEM have no invalid cell
        np.copyto(gx, np.nan, where=bad)
        np.copyto(gy, np.nan, where=bad)


def gradient(
    dem: np.ndarray, transform_or_resolution: TransformOrResolution
) -> tuple[np.ndarray, np.ndarray]:
    """Horn gradient ``(dz/dx east, dz/dy north)`` of a DEM array.

    Parameters
    ----------
    dem : array_like, shape (rows, cols)
        Elevation in metres; NaN = invalid.
    transform_or_resolution : affine.Affine, float or (float, float)
        See :func:`pixel_steps`.

    Returns
    -------
    dzdx, dzdy : ndarray of float64

    Examples
    --------
    >>> x = np.arange(5.0)
    >>> z = np.tile(0.5 * x, (4, 1))  # rises 0.5 m per metre eastwards
    >>> gx, gy = gradient(z, 1.0)
    >>> float(gx[1, 2]), float(gy[1, 2])
    (0.5, 0.0)
    """
    sx, sy = pixel_steps(transform_or_resolution)
    return horn_gradient(np.asarray(dem, dtype=np.float64), sx, sy)


def slope_from_gradient(dzdx: np.ndarray, dzdy: np.ndarray, degrees: bool = True) -> np.ndarray:
    """Slope ``atan(hypot(dzdx, dzdy))``, in degrees or radians."""
    s = np.arctan(np.hypot(dzdx, dzdy))
    return np.degrees(s, out=s) if degrees else s


def aspect_from_gradient(dzdx: np.ndarray, dzdy: np.ndarray, degrees: bool = True) -> np.ndarray:
    """GIS aspect (downslope, clockwise from north, [0, 360)) from a gradient.

    NaN where the gradient is NaN or exactly zero (flat, undefined; gdaldem: -9999).

    Examples
    --------
    >>> aspect_from_gradient(np.array([-1.0, 0.0, 1.0, 0.0]), np.array([0.0, -1.0, 0.0, 0.0]))
    array([ 90.,   0., 270.,  nan])
    """
    dzdx = np.asarray(dzdx, dtype=np.float64)
    dzdy = np.asarray(dzdy, dtype=np.float64)
    # downslope vector (-dzdx, -dzdy); azimuth clockwise from north = atan2(east, north)
    shape = np.broadcast(dzdx, dzdy).shape
    a = np.arctan2(-dzdx, -dzdy).reshape(-1)  # (-pi, pi], a flat copy
    np.degrees(a, out=a)
    a[a < 0.0] += 360.0
    a[a >= 360.0] = 0.0  # -tiny + 360 rounds to 360
    a += 0.0  # -0.0 -> 0.0
    a[((dzdx == 0) & (dzdy == 0)).reshape(-1)] = np.nan
    if not degrees:
        np.radians(a, out=a)
    return a.reshape(shape)


def slope(
    dem: np.ndarray, transform_or_resolution: TransformOrResolution, degrees: bool = True
) -> np.ndarray:
    """Slope of a DEM by Horn's method (as ``gdaldem slope``).

    Parameters
    ----------
    dem : array_like, shape (rows, cols)
        Elevation in metres (same unit as the pixel size); NaN = invalid.
    transform_or_resolution : affine.Affine, float or (float, float)
        See :func:`pixel_steps`.
    degrees : bool
        Degrees (default) or radians.

    Returns
    -------
    ndarray of float64
        Slope; NaN on the border and around invalid cells.

    Examples
    --------
    >>> z = np.tile(np.arange(5.0), (4, 1))  # 1 m rise per metre
    >>> round(float(slope(z, 1.0)[1, 1]), 6)
    45.0
    """
    return slope_from_gradient(*gradient(dem, transform_or_resolution), degrees=degrees)


def aspect(
    dem: np.ndarray, transform_or_resolution: TransformOrResolution, degrees: bool = True
) -> np.ndarray:
    """GIS aspect of a DEM by Horn's method (as ``gdaldem aspect``).

    Direction of steepest descent, clockwise from north, in [0, 360) degrees (or the same
    angle in radians). NaN on flat cells (gdaldem: -9999), on the border and around
    invalid cells.

    Examples
    --------
    >>> z = np.tile(np.arange(5.0), (4, 1))  # rises to the east, so faces west
    >>> float(aspect(z, 1.0)[1, 1])
    270.0
    """
    return aspect_from_gradient(*gradient(dem, transform_or_resolution), degrees=degrees)


def hillshade(
    dem: np.ndarray,
    transform_or_resolution: TransformOrResolution,
    azimuth: float = 315.0,
    altitude: float = 45.0,
    z_factor: float = 1.0,
) -> np.ndarray:
    """Lambertian hillshade in [0, 1] (gdaldem's formula, for plots).

    Parameters
    ----------
    dem : array_like
        Elevation; NaN = invalid.
    transform_or_resolution : affine.Affine, float or (float, float)
        See :func:`pixel_steps`.
    azimuth : float
        Direction the light comes *from*, degrees clockwise from north (315 = north-west).
    altitude : float
        Sun elevation above the horizon, degrees.
    z_factor : float
        Vertical exaggeration.

    Returns
    -------
    ndarray of float64
        ``cos`` of the angle between the surface normal and the sun, clipped at 0; NaN
        where the gradient is NaN.

    Examples
    --------
    >>> z = np.zeros((3, 3))
    >>> round(float(hillshade(z, 1.0)[1, 1]), 6) == round(math.sin(math.radians(45)), 6)
    True
    """
    gx, gy = gradient(dem, transform_or_resolution)
    return shade(gx * z_factor, gy * z_factor, azimuth, altitude)


def shade(
    dzdx: np.ndarray, dzdy: np.ndarray, azimuth: float = 315.0, altitude: float = 45.0
) -> np.ndarray:
    """Lambertian hillshade in [0, 1] of a gradient (metres per metre, east and north).

    What :func:`hillshade` draws once it has the gradient; a grid whose gradient is
    known (a longitude/latitude DEM's geodesic Horn gradient,
    :class:`~energy_planner.terrain.native.NativeGrid`) is shaded from it directly.

    Examples
    --------
    >>> flat = np.zeros(1)
    >>> bool(np.isclose(shade(flat, flat)[0], math.sin(math.radians(45))))
    True
    """
    gx, gy = np.asarray(dzdx, dtype=float), np.asarray(dzdy, dtype=float)
    az = math.radians(azimuth)
    alt = math.radians(altitude)
    # unit vector towards the sun in (east, north, up)
    sun = (math.sin(az) * math.cos(alt), math.cos(az) * math.cos(alt), math.sin(alt))
    # surface normal (-gx, -gy, 1) / norm
    lit = (-gx * sun[0] - gy * sun[1] + sun[2]) / np.sqrt(1.0 + gx * gx + gy * gy)
    return np.clip(lit, 0.0, 1.0)
