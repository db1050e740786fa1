"""A mission: several sites visited in the best order, each leg planned and priced.

The energy between every pair of sites comes from **one search per site**: the planner's
own search over (x, y, heading) (the same motions and kernel as
:func:`energy_planner.planning.reach.reach` and :func:`energy_planner.planning.plan`),
stopped once every other site is settled (:mod:`energy_planner.mission.matrix`). The
matrix is asymmetric (uphill is not downhill). Each leg of a tour is planned with
:func:`energy_planner.planning.plan` from its site to the next, with ``plan``'s own
defaults (the search, then the refinement of its path): a leg costs what ``plan`` says
for the same two sites. With ``planner="search"``, ``leg_eps=1`` and the sites on cell
centres, a leg's planned energy equals its matrix entry; the refinement makes it lower.

The matrix only bounds the legs (an entry at ``eps`` is at most ``eps`` times the least
energy, so ``entry / eps`` bounds it from below), so the order is settled on plan's legs
(:func:`energy_planner.mission.tour.settle_order`): chosen on the bounds, its legs
planned and put in place of their bounds, chosen again until its legs are all planned,
at most :data:`ORDER_MAX_PRICED` legs planned per leg of the tour. Up to
:data:`~energy_planner.mission.tour.EXACT_MAX_SITES` sites no order then costs less
given the bounds (``info["order_check"]["proven"]``; the bounds hold for the search's
energies, which the refinement can undercut by about 1 %); beyond, the solver's one
order is planned.

The matrix's searches stand on the DEM's cell centres (as
:func:`~energy_planner.planning.reach.reach` moves its start); the moved distance is
reported. Headings are free at every site.

The per-site searches are independent: with a ``dask.distributed`` client they run in
parallel on its workers (a :class:`~distributed.LocalCluster` or a cluster given by
address), with the same result as the serial loop.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.errors import PlanningError
from energy_planner.mission.sites import Sites
from energy_planner.mission.tour import _cost, order_legs, order_sites, settle_order
from energy_planner.problem import takes_problem
from energy_planner.results import Result, path_first
from energy_planner.trust import Assessed, Assessment

__all__ = ["Leg", "MissionResult", "energy_matrix", "mission"]


#: At most this many legs planned per leg of the tour while settling the order
#: (:func:`energy_planner.mission.tour.settle_order`; legs whose bounds could change it).
ORDER_MAX_PRICED = 3


@dataclass(frozen=True)
class Leg(Assessed):
    """One leg of a tour: from site ``a`` to site ``b``, planned as ``plan`` plans it.

    ``assessment``: the leg's own interval and domain report (the plan's); with a battery,
    the verdict on the energy spent from the start up to the end of this leg (the
    robot has walked the legs before it on the same battery). ``wait_s`` / ``wait_j``:
    with arrival windows, how long the robot waits at ``b`` for its window to open and
    what that costs at the standing power (0 otherwise). ``gaits``: each segment's gait
    where the motions chose it (a model that names gaits, over a speed range), as
    :attr:`~energy_planner.planning.plan.PlanResult.gaits`.
    """

    a: int
    b: int
    energy_j: float
    matrix_energy_j: float
    distance_m: float
    duration_s: float
    states: np.ndarray = field(repr=False)
    assessment: Any = field(default=None, repr=False, compare=False)
    times: np.ndarray | None = field(default=None, repr=False, compare=False)
    wait_s: float = 0.0
    wait_j: float = 0.0
    gaits: list[str | None] | None = field(default=None, repr=False, compare=False)

    def speed_profile(self) -> list[dict[str, Any]]:
        """Per segment: distance, duration, ground speed, where the leg chose its speeds.

        And ``gait`` where it chose its gaits. Empty at the nominal speed
        (:func:`energy_planner.planning.speed.speed_profile`).
        """
        from energy_planner.planning.speed import speed_profile

        return speed_profile(self.states, self.times, gaits=self.gaits)


@dataclass(repr=False)
class MissionResult(Result, Assessed):
    """A planned mission: the order, its legs, totals and the energy matrix.

    Attributes
    ----------
    sites : Sites
        The sites (working CRS, on cell centres), names included.
    order : list of int
        Visiting order (site indices; the first is the start).
    legs : list of Leg
        The planned legs in order (with the return leg when ``return_to_start``).
    matrix_j : ndarray, shape (n, n)
        Least energy from row site to column site (one search per site), J.
    method : str
        How the order was chosen.
    return_to_start : bool
        Whether the tour comes back to the first site.
    assessment : Assessment or None
        The whole tour's interval (its energy and duration), its domain report (the
        legs' reports weighted by duration) and, with a battery, its verdict.
    battery_legs : dict or None
        With a battery: :meth:`battery_by_leg` of the tour (the chance after each leg, where the
        reserve is crossed).
    problem : Problem or None
        The terrain, model and request it was planned on
        (:class:`~energy_planner.results.Result`): the writers need no terrain.
    """

    sites: Sites
    order: list[int]
    legs: list[Leg]
    matrix_j: np.ndarray
    method: str
    return_to_start: bool
    info: dict[str, Any] = field(default_factory=dict)
    assessment: Any = field(default=None, repr=False)
    battery_legs: dict[str, Any] | None = field(default=None, repr=False)

    @property
    def energy_j(self) -> float:
        """Total planned energy, J (the legs', and the waits for windows to open)."""
        return float(sum(leg.energy_j + leg.wait_j for leg in self.legs))

    @property
    def distance_m(self) -> float:
        """Total ground distance, m."""
        return float(sum(leg.distance_m for leg in self.legs))

    @property
    def duration_s(self) -> float:
        """Total walking time, s."""
        return float(sum(leg.duration_s for leg in self.legs))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary: order, legs, totals, the matrix and the assessments."""
        names = self.sites.names
        out = {
            "order": [names[i] for i in self.order],
            "order_index": list(self.order),
            "method": self.method,
            "return": self.return_to_start,
            "energy_j": self.energy_j,
            "energy_wh": self.energy_j / 3600.0,
            "distance_m": self.distance_m,
            "duration_s": self.duration_s,
            "legs": [
                {
                    "from": names[leg.a],
                    "to": names[leg.b],
                    "energy_j": leg.energy_j,
                    "matrix_energy_j": leg.matrix_energy_j,
                    "distance_m": leg.distance_m,
                    "duration_s": leg.duration_s,
                    **({"wait_s": leg.wait_s, "wait_j": leg.wait_j} if leg.wait_s else {}),
                    **_leg_speeds(leg),
                    **leg.assessment_dict(),
                }
                for leg in self.legs
            ],  # fmt: skip
            "sites": self.sites.to_dicts(),
            "matrix_j": [
                [None if not math.isfinite(v) else float(v) for v in row] for row in self.matrix_j
            ],  # fmt: skip
            **self.info,
            **self.assessment_dict(),
        }
        if self.battery_legs is not None:
            out["battery_legs"] = self.battery_legs
        return out

    def battery_by_leg(
        self, model, battery_wh: float, reserve_wh: float = 0.0, confidence: float = 0.9
    ) -> dict[str, Any]:
        """The chance of finishing each leg on one battery, and where the reserve is crossed.

        After leg ``k`` the robot has spent the sum of legs ``0..k``; its chance of
        success is :func:`energy_planner.uncertainty.assess.assess` of that sum (its
        duration, and the legs' domain reports weighted by duration). ``reserve_crossed_at``
        names the first leg whose chance falls below ``confidence`` (None: the whole tour
        fits).
        """
        from energy_planner.trust import Trust

        trust = Trust(battery_wh=battery_wh, reserve_wh=reserve_wh, confidence=confidence)
        return _battery_legs(self, model, trust, set_legs=False)[0]

    def write_json(self, path: str | Path) -> Path:
        """Write :meth:`to_dict` to ``path`` atomically; returns the path."""
        from energy_planner.io import write_json

        return write_json(path, self.to_dict())

    def write_geojson(self, path: str | Path, terrain: Any = None, *, native: bool = False) -> Path:
        """Write :meth:`to_geojson` to ``path`` atomically; returns the path."""
        from energy_planner.io import write_geojson

        return write_geojson(path, self.to_geojson(terrain, native=native))

    def to_geojson(self, terrain: Any = None, *, native: bool = False) -> dict[str, Any]:
        """RFC 7946 FeatureCollection: one LineString per leg and one Point per site."""
        from shapely.geometry import LineString, Point

        from energy_planner.io.geojson import feature_collection

        geoms, props = [], []
        for k, leg in enumerate(self.legs):
            geoms.append(LineString(leg.states[:, :2]))
            props.append({"leg": k, "from": self.sites.names[leg.a],
                          "to": self.sites.names[leg.b], "energy_j": leg.energy_j,
                          "distance_m": leg.distance_m, "duration_s": leg.duration_s})  # fmt: skip
        for i in self.order:
            geoms.append(Point(self.sites.xy[i]))
            props.append({"site": self.sites.names[i], "visit": self.order.index(i)})
        crs = self._terrain(terrain).crs
        return feature_collection(zip(geoms, props, strict=True), crs=crs, native=native)

    def write_html(
        self, path: str | Path, problem: Any = None, battery: dict | None = None
    ) -> Path:
        """One self-contained HTML page (:func:`energy_planner.webmap.mission_page`).

        ``problem``: default the one the mission was planned on. ``battery`` is
        :meth:`battery_by_leg`'s result (default: :attr:`battery_legs`, set when the
        mission was planned with a battery): each leg's hover gives its chance.
        """
        from energy_planner.webmap import mission_page

        return mission_page(self._problem_for(problem), self, path,
                            battery or self.battery_legs)  # fmt: skip

    def plot(self, path: str | Path, terrain: Any = None, request: Any = None) -> Path:
        """PNG: legs over a hillshade, sites numbered in visiting order.

        The request it was planned with (or ``request``) adds its keep-outs, slope-limit
        mask and channel rasters (:func:`energy_planner.plotting.draw_request`). The map
        is drawn in the DEM's own CRS (:class:`energy_planner.plotting.MapFrame`: degrees
        for a longitude/latitude DEM), its axes named with their units.
        """
        path, terrain = path_first(path, terrain)
        terrain, request = self._terrain(terrain), self._request(request)
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from energy_planner.io import save_figure
        from energy_planner.plotting import MapFrame, draw_request

        frame = MapFrame(terrain)
        fig, ax = plt.subplots(figsize=(8, 6.5), layout="constrained")
        ext = frame.extent
        im = ax.imshow(frame.slope_deg(), extent=ext, cmap="Greys", origin="upper")
        fig.colorbar(im, ax=ax, label="slope (deg)")
        if draw_request(ax, frame, request):
            ax.set_xlim(ext[0], ext[1])
            ax.set_ylim(ext[2], ext[3])
        names = self.sites.names
        for k, leg in enumerate(self.legs):
            line = ax.plot(*frame.xy(leg.states[:, 0], leg.states[:, 1]), lw=2,
                           label=f"leg {k + 1}: {names[leg.a]} \u2192 {names[leg.b]}, "
                                 f"{leg.energy_j / 1000:.1f} kJ")[0]  # fmt: skip
            line.set_gid(f"leg:{k}")
        cx = 0.5 * (ext[0] + ext[1])
        sxy = np.asarray(self.sites.xy, dtype=float)
        sx, sy = frame.xy(sxy[:, 0], sxy[:, 1])
        for k, i in enumerate(self.order):
            x, y = float(sx[i]), float(sy[i])
            ax.plot(x, y, "o", color="tab:red", gid=f"site:{i}")
            right = x > cx  # labels point into the map, so none is clipped at its edge
            box = dict(boxstyle="round,pad=0.15", fc="white", alpha=0.7, lw=0)
            ax.annotate(f"{k}: {names[i]}", (x, y), textcoords="offset points",
                        xytext=(-5 if right else 5, 5), ha="right" if right else "left",
                        bbox=box)  # fmt: skip
        ax.set_title(f"mission: {self.energy_j / 1000:.1f} kJ, {self.distance_m:.0f} m "
                     f"({self.method})")  # fmt: skip
        frame.finish(ax)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="lower left", fontsize=7, framealpha=0.9)
        out = save_figure(fig, path, dpi=110, bbox_inches="tight", pad_inches=0.15)
        plt.close(fig)
        return out

    def write_bag(
        self,
        path: str | Path,
        terrain: Any = None,
        *,
        request: Any = None,
        frame: str = "map",
        storage: str = "mcap",
    ) -> dict[str, Any]:
        """Write each leg as a ``nav_msgs/msg/Path`` on its own topic into a ROS 2 bag.

        Topics ``/energy_planner/mission/leg_<k>`` (k = 0, 1, ... in visiting order), so
        that a robot can follow one leg, stop at its site and take the next. The stamps
        run on through the mission (leg ``k`` starts when leg ``k - 1`` ends); frame
        and stamps as :meth:`energy_planner.planning.plan.PlanResult.write_bag`
        (``request``: by default the one the mission was planned with). Returns the frame
        and conventions.
        """
        from energy_planner.energy.path import write_paths_bag

        names = self.sites.names
        paths = [
            (f"/energy_planner/mission/leg_{k}", leg.states, leg.duration_s, f"leg {k}",
             {"leg": k, "from": names[leg.a], "to": names[leg.b], "energy_j": leg.energy_j,
              "distance_m": leg.distance_m, "duration_s": leg.duration_s})
            for k, leg in enumerate(self.legs)
        ]  # fmt: skip
        return write_paths_bag(path, paths, self._terrain(terrain), self._request(request),
                               frame=frame, storage=storage, chain=True)  # fmt: skip

    def write_nav2_graph(
        self, path: str | Path, problem: Any = None, **options: Any
    ) -> dict[str, Any]:
        """Write the sites and legs as a Nav2 Route Server graph (GeoJSON) at ``path``.

        Every ordered pair of sites is a directed edge whose ``cost`` is its energy in J
        (both directions, each with its own cost), with its duration, interval and, with
        a battery, its chance in ``metadata``; the pairs outside the tour are planned on
        ``problem`` (default: the one the mission was planned on). ``options``: ``eps``,
        ``level``, ``battery_wh``, ``reserve_wh``, ``confidence``, ``frame``,
        ``progress`` (:func:`energy_planner.mission.graph.route_graph`). Returns the
        path, the counts and the frame.
        """
        from energy_planner.mission.graph import write_nav2_graph

        return write_nav2_graph(path, self._problem_for(problem), self, **options)


def _leg_speeds(leg: Leg) -> dict[str, Any]:
    """A leg's walking speeds for its JSON (empty at the nominal speed)."""
    walk = [p["speed_m_s"] for p in leg.speed_profile() if p["speed_m_s"] > 0]
    if not walk:
        return {}
    out = {"speed_min_m_s": min(walk), "speed_max_m_s": max(walk),
           "times_s": [float(v) for v in leg.times]}  # fmt: skip
    if leg.gaits is not None:  # each segment's gait (between times_s[i] and times_s[i + 1])
        out["gaits"] = list(leg.gaits)
    return out


