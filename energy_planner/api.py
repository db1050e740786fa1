"""The public verbs: ``import energy_planner as ep``.

One :class:`~energy_planner.problem.Problem` binds a terrain, a model and a planning
request (robot, limits, keep-outs, channels) once (it lives below planning, in
:mod:`energy_planner.problem`, and is re-exported here); every verb takes a DEM path or a
:class:`Problem` and returns
the library's own result object, which writes and draws itself. Coordinates are in the
DEM's own CRS unless ``crs=`` names another (lon/lat, another UTM zone, ...); yaw is in
radians (the Python API's convention), counter-clockwise from that CRS's x axis.

The library, not the caller, decides how to read the map: :func:`plan` on a DEM path too
large for the memory cap reads it by windows (:mod:`energy_planner.planning.corridor`), as
the ``plan`` command does.

Examples
--------
>>> import energy_planner as ep
>>> prob = ep.Problem.from_dem(ep.map_path("plane"), max_slope_deg=30)
>>> e = prob.path_energy([(500010.0, 5000050.0), (500030.0, 5000050.0)])
>>> round(e.distance_m, 2) > 20, e.energy_j > 0
(True, True)
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.problem import REQUEST_KEYS, Problem, request_with, verb_doc
from energy_planner.terrain.memory import DEFAULT_CAP
from energy_planner.trust import TRUST_KEYS

__all__ = [
    "CLI_NAMES",
    "Problem",
    "compare_routes",
    "discover",
    "energy_map",
    "fit",
    "load_model",
    "mission",  # noqa: F822 (module __getattr__)
    "open_terrain",
    "pareto",
    "path_energy",
    "plan",
    "reach",
]


def open_terrain(path: str | Path, *, band: int | None = None):
    """Open a DEM (any CRS) as a :class:`~energy_planner.terrain.Terrain`.

    A geographic DEM is put on a metric working grid; slopes and aspects are metric.
    """
    from energy_planner.terrain import load_dem

    return load_dem(path, band=band)


def load_model(path: str | Path | None = None):
    """The bundled B1-class model (``path=None``), a model file, or a bundled model by name.

    Names: ``"b1_default"`` (0.3 m/s), ``"b1_speeds"`` (0.15-1.2 m/s, walk and trot;
    :data:`energy_planner.model.model.BUNDLED_MODELS`).
    """
    from energy_planner.model import EnergyModel

    return EnergyModel.default() if path is None else EnergyModel.load(path)


#: How every option of the commands that have a verb here (``plan``, ``energy``,
#: ``compare-routes``, ``reach``, ``mission``, ``energy-map``) reaches Python. An option
#: whose name (dashes as underscores) is a keyword of the verb is that keyword; the others
#: are listed here, ONE table: ``"keyword"`` (the verb's keyword of another name), or
#: ``"result.METHOD"`` (an output: the result writes it, ``res.METHOD(path)``), or
#: ``"ep.VERB:KEYWORD"`` (the option turns the command into another verb of this module,
#: e.g. ``plan --pareto N`` is ``ep.pareto(..., n=N)``), or
#: ``"output"`` (how the command prints: no Python counterpart). A dict maps a command
#: to its meaning where commands differ. ``tests/test_api_cli_names.py`` checks that
#: every option of those commands is one or the other.
CLI_NAMES: dict[str, str | dict[str, str]] = {
    "--max-slope": "max_slope_deg",
    "--max-cross-slope": "max_cross_slope_deg",
    "--max-backward-slope": "max_backward_slope_deg",
    "--max-crab": "max_crab_deg",
    "--set": "channels",
    "--channel": "channels",
    "--return": "return_to_start",
    "--points-crs": "crs",
    "--dask": "use_dask",
    "--scheduler": {"mission": "client", "energy-map": "client"},
    "--out": {"plan": "result.write_geojson", "reach": "result.write_geotiff"},
    "--geojson": {"reach": "result.write_geojson", "mission": "result.write_geojson"},
    "--geojson-crs": "result.write_geojson",  # native=True for 'dem'
    "--chance-out": "result.write_chance_geotiff",
    "--domain-out": "result.write_domain_geotiff",
    "--plot": "result.plot",
    "--html": "result.write_html",
    "--bag": "result.write_bag",
    "--bag-frame": "result.write_bag",  # frame=
    "--nav2-graph": "result.write_nav2_graph",
    "--pareto": {"plan": "ep.pareto:n"},
    "--window": {"mission": "windows"},
    "--refuse": "output",  # exit status 1 below --confidence: result.assessment.battery.ok
    "--json": "output",  # result.to_dict()
    "--quiet": "output",  # progress=False is the Python default
}


def __getattr__(name: str) -> Any:
    """``mission``, imported on first use (``import energy_planner.api`` stays light).

    The verb lives in the missions package (:mod:`energy_planner.mission.verb`).
    """
    if name == "mission":
        from energy_planner.mission.verb import mission

        return mission
    raise AttributeError(f"module 'energy_planner.api' has no attribute {name!r}")


def _take(values: dict[str, Any], keys: tuple[str, ...]) -> dict[str, Any]:
    """The entries of a verb's ``locals()`` named in ``keys`` (those it has)."""
    return {k: values[k] for k in keys if k in values}


