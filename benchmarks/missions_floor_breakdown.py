"""Where the base model's error on clean mission logs comes from, window class by class.

Simulates missions with no hidden effect, runs ``discover``'s data checks, windows and
base-model ranking (no step), and prints per window class (steady walking, speed ramps,
turns in place, standing: the stops cleaning keeps) the base model's held-out power RMSE
against the campaign's noise floor (true against measured window power), with the
``imu_tilt`` repair and without it (the same logs without the pose altitude ``z``).
Then, on the steady windows, the base model fitted to the TRUE power with the true
features, with the measured ones, and with the measured ones but the true slope and
heading: what the measured features cost.

With ``--loads`` the missions carry a load (the simulator's ``load`` effect, logged as
``load_kg``): the truth is then fitted by the base terms, ``load_kg`` times each of them
and ``load_kg ** 2`` times each squared-force one (a family rich enough for a carried
mass: the in-sample fit to the TRUE power is what the features allow, not a validation
of a model), and the cost of the measured slope and heading is what the IMU's per-run
tilt bias costs under that load; ``discover`` is run to the end (``--max-steps``) and
its final held-out RMSE is given beside the floor.

Run::

    python benchmarks/missions_floor_breakdown.py                          # 30 x 120 s
    python benchmarks/missions_floor_breakdown.py --varied --missions 60 --duration 60
    python benchmarks/missions_floor_breakdown.py --loads 0 9 18 27 --max-steps 4

Measured with ``--loads 0 9 18 27 --max-steps 4`` (seed 0, the logs of
``bench_field_logs.py --no-field``'s ``sim-load-0``; discover adds ``load_kg*P_base`` and
stops either way)::

                  imu_tilt repaired          no z
    windows     n  held-out  floor  ratio   held-out  ratio
    steady   1429    6.35 W  1.37 W  4.63    7.95 W   5.79
    ramp      284   10.81   10.28    1.05   11.55     1.12
    turn       65   16.65   15.57    1.07   16.57     1.06
    standing   12    8.81    7.51    1.17    8.60     1.15
    all      1790    7.83    5.24    1.49    9.06     1.73
    load family fitted to the TRUE power of the steady windows (in-sample):
      true features 0.71 W; measured 1.84 W (tilt repaired), 4.14 W (no z);
      measured with the true slope and heading 1.66 W

The floor lies in the speed ramps and turns (smoothing lag, ripple); on the steady windows
it is 1.4 W and the model is 4.6-5.8x it. The family of the channel's products expresses
the load to 0.7 W; what the logs' features cost is the IMU's per-run tilt, 4.1 W without
the altitude (1.8 W repaired). The rest of the 6.4-8.0 W is the model discover ends with:
one ``load_kg*P_base`` where the load needs its own coefficient per base term.
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


def _family(load: bool) -> list[str]:
    """The terms the truth is fitted with: the base, and with a load its products."""
    from energy_planner.model import BASE_TERMS, CATALOG

    terms = list(BASE_TERMS)
    if load:
        f = {t: CATALOG[t].formula for t in BASE_TERMS}
        terms += [f"load_kg * ({f[t]})" for t in BASE_TERMS]
        terms += [f"load_kg ** 2 * ({f[t]})" for t in BASE_TERMS if t.endswith("_sq")]
        terms += ["load_kg ** 2"]
    return terms


def breakdown(camp, logs: pd.DataFrame, max_steps: int = 0) -> dict:
    """Held-out error and floor per window class, and the features' cost on steady ones."""
    from energy_planner.diagnosis.discover import discover
    from energy_planner.model import EnergyModel, prepare_features

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = discover(logs, max_steps=max_steps, fit_final=False)
    wd, s = d.data, d.windows.samples
    tr = _truth(camp, s)
    win = s["window"].to_numpy()

    def wmean(a):
        return pd.Series(np.asarray(a, float)).groupby(win).mean().to_numpy()

    true_w = wmean(tr["power_expected"])
    noise = wd.power - true_w
    err = d.rankings[-1].heldout_errors
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

    load = "load_kg" in s.columns
    family = _family(load)

    def design(feat):
        if load:
            feat = feat.assign(load_kg=s["load_kg"].to_numpy(float))
        m = EnergyModel(terms=family).design_matrix(prepare_features(feat))
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
                                                        if f.finding],
            "added": d.added, "final_rmse_w": d.rankings[-1].heldout_rmse_w,
            "supported": d.rankings[-1].supported}  # fmt: skip


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--missions", type=int, default=30)
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--rate", type=float, default=20.0)
    ap.add_argument("--varied", action="store_true", help="MissionConfig.varied() phases")
    ap.add_argument(
        "--loads", type=float, nargs="*", default=None,
        help="missions carry these loads, kg (the simulator's load effect; default none)",
    )  # fmt: skip
    ap.add_argument("--max-steps", type=int, default=0, help="discover's steps (default 0)")
    args = ap.parse_args(argv)
    from energy_planner.simulate import MissionConfig, simulate_missions, synthetic_dem

    make = MissionConfig.varied if args.varied else MissionConfig
    extra = {} if not args.loads else {"loads_kg": tuple(args.loads)}
    cfg = make(missions=args.missions, duration_s=args.duration, rate_hz=args.rate, **extra)
    effects = ("load",) if args.loads else ()
    # the DEM bench_field_logs.py simulates its missions over (the same seed, the same logs)
    terrain = synthetic_dem(args.seed) if args.loads else None
    camp = simulate_missions(seed=args.seed, config=cfg, effects=effects, terrain=terrain)
    what = f"loads {', '.join(f'{v:g}' for v in args.loads)} kg" if args.loads else "clean"
    print(
        f"{what} missions: {args.missions} x {args.duration:g} s at {args.rate:g} Hz, "
        f"{'varied' if args.varied else 'default'} phases, seed {args.seed}"
    )
    for label, logs in (("imu_tilt repaired", camp.logs), ("no z", camp.logs.drop(columns="z"))):
        b = breakdown(camp, logs, args.max_steps)
        print(f"\n{label} (data findings: {', '.join(b['findings'])})")
        if args.max_steps:
            print(f"discover added: {', '.join(b['added']) or 'nothing'}")
        print(f"{'windows':<12}{'n':>6}{'held-out W':>12}{'floor W':>9}{'ratio':>7}")
        for c, (n, e, f) in b["classes"].items():
            print(f"{c:<12}{n:>6}{e:>12.2f}{f:>9.2f}{e / f:>7.2f}")
        fam = "base" + (" and its load products" if args.loads else "")
        print(f"{fam} fitted to the TRUE power of the steady windows, in-sample RMSE:")
        for k, v in b["fits"].items():
            print(f"  {k:<34}{v:6.2f} W")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
