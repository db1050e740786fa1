"""Horn on a DEM's own grid when its CRS is not metric (longitude/latitude, feet).

A longitude/latitude DEM is not resampled before its slopes are computed: resampling
smooths them (on the bundled Jacksboro DEM the UTM round trip lowered slopes by 0.72 deg
median against Horn on the native grid). Instead:

1. :func:`native_gradient`: Horn on the DEM's own grid, each row with its own metric
   spacing. For a geographic CRS the step along a parallel is ``dlon N(lat) cos(lat)``
   and along a meridian ``dlat M(lat)`` (``N``, ``M``: the prime-vertical and meridional
   radii of curvature of the CRS's ellipsoid, closed form), which is the geodesic
   distance between neighbouring cell centres to ~1e-9 for arc-second cells. The gradient
   is towards local east and true north. For a projected CRS in another unit than the
   metre (US feet) the steps are the pixel size times the unit's length in metres.
2. :func:`gradient_to_work`: the planners' metric working grid (UTM, see
   :mod:`energy_planner.terrain.dem`) takes that gradient at each of its cell centres,
   bilinear in the two components (as :meth:`Terrain.sample` does), and turns it into its
   own axes by the chain rule ``dz/dx_work = dz/dE dE/dx_work + dz/dN dN/dx_work``. The
   Jacobian ``d(E, N) / d(x_work, y_work)`` is a central difference of the exact
   back-projection of the neighbouring working cell centres: the rotation by the
   meridian convergence and the UTM scale factor, without assuming either.

So there is one Horn (:func:`energy_planner.terrain.horn.horn_gradient`), run where the
data are, and the planners read the same slopes as ``terrain`` writes, up to bilinear
interpolation of the gradient.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from affine import Affine

from energy_planner.terrain.horn import aspect_from_gradient, horn_gradient, slope_from_gradient
from energy_planner.terrain.sample import bilinear

__all__ = [
    "NativeGrid",
    "gradient_to_work",
    "metric_scale",
    "native_gradient",
    "native_steps",
]


@dataclass(frozen=True)
class _Scale:
    """How many metres one unit of a CRS's coordinates is, along x and y."""

    geographic: bool
    unit_m: float  # projected: metres per unit
    unit_rad: float  # geographic: radians per angular unit
    a: float  # semi-major axis, m
    e2: float  # first eccentricity squared

    def at(self, y: np.ndarray) -> tuple[np.ndarray | float, np.ndarray | float]:
        """Metres per unit of x and of y at coordinate ``y`` (latitude if geographic)."""
        if not self.geographic:
            return self.unit_m, self.unit_m
        phi = np.asarray(y, dtype=np.float64) * self.unit_rad
        s2 = np.sin(phi) ** 2
        w = np.sqrt(1.0 - self.e2 * s2)
        n = self.a / w  # prime vertical radius of curvature
        m = self.a * (1.0 - self.e2) / (w * w * w)  # meridional radius of curvature
        return self.unit_rad * n * np.cos(phi), self.unit_rad * m


def metric_scale(crs: Any) -> _Scale:
    """The metric scale of a non-metric CRS (see :meth:`_Scale.at`).

    Parameters
    ----------
    crs : rasterio.crs.CRS
        A geographic CRS (angles on an ellipsoid) or a projected CRS in any linear unit.

    Returns
    -------
    _Scale
        ``.at(y)`` gives metres per unit of x and y at ``y``.

    Examples
    --------
    >>> from rasterio.crs import CRS
    >>> kx, ky = metric_scale(CRS.from_epsg(4326)).at(0.0)  # one degree on the equator
    >>> round(float(kx), 1), round(float(ky), 1)
    (111319.5, 110574.3)
    >>> kx, ky = metric_scale(CRS.from_epsg(2229)).at(0.0)  # California zone 5, US feet
    >>> round(kx, 12), round(ky, 12)  # 1200/3937 m, everywhere
    (0.304800609601, 0.304800609601)
    """
    from pyproj import CRS as ProjCRS

    pc = ProjCRS.from_user_input(crs.to_wkt())
    if pc.is_geographic:
        ell = pc.ellipsoid
        a = float(ell.semi_major_metre)
        b = float(ell.semi_minor_metre)
        unit = pc.axis_info[0].unit_conversion_factor if pc.axis_info else math.pi / 180.0
        return _Scale(True, 1.0, float(unit), a, 1.0 - (b / a) ** 2)
    _, factor = crs.linear_units_factor
    return _Scale(False, float(factor), 1.0, 0.0, 0.0)


