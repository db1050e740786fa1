"""What every map plot shares: axes that name their CRS, and the request drawn on the map.

The plots of ``plan``, ``compare-routes`` and ``demo``
(:meth:`energy_planner.planning.compare.RouteComparison.plot`), ``reach``
(:meth:`energy_planner.planning.reach.ReachMap.plot`), ``mission``
(:meth:`energy_planner.mission.MissionResult.plot`) and ``energy-map``
(:func:`energy_planner.energymap.plot_energy_map`) label their axes with the CRS they are
drawn in (``x (EPSG:32631, m)``; a lon/lat DEM is planned on a UTM working grid, and
that grid's CRS is named) and draw what the command was given:

- keep-out polygons (hatched red patches, ``gid="keep_out"``),
- the cells a slope limit forbids (a hatched mask, ``gid="slope_mask"``),
- channel rasters (contour lines, ``gid="channel:NAME"``: the boundaries between the
  categories of a categorical channel, a few levels of a numeric one).

Each drawn layer gets a legend entry. The artists carry their ``gid`` so that tests and
callers can find them.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = [
    "crs_label",
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
        ax.set_xlabel(f"x ({name}, m)")
        ax.set_ylabel(f"y ({name}, m)")
    for axis, bins in ((ax.xaxis, 4), (ax.yaxis, 6)):
        fmt = ScalarFormatter(useOffset=False)
        fmt.set_scientific(False)
        axis.set_major_formatter(fmt)
        axis.set_major_locator(MaxNLocator(bins, steps=[1, 2, 2.5, 5, 10]))


def grid_extent(shape: tuple[int, int], transform: Any) -> tuple[float, float, float, float]:
    """``(left, right, bottom, top)`` of a north-up grid, for ``imshow(extent=...)``."""
    rows, cols = shape
    left, top = transform.c, transform.f
    return (left, left + cols * transform.a, top + rows * transform.e, top)


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

    The axes are in the terrain's working CRS. Keep-outs are read as the planner reads
    them (:func:`energy_planner.keepout.keep_out_geometries`; a polygon off the
    map was already reported by the command, and is not drawn); the mask shades the
    cells steeper than ``max_slope_deg``; channels are bound to the working grid.

    Returns
    -------
    list of str
        What was drawn: ``"keep_out"``, ``"slope_mask"``, ``"channel:NAME"``.
    """
    if request is None:
        return []
    from energy_planner.keepout import keep_out_geometries

    drawn: list[str] = []
    lim = request.limits
    if lim.keep_out is not None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            geoms = keep_out_geometries(lim.keep_out, terrain)
        if draw_keep_out(ax, geoms):
            drawn.append("keep_out")
    extent = grid_extent(terrain.shape, terrain.transform)
    if lim.max_slope_deg is not None:
        with np.errstate(invalid="ignore"):
            steep = np.degrees(terrain.slope) > lim.max_slope_deg
        label = f"steeper than {lim.max_slope_deg:g}\u00b0 (slope limit)"
        if draw_mask(ax, steep, extent, label) is not None:
            drawn.append("slope_mask")
    ch = request.channels
    if ch is not None and ch.rasters:
        bound = ch.bind_grid(
            terrain.shape, terrain.transform, terrain.crs,
            default_crs=getattr(terrain, "source_crs", None), quiet=True,
        )  # fmt: skip
        drawn += [
            f"channel:{n}" for n in draw_channels(ax, bound, terrain.shape, terrain.transform)
        ]
    return drawn
