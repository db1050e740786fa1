"""The follower's printed remaining energy against the rest priced with its coefficients.

The printed estimate (``FollowUpdate.remaining_j``) is the median of the follower's
calibrated predictive distribution: the rest priced with the updated coefficients
(``FollowUpdate.model_j``, the baseline) over one plus the median of the calibrated
errors of its group and remaining share. Per event and checkpoint (25, 50, 75 % of each
mission), over missions of 60 s at 10 Hz on seeds 0, 1, ... (the bundled scores were
calibrated on seeds 1000-1299: disjoint), it prints the median ``|E / E_true - 1|`` of
both side by side, the share of updates whose estimate lies in its own interval, and the
interval's coverage of the truth (checkpoints after the event's pick-up only, as the
calibration counts them).

Run: ``python benchmarks/bench_follow_estimate.py --missions 30`` (docs/follow.md).
"""

from __future__ import annotations

import argparse

import numpy as np


def main() -> None:
    import energy_planner as ep
    from energy_planner.follow.calibrate import (
        EVENT_NAMES,
        bundled_scores,
        counted,
        follow_simulated_mission,
    )

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--missions", type=int, default=30)
    args = ap.parse_args()
    model, scores = ep.load_model(), bundled_scores()
    print(f"{'event':9s} {'share':>5} {'n':>4} {'estimate':>9} {'baseline':>9} "
          f"{'in own iv':>9} {'coverage':>8}")  # fmt: skip
    for ev in EVENT_NAMES:
        rows: dict[float, list] = {c: [] for c in (0.25, 0.5, 0.75)}
        for seed in range(args.missions):
            run = follow_simulated_mission(seed, ev, model, 60.0, 10.0, remaining_scores=scores)
            ups, t, true = run["updates"], run["t"], run["true"]
            for c, out in rows.items():
                i = int(np.argmin(np.abs(t - (run["t0"] + c * (run["t1"] - run["t0"])))))
                u = ups[i]
                if counted(run, u.t) and true[i] > 0:
                    out.append((abs(u.remaining_j / true[i] - 1), abs(u.model_j / true[i] - 1),
                                u.low_j <= u.remaining_j <= u.high_j,
                                u.low_j <= true[i] <= u.high_j))  # fmt: skip
        for c, out in rows.items():
            if out:
                a = np.asarray(out, dtype=float)
                print(f"{ev:9s} {c:5.2f} {len(a):4d} {100 * np.median(a[:, 0]):8.2f}% "
                      f"{100 * np.median(a[:, 1]):8.2f}% {a[:, 2].mean():9.2f} "
                      f"{a[:, 3].mean():8.2f}", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
