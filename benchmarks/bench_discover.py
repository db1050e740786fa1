"""Benchmark: does ``discover`` find what a campaign hides, and nothing when it hides nothing.

For every hidden effect the simulator offers (``energy_planner.simulate.HIDDEN_EFFECTS``,
and campaigns hiding two at once), a campaign is simulated, ``discover`` walks the
staircase from the raw logs, and the table says which terms it added, whether the hidden
effect(s) came within the first two steps, and the final held-out power RMSE against the
campaign's noise floor (RMSE of the true against the measured window power, on the windows
``discover`` used). A second table runs the effects that are not discovery targets
(robot-parameter variants the base's coefficients absorb, and ``acceleration``, too small
to see): nothing should be added. Then campaigns with no hidden effect (default sensors) on
many seeds give the false-finding rate: the share of seeds where ``discover`` added any
term.

Run::

    python benchmarks/bench_discover.py --size full --seeds 0   # the issue's table
    python benchmarks/bench_discover.py --size medium --seeds 20 --null-size small
    python benchmarks/bench_discover.py --size small --seeds 0 --effects load ground+load
    python benchmarks/bench_discover.py --size medium --effects none --null-speeds 0.2,0.3,0.45
    python benchmarks/bench_discover.py --seeds 0 --effects none --missions load ground
    python benchmarks/bench_discover.py --json
    python benchmarks/bench_discover.py --memory --baseline /work/main/.venv/bin/python

``--memory`` (issue 21 point 4) runs ``energy-planner discover`` on one full campaign
hiding a load (simulated once into ``--campaign``, default ``benchmarks/results/campaign``)
in child processes, under this interpreter and under ``--baseline`` (one whose
``energy_planner`` is main's), and prints each one's peak RSS (the child's ``ru_maxrss``,
what ``/usr/bin/time -v`` reports as maximum resident set size), its wall time, and whether
the two printed the same staircase and held-out numbers.

Prints ``uptime`` with the timings (the machine is shared), and the process's peak RSS
(issue 21: discover on a full campaign at most 1 GB; main before the bounded column
cache: 2.94 GB).
"""

from __future__ import annotations

import os

# one BLAS thread: thousands of small least-squares solves; threads on a loaded machine
# make each 20 times slower (measured: 0.25 s -> 0.012 s per held-out fit, 5104 x 19)
for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from collections.abc import Sequence  # noqa: E402
from dataclasses import asdict, dataclass, field  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402


def _missions():
    from energy_planner.simulate import MissionConfig

    # 30 missions of 2 min (the runs are the units of the held-out test: the default 8
    # missions of 4 min cannot pass a test by run at the Bonferroni level)
    return MissionConfig(missions=30, duration_s=120.0, rate_hz=20.0)


@dataclass
class Case:
    """One campaign through ``discover``."""

    effects: tuple[str, ...]
    seed: int
    added: list[str]
    added_names: list[str]
    data_findings: list[str]
    hit_steps: list[int | None]  # step at which each hidden effect was added (None: never)
    base_rmse_w: float
    final_rmse_w: float
    noise_floor_w: float
    run_energy_median: float
    run_energy_p90: float
    seconds: float
    alternatives: list[list[str]] = field(default_factory=list)

    in_base: list[bool] = field(default_factory=list)

    @property
    def found(self) -> bool:
        """Every hidden effect added within the first two steps.

        An effect the base already represents counts when nothing was added for it and
        the final RMSE is at the floor.
        """
        return all(
            (s is not None and s <= 2) or (b and self.ratio <= 1.2)
            for s, b in zip(self.hit_steps, self.in_base, strict=True)
        )

    @property
    def ratio(self) -> float:
        """Final held-out RMSE over the noise floor."""
        return self.final_rmse_w / self.noise_floor_w


def noise_floor(camp, windows) -> float:
    """RMSE of true against measured mean window power, on ``windows``.

    Uses the simulator's own ``Campaign.noise_floor`` when it has one.
    """
    if hasattr(camp, "noise_floor"):
        return float(camp.noise_floor(windows).rmse_w)
    s = windows.samples[["run", "t", "power", "window"]].copy()
    s["run"] = s["run"].astype(str)
    tr = camp.true_samples[["run", "t", "power"]].rename(columns={"power": "true_power"})
    tr = tr.assign(run=tr["run"].astype(str))
    m = s.merge(tr, on=["run", "t"], how="inner")
    g = m.groupby(["run", "window"])[["power", "true_power"]].mean()
    return float(np.sqrt(np.mean((g["power"] - g["true_power"]) ** 2)))