def _problem(dem: Any, model: Any, request: Any, **given: Any) -> Problem:
    """The verb's :class:`Problem` (:meth:`Problem.coerce`: keywords applied)."""
    return Problem.coerce(_dem(dem), model, request, **given)


def _dem(dem: Any) -> Any:
    """A DEM path or bundled map name as a path; anything else as it is."""
    if isinstance(dem, str | Path):
        from energy_planner.maps import resolve

        return resolve(dem)
    return dem


def _pose(problem: Problem, p: Any, crs: Any) -> tuple:
    """A point ``(x, y[, yaw])`` in the DEM's CRS (or ``crs``) in the working CRS."""
    return tuple(float(v) for v in problem.to_work(p, crs)[0])


def _bound(result: Any, problem: Problem) -> Any:
    """``result`` with its Problem (terrain, model, request) remembered."""
    result.problem = problem
    return result


@verb_doc
def plan(
    dem: Any,
    start: Any,
    goal: Any,
    *,
    crs: Any = None,
    model: Any = None,
    request: Any = None,
    speed: float | tuple[float, float] | str | None = None,
    yaw_rate: float | None = None,
    max_slope_deg: float | None = None,
    max_cross_slope_deg: float | None = None,
    keep_out: Any = None,
    max_backward_slope_deg: float | None = None,
    max_crab_deg: float | None = None,
    channels: Any = None,
    allow_unknown_category: bool = False,
    planner: str = "auto",
    time: float | None = None,
    seed: int = 0,
    step: float | None = None,
    eps: float | None = None,
    deadline: float | None = None,
    time_weight: float | None = None,
    memory_cap: Any = DEFAULT_CAP,
    stay_in_domain: bool = False,
    level: float = 0.9,
    battery_wh: float | None = None,
    reserve_wh: float = 0.0,
    confidence: float = 0.9,
    n_headings: int = 16,
    moves: str = "all",
    iterations: int | None = None,
    callback: Any = None,
    progress: bool = False,
):
    """Plan an energy-minimal path from ``start`` to ``goal`` (the ``plan`` command).

    Parameters
    ----------
    {dem}
    start, goal : sequence of float
        ``(x, y)`` or ``(x, y, yaw)`` in the DEM's CRS (or ``crs``), yaw in radians CCW
        from its x axis (``--start``, ``--goal``); without a yaw the planner chooses.
    crs : str, optional
        CRS of ``start`` and ``goal`` (``--points-crs``), e.g. ``"EPSG:4326"``.
    {common}
    {planning}
    step : float, optional
        Position spacing of the search, metres (``--step``; default: the cell size).
    eps : float, optional
        Heuristic weight of the search (``--eps``; default 1.05, 1 = optimal).
    deadline : float, optional
        Seconds (``--deadline``): the least-energy path that arrives in time, route and
        each motion's speed chosen together (energy + lambda x time, lambda by
        bisection); speeds within ``speed`` (default ``"auto"``).
    time_weight : float, optional
        lambda, J per second: minimise energy + lambda x time (one point of
        :func:`pareto`'s front).
    memory_cap : int, DEFAULT_CAP or NO_CAP
        Memory planning may use, bytes (``--memory-cap``); a DEM file too large for it
        is planned by windows (``info["corridor"]`` says whether proven).
    stay_in_domain : bool
        Keep the plan inside the model's calibration domain (``--stay-in-domain``;
        what changed is in ``info["stay_in_domain"]``).
    {trust}
    n_headings, moves, iterations, callback
        Search headings, move set, OMPL iterations and progress callback
        (:func:`energy_planner.planning.plan`).
    progress : bool
        Progress on stderr (the command shows it unless ``--quiet``).

    Notes
    -----
    ``speed`` is a fixed speed (m/s, as ``--speed V``: every motion walks at it) or a
    range the motions choose from, ``(vmin, vmax)`` or ``"auto"`` (``--speed MIN:MAX``,
    ``--speed auto``: the range the model's logs cover); each motion then walks at its
    own least-energy speed (closed form) and the path carries its speed profile
    (``times``, ``speed_profile()``).

    Returns
    -------
    PlanResult
        Remembers its Problem: ``res.write_geojson(path)``, ``res.plot(path)``,
        ``res.write_bag(path)``, ``res.write_html(path)``, ``res.write_json(path)``.

    Examples
    --------
    >>> import energy_planner as ep
    >>> res = ep.plan("hill", (500058, 5000046), (500058, 5000084), max_slope_deg=30,
    ...               channels={{"load_kg": 0}}, time=2)  # doctest: +SKIP
    """
    from energy_planner.energy.path import check_cost_power

    given = _take(locals(), REQUEST_KEYS)
    choice: dict[str, Any] = {}  # the motions choose their speed (a range, a deadline)
    if speed is not None and not isinstance(speed, int | float):
        choice["speed"] = given.pop("speed")
    if deadline is not None:
        choice.update(deadline=deadline, speed=choice.get("speed", "auto"))
    if time_weight is not None:
        choice.update(time_weight=time_weight, speed=choice.get("speed", "auto"))
    kwargs = dict(planner=planner, time=time, seed=seed, step=step, eps=eps,
                  n_headings=n_headings, moves=moves, iterations=iterations, callback=callback,
                  **_take(locals(), TRUST_KEYS))  # fmt: skip
    notes: list[str] | None = [] if stay_in_domain else None
    if isinstance(dem, str | Path):
        from energy_planner.planning.corridor import needs_windows, plan_in_corridor

        path = _dem(dem)
        if needs_windows(path, memory_cap):
            m = load_model(model) if isinstance(model, str | Path) or model is None else model
            req = request_with(request, **given)
            if crs is not None:
                raise ValueError("crs= is not supported on a DEM read by windows; give the "
                                 "points in the DEM's CRS")  # fmt: skip
            if choice:
                from energy_planner.errors import PlanningConfigError

                raise PlanningConfigError(
                    f"{dem}: a DEM read by windows (over memory_cap) is planned at the "
                    "request's speed; expected a fixed speed= (m/s) and no deadline= or "
                    "time_weight=, or a larger memory_cap",
                    value=choice.get("speed"),
                    param="speed",
                )
            if stay_in_domain:
                req = _in_domain(req, m, None, notes)
                if req.channels is not None and req.channels.rasters:
                    notes.append("raster channels are not masked to the domain when "
                                 "planning by windows")  # fmt: skip
            s, g = (tuple(np.asarray(p, dtype=float)) for p in (start, goal))
            res, terrain = plan_in_corridor(path, m, s, g, req, cap=memory_cap,
                                            progress=progress, **kwargs)  # fmt: skip
            prob = Problem(terrain, m, req)
            check_cost_power(prob.cost)
            if notes is not None:
                res.info["stay_in_domain"] = notes
            return _bound(res, prob)
    from energy_planner.planning.plan import plan as _plan

    prob = _problem(dem, model, request, **given)
    if stay_in_domain:
        prob = prob.replace(request=_in_domain(prob.request, prob.model, prob.terrain, notes))
    # a model that prices walking on this map at <= 0 W would plan a free route
    check_cost_power(prob.cost)
    res = _plan(prob, _pose(prob, start, crs), _pose(prob, goal, crs), progress=progress,
                **kwargs, **choice)  # fmt: skip
    if notes is not None:
        res.info["stay_in_domain"] = notes
    return _bound(res, prob)


