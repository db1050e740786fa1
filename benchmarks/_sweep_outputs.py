"""Sweep cases: outputs where users point them (missing folders, folders, read-only, full).

One rule for every output: its folder is created. An output that cannot be written (a
folder in its place, a read-only folder, a full disk) is one clear line and the previous
output is kept; ``simulate --out`` refuses a folder that holds something unless
``--overwrite``, which replaces it whole.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
from _sweep import Verdict, case, expect_error, run

TOPIC = "outputs"


def _hill() -> str:
    import _sweep

    return str(Path(_sweep.ROOT) / "energy_planner" / "data" / "maps" / "hill.tif")


START, GOAL = "500058,5000046", "500058,5000084"


def _plan(tmp: Path, out: Path, *extra: object):
    return run(tmp, "plan", "--dem", _hill(), "--start", START, "--goal", GOAL, "--time", "0.5",
               "--out", out, *extra)  # fmt: skip


def _written(r, *paths: Path) -> Verdict:
    if r.traceback or r.rc != 0:
        return Verdict(r.error or "traceback", False, "refused: expected the file written")
    missing = [str(p) for p in paths if not p.exists()]
    if missing:
        return Verdict("exit 0", False, f"not written: {', '.join(missing)}")
    stray = [q.name for p in paths for q in p.parent.iterdir() if q.name.startswith(".")]
    if stray:
        return Verdict("exit 0", False, f"temporary files left: {stray}")
    return Verdict(f"written: {', '.join(p.name for p in paths)} (folders made)", True)


@case(TOPIC, "plan --out and --plot into folders that do not exist")
def plan_into_missing_folder(tmp: Path) -> Verdict:
    out, plot = tmp / "new" / "a" / "path.geojson", tmp / "new2" / "b" / "path.png"
    return _written(_plan(tmp, out, "--plot", plot), out, plot)


@case(TOPIC, "energy-map --out into a folder that does not exist")
def energy_map_into_missing_folder(tmp: Path) -> Verdict:
    out = tmp / "maps" / "2026" / "map.tif"
    return _written(run(tmp, "energy-map", _hill(), "--out", out, "--headings", "4"), out)


@case(TOPIC, "reach --out and --geojson into a folder that does not exist")
def reach_into_missing_folder(tmp: Path) -> Verdict:
    out, gj = tmp / "new" / "reach.tif", tmp / "new" / "reach.geojson"
    r = run(tmp, "reach", _hill(), "--start", START, "--budget-wh", "5", "--out", out,
            "--geojson", gj)  # fmt: skip
    return _written(r, out, gj)


@case(TOPIC, "plan --out names an existing folder")
def output_is_a_folder(tmp: Path) -> Verdict:
    (tmp / "taken").mkdir()
    return expect_error(_plan(tmp, tmp / "taken"), "taken", "directory")


@case(TOPIC, "plan --out under a path whose 'folder' is a file")
def parent_is_a_file(tmp: Path) -> Verdict:
    (tmp / "notes.txt").write_text("mine")
    return expect_error(_plan(tmp, tmp / "notes.txt" / "path.geojson"), "notes.txt", "is a file")


def _read_only(path: Path) -> bool:
    """Make ``path`` read-only (a read-only tmpfs for root, permissions otherwise)."""
    path.mkdir(exist_ok=True)
    if os.geteuid() != 0:
        path.chmod(0o555)
        return True
    ok = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(path)],
                        capture_output=True).returncode == 0  # fmt: skip
    if ok:
        (path / "path.geojson").write_text("the previous path")
        ok = subprocess.run(["mount", "-o", "remount,ro", str(path)],
                            capture_output=True).returncode == 0  # fmt: skip
    return ok


def _release(path: Path) -> None:
    if os.geteuid() != 0:
        path.chmod(0o755)
    else:
        subprocess.run(["umount", "-l", str(path)], capture_output=True)


@case(TOPIC, "plan --out into a read-only folder holding the previous path")
def unwritable_output(tmp: Path) -> Verdict:
    ro = tmp / "ro"
    if os.geteuid() != 0:
        ro.mkdir()
        (ro / "path.geojson").write_text("the previous path")
    if not _read_only(ro):
        return Verdict("(cannot make a read-only folder here)", True, "skipped")
    try:
        v = expect_error(_plan(tmp, ro / "path.geojson"), "cannot write", "previous file is kept")
        if v.handled and (ro / "path.geojson").read_text() != "the previous path":
            return Verdict(v.answer, False, "the previous path was lost")
        return v
    finally:
        _release(ro)


@case(TOPIC, "terrain --slope-out onto a full disk (a 1 MB tmpfs) over a previous slope map")
def full_disk(tmp: Path) -> Verdict:
    if os.geteuid() != 0 or shutil.which("mount") is None:
        return Verdict("(mounting a small tmpfs needs root)", True, "skipped")
    disk = tmp / "disk"
    disk.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(disk)],
                      capture_output=True).returncode:  # fmt: skip
        return Verdict("(mount not permitted)", True, "skipped")
    try:
        (disk / "slope.tif").write_bytes(b"the previous slope map")
        dem = _big_dem(tmp / "dem.tif")
        r = run(tmp, "terrain", dem, "--slope-out", disk / "slope.tif")
        v = expect_error(r, "no space left", "previous file is kept")
        if v.handled and (disk / "slope.tif").read_bytes() != b"the previous slope map":
            return Verdict(v.answer, False, "the previous map was lost")
        if v.handled and sorted(p.name for p in disk.iterdir()) != ["slope.tif"]:
            return Verdict(v.answer, False, "temporary files left on the full disk")
        return v
    finally:
        subprocess.run(["umount", "-l", str(disk)], capture_output=True)


def _big_dem(path: Path) -> Path:
    import rasterio
    from rasterio.transform import from_origin

    n = 800  # its slope map: 2.5 MB of float32
    z = np.random.default_rng(0).random((n, n)).astype("float32")
    prof = dict(driver="GTiff", height=n, width=n, count=1, dtype="float32", crs="EPSG:32631")
    with rasterio.open(path, "w", transform=from_origin(5e5, 5e6 + n, 1, 1), **prof) as dst:
        dst.write(z, 1)
    return path


def _old_campaign(tmp: Path) -> Path:
    """A folder holding an older campaign's log."""
    out = tmp / "campaign"
    out.mkdir()
    (out / "old_run.csv").write_text("an older campaign's log")
    return out


