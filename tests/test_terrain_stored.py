"""A DEM read back from the cache folder (``energy``'s warm start) is the DEM GDAL reads.

Every check compares the read-back Terrain with ``load_dem`` of the same file (rasterio,
GDAL): the same numbers, the same CRS answers; and a changed file, a new sidecar or a
geographic DEM are read by GDAL again.
"""

from __future__ import annotations

import pickle
import shutil

import numpy as np
import pytest
import rasterio
from _energy_process import energy_in_process
from rasterio.crs import CRS

from energy_planner.maps import map_path
from energy_planner.terrain import load_dem
from energy_planner.terrain.stored import StoredCRS, keep_stored, read_stored


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    """A fresh cache folder; a copy of the bundled hill in its own folder."""
    monkeypatch.setenv("ENERGY_PLANNER_CACHE", str(tmp_path / "cache"))
    (tmp_path / "dem").mkdir()
    dem = tmp_path / "dem" / "hill.tif"
    shutil.copy(map_path("hill"), dem)
    return dem


def _keep(dem, band=None):
    t, key = read_stored(dem, band)
    assert t is None and key is not None
    fresh = load_dem(dem, band=band)
    assert keep_stored(key, fresh)
    return fresh


def test_read_back_is_the_gdal_read(cache):
    fresh = _keep(cache)
    back, _ = read_stored(cache)
    assert isinstance(back.crs, StoredCRS) and back.source_crs is back.crs
    np.testing.assert_array_equal(back.elevation, fresh.elevation)
    np.testing.assert_array_equal(back.grad, fresh.grad)  # Horn again, bit for bit
    assert back.transform == fresh.transform
    assert back.source_transform == fresh.source_transform
    assert back.source_shape == fresh.source_shape and back.path == fresh.path
    assert back.native is None
    # the CRS answers without rasterio are rasterio's
    real = fresh.crs
    assert str(back.crs) == str(real) == "EPSG:32631" and repr(back.crs) == repr(real)
    assert back.crs.to_epsg() == real.to_epsg() == 32631
    assert back.crs.is_geographic is False and back.crs.is_projected is True
    assert back.crs.linear_units_factor == real.linear_units_factor == ("metre", 1.0)
    assert back.crs.to_wkt() == real.to_wkt()
    # and it is that CRS for everything else, both ways
    assert back.crs == real and real == back.crs and not (back.crs != real)
    assert back.crs != CRS.from_epsg(32632) and CRS.from_epsg(32632) != back.crs
    assert (back.crs == None) is (real == None) is False  # noqa: E711 - as rasterio's
    assert back.crs == "EPSG:32631" and real == "EPSG:32631"
    assert back.crs.to_dict() == real.to_dict()
    assert CRS.from_user_input(back.crs) == real
    assert hash(back.crs) == hash(real)
    again = pickle.loads(pickle.dumps(back.crs))
    assert isinstance(again, StoredCRS) and again == real and str(again) == str(real)
    # a transform through rasterio with it: the same numbers as with the real CRS
    from rasterio.warp import transform

    xy = ([500058.0], [5000046.0])
    assert transform(back.crs, "EPSG:4326", *xy) == transform(real, "EPSG:4326", *xy)
    # and the Terrain samples the same slopes
    s1, s2 = back.sample(500058.0, 5000046.0), fresh.sample(500058.0, 5000046.0)
    assert s1.slope == s2.slope and s1.elevation == s2.elevation


