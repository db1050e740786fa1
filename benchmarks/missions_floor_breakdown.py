"""Where the base model's error on clean mission logs comes from, window class by class.

Simulates missions with no hidden effect, runs ``discover``'s data checks, windows and
base-model ranking (no step), and prints per window class (steady walking, speed ramps,
turns in place, standing: the stops cleaning keeps) the base model's held-out power RMSE
against the campaign's noise floor (true against measured window power), with the
``imu_tilt`` repair and without it (the same logs without the pose altitude ``z``).
Then, on the steady windows, the base model fitted to the TRUE power with the true
features, with the measured ones, and with the measured ones but the true slope and
heading: what the measured features cost.

Run::

    python benchmarks/missions_floor_breakdown.py                          # 30 x 120 s
    python benchmarks/missions_floor_breakdown.py --varied --missions 60 --duration 60
"""

from __future__ import annotations

import os

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402


def _rms(a) -> float:
    return float(np.sqrt(np.mean(np.square(np.asarray(a, float)))))


def _truth(camp, samples: pd.DataFrame) -> pd.DataFrame:
    """The simulator's truth row of every window sample (same order)."""
    key = pd.DataFrame(
        {
            "run": samples["run"].astype(str).to_numpy(),
            "tk": np.round(samples["t"].to_numpy(float) * 1e6).astype(np.int64),
        }
    )
    ts = camp.true_samples.assign(
        run=camp.true_samples["run"].astype(str),
        tk=np.round(camp.true_samples["t"].to_numpy(float) * 1e6).astype(np.int64),
    )
    return key.merge(ts.drop(columns="t"), on=["run", "tk"], how="left")


def breakdown(camp, logs: pd.DataFrame) -> dict:
    """Held-out error and floor per window class, and the features' cost on steady ones."""
    from energy_planner.diagnosis.discover import discover
    from energy_planner.model import BASE_TERMS, EnergyModel, prepare_features

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = discover(logs, max_steps=0, fit_final=False)
    wd, s = d.data, d.windows.samples
    tr = _truth(camp, s)
    win = s["window"].to_numpy()

    def wmean(a):
        return pd.Series(np.asarray(a, float)).groupby(win).mean().to_numpy()

    true_w = wmean(tr["power_expected"])
    noise = wd.power - true_w
    err = d.rankings[0].heldout_errors
    speed = np.hypot(tr["vx"], tr["vy"])
    g = pd.DataFrame({"sp": speed, "wz": np.abs(tr["wz"])}).groupby(win)
    dsp = (g["sp"].max() - g["sp"].min()).to_numpy()
    cls = np.where(dsp > 0.03, "speed ramp", np.where(g["wz"].max() > 0.3, "turn", "steady"))
    # the stops the cleaning keeps (calibration.prepare.clean_logs): at rest throughout
    still = ((g["sp"].max() < 0.05) & (g["wz"].max() < 0.05)).to_numpy()
    cls = np.where(still, "standing", cls)
    rows = {}
    for c in ("steady", "speed ramp", "turn", "standing", "all"):
        k = np.ones(len(cls), bool) if c == "all" else cls == c
        rows[c] = (int(k.sum()), _rms(err[k]), _rms(noise[k]))

    steady = cls == "steady"

    def design(feat):
        m = EnergyModel(terms=list(BASE_TERMS)).design_matrix(prepare_features(feat))
        return np.column_stack([wmean(col) for col in np.asarray(m).T])

    def resid(X):
        b, *_ = np.linalg.lstsq(X[steady], true_w[steady], rcond=None)
        return _rms(true_w[steady] - X[steady] @ b)

    cols = ("alpha", "gamma", "vx", "vy", "wz", "ax", "ay")
    meas = pd.DataFrame({c: s[c].to_numpy(float) for c in cols})
    true = pd.DataFrame({c: tr[c].to_numpy(float) for c in cols})
    mixed = meas.assign(alpha=true["alpha"], gamma=true["gamma"])
    fits = {
        "true features": resid(design(true)),
        "measured features": resid(design(meas)),
        "measured, true slope and heading": resid(design(mixed)),
    }
    return {"classes": rows, "fits": fits, "findings": [f.name for f in d.data_findings
                                                        if f.finding]}  # fmt: skip


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--missions", type=int, default=30)
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--rate", type=float, default=20.0)
    ap.add_argument("--varied", action="store_true", help="MissionConfig.varied() phases")
    args = ap.parse_args(argv)
    from energy_planner.simulate import MissionConfig, simulate_missions

    make = MissionConfig.varied if args.varied else MissionConfig
    cfg = make(missions=args.missions, duration_s=args.duration, rate_hz=args.rate)
    camp = simulate_missions(seed=args.seed, config=cfg)
    print(
        f"clean missions: {args.missions} x {args.duration:g} s at {args.rate:g} Hz, "
        f"{'varied' if args.varied else 'default'} phases, seed {args.seed}"
    )
    for label, logs in (("imu_tilt repaired", camp.logs), ("no z", camp.logs.drop(columns="z"))):
        b = breakdown(camp, logs)
        print(f"\n{label} (data findings: {', '.join(b['findings'])})")
        print(f"{'windows':<12}{'n':>6}{'held-out W':>12}{'floor W':>9}{'ratio':>7}")
        for c, (n, e, f) in b["classes"].items():
            print(f"{c:<12}{n:>6}{e:>12.2f}{f:>9.2f}{e / f:>7.2f}")
        print("base fitted to the TRUE power of the steady windows, in-sample RMSE:")
        for k, v in b["fits"].items():
            print(f"  {k:<34}{v:6.2f} W")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
