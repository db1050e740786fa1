"""Heading-dependent energy maps: J per metre of walking each way from every cell.

For every valid cell and each of ``N`` map headings ``h_j = 360 j / N`` degrees
(counter-clockwise from the working grid's +x axis, east, as every yaw in the project),
the map holds the energy per metre of **map** (horizontal) distance of walking in that
direction through the cell centre, under the same model physics as ``energy`` and the
planners: the Horn gradient of the cell, the robot on the ground at its nominal speed
along the surface, its body frame tilted with the slope (see
:mod:`energy_planner.energy.kernels`; the numba function ``map_costs`` of the same
compiled module as the motion kernels, sharing their slope and body-velocity code and the
model's ``power``, looked up in :class:`~energy_planner.energy.heading.HeadingCost`'s
table over slope and relative heading). It is the limit of ``energy`` of a short straight
motion through the cell centre divided by its map length.

Bands (float32, NaN = nodata; ``inf`` = above a slope limit):

- ``along_<deg>`` (N bands, written with ``bands="all"``): walking forward, facing along
  the heading;
- ``best_<deg>`` (N bands): the cheapest way to move along the heading, over every body
  yaw the gait limits allow (crabbing included: the continuous minimum of
  :class:`energy_planner.energy.heading.HeadingCost`, the one the planners use);
- ``cheapest`` / ``dearest``: the least and greatest ``best`` over the headings;
- ``anisotropy``: ``dearest / cheapest`` (``inf`` where the cheapest costs nothing);
- ``cheapest_heading_deg``: the heading of ``cheapest``, degrees CCW from east in [0, 360).

Three ways to compute it, with equal results:

- **terrain**: from a loaded :class:`~energy_planner.terrain.Terrain` (on its grid). A
  geographic DEM file is loaded and warped to UTM this way, mapped on that working grid,
  then resampled onto the DEM's own grid and CRS (bilinear over valid cells; headings
  rotated by the meridian convergence, so that they are degrees CCW from the DEM's local
  east; see :func:`east_angle`);
- **windowed**: a DEM in a metric CRS is read by windows of rows (plus one halo row each
  side for Horn's 3 x 3 stencil) and the map written by windows, so memory stays bounded
  by the window, whatever the DEM's size;
- **dask**: the DEM as a chunked dask array (rioxarray), the gradient by
  ``map_overlap`` with depth 1 reusing :func:`energy_planner.terrain.horn.horn_gradient`,
  the costs by ``map_blocks``; runs on the threads of one machine or on a
  ``dask.distributed`` cluster (the workers rebuild the kernel from the model's source
  text, loaded from the numba disk cache). Used with ``use_dask=True`` or when the DEM's
  decoded size passes the memory cap (``ENERGY_PLANNER_MEMORY_CAP``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.energymap.bands import (  # noqa: F401  (re-exported: old import paths)
    BAND_SETS,
    DEFAULT_BANDS,
    DEM_EAST,
    GRID_EAST,
    SUMMARY_BANDS,
    _deg_label,
    band_descriptions,
    band_names,
    block_bands,
    heading_angles,
)
from energy_planner.energymap.encoding import DEFAULT_ENCODING, EncodingOverflow
from energy_planner.energymap.result import (  # noqa: F401  (re-exported: old import paths)
    _TILE,
    EnergyMapResult,
    _bytes_per_row,
    _model_name,
    _profile,
    _result,
    _Samples,
    _stats,
    _tile,
    _write_metadata,
    sample_band,
)
from energy_planner.energymap.setup import DEFAULT_COMPRESS, _Setup, _setup  # noqa: F401
from energy_planner.errors import DEMError, DEMIOError, EnergyMapError
from energy_planner.io import open_geotiff
from energy_planner.terrain.memory import BYTES_PER_CELL, memory_cap, parse_size

__all__ = [
    "EnergyMapError",
    "EnergyMapResult",
    "band_names",
    "energy_map",
    "memory_cap",
    "parse_size",
    "SUMMARY_BANDS",
]

#: GDAL's block cache while a map is written, MB: dirty tiles wait there until flushed,
#: so the default (5 % of the memory) would let the cache, not the window, set the peak.
GDAL_CACHE_MB = 64


def _rows_per_block(cols: int, nbands: int, target_bytes: float = 96e6) -> int:
    """Rows per window: whole rows of output tiles, about ``target_bytes`` of arrays.

    Whole tile rows (of :func:`~energy_planner.energymap.result._tile`, the side
    :func:`_profile` gives the output), so that every write completes its tiles and GDAL
    can flush them; at least one.
    """
    tile = _tile(cols, nbands)
    rows = int(target_bytes // max(_bytes_per_row(cols, nbands), 1))
    return max(tile, (rows // tile) * tile)


def _window_rows(dst: Any, cols: int, nbands: int) -> int:
    """Rows per window of a map written to ``dst``: whole rows of the file's blocks.

    :func:`_rows_per_block`, rounded down to whole rows of ``dst``'s blocks (at least
    one): the same for a tiled file, whose tiles it is made of already; a file in strips
    (an output narrower or lower than a tile, :func:`_profile`) has GDAL's strip height,
    which need not divide it. So each block of the file is written whole by one window,
    and GDAL writes it straight to the file, past its block cache. A block that two
    windows share waits in that cache, dirty, between their writes, and the cache is
    the process's: the thread that reads the DEM ahead (:class:`_Inputs`) may evict it
    and, before it has written it, the next window's write read the block back from the
    file without the first window's rows (a weakness of GDAL's cache that its
    ``GDALRasterBlock::Internalize`` documents): those rows of a band were NaN in the
    file, now and then.
    """
    block = max(int(dst.block_shapes[0][0]), 1)
    return max(1, _rows_per_block(cols, nbands) // block) * block


def _progress(iterable: Any, total: int, desc: str, progress: Any) -> Any:
    if progress is False or total < 2:
        return iterable
    from energy_planner.progress import reporter

    return reporter(progress).iterate(iterable, desc, total, unit="block")


def _compute_terrain(
    terrain: Any, out: Path, setup: _Setup, model_name: str, progress, samples=None
) -> None:
    """From a loaded Terrain: windows of rows of its gradient, written as they come.

    ``samples``: a :class:`~energy_planner.energymap.result._Samples` that takes the
    statistics' cells from each window.
    """
    rows, cols = terrain.shape
    chan_all, _ = setup.channels.bind(terrain).stack(terrain.shape)
    prof = _profile(terrain.shape, terrain.transform, terrain.crs, setup.nbands, setup.compress,
                    setup.encoding, writer_thread=True)  # fmt: skip

    def block(r0: int, r1: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        chan = chan_all[:, r0:r1] if chan_all.shape[0] else chan_all
        return terrain.dzdx[r0:r1], terrain.dzdy[r0:r1], chan

    with open_geotiff(out, **prof) as dst:
        _map_by_windows(dst, setup, terrain.shape, block, progress, samples)
        _write_metadata(dst, setup, model_name, "terrain")


class _BackgroundWriter:
    """Writes each window in a thread of its own while the caller computes the next.

    One write in flight: :meth:`write` first waits for the one before, so the caller
    alternates two buffers. GDAL's write releases Python's lock and compresses the tiles
    (in this thread for ``uint16`` bands on up to two cores, else in GDAL's worker
    threads: :func:`~energy_planner.energymap.result._compress_threads`); the next
    window's reading, gradient, kernel and encoding run beside it.
    """

    def __init__(self, dst: Any) -> None:
        from concurrent.futures import ThreadPoolExecutor

        self.dst = dst
        self._pool = ThreadPoolExecutor(1, thread_name_prefix="energy-map-write")
        self._job: Any = None

    def write(self, data: np.ndarray, window: Any) -> None:
        """Write ``data`` at ``window`` once the previous write is done; return at once."""
        self.wait()
        self._job = self._pool.submit(self.dst.write, data, window=window)

    def wait(self) -> None:
        """Wait for the write in flight (its error raised here)."""
        job, self._job = self._job, None
        if job is not None:
            job.result()

    def __enter__(self) -> _BackgroundWriter:
        return self

    def __exit__(self, exc_type: Any, *_: Any) -> None:
        try:
            if exc_type is None:
                self.wait()
            elif self._job is not None:
                self._job.exception()  # let it finish; the first error is the one raised
        finally:
            self._pool.shutdown(wait=True)


class _Inputs:
    """The inputs of each window in turn, those of the next made in a thread meanwhile.

    ``inputs.get(k)``: ``block(*windows[k])``. With ``ahead``, window ``k + 1``'s
    (reading its rows and their gradient) is started in a thread of its own as window
    ``k``'s are handed over, so that it runs beside window ``k``'s kernel instead of
    before window ``k + 1``'s: one window's inputs at most are held ahead. Reading
    (GDAL) and NumPy's gradient release Python's lock. Whatever ``block`` raises is
    raised by :meth:`get` of its window, as without a thread; a window's inputs not
    asked for when the run stops (an error) are waited for and dropped, so that the
    source is not closed under a read.
    """

    def __init__(self, block: Any, windows: list[tuple[int, int]], ahead: bool) -> None:
        self.block = block
        self.windows = windows
        self._pool: Any = None
        if ahead and len(windows) > 1:
            from concurrent.futures import ThreadPoolExecutor

            self._pool = ThreadPoolExecutor(1, thread_name_prefix="energy-map-read")
        self._next: Any = None  # (k, future) of the window read ahead

    def get(self, k: int) -> Any:
        """The inputs of window ``k`` (its error raised here); the next one's started."""
        if self._pool is None:
            return self.block(*self.windows[k])
        job, self._next = self._next, None
        if job is not None and job[0] == k:
            out = job[1].result()
        else:
            if job is not None:
                job[1].exception()  # a window not asked for: finished, then dropped
            out = self.block(*self.windows[k])
        if k + 1 < len(self.windows):
            self._next = (k + 1, self._pool.submit(self.block, *self.windows[k + 1]))
        return out

    def __enter__(self) -> _Inputs:
        return self

    def __exit__(self, *_: Any) -> None:
        if self._pool is None:
            return
        job, self._next = self._next, None
        try:
            if job is not None:
                job[1].exception()  # its error, if any, dropped: nobody asked for it
        finally:
            self._pool.shutdown(wait=True)


