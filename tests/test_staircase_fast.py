"""The staircase's shortcuts give the direct computation's numbers.

The candidate search solves thousands of small normal equations: ``solve_min_norm``
solves a system certified well-conditioned by LU instead of its eigendecomposition, and
``choice_by_fold`` borders the model's statistics with each candidate's column and solves
every candidate's inner systems at once. Each is checked here against the direct
computation written out independently (numpy's ``lstsq`` per system, the candidates one
by one), on random data and on the cases where the shortcut must step aside: dependent
columns, a column a fold does not fit (a zero row and column), a candidate in the span
of the model's columns, a candidate that is 0 on a fold, missing values.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.stats import paired_run_test, solve_min_norm
from energy_planner.stats.heldout import _choice_gains, choice_by_fold
from energy_planner.stats.numerics import solve_bordered

sys.path.insert(0, str(Path(__file__).parent))
from test_diagnosis_units import synth  # noqa: E402


def _lstsq(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.array([np.linalg.lstsq(a, v, rcond=1e-12)[0] for a, v in zip(A, b, strict=True)])


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    k=st.integers(1, 20),
    n=st.sampled_from([1, 5, 20, 40, 200]),
    dependent=st.floats(0.0, 1.0),
    zero=st.floats(0.0, 1.0),
    scale=st.sampled_from([1e-3, 1.0, 1e4]),
)
def test_min_norm_solve_is_lstsq(seed, k, n, dependent, zero, scale):
    """Every system of a stack, well-conditioned or not, gets lstsq's minimum-norm solution:
    stacks of 1 to 200 (the held-out folds, the inner pairs of many candidates), with
    some systems rank-deficient (a column copied) and some with a zero row and column (a
    term the fold does not fit, whose right-hand side is not 0)."""
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(n, 3 * k + 2, k)) * scale
    a[:, :, 0] += 3.0 * scale  # correlated columns, as physical terms are
    dep = rng.random(n) < dependent
    if k > 1:
        a[dep, :, -1] = 2.0 * a[dep, :, 0]
    A = a.transpose(0, 2, 1) @ a
    gone = (rng.random(n) < zero) & (k > 1)
    if k > 1:
        A[gone, 1, :] = 0.0
        A[gone, :, 1] = 0.0
    b = rng.normal(size=(n, k)) * scale
    got = solve_min_norm(A, b, hermitian=True)
    want = _lstsq(A, b)
    tol = 1e-8 * (np.abs(want).max() + 1.0 / scale)
    np.testing.assert_allclose(got, want, rtol=1e-8, atol=tol)
    if k > 1:  # a zero line: no coefficient
        assert np.all(np.abs(got[gone, 1]) <= tol)


def test_min_norm_solve_near_the_cut_off_takes_the_eigendecomposition():
    """A system with condition number 1e9 is far from certified: its solution is lstsq's,
    which keeps every singular value (1e9 < 1e12); one at 1e14 is cut, as lstsq cuts it."""
    rng = np.random.default_rng(3)
    q, _ = np.linalg.qr(rng.normal(size=(6, 6)))
    out = []
    for smallest in (1e-9, 1e-14):
        A = q @ np.diag([1.0, 0.5, 0.3, 0.2, 0.1, smallest]) @ q.T
        A = (A + A.T) / 2
        b = rng.normal(size=6)
        got = solve_min_norm(A[None], b[None], hermitian=True)[0]
        want = np.linalg.lstsq(A, b, rcond=1e-12)[0]
        np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-9 * np.abs(want).max())
        out.append(np.abs(got).max())
    assert out[0] > 1e6 > out[1]  # kept: a huge coefficient; cut: none


def _choice_direct(X, Z, y, folds, w, scored):
    """Candidate by candidate, pair by pair: the inner held-out SSE of ``[X, z]`` and of
    ``X`` over the training folds of every outer fold, each predicted by a weighted
    least-squares fit (columns at unit weighted norm, minimum norm) on the folds that
    are neither."""
    n_folds = int(folds.max()) + 1
    k = X.shape[1]
    gains = np.full((Z.shape[1], n_folds), np.nan)

    def sse(A, y, w, folds, scored, f):
        s = A / np.where(np.sqrt(w @ A**2) == 0, 1.0, np.sqrt(w @ A**2))
        tot = 0.0
        for g in range(n_folds):
            if g == f or not (folds == g).any():
                continue
            tr = (folds != f) & (folds != g)
            sw = np.sqrt(w[tr])
            G = (s[tr] * sw[:, None]).T @ (s[tr] * sw[:, None])
            r = (s[tr] * sw[:, None]).T @ (y[tr] * sw)
            beta = np.linalg.lstsq(G, r, rcond=1e-12)[0]
            te = (folds == g) & scored
            tot += float(np.sum((y[te] - s[te] @ beta) ** 2))
        return tot

    for j in range(Z.shape[1]):
        ok = np.isfinite(Z[:, j])
        if ok.sum() <= k + 1:
            continue
        A = np.column_stack([X[ok], Z[ok, j]])
        args = (y[ok], w[ok], folds[ok], scored[ok])
        for f in range(n_folds):
            s0, s1 = sse(A[:, :k], *args, f), sse(A, *args, f)
            gains[j, f] = 1.0 - s1 / s0 if s0 > 0 else 0.0
    return gains


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    k=st.integers(1, 6),
    m=st.integers(1, 12),
    collinear=st.booleans(),
    nan_share=st.sampled_from([0.0, 0.05]),
    n_folds=st.integers(3, 5),
)
def test_choice_by_fold_equals_candidate_by_candidate(seed, k, m, collinear, nan_share, n_folds):
    """The bordered, stacked choice gives every candidate's gain in every fold as the
    direct computation does, and so the same choice: random model columns (some copies
    of another: rank-deficient inner fits), candidates with signal, in the model's span,
    0 on a fold, and with missing values (their own rows)."""
    rng = np.random.default_rng(seed)
    n = 30 * n_folds
    folds = rng.permutation(np.arange(n) % n_folds)
    X = np.column_stack([np.ones(n), rng.normal(size=(n, k - 1))])
    if collinear and k > 2:
        X[:, -1] = 2.0 * X[:, 1]
    Z = rng.normal(size=(n, m)) * rng.choice([1e-3, 1.0, 1e3], m)
    if m > 1:
        Z[:, 1] = X @ rng.normal(size=k)  # in the span of the model
    if m > 2:
        Z[folds == 0, 2] = 0.0  # no signal on a fold
    Z[rng.random((n, m)) < nan_share] = np.nan
    y = X @ rng.normal(size=k) + 2.0 * np.nan_to_num(Z[:, 0]) + rng.normal(0, 0.5, n)
    w = rng.uniform(0.5, 2.0, n)
    scored = rng.random(n) < 0.85
    got = _choice_gains(X, Z, y, folds, w, scored, n_folds)
    want = _choice_direct(X, Z, y, folds, w, scored)
    assert np.array_equal(np.isnan(got), np.isnan(want))
    np.testing.assert_allclose(got, want, rtol=1e-7, atol=1e-9)
    pick = choice_by_fold(X, Z, y, folds, w, scored=scored)
    for f in range(n_folds):  # the direct choice, where no two gains tie within 1e-7
        g = np.where(np.isnan(want[:, f]), -np.inf, want[:, f])
        top = np.sort(g)[::-1]
        if top[0] <= 1e-7:  # no gain beyond rounding: none chosen, or one of no loss
            assert pick[f] == -1 or g[pick[f]] > -1e-7
        elif len(top) < 2 or top[0] - top[1] > 1e-7:
            assert pick[f] == int(np.argmax(g))


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000), n_runs=st.integers(2, 40))
def test_run_test_by_run_codes_equals_by_run_names(seed, n_runs):
    """The diagnosis groups windows by run codes (integers in the order of the run names)
    instead of the names: the same statistic and p-value."""
    rng = np.random.default_rng(seed)
    names = np.array([f"run_{rng.integers(0, 10**6)}_{i}" for i in range(n_runs)], dtype=object)
    runs = names[rng.integers(0, n_runs, 300)]
    codes = np.unique(runs, return_inverse=True)[1]
    e0 = rng.normal(0, 2, 300)
    e1 = e0 * rng.uniform(0.3, 1.2, 300)
    a, b = paired_run_test(e0, e1, runs), paired_run_test(e0, e1, codes)
    np.testing.assert_equal(a, b)


def _windows(seed: int, n_runs: int):
    """A small windowed campaign (tests/test_diagnosis_units.synth) with a hidden term."""
    from energy_planner.diagnosis import window_data

    return window_data(synth(n_runs=n_runs, seed=seed, effect="temperature_c * speed", coef=20.0))


@settings(max_examples=12, deadline=None)
@given(
    seed=st.integers(0, 1000),
    n_runs=st.integers(10, 30),
    n_splits=st.integers(2, 5),
    extra=st.sampled_from(
        [(), ("temperature_c",), ("temperature_c * speed", "speed ** 2"), ("temperature_c",) * 2]
    ),
    holes=st.booleans(),
    drop=st.floats(0.0, 0.3),
)
def test_window_heldout_equals_the_direct_heldout(seed, n_runs, n_splits, extra, holes, drop):
    """``WindowData.heldout`` (the samples sorted by fold, one product per fold) gives
    ``stats.heldout`` on the stacked per-sample design: the same coefficients,
    predictions, residuals and floored sample predictions, on every window or a subset
    (``ok``), with extra columns, a term missing on some samples, a repeated extra."""
    from energy_planner.calibration.fit import base_terms, identifiable_by_fold
    from energy_planner.calibration.windowdata import _with_kind
    from energy_planner.model import EnergyModel
    from energy_planner.stats import fold_index, heldout

    wd = _windows(seed, n_runs)
    rng = np.random.default_rng(seed)
    if holes:  # a channel missing on some samples (the window mean ignores them)
        v = wd.samples["temperature_c"].to_numpy(float).copy()
        v[rng.random(v.size) < 0.1] = np.nan
        wd.samples["temperature_c"] = v
    terms = list(base_terms(wd.table.assign(motion=wd.table["motion"])))[:6]
    folds = fold_index(wd.runs, n_splits, seed)
    # the windows where every column is finite, some dropped at random
    ok = np.isfinite(wd.columns([*terms, *extra])).all(axis=1) & (rng.random(wd.n_windows) >= drop)
    ok = None if ok.all() else ok
    got = wd.heldout(terms, folds, ok, extra=list(extra))
    # the direct computation: every sample's design stacked, the same fit columns
    cols = list(terms) + list(extra)
    X, means = wd.sample_columns(cols), wd.columns(cols)
    sel = np.ones(wd.n_windows, bool) if ok is None else ok
    keep = sel[wd.key]
    rows = (np.cumsum(sel) - 1)[wd.key[keep]]
    k = len(terms)  # each fold fits the model terms its training windows identify
    fit = identifiable_by_fold(
        EnergyModel(terms=terms), means[sel][:, :k], wd.weights[sel],
        _with_kind(wd.table[sel]), folds[sel],
    )  # fmt: skip
    fit = np.column_stack([fit, np.ones((len(fit), len(extra)), dtype=bool)])
    want = heldout(
        X[keep], wd.power[sel], folds[sel], wd.weights[sel], rows=rows, means=means[sel],
        fit_columns=fit,
    )  # fmt: skip
    np.testing.assert_allclose(got.coef, want.coef, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(got.predicted, want.predicted, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(got.residuals, want.residuals, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(got.sample_predicted, want.sample_predicted, rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(got.folds, folds[sel])


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    k=st.integers(1, 12),
    n_pairs=st.integers(1, 8),
    c=st.integers(1, 12),
    dependent=st.floats(0.0, 1.0),
    zero=st.floats(0.0, 1.0),
    scale=st.sampled_from([1e-3, 1.0, 1e4]),
)
def test_bordered_solve_is_lstsq(seed, k, n_pairs, c, dependent, zero, scale):
    """``solve_bordered`` (one model's normal equations bordered by each candidate) gives
    every bordered system the solution ``solve_min_norm`` gives the full system (lstsq's
    minimum-norm one, tested above): models rank-deficient (a column copied) or with a zero
    row and column, candidates in the model's span, zero, or crossing a zero line of the
    model."""
    rng = np.random.default_rng(seed)
    rows = 3 * k + 4
    a = rng.normal(size=(n_pairs, rows, k)) * scale
    a[:, :, 0] += 3.0 * scale
    if k > 1:
        dep = rng.random(n_pairs) < dependent
        a[dep, :, -1] = 2.0 * a[dep, :, 0]  # rank-deficient: a column copied
    gone = (rng.random(n_pairs) < zero) & (k > 1)
    a[gone, :, -1] = 0.0  # a term these rows do not fit
    z = rng.normal(size=(n_pairs, rows, c)) * scale
    if c > 1:
        z[:, :, 1] = a @ rng.normal(size=k)  # in the model's span
    if c > 2:
        z[:, :, 2] = 0.0  # a candidate with no value on these rows
    G = a.transpose(0, 2, 1) @ a
    U = a.transpose(0, 2, 1) @ z  # (p, k, c)
    if c > 3:
        U[gone, -1, 3] = scale  # a border crossing the model's zero line (not a Gram)
    corner = np.einsum("prc,prc->cp", z, z)
    r = rng.normal(size=(n_pairs, k)) * scale
    s = rng.normal(size=(c, n_pairs)) * scale
    got = solve_bordered(G, r, U, corner, s)
    A = np.empty((c, n_pairs, k + 1, k + 1))
    A[:, :, :k, :k] = G[None]
    A[:, :, :k, k] = A[:, :, k, :k] = U.transpose(2, 0, 1)
    A[:, :, k, k] = corner
    b = np.concatenate([np.broadcast_to(r, (c, n_pairs, k)), s[:, :, None]], axis=2)
    want = solve_min_norm(A, b, hermitian=True)  # lstsq's (test_min_norm_solve_is_lstsq)
    tol = 1e-7 * (np.abs(want).max() + 1.0 / scale)
    np.testing.assert_allclose(got, want, rtol=1e-7, atol=tol)
