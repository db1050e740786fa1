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

from energy_planner.energy._laurent import laurent_argmin, laurent_value
from energy_planner.energy._sampling import sample_channels, sample_gradient, wrap_angle
from energy_planner.energy.kernels import (
    BLOCKED,
    GAIT_TOL,
    IN_ANG_STEP,
    IN_BLOCKED,
    IN_BTAN,
    IN_CHAN,
    IN_CMAX,
    IN_DX,
    IN_DY,
    IN_EXPS,
    IN_GRAD,
    IN_NEAREST,
    IN_NODES,
    IN_SMAX,
    IN_SPEED,
    IN_STEP,
    IN_TIME_WEIGHT,
    IN_TMAX,
    IN_VINV,
    IN_VMAX,
    IN_VMIN,
    IN_X0,
    IN_Y0,
    IN_YAW_RATE,
    N_KINDS,
    N_OUT,
    NO_CHANNEL,
    OK,
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
def first_pass(x0, y0, ddx, ddy, n, data, chv):
    """Pass 1 of a motion: check the limits at its ``n`` sub-steps, measure its ground length.

    Returns ``(code, surface, gx, gy)``: :data:`OK` or the violation, the length along the
    surface (m) and the last sample's gradient. ``chv`` receives the sampled channels. A
    turn in place (``ddx == ddy == 0``) has every sub-step at ``(x0, y0)``, where each
    would read the same values and add 0 to the length: one is checked.
    """
    if ddx == 0.0 and ddy == 0.0:
        n = 1
    grad = data[IN_GRAD]
    blocked = data[IN_BLOCKED]
    gx0, gy0, gdx, gdy = data[IN_X0], data[IN_Y0], data[IN_DX], data[IN_DY]
    tmax = data[IN_TMAX]
    chan = data[IN_CHAN]
    nearest = data[IN_NEAREST]
    nch = chan.shape[0]
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
            return OUTSIDE, surface, gxs, gys
        if nr > 0:
            r = int(round((y - gy0) / gdy))
            c = int(round((x - gx0) / gdx))
            if 0 <= r < nr and 0 <= c < nc and blocked[r, c]:
                return BLOCKED, surface, gxs, gys
        if gxs * gxs + gys * gys > tmax * tmax:
            return TOO_STEEP, surface, gxs, gys
        if nch > 0 and not sample_channels(chan, nearest, gx0, gy0, gdx, gdy, x, y, chv):
            return NO_CHANNEL, surface, gxs, gys
        dz = gxs * hx + gys * hy
        surface += math.sqrt(hx * hx + hy * hy + dz * dz)
    return OK, surface, gxs, gys


#: Relative slack of a motion's sub-step count: a length or turn that is a whole number of
#: steps up to rounding takes that number of sub-steps, not one more. The same turn given
#: with its yaws 2 pi apart differs by an ulp after :func:`wrap_angle` (1.9 rad: 38 steps
#: of 0.05 as 37.99999999999999 or 38.00000000000001), which changed the energy by ~1e-4.
SUBSTEP_RTOL = 1e-9


@numba.njit(cache=True)
def substeps(dist, step, dth, ang_step):
    """Sub-steps of a motion of map length ``dist`` turning ``dth``, at least one.

    At most ``step`` metres and ``ang_step`` radians each, :data:`SUBSTEP_RTOL` of slack.
    """
    slack = 1.0 - SUBSTEP_RTOL
    return max(1, int(math.ceil(dist / step * slack)), int(math.ceil(abs(dth) / ang_step * slack)))


@numba.njit(cache=True)
def motion_full(x0, y0, th0, x1, y1, th1, duration, data, out):
    grad = data[IN_GRAD]
    gx0, gy0, gdx, gdy = data[IN_X0], data[IN_Y0], data[IN_DX], data[IN_DY]
    speed, yaw_rate, step, ang_step = (data[IN_SPEED], data[IN_YAW_RATE], data[IN_STEP],
                                       data[IN_ANG_STEP])  # fmt: skip
    smax, chan, nearest, btan, cmax = (data[IN_SMAX], data[IN_CHAN], data[IN_NEAREST],
                                       data[IN_BTAN], data[IN_CMAX])  # fmt: skip
    ddx = x1 - x0
    ddy = y1 - y0
    dist = math.sqrt(ddx * ddx + ddy * ddy)
    dth = wrap_angle(th1 - th0)
    n = substeps(dist, step, dth, ang_step)
    for k in range(N_OUT):
        out[k] = 0.0
    out[OUT_TURN] = abs(dth)
    # sampled channel values: scratch space after the results (no allocation per motion)
    nch = chan.shape[0]
    chv = out[N_OUT : N_OUT + nch]
    # pass 1: check the limits and measure the surface length (pass 2 samples the
    # gradient again: cheaper than allocating a buffer per motion)
    hx = ddx / n
    hy = ddy / n
    code, surface, gxs, gys = first_pass(x0, y0, ddx, ddy, n, data, chv)
    if code != OK:
        out[OUT_CODE] = code
        out[OUT_ENERGY] = np.inf
        return
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
    # a turn in place samples (x0, y0) at every sub-step: the gradient, the channels and
    # the slope's own angles once (slope_frame's operations, so the same numbers)
    still = ddx == 0.0 and ddy == 0.0
    alpha = psi = ca = 0.0
    for i in range(n):
        s = (i + 0.5) / n
        x = x0 + s * ddx
        y = y0 + s * ddy
        if i == 0 or not still:
            ok, gxs, gys = sample_gradient(grad, gx0, gy0, gdx, gdy, x, y)
            if nch > 0:
                sample_channels(chan, nearest, gx0, gy0, gdx, gdy, x, y, chv)
            alpha = math.atan(math.sqrt(gxs * gxs + gys * gys))
            psi = math.atan2(gys, gxs)
            ca = math.cos(alpha)
        dz = gxs * hx + gys * hy
        ds = math.sqrt(hx * hx + hy * hy + dz * dz)
        dt = T / n if surface <= 0.0 else T * ds / surface
        th = th0 + s * dth
        gh = th - psi
        gamma = math.atan2(math.sin(gh) * ca, math.cos(gh))
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
def speed_pass(x0, y0, th0, ddx, ddy, dth, n, surface, speeds, data, chv, energy):
    """Energy (J) of a translation at each ground speed of ``speeds``, into ``energy``.

    Pass 2 of :func:`motion_full` at constant ground speed ``v`` (its sub-steps, slope
    frame, tilted body velocity and limits), for several speeds at once: the body twist
    of a sub-step is ``v`` times the one at unit speed (``wz = v dth / surface``), its
    time ``ds / v``, so the geometry is sampled once and only ``power`` is called per
    speed. Returns :data:`OK` or the violation code (cross-slope, gait limits).
    """
    grad = data[IN_GRAD]
    gx0, gy0, gdx, gdy = data[IN_X0], data[IN_Y0], data[IN_DX], data[IN_DY]
    smax, chan, nearest = data[IN_SMAX], data[IN_CHAN], data[IN_NEAREST]
    btan, cmax = data[IN_BTAN], data[IN_CMAX]
    nch = chan.shape[0]
    m = speeds.shape[0]
    for j in range(m):
        energy[j] = 0.0
    dist = math.sqrt(ddx * ddx + ddy * ddy)
    hx = ddx / n
    hy = ddy / n
    w = dth / surface
    for i in range(n):
        s = (i + 0.5) / n
        x = x0 + s * ddx
        y = y0 + s * ddy
        ok, gxs, gys = sample_gradient(grad, gx0, gy0, gdx, gdy, x, y)
        if nch > 0:
            sample_channels(chan, nearest, gx0, gy0, gdx, gdy, x, y, chv)
        dz = gxs * hx + gys * hy
        ds = math.sqrt(hx * hx + hy * hy + dz * dz)
        th = th0 + s * dth
        alpha, gamma = slope_frame(gxs, gys, th)
        if math.sin(alpha) * abs(math.sin(gamma)) > smax:
            return TOO_CROSS
        ux, uy = body_velocity(gxs, gys, th, hx / ds, hy / ds, dz / ds)
        code = gait_violation(gxs, gys, ux, uy, dist, btan, cmax)
        if code != 0:
            return code
        for j in range(m):
            v = speeds[j]
            p, kinds = power(alpha, gamma, v * ux, v * uy, v * w, 0.0, 0.0, chv)
            energy[j] += p * ds / v
    return OK


#: Golden-section iterations of a motion whose energy is not a Laurent polynomial in
#: speed (the bracket shrinks to 0.618^30, 5e-7, of the speed range).
SPEED_GOLDEN_ITERS = 30
#: Relative tolerance of the check of the Laurent fit of a motion (as
#: :data:`energy_planner.energy.speed.FIT_RTOL`).
SPEED_FIT_RTOL = 1e-7


@numba.njit(cache=True)
def _speed_cost(x0, y0, th0, ddx, ddy, dth, n, surface, v, lam, data, chv, one, e):
    """Energy + ``lam`` x time of the translation at ground speed ``v`` (inf: a limit)."""
    one[0] = v
    if speed_pass(x0, y0, th0, ddx, ddy, dth, n, surface, one, data, chv, e) != OK:
        return np.inf
    return e[0] + lam * surface / v


@numba.njit(cache=True)
def motion_best(x0, y0, th0, x1, y1, th1, duration, data, out):
    """:func:`motion_full` at the ground speed that minimises energy + lambda x time.

    The speed range ``[IN_VMIN, IN_VMAX]`` and the price of a second ``lambda``
    (``IN_TIME_WEIGHT``, J/s) come from ``data``. A translation's energy is a Laurent
    polynomial in its speed (:mod:`energy_planner.energy.speed`): it is priced at the
    node speeds ``IN_NODES`` in one pass (:func:`speed_pass`), its coefficients solved
    (``IN_VINV``), checked at the last node, and minimised in closed form
    (:func:`energy_planner.energy._laurent.laurent_argmin`); where the check fails, by
    golden section over the range. A motion that also turns may not be faster than its
    turn allows (``surface * yaw_rate / |dth|``). Turns in place, and motions given a
    ``duration``, are :func:`motion_full`'s.

    Fills ``out[OUT_ENERGY]`` with energy + lambda x duration (the objective; the energy
    when lambda is 0), ``OUT_DURATION``, ``OUT_DISTANCE``, ``OUT_TURN`` and ``OUT_CODE``;
    the other entries are 0 (price the chosen durations with :func:`path_table` for
    them).
    """
    vmin, vmax, lam = data[IN_VMIN], data[IN_VMAX], data[IN_TIME_WEIGHT]
    step, ang_step, yaw_rate = data[IN_STEP], data[IN_ANG_STEP], data[IN_YAW_RATE]
    ddx = x1 - x0
    ddy = y1 - y0
    dist = math.sqrt(ddx * ddx + ddy * ddy)
    if duration > 0.0 or dist <= 0.0:
        motion_full(x0, y0, th0, x1, y1, th1, duration, data, out)
        out[OUT_ENERGY] += lam * out[OUT_DURATION]
        return
    dth = wrap_angle(th1 - th0)
    n = substeps(dist, step, dth, ang_step)
    for k in range(N_OUT):
        out[k] = 0.0
    out[OUT_TURN] = abs(dth)
    chv = out[N_OUT : N_OUT + data[IN_CHAN].shape[0]]
    code, surface, gxs, gys = first_pass(x0, y0, ddx, ddy, n, data, chv)
    if code != OK:
        out[OUT_CODE] = code
        out[OUT_ENERGY] = np.inf
        return
    hi = vmax
    if dth != 0.0:
        hi = min(hi, surface * yaw_rate / abs(dth))
    lo = min(vmin, hi)
    exps = data[IN_EXPS]
    nodes = data[IN_NODES]
    vinv = data[IN_VINV]
    k = nodes.shape[0] - 1
    one = np.empty(1)
    e1 = np.empty(1)
    best_v = lo
    best_f = np.inf
    solved = False
    if k > 0 and hi > lo:
        energy = np.empty(k + 1)
        code = speed_pass(x0, y0, th0, ddx, ddy, dth, n, surface, nodes, data, chv, energy)
        if code != OK:
            out[OUT_CODE] = code
            out[OUT_ENERGY] = np.inf
            return
        c = np.zeros(k)
        scale = 0.0
        for a in range(k):
            for b in range(k):
                c[a] += vinv[a, b] * energy[b]
        for a in range(k + 1):
            scale = max(scale, abs(energy[a]))
        pred = laurent_value(c, exps, nodes[k])
        if abs(pred - energy[k]) <= SPEED_FIT_RTOL * scale + 1e-12:
            for a in range(k):
                if exps[a] == -1.0:
                    c[a] += lam * surface
            best_v = laurent_argmin(c, exps, lo, hi)
            best_f = laurent_value(c, exps, best_v)
            solved = True
    if not solved:
        if hi > lo:  # golden section over the range (assumes one minimum in it)
            g = 0.3819660112501051
            a_, b_ = lo, hi
            xa = a_ + g * (b_ - a_)
            xb = b_ - g * (b_ - a_)
            fa = _speed_cost(x0, y0, th0, ddx, ddy, dth, n, surface, xa, lam, data, chv, one, e1)
            fb = _speed_cost(x0, y0, th0, ddx, ddy, dth, n, surface, xb, lam, data, chv, one, e1)
            for _ in range(SPEED_GOLDEN_ITERS):
                if fa <= fb:
                    b_, xb, fb = xb, xa, fa
                    xa = a_ + g * (b_ - a_)
                    fa = _speed_cost(x0, y0, th0, ddx, ddy, dth, n, surface, xa, lam, data, chv,
                                     one, e1)  # fmt: skip
                else:
                    a_, xa, fa = xa, xb, fb
                    xb = b_ - g * (b_ - a_)
                    fb = _speed_cost(x0, y0, th0, ddx, ddy, dth, n, surface, xb, lam, data, chv,
                                     one, e1)  # fmt: skip
            best_v, best_f = (xa, fa) if fa <= fb else (xb, fb)
            for v in (lo, hi):
                f = _speed_cost(x0, y0, th0, ddx, ddy, dth, n, surface, v, lam, data, chv, one, e1)
                if f < best_f:
                    best_v, best_f = v, f
        else:
            best_v = lo
            best_f = _speed_cost(x0, y0, th0, ddx, ddy, dth, n, surface, lo, lam, data, chv, one,
                                 e1)  # fmt: skip
        if not math.isfinite(best_f):
            code = speed_pass(x0, y0, th0, ddx, ddy, dth, n, surface, one, data, chv, e1)
            out[OUT_CODE] = code if code != OK else TOO_CROSS
            out[OUT_ENERGY] = np.inf
            return
    out[OUT_ENERGY] = best_f
    out[OUT_DURATION] = surface / best_v
    out[OUT_DISTANCE] = surface


@numba.njit(cache=True)
def motion_priced(x0, y0, th0, x1, y1, th1, duration, data, out):
    """The motion at its chosen speed, or at the nominal one.

    :func:`motion_best` when ``data`` gives a speed range or a time price, else
    :func:`motion_full` (the nominal speed: the fixed-speed code, unchanged).
    """
    if data[IN_VMAX] > data[IN_VMIN] or data[IN_TIME_WEIGHT] > 0.0:
        motion_best(x0, y0, th0, x1, y1, th1, duration, data, out)
    else:
        motion_full(x0, y0, th0, x1, y1, th1, duration, data, out)


@numba.njit(cache=True)
def motion_cost(x0, y0, th0, x1, y1, th1, data):
    out = np.empty(N_OUT + data[IN_CHAN].shape[0])
    motion_priced(x0, y0, th0, x1, y1, th1, -1.0, data, out)
    return out[OUT_ENERGY]


@numba.njit(cache=True)
def motion_batch(x0, y0, th0, x1, y1, th1, data):
    n = x0.shape[0]
    res = np.empty(n)
    out = np.empty(N_OUT + data[IN_CHAN].shape[0])
    for i in range(n):
        motion_priced(x0[i], y0[i], th0[i], x1[i], y1[i], th1[i], -1.0, data, out)
        res[i] = out[OUT_ENERGY]
    return res


@numba.njit(cache=True)
def path_speeds(x, y, th, data):
    """Durations (s) of consecutive motions at their best speeds (:func:`motion_priced`).

    ``inf`` for a motion that breaks a limit. Price the poses with these durations
    (:func:`path_table`) for the energy and its breakdown.
    """
    m = x.shape[0] - 1
    res = np.empty(max(m, 0))
    out = np.empty(N_OUT + data[IN_CHAN].shape[0])
    for i in range(m):
        motion_priced(x[i], y[i], th[i], x[i + 1], y[i + 1], th[i + 1], -1.0, data, out)
        res[i] = out[OUT_DURATION] if math.isfinite(out[OUT_ENERGY]) else np.inf
    return res


@numba.njit(cache=True)
def path_table(x, y, th, durations, data):
    m = x.shape[0] - 1
    table = np.empty((max(m, 0), N_OUT))
    out = np.empty(N_OUT + data[IN_CHAN].shape[0])
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


# --- the cheapest way to move along a heading, over the body's yaw ------------------
#: Coarse step of the sweep over the body's yaw relative to the travel, radians; each of
#: the two best local minima of the sweep is then refined by golden-section search.
YAW_SWEEP_STEP = math.radians(6.0)
#: Golden-section iterations of a refinement: the bracket (two sweep steps) shrinks by
#: 0.618 per iteration, to 0.02 degrees.
YAW_REFINE_ITERS = 14
#: The second-lowest local minimum of the sweep is refined too when it is within this
#: factor of the lowest (a basin between two sweep samples may hold the true minimum).
SECOND_BASIN = 1.1


@numba.njit(cache=True)
def slope_of(a, b):
    """``(alpha, cos alpha, sin alpha, cos psi, sin psi)`` of gradient (a, b).

    ``psi`` is the uphill azimuth; on flat ground ``atan2(0, 0) = 0`` (cos 1, sin 0).
    """
    g = math.sqrt(a * a + b * b)
    alpha = math.atan(g)
    c_psi = a / g if g > 0.0 else 1.0
    s_psi = b / g if g > 0.0 else 0.0
    return alpha, math.cos(alpha), math.sin(alpha), c_psi, s_psi


@numba.njit(cache=True)
def travel(a, b, u0, u1, speed):
    """Time per map metre and 3-D velocity of walking along unit map direction (u0, u1).

    The robot keeps ``speed`` along the ground (as :func:`motion_full`): a map metre is
    ``sqrt(1 + dz^2)`` metres of ground, ``dz = g . u``.
    """
    dz = a * u0 + b * u1
    dt = math.sqrt(1.0 + dz * dz) / speed
    return dt, u0 / dt, u1 / dt, dz / dt


@numba.njit(cache=True)
def gait_at(a, b, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt, smax, btan, cmax,
            chv, r):  # fmt: skip
    """J per map metre along (u0, u1) with the body yaw turned ``r`` from the travel.

    ``r`` is a map angle; ``inf`` where the gait breaks a limit (:func:`gait_cost`).
    """
    cr = math.cos(r)
    sr = math.sin(r)
    return gait_cost(a, b, alpha, ca, sa, c_psi, s_psi, u0 * cr - u1 * sr, u1 * cr + u0 * sr,
                     v0, v1, v2, dt, smax, btan, cmax, chv)  # fmt: skip


@numba.njit(cache=True)
def _golden(a, b, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt, smax, btan, cmax, chv,
            lo, hi, fb, rb):  # fmt: skip
    """Golden-section search of :func:`gait_at` over ``r`` in [lo, hi].

    Returns the best of it and the known point ``(rb, fb)``.
    """
    g = 0.3819660112501051  # 2 - golden ratio
    x1 = lo + g * (hi - lo)
    x2 = hi - g * (hi - lo)
    f1 = gait_at(a, b, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt, smax, btan, cmax,
                 chv, x1)  # fmt: skip
    f2 = gait_at(a, b, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt, smax, btan, cmax,
                 chv, x2)  # fmt: skip
    for _ in range(YAW_REFINE_ITERS):
        if f1 <= f2:
            hi = x2
            x2 = x1
            f2 = f1
            x1 = lo + g * (hi - lo)
            f1 = gait_at(a, b, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt, smax, btan,
                         cmax, chv, x1)  # fmt: skip
        else:
            lo = x1
            x1 = x2
            f1 = f2
            x2 = hi - g * (hi - lo)
            f2 = gait_at(a, b, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt, smax, btan,
                         cmax, chv, x2)  # fmt: skip
    if f1 < fb:
        fb, rb = f1, x1
    if f2 < fb:
        fb, rb = f2, x2
    return fb, rb


@numba.njit(cache=True)
def half_min(a, b, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt, smax, btan, cmax, chv,
             centre, width, anchor):  # fmt: skip
    """Least :func:`gait_at` over ``r`` in ``[centre - width, centre + width]``: ``(J/m, r)``.

    A sweep at about :data:`YAW_SWEEP_STEP` (endpoints included), then a golden-section
    refinement within one sweep step either side of each of the two lowest local minima
    of the sweep (the second only within :data:`SECOND_BASIN` of the lowest); ``anchor``,
    a yaw in the interval, is a candidate too (the body along the travel or its
    opposite: a kink of most models, ``|vy|``, where the minimum often lies). Every value
    returned is an evaluated cost (of a yaw in the interval), ``inf`` if every sampled
    yaw breaks a limit (cross-slope ``smax``, gait limits ``btan``, ``cmax``).
    """
    fa = gait_at(a, b, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt, smax, btan, cmax,
                 chv, anchor)  # fmt: skip
    if width <= 0.0:
        return fa, anchor
    lo = centre - width
    hi = centre + width
    n = max(2, int(math.ceil((hi - lo) / YAW_SWEEP_STEP)))
    h = (hi - lo) / n
    b1 = b2 = np.inf
    r1 = r2 = centre
    f_prev = np.inf
    f_cur = gait_at(a, b, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt, smax, btan, cmax,
                    chv, lo)  # fmt: skip
    for k in range(n + 1):
        f_next = np.inf
        if k < n:
            f_next = gait_at(a, b, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt, smax,
                             btan, cmax, chv, lo + (k + 1) * h)  # fmt: skip
        if f_cur <= f_prev and f_cur <= f_next:  # a local minimum of the sweep
            if f_cur < b1:
                b2, r2 = b1, r1
                b1, r1 = f_cur, lo + k * h
            elif f_cur < b2:
                b2, r2 = f_cur, lo + k * h
        f_prev = f_cur
        f_cur = f_next
    if b1 < np.inf:
        b1, r1 = _golden(a, b, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt, smax, btan,
                         cmax, chv, max(lo, r1 - h), min(hi, r1 + h), b1, r1)  # fmt: skip
    if b2 < SECOND_BASIN * b1:
        b2, r2 = _golden(a, b, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt, smax, btan,
                         cmax, chv, max(lo, r2 - h), min(hi, r2 + h), b2, r2)  # fmt: skip
    if b2 < b1:
        b1, r1 = b2, r2
    if fa < b1:
        return fa, anchor
    return b1, r1


@numba.njit(cache=True)
def yaw_window(ca, c_psi, s_psi, u0, u1, w):
    """Map yaws of a body within in-plane angle ``w`` of the travel: ``(centre, width)``.

    The gait limits hold on angles in the slope plane (:func:`gait_violation`: the angle
    between body x and the velocity), the sweep of :func:`half_min` runs over map angles
    ``r`` relative to the travel (u0, u1). A map direction ``m`` from uphill lies at
    ``atan2(cos(alpha) sin m, cos m)`` in the plane (as :func:`slope_frame`), so the
    in-plane interval ``[t0 - w, t0 + w]`` around the travel's ``t0`` maps to the map yaws
    ``[centre - width, centre + width]``, exactly (``w <= pi / 2``; ``ca``: cos of the
    slope; ``c_psi``, ``s_psi``: the uphill azimuth). Near the fall line the window is
    wider than ``w`` (up to ``2 atan(tan(w / 2) / cos(alpha))``), across it narrower; its
    opposite (walking backward) is the same window turned by ``pi``.
    """
    if w <= 0.0:
        return 0.0, 0.0
    cphi = u0 * c_psi + u1 * s_psi  # the travel from uphill (map angle phi)
    sphi = u1 * c_psi - u0 * s_psi
    phi = math.atan2(sphi, cphi)
    t0 = math.atan2(ca * sphi, cphi)  # in the slope plane
    lo = wrap_angle(math.atan2(math.sin(t0 - w), ca * math.cos(t0 - w)) - phi)
    hi = wrap_angle(math.atan2(math.sin(t0 + w), ca * math.cos(t0 + w)) - phi)
    if hi < lo - math.pi:  # wrapped across +-pi (lo <= 0 <= hi before wrapping)
        hi += 2.0 * math.pi
    return 0.5 * (lo + hi), max(0.5 * (hi - lo), 0.0)


@numba.njit(cache=True)
def cheapest_at(a, b, u0, u1, speed, smax, btan, cmax, chv):
    """The cheapest way to move along unit map direction (u0, u1) on gradient (a, b).

    Least J per map metre over the body's yaw ``r`` relative to the travel, within the
    gait limits of :func:`gait_violation` (angles in the slope plane): body x within
    ``cmax`` of the travel (walking forward or sideways) or of its opposite (walking
    backward, only where ``|g| <= btan``: never if it is negative); ``cmax >= pi / 2`` is
    no crab limit. Returns ``(J per map metre, r)``, ``r`` in (-pi, pi] (map angle);
    ``inf`` if no allowed yaw may move (cross-slope limit ``smax``). The continuous
    minimum of :func:`half_min` on each half of the yaws (:func:`yaw_window`).
    """
    alpha, ca, sa, c_psi, s_psi = slope_of(a, b)
    dt, v0, v1, v2 = travel(a, b, u0, u1, speed)
    centre, width = yaw_window(ca, c_psi, s_psi, u0, u1, min(cmax, 0.5 * math.pi))
    f, r = half_min(a, b, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt, smax, btan,
                    cmax, chv, centre, width, 0.0)  # fmt: skip
    if btan >= 0.0 and a * a + b * b <= btan * btan:
        fb, rb = half_min(a, b, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt, smax,
                          btan, cmax, chv, centre + math.pi, width, math.pi)  # fmt: skip
        if fb < f:
            f, r = fb, wrap_angle(rb)
    return f, r


@numba.njit(cache=True, parallel=True)
def cheapest_batch(gx, gy, heading, speed, smax, btan, cmax, chan, consts):
    """:func:`cheapest_at` of every ``(gx[i], gy[i], heading[i])``; channels ``chan[:, i]``.

    ``consts``: the constant channels (``--set``), read after the rasters: run-time
    inputs, so that a new value needs no compilation. Returns ``(J per map metre, body
    yaw relative to the travel)`` arrays; NaN where the gradient or a channel is not
    finite.
    """
    n = gx.shape[0]
    cost = np.empty(n)
    yaw = np.empty(n)
    nch = chan.shape[0]
    ncst = consts.shape[0]
    for i in numba.prange(n):
        chv = np.empty(nch + ncst)
        ok = math.isfinite(gx[i]) and math.isfinite(gy[i]) and math.isfinite(heading[i])
        for k in range(nch):
            chv[k] = chan[k, i]
            ok = ok and math.isfinite(chv[k])
        for k in range(ncst):
            chv[nch + k] = consts[k]
        if not ok:
            cost[i] = yaw[i] = np.nan
            continue
        cost[i], yaw[i] = cheapest_at(gx[i], gy[i], math.cos(heading[i]), math.sin(heading[i]),
                                      speed, smax, btan, cmax, chv)  # fmt: skip
    return cost, yaw


@numba.njit(cache=True, parallel=True)
def heading_table(speed, smax, cmax, d_alpha, i_start, n_rows, n_phi, chv):
    """The cheapest J per map metre at table nodes, each half of the body's yaws apart.

    ``table[0, i, j]``: body within ``cmax`` (at most pi/2, in the slope plane) of the
    travel direction; ``table[1, i, j]``: within ``cmax`` of its opposite (walking
    backward, whatever the slope: the backward-slope limit is applied per cell by
    :func:`map_costs`); ``table[2, i, j]``: walking forward facing the travel; on ground
    of slope ``(i_start + i) * d_alpha`` travelling ``2 pi j / n_phi`` counter-clockwise
    from uphill (map angles): :func:`half_min` of each half, as :func:`cheapest_at`
    computes them. ``n_rows`` rows of slope; each node is computed on its own, so a table
    built in pieces equals one built whole.
    """
    table = np.empty((3, n_rows, n_phi))
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
        table[0, i, j] = half_min(a, 0.0, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt,
                                  smax, np.inf, cmax, chv, centre, width, 0.0)[0]  # fmt: skip
        table[1, i, j] = half_min(a, 0.0, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt,
                                  smax, np.inf, cmax, chv, centre + math.pi, width,
                                  math.pi)[0]  # fmt: skip
        table[2, i, j] = gait_cost(a, 0.0, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt,
                                   smax, np.inf, cmax, chv)  # fmt: skip
    return table


@numba.njit(cache=True)
def _lerp_table(table, h, i0, ti, j0, j1, tj):
    return ((1.0 - ti) * ((1.0 - tj) * table[h, i0, j0] + tj * table[h, i0, j1])
            + ti * ((1.0 - tj) * table[h, i0 + 1, j0] + tj * table[h, i0 + 1, j1]))  # fmt: skip


@numba.njit(cache=True, parallel=True)
def map_costs(gx, gy, chan, consts, headings, speed, tmax, smax, btan, cmax, table, d_alpha,
              along, best):  # fmt: skip
    """Energy-map costs of a block of cells (J per metre of map distance).

    ``gx``, ``gy``: gradient of the block's cells, shape (rows, cols); ``chan``: raster
    channels on the same cells, shape (k, rows, cols), category indices for categorical
    ones; ``consts``: the constant channels (``--set``), read after the rasters (run-time
    inputs: a new value needs no compilation). ``along[j, r, c]``: walking forward along
    ``headings[j]`` (facing along);
    ``best[j, r, c]``: the cheapest way to move along it over the body's yaw within the
    gait limits (:func:`cheapest_at`), never above ``along``. Both bilinear in ``table``
    (of :func:`heading_table`, slope step ``d_alpha``) where the cell's slope is inside
    it and the four nodes are finite, else exactly (:func:`gait_cost`,
    :func:`cheapest_at`). Each is the limit of :func:`motion_full` for a short straight motion
    through the cell centre, divided by its map length. NaN where the gradient or a
    channel is undefined, ``inf`` above a slope limit. An empty ``table`` (channel
    rasters: the cost varies with them) computes every ``best`` by :func:`cheapest_at`.
    """
    rows, cols = gx.shape
    nh = headings.shape[0]
    nch = chan.shape[0]
    ncst = consts.shape[0]
    n_alpha = table.shape[1]
    n_phi = table.shape[2]
    d_phi = 2.0 * math.pi / max(n_phi, 1)
    two_pi = 2.0 * math.pi
    hc = np.cos(headings)
    hs = np.sin(headings)
    for r in numba.prange(rows):
        chv = np.empty(nch + ncst)
        for k in range(ncst):
            chv[nch + k] = consts[k]
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
            alpha, ca, sa, c_psi, s_psi = slope_of(a, b)
            back_ok = btan >= 0.0 and g2 <= btan * btan
            fi = alpha / d_alpha if n_alpha >= 2 else np.inf
            in_table = fi <= n_alpha - 1
            i0 = 0
            ti = 0.0
            psi = 0.0
            if in_table:
                i0 = min(int(fi), n_alpha - 2)
                ti = fi - i0
                psi = math.atan2(s_psi, c_psi)
            for j in range(nh):
                fwd = np.inf
                m = np.inf
                exact = True
                if in_table:
                    phi = headings[j] - psi
                    if phi < 0.0:
                        phi += two_pi
                    elif phi >= two_pi:
                        phi -= two_pi
                    fj = phi / d_phi
                    j0 = min(int(fj), n_phi - 1)
                    tj = fj - j0
                    j1 = j0 + 1 if j0 + 1 < n_phi else 0
                    fwd = _lerp_table(table, 2, i0, ti, j0, j1, tj)
                    m = _lerp_table(table, 0, i0, ti, j0, j1, tj)
                    # a node where the gait breaks the cross-slope limit: exactly
                    exact = not (math.isfinite(m) and math.isfinite(fwd))
                    if back_ok:
                        mb = _lerp_table(table, 1, i0, ti, j0, j1, tj)
                        exact = exact or not math.isfinite(mb)
                        m = min(m, mb)
                if exact:
                    u0 = hc[j]
                    u1 = hs[j]
                    dt, v0, v1, v2 = travel(a, b, u0, u1, speed)
                    fwd = gait_cost(a, b, alpha, ca, sa, c_psi, s_psi, u0, u1, v0, v1, v2, dt,
                                    smax, btan, cmax, chv)  # fmt: skip
                    m = cheapest_at(a, b, u0, u1, speed, smax, btan, cmax, chv)[0]
                along[j, r, c] = fwd
                best[j, r, c] = min(m, fwd)
