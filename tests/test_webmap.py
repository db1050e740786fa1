"""The HTML pages of every product render in a real headless Chromium with the network blocked.

Each page (plan, compare-routes, reach, mission, energy-map, follow) is written by the
library, opened from disk in Debian's Chromium driven by Playwright with every request
other than the file itself aborted, and checked: it draws its traces, makes no network
request, raises no script error; hovering a route vertex shows that segment's energy, which
must equal the per-segment energy of ``path_energy`` (an independent call).

CI installs Chromium (``.ci/run``); elsewhere the browser tests skip when there is none.
"""

from __future__ import annotations

import os
import re
import shutil

import numpy as np
import pytest

import energy_planner as ep
from energy_planner import webmap

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
ARGS = [
    "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
]  # fmt: skip


def _browser_or_skip():
    if CHROMIUM is None:
        if os.environ.get("CI"):
            pytest.fail("CI must install Chromium (.ci/run: apt-get install chromium)")
        pytest.skip("no chromium on this machine (apt-get install chromium)")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:  # pragma: no cover - a test extra
        pytest.fail("playwright is a test dependency (pip install -e '.[test]')")
    return sync_playwright


@pytest.fixture(scope="module")
def small():
    """A 60 m x 60 m hill at 1 m and the bundled model: every product in seconds."""
    terrain = ep.Terrain.from_function(
        lambda x, y: 12.0 * np.exp(-((x - 30.0) ** 2 + (y - 30.0) ** 2) / 300.0),
        size=(60, 60),
        crs="EPSG:32631",
    )
    return ep.Problem(terrain, ep.load_model())


@pytest.fixture(scope="module")
def pages(small, tmp_path_factory, make_follower, follow_mission):
    """Every product's page, written by the library."""
    d = tmp_path_factory.mktemp("html")
    prob = small
    s, g = (10.5, 10.5), (50.5, 48.5)
    res = ep.plan(prob, s, g, time=0.5)
    out = {"plan": res.write_html(d / "plan.html", prob)}
    comp = ep.compare_routes(prob, s, g, time=0.5)
    out["routes"] = comp.write_html(d / "routes.html", prob)
    reach = ep.reach(prob, s)
    out["reach"] = reach.write_html(d / "reach.html", prob.terrain, 2.0 * 3600,
                                    model=prob.model, usable_j=3.0 * 3600)  # fmt: skip
    from energy_planner.mission import Sites, mission

    sites = Sites(np.array([[10.5, 10.5], [50.5, 12.5], [30.5, 50.5]]), ["a", "b", "c"])
    m = mission(prob, sites)
    out["mission"] = m.write_html(d / "mission.html", prob, m.battery(prob.model, 30.0))
    dem = d / "hill.tif"
    from energy_planner.io import write_geotiff

    write_geotiff(dem, prob.terrain.elevation, transform=prob.terrain.transform,
                  crs=prob.terrain.crs)  # fmt: skip
    emap = ep.energy_map(dem, d / "map.tif", headings=4)
    out["energy_map"] = emap.write_html(d / "map.html", dem)
    logs = follow_mission()
    f = make_follower(logs, battery_wh=30.0)
    f.replay(logs)
    out["follow"] = f.write_html(d / "follow.html")
    return {"paths": out, "plan": res, "problem": prob}


def test_route_hover_texts_are_the_segments_of_path_energy(small):
    # independent of the browser: the hover of vertex i is segment i of path_energy
    states = np.array([[10.5, 10.5, 0.0], [30.5, 12.5, 0.3], [50.5, 40.5, 1.2]])
    hover = webmap.route_hover(small, states, "r")
    from energy_planner.energy import path_energy

    pe = path_energy(small.terrain, small.model, states[:, :2], yaw=states[:, 2])
    assert len(hover) == 3
    for i in range(2):
        shown = float(re.search(r"energy ([\d,.]+) J", hover[i]).group(1).replace(",", ""))
        assert shown == pytest.approx(pe.table["energy_j"][i], abs=0.06)
    assert f"{pe.energy_j:,.0f} J" in hover[-1]


def test_every_page_is_self_contained(pages):
    for name, p in pages["paths"].items():
        text = p.read_text()
        # no script or stylesheet fetched from anywhere: everything inline
        assert not re.search(r"<script[^>]+src=", text), name
        assert not re.search(r"<link[^>]+href=\"http", text), name
        assert len(text) > 3_000_000, name  # plotly.js (about 4.6 MB) is inlined


def test_pages_render_offline_and_hover_shows_the_segment_energy(pages):
    sync_playwright = _browser_or_skip()
    plan = pages["plan"]
    hover_expected = webmap.route_hover(pages["problem"], plan.states, "planned")
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, headless=True, args=ARGS)
        ctx = browser.new_context(offline=True, viewport={"width": 1200, "height": 900})
        asked: list[str] = []

        def route(r):
            url = r.request.url
            if url.startswith(("file:", "data:")):
                r.continue_()
            else:
                asked.append(url)
                r.abort()

        ctx.route("**/*", route)
        page = ctx.new_page()
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        drawn = {}
        for name, p in pages["paths"].items():
            page.goto(p.as_uri())
            page.wait_for_selector("#energy-planner-map .main-svg", timeout=60000)
            drawn[name] = page.evaluate(
                "() => { const gd = document.getElementById('energy-planner-map');"
                " return gd._fullData.map(d => d.type); }"
            )
            if name == "plan":
                # hover the middle vertex of the route, as a user moves the mouse there
                i = len(plan.states) // 2
                xy = page.evaluate(
                    """(i) => { const gd = document.getElementById('energy-planner-map');
                    const tr = gd._fullData.find(d => d.type === 'scatter');
                    const xa = gd._fullLayout.xaxis, ya = gd._fullLayout.yaxis;
                    const bb = gd.getBoundingClientRect();
                    return [bb.left + xa._offset + xa.l2p(tr.x[i]),
                            bb.top + ya._offset + ya.l2p(tr.y[i])]; }""",
                    i,
                )
                page.mouse.move(*xy)
                page.wait_for_selector(".hoverlayer .hovertext", timeout=10000)
                shown = page.text_content(".hoverlayer")
                want = re.search(r"energy ([\d,.]+ J)", hover_expected[i]).group(1)
                assert f"segment {i + 1} of" in shown and want in shown, shown
        browser.close()
    assert asked == [] and errors == []
    assert drawn["plan"].count("scatter") == 2  # the route, start and goal
    assert drawn["routes"].count("scatter") >= 3
    assert drawn["reach"].count("heatmap") == 2 and "contour" in drawn["reach"]
    assert drawn["mission"].count("scatter") == 3  # two legs, the sites
    assert drawn["energy_map"].count("heatmap") >= 3  # the band chooser's bands
    assert "scatter" in drawn["follow"]