def native_steps(transform: Affine, rows: int, crs: Any) -> tuple[Any, Any]:
    """Signed metric steps of a grid per column and per row, for each row.

    Parameters
    ----------
    transform : affine.Affine
        The grid's geotransform (no rotation), in ``crs`` units.
    rows : int
        Number of rows.
    crs : rasterio.crs.CRS
        Geographic or projected (any linear unit).

    Returns
    -------
    step_x, step_y : ndarray of shape (rows,) or float
        Metres per column (towards east) and per row (negative when row 0 is north), at
        each row's centre latitude; scalars for a projected CRS. Feed them to
        :func:`~energy_planner.terrain.horn.horn_gradient`.
    """
    y = transform.f + (np.arange(rows) + 0.5) * transform.e
    kx, ky = metric_scale(crs).at(y)
    return transform.a * kx, transform.e * ky


def native_gradient(z: np.ndarray, transform: Affine, crs: Any) -> tuple[np.ndarray, np.ndarray]:
    """Horn gradient of a DEM on its own non-metric grid, in metres per metre.

    Returns
    -------
    dzdx, dzdy : ndarray of float64
        Towards local east and true north for a geographic CRS (along the CRS's x and y
        axes for a projected one); NaN on the border and around invalid cells.
    """
    sx, sy = native_steps(transform, z.shape[0], crs)
    return horn_gradient(z, sx, sy)


@dataclass(frozen=True, eq=False)
class NativeGrid:
    """Horn slope and aspect on a DEM's own grid (what ``terrain`` writes).

    Attributes
    ----------
    elevation : ndarray
        The DEM as read (north-up), NaN = invalid.
    dzdx, dzdy : ndarray
        Horn gradient in metres per metre towards the grid's east and north: local east
        and true north on a longitude/latitude grid.
    transform : affine.Affine
        North-up geotransform of the grid.
    crs : rasterio.crs.CRS or None
        The grid's CRS.
    """

    elevation: np.ndarray
    dzdx: np.ndarray
    dzdy: np.ndarray
    transform: Affine
    crs: Any

    @cached_property
    def slope(self) -> np.ndarray:
        """Slope ``atan(|grad z|)``, radians."""
        return slope_from_gradient(self.dzdx, self.dzdy, degrees=False)

    @cached_property
    def aspect_deg(self) -> np.ndarray:
        """GIS aspect (downslope, degrees clockwise from the grid's north; NaN if flat)."""
        return aspect_from_gradient(self.dzdx, self.dzdy, degrees=True)


def gradient_to_work(
    grads: tuple[np.ndarray, np.ndarray],
    src_transform: Affine,
    crs: Any,
    src_x: np.ndarray,
    src_y: np.ndarray,
    work_step: tuple[float, float],
) -> tuple[np.ndarray, np.ndarray]:
    """The native gradient at working cell centres, in the working grid's axes.

    Parameters
    ----------
    grads : (ndarray, ndarray)
        :func:`native_gradient` on the source grid (north-up ``src_transform``).
    src_transform : affine.Affine
        The source grid's geotransform.
    crs : rasterio.crs.CRS
        The source CRS.
    src_x, src_y : ndarray, shape (n + 2, m + 2)
        Source-CRS coordinates of a block of ``n x m`` working cell centres *and* a ring
        of their neighbours (one row above and below, one column each side).
    work_step : (float, float)
        Working grid steps per column and per row (``dy < 0``), metres.

    Returns
    -------
    dzdx, dzdy : ndarray, shape (n, m)
        ``dz/dx`` and ``dz/dy`` of the working CRS; NaN where any source cell carrying
        bilinear weight has no gradient.
    """
    grid = (
        src_transform.c + 0.5 * src_transform.a,
        src_transform.f + 0.5 * src_transform.e,
        src_transform.a,
        src_transform.e,
    )
    cx, cy = src_x[1:-1, 1:-1], src_y[1:-1, 1:-1]
    ge, gn = bilinear(grads, grid, cx, cy)
    scale = metric_scale(crs)
    kx, ky = scale.at(cy)
    dx, dy = work_step
    # d(source x, y) / d(working x) and / d(working y): central differences over the ring
    # (row r - 1 is the neighbour at +y when dy < 0)
    dsx = src_x[1:-1, 2:] - src_x[1:-1, :-2]
    dsy_x = src_y[1:-1, 2:] - src_y[1:-1, :-2]
    dsx_y = src_x[:-2, 1:-1] - src_x[2:, 1:-1]
    dsy = src_y[:-2, 1:-1] - src_y[2:, 1:-1]
    if scale.geographic:  # a longitude difference across the antimeridian
        half = math.pi / scale.unit_rad
        dsx = (dsx + half) % (2 * half) - half
        dsx_y = (dsx_y + half) % (2 * half) - half
    de_dx = kx * dsx / (2.0 * dx)
    dn_dx = ky * dsy_x / (2.0 * dx)
    de_dy = kx * dsx_y / (-2.0 * dy)
    dn_dy = ky * dsy / (-2.0 * dy)
    return ge * de_dx + gn * dn_dx, ge * de_dy + gn * dn_dy
