"""Battery reach (``energy_planner.planning.reach`` and ``energy-planner reach``).

Checked against analytic costs on level ground, against ``plan`` on a hill (the same
search, so the least energy of a cell on the budget contour is the energy ``plan``
finds to it), and through the CLI's files (GeoTIFF grid/CRS/nodata, GeoJSON polygon).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

from energy_planner.cli import main
from energy_planner.model import EnergyModel
from energy_planner.planning.reach import NODATA, reach
from energy_planner.terrain import Terrain

X0, Y0 = 500000.0, 5000000.0


def _cell(terrain, res, dx, dy):
    """Reach energy at the cell ``(dx, dy)`` metres from the start."""
    x0, y0, sx, sy = terrain.grid
    x, y = res.start[0] + dx, res.start[1] + dy
    return res.energy_j[round((y - y0) / sy), round((x - x0) / sx)]


@pytest.fixture(scope="module")
def flat():
    return Terrain.from_function(lambda x, y: 0.0 * x, size=(31, 31))


# cells along the search's move directions, where the lattice distance is the distance
OFFSETS = [(10, 0), (0, -10), (10, 5), (-10, -5), (8, 8), (-4, 8)]


def _level_power(model, vx=0.0, vy=0.0, wz=0.0):
    """The model's power on level ground for one body twist, W."""
    f = {"alpha": [0.0], "gamma": [0.0], "vx": [vx], "vy": [vy], "wz": [wz], "ax": [0.0],
         "ay": [0.0]}  # fmt: skip
    return float(model.power(f)[0])


def test_level_ground_costs_distance_times_the_level_cost_per_metre(flat):
    model = EnergyModel.default()
    res = reach(flat, model, (15.4, 15.6))
    assert res.start == (15.5, 15.5)  # the centre of the start's cell
    # the cheapest gait on level ground: forward, J per metre = power / speed
    v = 0.3
    a = _level_power(model, vx=v) / v
    assert a < min(_level_power(model, vx=-v), _level_power(model, vy=v)) / v
    for dx, dy in OFFSETS:
        # (the search keeps energies in float32)
        assert _cell(flat, res, dx, dy) == pytest.approx(math.hypot(dx, dy) * a, rel=1e-6)
    assert _cell(flat, res, 0, 0) == 0.0


def test_return_doubles_a_symmetric_cost_and_adds_the_turn_around(flat):
    base = EnergyModel.default()
    c = dict(base.coefficients)
    # turning free (no turning torque, no standing power): going and coming back costs
    # exactly twice going
    free = EnergyModel(
        base.term_specs, {**c, "turn_const": 0.0, "turn_slope": 0.0, "idle_power": 0.0}
    )
    one = reach(flat, free, (15.5, 15.5))
    two = reach(flat, free, (15.5, 15.5), round_trip=True)
    for dx, dy in OFFSETS:
        assert _cell(flat, two, dx, dy) == pytest.approx(2 * _cell(flat, one, dx, dy), rel=1e-6)
    # the default model: out forward, then back either after turning round in place
    # (pi rad at the yaw rate) or walking back backwards, whichever is cheaper
    v, w = 0.3, 0.5
    fwd, bwd = _level_power(base, vx=v) / v, _level_power(base, vx=-v) / v
    turn = _level_power(base, wz=w) * math.pi / w
    rt = reach(flat, base, (15.5, 15.5), round_trip=True)
    for dx, dy in OFFSETS:
        d = math.hypot(dx, dy)
        expected = 2 * d * fwd + min(turn, d * (bwd - fwd))
        assert _cell(flat, rt, dx, dy) == pytest.approx(expected, rel=1e-6)
    # headings free at the cell (two plans): both legs walk forwards, twice the one way
    legs = reach(flat, base, (15.5, 15.5), round_trip=True, turn_at_cell=False)
    for dx, dy in OFFSETS:
        d = math.hypot(dx, dy)
        assert _cell(flat, legs, dx, dy) == pytest.approx(2 * d * fwd, rel=1e-6)


