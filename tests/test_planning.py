"""Planning: lattice reference, OMPL planners, auto pipeline, limits.

Numbers are checked against closed forms (zigzag at the critical grade), physical laws
(uphill minus downhill energy = twice the grade work; energies of segments add) and
geometry (straight on flat ground, keep-out polygons avoided), never against values the
planner itself produced.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from shapely.geometry import LineString, box

from energy_planner.energy import path_energy
from energy_planner.errors import InvalidStateError, PlanningError
from energy_planner.model import EnergyModel
from energy_planner.planning.lattice import lattice_plan, simplify_states
from energy_planner.planning.limits import make_motion_cost
from energy_planner.planning.plan import plan
from energy_planner.planning.refine import densify
from energy_planner.request import Request
from energy_planner.terrain import Terrain

QUAD = "pos(vx) * (sin(alpha) * cos(gamma)) ** 2"


@pytest.fixture(scope="module")
def model():
    return EnergyModel.default()


@pytest.fixture(scope="module")
def flat():
    return Terrain.from_function(lambda x, y: 0.0 * x, size=(40, 40))


@pytest.fixture(scope="module")
def ramp():
    # inclined plane, uphill towards +y, grade 0.5 (26.6 deg)
    return Terrain.from_function(lambda x, y: 0.5 * y, size=(60, 60))


@pytest.fixture(scope="module")
def strip():
    """The ramp's plane, 20 m wide about x = 30 (x 20-40, y 0-50): the lattice's graph is a
    quarter of the ramp's, and it holds the climbs at x = 30 between y = 5 and 45, straight
    or zigzagging (legs of up to 20 m across the slope: any mix of legs at the critical
    grade is optimal, so the closed form does not depend on the width)."""
    return Terrain.from_function(lambda x, y: 0.5 * y, size=(20, 50), origin=(20.0, 0.0))


def _quad_model(c0: float, k: float) -> EnergyModel:
    """Walking forward costs c0 + k sin(beta)^2 per metre (beta: path inclination);
    walking backward or sideways costs 10 c0 per metre, turning is free."""
    # explicit per-metre formulas (the catalog's *_const terms weight oblique walking by
    # squared direction cosines, which would make crab walking cheap here)
    return EnergyModel(
        ["pos(vx)", "pos(-vx)", "abs(vy)", QUAD],
        {"pos(vx)": c0, "pos(-vx)": 10 * c0, "abs(vy)": 10 * c0, QUAD: k},
    )


def test_flat_ground_path_is_straight(flat, model):
    res = plan(flat, model, (5.0, 20.0, 0.0), (35.0, 20.0, 0.0), planner="lattice", progress=False)
    assert np.allclose(res.states[:, 1], 20.0)
    assert np.allclose(res.states[:, 2], 0.0)
    straight = path_energy(flat, model, [(5.0, 20.0), (35.0, 20.0)], yaw=[0.0, 0.0])
    assert res.energy_j == pytest.approx(straight.energy_j, rel=1e-9)
    assert res.distance_m == pytest.approx(30.0)


def test_auto_on_flat_ground_stays_on_the_line(flat, model):
    res = plan(flat, model, (5.0, 8.0), (33.0, 30.0), planner="auto", time=20, progress=False)
    line = LineString([(5.0, 8.0), (33.0, 30.0)])
    dev = max(line.distance(LineString(res.states[:, :2]).interpolate(f, normalized=True))
              for f in np.linspace(0, 1, 50))  # fmt: skip
    assert dev < 1.0
    # and no dearer than walking the straight line facing forward
    straight = path_energy(flat, model, [(5.0, 8.0), (33.0, 30.0)])
    assert res.energy_j <= straight.energy_j * 1.001


def _zigzag_case():
    """The zigzag test's plane (grade 0.5 up +y) and quadratic model whose critical grade
    the lattice move (2, 1) climbs at: ``(s, c0, k, model, start, goal, E*)`` with
    ``E* = 2 H sqrt(c0 k)`` the least energy of any climb (docstring below)."""
    s = 0.5
    g = s / math.sqrt(5)
    u = g / math.sqrt(1 + g * g)
    c0 = 100.0
    k = c0 / u**2
    start, goal = (30.0, 5.0), (30.0, 45.0)
    closed_form = 2 * s * (goal[1] - start[1]) * math.sqrt(c0 * k)
    return s, c0, k, _quad_model(c0, k), start, goal, closed_form


def test_zigzag_at_the_critical_grade_matches_closed_form(strip):
    r"""On a plane, walking forward along a direction of inclination beta (the path's
    angle above the horizontal, :math:`\sin\beta = \sin\alpha\cos\gamma`) costs
    :math:`c(u) = c_0 + k u^2` per metre along the ground, with :math:`u = \sin\beta`,
    and gains :math:`u` metres of height per metre. Climbing a height H along directions
    of inclination u costs :math:`H (c_0 + k u^2) / u`, minimal at the critical grade
    :math:`u^* = \sqrt{c_0 / k}`: :math:`E^* = 2 H \sqrt{c_0 k}`, whatever the mix of
    zigzag legs, as long as every leg climbs at :math:`u^*` (turning is free here). No
    path can do better, and the straight climb (:math:`u = \sin\alpha > u^*`) does worse.

    The lattice move (2, 1) on this plane (grade s = 0.5 uphill +y) has horizontal grade
    :math:`s \cos\varphi` with :math:`\cos\varphi = 1/\sqrt5`, so
    :math:`u = (s/\sqrt5) / \sqrt{1 + s^2/5}`; k is chosen so that this is the critical
    grade, so the lattice can realise the optimum exactly.
    """
    s, c0, k, m, start, goal, closed_form = _zigzag_case()
    height = s * (goal[1] - start[1])
    lat = plan(strip, m, start, goal, planner="lattice", step=1.0, progress=False)
    assert lat.energy_j == pytest.approx(closed_form, rel=1e-6)
    # its progress report prices the lattice's own poses motion by motion: the optimum too
    assert lat.history[-1][1] == pytest.approx(closed_form, rel=1e-6)
    # it zigzags: legs cross the slope, none goes straight up
    d = np.diff(lat.states[:, :2], axis=0)
    moving = np.hypot(d[:, 0], d[:, 1]) > 1e-9
    assert np.all(np.abs(d[moving, 0]) > 0)
    # the direct climb is dearer, and the refined path cannot beat the closed form
    sin_a = s / math.sqrt(1 + s * s)
    direct = height * (c0 + k * sin_a**2) / sin_a
    line = path_energy(strip, m, [start, goal], yaw=[math.pi / 2] * 2)
    assert line.energy_j == pytest.approx(direct, rel=1e-6)
    auto = plan(strip, m, start, goal, planner="auto", time=3, step=1.0, progress=False)
    assert closed_form * (1 - 1e-6) <= auto.energy_j <= lat.energy_j * (1 + 1e-9)


def test_uphill_and_downhill_cost_differently(strip):
    """Both ways the best path is the straight line for a model linear in the grade
    (``c0 + fwd_grade * sin(beta)`` per metre walking forward, the power staying positive
    downhill; other gaits dear), so E_up - E_down is twice the grade work:
    ``2 * fwd_grade * H``."""
    grade = "vx * sin(alpha) * cos(gamma)"
    fwd_grade = 1000.0
    model = EnergyModel(
        ["pos(vx)", "pos(-vx)", "abs(vy)", grade],
        {"pos(vx)": 600.0, "pos(-vx)": 6000.0, "abs(vy)": 6000.0, grade: fwd_grade},
    )
    a, b = (30.0, 10.0), (30.0, 40.0)
    up = plan(strip, model, a, b, planner="lattice", step=1.0, progress=False)
    down = plan(strip, model, b, a, planner="lattice", step=1.0, progress=False)
    assert up.energy_j > down.energy_j
    height = 0.5 * 30.0
    assert up.energy_j - down.energy_j == pytest.approx(2 * fwd_grade * height, rel=1e-6)


def test_invalid_start_and_goal_name_the_limit(ramp, model):
    with pytest.raises(InvalidStateError, match="start .* outside the map"):
        plan(ramp, model, (-5.0, 10.0), (30.0, 30.0), planner="lattice", progress=False)
    with pytest.raises(InvalidStateError, match="goal .* outside the map"):
        plan(ramp, model, (30.0, 10.0), (30.0, 70.0), planner="lattice", progress=False)
    with pytest.raises(InvalidStateError, match=r"start .*slope 26\.6 deg > limit 20 deg"):
        plan(ramp, model, (30.0, 10.0, 0.0), (30.0, 30.0, 0.0), Request.make(max_slope_deg=20),
             planner="lattice", progress=False)  # fmt: skip
    with pytest.raises(InvalidStateError, match=r"cross-slope 26\.6 deg > limit 15 deg"):
        plan(ramp, model, (30.0, 10.0, 0.0), (30.0, 30.0, 0.0),
             Request.make(max_cross_slope_deg=15), planner="lattice", progress=False)  # fmt: skip
    with pytest.raises(InvalidStateError, match="keep-out"):
        plan(ramp, model, (30.0, 10.0), (30.0, 30.0), Request.make(keep_out=[box(25, 25, 35, 35)]),
             planner="lattice", progress=False)  # fmt: skip
    with pytest.raises(PlanningError, match="valid planners: auto, search, lattice"):
        plan(ramp, model, (30.0, 10.0), (30.0, 30.0), planner="prmstar", progress=False)


def test_keep_out_is_respected(flat, model):
    wall = box(18.0, 8.0, 22.0, 32.0)
    res = plan(flat, model, (5.0, 20.0), (35.0, 20.0), Request.make(keep_out=[wall]),
               planner="auto", time=3, progress=False)  # fmt: skip
    assert not LineString(res.states[:, :2]).intersects(wall)
    straight = path_energy(flat, model, [(5.0, 20.0), (35.0, 20.0)])
    assert res.energy_j > straight.energy_j
    # it goes round the wall's end (y > 32 or y < 8)
    assert res.states[:, 1].max() > 32.0 or res.states[:, 1].min() < 8.0


def test_default_refinement_is_a_floor_of_rounds_not_of_seconds(ramp):
    """Without a time budget the refinement runs at least REFINE_MIN_ROUNDS rounds (on a
    small map the search's quarter is milliseconds), and its path still respects the
    closed form of the zigzag test (no path climbs H for less than 2 H sqrt(c0 k)) while
    never costing more than the search's own path."""
    from energy_planner.planning.plan import REFINE_MIN_ROUNDS

    _, _, _, m, start, goal, closed_form = _zigzag_case()
    search = plan(ramp, m, start, goal, planner="search", step=1.0, progress=False)
    auto = plan(ramp, m, start, goal, planner="auto", step=1.0, progress=False)
    rounds = auto.info["refine"]["rounds"]
    assert rounds >= REFINE_MIN_ROUNDS or auto.info["refine"]["converged"]
    assert closed_form * (1 - 1e-6) <= auto.energy_j <= search.energy_j * (1 + 1e-9)


def test_same_seed_same_path(flat, model):
    # the refinement stops at convergence or after 25 rounds, long before 30 s
    kw = dict(planner="auto", time=30, iterations=25, progress=False,
              request=Request.make(keep_out=[box(18.0, 12.0, 22.0, 28.0)]))  # fmt: skip
    a = plan(flat, model, (5.0, 20.0), (35.0, 21.0), seed=3, **kw)
    b = plan(flat, model, (5.0, 20.0), (35.0, 21.0), seed=3, **kw)
    assert a.info["refine"]["converged"] or a.info["refine"]["rounds"] == 25
    assert a.history[-1][1] < a.history[0][1]  # the refinement did something
    assert np.array_equal(a.states, b.states)
    c = plan(flat, model, (5.0, 20.0), (35.0, 21.0), seed=4, **kw)
    assert not np.array_equal(a.states, c.states)  # the seed matters
    r1 = plan(flat, model, (5.0, 20.0), (35.0, 21.0), planner="rrtstar", seed=7,
              iterations=150, progress=False)  # fmt: skip
    r2 = plan(flat, model, (5.0, 20.0), (35.0, 21.0), planner="rrtstar", seed=7,
              iterations=150, progress=False)  # fmt: skip
    assert np.array_equal(r1.states, r2.states)


def test_planned_energy_is_the_sum_of_its_segments(ramp, model):
    res = plan(ramp, model, (10.0, 10.0), (50.0, 45.0), planner="auto", time=2, progress=False)
    pe = path_energy(ramp, model, res.states[:, :2], yaw=res.states[:, 2])
    assert res.energy_j == pytest.approx(pe.energy_j, rel=1e-12)
    assert pe.segments["energy_j"].sum() == pytest.approx(res.energy_j, rel=1e-9)
    # splitting every motion in two changes nothing on a plane
    dense = densify(res.states, 0.7)
    pd_ = path_energy(ramp, model, dense[:, :2], yaw=dense[:, 2])
    assert pd_.energy_j == pytest.approx(res.energy_j, rel=1e-6)


@settings(max_examples=15, deadline=None)
@given(x0=st.floats(3, 37), y0=st.floats(3, 37), x1=st.floats(3, 37), y1=st.floats(3, 37))
@example(x0=3.0, y0=3.0, x1=3.0, y1=3.0000000000000004)  # found by CI: start ~= goal
def test_lattice_never_beats_the_admissible_bound(flat, model, x0, y0, x1, y1):
    """On flat ground no path costs less than min_cost_per_metre * distance, and the
    lattice path is at most ~8% dearer than the straight line (16 directions)."""
    cost, _ = make_motion_cost(flat, model)
    res = lattice_plan(cost, flat, (x0, y0, None), (x1, y1, None), step=2.0)
    e = sum(cost(*a, *b) for a, b in zip(res.states[:-1], res.states[1:], strict=True))
    d = math.hypot(x1 - x0, y1 - y0)
    # 1e-9 J absolute: a goal within float rounding of the start (d ~ 4e-16 m) is a stay
    assert e >= cost.min_cost_per_metre * d * (1 - 1e-9) - 1e-9
    h = math.atan2(y1 - y0, x1 - x0)
    line = cost(x0, y0, h, x1, y1, h)
    assert e <= line * 1.09 + 3 * cost.min_cost_per_metre * 2.0


def test_simplify_keeps_energy(ramp, model):
    cost, _ = make_motion_cost(ramp, model)
    s = np.array([[5, 5, 0.3], [6, 5, 0.3], [7, 5, 0.3], [9, 5, 0.3], [9, 5, 1.0]], float)
    t = simplify_states(s)
    assert len(t) == 3
    e = [sum(cost(*a, *b) for a, b in zip(p[:-1], p[1:], strict=True)) for p in (s, t)]
    assert e[0] == pytest.approx(e[1], rel=1e-9)


def test_richer_lattices_are_never_worse(ramp, model):
    """A superset of motion primitives cannot give a dearer optimum on the same graph
    positions: all 16 moves at every heading <= the 4 body-axis moves."""
    cost, _ = make_motion_cost(ramp, model)
    s, g = (8.0, 8.0, None), (50.0, 40.0, None)
    axes = lattice_plan(cost, ramp, s, g, step=2.0, moves="axes")
    full = lattice_plan(cost, ramp, s, g, step=2.0, moves="all")
    assert full.n_edges > axes.n_edges
    assert full.cost <= axes.cost * (1 + 1e-12)
    eight = lattice_plan(cost, ramp, s, g, step=2.0, n_headings=8)
    assert math.isfinite(eight.cost) and eight.n_nodes == axes.n_nodes // 2
    # with the distance metric: no shorter than the straight line, and (16 directions,
    # offset (42, 32) between two of them) at most a few percent longer
    dist = lattice_plan(cost, ramp, s, g, step=2.0, metric="distance")
    d = math.hypot(42.0, 32.0)
    assert d <= dist.cost <= d * 1.03


@pytest.mark.parametrize("goal", [(50.0, 10.0, None), (50.0, 44.0, 0.0), (12.0, 50.0, None)])
def test_distance_lattice_prices_only_what_the_shortest_path_can_use(model, goal):
    """The shortest feasible path priced inside a growing ellipse is the one Dijkstra
    finds on the whole distance lattice (same length, same poses), for fewer edges."""
    from scipy.sparse.csgraph import dijkstra

    from energy_planner.planning.lattice import _endpoint_nodes, lattice_graph

    # a ridge along x = 30 too steep for the limit, open only near y = 52
    wall = Terrain.from_function(
        lambda x, y: 6.0 * np.exp(-((x - 30.0) ** 2) / 8.0) * (np.abs(y - 52.0) > 5.0),
        size=(60, 60),
    )  # fmt: skip
    cost, _ = make_motion_cost(wall, model, max_slope_deg=25.0)
    s = (8.0, 10.0, None)
    got = lattice_plan(cost, wall, s, goal, step=2.0, metric="distance")
    full = lattice_graph(cost, wall, s[:2], 2.0, 16, "axes", "distance")
    src = _endpoint_nodes(full, *s, "start")
    dst = _endpoint_nodes(full, *goal, "goal")
    dist = dijkstra(full.graph, directed=True, indices=src, min_only=True)
    assert got.cost == pytest.approx(float(dist[dst].min()), rel=1e-12)
    assert got.n_edges < full.graph.nnz
    # the ridge forces the detour through the gap where the goal lies beyond it
    if goal[0] > 30:
        assert got.cost > math.hypot(goal[0] - s[0], goal[1] - s[1]) * 1.1


def test_distance_lattice_without_a_path_says_so(model):
    """A ridge closed from edge to edge: no shortest path, after pricing the whole map."""
    closed = Terrain.from_function(
        lambda x, y: 6.0 * np.exp(-((x - 30.0) ** 2) / 8.0) + 0.0 * y, size=(60, 60)
    )
    cost, _ = make_motion_cost(closed, model, max_slope_deg=25.0)
    with pytest.raises(PlanningError, match="no feasible path"):
        lattice_plan(cost, closed, (8.0, 10.0, None), (50.0, 10.0, None), step=2.0,
                     metric="distance")  # fmt: skip


def test_a_second_lattice_plan_from_the_same_start_searches_the_kept_graph(model):
    """The energy lattice's graph is kept for the next plan of the same model, request and
    start (another goal): the same path and cost as a graph built afresh."""
    from energy_planner.planning import lattice
    from energy_planner.problem import Problem

    t = Terrain.from_function(lambda x, y: 0.05 * x + 0.02 * y * y, size=(9, 9))
    p = Problem(t, model)
    s = (2.5, 2.5, None)
    lattice_plan(p, s, (6.5, 5.5, None), step=1.0)
    kept = lattice._GRAPHS[t][3]
    again = lattice_plan(p, s, (5.5, 3.5, 0.0), step=1.0)
    assert lattice._GRAPHS[t][3] is kept
    lattice._GRAPHS.clear()
    fresh = lattice_plan(p, s, (5.5, 3.5, 0.0), step=1.0)
    assert lattice._GRAPHS[t][3] is not kept
    assert again.cost == fresh.cost and again.n_edges == fresh.n_edges
    np.testing.assert_array_equal(again.states, fresh.states)
    lattice_plan(p, (3.5, 2.5, None), (5.5, 3.5, None), step=1.0)  # another start
    assert lattice._GRAPHS[t][2][0] == (3.5, 2.5)
