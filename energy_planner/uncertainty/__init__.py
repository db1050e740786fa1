r"""Prediction intervals on energies and the chance that a battery suffices.

A fitted model predicts a run's energy ``E``; on runs it was not fitted on, its error
``r = E / E_true - 1`` scatters. The fit's cross-validation by run
(:func:`energy_planner.calibration.fit.cross_validate`) records every held-out run's ``r``
in the model (``metadata["fit"]["heldout_run_rel_errors"]``). Those are the scores of a
**split-conformal** interval: with ``n`` held-out scores and level ``L``, the conformal
quantiles of ``r`` (the ``ceil((n + 1) p) / n`` order statistics) bound the error of a new
run drawn like the calibration's runs with probability at least ``L``, by construction, and
the interval on the true energy is

.. math:: E_\text{true} \in [E / (1 + r_\text{hi}),\; E / (1 + r_\text{lo})].

The same scores give the whole predictive distribution, so the chance that the true energy
fits in a usable battery energy ``U`` is the share of scores with ``E / (1 + r) <= U``
(:func:`success_probability`).

Outside the calibration's domain (:mod:`energy_planner.uncertainty.domain`): a path that
goes beyond a numeric range (slope, speed, a numeric channel) is widened by the growth of
the error the fit measured by holding out its most extreme runs
(:class:`~energy_planner.uncertainty.errormodel.ErrorModel`, ``extrapolation``), given the
path's domain report (``domain=``, :func:`path_domain`); what no measured growth covers is
*not calibrated*: the interval says so and :func:`battery_decision` refuses to decide on
it. So is a path whose predicted mean power lies above (or below) every calibration
run's (each quantity may be inside its range while their combination, heavy and steep
uphill, is not): the report counts it as the quantity ``mean_power``, whose growth is
never measured. :func:`path_trust` gives a path's interval, domain and battery decision
at once, as every door reports them. A path far longer than the calibration's runs makes
the interval conservative (errors that average out). A model without held-out scores (an
old file, or ``fit --folds 0``) has no interval: ``None``, said so.

Examples
--------
>>> rng = np.random.default_rng(0)
>>> scores = np.sort(rng.normal(0.0, 0.02, 500))
>>> iv = interval(1000.0, scores, level=0.9)
>>> bool(iv.low_j < 1000.0 < iv.high_j), iv.level
(True, 0.9)
>>> round(success_probability(1000.0, scores, usable_j=1000.0), 1)
0.5
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from energy_planner.errors import EnergyPlannerError
from energy_planner.trust import Assessment
from energy_planner.uncertainty.domain import domain_report, path_domain, stay_in_domain
from energy_planner.uncertainty.errormodel import ErrorModel

__all__ = [
    "DEFAULT_LEVEL",
    "BatteryDecision",
    "EnergyInterval",
    "ErrorModel",
    "ExtrapolationError",
    "PathTrust",
    "battery_decision",
    "conformal_bounds",
    "confident_budget",
    "interval",
    "domain_report",
    "model_error_model",
    "model_scores",
    "path_domain",
    "path_trust",
    "predict_interval",
    "stay_in_domain",
    "success_probability",
]

#: Default level of prediction intervals.
DEFAULT_LEVEL = 0.9


class BatteryError(EnergyPlannerError, ValueError):
    """A battery's chance of getting through is below the required confidence."""


class ExtrapolationError(BatteryError):
    """No battery decision: part of the path lies where the error growth was not measured."""


