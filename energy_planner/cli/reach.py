"""``energy-planner reach``: how far the battery goes, from a start, over the whole map."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from energy_planner.cli import options
from energy_planner.cli.options import load_model_option, parse_memory_cap
from energy_planner.cli.plan import (
    load_terrain,
    over_memory_cap,
    planning_error,
    point_in_dem_crs,
    point_to_work,
)

if TYPE_CHECKING:
    from energy_planner.request import Request


def _text(res: dict[str, Any]) -> str:
    what = "go and come back" if res["round_trip"] else "reach"
    lines = [
        f"start        {res['start'][0]:.2f}, {res['start'][1]:.2f} (centre of its cell, DEM CRS)",
        f"energy to {what}: {res['min_wh']:.2f} .. {res['max_wh']:.2f} Wh over "
        f"{res['reachable_cells']} reachable cells (median {res['median_wh']:.2f} Wh)",
    ]
    b = res.get("battery")
    if b:
        what = "reach and come back" if res["round_trip"] else "reach"
        lines.append(
            f"battery      {b['battery_wh']:g} Wh - {b['reserve_wh']:g} Wh reserve: "
            f"{b['cells']} cells ({b['area_m2']:.0f} m^2) {what} with a chance of at least "
            f"{100 * b['confidence']:g} % (predicted energy <= {b['confident_budget_wh']:.2f} Wh)"
        )
        if b.get("refused_cells"):
            why = "; ".join(f"{k} ({n} cells)" for k, n in b["refused"].items())
            lines.append(f"             no battery decision for {b['refused_cells']} cells: {why}")
    if res.get("budget_wh") is not None:
        lines.append(
            f"within {res['budget_wh']:g} Wh: {res['budget_cells']} cells, "
            f"{res['budget_area_m2']:.0f} m^2"
        )
    lines += _domain_lines(res.get("domain"))
    for key, label in (("out", "GeoTIFF"), ("chance_out", "chance"), ("domain_out", "outside"),
                       ("geojson", "GeoJSON"), ("plot", "plot")):  # fmt: skip
        if res.get(key):
            lines.append(f"{label:<12} {res[key]}")
    w = res.get("window")
    if w:
        lines.append(
            f"window       DEM {w['dem_shape'][0]} x {w['dem_shape'][1]} read as a window of "
            f"{w['shape'][0]} x {w['shape'][1]} cells (radius {w['radius_m']:.0f} m, "
            f"c_min {w['c_min_j_per_m']:.1f} J/m); cells above the budget left nodata"
        )
    tb = res.get("time_bound")
    if tb:
        far = tb["least_time_max_s"]
        lines.append(
            f"within {tb['max_time_s']:g} s: the cells above (the farthest in "
            f"{'-' if far is None else f'{far:.0f}'} s, every motion at "
            f"{tb['top_speed_m_s']:g} m/s, turning at {tb['yaw_rate_rad_s']:g} rad/s)"
        )
    sp = res.get("speed")
    if sp:
        lo, hi = sp["speed_range"]
        lines.append(f"speed        each motion at its least-energy speed within {lo:g}-{hi:g} m/s")
    lines.append(f"search       {res['search']}, {res['time_s']:.1f} s")
    lines += [f"warning      {w}" for w in res.get("warnings", [])]
    return "\n".join(lines)


def _domain_lines(d: dict[str, Any] | None) -> list[str]:
    """The map's domain summary (``ReachMap.domain``) as text."""
    if not d or "reached_cells" not in d:
        return []
    lines = [
        f"domain       {d['outside_cells']} of {d['reached_cells']} reachable cells "
        f"({100 * d['outside_cell_share']:.0f} %) have a least-energy path leaving the "
        "calibration's ranges"
    ]
    lines += [f"             {why}: {n} cells" for why, n in d["reasons"].items() if n]
    wb = d.get("within_budget")
    if wb:
        lines.append(
            f"             within {wb['budget_wh']:g} Wh: {wb['outside_cells']} of "
            f"{wb['cells']} cells"
        )
    c = d.get("confident")
    if c:
        lines.append(
            f"             reached with a chance of at least {100 * c['confidence']:g} %: "
            f"{c['outside_cells']} of {c['cells']} cells (widened by their paths' domain)"
        )
    return lines


