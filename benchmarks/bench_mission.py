"""The mission's energy matrix: serial vs a 2-worker dask LocalCluster (issue 22, point 2).

``n`` sites (default 20) at random on a hilly synthetic DEM (``_hilly.py``: knolls and
valleys, slopes up to about 25 deg), one least-energy search per site
(:func:`energy_planner.mission.energy_matrix`), first in this process, then on a dask
``LocalCluster`` of 2 single-threaded worker processes (the same code runs on a cluster
given by address: ``mission --scheduler ADDRESS``). The matrices must be equal.

Usage::

    python benchmarks/bench_mission.py              # reduced: 20 sites, 100 x 100 (2 min)
    python benchmarks/bench_mission.py --size 2000      # full size (issue 22): 20 sites, 2000^2
    python benchmarks/bench_mission.py --json
    python benchmarks/bench_mission.py --scaling 100,200,400   # one search per size, to 2000^2

``--scaling`` times one site's search (:func:`energy_planner.mission.energy_matrix` on one
site, after a warm-up that compiles the kernels) on DEMs of the given sizes, and
extrapolates the matrix time of ``--sites`` sites on a ``--size`` DEM from the largest,
linearly in the number of states (cells x headings).

On a machine shared with other jobs the cluster's speed-up is bounded by the free cores.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np


def main(argv: list[str] | None = None) -> dict:
    """Run the benchmark and print its table."""
    from _hilly import X0, Y0, hilly_elevation

    import energy_planner as ep
    from energy_planner.mission import Sites, energy_matrix
    from energy_planner.terrain import Terrain

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=None, help="DEM size (100; --scaling: 2000)")
    ap.add_argument("--sites", type=int, default=20)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--scaling", default=None, help="comma-separated DEM sizes")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)
    if a.scaling:
        sizes = [int(v) for v in a.scaling.split(",")]
        return scaling(sizes, a.size or 2000, a.sites, a.json)
    a.size = a.size or 100
    ter = Terrain.from_array(hilly_elevation(a.size), resolution=1.0, origin=(X0, Y0))
    model = ep.load_model()
    rng = np.random.default_rng(0)
    m = 5.0
    pts = rng.uniform(m, a.size - m, (a.sites, 2)) + np.array([X0, Y0])
    sites = Sites(pts, [f"s{i}" for i in range(a.sites)]).on_cells(ter)
    energy_matrix(ter, model, Sites(sites.xy[:1], ["warm"]))  # compile once, not timed
    t0 = time.perf_counter()
    serial = energy_matrix(ter, model, sites)
    t_serial = time.perf_counter() - t0

    from distributed import Client, LocalCluster

    with (
        LocalCluster(
            n_workers=a.workers, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        Client(cluster) as client,
    ):
        client.run(lambda: __import__("energy_planner.energy.motion"))
        energy_matrix(
            ter, model, Sites(sites.xy[: a.workers], ["w0", "w1"][: a.workers]), client=client
        )
        t0 = time.perf_counter()
        par = energy_matrix(ter, model, sites, client=client)
        t_dask = time.perf_counter() - t0
    same = bool(np.array_equal(serial, par))
    res = {
        "size": a.size,
        "sites": a.sites,
        "workers": a.workers,
        "serial_s": t_serial,
        "dask_s": t_dask,
        "speedup": t_serial / t_dask,
        "same_matrix": same,
        "finite_share": float(np.isfinite(serial).mean()),
    }
    if a.json:
        print(json.dumps(res, indent=2))
        return res
    print(f"{a.sites} sites on a {a.size} x {a.size} DEM (1 m cells), one search per site")
    print(f"{'run':<28} {'time s':>8} {'ratio':>7}")
    print(f"{'serial (baseline)':<28} {t_serial:>8.1f} {1.0:>7.2f}")
    print(
        f"{f'dask LocalCluster, {a.workers} workers':<28} {t_dask:>8.1f} {t_dask / t_serial:>7.2f}"
    )
    print(f"same matrix: {same}; speed-up {t_serial / t_dask:.2f}x")
    return res


def scaling(sizes: list[int], target: int, n_sites: int, as_json: bool = False) -> dict:
    """Time one site's search per DEM size; extrapolate the full matrix from the largest."""
    import os

    from _hilly import X0, Y0, hilly_elevation

    import energy_planner as ep
    from energy_planner.mission import Sites, energy_matrix
    from energy_planner.terrain import Terrain

    model = ep.load_model()
    rows = []
    for size in sizes:
        ter = Terrain.from_array(hilly_elevation(size), resolution=1.0, origin=(X0, Y0))
        one = Sites(np.array([[X0 + size / 2, Y0 + size / 2]]), ["c"]).on_cells(ter)
        if not rows:
            energy_matrix(ter, model, one)  # compile once, not timed
        t0 = time.perf_counter()
        energy_matrix(ter, model, one)
        rows.append({"size": size, "search_s": time.perf_counter() - t0})
    last = rows[-1]
    per = last["search_s"] * (target / last["size"]) ** 2
    res = {
        "rows": rows,
        "load_average_1min": os.getloadavg()[0],
        "target_size": target,
        "extrapolated_search_s": per,
        "extrapolated_matrix_serial_s": per * n_sites,
    }
    if as_json:
        print(json.dumps(res, indent=2))
        return res
    print(f"one site's search (load average {res['load_average_1min']:.1f})")
    print(f"{'DEM':>11} {'search s':>9} {'s per 1e4 cells':>16}")
    for r in rows:
        print(f"{r['size']:>5} x {r['size']:<4} {r['search_s']:>9.1f} "
              f"{r['search_s'] / r['size'] ** 2 * 1e4:>16.2f}")  # fmt: skip
    print(f"extrapolated to {target} x {target}: {per / 60:.0f} min per search, "
          f"{per * n_sites / 3600:.1f} h for {n_sites} sites serial")  # fmt: skip
    return res


if __name__ == "__main__":
    main()
