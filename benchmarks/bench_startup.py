"""Start-up time of the command line (issue 21 point 5), each beside its baseline.

Rows, each the median wall time of whole processes after one warm-up run:

- ``python -c pass``: the interpreter alone (the floor of any command);
- ``--help`` as it was: a listing that imports every command module (what click's default
  ``format_commands`` did before the summaries moved into ``energy_planner.cli.COMMANDS``);
- ``energy-planner --help`` now;
- ``import numba`` plus the first call of one cached ``@njit`` function (the floor of any
  command that prices energy with the compiled kernels);
- a warm ``energy-planner energy`` of the direct climb on the bundled hill (kernels cached).

Usage: ``python benchmarks/bench_startup.py [--runs 7]``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

PY = sys.executable
EP = str(Path(PY).parent / "energy-planner")

OLD_HELP = (
    "import importlib\n"
    "from click.testing import CliRunner\n"
    "from energy_planner.cli import COMMANDS, main\n"
    "for mod, _ in COMMANDS.values():\n"
    "    importlib.import_module('energy_planner.cli.' + mod)\n"
    "CliRunner().invoke(main, ['--help'])\n"
)
NUMBA_FLOOR = "import numba\n@numba.njit(cache=True)\ndef f(x):\n    return x + 1.0\nf(1.0)\n"


def wall(cmd: list[str], runs: int, cwd: str) -> list[float]:
    """Wall times of ``runs`` runs of ``cmd`` after one warm-up."""
    out = []
    for i in range(runs + 1):
        t0 = time.perf_counter()
        subprocess.run(cmd, cwd=cwd, capture_output=True, check=True)
        if i:
            out.append(time.perf_counter() - t0)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=7, help="counted runs per row")
    args = ap.parse_args()
    from energy_planner.maps import map_path

    with tempfile.TemporaryDirectory() as d:
        Path(d, "direct.csv").write_text("x,y\n500058,5000046\n500058,5000109\n")
        Path(d, "numba_floor.py").write_text(NUMBA_FLOOR)
        rows = [
            ("python -c pass (floor)", [PY, "-c", "pass"]),
            ("--help, listing imports every command (before)", [PY, "-c", OLD_HELP]),
            ("energy-planner --help (now)", [EP, "--help"]),
            ("import numba + one cached njit call (floor)", [PY, "numba_floor.py"]),
            (
                "energy-planner energy, hill, warm",
                [EP, "energy", "--dem", str(map_path("hill")), "--waypoints", "direct.csv"],
            ),
        ]
        print(f"load average {os.getloadavg()[0]:.1f}; median of {args.runs} runs")
        print(f"{'command':<50} {'median s':>9} {'min s':>7} {'max s':>7}")
        med = {}
        for name, cmd in rows:
            t = wall(cmd, args.runs, d)
            med[name] = statistics.median(t)
            print(f"{name:<50} {med[name]:>9.3f} {min(t):>7.3f} {max(t):>7.3f}")
        before, now = rows[1][0], rows[2][0]
        print(f"--help now / before: {med[now] / med[before]:.2f}")


if __name__ == "__main__":
    main()
