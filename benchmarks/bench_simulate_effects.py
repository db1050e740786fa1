"""How visible each hidden effect is to the base model: held-out RMSE over the noise floor.

Usage::

    python benchmarks/bench_simulate_effects.py [--full] [--seed 1] [--json]

For no effect and for every effect of ``energy_planner.simulate.EFFECTS`` (``idle_power``
and ``speed_dependence`` with speeds 0.2, 0.3, 0.45 m/s), simulate a campaign (small, or
the default one with ``--full``), preprocess and window it, fit the package's base model
(``calibration.fit_model``, held out by run) and print its held-out power RMSE, the
campaign's noise floor (``Campaign.noise_floor`` on the same windows), their ratio and the
held-out run-energy errors. An effect the base model absorbs (it changes only the base
coefficients) leaves the ratio near the no-effect row.
"""

from __future__ import annotations

import argparse
import json
import os
import time


def main(argv: list[str] | None = None) -> int:
    from energy_planner.calibration import fit_model
    from energy_planner.measurements import make_windows, preprocess
    from energy_planner.simulate import EFFECTS, CampaignConfig, simulate_campaign

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--full", action="store_true", help="default campaign instead of small")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    rows = []
    t0 = time.perf_counter()
    load = os.getloadavg()[0]
    for name in [None, *EFFECTS]:
        speeds = (0.2, 0.3, 0.45) if name in ("idle_power", "speed_dependence") else (0.3,)
        cfg = CampaignConfig(speeds=speeds) if args.full else CampaignConfig.small(speeds=speeds)
        camp = simulate_campaign(seed=args.seed, effects=(name,) if name else (), config=cfg)
        windows = make_windows(preprocess(camp.logs)[0])
        held = fit_model(windows, seed=args.seed).heldout
        floor = camp.noise_floor(windows).rmse_w
        rows.append(
            {
                "effect": name or "(none)",
                "speeds": len(speeds),
                "heldout_rmse_w": held.rmse_w,
                "noise_floor_w": floor,
                "ratio": held.rmse_w / floor,
                "energy_median": float(getattr(held, "energy_median_abs_rel", float("nan"))),
                "energy_p90": float(getattr(held, "energy_p90_abs_rel", float("nan"))),
            }
        )
    if args.json:
        print(
            json.dumps(
                {"load_avg": load, "seconds": time.perf_counter() - t0, "rows": rows}, indent=2
            )
        )
        return 0
    print(f"campaign: {'default' if args.full else 'small'}, seed {args.seed}, load {load:.1f}")
    print(
        f"{'effect':<20}{'speeds':>7}{'heldout W':>11}{'floor W':>9}{'ratio':>7}"
        f"{'E med':>8}{'E p90':>8}"
    )
    for r in rows:
        print(
            f"{r['effect']:<20}{r['speeds']:>7}{r['heldout_rmse_w']:>11.2f}"
            f"{r['noise_floor_w']:>9.2f}{r['ratio']:>7.2f}{r['energy_median']:>8.1%}"
            f"{r['energy_p90']:>8.1%}"
        )
    print(f"total {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
