"""Options and output helpers shared by every command, defined once."""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import click
import numpy as np

from energy_planner.planners import PLANNERS as PLANNER_CHOICES  # no planner imported
from energy_planner.request import DEFAULT_SPEED, DEFAULT_YAW_RATE
from energy_planner.trust import Trust as _LibraryTrust


def _quiet(ctx: click.Context, param: click.Parameter, value: bool) -> None:
    if value:
        from energy_planner.progress import quiet

        quiet()


#: ``-q/--quiet`` of every command that prints a result (the group takes it too).
quiet_option = click.option(
    "-q",
    "--quiet",
    is_flag=True,
    expose_value=False,
    is_eager=True,
    callback=_quiet,
    help="No progress on stderr (bars on a terminal, a line every 10 s in a log).",
)


def json_option(f: Callable) -> Callable:
    """``--json`` (print the result as JSON) and ``-q/--quiet`` (no progress on stderr)."""
    f = click.option(
        "--json", "as_json", is_flag=True, help="Print the result as JSON instead of a table."
    )(f)
    return quiet_option(f)


def path_option(*decls: str, help: str, folder: bool = False, **kw: Any) -> Callable:
    """An option naming a file (a folder with ``folder``) as a :class:`~pathlib.Path`.

    ``decls`` and ``kw`` are those of :func:`click.option` (``required``, ``default``, ...;
    the default is None).
    """
    if not kw.get("required"):  # click >= 8.3 fills a required option from default=None
        kw.setdefault("default", None)
    kind = (
        click.Path(file_okay=False, path_type=Path)
        if folder
        else click.Path(dir_okay=False, path_type=Path)
    )
    return click.option(*decls, type=kind, help=help, **kw)


def value_option(*decls: str, default: Any, help: str, type: Any = None, **kw: Any) -> Callable:
    """An option of type ``type`` whose ``default`` ``--help`` shows (:func:`click.option`)."""
    return click.option(*decls, type=type, default=default, show_default=True, help=help, **kw)


def plot_option(help: str) -> Callable:
    """``--plot FILE`` (a PNG), with ``help`` saying what is drawn."""
    return path_option("--plot", help=help)


def html_option(help: str) -> Callable:
    """``--html FILE``: one self-contained page (:mod:`energy_planner.webmap`), offline."""
    return path_option(
        "--html",
        help=help + " One self-contained HTML file (Plotly inlined): opens in any browser, "
        "no network needed.",
    )


def write_output(result: dict[str, Any], key: str, path: Path | None, write: Callable) -> None:
    """An optional output: ``write(path)`` when ``path`` is given, and ``result[key]`` names it.

    ``write`` writes through :mod:`energy_planner.io` (atomic); nothing happens for None.
    """
    if path is not None:
        write(path)
        result[key] = str(path)


def write_geojson_output(
    result: dict[str, Any], key: str, path: Path | None, document: Callable[[], dict], **kw: Any
) -> None:
    """:func:`write_output` of the GeoJSON ``document()`` (built only when ``path`` is given).

    ``kw`` goes to :func:`energy_planner.io.write_geojson` (e.g. ``indent=None``).
    """
    if path is not None:
        from energy_planner.io import write_geojson

        write_output(result, key, path, lambda p: write_geojson(p, document(), **kw))


