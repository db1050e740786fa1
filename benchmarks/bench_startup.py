"""Start-up time of the command line, each command beside its baselines and its target.

Rows, each the median wall and CPU time (user + system, the child's own accounting) of
whole processes after one warm-up run:

- ``python -c pass``: the interpreter alone (the floor of any command);
- ``--help`` as it was: a listing that imports every command module (what click's default
  ``format_commands`` did before the summaries moved into ``energy_planner.cli.COMMANDS``);
- ``import click``: what a ``--help`` rendered by click pays before it prints (click's
  own imports: typing, inspect, uuid, datetime, platform, gettext);
- ``energy-planner --help``: the group's help, printed by ``energy_planner.cli`` without
  importing click (:func:`energy_planner.cli.group_help`);
- ``import numba`` plus the first call of one cached ``@njit`` function (the floor of any
  command that prices energy with the compiled kernels: numba's import, its typing and
  target registries, and the scipy.linalg import its BLAS check makes);
- a warm ``energy-planner energy`` of the direct climb on the bundled hill (kernels cached:
  the model's precompiled module, which loads without numba);
- the same with a model that reads a channel (the bundled model plus ``load_kg * speed``)
  and one ``--set load_kg=10`` in every run, then a ``--set load_kg=`` value never given
  before in each run (the model's kernels cached, the value new: the pair shows what a
  new value costs), and with a numeric channel raster never given before (a new file of
  new values each run, ``--channel load_kg=RASTER``);
- ``energy-planner energy-map`` of the hill with such a new value (fewer runs: a baseline
  that compiles its kernels for every value takes a minute a run).

The rows run in rounds: each round runs every row once, in turn, so rows compared with
each other (a warm run, a repeated value, a new value, a new raster) see the same machine
however its load drifts; the first round warms up. Every row also runs ``gdaldem slope``
on the hill in turn with it (the GIS tool's start-up and a whole small job: what a GIS
user compares a command with), and prints the target of the row (``--help`` 0.1 s, a
warm ``energy`` 0.5 s) with ``met`` when the median wall time is within it. Without
``gdaldem`` on the path (``apt-get install gdal-bin``) that column says so. The children
run with ``PYTHONDONTWRITEBYTECODE`` unset, as an installed package runs (its modules'
bytecode cached, under the temporary directory), whatever this shell sets; the baseline
runs without ``PYTHONPATH`` (its own package). The header says whether each
environment's interpreter imports setuptools' editable-install finder at every start
(an install made before the project's ``package-dir`` setting: ``pip install -e .``
again drops it).

With ``--baseline BIN`` (the ``bin`` directory of a virtual environment with another
checkout installed, e.g. ``main``'s) every row also runs there, A and B in turn, and the
table gives both medians and the median of the pairwise ratios A/B (pairs keep the ratio
meaningful when the shared machine's speed drifts). CPU seconds move much less than wall
seconds with the machine's load: both are printed.

Usage::

    python benchmarks/bench_startup.py [--runs 7] [--map-runs 3] [--baseline ../main/.venv/bin]

Measured 2026-11-29 on the shared 2-core machine, other jobs running (load average 3.9
at the start, 5.4 at the end: wall seconds are inflated about twice, the CPU seconds and
the paired ratios hold better); A the ``--help`` printed without click, B main at
b68ae2d (its ``--help`` rendered by click), medians of 9 (energy-map: 2), run in the
branch's worktree with ``PYTHONPATH=$PWD``::

    python benchmarks/bench_startup.py --runs 9 --map-runs 2 --baseline /work/main/.venv/bin

    row                                        A wall  A cpu  B wall  B cpu  A/B wall  A/B cpu
    python -c pass (floor)                      0.045  0.020   0.042  0.020      1.00     1.00
    import click (floor of a --help through ..  0.202  0.101   0.202  0.100      0.98     0.99
    energy-planner --help                       0.078  0.039   0.205  0.097      0.42     0.38
    energy, hill, warm                          0.996  0.488   1.004  0.465      1.07     1.07
    energy, hill, one --set value, the same     1.052  0.519   1.004  0.496      1.06     1.02
    energy, hill, a new --set value             1.168  0.544   1.103  0.528      1.07     1.04
    energy, hill, a new numeric channel raster  1.110  0.539   1.072  0.523      1.04     1.00
    energy-map, hill, a new --set value         2.830  1.363   2.568  1.257      1.11     1.10

``--help`` is 0.4 of main's (0.039 CPU s against 0.097; at load 7.3 another run gave
0.055 s wall against 0.155). The energy rows load the same modules in A and B (A one
more, the group's) and A runs each round first: their A/B ratios of 1.00-1.07 are within
what that order and the load give (alternating the order at load 4.6, 25 pairs of the
warm row gave 1.015 CPU). A new ``--set`` value costs what the same value each run
costs, within the scatter between rounds (in A 0.544 against 0.519 CPU s here, 0.487
against 0.571 in a run of 21 rounds at load 7.9): the value is a run-time input of the
model's cached precompiled module, and the two command lines import the same modules
(listed, diffed).

Measured again 2026-11-29 (load 4.8 falling to 3.4, other jobs running), A the branch
that binds extension modules lazily, reads a band's mask without ``numpy.ma``, parses
each term formula once and reads CSV waypoints without the ROS bag module, B main at
cfdef37, medians of 7 (energy-map: 2)::

    python benchmarks/bench_startup.py --runs 7 --map-runs 2 --baseline /work/main/.venv/bin

    row                                        A wall  A cpu  B wall  B cpu  A/B wall  A/B cpu
    python -c pass (floor)                      0.032  0.027   0.033  0.022      1.08     1.03
    energy-planner --help                       0.060  0.038   0.056  0.040      1.01     1.01
    energy, hill, warm                          0.610  0.413   0.647  0.510      0.91     0.89
    energy, hill, one --set value, the same     0.583  0.507   0.633  0.548      0.96     0.95
    energy, hill, a new --set value             0.658  0.495   0.608  0.524      0.96     0.96
    energy, hill, a new numeric channel raster  0.585  0.451   0.676  0.511      0.93     0.92
    energy-map, hill, a new --set value         2.802  1.376   2.932  1.448      0.96     0.95

The wall seconds are the load's (a warm ``energy`` is 0.35-0.55 s when a core is free);
the instructions, which no load moves, of a warm ``energy`` on the hill
(``valgrind --tool=callgrind energy-planner energy --dem hill.tif --waypoints
direct.csv``, byte code cached): 941 M against main's 1028 M (-8.5 %; the same every run
to 0.02 %); of ``energy-map`` of the hill 1176 M against 1217 M. The two groups the warm
row's wall times fell in, by run (0.35-0.39 and 0.48-0.55 s), are not in the process:
its instruction count and page faults (9673-9680, ``perf stat``) are the same in every
run, and every run opens the same files (``strace -f -e trace=openat``). At load 1.8,
15 whole-process runs of the warm row in turn with main's: median 0.412 s wall,
0.411 CPU s (0.335-0.525 s) against 0.474 s, 0.472 (0.356-0.565 s): paired 0.90.

Measured again 2026-11-29 (load 5.4 rising to 6.1, other jobs running), A the branch
whose ``energy`` reads a DEM read before back from the cache folder without rasterio
(``energy_planner.terrain.stored``), loads the DEM reader's modules only when a DEM is
read and the progress module only for ``--quiet``, B main at e5c71ed, medians of 7
(energy-map: 2)::

    python benchmarks/bench_startup.py --runs 7 --map-runs 2 --baseline /work/main/.venv/bin

    row                                        A wall  A cpu  B wall  B cpu  A/B wall  A/B cpu
    python -c pass (floor)                      0.032  0.022   0.031  0.022      0.92     1.00
    energy-planner --help                       0.056  0.039   0.055  0.035      0.99     0.99
    energy, hill, warm                          0.560  0.361   0.653  0.408      0.73     0.74
    energy, hill, one --set value, the same     0.383  0.266   0.570  0.362      0.70     0.73
    energy, hill, a new --set value             0.437  0.275   0.634  0.399      0.73     0.73
    energy, hill, a new numeric channel raster  0.624  0.434   0.616  0.457      0.98     0.96
    energy-map, hill, a new --set value         2.195  1.156   1.949  1.214      1.11     0.96

(``gdaldem slope`` of the hill 0.15-0.17 s in turn with each row.) The instructions of a
warm ``energy`` on the hill (callgrind, as above): 689 M against main's 941 M (0.73); the
first ``energy`` on a DEM, which reads it with rasterio and keeps it, 950 M against 939 M.
The channel raster row reads its new raster with rasterio, so it keeps main's cost (969 M
instructions against the same ``--set`` value's 688 M): a new raster is new data, which
only GDAL reads. At load 4.0-5.2, 25 whole-process runs of the warm row in turn with
main's: median 0.368 s wall, 0.239 CPU s against 0.510 s, 0.332 (paired 0.73 wall, 0.72
CPU), peak memory 38 MiB against 75.

Measured 2026-11-29 idle (load 0.05 at the start, 0.87 at the end; no other job), main at
f303cd3, the machine in its slower state (``gdaldem slope`` of the hill 0.12 s)::

    python benchmarks/bench_startup.py --runs 11 --map-runs 2

    command                                     runs A wall  A cpu gdal wall A/gdal target
    python -c pass (floor)                        11  0.023  0.022     0.118    0.2
    energy-planner --help                         11  0.043  0.042     0.122    0.4 0.10 met
    energy, hill, warm                            11  0.325  0.322     0.123    2.6 0.50 met
    energy, hill, one --set value, the same       11  0.326  0.321     0.122    2.7 0.50 met
    energy, hill, a new --set value               11  0.338  0.335     0.124    2.8 0.50 met
    energy, hill, a new numeric channel raster    11  0.476  0.472     0.116    3.9 0.50 met
    energy-map, hill, a new --set value            2  0.884  1.239     0.119    7.6

The same warm row took 0.48-0.51 s in that state at 941 M instructions; at 689 M it takes
0.325 s. A new channel raster is read with rasterio (its import and open), 0.15 s over the
warm row.
"""

