"""The kernels' input tuple is read by name (``kernels.IN_*``), and the names fit it."""

from __future__ import annotations

import math

import numpy as np

from energy_planner.energy import MotionCost
from energy_planner.energy import kernels as k
from energy_planner.model import EnergyModel
from energy_planner.terrain import Terrain


def test_named_inputs_match_the_data_tuple():
    t = Terrain.from_function(lambda x, y: 0.1 * x, size=(20, 30), resolution=2.0)
    cost = MotionCost(
        t, EnergyModel.default(), 0.4, 0.6, max_slope_deg=30, max_crab_deg=20,
        max_backward_slope_deg=10,
    )  # fmt: skip
    d = cost.data
    assert len(d) == k.N_IN
    assert d[k.IN_GRAD].shape == (*t.dzdx.shape, 2)
    np.testing.assert_allclose(d[k.IN_GRAD][..., 0][np.isfinite(d[k.IN_GRAD][..., 0])], 0.1)
    assert (d[k.IN_X0], d[k.IN_Y0], d[k.IN_DX], d[k.IN_DY]) == t.grid
    assert (d[k.IN_SPEED], d[k.IN_YAW_RATE]) == (0.4, 0.6)
    assert math.isclose(d[k.IN_TMAX], math.tan(math.radians(30)))
    assert math.isclose(d[k.IN_BTAN], math.tan(math.radians(10)))
    assert math.isclose(d[k.IN_CMAX], math.radians(20))
    assert d[k.IN_CHAN].ndim == 3


def test_the_cost_reads_the_terrain_gradient_without_a_copy():
    """A Terrain's gradient is the kernels' input as it is; a terrain without ``grad``
    (a window, a test double) gets its two components stacked."""
    t = Terrain.from_function(lambda x, y: 0.1 * x + 0.05 * y, size=(20, 30), resolution=2.0)
    cost = MotionCost(t, EnergyModel.default(), 0.4, 0.6)
    assert cost.data[k.IN_GRAD] is t.grad

    class Bare:
        grid, dzdx, dzdy = t.grid, np.array(t.dzdx), np.array(t.dzdy)

    bare = MotionCost(Bare(), EnergyModel.default(), 0.4, 0.6).data[k.IN_GRAD]
    assert bare.flags.c_contiguous and bare is not t.grad
    np.testing.assert_array_equal(bare, t.grad)
