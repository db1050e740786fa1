"""Joint least-squares calibration of an energy model, validated by run.

Every term of the model is fitted at once on all windows: the rows are the per-window
means of the terms (``model.design_matrix(samples, groups=samples["window"])``), the
target is the window's mean electrical power, and each window weighs as much as its
duration (so a window counts as much as the seconds of data in it). Power is linear in
the coefficients, so this is a weighted linear least-squares problem with closed-form
standard errors.

Cross-validation holds out whole runs (grouped K-fold on ``run``): windows of one run
are strongly correlated (same patch of ground, same battery state, same gait), so
mixing them between training and test would report an optimistic error. The held-out
metrics are the window power errors (RMSE, MAE, R^2) and the per-run energy errors,
where a run's predicted energy is the integral of the model's per-sample power over the
run's windowed samples and its measured energy the same integral of measured power.

Before fitting, :func:`fit_model` checks what the data can support and says so in
specific warnings: the slope coverage of each motion type, a single walking speed with a
speed term, terms nearly in the span of the others. Too little data raises
:class:`~energy_planner.errors.FitError` with the counts.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import numpy as np
import pandas as pd

from energy_planner.calibration._windows import (
    STANDING,
    aligned_table,
    heading_class,
    window_energy,
    window_kind,
)
from energy_planner.errors import FitError
from energy_planner.model import (
    BASE_TERMS,
    GAIT_CHANNEL,
    SPEED_TERMS,
    STANDING_TERMS,
    EnergyModel,
    Term,
    gait_terms,
)
from energy_planner.model.formula import MOTION_FEATURES
from energy_planner.model.model import prepare_features
from energy_planner.stats import fold_index, heldout, independent_columns, vif, wls

__all__ = [
    "FitResult",
    "heldout_outside_shares",
    "extrapolation_growth",
    "CrossValidation",
    "fit_model",
    "as_windows",
    "base_terms",
    "cross_validate",
    "identifiable",
    "identifiable_by_fold",
    "identify_terms",
    "refuse_free_walking",
    "calibration_domain",
    "run_power_range",
    "speed_support",
    "SpeedSupport",
    "MIN_WINDOWS_PER_TERM",
    "MIN_RUNS",
]

#: A fit needs at least this many windows per term.
MIN_WINDOWS_PER_TERM = 3
#: And at least this many runs (to hold one out).
MIN_RUNS = 2
#: A slope is "steep" for the coverage check above this angle (deg).
STEEP_DEG = 5.0
#: Warn when a term's variance inflation factor exceeds this (1 - R^2 < 1/VIF_WARN).
VIF_WARN = 100.0
#: Relative spread of the runs' cruising speeds under which a campaign is single-speed.
SINGLE_SPEED_SPREAD = 0.1
#: The logs identify how the cost depends on speed (:func:`speed_support`) when the 90th
#: percentile of their steady walking speeds is at least this times the 10th.
SPEED_RANGE_RATIO = 3.0
#: Windows whose mean acceleration is below this (m/s^2) walk at a steady speed.
STEADY_ACCEL = 0.05
#: Per-sample features of the motion itself (not log channels).
_KINEMATIC = frozenset({"alpha", "gamma", "vx", "vy", "wz", "speed", "ax", "ay"})


@dataclass
class CrossValidation:
    """Held-out errors of a model validated by run.

    Attributes
    ----------
    n_splits : int
        Number of folds actually used.
    seed : int
        Seed of the random assignment of runs to folds.
    folds : list of list of str
        The runs held out in each fold (disjoint; together all runs).
    windows : pandas.DataFrame
        One row per window: run, window, fold, duration, measured_w, predicted_w.
    runs : pandas.DataFrame
        One row per run: run, fold, duration_s, measured_j, predicted_j, error_j,
        rel_error (predicted / measured - 1).
    fold_coefficients : pandas.DataFrame
        The coefficients fitted in each fold (index: fold), to judge their stability.
    rmse_w, mae_w, r2 : float
        Held-out window power errors (W) and the coefficient of determination.
    energy_mean_abs_rel, energy_max_abs_rel : float
        Mean and largest absolute relative error of held-out run energies.
    energy_median_abs_rel, energy_p90_abs_rel : float
        Median and 90th percentile of the absolute relative run-energy errors.
    energy_total_rel : float
        Relative error of the summed held-out energy of all runs.
    warnings : list of str
        Folds in which a term had no training data, fewer runs than folds, ...
    whole : pandas.DataFrame or None
        One row per run, the run WHOLE (every sample, not only its windows): run, fold,
        duration_s, measured_j (battery energy of every sample), predicted_j (the
        windows' prediction plus the samples no window holds, priced by the same fold's
        coefficients: :func:`whole_run_predictions`), rest_predicted_j (that second part),
        priced_by (``path``: the logged poses over the map; ``samples``) and rel_error
        (predicted / measured - 1).
        None when the windows carry no whole runs (``Windows.whole_runs``: windows
        cut without :func:`~energy_planner.calibration.prepare_logs`); ``whole_runs``
        in :meth:`to_dict`.
    """

    n_splits: int
    seed: int
    folds: list[list[str]]
    windows: pd.DataFrame
    runs: pd.DataFrame
    fold_coefficients: pd.DataFrame
    rmse_w: float
    mae_w: float
    r2: float
    energy_mean_abs_rel: float
    energy_max_abs_rel: float
    energy_total_rel: float
    energy_median_abs_rel: float = float("nan")
    energy_p90_abs_rel: float = float("nan")
    warnings: list[str] = field(default_factory=list)
    whole: pd.DataFrame | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (per-run rows included, per-window rows left out)."""
        return {
            "n_splits": self.n_splits,
            "seed": self.seed,
            "folds": self.folds,
            "power_rmse_w": self.rmse_w,
            "power_mae_w": self.mae_w,
            "power_r2": self.r2,
            "energy_mean_abs_rel_error": self.energy_mean_abs_rel,
            "energy_max_abs_rel_error": self.energy_max_abs_rel,
            "energy_median_abs_rel_error": self.energy_median_abs_rel,
            "energy_p90_abs_rel_error": self.energy_p90_abs_rel,
            "energy_total_rel_error": self.energy_total_rel,
            "runs": self.runs.to_dict(orient="records"),
            "whole_runs": None if self.whole is None else self.whole.to_dict(orient="records"),
            "warnings": list(self.warnings),
        }


