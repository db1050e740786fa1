"""Per-site arrival windows of a mission: the order and each leg's speeds keep them.

On level ground with a model whose power is ``a v + b + c v^3`` at any slope and heading,
a metre costs ``a + b / v + c v^2`` (least at ``v* = (b / 2c)^(1/3)``) and standing costs
``b`` watts: every number below is calculus. Three sites on the lattice's axes, 10 m
apart (``a -> b`` east, ``b -> c`` south), so each leg is a straight 10 m line.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

import energy_planner as ep
from energy_planner.cli import main
from energy_planner.errors import PlanningError, WaypointError
from energy_planner.mission import Sites, read_sites
from energy_planner.mission.windows import standing_power
from energy_planner.model import EnergyModel
from energy_planner.problem import Problem
from energy_planner.terrain import Terrain

A, B, C = 100.0, 40.0, 90.0  # power a v + b + c v^3
RANGE = (0.2, 1.5)
V_STAR = (B / (2 * C)) ** (1 / 3)


def _per_metre(v: float) -> float:
    return A + B / v + C * v * v


@pytest.fixture(scope="module")
def scene():
    m = EnergyModel(["speed", "1", "speed ** 3"], {"speed": A, "1": B, "speed ** 3": C})
    m.metadata = {"fit": {"domain": {"speed_m_s": list(RANGE), "max_slope_deg": 30.0,
                                     "max_turn_rate_rad_s": 0.6, "gaits": {},
                                     "channels": {}}}}  # fmt: skip
    t = Terrain.from_function(lambda x, y: 0.0 * x, size=(16, 16), resolution=1.0)
    x0, y0 = t.grid[0], t.grid[1]
    sites = Sites(np.array([[x0 + 3, y0 - 3], [x0 + 13, y0 - 3], [x0 + 13, y0 - 13]]),
                  ["a", "b", "c"])  # fmt: skip
    return Problem(t, m), sites


def test_a_window_that_closes_early_walks_its_leg_at_length_over_time(scene):
    """``b`` must be reached within 12 s: the 10 m leg walks at 10/12 m/s (above v*, the
    cost per metre is convex in v, so the least energy in time walks at the slowest speed
    in time), the next leg, unconstrained, at v*."""
    p, sites = scene
    res = ep.mission(p, sites, windows={"b": (None, 12.0)})
    assert res.order == [0, 1, 2]
    stops = res.info["windows"]["stops"]
    assert stops[1]["arrive_s"] <= 12.0 + 1e-6
    v1 = res.legs[0].speed_profile()[0]["speed_m_s"]
    assert v1 == pytest.approx(10.0 / 12.0, rel=0.01)
    assert res.legs[1].speed_profile()[0]["speed_m_s"] == pytest.approx(V_STAR, rel=1e-4)
    assert res.energy_j == pytest.approx(10 * _per_metre(10 / 12) + 10 * _per_metre(V_STAR),
                                         rel=0.001)  # fmt: skip
    assert res.info["windows"]["wait_energy_j"] == 0.0


def test_an_early_robot_waits_at_the_standing_power(scene):
    """Given order, ``c`` opens at 60 s: the robot walks both legs at v* (20 / v* s) and
    waits the rest at ``b`` watts (the model's power at zero speed)."""
    p, sites = scene
    assert standing_power(p, sites.xy).tolist() == [B, B, B]
    res = ep.mission(p, sites, order="given", windows=[None, None, (60.0, None)])
    walk = 20.0 / V_STAR
    stop = res.info["windows"]["stops"][2]
    assert stop["arrive_s"] == pytest.approx(walk, rel=1e-4)
    assert stop["wait_s"] == pytest.approx(60.0 - walk, rel=1e-4)
    assert res.legs[1].wait_j == pytest.approx(B * (60.0 - walk), rel=1e-4)
    assert res.energy_j == pytest.approx(20 * _per_metre(V_STAR) + B * (60.0 - walk), rel=1e-4)
    assert res.to_dict()["legs"][1]["wait_s"] == pytest.approx(60.0 - walk, rel=1e-4)


def test_a_window_changes_the_order(scene):
    """``b`` opens at 40 s: a -> b -> c waits 23.5 s at b (940 J); a -> c -> b (14.1 m + 10
    m at v*) arrives at b at 39.9 s and waits 0.14 s, cheaper; the best order is that."""
    p, sites = scene
    res = ep.mission(p, sites, windows={"b": (40.0, None)})
    assert res.order == [0, 2, 1]
    d = (10 * math.sqrt(2) + 10) / V_STAR
    assert res.info["windows"]["stops"][2]["arrive_s"] == pytest.approx(d, rel=1e-3)
    assert res.energy_j == pytest.approx((10 * math.sqrt(2) + 10) * _per_metre(V_STAR)
                                         + B * (40.0 - d), rel=1e-3)  # fmt: skip


def test_no_order_in_time_names_the_site_and_its_earliest_arrival(scene):
    p, sites = scene
    with pytest.raises(PlanningError, match=r"site 'b'.*earliest arrival is 6\.7 s") as err:
        ep.mission(p, sites, order="given", windows={"b": (None, 5.0)})
    assert err.value.limit == "window" and err.value.value == pytest.approx(10 / RANGE[1])


def test_windows_read_from_the_sites_file_and_bad_ones_named(scene, tmp_path):
    p, sites = scene
    x, y = sites.xy.T
    rows = [f"{x[k]},{y[k]},{n},{a},{b}" for k, (n, a, b) in
            enumerate([("a", "", ""), ("b", "", "12"), ("c", "", "")])]  # fmt: skip
    f = tmp_path / "s.csv"
    f.write_text("x,y,name,arrive_after,arrive_before\n" + "\n".join(rows) + "\n")
    read = read_sites(f, p.terrain)
    assert np.isnan(read.windows[0]).all() and read.windows[1, 1] == 12.0
    assert read.on_cells(p.terrain).windows is read.windows
    f.write_text(f.read_text().replace(",12\n", ",soon\n"))
    with pytest.raises(WaypointError, match=r"s\.csv.*'b'.*arrive_before='soon'"):
        read_sites(f, p.terrain)
    with pytest.raises(WaypointError, match="opens at 9 s after it closes"):
        sites.with_windows({"c": (9, 3)})
    with pytest.raises(WaypointError, match="no site named 'd'"):
        sites.with_windows({"d": (None, 3)})


def test_windows_read_from_geojson_properties(scene, tmp_path):
    p, sites = scene
    feats = [{"type": "Feature", "geometry": {"type": "Point", "coordinates": list(xy)},
              "properties": {"name": n, **w}}
             for xy, n, w in zip(sites.xy.tolist(), sites.names,
                                 [{}, {"arrive_after": 30}, {"arrive_before": 90.5}],
                                 strict=True)]  # fmt: skip
    f = tmp_path / "s.geojson"
    crs = {"type": "name", "properties": {"name": "EPSG:32631"}}
    f.write_text(json.dumps({"type": "FeatureCollection", "features": feats, "crs": crs}))
    read = read_sites(f, p.terrain)
    assert read.names == sites.names
    np.testing.assert_array_equal(read.windows, [[np.nan, np.nan], [30, np.nan], [np.nan, 90.5]])
    assert read.to_dicts()[1]["arrive_after_s"] == 30.0


def test_a_round_trip_returns_before_the_start_window_closes(scene):
    """With ``return_to_start`` the start's ``arrive_before`` bounds the return: the way
    back from ``c`` to ``a`` is 14.1 m, and the tour of 34.1 m due in 40 s walks every
    leg at one speed (one price of a second), 34.1 / 40 m/s."""
    p, sites = scene
    res = ep.mission(p, sites, order="given", return_to_start=True, windows={"a": (None, 40.0)})
    length = 20 + 10 * math.sqrt(2)
    assert res.info["windows"]["stops"][-1]["arrive_s"] == pytest.approx(40.0, rel=1e-3)
    for leg in res.legs:
        assert leg.speed_profile()[0]["speed_m_s"] == pytest.approx(length / 40.0, rel=0.01)


def test_cli_windows_print_what_the_library_returns(scene, tmp_path, monkeypatch):
    import rasterio
    from rasterio.transform import from_origin

    import energy_planner.mission as pkg

    p, _ = scene
    dem = tmp_path / "flat.tif"
    with rasterio.open(
        dem, "w", driver="GTiff", height=16, width=16, count=1, dtype="float64",
        crs="EPSG:32631", transform=from_origin(500000.0, 5000016.0, 1.0, 1.0),
    ) as dst:  # fmt: skip
        dst.write(np.zeros((16, 16)), 1)
    model = tmp_path / "m.json"
    p.model.save(model)
    csv = tmp_path / "s.csv"
    csv.write_text("x,y,name\n500003.5,5000012.5,a\n500013.5,5000012.5,b\n"
                   "500013.5,5000002.5,c\n")  # fmt: skip
    real, kept = pkg.mission, []

    def spy(*a, **k):
        kept.append(real(*a, **k))
        return kept[-1]

    monkeypatch.setattr(pkg, "mission", spy)
    args = ["mission", "--dem", str(dem), "--sites", str(csv), "--model", str(model)]
    run = CliRunner().invoke(main, [*args, "--window", "b=:12", "--json"])
    assert run.exit_code == 0, run.output
    printed = json.loads(run.stdout)
    assert printed["windows"]["stops"][1]["arrive_s"] <= 12.0 + 1e-6
    assert printed["energy_j"] == pytest.approx(kept[-1].energy_j, rel=1e-12)
    assert printed["legs"][0]["speed_max_m_s"] == pytest.approx(10 / 12, rel=0.01)
    bad = CliRunner().invoke(main, [*args, "--window", "b=:5", "--order", "given"])
    assert bad.exit_code != 0 and "earliest arrival is 6.7 s" in bad.output
    worse = CliRunner().invoke(main, [*args, "--window", "b=5"])
    assert worse.exit_code != 0 and "NAME=AFTER:BEFORE" in worse.output