@takes_problem(1)
def energy_matrix(
    problem,
    sites: Sites,
    *,
    n_headings: int = 16,
    max_energy: float | None = None,
    client: Any = None,
    eps: float = 1.0,
    progress: bool = False,
) -> np.ndarray:
    """Least energy between every ordered pair of sites, one search per site.

    Each search stops once every other site is settled, inside a proven window around
    the sites (:func:`energy_planner.mission.matrix.matrix_search`, which also reports
    the window and the states expanded); the entries equal a full search's (with
    ``eps > 1``: at most ``eps`` times it).

    Parameters
    ----------
    problem : Problem
        Terrain, model and request bound once (as for
        :func:`energy_planner.planning.plan`; the older form ``energy_matrix(terrain,
        model, sites, request=None, ...)`` is accepted).
    sites : Sites
        On cell centres (working CRS).
    n_headings : int
        Search headings.
    max_energy : float, optional
        Stop each search at this energy (J); farther sites get ``inf``.
    client : distributed.Client, optional
        Run the searches on this dask cluster's workers (same result as serial).
    eps : float
        Heuristic weight of the searches, as ``plan``'s (1: the least energies).
    progress : bool
        A progress bar over the sites on stderr.

    Returns
    -------
    ndarray, shape (n, n)
        ``E[i, j]``: energy from site i to site j, J (``inf`` unreachable, 0 diagonal).
    """
    return _matrix(problem, sites, n_headings=n_headings, max_energy=max_energy, client=client,
                   eps=eps, progress=progress).energy_j  # fmt: skip


