"""A longitude/latitude DEM's map plots are drawn in its own CRS, in degrees.

The DEM is the bundled hill (UTM 31N) warped to EPSG:4326 on a small grid; the planner
works on a UTM grid, the plots draw in lon/lat. Every drawn route, leg, site and start is
checked against the working-CRS coordinates converted independently with pyproj
(``always_xy``), the reach budget contour against the analytic circle of a cone of
energy (converted back to metres with pyproj), a lon/lat keep-out against the ring
given, the limits against the DEM's bounds, and the aspect against ``1 / cos(lat)``.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pyproj
import pytest
import rasterio
from rasterio.warp import Resampling, calculate_default_transform, reproject
from shapely.geometry import Point

from energy_planner.maps import map_path
from energy_planner.terrain import load_dem

LON = "longitude (EPSG:4326, deg)"
LAT = "latitude (EPSG:4326, deg)"


@pytest.fixture(scope="module")
def lonlat(tmp_path_factory):
    """The hill warped to EPSG:4326 on a 50 x 50 grid (about 4 m cells)."""
    out = tmp_path_factory.mktemp("ll") / "hill_ll.tif"
    with rasterio.open(map_path("hill")) as src:
        t, w, h = calculate_default_transform(
            src.crs, "EPSG:4326", src.width, src.height, *src.bounds, dst_width=50, dst_height=50
        )
        z = np.full((h, w), np.nan)
        reproject(rasterio.band(src, 1), z, dst_transform=t, dst_crs="EPSG:4326",
                  dst_nodata=np.nan, resampling=Resampling.bilinear)  # fmt: skip
    with rasterio.open(out, "w", driver="GTiff", height=h, width=w, count=1, dtype="float64",
                       crs="EPSG:4326", transform=t, nodata=np.nan) as dst:  # fmt: skip
        dst.write(z, 1)
    terrain = load_dem(out)
    assert terrain.source_crs.is_geographic and not terrain.crs.is_geographic
    return terrain


@pytest.fixture
def figures(monkeypatch):
    """The figures the plots save, in order (nothing is written)."""
    import energy_planner.io as io

    caught = []
    monkeypatch.setattr(io, "save_figure", lambda fig, path, **kw: caught.append(fig) or path)
    return caught


def _to_ll(t, x, y):
    tr = pyproj.Transformer.from_crs(t.crs.to_wkt(), "EPSG:4326", always_xy=True)
    return tr.transform(np.asarray(x, float), np.asarray(y, float))


def _inner(t, fx, fy):
    """A working-CRS point at fractions (fx, fy) of the DEM's lon/lat box."""
    b = t.source_bounds
    return t.to_work(b[0] + fx * (b[2] - b[0]), b[1] + fy * (b[3] - b[1]))


def _check_axes(ax, t):
    assert ax.get_xlabel() == LON and ax.get_ylabel() == LAT
    b = t.source_bounds
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    assert b[0] - 1e-12 <= x0 < x1 <= b[2] + 1e-12
    assert b[1] - 1e-12 <= y0 < y1 <= b[3] + 1e-12
    lat = math.radians(0.5 * (b[1] + b[3]))
    assert ax.get_aspect() == pytest.approx(1 / math.cos(lat), rel=1e-9)
    # the hillshade / raster under everything is the DEM's own grid
    assert ax.images[0].get_extent() == pytest.approx([b[0], b[2], b[1], b[3]])


def _route_states(t):
    a, b, c = _inner(t, 0.3, 0.25), _inner(t, 0.55, 0.5), _inner(t, 0.7, 0.8)
    xy = np.array([a, b, c], float)
    return np.column_stack([xy, np.arctan2(np.gradient(xy[:, 1]), np.gradient(xy[:, 0]))])


