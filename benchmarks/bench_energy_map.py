"""Time and peak memory of ``energy-map`` on the bundled Jacksboro DEM and a large DEM.

Usage::

    python benchmarks/bench_energy_map.py --kernel [--sizes 1024 2048 4096] [--headings 16]
    python benchmarks/bench_energy_map.py [--size 4096] [--headings 16] [--chunk 512]
        [--skip-large] [--workdir /tmp/bench_energy_map]

``--kernel``: the map's computation alone (no GeoTIFF), old against new, each size in
its own process (peak RSS from ``os.wait4``) on the synthetic DEM's in-memory gradient,
by blocks of 256 rows (the bands of a block: ``2 N`` float32 planes):

- ``old``: the kernel of main before the one heading cost (kept below as
  ``OLD_MAP_COSTS``, compiled with the model's ``power`` into the same module as the
  motion kernels): ``best`` is the least of 4 body yaws (forward, backward, sideways);
- ``new``: :meth:`energy_planner.energy.heading.HeadingCost.map_bands`, ``best`` the
  least over every body yaw (table lookup, exact minimum where the table does not
  serve). Its table is built in the run (``table s``, included in the time; the disk
  cache is bypassed).

Columns: wall seconds, CPU seconds, cell-headings per second of wall and per CPU second,
the ratio new / old of the latter, peak RSS. The load average is printed with the
table: on a shared machine compare within one table, and by CPU seconds.

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


#: main's map kernel before the one heading cost (the baseline): best of 4 body yaws.
OLD_MAP_COSTS = """
@numba.njit(cache=True, parallel=True)
def old_map_costs(gx, gy, chan, headings, speed, tmax, smax, along, best):
    rows, cols = gx.shape
    nh = headings.shape[0]
    nch = chan.shape[0]
    hc = np.cos(headings)
    hs = np.sin(headings)
    for r in numba.prange(rows):
        chv = np.empty(nch)
        for c in range(cols):
            a = gx[r, c]
            b = gy[r, c]
            ok = math.isfinite(a) and math.isfinite(b)
            for k in range(nch):
                chv[k] = chan[k, r, c]
                if not math.isfinite(chv[k]):
                    ok = False
            if not ok:
                for j in range(nh):
                    along[j, r, c] = np.nan
                    best[j, r, c] = np.nan
                continue
            g2 = a * a + b * b
            if g2 > tmax * tmax:
                for j in range(nh):
                    along[j, r, c] = np.inf
                    best[j, r, c] = np.inf
                continue
            g = math.sqrt(g2)
            alpha = math.atan(g)
            ca = math.cos(alpha)
            sa = math.sin(alpha)
            c_psi = a / g if g > 0.0 else 1.0
            s_psi = b / g if g > 0.0 else 0.0
            for j in range(nh):
                u0 = hc[j]
                u1 = hs[j]
                dz = a * u0 + b * u1
                ds = math.sqrt(1.0 + dz * dz)
                dt = ds / speed
                v0 = u0 / dt
                v1 = u1 / dt
                v2 = dz / dt
                fwd = gait_cost(a, b, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt,
                                smax, chv)
                m = fwd
                m = min(m, gait_cost(a, b, alpha, ca, sa, c_psi, s_psi, -u0, -u1, v0, v1, v2,
                                     dt, smax, chv))
                m = min(m, gait_cost(a, b, alpha, ca, sa, c_psi, s_psi, u1, -u0, v0, v1, v2,
                                     dt, smax, chv))
                m = min(m, gait_cost(a, b, alpha, ca, sa, c_psi, s_psi, -u1, u0, v0, v1, v2,
                                     dt, smax, chv))
                along[j, r, c] = fwd
                best[j, r, c] = m
"""


def old_kernel(model):
    """Main's 4-yaw map kernel compiled with ``model``'s power (the baseline)."""
    from energy_planner.energy import kernels
    from energy_planner.model._codegen import load_generated_module

    source = model.kernel_source({}, [])
    block = "# --- power: replaced per model ---\n@numba.njit(cache=True)\n" + source
    text = kernels._POWER_BLOCK.sub(lambda _: block + "\n\n# --- end power ---\n",
                                    kernels._TEMPLATE.read_text())  # fmt: skip
    return load_generated_module(text + OLD_MAP_COSTS, prefix="bench_old").old_map_costs


_KERNEL_SCRIPT = """
import json, math, os, sys, time
sys.path.insert(0, sys.argv[4])
import numpy as np
from bench_energy_map import old_kernel, synthetic_gradient
from energy_planner.energy.heading import HeadingCost, heading_cost
from energy_planner.energymap.core import heading_angles
from energy_planner.model import EnergyModel
size, nh, which = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
model = EnergyModel.default()
gx, gy = synthetic_gradient(size)
ang = heading_angles(nh)
hc = heading_cost(model)
fresh = HeadingCost(*hc.params)  # a table of its own: built in this run
kernel = old_kernel(model)
w = np.ascontiguousarray
chan = np.zeros((0, 1, 1))
def run(a, b, along, best):
    if which == "old":
        kernel(a, b, chan, ang, 0.3, math.inf, math.inf, along, best)
    else:
        fresh.map_bands(a, b, chan, ang, along, best)