from __future__ import annotations

import argparse
import itertools
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

OLD_HELP = (
    "import importlib\n"
    "from click.testing import CliRunner\n"
    "from energy_planner.cli import COMMANDS, main\n"
    "for mod, _ in COMMANDS.values():\n"
    "    importlib.import_module('energy_planner.cli.' + mod)\n"
    "CliRunner().invoke(main, ['--help'])\n"
)
NUMBA_FLOOR = "import numba\n@numba.njit(cache=True)\ndef f(x):\n    return x + 1.0\nf(1.0)\n"
LOAD_MODEL = (
    "import sys\n"
    "from energy_planner.model import EnergyModel\n"
    "m = EnergyModel.default()\n"
    "coefs = {**m.coefficients, 'load_kg * speed': 5.0}\n"
    "EnergyModel([t.name for t in m.terms] + ['load_kg * speed'], coefs).save(sys.argv[1])\n"
)
#: A value of ``load_kg`` never given before: a fresh one for every run of every row.
_FRESH = itertools.count()
_SALT = time.time_ns() % 1_000_000


def fresh_value() -> str:
    """A ``load_kg`` value that no earlier run (of this or another call) has used."""
    return f"{10 + next(_FRESH) + _SALT * 1e-6:.6f}"


_RASTER = re.compile(r"\{raster:([^}]*)\}")
#: Target wall seconds of a row (by the start of its name), from the project's goals.
TARGETS = {"energy-planner --help": 0.1, "energy, hill": 0.5}
#: The environment of every child: bytecode cached, as an installed package runs (in a
#: directory of its own, so that no checkout gets files written into it).
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
ENV["PYTHONPYCACHEPREFIX"] = str(Path(tempfile.gettempdir()) / "bench_startup_pycache")
#: The baseline's: its own installed package, whatever PYTHONPATH this shell sets.
BASE_ENV = {k: v for k, v in ENV.items() if k != "PYTHONPATH"}


