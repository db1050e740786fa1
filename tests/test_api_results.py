"""The verbs' keywords mean what the command's options mean; results remember their Problem.

Every result writes itself with one argument, the destination, and its repr is short (no
arrays). A keyword given with a Problem replaces that field of its request, as the same
option would on the command line.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import energy_planner as ep
from energy_planner import api
from energy_planner.energy.channels import Channels
from energy_planner.mission import Sites
from energy_planner.problem import request_with
from energy_planner.request import Request
from energy_planner.results import REPR_MAX

PNG = b"\x89PNG\r\n\x1a\n"
X0, Y0 = 500000.0, 5000000.0
A, B = (X0 + 4.5, Y0 + 4.5), (X0 + 30.5, Y0 + 30.5)


def _hill() -> ep.Terrain:
    """A 40 m x 40 m Gaussian hill, 6 m high, 1 m cells."""
    y, x = np.mgrid[0:40, 0:40]
    z = 6.0 * np.exp(-((x - 22.0) ** 2 + (y - 18.0) ** 2) / (2 * 7.0**2))
    return ep.Terrain.from_array(z, resolution=1.0, origin=(X0, Y0))


@pytest.fixture(scope="module")
def prob():
    return ep.Problem(_hill())


@pytest.fixture(scope="module")
def results(prob):
    """One result of every verb on the small hill (each made once)."""
    sites = Sites(np.array([A, B, (X0 + 30.5, Y0 + 6.5)]), ["a", "b", "c"])
    return {
        "plan": ep.plan(prob, A, B, planner="search"),
        "energy": ep.path_energy(prob, [A, B]),
        "compare": ep.compare_routes(prob, A, B, time=0.5),
        "reach": ep.reach(prob, A, budget_wh=5.0),
        "mission": api.mission(prob, sites),
    }


def test_reprs_are_short_and_hold_no_array(results, tmp_path, prob):
    em = ep.energy_map(prob, tmp_path / "m.tif", headings=4)
    for name, res in {**results, "energy_map": em}.items():
        text = repr(res)
        assert len(text) <= REPR_MAX, (name, text)
        assert "array(" not in text and "\n" not in text, (name, text)
        assert text.startswith(type(res).__name__ + "("), text


def test_every_result_writes_json_with_the_destination_only(results, tmp_path):
    for name, res in results.items():
        doc = json.loads(res.write_json(tmp_path / f"{name}.json").read_text())
        assert set(doc) == set(res.to_dict()), name
        if hasattr(res, "energy_j") and not isinstance(res.energy_j, np.ndarray):
            assert doc["energy_j"] == pytest.approx(res.energy_j, rel=1e-12), name
    assert doc["legs"][0]["from"] == "a"  # the mission's, by name


def test_results_write_their_maps_with_the_destination_only(results, tmp_path, prob):
    plan, comp, reach, mission = (results[k] for k in ("plan", "compare", "reach", "mission"))
    # the remembered terrain gives the same document as the terrain given again
    for res in (plan, results["energy"], mission):
        assert res.to_geojson() == res.to_geojson(prob.terrain)
        assert json.loads(res.write_geojson(tmp_path / "x.geojson").read_text())["features"]
    for res in (plan, comp, reach, mission):
        assert res.plot(tmp_path / "p.png").read_bytes()[:8] == PNG
    for res in (plan, comp, mission):
        frame = res.write_bag(tmp_path / f"{type(res).__name__}_bag")
        assert frame["frame"] == "map"
    area = json.loads(reach.write_geojson(tmp_path / "area.geojson").read_text())
    cells = reach.mask(5.0 * 3600.0).sum()  # whole 1 m cells within the budget
    assert area["features"][0]["properties"]["area_m2"] == pytest.approx(float(cells))
    assert reach.write_geotiff(tmp_path / "r.tif").exists()


def test_keywords_replace_the_problems_request(prob):
    steep = ep.plan(prob, A, B, planner="search")
    limit = 20.0  # the flanks reach 27.5 deg, the start and goal are below 19 deg
    low = ep.plan(prob, A, B, planner="search", max_slope_deg=limit)
    assert low.problem.request.limits.max_slope_deg == limit
    assert prob.request.limits.max_slope_deg is None  # the Problem itself is unchanged
    assert low.energy_j != steep.energy_j
    same = ep.plan(ep.Problem(prob.terrain, request=Request.make(max_slope_deg=limit)), A, B,
                   planner="search")  # fmt: skip
    assert low.energy_j == pytest.approx(same.energy_j, rel=1e-12)


def test_channels_take_a_dict_of_values():
    ch = Channels.coerce({"load_kg": 10, "ground": "meadow"})
    assert ch == Channels({"load_kg": 10.0, "ground": "meadow"})
    req = request_with(None, channels={"load_kg": 10}, speed=0.4, max_slope_deg=25)
    assert req.channels.constants == {"load_kg": 10.0}
    assert (req.robot.speed, req.limits.max_slope_deg) == (0.4, 25.0)
    assert request_with(None) is None  # nothing given: the Problem's own request
    kept = request_with(req, max_crab_deg=45)  # the other fields as they were
    assert kept.channels is req.channels and kept.limits.max_slope_deg == 25.0


def test_bundled_names_work_wherever_a_path_does(tmp_path):
    prob = ep.Problem.coerce("hill")
    assert prob.terrain.shape == ep.open_terrain(ep.map_path("hill")).shape
    sites = ep.read_sites("hill_sites", prob.terrain)
    assert len(sites) >= 3
    pe = ep.path_energy("hill", [(500058, 5000046), (500058, 5000084)])
    assert pe.energy_j > 0 and pe.problem.terrain.shape == prob.terrain.shape
