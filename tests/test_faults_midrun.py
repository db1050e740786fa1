"""Faults mid-run: SIGKILL at random points, two runs at once, read-only cache, full disk.

Every command writes through ``energy_planner.io`` (``test_atomic_outputs`` holds that),
with one of these writers: JSON (fit, discover, models), text (HTML reports), GeoJSON
(plan, mission, reach), GeoTIFF (terrain, energy-map, reach), PNG (every ``--plot``)
and a whole folder (simulate). A child process writes each of them over and over (every
version complete and recognisable) and is killed with SIGKILL at a random moment; each
output must then be a complete version, and the next write must leave nothing beside
it. Two commands run through the real CLI as well: ``simulate --overwrite`` killed
mid-campaign and two ``energy-map`` runs writing one output at once.
"""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import rasterio

ROOT = Path(__file__).resolve().parents[1]
SEED = int(os.environ.get("FAULT_SEED", "31"))
CLI = [sys.executable, "-c", "from energy_planner.cli import main; main()"]

#: The child: writes every kind of output, version after version, forever.
WRITER = textwrap.dedent(
    """
    import json, sys
    from pathlib import Path
    import numpy as np
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from rasterio.transform import from_origin
    from energy_planner import io

    d = Path(sys.argv[1])
    fig, ax = plt.subplots(figsize=(6, 6))
    ax.imshow(np.random.default_rng(0).random((400, 400)))
    k = 0
    while True:
        k += 1
        payload = {"version": k, "data": list(range(20000)), "end": k}
        io.write_json(d / "out" / "model.json", payload)
        io.write_text(d / "out" / "report.html", f"<html>{k} " + "x" * 200000 + f" {k}</html>")
        io.write_geojson(d / "out" / "path.geojson", {"type": "FeatureCollection",
            "features": [], "version": k, "pad": "y" * 100000, "end": k})
        io.write_geotiff(d / "out" / "map.tif", np.full((2, 300, 300), k, "float32"),
            transform=from_origin(500000, 5000300, 1, 1), crs="EPSG:32631")
        ax.set_title(str(k))
        io.save_figure(fig, d / "out" / "plot.png", dpi=60)
        with io.atomic_dir(d / "campaign", overwrite=True) as tmp:
            for i in range(30):
                (tmp / f"run{i}.csv").write_text(f"t,v\\n0,{k}\\n")
            (tmp / "campaign.json").write_text(json.dumps({"version": k, "runs": 30}))
        if k == 1:
            print("ready", flush=True)
    """
)


def _complete(d: Path) -> None:
    """Every output in ``d`` is one complete version (or absent: never written)."""
    out = d / "out"
    for name in ("model.json", "path.geojson"):
        p = out / name
        if p.exists():
            doc = json.loads(p.read_text())
            assert doc["version"] == doc["end"], name
    p = out / "report.html"
    if p.exists():
        text = p.read_text()
        assert text.startswith("<html>") and text.endswith("</html>")
        assert text.split()[0][6:] == text.split()[-1][:-7]
    p = out / "map.tif"
    if p.exists():
        with rasterio.open(p) as src:
            a = src.read()
        assert a.shape == (2, 300, 300) and np.all(a == a.flat[0])
    p = out / "plot.png"
    if p.exists():
        assert p.read_bytes()[-8:-4] == b"IEND"  # a PNG's last chunk: the file is whole
    c = d / "campaign"
    if c.exists():
        meta = json.loads((c / "campaign.json").read_text())
        runs = sorted(c.glob("run*.csv"))
        assert len(runs) == meta["runs"]
        assert {r.read_text().split()[-1] for r in runs} <= {f"0,{meta['version']}"}


def _leftovers(d: Path) -> list[str]:
    return sorted(p.name for p in d.rglob(".*"))


def _env(**extra: str) -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(ROOT), **extra}


