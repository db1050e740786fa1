"""Time and peak memory of ``energy-map`` on the bundled Jacksboro DEM and a large DEM.

Usage::

    python benchmarks/bench_energy_map.py --kernel [--sizes 1024 2048 4096] [--headings 16]
    python benchmarks/bench_energy_map.py [--size 4096] [--headings 16] [--chunk 512]
        [--skip-large] [--workdir /tmp/bench_energy_map] [--baseline-python PYTHON]
        [--compress zstd] [--also-compress deflate none]
    python benchmarks/bench_energy_map.py --stages [--size 4096] [--compress zstd]
    python benchmarks/bench_energy_map.py --codecs [--size 2048] [--runs 5]
        [--map-args "--bands all"]
    python benchmarks/bench_energy_map.py --speed MIN:MAX [--fixed-speed V] [--size 2048]
        [--runs 2] [--model NAME] [--set NAME=VALUE ...]

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

End to end (the default): every run is a fresh Python process
(``energy-planner energy-map ...`` through :func:`run_one`), so its peak resident memory
(``os.wait4``'s ``ru_maxrss``) is its own; the kernel is compiled (cached on disk) by a
warm-up run first, so the times are the map's, not numba's. Rows, side by side:

- ``jacksboro``: the bundled lon/lat DEM (loaded and warped to UTM: the *terrain* path);
- ``SIZE^2 terrain`` (baseline): a synthetic metric DEM of SIZE x SIZE cells loaded whole
  (``load_dem``) and mapped from the in-memory Terrain;
- ``SIZE^2 windowed``: the same DEM read by windows of rows (the default for a metric DEM);
- ``SIZE^2 dask``: the same with dask arrays (``--dask``, threads of this machine).

Columns: wall time, CPU time (user + sys of the process and all its threads, from
``os.wait4``), peak RSS, the CPU as a ratio to the in-memory row, and the largest
difference between each large map and the in-memory one's (they must be equal).
``--baseline-python`` (e.g. main's venv: ``/work/main/.venv/bin/python``) runs every row
again with that interpreter's ``energy_planner`` (its own ``energy-planner`` script
beside it, without ``--compress``) and prints its wall, CPU and RSS beside this tree's,
with the ratio baseline / this of the CPU. ``--also-compress`` adds windowed rows with
other compressions. The machine load (``uptime``) is printed next to the table: on a
shared machine compare CPU seconds; wall times are mostly waiting for a CPU.

``--pace``: the command against the disk and a GIS tool, in one run, on a SIZE^2 DEM
(``--size 2048``): ``gdaldem slope`` of the DEM (a GIS tool's whole job on it, when
gdal-bin is installed); ``energy-map`` with the default bands (``best_*`` and the
summary, N + 4 bands stored as scaled uint16, zstd) against the target (2.5 s), with
``--encoding float32``, with ``--bands all`` (2 N + 4 bands) and with ``--bands summary``
(the 4 summary bands); each with the bytes it wrote; with ``--baseline-python`` also
that interpreter's ``energy-map`` (default bands, and ``--bands summary``) in the same
rounds. The floor beside
them: the time to write the same bytes to the same disk (a file of that size, written
and closed) plus the map kernel's compute at its cells-per-second on this machine
(``HeadingCost.map_bands`` over the DEM's gradient in this process, both cores). A run
is *quiet* when the other processes of the machine took less than ``QUIET_CORES`` (0.1)
of a core while it ran (``/proc/stat``'s busy time less the run's own CPU, over its
wall time): the column ``quiet runs`` gives the median wall time of those and their
number, and the 2.5 s target is judged on all runs and on the quiet ones (on a machine
shared with other jobs, a run that waits for a core says nothing of the command).

Start-up counts compiling the package's modules where Python keeps no byte code
(``PYTHONDONTWRITEBYTECODE``, a fresh checkout): 0.2-0.5 CPU s here. An installed
package has its ``.pyc`` files; run the benchmark with byte-code caching on, e.g.
``env -u PYTHONDONTWRITEBYTECODE PYTHONPYCACHEPREFIX=/tmp/pyc python ...`` (the warm-up
run writes them, for the baseline too, outside its checkout).

``--speed MIN:MAX`` (or ``auto``): the map at the best speed of a range against the map
at one fixed speed (``--fixed-speed``, default the range's top; ``--fixed-set`` gives
that row alone channel values, e.g. the gait a model that names gaits needs at a fixed
speed, where the range's row chooses it), on the SIZE^2 DEM with
the default bands, ``--runs`` fresh processes each, alternating, after one warm-up run of
each (the range's heading table is built once per machine, model and range: the
warm-up's time is printed apart). Columns: median wall and CPU seconds, and their ratio
to the fixed-speed map's.

``--stages``: one windowed map in this process, the time of each stage (reading the
DEM, the gradient, the heading table (disk cache), the kernel, the summary bands, the
GeoTIFF write, closing the file, the summary statistics) and the CPU seconds of each
thread (the main thread, numba's workers, GDAL's compression workers), so that the
two-core wall time can be argued from CPU seconds on a loaded machine; then the map's
head (from the call to its first kernel: set-up, the first window's rows and gradient),
its windows (first kernel to the last one's end) and its tail (the last window's
compression, closing the file, the result), wall and CPU seconds each. Head and tail
run on about one core, the windows on both: on two free cores the map takes about
head + windows' CPU / 2 + tail.

``--codecs``: the GTiff storage options of ``CODECS`` on the bands a map holds (the map
written once by ``energy-map``, ``--map-args`` its options as one string), each writing
the same bands by windows of 256 rows in one thread, as the command's writer thread
does: CPU seconds of that thread (median of ``--runs``), the file's bytes, and whether
every band reads back equal, cell for cell, to the map's.

Measured (2 cores shared with other jobs, load 6-10; CPU s of the whole process; main's
``energy-planner`` as the baseline in the same rounds; docs/energy_map.md has the rest):

=====================================================  ======  ========  ==========
run (2048^2 DEM, 16 headings)                          CPU s   MB        main CPU s
=====================================================  ======  ========  ==========
default (20 bands, uint16)                             4.57    45        5.37 (179)
``--encoding float32``                                 5.26    179       -
``--bands all`` (36 bands)                             5.66    84        -
``--bands summary`` (4 bands)                          3.44    8         3.54 (29)
map alone, ``--stages`` (default bands)                4.12    -         5.00
=====================================================  ======  ========  ==========

Since then the writer thread compresses the uint16 tiles itself on up to two cores, the
statistics are worked out beside the last write and the command skips the interpreter's
exit collection (load 8-9, main in the same rounds): default 4.74 CPU s (main 4.87),
``--bands summary`` 3.51 (3.57), ``--encoding float32`` 5.69, ``--bands all`` 5.88; the
map alone (``--stages``) 4.29 (4.53). The same bytes as main's.

With the ``along_*`` bands kept out of the windows unless written (the precompiled
kernel puts the walking-forward values into one plane with a stride of 0 along the
headings; load 2.4-2.9, main 02b8eea in the same rounds, byte code cached): ``--pace``
default 4.63 CPU s (main 5.05), ``--bands summary`` 3.32 (3.56), ``--encoding float32``
5.82, ``--bands all`` 6.19; paired runs in turn (whole command, ``os.wait4``), median of
8 pairs 4.43 CPU s against 4.75 (0.93x; 8 more at load 3.3-5: 4.75 against 4.87,
0.98x), peak RSS 210 MB against 244, fastest wall 2.51 s
against 2.55; ``--bands summary`` 6 pairs 3.42 against 3.64 (0.95x). The same bytes as
main's (``cmp``: default, ``--bands all``, ``--bands summary``, ``--encoding float32``).

With each DEM row read once (the windows' halo rows had every window decode three
chunks of the DEM's compressed tiles), the next window's rows and gradient made in a
thread beside a window's kernel, and the heading table's extent found over row ranges in
threads (main b68ae2d in the same rounds; the same bytes, ``cmp``: default, ``--bands
all``, ``--bands summary``, ``--encoding float32``, ``--dask``): instructions of the
whole command, load-independent (``valgrind --tool=callgrind energy-planner energy-map
dem_2048.tif ...``), default bands: 20.80 G against 21.31 G (-2.4 %; DEFLATE decoding
0.27 G against 0.73 G); at 1024^2 5.88 G against 5.99 G. Paired whole-command runs in
turn (124 pairs, ``os.wait4``; kept: the 31 during which the other processes took less
than 0.05 of a core, from ``/proc/stat``): median 2.54 s wall against 2.64, paired
ratio 0.966 (faster in 20 of 31), 4.15 CPU s against 4.23 (0.974); fastest 2.08 s
against 2.06. Peak RSS 213 MB against 197 (the next window's inputs held ahead).
``--pace --runs 5`` at load 4.0-4.6 (mostly waiting for a CPU): default 5.92 s wall,
3.82 CPU s (main 5.52 s, 4.09), ``--bands summary`` 4.06 s, 3.16 (main 3.99 s, 2.89),
``--encoding float32`` 7.47 s, 5.02, ``--bands all`` 8.37 s, 6.01. On two cores the
map was already nearly CPU-bound: while the main thread read and differentiated, the
writer thread compressed on the other core, so moving that work beside the kernel saves
little there (it shortens the main thread's path where more cores are free); the rest
of the gain is the decoding's CPU.

With each row thread encoding its rows right after its kernel and summary rows (one fork
and join a window instead of three), the Horn gradient and the steepest slope by strips
of rows that stay in the cache and the command's extension modules bound lazily (main
cfdef37 as the baseline; the same bytes, ``cmp``: default, ``--bands all``, ``--bands
summary``, ``--encoding float32``; ``--dask`` equal cell for cell and in its tags, as
main's own ``--dask`` files are from run to run): instructions of the whole command at
1024^2 (callgrind, byte code cached) 5.830 G against 5.882 G (-0.9 %: the start-up's
symbol binding 35 M, the gradient's fills and temporaries; the kernels' the same); of
``energy-map`` of the hill 1176 M against 1217 M. Paired whole-command runs in turn
(``os.wait4``; no idle spell in this round): CPU 4.43 against 4.55 s (ratio 0.965, 6
pairs, load 5-8), 4.36 against 4.44 (0.999, 10 pairs, load 3-4), 3.52 against 3.99
(0.908, 10 pairs, load 1.4-3.5, ratios 0.71-1.11), 4.27 against 4.35 (0.961, 8 pairs,
load 1.8-3.0); wall ratios 0.954, 1.02, 0.900, 0.970; peak
RSS 201 MB against 213. ``--pace --runs 5 --baseline-python`` at load 4-5: default
4.29 s wall, 3.96 CPU s (main 4.39 s, 4.09), ``--bands summary`` 3.27 s, 3.01 (main
2.88 s, 2.89), ``--encoding float32`` 5.73 s, 5.18, ``--bands all`` 5.66 s, 5.62,
``gdaldem slope`` 0.53 s. The CPU a 2048^2 map takes moved by more than these
differences from one spell of this machine's load to the next: the instruction counts
are the load-free measure, and they say the map's own work is nearly unchanged (the
kernel, zstd and libtiff's predictor are two thirds of its CPU, ``perf record``).

Where the 2048^2 default map's wall time goes, measured on main e5c71ed with the other
jobs taking 1-1.5 cores throughout (``/proc/stat``; no idle spell): ``--stages`` (load
2.3-3.8) head 0.05 s wall, 0.05 CPU s; windows 2.77 s, 2.76 CPU s (1.00 core busy: the
other went to the other jobs); tail 0.26 s, 0.23 CPU s; about 1.66 s of map on two free
cores plus about 0.3 s of start-up. Timed inside one process during a quiet spell: 0.31
s of start-up, then 1.60 s of map (set-up and the first window 0.08 s, windows of
0.17-0.19 s, the last window's compression 0.11 s and closing 0.03 s). ``--pace --runs
8`` at load 4.3-5.6: default 5.11 s wall, 3.46 CPU s, its one quiet run 2.24 s;
``--bands summary`` 3.80 s, 2.67; ``--encoding float32`` 6.38 s, 4.60; ``--bands all``
7.59 s, 4.77; ``gdaldem slope`` 0.71 s; at load 2.2-3.1 (``--runs 5``): default 3.51 s,
3.49 CPU s, ``--bands summary`` 3.09 s, ``--encoding float32`` 4.39 s, ``--bands all``
3.97 s, ``gdaldem slope`` 0.53 s; ``--runs 5`` at load 0.7-3.1: default 4.01 s, 4.11 CPU
s, its one quiet run 2.69 s, ``--encoding float32`` 5.70 s (quiet 2.99 s), ``--bands
all`` 5.58 s, ``--bands summary`` 3.17 s, ``gdaldem slope`` 0.43 s. The target is so far
not shown: one quiet run under 2.5 s, one over. A hundred more default runs, one after
another (load 3.0-6.2): none quiet, 2.9-9.6 s wall for 2.8-4.9 CPU s, the others taking
0.97-1.59 cores. ``--codecs`` (load 4.1-4.3, CPU s of the writing thread / MB, every
option read back equal): zstd level 1 with the horizontal predictor (the command's) 1.03
/ 45.4, no predictor 1.01 / 100.1, zstd level 3 1.42 / 43.1, deflate level 1
(libdeflate) 1.35 / 46.6, LERC lossless with zstd 1.48 / 90.9, tiles of 128 1.08 / 46.8,
pixel interleaved 1.30 / 53.4, none 0.25 / 167.8. Tried and not kept (the same values,
read back cell for cell): tiles of 128 (to make the last window, whose compression is
the tail, a tile row of 128) 5.94 G instructions against 5.83 G (callgrind, 1024^2);
tiles of 256 x 128 with the last window a tile row of 128: the last window's compression
0.06-0.07 CPU s against 0.15 at load 5 (0.11 in the quiet spell), so a tail about 0.05 s
shorter on a quiet machine, for 20.86 G instructions against 20.75 G (+0.5 %, callgrind,
2048^2) and 0.8 % more bytes: 2-3 % of the quiet wall time, which no run here could
show, for a new tile shape; windows of 128 rows with tiles of 128, median 4.60 against
3.82 CPU s (8 pairs in turn, load 4-6); the C allocator keeping the memory it frees
(``MALLOC_TRIM_THRESHOLD_``, ``MALLOC_MMAP_THRESHOLD_``): 18 k page faults against 27.5
k, CPU ratios 0.955 and 1.036 (medians of 10 and 14 pairs, load 4-6), noise.

``--speed`` (2048^2, 16 headings, ``b1_speeds``; medians of 2, load 9-11): the range
0.3:1.2 with ``--set gait=trot`` 21.24 s wall, 8.69 CPU s against 14.18 s, 5.69 CPU s at
0.6 (1.50x wall, 1.53x CPU); ``--speed auto`` choosing the gait too 25.80 s, 10.60 CPU s
against 11.18 s, 5.04 CPU s (2.31x wall, 2.10x CPU).

Earlier rounds, kept here (the guide states the current numbers): at 4096^2 with 36
float32 bands, against commit b0302e8 in the same script (load 5-12): in memory 17.8 CPU
s against 33.4, windowed 16.2 against 33.5, dask 18.1 against 639.3 (its blocks stored
by ``rio.to_raster``), jacksboro 2.5 against 2.7, every map bit for bit the baseline's.
At 2048^2 with the precompiled map kernels and float32 bands (load 8): default 5.97 CPU
s (main 7.12), ``--bands all`` 7.78 (9.06); the 200 x 200 hill 0.84 CPU s, 1.8 s wall
against 1.94 CPU s, 4.5 s. With the writer thread compressing, nearly idle (8 runs of
each in turn, whole process): default 2.80 s wall, 4.66 CPU s against main's 2.96 s,
4.92 CPU s; a 64 x 64 map 571-603 ms of CPU against 654-680 (``perf stat -r 8``, load 9).

Commands: ``env -u PYTHONDONTWRITEBYTECODE PYTHONPYCACHEPREFIX=/tmp/pyc python
benchmarks/bench_energy_map.py --pace --size 2048 --runs 2 --baseline-python
/work/main/.venv/bin/python`` (the first four rows); ``python
benchmarks/bench_energy_map.py --stages --size 2048`` in this tree and in main's (the
last).

Measured 2026-11-29 idle (load 0.9 rising to 2.3 from this benchmark itself; every run
quiet), main at f303cd3, twice::

    env -u PYTHONDONTWRITEBYTECODE PYTHONPYCACHEPREFIX=/tmp/pyc \
        python benchmarks/bench_energy_map.py --pace --size 2048 --runs 7

    run                          wall s       CPU s       MB   floor s  wall / gdaldem
    gdaldem slope                0.40, 0.50   -           -    -        1.0
    energy-map (default)         2.31, 2.34   3.72, 3.80  45   1.04     5.8, 4.7   (2.5 s: met)
    --encoding float32           2.81, 2.93   4.56, 4.74  179  1.09
    --bands all                  3.11, 3.06   4.96, 4.77  84   1.05
    --bands summary              1.90, 1.89   3.01, 2.91  8    1.02

(map kernel 66 M cell-headings/s in this process.)
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
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
kw = {"compress": sys.argv[4]} if len(sys.argv) > 4 else {}
res = energy_map(terrain, sys.argv[2], headings=int(sys.argv[3]), progress=False, **kw)
print(json.dumps({"seconds": time.perf_counter() - t0, "mode": res.mode}))
"""


