"""Horn on a lon/lat DEM's own grid with geodesic spacing (issue 19, point 7).

References are independent of the code under test: planes defined in UTM and measured
on the ellipsoid with ``pyproj.Geod`` (slope = rise over the geodesic length of a short
step down the plane, aspect = the step's geodesic azimuth), and for the bundled
Jacksboro DEM a plain NumPy Horn with cell sizes from ``Geod.inv``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import rasterio
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pyproj import Geod, Transformer
from rasterio.transform import from_origin
from scipy.ndimage import map_coordinates

from energy_planner.maps import map_path
from energy_planner.terrain import load_dem
from energy_planner.terrain.horn import horn_gradient
from energy_planner.terrain.native import native_steps

GEOD = Geod(ellps="WGS84")


def _utm(lon: float, lat: float) -> str:
    zone = int((lon + 180.0) // 6.0) % 60 + 1
    return f"EPSG:{(32600 if lat >= 0 else 32700) + zone}"


def _lonlat_plane(path, lon0, lat0, res_x, res_y, p, q, n=24):
    """``z = p x + q y`` in the UTM zone of (lon0, lat0), sampled at lon/lat cell centres.

    Returns the file, the cell centres and the reference slope/aspect (degrees) per cell.
    """
    utm = _utm(lon0, lat0)
    fwd = Transformer.from_crs("EPSG:4326", utm, always_xy=True)
    inv = Transformer.from_crs(utm, "EPSG:4326", always_xy=True)
    west, north = lon0 - n / 2 * res_x, lat0 + n / 2 * res_y
    lon = west + (np.arange(n) + 0.5) * res_x
    lat = north - (np.arange(n) + 0.5) * res_y
    lo, la = np.meshgrid(lon, lat)
    x, y = fwd.transform(lo, la)
    z = p * x + q * y
    with rasterio.open(
        path, "w", driver="GTiff", width=n, height=n, count=1, dtype="float64",
        crs="EPSG:4326", transform=from_origin(west, north, res_x, res_y),
    ) as dst:  # fmt: skip
        dst.write(z, 1)
    # a 1 cm step straight down the plane (in UTM), measured on the ellipsoid
    step = 0.01
    u = -np.array([p, q]) / math.hypot(p, q)
    lo2, la2 = inv.transform(x + step * u[0], y + step * u[1])
    az, _, dist = GEOD.inv(lo, la, lo2, la2)
    slope = np.degrees(np.arctan(math.hypot(p, q) * step / dist))
    return path, utm, slope, np.mod(az, 360.0)


def _angle_diff(a, b):
    return (a - b + 180.0) % 360.0 - 180.0


def test_lonlat_plane_off_the_central_meridian(tmp_path):
    """A UTM plane 2.5 deg east of zone 31's meridian (convergence 1.8 deg, k = 1.0000)."""
    p, q = 0.12, -0.11
    f, utm, ref_slope, ref_aspect = _lonlat_plane(tmp_path / "p.tif", 5.5, 45.0, 1 / 3600,
                                                   1 / 3600, p, q, n=40)  # fmt: skip
    t = load_dem(f)
    g = t.native_grid
    assert g.crs.to_epsg() == 4326 and g.elevation.shape == (40, 40)
    inner = np.s_[1:-1, 1:-1]
    # measured: 2.2e-6 deg slope, 1.4e-5 deg aspect
    np.testing.assert_allclose(np.degrees(g.slope)[inner], ref_slope[inner], atol=1e-4)
    assert np.abs(_angle_diff(g.aspect_deg[inner], ref_aspect[inner])).max() < 1e-3
    assert np.isnan(g.slope[0]).all() and np.isnan(g.slope[:, -1]).all()  # border
    # the planners' working grid is that UTM zone: its gradient is the plane's (p, q),
    # rotated by the meridian convergence and scaled by k from the native gradient
    assert t.crs.to_string() == utm
    ok = np.isfinite(t.dzdx)
    assert ok.sum() > 0.6 * ok.size
    np.testing.assert_allclose(t.dzdx[ok], p, atol=1e-8)
    np.testing.assert_allclose(t.dzdy[ok], q, atol=1e-8)


