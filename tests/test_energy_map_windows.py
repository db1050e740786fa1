"""How the windowed map reads a DEM: each row read once, the windows (their rows and a
one-row halo each side) equal to the whole band read at once, and the next window's
inputs made in a thread while a window is computed: the same bits as the in-memory map,
and an error in either thread raised as without it, leaving no file. The windows are
whole rows of the file's blocks: no block written twice, none lost to the reading
thread's use of GDAL's block cache."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
from pathlib import Path

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
#: The rows of a strip of the maps of the DEM (too small for tiles): GDAL's default, a
#: band's strip about 8 KB, 8192 // (70 * 4 bytes) rows.
STRIP = 29
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
    """Windows of about 16 rows: of one strip (29 rows; 4 windows for the DEM), the
    least number of whole strips; the threads that computed each gradient."""
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
    """Four windows, the inputs of the last three made in the reading thread: every band
    (float32, all) equal to the map of the Terrain loaded whole, bit for bit."""
    ref, win = tmp_path / "ref.tif", tmp_path / "win.tif"
    energy_map(load_dem(dem), ref, MODEL, headings=8, bands="all", encoding="float32")
    small_windows.clear()
    res = energy_map(dem, win, MODEL, headings=8, bands="all", encoding="float32")
    assert res.mode == "windowed"
    assert small_windows[0] == threading.current_thread().name
    assert [n.startswith("energy-map-read") for n in small_windows] == [False] + [True] * 3
    with rasterio.open(ref) as a, rasterio.open(win) as b:
        x, y = a.read(), b.read()
    assert np.isfinite(x).any() and np.isnan(x).any()
    np.testing.assert_array_equal(x, y)
    assert not _readers_alive()


def test_each_block_of_the_file_is_written_by_one_window(dem, tmp_path, monkeypatch,
                                                         small_windows):  # fmt: skip
    """Windows of 16 rows asked for, the file in strips of 29 rows: windows of whole
    strips, 0 .. 29 .. 58 .. 87 .. 90, each strip written once, whole. (A strip that two
    windows share waits, dirty, in GDAL's block cache between their writes, where the
    reading thread may evict it as the next write reads it back from the file: rows of
    it were NaN in the file, now and then; see the next test.)"""
    written = []
    write = core._BackgroundWriter.write

    def recording(self, data, window):
        written.append((window.row_off, window.row_off + window.height))
        return write(self, data, window)

    monkeypatch.setattr(core._BackgroundWriter, "write", recording)
    out = tmp_path / "win.tif"
    energy_map(dem, out, MODEL, headings=8, bands="all", encoding="float32")
    with rasterio.open(out) as b:
        assert b.block_shapes[0] == (STRIP, COLS)  # 16 is not whole strips
    assert written == [(0, 29), (29, 58), (58, 87), (87, 90)]


#: A child process: ``energy_map`` of a DEM by windows of 16 rows asked for, ``n`` times,
#: GDAL's block cache in its debugging mode (GDAL_DEBUG_BLOCK_CACHE, read as GDAL starts:
#: hence a process of its own), the reading thread pausing after it has taken a dirty
#: block of the map out of the cache and before writing it (GDAL's
#: GDAL_RB_INTERNALIZE_SLEEP_AFTER_DETACH_BEFORE_WRITE, set in that thread only).
#: Exit 3 where the GDAL library rasterio loaded is not found.
_EVICTING_READER = """
import ctypes, sys, threading
import rasterio
sys.path.insert(0, sys.argv[4])
import energy_planner.energymap.core as core
from b1_model import b1_model
from energy_planner.energymap import energy_map

with open("/proc/self/maps") as maps:
    libs = [ln.split()[-1] for ln in maps if "/libgdal" in ln]
if not libs:
    sys.exit(3)
gdal = ctypes.CDLL(libs[0])
core._rows_per_block = lambda cols, nbands: 16
stored = core._read_stored

def read(src, band, a, b, out):
    if threading.current_thread().name.startswith("energy-map-read"):
        gdal.CPLSetThreadLocalConfigOption(
            b"GDAL_RB_INTERNALIZE_SLEEP_AFTER_DETACH_BEFORE_WRITE", b"0.2")
    stored(src, band, a, b, out)

core._read_stored = read
for i in range(int(sys.argv[3])):
    energy_map(sys.argv[1], f"{sys.argv[2]}{i}.tif", b1_model(), headings=8, bands="all",
               encoding="float32")
"""


@pytest.mark.skipif(not Path("/proc/self/maps").exists(), reason="finds GDAL in /proc")
def test_windows_survive_the_reading_thread_evicting_the_maps_blocks(dem, tmp_path):
    """Four maps by windows, the reading thread slow to write the map's blocks it
    evicts from GDAL's block cache: each equal to the in-memory map, bit for bit. (With
    windows of 16 rows, strips shared by two windows, the last band lost the rows of one
    window in a strip in 28 of 50 such maps.)"""
    ref = tmp_path / "ref.tif"
    energy_map(load_dem(dem), ref, MODEL, headings=8, bands="all", encoding="float32")
    env = dict(os.environ, GDAL_DEBUG_BLOCK_CACHE="YES")
    n, tests = 4, str(Path(__file__).parent)
    done = subprocess.run(
        [sys.executable, "-c", _EVICTING_READER, str(dem), str(tmp_path / "win"), str(n), tests],
        env=env, capture_output=True, text=True,
    )  # fmt: skip
    if done.returncode == 3:
        pytest.skip("the GDAL library rasterio loaded is not in /proc/self/maps")
    assert done.returncode == 0, done.stderr
    with rasterio.open(ref) as a:
        x = a.read()
    for i in range(n):
        with rasterio.open(tmp_path / f"win{i}.tif") as b:
            np.testing.assert_array_equal(b.read(), x)


def test_an_error_reading_ahead_is_raised_and_leaves_no_file(dem, tmp_path, monkeypatch,
                                                             small_windows):  # fmt: skip
    """Rows 58 on unreadable: read (in the reading thread, the third window's rows)
    while an earlier window is computed, the error raised by ``energy_map`` as it is;
    the previous file kept, no scratch file left, the thread ended."""
    stored = core._read_stored
    where = []

    def failing(src, band, a, b, out):
        if a >= 2 * STRIP:
            where.append(threading.current_thread().name)
            raise DEMIOError(f"cannot read rows {a} .. {b}")
        stored(src, band, a, b, out)

    monkeypatch.setattr(core, "_read_stored", failing)
    out = tmp_path / "map.tif"
    out.write_bytes(b"the previous map")
    with pytest.raises(DEMIOError, match="cannot read rows 58 .. 87"):
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
