"""Convergence of each planner against the lattice reference on the bundled hill.

Usage::

    python benchmarks/bench_planning.py [--time 10] [--seed 0]
        [--planners auto,rrtstar,sorrtstar,bitstar] [--problems slope-limit,grade^2]
        [--ctg-seeds 0,1,2] [--ctg-planners bitstar,rrtstar,sorrtstar] [--skip-convergence]

Two problems from the hill scenario (foot to top, ``energy_planner.maps.scenario("hill")``):

* ``slope-limit``: the bundled default model with ``--max-slope 20`` (the straight climb
  is infeasible; the planners must go round);
* ``grade^2``: the default model plus a cost per metre growing with the square of the
  path's grade (``GRADE_SQ``), no limit - the detour is cheaper than the feasible line.

For each planner, the best energy found by 0.5, 1, 2, 5 and 10 s of planning (the
clock starts after kernel compilation) and its ratio to the reference: the
full-resolution search with ``eps=1`` (1 m, 16 headings: the optimum on its motion
primitives, the same as the full lattice at 1 m). ``auto`` is the search plus the
cost-aware refinement. OMPL planners run twice: with OMPL's defaults
(``OMPL_TUNING = False``: k-nearest rewiring, motions priced again for the cost) and
tuned (r-disc rewiring, a motion validator that prices each motion once and hands the
cost to the objective).

Then the cost-to-go table (issue 21 point 6): each OMPL planner (tuned) for ``--time``
seconds at each of ``--ctg-seeds``, with ``OMPL_COST_TO_GO`` off (distance bound
``min J/m * d`` only) and on (BIT* gets the search's 2-D relaxed cost-to-go through
``motionCostHeuristic(s, goal)``; RRT* and SORRT* never ask for it in ompl 2.0.1, so
their "on" rows are the same planner again: a check of the noise). Median and range of
the final energy over the search's, and what limits the planner: iterations, motions
priced by the kernel per second, and the time to build the cost-to-go (before the
clock, like the kernels).
"""

from __future__ import annotations

import argparse
import math
import platform
import statistics
import time

CHECKPOINTS = (0.5, 1.0, 2.0, 5.0, 10.0)
GRADE_SQ = "(sin(alpha) * (vx * cos(gamma) - vy * sin(gamma))) ** 2 / max(speed, 1e-06)"


def best_at(history, t):
    """Best energy reached by time ``t`` (inf if none yet)."""
    vals = [e for (s, e) in history if s <= t]
    return min(vals) if vals else math.inf


