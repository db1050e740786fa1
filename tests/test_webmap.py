"""The HTML pages of every product render in a real headless Chromium with the network blocked.

Each page (plan, compare-routes, reach, mission, energy-map, follow) is written by its
command's ``--html``, opened from disk (copied unchanged to one path, see the browser test) in
Debian's Chromium driven by Playwright with every request other than the file itself aborted,
and checked: it draws its traces, makes no network request, raises no script error; hovering
a route vertex shows that segment's energy, which must equal the per-segment energy of
``path_energy`` (an independent call).

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
def pages(small, tmp_path_factory):
    """Every product's page, written by its command as a user runs it (``--html``).

    Checks the wiring on the way: each command exits 0 and names the page in ``--json``.
    The plan's page is also written by the library, for the hover check.
    """
    import json

    from click.testing import CliRunner

    from energy_planner.cli import main
    from energy_planner.io import write_geotiff
    from energy_planner.simulate import simulate_missions
    from energy_planner.simulate.missions import MissionConfig

    d = tmp_path_factory.mktemp("html")
    prob = small
    dem = d / "hill.tif"
    write_geotiff(dem, prob.terrain.elevation, transform=prob.terrain.transform,
                  crs=prob.terrain.crs)  # fmt: skip
    sites = d / "sites.csv"
    sites.write_text("name,x,y\na,10.5,10.5\nb,50.5,12.5\nc,30.5,50.5\n")
    logs = d / "run.csv"
    cfg = MissionConfig(missions=1, duration_s=20.0, stop_prob=0.0, sideways_prob=0.0,
                        backward_prob=0.0, speeds=(0.3,), loads_kg=(0.0,),
                        grounds=("asphalt",))  # fmt: skip
    simulate_missions(seed=5, config=cfg, terrain=prob.terrain).logs.to_csv(logs, index=False)
    pts = ["--start", "10.5,10.5", "--goal", "50.5,48.5"]
    battery = ["--battery-wh", "30"]
    runs = {
        "plan": ["plan", "--dem", str(dem), *pts, "--time", "0.3"],
        "routes": ["compare-routes", "--dem", str(dem), *pts, "--time", "0.3"],
        "reach": ["reach", str(dem), "--start", "10.5,10.5", "--budget-wh", "2", *battery],
        "mission": ["mission", "--dem", str(dem), "--sites", str(sites), *battery],
        "energy_map": ["energy-map", str(dem), "--out", str(d / "m.tif"), "--headings", "4"],
        "follow": ["follow", str(logs), "--dem", str(dem), "--no-replan", *battery],
    }
    out = {}
    for name, args in runs.items():
        page = d / f"{name}.html"
        r = CliRunner().invoke(main, [*args, "--html", str(page), "--json"])
        assert r.exit_code == 0, (name, r.output)
        assert json.loads(r.stdout)["html"] == str(page), name
        out[name] = page
    res = ep.plan(prob, (10.5, 10.5), (50.5, 48.5), time=0.3)
    out["plan_library"] = res.write_html(d / "plan_library.html", prob)
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


def test_route_hover_uses_the_built_precompiled_kernels_and_never_builds_them(small, monkeypatch):
    # plan prices its path with the model's precompiled module; the page's hover does too
    # where the machine has built it (no numba kernel loaded for a page), and never builds it
    from energy_planner.energy import kernels, motion

    states = np.array([[10.5, 10.5, 0.0], [30.5, 12.5, 0.3], [50.5, 40.5, 1.2]])
    numba_path_table = small.gait_only().cost._fn_numba("path_table")
    priced = []

    class Built:  # a built module: numba's path_table (the same code), its calls counted
        @staticmethod
        def path_table(*args):
            priced.append(len(args[0]))
            return numba_path_table(*args)

    texts, asked = {}, {}
    for built in (Built, None):
        asked[built] = []

        def module(source, build=True, built=built):
            asked[built].append(build)
            if built is None and build:
                pytest.fail("a page built the precompiled module")
            return built

        monkeypatch.setattr(kernels, "precompiled_module", module)
        monkeypatch.setattr(motion, "precompiled_module", module)
        texts[built] = webmap.route_hover(small, states, "r")
    assert priced == [3]  # the hover's three poses, priced once: by the built module
    assert asked[Built][0] is False  # looked up without building, then loaded
    assert asked[None] == [False]  # not built: looked up only, numba's kernels price it
    assert texts[Built] == texts[None] and len(texts[None]) == 3


def test_every_page_is_self_contained(pages):
    bundle = webmap.CARTESIAN_JS.read_text("utf-8")
    for name, p in pages["paths"].items():
        text = p.read_text()
        # no script or stylesheet fetched from anywhere: everything inline
        assert not re.search(r"<script[^>]+src=", text), name
        assert not re.search(r"<link[^>]+href=\"http", text), name
        # plotly.js is inlined: the vendored cartesian bundle (1.5 MB), whole and once
        assert text.count(bundle) == 1 and len(bundle) > 1_000_000, name


def test_the_vendored_plotly_bundle_is_the_plotly_packages_release(monkeypatch):
    """The cartesian bundle the pages inline is plotly.js of the version the ``plotly``
    package bundles (its figure JSON is that version's), has exactly the trace types
    :data:`~energy_planner.webmap.CARTESIAN_TRACES` names, is the file its README's sha256
    names, ships in the wheel with its licence; a page with another trace type, or under a
    ``plotly`` that bundles another plotly.js, inlines Plotly's full bundle."""
    import fnmatch
    import hashlib
    import tomllib
    from pathlib import Path

    import plotly.graph_objects as go
    from plotly.offline import get_plotlyjs_version

    raw = webmap.CARTESIAN_JS.read_bytes()
    head = raw[:200].decode("ascii")
    assert re.search(r"plotly\.js \(cartesian - minified\) v([\d.]+)\n", head).group(1) == (
        get_plotlyjs_version()
    )
    traces = re.findall(rb'moduleType:"trace",name:"(\w+)"', raw)
    assert sorted(t.decode() for t in traces) == sorted(webmap.CARTESIAN_TRACES)
    folder = webmap.CARTESIAN_JS.parent
    assert hashlib.sha256(raw).hexdigest() in (folder / "README.md").read_text()
    assert "MIT License" in (folder / "LICENSE").read_text()
    root = Path(__file__).resolve().parents[1]
    shipped = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"][
        "package-data"
    ]["energy_planner"]
    for f in ("plotly-cartesian.min.js", "LICENSE", "README.md"):
        assert any(fnmatch.fnmatch(f"data/plotly/{f}", pat) for pat in shipped), f

    t = ep.Terrain.from_function(lambda x, y: 0.1 * x, size=(8, 8))
    page = webmap.WebMap(t, "a plane")
    page.add_route("line", [[2.0, 2.0], [6.0, 2.0]])
    text = page.html()
    assert text.count(raw.decode("utf-8")) == 1 and "plotly.js v" not in text
    full = f"plotly.js v{get_plotlyjs_version()}\n"
    with monkeypatch.context() as m:  # a plotly of another plotly.js: its own bundle
        m.setattr("plotly.offline.get_plotlyjs_version", lambda: "2.35.2")
        text = page.html()
    assert full in text and "plotly.js (cartesian" not in text
    page.figure.add_trace(go.Scatter3d(x=[0], y=[0], z=[0]))  # not in the cartesian bundle
    text = page.html()
    assert full in text and "plotly.js (cartesian" not in text


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
        page.set_default_timeout(180000)  # a loaded CI machine parses 1.5 MB pages slowly
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        drawn = {}
        # every page is opened at one path, a byte-for-byte copy of it: V8 keeps the
        # compiled plotly.js (1.5 MB, inlined in each page) per script URL, so seven paths
        # would compile it seven times
        view = pages["paths"]["plan"].parent / "view" / "page.html"
        view.parent.mkdir(exist_ok=True)
        for name, p in pages["paths"].items():
            shutil.copyfile(p, view)
            assert view.read_bytes() == p.read_bytes(), name
            page.goto(view.as_uri())
            page.wait_for_selector("#energy-planner-map .main-svg", timeout=180000)
            drawn[name] = page.evaluate(
                "() => { const gd = document.getElementById('energy-planner-map');"
                " return gd._fullData.map(d => d.type); }"
            )
            if name == "plan_library":
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
                page.wait_for_selector(".hoverlayer .hovertext", timeout=60000)
                shown = page.text_content(".hoverlayer")
                want = re.search(r"energy ([\d,.]+ J)", hover_expected[i]).group(1)
                assert f"segment {i + 1} of" in shown and want in shown, shown
        browser.close()
    assert asked == [] and errors == []
    assert drawn["plan"].count("scatter") == 2  # the route, start and goal
    assert drawn["plan_library"] == drawn["plan"]
    assert drawn["routes"].count("scatter") >= 3
    assert drawn["reach"].count("heatmap") == 2 and "contour" in drawn["reach"]
    assert drawn["mission"].count("scatter") == 3  # two legs, the sites
    assert drawn["energy_map"].count("heatmap") >= 3  # the band chooser's bands
    assert drawn["follow"].count("scatter") == 3  # the path, the walked poses, the updates
