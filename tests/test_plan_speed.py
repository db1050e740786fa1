"""Planning with the speed as a decision, on a plane where every number is calculus.

The model's power is ``a v + b + c v^2`` whatever the slope and heading: a metre costs
``a + b / v + c v`` (least at ``v* = sqrt(b / c)``) and lasts ``1 / v``. With a price of a
second ``lambda`` a metre costs ``a + (b + lambda) / v + c v``: least at ``sqrt((b +
lambda) / c)``. On a straight path of ground length ``L`` at one speed, a deadline ``D``
asks for ``v = L / D`` when that is above ``v*`` (energy per metre is convex in ``v``).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

import energy_planner as ep
from energy_planner.cli import main
from energy_planner.errors import PlanningError
from energy_planner.model import EnergyModel
from energy_planner.problem import Problem
from energy_planner.terrain import Terrain

A, B, C = 120.0, 40.0, 100.0
V_STAR = math.sqrt(B / C)
RANGE = (0.2, 1.5)


def _model() -> EnergyModel:
    m = EnergyModel(["speed", "1", "speed ** 2"], {"speed": A, "1": B, "speed ** 2": C})
    m.metadata = {
        "fit": {
            "domain": {
                "speed_m_s": list(RANGE), "max_slope_deg": 30.0, "max_turn_rate_rad_s": 0.6,
                "gaits": {}, "channels": {},
            }
        }
    }  # fmt: skip
    return m


def _per_metre(v):
    return A + B / v + C * v


@pytest.fixture(scope="module")
def plane():
    """A 12 % grade along x, 30 m x 12 m: start and goal on the x axis of the lattice."""
    t = Terrain.from_function(lambda x, y: 0.12 * x, size=(30, 12), resolution=1.0)
    p = Problem(t, _model())
    x0, y0 = t.grid[0], t.grid[1]
    return p, (x0 + 2.0, y0 - 5.0, 0.0), (x0 + 26.0, y0 - 5.0)


def _walks(res):
    return [s for s in res.speed_profile() if s["speed_m_s"] > 0]


def test_each_motion_walks_at_sqrt_b_over_c(plane):
    p, s, g = plane
    res = ep.plan(p, s, g, speed=RANGE, progress=False)
    walks = _walks(res)
    assert walks and all(w["speed_m_s"] == pytest.approx(V_STAR, rel=0.01) for w in walks)
    assert res.energy_j == pytest.approx(res.distance_m * _per_metre(V_STAR), rel=1e-6)
    assert res.times[-1] == pytest.approx(res.duration_s, rel=1e-12)
    fixed = ep.plan(p, s, g, progress=False)  # the nominal 0.3 m/s
    assert fixed.times is None
    assert fixed.energy_j == pytest.approx(fixed.distance_m * _per_metre(0.3), rel=1e-6)


@pytest.mark.parametrize("lam", [0.0, 60.0])
def test_lattice_motions_take_their_best_speed_as_the_search_does(plane, lam):
    """The lattice prices every edge with the search's kernel at its own speed: each motion
    walks at ``sqrt((b + lambda) / c)``, the lattice's energy and time are the search's; a
    fixed speed walks it at 0.3 m/s as before (no times)."""
    p, s, g = plane
    v = math.sqrt((B + lam) / C)
    lat = ep.plan(p, s, g, speed=RANGE, time_weight=lam, planner="lattice", progress=False)
    walks = _walks(lat)
    assert walks and all(w["speed_m_s"] == pytest.approx(v, rel=1e-6) for w in walks)
    assert lat.energy_j == pytest.approx(lat.distance_m * _per_metre(v), rel=1e-6)
    srch = ep.plan(p, s, g, speed=RANGE, time_weight=lam, planner="search", eps=1.0,
                   progress=False)  # fmt: skip
    assert lat.energy_j == pytest.approx(srch.energy_j, rel=1e-9)
    assert lat.duration_s == pytest.approx(srch.duration_s, rel=1e-9)
    fixed = ep.plan(p, s, g, planner="lattice", progress=False)
    assert fixed.times is None
    assert fixed.energy_j == pytest.approx(fixed.distance_m * _per_metre(0.3), rel=1e-6)


def test_range_clamps_the_speed(plane):
    """The search's translations keep their heading: each walks at the range's floor.

    (A motion that turns while it walks may be slower: its turn takes |dyaw| / yaw_rate.)
    """
    p, s, g = plane
    res = ep.plan(p, s, g, speed=(0.8, 1.2), planner="search", progress=False)
    assert _walks(res)
    assert all(w["speed_m_s"] == pytest.approx(0.8, rel=1e-6) for w in _walks(res))


def test_deadline_walks_as_slowly_as_it_may(plane):
    p, s, g = plane
    free = ep.plan(p, s, g, speed=RANGE, progress=False)
    length = free.distance_m
    deadline = length / 1.0  # needs 1 m/s, above v* = 0.63
    res = ep.plan(p, s, g, speed=RANGE, deadline=deadline, progress=False)
    assert res.duration_s <= deadline
    v = length / res.duration_s
    assert 1.0 <= v <= 1.05
    assert res.energy_j == pytest.approx(length * _per_metre(1.0), rel=0.01)
    assert res.info["deadline"]["lambda_j_per_s"] > 0
    # a deadline the free plan meets changes nothing
    easy = ep.plan(p, s, g, speed=RANGE, deadline=free.duration_s * 1.5, progress=False)
    assert easy.energy_j == pytest.approx(free.energy_j, rel=1e-12)


def test_deadline_no_path_can_gives_the_fastest_time(plane):
    p, s, g = plane
    length = ep.plan(p, s, g, speed=RANGE, progress=False).distance_m
    with pytest.raises(PlanningError, match="fastest") as info:
        ep.plan(p, s, g, speed=RANGE, deadline=length / 2.0, progress=False)
    assert info.value.value == pytest.approx(length / RANGE[1], rel=1e-6)


def test_pareto_front_is_the_analytic_one(plane):
    from energy_planner.planning.plan import DEFAULT_EPS

    p, s, g = plane
    front = ep.pareto(p, s, g, 4, speed=RANGE, progress=False)
    rows = front.rows()
    assert len(rows) == 4 and "convex hull" in front.note
    for lam, r in zip(front.lambdas, rows, strict=True):
        v = min(max(math.sqrt((B + lam) / C), RANGE[0]), RANGE[1])
        assert r["speed_max_m_s"] == pytest.approx(v, rel=1e-6)
        assert r["energy_j"] == pytest.approx(r["distance_m"] * _per_metre(v), rel=1e-6)
    assert np.all(np.diff([r["duration_s"] for r in rows]) <= 1e-9)
    assert np.all(np.diff([r["energy_j"] for r in rows]) >= -1e-9)
    # the dearest second's point walks the route planned before it at its own speeds:
    # within eps of the front's lower bound (the least-energy search's bound of the
    # energy plus lambda times the line at the top speed)
    found = front.plans[0].info["search"]
    line = g[0] - s[0]
    last = front.plans[-1]
    assert "retimed" in last.info
    bound = found["h_start_j"] + front.lambdas[-1] * line / RANGE[1]
    cost = last.energy_j + front.lambdas[-1] * last.duration_s
    assert cost == pytest.approx(last.info["retimed"]["certified"] * bound, rel=1e-9)
    assert cost <= DEFAULT_EPS * bound


def test_cli_speed_auto_and_energy_of_the_written_path(tmp_path):
    """``plan --speed auto --out``: ``energy --waypoints`` of the file gives its energy."""
    model = tmp_path / "m.json"
    _model().save(model)
    out = tmp_path / "p.geojson"
    run = CliRunner().invoke(main, [
        "plan", "--dem", "plane", "--start", "500010,5000010", "--goal", "500060,5000040",
        "--model", str(model), "--speed", "auto", "--out", str(out), "--json",
    ])  # fmt: skip
    assert run.exit_code == 0, run.output
    planned = json.loads(run.stdout)
    assert planned["speed"]["speed_range"] == list(RANGE)
    assert all(
        s["speed_m_s"] == pytest.approx(V_STAR, rel=0.01)
        for s in planned["speed_profile"]
        if s["speed_m_s"] > 0
    )
    props = json.loads(out.read_text())["features"][0]["properties"]
    assert "t" in props and props["t"][-1] == pytest.approx(planned["duration_s"])
    run = CliRunner().invoke(
        main, ["energy", "--dem", "plane", "--waypoints", str(out), "--model", str(model),
               "--json"],
    )  # fmt: skip
    assert run.exit_code == 0, run.output
    assert json.loads(run.stdout)["energy_j"] == pytest.approx(planned["energy_j"], rel=1e-3)


def test_cli_bad_speed_names_the_value():
    run = CliRunner().invoke(main, ["plan", "--dem", "plane", "--start", "500010,5000010",
                                    "--goal", "500060,5000040", "--speed", "1.5:0.2"])  # fmt: skip
    assert run.exit_code == 2
    assert "1.5:0.2" in run.output and "--speed" in run.output


def test_refinement_keeps_shortcut_prices_and_finds_the_same_path(plane, monkeypatch):
    """A cost that chooses its speed keeps its shortcuts' prices across rounds (each is
    priced at several speeds): the refined path is the one the refinement finds pricing
    every shortcut again (the memo emptied before every pass), in fewer motions priced,
    and it ends at the closed form's least energy of the straight line."""
    from energy_planner.planning import refine

    p, s, g = plane
    cost = p.with_speed(RANGE).cost.compile()
    rng = np.random.default_rng(5)
    xs = np.linspace(s[0], g[0], 13)
    ys = s[1] + rng.uniform(-1.5, 1.5, 13) * np.r_[0, np.ones(11), 0]
    states = np.column_stack([xs, ys, np.zeros(13)])
    kw = dict(budget=0.0, seed=2, spacing=1.0, max_rounds=5, min_rounds=5)
    kept, info = refine.refine_path(cost, states, **kw)
    monkeypatch.setattr(refine, "MEMO_SIZE", -1)
    again, info2 = refine.refine_path(cost, states, **kw)
    assert np.array_equal(kept, again)
    assert info["evaluations"] <= info2["evaluations"]
    # a pass over poses whose shortcuts are all kept prices nothing, and gives what
    # pricing them again gives
    dense = refine.densify(states, 1.0)
    e0 = refine._edge_costs(cost, dense)
    memo: dict = {}
    first = refine._shortcut_pass(cost, dense, e0, 3, memo)
    second = refine._shortcut_pass(cost, dense, e0, 3, memo)
    fresh = refine._shortcut_pass(cost, dense, e0, 3)
    assert first[2] > 0 and second[2] == 0 and fresh[2] == first[2]
    for a, b in ((first, second), (first, fresh)):
        assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    e = float(refine._edge_costs(cost, kept).sum())
    assert e == pytest.approx((g[0] - s[0]) * math.hypot(1, 0.12) * _per_metre(V_STAR), rel=0.02)


