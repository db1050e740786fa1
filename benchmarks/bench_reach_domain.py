"""What a reach map's per-cell domain report costs: reach with and without it, side by side.

Usage::

    python benchmarks/bench_reach_domain.py [--size 1000] [--repeats 3] [--budget-wh B]
        [--return] [--maps hill,synthetic]

Runs :func:`energy_planner.planning.reach.reach` from the Fig. 1 start on the bundled hill
(``maps/hill.tif``, 200 x 200 cells at 1 m) and on a synthetic ``--size`` x ``--size`` map
at 1 m (two hills 120 and 60 m high whose widths scale with the map, 31 deg at their
steepest at 1000 cells, and a tilt; start in its south-west quarter), each with the
bundled model
as it is (no calibration domain: no per-cell report, the search alone) and with the same
model given a calibration domain (slopes to 12 deg, forward walking and turning: the tree
of least-energy paths is read from the search, its motions priced and sampled, the columns
summed along it). The two runs alternate, ``--repeats`` times each; the script prints
each run's wall and CPU time, the domain step's own time (``info["domain_s"]``) and the
ratio of the medians, with the load average before and after (the machine is shared).

Both runs search the same states with the same kernel: the difference is the domain
report, and the numbers it reports do not depend on the time it takes.

Measured when the report was added (2 shared cores; wall times are dominated by the other
processes, CPU times are the comparison):

- ``--maps hill --repeats 5`` at load 0.7-1.7: median CPU 9.87 s without, 10.60 s with
  (1.074 x), the step 0.38 s (median); ``--repeats 3`` at load 0.3-0.8: pairs 9.61 / 10.86,
  10.50 / 10.88, 9.60 / 9.96 s (1.04-1.13 x), the step 0.40 s.
- ``--maps hill --repeats 3`` at load 3.4-4.5: CPU 10.80 / 11.07 / 11.38 s without,
  11.28 / 11.69 / 11.10 s with (medians 1.02 x); the report's step 0.40-1.27 s of wall;
  39 204 cells, 11 467 outside. The code before the report on the same map (its reach
  ignores the domain): 11.50 and 10.91 s of CPU.
- ``--maps synthetic --size 1000 --repeats 1`` at load 1.3-6: CPU 344.7 s without, 348.4 s
  with (1.011 x), step 18.6 s of wall; 996 004 cells, 469 242 outside. (The same with hills
  a quarter as high, none outside: 347.6 s and 355.7 s, 1.023 x, step 15.9 s.)
"""

from __future__ import annotations

import argparse
import os
import statistics
import time


def _domain_model():
    import energy_planner as ep

    m = ep.load_model()
    dom = {"max_slope_deg": 12.0, "speed_m_s": [0.2, 0.45], "max_turn_rate_rad_s": 0.6,
           "gaits": {"forward": {"windows": 9, "rel_heading_deg": [0.0, 180.0]},
                     "turning": {"windows": 9, "rel_heading_deg": None}}}  # fmt: skip
    m.metadata = dict(m.metadata, fit=dict(m.metadata.get("fit") or {}, domain=dom))
    return m


def _synthetic(size: int):
    import numpy as np

    from energy_planner.terrain import Terrain

    s = float(size)

    def z(x, y):
        x, y = x - 500000.0, y - 5000000.0
        h1 = 120.0 * np.exp(-((x - 0.6 * s) ** 2 + (y - 0.55 * s) ** 2) / (2 * (0.12 * s) ** 2))
        h2 = 60.0 * np.exp(-((x - 0.3 * s) ** 2 + (y - 0.75 * s) ** 2) / (2 * (0.08 * s) ** 2))
        return h1 + h2 + 0.02 * x

    return Terrain.from_function(z, size=(s, s), origin=(500000.0, 5000000.0))


def main() -> None:
    import energy_planner as ep
    from energy_planner.maps import map_path, scenario
    from energy_planner.planning.reach import reach
    from energy_planner.terrain import load_dem

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=1000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--budget-wh", type=float, default=None, help="search only this far")
    ap.add_argument("--return", dest="round_trip", action="store_true")
    ap.add_argument("--maps", default="hill,synthetic", help="which: hill, synthetic or both")
    args = ap.parse_args()

    plain, with_domain = ep.load_model(), _domain_model()
    maps = []
    if "hill" in args.maps:
        hill = load_dem(map_path("hill"))
        maps.append(("hill 200x200", hill, hill.to_work(*scenario("hill")["start"])))
    if "synthetic" in args.maps:
        n = args.size
        start = (500000.0 + 0.25 * n + 0.5, 5000000.0 + 0.3 * n + 0.5)
        maps.append((f"synthetic {n}x{n}", _synthetic(n), start))
    budget = None if args.budget_wh is None else args.budget_wh * 3600.0
    print(f"# load average before: {os.getloadavg()}")
    for name, terrain, start in maps:
        # warm-up: compile / load the kernels and the tree functions once for both
        for m in (plain, with_domain):
            reach(ep.Problem(terrain, m), start, max_energy=100.0)
        times: dict[str, list[tuple[float, float]]] = {"plain": [], "domain": []}
        dom_s = []
        for _ in range(args.repeats):
            for label, m in (("plain", plain), ("domain", with_domain)):
                prob = ep.Problem(terrain, m)
                w0, c0 = time.perf_counter(), time.process_time()
                res = reach(prob, start, max_energy=budget, round_trip=args.round_trip)
                wall, cpu = time.perf_counter() - w0, time.process_time() - c0
                times[label].append((wall, cpu))
                if label == "domain":
                    dom_s.append(res.info["domain_s"])
                    d = res.domain
                print(f"{name:<22} {label:<7} wall {wall:7.2f} s  cpu {cpu:7.2f} s"
                      + (f"  (domain step {res.info['domain_s']:.2f} s)" if label == "domain"
                         else ""))  # fmt: skip
        med = {k: statistics.median(w for w, _ in v) for k, v in times.items()}
        medc = {k: statistics.median(c for _, c in v) for k, v in times.items()}
        print(f"# {name}: median wall plain {med['plain']:.2f} s, with domain "
              f"{med['domain']:.2f} s ({med['domain'] / med['plain']:.3f} x); CPU "
              f"{medc['plain']:.2f} -> {medc['domain']:.2f} s "
              f"({medc['domain'] / medc['plain']:.3f} x); domain step median "
              f"{statistics.median(dom_s):.2f} s; {d['reached_cells']} cells, "
              f"{d['outside_cells']} outside")  # fmt: skip
    print(f"# load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
