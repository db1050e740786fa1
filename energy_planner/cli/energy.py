"""``energy-planner energy``: the energy of a given path over a DEM, per segment."""

from __future__ import annotations

import math
import warnings
from pathlib import Path
from typing import Any

import click

from energy_planner.cli import options
from energy_planner.request import DEFAULT_SPEED, DEFAULT_YAW_RATE


def load_terrain(dem: Path, band: int | None, stored: bool = False) -> Any:
    """Load ``--dem``; DEM errors become ``click.BadParameter``.

    ``stored``: read a DEM read before from the project's cache folder, without GDAL,
    and keep one read now there (:mod:`energy_planner.terrain.stored`): the same
    Terrain, its CRS a :class:`~energy_planner.terrain.stored.StoredCRS`.
    """
    from energy_planner.errors import DEMError, DEMIOError

    try:
        if not stored:
            from energy_planner.terrain import load_dem

            return load_dem(dem, band=band)
        from energy_planner.terrain.stored import keep_stored, read_stored

        terrain, key = read_stored(dem, band)
        if terrain is not None:
            return terrain
        from energy_planner.terrain import load_dem

        try:
            with warnings.catch_warnings(record=True) as caught:
                terrain = load_dem(dem, band=band)
        finally:  # shown as they would have been (the filters applied already)
            for w in caught:
                warnings.showwarning(w.message, w.category, w.filename, w.lineno, w.file, w.line)
        if not any(  # a library's deprecation notes say nothing of the DEM
            not issubclass(w.category, DeprecationWarning | PendingDeprecationWarning)
            for w in caught
        ):
            keep_stored(key, terrain)
        return terrain
    except (DEMIOError, DEMError) as exc:
        hint = " (use --band N)" if getattr(exc, "param", None) == "band" else ""
        raise click.BadParameter(f"{exc}{hint}", param_hint="--dem") from exc


def _source_bounds(terrain: Any) -> tuple[float, float, float, float]:
    """(xmin, ymin, xmax, ymax) of the DEM in its own CRS."""
    t = terrain.source_transform
    rows, cols = terrain.source_shape
    xs = [t.c, t.c + cols * t.a]
    ys = [t.f, t.f + rows * t.e]
    return min(xs), min(ys), max(xs), max(ys)


def _fmt_xy(x: float, y: float, geographic: bool) -> str:
    return f"({x:.6f}, {y:.6f})" if geographic else f"({x:.2f}, {y:.2f})"


def check_waypoints(terrain: Any, cost: Any, xy_src: Any, xy_work: Any) -> None:
    """Raise ``click.ClickException`` naming the first waypoint or segment off the map.

    Waypoints are named by index and by their coordinates in the DEM's CRS.
    """
    import numpy as np

    geographic = bool(getattr(terrain.source_crs, "is_geographic", False))
    s = terrain.sample(xy_work[:, 0], xy_work[:, 1])
    bad = np.flatnonzero(~np.isfinite(np.atleast_1d(s.slope)))
    xmin, ymin, xmax, ymax = _source_bounds(terrain)
    crs = terrain.source_crs or "local metres"
    if bad.size:
        i = int(bad[0])
        x, y = xy_src[i]
        inside = xmin <= x <= xmax and ymin <= y <= ymax
        where = (
            "on nodata (or within a cell of nodata or the map edge, where the slope is not defined)"
            if inside
            else "outside the map"
        )
        msg = (
            f"waypoint {i} at {_fmt_xy(x, y, geographic)} is {where}; "
            f"{bad.size} of {len(xy_src)} waypoint(s) are unusable: {bad.tolist()[:10]}"
        )
        if bad.size == len(xy_src) or not inside:
            from energy_planner.errors import extent_text

            msg += (
                f"\nhint: are the waypoints in the DEM's CRS ({crs})? The DEM covers "
                f"{extent_text((xmin, ymin, xmax, ymax), terrain.source_crs)}"
            )
        raise click.ClickException(msg)
    d = np.diff(xy_work, axis=0)
    h = np.arctan2(d[:, 1], d[:, 0])
    e = cost.batch(xy_work[:-1, 0], xy_work[:-1, 1], h, xy_work[1:, 0], xy_work[1:, 1], h)
    off = np.flatnonzero(~np.isfinite(e))
    if off.size:
        i = int(off[0])
        raise click.ClickException(
            f"segment {i} from waypoint {i} at {_fmt_xy(*xy_src[i], geographic)} to "
            f"waypoint {i + 1} at {_fmt_xy(*xy_src[i + 1], geographic)} crosses nodata or "
            f"leaves the map ({off.size} segment(s) do: {off.tolist()[:10]})"
        )


def _pct(v: float) -> str:
    return "-" if v is None or not math.isfinite(v) else f"{100 * v:.0f}%"


