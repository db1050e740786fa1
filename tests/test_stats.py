"""Shared numerics (energy_planner.stats) against independent computations."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from energy_planner.errors import FitError
from energy_planner.stats import (
    classify_motion,
    cluster_stderr,
    fold_index,
    heldout,
    independent_columns,
    solve_min_norm,
    span_residual,
    vif,
    wls,
    wls_coef,
)


def _data(seed: int, n: int = 120, k: int = 4):
    rng = np.random.default_rng(seed)
    X = np.column_stack([np.ones(n), rng.uniform(-1, 1, (n, k - 1)) * [1, 100, 0.01][: k - 1]])
    w = rng.uniform(0.5, 2.0, n)
    beta = rng.normal(0, 3, k)
    y = X @ beta + rng.normal(0, 0.5, n)
    return X, y, w


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_wls_solves_the_weighted_normal_equations(seed):
    """Coefficients equal the textbook (X^T W X)^-1 X^T W y, whatever the column scales."""
    X, y, w = _data(seed)
    ref = np.linalg.solve(X.T @ (X * w[:, None]), X.T @ (w * y))
    fit = wls(X, y, w)
    np.testing.assert_allclose(fit.coef, ref, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(wls_coef(X, y, w), ref, rtol=1e-6, atol=1e-8)
    # classical covariance sigma^2 (X^T W X)^-1 with sigma^2 = sum(w r^2) / (n - k)
    r = y - X @ ref
    s2 = np.sum(w * r**2) / (len(y) - X.shape[1])
    se = np.sqrt(np.diag(s2 * np.linalg.inv(X.T @ (X * w[:, None]))))
    np.testing.assert_allclose(fit.stderr, se, rtol=1e-6)
    assert fit.rank == X.shape[1]


def test_cluster_stderr_matches_the_sandwich_by_hand():
    X, y, w = _data(3, n=40, k=2)
    runs = np.repeat(np.arange(8), 5)
    fit = wls(X, y, w, clusters=runs)
    B = X.T @ (X * w[:, None])
    meat = np.zeros((2, 2))
    for g in range(8):
        m = runs == g
        s = X[m].T @ (w[m] * fit.resid[m])
        meat += np.outer(s, s)
    V = np.linalg.inv(B) @ meat @ np.linalg.inv(B) * 8 / 7
    np.testing.assert_allclose(fit.stderr_by_run, np.sqrt(np.diag(V)), rtol=1e-9)
    np.testing.assert_allclose(cluster_stderr(X, fit.resid, w, runs), fit.stderr_by_run)


def test_duplicated_rows_leave_clustered_errors_unchanged():
    X, y, w = _data(4, n=60, k=3)
    runs = np.repeat(np.arange(12), 5)
    a = wls(X, y, w, clusters=runs)
    b = wls(np.vstack([X, X]), np.r_[y, y], np.r_[w, w], clusters=np.r_[runs, runs])
    np.testing.assert_allclose(b.stderr_by_run, a.stderr_by_run, rtol=1e-9)
    np.testing.assert_allclose(b.stderr, a.stderr / np.sqrt(2), rtol=0.03)


@settings(max_examples=30, deadline=None)
@given(
    runs=st.lists(st.sampled_from("abcdefgh"), min_size=2, max_size=40),
    n_splits=st.integers(2, 8),
    seed=st.integers(0, 100),
)
def test_folds_partition_the_runs(runs, n_splits, seed):
    uniq = sorted(set(runs))
    if len(uniq) < 2:
        with pytest.raises(FitError, match="at least 2 runs"):
            fold_index(runs, n_splits, seed)
        return
    f = fold_index(runs, n_splits, seed)
    for r in uniq:  # a run never spans two folds
        assert len({int(f[i]) for i, x in enumerate(runs) if x == r}) == 1
    k = min(n_splits, len(uniq))
    assert sorted(set(f.tolist())) == list(range(k))
    sizes = [len({r for r, fi in zip(runs, f, strict=True) if fi == i}) for i in range(k)]
    assert sum(sizes) == len(uniq) and max(sizes) - min(sizes) <= 1
    with pytest.raises(FitError, match="at least 2 folds"):
        fold_index(runs, 1)


def test_heldout_equals_explicit_refits():
    """Each fold's prediction is an ordinary weighted least-squares fit on the other folds."""
    X, y, w = _data(5, n=90, k=3)
    folds = np.arange(90) % 3
    h = heldout(X, y, folds, w, floor=None)
    for f in range(3):
        tr = folds != f
        b = np.linalg.lstsq(X[tr] * np.sqrt(w[tr])[:, None], y[tr] * np.sqrt(w[tr]), rcond=None)[0]
        te = folds == f
        np.testing.assert_allclose(h.residuals[te], y[te] - X[te] @ b, atol=1e-8)
        np.testing.assert_allclose(h.coef[f], b, rtol=1e-8)
    assert h.fold_rmse.shape == (3,)
    assert h.rmse == pytest.approx(np.sqrt(np.mean(h.residuals**2)))


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), per_window=st.integers(1, 6))
def test_heldout_floors_every_sample_then_averages(seed, per_window):
    """A window's prediction is the mean of its samples' floored predictions.

    Reference: each fold refitted by ``numpy.linalg.lstsq`` on the training windows' mean
    regressors, every held-out sample predicted and floored by hand. With one sample per
    window the two floors agree; with several they differ where a window mixes signs.
    """
    rng = np.random.default_rng(seed)
    n = 24
    rows = np.repeat(np.arange(n), per_window)
    Xs = np.column_stack([np.ones(len(rows)), rng.normal(0, 2, len(rows))])
    Xw = np.array([Xs[rows == i].mean(axis=0) for i in range(n)])
    y = Xw @ [1.0, 3.0] + rng.normal(0, 0.3, n)
    w = rng.uniform(0.5, 2.0, n)
    folds = np.arange(n) % 4
    h = heldout(Xs, y, folds, w, rows=rows)
    for f in range(4):
        tr = folds != f
        sw = np.sqrt(w[tr])
        b = np.linalg.lstsq(Xw[tr] * sw[:, None], y[tr] * sw, rcond=None)[0]
        for i in np.flatnonzero(folds == f):
            want = np.maximum(Xs[rows == i] @ b, 0.0).mean()
            assert h.predicted[i] == pytest.approx(want, abs=1e-9)
    if per_window == 1:
        np.testing.assert_allclose(h.predicted, np.maximum(Xw @ h.coef[folds].T, 0).diagonal())


