"""Benchmark: the one held-out evaluation, floored per sample, against the window-mean floor.

``stats.heldout`` floors every sample's prediction and averages a window's floored samples
(the model's semantics). The diagnosis scores hundreds of candidates with it
(``WindowData.heldout``). The baseline is the evaluation the diagnosis used before: the
same fits, each window one row, the floor on the window mean (``stats.heldout`` on the
window means, ``rows`` left out). The table gives the time per candidate scored and the
held-out RMSE of the base model both ways.

Run::

    python benchmarks/bench_heldout.py                  # small campaign (a few seconds)
    python benchmarks/bench_heldout.py --size full      # the default campaign (572 runs)
"""

from __future__ import annotations

import os

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import subprocess  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402


def main(argv: list[str] | None = None) -> None:
    """Print the table (see the module docstring)."""
    from energy_planner.calibration.prepare import prepare_logs
    from energy_planner.diagnosis import window_data
    from energy_planner.diagnosis.suspects import default_candidates
    from energy_planner.model import BASE_TERMS
    from energy_planner.simulate import CampaignConfig, simulate_campaign
    from energy_planner.stats import fold_index, heldout

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", choices=("small", "full"), default="small")
    ap.add_argument("--candidates", type=int, default=60, help="candidates timed")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    cfg = CampaignConfig.small() if args.size == "small" else CampaignConfig()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        camp = simulate_campaign(seed=args.seed, config=cfg)
        wd = window_data(prepare_logs(camp.logs).windows)
    terms = list(BASE_TERMS)
    folds = fold_index(wd.runs, 5, 0)
    have = set(wd.samples.columns) | {"speed"}
    cands = [c.term for c in default_candidates(wd, terms)[0] if set(c.variables) <= have]
    cands = cands[: args.candidates]
    wd.columns(terms + cands)  # evaluate once, as a ranking does
    y, w = wd.power, wd.weights

    def per_sample(extra: list[str]) -> float:
        return wd.heldout(terms, folds, extra=extra).rmse

    def window_mean(extra: list[str]) -> float:
        return heldout(wd.columns(terms + extra), y, folds, w).rmse

    rows = []
    ways = (("window-mean floor (baseline)", window_mean), ("per-sample floor", per_sample))
    for name, f in ways:
        base = f([])
        t0 = time.perf_counter()
        for c in cands:
            f([c])
        rows.append((name, base, (time.perf_counter() - t0) / len(cands) * 1e3))
    load = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    print(f"{args.size} campaign seed {args.seed}: {len(wd.samples)} samples, "
          f"{wd.n_windows} windows, {len(cands)} candidates timed ({load})")  # fmt: skip
    print(f"{'evaluation':<30}{'base RMSE W':>13}{'ms/candidate':>14}{'ratio':>8}")
    for name, rmse, ms in rows:
        print(f"{name:<30}{rmse:>13.5f}{ms:>14.2f}{ms / rows[0][2]:>8.2f}")
    print(f"RMSE difference {abs(rows[1][1] - rows[0][1]):.2e} W; "
          f"finite: {bool(np.isfinite(rows[1][1]))}")  # fmt: skip


if __name__ == "__main__":
    main()
