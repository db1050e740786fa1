"""Numba kernels: the energy of one SE(2) motion over a terrain grid.

A motion from pose ``(x0, y0, th0)`` to ``(x1, y1, th1)`` (working CRS, metres; yaw in
radians CCW from +x) moves the position linearly in the map and the yaw along the
shortest arc. The robot walks on the ground, not on the map: it keeps a constant speed
along the surface (odometry's speed), so the motion lasts
``max(surface_length / speed, |dth| / yaw_rate)`` (or a given duration) and its body
frame is tilted with the ground. The body twist at each sub-step is the 3-D velocity
along the surface expressed in that tilted body frame, so a motion whose yaw differs from
its direction walks sideways. The energy is the midpoint-rule integral of the model power
over ``n`` sub-steps, short enough (a fraction of a cell) that a motion crossing a ridge
is charged for both sides.

Terrain is sampled by bilinear interpolation of the Horn gradient at cell centres; the
four corner cells must be valid (a NaN corner makes the sample invalid).

Violation codes returned by the kernels: 0 valid, 1 outside the map or on nodata,
2 slope above the limit, 3 cross-slope above the limit, 4 a blocked (keep-out) cell.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numba
import numpy as np

OK, OUTSIDE, TOO_STEEP, TOO_CROSS, BLOCKED = 0, 1, 2, 3, 4
VIOLATIONS = {
    OUTSIDE: "outside the map or on nodata",
    TOO_STEEP: "slope above the limit",
    TOO_CROSS: "cross-slope above the limit",
    BLOCKED: "inside a keep-out area",
}
#: Length of the per-motion result vector of ``motion_full``.
N_OUT = 13


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
def wrap_angle(a):
    """Wrap to (-pi, pi]."""
    two_pi = 2.0 * math.pi
    a = (a + math.pi) - two_pi * math.floor((a + math.pi) / two_pi)  # in [0, 2 pi)
    if a <= 0.0:
        a += two_pi
    return a - math.pi


@lru_cache(maxsize=64)
def make_kernels(power):
    """Build the motion kernels around a compiled model power function.

    Parameters
    ----------
    power : numba dispatcher
        ``power(alpha, gamma, vx, vy, wz, ax, ay) -> (total, by_kind)`` from
        :meth:`energy_planner.model.EnergyModel.power_kernel`.

    Returns
    -------
    motion_full, motion_cost, motion_batch : numba dispatchers
        ``motion_full(x0, y0, th0, x1, y1, th1, duration, data, out)`` fills ``out``
        (length :data:`N_OUT`): energy J, duration s, surface distance m, |turn| rad, mean slope
        rad, mean |gamma| rad, max slope rad, energy by kind (forward, backward, lateral,
        turning, other), violation code. ``motion_cost(x0, y0, th0, x1, y1, th1, data)``
        returns the energy or ``inf`` if invalid; ``motion_batch`` maps it over arrays.
        ``data`` is the tuple built by :class:`energy_planner.energy.MotionCost`.
    """

    @numba.njit
    def motion_full(x0, y0, th0, x1, y1, th1, duration, data, out):
        grad, blocked, gx0, gy0, gdx, gdy, speed, yaw_rate, step, ang_step, tmax, smax = data
        ddx = x1 - x0
        ddy = y1 - y0
        dist = math.sqrt(ddx * ddx + ddy * ddy)
        dth = wrap_angle(th1 - th0)
        n = max(1, int(math.ceil(dist / step)), int(math.ceil(abs(dth) / ang_step)))
        for k in range(N_OUT):
            out[k] = 0.0
        out[3] = abs(dth)
        # pass 1: check the limits and measure the surface length (pass 2 samples the
        # gradient again: cheaper than allocating a buffer per motion)
        nr, nc = blocked.shape
        hx = ddx / n
        hy = ddy / n
        surface = 0.0
        for i in range(n):
            s = (i + 0.5) / n
            x = x0 + s * ddx
            y = y0 + s * ddy
            ok, gxs, gys = sample_gradient(grad, gx0, gy0, gdx, gdy, x, y)
            if not ok:
                out[12] = OUTSIDE
                out[0] = np.inf
                return
            if nr > 0:
                r = int(round((y - gy0) / gdy))
                c = int(round((x - gx0) / gdx))
                if 0 <= r < nr and 0 <= c < nc and blocked[r, c]:
                    out[12] = BLOCKED
                    out[0] = np.inf
                    return
            if gxs * gxs + gys * gys > tmax * tmax:
                out[12] = TOO_STEEP
                out[0] = np.inf
                return
            dz = gxs * hx + gys * hy
            surface += math.sqrt(hx * hx + hy * hy + dz * dz)
        T = duration
        if T <= 0.0:
            T = max(surface / speed, abs(dth) / yaw_rate)
        out[1] = T
        out[2] = surface
        if T <= 0.0:
            return
        # pass 2: the robot keeps a constant speed along the surface (and a constant yaw
        # rate); its body frame is tilted with the ground: x = unit(c, s, g.(c, s)),
        # z = unit(-gx, -gy, 1), y = z cross x.
        wz = dth / T
        for i in range(n):
            s = (i + 0.5) / n
            ok, gxs, gys = sample_gradient(grad, gx0, gy0, gdx, gdy, x0 + s * ddx, y0 + s * ddy)
            dz = gxs * hx + gys * hy
            ds = math.sqrt(hx * hx + hy * hy + dz * dz)
            dt = T / n if surface <= 0.0 else T * ds / surface
            th = th0 + s * dth
            g2 = gxs * gxs + gys * gys
            alpha = math.atan(math.sqrt(g2))
            gamma = wrap_angle(th - math.atan2(gys, gxs))
            if math.sin(alpha) * abs(math.sin(gamma)) > smax:
                out[12] = TOO_CROSS
                out[0] = np.inf
                return
            vx = 0.0
            vy = 0.0
            if dt > 0.0:
                # 3-D velocity along the surface
                v0 = hx / dt
                v1 = hy / dt
                v2 = dz / dt
                c_ = math.cos(th)
                s_ = math.sin(th)
                bx0, bx1, bx2 = c_, s_, gxs * c_ + gys * s_
                nx = math.sqrt(bx0 * bx0 + bx1 * bx1 + bx2 * bx2)
                bx0 /= nx
                bx1 /= nx
                bx2 /= nx
                nz = math.sqrt(1.0 + g2)
                bz0, bz1, bz2 = -gxs / nz, -gys / nz, 1.0 / nz
                by0 = bz1 * bx2 - bz2 * bx1
                by1 = bz2 * bx0 - bz0 * bx2
                by2 = bz0 * bx1 - bz1 * bx0
                vx = v0 * bx0 + v1 * bx1 + v2 * bx2
                vy = v0 * by0 + v1 * by1 + v2 * by2
            p, kinds = power(alpha, gamma, vx, vy, wz, 0.0, 0.0)
            out[0] += p * dt
            out[4] += alpha / n
            out[5] += abs(gamma) / n
            out[6] = max(out[6], alpha)
            for k in range(5):
                out[7 + k] += kinds[k] * dt

    @numba.njit
    def motion_cost(x0, y0, th0, x1, y1, th1, data):
        out = np.empty(N_OUT)
        motion_full(x0, y0, th0, x1, y1, th1, -1.0, data, out)
        return out[0]

    @numba.njit
    def motion_batch(x0, y0, th0, x1, y1, th1, data):
        n = x0.shape[0]
        res = np.empty(n)
        out = np.empty(N_OUT)
        for i in range(n):
            motion_full(x0[i], y0[i], th0[i], x1[i], y1[i], th1[i], -1.0, data, out)
            res[i] = out[0]
        return res

    @numba.njit
    def path_table(x, y, th, durations, data):
        m = x.shape[0] - 1
        table = np.empty((max(m, 0), N_OUT))
        out = np.empty(N_OUT)
        for i in range(m):
            motion_full(x[i], y[i], th[i], x[i + 1], y[i + 1], th[i + 1], durations[i], data, out)
            table[i, :] = out
        return table

    return motion_full, motion_cost, motion_batch, path_table
