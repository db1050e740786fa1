"""The picture of an energy map: cheapest cost over a hillshade, arrows for the way to go.

The colour is the cheapest heading's cost (J per map metre) laid over the DEM's hillshade;
an arrow at regularly spaced cells points along the cheapest heading where the direction
matters (anisotropy above a threshold), a dot where it does not. Large maps are read
decimated (at most ``max_side`` pixels on the longer side), so the plot costs the same
for a 4096 x 4096 map as for a small one.

The colour scale spans the 2nd to 98th percentile of the cheapest cost; when values lie
beyond it the colour bar shows arrows at those ends and says so ("colour scale clipped
at p2..p98: X..Y J/m"). Cells above a slope limit at every heading (inf in the map) are
shaded, raster channels named in the map's tags are contoured, and the axes name the
map's CRS (:mod:`energy_planner.plotting`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.errors import fmt_num

__all__ = ["plot_energy_map", "colour_scale"]


def _decimated_grid(src: Any, max_side: int) -> tuple[tuple[int, int], Any]:
    from affine import Affine

    scale = max(1.0, max(src.height, src.width) / max_side)
    shape = (max(1, round(src.height / scale)), max(1, round(src.width / scale)))
    t = src.transform @ Affine.scale(src.width / shape[1], src.height / shape[0])
    return shape, t


def _hillshade_on(dem: Any, shape: tuple[int, int], transform: Any, crs: Any) -> np.ndarray | None:
    """Hillshade of ``dem`` (path or Terrain) on the (decimated) map grid, or None."""
    import rasterio
    from rasterio.warp import Resampling, reproject

    from energy_planner.terrain.horn import hillshade

    z = np.full(shape, np.nan)
    if dem is None:
        return None
    if hasattr(dem, "elevation"):
        src_arr, src_t, src_crs = dem.elevation, dem.transform, dem.crs
        reproject(
            source=src_arr, destination=z, src_transform=src_t, src_crs=src_crs or crs,
            dst_transform=transform, dst_crs=crs or src_crs, src_nodata=np.nan,
            dst_nodata=np.nan, resampling=Resampling.average,
        )  # fmt: skip
    else:
        from energy_planner.maps import resolve

        with rasterio.open(resolve(dem)) as src:  # a file, or a bundled map's name
            reproject(
                source=rasterio.band(src, 1), destination=z, src_transform=src.transform,
                src_crs=src.crs or crs, src_nodata=src.nodata, dst_transform=transform,
                dst_crs=crs or src.crs, dst_nodata=np.nan, resampling=Resampling.average,
            )  # fmt: skip
    if not np.isfinite(z).any():
        return None
    if crs is not None and crs.is_geographic:  # geodesic Horn on the lon/lat grid
        from energy_planner.terrain.horn import shade
        from energy_planner.terrain.native import native_gradient

        return shade(*native_gradient(z, transform, crs))
    return hillshade(z, transform)


def colour_scale(values: np.ndarray) -> tuple[float, float, str]:
    """Colour limits of a map: its 2nd and 98th percentiles, and what they clip.

    Returns
    -------
    vmin, vmax : float
        The percentiles (0, 1 without finite values).
    extend : str
        matplotlib's colour bar ``extend``: ``"min"``, ``"max"`` or ``"both"`` for the
        ends where values lie beyond the scale, ``"neither"`` when nothing is clipped.

    Examples
    --------
    >>> colour_scale(np.arange(101.0))
    (2.0, 98.0, 'both')
    >>> colour_scale(np.array([5.0, 5.0, 5.0]))
    (5.0, 5.0, 'neither')
    """
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    if not values.size:
        return 0.0, 1.0, "neither"
    vmin, vmax = (float(v) for v in np.percentile(values, [2, 98]))
    low, high = bool(values.min() < vmin), bool(values.max() > vmax)
    return vmin, vmax, {(0, 0): "neither", (1, 0): "min", (0, 1): "max"}.get((low, high), "both")


def _limit_label(tags: dict[str, str]) -> str:
    """Legend text of the cells above a slope limit, from the map's tags."""
    parts = []
    for key, what, inv in (("max_slope_tan", "slope", math.atan),
                           ("max_cross_slope_sin", "cross slope", math.asin)):  # fmt: skip
        try:
            v = float(tags.get(key, "inf"))
        except ValueError:
            continue
        if math.isfinite(v):
            parts.append(f"{what} {math.degrees(inv(v)):.4g}\u00b0")
    return "above the slope limit at every heading" + (f" ({', '.join(parts)})" if parts else "")


