"""#21 point 5: the ``energy`` command's path imports no pandas (about 0.2-0.5 s of start-up).

The per-segment table is computed with numpy; ``PathEnergy.segments`` builds the pandas
frame only when asked, and holds the same numbers as the JSON rows.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
from _energy_process import energy_in_process

from energy_planner.maps import map_path


def test_energy_command_does_not_import_pandas(tmp_path):
    wp = tmp_path / "w.csv"
    wp.write_text("x,y\n500058,5000046\n500058,5000080\n500090,5000080\n")
    res = energy_in_process(map_path("hill"), wp, "pandas")
    assert res["imported"]["pandas"] is False
    segs = res["out"]["segments"]
    assert [s["segment"] for s in segs] == [0, 1]
    # the segments add up to the totals
    total = res["out"]["energy_j"]
    assert abs(sum(s["energy_j"] for s in segs) - total) <= 1e-9 * total


def test_segments_frame_equals_the_table():
    from energy_planner.energy import path_energy
    from energy_planner.model import EnergyModel
    from energy_planner.terrain import load_dem

    t = load_dem(map_path("hill"))
    xy = np.array([[500058.0, 5000046.0], [500058.0, 5000080.0], [500090.0, 5000080.0]])
    pe = path_energy(t, EnergyModel.default(), xy)
    df = pe.segments
    rows = pe.to_dict()["segments"]
    # the JSON rows add the map (horizontal) distance of each segment to the table's columns
    assert list(df.columns) == [c for c in rows[0] if c != "map_distance_m"]
    for i, row in enumerate(rows):
        for c, v in row.items():
            if c != "map_distance_m":
                np.testing.assert_equal(df[c].iloc[i], v)
    # a corner: the turn in place belongs to the second segment, its time at the yaw rate
    assert rows[0]["turn_deg"] == 0.0 and abs(rows[1]["turn_deg"] - 90.0) < 1e-9
    assert abs(sum(r["duration_s"] for r in rows) - pe.duration_s) <= 1e-9 * pe.duration_s


FRESH = (
    "import json, sys\n"
    "from click.testing import CliRunner\n"
    "from energy_planner.cli import main\n"
    "r = CliRunner().invoke(main, ['energy', '--dem', sys.argv[1], '--waypoints', sys.argv[2],"
    " '--json', '--model', sys.argv[3], '--set', 'load_kg=' + sys.argv[4]])\n"
    "assert r.exit_code == 0, r.output\n"
    "heavy = [m for m in ('numba', 'scipy.stats', 'scipy.special', 'pandas') if m in sys.modules]\n"
    "print(json.dumps({'heavy': heavy, 'out': json.loads(r.stdout)}))\n"
)


def test_precompiled_energy_loads_no_numba_and_prices_as_numba(tmp_path):
    """``energy`` runs the model's precompiled kernels: numba, scipy.stats and
    scipy.special stay unloaded, a new ``--set`` value compiles nothing, and every
    segment's energy is the numba kernels' to the last bit (the same code, compiled
    ahead of time); the load term adds what its formula says."""
    import os

    from energy_planner.energy import path_energy
    from energy_planner.model import EnergyModel
    from energy_planner.terrain import load_dem

    base = EnergyModel.default()
    model = EnergyModel(
        [t.name for t in base.terms] + ["load_kg * speed"],
        {**base.coefficients, "load_kg * speed": 5.0},
    )
    path = tmp_path / "load.json"
    model.save(path)
    wp = tmp_path / "w.csv"
    wp.write_text("x,y\n500058,5000046\n500058,5000080\n500090,5000080\n")
    xy = np.array([[500058.0, 5000046.0], [500058.0, 5000080.0], [500090.0, 5000080.0]])
    terrain = load_dem(map_path("hill"))
    env = {**os.environ, "ENERGY_PLANNER_PRECOMPILE": "1"}
    totals = []
    for load in (7.25, 31.5):  # the second value: the module built for the first serves
        done = subprocess.run(
            [sys.executable, "-c", FRESH, str(map_path("hill")), str(wp), str(path), str(load)],
            capture_output=True, text=True, check=True, env=env,
        )  # fmt: skip
        res = json.loads(done.stdout.strip().splitlines()[-1])
        assert res["heavy"] == []
        if load == 31.5:
            assert "compiling" not in done.stderr
        ref = path_energy(terrain, model, xy, constants={"load_kg": load})  # numba's kernels
        got = [s["energy_j"] for s in res["out"]["segments"]]
        assert got == [r["energy_j"] for r in ref.to_dict()["segments"]]
        totals.append((res["out"]["energy_j"], res["out"]["distance_m"]))
    # 5 W per kg and m/s, integrated over the walk (the turn in place has no speed):
    # 24.25 kg more adds 5 * 24.25 J per metre walked
    (e0, d0), (e1, d1) = totals
    assert d0 == d1 and abs((e1 - e0) - 5.0 * 24.25 * d0) < 1e-9 * e1


MAP = (
    "import json, sys\n"
    "from click.testing import CliRunner\n"
    "from energy_planner.cli import main\n"
    "r = CliRunner().invoke(main, ['energy-map', 'hill', '--out', sys.argv[1], '--bands', 'all',"
    " '--max-crab', '20', '--max-backward-slope', '5', '--encoding', 'float32', '--json'])\n"
    "assert r.exit_code == 0, r.output\n"
    "print(json.dumps({'numba': 'numba' in sys.modules}))\n"
)


def test_precompiled_energy_map_loads_no_numba_and_writes_numbas_values(tmp_path):
    """``energy-map`` runs the model's precompiled map kernels (``map_costs``, the
    summary bands and the uint16 encoding, in threads over each block's rows): numba
    stays unloaded, every band is the numba kernels' to the last bit, under gait limits,
    and so are the codes of the encoding."""
    import os

    import rasterio

    from energy_planner.energymap.bands import block_bands
    from energy_planner.energymap.setup import _setup
    from energy_planner.request import Request
    from energy_planner.terrain import load_dem

    out = tmp_path / "map.tif"
    env = {**os.environ, "ENERGY_PLANNER_PRECOMPILE": "1"}
    done = subprocess.run([sys.executable, "-c", MAP, str(out)], capture_output=True,
                          text=True, check=True, env=env)  # fmt: skip
    assert json.loads(done.stdout.strip().splitlines()[-1]) == {"numba": False}
    with rasterio.open(out) as src:
        got = src.read()
    t = load_dem(map_path("hill"))
    req = Request.make(max_crab_deg=20.0, max_backward_slope_deg=5.0)
    setup = _setup(None, req, None, 16)
    ref = block_bands(setup.heading, t.dzdx, t.dzdy, np.zeros((0, 1, 1)), 16)  # numba's
    assert np.isfinite(ref).any() and not np.array_equal(ref[:16], ref[16:32])
    np.testing.assert_array_equal(got, ref)
    # the precompiled uint16 encoding (threads over the rows) gives numba's codes
    from energy_planner.energy.kernels import precompiled_map_module
    from energy_planner.energymap.bands import band_names
    from energy_planner.energymap.encoding import band_steps, encode_block

    aot = precompiled_map_module(setup.heading.source, build=False)  # built by the run
    assert aot is not None
    steps = band_steps(16, band_names(16))
    np.testing.assert_array_equal(encode_block(ref, steps, aot=aot), encode_block(ref, steps))


def _recording(monkeypatch, cls, seen):
    """Record the stride along the headings of the ``along`` bands ``cls.map_bands`` gets."""
    orig = cls.map_bands

    def map_bands(self, gx, gy, chan, ang, along, best, precompiled=False, **kw):
        seen.append(along.strides[0])
        return orig(self, gx, gy, chan, ang, along, best, precompiled, **kw)

    monkeypatch.setattr(cls, "map_bands", map_bands)


def test_blocks_without_along_bands_equal_the_full_blocks(tmp_path, monkeypatch):
    """``block_bands(along=False)`` (a file without the ``along_*`` bands) gives the full
    block's ``best_*`` and summary bands to the last bit, by numba's kernels (the along
    values into a scratch block) and by the precompiled ones (into one plane that every
    heading overwrites: a view with a stride of 0 along the headings); on the bundled
    hill under gait limits, and with a categorical land-cover raster (one kernel pass per
    category)."""
    import rasterio
    from affine import Affine
    from b1_model import b1_model  # tests/ helper

    from energy_planner.energy.channels import Channels
    from energy_planner.energy.heading import HeadingCost
    from energy_planner.energymap.bands import block_bands
    from energy_planner.energymap.setup import _setup
    from energy_planner.request import Request
    from energy_planner.terrain import load_dem

    monkeypatch.setenv("ENERGY_PLANNER_PRECOMPILE", "1")
    hill = load_dem(map_path("hill"))
    req = Request.make(max_crab_deg=20.0, max_backward_slope_deg=5.0)
    # a cover raster on the hill's grid: meadow (costs 250 W per m/s more) on its west half
    rows, cols = hill.shape
    cover = tmp_path / "cover.tif"
    prof = dict(driver="GTiff", width=cols, height=rows, count=1, dtype="float64",
                crs=hill.crs, transform=Affine(*tuple(hill.transform)[:6]))  # fmt: skip
    with rasterio.open(cover, "w", **prof) as dst:
        dst.write(np.where(np.arange(cols) < cols // 2, 1.0, 2.0)[None].repeat(rows, 0), 1)
    table = tmp_path / "t.json"
    table.write_text('{"1": "meadow", "2": "asphalt"}')
    meadow = b1_model(extra={"speed * (ground == 'meadow')": 250.0})
    cases = [
        (_setup(None, req, None, 16), np.zeros((0, 1, 1))),
        (_setup(meadow, req, Channels.parse([], [f"ground={cover}:{table}"]), 8), None),
    ]
    for setup, chan in cases:
        n = setup.headings
        if chan is None:
            chan = setup.channels.bind(hill).stack(hill.shape)[0]
            assert set(np.unique(chan).tolist()) == {0.0, 1.0}  # both categories
        heading = HeadingCost(*setup.heading.params)  # its own precompiled module, built
        assert heading.precompiled_map() is not None
        ref = block_bands(heading, hill.dzdx, hill.dzdy, chan, n)  # numba's, every band
        assert ref.shape[0] == 2 * n + 4 and np.isfinite(ref[n:]).any()
        if setup.channels.rasters:  # the meadow half costs more
            cheapest = ref[2 * n]
            assert np.nanmedian(cheapest[:, : cols // 2]) > np.nanmedian(cheapest[:, cols // 2 :])
        else:  # under gait limits, walking forward is not always the cheapest way
            assert not np.array_equal(ref[:n], ref[n : 2 * n], equal_nan=True)
        seen: list[int] = []
        with monkeypatch.context() as m:
            _recording(m, HeadingCost, seen)
            for precompiled in (False, True):
                got = block_bands(heading, hill.dzdx, hill.dzdy, chan, n,
                                  precompiled=precompiled, along=False)  # fmt: skip
                assert got.shape == (n + 4, *hill.shape)
                np.testing.assert_array_equal(got, ref[n:])
        # numba's kernel: a C-contiguous scratch block; the precompiled one: one plane
        assert seen == [4 * rows * cols, 0]


PLAN = (
    "import json, sys\n"
    "from energy_planner.energy.channels import Channels\n"
    "from energy_planner.model import EnergyModel\n"
    "from energy_planner.request import Request\n"
    "from energy_planner.terrain import load_dem\n"
    "from energy_planner.planning.plan import plan\n"
    "t = load_dem(sys.argv[1]); m = EnergyModel.load(sys.argv[2])\n"
    "ch = Channels(constants={'load_kg': 7.25})\n"
    "req = Request.make(max_slope_deg=float(sys.argv[3]), channels=ch)\n"
    "r = plan(t, m, (500010.0, 5000010.0), (500110.0, 5000090.0), req, progress=False,\n"
    "         iterations=4)\n"
    "print(json.dumps({'numba': 'numba' in sys.modules, 'states': r.states.tolist(),\n"
    "                  'energy': r.energy_j}))\n"
)


def test_precompiled_plan_loads_no_numba_and_plans_as_numba(tmp_path, monkeypatch):
    """``plan`` (``auto``, a fixed speed) runs the model's precompiled motion and search
    kernels (:func:`energy_planner.planning.search.precompiled_search`): numba stays
    unloaded, and the path, pose for pose, and its energy are those of the numba
    kernels (the same code, compiled ahead of time), under a slope limit that binds
    (the path without it costs about 13 % less)."""
    import os

    from energy_planner.energy import MotionCost
    from energy_planner.energy.channels import Channels
    from energy_planner.model import EnergyModel
    from energy_planner.planning.plan import plan
    from energy_planner.request import Request
    from energy_planner.terrain import load_dem

    base = EnergyModel.default()
    model = EnergyModel(  # the model of the energy test above: its motion module serves
        [t.name for t in base.terms] + ["load_kg * speed"],
        {**base.coefficients, "load_kg * speed": 5.0},
    )
    path = tmp_path / "load.json"
    model.save(path)
    # numba's kernels first (they price the search's bound table, kept on disk, which
    # the precompiled run reads: a new table's heading rows are numba's)
    monkeypatch.setattr(MotionCost, "precompile", lambda self: False)
    req = Request.make(max_slope_deg=16.0, channels=Channels(constants={"load_kg": 7.25}))
    ref = plan(load_dem(map_path("hill")), model, (500010.0, 5000010.0), (500110.0, 5000090.0),
               req, progress=False, iterations=4)  # fmt: skip
    env = {**os.environ, "ENERGY_PLANNER_PRECOMPILE": "1"}
    done = subprocess.run(
        [sys.executable, "-c", PLAN, str(map_path("hill")), str(path), "16"],
        capture_output=True, text=True, check=True, env=env,
    )  # fmt: skip
    got = json.loads(done.stdout.strip().splitlines()[-1])
    assert got["numba"] is False
    assert got["energy"] == ref.energy_j
    np.testing.assert_array_equal(np.array(got["states"]), ref.states)