def _matrix(problem, sites, **kw):
    """:func:`~energy_planner.mission.matrix.matrix_search` on ``problem`` (its speed choice)."""
    from energy_planner.mission.matrix import matrix_search

    cost = problem.cost  # its speed choice, if the motions choose their speed
    speed = (cost.speed_range, cost.time_weight) if cost.ranged else None
    return matrix_search(problem.terrain, problem.model, sites, problem.request, speed=speed,
                         **kw)  # fmt: skip


@takes_problem(1)
def mission(
    problem,
    sites: Sites | str | Path,
    *,
    order: str = "best",
    return_to_start: bool = False,
    planner: str = "auto",
    eps: float = 1.0,
    leg_eps: float | None = None,
    n_headings: int = 16,
    client: Any = None,
    progress: bool = False,
    speed: Any = None,
    time_budget: float | None = None,
    windows: Any = None,
    **trust: Any,
) -> MissionResult:
    """Visit several sites in the given or the least-energy order and plan every leg.

    Parameters
    ----------
    problem : Problem
        Terrain, model and request (robot, limits, channels) bound once
        (:class:`energy_planner.problem.Problem`; the older form ``mission(terrain, model,
        sites, request=None, ...)`` is accepted).
    sites : Sites or path
        The sites, or a CSV/GeoJSON file (:func:`energy_planner.mission.read_sites`).
    order : {"best", "given"}
        ``best``: the least-energy order (exact up to
        :data:`~energy_planner.mission.tour.EXACT_MAX_SITES` sites).
    return_to_start : bool
        Come back to the first site.
    planner, eps, leg_eps, n_headings
        Each leg is planned from its site to the next as
        :func:`energy_planner.planning.plan` plans it: ``planner`` (default, as
        ``plan``'s: the search, then the refinement of its path), ``leg_eps`` (default:
        ``plan``'s :data:`~energy_planner.planning.plan.DEFAULT_EPS`), ``n_headings``;
        so a leg's energy is the one ``plan`` gives for the same sites. ``eps`` weighs
        the matrix's searches (each entry at most ``eps`` times the least energy on the
        search's motions; the order is chosen on them).
    client : distributed.Client, optional
        Run the per-site searches on a dask cluster.
    progress : bool
        Progress on stderr.
    speed : float, (float, float) or "auto", optional
        A number: every leg at that speed. A range (``"auto"``: the one the model's logs
        cover): each motion of the matrix's searches and of every leg walks at its own
        least-energy speed in it (legs planned as ``plan(..., speed=(vmin, vmax))`` plans
        them), and each leg carries its times.
    time_budget : float, optional
        Seconds for the whole tour (speeds within ``speed``, default ``"auto"``): the
        order and every leg's route and speeds minimise energy + lambda x time together
        (the matrix and the legs priced with the same ``lambda``, so each second is worth
        the same on every leg), with ``lambda`` the least one whose tour is in time, by
        bisection (:data:`~energy_planner.planning.speed.DEADLINE_ITERS` steps after the
        bracket); ``info["time_budget"]`` lists the tours priced. ``matrix_j`` then holds
        energy + lambda x time. A :class:`PlanningError` (``limit="deadline"``) gives the
        fastest tour's duration when none is in time.
    windows : mapping or sequence, optional
        Per-site arrival windows, seconds from the start: ``{name: (after, before)}``
        (None for an open end) or one pair per site; they replace the windows read from
        the sites file (``arrive_after`` / ``arrive_before``). The order and each leg's
        speeds keep every window (speeds within ``speed``, default ``"auto"``): a leg
        walks its ``plan`` route faster where a window asks for it, and a robot early at a
        site waits at the model's standing power (:mod:`energy_planner.mission.windows`).
        ``info["windows"]`` gives each stop's arrival, wait and its energy; the tour's
        energy includes the waits. A :class:`PlanningError` (``limit="window"``) names
        the site no order reaches in time and its earliest arrival.
    **trust
        ``level``, ``battery_wh``, ``reserve_wh``, ``confidence``
        (:class:`~energy_planner.trust.Trust`, or ``trust=`` one): the tour's and each
        leg's ``assessment``, and with a battery ``battery_legs``.

    Returns
    -------
    MissionResult
    """
    from energy_planner.trust import Trust

    want = Trust.pop(trust)
    if trust:
        raise TypeError(f"mission() got unexpected keyword(s) {', '.join(trust)}")
    terrain = problem.terrain
    if not isinstance(sites, Sites):
        from energy_planner.mission.sites import read_sites

        sites = read_sites(sites, terrain)
    sites = sites.with_windows(windows)
    kw = dict(order=order, return_to_start=return_to_start, planner=planner, eps=eps,
              leg_eps=leg_eps, n_headings=n_headings, client=client, progress=progress,
              want=want)  # fmt: skip
    timed = sites.windows is not None
    if speed is None and time_budget is None and not timed:
        return _tour(problem, sites, **kw)
    from energy_planner.planning.speed import resolve_speed, with_speed

    spec = resolve_speed("auto" if speed is None else speed, problem.model)
    problem = with_speed(problem, spec)  # a number: the nominal speed, as before
    if timed:
        if time_budget is not None:
            from energy_planner.errors import PlanningConfigError

            raise PlanningConfigError(
                "give a time budget or arrival windows, not both (a budget for the whole "
                "tour is the last site's arrive_before)", value=time_budget,
                param="time_budget",
            )  # fmt: skip
        return _tour(problem, sites, speed=spec, **kw)
    if time_budget is None:
        return _tour(problem, sites, **kw)
    if problem.cost.speed_range is None:
        from energy_planner.errors import PlanningConfigError

        raise PlanningConfigError(
            "a time budget needs a speed range (vmin, vmax) or 'auto' from a model whose "
            f"logs cover several speeds, got speed={speed!r}", value=speed, param="speed",
        )  # fmt: skip
    return _in_time(problem, sites, float(time_budget), kw)


