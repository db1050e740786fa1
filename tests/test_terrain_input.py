"""Bad input to the terrain layer (issue 13): coordinates in the wrong CRS, rasters too
large for memory, all-nodata DEMs; each gives a project error with structured fields."""

from __future__ import annotations

import json
import resource
import time

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner
from rasterio.transform import from_origin

from energy_planner.cli import main
from energy_planner.errors import (
    CoordinateError,
    DEMError,
    EnergyPlannerError,
    OutsideMapError,
    RasterTooLargeError,
)
from energy_planner.maps import map_path
from energy_planner.terrain import MEMORY_CAP_ENV, Terrain, check_memory, load_dem, memory_cap
from energy_planner.terrain.memory import parse_size


@pytest.fixture(scope="module")
def jacksboro():
    return load_dem(map_path("jacksboro"))


# ---------------------------------------------------------------------- coordinates
def test_metric_coordinates_on_a_lonlat_dem(jacksboro):
    """``plan --dem jacksboro --start 741700,4048300`` gave a PROJ traceback."""
    with pytest.raises(CoordinateError) as exc:
        jacksboro.to_work(741700.0, 4048300.0)
    e = exc.value
    assert isinstance(e, OutsideMapError) and isinstance(e, ValueError)
    msg = str(e)
    for needle in (
        "(741700, 4048300)",
        "EPSG:4326",
        "geographic",
        "jacksboro_fault_dem.tif",
        "longitude,latitude",
        "lon -84.41",
        "lat 36.44",
    ):
        assert needle in msg, needle
    assert e.value == (741700.0, 4048300.0) and e.crs == "EPSG:4326"
    left, bottom, right, top = e.bounds
    assert (left, bottom, right, top) == pytest.approx(jacksboro.source_bounds)
    assert -84.5 < left < right < -84.0 and 36.4 < bottom < top < 36.8
    # the point is on the working UTM grid: the hint gives its lon/lat, which converts back
    assert "EPSG:32616" in e.hint
    lon, lat = (
        float(v) for v in e.hint.split("at lon ")[1].split(": ")[0].replace("lat ", "").split(", ")
    )
    x, y = jacksboro.to_work(lon, lat)
    assert (x, y) == pytest.approx((741700.0, 4048300.0), abs=0.05)


def test_array_conversion_names_the_first_bad_point(jacksboro):
    with pytest.raises(CoordinateError, match=r"point 1; 1 of 3 points fail") as exc:
        jacksboro.to_work([-84.2, -84.2, -84.3], [36.6, 4048300.0, 36.5])
    assert exc.value.index == 1 and exc.value.n_bad == 1
    x, y = jacksboro.to_work([-84.2, -84.3], [36.6, 36.5])  # good points still convert
    assert np.all(np.isfinite(x)) and np.all(np.isfinite(y))


def test_nan_coordinates_are_named():
    t = load_dem(map_path("jacksboro"))
    with pytest.raises(CoordinateError, match="nan"):
        t.to_work(float("nan"), 36.6)


def test_projected_dem_passes_coordinates_through():
    t = Terrain.from_function(lambda x, y: 0 * x, size=(10, 10))
    assert t.to_work(1e9, -1e9) == (1e9, -1e9)  # off the map: the caller's bounds check


# ---------------------------------------------------------------------- memory cap
@pytest.fixture(scope="module")
def huge_tif(tmp_path_factory):
    """A 50000 x 50000 float32 GeoTIFF of about 300 KB (sparse tiles, as in issue 13)."""
    p = tmp_path_factory.mktemp("big") / "huge.tif"
    with rasterio.open(
        p,
        "w",
        driver="GTiff",
        width=50000,
        height=50000,
        count=1,
        dtype="float32",
        crs="EPSG:32631",
        transform=from_origin(5e5, 5e6, 1, 1),
        tiled=True,
        compress="deflate",
        sparse_ok=True,
    ):
        pass
    assert p.stat().st_size < 1_000_000
    return p