@verb_doc
def pareto(
    dem: Any,
    start: Any,
    goal: Any,
    n: int = 9,
    *,
    crs: Any = None,
    model: Any = None,
    request: Any = None,
    speed: Any = "auto",
    yaw_rate: float | None = None,
    max_slope_deg: float | None = None,
    max_cross_slope_deg: float | None = None,
    keep_out: Any = None,
    max_backward_slope_deg: float | None = None,
    max_crab_deg: float | None = None,
    channels: Any = None,
    allow_unknown_category: bool = False,
    planner: str = "auto",
    time: float | None = None,
    seed: int = 0,
    step: float | None = None,
    eps: float | None = None,
    level: float = 0.9,
    battery_wh: float | None = None,
    reserve_wh: float = 0.0,
    confidence: float = 0.9,
    progress: bool = False,
):
    """The energy-time front from ``start`` to ``goal`` (``plan --pareto N``).

    ``n`` plans over a sweep of lambda, each minimising energy + lambda x time over
    routes and each motion's speed; only the front's convex hull is found
    (:func:`energy_planner.planning.speed.pareto`). ``plan(..., deadline=...)`` gives the
    least-energy path that arrives in time.

    Parameters
    ----------
    {dem}
    start, goal : sequence of float
        ``(x, y)`` or ``(x, y, yaw)`` in the DEM's CRS (or ``crs``), yaw in radians.
    n : int
        Points of the front (``--pareto N``), at least 2.
    crs : str, optional
        CRS of ``start`` and ``goal`` (``--points-crs``).
    {common}
    {planning}
    step : float, optional
        Position spacing of the search, metres (``--step``).
    eps : float, optional
        Heuristic weight of the search (``--eps``).
    {trust}
    progress : bool
        Progress on stderr.

    Notes
    -----
    ``speed`` here is the range of speeds the motions choose from: ``(vmin, vmax)`` or
    ``"auto"`` (the range the model's logs cover; the default).

    Returns
    -------
    ParetoFront
        Its plans (each a :class:`PlanResult` with its interval, duration and speed
        profile), ``to_dict()``, ``text()`` and ``plot(path)``.
    """
    from energy_planner.planning.speed import pareto as _pareto

    given = _take(locals(), REQUEST_KEYS)
    given.pop("speed", None)  # the range is the front's, not the request's nominal speed
    prob = _problem(dem, model, request, **given)
    return _pareto(prob, _pose(prob, start, crs), _pose(prob, goal, crs), n, speed=speed,
                   planner=planner, time=time, seed=seed, step=step, eps=eps,
                   progress=progress, **_take(locals(), TRUST_KEYS))  # fmt: skip


