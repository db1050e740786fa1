"""Where the error of a held-out mission's energy lies: in its windows or outside them.

``bench_field_logs.py``'s varied-phase load campaign (seed ``SEED``: 60 missions x 60 s at
20 Hz, loads 0/9/18/27 kg, no ``z``; 20 held-out missions of seed ``SEED + 1000``),
discover given the map. For each held-out mission, the model discover writes predicts

- the whole mission from its logged poses (``bench_field_logs.mission_energy``), against
  the battery energy of every sample;
- its windows only (the held-out logs prepared as discover prepares them:
  ``prepare_logs(..., terrain=)``), the model's per-sample power from the pose's twist
  (``calibration.prepare.pose_twist``) and from the odometry's, against the battery
  energy of the same windows,

each with its error model's sigma (``ErrorModel.sigma`` of the prediction and duration):
``z = (predicted - measured) / sigma``. Also the windows' share of the battery energy and
the error of the rest (the samples cleaning drops), as a share of the mission's energy.
Findings in ``bench_field_logs.py``'s docstring.

Run::

    python benchmarks/field_logs_window_share.py 1     # ~3 min on 2 shared cores
"""

from __future__ import annotations

import os

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_field_logs as bench  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    from energy_planner.calibration._windows import window_energy
    from energy_planner.calibration.fit import model_features
    from energy_planner.calibration.prepare import pose_twist, prepare_logs
    from energy_planner.simulate import MissionConfig, simulate_missions, synthetic_dem
    from energy_planner.uncertainty import model_error_model

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("seed", type=int)
    seed = ap.parse_args(argv).seed
    cfg = MissionConfig.varied(
        missions=60, duration_s=60, rate_hz=20, loads_kg=(0.0, 9.0, 18.0, 27.0)
    )
    terrain = synthetic_dem(seed)
    camp = simulate_missions(seed=seed, effects=("load",), config=cfg, terrain=terrain)
    held = simulate_missions(
        seed=seed + 1000, effects=("load",), config=cfg.replace(missions=20), terrain=terrain
    )
    out = Path(tempfile.mkdtemp()) / "model.json"
    _, model = bench.discover_and_write(camp.logs.drop(columns="z"), out, 4, terrain)
    em = model_error_model(model)
    logs = held.logs.drop(columns="z")
    rows = []
    for _, g in logs.groupby("run", sort=True):
        m = bench.mission_energy(terrain, model, g, 0.5)
        rows.append({"run": m.run, "meas": m.measured_j, "pose": m.predicted_j, "T": m.duration_s})
    r = pd.DataFrame(rows).set_index("run")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        p = prepare_logs(logs, terrain=terrain)
    s = p.windows.samples
    coef = np.array([model.coefficients[n] for n in model.term_names])

    def power(samples: pd.DataFrame) -> np.ndarray:
        return np.maximum(model.design_matrix(model_features(samples, model)) @ coef, 0.0)

    table = p.windows.table
    run_of = table.set_index("window")["run"].astype(str)

    def by_run(e: pd.Series) -> pd.Series:
        return e.groupby(run_of.reindex(e.index).to_numpy()).sum()

    r["meas_win"] = by_run(window_energy(s))
    r["odo_win"] = by_run(window_energy(s, power(s)))
    r["pose_win"] = by_run(window_energy(s, power(pose_twist(s))))
    r["T_win"] = table.groupby(table["run"].astype(str))["duration"].sum()
    print(f"seed {seed}: {', '.join(model.term_names)}")
    for col, meas, t, what in (
        ("pose", "meas", "T", "whole mission, logged poses"),
        ("pose_win", "meas_win", "T_win", "its windows, priced from the pose"),
        ("odo_win", "meas_win", "T_win", "its windows, priced from the odometry"),
    ):
        e = r[col] - r[meas]
        sig = em.sigma(r[col].to_numpy(float), r[t].to_numpy(float))
        z = e.to_numpy(float) / sig
        rel = e / r[meas]
        print(
            f"{what:<40} error mean {100 * rel.mean():+.2f} %, RMS "
            f"{100 * np.sqrt((rel**2).mean()):.2f} %; z mean {z.mean():+.2f}, RMS "
            f"{np.sqrt((z**2).mean()):.2f}; sigma {100 * np.median(sig / r[col]):.2f} % (median)"
        )
    rest = ((r["pose"] - r["pose_win"]) - (r["meas"] - r["meas_win"])) / r["meas"]
    print(
        f"windows' share of the battery energy {(r['meas_win'] / r['meas']).median():.3f} "
        f"(median); the rest priced {100 * rest.mean():+.2f} % of the mission's energy "
        f"(sd {100 * rest.std():.2f} %)"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