@dataclass
class FitResult:
    """A calibrated model and what the data says about it.

    Attributes
    ----------
    model : EnergyModel
        The fitted model (coefficients and standard errors set).
    coefficients, stderr : dict
        Term name -> coefficient and its classical standard error (units of each term),
        which assumes independent windows.
    stderr_by_run : dict
        Term name -> standard error robust to correlation within a run (cluster
        sandwich estimator over runs): windows of one run share slip, IMU bias and
        ground, so this one is the honest one when it is larger.
    n_windows, n_runs : int
        Data the fit used.
    heldout : CrossValidation or None
        Held-out errors by run (None when ``n_splits=0``).
    warnings : list of str
        What the data cannot support (named terms, specific causes).
    residual_rms_w : float
        Duration-weighted RMS of the in-sample window power residuals (W).
    condition_number : float
        Of the column-normalised weighted design matrix.
    vif : dict
        Term name -> variance inflation factor (1 / (1 - R^2) of its column regressed
        on the others, uncentred).
    coverage : pandas.DataFrame
        Windows per motion kind and heading class, with the steepest slope (deg).
    unidentified : dict
        Term name -> why the campaign cannot identify it; such terms are not in ``model``.
    held_at_prior : dict
        Term name -> coefficient taken from the prior model (unidentified, kept).
    data_findings : list of dict or None
        Every data check's result (:func:`energy_planner.calibration.prepare_logs`) when
        the fit started from raw samples; None when it was given windows (the checks run
        on raw samples, before cleaning).
    """

    model: EnergyModel
    coefficients: dict[str, float]
    stderr: dict[str, float]
    n_windows: int
    n_runs: int
    heldout: CrossValidation | None
    warnings: list[str]
    residual_rms_w: float
    condition_number: float
    vif: dict[str, float]
    coverage: pd.DataFrame
    stderr_by_run: dict[str, float] = field(default_factory=dict)
    unidentified: dict[str, str] = field(default_factory=dict)
    held_at_prior: dict[str, float] = field(default_factory=dict)
    data_findings: list[dict[str, Any]] | None = None
    speed_terms: SpeedSupport | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (``unidentified``: term -> reason, not in the model)."""
        terms = {t.name: t for t in self.model.terms}

        def num(x: float | None) -> float | None:
            return None if x is None or not np.isfinite(x) else float(x)

        return {
            "terms": [
                {
                    "name": name,
                    "formula": terms[name].formula,
                    "unit": terms[name].unit,
                    "coefficient": self.coefficients[name],
                    "stderr": num(self.stderr[name]),
                    "stderr_by_run": num(self.stderr_by_run.get(name)),
                    "vif": num(self.vif.get(name)),
                    "status": "prior" if name in self.held_at_prior else "fitted",
                }
                for name in self.model.term_names
            ],
            "unidentified": [{"name": n, "reason": why} for n, why in self.unidentified.items()],
            "held_at_prior": [{"name": n, "coefficient": c} for n, c in self.held_at_prior.items()],
            "n_windows": self.n_windows,
            "n_runs": self.n_runs,
            "residual_rms_w": self.residual_rms_w,
            "condition_number": self.condition_number,
            "heldout": None if self.heldout is None else self.heldout.to_dict(),
            "coverage": self.coverage.to_dict(orient="records"),
            "warnings": list(self.warnings),
            "data_findings": self.data_findings,
            "speed_terms": None if self.speed_terms is None else self.speed_terms.to_dict(),
        }

    def summary(self) -> str:
        """Human-readable table of coefficients, held-out errors and warnings."""
        terms = {t.name: t for t in self.model.terms}
        names = self.model.term_names
        nw = max(28, *(len(n) for n in names))
        units = {n: terms[n].unit if len(terms[n].unit) <= 8 else "W/unit" for n in names}
        lines = [
            f"fitted {len(self.coefficients)} terms on {self.n_windows} windows "
            f"from {self.n_runs} runs (in-sample RMS residual {self.residual_rms_w:.1f} W)",
            "",
            f"{'term':<{nw}} {'coefficient':>12} {'std err':>10} {'by run':>9} {'unit':<6} formula",
        ]
        for name in names:
            by_run = self.stderr_by_run.get(name, float("nan"))
            se = "prior" if name in self.held_at_prior else f"{self.stderr[name]:.2f}"
            lines.append(
                f"{name:<{nw}} {self.coefficients[name]:>12.2f} {se:>10} "
                f"{by_run:>9.2f} {units[name]:<6} {terms[name].formula}"
            )
        lines.append("(std err: classical; by run: robust to correlated windows within a run)")
        if self.unidentified:
            lines += ["", "not identified by this campaign (left out of the model):"]
            lines += [f"  {n:<{nw - 2}} {why}" for n, why in self.unidentified.items()]
        if self.speed_terms is not None:
            lines += ["", self.speed_terms.line(self.model.term_names)]
        if self.held_at_prior:
            lines += ["", "not identified, held at the prior's value:"]
            lines += [f"  {n:<{nw - 2}} {c:.2f}" for n, c in self.held_at_prior.items()]
        cv = self.heldout
        if cv is not None:
            lines += [
                "",
                f"held-out by run ({cv.n_splits} folds, runs never split): power RMSE "
                f"{cv.rmse_w:.1f} W, MAE {cv.mae_w:.1f} W, R^2 {cv.r2:.3f}",
                f"run energy error: median |err| {100 * cv.energy_median_abs_rel:.2f} %, "
                f"90th percentile {100 * cv.energy_p90_abs_rel:.2f} %, "
                f"mean {100 * cv.energy_mean_abs_rel:.2f} %, "
                f"max {100 * cv.energy_max_abs_rel:.2f} %, "
                f"total {100 * cv.energy_total_rel:+.2f} %",
            ]
        if self.warnings:
            lines += ["", "warnings:"] + [f"  - {w}" for w in self.warnings]
        if self.data_findings is not None:
            from energy_planner.calibration.prepare import findings_text

            lines += ["", *findings_text(self.data_findings)]
        return "\n".join(lines)


# --------------------------------------------------------------------------- helpers
@dataclass(frozen=True)
class SpeedSupport:
    """Whether the logs identify how the cost depends on speed, and the gaits they name.

    Attributes
    ----------
    supported : bool
        The steady walking speeds span at least :data:`SPEED_RANGE_RATIO` (90th over 10th
        percentile): then the base model gets :data:`~energy_planner.model.SPEED_TERMS`
        (and the gait channel's terms) and its cost per metre has an optimum speed.
    speed_p10, speed_p90 : float or None
        10th and 90th percentile of the steady walking windows' speeds, m/s.
    n_windows : int
        Steady walking windows.
    gaits : dict
        Gait (value of the channel ``gait``) -> [min, max] speed of its walking windows,
        m/s; empty without a gait channel.
    reference_gait : str or None
        The gait the others are priced against (the slowest).
    reason : str
        Why the speed terms are or are not supported, in words.
    """

    supported: bool
    speed_p10: float | None
    speed_p90: float | None
    n_windows: int
    gaits: dict[str, list[float]]
    reference_gait: str | None
    reason: str

    def terms(self) -> list[str | Term]:
        """The terms these logs add to the base model (none when not supported)."""
        if not self.supported:
            return []
        # across speeds the speed changes between them carry kinetic energy of the order
        # of the speed terms' (a ramp to 1.2 m/s pays ~M v a = 36 W): the catalog's
        # acceleration prices it, so that the speed terms do not absorb it
        extra: list[str | Term] = [*SPEED_TERMS, "acceleration"]
        if self.reference_gait is not None and len(self.gaits) >= 2:
            extra += gait_terms(list(self.gaits), self.reference_gait)
        return extra

    def line(self, model_terms: Sequence[str]) -> str:
        """One line for the fit's report: which speed terms the model has, or why none."""
        have = [n for n in model_terms if n in SPEED_TERMS]
        gait = [n for n in model_terms if f"{GAIT_CHANNEL} ==" in n]
        if self.supported and have:
            return (
                f"speed terms: identified ({', '.join(have)}"
                + (f"; {len(gait)} gait terms against {self.reference_gait!r}" if gait else "")
                + f"): {self.reason}"
            )
        return f"speed terms: unsupported ({self.reason})"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (``supported``, the percentiles, ``gaits``, ``reason``)."""
        return {
            "supported": self.supported,
            "speed_p10_m_s": self.speed_p10,
            "speed_p90_m_s": self.speed_p90,
            "n_windows": self.n_windows,
            "gaits": dict(self.gaits),
            "reference_gait": self.reference_gait,
            "terms": [t if isinstance(t, str) else t.name for t in self.terms()],
            "reason": self.reason,
        }


def speed_support(windows: Any) -> SpeedSupport:
    """Do the logs identify how the cost depends on speed? From the steady walking windows.

    A window walks steadily when its speed exceeds the standing threshold (0.05 m/s) and
    its mean acceleration is below :data:`STEADY_ACCEL` (the ramps at run starts and ends
    are not other speeds). The speed terms are supported when the 90th percentile of those
    speeds is at least :data:`SPEED_RANGE_RATIO` times the 10th, in at least
    :data:`MIN_WINDOWS_PER_TERM` times as many windows as there are speed terms: over a
    narrower range the curvature of the cost in speed is lost in the per-metre and
    per-second terms, and an optimum speed would be an extrapolation. A categorical
    channel ``gait`` with two or more values (each in at least
    :data:`MIN_WINDOWS_PER_TERM` walking windows) adds its terms
    (:func:`energy_planner.model.gait_terms`) against the slowest gait.

    Parameters
    ----------
    windows : Windows, WindowData or pandas.DataFrame
        Windows (their ``table``) or a window table with ``speed`` (or ``vx, vy``).

    Examples
    --------
    >>> t = pd.DataFrame({"speed": np.repeat([0.3, 0.6, 0.9], 10), "wz": 0.0})
    >>> speed_support(t).supported, speed_support(t.iloc[:10]).supported
    (True, False)
    """
    table = windows if isinstance(windows, pd.DataFrame) else windows.table
    speed = (
        table["speed"].to_numpy(float)
        if "speed" in table
        else np.hypot(table["vx"].to_numpy(float), table["vy"].to_numpy(float))
    )
    from energy_planner.model.model import WALKING_SPEED

    steady = np.isfinite(speed) & (speed > WALKING_SPEED)
    if {"ax", "ay"} <= set(table.columns):
        acc = np.hypot(table["ax"].to_numpy(float), table["ay"].to_numpy(float))
        steady &= np.nan_to_num(acc, nan=np.inf) < STEADY_ACCEL
    walking = speed[steady]
    gaits: dict[str, list[float]] = {}
    reference = None
    if GAIT_CHANNEL in table.columns:
        g = table[GAIT_CHANNEL].astype(str).to_numpy()
        walk = np.isfinite(speed) & (speed > WALKING_SPEED) & (table[GAIT_CHANNEL].notna())
        means = {}
        for name in sorted(set(g[walk])):
            sel = walk & (g == name)
            if int(sel.sum()) >= MIN_WINDOWS_PER_TERM:
                gaits[name] = [round(float(speed[sel].min()), 3), round(float(speed[sel].max()), 3)]
                means[name] = float(np.mean(speed[sel]))
        reference = min(means, key=lambda k: (means[k], k)) if means else None
    need = MIN_WINDOWS_PER_TERM * len(SPEED_TERMS)
    if walking.size < max(need, 10):
        return SpeedSupport(False, None, None, int(walking.size), gaits, reference,
                            f"{walking.size} steady walking window(s), need {max(need, 10)} at "
                            "several speeds")  # fmt: skip
    lo, hi = (float(q) for q in np.quantile(walking, [0.1, 0.9]))
    span = f"steady walking {lo:.2f}-{hi:.2f} m/s (10th-90th percentile)"
    if hi < SPEED_RANGE_RATIO * lo:
        return SpeedSupport(
            False, round(lo, 3), round(hi, 3), int(walking.size), gaits, reference,
            f"{span}: a range of at least {SPEED_RANGE_RATIO:g}x (e.g. 0.2-0.6 m/s) is "
            "needed to identify how the cost per metre changes with speed; the model's cost "
            "per metre holds at the logged speeds, and it has no optimum speed (record runs "
            "across speeds, e.g. simulate --across-speeds)",
        )  # fmt: skip
    return SpeedSupport(True, round(lo, 3), round(hi, 3), int(walking.size), gaits, reference,
                        span)  # fmt: skip


def base_terms(windows: Any) -> list[str]:
    """The base model for these windows: the paper's terms, and the gait's running power.

    :data:`~energy_planner.model.BASE_TERMS`, plus
    :data:`~energy_planner.model.SPEED_TERMS` and the gait channel's terms when the logs
    span a range of speeds (:func:`speed_support`), plus
    :data:`~energy_planner.model.STANDING_TERMS` (``gait_power``, ``gait_tilt_x_sq``) when
    at least :data:`MIN_WINDOWS_PER_TERM` windows stand
    (:func:`~energy_planner.calibration._windows.window_kind`): then ``idle_power`` and
    ``tilt_x_sq`` are fitted as the standing power and the STANDING_TERMS as what walking
    or turning adds to it. Without standing windows they are the same columns on the
    walking windows, and ``idle_power`` and ``tilt_x_sq`` alone hold both.

    Parameters
    ----------
    windows : Windows, WindowData or pandas.DataFrame
        Windows (their ``table``) or a window table with ``motion`` (optional), ``speed``
        (or ``vx``, ``vy``) and ``wz``.

    Examples
    --------
    >>> t = pd.DataFrame({"speed": [0.3] * 3 + [0.0] * 3, "wz": 0.0})
    >>> base_terms(t)[-2:], len(base_terms(t.iloc[:4]))
    (['gait_power', 'gait_tilt_x_sq'], 17)
    """
    table = windows if isinstance(windows, pd.DataFrame) else windows.table
    if len(table) == 0:
        return list(BASE_TERMS)
    speed = (
        table["speed"].to_numpy(float)
        if "speed" in table
        else np.hypot(table["vx"].to_numpy(float), table["vy"].to_numpy(float))
    )
    motion = table["motion"].to_numpy() if "motion" in table else np.full(len(table), "mixed")
    kind = window_kind(motion, speed, table["wz"].to_numpy(float))
    standing = int(np.sum(kind == STANDING)) >= MIN_WINDOWS_PER_TERM
    speed_terms = [t if isinstance(t, str) else t.name for t in speed_support(table).terms()]
    return [*BASE_TERMS, *(STANDING_TERMS if standing else ()), *speed_terms]


def _as_model(
    model_or_terms: EnergyModel | Sequence[str | Term] | None, windows: Any = None
) -> EnergyModel:
    if model_or_terms is None:
        return EnergyModel(BASE_TERMS if windows is None else base_terms(windows))
    if isinstance(model_or_terms, EnergyModel):
        return EnergyModel(
            list(model_or_terms.terms),
            regenerative=model_or_terms.regenerative,
            metadata=model_or_terms.metadata,
        )
    if isinstance(model_or_terms, str | Term):
        model_or_terms = [model_or_terms]
    model = EnergyModel(list(model_or_terms))
    model.terms  # noqa: B018 - resolve now: unknown names raise here
    return model


def model_features(samples: pd.DataFrame, model: EnergyModel) -> dict[str, np.ndarray]:
    """The sample columns ``model`` reads, as arrays (converting only those columns).

    Examples
    --------
    >>> s = pd.DataFrame({"vx": [0.3], "vy": [0.0], "note": ["x"]})
    >>> sorted(model_features(s, EnergyModel(["fwd_const", "speed_dependence"])))
    ['speed', 'vx', 'vy']
    """
    need = set(model.variables) | {"vx", "vy"}
    out = {c: samples[c].to_numpy() for c in samples.columns if c in need}
    if "speed" in need and "speed" not in out and "vx" in out and "vy" in out:
        out["speed"] = np.hypot(out["vx"].astype(float), out["vy"].astype(float))
    return out


def _check_amount(n_windows: int, n_runs: int, k: int, names: list[str]) -> None:
    need_w = MIN_WINDOWS_PER_TERM * k
    if n_windows < need_w or n_runs < MIN_RUNS:
        raise FitError(
            f"too little data to fit {k} terms ({', '.join(names)}): got {n_windows} windows "
            f"from {n_runs} run(s); need at least {need_w} windows ({MIN_WINDOWS_PER_TERM} "
            f"per term) from at least {MIN_RUNS} runs (to validate on held-out runs). "
            "Record more runs or use shorter windows (--window)"
        )


#: A window exercises a motion term when the term's value per unit rate (m/s or rad/s)
#: exceeds this floor and this fraction of its largest value on the motion's windows.
EXERCISE_FLOOR = 0.01
EXERCISE_FRACTION = 0.05
#: Columns whose relative residual on the earlier columns is below this are dependent.
DEPENDENCE_TOL = 1e-6
_RATE_OF_KIND = {"forward": "speed", "backward": "speed", "lateral": "speed", "turning": "yaw"}


def identify_terms(
    model: EnergyModel, X: np.ndarray, w: np.ndarray, table: pd.DataFrame
) -> dict[str, str]:
    """Terms the campaign cannot identify, each with the reason (empty when all are).

    A motion term (kind forward, backward, lateral or turning) needs at least
    :data:`MIN_WINDOWS_PER_TERM` windows of its motion in which it is exercised: its value
    per unit rate above ``max(EXERCISE_FLOOR, EXERCISE_FRACTION * largest)`` (a grade of
    about 0.6 deg for the linear grade terms). Sensor noise alone (a few mm/s of ``vx``
    while side-stepping) makes a backward column non-zero without any backward run, so a
    least-squares fit would happily give it a value; this rule does not. A term of any
    other kind (a formula, a channel times the base power as ``discover`` adds) is not
    identified when it prices a motion class the campaign lacks (fewer than
    :data:`MIN_WINDOWS_PER_TERM` windows of it): on probe motions of that class
    (:func:`_class_probes`) its value differs from its value standing still at the same
    slope, heading and channel values, so it says something about that motion that the
    logs cannot have told it; unless a motion class the logs hold prices it at least as
    much (the largest difference from standing over the probes): then the logs told its
    coefficient on that motion, and the absent motion is priced by its formula in
    proportion, as the identified base prices it (``load_kg * speed`` on logs that walk
    forward only; ``load_kg*P_base`` on a base with ``gait_power``, which prices every
    walk alike), while ``vy ** 2`` from forward walking is not. A term that prices every
    motion class alike and standing differently (``gait_power``: what walking adds to
    standing) is told by the standing windows instead: it needs
    :data:`MIN_WINDOWS_PER_TERM` of them. Then, in term order, a
    column that is (numerically) a combination of the earlier identified ones is not
    identified either (:func:`energy_planner.stats.independent_columns`).

    Parameters
    ----------
    model : EnergyModel
        Its terms, in the order of the columns of ``X``.
    X : numpy.ndarray
        Window means of the terms, shape ``(n_windows, k)``.
    w : numpy.ndarray
        Window weights (durations).
    table : pandas.DataFrame
        :func:`~energy_planner.calibration._windows.aligned_table` (``kind``, ``speed`` or
        ``vx``/``vy``, ``wz``).

    Returns
    -------
    dict
        Term name -> why the data cannot identify it.
    """
    names = model.term_names
    out: dict[str, str] = {}
    kind = table["kind"].to_numpy()
    speed = (
        table["speed"].to_numpy(float)
        if "speed" in table
        else np.hypot(table["vx"].to_numpy(float), table["vy"].to_numpy(float))
    )
    yaw = np.abs(table["wz"].to_numpy(float))
    absent = [k for k in _RATE_OF_KIND if int(np.sum(kind == k)) < MIN_WINDOWS_PER_TERM]
    present = [k for k in _RATE_OF_KIND if k not in absent]
    n_standing = int(np.sum(kind == STANDING))
    probed: dict[str, Any] = {}  # each channel's probe value, taken once for every term
    for j, term in enumerate(model.terms):
        if term.kind not in _RATE_OF_KIND:
            why = _prices_absent_motion(
                term, absent, X[:, j], table, n_standing, present, probed=probed
            )
            if why:
                out[term.name] = why
            continue
        sel = kind == term.kind
        rate = (speed if _RATE_OF_KIND[term.kind] == "speed" else yaw)[sel]
        per_rate = np.abs(X[sel, j]) / np.maximum(rate, 1e-9)
        top = float(per_rate.max()) if per_rate.size else 0.0
        n = int(np.sum(per_rate > max(EXERCISE_FLOOR, EXERCISE_FRACTION * top)))
        if n < MIN_WINDOWS_PER_TERM:
            label = "turn-in-place" if term.kind == "turning" else term.kind
            out[term.name] = (
                f"{n} {label} window(s) exercise it (of {int(sel.sum())} {label} windows; "
                f"need {MIN_WINDOWS_PER_TERM}): the campaign has no {label} motion where "
                f"{term.formula} is non-zero; record such runs"
            )
    rest = [j for j, nm in enumerate(names) if nm not in out]
    if rest:
        keep, why = independent_columns(X[:, rest], w, tol=DEPENDENCE_TOL)
        for i, by in why.items():
            nm = names[rest[i]]
            if by:
                out[nm] = (
                    "a linear combination of "
                    + ", ".join(names[rest[b]] for b in by)
                    + " on these windows: the campaign does not vary what tells them apart"
                )
            else:
                out[nm] = "zero on every window: the campaign never exercises it"
    return {nm: out[nm] for nm in names if nm in out}


def identifiable_by_fold(
    model: EnergyModel, X: np.ndarray, w: np.ndarray, table: pd.DataFrame, folds: np.ndarray
) -> np.ndarray:
    """Which terms each fold's training windows identify (:func:`identify_terms`).

    The held-out evaluation (:func:`energy_planner.stats.heldout`, ``fit_columns``) fits
    only these in each fold and predicts the others as 0, in ``fit``, ``diagnose`` and
    ``discover`` alike.

    Parameters
    ----------
    model : EnergyModel
        Its terms, in the order of the columns of ``X``.
    X, w, table
        Window means of the terms, window weights and the window table, as for
        :func:`identify_terms`.
    folds : numpy.ndarray
        Fold of every window.

    Returns
    -------
    numpy.ndarray
        Boolean ``(n_folds, k)``.
    """
    names = model.term_names
    n_folds = int(np.max(folds)) + 1
    out = np.ones((n_folds, len(names)), dtype=bool)
    # the columns identify_terms reads (the motion, the rates, the terms' channels): the
    # folds' training rows are taken of these alone
    reads = {"kind", "speed", "vx", "vy", "wz"}.union(*(t.variables for t in model.terms))
    table = table[[c for c in table.columns if c in reads]]
    for i in range(n_folds):
        train = np.asarray(folds) != i
        lost = identify_terms(model, X[train], w[train], table[train])
        out[i] = [n not in lost for n in names]
    return out


#: Probe motions of each motion class (body velocity direction, rad; None: turn in place).
_CLASS_DIRECTIONS = {
    "forward": (0.0,),
    "backward": (math.pi,),
    "lateral": (math.pi / 2, -math.pi / 2),
    "turning": (None,),
}


def _class_probes(kind: str, channels: Mapping[str, Any]) -> tuple[dict, dict]:
    """Features of probe motions of one motion class and of standing at the same poses.

    Slopes 0, 10 and 20 deg, relative headings every 45 deg, the nominal speed (turning in
    place at the nominal yaw rate) and the given channel values.
    """
    from energy_planner.request import DEFAULT_SPEED, DEFAULT_YAW_RATE

    a, h = np.meshgrid(np.radians([0.0, 10.0, 20.0]), np.radians(np.arange(-180, 180, 45)))
    a, h = a.ravel(), h.ravel()
    moving: dict[str, list] = {k: [] for k in ("alpha", "gamma", "vx", "vy", "wz")}
    for d in _CLASS_DIRECTIONS[kind]:
        moving["alpha"].append(a)
        moving["gamma"].append(h)
        moving["vx"].append(np.full(a.size, 0.0 if d is None else DEFAULT_SPEED * math.cos(d)))
        moving["vy"].append(np.full(a.size, 0.0 if d is None else DEFAULT_SPEED * math.sin(d)))
        moving["wz"].append(np.full(a.size, DEFAULT_YAW_RATE if d is None else 0.0))
    probe = {k: np.concatenate(v) for k, v in moving.items()}
    n = probe["alpha"].size
    probe["ax"] = probe["ay"] = np.zeros(n)
    stand = {**probe, "vx": np.zeros(n), "vy": np.zeros(n), "wz": np.zeros(n)}
    for c, v in channels.items():
        probe[c] = stand[c] = np.full(n, v, dtype=object if isinstance(v, str) else float)
    return probe, stand


def _evaluate(term: Term, features: dict) -> np.ndarray:
    v = term.parsed.evaluate(prepare_features(features))
    return np.broadcast_to(np.asarray(v, dtype=float), features["alpha"].shape)


@lru_cache(maxsize=1024)
def _moving_vs_standing(term: Term, channels: tuple) -> float:
    """How much a term prices moving over standing when it prices every motion class alike.

    0 when it prices a class differently from another (or moving as standing); else the
    largest difference between its value moving and standing on :func:`_class_probes`.
    """
    n = None
    moving, standing = [], []
    for k in _CLASS_DIRECTIONS:
        probe, stand = _class_probes(k, dict(channels))
        n = n or probe["alpha"].size // len(_CLASS_DIRECTIONS[k])
        moving.append(_evaluate(term, probe).reshape(-1, n))
        standing.append(_evaluate(term, stand)[:n])
    rows = np.vstack(moving)
    if not np.allclose(rows, rows[0], rtol=1e-9, atol=1e-12):
        return 0.0
    return float(np.max(np.abs(rows[0] - standing[0])))


def _prices_absent_motion(
    term: Term,
    absent: Sequence[str],
    column: np.ndarray,
    table: pd.DataFrame,
    n_standing: int | None = None,
    present: Sequence[str] = (),
    *,
    probed: dict[str, Any] | None = None,
) -> str | None:
    """Why a term of another kind is not identified, or None (see :func:`identify_terms`).

    ``probed``: the channels' probe values taken so far from this ``table`` (filled in
    here): the terms of one model share their channels, whose median or most frequent
    value is then taken once.
    """
    if not absent and n_standing is None:
        return None
    probed = {} if probed is None else probed
    channels: dict[str, Any] = {}
    for c in sorted(term.variables - MOTION_FEATURES):
        if c not in table:
            return None  # evaluated without the table's channels: nothing to probe with
        if c not in probed:
            v = table[c]
            probed[c] = (
                float(np.nanmedian(v.to_numpy(float)))
                if pd.api.types.is_numeric_dtype(v)
                else str(v.mode().iloc[0])
            )
        channels[c] = probed[c]
    scale = float(np.nanmax(np.abs(column))) if column.size else 0.0
    tol = 1e-6 * scale + 1e-9
    if n_standing is not None:
        gait = _moving_vs_standing(term, tuple(sorted(channels.items())))
        if gait > tol:
            if n_standing >= MIN_WINDOWS_PER_TERM:
                return None  # every motion alike: the standing windows tell it
            return (
                f"it prices moving against standing (by up to {gait:.3g}, the same for every "
                f"motion), and the campaign has {n_standing} standing window(s) (need "
                f"{MIN_WINDOWS_PER_TERM}): the logs cannot tell it from idle_power; keep the "
                "stops in the logs"
            )
    if not absent:
        return None
    parts = _additive_parts(term)
    if len(parts) > 1:  # a sum is told when each of its parts is
        for part in parts:
            why = _prices_absent_motion(
                part, absent, column, table, n_standing, present, probed=probed
            )
            if why:
                return why
        return None
    told = max((_prices_class(term, k, channels) for k in present), default=0.0)
    for k in absent:
        diff = _prices_class(term, k, channels)
        if diff > tol and diff > told * (1.0 + 1e-9):
            label = "turn-in-place" if k == "turning" else k
            held = f"up to {told:.3g}" if told > tol else "nothing"
            return (
                f"it prices {label} motion (its value walking {label} differs from its value "
                f"standing by up to {diff:.3g}; on the motions the logs hold, by {held}), "
                f"and the campaign has fewer than {MIN_WINDOWS_PER_TERM} {label} windows: "
                f"the logs cannot have told it what {label} motion costs; record such runs"
            )
    return None


def _additive_parts(term: Term) -> list[Term]:
    """The terms of a sum, a factor without motion distributed over them.

    ``load_kg * (2 * pos(vx) + 3 * gait)`` -> ``load_kg * (2 * pos(vx))``,
    ``load_kg * (3 * gait)``: what a channel times the fitted base is made of. A formula
    that is not a sum is its own only part.
    """
    import ast

    def split(node: ast.expr) -> list[ast.expr]:
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add):
            return split(node.left) + split(node.right)
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mult):
            for factor, rest in ((node.left, node.right), (node.right, node.left)):
                names = {n.id for n in ast.walk(factor) if isinstance(n, ast.Name)}
                if not names & MOTION_FEATURES:
                    inner = split(rest)
                    if len(inner) > 1:
                        return [ast.BinOp(factor, ast.Mult(), p) for p in inner]
        return [node]

    nodes = split(term.parsed._tree)
    if len(nodes) < 2:
        return [term]
    return [Term(name=f"{term.name}[{i}]", formula=ast.unparse(n)) for i, n in enumerate(nodes)]


def _prices_class(term: Term, kind: str, channels: Mapping[str, Any]) -> float:
    """Largest difference of a term's value on probes of a motion class from standing."""
    probe, stand = _class_probes(kind, channels)
    ev = [term.parsed.evaluate(prepare_features(f)) for f in (probe, stand)]
    diff = np.abs(np.asarray(ev[0], float) - np.asarray(ev[1], float))
    diff = np.broadcast_to(diff, probe["alpha"].shape)
    return float(np.nanmax(diff)) if np.isfinite(diff).any() else 0.0


