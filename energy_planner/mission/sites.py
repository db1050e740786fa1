r"""Mission sites: read from CSV or GeoJSON with their CRS, placed on the DEM's cells.

CSV
    A header with ``x, y`` (the DEM's CRS, like waypoint files; another CRS with
    ``crs=``), optional ``yaw_deg`` (ignored by the tour: headings are free at sites) and
    optional ``name``, and optional ``arrive_after`` / ``arrive_before``.
GeoJSON
    Points (a FeatureCollection of Point features, or a MultiPoint), RFC 7946 longitude,
    latitude unless the file declares a ``crs``; ``properties.name`` names a site,
    ``properties.arrive_after`` / ``properties.arrive_before`` give its window.

Arrival windows
    ``arrive_after`` and ``arrive_before`` are seconds from the mission's start (an empty
    cell or a missing property: no bound). A robot that arrives before ``arrive_after``
    waits there until it opens; it must arrive by ``arrive_before``. On the first site
    (the start) ``arrive_after`` is the time of departure.

Examples
--------
>>> import tempfile, pathlib
>>> from energy_planner.terrain import Terrain
>>> t = Terrain.from_array(np.zeros((10, 10)), resolution=1.0, origin=(0, 0),
...                        crs="EPSG:32631")
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> _ = (d / "s.csv").write_text("x,y,name\n1.2,8.9,base\n7.4,2.1,well\n")
>>> s = read_sites(d / "s.csv", t)
>>> s.names, s.on_cells(t).xy.tolist()
(['base', 'well'], [[1.5, 8.5], [7.5, 2.5]])
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.errors import InvalidStateError, WaypointError

__all__ = ["Sites", "WINDOW_KEYS", "read_sites", "site_windows"]


@dataclass(frozen=True)
class Sites:
    """Named sites in the working CRS.

    Attributes
    ----------
    xy : ndarray, shape (n, 2)
        Working-CRS coordinates, metres.
    names : list of str
        One name per site.
    moved_m : ndarray, shape (n,)
        How far :meth:`on_cells` moved each site (0 as read).
    windows : ndarray, shape (n, 2), optional
        Arrival window of each site, ``(arrive_after, arrive_before)`` in seconds from the
        mission's start, NaN where open (None: no site has one).
    """

    xy: np.ndarray
    names: list[str]
    moved_m: np.ndarray | None = None
    windows: np.ndarray | None = None

    def __len__(self) -> int:
        return int(self.xy.shape[0])

    def cells(self, terrain) -> np.ndarray:
        """``(row, col)`` of each site's cell; an error names a site off the map."""
        x0, y0, dx, dy = terrain.grid
        rows, cols = terrain.shape
        c = np.floor((self.xy[:, 0] - x0) / dx + 0.5).astype(int)
        r = np.floor((self.xy[:, 1] - y0) / dy + 0.5).astype(int)
        for k in range(len(self)):
            if not (0 <= r[k] < rows and 0 <= c[k] < cols):
                from energy_planner.errors import extent_text

                raise InvalidStateError(
                    f"site {self.names[k]!r} at {self.xy[k].tolist()} (working CRS) is "
                    f"outside the map, which covers "
                    f"{extent_text(terrain.source_bounds, terrain.source_crs)}",
                    endpoint="site", value=self.names[k], limit="map",
                )  # fmt: skip
        return np.column_stack([r, c])

    def on_cells(self, terrain) -> Sites:
        """The sites moved to the centres of their cells (where the searches stand)."""
        x0, y0, dx, dy = terrain.grid
        rc = self.cells(terrain)
        xy = np.column_stack([x0 + rc[:, 1] * dx, y0 + rc[:, 0] * dy])
        return Sites(xy, list(self.names), np.hypot(*(xy - self.xy).T), self.windows)

    def with_windows(self, windows: Any, source: str = "windows") -> Sites:
        """These sites with arrival windows (:func:`site_windows`; None: as they are)."""
        if windows is None:
            return self
        return replace(self, windows=site_windows(windows, self.names, source))

    def to_dicts(self) -> list[dict[str, Any]]:
        """Name, working coordinates, the distance moved onto the cell (and window), per site."""
        moved = self.moved_m if self.moved_m is not None else np.zeros(len(self))
        out = [{"name": n, "x": float(p[0]), "y": float(p[1]), "moved_m": float(m)}
               for n, p, m in zip(self.names, self.xy, moved, strict=True)]  # fmt: skip
        if self.windows is not None:
            for d, (lo, hi) in zip(out, self.windows, strict=True):
                d["arrive_after_s"] = None if math.isnan(lo) else float(lo)
                d["arrive_before_s"] = None if math.isnan(hi) else float(hi)
        return out