def main() -> None:
    import importlib

    from energy_planner.maps import scenario
    from energy_planner.model import BASE_TERMS, EnergyModel
    from energy_planner.planning.plan import plan
    from energy_planner.request import Request
    from energy_planner.terrain import load_dem

    # the module (the package's ``plan`` attribute is the function)
    plan_mod = importlib.import_module("energy_planner.planning.plan")

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--time", type=float, default=10.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--planners", default="auto,search,lattice,rrtstar,sorrtstar,bitstar")
    ap.add_argument("--problems", default="slope-limit,grade^2")
    ap.add_argument("--ctg-seeds", default="0,1,2")
    ap.add_argument("--ctg-planners", default="bitstar,rrtstar,sorrtstar")
    ap.add_argument("--skip-convergence", action="store_true",
                    help="only the cost-to-go table")  # fmt: skip
    args = ap.parse_args()

    sc = scenario("hill")
    terrain = load_dem(sc["path"])
    s = terrain.to_work(*sc["start"])
    g = terrain.to_work(*sc["goal"])
    m0 = EnergyModel.default()
    problems = {
        "slope-limit": (m0, 20.0),
        "grade^2": (
            EnergyModel([*BASE_TERMS, GRADE_SQ], {**m0.coefficients, GRADE_SQ: 40000.0}),
            None,
        ),
    }
    print(f"# {platform.processor() or platform.machine()}, python {platform.python_version()}")
    print(
        f"# hill scenario {sc['start']} -> {sc['goal']}, budget {args.time:g} s, seed {args.seed}"
    )
    for name in args.problems.split(","):
        model, max_slope = problems[name]
        req = Request.make(max_slope_deg=max_slope)
        t0 = time.perf_counter()
        ref = plan(terrain, model, s, g, req, planner="search", eps=1.0, progress=False)
        se = ref.info["search"]
        print(
            f"\n## {name}: reference (search, eps=1) {ref.energy_j:.0f} J "
            f"(step {se['step_m']:.2f} m, {se['states']} states, {se['expanded']} expanded; "
            f"wall {time.perf_counter() - t0:.1f} s)"
        )
        if args.ctg_planners:
            ctg_table(plan_mod, terrain, model, s, g, req, ref, args)
        if args.skip_convergence:
            continue
        head = "| planner | " + " | ".join(f"{c:g} s" for c in CHECKPOINTS) + " | final/ref |"
        print(head)
        print("|" + "---|" * (len(CHECKPOINTS) + 2))
        runs = []
        for p in args.planners.split(","):
            if p in ("rrtstar", "sorrtstar", "bitstar"):
                runs += [(p, False), (p, True)]
            else:
                runs.append((p, True))
        for p, tuned in runs:
            plan_mod.OMPL_TUNING = tuned
            label = (
                p
                if p not in ("rrtstar", "sorrtstar", "bitstar")
                else (f"{p} ({'tuned' if tuned else 'OMPL defaults'})")
            )
            try:
                res = plan(terrain, model, s, g, req, planner=p, time=args.time, seed=args.seed,
                           progress=False)  # fmt: skip
                hist = res.history
                final = res.energy_j
            except Exception as exc:  # report and go on
                print(f"| {label} | failed: {exc} |")
                continue
            if not hist:
                hist = [(res.time_s, final)]
            p = label
            cells = []
            for c in CHECKPOINTS:
                b = best_at(hist, c)
                cells.append("-" if not math.isfinite(b) else f"{b:.0f} ({b / ref.energy_j:.3f})")
            print(f"| {p} | " + " | ".join(cells) + f" | {final / ref.energy_j:.3f} |")


def ctg_table(plan_mod, terrain, model, s, g, req, ref, args) -> None:
    """OMPL planners with and without the search's cost-to-go, several seeds."""
    from energy_planner.planning.plan import plan

    seeds = [int(x) for x in args.ctg_seeds.split(",")]
    print(
        f"\n### cost-to-go: {args.time:g} s each, seeds {args.ctg_seeds}; energy / search "
        "(median [min, max]), per run medians"
    )
    print(
        "| planner | cost-to-go | final / search | iterations | motions priced | "
        "priced per s | h build s | h(start) / search |"
    )
    print("|---|---|---|---|---|---|---|---|")
    plan_mod.OMPL_TUNING = True
    for p in args.ctg_planners.split(","):
        for on in (False, True):
            plan_mod.OMPL_COST_TO_GO = on
            ratios, iters, priced, rate, build, hstart = [], [], [], [], [], []
            for seed in seeds:
                try:
                    res = plan(terrain, model, s, g, req, planner=p, time=args.time, seed=seed,
                               progress=False)  # fmt: skip
                except Exception as exc:  # report and go on
                    print(f"| {p} | {'on' if on else 'off'} | seed {seed} failed: {exc} |")
                    continue
                ratios.append(res.energy_j / ref.energy_j)
                iters.append(res.info.get("iterations", 0))
                priced.append(res.info.get("motions_priced", 0))
                rate.append(priced[-1] / max(res.time_s, 1e-9))
                c = res.info.get("cost_to_go")
                if c:
                    build.append(c["build_s"])
                    hstart.append(c["h_start_j"] / ref.energy_j)
            if not ratios:
                continue
            med = statistics.median
            print(
                f"| {p} | {'on' if on else 'off'} | {med(ratios):.3f} "
                f"[{min(ratios):.3f}, {max(ratios):.3f}] | {med(iters):.0f} | "
                f"{med(priced):.0f} | {med(rate):.0f} | "
                + (f"{med(build):.1f} | {med(hstart):.3f} |" if build else "- | - |")
            )


if __name__ == "__main__":
    main()