def _in_domain(request: Any, model: Any, terrain: Any, notes: list[str] | None) -> Any:
    """``request`` kept inside the model's calibration domain; ``notes`` say what changed."""
    from energy_planner.request import Request
    from energy_planner.uncertainty import stay_in_domain

    req, said = stay_in_domain(request if request is not None else Request(), model, terrain)
    if notes is not None:
        notes.extend(said)
    return req


@verb_doc
def path_energy(
    dem: Any,
    waypoints: Any,
    yaw: Any = None,
    t: Any = None,
    *,
    crs: Any = None,
    bag_topic: str | None = None,
    band: int | None = None,
    model: Any = None,
    request: Any = None,
    speed: float | None = None,
    yaw_rate: float | None = None,
    max_backward_slope_deg: float | None = None,
    max_crab_deg: float | None = None,
    channels: Any = None,
    allow_unknown_category: bool = False,
    level: float = 0.9,
    battery_wh: float | None = None,
    reserve_wh: float = 0.0,
    confidence: float = 0.9,
):
    """Energy of walking given waypoints over ``dem`` (the ``energy`` command).

    Parameters
    ----------
    {dem}
    waypoints : path or array-like
        A waypoint file as ``energy --waypoints`` reads it (CSV ``x,y[,yaw_deg][,t]``,
        GeoJSON LineString, ROS 2 bag; its yaw and times are used), or points ``(x, y)``
        in the DEM's CRS (or ``crs``).
    yaw, t : array-like, optional
        With points: yaw per point (radians, CCW from x) and times (s).
    crs : str, optional
        CRS of the points (a file declares its own).
    bag_topic : str, optional
        The topic of a ROS bag ``waypoints`` (``--bag-topic``).
    band : int, optional
        1-based band of a multi-band DEM file (``--band``).
    model : EnergyModel or path, optional
        The energy model (``--model``; default: the bundled B1-class model).
    request : Request, optional
        A whole request; the keywords below replace its fields.
    speed, yaw_rate : float, optional
        Nominal speed (m/s) and turning rate (rad/s) where the waypoints have no times
        (``--speed``, ``--yaw-rate``).
    max_backward_slope_deg, max_crab_deg : float, optional
        Gait limits (``--max-backward-slope``, ``--max-crab``): a segment that breaks
        one is an error naming it.
    channels : dict or Channels, optional
        Channel values (``--set``, ``--channel``), as :func:`plan` takes them.
    allow_unknown_category : bool
        Accept a category the model does not name (``--allow-unknown-category``).
    {trust}

    Returns
    -------
    PathEnergy
        With its interval, domain report and, given a battery, its verdict; it
        remembers its Problem (``write_geojson(path)``, ``write_json(path)``).
    """
    given = _take(locals(), REQUEST_KEYS)
    if band is not None and isinstance(dem, str | Path):
        dem = open_terrain(dem, band=band)
    prob = _problem(dem, model, request, **given)
    if isinstance(waypoints, str | Path):
        from energy_planner.energy.waypoints import read_waypoints, waypoints_to_work

        wp = read_waypoints(waypoints, bag_topic)
        xy, yaw = waypoints_to_work(prob.terrain, wp)
        t, crs = wp.t, prob.terrain.crs
        waypoints = xy
    pe = prob.path_energy(waypoints, yaw, t, crs=crs, **_take(locals(), TRUST_KEYS))
    return _bound(pe, prob)


