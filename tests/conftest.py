"""Fixtures shared by several test files."""

from __future__ import annotations

import os

import pytest

# one BLAS thread per process, set before anything imports numpy (which loads OpenBLAS):
# the suite runs one xdist worker per core, and OpenBLAS's own threads then spin against
# the other worker's; a 483 x 33 SVD (the identifiability check of every fold's fit) took
# 100 ms of CPU instead of 1.3 ms on a busy 2-core machine (tests/test_speed_physics.py:
# 40.9 -> 14.0 s CPU). CLI subprocesses inherit it.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

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
    import numpy as np

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


@pytest.fixture(scope="session")
def load_discovery():
    """``(campaign, discovery, simulate_events, discover_events)``: the small campaign with
    a hidden load (seed 0) and ``ep.discover(max_steps=1, fit_final=False)`` on its logs, with
    the progress events each reported (computed once per worker; its readers share the
    xdist group ``load_discovery``, so one worker computes it)."""
    import energy_planner as ep
    from energy_planner.simulate import CampaignConfig, simulate_campaign

    sim_events: list = []
    c = simulate_campaign(0, ["load"], CampaignConfig.small(), progress=sim_events.append)
    events: list = []
    d = ep.discover(c.logs, max_steps=1, fit_final=False, progress=events.append)
    return c, d, sim_events, events
