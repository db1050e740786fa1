"""Benchmark: intervals beyond the logs, fitted on slopes up to 20 deg, planned up to 30 deg.

A designed campaign is simulated on ramps of 0-20 deg (``energy_planner.simulate``: its
physics is mechanistic, not the model's formulas) and the base model is fitted on it
(:func:`energy_planner.calibration.fit_model`, 5 folds by run: the error model and the
measured growth of the error beyond each range). Paths then cross a steeper synthetic
hill (a Gaussian bump whose steepest slope is 30 deg):

- straight crossings at offsets from the summit (as ``energy --waypoints`` prices them),
  so that their steepest slope spreads from the campaign's range to 30 deg;
- energy-optimal plans (``ep.plan``, no slope limit) between points around the hill.

Each path's predicted energy is the model's; its true energy is the simulator's physics
along the same poses (:func:`energy_planner.simulate.true_path_energy`, the campaign's
hidden effects and channel values). Its nominal 90 % interval is computed two ways, side
by side:

- ``before``: the share of the path outside the domain counted per segment (a segment
  steeper than the campaign anywhere is wholly outside) and the interval widened by the
  assumed factor ``1 + share`` (what ``energy`` and ``plan`` printed before);
- ``after``: :func:`energy_planner.uncertainty.path_domain` (per metre walked, with the
  distance beyond each range) and :func:`energy_planner.uncertainty.predict_interval`
  with that report (the growth the fit measured by holding out its steepest runs).

The table gives, per case, the coverage of the true energy by each (target: 85-95 %),
the median relative width and the share of paths beyond the campaign's slopes.

Run::

    python benchmarks/bench_domain_extrapolation.py            # 3 seeds, ~8 min on 2 cores
    python benchmarks/bench_domain_extrapolation.py --paths 40 --seeds 0 1 2 3 4

Each seed is one fitted campaign (the three load cases share it): all the paths of one
fit share its extrapolation error, so coverage is a statistic over seeds, not paths.
Measured (3 seeds, 26 paths per case and seed, load average ~10 on 2 cores, 1590 s)::

    case         paths beyond  med err p90 |err| cover after  met |e|/half p90 width after
    plain           78     61     0.7%      1.3%       71.8%    n         1.35        2.0%
    load 10 kg      78     62     1.0%      1.5%      100.0%    n         0.61        5.1%
    load 20 kg      78     61    -1.0%      3.0%      100.0%    n         0.62       10.0%
    load 30 kg      78     60    -4.7%      7.9%      100.0%    n         0.82       26.6%
    seed 0         104     80    -0.3%      7.8%      100.0%    n         0.58        8.9%
    seed 1         104     81     0.4%      4.1%       88.5%    y         1.13        8.3%
    seed 2         104     83     0.2%      6.6%       90.4%    y         0.92        6.2%
    all            312    244     0.2%      5.9%       92.9%    y         0.85        7.3%

With the error model scored on whole held-out runs (``scored_on="runs"``: every sample's
battery energy; the growth still measured on the extreme runs' window energies and netted
against the error model of window energies, ``calibration.fit._error_model(whole=False)``),
3 seeds, 26 paths per case and seed, nearly idle, 62 s (kernels cached)::

    case         paths beyond  med err p90 |err| cover after   met |e|/half p90 width after
    plain           78     61     0.7%      1.3%      100.0%    n         0.51        3.6%
    load 10 kg      78     62     1.0%      1.5%      100.0%    n         0.39        7.7%
    load 20 kg      78     61    -1.1%      3.3%      100.0%    n         0.79       11.3%
    load 30 kg      78     60    -4.8%      8.1%       66.7%    n         1.14       18.9%
    seed 0         104     80    -0.3%      7.9%       84.6%    n         1.09       10.6%
    seed 1         104     81     0.4%      4.1%      100.0%    n         0.45        9.8%
    seed 2         104     83     0.2%      6.6%       90.4%    y         0.98        7.0%
    all            312    244     0.1%      6.0%       91.7%    y         0.87        8.9%

(paths beyond 20 deg only: 89.3 %.) Netted against the whole-run error model instead (its
larger scale includes the energy outside the windows, which the extreme runs' window
energies do not hold), the growth of seed 0 came out 0 and ``all`` 88.1 % (seed 0 80.8 %,
load 30 kg 52.6 %, beyond 20 deg 84.8 %; 764 s at load ~3 with a cold kernel cache).

With the mean-power check of the domain report (branch power44: a path whose predicted
mean power lies beyond every calibration run's is outside, x 2, not calibrated; columns
``power out`` and ``cover w/o power``; 116 s, 3 seeds, kernels cached) the whole-run table
above is the same to the digit: none of the 312 paths lies beyond the ramp campaign's
runs' predicted mean power (why was not measured), so ``all`` stays 91.7 %.

(seed 0 alone before the error model measured its noise from the windows: plain 100 %
at width 6.1 %, the load cases 100 % at 8.8 / 13.7 / 32.7 %.) The plain fit of seed 1
measures no growth beyond its slopes (``growth_per_unit`` 0: its held-out steepest runs
err no more than their noise), and its paths' 0.7 % extrapolation error falls outside
intervals of +-1 %.
"""

