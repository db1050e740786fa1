"""Time and peak memory of the lattice search at several resolutions (bundled hill).

Usage::

    python benchmarks/bench_lattice.py [--steps 4,2,1.41,1] [--moves axes]

Each resolution runs in a fresh process (so peak RSS is its own): graph build (edge
costs from ``MotionCost.batch``, CSR assembly), Dijkstra (``scipy.sparse.csgraph``),
nodes, edges, energy of the path and the peak resident memory of the process. The
kernels are compiled (and cached on disk) before the clock starts.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

CHILD = r"""
import json, resource, sys, time
import numpy as np
from energy_planner.maps import scenario
from energy_planner.model import EnergyModel
from energy_planner.energy import path_energy
from energy_planner.planning.lattice import lattice_plan
from energy_planner.planning.limits import make_motion_cost
from energy_planner.terrain import load_dem
step, moves = float(sys.argv[1]), sys.argv[2]
sc = scenario("hill"); t = load_dem(sc["path"]); m = EnergyModel.default()
cost, _ = make_motion_cost(t, m, max_slope_deg=20)
z = np.zeros(1); cost.batch(z, z, z, z, z, z)
rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
s = (*t.to_work(*sc["start"]), None); g = (*t.to_work(*sc["goal"]), None)
t0 = time.perf_counter()
r = lattice_plan(cost, t, s, g, step=step, moves=moves)
wall = time.perf_counter() - t0
e = path_energy(t, m, r.states[:, :2], yaw=r.states[:, 2], cost=cost).energy_j
rss1 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps(dict(step=r.step, nodes=r.n_nodes, edges=r.n_edges, build=r.build_s,
                      search=r.search_s, wall=wall, energy=e,
                      peak_mb=rss1 / 1024, base_mb=rss0 / 1024)))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--steps", default="4,2,1.41,1")
    ap.add_argument("--moves", default="axes", choices=["axes", "crab", "all"])
    args = ap.parse_args()
    print(f"# hill scenario, max slope 20 deg, 16 headings, moves={args.moves}")
    print("| step m | nodes | edges | build s | Dijkstra s | total s | energy J | peak RSS MB "
          "(before search) |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    for step in args.steps.split(","):
        out = subprocess.run(
            [sys.executable, "-c", CHILD, step, args.moves], capture_output=True, text=True
        )
        if out.returncode != 0:
            print(f"| {step} | failed: {out.stderr.strip().splitlines()[-1]} |")
            continue
        r = json.loads(out.stdout.strip().splitlines()[-1])
        print(
            f"| {r['step']:.2f} | {r['nodes']} | {r['edges']} | {r['build']:.2f} | "
            f"{r['search']:.2f} | {r['wall']:.2f} | {r['energy']:.0f} | "
            f"{r['peak_mb']:.0f} ({r['base_mb']:.0f}) |"
        )


if __name__ == "__main__":
    main()
