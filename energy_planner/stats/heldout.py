"""Held-out evaluation by run: the folds and the one held-out prediction.

Every held-out number the package reports (``fit``, ``diagnose``, ``discover``, the
diagnosis' candidate scores and the calibration's run-energy errors) comes from
:func:`heldout`, on folds from :func:`fold_index`:

* :func:`fold_index` - grouped K-fold: whole runs per fold, as the fold of every row;
* :func:`heldout` - refit a linear model on the other folds, predict each fold's rows.

**Where the floor applies.** The model's power is floored *per sample*,
``P = max(sum_k c_k term_k, 0)`` (a legged robot does not regenerate), and a window's
predicted power is the mean of its samples' floored powers, exactly as
``EnergyModel.power`` followed by a window mean. The fit itself is linear on the window
means of the terms (the window mean of an unfloored power is the sum of the window means
of the terms). So :func:`heldout` takes the *per-sample* design and the window (row) of
every sample: it forms the window means for the fit, predicts every held-out sample, floors
it, and averages the floored samples of each window. Flooring the window mean instead
(``max(mean_s sum_k c_k term_k, 0)``) would credit a window with the regeneration of its
negative samples. On the simulated campaigns no held-out sample is negative (0 of 10422
on ``CampaignConfig.small()`` seed 0, none with 30 degree slopes either), so the two
agree there; they differ when a window mixes negative and positive samples (example
below). ``benchmarks/bench_heldout.py`` measures the cost of flooring per sample.

Examples
--------
>>> X = np.column_stack([np.ones(6), np.arange(6.0)])
>>> h = heldout(X, 1.0 + 2.0 * np.arange(6.0), np.arange(6) % 2)
>>> round(h.rmse, 9), h.coef.shape
(0.0, (2, 2))
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from energy_planner.errors import FitError
from energy_planner.stats.numerics import _scaled, _weights, solve_bordered, solve_min_norm

__all__ = [
    "EXACT_MAX_RUNS",
    "HeldOut",
    "choice_by_fold",
    "fold_index",
    "heldout",
    "paired_run_test",
    "run_sq_gain",
]


# --------------------------------------------------------------------------- folds by run
def fold_index(runs: Sequence | np.ndarray, n_splits: int = 5, seed: int = 0) -> np.ndarray:
    """Fold of every row, whole runs per fold (grouped K-fold, runs shuffled by ``seed``).

    The sorted distinct runs (compared as strings) are permuted by
    ``numpy.random.default_rng(seed)`` and split into ``n_splits`` parts whose sizes differ
    by at most one; a row's fold is its run's part. ``n_splits`` is reduced to the number
    of runs when there are fewer (leave one run out). The runs of fold ``i`` are
    ``sorted(set(runs[fold_index(runs) == i]))``.

    Parameters
    ----------
    runs : sequence
        Run id of every row (repeats allowed).
    n_splits : int
        Number of folds, at least 2.
    seed : int
        Seed of the shuffle.

    Returns
    -------
    numpy.ndarray
        Fold of every row, ``int64`` in ``0 .. min(n_splits, n_runs) - 1``.

    Raises
    ------
    FitError
        Fewer than two runs, or fewer than two folds asked for (names both counts).

    Examples
    --------
    >>> f = fold_index(["a", "a", "b", "c", "c", "c"], n_splits=2)
    >>> bool(f[0] == f[1]) and bool(f[3] == f[4] == f[5]), sorted(set(f.tolist()))
    (True, [0, 1])
    """
    runs = np.asarray(runs).astype(str)
    uniq = np.unique(runs)
    if len(uniq) < 2:
        raise FitError(
            f"held-out validation by run needs at least 2 runs, got {len(uniq)} "
            f"({list(uniq)}); record more runs"
        )
    if n_splits < 2:
        raise FitError(
            f"cannot split {len(uniq)} runs into {n_splits} fold(s): need at least 2 folds"
        )
    n = min(n_splits, len(uniq))
    perm = np.random.default_rng(seed).permutation(len(uniq))
    fold_of_run = np.empty(len(uniq), dtype=np.int64)
    for i, part in enumerate(np.array_split(perm, n)):
        fold_of_run[part] = i
    return fold_of_run[np.searchsorted(uniq, runs)]


# --------------------------------------------------------------------------- held-out
@dataclass(frozen=True)
class HeldOut:
    """Held-out predictions of a linear model validated by fold (:func:`heldout`).

    Attributes
    ----------
    predicted : numpy.ndarray
        Held-out prediction of every row (window): the mean of its samples' floored
        predictions; NaN for a row with no finite sample prediction.
    residuals : numpy.ndarray
        ``y - predicted`` per row.
    folds : numpy.ndarray
        Fold of every row.
    coef : numpy.ndarray
        Coefficients fitted in each fold, shape ``(n_folds, k)`` (0 for a column the fold
        did not fit).
    sample_predicted : numpy.ndarray
        Held-out floored prediction of every sample (row of ``X``).
    """

    predicted: np.ndarray
    residuals: np.ndarray
    folds: np.ndarray
    coef: np.ndarray
    sample_predicted: np.ndarray

    @property
    def rmse(self) -> float:
        """Pooled held-out RMSE over rows (every row alike)."""
        return float(np.sqrt(np.mean(self.residuals**2)))

    @property
    def fold_rmse(self) -> np.ndarray:
        """Held-out RMSE of each fold's rows."""
        n = self.coef.shape[0]
        sq = np.bincount(self.folds, weights=self.residuals**2, minlength=n)
        cnt = np.bincount(self.folds, minlength=n)
        return np.sqrt(sq / np.maximum(cnt, 1))


