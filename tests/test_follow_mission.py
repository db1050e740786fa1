"""``mission --order best`` against brute force on a window of the bundled hill (issue 22)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import energy_planner as ep
from energy_planner.mission import Sites, mission
from energy_planner.terrain import Terrain


@pytest.fixture(scope="module")
def window():
    """A 30 m x 30 m window of maps/hill.tif (its flank: slopes up to about 30 deg)."""
    hill = ep.open_terrain(ep.map_path("hill"))
    x0, y0, dx, dy = hill.grid
    r0, c0, n = 70, 50, 30
    z = hill.elevation[r0 : r0 + n, c0 : c0 + n]
    west = x0 - dx / 2 + c0 * dx
    south = y0 - dy / 2 + (r0 + n) * dy  # dy < 0: rows go south
    return Terrain.from_array(z, resolution=dx, origin=(west, south), crs=hill.crs)


def _brute(E: np.ndarray) -> float:
    """Every order of sites 1..n-1 after site 0, and back: the least energy (independent)."""
    n = E.shape[0]
    best = math.inf
    for perm in itertools.permutations(range(1, n)):
        tour = (0, *perm, 0)
        best = min(best, sum(E[a, b] for a, b in itertools.pairwise(tour)))
    return best


@pytest.mark.parametrize("seed", [0])
def test_best_order_matches_brute_force_on_the_bundled_hill(window, seed):
    (xmin, ymin, xmax, ymax) = window.bounds
    rng = np.random.default_rng(seed)
    pts = np.column_stack([rng.uniform(xmin + 3, xmax - 3, 7), rng.uniform(ymin + 3, ymax - 3, 7)])
    sites = Sites(pts, [f"s{i}" for i in range(7)]).on_cells(window)
    # 8 headings keep the 7 searches and 7 leg plans quick; the order is what is tested
    res = mission(window, ep.load_model(), sites, order="best", return_to_start=True, n_headings=8)
    E = res.matrix_j
    assert np.all(np.isfinite(E)) and E[0, 1] != E[1, 0]  # asymmetric, all reachable
    assert res.info["matrix_energy_j"] == pytest.approx(_brute(E), rel=1e-9)