@case(TOPIC, "simulate --out into a folder holding an older campaign")
def simulate_into_old_campaign(tmp: Path) -> Verdict:
    out = _old_campaign(tmp)
    r = run(tmp, "simulate", "--out", out, "--small")
    v = expect_error(r, "is not empty", "--overwrite")
    if v.handled and sorted(p.name for p in out.iterdir()) != ["old_run.csv"]:
        return Verdict(v.answer, False, "the folder was changed")
    return v


@case(TOPIC, "simulate --out OLD --overwrite: the older campaign replaced whole")
def simulate_overwrite(tmp: Path) -> Verdict:
    out = _old_campaign(tmp)
    r = run(tmp, "simulate", "--out", out, "--small", "--overwrite")
    if r.traceback or r.rc != 0:
        return Verdict(r.error or "traceback", False, "refused")
    names = {p.name for p in out.iterdir()}
    if "old_run.csv" in names:
        return Verdict("exit 0", False, "old and new files mixed")
    if sorted(p.name for p in tmp.iterdir()) != ["campaign"]:
        return Verdict("exit 0", False, "a temporary folder left beside it")
    return Verdict(f"replaced: {len(names)} files, none of the old", True)


@case(TOPIC, "a read-only kernel cache folder (ENERGY_PLANNER_CACHE)")
def read_only_cache(tmp: Path) -> Verdict:
    ro = tmp / "cache"
    if os.geteuid() != 0:
        ro.mkdir()
    if not _read_only(ro):
        return Verdict("(cannot make a read-only folder here)", True, "skipped")
    old = os.environ.get("ENERGY_PLANNER_CACHE")
    os.environ["ENERGY_PLANNER_CACHE"] = str(ro)
    try:
        out = tmp / "path.geojson"
        r = _plan(tmp, out)
    finally:
        if old is None:
            del os.environ["ENERGY_PLANNER_CACHE"]
        else:
            os.environ["ENERGY_PLANNER_CACHE"] = old
        _release(ro)
    if r.traceback or r.rc != 0:
        return Verdict(r.error or "traceback", False, "refused: expected a plan")
    hits = [w for w in r.warnings if "kernel cache" in w]
    if not hits or not out.exists():
        return Verdict("planned without a word", False, "no warning naming the cache")
    return Verdict(hits[0][:160], True)
