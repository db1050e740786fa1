"""Template of the motion kernels, compiled once per energy model.

:func:`energy_planner.energy.kernels.make_kernels` copies this file, replaces the
``power`` function between the markers with the model's generated one, writes it to the
kernel cache directory and imports it, so that numba's on-disk cache (``cache=True``)
keeps the compiled code between runs. Imported as it is, the placeholder ``power`` is a
level-ground model of 1 N per m/s in every direction (used by the tests of this file).

Signatures: see :func:`energy_planner.energy.kernels.make_kernels`.
"""

import math

import numba
import numpy as np

from energy_planner.energy.kernels import (
    BLOCKED,
    N_OUT,
    OUTSIDE,
    TOO_CROSS,
    TOO_STEEP,
    sample_gradient,
    wrap_angle,
)


# --- power: replaced per model ---
@numba.njit(cache=True)
def power(alpha, gamma, vx, vy, wz, ax, ay):
    p = abs(vx) + abs(vy) + abs(wz)
    return p, (max(vx, 0.0), max(-vx, 0.0), abs(vy), abs(wz), 0.0)


# --- end power ---


@numba.njit(cache=True)
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
        # no motion: report the slope where the robot stands (the last sample)
        out[4] = out[6] = math.atan(math.sqrt(gxs * gxs + gys * gys))
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
        # relative heading in the slope plane (as the IMU measures it): from the in-plane
        # uphill direction to body x; tan(gamma) = tan(theta - psi) cos(alpha)
        gh = th - math.atan2(gys, gxs)
        gamma = math.atan2(math.sin(gh) * math.cos(alpha), math.cos(gh))
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


@numba.njit(cache=True)
def motion_cost(x0, y0, th0, x1, y1, th1, data):
    out = np.empty(N_OUT)
    motion_full(x0, y0, th0, x1, y1, th1, -1.0, data, out)
    return out[0]


@numba.njit(cache=True)
def motion_batch(x0, y0, th0, x1, y1, th1, data):
    n = x0.shape[0]
    res = np.empty(n)
    out = np.empty(N_OUT)
    for i in range(n):
        motion_full(x0[i], y0[i], th0[i], x1[i], y1[i], th1[i], -1.0, data, out)
        res[i] = out[0]
    return res


@numba.njit(cache=True)
def path_table(x, y, th, durations, data):
    m = x.shape[0] - 1
    table = np.empty((max(m, 0), N_OUT))
    out = np.empty(N_OUT)
    for i in range(m):
        motion_full(x[i], y[i], th[i], x[i + 1], y[i + 1], th[i + 1], durations[i], data, out)
        table[i, :] = out
    return table
