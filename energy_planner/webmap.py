"""Self-contained HTML pages of the products: a map that opens in any browser, offline.

``--html FILE`` on ``plan``, ``compare-routes``, ``reach``, ``mission``, ``energy-map`` and
``follow`` (and the results' ``write_html``) writes one HTML file that holds everything it
shows: Plotly's JavaScript is inlined and the hillshade is an inline PNG, so the page makes
no network request (a field laptop has none). The script is plotly.js's "cartesian" bundle
(``data/plotly/``; 1.5 MB where the full one has 4.8 MB) when the page draws only its trace
types (:data:`CARTESIAN_TRACES`; every page here does) and it is the plotly.js release the
installed ``plotly`` bundles; Plotly's full bundle otherwise. The page shows

- the DEM's hillshade in the working grid's CRS (metres; the axes name the CRS),
- routes as lines; hovering a vertex shows the segment that starts there: its energy, the
  energy so far, slope, the direction of travel, the body yaw and the speed,
- rasters (reach energy, its battery chance, energy-map bands) as colour layers with a
  chooser when there are several, the reach's budget contour,
- sites with their names, and the legs between them with their energies and chances.

Angles on the page follow the project's frames: the direction of travel and the body yaw
are degrees counter-clockwise from the grid's +x axis (east), the relative heading is
``yaw - uphill azimuth`` (0 facing uphill).

Examples
--------
>>> import energy_planner as ep
>>> from energy_planner.webmap import WebMap
>>> t = ep.Terrain.from_function(lambda x, y: 0.1 * x, size=(20, 20))
>>> page = WebMap(t, "a plane")
>>> page.add_route("line", [[2.0, 2.0], [10.0, 2.0]], hover=["start", "end"])
>>> len(page.figure.data)
1
"""

from __future__ import annotations

import base64
import html as _html
import io
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "CARTESIAN_TRACES",
    "MAX_SIDE",
    "WebMap",
    "route_hover",
    "plan_page",
    "routes_page",
    "reach_page",
    "mission_page",
    "follow_page",
]