@verb_doc
def compare_routes(
    dem: Any,
    start: Any,
    goal: Any,
    *,
    crs: Any = None,
    model: Any = None,
    request: Any = None,
    speed: float | tuple[float, float] | str | None = None,
    yaw_rate: float | None = None,
    max_slope_deg: float | None = None,
    max_cross_slope_deg: float | None = None,
    keep_out: Any = None,
    max_backward_slope_deg: float | None = None,
    max_crab_deg: float | None = None,
    channels: Any = None,
    allow_unknown_category: bool = False,
    planner: str = "auto",
    time: float = 10.0,
    seed: int = 0,
    step: float | None = None,
    deadline: float | None = None,
    pareto: int | None = None,
    level: float = 0.9,
    battery_wh: float | None = None,
    reserve_wh: float = 0.0,
    confidence: float = 0.9,
    progress: bool = False,
):
    """The direct line, the shortest and the energy-optimal path (``compare-routes``).

    Parameters
    ----------
    {dem}
    start, goal : sequence of float
        ``(x, y)`` or ``(x, y, yaw)`` in the DEM's CRS (or ``crs``), yaw in radians.
    crs : str, optional
        CRS of ``start`` and ``goal`` (``--points-crs``).
    {common}
    {planning}
    step : float, optional
        Position spacing of the searches, metres.
    deadline : float, optional
        Seconds (``--deadline``): each route walked at the least-energy speed profile
        that arrives in time, and the energy-optimal route the least-energy one in time
        (the plan under the deadline among them); speeds within ``speed`` (default
        ``"auto"``).
    pareto : int, optional
        Points of each route's energy-time front (``--pareto N``; ``fronts`` of the
        result); speeds within ``speed`` (default ``"auto"``).
    {trust}
    progress : bool
        Progress on stderr.

    Notes
    -----
    ``speed`` is a fixed speed (m/s, ``--speed V``) or a range each motion of every route
    chooses its speed from, ``(vmin, vmax)`` or ``"auto"`` (``--speed MIN:MAX``,
    ``--speed auto``); each route then carries its speed profile.

    Returns
    -------
    RouteComparison
        The routes (paper Fig. 1), each assessed; remembers its Problem
        (``plot(path)``, ``write_bag(path)``, ``write_html(path)``, ``write_json(path)``).
    """
    from energy_planner.planning.compare import compare_routes as _cr

    given = _take(locals(), REQUEST_KEYS)
    choice = {"deadline": deadline, "pareto": pareto}
    if speed is not None and not isinstance(speed, int | float):
        choice["speed"] = given.pop("speed")  # a range: chosen per motion
    prob = _problem(dem, model, request, **given)
    comp = _cr(prob, _pose(prob, start, crs), _pose(prob, goal, crs), planner=planner,
               time=time, seed=seed, step=step, progress=progress, **choice,
               **_take(locals(), TRUST_KEYS))  # fmt: skip
    return _bound(comp, prob)