def _in_time(problem, sites, budget: float, kw: dict) -> MissionResult:
    """The least-energy tour (order, routes and speeds) whose duration is within ``budget``.

    Every tour minimises energy + lambda x time (:func:`_tour` on the problem priced at
    ``lambda``); ``lambda`` 0 if that tour is in time, else the bracket grows by 4 from
    its mean power until a tour is in time, then bisections on ``log(lambda)``, as
    :func:`energy_planner.planning.speed.plan_deadline` does for one path.
    """
    from energy_planner.errors import PlanningConfigError
    from energy_planner.planning.speed import bisect_time_price

    if not (math.isfinite(budget) and budget > 0):
        raise PlanningConfigError(f"time_budget must be > 0 seconds, got {budget!r}",
                                  value=budget, param="time_budget")  # fmt: skip
    rng = problem.cost.speed_range
    tried: list[list[float]] = []

    def run(lam: float) -> MissionResult:
        res = _tour(problem.with_speed(rng, lam), sites, **kw)
        tried.append([lam, res.energy_j, res.duration_s])
        return res

    def done(res: MissionResult, lam: float) -> MissionResult:
        res.info["time_budget"] = {"time_budget_s": budget, "lambda_j_per_s": lam,
                                   "tours": [list(t) for t in tried]}  # fmt: skip
        res.problem = problem
        return res

    late = (
        f"no tour visits the sites within {budget:g} s: the fastest found takes "
        "{duration:.1f} s ({energy:.0f} J, every motion at the top of the speed range); "
        "give a larger time budget or a higher top speed"
    )
    return done(*bisect_time_price(run, budget, late))