#: Pixels on the longer side of a raster drawn on a page (hillshade, reach, map bands):
#: enough to read a map, small enough for a page of a few MB.
MAX_SIDE = 600
#: Route colours, in order (the matplotlib plots use the same order of hues).
ROUTE_COLORS = ("#1f77b4", "#2ca02c", "#d62728", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2")
#: The trace types of plotly.js's "cartesian" bundle, vendored in ``data/plotly/`` (its
#: README: source, version, sha256). A page whose traces are all of these inlines it.
CARTESIAN_TRACES = frozenset({
    "bar", "box", "contour", "heatmap", "histogram", "histogram2d", "histogram2dcontour",
    "image", "pie", "scatter", "scatterternary", "violin",
})  # fmt: skip
#: The vendored bundle (MIT, ``data/plotly/LICENSE``); its plotly.js version is the one the
#: ``plotly`` package bundles, so the figure JSON Python writes is the one it reads.
CARTESIAN_JS = Path(__file__).parent / "data" / "plotly" / "plotly-cartesian.min.js"


def _stride(shape: tuple[int, int], max_side: int) -> int:
    return max(1, math.ceil(max(shape) / max_side))


def _png_uri(gray: np.ndarray) -> str:
    """An inline PNG (data URI) of a 0..1 array; NaN transparent.

    Encoded by Pillow directly (what matplotlib's ``imsave`` calls, without importing
    matplotlib: a page that draws no matplotlib figure does not pay its import).
    """
    from PIL import Image

    g = np.clip(np.nan_to_num(gray, nan=0.0), 0.0, 1.0)
    rgba = np.empty(gray.shape + (4,), dtype=np.uint8)
    rgba[..., :3] = (g * 255).astype(np.uint8)[..., None]
    rgba[..., 3] = np.where(np.isfinite(gray), 255, 0)
    buf = io.BytesIO()
    Image.fromarray(rgba).save(buf, format="png")  # (h, w, 4) uint8: RGBA
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _cartesian_js() -> str | None:
    """The vendored cartesian bundle, or None if ``plotly`` bundles another plotly.js.

    The figure JSON that ``plotly`` writes is for its own plotly.js version: under another
    one the pages inline its full bundle.
    """
    from plotly.offline import get_plotlyjs_version

    js = CARTESIAN_JS.read_text("utf-8")
    head = f"plotly.js (cartesian - minified) v{get_plotlyjs_version()}\n"
    return js if head in js[:200] else None


def _fmt(v: float, unit: str, digits: int = 0) -> str:
    return "n/a" if v is None or not np.isfinite(v) else f"{v:,.{digits}f} {unit}".strip()


class WebMap:
    """A Plotly map in a terrain's working CRS: hillshade underneath, products on top.

    Parameters
    ----------
    terrain : Terrain
        The map; its hillshade is drawn underneath and its working CRS names the axes.
    title : str
        Page and figure title.
    max_side : int
        Pixels on the longer side of every raster drawn.

    Notes
    -----
    Coordinates are the working grid's (``terrain.crs``, metres), as the PNG plots
    draw them; routes and sites are given in that CRS.
    """

    def __init__(self, terrain: Any, title: str, max_side: int = MAX_SIDE) -> None:
        k = _stride(terrain.shape, max_side)
        self._setup(title, terrain.hillshade()[::k, ::k], terrain.grid, terrain.shape,
                    terrain.crs, max_side)  # fmt: skip

    @classmethod
    def of_grid(
        cls,
        title: str,
        shade: np.ndarray | None,
        transform: Any,
        shape: tuple[int, int],
        crs: Any,
        max_side: int = MAX_SIDE,
    ) -> WebMap:
        """A page on a raster's grid (``transform``, ``shape``) rather than a terrain's.

        ``shade`` is the hillshade on that grid (or any coarser grid of the same extent;
        None: no hillshade), e.g. an energy map's grid when the DEM is larger than memory.
        """  # fmt: skip
        page = cls.__new__(cls)
        grid = (transform.c + transform.a / 2, transform.f + transform.e / 2,
                transform.a, transform.e)  # fmt: skip
        page._setup(title, shade, grid, shape, crs, max_side)
        return page

    def _setup(self, title, shade, grid, shape, crs, max_side) -> None:
        import plotly.graph_objects as go

        from energy_planner.plotting import crs_label

        self.title = title
        self.max_side = max_side
        self.grid = grid
        self.figure = go.Figure()
        self._rasters: list[tuple[int, str]] = []
        x0, y0, dx, dy = grid
        rows, cols = shape
        self.extent = (x0 - dx / 2, x0 + (cols - 0.5) * dx, y0 + (rows - 0.5) * dy, y0 - dy / 2)
        left, right, bottom, top = self.extent
        if shade is not None:
            self.figure.add_layout_image(
                source=_png_uri(shade), xref="x", yref="y",
            x=left, y=top, sizex=right - left, sizey=top - bottom,
                sizing="stretch", layer="below", name="hillshade",
            )  # fmt: skip
        name = crs_label(crs)
        self.figure.update_layout(
            title=title,
            template="plotly_white",
            xaxis=dict(title=f"x ({name}, m)", range=[left, right], showgrid=False,
                       constrain="domain", tickformat="d"),
            yaxis=dict(title=f"y ({name}, m)", range=[bottom, top], showgrid=False,
                       scaleanchor="x", scaleratio=1, constrain="domain", tickformat="d"),
            legend=dict(orientation="h", yanchor="top", y=-0.12, x=0),
            hovermode="closest",
            margin=dict(l=70, r=30, t=60, b=90),
            height=760,
        )  # fmt: skip

    def add_raster(
        self,
        name: str,
        values: np.ndarray,
        unit: str,
        *,
        colorscale: str = "Viridis",
        visible: bool = True,
        opacity: float = 0.6,
        transform: Any = None,
    ) -> None:
        """A colour layer of ``values`` (the working grid, or ``transform``'s grid).

        Several rasters get a chooser (:meth:`write` adds it): one shown at a time.
        """
        import plotly.graph_objects as go

        values = np.asarray(values, dtype=float)
        k = _stride(values.shape, self.max_side)
        z = values[::k, ::k].astype(np.float32)
        if transform is None:
            x0, y0, dx, dy = self.grid
        else:
            dx, dy = transform.a, transform.e
            x0, y0 = transform.c + dx / 2, transform.f + dy / 2
        xs = x0 + dx * k * np.arange(z.shape[1])
        ys = y0 + dy * k * np.arange(z.shape[0])
        z = np.where(np.isfinite(z), z, np.nan)
        finite = z[np.isfinite(z)]
        lo, hi = np.percentile(finite, [2, 98]) if finite.size else (0.0, 1.0)
        self._rasters.append((len(self.figure.data), name))
        self.figure.add_trace(
            go.Heatmap(
                z=z, x=xs, y=ys, colorscale=colorscale, zmin=float(lo), zmax=float(max(hi, lo)),
                opacity=opacity, visible=visible, name=name, showlegend=False,
                colorbar=dict(title=f"{name}, {unit}", len=0.8),
                hovertemplate=f"x %{{x:.0f}} m<br>y %{{y:.0f}} m<br>{_html.escape(name)}: "
                              f"%{{z:.3g}} {unit}<extra></extra>",
            )
        )  # fmt: skip

    def add_contour(self, values: np.ndarray, level: float, name: str, color: str = "red") -> None:
        """The line where ``values`` crosses ``level`` (working grid), e.g. a budget."""
        import plotly.graph_objects as go

        values = np.asarray(values, dtype=float)
        if not (np.isfinite(values).any() and np.nanmin(values) < level):
            return
        k = _stride(values.shape, self.max_side)
        z = values[::k, ::k]
        z = np.where(np.isfinite(z), z, np.nanmax(z) * 2 + 1)
        x0, y0, dx, dy = self.grid
        self.figure.add_trace(
            go.Contour(
                z=z, x=x0 + dx * k * np.arange(z.shape[1]), y=y0 + dy * k * np.arange(z.shape[0]),
                contours=dict(start=level, end=level, size=1, coloring="none"),
                line=dict(color=color, width=3), showscale=False, name=name, showlegend=True,
                hoverinfo="skip",
            )
        )  # fmt: skip

    def add_route(
        self,
        name: str,
        xy: Any,
        *,
        hover: Sequence[str] | None = None,
        color: str | None = None,
        width: float = 3.0,
        dash: str | None = None,
    ) -> None:
        """A route through ``xy`` (working CRS); ``hover`` is one text per vertex."""
        import plotly.graph_objects as go

        xy = np.asarray(xy, dtype=float)
        color = color or ROUTE_COLORS[sum(1 for d in self.figure.data if d.type == "scatter")
                                      % len(ROUTE_COLORS)]  # fmt: skip
        self.figure.add_trace(
            go.Scatter(
                x=xy[:, 0], y=xy[:, 1], mode="lines+markers", name=name,
                line=dict(color=color, width=width, dash=dash), marker=dict(size=5, color=color),
                text=list(hover) if hover is not None else None,
                hovertemplate=("%{text}" if hover is not None else "x %{x:.0f}, y %{y:.0f}")
                + f"<extra>{_html.escape(name)}</extra>",
            )
        )  # fmt: skip

    def add_points(
        self, name: str, xy: Any, labels: Sequence[str], hover: Sequence[str], *, color="white"
    ) -> None:
        """Marked points (sites, a start) with a label beside each and a hover text."""
        import plotly.graph_objects as go

        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        self.figure.add_trace(
            go.Scatter(
                x=xy[:, 0], y=xy[:, 1], mode="markers+text", name=name, text=list(labels),
                textposition="top center", textfont=dict(color="black", size=13),
                marker=dict(size=13, color=color, line=dict(color="black", width=1.5)),
                hovertext=list(hover), hovertemplate="%{hovertext}<extra></extra>",
            )
        )  # fmt: skip

    def html(self) -> str:
        """The page: one HTML document with Plotly's JavaScript inlined.

        The script is the vendored "cartesian" bundle when every trace is one of
        :data:`CARTESIAN_TRACES` and the installed ``plotly`` bundles its plotly.js version,
        Plotly's full bundle otherwise.
        """
        fig = self.figure
        if len(self._rasters) > 1:
            n = len(fig.data)
            raster_ids = [i for i, _ in self._rasters]
            buttons = []
            for i, name in self._rasters:
                vis = [True] * n
                for j in raster_ids:
                    vis[j] = j == i
                buttons.append(dict(label=name, method="restyle", args=[{"visible": vis}]))
            first = next((b for b, (i, _) in enumerate(self._rasters) if fig.data[i].visible
                          is not False), 0)  # fmt: skip
            fig.update_layout(
                updatemenus=[dict(buttons=buttons, active=first, x=1.0, xanchor="right",
                                  y=1.08, yanchor="bottom", direction="down")]
            )  # fmt: skip
        # the cartesian bundle goes where to_html puts the full one (in <head>, Chromium
        # spent twice the CPU on the test's pages): to_html writes a script tag that loads
        # a file (src), and the bundle takes its place inline
        src = "energy-planner-plotly-cartesian.min.js"
        if {d.type for d in fig.data} <= CARTESIAN_TRACES and (js := _cartesian_js()):
            text = self._to_html(src)
            before, tag, after = text.partition(f'<script charset="utf-8" src="{src}"></script>')
            if tag:  # (a plotly that writes the tag otherwise: the full bundle, below)
                return f"{before}<script>{js}</script>{after}"  # as to_html inlines
        return self._to_html(True)

    def _to_html(self, include_plotlyjs: bool | str) -> str:
        return self.figure.to_html(
            include_plotlyjs=include_plotlyjs,
            full_html=True,
            config={"displaylogo": False, "responsive": True},
            div_id="energy-planner-map",
        ).replace("<head>", f"<head><title>{_html.escape(self.title)}</title>", 1)

    def write(self, path: str | Path) -> Path:
        """Write :meth:`html` to ``path`` atomically; returns the path."""
        from energy_planner.io import write_text

        return write_text(path, self.html())


def route_hover(problem: Any, states: Any, name: str = "route") -> list[str]:
    """One hover text per vertex of a planned route: the segment that starts there.

    Energy, distance and duration per segment come from
    :meth:`energy_planner.problem.Problem.path_energy`'s per-segment table (the body
    yaw of ``states`` followed); the last vertex gives the totals. They are priced by the
    model's precompiled kernels where this machine has built them (as ``plan`` prices
    its path): the same code as numba's, without loading numba's kernels for a page.
    """
    from energy_planner.energy import path_energy

    states = np.asarray(states, dtype=float)
    if len(states) < 2:
        return ["start"] * len(states)
    cost = problem.gait_only().cost
    if not cost.ranged:
        cost.precompile(build=False)  # already built: loaded, never built for a page
    pe = path_energy(problem.terrain, problem.model, states[:, :2], yaw=states[:, 2],
                     cost=cost)  # fmt: skip
    tab = pe.table
    cum = np.concatenate([[0.0], np.cumsum(tab["energy_j"])])
    out = []
    for i in range(len(states) - 1):
        d = states[i + 1, :2] - states[i, :2]
        travel = math.degrees(math.atan2(d[1], d[0])) if np.hypot(*d) > 1e-9 else float("nan")
        dur = tab["duration_s"][i]
        speed = tab["distance_m"][i] / dur if dur > 0 else float("nan")
        out.append(
            "<br>".join([
                f"<b>{_html.escape(name)}</b> segment {i + 1} of {len(states) - 1}",
                f"energy {_fmt(tab['energy_j'][i], 'J', 1)} (so far {_fmt(cum[i], 'J')})",
                f"slope {_fmt(tab['mean_slope_deg'][i], '°', 1)}"
                f" (max {_fmt(tab['max_slope_deg'][i], '°', 1)})",
                f"travel heading {_fmt(travel, '°')} CCW from east",
                f"body yaw {_fmt(math.degrees(states[i, 2]), '°')}"
                f", relative to uphill {_fmt(tab['mean_rel_heading_deg'][i], '°')}",
                f"speed {_fmt(speed, 'm/s', 2)}, {_fmt(tab['distance_m'][i], 'm', 1)}"
                f" in {_fmt(dur, 's', 1)}",
            ])
        )  # fmt: skip
    out.append(f"<b>{_html.escape(name)}</b> end: {_fmt(pe.energy_j, 'J')} over "
               f"{_fmt(pe.distance_m, 'm', 1)} in {_fmt(pe.duration_s, 's')}")  # fmt: skip
    return out


def _start_goal(page: WebMap, start: Any, goal: Any) -> None:
    pts = np.array([start[:2], goal[:2]], dtype=float)
    page.add_points("start / goal", pts, ["start", "goal"],
                    [f"start ({start[0]:.0f}, {start[1]:.0f})",
                     f"goal ({goal[0]:.0f}, {goal[1]:.0f})"])  # fmt: skip


def plan_page(problem: Any, result: Any, path: str | Path, title: str | None = None) -> Path:
    """``plan --html``: the planned path with per-segment hover (a :class:`PlanResult`)."""
    page = WebMap(problem.terrain, title or f"Planned path: {result.energy_j:,.0f} J")
    page.add_route(f"planned {result.energy_j:,.0f} J", result.states[:, :2],
                   hover=route_hover(problem, result.states, "planned"))  # fmt: skip
    _start_goal(page, result.states[0], result.states[-1])
    return page.write(path)


def routes_page(problem: Any, comparison: Any, path: str | Path, title: str | None = None) -> Path:
    """``compare-routes --html``: every route of a :class:`RouteComparison`."""
    page = WebMap(problem.terrain, title or "Direct climb, shortest and energy-optimal routes")
    for r in comparison.routes:
        if r.states is None or len(r.states) < 2:
            continue
        label = f"{r.name}: {_fmt(r.energy_j, 'J')}" + ("" if r.feasible else " (infeasible)")
        page.add_route(label, r.states[:, :2], hover=route_hover(problem, r.states, r.name),
                       dash=None if r.feasible else "dot")  # fmt: skip
    _start_goal(page, comparison.start, comparison.goal)
    return page.write(path)


def reach_page(
    terrain: Any,
    reach: Any,
    path: str | Path,
    budget_j: float | None = None,
    chance: np.ndarray | None = None,
    title: str | None = None,
) -> Path:
    """``reach --html``: energy to every cell (Wh), the budget's contour, its chance."""
    what = "energy to go and come back" if reach.round_trip else "energy to reach"
    page = WebMap(terrain, title or "Battery reach" + (" (out and back)" if reach.round_trip
                                                       else ""))  # fmt: skip
    page.add_raster(what, reach.energy_j / 3600.0, "Wh")
    if chance is not None:
        page.add_raster("chance the battery suffices", 100.0 * np.asarray(chance), "%",
                        colorscale="RdYlGn", visible=False)  # fmt: skip
    if budget_j is not None:
        page.add_contour(reach.energy_j / 3600.0, budget_j / 3600.0,
                         f"budget {budget_j / 3600:.1f} Wh")  # fmt: skip
    page.add_points("start", [reach.start], ["start"],
                    [f"start ({reach.start[0]:.0f}, {reach.start[1]:.0f})"])  # fmt: skip
    return page.write(path)


def mission_page(
    problem: Any,
    mission: Any,
    path: str | Path,
    battery: dict[str, Any] | None = None,
    title: str | None = None,
) -> Path:
    """``mission --html``: the sites in visiting order and each leg with its energy.

    ``battery`` is the mission's battery decision (:meth:`MissionResult.battery_by_leg`): the
    chance after each leg is shown on that leg's hover.
    """
    sites = mission.sites
    page = WebMap(problem.terrain, title or f"Mission: {mission.energy_j:,.0f} J over "
                                            f"{len(mission.legs)} legs")  # fmt: skip
    rows = list((battery or {}).get("legs", []))
    for k, leg in enumerate(mission.legs):
        a, b = sites.names[leg.a], sites.names[leg.b]
        name = f"leg {k + 1}: {a} → {b}, {leg.energy_j:,.0f} J"
        hover = route_hover(problem, leg.states, f"leg {k + 1} {a} → {b}")
        if k < len(rows) and rows[k].get("probability") is not None:
            p = rows[k]["probability"]
            hover = [h + f"<br>chance the battery lasts to {b}: {100 * p:.1f} %"
                     for h in hover]  # fmt: skip
        page.add_route(name, leg.states[:, :2], hover=hover)
    visit = {s: i for i, s in enumerate(mission.order)}
    labels = [f"{visit[i] + 1}. {n}" if i in visit else n for i, n in enumerate(sites.names)]
    hovers = [f"{n} ({x:.0f}, {y:.0f})" for n, (x, y) in zip(sites.names, sites.xy, strict=True)]
    page.add_points("sites", sites.xy, labels, hovers)
    return page.write(path)


def follow_page(
    terrain: Any,
    path: str | Path,
    walked_xy: Any,
    updates: Sequence[Any],
    planned_xy: Any = None,
    title: str | None = None,
) -> Path:
    """``follow --html``: the planned path, the walked track and the follower's updates.

    Each update is a point on the track; hovering it shows the time, the energy used,
    the remaining energy with its interval and the battery chance.
    """
    page = WebMap(terrain, title or "Following a mission")
    if planned_xy is not None and len(planned_xy) > 1:
        page.add_route("planned path", planned_xy, color="#7f7f7f", dash="dash")
    walked = np.asarray(walked_xy, dtype=float)
    if len(walked) > 1:
        page.add_route("walked", walked, color="#1f77b4", width=2)
    pts, hover = [], []
    for u in updates:
        d = u.to_dict() if hasattr(u, "to_dict") else dict(u)
        if d.get("x") is None or d.get("y") is None:
            continue
        pts.append((d["x"], d["y"]))
        lo, hi = d.get("remaining_low_j"), d.get("remaining_high_j")
        band = f" [{_fmt(lo, 'J')} .. {_fmt(hi, 'J')}]" if lo is not None and hi is not None else ""
        chance = d.get("success_probability")
        hover.append("<br>".join([
            f"t = {_fmt(d.get('t'), 's', 1)}",
            f"energy used {_fmt(d.get('used_j'), 'J')}",
            f"remaining {_fmt(d.get('remaining_j'), 'J')}{band}",
            f"battery chance {100 * chance:.1f} %" if chance is not None else "no battery given",
        ]))  # fmt: skip
    if pts:
        page.add_points("updates", pts, [""] * len(pts), hover, color="#ff7f0e")
    return page.write(path)
