"""Horn slope/aspect/gradient against analytic surfaces (planes, paraboloid, holes)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from affine import Affine
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from energy_planner.errors import DEMError
from energy_planner.terrain import Terrain, aspect, gradient, hillshade, slope
from energy_planner.terrain.horn import horn_gradient, pixel_steps


def plane(g: float, psi: float, xres: float, yres: float, shape=(9, 11)):
    """Plane of gradient magnitude g rising towards psi (CCW from east), north-up grid."""
    rows, cols = shape
    x = (np.arange(cols) + 0.5) * xres
    y = (rows - np.arange(rows) - 0.5) * yres  # row 0 north
    xx, yy = np.meshgrid(x, y)
    return 7.0 + g * (xx * math.cos(psi) + yy * math.sin(psi))


def wrap_deg(a):
    return (np.asarray(a) + 180.0) % 360.0 - 180.0


@settings(max_examples=150, deadline=None)
@given(
    psi_deg=st.floats(-180.0, 180.0),
    slope_deg=st.floats(0.5, 70.0),
    xres=st.floats(0.25, 30.0),
    yres=st.floats(0.25, 30.0),
)
def test_plane_any_direction_and_pixel_shape(psi_deg, slope_deg, xres, yres):
    psi = math.radians(psi_deg)
    g = math.tan(math.radians(slope_deg))
    z = plane(g, psi, xres, yres)
    gx, gy = gradient(z, (xres, yres))
    inner = np.s_[1:-1, 1:-1]
    np.testing.assert_allclose(gx[inner], g * math.cos(psi), atol=1e-9 * (1 + g))
    np.testing.assert_allclose(gy[inner], g * math.sin(psi), atol=1e-9 * (1 + g))
    np.testing.assert_allclose(slope(z, (xres, yres))[inner], slope_deg, atol=1e-7)
    # GIS aspect: downslope, clockwise from north = 270 - psi_deg (mod 360)
    expected_aspect = (270.0 - psi_deg) % 360.0
    asp = aspect(z, (xres, yres))[inner]
    np.testing.assert_allclose(wrap_deg(asp - expected_aspect), 0.0, atol=1e-6)
    assert np.all((asp >= 0) & (asp < 360))
    # the Terrain view agrees, including uphill azimuth psi (CCW from east)
    t = Terrain.from_array(z, resolution=(xres, yres))
    np.testing.assert_allclose(
        wrap_deg(np.degrees(t.uphill_azimuth[inner]) - psi_deg), 0, atol=1e-6
    )
    np.testing.assert_allclose(np.degrees(t.slope[inner]), slope_deg, atol=1e-7)


@pytest.mark.parametrize(
    "psi_deg, aspect_deg",
    [(90, 180), (0, 270), (-90, 0), (180, 90), (45, 225)],
)
def test_aspect_cardinal_directions(psi_deg, aspect_deg):
    """Rising to the north faces south (180), rising to the east faces west (270), ..."""
    z = plane(0.3, math.radians(psi_deg), 1.0, 1.0)
    np.testing.assert_allclose(wrap_deg(aspect(z, 1.0)[1:-1, 1:-1] - aspect_deg), 0, atol=1e-9)


def test_edges_are_nan_like_gdaldem_default():
    z = plane(0.2, 0.3, 1.0, 1.0, shape=(6, 7))
    s = slope(z, 1.0)
    border = np.ones_like(s, dtype=bool)
    border[1:-1, 1:-1] = False
    assert np.isnan(s[border]).all() and np.isfinite(s[~border]).all()


def test_flat_cells_have_no_aspect_but_zero_slope():
    z = np.full((5, 5), 3.0)
    assert np.isnan(aspect(z, 1.0)).all()
    np.testing.assert_array_equal(slope(z, 1.0)[1:-1, 1:-1], 0.0)
    t = Terrain.from_array(z)
    np.testing.assert_array_equal(t.uphill_azimuth[1:-1, 1:-1], 0.0)


@pytest.mark.parametrize("a", [0.001, 0.01, 0.05])
def test_paraboloid_slope_is_atan_2ar(a):
    """Horn's 1-2-1 central differences are exact on z = a (x^2 + y^2)."""
    res = 0.5
    t = Terrain.from_function(
        lambda x, y: a * ((x - 40.25) ** 2 + (y - 30.25) ** 2), size=(80, 60), resolution=res
    )
    x, y = t.cell_centers()
    r = np.hypot(x - 40.25, y - 30.25)
    inner = np.s_[1:-1, 1:-1]
    np.testing.assert_allclose(t.slope[inner], np.arctan(2 * a * r[inner]), rtol=1e-9, atol=1e-12)
    # uphill points away from the centre
    away = np.arctan2(y - 30.25, x - 40.25)
    diff = np.angle(np.exp(1j * (t.uphill_azimuth[inner] - away[inner])))
    assert np.abs(diff).max() < 1e-9


