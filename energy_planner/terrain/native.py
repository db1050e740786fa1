"""Horn on a DEM's own grid when its CRS is not metric (longitude/latitude, feet, Mercator).

A longitude/latitude DEM is not resampled before its slopes are computed: resampling
smooths them (on the bundled Jacksboro DEM the UTM round trip lowered slopes by 0.72 deg
median against Horn on the native grid). Instead:

1. :func:`native_gradient`: Horn on the DEM's own grid, each row with its own metric
   spacing. For a geographic CRS the step along a parallel is ``dlon N(lat) cos(lat)``
   and along a meridian ``dlat M(lat)`` (``N``, ``M``: the prime-vertical and meridional
   radii of curvature of the CRS's ellipsoid, closed form), which is the geodesic
   distance between neighbouring cell centres to ~1e-9 for arc-second cells. The gradient
   is towards local east and true north. For a projected CRS in another unit than the
   metre (US feet) the steps are the pixel size times the unit's length in metres; for a
   cylindrical one whose map metres are not ground metres (web-mercator) each row's
   ground steps from the exact inverse projection (:func:`metric_scale`).
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
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
from affine import Affine

from energy_planner.terrain.horn import (
    aspect_from_gradient,
    horn_gradient,
    shade,
    slope_from_gradient,
)
from energy_planner.terrain.sample import bilinear

__all__ = [
    "NativeGrid",
    "gradient_to_work",
    "metric_scale",
    "native_gradient",
    "native_steps",
]


#: Map units may differ from ground metres by this share (after the CRS's unit) and the
#: DEM still be read as metric: 0.5 % (a UTM grid is within 0.1 % inside its zone).
GROUND_TOLERANCE = 0.005


@dataclass(frozen=True, eq=False)
class _Scale:
    """How many ground metres one unit of a CRS's coordinates is, along x and y."""

    geographic: bool
    unit_m: float  # projected: metres per unit
    unit_rad: float  # geographic: radians per angular unit
    a: float  # semi-major axis, m
    e2: float  # first eccentricity squared
    ground: Any = None  # projected, map metres not ground metres: _GroundJacobian

    @property
    def metric(self) -> bool:
        """True if the coordinates are ground metres (within :data:`GROUND_TOLERANCE`)."""
        return not self.geographic and self.ground is None and abs(self.unit_m - 1.0) < 1e-12

    def at(self, y: np.ndarray, x: Any = None) -> tuple[np.ndarray | float, np.ndarray | float]:
        """Ground metres per unit of x and of y at ``(x, y)`` (``y`` latitude if geographic).

        ``x`` matters only for a projected CRS whose scale is not 1 (then it depends on
        ``y`` alone, :func:`metric_scale` checked it; ``x`` defaults to the DEM's centre).
        """
        if self.ground is not None:
            return self.ground.steps(x, y)
        if not self.geographic:
            return self.unit_m, self.unit_m
        phi = np.asarray(y, dtype=np.float64) * self.unit_rad
        s2 = np.sin(phi) ** 2
        w = np.sqrt(1.0 - self.e2 * s2)
        n = self.a / w  # prime vertical radius of curvature
        m = self.a * (1.0 - self.e2) / (w * w * w)  # meridional radius of curvature
        return self.unit_rad * n * np.cos(phi), self.unit_rad * m