def test_a_second_round_trip_of_the_same_problem_searches_the_kept_graph():
    """The lattice graph of a round trip is kept for the next one of the same model,
    request and start (the other ``turn_at_cell`` above reads it): the same energies as a
    graph built afresh; another model or start builds its own."""
    from energy_planner.planning import reach as reach_mod

    t = Terrain.from_function(lambda x, y: 0.05 * x, size=(9, 9))
    model = EnergyModel.default()
    reach(t, model, (4.5, 4.5), round_trip=True, turn_at_cell=False)
    kept = reach_mod._GRAPHS[t][3]
    again = reach(t, model, (4.5, 4.5), round_trip=True)
    assert reach_mod._GRAPHS[t][3] is kept
    reach_mod._GRAPHS.clear()
    fresh = reach(t, model, (4.5, 4.5), round_trip=True)
    built = reach_mod._GRAPHS[t][3]
    assert built is not kept
    np.testing.assert_array_equal(again.energy_j, fresh.energy_j)
    reach(t, EnergyModel.default(), (4.5, 4.5), round_trip=True)  # another model object
    assert reach_mod._GRAPHS[t][3] is not built
    reach(t, model, (3.5, 4.5), round_trip=True)  # another start
    assert reach_mod._GRAPHS[t][2][0] == (3.5, 4.5)


def _hill(x, y):
    return 6.0 * np.exp(-((x - X0 - 28.0) ** 2 + (y - Y0 - 26.0) ** 2) / (2 * 9.0**2))


@pytest.fixture(scope="module")
def hill_tif(tmp_path_factory):
    import rasterio
    from rasterio.transform import from_origin

    t = Terrain.from_function(_hill, size=(50, 50), origin=(X0, Y0))
    z = t.elevation.copy()
    z[40:45, 5:9] = np.nan  # a nodata hole (row 40 is 40 m south of the north edge)
    path = tmp_path_factory.mktemp("reach") / "hill.tif"
    with rasterio.open(
        path, "w", driver="GTiff", height=50, width=50, count=1, dtype="float64",
        crs="EPSG:32631", transform=from_origin(X0, Y0 + 50.0, 1.0, 1.0), nodata=-1.0,
    ) as dst:  # fmt: skip
        dst.write(np.where(np.isfinite(z), z, -1.0), 1)
    return path


def test_cells_on_the_budget_contour_cost_the_budget_when_planned(hill_tif):
    from energy_planner.planning.plan import plan
    from energy_planner.terrain import load_dem

    terrain = load_dem(hill_tif)
    model = EnergyModel.default()
    start = (X0 + 10.5, Y0 + 12.5)
    res = reach(terrain, model, start)
    budget = 0.6 * np.nanmax(res.energy_j)
    inside = res.mask(budget)
    # cells inside the budget with a neighbour outside it: the contour
    edge = inside & ~(
        np.roll(inside, 1, 0) & np.roll(inside, -1, 0) & np.roll(inside, 1, 1)
        & np.roll(inside, -1, 1)
    )  # fmt: skip
    edge[[0, -1], :] = edge[:, [0, -1]] = False
    rows, cols = np.nonzero(edge & (res.energy_j > 0.98 * budget))
    rng = np.random.default_rng(0)
    x0, y0, dx, dy = terrain.grid
    # two of the contour cells (the first two of the four drawn before): each cell's check
    # is the same (a plan by each planner, at the same tolerances), and a lattice plan of
    # this map is 1.5 s of CPU
    for k in rng.choice(rows.size, size=4, replace=False)[:2]:
        r, c = rows[k], cols[k]
        goal = (x0 + c * dx, y0 + r * dy)
        for planner in ("search", "lattice"):  # the default planner's search, the reference
            p = plan(terrain, model, res.start, goal, planner=planner, step=1.0, progress=False)
            if planner == "lattice":
                assert p.energy_j == pytest.approx(res.energy_j[r, c], rel=0.01)
            else:  # weighted A*: within its eps (DEFAULT_EPS) of the optimum
                assert 0.99 * res.energy_j[r, c] <= p.energy_j <= 1.05 * res.energy_j[r, c]
            assert p.energy_j == pytest.approx(budget, rel=0.03)


