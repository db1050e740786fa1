"""Weighted least squares, run-clustered errors, folds by run, identifiability, motion classes.

One implementation of the numerics that calibration (:mod:`energy_planner.calibration`),
the model's own fit (:meth:`energy_planner.model.EnergyModel.fit`) and the diagnosis
(:mod:`energy_planner.diagnosis`) share:

* :func:`wls` - weighted least squares on column-scaled regressors, with classical and
  run-clustered (CR1 sandwich) standard errors; :func:`wls_coef` - the coefficients only,
  through the normal equations (cheap when thousands of small fits are made);
  :func:`solve_min_norm` - a stack of small minimum-norm solves in one call;
* folds by run and the held-out evaluation live in :mod:`energy_planner.stats.heldout`;
* :func:`independent_columns`, :func:`vif`, :func:`span_basis`, :func:`span_residual` -
  which columns the data can tell apart;
* :func:`classify_motion` - the motion class of a body twist.

Rows are windows (or samples), columns are model terms; weights are window durations.

Examples
--------
>>> X = np.column_stack([np.ones(6), np.arange(6.0)])
>>> fit = wls(X, 1.0 + 2.0 * np.arange(6.0), clusters=["a", "a", "b", "b", "c", "c"])
>>> np.round(fit.coef, 9).tolist(), fit.rank
([1.0, 2.0], 2)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from energy_planner.errors import FitError

__all__ = [
    "MOTIONS",
    "WLSFit",
    "classify_motion",
    "cluster_covariance",
    "cluster_stderr",
    "independent_columns",
    "solve_min_norm",
    "span_basis",
    "span_residual",
    "vif",
    "wls",
    "wls_coef",
]

#: Motion classes, in the order :func:`classify_motion` assigns them.
MOTIONS: tuple[str, ...] = (
    "forward",
    "backward",
    "lateral_left",
    "lateral_right",
    "turn_left",
    "turn_right",
    "mixed",
)


# --------------------------------------------------------------------------- least squares
def _weights(w: np.ndarray | Sequence[float] | None, n: int) -> np.ndarray:
    if w is None:
        return np.ones(n)
    w = np.asarray(w, dtype=float)
    if w.shape != (n,):
        raise FitError(f"weights have shape {w.shape}, expected ({n},): one weight per row")
    if not np.all(np.isfinite(w)) or np.any(w < 0):
        raise FitError("weights must be finite and non-negative (e.g. window durations in s)")
    return w


def _scaled(X: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``sqrt(w)``, the weighted columns scaled to unit norm, and the scales (0 -> 1)."""
    sw = np.sqrt(w)
    Xw = X * sw[:, None]
    scale = np.linalg.norm(Xw, axis=0)
    scale[scale == 0] = 1.0
    return sw, Xw / scale, scale


@dataclass(frozen=True)
class WLSFit:
    """Result of :func:`wls`.

    Attributes
    ----------
    coef : numpy.ndarray
        Coefficients, shape ``(k,)`` (minimum norm when the columns are dependent).
    stderr : numpy.ndarray
        Classical standard errors ``sqrt(diag(sigma^2 (X^T W X)^-1))`` (windows taken as
        independent); NaN where the design is rank-deficient.
    stderr_by_run : numpy.ndarray or None
        Run-clustered (CR1 sandwich) standard errors when ``clusters`` was given.
    resid : numpy.ndarray
        Unweighted residuals ``y - X coef``.
    sigma2 : float
        Weighted residual variance ``sum(w r^2) / (n - rank)``.
    rank : int
        Numerical rank of the column-scaled weighted design.
    condition_number : float
        Of the column-scaled weighted design (inf when rank-deficient).
    """

    coef: np.ndarray
    stderr: np.ndarray
    stderr_by_run: np.ndarray | None
    resid: np.ndarray
    sigma2: float
    rank: int
    condition_number: float