def _busy_seconds() -> float:
    """CPU seconds every process of the machine has used so far (``/proc/stat``; 0 if none)."""
    try:
        f = Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]
    except OSError:
        return 0.0
    busy = sum(int(x) for i, x in enumerate(f[:8]) if i not in (3, 4))  # not idle, iowait
    return busy / os.sysconf("SC_CLK_TCK")


def run_one(args: list[str], terrain: bool = False, python: str | None = None) -> dict:
    """Run one map in a fresh process; wall and CPU seconds, peak RSS (MB), its JSON.

    ``python``: the interpreter (default this one); the CLI is the ``energy-planner``
    script beside it, run from its repository.
    """
    exe = Path(python or sys.executable)
    if terrain:
        cmd = [str(exe), "-c", _TERRAIN_SCRIPT, *args]
    else:
        cmd = [str(exe.with_name("energy-planner")), "energy-map", *args, "--json"]
    t0, busy0 = time.perf_counter(), _busy_seconds()
    # run outside any checkout: ``python -c`` puts the working directory first on
    # sys.path, where this tree's energy_planner would shadow the baseline's; nor may
    # this tree's PYTHONPATH reach the baseline (which may be the same venv)
    env = None
    if python is not None:
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                         cwd=tempfile.gettempdir(), env=env)  # fmt: skip
    out = p.stdout.read()  # type: ignore[union-attr]
    _, status, usage = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    if status != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed with status {status}")
    doc = json.loads(out)
    cpu = usage.ru_utime + usage.ru_stime
    # the cores the other processes took meanwhile (this one's CPU left out)
    others = max(0.0, _busy_seconds() - busy0 - cpu) / wall
    return {"wall_s": wall, "cpu_s": cpu, "rss_mb": usage.ru_maxrss / 1024.0, "doc": doc,
            "others": others}  # fmt: skip