def fresh_raster(cwd: str, hill: str) -> str:
    """A new ``load_kg`` raster on the hill's grid (new values, new file) in ``cwd``."""
    import numpy as np
    import rasterio

    v = float(fresh_value())
    path = Path(cwd, f"load_{v:.6f}.tif")
    with rasterio.open(hill) as src:
        prof = dict(src.profile, dtype="float32", count=1, nodata=None)
        data = np.full((src.height, src.width), v, dtype=np.float32)
        data += np.linspace(0.0, 1.0, src.width, dtype=np.float32)[None, :]
    with rasterio.open(path, "w", **prof) as dst:
        dst.write(data, 1)
    return str(path)


def run(cmd: list[str], cwd: str, env: dict[str, str] | None = None) -> tuple[float, float]:
    """Wall and CPU seconds of one whole process.

    ``{new}`` in ``cmd``: a fresh value; ``{raster:HILL}``: a fresh raster on HILL's grid.
    """
    cmd = [c.replace("{new}", fresh_value()) if "{new}" in c else c for c in cmd]
    cmd = [_RASTER.sub(lambda m: fresh_raster(cwd, m.group(1)), c) for c in cmd]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, cwd=cwd, capture_output=True, check=True, env=env or ENV)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def editable_finder(bin_dir: Path, env: dict[str, str]) -> str:
    """``yes`` if a start of ``bin_dir``'s python imports setuptools' editable-install finder.

    A flat-layout ``pip install -e .`` without ``package-dir`` puts that finder (and its
    pathlib and urllib imports) in every start of every command; the project's
    ``package-dir = {"" = "."}`` makes it a plain path in a ``.pth`` file instead.
    """
    code = "import sys; print(any(m.startswith('__editable__') for m in sys.modules))"
    out = subprocess.run([str(bin_dir / "python"), "-c", code], capture_output=True,
                         text=True, env=env, check=True).stdout  # fmt: skip
    return "yes" if out.strip() == "True" else "no"


