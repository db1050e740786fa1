"""``energy-planner compare-routes``: direct climb vs detour (the paper's Fig. 1)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from energy_planner.cli.options import (
    add_trust,
    channel_options,
    channels_from_options,
    dem_option,
    emit,
    examples,
    gait_limits,
    json_option,
    load_model_option,
    model_option,
    start_goal_options,
    trust_options,
)
from energy_planner.cli.plan import (
    check_planner,
    load_terrain,
    planning_error,
    planning_options,
    point_to_work,
)


def format_table(res: dict[str, Any]) -> str:
    """The comparison as a table (energy, Wh, distance, duration, max slope, saving).

    Below it, each priced route's prediction interval and, with a battery, its chance.
    """
    from energy_planner.cli.options import trust_lines
    from energy_planner.planning.compare import RouteComparison

    text = RouteComparison.from_dict(res).table()
    for r in res["routes"]:
        lines = trust_lines(r)
        if lines and r.get("same_as") is None:
            text += f"\n{r['name']}:\n  " + lines.replace("\n", "\n  ")
    if res.get("plot"):
        text += f"\nplot written to {res['plot']}"
    return text


@click.command(
    "compare-routes",
    epilog=examples(
        "energy-planner compare-routes --dem maps/hill.tif --start "
        "500058,5000046 --goal 500058,5000109 --max-slope 30 --plot routes.png",
        "energy-planner compare-routes --dem maps/hill.tif --start "
        "500058,5000046 --goal 500058,5000084 --battery-wh 30 --reserve-wh 2 "
        "--json",
    ),
)
@dem_option
@start_goal_options
@model_option
@planning_options("the energy-optimal route")
@channel_options
@trust_options
@click.option(
    "--plot",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="PNG: the three routes over a hillshade with heading marks.",
)
@json_option
def command(
    dem: Path,
    start: str,
    goal: str,
    model_path: Path | None,
    planner: str,
    time_s: float,
    seed: int,
    max_slope: float | None,
    max_cross_slope: float | None,
    keep_out: Path | None,
    speed: float,
    yaw_rate: float,
    sets: tuple[str, ...],
    channels: tuple[str, ...],
    level: float,
    battery_wh: float | None,
    reserve_wh: float,
    confidence: float,
    refuse: bool,
    plot: Path | None,
    as_json: bool,
) -> None:
    """Compare the direct line, the shortest feasible path and the energy-optimal path.

    Each route gets its energy (J, Wh), distance, duration, ascent, mean climbing grade,
    steepest slope and the energy saved against the direct line. A direct line that
    breaks a limit is reported as infeasible with the reason; a route that is the same
    path as an earlier one says so. Below the table: the model's critical grade (the
    grade at which a metre of height is cheapest), which explains the detour's saving,
    and each route's prediction interval (``--level``) and, with ``--battery-wh``, the
    chance that it fits in the battery (``--refuse`` judges the energy-optimal route).
    """
    from energy_planner.errors import EnergyPlannerError, InvalidStateError, MissingChannelError
    from energy_planner.planning.compare import compare_routes
    from energy_planner.problem import Problem
    from energy_planner.request import Request

    check_planner(planner)
    terrain = load_terrain(dem)
    model = load_model_option(model_path)
    s = point_to_work(terrain, start, "--start", True)
    g = point_to_work(terrain, goal, "--goal", True)
    try:
        request = Request.make(
            speed=speed, yaw_rate=yaw_rate, max_slope_deg=max_slope,
            max_cross_slope_deg=max_cross_slope, keep_out=keep_out,
            channels=channels_from_options(sets, channels), **gait_limits(),
        )  # fmt: skip
        comp = compare_routes(
            Problem(terrain, model, request), s, g, planner=planner, time=time_s, seed=seed,
            progress=True,
        )  # fmt: skip
    except InvalidStateError as exc:
        hint = "--start" if str(exc).startswith("start") else "--goal"
        raise click.BadParameter(str(exc), param_hint=hint) from exc
    except MissingChannelError as exc:
        raise click.BadParameter(str(exc), param_hint="--set/--channel") from exc
    except EnergyPlannerError as exc:
        raise planning_error(exc) from exc  # --keep-out errors name the option (exit 2)
    result = comp.to_dict(terrain)
    for r in result["routes"]:
        if r["energy_j"] is not None and r["feasible"]:
            add_trust(r, model, r["energy_j"], level, battery_wh, reserve_wh, confidence,
                      refuse and r["name"] == "energy_optimal", label=r["name"],
                      duration_s=r.get("duration_s"))  # fmt: skip
    if plot is not None:
        comp.plot(terrain, plot, request=request)
        result["plot"] = str(plot)
    emit(result, as_json, format_table)