def _map_by_windows(
    dst: Any, setup: _Setup, shape: tuple[int, int], block: Any, progress: Any, samples: Any,
    ahead: bool = False,
) -> None:  # fmt: skip
    """Compute the map by windows of whole block rows and write them as they come.

    The windows: :func:`_window_rows` rows each, whole rows of ``dst``'s blocks, so
    that no block of the file is written by two windows.

    ``block(r0, r1)``: the gradient and channel rasters of rows ``r0 .. r1``; with
    ``ahead``, the next window's are made in a thread while a window is computed
    (:class:`_Inputs`: for a ``block`` that reads and differentiates). Each window is
    written (:class:`_BackgroundWriter`) while the next is computed, from one of two
    buffers in turn; ``samples`` (a :class:`~energy_planner.energymap.result._Samples`)
    takes the statistics' cells of each window.
    """
    from rasterio.windows import Window

    rows, cols = shape
    step = _window_rows(dst, cols, setup.full)
    windows = [(r0, min(rows, r0 + step)) for r0 in range(0, rows, step)]
    bufs: list[Any] = [None, None]  # float bands: one, or two when they are what is written
    codes: list[Any] = [None, None]
    first = setup.first - setup.computed  # the first band written, in a window's bands
    # uint16 bands with the precompiled kernels: each row thread encodes its rows as soon
    # as the kernel and the summary have made them (block_bands' ``then``)
    aot = setup.heading.precompiled_map() if setup.encoding == "uint16" else None
    inv = np.ascontiguousarray(1.0 / np.asarray(setup.steps, dtype=np.float64))
    with _BackgroundWriter(dst) as writer, _Inputs(block, windows, ahead) as inputs:
        for k in _progress(range(len(windows)), len(windows), "energy map", progress):
            r0, r1 = windows[k]
            gx, gy, chan = inputs.get(k)
            b = k % 2 if setup.encoding == "float32" else 0
            then = code = None
            bad: list[int] = []
            if aot is not None:
                shape_k = (setup.nbands, r1 - r0, cols)
                if codes[k % 2] is None or codes[k % 2].shape != shape_k:
                    codes[k % 2] = np.empty(shape_k, dtype=np.uint16)
                code = codes[k % 2]

                def then(out: np.ndarray, a: int, z: int, code=code, bad=bad) -> None:
                    bad.append(int(aot.encode(out[first:, a:z], inv, code[:, a:z])))

            bufs[b] = bands = block_bands(
                setup.heading, gx, gy, chan, setup.headings, bufs[b], precompiled=True,
                along=setup.along, then=then,
            )  # fmt: skip
            if samples is not None:
                samples.add(bands, r0, setup.computed)
            data = bands[first:]
            if code is not None:  # encoded by the row threads (the same shape: nbands)
                if sum(bad):
                    raise EncodingOverflow(
                        f"{sum(bad)} values outside the uint16 range of their band"
                    )
                data = code
            else:
                codes[k % 2] = data = _encoded(setup, data, codes[k % 2])
            writer.write(data, Window(0, r0, cols, r1 - r0))
        if samples is not None:
            # beside the last window's write (the result takes them), in the memory of the
            # buffers no longer needed (the one in flight stays referenced by the writer)
            bands = data = gx = gy = chan = None
            bufs.clear()
            codes.clear()
            samples.stats()


