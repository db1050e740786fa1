"""DEM values as GDAL describes them, read alike by every door.

Truths: an analytic plane written in the stored units (decimetres with a GDAL scale and
offset, feet by the band's unit, undeclared -32768 voids) and the same plane written as
float metres with a declared nodata; the energy map's three ways of reading a file
(whole, by windows, dask chunks) and the corridor's strips against the whole-DEM terrain.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
import rasterio
from affine import Affine

from energy_planner.energymap import energy_map
from energy_planner.errors import DEMError
from energy_planner.model import EnergyModel
from energy_planner.planning.corridor import gradient_box, raster_info
from energy_planner.terrain import load_dem

X0, Y0, RES, N = 500000.0, 5000000.0, 2.0, 48
MODEL = EnergyModel.default()


def write(path, stored, dtype="float64", nodata=None, scale=None, offset=None, units=None,
          crs="EPSG:32631", transform=None):  # fmt: skip
    t = transform or Affine(RES, 0.0, X0, 0.0, -RES, Y0 + RES * stored.shape[0])
    prof = dict(driver="GTiff", width=stored.shape[1], height=stored.shape[0], count=1,
                dtype=dtype, crs=crs, transform=t, nodata=nodata)  # fmt: skip
    with rasterio.open(path, "w", **prof) as dst:
        dst.write(stored.astype(dtype), 1)
        if scale is not None or offset is not None:
            dst.scales = (1.0 if scale is None else scale,)
            dst.offsets = (0.0 if offset is None else offset,)
        if units is not None:
            dst.units = (units,)
    return path


def hills(n=N):
    """Metres: gentle hills rising east, row 0 north."""
    x = np.arange(n) * RES
    xx, yy = np.meshgrid(x, x)
    return 150.0 + 8 * np.sin(xx / 30) * np.cos(yy / 25) + 0.05 * xx


def holes(n=N):
    h = np.zeros((n, n), bool)
    h[20:26, 10:30] = True
    return h


@pytest.fixture(scope="module")
def scaled(tmp_path_factory):
    """The hills as int16 decimetres (scale 0.1, offset 100 m) with undeclared -32768
    voids, and the same decimetre heights as float metres with declared nodata."""
    d = tmp_path_factory.mktemp("scaled")
    z = np.round((hills() - 100.0) / 0.1)
    metres = z * 0.1 + 100.0
    z[holes()] = -32768
    metres[holes()] = -9999.0
    stored = write(d / "dm.tif", z, "int16", scale=0.1, offset=100.0)
    plain = write(d / "m.tif", metres, nodata=-9999.0)
    return stored, plain


def test_scaled_int_with_undeclared_voids_reads_as_the_plain_dem(scaled):
    stored, plain = scaled
    with pytest.warns(UserWarning, match=r"120 cells of -32768 .* gdal_edit.py -a_nodata -32768"):
        t = load_dem(stored)
    ref = load_dem(plain)
    np.testing.assert_allclose(t.elevation, ref.elevation, rtol=0, atol=1e-9)
    np.testing.assert_allclose(t.dzdx, ref.dzdx, rtol=0, atol=1e-9)


@pytest.mark.parametrize("local", [False, True], ids=["scanned-first", "window-by-window"])
def test_every_door_reads_the_scaled_dem_alike(scaled, tmp_path, local, monkeypatch):
    """Whole (terrain), windowed and dask energy maps, the corridor's strips and a window.

    Also as a file too large to scan first (``SCAN_CELLS`` below its size): each window
    finds its own voids, with the same cells as the scan.
    """
    if local:
        monkeypatch.setattr("energy_planner.terrain.raster.SCAN_CELLS", 100)
    stored, plain = scaled
    ref_map = tmp_path / "ref.tif"
    energy_map(load_dem(plain), ref_map, MODEL, headings=4)
    with rasterio.open(ref_map) as src:
        ref = src.read()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # the voids' warning (tested above)
        for kw in ({"use_dask": False}, {"use_dask": True, "chunk": 64}):
            out = tmp_path / f"{kw['use_dask']}.tif"
            energy_map(stored, out, MODEL, headings=4, **kw)
            with rasterio.open(out) as src:
                np.testing.assert_allclose(src.read(), ref, rtol=1e-6, equal_nan=True)
        lo, hi, valid = gradient_box(raster_info(stored))
        win = load_dem(stored, bounds=(X0 + 10, Y0 + 10, X0 + 70, Y0 + 60))
    t = load_dem(plain)
    np.testing.assert_allclose(lo, [np.nanmin(t.dzdx), np.nanmin(t.dzdy)], rtol=1e-12)
    np.testing.assert_allclose(hi, [np.nanmax(t.dzdx), np.nanmax(t.dzdy)], rtol=1e-12)
    assert valid == int(np.isfinite(t.dzdx).sum())
    x, y = X0 + 40.0, Y0 + 35.0
    assert win.sample(x, y).elevation == pytest.approx(t.sample(x, y).elevation, abs=1e-9)


def test_vertical_feet_and_unknown_units(tmp_path):
    z = hills()
    feet = load_dem(write(tmp_path / "ft.tif", z / 0.3048, units="ft"))
    ref = load_dem(write(tmp_path / "m.tif", z))
    np.testing.assert_allclose(feet.dzdx, ref.dzdx, rtol=0, atol=1e-12)
    with pytest.raises(DEMError, match=r"'furlong'.*gdal_edit.py -units m"):
        load_dem(write(tmp_path / "u.tif", z, units="furlong"))
    with pytest.raises(DEMError, match=r"scale 0\.0"):
        load_dem(write(tmp_path / "s.tif", z, scale=0.0))


def test_values_near_the_rest_are_not_voids(tmp_path):
    """A DEM whose lowest cells really are -9999 m next to -9990 m (bathymetry) keeps them."""
    z = np.linspace(-9999.0, -9990.0, N)[None].repeat(N, 0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        t = load_dem(write(tmp_path / "deep.tif", z))
    assert np.isfinite(t.elevation).all()


def test_decimating_undeclared_voids_is_refused(tmp_path):
    z = hills()
    z[holes()] = -9999.0
    dem = write(tmp_path / "v.tif", z)
    with pytest.warns(UserWarning, match="-9999"), pytest.raises(DEMError, match="-a_nodata"):
        load_dem(dem, decimate=2)


def test_a_far_from_true_scale_projection_is_refused_with_the_warp(tmp_path):
    """Polar stereographic (EPSG:3031) at 60 S: 4 % from ground metres, not cylindrical."""
    from pyproj import Transformer

    x, y = Transformer.from_crs("EPSG:4326", "EPSG:3031", always_xy=True).transform(20.0, -60.0)
    t = Affine(RES, 0.0, x, 0.0, -RES, y)
    with pytest.raises(DEMError, match=r"gdalwarp -t_srs EPSG:32734") as exc:
        load_dem(write(tmp_path / "polar.tif", hills(), crs="EPSG:3031", transform=t))
    assert "ground metre" in str(exc.value)


def test_web_mercator_plane_reads_its_ground_slope(tmp_path):
    """A 10 % grade north at 45 N in EPSG:3857: heights from geodesic distances (pyproj)."""
    from pyproj import Geod, Transformer

    fwd = Transformer.from_crs("EPSG:4326", "EPSG:3857", always_xy=True)
    inv = Transformer.from_crs("EPSG:3857", "EPSG:4326", always_xy=True)
    x0, y0 = fwd.transform(3.0, 45.0)
    ys = y0 - (np.arange(N) + 0.5) * RES
    _, lat = inv.transform(np.full(N, x0), ys)
    _, _, dist = Geod(ellps="WGS84").inv(np.full(N, 3.0), np.full(N, 45.0), np.full(N, 3.0), lat)
    z = np.repeat((100.0 - 0.1 * dist)[:, None], N, axis=1)  # rows go south: downhill
    t = load_dem(write(tmp_path / "m.tif", z, crs="EPSG:3857",
                       transform=Affine(RES, 0, x0, 0, -RES, y0)))  # fmt: skip
    slope = np.degrees(t.native_grid.slope)
    assert np.nanmax(np.abs(slope - math.degrees(math.atan(0.1)))) < 1e-4
    assert t.crs.to_epsg() == 32631  # carried to a grid in ground metres


def test_a_point_inside_the_map_without_slope_names_the_real_cause():
    from energy_planner.errors import InvalidStateError
    from energy_planner.planning.limits import check_endpoint
    from energy_planner.problem import Problem
    from energy_planner.terrain import Terrain

    z = hills()
    z[holes()] = np.nan
    t = Terrain.from_array(z, resolution=RES, origin=(X0, Y0))
    x0, y0, dx, dy = t.grid
    on_void = (x0 + 20 * dx, y0 + 22 * dy)  # row 22, column 20: in the hole
    beside = (x0 + 20 * dx, y0 + 19 * dy)  # row 19: next to it
    assert t.invalid_reason(*on_void) == "on a nodata cell (row 22, column 20 of the working grid)"
    assert t.invalid_reason(*beside).startswith("next to a nodata cell")
    assert t.invalid_reason(x0 - 50, y0) == "outside the map"
    assert t.invalid_reason(x0 + 5 * dx, y0 + 5 * dy) is None
    cost = Problem(t, MODEL).cost
    with pytest.raises(InvalidStateError, match="invalid: on a nodata cell") as exc:
        check_endpoint(cost, t, "start", (*on_void, None))
    assert "outside" not in str(exc.value).split(";")[0]


def test_a_scaled_numeric_channel_raster_reads_its_values(tmp_path):
    """A payload map stored as int16 tenths of a kilogram (scale 0.1) reads as kilograms."""
    from energy_planner.energy.channels import Channels
    from energy_planner.terrain import Terrain

    kg = np.linspace(0.0, 30.0, N)[None].repeat(N, 0)
    plain = write(tmp_path / "kg.tif", kg)
    tenths = write(tmp_path / "tenths.tif", np.round(kg * 10), "int16", scale=0.1)
    t = Terrain.from_array(hills(), resolution=RES, origin=(X0, Y0))
    got, want = (
        Channels.parse([], [f"load_kg={f}"]).bind(t).stack(t.shape)[0][0] for f in (tenths, plain)
    )
    np.testing.assert_allclose(got, np.round(want * 10) / 10, rtol=0, atol=1e-9)