def test_independent_columns_names_the_dependence():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=50), rng.normal(size=50)
    X = np.column_stack([a, b, 2 * a - b, np.zeros(50), rng.normal(size=50)])
    keep, why = independent_columns(X)
    assert keep.tolist() == [True, True, False, False, True]
    assert sorted(why[2]) == [0, 1] and why[3] == []
    assert np.isinf(vif(X)[2]) and np.isfinite(vif(X)[4])
    assert span_residual(X[:, 2], X[:, :2]) < 1e-12
    fit = wls(X, rng.normal(size=50))
    assert fit.rank == 3 and np.isnan(fit.stderr).all()


def _independent_by_definition(X, w, tol):
    """Column by column: kept when its residual on the kept earlier ones exceeds tol."""
    Xw = X * np.sqrt(w)[:, None]
    keep = np.zeros(X.shape[1], dtype=bool)
    for j in range(X.shape[1]):
        kept = np.flatnonzero(keep)
        z = Xw[:, j]
        keep[j] = np.any(z) and (kept.size == 0 or span_residual(z, Xw[:, kept]) > tol)
    return keep


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    near=st.sampled_from([1e-9, 1e-7, 5e-7, 1e-6, 2e-6, 1e-5, 1e-4, 1e-3, 2e-3]),
    tol=st.sampled_from([1e-6, 1e-8, 1e-4, 1e-2]),
)
def test_independent_columns_decides_as_the_residual_of_each_column(seed, near, tol):
    """The columns kept are those whose relative residual on the kept earlier ones exceeds
    ``tol`` (:func:`span_residual`), whatever shortcut decides the clearly independent
    ones: columns of scales 1e-4 to 1e4, a column near the span of earlier ones by a
    relative ``near`` either side of the tolerances (at 1e-6, DEPENDENCE_TOL), an exact
    combination, a zero column and a duplicate."""
    rng = np.random.default_rng(seed)
    n = 60
    base = rng.normal(size=(n, 4)) * 10.0 ** rng.uniform(-4, 4, 4)
    combo = base[:, :3] @ rng.normal(size=3)
    off = rng.normal(size=n)
    off -= base @ np.linalg.lstsq(base, off, rcond=None)[0]  # orthogonal to the span
    nearby = combo + near * np.linalg.norm(combo) * off / np.linalg.norm(off)
    cols = [base[:, 0], base[:, 1], nearby, base[:, 2], combo, np.zeros(n), base[:, 3]]
    X = np.column_stack([*cols, base[:, 1]])[:, rng.permutation(len(cols) + 1)]
    w = rng.uniform(0.5, 2.0, n)
    keep, why = independent_columns(X, w, tol=tol)
    assert keep.tolist() == _independent_by_definition(X, w, tol).tolist()
    assert set(why) == set(np.flatnonzero(~keep).tolist())


