"""Faults mid-run: SIGKILL at random points, two runs at once, read-only cache, full disk.

Every command writes through ``energy_planner.io`` (``test_atomic_outputs`` holds that),
with one of these writers: JSON (fit, discover, models), text (HTML reports), GeoJSON
(plan, mission, reach), GeoTIFF (terrain, energy-map, reach), PNG (every ``--plot``)
and a whole folder (simulate). A child process writes each of them over and over (every
version complete and recognisable) and is killed with SIGKILL at a random moment; each
output must then be a complete version with nothing beside it. Every writing command is
then killed itself (through the CLI's ``main``, forked from a server that imported the
library once), in its writing and in its work before: each output stays the previous one
or the whole new one, and its folder holds nothing else. Also: ``simulate --overwrite``
killed mid-campaign, two ``energy-map`` runs writing one output at once, and
``energy-map`` and ``terrain`` onto a full disk.

What a SIGKILL may leave beside an output, exactly (:mod:`energy_planner.io.atomic`):
a file is unnamed until it is complete, then named ``.<stem>.<pid>.<random>.tmp<suffix>``
and renamed over the output by the next system call; a kill between those two calls (a
few microseconds) leaves that hidden name holding the *complete* new file, which the
next write removes. A folder is built in a private folder on the same mount (the
temporary folder here) and moved in by one rename: nothing is left beside it. Only where
no such private folder exists (the temporary folder on another mount) is it built in a
hidden ``.<name>.<pid>.<random>.tmp`` folder beside it, which a kill leaves and the next
write removes. The private folders a kill leaves in the temporary folder are removed by
the next process that builds a folder.
"""

from __future__ import annotations

import json
import os
import random
import re
import signal
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import rasterio

ROOT = Path(__file__).resolve().parents[1]
SEED = int(os.environ.get("FAULT_SEED", "31"))

#: The child: writes every kind of output, version after version, forever (forked from
#: :data:`SERVER`, which gives it ``ready()``: called once every output is written).
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
    if sys.argv[2:] == ["fallback"]:  # as where files cannot be unnamed, folders not moved
        from energy_planner.io import atomic
        atomic._open_unnamed = lambda parent, mode: None
        atomic._staging_base = lambda parent: None
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
            ready()
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


#: The only name a SIGKILL can leave beside an output file: its complete new version,
#: named for the rename over it (``.<stem>.<pid>.<random>.tmp<suffix>``).
NAMED = re.compile(r"\.(.+)\.(\d+)\.[A-Za-z0-9_]+\.tmp(\.[^.]+)?")


def _window_leftovers(folder: Path, outputs: list[Path], fallback: bool = False) -> list[Path]:
    """What a kill left beside ``outputs`` in ``folder``, checked: see the module's notes.

    Nothing, or (a kill between naming a complete file and renaming it over its output)
    one hidden file named after one of ``outputs`` and holding a complete version of it.
    Where folders cannot be built in a private folder on ``folder``'s mount, also the
    hidden work folder of a folder output. ``fallback``: files could not be unnamed nor
    folders built in a private folder; then one hidden file (maybe partial) or folder
    named after an output. Returns them.
    """
    from energy_planner.io import atomic

    staged = atomic._staging_base(folder) is not None and not fallback
    hidden = sorted(p for p in folder.rglob(".*"))
    files = [h for h in hidden if h.is_file()]
    for h in hidden:
        m = NAMED.fullmatch(h.name)
        assert m, f"{h} is beside the outputs and is not a name of one"
        out = h.parent / (m.group(1) + (m.group(3) or ""))
        if h.is_dir():
            assert not staged and out in outputs, f"{h}: a folder's hidden work folder"
            continue
        inside = out in outputs or any(o in out.parents for o in outputs)  # a folder's file
        assert inside, f"{h} is not a temporary name of an output"
        if not fallback:
            _whole(h)  # named only when complete
    assert len(files) <= 1 or fallback, f"more than one named temporary file: {files}"
    return hidden


def _env(**extra: str) -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(ROOT), **extra}