@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    lat=st.floats(-70.0, 70.0),
    dlon=st.floats(-2.9, 2.9),
    slope_deg=st.floats(0.5, 50.0),
    psi_deg=st.floats(0.0, 360.0),
    res_x=st.sampled_from([1.0, 3.0, 10.0]),
    res_y=st.sampled_from([1.0, 3.0]),
)
def test_lonlat_planes_any_latitude(tmp_path, lat, dlon, slope_deg, psi_deg, res_x, res_y):
    """Planes of every slope and direction, north and south, any pixel shape."""
    zone_cm = 9.0  # zone 32's central meridian
    g = math.tan(math.radians(slope_deg))
    p, q = g * math.cos(math.radians(psi_deg)), g * math.sin(math.radians(psi_deg))
    f, _, ref_slope, ref_aspect = _lonlat_plane(
        tmp_path / "h.tif", zone_cm + dlon, lat, res_x / 3600, res_y / 3600, p, q, n=12
    )
    t = load_dem(f)
    inner = np.s_[1:-1, 1:-1]
    s = np.degrees(t.native_grid.slope)[inner]
    np.testing.assert_allclose(s, ref_slope[inner], atol=1e-4)
    da = _angle_diff(t.native_grid.aspect_deg[inner], ref_aspect[inner])
    assert np.abs(da).max() < 1e-3


def test_native_steps_are_geodesic_distances():
    """Closed-form row steps against Geod.inv between neighbouring cell centres."""
    from rasterio.crs import CRS

    res = 3 / 3600
    for lat0 in (-66.0, -20.0, 0.0, 36.5, 60.0):
        t = from_origin(10.0, lat0 + 3 * res, res, res)
        sx, sy = native_steps(t, 5, CRS.from_epsg(4326))
        lat = lat0 + 3 * res - (np.arange(5) + 0.5) * res
        _, _, dx = GEOD.inv(np.full(5, 10.0), lat, np.full(5, 10.0 + res), lat)
        _, _, dy = GEOD.inv(np.full(5, 10.0), lat + res / 2, np.full(5, 10.0), lat - res / 2)
        np.testing.assert_allclose(sx, dx, rtol=1e-8)
        np.testing.assert_allclose(-sy, dy, rtol=1e-8)


@pytest.fixture(scope="module")
def jacksboro_reference():
    """Plain NumPy Horn on the Jacksboro lon/lat grid, spacing from Geod.inv."""
    with rasterio.open(map_path("jacksboro")) as src:
        z = src.read(1, masked=True).astype(float).filled(np.nan)
        tr = src.transform
    assert tr.e < 0 and tr.a > 0  # north-up
    rows, cols = z.shape
    lat = tr.f + (np.arange(rows) + 0.5) * tr.e
    lon0, lon1 = tr.c + 0.5 * tr.a, tr.c + 1.5 * tr.a
    _, _, dx = GEOD.inv(np.full(rows, lon0), lat, np.full(rows, lon1), lat)
    _, _, dy2 = GEOD.inv(np.full(rows - 2, lon0), lat[:-2], np.full(rows - 2, lon0), lat[2:])
    a, b, c = z[:-2, :-2], z[:-2, 1:-1], z[:-2, 2:]
    d, f = z[1:-1, :-2], z[1:-1, 2:]
    g, h, i = z[2:, :-2], z[2:, 1:-1], z[2:, 2:]
    gx = ((c + 2 * f + i) - (a + 2 * d + g)) / (8 * dx[1:-1, None])
    gy = ((a + 2 * b + c) - (g + 2 * h + i)) / (4 * dy2[:, None])  # 8 * (dy2 / 2)
    grad = np.full((2, *z.shape), np.nan)
    grad[0, 1:-1, 1:-1], grad[1, 1:-1, 1:-1] = gx, gy
    slope = np.degrees(np.arctan(np.hypot(grad[0], grad[1])))
    aspect = np.degrees(np.arctan2(-grad[0], -grad[1])) % 360.0
    return slope, aspect, tr, grad


