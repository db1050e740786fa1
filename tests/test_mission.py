"""Missions (``energy_planner.mission`` and ``energy-planner mission``).

Checked against independent answers: the exact order against brute force over every
permutation, the one-search-per-site matrix against ``plan`` between the same poses, and
a dask cluster against the serial loop.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from energy_planner.cli import main
from energy_planner.mission import (
    Sites,
    brute_force,
    energy_matrix,
    held_karp,
    mission,
    order_sites,
    read_sites,
    settle_order,
)
from energy_planner.model import EnergyModel
from energy_planner.planning.plan import plan
from energy_planner.terrain import Terrain


@settings(max_examples=60, deadline=None)
@given(
    st.integers(2, 7).flatmap(
        lambda n: arrays(float, (n, n), elements=st.floats(0.5, 100, allow_nan=False))
    ),
    st.booleans(),
)
def test_held_karp_equals_brute_force(E, ret):
    o1, c1 = held_karp(E, ret)
    o2, c2 = brute_force(E, ret)
    assert c1 == pytest.approx(c2, rel=1e-12)
    assert o1[0] == 0 and sorted(o1) == list(range(len(E)))
    legs = list(zip(o1[:-1], o1[1:], strict=True)) + ([(o1[-1], 0)] if ret else [])
    assert sum(E[a, b] for a, b in legs) == pytest.approx(c1, rel=1e-12)


@settings(max_examples=60, deadline=None)
@given(
    st.integers(2, 7).flatmap(
        lambda n: st.tuples(
            arrays(float, (n, n), elements=st.floats(0.5, 100, allow_nan=False)),
            arrays(float, (n, n), elements=st.floats(1.0, 1.1, allow_nan=False)),
        )
    ),
    st.booleans(),
)
def test_settled_order_is_the_best_on_the_true_legs(mats, ret):
    # bounds below the true legs (true / eps, eps up to 1.1): pricing only the legs the
    # bounds point to ends on an order brute force over the true legs cannot beat
    true, eps = mats
    calls = []

    def price(a, b):
        calls.append((a, b))
        return true[a, b]

    s = settle_order(true / eps, price, ret)
    _, best = brute_force(true, ret)
    assert s.proven and s.energy == pytest.approx(best, rel=1e-12)
    legs = list(zip(s.order[:-1], s.order[1:], strict=True)) + ([(s.order[-1], 0)] if ret else [])
    assert all(leg in s.priced for leg in legs) and len(set(calls)) == len(calls)
    assert s.energy == pytest.approx(sum(true[a, b] for a, b in legs), rel=1e-12)


def test_many_sites_use_a_solver_and_beat_the_given_order():
    rng = np.random.default_rng(3)
    E = rng.uniform(1, 10, (18, 18))
    o, c, method = order_sites(E, "best", True, time_limit_s=1)
    assert "not proven" in method and sorted(o) == list(range(18))
    assert c < order_sites(E, "given", True)[1]


@pytest.fixture(scope="module")
def hill():
    """A 40 m x 40 m Gaussian hill, 6 m high, 1 m cells."""
    y, x = np.mgrid[0:40, 0:40]
    z = 6.0 * np.exp(-((x - 22.0) ** 2 + (y - 18.0) ** 2) / (2 * 7.0**2))
    return Terrain.from_array(z, resolution=1.0, origin=(0.0, 0.0))


@pytest.fixture(scope="module")
def model():
    return EnergyModel.default()


def _sites(hill, pts):
    return Sites(np.asarray(pts, float), [f"s{i}" for i in range(len(pts))]).on_cells(hill)


def test_matrix_is_asymmetric_and_agrees_with_plan(hill, model):
    s = _sites(hill, [(4.5, 35.5), (22.5, 21.5), (35.5, 6.5)])
    E = energy_matrix(hill, model, s)
    assert np.all(np.isfinite(E)) and np.all(np.diag(E) == 0)
    # the hilltop costs more to reach than to leave
    assert E[0, 1] > 1.2 * E[1, 0]
    for a, b in [(0, 1), (1, 0), (1, 2)]:
        p = plan(hill, model, tuple(s.xy[a]), tuple(s.xy[b]), planner="search", eps=1.0,
                 progress=False)  # fmt: skip
        assert E[a, b] == pytest.approx(p.energy_j, rel=0.01)


def test_best_order_on_a_map_matches_brute_force_and_legs_match_plan(hill, model):
    rng = np.random.default_rng(7)
    pts = rng.uniform(3, 37, (7, 2))
    given = Sites(pts, [f"s{i}" for i in range(len(pts))])
    res = mission(hill, model, given, order="best", return_to_start=True)
    _, best = brute_force(res.matrix_j, True)
    assert res.info["matrix_energy_j"] == pytest.approx(best, rel=1e-9)
    assert len(res.legs) == 7
    for leg in res.legs:
        # planned as `plan` plans it from the given sites (the search at eps 1.05, then
        # refined off its motions); the matrix: the optimal search between the sites'
        # cell centres (up to 0.7 m away on legs of 10-30 m): close, not equal
        assert leg.energy_j == pytest.approx(leg.matrix_energy_j, rel=0.15)
    for leg in res.legs[:2]:  # the same leg asked of `plan`
        p = plan(hill, model, tuple(pts[leg.a]), tuple(pts[leg.b]), progress=False)
        assert leg.energy_j == pytest.approx(p.energy_j, rel=0.005)
    assert res.energy_j == pytest.approx(sum(leg.energy_j for leg in res.legs))
    # a battery between the energy spent after leg k and after leg k + 1 (the widest gap)
    cum = np.cumsum([leg.energy_j for leg in res.legs])
    k = int(np.argmax(cum[1:] / cum[:-1]))
    assert cum[k + 1] / cum[k] > 1.1
    usable_wh = np.sqrt(cum[k] * cum[k + 1]) / 3600.0
    b = res.battery_by_leg(model, battery_wh=usable_wh + 1.0, reserve_wh=1.0, confidence=0.9)
    p = [leg["probability"] for leg in b["legs"]]
    assert all(x >= y for x, y in zip(p, p[1:], strict=False))
    assert b["reserve_crossed_at"] == k + 1 and p[k] > 0.9 and p[k + 1] < 0.1


def test_mission_legs_are_plans_and_its_order_the_best_on_plans_legs(hill, model):
    # the matrix at eps 1.05 only bounds the legs; each leg the mission reports is within
    # 0.5 % of `plan` asked for it, and no order of plan's own legs (every pair planned
    # here, independently) beats the mission's order by more than that
    rng = np.random.default_rng(11)
    pts = rng.uniform(3, 37, (5, 2))
    res = mission(hill, model, Sites(pts, [f"s{i}" for i in range(5)]), eps=1.05,
                  return_to_start=True)  # fmt: skip
    P = np.zeros((5, 5))
    for a in range(5):
        for b in range(5):
            if a != b:
                P[a, b] = plan(hill, model, tuple(pts[a]), tuple(pts[b]), progress=False).energy_j
    for leg in res.legs:
        assert leg.energy_j == pytest.approx(P[leg.a, leg.b], rel=0.005)
    _, best = brute_force(P, True)
    assert res.energy_j <= best * 1.005
    check = res.info["order_check"]
    assert check["proven"] and check["bound_j"] == pytest.approx(res.energy_j, rel=1e-9)
    assert 5 <= check["legs_planned"] <= 15


def test_dask_cluster_gives_the_serial_matrix_and_shares_the_edges(hill, model, monkeypatch):
    # the serial matrix on two workers; the two batches of rows sharing each round's new
    # edges price fewer than two caches kept apart (all the rows in one round)
    distributed = pytest.importorskip("distributed")
    from energy_planner.mission import matrix

    s = _sites(hill, [(4.5, 35.5), (22.5, 21.5), (35.5, 6.5), (10.5, 10.5)])
    s5 = _sites(hill, [(4.5, 35.5), (22.5, 21.5), (35.5, 6.5), (10.5, 10.5), (30.5, 30.5)])
    serial = energy_matrix(hill, model, s)
    serial5 = matrix.matrix_search(hill, model, s5, window=False)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:  # fmt: skip
        with distributed.Client(cluster) as client:
            par = energy_matrix(hill, model, s, client=client)
            shared = matrix.matrix_search(hill, model, s5, window=False, client=client)
            monkeypatch.setattr(matrix, "ROWS_PER_ROUND", 10)
            apart = matrix.matrix_search(hill, model, s5, window=False, client=client)
            assert not matrix._BATCHES  # freed on the workers (one process here)
    np.testing.assert_array_equal(serial, par)
    np.testing.assert_array_equal(serial5.energy_j, shared.energy_j)
    np.testing.assert_array_equal(serial5.energy_j, apart.energy_j)
    assert serial5.info["priced"] <= shared.info["priced"] < apart.info["priced"]


def test_cli_mission_reads_lonlat_geojson_sites(tmp_path, hill):
    from energy_planner.io import write_geojson, write_geotiff

    dem = tmp_path / "hill.tif"
    write_geotiff(dem, hill.elevation, transform=hill.transform, crs=hill.crs)
    from shapely.geometry import Point

    pts = [(5.5, 34.5), (30.5, 30.5), (20.5, 6.5)]
    write_geojson(tmp_path / "sites.geojson",
                  [(Point(p), {"name": n}) for p, n in zip(pts, "abc", strict=True)],
                  crs=hill.crs)  # fmt: skip
    doc = json.loads((tmp_path / "sites.geojson").read_text())
    assert "crs" not in doc  # RFC 7946 lon/lat
    args = ["mission", "--dem", str(dem), "--sites", str(tmp_path / "sites.geojson"),
            "--order", "given", "--json", "--geojson", str(tmp_path / "out.geojson")]  # fmt: skip
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout[r.stdout.index("{") :])
    assert out["order"] == ["a", "b", "c"] and len(out["legs"]) == 2
    sites = read_sites(tmp_path / "sites.geojson", hill)
    np.testing.assert_allclose(sites.xy, pts, atol=1e-3)  # lon/lat read back to the grid
    assert out["energy_j"] == pytest.approx(sum(leg["energy_j"] for leg in out["legs"]))


def test_cli_mission_bad_sites(tmp_path):
    (tmp_path / "s.csv").write_text("a,b\n1,2\n")
    r = CliRunner().invoke(main, ["mission", "--dem", "maps/plane.tif", "--sites",
                                  str(tmp_path / "s.csv")])  # fmt: skip
    assert r.exit_code == 1 and "x,y" in r.output  # the file is there: bad content, data
