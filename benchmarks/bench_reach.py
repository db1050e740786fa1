"""Battery reach on the bundled hill: time, and agreement with ``plan`` on the budget contour.

Usage::

    python benchmarks/bench_reach.py [--budget-wh 12] [--samples 8] [--model M.json]
        [--return [--free-turn]] [--png docs/img/reach_hill.png]

Runs :func:`energy_planner.planning.reach.reach` from the Fig. 1 start on ``maps/hill.tif``
(1 m cells, full resolution), picks ``--samples`` cells on the budget contour (cells within
the budget with a neighbour outside it, and a cost within 2 % of the budget), plans to each
with ``plan`` (``search`` at the same 1 m step: the same search with a goal, optimal
with ``eps=1`` and within its bound at the default ``eps``; and ``auto``, the default,
which refines the search's path off the grid) and prints the
energies side by side with their ratio to the reach value (with ``--return``: plan there
plus plan back, which ``--free-turn`` should equal). Records the load average
(the machine is shared).
"""

from __future__ import annotations

import argparse
import os
import time


def main() -> None:
    import numpy as np

    from energy_planner.maps import map_path, scenario
    from energy_planner.model import EnergyModel
    from energy_planner.planning.plan import plan
    from energy_planner.planning.reach import reach
    from energy_planner.terrain import load_dem

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--budget-wh", type=float, default=12.0)
    ap.add_argument("--samples", type=int, default=8)
    ap.add_argument("--model", default=None)
    ap.add_argument("--return", dest="round_trip", action="store_true")
    ap.add_argument("--free-turn", action="store_true", help="with --return: free heading at cell")
    ap.add_argument("--png", default=None)
    args = ap.parse_args()

    model = EnergyModel.load(args.model) if args.model else EnergyModel.default()
    terrain = load_dem(map_path("hill"))
    sc = scenario("hill")
    start = terrain.to_work(*sc["start"])
    print(f"# load average before: {os.getloadavg()}")
    t0 = time.perf_counter()
    res = reach(terrain, model, start, round_trip=args.round_trip,
                turn_at_cell=not args.free_turn)  # fmt: skip
    t_reach = time.perf_counter() - t0
    budget = args.budget_wh * 3600.0
    inside = res.mask(budget)
    print(
        f"# reach on {terrain.shape[0]} x {terrain.shape[1]} cells (1 m), "
        f"{res.info['states']} states: {t_reach:.1f} s; {int(inside.sum())} cells within "
        f"{args.budget_wh:g} Wh"
    )
    if args.png:
        res.plot(terrain, args.png, budget)
        print(f"# plot: {args.png}")
    edge = inside & ~(
        np.roll(inside, 1, 0) & np.roll(inside, -1, 0) & np.roll(inside, 1, 1)
        & np.roll(inside, -1, 1)
    )  # fmt: skip
    edge[[0, -1], :] = edge[:, [0, -1]] = False
    rows, cols = np.nonzero(edge & (res.energy_j > 0.98 * budget))
    rng = np.random.default_rng(0)
    pick = rng.choice(rows.size, size=min(args.samples, rows.size), replace=False)
    x0, y0, dx, dy = terrain.grid
    print(
        "| cell (E, N) | reach J | plan search eps=1 J | ratio | plan search J | ratio | "
        "plan auto J | ratio | vs budget |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    worst = 0.0
    worst1 = 0.0
    for k in pick:
        r, c = rows[k], cols[k]
        goal = (x0 + c * dx, y0 + r * dy)
        e = res.energy_j[r, c]
        legs = ((res.start, goal), (goal, res.start)) if args.round_trip else ((res.start, goal),)
        # plan there (and back, for --return): the search, and the default planner
        e_opt = sum(
            plan(terrain, model, a, b, planner="search", step=1.0, eps=1.0,
                 progress=False).energy_j
            for a, b in legs
        )  # fmt: skip
        e_search = sum(
            plan(terrain, model, a, b, planner="search", step=1.0, progress=False).energy_j
            for a, b in legs
        )
        e_auto = sum(
            plan(terrain, model, a, b, planner="auto", step=1.0, time=3,
                 progress=False).energy_j
            for a, b in legs
        )  # fmt: skip
        worst = max(worst, abs(e_search / e - 1))
        worst1 = max(worst1, abs(e_opt / e - 1))
        gx, gy = terrain.from_work(*goal)
        print(
            f"| {gx:.1f}, {gy:.1f} | {e:.0f} | {e_opt:.0f} | {e_opt / e:.4f} | {e_search:.0f} | "
            f"{e_search / e:.4f} | {e_auto:.0f} | {e_auto / e:.4f} | {e / budget:.4f} |",
            flush=True,
        )
    print(
        f"\nworst |plan search eps=1 / reach - 1| = {100 * worst1:.2f}%; default eps: "
        f"{100 * worst:.2f}%"
    )
    print(f"# load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
