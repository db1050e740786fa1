"""Slope and relative heading from the IMU gravity vector.

Relation shared by the whole project (design notes): with ``R`` the body-to-world
rotation of the IMU quaternion, the world up vector seen in the body frame is
``u = R^T (0, 0, 1)``; then ``alpha = arccos(u_z)`` and ``gamma = -atan2(u_y, u_x)``
(``u_x > 0`` facing uphill; ``gamma = +pi/2`` when uphill is on the robot's right).
On a planar slope of angle ``alpha``, uphill azimuth ``psi`` and yaw ``theta`` this
gives ``wrap(theta - psi)`` in ``(-pi, pi]`` when ``theta`` is the heading measured
in the slope plane, and ``wrap(atan2(cos(alpha) sin(d), cos(d)))`` with ``d = theta -
psi`` when ``theta`` is the yaw of the horizontal projection of body x (the contract's
body frame). :func:`imu_slope_heading` computes the first by default (the simulator
builds its IMU quaternions so that it returns the simulated gamma exactly) and the
second with ``heading="yaw"``.
"""

from __future__ import annotations

import numpy as np

from energy_planner.angles import wrap

#: Kept for existing imports; the project's one wrapping function is
#: :func:`energy_planner.angles.wrap` (``(-pi, pi]``).
wrap_angle = wrap


def up_in_body(qw, qx, qy, qz) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World up vector in the body frame, ``u = R^T (0, 0, 1)``.

    The quaternion (body to world, scalar ``qw``) is normalised first; a zero
    quaternion (no orientation) gives NaN.

    Returns
    -------
    ux, uy, uz : ndarray
        The third row of ``R``.

    Examples
    --------
    >>> [float(c) for c in up_in_body(1.0, 0.0, 0.0, 0.0)]
    [0.0, 0.0, 1.0]
    """
    qw, qx, qy, qz = (np.asarray(a, dtype=float) for a in (qw, qx, qy, qz))
    n = np.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
    with np.errstate(invalid="ignore", divide="ignore"):  # a zero quaternion gives NaN
        qw, qx, qy, qz = qw / n, qx / n, qy / n, qz / n
    ux = 2.0 * (qx * qz - qw * qy)
    uy = 2.0 * (qy * qz + qw * qx)
    uz = 1.0 - 2.0 * (qx * qx + qy * qy)
    return ux, uy, uz


def imu_slope_heading(qw, qx, qy, qz, heading: str = "plane") -> tuple[np.ndarray, np.ndarray]:
    """Slope ``alpha`` and signed relative heading ``gamma`` from an IMU quaternion.

    Parameters
    ----------
    qw, qx, qy, qz : array_like
        Orientation, body to world (ENU), as ``sensor_msgs/Imu`` (normalised here).
    heading : {"plane", "yaw"}
        ``"plane"`` (default, the project's IMU relation): ``gamma = -atan2(u_y, u_x)``,
        the angle *in the slope plane* between body x and the uphill direction.
        ``"yaw"``: ``gamma = atan2(-u_y, u_x * u_z)``, which equals ``wrap(theta - psi)``
        with ``theta`` the horizontal yaw of body x. The two agree on level ground and
        for the named headings (0, +-pi/2, pi); elsewhere they differ by
        ``atan2(cos(alpha) sin(d), cos(d)) - d``, e.g. 2.8 degrees at ``alpha = 25`` and
        ``d = theta - psi = 47.8`` degrees.

    Returns
    -------
    alpha : ndarray
        Slope angle, rad, ``arccos(u_z)`` in ``[0, pi]``.
    gamma : ndarray
        Relative heading, rad, wrapped to ``(-pi, pi]``: 0 facing uphill, pi facing
        downhill, +pi/2 with uphill on the robot's right. It is 0 on level ground
        (undefined there; every model term multiplies it by ``sin(alpha)``).

    Examples
    --------
    Pitched nose-up by 10 degrees (rotation about body y by -10 deg), facing uphill:

    >>> h = np.radians(-10.0) / 2
    >>> a, g = imu_slope_heading(np.cos(h), 0.0, np.sin(h), 0.0)
    >>> round(float(np.degrees(a)), 6), round(float(g), 6)
    (10.0, 0.0)
    """
    ux, uy, uz = up_in_body(qw, qx, qy, qz)
    alpha = np.arccos(np.clip(uz, -1.0, 1.0))
    if heading == "plane":
        gamma = wrap(-np.arctan2(uy, ux))
    elif heading == "yaw":
        gamma = wrap(np.arctan2(-uy, ux * uz))
    else:
        from energy_planner.errors import LogError

        raise LogError(f"heading={heading!r} is not valid; expected 'plane' or 'yaw'")
    return alpha, gamma
