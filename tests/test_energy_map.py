"""Energy maps: the analytic plane, agreement with ``energy`` of short motions at sampled
cells and headings, nodata, metadata, channels, and the out-of-core (dask) path equal to
the in-memory one."""

from __future__ import annotations

import functools
import json
import math

import numpy as np
import pytest
import rasterio
from affine import Affine
from b1_model import b1_model  # tests/ helper
from click.testing import CliRunner

from energy_planner.cli import main
from energy_planner.energy import MotionCost, path_energy
from energy_planner.energy.channels import Channels
from energy_planner.energymap import band_names, parse_size
from energy_planner.energymap import energy_map as _energy_map
from energy_planner.energymap.encoding import read_band
from energy_planner.errors import EnergyMapError, MissingChannelError
from energy_planner.maps import map_path
from energy_planner.request import Limits, Request
from energy_planner.terrain import load_dem

#: These tests read the along_* bands and the full band layout: every map holds all bands
#: (the default, bands="best", is checked in test_energy_map_write.py and the CLI test),
#: as computed (float32: the default uint16 encoding's round trip is checked in
#: test_energy_map_write.py against these values).
energy_map = functools.partial(_energy_map, bands="all", encoding="float32")
MODEL = b1_model()
X0, Y0 = 500000.0, 5000000.0
H = 16


def write_tif(path, z, res=1.0, crs="EPSG:32631", nodata=-9999.0, dtype="float64"):
    z = np.asarray(z, dtype=dtype)
    prof = dict(
        driver="GTiff", width=z.shape[1], height=z.shape[0], count=1, dtype=dtype,
        crs=crs, transform=Affine(res, 0.0, X0, 0.0, -res, Y0 + res * z.shape[0]),
        nodata=nodata,
    )  # fmt: skip
    with rasterio.open(path, "w", **prof) as dst:
        dst.write(z, 1)
    return path


def plane_z(n, slope_deg, psi_deg, res=1.0):
    k = math.tan(math.radians(slope_deg))
    u = (math.cos(math.radians(psi_deg)), math.sin(math.radians(psi_deg)))
    x = (np.arange(n) + 0.5) * res
    y = (n - np.arange(n) - 0.5) * res
    xx, yy = np.meshgrid(x, y)
    return 100.0 + k * (u[0] * xx + u[1] * yy)


def read(path):
    """Every band as values (a uint16 map decoded), the band names, the dataset."""
    with rasterio.open(path) as src:
        data = np.stack([read_band(src, i) for i in range(1, src.count + 1)])
        return data, list(src.descriptions), src


@pytest.fixture(scope="module")
def plane(tmp_path_factory):
    d = tmp_path_factory.mktemp("emap")
    dem = write_tif(d / "plane.tif", plane_z(40, 12.0, 0.0))
    out = d / "plane_map.tif"
    energy_map(dem, out, MODEL, headings=H)
    return dem, out


def forward_analytic(slope_deg, psi_deg, h_deg):
    """J per map metre walking forward along h on a plane: (f0 + f1 sin t) / cos t, t the
    path's own inclination, tan t = tan(slope) cos(h - psi); downhill f0 - f1 |sin t|."""
    t = math.atan(math.tan(math.radians(slope_deg)) * math.cos(math.radians(h_deg - psi_deg)))
    return max(600.0 + 1000.0 * math.sin(t), 0.0) / math.cos(t)


# ------------------------------------------------------------------------ physics
def test_plane_of_known_slope_matches_the_analytic_cost(plane):
    dem, out = plane
    data, names, _ = read(out)
    assert names == band_names(H)
    for j in range(H):
        band = data[names.index(f"along_{band_names(H)[j][6:]}")]
        inner = band[2:-2, 2:-2]
        expected = forward_analytic(12.0, 0.0, 360.0 * j / H)
        np.testing.assert_allclose(inner, expected, rtol=2e-6)
    cheapest = data[names.index("cheapest")][2:-2, 2:-2]
    # downhill, walking forward, is the cheapest way over this plane
    np.testing.assert_allclose(cheapest, forward_analytic(12.0, 0.0, 180.0), rtol=2e-6)
    np.testing.assert_array_equal(data[names.index("cheapest_heading_deg")][2:-2, 2:-2], 180.0)
    best = data[H : 2 * H]
    np.testing.assert_allclose(data[names.index("dearest")], best.max(axis=0))
    np.testing.assert_allclose(
        data[names.index("anisotropy")], best.max(axis=0) / best.min(axis=0), rtol=1e-6
    )


