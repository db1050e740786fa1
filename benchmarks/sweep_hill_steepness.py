"""Over the hill or round it? A sweep over hill steepness (paper Fig. 1).

Usage::

    python benchmarks/sweep_hill_steepness.py [--heights 0,2,4,6,8,10,12,16,20,25]
        [--braking 600] [--time 4] [--png docs/img/sweep_hill_steepness.png]

A Gaussian hill (sigma 15 m) in the middle of a 120 m x 120 m map, 1 m cells; the
robot crosses it from (15, 60) to (105, 60), the straight line running over the top.
The model is the bundled default plus the catalog's ``downhill_braking`` effect
(coefficient ``--braking`` N: descending, the legs brake the body and dissipate
instead of regenerating). Without that term the default model is linear in the grade,
so the work of climbing is returned on the way down and the straight line always wins.

For each hill height: the steepest slope on the line, the energy of the straight line
(walked facing forward), of the planned path (``auto``), the planned distance, and the
saving. The PNG plots the saving against the steepest slope.
"""

from __future__ import annotations

import argparse


def main() -> None:
    import numpy as np

    from energy_planner.energy import path_energy
    from energy_planner.model import BASE_TERMS, EnergyModel
    from energy_planner.planning.plan import plan
    from energy_planner.terrain import Terrain

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--heights", default="0,2,4,6,8,10,12,16,20,25")
    ap.add_argument("--braking", type=float, default=600.0)
    ap.add_argument("--time", type=float, default=4.0)
    ap.add_argument("--png", default="docs/img/sweep_hill_steepness.png")
    args = ap.parse_args()

    m0 = EnergyModel.default()
    model = EnergyModel(
        [*BASE_TERMS, "downhill_braking"], {**m0.coefficients, "downhill_braking": args.braking}
    )
    s, g = (15.0, 60.0), (105.0, 60.0)
    rows = []
    print(f"# default model + downhill_braking = {args.braking:g} N; crossing (15,60)->(105,60)")
    print("| hill height m | max slope on line deg | direct J | planned J | planned m | saving |")
    print("|---|---|---|---|---|---|")
    for h in (float(v) for v in args.heights.split(",")):
        t = Terrain.from_function(
            lambda x, y, h=h: h * np.exp(-((x - 60) ** 2 + (y - 60) ** 2) / (2 * 15.0**2)),
            size=(120, 120),
        )
        xs = np.linspace(s[0], g[0], 200)
        slope = float(np.degrees(np.nanmax(t.sample(xs, np.full_like(xs, 60.0)).slope)))
        direct = path_energy(t, model, [s, g]).energy_j
        res = plan(t, model, s, g, planner="auto", time=args.time, progress=False)
        saving = (direct - res.energy_j) / direct
        rows.append((h, slope, direct, res.energy_j, res.distance_m, saving))
        print(
            f"| {h:g} | {slope:.1f} | {direct:.0f} | {res.energy_j:.0f} | "
            f"{res.distance_m:.1f} | {100 * saving:.1f}% |"
        )
    import matplotlib

    matplotlib.use("Agg")
    from pathlib import Path

    import matplotlib.pyplot as plt

    r = np.array(rows)
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(r[:, 1], 100 * r[:, 5], "o-")
    ax.axhline(0, color="k", lw=0.5)
    for row in rows:
        ax.annotate(f"{row[0]:g} m", (row[1], 100 * row[5]), fontsize=7,
                    xytext=(3, 3), textcoords="offset points")  # fmt: skip
    ax.set_xlabel("steepest slope on the straight line (deg)")
    ax.set_ylabel("energy saved by the planned path (%)")
    ax.set_title("Over the hill or round it (labels: hill height)")
    fig.tight_layout()
    Path(args.png).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.png, dpi=120)
    print(f"\nplot: {args.png}")
    first = next((row for row in rows if row[5] > 0.005), None)
    if first is not None:
        print(
            f"the detour first saves > 0.5% at hill height {first[0]:g} m "
            f"(steepest slope on the line {first[1]:.1f} deg)"
        )


if __name__ == "__main__":
    main()