@pytest.mark.skipif(not hasattr(os, "fork"), reason="POSIX fork and signals")
def test_sigkill_at_random_points_leaves_complete_outputs_and_the_next_write_cleans(
    tmp_path, fork_server
):
    rng = random.Random(SEED)
    for attempt in range(3):
        d = tmp_path / f"try{attempt}"
        fallback = attempt == 2  # the last as where files cannot be unnamed
        # the writer in a child forked from the server (the libraries imported once), killed
        # at a seeded random moment up to 1 s after its first whole round of writes
        delay = rng.uniform(0.0, 1.0)  # seeded: FAULT_SEED=... to vary
        args = [str(d), *(["fallback"] if fallback else [])]
        got = fork_server(tmp_path, args, delay, True, code=WRITER)
        assert got["wrote"] is not None and got["killed"], got  # ready, then killed
        assert got["code"] == -signal.SIGKILL, got
        _complete(d)
        outputs = [d / "out" / n for n in ("model.json", "report.html", "path.geojson",
                                           "map.tif", "plot.png")] + [d / "campaign"]  # fmt: skip
        left = _window_leftovers(d, outputs, fallback)
        assert {p.name for p in (d / "out").iterdir()} - {p.name for p in left} <= {
            p.name for p in outputs
        }
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
        # and the private folders the killed writer left in the temporary folder
        assert not list(Path(tempfile.gettempdir()).glob(f"energy_planner.{got['pid']}.*"))