@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="POSIX signals")
def test_sigkill_at_random_points_leaves_complete_outputs_and_the_next_write_cleans(tmp_path):
    rng = random.Random(SEED)
    for attempt in range(3):
        d = tmp_path / f"try{attempt}"
        proc = subprocess.Popen(
            [sys.executable, "-c", WRITER, str(d)],
            env=_env(),
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        try:
            assert proc.stdout.readline().strip() == "ready"
            time.sleep(rng.uniform(0.0, 1.0))  # seeded: FAULT_SEED=... to vary
            proc.send_signal(signal.SIGKILL)
            assert proc.wait(timeout=60) == -signal.SIGKILL
        finally:
            if proc.poll() is None:
                proc.kill()
        _complete(d)
        # the next write of each output removes what the killed writer left beside it
        from energy_planner import io

        io.write_json(d / "out" / "model.json", {"version": 0, "end": 0})
        io.write_text(d / "out" / "report.html", "<html>0 0</html>")
        io.write_geojson(d / "out" / "path.geojson", {"version": 0, "end": 0})
        for name in ("map.tif", "plot.png"):
            with io.atomic_path(d / "out" / name) as tmp:
                tmp.write_bytes((d / "out" / name).read_bytes())
        with io.atomic_dir(d / "campaign", overwrite=True) as tmp:
            (tmp / "campaign.json").write_text('{"version": 0, "runs": 0}')
        _complete(d)
        assert _leftovers(d) == [], f"attempt {attempt}: {_leftovers(d)}"


def test_a_live_writers_temp_file_is_never_removed(tmp_path):
    """Two writers of one output: the second's cleanup leaves the first's file alone."""
    from energy_planner.io import atomic_path, remove_stale

    dest = tmp_path / "m.json"
    with atomic_path(dest) as mine:
        mine.write_text("being written")
        assert remove_stale(dest) == []  # my own, live (my pid, my lock)
        # a live writer in another process: its pid exists and it holds the lock
        other = subprocess.Popen(
            [
                sys.executable,
                "-c",
                "import sys, time; from energy_planner.io import atomic_path\n"
                f"with atomic_path({str(dest)!r}) as t:\n"
                "    t.write_text('theirs'); print(t, flush=True); time.sleep(30)",
            ],
            env=_env(),
            stdout=subprocess.PIPE,
            text=True,
        )
        try:
            theirs = Path(other.stdout.readline().strip())
            assert remove_stale(dest) == [] and theirs.exists() and mine.exists()
            other.kill()
            other.wait()
            assert remove_stale(dest) == [theirs]  # gone with its writer
        finally:
            if other.poll() is None:
                other.kill()
    assert dest.read_text() == "being written"


@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="POSIX signals")
def test_simulate_overwrite_killed_mid_campaign_keeps_one_whole_campaign(tmp_path):
    from energy_planner.simulate import CampaignConfig, simulate_campaign

    out = tmp_path / "campaign"
    small = CampaignConfig.small(slopes_deg=(0.0,), arcs=False, stand=False)
    simulate_campaign(seed=1, config=small).write(out)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    proc = subprocess.Popen(
        [*CLI, "simulate", "--out", str(out),
         "--small", "--seed", "2", "--overwrite"],
        env=_env(), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    try:  # kill it once it writes the new campaign beside the old one
        t0 = time.monotonic()
        while not any(tmp_path.glob(".campaign.*.tmp/*.csv")) and time.monotonic() - t0 < 120:
            if proc.poll() is not None:
                break
            time.sleep(0.01)
        time.sleep(random.Random(SEED).uniform(0.0, 0.3))
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    now = {p.name: p.read_bytes() for p in out.iterdir()}
    if now != before:  # it finished: then the whole new campaign, nothing of the old
        meta = json.loads(now["campaign.json"])
        runs = pd.read_csv(out / "runs.csv")
        assert meta["seed"] == 2 and set(runs["run"] + ".csv") <= set(now)
        assert not set(before) - set(now) - {"runs.csv", "campaign.json", "physics.json"}
    simulate_campaign(seed=3, config=small).write(out, overwrite=True)  # cleans the leftover
    assert sorted(p.name for p in tmp_path.iterdir()) == ["campaign"]


#: Each of the two runs: compile a new kernel into a shared cold cache, then run an
#: energy map into the shared output with the usual (shared, warm) kernel cache.
TWIN = textwrap.dedent(
    """
    import os, sys
    from energy_planner.model import _codegen
    os.environ["ENERGY_PLANNER_CACHE"] = sys.argv[1]
    power = _codegen.compile_kernel(sys.argv[2])
    assert power(2.0) == 2.0 * float(sys.argv[3])
    del os.environ["ENERGY_PLANNER_CACHE"]
    from energy_planner.cli import main
    main(sys.argv[4:])
    """
)


def test_two_runs_sharing_the_kernel_cache_and_an_output(tmp_path):
    """Both compile one new kernel into one cache and write one output: neither breaks."""
    n = 64
    dem = tmp_path / "dem.tif"
    from rasterio.transform import from_origin

    yy, xx = np.mgrid[0:n, 0:n]
    z = (5 * np.sin(xx / 9.0) * np.cos(yy / 11.0)).astype("float32")
    prof = dict(driver="GTiff", height=n, width=n, count=1, dtype="float32", crs="EPSG:32631")
    with rasterio.open(dem, "w", transform=from_origin(5e5, 5e6 + n, 1, 1), **prof) as dst:
        dst.write(z, 1)
    out, cache = tmp_path / "map.tif", tmp_path / "cache"
    k = f"{time.time_ns() % 10**9}.0"  # a kernel no cache holds yet
    src = f"def power(x):\n    return {k} * x\n"
    args = [sys.executable, "-c", TWIN, str(cache), src, k,
            "energy-map", str(dem), "--out", str(out), "--headings", "4"]  # fmt: skip
    procs = [
        subprocess.Popen(args, env=_env(), stderr=subprocess.PIPE, text=True) for _ in range(2)
    ]
    errs = [p.communicate(timeout=600)[1] for p in procs]
    assert [p.returncode for p in procs] == [0, 0], errs
    with rasterio.open(out) as src_map:
        # best_* and the summary bands (the default set)
        assert src_map.count == 4 + 4 and np.isfinite(src_map.read(1)).any()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cache", "dem.tif", "map.tif"]
    mods = sorted(cache.glob("kernels/*.py"))
    assert len(mods) == 1 and not list(cache.glob("kernels/.*"))  # one whole module
    from energy_planner.model import _codegen

    os.environ["ENERGY_PLANNER_CACHE"] = str(cache)
    try:  # a third run loads what the two left
        assert _codegen.load_generated_module(mods[0].read_text(), "power").power(1.0) == float(k)
    finally:
        del os.environ["ENERGY_PLANNER_CACHE"]


def test_a_read_only_kernel_cache_warns_compiles_elsewhere_and_keeps_it(tmp_path, monkeypatch):
    from faults import read_only_dir  # tests/ helper

    from energy_planner.model import _codegen

    with read_only_dir(tmp_path / "cache", {"keep.txt": b"mine"}) as ro:
        monkeypatch.setenv("ENERGY_PLANNER_CACHE", str(ro))
        monkeypatch.setattr(_codegen, "_WARNED", set())
        with pytest.warns(UserWarning, match="kernel cache folder cannot be written") as rec:
            used = _codegen.cache_dir()
        assert str(ro) in str(rec[0].message)
        assert not str(used).startswith(str(ro))
        power = _codegen.compile_kernel("def power(x):\n    return 2.0 * x\n")
        assert power(3.0) == 6.0
        assert sorted(p.name for p in ro.iterdir()) == ["keep.txt"]


def test_a_full_disk_is_one_clear_line_and_keeps_the_previous_output(tmp_path):
    from faults import small_disk  # tests/ helper

    from energy_planner.errors import OutputError
    from energy_planner.io import write_geotiff
    from energy_planner.simulate import CampaignConfig, simulate_campaign

    with small_disk(tmp_path / "disk", "1m") as disk:
        from rasterio.transform import from_origin

        (disk / "slope.tif").write_bytes(b"the previous slope map")
        big = np.random.default_rng(0).random((1, 700, 700)).astype("float32")  # 2 MB
        with pytest.raises(OutputError, match="no space left on the device") as err:
            write_geotiff(disk / "slope.tif", big, transform=from_origin(0, 700, 1, 1),
                          crs="EPSG:32631", compress="none")  # fmt: skip
        assert "the previous file is kept" in str(err.value) and "slope.tif" in str(err.value)
        assert (disk / "slope.tif").read_bytes() == b"the previous slope map"
        assert sorted(p.name for p in disk.iterdir()) == ["slope.tif"]
        # a campaign larger than the disk: refused whole, the previous one kept
        camp = disk / "campaign"
        camp.mkdir()
        (camp / "old.csv").write_text("the previous campaign")
        big_camp = simulate_campaign(seed=1, config=CampaignConfig.small())
        with pytest.raises(OutputError, match="no space left on the device"):
            big_camp.write(camp, overwrite=True)
        assert [p.name for p in camp.iterdir()] == ["old.csv"]
        assert sorted(p.name for p in disk.iterdir()) == ["campaign", "slope.tif"]


def test_an_output_that_is_a_folder_is_refused_by_the_writer(tmp_path):
    from energy_planner.errors import OutputError
    from energy_planner.io import write_json

    (tmp_path / "m.json").mkdir()
    with pytest.raises(OutputError, match="it is a folder"):
        write_json(tmp_path / "m.json", {"a": 1})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.json"]