def test_huge_raster_is_refused_before_reading(huge_tif, monkeypatch):
    monkeypatch.setenv(MEMORY_CAP_ENV, "4G")
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t0 = time.perf_counter()
    with pytest.raises(RasterTooLargeError) as exc:
        load_dem(huge_tif)
    assert time.perf_counter() - t0 < 5.0
    # peak RSS (KiB on Linux) grew by far less than one decoded band (9.3 GiB)
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss0 < 500_000
    e = exc.value
    assert isinstance(e, MemoryError) and isinstance(e, DEMError)
    assert e.shape == (50000, 50000) and e.size_bytes == 50000 * 50000 * 64
    assert e.cap_bytes == 4 * 2**30
    msg = str(e)
    for needle in (
        "huge.tif",
        "50000 x 50000",
        "149 GiB",
        "4 GiB",
        MEMORY_CAP_ENV,
        "window",
        "coarser grid",
        "--decimate 7",
        "energy-map --dask",
    ):
        assert needle in msg, needle


def test_cap_can_be_raised_or_switched_off(monkeypatch):
    monkeypatch.setenv(MEMORY_CAP_ENV, "off")
    assert memory_cap() is None
    check_memory((10**6, 10**6), 64, "x")  # no cap: no error
    monkeypatch.setenv(MEMORY_CAP_ENV, "25%")
    half = memory_cap()
    monkeypatch.setenv(MEMORY_CAP_ENV, "50%")
    assert memory_cap() == pytest.approx(2 * half, rel=1e-6)
    monkeypatch.delenv(MEMORY_CAP_ENV)
    assert memory_cap() == pytest.approx(2 * half, rel=1e-6)  # the default is 50 %
    monkeypatch.setenv(MEMORY_CAP_ENV, "lots")
    with pytest.raises(DEMError, match="lots") as exc:
        memory_cap()
    assert exc.value.param == MEMORY_CAP_ENV
    assert parse_size("1.5GiB") == 3 * 2**29 and parse_size("2GB") == 2 * 10**9


def test_terrain_cli_refuses_huge_raster(huge_tif, monkeypatch):
    monkeypatch.setenv(MEMORY_CAP_ENV, "2G")
    res = CliRunner().invoke(main, ["terrain", str(huge_tif)])
    assert res.exit_code == 1 and "Traceback" not in res.output
    assert "50000 x 50000" in res.output and "energy-map --dask" in res.output


def test_energy_cli_refuses_huge_raster(huge_tif, tmp_path, monkeypatch):
    monkeypatch.setenv(MEMORY_CAP_ENV, "2G")
    w = tmp_path / "w.csv"
    w.write_text("x,y\n500010,4999990\n500020,4999990\n")
    res = CliRunner().invoke(main, ["energy", "--dem", str(huge_tif), "--waypoints", str(w)])
    assert res.exit_code != 0 and isinstance(res.exception, SystemExit), res.output
    assert "50000 x 50000" in res.output


# ---------------------------------------------------------------------- all nodata
def _void(path, bands):
    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        width=4,
        height=4,
        count=bands,
        dtype="float32",
        crs="EPSG:32631",
        transform=from_origin(0, 4, 1, 1),
        nodata=-1,
    ) as dst:
        dst.write(np.full((bands, 4, 4), -1, np.float32))
    return path


def test_all_nodata_one_band_does_not_suggest_another_band(tmp_path):
    p = _void(tmp_path / "void.tif", 1)
    with pytest.raises(DEMError) as exc:
        load_dem(p)
    assert "band" not in str(exc.value).replace(str(p), "")
    assert "nodata (-1)" in str(exc.value) and exc.value.param is None
    res = CliRunner().invoke(main, ["terrain", str(p)])
    assert res.exit_code == 1 and "--band" not in res.output and "void.tif" in res.output


def test_energy_cli_all_nodata_one_band_hint_fits(tmp_path):
    (tmp_path / "bands").mkdir()  # a folder name the hint must not react to
    p = _void(tmp_path / "bands" / "void.tif", 1)
    res = CliRunner().invoke(main, ["energy", "--dem", str(p), "--waypoints", str(p)])
    assert res.exit_code == 1 and "void.tif" in res.output  # bad content: data error
    assert "--band" not in res.output


def test_all_nodata_band_of_several_suggests_band(tmp_path):
    p = _void(tmp_path / "void2.tif", 2)
    with pytest.raises(DEMError, match="band 2 of DEM .* 2 bands") as exc:
        load_dem(p, band=2)
    assert exc.value.param == "band"
    res = CliRunner().invoke(main, ["terrain", str(p), "--band", "1"])
    assert res.exit_code == 2 and "--band" in res.output


