"""Where a held-out mission's energy error comes from, split against the simulator's truth.

``bench_field_logs.py``'s varied-phase load campaign (seed ``SEED``: 60 missions x 60 s at
20 Hz, loads 0/9/18/27 kg, no ``z``, discover given the map) and held-out draws of the
same missions (``--draws``, default ``SEED + 1000``, ``--held-out`` missions each). The
model discover writes prices each mission's logged poses as the bench does
(``walked_path`` every 0.5 s, ``path_energy`` with the mission's load); its error
against the battery energy splits into three parts that add up to it:

- ``noise``: the simulator's expected power (``true_samples.power_expected``, the gait
  cycle's mean) against the battery's ``voltage * current`` (sensor noise, ripple);
- ``model``: the model on the TRUE features of every sample (``Campaign.features``)
  against the expected power: the written coefficients and terms, with nothing measured.
  Both sides are functions of the true motion, so two sets of missions differ here only
  by what they walk; split by motion (from the true twist: ``stand``, ``turn`` in place,
  ``ramp`` (walking with an acceleration above 0.05 m/s^2), ``fwd``, ``bwd``, ``lat``);
- ``path``: the logged poses' path against the model on the true features (how the
  poses price the motion: stops, ramps, turns between two poses).

The training campaign itself is split too (in-sample: the final fit saw it). With
``--family`` the written model's terms are also fitted to the TRUE expected power of the
training campaign's moving samples (no sensor, no noise: what the terms can do), jointly
and with the base terms fitted at load 0 alone (the load terms then fitted to the rest),
and each fit's mean error by load is printed on every set.

Run::

    python benchmarks/field_logs_truth_split.py 2 --family   # ~2 min on 2 shared cores
    python benchmarks/field_logs_truth_split.py 2 --draws 1002 2002 3002 4002 5002

Measured (branch b50 on m50 173608a; load average 4-5 on 2 shared cores). Seed 2
(``2 --family --draws 1002 2002 3002 4002 5002``, 5 min): discover adds ``load_kg*P_base``,
``load_kg_sq*P_copper``, ``load_kg*speed^2`` (as in the bench). Mean over each load's
missions, % of the measured energy, then the model part by motion::

    set        load  error  noise  model  path | stand  turn  ramp   fwd   bwd   lat
    training     0   -0.56  +0.04  -1.33 +0.73 | -0.56 -0.47 -0.16 -0.17 +0.06 -0.04
    held 1002    0   -1.89  -0.03  -2.55 +0.69 | -0.49 -0.79 -0.34 -0.54 -0.33 -0.07
    training     9   +0.70  -0.05  -0.14 +0.89
    held 1002    9   +0.72  +0.07  -0.06 +0.71
    training    27   -0.26  -0.05  -1.02 +0.81
    held 1002   27   +0.05  -0.01  -0.69 +0.75
    load 0, draws 2002 / 3002 / 4002 / 5002: error -0.98 / -0.62 / -1.16 / -1.28,
    model -1.66 / -1.23 / -1.94 / -1.92, path +0.70 / +0.56 / +0.64 / +0.78

At load 0 the held-out draw's extra -1.33 points are the model part (-1.22): the noise
and the pose pricing are the same as in training, at every load (the path part is +0.4
to +0.9 at every load of every seed: the poses price the stops above the model on the
true motion, whose standing part is low on every seed; seed 2's model prices standing
on level ground 8-11 W low at every load). The draw's 15 load-0 missions turn in
place 14.8 % of their time (training 9.3 %), walk up grades above 4 deg 18.7 % (5.4 %),
down them 7.9 % (30.2 %), backward 16.8 % (5.0 %); same speed (0.295 m/s walking) and
no steeper (6.1 deg mean). At load 0 the model prices turning in place 10.7 W (5 %) low,
forward walking up 4-8 deg 5.5 W low, backward up a grade 5-7 W low, backward downhill 3
W high. Over the load-0 missions of the five draws, the model part follows the time
turning in place (-6.8 points per unit share), walking uphill (-0.6) and downhill
(+0.8) (R^2 0.48 over 75 missions); of the five, draw 1002 turns in place and walks
uphill the most and downhill the least.

The terms fitted to the truth (``--family``; each seed with its draw ``SEED + 1000``): the
model part at load 0 on the training / held-out missions, %, with the written
coefficients, the terms fitted jointly, and the base fitted at load 0 alone (the load
terms are ``load_kg`` times the named power, or the named function of ``load_kg``)::

    seed  load terms discover added                      written        joint         load 0 base
    0     P_base, P_copper (load^2), gait_power          -0.51 / -0.06  -0.78 / -0.16  -0.28 / -0.21
    1     P_base, fwd_const, load^2                      -0.85 / -1.21  +0.03 / -0.50  -0.36 / -0.43
    2     P_base, P_copper (load^2), speed^2             -1.32 / -2.57  -0.79 / -2.09  -0.32 / -0.69
    3     P_base, P_copper (load^2), load^2              -0.35 / -0.92  +0.53 / -0.24  -0.24 / -0.32
    4     P_base, P_copper, load>9                       -0.54 / -1.09  +0.45 / -0.09  -0.05 / -0.24

With 180 held-out missions per seed (``bench_field_logs.py ... --held-out 180 --seeds 0
1 2 3 4``) the load-0 errors are -0.12 / -0.51 / -1.49 / +0.27 / -0.38 % (seed 2: 31 of
45 in their intervals; 9 kg +0.97 %, 37 of 45). Seed 2's terms, even fitted to the truth
without noise, leave -2.09 % at load 0 on draw 1002 (-1.08 to -1.57 % on the other four
draws); the other seeds' terms -0.09 to -0.50 %.
Its base terms fitted at load 0 alone leave -0.69 %: the base coefficients carry load 0
alone and the joint fit pulls them toward the loaded runs (``fwd_up`` 464 against 626 at
load 0 alone, ``turn_const`` 98 against 112), because the load terms (one load function
times a power frozen at the step that added it) do not follow the truth's mass dependence
in every motion; the joint least squares leaves the ends (0 and 27 kg) low. Rebuilding
``P_base`` from the fit's own base coefficients until it settles (a bilinear fit; tried on
the truth, not kept) moves seed 2's held-out load 0 to -1.44 % but training load 0 to
-1.09 % and 9 / 18 kg to +0.69 / +0.61 %.

Two interval changes, tried offline on the 180-mission draws of the bench (not kept): each
mission's prediction and interval divided by ``1 +`` its load's mean cross-validated
whole-run error in training (``CrossValidation.whole``; seed 2: -0.59 / +0.61 / +0.71 /
-0.44 % at 0 / 9 / 18 / 27 kg) take seed 2 from 146 to 168 of 180 (median +0.08 ->
-0.04 %, p90 2.16 -> 1.69 %) but move seeds 0 and 1 off centre (median +0.01 -> -0.24 %,
-0.02 -> -0.19 %; p90 1.59 -> 1.63 %, 1.22 -> 1.29 %; seed 0 167 -> 166); widening each
interval by that mean error in quadrature instead gives seed 2 155, and seed 4, already
above its band (172; band 154-169), 174.
"""

