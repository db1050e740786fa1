"""Benchmark: mission logs without altitude, before and after the standing power is fitted.

Issue 20 point 4. Mission logs (``simulate_missions``: curved paths over rolling hills,
three speeds, stops, turns in place) WITHOUT the pose's altitude ``z``, so the IMU tilt
cannot be checked. Two tables, each side by side *before* (cleaning drops the samples at
rest, paper IV-B, so ``idle_power`` is fitted on walking windows only: the library as it
was) and *after* (the stops stay in the windows, ``calibration.prepare.CLEANING``, and
the base model gets the running gait's power ``gait_power`` when the logs hold standing,
``calibration.fit.base_terms``: ``idle_power`` is then the standing power):

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

    python benchmarks/bench_missions_odometry.py --effects --phases default varied \
        --missions 24 --duration 90 --held-out 10      # reduced pose table: ~8 min
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
def stops_dropped():
    """The library as it was before the standing power: cleaning drops the samples at rest."""
    from energy_planner.calibration import prepare
    from energy_planner.measurements.preprocess import PreprocessParams

    saved = prepare.CLEANING
    prepare.CLEANING = PreprocessParams()
    try:
        yield
    finally:
        prepare.CLEANING = saved


VARIANTS = {
    "before": dict(repair=True),
    "after": dict(repair=True),
    "no repair": dict(repair=False),
}


def run_discover(logs: pd.DataFrame, variant: str, max_steps: int, fit_final: bool):
    """``discover`` on ``logs`` as ``variant`` (before / after / no repair)."""
    from energy_planner.diagnosis.discover import discover

    ctx = stops_dropped() if variant == "before" else contextlib.nullcontext()
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


SENSORS = {
    "default": ("default sensors", {}),
    "short": ("odometry 3 % short", dict(slip_mean=0.03, slip_per_sin_slope=0.0)),
}


def pose_rows(seed, cfg, held_missions, max_steps, step, sensors=tuple(SENSORS)) -> list[dict]:
    """Table 2: logged-pose energy of held-out missions, per sensor set and variant."""
    from energy_planner.simulate import SensorConfig, simulate_missions, synthetic_dem

    terrain = synthetic_dem(seed)
    rows = []
    for key in sensors:
        label, kw = SENSORS[key]
        c = cfg.replace(sensors=SensorConfig(**kw))
        camp = simulate_missions(seed=seed, effects=("load",), config=c, terrain=terrain)
        hc = c.replace(missions=held_missions)
        held = simulate_missions(seed=seed + 1000, effects=("load",), config=hc, terrain=terrain)
        row: dict = {"sensors": label}
        for v in ("before", "after"):
            t0 = time.perf_counter()
            d = run_discover(camp.logs.drop(columns="z"), v, max_steps, fit_final=True)
            row[v] = pose_energy(d.model, held, terrain, step)
            row[v]["repaired"] = [f.name for f in d.data_findings if f.repaired]
            row[v]["added"] = [r["name"] for r in d.table()[1:]]
            co = d.model.coefficients
            row[v]["idle_power_w"] = co.get("idle_power")
            row[v]["gait_power_w"] = co.get("gait_power")
            row[v]["seconds"] = time.perf_counter() - t0
            print(f"  {label} {v}: median {100 * row[v]['median']:+.2f} % "
                  f"({row[v]['seconds']:.0f} s)", file=sys.stderr)  # fmt: skip
        rows.append(row)
    return rows


def _classes_text(r: dict) -> str:
    return "; ".join(
        f"{c} {100 * v['share']:.0f} % {100 * v['error']:+.0f} % ({100 * v['of_total']:+.1f})"
        for c, v in r["classes"].items()
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--effects", nargs="*", default=["load", "ground", "motor_temp",
                                                       "cold_joints", "vegetation"])  # fmt: skip
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--missions", type=int, default=30)
    ap.add_argument("--duration", type=float, default=120.0, help="s per mission")
    ap.add_argument("--held-out", type=int, default=20, help="held-out missions")
    ap.add_argument("--phases", nargs="+", choices=("default", "varied"), default=["default"])
    ap.add_argument("--sensors", nargs="+", choices=tuple(SENSORS), default=list(SENSORS))
    ap.add_argument("--max-steps", type=int, default=4)
    ap.add_argument("--pose-step", type=int, default=1, help="use every k-th logged pose")
    ap.add_argument("--no-pose", action="store_true", help="skip the pose-energy table")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    floors, poses = {}, {}
    for ph in args.phases:
        cfg = config(ph, args.missions, args.duration)
        floors[ph] = floor_rows(args.effects, args.seed, cfg, args.max_steps)
        poses[ph] = (
            []
            if args.no_pose
            else pose_rows(
                args.seed, cfg, args.held_out, args.max_steps, args.pose_step, args.sensors
            )
        )
    elapsed = time.perf_counter() - t0
    load = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    what = (f"{args.missions} missions x {args.duration:g} s at 20 Hz, seed {args.seed}, "
            "no altitude z")  # fmt: skip
    if args.json:
        doc = {"config": what, "floor": floors, "pose_energy": poses, "elapsed_s": elapsed,
               "uptime": load}  # fmt: skip
        print(json.dumps(doc, indent=2, default=float))
        return 0
    for ph in args.phases:
        if not floors[ph]:
            continue
        print(f"\ndiscover on mission logs without altitude: {what}, {ph} phases")
        print(f"{'hidden effect':<14}{'before':>8}{'after':>8}{'no repair':>11}  "
              f"{'repairs refused (after)':<28}terms added (after)")  # fmt: skip
        for r in floors[ph]:
            print(
                f"{r['effect']:<14}{r['before']['ratio']:>7.2f}x{r['after']['ratio']:>7.2f}x"
                f"{r['no repair']['ratio']:>10.2f}x  "
                f"{', '.join(r['after']['refused']) or '-':<28}"
                f"{'; '.join(r['after']['added']) or '(none)'}"
            )
        n_before = sum(r["before"]["ratio"] <= 1.2 for r in floors[ph])
        n_after = sum(r["after"]["ratio"] <= 1.2 for r in floors[ph])
        n = len(floors[ph])
        print(f"within 1.2x the floor: before {n_before}/{n}, after {n_after}/{n}")
    if any(poses.values()):
        print(f"\nenergy of {args.held_out} held-out missions' logged poses (every "
              f"{args.pose_step}. pose, their load_kg) against the measured battery energy; "
              f"model discovered on missions hiding a payload ({what})")  # fmt: skip
        print(f"{'phases':<9}{'sensors':<20}{'before: median':>15}{'p90 |e|':>9}"
              f"{'after: median':>15}{'p90 |e|':>9}  idle / gait W (after)")  # fmt: skip
        for ph in args.phases:
            for r in poses[ph]:
                b, a = r["before"], r["after"]
                gait = a["gait_power_w"]
                print(f"{ph:<9}{r['sensors']:<20}{100 * b['median']:>+14.2f}%"
                      f"{100 * b['p90_abs']:>8.2f}%{100 * a['median']:>+14.2f}%"
                      f"{100 * a['p90_abs']:>8.2f}%  {a['idle_power_w']:.1f} / "
                      f"{'-' if gait is None else f'{gait:.1f}'}")  # fmt: skip
        print("\nby motion: share of the true energy, error of the class (points of the total)")
        for ph in args.phases:
            for r in poses[ph]:
                for v in ("before", "after"):
                    print(f"{ph:<9}{r['sensors']:<20}{v:<7} {_classes_text(r[v])}")
    print(f"\n{elapsed:.0f} s in all; {load}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