def identifiable(windows: Any, terms: EnergyModel | Sequence[str | Term]) -> dict[str, str]:
    """Terms these windows cannot identify, with the reason (:func:`identify_terms`).

    Parameters
    ----------
    windows : Windows
        As for :func:`fit_model`.
    terms : EnergyModel or sequence of term specs
        The terms to check.

    Returns
    -------
    dict
        Term name -> why the windows cannot identify it (empty when all are).
    """
    model = _as_model(terms, windows)
    table = aligned_table(windows)
    groups = windows.samples["window"].to_numpy()
    X = model.design_matrix(model_features(windows.samples, model), groups=groups)
    return identify_terms(model, X, table["duration"].to_numpy(float), table)


#: Motion class of the windows -> gaits of :func:`energy_planner.model.check_walking_power`.
_GAITS_OF_KIND = {
    "forward": ("forward",),
    "backward": ("backward",),
    "lateral": ("sideways left", "sideways right"),
    "turning": ("turning in place",),
}


def refuse_free_walking(model: EnergyModel, table: pd.DataFrame) -> int:
    """Refuse a fitted model that prices walking at <= 0 W inside its calibration's domain.

    The domain: every gait the model prices (the motion classes of the windows with at
    least :data:`MIN_WINDOWS_PER_TERM` windows, and those of its terms), slopes up to the
    steepest window, the 10th and 90th percentile speeds of the walking windows, and each
    channel the model reads at its minimum, median and maximum (every category). See
    :func:`energy_planner.model.model.check_walking_power`.

    Returns
    -------
    int
        Walking motions checked.

    Raises
    ------
    NonPositivePowerError
        The model prices a walking motion of its domain at <= 0 W (names the term).
    """
    from energy_planner.model.model import check_walking_power

    kinds = table["kind"].to_numpy()
    seen = {k for k in _GAITS_OF_KIND if int(np.sum(kinds == k)) >= MIN_WINDOWS_PER_TERM}
    seen |= {t.kind for t in model.terms if t.kind in _GAITS_OF_KIND}
    gaits = [g for k in _GAITS_OF_KIND if k in seen for g in _GAITS_OF_KIND[k]]
    walking = _walking_speeds(table)
    speeds = (
        sorted({float(np.quantile(walking, 0.1)), float(np.quantile(walking, 0.9))})
        if walking.size
        else [0.3]
    )
    values: dict[str, Any] = {
        c: v if isinstance(v, list)
        else (sorted({float(v.min()), float(np.median(v)), float(v.max())}) if v.size else [0.0])
        for c, v in _channel_values(table, model).items()
    }  # fmt: skip
    max_slope = float(np.degrees(np.nanmax(table["alpha"].to_numpy(float)))) if len(table) else 0.0
    return check_walking_power(
        model,
        values,
        max_slope_deg=max_slope,
        speeds=speeds,
        gaits=gaits,
        where="fitted on these logs, ",
    )


