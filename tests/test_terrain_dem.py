"""load_dem: file handling, errors, CRS handling (geographic -> UTM), bundled maps."""

from __future__ import annotations

import math

import numpy as np
import pytest
import rasterio
from rasterio.transform import from_origin
from rasterio.warp import transform as warp_transform
from scipy import ndimage

from energy_planner.errors import DEMError, DEMIOError
from energy_planner.maps import map_names, map_path, scenario
from energy_planner.terrain import Terrain, load_dem, utm_epsg


def write_tif(path, data, transform, crs="EPSG:32631", nodata=None):
    data = np.asarray(data)
    if data.ndim == 2:
        data = data[None]
    profile = dict(
        driver="GTiff",
        width=data.shape[2],
        height=data.shape[1],
        count=data.shape[0],
        dtype=data.dtype,
        crs=crs,
        transform=transform,
        nodata=nodata,
    )
    with rasterio.open(path, "w", **profile) as dst:
        dst.write(data)
    return path


def test_missing_file_names_it(tmp_path):
    missing = tmp_path / "nope.tif"
    with pytest.raises(DEMIOError, match="nope.tif.*does not exist"):
        load_dem(missing)
    with pytest.raises(OSError):  # DEMIOError is also an OSError
        load_dem(missing)


def test_not_a_raster(tmp_path):
    p = tmp_path / "notes.txt"
    p.write_text("not a raster\n")
    with pytest.raises(DEMIOError, match="notes.txt"):
        load_dem(p)


def test_multiband_needs_band(tmp_path):
    z = np.stack([np.full((5, 6), v, dtype=np.float32) for v in (1, 2, 3)])
    p = write_tif(tmp_path / "rgb.tif", z, from_origin(0, 5, 1, 1))
    with pytest.raises(DEMError, match=r"3 bands.*band=N.*--band N.*1\.\.3"):
        load_dem(p)
    t = load_dem(p, band=2)
    assert np.nanmax(t.elevation) == 2.0
    with pytest.raises(DEMError, match=r"band 4 is out of range.*1\.\.3"):
        load_dem(p, band=4)


def test_all_nodata(tmp_path):
    p = write_tif(
        tmp_path / "empty.tif",
        np.full((4, 4), -9999, np.float32),
        from_origin(0, 4, 1, 1),
        nodata=-9999,
    )
    with pytest.raises(DEMError, match="no valid cell"):
        load_dem(p)


def test_nodata_becomes_nan_and_masks_gradient(tmp_path):
    z = np.arange(64, dtype=np.int16).reshape(8, 8)
    z[3, 4] = -32768
    p = write_tif(tmp_path / "hole.tif", z, from_origin(100, 200, 2, 2), nodata=-32768)
    t = load_dem(p)
    assert np.isnan(t.elevation[3, 4]) and np.isfinite(t.elevation).sum() == 63
    assert np.isnan(t.dzdx[2:5, 3:6]).all()
    assert np.isfinite(t.dzdx[5:7, 1:7]).all()
    # z grows by 8 per row southwards at 2 m pixels: dz/dy = -4 (north), dz/dx = 1/2
    np.testing.assert_allclose(t.dzdy[6, 1:7], -4.0)
    np.testing.assert_allclose(t.dzdx[6, 1:7], 0.5)


def test_rotated_geotransform_is_rejected(tmp_path):
    t = rasterio.Affine(1, 0.2, 0, 0.1, -1, 10)
    p = write_tif(tmp_path / "rot.tif", np.ones((5, 5), np.float32), t)
    with pytest.raises(DEMError, match="rot.tif.*rotated/sheared"):
        load_dem(p)


def test_no_crs_warns_and_is_metric(tmp_path):
    z = np.add.outer(np.zeros(6), np.arange(6.0) * 0.5).astype(np.float32)
    p = write_tif(tmp_path / "local.tif", z, from_origin(0, 6, 1, 1), crs=None)
    with pytest.warns(UserWarning, match="no CRS"):
        t = load_dem(p)
    assert t.crs is None and t.source_crs is None
    np.testing.assert_allclose(np.degrees(t.slope[1:-1, 1:-1]), math.degrees(math.atan(0.5)))


def test_south_up_file_is_flipped(tmp_path):
    z = np.add.outer(np.arange(6.0), np.zeros(5)).astype(np.float32)  # grows with row
    p = write_tif(tmp_path / "southup.tif", z, rasterio.Affine(1, 0, 100, 0, 1, 200))
    t = load_dem(p)
    assert t.transform.e < 0
    np.testing.assert_allclose(t.dzdy[1:-1, 1:-1], 1.0)  # rows went north in the file


