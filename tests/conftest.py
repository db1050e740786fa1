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


def pytest_collection_modifyitems(config, items):
    """xdist groups: the readers of a module fixture share one; each group's tests get the id
    ``--dist loadgroup`` reads.

    ``--dist loadgroup`` hands single tests to whichever worker is free, so the readers of
    a module-scoped fixture alternate between workers and each worker builds it (a campaign
    fit twice: 39 and 38 s of ``test_speed_physics`` setup in one run). The tests that read
    a module fixture of their own file get one group per file (a test with a group of its
    own keeps it); xdist sends the groups first, largest first, so they do not hold up the
    end of the run.

    pytest-xdist 3.8 marks a group by setting ``item._nodeid`` to ``<id>@<group>``, which
    pytest 9 no longer reads (a node's id is ``item._id``): every group was ignored, and the
    readers of a shared fixture or of the examples' shared runs each computed them on their
    own worker. The same id is set here where xdist's did not take.
    """
    for item in items:
        info = getattr(item, "_fixtureinfo", None)
        if info is None or item.get_closest_marker("xdist_group") is not None:
            continue
        module = item.nodeid.split("::")[0]
        if any(
            defs[-1].scope == "module" and defs[-1].baseid == module
            for name in info.names_closure
            if (defs := info.name2fixturedefs.get(name))
        ):
            item.add_marker(pytest.mark.xdist_group(f"{module}-fixtures"))
    if not getattr(config.option, "loadgroup", False):
        return  # not an xdist worker of --dist loadgroup
    from _pytest.nodeid import NodeId

    for item in items:
        names = sorted({str(m.args[0] if m.args else m.kwargs.get("name", "default"))
                        for m in item.iter_markers("xdist_group")})  # fmt: skip
        suffix = "@" + "_".join(names)
        if names and not item.nodeid.endswith(suffix):
            item._id = NodeId.parse(item.nodeid + suffix)
