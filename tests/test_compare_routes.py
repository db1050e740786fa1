"""compare_routes and the ``plan`` / ``compare-routes`` commands (through CliRunner)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

from energy_planner.cli import main
from energy_planner.model import EnergyModel
from energy_planner.planning import PLANNERS
from energy_planner.planning.compare import compare_routes
from energy_planner.request import Request
from energy_planner.terrain import Terrain


def _ridge(x, y):
    # a ridge across the map, steep (about 31 deg) in the middle, gentle at the east end
    x, y = x - 500000.0, y - 5000000.0
    h = 12.0 * np.exp(-(((y - 30.0) / 8.0) ** 2)) * np.clip((60.0 - x) / 40.0, 0.0, 1.0)
    return h


@pytest.fixture(scope="module")
def dem(tmp_path_factory):
    import rasterio
    from rasterio.transform import from_origin

    t = Terrain.from_function(_ridge, size=(60, 60), origin=(500000.0, 5000000.0))
    path = tmp_path_factory.mktemp("dem") / "ridge.tif"
    with rasterio.open(
        path, "w", driver="GTiff", height=60, width=60, count=1, dtype="float64",
        crs="EPSG:32631", transform=from_origin(500000.0, 5000060.0, 1.0, 1.0),
    ) as dst:  # fmt: skip
        dst.write(t.elevation, 1)
    return path, t


@pytest.fixture(scope="module")
def south(dem, tmp_path_factory):
    """The ridge's southern third (y 0-20 m, below its foot) as a GeoTIFF: a line along
    y = 10 m is the same there as on the whole map, and the routes a command plans besides
    cost a third."""
    import rasterio
    from rasterio.transform import from_origin

    z = dem[1].elevation[40:]  # row 0 is the north edge (y = 60 m)
    path = tmp_path_factory.mktemp("south") / "south.tif"
    with rasterio.open(
        path, "w", driver="GTiff", height=z.shape[0], width=z.shape[1], count=1,
        dtype="float64", crs="EPSG:32631", transform=from_origin(500000.0, 5000020.0, 1.0, 1.0),
    ) as dst:  # fmt: skip
        dst.write(z, 1)
    return path


@pytest.fixture(scope="module")
def across_the_ridge(dem, tmp_path_factory):
    """``compare-routes --max-slope 20 --time 2`` across the ridge, run once: the command's
    result (exit, JSON, its ``--plot``) and the comparison the library returned to it (a
    spy on ``energy_planner.api.compare_routes``, which the command calls with the DEM's
    terrain, the bundled model and the request). The library's checks and the command's read
    this one search (each searched it on its own: the same map, model and limit)."""
    import energy_planner.api as api

    path, _ = dem
    png = tmp_path_factory.mktemp("routes") / "routes.png"
    real, kept = api.compare_routes, []

    def spy(*a, **k):
        kept.append((k, real(*a, **k)))
        return kept[-1][1]

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(api, "compare_routes", spy)
        res = CliRunner().invoke(
            main,
            ["compare-routes", "--dem", str(path), "--start", "500015,5000010", "--goal",
             "500015,5000050", "--max-slope", "20", "--time", "2", "--plot", str(png),
             "--json"],
        )  # fmt: skip
    return res, kept, png


def test_compare_routes_reports_an_infeasible_direct_line(across_the_ridge):
    _, kept, _ = across_the_ridge
    ((kw, comp),) = kept  # one search: the default planner for 2 s, the 20 deg limit
    assert kw["planner"] == "auto" and kw["time"] == 2.0
    assert kw["model"].to_dict() == EnergyModel.default().to_dict()
    assert kw["request"].limits.max_slope_deg == 20.0
    names = [r.name for r in comp.routes]
    assert names == ["direct", "direct_best_yaw", "shortest", "energy_optimal"]
    assert not comp.route("direct_best_yaw").feasible
    direct = comp.route("direct")
    assert not direct.feasible
    assert "slope" in direct.reason and "limit 20 deg" in direct.reason
    # the direct line still has an energy (it stays on the map) and crosses > 20 deg
    assert direct.max_slope_deg > 20
    for name in ("shortest", "energy_optimal"):
        r = comp.route(name)
        assert r.feasible and r.max_slope_deg <= 20.0 + 1e-6
        assert r.distance_m > direct.distance_m
    shortest, best = comp.route("shortest"), comp.route("energy_optimal")
    assert best.energy_j <= shortest.energy_j * (1 + 1e-9)
    assert best.saving_vs_direct == pytest.approx(
        (direct.energy_j - best.energy_j) / direct.energy_j
    )


def test_compare_routes_cli_json_and_plot(across_the_ridge, south):
    res, _, png = across_the_ridge
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    routes = {r["name"]: r for r in out["routes"]}
    assert set(routes) == {"direct", "direct_best_yaw", "shortest", "energy_optimal"}
    for r in routes.values():
        for key in ("energy_j", "distance_m", "duration_s", "max_slope_deg", "feasible"):
            assert key in r
    assert routes["direct"]["feasible"] is False and "limit 20 deg" in routes["direct"]["reason"]
    assert routes["energy_optimal"]["feasible"] is True
    assert png.stat().st_size > 10_000
    # the text table names every route (the layout: on the southern third, a third the work)
    res = CliRunner().invoke(
        main,
        ["compare-routes", "--dem", str(south), "--start", "500015,5000010", "--goal",
         "500040,5000010", "--time", "1", "--planner", "lattice"],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    assert all(n in res.output for n in ("direct", "shortest", "energy_optimal"))


def test_compare_routes_cli_interval_and_battery_per_route(dem, south):
    """Each feasible route carries its interval and battery chance; --refuse judges the best."""
    from energy_planner.uncertainty import battery_decision, predict_interval

    path, _ = dem
    base = ["compare-routes", "--dem", str(path), "--start", "500015,5000010",
            "--goal", "500015,5000050", "--max-slope", "20", "--time", "1",
            "--planner", "lattice"]  # fmt: skip
    res = CliRunner().invoke(main, [*base, "--json", "--battery-wh", "30", "--reserve-wh", "2"])
    assert res.exit_code == 0, res.output
    routes = {r["name"]: r for r in json.loads(res.stdout)["routes"]}
    model = EnergyModel.default()
    for r in routes.values():
        if not r["feasible"]:
            assert "interval" not in r and "battery" not in r
            continue
        iv, want = r["interval"], predict_interval(model, r["energy_j"], 0.9)
        assert iv["low_j"] < r["energy_j"] < iv["high_j"]
        assert (iv["low_j"], iv["high_j"]) == pytest.approx((want.low_j, want.high_j))
        d = battery_decision(model, r["energy_j"], 30.0, 2.0, 0.9)
        assert r["battery"]["probability"] == pytest.approx(d.probability)
    # a battery too small for the energy-optimal route: a warning naming it, or exit 1. On the
    # southern third (a third of the planning; its route measured 4.41 Wh), so that the two
    # runs below cost less than the one above; the --json run checks the battery is too small.
    on_south = ["compare-routes", "--dem", str(south), "--start", "500015,5000010",
                "--goal", "500040,5000010", "--max-slope", "20", "--time", "1",
                "--planner", "lattice", "--battery-wh", "3.5"]  # fmt: skip
    res = CliRunner().invoke(main, [*on_south, "--json"])
    assert res.exit_code == 0 and "warning: energy_optimal:" in res.stderr, res.output
    best = {r["name"]: r for r in json.loads(res.stdout)["routes"]}["energy_optimal"]
    assert 0.7 < 3.5 / (best["energy_j"] / 3600.0) < 0.9  # just too small, as 80 % of it
    assert best["battery"]["ok"] is False
    res = CliRunner().invoke(main, [*on_south, "--refuse"])
    assert res.exit_code == 1 and "Error: energy_optimal:" in res.output, res.output


def test_plan_cli_json_geojson(dem, tmp_path):
    path, _ = dem
    out = tmp_path / "path.geojson"
    res = CliRunner().invoke(
        main,
        ["plan", "--dem", str(path), "--start", "500010,5000010,90", "--goal",
         "500050,5000012", "--planner", "lattice", "--out", str(out), "--json"],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    for key in ("energy_j", "distance_m", "duration_s", "planner", "waypoints"):
        assert key in data
    assert data["planner"] == "lattice"
    w = data["waypoints"]
    assert (w[0]["x"], w[0]["y"], w[0]["yaw_deg"]) == pytest.approx((500010, 5000010, 90))
    assert (w[-1]["x"], w[-1]["y"]) == pytest.approx((500050, 5000012))
    # the project's one path format (energy_planner.geojson; RFC 7946 lon/lat), read back
    # and placed on the map: the same poses
    from energy_planner.energy.waypoints import waypoints_to_work
    from energy_planner.geojson import read_path

    wp = read_path(out)
    assert wp.declared_crs == "OGC:CRS84"
    xy, _ = waypoints_to_work(dem[1], wp)
    assert np.allclose(xy, [[p["x"], p["y"]] for p in w], atol=1e-6)
    assert len(wp.yaw_rad) == len(w)
    assert math.isclose(wp.properties["energy_j"], data["energy_j"])


def test_plan_cli_errors(dem):
    path, _ = dem
    base = ["plan", "--dem", str(path), "--goal", "500050,5000012"]
    res = CliRunner().invoke(main, [*base, "--start", "500010,5000010", "--planner", "prm"])
    assert res.exit_code == 2
    assert "unknown planner 'prm'" in res.output
    assert ", ".join(PLANNERS) in res.output
    res = CliRunner().invoke(main, [*base, "--start", "400000,5000010"])
    assert res.exit_code == 2
    assert "--start" in res.output and "outside the map" in res.output
    res = CliRunner().invoke(main, [*base, "--start", "500015,5000024", "--max-slope", "10"])
    assert res.exit_code == 2
    assert "slope" in res.output and "limit 10 deg" in res.output
    res = CliRunner().invoke(main, [*base, "--start", "1,2,3,4"])
    assert res.exit_code == 2


def test_plan_cli_keep_out_file(dem, tmp_path):
    path, _ = dem
    ko = tmp_path / "ko.geojson"
    ko.write_text(json.dumps({"type": "FeatureCollection",
        "crs": {"type": "name", "properties": {"name": "EPSG:32631"}}, "features": [{
        "type": "Feature", "properties": {},
        "geometry": {"type": "Polygon", "coordinates": [[
            [500028, 5000002], [500032, 5000002], [500032, 5000020], [500028, 5000020],
            [500028, 5000002]]]}}]}))  # fmt: skip
    res = CliRunner().invoke(
        main,
        ["plan", "--dem", str(path), "--start", "500010,5000010", "--goal", "500050,5000010",
         "--planner", "lattice", "--keep-out", str(ko), "--json"],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    from shapely.geometry import LineString, box

    w = json.loads(res.stdout)["waypoints"]
    line = LineString([(p["x"], p["y"]) for p in w])
    assert not line.intersects(box(500028, 5000002, 500032, 5000020))
    bad = tmp_path / "bad.geojson"
    bad.write_text("{not json")
    res = CliRunner().invoke(
        main,
        ["plan", "--dem", str(path), "--start", "500010,5000010", "--goal", "500050,5000010",
         "--keep-out", str(bad)],
    )  # fmt: skip
    assert res.exit_code != 0 and "not JSON" in res.output


# --- the physics of the detour: a convex cost per metre and its critical grade ----------
#
# A model whose forward cost per metre along a path of grade g (the sine of the path's
# inclination; on a slope alpha walked at relative heading gamma, g = sin(alpha) cos(gamma))
# is c(g) = a + b g + k g^2: the quadratic term is the copper loss of the force the legs
# hold against gravity. Backward and sideways gaits cost more than forward at any grade
# these tests use, so the planner climbs walking forward. Turning is free. A metre of
# height then costs c(g) / g >= c(g*) / g* with g* = sqrt(a / k), on any path: a lower
# bound for the energy of climbing H metres, E >= H c(g*) / g*, which a zig-zag at g*
# reaches. The straight climb of a plane of slope s costs H c(s) / s.
A_, B_, K_ = 600.0, 1000.0, 15000.0  # g* = sqrt(600 / 15000) = 0.2 (11.5 deg)
QUAD = "pos(vx) * (sin(alpha) * cos(gamma)) ** 2"


def _convex_model(k=K_):
    from energy_planner.model.terms import resolve_term

    g_fwd = "sin(alpha) * cos(gamma)"  # grade along the travel walking forward
    spec = {
        "pos(vx)": A_, f"pos(vx) * {g_fwd}": B_,
        "pos(-vx)": A_ + K_, f"-pos(-vx) * {g_fwd}": B_,
        "abs(vy)": A_ + K_, "-vy * sin(alpha) * sin(gamma)": B_,
    }  # fmt: skip
    if k:
        spec[QUAD] = k
    terms = [resolve_term(f) for f in spec]
    return EnergyModel(terms, {t.name: v for t, v in zip(terms, spec.values(), strict=True)})


def _c(g):
    return A_ + B_ * g + K_ * g * g


def _plane(s, size=40):
    return Terrain.from_function(lambda x, y: math.tan(math.asin(s)) * y, size=(size, size))


def test_grade_cost_finds_the_closed_form_critical_grade():
    from energy_planner.planning.compare import grade_cost

    gc = grade_cost(_convex_model())
    assert gc.critical_grade == pytest.approx(math.sqrt(A_ / K_), abs=1e-3)
    assert gc.closed_form_grade == pytest.approx(math.sqrt(A_ / K_), rel=1e-6)
    assert gc.quadratic == pytest.approx((A_, B_, K_), rel=1e-6)
    # the per-height cost is the analytic one
    assert gc.per_height(0.5) == pytest.approx(_c(0.5) / 0.5, rel=1e-3)
    # linear in the grade: c(g) / g falls all the way, no critical grade
    assert grade_cost(_convex_model(k=0.0)).critical_grade is None


@pytest.mark.parametrize(
    ("s", "detour"), [(0.5, True), (0.12, False)], ids=["steeper-than-g*", "gentler"]
)
def test_zigzag_pays_exactly_when_the_slope_exceeds_the_critical_grade(s, detour):
    terrain = _plane(s)
    start, goal = (20.0, 5.0), (20.0, 35.0)
    comp = compare_routes(terrain, _convex_model(), start, goal, time=2, progress=False)
    direct, short, best = (comp.route(n) for n in ("direct", "shortest", "energy_optimal"))
    H = 30.0 * math.tan(math.asin(s))
    # the straight climb: H c(s) / s, analytically
    assert direct.energy_j == pytest.approx(H * _c(s) / s, rel=2e-3)
    # no limit: the straight line is the shortest path, and the table says so
    assert short.same_as == "direct"
    g_star = math.sqrt(A_ / K_)
    bound = H * _c(g_star) / g_star if detour else H * _c(s) / s
    # never below the lower bound (a physical law), at most 3% above it (lattice headings)
    assert best.energy_j >= bound * (1 - 2e-3)
    assert best.energy_j <= bound * 1.03
    if detour:
        assert best.same_as is None
        assert best.distance_m > 1.5 * direct.distance_m
        assert best.saving_vs_direct > 0.2
        # it climbs near the critical grade, far below the plane's slope
        assert best.climb_grade < 0.6 * s
        assert comp.physics["critical_grade"] == pytest.approx(g_star, abs=1e-3)
        assert "critical grade g* = 11.5 deg" in comp.table()
    else:
        assert best.energy_j == pytest.approx(direct.energy_j, rel=5e-3)


def test_a_linear_model_never_zigzags_without_a_limit():
    comp = compare_routes(
        _plane(0.5), _convex_model(k=0.0), (20.0, 5.0), (20.0, 35.0), time=1, progress=False
    )
    best, direct = comp.route("energy_optimal"), comp.route("direct")
    assert best.energy_j == pytest.approx(direct.energy_j, rel=5e-3)
    assert comp.physics["critical_grade"] is None
    assert "never by climbing more gently" in comp.table()


def test_three_different_routes_with_a_limit_and_a_convex_model(dem):
    _, terrain = dem
    s, g = (500015.0, 5000010.0), (500015.0, 5000050.0)
    comp = compare_routes(
        terrain, _convex_model(), s, g, Request.make(max_slope_deg=20), time=2, progress=False
    )
    direct, short, best = (comp.route(n) for n in ("direct", "shortest", "energy_optimal"))
    assert not direct.feasible
    assert short.same_as is None and best.same_as is None
    assert short.distance_m <= best.distance_m
    assert best.energy_j < short.energy_j
    text = comp.table()
    assert "(the same path)" not in text


def test_route_lookup_error_is_a_project_error_and_a_key_error(dem):
    from energy_planner.errors import EnergyPlannerError
    from energy_planner.planning.compare import RouteComparison

    comp = RouteComparison([], (0.0, 0.0, None), (1.0, 1.0, None))
    with pytest.raises(KeyError, match="no route 'fastest'"):
        comp.route("fastest")
    with pytest.raises(EnergyPlannerError):
        comp.route("fastest")


def test_compare_routes_cli_reads_channels(south, tmp_path):
    """--set feeds a channel the model reads: a payload term ``c * payload_kg * speed``
    adds ``c * payload_kg`` J per metre to every route (the direct line analytically).
    On the ridge's southern third (:func:`south`), where the direct line runs."""
    path = south
    base = EnergyModel.default()
    c = 9.81
    model = EnergyModel([*base.term_specs, "payload"], {**base.coefficients, "payload": c})
    mpath = model.save(tmp_path / "payload.json")
    args = ["compare-routes", "--dem", str(path), "--start", "500015,5000010", "--goal",
            "500040,5000010", "--planner", "lattice", "--time", "1", "--model", str(mpath),
            "--json"]  # fmt: skip
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 2 and "payload_kg" in r.output and "--set" in r.output
    out = {}
    for kg in (0, 10):
        r = CliRunner().invoke(main, [*args, "--set", f"payload_kg={kg}"])
        assert r.exit_code == 0, r.output
        out[kg] = {x["name"]: x for x in json.loads(r.stdout)["routes"]}
    d0, d10 = out[0]["direct"], out[10]["direct"]
    assert d10["energy_j"] - d0["energy_j"] == pytest.approx(c * 10 * d0["distance_m"], rel=1e-6)