def _walking_speeds(table: pd.DataFrame) -> np.ndarray:
    """Speeds of the windows that walk (above the standing threshold), m/s."""
    from energy_planner.model.model import WALKING_SPEED

    speed = (
        table["speed"].to_numpy(float)
        if "speed" in table
        else np.hypot(table["vx"].to_numpy(float), table["vy"].to_numpy(float))
    )
    return speed[speed > WALKING_SPEED]


def _channel_values(table: pd.DataFrame, model: EnergyModel) -> dict[str, Any]:
    """Per log channel the model reads: its finite values (numeric) or sorted categories."""
    out: dict[str, Any] = {}
    for c in sorted(model.variables - MOTION_FEATURES):
        if c not in table:
            continue
        v = table[c]
        if pd.api.types.is_numeric_dtype(v):
            f = v.to_numpy(float)
            out[c] = f[np.isfinite(f)]
        else:
            out[c] = sorted(v.dropna().astype(str).unique())
    return out


def calibration_domain(table: pd.DataFrame, model: EnergyModel) -> dict[str, Any]:
    """The ranges the calibration's windows saw (stored as ``metadata.fit.domain``).

    Returns
    -------
    dict
        ``max_slope_deg``; ``speed_m_s`` [min, max] of the walking windows;
        ``max_turn_rate_rad_s``; ``gaits``: per motion class with windows, their number and
        the [min, max] relative heading ``|gamma|`` (deg) of its windows on slopes above
        :data:`energy_planner.uncertainty.domain.SLOPED_DEG` (None without any);
        ``channels``: per channel the model reads, [min, max] (numeric) or the categories;
        ``gait_speed_m_s`` (when the model reads the ``gait`` channel): per gait the [min,
        max] speed of its walking windows. :func:`fit_model` adds ``mean_power_w``, the
        runs' predicted mean power range (:func:`run_power_range`).
    """
    from energy_planner.uncertainty.domain import SLOPED_DEG

    walking = _walking_speeds(table)
    gamma = np.degrees(np.abs(table["gamma"].to_numpy(float)))
    sloped = np.degrees(table["alpha"].to_numpy(float)) > SLOPED_DEG
    kinds = table["kind"].to_numpy()
    gaits = {}
    for k in _GAITS_OF_KIND:
        sel = kinds == k
        if sel.any():
            on = sel & sloped  # the relative heading means something on sloped ground only
            gaits[k] = {
                "windows": int(sel.sum()),
                "rel_heading_deg": (
                    [round(float(gamma[on].min()), 2), round(float(gamma[on].max()), 2)]
                    if on.any()
                    else None
                ),
            }
    channels: dict[str, Any] = {
        c: v if isinstance(v, list) else [float(v.min()), float(v.max())]
        for c, v in _channel_values(table, model).items()
        if isinstance(v, list) or v.size
    }
    out: dict[str, Any] = {}
    if GAIT_CHANNEL in model.variables:
        # the speeds the controller walked each gait at: a plan prices a gait there only
        out["gait_speed_m_s"] = speed_support(table).gaits
    return {
        **out,
        "max_slope_deg": round(float(np.degrees(np.nanmax(table["alpha"].to_numpy(float)))), 2),
        "speed_m_s": (
            [round(float(walking.min()), 3), round(float(walking.max()), 3)]
            if walking.size
            else None
        ),
        "max_turn_rate_rad_s": round(float(np.nanmax(np.abs(table["wz"].to_numpy(float)))), 3),
        "gaits": gaits,
        "channels": channels,
    }


