"""The out-of-core energy map: dask arrays over a DEM read by chunks.

The DEM is read lazily by chunks through the one reader of DEM values
(:class:`~energy_planner.terrain.raster.BandReading`: masks, scale, offset, unit,
undeclared voids), the Horn gradient is computed per
chunk with :func:`dask.array.map_overlap` (depth 1: one halo cell for the 3 x 3 stencil,
NaN beyond the map's edge, so the map's border is NaN exactly as in the in-memory
:func:`energy_planner.terrain.horn.horn_gradient`), and every band per chunk with
:func:`dask.array.map_blocks` calling the same :func:`~energy_planner.energymap.core.block_bands`
as the other paths. The graph runs on whatever dask scheduler is active: the threads of
this machine (the blocks written to one GeoTIFF opened once, with the project's profile,
under a lock), or a ``dask.distributed`` cluster when a ``Client`` exists (its workers
rebuild the compiled kernel from the model's source text, loaded from the numba disk
cache, and write their chunks to the GeoTIFF with rioxarray under a cluster-wide lock).
"""

from __future__ import annotations

import contextlib
import sys
import threading
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.energymap.core import _DemInfo, _Setup, _write_metadata, block_bands

__all__ = ["compute_dask", "gradient_dask"]

# The map kernel runs its rows in parallel itself (numba prange); numba's fallback
# threading layer (workqueue) must not be entered by two threads at once, so the chunks
# of one process take turns in the kernel (reading, gradients and writing still overlap).
_KERNEL_LOCK = threading.Lock()


def _horn_component(z: np.ndarray, step_x: float, step_y: float, which: int) -> np.ndarray:
    from energy_planner.terrain.horn import horn_gradient

    z = np.where(np.isfinite(z), z, np.nan)
    return horn_gradient(z, step_x, step_y)[which]


def _read_block(block_info: Any = None, *, path: str, reading: Any) -> np.ndarray:
    """One chunk of the DEM in metres, NaN invalid (the one reader: ``reading.read``)."""
    import rasterio
    from rasterio.windows import Window

    (r0, r1), (c0, c1) = block_info[None]["array-location"]
    with rasterio.open(path) as src:
        return reading.read(src, window=Window(c0, r0, c1 - c0, r1 - r0))


def gradient_dask(z: Any, step_x: float, step_y: float) -> tuple[Any, Any]:
    """Horn gradient ``(dz/dx, dz/dy)`` of a 2-D dask array (NaN border and nodata)."""
    kw = dict(depth=1, boundary=np.nan, dtype=np.float64, step_x=step_x, step_y=step_y)
    gx = z.map_overlap(_horn_component, which=0, **kw)
    gy = z.map_overlap(_horn_component, which=1, **kw)
    return gx, gy


def _bands_block(gx, gy, *, heading, headings, channels, transform, crs, along=True,
                 block_info=None):  # fmt: skip
    from affine import Affine

    rows, cols = gx.shape
    if channels.rasters:
        (r0, _), (c0, _) = block_info[0]["array-location"]
        t = transform @ Affine.translation(c0, r0)
        chan, _ = channels.bind_grid((rows, cols), t, crs, quiet=True).stack((rows, cols))
    else:
        chan = np.zeros((0, 1, 1))
    with _KERNEL_LOCK:
        return block_bands(heading, gx, gy, chan, headings, along=along)


def _encode_block(block: np.ndarray, *, steps: np.ndarray) -> np.ndarray:
    from energy_planner.energymap.encoding import encode_block

    return encode_block(np.ascontiguousarray(block), steps)


class _WindowWriter:
    """A ``dask.array.store`` target: each block is written to one open GeoTIFF."""

    def __init__(self, dst: Any) -> None:
        self.dst = dst

    def __setitem__(self, key: tuple[slice, slice, slice], value: np.ndarray) -> None:
        from rasterio.windows import Window

        _, ys, xs = key
        win = Window(xs.start, ys.start, xs.stop - xs.start, ys.stop - ys.start)
        self.dst.write(value, window=win)