from __future__ import annotations

import os

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import copy  # noqa: E402
import subprocess  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

X0, Y0 = 500_000.0, 5_000_000.0
#: Issue 28's "Done when": nominal 90 % intervals hold the true energy of 85-95 % of plans.
TARGET_COVERAGE = (0.85, 0.95)
#: (case, hidden effects, the load the paths are walked with: None, inside or beyond)
CASES: tuple[tuple[str, tuple[str, ...], float | None], ...] = (
    ("plain", (), None),
    ("load 10 kg", ("load",), 10.0),
    ("load 20 kg", ("load",), 20.0),
    ("load 30 kg", ("load",), 30.0),
)


def steep_hill(size: int = 160, sigma: float = 25.0, top_deg: float = 30.0) -> Any:
    """A Gaussian hill on a 1 m grid whose steepest slope is ``top_deg``."""
    from energy_planner.terrain import Terrain

    height = np.tan(np.radians(top_deg)) * sigma * np.exp(0.5)  # max |grad| = H/sigma e^-1/2
    c = (size - 1) / 2.0
    yy, xx = np.mgrid[0:size, 0:size].astype(float)
    z = height * np.exp(-((xx - c) ** 2 + (yy - c) ** 2) / (2 * sigma**2))
    return Terrain.from_array(z, resolution=1.0, origin=(X0, Y0))