def in_base(effect: str) -> bool:
    """Whether the effect is not a discovery target (``Effect.target`` False).

    A robot-parameter variant changes only the base model's coefficients (nothing is
    missing, nothing should be added); ``acceleration`` is too small to see (see
    ``energy_planner.simulate.effects``).
    """
    from energy_planner.simulate import EFFECTS

    return not EFFECTS[effect].target


def matches(term: str, effect: str) -> bool:
    """Whether an added term stands for a hidden effect.

    Judged by the effect's own description: a channel effect by any term reading its
    channel; a structural one by the catalog term it resembles, or (speed_dependence) by
    a speed shape.
    """
    from energy_planner.model import resolve_term
    from energy_planner.simulate import EFFECTS

    e = EFFECTS[effect]
    try:
        variables = set(resolve_term(term).variables)
    except Exception:  # noqa: BLE001 - a term we cannot parse matches nothing
        return False
    if e.channel:
        return e.channel in variables
    if term == e.resembles:
        return True
    if effect == "acceleration":  # the kinetic-energy shapes read the accelerations
        return {"ax", "ay"} <= variables
    # a speed shape: speed alone, or one gait's rate squared (pos(vx) ** 2, vy ** 2)
    return effect == "speed_dependence" and bool(variables) and variables <= {"speed", "vx", "vy"}


def config_for(effects: Sequence[str], config):
    """The campaign an effect needs: several speeds for a speed dependence."""
    if "speed_dependence" in effects:
        return config.replace(speeds=(0.2, 0.3, 0.45))
    return config


def run_case(
    effects: Sequence[str], seed: int, config, max_steps: int = 4, mission: bool = False
) -> Case:
    """Simulate one campaign and discover on it."""
    from energy_planner.diagnosis.discover import discover
    from energy_planner.simulate import simulate_campaign

    if mission:
        from energy_planner.simulate import simulate_missions

        camp = simulate_missions(seed=seed, effects=tuple(effects), config=_missions())
    else:
        camp = simulate_campaign(
            seed=seed, effects=tuple(effects), config=config_for(effects, config)
        )
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = discover(camp.logs, max_steps=max_steps, fit_final=False)
    dt = time.perf_counter() - t0
    rows = d.table()
    hits = []
    for e in effects:
        step = next((r["step"] for r in rows[1:] if matches(r["added"], e)), None)
        if step is None:  # reported as a confounded alternative of a step: found too
            step = next(
                (r["step"] for r in rows[1:] for a in r["alternatives"] if matches(a["term"], e)),
                None,
            )
        hits.append(step)
    return Case(
        effects=tuple(effects),
        seed=seed,
        added=d.added,
        added_names=[r["name"] for r in rows[1:]],
        data_findings=[f.name for f in d.data_findings if f.finding],
        hit_steps=hits,
        base_rmse_w=rows[0]["heldout_rmse_w"],
        final_rmse_w=rows[-1]["heldout_rmse_w"],
        noise_floor_w=noise_floor(camp, d.windows),
        run_energy_median=rows[-1]["run_energy_error_median"],
        run_energy_p90=rows[-1]["run_energy_error_p90"],
        seconds=dt,
        alternatives=[[a["name"] for a in r["alternatives"]] for r in rows[1:]],
        in_base=[in_base(e) for e in effects],
    )


def default_cases() -> list[tuple[str, ...]]:
    """Every hidden effect alone, and three campaigns hiding two effects at once."""
    from energy_planner.simulate import HIDDEN_EFFECTS

    singles = [(e,) for e in HIDDEN_EFFECTS]
    pairs = [("idle_power", "vegetation"), ("speed_dependence", "cold_joints"),
             ("load", "ground")]  # fmt: skip
    pairs = [p for p in pairs if set(p) <= set(HIDDEN_EFFECTS)]
    return singles + [tuple(p) for p in pairs]


def variant_cases() -> list[tuple[str, ...]]:
    """The effects that are not discovery targets (robot-parameter variants, too small)."""
    from energy_planner.simulate import EFFECTS

    return [(n,) for n, e in EFFECTS.items() if not e.target]


def _discover_child(python: str, campaign: str, out: str) -> tuple[float, float, str]:
    """Run ``energy-planner discover`` under ``python``; (peak RSS GB, wall s, stdout)."""
    import subprocess

    cmd = [python, "-c", "from energy_planner.cli import main; main()", "discover", campaign,
           "--out", out]  # fmt: skip
    t0 = time.perf_counter()
    # cwd "/": "-c" puts the working directory first on sys.path, which would import this
    # tree's energy_planner under the baseline's interpreter too
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, cwd="/")
    text = p.stdout.read()
    _, status, usage = os.wait4(p.pid, 0)
    p.returncode = os.waitstatus_to_exitcode(status)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed with exit status {p.returncode}")
    return usage.ru_maxrss / 2**20, wall, text  # ru_maxrss in kB on Linux