def test_a_live_writers_temp_file_is_never_removed(tmp_path, monkeypatch):
    """Two writers of one output: the second's cleanup leaves the first's file alone.

    Hidden temporary names beside an output exist where files cannot be unnamed (forced
    here in both processes), and for an instant before each rename where they can.
    """
    from faults import named_files  # tests/ helper

    from energy_planner.io import atomic_path, remove_stale

    named_files(monkeypatch)
    dest = tmp_path / "m.json"
    with atomic_path(dest) as mine:
        mine.write_text("being written")
        assert remove_stale(dest) == []  # my own, live (my pid, my lock)
        # a live writer in another process: its pid exists and it holds the lock
        other = subprocess.Popen(
            [
                sys.executable,
                "-c",
                "import sys, time, pytest; from energy_planner.io import atomic_path\n"
                "from faults import named_files; named_files(pytest.MonkeyPatch())\n"
                f"with atomic_path({str(dest)!r}) as t:\n"
                "    t.write_text('theirs'); print(t, flush=True); time.sleep(30)",
            ],
            env=_env(PYTHONPATH=f"{ROOT}{os.pathsep}{ROOT / 'tests'}"),
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


#: ``simulate`` (the CLI's ``main(args)``) that calls ``ready()`` once it writes the new
#: campaign: in a private folder on the same mount (the temporary folder, as here), or where
#: there is none in a hidden folder beside the old one (a thread looks every 10 ms).
BUILDING = textwrap.dedent(
    """
    import os, sys, tempfile, threading, time
    from pathlib import Path
    from energy_planner.cli import main

    def watch():
        private, here = Path(tempfile.gettempdir()), Path.cwd()
        while not (any(private.glob(f"energy_planner.{os.getpid()}.*/campaign/*.csv"))
                   or any(here.glob(".campaign.*.tmp/campaign/*.csv"))):
            time.sleep(0.01)
        ready()

    threading.Thread(target=watch, daemon=True).start()
    main(sys.argv[1:])
    """
)


@pytest.mark.skipif(not hasattr(os, "fork"), reason="POSIX fork and signals")
def test_simulate_overwrite_killed_mid_campaign_keeps_one_whole_campaign(tmp_path, fork_server):
    from energy_planner.io.atomic import _staging_base
    from energy_planner.simulate import CampaignConfig, simulate_campaign

    out = tmp_path / "campaign"
    small = CampaignConfig.small(slopes_deg=(0.0,), arcs=False, stand=False)
    simulate_campaign(seed=1, config=small).write(out)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    private = Path(tempfile.gettempdir())
    staged = _staging_base(tmp_path) is not None
    # killed at a random moment up to 0.3 s after it starts writing the new campaign (in
    # a child forked from the server: the library imported once)
    args = ["simulate", "--out", str(out), "--small", "--seed", "2", "--overwrite"]
    delay = random.Random(SEED).uniform(0.0, 0.3)
    got = fork_server(tmp_path, args, delay, True, code=BUILDING)
    assert got["killed"] or got["code"] == 0, got  # killed, or it finished first
    now = {p.name: p.read_bytes() for p in out.iterdir()}
    if now != before:  # it finished: then the whole new campaign, nothing of the old
        meta = json.loads(now["campaign.json"])
        runs = pd.read_csv(out / "runs.csv")
        assert meta["seed"] == 2 and set(runs["run"] + ".csv") <= set(now)
        assert not set(before) - set(now) - {"runs.csv", "campaign.json", "physics.json"}
    if staged:  # built in the temporary folder: nothing beside the campaign
        assert sorted(p.name for p in tmp_path.iterdir()) == ["campaign"]
    simulate_campaign(seed=3, config=small).write(out, overwrite=True)  # cleans the leftover
    assert sorted(p.name for p in tmp_path.iterdir()) == ["campaign"]
    assert not list(private.glob(f"energy_planner.{got['pid']}.*"))  # and the private folder


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


def test_two_runs_sharing_the_kernel_cache_and_an_output(tmp_path, fork_server):
    """Both compile one new kernel into one cache and write one output: neither breaks.

    The two runs are two processes at once, forked from the fork server (the library
    imported once) rather than two new interpreters."""
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
    args = [str(cache), src, k, "energy-map", str(dem), "--out", str(out), "--headings", "4"]
    got = fork_server(tmp_path, args, 0.0, False, code=TWIN, copies=2)
    assert got["codes"] == [0, 0], got["errs"]
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


# ------------------------------------------------------ every writing command, killed

#: A fork server: imports the whole library once (with ``LAZY``, the modules it imports
#: only where they are used), then for each job forks a child that
#: runs one command (``main(args)``, the CLI itself) and kills it with SIGKILL ``delay``
#: s after its start, or after it starts writing its first output (the writer of an
#: output in its folder starts: ``energy_planner.io.atomic.remove_stale``, which every
#: write calls first). Forking keeps each command's start cheap, so that every writing
#: command can be killed at a few random points in a few seconds. A job with ``code``
#: runs that script instead (``python -c code *args``), whose ``ready()`` starts the delay:
#: the writers of :data:`WRITER`, which imported matplotlib, rasterio and the library
#: afresh in a new interpreter each (about 1.5 s of CPU per kill). A job with ``copies``
#: forks that many children of ``code`` at once and waits for them: the two runs of
#: :data:`TWIN`.
SERVER = textwrap.dedent(
    """
    import importlib, json, os, pkgutil, select, signal, sys, time
    LAZY = ("scipy.ndimage", "scipy.optimize", "scipy.special", "scipy.sparse.csgraph",
            "scipy.spatial.transform", "pyproj", "shapely.geometry", "shapely.ops",
            "plotly.graph_objects", "pyarrow.parquet", "pyarrow.csv", "rasterio.warp")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot
    import energy_planner
    for m in pkgutil.walk_packages(energy_planner.__path__, "energy_planner."):
        try:
            importlib.import_module(m.name)
        except Exception:
            pass
    # and what the library imports only where it is used (its start-up stays short), which
    # every forked command would otherwise import again, twice per command
    for name in LAZY:
        try:
            importlib.import_module(name)
        except Exception:
            pass
    # a page's first figure loads plotly's figure classes, their validators and the
    # template (about 1 s of CPU), which every forked command that writes --html would
    # load again: one page here, on a grid (no terrain, no kernel)
    import numpy as np
    from rasterio.transform import from_origin
    from energy_planner.webmap import WebMap
    page = WebMap.of_grid("warm-up", np.zeros((4, 4)), from_origin(0, 4, 1, 1), (4, 4),
                          "EPSG:32631")
    for name in ("a", "b"):
        page.add_raster(name, np.arange(16.0).reshape(4, 4), "J")
    page.add_contour(np.arange(16.0).reshape(4, 4), 8.0, "budget")
    page.add_route("route", [[0.5, 0.5], [2.5, 2.5]], hover=["a", "b"])
    page.add_points("sites", [[0.5, 0.5]], ["a"], ["a"])
    page.html()
    from energy_planner.cli import main
    # the bundled model's motion kernels, loaded once here rather than by every forked
    # command (no parallel kernel: its threads would not survive a fork)
    import energy_planner as ep
    hill = ep.Terrain.from_function(lambda x, y: 0.1 * x, size=(20, 20))
    ep.Problem(hill, ep.load_model()).cost.compile()
    print("ready", flush=True)

    from energy_planner.io import atomic

    def telling(start, w, cwd):
        def wrapped(dest, *a, **k):  # the write of an output in the folder starts
            if os.path.realpath(dest).startswith(cwd):
                try:
                    os.write(w, b"w")
                except OSError:
                    pass
            return start(dest, *a, **k)
        return wrapped

    for line in sys.stdin:
        job = json.loads(line)
        if job.get("copies"):  # the script in that many children at once, none killed
            import tempfile, traceback
            pids = []
            for _ in range(job["copies"]):
                pid = os.fork()
                if pid == 0:
                    os.chdir(job["cwd"])
                    err = os.open(os.path.join(tempfile.gettempdir(),
                                               f"fork_server.{os.getpid()}.err"),
                                  os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
                    os.dup2(err, 2)
                    os.dup2(os.open(os.devnull, os.O_WRONLY), 1)  # the server's replies
                    code = 0
                    try:
                        sys.argv = ["-c", *job["args"]]
                        exec(job["code"], {"__name__": "__main__"})
                    except SystemExit as e:
                        code = e.code if isinstance(e.code, int) else 1
                    except BaseException:
                        traceback.print_exc()
                        code = 99
                    sys.stderr.flush()
                    os._exit(code)
                pids.append(pid)
            codes = [os.waitstatus_to_exitcode(os.waitpid(p, 0)[1]) for p in pids]
            errs = []
            for p in pids:
                f = os.path.join(tempfile.gettempdir(), f"fork_server.{p}.err")
                with open(f) as fh:
                    errs.append(fh.read())
                os.remove(f)
            print(json.dumps({"codes": codes, "pids": pids, "errs": errs}), flush=True)
            continue
        r, w = os.pipe()
        t0 = time.monotonic()
        pid = os.fork()
        if pid == 0:
            os.close(r)
            cwd = os.path.realpath(job["cwd"])
            if job.get("code") is None:
                atomic.remove_stale = telling(atomic.remove_stale, w, cwd)
            os.chdir(cwd)
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, 1)
            os.dup2(null, 2)
            code = 0
            try:
                if job.get("code") is None:
                    main(job["args"])
                else:  # a script, run as ``python -c code *args``; it calls ready()
                    sys.argv = ["-c", *job["args"]]
                    exec(job["code"], {"__name__": "__main__",
                                       "ready": lambda: os.write(w, b"w")})
            except SystemExit as e:
                code = e.code if isinstance(e.code, int) else 1
            except BaseException:
                code = 99
            os._exit(code)
        os.close(w)
        # the delay counts from the start, or ("after_write") from the first output write
        start, wrote, killed = (None if job["after_write"] else t0), None, False
        while True:
            done, status = os.waitpid(pid, os.WNOHANG)
            if done:
                break
            ready = select.select([r], [], [], 0.002)[0]
            if ready and os.read(r, 64) and wrote is None:
                wrote = time.monotonic()
                start = start or wrote
            if start is not None and time.monotonic() - start >= job["delay"]:
                os.kill(pid, signal.SIGKILL)
                _, status = os.waitpid(pid, 0)
                killed = True
                break
        os.close(r)
        print(json.dumps({"code": os.waitstatus_to_exitcode(status), "killed": killed,
                          "pid": pid,
                          "elapsed": time.monotonic() - t0,
                          "wrote": None if wrote is None else wrote - t0}), flush=True)
    os._exit(0)  # every reply is flushed: the interpreter's teardown (~1 s of CPU) is not needed
    """
)

START, GOAL = "500010,5000010", "500040,5000050"

#: Every command that writes, with its outputs (relative to its folder) and inputs
#: (``{name}``: a file of the ``inputs`` fixture). ``energy`` prints only: not here.
#: What a command computes before it writes does not matter here, only that it is killed
#: in that work and in its writing: the calibration commands skip the data repairs' held-out
#: checks and the staircase's steps (``--no-repair``, ``--max-steps 0``), which were most
#: of their time (the same outputs are written, by the same writers).
COMMANDS: dict[str, list[str]] = {
    "terrain": ["terrain", "{dem}", "--slope-out", "o/slope.tif", "--aspect-out",
                "o/aspect.tif", "--plot", "o/slope.png"],
    "plan": ["plan", "--dem", "{dem}", "--start", START, "--goal", GOAL, "--out",
             "o/path.geojson", "--plot", "o/path.png", "--html", "o/path.html"],
    "compare-routes": ["compare-routes", "--dem", "{dem}", "--start", START, "--goal", GOAL,
                       "--time", "0.2", "--plot", "o/routes.png", "--html", "o/routes.html"],
    "reach": ["reach", "{dem}", "--start", START, "--budget-wh", "1", "--battery-wh", "2",
              "--out", "o/reach.tif", "--chance-out", "o/chance.tif", "--geojson",
              "o/reach.geojson", "--plot", "o/reach.png"],
    "mission": ["mission", "--dem", "{dem}", "--sites", "{sites}", "--geojson",
                "o/tour.geojson", "--plot", "o/tour.png", "--nav2-graph", "o/graph.geojson"],
    "energy-map": ["energy-map", "{dem}", "--headings", "4", "--out", "o/map.tif", "--plot",
                   "o/map.png", "--html", "o/map.html"],
    "fit": ["fit", "{logs}", "--out", "o/model.json", "--no-repair"],
    "discover": ["discover", "{logs}", "--out", "o/model.json", "--report", "o/report.html",
                 "--folds", "2", "--max-steps", "0", "--no-repair"],
    "diagnose": ["diagnose", "{logs}", "--report", "o/report.html", "--folds", "2",
                 "--max-steps", "0", "--no-repair"],
    "figures": ["figures", "{logs}", "--out", "o/figures"],
    "simulate": ["simulate", "--small", "--seed", "2", "--out", "o/campaign", "--overwrite",
                 "--plot", "o/fig4.png"],
    "follow": ["follow", "{walk}", "--dem", "hill", "--html", "o/follow.html"],
    "demo": ["demo", "--scenario", "plane", "--time", "0.5", "--plot", "o/demo.png"],
}  # fmt: skip


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """A 60 m hill, sites on it, a tiny campaign's logs and a 20 s walk on the bundled hill."""
    import energy_planner as ep
    from energy_planner.follow.calibrate import forward_mission
    from energy_planner.simulate import CampaignConfig, simulate_campaign, simulate_missions

    d = tmp_path_factory.mktemp("killed")
    n = 30
    yy, xx = np.mgrid[0:n, 0:n]
    z = (4.0 * np.exp(-((xx - 15.0) ** 2 + (yy - 15.0) ** 2) / 80.0)).astype("float32")
    prof = dict(driver="GTiff", height=n, width=n, count=1, dtype="float32", crs="EPSG:32631")
    from rasterio.transform import from_origin

    with rasterio.open(d / "dem.tif", "w", transform=from_origin(5e5, 5000060, 2, 2), **prof) as f:
        f.write(z, 1)
    (d / "sites.csv").write_text("x,y\n500010,5000010\n500040,5000050\n500012,5000045\n")
    tiny = CampaignConfig.small(
        slopes_deg=(0.0, 20.0), headings_deg=(0.0, 180.0), run_s=4.0, arcs=False, stand=False,
        composite_slopes_deg=(),
    )  # fmt: skip
    simulate_campaign(seed=1, config=tiny).write(d / "logs")
    walk = forward_mission(150.0, 20.0).replace(duration_s=20.0)
    hill = ep.open_terrain(ep.map_path("hill"))
    simulate_missions(seed=2, config=walk, terrain=hill).logs.to_csv(d / "walk.csv", index=False)
    return {
        "dem": d / "dem.tif",
        "sites": d / "sites.csv",
        "logs": d / "logs",
        "walk": d / "walk.csv",
    }


@pytest.fixture(scope="module")
def fork_server():
    """``run(cwd, args, delay, after_write, code=None, copies=0)``: one command (or the
    script ``code`` with ``args``) in a forked child, killed; with ``copies``, that many
    children of the script at once, none killed (``{"codes", "pids", "errs"}``)."""
    proc = subprocess.Popen(
        [sys.executable, "-c", SERVER], env=_env(), stdin=subprocess.PIPE,
        stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    assert proc.stdout.readline().strip() == "ready"

    def run(
        cwd: Path,
        args: list[str],
        delay: float,
        after_write: bool,
        code: str | None = None,
        copies: int = 0,
    ) -> dict:
        job = {"cwd": str(cwd), "args": args, "delay": delay, "after_write": after_write,
               "code": code, "copies": copies}  # fmt: skip
        proc.stdin.write(json.dumps(job) + "\n")
        proc.stdin.flush()
        return json.loads(proc.stdout.readline())

    try:
        yield run
    finally:
        proc.stdin.close()
        proc.wait(timeout=60)


def _outputs(args: list[str]) -> list[str]:
    return [a for a in args if a.startswith("o/")]


def _whole(path: Path) -> None:
    """``path`` is one complete output of its kind (a folder: each of its files)."""
    if path.is_dir():
        files = [p for p in path.rglob("*") if p.is_file() and not p.name.startswith(".")]
        assert files, f"{path} is empty"
        for p in files:
            _whole(p)
        if (path / "campaign.json").exists():  # a campaign: every run its table lists
            json.loads((path / "campaign.json").read_text())
            runs = pd.read_csv(path / "runs.csv")
            assert all((path / f"{r}.csv").is_file() for r in runs["run"]), path
        return
    data = path.read_bytes()
    assert data, f"{path} is empty"
    if path.suffix in (".json", ".geojson"):
        json.loads(data)
    elif path.suffix == ".tif":
        with rasterio.open(path) as src:
            src.read()
    elif path.suffix == ".png":
        assert data[-8:-4] == b"IEND", f"{path} is cut short"  # a PNG's last chunk
    elif path.suffix == ".html":
        assert data.rstrip().endswith(b"</html>"), f"{path} is cut short"
    elif path.suffix == ".csv":
        assert data.endswith(b"\n"), f"{path} is cut short"
        pd.read_csv(path)


def _previous(path: Path) -> None:
    """Write a small, whole output of ``path``'s kind: the previous output."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix in (".json", ".geojson"):
        path.write_text('{"previous": true}')
    elif path.suffix == ".html":
        path.write_text("<html>the previous report</html>")
    elif path.suffix == ".png":
        import matplotlib.pyplot as plt

        plt.imsave(path, np.zeros((2, 2)))
    elif path.suffix == ".tif":
        from rasterio.transform import from_origin

        prof = dict(driver="GTiff", height=1, width=1, count=1, dtype="float32")
        with rasterio.open(path, "w", transform=from_origin(0, 1, 1, 1), **prof) as dst:
            dst.write(np.zeros((1, 1, 1), "float32"))
    elif path.name == "campaign":  # a campaign of no run
        path.mkdir()
        (path / "campaign.json").write_text('{"previous": true}')
        (path / "runs.csv").write_text("run\n")
    else:  # a folder of figures
        _previous(path / "previous.png")


@pytest.mark.skipif(not hasattr(os, "fork"), reason="POSIX fork and signals")
@pytest.mark.parametrize("command", list(COMMANDS))
def test_every_writing_command_killed_at_random_points(command, inputs, fork_server, tmp_path):
    """SIGKILL at seeded random points: each output is the previous one or the whole new one.

    Each output first holds a previous version. The command is killed twice: at a random
    moment up to 0.3 s after it starts writing its outputs, and at a random moment of its
    work before that. After each kill every output is there and whole (the previous one
    or the complete new one: never gone, never cut short), every visible file is whole,
    and the output folder holds the outputs and nothing else (but what the module's
    notes allow: a complete new file under a hidden name, left by a kill between the
    two system calls that name it and rename it over its output). The private folders
    the killed command left in the temporary folder are removed by the next folder
    output's writer.
    """
    from energy_planner.io import atomic

    args = [a.format(**{k: str(v) for k, v in inputs.items()}) for a in COMMANDS[command]]
    outs = [tmp_path / o for o in _outputs(args)]
    for p in outs:
        _previous(p)
    top = {p.relative_to(tmp_path / "o").parts[0] for p in outs}
    rng = random.Random(f"{SEED}:{command}")  # FAULT_SEED=... to vary
    wrote, pids = None, []
    for after_write in (True, False):  # in its writing, then in its work before
        delay = rng.uniform(0.0, 0.3) if after_write else rng.uniform(0.1, 1.0) * wrote
        got = fork_server(tmp_path, args, delay, after_write)
        pids.append(got["pid"])
        assert got["killed"] or got["code"] == 0, f"{command}: {got}"
        assert got["wrote"] is not None or not after_write, f"{command} wrote nothing: {got}"
        wrote = wrote or got["wrote"]
        for p in outs:
            assert p.exists(), f"{command} killed after {delay:.2f} s: {p.name} is gone"
            _whole(p)
        for p in (tmp_path / "o").rglob("*"):
            if p.is_file() and not any(x.startswith(".") for x in p.relative_to(tmp_path).parts):
                _whole(p)
        # nothing beside the outputs (but the one complete file a kill may leave named)
        left = _window_leftovers(tmp_path / "o", outs)
        visible = {p.name for p in (tmp_path / "o").iterdir()} - {p.name for p in left}
        assert visible == top, f"{command} left {sorted(visible - top)} beside its outputs"
        for h in left:  # the next write of its output removes it
            m = NAMED.fullmatch(h.name)
            atomic.remove_stale(h.parent / (m.group(1) + (m.group(3) or "")))
    left = sorted(str(p.relative_to(tmp_path)) for p in (tmp_path / "o").rglob(".*"))
    assert left == [], f"{command}: left beside its outputs: {left}"
    atomic._sweep(Path(tempfile.gettempdir()), again=True)  # as the next folder output does
    for pid in pids:
        assert not list(Path(tempfile.gettempdir()).glob(f"energy_planner.{pid}.*")), command


def test_commands_onto_a_full_disk_are_one_clear_line_and_keep_the_previous_outputs(tmp_path):
    """The commands themselves, not only the writers: GDAL's failed flush is caught too.

    An energy map written by windows reported a full disk only in GDAL's log and renamed
    the cut-short file over the previous map (then a traceback reading it back).
    """
    from click.testing import CliRunner
    from faults import small_disk  # tests/ helper
    from rasterio.transform import from_origin

    from energy_planner.cli import main

    n = 300  # its 4-heading energy map: 2.9 MB of float32, its slope map 0.36 MB x 3
    z = np.random.default_rng(0).random((n, n)).astype("float32")
    prof = dict(driver="GTiff", height=n, width=n, count=1, dtype="float32", crs="EPSG:32631")
    dem = tmp_path / "dem.tif"
    with rasterio.open(dem, "w", transform=from_origin(5e5, 5e6 + n, 1, 1), **prof) as dst:
        dst.write(z, 1)
    with small_disk(tmp_path / "disk", "1m") as disk:
        (disk / "map.tif").write_bytes(b"the previous map")
        (disk / "slope.tif").write_bytes(b"the previous slope map")
        for args in (
            ["energy-map", str(dem), "--headings", "4", "--out", str(disk / "map.tif")],
            ["terrain", str(dem), "--slope-out", str(disk / "slope.tif"), "--aspect-out",
             str(disk / "aspect.tif"), "--plot", str(disk / "slope.png")],
        ):  # fmt: skip
            r = CliRunner().invoke(main, args)
            assert r.exit_code != 0 and "Traceback" not in r.output, r.output
            assert "no space left on the device" in r.output, r.output
        assert (disk / "map.tif").read_bytes() == b"the previous map"  # 2.9 MB: never fits
        # terrain's outputs: each the previous one, or whole (those written before the
        # disk filled); nothing else on the disk
        if (disk / "slope.tif").read_bytes() != b"the previous slope map":
            _whole(disk / "slope.tif")
        for p in disk.glob("aspect.tif"):
            _whole(p)
        names = {p.name for p in disk.iterdir()}
        assert {"map.tif", "slope.tif"} <= names <= {"map.tif", "slope.tif", "aspect.tif"}