def _geographic_plane(tmp_path, hole=False):
    """A 10 deg plane defined in UTM 31N, sampled on a 1" lon/lat grid around (3 E, 45 N)."""
    g = math.tan(math.radians(10.0))
    psi = math.radians(-35.0)
    res = 1.0 / 3600.0
    rows, cols = 80, 90
    west, north = 2.99, 45.01
    lon = west + (np.arange(cols) + 0.5) * res
    lat = north - (np.arange(rows) + 0.5) * res
    lo, la = np.meshgrid(lon, lat)
    x, y = warp_transform("EPSG:4326", "EPSG:32631", lo.ravel(), la.ravel())
    x = np.asarray(x).reshape(lo.shape) - 500_000.0
    y = np.asarray(y).reshape(lo.shape) - 4_980_000.0
    z = 300.0 + g * (x * math.cos(psi) + y * math.sin(psi))
    if hole:
        z[40, 45] = np.nan
    p = write_tif(tmp_path / "geo.tif", z, from_origin(west, north, res, res), crs="EPSG:4326")
    return p, (west + cols * res / 2, north - rows * res / 2), psi


def test_geographic_dem_is_reprojected_to_utm(tmp_path):
    p, (lon_c, lat_c), psi = _geographic_plane(tmp_path)
    t = load_dem(p)
    assert t.crs.to_epsg() == utm_epsg(lon_c, lat_c) == 32631
    assert t.source_crs.to_epsg() == 4326
    # equal-area square pixel: sqrt(1" east * 1" north) at 45 N, about 26 m
    expected_res = math.sqrt(
        (math.radians(1 / 3600) * 6378137 * math.cos(math.radians(45)))
        * (math.radians(1 / 3600) * 6367449)
    )
    assert t.resolution[0] == pytest.approx(expected_res, rel=0.01)
    # slope/azimuth are metric: the UTM plane comes back (interior points, in lon/lat)
    lon = lon_c + np.linspace(-0.008, 0.008, 9)
    lat = lat_c + np.linspace(-0.007, 0.007, 9)
    s = t.sample(*t.to_work(*np.meshgrid(lon, lat)))
    np.testing.assert_allclose(np.degrees(s.slope), 10.0, atol=0.01)
    np.testing.assert_allclose(
        np.degrees(np.angle(np.exp(1j * (s.uphill_azimuth - psi)))), 0, atol=0.05
    )
    # valid cells only inside the footprint: nothing extrapolated
    x, y = t.cell_centers()
    lo, la = t.from_work(x[t.valid], y[t.valid])
    assert lo.min() >= 2.99 and lo.max() <= 2.99 + 90 / 3600
    assert la.min() >= 45.01 - 80 / 3600 and la.max() <= 45.01


def test_geographic_nodata_hole_survives_warp(tmp_path):
    p, _, _ = _geographic_plane(tmp_path, hole=True)
    t = load_dem(p)
    res = 1 / 3600
    hx, hy = t.to_work(2.99 + 45.5 * res, 45.01 - 40.5 * res)
    assert np.isnan(t.sample(hx, hy).elevation)
    # the hole is a small island of invalid cells (those whose bilinear footprint touches
    # it), not a big gap; every other cell is exactly what the hole-free DEM gives
    x0, y0, dx, dy = t.grid
    r, c = round((hy - y0) / dy), round((hx - x0) / dx)
    assert not t.valid[r, c]
    lab, _ = ndimage.label(~t.valid)
    assert 1 <= (lab == lab[r, c]).sum() <= 9
    (tmp_path / "full").mkdir()
    t_full = load_dem(_geographic_plane(tmp_path / "full", hole=False)[0])
    same = t.valid
    assert (t_full.valid & ~same).sum() == (lab == lab[r, c]).sum()
    np.testing.assert_array_equal(t.elevation[same], t_full.elevation[same])


def test_to_work_from_work_round_trip(tmp_path):
    p, (lon_c, lat_c), _ = _geographic_plane(tmp_path)
    t = load_dem(p)
    lon = np.array([lon_c, lon_c + 0.001])
    lat = np.array([lat_c, lat_c - 0.002])
    x, y = t.to_work(lon, lat)
    assert np.all(x > 400_000) and np.all(y > 4_900_000)
    lo2, la2 = t.from_work(x, y)
    np.testing.assert_allclose(lo2, lon, atol=1e-10)
    np.testing.assert_allclose(la2, lat, atol=1e-10)
    xs, ys = t.to_work(float(lon_c), float(lat_c))
    assert isinstance(xs, float) and isinstance(ys, float)