def test_best_yaw_line_and_same_path_judged_on_poses():
    from energy_planner.planning.compare import Route, _same_path

    flat = Terrain.from_array(np.zeros((40, 40)), resolution=1.0)
    model = EnergyModel.default()
    x0, y0 = flat.grid[0], flat.grid[1]
    s, g = (x0 + 5, y0 - 20), (x0 + 30, y0 - 20)
    comp = compare_routes(flat, model, s, g, time=1, progress=False)
    d, dy = comp.route("direct"), comp.route("direct_best_yaw")
    # on level ground facing forward is the cheapest gait: nothing to gain by crabbing
    assert dy.energy_j == pytest.approx(d.energy_j, rel=1e-9) and dy.body_yaw_deg == 0.0
    assert dy.same_as == "direct"
    # the same line with the body turned 40 deg is another gait, not "the same path"
    turned = d.states.copy()
    turned[:, 2] += np.radians(40)
    other = Route("x", turned, 1.0, d.distance_m, 1.0, 0.0, True)
    assert _same_path(d, d, 1.0) and not _same_path(d, other, 1.0)
    # on a slope the crabbed line is never dearer, and the split adds up
    hill = compare_routes(
        Terrain.from_array(np.add.outer(np.zeros(40), 0.4 * np.arange(40.0)), resolution=1.0),
        model, s, g, time=1, progress=False,
    )  # fmt: skip
    fwd, crab = hill.route("direct"), hill.route("direct_best_yaw")
    assert crab.energy_j <= fwd.energy_j
    split = " ".join(hill.saving_split())
    assert "points are gait" in split
