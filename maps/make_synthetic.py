"""Write the synthetic maps ``maps/hill.tif``, ``maps/plane.tif`` and ``maps/scenarios.json``.

``hill.tif`` is the scene of the paper's Fig. 1: a hill 20 m high on a 200 m x 200 m grid
at 1 m (EPSG:32631, UTM 31N, south-west corner at E 500000, N 5000000), top at local
(58, 84). Its radial profile is a cone with rounded foot and top,
``z = H r(1 - rho) / (1 - w)`` with ``rho = dist / L(phi)`` and ``r`` the C1 ramp of
:func:`_ramp` (blend ``w = 0.2``), where the footprint radius ``L`` depends on the
direction ``phi`` from the top (a periodic cubic spline through 29 m south, 90 m east,
60 m north, 45 m west). The south face is steep: the straight climb from the start at the
southern foot to the top is 33 degrees on average and up to 47 (steeper than the bundled
model's critical grade, about 20 degrees, where a metre of height is cheapest), while
the flanks towards the east are gentler, so a longer route that climbs near the critical
grade costs less than the direct climb without any slope limit. ``python
maps/make_synthetic.py --check`` prints the numbers (measured with the package's own
Horn slope, a grid shortest path and the bundled model's critical grade).

``plane.tif`` is an inclined plane for analytic checks: slope 10 degrees, rising towards
uphill azimuth psi = 30 degrees counter-clockwise from east (GIS aspect, the downslope
direction clockwise from north, is 240 degrees), 100 m x 100 m at 1 m, same CRS and
corner, ``z = 100 + tan(10 deg) * ((x - x0) cos 30 + (y - y0) sin 30)``, float64.

Run: ``python maps/make_synthetic.py [--check]`` (writes next to this script).
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np

# package data (maps/ at the root links to it)
HERE = Path(__file__).resolve().parents[1] / "energy_planner" / "data" / "maps"
CRS = "EPSG:32631"
X0, Y0 = 500_000.0, 5_000_000.0  # south-west corner of both maps

HILL_HEIGHT = 20.0
HILL_TOP = (58.0, 84.0)  # local metres from the corner
HILL_L = {-90: 29.0, 0: 90.0, 90: 60.0, 180: 45.0}  # footprint radius per direction
HILL_BLEND = 0.2  # rounded foot and top, as a fraction of the radius
HILL_START = (58.0, 46.0)
HILL_GOAL = (58.0, 84.0)

PLANE_SLOPE_DEG = 10.0
PLANE_PSI_DEG = 30.0  # uphill azimuth, CCW from east


def hill_z(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Hill elevation at map coordinates (metres, EPSG:32631)."""
    from scipy.interpolate import CubicSpline

    phis = np.radians([-90, 0, 90, 180, 270])
    radii = [HILL_L[-90], HILL_L[0], HILL_L[90], HILL_L[180], HILL_L[-90]]
    spline = CubicSpline(phis, radii, bc_type="periodic")
    u = x - X0 - HILL_TOP[0]
    v = y - Y0 - HILL_TOP[1]
    phi = np.arctan2(v, u)
    phi = np.where(phi < -np.pi / 2, phi + 2 * np.pi, phi)
    rho = np.minimum(np.hypot(u, v) / spline(phi), 1.0)
    return HILL_HEIGHT * _ramp(1.0 - rho, HILL_BLEND) / (1.0 - HILL_BLEND)


def _ramp(u: np.ndarray, w: float) -> np.ndarray:
    """A cone profile with rounded ends; C1, peak slope 1.

    ``u - w/2`` on ``[w, 1 - w]``, parabolas joining 0 (slope 0) at ``u = 0`` and the
    top (slope 0) at ``u = 1``.
    """
    u = np.clip(u, 0.0, 1.0)
    return np.where(
        u < w, u**2 / (2 * w), np.where(u > 1 - w, 1 - w - (1 - u) ** 2 / (2 * w), u - w / 2)
    )