@verb_doc
def reach(
    dem: Any,
    start: Any,
    *,
    crs: Any = None,
    budget_wh: float | None = None,
    return_to_start: bool = False,
    within_budget: bool = False,
    free_turn: bool = False,
    model: Any = None,
    request: Any = None,
    speed: float | tuple[float, float] | str | None = None,
    yaw_rate: float | None = None,
    max_slope_deg: float | None = None,
    max_cross_slope_deg: float | None = None,
    keep_out: Any = None,
    max_backward_slope_deg: float | None = None,
    max_crab_deg: float | None = None,
    channels: Any = None,
    allow_unknown_category: bool = False,
    battery_wh: float | None = None,
    reserve_wh: float = 0.0,
    confidence: float = 0.9,
    memory_cap: Any = DEFAULT_CAP,
    max_time: float | None = None,
    n_headings: int = 16,
    progress: bool = False,
):
    """Least energy from ``start`` to every cell of ``dem`` (the ``reach`` command).

    Parameters
    ----------
    {dem}
    start : sequence of float
        ``(x, y)`` in the DEM's CRS (or ``crs``); moved to the centre of its cell.
    crs : str, optional
        CRS of ``start`` (``--points-crs``).
    budget_wh : float, optional
        Battery budget, Wh (``--budget-wh``): the result's area, contour and GeoJSON
        are those within it.
    return_to_start : bool
        The cost of going to each cell and coming back (``--return``).
    within_budget : bool
        Search only as far as ``budget_wh`` (``--within-budget``; cells above it NaN).
    free_turn : bool
        With ``return_to_start``: headings free at the cell (``--free-turn``).
    {common}
    battery_wh : float, optional
        Battery energy, Wh (``--battery-wh``): the area reached with a chance of at
        least ``confidence`` (``result.battery``).
    reserve_wh : float
        Energy to keep in the battery, Wh (``--reserve-wh``).
    confidence : float
        Required chance that the battery suffices (``--confidence``).
    memory_cap : int, DEFAULT_CAP or NO_CAP
        Memory the search may use, bytes (``--memory-cap``); a DEM file too large for
        it is read as one window about the start that the budget can reach (needs
        ``budget_wh``).
    max_time : float, optional
        Seconds (``--max-time``): only the cells some path reaches (and leaves, with
        ``return_to_start``) within this time, every motion at the top of ``speed``;
        the least time per cell is ``result.time_s``.
    n_headings : int
        Search headings.
    progress : bool
        Progress on stderr.

    Notes
    -----
    ``speed`` is a fixed speed (m/s, ``--speed V``) or a range each motion chooses its
    least-energy speed from, ``(vmin, vmax)`` or ``"auto"`` (``--speed MIN:MAX``,
    ``--speed auto``; the range the model's logs cover).

    Returns
    -------
    ReachMap
        Remembers its Problem and budget: ``write_geotiff(path)``, ``write_geojson(path)``,
        ``plot(path)``, ``write_html(path)``, ``write_json(path)``.
    """
    from energy_planner.errors import PlanningConfigError
    from energy_planner.planning.reach import reach as _reach

    if free_turn and not return_to_start:
        raise PlanningConfigError("free_turn applies to return_to_start only",
                                  param="free_turn", value=free_turn)  # fmt: skip
    if within_budget and budget_wh is None:
        raise PlanningConfigError("give budget_wh with within_budget", param="within_budget",
                                  value=within_budget)  # fmt: skip
    trust = _take(locals(), TRUST_KEYS)
    given = _take(locals(), REQUEST_KEYS)
    ranged = None
    if speed is not None and not isinstance(speed, int | float):
        ranged = given.pop("speed")  # each motion chooses its speed in the range
    if isinstance(dem, str | Path):
        from energy_planner.planning.corridor import needs_windows, reach_in_window

        path = _dem(dem)
        if needs_windows(path, memory_cap):
            if budget_wh is None:
                raise PlanningConfigError(
                    f"DEM {str(path)!r} is too large for the memory cap to be searched "
                    "whole; give budget_wh to search only the window the budget can reach",
                    param="budget_wh", value=None,
                )  # fmt: skip
            if crs is not None:
                raise ValueError("crs= is not supported on a DEM read by windows; give the "
                                 "start in the DEM's CRS")  # fmt: skip
            if ranged is not None or max_time is not None:
                raise PlanningConfigError(
                    f"{dem}: a DEM read as a window (over memory_cap) is searched at the "
                    "request's speed; expected a fixed speed= (m/s) and no max_time=, or a "
                    "larger memory_cap",
                    param="speed", value=ranged,
                )  # fmt: skip
            m = load_model(model) if isinstance(model, str | Path) or model is None else model
            req = request_with(request, **given)
            s = tuple(float(v) for v in np.asarray(start, dtype=float)[:2])
            rm, terrain = reach_in_window(
                path, m, s, budget_wh * 3600.0, req, cap=memory_cap,
                round_trip=return_to_start, turn_at_cell=not free_turn, progress=progress,
                n_headings=n_headings, **trust,
            )  # fmt: skip
            rm.budget_wh = budget_wh
            return _bound(rm, Problem(terrain, m, req))
    prob = _problem(dem, model, request, **given)
    pose = _pose(prob, start, crs)[:2]
    if ranged is not None:
        from energy_planner.planning.speed import with_speed

        prob = with_speed(prob, ranged)
    rm = _reach(prob, pose, round_trip=return_to_start,
                turn_at_cell=not free_turn, n_headings=n_headings, progress=progress,
                max_energy=budget_wh * 3600.0 if within_budget else None, max_time=max_time,
                **trust)  # fmt: skip
    rm.budget_wh = budget_wh
    return _bound(rm, prob)


