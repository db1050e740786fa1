"""``energy-planner terrain``: inspect a DEM, write slope/aspect rasters and a plot."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click
import numpy as np

from energy_planner.cli import options


def _resolve_dem(dem: str) -> Path:
    """A path, or the name of a bundled map (``hill``, ``plane``, ``jacksboro``)."""
    from energy_planner.maps import resolve

    return resolve(dem)


def _parse_bounds(value: str | None) -> tuple[float, float, float, float] | None:
    """``XMIN,YMIN,XMAX,YMAX`` -> a tuple (click.BadParameter otherwise)."""
    if value is None:
        return None
    try:
        vals = tuple(float(v) for v in value.split(","))
    except ValueError:
        vals = ()
    if len(vals) != 4:
        raise click.BadParameter(
            f"{value!r} is not XMIN,YMIN,XMAX,YMAX (four numbers in the DEM's CRS)",
            param_hint="'--bounds'",
        )
    return vals  # type: ignore[return-value]


def _load(dem: Path, band: int | None, bounds=None, decimate: int = 1):
    from energy_planner.errors import DEMError, DEMIOError, RasterTooLargeError
    from energy_planner.maps import map_names
    from energy_planner.terrain import load_dem

    try:
        return load_dem(dem, band=band, bounds=bounds, decimate=decimate)
    except DEMIOError as exc:
        raise click.BadParameter(
            f"{exc}. Give a raster file (GeoTIFF, ...) or a bundled map name: "
            f"{', '.join(map_names())}.",
            param_hint="'DEM'",
        ) from exc
    except RasterTooLargeError as exc:  # the message carries its own remedy
        raise click.ClickException(str(exc)) from exc
    except DEMError as exc:
        if exc.param in ("band", "bounds", "decimate"):
            raise click.BadParameter(str(exc), param_hint=f"'--{exc.param}'") from exc
        raise click.ClickException(f"{exc}. Hint: check the file's nodata value and CRS.") from exc


def _write(path: Path, data: np.ndarray, grid, name: str, description: str) -> None:
    """Write one band on ``grid`` (a :class:`~energy_planner.terrain.native.NativeGrid`)."""
    from energy_planner.io import write_geotiff

    write_geotiff(
        path, np.where(np.isfinite(data), data, np.nan), transform=grid.transform,
        crs=grid.crs, names=[name], units=["deg"], descriptions=[description],
        tags={"software": "energy_planner terrain"},
    )  # fmt: skip


def _plot(path: Path, terrain, title: str) -> None:
    """The slope over a hillshade on the DEM's own grid and CRS (as the rasters written)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from energy_planner.plotting import MapFrame

    frame = MapFrame(terrain)
    slope_deg = np.degrees(frame.grid.slope)
    extent = frame.extent
    fig, ax = plt.subplots(figsize=(7.5, 6.5), layout="constrained")
    ax.imshow(frame.hillshade(), cmap="gray", extent=extent, vmin=0, vmax=1)
    finite = slope_deg[np.isfinite(slope_deg)]
    vmax = float(np.percentile(finite, 99.5)) if finite.size else 1.0
    im = ax.imshow(slope_deg, cmap="magma_r", alpha=0.6, extent=extent, vmin=0, vmax=vmax)
    fig.colorbar(im, ax=ax, label="slope (deg, Horn)")
    frame.finish(ax)
    ax.set_title(title)
    from energy_planner.io import save_figure

    save_figure(fig, path, dpi=120)
    plt.close(fig)


def summarize(terrain) -> dict[str, Any]:
    """Summary numbers of a :class:`~energy_planner.terrain.Terrain` (for text and JSON).

    Slopes, elevations and shares are those of the DEM's own grid
    (:attr:`Terrain.native_grid`: Horn with geodesic spacing on a lon/lat grid), the
    grid the slope and aspect rasters are written on.
    """
    grid = terrain.native_grid
    slope_deg = np.degrees(grid.slope)
    finite = slope_deg[np.isfinite(slope_deg)]
    valid = np.isfinite(grid.elevation)
    z = grid.elevation[valid]

    def crs_str(c):
        return c.to_string() if c is not None else None

    cell_m = None
    if terrain.native is not None:  # Horn ran on the DEM's own (non-metric) grid
        from energy_planner.terrain.native import native_steps

        sx, sy = native_steps(grid.transform, grid.elevation.shape[0], grid.crs, grid.scale)
        sx, sy = np.abs(np.atleast_1d(sx)), np.abs(np.atleast_1d(sy))
        cell_m = [float(sx.min()), float(sx.max()), float(sy.min()), float(sy.max())]
    return {
        "path": str(terrain.path) if terrain.path else None,
        "crs": crs_str(terrain.source_crs),
        "working_crs": crs_str(terrain.crs),
        "reprojected": terrain.source_crs != terrain.crs,
        "source_shape": list(terrain.source_shape),
        "shape": list(terrain.shape),
        "resolution_m": list(terrain.resolution),
        "slope_grid": "source" if cell_m is not None else "working",
        "source_cell_m": cell_m,
        "bounds": list(terrain.bounds),
        "elevation_min": float(z.min()),
        "elevation_max": float(z.max()),
        "slope_min_deg": float(finite.min()) if finite.size else None,
        "slope_mean_deg": float(finite.mean()) if finite.size else None,
        "slope_max_deg": float(finite.max()) if finite.size else None,
        "nodata_share": float(1.0 - valid.mean()),
        "no_slope_share": float(1.0 - finite.size / slope_deg.size),
    }