# compile (or load) on a small block first
s = np.empty((nh, 4, 4), np.float32)
(kernel if which == "old" else hc.map_bands)(*([w(gx[1:5, 1:5]), w(gy[1:5, 1:5]), chan, ang]
    + ([0.3, math.inf, math.inf] if which == "old" else [])), s, s.copy())
import energy_planner.energy.heading as H
H._load_table = lambda key: None  # build the table in the run
H._save_table = lambda key, t: None
t0, c0 = time.perf_counter(), time.process_time()
tt = 0.0
step = 256
along = np.empty((nh, step, size), np.float32)
best = np.empty_like(along)
for r0 in range(0, size, step):
    r1 = min(size, r0 + step)
    a, b = w(gx[r0:r1]), w(gy[r0:r1])
    if which == "new" and fresh._built < fresh.n_alpha:
        t1 = time.perf_counter()
        g = np.hypot(a, b)
        fresh.table(float(np.arctan(np.nanmax(g))))
        tt += time.perf_counter() - t1
    run(a, b, along[:, : r1 - r0], best[:, : r1 - r0])
print(json.dumps({"wall": time.perf_counter() - t0, "cpu": time.process_time() - c0,
                  "table": tt}))
"""


def synthetic_gradient(size: int, res: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    """Horn gradient of :func:`make_dem`'s rolling hills, in memory (float64)."""
    from energy_planner.terrain.horn import horn_gradient

    x = np.arange(size) * res
    y = x[:, None]
    z = 40 * np.sin(x / 310.0) * np.cos(y / 270.0) + 8 * np.sin((x + 2 * y) / 53.0) + 0.02 * x
    return horn_gradient(z, res, -res)


def kernel_table(sizes: list[int], headings: int, old_max: int = 2048) -> None:
    """Old (4 yaws) against new (every yaw) map kernels; prints a markdown table.

    The old kernel runs up to ``old_max`` cells a side (a 4096^2 old run takes minutes).
    """
    rows = []
    for size in sizes:
        res = {}
        for which in ("old", "new") if size <= old_max else ("new",):
            cmd = [sys.executable, "-c", _KERNEL_SCRIPT, str(size), str(headings), which,
                   str(Path(__file__).parent)]  # fmt: skip
            p = subprocess.Popen(cmd, stdout=subprocess.PIPE, cwd=ROOT)
            out = p.stdout.read()  # type: ignore[union-attr]
            _, status, usage = os.wait4(p.pid, 0)
            if status != 0:
                raise RuntimeError(f"{which} {size} failed with status {status}")
            res[which] = {**json.loads(out), "rss": usage.ru_maxrss / 1024.0}
        rows.append((size, res))
    load = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    print(f"energy-map kernel, {headings} headings; machine: {os.cpu_count()} cores; {load}")
    print()
    print("| DEM | kernel | wall s | CPU s | table s | cell-headings/s (wall) | "
          "cell-headings per CPU s | new / old (per CPU s) | peak RSS MB |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|")
    for size, res in rows:
        n = size * size * headings
        for which, label in (("old", "old: 4 yaws (main)"), ("new", "new: every yaw")):
            if which not in res:
                continue
            r = res[which]
            ratio = res["old"]["cpu"] / r["cpu"] if "old" in res else math.nan
            table = f"{r['table']:.2f}" if which == "new" else "-"
            print(f"| {size}^2 | {label} | {r['wall']:.2f} | {r['cpu']:.2f} | {table} | "
                  f"{n / r['wall'] / 1e6:.1f} M | {n / r['cpu'] / 1e6:.1f} M | {ratio:.2f} | "
                  f"{r['rss']:.0f} |")  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--kernel", action="store_true", help="old vs new map kernel only")
    ap.add_argument("--sizes", type=int, nargs="+", default=[1024, 2048])
    ap.add_argument("--old-max", type=int, default=2048, help="largest size for the old kernel")
    ap.add_argument("--size", type=int, default=4096)
    ap.add_argument("--headings", type=int, default=16)
    ap.add_argument("--chunk", type=int, default=512)
    ap.add_argument("--skip-large", action="store_true")
    ap.add_argument("--workdir", type=Path, default=Path("/tmp/bench_energy_map"))
    a = ap.parse_args()
    if a.kernel:
        kernel_table(a.sizes, a.headings, a.old_max)
        return
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