def _encoded(setup: _Setup, block: np.ndarray, out: np.ndarray | None) -> np.ndarray:
    """The bands of a block as the file stores them (``setup.encoding``).

    ``uint16``: :func:`~energy_planner.energymap.encoding.encode_block` into ``out``
    (reused from window to window); ``float32``: the block itself.
    """
    if setup.encoding == "float32":
        return block
    from energy_planner.energymap.encoding import encode_block

    return encode_block(block, setup.steps, out, aot=setup.heading.precompiled_map())


@dataclass
class _DemInfo:
    path: str
    band: int
    shape: tuple[int, int]
    transform: Any
    crs: Any
    metric_north_up: bool
    nbytes: int


def _dem_info(dem: str | Path, band: int | None) -> _DemInfo:
    import rasterio
    from rasterio.errors import RasterioIOError

    from energy_planner.terrain.native import metric_scale
    from energy_planner.terrain.raster import band_reading

    name = str(dem)
    if not name.startswith("/vsi") and "://" not in name and not Path(name).exists():
        raise DEMIOError(
            f"DEM file {name!r} does not exist (expected a raster, e.g. GeoTIFF)", path=name
        )
    try:
        src = rasterio.open(name)
    except RasterioIOError as exc:
        raise DEMIOError(f"cannot open DEM {name!r} as a raster: {exc}", path=name) from exc
    with src:
        n = src.count
        if band is None:
            if n != 1:
                raise DEMError(
                    f"DEM {name!r} has {n} bands; choose one with --band N, N in 1..{n}",
                    path=name,
                    param="band",
                )
            band = 1
        if not 1 <= band <= n:
            raise DEMError(
                f"band {band} is out of range for DEM {name!r}: valid bands 1..{n}",
                path=name,
                param="band",
                value=band,
            )
        t = src.transform
        north_up = t.b == 0 and t.d == 0 and t.a > 0 and t.e < 0
        band_reading(src, int(band), name)  # a unit or scale it cannot read: said now
        metric = src.crs is None or (north_up and metric_scale(src.crs, src.bounds, name).metric)
        return _DemInfo(
            path=name,
            band=int(band),
            shape=(src.height, src.width),
            transform=t,
            crs=src.crs,
            metric_north_up=north_up and metric,
            nbytes=BYTES_PER_CELL * src.height * src.width,
        )


