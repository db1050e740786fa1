"""CPU time of the report figures: this tree's against another revision's, side by side.

Rows, each the median CPU seconds (``time.process_time``, this process) of one call:

- ``diagnose --report`` page: :func:`energy_planner.diagnosis.report.render_html` of the
  diagnosis of a small simulated campaign (``simulate --small --effect load``, the
  bundled default model, the ``diagnose`` pipeline with the data repairs): its five
  figures drawn and PNG-encoded, and its tables;
- ``discover --report`` staircase: :func:`~energy_planner.diagnosis.report.plot_discovery`
  of that diagnosis' staircase, encoded as the page embeds it;
- ``figures`` (Fig. 4, 5, 3): :mod:`energy_planner.calibration.figures`' force against
  slope, yaw torque and superposition PNGs of that campaign, as ``figures CAMP --model``
  draws them with the bundled default model.

A is this tree; B is ``energy_planner/diagnosis/report.py`` and
``energy_planner/calibration/figures.py`` of revision ``--baseline`` (``git show``),
loaded beside them and run on the same inputs. The rows run in rounds, A then B in each,
so both see the same machine however its load drifts; the first round warms up. The
table gives both medians and the median of the pairwise ratios A/B. The report pages are
compared too: the same HTML (``same``).

Usage::

    python benchmarks/bench_report.py [--rounds 7] [--baseline 45c2c81]

Measured 2026-11-30 on the shared 2-core machine, other jobs running (load average 3.9
at the start, 4.1 at the end), A the figures laid out for the resolution they are saved at
(``fit_layout(fig, dpi=...)``: the report's 80 dpi, the figures' 110; the text measured by
the layout is the text drawn, on one renderer), B main at 124c0f5 (laid out at the
figure's 100 dpi, every text measured again at the saved dpi on a second renderer), run
in the branch's worktree with ``PYTHONPATH=$PWD``::

    python benchmarks/bench_report.py --rounds 15 --baseline 124c0f5

    B = 124c0f5; 15 rounds; report HTML the same: False
    row                                        A cpu   B cpu    A/B
    diagnose --report page                     2.143   2.116   0.91
    discover --report staircase                0.281   0.270   0.96
    figures (Fig. 4, 5, 3)                     1.453   1.513   0.93

At that load the ratios move between runs (the page 0.91-1.06 over five runs, the figures
0.83-0.98 over four); per page, A measures the size of 130 texts where B measured 247
(cProfile: A's draw finds the sizes its layout measured).
The pages differ by the layout: the axes move by a pixel or so, the data, labels and
legends are the same (the suspects plot's tick labels now keep the layout's pad from the
image's edge, where B's came within 3 px of it).

The first measurement (2026-11-30, load 3.1-4.2), A the figures made outside pyplot and
laid out once (``new_figure``, ``fit_layout``: no layout engine left, one draw when saved),
B main at 45c2c81 (``tight_layout``, then ``savefig`` drawing every figure twice)::

    B = 45c2c81; 9 rounds; report HTML the same: True
    row                                        A cpu   B cpu    A/B
    diagnose --report page                     2.996   3.298   0.84
    discover --report staircase                0.318   0.409   0.81

Those pages were byte-identical: the same subplot parameters, one draw instead of two.
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


def _campaign():
    """``simulate --small --effect load`` (seed 0), prepared as ``diagnose`` prepares it."""
    from energy_planner.calibration import prepare_logs
    from energy_planner.simulate import CampaignConfig, simulate_campaign

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        camp = simulate_campaign(seed=0, effects=("load",), config=CampaignConfig.small())
        return camp, prepare_logs(camp.logs)


def _diagnosis(camp, prepared):
    """The diagnosis ``diagnose CAMP --report`` renders, CAMP ``simulate --small --effect load``."""
    from energy_planner.diagnosis import diagnose
    from energy_planner.model import EnergyModel

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return diagnose(EnergyModel.default(), prepared, runs_meta=camp.runs)


def _figures(mod, camp, prepared, out: Path) -> list[Path]:
    """``figures CAMP --model default``'s Fig. 4, Fig. 5 and Fig. 3 drawn by module ``mod``."""
    from energy_planner.calibration import force_estimates
    from energy_planner.calibration.figures import run_energy, superposition_table
    from energy_planner.model import EnergyModel

    model = EnergyModel.default()
    est = force_estimates(prepared.windows)
    paths = [out / "force_slope.png", out / "yaw_torque.png", out / "superposition.png"]
    mod.plot_force_slope(est, model, paths[0])
    mod.plot_yaw_torque(est, model, paths[1])
    table = superposition_table(run_energy(camp.logs), camp.runs)
    mod.plot_superposition(table, paths[2])
    return paths


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--baseline", default="main", help="git revision of B (default: main)")
    args = ap.parse_args()

    from energy_planner.calibration import figures
    from energy_planner.diagnosis import report

    old = _old_module(args.baseline, "energy_planner/diagnosis/report.py", "old_report")
    old_figures = _old_module(args.baseline, "energy_planner/calibration/figures.py", "old_figures")
    camp, prepared = _campaign()
    d = _diagnosis(camp, prepared)
    tmp = Path(tempfile.mkdtemp())
    (tmp / "a").mkdir()
    (tmp / "b").mkdir()
    table = [
        {"name": s.name, "heldout_rmse_w": s.heldout_rmse_w, "fold_rmse_w": s.fold_rmse_w,
         "run_energy_error_median": 0.05, "run_energy_error_p90": 0.1}
        for s in d.steps
    ]  # fmt: skip
    rows = {
        "diagnose --report page": (
            lambda: report.render_html(d),
            lambda: old.render_html(d),
        ),
        "discover --report staircase": (
            lambda: report._png(report.plot_discovery(table)),
            lambda: old._png(old.plot_discovery(table)),
        ),
        "figures (Fig. 4, 5, 3)": (
            lambda: _figures(figures, camp, prepared, tmp / "a"),
            lambda: _figures(old_figures, camp, prepared, tmp / "b"),
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
    print(f"B = {args.baseline}; {args.rounds} rounds; report HTML the same: {same}")
    print(f"{'row':40s} {'A cpu':>7s} {'B cpu':>7s} {'A/B':>6s}")
    for key, (a, b) in times.items():
        ratio = statistics.median(x / y for x, y in zip(a, b, strict=True))
        print(f"{key:40s} {statistics.median(a):7.3f} {statistics.median(b):7.3f} {ratio:6.2f}")


if __name__ == "__main__":
    main()