def test_non_square_pixels_use_their_own_spacing():
    """Same array, different yres: only dz/dy scales."""
    z = np.add.outer(-np.arange(6.0) * 2.0, np.arange(7.0) * 1.0)  # +1 per col, +2 per row north
    gx1, gy1 = gradient(z, (1.0, 1.0))
    gx2, gy2 = gradient(z, (0.5, 4.0))
    np.testing.assert_allclose(gx1[1:-1, 1:-1], 1.0)
    np.testing.assert_allclose(gy1[1:-1, 1:-1], 2.0)
    np.testing.assert_allclose(gx2[1:-1, 1:-1], 2.0)
    np.testing.assert_allclose(gy2[1:-1, 1:-1], 0.5)


def test_transform_orientation_is_respected():
    """A south-up transform flips the sign of dz/dy for the same array; Terrain flips rows."""
    z = np.add.outer(np.arange(6.0), np.zeros(5))  # grows with the row index
    north_up = Affine(1, 0, 0, 0, -1, 6)
    south_up = Affine(1, 0, 0, 0, 1, 0)
    assert gradient(z, north_up)[1][2, 2] == pytest.approx(-1.0)  # rows go south: falls north
    assert gradient(z, south_up)[1][2, 2] == pytest.approx(1.0)
    t = Terrain(z, south_up)
    assert t.transform.e < 0 and t.dzdy[2, 2] == pytest.approx(1.0)
    assert t.elevation[0, 0] == 5.0  # flipped: row 0 is now the northern (highest) row


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_holes=st.integers(1, 12))
def test_nodata_holes_mask_neighbours_and_change_nothing_else(seed, n_holes):
    rng = np.random.default_rng(seed)
    t0 = Terrain.from_function(
        lambda x, y: 0.02 * (x - 12) ** 2 + 0.01 * x * y, size=(25, 20), resolution=1.0
    )
    z = t0.elevation.copy()
    holes = np.zeros(z.shape, dtype=bool)
    holes[rng.integers(0, z.shape[0], n_holes), rng.integers(0, z.shape[1], n_holes)] = True
    z[holes] = np.nan
    t = Terrain.from_array(z)
    touched = ndimage.binary_dilation(holes, structure=np.ones((3, 3), dtype=bool))
    touched[0, :] = touched[-1, :] = touched[:, 0] = touched[:, -1] = True
    assert np.isnan(t.dzdx[touched]).all() and np.isnan(t.dzdy[touched]).all()
    np.testing.assert_array_equal(t.dzdx[~touched], t0.dzdx[~touched])
    np.testing.assert_array_equal(t.dzdy[~touched], t0.dzdy[~touched])
    np.testing.assert_array_equal(np.isnan(t.elevation), holes)  # nothing filled in
    assert t.nodata_fraction == pytest.approx(holes.mean())


def test_nodata_value_in_from_array():
    z = np.ones((5, 5))
    z[2, 2] = -9999.0
    t = Terrain.from_array(z, nodata=-9999.0)
    assert np.isnan(t.elevation[2, 2]) and np.isnan(t.slope).all()


def test_hillshade_of_plane_matches_lambert():
    """Plane facing the sun: cos(angle between normal and sun) by hand."""
    g, psi = math.tan(math.radians(20)), math.radians(180.0)  # rises to the west: faces east
    z = plane(g, psi, 1.0, 1.0)
    hs = hillshade(z, 1.0, azimuth=90.0, altitude=30.0)[1:-1, 1:-1]
    normal = np.array([-g * math.cos(psi), -g * math.sin(psi), 1.0]) / math.hypot(g, 1.0)
    sun = np.array([math.cos(math.radians(30)), 0.0, math.sin(math.radians(30))])
    np.testing.assert_allclose(hs, normal @ sun, atol=1e-12)


