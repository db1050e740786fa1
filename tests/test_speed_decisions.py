"""The speed as a decision in compare-routes, reach, mission and follow: a range, a deadline.

On a plane with a model whose power is ``a v + b + c v^2`` at any slope and heading (the
model of ``tests/test_plan_speed.py``), every number is calculus: a metre costs ``a + b / v
+ c v``, least at ``v* = sqrt(b / c)``; a route of ground length ``L`` due within ``D``
seconds, with ``L / D`` above ``v*``, walks at ``L / D`` (the cost per metre is convex in
``v``). On a window of the bundled hill, a model whose cost per metre is convex in the
grade (the detour model of ``tests/test_compare_routes.py``) plus standing power and swing
losses makes the least-energy route a detour at its best speed; a deadline that asks for
speed makes the straight climb the least-energy route in time (the detour cannot arrive).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

import energy_planner as ep
from energy_planner.cli import main
from energy_planner.errors import PlanningConfigError, PlanningError
from energy_planner.mission import Sites
from energy_planner.model import EnergyModel
from energy_planner.planning.speed import route_front, timed, timed_deadline
from energy_planner.problem import Problem
from energy_planner.terrain import Terrain

A, B, C = 120.0, 40.0, 100.0  # power a v + b + c v^2
V_STAR = math.sqrt(B / C)
RANGE = (0.2, 1.5)


def _model() -> EnergyModel:
    m = EnergyModel(["speed", "1", "speed ** 2"], {"speed": A, "1": B, "speed ** 2": C})
    dom = {"speed_m_s": list(RANGE), "max_slope_deg": 30.0, "max_turn_rate_rad_s": 0.6,
           "gaits": {}, "channels": {}}  # fmt: skip
    m.metadata = {"fit": {"domain": dom}}
    return m


def _per_metre(v):
    return A + B / v + C * v


def _detour_model() -> EnergyModel:
    """Forward cost per metre 600 + 1000 g + 15000 g^2 at grade g (critical grade 11.5 deg),
    dearer backward and sideways, plus 200 W standing and swing losses 800 v^2 W."""
    from energy_planner.model.terms import resolve_term

    g = "sin(alpha) * cos(gamma)"
    spec = {
        "pos(vx)": 600.0, f"pos(vx) * {g}": 1000.0, f"pos(vx) * ({g}) ** 2": 15000.0,
        "pos(-vx)": 15600.0, f"-pos(-vx) * {g}": 1000.0,
        "abs(vy)": 15600.0, "-vy * sin(alpha) * sin(gamma)": 1000.0,
        "1": 200.0, "speed ** 2": 800.0,
    }  # fmt: skip
    terms = [resolve_term(f) for f in spec]
    return EnergyModel(terms, {t.name: v for t, v in zip(terms, spec.values(), strict=True)})


def _spy(monkeypatch) -> list:
    """Keep what the library's compare_routes returns to the command."""
    import energy_planner.planning.compare as mod

    real, kept = mod.compare_routes, []

    def spy(*a, **k):
        kept.append(real(*a, **k))
        return kept[-1]

    monkeypatch.setattr(mod, "compare_routes", spy)
    return kept


def _json_equal(printed: dict, obj: dict) -> bool:
    """``printed`` is ``obj`` as JSON, besides the wall-clock times and the outputs written."""
    from energy_planner.cli.options import _jsonable

    def strip(d):
        if isinstance(d, dict):
            return {k: strip(v) for k, v in d.items() if k not in ("time_s", "plot")}
        if isinstance(d, list):
            return [strip(v) for v in d]
        return d

    return strip(printed) == strip(json.loads(json.dumps(_jsonable(obj))))


@pytest.fixture(scope="module")
def plane():
    t = Terrain.from_function(lambda x, y: 0.12 * x, size=(30, 12), resolution=1.0)
    x0, y0 = t.grid[0], t.grid[1]
    return Problem(t, _model()), (x0 + 2.0, y0 - 5.0), (x0 + 26.0, y0 - 5.0)