def test_jacksboro_slope_is_native_geodesic_horn(jacksboro_reference):
    """``terrain``'s slope/aspect (Terrain.native_grid) against the independent Horn.

    Before issue 19 the slope came from Horn on the UTM-warped DEM: 0.72 deg median
    |difference| at the DEM's cell centres. Now Horn runs on the native grid: measured
    max 3e-10 deg.
    """
    ref_slope, ref_aspect, tr, _ = jacksboro_reference
    t = load_dem(map_path("jacksboro"))
    g = t.native_grid
    assert g.transform == tr
    s = np.degrees(g.slope)
    np.testing.assert_array_equal(np.isnan(s), np.isnan(ref_slope))
    ok = np.isfinite(ref_slope)
    assert ok.sum() > 130_000
    d = np.abs(s[ok] - ref_slope[ok])
    assert np.median(d) <= 0.3  # the acceptance bound
    assert d.max() < 1e-6
    steep = ok & (ref_slope > 1.0)
    assert np.abs(_angle_diff(g.aspect_deg[steep], ref_aspect[steep])).max() < 1e-6


def test_jacksboro_working_grid_follows_native_horn(jacksboro_reference):
    """The planners' UTM gradient is the native Horn carried to its cell centres.

    At each working cell centre (projected back to lon/lat with pyproj), the working
    slope is compared with the slope of the reference gradient interpolated bilinearly
    there (scipy; cells with a NaN neighbour left out; angles are never interpolated).
    Measured median 0.004 deg (the UTM scale factor k ~ 1.0004 alone makes 0.003 deg at
    12 deg); Horn on the warped DEM gave 0.14 deg. Reading the working grid *between*
    its centres interpolates a second time: at the DEM's own cell centres that is
    0.71 deg median (docs/terrain.md).
    """
    ref_slope, _, tr, grad = jacksboro_reference
    t = load_dem(map_path("jacksboro"))
    x, y = t.cell_centers()
    to_ll = Transformer.from_crs(t.crs.to_string(), "EPSG:4326", always_xy=True)
    lon, lat = to_ll.transform(x, y)
    at = [((lat - tr.f) / tr.e - 0.5).ravel(), ((lon - tr.c) / tr.a - 0.5).ravel()]
    gx, gy = (
        map_coordinates(np.nan_to_num(g), at, order=1, mode="nearest").reshape(x.shape)
        for g in grad
    )
    nan_near = map_coordinates(np.isnan(ref_slope).astype(float), at, order=1, cval=1.0)
    ref = np.where(nan_near.reshape(x.shape) > 0, np.nan, np.degrees(np.arctan(np.hypot(gx, gy))))
    work = np.degrees(t.slope)
    ok = np.isfinite(ref) & np.isfinite(work)
    assert ok.sum() > 120_000
    d = np.abs(work[ok] - ref[ok])
    assert np.median(d) <= 0.3
    assert np.median(d) < 0.02 and d.max() < 0.1
    # Horn of the warped elevation (what the working grid used to hold) is further off
    old = np.degrees(np.arctan(np.hypot(*horn_gradient(t.elevation, *t.grid[2:]))))
    assert np.nanmedian(np.abs(old[ok] - ref[ok])) > 5 * np.median(d)


