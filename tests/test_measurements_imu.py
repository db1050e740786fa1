"""Slope and heading from the IMU quaternion against the analytic slope frame.

Two analytic frames: the contract's (body x = unit(cos th, sin th, tan a cos(th - psi)),
th the horizontal yaw) and the in-plane one (body x = cos g e_up + sin g e_side).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from energy_planner.errors import LogError
from energy_planner.measurements import imu_slope_heading, wrap_angle


def to_quat(R):
    qx, qy, qz, qw = Rotation.from_matrix(R).as_quat()
    return np.array([qw, qx, qy, qz])


def contract_frame(alpha, psi, theta):
    """Body to world rotation exactly as the design notes state it."""
    x = np.array([np.cos(theta), np.sin(theta), np.tan(alpha) * np.cos(theta - psi)])
    x /= np.linalg.norm(x)
    z = np.array([-np.sin(alpha) * np.cos(psi), -np.sin(alpha) * np.sin(psi), np.cos(alpha)])
    return np.column_stack([x, np.cross(z, x), z])


def plane_frame(alpha, psi, gamma):
    """Body x at the in-plane angle gamma from the uphill direction."""
    e_up = np.array([np.cos(alpha) * np.cos(psi), np.cos(alpha) * np.sin(psi), np.sin(alpha)])
    e_side = np.array([-np.sin(psi), np.cos(psi), 0.0])
    z = np.array([-np.sin(alpha) * np.cos(psi), -np.sin(alpha) * np.sin(psi), np.cos(alpha)])
    x = np.cos(gamma) * e_up + np.sin(gamma) * e_side
    return np.column_stack([x, np.cross(z, x), z])


angles = st.floats(-np.pi, np.pi, allow_nan=False)
slopes = st.floats(0.0, np.radians(40.0))
signs = st.sampled_from([1.0, -1.0])


def close_angle(a, b, tol):
    return abs(float(wrap_angle(a - b))) < tol


@settings(max_examples=200, deadline=None)
@given(alpha=slopes, psi=angles, theta=angles, sign=signs)
def test_contract_frame_yaw_heading_is_theta_minus_psi(alpha, psi, theta, sign):
    q = to_quat(contract_frame(alpha, psi, theta)) * sign  # q and -q: same rotation
    a, g = imu_slope_heading(*q, heading="yaw")
    assert abs(float(a) - alpha) < 1e-7
    if alpha > 1e-3:  # gamma is undefined on level ground
        assert close_angle(g, wrap_angle(theta - psi), 1e-6)
    # the in-plane heading of the same frame is the projected angle
    _, gp = imu_slope_heading(*q)
    if alpha > 1e-3:
        d = theta - psi
        assert close_angle(gp, np.arctan2(np.cos(alpha) * np.sin(d), np.cos(d)), 1e-6)


@settings(max_examples=200, deadline=None)
@given(alpha=slopes, psi=angles, gamma=angles, sign=signs)
def test_plane_frame_plane_heading_is_gamma(alpha, psi, gamma, sign):
    a, g = imu_slope_heading(*(to_quat(plane_frame(alpha, psi, gamma)) * sign))
    assert abs(float(a) - alpha) < 1e-7
    if alpha > 1e-3:
        assert close_angle(g, gamma, 1e-6)


@pytest.mark.parametrize("heading", ["plane", "yaw"])
def test_named_headings_agree(heading):
    a = np.radians(15.0)
    for rel in (0.0, np.pi / 2, -np.pi / 2, np.pi):
        alpha, gamma = imu_slope_heading(
            *to_quat(contract_frame(a, 0.3, 0.3 + rel)), heading=heading
        )
        assert np.isclose(alpha, a) and np.isclose(gamma, rel, atol=1e-12)
    # yawed +90 deg from uphill, uphill is on the right: body y points downhill (-x)
    R = contract_frame(a, 0.0, np.pi / 2)
    assert R[:, 1] @ np.array([1.0, 0.0, 0.0]) < 0
    assert np.isclose(imu_slope_heading(*to_quat(R), heading=heading)[1], np.pi / 2)


def test_known_difference_between_conventions():
    # 25 deg slope, in-plane heading 45 deg -> horizontal yaw offset 47.8 deg
    q = to_quat(plane_frame(np.radians(25.0), 0.7, np.radians(45.0)))
    _, gp = imu_slope_heading(*q)
    _, gy = imu_slope_heading(*q, heading="yaw")
    assert np.degrees(gp) == pytest.approx(45.0)
    assert np.degrees(gy) == pytest.approx(np.degrees(np.arctan2(1.0, np.cos(np.radians(25)))))
    assert np.degrees(gy) == pytest.approx(47.8, abs=0.05)
    with pytest.raises(LogError, match="'plane' or 'yaw'"):
        imu_slope_heading(*q, heading="roll")


def test_vectorized_and_unnormalized():
    qs = np.array([to_quat(plane_frame(np.radians(a), 1.0, 2.0)) for a in (5, 10, 20)])
    a, g = imu_slope_heading(*(3.0 * qs.T))
    np.testing.assert_allclose(np.degrees(a), [5, 10, 20], atol=1e-9)
    np.testing.assert_allclose(g, 2.0, atol=1e-9)


def test_wrap_angle_range():
    x = np.linspace(-10, 10, 1001)
    w = wrap_angle(x)
    assert (w > -np.pi).all() and (w <= np.pi).all()
    np.testing.assert_allclose(np.sin(w), np.sin(x), atol=1e-12)
    np.testing.assert_allclose(np.cos(w), np.cos(x), atol=1e-12)
