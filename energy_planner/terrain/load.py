"""DEM loading: any single-band raster rasterio opens -> a metric :class:`Terrain`.

:func:`load_dem` reads a DEM (whole, a window, or decimated), checks its band,
georeferencing and memory cost before decoding, and builds the working grid: the DEM's
own when its CRS is metric, else a UTM grid with Horn on the DEM's own grid
(:func:`_warp_to_utm`). The decisions are listed in :mod:`energy_planner.terrain.dem`.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from affine import Affine

from energy_planner.errors import DEMError, DEMIOError, extent_text
from energy_planner.terrain.dem import Terrain, _north_up, utm_epsg
from energy_planner.terrain.memory import BYTES_PER_CELL, LONLAT_BYTES_PER_CELL, check_memory
from energy_planner.terrain.native import (
    NativeGrid,
    gradient_to_work,
    metric_scale,
    native_gradient,
)
from energy_planner.terrain.raster import BandReading, band_reading
from energy_planner.terrain.sample import bilinear

__all__ = ["load_dem", "open_dem"]


def _warp_to_utm(
    z: np.ndarray, transform: Affine, crs: Any, path: Path, scale: Any = None
) -> tuple[np.ndarray, Affine, Any, tuple[np.ndarray, np.ndarray], np.ndarray]:
    """Reproject a non-metric DEM to its local UTM zone (bilinear, NaN-aware).

    Returns the working elevation, transform and CRS, the native Horn gradient ``grads``
    of ``z`` (:func:`~energy_planner.terrain.native.native_gradient`, ``transform``
    north-up), and the working gradient, ``(height, width, 2)`` as :attr:`Terrain.grad`:
    ``grads`` carried to the working cell centres and axes by
    :func:`~energy_planner.terrain.native.gradient_to_work`. ``scale``: the
    CRS's :func:`~energy_planner.terrain.native.metric_scale` over the DEM.
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
    grads = native_gradient(z, transform, crs, scale)
    zw = np.empty((height, width))
    gw = np.empty((height, width, 2))  # kept by the Terrain as it is (no copy)
    gxw, gyw = gw[..., 0], gw[..., 1]
    # working cell centres with a ring of neighbours (one column each side), for the
    # Jacobian of the back-projection in gradient_to_work
    xs_dst = dst_transform.c + (np.arange(-1, width + 1) + 0.5) * dst_transform.a
    block = max(1, 250_000 // max(width, 1))  # points per PROJ call: bounds the temporaries
    starts = range(0, height, block)
    if len(starts) > 2:  # big rasters: show progress on a terminal (stderr)
        from energy_planner.progress import reporter

        starts = reporter(None).iterate(
            starts, f"reprojecting {path.name} to {dst_crs}", unit="block"
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
            grads, transform, crs, sx, sy, (dst_transform.a, dst_transform.e), scale
        )
    return zw, dst_transform, dst_crs, grads, gw


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
        Any raster rasterio opens (GeoTIFF, ...). Its values become metres as GDAL
        describes them: nodata and masks, scale and offset, the band's unit; undeclared
        voids (-9999, ...) are masked with a warning (:mod:`energy_planner.terrain.raster`).
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
        rotated geotransform; an unknown vertical unit; a projected CRS whose units are
        not ground metres and that is not cylindrical (with the ``gdalwarp`` to use).
        Fields: ``path``, ``value``, ``param="band"`` when the remedy is another band.
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
    from energy_planner.maps import resolve

    p = resolve(path)  # a file, or a bundled map's name ("hill")
    name = str(p)
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
        _check_georeferenced(src, transform, name)
        nodata = src.nodatavals[int(band) - 1]
        whole = bounds is None and decimate == 1
        reading = band_reading(
            src, band, name, scan=False if whole else ("full" if decimate > 1 else True)
        )
        if reading.voids and decimate > 1:
            raise DEMError(
                f"DEM {name!r} marks voids with {reading.voids[0][0]:g} without declaring "
                "it as nodata, and a decimated read would average them into the "
                f"elevations; declare it first: gdal_edit.py -a_nodata "
                f"{reading.voids[0][0]:g} {name}",
                path=name,
                value=reading.voids[0][0],
                param="decimate",
                expected="a declared nodata value",
                hint=f"gdal_edit.py -a_nodata {reading.voids[0][0]:g}",
            )
        z = _read_band(src, reading, None if whole else (win, shape), name)
        crs = src.crs
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
            raise _band_error(
                f"DEM {name!r} has {n} bands; choose one with band=N (Python) or "
                f"--band N (CLI), N in 1..{n}",
                name,
                n,
                n,
            )
        return 1
    if not (isinstance(band, int | np.integer) and 1 <= band <= n):
        raise _band_error(
            f"band {band!r} is out of range for DEM {name!r}: valid bands 1..{n}", name, band, n
        )
    return band


def _band_error(message: str, name: str, value: Any, n: int) -> DEMError:
    """A :class:`DEMError` on the ``band`` of DEM ``name`` (``n`` bands), for ``value``."""
    return DEMError(
        message, path=name, value=value, param="band", expected=f"a band in 1..{n}",
        hint="--band N",
    )  # fmt: skip


def _read_band(src, reading: BandReading, window, name: str) -> np.ndarray:
    """The band in metres, float64, NaN invalid; ``window`` ``(win, out_shape)`` or None.

    A whole read finds undeclared voids itself (and warns); a window uses the file's
    (``reading.voids``).

    Raises
    ------
    DEMIOError
        The file cannot be read (truncated or corrupt).
    """
    from rasterio._err import CPLE_BaseError
    from rasterio.errors import RasterioIOError

    kwargs: dict[str, Any] = {}
    if window is not None:
        from rasterio.enums import Resampling

        kwargs = dict(window=window[0], out_shape=window[1], resampling=Resampling.average)
    try:
        return reading.read(src, find=window is None, **kwargs)
    except (RasterioIOError, CPLE_BaseError) as exc:  # truncated or corrupt file
        raise DEMIOError(
            f"cannot read band {reading.band} of DEM {name!r}: {exc}",
            path=name,
            expected="a readable raster (is the file truncated?)",
        ) from exc


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
    from rasterio.transform import array_bounds

    scale = metric_scale(crs, array_bounds(*z.shape, transform), name)
    if scale.metric:
        return z, transform, crs, None, None
    # Horn on the DEM's own grid (ground spacing of each row), carried to the working grid
    (z,), north_up = _north_up([z], transform)
    work_z, work_t, work_crs, grads, work_grad = _warp_to_utm(z, north_up, crs, p, scale)
    native = NativeGrid(z, *grads, north_up, crs, scale)
    if not np.isfinite(work_z).any():
        raise DEMError(
            f"DEM {name!r} has no valid cell after reprojection to {work_crs}",
            path=name,
            crs=str(work_crs),
            expected="valid cells",
        )
    return work_z, work_t, work_crs, native, work_grad
