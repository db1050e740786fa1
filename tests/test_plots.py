"""Map plots draw what the command had, name their CRS, and say when a colour bar clips.

The figures are caught as they are saved (``energy_planner.io.save_figure``) and their
artists read back: the keep-out patch against the polygon given (also as RFC 7946
lon/lat, converted independently with pyproj), the slope-limit mask against the analytic
slope of a parabolic valley ``z = k (x - X0)^2`` (slope ``atan(2 k (x - X0))``, which
Horn's central difference gives exactly on a quadratic), a categorical channel's
boundary against the cell edge where the category changes, and the colour scale of an
energy map against numpy's percentiles of a ramp.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from shapely.geometry import box

import energy_planner as ep
from energy_planner.energy.channels import ChannelRaster, Channels
from energy_planner.plotting import crs_label, label_map_axes
from energy_planner.request import Limits, Request
from energy_planner.terrain import Terrain

X0, Y0 = 500000.0, 5000000.0
K = 0.02  # z = K (x - X0)^2: slope atan(2 K (x - X0))
LIMIT = 20.0  # deg: steeper where x - X0 > tan(20 deg) / (2 K) = 9.10 m
ZONE = box(X0 + 2.0, Y0 + 5.0, X0 + 6.0, Y0 + 9.0)  # the keep-out, in the DEM's CRS
SPLIT = 15.0  # the ground channel is "mud" east of X0 + 15


@pytest.fixture(scope="module")
def valley():
    return Terrain.from_function(lambda x, y: K * (x - X0) ** 2 + 0.0 * y, size=(30, 20),
                                 origin=(X0, Y0))  # fmt: skip


@pytest.fixture
def figures(monkeypatch):
    """The figures the plots save, in order (nothing is written)."""
    import energy_planner.io as io

    caught = []

    def fake_save(fig, path, **kwargs):
        caught.append(fig)
        return path

    monkeypatch.setattr(io, "save_figure", fake_save)
    return caught


def _request(terrain, keep_out=(ZONE,)):
    xc, _ = terrain.cell_centers()
    ground = (xc - X0 > SPLIT).astype(float)  # category index: 0 grass, 1 mud
    load = 5.0 + 0.1 * (xc - X0)
    ch = Channels(rasters={
        "ground": ChannelRaster("ground", values=ground, categories=("grass", "mud")),
        "load_kg": ChannelRaster("load_kg", values=load),
    })  # fmt: skip
    return Request(limits=Limits(max_slope_deg=LIMIT, keep_out=keep_out), channels=ch)


def _check_overlays(ax, terrain):
    # the keep-out: one patch, exactly the polygon
    ko = [p for p in ax.patches if p.get_gid() == "keep_out"]
    assert len(ko) == 1
    v = ko[0].get_path().vertices
    np.testing.assert_allclose([v[:, 0].min(), v[:, 1].min(), v[:, 0].max(), v[:, 1].max()],
                               ZONE.bounds, atol=1e-6)  # fmt: skip
    # the slope mask: the cells steeper than the limit, from the analytic slope
    (mask,) = [im for im in ax.images if im.get_gid() == "slope_mask"]
    drawn = ~np.ma.getmaskarray(mask.get_array())
    xc, _ = terrain.cell_centers()
    expected = np.degrees(np.arctan(2 * K * np.abs(xc - X0))) > LIMIT
    expected &= np.isfinite(terrain.slope)  # Horn leaves the border ring without a slope
    np.testing.assert_array_equal(drawn, expected)
    assert expected.sum() > 0 and (~expected).sum() > 0
    # channels: the category boundary on the cell edge at X0 + 15, numeric contours
    gids = {c.get_gid(): c for c in ax.collections}
    assert "channel:load_kg" in gids
    pts = np.vstack([p.vertices for p in gids["channel:ground"].get_paths() if len(p.vertices)])
    np.testing.assert_allclose(pts[:, 0], X0 + SPLIT, atol=1e-9)
    labels = ax.get_legend_handles_labels()[1]
    assert "keep-out" in labels
    assert f"steeper than {LIMIT:g}\u00b0 (slope limit)" in labels
    assert "ground: category boundaries (grass, mud)" in labels
    assert ax.get_xlabel() == "x (EPSG:32631, m)" and ax.get_ylabel() == "y (EPSG:32631, m)"


def test_reach_plot_draws_the_request_and_names_the_crs(valley, figures, tmp_path):
    from energy_planner.planning.reach import ReachMap

    res = ReachMap(energy_j=np.full(valley.shape, 3600.0), start=(X0 + 3.5, Y0 + 15.5),
                   round_trip=False, step=1.0)  # fmt: skip
    res.plot(valley, tmp_path / "r.png", 2 * 3600.0, request=_request(valley))
    _check_overlays(figures[0].axes[0], valley)


def test_route_plot_draws_the_request_and_names_the_crs(valley, figures, tmp_path):
    from energy_planner.planning.compare import Route, RouteComparison

    states = np.array([[X0 + 1.5, Y0 + 1.5, 0.0], [X0 + 18.5, Y0 + 28.5, 0.0]])
    comp = RouteComparison(routes=[Route("energy_optimal", states, 1.0, 30.0, 100.0, None, True)],
                           start=tuple(states[0]), goal=tuple(states[-1]))  # fmt: skip
    comp.plot(valley, tmp_path / "c.png", request=_request(valley))
    _check_overlays(figures[0].axes[0], valley)
    # without a request: nothing drawn, the CRS still named
    comp.plot(valley, tmp_path / "c.png")
    ax = figures[1].axes[0]
    assert not [p for p in ax.patches if p.get_gid() == "keep_out"]
    assert ax.get_xlabel() == "x (EPSG:32631, m)"


def test_mission_plot_draws_the_request_and_names_the_crs(valley, figures, tmp_path):
    from energy_planner.mission.core import Leg, MissionResult
    from energy_planner.mission.sites import Sites

    xy = np.array([[X0 + 1.5, Y0 + 1.5], [X0 + 8.5, Y0 + 20.5]])
    states = np.column_stack([xy, np.zeros(2)])
    res = MissionResult(sites=Sites(xy=xy, names=["a", "b"]), order=[0, 1],
                        legs=[Leg(0, 1, 1.0, 1.0, 20.0, 60.0, states)],
                        matrix_j=np.zeros((2, 2)), method="test",
                        return_to_start=False)  # fmt: skip
    res.plot(valley, tmp_path / "m.png", request=_request(valley))
    _check_overlays(figures[0].axes[0], valley)


def test_a_keep_out_in_lon_lat_is_drawn_where_the_planner_puts_it(valley, figures, tmp_path):
    """RFC 7946: the file's lon/lat corners, converted with pyproj, land on the polygon."""
    import pyproj

    from energy_planner.planning.reach import ReachMap

    to_ll = pyproj.Transformer.from_crs("EPSG:32631", "EPSG:4326", always_xy=True)
    ring = [list(to_ll.transform(x, y)) for x, y in ZONE.exterior.coords]
    path = tmp_path / "zone.geojson"
    path.write_text(json.dumps({"type": "Polygon", "coordinates": [ring]}))
    res = ReachMap(energy_j=np.full(valley.shape, 1.0), start=(X0 + 3.5, Y0 + 15.5),
                   round_trip=False, step=1.0)  # fmt: skip
    res.plot(valley, tmp_path / "r.png", request=_request(valley, keep_out=path))
    (ko,) = [p for p in figures[0].axes[0].patches if p.get_gid() == "keep_out"]
    v = ko.get_path().vertices
    np.testing.assert_allclose([v[:, 0].min(), v[:, 1].min(), v[:, 0].max(), v[:, 1].max()],
                               ZONE.bounds, atol=1e-3)  # fmt: skip