@dataclass(frozen=True)
class EnergyInterval:
    """A predicted energy with its prediction interval.

    Attributes
    ----------
    energy_j : float
        The model's prediction, J.
    low_j, high_j : float
        The interval's bounds, J.
    level : float
        Its nominal coverage (0.9: 90 %).
    n_scores : int
        Held-out runs it was calibrated on.
    method : str
        How it was computed.
    not_calibrated : tuple of str
        Empty when the whole interval is calibrated; else ``"quantity: why"`` for each
        range the path leaves where the fit could not measure how the error grows (the
        bounds there rest on an assumed widening).
    """

    energy_j: float
    low_j: float
    high_j: float
    level: float = DEFAULT_LEVEL
    n_scores: int = 0
    method: str = "split-conformal on held-out run energies"
    not_calibrated: tuple[str, ...] = ()

    @property
    def calibrated(self) -> bool:
        """True unless part of the path lies where the error growth was not measured."""
        return not self.not_calibrated

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields (J and Wh)."""
        return {
            "energy_j": self.energy_j,
            "low_j": self.low_j,
            "high_j": self.high_j,
            "low_wh": self.low_j / 3600.0,
            "high_wh": self.high_j / 3600.0,
            "level": self.level,
            "calibrated_on_runs": self.n_scores,
            "method": self.method,
            "calibrated": self.calibrated,
            "not_calibrated": list(self.not_calibrated),
        }

    def text(self) -> str:
        """``"[a .. b] J (90 %)"``, and ``NOT calibrated ...`` when it is not."""
        t = f"[{self.low_j:.0f} .. {self.high_j:.0f}] J ({100 * self.level:g} %)"
        if self.not_calibrated:
            t += " NOT calibrated beyond the logs' ranges (" + "; ".join(self.not_calibrated) + ")"
        return t


def model_scores(model: Any) -> np.ndarray | None:
    """The held-out relative run-energy errors a model carries (sorted), or None."""
    fit = (getattr(model, "metadata", None) or {}).get("fit") or {}
    s = fit.get("heldout_run_rel_errors")
    if not s:
        return None
    a = np.sort(np.asarray(s, dtype=float))
    a = a[np.isfinite(a) & (a > -1.0)]
    return a if a.size else None


def _conformal(scores: np.ndarray, p: float) -> float:
    """The conformal ``p`` quantile: order statistic ``ceil((n + 1) p)`` (1-based), clipped."""
    n = scores.size
    k = math.ceil((n + 1) * p)
    return float(scores[min(max(k, 1), n) - 1])


def interval(energy_j: float, scores: np.ndarray, level: float = DEFAULT_LEVEL) -> EnergyInterval:
    """The split-conformal interval of a predicted energy from held-out scores.

    Parameters
    ----------
    energy_j : float
        Predicted energy, J.
    scores : ndarray
        Held-out ``predicted / measured - 1`` of runs (any order).
    level : float
        Nominal coverage, in (0, 1).

    Returns
    -------
    EnergyInterval
    """
    r_lo, r_hi = conformal_bounds(scores, level)
    return EnergyInterval(float(energy_j), float(energy_j) / (1.0 + r_hi),
                          float(energy_j) / (1.0 + r_lo), float(level),
                          int(np.size(scores)))  # fmt: skip


def conformal_bounds(scores: Any, level: float = DEFAULT_LEVEL) -> tuple[float, float]:
    """The split-conformal ``(low, high)`` order statistics of held-out scores at ``level``.

    With ``n`` scores and ``a = (1 - level) / 2``: the ``floor((n + 1) a)``-th smallest
    and the ``ceil((n + 1) (1 - a))``-th smallest (1-based, clipped to 1..n). A new score
    exchangeable with them falls below the ``k``-th smallest of ``n`` with probability
    ``k / (n + 1)``, so it lies between the two with probability at least ``level``
    (when neither is clipped).

    Examples
    --------
    >>> conformal_bounds(np.arange(1.0, 20.0), 0.9)
    (1.0, 19.0)
    """
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must be in (0, 1), not {level!r}")
    s = np.sort(np.asarray(scores, dtype=float))
    a = (1.0 - level) / 2.0
    return float(s[max(math.floor((s.size + 1) * a), 1) - 1]), _conformal(s, 1.0 - a)


#: Without an error model (a model fitted before it was recorded) the held-out relative
#: scores are scaled by ``1 + OUTSIDE_WIDENING * share`` outside the calibration's domain:
#: a stated assumption, not a calibrated one.
OUTSIDE_WIDENING = 1.0


def model_error_model(model: Any) -> ErrorModel | None:
    """The run-to-run error model a fit recorded (``metadata.fit.error_model``), or None."""
    d = ((getattr(model, "metadata", None) or {}).get("fit") or {}).get("error_model")
    return None if not d else ErrorModel.from_dict(d)


def _outside(model: Any, em: ErrorModel | None, outside_share: float,
             domain: Any) -> Any:  # fmt: skip
    """The :class:`~energy_planner.uncertainty.errormodel.Outside` of a prediction.

    With a domain report: what the fit's measured growth covers, and the rest; with only a
    share: all of it by the share (not calibrated unless the error model fitted ``d``).
    """
    from energy_planner.uncertainty.errormodel import Outside, power_outside

    if domain is not None:
        if em is not None:
            return em.outside(domain)
        share = float(domain.get("outside_share") or 0.0)
        return Outside(0.0, share, (), ("the model records no error model",) if share else (),
                       *power_outside(domain))  # fmt: skip
    share = float(outside_share or 0.0)
    loose = ("a share outside given without the path's domain report",) if share > 0 else ()
    return Outside(0.0, share, (), loose)


def _not_calibrated(em: ErrorModel | None, out: Any) -> tuple[str, ...]:
    """The quantities outside where the interval rests on an assumption.

    Those without a measured growth when ``d`` was not fitted, and a mean power beyond
    every calibration run's whatever ``d`` is (:meth:`ErrorModel.outside`).
    """
    loose: tuple[str, ...] = ()
    if out.share > 0 and (em is None or em.outside_rel_var is None):
        loose = tuple(out.not_measured)
    if out.assumed_share > 0:
        loose += tuple(out.assumed)
    return loose


def predict_interval(
    model: Any,
    energy_j: float,
    level: float = DEFAULT_LEVEL,
    outside_share: float = 0.0,
    duration_s: float | None = None,
    *,
    domain: Mapping[str, Any] | None = None,
) -> EnergyInterval | None:
    """The interval of ``energy_j`` predicted by ``model``, or None if it carries no scores.

    With the fit's error model (:mod:`energy_planner.uncertainty.errormodel`): the scale
    ``sigma(E, T, outside)`` times the split-conformal bounds of the normalized held-out
    scores; ``duration_s`` is the path's duration (default: the energy over the held-out
    runs' mean power). ``domain``, the path's domain report (:func:`path_domain`,
    :func:`domain_report`), widens it by the growth of the error the fit measured beyond
    each numeric range, for the distance the path goes beyond it; what no measured
    growth covers widens it by its share (the fitted ``d``, or the assumed ``1 + share``,
    then ``not_calibrated`` names it); a predicted mean power beyond every calibration
    run's (the report's ``mean_power`` share) widens it by the assumed ``1 + share``
    whatever ``d`` is, and ``not_calibrated`` names it. ``outside_share`` (0-1) without
    a report: all of it by the share. Without an error model (older model files): the
    relative held-out scores ``r``, each scaled by ``1 + OUTSIDE_WIDENING * share`` (kept
    above -0.9), not calibrated outside.

    Examples
    --------
    >>> from energy_planner.model import EnergyModel
    >>> em = ErrorModel(0.0, 1e-4, 0.0, None, np.linspace(-1.645, 1.645, 199), 100.0,
    ...                 extrapolation={"slope": {"growth_per_unit": 0.01}})
    >>> m = EnergyModel(["idle_power"], {"idle_power": 100.0},
    ...                 metadata={"fit": {"error_model": em.to_dict()}})
    >>> dom = {"shares": {"slope": 0.5}, "excess": {"slope": 3.0}}  # 3 deg beyond on average
    >>> iv = predict_interval(m, 1000.0, domain=dom)  # sigma = 1000 sqrt(1e-4 + 0.03^2) J
    >>> round(float((iv.high_j - 1000.0) / (1000.0 * np.sqrt(1e-4 + 0.03**2))), 3), iv.calibrated
    (1.512, True)
    """
    em = model_error_model(model)
    out = _outside(model, em, outside_share, domain)
    loose = _not_calibrated(em, out)
    if em is not None:
        lo, hi = em.bounds(float(energy_j), level, duration_s, out.share, out.extra_rel_var,
                           out.assumed_share)  # fmt: skip
        how = _EM_METHOD + (_SMALL if em.small_sample(level) else "")
        if out.measured:
            how += "; beyond the range of " + ", ".join(out.measured) + " by the measured growth"
        return EnergyInterval(float(energy_j), lo, hi, float(level), int(em.scores.size),
                              method=how, not_calibrated=loose)  # fmt: skip
    s = model_scores(model)
    if s is None:
        return None
    if out.share > 0:
        s = np.maximum(s * (1.0 + OUTSIDE_WIDENING * float(out.share)), -0.9)
    iv = interval(energy_j, s, level)
    return EnergyInterval(iv.energy_j, iv.low_j, iv.high_j, iv.level, iv.n_scores, iv.method,
                          loose)  # fmt: skip


_SMALL = "; too few runs for conformal bounds: Student-t bounds of the normalized errors"
_EM_METHOD = ("split-conformal on held-out runs' errors normalized by the fitted error "
              "scale sigma(energy, duration, share outside the domain)")  # fmt: skip


def success_probability(energy_j: float, scores: np.ndarray, usable_j: float) -> float:
    """Chance that the true energy of a run predicted at ``energy_j`` is at most ``usable_j``.

    The share of held-out scores ``r`` with ``energy_j / (1 + r) <= usable_j`` (with the
    conformal ``+1`` in the count, so that it is never 1 from a finite sample).
    """
    s = np.asarray(scores, dtype=float)
    if usable_j <= 0:
        return 0.0
    ok = int(np.count_nonzero(energy_j / (1.0 + s) <= usable_j))
    return ok / (s.size + 1)


@dataclass(frozen=True)
class BatteryDecision:
    """Whether a route fits in a battery: the chance, and the verdict at a confidence."""

    battery_wh: float
    reserve_wh: float
    usable_j: float
    probability: float
    confidence: float

    @property
    def ok(self) -> bool:
        """The chance reaches the confidence."""
        return self.probability >= self.confidence

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields."""
        return {"battery_wh": self.battery_wh, "reserve_wh": self.reserve_wh,
                "usable_wh": self.usable_j / 3600.0, "probability": self.probability,
                "confidence": self.confidence, "ok": self.ok}  # fmt: skip

    def text(self) -> str:
        """One line for people."""
        verdict = "OK" if self.ok else "BELOW the required confidence"
        return (f"battery      {100 * self.probability:.1f} % chance the route fits in "
                f"{self.usable_j / 3600:.1f} Wh usable ({self.battery_wh:g} Wh - "
                f"{self.reserve_wh:g} Wh reserve): {verdict} "
                f"({100 * self.confidence:g} % required)")  # fmt: skip


