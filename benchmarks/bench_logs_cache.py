"""``fit`` on a log folder read before: the cache of ``load_logs`` and ``prepare_logs``.

Two measurements, each printing the wall and CPU seconds (user + system of the child
processes) and the ratios:

1. ``energy-planner fit CAMPAIGN --out m.json`` of a simulated campaign
   (``simulate --small --effect load``: 95 CSV logs), in whole processes: *cold* (the
   cache folder's ``logs`` entries removed first: every file read, checked, repaired,
   cleaned and windowed) and *warm* (the entries of the run before: the samples and the
   prepared logs read back, :mod:`energy_planner.measurements.stored`), in rounds that
   alternate which runs first; one untimed run first (kernels compiled, files in the page
   cache). Also *off* (``ENERGY_PLANNER_LOG_CACHE=0``, every run cold: what a command
   cost without the cache) and, with ``--baseline BIN``, the same command of another
   checkout's environment. The model each run writes is compared with the cold one's
   (the same JSON but its timestamps).
2. With ``--tests``: the CPU seconds of the test files whose commands re-read the same
   folders (``test_examples``' calibration and README chains, ``test_heldout_agree``,
   ``test_cli_fit``, ``test_diagnosis_units``, ``test_discover``'s command tests), each
   by ``/usr/bin/time -v python -m pytest -n 0 FILE`` with the cache folder's ``logs``
   entries removed first (a suite's first run), A (this checkout, ``PYTHONPATH``) and,
   with ``--baseline``, B (the other checkout's tests with its own package), in turn;
   the cache folder starts with hard links to the user's compiled kernels (as a suite
   run on this machine finds them).

Usage::

    python benchmarks/bench_logs_cache.py [--rounds 5] [--baseline /work/main/.venv/bin]
        [--tests] [--main /work/main]

The cache folder is a temporary one (``ENERGY_PLANNER_CACHE``), so the user's is left
alone; the kernels compiled into it by the untimed first run are kept for the timed ones.

Measured 2026-11-30 on the shared 2-core machine, other jobs running (load average 2.5 to
5.4), A the branch a46 (the cache), B main at 691ce9b (no cache)::

    python benchmarks/bench_logs_cache.py --rounds 3 --baseline /work/main/.venv/bin

    row          wall s    cpu s  wall/cold  cpu/cold
    cold          10.06     6.23       1.00      1.00
    warm           4.90     2.81       0.49      0.45
    off           13.09     6.49       1.30      1.04
    baseline       9.33     6.58       0.93      1.06
    paired warm/cold CPU ratio: median 0.44
    warm model equals cold model: True; off equals cold: True

A second ``fit`` of the folder costs 0.44 of the first (CPU); the first costs what it
costs without the cache (off, main: 1.04-1.06 of cold, within the scatter: hashing the
samples and writing the two entries, ~5 MB, are a few tens of ms).

    python benchmarks/bench_logs_cache.py --no-fit --tests --baseline /work/main/.venv/bin

    file                                           A cpu   B cpu   A/B
    tests/test_examples.py -k 'calibration or README'    72.3    76.3  0.95
    tests/test_heldout_agree.py                     25.2    32.2  0.78
    tests/test_cli_fit.py                           22.0    25.5  0.86
    tests/test_diagnosis_units.py                   33.1    38.8  0.85
    tests/test_discover.py -k 'cli'                 15.1    16.5  0.92
    all                                            167.7   189.2  0.89

and the same for whole files that prepare the same simulated samples in several tests
(the entry of ``prepare_logs`` is keyed by the samples' content): ``test_discover.py``
66.9 against 69.7, ``test_discover_undecided.py`` 14.4 against 16.0,
``test_calibration_sim.py`` 10.1 against 10.9 CPU s. The README chain reads each of its
folders once (nothing to answer again); the calibration chain's five commands on one
folder read and prepare it once, the other four read both entries back (~20 ms each).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent.parent
CLI = "from energy_planner.cli import main; main()"
TEST_FILES = (
    ("tests/test_examples.py", "calibration or README"),
    ("tests/test_heldout_agree.py", None),
    ("tests/test_cli_fit.py", None),
    ("tests/test_diagnosis_units.py", None),
    ("tests/test_discover.py", "cli"),
)


def _env(cache: Path, *, path: Path | None, **extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH",)}
    if path is not None:
        env["PYTHONPATH"] = str(path)
    env["ENERGY_PLANNER_CACHE"] = str(cache)
    env["MPLBACKEND"] = "Agg"
    env.update(extra)
    return env


def _timed(cmd: list[str], env: dict[str, str], cwd: Path) -> tuple[float, float]:
    """(wall s, CPU s) of one child process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, cwd=cwd, env=env, check=True, capture_output=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def _model(path: Path) -> dict:
    doc = json.loads(path.read_text())
    doc.get("metadata", {}).pop("created", None)
    doc.get("metadata", {}).pop("fitted_at", None)
    return doc


def _user_cache() -> Path:
    env = os.environ.get("ENERGY_PLANNER_CACHE")
    if env:
        return Path(env)
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "energy_planner"


def _forget(cache: Path) -> None:
    shutil.rmtree(cache / "logs", ignore_errors=True)