def run_power_range(cv: CrossValidation | None) -> dict[str, Any]:
    """The calibration runs' predicted mean power range, ``{"mean_power_w": [lo, hi]}``.

    Each run's cross-validated prediction over its duration: the run whole
    (``CrossValidation.whole``, its predicted energy over its duration) when the windows
    carry their runs, else its windows' (``CrossValidation.windows``: their held-out mean
    power weighted by their durations). The predicted power,
    not the measured one: a path's mean power is a prediction (:func:`~energy_planner.
    uncertainty.domain_report` compares ``energy_j / duration_s`` with it), so the two
    carry the same model error, and these predictions are those whose errors are the
    interval's scores: beyond them the interval was calibrated on no prediction. Empty
    without a cross-validation (no scores, no interval) or runs.
    """
    if cv is None:
        return {}
    if cv.whole is not None:
        e = cv.whole["predicted_j"].to_numpy(float)
        t = cv.whole["duration_s"].to_numpy(float)
    else:
        w = cv.windows
        run = w["run"].astype(str).to_numpy()
        g = pd.DataFrame({"e": w["predicted_w"] * w["duration"], "t": w["duration"]})
        g = g.groupby(run, sort=True).sum(min_count=1)
        e, t = g["e"].to_numpy(float), g["t"].to_numpy(float)
    ok = np.isfinite(e) & np.isfinite(t) & (t > 0)
    if not ok.any():
        return {}
    p = e[ok] / t[ok]
    return {"mean_power_w": [round(float(p.min()), 2), round(float(p.max()), 2)]}


# --------------------------------------------------------------------------- diagnostics
def _coverage(table: pd.DataFrame) -> pd.DataFrame:
    heading = heading_class(table["alpha"].to_numpy(float), table["climb"].to_numpy(float))
    df = pd.DataFrame(
        {
            "kind": table["kind"].to_numpy(),
            "heading": np.where(table["kind"] == "turning", "in place", heading),
            "alpha_deg": np.degrees(table["alpha"].to_numpy(float)),
            "run": table["run"].astype(str).to_numpy(),
        }
    )
    cov = (
        df.groupby(["kind", "heading"])
        .agg(
            windows=("alpha_deg", "size"),
            runs=("run", "nunique"),
            max_alpha_deg=("alpha_deg", "max"),
        )
        .reset_index()
    )
    cov["max_alpha_deg"] = cov["max_alpha_deg"].round(2)
    return cov


def _support_warnings(
    model: EnergyModel, X: np.ndarray, w: np.ndarray, table: pd.DataFrame, vif: np.ndarray
) -> list[str]:
    out: list[str] = []
    names = model.term_names
    alpha_deg = np.degrees(table["alpha"].to_numpy(float))
    heading = heading_class(table["alpha"].to_numpy(float), table["climb"].to_numpy(float))
    kinds_in_model = {t.kind for t in model.terms}
    labels = {"forward": "forward", "backward": "backward", "lateral": "lateral", "turning": "turn"}
    # slope coverage per motion type
    for kind in ("forward", "backward", "lateral", "turning"):
        if kind not in kinds_in_model:
            continue
        kind_terms = [t.name for t in model.terms if t.kind == kind]
        sel = (table["kind"] == kind).to_numpy()
        if not sel.any():
            continue  # a zero column: model.fit names the terms
        steepest = float(alpha_deg[sel].max())
        if steepest < STEEP_DEG:
            out.append(
                f"no {labels[kind]} windows on slopes steeper than {STEEP_DEG:g} deg (steepest "
                f"{steepest:.1f} deg): the slope terms {', '.join(kind_terms)} rest on nearly "
                f"level ground and extrapolate on real slopes; record {labels[kind]} runs on "
                "slopes"
            )
            continue
        if kind in ("forward", "backward", "lateral"):
            on_slope = sel & (heading != "level")
            ups = int(np.sum(on_slope & (heading == "uphill")))
            downs = int(np.sum(on_slope & (heading == "downhill")))
            if ups == 0 or downs == 0:
                missing = "downhill" if downs == 0 else "uphill"
                out.append(
                    f"{labels[kind]} windows on slopes include no {missing} travel "
                    f"({ups} uphill, {downs} downhill): the {missing} {labels[kind]} force is "
                    f"extrapolated from the other direction through {', '.join(kind_terms)}"
                )
        n_runs_kind = table.loc[sel, "run"].nunique()
        if n_runs_kind < 2:
            out.append(
                f"all {labels[kind]} windows come from one run: "
                f"{', '.join(kind_terms)} cannot be validated on a held-out run"
            )
    # a single speed with a speed term: judge by each run's cruising speed (the 90th
    # percentile of its windows), since speed ramps at run starts and ends spread the
    # window speeds without giving a second steady speed
    speed = table["speed"].to_numpy(float) if "speed" in table else np.hypot(table.vx, table.vy)
    moving = speed > 0.05
    cruise = (
        pd.Series(speed[moving]).groupby(table["run"].astype(str).to_numpy()[moving]).quantile(0.9)
    )
    if len(cruise) >= 2:
        lo, med, hi = np.percentile(cruise.to_numpy(), [5, 50, 95])
        if (hi - lo) <= SINGLE_SPEED_SPREAD * med:
            for t in model.terms:
                # a term that also reads a log channel (payload_kg * speed) is told apart
                # by that channel varying between runs; one of motion only is not
                if t.name in BASE_TERMS or "speed" not in t.variables:
                    continue
                if not set(t.variables) <= _KINEMATIC:
                    continue
                out.append(
                    f"all runs cruise at one speed ({med:.2f} m/s; 5-95 % of runs "
                    f"{lo:.2f}-{hi:.2f} m/s): term {t.name!r} ({t.formula}) needs runs at "
                    "several speeds; with one speed only the speed ramps vary it, it trades "
                    "off against the per-metre forces and its coefficient means little"
                )
    # (near) linear dependence
    for j, name in enumerate(names):
        if np.isfinite(vif[j]) and vif[j] > VIF_WARN:
            Xw = X * np.sqrt(w)[:, None]
            others = np.delete(Xw, j, axis=1)
            coef, *_ = np.linalg.lstsq(others, Xw[:, j], rcond=None)
            contrib = np.abs(coef) * np.linalg.norm(others, axis=0)
            other_names = [n for i, n in enumerate(names) if i != j]
            top = [other_names[i] for i in np.argsort(contrib)[::-1][:2]]
            out.append(
                f"term {name!r} is nearly in the span of the other terms (VIF {vif[j]:.0f}, "
                f"1 - R^2 = {1 / vif[j]:.3g}; mostly {', '.join(top)}): the data hardly tells "
                "them apart, so its coefficient is poorly determined"
            )
    # terms supported by very few windows
    for j, name in enumerate(names):
        nz = int(np.sum(np.abs(X[:, j]) > 1e-9))
        if 0 < nz < MIN_WINDOWS_PER_TERM:
            out.append(f"term {name!r} is non-zero on only {nz} window(s): too few to fit it")
    return out


# --------------------------------------------------------------------------- API
def cross_validate(
    model_or_terms: EnergyModel | Sequence[str | Term] | None,
    windows: Any,
    n_splits: int = 5,
    seed: int = 0,
    *,
    fixed: Mapping[str, float] | None = None,
) -> CrossValidation:
    """Validate a model's terms by run: refit on some runs, predict the others.

    Parameters
    ----------
    model_or_terms : EnergyModel, sequence of term specs, or None
        The terms to validate (a model's coefficients are ignored: each fold refits
        them); None means the base model (:func:`base_terms`).
    windows : Windows
        Measurements contract: ``samples`` and ``table``.
    n_splits : int
        Number of folds; reduced to the number of runs (leave-one-run-out) when there
        are fewer runs, with a warning.
    seed : int
        Seed of the random assignment of runs to folds.
    fixed : mapping, optional
        Term name -> coefficient held fixed in every fold (a prior for a term the data
        cannot identify, see :func:`fit_model`); the other terms are refitted.

    Returns
    -------
    CrossValidation

    Raises
    ------
    FitError
        Fewer than two runs, or missing columns.
    """
    model = _as_model(model_or_terms, windows)
    table = aligned_table(windows)
    samples = windows.samples
    runs = table["run"].astype(str).to_numpy()
    n_runs = len(np.unique(runs))
    warnings: list[str] = []
    if n_runs < MIN_RUNS:
        raise FitError(
            f"cross-validation by run needs at least {MIN_RUNS} runs; the data has {n_runs}"
        )
    if n_splits > n_runs:
        warnings.append(
            f"{n_splits} folds requested but only {n_runs} runs: using {n_runs} folds "
            "(leave one run out)"
        )
        n_splits = n_runs
    fold_of_window = fold_index(runs, n_splits, seed)
    folds = [sorted(set(runs[fold_of_window == i])) for i in range(n_splits)]
    fixed = dict(fixed or {})
    all_names = model.term_names
    D_all = model.design_matrix(model_features(samples, model))  # per sample
    free = np.array([n not in fixed for n in all_names], dtype=bool)
    names = [n for n in all_names if n not in fixed]
    held = np.array([fixed[n] for n in all_names if n in fixed], dtype=float)
    D = D_all if free.all() else D_all[:, free]  # no copy of the design when all are free
    offset_sample = D_all[:, ~free] @ held if held.size else None
    del D_all
    _, win = np.unique(samples["window"].to_numpy(), return_inverse=True)
    X = pd.DataFrame(D, copy=False).groupby(win, sort=True).mean().to_numpy()  # no copy of D
    y = table["power"].to_numpy(float)
    w = table["duration"].to_numpy(float)

    # the terms each fold's training runs can identify; the others are predicted as 0
    free_model = EnergyModel([t for t in model.terms if t.name not in fixed])
    fit_columns = identifiable_by_fold(free_model, X, w, table, fold_of_window)
    for i, test_runs in enumerate(folds):
        test = fold_of_window == i
        lost = [
            n
            for j, n in enumerate(names)
            if not fit_columns[i, j] and np.any(np.abs(X[test, j]) > 0)
        ]
        if lost:
            warnings.append(
                f"fold {i}: the training runs cannot identify {', '.join(lost)} (the runs "
                f"that do are held out: {', '.join(test_runs[:6])}"
                f"{', ...' if len(test_runs) > 6 else ''}); this fold predicts them as 0"
            )
    ho = heldout(
        D,
        y,
        fold_of_window,
        w,
        rows=win,
        offset=offset_sample,
        fit_columns=fit_columns,
        floor=None if model.regenerative else 0.0,
        means=X,  # the window means above: heldout need not form them again (memory)
    )
    coefs, pred_w, pred_sample = ho.coef, ho.predicted, ho.sample_predicted
    resid = pred_w - y
    rmse = ho.rmse
    mae = float(np.mean(np.abs(resid)))
    ss_tot = float(np.sum((y - y.mean()) ** 2))
    r2 = float(1 - np.sum(resid**2) / ss_tot) if ss_tot > 0 else float("nan")

    e_meas = window_energy(samples).to_numpy()
    e_pred = window_energy(samples, pred_sample).to_numpy()
    per_window = pd.DataFrame(
        {
            "run": runs,
            "window": table["window"].to_numpy(),
            "fold": fold_of_window,
            "duration": w,
            "measured_w": y,
            "predicted_w": pred_w,
            "measured_j": e_meas,
            "predicted_j": e_pred,
        }
    )
    per_run = (
        per_window.groupby("run", sort=True)
        .agg(
            fold=("fold", "first"),
            duration_s=("duration", "sum"),
            measured_j=("measured_j", "sum"),
            predicted_j=("predicted_j", "sum"),
        )
        .reset_index()
    )
    per_run["error_j"] = per_run["predicted_j"] - per_run["measured_j"]
    with np.errstate(divide="ignore", invalid="ignore"):
        per_run["rel_error"] = per_run["error_j"] / per_run["measured_j"]
    rel = per_run["rel_error"].to_numpy(float)
    rel = rel[np.isfinite(rel)]
    total_rel = float(per_run["error_j"].sum() / per_run["measured_j"].sum())
    whole = whole_run_predictions(
        getattr(windows, "whole_runs", None), model, per_window, coefs, names, fixed,
        floor=None if model.regenerative else 0.0,
    )  # fmt: skip
    return CrossValidation(
        n_splits=n_splits,
        seed=seed,
        folds=folds,
        windows=per_window.drop(columns=["measured_j", "predicted_j"]),
        runs=per_run,
        fold_coefficients=pd.DataFrame(coefs, columns=names)
        .assign(**{n: fixed[n] for n in all_names if n in fixed})
        .rename_axis("fold"),
        rmse_w=rmse,
        mae_w=mae,
        r2=r2,
        energy_mean_abs_rel=float(np.mean(np.abs(rel))) if rel.size else float("nan"),
        energy_max_abs_rel=float(np.max(np.abs(rel))) if rel.size else float("nan"),
        energy_median_abs_rel=float(np.median(np.abs(rel))) if rel.size else float("nan"),
        energy_p90_abs_rel=float(np.percentile(np.abs(rel), 90)) if rel.size else float("nan"),
        energy_total_rel=total_rel,
        warnings=warnings,
        whole=whole,
    )


