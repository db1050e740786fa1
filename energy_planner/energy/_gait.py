"""Template of the gait choice's kernels, appended to a model's motion kernels.

:func:`energy_planner.energy.gait_kernels.gait_source` puts this file after the motion
kernels of ``_motion.py`` (with the model's ``power``) for a model that chooses its gait.
``data`` is :attr:`energy_planner.energy.MotionCost.data` of such a model: the nominal
gait's inputs, then (entry ``IN_GAITS``) one input tuple per gait of the same type, so
that ``motion_full`` and ``motion_best`` run unchanged on each gait's tuple. The gait
index of these functions is one of :attr:`~energy_planner.energy.MotionCost.gaits`,
-1 for the nominal gait.
"""

import math

import numba
import numpy as np

from energy_planner.energy._motion import motion_best, motion_full  # --- motion ---
from energy_planner.energy.gait_kernels import IN_GAITS
from energy_planner.energy.kernels import (
    IN_CHAN,
    IN_TIME_WEIGHT,
    IN_VMAX,
    IN_VMIN,
    N_OUT,
    OUT_DURATION,
    OUT_ENERGY,
)


@numba.njit(cache=True)
def gait_motion(x0, y0, th0, x1, y1, th1, duration, gait, data, out):
    """``motion_full`` of one motion in gait ``gait`` (-1: the nominal gait)."""
    if gait < 0:
        motion_full(x0, y0, th0, x1, y1, th1, duration, data[:IN_GAITS], out)
    else:
        motion_full(x0, y0, th0, x1, y1, th1, duration, data[IN_GAITS][gait], out)


@numba.njit(cache=True)
def gait_best(x0, y0, th0, x1, y1, th1, duration, data, out):
    """The motion in the gait and at the speed that minimise energy + lambda x time.

    With a speed range or a time price: ``motion_best`` in each gait (within that gait's
    speeds, its best speed in closed form), the least kept (the first on ties); returns
    its gait, -1 where every gait breaks a limit (``out`` then holds the last gait's
    code). Without: ``motion_full`` at the nominal speed in the nominal gait, -1.
    ``out`` as ``motion_best`` fills it.
    """
    if not (data[IN_VMAX] > data[IN_VMIN] or data[IN_TIME_WEIGHT] > 0.0):
        motion_full(x0, y0, th0, x1, y1, th1, duration, data[:IN_GAITS], out)
        return -1
    gaits = data[IN_GAITS]
    keep = np.empty(N_OUT)
    best = -1
    for g in range(len(gaits)):
        motion_best(x0, y0, th0, x1, y1, th1, duration, gaits[g], out)
        if math.isfinite(out[OUT_ENERGY]) and (best < 0 or out[OUT_ENERGY] < keep[OUT_ENERGY]):
            best = g
            keep[:] = out[:N_OUT]
    if best >= 0:
        out[:N_OUT] = keep
    return best


@numba.njit(cache=True)
def gait_cost(x0, y0, th0, x1, y1, th1, data):
    """Energy (+ lambda x time) of one motion as :func:`gait_best` chooses it, or ``inf``."""
    out = np.empty(N_OUT + data[IN_CHAN].shape[0])
    gait_best(x0, y0, th0, x1, y1, th1, -1.0, data, out)
    return out[OUT_ENERGY]


@numba.njit(cache=True)
def gait_batch(x0, y0, th0, x1, y1, th1, data):
    """:func:`gait_cost` over arrays."""
    n = x0.shape[0]
    res = np.empty(n)
    out = np.empty(N_OUT + data[IN_CHAN].shape[0])
    for i in range(n):
        gait_best(x0[i], y0[i], th0[i], x1[i], y1[i], th1[i], -1.0, data, out)
        res[i] = out[OUT_ENERGY]
    return res


@numba.njit(cache=True)
def gait_speeds(x, y, th, data):
    """Durations (s) and gaits of consecutive motions as :func:`gait_best` chooses them.

    Shape ``(m, 2)``: the duration (``inf`` for a motion that breaks a limit) and the gait
    (-1: none chosen). Price the poses with both (:func:`gait_table`) for the energy and
    its breakdown.
    """
    m = x.shape[0] - 1
    res = np.empty((max(m, 0), 2))
    out = np.empty(N_OUT + data[IN_CHAN].shape[0])
    for i in range(m):
        g = gait_best(x[i], y[i], th[i], x[i + 1], y[i + 1], th[i + 1], -1.0, data, out)
        res[i, 0] = out[OUT_DURATION] if math.isfinite(out[OUT_ENERGY]) else np.inf
        res[i, 1] = g
    return res


@numba.njit(cache=True)
def gait_table(x, y, th, durations, gaits, data):
    """``path_table`` with each motion in its gait of ``gaits`` (-1: the nominal gait)."""
    m = x.shape[0] - 1
    table = np.empty((max(m, 0), N_OUT))
    out = np.empty(N_OUT + data[IN_CHAN].shape[0])
    for i in range(m):
        gait_motion(x[i], y[i], th[i], x[i + 1], y[i + 1], th[i + 1], durations[i],
                    int(gaits[i]), data, out)  # fmt: skip
        table[i, :] = out[:N_OUT]
    return table