def _read_rows(src: Any, reading: Any, r0: int, r1: int) -> np.ndarray:
    """Rows ``r0 .. r1`` (may pass the edges: NaN there) in metres, float64, NaN nodata.

    Read straight into the float64 array (GDAL converts); a DEM whose only mask is its
    nodata value is masked by comparing with it, any other mask (alpha, a mask band) by
    reading it; then the file's undeclared voids, scale, offset and unit
    (:class:`~energy_planner.terrain.raster.BandReading`).
    """
    rows, cols = src.height, src.width
    z = np.full((r1 - r0, cols), np.nan)
    a, b = max(r0, 0), min(r1, rows)
    if b > a:
        _read_stored(src, reading.band, a, b, z[a - r0 : b - r0])
    return _in_metres(z, reading)


def _read_stored(src: Any, band: int, a: int, b: int, out: np.ndarray) -> None:
    """Rows ``a .. b`` (inside the raster) as stored, into float64 ``out``, masked cells NaN.

    Cell by cell: the same values whatever rows a read takes.
    """
    from rasterio.enums import MaskFlags
    from rasterio.windows import Window

    win = Window(0, a, src.width, b - a)
    src.read(band, window=win, out=out)
    flags = src.mask_flag_enums[band - 1]
    if flags == [MaskFlags.nodata] and src.nodata is not None:
        nod = np.float64(np.array(src.nodata, dtype=src.dtypes[band - 1]))
        if not np.isnan(nod):  # a NaN nodata is NaN already
            out[out == nod] = np.nan
    elif flags != [MaskFlags.all_valid]:
        out[src.read_masks(band, window=win) == 0] = np.nan


def _in_metres(z: np.ndarray, reading: Any) -> np.ndarray:
    """Stored rows (float64, masked NaN) to metres: infinities and voids NaN, in place."""
    np.putmask(z, np.isinf(z), np.nan)
    reading.mask_voids(z)
    return reading.to_metres(z)


class _RowReader:
    """A DEM band's rows by windows with a one-row halo each side, each row read once.

    ``reader(r0, r1)`` is :func:`_read_rows` of ``r0 .. r1`` (the same values: the stored
    rows are masked cell by cell, and the voids, scale and unit are applied to that
    window as there), for windows that follow each other down the raster. The stored
    rows are read ahead in chunks of ``step`` rows from row 0 (the windows' own rows),
    and a chunk is kept until no later window needs it: a window's halo row below it is
    the first row of the next chunk. Reading each window with its halo rows instead
    reads the blocks of three chunks for every window (a compressed tile is decoded
    whole for its one row in the halo): 0.17 against 0.06 s of decoding for a 2048 x
    2048 deflate DEM by windows of 256 rows. At most two chunks are held (a window's
    own rows and the next chunk).
    """

    def __init__(self, src: Any, reading: Any, step: int) -> None:
        self.src = src
        self.reading = reading
        self.step = max(1, int(step))
        self._chunks: list[tuple[int, np.ndarray]] = []  # (first row, stored rows)
        self._end = 0  # rows read so far: 0 .. _end

    def __call__(self, r0: int, r1: int) -> np.ndarray:
        src = self.src
        rows, cols = src.height, src.width
        a, b = max(r0, 0), min(r1, rows)
        held = self._chunks[0][0] if self._chunks else self._end
        if a < held:  # rows let go already (windows out of order): read from row a on
            self._chunks, self._end = [], a
        while self._end < b:  # the chunks down to row b
            c0, c1 = self._end, min(rows, self._end + self.step)
            part = np.empty((c1 - c0, cols))
            _read_stored(src, self.reading.band, c0, c1, part)
            self._chunks.append((c0, part))
            self._end = c1
        z = np.full((r1 - r0, cols), np.nan)
        for c0, part in self._chunks:
            lo, hi = max(a, c0), min(b, c0 + len(part))
            if hi > lo:
                z[lo - r0 : hi - r0] = part[lo - c0 : hi - c0]
        # the next window starts one row above this one's halo row below (row b - 2):
        # the rows above it are no later window's
        keep = b - 2
        self._chunks = [
            (c0, p) if c0 >= keep else (keep, p[keep - c0 :].copy())
            for c0, p in self._chunks
            if c0 + len(p) > keep
        ]
        return _in_metres(z, self.reading)