def _tour(problem, sites: Sites, *, order, return_to_start, planner, eps, leg_eps, n_headings,
          client, progress, want, speed=None) -> MissionResult:  # fmt: skip
    """The mission on ``problem`` (its motions' speed choice and price of a second).

    With the sites' arrival windows, the order and the legs' speeds keep them
    (:func:`energy_planner.mission.windows.in_windows`; ``speed`` the resolved speed).
    """
    given = sites
    sites = sites.on_cells(problem.terrain)  # where the matrix's searches stand
    t0, c0 = time.perf_counter(), time.process_time()
    mat = _matrix(problem, sites, n_headings=n_headings, client=client, eps=eps,
                  progress=progress)  # fmt: skip
    E = mat.energy_j
    t1, c1 = time.perf_counter(), time.process_time()
    # where the time went (CPU: this process; on dask the searches run on the workers)
    timing = {"matrix_s": t1 - t0, "matrix_cpu_s": c1 - c0}
    if sites.windows is not None:
        res = _windowed(problem, given, sites, E, speed, order=order,
                        return_to_start=return_to_start, planner=planner, eps=eps,
                        leg_eps=leg_eps, n_headings=n_headings, progress=progress,
                        want=want)  # fmt: skip
    else:
        res = _ordered(problem, given, sites, E, order=order, return_to_start=return_to_start,
                       planner=planner, eps=eps, leg_eps=leg_eps, n_headings=n_headings,
                       progress=progress, want=want)  # fmt: skip
    timing.update(legs_s=time.perf_counter() - t1, legs_cpu_s=time.process_time() - c1)
    res.info["matrix"] = {k: mat.info[k] for k in MATRIX_INFO}
    res.info.update(timing)
    return res


