"""What every map plot shares: axes that name their CRS, and the request drawn on the map.

The plots of ``plan``, ``compare-routes`` and ``demo``
(:meth:`energy_planner.planning.compare.RouteComparison.plot`), ``reach``
(:meth:`energy_planner.planning.reach.ReachMap.plot`), ``mission``
(:meth:`energy_planner.mission.MissionResult.plot`) and ``energy-map``
(:func:`energy_planner.energymap.plot_energy_map`) label their axes with the CRS they are
drawn in and draw in the DEM's own CRS (:class:`MapFrame`): a DEM in metres as it is
planned (``x (EPSG:32631, m)``), a longitude/latitude DEM (planned on a UTM working grid)
on its own grid in degrees (``longitude (EPSG:4326, deg)``), as a GIS shows it, with the
routes, sites and outlines converted from the working CRS. They draw what the command
was given:

- keep-out polygons (hatched red patches, ``gid="keep_out"``),
- the cells a slope limit forbids (a hatched mask, ``gid="slope_mask"``),
- channel rasters (contour lines, ``gid="channel:NAME"``: the boundaries between the
  categories of a categorical channel, a few levels of a numeric one).

Each drawn layer gets a legend entry. The artists carry their ``gid`` so that tests and
callers can find them.

The report and calibration figures (``diagnose --report``, ``discover --report``,
``figures``) are made with :func:`new_figure` and laid out with :func:`fit_layout`:
figures of their own, drawn by Agg, that neither import pyplot nor switch the caller's
backend, laid out once (for the resolution they are saved at) so that saving them draws
them once.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

__all__ = [
    "new_figure",
    "fit_layout",
    "MapFrame",
    "crs_label",
    "degree_aspect",
    "label_map_axes",
    "grid_extent",
    "draw_keep_out",
    "draw_mask",
    "draw_channels",
    "draw_request",
]

#: Colours of the overlays (distinct from the routes' blue, green and red).
KEEP_OUT_COLOR = "crimson"
MASK_COLOR = "orangered"
CHANNEL_COLORS = ("deepskyblue", "magenta", "gold", "lime")


def new_figure(
    nrows: int = 1, ncols: int = 1, *, cells: int | None = None, **subplots_kw: Any
) -> tuple[Any, Any]:
    """A figure of its own and its axes: ``plt.subplots`` without pyplot.

    The figure is a :class:`matplotlib.figure.Figure` with an Agg canvas: it is not
    registered with pyplot (no global figure manager, nothing to close, the caller's
    backend left as it is) and it saves and draws (``fig.savefig``,
    ``fig.canvas.buffer_rgba()``) on any machine, without a display.

    Parameters
    ----------
    nrows, ncols : int
        The grid of axes.
    cells : int, optional
        Axes in only the first ``cells`` cells of the grid, row by row (the others stay
        empty, as hidden axes would leave them, without making axes never drawn); they
        are returned as a list.
    **subplots_kw
        ``figsize`` and ``dpi`` go to the figure, the rest to
        :meth:`matplotlib.figure.Figure.subplots` (``squeeze``, ``sharey``,
        ``gridspec_kw``, ...; with ``cells``, ``gridspec_kw`` and ``subplot_kw`` only).

    Returns
    -------
    fig : matplotlib.figure.Figure
    axes : matplotlib.axes.Axes or numpy.ndarray of them
        As :func:`matplotlib.pyplot.subplots` returns them (a list with ``cells``).

    Examples
    --------
    >>> fig, (a, b) = new_figure(1, 2, figsize=(4, 2))
    >>> type(fig.canvas).__name__, fig.get_size_inches().tolist()
    ('FigureCanvasAgg', [4.0, 2.0])
    >>> fig, axes = new_figure(2, 3, cells=4)
    >>> len(fig.axes), axes[3].get_subplotspec().get_topmost_subplotspec().rowspan
    (4, range(1, 2))
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig_kw = {k: subplots_kw.pop(k) for k in ("figsize", "dpi") if k in subplots_kw}
    fig = Figure(**fig_kw)
    FigureCanvasAgg(fig)
    if cells is None:
        return fig, fig.subplots(nrows, ncols, **subplots_kw)
    grid = fig.add_gridspec(nrows, ncols, **subplots_kw.pop("gridspec_kw", {}))
    subplot_kw = subplots_kw.pop("subplot_kw", {})
    if subplots_kw:
        raise TypeError(f"new_figure(cells=...) takes no {', '.join(subplots_kw)}")
    return fig, [fig.add_subplot(grid[i // ncols, i % ncols], **subplot_kw) for i in range(cells)]


def fit_layout(fig: Any, dpi: float | None = None, **tight_kw: Any) -> Any:
    """Lay ``fig`` out as ``fig.tight_layout()`` does, leaving no layout engine behind.

    ``Figure.tight_layout`` leaves a placeholder layout engine on the figure, and
    ``savefig`` draws a figure with any layout engine twice (a pass without rendering,
    then the image). Laid out here (the tight layout engine run once, without a ``rect``
    as ``tight_layout`` runs it: one pass), the figure gets the same subplot parameters,
    has no engine and is drawn once when saved.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    dpi : float, optional
        The resolution the figure will be saved at: it is laid out on the text as drawn
        at that resolution (the figure's own dpi is left as it is). Saved at this dpi,
        the image is drawn on the renderer the layout measured its text with, whose text
        sizes are then already known. Default: the figure's dpi, as ``tight_layout``.
    **tight_kw
        ``pad``, ``h_pad``, ``w_pad``, ``rect``, as for ``tight_layout``.

    Returns
    -------
    matplotlib.figure.Figure
        ``fig``.

    Examples
    --------
    >>> fig, ax = new_figure(figsize=(3, 2))
    >>> default = fig.subplotpars.right
    >>> fit_layout(fig).get_layout_engine() is None, bool(fig.subplotpars.right > default)
    (True, True)
    >>> fit_layout(fig, dpi=80).dpi
    100.0
    """
    from matplotlib.layout_engine import TightLayoutEngine

    from energy_planner.io.atomic import layout_at_dpi

    tight_kw.setdefault("rect", None)  # as tight_layout: the engine's (0, 0, 1, 1) measures twice
    engine = TightLayoutEngine(**tight_kw)
    if dpi is None or dpi == fig.dpi:
        engine.execute(fig)
    else:
        layout_at_dpi(fig, engine, dpi)
    return fig


def crs_label(crs: Any) -> str:
    """Short name of a CRS for an axis label: its EPSG code, else its name.

    Examples
    --------
    >>> crs_label("EPSG:32631"), crs_label(None)
    ('EPSG:32631', 'no CRS, local grid')
    >>> crs_label("+proj=tmerc +lat_0=0 +lon_0=3 +k=1 +x_0=0 +y_0=0 +ellps=WGS84 +units=m")
    'unknown (Transverse Mercator)'
    """
    if crs is None:
        return "no CRS, local grid"
    from pyproj import CRS

    from energy_planner.io import crs_name

    try:
        c = CRS.from_user_input(crs if isinstance(crs, str) else crs.to_wkt())
    except Exception:  # noqa: BLE001 - any CRS pyproj cannot read: its own text
        return str(crs_name(crs))
    epsg = c.to_epsg()
    if epsg:
        return f"EPSG:{epsg}"
    method = getattr(getattr(c, "coordinate_operation", None), "method_name", None)
    return f"{c.name} ({method})" if method and method not in c.name else c.name


def label_map_axes(ax: Any, crs: Any) -> None:
    """``x (EPSG:n, m)`` / ``y (...)``, or longitude/latitude in degrees for a lon/lat CRS.

    The ticks are plain numbers (no offset, no exponent) and few enough along x that
    seven-digit projected coordinates do not overlap.
    """
    from matplotlib.ticker import MaxNLocator, ScalarFormatter

    name = crs_label(crs)
    geographic = bool(getattr(crs, "is_geographic", False))
    if geographic:
        ax.set_xlabel(f"longitude ({name}, deg)")
        ax.set_ylabel(f"latitude ({name}, deg)")
    else:
        unit = _linear_unit(crs)
        ax.set_xlabel(f"x ({name}, {unit})")
        ax.set_ylabel(f"y ({name}, {unit})")
    for axis, bins in ((ax.xaxis, 4), (ax.yaxis, 6)):
        fmt = ScalarFormatter(useOffset=False)
        fmt.set_scientific(False)
        axis.set_major_formatter(fmt)
        axis.set_major_locator(MaxNLocator(bins, steps=[1, 2, 2.5, 5, 10]))


def _linear_unit(crs: Any) -> str:
    """``m``, or the name of a projected CRS's other linear unit (``US survey foot``)."""
    unit = str(getattr(crs, "linear_units", "") or "metre")
    return "m" if unit.lower() in ("metre", "meter", "m", "unknown") else unit


def grid_extent(shape: tuple[int, int], transform: Any) -> tuple[float, float, float, float]:
    """``(left, right, bottom, top)`` of a north-up grid, for ``imshow(extent=...)``."""
    rows, cols = shape
    left, top = transform.c, transform.f
    return (left, left + cols * transform.a, top + rows * transform.e, top)


def degree_aspect(bottom: float, top: float) -> float:
    """Axes aspect of a lon/lat map between two latitudes: ``1 / cos`` of their middle.

    A degree of longitude is ``cos(latitude)`` of a degree of latitude on the ground;
    drawn so, the map keeps the ground's shape.

    Examples
    --------
    >>> round(degree_aspect(59.0, 61.0), 12)
    2.0
    """
    return 1.0 / max(math.cos(math.radians(0.5 * (bottom + top))), 1e-6)


@dataclass(frozen=True, eq=False)
class MapFrame:
    """Where a map of a terrain is drawn: the DEM's own CRS and grid.

    A DEM planned on its own grid (projected, in metres) is drawn on it, exactly as it is
    planned. A DEM the planner works on in another CRS (a longitude/latitude DEM, planned
    on a UTM grid) is drawn on its own grid (:attr:`Terrain.native_grid
    <energy_planner.terrain.Terrain.native_grid>`, what ``terrain`` writes): its
    hillshade and slope from the geodesic Horn gradient, the working grid's rasters
    resampled onto it (nearest cell), the working CRS's points converted with
    :meth:`Terrain.from_work <energy_planner.terrain.Terrain.from_work>`, and a degree of
    longitude drawn ``cos(latitude)`` of a degree of latitude (the aspect
    ``1 / cos(lat)`` at the grid's middle), so that the map keeps the ground's shape.

    Parameters
    ----------
    terrain : Terrain
        The terrain the plot draws (its working grid, its source CRS and grid).

    Examples
    --------
    >>> from energy_planner.terrain import Terrain
    >>> f = MapFrame(Terrain.from_function(lambda x, y: 0 * x, size=(4, 3)))
    >>> f.reprojected, f.aspect, f.extent
    (False, 1.0, (0.0, 4.0, 0.0, 3.0))
    """

    terrain: Any

    @property
    def reprojected(self) -> bool:
        """True when the DEM's own grid is not the working grid (a lon/lat DEM)."""
        return getattr(self.terrain, "native", None) is not None

    @cached_property
    def grid(self) -> Any:
        """The grid drawn: the DEM's own (:class:`~energy_planner.terrain.native.NativeGrid`)."""
        return self.terrain.native_grid

    @property
    def crs(self) -> Any:
        """The CRS drawn in: the DEM's own."""
        return self.grid.crs

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)`` of the drawn grid."""
        return tuple(np.shape(self.grid.elevation))  # type: ignore[return-value]

    @property
    def geographic(self) -> bool:
        """True for a longitude/latitude CRS (axes in degrees)."""
        return bool(getattr(self.crs, "is_geographic", False))

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """``(left, right, bottom, top)`` of the drawn grid (:func:`grid_extent`)."""
        return grid_extent(self.shape, self.grid.transform)

    @property
    def aspect(self) -> float:
        """y/x scale of the axes: 1, or ``1 / cos(lat)`` at the grid's middle in degrees."""
        if not self.geographic:
            return 1.0
        left, right, bottom, top = self.extent
        return degree_aspect(bottom, top)

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """1-D cell-centre coordinates ``(x of each column, y of each row)``."""
        t = self.grid.transform
        rows, cols = self.shape
        return t.c + t.a * (np.arange(cols) + 0.5), t.f + t.e * (np.arange(rows) + 0.5)

    def hillshade(self) -> np.ndarray:
        """Hillshade in [0, 1] of the drawn grid."""
        if not self.reprojected:
            return self.terrain.hillshade()
        return self.grid.hillshade()

    def slope_deg(self) -> np.ndarray:
        """Slope of the drawn grid, degrees (Horn; geodesic on a lon/lat grid)."""
        if not self.reprojected:
            return np.degrees(self.terrain.slope)
        return np.degrees(self.grid.slope)

    def xy(self, x: Any, y: Any) -> tuple[np.ndarray, np.ndarray]:
        """Working-CRS coordinates in the drawn CRS (unchanged when not reprojected)."""
        if not self.reprojected:
            return np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        u, v = self.terrain.from_work(x, y)
        return np.asarray(u, dtype=float), np.asarray(v, dtype=float)

    def geometry(self, geom: Any) -> Any:
        """A shapely geometry of the working CRS in the drawn CRS."""
        if not self.reprojected:
            return geom
        from shapely.ops import transform

        return transform(lambda x, y, z=None: self.xy(x, y), geom)

    def raster(self, values: np.ndarray) -> np.ndarray:
        """A working-grid raster on the drawn grid (nearest cell; NaN outside the map)."""
        v = np.asarray(values, dtype=float)
        if not self.reprojected:
            return v
        from rasterio.warp import Resampling, reproject

        out = np.full(self.shape, np.nan)
        t = self.terrain
        reproject(
            source=v, destination=out, src_transform=t.transform, src_crs=t.crs,
            dst_transform=self.grid.transform, dst_crs=self.crs, src_nodata=np.nan,
            dst_nodata=np.nan, resampling=Resampling.nearest,
        )  # fmt: skip
        return out

    def directions(
        self, x: np.ndarray, y: np.ndarray, heading: np.ndarray, step: float = 1.0
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Points and unit arrows of headings (radians CCW from the working x axis).

        Returns ``(x, y, u, v)`` in the drawn CRS, ``(u, v)`` as the axes show them
        (:attr:`aspect` applied), for ``quiver``. ``step``: working metres between a point
        and the one along its heading that turns the direction.
        """
        c, s = np.cos(heading), np.sin(heading)
        if not self.reprojected:
            return np.asarray(x), np.asarray(y), c, s
        px, py = self.xy(x, y)
        qx, qy = self.xy(np.asarray(x) + step * c, np.asarray(y) + step * s)
        u, v = (qx - px) / self.aspect, qy - py
        n = np.hypot(u, v)
        n[n == 0] = 1.0
        return px, py, u / n, v / n

    def view(self, box: Sequence[float]) -> tuple[float, float, float, float]:
        """A working-CRS ``(left, right, bottom, top)`` as drawn, clipped to :attr:`extent`."""
        if not self.reprojected:
            return tuple(float(b) for b in box)  # type: ignore[return-value]
        left, right, bottom, top = box
        k = np.linspace(0.0, 1.0, 21)
        xs = np.r_[left + (right - left) * k, np.full(21, right),
                   right - (right - left) * k, np.full(21, left)]  # fmt: skip
        ys = np.r_[np.full(21, bottom), bottom + (top - bottom) * k,
                   np.full(21, top), top - (top - bottom) * k]  # fmt: skip
        u, v = self.xy(xs, ys)
        e = self.extent
        return (max(e[0], float(u.min())), min(e[1], float(u.max())),
                max(e[2], float(v.min())), min(e[3], float(v.max())))  # fmt: skip

    def finish(self, ax: Any) -> None:
        """Label the axes in the drawn CRS (:func:`label_map_axes`) and set the aspect."""
        ax.set_aspect(self.aspect if self.geographic else "equal")
        label_map_axes(ax, self.crs)


def _patch_path(geom: Any):
    """A matplotlib Path of a shapely (Multi)Polygon, holes included."""
    from matplotlib.path import Path as MplPath

    polys = list(getattr(geom, "geoms", [geom]))
    verts, codes = [], []
    for p in polys:
        if p.geom_type != "Polygon" or p.is_empty:
            continue
        for ring in (p.exterior, *p.interiors):
            xy = np.asarray(ring.coords)[:, :2]
            verts.append(xy)
            codes += [MplPath.MOVETO] + [MplPath.LINETO] * (len(xy) - 2) + [MplPath.CLOSEPOLY]
    if not verts:
        return None
    return MplPath(np.vstack(verts), codes)


def draw_keep_out(ax: Any, geoms: Sequence[Any], label: str = "keep-out") -> list[Any]:
    """Draw keep-out polygons (in the axes' coordinates) as hatched patches.

    Returns
    -------
    list of matplotlib.patches.PathPatch
        One per polygon, ``gid="keep_out"``; the first carries the legend label.
    """
    from matplotlib.patches import PathPatch

    out = []
    for g in geoms:
        path = _patch_path(g)
        if path is None:
            continue
        patch = PathPatch(
            path, facecolor=KEEP_OUT_COLOR, edgecolor=KEEP_OUT_COLOR, alpha=0.35, hatch="xx",
            lw=1.5, zorder=3, label=label if not out else None,
        )  # fmt: skip
        patch.set_gid("keep_out")
        ax.add_patch(patch)
        out.append(patch)
    return out


def draw_mask(ax: Any, mask: np.ndarray, extent: Sequence[float], label: str) -> Any | None:
    """Shade the True cells of ``mask`` (a grid with ``extent``); None if none is True.

    Returns
    -------
    matplotlib.image.AxesImage or None
        ``gid="slope_mask"``; its array is masked where ``mask`` is False.
    """
    from matplotlib.colors import ListedColormap

    mask = np.asarray(mask, dtype=bool)
    if not mask.any():
        return None
    img = ax.imshow(
        np.ma.masked_where(~mask, np.ones(mask.shape)), cmap=ListedColormap([MASK_COLOR]),
        extent=tuple(extent), origin="upper", alpha=0.45, interpolation="nearest", zorder=2,
        vmin=0, vmax=1,
    )  # fmt: skip
    img.set_gid("slope_mask")
    ax.fill([], [], color=MASK_COLOR, alpha=0.45, label=label)  # the legend entry
    return img


def draw_channels(ax: Any, channels: Any, shape: tuple[int, int], transform: Any) -> dict[str, Any]:
    """Contour the raster channels (bound to the grid ``shape, transform``).

    A categorical channel: the boundaries between its categories; a numeric one: five
    levels between its 5th and 95th percentiles, labelled.

    Returns
    -------
    dict
        Channel name -> its ``ContourSet`` (``gid="channel:NAME"``).
    """
    out: dict[str, Any] = {}
    rows, cols = shape
    xc = transform.c + transform.a * (np.arange(cols) + 0.5)
    yc = transform.f + transform.e * (np.arange(rows) + 0.5)
    for k, (name, r) in enumerate(channels.rasters.items()):
        v = np.asarray(r.values, dtype=float)
        if v.shape != (rows, cols) or not np.isfinite(v).any():
            continue
        color = CHANNEL_COLORS[k % len(CHANNEL_COLORS)]
        finite = v[np.isfinite(v)]
        if r.categories is not None:
            present = np.unique(finite)
            levels = [c + 0.5 for c in present[:-1]]
            what = f"{name}: category boundaries ({', '.join(r.categories)})"
        else:
            lo, hi = np.percentile(finite, [5, 95])
            levels = list(np.linspace(lo, hi, 5)) if hi > lo else []
            what = f"{name}: contours"
        if not levels:
            continue
        cs = ax.contour(xc, yc, np.where(np.isfinite(v), v, np.nan), levels=levels,
                        colors=color, linewidths=1.3, linestyles="--", zorder=3)  # fmt: skip
        cs.set_gid(f"channel:{name}")
        if r.categories is None:
            ax.clabel(cs, fontsize=6, fmt="%.3g")
        ax.plot([], [], color=color, ls="--", label=what)  # the legend entry
        out[name] = cs
    return out


def draw_request(ax: Any, terrain: Any, request: Any = None) -> list[str]:
    """Draw a request's keep-outs, slope-limit mask and channel rasters over ``terrain``.

    The axes are in the DEM's own CRS (:class:`MapFrame`; ``terrain`` may be one).
    Keep-outs are read as the planner reads them
    (:func:`energy_planner.keepout.keep_out_geometries`; a polygon off the map was
    already reported by the command, and is not drawn); the mask shades the working
    cells steeper than ``max_slope_deg`` (those the planner forbids); channels are bound
    to the drawn grid.

    Returns
    -------
    list of str
        What was drawn: ``"keep_out"``, ``"slope_mask"``, ``"channel:NAME"``.
    """
    if request is None:
        return []
    from energy_planner.keepout import keep_out_geometries

    frame = terrain if isinstance(terrain, MapFrame) else MapFrame(terrain)
    terrain = frame.terrain
    drawn: list[str] = []
    lim = request.limits
    if lim.keep_out is not None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            geoms = keep_out_geometries(lim.keep_out, terrain)
        if draw_keep_out(ax, [frame.geometry(g) for g in geoms]):
            drawn.append("keep_out")
    if lim.max_slope_deg is not None:
        with np.errstate(invalid="ignore"):
            steep = frame.raster(np.degrees(terrain.slope) > lim.max_slope_deg) > 0.5
        label = f"steeper than {lim.max_slope_deg:g}\u00b0 (slope limit)"
        if draw_mask(ax, steep, frame.extent, label) is not None:
            drawn.append("slope_mask")
    ch = request.channels
    if ch is not None and ch.rasters:
        shape, transform = frame.shape, frame.grid.transform
        bound = ch.bind_grid(
            shape, transform, frame.crs,
            default_crs=getattr(terrain, "source_crs", None), quiet=True,
        )  # fmt: skip
        drawn += [f"channel:{n}" for n in draw_channels(ax, bound, shape, transform)]
    return drawn
