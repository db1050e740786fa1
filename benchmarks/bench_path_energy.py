"""Segments per second of the path-energy kernel on a 1 m DEM, one core.

Usage::

    NUMBA_NUM_THREADS=1 python benchmarks/bench_path_energy.py [--dem maps/hill.tif]
        [--segments 200000] [--repeat 3]

Prints, for lattice-like motions of 1 m and 5 m (random start and heading, facing along
the motion, on valid ground), side by side:

- ``batch``: :meth:`MotionCost.batch` over arrays of motions (what a lattice planner
  calls), segments/s;
- ``path_energy``: :func:`path_energy` on one long path of such segments (turns in place
  at the corners, the per-segment table built with pandas), waypoint segments/s;
- ``call``: ``cost(x0, y0, th0, x1, y1, th1)`` one motion per Python call (OMPL's
  ``motionCost``), calls/s;
- ``numpy``: the same integral evaluated with vectorized numpy (``Terrain.sample`` and
  ``EnergyModel.power`` over every sub-step of every motion, the tilted body frame built
  with array operations), segments/s; the ``batch/numpy`` ratio; and the largest relative
  difference between the two energies (they must agree to rounding).

Target: >= 1e6 segments/s for ``batch`` on one core.
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import argparse  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402
from functools import partial  # noqa: E402

import numpy as np  # noqa: E402


def valid_motions(terrain, cost, n, length, rng):
    """``n`` motions of ``length`` m facing along themselves, entirely on valid ground."""
    b = terrain.bounds
    out = []
    while sum(len(o[0]) for o in out) < n:
        m = 2 * n
        x0 = rng.uniform(b[0], b[2], m)
        y0 = rng.uniform(b[1], b[3], m)
        th = rng.uniform(-math.pi, math.pi, m)
        x1 = x0 + length * np.cos(th)
        y1 = y0 + length * np.sin(th)
        ok = np.isfinite(cost.batch(x0, y0, th, x1, y1, th))
        out.append((x0[ok], y0[ok], th[ok], x1[ok], y1[ok]))
    return [np.concatenate([o[k] for o in out])[:n] for k in range(5)]


def numpy_energy(terrain, model, x0, y0, th, x1, y1, speed, step):
    """The kernel's integral for straight motions without turning, in vectorized numpy.

    Motions are grouped by their number of sub-steps ``ceil(d / step)`` (as the kernel
    counts them; rounding can add one for a nominally whole number).
    """
    n_all = np.maximum(1, np.ceil(np.hypot(x1 - x0, y1 - y0) / step)).astype(int)
    e = np.empty(len(x0))
    for n in np.unique(n_all):
        k = n_all == n
        e[k] = _numpy_group(terrain, model, x0[k], y0[k], th[k], x1[k], y1[k], speed, int(n))
    return e


def _numpy_group(terrain, model, x0, y0, th, x1, y1, speed, n):
    dx, dy = x1 - x0, y1 - y0
    s = (np.arange(n) + 0.5) / n
    x = x0[:, None] + s * dx[:, None]
    y = y0[:, None] + s * dy[:, None]
    smp = terrain.sample(x, y)
    gx, gy = np.asarray(smp.dzdx), np.asarray(smp.dzdy)
    hx, hy = (dx / n)[:, None], (dy / n)[:, None]
    dz = gx * hx + gy * hy
    ds = np.sqrt(hx * hx + hy * hy + dz * dz)
    surface = ds.sum(axis=1, keepdims=True)
    dt = (surface / speed) * ds / surface
    c, sn = np.cos(th)[:, None], np.sin(th)[:, None]
    bx = np.stack(np.broadcast_arrays(c, sn, gx * c + gy * sn), axis=-1)
    bx /= np.linalg.norm(bx, axis=-1, keepdims=True)
    bz = np.stack([-gx, -gy, np.ones_like(gx)], axis=-1)
    bz /= np.linalg.norm(bz, axis=-1, keepdims=True)
    by = np.cross(bz, bx)
    v = np.stack(np.broadcast_arrays(hx, hy, dz), axis=-1) / dt[..., None]
    psi = np.arctan2(gy, gx)
    alpha = np.arctan(np.hypot(gx, gy))
    gh = th[:, None] - psi  # heading from uphill on the map; gamma is measured in the
    gamma = np.arctan2(np.sin(gh) * np.cos(alpha), np.cos(gh))  # slope plane (IMU's)
    feats = {
        "alpha": alpha.ravel(),
        "gamma": gamma.ravel(),
        "vx": np.sum(v * bx, axis=-1).ravel(),
        "vy": np.sum(v * by, axis=-1).ravel(),
        "wz": np.zeros(x.size),
        "ax": np.zeros(x.size),
        "ay": np.zeros(x.size),
    }
    p = model.power(feats).reshape(x.shape)
    return np.sum(p * dt, axis=1)


def long_path(terrain, cost, n_seg, length, rng):
    """A random walk of ``n_seg`` segments of ``length`` m that stays on valid ground."""
    b = terrain.bounds
    margin = 4.0
    xy = np.empty((n_seg + 1, 2))
    xy[0] = [(b[0] + b[2]) / 2, (b[1] + b[3]) / 2]
    h = 0.0
    i = 0
    while i < n_seg:
        h2 = h + rng.normal(0, 0.6)
        p = xy[i] + length * np.array([math.cos(h2), math.sin(h2)])
        inside = b[0] + margin < p[0] < b[2] - margin and b[1] + margin < p[1] < b[3] - margin
        if inside and math.isfinite(cost(xy[i, 0], xy[i, 1], h2, p[0], p[1], h2)):
            xy[i + 1] = p
            h = h2
            i += 1
        else:
            h = h + math.pi / 2
    return xy


def best_time(fn, repeat):
    """Best of ``repeat`` runs, in CPU seconds of this process (``time.process_time``).

    The work is single-threaded, and CPU time is what other jobs on a shared machine do
    not inflate (wall-clock time is printed too, in ``main``).
    """
    best = math.inf
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        best = min(best, time.process_time() - t0)
    return best


def measure(terrain, model, cost, length, rng, args, path_energy) -> dict[str, float]:
    """Rates (per second) of the four evaluations for motions of ``length`` m."""
    mot = valid_motions(terrain, cost, args.segments, length, rng)
    x0, y0, th, x1, y1 = mot
    n = len(x0)
    t_batch = best_time(partial(cost.batch, x0, y0, th, x1, y1, th), args.repeat)
    e_batch = cost.batch(x0, y0, th, x1, y1, th)

    k = min(n, 50_000)
    sub = [a[:k] for a in mot]
    numpy_energy(terrain, model, *[a[:10] for a in sub], 0.3, cost.step)  # warm up
    t_np = best_time(partial(numpy_energy, terrain, model, *sub, 0.3, cost.step), args.repeat)
    e_np = numpy_energy(terrain, model, *sub, 0.3, cost.step)
    rel = float(np.max(np.abs(e_np - e_batch[:k]) / np.abs(e_batch[:k])))

    c = min(args.calls, n)
    cols = [a[:c].tolist() for a in mot]

    def calls() -> None:
        for a, b, t, d, e in zip(*cols, strict=True):
            cost(a, b, t, d, e, t)

    t_call = best_time(calls, args.repeat)

    xy = long_path(terrain, cost, args.path_segments, length, rng)
    path_energy(terrain, model, xy[:3], cost=cost)  # warm up
    t_path = best_time(partial(path_energy, terrain, model, xy, cost=cost), args.repeat)
    return {
        "n_sub": int(math.ceil(length / cost.step)),
        "batch": n / t_batch,
        "numpy": k / t_np,
        "call": c / t_call,
        "path": args.path_segments / t_path,
        "rel": rel,
    }


def main() -> None:
    from energy_planner.energy import MotionCost, path_energy
    from energy_planner.maps import map_path
    from energy_planner.model import EnergyModel
    from energy_planner.terrain import load_dem

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dem", default=None, help="1 m DEM (default: the bundled hill)")
    ap.add_argument("--segments", type=int, default=200_000)
    ap.add_argument("--path-segments", type=int, default=50_000)
    ap.add_argument("--calls", type=int, default=50_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    terrain = load_dem(args.dem or map_path("hill"))
    model = EnergyModel.default()
    cost = MotionCost(terrain, model, 0.3, 0.5)
    rng = np.random.default_rng(args.seed)
    cost.batch(*([np.zeros(1)] * 6))  # compile (or load from the kernel cache)
    print(
        f"DEM {terrain.path} {terrain.shape[1]}x{terrain.shape[0]} cells, "
        f"{terrain.resolution[0]:g} m; sub-step {cost.step:g} m; "
        f"NUMBA_NUM_THREADS={os.environ['NUMBA_NUM_THREADS']}; {platform.processor() or ''} "
        f"python {platform.python_version()}; load average {os.getloadavg()[0]:.1f} on "
        f"{os.cpu_count()} CPUs; rates per CPU second"
    )
    wall0 = time.perf_counter()
    header = (
        f"{'motion':>7} {'sub-steps':>9} {'batch seg/s':>12} {'path_energy seg/s':>18} "
        f"{'call /s':>9} {'numpy seg/s':>12} {'batch/numpy':>11} {'max rel diff':>12}"
    )
    print(header)
    print("-" * len(header))
    for length in (1.0, 5.0):
        row = measure(terrain, model, cost, length, rng, args, path_energy)
        print(
            f"{length:>5g} m {row['n_sub']:>9d} {row['batch']:>12.3g} {row['path']:>18.3g} "
            f"{row['call']:>9.3g} {row['numpy']:>12.3g} {row['batch'] / row['numpy']:>11.1f} "
            f"{row['rel']:>12.1e}"
        )
    print(f"(wall-clock time of the measurements: {time.perf_counter() - wall0:.1f} s)")
    print(
        "\nbatch: MotionCost.batch; path_energy: one long random-walk path, turns at corners "
        "and the segment table included; call: one cost() per Python call; numpy: the same "
        "integral vectorized with Terrain.sample + EnergyModel.power (the baseline)."
    )


if __name__ == "__main__":
    main()
