"""energy_planner.io: atomic outputs, the GeoTIFF writer, GeoJSON with its CRS."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine
from shapely.geometry import Polygon, box

from energy_planner.io import (
    atomic_path,
    feature_collection,
    read_geometries,
    write_geojson,
    write_geotiff,
    write_json,
    write_text,
)

ROOT = Path(__file__).resolve().parents[1]


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(ROOT)}


# ---------------------------------------------------------------------- atomic
@pytest.mark.parametrize("unnamed", [True, False], ids=["unnamed", "named"])
def test_atomic_success_replaces_and_keeps_suffix(tmp_path, unnamed, monkeypatch):
    from faults import named_files  # tests/ helper

    if not unnamed:
        named_files(monkeypatch)
    dest = tmp_path / "map.tif"
    dest.write_text("old")
    with atomic_path(dest) as tmp:
        assert tmp.suffix == ".tif" and tmp != dest
        # an unnamed file (Linux) is not beside the destination; a named one is
        assert (tmp.parent == tmp_path) == (not unnamed)
        tmp.write_text("new")
        assert dest.read_text() == "old"
    assert dest.read_text() == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["map.tif"]


def test_atomic_failure_keeps_previous_and_removes_temp(tmp_path):
    dest = tmp_path / "model.json"
    write_json(dest, {"v": 1})
    with pytest.raises(ValueError), atomic_path(dest) as tmp:
        tmp.write_text('{"v": 2, "half')
        raise ValueError("boom")
    assert json.loads(dest.read_text()) == {"v": 1}
    assert [p.name for p in tmp_path.iterdir()] == ["model.json"]


def test_atomic_failure_without_previous_leaves_nothing(tmp_path):
    with pytest.raises(RuntimeError), atomic_path(tmp_path / "a.txt") as tmp:
        tmp.write_text("x")
        raise RuntimeError
    assert list(tmp_path.iterdir()) == []


def test_write_json_unserialisable_leaves_previous(tmp_path):
    dest = write_text(tmp_path / "a.json", "{}\n")
    with pytest.raises(TypeError):
        write_json(dest, {"x": object()})
    assert dest.read_text() == "{}\n"


def test_atomic_keeps_permissions_of_previous_file(tmp_path):
    dest = write_text(tmp_path / "a.txt", "1")
    os.chmod(dest, 0o640)
    write_text(dest, "2")
    assert dest.stat().st_mode & 0o777 == 0o640


def test_atomic_sigterm_restores_handler(tmp_path):
    before = signal.getsignal(signal.SIGTERM)
    with atomic_path(tmp_path / "a") as tmp:
        assert signal.getsignal(signal.SIGTERM) not in (before,)
        tmp.write_text("x")
    assert signal.getsignal(signal.SIGTERM) == before


def test_sigterm_mid_write_keeps_previous_file(tmp_path):
    """A process killed (SIGTERM) while writing leaves the previous file and no temp."""
    dest = tmp_path / "out.txt"
    dest.write_text("previous")
    code = textwrap.dedent(
        f"""
        import sys, time
        from energy_planner.io import atomic_path
        with atomic_path({str(dest)!r}) as tmp:
            with open(tmp, "w") as f:
                f.write("partial")
                f.flush()
                print("writing", flush=True)
                time.sleep(60)
        """
    )
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, env=_env())
    assert proc.stdout.readline().strip() == b"writing"
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=30) == 128 + signal.SIGTERM
    assert dest.read_text() == "previous"
    assert [p.name for p in tmp_path.iterdir()] == ["out.txt"]


# ---------------------------------------------------------------------- GeoTIFF
def test_write_geotiff_units_descriptions_nodata(tmp_path):
    data = np.array([[[1.0, np.nan], [2.0, 3.0]], [[0.0, 1.0], [np.nan, 5.0]]])
    p = write_geotiff(
        tmp_path / "x.tif", data, transform=Affine(10, 0, 500000, 0, -10, 5000000),
        crs="EPSG:32631", names=["a", "b"], units=["J/m", "deg"],
        descriptions=["cost", "slope"], tags={"software": "t"}, band_tags=[{"k": 1}, {}],
    )  # fmt: skip
    with rasterio.open(p) as src:
        assert src.units == ("J/m", "deg")
        assert src.descriptions == ("a", "b")
        assert np.isnan(src.nodata)
        assert src.tags()["software"] == "t"
        assert src.tags(1)["k"] == "1" and src.tags(2)["description"] == "slope"
        np.testing.assert_array_equal(src.read(), data.astype("float32"))


def test_write_geotiff_refuses_numeric_float_nodata(tmp_path):
    with pytest.raises(ValueError, match="NaN"):
        write_geotiff(tmp_path / "x.tif", np.zeros((2, 2)), transform=Affine.identity(),
                      crs=None, nodata=-9999)  # fmt: skip
    assert not (tmp_path / "x.tif").exists()


# ---------------------------------------------------------------------- GeoJSON
def test_feature_collection_rfc7946_and_native():
    sq = box(500000, 5000000, 500100, 5000100)
    doc = feature_collection([(sq, {"a": 1})], crs="EPSG:32631")
    assert "crs" not in doc
    lon, lat = np.array(doc["features"][0]["geometry"]["coordinates"][0]).T
    # UTM 31N easting 500000 is the central meridian, 3 deg E; 5000 km north ~ 45.1 deg N
    assert np.allclose(lon.min(), 3.0, atol=1e-9) and 45.0 < lat.min() < 45.2
    nat = feature_collection([(sq, {})], crs="EPSG:32631", native=True)
    assert nat["crs"]["properties"]["name"] == "EPSG:32631"
    assert (500000.0, 5000000.0) in nat["features"][0]["geometry"]["coordinates"][0]


def test_read_geometries_default_is_lonlat(tmp_path):
    p = write_geojson(tmp_path / "k.geojson", [(box(3.0, 45.0, 3.001, 45.001), {})],
                      crs="OGC:CRS84")  # fmt: skip
    g = read_geometries(p)
    assert g.crs == "OGC:CRS84" and g[0].geom_type == "Polygon"


def test_read_geometries_declared_crs_round_trip(tmp_path):
    sq = box(500000, 5000000, 500100, 5000100)
    p = write_geojson(tmp_path / "k.geojson", [(sq, {})], crs="EPSG:32631", native=True)
    g = read_geometries(p)
    assert g.crs == "EPSG:32631" and g[0].equals(sq)


def test_read_geometries_projected_without_crs_is_an_error(tmp_path):
    p = tmp_path / "k.geojson"
    p.write_text(
        json.dumps(Polygon([(5e5, 5e6), (5e5 + 9, 5e6), (5e5, 5e6 + 9)]).__geo_interface__)
    )
    with pytest.raises(ValueError, match="RFC 7946.*declare it"):
        read_geometries(p)


def test_read_geometries_missing_file(tmp_path):
    with pytest.raises(ValueError, match="does not exist"):
        read_geometries(tmp_path / "nope.geojson")


def test_atomic_new_path_for_directory_writers(tmp_path):
    """create=False: a fresh name (a ROS 2 bag writer makes a folder there)."""
    dest = tmp_path / "run1"
    with atomic_path(dest, create=False) as tmp:
        assert not tmp.exists() and tmp.name == "run1"
        tmp.mkdir()
        (tmp / "data.mcap").write_text("x")
        assert not dest.exists()
    assert (dest / "data.mcap").read_text() == "x"
    with pytest.raises(RuntimeError), atomic_path(tmp_path / "run2", create=False) as tmp:
        tmp.mkdir()
        raise RuntimeError
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run1"]