class _GroundJacobian:
    """Ground metres per map unit of a projected CRS, from its exact inverse projection.

    At map point ``(x, y)``: the geodetic ``(lon, lat)`` of ``(x +- h, y)`` and
    ``(x, y +- h)`` (central differences, ``h`` one map unit), and the ellipsoid's radii of
    curvature turn the changes into metres east and north on the ground.
    """

    def __init__(self, pc: Any, x_ref: float) -> None:
        from pyproj import Transformer

        geod = pc.geodetic_crs
        self.to_geo = Transformer.from_crs(pc, geod, always_xy=True)
        ell = geod.ellipsoid
        a = float(ell.semi_major_metre)
        b = float(ell.semi_minor_metre)
        self.a, self.e2 = a, 1.0 - (b / a) ** 2
        self.x_ref = float(x_ref)

    def jacobian(self, x: Any, y: Any) -> tuple[np.ndarray, ...]:
        """``(east_x, north_x, east_y, north_y)``: ground metres per map unit of x and y."""
        x = np.asarray(self.x_ref if x is None else x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        x, y = np.broadcast_arrays(x, y)
        h = 1.0
        lon = []
        lat = []
        for dx, dy in ((h, 0.0), (-h, 0.0), (0.0, h), (0.0, -h)):
            lo, la = self.to_geo.transform(x + dx, y + dy)
            lon.append(np.asarray(lo, dtype=np.float64))
            lat.append(np.asarray(la, dtype=np.float64))
        phi = np.radians(0.25 * (lat[0] + lat[1] + lat[2] + lat[3]))
        w = np.sqrt(1.0 - self.e2 * np.sin(phi) ** 2)
        k_east = self.a / w * np.cos(phi) * (math.pi / 180.0)  # metres per degree of lon
        k_north = self.a * (1.0 - self.e2) / w**3 * (math.pi / 180.0)
        dlon_x = ((lon[0] - lon[1] + 180.0) % 360.0 - 180.0) / (2 * h)
        dlon_y = ((lon[2] - lon[3] + 180.0) % 360.0 - 180.0) / (2 * h)
        return (
            k_east * dlon_x,
            k_north * (lat[0] - lat[1]) / (2 * h),
            k_east * dlon_y,
            k_north * (lat[2] - lat[3]) / (2 * h),
        )

    def steps(self, x: Any, y: Any) -> tuple[np.ndarray, np.ndarray]:
        """Ground metres per map unit along x and along y (axes east and north)."""
        ex, nx, ey, ny = self.jacobian(x, y)
        return np.hypot(ex, nx), np.hypot(ey, ny)


def _transverse_mercator_within(crs: Any, bounds: Sequence[float]) -> bool:
    """True if ``crs`` is transverse Mercator (UTM) with ground metres over ``bounds``.

    The scale of a transverse Mercator projection at a distance ``x`` from its central
    meridian is ``k0 * (1 + x**2 / (2 * k0**2 * R**2) + ...)`` (Snyder, *Map
    Projections: A Working Manual*, eq. 8-11), so the check that
    :func:`metric_scale` makes on a grid of points is answered in closed form, without
    importing pyproj (a tenth of a second of every command's start-up). The bound
    keeps a margin: a case near :data:`GROUND_TOLERANCE` goes to the exact check.

    Examples
    --------
    >>> from rasterio.crs import CRS
    >>> _transverse_mercator_within(CRS.from_epsg(32631), (500000, 5e6, 500200, 5000200))
    True
    >>> _transverse_mercator_within(CRS.from_epsg(32631), (-2e6, 5e6, -1.9e6, 5.1e6))
    False
    >>> _transverse_mercator_within(CRS.from_epsg(3857), (0, 5e6, 200, 5000200))
    False
    """
    try:
        params = crs.to_dict()
        factor = float(crs.linear_units_factor[1])
    except Exception:  # noqa: BLE001 - not a CRS this shortcut reads: the exact check
        return False
    if params.get("proj") == "utm":
        k0, x0 = 0.9996, 500000.0
    elif params.get("proj") == "tmerc":
        k0, x0 = float(params.get("k_0", params.get("k", 1.0))), float(params.get("x_0", 0.0))
    else:
        return False
    x_far = max(abs(float(bounds[0]) * factor - x0), abs(float(bounds[2]) * factor - x0))
    radius = 6356752.0  # the smallest radius of curvature of the common ellipsoids, metres
    k_far = k0 * (1.0 + 1.05 * (x_far / (k0 * radius)) ** 2 / 2.0)  # 5 % margin on the term
    margin = 0.8 * GROUND_TOLERANCE
    return abs(k0 - 1.0) <= margin and abs(k_far - 1.0) <= margin


def metric_scale(
    crs: Any, bounds: Sequence[float] | None = None, name: str | None = None
) -> _Scale:
    """The ground scale of a CRS's coordinates (see :meth:`_Scale.at`).

    Parameters
    ----------
    crs : rasterio.crs.CRS
        A geographic CRS (angles on an ellipsoid) or a projected CRS in any linear unit.
    bounds : (left, bottom, right, top), optional
        The DEM's extent in ``crs``. With it, a projected CRS is checked on a 5 x 5 grid of
        points: where its map units are ground metres times the unit's length (within
        :data:`GROUND_TOLERANCE`), as for UTM, the scale is the unit's length; where not
        (web-mercator: 1.41 map metres per ground metre at 45 deg N) but the map's axes
        point east and north and the scale depends on ``y`` only (Mercator and the other
        cylindrical projections), the scale is the exact one at each point; otherwise
        the DEM is refused.
    name : str, optional
        The DEM's file, for the error.

    Returns
    -------
    _Scale
        ``.at(y)`` gives ground metres per unit of x and y at ``y``; ``.metric`` is True
        when the coordinates are ground metres.

    Raises
    ------
    DEMError
        A projected CRS whose scale differs from 1 over the DEM and varies along x or
        turns the axes (a conic or azimuthal projection far from its true scale): the
        message gives the ``gdalwarp`` command to the DEM's UTM zone.

    Examples
    --------
    >>> from rasterio.crs import CRS
    >>> kx, ky = metric_scale(CRS.from_epsg(4326)).at(0.0)  # one degree on the equator
    >>> round(float(kx), 1), round(float(ky), 1)
    (111319.5, 110574.3)
    >>> kx, ky = metric_scale(CRS.from_epsg(2229)).at(0.0)  # California zone 5, US feet
    >>> round(kx, 12), round(ky, 12)  # 1200/3937 m, everywhere
    (0.304800609601, 0.304800609601)
    >>> s = metric_scale(CRS.from_epsg(3857), (333000.0, 5621000.0, 334000.0, 5622000.0))
    >>> kx, ky = s.at(5621500.0)  # web-mercator at 45 deg N: 0.71 ground m per map m
    >>> s.metric, round(float(kx), 4), round(float(ky), 4)
    (False, 0.7083, 0.7059)
    """
    if bounds is not None and _transverse_mercator_within(crs, bounds):
        return _Scale(False, float(crs.linear_units_factor[1]), 1.0, 0.0, 0.0)
    from pyproj import CRS as ProjCRS

    pc = ProjCRS.from_user_input(crs.to_wkt())
    if pc.is_geographic:
        ell = pc.ellipsoid
        a = float(ell.semi_major_metre)
        b = float(ell.semi_minor_metre)
        unit = pc.axis_info[0].unit_conversion_factor if pc.axis_info else math.pi / 180.0
        return _Scale(True, 1.0, float(unit), a, 1.0 - (b / a) ** 2)
    _, factor = crs.linear_units_factor
    plain = _Scale(False, float(factor), 1.0, 0.0, 0.0)
    if bounds is None or pc.geodetic_crs is None:
        return plain
    left, bottom, right, top = (float(v) for v in bounds)
    ground = _GroundJacobian(pc, 0.5 * (left + right))
    xs, ys = np.meshgrid(np.linspace(left, right, 5), np.linspace(bottom, top, 5))
    with np.errstate(invalid="ignore"):
        ex, nx, ey, ny = ground.jacobian(xs, ys)
    kx, ky = np.hypot(ex, nx), np.hypot(ey, ny)
    if not (np.all(np.isfinite(kx)) and np.all(np.isfinite(ky))):
        return plain  # outside the projection's domain: the warp or the sampling says so
    rel = np.concatenate([kx.ravel(), ky.ravel()]) / float(factor)
    if np.all(np.abs(rel - 1.0) <= GROUND_TOLERANCE):
        return plain
    turned = np.abs(np.arctan2(nx, ex)).max() + np.abs(np.arctan2(ey, ny)).max()
    along_x = max(np.ptp(kx, axis=1).max() / kx.mean(), np.ptp(ky, axis=1).max() / ky.mean())
    if turned < 1e-7 and along_x < 1e-7:
        return _Scale(False, float(factor), 1.0, 0.0, 0.0, ground)
    from energy_planner.errors import DEMError
    from energy_planner.terrain.dem import utm_epsg

    lon, lat = ground.to_geo.transform(0.5 * (left + right), 0.5 * (bottom + top))
    epsg = utm_epsg(float(lon), float(lat))
    dem = f"DEM {name!r}" if name else "the DEM"
    out = f"{Path(name).stem}_utm.tif" if name else "dem_utm.tif"
    fix = (
        f"warp it to its UTM zone first: gdalwarp -t_srs EPSG:{epsg} -r bilinear "
        f"{name or 'dem.tif'} {out}"
    )
    if crs.to_epsg() == epsg:  # a UTM DEM reaching far beyond its zone
        fix = (
            "it reaches far beyond its UTM zone: cut it into parts of one zone each, "
            f"each warped to its zone (gdalwarp -t_srs EPSG:326ZZ -te ... {name or 'dem.tif'} "
            "part.tif)"
        )
    raise DEMError(
        f"{dem} is in {crs}, whose map units are {1 / rel.max():.3f} .. {1 / rel.min():.3f} "
        "per ground metre over the DEM (not ground metres: slopes and distances would be "
        f"off by that much); {fix}",
        path=name,
        value=str(crs),
        crs=str(crs),
        expected="a CRS whose map metres are ground metres (UTM, a national grid)",
        hint=f"gdalwarp -t_srs EPSG:{epsg} -r bilinear",
    )


def native_steps(
    transform: Affine, rows: int, crs: Any, scale: _Scale | None = None
) -> tuple[Any, Any]:
    """Signed metric steps of a grid per column and per row, for each row.

    Parameters
    ----------
    transform : affine.Affine
        The grid's geotransform (no rotation), in ``crs`` units.
    rows : int
        Number of rows.
    crs : rasterio.crs.CRS
        Geographic or projected (any linear unit).
    scale : _Scale, optional
        :func:`metric_scale` of ``crs`` over the DEM (default: from ``crs`` alone).

    Returns
    -------
    step_x, step_y : ndarray of shape (rows,) or float
        Metres per column (towards east) and per row (negative when row 0 is north), at
        each row's centre latitude; scalars for a projected CRS. Feed them to
        :func:`~energy_planner.terrain.horn.horn_gradient`.
    """
    y = transform.f + (np.arange(rows) + 0.5) * transform.e
    kx, ky = (scale or metric_scale(crs)).at(y)
    return transform.a * kx, transform.e * ky


def native_gradient(
    z: np.ndarray, transform: Affine, crs: Any, scale: _Scale | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Horn gradient of a DEM on its own non-metric grid, in metres per metre.

    Returns
    -------
    dzdx, dzdy : ndarray of float64
        Towards local east and true north for a geographic CRS (along the CRS's x and y
        axes for a projected one); NaN on the border and around invalid cells.
    """
    sx, sy = native_steps(transform, z.shape[0], crs, scale)
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
    scale: Any = None  # metric_scale of the CRS over the DEM (native_steps)

    @cached_property
    def slope(self) -> np.ndarray:
        """Slope ``atan(|grad z|)``, radians."""
        return slope_from_gradient(self.dzdx, self.dzdy, degrees=False)

    @cached_property
    def aspect_deg(self) -> np.ndarray:
        """GIS aspect (downslope, degrees clockwise from the grid's north; NaN if flat)."""
        return aspect_from_gradient(self.dzdx, self.dzdy, degrees=True)

    def hillshade(self, azimuth: float = 315.0, altitude: float = 45.0) -> np.ndarray:
        """Hillshade in [0, 1] of the grid, from its Horn gradient (:func:`horn.shade`)."""
        return shade(self.dzdx, self.dzdy, azimuth, altitude)


def gradient_to_work(
    grads: tuple[np.ndarray, np.ndarray],
    src_transform: Affine,
    crs: Any,
    src_x: np.ndarray,
    src_y: np.ndarray,
    work_step: tuple[float, float],
    scale: _Scale | None = None,
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
    scale : _Scale, optional
        :func:`metric_scale` of ``crs`` over the DEM (default: from ``crs`` alone).

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
    scale = scale or metric_scale(crs)
    kx, ky = scale.at(cy, cx)
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
