"""Every verb's result writes itself (JSON, GeoJSON) and draws itself (PNG), from Python.

The numbers a result writes are the numbers it holds: the files are read back and set
against the object (#18: "returns a result object that writes GeoJSON/GeoTIFF/JSON and
draws itself").
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import energy_planner as ep

PNG = b"\x89PNG\r\n\x1a\n"
HILL = "maps/hill.tif"


@pytest.fixture(scope="module")
def prob():
    return ep.Problem.from_dem(HILL, max_slope_deg=30)


def test_a_plan_writes_its_geojson_json_and_plot(prob, tmp_path):
    res = ep.plan(prob, (500058, 5000046), (500058, 5000084), planner="search")
    # the result remembers its terrain: every writer takes the destination only
    gj = json.loads(res.write_geojson(tmp_path / "p.geojson").read_text())
    assert gj == json.loads(json.dumps(res.to_geojson(prob.terrain)))
    props = gj["features"][0]["properties"]
    assert props["energy_j"] == pytest.approx(res.energy_j)
    doc = json.loads(res.write_json(tmp_path / "p.json").read_text())
    assert doc["energy_j"] == pytest.approx(res.energy_j)
    assert len(doc["waypoints"]) == len(res.states)
    assert res.plot(tmp_path / "p.png").read_bytes()[:8] == PNG
    assert res.plot(prob.terrain, tmp_path / "q.png").read_bytes()[:8] == PNG  # older order


def test_a_path_energy_writes_what_it_holds_and_draws_energy_along_the_path(prob, tmp_path):
    pts = [(500058, 5000046), (500058, 5000060), (500070, 5000070)]
    pe = ep.path_energy(prob, pts)
    doc = json.loads(pe.write_json(tmp_path / "e.json").read_text())
    assert doc["energy_j"] == pytest.approx(pe.energy_j)
    assert sum(s["energy_j"] for s in doc["segments"]) == pytest.approx(pe.energy_j)
    gj = json.loads(pe.write_geojson(tmp_path / "e.geojson", native=True).read_text())
    xy = np.array(gj["features"][0]["geometry"]["coordinates"])[:, :2]
    np.testing.assert_allclose(xy[0], pts[0], atol=1e-6)
    np.testing.assert_allclose(xy[-1], pts[-1], atol=1e-6)
    assert pe.plot(tmp_path / "e.png").read_bytes()[:8] == PNG


def test_an_energy_map_result_draws_itself_and_writes_its_summary(prob, tmp_path):
    r = ep.energy_map(HILL, tmp_path / "m.tif", headings=8)
    assert r.plot(tmp_path / "m.png").read_bytes()[:8] == PNG  # over its own DEM
    doc = json.loads(r.write_json(tmp_path / "m.json").read_text())
    assert doc["path"] == str(r.path) and doc["headings"] == 8


@pytest.mark.xdist_group("load_discovery")  # shares conftest.load_discovery
def test_a_discovery_writes_its_report_and_draws_its_staircase(load_discovery, tmp_path):
    d = load_discovery[1]  # discover(max_steps=1, fit_final=False) of the load campaign
    doc = json.loads(d.write_json(tmp_path / "d.json").read_text())
    assert [r["heldout_rmse_w"] for r in doc["staircase"]] == pytest.approx(
        [r["heldout_rmse_w"] for r in d.table()]
    )
    assert d.plot(tmp_path / "d.png").read_bytes()[:8] == PNG
    assert "<html" in d.write_html(tmp_path / "d.html").read_text()
