"""How an energy map is written: the summary bands' compiled pass against NumPy, the
compression options round-tripping the values exactly, the three ways of computing a
map (in memory, windowed, dask) writing the same values, bit for bit, and the default
uint16 encoding against the float32 map."""

from __future__ import annotations

import json

import numpy as np
import pytest
import rasterio
from affine import Affine
from b1_model import b1_model  # tests/ helper
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from energy_planner.cli import main
from energy_planner.energymap import energy_map
from energy_planner.energymap._summary import encode, summary_bands
from energy_planner.energymap.encoding import read_band
from energy_planner.errors import EnergyMapError
from energy_planner.io import COMPRESSIONS, compression_options
from energy_planner.request import Limits, Request
from energy_planner.terrain import load_dem

MODEL = b1_model()


def numpy_summary(best: np.ndarray, ang: np.ndarray) -> np.ndarray:
    """The summary bands by NumPy's reductions (how the map computed them before)."""
    out = np.empty((4, *best.shape[1:]), np.float32)
    valid = ~np.isnan(best[0])
    with np.errstate(invalid="ignore", divide="ignore"):
        cheapest = best.min(axis=0)
        dearest = best.max(axis=0)
        arg = np.argmin(np.where(np.isnan(best), np.inf, best), axis=0)
        out[0], out[1] = cheapest, dearest
        out[2] = np.where(valid, dearest / cheapest, np.nan)
    out[3] = np.where(valid & np.isfinite(cheapest), np.degrees(ang)[arg], np.nan)
    return out


# + 0.0: no negative zero (NumPy's SIMD min returns either zero of a tie; costs are never -0)
values = st.sampled_from([0.0, 1.0, 2.5, 600.0, np.inf, np.nan]) | st.floats(
    -1e4, 1e4, width=32
).map(lambda v: v + 0.0)


def _geographic_corner(dem, tmp_path):
    """A 48 x 48 corner of ``dem`` declared in lon/lat (EPSG:4326), written to ``geo.tif``."""
    with rasterio.open(dem) as src:
        z = src.read(1)[:48, :48]
        prof = dict(src.profile, crs="EPSG:4326", width=48, height=48,
                    transform=Affine(2e-5, 0, 3.0, 0, -2e-5, 45.0))  # fmt: skip
    geo = tmp_path / "geo.tif"
    with rasterio.open(geo, "w", **prof) as dst:
        dst.write(z, 1)
    return geo


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 9).flatmap(lambda n: arrays(np.float32, (n, 3, 5), elements=values)))
def test_summary_bands_equal_numpys_reductions(best):
    """cheapest, dearest, their ratio and the first cheapest heading, NaN and inf included."""
    n = best.shape[0]
    ang = 2 * np.pi * np.arange(n) / n
    out = np.full((4, 3, 5), 7.0, np.float32)
    summary_bands(best, np.degrees(ang), out)
    np.testing.assert_array_equal(out, numpy_summary(best, ang))


@pytest.fixture(scope="module")
def hills(tmp_path_factory):
    """200 x 140 cells of hills with a nodata patch (windows of 128 rows: two of them)."""
    d = tmp_path_factory.mktemp("emw")
    rows, cols = 200, 140
    x = np.arange(cols) * 2.0
    y = np.arange(rows)[:, None] * 2.0
    z = 30 * np.sin(x / 50) * np.cos(y / 35) + 0.05 * x + 3 * np.sin((x + 2 * y) / 11)
    z[120:132, 40:70] = -9999.0
    path = d / "hills.tif"
    prof = dict(
        driver="GTiff", width=cols, height=rows, count=1, dtype="float32", nodata=-9999.0,
        crs="EPSG:32631", transform=Affine(2.0, 0, 500000.0, 0, -2.0, 5000400.0),
    )  # fmt: skip
    with rasterio.open(path, "w", **prof) as dst:
        dst.write(z.astype(np.float32), 1)
    ref = d / "ref.tif"
    energy_map(load_dem(path), ref, MODEL, headings=8)
    with rasterio.open(ref) as src:
        return path, src.read()