def _walks(route):
    return [p["speed_m_s"] for p in route.speed_profile() if p["speed_m_s"] > 0]


def test_a_fixed_route_walks_at_sqrt_b_over_c_and_at_length_over_deadline(plane):
    p, s, g = plane
    line = np.array([[*s, 0.0], [*g, 0.0]])
    free = timed(p, line, speed=RANGE)
    assert free.speed_profile()[0]["speed_m_s"] == pytest.approx(V_STAR, rel=1e-6)
    length = free.distance_m
    assert free.energy_j == pytest.approx(length * _per_metre(V_STAR), rel=1e-9)
    late = timed_deadline(p, line, length / 1.1, speed=RANGE)
    v = length / late.duration_s
    assert late.duration_s <= length / 1.1
    assert v == pytest.approx(1.1, rel=2e-4)
    assert late.energy_j == pytest.approx(length * _per_metre(1.1), rel=1e-3)
    # a deadline the free timing meets changes nothing
    easy = timed_deadline(p, line, 2 * free.duration_s, speed=RANGE)
    assert easy.energy_j == free.energy_j and easy.info["deadline"]["lambda_j_per_s"] == 0
    with pytest.raises(PlanningError, match="top of the speed range") as info:
        timed_deadline(p, line, length / 2.0, speed=RANGE)
    assert info.value.value == pytest.approx(length / RANGE[1], rel=1e-6)
    # each point of a route's front: the closed form sqrt((b + lambda) / c), clamped
    front = route_front(p, line, [0.0, 10.0, 1000.0], speed=RANGE)
    for lam, row in zip(front.lambdas, front.rows(), strict=True):
        v = min(max(math.sqrt((B + lam) / C), RANGE[0]), RANGE[1])
        assert row["speed_max_m_s"] == pytest.approx(v, rel=1e-6)
        assert row["energy_j"] == pytest.approx(length * _per_metre(v), rel=1e-9)


def test_compare_routes_at_the_best_speed_and_under_a_deadline(plane):
    p, s, g = plane
    fixed = ep.compare_routes(p, s, g, time=1)  # the nominal 0.3 m/s, as always
    assert all(r.times is None for r in fixed.routes) and "speed chosen" not in fixed.table()
    comp = ep.compare_routes(p, s, g, speed=RANGE, time=1)
    direct = comp.route("direct")
    assert _walks(direct) == [pytest.approx(V_STAR, rel=1e-6)]
    assert direct.energy_j == pytest.approx(direct.distance_m * _per_metre(V_STAR), rel=1e-9)
    assert direct.to_dict()["speed_profile"][0]["speed_m_s"] == pytest.approx(V_STAR)
    assert "speed chosen per motion within 0.2-1.5 m/s" in comp.table()
    deadline = direct.distance_m / 1.2
    late = ep.compare_routes(p, s, g, speed=RANGE, deadline=deadline, time=1)
    d = late.route("direct")
    assert d.duration_s <= deadline and d.deadline["on_time"]
    assert _walks(d) == [pytest.approx(1.2, rel=2e-4)]
    assert d.energy_j == pytest.approx(d.distance_m * _per_metre(1.2), rel=1e-3)
    best = late.route("energy_optimal")
    assert best.duration_s <= deadline and best.energy_j <= d.energy_j * (1 + 1e-9)
    info = late.info["deadline"]
    assert info["deadline_s"] == deadline and info["energy_optimal_from"]
    assert {c["route"] for c in info["candidates"]} >= {"direct", "plan under the deadline"}
    assert "the least energy in time" in late.table()
    with pytest.raises(PlanningConfigError, match="not both"):
        ep.compare_routes(p, s, g, speed=RANGE, deadline=deadline, pareto=3)


@pytest.fixture(scope="module")
def hill():
    """A 36 m x 28 m window of the bundled hill; the detour model with speed terms."""
    from energy_planner.terrain import load_dem

    model = _detour_model()  # v* = 0.5 m/s
    terrain = load_dem(ep.map_path("hill"), bounds=(500040, 5000040, 500076, 5000068))
    return Problem(terrain, model), (500058.0, 5000046.0), (500058.0, 5000062.0)


