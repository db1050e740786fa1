"""Time and peak memory of ``energy-map`` on the bundled Jacksboro DEM and a large DEM.

Usage::

    python benchmarks/bench_energy_map.py [--size 4096] [--headings 16] [--chunk 512]
        [--skip-large] [--workdir /tmp/bench_energy_map]

Every run is a fresh Python process (``python -m energy_planner.cli energy-map ...``
through :func:`run_one`), so its peak resident memory (``os.wait4``'s ``ru_maxrss``) is its
own; the kernel is compiled (cached on disk) by a warm-up run first, so the times are
the map's, not numba's. Rows, side by side:

- ``jacksboro``: the bundled lon/lat DEM (loaded and warped to UTM: the *terrain* path);
- ``SIZE^2 terrain`` (baseline): a synthetic metric DEM of SIZE x SIZE cells loaded whole
  (``load_dem``) and mapped from the in-memory Terrain;
- ``SIZE^2 windowed``: the same DEM read by windows of rows (the default for a metric DEM);
- ``SIZE^2 dask``: the same with dask arrays (``--dask``, threads of this machine).

Columns: wall time, peak RSS, both as ratios to the baseline, cells/s, and the largest
difference between each large map and the baseline's (they must be equal). The machine
load (``uptime``) is printed next to the table: on a shared machine, times are only
comparable within one table.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def make_dem(path: Path, size: int, res: float = 2.0) -> Path:
    """A SIZE x SIZE float32 DEM of rolling hills (EPSG:32631, ``res`` m cells), by rows."""
    import rasterio
    from affine import Affine

    if path.exists():
        return path
    prof = dict(
        driver="GTiff", width=size, height=size, count=1, dtype="float32", crs="EPSG:32631",
        transform=Affine(res, 0, 500000.0, 0, -res, 5000000.0 + res * size), nodata=-9999.0,
        tiled=True, blockxsize=256, blockysize=256, compress="deflate",
    )  # fmt: skip
    x = np.arange(size) * res
    with rasterio.open(path, "w", **prof) as dst:
        step = 512
        for r0 in range(0, size, step):
            y = (np.arange(r0, min(size, r0 + step)) * res)[:, None]
            z = 40 * np.sin(x / 310.0) * np.cos(y / 270.0) + 8 * np.sin((x + 2 * y) / 53.0)
            z = z + 0.02 * x
            dst.write(z.astype("float32"), 1, window=((r0, r0 + len(y)), (0, size)))
    return path


_TERRAIN_SCRIPT = """
import json, sys, time
from energy_planner.energymap import energy_map
from energy_planner.terrain import load_dem
t0 = time.perf_counter()
terrain = load_dem(sys.argv[1])
res = energy_map(terrain, sys.argv[2], headings=int(sys.argv[3]), progress=False)
print(json.dumps({"seconds": time.perf_counter() - t0, "mode": res.mode}))
"""


def run_one(args: list[str], terrain: bool = False) -> dict:
    """Run one map in a fresh process; wall seconds, peak RSS (MB), its JSON."""
    if terrain:
        cmd = [sys.executable, "-c", _TERRAIN_SCRIPT, *args]
    else:
        cmd = [str(Path(sys.executable).with_name("energy-planner")), "energy-map", *args, "--json"]
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, cwd=ROOT)
    out = p.stdout.read()  # type: ignore[union-attr]
    _, status, usage = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    if status != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed with status {status}")
    doc = json.loads(out)
    return {"wall_s": wall, "rss_mb": usage.ru_maxrss / 1024.0, "doc": doc}


def max_diff(a: Path, b: Path) -> float:
    """Largest relative difference between two maps (finite cells), by windows."""
    import rasterio

    worst = 0.0
    with rasterio.open(a) as sa, rasterio.open(b) as sb:
        for _, win in sa.block_windows(1):
            x = sa.read(window=win).astype(float)
            y = sb.read(window=win).astype(float)
            if not np.array_equal(np.isnan(x), np.isnan(y)):
                return math.inf
            ok = np.isfinite(x) & np.isfinite(y)
            if ok.any():
                d = np.abs(x[ok] - y[ok]) / np.maximum(np.abs(y[ok]), 1e-9)
                worst = max(worst, float(d.max()))
    return worst


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=4096)
    ap.add_argument("--headings", type=int, default=16)
    ap.add_argument("--chunk", type=int, default=512)
    ap.add_argument("--skip-large", action="store_true")
    ap.add_argument("--workdir", type=Path, default=Path("/tmp/bench_energy_map"))
    a = ap.parse_args()
    a.workdir.mkdir(parents=True, exist_ok=True)
    h = str(a.headings)
    jack = ROOT / "maps" / "jacksboro_fault_dem.tif"
    # warm-up: compile (or load) the kernel once
    run_one([str(jack), "--out", str(a.workdir / "warm.tif"), "--headings", h])
    rows = []
    r = run_one([str(jack), "--out", str(a.workdir / "jack.tif"), "--headings", h])
    rows.append(("jacksboro (lon/lat -> UTM)", r, None, r["doc"]["shape"]))
    if not a.skip_large:
        dem = make_dem(a.workdir / f"dem_{a.size}.tif", a.size)
        base_out = a.workdir / "terrain.tif"
        base = run_one([str(dem), str(base_out), h], terrain=True)
        shape = [a.size, a.size]
        rows.append((f"{a.size}^2 terrain (baseline)", base, 0.0, shape))
        for name, extra in [("windowed", []), ("dask", ["--dask", "--chunk", str(a.chunk)])]:
            out = a.workdir / f"{name}.tif"
            r = run_one([str(dem), "--out", str(out), "--headings", h, *extra])
            rows.append((f"{a.size}^2 {name}", r, max_diff(out, base_out), shape))
    load = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    print(f"energy-map, {a.headings} headings; machine: {os.cpu_count()} cores; {load}")
    print()
    print("| run | cells | wall s | peak RSS MB | time / baseline | RSS / baseline | "
          "cells/s | max rel. diff vs baseline |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    base_row = next((r for r in rows if "baseline" in r[0]), None)
    for name, r, diff, shape in rows:
        cells = shape[0] * shape[1]
        tr = f"{r['wall_s'] / base_row[1]['wall_s']:.2f}" if base_row else "-"
        mr = f"{r['rss_mb'] / base_row[1]['rss_mb']:.2f}" if base_row else "-"
        d = "-" if diff is None else f"{diff:.1e}"
        print(f"| {name} | {cells:,} | {r['wall_s']:.1f} | {r['rss_mb']:.0f} | {tr} | {mr} | "
              f"{cells / r['wall_s']:,.0f} | {d} |")  # fmt: skip


if __name__ == "__main__":
    main()