def test_crs_labels():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from rasterio.crs import CRS

    fig, ax = plt.subplots()
    label_map_axes(ax, CRS.from_epsg(4326))
    assert ax.get_xlabel() == "longitude (EPSG:4326, deg)"
    assert ax.get_ylabel() == "latitude (EPSG:4326, deg)"
    label_map_axes(ax, CRS.from_epsg(32616))
    assert ax.get_xlabel() == "x (EPSG:32616, m)"
    plt.close(fig)
    assert crs_label(None) == "no CRS, local grid"
    assert "Transverse Mercator" in crs_label("+proj=tmerc +lon_0=3 +ellps=WGS84 +units=m")


def test_a_lon_lat_dem_is_plotted_in_its_own_crs_not_the_working_utm(figures, tmp_path):
    # planned on a UTM working grid, drawn in the DEM's own lon/lat, as a GIS shows it
    from energy_planner.maps import map_path
    from energy_planner.planning.reach import ReachMap
    from energy_planner.terrain import load_dem

    t = load_dem(map_path("jacksboro_fault_dem"))
    assert t.source_crs.is_geographic
    res = ReachMap(energy_j=np.full(t.shape, 1.0), start=t.to_work(*_centre(t)),
                   round_trip=False, step=1.0)  # fmt: skip
    res.plot(t, tmp_path / "r.png")
    ax = figures[0].axes[0]
    assert ax.get_xlabel() == "longitude (EPSG:4326, deg)"
    assert ax.get_ylabel() == "latitude (EPSG:4326, deg)"
    b = t.source_bounds
    assert ax.get_xlim() == pytest.approx((b[0], b[2]))
    assert ax.get_ylim() == pytest.approx((b[1], b[3]))