def wls(
    X: np.ndarray,
    y: np.ndarray,
    w: np.ndarray | Sequence[float] | None = None,
    *,
    clusters: Sequence | np.ndarray | None = None,
    rcond: float = 1e-10,
) -> WLSFit:
    """Weighted least squares ``y ~ X`` with classical and run-clustered standard errors.

    Columns are scaled to unit weighted norm before solving (terms in N, N m and W live on
    very different scales), and the solution is the minimum-norm one when columns are
    dependent (check :func:`independent_columns` first to name them).

    Parameters
    ----------
    X : numpy.ndarray
        Design, shape ``(n, k)``.
    y : numpy.ndarray
        Target, shape ``(n,)``.
    w : array-like, optional
        Non-negative row weights (window durations); equal by default.
    clusters : array-like, optional
        Cluster label of each row (the run): adds ``stderr_by_run``, the CR1 sandwich
        ``G/(G-1) B^-1 (sum_g s_g s_g^T) B^-1`` with ``B = X^T W X`` and run scores
        ``s_g = X_g^T W_g r_g``. Windows of one run share slip, IMU bias and ground, so this
        is the honest error when it is the larger.
    rcond : float
        Relative singular-value cut-off of the scaled design.

    Returns
    -------
    WLSFit

    Examples
    --------
    >>> X = np.ones((4, 1)); y = np.array([1.0, 1.0, -1.0, -1.0])
    >>> f = wls(X, y, clusters=np.array(["a", "a", "b", "b"]))
    >>> float(f.coef[0]), float(f.stderr_by_run[0])
    (0.0, 1.0)
    """
    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float)
    n, k = X.shape
    if y.shape != (n,):
        raise FitError(f"target has shape {y.shape}, expected ({n},): one value per row")
    w = _weights(w, n)
    sw, Xs, scale = _scaled(X, w)
    yw = y * sw
    U, sv, Vt = np.linalg.svd(Xs, full_matrices=False)
    keep = sv > rcond * (sv[0] if sv.size else 1.0)
    rank = int(keep.sum())
    inv_sv = np.where(keep, 1.0 / np.where(keep, sv, 1.0), 0.0)
    beta_s = Vt.T @ (inv_sv * (U.T @ yw))
    coef = beta_s / scale
    resid = y - X @ coef
    dof = max(n - rank, 1)
    sigma2 = float(np.sum(w * resid**2)) / dof
    if rank == k:
        cov_s = (Vt.T * inv_sv**2) @ Vt
        stderr = np.sqrt(np.clip(np.diag(cov_s) * sigma2, 0, None)) / scale
        cond = float(sv[0] / sv[-1])
    else:
        stderr = np.full(k, np.nan)
        cond = float("inf")
    by_run = None if clusters is None else cluster_stderr(X, resid, w, clusters)
    return WLSFit(coef, stderr, by_run, resid, sigma2, rank, cond)


def wls_coef(
    X: np.ndarray, y: np.ndarray, w: np.ndarray | Sequence[float] | None = None
) -> np.ndarray:
    """Coefficients of weighted least squares ``y ~ X`` (column-scaled, minimum norm).

    Solved through the normal equations of the unit-norm columns: for a dozen well-scaled
    columns a ``k x k`` solve is much cheaper than an SVD of the ``n x k`` design, which
    matters when thousands of fits are made (the diagnosis' candidate search).

    Examples
    --------
    >>> x = np.column_stack([np.ones(4), [0.0, 1, 2, 3]])
    >>> np.round(wls_coef(x, np.array([1.0, 3, 5, 7])), 9).tolist()
    [1.0, 2.0]
    """
    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float)
    sw, Xs, scale = _scaled(X, _weights(w, len(y)))
    return np.linalg.lstsq(Xs.T @ Xs, Xs.T @ (y * sw), rcond=1e-12)[0] / scale


#: A symmetric system of :func:`solve_min_norm` whose smallest eigenvalue is certified above
#: this share of its trace (so of its largest eigenvalue: condition number below 1e6) is
#: solved by LU instead of the eigendecomposition: every eigenvalue is far above the
#: minimum-norm cut-off, so both give ``A^-1 b``, to within ``1e6 * eps`` of each other
#: (an 18 x 18 eigendecomposition costs ten solves). The certificate: the Cholesky
#: factorization of ``A - CERTIFIED * trace(A) * I`` exists.
CERTIFIED = 1e-6


