"""The mission's energy matrix: early-stopped searches in a proven window, serial or on dask.

Each matrix is checked against an independent answer: the full search of every site
(:func:`energy_planner.planning.reach.reach`, Dijkstra over the whole map without a
goal, read at the other sites), and ``plan`` between the same poses.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely.geometry import box

from energy_planner.mission import Sites, energy_matrix
from energy_planner.mission import matrix as mx
from energy_planner.mission.matrix import matrix_search
from energy_planner.model import EnergyModel
from energy_planner.planning.plan import plan
from energy_planner.planning.reach import reach
from energy_planner.request import Request
from energy_planner.terrain import Terrain

#: float32 energies (and float32 edge prices) summed along different (equally cheap) paths
#: may differ in the last bits
RTOL = 1e-6


@pytest.fixture(scope="module")
def model():
    return EnergyModel.default()


@pytest.fixture(scope="module")
def knoll():
    """A 24 m x 24 m knoll, 3 m high, 1 m cells."""
    y, x = np.mgrid[0:24, 0:24]
    z = 3.0 * np.exp(-((x - 13.0) ** 2 + (y - 10.0) ** 2) / (2 * 4.0**2))
    return Terrain.from_array(z, resolution=1.0, origin=(0.0, 0.0))


@pytest.fixture(scope="module")
def tilted():
    """A 40 m x 40 m plane rising 5 % to the east, 1 m cells."""
    y, x = np.mgrid[0:40, 0:40]
    return Terrain.from_array(0.05 * x.astype(float), resolution=1.0, origin=(0.0, 0.0))


def _sites(terrain, pts) -> Sites:
    return Sites(np.asarray(pts, float), [f"s{i}" for i in range(len(pts))]).on_cells(terrain)


def _full_matrix(terrain, model, sites, request=None) -> np.ndarray:
    """The reference: one full reach (Dijkstra over the whole map) per site."""
    rc = sites.cells(terrain)
    E = np.array([reach(terrain, model, tuple(p), request).energy_j[rc[:, 0], rc[:, 1]]
                  for p in sites.xy])  # fmt: skip
    return np.where(np.isfinite(E), E, np.inf)


@settings(max_examples=2, deadline=None)
@given(st.lists(st.tuples(st.integers(3, 20), st.integers(3, 20)), min_size=2, max_size=3,
                unique=True))  # fmt: skip
def test_early_stopped_matrix_equals_the_full_search(knoll, model, cells):
    s = _sites(knoll, [(c + 0.0, r + 0.0) for c, r in cells])
    full = _full_matrix(knoll, model, s)
    for window, edges in ((True, None), (False, True)):
        res = matrix_search(knoll, model, s, window=window, edge_cache=edges)
        assert res.info["edges"] == ("table" if edges else "lazy")  # serial: the cache
        np.testing.assert_allclose(res.energy_j, full, rtol=RTOL)
        assert res.info["proven"]
        # early stop: fewer states than one full search per site
        assert res.info["expanded"] < res.info["states_total"]


@settings(max_examples=3, deadline=None)
@given(st.lists(st.tuples(st.integers(3, 20), st.integers(3, 20)), min_size=2, max_size=3,
                unique=True), st.sampled_from([1.05, 1.5]))  # fmt: skip
def test_weighted_matrix_is_within_eps_of_the_full_search(knoll, model, cells, eps):
    """The weighted A* bound, per target: optimum <= entry <= eps * optimum."""
    s = _sites(knoll, [(c + 0.0, r + 0.0) for c, r in cells])
    full = _full_matrix(knoll, model, s)
    res = matrix_search(knoll, model, s, eps=eps)
    assert not res.info["edge_table"] and res.info["proven"]
    E = res.energy_j
    np.testing.assert_array_equal(np.isfinite(E), np.isfinite(full))
    fin = np.isfinite(full) & (full > 0)
    assert np.all(E[fin] >= full[fin] * (1 - RTOL))
    assert np.all(E[fin] <= eps * full[fin] * (1 + RTOL))


def test_weighted_matrix_expands_fewer_states(tilted, model):
    """Across the tilted plane and back: eps > 1 expands fewer states for entries in bound."""
    s = _sites(tilted, [(4, 6), (35, 33), (6, 34)])
    full = _full_matrix(tilted, model, s)
    exact = matrix_search(tilted, model, s, window=False, edge_cache=False)
    weighted = matrix_search(tilted, model, s, window=False, eps=1.05)
    np.testing.assert_allclose(exact.energy_j, full, rtol=RTOL)
    assert weighted.info["expanded"] < exact.info["expanded"]
    off = ~np.eye(3, dtype=bool)
    ratio = weighted.energy_j[off] / full[off]
    assert np.all(ratio >= 1 - RTOL) and np.all(ratio <= 1.05 * (1 + RTOL))


def test_lazy_edge_cache_prices_each_state_once_and_keeps_the_optimum(knoll, model):
    """A cache filled as the rows expand states: the full search's matrix, fewer prices,
    and exactly the entries of the whole edge table (the same float32 kernel prices)."""
    s = _sites(knoll, [(3, 20), (13, 10), (20, 3), (4, 4)])
    full = _full_matrix(knoll, model, s)
    lazy = matrix_search(knoll, model, s, window=False)
    own = matrix_search(knoll, model, s, window=False, edge_cache=False)
    table = matrix_search(knoll, model, s, window=False, edge_cache=True)
    assert lazy.info["edges"] == "lazy" and own.info["edges"] == "on demand"
    assert table.info["edges"] == "table"
    np.testing.assert_array_equal(lazy.energy_j, table.energy_j)
    np.testing.assert_allclose(lazy.energy_j, full, rtol=RTOL)
    np.testing.assert_allclose(own.energy_j, full, rtol=RTOL)
    # each state's 18 edges at most once over the four rows; the rows alone price more
    assert lazy.info["priced"] <= 18 * lazy.info["states_total"]
    assert lazy.info["priced"] < own.info["priced"]
    assert lazy.info["expanded"] == own.info["expanded"]


def test_window_is_proven_smaller_than_the_map_and_exact(tilted, model, monkeypatch):
    monkeypatch.setattr(mx, "WINDOW_MIN_CELLS", 6)  # a small map: a narrow first window
    s = _sites(tilted, [(15, 15), (23, 17), (17, 23)])
    res = matrix_search(tilted, model, s)
    x0, y0, x1, y1 = res.info["window"]
    assert res.info["proven"] and not res.info["whole_map"] and res.info["passes"] == 1
    assert (x1 - x0) * (y1 - y0) < 0.5 * 39 * 39
    # the ellipse of every pair lies inside: no cheaper path can leave the window
    need = mx.window_proof(s.xy, res.energy_j, res.info["c_min_j_per_m"])
    assert need[0] >= x0 and need[1] >= y0 and need[2] <= x1 and need[3] <= y1
    np.testing.assert_allclose(res.energy_j, _full_matrix(tilted, model, s), rtol=RTOL)
    # uphill (east) costs more than downhill
    assert res.energy_j[0, 1] > res.energy_j[1, 0]


@pytest.mark.parametrize("wall_half", [2.0, 14.0])
def test_window_grows_around_a_wall(tilted, model, monkeypatch, wall_half):
    """A keep-out wall between two sites: the way round leaves the first window.

    A short wall: the window's path goes round it but its ellipse leaves the window, which
    grows to the ellipse's box. A long wall: no way round inside the first window, which
    becomes the whole map. Either way the second pass equals the full search.
    """
    monkeypatch.setattr(mx, "WINDOW_MIN_CELLS", 3)
    req = Request.make(keep_out=[box(19.4, 20 - wall_half, 20.6, 20 + wall_half)])
    s = _sites(tilted, [(15, 20), (25, 20)])
    res = matrix_search(tilted, model, s, req)
    assert res.info["passes"] == 2 and res.info["proven"]
    assert res.info["whole_map"] == (wall_half > 10)
    np.testing.assert_allclose(res.energy_j, _full_matrix(tilted, model, s, req), rtol=RTOL)


@pytest.mark.parametrize("eps", [1.0, 1.05])
def test_rows_agree_with_plan_within_one_percent(knoll, model, eps):
    s = _sites(knoll, [(3, 20), (13, 10), (20, 3)])
    E = energy_matrix(knoll, model, s, eps=eps)
    for a, b in [(0, 2), (2, 0), (0, 1)]:  # across the knoll both ways, and onto its top
        p = plan(knoll, model, tuple(s.xy[a]), tuple(s.xy[b]), planner="search", eps=1.0,
                 progress=False)  # fmt: skip
        assert E[a, b] == pytest.approx(p.energy_j, rel=0.01)


def test_sites_in_one_cell_share_a_row(knoll, model):
    s = _sites(knoll, [(3, 20), (3.2, 19.9), (20, 3)])
    E = energy_matrix(knoll, model, s)
    assert E[0, 1] == E[1, 0] == 0.0
    np.testing.assert_array_equal(E[0, 2], E[1, 2])
    np.testing.assert_array_equal(E[2, 0], E[2, 1])


def test_a_cluster_given_by_address_gives_the_serial_matrix(tmp_path, knoll, model):
    """The same code on a dask cluster reached by its scheduler's address (library and CLI)."""
    distributed = pytest.importorskip("distributed")
    from energy_planner.io import write_geotiff

    s = _sites(knoll, [(3, 20), (20, 3), (13, 10)])  # 2 workers: a batch of 2 rows
    serial = energy_matrix(knoll, model, s)
    dem = tmp_path / "knoll.tif"
    write_geotiff(dem, knoll.elevation, transform=knoll.transform, crs=knoll.crs)
    (tmp_path / "sites.csv").write_text("x,y,name\n" + "".join(
        f"{x},{y},s{k}\n" for k, (x, y) in enumerate(s.xy)))  # fmt: skip
    import dask

    with (
        dask.config.set(mx.CLUSTER_CONFIG),
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
        ) as cluster,
    ):  # the configuration docs/routes.md tells a cluster's user to set
        address = cluster.scheduler_address
        with distributed.Client(address) as client:
            par = energy_matrix(knoll, model, s, client=client)
            par_w = energy_matrix(knoll, model, s, client=client, eps=1.05)
            # the whole table priced by strips on the workers (dask's default for many sites)
            par_t = matrix_search(knoll, model, s, client=client, edge_cache=True)
        args = ["mission", "--dem", str(dem), "--sites", str(tmp_path / "sites.csv"),
                "--order", "given", "--scheduler", address, "--json"]  # fmt: skip
        r = CliRunner().invoke(__import__("energy_planner.cli", fromlist=["main"]).main, args)
    np.testing.assert_array_equal(serial, par)
    assert par_t.info["edges"] == "table"
    np.testing.assert_array_equal(serial, par_t.energy_j)
    # the weighted searches too: no edge table, each row priced on demand the same way
    np.testing.assert_array_equal(energy_matrix(knoll, model, s, eps=1.05), par_w)
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout[r.stdout.index("{") :])
    np.testing.assert_allclose(np.array(out["matrix_j"], float), serial, rtol=RTOL)


