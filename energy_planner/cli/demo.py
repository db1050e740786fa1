"""``energy-planner demo``: the main job on a bundled map, end to end."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from energy_planner.cli import options


def _limits_text(res: dict[str, Any]) -> str:
    """The demo's limits in words: the slope limit and the gait limits given."""
    lim = res.get("limits") or {}
    words = [
        f"{what} {lim[key]:g} deg"
        for key, what in (
            ("max_slope_deg", "max slope"),
            ("max_backward_slope_deg", "no backward walking above"),
            ("max_crab_deg", "max crab angle"),
        )
        if lim.get(key) is not None
    ]
    return ", ".join(words) or "none (the detour must pay by physics alone)"


def _text(comp: Any, res: dict[str, Any]) -> str:
    head = [
        f"scenario   {res['scenario']}: {res['description']}",
        f"map        {res['map']}",
        f"model      {res['model']}",
        f"start      {res['start'][0]:.1f}, {res['start'][1]:.1f}    goal  "
        f"{res['goal'][0]:.1f}, {res['goal'][1]:.1f}  ({res['crs']})",
        "limits     " + _limits_text(res),
        "",
    ]
    tail = [
        "",
        "Next: energy-planner compare-routes --dem DEM --start X,Y --goal X,Y (your map),",
        "      energy-planner simulate / fit / diagnose (calibrate your robot from its logs).",
    ]
    table = comp.table() + (f"\nplot written to {res['plot']}" if res.get("plot") else "")
    return "\n".join(head) + table + "\n" + "\n".join(tail)


@options.command(
    "demo", "energy-planner demo", "energy-planner demo --max-slope 25 --plot demo25.png"
)
@options.value_option(
    "--scenario",
    "scenario_name",
    default="hill",
    help="Bundled scenario (maps/scenarios.json): hill, hill_crossing, plane.",
)
@options.model_option
@click.option(
    "--max-slope",
    type=click.FloatRange(min=0, max=89),
    default=None,
    help="A slope limit, degrees (a B1-class quadruped: about 25). Default: none, as in "
    "the paper's Fig. 1: the detour must pay by the model's physics alone.",
)
@options.value_option(
    "--time",
    "time_s",
    type=click.FloatRange(min=0, min_open=True),
    default=5.0,
    help="Planning budget of the energy-optimal route, seconds.",
)
@options.value_option(
    "--plot",
    type=click.Path(dir_okay=False, path_type=Path),
    default=Path("energy-planner-demo.png"),
    help="PNG of the routes over a hillshade.",
)
@click.option(
    "--speeds",
    "speeds",
    is_flag=True,
    help="The routes at the fixed 0.3 m/s, at their best speed and gait, and under a "
    "deadline (--deadline, default 0.9 x the best plan's duration), with what body yaw, "
    "route, speed and gait each save; model default: the bundled b1_speeds. No plot.",
)
@options.value_option(
    "--deadline",
    type=click.FloatRange(min=0, min_open=True),
    default=None,
    help="With --speeds: the deadline, seconds.",
)
@options.gait_limit_options
@options.channel_options
@options.json_option
def command(
    scenario_name: str,
    model_path: Path | None,
    max_slope: float | None,
    time_s: float,
    plot: Path,
    speeds: bool,
    deadline: float | None,
    sets: tuple[str, ...],
    channels: tuple[str, ...],
    as_json: bool,
) -> None:
    """Compare the direct climb, the shortest and the energy-optimal path on a bundled map.

    The map is the paper's Fig. 1 hill by default; prints the table and draws the routes.

    Below the table: the model's critical grade (where a metre of height is cheapest)
    and each route's climbing grade, which say why the longer route costs less.

    With --speeds: each route at the fixed speed, at its best speed and gait, and under a
    deadline, and the saving split into body yaw, route, speed and gait
    (energy_planner.planning.scene.speed_scene; --json prints its to_dict()).
    """
    from energy_planner.errors import MissingChannelError
    from energy_planner.maps import map_path, scenario, scenario_names
    from energy_planner.planning.compare import compare_routes
    from energy_planner.problem import Problem
    from energy_planner.request import Request
    from energy_planner.terrain import load_dem

    try:
        sc = scenario(scenario_name)
    except KeyError as exc:
        raise click.BadParameter(
            f"no scenario {scenario_name!r}; valid: {', '.join(scenario_names())}",
            param_hint="--scenario",
        ) from exc
    if deadline is not None and not speeds:
        raise click.BadParameter("--deadline needs --speeds", param_hint="--deadline")
    model = options.load_model_option(Path("b1_speeds") if speeds and model_path is None
                                      else model_path)  # fmt: skip
    terrain = load_dem(map_path(sc["map"]))
    start = terrain.to_work(*sc["start"])
    goal = terrain.to_work(*sc["goal"])
    request = Request.make(
        max_slope_deg=max_slope,
        channels=options.channels_from_options(sets, channels),
        **options.gait_limits(),
    )
    if speeds:
        _speeds(Problem(terrain, model, request), start, goal, deadline, time_s, as_json)
        return
    try:
        comp = compare_routes(Problem(terrain, model, request), start, goal, time=time_s,
                              progress=True)  # fmt: skip
    except MissingChannelError as exc:
        raise click.BadParameter(str(exc), param_hint="--set/--channel") from exc
    res = comp.to_dict()  # the comparison remembers its terrain and request
    comp.plot(plot, title=f"energy-planner demo: {scenario_name}")
    res.update(
        scenario=scenario_name,
        description=sc["description"],
        map=str(map_path(sc["map"])),
        crs=sc["crs"],
        start=sc["start"],
        goal=sc["goal"],
        max_slope_deg=max_slope,
        model=str(model_path) if model_path else "bundled B1-class default",
        plot=str(plot),
    )
    options.emit(res, as_json, lambda r: _text(comp, r))


def _speeds(problem, start, goal, deadline, time_s, as_json) -> None:
    """``demo --speeds``: :func:`energy_planner.planning.scene.speed_scene`, printed."""
    from energy_planner.errors import EnergyPlannerError
    from energy_planner.planning.scene import speed_scene

    try:
        scene = speed_scene(problem, start, goal, deadline=deadline, time=time_s, progress=True)
    except EnergyPlannerError as exc:
        raise click.ClickException(str(exc)) from exc
    options.emit(scene.to_dict(), as_json, lambda _: scene.table())
