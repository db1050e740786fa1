"""A benchmark case run on two source trees side by side: this checkout and a baseline.

Each run is a child process ``python -c CHILD case *args`` with ``PYTHONPATH`` set to the
tree, whose last line of output is a JSON object (its CPU s and a hash of its results).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path


def tree_parser(doc: str, cases: dict[str, str]) -> argparse.ArgumentParser:
    """The options every side-by-side benchmark takes: ``--repeat``, ``--baseline``, ``--cases``."""
    ap = argparse.ArgumentParser(description=doc.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--baseline", default="/work/main", help="source tree of the method before")
    ap.add_argument("--cases", default=",".join(cases))
    return ap


def run_in_tree(tree: Path, child: str, *args: str) -> dict:
    """The JSON the child script prints last, run on the source ``tree``."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    got = subprocess.run([sys.executable, "-c", child, *args], env=env, cwd=tree,
                         capture_output=True, text=True, check=True)  # fmt: skip
    return json.loads(got.stdout.strip().splitlines()[-1])


def alternate(baseline: Path, new: Path, repeat: int, child: str, *args: str):
    """Run the case ``repeat`` times on each tree, alternated so both see the same load.

    Returns ``(base, new, cpu_base, cpu_new)``: each tree's JSON results and the median of
    their ``cpu_s``.
    """
    import statistics

    base_runs, new_runs = [], []
    for _ in range(repeat):
        base_runs.append(run_in_tree(baseline, child, *args))
        new_runs.append(run_in_tree(new, child, *args))
    cpu = [statistics.median(r["cpu_s"] for r in runs) for runs in (base_runs, new_runs)]
    return base_runs, new_runs, float(cpu[0]), float(cpu[1])
