"""Discovery: the whole staircase in one call, from raw logs to a validated model.

``discover`` (``energy-planner discover``) does what a person would do by hand with
``fit`` and ``diagnose``:

1. run the data checks (:mod:`energy_planner.measurements.datacheck`) on the raw samples and
   repair what they find (a sensor problem is a *data finding*, never a model term);
2. preprocess and cut windows as ``fit`` does;
3. start from the base model, rank every candidate effect on held-out runs, add the best
   one above noise (:mod:`energy_planner.diagnosis.suspects`), re-rank, and repeat until
   none is above noise or ``max_steps`` terms were added;
4. fit the final model on all windows (``calibration.fit_model``) and validate it by run.

Each step records the term added, its physical explanation, the suspects the data cannot
tell from it (confounded alternatives), the held-out power RMSE, the held-out run-energy
error (median and 90th percentile over runs) and the share of the held-out error removed.

The conclusion is worded by the noise floor the logs themselves show
(:func:`energy_planner.diagnosis.metrics.noise_floor`): "explains these logs" only when the
final held-out RMSE is within :data:`WITHIN_FLOOR` times that floor; otherwise the note
says that the model does NOT explain them, with the ratio.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from energy_planner.calibration.windowdata import WindowData, window_data
from energy_planner.diagnosis.metrics import NoiseFloorEstimate, noise_floor
from energy_planner.diagnosis.scoring import Undecided
from energy_planner.diagnosis.suspects import Ranking, Step, Thresholds, model_term, staircase
from energy_planner.measurements.datacheck import DataFinding
from energy_planner.model.terms import Term

#: A final held-out RMSE within this factor of the noise floor estimated from the logs is
#: "within the noise": the clean simulated campaigns end at 1.0-1.3x (docs/diagnosis.md).
WITHIN_FLOOR = 1.5


def conclusion(
    rmse_w: float,
    floor: NoiseFloorEstimate,
    *,
    suspects_left: bool,
    undecided: Undecided | None = None,
) -> str:
    """The closing note of a discovery, worded by the noise floor of the logs.

    Parameters
    ----------
    rmse_w : float
        Held-out window-power RMSE of the final model, W.
    floor : NoiseFloorEstimate
        The floor the logs show.
    suspects_left : bool
        Whether candidates above noise remain (the step limit stopped the staircase).
    undecided : Undecided, optional
        The best candidate the logs cannot decide (``Ranking.undecided``): the note says
        what it would gain and what would decide it, instead of "no candidate effect".

    Examples
    --------
    >>> f = NoiseFloorEstimate(8.0, 1.6, 7.8, 10.0, 300)
    >>> conclusion(52.0, f, suspects_left=False)[:55]
    'the model does NOT explain these logs: held-out RMSE 52'
    >>> "explains these logs within their noise" in conclusion(9.0, f, suspects_left=False)
    True
    """
    ratio = rmse_w / floor.rmse_w if floor.rmse_w > 0 else math.nan
    where = (
        f"held-out RMSE {rmse_w:.2f} W is {ratio:.1f}x the noise floor estimated from the "
        f"logs ({floor.rmse_w:.2f} W)"
    )
    if not math.isfinite(ratio):
        why = "" if undecided is None else f"; {undecided.sentence()}"
        return (
            f"no noise floor could be estimated ({floor.method}): whether the model explains "
            f"these logs is not known{why}"
        )
    if ratio > WITHIN_FLOOR:
        if suspects_left:
            why = "candidate effects remain above noise (the step limit stopped the search)"
        elif undecided is not None:
            why = f"no candidate effect is confirmed: {undecided.sentence()}"
        else:
            why = (
                "no candidate effect is above noise: something the candidates do not "
                "capture remains (try your own --term, or more runs)"
            )
        return f"the model does NOT explain these logs: {where}; {why}"
    if suspects_left:
        return (
            f"{where} (within {WITHIN_FLOOR}x), but candidate effects remain above noise "
            "(the step limit stopped the search)"
        )
    if undecided is not None:
        return (
            f"{where} (within {WITHIN_FLOOR}x) and no candidate effect is confirmed: "
            f"{undecided.sentence()}"
        )
    return (
        f"no candidate effect is above noise and {where} (within {WITHIN_FLOOR}x): the model "
        "explains these logs within their noise"
    )


def run_energy_errors(wd: WindowData, heldout_err: np.ndarray) -> np.ndarray:
    """Relative energy error of every run from held-out window errors.

    A run's measured energy is the sum over its windows of mean power times duration; the
    predicted one uses the held-out prediction ``power - err`` of each window.

    Returns
    -------
    numpy.ndarray
        ``|E_pred - E_meas| / E_meas`` per run (runs with no energy left out).

    Examples
    --------
    >>> import pandas as pd
    >>> t = pd.DataFrame({"run": ["a", "a", "b"], "power": [10.0, 10, 20],
    ...                   "duration": [2.0, 2, 2]})
    >>> wd = WindowData(pd.DataFrame(), np.zeros(3, int), t)
    >>> np.round(run_energy_errors(wd, np.array([1.0, -3.0, 4.0])), 12).tolist()
    [0.1, 0.2]
    """
    y = wd.power
    dur = wd.weights
    ok = np.isfinite(heldout_err) & np.isfinite(y)
    runs = wd.runs[ok]
    _, inv = np.unique(runs, return_inverse=True)
    meas = np.bincount(inv, weights=y[ok] * dur[ok])
    pred = np.bincount(inv, weights=(y[ok] - heldout_err[ok]) * dur[ok])
    good = meas > 0
    return np.abs(pred[good] - meas[good]) / meas[good]


@dataclass
class Discovery:
    """What :func:`discover` found; :meth:`to_dict` is the ``--json`` output."""

    base_terms: list[str]
    steps: list[Step]
    rankings: list[Ranking]
    data_findings: list[DataFinding]
    step_metrics: list[dict[str, float]]
    thresholds: Thresholds
    n_windows: int
    n_runs: int
    speeds: dict[str, Any]
    floor: NoiseFloorEstimate | None = None
    speed_terms: dict[str, Any] | None = None  # calibration.fit.speed_support, as a dict
    fit: Any = None  # calibration FitResult of the final model, or None
    notes: list[str] = field(default_factory=list)
    data: WindowData | None = field(default=None, repr=False)
    windows: Any = field(default=None, repr=False)

    @property
    def terms(self) -> list[str]:
        """Terms of the final model as formulas: the base terms and every term added."""
        return [*self.base_terms, *(s.added for s in self.steps[1:])]

    @property
    def model_terms(self) -> list[str | Term]:
        """Terms of the final model as it is written (a long formula named, :func:`model_term`)."""
        added = [model_term(s.name, s.added, s.explanation) for s in self.steps[1:]]
        return [*self.base_terms, *added]

    @property
    def term_names(self) -> list[str]:
        """Names of the final model's terms: what messages print and ``fit --term`` takes."""
        return [t.name if isinstance(t, Term) else t for t in self.model_terms]

    @property
    def undecided(self) -> Undecided | None:
        """The best candidate where the staircase stopped, when the logs cannot decide it.

        It passes its own test by run but the choice test by fold fails
        (``Ranking.undecided``); None when the staircase stopped for another reason.
        """
        return self.rankings[-1].undecided if self.rankings else None

    @property
    def added(self) -> list[str]:
        """Terms added, in order."""
        return [s.added for s in self.steps[1:]]

    @property
    def model(self):
        """The final fitted model (None when the final fit failed)."""
        return None if self.fit is None else self.fit.model

    def table(self) -> list[dict[str, Any]]:
        """The staircase as rows (step 0 is the base model)."""
        rows = []
        first = self.step_metrics[0]["heldout_rmse_w"] if self.step_metrics else math.nan
        fl = math.nan if self.floor is None else self.floor.rmse_w
        for i, (s, m) in enumerate(zip(self.steps, self.step_metrics, strict=True)):
            tried = self.rankings[i - 1].dropped if i and i <= len(self.rankings) else []
            removed_total = 1.0 - (m["heldout_rmse_w"] / first) ** 2 if first > 0 else math.nan
            rows.append(
                {
                    "step": s.step,
                    "added": s.added,
                    "name": s.name,
                    "explanation": s.explanation,
                    "alternatives": s.alternatives,
                    "heldout_rmse_w": m["heldout_rmse_w"],
                    "supported_rmse_w": s.supported_rmse_w,
                    "outside_support": dict(s.outside),
                    "floor_ratio": m["heldout_rmse_w"] / fl if fl > 0 else math.nan,
                    "run_energy_error_median": m["run_energy_error_median"],
                    "run_energy_error_p90": m["run_energy_error_p90"],
                    "error_removed": s.error_explained,
                    "error_removed_total": removed_total,
                    "fold_rmse_w": s.fold_rmse_w,
                    "dropped": [dict(d) for d in tried],
                }
            )
        return rows

    @property
    def dropped(self) -> list[dict[str, Any]]:
        """Suspects above noise a refit left out, with the step that tried them and why."""
        return [{"step": i + 1, **d} for i, r in enumerate(self.rankings) for d in r.dropped]

    def plot(self, path: Any) -> Any:
        """The staircase (held-out RMSE and run-energy error per step); PNG at ``path``."""
        import matplotlib.pyplot as plt

        from energy_planner.diagnosis.report import plot_discovery
        from energy_planner.io import save_figure

        fig = plot_discovery(self.table(), dpi=None)  # saved at the figure's dpi
        try:
            return save_figure(fig, path)
        finally:
            plt.close(fig)

    def write_json(self, path: Any) -> Any:
        """Write :meth:`to_dict` to ``path`` atomically; returns the path."""
        from energy_planner.io import write_json

        return write_json(path, self.to_dict())

    def write_html(self, path: Any, title: str = "energy_planner discover") -> Any:
        """The self-contained HTML report (plots embedded) at ``path``."""
        from energy_planner.diagnosis.report import render_discovery_html
        from energy_planner.io import write_text

        return write_text(path, render_discovery_html(self.to_dict(), title))

    def to_dict(self) -> dict[str, Any]:
        """The JSON document (see ``docs/diagnosis.md``)."""
        last = self.rankings[-1] if self.rankings else None
        th = self.thresholds
        fit = self.fit
        return {
            "base_terms": list(self.base_terms),
            "added": self.added,
            "dropped": self.dropped,
            "terms": self.term_names,
            "n_windows": self.n_windows,
            "n_runs": self.n_runs,
            "speeds": self.speeds,
            "speed_terms": self.speed_terms,
            "staircase": self.table(),
            "noise_floor": None if self.floor is None else self.floor.to_dict(),
            "data_findings": [f.to_dict() for f in self.data_findings],
            "below_noise_at_end": []
            if last is None
            else [s.to_dict() for s in last.below_noise[:5]],
            "unsupported_at_end": [] if last is None else last.unsupported,
            "n_tested": [r.n_tested for r in self.rankings],
            "choice": [None if r.choice is None else r.choice.to_dict() for r in self.rankings],
            "undecided": None if self.undecided is None else self.undecided.to_dict(),
            "thresholds": {
                "alpha": th.alpha,
                "min_rel": th.min_rel,
                "span_tol": th.span_tol,
                "n_splits": th.n_splits,
                "seed": th.seed,
                "confound_alpha": th.confound_alpha,
            },
            "final_fit": None
            if fit is None
            else {
                "coefficients": fit.coefficients,
                "stderr": fit.stderr,
                "heldout_power_rmse_w": None if fit.heldout is None else fit.heldout.rmse_w,
                "warnings": [str(w) for w in fit.warnings],
            },
            "notes": self.notes,
        }


