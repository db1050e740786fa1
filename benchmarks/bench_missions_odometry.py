"""Benchmark: mission logs without altitude, before and after the odometry scale and repair guard.

Issue 20 point 4. Mission logs (``simulate_missions``: curved paths over rolling hills,
three speeds, stops, turns in place) WITHOUT the pose's altitude ``z``, so the IMU tilt
cannot be checked. Two tables, each side by side *before* (every repair applied, no
``odometry_scale`` check: the data checks as they were) and *after* (the checks of this
branch: ``odometry_scale``, and a repair kept only if the held-out error does not rise,
``calibration.prepare_logs``):

1. per hidden effect, ``discover``'s final held-out power RMSE over the campaign's
   noise floor (``Campaign.noise_floor``: the simulator's TRUE window power against the
   measured one), with ``--no-repair`` for reference, and the repairs refused;
2. the energy of held-out missions' logged poses (``energy.path_energy`` of each
   mission's ``x, y, yaw`` with its times and its ``load_kg``, on the same DEM) against
   the battery energy the mission measured (``measurements.run_energies``): median error
   and 90th percentile of ``|error|``, for a model discovered on missions hiding a
   payload, with the default sensors (slip ``0.02 + 0.1 sin(alpha)``) and with an
   odometry that reads 3 % short on every slope (``slip_mean=0.03``, no slope part).
   Also the share of the error in each motion class (walking, speed ramps, turns in
   place, standing): the simulator's true power of each pose step against the model's.

Run::

    python benchmarks/bench_missions_odometry.py --missions 16 --duration 90   # reduced
    python benchmarks/bench_missions_odometry.py        # full: 30 x 120 s, 20 held out
    python benchmarks/bench_missions_odometry.py --phases varied --missions 60 --duration 60
    python benchmarks/bench_missions_odometry.py --json

Prints ``uptime`` with the timings (the machine is shared).
"""

from __future__ import annotations

import os

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import contextlib  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402


@contextlib.contextmanager
def checks_before():
    """The data checks as they were before this change: no ``odometry_scale`` check."""
    from energy_planner.measurements import datacheck

    saved = datacheck.CHECKS
    datacheck.CHECKS = tuple(c for c in saved if c is not datacheck.check_odometry_scale)
    try:
        yield
    finally:
        datacheck.CHECKS = saved


VARIANTS = {
    "before": dict(repair=True, guard=False),
    "after": dict(repair=True, guard=True),
    "no repair": dict(repair=False),
}


def run_discover(logs: pd.DataFrame, variant: str, max_steps: int, fit_final: bool):
    """``discover`` on ``logs`` as ``variant`` (before / after / no repair)."""
    from energy_planner.diagnosis.discover import discover

    ctx = checks_before() if variant == "before" else contextlib.nullcontext()
    with ctx, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return discover(logs, max_steps=max_steps, fit_final=fit_final, **VARIANTS[variant])


def config(phases: str, missions: int, duration: float, **kw):
    from energy_planner.simulate import MissionConfig

    make = MissionConfig.varied if phases == "varied" else MissionConfig
    return make(missions=missions, duration_s=duration, rate_hz=20.0, **kw)


def floor_rows(effects, seed, cfg, max_steps) -> list[dict]:
    """Table 1: final x-floor per effect and variant."""
    from energy_planner.simulate import simulate_missions

    rows = []
    for eff in effects:
        camp = simulate_missions(seed=seed, effects=tuple(eff.split("+")), config=cfg)
        logs = camp.logs.drop(columns="z")
        row: dict = {"effect": eff}
        for v in VARIANTS:
            t0 = time.perf_counter()
            d = run_discover(logs, v, max_steps, fit_final=False)
            floor = float(camp.noise_floor(d.windows).rmse_w)
            last = d.table()[-1]
            row[v] = {
                "ratio": last["heldout_rmse_w"] / floor,
                "added": [r["name"] for r in d.table()[1:]],
                "refused": [
                    f.name for f in d.data_findings if f.finding and "heldout_check" in
                    f.evidence and not f.evidence["heldout_check"]["kept"]
                ],
                "repaired": [f.name for f in d.data_findings if f.repaired],
                "seconds": time.perf_counter() - t0,
            }  # fmt: skip
            print(f"  {eff} {v}: {row[v]['ratio']:.2f}x ({row[v]['seconds']:.0f} s)",
                  file=sys.stderr)  # fmt: skip
        rows.append(row)
    return rows