#: The matrix's :attr:`~energy_planner.mission.matrix.MatrixResult.info` a mission reports
#: (``info["matrix"]``; its wall and CPU seconds in ``info["matrix_s"]`` and
#: ``info["matrix_cpu_s"]``, the order's and the legs' in ``legs_s`` and ``legs_cpu_s``).
MATRIX_INFO = ("window", "whole_map", "proven", "passes", "expanded", "priced", "edges")


def _ordered(problem, given, sites, E, *, order, return_to_start, planner, eps, leg_eps,
             n_headings, progress, want) -> MissionResult:  # fmt: skip
    """The mission's order and legs on the matrix ``E`` (no windows)."""
    from energy_planner.planning.plan import plan
    from energy_planner.progress import reporter

    planned: dict[tuple[int, int], Any] = {}
    with reporter(progress or False).bar("legs", None, "leg") as bar:

        def leg_plan(a: int, b: int) -> float:
            # from the sites as given, as `plan` from one site to the next plans the leg
            planned[a, b] = plan(problem, tuple(given.xy[a]), tuple(given.xy[b]),
                                 planner=planner, eps=leg_eps, n_headings=n_headings,
                                 progress=progress, level=want.level)  # fmt: skip
            bar.update(1)
            return float(planned[a, b].energy_j)

        settled = None
        if order == "best":  # the order on the matrix's bounds, settled on plan's legs
            n_legs = len(order_legs(list(range(len(E))), return_to_start))
            settled = settle_order(E / eps, leg_plan, return_to_start,
                                   max_priced=ORDER_MAX_PRICED * n_legs)  # fmt: skip
            o, total, method = settled.order, settled.energy, settled.method
        else:
            o, total, method = order_sites(E, order, return_to_start)
        if not math.isfinite(total):
            bad = [(sites.names[i], sites.names[j]) for i in range(len(E))
                   for j in range(len(E)) if not math.isfinite(E[i, j])]  # fmt: skip
            raise PlanningError(
                f"no tour visits every site: no path between {bad[:5]} (slope limits, "
                "keep-outs or the map's edge separate them)", value=bad[:5])  # fmt: skip
        pairs = order_legs(o, return_to_start)
        for a, b in pairs:
            if (a, b) not in planned:
                leg_plan(a, b)
    legs = []
    for a, b in pairs:
        r = planned[a, b]
        legs.append(Leg(a, b, float(r.energy_j), float(E[a, b]), float(r.distance_m),
                        float(r.duration_s), r.states, r.assessment, r.times,
                        gaits=r.gaits))  # fmt: skip
    info = {"matrix_energy_j": _cost(E, o, return_to_start), "planner": planner, "eps": eps}
    if settled is not None:
        info["order_check"] = {
            "legs_planned": len(planned),
            "orders": settled.rounds,
            "proven": settled.proven,
            "bound_j": None if math.isnan(settled.bound) else settled.bound,
        }
    info.update(_speed_info(problem))
    res = MissionResult(sites, o, legs, E, method, return_to_start, info=info)
    res.battery_legs, res.assessment = _battery_legs(res, problem.model, want)
    res.problem = problem
    return res


