"""The full-resolution search: admissible heuristic, optimality against the built lattice
(scipy's Dijkstra on every edge priced up front: an independent search of the same graph),
the eps bound, the goal-less reach mode, and plan-vs-energy agreement on real maps."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _bounds import check_edge_bounds  # tests/ helper
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from energy_planner.energy import MotionCost, path_energy
from energy_planner.errors import InvalidStateError, PlanningError
from energy_planner.maps import map_path
from energy_planner.model import EnergyModel
from energy_planner.planning.lattice import lattice_plan
from energy_planner.planning.limits import make_motion_cost
from energy_planner.planning.search import (
    _Grid,
    bound_table,
    reach_search,
    relaxed_cost_to_go,
    search_plan,
)
from energy_planner.request import Request
from energy_planner.terrain import Terrain, load_dem


@pytest.fixture(scope="module")
def model():
    return EnergyModel.default()


def _bumpy(seed: int, size: int = 24, amp: float = 4.0) -> Terrain:
    """A random smooth terrain: a few Gaussian bumps and a tilt."""
    rng = np.random.default_rng(seed)
    c = rng.uniform(0, size, (4, 2))
    h = rng.uniform(-amp, amp, 4)
    w = rng.uniform(3, 8, 4)
    tilt = rng.uniform(-0.2, 0.2, 2)

    def z(x, y):
        out = tilt[0] * x + tilt[1] * y
        for k in range(4):
            out = out + h[k] * np.exp(-((x - c[k, 0]) ** 2 + (y - c[k, 1]) ** 2) / w[k] ** 2)
        return out

    return Terrain.from_function(z, size=(size, size))


def _crest(seed: int, size: int = 24) -> Terrain:
    """A random sharp crest 4 m high over a tilt: moves straddle it.

    Its flanks climb at 17-29 degrees (walkable under a 30-degree limit) or 37-45
    degrees (a band at most 8 m wide); it runs NW-SE through the centre, so the SW and
    NE corners (5.5 m or more from it) are walkable either way.
    """
    rng = np.random.default_rng(seed)
    ang = rng.uniform(0.1, 0.5 * np.pi - 0.1)
    flank = rng.uniform(0.3, 0.55) if rng.uniform() < 0.5 else rng.uniform(0.75, 1.0)
    tilt = rng.uniform(-0.05, 0.05, 2)

    def z(x, y):
        d = (x - size / 2) * np.cos(ang) + (y - size / 2) * np.sin(ang)
        return np.maximum(4.0 - flank * np.abs(d), 0.0) + tilt[0] * x + tilt[1] * y

    return Terrain.from_function(z, size=(size, size))


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    seed=st.integers(0, 10_000),
    p=st.integers(0, 10_000),
    cross=st.sampled_from([None, 25.0]),
    slope=st.sampled_from([None, 30.0]),
    moves=st.sampled_from(["all", "crab", "axes"]),
    crest=st.booleans(),
)
def test_edge_bound_never_exceeds_the_kernel(model, seed, p, cross, slope, moves, crest):
    """Every translation the search can make costs at least the heuristic's bound of it,
    at every heading allowed to make it (the kernel is the independent side): with
    ``moves="all"`` also every crab edge (body yaw off the direction of travel), on moves
    over a sharp crest (the bound prices each of the kernel's samples at its own
    gradient) and near a slope limit (nodes beyond it are inf)."""
    t = _crest(seed) if crest else _bumpy(seed)
    req = Request.make(max_cross_slope_deg=cross, max_slope_deg=slope)
    cost, _ = make_motion_cost(t, model, req)
    grid = _Grid(cost, t, (1.5, 2.5), None, 16, moves)
    rng = np.random.default_rng(p)
    # interior positions (the Horn gradient of the outer cells is undefined)
    ii = [2, grid.nx - 3, *rng.integers(2, grid.nx - 2, 2)]
    jj = [2, grid.ny - 3, *rng.integers(2, grid.ny - 2, 2)]
    checked, _ = check_edge_bounds(cost, grid, zip(ii, jj, strict=True))
    assert checked > 0


@settings(max_examples=4, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), p=st.integers(0, 10_000), slope=st.sampled_from([None, 30.0]))
def test_relaxed_cost_to_go_is_below_the_optimum_from_random_states(model, seed, p, slope):
    """Admissibility of the whole relaxed problem (turning free, each sample at its
    cheapest yaw): from random positions of a random crest, ``h`` is at most the
    optimal cost to the goal found by the search with ``eps = 1`` (whose optimality is
    checked against the built lattice below)."""
    t = _crest(seed, size=16)
    cost, _ = make_motion_cost(t, model, Request.make(max_slope_deg=slope))
    goal = (2.5, 2.5, None)  # off the crest
    grid = _Grid(cost, t, goal[:2], None, 16, "all")
    h = relaxed_cost_to_go(cost, grid, grid.position(goal[0], goal[1], "goal"))
    # random positions the relaxed problem reaches (the others have h = inf), not too
    # steep to stand on
    X, Y = np.meshgrid(grid.xs, grid.ys)
    ok = np.isfinite(h) & (h > 0) & (np.degrees(t.sample(X.ravel(), Y.ravel()).slope) < 28)
    cand = np.nonzero(ok)[0]
    tried = 0
    for q in np.random.default_rng(p).choice(cand, size=min(6, cand.size), replace=False):
        x, y = grid.xy(q)
        hp = float(h[grid.position(x, y, "start")])
        try:
            r = search_plan(cost, t, (float(x), float(y), None), goal, eps=1.0)
        except (PlanningError, InvalidStateError):
            continue  # unreachable or a limit at the position: nothing to bound
        assert hp <= r.cost * (1 + 1e-6), (x, y, hp, r.cost)
        assert hp >= 0.8 * r.cost or r.cost < 1.0  # and tight (the old box bound: 0.6)
        tried += 1
    assert tried > 0


@settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), moves=st.sampled_from(["all", "axes"]))
def test_search_finds_the_lattice_optimum_and_h_is_a_lower_bound(model, seed, moves):
    t = _bumpy(seed, size=20)
    cost, _ = make_motion_cost(t, model)
    s, g = (2.5, 3.5, None), (17.5, 16.5, None)
    # scipy Dijkstra over the built graph
    ref = lattice_plan(cost, t, s, g, step=1.0, moves=moves)
    opt = search_plan(cost, t, s, g, eps=1.0, moves=moves)
    assert opt.cost == pytest.approx(ref.cost, rel=1e-5)  # float32 g-values
    assert opt.info["h_start"] <= opt.cost * (1 + 1e-6)
    # the heuristic is below the optimal cost-to-go from every position (reach from the goal
    # is not the reverse problem, so compare with searches from a few other starts)
    grid = _Grid(cost, t, s[:2], None, 16, moves)
    h = relaxed_cost_to_go(cost, grid, grid.position(g[0], g[1], "goal"))
    for x, y in [(10.5, 3.5), (3.5, 12.5), (15.5, 9.5)]:
        r = search_plan(cost, t, (x, y, None), g, eps=1.0, moves=moves)
        assert h[grid.position(x, y, "start")] <= r.cost * (1 + 1e-6)
    # eps bounds the suboptimality
    w = search_plan(cost, t, s, g, eps=1.5, moves=moves)
    assert ref.cost * (1 - 1e-6) <= w.cost <= 1.5 * ref.cost


def test_reach_agrees_with_the_search(model):
    t = _bumpy(3, size=20)
    cost, _ = make_motion_cost(t, model)
    s = (2.5, 3.5, None)
    reach = reach_search(cost, t, s)
    for gx, gy in [(17.5, 16.5), (10.5, 3.5), (2.5, 15.5)]:
        j = int(np.argmin(np.abs(reach.ys - gy)))
        i = int(np.argmin(np.abs(reach.xs - gx)))
        opt = search_plan(cost, t, s, (gx, gy, None), eps=1.0)
        assert reach.energy[j, i] == pytest.approx(opt.cost, rel=1e-5)
    assert reach.energy[int(np.argmin(np.abs(reach.ys - 3.5))), 2] == 0.0
    capped = reach_search(cost, t, s, max_energy=2000.0)
    assert np.all(np.isinf(capped.energy[reach.energy > 2000.0]))
    fin = reach.energy <= 2000.0
    assert np.allclose(capped.energy[fin], reach.energy[fin])


def test_crab_moves_on_a_steep_plane(model):
    """With the bundled model, walking with the body yawed off the direction of travel is
    cheaper than facing it on a 27-degree plane (its fore-aft tilt term is much larger
    than the sideways one). The crab moves must then lower the search's optimum, bring it
    within 1 % of the default planner (search + continuous pose refinement), and ``reach``
    (the same move set, no goal) must agree with ``plan(planner="search")``."""
    from energy_planner.planning.plan import plan

    t = Terrain.from_function(lambda x, y: 0.5 * x + 0.15 * y, size=(24, 24))
    cost, _ = make_motion_cost(t, model)
    s, g = (2.5, 2.5, None), (20.5, 11.5, None)
    facing = search_plan(cost, t, s, g, eps=1.0, moves="axes")
    crab = search_plan(cost, t, s, g, eps=1.0)  # default moves: all 16 at every heading
    assert crab.cost <= facing.cost * (1 + 1e-6)
    assert crab.cost < 0.95 * facing.cost  # crabbing matters here (not a tie)
    yaw_off = []
    for a, b in zip(crab.states[:-1], crab.states[1:], strict=True):
        d = b[:2] - a[:2]
        if np.hypot(*d) > 0:
            yaw_off.append(abs(math.remainder(math.atan2(d[1], d[0]) - a[2], 2 * math.pi)))
    assert max(yaw_off) > math.radians(10)  # the optimum does crab
    auto = plan(t, model, s, g, progress=False)
    assert crab.cost <= auto.energy_j * 1.01
    searched = plan(t, model, s, g, planner="search", progress=False)
    reach = reach_search(cost, t, s)
    j = int(np.argmin(np.abs(reach.ys - g[1])))
    i = int(np.argmin(np.abs(reach.xs - g[0])))
    assert (reach.xs[i], reach.ys[j]) == (g[0], g[1])
    assert reach.energy[j, i] == pytest.approx(crab.cost, rel=1e-5)
    assert reach.energy[j, i] == pytest.approx(searched.energy_j, rel=0.01)


def _energy_of_written_path(tmp_path, terrain, model, res):
    """Write the plan with --out's format, read it back as `energy --waypoints` does and
    price it with a fresh MotionCost (nothing shared with the planner)."""
    from energy_planner.energy.waypoints import waypoints_to_work
    from energy_planner.geojson import read_path, write_path_from_work

    f = write_path_from_work(tmp_path / "p.geojson", terrain, res.states)  # RFC 7946 lon/lat
    wp = read_path(f)
    assert wp.yaw_frame == "crs_x_ccw" and wp.declared_crs == "OGC:CRS84"
    xy, yaw = waypoints_to_work(terrain, wp)
    fresh = MotionCost(terrain, model)
    return path_energy(terrain, model, xy, yaw=yaw, cost=fresh).energy_j


@pytest.mark.parametrize(
    "name, start, goal",
    [
        ("hill", (500058.0, 5000046.0), (500058.0, 5000109.0)),
        ("jacksboro_fault_dem", (-84.22, 36.52), (-84.19, 36.55)),
    ],
)
def test_plan_energy_equals_energy_of_its_waypoints(tmp_path, model, name, start, goal):
    from energy_planner.planning.plan import plan

    terrain = load_dem(map_path(name))
    s = terrain.to_work(*start)
    g = terrain.to_work(*goal)
    res = plan(terrain, model, s, g, planner="search", progress=False)
    e = _energy_of_written_path(tmp_path, terrain, model, res)
    assert e == pytest.approx(res.energy_j, rel=1e-3)


def test_bound_table_from_the_cache_is_the_computed_one(model, monkeypatch):
    """The bound's ``best`` bands read back from the cost's kept table, the process memo
    and the disk cache are the ones :meth:`HeadingCost.map_bands` computes, bit for bit."""
    import hashlib
    import uuid

    from energy_planner.model._codegen import cache_dir
    from energy_planner.planning import search

    t = _bumpy(7)
    cost, _ = make_motion_cost(t, model, Request.make())
    grid = _Grid(cost, t, (1.5, 2.5), None, 16, "all")
    # cold without touching the shared cache: this run's keys are salted, so no file of
    # an earlier run (or of another xdist worker's plans) is read, and none is deleted
    salt, keys, real = uuid.uuid4().hex, [], search._best_key

    def salted(*args, **kwargs) -> str:
        keys.append(hashlib.sha256((real(*args, **kwargs) + salt).encode()).hexdigest()[:24])
        return keys[-1]

    monkeypatch.setattr(search, "_best_key", salted)
    search._BEST_MEMO.clear()
    try:
        computed, tgeo = bound_table(cost, grid.headings, grid.move_ok)
        written = [cache_dir() / f"bound_{k}.npy" for k in set(keys)]
        assert written and all(f.exists() for f in written)
        kept, _ = bound_table(cost, grid.headings, grid.move_ok)  # the cost's own table
        search._TABLES.clear()
        memo, _ = bound_table(cost, grid.headings, grid.move_ok)
        search._TABLES.clear()
        search._BEST_MEMO.clear()
        disk, tgeo2 = bound_table(cost, grid.headings, grid.move_ok)
    finally:
        search._BEST_MEMO.clear()
        search._TABLES.clear()
        for k in set(keys):
            (cache_dir() / f"bound_{k}.npy").unlink(missing_ok=True)
    np.testing.assert_array_equal(kept, computed)
    np.testing.assert_array_equal(memo, computed)
    np.testing.assert_array_equal(disk, computed)
    np.testing.assert_array_equal(tgeo2, tgeo)


def _steep_crest(seed: int, size: int = 24) -> Terrain:
    """A crest whose flanks climb at 55-68 degrees over a tilt: gradients beyond the
    heading table's default 60 degrees (the bound of a speed range reads its own table
    there, :data:`~energy_planner.planning.search.RANGED_TOP_STEP_DEG`)."""
    rng = np.random.default_rng(seed)
    ang = rng.uniform(0.0, np.pi)
    flank = rng.uniform(1.45, 2.5)
    tilt = rng.uniform(-0.1, 0.1, 2)

    def z(x, y):
        d = (x - size / 2) * np.cos(ang) + (y - size / 2) * np.sin(ang)
        return np.maximum(6.0 - flank * np.abs(d), 0.0) + tilt[0] * x + tilt[1] * y

    return Terrain.from_function(z, size=(size, size))


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    seed=st.integers(0, 10_000),
    p=st.integers(0, 10_000),
    lam=st.sampled_from([0.0, 300.0]),
    steep=st.booleans(),
)
def test_bound_of_a_speed_range_never_exceeds_the_kernel(seed, p, lam, steep):
    """A motion that chooses its speed (and pays ``lam`` J per second) costs at least the
    heuristic's bound of it, at every heading allowed to make it: the bound is the least
    over speeds of heading tables that reach the terrain's steepest gradients (60-68
    degrees on the steep crest, where the fixed speed's bound takes the exact minimum).
    The kernel (``motion_best``: each motion's speed in closed form) is the independent
    side."""
    from test_speed_decisions import _detour_model

    from energy_planner.problem import Problem

    t = _steep_crest(seed) if steep else _bumpy(seed, amp=8.0)
    cost = Problem(t, _detour_model()).with_speed((0.2, 2.0), lam).cost.compile()
    grid = _Grid(cost, t, (1.5, 2.5), None, 16, "all")
    rng = np.random.default_rng(p)
    cells = zip(rng.integers(2, grid.nx - 3, 6), rng.integers(2, grid.ny - 3, 6), strict=True)
    checked, tight = check_edge_bounds(cost, grid, cells)
    assert checked > 0 and tight > 0  # a bound of 0 would pass the first alone