def _classes(ts: pd.DataFrame) -> np.ndarray:
    """Motion class of each pose step (from the simulator's true twist at its end)."""
    sp = np.hypot(ts["vx"].to_numpy(), ts["vy"].to_numpy())
    dt = np.diff(ts["t"].to_numpy())
    acc = np.abs(np.diff(sp)) / dt
    wz = np.abs(ts["wz"].to_numpy()[1:])
    walking = sp[1:] > 0.05
    return np.where(
        walking, np.where(acc > 0.05, "ramp", "walk"), np.where(wz > 0.1, "turn", "stand")
    )


def pose_energy(model, held, terrain, step: int) -> dict:
    """Energy of the held-out missions' logged poses against their measured battery energy."""
    from energy_planner.energy.path import path_energy
    from energy_planner.measurements import run_energies

    meas = run_energies(held.logs).set_index("run")["measured_j"]
    ts_all = held.true_samples.assign(run=held.true_samples["run"].astype(str))
    errs, parts = [], []
    for run, g in held.logs.assign(run=held.logs["run"].astype(str)).groupby("run"):
        g = g.sort_values("t").iloc[::step]
        ts = ts_all[ts_all["run"] == run].sort_values("t").iloc[::step]
        e = path_energy(
            terrain, model, g[["x", "y"]].to_numpy(), yaw=g["yaw"].to_numpy(),
            t=g["t"].to_numpy(), constants={"load_kg": float(g["load_kg"].iloc[0])},
        )  # fmt: skip
        errs.append(e.energy_j / meas[run] - 1.0)
        p = ts["power_expected"].to_numpy()
        true_j = 0.5 * (p[1:] + p[:-1]) * np.diff(ts["t"].to_numpy())
        parts.append(
            pd.DataFrame(
                {"cls": _classes(ts), "pred": e.segments["energy_j"].to_numpy(), "true": true_j}
            )
        )
    errs = np.asarray(errs)
    df = pd.concat(parts)
    total = df["true"].sum()
    by = df.groupby("cls")[["pred", "true"]].sum()
    return {
        "median": float(np.median(errs)),
        "p90_abs": float(np.quantile(np.abs(errs), 0.9)),
        "n": int(errs.size),
        "classes": {
            c: {
                "share": float(r.true / total),
                "error": float(r.pred / r.true - 1),
                "of_total": float((r.pred - r.true) / total),
            }
            for c, r in by.iterrows()
        },  # fmt: skip
    }