def format_table(res: dict[str, Any]) -> str:
    """Human-readable totals and per-segment table."""
    lines = [
        f"energy    {res['energy_j']:.1f} J ({res['energy_wh']:.3f} Wh)",
        f"distance  {res['distance_m']:.2f} m along the ground "
        f"({res['map_distance_m']:.2f} m on the map)",
        f"duration  {res['duration_s']:.1f} s",
        "mean      "
        + (f"{res['energy_j'] / res['distance_m']:.1f} J/m" if res["distance_m"] > 0 else "-"),
        "",
    ]
    segs = res["segments"]
    other = any(
        s["other_share"] is not None and math.isfinite(s["other_share"]) and s["other_share"] > 0
        for s in segs
    )
    head = (
        f"{'seg':>4} {'energy J':>10} {'dist m':>8} {'time s':>8} {'slope°':>7} {'max°':>5} "
        f"{'rel.head°':>9} {'fwd':>5} {'lat':>5} {'turn':>5}"
    ) + (f" {'other':>5}" if other else "")
    lines.append(head)
    for s in segs:
        row = (
            f"{s['segment']:>4} {s['energy_j']:>10.1f} {s['distance_m']:>8.2f} "
            f"{s['duration_s']:>8.1f} {s['mean_slope_deg']:>7.1f} {s['max_slope_deg']:>5.1f} "
            f"{s['mean_rel_heading_deg']:>9.1f} {_pct(s['forward_share']):>5} "
            f"{_pct(s['lateral_share']):>5} {_pct(s['turning_share']):>5}"
        )
        if other:
            row += f" {_pct(s['other_share']):>5}"
        lines.append(row)
    lines += [
        "",
        "dist: along the ground; slope, max: mean and steepest slope along the segment;",
        "rel.head: mean |relative heading| (0 = facing uphill, 180 = downhill);",
        "fwd/lat/turn: shares of the segment's work",
    ]
    for note in res.get("notes", []):
        lines.append(f"note: {note}")
    return "\n".join(lines)


def compute(
    dem: Path,
    waypoints: Path,
    model_path: Path | None = None,
    speed: float = DEFAULT_SPEED,
    yaw_rate: float = DEFAULT_YAW_RATE,
    band: int | None = None,
    channels: Any = None,
    max_backward_slope_deg: float | None = None,
    max_crab_deg: float | None = None,
    trust: Any = None,
    bag_topic: str | None = None,
) -> tuple[Any, dict[str, Any]]:
    """The command's work: the priced path and its context (click errors on bad input).

    Returns the :class:`~energy_planner.energy.path.PathEnergy` (with its assessment for
    ``trust``, a :class:`~energy_planner.trust.Trust`) and what the command adds to its
    :meth:`~energy_planner.energy.path.PathEnergy.to_dict`: the inputs and notes.

    ``channels`` is a :class:`~energy_planner.energy.channels.Channels` (``--set`` /
    ``--channel``) or None. ``max_backward_slope_deg`` and ``max_crab_deg`` are the gait
    limits (:class:`~energy_planner.request.Limits`): a segment that breaks one is an
    error naming it. ``bag_topic``: the topic of a ROS bag ``waypoints``.
    """
    import numpy as np

    from energy_planner.energy import MotionCost
    from energy_planner.energy.channels import Channels
    from energy_planner.energy.waypoints import (
        WaypointError,
        WaypointIOError,
        read_waypoints,
        waypoints_to_work,
    )
    from energy_planner.errors import EnergyPlannerError
    from energy_planner.io.path_format import segment_gaits
    from energy_planner.problem import Problem
    from energy_planner.request import Request
    from energy_planner.uncertainty import BatteryError

    terrain = load_terrain(dem, band, stored=True)
    model = options.load_model_option(model_path)
    channels = channels if channels is not None else Channels()
    try:
        wp = read_waypoints(waypoints, bag_topic)
    except WaypointIOError as exc:
        raise click.BadParameter(str(exc), param_hint="--waypoints") from exc
    except WaypointError as exc:
        raise click.ClickException(
            f"{exc}\nhint: a CSV with a header x,y[,yaw_deg][,t], a GeoJSON LineString in "
            "the DEM's CRS or a ROS bag with a nav_msgs/Path (docs/energy.md)"
        ) from exc
    try:
        gaits = segment_gaits(wp)
    except WaypointError as exc:
        raise click.BadParameter(str(exc), param_hint="--waypoints") from exc
    notes = list(wp.notes)
    if gaits is not None:
        notes.append("each segment walked in the gait the file gives (properties.gait)")
    if wp.t is not None:
        notes.append(
            "times from the file set the speed and turning rate; --speed and --yaw-rate "
            "are not used"
            if wp.yaw_rad is not None
            else "times from the file set the walking speed (--speed not used); turns in "
            "place at corners take their time at --yaw-rate"
        )
    unused = channels.unused(model)
    if unused:
        notes.append(f"the model does not read channel(s) {', '.join(unused)}; ignored")
    try:
        xy, yaw = waypoints_to_work(terrain, wp)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", UserWarning)
            # channel rasters that leave part of the DEM uncovered, or have no CRS
            request = Request.make(
                speed=speed, yaw_rate=yaw_rate, channels=channels,
                max_backward_slope_deg=max_backward_slope_deg, max_crab_deg=max_crab_deg,
            )  # fmt: skip
            cost = MotionCost(
                terrain, model, speed, yaw_rate, channels=channels,
                max_backward_slope_deg=max_backward_slope_deg, max_crab_deg=max_crab_deg,
                precompiled=True,  # loads without numba (built once per machine and model)
                gait_choice=True if gaits is not None else None,
            )  # fmt: skip
            problem = Problem.of_cost(cost, request)
        notes += [str(w.message) for w in caught if issubclass(w.category, UserWarning)]
        xs, ys = terrain.from_work(xy[:, 0], xy[:, 1])  # the DEM's CRS, for messages
        check_waypoints(terrain, cost, np.column_stack([np.atleast_1d(xs), np.atleast_1d(ys)]), xy)
        result = problem.path_energy(xy, yaw, wp.t, crs=terrain.crs, segment_gaits=gaits,
                                     trust=trust)  # fmt: skip
    except click.ClickException:
        raise
    except BatteryError as exc:
        raise click.BadParameter(str(exc), param_hint="--battery-wh/--reserve-wh") from exc
    except EnergyPlannerError as exc:
        raise click.ClickException(str(exc)) from exc
    out: dict[str, Any] = {}
    if (
        wp.declared_crs
        and terrain.crs is not None
        and str(wp.declared_crs) != str(terrain.source_crs)
    ):
        notes.append(f"waypoints converted from {wp.declared_crs} (the file's CRS) to the map")
    if terrain.source_crs != terrain.crs:
        notes.append(
            f"waypoints converted from the DEM's CRS {terrain.source_crs} to the working "
            f"grid {terrain.crs}; distances are on that grid"
        )
    out.update(
        {
            "waypoints": len(wp),
            "dem": str(dem),
            "working_crs": str(terrain.crs) if terrain.crs is not None else None,
            "yaw_given": wp.yaw_rad is not None,
            "times_given": wp.t is not None,
            "speed": speed,
            "yaw_rate": yaw_rate,
            "channels": cost.channels.describe(),
            "notes": notes,
        }
    )
    return result, out