def whole_run_predictions(
    whole: Any, model: EnergyModel, per_window: pd.DataFrame, coefs: np.ndarray,
    names: Sequence[str], fixed: Mapping[str, float], floor: float | None = 0.0,
) -> pd.DataFrame | None:  # fmt: skip
    """Held-out runs whole: their windows' prediction plus the samples no window holds.

    A run's windows are priced at their held-out mean power times their duration (the
    sum of their samples' time steps, as ``WholeRuns.runs.window_s`` counts them: the
    trapezoid within a window, ``CrossValidation.runs``, leaves out one step per window,
    2.5 % of a 2 s window at 20 Hz, which the whole run must not lose). Each run's
    left-out samples (``WholeRuns.rest``: speed ramps, samples beyond the
    consistency bound, windows too short) are priced by its fold's coefficients
    (``coefs``, one row per fold over the free terms ``names``; the ``fixed`` terms at
    their values), floored per sample as the windows are, each sample times its share of
    the time no window holds (``_w``); the run's measured energy is the battery energy
    of every sample (``WholeRuns.runs``).

    Parameters
    ----------
    whole : WholeRuns or None
        ``Windows.whole_runs``.
    per_window : pandas.DataFrame
        ``CrossValidation.windows`` (run, fold, duration, predicted_w).

    Returns
    -------
    pandas.DataFrame or None
        Rows of :attr:`CrossValidation.whole`; None without ``whole``, when a run of
        ``per_window`` is missing from it or holds other windows than the run was cut
        into (a subset of them), or when its rest cannot be priced.
    """
    if whole is None:
        return None
    win_j = (
        (per_window["predicted_w"] * per_window["duration"])
        .groupby(per_window["run"].astype(str).to_numpy(), sort=True)
        .sum(min_count=1)
    )
    per_run = pd.DataFrame(
        {"run": win_j.index.to_numpy(str), "predicted_j": win_j.to_numpy(float),
         "fold": per_window.groupby(per_window["run"].astype(str), sort=True)["fold"].first()
         .reindex(win_j.index).to_numpy(int)}
    )  # fmt: skip
    runs = per_run["run"].astype(str).to_numpy()
    tab = whole.runs
    if not np.isin(runs, tab.index.to_numpy(str)).all():
        return None
    dur = per_window.groupby(per_window["run"].astype(str), sort=True)["duration"].sum()
    if not np.allclose(
        dur.reindex(runs).to_numpy(float),
        tab["window_s"].reindex(runs).to_numpy(float),
        rtol=1e-9,
        atol=1e-6,
    ):
        return None  # not the windows the runs were cut into (a subset): not whole
    rest = whole.rest
    rest = rest[np.isin(rest["run"].astype(str).to_numpy(), runs)]
    fold_of = dict(zip(runs, per_run["fold"].to_numpy(int), strict=True))
    rest_j = pd.Series(0.0, index=runs)
    if len(rest):
        try:
            D = model.design_matrix(model_features(rest, model))
        except (KeyError, ValueError):
            return None
        free = np.array([n in names for n in model.term_names], dtype=bool)
        fold = np.array([fold_of[r] for r in rest["run"].astype(str)], dtype=int)
        p = np.einsum("ij,ij->i", D[:, free], np.asarray(coefs)[fold])
        if (~free).any():
            p = p + D[:, ~free] @ np.array([fixed[n] for n in model.term_names if n in fixed])
        if floor is not None:
            p = np.maximum(p, floor)
        e = np.where(np.isfinite(p), p, 0.0) * rest["_w"].to_numpy(float)
        rest_j = rest_j.add(pd.Series(e).groupby(rest["run"].astype(str).to_numpy()).sum(),
                            fill_value=0.0)  # fmt: skip
    out = pd.DataFrame(
        {
            "run": runs,
            "fold": per_run["fold"].to_numpy(),
            "duration_s": tab["duration_s"].reindex(runs).to_numpy(float),
            "measured_j": tab["measured_j"].reindex(runs).to_numpy(float),
            "rest_predicted_j": rest_j.reindex(runs).to_numpy(float),
        }
    )
    out["predicted_j"] = per_run["predicted_j"].to_numpy(float) + out["rest_predicted_j"]
    out["priced_by"] = "samples"
    if whole.priced_by == "path":
        path_j = _path_predictions(whole, model, out, coefs, names, fixed)
        use = np.isfinite(path_j)
        out.loc[use, "predicted_j"] = path_j[use]
        out.loc[use, "priced_by"] = "path"
    m = out["measured_j"].to_numpy(float)
    with np.errstate(divide="ignore", invalid="ignore"):
        out["rel_error"] = np.where(m > 0, out["predicted_j"].to_numpy(float) / m - 1.0, np.nan)
    return out


def _path_predictions(
    whole: Any, model: EnergyModel, runs: pd.DataFrame, coefs: np.ndarray,
    names: Sequence[str], fixed: Mapping[str, float],
) -> np.ndarray:  # fmt: skip
    """Each held-out run's logged path over the map priced by its fold's coefficients.

    What the energy of a logged path is (``energy --waypoints`` with times and the run's
    channel values, ``energy.path_energy``), by the fit that did not see the run; NaN
    where the run has no path or it cannot be priced (off the map, a channel missing).
    """
    from energy_planner.energy import path_energy
    from energy_planner.energy.channels import channel_kinds
    from energy_planner.errors import EnergyPlannerError

    chans = list(channel_kinds(model))
    out = np.full(len(runs), np.nan)
    for k in np.unique(runs["fold"].to_numpy(int)):
        fm = copy.copy(model)
        fm.coefficients = {**dict(zip(names, map(float, np.asarray(coefs)[k]), strict=True)),
                           **{n: float(v) for n, v in fixed.items()}}  # fmt: skip
        for i in np.flatnonzero(runs["fold"].to_numpy(int) == k):
            p = whole.paths.get(str(runs["run"].iloc[i]))
            if p is None or any(c not in p["values"] for c in chans):
                continue
            consts = {c: p["values"][c] for c in chans}
            try:
                e = path_energy(whole.terrain, fm, p["xy"], yaw=p["yaw"], t=p["t"],
                                constants=consts)  # fmt: skip
            except (EnergyPlannerError, ValueError):
                continue
            out[i] = float(e.energy_j)
    return out


def as_windows(data: Any, *, window: float = 2.0, repair: bool = True) -> tuple[Any, Any]:
    """Windows and data findings from raw samples, prepared logs or windows.

    Raw canonical samples (a DataFrame without a ``window`` column) go through the one
    data pipeline, :func:`energy_planner.calibration.prepare_logs` (data checks, repair,
    cleaning, windows); a ``PreparedLogs`` brings its own findings; ``Windows`` (or
    windowed samples) come back as they are with no findings (None): the checks run on raw
    samples, before cleaning.

    Returns
    -------
    tuple
        ``(windows, findings)``, findings a list of dicts or None.
    """
    from energy_planner.calibration.prepare import PreparedLogs, prepare_logs

    if isinstance(data, pd.DataFrame) and "window" not in data.columns:
        data = prepare_logs(data, window=window, repair=repair)
    if isinstance(data, PreparedLogs):
        return data.windows, data.findings_dicts()
    return data, None


