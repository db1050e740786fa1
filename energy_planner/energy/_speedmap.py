"""Template of the energy map's kernels at the best speed of each cell and heading.

:func:`energy_planner.energy.speed_map.speed_map_source` builds a module from the motion
kernels of ``_motion.py`` (unchanged) whose ``power`` is :func:`ranged_power` (this file)
over the model's own power (``model_power``), then this file (without its import of the
motion kernels). Called at a ground speed of 1 m/s (the body velocity a unit vector),
that ``power`` returns the cost of a metre of ground at the best speed in the range
times that speed: every heading kernel of ``_motion.py`` (``gait_cost``, ``half_min``,
``cheapest_at``, ``heading_table``, ``map_costs``), which multiplies the power by the
seconds a map metre lasts, then prices each yaw at its best speed, and their minimum
over the yaw is the least over yaw and speed together (a minimum of minima).

The speed choice is the motions' (:func:`energy_planner.energy._motion.motion_best`):
the energy per metre at the node speeds of the model's speed law, its Laurent
coefficients solved and checked at one more node, the least on the range in closed form
(:func:`energy_planner.energy._laurent.laurent_argmin`); where the check fails (a term
with a kink inside the range), golden section over the range.

The speed range and the law's nodes travel at the end of the channel vector ``ch``
(after the rasters and the constants the model reads, which ``model_power`` reads by
their indices): ``vmin, vmax, K, exps[K], nodes[K + 1], inverse[K * K], offset``, the
last entry the index of ``vmin`` (:func:`energy_planner.energy.speed_map.speed_tail`).
"""

import math

import numba
import numpy as np

from energy_planner.energy._laurent import laurent_argmin, laurent_value
from energy_planner.energy._motion import (  # --- motion ---
    SPEED_FIT_RTOL,
    SPEED_GOLDEN_ITERS,
    body_velocity_cs,
    cheapest_at,
    gait_cost,
    half_min,
    slope_of,
    travel,
    yaw_window,
)
from energy_planner.energy._motion import power as model_power  # --- model power ---


@numba.njit(cache=True)
def _per_metre(alpha, gamma, ux, uy, uw, ch, v):
    """J per metre of ground at ground speed ``v`` along the unit twist ``(ux, uy, uw)``."""
    p, kinds = model_power(alpha, gamma, v * ux, v * uy, v * uw, 0.0, 0.0, ch)
    return p / v


@numba.njit(cache=True)
def best_ground_speed(alpha, gamma, ux, uy, uw, ch):
    """``(J per metre of ground, speed)`` at the best speed of the range in ``ch``'s tail."""
    n = ch.shape[0]
    o = int(ch[n - 1])
    lo = ch[o]
    hi = ch[o + 1]
    k = int(ch[o + 2])
    if k > 0 and hi > lo:
        exps = ch[o + 3 : o + 3 + k]
        nodes = ch[o + 3 + k : o + 4 + 2 * k]
        vinv = o + 4 + 2 * k
        e = np.empty(k + 1)
        scale = 0.0
        for a in range(k + 1):
            e[a] = _per_metre(alpha, gamma, ux, uy, uw, ch, nodes[a])
            scale = max(scale, abs(e[a]))
        c = np.zeros(k)
        for a in range(k):
            for b in range(k):
                c[a] += ch[vinv + a * k + b] * e[b]
        if abs(laurent_value(c, exps, nodes[k]) - e[k]) <= SPEED_FIT_RTOL * scale + 1e-12:
            v = laurent_argmin(c, exps, lo, hi)
            return laurent_value(c, exps, v), v
    if not hi > lo:
        return _per_metre(alpha, gamma, ux, uy, uw, ch, lo), lo
    # golden section over the range (assumes one minimum in it), and both ends
    g = 0.3819660112501051
    a_, b_ = lo, hi
    xa = a_ + g * (b_ - a_)
    xb = b_ - g * (b_ - a_)
    fa = _per_metre(alpha, gamma, ux, uy, uw, ch, xa)
    fb = _per_metre(alpha, gamma, ux, uy, uw, ch, xb)
    for _ in range(SPEED_GOLDEN_ITERS):
        if fa <= fb:
            b_, xb, fb = xb, xa, fa
            xa = a_ + g * (b_ - a_)
            fa = _per_metre(alpha, gamma, ux, uy, uw, ch, xa)
        else:
            a_, xa, fa = xa, xb, fb
            xb = b_ - g * (b_ - a_)
            fb = _per_metre(alpha, gamma, ux, uy, uw, ch, xb)
    best_v, best_f = (xa, fa) if fa <= fb else (xb, fb)
    for v in (lo, hi):
        f = _per_metre(alpha, gamma, ux, uy, uw, ch, v)
        if f < best_f:
            best_v, best_f = v, f
    return best_f, best_v


