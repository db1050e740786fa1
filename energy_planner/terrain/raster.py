"""Elevations as GDAL describes them: the one reader of a DEM band's values.

Every door that reads DEM cells (``load_dem``, the energy map's windowed and dask paths,
the corridor's strips) decodes them here, so that they agree:

- **Masks.** Cells are invalid where GDAL's mask says so: the declared nodata value, an
  internal or external mask band, an alpha band (``read(masked=True)``), and where the
  value is NaN or infinite.
- **Scale and offset.** ``metres = (stored * scale + offset) * unit``, with the band's
  ``scale``/``offset`` (``gdal_edit.py -scale -offset``; an int16 decimetre DEM has
  scale 0.1) and the length of the band's unit (``m``, ``dm``, ``cm``, ``mm``, ``ft``,
  ``US survey foot``...; no unit is metres). An unknown unit is refused.
- **Undeclared voids.** A DEM with no nodata value and no mask whose cells hold a value
  that marks voids by convention (-9999, -32768, 1e30, the float32 extremes... see
  :data:`VOID_VALUES`), far outside the other cells (further from them than their own
  range), or any value beyond 1e15 m, gets those cells masked with a
  ``UserWarning`` naming the value, the count and the ``gdal_edit.py -a_nodata`` that
  declares it. A file read by windows is scanned once for them (:func:`band_reading`)
  when it holds up to :data:`SCAN_CELLS` cells; in a larger file each window finds its
  own (the rule above within the window; one warning per file and value), so that a
  corridor or an energy map of a large DEM reads its cells once, not twice.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.errors import DEMError

__all__ = ["VOID_VALUES", "BandReading", "band_reading", "find_voids", "vertical_unit"]

#: Stored values that mark voids by convention when no nodata is declared: ESRI/ASCII
#: grids (-9999, -99999), SRTM and int16 tools (-32768, -32767, 32767), uint16 (65535),
#: float tools (+-1e20, +-1e30, +-1e38, the float32 extremes).
VOID_VALUES = (
    -9999.0, -99999.0, -32768.0, -32767.0, 32767.0, 65535.0, -1e20, 1e20, -1e30, 1e30,
    -1e38, 1e38, -3.4028234663852886e38, 3.4028234663852886e38,
)  # fmt: skip

#: A value this far from sea level (metres) is a void whatever the other cells hold.
IMPOSSIBLE_M = 1e15

#: Windowed readers of a file of up to this many cells scan it whole for undeclared voids
#: first (exact counts; a fraction of a second); larger files find them window by window.
SCAN_CELLS = 16_000_000

#: Metres per vertical unit, by the unit names GDAL writers use (lower case).
_UNITS = {
    "": 1.0, "m": 1.0, "metre": 1.0, "meter": 1.0, "metres": 1.0, "meters": 1.0,
    "dm": 0.1, "decimetre": 0.1, "decimeter": 0.1, "decimetres": 0.1, "decimeters": 0.1,
    "cm": 0.01, "centimetre": 0.01, "centimeter": 0.01, "centimetres": 0.01,
    "centimeters": 0.01, "mm": 0.001, "millimetre": 0.001, "millimeter": 0.001,
    "millimetres": 0.001, "millimeters": 0.001, "km": 1000.0, "kilometre": 1000.0,
    "kilometer": 1000.0, "ft": 0.3048, "foot": 0.3048, "feet": 0.3048,
    "international foot": 0.3048, "intl foot": 0.3048, "us survey foot": 1200.0 / 3937.0,
    "us-ft": 1200.0 / 3937.0, "ftus": 1200.0 / 3937.0, "us_survey_foot": 1200.0 / 3937.0,
    "us foot": 1200.0 / 3937.0, "survey foot": 1200.0 / 3937.0, "us feet": 1200.0 / 3937.0,
}  # fmt: skip


def vertical_unit(unit: str | None, name: str, crs: Any = None) -> float:
    """Metres per stored unit of elevation: the band's unit, else the CRS's vertical axis.

    Raises
    ------
    DEMError
        A unit that is not a length this table knows.

    Examples
    --------
    >>> vertical_unit("ft", "dem.tif"), vertical_unit("", "dem.tif"), vertical_unit("m asl", "x")
    (0.3048, 1.0, 1.0)
    """
    key = " ".join((unit or "").strip().lower().split())
    if key == "" and crs is not None:
        return _crs_vertical_unit(crs)
    if key in _UNITS:
        return _UNITS[key]
    first = key.split(" ")[0]
    if first in _UNITS and first not in ("us", "intl", "international", "survey"):
        return _UNITS[first]  # "m asl", "metres above sea level"
    raise DEMError(
        f"DEM {name!r} gives its elevations in {unit!r}, which is not a length unit this "
        "reader knows; expected m, dm, cm, mm, ft or US survey foot (set it with "
        f"gdal_edit.py -units m {name}, after converting the values if needed)",
        path=name,
        value=unit,
        expected="a vertical unit: m, dm, cm, mm, ft, US survey foot",
    )


def _crs_vertical_unit(crs: Any) -> float:
    """Metres per unit of a compound CRS's vertical axis (1 without one).

    A CRS whose WKT names no vertical part is answered without importing pyproj (its
    import costs a command's start-up a tenth of a second).
    """
    try:
        if "VERT" not in crs.to_wkt().upper():
            return 1.0
        from pyproj import CRS as ProjCRS

        pc = ProjCRS.from_user_input(crs.to_wkt())
        for sub in pc.sub_crs_list or ():
            if sub.is_vertical and sub.axis_info:
                return float(sub.axis_info[0].unit_conversion_factor)
    except Exception:  # noqa: BLE001 - an odd CRS has no vertical axis we can read
        return 1.0
    return 1.0


@dataclass(frozen=True)
class BandReading:
    """How to turn one band's stored values into metres (see the module docstring).

    Attributes
    ----------
    path : str
        The DEM file.
    band : int
        1-based band.
    scale, offset : float
        GDAL's band scale and offset (1 and 0 when not set).
    unit_m : float
        Metres per unit of ``stored * scale + offset``.
    declared : bool
        True if GDAL masks the band (a nodata value, a mask or alpha band).
    voids : tuple of (float, int)
        Undeclared void values found in the file (stored value, cells), for windowed
        reads; empty when the band is declared or none were found.
    local : bool
        True if the file was too large to scan first (:data:`SCAN_CELLS`): every read
        finds the undeclared voids of its own window (:meth:`mask_voids`).
    """

    path: str
    band: int
    scale: float = 1.0
    offset: float = 0.0
    unit_m: float = 1.0
    declared: bool = False
    voids: tuple[tuple[float, int], ...] = ()
    local: bool = False

    @property
    def identity(self) -> bool:
        """True if the stored values are metres as they are."""
        return self.scale == 1.0 and self.offset == 0.0 and self.unit_m == 1.0

    def to_metres(self, stored: np.ndarray) -> np.ndarray:
        """Stored values (float64, NaN invalid) to metres, in place when float64."""
        z = np.asarray(stored, dtype=np.float64)
        if not self.identity:
            z *= self.scale * self.unit_m
            z += self.offset * self.unit_m
        return z

    def mask_voids(self, stored: np.ndarray) -> None:
        """Set the cells of :attr:`voids` to NaN in ``stored`` (float64, in place).

        With :attr:`local`, the voids of this window (:func:`find_voids`), warned once
        per file and value.
        """
        if self.local and not self.declared:
            _find_local(stored, self)
            return
        for value, _ in self.voids:
            stored[stored == value] = np.nan

    def read(self, src: Any, find: bool = False, warn: bool = True, **kwargs: Any) -> np.ndarray:
        """``src.read(band, masked=True, **kwargs)`` in metres, float64, NaN invalid.

        Masked cells, NaN and infinities become NaN; undeclared voids too: the file's
        (:attr:`voids`), or with ``find`` those of this array (:func:`find_voids`, for a
        read of the whole band; ``warn``: with its warning); then scale, offset and unit
        are applied. The mask is ``src.read_masks`` of the same cells (what a masked read
        takes), read only when the band declares one (:attr:`declared`; otherwise every
        cell is valid): no ``numpy.ma`` (whose import alone costs a warm command ~10 ms).
        """
        z = src.read(self.band, **kwargs).astype(np.float64)
        if self.declared:
            np.putmask(z, src.read_masks(self.band, **kwargs) == 0, np.nan)
        np.putmask(z, ~np.isfinite(z), np.nan)
        if find and not self.local:
            find_voids(z, self, warn=warn)
        else:
            self.mask_voids(z)
        return self.to_metres(z)


_SCANNED: dict[tuple, BandReading] = {}


def band_reading(src: Any, band: int, name: str, scan: bool | str = False) -> BandReading:
    """The :class:`BandReading` of band ``band`` of the open dataset ``src``.

    ``scan``: when the band declares no nodata and no mask, read the whole file once, in
    strips of rows, for undeclared voids (:func:`find_voids`; a ``UserWarning`` names
    them). For readers that see the file by windows; a whole read finds them itself
    (:func:`find_voids` on its array). A file is scanned once per version (its size and
    modification time): the corridor's windows of one DEM share the scan. A file of more
    than :data:`SCAN_CELLS` cells is not scanned: its reading is :attr:`~BandReading.local`
    (each window finds its own), unless ``scan="full"`` (a decimated read, which would
    average voids into its cells, needs to know them first).

    Raises
    ------
    DEMError
        A zero or non-finite scale, or a vertical unit that is not a length.
    """
    from rasterio.enums import MaskFlags

    i = int(band) - 1
    scale = float(src.scales[i]) if src.scales and src.scales[i] is not None else 1.0
    offset = float(src.offsets[i]) if src.offsets and src.offsets[i] is not None else 0.0
    if not (math.isfinite(scale) and scale != 0.0 and math.isfinite(offset)):
        raise DEMError(
            f"DEM {name!r} band {band} has scale {scale!r} and offset {offset!r}; expected "
            f"a finite non-zero scale (fix it with gdal_edit.py -scale 1 -offset 0 {name})",
            path=name,
            value=(scale, offset),
            expected="a finite non-zero scale and a finite offset",
        )
    unit_m = vertical_unit(src.units[i] if src.units else "", name, src.crs)
    declared = src.mask_flag_enums[i] != [MaskFlags.all_valid]
    reading = BandReading(name, int(band), scale, offset, unit_m, declared)
    if not scan or declared:
        return reading
    if scan != "full" and src.height * src.width > SCAN_CELLS:
        return BandReading(name, int(band), scale, offset, unit_m, declared, local=True)
    try:
        st = Path(name).stat()
        key: tuple | None = (str(Path(name).resolve()), st.st_size, st.st_mtime_ns, int(band))
    except OSError:
        key = None
    if key is not None and key in _SCANNED:
        return _SCANNED[key]
    voids = _scan_voids(src, reading)
    if voids:
        warn_voids(voids, name)
        reading = BandReading(name, int(band), scale, offset, unit_m, declared, voids)
    if key is not None:
        if len(_SCANNED) > 32:
            _SCANNED.clear()
        _SCANNED[key] = reading
    return reading


def _scan_voids(src: Any, reading: BandReading) -> tuple[tuple[float, int], ...]:
    """Undeclared voids of the whole band, read in strips of about 4 million cells."""
    from rasterio.windows import Window

    rows, cols = src.height, src.width
    step = max(1, 4_000_000 // max(cols, 1))
    counts: dict[float, int] = {}
    lo, hi = math.inf, -math.inf  # range of the other cells, metres
    for r0 in range(0, rows, step):
        part = src.read(reading.band, window=Window(0, r0, cols, min(step, rows - r0)))
        z = part.astype(np.float64)
        np.putmask(z, ~np.isfinite(z), np.nan)
        cand = _candidates(z, reading)
        for v in _distinct(z[cand]):
            counts[float(v)] = counts.get(float(v), 0) + int(np.count_nonzero(z == v))
        rest = reading.to_metres(np.where(cand, np.nan, z))
        if np.isfinite(rest).any():
            lo, hi = min(lo, float(np.nanmin(rest))), max(hi, float(np.nanmax(rest)))
    return _decide(counts, reading, lo, hi)


def _distinct(values: np.ndarray) -> np.ndarray:
    """The distinct values of a 1-D float array, sorted (no NaN among them).

    ``np.unique``'s values; NumPy 2's ``unique`` imports ``numpy.ma`` (~10 ms of a
    command's start-up) to ask whether its argument is masked.
    """
    v = np.sort(values)
    if v.size < 2:
        return v
    keep = np.empty(v.size, dtype=bool)
    keep[0] = True
    np.not_equal(v[1:], v[:-1], out=keep[1:])
    return v[keep]


def _candidates(stored: np.ndarray, reading: BandReading) -> np.ndarray:
    """Cells whose stored value may mark a void: a conventional value or an impossible one."""
    cand = np.isin(stored, VOID_VALUES)
    with np.errstate(invalid="ignore", over="ignore"):
        metres = (stored * reading.scale + reading.offset) * reading.unit_m
        cand |= np.abs(metres) >= IMPOSSIBLE_M
    return cand


def _decide(
    counts: dict[float, int], reading: BandReading, lo: float, hi: float
) -> tuple[tuple[float, int], ...]:
    """The candidate values that are voids.

    Those impossible as elevations, or further from the other cells than their range
    (every candidate when no other cell is valid).
    """
    out = []
    spread = hi - lo if math.isfinite(lo) else math.nan
    for v, n in sorted(counts.items(), key=lambda kv: -kv[1]):
        m = (v * reading.scale + reading.offset) * reading.unit_m
        if abs(m) >= IMPOSSIBLE_M or not math.isfinite(spread):
            out.append((v, n))
            continue
        gap = lo - m if m < lo else (m - hi if m > hi else 0.0)
        if gap > max(spread, 1.0):
            out.append((v, n))
    return tuple(out)


def find_voids(
    stored: np.ndarray, reading: BandReading, warn: bool = True
) -> tuple[tuple[float, int], ...]:
    """Undeclared voids of a whole array of stored values; set to NaN in place.

    ``stored`` is float64 with NaN for invalid cells, before scale and offset. Returns
    the void values and their counts (empty when the band declares its nodata or mask);
    with ``warn`` a ``UserWarning`` names them.
    """
    if reading.declared:
        return ()
    cand = _candidates(stored, reading)
    if not cand.any():
        return ()
    values, n = np.unique(stored[cand], return_counts=True)
    rest = reading.to_metres(np.where(cand, np.nan, stored))
    finite = np.isfinite(rest)
    lo = float(np.nanmin(rest)) if finite.any() else math.nan
    hi = float(np.nanmax(rest)) if finite.any() else math.nan
    voids = _decide(
        {float(v): int(k) for v, k in zip(values, n, strict=True)},
        reading,
        lo if finite.any() else math.inf,
        hi if finite.any() else -math.inf,
    )
    for v, _ in voids:
        stored[stored == v] = np.nan
    if voids and warn:
        warn_voids(voids, reading.path, (lo, hi) if finite.any() else None)
    return voids


_WARNED: set[tuple[str, float]] = set()


def _find_local(stored: np.ndarray, reading: BandReading) -> None:
    """The undeclared voids of one window of a :attr:`~BandReading.local` reading.

    Set to NaN in place; a value is warned of once per file.
    """
    voids = find_voids(stored, reading, warn=False)
    new = tuple((v, n) for v, n in voids if (reading.path, v) not in _WARNED)
    if new:
        _WARNED.update((reading.path, v) for v, _ in new)
        warn_voids(new, reading.path, where=" in the first window read that holds them")


def warn_voids(
    voids: tuple[tuple[float, int], ...],
    name: str,
    rest: tuple[float, float] | None = None,
    where: str = "",
) -> None:
    """The ``UserWarning`` that names undeclared void values and their counts."""
    what = ", ".join(f"{n} cells of {v:g}" for v, n in voids[:3]) + where
    if len(voids) > 3:
        what += f" and {len(voids) - 3} more values"
    among = f" (the other cells are {rest[0]:.6g} .. {rest[1]:.6g} m)" if rest is not None else ""
    warnings.warn(
        f"DEM {name!r} declares no nodata value but holds {what}{among}: read as voids. "
        f"Declare it to silence this: gdal_edit.py -a_nodata {voids[0][0]:g} {name}",
        UserWarning,
        stacklevel=3,
    )