def _speed_info(problem) -> dict[str, Any]:
    """The tour's speed choice for its info (empty at a fixed speed)."""
    cost = problem.cost
    if cost.speed_range is None:
        return {}
    return {"speed": {"speed_range": list(cost.speed_range), "time_weight": cost.time_weight,
                      "speed_law": cost.speed_law.note}}  # fmt: skip


def _windowed(problem, given, sites, E, speed, *, order, return_to_start, planner, eps, leg_eps,
              n_headings, progress, want) -> MissionResult:  # fmt: skip
    """The mission in the sites' windows.

    Each pair's leg is planned once, as ``plan`` plans it; the order and speeds are
    :func:`energy_planner.mission.windows.in_windows`'.
    """
    from energy_planner.mission.windows import in_windows
    from energy_planner.planning.plan import plan

    planned: dict[tuple[int, int], Any] = {}

    def legs_of(a: int, b: int) -> np.ndarray:
        if (a, b) not in planned:
            planned[a, b] = plan(problem, tuple(given.xy[a]), tuple(given.xy[b]),
                                 planner=planner, eps=leg_eps, n_headings=n_headings,
                                 progress=progress, level=want.level).states  # fmt: skip
        return planned[a, b]

    s, method, tried = in_windows(problem, sites, E, speed, legs_of, order=order,
                                  return_to_start=return_to_start)  # fmt: skip
    legs = []
    for k, (a, b) in enumerate(zip(s.stops[:-1], s.stops[1:], strict=True)):
        r = s.legs[k]
        legs.append(Leg(a, b, float(r.energy_j), float(E[a, b]), float(r.distance_m),
                        float(r.duration_s), r.states, r.assessment, r.times,
                        float(s.wait[k + 1]), float(s.wait_j[k + 1]), gaits=r.gaits))  # fmt: skip
    o = s.stops[:-1] if return_to_start and len(s.stops) > 1 else list(s.stops)
    from energy_planner.mission.windows import standing_power

    power = standing_power(problem, sites.xy)
    info: dict[str, Any] = {
        "matrix_energy_j": _cost(E, o, return_to_start), "planner": planner, "eps": eps,
        "windows": {
            "stops": [{"site": sites.names[i], "arrive_s": float(s.arrive[k]),
                       "wait_s": float(s.wait[k]), "depart_s": float(s.depart[k]),
                       "standing_power_w": float(power[i]), "wait_j": float(s.wait_j[k])}
                      for k, i in enumerate(s.stops)],
            "lambda_j_per_s": [float(v) for v in s.lambdas],
            "wait_energy_j": float(s.wait_j.sum()), "orders_scheduled": tried,
        },
    }  # fmt: skip
    info.update(_speed_info(problem))
    res = MissionResult(sites, o, legs, E, method, return_to_start, info=info)
    res.battery_legs, res.assessment = _battery_legs(res, problem.model, want)
    res.problem = problem
    return res


