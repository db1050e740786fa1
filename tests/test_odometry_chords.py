"""The odometry's scale is measured chord by chord, not by a whole run's net displacement.

Dead-reckoning a long curved run through an IMU whose heading drifts turns the far end of
the integrated path: the ratio of net displacements then measures the drift and the
path's shape, not the odometry's scale. Analytic logs: a 20-minute run around a figure of
eight whose odometry reads ``scale`` of every metre, with the IMU heading drifting.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.measurements.datacheck import ODOMETRY_CHORD_S, odometry_ratios


def _figure_eight(scale: float, drift_rad: float, duration_s: float = 1200.0) -> pd.DataFrame:
    """One run at 0.35 m/s on a lemniscate-like path; the IMU's heading drifts linearly."""
    t = np.arange(0.0, duration_s, 0.1)
    v = 0.35
    yaw = 1.2 * np.sin(2 * np.pi * t / 300.0)  # the heading swings: the path curves both ways
    x = np.cumsum(v * np.cos(yaw)) * 0.1
    y = np.cumsum(v * np.sin(yaw)) * 0.1
    x, y = np.r_[0.0, x[:-1]], np.r_[0.0, y[:-1]]  # the pose the twist of each step leads to
    imu_yaw = yaw + drift_rad * t / duration_s
    return pd.DataFrame(
        {"run": "a", "t": t, "qw": np.cos(imu_yaw / 2), "qx": 0.0, "qy": 0.0,
         "qz": np.sin(imu_yaw / 2), "vx": v * scale, "vy": 0.0, "wz": 0.0,
         "voltage": 50.0, "current": 4.0, "x": x, "y": y}
    )  # fmt: skip


def _net_ratio(s: pd.DataFrame) -> float:
    """The whole run's net displacement of the integrated twist over the pose's."""
    yaw = 2 * np.arctan2(s["qz"], s["qw"])
    dt = np.r_[0.0, np.diff(s["t"])]
    ox = np.sum(s["vx"] * np.cos(yaw) * dt)
    oy = np.sum(s["vx"] * np.sin(yaw) * dt)
    dx, dy = s["x"].iloc[-1] - s["x"].iloc[0], s["y"].iloc[-1] - s["y"].iloc[0]
    return float(np.hypot(ox, oy) / np.hypot(dx, dy))


@settings(max_examples=15, deadline=None)
@given(scale=st.floats(0.9, 1.1), drift=st.floats(-0.3, 0.3))
def test_the_chord_ratio_is_the_scale_whatever_the_heading_drift(scale, drift):
    s = _figure_eight(scale, drift)
    m = odometry_ratios(s)
    # a chord of 10 s turns the drift by at most 0.3 * 10 / 1200 rad: cos of it is 1
    np.testing.assert_allclose(m.ratio, scale, rtol=2e-3)


def test_the_net_ratio_would_not_be():
    """The reason for chords: with a heading drift of 0.2 rad over 20 minutes, the net
    displacement ratio of the same run is off by more than 1 %."""
    s = _figure_eight(0.94, 0.2)
    assert abs(_net_ratio(s) / 0.94 - 1.0) > 0.01
    assert abs(float(odometry_ratios(s).ratio[0]) / 0.94 - 1.0) < 2e-3
    assert ODOMETRY_CHORD_S * 10 < s["t"].iloc[-1]  # many chords per run