def _row_means(X: np.ndarray, rows: np.ndarray, n: int) -> np.ndarray:
    """Mean of each row's samples, column by column, non-finite samples ignored."""
    m, k = X.shape
    ok = np.isfinite(X)
    idx = (rows[:, None] * k + np.arange(k)).ravel()
    tot = np.bincount(idx, weights=np.where(ok, X, 0.0).ravel(), minlength=n * k)
    cnt = np.bincount(idx, weights=ok.ravel(), minlength=n * k)
    out = np.full(n * k, np.nan)
    np.divide(tot, cnt, out=out, where=cnt > 0)
    return out.reshape(n, k)


def heldout(
    X: np.ndarray,
    y: np.ndarray,
    folds: np.ndarray,
    w: np.ndarray | Sequence[float] | None = None,
    *,
    rows: np.ndarray | None = None,
    offset: np.ndarray | None = None,
    fit_columns: np.ndarray | None = None,
    floor: float | None = 0.0,
    means: np.ndarray | None = None,
) -> HeldOut:
    """Held-out predictions of ``y ~ mean(X)`` by fold, floored per sample.

    Each fold's coefficients come from the other folds' rows only, by weighted least
    squares on the rows' mean regressors (columns scaled to unit weighted norm; the
    training normal equations of a fold are the totals minus the fold's own, one
    ``k x k`` solve per fold, minimum norm when columns are dependent). Every sample of a
    held-out row is predicted, floored at ``floor`` (module docstring: the model's power
    is floored per sample), and a row's prediction is the mean of its floored samples.

    Parameters
    ----------
    X : numpy.ndarray
        Per-sample design, shape ``(m, k)``: the terms evaluated on every sample.
    y : numpy.ndarray
        Target of every row (a window's mean measured power), shape ``(n,)``.
    folds : numpy.ndarray
        Fold of every row (:func:`fold_index`).
    w : array-like, optional
        Row weights of the fits (window durations); equal by default.
    rows : numpy.ndarray, optional
        Row (window) of every sample, integers in ``0 .. n - 1``; default: every sample is
        its own row (``m == n``).
    offset : numpy.ndarray, optional
        Per-sample fixed part of the prediction (terms held at given coefficients): the
        fits target ``y`` minus its row mean, and it is added to every sample's prediction
        before the floor.
    fit_columns : numpy.ndarray, optional
        Boolean ``(n_folds, k)``: the columns each fold fits; the others get 0 (a term
        the fold's training rows cannot identify). Default: all.
    floor : float or None
        Floor of a sample's prediction (0: no regeneration); None leaves it unfloored.
    means : numpy.ndarray, optional
        The rows' means of ``X`` (non-finite samples ignored), shape ``(n, k)``, when the
        caller has them cached (the diagnosis scores hundreds of candidates on one model).

    Returns
    -------
    HeldOut

    Raises
    ------
    FitError
        Shapes that do not match (names them).

    Examples
    --------
    A window of two samples whose unfloored powers are -10 and +30 W is predicted
    (0 + 30) / 2 = 15 W, not max((-10 + 30) / 2, 0) = 10 W:

    >>> X = np.array([[-1.0], [3.0], [0.0], [2.0], [4.0]])  # P = 10 x, per sample
    >>> rows = np.array([0, 0, 1, 2, 3])
    >>> h = heldout(X, np.array([10.0, 0.0, 20.0, 40.0]), np.array([0, 1, 1, 1]), rows=rows)
    >>> h.sample_predicted[:2].round(9).tolist(), round(float(h.predicted[0]), 9)
    ([0.0, 30.0], 15.0)
    """
    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float)
    folds = np.asarray(folds, dtype=np.int64)
    n = len(y)
    if X.ndim != 2:
        raise FitError(f"the design has shape {X.shape}, expected (samples, terms)")
    m, k = X.shape
    rows = np.arange(m) if rows is None else np.asarray(rows, dtype=np.int64)
    if rows.shape != (m,) or (m and (rows.min() < 0 or rows.max() >= n)):
        raise FitError(
            f"rows has shape {rows.shape} with values in [{rows.min() if m else 0}, "
            f"{rows.max() if m else 0}], expected ({m},) with values in [0, {n - 1}]: "
            "the row (window) of every sample"
        )
    if folds.shape != (n,):
        raise FitError(f"folds have shape {folds.shape}, expected ({n},): one fold per row")
    w = _weights(w, n)
    off = np.zeros(m) if offset is None else np.asarray(offset, dtype=float)
    Xr = _row_means(X, rows, n) if means is None else np.asarray(means, dtype=float)
    if Xr.shape != (n, k):
        raise FitError(f"means have shape {Xr.shape}, expected ({n}, {k}): rows x terms")
    yr = y - (_row_means(off[:, None], rows, n)[:, 0] if offset is not None else 0.0)
    n_folds = int(folds.max()) + 1 if n else 0
    cols = (
        np.ones((n_folds, k), dtype=bool)
        if fit_columns is None
        else np.asarray(fit_columns, dtype=bool)
    )
    if cols.shape != (n_folds, k):
        raise FitError(
            f"fit_columns has shape {cols.shape}, expected ({n_folds}, {k}): folds x terms"
        )
    coef = _fold_coef(Xr, yr, folds, w, cols)
    # every sample by its row's fold's coefficients
    # one matrix-vector product per fold: a threaded BLAS spends far longer starting its
    # threads on this thin product (m x k by k x n_folds) than computing it when the
    # cores are busy (12 ms against 0.5 ms at a load of 4 on 2 cores)
    by_fold = np.empty((m, n_folds))
    for f in range(n_folds):
        by_fold[:, f] = X @ coef[f]
    pred_s = np.take_along_axis(by_fold, folds[rows][:, None], axis=1)[:, 0] + off
    if floor is not None:
        pred_s = np.maximum(pred_s, floor)
    pred = _row_means(pred_s[:, None], rows, n)[:, 0]
    return HeldOut(pred, y - pred, folds, coef, pred_s)


