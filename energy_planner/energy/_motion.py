"""Template of the motion kernels, compiled once per energy model.

:func:`energy_planner.energy.kernels.make_kernels` copies this file, replaces the
``power`` function between the markers with the model's generated one, writes it to the
kernel cache directory and imports it, so that numba's on-disk cache (``cache=True``)
keeps the compiled code between runs. Imported as it is, the placeholder ``power`` is a
level-ground model of 1 N per m/s in every direction, plus the first raster channel if
there is one (used by the tests of this file).

Signatures: see :func:`energy_planner.energy.kernels.make_kernels`. Entries of the result
vector are read and written through the named indices ``OUT_*`` of
:mod:`energy_planner.energy.kernels`.
"""

import math

import numba
import numpy as np

from energy_planner.energy.kernels import (
    BLOCKED,
    GAIT_TOL,
    N_KINDS,
    N_OUT,
    NO_CHANNEL,
    OUT_CODE,
    OUT_DISTANCE,
    OUT_DURATION,
    OUT_E_FORWARD,
    OUT_ENERGY,
    OUT_MAX_SLOPE,
    OUT_MEAN_GAMMA,
    OUT_MEAN_SLOPE,
    OUT_TURN,
    OUTSIDE,
    TOO_BACKWARD,
    TOO_CRAB,
    TOO_CROSS,
    TOO_STEEP,
    sample_channels,
    sample_gradient,
    wrap_angle,
)


# --- power: replaced per model ---
@numba.njit(cache=True)
def power(alpha, gamma, vx, vy, wz, ax, ay, ch):
    p = abs(vx) + abs(vy) + abs(wz)
    if ch.shape[0] > 0:
        p += ch[0]
    return p, (max(vx, 0.0), max(-vx, 0.0), abs(vy), abs(wz), 0.0)


# --- end power ---


@numba.njit(cache=True)
def slope_frame(gxs, gys, th):
    """Slope ``alpha`` and relative heading ``gamma`` of body yaw ``th`` on gradient g.

    ``gamma`` is measured in the slope plane (as the IMU measures it), from the in-plane
    uphill direction to body x: ``tan(gamma) = tan(th - psi) cos(alpha)``.
    """
    alpha = math.atan(math.sqrt(gxs * gxs + gys * gys))
    gh = th - math.atan2(gys, gxs)
    gamma = math.atan2(math.sin(gh) * math.cos(alpha), math.cos(gh))
    return alpha, gamma


@numba.njit(cache=True)
def body_velocity(gxs, gys, th, v0, v1, v2):
    """Body-frame (vx, vy) of the 3-D velocity (v0, v1, v2) along the surface.

    The body frame is tilted with the ground: x = unit(c, s, g.(c, s)),
    z = unit(-gx, -gy, 1), y = z cross x.
    """
    return body_velocity_cs(gxs, gys, math.cos(th), math.sin(th), v0, v1, v2)


@numba.njit(cache=True)
def body_velocity_cs(gxs, gys, c_, s_, v0, v1, v2):
    """:func:`body_velocity` given the cosine and sine of the yaw."""
    bx0, bx1, bx2 = c_, s_, gxs * c_ + gys * s_
    nx = math.sqrt(bx0 * bx0 + bx1 * bx1 + bx2 * bx2)
    bx0 /= nx
    bx1 /= nx
    bx2 /= nx
    nz = math.sqrt(1.0 + gxs * gxs + gys * gys)
    bz0, bz1, bz2 = -gxs / nz, -gys / nz, 1.0 / nz
    by0 = bz1 * bx2 - bz2 * bx1
    by1 = bz2 * bx0 - bz0 * bx2
    by2 = bz0 * bx1 - bz1 * bx0
    return v0 * bx0 + v1 * bx1 + v2 * bx2, v0 * by0 + v1 * by1 + v2 * by2


@numba.njit(cache=True)
def gait_violation(gxs, gys, vx, vy, dist, btan, cmax):
    """The gait limit a translation breaks (a violation code), or 0.

    ``(vx, vy)``: the body-frame velocity (any scale); ``dist``: the motion's map length
    (0: a turn in place, never refused); ``btan``: tangent of the steepest slope on
    which walking backward is allowed; ``cmax``: the largest crab angle, radians. The
    angle from body x to the velocity is ``atan2(|vy|, vx)`` in [0, pi]: beyond
    ``pi / 2`` the robot walks backward, and its crab angle is the smaller of the angle
    and its supplement. :data:`GAIT_TOL` of slack on both.
    """
    if dist <= 0.0 or (vx == 0.0 and vy == 0.0):
        return 0
    ang = math.atan2(abs(vy), vx)
    if ang > 0.5 * math.pi + GAIT_TOL and gxs * gxs + gys * gys > btan * btan:
        return TOO_BACKWARD
    if min(ang, math.pi - ang) > cmax + GAIT_TOL:
        return TOO_CRAB
    return 0