def fit_campaign(effects: tuple[str, ...], seed: int) -> Any:
    """A model fitted on a campaign of ramps up to 20 deg.

    The base model; with a hidden load, the base plus the load term ``discover`` finds
    (``load_kg*P_base``: the channel times the fitted base power), so that the model
    reads ``load_kg`` and its domain records the loads of the campaign (0-15 kg).
    """
    from energy_planner.calibration import fit_model, prepare_logs
    from energy_planner.model.terms import CATALOG
    from energy_planner.simulate import CampaignConfig, simulate_campaign

    cfg = CampaignConfig.small(slopes_deg=(0.0, 5.0, 10.0, 15.0, 20.0), repeats=2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        camp = simulate_campaign(seed=seed, effects=effects, config=cfg)
        prep = prepare_logs(camp.logs)
        if "load" not in effects:
            return camp, fit_model(prep, seed=seed).model
        base = fit_model(prep, n_splits=0).model
        parts = [f"{c:.4g} * ({CATALOG[t].formula})" for t, c in base.coefficients.items()
                 if t in CATALOG and c != 0]  # fmt: skip
        term = f"load_kg * ({' + '.join(parts)})"
        return camp, fit_model(prep, [*base.term_names, term], seed=seed).model


def crossings(terrain: Any, n: int, rng: Any) -> list[np.ndarray]:
    """Straight lines across the hill at random headings and offsets from the summit."""
    size = terrain.shape[0]
    c = np.array([X0 + (size - 1) / 2.0, Y0 + (size - 1) / 2.0])  # summit (cell centres)
    half = 0.42 * size
    out = []
    for _ in range(n):
        th = rng.uniform(0, np.pi)
        off = rng.uniform(0.0, 40.0)
        d = np.array([np.cos(th), np.sin(th)])
        nrm = np.array([-d[1], d[0]])
        mid = c + off * nrm
        out.append(np.array([mid - half * d, mid + half * d]))
    return out


def plans(terrain: Any, model: Any, request: Any, n: int, rng: Any) -> list[Any]:
    """Energy-optimal plans between random points on opposite sides of the hill."""
    import energy_planner as ep

    size = terrain.shape[0]
    c = np.array([X0 + (size - 1) / 2.0, Y0 + (size - 1) / 2.0])
    prob = ep.Problem(terrain, model, request)
    out = []
    for _ in range(n):
        th = rng.uniform(0, 2 * np.pi)
        r = 0.4 * size
        a = c + r * np.array([np.cos(th), np.sin(th)])
        b = c - r * np.array([np.cos(th + rng.uniform(-0.5, 0.5)), np.sin(th)])
        res = ep.plan(prob, tuple(a), tuple(b), step=2.0, progress=False)
        out.append(np.asarray(res.states, dtype=float))
    return out


def before_share(model: Any, pe: Any, constants: Any) -> float:
    """The share outside counted per segment (the report before it sampled each metre)."""
    from energy_planner.uncertainty import domain_report

    return float(domain_report(model, pe.segments, constants, pe.poses)["outside_share"])


def run_case(case: str, effects: tuple[str, ...], load: float | None, seed: int,
             n_paths: int, n_plans: int, level: float) -> list[dict]:  # fmt: skip
    """One row per path: predicted, true, both intervals."""
    from energy_planner.energy.channels import Channels
    from energy_planner.energy.path import path_energy
    from energy_planner.request import Request
    from energy_planner.simulate import true_path_energy
    from energy_planner.uncertainty import path_domain, predict_interval

    camp, model = fit_campaign(effects, seed)
    # the same model without the runs' mean power in its domain: no mean-power check
    fit = model.metadata["fit"]
    model0 = copy.copy(model)
    model0.metadata = {**model.metadata, "fit": {**fit, "domain": {
        k: v for k, v in fit["domain"].items() if k != "mean_power_w"}}}  # fmt: skip
    terrain = steep_hill()
    consts = {} if load is None else {"load_kg": load}
    ch = Channels(consts) if consts else None
    rng = np.random.default_rng(100 + seed)
    paths = [("straight", p) for p in crossings(terrain, n_paths, rng)]
    request = Request.make(channels=ch)
    paths += [("plan", s) for s in plans(terrain, model, request, n_plans, rng)]
    rows = []
    for kind, st in paths:
        yaw = st[:, 2] if st.shape[1] == 3 else None
        pe = path_energy(terrain, model, st[:, :2], yaw=yaw, channels=ch)
        truth = true_path_energy(terrain, pe.poses, effects=camp.effects, channels=consts)
        dom = path_domain(model, terrain, pe, ch)
        old = before_share(model, pe, consts or None)
        ivs = {
            "before": predict_interval(model, pe.energy_j, level, old, pe.duration_s),
            "after": predict_interval(model, pe.energy_j, level, duration_s=pe.duration_s,
                                      domain=dom),
            "nopower": predict_interval(model, pe.energy_j, level, duration_s=pe.duration_s,
                                        domain=path_domain(model0, terrain, pe, ch)),
        }  # fmt: skip
        row = {"case": case, "seed": seed, "kind": kind, "pred": pe.energy_j,
               "true": truth.energy_j, "max_slope": float(pe.table["max_slope_deg"].max()),
               "share_before": old, "share_after": dom["outside_share"],
               "excess_slope": dom["excess"].get("slope", 0.0),
               "power_out": dom["shares"].get("mean_power", 0.0) > 0,
               "calibrated": ivs["after"].calibrated}  # fmt: skip
        for k, iv in ivs.items():
            row[f"in_{k}"] = bool(iv.low_j <= truth.energy_j <= iv.high_j)
            row[f"width_{k}"] = (iv.high_j - iv.low_j) / pe.energy_j
            half = (iv.high_j if truth.energy_j > pe.energy_j else iv.low_j) - pe.energy_j
            row[f"ratio_{k}"] = abs(truth.energy_j - pe.energy_j) / max(abs(half), 1e-9)
        rows.append(row)
    growth = model.metadata["fit"]["error_model"]["extrapolation"]
    g = {q: v.get("growth_per_unit") for q, v in growth.items()}
    print(f"  {case}, seed {seed}: fitted domain max slope "
          f"{model.metadata['fit']['domain']['max_slope_deg']} deg; growth per unit {g}",
          flush=True)  # fmt: skip
    return rows


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--paths", type=int, default=20, help="straight crossings per case")
    ap.add_argument("--plans", type=int, default=6, help="energy-optimal plans per case")
    ap.add_argument(
        "--seeds",
        type=int,
        nargs="+",
        default=[0, 1, 2],
        help="campaigns: each fit's extrapolation error is one draw shared by "
        "all its paths, so coverage needs several",
    )
    ap.add_argument("--level", type=float, default=0.9)
    ap.add_argument("--cases", nargs="+", default=[c[0] for c in CASES])
    args = ap.parse_args(argv)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()  # fmt: skip
    t0 = time.perf_counter()
    rows = []
    for case, effects, load in CASES:
        if case not in args.cases:
            continue
        for seed in args.seeds:
            rows += run_case(case, effects, load, seed, args.paths, args.plans, args.level)
    import pandas as pd

    df = pd.DataFrame(rows)
    df["err"] = df["pred"] / df["true"] - 1.0
    print(f"\nnominal {100 * args.level:g} % intervals of the simulator's true energy; fit on "
          f"slopes <= 20 deg, paths over a hill up to 30 deg (commit {commit}, "
          f"{time.perf_counter() - t0:.0f} s)")  # fmt: skip
    lo, hi = TARGET_COVERAGE
    head = (f"{'case':<12}{'paths':>6}{'beyond':>7}{'med err':>9}{'p90 |err|':>10}"
            f"{'cover before':>13}{'cover after':>12}{'target':>9}{'met':>4}"
            f"{'|e|/half p90':>13}{'width before':>13}{'width after':>12}"
            f"{'uncalibrated':>13}{'power out':>10}{'cover w/o power':>16}")  # fmt: skip
    print(head)
    groups = [*df.groupby("case", sort=False)]
    if len(args.seeds) > 1:
        groups += [(f"seed {k}", g) for k, g in df.groupby("seed", sort=True)]
    for key, g in [*groups, ("all", df)]:
        beyond = g["excess_slope"] > 0
        cov = g["in_after"].mean()
        met = "y" if lo <= cov <= hi else "n"
        print(f"{key:<12}{len(g):>6}{beyond.sum():>7}{100 * g['err'].median():>8.1f}%"
              f"{100 * g['err'].abs().quantile(0.9):>9.1f}%"
              f"{100 * g['in_before'].mean():>12.1f}%{100 * cov:>11.1f}%"
              f"{f'{lo:.0%}-{hi:.0%}':>9}{met:>4}{g['ratio_after'].quantile(0.9):>13.2f}"
              f"{100 * g['width_before'].median():>12.1f}%{100 * g['width_after'].median():>11.1f}%"
              f"{(~g['calibrated']).sum():>13}{g['power_out'].sum():>10}"
              f"{100 * g['in_nopower'].mean():>15.1f}%")  # fmt: skip
    print(
        "|e|/half p90: the 90th percentile of each path's |true - predicted| over its "
        "interval's half-width on that side (1.0 at nominal coverage; below 1: too wide)"
    )
    print(
        "power out: paths whose predicted mean power lies beyond every calibration run's "
        "(not calibrated, no battery decision, sigma x 2); cover w/o power: the same "
        "intervals without that check"
    )
    up = df[df["power_out"]]
    if len(up):
        print(
            f"paths beyond the runs' power ({len(up)}): coverage {100 * up['in_after'].mean():.1f}"
            f" % with the check, {100 * up['in_nopower'].mean():.1f} % without; median width "
            f"{100 * up['width_after'].median():.1f} % / {100 * up['width_nopower'].median():.1f} %"
        )
    bey = df[df["excess_slope"] > 0]
    if len(bey):
        print(
            f"paths beyond 20 deg only ({len(bey)}): coverage before "
            f"{100 * bey['in_before'].mean():.1f} %, after {100 * bey['in_after'].mean():.1f} %"
        )
    print(
        "\ncommand: python benchmarks/bench_domain_extrapolation.py "
        + " ".join(argv if argv is not None else __import__("sys").argv[1:])
    )


if __name__ == "__main__":
    main()