def pose_rows(seed, cfg, held_missions, max_steps, step) -> list[dict]:
    """Table 2: logged-pose energy of held-out missions, per sensor set and variant."""
    from energy_planner.simulate import SensorConfig, simulate_missions, synthetic_dem

    terrain = synthetic_dem(seed)
    rows = []
    for label, sens in (
        ("default sensors", SensorConfig()),
        ("odometry 3 % short", SensorConfig(slip_mean=0.03, slip_per_sin_slope=0.0)),
    ):
        c = cfg.replace(sensors=sens)
        camp = simulate_missions(seed=seed, effects=("load",), config=c, terrain=terrain)
        hc = c.replace(missions=held_missions)
        held = simulate_missions(seed=seed + 1000, effects=("load",), config=hc, terrain=terrain)
        row: dict = {"sensors": label}
        for v in ("before", "after"):
            t0 = time.perf_counter()
            d = run_discover(camp.logs.drop(columns="z"), v, max_steps, fit_final=True)
            row[v] = pose_energy(d.model, held, terrain, step)
            row[v]["repaired"] = [f.name for f in d.data_findings if f.repaired]
            row[v]["seconds"] = time.perf_counter() - t0
            print(f"  {label} {v}: median {100 * row[v]['median']:+.2f} % "
                  f"({row[v]['seconds']:.0f} s)", file=sys.stderr)  # fmt: skip
        rows.append(row)
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--effects", nargs="*", default=["load", "ground", "motor_temp",
                                                       "cold_joints", "vegetation"])  # fmt: skip
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--missions", type=int, default=30)
    ap.add_argument("--duration", type=float, default=120.0, help="s per mission")
    ap.add_argument("--held-out", type=int, default=20, help="held-out missions")
    ap.add_argument("--phases", choices=("default", "varied"), default="default")
    ap.add_argument("--max-steps", type=int, default=4)
    ap.add_argument("--pose-step", type=int, default=1, help="use every k-th logged pose")
    ap.add_argument("--no-pose", action="store_true", help="skip the pose-energy table")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    cfg = config(args.phases, args.missions, args.duration)
    t0 = time.perf_counter()
    floors = floor_rows(args.effects, args.seed, cfg, args.max_steps)
    poses = [] if args.no_pose else pose_rows(
        args.seed, cfg, args.held_out, args.max_steps, args.pose_step)  # fmt: skip
    elapsed = time.perf_counter() - t0
    load = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    what = (f"{args.missions} missions x {args.duration:g} s at 20 Hz, {args.phases} phases, "
            f"seed {args.seed}, no altitude z")  # fmt: skip
    if args.json:
        doc = {"config": what, "floor": floors, "pose_energy": poses, "elapsed_s": elapsed,
               "uptime": load}  # fmt: skip
        print(json.dumps(doc, indent=2, default=float))
        return 0
    print(f"\ndiscover on mission logs without altitude: {what}")
    print(f"{'hidden effect':<14}{'before':>8}{'after':>8}{'no repair':>11}  "
          f"{'repairs refused (after)':<28}terms added (after)")  # fmt: skip
    for r in floors:
        print(
            f"{r['effect']:<14}{r['before']['ratio']:>7.2f}x{r['after']['ratio']:>7.2f}x"
            f"{r['no repair']['ratio']:>10.2f}x  {', '.join(r['after']['refused']) or '-':<28}"
            f"{'; '.join(r['after']['added']) or '(none)'}"
        )
    n_before = sum(r["before"]["ratio"] <= 1.2 for r in floors)
    n_after = sum(r["after"]["ratio"] <= 1.2 for r in floors)
    print(f"within 1.2x the floor: before {n_before}/{len(floors)}, after {n_after}/{len(floors)}")
    if poses:
        print(f"\nenergy of {args.held_out} held-out missions' logged poses (every "
              f"{args.pose_step}. pose, their load_kg) against the measured battery energy; "
              "model discovered on missions hiding a payload")  # fmt: skip
        print(f"{'sensors':<22}{'before: median':>15}{'p90 |e|':>9}{'after: median':>15}"
              f"{'p90 |e|':>9}  by motion (after): energy share, error (of total)")  # fmt: skip
        for r in poses:
            b, a = r["before"], r["after"]
            cls = "; ".join(
                f"{c} {100 * v['share']:.0f} % {100 * v['error']:+.0f} % "
                f"({100 * v['of_total']:+.1f})"
                for c, v in a["classes"].items()
            )
            print(f"{r['sensors']:<22}{100 * b['median']:>+14.2f}%{100 * b['p90_abs']:>8.2f}%"
                  f"{100 * a['median']:>+14.2f}%{100 * a['p90_abs']:>8.2f}%  {cls}")  # fmt: skip
    print(f"\n{elapsed:.0f} s in all; {load}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
