"""A DEM read before, read again without GDAL: the warm start of ``energy``.

:func:`read_stored` and :func:`keep_stored` keep
:func:`~energy_planner.terrain.load.load_dem` of a whole DEM (one band, no window, no
decimation) for a command that asks little of its CRS (``energy``). The first read of a
DEM goes through rasterio as always; the caller keeps the working grid (its elevation,
transforms and shape) and its CRS's WKT and answers (``str``, EPSG code, geographic or
projected, linear unit) in the project's cache folder
(:func:`~energy_planner.model._codegen.cache_dir`, ``dem_<key>.npy`` and ``.json``). A
later read of the same file finds them and builds the same :class:`Terrain` from them,
without importing rasterio (GDAL, PROJ's database): about 0.1 s of a warm command.

What makes an entry the same: the DEM's resolved path, its band, the size, modification
and change times and inode of the file and of every file beside it whose name starts
with its stem (``.aux.xml``, ``.msk``, world files: what GDAL reads with it), the
environment variables that steer GDAL, PROJ and the project (``GDAL_*``, ``GTIFF_*``,
``CPL_*``, ``PROJ_*``, ``OSR_*``, ``ENERGY_PLANNER_*``), the installed rasterio and the
project's terrain modules. Anything else is a new entry. Only DEMs whose CRS is metric
(no reprojection), of at most :data:`MAX_CELLS` cells and read without a warning are
kept (the caller shows a read's warnings and keeps no read that warned, but for a
library's deprecation notes); the :data:`KEEP` most recently used entries stay.

The CRS of a Terrain read back is a :class:`StoredCRS`: it answers the stored questions
itself and builds the rasterio CRS from the WKT for anything else (and for comparison
with any other CRS), so code that uses it as a rasterio CRS gets the same answers.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["KEEP", "MAX_CELLS", "StoredCRS", "keep_stored", "read_stored"]

#: Largest working grid kept (cells; 8 bytes each on disk).
MAX_CELLS = 1_000_000
#: Entries kept in the cache folder (the most recently used).
KEEP = 16
#: Environment variables (by prefix) that change what reading a DEM gives.
_ENV_PREFIXES = ("GDAL_", "GTIFF_", "CPL_", "PROJ_", "OSR_", "ENERGY_PLANNER_")
#: Questions a :class:`StoredCRS` answers without rasterio (attribute names).
_ANSWERED = ("is_geographic", "is_projected", "linear_units", "linear_units_factor")


class StoredCRS:
    """A CRS kept as its WKT and some answers; a rasterio CRS for anything else.

    Parameters
    ----------
    wkt : str
        ``CRS.to_wkt()`` of the CRS as rasterio read it.
    answers : dict
        ``str``, ``repr``, ``epsg`` (``to_epsg()``) and the attributes in
        ``_ANSWERED``, as the rasterio CRS gave them; a missing one is asked of it.

    Examples
    --------
    >>> c = StoredCRS('LOCAL_CS["x"]', {"str": "x", "is_geographic": False})
    >>> str(c), c.is_geographic, c == c, bool(c)
    ('x', False, True, True)
    """

    __slots__ = ("_wkt", "_answers", "_real")

    def __init__(self, wkt: str, answers: dict[str, Any]) -> None:
        self._wkt = wkt
        self._answers = answers
        self._real = None

    @classmethod
    def of(cls, crs: Any) -> StoredCRS:
        """The stored form of a rasterio CRS (its answers asked now)."""
        answers: dict[str, Any] = {"str": str(crs), "repr": repr(crs)}
        for name in _ANSWERED:
            try:
                answers[name] = getattr(crs, name)
            except Exception:  # noqa: BLE001 - asked again (and raised) when used
                pass
        try:
            answers["epsg"] = crs.to_epsg()
        except Exception:  # noqa: BLE001
            pass
        if isinstance(answers.get("linear_units_factor"), tuple):
            answers["linear_units_factor"] = list(answers["linear_units_factor"])
        return cls(crs.to_wkt(), answers)

    def real(self) -> Any:
        """The rasterio CRS (built once, from the WKT)."""
        if self._real is None:
            from rasterio.crs import CRS

            self._real = CRS.from_wkt(self._wkt)
        return self._real

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__") or name in StoredCRS.__slots__:
            raise AttributeError(name)
        if name in _ANSWERED and name in self._answers:
            v = self._answers[name]
            return tuple(v) if isinstance(v, list) else v
        return getattr(self.real(), name)

    def to_wkt(self, *args: Any, **kwargs: Any) -> str:
        """The WKT (as ``CRS.to_wkt``; other dialects or versions ask rasterio)."""
        return self.real().to_wkt(*args, **kwargs) if args or kwargs else self._wkt

    def to_epsg(self, *args: Any, **kwargs: Any) -> int | None:
        """The EPSG code (as ``CRS.to_epsg``)."""
        if args or kwargs or "epsg" not in self._answers:
            return self.real().to_epsg(*args, **kwargs)
        return self._answers["epsg"]

    def __str__(self) -> str:
        return self._answers["str"] if "str" in self._answers else str(self.real())

    def __repr__(self) -> str:
        return self._answers["repr"] if "repr" in self._answers else repr(self.real())

    def __bool__(self) -> bool:
        return bool(self._wkt)

    def __hash__(self) -> int:
        return hash(self._wkt)  # as rasterio's: hash(self.to_wkt())

    def __eq__(self, other: object) -> bool:
        if other is self or (isinstance(other, StoredCRS) and other._wkt == self._wkt):
            return True
        if other is None:  # as rasterio's: no CRS equals a CRS
            return False
        return self.real() == (other.real() if isinstance(other, StoredCRS) else other)

    def __ne__(self, other: object) -> bool:
        return not self == other

    def __reduce__(self) -> tuple[Any, ...]:
        return (StoredCRS, (self._wkt, self._answers))


def _stat(path: Path) -> str:
    st = os.stat(path)
    return f"{st.st_size}:{st.st_mtime_ns}:{st.st_ctime_ns}:{st.st_ino}:{st.st_dev}"


def _stamp(p: Path, band: int | None) -> str | None:
    """What the entry of DEM ``p`` depends on, as text; None if it cannot be kept."""
    name = str(p)
    if name.startswith("/vsi") or "://" in name:
        return None
    try:
        real = p.resolve(strict=True)
        if not real.is_file():
            return None
        parts = [str(real), repr(band), _stat(real)]
        stem = real.stem.lower()
        with os.scandir(real.parent) as entries:  # sidecars GDAL reads with the file
            beside = sorted(e.name for e in entries if e.name.lower().startswith(stem))
        parts += [f"{b}={_stat(real.parent / b)}" for b in beside]
        here = Path(__file__).parent
        parts += [f"{f.name}={_stat(f)}" for f in sorted(here.glob("*.py"))]
    except OSError:
        return None
    parts += sorted(f"{k}={v}" for k, v in os.environ.items() if k.startswith(_ENV_PREFIXES))
    import importlib.util

    spec = importlib.util.find_spec("rasterio")
    if spec is None or spec.origin is None:
        return None
    try:
        parts.append(f"rasterio={spec.origin}:{_stat(Path(spec.origin))}")
    except OSError:
        return None
    return "\n".join(parts)


def _entry(key: str) -> tuple[Path, Path]:
    from energy_planner.model._codegen import cache_dir

    d = cache_dir()
    return d / f"dem_{key}.npy", d / f"dem_{key}.json"


def _read_back(key: str, p: Path) -> Any:
    """The Terrain of entry ``key``, or None when it is missing or unreadable."""
    from affine import Affine

    from energy_planner.terrain.dem import Terrain

    try:
        npy, meta_path = _entry(key)
        meta = json.loads(meta_path.read_text())
        z = np.load(npy, allow_pickle=False)
    except (OSError, ValueError):
        return None
    if z.dtype != np.float64 or list(z.shape) != meta.get("shape"):
        return None
    try:
        os.utime(meta_path)  # recently used: kept by the pruning
    except OSError:
        pass
    crs = StoredCRS(meta["wkt"], meta["answers"])
    return Terrain(
        z,
        Affine(*meta["transform"]),
        crs,
        source_crs=crs,
        source_transform=Affine(*meta["source_transform"]),
        source_shape=tuple(meta["source_shape"]),
        path=p,
    )


def _keep(key: str, terrain: Any) -> bool:
    """Write the entry ``key`` of ``terrain`` (an optimisation only: errors are ignored)."""
    from energy_planner.io import atomic_path

    meta = {
        "shape": list(terrain.elevation.shape),
        "transform": list(terrain.transform)[:6],
        "source_transform": list(terrain.source_transform)[:6],
        "source_shape": list(terrain.source_shape),
        "wkt": terrain.crs.to_wkt(),
        "answers": StoredCRS.of(terrain.crs)._answers,
    }
    try:
        npy, meta_path = _entry(key)
        with atomic_path(npy) as tmp, open(tmp, "wb") as f:
            np.save(f, np.ascontiguousarray(terrain.elevation, dtype=np.float64))
        with atomic_path(meta_path) as tmp:
            Path(tmp).write_text(json.dumps(meta))
        _prune(meta_path.parent)
    except (OSError, TypeError, ValueError):
        return False
    return True


def _prune(folder: Path, keep: int = KEEP) -> None:
    """Delete the entries of ``folder`` beyond the ``keep`` most recently used."""
    entries = []
    for f in folder.glob("dem_*.json"):
        try:
            entries.append((f.stat().st_mtime_ns, f))
        except OSError:
            continue
    entries.sort(reverse=True)
    for _, f in entries[keep:]:
        for g in (f, f.with_suffix(".npy")):
            try:
                g.unlink()
            except OSError:
                pass


def read_stored(path: str | Path, band: int | None = None) -> tuple[Any, str | None]:
    """The Terrain ``load_dem(path, band=band)`` gave before, and the entry's key.

    Returns ``(terrain, key)``: ``terrain`` the same
    :class:`~energy_planner.terrain.dem.Terrain` (elevation, gradient, transforms,
    shape, path) with a :class:`StoredCRS` as its ``crs`` and ``source_crs``, or None
    when there is no entry (then :func:`keep_stored` with ``key`` after the read keeps
    one); ``key`` None when this DEM cannot be kept (not a local file).
    """
    from energy_planner.maps import resolve

    p = resolve(path)
    stamp = _stamp(p, band)
    if stamp is None:
        return None, None
    key = hashlib.sha256(stamp.encode()).hexdigest()[:32]
    return _read_back(key, p), key


def keep_stored(key: str | None, terrain: Any) -> bool:
    """Keep ``terrain`` (just read by ``load_dem``) as entry ``key`` if it may be kept.

    Only a DEM on its own metric grid (no reprojection) with a CRS and at most
    :data:`MAX_CELLS` cells; the caller keeps only reads that gave no warning. Returns
    whether an entry was written.
    """
    if (
        key is None
        or terrain.native is not None
        or terrain.crs is None
        or terrain.crs != terrain.source_crs
        or terrain.elevation.size > MAX_CELLS
    ):
        return False
    return _keep(key, terrain)
