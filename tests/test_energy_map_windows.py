"""How the windowed map reads a DEM: each row read once, the windows (their rows and a
one-row halo each side) equal to the whole band read at once, and the next window's
inputs made in a thread while a window is computed: the same bits as the in-memory map,
and an error in either thread raised as without it, leaving no file."""

from __future__ import annotations

import threading

import numpy as np
import pytest
import rasterio
from affine import Affine
from b1_model import b1_model  # tests/ helper

import energy_planner.energymap.core as core
from energy_planner.energymap import energy_map
from energy_planner.errors import DEMIOError
from energy_planner.terrain import load_dem
from energy_planner.terrain.raster import band_reading

MODEL = b1_model()
ROWS, COLS = 90, 70
SCALE, OFFSET = 0.5, 100.0  # stored value * 0.5 + 100 = metres (exact in binary)


@pytest.fixture(scope="module")
def dem(tmp_path_factory):
    """90 x 70 stored values with a scale and offset, a nodata patch and an ``inf`` cell."""
    path = tmp_path_factory.mktemp("emwin") / "dem.tif"
    x = np.arange(COLS) * 2.0
    y = np.arange(ROWS)[:, None] * 2.0
    z = 60 * np.sin(x / 40) * np.cos(y / 30) + 0.1 * x + 6 * np.sin((x + 2 * y) / 9)
    z[40:47, 10:25] = -9999.0
    z[70, 50] = np.inf
    prof = dict(
        driver="GTiff", width=COLS, height=ROWS, count=1, dtype="float32", nodata=-9999.0,
        crs="EPSG:32631", transform=Affine(2.0, 0, 500000.0, 0, -2.0, 5000180.0),
    )  # fmt: skip
    with rasterio.open(path, "w", **prof) as dst:
        dst.write(z.astype(np.float32), 1)
        dst.scales, dst.offsets = (SCALE,), (OFFSET,)
    return path


def _whole(path):
    """The band read at once in metres: nodata and infinities NaN."""
    with rasterio.open(path) as src:
        z = src.read(1, masked=True).astype(np.float64).filled(np.nan)
    z[np.isinf(z)] = np.nan
    z *= SCALE
    z += OFFSET
    return z


@pytest.mark.parametrize("step", [1, 7, 16, 45, 90, 200])
def test_row_reader_reads_each_row_once_and_gives_the_whole_bands_rows(dem, monkeypatch, step):
    """Windows of ``step`` rows with their halo: the rows of the whole band (NaN beyond
    its edges); the stored rows read once each, in chunks of ``step`` from row 0; at most
    two chunks held."""
    reads = []
    stored = core._read_stored

    def counting(src, band, a, b, out):
        reads.append((a, b))
        stored(src, band, a, b, out)

    monkeypatch.setattr(core, "_read_stored", counting)
    whole = _whole(dem)
    assert np.isnan(whole).sum() == 7 * 15 + 1
    padded = np.full((ROWS + 2, COLS), np.nan)
    padded[1:-1] = whole
    with rasterio.open(dem) as src:
        rows_of = core._RowReader(src, band_reading(src, 1, str(dem), scan=True), step)
        for r0 in range(0, ROWS, step):
            r1 = min(ROWS, r0 + step)
            z = rows_of(r0 - 1, r1 + 1)
            np.testing.assert_array_equal(z, padded[r0 : r1 + 2])
            assert sum(len(p) for _, p in rows_of._chunks) <= 2 * step
    assert reads == [(a, min(ROWS, a + step)) for a in range(0, ROWS, step)]


def test_row_reader_reads_again_rows_it_let_go(dem):
    """A window above those read before (out of order) is read again: the same rows."""
    with rasterio.open(dem) as src:
        rows_of = core._RowReader(src, band_reading(src, 1, str(dem), scan=True), 16)
        first = rows_of(-1, 17)
        rows_of(15, 33)
        rows_of(31, 49)
        np.testing.assert_array_equal(rows_of(-1, 17), first)


@pytest.fixture
def small_windows(monkeypatch):
    """Windows of 16 rows (6 for the DEM); the threads that computed each gradient."""
    monkeypatch.setattr(core, "_rows_per_block", lambda cols, nbands: 16)
    import energy_planner.terrain.horn as horn

    names = []
    gradient = horn.horn_gradient

    def named(*a, **k):
        names.append(threading.current_thread().name)
        return gradient(*a, **k)

    monkeypatch.setattr(horn, "horn_gradient", named)
    return names