def test_cluster_config_names_dask_settings():
    """Every key of CLUSTER_CONFIG is one of dask's settings (a misspelt one does nothing)."""
    pytest.importorskip("distributed")
    import dask
    from dask.utils import parse_timedelta

    for key, value in mx.CLUSTER_CONFIG.items():
        default = dask.config.get(key)  # KeyError if dask has no such setting
        assert type(value) is type(default), key
        if isinstance(value, str):  # an interval
            assert parse_timedelta(value) > 0, key


def test_mission_command_takes_eps(tmp_path, knoll, model):
    """``mission --eps``: the weighted matrix and legs; below 1 a usage error (exit 2)."""
    from energy_planner.cli import main
    from energy_planner.io import write_geotiff

    s = _sites(knoll, [(3, 20), (20, 3), (13, 10)])
    dem = tmp_path / "knoll.tif"
    write_geotiff(dem, knoll.elevation, transform=knoll.transform, crs=knoll.crs)
    (tmp_path / "sites.csv").write_text("x,y,name\n" + "".join(
        f"{x},{y},s{k}\n" for k, (x, y) in enumerate(s.xy)))  # fmt: skip
    args = ["mission", "--dem", str(dem), "--sites", str(tmp_path / "sites.csv"), "--json"]
    r = CliRunner().invoke(main, [*args, "--eps", "1.05"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout[r.stdout.index("{") :])
    assert out["eps"] == 1.05
    np.testing.assert_allclose(np.array(out["matrix_j"], float),
                               energy_matrix(knoll, model, s, eps=1.05), rtol=RTOL)  # fmt: skip
    bad = CliRunner().invoke(main, [*args, "--eps", "0.5"])
    assert bad.exit_code == 2 and "--eps" in bad.output and "Traceback" not in bad.output


def test_relaxed_table_heuristics_equal_the_planner_s_relaxed_problem(knoll, model):
    """The shared relaxed edges give each site the planner's own bound (up to float32).

    The reference is :func:`~energy_planner.planning.search.relaxed_cost_to_go`, which prices
    every edge itself; a keep-out square and a slope limit make some edges refused. Strips
    of rows stacked in order are the whole table.
    """
    from energy_planner.planning.search import relaxed_cost_to_go, search_grid
    from energy_planner.problem import Problem

    req = Request.make(max_slope_deg=12.0, keep_out=[box(8.5, 14.5, 11.5, 17.5)])
    cost = Problem(knoll, model, req).cost
    cost.compile()
    s = _sites(knoll, [(3, 20), (20, 3), (13, 3)])
    grid = search_grid(cost, knoll, tuple(s.xy[0]), n_headings=16)
    table = mx.relaxed_table(cost, grid)
    strips = np.concatenate([mx.relaxed_table(cost, grid, r) for r in ((0, 7), (7, 8), (8, 24))])
    np.testing.assert_array_equal(strips, table)
    got = mx.relaxed_heuristics(grid, table, s.xy)
    for k, (x, y) in enumerate(s.xy):
        ref = relaxed_cost_to_go(cost, grid, grid.position(x, y, "target"))
        np.testing.assert_array_equal(np.isfinite(got[k]), np.isfinite(ref))
        assert (~np.isfinite(ref)).any()  # the keep-out and the limit cut some cells off
        fin = np.isfinite(ref)
        np.testing.assert_allclose(got[k][fin], ref[fin], rtol=RTOL, atol=1e-3)
