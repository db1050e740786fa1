r"""Benchmark: CPU time of the discover staircase, this tree beside a baseline, same windows.

The staircase (``diagnosis.suspects.staircase``: rank every candidate by run-held-out
error, add the best, re-rank) is what a user of ``discover`` waits for once the logs are
prepared, and the largest library cost of the test suite. This benchmark simulates a few
reduced campaigns (``CampaignConfig.small()``, as ``tests/test_discover.py``), prepares
their windows once with this tree's code and pickles them, then times the staircase
(``max_steps=2``, CPU seconds of the process, the windows already loaded) in child
processes, this tree and ``--baseline`` alternately, ``--rounds`` times, and prints the
smallest CPU time of each with their ratio, and whether the two walked the same staircase
(the same terms added, every step's held-out RMSE and every suspect's p-value equal to
1e-9 relative).

Run::

    python benchmarks/bench_discover_staircase.py --baseline /work/main/.venv/bin/python \\
        --baseline-path /work/main --rounds 3

``--baseline-path`` is put first on the baseline child's ``PYTHONPATH`` (the tree whose
``energy_planner`` it imports); this tree's child gets this file's repository.

Measured 2026-11-30 on the shared 2-core machine (load average 2.6-3.6 from other jobs;
the two trees ran alternately under the same load, smallest of 3 rounds), baseline main
691ce9b against branch b46 (solve_min_norm's certified LU path, the bordered and stacked
``choice_by_fold``, ``WindowData.heldout`` on samples sorted by fold with the model's
window statistics made once, run codes in the run tests)::

    campaign (small, seed)  main CPU s  b46 CPU s  ratio  same staircase
    speed_dependence 0            5.76       3.98   1.45  True
    load 0                        2.87       1.75   1.64  True
    ground 1                      2.65       1.84   1.44  True
    none 2                        1.18       0.93   1.26  True
    total                        12.46       8.51   1.47

The same at idle (load average 0.06 at the start, smallest of 2 rounds): total 11.71 CPU s
on main, 8.68 on b46, ratio 1.35 (speed_dependence 1.36, load 1.44, ground 1.32, none
1.21), the same staircase.
"""

from __future__ import annotations

import os

# one BLAS thread: thousands of small solves (as bench_discover.py)
for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import pickle  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

#: (hidden effects, seed) of the campaigns timed: a speed dependence (three speeds), a
#: payload, a ground type, and nothing hidden (the false-finding case)
CASES = [(("speed_dependence",), 0), (("load",), 0), (("ground",), 1), ((), 2)]
ROOT = Path(__file__).resolve().parents[1]


def _name(effects, seed) -> str:
    return f"{'+'.join(effects) or 'none'} {seed}"


def prepare(folder: Path) -> list[Path]:
    """Simulate and prepare every case once (this tree's code); pickle the windows."""
    from energy_planner.calibration.prepare import prepare_logs
    from energy_planner.simulate import CampaignConfig, simulate_campaign

    out = []
    for effects, seed in CASES:
        path = folder / f"{_name(effects, seed).replace(' ', '_')}.pkl"
        if not path.exists():
            cfg = CampaignConfig.small()
            if "speed_dependence" in effects:
                cfg = cfg.replace(speeds=(0.2, 0.3, 0.45))
            camp = simulate_campaign(seed=seed, effects=effects, config=cfg)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                windows = prepare_logs(camp.logs).windows
            path.write_bytes(pickle.dumps(windows))
        out.append(path)
    return out


def child(paths: list[str]) -> None:
    """Time the staircase on each pickled case; print one JSON line per case."""
    from energy_planner.calibration.fit import base_terms, identifiable
    from energy_planner.diagnosis import window_data
    from energy_planner.diagnosis.suspects import staircase
    from energy_planner.model import resolve_term

    for p in paths:
        windows = pickle.loads(Path(p).read_bytes())
        base = list(base_terms(windows))
        lost = identifiable(windows, base)
        start = [t for t in base if resolve_term(t).name not in lost]
        wd = window_data(windows)
        t0 = time.process_time()
        steps, rankings = staircase(wd, start, max_steps=2)
        cpu = time.process_time() - t0
        doc = {
            "cpu": cpu,
            "added": [s.added for s in steps],
            "rmse": [s.heldout_rmse_w for s in steps],
            "p": [[s.p_value for s in r.suspects + r.below_noise] for r in rankings],
        }
        print(json.dumps(doc), flush=True)


def _run(python: str, path: str | None, cases: list[Path]) -> list[dict]:
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    if path:
        env["PYTHONPATH"] = path
    cmd = [python, str(Path(__file__).resolve()), "--child", *map(str, cases)]
    # cwd "/": no tree is imported from the working directory
    out = subprocess.run(cmd, env=env, cwd="/", check=True, capture_output=True, text=True)
    return [json.loads(line) for line in out.stdout.splitlines() if line.startswith("{")]


def _same(a: dict, b: dict, rel: float = 1e-9) -> bool:
    def close(x, y):
        return math.isclose(x, y, rel_tol=rel) or (math.isnan(x) and math.isnan(y))

    return (
        a["added"] == b["added"]
        and all(close(x, y) for x, y in zip(a["rmse"], b["rmse"], strict=True))
        and len(a["p"]) == len(b["p"])
        and all(
            len(pa) == len(pb) and all(close(x, y) for x, y in zip(pa, pb, strict=True))
            for pa, pb in zip(a["p"], b["p"], strict=True)
        )
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", default=None, help="python of the baseline")
    ap.add_argument("--baseline-path", default=None, help="PYTHONPATH of the baseline child")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--child", nargs="*", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child is not None:
        child(args.child)
        return 0
    folder = Path(tempfile.gettempdir()) / "bench_discover_staircase"
    folder.mkdir(exist_ok=True)
    cases = prepare(folder)
    runs = [("branch", sys.executable, str(ROOT))]
    if args.baseline:
        runs.insert(0, ("baseline", args.baseline, args.baseline_path))
    got: dict[str, list[list[dict]]] = {name: [] for name, _, _ in runs}
    for r in range(args.rounds):
        for name, python, path in runs:
            got[name].append(_run(python, path, cases))
            print(f"round {r + 1} {name} done, load {os.getloadavg()[0]:.2f}", file=sys.stderr)
    best = {name: [min(rd[i]["cpu"] for rd in rounds) for i in range(len(cases))]
            for name, rounds in got.items()}  # fmt: skip
    print(f"{'campaign':<22}{'baseline s':>11}{'branch s':>10}{'ratio':>7}  same staircase")
    tot = {name: sum(v) for name, v in best.items()}
    for i, (effects, seed) in enumerate(CASES):
        b = best.get("baseline", [math.nan] * len(cases))[i]
        t = best["branch"][i]
        same = "-"
        if "baseline" in got:
            same = str(_same(got["baseline"][0][i], got["branch"][0][i]))
        print(f"{_name(effects, seed):<22}{b:>11.2f}{t:>10.2f}{b / t:>7.2f}  {same}")
    b = tot.get("baseline", math.nan)
    print(f"{'total':<22}{b:>11.2f}{tot['branch']:>10.2f}{b / tot['branch']:>7.2f}")
    load = os.getloadavg()
    print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} (2 cores shared)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
