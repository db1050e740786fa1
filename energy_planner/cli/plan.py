"""``energy-planner plan``: an energy-minimal SE(2) path over a DEM."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from energy_planner.cli import options
from energy_planner.cli.options import load_model_option, parse_memory_cap

if TYPE_CHECKING:
    from energy_planner.request import Request


def load_terrain(dem: Path) -> Any:
    """Load ``--dem``; DEM errors become ``click.BadParameter``."""
    from energy_planner.errors import DEMError, DEMIOError
    from energy_planner.terrain import load_dem

    try:
        return load_dem(dem)
    except (DEMIOError, DEMError) as exc:
        raise click.BadParameter(str(exc), param_hint="--dem") from exc


def point_to_work(terrain: Any, value: str, hint: str, with_yaw: bool) -> tuple:
    """``X,Y[,YAW_DEG]`` in the DEM's CRS -> ``(x, y, yaw_rad | None)`` in the working CRS."""
    from energy_planner.errors import CoordinateError, OutsideMapError

    p = options.parse_point(value, hint, with_yaw=with_yaw)
    if options.points_crs() is not None and terrain.crs is not None:
        return _reproject_point(p, terrain.crs, hint, terrain.source_bounds, terrain.source_crs)
    try:
        x, y = terrain.to_work(p[0], p[1])
    except (CoordinateError, OutsideMapError) as exc:
        raise click.BadParameter(str(exc), param_hint=hint) from exc
    yaw = math.radians(p[2]) if len(p) == 3 else None
    return (float(x), float(y), yaw)


def _reproject_point(p: tuple, dst: Any, hint: str, bounds: Any, dem_crs: Any) -> tuple:
    """A point given in ``--points-crs`` -> ``(x, y, yaw_rad | None)`` in CRS ``dst``."""
    from energy_planner.errors import extent_text
    from energy_planner.io import reproject_xy, x_axis_angle

    src = options.points_crs()
    x, y = (float(v[0]) for v in reproject_xy(src, dst, [p[0]], [p[1]]))
    if not (math.isfinite(x) and math.isfinite(y)):
        raise click.BadParameter(
            f"({p[0]:.10g}, {p[1]:.10g}) is not a position in {src} (--points-crs); the map "
            f"covers {extent_text(bounds, dem_crs)}",
            param_hint=hint,
        )
    yaw = None
    if len(p) == 3:
        yaw = math.radians(p[2]) + float(x_axis_angle(src, dst, [p[0]], [p[1]])[0])
    return (x, y, yaw)


def over_memory_cap(dem: Path, cap: int | None) -> bool:
    """True if planning on the whole of ``dem`` would pass the memory cap.

    The library decides: :func:`energy_planner.planning.corridor.needs_windows`.
    """
    from energy_planner.planning.corridor import needs_windows

    return needs_windows(dem, cap)


def point_in_dem_crs(value: str, hint: str, with_yaw: bool) -> tuple:
    """``X,Y[,YAW_DEG]`` as ``(x, y[, yaw_rad])`` in the DEM's own (projected) CRS."""
    p = options.parse_point(value, hint, with_yaw=with_yaw)
    if options.points_crs() is not None:  # the DEM's CRS from its header
        import rasterio

        dem = click.get_current_context().params.get("dem")
        with rasterio.open(dem) as src:
            crs, b = src.crs, src.bounds
        if crs is not None:
            x, y, yaw = _reproject_point(p, crs, hint, (b.left, b.bottom, b.right, b.top), crs)
            return (x, y, yaw) if with_yaw and yaw is not None else (x, y)
    return (p[0], p[1], math.radians(p[2])) if len(p) == 3 else (p[0], p[1])


