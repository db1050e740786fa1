"""How well the base model fitted from logs predicts held-out runs of the simulator (issue 9).

For campaigns with no hidden effect (the simulator's mechanistic truth, realistic
sensors), the base model is fitted by ``calibration.fit_model`` and validated by run
(5-fold grouped cross-validation: a run is never predicted by a fit that saw it). Reported
per campaign:

* held-out run-energy error: median and 90th percentile of ``|E_pred / E_meas - 1|``;
* held-out window power RMSE against the campaign's noise floor, the RMSE of the true
  (noise-free) power against the measured power on the same windows
  (``Campaign.noise_floor``): a model cannot predict the sensor noise, so 1.0 is perfect;

side by side with a baseline: the paper's linear wrench (one grade term per direction,
the base model before issue 9) fitted and validated on the same windows. Acceptance
(issue 9): median <= 3 %, 90th percentile <= 6 %, RMSE <= 1.3 x the noise floor.

Usage::

    python benchmarks/bench_calibration_fidelity.py                 # full default campaign
    python benchmarks/bench_calibration_fidelity.py --seeds 0 1 2   # several campaigns
    python benchmarks/bench_calibration_fidelity.py --reduced       # the test's campaign
    python benchmarks/bench_calibration_fidelity.py --small --json  # tiny, a quick look
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from typing import Any

import numpy as np

#: The paper's linear wrench (the base model before issue 9): the baseline.
LINEAR_WRENCH = (
    "pos(vx)",
    "pos(vx) * sin(alpha) * cos(gamma)",
    "pos(-vx)",
    "-pos(-vx) * sin(alpha) * cos(gamma)",
    "abs(vy)",
    "-vy * sin(alpha) * sin(gamma)",
    "abs(wz)",
    "abs(wz) * sin(alpha)",
)
#: Acceptance thresholds of issue 9.
MEDIAN_MAX, P90_MAX, RMSE_RATIO_MAX = 0.03, 0.06, 1.3


def noise_floor(camp: Any, windows: Any) -> float:
    """RMSE (W) of the true against the measured window power on ``windows``."""
    return float(camp.noise_floor(windows).rmse_w)


def measure(camp: Any, windows: Any, terms: Any, n_splits: int = 5, seed: int = 0) -> dict:
    """Fit ``terms`` with cross-validation by run; the held-out metrics."""
    from energy_planner.calibration import fit_model

    t0 = time.perf_counter()
    res = fit_model(windows, terms, n_splits=n_splits, seed=seed)
    cv = res.heldout
    floor = noise_floor(camp, windows)
    return {
        "terms": len(res.model.term_names),
        "unidentified": list(res.unidentified),
        "n_runs": res.n_runs,
        "n_windows": res.n_windows,
        "median_run_energy_error": cv.energy_median_abs_rel,
        "p90_run_energy_error": cv.energy_p90_abs_rel,
        "max_run_energy_error": cv.energy_max_abs_rel,
        "total_energy_error": cv.energy_total_rel,
        "power_rmse_w": cv.rmse_w,
        "noise_floor_w": floor,
        "rmse_over_floor": cv.rmse_w / floor,
        "fit_s": time.perf_counter() - t0,
        "model": res.model,
    }


def campaign_config(size: str) -> Any:
    """Campaign configuration of the given size.

    ``default`` (the paper's campaign), ``reduced`` (the acceptance test's: 4 slopes,
    8 headings, 10 s runs, 20 Hz) or ``small`` (``CampaignConfig.small()``).
    """
    from energy_planner.simulate import CampaignConfig

    if size == "reduced":  # == tests/test_calibration_sim.py REDUCED
        return CampaignConfig.small(
            slopes_deg=(0.0, 8.0, 16.0, 24.0),
            headings_deg=(0.0, 45.0, 90.0, 135.0, 180.0, -135.0, -90.0, -45.0),
            run_s=10.0,
        )
    return CampaignConfig.small() if size == "small" else CampaignConfig()


def campaign(seed: int, size: str) -> tuple[Any, Any]:
    """Simulate a campaign without hidden effect and cut it into 2 s windows."""
    from energy_planner.measurements import make_windows, preprocess
    from energy_planner.simulate import simulate_campaign

    config = campaign_config(size)
    camp = simulate_campaign(seed=seed, effects=(), config=config)
    clean, _ = preprocess(camp.logs)
    return camp, make_windows(clean, duration=2.0)


def passes(m: dict) -> bool:
    """Issue 9's acceptance."""
    return (
        m["median_run_energy_error"] <= MEDIAN_MAX
        and m["p90_run_energy_error"] <= P90_MAX
        and m["rmse_over_floor"] <= RMSE_RATIO_MAX
    )


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark; print the table (or JSON with --json)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0], help="simulator seeds")
    size = ap.add_mutually_exclusive_group()
    size.add_argument("--reduced", action="store_true", help="the acceptance test's campaign")
    size.add_argument("--small", action="store_true", help="CampaignConfig.small (quick look)")
    ap.add_argument("--json", action="store_true", help="JSON on stdout")
    args = ap.parse_args(argv)
    from energy_planner.model import BASE_TERMS

    rows = []
    for seed in args.seeds:
        t0 = time.perf_counter()
        print(f"seed {seed}: simulating ...", file=sys.stderr)
        size = "reduced" if args.reduced else "small" if args.small else "default"
        camp, windows = campaign(seed, size)
        sim_s = time.perf_counter() - t0
        base = measure(camp, windows, BASE_TERMS)
        lin = measure(camp, windows, LINEAR_WRENCH)
        base.pop("model")
        lin.pop("model")
        rows.append(
            {
                "seed": seed,
                "campaign": size,
                "simulate_s": sim_s,
                "base": base,
                "linear_wrench": lin,
                "pass": passes(base),
            }
        )
    load = os.getloadavg()[0]
    if args.json:
        print(
            json.dumps(
                {
                    "rows": rows,
                    "load_1min": load,
                    "thresholds": {
                        "median": MEDIAN_MAX,
                        "p90": P90_MAX,
                        "rmse_over_floor": RMSE_RATIO_MAX,
                    },
                },
                indent=2,
            )
        )
        return 0 if all(r["pass"] for r in rows) else 1
    hdr = (
        f"{'campaign':<8} {'seed':>4} {'runs':>5} {'windows':>7} | {'model':<13} "
        f"{'median':>7} {'p90':>7} {'max':>7} {'RMSE W':>7} {'floor W':>7} {'ratio':>6}"
    )
    print(hdr)
    print("-" * len(hdr))
    for r in rows:
        for label, m in (("base", r["base"]), ("linear wrench", r["linear_wrench"])):
            print(
                f"{r['campaign']:<8} {r['seed']:>4} {m['n_runs']:>5} {m['n_windows']:>7} | "
                f"{label:<13} {100 * m['median_run_energy_error']:>6.2f}% "
                f"{100 * m['p90_run_energy_error']:>6.2f}% "
                f"{100 * m['max_run_energy_error']:>6.2f}% "
                f"{m['power_rmse_w']:>7.2f} {m['noise_floor_w']:>7.2f} {m['rmse_over_floor']:>6.2f}"
            )
        b, lw = r["base"], r["linear_wrench"]
        med = b["median_run_energy_error"] / lw["median_run_energy_error"]
        print(
            f"{'':<27} | base / linear: median x{med:.2f}, "
            f"p90 x{b['p90_run_energy_error'] / lw['p90_run_energy_error']:.2f}, "
            f"RMSE x{b['power_rmse_w'] / lw['power_rmse_w']:.2f}; "
            f"acceptance {'PASS' if r['pass'] else 'FAIL'} "
            f"(median <= {100 * MEDIAN_MAX:g} %, p90 <= {100 * P90_MAX:g} %, "
            f"RMSE <= {RMSE_RATIO_MAX} x floor)"
        )
        if b["unidentified"]:
            print(f"{'':<27} | not identified: {', '.join(b['unidentified'])}")
    print(
        f"(load average {load:.2f}; simulate {np.mean([r['simulate_s'] for r in rows]):.0f} s, "
        f"fit+CV {np.mean([r['base']['fit_s'] for r in rows]):.0f} s per campaign)"
    )
    return 0 if all(r["pass"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
