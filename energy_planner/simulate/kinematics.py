"""Twist profiles, pose on a planar slope and the IMU orientation.

Geometry (design notes, "Relations between slope, heading and the IMU"): a planar slope
of angle ``alpha`` whose uphill direction has azimuth ``psi`` has the in-plane unit
vectors ``e_up = (cos a cos psi, cos a sin psi, sin a)`` (uphill),
``e_side = (-sin psi, cos psi, 0)`` (horizontal, 90 degrees counter-clockwise from
uphill) and the normal ``n = (-sin a cos psi, -sin a sin psi, cos a)``. The robot's
body z is ``n``; its body x makes the in-plane angle ``gamma`` with ``e_up``::

    body x = cos(gamma) e_up + sin(gamma) e_side,   body y = n x body x
           = cos(gamma) e_side - sin(gamma) e_up

This is the contract's ``body x = unit(cos th, sin th, tan(a) cos(th - psi))`` with the
horizontal yaw ``th = psi + atan2(sin gamma, cos gamma cos a)``, and the IMU relation
``gamma = -atan2(u_y, u_x)`` returns exactly this ``gamma`` (the in-plane heading).
Note that ``th - psi`` equals ``gamma`` only on level ground or along the fall line;
at 25 degrees and ``gamma = 45`` degrees, ``th - psi = 47.8`` degrees.

Body yaw rate ``wz`` turns the body about ``n``, so ``gamma`` integrates ``wz``.

Examples
--------
>>> import numpy as np
>>> t, vx, vy, wz, ax, ay = twist_profile([(2.0, 0.3, 0.0, 0.0)], ramp_s=1.0, dt=0.5)
>>> t.tolist()
[0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0]
>>> np.round(vx, 3).tolist()
[0.0, 0.15, 0.3, 0.3, 0.3, 0.15, 0.0]
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from energy_planner.angles import wrap  # re-exported: one wrapping convention, (-pi, pi]

__all__ = [
    "twist_profile",
    "slope_frame",
    "integrate_pose",
    "body_to_world",
    "imu_quaternion",
    "quat_mul",
    "quat_from_rotvec",
    "wrap",
]

Segment = tuple[float, float, float, float]  # (duration_s, vx, vy, wz)


def twist_profile(segments: Sequence[Segment], ramp_s: float, dt: float) -> tuple[np.ndarray, ...]:
    """Sampled body twist of a run made of constant-twist segments with linear ramps.

    The commanded twist ``u(t)`` is piecewise constant (zero before the first and after
    the last segment). The executed twist is its moving average over ``ramp_s``
    (``v(tau) = (1/ramp_s) * integral of u over [tau - ramp_s, tau]``), which turns every
    step into a linear ramp and keeps every integral (distance, angle): a run of
    segments lasting ``T`` lasts ``T + ramp_s``.

    Parameters
    ----------
    segments : sequence of (duration_s, vx, vy, wz)
        Durations should be multiples of ``dt`` (then the energy of a piecewise-linear
        power is integrated exactly by the trapezoid rule).
    ramp_s : float
        Ramp length, s; 0 for steps.
    dt : float
        Sample period, s.

    Returns
    -------
    t, vx, vy, wz, ax, ay : ndarray
        Time from 0 (s), twist (m/s, m/s, rad/s) and the body-frame acceleration
        ``(d vx/dt, d vy/dt)`` (m/s^2; the average of the two one-sided slopes at a
        kink).
    """
    seg = np.asarray(segments, dtype=float).reshape(-1, 4)
    dur = seg[:, 0]
    edges = np.concatenate([[0.0], np.cumsum(dur)])
    total = edges[-1] + ramp_s
    n = int(round(total / dt)) + 1
    t = np.arange(n) * dt
    out: list[np.ndarray] = []
    acc: list[np.ndarray] = []
    for j in (1, 2, 3):
        vals = seg[:, j]
        if ramp_s > 0:
            cum = np.concatenate([[0.0], np.cumsum(vals * dur)])

            def v_at(tau: np.ndarray, cum: np.ndarray = cum) -> np.ndarray:
                return (np.interp(tau, edges, cum) - np.interp(tau - ramp_s, edges, cum)) / ramp_s

            out.append(v_at(t))
            acc.append((v_at(t + dt / 2) - v_at(t - dt / 2)) / dt)
        else:
            # steps: a sample on a junction takes the mean of both sides, so that the
            # trapezoid rule still integrates the distance exactly
            # (compared in whole samples, free of rounding)
            k, ke = np.arange(n), np.rint(edges / dt).astype(int)
            right = np.clip(np.searchsorted(ke, k, side="right") - 1, 0, len(vals) - 1)
            left = np.clip(np.searchsorted(ke, k, side="left") - 1, 0, len(vals) - 1)
            out.append((vals[right] + vals[left]) / 2)
            acc.append(np.zeros(n))
    return t, out[0], out[1], out[2], acc[0], acc[1]


def slope_frame(alpha: float, psi: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """In-plane uphill, in-plane sideways (left of uphill) and normal unit vectors.

    >>> e_up, e_side, n = slope_frame(np.radians(30.0), 0.0)
    >>> np.round(e_up, 3).tolist(), np.round(n, 3).tolist()
    ([0.866, 0.0, 0.5], [-0.5, -0.0, 0.866])
    """
    ca, sa, cp, sp = np.cos(alpha), np.sin(alpha), np.cos(psi), np.sin(psi)
    e_up = np.array([ca * cp, ca * sp, sa])
    e_side = np.array([-sp, cp, 0.0])
    n = np.array([-sa * cp, -sa * sp, ca])
    return e_up, e_side, n


def _cumtrapz(y: np.ndarray, dt: float) -> np.ndarray:
    out = np.zeros_like(y)
    out[1:] = np.cumsum((y[1:] + y[:-1]) * (dt / 2))
    return out


def integrate_pose(
    t: np.ndarray,
    vx: np.ndarray,
    vy: np.ndarray,
    wz: np.ndarray,
    alpha: float,
    psi: float,
    gamma0: float,
    start: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Integrate the body twist on the plane (trapezoid rule).

    Parameters
    ----------
    t, vx, vy, wz : ndarray
        Uniformly sampled time (s) and true body twist.
    alpha, psi : float
        Slope and uphill azimuth, rad.
    gamma0 : float
        In-plane heading at ``t[0]``, rad.
    start : ndarray, optional
        World position (x, y, z) at ``t[0]``, m (default the origin).

    Returns
    -------
    pos : ndarray (n, 3)
        World position, m (ENU).
    gamma : ndarray
        In-plane heading relative to uphill, rad (not wrapped).
    yaw : ndarray
        Horizontal yaw of body x, rad, wrapped to ``(-pi, pi]``.

    Examples
    --------
    Walking 1 m straight uphill on a 30 degree slope rises 0.5 m:

    >>> t = np.linspace(0, 1, 11)
    >>> pos, g, yaw = integrate_pose(t, np.ones(11), np.zeros(11), np.zeros(11),
    ...                              np.radians(30.0), 0.0, 0.0)
    >>> np.round(pos[-1], 3).tolist()
    [0.866, 0.0, 0.5]
    """
    dt = float(t[1] - t[0]) if len(t) > 1 else 1.0
    gamma = gamma0 + _cumtrapz(wz, dt)
    c, s = np.cos(gamma), np.sin(gamma)
    p_up = _cumtrapz(vx * c - vy * s, dt)
    p_side = _cumtrapz(vx * s + vy * c, dt)
    e_up, e_side, _ = slope_frame(alpha, psi)
    pos = p_up[:, None] * e_up + p_side[:, None] * e_side
    if start is not None:
        pos = pos + np.asarray(start, dtype=float)
    yaw = wrap(psi + np.arctan2(s, c * np.cos(alpha)))
    return pos, gamma, yaw