@options.command(
    "reach",
    "energy-planner reach hill --start 500058,5000046 --budget-wh 15 --within-budget "
    "--out reach.tif --geojson area.geojson --plot reach.png",
)
@options.dem_argument
@click.option("--start", required=True, help="Start X,Y in the DEM's CRS (or --points-crs).")
@options.points_crs_option
@click.option(
    "--budget-wh",
    type=click.FloatRange(min=0, min_open=True),
    help="Battery budget, Wh: the area reachable within it (GeoJSON, contour on the plot).",
)
@click.option(
    "--return",
    "round_trip",
    is_flag=True,
    help="Cost of going to each cell and coming back to the start.",
)
@click.option(
    "--within-budget",
    is_flag=True,
    help="Search only as far as --budget-wh (much faster on a large map); cells above the "
    "budget are nodata. Implied when the DEM is read as a window.",
)
@click.option(
    "--free-turn",
    is_flag=True,
    help="With --return: headings free at the cell (the sum of two `plan` calls with no "
    "yaw there); default: the robot keeps its heading and pays the turn round.",
)
@click.option(
    "--max-time",
    type=click.FloatRange(min=0, min_open=True),
    help="Seconds: only the cells some path reaches (and leaves, with --return) within this "
    "time, every motion at the top of --speed (MIN:MAX, or the fixed speed); the energies "
    "stay the least ones, each motion at its best speed with a range.",
)
@options.model_option
@options.ranged_request_options
@options.path_option(
    "--out", help="GeoTIFF of the least energy per cell (J), on the DEM's grid and CRS."
)
@options.path_option(
    "--geojson",
    help="GeoJSON polygon of the area reachable within --budget-wh, or with --battery-wh the "
    "area reached with a chance of at least --confidence (longitude, latitude; see "
    "--geojson-crs).",
)
@options.geojson_crs_option
@options.battery_options
@options.path_option(
    "--chance-out",
    help="With --battery-wh: GeoTIFF of the chance that each cell is reached (and left, with "
    "--return) on the usable battery.",
)
@options.path_option(
    "--domain-out",
    help="GeoTIFF of the share of each cell's least-energy path outside the model's "
    "calibration domain (0-1; needs a model that records its domain).",
)
@options.plot_option("PNG: energy over a hillshade with the budget contour.")
@options.html_option(
    "Energy to every cell over the hillshade, the budget contour (at "
    "--confidence with --battery-wh) and the battery chance."
)
@options.memory_cap_option(
    "the search may use (160 bytes per DEM cell); a larger DEM is read as one window about "
    "the start, of the radius the budget can reach (needs --budget-wh)"
)
@options.json_option
def command(
    dem: Path,
    start: str,
    budget_wh: float | None,
    round_trip: bool,
    within_budget: bool,
    free_turn: bool,
    model_path: Path | None,
    request: Request,
    out: Path | None,
    geojson: Path | None,
    geojson_crs: str,
    battery_wh: float | None,
    reserve_wh: float,
    confidence: float,
    chance_out: Path | None,
    domain_out: Path | None,
    plot: Path | None,
    html: Path | None,
    memory_cap: str | None,
    as_json: bool,
    max_time: float | None = None,
) -> None:
    """Least energy to reach every cell of DEM from --start (or to go and come back).

    Uses the planner's own search (same motion primitives and energy kernel as
    `plan`), at the DEM's cell size, any initial heading. A DEM too large for
    --memory-cap is read as one window about the start that provably holds every cell
    within --budget-wh (its radius: the budget over the least energy per metre anywhere on
    the DEM); the outputs then cover that window, and cells above the budget are nodata.
    With --within-budget (as in the example) the search stops at the budget: the same
    area within it, its search about a third of the whole map's on the bundled hill.
    """
    _check_options(free_turn, round_trip, within_budget, budget_wh, geojson, battery_wh,
                   chance_out, reserve_wh)  # fmt: skip
    cap = parse_memory_cap(memory_cap)
    windowed = over_memory_cap(dem, cap)
    if windowed and budget_wh is None:
        raise click.BadParameter(
            f"DEM {str(dem)!r} is too large for the memory cap to be searched whole; give "
            "--budget-wh to search only the window the budget can reach (or raise "
            "--memory-cap / ENERGY_PLANNER_MEMORY_CAP)",
            param_hint="--budget-wh",
        )
    model = load_model_option(model_path)
    from energy_planner.uncertainty.domain import domain_of

    if domain_out is not None and domain_of(model) is None:
        raise click.BadParameter("the model records no calibration domain (metadata.fit."
                                 "domain): no domain report to write; give a model that "
                                 "fit or discover wrote", param_hint="--domain-out")  # fmt: skip
    choice = {"max_time": max_time}
    if options.speed_choice() is not None:
        choice["speed"] = options.speed_choice()
    res = _run_reach(dem, start, model, request, cap, windowed, budget_wh, round_trip,
                     free_turn, within_budget, battery_wh, reserve_wh, confidence,
                     choice)  # fmt: skip
    result = {"dem": str(dem), **res.to_dict()}
    options.write_output(result, "chance_out", chance_out, res.write_chance_geotiff)
    options.write_output(result, "out", out, res.write_geotiff)
    options.write_output(result, "domain_out", domain_out, res.write_domain_geotiff)
    native = geojson_crs == "dem"
    options.write_output(result, "geojson", geojson,
                         lambda p: res.write_geojson(p, native=native))  # fmt: skip
    options.write_output(result, "plot", plot, res.plot)
    options.write_output(result, "html", html, res.write_html)
    options.emit(result, as_json, _text)


