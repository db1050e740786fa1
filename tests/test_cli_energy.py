"""``energy-planner energy`` through click's CliRunner: hand-worked energies on a plane
GeoTIFF, errors naming waypoints, and a geographic DEM against geodesic distances."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from affine import Affine
from b1_model import B1, b1_model  # tests/ helper
from click.testing import CliRunner
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from energy_planner.cli import main
from energy_planner.maps import map_path

SLOPE, PSI = 10.0, 30.0  # degrees; uphill azimuth CCW from east
X0, Y0, N = 500000.0, 5000000.0, 100  # south-west corner, cells (1 m)
C = B1  # coefficients of the explicit B1 model every run here is given (--model)
SA = math.sin(math.radians(SLOPE))
CA = math.cos(math.radians(SLOPE))  # the robot walks on the ground: L_ground = L_map / cos a
U = np.array([math.cos(math.radians(PSI)), math.sin(math.radians(PSI))])  # uphill
V = np.array([-U[1], U[0]])  # along the contour, uphill on the right when facing V
MID = np.array([X0 + 50.0, Y0 + 50.0])


def write_plane(path, bands=1, hole=None):
    """A plane of SLOPE deg rising toward PSI in EPSG:32631, float32, 1 m pixels."""
    import rasterio

    k = math.tan(math.radians(SLOPE))
    xc = X0 + 0.5 + np.arange(N)
    yc = Y0 + N - 0.5 - np.arange(N)
    xx, yy = np.meshgrid(xc - X0, yc - Y0)
    z = (200.0 + k * (U[0] * xx + U[1] * yy)).astype("float32")
    if hole is not None:
        r0, r1, c0, c1 = hole
        z[r0:r1, c0:c1] = -9999.0
    profile = dict(
        driver="GTiff", width=N, height=N, count=bands, dtype="float32", crs="EPSG:32631",
        transform=Affine(1.0, 0.0, X0, 0.0, -1.0, Y0 + N), nodata=-9999.0,
    )  # fmt: skip
    with rasterio.open(path, "w", **profile) as dst:
        for b in range(bands):
            dst.write(z, b + 1)
    return path


@pytest.fixture(scope="module")
def plane_tif(tmp_path_factory):
    return write_plane(tmp_path_factory.mktemp("dem") / "plane.tif")


def csv(tmp_path, rows, header="x,y", name="w.csv"):
    p = tmp_path / name
    p.write_text(
        header + "\n" + "\n".join(",".join(repr(float(v)) for v in r) for r in rows) + "\n"
    )
    return p


@pytest.fixture(scope="module", autouse=True)
def b1_file(tmp_path_factory):
    """The B1 model as a file: hand-worked energies need terms that stay what they are."""
    global B1_FILE
    B1_FILE = b1_model().save(tmp_path_factory.mktemp("model") / "b1.json")
    return B1_FILE


B1_FILE = None


def run(*args):
    args = list(map(str, args))
    if "--model" not in args:
        args += ["--model", str(B1_FILE)]
    return CliRunner().invoke(main, ["energy", *args])


def run_json(*args):
    r = run(*args, "--json")
    assert r.exit_code == 0, r.output
    return json.loads(r.stdout)


# ---------------------------------------------------------------------- hand-worked energies
def test_climb_and_descent_match_the_hand_worked_force(plane_tif, tmp_path):
    """Straight up the fall line: E = (f0 + f1 sin a) L; down: (f0 - f1 sin a) L, with
    L = 60 m / cos(a) the length along the ground."""
    a, b = MID - 30 * U, MID + 30 * U
    up = run_json("--dem", plane_tif, "--waypoints", csv(tmp_path, [a, b]))
    assert set(up) >= {"energy_j", "energy_wh", "distance_m", "duration_s", "segments"}
    L = 60.0 / CA
    assert up["energy_j"] == pytest.approx((C["fwd_const"] + C["fwd_grade"] * SA) * L, rel=1e-6)
    assert up["energy_wh"] == pytest.approx(up["energy_j"] / 3600)
    assert up["distance_m"] == pytest.approx(L)
    assert up["map_distance_m"] == pytest.approx(60.0)
    assert up["duration_s"] == pytest.approx(L / 0.3)
    (seg,) = up["segments"]
    assert seg["mean_slope_deg"] == pytest.approx(SLOPE, abs=1e-4)
    assert seg["mean_rel_heading_deg"] == pytest.approx(0.0, abs=1e-3)  # float32 DEM
    assert seg["forward_share"] == pytest.approx(1.0)
    down = run_json("--dem", plane_tif, "--waypoints", csv(tmp_path, [b, a]), "--speed", "0.6")
    assert down["energy_j"] == pytest.approx((C["fwd_const"] - C["fwd_grade"] * SA) * L, rel=1e-6)
    assert down["duration_s"] == pytest.approx(L / 0.6)
    assert down["segments"][0]["mean_rel_heading_deg"] == pytest.approx(180.0, abs=1e-3)


def test_corner_adds_a_turn_in_place(plane_tif, tmp_path):
    """Up the fall line, a 90 deg left turn, then along the contour:
    (f0 + f1 sin a) L1 / cos a + (tau0 + tau1 sin a) pi/2 + f0 L2 (level along the
    contour)."""
    a = MID - 20 * U
    b = MID + 10 * U
    c = b + 25 * V  # V is U turned 90 deg counter-clockwise: a left turn
    turn = abs(math.remainder(math.atan2(*(c - b)[::-1]) - math.atan2(*(b - a)[::-1]), 2 * math.pi))
    assert turn == pytest.approx(math.pi / 2)
    res = run_json("--dem", plane_tif, "--waypoints", csv(tmp_path, [a, b, c]))
    e1 = (C["fwd_const"] + C["fwd_grade"] * SA) * 30.0 / CA
    et = (C["turn_const"] + C["turn_slope"] * SA) * turn
    e2 = C["fwd_const"] * 25.0
    assert res["energy_j"] == pytest.approx(e1 + et + e2, rel=1e-6)
    s0, s1 = res["segments"]
    assert s0["energy_j"] == pytest.approx(e1, rel=1e-6)
    assert s1["energy_j"] == pytest.approx(et + e2, rel=1e-6)
    assert s1["turning_share"] == pytest.approx(et / (et + e2), rel=1e-6)
    assert s1["turn_deg"] == pytest.approx(90.0)
    assert res["distance_m"] == pytest.approx(30.0 / CA + 25.0)
    assert res["map_distance_m"] == pytest.approx(55.0)
    assert res["duration_s"] == pytest.approx((30.0 / CA + 25.0) / 0.3 + turn / 0.5)
    # a slower turn costs the same energy (power is linear in the yaw rate)
    slow = run_json("--dem", plane_tif, "--waypoints", csv(tmp_path, [a, b, c]), "--yaw-rate", 0.1)
    assert slow["energy_j"] == pytest.approx(res["energy_j"], rel=1e-9)
    assert slow["duration_s"] == pytest.approx((30.0 / CA + 25.0) / 0.3 + turn / 0.1)


def test_given_yaw_walks_sideways_and_times_set_duration(plane_tif, tmp_path):
    """Facing uphill (yaw = psi) and stepping along the contour: pure lateral, no grade."""
    a, b = MID - 15 * V, MID + 15 * V
    rows = [[*a, PSI, 0.0], [*b, PSI, 150.0]]
    res = run_json("--dem", plane_tif, "--waypoints", csv(tmp_path, rows, header="x,y,yaw_deg,t"))
    assert res["energy_j"] == pytest.approx(C["lat_const"] * 30.0, rel=1e-6)
    assert res["duration_s"] == pytest.approx(150.0)
    assert res["segments"][0]["lateral_share"] == pytest.approx(1.0)
    assert res["yaw_given"] and res["times_given"]
    assert any("--speed and --yaw-rate are not used" in n for n in res["notes"])


def test_geojson_waypoints_and_table_output(plane_tif, tmp_path):
    from energy_planner.energy.waypoints import write_waypoints_geojson

    a, b = MID - 30 * U, MID + 30 * U
    p = write_waypoints_geojson(tmp_path / "w.geojson", [a, MID, b], crs="EPSG:32631")
    res = run_json("--dem", plane_tif, "--waypoints", p)
    e = (C["fwd_const"] + C["fwd_grade"] * SA) * 60.0 / CA
    assert res["energy_j"] == pytest.approx(e, rel=1e-6)
    assert [s["distance_m"] for s in res["segments"]] == pytest.approx([30.0 / CA] * 2)
    r = run("--dem", plane_tif, "--waypoints", p)
    assert r.exit_code == 0, r.output
    assert f"{res['energy_j']:.1f} J" in r.output and f"{res['energy_wh']:.3f} Wh" in r.output
    lines = r.output.splitlines()
    head = next(i for i, s in enumerate(lines) if s.split()[:2] == ["seg", "energy"])
    rows = [lines[head + 1].split(), lines[head + 2].split()]
    assert [r[0] for r in rows] == ["0", "1"]
    assert float(rows[0][1]) == pytest.approx(res["segments"][0]["energy_j"], abs=0.05)
    assert float(rows[0][5]) == pytest.approx(SLOPE, abs=0.05)  # max slope
    assert rows[0][7] == "100%"


def test_model_option_and_multiband_dem(tmp_path):
    tif = write_plane(tmp_path / "two.tif", bands=2)
    a, b = MID - 30 * U, MID + 30 * U
    w = csv(tmp_path, [a, b])
    r = run("--dem", tif, "--waypoints", w)
    assert r.exit_code == 2 and "--band" in r.output
    # B1 plus 5 W per kg per m/s of load (a model other tests compile too): 10 J/m at 2 kg
    mp = b1_model(extra={"load_kg * speed": 5.0}).save(tmp_path / "m.json")
    args = ("--waypoints", w, "--model", mp, "--set", "load_kg=2")
    res = run_json("--dem", tif, "--band", 2, *args)
    e = (C["fwd_const"] + C["fwd_grade"] * SA + 5.0 * 2) * 60.0 / CA
    assert res["energy_j"] == pytest.approx(e, rel=1e-6)


# ---------------------------------------------------------------------- errors
def test_waypoint_outside_the_map_is_named(plane_tif, tmp_path):
    rows = [MID, [X0 + 150.0, Y0 + 20.0], MID + 5]
    r = run("--dem", plane_tif, "--waypoints", csv(tmp_path, rows))
    assert r.exit_code == 1
    assert "waypoint 1 at (500150.00, 5000020.00) is outside the map" in r.output


def test_all_waypoints_outside_hints_at_the_crs(plane_tif, tmp_path):
    r = run("--dem", plane_tif, "--waypoints", csv(tmp_path, [[2.35, 48.85], [2.36, 48.86]]))
    assert r.exit_code == 1
    assert "waypoint 0" in r.output and "EPSG:32631" in r.output and "500000" in r.output


def test_waypoint_on_nodata_and_segment_across_nodata(tmp_path):
    # hole: rows 40..59 (y 5000040..5000060), cols 40..59 (x 500040..500060)
    tif = write_plane(tmp_path / "hole.tif", hole=(40, 60, 40, 60))
    r = run("--dem", tif, "--waypoints", csv(tmp_path, [[X0 + 10, Y0 + 10], MID]))
    assert r.exit_code == 1 and "waypoint 1 at (500050.00, 5000050.00) is on nodata" in r.output
    rows = [[X0 + 10, Y0 + 10], [X0 + 90, Y0 + 90]]
    r = run("--dem", tif, "--waypoints", csv(tmp_path, rows))
    assert r.exit_code == 1
    assert "segment 0 from waypoint 0 at (500010.00, 5000010.00)" in r.output
    assert "crosses nodata" in r.output


def test_bad_files(plane_tif, tmp_path):
    r = run("--dem", plane_tif, "--waypoints", tmp_path / "missing.csv")
    assert r.exit_code == 2 and "missing.csv" in r.output and "does not exist" in r.output
    bad = tmp_path / "bad.csv"
    bad.write_text("x,y\n1,2\n3,oops\n")
    r = run("--dem", plane_tif, "--waypoints", bad)
    assert r.exit_code == 1
    assert "line 3" in r.output and "'oops' is not a number" in r.output and "hint" in r.output
    r = run("--dem", tmp_path / "nodem.tif", "--waypoints", bad)
    assert r.exit_code == 2 and "nodem.tif" in r.output


def test_declared_crs_is_reprojected(plane_tif, tmp_path):
    """A waypoint file in another CRS than the DEM's is reprojected (#19), and one whose
    coordinates are not in the CRS it declares is a data error naming it and the map."""
    import pyproj

    from energy_planner.energy.waypoints import write_waypoints_geojson

    bad = write_waypoints_geojson(tmp_path / "w.geojson", [MID, MID + 5], crs="EPSG:4326")
    r = run("--dem", plane_tif, "--waypoints", bad)
    assert r.exit_code == 1 and "OGC:CRS84" in r.output and "covers x 500000" in r.output
    same = run("--dem", plane_tif, "--waypoints", csv(tmp_path, [MID, MID + 5]), "--json")
    to_ll = pyproj.Transformer.from_crs("EPSG:32631", "EPSG:4326", always_xy=True)
    ll = np.array([to_ll.transform(*MID), to_ll.transform(*(MID + 5))])
    p = write_waypoints_geojson(tmp_path / "ll.geojson", ll, crs="EPSG:4326")
    r = run("--dem", plane_tif, "--waypoints", p, "--json")
    assert r.exit_code == 0, r.output
    a, b = json.loads(same.stdout), json.loads(r.stdout)
    assert b["energy_j"] == pytest.approx(a["energy_j"], rel=1e-6)


# ---------------------------------------------------------------------- geographic DEM
def vincenty(lon1, lat1, lon2, lat2):
    """Geodesic distance on WGS 84 (Vincenty's inverse formula), metres."""
    a, f = 6378137.0, 1 / 298.257223563
    b = (1 - f) * a
    L = math.radians(lon2 - lon1)
    U1 = math.atan((1 - f) * math.tan(math.radians(lat1)))
    U2 = math.atan((1 - f) * math.tan(math.radians(lat2)))
    sU1, cU1, sU2, cU2 = math.sin(U1), math.cos(U1), math.sin(U2), math.cos(U2)
    lam = L
    for _ in range(200):
        sl, cl = math.sin(lam), math.cos(lam)
        ss = math.hypot(cU2 * sl, cU1 * sU2 - sU1 * cU2 * cl)
        cs = sU1 * sU2 + cU1 * cU2 * cl
        sigma = math.atan2(ss, cs)
        sa = cU1 * cU2 * sl / ss
        c2a = 1 - sa * sa
        c2sm = cs - 2 * sU1 * sU2 / c2a
        Cc = f / 16 * c2a * (4 + f * (4 - 3 * c2a))
        prev = lam
        lam = L + (1 - Cc) * f * sa * (sigma + Cc * ss * (c2sm + Cc * cs * (-1 + 2 * c2sm**2)))
        if abs(lam - prev) < 1e-13:
            break
    u2 = c2a * (a * a - b * b) / (b * b)
    A = 1 + u2 / 16384 * (4096 + u2 * (-768 + u2 * (320 - 175 * u2)))
    B = u2 / 1024 * (256 + u2 * (-128 + u2 * (74 - 47 * u2)))
    ds = B * ss * (c2sm + B / 4 * (cs * (-1 + 2 * c2sm**2) - B / 6 * c2sm * (-3 + 4 * ss**2)
                                   * (-3 + 4 * c2sm**2)))  # fmt: skip
    return b * A * (sigma - ds)


def test_vincenty_reference():
    """The helper against a published value: Flinders Peak to Buninyong (Vincenty 1975)."""
    d = vincenty(144 + 25 / 60 + 29.52440 / 3600, -(37 + 57 / 60 + 3.72030 / 3600),
                 143 + 55 / 60 + 35.38390 / 3600, -(37 + 39 / 60 + 10.15610 / 3600))  # fmt: skip
    assert d == pytest.approx(54972.271, abs=0.01)


@pytest.fixture(scope="module")
def jacksboro():
    return map_path("jacksboro")


def test_flat_geographic_dem_distance_is_geodesic(tmp_path):
    """On a level EPSG:4326 DEM the ground distance is the geodesic one (UTM scale
    error < 0.05 % here)."""
    import rasterio

    p = tmp_path / "flat4326.tif"
    res_deg = 1 / 1200
    profile = dict(
        driver="GTiff", width=150, height=150, count=1, dtype="float32", crs="EPSG:4326",
        transform=Affine(res_deg, 0.0, 5.4, 0.0, -res_deg, 60.1),
    )  # fmt: skip
    with rasterio.open(p, "w", **profile) as dst:
        dst.write(np.full((150, 150), 50.0, dtype="float32"), 1)
    pts = [(5.41, 60.09), (5.50, 60.05), (5.45, 60.0)]
    res = run_json("--dem", p, "--waypoints", csv(tmp_path, pts))
    geo = [vincenty(*pts[i], *pts[i + 1]) for i in range(len(pts) - 1)]
    assert [s["distance_m"] for s in res["segments"]] == pytest.approx(geo, rel=5e-3)
    assert res["distance_m"] == pytest.approx(sum(geo), rel=5e-3)
    # a metre read as a degree would be off by a factor 10^5; lon/lat swapped by ~2x
    assert res["working_crs"] == "EPSG:32631"


def test_geographic_dem_distance_is_geodesic(jacksboro, tmp_path):
    """Jacksboro (EPSG:4326, hilly): the map distance is the geodesic one; the distance
    along the ground is longer."""
    pts = [(-84.35, 36.50), (-84.20, 36.52), (-84.15, 36.65), (-84.30, 36.68)]
    res = run_json("--dem", jacksboro, "--waypoints", csv(tmp_path, pts))
    geo = [vincenty(*pts[i], *pts[i + 1]) for i in range(len(pts) - 1)]
    for seg, g in zip(res["segments"], geo, strict=True):
        assert seg["map_distance_m"] == pytest.approx(g, rel=5e-3)
        assert seg["distance_m"] > seg["map_distance_m"]
    assert res["map_distance_m"] == pytest.approx(sum(geo), rel=5e-3)
    assert res["working_crs"] == "EPSG:32616"
    assert any("EPSG:4326" in n for n in res["notes"])


def test_geographic_dem_yaw_north_faces_along_a_meridian(jacksboro, tmp_path):
    """yaw_deg 90 is the map's +y (north). Walking north along a meridian facing yaw 90
    must be pure forward walking; an unconverted yaw would be off by the ~1.7 deg
    meridian convergence and walk sideways for several per cent of the work."""
    rows = [[-84.2, 36.50, 90.0], [-84.2, 36.55, 90.0], [-84.2, 36.60, 90.0]]
    res = run_json("--dem", jacksboro, "--waypoints", csv(tmp_path, rows, "x,y,yaw_deg"))
    for seg in res["segments"]:
        assert seg["lateral_share"] < 1e-3
        assert seg["turning_share"] < 1e-3
    # sanity of the threshold: a body turned by the convergence does walk sideways
    rot = [[-84.2, 36.50, 90.0 - 1.65], [-84.2, 36.55, 90.0 - 1.65]]
    off = run_json("--dem", jacksboro, "--waypoints", csv(tmp_path, rot, "x,y,yaw_deg"))
    assert off["segments"][0]["lateral_share"] > 0.02


def test_geographic_dem_error_names_lon_lat(jacksboro, tmp_path):
    r = run("--dem", jacksboro, "--waypoints", csv(tmp_path, [[-84.2, 36.5], [-85.0, 36.5]]))
    assert r.exit_code == 1
    assert "waypoint 1 at (-85.000000, 36.500000) is outside the map" in r.output


# ---------------------------------------------------------------------- properties
@settings(max_examples=12, deadline=None)
@given(
    pts=st.lists(st.tuples(st.floats(10.0, 90.0), st.floats(10.0, 90.0)), min_size=3, max_size=3)
)
def test_energies_of_concatenated_segments_add(plane_tif, tmp_path_factory, pts):
    """On the plane, A->B->C costs A->B plus B->C plus the turn in place at B,
    (tau0 + tau1 sin a) |turn|; each leg costs (f0 + f1 sin a cos g) L_ground."""
    a, b, c = (np.array([X0 + x, Y0 + y]) for x, y in pts)
    assume(np.hypot(*(b - a)) > 0.5 and np.hypot(*(c - b)) > 0.5)
    d = tmp_path_factory.mktemp("add")
    whole = run_json("--dem", plane_tif, "--waypoints", csv(d, [a, b, c]))
    legs = [run_json("--dem", plane_tif, "--waypoints", csv(d, p)) for p in ([a, b], [b, c])]
    h1, h2 = (math.atan2(*(q - p)[::-1]) for p, q in ((a, b), (b, c)))
    turn = abs(math.remainder(h2 - h1, 2 * math.pi))
    e_turn = (C["turn_const"] + C["turn_slope"] * SA) * turn
    total = legs[0]["energy_j"] + legs[1]["energy_j"] + e_turn
    assert whole["energy_j"] == pytest.approx(total, rel=1e-6)
    assert whole["segments"][1]["energy_j"] == pytest.approx(legs[1]["energy_j"] + e_turn, rel=1e-6)
    for leg, (p, q) in zip(legs, ((a, b), (b, c)), strict=True):
        # on a plane: grade along the leg = k cos(heading - psi); force per ground metre
        g = math.tan(math.radians(SLOPE)) * math.cos(math.atan2(*(q - p)[::-1]) - math.radians(PSI))
        length = np.hypot(*(q - p)) * math.sqrt(1 + g * g)
        sin_climb = g / math.sqrt(1 + g * g)  # sin(a) cos(gamma) in the slope plane
        force = C["fwd_const"] + C["fwd_grade"] * sin_climb
        assert leg["energy_j"] == pytest.approx(force * length, rel=1e-5)