def max_diff(a: Path, b: Path) -> float:
    """Largest relative difference between two maps, by windows.

    Over the cells finite in both; ``inf`` if their NaN or ``+inf`` cells differ.
    """
    import rasterio

    worst = 0.0
    # GDAL's block cache held small: the runs are forked from this process, and a child's
    # peak RSS (wait4) counts this process's resident pages at the fork
    with rasterio.Env(GDAL_CACHEMAX=64), rasterio.open(a) as sa, rasterio.open(b) as sb:
        for _, win in sa.block_windows(1):
            x = sa.read(window=win).astype(float)
            y = sb.read(window=win).astype(float)
            if not np.array_equal(np.isnan(x), np.isnan(y)) or not np.array_equal(
                np.isinf(x) & (x > 0), np.isinf(y) & (y > 0)
            ):
                return math.inf
            ok = np.isfinite(x) & np.isfinite(y)
            if ok.any():
                d = np.abs(x[ok] - y[ok]) / np.maximum(np.abs(y[ok]), 1e-9)
                worst = max(worst, float(d.max()))
    return worst


#: main's map kernel before the one heading cost (the baseline): best of 4 body yaws.
#: It predates the gait limits: ``gait_cost`` is called with none (``btan = cmax = inf``),
#: which is also what the default model's heading cost uses.
OLD_MAP_COSTS = """
@numba.njit(cache=True, parallel=True)
def old_map_costs(gx, gy, chan, headings, speed, tmax, smax, along, best):
    rows, cols = gx.shape
    nh = headings.shape[0]
    nch = chan.shape[0]
    hc = np.cos(headings)
    hs = np.sin(headings)
    nolim = math.inf  # gait_cost's btan and cmax: no gait limit, as this kernel had
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
                                smax, nolim, nolim, chv)
                m = fwd
                m = min(m, gait_cost(a, b, alpha, ca, sa, c_psi, s_psi, -u0, -u1, v0, v1, v2,
                                     dt, smax, nolim, nolim, chv))
                m = min(m, gait_cost(a, b, alpha, ca, sa, c_psi, s_psi, u1, -u0, v0, v1, v2,
                                     dt, smax, nolim, nolim, chv))
                m = min(m, gait_cost(a, b, alpha, ca, sa, c_psi, s_psi, -u1, u0, v0, v1, v2,
                                     dt, smax, nolim, nolim, chv))
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
H._load_table = lambda *key: None  # build the table in the run
H._save_table = lambda *key: None
t0, c0 = time.perf_counter(), time.process_time()
tt = 0.0
step = 256
along = np.empty((nh, step, size), np.float32)
best = np.empty_like(along)
for r0 in range(0, size, step):
    r1 = min(size, r0 + step)
    a, b = w(gx[r0:r1]), w(gy[r0:r1])
    built = fresh._tables.get((), [None, 0])[1]  # rows of the table built so far
    if which == "new" and built < fresh.n_alpha:
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
        for which, label in (("old", "old: 4 yaws"), ("new", "new: every yaw")):
            if which not in res:
                continue
            r = res[which]
            ratio = res["old"]["cpu"] / r["cpu"] if "old" in res else math.nan
            table = f"{r['table']:.2f}" if which == "new" else "-"
            print(f"| {size}^2 | {label} | {r['wall']:.2f} | {r['cpu']:.2f} | {table} | "
                  f"{n / r['wall'] / 1e6:.1f} M | {n / r['cpu'] / 1e6:.1f} M | {ratio:.2f} | "
                  f"{r['rss']:.0f} |")  # fmt: skip


def _thread_cpu() -> dict[str, float]:
    """CPU seconds (user + sys) of each thread of this process (``main`` or its id)."""
    tick = os.sysconf("SC_CLK_TCK")
    out: dict[str, float] = {}
    for task in Path(f"/proc/{os.getpid()}/task").iterdir():
        try:
            name = (task / "comm").read_text().strip()
            f = (task / "stat").read_text().rsplit(") ", 1)[1].split()
        except OSError:
            continue
        cpu = (int(f[11]) + int(f[12])) / tick
        key = "main" if task.name == str(os.getpid()) else f"{name} {task.name}"
        out[key] = cpu
    return out


def stage_table(size: int, headings: int, compress: str, workdir: Path) -> None:
    """Profile one windowed map in this process, stage by stage; prints markdown tables."""
    import time as _time
    from collections import defaultdict

    import rasterio.io

    import energy_planner.energy.heading as heading_mod
    import energy_planner.energymap.bands as bands_mod
    import energy_planner.energymap.core as core
    import energy_planner.energymap.encoding as encoding_mod
    import energy_planner.terrain.horn as horn
    from energy_planner.energymap import _summary

    dem = make_dem(workdir / f"dem_{size}.tif", size)
    acc: dict[str, list[float]] = defaultdict(lambda: [0.0, 0.0])

    def cpu() -> float:
        t = os.times()
        return t.user + t.system

    def timed(owner, name, label):
        f = getattr(owner, name)

        def g(*a, **k):
            w, c = _time.perf_counter(), cpu()
            try:
                return f(*a, **k)
            finally:
                acc[label][0] += _time.perf_counter() - w
                acc[label][1] += cpu() - c

        setattr(owner, name, g)

    timed(core, "_read_stored", "read DEM rows (in the reading thread but the first)")
    timed(core, "_in_metres", "DEM rows to metres")
    timed(horn, "horn_gradient", "gradient (Horn)")
    timed(heading_mod.HeadingCost, "table", "heading table (disk cache)")
    timed(heading_mod.HeadingCost, "_map", "kernel (along, best)")
    # the first kernel's start and the last one's end (wall, process CPU): the map's head
    # (before any kernel: set-up, the first window's rows and gradient) and tail (after
    # the last kernel: its window's compression, closing, the result) run on one core
    spans: list[tuple[float, float, float, float]] = []
    kernel = heading_mod.HeadingCost._map

    def marked(*a, **k):
        w, c = _time.perf_counter(), cpu()
        try:
            return kernel(*a, **k)
        finally:
            spans.append((w, c, _time.perf_counter(), cpu()))

    heading_mod.HeadingCost._map = marked
    timed(_summary, "_summary", "summary bands")
    timed(encoding_mod, "encode_block", "encode (uint16)")
    timed(rasterio.io.DatasetWriter, "write", "GeoTIFF write (compress; in its own thread)")
    timed(rasterio.io.DatasetWriter, "close", "GeoTIFF close (flush)")
    timed(core, "_result", "result (statistics read back unless sampled in the windows)")
    del bands_mod
    from energy_planner.energymap import energy_map

    out = workdir / f"stages_{compress}.tif"
    # load the kernels first (the CLI's start-up): not a stage of the map
    energy_map(make_dem(workdir / "dem_256.tif", 256), out, headings=headings,
               progress=False, compress=compress)  # fmt: skip
    acc.clear()
    spans.clear()
    before = _thread_cpu()
    w0, c0 = _time.perf_counter(), cpu()
    res = energy_map(dem, out, headings=headings, progress=False, compress=compress)
    wall, total = _time.perf_counter() - w0, cpu() - c0
    after = _thread_cpu()
    load = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    print(f"energy-map stages, {size}^2, {headings} headings, {res.mode}, compress={compress}; "
          f"machine: {os.cpu_count()} cores; {load}")  # fmt: skip
    print()
    print("| stage | wall s | CPU s (all threads while in it) |")
    print("|---|---|---|")
    for k, (w, c) in acc.items():
        print(f"| {k} | {w:.2f} | {c:.2f} |")
    print(f"| **whole map** | {wall:.2f} | {total:.2f} |")
    print()
    print("| thread | CPU s |")
    print("|---|---|")
    for k in sorted(after, key=lambda k: -(after[k] - before.get(k, 0.0))):
        d = after[k] - before.get(k, 0.0)
        if d >= 0.01:
            print(f"| {k} | {d:.2f} |")
    main = after.get("main", 0.0) - before.get("main", 0.0)
    print()
    print(f"Two free cores: at least max(main thread, all / 2) = "
          f"{max(main, total / 2):.1f} s; at most main + others / 2 = "
          f"{main + (total - main) / 2:.1f} s (plus start-up).")  # fmt: skip
    if spans:
        (hw, hc), (tw, tc) = spans[0][:2], spans[-1][2:]
        head, tail, body = (
            (hw - w0, hc - c0),
            (wall - (tw - w0), total - (tc - c0)),
            (tw - hw, tc - hc),
        )
        print(f"Head (map call to the first kernel): {head[0]:.2f} s wall, {head[1]:.2f} CPU s; "
              f"windows (first kernel to the last one's end): {body[0]:.2f} s wall, {body[1]:.2f} "
              f"CPU s ({body[1] / max(body[0], 1e-9):.2f} cores busy); tail (to the result): "
              f"{tail[0]:.2f} s wall, {tail[1]:.2f} CPU s. Two free cores: about head + "
              f"windows' CPU / 2 + tail = {head[1] + body[1] / 2 + tail[1]:.2f} s (plus "
              "start-up).")  # fmt: skip


def _write_seconds(nbytes: int, path: Path) -> float:
    """Seconds to write ``nbytes`` (incompressible) to a new file at ``path`` and close it."""
    block = np.random.default_rng(0).integers(0, 255, 1 << 24, dtype=np.uint8).tobytes()
    t0 = time.perf_counter()
    with open(path, "wb") as f:
        left = nbytes
        while left > 0:
            f.write(block[: min(left, len(block))])
            left -= len(block)
    seconds = time.perf_counter() - t0
    path.unlink()
    return seconds


def _kernel_seconds(dem: Path, headings: int) -> float:
    """Wall seconds of the map kernel over ``dem``'s gradient (table built beforehand)."""
    from energy_planner.energymap.bands import heading_angles
    from energy_planner.energymap.setup import _setup
    from energy_planner.terrain import load_dem

    t = load_dem(dem)
    gx, gy = np.ascontiguousarray(t.dzdx), np.ascontiguousarray(t.dzdy)
    setup = _setup(None, None, None, headings)
    ang = heading_angles(headings)
    rows = 256
    along = np.empty((headings, rows, gx.shape[1]), np.float32)
    best = np.empty_like(along)
    chan = np.zeros((0, 1, 1))
    setup.heading.map_bands(gx[:rows], gy[:rows], chan, ang, along, best)  # warm: table
    t0 = time.perf_counter()
    for r0 in range(0, gx.shape[0], rows):
        r1 = min(gx.shape[0], r0 + rows)
        n = r1 - r0
        setup.heading.map_bands(gx[r0:r1], gy[r0:r1], chan, ang, along[:, :n], best[:, :n])
    return time.perf_counter() - t0