def battery_decision(
    model: Any, energy_j: float, battery_wh: float, reserve_wh: float = 0.0,
    confidence: float = DEFAULT_LEVEL, duration_s: float | None = None,
    outside_share: float = 0.0, *, domain: Mapping[str, Any] | None = None,
) -> BatteryDecision:  # fmt: skip
    """The chance that a route predicted at ``energy_j`` fits in a battery.

    From the same predictive distribution as :func:`predict_interval` (the fit's error
    model with the route's ``duration_s`` and its ``domain`` report or ``outside_share``
    when the model has one, else the relative held-out scores).

    Raises
    ------
    BatteryError
        The model carries no held-out scores (refit it with cross-validation), or the
        reserve is not below the battery.
    ExtrapolationError
        Part of the route lies beyond the calibration's ranges where the fit could not
        measure how its error grows: no chance is given there (names the quantities).
    """
    if not reserve_wh < battery_wh:
        raise BatteryError(f"the reserve ({reserve_wh:g} Wh) must be below the battery "
                           f"({battery_wh:g} Wh)", value=reserve_wh)  # fmt: skip
    usable = (battery_wh - reserve_wh) * 3600.0
    em = model_error_model(model)
    out = _outside(model, em, outside_share, domain)
    loose = _not_calibrated(em, out)
    if loose:
        share = max(out.share, out.assumed_share)
        inside = ("refit on logs that cover it" if out.assumed_share > 0 else
                  "keep the route inside (plan --stay-in-domain) or refit on logs that "
                  "cover it")  # fmt: skip
        raise ExtrapolationError(
            f"no battery decision: {100 * share:.0f} % of the route lies outside the "
            "calibration's ranges where the fit could not measure how the error grows ("
            + "; ".join(loose)
            + f"); {inside}",
            value=share,
        )
    if em is not None:
        p = em.probability(float(energy_j), usable, duration_s, out.share, out.extra_rel_var,
                           out.assumed_share)  # fmt: skip
        return BatteryDecision(float(battery_wh), float(reserve_wh), usable, p,
                               float(confidence))  # fmt: skip
    s = model_scores(model)
    if s is None:
        raise BatteryError(
            "the model carries no held-out run errors, so it cannot give the chance that a "
            "battery suffices: refit it with cross-validation (energy-planner fit --folds 5)"
        )
    return BatteryDecision(float(battery_wh), float(reserve_wh), usable,
                           success_probability(energy_j, s, usable), float(confidence))  # fmt: skip


