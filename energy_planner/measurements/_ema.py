"""Numba kernel of :func:`energy_planner.measurements.preprocess.ema`.

A module of its own, imported only when a log is smoothed: ``import energy_planner``
stays free of numba, and at module level ``cache=True`` keeps the machine code on disk, so
a process pays ~0.05 s to load it rather than ~1 s to compile it.
"""

import numba
import numpy as np


@numba.njit(cache=True)
def ema_kernel(x, t, tau):  # pragma: no cover - compiled
    """``y[i] = y[i-1] + (1 - exp(-(t[i] - t[i-1]) / tau)) (x[i] - y[i-1])``, ``y[0] = x[0]``."""
    y = np.empty_like(x)
    y[0] = x[0]
    for i in range(1, x.size):
        a = 1.0 - np.exp(-(t[i] - t[i - 1]) / tau)
        y[i] = y[i - 1] + a * (x[i] - y[i - 1])
    return y