def test_a_deadline_favours_the_direct_climb_over_the_detour(hill):
    p, s, g = hill
    free = ep.compare_routes(p, s, g, speed=(0.2, 2.0), time=0.5)
    direct, detour = free.route("direct"), free.route("energy_optimal")
    # at its best speed, the least-energy route is a detour, cheaper than the climb
    assert detour.same_as is None and detour.distance_m > 1.05 * direct.distance_m
    assert detour.energy_j < 0.9 * direct.energy_j
    deadline = direct.distance_m / 1.6  # the straight climb at 1.6 m/s
    late = ep.compare_routes(p, s, g, speed=(0.2, 2.0), deadline=deadline, time=0.5)
    best, line = late.route("energy_optimal"), late.route("direct")
    assert best.duration_s <= deadline and line.duration_s <= deadline
    # in time, the least-energy route is the straight climb: the detour is late, or dearer
    assert best.distance_m < 1.02 * direct.distance_m
    # the detour found without the deadline, walked to arrive in time: late, or dearer
    try:
        walked = timed_deadline(p, detour.states, deadline, speed=(0.2, 2.0))
    except PlanningError as exc:
        assert exc.limit == "deadline" and exc.value > deadline
    else:
        assert walked.energy_j > line.energy_j
    # the climb's energy in time is the energy command's for its poses at those times
    pe = ep.path_energy(p, line.states[:, :2], yaw=line.states[:, 2], t=line.times)
    assert pe.energy_j == pytest.approx(line.energy_j, rel=1e-9)


@pytest.fixture(scope="module")
def ramp(tmp_path_factory):
    """A GeoTIFF of a 12 % grade along x, 30 m x 12 m, and the plane model's file."""
    import rasterio
    from rasterio.transform import from_origin

    where = tmp_path_factory.mktemp("ramp")
    model = where / "m.json"
    _model().save(model)
    dem = where / "ramp.tif"
    z = np.tile(0.12 * (np.arange(30) + 0.5), (12, 1))
    with rasterio.open(
        dem, "w", driver="GTiff", height=12, width=30, count=1, dtype="float64",
        crs="EPSG:32631", transform=from_origin(500000.0, 5000012.0, 1.0, 1.0),
    ) as dst:  # fmt: skip
        dst.write(z, 1)
    return dem, model


def test_cli_deadline_and_pareto_print_what_the_library_returns(ramp, tmp_path, monkeypatch):
    dem, model = ramp
    args = ["compare-routes", "--dem", str(dem), "--start", "500002,5000006", "--goal",
            "500026,5000006", "--model", str(model), "--time", "0.5"]  # fmt: skip
    kept = _spy(monkeypatch)
    run = CliRunner().invoke(main, [*args, "--deadline", "22", "--json"])
    assert run.exit_code == 0, run.output
    printed = json.loads(run.stdout)
    assert _json_equal(printed, kept[-1].to_dict())
    assert printed["info"]["deadline"]["deadline_s"] == 22
    assert printed["info"]["speed"]["speed_range"] == list(RANGE)  # auto: the logged range
    d = next(r for r in printed["routes"] if r["name"] == "direct")
    assert d["duration_s"] <= 22 and d["deadline"]["on_time"]
    assert d["speed_profile"][0]["speed_m_s"] == pytest.approx(d["distance_m"] / 22, rel=2e-4)
    plot = tmp_path / "front.png"
    run = CliRunner().invoke(main, [*args, "--pareto", "3", "--plot", str(plot), "--json"])
    assert run.exit_code == 0, run.output
    printed = json.loads(run.stdout)
    assert _json_equal(printed, kept[-1].to_dict())
    assert plot.stat().st_size > 0 and printed["plot"] == str(plot)
    fronts = printed["fronts"]
    assert set(fronts) >= {"direct", "energy_optimal"}
    rows = fronts["direct"]["points"]
    assert len(rows) == 3 and rows[0]["speed_max_m_s"] == pytest.approx(V_STAR, rel=1e-6)
    assert np.all(np.diff([r["duration_s"] for r in rows]) < 0)
    assert "energy-time front of direct" in kept[-1].table()


