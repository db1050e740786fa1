"""``energy-planner terrain`` through click's CliRunner."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner
from rasterio.transform import from_origin

from energy_planner.cli import main
from energy_planner.maps import map_path
from energy_planner.terrain import load_dem


@pytest.fixture
def runner():
    return CliRunner()


def test_summary_json_on_plane(runner):
    res = runner.invoke(main, ["terrain", str(map_path("plane")), "--json"])
    assert res.exit_code == 0, res.output
    r = json.loads(res.stdout)
    assert r["crs"] == r["working_crs"] == "EPSG:32631" and not r["reprojected"]
    assert r["shape"] == [100, 100] and r["resolution_m"] == [1.0, 1.0]
    for key in ("slope_min_deg", "slope_mean_deg", "slope_max_deg"):
        assert r[key] == pytest.approx(10.0, abs=1e-9)
    assert r["nodata_share"] == 0.0
    assert r["no_slope_share"] == pytest.approx(1 - 98 * 98 / 100**2)


def test_text_output_and_bundled_name(runner):
    res = runner.invoke(main, ["terrain", "hill"])
    assert res.exit_code == 0, res.output
    assert "EPSG:32631" in res.output and "slope (deg)" in res.output
    assert "slope grid" not in res.output  # a metric DEM: the working grid is its own


def test_rasters_keep_the_dem_georeferencing(runner, tmp_path):
    s_out, a_out, png = tmp_path / "s.tif", tmp_path / "a.tif", tmp_path / "p.png"
    dem = map_path("plane")
    res = runner.invoke(
        main,
        [
            "terrain",
            str(dem),
            "--slope-out",
            str(s_out),
            "--aspect-out",
            str(a_out),
            "--plot",
            str(png),
        ],
    )
    assert res.exit_code == 0, res.output
    with rasterio.open(dem) as src, rasterio.open(s_out) as s, rasterio.open(a_out) as a:
        assert s.crs == src.crs and s.transform == src.transform and s.shape == src.shape
        assert a.crs == src.crs and a.transform == src.transform
        sl, asp = s.read(1), a.read(1)
        assert np.isnan(s.nodata) and np.isnan(sl[0, 0])  # border (gdaldem: -9999)
        assert s.units == ("deg",) and a.units == ("deg",)  # GDAL band units (#19)
        assert s.descriptions == ("slope",) and a.descriptions == ("aspect",)
        np.testing.assert_allclose(sl[1:-1, 1:-1], 10.0, atol=1e-4)
        np.testing.assert_allclose(asp[1:-1, 1:-1], 240.0, atol=1e-3)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000


def test_geographic_dem_written_on_its_own_grid(runner, tmp_path):
    """A lon/lat DEM's slope and aspect are written on its own grid (Horn computed there).

    Before issue 19 they were written on the UTM working grid, from Horn of the warped
    elevation: 0.72 deg median off Horn on the native grid (test_terrain_native.py holds
    the values against an independent reference).
    """
    s_out, a_out = tmp_path / "s.tif", tmp_path / "a.tif"
    args = ["terrain", "jacksboro", "--slope-out", str(s_out), "--aspect-out", str(a_out)]
    res = runner.invoke(main, [*args, "--json"])
    assert res.exit_code == 0, res.output
    r = json.loads(res.stdout)
    assert r["crs"] == "EPSG:4326" and r["working_crs"] == "EPSG:32616" and r["reprojected"]
    t = load_dem(map_path("jacksboro"))
    with rasterio.open(map_path("jacksboro")) as src, rasterio.open(s_out) as s:
        assert s.crs == src.crs and s.transform == src.transform and s.shape == src.shape
        sl = s.read(1, masked=True).filled(np.nan)
    with rasterio.open(a_out) as a:
        assert a.transform == t.native_grid.transform
        asp = a.read(1, masked=True).filled(np.nan)
    native = np.degrees(t.native_grid.slope)
    np.testing.assert_allclose(sl, native.astype(np.float32))
    np.testing.assert_allclose(asp, t.native_grid.aspect_deg.astype(np.float32))
    assert r["slope_max_deg"] == pytest.approx(float(np.nanmax(native)))
    assert r["source_shape"] == list(sl.shape) and r["shape"] == list(t.shape)
    # 3" cells at 36.4-36.7 N: 3/3600 deg x 111.0 km x cos(lat) by 92.5 m
    assert r["slope_grid"] == "source"
    x0, x1, y0, y1 = r["source_cell_m"]
    assert 74.3 < x0 < x1 < 74.8 and 92.4 < y0 <= y1 < 92.6
    text = runner.invoke(main, ["terrain", "jacksboro"]).output
    assert "slope grid     the DEM's own (344 x 403), cells 74.4..74.7 x 92.5..92.5 m" in text
    assert r["nodata_share"] == pytest.approx(float(np.isnan(t.native_grid.elevation).mean()))


def test_missing_file(runner, tmp_path):
    res = runner.invoke(main, ["terrain", str(tmp_path / "none.tif")])
    assert res.exit_code == 2
    assert "none.tif" in res.output and "does not exist" in res.output
    assert "hill, jacksboro, plane" in res.output


def test_multiband_needs_band(runner, tmp_path):
    p = tmp_path / "two.tif"
    with rasterio.open(
        p,
        "w",
        driver="GTiff",
        width=5,
        height=5,
        count=2,
        dtype="float32",
        crs="EPSG:32631",
        transform=from_origin(0, 5, 1, 1),
    ) as dst:
        dst.write(np.stack([np.zeros((5, 5)), np.ones((5, 5))]).astype(np.float32))
    res = runner.invoke(main, ["terrain", str(p)])
    assert res.exit_code == 2 and "2 bands" in res.output and "--band" in res.output
    res = runner.invoke(main, ["terrain", str(p), "--band", "2", "--json"])
    assert res.exit_code == 0 and json.loads(res.stdout)["elevation_max"] == 1.0
    res = runner.invoke(main, ["terrain", str(p), "--band", "3"])
    assert res.exit_code == 2 and "1..2" in res.output


def test_all_nodata(runner, tmp_path):
    p = tmp_path / "void.tif"
    with rasterio.open(
        p,
        "w",
        driver="GTiff",
        width=4,
        height=4,
        count=1,
        dtype="float32",
        crs="EPSG:32631",
        transform=from_origin(0, 4, 1, 1),
        nodata=-1,
    ) as dst:
        dst.write(np.full((1, 4, 4), -1, np.float32))
    res = runner.invoke(main, ["terrain", str(p)])
    assert res.exit_code == 1 and "no valid cell" in res.output and "void.tif" in res.output


def test_no_crs_dem_is_treated_as_metres(runner, tmp_path):
    p = tmp_path / "local.tif"
    z = np.add.outer(np.zeros(8), np.arange(8.0)).astype(np.float32)  # 1 m per metre
    with rasterio.open(
        p,
        "w",
        driver="GTiff",
        width=8,
        height=8,
        count=1,
        dtype="float32",
        transform=from_origin(0, 8, 1, 1),
    ) as dst:
        dst.write(z[None])
    res = runner.invoke(main, ["terrain", str(p), "--json"])
    assert res.exit_code == 0, res.output
    assert "warning: " in res.stderr and "no CRS" in res.stderr  # the CLI prints warnings
    r = json.loads(res.stdout)
    assert r["crs"] is None and r["slope_mean_deg"] == pytest.approx(45.0)
    assert math.isclose(r["slope_max_deg"], 45.0)