def _check_options(free_turn, round_trip, within_budget, budget_wh, geojson, battery_wh,
                   chance_out, reserve_wh) -> None:  # fmt: skip
    """``click.BadParameter`` for options that do not go together."""
    if free_turn and not round_trip:
        raise click.BadParameter("--free-turn applies to --return only", param_hint="--free-turn")
    if within_budget and budget_wh is None:
        raise click.BadParameter(
            "give --budget-wh with --within-budget", param_hint="--within-budget"
        )
    if geojson is not None and budget_wh is None and battery_wh is None:
        raise click.BadParameter(
            "--geojson writes the area within a budget: give --budget-wh (or --battery-wh for "
            "the area reached with the chance --confidence)",
            param_hint="--geojson",
        )
    if chance_out is not None and battery_wh is None:
        raise click.BadParameter("--chance-out needs --battery-wh", param_hint="--chance-out")
    if battery_wh is not None and not reserve_wh < battery_wh:
        raise click.BadParameter(
            f"the reserve ({reserve_wh:g} Wh) must be below the battery ({battery_wh:g} Wh)",
            param_hint="--reserve-wh",
        )


def _run_reach(dem, start, model, request, cap, windowed, budget_wh, round_trip, free_turn,
               within_budget, battery_wh, reserve_wh, confidence, choice):  # fmt: skip
    """The reach map (:func:`energy_planner.api.reach`): the DEM whole, or one window.

    Errors become ``click.BadParameter`` naming the option to change (exit 2).
    """
    import warnings

    from energy_planner.api import reach
    from energy_planner.errors import (
        DEMError,
        DEMIOError,
        EnergyPlannerError,
        InvalidStateError,
        MissingChannelError,
        RasterTooLargeError,
        ReachEdgeWarning,
    )
    from energy_planner.uncertainty import BatteryError

    if windowed:  # the library reads the window; the start in the DEM's CRS
        where, crs, s = dem, None, point_in_dem_crs(start, "--start", False)
    else:
        where = load_terrain(dem)
        crs, s = where.crs, point_to_work(where, start, "--start", False)[:2]
    try:
        with warnings.catch_warnings():  # the CLI reports the map's edge for each budget
            warnings.filterwarnings("ignore", category=ReachEdgeWarning)
            return reach(
                where, s, crs=crs, budget_wh=budget_wh, return_to_start=round_trip,
                within_budget=within_budget, free_turn=free_turn, model=model,
                request=request, battery_wh=battery_wh, reserve_wh=reserve_wh,
                confidence=confidence, memory_cap=cap, progress=True, **choice,
            )  # fmt: skip
    except RasterTooLargeError as exc:
        raise click.BadParameter(str(exc), param_hint="--budget-wh") from exc
    except (DEMError, DEMIOError) as exc:
        raise click.BadParameter(str(exc), param_hint="--dem") from exc
    except InvalidStateError as exc:
        raise click.BadParameter(str(exc), param_hint="--start") from exc
    except BatteryError as exc:
        raise click.BadParameter(str(exc), param_hint="--battery-wh") from exc
    except MissingChannelError as exc:
        raise click.BadParameter(str(exc), param_hint="--set/--channel") from exc
    except EnergyPlannerError as exc:
        raise planning_error(exc) from exc  # --keep-out errors name the option (exit 2)
