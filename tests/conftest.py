"""Fixtures shared by several test files."""

from __future__ import annotations

import os

import numpy as np
import pytest

# precompiled kernel modules take ~10 s to build per model: only the tests that check
# them build one (tests/test_energy_imports.py); the others price with numba's kernels
os.environ.setdefault("ENERGY_PLANNER_PRECOMPILE", "0")

#: The follower's tests: one mission walked forward at a constant speed (the plan's
#: timing is the log's), on the synthetic hill of seed FOLLOW_SEED.
FOLLOW_SEED = 1


@pytest.fixture(scope="session")
def follow_config():
    """The follower tests' mission configuration (150 s, forward only, 0.3 m/s)."""
    from energy_planner.follow.calibrate import forward_mission

    return forward_mission(150.0, 20.0)


@pytest.fixture(scope="session")
def follow_mission(follow_config):
    """``make(events=())``: the logs of that mission with the given events (cached)."""
    from energy_planner.simulate import simulate_missions

    cache: dict = {}

    def make(events=()):
        key = tuple(events)
        if key not in cache:
            cfg = follow_config.replace(events=key)
            cache[key] = simulate_missions(seed=FOLLOW_SEED, config=cfg).logs
        return cache[key]

    return make


@pytest.fixture(scope="session")
def make_follower():
    """``make(logs, **options)``: a Follower of the bundled model on the walked path.

    The plan is the walked path every 0.5 s (every 10th sample at 20 Hz) with its times.
    """
    import energy_planner as ep
    from energy_planner.follow import Follower
    from energy_planner.simulate import synthetic_dem

    def make(logs, **kw):
        k = np.arange(0, len(logs), 10)
        k[-1] = len(logs) - 1
        return Follower(
            synthetic_dem(FOLLOW_SEED),
            ep.load_model(),
            logs[["x", "y"]].to_numpy()[k],
            logs["yaw"].to_numpy()[k],
            logs["t"].to_numpy()[k],
            **kw,
        )

    return make
