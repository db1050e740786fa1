"""Bilinear sampling: exact on planes, NaN outside and near holes, grid contract."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.terrain import Terrain, TerrainSample


def _plane_terrain(g=0.3, psi=0.7, res=(2.0, 0.5), origin=(1000.0, 2000.0)):
    def f(x, y):
        return 50.0 + g * ((x - origin[0]) * math.cos(psi) + (y - origin[1]) * math.sin(psi))

    rows, cols = 30, 20
    xr, yr = res
    x = origin[0] + (np.arange(cols) + 0.5) * xr
    y = origin[1] + (rows - np.arange(rows) - 0.5) * yr
    xx, yy = np.meshgrid(x, y)
    return Terrain.from_array(f(xx, yy), resolution=res, origin=origin), f


@settings(max_examples=60, deadline=None)
@given(u=st.floats(0.0, 1.0), v=st.floats(0.0, 1.0), psi=st.floats(-math.pi, math.pi))
def test_bilinear_is_exact_on_a_plane(u, v, psi):
    t, f = _plane_terrain(psi=psi)
    left, bottom, right, top = t.bounds
    # gradient is valid from the 2nd to the penultimate centre: stay in that rectangle
    x0, y0, dx, dy = t.grid
    rows, cols = t.shape
    x = x0 + dx * (1 + u * (cols - 3))
    y = y0 + dy * (1 + v * (rows - 3))
    s = t.sample(x, y)
    assert isinstance(s, TerrainSample) and isinstance(s.elevation, float)
    assert math.isclose(s.elevation, f(x, y), abs_tol=1e-9)
    assert math.isclose(s.slope, math.atan(0.3), abs_tol=1e-12)
    assert abs(math.remainder(s.uphill_azimuth - psi, 2 * math.pi)) < 1e-9
    assert math.isclose(s.dzdx, 0.3 * math.cos(psi), abs_tol=1e-12)
    assert math.isclose(s.dzdy, 0.3 * math.sin(psi), abs_tol=1e-12)


def test_nan_outside_and_on_the_border_ring():
    t, f = _plane_terrain()
    left, bottom, right, top = t.bounds
    x0, y0, dx, dy = t.grid
    xs = np.array([left - 1, right + 1, 0.5 * (left + right), 0.5 * (left + right), np.nan])
    ys = np.array([0.5 * (bottom + top), 0.5 * (bottom + top), bottom - 0.1, top + 5, bottom])
    s = t.sample(xs, ys)
    assert np.isnan(s.elevation).all() and np.isnan(s.slope).all()
    # between the outer edge and the outermost centre: outside the interpolation domain
    assert np.isnan(t.sample(left + 0.25 * dx, y0 + 5 * dy).elevation)
    # on the outermost centre line: elevation yes, gradient no (border cells have none)
    s = t.sample(x0, y0 + 5 * dy)
    assert math.isclose(s.elevation, f(x0, y0 + 5 * dy), abs_tol=1e-9)
    assert math.isnan(s.slope) and not t.contains(x0, y0 + 5 * dy)
    assert t.contains(x0 + 3 * dx, y0 + 3 * dy)


def test_hole_poisons_only_its_neighbourhood():
    t0, f = _plane_terrain()
    z = t0.elevation.copy()
    z[10, 10] = np.nan
    t = Terrain.from_array(z, resolution=t0.resolution, origin=(t0.bounds[0], t0.bounds[1]))
    x0, y0, dx, dy = t.grid
    # any point within one cell of the hole centre uses it (elevation) ...
    near = t.sample(x0 + 10.5 * dx, y0 + 9.7 * dy)
    assert math.isnan(near.elevation)
    # ... its gradient needs the 3x3 windows around the 4 surrounding centres
    assert math.isnan(t.sample(x0 + 11.9 * dx, y0 + 10 * dy).dzdx)
    # two cells away gradient is back, and equals the hole-free plane
    far = t.sample(x0 + 13.0 * dx, y0 + 10.0 * dy)
    ref = t0.sample(x0 + 13.0 * dx, y0 + 10.0 * dy)
    assert far == ref
    # a point exactly on a valid centre next to the hole keeps its elevation
    on = t.sample(x0 + 11 * dx, y0 + 10 * dy)
    assert on.elevation == t0.elevation[10, 11]


def test_grid_contract_for_external_kernels():
    """A hand-written lookup with t.grid (as numba kernels do) matches sample()."""
    t = Terrain.from_function(
        lambda x, y: 0.01 * (x - 30) ** 2 - 0.02 * x * y / 10,
        size=(60, 40),
        resolution=0.5,
        origin=(500.0, 800.0),
    )
    x0, y0, dx, dy = t.grid
    assert dx > 0 and dy < 0
    rng = np.random.default_rng(3)
    x = rng.uniform(t.bounds[0] + 1, t.bounds[2] - 1, 200)
    y = rng.uniform(t.bounds[1] + 1, t.bounds[3] - 1, 200)
    fc, fr = (x - x0) / dx, (y - y0) / dy
    c0, r0 = np.floor(fc).astype(int), np.floor(fr).astype(int)
    tc, tr = fc - c0, fr - r0
    a = t.dzdx
    manual = (
        (1 - tr) * (1 - tc) * a[r0, c0]
        + (1 - tr) * tc * a[r0, c0 + 1]
        + tr * (1 - tc) * a[r0 + 1, c0]
        + tr * tc * a[r0 + 1, c0 + 1]
    )
    np.testing.assert_allclose(t.sample(x, y).dzdx, manual, rtol=1e-12, atol=1e-15)


def test_array_shapes_are_kept():
    t, _ = _plane_terrain()
    x0, y0, dx, dy = t.grid
    xs = x0 + dx * np.array([[3.0, 4.0, 5.0], [6.0, 7.0, 8.0]])
    s = t.sample(xs, y0 + 5 * dy)
    assert all(np.shape(v) == (2, 3) for v in s)


def test_slope_from_interpolated_gradient_not_interpolated_angles():
    """Between a cell rising east and one rising north, the azimuth follows the mean
    gradient vector (45 deg), and the slope is atan(|mean gradient|), not the mean slope."""
    z = np.zeros((4, 6))
    t = Terrain.from_array(z)
    t.dzdx[:] = np.nan
    t.dzdy[:] = np.nan
    t.dzdx[1, 1:3] = [1.0, 0.0]
    t.dzdy[1, 1:3] = [0.0, 1.0]
    t.dzdx[2, 1:3] = [1.0, 0.0]
    t.dzdy[2, 1:3] = [0.0, 1.0]
    x0, y0, dx, dy = t.grid
    s = t.sample(x0 + 1.5 * dx, y0 + 1.5 * dy)
    assert math.isclose(s.uphill_azimuth, math.pi / 4)
    assert math.isclose(s.slope, math.atan(math.hypot(0.5, 0.5)))