def test_refinement_leaves_straight_runs_unpriced_and_merges_the_long_ones(plane):
    """A cost that chooses its speed: a shortcut over poses on one straight line at one yaw
    walks it at one speed where each motion took its own, so it is not priced (forward:
    nothing; crab: only turn-walk-turn); a run of at least ``MERGE_MIN_RUN`` motions at
    one speed becomes one motion, a shorter one is kept, and on the plane (every motion
    at ``v*``) the merged path costs the closed form's ``L (a + b / v* + c v*)``."""
    from energy_planner.planning import refine

    p, s, g = plane
    cost = p.with_speed(RANGE).cost.compile()
    for yaw, per_shortcut in ((0.0, 0), (0.4, 3)):
        line = refine.densify(np.array([[s[0], s[1], yaw], [s[0] + 20.0, s[1], yaw]]), 1.0)
        e = refine._edge_costs(cost, line)
        out, e2, priced = refine._shortcut_pass(cost, line, e, 3, {})
        assert priced == per_shortcut * (len(line) - 3)
        assert np.array_equal(out, line) and np.array_equal(e2, e)
    for n, merged in ((refine.MERGE_MIN_RUN - 6, False), (refine.MERGE_MIN_RUN + 4, True)):
        line = refine.densify(np.array([[s[0], s[1], 0.0], [s[0] + n, s[1], 0.0]]), 1.0)
        e = refine._edge_costs(cost, line)
        out, e2, priced = refine._merge_straight(cost, line, e)
        assert (len(out), priced) == ((2, 1) if merged else (len(line), 0))
        run = n * math.hypot(1.0, 0.12)  # ground length on the 12 % grade
        assert e2.sum() == pytest.approx(run * _per_metre(V_STAR), rel=1e-6)
