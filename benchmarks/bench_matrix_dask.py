"""The mission matrix on a dask LocalCluster: its CPU over every process against serial.

Issue 32, point 3: on a ``dask.distributed`` cluster the matrix's work must divide without
overhead beyond 10 %. The matrix of ``--sites`` random sites (``bench_peers.mission_sites``)
on the ``--size``² hilly DEM (``_hilly.py``, 1 m; cells steeper than ``--max-slope`` are
barriers; ``eps`` 1.05, the plan's default) is computed ``--repeat`` times, serial and on
a LocalCluster of ``--workers`` single-threaded worker processes alternating, each run in
its own process after a warm-up (a two-site matrix: the kernels loaded, the cluster
started), so that both are warm. The cluster is configured as docs/routes.md tells a
cluster's user to (:data:`energy_planner.mission.matrix.CLUSTER_CONFIG`); ``--config
default`` keeps dask's defaults instead, for comparison.

Printed per run: wall time and the matrix's CPU time, serial (this process) and on the
cluster over every process: the client's process (its main thread, where
``matrix_search`` prepares and waits, and its other threads: the client's and the
scheduler's and the nannies' event loop: a LocalCluster runs them in the client's process),
the workers (their task threads, their event loops, their other threads) and any other
process the cluster started; and the ratio of the cluster's CPU to the serial run's (target:
at most 1.10). The matrices must be equal (0 J apart).

Usage::

    python benchmarks/bench_matrix_dask.py --size 1000 --repeat 2
    python benchmarks/bench_matrix_dask.py --size 300 --config default   # dask's defaults

On a machine without free cores the cluster's wall time cannot fall; its CPU time shows
whether the work divides.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def _threads() -> dict[str, float]:
    """CPU seconds of each thread of the calling process, by name (unnamed: by its id)."""
    import threading

    import psutil

    names = {t.native_id: t.name for t in threading.enumerate()}
    out: dict[str, float] = {}
    for t in psutil.Process().threads():
        name = names.get(t.id, f"native-{t.id}")
        out[name] = out.get(name, 0.0) + t.user_time + t.system_time
    return out


def _delta(after: dict[str, float], before: dict[str, float]) -> dict[str, float]:
    return {k: v - before.get(k, 0.0) for k, v in after.items()}


def _tree_cpu() -> dict[int, float]:
    """CPU seconds of each descendant process of this one, by pid."""
    import psutil

    out = {}
    for p in psutil.Process().children(recursive=True):
        try:
            out[p.pid] = sum(p.cpu_times()[:2])
        except psutil.Error:
            pass
    return out


def child(spec: dict) -> dict:
    """One run, in this process: the warm-up, then the matrix, timed (serial or on dask)."""
    import numpy as np

    from energy_planner.mission import Sites
    from energy_planner.mission.matrix import CLUSTER_CONFIG, matrix_search
    from energy_planner.model import EnergyModel
    from energy_planner.request import Request
    from energy_planner.terrain import load_dem

    model = EnergyModel.default()
    req = Request.make(max_slope_deg=spec["max_slope"])
    ter = load_dem(spec["dem"])
    xy = np.array(spec["sites"], float)
    sites = Sites(np.column_stack(ter.to_work(xy[:, 0], xy[:, 1])),
                  [f"s{i}" for i in range(len(xy))]).on_cells(ter)  # fmt: skip
    two = Sites(sites.xy[:2], ["w0", "w1"])
    client = cluster = None
    if spec["workers"]:
        import dask
        from distributed import Client, LocalCluster

        if spec["config"] == "library":
            dask.config.set(CLUSTER_CONFIG)
        cluster = LocalCluster(n_workers=spec["workers"], threads_per_worker=1,
                               processes=True, dashboard_address=None)  # fmt: skip
        client = Client(cluster)
    matrix_search(ter, model, two, req, eps=spec["eps"], client=client)  # warm-up
    time.sleep(1.0)
    workers0 = client.run(_threads) if client is not None else {}
    tree0, own0 = _tree_cpu(), _threads()
    t0 = time.perf_counter()
    res = matrix_search(ter, model, sites, req, eps=spec["eps"], client=client)
    wall = time.perf_counter() - t0
    own = _delta(_threads(), own0)
    tree = _delta(_tree_cpu(), tree0)
    out = {"wall_s": wall, "priced": res.info["priced"], "expanded": res.info["expanded"],
           "main_s": own.pop("MainThread", 0.0), "client_other_s": sum(own.values()),
           "client_threads": own}  # fmt: skip
    if client is not None:
        wth = {w: _delta(v, workers0.get(w, {})) for w, v in client.run(_threads).items()}
        pids = client.run(os.getpid)
        task = sum(v for d in wth.values() for k, v in d.items() if "Dask-Default-Threads" in k)
        loop = sum(d.get("MainThread", 0.0) for d in wth.values())
        workers = sum(tree.get(p, 0.0) for p in pids.values())
        out.update(task_s=task, worker_loop_s=loop, worker_other_s=workers - task - loop,
                   nanny_s=sum(tree.values()) - workers,
                   worker_threads=list(wth.values()))  # fmt: skip
        client.close()
        cluster.close()
    out["cpu_s"] = (
        out["main_s"]
        + out["client_other_s"]
        + sum(out.get(k, 0.0) for k in ("task_s", "worker_loop_s", "worker_other_s", "nanny_s"))
    )
    np.save(spec["out"], res.energy_j)
    return out


def _run_child(spec: dict, timeout: float) -> dict:
    cmd = [sys.executable, __file__, "--child", json.dumps(spec)]
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": f"killed at {timeout:.0f} s"}
    if p.returncode != 0:
        return {"error": (p.stderr.strip().splitlines() or ["?"])[-1][:300]}
    return json.loads(p.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> dict:
    """Run the benchmark and print its table."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=1000, help="DEM side, cells of 1 m")
    ap.add_argument("--sites", type=int, default=20)
    ap.add_argument("--max-slope", type=float, default=15.0, help="barriers: steeper cells")
    ap.add_argument("--eps", type=float, default=1.05)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=1, help="pairs of runs, alternating")
    ap.add_argument("--config", choices=("library", "default"), default="library",
                    help="the cluster's dask configuration: the one docs/routes.md tells "
                    "users to set (CLUSTER_CONFIG) or dask's defaults")  # fmt: skip
    ap.add_argument("--timeout", type=float, default=3600.0)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        print(json.dumps(child(json.loads(a.child))))
        return {}
    sys.path.insert(0, str(HERE))
    import numpy as np
    from _hilly import hilly_dem
    from bench_peers import mission_sites

    load0 = os.getloadavg()[0]
    runs = []
    with tempfile.TemporaryDirectory() as d:
        dem = hilly_dem(a.size, Path(d) / f"hilly_{a.size}.tif")
        spec = {"dem": str(dem), "sites": mission_sites(a.size, a.sites), "eps": a.eps,
                "max_slope": a.max_slope, "config": a.config}  # fmt: skip
        for k in range(a.repeat):
            pair = {}
            for mode, workers in (("serial", 0), ("dask", a.workers)):
                out = str(Path(d) / f"{mode}{k}.npy")
                r = _run_child({**spec, "workers": workers, "out": out}, a.timeout)
                r["load"] = os.getloadavg()[0]
                if "error" not in r:
                    r["matrix"] = np.load(out)
                pair[mode] = r
                print(f"# {mode} {k}: " + json.dumps({k2: v for k2, v in r.items()
                                                       if k2 != "matrix"}),
                      file=sys.stderr, flush=True)  # fmt: skip
            s, c = pair["serial"], pair["dask"]
            if "error" not in s and "error" not in c:
                diff = np.where(np.isfinite(s["matrix"]), np.abs(s["matrix"] - c["matrix"]), 0)
                same = np.array_equal(np.isinf(s["matrix"]), np.isinf(c["matrix"]))
                pair["max_diff_j"] = float(diff.max()) if same else float("inf")
                pair["ratio"] = c["cpu_s"] / s["cpu_s"]
            for r in pair.values():
                if isinstance(r, dict):
                    r.pop("matrix", None)
            runs.append(pair)
    out = {"size": a.size, "sites": a.sites, "workers": a.workers, "eps": a.eps,
           "config": a.config, "load_start": load0, "load_end": os.getloadavg()[0],
           "runs": runs}  # fmt: skip
    if a.json:
        print(json.dumps(out, indent=2))
        return out
    print(f"# {a.sites} sites on the {a.size}² hilly DEM, eps {a.eps:g}, cells steeper than "
          f"{a.max_slope:g}° barriers; LocalCluster of {a.workers} single-threaded workers, "
          f"{'CLUSTER_CONFIG' if a.config == 'library' else 'dask defaults'}; load "
          f"{load0:.1f} -> {out['load_end']:.1f} on {os.cpu_count()} cores")  # fmt: skip
    print("| run | wall s | CPU s | client's main thread | client's loop (scheduler, nannies)"
          " | workers' tasks | workers' loops | workers' other threads | other processes | "
          "ratio (CPU) | max diff J |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for k, pair in enumerate(runs):
        for mode in ("serial", "dask"):
            r = pair[mode]
            if "error" in r:
                print(f"| {mode} {k} | {r['error']} |" + " |" * 9)
                continue
            parts = [r["main_s"], r["client_other_s"]] + [
                r.get(f, float("nan"))
                for f in ("task_s", "worker_loop_s", "worker_other_s", "nanny_s")
            ]
            rat = f"{pair['ratio']:.3f}" if mode == "dask" and "ratio" in pair else "1.000"
            dj = f"{pair['max_diff_j']:g}" if mode == "dask" and "max_diff_j" in pair else ""
            print(f"| {mode} {k} (load {r['load']:.1f}) | {r['wall_s']:.1f} | {r['cpu_s']:.1f}"
                  f" | " + " | ".join("" if v != v else f"{v:.2f}" for v in parts)
                  + f" | {rat} | {dj} |")  # fmt: skip
    return out


if __name__ == "__main__":
    main()
