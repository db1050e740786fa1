"""Energy maps at the best speed of a range: calculus on flat ground, the least over a fine
grid of fixed-speed maps, ``energy`` of a short motion at its chosen speed, bad ranges.

The model is the detour model of ``tests/test_speed_decisions.py`` (its kernels are
compiled there already): forward cost per metre ``600 + 1000 g + 15000 g^2`` at grade
``g``, dearer backward and sideways, plus 200 W standing and swing losses ``800 v^2`` W.
On flat ground a metre walked forward costs ``600 + 200 / v + 800 v``: least at
``v* = sqrt(200 / 800) = 0.5`` m/s, 1400 J/m, clamped to the range.
"""

from __future__ import annotations

import functools
import json
import math

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner
from test_energy_map import plane_z, write_tif  # tests/ helpers
from test_speed_decisions import _detour_model  # tests/ helper

from energy_planner.cli import main
from energy_planner.energy import MotionCost
from energy_planner.energymap import energy_map as _energy_map
from energy_planner.energymap.encoding import SPEED_STEP, read_band
from energy_planner.errors import PlanningConfigError
from energy_planner.terrain import load_dem

energy_map = functools.partial(_energy_map, bands="all", encoding="float32")
MODEL = _detour_model()
H = 8


def _read(path):
    with rasterio.open(path) as src:
        names = list(src.descriptions)
        return {n: read_band(src, i + 1) for i, n in enumerate(names)}, dict(src.tags())


def _per_metre(v):
    return 600.0 + 200.0 / v + 800.0 * v


@pytest.fixture(scope="module")
def flat(tmp_path_factory):
    return write_tif(tmp_path_factory.mktemp("speedmap") / "flat.tif", np.full((12, 12), 50.0))


@pytest.mark.parametrize(("lo", "hi"), [(0.2, 1.5), (0.6, 1.2), (0.1, 0.4)])
def test_flat_ground_best_speed_is_the_clamped_optimum(flat, tmp_path, lo, hi):
    """sqrt(b / c) clamped to the range, to 1 %; the cost a + b / v + c v there."""
    res = energy_map(flat, tmp_path / "m.tif", MODEL, headings=H, speed_range=(lo, hi))
    bands, tags = _read(res.path)
    want_v = min(max(0.5, lo), hi)
    inner = (slice(2, -2), slice(2, -2))
    np.testing.assert_allclose(bands["cheapest_speed"][inner], want_v, rtol=0.01)
    np.testing.assert_allclose(bands["cheapest"][inner], _per_metre(want_v), rtol=1e-5)
    for j in range(H):  # flat: every heading walks forward at the same speed
        np.testing.assert_allclose(bands[f"best_{45 * j:03d}"][inner], _per_metre(want_v),
                                   rtol=1e-5)  # fmt: skip
    assert res.speed_range == (lo, hi)
    assert tags["speed_range_m_s"] == f"{lo!r}:{hi!r}"
    assert "speed_m_s" not in tags
    assert res.stats["cheapest_speed_m_s"]["median"] == pytest.approx(want_v, rel=0.01)
    assert res.to_dict()["speed_range_m_s"] == [lo, hi]


@pytest.fixture(scope="module")
def bumpy(tmp_path_factory):
    """Slopes up to about 20 degrees facing every way (the tables stay small)."""
    n = 14
    x = np.arange(n)
    xx, yy = np.meshgrid(x, x)
    z = 20.0 + 0.6 * np.sin(xx / 2.5) * np.cos(yy / 3.0) + 0.12 * xx
    return write_tif(tmp_path_factory.mktemp("speedmap") / "bumpy.tif", z)


def test_range_map_is_the_least_over_fixed_speed_maps(bumpy, tmp_path):
    """Below every fixed-speed map of the range, and equal to the least of a grid of 21."""
    lo, hi = 0.2, 1.5
    ranged, _ = _read(energy_map(bumpy, tmp_path / "r.tif", MODEL, headings=H,
                                 speed_range=(lo, hi)).path)  # fmt: skip
    names = [f"best_{45 * j:03d}" for j in range(H)] + ["cheapest"]
    grid = {n: np.full(ranged[n].shape, np.inf) for n in names}
    for k, v in enumerate(np.geomspace(lo, hi, 21)):
        fixed, _ = _read(energy_map(bumpy, tmp_path / f"f{k}.tif", MODEL, headings=H,
                                    speed_range=float(v)).path)  # fmt: skip
        assert "cheapest_speed" not in fixed
        for n in names:
            ok = np.isfinite(fixed[n])
            assert np.all(ranged[n][ok] <= fixed[n][ok] * (1 + 1e-4)), (n, v)
            grid[n] = np.minimum(grid[n], fixed[n])
    for n in names:
        ok = np.isfinite(grid[n])
        assert ok.sum() > 100
        # the grid (speeds 1.1 apart) misses the least by its curvature: < 0.1 %
        np.testing.assert_allclose(ranged[n][ok], grid[n][ok], rtol=1e-3)
    v = ranged["cheapest_speed"][np.isfinite(ranged["cheapest"])]
    assert np.all((v >= lo * (1 - 1e-6)) & (v <= hi * (1 + 1e-6)))


