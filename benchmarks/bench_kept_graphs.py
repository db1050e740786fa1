"""Work a problem keeps for its next plan: the lattice graph and the search's bound table.

Two things a plan of a :class:`~energy_planner.problem.Problem` prices that the next plan
of the same problem needs again:

- ``lattice``: the energy lattice's graph (every edge priced by the motion kernel) is the
  same for every goal from one start; :func:`energy_planner.planning.lattice.kept_graph`
  keeps the last one per terrain (as ``reach``'s round trips did), so a second lattice
  plan from that start searches it again.
- ``search``: the search's bound table (:func:`energy_planner.planning.search.bound_table`)
  is read by ``prepare_bound`` before a plan's clock, by the search itself and by
  ``reach``'s move bounds: each cost now keeps its tables (a cost that chooses its speed
  already did), where a fixed-speed cost rebuilt its heading cost and looked its grid up
  in the memo each time (about 5 ms a call).

Each case runs in a child process on this tree and on a baseline tree (``--baseline``,
default ``/work/main``: the method before), alternating, after a warm-up that loads the
compiled kernels; printed per case: CPU s of each (median of ``--repeat``), their ratio,
and whether the two results are identical (a hash of every plan's cost and poses).

Measured (2026-11-30, ``--repeat 3``, 2 cores shared with other jobs, load 3.7-4.6,
baseline main 124c0f5)::

    case                                  CPU s base / new  ratio  same
    3 lattice plans, one start (hill)        6.91 /   2.82   2.45   yes
    20 search plans (hill, 4 legs x 5)       0.98 /   0.60   1.62   yes

Usage::

    python benchmarks/bench_kept_graphs.py [--repeat 3] [--baseline /work/main]
"""

from __future__ import annotations

import os
from pathlib import Path

from _trees import alternate, tree_parser

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

CHILD = r"""
import hashlib, json, sys, time
import numpy as np
case = sys.argv[1]
from energy_planner import api
from energy_planner.planning.lattice import lattice_plan
from energy_planner.planning.search import prepare_bound, search_plan

def sha(results):
    h = hashlib.sha1()
    for r in results:
        h.update(np.array([r.cost]).tobytes())
        h.update(np.ascontiguousarray(r.states).tobytes())
    return h.hexdigest()[:12]

prob = api._problem("hill", None, None)
x0, y0, dx, dy = prob.terrain.grid
ny, nx = prob.terrain.shape
xs = sorted((x0, x0 + (nx - 1) * dx)); ys = sorted((y0, y0 + (ny - 1) * dy))
s = (xs[0] + 10.5, ys[0] + 10.5, None)
goals = [(xs[1] - 10.5, ys[1] - 10.5, None), (xs[1] - 10.5, ys[0] + 12.5, None),
         (xs[0] + 12.5, ys[1] - 10.5, None)]
if case == "lattice":
    # warm-up on another problem of the same model (kernels loaded, nothing kept)
    other = api._problem("hill", None, None)
    lattice_plan(other, s, (s[0] + 2, s[1] + 2, None), step=2.0)
    t = time.process_time()
    res = [lattice_plan(prob, s, g, step=2.0) for g in goals]
    cpu = time.process_time() - t
else:
    legs = [(s, goals[0]), (goals[0], goals[1]), (goals[1], goals[2]), (goals[2], s)]
    search_plan(prob, s, (s[0] + 3, s[1] + 3, None))  # warm-up
    t = time.process_time()
    res = []
    for _ in range(5):  # a mission's legs, each prepared before its clock as plan() does
        for a, b in legs:
            prepare_bound(prob, a)
            res.append(search_plan(prob, a, b, eps=1.05))
    cpu = time.process_time() - t
print(json.dumps({"cpu_s": cpu, "sha": sha(res)}))
"""

CASES = {
    "lattice": "3 lattice plans, one start (hill)",
    "search": "20 search plans (hill, 4 legs x 5)",
}


def main(argv: list[str] | None = None) -> dict:
    a = tree_parser(__doc__, CASES).parse_args(argv)

    print(f"# uptime: {os.popen('uptime').read().strip()}", flush=True)
    print(f"{'case':36s} {'CPU s base / new':>17s} {'ratio':>6s} {'same':>5s}", flush=True)
    out = {}
    for case in a.cases.split(","):
        base, new, cb, cn = alternate(Path(a.baseline), ROOT, a.repeat, CHILD, case)
        same = all(r["sha"] == base[0]["sha"] for r in base + new)
        out[case] = {"cpu_s_base": cb, "cpu_s_new": cn, "ratio": cb / cn, "same": same}
        print(f"{CASES[case]:36s} {cb:8.2f} / {cn:6.2f} {cb / cn:6.2f} "
              f"{'yes' if same else 'NO':>5s}", flush=True)  # fmt: skip
    print(f"# uptime: {os.popen('uptime').read().strip()}")
    return out


if __name__ == "__main__":
    main()
