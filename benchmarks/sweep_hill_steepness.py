"""Over the hill or round it? Where the detour starts to pay, against the closed form.

Usage::

    python benchmarks/sweep_hill_steepness.py [--model M.json | --test-model]
        [--slopes 6,10,14,18,22,26,30,35] [--time 4] [--png docs/img/sweep_hill_steepness.png]

The scene is a cone of constant slope ``s`` (radius 45 m, on a 110 m x 110 m map at 1 m):
the robot walks from its foot to its top. The straight climb goes up the fall line at
grade ``s`` (the sine of the slope angle); a detour (a spiral or zig-zag) climbs at any
grade ``g < s`` walking forward at the relative heading ``acos(g / s)``. Walking at grade
``g`` costs ``c_s(g)`` J per metre (the model's power / speed), a metre of height
``c_s(g) / g``, so the detour pays exactly when the least of ``c_s(g) / g`` over
``g <= s`` lies below ``s``: the critical grade. For a convex cost
``c = a + b g + k g^2`` it is ``g* = sqrt(a / k)`` (the closed form), and the detour
pays when ``s > g*``; with cross-slope terms ``a`` and ``k`` depend on ``s`` (on a
plane ``C^2 = s^2 - g^2``), so the script fits ``c_s`` per slope. The predicted saving
against the direct climb (walked facing up) is ``1 - min_g (c_s(g) / g) / (c_s(s) / s)``
walking facing the travel, and with the cheapest body yaw (crabbing, which some models
make cheaper; it includes crabbing straight up); no turning cost, so an upper bound of
what a path can save.

For each slope: the direct climb's energy (walked facing up), the energy-optimal route's
(``compare_routes``: ``plan`` ``auto``, also refined from the straight line), the
saving, the predicted saving and the critical grade. The PNG plots measured and
predicted saving against the slope, with the closed-form critical slope.
``--test-model`` uses the convex model of the tests (critical grade 11.5 deg).
"""

from __future__ import annotations

import argparse
import math
import os
import time


def _test_model():
    """The convex model of tests/test_compare_routes.py (formulas, not catalog names)."""
    from energy_planner.model import EnergyModel
    from energy_planner.model.terms import resolve_term

    a, b, k = 600.0, 1000.0, 15000.0
    g_fwd = "sin(alpha) * cos(gamma)"
    spec = {
        "pos(vx)": a, f"pos(vx) * {g_fwd}": b, "pos(-vx)": a + k, f"-pos(-vx) * {g_fwd}": b,
        "abs(vy)": a + k, "-vy * sin(alpha) * sin(gamma)": b, f"pos(vx) * ({g_fwd}) ** 2": k,
    }  # fmt: skip
    terms = [resolve_term(f) for f in spec]
    return EnergyModel(terms, {t.name: v for t, v in zip(terms, spec.values(), strict=True)})


def critical_slope(
    model, speed: float, any_yaw: bool = False, lo: float = 0.02, hi: float = 0.9
) -> float | None:
    """The least slope ``s`` at which ``min_{g<=s} c_s(g)/g < c_s(s)/s`` (bisection)."""
    from energy_planner.planning.compare import grade_cost

    def pays(s):
        gc = grade_cost(model, speed, slope=s, any_yaw=any_yaw)
        return gc.critical_grade is not None and gc.critical_grade < s * 0.999

    if not pays(hi):
        return None
    if pays(lo):
        return lo
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if pays(mid) else (mid, hi)
    return 0.5 * (lo + hi)