def solve_min_norm(
    A: np.ndarray, b: np.ndarray, rcond: float = 1e-12, *, hermitian: bool = False
) -> np.ndarray:
    """Minimum-norm least-squares solutions of a stack of small systems ``A[i] x = b[i]``.

    The same solution as ``numpy.linalg.lstsq(A[i], b[i], rcond=rcond)[0]`` for each
    system (singular values at most ``rcond`` times the largest count as zero), from one
    batched SVD: the held-out evaluation solves thousands of ``k x k`` normal equations
    (one per fold and candidate), where a call of ``lstsq`` each costs far more in Python
    and LAPACK set-up than in arithmetic. A zero row and column (a term a fold does not
    fit) gets a zero coefficient, as the smaller system without it would give.

    Parameters
    ----------
    A : numpy.ndarray
        Shape ``(..., m, k)``.
    b : numpy.ndarray
        Shape ``(..., m)``.
    rcond : float
        Relative cut-off of the singular values.
    hermitian : bool
        ``A`` is symmetric (normal equations): an eigendecomposition stands in for the
        SVD (the singular values are the absolute eigenvalues), about twice as fast; and a
        system certified well-conditioned (:data:`CERTIFIED`, its zero rows and columns
        aside) is solved by LU, ten times faster, to the same solution.

    Returns
    -------
    numpy.ndarray
        Shape ``(..., k)``.

    Examples
    --------
    >>> A = np.array([[[2.0, 0.0], [0.0, 0.0]], [[1.0, 1.0], [1.0, 1.0]]])
    >>> b = np.array([[4.0, 0.0], [2.0, 2.0]])
    >>> solve_min_norm(A, b).round(9).tolist()
    [[2.0, 0.0], [1.0, 1.0]]
    >>> solve_min_norm(A, b, hermitian=True).round(9).tolist()
    [[2.0, 0.0], [1.0, 1.0]]
    """
    A = np.asarray(A, dtype=float)
    b = np.asarray(b, dtype=float)
    if A.shape[-1] == 0:
        return np.zeros(A.shape[:-2] + (0,))
    if hermitian:
        k = A.shape[-1]
        shape = A.shape[:-2]
        A2, b2 = A.reshape(-1, k, k), b.reshape(-1, k)
        if CERTIFIED <= rcond:  # the certificate would not keep clear of the cut-off
            return _solve_eigh(A2, b2, rcond).reshape(*shape, k)
        zero = _zero_lines(A2)
        M = _padded(A2, zero)
        fast = _certified(M)
        x = np.empty(b2.shape)
        if fast.all():
            x = _solve_padded(M, b2, zero)
        elif fast.any():
            x[fast] = _solve_padded(M[fast], b2[fast], zero[fast])
        slow = ~fast
        if slow.any():
            x[slow] = _solve_eigh(A2[slow], b2[slow], rcond)
        return x.reshape(*shape, k)
    u, sv, vt = np.linalg.svd(A, full_matrices=False)
    keep = sv > rcond * sv[..., :1]
    inv = np.where(keep, 1.0 / np.where(keep, sv, 1.0), 0.0)
    ub = np.einsum("...ji,...j->...i", u, b)
    return np.einsum("...ji,...j->...i", vt, inv * ub)