def _fold_coef(
    Xr: np.ndarray, yr: np.ndarray, folds: np.ndarray, w: np.ndarray, cols: np.ndarray
) -> np.ndarray:
    """Each fold's coefficients from the other folds' rows (:func:`heldout`'s fit).

    ``cols`` (``(n_folds, k)``, boolean) are the columns each fold fits; the others get 0.
    """
    n_folds, k = cols.shape
    sw, Xs, scale = _scaled(Xr, w)
    yw = yr * sw
    g, r = Xs.T @ Xs, Xs.T @ yw
    # every fold's training normal equations, solved at once; a column the fold does not
    # fit is a zero row and column (a zero coefficient, as the smaller system gives)
    gs, rs = np.empty((n_folds, k, k)), np.empty((n_folds, k))
    for f in range(n_folds):
        te = folds == f
        xt = Xs[te]
        gs[f] = g - xt.T @ xt
        rs[f] = r - xt.T @ yw[te]
    off_f = ~cols
    gs[off_f] = 0.0
    gs.transpose(0, 2, 1)[off_f] = 0.0
    rs[off_f] = 0.0
    coef = solve_min_norm(gs, rs, hermitian=True) / scale
    coef[off_f] = 0.0
    return coef


class _FoldFit:
    """:func:`_fold_coef` of a model's columns bordered with a few more, many times over.

    The model's statistics (its columns scaled to unit weighted norm, their Gram matrix
    and moments, in total and per fold) are made once; each call adds the extra columns'
    rows and columns (each column is scaled alone, as :func:`_scaled` scales it) and
    solves the folds' systems as :func:`_fold_coef` does: the same coefficients, to
    rounding. The diagnosis scores hundreds of candidates on one model this way.
    """

    def __init__(self, Xr: np.ndarray, yr: np.ndarray, folds: np.ndarray, w: np.ndarray):
        self.n_folds = int(folds.max()) + 1 if len(folds) else 0
        self.w = w
        self.sw, self.Xs, self.scale = _scaled(Xr, w)
        self.yw = yr * self.sw
        self.test = [np.flatnonzero(folds == f) for f in range(self.n_folds)]
        g, r = self.Xs.T @ self.Xs, self.Xs.T @ self.yw
        self.xt = [self.Xs[te] for te in self.test]
        self.ywt = [self.yw[te] for te in self.test]
        self.g = np.array([g - x.T @ x for x in self.xt]).reshape(self.n_folds, *g.shape)
        self.r = np.array([r - x.T @ self.yw[te] for x, te in zip(self.xt, self.test, strict=True)])
        self.r = self.r.reshape(self.n_folds, len(r))

    def coef(self, Zr: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Each fold's coefficients of ``[Xr, Zr]``, fitting ``cols`` (``(n_folds, k + e)``)."""
        k, e = self.Xs.shape[1], Zr.shape[1]
        _, Zs, zscale = _scaled(Zr, self.w)
        gxz, gzz, rz = self.Xs.T @ Zs, Zs.T @ Zs, Zs.T @ self.yw
        gs, rs = np.empty((self.n_folds, k + e, k + e)), np.empty((self.n_folds, k + e))
        gs[:, :k, :k] = self.g
        rs[:, :k] = self.r
        for f, (x, te, yt) in enumerate(zip(self.xt, self.test, self.ywt, strict=True)):
            zt = Zs[te]
            gs[f, :k, k:] = gxz - x.T @ zt
            gs[f, k:, :k] = gs[f, :k, k:].T
            gs[f, k:, k:] = gzz - zt.T @ zt
            rs[f, k:] = rz - zt.T @ yt
        off_f = ~cols
        gs[off_f] = 0.0
        gs.transpose(0, 2, 1)[off_f] = 0.0
        rs[off_f] = 0.0
        scale = np.concatenate([np.ravel(self.scale), np.ravel(zscale)])
        coef = solve_min_norm(gs, rs, hermitian=True) / scale
        coef[off_f] = 0.0
        return coef


def choice_by_fold(
    X: np.ndarray,
    Z: np.ndarray,
    y: np.ndarray,
    folds: np.ndarray,
    w: np.ndarray | Sequence[float] | None = None,
    scored: np.ndarray | None = None,
) -> np.ndarray:
    """For each fold, the candidate column that the other folds alone would add to ``X``.

    The choice is made as the diagnosis makes it on all runs (the candidate with the
    smallest held-out error), but on fold ``f``'s training folds only: each candidate
    ``Z[:, j]`` is scored by the held-out squared error of ``y ~ [X, z_j]`` over the
    training folds, each predicted by a fit on the others (weighted least squares on
    columns scaled to unit norm, minimum norm, unfloored, row by row), relative to the
    same of ``y ~ X`` on the same rows. The rows of fold ``f`` never enter its choice, so
    the held-out errors of fold ``f`` with its choice are an honest held-out measure of
    *choosing* a candidate, whatever the number of candidates (nested cross-validation).

    Every column of ``X`` is fitted in the inner folds (minimum norm), where :func:`heldout`
    fits only what a fold identifies: a model term that two or three runs support can
    then extrapolate wildly in an inner fold that holds them out, and the folds choose at
    random. That costs the choice power (on mission logs with a load, the default-phase
    campaigns of ``benchmarks/bench_field_logs.py``), never its level. Fitting only the
    identifiable model terms in the inner folds is not enough: a candidate then stands in
    for the term left out and is chosen, to extrapolate in the outer fold.

    Parameters
    ----------
    X : numpy.ndarray
        The model's columns, shape ``(n, k)`` (rows with a non-finite value must be left
        out by the caller).
    Z : numpy.ndarray
        Candidate columns, shape ``(n, m)``; a NaN leaves that row out of the candidate's
        score (and out of the score of ``X`` it is compared with).
    y : numpy.ndarray
        Target, shape ``(n,)``.
    folds : numpy.ndarray
        Fold of every row (:func:`fold_index`).
    w : array-like, optional
        Row weights of the fits; equal by default.
    scored : numpy.ndarray, optional
        Boolean: the rows whose inner held-out errors score a candidate (default all).
        The others still enter every fit: rows that extrapolate (a way of walking that
        their fold's training runs lack) are not scored, but the fits still learn from
        them.

    Returns
    -------
    numpy.ndarray
        Index of the chosen column per fold, ``int64`` of shape ``(n_folds,)``; -1 where
        no candidate lowers the training folds' held-out error.

    Examples
    --------
    Only the second candidate carries signal; every fold's training folds see it:

    >>> rng = np.random.default_rng(0)
    >>> x = np.ones((40, 1)); Z = rng.normal(size=(40, 3))
    >>> y = 2.0 + 3.0 * Z[:, 1] + rng.normal(0, 0.1, 40)
    >>> choice_by_fold(x, Z, y, np.arange(40) % 4).tolist()
    [1, 1, 1, 1]
    """
    X = np.asarray(X, dtype=float)
    Z = np.asarray(Z, dtype=float)
    y = np.asarray(y, dtype=float)
    folds = np.asarray(folds, dtype=np.int64)
    n, k = X.shape
    if Z.ndim != 2 or Z.shape[0] != n or y.shape != (n,) or folds.shape != (n,):
        raise FitError(
            f"X {X.shape}, Z {Z.shape}, y {y.shape} and folds {folds.shape} must share their rows"
        )
    w = _weights(w, n)
    scored = np.ones(n, dtype=bool) if scored is None else np.asarray(scored, dtype=bool)
    n_folds = int(folds.max()) + 1 if n else 0
    gains = _choice_gains(X, Z, y, folds, w, scored, n_folds)
    best = np.full(n_folds, -1, dtype=np.int64)
    gain = np.zeros(n_folds)
    for j, g in enumerate(gains):  # the first of equal gains, as candidate by candidate
        if np.isnan(g).all():  # too few finite rows: not scored
            continue
        better = g > gain
        best[better], gain[better] = j, g[better]
    return best


def _choice_gains(X, Z, y, folds, w, scored, n_folds) -> np.ndarray:
    """Each candidate's relative gain in each outer fold (:func:`choice_by_fold`).

    Shape ``(m, n_folds)``; NaN for a candidate with too few finite rows. Candidates
    with the same finite rows share the model's statistics on them (the model's columns,
    fitted once), and are bordered with their own column side by side
    (:func:`_bordered_gains`).
    """
    k, m = X.shape[1], Z.shape[1]
    gains = np.full((m, n_folds), np.nan)
    fin = np.isfinite(Z)
    groups: dict[bytes, list[int]] = {}
    for j in range(m):
        if fin[:, j].sum() > k + 1:
            groups.setdefault(fin[:, j].tobytes(), []).append(j)
    for cols in groups.values():
        ok = fin[:, cols[0]]
        for i in range(0, len(cols), CHOICE_CHUNK):
            part = cols[i : i + CHOICE_CHUNK]
            gains[part] = _bordered_gains(
                X[ok], Z[ok][:, part], y[ok], w[ok], folds[ok], n_folds, scored[ok]
            )
    return gains


#: Candidates :func:`choice_by_fold` borders at once (bounds the stacked systems:
#: ``CHOICE_CHUNK * n_folds * (n_folds - 1)`` of them, each ``(k + 1) x (k + 1)``).
CHOICE_CHUNK = 64


def _bordered_gains(X, Z, y, w, folds, n_folds, scored):
    """:func:`choice_by_fold`'s relative gain of each column of ``Z`` in each outer fold.

    The same as scoring ``[X, Z[:, j]]`` by :func:`_fold_stats` and :func:`_inner_sse`,
    candidate by candidate: the statistics of ``X`` (scaled to unit weighted norm on these
    rows) are made once, each candidate adds its own row and column to them (its column
    scaled alone, as :func:`_scaled` scales every column alone), and the inner systems
    of every candidate and pair of folds are solved together (:func:`solve_bordered`:
    the model's block once per pair).
    """
    n, k = X.shape
    c = Z.shape[1]
    stats = _fold_stats(X, y, w, folds, n_folds, scored)
    sse0 = _inner_sse(stats, k, n_folds)
    _, _, xscale = _scaled(X, w)
    _, _, zscale = _scaled(Z, w)
    Xs, Zs = X / xscale, Z / zscale  # unit weighted norm, unweighted rows
    # per fold: the border of the weighted Gram (fits) and of the plain one (errors)
    gw, gs = np.empty((n_folds, k, c)), np.empty((n_folds, k, c))
    cw, cs = np.empty((c, n_folds)), np.empty((c, n_folds))
    rwz, rsz = np.empty((c, n_folds)), np.empty((c, n_folds))
    for f in range(n_folds):
        te = folds == f
        a, z, yy = Xs[te], Zs[te], y[te]
        zw = z * w[te][:, None]
        gw[f], cw[:, f], rwz[:, f] = a.T @ zw, np.einsum("nc,nc->c", zw, z), yy @ zw
        sc = scored[te]
        a_s, z_s, y_s = a[sc], z[sc], yy[sc]
        gs[f], cs[:, f], rsz[:, f] = a_s.T @ z_s, np.einsum("nc,nc->c", z_s, z_s), y_s @ z_s
    GW = np.array([s[0] for s in stats])  # (F, k, k)
    RW = np.array([s[1] for s in stats])
    GS = np.array([s[2] for s in stats])
    RS = np.array([s[3] for s in stats])
    Q = np.array([s[4] for s in stats])
    pairs = [(f, g) for f in range(n_folds) for g in range(n_folds) if g != f and stats[g][5] > 0]
    out = np.zeros((c, n_folds))
    if not pairs:
        return _gain(sse0, out)
    fi, gi = np.array(pairs).T
    # the training systems of every (candidate, pair): totals minus the two folds, the
    # model's block shared by every candidate's border
    beta = solve_bordered(
        GW.sum(axis=0) - GW[fi] - GW[gi],
        RW.sum(axis=0) - RW[fi] - RW[gi],
        gw.sum(axis=0)[None] - gw[fi] - gw[gi],  # (p, k, c)
        cw.sum(axis=1)[:, None] - cw[:, fi] - cw[:, gi],
        rwz.sum(axis=1)[:, None] - rwz[:, fi] - rwz[:, gi],
    )  # (c, p, k + 1)
    # each pair's error on its test fold g: y.y - 2 b.r + b.G b
    bx, bz = beta[..., :k], beta[..., k]
    r_dot = np.einsum("cpi,pi->cp", bx, RS[gi]) + bz * rsz[:, gi]
    quad = (
        np.einsum("cpi,pij,cpj->cp", bx, GS[gi], bx)
        + 2.0 * bz * np.einsum("cpi,pic->cp", bx, gs[gi])
        + bz**2 * cs[:, gi]
    )
    err = Q[gi][None] - 2.0 * r_dot + quad
    for q, f in enumerate(fi):  # summed in the order of the loop it replaces
        out[:, f] += err[:, q]
    return _gain(sse0, out)


def _gain(sse0: np.ndarray, sse1: np.ndarray) -> np.ndarray:
    """Relative reduction ``1 - sse1 / sse0`` per outer fold (0 where ``sse0`` is 0)."""
    return np.where(sse0 > 0, 1.0 - sse1 / np.where(sse0 > 0, sse0, 1.0), 0.0)


def _fold_stats(A, y, w, folds, n_folds, scored=None):
    """Per fold: weighted Gram and moment (fits), plain Gram, moment and ``y.y`` (errors).

    The fits use every row of the fold, the errors only its ``scored`` rows (default all).
    """
    _, As, scale = _scaled(A, w)
    As = A / scale  # unit weighted norm, unweighted rows
    scored = np.ones(len(y), dtype=bool) if scored is None else scored
    out = []
    for f in range(n_folds):
        te = folds == f
        a, yy, ww = As[te], y[te], w[te]
        aw = a * ww[:, None]
        sc = scored[te]  # the errors: the scored rows only
        a_s, y_s = a[sc], yy[sc]
        out.append((aw.T @ a, aw.T @ yy, a_s.T @ a_s, a_s.T @ y_s, float(y_s @ y_s), int(te.sum())))
    return out


def _inner_sse(stats, c: int, n_folds: int) -> np.ndarray:
    """Per outer fold, the inner held-out squared error of the first ``c`` columns.

    Over the other folds, each predicted by a fit on the folds that are neither (from the
    statistics of :func:`_fold_stats`: a fold's error is ``y.y - 2 b.r + b.G b``).
    """
    gw = np.array([s[0][:c, :c] for s in stats])
    rw = np.array([s[1][:c] for s in stats])
    gt, rt = gw.sum(axis=0), rw.sum(axis=0)
    pairs = [(f, g) for f in range(n_folds) for g in range(n_folds) if g != f and stats[g][5] > 0]
    out = np.zeros(n_folds)
    if not pairs:
        return out
    fi, gi = np.array(pairs).T
    b = solve_min_norm(gt - gw[fi] - gw[gi], rt - rw[fi] - rw[gi], hermitian=True)
    G = np.array([s[2][:c, :c] for s in stats])[gi]
    r = np.array([s[3][:c] for s in stats])[gi]
    q = np.array([s[4] for s in stats])[gi]
    err = q - 2.0 * np.einsum("pi,pi->p", b, r) + np.einsum("pi,pij,pj->p", b, G, b)
    for f, e in zip(fi, err, strict=True):  # summed in the order of the loop it replaces
        out[f] += e
    return out


#: Up to this many runs without tied differences, :func:`paired_run_test` takes its p-value
#: from the exact null distribution of the signed-rank statistic (all ``2 ** n`` sign
#: patterns equally likely) rather than its normal approximation. With 12 runs the
#: approximation cannot go below p = 0.0011 however consistent the runs (all 12 better),
#: where the exact p is ``2 ** -12`` = 0.00024: a few runs must be able to show an effect
#: at the level the diagnosis asks for.
EXACT_MAX_RUNS = 25


def run_sq_gain(
    e0: np.ndarray, e1: np.ndarray, runs: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reduction of the squared held-out error by run: what :func:`paired_run_test` tests.

    Parameters
    ----------
    e0, e1 : numpy.ndarray
        Held-out errors of the same windows without and with a change.
    runs : numpy.ndarray
        Run of every window.

    Returns
    -------
    tuple
        ``(run_ids, gain, n)``: the runs (sorted), the sum over each run's windows of
        ``e0**2 - e1**2`` (their sum is the change of the pooled sum of squared errors) and
        each run's number of windows (``gain / n`` is the test's ``d_r``).

    Examples
    --------
    >>> ids, g, n = run_sq_gain(np.array([2.0, 2, 1]), np.array([1.0, 0, 1]),
    ...                         np.array(["b", "b", "a"]))
    >>> ids.tolist(), g.tolist(), n.tolist()
    (['a', 'b'], [0.0, 7.0], [1, 2])
    """
    runs = np.asarray(runs)
    if runs.dtype.kind in "iu" and runs.size and runs.min() >= 0 and runs.max() < 4 * runs.size:
        # run codes (the diagnosis' integers): counted, not sorted; the same ids and
        # inverse as np.unique
        have = np.bincount(runs) > 0
        ids = np.flatnonzero(have).astype(runs.dtype)
        inv = (np.cumsum(have) - 1)[runs]
    else:
        ids, inv = np.unique(runs, return_inverse=True)
    return ids, np.bincount(inv, weights=e0**2 - e1**2), np.bincount(inv)


def paired_run_test(e0: np.ndarray, e1: np.ndarray, runs: np.ndarray) -> tuple[float, float, int]:
    """One-sided paired test by run that ``e1`` has smaller squared errors than ``e0``.

    ``d_r`` is the mean over run ``r``'s windows of ``e0**2 - e1**2`` (:func:`run_sq_gain`);
    the runs are the independent units (held out by run; a run's windows share its ground
    and sensors). The
    test is Wilcoxon's signed-rank test of ``d_r`` (the diagnosis names it
    ``RUN_TEST_NAME``; :func:`~energy_planner.stats.signedrank.signed_rank_test`, as
    ``scipy.stats.wilcoxon``, one-sided, zero differences dropped): an
    effect often lives in a few runs (those on mud, those with a payload) and makes ``d_r``
    very skewed, where a t-test has little power; the signed-rank test counts how
    consistently runs improve. The p-value is exact (the null distribution of the statistic
    over the ``2 ** n`` sign patterns) for at most :data:`EXACT_MAX_RUNS` runs without tied
    ``|d_r|``, and the normal approximation with tie correction otherwise; the statistic
    ``z`` is always the standardised one (normal approximation).

    Returns
    -------
    tuple
        ``(z, p, n_runs)``: the standardised signed-rank statistic (> 0: ``e1`` better),
        its one-sided p-value and the number of runs.

    Examples
    --------
    >>> runs = np.repeat(np.arange(20), 3)
    >>> rng = np.random.default_rng(1)
    >>> e0 = rng.normal(0, 2, 60); e1 = e0 / 2
    >>> z, p, n = paired_run_test(e0, e1, runs)
    >>> bool(z > 3 and p < 1e-3), n
    (True, 20)
    >>> z, p, n = paired_run_test(e1, e0, runs)
    >>> bool(z < -3 and p > 0.99)
    True

    Twelve runs that all improve: exactly one sign pattern in ``2 ** 12`` is as extreme.

    >>> _, p, n = paired_run_test(np.full(12, 2.0) + np.arange(12), np.ones(12), np.arange(12))
    >>> p == 2.0**-12, n
    (True, 12)
    """
    from energy_planner.stats.signedrank import signed_rank_test

    _, gain, count = run_sq_gain(e0, e1, runs)
    d = gain / count
    n = d.size
    scale = np.max(np.abs(d)) if n else 0.0
    d = d[np.abs(d) > 1e-12 * max(scale, 1e-300)]  # zero differences carry no sign
    if d.size < 2:
        return math.nan, 1.0, n
    # one call: the statistic z is the standardised one whatever the method
    exact = d.size <= EXACT_MAX_RUNS and np.unique(np.abs(d)).size == d.size
    _, z, p = signed_rank_test(d, "greater", "exact" if exact else "asymptotic")
    if not math.isfinite(z):
        return math.nan, 1.0, n
    return z, p, n