def _centre(t):
    b = t.source_bounds
    return (b[0] + b[2]) / 2, (b[1] + b[3]) / 2


# ---------------------------------------------------------------------- energy map


def _map(tmp_path, cheap, tags=None):
    """A small energy-map GeoTIFF with the bands the plot reads."""
    from rasterio.transform import from_origin

    from energy_planner.energymap.core import band_names
    from energy_planner.io import write_geotiff

    names = band_names(4)
    rows, cols = cheap.shape
    data = np.ones((len(names), rows, cols))
    data[names.index("cheapest")] = cheap
    data[names.index("cheapest_heading_deg")] = 90.0
    data[names.index("anisotropy")] = 1.5
    path = tmp_path / "map.tif"
    return write_geotiff(path, data, transform=from_origin(X0, Y0 + rows, 1.0, 1.0),
                         crs="EPSG:32631", names=names, tags=tags or {})  # fmt: skip


def test_energy_map_colour_bar_says_it_clips(tmp_path, figures):
    from energy_planner.energymap import plot_energy_map

    ramp = np.arange(1.0, 101.0).reshape(10, 10)  # p2 = 2.98, p98 = 98.02 (numpy, linear)
    blocked = ramp.copy()
    blocked[0, :3] = np.inf  # above a slope limit at every heading
    tags = {"max_slope_tan": repr(math.tan(math.radians(25.0))), "max_cross_slope_sin": "inf"}
    plot_energy_map(_map(tmp_path, blocked, tags), tmp_path / "m.png")
    fig = figures[0]
    ax, cax = fig.axes
    (im,) = [i for i in ax.images if i.get_gid() != "slope_mask"]
    finite = blocked[np.isfinite(blocked)]
    lo, hi = np.percentile(finite, [2, 98])
    assert im.get_clim() == pytest.approx((lo, hi))
    assert im.colorbar.extend == "both"
    label = cax.get_ylabel()
    assert f"colour scale clipped at p2..p98: {lo:.4g}..{hi:.4g} J/m" in label
    # the blocked cells are the mask, named by the limit in the map's tags
    (mask,) = [i for i in ax.images if i.get_gid() == "slope_mask"]
    np.testing.assert_array_equal(~np.ma.getmaskarray(mask.get_array()), np.isinf(blocked))
    assert (
        "above the slope limit at every heading (slope 25\u00b0)"
        in (ax.get_legend_handles_labels()[1])
    )
    assert ax.get_xlabel() == "x (EPSG:32631, m)"


def test_energy_map_colour_bar_without_clipping_says_nothing(tmp_path, figures):
    from energy_planner.energymap import plot_energy_map
    from energy_planner.energymap.plot import colour_scale

    flat = np.full((6, 6), 7.0)
    plot_energy_map(_map(tmp_path, flat), tmp_path / "m.png")
    ax, cax = figures[0].axes
    assert ax.images[0].colorbar.extend == "neither"
    assert "clipped" not in cax.get_ylabel()
    # one end only: a single high outlier above p98 of 50 equal values
    v = np.r_[np.full(49, 1.0), 1000.0]
    assert colour_scale(v)[2] == "max" and colour_scale(-v)[2] == "min"


def test_energy_map_draws_its_channel_rasters(tmp_path, figures):
    """A categorical channel raster named in the map's tags: its boundary is drawn."""
    from rasterio.transform import from_origin

    from energy_planner.energymap import plot_energy_map
    from energy_planner.io import write_geotiff

    codes = np.ones((10, 10))
    codes[:, 6:] = 2.0  # mud from x = X0 + 6
    raster = write_geotiff(tmp_path / "ground.tif", codes, transform=from_origin(X0, Y0 + 10, 1, 1),
                           crs="EPSG:32631")  # fmt: skip
    table = tmp_path / "ground.csv"
    table.write_text("code,category\n1,grass\n2,mud\n")
    ch = {"constants": {}, "rasters": [{"name": "ground", "raster": str(raster),
                                        "table": str(table)}]}  # fmt: skip
    plot_energy_map(_map(tmp_path, np.ones((10, 10)), {"channels": repr(ch)}), tmp_path / "m.png")
    ax = figures[0].axes[0]
    (cs,) = [c for c in ax.collections if c.get_gid() == "channel:ground"]
    pts = np.vstack([p.vertices for p in cs.get_paths() if len(p.vertices)])
    np.testing.assert_allclose(pts[:, 0], X0 + 6.0, atol=1e-9)


