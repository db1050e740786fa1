"""The OMPL objective is the energy kernel; its heuristic is admissible."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.model import EnergyModel
from energy_planner.planning.limits import make_motion_cost
from energy_planner.planning.objective import EnergyObjective, make_space, set_state
from energy_planner.planning.plan import plan
from energy_planner.terrain import Terrain


@pytest.fixture(scope="module")
def setup():
    from ompl import base as ob

    t = Terrain.from_function(
        lambda x, y: 8.0 * np.exp(-((x - 30) ** 2 + (y - 30) ** 2) / 200.0), size=(60, 60)
    )
    cost, _ = make_motion_cost(t, EnergyModel.default(), max_slope_deg=30)
    space = make_space(t)
    si = ob.SpaceInformation(space)
    si.setup()
    obj = EnergyObjective(si, cost)
    return t, cost, space, obj


coord = st.floats(2.0, 58.0)
yaw = st.floats(-math.pi, math.pi)


@settings(max_examples=60, deadline=None)
@given(x0=coord, y0=coord, t0=yaw, x1=coord, y1=coord, t1=yaw)
def test_motion_cost_is_the_kernel_and_heuristic_is_admissible(setup, x0, y0, t0, x1, y1, t1):
    _, cost, space, obj = setup
    a, b = space.allocState(), space.allocState()
    set_state(a, x0, y0, t0)
    set_state(b, x1, y1, t1)
    c = obj.motionCost(a, b).value()
    assert c == cost(x0, y0, a.getYaw(), x1, y1, b.getYaw()) or (
        math.isinf(c) and math.isinf(cost(x0, y0, t0, x1, y1, t1))
    )
    assert obj.motionCostHeuristic(a, b).value() <= c * (1 + 1e-12)
    assert obj.stateCost(a).value() == 0.0
    assert obj.isSymmetric() is False


def test_direction_matters(setup):
    _, cost, space, obj = setup
    a, b = space.allocState(), space.allocState()
    set_state(a, 30.0, 12.0, math.pi / 2)  # foot of the hill, facing north (uphill)
    set_state(b, 30.0, 22.0, math.pi / 2)
    up = obj.motionCost(a, b).value()
    down = obj.motionCost(b, a).value()  # same yaw: walking backward downhill
    assert up != down
    assert up == pytest.approx(cost(30.0, 12.0, math.pi / 2, 30.0, 22.0, math.pi / 2))


def test_progress_callback_reports_a_decreasing_best(setup):
    t = Terrain.from_function(lambda x, y: 0.0 * x, size=(30, 30))
    seen = []
    res = plan(t, EnergyModel.default(), (3.0, 4.0), (26.0, 21.0), time=2, progress=False,
               callback=lambda s, e: seen.append((s, e)))  # fmt: skip
    assert seen and seen == res.history
    best = [e for _, e in seen]
    assert all(b2 <= b1 for b1, b2 in zip(best, best[1:], strict=False))
    assert best[-1] == pytest.approx(res.energy_j, rel=1e-6)