@numba.njit(cache=True)
def motion_full(x0, y0, th0, x1, y1, th1, duration, data, out):
    (grad, blocked, gx0, gy0, gdx, gdy, speed, yaw_rate, step, ang_step, tmax, smax, chan,
     nearest, btan, cmax) = data  # fmt: skip
    ddx = x1 - x0
    ddy = y1 - y0
    dist = math.sqrt(ddx * ddx + ddy * ddy)
    dth = wrap_angle(th1 - th0)
    n = max(1, int(math.ceil(dist / step)), int(math.ceil(abs(dth) / ang_step)))
    for k in range(N_OUT):
        out[k] = 0.0
    out[OUT_TURN] = abs(dth)
    # sampled channel values: scratch space after the results (no allocation per motion)
    nch = chan.shape[0]
    chv = out[N_OUT : N_OUT + nch]
    # pass 1: check the limits and measure the surface length (pass 2 samples the
    # gradient again: cheaper than allocating a buffer per motion)
    nr, nc = blocked.shape
    hx = ddx / n
    hy = ddy / n
    surface = 0.0
    gxs = gys = 0.0
    for i in range(n):
        s = (i + 0.5) / n
        x = x0 + s * ddx
        y = y0 + s * ddy
        ok, gxs, gys = sample_gradient(grad, gx0, gy0, gdx, gdy, x, y)
        if not ok:
            out[OUT_CODE] = OUTSIDE
            out[OUT_ENERGY] = np.inf
            return
        if nr > 0:
            r = int(round((y - gy0) / gdy))
            c = int(round((x - gx0) / gdx))
            if 0 <= r < nr and 0 <= c < nc and blocked[r, c]:
                out[OUT_CODE] = BLOCKED
                out[OUT_ENERGY] = np.inf
                return
        if gxs * gxs + gys * gys > tmax * tmax:
            out[OUT_CODE] = TOO_STEEP
            out[OUT_ENERGY] = np.inf
            return
        if nch > 0 and not sample_channels(chan, nearest, gx0, gy0, gdx, gdy, x, y, chv):
            out[OUT_CODE] = NO_CHANNEL
            out[OUT_ENERGY] = np.inf
            return
        dz = gxs * hx + gys * hy
        surface += math.sqrt(hx * hx + hy * hy + dz * dz)
    T = duration
    if T <= 0.0:
        T = max(surface / speed, abs(dth) / yaw_rate)
    out[OUT_DURATION] = T
    out[OUT_DISTANCE] = surface
    if T <= 0.0:
        # no motion: report the slope where the robot stands (the last sample)
        out[OUT_MEAN_SLOPE] = out[OUT_MAX_SLOPE] = math.atan(math.sqrt(gxs * gxs + gys * gys))
        return
    # pass 2: the robot keeps a constant speed along the surface (and a constant yaw
    # rate); its body frame is tilted with the ground (see body_velocity).
    wz = dth / T
    for i in range(n):
        s = (i + 0.5) / n
        x = x0 + s * ddx
        y = y0 + s * ddy
        ok, gxs, gys = sample_gradient(grad, gx0, gy0, gdx, gdy, x, y)
        if nch > 0:
            sample_channels(chan, nearest, gx0, gy0, gdx, gdy, x, y, chv)
        dz = gxs * hx + gys * hy
        ds = math.sqrt(hx * hx + hy * hy + dz * dz)
        dt = T / n if surface <= 0.0 else T * ds / surface
        th = th0 + s * dth
        alpha, gamma = slope_frame(gxs, gys, th)
        if math.sin(alpha) * abs(math.sin(gamma)) > smax:
            out[OUT_CODE] = TOO_CROSS
            out[OUT_ENERGY] = np.inf
            return
        vx = 0.0
        vy = 0.0
        if dt > 0.0:
            # 3-D velocity along the surface, in the tilted body frame
            vx, vy = body_velocity(gxs, gys, th, hx / dt, hy / dt, dz / dt)
        code = gait_violation(gxs, gys, vx, vy, dist, btan, cmax)
        if code != 0:
            out[OUT_CODE] = code
            out[OUT_ENERGY] = np.inf
            return
        p, kinds = power(alpha, gamma, vx, vy, wz, 0.0, 0.0, chv)
        out[OUT_ENERGY] += p * dt
        out[OUT_MEAN_SLOPE] += alpha / n
        out[OUT_MEAN_GAMMA] += abs(gamma) / n
        out[OUT_MAX_SLOPE] = max(out[OUT_MAX_SLOPE], alpha)
        for k in range(N_KINDS):
            out[OUT_E_FORWARD + k] += kinds[k] * dt


@numba.njit(cache=True)
def motion_cost(x0, y0, th0, x1, y1, th1, data):
    out = np.empty(N_OUT + data[12].shape[0])
    motion_full(x0, y0, th0, x1, y1, th1, -1.0, data, out)
    return out[OUT_ENERGY]


@numba.njit(cache=True)
def motion_batch(x0, y0, th0, x1, y1, th1, data):
    n = x0.shape[0]
    res = np.empty(n)
    out = np.empty(N_OUT + data[12].shape[0])
    for i in range(n):
        motion_full(x0[i], y0[i], th0[i], x1[i], y1[i], th1[i], -1.0, data, out)
        res[i] = out[OUT_ENERGY]
    return res