# --- reach bounded in time -------------------------------------------------------------


def test_reach_within_a_time_walks_at_the_best_speed_and_bounds_by_the_fastest():
    """On level ground: along the lattice's axes the least energy is ``d (a + 2 sqrt(b c))``
    (each motion at ``v*``) and the least time ``d / vmax``; ``max_time`` keeps the cells
    reached within it."""
    t = Terrain.from_function(lambda x, y: 0.0 * x, size=(25, 25), resolution=1.0)
    p = Problem(t, _model())
    x0, y0 = t.grid[0], t.grid[1]
    s = (x0 + 12.0, y0 - 12.0)
    res = ep.reach(p, s, speed=RANGE, max_time=6.0)
    row = res.energy_j[12]  # the row of the start, west to east
    d = np.abs(np.arange(25) - 12.0)
    axis = np.isfinite(row)
    assert list(np.nonzero(axis)[0]) == list(range(3, 22))  # 9 m at 1.5 m/s: 6 s
    np.testing.assert_allclose(row[axis], d[axis] * (A + 2 * math.sqrt(B * C)), rtol=1e-5)
    np.testing.assert_allclose(res.time_s[12][axis], d[axis] / RANGE[1], rtol=1e-5)
    out = res.to_dict()
    assert out["time_bound"]["max_time_s"] == 6.0 and out["time_bound"]["top_speed_m_s"] == 1.5
    assert out["speed"]["speed_range"] == list(RANGE)
    fixed = ep.reach(p, s, budget_wh=1.0)  # the nominal 0.3 m/s, no bound: as before
    assert fixed.time_s is None and "time_bound" not in fixed.to_dict()
    inner = slice(1, 24)  # the map's border cells are not searched
    np.testing.assert_allclose(fixed.energy_j[12, inner], d[inner] * _per_metre(0.3), rtol=1e-5)


def test_cli_reach_max_time_prints_what_the_library_returns(ramp, tmp_path):
    dem, model = ramp
    args = ["reach", str(dem), "--start", "500015,5000006", "--model", str(model), "--speed",
            "auto", "--max-time", "6"]  # fmt: skip
    plot = tmp_path / "r.png"
    run = CliRunner().invoke(main, [*args, "--plot", str(plot), "--json"])
    assert run.exit_code == 0, run.output
    printed = json.loads(run.stdout)
    res = ep.reach(str(dem), (500015, 5000006), model=str(model), speed="auto", max_time=6.0)
    assert _json_equal(printed, {"dem": str(dem), **res.to_dict()})
    assert printed["time_bound"]["top_speed_m_s"] == RANGE[1]
    assert 0 < printed["time_bound"]["least_time_max_s"] <= 6.0
    assert plot.stat().st_size > 0
    run = CliRunner().invoke(main, args)
    assert "within 6 s" in run.output and "least-energy speed within 0.2-1.5" in run.output


# --- a mission within a time budget ----------------------------------------------------


