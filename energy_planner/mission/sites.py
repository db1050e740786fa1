r"""Mission sites: read from CSV or GeoJSON with their CRS, placed on the DEM's cells.

CSV
    A header with ``x, y`` (the DEM's CRS, like waypoint files; another CRS with
    ``crs=``), optional ``yaw_deg`` (ignored by the tour: headings are free at sites) and
    optional ``name``.
GeoJSON
    Points (a FeatureCollection of Point features, or a MultiPoint), RFC 7946 longitude,
    latitude unless the file declares a ``crs``; ``properties.name`` names a site.

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
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.errors import InvalidStateError, WaypointError

__all__ = ["Sites", "read_sites"]


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
    """

    xy: np.ndarray
    names: list[str]
    moved_m: np.ndarray | None = None

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
        return Sites(xy, list(self.names), np.hypot(*(xy - self.xy).T))

    def to_dicts(self) -> list[dict[str, Any]]:
        """Name, working coordinates and the distance moved onto the cell, per site."""
        moved = self.moved_m if self.moved_m is not None else np.zeros(len(self))
        return [{"name": n, "x": float(p[0]), "y": float(p[1]), "moved_m": float(m)}
                for n, p, m in zip(self.names, self.xy, moved, strict=True)]  # fmt: skip


def _csv_sites(p: Path) -> tuple[np.ndarray, list[str]]:
    try:
        rows = list(csv.DictReader(
            line for line in p.read_text().splitlines() if line.strip() and line[0] != "#"
        ))  # fmt: skip
    except (OSError, UnicodeDecodeError) as exc:
        raise WaypointError(f"cannot read sites file {str(p)!r}: {exc}", path=str(p)) from exc
    if not rows or not {"x", "y"} <= set(rows[0]):
        raise WaypointError(
            f"sites file {str(p)!r} needs a header with columns x,y[,yaw_deg][,name]",
            path=str(p), expected="x,y[,yaw_deg][,name]",
        )  # fmt: skip
    xy, names = [], []
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
    return np.asarray(xy, dtype=float), names


def _geojson_names(p: Path, n: int) -> list[str]:
    data = json.loads(p.read_text())
    feats = data.get("features", []) if isinstance(data, dict) else []
    names = [str((f.get("properties") or {}).get("name") or f"site{k}")
             for k, f in enumerate(feats) if isinstance(f, dict)]  # fmt: skip
    return names if len(names) == n else [f"site{k}" for k in range(n)]


def read_sites(path: str | Path, terrain, crs: Any = None) -> Sites:
    """Read sites from a CSV or GeoJSON file into the terrain's working CRS.

    Parameters
    ----------
    path : str or Path
        CSV (``x,y[,yaw_deg][,name]``) or GeoJSON points.
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
        Unreadable file, missing columns, fewer than two sites.
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
        names = _geojson_names(p, len(xy))
        src = geoms.crs
    else:
        xy, names = _csv_sites(p)
        src = crs
    if len(xy) < 2:
        raise WaypointError(f"sites file {str(p)!r} has {len(xy)} site(s); a mission needs 2+",
                            path=str(p), value=len(xy))  # fmt: skip
    if src is not None:
        x, y = reproject_xy(src, terrain.crs, xy[:, 0], xy[:, 1])
    else:
        x, y = terrain.to_work(xy[:, 0], xy[:, 1])
    return Sites(np.column_stack([np.atleast_1d(x), np.atleast_1d(y)]), names)
