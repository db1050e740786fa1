"""compare_routes refines each distinct starting path once.

The energy-optimal candidates include the plan and the plan walked at its cheapest
constant body yaw; where that yaw is the plan's own, both are the same poses, and
refining them again (same seed, same objective) repeats the same search.
"""

from __future__ import annotations

import numpy as np

from energy_planner.model import EnergyModel
from energy_planner.planning import compare, refine
from energy_planner.problem import Problem
from energy_planner.terrain import Terrain


def test_the_same_path_offered_twice_is_refined_once(monkeypatch):
    t = Terrain.from_function(lambda x, y: 0.2 * x + 0.05 * y, size=(20, 20))
    problem = Problem(t, EnergyModel.default())
    calls = []
    real = refine.refine_path

    def counting(cost, states, **kw):
        calls.append(np.array(states, float))
        return real(cost, states, **kw)

    monkeypatch.setattr(refine, "refine_path", counting)
    cands = compare._Candidates("energy_optimal", problem, lambda r: r.energy_j, 0.2, 0)
    path = np.array([[2.5, 2.5, 0.0], [9.5, 6.5, 0.3], [16.5, 14.5, 0.6]])
    cands.offer(path, "plan", problem)
    first = cands.best
    assert first is not None and len(calls) == 1
    cands.offer(path.copy(), "plan again", problem)  # the same poses and objective
    assert len(calls) == 1 and cands.best is first and cands.origin.startswith("plan")
    cands.offer(path, "unrefined", None)  # another objective (none): offered
    cands.offer(path + [0.0, 1.0, 0.0], "moved", problem)  # other poses: refined
    assert len(calls) == 2
    assert not np.array_equal(calls[1], calls[0])
