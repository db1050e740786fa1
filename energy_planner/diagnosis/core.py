"""Compare a model with measurements and find the physical effect it is missing."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from energy_planner.calibration.windowdata import WindowData, window_data
from energy_planner.diagnosis.metrics import breakdown, hotspots, power_metrics, superposition
from energy_planner.diagnosis.suspects import Ranking, Step, Thresholds, staircase
from energy_planner.errors import FitError


def _integrate(samples: pd.DataFrame, power: np.ndarray) -> pd.DataFrame:
    """Energy of each run for any per-sample power, as ``run_energies`` integrates it.

    ``run_energies`` integrates ``voltage * current`` (trapezoids, gaps not bridged); here
    the power given is fed to it as the current at 1 V.
    """
    from energy_planner.measurements import run_energies

    s = samples[["run", "t"]].assign(voltage=1.0, current=np.asarray(power, dtype=float))
    return run_energies(s)


def run_table(samples: pd.DataFrame, model) -> pd.DataFrame:
    """Measured and predicted energy of every run (J), integrated the same way.

    Both integrate over the same samples (those the model is compared on: the windowed,
    cleaned samples), so the difference is the model's error alone.

    Parameters
    ----------
    samples : pandas.DataFrame
        Clean per-sample data with ``run``, ``t``, ``power`` and the model's features.
    model : EnergyModel
        A fitted model.

    Returns
    -------
    pandas.DataFrame
        ``run, duration_s, measured_j, predicted_j, error_j, error_rel``.
    """
    s = samples.reset_index(drop=True)
    s = s.assign(run=s["run"].astype(str))
    measured = _integrate(s, s["power"].to_numpy(float))
    predicted = _integrate(s, np.asarray(model.power(s), float))
    out = measured[["run", "duration_s", "measured_j"]].merge(
        predicted[["run", "measured_j"]].rename(columns={"measured_j": "predicted_j"}), on="run"
    )
    out["run"] = out["run"].astype(str)
    out["error_j"] = out["predicted_j"] - out["measured_j"]
    m = out["measured_j"].to_numpy(float)
    rel = np.full(len(out), np.nan)
    np.divide(out["error_j"].to_numpy(float), m, out=rel, where=m != 0)
    out["error_rel"] = rel
    return out


def infer_composites(
    samples: pd.DataFrame | None = None, runs_meta: pd.DataFrame | None = None
) -> list[dict]:
    """Composite paths and their parts, from run metadata or from log channels.

    Looks for columns ``run``, ``composite`` (the composite path a run belongs to) and
    ``part`` in ``runs_meta`` (one row per run, e.g. the ``runs.csv`` a simulated campaign
    writes) or else in the samples. Within a composite, single-letter parts (``A``,
    ``B``) are legs; a run whose part is their concatenation (``AB``) is the legs
    executed in one go (a *concatenation*), and any other single-letter run not named in
    it (``C``) is a different path between the same poses (an *alternative*).

    Returns
    -------
    list of dict
        ``{"composite": run, "parts": [runs], "kind": "concatenation" | "alternative",
        "group": name}``.

    Examples
    --------
    >>> meta = pd.DataFrame({"run": ["a", "b", "ab", "c"], "composite": "s1",
    ...                      "part": ["A", "B", "AB", "C"]})
    >>> [(c["composite"], c["parts"], c["kind"]) for c in infer_composites(runs_meta=meta)]
    [('ab', ['a', 'b'], 'concatenation'), ('c', ['a', 'b'], 'alternative')]
    """
    cols = {"run", "composite", "part"}
    src = runs_meta
    if src is None or not cols <= set(src.columns):
        if samples is None or not cols <= set(samples.columns):
            return []
        src = samples[["run", "composite", "part"]].drop_duplicates("run")
    src = src[src["composite"].notna() & src["part"].notna()]
    out: list[dict] = []
    for comp, g in src.groupby(src["composite"].astype(str), sort=True):
        if comp in ("", "nan", "None"):
            continue
        part = dict(zip(g["part"].astype(str), g["run"].astype(str), strict=False))
        for whole in sorted(p for p in part if len(p) > 1):
            legs = list(whole)
            if not all(leg in part for leg in legs):
                continue
            parts = [part[leg] for leg in legs]
            out.append(
                {"composite": part[whole], "parts": parts, "kind": "concatenation", "group": comp}
            )
            for alt in sorted(p for p in part if len(p) == 1 and p not in legs):
                out.append(
                    {"composite": part[alt], "parts": parts, "kind": "alternative", "group": comp}
                )
    return out


@dataclass
class Diagnosis:
    """Everything the diagnosis found; :meth:`to_dict` is the ``--json`` output."""

    model: Any
    data: WindowData
    predicted: np.ndarray
    metrics: dict[str, float]
    runs: pd.DataFrame
    breakdown: dict[str, dict]
    superposition: list[dict]
    ranking: Ranking | None
    steps: list[Step] = field(default_factory=list)
    rankings: list[Ranking] = field(default_factory=list)
    thresholds: Thresholds = field(default_factory=Thresholds)
    notes: list[str] = field(default_factory=list)
    data_findings: list[dict[str, Any]] | None = None

    @property
    def residual(self) -> np.ndarray:
        """Measured minus predicted mean power of each window, W."""
        return self.data.power - self.predicted

    @property
    def undecided(self):
        """The best candidate where the staircase stopped, if the logs cannot decide it.

        ``Ranking.undecided`` (:class:`~energy_planner.diagnosis.scoring.Undecided`).
        """
        return self.rankings[-1].undecided if self.rankings else None

    @property
    def suspects(self) -> list:
        """Above-noise suspects, best first."""
        return [] if self.ranking is None else self.ranking.suspects

    def to_dict(self) -> dict[str, Any]:
        """The JSON document (see ``docs/diagnosis.md``)."""
        r = self.ranking
        runs = self.runs.replace({np.nan: None}).to_dict(orient="records")
        th = self.thresholds
        return {
            "model_terms": list(self.model.term_names),
            "n_windows": self.data.n_windows,
            "n_runs": int(len(np.unique(self.data.runs))),
            "rmse_w": self.metrics["rmse_w"],
            "mae_w": self.metrics["mae_w"],
            "bias_w": self.metrics["bias_w"],
            "r2": self.metrics["r2"],
            "heldout_rmse_w": None if r is None else r.heldout_rmse_w,
            "runs": runs,
            "superposition": self.superposition,
            "breakdown": self.breakdown,
            "hotspots": hotspots(self.breakdown),
            "suspects": [] if r is None else [s.to_dict() for s in r.suspects],
            "below_noise": [] if r is None else [s.to_dict() for s in r.below_noise],
            "unsupported": [] if r is None else r.unsupported,
            "alternatives": [] if r is None else [s.to_dict() for s in r.alternatives],
            "n_tested": 0 if r is None else r.n_tested,
            "p_threshold": None if r is None else r.p_threshold,
            "choice": None if r is None or r.choice is None else r.choice.to_dict(),
            "undecided": None if self.undecided is None else self.undecided.to_dict(),
            "staircase": [s.to_dict() for s in self.steps],
            "thresholds": {
                k: getattr(th, k) for k in ("alpha", "min_rel", "span_tol", "n_splits", "seed")
            },
            "notes": self.notes,
            "data_findings": self.data_findings,
        }


def diagnose(
    model,
    samples: pd.DataFrame,
    *,
    composites: Sequence[dict] | Mapping[str, Sequence[str]] | None = None,
    runs_meta: pd.DataFrame | None = None,
    thresholds: Thresholds | None = None,
    max_steps: int = 4,
    extras: Sequence[str] | None = None,
    terms: Sequence[str] = (),
    progress=None,
    window: float = 2.0,
    repair: bool = True,
) -> Diagnosis:
    """Compare ``model`` with windowed measurements and rank the effects it misses.

    Parameters
    ----------
    model : EnergyModel
        A fitted model (its terms are also the starting point of the refits).
    samples : pandas.DataFrame, Windows or PreparedLogs
        Windowed per-sample data, ``make_windows(clean).samples`` (or a ``Windows``); or
        raw canonical samples, which first go through the data checks (repaired unless
        ``repair`` is False), cleaning and windows as ``fit`` and ``discover`` do them
        (:func:`energy_planner.calibration.fit.as_windows`); the findings are then in
        ``Diagnosis.data_findings``.
    composites : list of dict or mapping, optional
        Composite paths for the superposition check (:func:`infer_composites` format, or
        composite run -> part runs); default inferred from ``runs_meta`` or the samples.
    runs_meta : pandas.DataFrame, optional
        One row per run with ``run, composite, part`` (a simulated campaign's ``runs``).
    thresholds : Thresholds, optional
        Support and noise rules (:mod:`energy_planner.diagnosis.suspects`).
    max_steps : int
        Largest number of terms the staircase adds (0: rank only).
    extras : sequence of str, optional
        Extra channels to examine (default: every non-canonical column).
    terms : sequence of str
        More candidate terms to test besides the catalog and the data-driven ones.
    progress : bool, callable or Reporter, optional
        Where each staircase step reports (:func:`energy_planner.progress.reporter`).
    window : float
        Window length (s) for raw samples.
    repair : bool
        Correct the data findings of raw samples (reported either way).

    Returns
    -------
    Diagnosis
    """
    from energy_planner.calibration.fit import as_windows

    samples, findings = as_windows(samples, window=window, repair=repair)
    wd = window_data(samples, extras)  # a Windows gives the measurements' durations
    if hasattr(samples, "samples"):
        samples = samples.samples
    th = thresholds or Thresholds()
    pred = wd.predict(model)
    metrics = power_metrics(wd.power, pred)
    notes: list[str] = []
    runs = run_table(samples, model)
    if composites is None:
        composites = infer_composites(samples, runs_meta)
    sup = superposition(runs, composites)
    bd = breakdown(
        wd.table, wd.power - pred, wd.numeric_extras, wd.categorical_extras, groups=wd.runs
    )
    ranking, steps, rankings = None, [], []
    try:
        steps, rankings = staircase(wd, model.terms, th, max_steps, progress=progress, extra=terms)
        ranking = rankings[0]
    except FitError as exc:
        notes.append(f"no suspects: {exc}")
    if ranking is not None and not ranking.suspects:
        # worded by the noise floor the logs show, as discover words it (one conclusion)
        from energy_planner.diagnosis.discover import conclusion
        from energy_planner.diagnosis.metrics import noise_floor

        notes.append(
            "no candidate effect is above noise; "
            + conclusion(
                metrics["rmse_w"], noise_floor(wd), suspects_left=False,
                undecided=ranking.undecided,
            )
        )  # fmt: skip
    elif rankings and rankings[-1].undecided is not None:  # where the staircase stopped
        notes.append(rankings[-1].undecided.sentence())
    if not math.isfinite(metrics["rmse_w"]):
        notes.append("no window has both a measured and a predicted power")
    return Diagnosis(
        model, wd, pred, metrics, runs, bd, sup, ranking, steps, rankings, th, notes, findings
    )