#: What :func:`path_trust` returns: the one record of a path's interval, domain and
#: battery decision (or why it was refused), the assessment every result carries.
PathTrust = Assessment


def path_trust(
    model: Any,
    energy_j: float,
    duration_s: float | None = None,
    domain: Mapping[str, Any] | None = None,
    *,
    level: float = DEFAULT_LEVEL,
    battery_wh: float | None = None,
    reserve_wh: float = 0.0,
    confidence: float = DEFAULT_LEVEL,
) -> PathTrust:
    """A path's interval, its domain and, given a battery, the chance it suffices.

    The one combination of :func:`predict_interval` and :func:`battery_decision` with the
    path's domain report (:func:`path_domain`) that every door uses (``energy``,
    ``plan`` and the result objects): the same ``duration_s`` and ``domain`` go into
    both. A battery decision beyond the ranges where the error growth was not measured
    is refused (``battery_refused`` says why) rather than given with false confidence.

    Raises
    ------
    BatteryError
        A battery is given but the model carries no held-out scores, or the reserve is
        not below the battery.
    """
    iv = predict_interval(model, energy_j, level, duration_s=duration_s, domain=domain or {})
    dom = None if domain is None else dict(domain)
    if battery_wh is None:
        return PathTrust(iv, dom)
    try:
        d = battery_decision(model, energy_j, battery_wh, reserve_wh, confidence, duration_s,
                             domain=domain or {})  # fmt: skip
    except ExtrapolationError as exc:
        return PathTrust(iv, dom, None, str(exc))
    return PathTrust(iv, dom, d)