def _store_local(bands: Any, out: Path, setup: _Setup, model_name: str, info: _DemInfo,
                 show: bool) -> None:  # fmt: skip
    """Compute ``bands`` on this machine's threads into one GeoTIFF opened once.

    One open dataset with the project's profile (:func:`~energy_planner.energymap.core.
    _profile`: the compression at its fastest level, compressed by GDAL's worker
    threads), written block by block under a lock. (rioxarray's ``to_raster`` reopens
    the file for every block, where GDAL forgets the creation options: zstd at its
    default level 9, 4x the CPU.)
    """
    import dask.array as da

    from energy_planner.energymap.core import _profile
    from energy_planner.io import open_geotiff

    nb = bands.shape[0]
    prof = _profile(info.shape, info.transform, info.crs, nb, setup.compress, setup.encoding)
    bar: Any = contextlib.nullcontext()
    if show:
        from dask.diagnostics import ProgressBar

        bar = ProgressBar(out=sys.stderr)
    with open_geotiff(out, **prof) as dst:
        with bar:
            da.store(bands, _WindowWriter(dst), lock=threading.Lock())
        _write_metadata(dst, setup, model_name, "dask")


def _client() -> Any:
    try:
        from distributed import get_client

        return get_client()
    except (ImportError, ValueError):
        return None


def compute_dask(
    info: _DemInfo,
    out: Path,
    setup: _Setup,
    model_name: str,
    *,
    chunk: int = 512,
    progress: bool | None = None,
) -> None:
    """Compute and write the map of ``info``'s DEM with dask (see the module docstring)."""
    import rioxarray
    import xarray as xr

    from energy_planner.energymap.core import _profile

    chunk = max(64, int(chunk))
    import dask.array as da
    import rasterio

    from energy_planner.terrain.raster import band_reading

    arr = rioxarray.open_rasterio(
        info.path, chunks={"band": 1, "y": chunk, "x": chunk}, masked=True, lock=False
    )
    with rasterio.open(info.path) as src:
        reading = band_reading(src, info.band, info.path, scan=True)
    z = da.map_blocks(
        _read_block, dtype=np.float64, chunks=arr.sel(band=info.band).data.chunks,
        meta=np.empty((0, 0)), path=info.path, reading=reading,
    )  # fmt: skip
    t = info.transform
    gx, gy = gradient_dask(z, t.a, t.e)

    bands = da.map_blocks(
        _bands_block, gx, gy, new_axis=0, chunks=((setup.full - setup.computed,), *gx.chunks),
        dtype=np.float32, heading=setup.heading, headings=setup.headings,
        channels=setup.channels, transform=t, crs=info.crs, along=setup.along,
    )[setup.first - setup.computed :]  # fmt: skip
    if setup.encoding == "uint16":
        bands = bands.map_blocks(_encode_block, steps=setup.steps, dtype=np.uint16)
    nb = setup.nbands
    show = progress if progress is not None else sys.stderr.isatty()
    client = _client()
    if client is None:
        _store_local(bands, out, setup, model_name, info, show)
        return
    # a dask.distributed cluster: its workers open the file themselves (rioxarray)
    from distributed import Lock

    xarr = xr.DataArray(
        bands,
        dims=("band", "y", "x"),
        coords={"band": np.arange(1, nb + 1), "y": arr.y.values, "x": arr.x.values},
    )
    xarr = xarr.rio.write_crs(info.crs).rio.write_transform(t)
    ints = setup.encoding == "uint16"
    xarr = xarr.rio.write_nodata(0 if ints else np.nan, encoded=False)
    lock: Any = Lock("energy_planner-energy-map-write")
    prof = _profile(info.shape, t, info.crs, nb, setup.compress, setup.encoding)
    keys = ("compress", "predictor", "zlevel", "zstd_level", "BIGTIFF", "interleave")
    opts = {k: prof[k] for k in keys if k in prof}
    if prof.get("tiled"):
        opts.update(tiled=True, blockxsize=256, blockysize=256)
    import rasterio

    from energy_planner.io import atomic_path
    from energy_planner.io.geotiff import check_written

    with atomic_path(out, shared=True) as tmp:  # the workers write it: a name they reach
        xarr.rio.to_raster(tmp, lock=lock, dtype=prof["dtype"], **opts)
        with rasterio.open(tmp, "r+") as dst:
            _write_metadata(dst, setup, model_name, "dask")
        check_written(tmp)  # GDAL only logs a write that failed at close (a full disk)
    del rioxarray  # imported for the .rio accessor
