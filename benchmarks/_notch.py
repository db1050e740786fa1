"""A ridge with a narrow notch, for the detour benchmarks (written to a temporary directory).

``notch_dem(extent, cell, path)``: a square of ``extent`` metres (EPSG:32631) at ``cell``
metres: gentle hills (:func:`_hilly.hilly_elevation`, scaled to about 4 degrees) crossed
west-east at mid-height by a ridge 64 m high with 45-degree flanks that runs from the west edge to
3/4 of the width (its east end is a cone, so a route can go round it), cut in the middle
by a notch: a channel 2 m wide whose floor climbs the ridge at about 18 degrees between
walls of about 63 degrees. The elevation is built at 1 m and averaged over each coarser
cell (as a DEM resampled by averaging), so the notch is one fine-resolution feature:
at 1 m its floor is under 30 degrees, at 2 m and coarser the averaging mixes the walls in
and every cell across it is steeper than 30 degrees (``--max-slope 30`` closes it; see
:func:`notch_open`). Start and goal (:func:`endpoints`) face each other across the ridge
on the notch's meridian, 10 % of the extent inside the south and north edges.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

X0, Y0 = 500_000.0, 5_000_000.0
#: ridge half-width at the base, m (its height equals it: 45-degree flanks)
RIDGE = 64.0
#: the ridge runs from the west edge to this fraction of the width
RIDGE_END = 0.75
#: notch: floor half-width (m), floor slope (m/m) and wall slope (m/m)
NOTCH_HALF, NOTCH_FLOOR, NOTCH_WALL = 1.0, 0.33, 2.0


def notch_elevation(extent: int, cell: int = 1, seed: int = 7) -> np.ndarray:
    """Elevation (m, float32), ``extent // cell`` square, row 0 north."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from _hilly import hilly_elevation

    L = int(extent)
    z = hilly_elevation(L, seed).astype(np.float64)
    z *= np.tan(np.radians(4.0)) / np.tan(np.radians(12.0))
    c = np.arange(L) + 0.5
    x = c[None, :]
    y = (L - c)[:, None]  # row 0 north
    w = RIDGE
    yc = 0.5 * L
    xe = RIDGE_END * L
    d = np.hypot(np.maximum(x - xe, 0.0), y - yc)  # distance to the ridge's axis
    ridge = np.maximum(w - d, 0.0)
    xn = 0.5 * L + 0.5
    floor = np.maximum(w * NOTCH_FLOOR / 1.0 - NOTCH_FLOOR * np.abs(y - yc), 0.0)
    walls = NOTCH_WALL * np.maximum(np.abs(x - xn) - NOTCH_HALF, 0.0)
    z += np.minimum(ridge, floor + walls)
    cell = int(cell)
    n = L // cell
    z = z[: n * cell, : n * cell].reshape(n, cell, n, cell).mean(axis=(1, 3))
    return z.astype(np.float32)


def notch_dem(extent: int, cell: int, path: Path, seed: int = 7) -> Path:
    """Write the DEM as a GeoTIFF and return its path."""
    import rasterio
    from rasterio.transform import from_origin

    z = notch_elevation(extent, cell, seed)
    n = z.shape[0]
    with rasterio.open(
        path, "w", driver="GTiff", width=n, height=n, count=1, dtype="float32",
        crs="EPSG:32631", transform=from_origin(X0, Y0 + extent, cell, cell), tiled=True,
        compress="deflate",
    ) as dst:  # fmt: skip
        dst.write(z, 1)
    return Path(path)


def endpoints(extent: int, cell: int) -> tuple[tuple[float, float], tuple[float, float]]:
    """Start (south) and goal (north) cell centres on the notch's meridian."""
    n = extent // cell
    i = int((0.5 * extent) // cell)
    js = int(0.1 * n)
    xc = X0 + (i + 0.5) * cell
    return (xc, Y0 + (js + 0.5) * cell), (xc, Y0 + (n - js - 0.5) * cell)


def keep_out_square(extent: int, side: float = 30.0) -> dict:
    """GeoJSON polygon (EPSG:32631) of a ``side`` metre square centred on the notch."""
    cx, cy = X0 + 0.5 * extent + 0.5, Y0 + 0.5 * extent
    h = 0.5 * side
    ring = [[cx - h, cy - h], [cx + h, cy - h], [cx + h, cy + h], [cx - h, cy + h]]
    ring.append(ring[0])
    return {"type": "Polygon", "coordinates": [ring]}


def notch_open(z: np.ndarray, cell: float, max_slope_deg: float = 30.0) -> bool:
    """Whether the notch is open at ``max_slope_deg``.

    True when the cells no steeper than ``max_slope_deg`` (Horn's slope) connect the two
    endpoints' sides across the ridge west of its east end, i.e. through the notch.
    """
    from scipy.ndimage import label

    from energy_planner.terrain.horn import slope

    s = slope(z.astype(np.float64), (cell, cell))
    ok = np.isfinite(s) & (s <= max_slope_deg)
    n = z.shape[0]
    ok[:, int(0.7 * n) :] = False  # cut the way round the ridge's east end
    lab, _ = label(ok)
    a, b = lab[int(0.9 * n), n // 2], lab[int(0.1 * n), n // 2]
    return bool(a > 0 and a == b)