def test_along_equals_energy_of_a_short_motion_at_its_chosen_speed(tmp_path):
    """``along_*`` at the best speed: a 1 m motion facing along, priced by the planners'
    kernel with the speed range (``motion_best``), per map metre, on a 12-degree plane
    (its slope and headings fall on the table's nodes)."""
    dem = write_tif(tmp_path / "plane.tif", plane_z(20, 12.0, 30.0))
    bands, _ = _read(energy_map(dem, tmp_path / "m.tif", MODEL, headings=H,
                                speed_range=(0.2, 1.5)).path)  # fmt: skip
    ter = load_dem(dem)
    cost = MotionCost(ter, MODEL, speed_range=(0.2, 1.5))
    x0, y0, dx, dy = ter.grid
    r, c = 9, 11
    x, y = x0 + c * dx, y0 + r * dy
    for j in range(H):
        h = 2 * math.pi * j / H
        e = cost(x - 0.5 * math.cos(h), y - 0.5 * math.sin(h), h,
                 x + 0.5 * math.cos(h), y + 0.5 * math.sin(h), h)  # fmt: skip
        assert bands[f"along_{45 * j:03d}"][r, c] == pytest.approx(e, rel=1e-5)


def test_uint16_speed_band_and_cli_json(flat, tmp_path):
    """The default encoding stores the speed to half its step; --json reports the range."""
    out = tmp_path / "m.tif"
    model_file = MODEL.save(tmp_path / "m.json")
    args = ["energy-map", flat, "--out", out, "--model", model_file, "--headings", "4",
            "--speed", "0.6:1.2", "--json"]  # fmt: skip
    res = CliRunner().invoke(main, list(map(str, args)))
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["speed_range_m_s"] == [0.6, 1.2]
    assert doc["stats"]["cheapest_speed_m_s"]["max"] == pytest.approx(0.6, rel=1e-3)
    assert doc["bands"][-1]["name"] == "cheapest_speed"
    assert doc["bands"][-1]["units"] == "m/s"
    with rasterio.open(out) as src:
        assert src.dtypes[-1] == "uint16"
        assert src.scales[-1] == SPEED_STEP
        v = read_band(src, src.count)
    assert np.nanmax(np.abs(v[2:-2, 2:-2] - 0.6)) <= SPEED_STEP / 2 + 1e-7


def test_fixed_speed_stays_the_fixed_map(flat, tmp_path):
    """``speed`` as a number (or "V") is the request's speed: no speed band, same values."""
    a = _energy_map(flat, tmp_path / "a.tif", MODEL, headings=4, speed_range=0.45)
    from energy_planner.request import Request, Robot

    b = _energy_map(flat, tmp_path / "b.tif", MODEL, headings=4,
                    request=Request(robot=Robot(speed=0.45)))  # fmt: skip
    assert a.speed_range is None and [x["name"] for x in a.bands] == [x["name"] for x in b.bands]
    assert a.path.read_bytes() == b.path.read_bytes()


@pytest.mark.parametrize("bad", [(1.0, 0.5), (0.0, 1.0), (-0.2, 1.0), "1:x", (0.2, math.inf)])
def test_bad_speed_ranges_say_so(flat, tmp_path, bad):
    with pytest.raises(PlanningConfigError, match="speed"):
        _energy_map(flat, tmp_path / "m.tif", MODEL, speed_range=bad)
    assert not (tmp_path / "m.tif").exists()


def test_cli_inverted_range_is_a_usage_error(flat, tmp_path):
    res = CliRunner().invoke(main, ["energy-map", str(flat), "--out", str(tmp_path / "m.tif"),
                                    "--speed", "1.2:0.6"])  # fmt: skip
    assert res.exit_code == 2
    assert "0 < vmin <= vmax" in res.output


def test_gaits_each_heading_in_its_cheapest_gait_and_speed(tmp_path):
    """A model that names gaits (b1_speeds: walk, trot), no gait given: ``along_*`` is
    the energy per map metre of a 1 m motion facing along as the planners price it,
    choosing gait and speed (``MotionCost`` with the range: ``gait_best``), and
    ``cheapest_gait`` / ``cheapest_speed`` are that motion's gait and speed where walking
    forward is the cheapest way (a 12-degree plane whose headings fall on table nodes)."""
    from energy_planner import load_model

    model = load_model("b1_speeds")
    dem = write_tif(tmp_path / "plane.tif", plane_z(8, 12.0, 30.0))
    res = energy_map(dem, tmp_path / "m.tif", model, headings=H, speed_range="auto")
    bands, tags = _read(res.path)
    assert res.gaits == ["trot", "walk"]
    assert "0=trot" in tags["gaits"] and "1=walk" in tags["gaits"]
    assert res.to_dict()["gaits"] == ["trot", "walk"]
    ter = load_dem(dem)
    cost = MotionCost(ter, model, speed_range=res.speed_range)
    assert cost.gaits == ("trot", "walk")
    x0, y0, dx, dy = ter.grid
    r, c = 4, 4
    x, y = x0 + c * dx, y0 + r * dy
    checked = 0
    for j in range(H):
        h = 2 * math.pi * j / H
        pts = [(x - 0.5 * math.cos(h), y - 0.5 * math.sin(h)),
               (x + 0.5 * math.cos(h), y + 0.5 * math.sin(h))]  # fmt: skip
        e = cost(*pts[0], h, *pts[1], h)
        assert bands[f"along_{45 * j:03d}"][r, c] == pytest.approx(e, rel=1e-5)
        dur, gaits = cost.best_timing(*(np.array(v) for v in zip(*pts, strict=True)),
                                      np.array([h, h]))  # fmt: skip
        if j == round(bands["cheapest_heading_deg"][r, c] / 45) % H and bands["cheapest"][
            r, c
        ] == pytest.approx(e, rel=1e-6):
            assert res.gaits[int(bands["cheapest_gait"][r, c])] == gaits[0]
            ground = math.hypot(1.0, math.tan(math.radians(12.0)) * math.cos(h - math.pi / 6))
            assert bands["cheapest_speed"][r, c] == pytest.approx(ground / dur[0], rel=1e-3)
            checked += 1
    assert checked == 1  # walking forward is the cheapest way here (downhill)