def test_the_reach_command_passes_its_request_to_the_plot(valley, figures, tmp_path):
    """``reach --plot`` with --max-slope and --keep-out: both drawn, the CRS named."""
    import pyproj
    from click.testing import CliRunner
    from rasterio.transform import from_origin

    from energy_planner.cli import main
    from energy_planner.io import write_geotiff

    dem = write_geotiff(tmp_path / "valley.tif", valley.elevation, crs="EPSG:32631",
                        transform=from_origin(X0, Y0 + 30.0, 1.0, 1.0))  # fmt: skip
    to_ll = pyproj.Transformer.from_crs("EPSG:32631", "EPSG:4326", always_xy=True)
    ring = [list(to_ll.transform(x, y)) for x, y in ZONE.exterior.coords]
    ko = tmp_path / "zone.geojson"
    ko.write_text(json.dumps({"type": "Polygon", "coordinates": [ring]}))
    args = ["reach", str(dem), "--start", f"{X0 + 3.5},{Y0 + 20.5}", "--max-slope", str(LIMIT),
            "--keep-out", str(ko), "--plot", str(tmp_path / "r.png"), "--json"]  # fmt: skip
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 0, r.output
    ax = figures[0].axes[0]
    assert [p for p in ax.patches if p.get_gid() == "keep_out"]
    assert [i for i in ax.images if i.get_gid() == "slope_mask"]
    assert ax.get_xlabel() == "x (EPSG:32631, m)"


def test_terrain_plot_of_a_lon_lat_dem_is_in_its_own_crs(figures, tmp_path):
    # the slope rasters `terrain` writes are on the DEM's own grid: so is its plot
    from click.testing import CliRunner

    from energy_planner.cli import main

    r = CliRunner().invoke(main, ["terrain", "jacksboro", "--plot", str(tmp_path / "s.png")])
    assert r.exit_code == 0, r.output
    ax = figures[0].axes[0]
    assert ax.get_xlabel() == "longitude (EPSG:4326, deg)"
    assert ax.get_ylabel() == "latitude (EPSG:4326, deg)"
    left, right = ax.get_xlim()
    assert -180 < left < right < 180


def test_map_axes_keep_seven_digit_ticks_apart(figures, tmp_path):
    # at most five x ticks on an 8-inch route plot over UTM northings/eastings (they
    # overlapped at 10 m steps), plain numbers without offset
    from energy_planner.planning.routes import Route, RouteComparison

    hill = ep.open_terrain("hill")
    s = np.array([[500058.0, 5000046.0, 1.57], [500058.0, 5000084.0, 1.57]])
    comp = RouteComparison(routes=[Route("direct", s, 1.0, 38.0, 127.0, None, True)],
                           start=tuple(s[0]), goal=tuple(s[-1]))  # fmt: skip
    comp.plot(hill, tmp_path / "p.png")
    ax = figures[0].axes[0]
    figures[0].canvas.draw()
    lo, hi = ax.get_xlim()
    ticks = [v for v in ax.get_xticks() if lo <= v <= hi]
    assert 2 <= len(ticks) <= 5, ticks
    assert all(t.get_text().isdigit() for t in ax.get_xticklabels() if t.get_text())


def test_energy_map_of_a_lon_lat_dem_is_in_its_own_crs(tmp_path, figures):
    """The map is on the DEM's grid (lon/lat here): the plot too, in degrees, with units."""
    from rasterio.transform import from_origin

    from energy_planner.energymap import plot_energy_map
    from energy_planner.energymap.core import band_names
    from energy_planner.io import write_geotiff

    names = band_names(4)
    data = np.ones((len(names), 12, 16))
    data[names.index("cheapest")] = np.arange(1.0, 193.0).reshape(12, 16)
    data[names.index("cheapest_heading_deg")] = 90.0
    left, top, res = -84.3, 36.6, 0.005  # inside the bundled lon/lat map (jacksboro)
    tif = write_geotiff(tmp_path / "ll.tif", data, transform=from_origin(left, top, res, res),
                        crs="EPSG:4326", names=names)  # fmt: skip
    plot_energy_map(tif, tmp_path / "ll.png", "jacksboro")  # its hillshade, by name
    ax, cax = figures[0].axes
    assert ax.get_xlabel() == "longitude (EPSG:4326, deg)"
    assert ax.get_ylabel() == "latitude (EPSG:4326, deg)"
    assert ax.get_xlim() == pytest.approx((left, left + 16 * res))
    assert ax.get_ylim() == pytest.approx((top - 12 * res, top))
    assert "J per map metre" in cax.get_ylabel()
    assert len(ax.images) >= 2  # the hillshade under the cost
    # a degree of longitude is cos(latitude) of one of latitude on the ground
    lat = math.radians(top - 6 * res)
    assert ax.get_aspect() == pytest.approx(1 / math.cos(lat), rel=1e-6)