@numba.njit(cache=True)
def ranged_power(alpha, gamma, vx, vy, wz, ax, ay, ch):
    """The ``power`` of the generated module: ``(vx, vy, wz)`` the twist at 1 m/s of ground.

    Returns the cost of a metre of ground at the best speed of the range (as a power at
    1 m/s: the heading kernels multiply it by the seconds a map metre lasts at 1 m/s,
    its ground length), and the by-kind tuple with it under "other".
    """
    f, v = best_ground_speed(alpha, gamma, vx, vy, wz, ch)
    return f, (0.0, 0.0, 0.0, 0.0, f)


@numba.njit(cache=True)
def speed_at(a, b, u0, u1, r, ch):
    """The best ground speed of moving along unit map direction (u0, u1), body yaw ``r``.

    On gradient (a, b), the body's yaw turned ``r`` (map angle) from the travel: the
    geometry of :func:`~energy_planner.energy._motion.gait_cost` (its relative heading
    and tilted body velocity), at 1 m/s.
    """
    alpha, ca, sa, c_psi, s_psi = slope_of(a, b)
    dt, v0, v1, v2 = travel(a, b, u0, u1, 1.0)
    cr = math.cos(r)
    sr = math.sin(r)
    cy = u0 * cr - u1 * sr
    sy = u1 * cr + u0 * sr
    gamma = math.atan2((sy * c_psi - cy * s_psi) * ca, cy * c_psi + sy * s_psi)
    vx, vy = body_velocity_cs(a, b, cy, sy, v0, v1, v2)
    return best_ground_speed(alpha, gamma, vx, vy, 0.0, ch)[1]


@numba.njit(cache=True, parallel=True)
def speed_heading_table(speed, smax, cmax, d_alpha, i_start, n_rows, n_phi, chv):
    """``heading_table`` of ``_motion.py`` with the best speed at each node beside it.

    ``table[0:3]``: as ``heading_table`` (forward half, backward half, along; each yaw
    at its best speed); ``table[3:6]``: the ground speed of each (at the yaw
    :func:`half_min` chose; NaN where the cost is not finite). ``speed`` is 1 (m/s):
    the unit twist :func:`ranged_power` takes.
    """
    table = np.empty((6, n_rows, n_phi))
    d_phi = 2.0 * math.pi / n_phi
    w = min(cmax, 0.5 * math.pi)
    for k in numba.prange(n_rows * n_phi):
        i = k // n_phi
        j = k - i * n_phi
        a = math.tan((i_start + i) * d_alpha)
        u0 = math.cos(j * d_phi)
        u1 = math.sin(j * d_phi)
        alpha, ca, sa, c_psi, s_psi = slope_of(a, 0.0)
        dt, v0, v1, v2 = travel(a, 0.0, u0, u1, speed)
        centre, width = yaw_window(ca, c_psi, s_psi, u0, u1, w)
        f0, r0 = half_min(a, 0.0, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt,
                          smax, np.inf, cmax, chv, centre, width, 0.0)  # fmt: skip
        f1, r1 = half_min(a, 0.0, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt,
                          smax, np.inf, cmax, chv, centre + math.pi, width, math.pi)  # fmt: skip
        f2 = gait_cost(a, 0.0, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt,
                       smax, np.inf, cmax, chv)  # fmt: skip
        table[0, i, j] = f0
        table[1, i, j] = f1
        table[2, i, j] = f2
        table[3, i, j] = speed_at(a, 0.0, u0, u1, r0, chv) if math.isfinite(f0) else np.nan
        table[4, i, j] = speed_at(a, 0.0, u0, u1, r1, chv) if math.isfinite(f1) else np.nan
        table[5, i, j] = speed_at(a, 0.0, u0, u1, 0.0, chv) if math.isfinite(f2) else np.nan
    return table


