"""The memory cap: rasters whose decoded size would pass it are refused before reading.

A compressed GeoTIFF can be tiny on disk and enormous in memory (a 300 KB file of
50000 x 50000 cells decodes to 10 GB of float32, and a :class:`~energy_planner.terrain.
Terrain` holds several float64 grids of that size). :func:`check_memory` compares the
size a step would allocate with :func:`memory_cap` and raises
:class:`~energy_planner.errors.RasterTooLargeError` *before* anything is allocated, with
the size and the remedies.

The cap is the environment variable ``ENERGY_PLANNER_MEMORY_CAP``: a size in bytes with
an optional unit (``8G``, ``512M``, ``1.5GiB``, ``2000000000``), a share of the
machine's memory (``50%``), or ``off``. Default: 50 % of the physical memory (or of the
cgroup limit, when lower).

Every function that takes a cap (``cap=``, ``memory_cap=``, ``memory_cap_bytes=``) takes
one value, read by :func:`resolve_cap`: a number of bytes, :data:`DEFAULT_CAP` (the cap
above; ``None`` means the same) or :data:`NO_CAP` (no cap at all). Text (the variable,
``--memory-cap``) is read by :func:`parse_cap`.

Examples
--------
>>> import os
>>> parse_size("8G"), parse_size("512 MiB"), parse_size("1500")
(8589934592, 536870912, 1500)
>>> os.environ["ENERGY_PLANNER_MEMORY_CAP"] = "1G"
>>> memory_cap()
1073741824
>>> check_memory((50000, 50000), 64, "DEM 'big.tif'")  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
energy_planner.errors.RasterTooLargeError: DEM 'big.tif' is 50000 x 50000 cells: ...
>>> del os.environ["ENERGY_PLANNER_MEMORY_CAP"]
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

from energy_planner.errors import DEMError, RasterTooLargeError

__all__ = [
    "BYTES_PER_CELL",
    "Cap",
    "DEFAULT_CAP",
    "DEFAULT_MEMORY_SHARE",
    "LONLAT_BYTES_PER_CELL",
    "MEMORY_CAP_ENV",
    "NO_CAP",
    "check_memory",
    "format_bytes",
    "memory_cap",
    "parse_cap",
    "parse_size",
    "resolve_cap",
    "total_memory",
]

#: Environment variable holding the cap.
MEMORY_CAP_ENV = "ENERGY_PLANNER_MEMORY_CAP"
#: Default cap as a share of the machine's memory.
DEFAULT_MEMORY_SHARE = 0.5
#: Bytes per working-grid cell budgeted for loading a DEM into a Terrain and deriving
#: slope/aspect from it. Measured peak (tracemalloc, ``docs/terrain.md``): 46 B/cell for a
#: float32 DEM in a metric CRS (read, mask, float64 copy, elevation, Horn gradient), 55 with
#: the reprojection to UTM; the slope and aspect grids add 8 each.
BYTES_PER_CELL = 64
#: The same for a longitude/latitude (or other non-metric) DEM, per working-grid cell: the
#: Terrain also keeps the DEM's own grid with its Horn gradient (24 B per source cell).
#: Measured peak of ``load_dem`` on a 3000 x 3000 float32 lon/lat DEM: 57 B per working
#: cell (47 held; ``benchmarks/bench_terrain_lonlat.py``); slope and aspect add 16.
LONLAT_BYTES_PER_CELL = 80


class _CapChoice:
    """A named cap that is not a number of bytes (:data:`DEFAULT_CAP`, :data:`NO_CAP`)."""

    def __init__(self, name: str) -> None:
        self._name = name

    def __repr__(self) -> str:
        return self._name


#: The default cap: :func:`memory_cap` (``ENERGY_PLANNER_MEMORY_CAP``, else a share of the
#: memory). ``None`` given as a cap means the same.
DEFAULT_CAP = _CapChoice("DEFAULT_CAP")
#: No cap: any raster is read whole.
NO_CAP = _CapChoice("NO_CAP")
#: What a ``cap`` argument takes: bytes, :data:`DEFAULT_CAP` (or None) or :data:`NO_CAP`.
Cap = int | _CapChoice | None

_UNITS = {
    "": 1,
    "b": 1,
    "k": 1024,
    "kb": 1000,
    "kib": 1024,
    "m": 1024**2,
    "mb": 1000**2,
    "mib": 1024**2,
    "g": 1024**3,
    "gb": 1000**3,
    "gib": 1024**3,
    "t": 1024**4,
    "tb": 1000**4,
    "tib": 1024**4,
}


def parse_size(text: str) -> int:
    """Bytes from ``"8G"``, ``"512 MiB"``, ``"1.5GB"`` or a plain number of bytes.

    Single letters (``K``, ``M``, ``G``, ``T``) are binary units, as ``ulimit`` and
    ``docker --memory`` read them.

    Raises
    ------
    ValueError
        Not a size.
    """
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([A-Za-z]*)\s*", str(text))
    if not m or m.group(2).lower() not in _UNITS:
        raise ValueError(f"{text!r} is not a size (expected e.g. 8G, 512M, 1.5GiB, 2000000000)")
    return int(float(m.group(1)) * _UNITS[m.group(2).lower()])


def total_memory() -> int | None:
    """Physical memory in bytes, or the cgroup (container) limit when lower; None if unknown."""
    total = None
    try:
        total = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        total = None
    for f in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            lim = int(Path(f).read_text().strip())
        except (OSError, ValueError):
            continue
        if 0 < lim < (total or math.inf):
            total = lim
    return total


def parse_cap(text: str) -> int | None:
    """A cap in bytes from its text: a size, a share of the memory (``50%``) or ``off``.

    ``""`` is the default (:data:`DEFAULT_MEMORY_SHARE` of the memory); ``off`` (or
    ``none``, ``no``, ``0``) and a share of an unknown memory give None (no cap).

    Raises
    ------
    ValueError
        Not a size, a share in (0, 1000] % or ``off``.

    Examples
    --------
    >>> parse_cap("2G"), parse_cap("off")
    (2147483648, None)
    """
    raw = str(text).strip()
    if raw.lower() in ("off", "none", "no", "0"):
        return None
    total = total_memory()
    if not raw:
        return None if total is None else int(DEFAULT_MEMORY_SHARE * total)
    if raw.endswith("%"):
        share = float(raw[:-1]) / 100.0
        if not 0 < share <= 10:
            raise ValueError(raw)
        return None if total is None else int(share * total)
    return parse_size(raw)


def memory_cap() -> int | None:
    """The cap in bytes from ``ENERGY_PLANNER_MEMORY_CAP`` (None = no cap).

    Raises
    ------
    DEMError
        The variable is set to something that is not a size, a percentage or ``off``.
    """
    raw = os.environ.get(MEMORY_CAP_ENV, "").strip()
    try:
        return parse_cap(raw)
    except ValueError:
        raise DEMError(
            f"{MEMORY_CAP_ENV}={raw!r} is not understood; expected a size (8G, 512M, "
            "2000000000), a share of the memory (50%) or off",
            value=raw,
            param=MEMORY_CAP_ENV,
            expected="a size, a percentage or off",
        ) from None


def resolve_cap(cap: Cap = DEFAULT_CAP) -> float:
    """The cap in bytes that ``cap`` stands for (``math.inf``: no cap).

    Parameters
    ----------
    cap : int, DEFAULT_CAP, NO_CAP or None
        Bytes; :data:`DEFAULT_CAP` or None: :func:`memory_cap` (which may be off);
        :data:`NO_CAP`: no cap.

    Examples
    --------
    >>> resolve_cap(2_000_000), resolve_cap(NO_CAP)
    (2000000, inf)
    """
    if cap is NO_CAP:
        return math.inf
    if cap is DEFAULT_CAP or cap is None:
        limit = memory_cap()
        return math.inf if limit is None else limit
    return int(cap)


def format_bytes(n: float) -> str:
    """``"1.5 GiB"`` style size.

    Examples
    --------
    >>> format_bytes(1536), format_bytes(160e9)
    ('1.5 KiB', '149 GiB')
    """
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if abs(n) < 1024 or unit == "TiB":
            return f"{n:.3g} {unit}" if unit != "B" else f"{int(n)} B"
        n /= 1024.0
    return f"{n:.3g} TiB"  # pragma: no cover


def check_memory(
    shape: tuple[int, int],
    bytes_per_cell: float,
    what: str,
    *,
    path: str | Path | None = None,
    hint: str | None = None,
    cap: Cap = DEFAULT_CAP,
) -> None:
    """Raise :class:`RasterTooLargeError` if ``shape`` cells would pass the memory cap.

    Parameters
    ----------
    shape : (int, int)
        Rows, columns.
    bytes_per_cell : float
        Bytes the step allocates per cell (e.g. :data:`BYTES_PER_CELL` for a DEM load).
    what : str
        Names the raster in the message (``"DEM 'big.tif'"``).
    path : str or Path, optional
        The file (a field of the error).
    hint : str, optional
        The remedy; default: read a window, a coarser resolution, or the out-of-core
        ``energy-map --dask``.
    cap : int, DEFAULT_CAP or NO_CAP, optional
        The cap (:func:`resolve_cap`; default :func:`memory_cap`).
    """
    limit = resolve_cap(cap)
    rows, cols = (int(v) for v in shape)
    need = float(rows) * float(cols) * float(bytes_per_cell)
    if need <= limit:
        return
    if hint is None:
        k = max(2, math.ceil(math.sqrt(need / limit)))
        hint = (
            "read a window (load_dem(..., bounds=(xmin, ymin, xmax, ymax)), `terrain --bounds "
            "XMIN,YMIN,XMAX,YMAX`, or gdal_translate -projwin), a coarser grid "
            f"(load_dem(..., decimate={k}), `terrain --decimate {k}`, or gdalwarp -tr XRES YRES "
            "-r average), or the out-of-core path (energy-planner energy-map --dask); or raise "
            f"the cap with {MEMORY_CAP_ENV}=SIZE if the machine has the memory"
        )
    total = total_memory()
    src = (
        f"set by {MEMORY_CAP_ENV}"
        if os.environ.get(MEMORY_CAP_ENV, "").strip()
        else f"default {DEFAULT_MEMORY_SHARE:.0%} of {format_bytes(total or 0)} memory; "
        f"{MEMORY_CAP_ENV} changes it"
    )
    raise RasterTooLargeError(
        f"{what} is {rows} x {cols} cells: working with it needs about "
        f"{format_bytes(need)} ({bytes_per_cell:g} bytes per cell), above the memory cap "
        f"{format_bytes(limit)} ({src}). Nothing was read. Hint: {hint}",
        path=path,
        shape=(rows, cols),
        size_bytes=int(need),
        cap_bytes=int(limit),
        hint=hint,
        expected=f"at most {format_bytes(limit)}",
    )