from __future__ import annotations

import os

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_field_logs as bench  # noqa: E402

#: Motions of a sample, from the true twist (in this order)
MOTIONS = ("stand", "turn", "ramp", "fwd", "bwd", "lat")
#: Below this speed (m/s) and yaw rate (rad/s) a sample stands (the model's own bound)
STILL = 0.05
#: Walking with an acceleration above this (m/s^2) is a ramp
RAMP_ACCEL = 0.05


def motion_of(f: dict[str, np.ndarray]) -> np.ndarray:
    """The motion of each sample (:data:`MOTIONS`) from the true features."""
    speed = np.hypot(f["vx"], f["vy"])
    still = speed < STILL
    return np.select(
        [
            still & (np.abs(f["wz"]) < STILL),
            still,
            np.hypot(f["ax"], f["ay"]) > RAMP_ACCEL,
            np.abs(f["vy"]) > np.abs(f["vx"]),
            f["vx"] > 0,
        ],
        ["stand", "turn", "ramp", "lat", "fwd"],
        default="bwd",
    )


def _trapz(p: np.ndarray, dt: float) -> float:
    return float(np.sum(0.5 * (p[1:] + p[:-1])) * dt)


def split_missions(camp: Any, terrain: Any, model: Any) -> pd.DataFrame:
    """Per mission: measured, predicted (the logged poses), and the parts of the error, J."""
    from energy_planner.energy import path_energy
    from energy_planner.follow import walked_path
    from energy_planner.measurements import run_energies

    f = camp.features()
    dt = camp.config.dt
    ts = camp.true_samples
    p_model = model.power(f)
    p_true = ts["power_expected"].to_numpy(float)
    motion = motion_of(f)
    run_of = ts["run"].to_numpy()
    rows = []
    for run, g in camp.logs.drop(columns="z").groupby("run", sort=True):
        g = g.sort_values("t", kind="stable")
        i = run_of == run
        wp = walked_path(g, every_s=0.5)
        xy = np.column_stack(terrain.to_work(wp.xy[:, 0], wp.xy[:, 1]))
        consts = bench.mission_channels(model, g)
        e = path_energy(terrain, model, xy, yaw=wp.yaw_rad, t=wp.t, constants=consts)
        row = {
            "run": run,
            "load": float(g["load_kg"].iloc[0]),
            "measured": float(run_energies(g)["measured_j"].iloc[0]),
            "predicted": float(e.energy_j),
            "true": _trapz(p_true[i], dt),
            "model_true": _trapz(p_model[i], dt),
        }
        w = np.full(int(i.sum()), dt)  # the trapezoid's weights: the parts add up to the whole
        w[[0, -1]] = dt / 2
        d = (p_model[i] - p_true[i]) * w
        for m in MOTIONS:
            row[f"model_{m}"] = float(d[motion[i] == m].sum())
            row[f"share_{m}"] = float(np.mean(motion[i] == m))
        rows.append(row)
    return pd.DataFrame(rows)