#: ``--pace``: a run is quiet when the other processes took less than this many cores
#: meanwhile (``/proc/stat``'s busy time less the run's own CPU, over its wall time).
QUIET_CORES = 0.1


def pace_table(
    size: int, headings: int, workdir: Path, runs: int, baseline: str | None = None
) -> None:
    """``--pace``: see the module docstring."""
    import shutil
    import statistics

    dem = make_dem(workdir / f"dem_{size}.tif", size)
    h = str(headings)
    run_one([str(dem), "--out", str(workdir / "warm.tif"), "--headings", h])  # kernels
    if baseline:
        run_one([str(dem), "--out", str(workdir / "warm.tif"), "--headings", h], python=baseline)
    gdaldem = shutil.which("gdaldem")
    cases: list[tuple[str, list[str], str | None]] = [
        ("energy-map (default: --bands best)", [], None),
        ("energy-map --encoding float32", ["--encoding", "float32"], None),
        ("energy-map --bands all", ["--bands", "all"], None),
        ("energy-map --bands summary", ["--bands", "summary"], None),
    ]
    if baseline:
        cases += [
            ("baseline: energy-map (default)", [], baseline),
            ("baseline: energy-map --bands summary", ["--bands", "summary"], baseline),
        ]
    res: dict[str, list[float]] = {name: [] for name, *_ in cases}
    cpu: dict[str, list[float]] = {name: [] for name, *_ in cases}
    quiet: dict[str, list[float]] = {name: [] for name, *_ in cases}  # walls of quiet runs
    size_b: dict[str, int] = {}
    gd: list[float] = []
    for _ in range(runs):  # in turn, so that the machine's load drifts over all rows alike
        if gdaldem:
            t0 = time.perf_counter()
            subprocess.run([gdaldem, "slope", "-q", str(dem), str(workdir / "slope.tif")],
                           check=True)  # fmt: skip
            gd.append(time.perf_counter() - t0)
        for name, extra, py in cases:
            out = workdir / f"pace{'_'.join(extra)}{'_base' if py else ''}.tif"
            r = run_one([str(dem), "--out", str(out), "--headings", h, *extra], python=py)
            res[name].append(r["wall_s"])
            cpu[name].append(r["cpu_s"])
            if r["others"] < QUIET_CORES:
                quiet[name].append(r["wall_s"])
            size_b[name] = out.stat().st_size
    kernel = _kernel_seconds(dem, headings)
    cells = size * size * headings
    load = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    print(f"python {' '.join(sys.argv)}")
    print(f"energy-map pace, {size}^2 DEM, {headings} headings, median of {runs} runs in "
          f"turn; machine: {os.cpu_count()} cores; {load}")  # fmt: skip
    print(f"map kernel: {kernel:.2f} s for {cells:,} cell-headings "
          f"({cells / kernel / 1e6:.0f} M/s, this process)")  # fmt: skip
    print()
    print("| run | wall s | CPU s | MB written | floor: write its bytes + kernel, s | "
          "wall / gdaldem | quiet runs: wall s (n) | target s |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    g = statistics.median(gd) if gd else None
    if g is not None:
        print(f"| gdaldem slope | {g:.2f} | - | - | - | 1.0 | - | - |")
    for name, *_ in cases:
        wall = statistics.median(res[name])
        floor = _write_seconds(size_b[name], workdir / "bytes.bin") + kernel
        mine = "default" in name and not name.startswith("baseline")
        q = statistics.median(quiet[name]) if quiet[name] else None
        target = "-"
        if mine:
            target = "2.5 " + ("met" if wall <= 2.5 else "NOT met")
            if q is not None:
                target += "; quiet runs: " + ("met" if q <= 2.5 else "NOT met")
        ratio = f"{wall / g:.1f}" if g else "- (no gdaldem)"
        qs = f"{q:.2f} ({len(quiet[name])})" if q is not None else "- (0)"
        print(f"| {name} | {wall:.2f} | {statistics.median(cpu[name]):.2f} | "
              f"{size_b[name] / 1e6:.0f} | {floor:.2f} | {ratio} | {qs} | {target} |")  # fmt: skip


#: ``--codecs``: GTiff storage options tried on a map's own bands, ``(label, creation
#: options)`` over the project's (tiles of 256, band interleaved; ``None`` drops an option).
CODECS: list[tuple[str, dict]] = [
    ("zstd level 1, predictor 2 (3 for float32 bands): the project's", {}),
    ("zstd level 1, no predictor", {"predictor": 1}),
    ("zstd level 3", {"zstd_level": 3}),
    ("deflate level 1 (libdeflate)", {"compress": "deflate", "zstd_level": None, "zlevel": 1}),
    ("LERC lossless (max_z_error 0) + zstd", {"compress": "lerc_zstd", "max_z_error": 0,
                                              "predictor": None}),
    ("zstd level 1, tiles of 128", {"blockxsize": 128, "blockysize": 128}),
    ("zstd level 1, pixel interleaved", {"interleave": "pixel"}),
    ("none", {"compress": "none", "zstd_level": None, "predictor": None}),
]  # fmt: skip


def codec_table(size: int, headings: int, workdir: Path, runs: int, extra: list[str]) -> None:
    """``--codecs``: each of :data:`CODECS` on the bands the map command writes.

    The map is written once by ``energy-map`` (``extra``: its options, e.g. ``--bands
    all``); its stored bands are read into memory and written again, by windows of 256
    rows as the command writes them, with each option set in this thread (GDAL's block
    cache 64 MB, as the command's): CPU seconds of the thread (median of ``runs``), the
    file's bytes, and whether every band reads back equal, cell for cell, to the map's.
    """
    import statistics

    import rasterio
    from rasterio.windows import Window

    dem = make_dem(workdir / f"dem_{size}.tif", size)
    src_path = workdir / "codecs_map.tif"
    run_one([str(dem), "--out", str(src_path), "--headings", str(headings), *extra])
    with rasterio.open(src_path) as src:
        data = src.read()
        prof = src.profile
    pred = 3 if prof["dtype"] == "float32" else 2  # the command's (compression_options)
    prof.update(zstd_level=1, predictor=pred, blockxsize=256, blockysize=256, tiled=True)
    out = workdir / "codecs_out.tif"
    rows = []
    for label, opts in CODECS:
        p = {**prof, **opts}
        p = {k: v for k, v in p.items() if v is not None}
        cpu = []
        for _ in range(runs):
            c0 = time.thread_time()
            with rasterio.Env(GDAL_CACHEMAX=64), rasterio.open(out, "w", **p) as dst:
                for r0 in range(0, data.shape[1], 256):
                    r1 = min(data.shape[1], r0 + 256)
                    dst.write(data[:, r0:r1], window=Window(0, r0, data.shape[2], r1 - r0))
            cpu.append(time.thread_time() - c0)
        with rasterio.open(out) as back:
            same = bool(np.array_equal(back.read(), data, equal_nan=data.dtype.kind == "f"))
        rows.append((label, statistics.median(cpu), out.stat().st_size, same))
    out.unlink()
    load = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    print(f"energy-map storage options, {size}^2 DEM, {headings} headings "
          f"{' '.join(extra) or '(default bands)'}: {data.shape[0]} {data.dtype} bands; "
          f"median of {runs}; machine: {os.cpu_count()} cores; {load}")  # fmt: skip
    print()
    print("| storage | CPU s (writing thread) | MB | / project's MB | read back equal |")
    print("|---|---|---|---|---|")
    for label, c, nbytes, same in rows:
        print(f"| {label} | {c:.2f} | {nbytes / 1e6:.1f} | {nbytes / rows[0][2]:.2f} | "
              f"{'yes' if same else 'NO'} |")  # fmt: skip


def speed_rows(
    size: int, headings: int, workdir: Path, runs: int, speed: str, fixed: str | None,
    model: str | None, sets: list[str], fixed_sets: list[str] = (),
) -> None:  # fmt: skip
    """The map at the best speed of ``speed`` against one at a fixed speed (see ``--speed``)."""
    import statistics

    dem = make_dem(workdir / f"dem_{size}.tif", size)
    common = [str(dem), "--headings", str(headings)]
    if model:
        common += ["--model", model]
    for kv in sets:
        common += ["--set", kv]
    if fixed is None:
        fixed = speed.split(":")[-1] if ":" in speed else None
    fixed_extra = [w for kv in fixed_sets for w in ("--set", kv)]
    cases = {"fixed": (["--speed", fixed] if fixed else []) + fixed_extra,
             "range": ["--speed", speed]}  # fmt: skip
    times: dict[str, list[dict]] = {k: [] for k in cases}
    for name, extra in cases.items():  # warm-up: kernels and heading tables
        r = run_one([*common, "--out", str(workdir / f"speed_{name}.tif"), *extra])
        print(f"warm-up {name}: {r['wall_s']:.1f} s wall, {r['cpu_s']:.1f} CPU s", flush=True)
    for _ in range(runs):
        for name, extra in cases.items():
            times[name].append(run_one([*common, "--out", str(workdir / f"speed_{name}.tif"),
                                        *extra]))  # fmt: skip
    load = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    print(f"energy-map {size}^2, {headings} headings, model {model or 'default'}; "
          f"{os.cpu_count()} cores; {load}")  # fmt: skip
    print("| map | --speed | wall s (median) | CPU s (median) | wall / fixed | CPU / fixed |")
    print("|---|---|---|---|---|---|")
    med = {k: (statistics.median(r["wall_s"] for r in v), statistics.median(r["cpu_s"] for r in v))
           for k, v in times.items()}  # fmt: skip
    for name, extra in cases.items():
        w, c = med[name]
        print(f"| {name} | {' '.join(extra) or 'default'} | {w:.2f} | {c:.2f} | "
              f"{w / med['fixed'][0]:.2f} | {c / med['fixed'][1]:.2f} |")  # fmt: skip


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
    ap.add_argument(
        "--baseline-python",
        default=None,
        help="interpreter whose energy_planner is the baseline (e.g. main's venv)",
    )
    ap.add_argument("--compress", default="zstd", help="this tree's --compress")
    ap.add_argument(
        "--baseline-skip",
        nargs="*",
        default=[],
        choices=["jacksboro", "in-memory", "windowed", "dask"],
        help="rows not run with the baseline (e.g. dask: main's takes 10+ min)",
    )
    ap.add_argument(
        "--also-compress", nargs="*", default=[], help="more windowed rows with these compressions"
    )
    ap.add_argument("--stages", action="store_true", help="profile one windowed map by stage")
    ap.add_argument("--pace", action="store_true", help="the map against the disk and gdaldem")
    ap.add_argument("--runs", type=int, default=3, help="runs per --pace row (median)")
    ap.add_argument("--codecs", action="store_true", help="storage options on the map's own bands")
    ap.add_argument(
        "--map-args", default="", help="energy-map options of the --codecs map, one string"
    )
    ap.add_argument("--speed", default=None, help="a range MIN:MAX or auto: ranged vs fixed")
    ap.add_argument("--fixed-speed", default=None, help="the fixed speed (default: the top)")
    ap.add_argument("--model", default=None, help="energy-map --model of the --speed rows")
    ap.add_argument("--set", action="append", default=[], help="energy-map --set (--speed rows)")
    ap.add_argument(
        "--fixed-set", action="append", default=[], help="--set of the fixed-speed row only"
    )
    a = ap.parse_args()
    a.workdir = a.workdir.resolve()
    if a.kernel:
        kernel_table(a.sizes, a.headings, a.old_max)
        return
    a.workdir.mkdir(parents=True, exist_ok=True)
    if a.stages:
        stage_table(a.size, a.headings, a.compress, a.workdir)
        return
    if a.codecs:
        codec_table(a.size, a.headings, a.workdir, a.runs, a.map_args.split())
        return
    if a.pace:
        pace_table(a.size, a.headings, a.workdir, a.runs, a.baseline_python)
        return
    if a.speed:
        speed_rows(a.size, a.headings, a.workdir, a.runs, a.speed, a.fixed_speed, a.model, a.set,
                   a.fixed_set)  # fmt: skip
        return
    h = str(a.headings)
    comp = ["--compress", a.compress]
    jack = ROOT / "maps" / "jacksboro_fault_dem.tif"
    pythons = [None] + ([a.baseline_python] if a.baseline_python else [])
    for py in pythons:  # warm-up: compile (or load) the kernels once
        extra = comp if py is None else []
        run_one([str(jack), "--out", str(a.workdir / "warm.tif"), "--headings", h, *extra],
                python=py)  # fmt: skip

    def both(args: list[str], terrain: bool = False, name: str = "") -> tuple[dict, dict | None]:
        mine = run_one([*args, *(comp if not terrain else [a.compress])], terrain)
        print(f"{name}: this tree {mine['wall_s']:.1f} s, {mine['cpu_s']:.1f} CPU s", flush=True)
        base = None
        if a.baseline_python and name not in a.baseline_skip:
            bargs = [x.replace(".tif", "_base.tif") if x.endswith(".tif") and "dem_" not in x
                     and "jacksboro" not in x else x for x in args]  # fmt: skip
            base = run_one(bargs, terrain, python=a.baseline_python)
            print(f"{name}: baseline {base['wall_s']:.1f} s, {base['cpu_s']:.1f} CPU s",
                  flush=True)  # fmt: skip
        return mine, base

    rows = []
    r, b = both([str(jack), "--out", str(a.workdir / "jack.tif"), "--headings", h],
                name="jacksboro")  # fmt: skip
    rows.append(("jacksboro (lon/lat -> UTM)", r, b, None, r["doc"]["shape"]))
    if not a.skip_large:
        dem = make_dem(a.workdir / f"dem_{a.size}.tif", a.size)
        base_out = a.workdir / "terrain.tif"
        r, b = both([str(dem), str(base_out), h], terrain=True, name="in-memory")
        shape = [a.size, a.size]
        rows.append((f"{a.size}^2 in memory (load_dem)", r, b, 0.0, shape))
        runs = [("windowed", []), ("dask", ["--dask", "--chunk", str(a.chunk)])]
        for name, extra in runs:
            out = a.workdir / f"{name}.tif"
            r, b = both([str(dem), "--out", str(out), "--headings", h, *extra], name=name)
            rows.append((f"{a.size}^2 {name}", r, b, max_diff(out, base_out), shape))
        for c in a.also_compress:
            out = a.workdir / f"windowed_{c}.tif"
            r = run_one([str(dem), "--out", str(out), "--headings", h, "--compress", c])
            rows.append((f"{a.size}^2 windowed, --compress {c}", r, None,
                         max_diff(out, base_out), shape))  # fmt: skip
    for py in pythons:
        where = subprocess.run(
            [py or sys.executable, "-c", "import energy_planner; print(energy_planner.__file__)"],
            capture_output=True, text=True, cwd=tempfile.gettempdir(),
        ).stdout.strip()  # fmt: skip
        print(f"{'baseline' if py else 'this tree'}: {where}")
    load = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    print(f"energy-map, {a.headings} headings, --compress {a.compress}; machine: "
          f"{os.cpu_count()} cores; {load}")  # fmt: skip
    print()
    base_hdr = " baseline wall s | baseline CPU s | baseline RSS MB | CPU baseline / this |"
    print(
        "| run | cells | wall s | CPU s | peak RSS MB | CPU / in-memory |"
        + (base_hdr if a.baseline_python else "")
        + " max rel. diff vs in-memory |"
    )
    print("|---|---|---|---|---|---|" + ("---|---|---|---|" if a.baseline_python else "")
          + "---|")  # fmt: skip
    ref = next((r for r in rows if r[3] == 0.0), None)
    for name, r, b, diff, shape in rows:
        cells = shape[0] * shape[1]
        ratio = f"{r['cpu_s'] / ref[1]['cpu_s']:.2f}" if ref else "-"
        d = "-" if diff is None else f"{diff:.1e}"
        line = (f"| {name} | {cells:,} | {r['wall_s']:.1f} | {r['cpu_s']:.1f} | "
                f"{r['rss_mb']:.0f} | {ratio} |")  # fmt: skip
        if a.baseline_python:
            if b is None:
                line += " - | - | - | - |"
            else:
                line += (f" {b['wall_s']:.1f} | {b['cpu_s']:.1f} | {b['rss_mb']:.0f} | "
                         f"{b['cpu_s'] / r['cpu_s']:.2f} |")  # fmt: skip
        print(line + f" {d} |")
    if a.baseline_python and not a.skip_large:
        print()
        for name in ("terrain", "windowed", "dask"):
            mine, theirs = a.workdir / f"{name}.tif", a.workdir / f"{name}_base.tif"
            if not theirs.exists():
                continue
            print(f"- {name}: max rel. diff between this tree's map and the baseline's: "
                  f"{max_diff(mine, theirs):.1e}")  # fmt: skip


if __name__ == "__main__":
    main()
