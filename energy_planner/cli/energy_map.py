"""``energy-planner energy-map``: J per metre of walking each way from every cell, as a GeoTIFF."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import click

from energy_planner.cli import options
from energy_planner.cli.options import (
    channels_from_options,
    gait_limits,
    load_model_option,
    parse_memory_cap,
)
from energy_planner.energymap.bands import BAND_SETS, DEFAULT_BANDS
from energy_planner.energymap.encoding import DEFAULT_ENCODING, ENCODINGS
from energy_planner.energymap.setup import DEFAULT_COMPRESS
from energy_planner.io.geotiff import COMPRESSIONS


def format_table(res: dict[str, Any]) -> str:
    """Human-readable summary of the written map."""
    s = res["stats"]
    lines = [
        f"wrote     {res['path']} ({res['shape'][0]} x {res['shape'][1]} cells, "
        f"{len(res['bands'])} bands, {res['crs']})",
        f"headings  {res['headings']} ({360 / res['headings']:g} deg apart, "
        + (
            "CCW from the DEM's local east)"
            if "local east" in res.get("heading_convention", "")
            else "CCW from east)"
        ),
        f"computed  {res['mode']} in {res['seconds']:.1f} s",
    ]
    c = s.get("cheapest_j_per_m")
    if c:
        lines.append(
            f"cheapest  {c['min']:.0f} .. {c['max']:.0f} J/m (median {c['median']:.0f}) "
            f"over {s['valid_cells']} valid cells"
            + (f" (sampled every {s['sampled_every']})" if s["sampled_every"] > 1 else "")
        )
    rng = res.get("speed_range_m_s")
    if rng:
        v = s.get("cheapest_speed_m_s")
        lines.append(
            f"speed     each cell and heading at its best speed within {rng[0]:g}-{rng[1]:g} m/s"
            + (f"; cheapest heading's {v['min']:.2f} .. {v['max']:.2f} m/s (median "
               f"{v['median']:.2f})" if v else "")
        )  # fmt: skip
    a = s.get("anisotropy")
    if a:
        lines.append(
            f"dearest/cheapest  median {a['median']:.2f}, p90 {a['p90']:.2f}, max {a['max']:.1f}"
        )
    if res.get("plot"):
        lines.append(f"plot      {res['plot']}")
    tail = 5 if rng else 4  # the summary bands (and the speed band)
    heads = "along_*, best_*" if len(res["bands"]) > res["headings"] + tail else "best_*"
    summary = ", ".join(b["name"] for b in res["bands"][-tail:])
    if len(res["bands"]) > tail:
        summary += f" after the {len(res['bands']) - tail} heading bands {heads} (J/m)"
    lines.append("bands     " + summary)
    for note in res.get("notes", []):
        lines.append(f"note: {note}")
    return "\n".join(lines)


@options.command(
    "energy-map",
    "energy-planner energy-map hill --out hill_energy.tif --plot hill.png",
    "energy-planner energy-map plane --out plane_speed.tif --model b1_speeds --speed auto",
)
@options.dem_argument
@options.path_option(
    "--out",
    required=True,
    help="Output GeoTIFF (one band per heading and gait, then the summary bands).",
)
@options.model_option
@options.value_option(
    "--headings",
    type=click.IntRange(1, 360),
    default=16,
    help="Number of map headings, 360/N degrees apart, the first east.",
)
@options.plan_speed_option
@options.gait_limit_options
@options.channel_options
@options.path_option(
    "--plot", help="Also draw the map (cheapest cost over a hillshade, arrows) to this PNG."
)
@options.html_option("The map's bands over the hillshade, with a band chooser.")
@options.band_option
@click.option(
    "--dask",
    "use_dask",
    is_flag=True,
    default=None,
    help="Compute out of core with dask (chunks of --chunk cells). Automatic when the "
    "DEM would not fit --memory-cap.",
)
@click.option(
    "--scheduler",
    default=None,
    metavar="ADDRESS",
    help="Run the dask path on this dask.distributed scheduler (e.g. tcp://host:8786); "
    "implies --dask. The workers must see the DEM, the output path and the kernel cache.",
)
@options.memory_cap_option(
    "the DEM may take in memory (64 bytes per cell, as load_dem counts) above which the "
    "map is computed out of core"
)
@options.value_option(
    "--chunk",
    type=click.IntRange(64, 16384),
    default=512,
    help="Chunk side (cells) of the out-of-core path.",
)
@click.option(
    "--compress",
    type=click.Choice(COMPRESSIONS, case_sensitive=False),
    default=DEFAULT_COMPRESS,
    show_default=True,
    help="Compression of the GeoTIFF: zstd writes 1.7x faster than deflate at the same size "
    "(GDAL >= 2.3 reads it); deflate reads everywhere; none writes fastest, 1.8x larger. "
    "Same values.",
)
@click.option(
    "--bands",
    type=click.Choice(BAND_SETS),
    default=DEFAULT_BANDS,
    show_default=True,
    help="Bands written: best (best_* per heading and the four summary bands), all "
    "(also along_*, walking facing each heading: 2N+4 float32 bands) or summary (the four "
    "summary bands: the cheapest heading and its cost, the dearest, their ratio; the "
    "fastest to write).",
)
@click.option(
    "--encoding",
    type=click.Choice(ENCODINGS),
    default=DEFAULT_ENCODING,
    show_default=True,
    help="How the bands are stored: uint16 (scaled integers with GDAL scale and offset, "
    "0.25 J/m steps, code 0 nodata, 65535 inf; a quarter of float32's bytes; a map with a "
    "cost above 16,383 J/m or an anisotropy above 64 falls back to float32) or float32 "
    "(the values as computed).",
)
@options.json_option
def command(
    dem: Path,
    out: Path,
    model_path: Path | None,
    headings: int,
    speed: Any,
    sets: tuple[str, ...],
    channels: tuple[str, ...],
    plot: Path | None,
    html: Path | None,
    band: int | None,
    use_dask: bool | None,
    scheduler: str | None,
    memory_cap: str | None,
    chunk: int,
    compress: str,
    bands: str,
    encoding: str,
    as_json: bool,
) -> None:
    """Heading-dependent energy map of DEM: J per metre of walking in each of N headings.

    For every cell: the cheapest way along each heading over the body yaws the gait
    limits allow, crabbing included (best_*), with --bands all also the cost of walking
    through it facing along each heading (along_*), the
    cheapest and dearest heading cost, their ratio and the cheapest heading. Same model
    physics as `energy` (a short straight motion through the cell centre, per metre of
    map distance). The map is on the DEM's grid and CRS: a DEM in a geographic CRS is
    computed on its UTM working grid and resampled back (bilinear), headings then CCW
    from the DEM's local east (the meridian convergence applied). With --speed MIN:MAX
    or auto, every cell, heading and body yaw walks at its own least-energy speed in the
    range (as plan's motions), and the band cheapest_speed gives the cheapest heading's.
    """
    from energy_planner.api import energy_map
    from energy_planner.errors import DEMError, DEMIOError, EnergyPlannerError

    cap = parse_memory_cap(memory_cap)
    model = load_model_option(model_path)
    ch = channels_from_options(sets, channels)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", UserWarning)
            res = energy_map(
                dem, out, model=model, headings=headings, speed=speed, **gait_limits(),
                channels=ch, band=band, use_dask=use_dask, client=scheduler,
                memory_cap=cap, chunk=chunk, compress=compress, bands=bands, encoding=encoding,
                progress=True,
            )  # fmt: skip
    except DEMIOError as exc:
        raise click.BadParameter(str(exc), param_hint="DEM") from exc
    except DEMError as exc:
        hint = "--band" if getattr(exc, "param", None) == "band" else "DEM"
        raise click.BadParameter(str(exc), param_hint=hint) from exc
    except EnergyPlannerError as exc:
        raise click.ClickException(str(exc)) from exc
    except (OSError, TimeoutError) as exc:
        if scheduler is None:
            raise
        raise click.BadParameter(
            f"cannot reach the dask scheduler {scheduler!r}: {exc}", param_hint="--scheduler"
        ) from exc
    result = res.to_dict()
    result["notes"] += [str(w.message) for w in caught if issubclass(w.category, UserWarning)]
    options.write_output(result, "plot", plot, res.plot)
    options.write_output(result, "html", html, res.write_html)
    options.emit(result, as_json, format_table)