def solve_bordered(
    G: np.ndarray, r: np.ndarray, U: np.ndarray, corner: np.ndarray, s: np.ndarray
) -> np.ndarray:
    """:func:`solve_min_norm` (``hermitian=True``) of symmetric systems that share a block.

    System ``(j, p)`` is ``[[G[p], U[p, :, j]], [U[p, :, j], corner[j, p]]]`` with the
    right-hand side ``[r[p], s[j, p]]``: one model's normal equations ``G[p]`` bordered by
    each candidate column ``j`` (the choice by fold solves one per candidate and pair of
    folds). Where a system is certified well-conditioned (as :func:`solve_min_norm`
    certifies, here through the shared block: the Cholesky factorization of ``G[p]``
    shifted by :data:`CERTIFIED` times the largest trace of its systems exists, and so
    does the bordered one's, whose last pivot is the shifted Schur complement
    ``corner - U^T (G - shift)^-1 U``), its solution is ``A^-1 b`` from one solve of
    ``G[p]`` for every candidate (the Schur complement); the other systems go to
    :func:`solve_min_norm`. The same solutions to rounding, at a fraction of the cost of
    factorizing every bordered system.

    Parameters
    ----------
    G : numpy.ndarray
        Shape ``(p, k, k)``, symmetric.
    r : numpy.ndarray
        Shape ``(p, k)``.
    U : numpy.ndarray
        Shape ``(p, k, c)``: the borders.
    corner, s : numpy.ndarray
        Shape ``(c, p)``: the borders' diagonal entries and right-hand sides.

    Returns
    -------
    numpy.ndarray
        Shape ``(c, p, k + 1)``.

    Examples
    --------
    >>> G = np.array([[[2.0, 0.0], [0.0, 1.0]]]); r = np.array([[2.0, 1.0]])
    >>> U = np.array([[[1.0, 0.0], [0.0, 0.0]]])          # two candidates
    >>> corner = np.array([[2.0], [0.0]]); s = np.array([[3.0], [0.0]])
    >>> solve_bordered(G, r, U, corner, s).round(9).tolist()  # the second: a zero column
    [[[0.333333333, 1.0, 1.333333333]], [[1.0, 1.0, 0.0]]]
    """
    G, r, U = (np.asarray(a, dtype=float) for a in (G, r, U))
    corner, s = np.asarray(corner, dtype=float), np.asarray(s, dtype=float)
    p, k, c = U.shape
    out = np.empty((c, p, k + 1))
    zero = _zero_lines(G)  # (p, k): a term the pair's training rows do not fit
    # a border that is not 0 on a zero line of G: that line is not 0 in the bordered system
    crossed = np.any((U != 0.0) & zero[:, :, None], axis=1).T  # (c, p)
    U0 = np.where(zero[:, :, None], 0.0, U)
    M = _padded(G, zero)
    tr = np.trace(G, axis1=-2, axis2=-1)
    shift = CERTIFIED * (tr + np.max(corner, axis=0, initial=0.0))  # (p,): the largest
    S = M - shift[:, None, None] * np.eye(k)
    fine = np.isfinite(S).all(axis=(-2, -1)) & (tr > 0)
    fine &= _cholesky_exists(np.where(fine[:, None, None], S, np.eye(k)))
    ok = np.zeros((c, p), dtype=bool)
    if fine.any():
        Uf = U0[fine]
        rhs = np.concatenate([np.where(zero, 0.0, r)[fine][:, :, None], Uf], axis=2)
        shifted = np.linalg.solve(S[fine], Uf)  # (q, k, c)
        schur_shifted = corner[:, fine] - shift[fine] - np.einsum("qkc,qkc->cq", Uf, shifted)
        sol = np.linalg.solve(M[fine], rhs)  # (q, k, c + 1): G^-1 r, G^-1 U
        a, V = sol[:, :, 0], sol[:, :, 1:]
        schur = corner[:, fine] - np.einsum("qkc,qkc->cq", Uf, V)
        good = np.isfinite(schur_shifted) & (schur_shifted > 0) & (schur > 0)
        good &= ~crossed[:, fine]
        bz = (s[:, fine] - np.einsum("qkc,qk->cq", Uf, a)) / np.where(good, schur, 1.0)
        bx = a[None] - V.transpose(2, 0, 1) * bz[:, :, None]  # (c, q, k)
        bx[:, zero[fine]] = 0.0
        idx = np.flatnonzero(fine)
        out[:, idx, :k] = bx
        out[:, idx, k] = bz
        ok[:, idx] = good
    if not ok.all():  # the rest as solve_min_norm solves any symmetric system
        jj, pp = np.nonzero(~ok)
        A = np.empty((jj.size, k + 1, k + 1))
        A[:, :k, :k] = G[pp]
        A[:, :k, k] = A[:, k, :k] = U[pp, :, jj]
        A[:, k, k] = corner[jj, pp]
        b = np.concatenate([r[pp], s[jj, pp][:, None]], axis=1)
        out[jj, pp] = solve_min_norm(A, b, hermitian=True)
    return out


def _solve_eigh(A: np.ndarray, b: np.ndarray, rcond: float) -> np.ndarray:
    """Minimum-norm solutions of symmetric systems from their eigendecompositions."""
    ev, v = np.linalg.eigh(A)
    sv = np.abs(ev)
    keep = sv > rcond * sv.max(axis=-1, keepdims=True)
    inv = np.where(keep, 1.0 / np.where(keep, ev, 1.0), 0.0)
    vb = np.einsum("...ji,...j->...i", v, b)
    return np.einsum("...ij,...j->...i", v, inv * vb)


def _zero_lines(A: np.ndarray) -> np.ndarray:
    """``(n, k)``: the rows (and columns: ``A`` is symmetric) of each system that are 0."""
    return ~np.any(A != 0.0, axis=-1)


def _padded(A: np.ndarray, zero: np.ndarray) -> np.ndarray:
    """``A`` with a zero line's diagonal set to the trace: decoupled, well-conditioned."""
    M = A.copy()
    if zero.any():
        i, j = np.nonzero(zero)
        M[i, j, j] = np.trace(A, axis1=-2, axis2=-1)[i]
    return M


