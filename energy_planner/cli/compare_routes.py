"""``energy-planner compare-routes``: direct climb vs detour (the paper's Fig. 1)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from energy_planner.cli import options
from energy_planner.cli.options import load_model_option
from energy_planner.cli.plan import load_terrain, planning_error, point_to_work

if TYPE_CHECKING:
    from energy_planner.request import Request


def format_table(comp: Any, res: dict[str, Any]) -> str:
    """The comparison as a table (energy, Wh, distance, duration, max slope, saving).

    Below it, each priced route's own assessment: its prediction interval, domain and,
    with a battery, its chance.
    """
    text = comp.table()
    for r in comp.routes:
        if r.assessment is not None and r.same_as is None:
            text += f"\n{r.name}:\n  " + r.assessment.text().replace("\n", "\n  ")
    if res.get("plot"):
        text += f"\nplot written to {res['plot']}"
    if res.get("bag"):
        text += f"\nROS 2 bag written to {res['bag']}"
    return text


@options.command(
    "compare-routes",
    "energy-planner compare-routes --dem hill --start "
    "500058,5000046 --goal 500058,5000109 --max-slope 30 --plot routes.png",
    "energy-planner compare-routes --dem hill --start "
    "500058,5000046 --goal 500058,5000084 --battery-wh 30 --reserve-wh 2 "
    "--json",
)
@options.with_request
@options.dem_option
@options.start_goal_options
@options.model_option
@options.planning_options("the energy-optimal route", speed_range=True)
@click.option(
    "--deadline",
    type=click.FloatRange(min=0, min_open=True),
    help="Seconds: each route walked at the least-energy speed profile that arrives in "
    "time, and the energy-optimal route the least-energy one in time (the plan under the "
    "deadline among them: a deadline may favour the direct climb); speeds within --speed "
    "MIN:MAX (default auto).",
)
@click.option(
    "--pareto",
    type=click.IntRange(min=2),
    help="N points of each route's energy-time front (energy + lambda x time swept over "
    "lambda; the energy-optimal route planned per lambda), each with its energy interval, "
    "duration and speed profile; --plot draws the fronts; speeds within --speed (default "
    "auto).",
)
@options.channel_options
@options.trust_options
@options.plot_option("PNG: the three routes over a hillshade with heading marks.")
@options.html_option("The routes over the hillshade; hover a vertex for its segment.")
@options.bag_options
@options.json_option
def command(
    dem: Path,
    start: str,
    goal: str,
    model_path: Path | None,
    search: dict[str, Any],
    request: Request,
    trust: options.Trust,
    plot: Path | None,
    html: Path | None,
    bag: Path | None,
    bag_frame: str,
    as_json: bool,
    deadline: float | None = None,
    pareto: int | None = None,
) -> None:
    """Compare the direct line, the shortest feasible path and the energy-optimal path.

    Each route gets its energy (J, Wh), distance, duration, ascent, mean climbing grade,
    steepest slope and the energy saved against the direct line. A direct line that
    breaks a limit is reported as infeasible with the reason; a route that is the same
    path as an earlier one says so. Below the table: the model's critical grade (the
    grade at which a metre of height is cheapest), which explains the detour's saving,
    and each route's prediction interval (``--level``) and, with ``--battery-wh``, the
    chance that it fits in the battery (``--refuse`` judges the energy-optimal route).

    With ``--speed MIN:MAX`` (or ``auto``) every route walks each motion at its own
    least-energy speed; ``--deadline`` walks each at the least-energy timing that arrives
    in time and names the least-energy route in time; ``--pareto N`` adds each route's
    energy-time front (``--plot`` then draws the fronts).
    """
    from energy_planner.api import compare_routes
    from energy_planner.cli.plan import _xy_yaw
    from energy_planner.errors import EnergyPlannerError, InvalidStateError, MissingChannelError
    from energy_planner.uncertainty import BatteryError

    terrain = load_terrain(dem)
    model = load_model_option(model_path)
    s = _xy_yaw(point_to_work(terrain, start, "--start", True))
    g = _xy_yaw(point_to_work(terrain, goal, "--goal", True))
    if deadline is not None and pareto is not None:
        raise click.BadParameter("give --pareto or --deadline, not both", param_hint="--pareto")
    speed = options.speed_choice()
    choice: dict[str, Any] = {} if speed is None else {"speed": speed}
    try:
        comp = compare_routes(terrain, s, g, crs=terrain.crs, model=model, request=request,
                              **search, **choice, deadline=deadline, pareto=pareto,
                              level=trust.level, battery_wh=trust.battery_wh,
                              reserve_wh=trust.reserve_wh, confidence=trust.confidence,
                              progress=True)  # fmt: skip
    except BatteryError as exc:
        raise click.BadParameter(str(exc), param_hint="--battery-wh/--reserve-wh") from exc
    except InvalidStateError as exc:
        hint = "--start" if str(exc).startswith("start") else "--goal"
        raise click.BadParameter(str(exc), param_hint=hint) from exc
    except MissingChannelError as exc:
        raise click.BadParameter(str(exc), param_hint="--set/--channel") from exc
    except EnergyPlannerError as exc:
        raise planning_error(exc) from exc  # --keep-out errors name the option (exit 2)
    result = comp.to_dict()
    for r in comp.routes:
        options.judge(r, trust, label=r.name, judged=r.name == "energy_optimal")
    options.write_output(result, "plot", plot, comp.plot_fronts if comp.fronts else comp.plot)
    options.write_output(result, "html", html, comp.write_html)
    options.write_bag_output(result, bag, lambda p: comp.write_bag(p, frame=bag_frame))
    options.emit(result, as_json, lambda res: format_table(comp, res))