#: The columns (CSV) and properties (GeoJSON) of a site's arrival window, seconds from start.
WINDOW_KEYS = ("arrive_after", "arrive_before")


def _bound(value: Any, where: str, key: str) -> float:
    """One bound of a window: seconds >= 0, or NaN where empty."""
    if value is None or (isinstance(value, str) and not value.strip()):
        return math.nan
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
        ok = False
    else:
        ok = math.isfinite(v) and v >= 0
    if not ok:
        raise WaypointError(
            f"{where}: {key}={value!r} is not a time; expected seconds from the mission's "
            "start (a number >= 0, or empty for no bound)", value=value,
            expected=f"{key} in seconds >= 0",
        )  # fmt: skip
    return v


def site_windows(windows: Any, names: list[str], source: str = "windows") -> np.ndarray | None:
    """Arrival windows as an ``(n, 2)`` array of ``(after, before)`` seconds, NaN where open.

    ``windows``: a mapping from site name to ``(after, before)`` (either None: open), or
    an array-like of one pair per site. An unknown name, a bound that is not a number of
    seconds >= 0, or ``after > before`` is an error naming the site. None if no site has
    a bound.

    Examples
    --------
    >>> site_windows({"well": (None, 60)}, ["base", "well"]).tolist()
    [[nan, nan], [nan, 60.0]]
    """
    n = len(names)
    out = np.full((n, 2), math.nan)
    if isinstance(windows, dict):
        unknown = sorted(set(windows) - set(names), key=str)
        if unknown:
            raise WaypointError(
                f"{source}: no site named {unknown[0]!r}; the sites are {names}",
                value=unknown[0], expected="a site's name",
            )  # fmt: skip
        pairs = [windows.get(name, (None, None)) for name in names]
    else:
        pairs = list(windows)
        if len(pairs) != n:
            raise WaypointError(
                f"{source}: {len(pairs)} window(s) for {n} sites",
                value=len(pairs), expected=f"{n} (after, before) pairs",
            )  # fmt: skip
    for k, pair in enumerate(pairs):
        pair = (None, None) if pair is None else tuple(pair)
        if len(pair) != 2:
            raise WaypointError(f"{source}: site {names[k]!r}: {pair!r} is not (after, before)",
                                value=pair, expected="(after, before)")  # fmt: skip
        where = f"{source}, site {names[k]!r}"
        out[k] = [_bound(v, where, key) for v, key in zip(pair, WINDOW_KEYS, strict=True)]
        if out[k, 0] > out[k, 1]:
            raise WaypointError(
                f"{where}: the window opens at {out[k, 0]:g} s after it closes "
                f"({out[k, 1]:g} s); expected arrive_after <= arrive_before",
                value=pair, expected="arrive_after <= arrive_before",
            )  # fmt: skip
    return out if np.isfinite(out).any() else None