def test_mission_within_a_time_budget_walks_every_leg_at_length_over_budget():
    """Level ground, three sites 10 m apart along the lattice's axes: each leg is a
    straight line, one price of a second walks every leg at the same speed, so a budget
    ``T`` for the 20 m tour asks for ``20 / T`` m/s on every leg."""
    t = Terrain.from_function(lambda x, y: 0.0 * x, size=(16, 16), resolution=1.0)
    p = Problem(t, _model())
    x0, y0 = t.grid[0], t.grid[1]
    sites = Sites(np.array([[x0 + 3, y0 - 3], [x0 + 13, y0 - 3], [x0 + 13, y0 - 13]]),
                  ["a", "b", "c"])  # fmt: skip
    free = ep.mission(p, sites, speed=RANGE)
    assert free.order == [0, 1, 2] and free.distance_m == pytest.approx(20.0)
    assert free.energy_j == pytest.approx(20.0 * _per_metre(V_STAR), rel=1e-6)
    assert all(leg.speed_profile()[0]["speed_m_s"] == pytest.approx(V_STAR, rel=1e-6)
               for leg in free.legs)  # fmt: skip
    res = ep.mission(p, sites, time_budget=20.0)  # speeds within the logged range
    v = res.distance_m / res.duration_s
    assert res.duration_s <= 20.0 and 1.0 <= v <= 1.03
    assert res.energy_j == pytest.approx(20.0 * _per_metre(v), rel=1e-6)
    assert res.energy_j == pytest.approx(20.0 * _per_metre(1.0), rel=0.01)
    d = res.to_dict()
    assert d["time_budget"]["time_budget_s"] == 20.0 and d["time_budget"]["lambda_j_per_s"] > 0
    assert d["legs"][0]["speed_max_m_s"] == pytest.approx(v, rel=1e-6)


def test_cli_mission_time_budget_prints_what_the_library_returns(ramp, tmp_path, monkeypatch):
    import energy_planner.mission as pkg

    dem, model = ramp
    csv = tmp_path / "sites.csv"
    csv.write_text("x,y,name\n500003.5,5000006.5,a\n500013.5,5000006.5,b\n500023.5,5000006.5,c\n")
    real, kept = pkg.mission, []

    def spy(*a, **k):
        kept.append(real(*a, **k))
        return kept[-1]

    monkeypatch.setattr(pkg, "mission", spy)
    run = CliRunner().invoke(main, ["mission", "--dem", str(dem), "--sites", str(csv), "--model",
                                    str(model), "--time-budget", "20", "--json"])  # fmt: skip
    assert run.exit_code == 0, run.output
    printed = json.loads(run.stdout)
    assert _json_equal(printed, {**kept[-1].to_dict(), "dem": str(dem)})
    assert printed["duration_s"] <= 20 and printed["time_budget"]["time_budget_s"] == 20
    assert printed["speed"]["speed_range"] == list(RANGE)


# --- following a mission with a deadline -----------------------------------------------


def test_follower_says_whether_the_deadline_holds_and_the_speed_that_keeps_it(
    follow_mission, make_follower
):
    """The mission walks forward at a constant 0.3 m/s and the plan's times are the log's:
    the slack is the deadline less the walk's duration at every update, and the speed that
    keeps a deadline ``D`` after ``e`` seconds is ``0.3 (T - e) / (D - e)``."""
    logs = follow_mission()
    t = logs["t"].to_numpy()
    total = float(t[-1] - t[0])
    v = float(np.hypot(*np.diff(logs[["x", "y"]].to_numpy(), axis=0).T).sum()) / total
    assert v == pytest.approx(0.3, rel=0.02)
    for share in (1.2, 0.75):
        deadline = share * total
        f = make_follower(logs, deadline=deadline)
        ups = f.replay(logs)
        assert len(ups) > 20
        for u in ups[:-1]:
            e = u.t - t[0]
            assert u.deadline_slack_s == pytest.approx(deadline - total, abs=1.5)
            if e >= deadline:  # past it: no speed keeps it
                assert u.speed_to_keep_m_s == math.inf
                continue
            keep = v * (total - e) / (deadline - e)  # (the path's ground metres: 0.005 m/s)
            assert u.speed_to_keep_m_s == pytest.approx(keep, rel=0.03, abs=0.005)
            assert u.to_dict()["deadline_ok"] == (share > 1)
        lost = [ev for ev in f.events if "before the deadline" in ev]
        assert len(lost) == (0 if share > 1 else 1)
        assert f.to_dict()["deadline_s"] == deadline
    assert "deadline_ok" not in make_follower(logs).replay(logs[:400])[0].to_dict()