def test_map_equals_energy_of_a_one_metre_motion_on_the_plane(plane, tmp_path):
    """The `energy` command on 1 m waypoint pairs through sampled cell centres."""
    dem, out = plane
    data, names, src = read(out)
    rng = np.random.default_rng(3)
    for r, c, j in zip(rng.integers(3, 37, 4), rng.integers(3, 37, 4), rng.integers(0, H, 4),
                       strict=True):  # fmt: skip
        x, y = src.transform * (c + 0.5, r + 0.5)
        h = 2 * math.pi * j / H
        dx, dy = 0.5 * math.cos(h), 0.5 * math.sin(h)
        wp = tmp_path / "w.csv"
        wp.write_text(f"x,y\n{x - dx},{y - dy}\n{x + dx},{y + dy}\n")
        model_file = MODEL.save(tmp_path / "m.json")
        args = ["energy", "--dem", dem, "--waypoints", wp, "--model", model_file, "--json"]
        res = CliRunner().invoke(main, list(map(str, args)))
        assert res.exit_code == 0, res.output
        e = json.loads(res.stdout)["energy_j"]
        assert data[j, r, c] == pytest.approx(e, rel=2e-6)


@pytest.mark.parametrize("name", ["hill", "plane", "jacksboro"])
def test_map_equals_short_motions_on_a_real_dem_at_sampled_cells(name, tmp_path):
    """On the bundled maps (the bundled model, which prefers crabbing on slopes), at sampled
    cells and 8 headings: ``along`` is the energy of a 1 cm forward motion, and ``best`` and
    ``cheapest`` the least energy of 1 cm motions along the heading over the body's yaw,
    swept every 0.1 degree (the motion kernel of ``energy``: the independent side), within
    0.5 %. (A 1 degree sweep is not fine enough: the model's braking term makes some
    minima sharp, and a sweep every degree misses them by up to 0.8 %.) Jacksboro is
    mapped on its UTM working grid (the terrain path)."""
    from energy_planner.model import EnergyModel

    model = EnergyModel.default()
    t = load_dem(map_path(name))
    out = tmp_path / f"{name}.tif"
    energy_map(t, out, model, headings=8)
    data, names, src = read(out)
    rng = np.random.default_rng(7)
    slope = np.where(np.isfinite(data[0]), t.slope, -1.0)
    slope[[0, 1, -2, -1], :] = slope[:, [0, 1, -2, -1]] = -1.0  # 1 cm motions stay inside
    valid = np.argwhere(slope >= 0)
    cells = [
        *valid[rng.choice(len(valid), 5, replace=False)],
        np.unravel_index(slope.argmax(), slope.shape),
    ]
    cost = MotionCost(t, model)
    yaw = np.radians(np.arange(0.0, 360.0, 0.1))
    eps = 0.005  # a 1 cm motion: the gradient barely changes along it
    for r, c in cells:
        x, y = src.transform * (c + 0.5, r + 0.5)
        least = np.inf
        for j in range(8):
            h = 2 * math.pi * j / 8
            x0, y0 = (
                np.full(yaw.size, x - eps * math.cos(h)),
                np.full(yaw.size, y - eps * math.sin(h)),
            )
            x1, y1 = (
                np.full(yaw.size, x + eps * math.cos(h)),
                np.full(yaw.size, y + eps * math.sin(h)),
            )
            per_m = cost.batch(x0, y0, h + yaw, x1, y1, h + yaw) / (2 * eps)
            assert data[j, r, c] == pytest.approx(per_m[0], rel=1e-3)
            assert data[8 + j, r, c] == pytest.approx(per_m.min(), rel=5e-3), (name, r, c, j)
            least = min(least, per_m.min())
        assert data[names.index("cheapest"), r, c] == pytest.approx(least, rel=5e-3)
    # the one `energy` of a short motion at the best yaw of the last cell and heading
    k = int(np.argmin(per_m))
    xy = [[x0[0], y0[0]], [x1[0], y1[0]]]
    e = path_energy(t, model, xy, yaw=[h + yaw[k]] * 2, cost=cost).energy_j / (2 * eps)
    assert data[15, r, c] == pytest.approx(e, rel=5e-3)