def _channels_on(tags: dict[str, str], shape: tuple[int, int], transform: Any, crs: Any):
    """The map's raster channels (named in its ``channels`` tag) on the plot's grid."""
    import ast
    import warnings

    from energy_planner.energy.channels import ChannelRaster, Channels
    from energy_planner.errors import EnergyPlannerError

    try:
        desc = ast.literal_eval(tags.get("channels", "{}"))
        rasters = {
            r["name"]: ChannelRaster(
                r["name"], path=Path(r["raster"]), table=Path(r["table"]) if r["table"] else None
            )
            for r in desc.get("rasters", [])
            if r.get("raster")
        }
    except (ValueError, SyntaxError, KeyError, TypeError, AttributeError):
        return None
    if not rasters:
        return None
    try:
        return Channels(rasters=rasters).bind_grid(shape, transform, crs, default_crs=crs,
                                                   quiet=True)  # fmt: skip
    except EnergyPlannerError as exc:  # moved or deleted since the map was made
        warnings.warn(f"channel rasters of the map not drawn: {exc}", UserWarning, stacklevel=3)
        return None


def plot_energy_map(
    map_path: str | Path,
    png: str | Path,
    dem: Any = None,
    *,
    arrows: int = 24,
    anisotropy_min: float = 1.05,
    max_side: int = 900,
    title: str | None = None,
) -> Path:
    """Draw an energy map GeoTIFF (from :func:`energy_map`) to a PNG.

    Parameters
    ----------
    map_path : str or pathlib.Path
        The energy map.
    png : str or pathlib.Path
        Output image.
    dem : str, pathlib.Path or Terrain, optional
        The DEM, for the hillshade (resampled onto the map's grid).
    arrows : int
        Arrows along the longer side.
    anisotropy_min : float
        Arrows only where ``dearest / cheapest`` passes this (a dot elsewhere).
    max_side : int
        Pixels on the longer side the map is read at.
    title : str, optional
        Figure title.

    Returns
    -------
    pathlib.Path
        ``png``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import rasterio
    from rasterio.enums import Resampling

    from energy_planner.energymap.encoding import read_band

    with rasterio.open(map_path) as src:
        names = list(src.descriptions)
        shape, t = _decimated_grid(src, max_side)
        crs = src.crs

        def band(name: str, how: Any) -> np.ndarray:
            return read_band(src, names.index(name) + 1, out_shape=shape,
                             resampling=how).astype(float)  # fmt: skip

        cheap = band("cheapest", Resampling.average)
        # inf marks a cell above a slope limit at every heading (the map's nodata tag)
        blocked = np.isposinf(band("cheapest", Resampling.nearest))
        head = band("cheapest_heading_deg", Resampling.nearest)
        aniso = band("anisotropy", Resampling.nearest)
        tags = src.tags()
        # the map's tag (a --bands summary map has no best_* band to count)
        headings = int(tags.get("headings") or sum(n.startswith("best_") for n in names))
    rows, cols = shape
    left, top = t.c, t.f
    right, bottom = left + cols * t.a, top + rows * t.e
    extent = (left, right, bottom, top)
    shade = _hillshade_on(dem, shape, t, crs)
    aspect = rows / max(cols, 1)
    fig, ax = plt.subplots(figsize=(8.5, max(4.0, 7.5 * aspect)), dpi=120)
    if shade is not None:
        ax.imshow(shade, cmap="gray", extent=extent, vmin=0, vmax=1, interpolation="bilinear")
    finite = cheap[np.isfinite(cheap)]
    vmin, vmax, extend = colour_scale(finite)
    im = ax.imshow(
        np.ma.masked_invalid(cheap), cmap="viridis", extent=extent, vmin=vmin, vmax=vmax,
        alpha=0.6 if shade is not None else 1.0, interpolation="nearest",
    )  # fmt: skip
    cb = fig.colorbar(im, ax=ax, shrink=0.85, extend=extend)
    label = "cheapest cost, J per map metre"
    if extend != "neither":
        label += f"\ncolour scale clipped at p2..p98: {fmt_num(vmin, 4)}..{fmt_num(vmax, 4)} J/m"
    cb.set_label(label)
    from energy_planner.plotting import degree_aspect, draw_channels, draw_mask, label_map_axes

    draw_mask(ax, blocked, extent, _limit_label(tags))
    bound = _channels_on(tags, shape, t, crs)
    if bound is not None:
        draw_channels(ax, bound, shape, t)
    step = max(1, math.ceil(max(rows, cols) / arrows))
    rr, cc = np.mgrid[step // 2 : rows : step, step // 2 : cols : step]
    xs = left + (cc + 0.5) * t.a
    ys = top + (rr + 0.5) * t.e
    h = np.radians(head[rr, cc])
    a = aniso[rr, cc]
    ok = np.isfinite(h)
    directed = ok & (a > anisotropy_min)
    length = 0.8 * step * abs(t.a)
    # lon/lat map: a degree of longitude is cos(lat) of one of latitude on the ground
    kx = 1.0
    if crs is not None and crs.is_geographic:
        kx = degree_aspect(bottom, top)
        ax.set_aspect(kx)
    u, v = np.cos(h[directed]) * kx, np.sin(h[directed])
    norm = np.hypot(u, v)
    ax.quiver(
        xs[directed], ys[directed], u / norm, v / norm,
        angles="xy", scale_units="xy", scale=1.0 / length, pivot="middle", color="white",
        edgecolor="black", linewidth=0.6, width=0.004,
    )  # fmt: skip
    flat = ok & ~directed
    ax.plot(xs[flat], ys[flat], ".", color="white", markersize=2.5)
    ax.set_xlim(left, right)
    ax.set_ylim(bottom, top)
    label_map_axes(ax, crs)
    ax.ticklabel_format(useOffset=False, style="plain")  # coordinates, not "+5e6"
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="lower left", fontsize=7, framealpha=0.9)
    ax.set_title(
        title
        or f"Energy map ({headings} headings): colour = cheapest way through each cell;\n"
        f"arrows = cheapest direction where dearest/cheapest > {anisotropy_min:g}",
        fontsize=10,
    )
    fig.tight_layout()
    png = Path(png)
    from energy_planner.io import save_figure

    save_figure(fig, png)
    plt.close(fig)
    return png


def energy_map_page(map_path: str | Path, dem: Any, path: str | Path, title=None) -> Path:
    """``energy-map --html``: the map's bands over the hillshade, with a band chooser.

    One self-contained page (:class:`energy_planner.webmap.WebMap`).

    The summary bands (cheapest cost, the cheapest heading, anisotropy) and the cost
    walking each heading at its best body yaw (``best_*``) are offered; read decimated
    to :data:`MAX_SIDE` pixels.
    """
    import rasterio
    from rasterio.enums import Resampling

    from energy_planner.energymap.encoding import read_band
    from energy_planner.webmap import MAX_SIDE, WebMap

    with rasterio.open(map_path) as src:
        names = list(src.descriptions)
        shape, t = _decimated_grid(src, MAX_SIDE)
        shade = _hillshade_on(dem, shape, t, src.crs) if dem is not None else None
        page = WebMap.of_grid(title or f"Energy map {Path(map_path).name}", shade, t, shape,
                              src.crs)  # fmt: skip
        wanted = [("cheapest", "J/m", "Viridis"), ("cheapest_heading_deg", "° CCW from east",
                  "HSV"), ("anisotropy", "ratio", "Magma")]  # fmt: skip
        wanted += [(n, "J/m", "Viridis") for n in names if n.startswith("best_")]
        for n, unit, cs in wanted:
            if n not in names:
                continue
            how = Resampling.nearest if n == "cheapest_heading_deg" else Resampling.average
            i = names.index(n)
            v = read_band(src, i + 1, out_shape=shape, resampling=how).astype(float)
            v[~np.isfinite(v)] = np.nan
            label = {"cheapest": "cheapest cost", "cheapest_heading_deg": "cheapest heading"}.get(
                n, n.replace("best_", "heading ") + "°" if n.startswith("best_") else n
            )
            page.add_raster(label, v, unit, colorscale=cs, visible=n == "cheapest", transform=t)
    return page.write(path)
