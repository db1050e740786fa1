"""Wilcoxon's signed-rank test without ``scipy.stats`` (whose import costs ~1 CPU s).

:func:`signed_rank_test` gives the numbers of ``scipy.stats.wilcoxon(d, alternative=...,
method=..., zero_method="wilcox", correction=False)`` (scipy 1.17: the same statistic,
standardised statistic and p-value, to the last bit; ``tests/test_stats.py`` checks it
against scipy on random, tied and zero differences) from ``scipy.special`` and numpy:

- ``r_plus``: the sum of the ranks (ties averaged) of ``|d|`` over the positive
  differences, zeros dropped;
- ``z``: ``(r_plus - n (n + 1) / 4) / sqrt((n (n + 1) (2 n + 1) - sum(t^3 - t) / 2) / 24)``
  over the ``n`` nonzero differences with tie groups of sizes ``t``;
- the p-value: from the normal distribution of ``z`` (``"asymptotic"``), from the exact
  null distribution of ``r_plus`` over the ``2 ** n`` sign patterns (``"exact"``, which
  assumes no ties or zeros), or (``"auto"``) exact without ties and zeros for at most 50
  differences, else a permutation test over every sign pattern for at most 13, else the
  normal approximation.
"""

from __future__ import annotations

import functools
import math

import numpy as np

__all__ = ["signed_rank_test"]

#: ``"auto"``: at most this many differences for an exact test ...
AUTO_EXACT_MAX = 50
#: ... and with ties or zeros, at most this many for a test over every sign pattern.
AUTO_PERMUTATION_MAX = 13


def _ranks(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Average ranks of ``a`` (1-based) and the sizes of its groups of equal values."""
    order = np.argsort(a, kind="stable")
    y = a[order]
    first = np.empty(max(y.size, 1), dtype=bool)  # np.r_[True, y[:-1] != y[1:]]
    first[0] = True
    np.not_equal(y[:-1], y[1:], out=first[1 : y.size])
    starts = np.flatnonzero(first)
    counts = np.diff(starts, append=y.size)
    mid = (starts + 1) + (counts - 1) / 2.0
    r = np.empty(a.size)
    r[order] = np.repeat(mid, counts)
    return r, counts


@functools.lru_cache(maxsize=64)
def _null_counts(n: int) -> np.ndarray:
    """Probabilities of ``r_plus = 0 .. n (n + 1) / 2`` under the null (no ties, no zeros).

    Cached (read-only): the diagnosis tests hundreds of candidates on the same runs.
    """
    c = np.ones(1)
    for k in range(1, n + 1):
        prev = c
        c = np.zeros(k * (k + 1) // 2 + 1)
        m = len(prev)
        c[:m] = prev * 0.5
        c[-m:] += prev * 0.5
    c.flags.writeable = False
    return c


def _exact_p(r_plus: float, n: int, alternative: str) -> float:
    pmf = _null_counts(n)
    mean = n * (n + 1) / 4

    def sf(k: int) -> float:  # P(R >= k)
        return float(pmf[k:].sum()) if k <= mean else float(1 - pmf[:k].sum())

    def cdf(k: int) -> float:  # P(R <= k)
        return float(pmf[: k + 1].sum()) if k <= mean else float(1 - pmf[k + 1 :].sum())

    if alternative == "greater":
        return sf(int(math.floor(r_plus)))
    if alternative == "less":
        return cdf(int(math.ceil(r_plus)))
    return float(min(1.0, 2 * min(sf(int(math.floor(r_plus))), cdf(int(math.ceil(r_plus))))))


def _permutation_p(d: np.ndarray, ranks: np.ndarray, r_plus: float, alternative: str) -> float:
    """The p-value of ``r_plus`` over all ``2 ** len(d)`` sign patterns of ``d``."""
    n = d.size
    signs = ((np.arange(2**n)[:, None] >> np.arange(n)) & 1).astype(bool)
    pos = np.where(signs, d > 0, d < 0)  # the pattern's positive differences
    null = (pos * ranks).sum(axis=1)
    gamma = abs(np.finfo(float).eps * 100 * r_plus)
    less = np.count_nonzero(null <= r_plus + gamma) / 2.0**n
    greater = np.count_nonzero(null >= r_plus - gamma) / 2.0**n
    p = {"less": less, "greater": greater}.get(alternative, 2 * min(less, greater))
    return float(min(max(p, 0.0), 1.0))


def signed_rank_test(
    d, alternative: str = "two-sided", method: str = "auto"
) -> tuple[float, float, float]:
    """Wilcoxon's signed-rank test of the differences ``d`` (zeros dropped).

    Parameters
    ----------
    d : array_like
        Paired differences.
    alternative : {"two-sided", "greater", "less"}
        ``"greater"``: the differences lean positive.
    method : {"auto", "asymptotic", "exact"}
        As ``scipy.stats.wilcoxon`` (module docstring).

    Returns
    -------
    tuple
        ``(r_plus, z, p)``: the sum of the positive differences' ranks, the standardised
        statistic (normal approximation, for every method) and the p-value.

    Examples
    --------
    Six differences, five of them positive: ``r_plus = 21 - 3``, and 5 of the ``2 ** 6``
    sign patterns leave ranks summing to at most 3 negative ({}, {1}, {2}, {3}, {1, 2}).

    >>> r, z, p = signed_rank_test([1.0, 2, -3, 4, 5, 6], "greater", "exact")
    >>> r, p == 5 / 64, round(z, 4)
    (18.0, True, 1.5724)
    """
    d = np.asarray(d, float).ravel()
    if alternative not in ("two-sided", "greater", "less"):
        raise ValueError(f"alternative must be two-sided, greater or less, got {alternative!r}")
    if method not in ("auto", "asymptotic", "exact"):
        raise ValueError(f"method must be auto, asymptotic or exact, got {method!r}")
    n_all = d.size
    if n_all == 0:
        return math.nan, math.nan, math.nan
    n_zero = int(np.count_nonzero(d == 0))
    if method == "auto" and n_all > AUTO_EXACT_MAX:
        method = "asymptotic"
    nz = d != 0
    r_nz, counts = _ranks(np.abs(d[nz]))
    ranks = np.zeros(n_all)
    ranks[nz] = r_nz
    r_plus = float(np.sum((d > 0) * ranks))
    n = float(nz.sum())
    has_ties = bool(np.any(counts > 1))
    mean = n * (n + 1.0) * 0.25
    var = n * (n + 1.0) * (2.0 * n + 1.0)
    tie = float(np.sum(counts.astype(float) ** 3 - counts))
    se = math.sqrt((var - tie / 2) / 24)
    z = (r_plus - mean) / se if se > 0 else math.nan
    if method == "auto":
        if not (has_ties or n_zero > 0):
            method = "exact"
        elif n_all <= AUTO_PERMUTATION_MAX:
            return r_plus, z, _permutation_p(d, ranks, r_plus, alternative)
        else:
            method = "asymptotic"
    if method == "exact":
        return r_plus, z, _exact_p(r_plus, int(n), alternative)
    from scipy.special import ndtr

    p = {"greater": ndtr(-z), "less": ndtr(z)}.get(alternative, 2 * ndtr(-abs(z)))
    return r_plus, z, float(p)
