r"""Recursive least squares with exponential forgetting, seeded from a fitted model.

The model's power is linear in its coefficients, ``y = x . c`` with ``x`` a row of
:meth:`energy_planner.model.EnergyModel.design_matrix` (window means of the terms). With
``P`` the covariance of ``c``, ``lambda`` the forgetting factor and ``s2`` the variance of a
window's measured mean power about the model, one window ``(x, y)`` updates (Kalman form of
RLS with forgetting)

.. math::

    P^- = P / \lambda,\quad k = P^- x / (x^T P^- x + s^2),\quad
    c \leftarrow c + k (y - x^T c),\quad P \leftarrow (I - k x^T) P^-.

Old windows weigh ``lambda^age``: the estimator's memory is about ``1 / (1 - lambda)``
windows. For a constant regressor ``x`` and ``P`` at its steady state ``s2 (1 - lambda) /
(x^T x)``, a step of size ``d`` in the true coefficient leaves an error of exactly
``d lambda^m`` after ``m`` windows (an exponentially weighted mean); the test suite checks
that. Directions the windows do not excite would let ``P / lambda`` grow without bound
("wind-up"); each coefficient's variance is capped at ``cov_cap`` (a congruence with a
diagonal, which keeps ``P`` positive semi-definite). When a change is detected (the
follower watches the recent mean innovation), :meth:`ForgettingRLS.reset` opens each
variance to its cap, keeping the correlations: covariance resetting, so that a step is
tracked within a few windows rather than after the forgetting has inflated ``P``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from energy_planner.errors import ModelError

__all__ = ["ForgettingRLS", "seed_covariance"]


def seed_covariance(model: Any) -> tuple[np.ndarray, str]:
    """The covariance of a fitted model's coefficients, and where it came from.

    Uses ``metadata["fit"]["covariance"]`` (a ``k x k`` list in term order) when the model
    file stores one; otherwise a diagonal built from the run-clustered standard errors
    (``metadata["fit"]["stderr_by_run"]``) or, failing those, the fit's ``stderr``. The
    returned note says which (a diagonal ignores the correlation of the coefficients).

    Raises
    ------
    ModelError
        If the model has neither a covariance nor standard errors for every term.
    """
    names = list(model.term_names)
    fit = (getattr(model, "metadata", None) or {}).get("fit") or {}
    cov = fit.get("covariance")
    if cov is not None:
        arr = np.asarray(cov, dtype=float)
        if arr.shape == (len(names), len(names)) and np.isfinite(arr).all():
            return arr, "covariance of the fit (model file)"
    for key, src in (("stderr_by_run", fit.get("stderr_by_run")), ("stderr", model.stderr)):
        if src and all(n in src and src[n] is not None for n in names):
            se = np.array([float(src[n]) for n in names])
            if np.isfinite(se).all():
                return np.diag(se**2), (
                    f"no covariance stored in the model: a diagonal built from its {key} "
                    "(correlations between coefficients ignored)"
                )
    missing = [n for n in names if not (model.stderr or {}).get(n)]
    raise ModelError(
        "the model stores neither a covariance nor standard errors of its coefficients "
        f"(missing for: {', '.join(missing) or 'all terms'}); refit it with "
        "energy-planner fit to follow a mission with it"
    )


@dataclass
class ForgettingRLS:
    """Recursive least squares with forgetting (see the module docstring).

    Parameters
    ----------
    coef : ndarray, shape (k,)
        Seed coefficients (the fit's).
    cov : ndarray, shape (k, k)
        Seed covariance of the coefficients.
    noise_var : float
        Variance of one window's mean power about the model, W^2.
    forgetting : float
        ``lambda`` in (0, 1]; 1 is ordinary recursive least squares.
    cov_cap : ndarray, shape (k,), optional
        Upper bound of each coefficient's variance (default: unbounded).

    Examples
    --------
    >>> r = ForgettingRLS(np.array([0.0]), np.array([[1.0]]), noise_var=1.0, forgetting=1.0)
    >>> r.update(np.array([1.0]), 2.0)
    2.0
    >>> float(r.coef[0]), float(r.cov[0, 0])
    (1.0, 0.5)
    """

    coef: np.ndarray
    cov: np.ndarray
    noise_var: float
    forgetting: float = 0.95
    cov_cap: np.ndarray | None = None
    n_updates: int = field(default=0, init=False)

    def __post_init__(self) -> None:
        self.coef = np.array(self.coef, dtype=float)
        self.cov = np.array(self.cov, dtype=float)
        k = self.coef.shape[0]
        if self.cov.shape != (k, k):
            raise ModelError(f"covariance shape {self.cov.shape} does not match {k} coefficients")
        if not 0.0 < self.forgetting <= 1.0:
            raise ModelError(f"forgetting factor {self.forgetting!r} must be in (0, 1]")
        if not self.noise_var > 0.0:
            raise ModelError(f"noise variance {self.noise_var!r} W^2 must be > 0")
        if self.cov_cap is not None:
            self.cov_cap = np.asarray(self.cov_cap, dtype=float)

    def update(self, x: np.ndarray, y: float) -> float:
        """Update with one window (regressor ``x``, measured mean power ``y``).

        Returns
        -------
        float
            The innovation ``y - x . c`` before the update, W.
        """
        P = self.cov / self.forgetting
        if self.cov_cap is not None:
            d = np.diag(P)
            s = np.sqrt(np.minimum(1.0, self.cov_cap / np.maximum(d, 1e-300)))
            P = P * s[:, None] * s[None, :]
        Px = P @ x
        gain = Px / (float(x @ Px) + self.noise_var)
        innovation = float(y - x @ self.coef)
        self.coef = self.coef + gain * innovation
        P = P - np.outer(gain, Px)
        self.cov = 0.5 * (P + P.T)
        self.n_updates += 1
        return innovation

    def reset(self) -> None:
        """Open the covariance to its cap (a change was detected: forget faster)."""
        if self.cov_cap is None:
            raise ModelError("reset needs cov_cap: the covariance to open to")
        d = np.sqrt(np.maximum(np.diag(self.cov), 1e-300))
        s = np.sqrt(self.cov_cap) / d
        self.cov = self.cov * np.maximum(s, 1.0)[:, None] * np.maximum(s, 1.0)[None, :]

    def variance_of(self, r: np.ndarray) -> float:
        """Variance of the linear combination ``r . c``."""
        return float(max(r @ self.cov @ r, 0.0))
