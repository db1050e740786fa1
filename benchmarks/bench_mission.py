"""The mission's energy matrix: serial vs a 2-worker dask LocalCluster (issue 22, point 2).

``n`` sites (default 20) at random on a hilly synthetic DEM (``_hilly.py``: knolls and
valleys, slopes up to about 25 deg), one early-stopped search per site
(:func:`energy_planner.mission.matrix.matrix_search`: an A* toward every other site at
once, keys ``g + eps * h`` with ``eps`` the plan's default 1.05, stopped when they are all
settled, in a proven window), first in this process, then on a dask ``LocalCluster`` of 2
single-threaded worker processes configured with
:data:`~energy_planner.mission.matrix.CLUSTER_CONFIG` (the same code runs on a cluster
given by address: ``mission --scheduler ADDRESS``). Printed:

- the matrix time, serial (baseline) and on the cluster, with the ratio, and the peak
  resident memory of this process and of each worker;
- the last session's method (``eps = 1`` with every edge of the window priced once in a
  shared table), timed on ``--old-sizes`` DEMs and extrapolated to ``--size`` by a fit of
  ``time = a * cells^k`` (so that the table's "before" is measured on this machine, at
  this load, not assumed);
- optionally (``--full-sites``, small maps only) one full Dijkstra per site over the whole
  map (:func:`energy_planner.planning.reach.reach`), scaled to ``n``, and the largest
  relative difference of the matrix's rows to it (at most ``eps - 1``);
- the largest difference between the serial and the cluster's matrices (must be 0);
- ``plan`` (``planner="search"``) on ``--legs`` random pairs against the matrix: at
  ``eps = 1`` (the optimum on the primitives; the entry lies between it and ``eps``
  times it) and at the plan's default eps; the issue asks for 1 %.

Usage::

    python benchmarks/bench_mission.py                  # reduced: 20 sites, 200 x 200
    python benchmarks/bench_mission.py --size 2000      # full size (issue 22): 20 sites, 2000^2
    python benchmarks/bench_mission.py --json
    python benchmarks/bench_mission.py --scaling 250,500,1000   # serial matrix per size, to 2000^2

``--scaling`` times the serial matrix of ``--sites`` sites per DEM size (after a warm-up
that compiles the kernels), fits ``time = a * cells^k`` over the sizes and extrapolates to
``--size`` (default 2000).

On a machine shared with other jobs the cluster's speed-up is bounded by the free cores.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time

import numpy as np


def _problem(size: int, n_sites: int, seed: int = 0):
    from _hilly import X0, Y0, hilly_elevation

    from energy_planner.mission import Sites
    from energy_planner.terrain import Terrain

    ter = Terrain.from_array(hilly_elevation(size), resolution=1.0, origin=(X0, Y0))
    rng = np.random.default_rng(seed)
    m = 5.0
    pts = rng.uniform(m, size - m, (n_sites, 2)) + np.array([X0, Y0])
    return ter, Sites(pts, [f"s{i}" for i in range(n_sites)]).on_cells(ter)


def _warm(ter, model, sites, client=None) -> None:
    """Compile the kernels (not timed): a two-site matrix in a small window.

    The first site and a point 5 cells from it, each way of pricing edges (the lazy cache
    at eps 1 and 1.05, the whole table of the old method).
    """
    from energy_planner.mission import Sites
    from energy_planner.mission.matrix import matrix_search

    p = sites.xy[0]
    q = p + np.where(p < np.array(ter_extent(ter)[:2]), 5.0, -5.0)
    two = Sites(np.array([p, q]), ["w0", "w1"]).on_cells(ter)
    for eps, table in ((1.0, None), (1.05, None), (1.0, True)):
        matrix_search(ter, model, two, client=client, eps=eps, edge_cache=table)


def ter_extent(ter) -> tuple[float, float, float, float]:
    """(x centre, y centre, width, height) of the map (working CRS)."""
    from energy_planner.planning.moves import terrain_extent

    xmin, xmax, ymin, ymax = terrain_extent(ter)
    return (xmin + xmax) / 2, (ymin + ymax) / 2, xmax - xmin, ymax - ymin


def _old_method(sizes: list[int], target: int, n_sites: int, model) -> dict:
    """The last session's matrix (``eps = 1``, shared edge table) timed per size, extrapolated."""
    from energy_planner.mission.matrix import matrix_search

    rows = []
    for size in sizes:
        ter, sites = _problem(size, n_sites)
        t0 = time.perf_counter()
        matrix_search(ter, model, sites, eps=1.0, edge_cache=True)
        rows.append({"size": size, "matrix_s": time.perf_counter() - t0})
    k, pred = _extrapolate(rows, target)
    return {"rows": rows, "exponent_in_cells": k, "extrapolated_s": pred}