def _battery_legs(
    res: MissionResult, model: Any, trust: Any, set_legs: bool = True
) -> tuple[dict | None, Assessment]:
    """The tour's battery record (None without a battery) and the whole tour's assessment.

    Each leg's verdict is :func:`energy_planner.uncertainty.assess.assess` of the energy
    spent up to its end (its duration, the legs' domain reports so far weighted by
    duration); with ``set_legs`` the legs take it into their assessment.
    """
    import dataclasses

    from energy_planner.uncertainty.assess import assess, sum_domain

    rows, parts, cum, cum_s, crossed, whole = [], [], 0.0, 0.0, None, None
    for k, leg in enumerate(res.legs):
        cum += leg.energy_j + leg.wait_j
        cum_s += leg.duration_s  # the error model's duration input
        parts.append((leg.domain, leg.duration_s))
        whole = assess(model, cum, duration_s=cum_s, domain=sum_domain(parts), trust=trust)
        d = whole.battery
        if set_legs and (d is not None or whole.battery_refused is not None):
            own = leg.assessment or Assessment()
            object.__setattr__(leg, "assessment", dataclasses.replace(
                own, battery=d, battery_refused=whole.battery_refused))  # fmt: skip
        if d is not None:
            rows.append({"leg": k, "to": res.sites.names[leg.b], "spent_j": cum,
                         "probability": d.probability, "ok": d.ok})  # fmt: skip
            if crossed is None and not d.ok:
                crossed = k
    if whole is None:
        whole = assess(model, 0.0, trust=trust)
    if trust.battery_wh is None:
        return None, whole
    record = {"battery_wh": trust.battery_wh, "reserve_wh": trust.reserve_wh,
              "confidence": trust.confidence, "legs": rows, "reserve_crossed_at": crossed,
              "probability": rows[-1]["probability"] if rows else 1.0}  # fmt: skip
    return record, whole
