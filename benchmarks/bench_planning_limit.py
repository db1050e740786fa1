"""The search under a slope limit: its bound next to the limit, before and after.

Usage::

    python benchmarks/bench_planning_limit.py [--repeat 3] [--limits none,25,30,40]

The routes of README.md and of ``compare-routes``' help on the bundled hill (foot to
top, 38 m and 63 m), planned by the full-resolution search (``planner="search"``,
``eps = 1.05``) under each slope limit, in one process two ways side by side:

* ``inf past the limit``: the bound table's nodes past the slope limit left ``inf``, so a
  walkable sample next to the limit is priced at the table's least (the search as it
  was: ``energy_planner.planning.search._past_the_limit`` switched off);
* ``physics past it``: those nodes (within one cell diagonal of the limit, the only ones
  a walkable sample reads) hold the same heading cost without the limit.

Per row: CPU seconds of the plan (median of ``--repeat``, kernels and tables loaded
before), states expanded, ``h(start) / cost`` (how tight the bound is) and the path's
energy; then the ratio of the CPU seconds. Measured on the 2-core machine of the suite
(load 3-5 from other jobs; CPU seconds, not wall), 2026-11-30:

    route  limit | inf past the limit: cpu s, expanded, h/cost, J |   physics past it | ratio
    38 m    none |      0.04     209   0.96    95362 |      0.04     209   0.96    95362 | 1.0
    38 m    25.0 |      3.64  187327   0.87   113681 |      0.10    2597   0.95   114202 | 34.8
    38 m    30.0 |      4.03  206920   0.86   104076 |      0.05     550   0.96   104046 | 84.3
    38 m    40.0 |      5.83  318418   0.67    95788 |      0.04     244   0.96    95607 | 130.6
    63 m    none |      0.17    5478   0.94    97079 |      0.13    5478   0.94    97079 | 1.3
    63 m    25.0 |      5.20  260831   0.83   115439 |      0.05     279   0.96   115548 | 107.1
    63 m    30.0 |      4.83  255620   0.80   100503 |      0.08    2806   0.95   100612 | 62.7
    63 m    40.0 |      5.51  284334   0.75    96935 |      0.15    4690   0.94    97182 | 37.6

(``--repeat 1``; the 38 m route under 40 degrees is README.md's ``ep.plan(prob, ...,
max_slope_deg=40)``, the 63 m one under 30 ``compare-routes``' help example.)
The energies differ by under 0.5 % (``eps = 1.05`` bounds both at 5 % of the optimum on
the primitives; which path within it the weighted search returns depends on the bound).
"""

from __future__ import annotations

import argparse
import statistics
import time

ROUTES = {"38 m": ((500058, 5000046), (500058, 5000084)),
          "63 m": ((500058, 5000046), (500058, 5000109))}  # fmt: skip


def run(start, goal, limit, repeat: int) -> dict:
    """CPU seconds (median), states expanded, h(start) / cost and energy of the search."""
    from energy_planner.planning.plan import plan
    from energy_planner.problem import Problem

    problem = Problem.from_dem("hill", max_slope_deg=limit)
    plan(problem, start, goal, planner="search", progress=False)  # tables, kernels
    cpu = []
    for _ in range(repeat):
        t0 = time.process_time()
        res = plan(problem, start, goal, planner="search", progress=False)
        cpu.append(time.process_time() - t0)
    s = res.info["search"]
    return {"cpu": statistics.median(cpu), "expanded": s["expanded"],
            "tight": s["h_start_j"] / res.energy_j, "energy": res.energy_j}  # fmt: skip


def main() -> None:
    import energy_planner.planning.search as search
    from energy_planner.errors import EnergyPlannerError

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--limits", default="none,25,30,40")
    args = ap.parse_args()
    limits = [None if v == "none" else float(v) for v in args.limits.split(",")]
    past = search._past_the_limit
    head = "inf past the limit: cpu s, expanded, h/cost, J"
    print(f"{'route':<6} {'limit':>5} | {head:>33} | {'physics past it':>33} | ratio")
    for name, (start, goal) in ROUTES.items():
        for limit in limits:
            rows = []
            try:
                for fill in (False, True):
                    search._past_the_limit = past if fill else (lambda *a, **k: None)
                    rows.append(run(start, goal, limit, args.repeat))
            except EnergyPlannerError as exc:
                print(f"{name:<6} {limit or 'none'!s:>5} | {exc}")
                continue
            finally:
                search._past_the_limit = past
            cells = [f"{r['cpu']:8.2f} {r['expanded']:7d} {r['tight']:6.2f} {r['energy']:8.0f}"
                     for r in rows]  # fmt: skip
            ratio = rows[0]["cpu"] / max(rows[1]["cpu"], 1e-9)
            print(f"{name:<6} {limit or 'none'!s:>5} | {cells[0]:>33} | {cells[1]:>33} | "
                  f"{ratio:.1f}")  # fmt: skip


if __name__ == "__main__":
    main()
