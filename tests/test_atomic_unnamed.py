"""Atomic outputs leave nothing beside the destination, even while being written.

On Linux ``energy_planner.io.atomic_path`` writes an unnamed file (``O_TMPFILE``) that
writers reach through a link in a private temporary folder; folders are built in a
private folder on the same mount. Each real writer the project uses (GDAL as the energy
map writes, matplotlib, pyarrow, numpy, the GeoJSON and JSON writers, ROS bag writers)
is checked to write through it: the destination's folder holds nothing else during the
write, the result is whole, and sidecar files follow the file. The fallback (no
``O_TMPFILE``: a hidden name beside) is forced and checked too.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import rasterio
from rasterio.transform import from_origin

from energy_planner.io import atomic, atomic_dir, atomic_path, scratch_path

pytestmark = pytest.mark.skipif(
    not sys.platform.startswith("linux"), reason="unnamed files: Linux (O_TMPFILE, /proc)"
)


@pytest.fixture(params=["unnamed", "named"])
def mode(request, monkeypatch):
    """Each test twice: unnamed files, then forced to the fallback (a hidden name beside)."""
    if request.param == "named":
        from faults import named_files  # tests/ helper

        named_files(monkeypatch)
    return request.param


def _beside(folder: Path, *keep: str) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name not in keep)


def _mine() -> list[Path]:
    """What this process's private folders in the temporary folder hold (links, folders)."""
    mine = Path(tempfile.gettempdir()).glob(f"energy_planner.{os.getpid()}.*")
    return sorted(p for d in mine for p in d.iterdir())


def _write_energy_map_like(path: Path, n: int = 300) -> np.ndarray:
    """A GTiff as the energy map writes it: DEFLATE + predictor, tiles, then r+ edits."""
    data = np.random.default_rng(0).random((3, n, n)).astype("float32")
    prof = dict(driver="GTiff", height=n, width=n, count=3, dtype="float32",
                crs="EPSG:32631", transform=from_origin(5e5, 5e6, 1, 1), nodata=np.nan,
                compress="deflate", predictor=3, tiled=True, blockxsize=256,
                blockysize=256)  # fmt: skip
    with rasterio.open(path, "w", **prof) as dst:
        dst.write(data)
        dst.set_band_unit(1, "Wh")
        dst.set_band_description(1, "cost_e")
        dst.build_overviews([2, 4])
    with rasterio.open(path, "r+") as dst:  # as outofcore does after rioxarray
        dst.update_tags(software="test")
    return data


def test_gdal_writes_an_energy_map_through_the_link(tmp_path, mode):
    dest = tmp_path / "map.tif"
    dest.write_bytes(b"the previous map")
    with atomic_path(dest) as tmp:
        data = _write_energy_map_like(tmp)
        assert dest.read_bytes() == b"the previous map"
        expected = ["map.tif"] if mode == "unnamed" else ["map.tif", tmp.name]
        assert _beside(tmp_path) == sorted(expected)
    assert _beside(tmp_path) == ["map.tif"]
    with rasterio.open(dest) as src:
        np.testing.assert_array_equal(src.read(), data)
        assert src.units[0] == "Wh" and src.descriptions[0] == "cost_e"
        assert src.overviews(1) == [2, 4] and src.tags()["software"] == "test"
        assert src.compression.name.lower() == "deflate" and src.block_shapes[0] == (256, 256)
    assert _mine() == []  # the link is gone


def test_gdal_sidecars_follow_the_file(tmp_path, mode):
    """A GTiff GDAL cannot describe inside (baseline TIFF): its .aux.xml goes beside dest."""
    dest = tmp_path / "plain.tif"
    prof = dict(driver="GTiff", height=4, width=4, count=1, dtype="float32",
                crs="EPSG:32631", transform=from_origin(5e5, 5e6, 1, 1),
                profile="BASELINE")  # fmt: skip
    with atomic_path(dest) as tmp:
        with rasterio.open(tmp, "w", **prof) as dst:
            dst.write(np.ones((1, 4, 4), "float32"))
            dst.update_tags(software="sidecar")
    assert "plain.tif.aux.xml" in _beside(tmp_path)
    assert not [n for n in _beside(tmp_path) if n.startswith(".")]
    with rasterio.open(dest) as src:
        assert src.tags()["software"] == "sidecar" and src.crs.to_epsg() == 32631