def test_route_plot_draws_the_routes_in_lon_lat(lonlat, figures, tmp_path):
    from energy_planner.planning.routes import Route, RouteComparison

    s = _route_states(lonlat)
    comp = RouteComparison(routes=[Route("energy_optimal", s, 1.0, 90.0, 300.0, None, True)],
                           start=tuple(s[0]), goal=tuple(s[-1]))  # fmt: skip
    comp.plot(tmp_path / "p.png", lonlat)
    ax = figures[0].axes[0]
    _check_axes(ax, lonlat)
    (line,) = [ln for ln in ax.lines if ln.get_gid() == "route:energy_optimal"]
    lon, lat = _to_ll(lonlat, s[:, 0], s[:, 1])
    np.testing.assert_allclose(line.get_xdata(), lon, atol=1e-6)
    np.testing.assert_allclose(line.get_ydata(), lat, atol=1e-6)
    # the view holds the route
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    assert x0 < lon.min() and lon.max() < x1 and y0 < lat.min() and lat.max() < y1
    # the heading arrows point along the route on the ground: north-east here, so the
    # drawn arrow (u, v) of a north-east leg has u > 0 and v > 0
    q = ax.collections[-1]
    assert np.all(q.U > 0) and np.all(q.V > 0)


def test_plan_result_plot_is_in_lon_lat(lonlat, figures, tmp_path):
    """``plan --plot``'s path.png: a PlanResult draws its path through the same plot."""
    from energy_planner.planning.plan import PlanResult

    s = _route_states(lonlat)
    res = PlanResult(states=s, energy_j=1.0, distance_m=90.0, duration_s=60.0, planner="test")
    res.plot(tmp_path / "path.png", lonlat)
    ax = figures[0].axes[0]
    _check_axes(ax, lonlat)
    lon, lat = _to_ll(lonlat, s[:, 0], s[:, 1])
    drawn = [ln for ln in ax.lines if (ln.get_gid() or "").startswith("route:")]
    assert drawn
    np.testing.assert_allclose(drawn[0].get_xdata(), lon, atol=1e-6)
    np.testing.assert_allclose(drawn[0].get_ydata(), lat, atol=1e-6)


def test_reach_plot_budget_circle_in_lon_lat(lonlat, figures, tmp_path):
    """Energy = 10 J per metre from the start: the budget contour is a circle on the ground."""
    from energy_planner.planning.reach import ReachMap

    start = _inner(lonlat, 0.5, 0.5)
    xc, yc = lonlat.cell_centers()
    energy = 10.0 * np.hypot(xc - start[0], yc - start[1])
    radius = 50.0  # m
    res = ReachMap(energy_j=energy, start=start, round_trip=False, step=1.0)
    res.plot(tmp_path / "r.png", lonlat, budget_j=10.0 * radius)
    ax = figures[0].axes[0]
    _check_axes(ax, lonlat)
    (start_pt,) = [ln for ln in ax.lines if ln.get_label() == "start"]
    lon, lat = _to_ll(lonlat, *start)
    assert start_pt.get_xdata()[0] == pytest.approx(lon, abs=1e-6)
    assert start_pt.get_ydata()[0] == pytest.approx(lat, abs=1e-6)
    (budget,) = [c for c in ax.collections if c.get_gid() == "budget"]
    v = np.vstack([p.vertices for p in budget.get_paths() if len(p.vertices)])
    back = pyproj.Transformer.from_crs("EPSG:4326", lonlat.crs.to_wkt(), always_xy=True)
    x, y = back.transform(v[:, 0], v[:, 1])
    r = np.hypot(np.asarray(x) - start[0], np.asarray(y) - start[1])
    cell = math.hypot(*lonlat.resolution)  # nearest-cell resampling moves it by < a cell
    np.testing.assert_allclose(r, radius, atol=cell)


