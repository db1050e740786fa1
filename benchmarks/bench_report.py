"""CPU time of the report figures: this tree's against another revision's, side by side.

Rows, each the median CPU seconds (``time.process_time``, this process) of one call:

- ``diagnose --report`` page: :func:`energy_planner.diagnosis.report.render_html` of the
  diagnosis of a small simulated campaign (``simulate --small --effect load``, the
  bundled default model, the ``diagnose`` pipeline with the data repairs): its five
  figures drawn and PNG-encoded, and its tables;
- ``discover --report`` staircase: :func:`~energy_planner.diagnosis.report.plot_discovery`
  of that diagnosis' staircase, encoded as the page embeds it;
- a map laid out with ``tight_layout`` (a 600 x 400 hillshade, a route, a legend, long
  tick labels), written by :func:`energy_planner.io.save_figure` at 120 dpi as ``plan``,
  ``reach`` and ``energy-map`` write theirs.

A is this tree; B is ``energy_planner/diagnosis/report.py`` and the ``save_figure`` of
revision ``--baseline`` (``git show``), loaded beside it and run on the same diagnosis.
The rows run in rounds, A then B in each, so both see the same machine however its load
drifts; the first round warms up. The table gives both medians and the median of the
pairwise ratios A/B. The report pages are compared too: the same HTML (``same``).

Usage::

    python benchmarks/bench_report.py [--rounds 7] [--baseline 45c2c81]

Measured 2026-11-30 on the shared 2-core machine, other jobs running (load average
about 2.5), A the figures laid out once (``fit_layout``, ``save_figure`` setting aside
the placeholder engine ``tight_layout`` leaves), B main at 45c2c81 (``tight_layout``,
then ``savefig`` drawing every figure twice), run in the branch's worktree with
``PYTHONPATH=$PWD``::

    python benchmarks/bench_report.py --rounds 7 --baseline 45c2c81

(see the commit message of this file for the table)
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import tempfile
import time
import types
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def _old_module(rev: str, path: str, name: str) -> types.ModuleType:
    """``path`` of revision ``rev`` as a module of its own (its imports from this tree)."""
    src = subprocess.run(
        ["git", "-C", str(ROOT), "show", f"{rev}:{path}"], capture_output=True, text=True,
        check=True,
    ).stdout  # fmt: skip
    mod = types.ModuleType(name)
    mod.__file__ = f"{rev}:{path}"
    exec(compile(src, mod.__file__, "exec"), mod.__dict__)
    return mod


def _diagnosis():
    """The diagnosis ``diagnose CAMP --report`` renders, CAMP ``simulate --small --effect load``."""
    from energy_planner.calibration import prepare_logs
    from energy_planner.diagnosis import diagnose
    from energy_planner.model import EnergyModel
    from energy_planner.simulate import CampaignConfig, simulate_campaign

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        camp = simulate_campaign(seed=0, effects=("load",), config=CampaignConfig.small())
        prepared = prepare_logs(camp.logs)
        return diagnose(EnergyModel.default(), prepared, runs_meta=camp.runs)


def _map(save, path: Path) -> None:
    """A map as the planning plots draw one: hillshade, route, legend, ``tight_layout``."""
    from energy_planner.plotting import new_figure

    fig, ax = new_figure(figsize=(8, 6))
    y, x = np.mgrid[0:400, 0:600]
    ax.imshow(np.sin(x / 40.0) * np.cos(y / 55.0), cmap="gray", extent=(0, 600, 0, 400))
    t = np.linspace(0, 1, 400)
    ax.plot(50 + 500 * t, 50 + 300 * t**2, color="C0", lw=2, label="route (1234.5 J)")
    ax.scatter([50, 550], [50, 350], color="k", zorder=3, label="start, goal")
    ax.set_xlabel("x (EPSG:32631, m)")
    ax.set_ylabel("y (EPSG:32631, m)")
    ax.legend(loc="upper left")
    fig.tight_layout()
    save(fig, path, dpi=120)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--baseline", default="main", help="git revision of B (default: main)")
    args = ap.parse_args()

    from energy_planner.diagnosis import report
    from energy_planner.io import save_figure

    old = _old_module(args.baseline, "energy_planner/diagnosis/report.py", "old_report")
    old_io = _old_module(args.baseline, "energy_planner/io/atomic.py", "old_atomic")
    d = _diagnosis()
    table = [
        {"name": s.name, "heldout_rmse_w": s.heldout_rmse_w, "fold_rmse_w": s.fold_rmse_w,
         "run_energy_error_median": 0.05, "run_energy_error_p90": 0.1}
        for s in d.steps
    ]  # fmt: skip
    out = Path(tempfile.mkdtemp(prefix="bench_report_"))
    rows = {
        "diagnose --report page": (
            lambda: report.render_html(d),
            lambda: old.render_html(d),
        ),
        "discover --report staircase": (
            lambda: report._png(report.plot_discovery(table)),
            lambda: old._png(old.plot_discovery(table)),
        ),
        "tight_layout map, save_figure 120 dpi": (
            lambda: _map(save_figure, out / "a.png"),
            lambda: _map(old_io.save_figure, out / "b.png"),
        ),
    }
    same = report.render_html(d) == old.render_html(d)
    times: dict[str, tuple[list[float], list[float]]] = {k: ([], []) for k in rows}
    for r in range(args.rounds + 1):
        for key, (a, b) in rows.items():
            ta = time.process_time()
            a()
            ta = time.process_time() - ta
            tb = time.process_time()
            b()
            tb = time.process_time() - tb
            if r:  # the first round warms up
                times[key][0].append(ta)
                times[key][1].append(tb)
    png_same = (out / "a.png").read_bytes() == (out / "b.png").read_bytes()
    print(f"B = {args.baseline}; {args.rounds} rounds; report HTML the same: {same}; "
          f"map PNG the same: {png_same}")  # fmt: skip
    print(f"{'row':40s} {'A cpu':>7s} {'B cpu':>7s} {'A/B':>6s}")
    for key, (a, b) in times.items():
        ratio = statistics.median(x / y for x, y in zip(a, b, strict=True))
        print(f"{key:40s} {statistics.median(a):7.3f} {statistics.median(b):7.3f} {ratio:6.2f}")


if __name__ == "__main__":
    main()