def confident_budget(model_or_scores: Any, usable_j: float, confidence: float) -> float:
    """The largest predicted energy whose chance of fitting in ``usable_j`` is >= ``confidence``.

    :func:`success_probability` falls with the predicted energy ``E``: it is at least ``p``
    when at least ``k = ceil(p (n + 1))`` scores ``r`` have ``E / (1 + r) <= U``, that is
    when ``E <= U (1 + r_(n-k+1))`` with ``r_(n-k+1)`` the ``k``-th largest score. So the
    cells reachable with chance ``p`` are those whose predicted energy is at most this
    budget (0 when ``p`` needs more scores than there are).

    Examples
    --------
    >>> s = np.linspace(-0.1, 0.1, 99)
    >>> b = confident_budget(s, 1000.0, 0.9)
    >>> success_probability(b, s, 1000.0) >= 0.9 > success_probability(b * 1.001, s, 1000.0)
    True
    """
    s = model_or_scores
    if not isinstance(s, np.ndarray):
        s = model_scores(model_or_scores)
        if s is None:
            raise BatteryError(
                "the model carries no held-out run errors, so it cannot give the chance that "
                "a battery suffices: refit it with cross-validation (energy-planner fit --folds 5)"
            )
    s = np.sort(np.asarray(s, dtype=float))
    k = math.ceil(confidence * (s.size + 1))
    if k > s.size:
        return 0.0
    return float(usable_j * (1.0 + s[s.size - k]))