def _readers_alive():
    return [t for t in threading.enumerate() if t.name.startswith("energy-map-read")]


def test_windows_read_ahead_write_the_in_memory_maps_bits(dem, tmp_path, small_windows):
    """Six windows, the inputs of the last five made in the reading thread: every band
    (float32, all) equal to the map of the Terrain loaded whole, bit for bit."""
    ref, win = tmp_path / "ref.tif", tmp_path / "win.tif"
    energy_map(load_dem(dem), ref, MODEL, headings=8, bands="all", encoding="float32")
    small_windows.clear()
    res = energy_map(dem, win, MODEL, headings=8, bands="all", encoding="float32")
    assert res.mode == "windowed"
    assert small_windows[0] == threading.current_thread().name
    assert [n.startswith("energy-map-read") for n in small_windows] == [False] + [True] * 5
    with rasterio.open(ref) as a, rasterio.open(win) as b:
        x, y = a.read(), b.read()
    assert np.isfinite(x).any() and np.isnan(x).any()
    np.testing.assert_array_equal(x, y)
    assert not _readers_alive()


def test_an_error_reading_ahead_is_raised_and_leaves_no_file(dem, tmp_path, monkeypatch,
                                                             small_windows):  # fmt: skip
    """Rows 48 on unreadable: read (in the reading thread) while an earlier window is
    computed, the error raised by ``energy_map`` as it is; the previous file kept, no
    scratch file left, the thread ended."""
    stored = core._read_stored
    where = []

    def failing(src, band, a, b, out):
        if a >= 48:
            where.append(threading.current_thread().name)
            raise DEMIOError(f"cannot read rows {a} .. {b}")
        stored(src, band, a, b, out)

    monkeypatch.setattr(core, "_read_stored", failing)
    out = tmp_path / "map.tif"
    out.write_bytes(b"the previous map")
    with pytest.raises(DEMIOError, match="cannot read rows 48 .. 64"):
        energy_map(dem, out, MODEL, headings=8, encoding="float32")
    assert where and where[0].startswith("energy-map-read")
    assert out.read_bytes() == b"the previous map"
    assert [p.name for p in tmp_path.iterdir()] == ["map.tif"]
    assert not _readers_alive()


def test_an_error_in_a_window_stops_the_read_ahead_and_leaves_no_file(
    dem, tmp_path, monkeypatch, small_windows
):
    """The kernel fails in the second window while the third's rows are read: its error
    raised, the reading thread waited for, no file."""
    calls = []
    bands = core.block_bands

    def failing(*a, **k):
        calls.append(1)
        if len(calls) == 2:
            raise RuntimeError("kernel failed")
        return bands(*a, **k)

    monkeypatch.setattr(core, "block_bands", failing)
    out = tmp_path / "map.tif"
    with pytest.raises(RuntimeError, match="kernel failed"):
        energy_map(dem, out, MODEL, headings=8, encoding="float32")  # computed once
    assert len(small_windows) == 3  # windows 1, 2 and the one read ahead: no further
    assert not out.exists() and not list(tmp_path.iterdir())
    assert not _readers_alive()


@pytest.mark.parametrize("tmax", [1e-3, 0.3, 0.8, np.inf])
def test_steepest_slope_over_row_ranges_is_the_gathered_cells(tmax):
    """The heading table's extent: arctan of the root of the greatest squared gradient
    within the limit, found by row ranges in threads, equal to the one of the cells
    gathered (0 with none: an empty block, all NaN, all above the limit)."""
    from energy_planner.energy.heading import _steepest

    rng = np.random.default_rng(3)
    gx, gy = rng.normal(0, 0.4, (2, 37, 23))
    gx[rng.random(gx.shape) < 0.1] = np.nan
    gy[5, 7] = np.inf
    g2 = gx * gx + gy * gy
    with np.errstate(invalid="ignore"):
        cells = g2[np.isfinite(g2) & (g2 <= tmax * tmax)]
    expect = float(np.arctan(np.sqrt(cells.max()))) if cells.size else 0.0
    assert _steepest(gx, gy, tmax) == expect
    assert (expect == 0.0) == (tmax == 1e-3)
    assert _steepest(gx[:0], gy[:0], tmax) == 0.0
    assert _steepest(gx * np.nan, gy, tmax) == 0.0