def test_return_equals_two_plans_on_the_hill_and_the_turn_round_is_bounded(hill_tif):
    from energy_planner.planning.lattice import lattice_headings
    from energy_planner.planning.plan import plan
    from energy_planner.problem import Problem
    from energy_planner.terrain import load_dem

    terrain = load_dem(hill_tif)
    model = EnergyModel.default()
    start = (X0 + 10.5, Y0 + 12.5)
    legs = reach(terrain, model, start, round_trip=True, turn_at_cell=False)
    rt = reach(terrain, model, start, round_trip=True)
    cost = Problem(terrain, model).cost
    th = lattice_headings(16)
    x0, y0, dx, dy = terrain.grid
    # cells over the hill, on its flank and near the nodata hole (row 40 = y0 + 40 dy)
    for r, c in [(10, 40), (25, 30), (38, 12)]:
        goal = (x0 + c * dx, y0 + r * dy)
        there = plan(terrain, model, legs.start, goal, planner="search", step=1.0)
        back = plan(terrain, model, goal, legs.start, planner="search", step=1.0)
        assert legs.energy_j[r, c] == pytest.approx(there.energy_j + back.energy_j, rel=0.01)
        # keeping the heading at the cell costs at most one half turn in place there
        half = max(
            min(
                sum(cost(*goal, th[(h + s * k) % 16], *goal, th[(h + s * (k + 1)) % 16])
                    for k in range(8))
                for s in (1, -1)
            )
            for h in range(16)
        )  # fmt: skip
        assert legs.energy_j[r, c] <= rt.energy_j[r, c] <= legs.energy_j[r, c] + half * 1.001


def test_reach_cli_writes_geotiff_geojson_and_plot(hill_tif, tmp_path):
    import rasterio
    from shapely.geometry import Point, shape

    tif, gj, png = tmp_path / "r.tif", tmp_path / "a.geojson", tmp_path / "r.png"
    args = ["reach", str(hill_tif), "--start", f"{X0 + 10.5},{Y0 + 12.5}", "--budget-wh", "3",
            "--out", str(tif), "--geojson", str(gj), "--plot", str(png), "--json"]  # fmt: skip
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    with rasterio.open(hill_tif) as src, rasterio.open(tif) as dst:
        assert dst.crs == src.crs and dst.transform == src.transform
        assert dst.shape == src.shape and np.isnan(dst.nodata) and np.isnan(NODATA)
        assert dst.units == ("J",) and dst.descriptions == ("energy_j",)  # GDAL band unit
        data = dst.read(1)
        dem = src.read(1, masked=True)
    assert np.isnan(data[dem.mask]).all()
    assert data[37, 10] == 0.0  # the start's cell (row 50 - 12.5 -> 37)
    # RFC 7946: longitude, latitude and no 'crs' member; back in UTM with pyproj
    fc = json.loads(gj.read_text())
    assert "crs" not in fc
    import pyproj
    from shapely.ops import transform as shp_transform

    ll = shape(fc["features"][0]["geometry"])
    assert -180 <= ll.bounds[0] <= ll.bounds[2] <= 180 and -90 <= ll.bounds[1] <= 90
    to_utm = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32631", always_xy=True).transform
    poly = shp_transform(to_utm, ll)
    assert poly.contains(Point(X0 + 10.5, Y0 + 12.5))
    within = np.isfinite(data) & (data <= 3 * 3600)
    assert fc["features"][0]["properties"]["cells"] == within.sum() == out["budget_cells"]
    assert poly.area == pytest.approx(within.sum() * 1.0, rel=1e-6)
    # --geojson-crs dem: the DEM's CRS, declared
    r = CliRunner().invoke(main, [*args, "--geojson-crs", "dem"])
    assert r.exit_code == 0, r.output
    fc = json.loads(gj.read_text())
    assert fc["crs"]["properties"]["name"] == "EPSG:32631"
    assert shape(fc["features"][0]["geometry"]).symmetric_difference(poly).area < 1e-5 * poly.area
    assert png.stat().st_size > 10_000
    assert out["round_trip"] is False and out["max_wh"] > 3


def test_reach_cli_errors(hill_tif):
    r = CliRunner().invoke(main, ["reach", str(hill_tif), "--start", "1,2"])
    assert r.exit_code == 2 and "--start" in r.output and "outside the map" in r.output
    r = CliRunner().invoke(
        main, ["reach", str(hill_tif), "--start", f"{X0 + 10},{Y0 + 10}", "--geojson", "a.json"]
    )
    assert r.exit_code == 2 and "--budget-wh" in r.output
    r = CliRunner().invoke(
        main, ["reach", str(hill_tif), "--start", f"{X0 + 10},{Y0 + 10}", "--free-turn"]
    )
    assert r.exit_code == 2 and "--return" in r.output