def test_flat_ground_best_gait_and_slope_limit(tmp_path):
    dem = write_tif(tmp_path / "flat.tif", np.full((20, 20), 5.0))
    out = tmp_path / "flat_map.tif"
    energy_map(dem, out, MODEL, headings=4)
    data, names, _ = read(out)
    np.testing.assert_allclose(data[:4, 1:-1, 1:-1], 600.0)  # forward
    np.testing.assert_allclose(data[names.index("anisotropy"), 1:-1, 1:-1], 1.0)
    steep = write_tif(tmp_path / "steep.tif", plane_z(20, 30.0, 45.0))
    energy_map(steep, out, MODEL, headings=4, request=Request(limits=Limits(max_slope_deg=20)))
    data, _, _ = read(out)
    assert np.isinf(data[:10, 1:-1, 1:-1]).all()  # every heading band, cheapest, dearest
    assert np.isnan(data[10:, 1:-1, 1:-1]).all()  # no ratio, no cheapest heading
    # across a 12 deg plane rising east: facing along north/south holds the body across
    # 12 deg (inf under a 5 deg cross-slope limit); walking sideways there faces the fall line
    tilted = write_tif(tmp_path / "tilted.tif", plane_z(20, 12.0, 0.0))
    lim = Request(limits=Limits(max_cross_slope_deg=5))
    energy_map(tilted, out, MODEL, headings=4, request=lim)
    data, _, _ = read(out)
    inner = data[:, 1:-1, 1:-1]
    assert np.isinf(inner[[1, 3]]).all() and np.isfinite(inner[[0, 2, 4, 5, 6, 7]]).all()


def test_nodata_and_edges_are_nan_and_grid_is_the_dems(tmp_path):
    z = plane_z(30, 8.0, 70.0)
    z[10:13, 15:18] = -9999.0
    dem = write_tif(tmp_path / "hole.tif", z)
    out = tmp_path / "hole_map.tif"
    res = energy_map(dem, out, MODEL, headings=4)
    data, names, src = read(out)
    with rasterio.open(dem) as d:
        assert src.crs == d.crs and src.transform == d.transform and src.shape == d.shape
    assert math.isnan(src.nodata)
    bad = np.zeros((30, 30), bool)
    bad[9:14, 14:19] = True  # the hole and the cells whose 3 x 3 window touches it
    bad[[0, -1], :] = bad[:, [0, -1]] = True
    assert np.isnan(data[:, bad]).all() and np.isfinite(data[:, ~bad]).all()
    assert res.stats["valid_cells"] == (~bad).sum()
    with rasterio.open(out) as s:
        assert s.tags(1)["units"] == "J/m" and s.tags(len(names))["units"] == "deg"
        assert "counter-clockwise" in s.tags()["heading_convention"]


def test_categorical_channel_map(tmp_path):
    m = b1_model(extra={"speed * (ground == 'meadow')": 250.0})
    dem = write_tif(tmp_path / "flat.tif", np.full((20, 20), 5.0))
    cover = write_tif(
        tmp_path / "cover.tif", np.where(np.arange(20) < 10, 1.0, 2.0)[None].repeat(20, 0)
    )
    table = tmp_path / "t.json"
    table.write_text('{"1": "meadow", "2": "asphalt"}')
    out = tmp_path / "m.tif"
    with pytest.raises(MissingChannelError, match="ground"):
        energy_map(dem, out, m, headings=4)
    ch = Channels.parse([], [f"ground={cover}:{table}"])
    energy_map(dem, out, m, headings=4, channels=ch)
    along = read(out)[0][0]
    np.testing.assert_allclose(along[1:-1, 1:10], 850.0)
    np.testing.assert_allclose(along[1:-1, 10:-1], 600.0)


def test_categorical_channel_map_on_a_slope_takes_every_yaw(tmp_path):
    """On a 15 deg plane with a land-cover raster, ``best`` on each cover equals the least
    energy of 1 cm motions over the body's yaw every 0.1 deg (``MotionCost`` with the
    same channels): one table per category, within 0.5 %."""
    m = b1_model(extra={"speed * (ground == 'meadow')": 250.0})  # as above: one compile
    dem = write_tif(tmp_path / "tilted.tif", plane_z(12, 15.0, 30.0))
    cover = write_tif(
        tmp_path / "cover.tif", np.where(np.arange(12) < 6, 1.0, 2.0)[None].repeat(12, 0)
    )
    table = tmp_path / "t.json"
    table.write_text('{"1": "meadow", "2": "asphalt"}')
    ch = Channels.parse([], [f"ground={cover}:{table}"])
    out = tmp_path / "m.tif"
    energy_map(dem, out, m, headings=4, channels=ch)
    data, _, src = read(out)
    t = load_dem(dem)
    cost = MotionCost(t, m, channels=ch)
    yaw = np.radians(np.arange(0.0, 360.0, 0.1))
    ones, eps = np.ones(yaw.size), 0.005
    for r, c in [(5, 3), (6, 8)]:
        x, y = src.transform * (c + 0.5, r + 0.5)
        for j in range(4):
            h = math.pi * j / 2
            dx, dy = eps * math.cos(h), eps * math.sin(h)
            e = cost.batch(ones * (x - dx), ones * (y - dy), h + yaw,
                           ones * (x + dx), ones * (y + dy), h + yaw) / (2 * eps)  # fmt: skip
            assert data[4 + j, r, c] == pytest.approx(e.min(), rel=5e-3), (r, c, j)
            assert data[j, r, c] == pytest.approx(e[0], rel=1e-3)