@settings(max_examples=50, deadline=None)
@given(
    vx=st.floats(-1, 1, allow_nan=False),
    vy=st.floats(-1, 1, allow_nan=False),
    wz=st.floats(-2, 2, allow_nan=False),
)
def test_classify_motion_mirror(vx, vy, wz):
    """The mirror image (vy, wz -> -vy, -wz) swaps left and right and nothing else."""
    a = classify_motion(vx, vy, wz)[0]
    b = classify_motion(vx, -vy, -wz)[0]
    swap = {
        "lateral_left": "lateral_right",
        "lateral_right": "lateral_left",
        "turn_left": "turn_right",
        "turn_right": "turn_left",
    }
    assert b == swap.get(a, a)


@settings(max_examples=15, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    n=st.integers(14, 60),  # fewer with ties: scipy's test over 2**n patterns, ~1 s each
    grid=st.sampled_from([0.0, 0.5, 1.0]),  # > 0: differences on a grid (ties, zeros)
    alternative=st.sampled_from(["two-sided", "greater", "less"]),
)
# each branch of "auto": exact (no ties, <= 50), every sign pattern (ties, <= 13), normal
@example(seed=1, n=12, grid=0.0, alternative="greater")
@example(seed=2, n=9, grid=1.0, alternative="two-sided")
@example(seed=5, n=6, grid=0.5, alternative="greater")
@example(seed=6, n=1, grid=0.0, alternative="less")
@example(seed=3, n=30, grid=0.5, alternative="less")
@example(seed=4, n=55, grid=0.0, alternative="two-sided")
def test_signed_rank_test_gives_scipys_numbers(seed, n, grid, alternative):
    """The signed-rank test without scipy.stats: scipy.stats.wilcoxon's statistic, z and
    p-value to the last bit, for every method (auto: exact, over every sign pattern or
    the normal approximation), with and without ties and zeros."""
    from scipy.stats import wilcoxon

    from energy_planner.stats.signedrank import signed_rank_test

    rng = np.random.default_rng(seed)
    d = rng.normal(0.3, 1.0, n) * 3
    if grid:
        d = np.round(d / grid) * grid
    if not np.any(d != 0):
        d[0] = 1.0
    for method in ("auto", "asymptotic", "exact"):
        kw = dict(alternative=alternative, method=method, zero_method="wilcox")
        if method == "exact" and (np.any(d == 0) or np.unique(np.abs(d)).size < d.size):
            continue  # scipy's exact null holds only without ties and zeros
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # scipy warns of ties / small samples
            ref = wilcoxon(d, **kw)
        r_plus, z, p = signed_rank_test(d, alternative, method)
        assert p == float(ref.pvalue), (method, d)
        if alternative != "two-sided":
            assert r_plus == float(ref.statistic)
        if method == "asymptotic":
            assert abs(z) == abs(float(ref.zstatistic))