def planning_error(exc: Exception, lighter: str = "") -> click.ClickException:
    """A planning error as a click exception, by its structured fields.

    ``lighter``: the command's options that make the search lighter (``"--step"``,
    ``"--eps"``), named when the time budget runs out, besides ``--time``.
    """
    from energy_planner.errors import CoordinateError, InvalidStateError

    if getattr(exc, "limit", None) == "time" and getattr(exc, "stage", None):
        what = exc.stage
        done = f" after {exc.expanded} states expanded" if getattr(exc, "expanded", None) else ""
        more = f", or make the search lighter with {lighter}" if lighter else ""
        return click.ClickException(
            f"the planning time budget ran out in the {what}{done}: give more --time{more}"
        )

    endpoint = getattr(exc, "endpoint", None)
    if isinstance(exc, InvalidStateError | CoordinateError) and endpoint in ("start", "goal"):
        return click.BadParameter(str(exc), param_hint=f"--{endpoint}")
    param = getattr(exc, "param", None)
    if param == "keep_out":
        return click.BadParameter(str(exc), param_hint="--keep-out")
    return click.ClickException(str(exc))


def plan_context(terrain: Any, request: Any, model: Any, model_path: Path | None) -> dict:
    """What a plan's JSON needs to be read alone: CRSs, limits and the model's id."""
    from energy_planner.io import content_id, crs_name

    lim, robot = request.limits, request.robot
    ko = lim.keep_out
    return {
        "crs": {
            "waypoints": crs_name(terrain.source_crs),
            "dem": crs_name(terrain.source_crs),
            "working_grid": crs_name(terrain.crs),
        },
        "limits": {
            "max_slope_deg": lim.max_slope_deg,
            "max_cross_slope_deg": lim.max_cross_slope_deg,
            "max_backward_slope_deg": lim.max_backward_slope_deg,
            "max_crab_deg": lim.max_crab_deg,
            "keep_out": None if ko is None else str(ko) if isinstance(ko, str | Path) else len(ko),
            "speed_m_s": robot.speed,
            "yaw_rate_rad_s": robot.yaw_rate,
        },
        "model": {
            "id": content_id(model.to_dict()),
            "source": "default" if model_path is None else str(model_path),
        },
    }


def _emit_front(front, terrain, request, model, model_path, plot, as_json) -> None:
    """Print (and with --plot draw) the energy-time front of ``plan --pareto``."""
    result = front.to_dict(terrain)
    result.update(plan_context(terrain, request, model, model_path))
    options.write_output(result, "plot", plot, front.plot)
    options.emit(result, as_json, lambda r: front.text())


def format_table(res: dict[str, Any]) -> str:
    """Human-readable summary."""
    lines = [
        f"planner   {res['planner']} ({res['time_s']:.1f} s)",
        f"energy    {res['energy_j']:.1f} J ({res['energy_j'] / 3600:.3f} Wh)",
        f"distance  {res['distance_m']:.1f} m",
        f"duration  {res['duration_s']:.0f} s",
        f"waypoints {len(res['waypoints'])} (x, y in the DEM's CRS, yaw deg CCW from x):",
    ]
    for w in res["waypoints"]:
        # degrees (a geographic DEM) to 6 decimals, metres to 2
        nd = 6 if max(abs(w["x"]), abs(w["y"])) <= 360 else 2
        lines.append(f"  {w['x']:>16.{nd}f} {w['y']:>16.{nd}f} {w['yaw_deg']:>8.1f}")
    prof = [p["speed_m_s"] for p in res.get("speed_profile", []) if p["speed_m_s"] > 0]
    if prof:
        sp = res.get("speed", {})
        lo, hi = sp.get("speed_range") or (min(prof), max(prof))
        lines.insert(4, f"speed     {min(prof):.2f}-{max(prof):.2f} m/s chosen per motion "
                        f"within {lo:g}-{hi:g} m/s ({sp.get('speed_law', '')})")  # fmt: skip
    d = res.get("deadline")
    if d:
        lines.insert(4, f"deadline  {d['deadline_s']:g} s met (lambda {d['lambda_j_per_s']:.1f} "
                        f"J/s after {len(d['plans'])} plans)")  # fmt: skip
    c = res.get("corridor")
    if c:
        last = c["windows"][-1]["shape"]
        lines.append(
            f"corridor  DEM {c['dem_shape'][0]} x {c['dem_shape'][1]} read by windows "
            f"({len(c['windows'])}, the last {last[0]} x {last[1]} cells): "
            + (
                "proven to hold every cheaper path"
                if c["proven"]
                else "NOT proven: a path leaving the window might be cheaper"
            )
        )
    if res.get("stay_in_domain") is not None:
        notes = "; ".join(res["stay_in_domain"]) or "the request was already inside"
        lines.append(f"in domain {notes}")
    lines += options.written_lines(res, {"out": "path", "plot": "plot", "bag": "ROS 2 bag"})
    return "\n".join(lines)