def test_bad_requests(plane, tmp_path):
    dem, _ = plane
    with pytest.raises(EnergyMapError, match="headings 0"):
        energy_map(dem, tmp_path / "x.tif", MODEL, headings=0)
    with pytest.raises(EnergyMapError, match="metric CRS"):
        energy_map(map_path("jacksboro"), tmp_path / "x.tif", MODEL, use_dask=True)
    assert parse_size("1.5GB") == 1_500_000_000
    with pytest.raises(ValueError, match="not a size"):
        parse_size("lots")


# ------------------------------------------------------------------------ out of core
@pytest.fixture(scope="module")
def bumpy(tmp_path_factory):
    """150 x 150 cells of hills with a nodata patch, and its in-memory map."""
    d = tmp_path_factory.mktemp("ooc")
    n = 150
    x = np.arange(n) * 2.0
    xx, yy = np.meshgrid(x, x)
    z = 20 * np.sin(xx / 40) * np.cos(yy / 30) + 0.05 * xx
    z[70:75, 40:60] = -9999.0
    dem = write_tif(d / "bumpy.tif", z, res=2.0)
    ref = d / "ref.tif"
    energy_map(load_dem(dem), ref, MODEL, headings=4)
    return dem, read(ref)[0]


def test_out_of_core_when_the_dem_passes_the_cap(bumpy, tmp_path, monkeypatch):
    dem, ref = bumpy
    # the DEM takes 1.4 MB in memory (64 bytes per cell, as load_dem counts)
    monkeypatch.setenv("ENERGY_PLANNER_MEMORY_CAP", "1MB")
    out = tmp_path / "dask.tif"
    res = energy_map(dem, out, MODEL, headings=4, chunk=64)
    assert res.mode == "dask" and "memory cap" in res.notes[0]
    np.testing.assert_allclose(read(out)[0], ref, rtol=1e-6, equal_nan=True)
    win = tmp_path / "win.tif"
    assert energy_map(dem, win, MODEL, headings=4, use_dask=False).mode == "windowed"
    np.testing.assert_allclose(read(win)[0], ref, rtol=1e-6, equal_nan=True)


def test_out_of_core_on_a_distributed_cluster(bumpy, tmp_path):
    """energy-map --scheduler ADDRESS of a LocalCluster(processes=False): the same map."""
    distributed = pytest.importorskip("distributed")
    dem, ref = bumpy
    out = tmp_path / "cluster.tif"
    model_file = MODEL.save(tmp_path / "m.json")
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
    ) as cluster:
        args = ["energy-map", dem, "--out", out, "--model", model_file, "--headings", "4",
                "--chunk", "64", "--scheduler", cluster.scheduler_address, "--json",
                "--bands", "all", "--encoding", "float32"]  # fmt: skip
        r = CliRunner().invoke(main, list(map(str, args)))
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["mode"] == "dask"
    np.testing.assert_allclose(read(out)[0], ref, rtol=1e-6, equal_nan=True)


def test_out_of_core_with_a_numeric_channel(bumpy, tmp_path):
    dem, _ = bumpy
    m = b1_model(extra={"load_kg * speed": 5.0})
    load = write_tif(tmp_path / "load.tif", np.linspace(0, 30, 75)[None].repeat(75, 0), res=4.0)
    ch = Channels.parse([], [f"load_kg={load}"])
    a, b = tmp_path / "a.tif", tmp_path / "b.tif"
    energy_map(load_dem(dem), a, m, headings=4, channels=ch)
    energy_map(dem, b, m, headings=4, channels=ch, use_dask=True, chunk=64)
    np.testing.assert_allclose(read(b)[0], read(a)[0], rtol=1e-6, equal_nan=True)


