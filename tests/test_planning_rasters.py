"""The search's heuristic on maps with categorical channel rasters (``--channel
ground=RASTER:TABLE``): the least over the categories met on the map, still below every
edge the kernel prices and below the optimum the built lattice gives (scipy's Dijkstra on
every edge priced up front: an independent search of the same graph)."""

from __future__ import annotations

import numpy as np
import pytest
from _bounds import check_edge_bounds  # tests/ helper
from b1_model import B1, b1_model  # tests/ helper

from energy_planner.energy.channels import ChannelRaster, Channels
from energy_planner.planning.lattice import lattice_plan
from energy_planner.planning.limits import make_motion_cost
from energy_planner.planning.search import (
    _Grid,
    bound_table,
    search_plan,
)
from energy_planner.request import Request
from energy_planner.terrain import Terrain

#: extra N per m/s on each ground (asphalt is cheaper than the B1 base, mud dearer)
GROUND = {"asphalt": -150.0, "meadow": 0.0, "mud": 300.0}
MODEL = b1_model(B1, extra={f"speed * (ground == '{g}')": k for g, k in GROUND.items() if k})


def _ground(seed: int, shape, categories=("asphalt", "meadow", "mud"), size: int = 5):
    """Random square patches of ``size`` cells, each one of the first two categories (the
    third, ``mud``, is named by the raster but on no cell: the bound ignores it)."""
    rng = np.random.default_rng(seed)
    rows, cols = shape
    patches = rng.integers(0, 2, (rows // size + 1, cols // size + 1)).astype(float)
    values = np.kron(patches, np.ones((size, size)))[:rows, :cols]
    return Channels(rasters={"ground": ChannelRaster("ground", values=values,
                                                      categories=categories)})  # fmt: skip


def _problem(seed: int, size: int = 20):
    rng = np.random.default_rng(seed)
    tilt = rng.uniform(-0.25, 0.25, 2)
    t = Terrain.from_function(lambda x, y: tilt[0] * x + tilt[1] * y + 0.002 * x * y,
                              size=(size, size))  # fmt: skip
    ch = _ground(seed, t.shape)
    cost, _ = make_motion_cost(t, MODEL, Request.make(channels=ch))
    return t, cost


@pytest.mark.parametrize("seed", [0, 1])
def test_edge_bound_on_a_ground_raster_never_exceeds_the_kernel(seed):
    """Every translation at every heading allowed to make it costs at least its bound."""
    t, cost = _problem(seed)
    grid = _Grid(cost, t, (1.5, 2.5), None, 16, "all")
    table, _ = bound_table(cost, grid.headings, grid.move_ok)
    assert np.isfinite(table).any() and table.max() > 0  # a table, not the zero heuristic
    cells = [(2, 2), (grid.nx - 3, grid.ny - 3), (7, 12), (12, 5)]
    checked, _ = check_edge_bounds(cost, grid, cells)
    assert checked > 0


@pytest.mark.parametrize("seed", [0, 1])
def test_search_on_a_ground_raster_finds_the_lattice_optimum(seed):
    """``h(start)`` is below the optimum and above 0 (the search is no longer Dijkstra), and
    the search with ``eps = 1`` finds the lattice's optimum."""
    t, cost = _problem(seed)
    s, g = (2.5, 3.5, None), (17.5, 16.5, None)
    ref = lattice_plan(cost, t, s, g, step=1.0)
    opt = search_plan(cost, t, s, g, eps=1.0)
    assert opt.cost == pytest.approx(ref.cost, rel=1e-5)  # float32 g-values
    assert 0.5 * opt.cost < opt.info["h_start"] <= opt.cost * (1 + 1e-6)