def _compute_windowed(
    info: _DemInfo, out: Path, setup: _Setup, model_name: str, progress, samples=None
) -> None:
    """A metric north-up DEM read by windows of rows with a one-row halo.

    ``samples``: as :func:`_compute_terrain`.
    """
    import rasterio
    from rasterio.windows import Window
    from rasterio.windows import transform as window_transform

    from energy_planner.terrain.horn import horn_gradient
    from energy_planner.terrain.raster import band_reading

    rows, cols = info.shape
    t = info.transform
    any_valid = False
    prof = _profile(info.shape, t, info.crs, setup.nbands, setup.compress, setup.encoding,
                    writer_thread=True)  # fmt: skip
    with rasterio.open(info.path) as src, open_geotiff(out, **prof) as dst:
        reading = band_reading(src, info.band, info.path, scan=True)
        rows_of = _RowReader(src, reading, _window_rows(dst, cols, setup.full))

        def block(r0: int, r1: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            nonlocal any_valid
            z = rows_of(r0 - 1, r1 + 1)
            any_valid = any_valid or bool(np.isfinite(z).any())
            gx, gy = horn_gradient(z, t.a, t.e)
            if setup.channels.rasters:
                wt = window_transform(Window(0, r0, cols, r1 - r0), t)
                ch = setup.channels.bind_grid((r1 - r0, cols), wt, info.crs, quiet=True)
                chan, _ = ch.stack((r1 - r0, cols))
            else:
                chan = np.zeros((0, 1, 1))
            return gx[1:-1], gy[1:-1], chan

        _map_by_windows(dst, setup, info.shape, block, progress, samples, ahead=True)
        _write_metadata(dst, setup, model_name, "windowed")
    if not any_valid:
        out.unlink(missing_ok=True)
        raise DEMError(
            f"DEM {info.path!r} band {info.band} has no valid cell (all nodata/NaN)",
            path=info.path,
        )


# ------------------------------------------------- back onto a geographic DEM's grid
def east_angle(shape: tuple[int, int], transform: Any, crs: Any, work_crs: Any) -> np.ndarray:
    """Angle (radians, CCW from the working grid's +x) of the DEM's local east at its cells.

    The DEM's local east is its CRS's +x direction (increasing longitude for a geographic
    CRS); in a conformal working CRS (UTM) it is the working grid's +x rotated by the
    meridian convergence. Found by mapping each cell centre and a point a small step
    east of it into the working CRS.
    """
    from rasterio.warp import transform as warp_transform

    rows, cols = shape
    cc, rr = np.meshgrid(np.arange(cols) + 0.5, np.arange(rows) + 0.5)
    xs, ys = transform * (cc.ravel(), rr.ravel())
    step = 1e-3 * abs(transform.a) if transform.a else 1e-6
    x0, y0 = warp_transform(crs, work_crs, list(xs), list(ys))
    x1, y1 = warp_transform(crs, work_crs, list(xs + step), list(ys))
    ang = np.arctan2(np.subtract(y1, y0), np.subtract(x1, x0))
    return ang.reshape(shape)


def _resample(
    arr: np.ndarray, src_t: Any, src_crs: Any, shape: tuple[int, int], dst_t: Any,
    dst_crs: Any, how: Any,
) -> np.ndarray:  # fmt: skip
    """``arr`` (NaN nodata) on the destination grid; NaN cells never enter an average.

    ``XSCALE=YSCALE=1``: the value at a destination cell centre is the source
    interpolated at that point (GDAL would otherwise widen the kernel where the
    destination cells are larger, smoothing the map).
    """
    from rasterio.warp import reproject

    dst = np.full(shape, np.nan, dtype=np.float64)
    reproject(
        source=np.ascontiguousarray(arr, dtype=np.float64), destination=dst,
        src_transform=src_t, src_crs=src_crs, src_nodata=np.nan, dst_transform=dst_t,
        dst_crs=dst_crs, dst_nodata=np.nan, resampling=how, XSCALE=1, YSCALE=1, tolerance=0.0,
    )  # fmt: skip
    return dst


def _resample_cost(arr, src_t, src_crs, shape, dst_t, dst_crs) -> np.ndarray:
    """Bilinear resampling of a cost band that never mixes ``inf`` into finite numbers.

    ``inf`` cells are masked out of the average and put back by nearest neighbour.
    """
    from rasterio.enums import Resampling

    inf = np.isinf(arr)
    finite = np.where(inf, np.nan, arr)
    out = _resample(finite, src_t, src_crs, shape, dst_t, dst_crs, Resampling.bilinear)
    if inf.any():
        flag = np.where(np.isnan(arr), np.nan, inf.astype(np.float64))
        near = _resample(flag, src_t, src_crs, shape, dst_t, dst_crs, Resampling.nearest)
        out[near == 1.0] = np.inf
    return out


def _to_dem_grid(work: Path, info: _DemInfo, out: Path, setup: _Setup, model_name: str):
    """Resample the working-grid map ``work`` onto the DEM's own grid and CRS.

    Cost bands and the anisotropy: bilinear over valid cells only. Heading bands are
    relabelled in the DEM's local-east frame: heading ``d`` of the output is the working
    heading ``d + convergence`` of the cell, interpolated linearly between the two
    computed working headings around it. The cheapest heading: nearest neighbour, then
    rotated into the DEM's frame. Cells outside the DEM's valid cells are NaN. Written
    band by band: a few DEM-sized arrays in memory whatever the number of headings.
    """
    import rasterio
    from rasterio.enums import Resampling

    n = setup.headings
    first = setup.first  # the working map holds every band, the output setup.bands
    from energy_planner.terrain.raster import band_reading

    with rasterio.open(info.path) as src:  # load_dem warned of undeclared voids
        reading = band_reading(src, info.band, info.path)
        dem_valid = np.isfinite(reading.read(src, find=True, warn=False))
    prof = _profile(info.shape, info.transform, info.crs, setup.nbands, setup.compress,
                    setup.encoding)  # fmt: skip
    steps = setup.steps
    with rasterio.open(work) as w, open_geotiff(out, **prof) as dst:
        wt, wcrs = w.transform, w.crs
        args = (wt, wcrs, info.shape, info.transform, info.crs)

        def cost(i: int) -> np.ndarray:  # 0-based band of the working map, resampled
            return _resample_cost(w.read(i + 1).astype(np.float64), *args)

        cheapest = cost(2 * n)
        cheapest_w = w.read(2 * n + 1).astype(np.float64)
        valid_w = _resample(np.where(np.isnan(cheapest_w), np.nan, 1.0), *args,
                            Resampling.nearest)  # fmt: skip
        del cheapest_w
        valid = dem_valid & (valid_w == 1.0) & ~np.isnan(cheapest)
        del valid_w, dem_valid
        theta = np.degrees(east_angle(info.shape, info.transform, info.crs, wcrs))
        k = np.mod(theta / (360.0 / n), n)  # the convergence in heading steps
        k_int = np.floor(k).astype(int)
        frac = k - k_int

        def put(i: int, arr: np.ndarray) -> None:  # i: 0-based in the full band layout
            band = np.where(valid, arr, np.nan).astype(np.float32)[None]
            if setup.encoding != "float32":
                from energy_planner.energymap.encoding import encode_block

                aot = setup.heading.precompiled_map()  # built by the working map
                band = encode_block(band, steps[i - first : i - first + 1], aot=aot)
            dst.write(band[0], i + 1 - first)

        for g in range(first // n, 2):  # along_* (when written), best_*
            cache: dict[int, np.ndarray] = {}
            for j in range(n):
                k0 = (j + k_int) % n
                k1 = (k0 + 1) % n
                need = set(np.unique(k0).tolist()) | set(np.unique(k1).tolist())
                for m in list(cache):
                    if m not in need:
                        del cache[m]
                for m in need:
                    if m not in cache:
                        cache[m] = cost(g * n + m)
                lo = np.zeros(info.shape)
                hi = np.zeros(info.shape)
                for m in need:
                    lo = np.where(k0 == m, cache[m], lo)
                    hi = np.where(k1 == m, cache[m], hi)
                with np.errstate(invalid="ignore"):
                    val = np.where(
                        frac < 1e-9, lo,
                        np.where(frac > 1 - 1e-9, hi, (1 - frac) * lo + frac * hi),
                    )  # fmt: skip
                put(g * n + j, val)
        put(2 * n, cheapest)
        put(2 * n + 1, cost(2 * n + 1))
        put(2 * n + 2, cost(2 * n + 2))
        head = _resample(w.read(2 * n + 4).astype(np.float64), *args, Resampling.nearest)
        with np.errstate(invalid="ignore"):
            rel = np.mod(head - theta, 360.0)
        rel = np.where(rel >= 360.0, 0.0, rel)
        put(2 * n + 3, np.where(np.isfinite(head), rel, np.nan))
        for e in range(len(setup.extra)):  # the cheapest heading's speed: bilinear too
            put(2 * n + 4 + e, cost(2 * n + 4 + e))
        _write_metadata(dst, setup, model_name, "terrain", DEM_EAST)
        dst.update_tags(
            working_grid_crs=str(wcrs),
            working_grid_transform=repr(tuple(wt)[:6]),
            resampling="bilinear over valid cells at the DEM's cell centres (costs, "
            "anisotropy; per-heading bands also linear in heading); nearest "
            "(cheapest_heading_deg, then rotated)",
            meridian_convergence_deg=f"{np.nanmin(theta):.4f} .. {np.nanmax(theta):.4f}",
        )


def _compute_on_dem_grid(
    terrain: Any, info: _DemInfo, out: Path, setup: _Setup, model_name: str, progress
) -> None:
    """Map on the working grid (a hidden scratch file next to ``out``), then onto the DEM's."""
    from energy_planner.io import scratch_path

    with scratch_path(out) as work:
        whole = replace(setup, bands="all", encoding="float32")  # resampled as values
        _compute_terrain(terrain, work, whole, model_name, progress)
        _to_dem_grid(work, info, out, setup, model_name)


# ---------------------------------------------------------------------------- the API
def energy_map(
    dem: Any,
    out: str | Path,
    model: Any = None,
    *,
    headings: int = 16,
    request: Any = None,
    channels: Any = None,
    band: int | None = None,
    use_dask: bool | None = None,
    memory_cap_bytes: int | None = None,
    chunk: int = 512,
    progress: bool | None = None,
    compress: str = DEFAULT_COMPRESS,
    bands: str = DEFAULT_BANDS,
    encoding: str = DEFAULT_ENCODING,
    speed_range: Any = None,
) -> EnergyMapResult:
    """Write the heading-dependent energy map of a DEM to a GeoTIFF.

    Parameters
    ----------
    dem : Problem, str, pathlib.Path or Terrain
        A :class:`~energy_planner.problem.Problem` (its terrain, model and request; then
        ``model`` and ``request`` are not given again), a DEM file, or a loaded terrain
        (computed on its working grid).
    out : str or pathlib.Path
        Output GeoTIFF (overwritten).
    model : EnergyModel, optional
        A fitted model (default: the bundled B1-class model).
    headings : int
        Number of map headings ``N`` (``360 / N`` degrees apart, the first east).
    request : energy_planner.request.Request, optional
        Robot speed (the yaw rate does not matter: straight motions), slope limits
        (cells above ``max_slope_deg`` cost ``inf``; headings whose gait holds the body
        across a steeper cross-slope than ``max_cross_slope_deg`` cost ``inf``), gait
        limits (the cheapest band takes only the gaits ``max_backward_slope_deg`` and
        ``max_crab_deg`` allow) and channels.
    channels : Channels, optional
        Extra channels the model reads (or ``request.channels``).
    band : int, optional
        Band of a multi-band DEM file.
    use_dask : bool, optional
        True: the dask path; False: never; None (default): dask when the DEM would not
        fit the memory cap in memory.
    memory_cap_bytes : int, optional
        The cap (default: :func:`energy_planner.terrain.memory_cap`, i.e.
        ``ENERGY_PLANNER_MEMORY_CAP`` or half the machine's memory). The DEM is taken to
        need ``BYTES_PER_CELL`` (64) bytes per cell in memory, as ``load_dem`` does.
    chunk : int
        Chunk side of the dask path, cells.
    progress : bool, optional
        Progress bars on stderr (None: when stderr is a terminal).
    compress : {"zstd", "deflate", "none"}
        Compression of the GeoTIFF (:func:`energy_planner.io.compression_options`):
        ``zstd`` (default) writes 1.7x faster than ``deflate`` at the same size (GDAL >=
        2.3 reads it); ``deflate`` reads everywhere; ``none`` writes fastest, about 1.8x
        larger. The values are the same.
    bands : {"best", "all", "summary"}
        Which bands the file holds: ``best`` (default) the ``best_*`` heading bands and
        the four summary bands (N + 4 bands); ``all`` also the ``along_*`` bands
        (walking facing along each heading; 2 N + 4 bands, nearly twice the bytes to
        write); ``summary`` the four summary bands. The values are the same either way;
        the ``along_*`` bands are kept in memory only with ``all``.
    encoding : {"uint16", "float32"}
        How the bands are stored (:mod:`energy_planner.energymap.encoding`): ``uint16``
        (default) scaled integers with GDAL scale and offset, to 0.125 J/m (half of
        :data:`~energy_planner.energymap.encoding.COST_STEP`), a quarter of float32's
        bytes; a map with a cost beyond their range (above 16,383 J/m) is written as
        float32 and says so in its notes. ``float32``: the values as computed.
        :func:`~energy_planner.energymap.encoding.read_band` reads either as values.
    speed_range : (float, float), str or float, optional
        Walk each cell and heading at its best ground speed: ``(vmin, vmax)`` in m/s,
        ``"MIN:MAX"``, or ``"auto"`` (the speeds the model's logs cover), as
        :func:`energy_planner.planning.speed.resolve_speed` reads them for ``plan``. Every
        body yaw takes the speed of the range that minimises its energy per metre (the
        closed form of the planners' motions), so ``best_*`` is the least over yaw and
        speed; the band ``cheapest_speed`` (m/s) gives the speed of the cheapest
        heading. A number is a fixed speed (the request's speed replaced); None
        (default): the request's speed.

    Returns
    -------
    EnergyMapResult

    Raises
    ------
    DEMIOError, DEMError
        Unreadable DEM, bad band, no valid cell.
    EnergyMapError
        Bad headings, compression or bands, or the out-of-core path asked for a DEM that is
        not in a metric CRS.
    PlanningConfigError
        A speed range that is not ``0 < vmin <= vmax`` (or ``auto`` for a model whose
        logs record no speeds).
    MissingChannelError
        The model reads a channel nobody gave.
    """
    import rasterio

    from energy_planner.problem import Problem

    if isinstance(dem, Problem):
        if model is not None or request is not None:
            raise EnergyMapError(
                "give the model and request in the Problem, not again as model=/request="
            )
        dem, model, request = dem.terrain, dem.model, dem.request
    if speed_range is not None:
        speed_range, request = _speed_choice(speed_range, model, request)
    if isinstance(dem, str | Path):
        from energy_planner.maps import resolve

        dem = resolve(dem)  # a file, or a bundled map's name ("hill")
    with rasterio.Env(GDAL_CACHEMAX=GDAL_CACHE_MB):
        res = _energy_map(
            dem, out, model, headings, request, channels, band, use_dask, memory_cap_bytes,
            chunk, progress, compress, bands, encoding, speed_range,
        )  # fmt: skip
    res.dem = dem
    return res


def _speed_choice(speed: Any, model: Any, request: Any) -> tuple[Any, Any]:
    """``(range or None, request)`` of a map's ``speed_range`` (as ``plan`` reads ``speed``).

    :func:`~energy_planner.planning.speed.resolve_speed`: a range stays one; a number
    becomes the request's speed (a fixed-speed map); ``auto`` for logs of one speed
    (None, with its warning) keeps the request's speed.
    """
    import dataclasses

    from energy_planner.model import EnergyModel
    from energy_planner.planning.speed import resolve_speed
    from energy_planner.request import Request

    spec = resolve_speed(speed, EnergyModel.default() if model is None else model)
    if isinstance(spec, float):
        request = Request() if request is None else request
        robot = dataclasses.replace(request.robot, speed=spec)
        return None, dataclasses.replace(request, robot=robot)
    return spec, request


def _energy_map(
    dem, out, model, headings, request, channels, band, use_dask, memory_cap_bytes, chunk,
    progress, compress, bands, encoding, speed_range=None,
) -> EnergyMapResult:  # fmt: skip
    from energy_planner.energymap.encoding import COST_STEP, RATIO_STEP, EncodingOverflow

    t0 = time.perf_counter()
    out = Path(out)
    setup = _setup(model, request, channels, headings, compress, bands, encoding, speed_range)
    notes = list(setup.notes)
    samples: list[_Samples] = []
    try:
        mode, convention = _compute(
            dem, out, model, setup, band, use_dask, memory_cap_bytes, chunk, progress, notes,
            samples,
        )  # fmt: skip
    except EncodingOverflow:
        samples.clear()
        setup = replace(setup, encoding="float32")
        notes[:] = list(setup.notes)  # the first attempt's notes come again
        notes.append(
            f"a value lies beyond the uint16 encoding's range (costs 0 .. {65533 * COST_STEP:g} "
            f"J/m, anisotropy up to {65533 * RATIO_STEP:.0f}): the map is written as float32"
        )
        mode, convention = _compute(
            dem, out, model, setup, band, use_dask, memory_cap_bytes, chunk, progress, notes,
            samples,
        )  # fmt: skip
    seconds = time.perf_counter() - t0
    return _result(out, setup, mode, seconds, notes, convention, samples[0] if samples else None)


def _compute(
    dem, out, model, setup, band, use_dask, memory_cap_bytes, chunk, progress, notes, samples
) -> tuple[str, str]:  # fmt: skip
    """Compute and write the map by the path that suits ``dem``; its mode and heading frame.

    ``samples``: gets the statistics' cells where the path computes the map on the
    output's grid by windows (else the statistics are read back from the file).
    """
    from energy_planner.terrain import Terrain

    model_name = _model_name(model)
    convention = GRID_EAST
    if isinstance(dem, Terrain):
        if use_dask:
            raise EnergyMapError(
                "the dask path reads a DEM file by chunks; give the file, not a Terrain"
            )
        samples.append(_Samples(dem.shape, setup.headings, speed=bool(setup.extra)))
        _compute_terrain(dem, out, setup, model_name, progress, samples[0])
        mode = "terrain"
    else:
        info = _dem_info(dem, band)
        from energy_planner.terrain.memory import resolve_cap

        cap = resolve_cap(memory_cap_bytes)  # None: the default cap
        too_big = info.nbytes > cap
        if use_dask or (use_dask is None and too_big):
            if not info.metric_north_up:
                raise EnergyMapError(
                    f"DEM {info.path!r} ({info.shape[0]} x {info.shape[1]} cells, about "
                    f"{info.nbytes / 1e9:.2f} GB in memory) needs the out-of-core path, which "
                    f"reads a north-up DEM in a metric CRS (this one is in {info.crs}); warp "
                    "it first, e.g. gdalwarp -t_srs EPSG:326ZZ (its UTM zone) in.tif out.tif",
                    path=info.path,
                    crs=str(info.crs),
                    hint="gdalwarp -t_srs <a metric CRS>",
                )
            if too_big and not use_dask:
                notes.append(
                    f"the DEM would take about {info.nbytes / 1e6:.0f} MB in memory "
                    f"({BYTES_PER_CELL} bytes per cell), above the memory cap "
                    f"{cap / 1e6:.0f} MB: computed out of core with dask"
                )
            from energy_planner.energymap.outofcore import compute_dask

            compute_dask(info, out, setup, model_name, chunk=chunk, progress=progress)
            mode = "dask"
        elif info.metric_north_up:
            samples.append(_Samples(info.shape, setup.headings, speed=bool(setup.extra)))
            _compute_windowed(info, out, setup, model_name, progress, samples[0])
            mode = "windowed"
        else:
            from energy_planner.terrain import load_dem

            terrain = load_dem(info.path, band=info.band)
            notes.append(
                f"the DEM's grid ({info.crs}) is not a metric north-up one: the map was "
                f"computed on the working grid {terrain.crs} and resampled onto the DEM's "
                "grid (bilinear); headings are degrees CCW from the DEM's local east"
            )
            _compute_on_dem_grid(terrain, info, out, setup, model_name, progress)
            convention = DEM_EAST
            mode = "terrain"
    return mode, convention
