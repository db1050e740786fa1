"""The OMPL objective is the energy kernel; its heuristics (distance, cost-to-go) are admissible."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.model import EnergyModel
from energy_planner.planning.limits import make_motion_cost
from energy_planner.planning.objective import CostToGo, EnergyObjective, make_space, set_state
from energy_planner.planning.plan import plan
from energy_planner.planning.search import reach_search
from energy_planner.request import Request
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
               callback=seen.append)  # fmt: skip
    seen = [
        (ev.elapsed, ev.value) for ev in seen if ev.value is not None and math.isfinite(ev.value)
    ]
    assert seen and [e for _, e in seen] == [e for _, e in res.history]
    best = [e for _, e in seen]
    assert all(b2 <= b1 for b1, b2 in zip(best, best[1:], strict=False))
    assert best[-1] == pytest.approx(res.energy_j, rel=1e-6)


GOAL = (30.0, 27.0)  # north-east of the small hill's top


@pytest.fixture(scope="module")
def small():
    """A Gaussian hill on 36 x 36 cells (1 m), slope limit 30 deg: small enough for a
    Dijkstra per drawn pose."""
    from ompl import base as ob

    t = Terrain.from_function(
        lambda x, y: 5.0 * np.exp(-((x - 18) ** 2 + (y - 18) ** 2) / 80.0), size=(36, 36)
    )
    cost, _ = make_motion_cost(t, EnergyModel.default(), max_slope_deg=30)
    space = make_space(t)
    si = ob.SpaceInformation(space)
    si.setup()
    return t, cost, space, si


@pytest.fixture(scope="module")
def with_ctg(small):
    t, cost, _, si = small
    ctg = CostToGo(cost, t, GOAL)
    return ctg, EnergyObjective(si, cost, ctg)


@settings(max_examples=10, deadline=None)
@given(x=st.floats(2.0, 33.0), y=st.floats(2.0, 33.0), th=yaw)
def test_cost_to_go_never_exceeds_the_optimum(small, with_ctg, x, y, th):
    """h(s) <= the search's least energy from s to the goal, and <= the direct motion.

    The reference is independent of the cost-to-go: a Dijkstra over (x, y, heading)
    from the drawn position (``reach_search``, grid aligned with it) to the position next
    to the goal, plus the kernel's last motion to the exact goal at the cheapest lattice
    yaw (no turn priced, so it is at most the search's optimum with exact ends).
    """
    t, cost, space, _ = small
    ctg, obj = with_ctg
    a, g = space.allocState(), space.allocState()
    set_state(a, x, y, th)
    set_state(g, *GOAL, th)
    h = obj.motionCostHeuristic(a, g).value()
    assert h >= ctg(x, y)
    direct = obj.motionCost(a, g).value()
    assert h <= direct * (1 + 1e-12)  # inf when the direct motion breaks the limit
    if not math.isfinite(cost(x, y, th, x, y, th)) and not math.isfinite(
        min(cost(x, y, th + k * math.pi / 8, x, y, th + k * math.pi / 8) for k in range(16))
    ):
        return  # the drawn pose breaks the slope limit at every yaw: no path starts here
    r = reach_search(cost, t, (x, y, None))
    i = int(round((GOAL[0] - r.xs[0]) / r.step))
    j = int(round((GOAL[1] - r.ys[0]) / r.step))
    qx, qy = float(r.xs[i]), float(r.ys[j])
    last = min(cost(qx, qy, k * math.pi / 8, *GOAL, k * math.pi / 8) for k in range(16))
    best = float(r.energy[j, i]) + last
    assert math.isfinite(best)
    assert ctg(x, y) <= best
    assert h <= best


def test_cost_to_go_says_more_than_the_distance_bound(small, with_ctg):
    """Zero at the goal; from the far corner well above min J/m times the distance."""
    _, _, space, _ = small
    ctg, obj = with_ctg
    a, g = space.allocState(), space.allocState()
    set_state(a, 5.0, 5.0, 0.0)
    set_state(g, *GOAL, 0.0)
    assert ctg(*GOAL) == 0.0
    assert obj.motionCostHeuristic(a, g).value() == ctg(5.0, 5.0)
    assert ctg(5.0, 5.0) > 1.2 * obj._lb * math.hypot(GOAL[0] - 5.0, GOAL[1] - 5.0)


def test_bitstar_with_cost_to_go_is_no_worse(monkeypatch):
    """Same seed, same iterations: BIT* with the cost-to-go ends at most at the energy
    it reaches with the distance bound alone."""
    import importlib

    pm = importlib.import_module("energy_planner.planning.plan")
    t = Terrain.from_function(
        lambda x, y: 6.0 * np.exp(-((x - 20) ** 2 + (y - 20) ** 2) / 60.0), size=(40, 40)
    )
    m = EnergyModel.default()
    out = {}
    for on in (False, True):
        monkeypatch.setattr(pm, "OMPL_COST_TO_GO", on)
        res = plan(t, m, (4.0, 4.0), (35.0, 36.0), Request.make(max_slope_deg=25),
                   planner="bitstar", iterations=1000, seed=3, progress=False)  # fmt: skip
        out[on] = res
    assert "cost_to_go" in out[True].info and "cost_to_go" not in out[False].info
    assert out[True].energy_j <= out[False].energy_j * (1 + 1e-9)
