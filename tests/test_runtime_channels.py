"""#21 point 3: channel values are run-time inputs of every kernel, never compiled in.

A second, distinct ``--set`` value (or numeric channel raster) must compile nothing in
any command that prices energy (``energy``, ``plan``, ``reach``, ``energy-map``): no new
generated kernel module,
no numba cache miss (a compilation), no new file of compiled code in the kernel
cache. And the numbers follow the value: on a plane rising east, walking up or down the
fall line facing along is priced by the model's numpy formula (``EnergyModel.power``)
times the time per map metre, and the energy of a straight climb is that times its
length.
"""

from __future__ import annotations

import json
import math
import sys
from functools import partial

import numpy as np
import pytest
from b1_model import B1, b1_model  # tests/ helper
from click.testing import CliRunner

from energy_planner.cli import main
from energy_planner.model._codegen import cache_dir

# a 40 m plane rising east at 10 degrees (on a node of the heading table: its lookup is
# exact there)
X0, Y0, N, GRADE = 500000.0, 5000000.0, 40, math.tan(math.radians(10.0))
K_LOAD = 7.0  # W per kg and m/s
MODEL = b1_model(B1, extra={"load_kg * speed": K_LOAD})
SPEED = 0.3


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    import rasterio
    from affine import Affine

    d = tmp_path_factory.mktemp("runtime")

    def tif(path, z):
        with rasterio.open(
            path, "w", driver="GTiff", width=N, height=N, count=1, dtype="float64",
            crs="EPSG:32631", transform=Affine(1.0, 0, X0, 0, -1.0, Y0 + N),
        ) as dst:  # fmt: skip
            dst.write(z, 1)
        return path

    dem = tif(d / "plane.tif", np.tile(100.0 + GRADE * np.arange(N, dtype=float), (N, 1)))
    for load in (3, 41):  # a numeric channel raster per load, the same everywhere
        tif(d / f"load_{load}.tif", np.full((N, N), float(load)))
    wp = d / "w.csv"
    wp.write_text(f"x,y\n{X0 + 10.5},{Y0 + 20.5}\n{X0 + 30.5},{Y0 + 20.5}\n")
    return {"dem": dem, "wp": wp, "model": MODEL.save(d / "load.json"), "dir": d}


def _compiled() -> tuple[dict, list[str]]:
    """What is compiled in this process and on disk: a snapshot to compare."""
    from numba.core.registry import CPUDispatcher

    state = {}
    stems = set()
    for name, mod in list(sys.modules.items()):
        if not name.startswith("energy_planner_kernel_"):
            continue
        stems.add(name.removeprefix("energy_planner_kernel_"))
        for key, fn in vars(mod).items():
            if isinstance(fn, CPUDispatcher):
                # a compilation is a miss of numba's cache (a signature loaded from the
                # cache, e.g. the table kernel run for the first time, is not)
                state[name, key] = sum(fn.stats.cache_misses.values())
    # the files of this process's kernel modules only: the cache is shared with the other
    # test workers, which compile their own kernels at the same time
    root = cache_dir()
    code = sorted(
        str(p.relative_to(root))
        for p in root.rglob("*")
        if p.suffix in (".py", ".nbi", ".nbc") and p.name.split(".")[0] in stems
    )
    return state, code


def _formula_per_map_metre(load: float, downhill: bool) -> float:
    """J per map metre facing along the fall line, from the model's numpy formula."""
    alpha = math.atan(GRADE)
    feats = {
        "alpha": np.array([alpha]), "gamma": np.array([math.pi if downhill else 0.0]),
        "vx": np.array([SPEED]), "vy": np.zeros(1), "wz": np.zeros(1), "ax": np.zeros(1),
        "ay": np.zeros(1), "load_kg": np.array([load]),
    }  # fmt: skip
    seconds_per_map_metre = math.hypot(1.0, GRADE) / SPEED
    return float(MODEL.power(feats)[0]) * seconds_per_map_metre


def _run(args: list) -> dict:
    r = CliRunner().invoke(main, [str(a) for a in args])
    assert r.exit_code == 0, r.output
    return json.loads(r.stdout)