@verb_doc
def energy_map(
    dem: Any,
    out: str | Path,
    *,
    model: Any = None,
    request: Any = None,
    headings: int = 16,
    speed: float | tuple[float, float] | str | None = None,
    max_slope_deg: float | None = None,
    max_cross_slope_deg: float | None = None,
    max_backward_slope_deg: float | None = None,
    max_crab_deg: float | None = None,
    channels: Any = None,
    allow_unknown_category: bool = False,
    band: int | None = None,
    use_dask: bool | None = None,
    client: Any = None,
    memory_cap: Any = DEFAULT_CAP,
    chunk: int = 512,
    compress: str | None = None,
    bands: str | None = None,
    encoding: str | None = None,
    progress: bool = False,
):
    """The heading-dependent energy map of ``dem``, written to ``out`` (``energy-map``).

    A DEM path is handed to the energy map as a path, so that it decides between memory,
    windows and dask.

    Parameters
    ----------
    {dem}
    out : str or path
        The GeoTIFF to write (``--out``).
    model : EnergyModel or path, optional
        The energy model (``--model``; default: the bundled B1-class model).
    request : Request, optional
        A whole request; the keywords below replace its fields.
    headings : int
        Number of map headings, 360/N degrees apart, the first east (``--headings``).
    speed : float, (float, float) or str, optional
        Walking speed along the ground, m/s, as :func:`plan` takes it (``--speed``): a
        number (every cell at it), or a range ``(vmin, vmax)`` / ``"auto"`` (the speeds
        the model's logs cover): each cell, heading and body yaw at its own best speed
        in the range, and the band ``cheapest_speed`` (m/s).
    max_slope_deg, max_cross_slope_deg : float, optional
        Slope limits: cells or headings beyond them cost inf.
    max_backward_slope_deg, max_crab_deg : float, optional
        Gait limits (``--max-backward-slope``, ``--max-crab``).
    channels : dict or Channels, optional
        Channel values (``--set``, ``--channel``), as :func:`plan` takes them.
    allow_unknown_category : bool
        Accept a category the model does not name (``--allow-unknown-category``).
    band : int, optional
        1-based band of a multi-band DEM (``--band``).
    use_dask : bool, optional
        Compute out of core with dask (``--dask``; None: when the DEM would not fit
        ``memory_cap``).
    client : distributed.Client or str, optional
        A dask.distributed client or scheduler address (``--scheduler``); implies dask.
    memory_cap : int, DEFAULT_CAP or NO_CAP
        Memory the DEM may take (``--memory-cap``).
    chunk : int
        Chunk side of the out-of-core path, cells (``--chunk``).
    compress : {{"zstd", "deflate", "none"}}, optional
        GeoTIFF compression (``--compress``; default zstd).
    bands : {{"best", "all"}}, optional
        Bands written (``--bands``; default best).
    encoding : {{"uint16", "float32"}}, optional
        How the bands are stored (``--encoding``; default uint16: scaled integers, to
        0.125 J/m; :mod:`energy_planner.energymap.encoding`).
    progress : bool
        Progress on stderr.

    Returns
    -------
    EnergyMapResult
        ``plot(path)``, ``write_html(path)``, ``write_json(path)`` (it remembers its DEM).
    """
    from energy_planner.energymap import energy_map as _em

    kwargs: dict[str, Any] = dict(headings=headings, band=band, use_dask=use_dask,
                                  chunk=chunk, progress=progress,
                                  memory_cap_bytes=memory_cap)  # fmt: skip
    if compress is not None:
        kwargs["compress"] = compress
    if bands is not None:
        kwargs["bands"] = bands
    if encoding is not None:
        kwargs["encoding"] = encoding
    if speed is not None and not isinstance(speed, int | float):  # a range, or auto
        kwargs["speed_range"], speed = speed, None
    given = _take(locals(), REQUEST_KEYS)
    own = None
    if isinstance(client, str):
        from distributed import Client

        client = own = Client(client, timeout=30)
    if client is not None:
        kwargs["use_dask"] = True
    try:
        if isinstance(dem, Problem):
            res = _em(_problem(dem, model, request, **given), out, **kwargs)
        else:
            m = load_model(model) if isinstance(model, str | Path) or model is None else model
            res = _em(_dem(dem), out, m, request=request_with(request, **given), **kwargs)
    finally:
        if own is not None:
            own.close()
    res.dem = dem.terrain if isinstance(dem, Problem) else _dem(dem)
    return res


