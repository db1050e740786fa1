"""The speed the planner chooses, priced by the simulator's own physics (reduced benchmark).

``benchmarks/bench_speed_physics.py`` on one start and goal over a small bump: a robot that
trots at every speed walks the short across-speeds campaign, the fitted model plans, and
every plan is charged by the TRUTH (``true_path_energy`` with the plan's own speed
profile), which no model term writes (the truth's stride frequency and duty factor are
powers of the speed the catalog does not have). The small campaign walks forward and to
the left only, so the plans are held to forward walking (``max_crab_deg=0``,
``max_backward_slope_deg=0``): elsewhere its model extrapolates.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import energy_planner as ep
from energy_planner.planning.speed import speed_range_of
from energy_planner.terrain import Terrain

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from bench_speed_physics import NOMINAL, plan_truth, robot, truth  # noqa: E402

#: Relative cost the chosen speeds may exceed the best constant speed by: the fitted
#: optimum speed is within a few % of the truth's, where the cost per metre is flat
#: (bench_speed_identification: at most 0.2 % above the truth's least cost per metre),
#: and the plan's speeds differ per segment, which a constant cannot.
CONST_TOL = 0.01


def _bump(x, y):
    return 6.0 * np.exp(-((x - 30.0) ** 2 + (y - 30.0) ** 2) / (2 * 9.0**2))


@pytest.fixture(scope="module")
def scene():
    camp, model = robot(seed=0, small=True)
    terrain = Terrain.from_function(_bump, size=(60.0, 60.0), resolution=2.0)
    kw = dict(step=2.0, max_crab_deg=0.0, max_backward_slope_deg=0.0)
    s, g = (8.0, 30.0), (52.0, 34.0)
    # the speed-choosing plan both tests read (it is deterministic: planned once)
    auto = ep.plan(terrain, s, g, model=model, speed="auto", **kw)
    return camp, model, terrain, kw, s, g, auto


def test_chosen_speed_beats_best_constant_and_nominal_by_physics(scene):
    camp, model, terrain, kw, s, g, auto = scene
    nom = ep.plan(terrain, s, g, model=model, **kw)
    assert nom.times is None and auto.times is not None
    e_nom = plan_truth(terrain, camp, nom).energy_j
    e_auto = plan_truth(terrain, camp, auto).energy_j
    lo, hi = speed_range_of(model)
    const = [truth(terrain, camp, auto.states, v).energy_j for v in np.linspace(lo, hi, 29)]
    assert e_auto <= min(const) * (1 + CONST_TOL)
    # the truth's optimum (~0.7 m/s and faster uphill) is far from 0.3 m/s: >= 5 % saved
    assert NOMINAL < 0.5 * min(p["speed_m_s"] for p in auto.speed_profile() if p["speed_m_s"])
    assert e_auto <= 0.95 * e_nom


def test_deadline_is_met_by_the_physics_duration(scene):
    camp, model, terrain, kw, s, g, auto = scene
    deadline = 0.8 * auto.duration_s
    res = ep.plan(terrain, s, g, model=model, deadline=deadline, **kw)
    walked = plan_truth(terrain, camp, res)
    assert walked.duration_s <= deadline
    assert walked.duration_s == pytest.approx(res.duration_s, rel=1e-6)