def fit_model(
    windows: Any,
    terms: EnergyModel | Sequence[str | Term] | None = None,
    *,
    n_splits: int = 5,
    seed: int = 0,
    metadata: dict[str, Any] | None = None,
    prior: EnergyModel | None = None,
    window: float = 2.0,
    repair: bool = True,
) -> FitResult:
    """Fit all terms of a model jointly on all windows and validate it by run.

    Terms the campaign cannot identify (:func:`identify_terms`: no windows of their
    motion, or a column that is a combination of the others) are not given a value: they
    are left out of the fitted model and reported in ``FitResult.unidentified`` (and the
    model's ``metadata["unidentified"]``). With ``prior``, such a term that the prior
    model has is kept at the prior's coefficient instead, reported in
    ``FitResult.held_at_prior`` (no standard error).

    Parameters
    ----------
    windows : Windows, PreparedLogs or pandas.DataFrame
        Measurements contract: ``samples`` (per sample, with ``window``) and ``table``
        (per window, with ``run``, ``duration``, ``power``, ``alpha``, ``motion``...); or
        raw canonical samples, which first go through the data checks, cleaning and
        windows (:func:`as_windows`), the findings then in ``FitResult.data_findings``.
    terms : EnergyModel, sequence of term specs, or None
        What to fit: a model (its terms; coefficients ignored), catalog names and
        formulas, or None for the base model (:func:`base_terms`: the paper's, and
        ``gait_power`` when the logs hold standing).
    n_splits : int
        Folds of the by-run cross-validation; 0 skips it.
    seed : int
        Seed of the assignment of runs to folds.
    metadata : dict, optional
        Stored in the model's ``metadata`` (with the data counts and held-out errors).
    prior : EnergyModel, optional
        A fitted model whose coefficients stand in for the terms this campaign cannot
        identify (e.g. :meth:`EnergyModel.default`); only when the user asks.
    window : float
        Window length (s) when ``windows`` are raw samples.
    repair : bool
        Correct the data findings of raw samples before fitting (reported either way).

    Returns
    -------
    FitResult

    Raises
    ------
    FitError
        Too little data (names the counts and what is needed), or no term identifiable.
    ModelError
        A term needs a channel the logs do not have.
    NonPositivePowerError
        The fitted model prices a walking motion of its calibration's domain at <= 0 W
        (:func:`refuse_free_walking`): it is not returned, so it cannot be saved.
    """
    windows, findings = as_windows(windows, window=window, repair=repair)
    requested = _as_model(terms, windows)
    table = aligned_table(windows)
    samples = windows.samples
    n_windows = len(table)
    n_runs = int(table["run"].nunique())
    w = table["duration"].to_numpy(float)
    if not np.all(np.isfinite(w)) or np.any(w <= 0):
        raise FitError("window durations must be positive and finite (windows.table.duration)")
    if n_runs < MIN_RUNS:
        _check_amount(n_windows, n_runs, len(requested.term_names), requested.term_names)

    groups = samples["window"].to_numpy()
    X_all = requested.design_matrix(model_features(samples, requested), groups=groups)
    y = table["power"].to_numpy(float)
    unidentified = identify_terms(requested, X_all, w, table)
    prior_coefs = dict(prior.coefficients or {}) if prior is not None else {}
    held = {n: float(prior_coefs[n]) for n in unidentified if n in prior_coefs}
    dropped = {n: why for n, why in unidentified.items() if n not in held}
    fit_idx = [j for j, n in enumerate(requested.term_names) if n not in unidentified]
    if not fit_idx:
        _check_amount(n_windows, n_runs, len(requested.term_names), requested.term_names)
        raise FitError(
            f"no term of the model can be identified from {n_windows} windows of {n_runs} "
            "runs: " + "; ".join(f"{n}: {why}" for n, why in unidentified.items())
        )
    names = [requested.term_names[j] for j in fit_idx]
    _check_amount(n_windows, n_runs, len(names), names)
    keep_terms = [t for t in requested.terms if t.name not in dropped]
    model = EnergyModel(
        keep_terms, regenerative=requested.regenerative, metadata=requested.metadata
    )
    X = X_all[:, fit_idx]
    held_idx = [requested.term_names.index(n) for n in held]
    offset = X_all[:, held_idx] @ np.array(list(held.values())) if held else np.zeros(n_windows)
    res = wls(X, y - offset, w, clusters=table["run"].astype(str).to_numpy())
    coefs = dict(zip(names, map(float, res.coef), strict=True))
    stderr = dict(zip(names, map(float, res.stderr), strict=True))
    se_run = dict(zip(names, map(float, res.stderr_by_run), strict=True))
    model.coefficients = {n: coefs.get(n, held.get(n)) for n in model.term_names}
    model.stderr = {n: stderr.get(n, float("nan")) for n in model.term_names}
    refuse_free_walking(model, table)
    resid = res.resid
    rms = float(np.sqrt(np.sum(w * resid**2) / np.sum(w)))
    vifs = vif(X, w)
    warnings = _support_warnings(EnergyModel(names), X, w, table, vifs)
    for n, why in dropped.items():
        warnings.append(
            f"term {n!r} cannot be identified from this campaign ({why}); it is left out of "
            "the fitted model, which therefore prices that motion without it (give a prior "
            "model, fit --prior, to hold it at the prior's value instead)"
        )
    for n, c in held.items():
        warnings.append(
            f"term {n!r} cannot be identified from this campaign ({unidentified[n]}); it is "
            f"held at the prior's value {c:g} {_unit(requested, n)}"
        )

    heldout = None
    error_model = None
    if n_splits:
        heldout = cross_validate(model, windows, n_splits=n_splits, seed=seed, fixed=held)
        warnings += heldout.warnings
        error_model, inside = _error_models(model, heldout, table, X, res, w)
        if error_model is not None:
            # the growth is measured on the extreme runs' window energies: their error
            # inside the range is the error model's of window energies, not of whole runs
            growth = extrapolation_growth(
                model, table, X, y, w, inside or error_model, offset, names
            )
            error_model = dataclasses.replace(error_model, extrapolation=growth)
    support = speed_support(table)
    model.metadata = {
        **model.metadata,
        **(metadata or {}),
        "fit": {
            "method": "joint weighted least squares on window means (weights: duration)",
            "speed_terms": {
                "supported": support.supported,
                "in_model": [n for n in model.term_names if n in SPEED_TERMS],
                "reason": support.reason,
            },
            "n_windows": n_windows,
            "n_runs": n_runs,
            "residual_rms_w": round(rms, 3),
            "stderr_by_run": {n: float(f"{v:.3g}") for n, v in se_run.items()},
            "unidentified": dict(dropped),
            "held_at_prior": {n: {"value": c, "reason": unidentified[n]} for n, c in held.items()},
            "domain": {**calibration_domain(table, model), **run_power_range(heldout)},
            **(
                {}
                if findings is None
                else {"data_findings": [f["name"] for f in findings if f["finding"]]}
            ),
            **(
                {}
                if heldout is None
                else {
                    "heldout_power_rmse_w": round(heldout.rmse_w, 3),
                    "heldout_energy_mean_abs_rel_error": round(heldout.energy_mean_abs_rel, 5),
                    "heldout_energy_median_abs_rel_error": round(heldout.energy_median_abs_rel, 5),
                    "heldout_energy_p90_abs_rel_error": round(heldout.energy_p90_abs_rel, 5),
                    # every held-out run's predicted / measured - 1, sorted: the scores of
                    # the split-conformal energy intervals (energy_planner.uncertainty)
                    "heldout_run_rel_errors": sorted(
                        round(float(v), 5) for v in heldout.runs["rel_error"].dropna()
                    ),
                    "n_splits": heldout.n_splits,
                    **({} if error_model is None else {"error_model": error_model.to_dict()}),
                }
            ),
        },
    }
    return FitResult(
        model=model,
        coefficients=dict(model.coefficients),
        stderr=dict(model.stderr),
        n_windows=n_windows,
        n_runs=n_runs,
        heldout=heldout,
        warnings=warnings,
        residual_rms_w=rms,
        condition_number=res.condition_number,
        vif=dict(zip(names, map(float, vifs), strict=True)),
        coverage=_coverage(table),
        stderr_by_run=se_run,
        unidentified=dict(dropped),
        held_at_prior=held,
        data_findings=findings,
        speed_terms=support,
    )


def _error_models(
    model: EnergyModel, cv: CrossValidation, table: pd.DataFrame, X: np.ndarray, res: Any,
    w: np.ndarray,
) -> tuple[Any, Any]:  # fmt: skip
    """The held-out runs' error models, ``(of the runs, of their window energies)``.

    The run-to-run error model of :mod:`energy_planner.uncertainty.errormodel`.

    A run's coefficient variance is ``g^T V g`` with ``g`` its term energies (the fitted
    columns' window means times the window durations, summed) and ``V`` a run-clustered
    covariance: of its fold's fit for the held-out errors (which hold it), of the full
    fit for new predictions (``rho2``, pooled over the runs as a share of ``E^2``). Its
    share outside the domain is measured against the ranges of its fold's training runs.

    A held-out run's predicted and measured energies are those of the run whole
    (``cv.whole``: every sample, the samples no window holds priced by the fold's
    coefficients; ``scored_on="runs"``) when the windows carry their whole runs, else
    its windows' (``scored_on="windows"``). The second model is always scored on the
    windows' energies (the scale the growth beyond the ranges is measured on; the same
    object as the first without whole runs). The coefficient variance and the noise within
    the run are the windows' either way; they are computed once for both.
    """  # noqa: E501
    from energy_planner.stats import cluster_covariance, wls_coef
    from energy_planner.uncertainty.errormodel import fit_error_model, within_run_noise

    runs = table["run"].astype(str).to_numpy()
    energy = X * w[:, None]  # term energies of each window

    def run_variance(V: np.ndarray, rows: np.ndarray) -> pd.Series:
        g = pd.DataFrame(energy[rows]).groupby(runs[rows], sort=True).sum()
        return pd.Series(np.einsum("ij,jk,ik->i", g.to_numpy(), V, g.to_numpy()), g.index)

    everything = np.ones(len(runs), bool)
    V = np.nan_to_num(cluster_covariance(X, res.resid, w, runs))
    full = run_variance(V, everything)
    # each held-out run was predicted by its fold's fit, whose coefficients err more
    # than the full fit's: its error holds that fold's coefficient variance
    fold = cv.windows["fold"].to_numpy()
    y = res.resid + X @ res.coef
    parts = []
    for k in np.unique(fold):
        tr = fold != k
        coef = wls_coef(X[tr], y[tr], w[tr])
        Vk = np.nan_to_num(cluster_covariance(X[tr], y[tr] - X[tr] @ coef, w[tr], runs[tr]))
        parts.append(run_variance(Vk, ~tr))
    fold_var = pd.concat(parts)
    share = heldout_outside_shares(table, model, fold)
    # the windows' errors within each run measure the error that averages out over a run
    cw = cv.windows
    noise = within_run_noise(
        cw["run"].astype(str).to_numpy(),
        ((cw["predicted_w"] - cw["measured_w"]) * cw["duration"]).to_numpy(float),
        (cw["predicted_w"] * cw["duration"]).to_numpy(float),
        cw["duration"].to_numpy(float),
    )

    def fit_on(scored: pd.DataFrame, scored_on: str) -> Any:
        per_run = scored.set_index(scored["run"].astype(str))
        pred = per_run["predicted_j"].to_numpy(float)
        ok = pred > 0
        rho2 = float(full.reindex(per_run.index).to_numpy(float)[ok].sum() / np.sum(pred[ok] ** 2))
        within = noise.reindex(per_run.index).fillna(0.0)  # no windows: no rows (dof 0)
        return fit_error_model(
            pred,
            per_run["measured_j"].to_numpy(float),
            per_run["duration_s"].to_numpy(float),
            fold_var.reindex(per_run.index).to_numpy(float),
            share.reindex(per_run.index).fillna(0.0).to_numpy(float),
            per_run["fold"].to_numpy(),
            param_rel_var=rho2,
            within=(within["ss"].to_numpy(), within["t_eff"].to_numpy(), within["dof"].to_numpy()),
            scored_on=scored_on,
        )

    # a held-out run's energy is the run whole when the windows carry their runs (the
    # energy a user asks for: every sample, the ones cleaning dropped priced by the same
    # fold's coefficients); else its windows' energy, and the error model says so
    of_windows = fit_on(cv.runs, "windows")
    if cv.whole is None:
        return of_windows, of_windows
    return fit_on(cv.whole, "runs"), of_windows