def test_mission_plot_draws_legs_and_sites_in_lon_lat(lonlat, figures, tmp_path):
    from energy_planner.mission.core import Leg, MissionResult
    from energy_planner.mission.sites import Sites

    s = _route_states(lonlat)
    xy = s[[0, -1], :2]
    res = MissionResult(sites=Sites(xy=xy, names=["a", "b"]), order=[0, 1],
                        legs=[Leg(0, 1, 1.0, 1.0, 20.0, 60.0, s)], matrix_j=np.zeros((2, 2)),
                        method="test", return_to_start=False)  # fmt: skip
    res.plot(tmp_path / "m.png", lonlat)
    ax = figures[0].axes[0]
    _check_axes(ax, lonlat)
    (leg,) = [ln for ln in ax.lines if ln.get_gid() == "leg:0"]
    lon, lat = _to_ll(lonlat, s[:, 0], s[:, 1])
    np.testing.assert_allclose(leg.get_xdata(), lon, atol=1e-6)
    np.testing.assert_allclose(leg.get_ydata(), lat, atol=1e-6)
    (site,) = [ln for ln in ax.lines if ln.get_gid() == "site:1"]
    assert site.get_xdata()[0] == pytest.approx(lon[-1], abs=1e-6)
    assert site.get_ydata()[0] == pytest.approx(lat[-1], abs=1e-6)


def test_a_lon_lat_keep_out_is_drawn_where_it_was_given(lonlat, figures, tmp_path):
    from energy_planner.planning.routes import Route, RouteComparison
    from energy_planner.request import Limits, Request

    cx, cy = _inner(lonlat, 0.5, 0.5)
    zone = Point(cx, cy).buffer(20.0, 8)
    ring = np.column_stack(_to_ll(lonlat, *np.asarray(zone.exterior.coords).T))
    path = tmp_path / "zone.geojson"
    path.write_text(json.dumps({"type": "Polygon", "coordinates": [ring.tolist()]}))
    s = _route_states(lonlat)
    comp = RouteComparison(routes=[Route("direct", s, 1.0, 90.0, 300.0, None, True)],
                           start=tuple(s[0]), goal=tuple(s[-1]))  # fmt: skip
    req = Request(limits=Limits(max_slope_deg=15.0, keep_out=path))
    comp.plot(tmp_path / "p.png", lonlat, request=req)
    ax = figures[0].axes[0]
    (ko,) = [p for p in ax.patches if p.get_gid() == "keep_out"]
    v = ko.get_path().vertices
    np.testing.assert_allclose(
        [v[:, 0].min(), v[:, 1].min(), v[:, 0].max(), v[:, 1].max()],
        [*ring.min(axis=0), *ring.max(axis=0)],
        atol=1e-6,
    )
    # the slope mask lies on the DEM's own grid
    (mask,) = [i for i in ax.images if i.get_gid() == "slope_mask"]
    b = lonlat.source_bounds
    assert mask.get_extent() == pytest.approx([b[0], b[2], b[1], b[3]])
    assert mask.get_array().shape == lonlat.source_shape


def test_a_metric_dem_is_drawn_in_its_working_crs_unchanged(figures, tmp_path):
    # a DEM planned on its own grid: the drawn coordinates are the planned ones, exactly
    import energy_planner as ep
    from energy_planner.planning.routes import Route, RouteComparison

    hill = ep.open_terrain("hill")
    s = np.array([[500058.0, 5000046.0, 1.57], [500058.0, 5000084.0, 1.57]])
    comp = RouteComparison(routes=[Route("direct", s, 1.0, 38.0, 127.0, None, True)],
                           start=tuple(s[0]), goal=tuple(s[-1]))  # fmt: skip
    comp.plot(tmp_path / "p.png", hill)
    ax = figures[0].axes[0]
    (line,) = [ln for ln in ax.lines if ln.get_gid() == "route:direct"]
    np.testing.assert_array_equal(line.get_xdata(), s[:, 0])
    np.testing.assert_array_equal(line.get_ydata(), s[:, 1])
    assert ax.get_xlabel() == "x (EPSG:32631, m)" and ax.get_aspect() == 1.0
