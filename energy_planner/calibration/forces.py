"""The paper's calibration: per-window force estimates and a compact fit per motion.

Section IV of the paper recovers the wrench from onboard signals only: over short
windows of a straight run the force-equivalent cost is ``F = P / v`` (N, i.e. J per
metre), over a turn in place the yaw torque is ``tau = P / |w|`` (N m). Indexed by slope
``alpha`` and heading, these estimates are the dataset of Fig. 4 and Fig. 5.

:func:`force_estimates` computes them; :func:`fit_forces` then fits each force as a
compact function of ``(alpha, gamma)``: for every kind of motion, the base terms of that
kind divided by the motion's rate (``pos(vx) * sin(alpha) * cos(gamma) / v`` is
``sin(alpha) * cos(gamma)`` on a forward window), by least squares on the windows of
that motion only. The result is a base :class:`~energy_planner.model.EnergyModel`, the
paper's way; :func:`energy_planner.calibration.fit.fit_model` fits all terms jointly on
all windows instead (and can add effects the per-motion forces cannot express).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from energy_planner.calibration._windows import STRAIGHT_KINDS, aligned_table, heading_class
from energy_planner.calibration.fit import base_terms, model_features
from energy_planner.errors import FitError
from energy_planner.model import EnergyModel, Term
from energy_planner.stats import independent_columns, wls

__all__ = ["ForceFit", "force_estimates", "fit_forces", "MOTION_KINDS"]

#: Kinds of motion that have a force (the base terms' kinds).
MOTION_KINDS = ("forward", "backward", "lateral", "turning")


def _rates(samples: pd.DataFrame) -> pd.DataFrame:
    """Per-window mean speed (m/s) and mean |yaw rate| (rad/s), sorted by window id."""
    speed = np.hypot(samples["vx"].to_numpy(float), samples["vy"].to_numpy(float))
    df = pd.DataFrame(
        {"speed": speed, "yaw_rate": np.abs(samples["wz"].to_numpy(float))},
        index=samples.index,
    )
    return df.groupby(samples["window"].to_numpy(), sort=True).mean()


def force_estimates(windows: Any, *, level_deg: float = 2.0) -> pd.DataFrame:
    """Per-window force (straight motion, N) and yaw-torque (turn in place, N m) estimates.

    Parameters
    ----------
    windows : Windows
        Measurements contract (``samples`` and ``table``).
    level_deg : float
        Slopes below this count as ``level`` in the heading class.

    Returns
    -------
    pandas.DataFrame
        One row per window of a pure motion (mixed windows are left out): run, window,
        motion, kind (forward/backward/lateral/turning), heading (uphill, downhill,
        cross, oblique, level; ``in place`` for turns), alpha, alpha_deg, gamma, climb,
        rate (m/s or rad/s), power (W), value (``P / rate``), unit (N or N m), duration.
    """
    table = aligned_table(windows)
    rates = _rates(windows.samples).reindex(table["window"].to_numpy())
    straight = table["kind"].isin(STRAIGHT_KINDS).to_numpy()
    turning = (table["kind"] == "turning").to_numpy()
    rate = np.where(straight, rates["speed"].to_numpy(), rates["yaw_rate"].to_numpy())
    keep = (straight | turning) & (rate > 0)
    heading = heading_class(
        table["alpha"].to_numpy(float), table["climb"].to_numpy(float), level_deg=level_deg
    )
    out = pd.DataFrame(
        {
            "run": table["run"].to_numpy(),
            "window": table["window"].to_numpy(),
            "motion": table["motion"].to_numpy(),
            "kind": table["kind"].to_numpy(),
            "heading": np.where(turning, "in place", heading),
            "alpha": table["alpha"].to_numpy(float),
            "alpha_deg": np.degrees(table["alpha"].to_numpy(float)),
            "gamma": table["gamma"].to_numpy(float),
            "climb": table["climb"].to_numpy(float),
            "rate": rate,
            "power": table["power"].to_numpy(float),
            "duration": table["duration"].to_numpy(float),
            "unit": np.where(turning, "N m", "N"),
        }
    )[keep]
    out.insert(out.columns.get_loc("power") + 1, "value", out["power"] / out["rate"])
    return out.reset_index(drop=True)


@dataclass
class ForceFit:
    """Per-motion force fits (the paper's calibration).

    Attributes
    ----------
    model : EnergyModel
        The base model assembled from the per-motion fits.
    coefficients, stderr : dict
        Term name -> coefficient (N or N m) and standard error.
    estimates : pandas.DataFrame
        The per-window estimates (see :func:`force_estimates`) with the fitted value
        ``fitted`` and the residual ``residual``.
    per_kind : pandas.DataFrame
        kind, unit, windows, runs, rms_residual (N or N m), max_alpha_deg.
    """

    model: EnergyModel
    coefficients: dict[str, float]
    stderr: dict[str, float]
    estimates: pd.DataFrame
    per_kind: pd.DataFrame

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary."""
        return {
            "coefficients": self.coefficients,
            "stderr": self.stderr,
            "per_kind": self.per_kind.to_dict(orient="records"),
        }


def fit_forces(
    windows: Any, terms: Sequence[str | Term] | None = None, *, level_deg: float = 2.0
) -> ForceFit:
    """Fit each motion's force as a compact function of slope and heading.

    For every motion kind, the force estimates ``P / rate`` of its windows are regressed
    (least squares weighted by window duration) on that kind's terms divided by the
    window's rate, i.e. on the terms' basis functions of ``(alpha, gamma)``. Terms of no
    single motion (kind ``other``: ``idle_power``, the per-second holding terms) are taken
    from the joint fit (:func:`energy_planner.calibration.fit.fit_model`) and subtracted,
    as a force ``P_other / rate``, before each motion's fit.

    Parameters
    ----------
    windows : Windows
        Measurements contract.
    terms : sequence of term specs, optional
        Terms to fit (default: the base model of these windows,
        :func:`energy_planner.calibration.fit.base_terms`).
    level_deg : float
        Passed to :func:`force_estimates`.

    Returns
    -------
    ForceFit

    Raises
    ------
    FitError
        A kind with fewer windows than its terms + 1 (the message names the kind and the
        counts), or a per-second term the joint fit cannot identify.
    """
    terms = list(base_terms(windows) if terms is None else terms)
    model = EnergyModel(terms)
    others = [j for j, t in enumerate(model.terms) if t.kind not in MOTION_KINDS]
    est = force_estimates(windows, level_deg=level_deg)
    table = aligned_table(windows)
    samples = windows.samples
    X = model.design_matrix(model_features(samples, model), groups=samples["window"].to_numpy())
    row = pd.Series(np.arange(len(table)), index=table["window"].to_numpy())
    idx = row.reindex(est["window"].to_numpy()).to_numpy()
    shared: dict[str, float] = {}
    shared_se: dict[str, float] = {}
    offset = np.zeros(len(est))
    if others:
        # per-second terms (idle power, holding the slope load) belong to no single
        # motion: take them from the joint fit, and fit each motion's force on the rest
        from energy_planner.calibration.fit import fit_model

        joint = fit_model(windows, model, n_splits=0)
        missing = [
            model.term_names[j] for j in others if model.term_names[j] not in joint.coefficients
        ]
        if missing:
            raise FitError(
                f"the joint fit cannot identify the per-second term(s) {', '.join(missing)} "
                "the per-motion forces need: " + "; ".join(joint.unidentified.values())
            )
        shared = {model.term_names[j]: joint.coefficients[model.term_names[j]] for j in others}
        shared_se = {n: joint.stderr[n] for n in shared}
        offset = X[idx][:, others] @ np.array(list(shared.values()))
    coef: dict[str, float] = dict(shared)
    err: dict[str, float] = dict(shared_se)
    fitted = np.full(len(est), np.nan)
    rows = []
    for kind in MOTION_KINDS:
        cols = [j for j, t in enumerate(model.terms) if t.kind == kind]
        if not cols:
            continue
        names = [model.term_names[j] for j in cols]
        sel = (est["kind"] == kind).to_numpy()
        n = int(sel.sum())
        if n < len(cols) + 1:
            raise FitError(
                f"{n} {kind} window(s) cannot fit {len(cols)} force term(s) "
                f"({', '.join(names)}); need at least {len(cols) + 1} from several slopes"
            )
        rate = est.loc[sel, "rate"].to_numpy()
        B = X[idx[sel]][:, cols] / rate[:, None]
        base_force = offset[sel] / rate  # the per-second terms, as a force at this rate
        F = est.loc[sel, "value"].to_numpy() - base_force
        w = est.loc[sel, "duration"].to_numpy()
        keep, why = independent_columns(B, w)
        if not keep.all():
            bad = [names[j] for j in why]
            raise FitError(
                f"the {kind} windows cannot separate {', '.join(bad)} from the other {kind} "
                "terms: record this motion on more slopes and headings, or fit with "
                "calibration.fit_model, which reports and leaves out such terms"
            )
        res = wls(B, F, w)
        beta, se = res.coef, res.stderr
        rms = float(np.sqrt(np.sum(w * (F - B @ beta) ** 2) / np.sum(w)))
        coef.update(zip(names, beta.tolist(), strict=True))
        err.update(zip(names, se.tolist(), strict=True))
        fitted[sel] = B @ beta + base_force
        rows.append(
            {
                "kind": kind,
                "unit": "N m" if kind == "turning" else "N",
                "windows": n,
                "runs": int(est.loc[sel, "run"].nunique()),
                "rms_residual": rms,
                "max_alpha_deg": float(est.loc[sel, "alpha_deg"].max()),
            }
        )
    est = est.assign(fitted=fitted, residual=est["value"] - fitted)
    fitted_model = EnergyModel(
        list(terms),
        {n: coef[n] for n in model.term_names},
        stderr={n: err[n] for n in model.term_names},
        metadata={"fit": {"method": "per-motion force fit (paper section IV)"}},
    )
    return ForceFit(fitted_model, coef, err, est, pd.DataFrame(rows))