def discover(
    samples: pd.DataFrame,
    *,
    base_terms: Sequence[str] | None = None,
    thresholds: Thresholds | None = None,
    max_steps: int = 4,
    terms: Sequence[str] = (),
    window: float = 2.0,
    repair: bool = True,
    guard: bool = True,
    fit_final: bool = True,
    progress=None,
    prior: Any = None,
    terrain: Any = None,
) -> Discovery:
    """Walk the staircase on raw canonical samples (module docstring).

    Parameters
    ----------
    samples : pandas.DataFrame
        Raw canonical samples, as ``measurements.load_logs`` or a simulated campaign's
        ``logs`` give them.
    base_terms : sequence of str, optional
        Where the staircase starts; default the base model
        (:func:`energy_planner.calibration.fit.base_terms`: the paper's terms, and
        ``gait_power`` when the logs hold standing).
    thresholds : Thresholds, optional
        Noise and support rules.
    max_steps : int
        Largest number of terms added.
    terms : sequence of str
        The user's own candidate terms, scored with the others.
    window : float
        Window length, s.
    repair : bool
        Correct the data findings before fitting (they are reported either way).
    guard : bool
        Keep a repair only if it does not raise the held-out error
        (``calibration.prepare_logs``); False applies every repair.
    fit_final : bool
        Fit the final model on all windows (``calibration.fit_model``).
    progress : bool, callable or Reporter, optional
        Where each stage reports (:func:`energy_planner.progress.reporter`: None prints
        a line per stage on a terminal's stderr; a callable gets a ``ProgressEvent``).
    prior : EnergyModel, optional
        A fitted model whose coefficients stand in for the terms the logs cannot identify
        in the final fit (``fit_model``'s ``prior``, e.g. ``EnergyModel.default()``).
    terrain : Terrain, optional
        The map the logs' poses lie on: logs without altitude get it from the map, and the
        IMU's tilt is checked against it (``calibration.prepare_logs``).

    Returns
    -------
    Discovery
    """
    from energy_planner.calibration import fit_model
    from energy_planner.calibration.fit import base_terms as default_base
    from energy_planner.calibration.fit import identifiable
    from energy_planner.calibration.prepare import prepare_logs
    from energy_planner.errors import EnergyPlannerError
    from energy_planner.model import resolve_term
    from energy_planner.progress import reporter

    rep = reporter(progress)

    def say(msg: str) -> None:
        rep.say(msg, stage="discover")

    th = thresholds or Thresholds()
    prepared = prepare_logs(
        samples, window=window, repair=repair, guard=guard, terrain=terrain
    )  # as fit
    findings, windows = prepared.findings, prepared.windows
    base = list(default_base(windows) if base_terms is None else base_terms)
    say("data checks done")
    wd = window_data(windows)
    say(f"{wd.n_windows} windows")
    from energy_planner.diagnosis.suspects import speed_levels

    # start from the base terms these windows identify (calibration.identifiable): a
    # candidate built on the fitted base (a channel times P_base) must not carry the
    # arbitrary value of a term whose motion the logs lack; fit_model drops those anyway
    unidentified_base = identifiable(windows, base)
    start = [t for t in base if resolve_term(t).name not in unidentified_base]
    steps, rankings = staircase(wd, start, th, max_steps, extra=terms, progress=rep)
    metrics = []
    for r in rankings:
        err = r.heldout_errors
        rel = run_energy_errors(wd, err)
        metrics.append(
            {
                "heldout_rmse_w": r.heldout_rmse_w,
                "run_energy_error_median": float(np.median(rel)) if rel.size else math.nan,
                "run_energy_error_p90": float(np.quantile(rel, 0.9)) if rel.size else math.nan,
            }
        )
    floor = noise_floor(wd)
    notes = []
    if rankings:
        last = rankings[-1]
        left = len(last.suspects) > len(last.dropped)  # the others a refit would leave out
        if left:
            notes.append(f"stopped at the step limit ({max_steps}); suspects remain above noise")
        notes.append(
            conclusion(last.heldout_rmse_w, floor, suspects_left=left, undecided=last.undecided)
        )
    from energy_planner.calibration.fit import speed_support

    support = speed_support(windows)
    fit = None
    if fit_final:
        wd.release_sample_columns()  # the final fit builds its own design (memory)
        try:
            added = [model_term(s.name, s.added, s.explanation) for s in steps[1:]]
            final = [*base, *added]
            fit = fit_model(windows, final, n_splits=th.n_splits, seed=th.seed, prior=prior)
        except EnergyPlannerError as exc:
            notes.append(f"the final fit failed: {exc}")
        else:
            names = {t.name if isinstance(t, Term) else resolve_term(t).name for t in added}
            lost = [n for n in fit.unidentified if n in names]
            if lost:  # the staircase checked this rule: a disagreement is a defect
                notes.append(
                    "the final fit left out term(s) the staircase added: "
                    + "; ".join(f"{n}: {fit.unidentified[n]}" for n in lost)
                )
    return Discovery(
        base_terms=base,
        steps=steps,
        rankings=rankings,
        data_findings=findings,
        step_metrics=metrics,
        thresholds=th,
        n_windows=wd.n_windows,
        n_runs=int(len(np.unique(wd.runs))),
        speeds=speed_levels(wd),
        floor=floor,
        speed_terms={
            **support.to_dict(),
            "line": support.line([resolve_term(t).name for t in start]),
        },  # fmt: skip
        fit=fit,
        notes=notes,
        data=wd,
        windows=windows,
    )