def _samples(logs: Any):
    """Canonical samples from log paths, a DataFrame of them, or a simulated campaign."""
    import pandas as pd

    from energy_planner.measurements import load_logs
    from energy_planner.measurements.logs import log_files

    if isinstance(logs, pd.DataFrame):
        return logs
    if isinstance(getattr(logs, "logs", None), pd.DataFrame):  # a simulated Campaign
        return logs.logs
    return load_logs(log_files([logs] if isinstance(logs, str | Path) else list(logs)))


def fit(
    logs: Any,
    terms: Any = None,
    *,
    window: float = 2.0,
    n_splits: int = 5,
    seed: int = 0,
    repair: bool = True,
):
    """Fit a model from robot logs (files or folders; CSV, Parquet, ROS bags).

    Runs the data checks and repairs what they find (``repair=False``: report only), as
    ``diagnose`` and ``discover`` do; cleans (paper IV-B) and windows the logs, then fits
    ``terms`` (default: the base model) jointly and validates them by run; returns the
    :class:`~energy_planner.calibration.fit.FitResult` (``.model`` is the model, with the
    held-out run errors its intervals use; ``.data_findings`` the checks' results).
    """
    from energy_planner.calibration import fit_model

    if not (window > 0 and math.isfinite(window)):
        raise ValueError(f"window must be a positive number of seconds, not {window!r}")
    return fit_model(
        _samples(logs), terms, n_splits=n_splits, seed=seed, window=window, repair=repair
    )


def discover(logs: Any, **kwargs: Any):
    """Find the effects the base model lacks in robot logs.

    ``logs``: log files or folders (CSV, Parquet, ROS bags), a DataFrame of canonical
    samples, or a simulated campaign. Data checks (``repair=False``: report only), then
    the staircase (:func:`energy_planner.diagnosis.discover`); returns its ``Discovery``
    (``.table()``, ``.write_json``, ``.write_html``, ``.plot``).
    """
    from energy_planner.diagnosis import discover as _discover

    return _discover(_samples(logs), **kwargs)
