"""The :class:`Terrain` working grid (DEM loading: :mod:`energy_planner.terrain.load`).

A :class:`Terrain` is a north-up grid in a metric CRS (the *working* grid): elevation,
the Horn gradient, slope and azimuths, the geotransform and the CRS.
:func:`~energy_planner.terrain.load.load_dem` builds one from any single-band raster
rasterio opens; :meth:`Terrain.from_array` and
:meth:`Terrain.from_function` build one from numbers (tests, synthetic maps).

Decisions (see also ``docs/terrain.md``):

- Nodata and NaN cells become NaN in ``elevation``; every later quantity is NaN where it
  would need them (Horn window, bilinear sampling). Nothing is filled in. Stored values
  become metres as GDAL describes them (masks, scale and offset, the band's unit,
  undeclared voids): :mod:`energy_planner.terrain.raster`.
- A projected CRS whose units are not ground metres (web-mercator) is handled like a
  geographic one when it is cylindrical, else refused with the ``gdalwarp`` command
  (:func:`energy_planner.terrain.native.metric_scale`).
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
from collections.abc import Callable, Sequence
from dataclasses import InitVar, dataclass, field
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from affine import Affine

from energy_planner.errors import CoordinateError, DEMError, fmt_num
from energy_planner.terrain.horn import (
    aspect_from_gradient,
    horn_gradient,
    pixel_steps,
)
from energy_planner.terrain.sample import TerrainSample, bilinear

if TYPE_CHECKING:  # loaded by a DEM in degrees (load_dem) or native_grid
    from energy_planner.terrain.native import NativeGrid

__all__ = ["Terrain", "utm_epsg"]


def _as_crs(crs: Any) -> Any:
    """``rasterio.crs.CRS`` from anything it accepts; None and a ``StoredCRS`` stay."""
    if crs is None:
        return None
    from energy_planner.terrain.stored import StoredCRS

    if isinstance(crs, StoredCRS):  # a DEM read back: rasterio only when asked more
        return crs
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
    gradient : (ndarray, ndarray), ndarray of shape (rows, cols, 2), or None
        Init only: the working grid's gradient when it is not Horn of ``elevation`` on
        this grid (a geographic DEM's native gradient carried over); None computes Horn.
        Needs a north-up grid; a float64 C-contiguous ``(rows, cols, 2)`` array is kept,
        not copied (a pair is stacked into one), and set to NaN in place where a
        component or the elevation is invalid.

    Attributes
    ----------
    grad : ndarray of float64, shape (rows, cols, 2), C-contiguous
        Horn gradient ``(dz/dx, dz/dy)`` of each cell (m/m), NaN where not computable.
        The one copy of the gradient: ``dzdx`` and ``dzdy`` are views of it, and the
        motion-cost kernels read it as it is (:class:`~energy_planner.energy.MotionCost`).
    dzdx, dzdy : ndarray of float64
        Horn gradient towards east and north (views of ``grad``, not C-contiguous).

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
    gradient: InitVar[tuple[np.ndarray, np.ndarray] | np.ndarray | None] = None
    grad: np.ndarray = field(init=False)
    dzdx: np.ndarray = field(init=False)
    dzdy: np.ndarray = field(init=False)

    def __post_init__(self, gradient: tuple[np.ndarray, np.ndarray] | np.ndarray | None) -> None:
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
            self.grad = np.empty((rows, cols, 2))
            horn_gradient(z, t.a, t.e, out=self.grad)
        else:
            if isinstance(gradient, np.ndarray) and gradient.shape == (rows, cols, 2):
                g = np.ascontiguousarray(gradient, dtype=np.float64)
            else:
                gx, gy = (np.asarray(v, dtype=np.float64) for v in gradient)
                if gx.shape != z.shape or gy.shape != z.shape:
                    raise DEMError(
                        f"gradient shapes {gx.shape}, {gy.shape}: expected the elevation's "
                        f"shape {z.shape}"
                    )
                g = np.stack([gx, gy], axis=-1)
            bad = ~(np.isfinite(g[..., 0]) & np.isfinite(g[..., 1]) & np.isfinite(z))
            g[bad] = np.nan
            self.grad = g
        self.dzdx, self.dzdy = self.grad[..., 0], self.grad[..., 1]

    def __getstate__(self) -> dict[str, Any]:
        """Pickled without ``dzdx``/``dzdy``: views of ``grad``, made again on loading."""
        return {k: v for k, v in self.__dict__.items() if k not in ("dzdx", "dzdy")}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self.dzdx, self.dzdy = self.grad[..., 0], self.grad[..., 1]

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
        from energy_planner.terrain.native import NativeGrid

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

    def invalid_reason(self, x: float, y: float) -> str | None:
        """Why the working-CRS point ``(x, y)`` has no slope; None if it has one.

        One of: ``"outside the map"``; ``"on a nodata cell (row R, column C of the
        working grid)"``; ``"next to a nodata cell or the map's edge: the slope needs
        the 3 x 3 cells around each of the cells it is read from"``.
        """
        if self.contains(x, y):
            return None
        left, bottom, right, top = self.bounds
        if not (left <= x <= right and bottom <= y <= top):
            return "outside the map"
        x0, y0, dx, dy = self.grid
        rows, cols = self.shape
        r = min(max(int(round((y - y0) / dy)), 0), rows - 1)
        c = min(max(int(round((x - x0) / dx)), 0), cols - 1)
        if not np.isfinite(self.elevation[r, c]):
            return f"on a nodata cell (row {r}, column {c} of the working grid)"
        return (
            "next to a nodata cell or the map's edge: the slope needs the 3 x 3 cells "
            "around each of the cells it is read from"
        )

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