def _extrapolate(rows: list[dict], target: int) -> tuple[float, float]:
    """Fit ``time = a * cells^k`` over ``rows`` (size, matrix_s); the time at ``target``."""
    cells = np.array([r["size"] ** 2 for r in rows], float)
    secs = np.array([r["matrix_s"] for r in rows])
    if len(rows) > 1:
        k, loga = np.polyfit(np.log(cells), np.log(secs), 1)
    else:
        k, loga = 1.0, math.log(secs[0] / cells[0])
    return float(k), math.exp(loga) * float(target) ** (2 * k)


def _note(text: str) -> None:
    """A line on stderr as each stage ends (a long run keeps what it measured)."""
    import sys

    print(f"[{time.strftime('%H:%M:%S')} load {os.getloadavg()[0]:.1f}] {text}",
          file=sys.stderr, flush=True)  # fmt: skip


def _peak_rss_gb() -> float:
    """Peak resident memory of the calling process, GB.

    Linux: ``VmHWM`` of ``/proc/self/status``, the peak of this address space.
    (``ru_maxrss`` is inherited across fork and exec: a dask worker spawned after the
    serial run reported the parent's peak.) Elsewhere ``ru_maxrss`` (kB).
    """
    import resource

    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1e6
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6


def main(argv: list[str] | None = None) -> dict:
    """Run the benchmark and print its table."""
    import energy_planner as ep
    from energy_planner.mission.matrix import matrix_search
    from energy_planner.planning.plan import DEFAULT_EPS

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=None, help="DEM size (200; --scaling: 2000)")
    ap.add_argument("--sites", type=int, default=20)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--eps", type=float, default=DEFAULT_EPS, help="the searches' weight")
    ap.add_argument("--full-sites", type=int, default=0,
                    help="sites timed with a full reach (small maps only)")  # fmt: skip
    ap.add_argument("--old-sizes", default="200,300,400",
                    help="DEM sizes timing the last session's method ('' to skip)")  # fmt: skip
    ap.add_argument("--legs", type=int, default=3, help="legs checked against plan")
    ap.add_argument("--scaling", default=None, help="comma-separated DEM sizes")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)
    if a.scaling:
        sizes = [int(v) for v in a.scaling.split(",")]
        return scaling(sizes, a.size or 2000, a.sites, a.json, a.eps)
    a.size = a.size or 200
    model = ep.load_model()
    ter, sites = _problem(a.size, a.sites)
    load0 = os.getloadavg()[0]
    _warm(ter, model, sites)
    old = None
    if a.old_sizes:
        old = _old_method([int(v) for v in a.old_sizes.split(",")], a.size, a.sites, model)
        _note(f"old method {old}")
    t0 = time.perf_counter()
    res = matrix_search(ter, model, sites, eps=a.eps)
    t_serial = time.perf_counter() - t0
    rss_serial = _peak_rss_gb()
    serial = res.energy_j
    _note(f"serial {t_serial:.1f} s, peak RSS {rss_serial:.2f} GB, {res.info}")

    t_full = d_full = None
    k = max(0, min(a.full_sites, a.sites))
    if k:  # one full Dijkstra per site over the whole map, read at the sites
        from energy_planner.planning.reach import reach

        rc = sites.cells(ter)
        t0 = time.perf_counter()
        full = np.array([reach(ter, model, tuple(p)).energy_j[rc[:, 0], rc[:, 1]]
                         for p in sites.xy[:k]])  # fmt: skip
        t_full = (time.perf_counter() - t0) * a.sites / k
        full = np.where(np.isfinite(full), full, np.inf)
        d_full = _max_rel(serial[:k], full)

    import dask
    from distributed import Client, LocalCluster

    from energy_planner.mission.matrix import CLUSTER_CONFIG

    with (
        dask.config.set(CLUSTER_CONFIG),  # what docs/routes.md tells a cluster's user to set
        LocalCluster(
            n_workers=a.workers, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        Client(cluster) as client,
    ):
        _warm(ter, model, sites, client)
        t0 = time.perf_counter()
        par = matrix_search(ter, model, sites, client=client, eps=a.eps).energy_j
        t_dask = time.perf_counter() - t0
        rss_workers = sorted(client.run(_peak_rss_gb).values())
    _note(f"dask {t_dask:.1f} s, workers' peak RSS {rss_workers} GB")
    d_dask = float(np.max(np.abs(np.where(np.isfinite(serial), serial - par, 0.0))))
    same_inf = bool(np.array_equal(np.isinf(serial), np.isinf(par)))

    from energy_planner.planning.plan import plan

    rng = np.random.default_rng(1)
    legs = []
    for _ in range(a.legs):
        i, j = rng.choice(a.sites, 2, replace=False)
        leg = {"from": int(i), "to": int(j), "matrix_j": float(serial[i, j])}
        for name, e in (("optimum", 1.0), ("plan_default", None)):
            t0 = time.perf_counter()
            p = plan(ter, model, tuple(sites.xy[i]), tuple(sites.xy[j]), planner="search",
                     eps=e, progress=False)  # fmt: skip
            leg[f"{name}_j"] = float(p.energy_j)
            leg[f"{name}_s"] = time.perf_counter() - t0
            leg[f"rel_diff_{name}"] = float(serial[i, j] / p.energy_j - 1.0)
        legs.append(leg)
        _note(f"leg {leg}")
    out = {
        "size": a.size,
        "sites": a.sites,
        "workers": a.workers,
        "eps": a.eps,
        "load_average_start": load0,
        "load_average_end": os.getloadavg()[0],
        "serial_s": t_serial,
        "dask_s": t_dask,
        "peak_rss_serial_gb": rss_serial,
        "peak_rss_workers_gb": rss_workers,
        "old_method": old,
        "full_search_s": t_full,
        "full_search_sites_timed": k,
        "max_rel_diff_vs_full_search": d_full,
        "max_diff_serial_vs_dask_j": d_dask,
        "same_unreachable": same_inf,
        "legs_vs_plan": legs,
        "window": res.info["window"],
        "whole_map": res.info["whole_map"],
        "expanded": res.info["expanded"],
        "states_total": res.info["states_total"],
        "heuristic_s": res.info["heuristic_s"],
        "search_s": res.info["search_s"],
        "edge_table": res.info["edge_table"],
        "edges": res.info["edges"],
        "priced": res.info["priced"],
        "edge_table_s": res.info["edge_table_s"],
    }
    if a.json:
        print(json.dumps(out, indent=2))
        return out
    print(f"{a.sites} sites on a {a.size} x {a.size} DEM (1 m cells), eps {a.eps:g}; load "
          f"average {load0:.1f} -> {out['load_average_end']:.1f} (2 cores)")  # fmt: skip
    print(f"{'run':<58} {'time s':>8} {'ratio':>7} {'peak RSS GB':>12}")
    name = f"serial, weighted early-stopped A* (eps {a.eps:g}; baseline)"
    print(f"{name:<58} {t_serial:>8.1f} {1.0:>7.2f} {rss_serial:>12.2f}")
    name = f"dask LocalCluster, {a.workers} workers"
    rss = "/".join(f"{v:.2f}" for v in rss_workers)
    print(f"{name:<58} {t_dask:>8.1f} {t_dask / t_serial:>7.2f} {rss:>12}")
    if old is not None:
        sizes = ", ".join(f"{r['size']}^2 {r['matrix_s']:.1f} s" for r in old["rows"])
        name = "before: eps 1 + edge table, extrapolated"
        print(f"{name:<58} {old['extrapolated_s']:>8.0f} "
              f"{old['extrapolated_s'] / t_serial:>7.2f}   (measured {sizes}; "
              f"~cells^{old['exponent_in_cells']:.2f})")  # fmt: skip
    if t_full is not None:
        name = f"before: full Dijkstra per site ({k} timed)"
        print(f"{name:<58} {t_full:>8.1f} {t_full / t_serial:>7.2f}")
    print(f"states expanded {res.info['expanded']:,} of {res.info['states_total']:,} "
          f"(positions x headings x rows: {res.info['expanded'] / res.info['states_total']:.2%}"
          f"), edges priced {res.info['priced']:,} ({res.info['edges']}); serial: heuristics "
          f"{res.info['heuristic_s']:.1f} s, edge table "
          f"{res.info['edge_table_s']:.1f} s, searches "
          f"{res.info['search_s'] - res.info['edge_table_s']:.1f} s; window "
          f"{'= the map' if res.info['whole_map'] else res.info['window']}")  # fmt: skip
    print(f"max |serial - dask| = {d_dask:g} J (same unreachable pairs: {same_inf})")
    if d_full is not None:
        print(f"max relative difference to the full searches: {d_full:.2g}")
    for leg in legs:
        print(f"leg s{leg['from']} -> s{leg['to']}: matrix {leg['matrix_j']:.0f} J; plan eps 1 "
              f"{leg['optimum_j']:.0f} J ({leg['rel_diff_optimum']:+.3%}, "
              f"{leg['optimum_s']:.0f} s); plan default {leg['plan_default_j']:.0f} J "
              f"({leg['rel_diff_plan_default']:+.3%}, {leg['plan_default_s']:.0f} s)")  # fmt: skip
    return out


def _max_rel(a: np.ndarray, b: np.ndarray) -> float:
    fin = np.isfinite(a) & np.isfinite(b) & (b > 0)
    if not np.array_equal(np.isfinite(a), np.isfinite(b)):
        return math.inf
    return float(np.max(np.abs(a[fin] / b[fin] - 1.0))) if fin.any() else 0.0


def scaling(sizes: list[int], target: int, n_sites: int, as_json: bool = False,
            eps: float = 1.05) -> dict:  # fmt: skip
    """Time the serial matrix per DEM size; fit ``a * cells^k`` and extrapolate."""
    import energy_planner as ep
    from energy_planner.mission.matrix import matrix_search

    model = ep.load_model()
    rows = []
    load0 = os.getloadavg()[0]
    for size in sizes:
        ter, sites = _problem(size, n_sites)
        if not rows:
            _warm(ter, model, sites)
        t0 = time.perf_counter()
        res = matrix_search(ter, model, sites, eps=eps)
        rows.append({"size": size, "matrix_s": time.perf_counter() - t0,
                     "expanded": res.info["expanded"], "heuristic_s": res.info["heuristic_s"],
                     "edge_table_s": res.info["edge_table_s"],
                     "states_total": res.info["states_total"]})  # fmt: skip
    k, pred = _extrapolate(rows, target)
    res = {"rows": rows, "eps": eps, "load_average_start": load0,
           "load_average_end": os.getloadavg()[0],
           "exponent_in_cells": float(k), "target_size": target,
           "extrapolated_matrix_serial_s": pred}  # fmt: skip
    if as_json:
        print(json.dumps(res, indent=2))
        return res
    print(f"serial matrix of {n_sites} sites, eps {eps:g} (load average {load0:.1f} -> "
          f"{res['load_average_end']:.1f})")  # fmt: skip
    print(f"{'DEM':>11} {'matrix s':>9} {'heuristics s':>13} {'edge table s':>13} "
          f"{'expanded / states':>26}")  # fmt: skip
    for r in rows:
        print(f"{r['size']:>5} x {r['size']:<4} {r['matrix_s']:>9.1f} "
              f"{r['heuristic_s']:>13.1f} {r['edge_table_s']:>13.1f} "
              f"{r['expanded']:>12,} / {r['states_total']:<12,}")  # fmt: skip
    print(f"time ~ cells^{k:.2f}; extrapolated to {target} x {target}: {pred / 3600:.1f} h "
          f"serial ({pred / 3600 / 2:.1f} h on 2 free workers)")  # fmt: skip
    return res


if __name__ == "__main__":
    main()