def read(path):
    with rasterio.open(path) as src:
        return src.read(), src.compression, src.profile


def test_three_paths_write_the_same_values(hills, tmp_path):
    """In memory (Terrain), windowed and dask (chunks of 64) maps: max difference 0."""
    dem, ref = hills
    assert np.isfinite(ref).any() and np.isnan(ref).any()
    win, dsk = tmp_path / "win.tif", tmp_path / "dask.tif"
    assert energy_map(dem, win, MODEL, headings=8).mode == "windowed"
    assert energy_map(dem, dsk, MODEL, headings=8, use_dask=True, chunk=64).mode == "dask"
    for path in (win, dsk):
        np.testing.assert_array_equal(read(path)[0], ref)


@pytest.mark.parametrize("compress", COMPRESSIONS)
def test_compression_round_trips_the_values(hills, tmp_path, compress):
    """Every compression, windowed and dask: the file says which, the values are the map's."""
    dem, ref = hills
    for use_dask in (False, True):
        out = tmp_path / f"{compress}_{use_dask}.tif"
        energy_map(dem, out, MODEL, headings=8, compress=compress, use_dask=use_dask, chunk=128)
        data, comp, prof = read(out)
        np.testing.assert_array_equal(data, ref)
        assert (comp.value.lower() if comp else "none") == compress
        # the default bands; float32: the test model prices steep descents near zero, its
        # anisotropy passes uint16's range (test_uint16_map_is_the_float32_map_...)
        assert prof["dtype"] == "float32" and prof["count"] == 8 + 4


def test_compression_options_and_errors(hills, tmp_path):
    assert compression_options("deflate") == {"compress": "deflate", "predictor": 3, "zlevel": 1}
    assert compression_options("ZSTD", floating=False, threads=2) == {
        "compress": "zstd", "predictor": 2, "zstd_level": 1, "NUM_THREADS": "2"
    }  # fmt: skip
    with pytest.raises(ValueError, match="lzma.*deflate, zstd, none"):
        compression_options("lzma")
    dem, _ = hills
    with pytest.raises(EnergyMapError, match="'lzma' is not one of deflate, zstd, none"):
        energy_map(dem, tmp_path / "x.tif", MODEL, compress="lzma")
    assert not (tmp_path / "x.tif").exists()


def test_cli_compress_option(hills, tmp_path):
    dem, ref = hills
    model = MODEL.save(tmp_path / "m.json")
    out = tmp_path / "cli.tif"
    base = ["energy-map", str(dem), "--out", str(out), "--model", str(model), "--headings", "8"]
    r = CliRunner().invoke(main, [*base, "--compress", "zstd", "--json"])
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["mode"] == "windowed"
    data, comp, _ = read(out)
    assert comp.value.lower() == "zstd"
    np.testing.assert_array_equal(data, ref)
    r = CliRunner().invoke(main, [*base, "--compress", "lzma"])
    assert r.exit_code == 2 and "deflate" in r.output and "zstd" in r.output