def body_to_world(alpha: float, psi: float, gamma: np.ndarray) -> np.ndarray:
    """Rotation matrices body to world (ENU), shape ``(n, 3, 3)``, columns body x, y, z.

    >>> R = body_to_world(0.0, 0.0, np.array([np.pi / 2]))
    >>> (np.round(R[0], 6) + 0.0).tolist()
    [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    """
    e_up, e_side, n = slope_frame(alpha, psi)
    c, s = np.cos(gamma)[:, None], np.sin(gamma)[:, None]
    bx = c * e_up + s * e_side
    by = c * e_side - s * e_up
    bz = np.broadcast_to(n, bx.shape)
    return np.stack([bx, by, bz], axis=2)


def quat_mul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product of quaternions ``(w, x, y, z)`` along the last axis.

    >>> quat_mul(np.array([0.0, 1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0, 0.0])).tolist()
    [0.0, 0.0, 0.0, 1.0]
    """
    pw, px, py, pz = np.moveaxis(np.asarray(p, float), -1, 0)
    qw, qx, qy, qz = np.moveaxis(np.asarray(q, float), -1, 0)
    return np.stack(
        [
            pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw,
        ],
        axis=-1,
    )


def quat_from_rotvec(r: np.ndarray) -> np.ndarray:
    """Quaternions ``(w, x, y, z)`` of rotation vectors (axis times angle, rad), shape (n, 3).

    >>> np.round(quat_from_rotvec(np.array([[0.0, 0.0, np.pi]])), 12).tolist()
    [[0.0, 0.0, 0.0, 1.0]]
    """
    r = np.asarray(r, float)
    angle = np.linalg.norm(r, axis=-1)
    half = angle / 2
    # sin(half) / angle, with its limit 1/2 at zero angle
    k = np.where(angle > 1e-12, np.sin(half) / np.where(angle > 1e-12, angle, 1.0), 0.5)
    return np.concatenate([np.cos(half)[..., None], r * k[..., None]], axis=-1)


def imu_quaternion(alpha: np.ndarray, psi: np.ndarray, gamma: np.ndarray) -> np.ndarray:
    """Body-to-world quaternions ``(qw, qx, qy, qz)``, ``qw >= 0``, of :func:`body_to_world`.

    ``R = Rz(psi) Ry(-alpha) Rz(gamma)``: the slope frame (``e_up, e_side, n``) is
    ``Rz(psi) Ry(-alpha)``, and body x makes the in-plane angle ``gamma`` with ``e_up``.

    Examples
    --------
    >>> q = imu_quaternion(np.array([0.3]), np.array([1.0]), np.array([-2.0]))
    >>> w, x, y, z = q[0]
    >>> R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
    ...               [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
    ...               [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    >>> bool(np.allclose(R, body_to_world(0.3, 1.0, np.array([-2.0]))[0]))
    True
    """
    alpha, psi, gamma = np.broadcast_arrays(*(np.asarray(a, float) for a in (alpha, psi, gamma)))
    zero = np.zeros_like(alpha)
    qz_psi = np.stack([np.cos(psi / 2), zero, zero, np.sin(psi / 2)], axis=-1)
    qy_alpha = np.stack([np.cos(alpha / 2), zero, -np.sin(alpha / 2), zero], axis=-1)
    qz_gamma = np.stack([np.cos(gamma / 2), zero, zero, np.sin(gamma / 2)], axis=-1)
    q = quat_mul(quat_mul(qz_psi, qy_alpha), qz_gamma)
    return np.where(q[..., :1] < 0, -q, q)
