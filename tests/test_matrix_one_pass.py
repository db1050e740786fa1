"""The matrix's window passes: one pass when its proof holds, a second one that prices once.

When the first window's proof fails, the second pass copies the edges the first one
priced inside it (:func:`energy_planner.mission.matrix._carry_cache`). The copied rows are
checked against the kernel's own prices on the grown window
(:func:`energy_planner.planning.search.edge_table`), and the matrices against the whole
map's (``window=False``) and against a second pass that prices every edge again.
"""

from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import box

from energy_planner.mission import Sites
from energy_planner.mission import matrix as mx
from energy_planner.mission.matrix import matrix_search
from energy_planner.model import EnergyModel
from energy_planner.planning import search
from energy_planner.request import Request
from energy_planner.terrain import Terrain

#: float32 energies summed along different (equally cheap) paths may differ in the last bits
RTOL = 1e-6


@pytest.fixture(scope="module")
def model():
    return EnergyModel.default()


@pytest.fixture(scope="module")
def knoll():
    """A 30 m x 30 m knoll, 3 m high, 1 m cells."""
    y, x = np.mgrid[0:30, 0:30]
    z = 3.0 * np.exp(-((x - 15.0) ** 2 + (y - 13.0) ** 2) / (2 * 4.0**2))
    return Terrain.from_array(z, resolution=1.0, origin=(0.0, 0.0))


@pytest.fixture(scope="module")
def tilted():
    """A 40 m x 40 m plane rising 5 % to the east, 1 m cells."""
    y, x = np.mgrid[0:40, 0:40]
    return Terrain.from_array(0.05 * x.astype(float), resolution=1.0, origin=(0.0, 0.0))


def _sites(terrain, pts) -> Sites:
    return Sites(np.asarray(pts, float), [f"s{i}" for i in range(len(pts))]).on_cells(terrain)


def test_a_proven_first_window_is_the_only_pass(tilted, model, monkeypatch):
    monkeypatch.setattr(mx, "WINDOW_MIN_CELLS", 6)
    s = _sites(tilted, [(15, 15), (23, 17), (17, 23)])
    res = matrix_search(tilted, model, s)
    assert res.info["passes"] == 1 and res.info["proven"] and not res.info["whole_map"]
    assert res.info["carried"] == 0
    # the proof itself: every pair's ellipse inside the window searched
    need = mx.window_proof(s.xy, res.energy_j, res.info["c_min_j_per_m"])
    x0, y0, x1, y1 = res.info["window"]
    assert need[0] >= x0 and need[1] >= y0 and need[2] <= x1 and need[3] <= y1
    whole = matrix_search(tilted, model, s, window=False)
    np.testing.assert_allclose(res.energy_j, whole.energy_j, rtol=RTOL)


@pytest.mark.parametrize("wall_half", [2.0, 14.0])
def test_a_second_pass_prices_only_new_edges_and_gives_the_whole_maps_matrix(
    tilted, model, monkeypatch, wall_half
):
    """A keep-out wall between two sites: the first window is refused. Short wall: the way
    round's ellipse leaves it, and the second pass takes the first one's edges. Long wall:
    no way round in it even in the relaxed problem, so its searches expand nothing (and
    hand nothing on); the second pass is the whole map."""
    monkeypatch.setattr(mx, "WINDOW_MIN_CELLS", 3)
    req = Request.make(keep_out=[box(19.4, 20 - wall_half, 20.6, 20 + wall_half)])
    s = _sites(tilted, [(15, 20), (25, 20)])
    res = matrix_search(tilted, model, s, req)
    short = wall_half < 10
    assert res.info["passes"] == 2 and res.info["proven"] and res.info["whole_map"] != short
    assert (res.info["carried"] > 0) == short
    whole = matrix_search(tilted, model, s, req, window=False)
    np.testing.assert_allclose(res.energy_j, whole.energy_j, rtol=RTOL)
    # the same passes pricing every edge again: the same entries, more edges priced
    monkeypatch.setattr(mx, "_carry_cache", lambda *a: 0)
    again = matrix_search(tilted, model, s, req)
    assert again.info["passes"] == 2 and again.info["carried"] == 0
    np.testing.assert_array_equal(res.energy_j, again.energy_j)
    assert res.info["expanded"] == again.info["expanded"]
    if short:
        assert res.info["priced"] < again.info["priced"]
    else:
        assert res.info["priced"] == again.info["priced"]


def test_carried_rows_are_the_kernels_prices_on_the_grown_window(knoll, model):
    """Every copied entry equals the edge table of the grown window, bit for bit; the
    moves the first window cut (off its lattice) were never priced there, and the grown
    window prices them."""
    anchor = (14.0, 12.0)
    small, big = (8.0, 6.0, 22.0, 19.0), (2.0, 1.0, 28.0, 27.0)
    cost, g1 = mx._setup(knoll, model, Request(), 16, small, anchor)
    _, g2 = mx._setup(knoll, model, Request(), 16, big, anchor)
    c1 = search.edge_cache(g1)
    xy = np.array([[10.0, 8.0], [20.0, 17.0], [14.0, 12.0]])
    heur = search.target_heuristics(cost, g1, xy)
    for p in xy:
        search.targets_search(cost, g1, tuple(p), xy, heur, cache=c1)
    c2 = search.edge_cache(g2)
    n = mx._carry_cache(g1, c1, g2, c2)
    table = search.edge_table(cost, g2)
    got = np.nonzero(c2[1])[0]
    assert got.size == n == np.count_nonzero(c1[1]) > 0
    K = table.shape[1]
    bits = ((c2[1][got, None] >> np.arange(K, dtype=np.uint32)) & 1) == 1
    np.testing.assert_array_equal(c2[0][got][bits], table[got][bits])
    # the translations of the priced states that leave the first window: no bit there
    H = g1.H
    old = np.nonzero(c1[1])[0]
    j, i = np.divmod(old // H, g1.nx)
    m = g1.moves_of[old % H]
    i2 = i[:, None] + g1.moves[m, 0]
    j2 = j[:, None] + g1.moves[m, 1]
    off = (m >= 0) & ((i2 < 0) | (j2 < 0) | (i2 >= g1.nx) | (j2 >= g1.ny))
    priced = ((c1[1][old, None] >> np.arange(m.shape[1], dtype=np.uint32)) & 1) == 1
    assert off.any() and not (priced & off).any()
    shift = (int(g1.ys[0] - g2.ys[0]) + j) * g2.nx + int(g1.xs[0] - g2.xs[0]) + i
    assert np.isfinite(table[shift * H + old % H][:, : m.shape[1]][off]).any()
