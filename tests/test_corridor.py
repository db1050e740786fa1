"""Planning and reach on DEMs larger than the memory cap (``planning.corridor``).

The windows are checked against the whole-map answer on DEMs small enough to load whole,
with a memory cap set so that they are not: a proven window must give the whole map's
energy; an unproven one can only be dearer (its border is impassable); reach within a
budget must equal the whole map's reach cell by cell. The bounds behind the proof are
checked on their own: the ellipse's box analytically, ``c_min`` against the kernel's
energy of straight motions, the strip-wise gradient range against the whole Horn grid.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.cli import main
from energy_planner.errors import DEMError, InvalidStateError, RasterTooLargeError
from energy_planner.model import EnergyModel
from energy_planner.planning import corridor
from energy_planner.planning.corridor import (
    PLAN_BYTES_PER_CELL,
    ellipse_box,
    gradient_box,
    least_cost_per_metre,
    plan_in_corridor,
    raster_info,
    reach_in_window,
)
from energy_planner.planning.plan import plan
from energy_planner.planning.reach import reach
from energy_planner.terrain import load_dem

X0, Y0 = 500000.0, 5000000.0
N = 110


@pytest.fixture(scope="module")
def model():
    return EnergyModel.default()


@pytest.fixture(scope="module")
def bumpy_tif(tmp_path_factory):
    """A 110 x 110 m DEM of smooth bumps (1 m cells, UTM 31N), slopes up to ~25 deg."""
    import rasterio
    from rasterio.transform import from_origin

    yy, xx = np.mgrid[0:N, 0:N].astype(float)
    z = (
        6.0 * np.sin(xx / 13.0) * np.cos(yy / 17.0)
        + 0.08 * yy
        + 4.0 * np.exp(-((xx - 55) ** 2 + (yy - 60) ** 2) / 200.0)
    )
    path = tmp_path_factory.mktemp("corridor") / "bumpy.tif"
    with rasterio.open(
        path, "w", driver="GTiff", height=N, width=N, count=1, dtype="float32",
        crs="EPSG:32631", transform=from_origin(X0, Y0 + N, 1.0, 1.0),
    ) as dst:  # fmt: skip
        dst.write(z.astype(np.float32), 1)
    return path


START = (X0 + 20.5, Y0 + 25.5)
GOAL = (X0 + 70.5, Y0 + 80.5)


def _cap(cells: int) -> int:
    return cells * PLAN_BYTES_PER_CELL


@pytest.fixture(scope="module")
def whole(bumpy_tif, model):
    return plan(load_dem(bumpy_tif), model, START, GOAL, planner="search", eps=1.0,
                progress=False)  # fmt: skip


def test_a_proven_window_gives_the_whole_maps_energy(bumpy_tif, model, whole):
    res, terrain = plan_in_corridor(
        bumpy_tif, model, START, GOAL, planner="search", eps=1.0, cap=_cap(105 * 105)
    )
    c = res.info["corridor"]
    assert c["proven"]
    assert terrain.shape[0] * terrain.shape[1] < N * N  # never the whole DEM
    assert res.energy_j == pytest.approx(whole.energy_j, rel=1e-9)
    # the proof: the path is shorter than the bound, the ellipse inside the last window
    assert res.distance_m <= c["length_bound_m"]
    e, w = c["ellipse_bounds"], c["windows"][-1]["bounds"]
    e = [max(e[0], X0), max(e[1], Y0), min(e[2], X0 + N), min(e[3], Y0 + N)]  # the DEM's part
    assert w[0] <= e[0] and w[1] <= e[1] and e[2] <= w[2] and e[3] <= w[3]


def test_an_unproven_window_is_never_cheaper_and_says_so(bumpy_tif, model, whole, tmp_path):
    res, terrain = plan_in_corridor(
        bumpy_tif, model, START, GOAL, planner="search", eps=1.0, cap=_cap(70 * 75)
    )
    c = res.info["corridor"]
    assert not c["proven"]
    assert res.energy_j >= whole.energy_j * (1 - 1e-9)
    x0, y0, x1, y1 = terrain.bounds
    assert np.all((res.states[:, 0] > x0) & (res.states[:, 0] < x1))
    assert np.all((res.states[:, 1] > y0) & (res.states[:, 1] < y1))
    assert any("NOT proven" in line for line in c["log"])
    # a ROS bag of a plan by windows is in the whole DEM's frame, not its window's
    assert (x0, y0) != (X0, Y0)
    assert res.write_bag(tmp_path / "bag", terrain)["origin"] == [X0, Y0, 0.0]
    assert whole.write_bag(tmp_path / "whole", load_dem(bumpy_tif))["origin"] == [X0, Y0, 0.0]


def test_the_start_goal_box_must_fit_the_cap(bumpy_tif, model):
    with pytest.raises(RasterTooLargeError, match="box of the start and the goal") as ei:
        plan_in_corridor(bumpy_tif, model, START, GOAL, cap=_cap(40 * 40))
    assert isinstance(ei.value, MemoryError) and ei.value.cap_bytes == _cap(40 * 40)
    with pytest.raises(InvalidStateError, match="outside DEM") as ei:
        plan_in_corridor(bumpy_tif, model, (X0 - 5, Y0 + 5), GOAL, cap=_cap(100 * 100))
    assert ei.value.endpoint == "start"


@settings(max_examples=60, deadline=None)
@given(
    st.floats(-50, 50), st.floats(-50, 50), st.floats(-50, 50), st.floats(-50, 50),
    st.floats(1.0, 3.0), st.floats(0, 2 * math.pi),
)  # fmt: skip
def test_the_ellipse_box_holds_the_ellipse_and_touches_it(sx, sy, gx, gy, k, t):
    d = math.hypot(gx - sx, gy - sy)
    length = max(k * d, 1e-3)
    box = ellipse_box((sx, sy), (gx, gy), length)
    # points of the ellipse |sp| + |pg| = length, by angle about the centre
    a = 0.5 * length
    f = 0.5 * d
    b = math.sqrt(max(a * a - f * f, 0.0))
    th = math.atan2(gy - sy, gx - sx)
    ts = np.linspace(0, 2 * math.pi, 721)
    ex = 0.5 * (sx + gx) + a * np.cos(ts) * math.cos(th) - b * np.sin(ts) * math.sin(th)
    ey = 0.5 * (sy + gy) + a * np.cos(ts) * math.sin(th) + b * np.sin(ts) * math.cos(th)
    tol = 1e-9 * (1 + length)
    assert np.all(ex >= box[0] - tol) and np.all(ex <= box[2] + tol)
    assert np.all(ey >= box[1] - tol) and np.all(ey <= box[3] + tol)
    # and the box is tight (touched within the sampling's resolution)
    assert ex.min() - box[0] <= 1e-4 * length + tol and box[2] - ex.max() <= 1e-4 * length + tol


def test_c_min_bounds_the_energy_per_metre_of_straight_motions(bumpy_tif, model):
    from energy_planner.energy import path_energy
    from energy_planner.planning.limits import make_motion_cost

    terrain = load_dem(bumpy_tif)
    cost, _ = make_motion_cost(terrain, model)
    lo, hi, _ = gradient_box(raster_info(bumpy_tif))
    c_min = least_cost_per_metre(cost, lo, hi)
    assert c_min > 0
    rng = np.random.default_rng(3)
    ratios = []
    for _ in range(40):
        p = X0 + 5 + rng.uniform(0, N - 10, 2), Y0 + 5 + rng.uniform(0, N - 10, 2)
        xy = np.column_stack([p[0], p[1]])
        yaw = rng.uniform(-math.pi, math.pi)  # any facing: crab, backward, forward
        pe = path_energy(terrain, model, xy, yaw=np.array([yaw, yaw]))
        ratios.append(pe.energy_j / pe.distance_m)
    assert min(ratios) >= c_min


def test_the_gradient_range_read_in_strips_equals_the_whole_grid(bumpy_tif, monkeypatch):
    monkeypatch.setattr(corridor, "STRIP_CELLS", 7 * N)  # 8-row strips: many seams
    lo, hi, valid = gradient_box(raster_info(bumpy_tif))
    t = load_dem(bumpy_tif)
    np.testing.assert_array_equal(lo, [np.nanmin(t.dzdx), np.nanmin(t.dzdy)])
    np.testing.assert_array_equal(hi, [np.nanmax(t.dzdx), np.nanmax(t.dzdy)])
    assert valid == int(np.isfinite(t.dzdx).sum())


def test_reach_in_a_window_equals_the_whole_maps_reach_within_the_budget(bumpy_tif, model):
    budget = 5.0 * 3600.0
    start = (X0 + 55.0, Y0 + 50.0)  # on a cell corner: the same cell in every window
    res, terrain = reach_in_window(bumpy_tif, model, start, budget, cap=_cap(80 * 80))
    w = res.info["window"]
    assert terrain.shape[0] * terrain.shape[1] < N * N
    full_t = load_dem(bumpy_tif)
    full = reach(full_t, model, start)
    assert res.start == full.start
    # the search stopped at the budget is exact within it
    bounded = reach(full_t, model, start, max_energy=budget)
    np.testing.assert_array_equal(bounded.energy_j <= budget, full.energy_j <= budget)
    ok = full.energy_j <= budget
    np.testing.assert_allclose(bounded.energy_j[ok], full.energy_j[ok], rtol=1e-12)
    # the window's cells in the whole map's grid
    r0 = round((full_t.bounds[3] - terrain.bounds[3]) / 1.0)
    c0 = round((terrain.bounds[0] - full_t.bounds[0]) / 1.0)
    sub = full.energy_j[r0 : r0 + terrain.shape[0], c0 : c0 + terrain.shape[1]]
    within = sub <= budget
    assert within.sum() > 500
    np.testing.assert_array_equal(res.energy_j <= budget, within)
    np.testing.assert_allclose(res.energy_j[within], sub[within], rtol=1e-12)
    # and no cell of the whole map outside the window is within the budget
    outside = np.ones_like(full.energy_j, bool)
    outside[r0 : r0 + terrain.shape[0], c0 : c0 + terrain.shape[1]] = False
    assert not np.any(full.energy_j[outside] <= budget)
    assert w["radius_m"] == pytest.approx(budget / w["c_min_j_per_m"])


def test_cli_plans_and_reaches_by_windows_and_says_so(bumpy_tif):
    runner = CliRunner()
    args = ["plan", "--dem", str(bumpy_tif), "--start", f"{START[0]},{START[1]}",
            "--goal", f"{GOAL[0]},{GOAL[1]}", "--memory-cap", str(_cap(105 * 105))]  # fmt: skip
    r = runner.invoke(main, args)
    assert r.exit_code == 0, r.output
    assert "read by windows" in r.output and "proven to hold every cheaper path" in r.output
    r = runner.invoke(main, [*args, "--json"])
    out = json.loads(r.stdout)
    assert out["corridor"]["proven"] is True and out["corridor"]["dem_shape"] == [N, N]
    # reach: a budget is needed to bound the window
    rargs = ["reach", str(bumpy_tif), "--start", f"{X0 + 55},{Y0 + 50}", "--memory-cap",
             str(_cap(80 * 80))]  # fmt: skip
    r = runner.invoke(main, rargs)
    assert r.exit_code == 2 and "--budget-wh" in r.output
    r = runner.invoke(main, [*rargs, "--budget-wh", "5", "--json"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert out["window"]["shape"][0] < N and out["max_wh"] <= 5.0
    # a budget whose window passes the cap names the budget that fits
    r = runner.invoke(main, [*rargs, "--budget-wh", "60"])
    assert r.exit_code == 2 and "a budget of at most" in r.output and "--budget-wh" in r.output
    r = runner.invoke(main, [*args[:-1], "12x"])
    assert r.exit_code == 2 and "--memory-cap" in r.output


def test_a_geographic_dem_over_the_cap_is_refused_with_the_warp_to_use():
    from energy_planner.maps import map_path

    with pytest.raises(DEMError, match="gdalwarp -t_srs EPSG:326") as ei:
        raster_info(map_path("jacksboro"))
    assert isinstance(ei.value, ValueError)
