"""The matrix's second window pass with and without the first pass's edges (issue 32).

When the first window's proof fails (:func:`energy_planner.mission.matrix.matrix_search`)
the searches run again on the grown window. The second pass takes the edges the first
one priced inside the first window (:func:`energy_planner.mission.matrix._carry_cache`);
the baseline, run side by side in the same process and at the same load, prices them all
again (``_carry_cache`` replaced by a function that copies nothing: the method before
issue 32). Cases: the README's mission (``--dem hill --sites hill_sites``, the bundled
model, eps 1) and a 5 % plane with a keep-out wall between two sites (the way round
leaves the first window). Printed per case: passes, states expanded, edges priced, the
CPU s of each method (median of ``--repeat`` alternated runs, after a warm-up that
compiles the kernels) and their ratio, and the largest difference of the two matrices
(must be 0: the same float32 prices).

Measured (2026-11-30, ``--repeat 3``, 2 cores shared with other jobs, load 3.5-4.7)::

    case (2 passes each)  expanded  priced before / after  CPU s before / after  ratio  diff J
    README mission          117786      1954008 / 977004           4.08 / 2.22   1.84     0.0
    plane with a wall        22837       382950 / 194634           0.67 / 0.38   1.79     0.0

Run again at load 3.4: 3.62 / 2.28 (1.59) and 0.77 / 0.44 (1.74); the edges priced
and the matrices do not change from run to run.

On the README's mission the second pass prices no edge at all (its searches expand only
states the first pass priced inside the first window); what is left of it is the
heuristics over the grown window and the heap.

Usage::

    python benchmarks/bench_mission_passes.py [--repeat 3] [--json]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np


def _readme():
    """As the command loads them: the bundled DEM, the default model, no limits."""
    from energy_planner.cli.plan import load_terrain
    from energy_planner.maps import map_path
    from energy_planner.mission.sites import read_sites
    from energy_planner.model import EnergyModel

    ter = load_terrain(map_path("hill"))
    return ter, EnergyModel.default(), read_sites("hill_sites", ter).on_cells(ter), None


def _wall():
    from shapely.geometry import box

    from energy_planner.mission import Sites
    from energy_planner.model import EnergyModel
    from energy_planner.request import Request
    from energy_planner.terrain import Terrain

    y, x = np.mgrid[0:120, 0:120]
    ter = Terrain.from_array(0.05 * x.astype(float), resolution=1.0, origin=(0.0, 0.0))
    req = Request.make(keep_out=[box(59.4, 42.0, 60.6, 78.0)])
    s = Sites(np.array([[50.0, 60.0], [70.0, 60.0]]), ["a", "b"])
    return ter, EnergyModel.default(), s.on_cells(ter), req


CASES = {"README mission (hill, hill_sites)": _readme, "plane with a wall, 120 m": _wall}


def _timed(ter, model, sites, req, carry: bool):
    from energy_planner.mission import matrix as mx

    keep = mx._carry_cache
    if not carry:
        mx._carry_cache = lambda *a: 0
    try:
        t = time.process_time()
        res = mx.matrix_search(ter, model, sites, req)
        return time.process_time() - t, res
    finally:
        mx._carry_cache = keep


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)
    out = {}
    for name, make in CASES.items():
        ter, model, sites, req = make()
        _timed(ter, model, sites, req, True)  # warm-up: the kernels compiled
        before, after = [], []
        for _ in range(a.repeat):  # alternated, so that both see the same load
            tb, rb = _timed(ter, model, sites, req, False)
            ta, ra = _timed(ter, model, sites, req, True)
            before.append(tb)
            after.append(ta)
        row = {
            "passes": ra.info["passes"],
            "expanded": ra.info["expanded"],
            "priced_before": rb.info["priced"],
            "priced_after": ra.info["priced"],
            "carried_states": ra.info["carried"],
            "cpu_s_before": float(np.median(before)),
            "cpu_s_after": float(np.median(after)),
            "max_abs_diff_j": float(np.max(np.abs(ra.energy_j - rb.energy_j))),
        }
        row["ratio"] = row["cpu_s_before"] / row["cpu_s_after"]
        out[name] = row
    if a.json:
        print(json.dumps(out, indent=1))
    else:
        head = ("case", "passes", "expanded", "priced before", "after", "CPU s before",
                "after", "ratio", "diff J")  # fmt: skip
        print("{:36s} {:>6s} {:>9s} {:>14s} {:>9s} {:>12s} {:>7s} {:>6s} {:>7s}".format(*head))
        for name, r in out.items():
            print(f"{name:36s} {r['passes']:6d} {r['expanded']:9d} {r['priced_before']:14d} "
                  f"{r['priced_after']:9d} {r['cpu_s_before']:12.2f} {r['cpu_s_after']:7.2f} "
                  f"{r['ratio']:6.2f} {r['max_abs_diff_j']:7.1f}")  # fmt: skip
    return out


if __name__ == "__main__":
    main()
