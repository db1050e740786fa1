"""Numba helpers of the motion kernels: terrain and channel sampling, angle wrapping.

They live apart from :mod:`energy_planner.energy.kernels` (which re-exports them) so that
importing the kernels' named indices does not import numba: a command that runs a
precompiled kernel module (:func:`energy_planner.energy.kernels.precompiled_module`)
never loads it.
"""

from __future__ import annotations

import math

import numba


@numba.njit(cache=True)
def sample_gradient(grad, x0, y0, dx, dy, x, y):
    """Bilinear gradient at (x, y); returns (ok, dz/dx, dz/dy).

    ``grad[r, c]`` holds (dz/dx, dz/dy) of cell (r, c), interleaved so that one lookup
    touches one cache line per corner.
    """
    nrows, ncols = grad.shape[0], grad.shape[1]
    fc = (x - x0) / dx
    fr = (y - y0) / dy
    if not (fc >= 0.0 and fr >= 0.0 and fc <= ncols - 1 and fr <= nrows - 1):
        return False, 0.0, 0.0
    c = min(int(fc), ncols - 2) if ncols > 1 else 0
    r = min(int(fr), nrows - 2) if nrows > 1 else 0
    tc = fc - c
    tr = fr - r
    c1 = min(c + 1, ncols - 1)
    r1 = min(r + 1, nrows - 1)
    a00, b00 = grad[r, c, 0], grad[r, c, 1]
    a01, b01 = grad[r, c1, 0], grad[r, c1, 1]
    a10, b10 = grad[r1, c, 0], grad[r1, c, 1]
    a11, b11 = grad[r1, c1, 0], grad[r1, c1, 1]
    if not math.isfinite(a00 + a01 + a10 + a11 + b00 + b01 + b10 + b11):
        return False, 0.0, 0.0
    w00 = (1 - tr) * (1 - tc)
    w01 = (1 - tr) * tc
    w10 = tr * (1 - tc)
    w11 = tr * tc
    return (
        True,
        w00 * a00 + w01 * a01 + w10 * a10 + w11 * a11,
        w00 * b00 + w01 * b01 + w10 * b10 + w11 * b11,
    )


@numba.njit(cache=True)
def sample_channels(chan, nearest, x0, y0, dx, dy, x, y, values):
    """Fill ``values[k]`` with channel ``k`` at (x, y); False if one has no value there.

    ``chan[k, r, c]`` is channel ``k`` on the terrain grid (NaN = no value). A channel
    with ``nearest[k]`` (categorical: a category index) takes the nearest cell's value;
    the others are bilinear between cell centres, as :func:`sample_gradient`. A
    ``(k, 1, 1)`` array holds uniform channels (the ``--set`` constants, given at run
    time so that a new value needs no compilation): their values everywhere.
    """
    nch = chan.shape[0]
    if nch == 0:
        return True
    nrows, ncols = chan.shape[1], chan.shape[2]
    if nrows == 1 and ncols == 1:  # uniform channels (constants given at run time)
        for k in range(nch):
            values[k] = chan[k, 0, 0]
        return True
    fc = (x - x0) / dx
    fr = (y - y0) / dy
    if not (fc >= -0.5 and fr >= -0.5 and fc <= ncols - 0.5 and fr <= nrows - 0.5):
        return False
    rn = min(max(int(math.floor(fr + 0.5)), 0), nrows - 1)
    cn = min(max(int(math.floor(fc + 0.5)), 0), ncols - 1)
    fcb = min(max(fc, 0.0), ncols - 1.0)
    frb = min(max(fr, 0.0), nrows - 1.0)
    c = min(int(fcb), ncols - 2) if ncols > 1 else 0
    r = min(int(frb), nrows - 2) if nrows > 1 else 0
    tc = fcb - c
    tr = frb - r
    c1 = min(c + 1, ncols - 1)
    r1 = min(r + 1, nrows - 1)
    for k in range(nch):
        if nearest[k]:
            v = chan[k, rn, cn]
        else:
            v = (
                (1 - tr) * (1 - tc) * chan[k, r, c]
                + (1 - tr) * tc * chan[k, r, c1]
                + tr * (1 - tc) * chan[k, r1, c]
                + tr * tc * chan[k, r1, c1]
            )
        if not math.isfinite(v):
            return False
        values[k] = v
    return True


@numba.njit(cache=True)
def wrap_angle(a):
    """Wrap to (-pi, pi]."""
    two_pi = 2.0 * math.pi
    a = (a + math.pi) - two_pi * math.floor((a + math.pi) / two_pi)  # in [0, 2 pi)
    if a <= 0.0:
        a += two_pi
    return a - math.pi
