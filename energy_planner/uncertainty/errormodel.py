r"""The run-to-run error model of a fit, and its normalized split-conformal scores.

A fitted model predicts a run's energy :math:`\hat E`; on runs it was not fitted on, the
error :math:`e = \hat E - E` scatters. A held-out run's energy is the run **whole**, as a
user asks for it (``ErrorModel.scored_on == "runs"``): :math:`E` the battery energy of
every sample of the run, :math:`\hat E` its windows' prediction plus the samples cleaning
left out of every window (the speed ramps as the gait starts and stops, samples beyond the
consistency bound, windows too short), priced by the same fold's coefficients from the
pose's twist (the way the energy of a logged path is priced; the odometry's without a
pose) (:func:`energy_planner.calibration.fit.whole_run_predictions`). Windows given
without the logs they came from have no whole runs: then the windows' energies alone are
scored (``scored_on == "windows"``, also the meaning of a model file without the field),
and an error of the dropped stretches is in no score. How much the error scatters depends
on the run:

.. math::

    \sigma^2 = \underbrace{\rho^2 \hat E^2}_\text{coefficients}
             + \underbrace{b\,\hat E^2}_\text{model error}
             + \underbrace{c\,T}_\text{noise}
             + \underbrace{d\,(s \hat E)^2}_\text{outside the domain}

- :math:`\rho^2`: the fit's run-clustered coefficient covariance :math:`V` carried to the
  held-out runs' energies (each run's term energies :math:`g`, :math:`g^T V g`), pooled
  as a share of :math:`\hat E^2` (a route's term energies are not computed at planning);
- :math:`b`: a relative error that does not average out over a run (a force the model
  prices wrong costs the same share on every metre);
- :math:`c`: an error whose variance grows with the duration :math:`T` (per-window noise
  of slip, ground and sensors that partly averages out over a long run), measured from
  the held-out windows' errors within each run once the run's own relative error is
  removed (:func:`within_run_noise`): runs of one duration (a designed campaign's) cannot
  tell it from :math:`b` by their run errors, and a path far longer than them would
  otherwise be priced as if all their noise were systematic;
- :math:`d`: the extra relative error of the share :math:`s` of the run outside the
  domain its prediction had (held-out runs against the ranges of their fold's training
  runs, :func:`energy_planner.calibration.fit.heldout_outside_shares`). Fitted only
  when at least :data:`MIN_OUTSIDE_RUNS` held-out runs lie partly outside and as many
  wholly inside (else :math:`d` and :math:`b` cannot be told apart); otherwise the
  interval is widened by the assumed factor :math:`1 + s` and the model says so.

Beyond a numeric range (slope, speed, a numeric channel) the share is replaced by how far
the path goes: the fit holds out its most extreme runs of each range, refits on the rest
and measures how the relative run-energy error grows with the mean distance ``u`` beyond
the range (:func:`energy_planner.calibration.fit.extrapolation_growth`, stored here as
``extrapolation``). A path ``u_q`` beyond range ``q`` adds

.. math:: \hat E^2 \sum_q (g_q u_q)^2

to :math:`\sigma^2` (:meth:`ErrorModel.outside`). Only what no growth covers (a range whose
growth could not be measured, a gait, heading or category the logs lack) goes by the share
:math:`s`; without a fitted :math:`d` that part is *not calibrated*: the interval says so
and no battery decision is given on it.

:math:`b, d \ge 0` (and :math:`c` when no windows are given) are fitted on the held-out
runs' squared errors net of :math:`c\,T` (non-negative least squares, weighted by
:math:`1/\sigma^4`, three passes). Distance is not an input: at the
calibration's speeds it is the duration times a nearly constant speed, so it adds a
column collinear with :math:`T`.

Conformal step: each held-out run's **normalized score** :math:`z = e / \sigma` uses a
:math:`\sigma` fitted on the *other* folds' runs (cross-fitting, so that no run scales its
own error), and the interval of a new prediction is

.. math:: E \in [\hat E - z_{hi}\,\sigma,\; \hat E - z_{lo}\,\sigma]

with :math:`z_{lo}, z_{hi}` the split-conformal order statistics of the scores at level
:math:`L` (:func:`energy_planner.uncertainty.conformal_bounds`). With too few scores for
that level (fewer than 19 at 90 %: the conformal bound would be infinite) the scores are
taken as normal and the Student-t prediction interval of a new draw is used instead
(:meth:`ErrorModel.small_sample`); the interval says which. A path walked twice gets
:math:`\hat E` and :math:`T` doubled: its interval is wider in joules (by a factor between
:math:`\sqrt 2` and 2) and no wider relative to its energy (narrower when the noise term
matters), because independent per-window noise partly cancels and a systematic error
does not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from energy_planner.uncertainty.domain import MEAN_POWER, POWER_HOW

__all__ = [
    "MIN_OUTSIDE_RUNS",
    "ErrorModel",
    "Outside",
    "OutsideCells",
    "fit_error_model",
    "outside_cells",
    "within_run_noise",
]

#: Held-out runs partly outside their fold's domain needed to fit the outside term.
MIN_OUTSIDE_RUNS = 5
#: The assumed widening outside the domain when it cannot be fitted: sigma * (1 + share).
ASSUMED_OUTSIDE_FACTOR = 1.0
#: Floor of sigma relative to the energy (a degenerate fit never gives a zero interval).
MIN_REL_SIGMA = 1e-3


@dataclass(frozen=True)
class ErrorModel:
    r"""The run-to-run error scale of a fit and its normalized conformal scores.

    Attributes
    ----------
    param_rel_var : float
        :math:`\rho^2`, the coefficients' covariance as a share of :math:`\hat E^2`.
    model_rel_var : float
        :math:`b`, relative variance that does not average out.
    noise_j2_per_s : float
        :math:`c`, variance growing with duration, J^2/s.
    outside_rel_var : float or None
        :math:`d`; None: not calibrated (too few held-out runs outside), the assumed
        factor ``1 + share`` applies.
    scores : ndarray
        Sorted normalized held-out errors ``(predicted - measured) / sigma``.
    mean_power_w : float
        Mean power of the held-out runs (their energy over their duration): the duration
        assumed for an energy given without one.
    n_outside : int
        Held-out runs partly outside their fold's domain.
    cross_fitted : bool
        True when each score's sigma was fitted without its run's fold.
    extrapolation : dict
        Per numeric quantity of the domain (``slope``, ``speed``, ``channel NAME``) the
        measured growth of the relative error beyond its range (``growth_per_unit``) or
        why it could not be measured
        (:func:`energy_planner.calibration.fit.extrapolation_growth`); empty for a model
        fitted before it was recorded.
    scored_on : str
        What a held-out run's energy was: ``"runs"``, the run whole (the battery energy
        of every sample against its windows' prediction plus the samples cleaning left
        out of every window, priced by the same fold's coefficients); ``"windows"``, its
        windows only (the calibration had no whole runs: windows given without the logs
        they came from, or a model saved before whole runs were scored). Scored on
        windows, an error of the stretches cleaning drops (the speed ramps as the gait
        starts and stops) is in no score.
    """

    param_rel_var: float
    model_rel_var: float
    noise_j2_per_s: float
    outside_rel_var: float | None
    scores: np.ndarray = field(repr=False)
    mean_power_w: float = float("nan")
    n_outside: int = 0
    cross_fitted: bool = True
    extrapolation: dict = field(default_factory=dict)
    scored_on: str = "windows"

    def sigma(
        self, energy_j: Any, duration_s: Any = None, outside_share: Any = 0.0,
        extra_rel_var: Any = 0.0, assumed_share: Any = 0.0,
    ) -> Any:  # fmt: skip
        """The error scale (J) of a predicted energy of a run of ``duration_s`` seconds.

        Without a duration it is ``energy_j / mean_power_w``. ``outside_share``: the share
        of the run outside the domain that no measured growth covers; ``extra_rel_var``:
        the measured growth's relative variance beyond the ranges (:meth:`outside`);
        ``assumed_share``: the share that goes by the assumed factor ``1 + share``
        whatever ``d`` is (a mean power beyond every calibration run's,
        :attr:`Outside.assumed_share`): with ``d`` fitted it multiplies the scale, without
        it the larger of the two shares does.
        """
        e = np.abs(np.asarray(energy_j, dtype=float))
        t = (e / self.mean_power_w if duration_s is None
             else np.asarray(duration_s, dtype=float))  # fmt: skip
        s = np.clip(np.asarray(outside_share, dtype=float), 0.0, 1.0)
        extra = np.asarray(extra_rel_var, dtype=float)
        v = (self.param_rel_var + self.model_rel_var + extra) * e**2
        v = v + self.noise_j2_per_s * t
        if self.outside_rel_var is not None:
            v = v + self.outside_rel_var * (s * e) ** 2
        sig = np.sqrt(np.maximum(v, (MIN_REL_SIGMA * e) ** 2))
        a = np.clip(np.asarray(assumed_share, dtype=float), 0.0, 1.0)
        if self.outside_rel_var is None:
            sig = sig * (1.0 + ASSUMED_OUTSIDE_FACTOR * np.maximum(s, a))
        else:  # (1 + 0 a) where nothing lies beyond the runs' power
            sig = sig * (1.0 + ASSUMED_OUTSIDE_FACTOR * a)
        return sig

    def outside(self, domain: Any) -> Outside:
        """How a path's domain report widens its interval (:class:`Outside`).

        The report: :func:`energy_planner.uncertainty.domain_report`. Each numeric
        quantity beyond its range by ``u`` (the report's ``excess``) with a
        measured growth ``g`` adds ``(g u)^2`` to the relative variance; the largest share
        outside a quantity no growth covers is the share the ``d`` term (or, without it,
        the assumed factor ``1 + s``) widens, and is *not calibrated* when ``d`` was not
        fitted. A predicted mean power beyond the calibration runs' (``mean_power``)
        has no measured growth and goes by the assumed factor whatever ``d`` is
        (``assumed_share``): ``d`` is fitted on held-out runs outside their fold's ranges
        range by range, and the cross-validation holds at most one run above its
        training runs' power range, so ``d`` says nothing of it (a fitted ``d = 0`` would
        not widen at all).
        """
        if not domain:
            return Outside(0.0, 0.0, (), ())
        extra, used, loose = 0.0, [], []
        assumed: tuple[str, ...] = ()
        shares = domain.get("shares") or {}
        excess = domain.get("excess") or {}
        share = assumed_share = 0.0
        for q, sh in shares.items():
            if not sh > 0:
                continue
            if q == MEAN_POWER:
                assumed_share, assumed = power_outside(domain)
                continue
            g, why = self.growth(q, q in excess)
            if g is not None:
                extra += (g * float(excess[q])) ** 2
                used.append(q)
            else:
                share = max(share, float(sh))
                loose.append(f"{q}: {why}")
        return Outside(extra, share, tuple(used), tuple(loose), assumed_share, assumed)

    def growth(self, quantity: str, numeric: bool) -> tuple[float | None, str]:
        """The measured growth of the relative error beyond ``quantity``'s range, or why none.

        ``numeric``: the report measures how far beyond the range the path goes (its
        ``excess``). Returns ``(growth per unit, "")`` or ``(None, why)``.
        """
        rec = self.extrapolation.get(quantity) or {}
        g = rec.get("growth_per_unit")
        if numeric and g is not None:
            return float(g), ""
        return None, rec.get("why") or ("no growth recorded (a model fitted before it was "
                                        "measured)" if numeric else
                                        "not a numeric range: no distance to measure")  # fmt: skip

    def outside_cells(self, shares: Any, excess: Any) -> OutsideCells:
        """:meth:`outside` of many paths at once (a reach map's cells).

        ``shares`` and ``excess``: per quantity an array (one value per path, NaN where
        there is no path), as a report's ``shares`` and ``excess``. The same rule per
        quantity as :meth:`outside`; ``refused`` where the interval would not be
        calibrated (a share no measured growth covers without a fitted ``d``, or a mean
        power beyond the runs').
        """
        return _cells(self, shares, excess)

    @property
    def outside_rule(self) -> str:
        """How the share outside the domain widens the interval."""
        if self.outside_rel_var is None:
            return (f"assumed: sigma x (1 + share) ({self.n_outside} held-out runs outside; "
                    f"{MIN_OUTSIDE_RUNS} outside and {MIN_OUTSIDE_RUNS} inside needed to "
                    "calibrate it)")  # fmt: skip
        return f"calibrated: d = {self.outside_rel_var:.3g} on {self.n_outside} held-out runs"

    def bounds(
        self, energy_j: float, level: float, duration_s: float | None = None,
        outside_share: float = 0.0, extra_rel_var: float = 0.0, assumed_share: float = 0.0,
    ) -> tuple[float, float]:  # fmt: skip
        """The interval ``(low, high)`` on the true energy, J (low at least 0).

        ``energy_j`` (and the others) may be arrays (a reach map's cells): arrays back.
        """
        from energy_planner.uncertainty import conformal_bounds

        if self.small_sample(level):
            z_lo, z_hi = self._student_bounds(level)
        else:
            z_lo, z_hi = conformal_bounds(self.scores, level)
        e = np.asarray(energy_j, dtype=float)
        sig = np.asarray(self.sigma(e, duration_s, outside_share, extra_rel_var, assumed_share),
                         dtype=float)  # fmt: skip
        lo, hi = np.maximum(e - z_hi * sig, 0.0), np.maximum(e - z_lo * sig, 0.0)
        return (float(lo), float(hi)) if lo.ndim == 0 else (lo, hi)

    def probability(
        self, energy_j: Any, usable_j: float, duration_s: Any = None,
        outside_share: Any = 0.0, extra_rel_var: float = 0.0, assumed_share: float = 0.0,
    ) -> Any:  # fmt: skip
        """Chance that the true energy is at most ``usable_j`` (conformal: count / (n + 1)).

        ``energy_j`` may be an array (a reach map's cells): the chance of each, same shape.
        """
        e = np.asarray(energy_j, dtype=float)
        if usable_j <= 0:
            return 0.0 if e.ndim == 0 else np.zeros(e.shape)
        sig = np.asarray(self.sigma(e, duration_s, outside_share, extra_rel_var, assumed_share),
                         dtype=float)  # fmt: skip
        with np.errstate(invalid="ignore", divide="ignore"):
            thr = (e - usable_j) / sig  # the run fits when its score is at least this
        if self.small_sample(0.9):
            z = self.scores
            sd = float(np.std(z, ddof=1)) * np.sqrt(1.0 + 1.0 / z.size)
            from scipy.special import stdtr  # scipy.stats costs seconds to import

            p = stdtr(z.size - 1, (z.mean() - thr) / sd)  # P(T > (thr - mean) / sd)
        else:
            z = np.sort(self.scores)
            p = (z.size - np.searchsorted(z, thr, side="left")) / (z.size + 1)
        return float(p) if e.ndim == 0 else np.asarray(p, dtype=float)

    def small_sample(self, level: float) -> bool:
        """Too few scores for a two-sided conformal interval at ``level``.

        The upper order statistic ``ceil((n + 1) (1 + level) / 2)`` exceeds ``n`` (for
        90 %: fewer than 19 scores): the conformal bound would be infinite. Then the
        normalized scores are taken as normal and the bounds are the Student-t
        prediction interval of a new draw, ``mean +- t(n-1) s sqrt(1 + 1/n)``, widened to
        the scores' range where that is wider.
        """
        n = self.scores.size
        return math.ceil((n + 1) * (1.0 + level) / 2.0) > n

    def _student_bounds(self, level: float) -> tuple[float, float]:
        z = self.scores
        if z.size < 2:
            return -math.inf, math.inf
        from scipy.special import stdtrit  # scipy.stats costs seconds to import

        q = float(stdtrit(z.size - 1, (1.0 + level) / 2.0))
        half = q * float(np.std(z, ddof=1)) * math.sqrt(1.0 + 1.0 / z.size)
        # never inside the scores' range, the widest a conformal bound of n scores gets
        # (so that a higher level never gives a narrower interval)
        return min(float(z.mean()) - half, float(z[0])), max(float(z.mean()) + half, float(z[-1]))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (stored as ``metadata.fit.error_model``)."""
        return {
            "form": "sigma^2 = (rho2 + b) E^2 + c T + d (share E)^2; "
            "interval E - z sigma, z split-conformal",
            "rho2": float(self.param_rel_var),
            "b": float(self.model_rel_var),
            "c_j2_per_s": float(self.noise_j2_per_s),
            "d": None if self.outside_rel_var is None else float(self.outside_rel_var),
            "outside_rule": self.outside_rule,
            "mean_power_w": float(self.mean_power_w),
            "n_outside": self.n_outside,
            "cross_fitted": self.cross_fitted,
            "extrapolation": self.extrapolation,
            "scored_on": self.scored_on,
            # full precision: a bound near zero is E - z sigma, where rounding cancels
            "scores": [float(z) for z in self.scores],
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ErrorModel:
        """Inverse of :meth:`to_dict`."""
        return cls(
            float(d["rho2"]), float(d["b"]), float(d["c_j2_per_s"]),
            None if d.get("d") is None else float(d["d"]),
            np.sort(np.asarray(d["scores"], dtype=float)), float(d["mean_power_w"]),
            int(d.get("n_outside", 0)), bool(d.get("cross_fitted", True)),
            dict(d.get("extrapolation") or {}),
            str(d.get("scored_on", "windows")),  # a file before it: windows' energies
        )  # fmt: skip


@dataclass(frozen=True)
class Outside:
    """How the part of a path outside the calibration's domain widens its interval.

    Attributes
    ----------
    extra_rel_var : float
        ``sum_q (g_q u_q)^2``: the measured growth beyond the numeric ranges.
    share : float
        The share of the path outside a quantity no growth covers.
    measured : tuple of str
        The quantities widened by their measured growth.
    not_measured : tuple of str
        ``"quantity: why"`` for each quantity outside without a measured growth.
    assumed_share : float
        The share widened by the assumed factor ``1 + share`` whatever ``d`` is: a
        predicted mean power above or below every calibration run's (never calibrated).
    assumed : tuple of str
        ``"quantity: why"`` for it.
    """

    extra_rel_var: float
    share: float
    measured: tuple[str, ...]
    not_measured: tuple[str, ...]
    assumed_share: float = 0.0
    assumed: tuple[str, ...] = ()


@dataclass(frozen=True)
class OutsideCells:
    """:class:`Outside` of many paths (arrays, one value per path).

    Attributes
    ----------
    extra_rel_var, share, assumed_share : ndarray
        As :class:`Outside`, per path.
    refused : ndarray of bool
        Paths whose interval would rest on an assumption: no battery decision.
    why : dict
        ``"quantity: why"`` -> per path, True where it is a reason of the refusal.
    """

    extra_rel_var: np.ndarray
    share: np.ndarray
    assumed_share: np.ndarray
    refused: np.ndarray
    why: dict


#: Why a mean power beyond the calibration runs' has no calibrated interval (many paths).
POWER_WHY = (f"{MEAN_POWER}: the path's mean power lies beyond every calibration run's, "
             "where the fit cannot measure how the error grows; log runs at that "
             "power")  # fmt: skip


def _cells(em: ErrorModel | None, shares: Any, excess: Any) -> OutsideCells:
    """:meth:`ErrorModel.outside_cells`, or with ``em`` None every share outside refused.

    ``em`` None: a model without an error model, whose relative errors are not widened.
    """
    excess = excess or {}
    shape = np.shape(next(iter(shares.values()))) if shares else ()
    extra, share, assumed = np.zeros(shape), np.zeros(shape), np.zeros(shape)
    why: dict[str, np.ndarray] = {}
    for q, sh in shares.items():
        sh = np.nan_to_num(np.asarray(sh, dtype=float))
        pos = sh > 0
        if not pos.any():
            continue
        if q == MEAN_POWER:
            assumed = np.maximum(assumed, sh)
            why[POWER_WHY] = pos
            continue
        g, reason = (None, "the model records no error model") if em is None else em.growth(
            q, q in excess)  # fmt: skip
        if g is not None:
            extra = extra + np.where(pos, (g * np.nan_to_num(np.asarray(excess[q], float))) ** 2,
                                     0.0)  # fmt: skip
        else:
            share = np.maximum(share, sh)
            why[f"{q}: {reason}"] = pos
    refused = assumed > 0
    if em is None or em.outside_rel_var is None:
        refused = refused | (share > 0)
    else:  # d widens the shares no growth covers: calibrated
        why = {k: v for k, v in why.items() if k == POWER_WHY}
    return OutsideCells(extra, share, assumed, refused, why)


def outside_cells(model_error: ErrorModel | None, shares: Any, excess: Any) -> OutsideCells:
    """:meth:`ErrorModel.outside_cells` of a model's error model, or with None refusals.

    ``model_error`` None (a model without an error model): every share outside refused,
    as a path's battery decision is refused there.
    """
    return _cells(model_error, shares, excess)


def power_outside(domain: Any) -> tuple[float, tuple[str, ...]]:
    """The share of a path beyond the calibration runs' mean power, and why, from its report.

    ``(0.0, ())`` when the report has no ``mean_power`` share (inside, or not checked).
    """
    sh = float(((domain or {}).get("shares") or {}).get(MEAN_POWER) or 0.0)
    return (sh, (f"{MEAN_POWER}: {_power_why(domain)}",)) if sh > 0 else (0.0, ())


def _power_why(domain: Any) -> str:
    """Why a path's mean power has no calibrated interval, with its numbers."""
    rng = (domain.get("domain") or {}).get("mean_power_w")
    p = domain.get("mean_power_w")
    if not rng or p is None:
        return ("the path's mean power lies beyond the calibration runs', where the fit "
                "cannot measure how the error grows; log runs at that power")  # fmt: skip
    lo, hi, p = float(rng[0]), float(rng[1]), float(p)
    # the side of the nearer end (the report rounds the power, maybe onto the edge)
    side = "above" if 2 * p > lo + hi else "below"
    return (f"the path's mean power {p:.0f} W lies {side} every calibration run's "
            f"({lo:.0f}-{hi:.0f} W), where the fit cannot measure how the error grows; log "
            f"runs at that power ({POWER_HOW[side]})")  # fmt: skip


def _fit_scale(
    e: np.ndarray, energy: np.ndarray, duration: np.ndarray, pvar: np.ndarray,
    share: np.ndarray, with_outside: bool, within: tuple[np.ndarray, ...] | None = None,
) -> np.ndarray:  # fmt: skip
    """``(b, c, d)`` >= 0 of the variance model on squared errors (IRLS on 1 / sigma^4).

    ``within``: per run ``(ss, t_eff, dof)`` of :func:`within_run_noise`, whose
    expectation is ``c t_eff`` whatever the run's systematic error: ``c`` is then their
    pooled moment ``sum ss / sum t_eff`` and only ``b`` (and ``d``) are fitted on the
    run errors, net of ``c T``. Without them ``c`` is fitted with ``b`` on the run
    errors alone (identified only when the runs' durations and energies vary apart).
    """
    from scipy.optimize import nnls  # imported when fitting only

    c_fixed = None
    if within is not None:
        ss, t_eff, k = within
        use = (k > 0) & (t_eff > 0) & np.isfinite(ss)
        if use.any():
            c_fixed = float(np.sum(ss[use]) / np.sum(t_eff[use]))
    cols = [energy**2] + ([duration] if c_fixed is None else [])
    cols += [(share * energy) ** 2] if with_outside else []
    F = np.column_stack(cols)
    known = pvar + (0.0 if c_fixed is None else c_fixed * duration)
    y = e**2 - known
    scale = np.linalg.norm(F, axis=0)
    scale[scale == 0] = 1.0
    w = np.ones(e.size)
    theta = np.zeros(F.shape[1])
    for _ in range(3):
        sw = np.sqrt(w)
        th, _ = nnls(F / scale * sw[:, None], y * sw)
        theta = th / scale
        var = np.maximum(known + F @ theta, (MIN_REL_SIGMA * energy) ** 2)
        w = 1.0 / var**2
        w /= w.mean()
    if c_fixed is not None:
        theta = np.r_[theta[0], c_fixed, theta[1:]]
    return np.r_[theta, 0.0] if not with_outside else theta


def within_run_noise(run: Any, error_j: Any, predicted_j: Any, duration_s: Any) -> Any:
    r"""Per run, what its windows' errors say about the error that averages out.

    A run's error is the sum of its windows' errors :math:`e_w`. The part of it that
    averages out over the run (sensor noise, slip, ground, a force mispriced on some
    windows and not others) is independent from window to window with variance
    :math:`c\,d_w`; the part that does not is the same share :math:`\rho` of every
    window's energy :math:`\hat E_w` (a systematic relative error). Removing the run's own
    share, :math:`r_w = e_w - a_w e` with :math:`a_w = \hat E_w / \hat E` and
    :math:`e = \sum e_w`, leaves the first alone:

    .. math:: E\Big[\sum_w r_w^2\Big] = c\,\Big(T - 2\sum_w a_w d_w
              + T \sum_w a_w^2\Big) = c\,T_\text{eff}

    with ``k - 1`` degrees of freedom for ``k`` windows. Runs of a single duration (a
    designed campaign's) cannot tell ``c T`` from ``b E^2`` by their run errors alone;
    these rows can.

    Parameters
    ----------
    run : array-like
        Run of each window.
    error_j, predicted_j, duration_s : array-like
        Per window: held-out predicted minus measured energy (J), predicted energy (J),
        duration (s).

    Returns
    -------
    pandas.DataFrame
        Index: run (sorted); columns ``ss`` (:math:`\sum_w r_w^2`, J^2), ``t_eff``
        (:math:`T_\text{eff}`, s) and ``dof`` (``k - 1``).

    Examples
    --------
    Three equal windows of pure noise: the expectation is ``c T (1 - 1/k)``.

    >>> w = within_run_noise(["a"] * 3, [1.0, -1.0, 0.0], [5.0] * 3, [2.0] * 3)
    >>> w.loc["a"].tolist()
    [2.0, 4.0, 2.0]
    """
    import pandas as pd

    df = pd.DataFrame({"run": np.asarray(run), "e": np.asarray(error_j, float),
                       "p": np.asarray(predicted_j, float),
                       "d": np.asarray(duration_s, float)})  # fmt: skip
    df = df[np.isfinite(df["e"]) & np.isfinite(df["p"]) & (df["d"] > 0)]
    g = df.groupby("run", sort=True)
    tot = g[["e", "p", "d"]].transform("sum")
    with np.errstate(invalid="ignore", divide="ignore"):
        a = np.where(tot["p"] > 0, df["p"] / tot["p"], np.nan)
    df = df.assign(r2=(df["e"] - a * tot["e"]) ** 2, ad=a * df["d"], a2=a**2)
    agg = df.groupby("run", sort=True).agg(ss=("r2", "sum"), ad=("ad", "sum"),
                                          a2=("a2", "sum"), t=("d", "sum"),
                                          k=("d", "size"))  # fmt: skip
    t_eff = (agg["t"] - 2 * agg["ad"] + agg["t"] * agg["a2"]).clip(lower=0.0)
    return pd.DataFrame({"ss": agg["ss"], "t_eff": t_eff, "dof": agg["k"] - 1.0}).astype(float)


def fit_error_model(
    predicted_j: Any,
    measured_j: Any,
    duration_s: Any,
    param_var_j2: Any = None,
    outside_share: Any = None,
    fold: Any = None,
    *,
    param_rel_var: float | None = None,
    within: tuple[Any, Any, Any] | None = None,
    scored_on: str = "windows",
) -> ErrorModel | None:
    """Fit the error scale on held-out runs and their normalized conformal scores.

    Parameters
    ----------
    predicted_j, measured_j, duration_s : array-like
        Per held-out run: its predicted energy (by a fit without it), its measured
        energy and its duration.
    param_var_j2 : array-like, optional
        Per run ``g^T V g``: the coefficient covariance of the fit that predicted it (its
        fold's) carried to its energy; part of its error, removed before fitting ``b, c,
        d`` and kept in the scale that normalizes its score.
    param_rel_var : float, optional
        ``rho^2`` of new predictions (the full fit's covariance as a share of
        ``E^2``); default: the pooled ``param_var_j2 / predicted_j^2``.
    outside_share : array-like, optional
        Per run, the share of its duration outside the domain its prediction had.
    fold : array-like, optional
        Per run its cross-validation fold: each score is normalized by a scale fitted on
        the other folds' runs (with one fold, on all runs: then ``cross_fitted`` False).
    within : tuple of array-like, optional
        Per run (same order) ``(ss, t_eff, dof)`` of :func:`within_run_noise`: its
        windows' errors, which measure the noise term ``c`` apart from ``b`` (without
        them, runs of one duration cannot tell an error that averages out over a long
        path from one that does not).
    scored_on : {"windows", "runs"}
        What the runs' energies are: their windows' only, or the runs whole
        (:attr:`ErrorModel.scored_on`).

    Returns
    -------
    ErrorModel or None
        None with fewer than 3 usable runs.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> E = rng.uniform(1e3, 1e4, 400); T = E / 100
    >>> meas = E + rng.normal(0, 0.05 * E)
    >>> em = fit_error_model(E, meas, T, fold=np.arange(400) % 5)
    >>> round(em.model_rel_var ** 0.5, 2)
    0.05
    """
    pred = np.asarray(predicted_j, dtype=float)
    meas = np.asarray(measured_j, dtype=float)
    dur = np.asarray(duration_s, dtype=float)
    n = pred.size
    pvar = np.zeros(n) if param_var_j2 is None else np.asarray(param_var_j2, dtype=float)
    share = np.zeros(n) if outside_share is None else np.asarray(outside_share, dtype=float)
    folds = np.zeros(n, int) if fold is None else np.asarray(fold)
    wr = (np.zeros((3, n)) if within is None
          else np.vstack([np.asarray(a, dtype=float) for a in within]))  # fmt: skip
    ok = (np.isfinite(pred) & np.isfinite(meas) & (meas > 0) & (pred > 0) & np.isfinite(dur)
          & (dur > 0) & np.isfinite(pvar) & np.isfinite(share))  # fmt: skip
    pred, meas, dur, pvar, share, folds = (a[ok] for a in (pred, meas, dur, pvar, share, folds))
    wr = wr[:, ok]
    has_within = within is not None and bool(np.any(wr[2] > 0))
    if pred.size < 3:
        return None
    e = pred - meas
    n_out = int(np.count_nonzero(share > 0))
    # the outside term is told apart from the error inside only with runs of both kinds
    with_out = min(n_out, share.size - n_out) >= MIN_OUTSIDE_RUNS
    rho2 = float(pvar.sum() / np.sum(pred**2)) if param_rel_var is None else param_rel_var

    def model_of(theta: np.ndarray, scores: np.ndarray, cross: bool, r2: float) -> ErrorModel:
        return ErrorModel(r2, float(theta[0]), float(theta[1]),
                          float(theta[2]) if with_out else None, np.sort(scores),
                          float(meas.sum() / dur.sum()), n_out, cross,
                          scored_on=scored_on)  # fmt: skip

    def own_sigma(th: np.ndarray, sel: np.ndarray) -> np.ndarray:
        # the scale of these runs' errors: their own coefficient variance and the
        # run-to-run terms (and the share outside their fold's domain)
        em = model_of(th, np.zeros(1), True, 0.0)
        v = em.sigma(pred[sel], dur[sel], 0.0) ** 2 + pvar[sel]
        if em.outside_rel_var is None:
            return np.sqrt(v) * (1.0 + ASSUMED_OUTSIDE_FACTOR * share[sel])
        return np.sqrt(v + em.outside_rel_var * (share[sel] * pred[sel]) ** 2)

    def rows(sel: np.ndarray) -> tuple[np.ndarray, ...] | None:
        return (wr[0][sel], wr[1][sel], wr[2][sel]) if has_within else None

    theta = _fit_scale(e, pred, dur, pvar, share, with_out, rows(np.ones(pred.size, bool)))
    labels = np.unique(folds)
    z = np.empty(pred.size)
    cross = labels.size >= 2
    if cross:
        for k in labels:
            test = folds == k
            train = ~test
            th = theta
            if np.count_nonzero(train) >= 3:
                th = _fit_scale(e[train], pred[train], dur[train], pvar[train], share[train],
                                with_out, rows(train))  # fmt: skip
            z[test] = e[test] / own_sigma(th, test)
    else:
        z = e / own_sigma(theta, np.ones(pred.size, bool))
    return model_of(theta, z, cross, rho2)
