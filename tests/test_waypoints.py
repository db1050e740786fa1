"""Waypoint files (CSV, GeoJSON): parsing, every error, round trip, yaw conversion."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from energy_planner.energy.waypoints import (
    WaypointError,
    WaypointIOError,
    read_waypoints,
    waypoints_to_work,
    write_waypoints_geojson,
    yaw_from_work,
    yaw_to_work,
)
from energy_planner.errors import EnergyPlannerError
from energy_planner.terrain import Terrain


def write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


def line(coords, **props):
    return {"type": "LineString", "coordinates": coords, **props}


def feature(geom, properties=None):
    return {"type": "Feature", "geometry": geom, "properties": properties}


def gj(tmp_path, doc, name="w.geojson"):
    return write(tmp_path, name, json.dumps(doc))


# ---------------------------------------------------------------------- CSV, good
def test_csv_xy_only(tmp_path):
    w = read_waypoints(write(tmp_path, "w.csv", "x,y\n1,2\n3.5,-4e1\n"))
    assert w.xy.tolist() == [[1.0, 2.0], [3.5, -40.0]]
    assert w.yaw_rad is None and w.t is None and w.notes == []
    assert len(w) == 2 and "DEM's CRS" in w.crs_note


def test_csv_yaw_degrees_and_time_any_column_order(tmp_path):
    text = "t, yaw_deg ,Y,X\n0,0,10,20\n2.5,90,11,21\n7,-180,12,22\n"
    w = read_waypoints(write(tmp_path, "w.csv", text))
    assert w.xy.tolist() == [[20.0, 10.0], [21.0, 11.0], [22.0, 12.0]]
    np.testing.assert_allclose(w.yaw_rad, [0.0, math.pi / 2, -math.pi])
    assert w.t.tolist() == [0.0, 2.5, 7.0]


def test_csv_extra_columns_are_ignored_with_a_note(tmp_path):
    w = read_waypoints(write(tmp_path, "w.csv", "name,x,y,yaw\na,0,0,1.2\nb,1,1,1.3\n"))
    assert w.yaw_rad is None
    assert len(w.notes) == 1
    assert "'name'" in w.notes[0] and "'yaw'" in w.notes[0] and "yaw_deg" in w.notes[0]


def test_csv_semicolon_tab_comments_blank_lines_bom(tmp_path):
    p = tmp_path / "w.csv"
    p.write_bytes("\ufeff# exported path\nx;y\n\n0;0\n# mid\n1;0\n".encode())
    assert read_waypoints(p).xy.tolist() == [[0.0, 0.0], [1.0, 0.0]]
    w = read_waypoints(write(tmp_path, "w.tsv", "x\ty\n0\t0\n0\t5\n"))
    assert w.xy.tolist() == [[0.0, 0.0], [0.0, 5.0]]


# ---------------------------------------------------------------------- CSV, bad
@pytest.mark.parametrize(
    "text, needles",
    [
        ("x,z\n0,0\n1,1\n", ["missing column(s) 'y'", "found columns ['x', 'z']"]),
        ("0,0\n1,1\n", ["missing column(s) 'x', 'y'", "add a header row"]),
        ("x,y\n0,0\n1,abc\n", ["line 3", "column 'y'", "'abc' is not a number"]),
        ("x,y\n0,0\nnan,1\n", ["line 3", "column 'x'", "'nan' is not finite"]),
        ("x,y\n0,0\n1,inf\n", ["line 3", "column 'y'", "not finite"]),
        ("x,y,yaw_deg\n0,0,\n1,1,0\n", ["line 2", "column 'yaw_deg'", "empty value"]),
        ("x,y\n0,0\n", ["1 waypoint(s)", "at least 2"]),
        ("x,y\n", ["0 waypoint(s)"]),
        ("", ["is empty"]),
        ("x,y,t\n0,0,0\n1,1,1\n2,2,1\n", ["line 4", "t = 1 s after t = 1 s", "increase"]),
        ("x,y,t\n0,0,5\n1,1,3\n", ["line 3", "t = 3 s after t = 5 s"]),
        ("x,y\n0,0\n1\n", ["line 3", "1 value(s) for 2 columns"]),
        ("x,y,x\n0,0,0\n1,1,1\n", ["'x' appear twice"]),
    ],
)
def test_csv_errors_name_file_row_column_value(tmp_path, text, needles):
    p = write(tmp_path, "bad.csv", text)
    with pytest.raises(WaypointError) as exc:
        read_waypoints(p)
    msg = str(exc.value)
    assert str(p) in msg
    for n in needles:
        assert n in msg
    assert isinstance(exc.value, EnergyPlannerError) and isinstance(exc.value, ValueError)


def test_missing_file(tmp_path):
    with pytest.raises(WaypointIOError, match="does not exist") as exc:
        read_waypoints(tmp_path / "nope.csv")
    assert isinstance(exc.value, OSError)


# ---------------------------------------------------------------------- GeoJSON, good
COORDS = [[0.0, 0.0], [10.0, 0.0], [10.0, 5.0]]


@pytest.mark.parametrize(
    "doc",
    [
        line(COORDS),
        feature(line(COORDS)),
        {"type": "FeatureCollection", "features": [feature(line(COORDS))]},
    ],
    ids=["geometry", "feature", "collection"],
)
def test_geojson_forms(tmp_path, doc):
    w = read_waypoints(gj(tmp_path, doc))
    assert w.xy.tolist() == COORDS
    # no 'crs' member: RFC 7946 longitude, latitude
    assert w.yaw_rad is None and w.t is None and w.declared_crs == "OGC:CRS84"


def test_geojson_properties_crs_z_and_other_features(tmp_path):
    doc = {
        "type": "FeatureCollection",
        "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32631"}},
        "features": [
            feature({"type": "Point", "coordinates": [0, 0]}),
            feature(
                line([[0, 0, 100], [1, 1, 101], [2, 2, 99]]),
                {"yaw_deg": [0, 45, 90], "t": [0, 1, 3], "name": "x"},
            ),
        ],
    }
    w = read_waypoints(gj(tmp_path, doc, "w.json"))
    assert w.xy.tolist() == [[0, 0], [1, 1], [2, 2]]
    np.testing.assert_allclose(w.yaw_rad, np.radians([0, 45, 90]))
    assert w.t.tolist() == [0, 1, 3]
    assert w.declared_crs == "EPSG:32631" and "EPSG:32631" in w.crs_note
    assert any("z coordinate" in n for n in w.notes)
    assert any("ignored 1 other feature" in n for n in w.notes)


def test_geojson_detected_by_content_without_extension(tmp_path):
    w = read_waypoints(gj(tmp_path, line(COORDS), "path.dat"))
    assert w.xy.tolist() == COORDS


# ---------------------------------------------------------------------- GeoJSON, bad
@pytest.mark.parametrize(
    "doc, needles",
    [
        ({"type": "Point", "coordinates": [0, 0]}, ["'Point' is not a LineString"]),
        (
            {"type": "MultiLineString", "coordinates": [COORDS, COORDS]},
            ["'MultiLineString' is not a LineString", "one LineString per file"],
        ),
        (feature({"type": "Polygon", "coordinates": []}), ["'Polygon' is not a LineString"]),
        (feature(None), ["None is not a LineString"]),
        (
            {"type": "FeatureCollection", "features": [feature(line(COORDS))] * 2},
            ["exactly one LineString", "found 2"],
        ),
        ({"type": "FeatureCollection", "features": []}, ["found 0"]),
        ({"type": "FeatureCollection"}, ["without a 'features' list"]),
        (feature(line(COORDS), {"yaw_deg": [0, 1]}), ["yaw_deg has 2 value(s) for 3 vertices"]),
        (feature(line(COORDS), {"t": [0, 1, 2, 3]}), ["properties.t has 4 value(s) for 3"]),
        (feature(line(COORDS), {"yaw_deg": 90}), ["properties.yaw_deg is 90", "a list"]),
        (feature(line(COORDS), {"yaw_deg": [0, None, 1]}), ["properties.yaw_deg[1]", "None"]),
        (feature(line(COORDS), {"t": [0, 2, 1]}), ["vertex 2", "t = 1 s after t = 2 s"]),
        (line([[0, 0], [1, "a"]]), ["vertex 1, y", "'a' is not a number"]),
        (line([[0, 0], [1]]), ["vertex 1", "not a position"]),
        (line([[0, 0]]), ["1 waypoint(s)"]),
        (line(None), ["without a 'coordinates' list"]),
        ([1, 2], ["not a GeoJSON object"]),
    ],
)
def test_geojson_errors(tmp_path, doc, needles):
    p = gj(tmp_path, doc)
    with pytest.raises(WaypointError) as exc:
        read_waypoints(p)
    msg = str(exc.value)
    assert str(p) in msg
    for n in needles:
        assert n in msg


def test_geojson_nan_coordinate(tmp_path):
    p = write(tmp_path, "w.geojson", '{"type": "LineString", "coordinates": [[0, 0], [NaN, 1]]}')
    with pytest.raises(WaypointError, match=r"vertex 1, x: value nan is not finite"):
        read_waypoints(p)


def test_invalid_json(tmp_path):
    with pytest.raises(WaypointError, match="not valid JSON"):
        read_waypoints(write(tmp_path, "w.geojson", '{"type": '))


# ---------------------------------------------------------------------- writing
finite = st.floats(-1e6, 1e6, allow_nan=False)


@pytest.mark.filterwarnings("ignore:.*look like radians:UserWarning")
@settings(max_examples=40, deadline=None)
@given(
    xy=st.lists(st.tuples(finite, finite), min_size=2, max_size=8),
    data=st.data(),
)
def test_geojson_round_trip(tmp_path_factory, xy, data):
    n = len(xy)
    yaw = data.draw(st.lists(st.floats(-10, 10), min_size=n, max_size=n))
    t = np.cumsum(data.draw(st.lists(st.floats(0.01, 100), min_size=n, max_size=n)))
    p = tmp_path_factory.mktemp("rt") / "p.geojson"
    write_waypoints_geojson(
        p, xy, yaw, t=t, crs="EPSG:32631", properties={"energy_j": 1.5}, native=True
    )
    w = read_waypoints(p)
    np.testing.assert_array_equal(w.xy, np.asarray(xy, dtype=float))
    np.testing.assert_allclose(w.yaw_rad, yaw, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(w.t, t)
    assert w.declared_crs == "EPSG:32631"
    assert json.loads(p.read_text())["features"][0]["properties"]["energy_j"] == 1.5


def test_write_rejects_bad_input(tmp_path):
    with pytest.raises(WaypointError, match="n >= 2"):
        write_waypoints_geojson(tmp_path / "a.geojson", [[0, 0]])
    with pytest.raises(WaypointError, match="yaw_deg: expected 2"):
        write_waypoints_geojson(tmp_path / "a.geojson", [[0, 0], [1, 1]], [0.0])


# ---------------------------------------------------------------------- yaw conversion
def _geographic_terrain(tmp_path, lon0, lat0, n=40, res=1 / 1200):
    """A flat EPSG:4326 DEM whose north-west corner is (lon0, lat0)."""
    import rasterio
    from affine import Affine

    from energy_planner.terrain import load_dem

    p = tmp_path / "geo.tif"
    profile = dict(
        driver="GTiff", width=n, height=n, count=1, dtype="float32", crs="EPSG:4326",
        transform=Affine(res, 0.0, lon0, 0.0, -res, lat0),
    )  # fmt: skip
    with rasterio.open(p, "w", **profile) as dst:
        dst.write(np.full((n, n), 100.0, dtype="float32"), 1)
    return load_dem(p)


@pytest.mark.parametrize("lon0, lat0", [(-84.25, 36.6), (13.9, -33.9), (5.5, 60.0)])
def test_yaw_rotation_is_the_meridian_convergence(tmp_path, lon0, lat0):
    """The DEM's +x (east) on the UTM grid is turned by the convergence
    gamma = atan(tan(lon - lon_cm) sin(lat)) (spherical formula; the ellipsoid adds
    less than 0.01 deg within a zone)."""
    t = _geographic_terrain(tmp_path, lon0, lat0)
    epsg = t.crs.to_epsg()
    zone = epsg % 100
    lon_cm = -183.0 + 6.0 * zone
    lon, lat = lon0 + 0.01, lat0 - 0.01
    expected = math.degrees(
        math.atan(math.tan(math.radians(lon - lon_cm)) * math.sin(math.radians(lat)))
    )
    got = math.degrees(yaw_to_work(t, [lon], [lat], [0.0])[0])
    assert got == pytest.approx(expected, abs=0.01)
    # any yaw turns by the same angle, and from_work undoes it
    yaw = np.array([0.5, -2.0])
    xw, yw = t.to_work([lon, lon], [lat, lat])
    w = yaw_to_work(t, [lon, lon], [lat, lat], yaw)
    np.testing.assert_allclose(w - yaw, math.radians(got), atol=1e-12)
    np.testing.assert_allclose(yaw_from_work(t, xw, yw, w), yaw, atol=1e-9)


def test_east_of_the_map_is_the_direction_of_a_parallel(tmp_path):
    """Walking east along a parallel on the UTM grid points along the converted yaw 0."""
    t = _geographic_terrain(tmp_path, -84.25, 36.6)
    lon, lat = -84.24, 36.59
    xw, yw = t.to_work([lon, lon + 0.005], [lat, lat])
    heading = math.atan2(yw[1] - yw[0], xw[1] - xw[0])
    assert yaw_to_work(t, [lon], [lat], [0.0])[0] == pytest.approx(heading, abs=1e-4)
    assert abs(heading) > math.radians(1.0)  # the convergence there is ~1.7 deg


def test_projected_dem_keeps_coordinates_and_yaw(tmp_path):
    t = Terrain.from_function(lambda x, y: 0 * x, size=(20, 20), origin=(500000, 5000000))
    p = write(tmp_path, "w.csv", "x,y,yaw_deg\n500001,5000001,30\n500010,5000011,-60\n")
    xy, yaw = waypoints_to_work(t, read_waypoints(p))
    assert xy.tolist() == [[500001, 5000001], [500010, 5000011]]
    np.testing.assert_allclose(yaw, np.radians([30, -60]))


# ---------------------------------------------------------------------- one path format
def _poses_on(t, lon, lat):
    """A zig-zag of working-grid poses with yaw off the segment direction (lateral parts)."""
    x0, y0 = t.to_work(lon, lat)
    return np.array(
        [
            [x0, y0, 0.3],
            [x0 + 300, y0 + 50, 1.2],
            [x0 + 500, y0 + 400, -2.0],
            [x0 + 520, y0 + 900, 1.5708],
        ]
    )


def test_planned_path_round_trips_with_crs_and_yaw_frame(tmp_path):
    """Poses on the UTM working grid of a lon/lat DEM, written with write_path_from_work and
    read back by read_waypoints, come back as the same working-grid poses (this is what
    makes ``energy --waypoints`` agree with ``plan --out``)."""
    from energy_planner.geojson import PATH_FORMAT, write_path_from_work

    t = _geographic_terrain(tmp_path, -84.25, 36.6, n=200)
    states = _poses_on(t, -84.2, 36.56)
    p = write_path_from_work(tmp_path / "plan.geojson", t, states, properties={"energy_j": 9.0})
    doc = json.loads(p.read_text())
    props = doc["features"][0]["properties"]
    assert "crs" not in doc and props["crs"] == "OGC:CRS84"  # RFC 7946
    assert props["format"] == PATH_FORMAT and props["yaw_frame"] == "crs_x_ccw"
    # the file holds lon/lat and yaw from local east: differs from the grid yaw by the
    # meridian convergence (~1.7 deg here)
    assert -84.3 < doc["features"][0]["geometry"]["coordinates"][0][0] < -84.1
    conv = math.radians(props["yaw_deg"][0]) - states[0, 2]
    assert 1.0 < abs(math.degrees(conv)) < 2.5
    w = read_waypoints(p)
    assert w.declared_crs == "OGC:CRS84" and w.properties == {"energy_j": 9.0}
    xy, yaw = waypoints_to_work(t, w)
    np.testing.assert_allclose(xy, states[:, :2], atol=1e-6)
    np.testing.assert_allclose(yaw, states[:, 2], atol=1e-9)


def test_older_planner_geojson_is_read_in_its_own_yaw_frame(tmp_path):
    """The planner's older output (a Feature, properties.crs and yaw_deg in the working
    grid's frame) is read in that frame, with a note: reading it in the CRS frame turned
    every yaw by the convergence (+4.1 % energy on the jacksboro map, issue 13)."""
    t = _geographic_terrain(tmp_path, -84.25, 36.6, n=200)
    states = _poses_on(t, -84.2, 36.56)
    lon, lat = t.from_work(states[:, 0], states[:, 1])
    old = {
        "type": "Feature",
        "geometry": {"type": "LineString", "coordinates": np.c_[lon, lat].tolist()},
        "properties": {
            "yaw_deg": np.degrees(states[:, 2]).tolist(),
            "energy_j": 1.0,
            "planner": "auto",
            "crs": "EPSG:4326",
        },
    }
    w = read_waypoints(gj(tmp_path, old))
    assert w.yaw_frame == "work_x_ccw" and w.declared_crs == "EPSG:4326"
    assert any("older planner GeoJSON" in n for n in w.notes)
    _, yaw = waypoints_to_work(t, w)
    np.testing.assert_allclose(yaw, states[:, 2], atol=1e-12)


def test_path_energy_of_written_and_read_path_is_the_same(tmp_path):
    from energy_planner.energy import path_energy
    from energy_planner.geojson import write_path_from_work
    from energy_planner.model import EnergyModel

    t = _geographic_terrain(tmp_path, -84.25, 36.6, n=200)
    states = _poses_on(t, -84.2, 36.56)
    m = EnergyModel.default()
    e0 = path_energy(t, m, states[:, :2], yaw=states[:, 2]).energy_j
    xy, yaw = waypoints_to_work(
        t, read_waypoints(write_path_from_work(tmp_path / "p.geojson", t, states))
    )
    assert path_energy(t, m, xy, yaw=yaw).energy_j == pytest.approx(e0, rel=1e-9)


def test_yaw_frame_unknown_is_an_error(tmp_path):
    doc = feature(line(COORDS), {"yaw_deg": [0, 1, 2], "yaw_frame": "compass"})
    with pytest.raises(WaypointError, match="yaw_frame 'compass'") as exc:
        read_waypoints(gj(tmp_path, doc))
    assert exc.value.column == "yaw_frame"


# ---------------------------------------------------------------------- radians in yaw_deg
def test_radians_in_yaw_deg_column_warn(tmp_path):
    """yaw_deg = 1.57 on a path due north: the robot would walk sideways (issue 13)."""
    p = write(tmp_path, "w.csv", "x,y,yaw_deg\n0,0,1.57\n0,10,1.57\n0,20,1.6\n")
    with pytest.warns(UserWarning, match="look like radians") as rec:
        w = read_waypoints(p)
    assert str(p) in str(rec[0].message)
    assert w.yaw_radians_suspect and any("radians" in n for n in w.notes)
    # still read as degrees: the file is not rewritten behind the user's back
    np.testing.assert_allclose(w.yaw_rad, np.radians([1.57, 1.57, 1.6]))


@pytest.mark.parametrize(
    "rows",
    [
        "0,0,90\n0,10,90\n0,20,90\n",  # degrees, north
        "0,0,0\n10,0,0\n20,0,0\n",  # zeros mean the same in both units
        "0,0,2\n10,0,1\n20,0,-1.5\n",  # small degrees, walking east
        "0,0,0\n0,10,0\n0,20,0\n",  # sideways to the north in degrees
        "0,0,180\n-10,0,180\n-20,0,180\n",  # west in degrees
    ],
)
def test_degrees_do_not_warn(tmp_path, rows):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        w = read_waypoints(write(tmp_path, "w.csv", "x,y,yaw_deg\n" + rows))
    assert not w.yaw_radians_suspect


def test_radians_westward_and_geojson_warn(tmp_path):
    p = write(tmp_path, "w.csv", "x,y,yaw_deg\n0,0,3.14\n-10,0,3.14\n-20,1,3.1\n")
    with pytest.warns(UserWarning, match="radians"):
        read_waypoints(p)
    doc = feature(line([[0, 0], [5, 5], [10, 10]]), {"yaw_deg": [0.785, 0.785, 0.785]})
    with pytest.warns(UserWarning, match="radians"):
        assert read_waypoints(gj(tmp_path, doc)).yaw_radians_suspect