def memory(baseline: str | None, campaign: str) -> int:
    """Peak RSS of ``discover`` on a full campaign hiding a load: this tree and a baseline."""
    from pathlib import Path

    if not (Path(campaign) / "campaign.json").exists():
        import subprocess

        subprocess.run(
            [sys.executable, "-c", "from energy_planner.cli import main; main()", "simulate",
             "--out", campaign, "--effect", "load"],
            check=True, stdout=subprocess.DEVNULL,
        )  # fmt: skip
    runs = [("this tree", sys.executable)]
    if baseline:
        runs.insert(0, ("baseline", baseline))
    got = {}
    for name, python in runs:
        out = str(Path(campaign).resolve().parent / "m.json")
        got[name] = _discover_child(python, str(Path(campaign).resolve()), out)
        print(f"  {name}: {got[name][0]:.2f} GB, {got[name][1]:.0f} s", file=sys.stderr)

    def staircase(text: str) -> list[str]:
        return [ln for ln in text.splitlines() if not ln.startswith("model written")]

    base = got.get("baseline")
    print(f"\ndiscover on {campaign} (#21: at most 1 GB on a full campaign hiding a load)")
    print(f"{'run':<12}{'peak RSS GB':>12}{'ratio':>8}{'wall s':>8}  same output as baseline")
    for name, (peak, wall, text) in got.items():
        ratio = f"{peak / base[0]:.2f}" if base else "-"
        same = "-" if base is None else str(staircase(text) == staircase(base[2]))
        print(f"{name:<12}{peak:>12.2f}{ratio:>8}{wall:>8.0f}  {same}")
    load = os.getloadavg()
    print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} (2 cores shared)")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--memory",
        action="store_true",
        help="peak RSS of discover on a full campaign hiding a load, this tree beside "
        "--baseline (module docstring)",
    )
    ap.add_argument("--baseline", default=None, help="python of the baseline (main's venv)")
    ap.add_argument("--campaign", default="benchmarks/results/campaign")
    ap.add_argument(
        "--size",
        choices=("small", "medium", "full"),
        default="full",
        help="campaign size of the effect cases: CampaignConfig.small(), "
        "CampaignConfig.small(repeats=2) or CampaignConfig()",
    )
    ap.add_argument("--seeds", type=int, default=20, help="seeds of the false-finding rate")
    ap.add_argument(
        "--null-size",
        choices=("small", "medium", "full"),
        default=None,
        help="campaign size of the false-finding seeds (default: as the effect cases); "
        "medium is CampaignConfig.small(repeats=2)",
    )
    ap.add_argument(
        "--null-speeds",
        default=None,
        help="walking speeds of the false-finding campaigns, e.g. 0.2,0.3,0.45 (default: "
        "the campaign size's, 0.3 m/s); several speeds make the speed shapes candidates",
    )
    ap.add_argument(
        "--effects", nargs="*", default=None, help="effects, a+b for two (default: all)"
    )
    ap.add_argument("--missions", nargs="*", default=None, help="effects on mission logs")
    ap.add_argument(
        "--no-variants",
        action="store_true",
        help="skip the effects that are not discovery targets (run by default when "
        "--effects is not given)",
    )
    ap.add_argument("--max-steps", type=int, default=4)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if args.memory:
        return memory(args.baseline, args.campaign)
    from energy_planner.simulate import CampaignConfig

    sizes = {
        "small": CampaignConfig.small(),
        "medium": CampaignConfig.small(repeats=2),
        "full": CampaignConfig(),
    }
    config = sizes[args.size]
    null_config = config if args.null_size is None else sizes[args.null_size]
    if args.null_speeds:
        null_config = null_config.replace(
            speeds=tuple(float(v) for v in args.null_speeds.split(","))
        )
    cases = default_cases() if args.effects is None else [
        tuple(e.split("+")) for e in args.effects if e != "none"
    ]  # fmt: skip
    results: list[Case] = []
    t_all = time.perf_counter()
    for eff in cases:
        c = run_case(eff, 0, config, args.max_steps)
        results.append(c)
        print(f"  {'+'.join(eff)}: {c.added_names} ({c.seconds:.0f} s)", file=sys.stderr)
    variants: list[Case] = []
    for eff in variant_cases() if args.effects is None and not args.no_variants else []:
        c = run_case(eff, 0, config, args.max_steps)
        variants.append(c)
        print(f"  variant {'+'.join(eff)}: {c.added_names} ({c.seconds:.0f} s)", file=sys.stderr)
    missions: list[Case] = []
    for e in args.missions or []:
        c = run_case(tuple(e.split("+")), 0, config, args.max_steps, mission=True)
        missions.append(c)
        print(f"  mission {e}: {c.added_names} ({c.seconds:.0f} s)", file=sys.stderr)
    nulls = []
    for seed in range(args.seeds):
        c = run_case((), seed, null_config, args.max_steps)
        nulls.append(c)
        print(f"  no effect, seed {seed}: {c.added_names} ({c.seconds:.0f} s)", file=sys.stderr)
    elapsed = time.perf_counter() - t_all
    load = os.getloadavg()
    if args.json:
        doc = {
            "cases": [asdict(c) | {"found": c.found, "ratio": c.ratio} for c in results],
            "missions": [asdict(c) | {"found": c.found, "ratio": c.ratio} for c in missions],
            "not_targets": [asdict(c) | {"ratio": c.ratio} for c in variants],
            "null": [asdict(c) for c in nulls],
            "false_finding_rate": float(np.mean([bool(c.added) for c in nulls])) if nulls
            else None,
            "elapsed_s": elapsed,
            "load": load,
        }  # fmt: skip
        print(json.dumps(doc, indent=2, default=float))
        return 0

    def table(rows: list[Case], title: str, summary: bool = True) -> None:
        print(f"\n{title}")
        print(
            f"{'hidden effect(s)':<34}{'steps':>6}  {'terms added (in order)':<58}"
            f"{'hit at':>8}{'base W':>8}{'final W':>8}{'floor W':>8}{'ratio':>7}"
            f"{'E med':>7}{'E p90':>7}{'s':>5}"
        )
        for c in rows:
            hit = (
                ",".join(
                    "base" if s is None and b else "-" if s is None else str(s)
                    for s, b in zip(c.hit_steps, c.in_base, strict=True)
                )
                or "-"
            )
            added = "; ".join(c.added_names) or "(none)"
            print(
                f"{'+'.join(c.effects) or '(none)':<34}{len(c.added):>6}  {added[:57]:<58}"
                f"{hit:>8}{c.base_rmse_w:>8.2f}{c.final_rmse_w:>8.2f}{c.noise_floor_w:>8.2f}"
                f"{c.ratio:>7.2f}{100 * c.run_energy_median:>6.1f}%{100 * c.run_energy_p90:>6.1f}%"
                f"{c.seconds:>5.0f}"
            )
        ok = [c for c in rows if c.effects]
        if ok and not summary:
            return
        if ok:
            n_found = sum(c.found for c in ok)
            n_ratio = sum(c.ratio <= 1.2 for c in ok)
            print(
                f"hidden effect(s) added within two steps: {n_found}/{len(ok)}; final RMSE "
                f"<= 1.2x noise floor: {n_ratio}/{len(ok)}"
            )

    size = {
        "small": "CampaignConfig.small()",
        "medium": "CampaignConfig.small(repeats=2)",
        "full": "CampaignConfig() (full)",
    }[args.size]
    table(results, f"discover on campaigns hiding effects ({size}, seed 0)")
    if variants:
        table(
            variants,
            f"effects that are not discovery targets ({size}, seed 0): nothing should be "
            "added ('base': a robot-parameter variant the base's coefficients absorb, or "
            "too small to see)",
            summary=False,
        )
    if missions:
        table(missions, "discover on mission logs (simulate_missions, seed 0)")
    if nulls:
        n_false = sum(bool(c.added) for c in nulls)
        speeds = f", speeds {args.null_speeds} m/s" if args.null_speeds else ""
        print(
            f"\nno hidden effect, default sensors, {args.null_size or 'same size'} campaigns"
            f"{speeds}, "
            f"seeds 0-{args.seeds - 1}: a term was added "
            f"in {n_false}/{len(nulls)} campaigns (false-finding rate {n_false / len(nulls):.0%})"
        )
        extra = pd.Series([t for c in nulls for t in c.added_names]).value_counts()
        if len(extra):
            print("  terms added: " + ", ".join(f"{k} x{v}" for k, v in extra.items()))
        ratios = [c.ratio for c in nulls]
        print(
            f"  base held-out RMSE / noise floor: median {np.median(ratios):.2f}, "
            f"max {np.max(ratios):.2f}; data findings: "
            + ", ".join(sorted({f for c in nulls for f in c.data_findings}) or ["none"])
        )
    import resource

    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20  # kB on Linux
    print(
        f"\n{elapsed:.0f} s in all; load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} "
        f"(2 cores shared); peak RSS of this process {peak:.2f} GB (#21: at most 1 GB on a "
        "full campaign; /usr/bin/time -v energy-planner discover LOGS --out m.json gives the "
        "same figure for one campaign)"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
