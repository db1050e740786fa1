"""``energy-planner mission``: visit several sites in the least-energy order."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from energy_planner.cli import options
from energy_planner.cli.options import load_model_option
from energy_planner.cli.plan import load_terrain, planning_error

if TYPE_CHECKING:
    from energy_planner.request import Request


def _text(res: dict[str, Any]) -> str:
    lines = [f"{'leg':<24} {'energy J':>10} {'Wh':>7} {'dist m':>8} {'time s':>8}"]
    for leg in res["legs"]:
        lines.append(
            f"{leg['from'] + ' -> ' + leg['to']:<24} {leg['energy_j']:>10.0f} "
            f"{leg['energy_j'] / 3600:>7.2f} {leg['distance_m']:>8.1f} {leg['duration_s']:>8.0f}"
        )
    lines.append(
        f"{'tour':<24} {res['energy_j']:>10.0f} {res['energy_wh']:>7.2f} "
        f"{res['distance_m']:>8.1f} {res['duration_s']:>8.0f}"
    )
    lines.append(f"order: {' -> '.join(res['order'])}" + (" (and back)" if res["return"] else ""))
    lines.append(f"chosen by: {res['method']}; energies between sites from one search per site")
    sp = res.get("speed")
    if sp:
        lo, hi = sp["speed_range"]
        lines.append(
            f"speed: each motion at its least-energy speed within {lo:g}-{hi:g} m/s"
            + (f" (lambda {sp['time_weight']:.1f} J/s)" if sp["time_weight"] else "")
        )
    win = res.get("windows")
    if win:
        for stop in win["stops"][1:]:
            wait = (f", waits {stop['wait_s']:.1f} s ({stop['wait_j']:.0f} J at "
                    f"{stop['standing_power_w']:.0f} W)" if stop["wait_s"] > 0 else "")  # fmt: skip
            lines.append(f"at {stop['site']}: arrives {stop['arrive_s']:.1f} s{wait}")
        lines.append(f"every arrival window kept ({win['wait_energy_j']:.0f} J waiting)")
    tb = res.get("time_budget")
    if tb:
        lines.append(
            f"time budget {tb['time_budget_s']:g} s met: the tour takes "
            f"{res['duration_s']:.1f} s (lambda {tb['lambda_j_per_s']:.1f} J/s after "
            f"{len(tb['tours'])} tours priced)"
        )
    moved = [s for s in res["sites"] if s["moved_m"] > 0.01]
    if moved:
        lines.append(f"{len(moved)} site(s) moved onto their cell centres, at most "
                     f"{max(s['moved_m'] for s in moved):.2f} m")  # fmt: skip
    b = res.get("battery_legs")
    if b:
        for leg in b["legs"]:
            lines.append(
                f"after leg {leg['leg']} (at {leg['to']}): {leg['spent_j'] / 3600:.2f} Wh "
                f"spent, {100 * leg['probability']:.1f} % chance within the battery"
            )
        k = b["reserve_crossed_at"]
        lines.append("the whole tour stays above the reserve at the required confidence"
                     if k is None else f"the reserve is crossed on leg {k}")  # fmt: skip
    for key, label in (("geojson", "GeoJSON"), ("plot", "plot"), ("bag", "ROS 2 bag"),
                       ("nav2_graph", "Nav2 graph")):  # fmt: skip
        if res.get(key):
            lines.append(f"{label:<8} {res[key]}")
    return "\n".join(lines)


def _windows(given: tuple[str, ...]) -> dict[str, tuple[str, str]] | None:
    """``--window NAME=AFTER:BEFORE`` options as ``{name: (after, before)}`` (None: none)."""
    out: dict[str, tuple[str, str]] = {}
    for text in given:
        name, eq, span = text.rpartition("=")
        after, colon, before = span.partition(":")
        if not (eq and colon and name.strip()):
            raise click.BadParameter(
                f"{text!r} is not NAME=AFTER:BEFORE (seconds from the start, either empty)",
                param_hint="--window",
            )
        out[name.strip()] = (after, before)
    return out or None


@options.command(
    "mission",
    "energy-planner mission --dem hill --sites hill_sites --return --json",
)
@options.dem_option
@options.path_option(
    "--sites",
    required=True,
    callback=options.bundled,
    help="CSV x,y[,yaw_deg][,name][,arrive_after][,arrive_before] in the DEM's CRS, or "
    "GeoJSON points (lon/lat unless the file declares a crs; properties name, arrive_after, "
    "arrive_before), or a bundled file's name (hill_sites). The first site is the start. "
    "arrive_after/arrive_before: the site's arrival window, seconds from the start.",
)
@options.value_option(
    "--order",
    type=click.Choice(["best", "given"]),
    default="best",
    help="best: the least-energy order (exact up to 15 sites); given: as listed.",
)
@click.option("--return", "return_to_start", is_flag=True, help="Come back to the first site.")
@options.value_option(
    "--eps",
    type=click.FloatRange(min=1.0),
    default=1.0,
    help="Heuristic weight of the per-site searches that choose the order: every energy "
    "at most EPS times the least (1: the least; 1.05 expands far fewer states on a large "
    "map). Each leg is then planned as `plan` plans it (its defaults).",
)
@click.option(
    "--scheduler",
    help="Address of a dask.distributed scheduler to run the per-site searches on "
    "(default: in this process); start its processes with the settings of "
    "energy_planner.mission.matrix.CLUSTER_CONFIG (docs/routes.md).",
)
@click.option(
    "--time-budget",
    type=click.FloatRange(min=0, min_open=True),
    help="Seconds for the whole tour: the order and each leg's route and speeds chosen "
    "together (the least energy in time: energy + lambda x time, one lambda for every leg, "
    "by bisection); speeds within --speed MIN:MAX (default auto).",
)
@click.option(
    "--window",
    "window",
    multiple=True,
    metavar="NAME=AFTER:BEFORE",
    help="Arrival window of the site NAME, seconds from the start (either side empty: open; "
    "repeatable; replaces the sites file's arrive_after/arrive_before). The order and each "
    "leg's speeds (within --speed, default auto) keep every window; a robot early at a "
    "site waits there at the model's standing power.",
)
@options.model_option
@options.ranged_request_options
@options.path_option(
    "--geojson", help="GeoJSON of the legs and sites (lon/lat; see --geojson-crs)."
)
@options.geojson_crs_option
@options.trust_options
@options.plot_option("PNG of the tour over the slope map.")
@options.html_option(
    "The sites and legs over the hillshade; hover a leg for its energy "
    "and, with --battery-wh, its battery chance."
)
@options.bag_options
@options.path_option(
    "--nav2-graph",
    help="Write the sites and legs as a Nav2 Route Server graph (GeoJSON in the --bag-frame "
    "frame): every ordered pair of sites an edge whose cost is its energy in J, with its "
    "duration, interval and battery chance in its metadata (the pairs outside the tour are "
    "planned too).",
)
@options.json_option
def command(
    dem: Path,
    sites: Path,
    order: str,
    return_to_start: bool,
    eps: float,
    scheduler: str | None,
    model_path: Path | None,
    request: Request,
    geojson: Path | None,
    geojson_crs: str,
    trust: options.Trust,
    plot: Path | None,
    html: Path | None,
    bag: Path | None,
    bag_frame: str,
    nav2_graph: Path | None,
    as_json: bool,
    time_budget: float | None = None,
    window: tuple[str, ...] = (),
) -> None:
    """Visit the sites of --sites in the least-energy (or given) order over DEM.

    The energy from each site to every other comes from one search per site (the
    planner's own motions and kernel; uphill differs from downhill), the order from
    Held-Karp (exact) or OR-Tools beyond 15 sites, and each leg is then planned from its
    site to the next as `plan` plans it.
    """
    from energy_planner.api import mission
    from energy_planner.errors import EnergyPlannerError
    from energy_planner.mission import read_sites
    from energy_planner.uncertainty import BatteryError

    terrain = load_terrain(dem)
    model = load_model_option(model_path)
    try:
        s = read_sites(sites, terrain)
    except EnergyPlannerError as exc:
        raise click.BadParameter(str(exc), param_hint="--sites") from exc
    choice: dict[str, Any] = {"time_budget": time_budget, "windows": _windows(window)}
    if options.speed_choice() is not None:
        choice["speed"] = options.speed_choice()
    try:
        res = mission(terrain, s, order=order, return_to_start=return_to_start, eps=eps,
                      client=scheduler, model=model, request=request, **choice,
                      level=trust.level,
                      battery_wh=trust.battery_wh, reserve_wh=trust.reserve_wh,
                      confidence=trust.confidence, progress=True)  # fmt: skip
    except BatteryError as exc:
        raise click.BadParameter(str(exc), param_hint="--battery-wh/--reserve-wh") from exc
    except EnergyPlannerError as exc:
        raise planning_error(exc) from exc
    out = res.to_dict()
    out["dem"] = str(dem)
    options.judge(res, trust)
    options.write_output(out, "geojson", geojson,
                         lambda p: res.write_geojson(p, native=geojson_crs == "dem"))  # fmt: skip
    options.write_output(out, "plot", plot, res.plot)
    options.write_output(out, "html", html, res.write_html)
    options.write_bag_output(out, bag, lambda p: res.write_bag(p, frame=bag_frame))
    if nav2_graph is not None:
        try:
            graph = res.write_nav2_graph(
                nav2_graph, eps=eps, level=trust.level, battery_wh=trust.battery_wh,
                reserve_wh=trust.reserve_wh, confidence=trust.confidence, frame=bag_frame,
                progress=True,
            )  # fmt: skip
        except EnergyPlannerError as exc:
            raise click.BadParameter(str(exc), param_hint="--nav2-graph") from exc
        out["nav2_graph"] = graph["path"]
        out["nav2_graph_edges"] = graph["edges"]
        out.setdefault("bag_frame", graph["frame"])
    options.emit(out, as_json, lambda r: _text(r) + "\n" + res.assessment.text())