def test_default_bands_are_the_full_maps_best_and_summary_bands(hills, tmp_path):
    """bands="best" (the default) writes the full layout's last N + 4 bands, bit for bit,
    named so, in every way of computing a map (in memory, windowed, dask, and a
    geographic DEM resampled onto its grid); --bands all writes all 2 N + 4, --bands summary
    the last 4."""
    from energy_planner.energymap import band_names

    dem, ref = hills
    assert ref.shape[0] == 8 + 4  # the fixture's map: the default bands
    full = tmp_path / "full.tif"
    energy_map(load_dem(dem), full, MODEL, headings=8, bands="all")
    data = read(full)[0]
    assert data.shape[0] == 2 * 8 + 4
    np.testing.assert_array_equal(data[8:], ref)
    for path, kw in ((tmp_path / "w.tif", {}), (tmp_path / "d.tif", {"use_dask": True})):
        energy_map(dem, path, MODEL, headings=8, chunk=64, **kw)
        with rasterio.open(path) as src:
            assert list(src.descriptions) == band_names(8, "best")
            assert src.tags()["bands"] == "best"
            np.testing.assert_array_equal(src.read(), data[8:])
    energy_map(dem, tmp_path / "s.tif", MODEL, headings=8, bands="summary")
    with rasterio.open(tmp_path / "s.tif") as src:
        assert list(src.descriptions) == band_names(8, "summary") == band_names(8)[16:]
        np.testing.assert_array_equal(src.read(), data[16:])
    # a geographic DEM (a corner of the hills): resampled onto its grid band by band
    geo = _geographic_corner(dem, tmp_path)
    a, b = tmp_path / "ga.tif", tmp_path / "gb.tif"
    energy_map(geo, a, MODEL, headings=8, bands="all")
    energy_map(geo, b, MODEL, headings=8)
    ga, gb = read(a)[0], read(b)[0]
    assert np.isfinite(gb).any()
    np.testing.assert_array_equal(gb, ga[8:])
    energy_map(geo, tmp_path / "gs.tif", MODEL, headings=8, bands="summary")
    np.testing.assert_array_equal(read(tmp_path / "gs.tif")[0], ga[16:])
    with pytest.raises(EnergyMapError, match="bands 'some'"):
        energy_map(dem, tmp_path / "x.tif", MODEL, headings=8, bands="some")


@settings(max_examples=60, deadline=None)
@given(arrays(np.float32, (2, 3, 5), elements=st.floats(0, 16383, width=32) | values))
def test_uint16_codes_are_the_nearest_step(block):
    """encode: code = 1 + the nearest multiple of the step (0 NaN, 65535 inf), counted
    out of range where a finite value (or -inf) has no code; by NumPy's rounding here."""
    steps = np.array([0.25, 1 / 1024])
    out = np.full(block.shape, 7, np.uint16)
    bad = encode(block, 1.0 / steps, out)
    x = block.astype(np.float64) / steps[:, None, None]
    with np.errstate(invalid="ignore"):
        inside = np.isfinite(x) & (x >= -0.5) & (x < 65533.5)
    assert bad == int((~inside & ~np.isnan(x) & ~np.isposinf(x)).sum())
    assert (out[np.isnan(x)] == 0).all() and (out[np.isposinf(x)] == 65535).all()
    got = (out[inside].astype(np.float64) - 1) * np.broadcast_to(steps[:, None, None], x.shape)[
        inside
    ]
    exact = block.astype(np.float64)[inside]
    assert np.abs(got - exact).max(initial=0) <= np.broadcast_to(steps[:, None, None] / 2, x.shape)[
        inside
    ].max(initial=0)


