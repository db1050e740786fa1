"""Geometry inputs are read with their CRS and reprojected to the working grid (#19).

A keep-out GeoJSON without a ``crs`` member is RFC 7946 longitude/latitude; one that
declares a CRS (UTM, a local transverse Mercator, web Mercator) is in that CRS. Wherever
it is declared, the plan never enters it. The check reprojects the zone independently
(pyproj), not with the library's code.
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pyproj
import pytest
import rasterio
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rasterio.transform import from_origin
from shapely.geometry import LineString, Polygon, box

from energy_planner.errors import GeometryOutsideMapWarning, PlanningConfigError
from energy_planner.model import EnergyModel
from energy_planner.planning.limits import load_keep_out, to_work_geometries
from energy_planner.planning.plan import plan
from energy_planner.request import Request
from energy_planner.terrain import load_dem

UTM = "EPSG:32631"
#: a local projected CRS: transverse Mercator centred on the map, false origin 1000, 2000
LOCAL = "+proj=tmerc +lat_0=45.1 +lon_0=3.0 +k=1 +x_0=1000 +y_0=2000 +ellps=WGS84 +units=m"
CRSS = ["lonlat", UTM, LOCAL, "EPSG:3857"]
X0, Y0 = 500000.0, 5000000.0  # south-west corner of the map, UTM 31N


@pytest.fixture(scope="module")
def dems(tmp_path_factory):
    """The same gentle ramp (80 m x 80 m) as a UTM DEM and as a lon/lat DEM."""
    d = tmp_path_factory.mktemp("crs")
    z = np.fromfunction(lambda r, c: 0.02 * c, (40, 40))
    with rasterio.open(d / "utm.tif", "w", driver="GTiff", height=40, width=40, count=1,
                       dtype="float64", crs=UTM,
                       transform=from_origin(X0, Y0 + 80, 2, 2)) as dst:  # fmt: skip
        dst.write(z, 1)
    to_ll = pyproj.Transformer.from_crs(UTM, "EPSG:4326", always_xy=True)
    (w, e), (s, n) = to_ll.transform([X0, X0 + 80], [Y0, Y0 + 80])
    with rasterio.open(d / "ll.tif", "w", driver="GTiff", height=40, width=40, count=1,
                       dtype="float64", crs="EPSG:4326",
                       transform=from_origin(w, n, (e - w) / 40, (n - s) / 40)) as dst:  # fmt: skip
        dst.write(z, 1)
    return {"utm": load_dem(d / "utm.tif"), "ll": load_dem(d / "ll.tif")}


def _zone_in(crs: str, zone: Polygon, working: str) -> tuple[dict, list]:
    """The zone (working CRS) as a GeoJSON document in ``crs`` (densified ring)."""
    ring = np.asarray(zone.segmentize(1.0).exterior.coords)
    target = "EPSG:4326" if crs == "lonlat" else crs
    xs, ys = pyproj.Transformer.from_crs(working, target, always_xy=True).transform(*ring.T)
    doc = {"type": "FeatureCollection", "features": [{"type": "Feature", "properties": {},
           "geometry": {"type": "Polygon", "coordinates": [np.c_[xs, ys].tolist()]}}]}  # fmt: skip
    if crs != "lonlat":
        doc["crs"] = {"type": "name", "properties": {"name": crs}}
    return doc, np.c_[xs, ys]


@settings(
    max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    crs=st.sampled_from(CRSS),
    dem=st.sampled_from(["utm", "ll"]),
    lo=st.floats(8.0, 30.0),
    hi=st.floats(8.0, 30.0),
    x=st.floats(28.0, 46.0),
)
def test_keep_out_is_honoured_in_any_declared_crs(dems, tmp_path, crs, dem, lo, hi, x):
    terrain = dems[dem]
    working = str(terrain.crs)
    cy = 0.5 * (terrain.bounds[1] + terrain.bounds[3])
    cx0 = terrain.bounds[0]
    wall = box(cx0 + x, cy - lo, cx0 + x + 6, cy + hi)  # across the straight line
    start, goal = (cx0 + 12, cy, 0.0), (cx0 + x + 22, cy, 0.0)
    assert LineString([start[:2], goal[:2]]).intersects(wall)
    doc, declared = _zone_in(crs, wall, working)
    f = tmp_path / "ko.geojson"
    f.write_text(json.dumps(doc))
    res = plan(terrain, EnergyModel.default(), start, goal, Request.make(keep_out=f),
               planner="lattice", progress=False)  # fmt: skip
    # the zone back on the working grid, independently of the library
    src = "EPSG:4326" if crs == "lonlat" else crs
    back = pyproj.Transformer.from_crs(src, working, always_xy=True).transform(*declared.T)
    zone = Polygon(np.c_[back])
    assert zone.symmetric_difference(wall).area < 1e-3 * wall.area
    path = LineString(res.states[:, :2])
    assert not path.intersects(zone), (crs, dem, path.wkt)


def test_projected_keep_out_without_crs_is_an_error_not_dropped(dems, tmp_path):
    f = tmp_path / "ko.geojson"
    f.write_text(json.dumps(box(X0 + 30, Y0 + 10, X0 + 36, Y0 + 70).__geo_interface__))
    with pytest.raises(PlanningConfigError, match="RFC 7946") as err:
        plan(dems["utm"], EnergyModel.default(), (X0 + 12, Y0 + 40, 0), (X0 + 60, Y0 + 40, 0),
             Request.make(keep_out=f), planner="lattice", progress=False)  # fmt: skip
    assert err.value.path == str(f)


def test_keep_out_off_the_map_is_a_named_warning(dems, tmp_path):
    f = tmp_path / "ko.geojson"
    f.write_text(json.dumps(box(10.0, 50.0, 10.001, 50.001).__geo_interface__))  # lon/lat
    with pytest.warns(GeometryOutsideMapWarning, match="outside the map.*covers x 500000"):
        to_work_geometries(load_keep_out(f), dems["utm"])


def test_keep_out_on_the_map_gives_no_warning(dems, tmp_path):
    doc, _ = _zone_in("lonlat", box(X0 + 30, Y0 + 10, X0 + 36, Y0 + 70), UTM)
    f = tmp_path / "ko.geojson"
    f.write_text(json.dumps(doc))
    with warnings.catch_warnings():
        warnings.simplefilter("error", GeometryOutsideMapWarning)
        (g,) = to_work_geometries(load_keep_out(f), dems["utm"])
    assert abs(g.bounds[0] - (X0 + 30)) < 0.01


def test_start_goal_in_another_crs_are_reprojected():
    """--points-crs: --start/--goal (and yaw, from local east) in lon/lat on a UTM DEM."""
    from click.testing import CliRunner

    from energy_planner.cli import main
    from energy_planner.maps import map_path

    hill = str(map_path("hill"))
    to_ll = pyproj.Transformer.from_crs(UTM, "EPSG:4326", always_xy=True)
    s, g = (500058.0, 5000046.0), (500070.0, 5000060.0)
    (slon, slat), (glon, glat) = to_ll.transform(*s), to_ll.transform(*g)
    base = ["plan", "--dem", hill, "--planner", "search", "--json"]
    utm = CliRunner().invoke(main, [*base, "--start", f"{s[0]},{s[1]},90", "--goal",
                                    f"{g[0]},{g[1]}"])  # fmt: skip
    # north (90 deg CCW from east) in lon/lat is grid north turned by the convergence
    fwd = pyproj.Transformer.from_crs("EPSG:4326", UTM, always_xy=True)
    (x0, x1), (y0, y1) = fwd.transform([slon, slon], [slat, slat + 1e-5])
    north = float(np.degrees(np.arctan2(y1 - y0, x1 - x0)))
    pts = ["--start", f"{slon!r},{slat!r},90", "--goal", f"{glon!r},{glat!r}"]
    ll = CliRunner().invoke(main, [*base, "--points-crs", "EPSG:4326", *pts])
    assert utm.exit_code == 0 and ll.exit_code == 0, (utm.output, ll.output)
    a, b = json.loads(utm.stdout), json.loads(ll.stdout)
    w0 = b["waypoints"][0]
    assert abs(w0["x"] - s[0]) < 1e-3 and abs(w0["y"] - s[1]) < 1e-3
    assert w0["yaw_deg"] == pytest.approx(north, abs=1e-4) and abs(north - 90) > 1e-4
    assert b["energy_j"] == pytest.approx(a["energy_j"], rel=5e-3)
    # reach within a small budget: the start is what is checked, not the whole hill's
    # search (10 s; --within-budget stops at the budget)
    r = CliRunner().invoke(main, ["reach", hill, "--points-crs", "EPSG:4326", "--start",
                                  f"{slon!r},{slat!r}", "--budget-wh", "2", "--within-budget",
                                  "--json"])  # fmt: skip
    assert r.exit_code == 0, r.output
    rs = json.loads(r.stdout)["start"]  # the DEM cell of the reprojected start
    assert abs(rs[0] - s[0]) <= 0.5 and abs(rs[1] - s[1]) <= 0.5, rs
    bad = CliRunner().invoke(main, [*base, "--points-crs", "EPSG:4326", "--start",
                                    f"{s[0]},{s[1]}", "--goal", f"{glon},{glat}"])  # fmt: skip
    assert bad.exit_code == 2 and "--points-crs" in bad.output and "covers x 500000" in bad.output