# ------------------------------------------------------------------------ CLI
def test_cli_energy_map_json_plot_and_errors(plane, tmp_path):
    dem, _ = plane
    model_file = MODEL.save(tmp_path / "m.json")
    out, png = tmp_path / "cli.tif", tmp_path / "cli.png"
    args = ["energy-map", dem, "--out", out, "--model", model_file, "--headings", "8",
            "--plot", png, "--json"]  # fmt: skip
    r = CliRunner().invoke(main, list(map(str, args)))
    assert r.exit_code == 0, r.output
    res = json.loads(r.stdout)
    # the default bands: best_* and the four summary bands
    assert res["headings"] == 8 and len(res["bands"]) == 12 and png.stat().st_size > 10_000
    assert [b["name"] for b in res["bands"]] == band_names(8, "best")
    assert res["stats"]["cheapest_j_per_m"]["min"] == pytest.approx(
        forward_analytic(12.0, 0.0, 180.0), rel=1e-5
    )
    r = CliRunner().invoke(main, ["energy-map", str(dem), "--out", str(out)])
    assert r.exit_code == 0 and "cheapest" in r.output
    term_model = b1_model(extra={"load_kg * speed": 1.0})
    tm = term_model.save(tmp_path / "load.json")
    r = CliRunner().invoke(main, ["energy-map", str(dem), "--out", str(out), "--model", str(tm)])
    assert r.exit_code == 2 and "load_kg" in r.output and "--set" in r.output
    r = CliRunner().invoke(main, ["energy-map", "nope.tif", "--out", str(out)])
    assert r.exit_code == 2 and "nope.tif" in r.output


# ------------------------------------------------------------- geographic DEMs
def _bilinear(arr, transform, x, y, spread=False):
    """``arr`` (a grid with cell-centre values) at the map point (x, y), bilinear; NaN
    when a neighbour is not finite. ``spread``: also the range of the 4 neighbours."""
    c, r = ~transform * (x, y)
    c, r = c - 0.5, r - 0.5
    c0, r0 = int(math.floor(c)), int(math.floor(r))
    fc, fr = c - c0, r - r0
    q = arr[r0 : r0 + 2, c0 : c0 + 2].astype(float)
    if q.shape != (2, 2) or not np.isfinite(q).all():
        return (math.nan, math.nan) if spread else math.nan
    v = (q[0, 0] * (1 - fc) * (1 - fr) + q[0, 1] * fc * (1 - fr)
         + q[1, 0] * (1 - fc) * fr + q[1, 1] * fc * fr)  # fmt: skip
    return (v, float(q.max() - q.min())) if spread else v


def _close(got, want, spread):
    """Equal up to 1e-3 relative plus 5 % of the neighbours' range: GDAL's warper maps
    points with an approximate (interpolated) transformer, so the interpolation point is
    off by a few hundredths of a cell."""
    return abs(got - want) <= 1e-3 * abs(want) + 0.05 * spread