def test_distribution_functions_are_scipy_stats():
    """The t, chi-squared and normal functions the checks call (scipy.special) are the
    ones scipy.stats gives, inf and a zero statistic included."""
    from scipy import special, stats

    x = np.array([-np.inf, -3.2, -0.4, 0.0, 0.7, 2.5, 40.0, np.inf])
    for df in (1, 4, 37):
        np.testing.assert_array_equal(special.stdtr(df, -x), stats.t.sf(x, df))
        xp = np.abs(x)
        np.testing.assert_array_equal(special.chdtrc(df, xp), stats.chi2.sf(xp, df))
    np.testing.assert_array_equal(special.ndtr(x), stats.norm.cdf(x))
    q = np.array([0.0, 1e-9, 0.025, 0.5, 0.95, 1.0])
    np.testing.assert_array_equal(special.ndtri(q), stats.norm.ppf(q))
    np.testing.assert_array_equal(-special.ndtri(q), stats.norm.isf(q))


def test_choice_by_fold_scores_only_the_scored_rows_but_fits_all():
    """Four rows (one per fold) that a second candidate alone prices, 20 W off: scored, the
    folds choose it (they are most of the error); left unscored, the folds choose the
    candidate that carries the signal of the other rows (the unscored rows still enter the
    fits)."""
    from energy_planner.stats.heldout import choice_by_fold

    rng = np.random.default_rng(1)
    n = 60
    folds = np.arange(n) % 4
    s = rng.normal(size=n)
    odd = np.zeros(n)
    odd[:4] = 1.0
    y = 2.0 + 3.0 * s + 20.0 * odd + rng.normal(0, 0.1, n)
    X, Z = np.ones((n, 1)), np.column_stack([s, odd])
    assert choice_by_fold(X, Z, y, folds).tolist() == [1, 1, 1, 1]
    assert choice_by_fold(X, Z, y, folds, scored=odd == 0).tolist() == [0, 0, 0, 0]
    assert (choice_by_fold(X, Z, y, folds, scored=np.ones(n, bool)) == [1, 1, 1, 1]).all()


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    k=st.integers(1, 8),
    rank_drop=st.integers(0, 2),
    hermitian=st.booleans(),
)
def test_solve_min_norm_is_lstsq_per_system(seed, k, rank_drop, hermitian):
    """The batched minimum-norm solve gives numpy's lstsq solution of every system,
    normal equations of full rank or with dependent columns alike."""
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(6, 30, k))
    for j in range(min(rank_drop, k - 1)):  # a column that copies another: rank-deficient
        a[:, :, k - 1 - j] = 2.0 * a[:, :, 0]
    A = a.transpose(0, 2, 1) @ a
    if not hermitian:
        A = A + rng.normal(0, 0.1, A.shape) * (rank_drop == 0)
    b = rng.normal(size=(6, k))
    got = solve_min_norm(A, b, hermitian=hermitian)
    want = np.array([np.linalg.lstsq(A[i], b[i], rcond=1e-12)[0] for i in range(6)])
    scale = np.abs(want).max() + 1.0
    assert np.allclose(got, want, rtol=1e-7, atol=1e-7 * scale)


def test_heldout_fold_without_a_column_predicts_it_as_zero():
    """A column a fold does not fit gets coefficient 0 there, and the other columns the
    fit of the smaller design (the heldout of the design without that column)."""
    X, y, w = _data(3)[:3]
    folds = np.arange(len(y)) % 4
    cols = np.ones((4, X.shape[1]), dtype=bool)
    cols[2, 3] = False
    h = heldout(X, y, folds, w, fit_columns=cols)
    small = heldout(X[:, :3], y, folds, w)
    assert h.coef[2, 3] == 0.0
    assert np.allclose(h.coef[2, :3], small.coef[2], rtol=1e-9)
    assert np.allclose(h.predicted[folds == 2], small.predicted[folds == 2], rtol=1e-9)