@options.command(
    "plan",
    "energy-planner plan --dem hill --start 500058,5000046 --goal "
    "500058,5000109 --max-slope 30 --out path.geojson --plot path.png",
)
@options.with_request
@options.dem_option
@options.start_goal_options
@options.model_option
@options.planning_options("the path", time_default=None, speed_range=True)
@click.option(
    "--deadline",
    type=click.FloatRange(min=0, min_open=True),
    help="Seconds: the least-energy path that arrives in time, route and each motion's speed "
    "chosen together (minimises energy + lambda x time, lambda by bisection); speeds within "
    "--speed MIN:MAX (default auto). An error gives the fastest path's time when none can.",
)
@click.option(
    "--pareto",
    type=click.IntRange(min=2),
    help="Plan N points of the energy-time front (a sweep of lambda in energy + lambda x "
    "time: the front's convex hull), each with its energy interval, duration and speed "
    "profile; --plot draws the front; speeds within --speed (default auto).",
)
@click.option(
    "--step",
    type=click.FloatRange(min=0, min_open=True),
    help="Position spacing of the search, metres (default: the DEM's cell size).",
)
@click.option(
    "--eps",
    type=click.FloatRange(min=1.0),
    help="Heuristic weight of the search: its energy is at most EPS times the optimum on "
    "its motion primitives (default 1.05; 1 = optimal, slower).",
)
@options.channel_options
@options.memory_cap_option(
    "planning may use (160 bytes per DEM cell); a larger DEM is planned by windows: a "
    "corridor about the start and the goal, proven to hold every cheaper path or reported "
    "as not proven"
)
@options.path_option(
    "--out",
    help="Write the path as a GeoJSON LineString (yaw_deg per vertex; longitude, latitude "
    "unless --geojson-crs dem).",
)
@options.geojson_crs_option
@options.bag_options
@options.trust_options
@options.plot_option("PNG plot.")
@options.html_option("The path over the hillshade; hover a vertex for its segment.")
@click.option(
    "--stay-in-domain",
    is_flag=True,
    default=False,
    help="Keep the plan inside the model's calibration domain (its metadata.fit.domain): "
    "--max-slope at most the steepest calibration window; no sideways (--max-crab 45) or "
    "backward walking on slopes when the logs had none; raster channel cells outside the "
    "recorded values impassable; --speed and --yaw-rate clamped to the recorded range "
    "(the output says what changed).",
)
@options.json_option
def command(
    dem: Path,
    start: str,
    goal: str,
    model_path: Path | None,
    search: dict[str, Any],
    request: Request,
    step: float | None,
    eps: float | None,
    memory_cap: str | None,
    out: Path | None,
    geojson_crs: str,
    bag: Path | None,
    bag_frame: str,
    trust: options.Trust,
    plot: Path | None,
    html: Path | None,
    stay_in_domain: bool,
    as_json: bool,
    deadline: float | None = None,
    pareto: int | None = None,
) -> None:
    """Plan an energy-minimal path (x, y, heading) from START to GOAL over a DEM.

    The energy is that of the model (--model, default the bundled B1-class model)
    integrated along the path; the path may walk sideways or backwards where that is
    cheaper, unless --max-backward-slope or --max-crab forbid it. The default planner
    searches (x, y, heading) at the DEM's own cell size with an admissible heuristic,
    then refines the path. Progress is shown on stderr. A DEM too large for --memory-cap
    is read by windows about the start and the goal (a corridor); the output says
    whether the window is proven to hold every cheaper path.
    """
    from energy_planner.api import plan
    from energy_planner.errors import (
        DEMError,
        DEMIOError,
        EnergyPlannerError,
        RasterTooLargeError,
    )
    from energy_planner.uncertainty import BatteryError
    from energy_planner.uncertainty.domain import DomainError

    model = load_model_option(model_path)
    cap = parse_memory_cap(memory_cap)
    speed = options.speed_choice()
    if (deadline is not None or pareto is not None) and speed is None:
        speed = "auto"
    choice: dict[str, Any] = {} if speed is None else {"speed": speed}
    if deadline is not None:
        choice["deadline"] = deadline
    if pareto is not None:
        if deadline is not None:
            raise click.BadParameter("give --pareto or --deadline, not both", param_hint="--pareto")
        for name, value in (("--out", out), ("--html", html), ("--bag", bag)):
            if value is not None:
                raise click.BadParameter(
                    f"{name} writes one path; --pareto plans {pareto} (use --json for all of "
                    "them, --plot for the front)",
                    param_hint=name,
                )
    if over_memory_cap(dem, cap):  # the library plans it by windows; points in the DEM's CRS
        if choice or pareto is not None:
            raise click.BadParameter(
                f"{dem}: the DEM is planned by windows (over --memory-cap), where the speed is "
                "the nominal one; expected a fixed --speed V, or raise --memory-cap",
                param_hint="--speed/--deadline/--pareto",
            )
        where, crs = dem, None
        s = point_in_dem_crs(start, "--start", True)
        g = point_in_dem_crs(goal, "--goal", True)
    else:
        where = load_terrain(dem)
        crs = where.crs
        s, g = (_xy_yaw(point_to_work(where, p, f"--{h}", True))
                for p, h in ((start, "start"), (goal, "goal")))  # fmt: skip
    trust_kw = dict(level=trust.level, battery_wh=trust.battery_wh, reserve_wh=trust.reserve_wh,
                    confidence=trust.confidence)  # fmt: skip
    try:
        if pareto is not None:
            from energy_planner.api import pareto as energy_time_front

            front = energy_time_front(where, s, g, pareto, crs=crs, model=model,
                                      request=request, **search, step=step, eps=eps,
                                      **choice, **trust_kw)  # fmt: skip
            prob = front.problem
            return _emit_front(front, prob.terrain, prob.request, model, model_path, plot,
                               as_json)  # fmt: skip
        res = plan(where, s, g, crs=crs, model=model, request=request, **search, step=step,
                   eps=eps, memory_cap=cap, stay_in_domain=stay_in_domain, progress=True,
                   **choice, **trust_kw)  # fmt: skip
    except RasterTooLargeError as exc:
        raise click.BadParameter(str(exc), param_hint="--memory-cap") from exc
    except (DEMError, DEMIOError) as exc:
        raise click.BadParameter(str(exc), param_hint="--dem") from exc
    except DomainError as exc:
        raise click.BadParameter(str(exc), param_hint="--stay-in-domain") from exc
    except BatteryError as exc:
        raise click.BadParameter(str(exc), param_hint="--battery-wh/--reserve-wh") from exc
    except EnergyPlannerError as exc:
        raise planning_error(exc, "a coarser --step or a larger --eps") from exc
    terrain, request = res.problem.terrain, res.problem.request
    result = res.to_dict()
    result.update(plan_context(terrain, request, model, model_path))
    options.judge(res, trust)
    options.write_output(result, "out", out,
                         lambda p: res.write_geojson(p, native=geojson_crs == "dem"))  # fmt: skip
    options.write_output(result, "plot", plot, res.plot)
    options.write_output(result, "html", html, res.write_html)
    options.write_bag_output(result, bag, lambda p: res.write_bag(p, frame=bag_frame))
    options.emit(result, as_json, lambda r: format_table(r) + "\n" + res.assessment.text())


def _xy_yaw(p: tuple) -> tuple:
    """``(x, y, yaw | None)`` as ``(x, y)`` or ``(x, y, yaw)`` (what the verbs take)."""
    return p[:2] if p[2] is None else p