def test_the_edge_of_the_map_cutting_the_budget_area_is_a_named_warning(flat):
    """Level ground: the energy of a cell is at least distance x the level cost a (the
    cheapest J/m), and exactly that along a move direction. The valid cells nearest the
    edge (Horn leaves the outer ring without a slope) are the four at 14 m on the axes."""
    import warnings

    from energy_planner.errors import EnergyPlannerError, ReachEdgeWarning

    model = EnergyModel.default()
    a = _level_power(model, vx=0.3) / 0.3
    # 14.02 a: the four axis cells (14 a) are in; (14, 1) needs at least 14.036 a
    with pytest.warns(ReachEdgeWarning) as rec:
        res = reach(flat, model, (15.5, 15.5), max_energy=14.02 * a)
    (w,) = [r.message for r in rec if isinstance(r.message, ReachEdgeWarning)]
    assert isinstance(w, EnergyPlannerError) and isinstance(w, UserWarning)
    assert (w.cells, w.map_edge_cells, w.nodata_edge_cells) == (4, 4, 0)
    assert w.budget_j == pytest.approx(14.02 * a)
    assert "4 cells" in str(w) and "edge" in str(w)
    assert res.edge_cells(flat, 14.02 * a)["cells"] == 4
    # 13.5 a stops a metre short of every edge-adjacent cell: no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = reach(flat, model, (15.5, 15.5), max_energy=13.5 * a)
    assert res.edge_warning(flat, 13.5 * a) is None
    # the whole map: every cell of the valid ring (29 x 29 cells, border 4 * 28) touches
    whole = reach(flat, model, (15.5, 15.5))
    assert whole.edge_cells(flat, 1e12) == {"cells": 112, "map_edge_cells": 112,
                                            "nodata_edge_cells": 0}  # fmt: skip


def test_a_nodata_hole_cutting_the_budget_area_is_reported_as_nodata():
    """A hole of nodata 7 m east of the start: its slope-less ring starts 6 m east, so the
    first cell that touches it is (5, 0), at exactly 5 a; (5, +-1) need 5.099 a."""
    from energy_planner.errors import ReachEdgeWarning

    z = np.zeros((31, 31))
    z[14:17, 22:25] = np.nan
    t = Terrain.from_array(z, resolution=1.0)
    model = EnergyModel.default()
    a = _level_power(model, vx=0.3) / 0.3
    with pytest.warns(ReachEdgeWarning) as rec:
        reach(t, model, (15.5, 15.5), max_energy=5.02 * a)
    (w,) = [r.message for r in rec if isinstance(r.message, ReachEdgeWarning)]
    assert (w.cells, w.map_edge_cells, w.nodata_edge_cells) == (1, 0, 1)
    assert "nodata (1 cells)" in str(w)


def test_reach_cli_reports_the_cut_in_text_and_json(tmp_path):
    """A 21 m square of level ground and a budget that covers all of it."""
    import rasterio
    from rasterio.transform import from_origin

    path = tmp_path / "flat.tif"
    with rasterio.open(
        path, "w", driver="GTiff", height=21, width=21, count=1, dtype="float64",
        crs="EPSG:32631", transform=from_origin(X0, Y0 + 21.0, 1.0, 1.0),
    ) as dst:  # fmt: skip
        dst.write(np.zeros((21, 21)), 1)
    args = ["reach", str(path), "--start", f"{X0 + 10.5},{Y0 + 10.5}", "--budget-wh", "50"]
    r = CliRunner().invoke(main, [*args, "--json"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    # the valid ring of a 21 x 21 map: 19 x 19 cells, 4 * 18 on its border
    assert out["edge_cut"] == [{"budget_wh": 50.0, "cells": 72, "map_edge_cells": 72,
                                "nodata_edge_cells": 0}]  # fmt: skip
    assert len(out["warnings"]) == 1 and "72 cells" in out["warnings"][0]
    r = CliRunner().invoke(main, [*args, "--within-budget"])
    assert r.exit_code == 0, r.output
    assert r.output.count("72 cells reached within 50 Wh touch the map's edge") == 1
    assert "ReachEdgeWarning" not in r.output and "warnings.warn" not in r.output
    r = CliRunner().invoke(main, [*args[:-1], "0.1", "--json"])  # 0.1 Wh: about 5 m
    assert r.exit_code == 0, r.output
    assert "edge_cut" not in json.loads(r.stdout)
