"""The search's edges that cannot improve their end, left unpriced: a baseline tree side by side.

The on-demand searches (``reach``'s Dijkstra, ``plan``'s A*, the energy matrix's rows)
price an edge by the motion kernel when they expand its start. A translation to a state
already reached with ``g <= g(s) + move_lb[m]`` (``move_lb``: the least energy of the
move anywhere, the relaxed problem's least edge bound,
:func:`energy_planner.planning.search.move_bounds`) cannot lower that state's ``g``, so
it is left unpriced, and the matrix's edge cache keeps each edge (not each state's whole
row) as a row first needs it. The results are the same bit for bit; the kernel calls
fewer.

Each case runs in a child process on this tree and on a baseline tree (``--baseline``,
default ``/work/main``: the method before), alternating, after a warm-up call that loads
the compiled kernels; printed per case: CPU s of each (median of ``--repeat``) and their
ratio, states expanded, edges priced, and whether the two results are identical (a hash
of the energies: reach's whole grid and its path tree, the plan's cost and states, the
matrix's entries).

Measured (2026-11-30, ``--repeat 3``, 2 cores shared with other jobs, load 4.0-5.8,
baseline main 2aed1b8; the baseline's reach does not report its edges: 5,619,856 by a
counting copy of its loop)::

    case                                CPU s base / new  ratio   priced base / new  same
    reach hill, whole map                 10.95 /   6.71   1.63         - / 3012251   yes
    reach hill, within 15 Wh               2.92 /   1.69   1.73          - / 788901   yes
    plan hilly 400, eps 1                  6.14 /   4.04   1.52   2418209 / 1303988   yes
    matrix README mission (lazy)           2.42 /   1.13   2.14     977004 / 320683   yes
    matrix README mission (on demand)      2.61 /   1.88   1.39    1176732 / 650324   yes

Usage::

    python benchmarks/bench_unpriced_edges.py [--repeat 3] [--baseline /work/main]
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

from _trees import alternate, tree_parser

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

CHILD = r"""
import hashlib, json, math, sys, time
import numpy as np
case, dem = sys.argv[1], sys.argv[2]

def sha(*arrays):
    h = hashlib.sha1()
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:12]

if case.startswith("reach"):
    from energy_planner import api
    from energy_planner.planning.search import reach_search
    prob = api._problem("hill", None, None)
    x, y = api._pose(prob, (500058, 5000046), None)[:2]
    me = math.inf if case == "reach_whole" else 15 * 3600.0
    reach_search(prob.cost, prob.terrain, (x, y, None), max_energy=1.0)  # warm-up
    t = time.process_time()
    r = reach_search(prob.cost, prob.terrain, (x, y, None), max_energy=me, tree=True)
    cpu = time.process_time() - t
    out = {"expanded": r.expanded, "priced": getattr(r, "priced", None),
           "sha": sha(r.energy, *(r.tree[k] for k in sorted(r.tree)))}
elif case == "plan":
    from energy_planner.model import EnergyModel
    from energy_planner.planning.search import search_plan
    from energy_planner.problem import Problem
    from energy_planner.terrain import load_dem
    ter = load_dem(dem)
    prob = Problem(ter, EnergyModel.default())
    x0, y0, dx, dy = ter.grid
    ny, nx = ter.shape
    xs = sorted((x0, x0 + (nx - 1) * dx)); ys = sorted((y0, y0 + (ny - 1) * dy))
    s = (xs[0] + 5, ys[0] + 5, None); g = (xs[1] - 5, ys[1] - 5, None)
    search_plan(prob, s, (s[0] + 3, s[1] + 3, None), eps=1.0)  # warm-up
    t = time.process_time()
    r = search_plan(prob, s, g, eps=1.0)
    cpu = time.process_time() - t
    out = {"expanded": r.expanded, "priced": r.priced, "sha": sha(np.array([r.cost]), r.states)}
else:
    from energy_planner.cli.plan import load_terrain
    from energy_planner.maps import map_path
    from energy_planner.mission import Sites
    from energy_planner.mission.matrix import matrix_search
    from energy_planner.mission.sites import read_sites
    from energy_planner.model import EnergyModel
    ter = load_terrain(map_path("hill"))
    m = EnergyModel.default()
    sites = read_sites("hill_sites", ter).on_cells(ter)
    two = Sites(sites.xy[:2], sites.names[:2]).on_cells(ter)
    cache = None if case == "matrix_lazy" else False
    matrix_search(ter, m, two, edge_cache=cache)  # warm-up
    t = time.process_time()
    r = matrix_search(ter, m, sites, edge_cache=cache)
    cpu = time.process_time() - t
    out = {"expanded": r.info["expanded"], "priced": r.info["priced"], "sha": sha(r.energy_j)}
out["cpu_s"] = cpu
print(json.dumps(out))
"""

CASES = {
    "reach_whole": "reach hill, whole map",
    "reach_budget": "reach hill, within 15 Wh",
    "plan": "plan hilly 400, eps 1",
    "matrix_lazy": "matrix README mission (lazy)",
    "matrix_demand": "matrix README mission (on demand)",
}


def main(argv: list[str] | None = None) -> dict:
    a = tree_parser(__doc__, CASES).parse_args(argv)
    sys.path.insert(0, str(HERE))
    from _hilly import hilly_dem

    print(f"# uptime: {os.popen('uptime').read().strip()}", flush=True)
    out = {}
    with tempfile.TemporaryDirectory() as d:
        dem = hilly_dem(400, Path(d) / "hilly_400.tif")
        print(f"{'case':34s} {'CPU s base / new':>17s} {'ratio':>6s} "
              f"{'priced base / new':>19s} {'same':>5s}", flush=True)  # fmt: skip
        for case in a.cases.split(","):
            base, new, cb, cn = alternate(Path(a.baseline), ROOT, a.repeat, CHILD, case, str(dem))
            same = base[0]["sha"] == new[0]["sha"] and base[0]["expanded"] == new[0]["expanded"]
            row = {"cpu_s_base": cb, "cpu_s_new": cn, "ratio": cb / cn, "same": same,
                   "expanded": new[0]["expanded"], "priced_base": base[0]["priced"],
                   "priced_new": new[0]["priced"]}  # fmt: skip
            out[case] = row
            pb, pn = row["priced_base"], row["priced_new"]
            priced = f"{pb or '-'} / {pn}"
            print(f"{CASES[case]:34s} {cb:8.2f} / {cn:6.2f} {cb / cn:6.2f} {priced:>19s} "
                  f"{'yes' if same else 'NO':>5s}", flush=True)  # fmt: skip
    print(f"# uptime: {os.popen('uptime').read().strip()}")
    return out


if __name__ == "__main__":
    main()
