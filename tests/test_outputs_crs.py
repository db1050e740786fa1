"""#19 outputs: RFC 7946 path files, plan JSON with CRS/limits/model id, no repeated vertex."""

from __future__ import annotations

import json

import numpy as np
import pyproj
from click.testing import CliRunner

from energy_planner.cli import main
from energy_planner.geojson import path_document
from energy_planner.io import content_id
from energy_planner.maps import map_path
from energy_planner.model import EnergyModel

HILL = str(map_path("hill"))
#: a short route with a bend (5 waypoints, planned in 0.1 s): the outputs are checked,
#: not the search (the hill's long climb to 500058,5000109 took 5.5 s a run)
ARGS = ["plan", "--dem", HILL, "--start", "500058,5000046", "--goal", "500070,5000075",
        "--max-slope", "30"]  # fmt: skip


def test_plan_out_is_rfc7946_and_json_carries_crs_limits_model(tmp_path):
    out = tmp_path / "p.geojson"
    r = CliRunner().invoke(main, [*ARGS, "--out", str(out), "--json"])
    assert r.exit_code == 0, r.output
    res = json.loads(r.stdout)
    assert res["crs"] == {"waypoints": "EPSG:32631", "dem": "EPSG:32631",
                          "working_grid": "EPSG:32631"}  # fmt: skip
    assert res["limits"]["max_slope_deg"] == 30.0 and res["limits"]["keep_out"] is None
    assert res["model"] == {"id": content_id(EnergyModel.default().to_dict()),
                            "source": "default"}  # fmt: skip
    doc = json.loads(out.read_text())
    assert "crs" not in doc  # RFC 7946: no 2008 crs member
    lonlat = np.array(doc["features"][0]["geometry"]["coordinates"])
    to_utm = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32631", always_xy=True)
    x, y = to_utm.transform(lonlat[:, 0], lonlat[:, 1])
    way = np.array([[w["x"], w["y"]] for w in res["waypoints"]])
    assert len(way) > 2  # a path with vertices between its ends
    np.testing.assert_allclose(np.c_[x, y], way, atol=1e-6)
    # the DEM's CRS on request, declared (a second run: the timed refinement can end on
    # other vertices under load, so it is held against its own --json waypoints)
    r = CliRunner().invoke(main, [*ARGS, "--out", str(out), "--geojson-crs", "dem", "--json"])
    assert r.exit_code == 0, r.output
    way = np.array([[w["x"], w["y"]] for w in json.loads(r.stdout)["waypoints"]])
    doc = json.loads(out.read_text())
    assert doc["crs"]["properties"]["name"] == "EPSG:32631"
    np.testing.assert_allclose(doc["features"][0]["geometry"]["coordinates"], way, atol=1e-9)


def test_path_repeats_no_vertex():
    """Repeated first and last poses (a zero-length segment) are not written."""
    xy = [[0.0, 0.0], [0.0, 0.0], [5.0, 0.0], [10.0, 0.0], [10.0, 0.0]]
    yaw = [0.0, 0.0, 0.0, 0.0, 0.0]
    doc = path_document(xy, yaw, crs="EPSG:32631", native=True)
    coords = doc["features"][0]["geometry"]["coordinates"]
    assert coords == [[0.0, 0.0], [5.0, 0.0], [10.0, 0.0]]
    assert len(doc["features"][0]["properties"]["yaw_deg"]) == 3
    # a turn in place (same position, new yaw) is a real pose and stays
    turn = path_document([[0, 0], [0, 0], [5, 0]], [0.0, 1.0, 1.0], crs=None)
    assert len(turn["features"][0]["geometry"]["coordinates"]) == 3


def test_energy_map_bands_carry_gdal_units(tmp_path):
    """GeoTIFF band units are GDAL units (src.units), not only tags (#19)."""
    import rasterio

    out = tmp_path / "plane.tif"
    r = CliRunner().invoke(main, ["energy-map", str(map_path("plane")), "--out", str(out),
                                  "--headings", "4"])  # fmt: skip
    assert r.exit_code == 0, r.output
    with rasterio.open(out) as src:
        units = [src.tags(b).get("units") for b in range(1, src.count + 1)]
        assert all(units) and list(src.units) == units
        assert all(src.descriptions)
        # the default uint16 encoding declares code 0 as nodata; float32 maps use NaN
        assert src.dtypes[0] == "uint16" and src.nodata == 0
