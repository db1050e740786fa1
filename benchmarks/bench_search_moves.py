"""The search alone on hilly 1 m DEMs, per move set: heuristic and search time, energy.

Usage::

    python benchmarks/bench_search_moves.py [--sizes 800,1600,3200] [--moves axes,all]
        [--eps 1.05]

For each size a hilly synthetic DEM (``benchmarks/_hilly.py``) is planned corner to corner
(5 cells inside) with :func:`energy_planner.planning.search.search_plan` (no refinement)
for each move set (``axes``: body-axis moves only; ``crab``: 8; ``all``: all 16 at every
heading, the default). Kernel and search compilation happen before the clock starts.
Printed: total time, the relaxed problem's (heuristic) and the search's share, states
expanded, edges priced, and ``path_energy`` of the returned poses, with ``uptime`` load
(the machine is shared).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main() -> None:
    sys.path.insert(0, str(HERE))
    from _hilly import corners, hilly_dem

    from energy_planner.energy import path_energy
    from energy_planner.model import EnergyModel
    from energy_planner.planning.limits import make_motion_cost
    from energy_planner.planning.search import search_module, search_plan
    from energy_planner.terrain import load_dem

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="800,1600,3200")
    ap.add_argument("--moves", default="axes,all")
    ap.add_argument("--eps", type=float, default=1.05)
    args = ap.parse_args()
    model = EnergyModel.default()
    print(f"# uptime: {os.popen('uptime').read().strip()}  (2 cores shared with other jobs)")
    print("| DEM | moves | total s | heuristic s | search s | expanded | edges priced | "
          "energy J | vs first move set |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|")
    for size in [int(v) for v in args.sizes.split(",") if v]:
        with tempfile.TemporaryDirectory() as d:
            terrain = load_dem(hilly_dem(size, Path(d) / f"hilly_{size}.tif"))
        cost, _ = make_motion_cost(terrain, model)
        search_module(cost)
        a, b = corners(size)
        s = (*terrain.to_work(*a), None)
        g = (*terrain.to_work(*b), None)
        ref = None
        for moves in args.moves.split(","):
            t0 = time.perf_counter()
            r = search_plan(cost, terrain, s, g, moves=moves, eps=args.eps)
            dt = time.perf_counter() - t0
            e = path_energy(terrain, model, r.states[:, :2], yaw=r.states[:, 2], cost=cost)
            ref = ref or e.energy_j
            print(f"| {size} x {size} | {moves} | {dt:.1f} | {r.heuristic_s:.1f} | "
                  f"{r.search_s:.1f} | {r.expanded:,} | {r.priced:,} | {e.energy_j:.0f} | "
                  f"{e.energy_j / ref:.4f} |", flush=True)  # fmt: skip
    print(f"# uptime: {os.popen('uptime').read().strip()}")


if __name__ == "__main__":
    main()
