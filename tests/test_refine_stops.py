"""The refinement stops when its rounds stop improving the path, on a path of any length.

On a flat plane with a power ``a v + b + c v^2`` walked at a fixed speed ``v``, a metre
costs ``a + b / v + c v`` whatever the heading and body yaw: the straight line is the
least-energy path, ``L (a + b / v + c v)``. A short path (a few poses) gets few trials a
round, so its step size hardly shrinks; it must still stop once its rounds gain nothing.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from energy_planner.model import EnergyModel
from energy_planner.planning import refine
from energy_planner.problem import Problem
from energy_planner.terrain import Terrain

A, B, C = 120.0, 40.0, 100.0
V = 0.3  # the planner's nominal speed
#: rounds the tests allow: a generous budget would run thousands
FEW = refine.CALM_WINDOW + 4


@pytest.fixture(scope="module")
def flat():
    m = EnergyModel(["speed", "1", "speed ** 2"], {"speed": A, "1": B, "speed ** 2": C})
    t = Terrain.from_function(lambda x, y: 0.0 * x, size=(30, 12), resolution=1.0)
    x0, y0 = t.grid[0], t.grid[1]
    return Problem(t, m).cost.compile(), x0 + 2.0, y0 - 5.0


def _energy(cost, states) -> float:
    return float(refine._edge_costs(cost, states).sum())


@pytest.mark.parametrize(
    "middle",
    [None, (4.0, 0.0), (4.0, 2.0)],
    ids=["two-poses", "straight-three-poses", "bent-three-poses"],
)
def test_a_short_path_on_a_plane_stops_in_few_rounds_at_the_straight_line(flat, middle):
    cost, x, y = flat
    poses = [(x, y, 0.0)] + ([(x + middle[0], y + middle[1], 0.0)] if middle else [])
    states = np.array(poses + [(x + 8.0, y, 0.0)])
    line = 8.0 * (A + B / V + C * V)
    out, info = refine.refine_path(cost, states, budget=60.0, seed=0, spacing=1.0)
    assert info["converged"] and info["rounds"] <= FEW
    assert _energy(cost, out) == pytest.approx(line, rel=1e-9)
    # the budget spent instead (convergence never declared: a negative tol), 200 rounds:
    # nothing cheaper found
    spent, info2 = refine.refine_path(
        cost, states, budget=math.inf, seed=0, spacing=1.0, max_rounds=200, tol=-1.0
    )
    assert info2["rounds"] == 200 and not info2["converged"]
    assert _energy(cost, out) <= _energy(cost, spent) * (1 + 1e-9)


def test_a_straight_line_stops_after_one_window_of_rounds_that_gain_nothing(flat):
    """No move is ever accepted: the step shrinks by 0.8 a round and would need 15 rounds
    to fall below a fiftieth of the spacing; the rounds' gain says it after the window."""
    cost, x, y = flat
    states = np.array([(x, y, 0.0), (x + 8.0, y, 0.0)])
    seen = []
    out, info = refine.refine_path(
        cost, states, budget=60.0, seed=3, spacing=1.0, report=seen.append
    )
    assert info == {**info, "rounds": refine.CALM_WINDOW, "converged": True}
    assert len(set(seen)) == 1  # no round changed the energy
    # the floor of work still holds: no time at all, and still the rounds asked for
    _, floor = refine.refine_path(cost, states, budget=0.0, seed=3, spacing=1.0, min_rounds=3)
    assert floor["rounds"] == 3 and not floor["converged"]