def rows(bin_dir: Path, hill: str, model: str) -> list[tuple[str, list[str], bool]]:
    """``(name, command, is_map_row)`` of every row, for the environment in ``bin_dir``."""
    py, ep = str(bin_dir / "python"), str(bin_dir / "energy-planner")
    energy = [ep, "energy", "--dem", hill, "--waypoints", "direct.csv"]
    return [
        ("python -c pass (floor)", [py, "-c", "pass"], False),
        ("--help, listing imports every command (before)", [py, "-c", OLD_HELP], False),
        ("import click (floor of a --help through click)", [py, "-c", "import click"], False),
        ("energy-planner --help", [ep, "--help"], False),
        ("import numba + one cached njit call (floor)", [py, "numba_floor.py"], False),
        ("energy, hill, warm", energy, False),
        (
            "energy, hill, one --set value, the same each run",
            [*energy, "--model", model, "--set", "load_kg=10"],
            False,
        ),  # fmt: skip
        (
            "energy, hill, a new --set value",
            [*energy, "--model", model, "--set", "load_kg={new}"],
            False,
        ),  # fmt: skip
        (
            "energy, hill, a new numeric channel raster",
            [*energy, "--model", model, "--channel", f"load_kg={{raster:{hill}}}"],
            False,
        ),  # fmt: skip
        (
            "energy-map, hill, a new --set value",
            [
                ep,
                "energy-map",
                hill,
                "--out",
                "map.tif",
                "--model",
                model,
                "--set",
                "load_kg={new}",
            ],
            True,
        ),  # fmt: skip
    ]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=7, help="counted runs per row")
    ap.add_argument("--map-runs", type=int, default=3, help="counted runs of the map row")
    ap.add_argument("--baseline", type=Path, help="bin directory of the baseline's venv")
    ap.add_argument("--only", help="run only the rows whose name contains this text")
    args = ap.parse_args()
    from energy_planner.maps import map_path

    here = Path(sys.executable).parent
    hill = str(map_path("hill"))
    with tempfile.TemporaryDirectory() as d:
        Path(d, "direct.csv").write_text("x,y\n500058,5000046\n500058,5000109\n")
        Path(d, "numba_floor.py").write_text(NUMBA_FLOOR)
        model = str(Path(d, "load_model.json"))
        subprocess.run([sys.executable, "-c", LOAD_MODEL, model], check=True)
        a_rows = rows(here, hill, model)
        b_rows = rows(args.baseline, hill, model) if args.baseline else [None] * len(a_rows)
        against = f", B = {args.baseline}" if args.baseline else ""
        gdaldem = shutil.which("gdaldem")
        gdal = [gdaldem, "slope", "-q", hill, "slope.tif"] if gdaldem else None
        print(f"python {' '.join(sys.argv)}")
        print(f"load average {os.getloadavg()[0]:.1f}; medians of whole processes after one "
              f"warm-up run; A = {here}{against}; gdaldem = `gdaldem slope` of the hill, "
              f"run in turn with each row"
              + ("" if gdal else " (not installed: apt-get install gdal-bin)"))  # fmt: skip
        finder = f"A {editable_finder(here, ENV)}"
        if args.baseline:
            finder += f", B {editable_finder(args.baseline, BASE_ENV)}"
        print(f"setuptools' editable-install finder imported by every start: {finder}")
        head = f"{'command':<48} {'runs':>4} {'A wall s':>8} {'A cpu s':>8}"
        if args.baseline:
            head += f" {'B wall s':>8} {'B cpu s':>8} {'A/B wall':>8} {'A/B cpu':>8}"
        head += f" {'gdal wall':>9} {'gdal cpu':>8} {'A/gdal wall':>11} {'target s':>8}"
        print(head)
        todo = [
            (a, b, args.map_runs if a[2] else args.runs)
            for a, b in zip(a_rows, b_rows, strict=True)
            if not args.only or args.only in a[0]
        ]
        times: list[tuple[list, list, list]] = [([], [], []) for _ in todo]
        # rounds: each round runs every row once, in turn (A, B, gdaldem), so that rows
        # meant to be compared (a warm run, a new value, a new raster) see the same machine
        for i in range(max((n for *_, n in todo), default=0) + 1):  # round 0 warms up
            for (a, b, n), (ta, tb, tg) in zip(todo, times, strict=True):
                if i > n:
                    continue
                wa = run(a[1], d)
                wb = run(b[1], d, BASE_ENV) if b else None
                wg = run(gdal, d) if gdal else None
                if i:
                    ta.append(wa)
                    if wb:
                        tb.append(wb)
                    if wg:
                        tg.append(wg)
        for (a, _, n), (ta, tb, tg) in zip(todo, times, strict=True):
            name = a[0]
            line = (f"{name:<48} {n:>4} {statistics.median(t[0] for t in ta):>8.3f} "
                    f"{statistics.median(t[1] for t in ta):>8.3f}")  # fmt: skip
            if tb:
                rw = statistics.median(x[0] / y[0] for x, y in zip(ta, tb, strict=True))
                rc = statistics.median(x[1] / y[1] for x, y in zip(ta, tb, strict=True))
                wb, cb = (statistics.median(t[k] for t in tb) for k in (0, 1))
                line += f" {wb:>8.3f} {cb:>8.3f} {rw:>8.2f} {rc:>8.2f}"
            if tg:
                rg = statistics.median(x[0] / y[0] for x, y in zip(ta, tg, strict=True))
                gw, gc = (statistics.median(t[k] for t in tg) for k in (0, 1))
                line += f" {gw:>9.3f} {gc:>8.3f} {rg:>11.1f}"
            else:
                line += f" {'-':>9} {'-':>8} {'-':>11}"
            target = next((v for k, v in TARGETS.items() if name.startswith(k)), None)
            if target is not None:
                met = statistics.median(t[0] for t in ta) <= target
                line += f" {target:>8.2f} {'met' if met else 'NOT met'}"
            print(line, flush=True)


if __name__ == "__main__":
    main()