@numba.njit(cache=True)
def _lerp(table, h, i0, ti, j0, j1, tj):
    return ((1.0 - ti) * ((1.0 - tj) * table[h, i0, j0] + tj * table[h, i0, j1])
            + ti * ((1.0 - tj) * table[h, i0 + 1, j0] + tj * table[h, i0 + 1, j1]))  # fmt: skip


@numba.njit(cache=True, parallel=True)
def map_speeds(gx, gy, chan, consts, heading, tmax, smax, btan, cmax, table, d_alpha, out):
    """The best ground speed of moving along ``heading[r, c]`` (radians) through each cell.

    The choice of ``map_costs`` of ``_motion.py`` for that heading: from the table of
    :func:`speed_heading_table` (the speed of the half whose bilinear cost is least, or
    of walking facing along where that is cheaper, bilinear in the speed nodes) where
    ``map_costs`` reads the table, else exactly (the yaw of ``cheapest_at``). NaN where
    the heading is NaN (no cheapest heading) or the cost is not finite.
    """
    rows, cols = gx.shape
    nch = chan.shape[0]
    ncst = consts.shape[0]
    n_alpha = table.shape[1]
    n_phi = table.shape[2]
    d_phi = 2.0 * math.pi / max(n_phi, 1)
    two_pi = 2.0 * math.pi
    for r in numba.prange(rows):
        chv = np.empty(nch + ncst)
        for k in range(ncst):
            chv[nch + k] = consts[k]
        for c in range(cols):
            a = gx[r, c]
            b = gy[r, c]
            h = heading[r, c]
            ok = math.isfinite(a) and math.isfinite(b) and math.isfinite(h)
            for k in range(nch):
                chv[k] = chan[k, r, c]
                if not math.isfinite(chv[k]):
                    ok = False
            g2 = a * a + b * b
            if not ok or g2 > tmax * tmax:
                out[r, c] = np.nan
                continue
            alpha, ca, sa, c_psi, s_psi = slope_of(a, b)
            back_ok = btan >= 0.0 and g2 <= btan * btan
            fi = alpha / d_alpha if n_alpha >= 2 else np.inf
            exact = True
            v = np.nan
            if fi <= n_alpha - 1:
                i0 = min(int(fi), n_alpha - 2)
                ti = fi - i0
                phi = h - math.atan2(s_psi, c_psi)
                while phi < 0.0:
                    phi += two_pi
                while phi >= two_pi:
                    phi -= two_pi
                fj = phi / d_phi
                j0 = min(int(fj), n_phi - 1)
                tj = fj - j0
                j1 = j0 + 1 if j0 + 1 < n_phi else 0
                fwd = _lerp(table, 2, i0, ti, j0, j1, tj)
                m = _lerp(table, 0, i0, ti, j0, j1, tj)
                half = 0
                exact = not (math.isfinite(m) and math.isfinite(fwd))
                if back_ok:
                    mb = _lerp(table, 1, i0, ti, j0, j1, tj)
                    exact = exact or not math.isfinite(mb)
                    if mb < m:
                        m = mb
                        half = 1
                if not exact:
                    v = _lerp(table, 5 if fwd < m else 3 + half, i0, ti, j0, j1, tj)
            if exact:
                u0 = math.cos(h)
                u1 = math.sin(h)
                dt, v0, v1, v2 = travel(a, b, u0, u1, 1.0)
                fwd = gait_cost(a, b, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt,
                                smax, btan, cmax, chv)  # fmt: skip
                m, yaw = cheapest_at(a, b, u0, u1, 1.0, smax, btan, cmax, chv)
                if fwd < m:
                    m, yaw = fwd, 0.0
                v = speed_at(a, b, u0, u1, yaw, chv) if math.isfinite(m) else np.nan
            out[r, c] = v
