"""DEM loading and the :class:`Terrain` working grid.

A :class:`Terrain` is a north-up grid in a metric CRS (the *working* grid): elevation,
the Horn gradient, slope and azimuths, the geotransform and the CRS. :func:`load_dem`
builds one from any single-band raster rasterio opens; :meth:`Terrain.from_array` and
:meth:`Terrain.from_function` build one from numbers (tests, synthetic maps).

Decisions (see also ``docs/terrain.md``):

- Nodata and NaN cells become NaN in ``elevation``; every later quantity is NaN where it
  would need them (Horn window, bilinear sampling). Nothing is filled in.
- A geographic CRS (degrees), or a projected CRS whose linear unit is not the metre, gets
  Horn on its own grid with each row's geodesic cell size (:attr:`Terrain.native_grid`,
  :mod:`energy_planner.terrain.native`) and a working grid in the local UTM zone (WGS 84,
  zone of the DEM's centre), at a square pixel whose area equals the source pixel's area
  at the DEM's centre (same cell count); the grid is laid out by ``rasterio.warp``
  (``calculate_default_transform``) and every working cell centre is projected back
  exactly with ``rasterio.warp.transform``. There the elevation is bilinear in the source
  elevation and the gradient bilinear in the native gradient, turned into UTM axes (not
  Horn of the warped elevation, which smooths slopes). A working cell is valid only if
  every source cell bilinear resampling draws on is valid. ``source_crs`` keeps the DEM's
  own CRS; :meth:`Terrain.to_work` / :meth:`Terrain.from_work` convert coordinates.
- A DEM without a CRS is taken as local metric coordinates (x east, y north, metres), with
  a ``UserWarning``: its slopes are only right if the pixels really are metres.
- A south-up or east-to-west grid is flipped to north-up; a rotated or sheared
  geotransform raises :class:`~energy_planner.errors.DEMError` (warp it first).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import InitVar, dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
from affine import Affine

from energy_planner.errors import CoordinateError, DEMError, DEMIOError, extent_text, fmt_num
from energy_planner.terrain.horn import (
    aspect_from_gradient,
    horn_gradient,
    pixel_steps,
)
from energy_planner.terrain.memory import BYTES_PER_CELL, LONLAT_BYTES_PER_CELL, check_memory
from energy_planner.terrain.native import NativeGrid, gradient_to_work, native_gradient
from energy_planner.terrain.sample import TerrainSample, bilinear

__all__ = ["Terrain", "load_dem", "utm_epsg"]


def _as_crs(crs: Any) -> Any:
    """``rasterio.crs.CRS`` from anything it accepts; None stays None."""
    if crs is None:
        return None
    from rasterio.crs import CRS
    from rasterio.errors import CRSError

    if isinstance(crs, CRS):
        return crs
    try:
        return CRS.from_user_input(crs)
    except CRSError as exc:
        raise DEMError(f"CRS {crs!r} is not understood: {exc}") from exc


def _is_metric(crs: Any) -> bool:
    """True for a projected CRS whose linear unit is the metre."""
    if crs is None:
        return True
    if crs.is_geographic:
        return False
    try:
        _, factor = crs.linear_units_factor
    except Exception:  # rasterio raises CRSError for odd definitions
        return False
    return abs(factor - 1.0) < 1e-12


def utm_epsg(lon: float, lat: float) -> int:
    """EPSG code of the WGS 84 UTM zone containing ``(lon, lat)`` (degrees).

    Examples
    --------
    >>> utm_epsg(-84.25, 36.6), utm_epsg(2.35, 48.85), utm_epsg(151.2, -33.9)
    (32616, 32631, 32756)
    """
    zone = int(math.floor((lon + 180.0) / 6.0)) % 60 + 1
    return (32600 if lat >= 0 else 32700) + zone


def _scalar_or_array(a: np.ndarray) -> np.ndarray | float:
    return float(a) if np.ndim(a) == 0 else a


def _north_up(arrays: Sequence[np.ndarray], t: Affine) -> tuple[list[np.ndarray], Affine]:
    """Flip grids (and their transform) to north-up, west-to-east; C-contiguous copies."""
    sx, sy = pixel_steps(t)
    out = [np.array(a, dtype=np.float64, order="C", copy=True) for a in arrays]
    rows, cols = out[0].shape
    if sx < 0:  # east-to-west columns: flip to west-to-east
        out = [np.ascontiguousarray(a[:, ::-1]) for a in out]
        t = t @ Affine.translation(cols, 0) @ Affine.scale(-1, 1)
    if sy > 0:  # south-up rows: flip to north-up
        out = [np.ascontiguousarray(a[::-1, :]) for a in out]
        t = t @ Affine.translation(0, rows) @ Affine.scale(1, -1)
    return out, t


@dataclass(eq=False, repr=False)
class Terrain:
    """A DEM on a north-up metric working grid, with its Horn gradient.

    Parameters
    ----------
    elevation : ndarray, shape (rows, cols)
        Elevation in metres, ``elevation[row, col]``; NaN = invalid. Copied to a
        C-contiguous float64 array; a south-up/east-to-west grid is flipped to north-up
        (row 0 north, column 0 west).
    transform : affine.Affine
        Geotransform of the working grid (cell corner convention, as rasterio).
    crs : rasterio.crs.CRS, str or None
        Working CRS (projected, metres); None = local metric coordinates.
    source_crs : CRS, str or None
        The DEM's own CRS (may be geographic); defaults to ``crs``.
    source_transform : affine.Affine or None
        The DEM's own geotransform (before any warp); defaults to ``transform``.
    source_shape : (int, int) or None
        The DEM's own shape; defaults to ``elevation.shape``.
    path : pathlib.Path or None
        File the DEM came from.
    native : NativeGrid or None
        Horn slope and aspect on the DEM's own grid when that grid is not metric
        (longitude/latitude): :func:`load_dem` computes them there and derives ``dzdx``,
        ``dzdy`` from them. None when the working grid is the DEM's grid.
    gradient : (ndarray, ndarray) or None
        Init only: the working grid's gradient when it is not Horn of ``elevation`` on
        this grid (a geographic DEM's native gradient carried over); None computes Horn.
        Needs a north-up grid; float64 C-contiguous arrays are kept, not copied, and set
        to NaN in place where a component or the elevation is invalid.

    Attributes
    ----------
    dzdx, dzdy : ndarray of float64
        Horn gradient towards east and north (m/m), NaN where not computable.

    Notes
    -----
    Angles: ``slope = atan(|grad z|)``; ``uphill_azimuth = atan2(dzdy, dzdx)`` in radians
    counter-clockwise from east; ``aspect_deg`` is the GIS aspect (downslope, degrees
    clockwise from north, NaN on flat cells, as gdaldem).

    Examples
    --------
    >>> t = Terrain.from_function(lambda x, y: 0.1 * y, size=(10, 10))
    >>> t.shape, t.grid
    ((10, 10), (0.5, 9.5, 1.0, -1.0))
    >>> s = t.sample(5.0, 5.0)
    >>> round(s.elevation, 9), round(math.degrees(s.uphill_azimuth), 9)
    (0.5, 90.0)
    """

    elevation: np.ndarray
    transform: Affine
    crs: Any = None
    source_crs: Any = None
    source_transform: Affine | None = None
    source_shape: tuple[int, int] | None = None
    path: Path | None = None
    native: NativeGrid | None = None
    gradient: InitVar[tuple[np.ndarray, np.ndarray] | None] = None
    dzdx: np.ndarray = field(init=False)
    dzdy: np.ndarray = field(init=False)

    def __post_init__(self, gradient: tuple[np.ndarray, np.ndarray] | None) -> None:
        z = np.asarray(self.elevation)
        if z.ndim != 2:
            raise DEMError(f"elevation must be a 2-D array, got shape {z.shape}")
        rows, cols = z.shape
        t = self.transform if isinstance(self.transform, Affine) else Affine(*self.transform)
        if gradient is not None:
            sx, sy = pixel_steps(t)
            if sx < 0 or sy > 0:
                raise DEMError("a given gradient needs a north-up, west-to-east grid")
            z = np.array(z, dtype=np.float64, order="C", copy=True)
        else:
            (z,), t = _north_up([z], t)
        z[~np.isfinite(z)] = np.nan
        self.elevation = z
        self.transform = t
        self.crs = _as_crs(self.crs)
        self.source_crs = self.crs if self.source_crs is None else _as_crs(self.source_crs)
        if self.source_transform is None:
            self.source_transform = t
        if self.source_shape is None:
            self.source_shape = (rows, cols)
        if gradient is None:
            self.dzdx, self.dzdy = horn_gradient(z, t.a, t.e)
        else:
            gx, gy = (np.ascontiguousarray(g, dtype=np.float64) for g in gradient)
            if gx.shape != z.shape or gy.shape != z.shape:
                raise DEMError(
                    f"gradient shapes {gx.shape}, {gy.shape}: expected the elevation's "
                    f"shape {z.shape}"
                )
            bad = ~(np.isfinite(gx) & np.isfinite(gy) & np.isfinite(z))
            gx[bad] = np.nan
            gy[bad] = np.nan
            self.dzdx, self.dzdy = gx, gy

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_array(
        cls,
        elevation: np.ndarray,
        resolution: float | Sequence[float] = 1.0,
        origin: tuple[float, float] = (0.0, 0.0),
        crs: Any = "EPSG:32631",
        nodata: float | None = None,
    ) -> Terrain:
        """Terrain from an elevation array on a north-up grid.

        Parameters
        ----------
        elevation : array_like, shape (rows, cols)
            Elevation in metres. **Row 0 is the northern edge** (raster order, as
            ``Terrain.elevation`` itself); column 0 the western edge.
        resolution : float or (float, float)
            Pixel size in metres, square or ``(xres, yres)``.
        origin : (float, float)
            ``(x_min, y_min)``: the south-west *outer corner* of the grid, so the default
            map covers ``[0, cols*xres] x [0, rows*yres]``. Cell ``(r, c)`` has its
            centre at ``(x_min + (c + 0.5) xres, y_min + (rows - r - 0.5) yres)``; see
            :meth:`cell_centers`, or use :meth:`from_function` to avoid index
            bookkeeping.
        crs : CRS, str or None
            A projected CRS in metres, or None for local coordinates.
        nodata : float or None
            Value to treat as invalid (NaN is always invalid).

        Returns
        -------
        Terrain

        Examples
        --------
        >>> t = Terrain.from_array(np.zeros((3, 4)), resolution=2.0, origin=(10.0, 20.0))
        >>> t.bounds
        (10.0, 20.0, 18.0, 26.0)
        """
        z = np.array(elevation, dtype=np.float64, copy=True)
        if z.ndim != 2:
            raise DEMError(f"elevation must be a 2-D array, got shape {z.shape}")
        sx, sy = pixel_steps(resolution)
        x_min, y_min = (float(v) for v in origin)
        if nodata is not None:
            z[z == nodata] = np.nan
        c = _as_crs(crs)
        if c is not None and not _is_metric(c):
            raise DEMError(
                f"from_array needs a projected CRS in metres, got {c}; "
                "use load_dem for a geographic DEM (it reprojects to UTM)"
            )
        rows = z.shape[0]
        transform = Affine(sx, 0.0, x_min, 0.0, sy, y_min - sy * rows)
        return cls(z, transform, c)

    @classmethod
    def from_function(
        cls,
        func: Callable[[np.ndarray, np.ndarray], np.ndarray],
        size: tuple[float, float] = (100.0, 100.0),
        resolution: float = 1.0,
        origin: tuple[float, float] = (0.0, 0.0),
        crs: Any = "EPSG:32631",
    ) -> Terrain:
        """Terrain with ``elevation = func(x, y)`` evaluated at cell centres.

        Parameters
        ----------
        func : callable
            Vectorized ``z = func(x, y)`` in map coordinates (x east, y north, metres).
        size : (float, float)
            ``(width, height)`` in metres, rounded to whole cells.
        resolution : float
            Square pixel size in metres.
        origin : (float, float)
            South-west outer corner ``(x_min, y_min)``.
        crs : CRS, str or None
            Projected CRS in metres (None = local coordinates).

        Examples
        --------
        >>> t = Terrain.from_function(lambda x, y: x + 2 * y, size=(4, 3))
        >>> t.elevation[0].tolist(), t.elevation[:, 0].tolist()  # row 0 is north
        ([5.5, 6.5, 7.5, 8.5], [5.5, 3.5, 1.5])
        """
        cols = int(round(size[0] / resolution))
        rows = int(round(size[1] / resolution))
        if rows < 1 or cols < 1:
            raise DEMError(f"size {size} at resolution {resolution} gives no cells")
        x = origin[0] + (np.arange(cols) + 0.5) * resolution
        y = origin[1] + (rows - np.arange(rows) - 0.5) * resolution
        xx, yy = np.meshgrid(x, y)
        z = np.broadcast_to(np.asarray(func(xx, yy), dtype=np.float64), xx.shape)
        return cls.from_array(z, resolution=resolution, origin=origin, crs=crs)

    # ------------------------------------------------------------------ grid
    def __repr__(self) -> str:
        rx, ry = self.resolution
        return (
            f"Terrain(shape={self.shape}, resolution=({rx:g}, {ry:g}) m, crs={self.crs}, "
            f"source_crs={self.source_crs}, valid={1 - self.nodata_fraction:.1%}, "
            f"path={self.path})"
        )

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)`` of the working grid."""
        return self.elevation.shape  # type: ignore[return-value]

    @property
    def resolution(self) -> tuple[float, float]:
        """Pixel size ``(xres, yres)`` in metres (positive)."""
        return float(self.transform.a), float(-self.transform.e)

    @property
    def grid(self) -> tuple[float, float, float, float]:
        """``(x0, y0, dx, dy)``: centre of cell (0, 0) and steps, ``dx > 0``, ``dy < 0``.

        Cell ``(r, c)`` is centred at ``(x0 + c dx, y0 + r dy)``; a kernel samples
        ``dzdx``/``dzdy`` at fractional index ``((y - y0) / dy, (x - x0) / dx)``.
        """
        t = self.transform
        return (float(t.c + 0.5 * t.a), float(t.f + 0.5 * t.e), float(t.a), float(t.e))

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """``(left, bottom, right, top)`` outer bounds of the working grid."""
        t = self.transform
        rows, cols = self.shape
        return (float(t.c), float(t.f + rows * t.e), float(t.c + cols * t.a), float(t.f))

    def cell_centers(self) -> tuple[np.ndarray, np.ndarray]:
        """2-D arrays ``(x, y)`` of cell-centre coordinates in the working CRS."""
        x0, y0, dx, dy = self.grid
        rows, cols = self.shape
        return np.meshgrid(x0 + dx * np.arange(cols), y0 + dy * np.arange(rows))

    @cached_property
    def valid(self) -> np.ndarray:
        """Boolean mask of cells with a valid elevation."""
        return np.isfinite(self.elevation)

    @property
    def nodata_fraction(self) -> float:
        """Share of working-grid cells without a valid elevation."""
        return float(1.0 - self.valid.mean()) if self.valid.size else 1.0

    # ------------------------------------------------------------------ derived
    @cached_property
    def slope(self) -> np.ndarray:
        """Slope ``atan(|grad z|)``, radians; NaN where the gradient is NaN."""
        return np.arctan(np.hypot(self.dzdx, self.dzdy))

    @cached_property
    def uphill_azimuth(self) -> np.ndarray:
        """Uphill azimuth ``atan2(dzdy, dzdx)``, radians CCW from east (0 on flat cells)."""
        return np.arctan2(self.dzdy, self.dzdx)

    @cached_property
    def aspect_deg(self) -> np.ndarray:
        """GIS aspect: downslope, degrees clockwise from north in [0, 360); NaN if flat."""
        return aspect_from_gradient(self.dzdx, self.dzdy, degrees=True)

    @cached_property
    def native_grid(self) -> NativeGrid:
        """Horn slope and aspect on the DEM's own grid (what ``terrain`` writes).

        For a longitude/latitude DEM: Horn with geodesic spacing on the lon/lat grid,
        aspect from true north (:attr:`native`). Otherwise the working grid itself.
        """
        if self.native is not None:
            return self.native
        return NativeGrid(self.elevation, self.dzdx, self.dzdy, self.transform, self.crs)

    def hillshade(self, azimuth: float = 315.0, altitude: float = 45.0) -> np.ndarray:
        """Hillshade in [0, 1] of the working grid (see :func:`horn.hillshade`)."""
        from energy_planner.terrain.horn import hillshade

        return hillshade(self.elevation, self.transform, azimuth=azimuth, altitude=altitude)

    # ------------------------------------------------------------------ queries
    def sample(self, x: np.ndarray | float, y: np.ndarray | float) -> TerrainSample:
        """Bilinear terrain at working-CRS points ``(x, y)``; NaN outside/invalid.

        Elevation and the two gradient components are interpolated; slope and uphill
        azimuth are computed from the interpolated gradient (angles are never
        interpolated).

        Parameters
        ----------
        x, y : array_like
            Coordinates in the working CRS (``self.crs``), broadcast together.

        Returns
        -------
        TerrainSample
            Arrays shaped like the broadcast query (floats for scalar queries).
        """
        z, gx, gy = bilinear((self.elevation, self.dzdx, self.dzdy), self.grid, x, y)
        slope = np.arctan(np.hypot(gx, gy))
        psi = np.arctan2(gy, gx)
        return TerrainSample(*(_scalar_or_array(a) for a in (z, slope, psi, gx, gy)))

    def contains(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray | bool:
        """True where :meth:`sample` gives a finite gradient (usable for planning)."""
        s = self.sample(x, y)
        ok = np.isfinite(s.dzdx) & np.isfinite(s.dzdy)
        return bool(ok) if np.ndim(ok) == 0 else ok

    @property
    def source_bounds(self) -> tuple[float, float, float, float]:
        """``(xmin, ymin, xmax, ymax)`` of the DEM in its own CRS (``source_crs``)."""
        t = self.source_transform
        rows, cols = self.source_shape
        xs = (t.c, t.c + cols * t.a)
        ys = (t.f, t.f + rows * t.e)
        return (float(min(xs)), float(min(ys)), float(max(xs)), float(max(ys)))

    def _coordinate_error(
        self, crs: Any, x: np.ndarray, y: np.ndarray, bad: np.ndarray, source: bool, cause: str
    ) -> CoordinateError:
        """A :class:`CoordinateError` naming the first bad point, the CRS and the bounds."""
        i = int(np.flatnonzero(bad.ravel())[0])
        px, py = float(x.ravel()[i]), float(y.ravel()[i])
        n_bad, n = int(bad.sum()), int(bad.size)
        geographic = bool(getattr(crs, "is_geographic", False))
        bounds = self.source_bounds if source else self.bounds
        dem = f"the DEM {str(self.path)!r}" if self.path else "the DEM"
        if geographic:
            expected = "longitude,latitude in degrees"
            cover = (
                f"lon {fmt_num(bounds[0])} .. {fmt_num(bounds[2])}, "
                f"lat {fmt_num(bounds[1])} .. {fmt_num(bounds[3])}"
            )
            hint = (
                f"give longitude,latitude, e.g. {0.5 * (bounds[0] + bounds[2]):.5f},"
                f"{0.5 * (bounds[1] + bounds[3]):.5f} (the map's centre)"
            )
            if source:
                wx0, wy0, wx1, wy1 = self.bounds
                if wx0 <= px <= wx1 and wy0 <= py <= wy1:  # metres on the working grid
                    lon, lat = self.from_work(px, py)
                    hint = (
                        f"({px:.10g}, {py:.10g}) lies on the DEM's working grid "
                        f"{self.crs} at lon {lon:.7f}, lat {lat:.7f}: give that"
                    )
            kind = "geographic"
        else:
            expected = f"x,y in {crs}"
            cover = (
                f"x {fmt_num(bounds[0])} .. {fmt_num(bounds[2])}, "
                f"y {fmt_num(bounds[1])} .. {fmt_num(bounds[3])}"
            )
            hint = f"give coordinates in {crs}, inside the DEM's bounds"
            kind = "projected"
        where = f" (point {i}; {n_bad} of {n} points fail)" if n > 1 else ""
        return CoordinateError(
            f"coordinates ({px:.10g}, {py:.10g}){where} {cause}: {dem} is in {crs} "
            f"({kind}), covering {cover}; expected {expected}. Hint: {hint}",
            value=(px, py),
            crs=str(crs),
            bounds=bounds,
            expected=expected,
            hint=hint,
            path=self.path,
            index=i,
            n_bad=n_bad,
        )

    def _convert(self, src: Any, dst: Any, x: Any, y: Any, source: bool) -> tuple[Any, Any]:
        xa = np.asarray(x, dtype=np.float64)
        ya = np.asarray(y, dtype=np.float64)
        xa, ya = np.broadcast_arrays(xa, ya)
        if src is None or dst is None or src == dst:
            return _scalar_or_array(xa.copy()), _scalar_or_array(ya.copy())
        from rasterio.errors import CRSError
        from rasterio.warp import transform

        bad = ~(np.isfinite(xa) & np.isfinite(ya))
        if getattr(src, "is_geographic", False):
            with np.errstate(invalid="ignore"):
                bad |= (np.abs(ya) > 90.0) | (np.abs(xa) > 360.0)
        if bad.any():
            raise self._coordinate_error(
                src,
                xa,
                ya,
                bad,
                source,
                "are not a longitude, latitude (beyond +-90 deg latitude or +-360 deg longitude)"
                if getattr(src, "is_geographic", False)
                else "are not finite",
            )
        try:
            xs, ys = transform(src, dst, xa.ravel().tolist(), ya.ravel().tolist())
        except (CRSError, Exception) as exc:  # noqa: BLE001 - PROJ errors (CPLE_*Error)
            # find the points PROJ rejects, one by one, to name the first
            bad = np.zeros(xa.size, dtype=bool)
            for k, (a, b) in enumerate(zip(xa.ravel(), ya.ravel(), strict=True)):
                try:
                    transform(src, dst, [float(a)], [float(b)])
                except Exception:  # noqa: BLE001
                    bad[k] = True
            if not bad.any():
                bad[0] = True
            raise self._coordinate_error(
                src,
                xa,
                ya,
                bad.reshape(xa.shape),
                source,
                f"cannot be converted to {dst} (PROJ: {exc})",
            ) from exc
        xo = np.asarray(xs, dtype=np.float64).reshape(xa.shape)
        yo = np.asarray(ys, dtype=np.float64).reshape(ya.shape)
        bad = ~(np.isfinite(xo) & np.isfinite(yo))
        if bad.any():
            raise self._coordinate_error(
                src, xa, ya, bad, source, f"have no finite position in {dst}"
            )
        return _scalar_or_array(xo), _scalar_or_array(yo)

    def to_work(self, x: Any, y: Any) -> tuple[Any, Any]:
        """Convert coordinates from the DEM's own CRS (``source_crs``) to the working CRS.

        For a geographic DEM, ``x`` is longitude and ``y`` latitude in degrees.

        Parameters
        ----------
        x, y : float or array_like
            Coordinates in ``source_crs``, broadcast together.

        Returns
        -------
        x, y : float or ndarray
            In the working CRS (floats for scalar input).

        Raises
        ------
        CoordinateError
            A point cannot be converted (e.g. metric coordinates on a longitude/latitude
            DEM): the message and the fields name the point, the DEM's CRS and its bounds
            in that CRS. Points that convert but lie off the map are not an error here.
        """
        return self._convert(self.source_crs, self.crs, x, y, True)

    def from_work(self, x: Any, y: Any) -> tuple[Any, Any]:
        """Convert coordinates from the working CRS to the DEM's own CRS.

        Parameters
        ----------
        x, y : float or array_like
            Coordinates in the working CRS.

        Returns
        -------
        x, y : float or ndarray
            In ``source_crs``.

        Raises
        ------
        CoordinateError
            A point cannot be converted.
        """
        return self._convert(self.crs, self.source_crs, x, y, False)


# ---------------------------------------------------------------------- loading
def _warp_to_utm(
    z: np.ndarray, transform: Affine, crs: Any, path: Path
) -> tuple[np.ndarray, Affine, Any, tuple[np.ndarray, np.ndarray]]:
    """Reproject a non-metric DEM to its local UTM zone (bilinear, NaN-aware).

    Returns the working elevation, transform and CRS, and the working gradient: the
    native Horn gradient ``grads`` of ``z`` (:func:`~energy_planner.terrain.native.
    native_gradient`, ``transform`` north-up) carried to the working cell centres and
    axes by :func:`~energy_planner.terrain.native.gradient_to_work`.
    """
    from rasterio.crs import CRS
    from rasterio.transform import array_bounds
    from rasterio.warp import calculate_default_transform, transform_bounds
    from rasterio.warp import transform as warp_transform

    rows, cols = z.shape
    west, south, east, north = array_bounds(rows, cols, transform)
    lw, ls, le, ln = transform_bounds(crs, "EPSG:4326", west, south, east, north)
    lon_c, lat_c = 0.5 * (lw + le), 0.5 * (ls + ln)
    if not (-180 <= lon_c <= 180 and -80 <= lat_c <= 84):
        raise DEMError(
            f"DEM {path} is centred at lon {lon_c:.3f}, lat {lat_c:.3f}: outside the UTM "
            "range (80 S to 84 N); reproject it to a metric CRS first"
        )
    dst_crs = CRS.from_epsg(utm_epsg(lon_c, lat_c))
    if le - lw > 6.0:
        warnings.warn(
            f"DEM {path} spans {le - lw:.1f} degrees of longitude; in one UTM zone "
            f"({dst_crs}) its far parts are distorted (scale error grows with the distance "
            "from the central meridian). Reproject it to a suitable metric CRS first.",
            UserWarning,
            stacklevel=3,
        )
    # metric size of the centre pixel -> square pixel with the same area
    cc, cr = cols / 2.0, rows / 2.0
    px = [transform @ (cc, cr), transform @ (cc + 1, cr), transform @ (cc, cr + 1)]
    xs, ys = warp_transform(crs, dst_crs, [p[0] for p in px], [p[1] for p in px])
    d_col = math.hypot(xs[1] - xs[0], ys[1] - ys[0])
    d_row = math.hypot(xs[2] - xs[0], ys[2] - ys[0])
    res = math.sqrt(d_col * d_row)
    dst_transform, width, height = calculate_default_transform(
        crs, dst_crs, cols, rows, west, south, east, north, resolution=(res, res)
    )
    check_memory(
        (height, width),
        LONLAT_BYTES_PER_CELL,
        f"DEM {str(path)!r} reprojected to {dst_crs}",
        path=path,
    )
    # Point-bilinear resampling at exactly projected cell centres (PROJ for every centre).
    # Not GDAL's warper: when the target pixel is larger than the source pixel along an
    # axis (here 26 m over 21.9 m), its bilinear kernel is widened and a 10 deg plane came
    # back with 9.5..10.5 deg ripples (with or without its approximate transformer).
    # A working cell is valid only if every source cell with weight in it is valid.
    src_grid = (
        transform.c + 0.5 * transform.a,
        transform.f + 0.5 * transform.e,
        transform.a,
        transform.e,
    )
    grads = native_gradient(z, transform, crs)
    zw = np.empty((height, width))
    gxw = np.empty((height, width))
    gyw = np.empty((height, width))
    # working cell centres with a ring of neighbours (one column each side), for the
    # Jacobian of the back-projection in gradient_to_work
    xs_dst = dst_transform.c + (np.arange(-1, width + 1) + 0.5) * dst_transform.a
    block = max(1, 250_000 // max(width, 1))  # points per PROJ call: bounds the temporaries
    starts = range(0, height, block)
    if len(starts) > 2:  # big rasters: show progress on a terminal (stderr)
        from tqdm import tqdm

        starts = tqdm(
            starts,
            desc=f"reprojecting {path.name} to {dst_crs}",
            unit="block",
            disable=None,
            leave=False,
        )
    for r0 in starts:
        r1 = min(height, r0 + block)
        ys_dst = dst_transform.f + (np.arange(r0 - 1, r1 + 1) + 0.5) * dst_transform.e
        gx, gy = np.meshgrid(xs_dst, ys_dst)
        sx, sy = warp_transform(dst_crs, crs, gx.ravel(), gy.ravel())
        sx = np.asarray(sx).reshape(gx.shape)
        sy = np.asarray(sy).reshape(gx.shape)
        (zb,) = bilinear((z,), src_grid, sx[1:-1, 1:-1], sy[1:-1, 1:-1])
        zw[r0:r1] = zb
        gxw[r0:r1], gyw[r0:r1] = gradient_to_work(
            grads, transform, crs, sx, sy, (dst_transform.a, dst_transform.e)
        )
    return zw, dst_transform, dst_crs, grads, (gxw, gyw)


def _read_window(
    src: Any, bounds: Sequence[float] | None, decimate: int, name: str
) -> tuple[Any, tuple[int, int], Affine]:
    """The window to read, the shape to read it at and that grid's transform."""
    from rasterio.windows import Window, from_bounds

    full = Window(0, 0, src.width, src.height)
    if bounds is None:
        win = full
    else:
        try:
            xmin, ymin, xmax, ymax = (float(v) for v in bounds)
        except (TypeError, ValueError):
            raise DEMError(
                f"bounds {bounds!r} are not (xmin, ymin, xmax, ymax)",
                path=name,
                value=bounds,
                param="bounds",
                expected="(xmin, ymin, xmax, ymax) in the DEM's CRS",
            ) from None
        if not (xmin < xmax and ymin < ymax):
            raise DEMError(
                f"bounds {bounds!r}: expected xmin < xmax and ymin < ymax",
                path=name,
                value=bounds,
                param="bounds",
                expected="(xmin, ymin, xmax, ymax) in the DEM's CRS",
            )
        w = from_bounds(xmin, ymin, xmax, ymax, transform=src.transform)
        w = w.round_offsets(op="floor").round_lengths(op="ceil")
        try:
            win = w.intersection(full)
        except Exception:  # noqa: BLE001 - rasterio raises WindowError for disjoint windows
            win = None
        if win is None or win.width < 1 or win.height < 1:
            left, bottom, right, top = src.bounds
            raise DEMError(
                f"bounds {tuple(bounds)!r} do not overlap DEM {name!r}, which covers "
                f"{extent_text((left, bottom, right, top), src.crs)}",
                path=name,
                value=tuple(bounds),
                param="bounds",
                bounds=(left, bottom, right, top),
                crs=str(src.crs),
                expected="bounds inside the DEM, in its CRS",
            )
    if not (isinstance(decimate, int | np.integer) and decimate >= 1):
        raise DEMError(
            f"decimate={decimate!r} must be an integer >= 1",
            path=name,
            value=decimate,
            param="decimate",
            expected="an integer >= 1",
        )
    h, w_ = int(win.height), int(win.width)
    shape = (max(1, math.ceil(h / decimate)), max(1, math.ceil(w_ / decimate)))
    t = src.window_transform(win) @ Affine.scale(w_ / shape[1], h / shape[0])
    return win, shape, t


def open_dem(path: str | Path) -> Any:
    """Open a DEM with rasterio; a missing or unreadable file is a :class:`DEMIOError`.

    Returns the open dataset (use it as a context manager).
    """
    import rasterio
    from rasterio.errors import RasterioIOError

    name = str(path)
    if not name.startswith("/vsi") and "://" not in name and not Path(name).exists():
        raise DEMIOError(
            f"DEM file {name!r} does not exist (expected a raster, e.g. GeoTIFF)",
            path=name,
            expected="a raster file (GeoTIFF, ...)",
        )
    try:
        return rasterio.open(name)
    except RasterioIOError as exc:
        raise DEMIOError(
            f"cannot open DEM {name!r} as a raster: {exc}",
            path=name,
            expected="a raster file (GeoTIFF, ...)",
        ) from exc


def load_dem(
    path: str | Path,
    band: int | None = None,
    *,
    bounds: Sequence[float] | None = None,
    decimate: int = 1,
) -> Terrain:
    """Load a single-band DEM raster into a metric :class:`Terrain`.

    Parameters
    ----------
    path : str or pathlib.Path
        Any raster rasterio opens (GeoTIFF, ...). Elevation in metres.
    band : int or None
        1-based band to read; required when the raster has several bands.
    bounds : (xmin, ymin, xmax, ymax), optional
        Read only this window, in the DEM's own CRS (whole cells covering it, clipped to
        the raster). For a raster too large to load whole.
    decimate : int
        Read every ``decimate``-th cell along each axis, each new cell the average of the
        ``decimate x decimate`` cells it covers (GDAL average resampling, nodata cells
        left out); 1 (default) reads the raster as it is.

    Returns
    -------
    Terrain
        On the DEM's own grid when its CRS is projected in metres (or absent), else on a
        UTM grid with the gradient of Horn on the DEM's own grid, which ``native_grid``
        keeps (see the module docstring).

    Raises
    ------
    DEMIOError
        The file does not exist or rasterio cannot open it.
    DEMError
        Several bands and no ``band``; ``band`` out of range; every cell nodata; a
        rotated geotransform. Fields: ``path``, ``value``, ``param="band"`` when the
        remedy is another band.
    RasterTooLargeError
        The DEM's decoded size would pass the memory cap
        (:func:`~energy_planner.terrain.memory.memory_cap`); raised before reading.

    Examples
    --------
    >>> from energy_planner.maps import map_path
    >>> t = load_dem(map_path("plane"))
    >>> t.crs.to_epsg(), t.resolution
    (32631, (1.0, 1.0))
    """
    p = Path(path)
    name = str(path)
    src = open_dem(name)
    with src:
        n = src.count
        band = _pick_band(band, n, name)
        win, shape, transform = _read_window(src, bounds, decimate, name)
        part = (
            ""
            if (bounds is None and decimate == 1)
            else (
                f" (window of {int(win.height)} x {int(win.width)} cells"
                + (f", decimated by {decimate}" if decimate > 1 else "")
                + ")"
            )
        )
        check_memory(shape, BYTES_PER_CELL, f"DEM {name!r}{part}", path=name)
        nodata = src.nodatavals[int(band) - 1]
        z = _read_band(src, band, None if bounds is None and decimate == 1 else (win, shape), name)
        crs = src.crs
        _check_georeferenced(src, transform, name)
    z[~np.isfinite(z)] = np.nan
    _check_some_valid(z, nodata, band, n, name)
    work_z, work_t, work_crs, native, work_grad = _working_grid(z, transform, crs, name, p)
    return Terrain(
        work_z,
        work_t,
        work_crs,
        source_crs=crs,
        source_transform=transform,
        source_shape=z.shape,
        path=p,
        native=native,
        gradient=work_grad,
    )


def _pick_band(band, n: int, name: str) -> int:
    """The band to read (1 when the DEM has one and none was asked for).

    Raises
    ------
    DEMError
        Several bands and no ``band``, or ``band`` out of range.
    """
    if band is None:
        if n != 1:
            raise DEMError(
                f"DEM {name!r} has {n} bands; choose one with band=N (Python) or "
                f"--band N (CLI), N in 1..{n}",
                path=name,
                value=n,
                param="band",
                expected=f"a band in 1..{n}",
                hint="--band N",
            )
        return 1
    if not (isinstance(band, int | np.integer) and 1 <= band <= n):
        raise DEMError(
            f"band {band!r} is out of range for DEM {name!r}: valid bands 1..{n}",
            path=name,
            value=band,
            param="band",
            expected=f"a band in 1..{n}",
            hint="--band N",
        )
    return band


def _read_band(src, band: int, window, name: str) -> np.ndarray:
    """Band ``band`` as float64 with NaN for nodata; ``window`` ``(win, out_shape)`` or None.

    Raises
    ------
    DEMIOError
        The file cannot be read (truncated or corrupt).
    """
    from rasterio._err import CPLE_BaseError
    from rasterio.errors import RasterioIOError

    try:
        if window is None:
            data = src.read(int(band), masked=True)
        else:
            from rasterio.enums import Resampling

            data = src.read(
                int(band),
                window=window[0],
                out_shape=window[1],
                masked=True,
                resampling=Resampling.average,
            )
    except (RasterioIOError, CPLE_BaseError) as exc:  # truncated or corrupt file
        raise DEMIOError(
            f"cannot read band {band} of DEM {name!r}: {exc}",
            path=name,
            expected="a readable raster (is the file truncated?)",
        ) from exc
    return np.ma.filled(data.astype(np.float64), np.nan)


def _check_georeferenced(src, transform, name: str) -> None:
    """:class:`DEMError` unless the DEM has a north-up geotransform."""
    if transform.b != 0 or transform.d != 0:
        raise DEMError(
            f"DEM {name!r} has a rotated/sheared geotransform {tuple(transform)[:6]}; "
            "expected north-up. Warp it first: gdalwarp -t_srs <its CRS> in.tif out.tif",
            path=name,
            value=tuple(transform)[:6],
            expected="a north-up geotransform",
        )
    if src.gcps[0] and transform == Affine.identity():
        raise DEMError(
            f"DEM {name!r} is georeferenced by GCPs only; warp it first",
            path=name,
            expected="a geotransform",
        )


def _check_some_valid(z: np.ndarray, nodata, band: int, n: int, name: str) -> None:
    """:class:`DEMError` if every cell of the band is nodata or NaN."""
    if np.isfinite(z).any():
        return
    what = "NaN" if nodata is None or np.isnan(nodata) else f"nodata ({nodata:g}) or NaN"
    if n == 1:
        raise DEMError(
            f"DEM {name!r} has no valid cell: every cell is {what}; expected "
            "elevations (check the file's nodata value)",
            path=name,
            value=nodata,
            expected="at least one valid elevation",
        )
    raise DEMError(
        f"band {band} of DEM {name!r} has no valid cell: every cell is {what}; "
        f"the file has {n} bands (choose another with --band N)",
        path=name,
        value=band,
        param="band",
        expected="a band with valid elevations",
        hint="--band N",
    )


def _working_grid(z: np.ndarray, transform, crs, name: str, p: Path):
    """The metric working grid: the DEM's own, or a UTM warp with Horn on the DEM's grid.

    Returns
    -------
    work_z, work_t, work_crs, native, work_grad
        Elevation, transform and CRS of the working grid; the :class:`NativeGrid` and
        the working grid's gradient (None unless the DEM was warped).
    """
    if crs is None:
        warnings.warn(
            f"DEM {name!r} has no CRS; treating its coordinates as local metres "
            "(x east, y north). Slopes are wrong if its pixels are not metres.",
            UserWarning,
            stacklevel=3,
        )
        return z, transform, None, None, None
    if _is_metric(crs):
        return z, transform, crs, None, None
    # Horn on the DEM's own grid (geodesic spacing), carried to the working grid
    (z,), north_up = _north_up([z], transform)
    work_z, work_t, work_crs, grads, work_grad = _warp_to_utm(z, north_up, crs, p)
    native = NativeGrid(z, *grads, north_up, crs)
    if not np.isfinite(work_z).any():
        raise DEMError(
            f"DEM {name!r} has no valid cell after reprojection to {work_crs}",
            path=name,
            crs=str(work_crs),
            expected="valid cells",
        )
    return work_z, work_t, work_crs, native, work_grad
