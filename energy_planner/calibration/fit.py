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

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from energy_planner.calibration._windows import aligned_table, heading_class, window_energy
from energy_planner.errors import FitError
from energy_planner.model import BASE_TERMS, EnergyModel, Term

__all__ = [
    "FitResult",
    "CrossValidation",
    "fit_model",
    "cross_validate",
    "run_folds",
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
VIF_WARN = 30.0
#: Relative spread of the runs' cruising speeds under which a campaign is single-speed.
SINGLE_SPEED_SPREAD = 0.1
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
    energy_total_rel : float
        Relative error of the summed held-out energy of all runs.
    warnings : list of str
        Folds in which a term had no training data, fewer runs than folds, ...
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
    warnings: list[str] = field(default_factory=list)

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
            "energy_total_rel_error": self.energy_total_rel,
            "runs": self.runs.to_dict(orient="records"),
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

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary."""
        terms = {t.name: t for t in self.model.terms}
        return {
            "terms": [
                {
                    "name": name,
                    "formula": terms[name].formula,
                    "unit": terms[name].unit,
                    "coefficient": self.coefficients[name],
                    "stderr": self.stderr[name],
                    "stderr_by_run": self.stderr_by_run.get(name),
                    "vif": self.vif.get(name),
                }
                for name in self.model.term_names
            ],
            "n_windows": self.n_windows,
            "n_runs": self.n_runs,
            "residual_rms_w": self.residual_rms_w,
            "condition_number": self.condition_number,
            "heldout": None if self.heldout is None else self.heldout.to_dict(),
            "coverage": self.coverage.to_dict(orient="records"),
            "warnings": list(self.warnings),
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
            lines.append(
                f"{name:<{nw}} {self.coefficients[name]:>12.2f} {self.stderr[name]:>10.2f} "
                f"{by_run:>9.2f} {units[name]:<6} {terms[name].formula}"
            )
        lines.append("(std err: classical; by run: robust to correlated windows within a run)")
        cv = self.heldout
        if cv is not None:
            lines += [
                "",
                f"held-out by run ({cv.n_splits} folds, runs never split): power RMSE "
                f"{cv.rmse_w:.1f} W, MAE {cv.mae_w:.1f} W, R^2 {cv.r2:.3f}",
                f"run energy error: mean |err| {100 * cv.energy_mean_abs_rel:.2f} %, "
                f"max |err| {100 * cv.energy_max_abs_rel:.2f} %, "
                f"total {100 * cv.energy_total_rel:+.2f} %",
            ]
        if self.warnings:
            lines += ["", "warnings:"] + [f"  - {w}" for w in self.warnings]
        return "\n".join(lines)


# --------------------------------------------------------------------------- helpers
def _as_model(model_or_terms: EnergyModel | Sequence[str | Term] | None) -> EnergyModel:
    if model_or_terms is None:
        return EnergyModel(BASE_TERMS)
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


def _wls(X: np.ndarray, y: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Weighted least squares (column-scaled, minimum norm for unsupported columns)."""
    sw = np.sqrt(w)
    Xw, yw = X * sw[:, None], y * sw
    scale = np.linalg.norm(Xw, axis=0)
    scale[scale == 0] = 1.0
    beta_s, *_ = np.linalg.lstsq(Xw / scale, yw, rcond=None)
    return beta_s / scale


def _vif(X: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Uncentred variance inflation factor of each column (inf when in the others' span)."""
    Xw = X * np.sqrt(w)[:, None]
    k = X.shape[1]
    out = np.full(k, np.inf)
    for j in range(k):
        xj = Xw[:, j]
        nj = float(xj @ xj)
        if nj == 0:
            continue
        if k == 1:
            out[j] = 1.0
            continue
        others = np.delete(Xw, j, axis=1)
        coef, *_ = np.linalg.lstsq(others, xj, rcond=None)
        r = xj - others @ coef
        frac = float(r @ r) / nj
        out[j] = np.inf if frac <= 1e-14 else 1.0 / frac
    return out


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


def _cluster_stderr(
    X: np.ndarray, resid: np.ndarray, w: np.ndarray, runs: np.ndarray
) -> np.ndarray:
    """Cluster-robust (by run) standard errors of weighted least squares.

    ``V = G/(G-1) B^-1 (sum_g s_g s_g^T) B^-1`` with ``B = X^T W X`` and the score of run
    ``g`` ``s_g = X_g^T W_g r_g`` (the CR1 sandwich estimator).

    Examples
    --------
    >>> X = np.ones((4, 1)); r = np.array([1.0, 1.0, -1.0, -1.0])
    >>> _cluster_stderr(X, r, np.ones(4), np.array(["a", "a", "b", "b"])).tolist()
    [1.0]
    """
    B = X.T @ (X * w[:, None])
    Binv = np.linalg.pinv(B)
    scores = pd.DataFrame(X * (w * resid)[:, None]).groupby(runs).sum().to_numpy()
    g = scores.shape[0]
    if g < 2:
        return np.full(X.shape[1], np.nan)
    meat = scores.T @ scores * (g / (g - 1))
    V = Binv @ meat @ Binv
    return np.sqrt(np.clip(np.diag(V), 0, None))


def run_folds(runs: Sequence[str], n_splits: int, seed: int = 0) -> list[list[str]]:
    """Assign whole runs to ``n_splits`` folds at random (grouped K-fold).

    Parameters
    ----------
    runs : sequence of str
        Run id of every window (repeats allowed).
    n_splits : int
        Number of folds; at most the number of distinct runs.
    seed : int
        Seed of the shuffle.

    Returns
    -------
    list of list of str
        Disjoint, sorted lists of runs, sizes differing by at most one.

    Examples
    --------
    >>> folds = run_folds(["a", "a", "b", "c", "d", "e"], 2, seed=1)
    >>> sorted(sum(folds, [])), sorted(len(f) for f in folds)
    (['a', 'b', 'c', 'd', 'e'], [2, 3])
    """
    uniq = np.array(sorted({str(r) for r in runs}))
    if not 2 <= n_splits <= len(uniq):
        raise FitError(
            f"cannot split {len(uniq)} run(s) into {n_splits} folds: need 2 <= folds <= runs"
        )
    perm = np.random.default_rng(seed).permutation(len(uniq))
    return [sorted(map(str, part)) for part in np.array_split(uniq[perm], n_splits)]


def _check_amount(n_windows: int, n_runs: int, k: int, names: list[str]) -> None:
    need_w = MIN_WINDOWS_PER_TERM * k
    if n_windows < need_w or n_runs < MIN_RUNS:
        raise FitError(
            f"too little data to fit {k} terms ({', '.join(names)}): got {n_windows} windows "
            f"from {n_runs} run(s); need at least {need_w} windows ({MIN_WINDOWS_PER_TERM} "
            f"per term) from at least {MIN_RUNS} runs (to validate on held-out runs). "
            "Record more runs or use shorter windows (--window)"
        )


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
) -> CrossValidation:
    """Validate a model's terms by run: refit on some runs, predict the others.

    Parameters
    ----------
    model_or_terms : EnergyModel, sequence of term specs, or None
        The terms to validate (a model's coefficients are ignored: each fold refits
        them); None means the base model.
    windows : Windows
        Measurements contract: ``samples`` and ``table``.
    n_splits : int
        Number of folds; reduced to the number of runs (leave-one-run-out) when there
        are fewer runs, with a warning.
    seed : int
        Seed of the random assignment of runs to folds.

    Returns
    -------
    CrossValidation

    Raises
    ------
    FitError
        Fewer than two runs, or missing columns.
    """
    model = _as_model(model_or_terms)
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
    folds = run_folds(runs, n_splits, seed)
    names = model.term_names
    D = model.design_matrix(model_features(samples, model))  # per sample
    win = samples["window"].to_numpy()
    X = pd.DataFrame(D).groupby(win, sort=True).mean().to_numpy()
    y = table["power"].to_numpy(float)
    w = table["duration"].to_numpy(float)
    sample_run = samples["run"].astype(str).to_numpy()

    run_to_fold = {r: i for i, fold in enumerate(folds) for r in fold}
    fold_of_window = pd.Series(runs).map(run_to_fold).to_numpy(int)
    fold_of_sample = pd.Series(sample_run).map(run_to_fold).to_numpy(int)
    pred_sample = np.full(len(samples), np.nan)
    coefs = []
    for i, test_runs in enumerate(folds):
        test = fold_of_window == i
        train = ~test
        beta = _wls(X[train], y[train], w[train])
        unsupported = [
            names[j]
            for j in range(len(names))
            if not np.any(np.abs(X[train, j]) > 1e-12) and np.any(np.abs(X[test, j]) > 1e-12)
        ]
        if unsupported:
            warnings.append(
                f"fold {i}: no training window exercises {', '.join(unsupported)} (all such "
                f"runs are held out: {', '.join(test_runs)}); this fold predicts them as 0"
            )
        coefs.append(beta)
        smask = fold_of_sample == i
        p = D[smask] @ beta
        pred_sample[smask] = p if model.regenerative else np.maximum(p, 0.0)

    pred_w = pd.Series(pred_sample).groupby(win, sort=True).mean().to_numpy()
    resid = pred_w - y
    rmse = float(np.sqrt(np.mean(resid**2)))
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
    return CrossValidation(
        n_splits=n_splits,
        seed=seed,
        folds=folds,
        windows=per_window.drop(columns=["measured_j", "predicted_j"]),
        runs=per_run,
        fold_coefficients=pd.DataFrame(coefs, columns=names).rename_axis("fold"),
        rmse_w=rmse,
        mae_w=mae,
        r2=r2,
        energy_mean_abs_rel=float(np.mean(np.abs(rel))) if rel.size else float("nan"),
        energy_max_abs_rel=float(np.max(np.abs(rel))) if rel.size else float("nan"),
        energy_total_rel=total_rel,
        warnings=warnings,
    )


def fit_model(
    windows: Any,
    terms: EnergyModel | Sequence[str | Term] | None = None,
    *,
    n_splits: int = 5,
    seed: int = 0,
    metadata: dict[str, Any] | None = None,
) -> FitResult:
    """Fit all terms of a model jointly on all windows and validate it by run.

    Parameters
    ----------
    windows : Windows
        Measurements contract: ``samples`` (per sample, with ``window``) and ``table``
        (per window, with ``run``, ``duration``, ``power``, ``alpha``, ``motion``...).
    terms : EnergyModel, sequence of term specs, or None
        What to fit: a model (its terms; coefficients ignored), catalog names and
        formulas, or None for the paper's base model.
    n_splits : int
        Folds of the by-run cross-validation; 0 skips it.
    seed : int
        Seed of the assignment of runs to folds.
    metadata : dict, optional
        Stored in the model's ``metadata`` (with the data counts and held-out errors).

    Returns
    -------
    FitResult

    Raises
    ------
    FitError
        Too little data (names the counts and what is needed), a term the data never
        exercises, or terms the data cannot tell apart (names them).
    ModelError
        A term needs a channel the logs do not have.
    """
    model = _as_model(terms)
    table = aligned_table(windows)
    samples = windows.samples
    names = model.term_names
    n_windows = len(table)
    n_runs = int(table["run"].nunique())
    _check_amount(n_windows, n_runs, len(names), names)

    feats = model_features(samples, model)
    groups = samples["window"].to_numpy()
    X = model.design_matrix(feats, groups=groups)
    y = table["power"].to_numpy(float)
    w = table["duration"].to_numpy(float)
    if not np.all(np.isfinite(w)) or np.any(w <= 0):
        raise FitError("window durations must be positive and finite (windows.table.duration)")
    # a motion's terms need windows of that motion: sensor noise alone (a few mm/s of
    # vx while walking sideways) would otherwise "fit" a backward force
    kind_counts = table["kind"].value_counts()
    for kind in ("forward", "backward", "lateral", "turning"):
        kind_terms = [t.name for t in model.terms if t.kind == kind]
        n_kind = int(kind_counts.get(kind, 0))
        if kind_terms and n_kind < MIN_WINDOWS_PER_TERM:
            raise FitError(
                f"the data has {n_kind} {kind} window(s) (of {n_windows} windows from "
                f"{n_runs} runs), too few for term(s) {', '.join(kind_terms)}; need at least "
                f"{MIN_WINDOWS_PER_TERM}: record {kind} runs, or fit a model without these "
                "terms"
            )
    zero = [names[j] for j in range(len(names)) if not np.any(np.abs(X[:, j]) > 1e-12)]
    if zero:
        raise FitError(
            f"the data never exercises term(s) {', '.join(zero)}: they are zero on all "
            f"{n_windows} windows from {n_runs} runs; record runs where they vary, or fit a "
            "model without them"
        )
    vif = _vif(X, w)
    warnings = _support_warnings(model, X, w, table, vif)
    try:
        model.fit(feats, y, groups=groups, sample_weight=w)
    except FitError as exc:
        raise FitError(f"{exc} ({n_windows} windows from {n_runs} runs)") from exc
    beta = model.coef_array()
    resid = X @ beta - y
    rms = float(np.sqrt(np.sum(w * resid**2) / np.sum(w)))
    Xs = X * np.sqrt(w)[:, None]
    Xs = Xs / np.linalg.norm(Xs, axis=0)
    cond = float(np.linalg.cond(Xs))

    se_run = _cluster_stderr(X, resid, w, table["run"].astype(str).to_numpy())
    heldout = None
    if n_splits:
        heldout = cross_validate(model, windows, n_splits=n_splits, seed=seed)
        warnings += heldout.warnings
    model.metadata = {
        **model.metadata,
        **(metadata or {}),
        "fit": {
            "method": "joint weighted least squares on window means (weights: duration)",
            "n_windows": n_windows,
            "n_runs": n_runs,
            "residual_rms_w": round(rms, 3),
            "stderr_by_run": {n: float(f"{v:.3g}") for n, v in zip(names, se_run, strict=True)},
            **(
                {}
                if heldout is None
                else {
                    "heldout_power_rmse_w": round(heldout.rmse_w, 3),
                    "heldout_energy_mean_abs_rel_error": round(heldout.energy_mean_abs_rel, 5),
                    "n_splits": heldout.n_splits,
                }
            ),
        },
    }
    return FitResult(
        model=model,
        coefficients=dict(model.coefficients or {}),
        stderr=dict(model.stderr or {}),
        n_windows=n_windows,
        n_runs=n_runs,
        heldout=heldout,
        warnings=warnings,
        residual_rms_w=rms,
        condition_number=cond,
        vif=dict(zip(names, map(float, vif), strict=True)),
        coverage=_coverage(table),
        stderr_by_run=dict(zip(names, map(float, se_run), strict=True)),
    )
