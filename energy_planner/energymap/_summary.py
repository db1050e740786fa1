"""The summary bands of an energy map from its ``best_*`` bands, one pass over the cells.

Compiled with numba (``prange`` over rows, cached on disk), so that the four summary
bands cost one read of ``best`` instead of NumPy's six whole-block passes and their
temporaries; the same function is in the model's precompiled map module
(:func:`energy_planner.energy.kernels.precompiled_map_module`, as ``summary``), which a
map uses when it is built. The values are NumPy's (see :func:`summary_bands`): the test
compares them with the NumPy expressions on random blocks with NaN and inf.
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, parallel=True, error_model="numpy")  # x / 0: inf or NaN
def _summary(best, heading_deg, out):  # pragma: no cover - compiled
    nh, rows, cols = best.shape
    nan32 = np.float32(np.nan)
    inf32 = np.float32(np.inf)
    for r in numba.prange(rows):
        # heading by heading along the row: each band's row is read contiguously
        mn = best[0, r].copy()
        mx = best[0, r].copy()
        key = np.empty(cols, np.float32)
        arg = np.zeros(cols, np.int64)
        anynan = np.empty(cols, np.bool_)
        for c in range(cols):
            anynan[c] = math.isnan(mn[c])
            key[c] = inf32 if anynan[c] else mn[c]
        for j in range(1, nh):
            row = best[j, r]
            for c in range(cols):
                v = row[c]
                if math.isnan(v):
                    anynan[c] = True
                    continue
                if v < mn[c]:
                    mn[c] = v
                if v > mx[c]:
                    mx[c] = v
                if v < key[c]:
                    key[c] = v
                    arg[c] = j
        for c in range(cols):
            lo = nan32 if anynan[c] else mn[c]
            hi = nan32 if anynan[c] else mx[c]
            out[0, r, c] = lo
            out[1, r, c] = hi
            valid = not math.isnan(best[0, r, c])
            if not valid:
                ratio = nan32
            elif lo != 0.0:
                ratio = hi / lo
            elif hi > 0.0:  # x / 0 as IEEE 754 says, spelled out: the precompiled
                ratio = inf32  # module's division raises on a zero divisor
            elif hi < 0.0:
                ratio = -inf32
            else:
                ratio = nan32
            out[2, r, c] = ratio
            if valid and math.isfinite(lo):
                out[3, r, c] = np.float32(heading_deg[arg[c]])
            else:
                out[3, r, c] = nan32


def summary_bands(best: np.ndarray, heading_deg: np.ndarray, out: np.ndarray) -> None:
    """Fill ``out`` (float32 ``(4, rows, cols)``) from ``best`` (float32 ``(N, rows, cols)``).

    Per cell, as NumPy would compute it: ``cheapest = best.min(0)`` and
    ``dearest = best.max(0)`` (NaN if any heading is NaN), ``anisotropy = dearest /
    cheapest`` in float32 where ``best[0]`` is not NaN (else NaN), and the heading
    ``heading_deg[argmin]`` (NaN counted as inf, the first of equal minima) where
    ``best[0]`` is not NaN and the cheapest is finite (else NaN). (Of a tie between
    ``0.0`` and ``-0.0`` NumPy's vectorised ``min`` may return either; costs are never
    ``-0.0``.)
    """
    _summary(best, np.ascontiguousarray(heading_deg, dtype=np.float64), out)


@numba.njit(cache=True, parallel=True)
def encode(src, inv_step, out):  # pragma: no cover - compiled
    """``uint16`` codes of float32 bands ``src`` (see :mod:`energy_planner.energymap.encoding`).

    ``out[i] = round(src[i] * inv_step[i]) + 1`` (halves up), 0 for NaN, 65535 for
    ``+inf``; returns how many finite values (or ``-inf``) fall outside ``0 .. 65533``
    steps (their codes are left 65535).
    """
    nb, rows, cols = src.shape
    bad = 0
    for r in numba.prange(rows):
        for i in range(nb):
            s = inv_step[i]
            for c in range(cols):
                v = src[i, r, c]
                if math.isnan(v):
                    out[i, r, c] = 0
                    continue
                q = v * s + 1.5
                if q >= 1.0 and q < 65535.0:
                    out[i, r, c] = np.uint16(int(q))
                else:
                    out[i, r, c] = 65535
                    if not (v > 0.0 and math.isinf(v)):
                        bad += 1
    return bad
