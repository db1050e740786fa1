"""The one GeoTIFF writer: one nodata convention, GDAL band units, descriptions, tags.

Conventions of every raster the project writes:

* floating-point bands use NaN as nodata (:data:`NODATA`), declared in the file; integer
  bands declare the nodata value the caller gives (or none);
* each band carries a GDAL description (its short name) and, when it has one, a GDAL unit
  (``gdalinfo`` prints ``Unit Type``; QGIS and rasterio read it as ``src.units``); band
  tags repeat them (``name``, ``description``, ``units``) with any others;
* DEFLATE compression (predictor 3 for floats), tiles of 256 for rasters of at least
  256 x 256 cells, BigTIFF when needed;
* written to a temporary (on Linux unnamed) file and renamed over the destination when
  complete (:func:`energy_planner.io.atomic_path`).

:func:`write_geotiff` writes arrays; :func:`open_geotiff` yields an open dataset for
writers that fill windows one by one. Both turn a band tag ``units`` into the GDAL unit
when the band has none, so that a band described by tags only still gets one.

Examples
--------
>>> import tempfile, pathlib, numpy as np, rasterio
>>> from affine import Affine
>>> p = pathlib.Path(tempfile.mkdtemp()) / "slope.tif"
>>> _ = write_geotiff(p, np.array([[1.0, np.nan]]), transform=Affine(1, 0, 0, 0, -1, 1),
...                   crs="EPSG:32631", names=["slope"], units=["deg"],
...                   descriptions=["slope angle"], tags={"software": "doc"})
>>> with rasterio.open(p) as src:
...     src.units, src.descriptions, src.tags(1)["description"], bool(np.isnan(src.nodata))
(('deg',), ('slope',), 'slope angle', True)
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.io.atomic import atomic_path

__all__ = [
    "COMPRESSIONS",
    "NODATA",
    "TILE",
    "check_written",
    "compression_options",
    "describe_band",
    "geotiff_profile",
    "open_geotiff",
    "write_geotiff",
]

#: The nodata value of floating-point rasters.
NODATA = float("nan")
#: Tile size of tiled rasters.
TILE = 256
#: Compressions :func:`compression_options` knows, fastest to write last.
COMPRESSIONS = ("deflate", "zstd", "none")


def compression_options(
    compress: str, *, floating: bool = True, threads: int | str | None = None
) -> dict[str, Any]:
    """GDAL creation options of a compression, at its fastest level, for large rasters.

    Parameters
    ----------
    compress : {"deflate", "zstd", "none"}
        ``deflate`` (level 1) reads everywhere (any GDAL, libtiff, QGIS, tifffile);
        ``zstd`` (level 1; GDAL >= 2.3) writes about 1.5x faster at the same size;
        ``none`` writes fastest and is about 1.8x larger for float costs.
    floating : bool
        Floating-point bands: the floating-point predictor (3), else the horizontal
        one (2).
    threads : int or "ALL_CPUS", optional
        GDAL's ``NUM_THREADS``: tiles are compressed by that many worker threads while
        the caller computes the next window (None: in the writing thread).

    Returns
    -------
    dict
        Creation options for :func:`geotiff_profile` / ``rasterio.open``.

    Raises
    ------
    ValueError
        ``compress`` is not one of :data:`COMPRESSIONS`.

    Examples
    --------
    >>> compression_options("zstd")
    {'compress': 'zstd', 'predictor': 3, 'zstd_level': 1}
    >>> compression_options("none", threads="ALL_CPUS")
    {'compress': 'none'}
    """
    name = str(compress).lower()
    if name not in COMPRESSIONS:
        raise ValueError(f"compression {compress!r} is not one of {', '.join(COMPRESSIONS)}")
    if name == "none":
        return {"compress": "none"}
    opts: dict[str, Any] = {"compress": name, "predictor": 3 if floating else 2}
    opts["zlevel" if name == "deflate" else "zstd_level"] = 1
    if threads is not None:
        opts["NUM_THREADS"] = str(threads)
    return opts


def geotiff_profile(
    shape: tuple[int, int],
    count: int = 1,
    *,
    transform: Any,
    crs: Any,
    dtype: str | np.dtype = "float32",
    nodata: float | None = None,
    **creation: Any,
) -> dict[str, Any]:
    """The rasterio profile of a project GeoTIFF (see the module docstring).

    Parameters
    ----------
    shape : (rows, cols)
    count : int
        Number of bands.
    transform, crs
        Georeferencing (``crs`` None for a local grid).
    dtype : str or dtype
        Band type.
    nodata : float, optional
        Integer rasters only (floating-point rasters always use NaN).
    **creation
        Other rasterio/GDAL creation options, overriding the defaults.

    Returns
    -------
    dict
    """
    rows, cols = int(shape[0]), int(shape[1])
    dt = np.dtype(dtype)
    is_float = np.issubdtype(dt, np.floating)
    if is_float and nodata is not None and not np.isnan(nodata):
        raise ValueError(
            f"nodata {nodata!r} for a {dt} raster: floating-point rasters use NaN as nodata"
        )
    prof: dict[str, Any] = dict(
        driver="GTiff", width=cols, height=rows, count=int(count), dtype=dt.name, crs=crs,
        transform=transform, nodata=NODATA if is_float else nodata, compress="deflate",
        predictor=3 if is_float else 2, BIGTIFF="IF_SAFER", interleave="band",
    )  # fmt: skip
    if rows >= TILE and cols >= TILE:
        prof.update(tiled=True, blockxsize=TILE, blockysize=TILE)
    prof.update(creation)
    if str(prof.get("compress")).lower() == "none":
        prof.pop("predictor", None)  # GDAL warns of a predictor without compression
    return prof


def describe_band(
    dst: Any,
    band: int,
    *,
    name: str | None = None,
    description: str | None = None,
    units: str | None = None,
    **tags: Any,
) -> None:
    """Set a band's GDAL description (``name``) and unit, and its tags.

    Parameters
    ----------
    dst : rasterio dataset open for writing
    band : int
        1-based band index.
    name : str, optional
        Short name: the GDAL band description and the ``name`` tag.
    description : str, optional
        Longer text, the ``description`` tag.
    units : str, optional
        The GDAL unit (``src.units``) and the ``units`` tag.
    **tags
        More band tags (values written with ``str``).
    """
    if name is not None:
        dst.set_band_description(band, name)
        tags["name"] = name
    if description is not None:
        tags["description"] = description
    if units is not None:
        dst.set_band_unit(band, units)
        tags["units"] = units
    if tags:
        dst.update_tags(band, **{k: str(v) for k, v in tags.items()})


def _units_from_tags(dst: Any) -> None:
    """Give every band whose ``units`` tag is set but GDAL unit is not that unit."""
    for b in range(1, dst.count + 1):
        unit = dst.tags(b).get("units")
        if unit and not (dst.units[b - 1] or ""):
            dst.set_band_unit(b, unit)


@contextlib.contextmanager
def open_geotiff(dest: str | os.PathLike[str], **profile: Any) -> Iterator[Any]:
    """Yield a rasterio dataset that becomes ``dest`` when the block completes.

    Parameters
    ----------
    dest : str or path-like
        The GeoTIFF to (re)write.
    **profile
        rasterio keywords (``width``, ``height``, ``count``, ``dtype``, ``crs``,
        ``transform``, ...), usually from :func:`geotiff_profile`; missing defaults
        (driver, compression, NaN nodata for floats) are filled in.

    Yields
    ------
    rasterio.io.DatasetWriter
        Write bands or windows, describe them (:func:`describe_band`), tag it.

    Notes
    -----
    On an exception or SIGTERM ``dest`` keeps its previous content (or stays absent).
    """
    import rasterio

    shape = (profile.pop("height"), profile.pop("width"))
    prof = geotiff_profile(
        shape,
        profile.pop("count", 1),
        transform=profile.pop("transform", None),
        crs=profile.pop("crs", None),
        dtype=profile.pop("dtype", "float32"),
        nodata=profile.pop("nodata", None),
        **profile,
    )
    with atomic_path(dest) as tmp:
        with rasterio.open(tmp, "w", **prof) as dst:
            yield dst
            _units_from_tags(dst)
        check_written(tmp)


def check_written(path: str | os.PathLike[str]) -> None:
    """Raise ``OSError`` unless the GeoTIFF just written at ``path`` is whole.

    GDAL reports a write that fails when it flushes its blocks at close (a full disk)
    only in its log, and the file is left cut short: a caller that renamed it over the
    previous output would lose both. Checked: the disk still has room (a disk left with
    less than 64 KiB is taken as full: ``ENOSPC``) and the file opens (its directory,
    written last, is there).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> bad = pathlib.Path(tempfile.mkdtemp()) / "cut.tif"
    >>> _ = bad.write_bytes(b"II*" + bytes(13))
    >>> check_written(bad)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    OSError: [Errno 5] the GeoTIFF written is not whole (...)
    """
    import errno

    import rasterio

    from energy_planner.io.atomic import _full_disk

    full = _full_disk(Path(path))
    if full:
        raise OSError(errno.ENOSPC, full)
    try:
        with rasterio.open(path) as src:
            src.profile  # noqa: B018 - reads the directory
    except rasterio.errors.RasterioIOError as exc:
        raise OSError(errno.EIO, f"the GeoTIFF written is not whole ({exc})") from exc


def _per_band(values: Sequence[Any] | None, count: int, what: str) -> list[Any]:
    if values is None:
        return [None] * count
    vals = list(values)
    if len(vals) != count:
        raise ValueError(f"{len(vals)} {what} for {count} band(s); give one per band")
    return vals


def write_geotiff(
    dest: str | os.PathLike[str],
    data: Any,
    *,
    transform: Any,
    crs: Any,
    names: Sequence[str] | None = None,
    units: Sequence[str | None] | None = None,
    descriptions: Sequence[str | None] | None = None,
    tags: Mapping[str, Any] | None = None,
    band_tags: Sequence[Mapping[str, Any]] | None = None,
    dtype: str | np.dtype = "float32",
    nodata: float | None = None,
    **creation: Any,
) -> Path:
    """Write a raster (one band 2-D, or bands first 3-D) as a project GeoTIFF.

    Parameters
    ----------
    dest : str or path-like
        Output file.
    data : array-like, shape (rows, cols) or (bands, rows, cols)
        Values; for floating-point output non-finite values other than inf are nodata
        (NaN).
    transform, crs
        Georeferencing.
    names, units, descriptions : sequence, optional
        One per band: GDAL description, GDAL unit, longer ``description`` tag.
    tags : mapping, optional
        Dataset tags.
    band_tags : sequence of mappings, optional
        More tags per band.
    dtype : str or dtype
        Output type (default float32).
    nodata : float, optional
        Nodata of an integer raster (floating-point rasters use NaN).
    **creation
        Other creation options.

    Returns
    -------
    pathlib.Path
    """
    arr = np.asarray(data)
    if arr.ndim == 2:
        arr = arr[None]
    if arr.ndim != 3:
        raise ValueError(f"raster data must be 2-D or 3-D (bands first); got shape {arr.shape}")
    count = arr.shape[0]
    per = zip(
        _per_band(names, count, "names"),
        _per_band(units, count, "units"),
        _per_band(descriptions, count, "descriptions"),
        _per_band(band_tags, count, "band tag sets"),
        strict=True,
    )
    prof = geotiff_profile(
        arr.shape[1:], count, transform=transform, crs=crs, dtype=dtype, nodata=nodata, **creation
    )
    with open_geotiff(dest, **prof) as dst:
        dst.write(arr.astype(prof["dtype"], copy=False))
        for b, (name, unit, desc, more) in enumerate(per, start=1):
            describe_band(dst, b, name=name, description=desc, units=unit, **dict(more or {}))
        if tags:
            dst.update_tags(**{k: str(v) for k, v in tags.items()})
    return Path(dest)
