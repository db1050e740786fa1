"""The search's edge bound against the kernel's edge cost (the independent side), at
chosen lattice positions: shared by the tests of the heuristic's admissibility."""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from energy_planner.energy.kernels import IN_STEP, IN_TMAX
from energy_planner.planning.search import BOUND_MARGIN, bound_table, search_module


def check_edge_bounds(cost, grid, cells: Iterable[tuple[int, int]]) -> tuple[int, int]:
    """Assert that every move from each position ``(i, j)`` of ``grid`` costs at least
    its bound (``BOUND_MARGIN * edge_bound``), at every heading allowed to make it.

    Returns ``(checked, tight)``: the finite edge costs checked, and those whose bound is
    above half the cost (a bound of 0 would pass the check alone).
    """
    mod = search_module(cost)
    table, tgeo = bound_table(cost, grid.headings, grid.move_ok)
    tmin = table.min(axis=(1, 2)).astype(float)
    geo = np.array(cost.data[2:6], dtype=float)
    kstep, tmax = float(cost.data[IN_STEP]), float(cost.data[IN_TMAX])
    checked = tight = 0
    for i, j in cells:
        xa, ya = grid.xs[i], grid.ys[j]
        for m, (di, dj) in enumerate(grid.moves):
            if not (0 <= i + di < grid.nx and 0 <= j + dj < grid.ny):
                continue
            xb, yb = grid.xs[i + di], grid.ys[j + dj]
            lb = BOUND_MARGIN * mod.edge_bound(cost.data[0], *geo, kstep, tmax, xa, ya, xb, yb,
                                               table, tmin, m, *tgeo)  # fmt: skip
            for h in np.nonzero(grid.move_ok[:, m])[0]:
                th = grid.headings[h]
                e = cost(xa, ya, th, xb, yb, th)
                assert lb <= e * (1 + 1e-9), (m, h, lb, e)
                checked += math.isfinite(e)
                tight += math.isfinite(e) and lb > 0.5 * e
    return checked, tight
