"""Convergence of each planner against the lattice reference on the bundled hill.

Usage::

    python benchmarks/bench_planning.py [--time 10] [--seed 0]
        [--planners auto,rrtstar,sorrtstar,bitstar]

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
"""

from __future__ import annotations

import argparse
import math
import platform
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
    for name, (model, max_slope) in problems.items():
        req = Request.make(max_slope_deg=max_slope)
        t0 = time.perf_counter()
        ref = plan(terrain, model, s, g, req, planner="search", eps=1.0, progress=False)
        se = ref.info["search"]
        print(
            f"\n## {name}: reference (search, eps=1) {ref.energy_j:.0f} J "
            f"(step {se['step_m']:.2f} m, {se['states']} states, {se['expanded']} expanded; "
            f"wall {time.perf_counter() - t0:.1f} s)"
        )
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


if __name__ == "__main__":
    main()