def _map_and_energy(files, load: float, raster: bool = False) -> dict:
    """``energy-map`` and ``energy`` with ``--set load_kg=load`` (or a raster of it)."""
    import rasterio

    s = ["--model", files["model"], "--set", f"load_kg={load:g}"]
    if raster:
        s = ["--model", files["model"], "--channel", f"load_kg={files['dir']}/load_{load:g}.tif"]
    out = files["dir"] / f"map_{load:g}_{raster}.tif"
    _run(["energy-map", files["dem"], "--out", out, "--headings", "16", "--json", "--bands",
          "all", "--encoding", "float32", *s])  # fmt: skip
    with rasterio.open(out) as src:
        along_east = src.read(1)[20, 20]  # along_000: up the fall line
        along_west = src.read(9)[20, 20]  # along_180: down it
    energy = _run(["energy", "--dem", files["dem"], "--waypoints", files["wp"], "--json", *s])
    return {"east": along_east, "west": along_west, "energy": energy["energy_j"]}


def _plan_and_reach(files, load: float) -> dict:
    """``plan`` and ``reach`` (their search heuristic's heading table) with that value."""
    s = ["--model", files["model"], "--set", f"load_kg={load:g}"]
    start, goal = f"{X0 + 10.5},{Y0 + 20.5}", f"{X0 + 14.5},{Y0 + 20.5}"
    plan = _run(["plan", "--dem", files["dem"], "--start", start, "--goal", goal, "--json", *s])
    _run(["reach", files["dem"], "--start", start, "--budget-wh", "1", "--within-budget",
          "--json", *s])  # fmt: skip
    return {"plan": plan["energy_j"]}


def _twice(doors, files, monkeypatch) -> tuple[dict, dict]:
    """``doors`` with load 3, then with load 41; asserts the second compiled nothing."""
    # the heading tables of both values are built here, not read from an earlier run
    monkeypatch.setattr("energy_planner.energy.heading._load_table", lambda key, depth=3: None)
    monkeypatch.setattr("energy_planner.energy.heading._save_table", lambda key, t: None)
    first = doors(files, 3.0)  # compiles (or loads) whatever these commands need
    before = _compiled()
    second = doors(files, 41.0)  # a value never seen before
    after = _compiled()
    assert after[0] == before[0]  # the same kernel modules, no numba cache miss
    # no new kernel module written for this process (the folder's files of the same modules
    # may still change: the cache is shared with the other workers, which compile the same
    # model's kernels at the same time; a module this process wrote would be imported, and
    # the first assert would see it)
    assert set(after[1]) >= set(before[1])
    return first, second


@pytest.mark.parametrize("raster", [False, True], ids=["set", "channel-raster"])
def test_a_new_value_compiles_nothing_in_energy_map_and_energy(files, monkeypatch, raster):
    first, second = _twice(partial(_map_and_energy, raster=raster), files, monkeypatch)
    for load, got in ((3.0, first), (41.0, second)):
        up = _formula_per_map_metre(load, downhill=False)
        down = _formula_per_map_metre(load, downhill=True)
        assert got["east"] == pytest.approx(up, rel=1e-6)  # float32 band
        assert got["west"] == pytest.approx(down, rel=1e-6)
        # a straight 20 m climb facing along: the same price per map metre
        assert got["energy"] == pytest.approx(20.0 * up, rel=1e-9)
    # the load term adds K_LOAD * (41 - 3) N (W per m/s) over the 20 m climb's ground length
    extra = K_LOAD * 38.0 * 20.0 * math.hypot(1.0, GRADE)
    assert second["energy"] - first["energy"] == pytest.approx(extra, rel=1e-9)


def test_a_new_set_value_compiles_nothing_in_plan_and_reach(files, monkeypatch):
    first, second = _twice(_plan_and_reach, files, monkeypatch)
    for load, got in ((3.0, first), (41.0, second)):
        # never dearer than walking the 4 m straight up facing along
        assert 0 < got["plan"] <= 4.0 * _formula_per_map_metre(load, False) * (1 + 1e-9)
    assert second["plan"] > first["plan"]  # the load is priced
