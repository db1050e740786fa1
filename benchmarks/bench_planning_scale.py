"""Issue 11's table, rerun: the default planner at 1 m on hilly DEMs of growing size.

Usage::

    python benchmarks/bench_planning_scale.py [--sizes 200,400,800,1600,3200]
        [--lattice-sizes 200,400] [--eps 1.05] [--timeout 900] [--max-slope DEG]

For each size a hilly synthetic DEM (``benchmarks/_hilly.py``: 1 m cells, EPSG:32631) is
written to a temporary directory and planned corner to corner (5 cells inside), each
planner in a fresh process so that peak RSS is its own:

* ``auto``: the default ``plan()`` (full-resolution search at the DEM's cell size, then
  the refinement), timed from before ``load_dem`` to the result, kernel compilation
  included (the numba cache is warm after the first size);
* ``search``: the search alone, and with ``--eps 1`` (optimal on its primitives) where
  ``--optimal-sizes`` asks for it;
* ``lattice``: the full lattice at step 1 m (every edge priced up front) where
  ``--lattice-sizes`` asks for it.

Printed: wall time, peak RSS, energy (``path_energy`` of the returned poses, which is what
``plan`` returns) and its ratio to the full lattice's (or to the eps = 1 search's, the same
optimum), states expanded. ``uptime`` load is printed with the table: the machine is shared.
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

CHILD = r"""
import json, math, resource, sys, time
sys.path.insert(0, sys.argv[1])
t0 = time.perf_counter()
from energy_planner.model import EnergyModel
from energy_planner.planning.plan import plan
from energy_planner.terrain import load_dem
from _hilly import corners
path, size, planner, eps = sys.argv[2], int(sys.argv[3]), sys.argv[4], float(sys.argv[5])
from energy_planner.request import Request
req = Request.make(max_slope_deg=float(sys.argv[6]) if sys.argv[6] != "none" else None)
t = load_dem(path)
m = EnergyModel.default()
a, b = corners(size)
s = t.to_work(*a); g = t.to_work(*b)
t1 = time.perf_counter()
kw = dict(step=1.0) if planner == "lattice" else dict(eps=eps)
r = plan(t, m, s, g, req, planner=planner, progress=True, **kw)
t2 = time.perf_counter()
info = r.info.get("search") or r.info.get("lattice") or {}
print(json.dumps(dict(energy=r.energy_j, distance=r.distance_m, load_s=t1 - t0,
                      plan_s=t2 - t1, total_s=t2 - t0,
                      rss_gb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6,
                      expanded=info.get("expanded"), states=info.get("states") or info.get("nodes"),
                      heuristic_s=info.get("heuristic_s"), search_s=info.get("search_s"),
                      h_start=info.get("h_start_j"))))
"""


def run(path: Path, size: int, planner: str, eps: float, timeout: float, slope: str) -> dict:
    t0 = time.perf_counter()
    try:
        out = subprocess.run(
            [sys.executable, "-c", CHILD, str(HERE), str(path), str(size), planner, str(eps),
             slope],
            capture_output=True, text=True, timeout=timeout,
        )  # fmt: skip
    except subprocess.TimeoutExpired:
        return {"error": f"killed at {timeout:.0f} s"}
    if out.returncode != 0:
        last = (out.stderr.strip().splitlines() or ["?"])[-1]
        return {"error": f"failed after {time.perf_counter() - t0:.0f} s: {last}"}
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    sys.path.insert(0, str(HERE))
    from _hilly import hilly_dem

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="200,400,800,1600,3200")
    ap.add_argument("--lattice-sizes", default="200,400")
    ap.add_argument("--optimal-sizes", default="200,400,800")
    ap.add_argument("--eps", type=float, default=1.05)
    ap.add_argument("--timeout", type=float, default=900.0)
    ap.add_argument("--max-slope", default="none", help="slope limit, degrees (forces detours)")
    args = ap.parse_args()
    sizes = [int(v) for v in args.sizes.split(",") if v]
    lat_sizes = {int(v) for v in args.lattice_sizes.split(",") if v}
    opt_sizes = {int(v) for v in args.optimal_sizes.split(",") if v}
    print(f"# uptime: {os.popen('uptime').read().strip()}  (2 cores shared with other jobs)")
    print(f"# hilly DEMs at 1 m, corner to corner, default model, max slope {args.max_slope} "
          f"deg; eps={args.eps}")  # fmt: skip
    print("| DEM | planner | time s (load + plan) | peak RSS GB | energy J | vs optimum | "
          "expanded / states |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as d:
        for size in sizes:
            path = hilly_dem(size, Path(d) / f"hilly_{size}.tif")
            rows = [("auto", args.eps), ("search", args.eps)]
            if size in opt_sizes:
                rows.append(("search", 1.0))
            if size in lat_sizes:
                rows.append(("lattice", 1.0))
            res = {}
            for planner, eps in rows:
                res[(planner, eps)] = run(path, size, planner, eps, args.timeout, args.max_slope)
            ref = res.get(("lattice", 1.0), {}).get("energy") or res.get(("search", 1.0), {}).get(
                "energy"
            )
            for (planner, eps), r in res.items():
                name = planner if planner in ("auto", "lattice") else f"search eps={eps:g}"
                if planner == "lattice":
                    name = "full lattice, step 1 m"
                if "error" in r:
                    print(f"| {size} x {size} | {name} | {r['error']} | | | | |")
                    continue
                ratio = f"{r['energy'] / ref:.4f}" if ref else "n/a"
                exp = (
                    f"{r['expanded']:,} / {r['states']:,}"
                    if r.get("expanded") is not None
                    else f"- / {r['states']:,}"
                    if r.get("states")
                    else ""
                )
                print(
                    f"| {size} x {size} | {name} | {r['total_s']:.1f} ({r['load_s']:.1f} + "
                    f"{r['plan_s']:.1f}) | {r['rss_gb']:.2f} | {r['energy']:.0f} | {ratio} | "
                    f"{exp} |",
                    flush=True,
                )
            os.unlink(path)
    print(f"# uptime: {os.popen('uptime').read().strip()}")


if __name__ == "__main__":
    main()