def bundled(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
    """Click callback: a file name that does not exist but names a bundled file becomes it.

    ``--dem hill``, ``--sites hill_sites`` (:func:`energy_planner.maps.resolve`).
    """
    if value is None:
        return None
    from energy_planner.maps import resolve

    return resolve(value)


def bundled_existing(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
    """:func:`bundled`, then a file that does not exist is a usage error naming it."""
    path = bundled(ctx, param, value)
    if path is not None and not path.exists():
        from energy_planner.maps import map_names

        raise click.BadParameter(
            f"file {str(value)!r} does not exist (nor is it a bundled map's name: "
            f"{', '.join(map_names())})",
            ctx=ctx,
            param=param,
        )
    return path


dem_option = path_option(
    "--dem",
    "dem",
    required=True,
    callback=bundled,
    help="DEM raster (any single-band raster rasterio opens, e.g. GeoTIFF), or a bundled "
    "map's name: hill, plane, jacksboro.",
)
#: The DEM as the first argument (``energy-map DEM``, ``reach DEM``).
dem_argument = click.argument(
    "dem", type=click.Path(dir_okay=False, path_type=Path), callback=bundled
)
#: ``--geojson-crs``: the CRS of GeoJSON outputs (io's RFC 7946 writer or the DEM's CRS).
geojson_crs_option = value_option(
    "--geojson-crs",
    type=click.Choice(["wgs84", "dem"]),
    default="wgs84",
    help="CRS of GeoJSON outputs: 'wgs84' (RFC 7946 longitude, latitude, what GIS and web "
    "maps expect) or 'dem' (the DEM's own CRS, declared with a 'crs' member).",
)
band_option = click.option(
    "--band",
    type=click.IntRange(min=1),
    default=None,
    help="1-based band of the DEM (required when the raster has several bands).",
)


def memory_cap_option(what: str):
    """``--memory-cap SIZE``: the memory ``what`` may use; parse with :func:`parse_memory_cap`."""
    return click.option(
        "--memory-cap",
        "memory_cap",
        default=None,
        metavar="SIZE",
        help=f"Memory {what}, e.g. 2GB, 512M, 50% or off "
        "(default: $ENERGY_PLANNER_MEMORY_CAP, else half the machine's memory).",
    )


def parse_memory_cap(value: str | None):
    """``--memory-cap`` as a cap (:func:`energy_planner.terrain.memory.resolve_cap`).

    Bytes, ``DEFAULT_CAP`` when not given, ``NO_CAP`` for off; ``click.BadParameter`` if
    not a size.
    """
    from energy_planner.terrain.memory import DEFAULT_CAP, NO_CAP, parse_cap

    if value is None:
        return DEFAULT_CAP
    text = value.strip()
    if text.lower() in ("off", "none", "no"):  # as ENERGY_PLANNER_MEMORY_CAP accepts
        return NO_CAP
    try:
        if not text:
            raise ValueError(text)
        size = parse_cap(text)
    except ValueError as exc:
        raise click.BadParameter(
            f"{value!r} is not a size; expected e.g. 2GB, 512M, 1.5GiB, 50% or off",
            param_hint="--memory-cap",
        ) from exc
    if size is None and text.endswith("%"):
        return DEFAULT_CAP  # a share of a memory size the machine does not report
    if size is None or size <= 0:  # "0" means off for the variable; here it is refused
        raise click.BadParameter(
            f"{value!r}: the cap must be more than 0 bytes (or off)", param_hint="--memory-cap"
        )
    return size


model_option = path_option(
    "--model",
    "model_path",
    help="Energy model JSON, or a bundled model by name: b1_default (the default, "
    "0.3 m/s), b1_speeds (0.15-1.2 m/s, walk and trot).",
)
seed_option = value_option(
    "--seed",
    type=int,
    default=0,
    help="Random seed (planner sampling; for fit/diagnose, the assignment of runs to folds).",
)
speed_option = value_option(
    "--speed",
    type=click.FloatRange(min=0, min_open=True),
    default=DEFAULT_SPEED,
    help="Nominal walking speed, m/s.",
)


class SpeedSpec(click.ParamType):
    """``--speed`` of ``plan``: ``V`` (fixed, m/s), ``MIN:MAX`` (a range) or ``auto``.

    A number converts to a float (the other commands' ``--speed``); a range to a pair,
    ``auto`` stays the string (:func:`energy_planner.planning.speed.resolve_speed`).
    """

    name = "V|MIN:MAX|auto"

    def convert(self, value: Any, param: Any, ctx: Any) -> Any:
        """A float, a ``(vmin, vmax)`` pair or ``"auto"``; a bad value fails naming it."""
        if isinstance(value, float | int | tuple):
            return value
        from energy_planner.errors import PlanningConfigError
        from energy_planner.planning.speed import resolve_speed

        if str(value).strip() == "auto":
            return "auto"
        try:
            return resolve_speed(str(value), None)
        except PlanningConfigError as exc:
            self.fail(f"{value!r}: {exc}", param, ctx)


#: ``ctx.meta`` key of a ``--speed`` range or ``auto`` (read by ``plan``).
SPEED_RANGE_KEY = "energy_planner.speed_range"

plan_speed_option = value_option(
    "--speed",
    type=SpeedSpec(),
    default=DEFAULT_SPEED,
    help="Walking speed along the ground, m/s: V (every motion at V), MIN:MAX (each motion "
    "at its own least-energy speed in the range, chosen in closed form; the path carries "
    "its speed profile) or auto (the range of speeds the model's logs cover).",
)
logs_argument = click.argument("logs", nargs=-1, required=True, type=click.Path(path_type=Path))
window_option = value_option(
    "--window",
    type=click.FloatRange(min=0, min_open=True),
    default=2.0,
    help="Window length, s.",
)

repair_option = value_option(
    "--repair/--no-repair",
    "repair",
    default=True,
    help="Correct the data findings (sensor problems: current sign, clock offset, odometry "
    "slip, IMU tilt, twist noise) before fitting; --no-repair reports them only.",
)

report_option = path_option(
    "--report", "report", help="Write a self-contained HTML report (plots embedded) to this file."
)


def staircase_options(f):
    """The options of the staircase of ``diagnose`` and ``discover``, defined once.

    ``--term`` (extra candidates), ``--folds``, ``--max-steps``, and the noise rule
    (``--alpha``, ``--min-rel``) with the fold ``--seed``. The command gets ``terms`` and
    ``staircase`` (:func:`staircase_from_options`) instead of the others.
    """
    for opt in reversed(
        (
            click.option(
                "--term",
                "terms",
                multiple=True,
                metavar="TERM",
                help="Also test this candidate term (catalog name or formula, e.g. "
                "'load_kg * speed * sin(alpha)'). Repeatable.",
            ),
            value_option(
                "--folds",
                type=click.IntRange(min=2),
                default=5,
                help="Folds of the held-out validation by run.",
            ),
            value_option(
                "--max-steps",
                type=click.IntRange(min=0),
                default=4,
                help="Largest number of terms the staircase adds to the model.",
            ),
            value_option(
                "--alpha",
                "alpha",
                type=click.FloatRange(min=0, max=1, min_open=True),
                default=0.01,
                help="Noise rule: family-wise false-finding level of each step (one-sided "
                "test by run of choosing at all, each fold choosing on its training runs; "
                "then the best at this level, the others Bonferroni over the candidates).",
            ),
            value_option(
                "--min-rel",
                type=click.FloatRange(min=0, max=1),
                default=0.05,
                help="Noise rule: the held-out RMSE must fall by at least this fraction.",
            ),
            value_option(
                "--seed",
                type=int,
                default=0,
                help="Seed of the assignment of runs to folds.",
            ),
            value_option(
                "--partitions",
                type=click.IntRange(min=1),
                default=10,
                help="Noise rule: assignments of the runs to folds (seeds --seed, --seed + 1, "
                "...) whose gains by run the test of choosing at all averages.",
            ),
        )
    ):
        f = opt(f)
    return collect(
        "staircase", staircase_from_options, "alpha", "min_rel", "folds", "seed", "max_steps",
        "partitions",
    )(f)  # fmt: skip


def staircase_from_options(
    alpha: float, min_rel: float, folds: int, seed: int, max_steps: int, partitions: int = 10
) -> dict[str, Any]:
    """The staircase's ``thresholds`` (noise rule and folds) and ``max_steps`` keywords."""
    from energy_planner.diagnosis.suspects import Thresholds

    th = Thresholds(
        alpha=alpha, min_rel=min_rel, n_splits=folds, seed=seed, n_partitions=partitions
    )
    return {"thresholds": th, "max_steps": max_steps}


#: ``ctx.meta`` key of ``--points-crs`` (read by :func:`points_crs`).
POINTS_CRS_KEY = "energy_planner.points_crs"


def _store_points_crs(ctx: click.Context, param: click.Parameter, value: str | None) -> None:
    if value is not None:
        from rasterio.crs import CRS
        from rasterio.errors import CRSError

        try:
            CRS.from_user_input(value)
        except CRSError as exc:
            raise click.BadParameter(
                f"{value!r} is not a CRS PROJ knows ({exc}); e.g. EPSG:4326 (longitude, "
                "latitude) or EPSG:32631",
                param_hint="--points-crs",
            ) from exc
    ctx.meta[POINTS_CRS_KEY] = value


#: ``--points-crs``: the CRS of the command line's points (default: the DEM's).
points_crs_option = click.option(
    "--points-crs",
    metavar="CRS",
    default=None,
    expose_value=False,
    callback=_store_points_crs,
    help="CRS of --start/--goal, e.g. EPSG:4326 for longitude,latitude (yaw then from "
    "local east); default: the DEM's CRS.",
)


def points_crs() -> str | None:
    """``--points-crs`` of the running command (None: the DEM's CRS)."""
    ctx = click.get_current_context(silent=True)
    return None if ctx is None else ctx.find_root().meta.get(POINTS_CRS_KEY)


def start_goal_options(f):
    """``--start`` and ``--goal`` as X,Y[,YAW_DEG] in the DEM's CRS (or ``--points-crs``)."""
    f = points_crs_option(f)
    f = click.option("--goal", required=True, help="Goal X,Y[,YAW_DEG] in the DEM's CRS.")(f)
    return click.option("--start", required=True, help="Start X,Y[,YAW_DEG] in the DEM's CRS.")(f)


#: ``ctx.meta`` key of the gait limits (read by :func:`gait_limits`).
GAIT_LIMITS_KEY = "energy_planner.gait_limits"
#: The gait-limit options and the :class:`~energy_planner.request.Limits` field of each.
GAIT_LIMIT_OPTIONS = {
    "--max-backward-slope": "max_backward_slope_deg",
    "--max-crab": "max_crab_deg",
}


#: The help text of each gait-limit option, in ``--help`` order.
GAIT_LIMIT_HELP = {
    "--max-backward-slope": "No backward walking (body x more than 90 deg from the direction "
    "of travel) on ground steeper than this, degrees.",
    "--max-crab": "Largest crab angle: the angle between the body's x axis and the direction "
    "of travel (or its opposite when walking backward), degrees; 0 = face along or straight "
    "back, 90 = any gait. Turns in place are not limited.",
}


def _store_gait_limit(ctx: click.Context, param: click.Parameter, value: float | None) -> None:
    field = GAIT_LIMIT_OPTIONS[param.opts[0]]
    ctx.find_root().meta.setdefault(GAIT_LIMITS_KEY, {})[field] = value


def gait_limit_options(f):
    """``--max-backward-slope`` and ``--max-crab``: the gait limits, defined once.

    Their values are read with :func:`gait_limits` (they are not parameters of the
    command function), so that every command with planning limits takes them the same way.
    """
    for name, text in reversed(GAIT_LIMIT_HELP.items()):
        f = click.option(name, metavar="DEG", type=click.FloatRange(0, 90), default=None,
                         expose_value=False, callback=_store_gait_limit, help=text)(f)  # fmt: skip
    return f


def gait_limits() -> dict[str, float | None]:
    """The running command's gait limits as :class:`~energy_planner.request.Limits` fields.

    ``{"max_backward_slope_deg": ..., "max_crab_deg": ...}`` (None: no limit).
    """
    ctx = click.get_current_context(silent=True)
    given = {} if ctx is None else ctx.find_root().meta.get(GAIT_LIMITS_KEY, {})
    return {field: given.get(field) for field in GAIT_LIMIT_OPTIONS.values()}


yaw_rate_option = value_option(
    "--yaw-rate",
    type=click.FloatRange(min=0, min_open=True),
    default=DEFAULT_YAW_RATE,
    help="Nominal turning rate, rad/s.",
)


def check_planner(planner: str) -> str:
    """Validate ``--planner`` (click.BadParameter listing the valid names)."""
    if planner not in PLANNER_CHOICES:
        raise click.BadParameter(
            f"unknown planner {planner!r}; valid planners: {', '.join(PLANNER_CHOICES)}",
            param_hint="--planner",
        )
    return planner


#: What ``--time`` bounds, for the help texts.
TIME_HELP = (
    "Budget for the whole planning of {what}, seconds, counted after the kernels are compiled "
    "(loading the DEM is not counted): the search's relaxed problem and search (an error if "
    "they do not finish in time), then the refinement, which gets what is left. Default: no "
    "limit for the search, and a quarter of its time (at most 10 s, at least 4 rounds) for "
    "the refinement; "
    "OMPL planners run for 10 s. The 'lattice' planner cannot be interrupted. A DEM planned "
    "by windows (above --memory-cap) counts everything: the gradient pass and each "
    "window's read and search."
)


def search_from_options(planner: str, time_s: float | None, seed: int) -> dict[str, Any]:
    """``planner``, ``time`` and ``seed`` keywords of the planners, ``--planner`` checked."""
    return {"planner": check_planner(planner), "time": time_s, "seed": seed}


def planning_options(what: str, time_default: float | None = 10.0, speed_range: bool = False):
    """--planner, --time, --seed, the limits, --speed and --yaw-rate, for planning ``what``.

    The command gets ``search`` (:func:`search_from_options`) instead of ``planner``,
    ``time_s`` and ``seed``. ``speed_range``: ``--speed`` also takes ``MIN:MAX`` and
    ``auto`` (:class:`SpeedSpec`; the command reads it with :func:`speed_choice`).
    """
    time_help = (
        TIME_HELP.format(what=what)
        if time_default is None
        else f"Planning budget of {what}, seconds."
    )

    def deco(f):
        for opt in reversed(
            [
                value_option(
                    "--planner",
                    default="auto",
                    help=f"Planner of {what}: {', '.join(PLANNER_CHOICES)}.",
                ),
                click.option(
                    "--time",
                    "time_s",
                    type=click.FloatRange(min=0, min_open=True),
                    default=time_default,
                    show_default=time_default is not None,
                    help=time_help,
                ),
                seed_option,
                limit_options,
                plan_speed_option if speed_range else speed_option,
                yaw_rate_option,
            ]
        ):
            f = opt(f)
        return collect("search", search_from_options, "planner", "time_s", "seed")(f)

    return deco


def limit_options(f):
    """--max-slope, --max-cross-slope, --keep-out and the gait limits.

    The gait limits (``--max-backward-slope``, ``--max-crab``:
    :func:`~energy_planner.cli.options.gait_limit_options`) are read with
    :func:`~energy_planner.cli.options.gait_limits`.
    """
    f = gait_limit_options(f)
    f = path_option(
        "--keep-out",
        "keep_out",
        help="GeoJSON polygons the path must avoid: longitude, latitude (RFC 7946) unless "
        "the file declares a crs; reprojected to the DEM.",
    )(f)
    f = click.option(
        "--max-cross-slope",
        type=click.FloatRange(0, 90),
        default=None,
        help="Steepest slope across the robot's body, degrees.",
    )(f)
    f = click.option(
        "--max-slope",
        type=click.FloatRange(0, 90),
        default=None,
        help="Steepest ground slope the path may cross, degrees.",
    )(f)
    return f


def request_from_options(
    speed: float,
    yaw_rate: float,
    max_slope: float | None,
    max_cross_slope: float | None,
    keep_out: Path | None,
    sets: tuple[str, ...] = (),
    channels: tuple[str, ...] = (),
):
    """The :class:`~energy_planner.request.Request` of the planning options.

    A bad value becomes ``click.BadParameter`` naming the option (from the error's
    ``field``, never from its text).
    """
    from energy_planner.request import Request, RequestError

    if not isinstance(speed, float | int):  # a range or auto (plan's --speed): the nominal
        click.get_current_context().meta[SPEED_RANGE_KEY] = speed  # speed stays the default
        speed = DEFAULT_SPEED
    option = {
        "speed": "--speed", "yaw_rate": "--yaw-rate", "max_slope_deg": "--max-slope",
        "max_cross_slope_deg": "--max-cross-slope", "keep_out": "--keep-out",
        "max_backward_slope_deg": "--max-backward-slope", "max_crab_deg": "--max-crab",
    }  # fmt: skip
    try:
        return Request.make(
            **gait_limits(),
            speed=speed,
            yaw_rate=yaw_rate,
            max_slope_deg=max_slope,
            max_cross_slope_deg=max_cross_slope,
            keep_out=keep_out,
            channels=channels_from_options(sets, channels),
        )
    except RequestError as exc:
        raise click.BadParameter(str(exc), param_hint=option.get(exc.field, exc.field)) from exc


def speed_choice() -> Any:
    """The ``--speed`` range or ``auto`` of this command (:class:`SpeedSpec`), or None."""
    return click.get_current_context().meta.get(SPEED_RANGE_KEY)


#: The options :func:`request_from_options` reads (a command's parameter names).
REQUEST_PARAMS = (
    "speed",
    "yaw_rate",
    "max_slope",
    "max_cross_slope",
    "keep_out",
    "sets",
    "channels",
)


def with_request(f):
    """The command gets one ``request`` (:func:`request_from_options`) for its options.

    Put under ``@click.command``, above the options of :data:`REQUEST_PARAMS` wherever the
    command declares them (``--help`` keeps their order).
    """
    return collect("request", request_from_options, *REQUEST_PARAMS)(f)


def request_options(f):
    """The limits, ``--speed``, ``--yaw-rate`` and the channel options: one ``request``."""
    for opt in (channel_options, yaw_rate_option, speed_option, limit_options):
        f = opt(f)
    return with_request(f)


def ranged_request_options(f):
    """:func:`request_options` whose ``--speed`` also takes ``MIN:MAX`` and ``auto``.

    The command reads a range with :func:`speed_choice` (the request keeps the nominal
    speed).
    """
    for opt in (channel_options, yaw_rate_option, plan_speed_option, limit_options):
        f = opt(f)
    return with_request(f)


#: ``ctx.meta`` key of ``--allow-unknown-category`` (read by :func:`channels_from_options`).
ALLOW_UNKNOWN_KEY = "energy_planner.allow_unknown_category"


def _store_allow_unknown(ctx: click.Context, param: click.Parameter, value: bool) -> None:
    ctx.meta[ALLOW_UNKNOWN_KEY] = bool(value)


def channel_options(f):
    """``--set NAME=VALUE``, ``--channel NAME=RASTER[:TABLE]`` and ``--allow-unknown-category``.

    ``--set`` and ``--channel`` are repeatable; the flag is stored in the context. The
    command receives ``sets`` and ``channels`` (tuples of strings); turn them into a
    :class:`~energy_planner.energy.channels.Channels` with :func:`channels_from_options`.
    """
    f = click.option(
        "--allow-unknown-category",
        is_flag=True,
        expose_value=False,
        callback=_store_allow_unknown,
        help="Accept a category the model's formulas do not name (in --set or a --channel "
        "value table): priced as none of the model's categories, with a warning. Default: "
        "an error listing the valid categories.",
    )(f)
    f = click.option(
        "--channel",
        "channels",
        multiple=True,
        metavar="NAME=RASTER[:TABLE]",
        help="A channel the model reads that varies over the map: a numeric raster "
        "(bilinear), or a coded raster with a value table (code,category CSV or JSON; "
        "nearest cell), e.g. ground=landcover.tif:landcover.csv. Aligned to the DEM. "
        "Repeatable.",
    )(f)
    return click.option(
        "--set",
        "sets",
        multiple=True,
        metavar="NAME=VALUE",
        help="A constant channel the model reads: a number (load_kg=10) or a category "
        "(ground=meadow). Repeatable.",
    )(f)


def channels_from_options(sets: tuple[str, ...], channels: tuple[str, ...]):
    """The :class:`~energy_planner.energy.channels.Channels` of ``--set``/``--channel``.

    Bad strings and missing files become ``click.BadParameter`` naming the option.
    """
    from energy_planner.energy.channels import Channels
    from energy_planner.errors import ChannelError, ChannelIOError

    ctx = click.get_current_context(silent=True)
    allow = bool(ctx is not None and ctx.find_root().meta.get(ALLOW_UNKNOWN_KEY))
    try:
        return Channels.parse(sets, channels, allow_unknown_categories=allow)
    except (ChannelError, ChannelIOError) as exc:
        hint = "--channel" if str(exc).startswith("--channel") or "table" in str(exc) else "--set"
        raise click.BadParameter(str(exc), param_hint=hint) from exc


def _jsonable(obj: Any) -> Any:
    """Convert numpy scalars/arrays and non-finite floats to JSON-friendly values."""
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        return _jsonable(obj.item())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, Path):
        return str(obj)
    return obj


def written_lines(res: dict[str, Any], labels: dict[str, str]) -> list[str]:
    """``"<label> written to <path>"`` for each output ``key -> label`` that ``res`` names."""
    return [f"{label} written to {res[key]}" for key, label in labels.items() if res.get(key)]


def emit(result: dict[str, Any], as_json: bool, text: Callable[[dict[str, Any]], str]) -> None:
    """Print ``result`` as JSON (``--json``) or through ``text`` as a human table."""
    if as_json:
        click.echo(json.dumps(_jsonable(result), indent=2))
    else:
        click.echo(text(result))


def parse_point(value: str, param_hint: str, with_yaw: bool = False) -> tuple[float, ...]:
    """Parse ``X,Y`` (or ``X,Y,YAW_DEG`` when ``with_yaw``) into floats.

    Raises ``click.BadParameter`` naming the value and the expected form.
    """
    parts = [p.strip() for p in value.split(",")]
    allowed = (2, 3) if with_yaw else (2,)
    form = "X,Y or X,Y,YAW_DEG" if with_yaw else "X,Y"
    try:
        nums = tuple(float(p) for p in parts)
    except ValueError:
        nums = ()
    if len(nums) not in allowed or not all(math.isfinite(n) for n in nums):
        raise click.BadParameter(
            f"{value!r} is not {form} (numbers in the DEM's CRS, yaw in degrees CCW from x).",
            param_hint=param_hint,
        )
    return nums


def load_model_option(model_path: Path | None):
    """Load the model named by ``--model``, or the bundled default."""
    from energy_planner.errors import EnergyPlannerError
    from energy_planner.model import EnergyModel

    try:
        if model_path is None:
            return EnergyModel.default()
        return EnergyModel.load(model_path)
    except EnergyPlannerError as exc:
        raise click.BadParameter(str(exc), param_hint="--model") from exc


def examples(*lines: str) -> str:
    """A command's ``epilog``: its examples, one ``$ energy-planner ...`` line each.

    Click's no-rewrap marker keeps each line whole, so it can be copied as printed; the
    tests run every one (``tests/test_examples.py``).
    """
    return "Examples:\n\n\b\n" + "\n".join(f"  $ {line}" for line in lines)


def command(name: str, *example_lines: str) -> Callable:
    """``@click.command(name)`` with its examples (:func:`examples`) as the epilog."""
    return click.command(name, epilog=examples(*example_lines))


def battery_options(f):
    """``--battery-wh``, ``--reserve-wh`` and ``--confidence``, defined once."""
    opts = [
        click.option("--battery-wh", type=click.FloatRange(min=0, min_open=True), default=None,
                     help="Battery energy, Wh: the chance that the route fits in it "
                     "(less --reserve-wh)."),
        click.option("--reserve-wh", type=click.FloatRange(min=0), default=0.0,
                     show_default=True, help="Energy to keep in the battery, Wh."),
        click.option("--confidence", type=click.FloatRange(0.5, 0.999), default=0.9,
                     show_default=True,
                     help="Required chance that the battery suffices."),
    ]  # fmt: skip
    for opt in reversed(opts):
        f = opt(f)
    return f


@dataclass(frozen=True)
class Trust(_LibraryTrust):
    """What ``--level``, the battery options and ``--refuse`` ask of a result's energy.

    The library's :class:`~energy_planner.trust.Trust` (``level``, ``battery_wh``,
    ``reserve_wh``, ``confidence``), handed to the verbs as it is, and ``refuse``: a
    chance below ``confidence`` is an error (exit status 1), not a warning.
    """

    refuse: bool = False


def collect(name: str, build: Callable[..., Any], *params: str) -> Callable:
    """A decorator: the command gets one value ``name`` = ``build(**params)``.

    The options ``params`` stay where the command declares them (its ``--help`` is
    unchanged); their values are taken out of the call and built into one object.
    """

    def deco(f: Callable) -> Callable:
        @functools.wraps(f)
        def command(*args: Any, **kwargs: Any) -> Any:
            values = {p: kwargs.pop(p) for p in params}
            return f(*args, **{name: build(**values)}, **kwargs)

        return command

    return deco


def trust_options(f):
    """``--level`` (interval), the battery options and ``--refuse``: one ``trust`` value.

    The command receives ``trust`` (a :class:`Trust`) instead of the five values.
    """
    f = collect("trust", Trust, "level", "battery_wh", "reserve_wh", "confidence", "refuse")(f)
    f = click.option("--refuse", is_flag=True,
                     help="Exit with an error (status 1) when the chance is below "
                     "--confidence (default: a warning).")(f)  # fmt: skip
    f = battery_options(f)
    return level_option(f)


#: ``--level``: the nominal coverage of an energy's prediction interval.
level_option = click.option(
    "--level", type=click.FloatRange(0.5, 0.99), default=0.9, show_default=True,
    help="Nominal coverage of the energy's prediction interval.",
)  # fmt: skip


def judge(result: Any, trust: Trust, label: str | None = None, judged: bool = True) -> None:
    """Say a battery verdict below the required chance, or a refused one: a warning or an error.

    ``result`` carries an assessment (:class:`~energy_planner.trust.Assessed`): its
    ``battery`` (a :class:`~energy_planner.uncertainty.BatteryDecision`, or None) and its
    ``battery_refused`` (why no decision was given beyond the calibrated ranges). Below
    ``trust.confidence``, or refused, it prints a warning on stderr (naming ``label``, the
    route, when given), or with ``trust.refuse`` (and ``judged``: the result the command
    judges) raises a ``click.ClickException`` (exit status 1).
    """
    a = getattr(result, "assessment", None)
    refused = None if a is None else a.battery_refused
    decision = None if a is None else a.battery
    if refused is not None:
        text = refused
    elif decision is not None and not decision.ok:
        text = decision.text().strip()
    else:
        return
    text = text if label is None else f"{label}: {text}"
    if trust.refuse and judged:
        raise click.ClickException(text)
    click.echo(f"warning: {text}", err=True)


def bag_options(fn: Callable) -> Callable:
    """``--bag DIR`` (a new ROS 2 bag folder of ``nav_msgs/Path``) and ``--bag-frame NAME``."""
    fn = value_option(
        "--bag-frame",
        default="map",
        help="The frame of --bag's poses: the DEM's (working) CRS shifted to the grid's "
        "south-west corner, REP 103 axes; the shift is in the bag's metadata and the JSON.",
    )(fn)
    return path_option(
        "--bag",
        folder=True,
        help="Write the path(s) as nav_msgs/msg/Path into a new ROS 2 bag folder (MCAP), "
        "stamped with the planned times.",
    )(fn)


def write_bag_output(result: dict[str, Any], path: Path | None, write: Callable) -> None:
    """``--bag``: ``write(path)`` returns the frame; ``result`` gets ``bag`` and ``bag_frame``.

    A library error (the folder exists, a bad frame name) becomes a ``click.BadParameter``
    of ``--bag``.
    """
    if path is None:
        return
    from energy_planner.errors import EnergyPlannerError

    try:
        frame = write(path)
    except EnergyPlannerError as exc:
        raise click.BadParameter(str(exc), param_hint="--bag") from exc
    result["bag"] = str(path)
    result["bag_frame"] = frame