def main() -> None:
    import numpy as np

    from energy_planner.model import EnergyModel
    from energy_planner.planning.compare import compare_routes, grade_cost
    from energy_planner.terrain import Terrain

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--model", default=None, help="model JSON (default: the bundled default)")
    ap.add_argument("--test-model", action="store_true", help="the tests' convex model")
    ap.add_argument("--slopes", default="6,10,14,18,22,26,30,35", help="cone slopes, degrees")
    ap.add_argument("--time", type=float, default=4.0)
    ap.add_argument("--png", default="docs/img/sweep_hill_steepness.png")
    args = ap.parse_args()

    if args.test_model:
        model, name = _test_model(), "tests' convex model (a, b, k = 600, 1000, 15000)"
    elif args.model:
        model, name = EnergyModel.load(args.model), args.model
    else:
        model, name = EnergyModel.default(), "bundled default model"
    speed = 0.3
    fall = grade_cost(model, speed, any_yaw=False)
    s_crit = critical_slope(model, speed)
    s_crit_any = critical_slope(model, speed, any_yaw=True)
    deg = fall.deg
    a, b, k = fall.quadratic
    print(
        f"# {name}; cone radius 45 m, foot (10, 55) -> top (55, 55); compare_routes "
        f"(plan auto) {args.time:g} s; load average {os.getloadavg()[0]:.1f}"
    )
    print(
        f"# fall line: c(g) ~ {a:.0f} + {b:.0f} g + {k:.0f} g^2 J/m; critical grade "
        f"{deg(fall.critical_grade) if fall.critical_grade else float('nan'):.1f} deg "
        f"(closed form sqrt(a/k): "
        f"{deg(fall.closed_form_grade) if fall.closed_form_grade else float('nan'):.1f} deg)"
    )
    print(
        "# on a plane of slope s (cross-slope terms included), facing the travel, the detour "
        "pays above "
        + (f"{deg(s_crit):.1f} deg" if s_crit else "no slope up to 64 deg")
        + "; with the cheapest body yaw (crabbing) above "
        + (f"{deg(s_crit_any):.1f} deg" if s_crit_any else "no slope up to 64 deg")
    )
    print(
        "| slope deg | g*(s) deg (closed form) | direct J | planned J | planned m | "
        "saving | predicted, facing travel | predicted, any yaw | time s |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    rows = []
    R, cx, cy = 45.0, 55.0, 55.0
    start, goal = (cx - R, cy), (cx, cy)
    for sd in (float(v) for v in args.slopes.split(",")):
        s = math.sin(math.radians(sd))
        tan = math.tan(math.radians(sd))
        t = Terrain.from_function(
            lambda x, y, tan=tan: tan * np.maximum(R - np.hypot(x - cx, y - cy), 0.0),
            size=(110, 110),
        )
        t0 = time.perf_counter()
        comp = compare_routes(t, model, start, goal, time=args.time, progress=False)
        dt = time.perf_counter() - t0
        direct = comp.route("direct").energy_j
        res = comp.route("energy_optimal")
        gc = grade_cost(model, speed, slope=s, any_yaw=False)
        gca = grade_cost(model, speed, slope=s, any_yaw=True)
        g_cf = gc.closed_form_grade
        # the direct route walks facing the goal: c_s(s)/s facing the travel
        base = gc.per_height(s)
        pred = pred_any = 0.0
        if gc.critical_grade is not None:
            pred = max(0.0, 1 - gc.per_height(gc.critical_grade) / base)
        if gca.critical_grade is not None:
            pred_any = max(0.0, 1 - gca.per_height(gca.critical_grade) / base)
        pred_any = max(pred_any, 1 - gca.per_height(s) / base)  # crabbing straight up
        saving = (direct - res.energy_j) / direct
        rows.append((sd, direct, res.energy_j, res.distance_m, saving, pred, pred_any))
        print(
            f"| {sd:g} | {deg(min(g_cf, 1.0)) if g_cf else float('nan'):.1f} | {direct:.0f} | "
            f"{res.energy_j:.0f} | {res.distance_m:.1f} | {100 * saving:.1f}% | "
            f"{100 * pred:.1f}% | {100 * pred_any:.1f}% | {dt:.1f} |",
            flush=True,
        )
    import matplotlib

    matplotlib.use("Agg")
    from pathlib import Path

    import matplotlib.pyplot as plt

    r = np.array(rows)
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    ax.plot(r[:, 0], 100 * r[:, 4], "o-", label="planned vs direct climb (measured)")
    ax.plot(r[:, 0], 100 * r[:, 5], "s--", label="closed form, facing the travel")
    ax.plot(r[:, 0], 100 * r[:, 6], "^:", label="closed form, cheapest body yaw")
    ax.axhline(0, color="k", lw=0.5)
    if s_crit is not None:
        ax.axvline(deg(s_crit), color="r", lw=1,
                   label=f"critical slope {deg(s_crit):.1f}\u00b0")  # fmt: skip
    if s_crit_any is not None and s_crit_any != s_crit:
        ax.axvline(deg(s_crit_any), color="r", lw=1, ls=":",
                   label=f"critical slope, any yaw {deg(s_crit_any):.1f}\u00b0")  # fmt: skip
    ax.set_xlabel("cone slope (deg)")
    ax.set_ylabel("energy saved by the detour (%)")
    ax.set_title(f"Over the hill or round it\n{name}", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    Path(args.png).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.png, dpi=120)
    print(f"\nplot: {args.png}")
    first = next((row for row in rows if row[4] > 0.005), None)
    if first is not None:
        print(f"the detour first saves > 0.5% at slope {first[0]:g} deg")
    else:
        print("the detour never saves > 0.5% on these slopes")


if __name__ == "__main__":
    main()
