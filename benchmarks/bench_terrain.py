"""Benchmark: slope + aspect on a large DEM, Horn (this package) vs baselines.

Prints one table row per method: wall and CPU time (best of ``--repeat``, methods run
round robin), throughput in cells per CPU second, peak memory allocated during the call
(tracemalloc, which NumPy reports to) and the ratio against the naive ``np.gradient``
baseline.

Methods
-------
- ``np.gradient (baseline)``: central differences without Horn's cross smoothing, edges
  by one-sided differences; slope = atan(|g|), aspect = atan2 -- the naive approach.
- ``scipy.ndimage.convolve Horn``: Horn's 3 x 3 kernels by convolution (same result as
  ours on the interior, no NaN rule).
- ``terrain.slope + terrain.aspect``: the functional API, each call computes the gradient.
- ``terrain.gradient once -> slope, aspect``: one gradient, both angles (what
  ``Terrain`` does).
- ``Terrain.from_array + .slope + .aspect_deg``: the full object path (copy, NaN mask).

Also checks that the Horn variants agree with each other on the interior.

Run: ``python benchmarks/bench_terrain.py [--size 4096] [--repeat 3]``.
"""

from __future__ import annotations

import argparse
import gc
import os
import platform
import time
import tracemalloc
from collections.abc import Callable

import numpy as np


def make_dem(n: int, seed: int = 0) -> np.ndarray:
    """Smooth hills plus small noise, metres (rough enough that nothing is flat)."""
    rng = np.random.default_rng(seed)
    x = np.linspace(0, 8 * np.pi, n)
    z = 80 * np.sin(x)[None, :] * np.cos(0.7 * x)[:, None]
    z += 30 * np.sin(2.3 * x + 1)[None, :] + 20 * np.cos(1.7 * x)[:, None]
    z += rng.normal(0, 0.2, (n, n))
    return z


def baseline_np_gradient(z: np.ndarray, res: float):
    gy_rows, gx = np.gradient(z, res)
    gy = -gy_rows  # rows go south
    slope = np.degrees(np.arctan(np.hypot(gx, gy)))
    aspect = np.degrees(np.arctan2(-gx, -gy)) % 360.0
    return slope, aspect


def scipy_horn(z: np.ndarray, res: float):
    from scipy import ndimage

    kx = np.array([[-1, 0, 1], [-2, 0, 2], [-1, 0, 1]], dtype=float) / (8 * res)
    ky = np.array([[1, 2, 1], [0, 0, 0], [-1, -2, -1]], dtype=float) / (8 * res)
    # convolve flips the kernel: correlate applies it as written
    gx = ndimage.correlate(z, kx, mode="nearest")
    gy = ndimage.correlate(z, ky, mode="nearest")
    slope = np.degrees(np.arctan(np.hypot(gx, gy)))
    aspect = np.degrees(np.arctan2(-gx, -gy)) % 360.0
    return slope, aspect


def ours_functional(z: np.ndarray, res: float):
    from energy_planner.terrain import aspect, slope

    return slope(z, res), aspect(z, res)


def ours_gradient_once(z: np.ndarray, res: float):
    from energy_planner.terrain import gradient
    from energy_planner.terrain.horn import aspect_from_gradient, slope_from_gradient

    gx, gy = gradient(z, res)
    return slope_from_gradient(gx, gy), aspect_from_gradient(gx, gy)


def ours_terrain(z: np.ndarray, res: float):
    from energy_planner.terrain import Terrain

    t = Terrain.from_array(z, resolution=res, crs=None)
    return np.degrees(t.slope), t.aspect_deg


def measure_times(func: Callable, z: np.ndarray, res: float) -> tuple[float, float]:
    """(wall, cpu) seconds of one call."""
    gc.collect()
    w0, c0 = time.perf_counter(), time.process_time()
    out = func(z, res)
    w1, c1 = time.perf_counter(), time.process_time()
    del out
    return w1 - w0, c1 - c0


def measure_peak(func: Callable, z: np.ndarray, res: float):
    """Peak traced allocation (bytes) of one call, and its result."""
    gc.collect()
    tracemalloc.start()
    tracemalloc.reset_peak()
    out = func(z, res)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return peak, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=4096)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    n = args.size
    res = 1.0
    z = make_dem(n)
    cells = z.size
    methods = [
        ("np.gradient (baseline)", baseline_np_gradient),
        ("scipy.ndimage.correlate Horn", scipy_horn),
        ("terrain.slope + terrain.aspect", ours_functional),
        ("terrain.gradient once -> slope, aspect", ours_gradient_once),
        ("Terrain.from_array + .slope + .aspect_deg", ours_terrain),
    ]
    load = os.getloadavg()[0]
    print(
        f"slope + aspect on a {n} x {n} float64 DEM ({cells / 1e6:.1f} M cells), "
        f"best of {args.repeat}; numpy {np.__version__}, Python {platform.python_version()}, "
        f"{platform.machine()}, {os.cpu_count()} CPUs, load average {load:.1f}"
    )
    # round robin over the methods so that background load hits all of them alike
    wall = {name: float("inf") for name, _ in methods}
    cpu = {name: float("inf") for name, _ in methods}
    for _ in range(args.repeat):
        for name, func in methods:
            w, c = measure_times(func, z, res)
            wall[name] = min(wall[name], w)
            cpu[name] = min(cpu[name], c)
    results = {}
    peaks = {}
    for name, func in methods:
        peaks[name], results[name] = measure_peak(func, z, res)
    base = cpu[methods[0][0]]
    header = (
        f"| {'method':<44} | {'wall (s)':>8} | {'CPU (s)':>7} | {'Mcells/s':>8} "
        f"| {'peak MB':>7} | {'speed vs baseline':>17} |"
    )
    print(header)
    print("|" + "|".join("-" * (len(c)) for c in header.split("|")[1:-1]) + "|")
    for name, _ in methods:
        print(
            f"| {name:<44} | {wall[name]:8.3f} | {cpu[name]:7.3f} | "
            f"{cells / cpu[name] / 1e6:8.1f} | {peaks[name] / 2**20:7.0f} | "
            f"{base / cpu[name]:16.2f}x |"
        )
    print("(Mcells/s and the ratio use CPU time: the machine is shared; all single-threaded)")
    # consistency: the Horn variants agree on the interior
    inner = np.s_[1:-1, 1:-1]
    ref_s, ref_a = results["terrain.gradient once -> slope, aspect"]
    for name in (
        "scipy.ndimage.correlate Horn",
        "terrain.slope + terrain.aspect",
        "Terrain.from_array + .slope + .aspect_deg",
    ):
        s, a = results[name]
        ds = np.nanmax(np.abs(s[inner] - ref_s[inner]))
        da = np.nanmax(np.abs((a[inner] - ref_a[inner] + 180) % 360 - 180))
        print(
            f"max |diff| vs 'gradient once' on the interior: {name}: slope {ds:.1e} deg, "
            f"aspect {da:.1e} deg"
        )
    s, _ = results["np.gradient (baseline)"]
    print(
        f"np.gradient vs Horn slope (not the same estimator): median |diff| "
        f"{np.median(np.abs(s[inner] - ref_s[inner])):.3f} deg"
    )


if __name__ == "__main__":
    main()