def test_cli_follow_deadline_prints_what_the_follower_returns(tmp_path, follow_config):
    from energy_planner.energy.waypoints import read_waypoints
    from energy_planner.follow import follow_log
    from energy_planner.io.path_format import write_path_from_work
    from energy_planner.simulate import simulate_missions

    ter = ep.open_terrain(ep.map_path("hill"))
    logs = simulate_missions(seed=2, config=follow_config.replace(duration_s=30.0),
                             terrain=ter).logs  # fmt: skip
    k = np.r_[np.arange(0, len(logs), 10), len(logs) - 1]
    path = write_path_from_work(tmp_path / "plan.geojson", ter,
                                logs[["x", "y", "yaw"]].to_numpy()[k],
                                t=logs["t"].to_numpy()[k])  # fmt: skip
    log = tmp_path / "run.csv"
    logs.to_csv(log, index=False)
    args = ["follow", str(log), "--dem", str(ep.map_path("hill")), "--path", str(path),
            "--deadline", "20"]  # fmt: skip
    run = CliRunner().invoke(main, [*args, "--json"])
    assert run.exit_code == 0, run.output
    printed = json.loads(run.stdout)
    from energy_planner.measurements import load_logs

    f = follow_log(ter, ep.load_model(), load_logs(log), read_waypoints(path), deadline=20.0)
    assert _json_equal(printed, {**f.to_dict(), "log": str(log), "dem": printed["dem"],
                                 "path": str(path)})  # fmt: skip
    assert printed["deadline_s"] == 20 and not printed["updates"][0]["deadline_ok"]
    assert any("before the deadline" in e for e in printed["events"])
    run = CliRunner().invoke(main, args)
    assert "slack s" in run.output and "keep m/s" in run.output


def test_pareto_plans_anew_where_the_route_changes(hill):
    """On the hill the least-energy route is a detour and the straight climb is the
    fastest: walking the detour faster is not within eps of the front's lower bound (the
    least-energy search's bound of the energy plus lambda times the straight line at the
    top speed), so the dearest second's point is planned anew, and is the straight
    climb."""
    p, s, g = hill
    front = ep.pareto(p, s, g, 4, speed=(0.2, 2.0), time=0.5)
    line = math.hypot(g[0] - s[0], g[1] - s[1])

    def length(pt):
        return float(np.hypot(*np.diff(pt.states[:, :2], axis=0).T).sum())

    assert length(front.plans[0]) > 1.05 * line  # the detour
    last = front.plans[-1]
    assert "retimed" not in last.info and length(last) < 1.001 * line


def test_bound_bands_of_a_speed_range_serve_every_price_of_a_second():
    """A deadline's bisection plans at one ``lambda`` after another: the bound table's bands
    at the speed nodes are priced once (they leave ``lambda`` out) and each ``lambda``'s
    table is bit for bit the one computed afresh; on this plane every table entry is at
    most the least cost of a metre, ``min over v in RANGE of a + (b + lambda) / v + c v``
    (the bound is admissible), and within 2 % of it (the speed nodes are that close)."""
    from energy_planner.planning import search

    t = Terrain.from_function(lambda x, y: 0.0 * x, size=(16, 16), resolution=1.0)
    p = Problem(t, _model())
    v = np.geomspace(*RANGE, 2001)
    for lam in (0.0, 60.0, 300.0):
        cost = p.with_speed(RANGE, lam).cost
        grid = search._Grid(cost, t, (t.grid[0] + 3, t.grid[1] - 3), None, 16, "all")
        kept, tgeo = search.bound_table(cost, grid.headings, grid.move_ok)
        assert len(search._RANGED_NODES[t]) == 1  # one set of bands for every lambda
        search._RANGED_NODES[t].clear()
        fresh, tgeo2 = search.bound_table(p.with_speed(RANGE, lam).cost, grid.headings,
                                          grid.move_ok)  # fmt: skip
        np.testing.assert_array_equal(kept, fresh)
        np.testing.assert_array_equal(tgeo, tgeo2)
        least = float(np.min(A + (B + lam) / v + C * v))
        fin = kept[np.isfinite(kept)]
        assert fin.max() <= least * (1 + 1e-6) and fin.min() >= 0.98 * least
