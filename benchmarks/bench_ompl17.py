"""OMPL 1.7.0's informed planners on the 200 x 200 hill with the search's cost-to-go.

Usage (1.7.0 beside the project's pinned 2.x, not installed over it)::

    pip install --target /tmp/ompl17 ompl==1.7.0
    for seed in 0 1 2; do
        PYTHONPATH=/tmp/ompl17 python benchmarks/bench_ompl17.py --time 10 --seed $seed
    done

The same problem as ``bench_planning.py``'s ``slope-limit`` (hill foot to top,
``max_slope_deg=20``), with the project's ``EnergyObjective`` and ``CostToGo``. 1.7.0's
bindings take a Python cost-to-go (``setCostToGoHeuristic``), which 2.0.1's do not, and
expose AIT* and EIT*. Start and goal yaws are those of the search's path (1.7.0's goal
regions are not subclassed here); no pricing motion validator. One seed per process
(OMPL's RNG can be seeded once). Prints one table row per planner and cost-to-go
setting: the final energy over the search's optimum.
"""

from __future__ import annotations

import argparse
import math

import numpy as np


def main() -> None:
    from ompl import base as ob
    from ompl import geometric as og
    from ompl import util as ou

    from energy_planner.maps import scenario
    from energy_planner.model import EnergyModel
    from energy_planner.planning.lattice import _terrain_extent
    from energy_planner.planning.limits import make_motion_cost
    from energy_planner.planning.objective import CostToGo, EnergyObjective, path_cost
    from energy_planner.planning.plan import plan
    from energy_planner.request import Request
    from energy_planner.terrain import load_dem

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--time", type=float, default=10.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--planners", default="AITstar,EITstar,BITstar")
    args = ap.parse_args()
    ou.setLogLevel(ou.LOG_ERROR)
    ou.RNG.setSeed(args.seed + 1)
    sc = scenario("hill")
    t = load_dem(sc["path"])
    s = t.to_work(*sc["start"])
    g = t.to_work(*sc["goal"])
    m = EnergyModel.default()
    ref = plan(t, m, s, g, Request.make(max_slope_deg=20), planner="search", eps=1.0,
               progress=False)  # fmt: skip
    cost, _ = make_motion_cost(t, m, max_slope_deg=20)
    cost.compile()
    syaw, gyaw = float(ref.states[0, 2]), float(ref.states[-1, 2])
    ctg = CostToGo(cost, t, g)
    xmin, xmax, ymin, ymax = _terrain_extent(t)
    for name in args.planners.split(","):
        for on in (False, True):
            sp = ob.SE2StateSpace()
            b = ob.RealVectorBounds(2)
            b.setLow(0, xmin)
            b.setHigh(0, xmax)
            b.setLow(1, ymin)
            b.setHigh(1, ymax)
            sp.setBounds(b)
            ss = og.SimpleSetup(sp)
            si = ss.getSpaceInformation()
            obj = EnergyObjective(si, cost, ctg if on else None)
            k = obj._kernel

            def valid(st, k=k) -> bool:
                x, y, th = st.getX(), st.getY(), st.getYaw()
                return math.isfinite(k(x, y, th, x, y, th))

            ss.setStateValidityChecker(ob.StateValidityCheckerFn(valid))
            si.setStateValidityCheckingResolution(0.02)
            if on:
                obj.setCostToGoHeuristic(
                    ob.CostToGoHeuristic(lambda st, goal: ob.Cost(ctg(st.getX(), st.getY())))
                )
            ss.setOptimizationObjective(obj)
            a = ob.State(sp)
            a().setX(s[0])
            a().setY(s[1])
            a().setYaw(syaw)
            z = ob.State(sp)
            z().setX(g[0])
            z().setY(g[1])
            z().setYaw(gyaw)
            ss.setStartAndGoalStates(a, z, 0.5)
            ss.setPlanner(getattr(og, name)(si))
            ss.solve(args.time)
            row = f"| {name} (ompl 1.7.0) | {'on' if on else 'off'} | {args.seed} | "
            if not ss.haveExactSolutionPath():
                print(row + f"no exact solution | {obj.calls} |", flush=True)
                continue
            p = ss.getSolutionPath()
            st = [p.getState(i) for i in range(p.getStateCount())]
            xs = np.array([(q.getX(), q.getY(), q.getYaw()) for q in st] + [[g[0], g[1], gyaw]])
            e = path_cost(k, xs)
            print(row + f"{e / ref.energy_j:.3f} | {obj.calls} |", flush=True)


if __name__ == "__main__":
    main()