def test_outputs_are_c_contiguous_float64():
    t = Terrain.from_array(np.asfortranarray(np.random.default_rng(0).random((8, 9))))
    for a in (t.elevation, t.grad):
        assert a.dtype == np.float64 and a.flags.c_contiguous
    assert t.grad.shape == (8, 9, 2)
    # one copy of the gradient: the components are views of it, equal to Horn's own
    assert t.dzdx.base is t.grad and t.dzdy.base is t.grad
    gx, gy = horn_gradient(t.elevation, 1.0, -1.0)
    assert gx.flags.c_contiguous and gy.flags.c_contiguous
    np.testing.assert_array_equal(t.dzdx, gx)
    np.testing.assert_array_equal(t.dzdy, gy)


def test_gradient_views_survive_pickling():
    """A pickled Terrain (a dask worker's) holds one gradient, its views made again."""
    import pickle

    t = Terrain.from_function(lambda x, y: 0.1 * x - 0.2 * y, size=(6, 5))
    u = pickle.loads(pickle.dumps(t))
    assert u.dzdx.base is u.grad and u.dzdy.base is u.grad
    np.testing.assert_array_equal(u.grad, t.grad)
    u.grad[2, 2] = (7.0, 8.0)
    assert (u.dzdx[2, 2], u.dzdy[2, 2]) == (7.0, 8.0)


def test_radians_option():
    z = plane(1.0, 0.0, 1.0, 1.0)
    np.testing.assert_allclose(slope(z, 1.0, degrees=False)[1:-1, 1:-1], math.pi / 4)
    np.testing.assert_allclose(aspect(z, 1.0, degrees=False)[1:-1, 1:-1], 1.5 * math.pi)


@pytest.mark.parametrize(
    "bad", [0.0, -1.0, (1.0, 0.0), (1.0, float("nan")), "x", Affine(1, 0.1, 0, 0, -1, 0)]
)
def test_bad_resolution_or_rotated_transform_raise(bad):
    with pytest.raises(DEMError, match="resolution|rotated|sheared"):
        pixel_steps(bad)


@settings(max_examples=60, deadline=None)
@given(
    p=st.floats(-2.0, 2.0),
    q=st.floats(-2.0, 2.0),
    sx0=st.floats(5.0, 100.0),
    shrink=st.floats(-0.02, 0.02),
    gaps=st.lists(st.floats(5.0, 100.0), min_size=7, max_size=7),
)
def test_per_row_steps_are_exact_on_a_plane(p, q, sx0, shrink, gaps):
    """Per-row steps (a lon/lat grid: columns narrow towards the pole, rows uneven).

    Column spacing linear in the row (as cos(latitude) over three rows, to first order)
    and rows at arbitrary spacing: Horn with step_x[r] and step_y[r] = half the signed
    distance from row r - 1 to row r + 1 is exact on ``z = p x`` (x along each row) and
    on ``z = q y``. (On such a grid a column is not a line of constant x, so ``p x``
    also varies along a column: only dz/dx is checked for it.)
    """
    rows, cols = 8, 6
    sx = sx0 * (1.0 + shrink * np.arange(rows))
    y = -np.concatenate([[0.0], np.cumsum(gaps)])  # row 0 north, y decreasing
    sy = np.empty(rows)
    sy[1:-1] = 0.5 * (y[2:] - y[:-2])
    sy[[0, -1]] = -1.0  # not used (border)
    x = np.arange(cols)[None, :] * sx[:, None]
    gx, _ = horn_gradient(p * x, sx, sy)
    np.testing.assert_allclose(gx[1:-1, 1:-1], p, atol=1e-9)
    gx, gy = horn_gradient(np.broadcast_to(q * y[:, None], x.shape), sx, sy)
    np.testing.assert_allclose(gx[1:-1, 1:-1], 0.0, atol=1e-12)
    np.testing.assert_allclose(gy[1:-1, 1:-1], q, atol=1e-9)
    z = p * x + q * y[:, None]
    # a scalar step and a constant per-row step give the same bits
    ref = horn_gradient(z, 7.0, -3.0)
    per_row = horn_gradient(z, np.full(rows, 7.0), np.full(rows, -3.0))
    np.testing.assert_array_equal(ref[0], per_row[0])
    np.testing.assert_array_equal(ref[1], per_row[1])


def test_per_row_steps_must_match_the_rows():
    with pytest.raises(DEMError, match="one step per row"):
        horn_gradient(np.zeros((4, 4)), np.ones(3), -1.0)
