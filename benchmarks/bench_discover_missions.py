"""Benchmark: ``discover`` on mission logs (a robot following paths over a DEM).

For each hidden effect, mission logs are simulated (``simulate_missions``: smooth random
paths over rolling hills, slope and heading changing continuously, turning while
walking, three speeds, stops, turns in place, sideways and backward phases), ``discover``
walks the staircase on the raw logs, and the table says which terms it added, whether the
hidden effect(s) came within the first two steps, and the final held-out power RMSE against
the campaign's noise floor (``Campaign.noise_floor``: RMSE of the true against the
measured window power, on the windows ``discover`` used).

Side by side, the baseline: the same logs without the pose's altitude ``z``, so the
``imu_tilt`` data check cannot run and the per-run IMU tilt of the default sensors stays
in the slope and heading (what ``discover`` did on mission logs before the check).

Then missions with no hidden effect on many seeds give the false-finding rate (share of
seeds where ``discover`` added any term) and the base model's ratio to the floor, and
missions whose IMU is mounted without tilt (``imu_bias_deg=0``) give the ``imu_tilt``
check's own false-finding rate.

Run::

    python benchmarks/bench_discover_missions.py     # every effect, a pair, 10 null seeds
    python benchmarks/bench_discover_missions.py --effects load ground --null-seeds 0
    python benchmarks/bench_discover_missions.py --missions 30 --duration 120   # fewer, longer
    python benchmarks/bench_discover_missions.py --phases default  # MissionConfig()'s phases
    python benchmarks/bench_discover_missions.py --json

Prints ``uptime`` with the timings (the machine is shared).
"""

from __future__ import annotations

import os

# one BLAS thread: thousands of small least-squares solves (see bench_discover.py)
for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import importlib.util  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from collections.abc import Sequence  # noqa: E402
from dataclasses import asdict, dataclass, field  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

#: Campaigns hiding two effects at once in the default table.
PAIRS = ("load+ground",)


def default_effects() -> list[str]:
    """Every discovery target (``simulate.HIDDEN_EFFECTS``), the pairs, then the rest."""
    from energy_planner.simulate import EFFECTS, HIDDEN_EFFECTS

    rest = [e for e in EFFECTS if e not in HIDDEN_EFFECTS]
    return [*HIDDEN_EFFECTS, *PAIRS, *rest]