def bench_fit(rounds: int, baseline: Path | None) -> None:
    work = Path(tempfile.mkdtemp(prefix="bench_logs_cache."))
    cache = work / "cache"
    py = sys.executable
    env_a = _env(cache, path=HERE)
    subprocess.run(
        [py, "-c", CLI, "simulate", "--out", str(work / "campaign"), "--small", "--effect", "load"],
        env=env_a, check=True, capture_output=True,
    )  # fmt: skip
    fit = ["fit", str(work / "campaign"), "--out"]
    rows: dict[str, list[tuple[float, float]]] = {"cold": [], "warm": [], "off": []}
    runs = {
        "cold": lambda: ([py, "-c", CLI, *fit, str(work / "cold.json")], env_a),
        "warm": lambda: ([py, "-c", CLI, *fit, str(work / "warm.json")], env_a),
        "off": lambda: (
            [py, "-c", CLI, *fit, str(work / "off.json")],
            _env(cache, path=HERE, ENERGY_PLANNER_LOG_CACHE="0"),
        ),
    }
    if baseline is not None:
        rows["baseline"] = []
        runs["baseline"] = lambda: (
            [str(baseline / "python"), "-c", CLI, *fit, str(work / "base.json")],
            _env(cache, path=None),
        )
    for name in runs:  # untimed: kernels compiled, files in the page cache
        cmd, env = runs[name]()
        subprocess.run(cmd, env=env, check=True, capture_output=True, cwd=work)
    order = list(runs)
    for r in range(rounds):
        for name in order if r % 2 == 0 else order[::-1]:
            if name == "cold":
                _forget(cache)
            elif name == "warm":  # the entries of a cold run of this process
                cmd, env = runs["cold"]()
                if not (cache / "logs").is_dir():
                    subprocess.run(cmd, env=env, check=True, capture_output=True, cwd=work)
            cmd, env = runs[name]()
            rows[name].append(_timed(cmd, env, work))
    same = _model(work / "warm.json") == _model(work / "cold.json")
    same_off = _model(work / "off.json") == _model(work / "cold.json")
    print(f"fit of a simulated campaign (95 CSV logs), medians of {rounds} rounds")
    print(f"load average {os.getloadavg()[0]:.1f}")
    print(f"{'row':<10} {'wall s':>8} {'cpu s':>8} {'wall/cold':>10} {'cpu/cold':>9}")
    cold_w = statistics.median(w for w, _ in rows["cold"])
    cold_c = statistics.median(c for _, c in rows["cold"])
    for name, vals in rows.items():
        w = statistics.median(v[0] for v in vals)
        c = statistics.median(v[1] for v in vals)
        print(f"{name:<10} {w:>8.2f} {c:>8.2f} {w / cold_w:>10.2f} {c / cold_c:>9.2f}")
    pairs = [c_w[1] / c_c[1] for c_w, c_c in zip(rows["warm"], rows["cold"], strict=True)]
    print(f"paired warm/cold CPU ratio: median {statistics.median(pairs):.2f}")
    print(f"warm model equals cold model: {same}; off equals cold: {same_off}")
    shutil.rmtree(work, ignore_errors=True)


def _pytest_cpu(python: str, root: Path, file: str, k: str | None, env: dict) -> tuple[float, str]:
    cmd = ["/usr/bin/time", "-v", python, "-m", "pytest", "-q", "-p", "no:cacheprovider"]
    cmd += ["-n", "0", file] + (["-k", k] if k else [])
    out = subprocess.run(cmd, cwd=root, env=env, capture_output=True, text=True)
    user = float(re.search(r"User time \(seconds\): ([\d.]+)", out.stderr).group(1))
    sys_ = float(re.search(r"System time \(seconds\): ([\d.]+)", out.stderr).group(1))
    tail = out.stdout.strip().splitlines()[-1] if out.stdout.strip() else "?"
    return user + sys_, tail


def bench_tests(baseline: Path | None, main: Path) -> None:
    cache = Path(tempfile.mkdtemp(prefix="bench_logs_cache_tests.")) / "cache"
    cache.mkdir()
    kernels = _user_cache() / "kernels"
    if kernels.is_dir():  # compiled kernels as a suite's run finds them (hard links: no copy)
        subprocess.run(["cp", "-al", str(kernels), str(cache / "kernels")], check=False)
    env_a = _env(cache, path=HERE)
    env_b = _env(cache, path=None)
    print(f"\nCPU s of test files (pytest -n 0, the logs entries removed first), load "
          f"{os.getloadavg()[0]:.1f}")  # fmt: skip
    print(f"{'file':<44} {'A cpu':>7} {'B cpu':>7} {'A/B':>5}")
    total_a = total_b = 0.0
    for file, k in TEST_FILES:
        _forget(cache)
        a, tail_a = _pytest_cpu(sys.executable, HERE, file, k, env_a)
        b, tail_b = float("nan"), ""
        if baseline is not None:
            _forget(cache)
            b, tail_b = _pytest_cpu(str(baseline / "python"), main, file, k, env_b)
        total_a += a
        total_b += b
        label = file + (f" -k '{k}'" if k else "")
        print(f"{label:<44} {a:>7.1f} {b:>7.1f} {a / b:>5.2f}   A: {tail_a}   B: {tail_b}")
    print(f"{'all':<44} {total_a:>7.1f} {total_b:>7.1f} {total_a / total_b:>5.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--baseline", type=Path, default=None, help="bin folder of another venv")
    ap.add_argument("--main", type=Path, default=Path("/work/main"), help="its checkout")
    ap.add_argument("--tests", action="store_true", help="also the test files' CPU seconds")
    ap.add_argument("--no-fit", action="store_true", help="only the test files")
    args = ap.parse_args()
    if not args.no_fit:
        bench_fit(args.rounds, args.baseline)
    if args.tests:
        bench_tests(args.baseline, args.main)


if __name__ == "__main__":
    main()