@numba.njit(cache=True)
def path_table(x, y, th, durations, data):
    m = x.shape[0] - 1
    table = np.empty((max(m, 0), N_OUT))
    out = np.empty(N_OUT + data[12].shape[0])
    for i in range(m):
        motion_full(x[i], y[i], th[i], x[i + 1], y[i + 1], th[i + 1], durations[i], data, out)
        table[i, :] = out[:N_OUT]
    return table


@numba.njit(cache=True)
def gait_cost(gx, gy, alpha, ca, sa, c_psi, s_psi, cy, sy, v0, v1, v2, dt, smax, btan, cmax,
              chv):  # fmt: skip
    """Energy of ``dt`` seconds of straight walking at velocity (v0, v1, v2).

    The walk is along the surface with body yaw of cosine ``cy`` and sine ``sy``, where
    the gradient is (gx, gy) (slope ``alpha``, its cosine ``ca`` and sine ``sa``, uphill
    azimuth of cosine ``c_psi`` and sine ``s_psi``); ``inf`` above the cross-slope limit
    ``smax`` or where the gait breaks a gait limit (``btan``, ``cmax``:
    :func:`gait_violation`).

    The same relative heading as :func:`slope_frame` (``tan(gamma) = tan(yaw - psi)
    cos(alpha)``) and the same body velocity as :func:`motion_full`.
    """
    gamma = math.atan2((sy * c_psi - cy * s_psi) * ca, cy * c_psi + sy * s_psi)
    if sa * abs(math.sin(gamma)) > smax:
        return np.inf
    vx, vy = body_velocity_cs(gx, gy, cy, sy, v0, v1, v2)
    if gait_violation(gx, gy, vx, vy, 1.0, btan, cmax) != 0:
        return np.inf
    p, kinds = power(alpha, gamma, vx, vy, 0.0, 0.0, 0.0, chv)
    return p * dt


@numba.njit(cache=True, parallel=True)
def map_costs(gx, gy, chan, headings, speed, tmax, smax, btan, cmax, along, best):
    """Energy-map costs of a block of cells (J per metre of map distance).

    ``gx``, ``gy``: gradient of the block's cells, shape (rows, cols); ``chan``: raster
    channels on the same cells, shape (k, rows, cols), category indices for categorical
    ones. ``along[j, r, c]``: walking forward along ``headings[j]`` (facing along);
    ``best[j, r, c]``: the cheapest of walking forward, backward or sideways (either
    side) along it, among the gaits the gait limits allow (``btan``, ``cmax``: see
    :func:`gait_violation`; facing along is always allowed). Each is the limit of
    :func:`motion_full` for a short straight motion through the cell centre, divided by
    its map length. NaN where the gradient or a channel is undefined, ``inf`` above a
    slope limit.
    """
    rows, cols = gx.shape
    nh = headings.shape[0]
    nch = chan.shape[0]
    hc = np.cos(headings)
    hs = np.sin(headings)
    for r in numba.prange(rows):
        chv = np.empty(nch)
        for c in range(cols):
            a = gx[r, c]
            b = gy[r, c]
            ok = math.isfinite(a) and math.isfinite(b)
            for k in range(nch):
                chv[k] = chan[k, r, c]
                if not math.isfinite(chv[k]):
                    ok = False
            if not ok:
                for j in range(nh):
                    along[j, r, c] = np.nan
                    best[j, r, c] = np.nan
                continue
            g2 = a * a + b * b
            if g2 > tmax * tmax:
                for j in range(nh):
                    along[j, r, c] = np.inf
                    best[j, r, c] = np.inf
                continue
            g = math.sqrt(g2)
            alpha = math.atan(g)
            ca = math.cos(alpha)
            sa = math.sin(alpha)
            c_psi = a / g if g > 0.0 else 1.0  # atan2(0, 0) = 0 on flat ground
            s_psi = b / g if g > 0.0 else 0.0
            for j in range(nh):
                u0 = hc[j]
                u1 = hs[j]
                dz = a * u0 + b * u1
                ds = math.sqrt(1.0 + dz * dz)  # metres along the ground per map metre
                dt = ds / speed
                v0 = u0 / dt
                v1 = u1 / dt
                v2 = dz / dt
                fwd = gait_cost(a, b, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt,
                                smax, btan, cmax, chv)  # fmt: skip
                m = fwd
                # backward (yaw h + pi), sideways (yaw h - pi/2 and h + pi/2)
                m = min(m, gait_cost(a, b, alpha, ca, sa, c_psi, s_psi, -u0, -u1, v0, v1, v2,
                                     dt, smax, btan, cmax, chv))  # fmt: skip
                m = min(m, gait_cost(a, b, alpha, ca, sa, c_psi, s_psi, u1, -u0, v0, v1, v2,
                                     dt, smax, btan, cmax, chv))  # fmt: skip
                m = min(m, gait_cost(a, b, alpha, ca, sa, c_psi, s_psi, -u1, u0, v0, v1, v2,
                                     dt, smax, btan, cmax, chv))  # fmt: skip
                along[j, r, c] = fwd
                best[j, r, c] = m