def test_feet_crs_is_reprojected(tmp_path):
    """A projected CRS in US feet gets metric slopes (warped to UTM)."""
    z = np.add.outer(np.zeros(40), np.arange(40.0) * 10.0).astype(np.float32)  # 10 m / cell
    # NAD83 / Tennessee (ftUS); 10 ft pixels -> 3.048 m: dz/dx = 10 / 3.048
    p = write_tif(tmp_path / "ft.tif", z, from_origin(2_000_000, 600_000, 10, 10), crs="EPSG:2274")
    t = load_dem(p)
    assert t.crs.is_projected and t.crs.linear_units_factor[1] == 1.0
    s = np.degrees(t.slope)
    inner = np.isfinite(s)
    assert inner.sum() > 100
    np.testing.assert_allclose(
        np.median(s[inner]), math.degrees(math.atan(10 / 3.048006)), atol=0.05
    )


def test_from_array_rejects_geographic_crs():
    with pytest.raises(DEMError, match="projected CRS in metres"):
        Terrain.from_array(np.zeros((3, 3)), crs="EPSG:4326")


def test_from_array_origin_and_grid():
    t = Terrain.from_array(np.zeros((4, 5)), resolution=(2.0, 3.0), origin=(10.0, 20.0))
    assert t.bounds == (10.0, 20.0, 20.0, 32.0)
    assert t.grid == (11.0, 30.5, 2.0, -3.0)
    x, y = t.cell_centers()
    assert (x[0, 0], y[0, 0], x[-1, -1], y[-1, -1]) == (11.0, 30.5, 19.0, 21.5)


# ---------------------------------------------------------------------- bundled maps
def test_map_path_lists_valid_names():
    assert map_names() == ["hill", "jacksboro", "plane"]
    with pytest.raises(DEMIOError, match="valid names: hill, jacksboro, plane"):
        map_path("everest")


def test_plane_map_is_the_stated_plane():
    sc = scenario("plane")
    t = load_dem(sc["path"])
    assert t.crs.to_epsg() == 32631 and t.resolution == (1.0, 1.0)
    inner = np.s_[1:-1, 1:-1]
    np.testing.assert_allclose(np.degrees(t.slope[inner]), 10.0, atol=1e-9)
    np.testing.assert_allclose(np.degrees(t.uphill_azimuth[inner]), 30.0, atol=1e-9)
    np.testing.assert_allclose(t.aspect_deg[inner], 240.0, atol=1e-9)
    assert np.isfinite(t.sample(*sc["start"]).slope) and np.isfinite(t.sample(*sc["goal"]).slope)


def test_hill_scenario_direct_is_steep_and_a_gentler_detour_exists():
    """The Fig. 1 hill: the direct line climbs far above the critical grade (~20 deg), and
    cells no steeper than 25 deg still connect start and goal, while <= 15 deg ones do not."""
    sc = scenario("hill")
    t = load_dem(sc["path"])
    assert t.crs.to_epsg() == 32631 and t.shape == (200, 200) and t.resolution == (1.0, 1.0)
    (sx, sy), (gx, gy) = sc["start"], sc["goal"]
    n = 300
    d = np.degrees(t.sample(np.linspace(sx, gx, n), np.linspace(sy, gy, n)).slope)
    assert 40.0 <= d.max() <= 50.0 and (d >= 20).mean() > 0.5
    x0, y0, dx, dy = t.grid
    rs, cs = round((sy - y0) / dy), round((sx - x0) / dx)
    rg, cg = round((gy - y0) / dy), round((gx - x0) / dx)
    for limit, connected in ((25.0, True), (15.0, False)):
        lab, _ = ndimage.label(np.degrees(t.slope) <= limit, structure=np.ones((3, 3)))
        assert bool(lab[rs, cs] != 0 and lab[rs, cs] == lab[rg, cg]) is connected, limit
    assert t.sample(gx, gy).elevation - t.sample(sx, sy).elevation > 19.0


def test_jacksboro_map_georeferencing():
    with rasterio.open(map_path("jacksboro")) as src:
        assert src.crs.to_epsg() == 4326 and src.shape == (344, 403)
        b = src.bounds
        assert b.left == pytest.approx(-84.41375) and b.top == pytest.approx(36.7329166667)
        assert src.res == pytest.approx((1 / 1200, 1 / 1200))


def test_wide_geographic_dem_warns_about_utm_distortion(tmp_path):
    z = np.add.outer(np.arange(10.0), np.arange(20.0)).astype(np.float32) * 100
    p = write_tif(tmp_path / "wide.tif", z, from_origin(0.0, 50.0, 0.5, 0.5), crs="EPSG:4326")
    with pytest.warns(UserWarning, match="spans 10.0 degrees"):
        t = load_dem(p)
    assert t.crs.to_epsg() == utm_epsg(5.0, 47.5)


def test_polar_geographic_dem_is_refused(tmp_path):
    z = np.ones((5, 5), np.float32)
    p = write_tif(tmp_path / "pole.tif", z, from_origin(10.0, 88.0, 0.01, 0.01), crs="EPSG:4326")
    with pytest.raises(DEMError, match="outside the UTM range"):
        load_dem(p)