def _bench_discover():
    """``benchmarks/bench_discover.py`` as a module: one definition of what counts as a hit."""
    path = Path(__file__).with_name("bench_discover.py")
    spec = importlib.util.spec_from_file_location("bench_discover", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules.setdefault(spec.name, mod)
    spec.loader.exec_module(mod)
    return mod


def mission_config(missions: int = 60, duration_s: float = 60.0, rate_hz: float = 20.0,
                   phases: str = "varied"):  # fmt: skip
    """The benchmark's missions: ``missions`` x ``duration_s`` s at ``rate_hz``.

    ``phases="varied"``: :meth:`MissionConfig.varied` (every gait direction often);
    ``"default"``: the default phases of :class:`MissionConfig`.
    """
    from energy_planner.simulate import MissionConfig

    make = MissionConfig.varied if phases == "varied" else MissionConfig
    return make(missions=missions, duration_s=duration_s, rate_hz=rate_hz)


@dataclass
class Row:
    """One discovery on one set of mission logs."""

    effects: tuple[str, ...]
    seed: int
    added: list[str]
    added_names: list[str]
    hit_steps: list[int | None]
    in_base: list[bool]
    base_rmse_w: float
    final_rmse_w: float
    noise_floor_w: float
    run_energy_median: float
    run_energy_p90: float
    data_findings: list[str]
    seconds: float
    truth_base_w: float = float("nan")
    truth_final_w: float = float("nan")
    baseline: dict | None = field(default=None)

    @property
    def ratio(self) -> float:
        """Final held-out RMSE over the noise floor."""
        return self.final_rmse_w / self.noise_floor_w

    @property
    def found(self) -> bool:
        """Every hidden effect added within two steps (a base effect: nothing missing)."""
        return all(
            (s is not None and s <= 2) or (b and self.ratio <= 1.2)
            for s, b in zip(self.hit_steps, self.in_base, strict=True)
        )


def truth_rmse(camp, d, terms: Sequence[str]) -> float:
    """Held-out RMSE of a model with ``terms`` against the TRUE window power, W.

    Fitted on the measured window power as ``discover`` fits (5 folds by run, weighted
    by duration), compared with the simulator's noise-free gait-cycle mean power of the
    same samples. A term that lowers it describes the simulator's physics; one found by
    noise does not.
    """
    from energy_planner.stats import fold_index

    wd, samples = d.data, d.windows.samples
    key = pd.DataFrame(
        {
            "run": samples["run"].astype(str).to_numpy(),
            "tk": np.round(samples["t"].to_numpy(float) * 1e6).astype(np.int64),
            "window": samples["window"].to_numpy(),
        }
    )
    ts = camp.true_samples
    truth = pd.DataFrame(
        {
            "run": ts["run"].astype(str).to_numpy(),
            "tk": np.round(ts["t"].to_numpy(float) * 1e6).astype(np.int64),
            "p": ts["power_expected"].to_numpy(float),
        }
    )
    true_w = key.merge(truth, on=["run", "tk"], how="left").groupby("window")["p"].mean()
    folds = fold_index(wd.runs, d.thresholds.n_splits, d.thresholds.seed)
    pred = wd.heldout(terms, folds).predicted  # floored per sample, as discover scores
    return float(np.sqrt(np.mean((true_w.to_numpy(float) - pred) ** 2)))


def discover_row(camp, logs: pd.DataFrame, effects: Sequence[str], max_steps: int) -> Row:
    """Run ``discover`` on ``logs`` of ``camp`` and score it against the hidden effects."""
    from energy_planner.diagnosis.discover import discover

    bd = _bench_discover()
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = discover(logs, max_steps=max_steps, fit_final=False)
    seconds = time.perf_counter() - t0
    rows = d.table()
    hits = []
    for e in effects:
        step = next((r["step"] for r in rows[1:] if bd.matches(r["added"], e)), None)
        if step is None:  # named as a confounded alternative of a step: found too
            step = next(
                (r["step"] for r in rows[1:] for a in r["alternatives"]
                 if bd.matches(a["term"], e)),
                None,
            )  # fmt: skip
        hits.append(step)
    return Row(
        effects=tuple(effects),
        seed=camp.seed,
        added=d.added,
        added_names=[r["name"] for r in rows[1:]],
        hit_steps=hits,
        in_base=[bd.in_base(e) for e in effects],
        base_rmse_w=rows[0]["heldout_rmse_w"],
        final_rmse_w=rows[-1]["heldout_rmse_w"],
        noise_floor_w=float(camp.noise_floor(d.windows).rmse_w),
        run_energy_median=rows[-1]["run_energy_error_median"],
        run_energy_p90=rows[-1]["run_energy_error_p90"],
        data_findings=[f.name for f in d.data_findings if f.finding],
        seconds=seconds,
        truth_base_w=truth_rmse(camp, d, d.base_terms),
        truth_final_w=truth_rmse(camp, d, d.terms),
    )


def run_case(
    effects: Sequence[str], seed: int, config, max_steps: int = 4, baseline: bool = True
) -> Row:
    """Simulate mission logs hiding ``effects``; discover with and without the altitude."""
    from energy_planner.simulate import simulate_missions

    camp = simulate_missions(seed=seed, effects=tuple(effects), config=config)
    row = discover_row(camp, camp.logs, effects, max_steps)
    if baseline:
        b = discover_row(camp, camp.logs.drop(columns="z"), effects, max_steps)
        row.baseline = {
            "added_names": b.added_names,
            "hit_steps": b.hit_steps,
            "final_rmse_w": b.final_rmse_w,
            "noise_floor_w": b.noise_floor_w,
            "ratio": b.ratio,
            "found": b.found,
        }
    return row


def tilt_false_finding(seed: int, config) -> bool:
    """Whether ``imu_tilt`` is a finding on missions whose IMU is mounted without tilt."""
    from energy_planner.measurements.datacheck import check_imu_tilt
    from energy_planner.simulate import SensorConfig, simulate_missions

    sens = SensorConfig(imu_bias_deg=0.0)
    camp = simulate_missions(seed=seed, config=config.replace(sensors=sens))
    logs = camp.logs.sort_values(["run", "t"], kind="stable").reset_index(drop=True)
    return bool(check_imu_tilt(logs)[0].finding)


def _hit(steps: list, in_base: list) -> str:
    return (
        ",".join(
            "base" if s is None and b else "-" if s is None else str(s)
            for s, b in zip(steps, in_base, strict=True)
        )
        or "-"
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--effects", nargs="*", default=None, help="effects, a+b for two")
    ap.add_argument("--seed", type=int, default=0, help="seed of the effect cases")
    ap.add_argument("--null-seeds", type=int, default=10, help="seeds with no hidden effect")
    ap.add_argument("--missions", type=int, default=60)
    ap.add_argument("--duration", type=float, default=60.0, help="s per mission")
    ap.add_argument("--rate", type=float, default=20.0, help="Hz")
    ap.add_argument(
        "--phases",
        choices=("varied", "default"),
        default="varied",
        help="MissionConfig.varied() phases (default) or MissionConfig()'s",
    )
    ap.add_argument("--max-steps", type=int, default=4)
    ap.add_argument("--no-baseline", action="store_true", help="skip the logs without z")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    config = mission_config(args.missions, args.duration, args.rate, args.phases)
    effects = default_effects() if args.effects is None else args.effects
    cases = [tuple(e.split("+")) for e in effects if e != "none"]
    t_all = time.perf_counter()
    rows: list[Row] = []
    for eff in cases:
        r = run_case(eff, args.seed, config, args.max_steps, not args.no_baseline)
        rows.append(r)
        print(f"  {'+'.join(eff)}: {r.added_names} ({r.seconds:.0f} s)", file=sys.stderr)
    nulls: list[Row] = []
    tilt_null: list[bool] = []
    for seed in range(args.null_seeds):
        r = run_case((), seed, config, args.max_steps, baseline=False)
        nulls.append(r)
        tilt_null.append(tilt_false_finding(seed, config))
        print(f"  no effect, seed {seed}: {r.added_names} ({r.seconds:.0f} s)", file=sys.stderr)
    elapsed = time.perf_counter() - t_all
    load = os.getloadavg()
    make = "MissionConfig.varied" if args.phases == "varied" else "MissionConfig"
    what = (
        f"{args.missions} missions x {args.duration:g} s at {args.rate:g} Hz "
        f"({make}(missions={args.missions}, duration_s={args.duration:g}, "
        f"rate_hz={args.rate:g}))"
    )
    if args.json:
        doc = {
            "config": what,
            "cases": [asdict(r) | {"found": r.found, "ratio": r.ratio} for r in rows],
            "null": [asdict(r) | {"ratio": r.ratio} for r in nulls],
            "false_finding_rate": float(np.mean([bool(r.added) for r in nulls])) if nulls
            else None,
            "imu_tilt_false_finding_rate": float(np.mean(tilt_null)) if tilt_null else None,
            "elapsed_s": elapsed,
            "load": load,
        }  # fmt: skip
        print(json.dumps(doc, indent=2, default=float))
        return 0

    print(f"\ndiscover on mission logs: {what}, seed {args.seed}")
    base_cols = "" if args.no_baseline else f"{'| no z: ratio':>14}{'hit':>6}"
    print(
        f"{'hidden effect(s)':<24}{'steps':>6}  {'terms added (in order)':<50}"
        f"{'hit at':>8}{'base W':>8}{'final W':>8}{'floor W':>8}{'ratio':>7}"
        f"{'E med':>7}{'E p90':>7}{'s':>5}{base_cols}"
    )
    for r in rows:
        added = "; ".join(r.added_names) or "(none)"
        line = (
            f"{'+'.join(r.effects):<24}{len(r.added):>6}  {added[:49]:<50}"
            f"{_hit(r.hit_steps, r.in_base):>8}{r.base_rmse_w:>8.2f}{r.final_rmse_w:>8.2f}"
            f"{r.noise_floor_w:>8.2f}{r.ratio:>7.2f}{100 * r.run_energy_median:>6.1f}%"
            f"{100 * r.run_energy_p90:>6.1f}%{r.seconds:>5.0f}"
        )
        if r.baseline is not None:
            b = r.baseline
            line += f"{b['ratio']:>14.2f}{_hit(b['hit_steps'], r.in_base):>6}"
        print(line)
    targets = [r for r in rows if not any(r.in_base)]
    if targets:
        n_found = sum(r.found for r in targets)
        n_ratio = sum(r.ratio <= 1.2 for r in targets)
        n_both = sum(r.found and r.ratio <= 1.2 for r in targets)
        k = len(targets)
        print(
            f"discovery targets (simulate.HIDDEN_EFFECTS and pairs): added within two steps: "
            f"{n_found}/{k}; final RMSE <= 1.2x noise floor: {n_ratio}/{k}; both: {n_both}/{k}"
        )
        if not args.no_baseline:
            b_ratio = sum(r.baseline["ratio"] <= 1.2 for r in targets)
            b_both = sum(r.baseline["found"] and r.baseline["ratio"] <= 1.2 for r in targets)
            print(f"  baseline (logs without z): ratio <= 1.2x: {b_ratio}/{k}; "
                  f"both: {b_both}/{k}")  # fmt: skip
    others = [r for r in rows if any(r.in_base)]
    if others:
        print(
            "not discovery targets (Effect.target False; 'base': nothing to add): "
            + ", ".join(f"{'+'.join(r.effects)} {r.ratio:.2f}x" for r in others)
        )
    if nulls:
        n_false = sum(bool(r.added) for r in nulls)
        print(
            f"\nno hidden effect, default sensors, seeds 0-{args.null_seeds - 1}: a term was "
            f"added in {n_false}/{len(nulls)} (false-finding rate {n_false / len(nulls):.0%})"
        )
        extra = pd.Series([t for r in nulls for t in r.added_names]).value_counts()
        if len(extra):
            print("  terms added: " + ", ".join(f"{k} x{v}" for k, v in extra.items()))
        real = [r.truth_final_w < r.truth_base_w for r in nulls if r.added]
        if real:
            print(
                f"  of these, {sum(real)}/{len(real)} lower the held-out error against the "
                "TRUE power (physics of the simulator the base lacks, not noise): "
                + ", ".join(
                    f"seed {r.seed} {r.truth_base_w:.2f} -> {r.truth_final_w:.2f} W"
                    for r in nulls
                    if r.added
                )
            )
        ratios = [r.ratio for r in nulls]
        print(
            f"  base held-out RMSE / noise floor: median {np.median(ratios):.2f}, max "
            f"{np.max(ratios):.2f}; data findings: "
            + ", ".join(
                f"{k} {v}/{len(nulls)}"
                for k, v in pd.Series([f for r in nulls for f in r.data_findings])
                .value_counts()
                .sort_index()
                .items()
            )
        )
        print(
            f"  imu_tilt on missions with an untilted IMU (imu_bias_deg=0), same seeds: "
            f"a finding in {sum(tilt_null)}/{len(tilt_null)}"
        )
    print(
        f"\n{elapsed:.0f} s in all; load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} "
        "(2 cores shared)"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