def test_text_figures_tables_and_arrays_write_through_the_link(tmp_path, mode):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pyarrow as pa
    import pyarrow.csv as pa_csv
    import pyarrow.parquet as pq

    from energy_planner.io import save_figure, write_geojson, write_json, write_text

    table = pa.table({"t": [0.0, 0.1], "v": [48.0, 47.9]})
    fig, ax = plt.subplots()
    ax.plot([0, 1], [1, 0])

    def during(write, name):  # nothing beside the outputs while each is written
        def check(tmp):
            write(tmp)
            names = _beside(tmp_path)
            assert names == sorted(done) if mode == "unnamed" else tmp.name in names

        with atomic_path(tmp_path / name) as tmp:
            check(tmp)
        done.append(name)

    done: list[str] = []
    during(lambda p: pa_csv.write_csv(table, p), "run.csv")
    during(lambda p: pq.write_table(table, p), "run.parquet")
    during(lambda p: np.save(p, np.arange(5)), "table.npy")
    during(lambda p: fig.savefig(p, dpi=30), "plot.png")
    save_figure(fig, tmp_path / "figure.svg")  # the format from the suffix
    plt.close(fig)
    write_json(tmp_path / "model.json", {"a": 1})
    write_text(tmp_path / "report.html", "<html></html>")
    write_geojson(tmp_path / "path.geojson", {"type": "FeatureCollection", "features": []})
    assert _beside(tmp_path) == sorted(
        [*done, "figure.svg", "model.json", "report.html", "path.geojson"]
    )
    assert pd.read_csv(tmp_path / "run.csv")["v"].tolist() == [48.0, 47.9]
    assert pq.read_table(tmp_path / "run.parquet").equals(table)
    assert np.load(tmp_path / "table.npy").tolist() == [0, 1, 2, 3, 4]
    assert (tmp_path / "plot.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (tmp_path / "figure.svg").read_text().rstrip().endswith("</svg>")
    assert json.loads((tmp_path / "model.json").read_text()) == {"a": 1}
    assert _mine() == []


def test_a_writer_that_renames_over_the_link_is_taken_back(tmp_path):
    """Some writers write their own temporary file and rename it over the path."""
    dest = tmp_path / "a.txt"
    with atomic_path(dest) as tmp:
        own = tmp.with_name("own.tmp")
        own.write_text("renamed over")
        os.replace(own, tmp)
    assert dest.read_text() == "renamed over" and _beside(tmp_path) == ["a.txt"]


def test_permissions_follow_the_previous_file_or_the_umask(tmp_path, mode):
    new = tmp_path / "new.txt"
    with atomic_path(new) as tmp:
        tmp.write_text("x")
    assert new.stat().st_mode & 0o777 == 0o666 & ~atomic._UMASK
    old = tmp_path / "old.txt"
    old.write_text("1")
    old.chmod(0o640)
    with atomic_path(old) as tmp:
        tmp.write_text("2")
    assert old.stat().st_mode & 0o777 == 0o640


def test_scratch_file_is_on_the_destination_disk_and_leaves_nothing(tmp_path, mode):
    dest = tmp_path / "map.tif"
    with scratch_path(dest) as work:
        _write_energy_map_like(work, 64)
        with rasterio.open(work) as src:
            assert src.count == 3
        if mode == "unnamed":
            assert _beside(tmp_path) == [] and os.stat(work).st_dev == tmp_path.stat().st_dev
    assert _beside(tmp_path) == [] and _mine() == []


@pytest.mark.parametrize("staged", [True, False], ids=["private", "beside"])
def test_bags_and_folders_are_built_away_from_the_destination(tmp_path, staged, monkeypatch):
    """create=False (ROS bag writers) and atomic_dir: nothing beside, or a hidden folder."""
    from energy_planner.measurements.rosbag import write_rosbag

    if not staged:
        monkeypatch.setattr(atomic, "_staging_base", lambda parent: None)
    t = np.arange(0.0, 1.0, 0.1)
    samples = pd.DataFrame({"run": "r1", "t": t, "qw": 1.0, "qx": 0.0, "qy": 0.0, "qz": 0.0,
                            "vx": 0.3, "vy": 0.0, "wz": 0.0, "voltage": 48.0,
                            "current": 2.0})  # fmt: skip
    seen: list[list[str]] = []

    class Spy:  # what is beside the outputs when each bag is moved in
        def __init__(self):
            self.orig = os.replace

        def __call__(self, a, b, *args, **kw):
            if Path(b).parent == tmp_path:
                seen.append(_beside(tmp_path))
            return self.orig(a, b, *args, **kw)

    monkeypatch.setattr(atomic.os, "replace", Spy())
    write_rosbag(samples, tmp_path / "bag2", version=2)
    write_rosbag(samples, tmp_path / "run.bag", version=1)
    hidden = [[n for n in names if n.startswith(".")] for names in seen]
    if staged:
        assert hidden == [[], []]
    else:  # the hidden work folder of each, while it is written
        assert [len(h) for h in hidden] == [1, 1] and hidden[0][0].startswith(".bag2.")
    assert _beside(tmp_path) == ["bag2", "run.bag"]
    assert (tmp_path / "bag2" / "metadata.yaml").is_file()
    from energy_planner.measurements.rosbag import load_rosbag

    assert len(load_rosbag(tmp_path / "run.bag")) == len(t)
    # a whole folder: the same
    (tmp_path / "campaign").mkdir()
    (tmp_path / "campaign" / "old.csv").write_text("old")
    with atomic_dir(tmp_path / "campaign", overwrite=True) as work:
        (work / "new.csv").write_text("new")
        names = _beside(tmp_path, "bag2", "run.bag")
        assert names == ["campaign"] if staged else len(names) == 2
    assert [p.name for p in (tmp_path / "campaign").iterdir()] == ["new.csv"]
    assert _beside(tmp_path) == ["bag2", "campaign", "run.bag"] and _mine() == []


def test_a_killed_writers_private_folders_are_removed_by_the_next(tmp_path, monkeypatch):
    """What a SIGKILL left in the temporary folder: removed once its writer is dead."""
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    dead = tmp_path / "energy_planner.999999999.abc123"
    (dead / "campaign").mkdir(parents=True)
    (dead / "campaign" / "half.csv").write_text("t\n0")
    live = tmp_path / "energy_planner.1.abc123"  # pid 1 exists: never removed
    live.mkdir()
    other = tmp_path / "someone_else.999999999.x"
    other.mkdir()
    with atomic.atomic_dir(tmp_path / "out" / "campaign") as work:
        (work / "a.csv").write_text("t\n0\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["out", live.name, other.name])


def test_a_killed_named_writers_sidecars_are_removed_with_it(tmp_path):
    left = [".plain.999999999.ab12.tmp.tif", ".plain.999999999.ab12.tmp.tif.aux.xml"]
    for n in left:
        (tmp_path / n).write_bytes(b"half")
    assert sorted(p.name for p in atomic.remove_stale(tmp_path / "plain.tif")) == left
    assert _beside(tmp_path) == []


def test_no_room_for_the_private_link_falls_back_to_a_named_file(tmp_path, monkeypatch):
    import contextlib
    import errno

    @contextlib.contextmanager
    def full(fd, name):
        raise OSError(errno.ENOSPC, "No space left on device")
        yield  # pragma: no cover

    monkeypatch.setattr(atomic, "_reach", full)
    dest = tmp_path / "m.json"
    with atomic_path(dest) as tmp:
        assert tmp.parent == tmp_path  # beside, named
        tmp.write_text("{}")
    assert dest.read_text() == "{}" and _beside(tmp_path) == ["m.json"]


def test_folders_are_built_in_the_cache_when_the_temporary_folder_is_elsewhere(
    tmp_path, monkeypatch
):
    """The temporary folder on another mount: the user's cache, else a folder beside."""
    other = tmp_path / "other_mount"
    other.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(other))
    monkeypatch.delenv("ENERGY_PLANNER_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    real = atomic._mount_of
    monkeypatch.setattr(
        atomic, "_mount_of",
        lambda p: "other" if os.path.realpath(p).startswith(str(other)) else real(p),
    )  # fmt: skip
    with atomic_dir(tmp_path / "out" / "campaign") as work:
        assert work.parent.parent == tmp_path / "cache" / "energy_planner" / "work"
        (work / "a.csv").write_text("t\n0\n")
        assert _beside(tmp_path / "out") == []
    monkeypatch.setenv("XDG_CACHE_HOME", str(other / "cache"))  # the cache too: beside
    with atomic_dir(tmp_path / "out" / "c2") as work:
        assert work.parent.parent == tmp_path / "out" and work.parent.name.startswith(".c2.")
        (work / "b.csv").write_text("t\n0\n")
    assert _beside(tmp_path / "out") == ["c2", "campaign"]
    assert (tmp_path / "out" / "campaign" / "a.csv").is_file()
    assert list((tmp_path / "cache" / "energy_planner" / "work").iterdir()) == []


@pytest.mark.skipif(not __import__("shutil").which("gdaladdo"), reason="no gdaladdo")
def test_another_process_reaches_the_file_and_its_ovr_follows(tmp_path, mode):
    """``gdaladdo -ro`` (another process) reaches the file, its ``.ovr`` lands beside dest."""
    import subprocess

    dest = tmp_path / "map.tif"
    prof = dict(driver="GTiff", height=64, width=64, count=1, dtype="float32",
                crs="EPSG:32631", transform=from_origin(5e5, 5e6, 1, 1),
                compress="deflate")  # fmt: skip
    with atomic_path(dest) as tmp:
        with rasterio.open(tmp, "w", **prof) as dst:
            dst.write(np.arange(64 * 64, dtype="float32").reshape(1, 64, 64))
        run = subprocess.run(["gdaladdo", "-ro", str(tmp), "2", "4"], capture_output=True,
                             text=True)  # fmt: skip
        assert run.returncode == 0, run.stderr
    assert _beside(tmp_path) == ["map.tif", "map.tif.ovr"]
    with rasterio.open(dest) as src:
        assert src.overviews(1) == [2, 4]  # read from the .ovr beside it
    with rasterio.open(dest, OVERVIEW_LEVEL=1) as ov:
        assert ov.shape == (16, 16)


def test_two_writes_of_one_name_at_once_get_links_of_their_own(tmp_path):
    a, b = tmp_path / "a" / "m.json", tmp_path / "b" / "m.json"
    with atomic_path(a) as ta, atomic_path(b) as tb:
        assert ta != tb and ta.name == tb.name == "m.json"
        ta.write_text("1")
        tb.write_text("2")
    assert (a.read_text(), b.read_text()) == ("1", "2") and _mine() == []