def _csv_sites(p: Path) -> tuple[np.ndarray, list[str], list[tuple[Any, Any]]]:
    try:
        rows = list(csv.DictReader(
            line for line in p.read_text().splitlines() if line.strip() and line[0] != "#"
        ))  # fmt: skip
    except (OSError, UnicodeDecodeError) as exc:
        raise WaypointError(f"cannot read sites file {str(p)!r}: {exc}", path=str(p)) from exc
    if not rows or not {"x", "y"} <= set(rows[0]):
        raise WaypointError(
            f"sites file {str(p)!r} needs a header with columns x,y[,yaw_deg][,name]"
            "[,arrive_after][,arrive_before]", path=str(p),
            expected="x,y[,yaw_deg][,name][,arrive_after][,arrive_before]",
        )  # fmt: skip
    xy, names, windows = [], [], []
    for k, row in enumerate(rows):
        try:
            x, y = float(row["x"]), float(row["y"])
        except (TypeError, ValueError) as exc:
            raise WaypointError(
                f"sites file {str(p)!r}, row {k + 1}: x={row.get('x')!r}, y={row.get('y')!r} "
                "are not numbers", path=str(p), value=k + 1,
            ) from exc  # fmt: skip
        if not (math.isfinite(x) and math.isfinite(y)):
            raise WaypointError(f"sites file {str(p)!r}, row {k + 1}: non-finite coordinate",
                                path=str(p), value=k + 1)  # fmt: skip
        xy.append((x, y))
        names.append((row.get("name") or "").strip() or f"site{k}")
        windows.append(tuple(row.get(key) for key in WINDOW_KEYS))
    return np.asarray(xy, dtype=float), names, windows


def _geojson_properties(p: Path, n: int) -> tuple[list[str], list[tuple[Any, Any]]]:
    """Each point's name and window (``properties``).

    Defaults where the features are not one point each (a MultiPoint).
    """
    data = json.loads(p.read_text())
    feats = data.get("features", []) if isinstance(data, dict) else []
    props = [f.get("properties") or {} for f in feats if isinstance(f, dict)]
    if len(props) != n:
        return [f"site{k}" for k in range(n)], [(None, None)] * n
    names = [str(q.get("name") or f"site{k}") for k, q in enumerate(props)]
    return names, [tuple(q.get(key) for key in WINDOW_KEYS) for q in props]


def read_sites(path: str | Path, terrain, crs: Any = None) -> Sites:
    """Read sites from a CSV or GeoJSON file into the terrain's working CRS.

    Parameters
    ----------
    path : str or Path
        CSV (``x,y[,yaw_deg][,name][,arrive_after][,arrive_before]``) or GeoJSON
        points (properties ``name``, ``arrive_after``, ``arrive_before``).
    terrain : Terrain
        The map; coordinates are converted to its working CRS.
    crs : optional
        The CRS of a CSV's coordinates (default: the DEM's own). GeoJSON files carry
        theirs (RFC 7946 lon/lat unless declared).

    Returns
    -------
    Sites

    Raises
    ------
    WaypointError
        Unreadable file, missing columns, fewer than two sites, a window bound that is
        not seconds >= 0 or that opens after it closes.
    """
    from energy_planner.io.geojson import reproject_xy
    from energy_planner.maps import resolve

    p = resolve(path)  # a file, or a bundled file's name ("hill_sites")
    if not p.is_file():
        raise WaypointError(f"sites file {str(p)!r} does not exist", path=str(p))
    if p.suffix.lower() in (".geojson", ".json"):
        from energy_planner.io.geojson import read_geometries

        geoms = read_geometries(p, what="sites", types=("Point", "MultiPoint"))
        pts = [q for g in geoms for q in getattr(g, "geoms", [g])]
        xy = np.array([[q.x, q.y] for q in pts], dtype=float)
        names, windows = _geojson_properties(p, len(xy))
        src = geoms.crs
    else:
        xy, names, windows = _csv_sites(p)
        src = crs
    if len(xy) < 2:
        raise WaypointError(f"sites file {str(p)!r} has {len(xy)} site(s); a mission needs 2+",
                            path=str(p), value=len(xy))  # fmt: skip
    if src is not None:
        x, y = reproject_xy(src, terrain.crs, xy[:, 0], xy[:, 1])
    else:
        x, y = terrain.to_work(xy[:, 0], xy[:, 1])
    return Sites(np.column_stack([np.atleast_1d(x), np.atleast_1d(y)]), names,
                 windows=site_windows(windows, names, f"sites file {str(p)!r}"))  # fmt: skip