def test_projected_dem_in_us_feet(tmp_path):
    """A plane on a US-feet grid (EPSG:2229): Horn natively with the foot's length.

    ``z = p X + q Y`` (X, Y in metres along the CRS's axes) gives ``(p, q)`` on the DEM's
    own grid; the UTM working grid's gradient is checked against finite differences of
    that plane evaluated through pyproj at each working cell centre.
    """
    ft = 1200.0 / 3937.0
    p, q = 0.05, 0.2
    n, res_ft = 30, 100.0
    west, north = 6_450_000.0, 1_850_000.0  # near Los Angeles, in US feet
    cols = west + (np.arange(n) + 0.5) * res_ft
    rows = north - (np.arange(n) + 0.5) * res_ft
    gx_ft, gy_ft = np.meshgrid(cols, rows)
    z = p * gx_ft * ft + q * gy_ft * ft
    f = tmp_path / "ft.tif"
    with rasterio.open(
        f, "w", driver="GTiff", width=n, height=n, count=1, dtype="float64",
        crs="EPSG:2229", transform=from_origin(west, north, res_ft, res_ft),
    ) as dst:  # fmt: skip
        dst.write(z, 1)
    t = load_dem(f)
    g = t.native_grid
    inner = np.s_[1:-1, 1:-1]
    np.testing.assert_allclose(g.dzdx[inner], p, atol=1e-9)
    np.testing.assert_allclose(g.dzdy[inner], q, atol=1e-9)
    to_ft = Transformer.from_crs(t.crs.to_string(), "EPSG:2229", always_xy=True)

    def plane_at(x, y):
        xf, yf = to_ft.transform(x, y)
        return p * np.asarray(xf) * ft + q * np.asarray(yf) * ft

    x, y = t.cell_centers()
    ok = np.isfinite(t.dzdx)
    assert ok.sum() > 300
    h = 0.5
    ref_x = (plane_at(x + h, y) - plane_at(x - h, y)) / (2 * h)
    ref_y = (plane_at(x, y + h) - plane_at(x, y - h)) / (2 * h)
    np.testing.assert_allclose(t.dzdx[ok], ref_x[ok], atol=1e-6)
    np.testing.assert_allclose(t.dzdy[ok], ref_y[ok], atol=1e-6)


def test_lonlat_memory_budget_counts_the_native_grid(monkeypatch):
    """The reprojected grid is checked at LONLAT_BYTES_PER_CELL (the native grid is kept).

    Jacksboro: 344 x 403 source cells x 64 B = 8.9 MB passes a 10 MB cap; the 393 x 373
    working grid x 80 B = 11.7 MB does not (at 64 B it would have passed: 9.4 MB).
    """
    from energy_planner.errors import RasterTooLargeError
    from energy_planner.terrain.memory import LONLAT_BYTES_PER_CELL, MEMORY_CAP_ENV

    monkeypatch.setenv(MEMORY_CAP_ENV, "10000000")
    with pytest.raises(RasterTooLargeError, match="reprojected to EPSG:32616") as exc:
        load_dem(map_path("jacksboro"))
    assert exc.value.size_bytes == 393 * 373 * LONLAT_BYTES_PER_CELL
    monkeypatch.setenv(MEMORY_CAP_ENV, "12000000")
    assert load_dem(map_path("jacksboro")).shape == (393, 373)


@settings(max_examples=100, deadline=None)
@given(
    zone=st.integers(1, 60),
    south=st.booleans(),
    easting=st.floats(-500_000.0, 1_500_000.0),
    northing=st.floats(100_000.0, 9_000_000.0),
)
def test_transverse_mercator_shortcut_agrees_with_pyproj(zone, south, easting, northing):
    """The closed-form UTM check never calls metric what pyproj's factors do not."""
    from pyproj import CRS as ProjCRS
    from pyproj import Proj
    from rasterio.crs import CRS

    from energy_planner.terrain.native import GROUND_TOLERANCE, _transverse_mercator_within

    epsg = (32700 if south else 32600) + zone
    bounds = (easting, northing, easting + 500.0, northing + 500.0)
    if not _transverse_mercator_within(CRS.from_epsg(epsg), bounds):
        return
    proj = ProjCRS.from_epsg(epsg)
    for x in (bounds[0], bounds[2]):
        for y in (bounds[1], bounds[3]):
            lon, lat = Transformer.from_crs(proj, proj.geodetic_crs, always_xy=True).transform(x, y)
            factors = Proj(proj).get_factors(lon, lat)
            assert abs(factors.meridional_scale - 1.0) <= GROUND_TOLERANCE
            assert abs(factors.parallel_scale - 1.0) <= GROUND_TOLERANCE