def by_load(t: pd.DataFrame) -> pd.DataFrame:
    """Mean over each load's missions, % of the measured energy: the error and its parts."""
    m = t["measured"]
    parts = pd.DataFrame(
        {
            "load": t["load"],
            "error": t["predicted"] / m - 1,
            "noise": (t["true"] - m) / m,
            "model": (t["model_true"] - t["true"]) / m,
            "path": (t["predicted"] - t["model_true"]) / m,
            **{f"m_{k}": t[f"model_{k}"] / m for k in MOTIONS},
        }
    )
    out = 100 * parts.groupby("load").mean()
    shares = t.groupby("load")[[f"share_{k}" for k in MOTIONS]].mean()
    return out.join(shares)


def family_fits(model: Any, train: Any) -> dict[str, np.ndarray]:
    """The model's terms fitted to the training campaign's TRUE power (moving samples).

    ``joint``: every term at once; ``load 0 base``: the base terms (no ``load`` in the name)
    on the load-0 samples alone, then the load terms on the rest of every sample's power.
    """
    f = train.features()
    X = model.design_matrix(f)
    y = train.true_samples["power_expected"].to_numpy(float)
    moving = (np.hypot(f["vx"], f["vy"]) >= STILL) | (np.abs(f["wz"]) >= STILL)
    is_load = np.array(["load" in n for n in model.term_names])
    joint = np.linalg.lstsq(X[moving], y[moving], rcond=None)[0]
    zero = moving & (np.asarray(f["load_kg"], float) == 0)
    anchored = np.zeros(len(is_load))
    anchored[~is_load] = np.linalg.lstsq(X[zero][:, ~is_load], y[zero], rcond=None)[0]
    rest = y - X[:, ~is_load] @ anchored[~is_load]
    anchored[is_load] = np.linalg.lstsq(X[moving][:, is_load], rest[moving], rcond=None)[0]
    return {"written": model.coef_array(), "joint": joint, "load 0 base": anchored}


def family_errors(model: Any, camp: Any, coefs: dict[str, np.ndarray]) -> pd.DataFrame:
    """Each coefficient set's energy error against the truth by load, % (every sample)."""
    f = camp.features()
    X = model.design_matrix(f)
    y = camp.true_samples["power_expected"].to_numpy(float)
    load = np.asarray(f["load_kg"], float)
    rows = {}
    for name, c in coefs.items():
        p = np.maximum(X @ c, 0.0)
        rows[name] = {
            v: 100 * (p[load == v].sum() / y[load == v].sum() - 1) for v in np.unique(load)
        }
    return pd.DataFrame(rows).T


def main(argv: list[str] | None = None) -> int:
    from energy_planner.simulate import MissionConfig, simulate_missions, synthetic_dem

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("seed", type=int)
    ap.add_argument("--draws", type=int, nargs="*", default=None, help="held-out seeds")
    ap.add_argument("--held-out", type=int, default=60, help="missions per held-out draw")
    ap.add_argument("--family", action="store_true", help="also fit the terms to the truth")
    args = ap.parse_args(argv)
    cfg = MissionConfig.varied(
        missions=60, duration_s=60, rate_hz=20, loads_kg=(0.0, 9.0, 18.0, 27.0)
    )
    terrain = synthetic_dem(args.seed)
    train = simulate_missions(seed=args.seed, effects=("load",), config=cfg, terrain=terrain)
    out = Path(tempfile.mkdtemp()) / "model.json"
    d, model = bench.discover_and_write(train.logs.drop(columns="z"), out, 4, terrain)
    print(f"seed {args.seed}: discover added {'; '.join(r['name'] for r in d.table()[1:])}")
    sets = {"training": train}
    for s in args.draws or [args.seed + 1000]:
        sets[f"held {s}"] = simulate_missions(
            seed=s, effects=("load",), config=cfg.replace(missions=args.held_out), terrain=terrain
        )
    pd.set_option("display.width", 200)
    for name, camp in sets.items():
        print(
            f"\n{name}: mean over each load's missions, % of the measured energy (error = "
            "noise + model + path; m_*: the model part by motion; share_*: time)"
        )
        print(by_load(split_missions(camp, terrain, model)).round(3).to_string())
    if args.family:
        coefs = family_fits(model, train)
        for name, camp in sets.items():
            print(f"\n{name}: the terms fitted to the truth, energy error by load, %")
            print(family_errors(model, camp, coefs).round(2).to_string())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
