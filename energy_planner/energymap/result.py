"""An energy map on disk: the GeoTIFF profile and metadata it is written with, and the result.

:class:`EnergyMapResult` (what :func:`energy_planner.energymap.energy_map` wrote, with
summary statistics read back) and :func:`sample_band`.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.energymap.bands import DEM_EAST, GRID_EAST, band_descriptions
from energy_planner.energymap.setup import _Setup
from energy_planner.results import Result

__all__ = ["EnergyMapResult", "sample_band"]

_TILE = 128  # output tile side, cells (the smaller one: see _tile)
_BIG_TILE = 256
#: Bytes of arrays per window of rows (bands as float32 + the gradient and temporaries)
#: up to which the output takes the larger tiles.
_BIG_TILE_BYTES = 256e6


def _bytes_per_row(cols: int, nbands: int) -> int:
    """Bytes of arrays a window holds per row: the bands (float32) and gradient temporaries.

    The 80 bytes per cell besides the bands: the window's gradient (16), the next
    window's, made while this one is computed (16, and up to 25 more while it is made:
    its rows in metres, a chunk of stored rows being read, the gradient's temporaries;
    :func:`~energy_planner.energymap.core._map_by_windows`), a chunk of stored rows kept
    for the next window (8), the squared gradient and its mask over a row range (about
    9, two ranges at once) and slack.
    """
    return cols * (nbands * 4 + 80)


def _tile(cols: int, nbands: int) -> int:
    """Output tile side: 256 while a window of 256 rows takes at most 256 MB, else 128.

    Tiles of 256 compress with 20 % less CPU than tiles of 128 (fewer, larger
    compression calls: 15.7 against 18.8 CPU s for a 4096^2 map); a window holds whole
    rows of tiles, so on a very wide DEM the smaller tile bounds its memory.
    """
    return _BIG_TILE if _BIG_TILE * _bytes_per_row(cols, nbands) <= _BIG_TILE_BYTES else _TILE


@dataclass(repr=False)
class EnergyMapResult(Result):
    """What :func:`energy_map` wrote and how.

    Attributes
    ----------
    path : pathlib.Path
        The GeoTIFF.
    shape : (int, int)
        Rows, columns.
    crs : str or None
        CRS of the map's grid.
    transform : tuple
        Its geotransform (6 numbers, rasterio order).
    headings : int
        Number of map headings.
    bands : list of dict
        ``name``, ``description``, ``units`` of every band, in order.
    mode : str
        ``"terrain"``, ``"windowed"`` or ``"dask"``.
    seconds : float
        Wall time of the computation and writing.
    stats : dict
        Summary of the cheapest cost and the anisotropy over valid cells.
    notes : list of str
        Decisions a reader should know (grid, ignored options).
    dem : path or Terrain or None
        The DEM the map was computed from (the hillshade of :meth:`plot` and
        :meth:`write_html`).
    speed_range : (float, float) or None
        ``(vmin, vmax)`` m/s where every cell and heading is priced at its best speed
        (with the band ``cheapest_speed``); None: one fixed speed.
    gaits : list of str
        The gaits each cell and heading chose among (the codes of ``cheapest_gait``, in
        order), where the model names them; else empty.
    """

    path: Path
    shape: tuple[int, int]
    crs: str | None
    transform: tuple[float, ...]
    headings: int
    bands: list[dict[str, str]]
    mode: str
    seconds: float
    stats: dict[str, Any] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    channels: dict[str, Any] = field(default_factory=dict)
    heading_convention: str = GRID_EAST
    dem: Any = field(default=None, repr=False, compare=False)
    speed_range: tuple[float, float] | None = None
    gaits: list[str] = field(default_factory=list)

    def write_html(self, path: str | Path, dem: Any = None) -> Path:
        """One self-contained HTML page with a band chooser.

        See :func:`energy_planner.energymap.plot.energy_map_page`.

        ``dem`` (a path or Terrain; default the map's own) gives the hillshade underneath.
        """
        from energy_planner.energymap.plot import energy_map_page

        return energy_map_page(self.path, self.dem if dem is None else dem, path)

    def plot(self, png: str | Path, dem: Any = None) -> Path:
        """Draw the map (:func:`~energy_planner.energymap.plot.plot_energy_map`) to ``png``.

        ``dem`` (a path or Terrain; default the map's own) gives the hillshade underneath.
        """
        from energy_planner.energymap.plot import plot_energy_map

        return plot_energy_map(self.path, png, self.dem if dem is None else dem)

    def write_json(self, path: str | Path) -> Path:
        """Write :meth:`to_dict` to ``path`` atomically; returns the path."""
        from energy_planner.io import write_json

        return write_json(path, self.to_dict())

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "path": str(self.path),
            "shape": list(self.shape),
            "crs": self.crs,
            "transform": list(self.transform),
            "headings": self.headings,
            "heading_convention": self.heading_convention,
            "bands": self.bands,
            "mode": self.mode,
            "seconds": self.seconds,
            "stats": self.stats,
            "channels": self.channels,
            "notes": self.notes,
            **(
                {} if self.speed_range is None else {"speed_range_m_s": list(self.speed_range)}
            ),  # fmt: skip
            **({"gaits": list(self.gaits)} if self.gaits else {}),
        }


def _profile(
    shape: tuple[int, int], transform: Any, crs: Any, nbands: int, compress: str = "deflate",
    encoding: str = "float32", writer_thread: bool = False,
) -> dict[str, Any]:  # fmt: skip
    """The project GeoTIFF profile (:func:`energy_planner.io.geotiff_profile`).

    Tiles of :func:`_tile`, so that a block of whole tile rows completes its tiles;
    ``compress`` at its fastest level (:func:`energy_planner.io.compression_options`),
    the tiles compressed by GDAL's worker threads (``NUM_THREADS=ALL_CPUS``) while the
    next window is computed. ``encoding``: ``float32`` (NaN nodata, floating-point
    predictor) or ``uint16`` (:mod:`~energy_planner.energymap.encoding`: code 0 nodata,
    horizontal predictor). ``writer_thread``: the file is written from a thread of its
    own beside the computation (:func:`~energy_planner.energymap.core._map_by_windows`);
    then ``uint16`` tiles are compressed in that thread (:func:`_compress_threads`).
    """
    from energy_planner.io import compression_options, geotiff_profile

    rows, cols = shape
    tiles: dict[str, Any] = {}
    side = _tile(cols, nbands)
    if rows >= side and cols >= side:
        tiles = dict(tiled=True, blockxsize=side, blockysize=side)
    elif rows >= _TILE and cols >= _TILE:
        tiles = dict(tiled=True, blockxsize=_TILE, blockysize=_TILE)
    # level 1: the bands (float32 costs) hardly compress further at deflate's default
    # level 6, which takes 1.6x the CPU (7.3 s against 4.6 s for 2048^2 x 36 bands)
    ints = encoding == "uint16"
    threads = _compress_threads(encoding) if writer_thread else "ALL_CPUS"
    comp = compression_options(compress, floating=not ints, threads=threads)
    kind: dict[str, Any] = dict(dtype="uint16", nodata=0) if ints else {}
    return geotiff_profile(shape, nbands, transform=transform, crs=crs, **comp, **tiles, **kind)


def _compress_threads(encoding: str, cores: int | None = None) -> str | None:
    """GDAL's ``NUM_THREADS`` for a map written from a thread of its own (None: that thread).

    On ``cores`` (default: those this process may run on) of at most 2, ``uint16`` tiles
    are compressed by the writing thread itself: they take less CPU than the map takes
    to compute (about 1.0 against 2.6 CPU s for a 2048 x 2048 map's 20 bands), so one
    thread keeps pace with the computation, and GDAL's worker threads would only add
    their hand-offs (0.2-0.25 CPU s more for the same map, each tile compressed in a
    scratch TIFF of its own). With more cores the computation would outrun one
    compressing thread (it keeps pace while its CPU times ``cores - 1`` stays below the
    computation's), and ``float32`` bands take twice the bytes and the floating-point
    predictor (4.3 CPU s for 36 bands): GDAL's workers (``ALL_CPUS``) share them.

    Examples
    --------
    >>> _compress_threads("uint16", cores=2), _compress_threads("uint16", cores=8)
    (None, 'ALL_CPUS')
    >>> _compress_threads("float32", cores=2)
    'ALL_CPUS'
    """
    if cores is None:
        from energy_planner.energy.heading import usable_cores

        cores = usable_cores()
    return None if encoding == "uint16" and cores <= 2 else "ALL_CPUS"


def _write_metadata(
    dst: Any, setup: _Setup, model_name: str, mode: str, convention: str = GRID_EAST
) -> None:
    """Band descriptions and units, dataset tags."""
    frame = "the DEM's local east" if convention == DEM_EAST else "east"
    descs = band_descriptions(
        setup.headings, frame, setup.bands, setup.extra, setup.speed_range, setup.gaits
    )
    from energy_planner.io import describe_band

    for i, (name, desc, units) in enumerate(descs, start=1):
        describe_band(dst, i, name=name, description=desc, units=units)
    if dst.dtypes[0] == "uint16":
        from energy_planner.energymap.encoding import INF_CODE

        steps = setup.steps
        dst.scales = tuple(float(x) for x in steps)
        dst.offsets = tuple(-float(x) for x in steps)
        dst.update_tags(
            encoding="uint16: value = code * scale + offset (offset = -scale); code 0 is "
            f"nodata (NaN), code {INF_CODE} is inf; precision scale / 2",
            inf_code=str(INF_CODE),
            nodata=f"code 0 (NaN); code {INF_CODE} = inf (above a slope limit)",
        )
    else:
        dst.update_tags(encoding="float32")
    dst.update_tags(
        software="energy_planner energy-map",
        bands=setup.bands,
        model=model_name,
        headings=str(setup.headings),
        heading_convention=convention,
        cost="J per metre of map (horizontal) distance through the cell centre",
        **(
            {"speed_m_s": repr(setup.speed)}
            if setup.speed_range is None
            else {
                "speed_range_m_s": "{!r}:{!r}".format(*setup.speed_range),
                "speed": "each body yaw of each cell and heading at its best ground speed "
                "in the range (energy_planner.energy.speed_map); cheapest_speed: the "
                "cheapest heading's",
            }
        ),
        **(
            {
                "gaits": ", ".join(
                    f"{k}={g} {a:g}-{b:g} m/s"
                    for k, (g, (a, b)) in enumerate(setup.heading.ranges.items())
                )
            }
            if setup.gaits
            else {}
        ),  # fmt: skip
        max_slope_tan=repr(setup.tmax),
        max_cross_slope_sin=repr(setup.smax),
        max_crab_rad=repr(setup.heading.crab),
        max_backward_slope_tan=repr(setup.heading.back_tan),
        best="least over the body's yaw relative to the travel (continuous minimum within "
        "the gait limits; energy_planner.energy.heading)",
        channels=repr(setup.channels.describe()),
        mode=mode,
        nodata="NaN; inf = above a slope limit",
    )


def _model_name(model: Any) -> str:
    if model is None:
        return "bundled default (B1-class)"
    meta = getattr(model, "metadata", {}) or {}
    return str(meta.get("source") or meta.get("name") or ", ".join(model.term_names))


def _result(
    out: Path, setup: _Setup, mode: str, seconds: float, notes: list[str],
    convention: str = GRID_EAST, samples: _Samples | None = None,
):  # fmt: skip
    """The result of a written map; its statistics from ``samples``, else read back."""
    import rasterio

    with rasterio.open(out) as src:
        shape = (src.height, src.width)
        crs = None if src.crs is None else str(src.crs)
        transform = tuple(src.transform)[:6]
        stats = _stats(src) if samples is None else samples.stats()
    frame = "the DEM's local east" if convention == DEM_EAST else "east"
    bands = [
        {"name": n, "description": d, "units": u}
        for n, d, u in band_descriptions(
            setup.headings, frame, setup.bands, setup.extra, setup.speed_range, setup.gaits
        )
    ]
    if stats.get("valid_cells", 1) == 0:
        warnings.warn(f"energy map {out} has no valid cell", UserWarning, stacklevel=3)
    return EnergyMapResult(
        path=out, shape=shape, crs=crs, transform=transform, headings=setup.headings,
        bands=bands, mode=mode, seconds=seconds, stats=stats, notes=notes,
        channels=setup.channels.describe(), heading_convention=convention,
        speed_range=setup.speed_range, gaits=list(setup.gaits),
    )  # fmt: skip


def _stats(src: Any, max_side: int = 1024) -> dict[str, Any]:
    """Quantiles of the cheapest cost and the anisotropy (every ``scale``-th cell).

    Read by windows of whole tile rows and decimated by slicing (the cell at the middle
    of each ``scale x scale`` square): GDAL's own decimated read (``out_shape``) of a
    deflated, tiled file decompresses each tile once per output line, 5 CPU s for a
    2048^2 map against 0.05 s for a full read.
    """
    from rasterio.windows import Window

    from energy_planner.energymap.encoding import read_band

    scale = max(1, math.ceil(max(src.height, src.width) / max_side))
    names = list(src.descriptions)
    i_cheap, i_aniso = names.index("cheapest") + 1, names.index("anisotropy") + 1
    i_speed = names.index("cheapest_speed") + 1 if "cheapest_speed" in names else None
    step = max(int(src.block_shapes[0][0]), 1)
    step = max(step, (1024 // step) * step)
    off = scale // 2
    cheap_parts: list = []
    aniso_parts: list = []
    speed_parts: list = []
    which = [(i_cheap, cheap_parts), (i_aniso, aniso_parts)]
    if i_speed is not None:
        which.append((i_speed, speed_parts))
    for r0 in range(0, src.height, step):
        win = Window(0, r0, src.width, min(step, src.height - r0))
        first = (off - r0) % scale  # first row of the window that is sampled
        for i, parts in which:
            parts.append(read_band(src, i, window=win)[first::scale, off::scale].astype(float))
    return _stats_of(cheap_parts, aniso_parts, scale, speed_parts)


class _Samples:
    """The cells :func:`_stats` reads back, taken from the windows as they are computed.

    The same cells (every ``scale``-th row and column from ``scale // 2``) of the float
    values, before any encoding: a windowed map's statistics need no read-back.
    """

    def __init__(
        self, shape: tuple[int, int], headings: int, max_side: int = 1024, speed: bool = False
    ) -> None:
        self.scale = max(1, math.ceil(max(shape) / max_side))
        self.off = self.scale // 2
        self.i_cheap, self.i_aniso = 2 * headings, 2 * headings + 2  # in the full layout
        self.i_speed = 2 * headings + 4 if speed else None  # cheapest_speed
        self.cheap: list[np.ndarray] = []
        self.aniso: list[np.ndarray] = []
        self.speed: list[np.ndarray] = []
        self._stats: dict[str, Any] | None = None

    def add(self, bands: np.ndarray, r0: int, lead: int = 0) -> None:
        """Take the sampled cells of a window's bands starting at row ``r0``.

        ``bands``: the full layout from its band ``lead`` on (``N`` for a window computed
        without its ``along_*`` bands).
        """
        self._stats = None
        first, off, k = (self.off - r0) % self.scale, self.off, self.scale
        self.cheap.append(bands[self.i_cheap - lead, first::k, off::k].astype(float))
        self.aniso.append(bands[self.i_aniso - lead, first::k, off::k].astype(float))
        if self.i_speed is not None:
            self.speed.append(bands[self.i_speed - lead, first::k, off::k].astype(float))

    def stats(self) -> dict[str, Any]:
        """As :func:`_stats` would read them (computed once after the last :meth:`add`).

        A windowed map asks for them as soon as its last window is computed, while that
        window is still being compressed and written: off the command's critical path.
        """
        if self._stats is None:
            self._stats = _stats_of(self.cheap, self.aniso, self.scale, self.speed)
        return self._stats


def _stats_of(
    cheap_parts: list, aniso_parts: list, scale: int, speed_parts: list | None = None
) -> dict[str, Any]:
    """Quantiles of the sampled cheapest costs, anisotropies and speeds (:func:`_stats`).

    ``speed_parts`` (a map at the best speed): ``cheapest_speed_m_s``, the quantiles of
    the cheapest heading's speed.
    """
    cheap = np.concatenate(cheap_parts).ravel()
    aniso = np.concatenate(aniso_parts).ravel()
    ok = np.isfinite(cheap)
    out: dict[str, Any] = {"sampled_every": scale, "valid_cells": int(ok.sum())}
    if ok.any():
        q = np.percentile(cheap[ok], [0, 10, 50, 90, 100])
        out["cheapest_j_per_m"] = dict(
            zip(("min", "p10", "median", "p90", "max"), q.tolist(), strict=True)
        )
        a = aniso[np.isfinite(aniso)]
        if a.size:
            qa = np.percentile(a, [50, 90, 100])
            out["anisotropy"] = dict(zip(("median", "p90", "max"), qa.tolist(), strict=True))
        sp = np.concatenate(speed_parts).ravel() if speed_parts else np.zeros(0)
        sp = sp[np.isfinite(sp)]
        if sp.size:
            qs = np.percentile(sp, [0, 10, 50, 90, 100])
            out["cheapest_speed_m_s"] = dict(
                zip(("min", "p10", "median", "p90", "max"), qs.tolist(), strict=True)
            )
    return out


def sample_band(path: str | Path, name: str, rows: Sequence[int], cols: Sequence[int]):
    """Values of band ``name`` at cells ``(rows[i], cols[i])`` of a written map.

    Float values whatever the map's encoding (:func:`~energy_planner.energymap.encoding.
    read_band`).
    """
    import rasterio

    from energy_planner.energymap.encoding import read_band

    with rasterio.open(path) as src:
        idx = list(src.descriptions).index(name) + 1
        data = read_band(src, idx)
    return data[np.asarray(rows), np.asarray(cols)]