def _text(r: dict[str, Any]) -> str:
    def f(v, fmt="{:.2f}"):
        return "-" if v is None else fmt.format(v)

    lines = [
        f"DEM            {r['path']}",
        f"CRS            {r['crs'] or 'none (local metres)'}",
        f"working CRS    {r['working_crs'] or 'none (local metres)'}"
        + ("  (reprojected)" if r["reprojected"] else ""),
        f"shape          {r['shape'][0]} x {r['shape'][1]} (source "
        f"{r['source_shape'][0]} x {r['source_shape'][1]})",
        f"resolution     {r['resolution_m'][0]:.3f} x {r['resolution_m'][1]:.3f} m",
    ]
    if r.get("source_cell_m"):
        x0, x1, y0, y1 = r["source_cell_m"]
        lines.append(
            f"slope grid     the DEM's own ({r['source_shape'][0]} x {r['source_shape'][1]}), "
            f"cells {x0:.1f}..{x1:.1f} x {y0:.1f}..{y1:.1f} m (geodesic)"
        )
    lines += [
        f"elevation      {f(r['elevation_min'])} .. {f(r['elevation_max'])} m",
        f"slope (deg)    min {f(r['slope_min_deg'])}  mean {f(r['slope_mean_deg'])}  "
        f"max {f(r['slope_max_deg'])}",
        f"nodata share   {r['nodata_share']:.2%} of cells "
        f"({r['no_slope_share']:.2%} without a slope: border and nodata neighbours)",
    ]
    lines += [f"wrote          {r[k]}" for k in ("slope_out", "aspect_out", "plot") if r.get(k)]
    return "\n".join(lines)


@options.command(
    "terrain",
    "energy-planner terrain hill --slope-out slope.tif --aspect-out aspect.tif",
    "energy-planner terrain jacksboro --plot jacksboro.png --json",
)
@click.argument("dem", metavar="DEM")
@options.band_option
@click.option(
    "--bounds",
    default=None,
    metavar="XMIN,YMIN,XMAX,YMAX",
    help="Read only this window, in the DEM's own CRS (for rasters too large to load whole).",
)
@options.value_option(
    "--decimate",
    type=click.IntRange(min=1),
    default=1,
    help="Read every N-th cell along each axis (each the average of N x N cells).",
)
@options.path_option("--slope-out", help="Write slope (degrees, float32, nodata NaN) as GeoTIFF.")
@options.path_option(
    "--aspect-out",
    help="Write GIS aspect (degrees clockwise from north, downslope; nodata NaN on flat "
    "and nodata cells, where gdaldem writes -9999) as GeoTIFF.",
)
@options.path_option("--plot", help="Write a PNG of the slope over a hillshade.")
@options.json_option
def command(
    dem: str,
    band: int | None,
    bounds: str | None,
    decimate: int,
    slope_out: Path | None,
    aspect_out: Path | None,
    plot: Path | None,
    as_json: bool,
) -> None:
    """Summarize a DEM: CRS, grid, metric resolution, slope statistics, nodata.

    DEM is any single-band raster rasterio opens (or a bundled map: hill, plane,
    jacksboro). Slopes are Horn's (as gdaldem), computed on the DEM's own grid and
    written on it: on a lon/lat DEM with each row's geodesic cell size, aspect from true
    north (the planners' UTM working grid takes its gradient from these values).

    A raster whose decoded size would pass the memory cap (ENERGY_PLANNER_MEMORY_CAP,
    default half the memory) is refused before reading; --bounds and --decimate read a
    part of it or a coarser grid.
    """
    path = _resolve_dem(dem)
    terrain = _load(path, band, _parse_bounds(bounds), decimate)
    result = summarize(terrain)
    grid = terrain.native_grid
    if slope_out is not None:
        _write(slope_out, np.degrees(grid.slope), grid, "slope", "slope angle, degrees")
        result["slope_out"] = str(slope_out)
    if aspect_out is not None:
        _write(aspect_out, grid.aspect_deg, grid, "aspect",
               "GIS aspect: downslope direction, degrees clockwise from north")  # fmt: skip
        result["aspect_out"] = str(aspect_out)
    if plot is not None:
        _plot(plot, terrain, f"Slope of {path.name}")
        result["plot"] = str(plot)
    options.emit(result, as_json, _text)