def plane_z(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Plane elevation at map coordinates."""
    g = math.tan(math.radians(PLANE_SLOPE_DEG))
    p = math.radians(PLANE_PSI_DEG)
    return 100.0 + g * ((x - X0) * math.cos(p) + (y - Y0) * math.sin(p))


def write(path: Path, func, size: float, dtype: str) -> None:
    import rasterio
    from rasterio.transform import from_origin

    n = int(size)
    xc = X0 + np.arange(n) + 0.5
    yc = Y0 + size - np.arange(n) - 0.5  # row 0 is north
    xx, yy = np.meshgrid(xc, yc)
    z = func(xx, yy).astype(dtype)
    profile = dict(
        driver="GTiff",
        width=n,
        height=n,
        count=1,
        dtype=dtype,
        crs=CRS,
        transform=from_origin(X0, Y0 + size, 1.0, 1.0),
        compress="deflate",
        predictor=3,
    )
    with rasterio.open(path, "w", **profile) as dst:
        dst.write(z, 1)
    print(f"wrote {path} ({n} x {n}, {dtype})")


def scenarios() -> dict:
    return {
        "hill": {
            "map": "hill",
            "crs": CRS,
            "start": [X0 + HILL_START[0], Y0 + HILL_START[1]],
            "goal": [X0 + HILL_GOAL[0], Y0 + HILL_GOAL[1]],
            "description": (
                "Paper Fig. 1: from the southern foot to the top of a 20 m hill; the "
                "straight climb averages 33 deg (up to 47), steeper than the critical grade "
                "where a metre of height is cheapest; a longer route over the gentler "
                "south-eastern flank climbs near it and costs less."
            ),
        },
        "hill_crossing": {
            "map": "hill",
            "crs": CRS,
            "start": [X0 + 30.0, Y0 + 10.0],
            "goal": [X0 + 30.0, Y0 + 190.0],
            "description": (
                "Crossing the hill's western flank from south to north: the straight line "
                "climbs over the flank; routes differ in how much they climb and how long "
                "they side-hill."
            ),
        },
        "plane": {
            "map": "plane",
            "crs": CRS,
            "start": [X0 + 20.0, Y0 + 20.0],
            "goal": [X0 + 80.0, Y0 + 80.0],
            "description": (
                "Constant 10 deg plane rising towards psi = 30 deg CCW from east (GIS "
                "aspect 240 deg); diagonal crossing for analytic checks."
            ),
        },
    }


def check() -> None:
    """Print the numbers the hill was designed for."""
    from scipy import ndimage
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    from energy_planner.terrain import load_dem

    t = load_dem(HERE / "hill.tif")
    sc = scenarios()["hill"]
    (sx, sy), (gx, gy) = sc["start"], sc["goal"]
    n = 400
    s = t.sample(np.linspace(sx, gx, n), np.linspace(sy, gy, n))
    d = np.degrees(s.slope)
    print(
        f"direct climb: {math.dist((sx, sy), (gx, gy)):.1f} m, rise "
        f"{s.elevation[-1] - s.elevation[0]:.2f} m, max slope {d.max():.2f} deg, "
        f"{(d >= 20).mean():.0%} of it at >= 20 deg"
    )
    slope = np.degrees(t.slope)
    x0, y0, dx, dy = t.grid

    def rc(x, y):
        return int(round((y - y0) / dy)), int(round((x - x0) / dx))

    from energy_planner.energy.grade import critical_grade
    from energy_planner.model import EnergyModel

    cg = critical_grade(EnergyModel.default())
    print(f"bundled model's critical grade: {cg['slope_deg']:.1f} deg ({cg['method']})")
    for limit in (30.0, 25.0):
        ok = slope <= limit
        lab, _ = ndimage.label(ok, structure=np.ones((3, 3)))
        rows, cols = ok.shape
        idx = np.arange(rows * cols).reshape(rows, cols)
        ii, jj, ww = [], [], []
        for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
            a = idx[: rows - dr, max(0, -dc) : cols - max(0, dc)].ravel()
            b = idx[dr:, max(0, dc) : cols - max(0, -dc) or None].ravel()
            m = ok.ravel()[a] & ok.ravel()[b]
            ii.append(a[m])
            jj.append(b[m])
            ww.append(np.full(int(m.sum()), math.hypot(dr, dc)))
        g = coo_matrix(
            (np.concatenate(ww), (np.concatenate(ii), np.concatenate(jj))),
            shape=(rows * cols,) * 2,
        ).tocsr()
        dist = dijkstra(g, directed=False, indices=idx[rc(sx, sy)])
        print(
            f"shortest route on cells <= {limit:g} deg: {dist[idx[rc(gx, gy)]]:.1f} m "
            f"(connected: {lab[rc(sx, sy)] == lab[rc(gx, gy)]})"
        )


def main(argv: list[str]) -> None:
    write(HERE / "hill.tif", hill_z, 200.0, "float32")
    write(HERE / "plane.tif", plane_z, 100.0, "float64")
    (HERE / "scenarios.json").write_text(json.dumps(scenarios(), indent=2) + "\n")
    print(f"wrote {HERE / 'scenarios.json'}")
    if "--check" in argv:
        check()


if __name__ == "__main__":
    main(sys.argv[1:])
