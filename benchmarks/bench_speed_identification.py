"""Identifying the optimum speed from logs across speeds (simulator with walk and trot gaits).

A campaign at 8 speeds from 0.15 to 1.2 m/s (``CampaignConfig.across_speeds()``: straight
runs on 0-24 deg ramps at 8 headings, walk below 0.5 m/s and trot from it, logged as the
channel ``gait``) is fitted by ``calibration.fit_model``, which adds the speed terms and the
gait channel's terms because the logs span the speeds, and validated by run (5 folds).
Side by side, the baseline: the same fit without the speed and gait terms (the base model
of single-speed logs), on the same windows. Reported:

* held-out window power RMSE and its ratio to the campaign's noise floor (RMSE of the true
  against the measured power on the same windows, ``Campaign.noise_floor``);
* per slope and relative heading (forward walking): the physics' optimum speed (found
  numerically from ``Physics.expected_power``, ``true_optimum_speed``), the fitted model's
  (``calibration.speed.optimum_speed``), their relative difference, and how much more than
  its optimum the truth pays per metre at the fitted optimum speed.

Usage::

    python benchmarks/bench_speed_identification.py              # the full preset, seed 0
    python benchmarks/bench_speed_identification.py --seeds 0 1
    python benchmarks/bench_speed_identification.py --small --json
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from typing import Any

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")  # small least squares: threads only contend

#: (slope deg, relative heading deg, load kg) of the optimum rows.
CONDITIONS = (
    (0, 0, 0), (8, 0, 0), (16, 0, 0), (24, 0, 0), (16, 90, 0), (16, 180, 0),
    (24, 90, 0), (24, 180, 0),
)  # fmt: skip


def _fit(windows: Any, terms: Any) -> tuple[Any, float]:
    from energy_planner.calibration import fit_model

    t0 = time.perf_counter()
    res = fit_model(windows, terms, n_splits=5, seed=0)
    return res, time.perf_counter() - t0


def run(seed: int, small: bool) -> dict[str, Any]:
    """One campaign: fits, ratios and the optimum table."""
    from energy_planner.calibration.fit import base_terms
    from energy_planner.calibration.speed import optimum_speed
    from energy_planner.measurements import make_windows, preprocess
    from energy_planner.model import SPEED_TERMS
    from energy_planner.simulate import (
        CampaignConfig,
        simulate_campaign,
        true_cost_per_metre,
        true_optimum_speed,
    )

    t0 = time.perf_counter()
    camp = simulate_campaign(seed=seed, config=CampaignConfig.across_speeds(small=small))
    clean, _ = preprocess(camp.logs)
    w = make_windows(clean, duration=2.0)
    sim_s = time.perf_counter() - t0
    floor = float(camp.noise_floor(w).rmse_w)
    full = base_terms(w)
    baseline = [t for t in full if t not in SPEED_TERMS and "gait ==" not in t
                and t != "acceleration"]  # fmt: skip
    res, fit_s = _fit(w, full)
    base, base_s = _fit(w, baseline)
    rows = []
    top = 20 if small else 24
    for slope, heading, _kg in CONDITIONS:
        if slope > top:
            continue
        truth = true_optimum_speed(camp.physics, slope, heading)
        got = optimum_speed(res.model, slope, heading)
        paid = true_cost_per_metre(camp.physics, [got["speed"]], slope, heading)["cost_n"][0]
        rows.append(
            {
                "slope_deg": slope,
                "heading_deg": heading,
                "true_speed": round(truth["speed"], 3),
                "fitted_speed": round(got["speed"], 3),
                "speed_error": round(got["speed"] / truth["speed"] - 1, 4),
                "fitted_gait": got["gait"],
                "interior": got["interior"],
                "true_cost_n": round(truth["cost_n"], 1),
                "cost_excess": round(paid / truth["cost_n"] - 1, 5),
            }
        )
    return {
        "seed": seed,
        "windows": len(w.table),
        "runs": int(w.table["run"].nunique()),
        "noise_floor_w": round(floor, 2),
        "speed_terms": res.speed_terms.to_dict(),
        "fit": {"terms": len(res.model.term_names), "heldout_rmse_w": round(res.heldout.rmse_w, 2),
                "ratio": round(res.heldout.rmse_w / floor, 3), "seconds": round(fit_s, 2)},
        "baseline": {"terms": len(base.model.term_names),
                     "heldout_rmse_w": round(base.heldout.rmse_w, 2),
                     "ratio": round(base.heldout.rmse_w / floor, 3), "seconds": round(base_s, 2)},
        "simulate_and_windows_s": round(sim_s, 2),
        "optimum": rows,
    }  # fmt: skip


def _table(doc: dict[str, Any]) -> str:
    f, b = doc["fit"], doc["baseline"]
    lines = [
        f"seed {doc['seed']}: {doc['windows']} windows of {doc['runs']} runs, noise floor "
        f"{doc['noise_floor_w']:.2f} W; {doc['speed_terms']['reason']}",
        f"  {'model':<34} {'terms':>5} {'held-out RMSE':>14} {'/ floor':>8} {'fit s':>7}",
        f"  {'with speed and gait terms':<34} {f['terms']:>5} {f['heldout_rmse_w']:>12.2f} W "
        f"{f['ratio']:>8.2f} {f['seconds']:>7.1f}",
        f"  {'baseline (single-speed base)':<34} {b['terms']:>5} {b['heldout_rmse_w']:>12.2f} W "
        f"{b['ratio']:>8.2f} {b['seconds']:>7.1f}",
        "",
        f"  {'slope':>5} {'heading':>7} {'physics v*':>10} {'fitted v*':>9} {'error':>7} "
        f"{'gait':>5} {'cost at fitted v*':>18}",
    ]
    for r in doc["optimum"]:
        lines.append(
            f"  {r['slope_deg']:>5} {r['heading_deg']:>7} {r['true_speed']:>10.3f} "
            f"{r['fitted_speed']:>9.3f} {100 * r['speed_error']:>+6.1f}% {r['fitted_gait']:>5} "
            f"{100 * r['cost_excess']:>+12.2f} %{'' if r['interior'] else ' (range end)'}"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark; print the table (or JSON)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0])
    ap.add_argument("--small", action="store_true", help="the test's short campaign")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    docs = [run(s, args.small) for s in args.seeds]
    if args.json:
        print(json.dumps(docs, indent=2))
    else:
        print("\n\n".join(_table(d) for d in docs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
