"""Numba helpers of the speed choice: the least of a Laurent polynomial on an interval.

A motion's energy as a function of its ground speed ``v`` is, for a model whose power is
a polynomial in ``v`` (each term homogeneous of an integer degree in the twist), a
Laurent polynomial ``E(v) = sum_k c_k v^e_k`` with integer exponents ``e_k`` in
``[-2, 2]`` (power of degree ``e_k + 1``: the per-second terms give ``v^-1``, the
per-metre terms ``v^0``, the swing losses ``v^1``...). Its least value on
``[lo, hi]`` is at an end or at a root of ``v^3 E'(v)``, a polynomial of degree at most
4: closed form up to degree 2, ``np.roots`` above. These functions are model
independent; the motion kernels (:mod:`energy_planner.energy._motion`) and the
vectorised :func:`energy_planner.energy.speed.best_speed` share them.

They live apart from the kernels so that :mod:`energy_planner.energy.speed` need not
compile a model to minimise.
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True)
def laurent_value(c, exps, v):
    """``sum_k c[k] v^exps[k]`` (``exps`` integers stored as floats)."""
    s = 0.0
    for k in range(c.shape[0]):
        s += c[k] * v ** exps[k]
    return s


@numba.njit(cache=True)
def laurent_argmin(c, exps, lo, hi):
    """The ``v`` in ``[lo, hi]`` (``0 < lo <= hi``) where :func:`laurent_value` is least.

    Candidates: both ends and the real roots inside of ``v^3 E'(v) = sum_k c_k e_k
    v^(e_k + 2)`` (degree at most 4, as ``exps`` lie in ``[-2, 2]``); the least of them
    (the lower end on ties).
    """
    if not hi > lo:
        return lo
    q = np.zeros(5)  # q[d]: coefficient of v^d in v^3 E'(v)
    for k in range(c.shape[0]):
        e = exps[k]
        if e != 0.0:
            q[int(e) + 2] += c[k] * e
    deg = 4
    while deg > 0 and q[deg] == 0.0:
        deg -= 1
    best_v = lo
    best_f = laurent_value(c, exps, lo)
    f = laurent_value(c, exps, hi)
    if f < best_f:
        best_v, best_f = hi, f
    if deg == 0:
        return best_v
    if deg == 1:
        r = -q[0] / q[1]
        if lo < r < hi:
            f = laurent_value(c, exps, r)
            if f < best_f:
                best_v, best_f = r, f
        return best_v
    if deg == 2:
        a, b, cc = q[2], q[1], q[0]
        disc = b * b - 4.0 * a * cc
        if disc >= 0.0:
            sq = math.sqrt(disc)
            # the numerically stable pair of roots
            t = -0.5 * (b + math.copysign(sq, b))
            roots = (t / a, cc / t if t != 0.0 else np.inf)
            for r in roots:
                if lo < r < hi:
                    f = laurent_value(c, exps, r)
                    if f < best_f:
                        best_v, best_f = r, f
        return best_v
    # np.roots, highest power first; complex input: numba's real eigvals refuses
    # complex roots
    poly = np.empty(deg + 1, dtype=np.complex128)
    for d in range(deg + 1):
        poly[d] = q[deg - d]
    for z in np.roots(poly):
        r = z.real
        if abs(z.imag) <= 1e-9 * max(1.0, abs(r)) and lo < r < hi:
            f = laurent_value(c, exps, r)
            if f < best_f:
                best_v, best_f = r, f
    return best_v


@numba.njit(cache=True, parallel=True)
def laurent_argmin_batch(c, exps, lo, hi):
    """:func:`laurent_argmin` of every row of ``c`` (shape ``(n, K)``) on ``[lo[i], hi[i]]``."""
    n = c.shape[0]
    out = np.empty(n)
    for i in numba.prange(n):
        out[i] = laurent_argmin(c[i], exps, lo[i], hi[i])
    return out