def test_error_fields_round_trip_to_json(tmp_path):
    p = _void(tmp_path / "void.tif", 1)
    with pytest.raises(EnergyPlannerError) as exc:
        load_dem(p)
    d = json.loads(json.dumps(exc.value.to_dict()))
    assert d["error"] == "DEMError" and d["path"] == str(p)


def test_energy_cli_metric_waypoints_on_lonlat_dem(tmp_path):
    w = tmp_path / "w.csv"
    w.write_text("x,y\n741700,4048300\n742000,4048600\n")
    res = CliRunner().invoke(
        main, ["energy", "--dem", str(map_path("jacksboro")), "--waypoints", str(w)]
    )
    assert res.exit_code == 1 and isinstance(res.exception, SystemExit), res.output
    assert "(741700, 4048300)" in res.output and "EPSG:4326" in res.output
    assert "longitude,latitude" in res.output


def test_truncated_raster_is_a_dem_io_error(tmp_path):
    """Found by tests/test_fuzz_loaders.py: a file GDAL opens but cannot read gave a
    RasterioIOError traceback."""
    from energy_planner.errors import DEMIOError

    p = tmp_path / "grid.asc"
    p.write_text("ncols 3\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2 3\n")
    with pytest.raises(DEMIOError) as exc:  # the read fails before the CRS is looked at
        load_dem(p)
    assert "cannot read band 1" in str(exc.value) and exc.value.path == str(p)
    assert isinstance(exc.value, OSError)


# ---------------------------------------------------------------------- the remedies
def test_bounds_reads_the_same_cells_as_a_slice():
    full = load_dem(map_path("hill"))
    x0, y0 = full.bounds[:2]
    part = load_dem(map_path("hill"), bounds=(x0 + 10.2, y0 + 20.5, x0 + 40, y0 + 50))
    assert part.bounds == (x0 + 10, y0 + 20, x0 + 40, y0 + 50)  # whole cells covering it
    r0 = int(round((full.bounds[3] - part.bounds[3]) / full.resolution[1]))
    c0 = int(round((part.bounds[0] - full.bounds[0]) / full.resolution[0]))
    np.testing.assert_array_equal(part.elevation, full.elevation[r0 : r0 + 30, c0 : c0 + 30])


def test_decimate_averages_blocks():
    full = load_dem(map_path("hill"))
    d = load_dem(map_path("hill"), decimate=4)
    assert d.shape == (50, 50) and d.resolution == (4.0, 4.0) and d.bounds == full.bounds
    blocks = full.elevation.reshape(50, 4, 50, 4).mean(axis=(1, 3))
    np.testing.assert_allclose(d.elevation, blocks, rtol=1e-6)  # float32 file


def test_window_of_the_huge_raster_loads(huge_tif, monkeypatch):
    monkeypatch.setenv(MEMORY_CAP_ENV, "2G")
    t = load_dem(huge_tif, bounds=(5e5, 5e6 - 300, 5e5 + 400, 5e6))
    assert t.shape == (300, 400)
    res = CliRunner().invoke(
        main, ["terrain", str(huge_tif), "--bounds", "500000,4999700,500400,5000000", "--json"]
    )
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["shape"] == [300, 400]
    # the error's hint names a decimation that fits
    with pytest.raises(RasterTooLargeError, match=r"decimate=9") as exc:
        load_dem(huge_tif)
    k = 9
    assert (50000 / k) ** 2 * 64 <= exc.value.cap_bytes < (50000 / (k - 1)) ** 2 * 64


def test_bad_bounds(tmp_path):
    with pytest.raises(DEMError, match="do not overlap") as exc:
        load_dem(map_path("hill"), bounds=(0, 0, 1, 1))
    assert exc.value.param == "bounds"
    res = CliRunner().invoke(main, ["terrain", "hill", "--bounds", "1,2,3"])
    assert res.exit_code == 2 and "XMIN,YMIN,XMAX,YMAX" in res.output
    res = CliRunner().invoke(main, ["terrain", "hill", "--bounds", "0,0,1,1"])
    assert res.exit_code == 2 and "do not overlap" in res.output