def _certified(M: np.ndarray) -> np.ndarray:
    """Which symmetric systems (:func:`_padded`) :func:`_solve_padded` solves as the eigh path.

    The part of a system off its zero lines must have its smallest eigenvalue above
    :data:`CERTIFIED` times its trace (its largest eigenvalue at most): the Cholesky
    factorization of ``M`` minus so much of the identity exists (a zero line, padded
    with the trace, is decoupled and far above the shift). Then no eigenvalue is near the
    cut-off, and the minimum-norm solution is ``A^-1 b`` there, 0 on the zero lines.
    """
    n, k = M.shape[0], M.shape[-1]
    tr = np.trace(M, axis1=-2, axis2=-1)
    ok = (tr > 0) & np.isfinite(tr) & np.isfinite(M).all(axis=(-2, -1))
    S = M.copy()
    d = np.einsum("nii->ni", S)  # a view: the diagonals, shifted in place
    d -= (CERTIFIED * np.where(ok, tr, 0.0))[:, None]
    if not ok.all():
        S[~ok] = np.eye(k)  # left to the eigh path (not certified)
    try:
        np.linalg.cholesky(S)
        return ok
    except np.linalg.LinAlgError:
        pass
    if n > 32:  # many systems: factorize them side by side, column by column
        return _cholesky_exists(S) & ok
    # a few: tell the ones that fail by halves
    out = np.zeros(n, dtype=bool)
    todo = [np.arange(n)]
    while todo:
        idx = todo.pop()
        try:
            np.linalg.cholesky(S[idx])
            out[idx] = True
        except np.linalg.LinAlgError:
            if len(idx) > 1:
                h = len(idx) // 2
                todo += [idx[:h], idx[h:]]
    return out & ok


def _cholesky_exists(S: np.ndarray) -> np.ndarray:
    """Whether each symmetric matrix of the stack ``S`` has a Cholesky factorization."""
    n, k = S.shape[0], S.shape[-1]
    L = np.zeros_like(S)
    ok = np.ones(n, dtype=bool)
    for j in range(k):
        row = L[:, j, :j]
        d = S[:, j, j] - np.einsum("ni,ni->n", row, row)
        ok &= d > 0
        ljj = np.sqrt(np.where(d > 0, d, 1.0))
        L[:, j, j] = ljj
        if j + 1 < k:
            below = S[:, j + 1 :, j] - np.einsum("nri,ni->nr", L[:, j + 1 :, :j], row)
            L[:, j + 1 :, j] = below / ljj[:, None]
    return ok


def _solve_padded(M: np.ndarray, b: np.ndarray, zero: np.ndarray) -> np.ndarray:
    """``A^-1 b`` off the zero lines, 0 on them, from the padded systems ``M``."""
    x = np.linalg.solve(M, np.where(zero, 0.0, b)[..., None])[..., 0]
    x[zero] = 0.0
    return x


def cluster_stderr(
    X: np.ndarray, resid: np.ndarray, w: np.ndarray | None, clusters: Sequence | np.ndarray
) -> np.ndarray:
    """Cluster-robust (CR1) standard errors of weighted least squares, clusters = runs.

    ``V = G/(G-1) B^-1 (sum_g s_g s_g^T) B^-1``, ``B = X^T W X``, ``s_g = X_g^T W_g r_g``.
    NaN with fewer than two clusters.

    Examples
    --------
    >>> X = np.ones((4, 1)); r = np.array([1.0, 1.0, -1.0, -1.0])
    >>> cluster_stderr(X, r, None, np.array(["a", "a", "b", "b"])).tolist()
    [1.0]
    """
    return np.sqrt(np.clip(np.diag(cluster_covariance(X, resid, w, clusters)), 0, None))


def cluster_covariance(
    X: np.ndarray, resid: np.ndarray, w: np.ndarray | None, clusters: Sequence | np.ndarray
) -> np.ndarray:
    """The cluster-robust (CR1) covariance of weighted least squares, clusters = runs.

    The matrix whose diagonal :func:`cluster_stderr` reports (squared); all NaN with fewer
    than two clusters.

    Examples
    --------
    >>> X = np.ones((4, 1)); r = np.array([1.0, 1.0, -1.0, -1.0])
    >>> cluster_covariance(X, r, None, np.array(["a", "a", "b", "b"])).tolist()
    [[1.0]]
    """
    X = np.asarray(X, dtype=float)
    w = _weights(w, X.shape[0])
    B = X.T @ (X * w[:, None])
    Binv = np.linalg.pinv(B)
    labels = np.asarray(clusters).astype(str)
    import pandas as pd  # not at import: the energy path loads this module without it

    scores = pd.DataFrame(X * (w * np.asarray(resid, float))[:, None]).groupby(labels).sum()
    g = scores.shape[0]
    if g < 2:
        return np.full((X.shape[1], X.shape[1]), np.nan)
    s = scores.to_numpy()
    return Binv @ (s.T @ s * (g / (g - 1))) @ Binv


