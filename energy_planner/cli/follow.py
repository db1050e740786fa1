"""``energy-planner follow``: replay a log against a plan and follow its remaining energy."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from energy_planner.cli.options import (
    battery_options,
    channel_options,
    dem_option,
    emit,
    examples,
    html_option,
    json_option,
    level_option,
    load_model_option,
    model_option,
    speed_option,
    write_output,
    yaw_rate_option,
)


def _text(res: dict[str, Any]) -> str:
    lines = [
        f"{'t s':>7} {'done m':>7} {'remaining J':>12} {'low J':>9} {'high J':>9} "
        f"{'static J':>9} {'chance':>7}"
    ]
    timed = res.get("deadline_s") is not None
    if timed:
        lines[0] += f" {'slack s':>8} {'keep m/s':>8}"
    for u in res["updates"]:
        p = u["success_probability"]
        lines.append(
            f"{u['t']:>7.0f} {u['distance_m']:>7.1f} {u['remaining_j']:>12.0f} "
            f"{u['remaining_low_j']:>9.0f} {u['remaining_high_j']:>9.0f} "
            f"{u['static_remaining_j']:>9.0f} {'-' if p is None else f'{100 * p:.0f}%':>7}"
        )
        if timed:
            lines[-1] += f" {u['deadline_slack_s']:>8.0f} {u['speed_to_keep_m_s']:>8.2f}"
    if timed:
        lines.append(
            f"deadline {res['deadline_s']:g} s from the log's start: slack, the time left once "
            "the rest is walked at the plan's pace; keep, the mean speed that arrives in time"
        )
    lines.append(
        "remaining: the rest of the path priced with the updated coefficients, its "
        f"calibrated bias taken out; low/high: {100 * res['level']:g} % interval; static: "
        "the fit's coefficients"
    )
    for f in res["slope_findings"]:
        off = f.get("gradient_offset_deg")
        grad = "" if off is None else f", the ground's gradient off by {off:.1f} deg"
        lines.append(
            f"slope    the IMU measures {f['imu_slope_deg']:.1f} deg where the DEM gives "
            f"{f['dem_slope_deg']:.1f} deg ({f['difference_deg']:+.1f} deg{grad}, beyond "
            f"the sensors' {f['threshold_deg']:.1f} deg) from ({f['from'][0]:.1f}, "
            f"{f['from'][1]:.1f}) to ({f['to'][0]:.1f}, {f['to'][1]:.1f}), "
            f"t {f['t_start']:.0f}-{f['t_end']:.0f} s"
        )
    for e in res["events"]:
        if not e.startswith("slope:"):
            lines.append(f"event    {e}")
    for n in res["notes"]:
        lines.append(f"note     {n}")
    return "\n".join(lines)


@click.command(
    "follow",
    epilog=examples(
        "energy-planner follow missions/mission_000.csv --dem hill --battery-wh 40 --reserve-wh 5",
    ),
)
@click.argument("log", type=click.Path(exists=True, path_type=Path))
@dem_option
@click.option(
    "--path",
    "path_file",
    default=None,
    type=click.Path(dir_okay=False, path_type=Path),
    help="The plan's path (the project's GeoJSON path format, as plan --out writes it; "
    "or CSV waypoints in the DEM's CRS). Default: the poses the log walked (a replay).",
)
@model_option
@battery_options
@level_option
@click.option(
    "--scores",
    "scores_file",
    default=None,
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    help="The follower's calibrated remaining-energy errors (JSON of "
    "RemainingScores.save, e.g. benchmarks/bench_follow.py --save-scores): the interval is "
    "split-conformal on them. Default: the bundled scores with the bundled model (as "
    "ep.Follower); with another model and no --scores, the model's run-error interval "
    "widened (said in the notes).",
)
@click.option("--run", default=None, help="The run to follow when LOG holds several.")
@click.option(
    "--speedup",
    type=click.FloatRange(min=0, min_open=True),
    default=None,
    help="Replay at this many times real time (default: as fast as it goes).",
)
@click.option(
    "--forgetting",
    type=click.FloatRange(0.5, 1.0),
    default=0.99,
    show_default=True,
    help="Forgetting factor of the online update, per 2 s window.",
)
@click.option("--no-replan", is_flag=True, help="Report a low chance of success but do not replan.")
@click.option(
    "--deadline",
    type=click.FloatRange(min=0, min_open=True),
    help="Seconds from the log's start by which the robot must reach the path's end: each "
    "update says whether the rest still fits at the plan's pace (slack) and the mean speed "
    "that arrives in time; losing it is an event.",
)
@channel_options
@speed_option
@yaw_rate_option
@html_option("The path, the walked poses and each update's remaining energy.")
@json_option
def command(
    log: Path,
    dem: Path,
    path_file: Path,
    model_path: Path | None,
    battery_wh: float | None,
    reserve_wh: float,
    confidence: float,
    level: float,
    scores_file: Path | None,
    run: str | None,
    speedup: float | None,
    forgetting: float,
    no_replan: bool,
    sets: tuple[str, ...],
    channels: tuple[str, ...],
    speed: float,
    yaw_rate: float,
    html: Path | None,
    as_json: bool,
    deadline: float | None = None,
) -> None:
    """Replay LOG (a robot log) against the plan in --path and follow the rest of it.

    Per 2 s window of the log: the IMU's slope against the DEM's (a disagreement beyond
    the sensors' noise is reported with its place), the model's coefficients updated by
    recursive least squares with forgetting, and the energy of the rest of the path with
    its interval and, with --battery-wh, the chance that the battery suffices. Below
    --confidence it replans from the current pose and says so.

    """
    from energy_planner.cli.energy import load_terrain
    from energy_planner.cli.options import channels_from_options
    from energy_planner.energy.waypoints import read_waypoints
    from energy_planner.errors import (
        EnergyPlannerError,
        LogError,
        LogIOError,
        WaypointError,
        WaypointIOError,
    )
    from energy_planner.follow import FollowError, RemainingScores, follow_log, walked_path
    from energy_planner.measurements import load_logs

    if battery_wh is not None and not reserve_wh < battery_wh:
        raise click.BadParameter(
            f"--reserve-wh {reserve_wh:g} must be below --battery-wh {battery_wh:g}",
            param_hint="--reserve-wh",
        )
    terrain = load_terrain(dem, None)
    model = load_model_option(model_path)
    ch = channels_from_options(sets, channels)
    try:
        # default: the library's (the bundled scores with the bundled model)
        scores = "auto" if scores_file is None else RemainingScores.load(scores_file)
    except FollowError as exc:
        raise click.BadParameter(str(exc), param_hint="--scores") from exc
    try:
        samples = load_logs(log)
    except (LogError, LogIOError) as exc:
        raise click.ClickException(f"{log}: {exc}") from exc
    try:
        wp = walked_path(samples, run) if path_file is None else read_waypoints(path_file)
    except (WaypointError, WaypointIOError) as exc:
        raise click.BadParameter(str(exc), param_hint="--path") from exc
    except LogError as exc:  # no pose in the log (measurements.poses)
        raise click.ClickException(f"{log}: {exc}") from exc
    try:
        f = follow_log(
            terrain,
            model,
            samples,
            wp,
            run=run,
            speedup=speedup,
            channels=ch,
            remaining_scores=scores,
            battery_wh=battery_wh,
            reserve_wh=reserve_wh,
            confidence=confidence,
            level=level,
            forgetting=forgetting,
            replan=not no_replan,
            speed=speed,
            yaw_rate=yaw_rate,
            deadline=deadline,
        )
    except FollowError as exc:
        raise click.ClickException(f"{log}: {exc}") from exc
    except EnergyPlannerError as exc:
        raise click.ClickException(str(exc)) from exc
    out = f.to_dict()
    walked = "the log's own poses"
    out.update({"log": str(log), "dem": str(dem),
                "path": walked if path_file is None else str(path_file)})  # fmt: skip
    write_output(out, "html", html, f.write_html)
    emit(out, as_json, _text)