def test_uint16_map_is_the_float32_map_to_half_a_step(hills, tmp_path):
    """The default encoding against the float map computed alongside (the bundled model):
    every band within half its step (0.125 J/m; 1/2048 of a ratio; the headings exactly),
    the same NaN and inf cells, decoded by the file's own GDAL scale, offset and nodata
    (rasterio's masked read) as any GDAL reader would, and by read_band; a map beyond
    the range (the test model: anisotropy up to 1e7) writes float32 and says so."""
    from energy_planner.model import EnergyModel

    dem, _ = hills
    model = EnergyModel.default()
    req = Request(limits=Limits(max_slope_deg=20.0, max_cross_slope_deg=12.0))
    f, q = tmp_path / "f.tif", tmp_path / "q.tif"
    ff = energy_map(dem, f, model, headings=8, request=req, encoding="float32", bands="all")
    res = energy_map(dem, q, model, headings=8, request=req, bands="all")
    assert not res.notes
    with rasterio.open(f) as a, rasterio.open(q) as b:
        assert a.dtypes[0] == "float32" and set(b.dtypes) == {"uint16"}
        assert b.tags()["inf_code"] == "65535"
        for i in range(1, b.count + 1):
            want = a.read(i).astype(np.float64)
            step = b.scales[i - 1]
            name = b.descriptions[i - 1]
            expect = {"anisotropy": 1 / 1024, "cheapest_heading_deg": 1 / 128}.get(name, 0.25)
            assert step == expect and b.offsets[i - 1] == -step
            codes = b.read(i, masked=True)  # nodata (code 0) masked by GDAL's declaration
            got = codes.filled(0).astype(np.float64) * step - step
            assert np.array_equal(codes.mask, np.isnan(want)), name
            assert np.array_equal(codes.filled(0) == 65535, np.isposinf(want)), name
            ok = np.isfinite(want)
            assert ok.any() and np.abs(got[ok] - want[ok]).max() <= step / 2, name
            np.testing.assert_array_equal(read_band(b, i)[ok], got[ok])
            if name == "cheapest_heading_deg":  # multiples of 45: exactly
                np.testing.assert_array_equal(got[ok], want[ok])
        assert np.isposinf(a.read()).any() and np.isnan(a.read()).any()
    assert res.stats == ff.stats  # from the float values in both
    # the other ways of computing a map encode alike: dask (the same codes as the
    # windowed map) and a geographic DEM resampled onto its grid (band by band)
    d = tmp_path / "d.tif"
    energy_map(dem, d, model, headings=8, request=req, bands="all", use_dask=True, chunk=64)
    with rasterio.open(q) as b, rasterio.open(d) as c:
        assert c.dtypes[0] == "uint16"
        np.testing.assert_array_equal(c.read(), b.read())
    geo = _geographic_corner(dem, tmp_path)
    gf, gq = tmp_path / "gf.tif", tmp_path / "gq.tif"
    energy_map(geo, gf, model, headings=8, encoding="float32")
    energy_map(geo, gq, model, headings=8)
    with rasterio.open(gf) as a, rasterio.open(gq) as b:
        assert b.dtypes[0] == "uint16"
        for i in range(1, b.count + 1):
            want, got = a.read(i).astype(np.float64), read_band(b, i)
            assert np.array_equal(np.isnan(want), np.isnan(got))
            ok = np.isfinite(want)
            assert ok.any() and np.abs(got[ok] - want[ok]).max() <= b.scales[i - 1] / 2
    wide = energy_map(dem, q, MODEL, headings=8)
    with rasterio.open(q) as b:
        assert b.dtypes[0] == "float32" and b.tags()["encoding"] == "float32"
        assert np.nanmax(b.read(b.descriptions.index("anisotropy") + 1)) > 64
    assert any("written as float32" in n for n in wide.notes)
    with pytest.raises(EnergyMapError, match="encoding 'f16'"):
        energy_map(dem, tmp_path / "x.tif", MODEL, encoding="f16")


def test_writer_thread_compresses_the_same_file_as_gdals_workers(hills, tmp_path, monkeypatch):
    """uint16 tiles compressed by the writing thread (two cores) or by GDAL's workers
    (more cores): the same codes, scales and statistics, and the same compressed bytes."""
    import energy_planner.energymap.result as result

    dem, _ = hills
    maps = {}
    for threads in (None, "ALL_CPUS"):
        monkeypatch.setattr(result, "_compress_threads", lambda enc, cores=None, t=threads: t)
        out = tmp_path / f"{threads}.tif"
        res = energy_map(dem, out, headings=8)  # the bundled model: uint16 codes
        with rasterio.open(out) as src:
            assert src.dtypes[0] == "uint16" and src.block_shapes[0] == (128, 128)
            maps[threads] = (src.read(), src.scales, res.stats, out.read_bytes())
    (codes, scales, stats, raw), (codes2, scales2, stats2, raw2) = maps.values()
    assert (codes > 0).any() and (codes == 0).any()  # values and the nodata patch
    np.testing.assert_array_equal(codes, codes2)
    assert scales == scales2 and stats == stats2 and raw == raw2
