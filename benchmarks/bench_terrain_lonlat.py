"""Benchmark: loading a lon/lat DEM (native geodesic Horn + UTM working grid) vs a metric one.

``load_dem`` on a longitude/latitude DEM runs Horn on the DEM's own grid with each row's
geodesic cell size, warps the elevation to UTM and carries the gradient to the working
cell centres (:mod:`energy_planner.terrain.native`). The baseline is the same elevations
on a metric (UTM) grid of the same shape, which ``load_dem`` reads as they are and runs
Horn on once: the ratio is the cost of the geographic path.

Prints one row per method: CPU time (best of ``--repeat``, methods run round robin; CPU
time because the machine is shared), cells per CPU second, peak memory allocated during
the call per working cell (tracemalloc) and the ratio to the baseline.

Run: ``python benchmarks/bench_terrain_lonlat.py [--size 3000] [--repeat 3]``
(``--size 1000`` finishes in about a minute).
"""

from __future__ import annotations

import argparse
import gc
import os
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np


def make_dem(n: int, seed: int = 0) -> np.ndarray:
    """Random-walk hills (float32, metres): rough at the cell scale, nothing flat."""
    rng = np.random.default_rng(seed)
    z = np.cumsum(rng.normal(size=(n, n)), axis=0) + np.cumsum(rng.normal(size=(n, n)), axis=1)
    return (z * 3.0 + 500.0).astype("float32")


def write(path: Path, z: np.ndarray, crs: str, transform) -> Path:
    import rasterio

    n = z.shape[0]
    with rasterio.open(
        path, "w", driver="GTiff", width=n, height=n, count=1, dtype="float32",
        crs=crs, transform=transform,
    ) as dst:  # fmt: skip
        dst.write(z, 1)
    return path


def measure(path: Path) -> tuple[float, float, int]:
    """CPU seconds, peak bytes and working cells of ``load_dem(path)`` + slope + aspect."""
    from energy_planner.terrain import load_dem

    gc.collect()
    tracemalloc.start()
    t0 = time.process_time()
    t = load_dem(path)
    _ = t.native_grid.slope, t.native_grid.aspect_deg
    cpu = time.process_time() - t0
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return cpu, peak, t.shape[0] * t.shape[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=3000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    from rasterio.transform import from_origin

    n = args.size
    z = make_dem(n)
    with tempfile.TemporaryDirectory() as tmp:
        cases = {
            "metric UTM DEM (baseline)": write(
                Path(tmp) / "utm.tif", z, "EPSG:32616", from_origin(740_000, 4_070_000, 83, 83)
            ),
            "lon/lat DEM, native Horn": write(
                Path(tmp) / "ll.tif", z, "EPSG:4326", from_origin(-84.4, 36.7, 1 / 1200, 1 / 1200)
            ),
        }
        best: dict[str, tuple[float, float, int]] = {}
        for _ in range(args.repeat):
            for name, path in cases.items():
                cpu, peak, cells = measure(path)
                if name not in best or cpu < best[name][0]:
                    best[name] = (cpu, peak, cells)
    base = best["metric UTM DEM (baseline)"][0]
    print(f"{n} x {n} float32 DEM, best of {args.repeat}, load average {os.getloadavg()[0]:.1f}")
    print("| method | CPU (s) | working cells | Mcells/CPU s | peak B/cell | CPU vs baseline |")
    print("|---|---|---|---|---|---|")
    for name, (cpu, peak, cells) in best.items():
        print(
            f"| {name} | {cpu:.2f} | {cells:,} | {cells / cpu / 1e6:.2f} | "
            f"{peak / cells:.1f} | {cpu / base:.2f}x |"
        )


if __name__ == "__main__":
    main()
