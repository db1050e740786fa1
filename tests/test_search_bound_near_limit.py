"""The search's bound next to a slope limit: still below the kernel, now close to it.

A walkable sample near the limit reads table nodes past it; those hold the heading cost
of the same physics without the slope limit (:func:`energy_planner.planning.search.
_past_the_limit`). The independent sides: the motion kernel itself for every edge, and
the built lattice searched by scipy's Dijkstra (:func:`lattice_plan`) for the optimum.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from energy_planner.energy.kernels import IN_STEP, IN_TMAX
from energy_planner.maps import map_path
from energy_planner.model import EnergyModel
from energy_planner.planning.lattice import lattice_plan
from energy_planner.planning.limits import make_motion_cost
from energy_planner.planning.search import (
    BOUND_MARGIN,
    _Grid,
    bound_table,
    search_module,
    search_plan,
)
from energy_planner.request import Request
from energy_planner.terrain import load_dem

#: the bundled hill's climb from the route of README.md, cut to a window (slopes to 47 deg)
WINDOW = (500040, 5000040, 500076, 5000090)
START, GOAL = (500058.0, 5000046.0, None), (500058.0, 5000084.0, None)


@pytest.fixture(scope="module")
def hill():
    return load_dem(map_path("hill"), bounds=WINDOW)


@pytest.mark.parametrize("limit", [40.0, 44.0])
def test_search_along_the_slope_limit_finds_the_lattice_optimum(hill, limit):
    """With ``eps = 1`` the search's cost is the built lattice's optimum (every edge
    priced up front, scipy's Dijkstra), so the bound stayed admissible; and ``h(start)``
    is within 7 % of it (the climb runs along the limit: with the nodes past the limit
    at ``inf`` it was 0.87 and 0.83 of it)."""
    cost, _ = make_motion_cost(hill, EnergyModel.default(), Request.make(max_slope_deg=limit))
    opt = search_plan(cost, hill, START, GOAL, eps=1.0)
    ref = lattice_plan(cost, hill, START, GOAL, step=1.0, moves="all")
    assert opt.cost == pytest.approx(ref.cost, rel=1e-5)  # float32 g-values
    h0 = opt.info["h_start"]
    assert h0 <= opt.cost * (1 + 1e-6)
    assert h0 >= 0.93 * opt.cost, (h0, opt.cost)


def test_edge_bound_next_to_the_limit_never_exceeds_the_kernel(hill):
    """Every translation from a cell within 4 degrees below a 40-degree limit costs at
    least its bound at every heading allowed to make it, and the bound there is read
    from the table (not its least, ``tmin``) for most of them."""
    limit = 40.0
    cost, _ = make_motion_cost(hill, EnergyModel.default(), Request.make(max_slope_deg=limit))
    grid = _Grid(cost, hill, START[:2], None, 16, "all")
    mod = search_module(cost)
    table, tgeo = bound_table(cost, grid.headings, grid.move_ok)
    tmin = table.min(axis=(1, 2)).astype(float)
    geo = np.array(cost.data[2:6], dtype=float)
    kstep, tmax = float(cost.data[IN_STEP]), float(cost.data[IN_TMAX])
    X, Y = np.meshgrid(grid.xs, grid.ys)
    slope = np.degrees(np.asarray(hill.sample(X.ravel(), Y.ravel()).slope)).reshape(X.shape)
    near = np.argwhere((slope > limit - 4) & (slope <= limit))
    near = near[(near[:, 0] >= 2) & (near[:, 0] < grid.ny - 2)]  # Horn needs neighbours
    near = near[(near[:, 1] >= 2) & (near[:, 1] < grid.nx - 2)]
    assert len(near) > 20
    checked = above_tmin = bounded = 0
    for j, i in near[:: max(1, len(near) // 40)]:
        xa, ya = grid.xs[i], grid.ys[j]
        for m, (di, dj) in enumerate(grid.moves):
            if not (0 <= i + di < grid.nx and 0 <= j + dj < grid.ny):
                continue
            xb, yb = grid.xs[i + di], grid.ys[j + dj]
            lb = mod.edge_bound(cost.data[0], *geo, kstep, tmax, xa, ya, xb, yb, table, tmin, m,
                                *tgeo)  # fmt: skip
            if not math.isfinite(lb):
                continue
            bounded += 1
            above_tmin += lb > 1.05 * tmin[m] * math.hypot(xb - xa, yb - ya)
            for h in np.nonzero(grid.move_ok[:, m])[0]:
                th = grid.headings[h]
                e = cost(xa, ya, th, xb, yb, th)
                assert BOUND_MARGIN * lb <= e * (1 + 1e-9), (m, h, lb, e)
                checked += math.isfinite(e)
    assert checked > 100
    assert above_tmin > 0.5 * bounded, (above_tmin, bounded)