def test_geographic_dem_map_is_on_the_dems_grid_and_crs(tmp_path):
    """Jacksboro (EPSG:4326): the map lands on the DEM's grid; its values are the
    working-grid (UTM) map interpolated at the DEM's cell centres, headings rotated by
    the meridian convergence (from pyproj, independent of the code's finite step)."""
    import pyproj
    from rasterio.warp import transform as warp_transform

    dem = map_path("jacksboro")
    out = tmp_path / "jack.tif"
    res = energy_map(dem, out, MODEL, headings=H)
    terrain = load_dem(dem)
    work = tmp_path / "jack_work.tif"
    energy_map(terrain, work, MODEL, headings=H)
    data, names, src = read(out)
    wdata, wnames, wsrc = read(work)
    with rasterio.open(dem) as d:
        assert src.crs == d.crs and src.transform == d.transform and src.shape == d.shape
        dem_valid = ~d.read(1, masked=True).mask if d.nodata is not None else None
    assert res.crs == str(src.crs) and "local east" in res.heading_convention
    with rasterio.open(out) as o:
        assert "local east" in o.tags()["heading_convention"]
    assert names == band_names(H)
    valid = np.isfinite(data[names.index("cheapest")])
    # nodata: only the DEM's invalid cells and the border (Horn's cell, resampling's cell)
    if dem_valid is not None and dem_valid.ndim == 2:
        assert not (valid & ~dem_valid).any()
    assert valid[2:-2, 2:-2].all()
    assert not valid[0].any() and not valid[-1].any()
    for k in range(len(names)):  # every band has the same nodata mask
        np.testing.assert_array_equal(np.isnan(data[k]), ~valid)
    rng = np.random.default_rng(5)
    proj = pyproj.Proj(str(terrain.crs))
    rows, cols = rng.integers(3, src.height - 3, 12), rng.integers(3, src.width - 3, 12)
    checked = 0
    for r, c in zip(rows, cols, strict=True):
        lon, lat = src.transform * (c + 0.5, r + 0.5)
        (x,), (y,) = warp_transform(src.crs, terrain.crs, [lon], [lat])
        for name in ("cheapest", "dearest", "anisotropy"):
            want, spread = _bilinear(wdata[wnames.index(name)], wsrc.transform, x, y, True)
            assert _close(data[names.index(name), r, c], want, spread), name
        gamma = proj.get_factors(lon, lat).meridian_convergence
        for j in (0, 5, 11):  # along_<d>: working heading d + gamma, between two bands
            k = (j + gamma / (360.0 / H)) % H
            k0 = int(k) % H
            f = k - int(k)
            lo, s0 = _bilinear(wdata[k0], wsrc.transform, x, y, True)
            hi, s1 = _bilinear(wdata[(k0 + 1) % H], wsrc.transform, x, y, True)
            assert _close(data[j, r, c], (1 - f) * lo + f * hi, max(s0, s1))
        head = data[names.index("cheapest_heading_deg"), r, c]
        # the working grid's cheapest heading, one of 360 j / H, minus the convergence
        assert (head + gamma) % (360.0 / H) == pytest.approx(0.0, abs=0.05) or (
            (head + gamma) % (360.0 / H) == pytest.approx(360.0 / H, abs=0.05)
        )
        checked += 1
    assert checked == 12


def test_geographic_plane_of_known_slope(tmp_path):
    """A lon/lat DEM whose elevation rises 12 deg towards UTM grid east: the cheapest cost
    is the analytic downhill one; in the DEM's frame the uphill azimuth is -gamma (the
    meridian convergence), so along_<d> is the analytic forward cost at d + gamma and
    the cheapest heading is 180 - gamma."""
    import pyproj

    n, res = 40, 0.0002
    t = Affine(res, 0.0, 5.5, 0.0, -res, 45.0 + n * res)
    cc, rr = np.meshgrid(np.arange(n) + 0.5, np.arange(n) + 0.5)
    lon, lat = t * (cc, rr)
    e, _ = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32631", always_xy=True).transform(
        lon, lat
    )
    z = 100.0 + math.tan(math.radians(12.0)) * (e - e.min())
    dem = tmp_path / "geo_plane.tif"
    prof = dict(driver="GTiff", width=n, height=n, count=1, dtype="float64",
                crs="EPSG:4326", transform=t, nodata=-9999.0)  # fmt: skip
    with rasterio.open(dem, "w", **prof) as dst:
        dst.write(z, 1)
    hh = 72
    out = tmp_path / "geo_plane_map.tif"
    energy_map(dem, out, MODEL, headings=hh)
    data, names, src = read(out)
    assert src.crs == "EPSG:4326" and src.transform == t
    inner = (slice(4, -4), slice(4, -4))
    gamma = pyproj.Proj("EPSG:32631").get_factors(lon, lat).meridian_convergence[inner]
    cheapest = data[names.index("cheapest")][inner]
    np.testing.assert_allclose(cheapest, forward_analytic(12.0, 0.0, 180.0), rtol=1e-4)
    # the dearest (a sideways or backward gait) against the same plane on a UTM grid
    ref = tmp_path / "utm_plane_map.tif"
    energy_map(write_tif(tmp_path / "utm_plane.tif", plane_z(40, 12.0, 0.0)), ref, MODEL,
               headings=hh)  # fmt: skip
    rdata, rnames, _ = read(ref)
    want_dear = rdata[rnames.index("dearest"), 20, 20]
    np.testing.assert_allclose(data[names.index("dearest")][inner], want_dear, rtol=1e-4)
    head = data[names.index("cheapest_heading_deg")][inner]
    np.testing.assert_allclose(head, 180.0 - gamma, atol=0.02)
    for j in (0, 10, 30, 45):
        d = 360.0 * j / hh
        want = np.vectorize(lambda g, d=d: forward_analytic(12.0, 0.0, d + g))(gamma)
        np.testing.assert_allclose(data[j][inner], want, rtol=5e-3)
