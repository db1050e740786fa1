"""How an energy map's bands are stored: scaled 16-bit integers (default) or float32.

``uint16`` (the default) stores each band as whole numbers with a GDAL scale and offset,
``value = code * scale + offset`` (``gdalinfo`` prints them; rasterio reads them as
``src.scales`` / ``src.offsets``; QGIS applies them), ``offset = -scale``:

- code ``0``: nodata (NaN in float32), declared as the band's nodata value;
- code ``65535``: ``inf`` (above a slope limit; the tag ``inf_code``);
- codes ``1 .. 65534``: ``(code - 1) * scale``, i.e. ``0 .. 65533 * scale``.

The scale of each band is its precision (the value is rounded to the nearest multiple,
so a decoded value is within ``scale / 2`` of the float32 one): J/m bands
(``along_*``, ``best_*``, ``cheapest``, ``dearest``) :data:`COST_STEP` (0.25 J/m, up
to 16,383.25 J/m), ``anisotropy`` :data:`RATIO_STEP` (1/4096, up to 16.0),
``cheapest_heading_deg`` :data:`HEADING_STEP` (1/128 degree: the
headings of a metric grid exactly when ``360 / N`` is a multiple of it, as for 16 or
360 headings; a map resampled onto a geographic DEM's grid, its headings rotated by the
meridian convergence, to 0.004 degrees). A map with a finite
value outside a band's range (a cost above 16,383 J/m, a cliff; a negative one; an anisotropy
above 64, where a model prices some heading near zero) is written as float32 instead,
and says so.

The same bytes hold half as many bits as float32 and compress to about a quarter of
its size (43 MB against 179 MB for a 2048 x 2048 map's 20 bands), with less CPU: the
integer predictor and zstd have less to do.

A map at the best speed of a range adds ``cheapest_speed`` at :data:`SPEED_STEP`
(1/2048 m/s, up to 32 m/s) and, choosing the gait, ``cheapest_gait`` at 1 (its code).

:func:`read_band` reads a band of either kind as float values (NaN and inf restored).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from energy_planner.errors import EnergyMapError

__all__ = [
    "COST_STEP",
    "DEFAULT_ENCODING",
    "ENCODINGS",
    "HEADING_STEP",
    "INF_CODE",
    "NODATA_CODE",
    "RATIO_STEP",
    "SPEED_STEP",
    "band_steps",
    "decode",
    "encode_block",
    "read_band",
]

#: Band encodings a map can be written with (:func:`energy_planner.energymap.energy_map`).
ENCODINGS = ("uint16", "float32")
#: The encoding unless asked otherwise.
DEFAULT_ENCODING = "uint16"
#: Precision of a J/m band in ``uint16``: 0.25 J/m, 2e-4 of the least cost a cell can
#: have under the bundled model (about 590 J/m), well below the heading table's 0.3 %
#: and the model's 1-2 % error on held-out runs.
COST_STEP = 0.25
#: Precision of the anisotropy (a ratio >= 1) in ``uint16``: 1/1024 (5e-4 of a ratio
#: of 1), up to 64.
RATIO_STEP = 1.0 / 1024.0
#: Precision of the cheapest heading in ``uint16``, degrees (up to 512).
HEADING_STEP = 1.0 / 128.0
#: Precision of the ground speed band (``cheapest_speed``) in ``uint16``, m/s (up to 32).
SPEED_STEP = 1.0 / 2048.0
#: The code of a nodata cell (NaN).
NODATA_CODE = 0
#: The code of ``inf`` (a cell or heading above a slope limit).
INF_CODE = 65535


class EncodingOverflow(EnergyMapError, OverflowError):
    """A finite value outside a band's ``uint16`` range: the map is written as float32."""


def band_steps(headings: int, names: list[str]) -> np.ndarray:
    """The ``uint16`` scale of each band named in ``names`` (a map with ``headings``).

    Examples
    --------
    >>> band_steps(16, ["best_000", "cheapest", "anisotropy", "cheapest_heading_deg"])
    array([0.25      , 0.25      , 0.00097656, 0.0078125 ])
    """
    out = []
    for n in names:
        if n == "anisotropy":
            out.append(RATIO_STEP)
        elif n == "cheapest_heading_deg":
            out.append(HEADING_STEP)
        elif n == "cheapest_speed":
            out.append(SPEED_STEP)
        elif n == "cheapest_gait":  # a code: 0, 1, ...
            out.append(1.0)
        else:
            out.append(COST_STEP)
    return np.array(out, dtype=np.float64)


def encode_block(
    block: np.ndarray, steps: np.ndarray, out: np.ndarray | None = None, aot: Any = None
) -> np.ndarray:
    """``uint16`` codes of a float32 block ``(bands, rows, cols)`` (see the module docstring).

    ``aot``: the model's precompiled map module (its ``encode``, GIL-free, run in threads
    over the rows), else numba's. ``out``: a uint16 array of the block's shape to fill.

    Raises
    ------
    EncodingOverflow
        A finite value is outside its band's range.
    """
    if out is None or out.shape != block.shape:
        out = np.empty(block.shape, dtype=np.uint16)
    inv = np.ascontiguousarray(1.0 / np.asarray(steps, dtype=np.float64))
    if aot is None:
        from energy_planner.energymap._summary import encode

        bad = int(encode(block, inv, out))
    else:
        from energy_planner.energy.heading import run_by_rows

        counts: list[int] = []
        rows = block.shape[1]
        run_by_rows(lambda a, b: counts.append(aot.encode(block[:, a:b], inv, out[:, a:b])), rows)
        bad = sum(counts)
    if bad:
        raise EncodingOverflow(f"{bad} values outside the uint16 range of their band")
    return out


def decode(codes: np.ndarray, scale: float, offset: float | None = None) -> np.ndarray:
    """Float values (float64) of ``uint16`` codes: NaN for code 0, ``inf`` for 65535.

    Examples
    --------
    >>> decode(np.array([0, 1, 2401, 65535], dtype=np.uint16), 0.25)
    array([ nan,   0., 600.,  inf])
    """
    offset = -scale if offset is None else offset
    v = codes.astype(np.float64) * scale + offset
    v[codes == NODATA_CODE] = np.nan
    v[codes == INF_CODE] = np.inf
    return v


def read_band(
    src: Any, index: int, *, window: Any = None, out_shape: Any = None, resampling: Any = None
) -> np.ndarray:
    """Band ``index`` (1-based) of an open energy map as float values, whatever its encoding.

    float32 maps are read as they are; ``uint16`` maps are decoded (:func:`decode`).
    ``out_shape`` and ``resampling``: a decimated read (GDAL's). Of a ``uint16`` map
    with a resampling other than ``nearest``, the codes are averaged (nodata left out)
    and a cell is ``inf`` where the nearest source cell is (GDAL reads no ``max``): a
    picture's approximation, not the float map's average.
    """
    kw: dict[str, Any] = {"window": window}
    if out_shape is not None:
        kw.update(out_shape=out_shape, resampling=resampling)
    if src.dtypes[index - 1] != "uint16":
        return src.read(index, **kw)
    from rasterio.enums import Resampling

    codes = src.read(index, out_dtype="float64", **kw)
    scale, offset = src.scales[index - 1], src.offsets[index - 1]
    v = codes * scale + offset
    v[codes == NODATA_CODE] = np.nan
    top = codes
    if out_shape is not None and resampling not in (None, Resampling.nearest):
        top = src.read(index, window=window, out_shape=out_shape, resampling=Resampling.nearest)
    v[top == INF_CODE] = np.inf
    return v