# --------------------------------------------------------------------------- identifiability
def span_basis(X: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the column span of ``X`` (from its SVD)."""
    X = np.asarray(X, dtype=float)
    if X.shape[1] == 0:
        return np.zeros((X.shape[0], 0))
    u, sv, _ = np.linalg.svd(X, full_matrices=False)
    return u[:, sv > sv[0] * 1e-10] if sv.size and sv[0] > 0 else u[:, :0]


def span_residual(z: np.ndarray, X: np.ndarray, basis: np.ndarray | None = None) -> float:
    """Relative residual ``||z - X b|| / ||z||`` of the projection of ``z`` on ``X``'s span.

    0: ``z`` is a combination of the columns of ``X`` (the data cannot tell it apart);
    1: orthogonal to them. ``basis`` (:func:`span_basis` of ``X``) saves the decomposition
    when many ``z`` are tested against the same ``X``.

    Examples
    --------
    >>> x = np.column_stack([np.ones(4), [0.0, 1, 2, 3]])
    >>> round(span_residual(np.array([1.0, 3, 5, 7]), x), 6)
    0.0
    """
    z = np.asarray(z, dtype=float)
    norm = float(np.linalg.norm(z))
    if norm == 0.0:
        return 0.0
    q = span_basis(X) if basis is None else basis
    return float(np.linalg.norm(z - q @ (q.T @ z)) / norm)


def vif(X: np.ndarray, w: np.ndarray | Sequence[float] | None = None) -> np.ndarray:
    """Uncentred variance inflation factor of each column (inf when in the others' span).

    ``VIF_j = 1 / (1 - R_j^2)`` with ``R_j^2`` from regressing (weighted) column ``j`` on
    the others without intercept: ``1 / span_residual(x_j, others)**2``.

    Examples
    --------
    >>> X = np.column_stack([np.ones(4), [0.0, 1, 2, 3], [0.0, 2, 4, 6]])
    >>> vif(X)[2] == np.inf, float(vif(X[:, :1])[0])
    (np.True_, 1.0)
    """
    X = np.asarray(X, dtype=float)
    Xw = X * np.sqrt(_weights(w, X.shape[0]))[:, None]
    k = X.shape[1]
    out = np.full(k, np.inf)
    for j in range(k):
        if not np.any(Xw[:, j]):
            continue
        if k == 1:
            out[j] = 1.0
            continue
        rel = span_residual(Xw[:, j], np.delete(Xw, j, axis=1))
        out[j] = np.inf if rel**2 <= 1e-14 else 1.0 / rel**2
    return out


def independent_columns(
    X: np.ndarray,
    w: np.ndarray | Sequence[float] | None = None,
    *,
    tol: float = 1e-6,
) -> tuple[np.ndarray, dict[int, list[int]]]:
    """Which columns the data can tell apart, taken in order (earlier columns win).

    Column ``j`` is kept when its (weighted) relative residual after projection on the
    kept earlier columns (:func:`span_residual`) exceeds ``tol``; otherwise it is a
    combination of them and is not identifiable. Zero columns are never kept.

    A column far from the kept ones' span (a relative residual above
    :data:`CLEARLY_INDEPENDENT` on an orthonormal basis of the kept columns grown one
    column at a time) is kept without the decomposition of :func:`span_residual`: that
    residual cannot then be at or below ``tol`` (see :data:`CLEARLY_INDEPENDENT`). The
    others are decided by :func:`span_residual` itself, so the answer is the same.

    Returns
    -------
    keep : numpy.ndarray of bool
        Kept (identifiable) columns.
    explained_by : dict
        Dropped column -> the kept columns that carry it (largest share first; empty for a
        zero column).

    Examples
    --------
    >>> X = np.column_stack([np.ones(4), [0.0, 1, 2, 3], [1.0, 2, 3, 4], np.zeros(4)])
    >>> keep, why = independent_columns(X)
    >>> keep.tolist(), why
    ([True, True, False, False], {2: [1, 0], 3: []})
    """
    X = np.asarray(X, dtype=float)
    Xw = X * np.sqrt(_weights(w, X.shape[0]))[:, None]
    n, k = Xw.shape
    keep = np.zeros(k, dtype=bool)
    why: dict[int, list[int]] = {}
    # an orthonormal basis of the kept columns (two Gram-Schmidt passes per column), while
    # every kept column stood clear of the span before it (else it is no longer used)
    quick = tol <= 1e-4
    Q = np.empty((n, k))
    m = 0
    for j in range(k):
        z = Xw[:, j]
        if not np.any(z):
            why[j] = []
            continue
        r = z
        if quick:
            for _ in range(2):
                r = r - Q[:, :m] @ (Q[:, :m].T @ r)
            rel = float(np.linalg.norm(r) / np.linalg.norm(z))
            if rel > CLEARLY_INDEPENDENT:  # NaN is not: decided below
                keep[j] = True
                Q[:, m] = r / np.linalg.norm(r)
                m += 1
                continue
        kept = np.flatnonzero(keep)
        if kept.size == 0 or span_residual(z, Xw[:, kept]) > tol:
            keep[j] = True
            quick = False  # kept, though close to the span: the basis stops here
            continue
        coef = np.linalg.lstsq(Xw[:, kept], z, rcond=None)[0]
        share = np.abs(coef) * np.linalg.norm(Xw[:, kept], axis=0)
        why[j] = [int(kept[i]) for i in np.argsort(share)[::-1] if share[i] > 1e-9 * share.max()]
    return keep, why


#: :func:`independent_columns` keeps a column whose relative residual on an orthonormal
#: basis of the kept columns exceeds this without asking :func:`span_residual`, when its
#: ``tol`` is at most 1e-4. Both residuals measure the distance to the kept columns'
#: span: the basis's to within ~1e-13 (every column it holds stood this far from the
#: span before it, so its direction carries at most ``eps / 1e-3`` of rounding), the
#: SVD's to within ~3e-6 (its directions of singular values near its ``1e-10`` cut-off
#: are rotated by up to ``eps / 1e-10``; a direction it cuts only raises its residual),
#: so the SVD's residual then exceeds ``1e-3 - 3e-6 > 1e-4 >= tol``: the same decision,
#: for a fraction of the cost (a model's columns are rarely near each other's span).
CLEARLY_INDEPENDENT = 1e-3


# --------------------------------------------------------------------------- motion
def classify_motion(vx, vy, wz, *, length: float = 0.5, ratio: float = 0.3) -> np.ndarray:
    """Motion class of each body twist (per sample or per window mean).

    The components ``(|vx|, |vy|, length * |wz|)`` (m/s; ``length`` in m turns a yaw rate
    into the speed of a point ``length`` from the yaw axis) are compared: the largest is
    the motion when every other component is at most ``ratio`` times it
    (``forward``/``backward`` by the sign of vx, ``lateral_left``/``lateral_right`` by vy,
    ``turn_left``/``turn_right`` by wz, counter-clockwise = left); otherwise, and when the
    robot stands still (all components 0), ``mixed``.

    Examples
    --------
    >>> classify_motion([0.3, -0.3, 0.0, 0.02, 0.3, 0.0], [0.0, 0.0, -0.2, 0.0, 0.2, 0.0],
    ...                 [0.01, 0.0, 0.0, 0.5, 0.0, 0.0]).tolist()
    ['forward', 'backward', 'lateral_right', 'turn_left', 'mixed', 'mixed']
    """
    vx, vy, wz = np.broadcast_arrays(
        *(np.atleast_1d(np.asarray(a, dtype=float)) for a in (vx, vy, wz))
    )
    c = np.stack([np.abs(vx), np.abs(vy), length * np.abs(wz)], axis=-1)
    k = np.argmax(c, axis=-1)
    top = np.take_along_axis(c, k[..., None], axis=-1)[..., 0]
    second = np.sort(c, axis=-1)[..., 1]
    sign = np.choose(k, [vx, vy, wz]) >= 0
    names = np.array(MOTIONS, dtype=object)
    out = names[2 * k + np.where(sign, 0, 1)]
    out[(second > ratio * top) | (top <= 0)] = "mixed"
    return out.astype(object)