def _unit(model: EnergyModel, name: str) -> str:
    """Unit of a term's coefficient (for messages)."""
    return {t.name: t.unit for t in model.terms}[name]


def heldout_outside_shares(
    table: pd.DataFrame, model: Any, fold_of_window: np.ndarray
) -> pd.Series:
    """Per run, the share of its duration outside the domain of its fold's training runs.

    In the cross-validation by run each run is predicted by a fit on the other folds; the
    ranges those folds saw (:func:`calibration_domain`)
    are the domain that prediction had, so the share of the held-out run outside it is
    the input the error model (:mod:`energy_planner.uncertainty.errormodel`) relates to
    that run's error.
    """
    import pandas as pd

    from energy_planner.uncertainty.domain import report_against_groups, window_segments

    runs = table["run"].astype(str).to_numpy()
    fold = np.asarray(fold_of_window)
    seg = window_segments(table)
    chan_cols = [c for c in table.columns if c in (model.variables or set())]
    out: dict[str, float] = {}
    for k in np.unique(fold):
        train = fold != k
        if not train.any():
            continue
        dom = calibration_domain(table.loc[train].reset_index(drop=True), model)
        # every held-out run's report from one set of the fold's segment columns
        held = np.unique(runs[~train])
        rows = [np.flatnonzero(runs == run) for run in held]
        vals = {c: table[c].to_numpy() for c in chan_cols if c in dom["channels"]}
        reps = report_against_groups(dom, seg, rows, vals)
        for run, rep in zip(held, reps, strict=True):
            out[run] = rep["outside_share"]
    return pd.Series(out, dtype=float)


#: Share of the runs held out at most, and the fewest, when measuring the error growth
#: beyond a range (:func:`extrapolation_growth`).
EXTREME_SHARE = (0.1, 0.4)
#: Fewest held-out runs beyond the rest's range for a growth to be measured.
MIN_EXTREME_RUNS = 3
#: The held-out runs must go beyond the rest's range by at least this share of its width
#: (median of their farthest window), else the quantity does not spread enough to measure.
MIN_EXCESS_SHARE = 0.2


def _quantity_values(
    table: pd.DataFrame, model: EnergyModel
) -> dict[str, tuple[np.ndarray, str, tuple[str, ...]]]:
    """Per numeric quantity of the domain: its value per window, its unit and its sides."""
    from energy_planner.model.model import WALKING_SPEED

    out = {"slope": (np.degrees(table["alpha"].to_numpy(float)), "deg", ("high",))}
    speed = (
        table["speed"].to_numpy(float)
        if "speed" in table
        else np.hypot(table["vx"].to_numpy(float), table["vy"].to_numpy(float))
    )
    out["speed"] = (np.where(speed > WALKING_SPEED, speed, np.nan), "m/s", ("low", "high"))
    for c, v in _channel_values(table, model).items():
        if not isinstance(v, list):
            out[f"channel {c}"] = (table[c].to_numpy(float), c, ("low", "high"))
    return out


def _extreme_runs(ext: pd.Series) -> list[str]:
    """The runs with the most extreme values: cut at the widest gap within the top 10-40 %.

    ``ext``: per run its extreme (the larger the more extreme). Designed campaigns come
    in levels (slopes 0, 5, ... 20 deg): the widest gap keeps a level whole.
    """
    e = ext.dropna().sort_values(ascending=False)
    n = e.size
    k_lo = max(MIN_EXTREME_RUNS, math.ceil(EXTREME_SHARE[0] * n))
    k_hi = min(math.floor(EXTREME_SHARE[1] * n), n - MIN_RUNS)
    if k_hi < k_lo:
        return []
    v = e.to_numpy(float)
    gaps = v[k_lo - 1 : k_hi] - v[k_lo : k_hi + 1]
    if not gaps.size or gaps.max() <= 0:
        return []
    k = k_lo + int(np.argmax(gaps))
    return [str(r) for r in e.index[:k]]


def extrapolation_growth(
    model: EnergyModel,
    table: pd.DataFrame,
    X: np.ndarray,
    y: np.ndarray,
    w: np.ndarray,
    error_model: Any,
    offset: np.ndarray | None = None,
    columns: Sequence[str] | None = None,
) -> dict[str, dict[str, Any]]:
    r"""How the run-energy error grows beyond each numeric range of the domain.

    For each numeric quantity the domain records (slope; walking speed; each numeric
    channel the model reads) and each side of its range (slope: the steepest; speed and
    channels: the lowest and the highest): the runs with the most extreme values (cut at
    the widest gap between run extremes within the top 10-40 % of runs) are held out, the
    model's fitted columns are refitted on the rest (one weighted least squares each) and
    the held-out runs' energies predicted. A held-out run goes ``u`` beyond the rest's
    range (each window's distance beyond it, averaged over the run's duration, as
    :func:`energy_planner.uncertainty.domain_report` averages a path's ``excess``); its
    relative error ``r = (E_pred - E) / E_pred`` has the inside variance ``v`` of the error
    model plus the growth:

    .. math:: r^2 \approx v + g^2 u^2, \qquad
              g^2 = \max\Big(0, \frac{\sum u^2 (r^2 - v)}{\sum u^4}\Big)

    pooled over both sides. Not measured (``growth_per_unit`` None, with ``why``) when
    fewer than :data:`MIN_EXTREME_RUNS` runs can be held out beyond the rest's range, when
    they go beyond it by less than :data:`MIN_EXCESS_SHARE` of its width, or when the rest
    cannot identify a term.

    Parameters
    ----------
    model : EnergyModel
        The fitted model (its fitted terms are the columns of ``X``).
    table : pandas.DataFrame
        The window table (``run``, ``alpha``, speed, channels).
    X, y, w : numpy.ndarray
        Window means of the fitted columns, window power (W), durations (s).
    error_model : ErrorModel
        The fit's error model (the inside variance ``v``).
    offset : numpy.ndarray, optional
        Power of the terms held at a prior, per window (W).
    columns : sequence of str, optional
        The terms of the columns of ``X`` (default: all of the model's).

    Returns
    -------
    dict
        Quantity (``slope``, ``speed``, ``channel NAME``) -> ``growth_per_unit``
        (relative error per unit beyond the range, or None), ``unit``, ``held_out_runs``,
        ``excess`` ([min, max] of the held-out runs' ``u``), ``rms_rel_error`` of the
        held-out runs, or ``why`` it was not measured.
    """
    from energy_planner.stats import wls_coef
    from energy_planner.uncertainty.domain import _beyond

    runs = table["run"].astype(str).to_numpy()
    off = np.zeros(len(y)) if offset is None else np.asarray(offset, float)
    names = list(model.term_names if columns is None else columns)
    fitted = EnergyModel([next(t for t in model.terms if t.name == n) for n in names])
    out: dict[str, dict[str, Any]] = {}
    for q, (v, unit, sides) in _quantity_values(table, model).items():
        per_run = pd.Series(v).groupby(runs)
        pts: list[tuple[float, float, float]] = []
        whys: list[str] = []
        for side in sides:
            ext = per_run.max() if side == "high" else -per_run.min()
            held = _extreme_runs(ext)
            if not held:
                whys.append(f"{side}: too few runs to hold out the most extreme")
                continue
            test = np.isin(runs, held)
            tv = v[~test][np.isfinite(v[~test])]
            if not tv.size:
                whys.append(f"{side}: the other runs have no value")
                continue
            lo, hi = float(tv.min()), float(tv.max())
            lim = (lo, np.inf) if side == "low" else (-np.inf, hi)
            beyond = _beyond(*lim, v)
            width = max(hi - lo, 1e-12)
            peak = pd.Series(beyond[test]).groupby(runs[test]).max()
            if (peak > 0).sum() < MIN_EXTREME_RUNS or peak.median() < MIN_EXCESS_SHARE * width:
                whys.append(f"{side}: the most extreme runs go too little beyond the rest "
                            f"({peak.median():.3g} {unit} beyond {lo:.3g}-{hi:.3g})")  # fmt: skip
                continue
            lost = identify_terms(fitted, X[~test], w[~test], table[~test])
            if lost:
                whys.append(f"{side}: without the most extreme runs the rest cannot identify "
                            + ", ".join(lost))  # fmt: skip
                continue
            coef = wls_coef(X[~test], y[~test] - off[~test], w[~test])
            p = X[test] @ coef + off[test]
            if not model.regenerative:
                p = np.maximum(p, 0.0)
            df = pd.DataFrame({"run": runs[test], "pred": p * w[test], "meas": y[test] * w[test],
                               "t": w[test], "u": beyond[test] * w[test]})  # fmt: skip
            g = df.groupby("run").sum()
            g = g[(g["pred"] > 0) & (g["u"] > 0)]
            for pr, me, t, uw in g[["pred", "meas", "t", "u"]].itertuples(index=False):
                r = (pr - me) / pr
                inside = float(error_model.sigma(pr, t)) / pr
                pts.append((uw / t, r, inside**2))
        if len(pts) < MIN_EXTREME_RUNS:
            why = "; ".join(whys) or "too few held-out runs beyond the range"
            out[q] = {"growth_per_unit": None, "unit": unit, "why": why}
            continue
        u, r, vin = (np.array(a) for a in zip(*pts, strict=True))
        g2 = max(float(np.sum(u**2 * (r**2 - vin)) / np.sum(u**4)), 0.0)
        out[q] = {
            "growth_per_unit": float(math.sqrt(g2)),
            "unit": unit,
            "held_out_runs": int(u.size),
            "excess": [float(u.min()), float(u.max())],
            "rms_rel_error": float(np.sqrt(np.mean(r**2))),
            **({"not_measured_sides": "; ".join(whys)} if whys else {}),
        }
    return out