@options.command(
    "energy",
    "energy-planner energy --dem hill --waypoints path.geojson",
    "energy-planner energy --dem hill --waypoints path.geojson "
    "--model load.json --set load_kg=10 --battery-wh 40",
)
@options.dem_option
@click.option(
    "--waypoints",
    "waypoints",
    required=True,
    type=click.Path(path_type=Path),
    help="Waypoints: CSV with header x,y[,yaw_deg][,t] in the DEM's CRS, or a GeoJSON "
    "LineString (optional properties.yaw_deg, properties.t lists) in longitude, latitude "
    "(RFC 7946) unless it declares a crs, as plan --out writes it, or a ROS bag (folder) "
    "with a nav_msgs/Path (or Odometry, PoseStamped messages), as plan --bag writes it.",
)
@click.option(
    "--bag-topic",
    help="The topic of a --waypoints ROS bag to read (default: its only path topic).",
)
@options.model_option
@options.speed_option
@options.yaw_rate_option
@options.band_option
@options.gait_limit_options
@options.channel_options
@options.trust_options
@options.json_option
def command(
    dem: Path,
    waypoints: Path,
    bag_topic: str | None,
    model_path: Path | None,
    speed: float,
    yaw_rate: float,
    band: int | None,
    sets: tuple[str, ...],
    channels: tuple[str, ...],
    trust: options.Trust,
    as_json: bool,
) -> None:
    """Energy of walking a given path over a DEM, with a per-segment breakdown.

    Without yaw the robot faces along each segment and turns in place at corners; with
    yaw_deg (degrees CCW from the map's x axis) it keeps the given orientation. Without
    times it walks at --speed and turns at --yaw-rate. Channels a fitted model reads
    (payload, ground type) are given with --set NAME=VALUE or --channel NAME=RASTER[:TABLE].
    """
    ch = options.channels_from_options(sets, channels)
    pe, context = compute(dem, waypoints, model_path, speed, yaw_rate, band, channels=ch,
                          trust=trust, bag_topic=bag_topic, **options.gait_limits())  # fmt: skip
    res = {**pe.to_dict(), **context}
    options.judge(pe, trust)
    options.emit(res, as_json, lambda r: format_table(r) + "\n" + pe.assessment.text())