def test_a_changed_file_or_a_new_sidecar_is_read_again(cache):
    _keep(cache)
    with rasterio.open(cache, "r+") as d:  # new values, same size
        d.write(d.read(1) * 1.5, 1)
    t, key = read_stored(cache)
    assert t is None
    fresh = load_dem(cache)
    assert keep_stored(key, fresh)
    back, _ = read_stored(cache)
    np.testing.assert_array_equal(back.elevation, fresh.elevation)
    # a PAM sidecar that halves the elevations: GDAL reads it, so a new entry
    aux = cache.parent / "hill.tif.aux.xml"
    aux.write_text(
        '<PAMDataset><PAMRasterBand band="1"><Offset>0</Offset><Scale>0.5</Scale>'
        "</PAMRasterBand></PAMDataset>"
    )
    t, key = read_stored(cache)
    assert t is None
    halved = load_dem(cache)
    np.testing.assert_allclose(halved.elevation, 0.5 * fresh.elevation, rtol=1e-15)
    keep_stored(key, halved)
    np.testing.assert_array_equal(read_stored(cache)[0].elevation, halved.elevation)
    aux.unlink()  # back to the entry of the file alone
    np.testing.assert_array_equal(read_stored(cache)[0].elevation, fresh.elevation)


def test_only_metric_dems_with_a_crs_are_kept(cache, tmp_path):
    geo = map_path("jacksboro_fault_dem")
    t, key = read_stored(geo)
    assert t is None
    warped = load_dem(geo)
    assert warped.native is not None and not keep_stored(key, warped)
    assert read_stored(geo)[0] is None
    # the band is part of the entry
    _keep(cache, band=1)
    assert read_stored(cache, 1)[0] is not None and read_stored(cache)[0] is None
    # a path GDAL reads through a virtual file system is never kept
    assert read_stored(f"/vsizip/{tmp_path}/x.zip/hill.tif") == (None, None)


def test_the_folder_keeps_the_most_recently_used(cache, monkeypatch):
    import energy_planner.terrain.stored as stored

    monkeypatch.setattr(stored, "KEEP", 2)
    monkeypatch.setattr(stored._prune, "__defaults__", (2,))
    names = []
    for k in range(3):
        dem = cache.parent / f"h{k}.tif"
        shutil.copy(cache, dem)
        _keep(dem)
        names.append(dem)
    folder = stored._entry("x")[0].parent
    assert len(list(folder.glob("dem_*.json"))) == 2 == len(list(folder.glob("dem_*.npy")))
    assert read_stored(names[0])[0] is None and read_stored(names[2])[0] is not None


def test_energy_twice_the_second_without_rasterio(tmp_path):
    """The first ``energy`` reads the DEM with GDAL and keeps it; the second reads it
    back without importing rasterio and prints the same JSON, to the last digit."""
    dem = tmp_path / "hill_copy.tif"
    shutil.copy(map_path("hill"), dem)
    wp = tmp_path / "w.csv"
    wp.write_text("x,y\n500058,5000046\n500058,5000080\n500090,5000080\n")
    runs = [energy_in_process(dem, wp, "rasterio") for _ in range(2)]
    assert [r["imported"]["rasterio"] for r in runs] == [True, False]
    assert runs[0]["out"] == runs[1]["out"]
    assert runs[1]["out"]["working_crs"] == "EPSG:32631"


def test_the_energy_door_shows_a_read_that_warns_and_keeps_it_not(cache):
    """``load_terrain(stored=True)``: a DEM without a CRS warns on every read (none kept);
    a clean DEM is read with GDAL once, then read back."""
    from energy_planner.cli.energy import load_terrain

    with rasterio.open(cache) as s:
        prof, a = dict(s.profile), s.read(1)
    prof.pop("crs")
    nocrs = cache.parent / "nocrs.tif"
    with rasterio.open(nocrs, "w", **prof) as d:
        d.write(a, 1)
    for _ in range(2):
        with pytest.warns(UserWarning, match="has no CRS"):
            t = load_terrain(nocrs, None, stored=True)
        assert t.crs is None
    assert read_stored(nocrs)[0] is None
    first = load_terrain(cache, None, stored=True)
    second = load_terrain(cache, None, stored=True)
    assert not isinstance(first.crs, StoredCRS) and isinstance(second.crs, StoredCRS)
    np.testing.assert_array_equal(first.grad, second.grad)
