"""Energy-minimal SE(2) planning: one entry point over the search, the lattice and OMPL.

Planners (``planner=``):

``"auto"`` (default)
    The full-resolution search (``"search"``), then a short cost-aware local refinement
    of its path (:func:`energy_planner.planning.refine.refine_path`: pose perturbation and
    shortcuts priced by the same kernel) that removes the discretisation of headings and
    move directions. Chosen by measurement (``benchmarks/bench_planning_scale.py``,
    ``docs/planning.md``).
``"search"``
    A* over (x, y, heading) at the DEM's cell size with edges priced on demand and an
    admissible heuristic (:mod:`energy_planner.planning.search`); its energy is at most
    ``eps`` times the optimum on its motion primitives.
``"lattice"``
    Dijkstra on the fully built lattice (:mod:`energy_planner.planning.lattice`), the
    reference: same primitives as ``search``, coarsened by default on large maps.
``"rrtstar"``, ``"sorrtstar"``, ``"bitstar"``
    OMPL's asymptotically optimal planners with the energy objective
    (:class:`~energy_planner.planning.objective.EnergyObjective`), run for ``time``
    seconds (or ``iterations`` planner iterations, which is reproducible).

The returned energy is always :func:`energy_planner.energy.path_energy` of the returned
poses with the same :class:`~energy_planner.energy.MotionCost`, so a planned path and a
queried path never disagree. Positions are in the terrain's working CRS (metres); yaw
in radians CCW from +x; use :meth:`PlanResult.waypoints` for the DEM's CRS.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from energy_planner.angles import wrap
from energy_planner.errors import EnergyPlannerError, PlanningConfigError, PlanningError
from energy_planner.planning import PLANNERS
from energy_planner.problem import takes_problem
from energy_planner.results import Result, path_first
from energy_planner.trust import Assessed

__all__ = ["PlanResult", "plan", "PLANNERS", "RUNNERS", "DEFAULT_EPS"]

_OMPL_PLANNERS = {"rrtstar": "RRTstar", "sorrtstar": "SORRTstar", "bitstar": "BITstar"}


@dataclass(repr=False)
class PlanResult(Result, Assessed):
    """A planned path and its energy, with its interval, domain and battery verdict.

    Attributes
    ----------
    states : ndarray, shape (n, 3)
        Poses ``x, y, yaw`` in the working CRS (metres, radians).
    energy_j, distance_m, duration_s : float
        From :func:`energy_planner.energy.path_energy` of ``states``.
    planner : str
        Planner name.
    history : list of (float, float)
        Convergence: (seconds since the start of planning, best energy so far in J).
    time_s : float
        Wall time of planning.
    seed : int
        The random seed used.
    info : dict
        Planner details (lattice size, iterations, motion-cost calls, ...).
    assessment : Assessment or None
        The energy's interval, the share of the path outside the calibration's domain
        and, given a battery, its verdict (:class:`~energy_planner.trust.Assessment`;
        :attr:`interval`, :attr:`domain`, :attr:`battery`).
    problem : Problem or None
        The terrain, model and request it was planned on
        (:class:`~energy_planner.results.Result`): the writers need no terrain.
    times : ndarray or None
        Seconds at each pose when the motions chose their speed (``plan(speed=(vmin,
        vmax))``, a deadline): the speed profile, which ``energy --waypoints`` of the
        written GeoJSON follows. None at the nominal speed.
    """

    states: np.ndarray
    energy_j: float
    distance_m: float
    duration_s: float
    planner: str
    history: list[tuple[float, float]] = field(default_factory=list)
    time_s: float = 0.0
    seed: int = 0
    info: dict[str, Any] = field(default_factory=dict)
    assessment: Any = field(default=None, repr=False)
    times: np.ndarray | None = field(default=None, repr=False)

    @property
    def energy_wh(self) -> float:
        """Energy in Wh."""
        return self.energy_j / 3600.0

    def speed_profile(self) -> list[dict[str, Any]]:
        """Per segment: ``distance_m``, ``duration_s`` and ``speed_m_s`` (ground; 0 turning).

        And ``gait`` where the motions chose their gait (:attr:`gaits`).

        Empty at the nominal speed (:attr:`times` None).
        """
        from energy_planner.planning.speed import speed_profile

        return speed_profile(self.states, self.times, self.info.get("segment_distance_m"),
                             self.info.get("gaits"))  # fmt: skip

    @property
    def gaits(self) -> list[str | None] | None:
        """The gait of each segment where the motions chose it, else None.

        (A model that names gaits, planned over a speed range.)
        """
        return self.info.get("gaits")

    def waypoints(self, terrain: Any = None) -> list[dict[str, float]]:
        """Poses in the DEM's CRS: dicts with ``x``, ``y``, ``yaw_deg``.

        ``yaw_deg`` is CCW from the +x axis of the DEM's CRS at the vertex (local east on
        a geographic DEM), the frame of :mod:`energy_planner.geojson`.
        """
        from energy_planner.geojson import yaw_from_work

        terrain = self._terrain(terrain)
        x, y = terrain.from_work(self.states[:, 0], self.states[:, 1])
        x, y = np.atleast_1d(x), np.atleast_1d(y)
        yaw = np.atleast_1d(
            yaw_from_work(terrain, self.states[:, 0], self.states[:, 1], self.states[:, 2])
        )
        return [
            {"x": float(a), "y": float(b), "yaw_deg": float(c)}
            for a, b, c in zip(x, y, np.degrees(yaw), strict=True)
        ]

    def to_geojson(self, terrain: Any = None, *, native: bool = False) -> dict[str, Any]:
        """The project's GeoJSON path document (:mod:`energy_planner.geojson`).

        RFC 7946 longitude/latitude (``native=True``: the DEM's CRS, declared), with
        ``yaw_deg`` per vertex and the energy, distance, duration, planner.
        """
        from energy_planner.geojson import path_document_from_work

        return path_document_from_work(
            self._terrain(terrain),
            self.states,
            t=None if self.times is None else [float(v) for v in self.times],
            gait=self.gaits,
            properties={
                "energy_j": self.energy_j,
                "distance_m": self.distance_m,
                "duration_s": self.duration_s,
                "planner": self.planner,
            },
            native=native,
        )

    def to_dict(self, terrain: Any = None) -> dict[str, Any]:
        """JSON-ready summary (waypoints in the DEM's CRS), with the assessment's keys.

        ``corridor`` (a DEM read by windows: without its log) when the plan has one;
        ``stay_in_domain`` (what keeping to the calibration's domain changed) when asked.
        """
        out = {
            "energy_j": self.energy_j,
            "energy_wh": self.energy_wh,
            "distance_m": self.distance_m,
            "duration_s": self.duration_s,
            "planner": self.planner,
            "seed": self.seed,
            "time_s": self.time_s,
            "history": [list(h) for h in self.history],
            "waypoints": self.waypoints(terrain),
            **self.assessment_dict(),
        }
        if "corridor" in self.info:
            out["corridor"] = {k: v for k, v in self.info["corridor"].items() if k != "log"}
        if "stay_in_domain" in self.info:
            out["stay_in_domain"] = list(self.info["stay_in_domain"])
        if self.times is not None:
            out["times_s"] = [float(v) for v in self.times]
            out["speed_profile"] = self.speed_profile()
            out["speed"] = {k: self.info[k] for k in ("speed_range", "time_weight", "speed_law",
                                                      "gait_ranges") if k in self.info}  # fmt: skip
        if "deadline" in self.info:
            out["deadline"] = self.info["deadline"]
        return out

    def write_geojson(self, path: Any, terrain: Any = None, *, native: bool = False) -> Any:
        """Write :meth:`to_geojson` to ``path`` atomically; returns the path."""
        from energy_planner.io import write_geojson

        return write_geojson(path, self.to_geojson(terrain, native=native))

    def write_json(self, path: Any, terrain: Any = None) -> Any:
        """Write :meth:`to_dict` to ``path`` atomically; returns the path."""
        from energy_planner.io import write_json

        return write_json(path, self.to_dict(terrain))

    def plot(
        self, path: Any, terrain: Any = None, *, request: Any = None, title: str | None = None
    ) -> Any:
        """Draw the path over the terrain's hillshade; write a PNG at ``path``.

        Drawn as the energy-optimal route of a
        :class:`~energy_planner.planning.routes.RouteComparison` (keep-outs, slope mask
        and channels of the request drawn too). ``terrain``, ``request``: default those
        it was planned on.
        """
        from energy_planner.planning.routes import Route, RouteComparison

        path, terrain = path_first(path, terrain)

        s, g = self.states[0], self.states[-1]
        comp = RouteComparison(
            routes=[Route("energy_optimal", self.states, self.energy_j, self.distance_m,
                          self.duration_s, None, True)],
            start=(float(s[0]), float(s[1]), float(s[2])),
            goal=(float(g[0]), float(g[1]), float(g[2])),
        )  # fmt: skip
        title = title or f"Planned path ({self.planner}): {self.energy_j:.0f} J"
        comp.problem = self.problem
        return comp.plot(path, terrain, title=title, request=request)

    def write_html(self, path: Any, problem: Any = None) -> Any:
        """One self-contained HTML page of the path (:func:`energy_planner.webmap.plan_page`).

        ``problem``: default the :class:`~energy_planner.problem.Problem` it was planned
        on; the hover of each vertex prices the segment that starts there with its model.
        """
        from energy_planner.webmap import plan_page

        return plan_page(self._problem_for(problem), self, path)

    def write_bag(
        self,
        path: Any,
        terrain: Any = None,
        *,
        request: Any = None,
        frame: str = "map",
        topic: str = "/energy_planner/plan",
        storage: str = "mcap",
        origin: Sequence[float] | None = None,
    ) -> dict[str, Any]:
        """Write the path as a ``nav_msgs/msg/Path`` into a new ROS 2 bag folder ``path``.

        Poses in the map frame ``frame`` (:mod:`energy_planner.io.ros2`: the working CRS
        shifted to the grid's south-west corner, REP 103 axes, yaw as a quaternion about
        z), stamped with the time the robot reaches each (at the speed and yaw rate of
        the request it was planned with; ``request=`` another is an error). ``origin``:
        another origin of the frame (working CRS); a plan made by windows
        (``info["corridor"]``) keeps the whole DEM's south-west corner, not its window's.
        Returns the frame and conventions (:meth:`energy_planner.io.ros2.MapFrame.to_dict`),
        also in the bag's metadata.
        """
        from energy_planner.energy.path import write_paths_bag

        times = self.times
        info = {"energy_j": self.energy_j, "distance_m": self.distance_m,
                "duration_s": self.duration_s, "planner": self.planner}  # fmt: skip
        dem_bounds = self.info.get("corridor", {}).get("dem_bounds")
        if origin is None and dem_bounds is not None:
            origin = dem_bounds[:2]
        return write_paths_bag(
            path, [(topic, self.states, self.duration_s, "the plan", info, times)],
            self._terrain(terrain), self._request(request), frame=frame, storage=storage,
            origin=origin,
        )  # fmt: skip


def _pose(p: Sequence[float], which: str) -> tuple[float, float, float | None]:
    if len(p) not in (2, 3):
        raise PlanningConfigError(f"{which} must be (x, y) or (x, y, yaw), got {tuple(p)!r}")
    p = list(p)
    yaw = p[2] if len(p) == 3 else None
    try:
        vals = [float(v) for v in p[:2]] + ([] if yaw is None else [float(yaw)])
    except (TypeError, ValueError) as exc:
        raise PlanningConfigError(f"{which} {tuple(p)!r} is not numeric") from exc
    if not all(math.isfinite(v) for v in vals):
        raise PlanningConfigError(f"{which} {tuple(p)!r} has a non-finite value")
    return (vals[0], vals[1], vals[2] if yaw is not None else None)


class _Progress:
    """Best-energy-so-far of an anytime planner, on the one progress reporter."""

    def __init__(self, total: float, show: bool, callback: Callable | None, desc: str):
        from energy_planner.progress import Reporter

        self.rep = Reporter(show=True if show else False, callback=callback)
        self.history: list[tuple[float, float]] = []
        if total > 0:
            self.bar = self.rep.bar(
                desc, round(total, 2), "s",
                fmt="{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total:.1f} s {postfix}",
            )  # fmt: skip
        else:  # no time budget: the seconds so far and the best energy
            self.bar = self.rep.bar(desc, None, "s", fmt="{desc}: {n:.1f} s {postfix}")
        self.best = math.inf

    def elapsed(self) -> float:
        return self.rep.elapsed()

    def report(self, energy: float) -> None:
        t = self.elapsed()
        if energy < self.best:
            self.best = float(energy)
        if math.isfinite(self.best):
            self.history.append((t, self.best))
        self.bar.set(round(t, 2), value=self.best, postfix=f"best {self.best:.1f} J")

    def close(self) -> None:
        self.bar.close()


def _seed_ompl(seed: int) -> None:
    from ompl import util as ou

    ou.setLogLevel(ou.LOG_NONE)  # setSeed complains (harmlessly) after the first run
    ou.RNG.setSeed(int(seed) % 2_147_483_000 + 1)  # OMPL rejects 0
    ou.setLogLevel(ou.LOG_WARN)


#: Remove the overhead that keeps OMPL's planners far from the search (measured in
#: ``benchmarks/bench_planning.py``): r-disc instead of k-nearest rewiring for RRT* and
#: SORRT*, and a motion validator that prices each motion once and hands its cost to the
#: objective. ``False`` gives OMPL's defaults (for the before/after benchmark).
OMPL_TUNING = True

#: Hand BIT* the search's 2-D relaxed cost-to-go
#: (:class:`~energy_planner.planning.objective.CostToGo`, through
#: ``motionCostHeuristic(s, goal)``, with which BIT* orders and prunes its edges; RRT*
#: and SORRT* never ask for a cost-to-go that way). ``False`` gives the distance bound
#: alone (for the before/after benchmark).
OMPL_COST_TO_GO = True


def _ompl_setup(cost, terrain, cost_to_go=None):
    from ompl import base as ob
    from ompl import geometric as og

    from energy_planner.planning.objective import EnergyObjective, make_space

    space = make_space(terrain)
    ss = og.SimpleSetup(space)
    si = ss.getSpaceInformation()
    obj = EnergyObjective(si, cost, cost_to_go)
    # poses that break a limit are invalid, so the tree does not grow into them (a
    # Python checker, about 1 us per pose; motions are still priced - and limited - by
    # the kernel, whose sub-steps are finer than the 2% checking resolution)
    kernel = obj._kernel

    def valid(state) -> bool:
        x, y, th = state.getX(), state.getY(), state.getYaw()
        return math.isfinite(kernel(x, y, th, x, y, th))

    ss.setStateValidityChecker(valid)
    si.setStateValidityCheckingResolution(0.02)
    if OMPL_TUNING:
        cache: dict = {}

        class PricingValidator(ob.MotionValidator):
            """A motion is valid iff its energy is finite.

            The energy is kept for ``motionCost`` (which RRT* asks for right after
            checking the motion).
            """

            def __init__(self) -> None:
                super().__init__(si)

            def checkMotion(self, s1, s2, *rest):  # noqa: N802 - OMPL's name
                key = (s1.getX(), s1.getY(), s1.getYaw(), s2.getX(), s2.getY(), s2.getYaw())
                e = kernel(*key)
                obj.priced += 1
                if len(cache) > 200_000:
                    cache.clear()
                cache[key] = e
                return math.isfinite(e)

        validator = PricingValidator()
        si.setMotionValidator(validator)
        obj.cache = cache
        obj._validator = validator  # keep it alive as long as the objective
    ss.setOptimizationObjective(obj)
    return space, ss, si, obj


def _make_planar_goal(si, gx: float, gy: float, threshold: float):
    """A goal region on (x, y) only, any yaw: sampleable for RRT*'s goal bias."""
    from ompl import base as ob

    class PlanarGoal(ob.GoalSampleableRegion):
        def __init__(self) -> None:
            super().__init__(si)
            self.setThreshold(threshold)
            self._k = 0

        def distanceGoal(self, s):  # noqa: N802 - OMPL's name
            return math.hypot(s.getX() - gx, s.getY() - gy)

        def sampleGoal(self, s):  # noqa: N802 - OMPL's name
            self._k += 1
            s.setX(gx)
            s.setY(gy)
            s.setYaw(float(wrap(self._k * math.pi / 8)))  # 16 yaws in turn

        def maxSampleCount(self):  # noqa: N802 - OMPL's name
            return 16  # finite: BIT* draws every goal sample up front

    return PlanarGoal()


def _run_ompl(
    cost,
    terrain,
    start,
    goal,
    planner: str,
    budget: float,
    seed: int,
    iterations: int | None,
    progress: _Progress,
    ctg=None,
) -> tuple[np.ndarray, dict]:
    """Run an OMPL planner in chunks, reporting the best energy after each chunk."""
    from ompl import base as ob
    from ompl import geometric as og

    from energy_planner.planning.objective import path_cost, path_states, set_state

    _seed_ompl(seed)
    space, ss, si, obj = _ompl_setup(cost, terrain, ctg)
    start_yaws = [start[2]] if start[2] is not None else list(np.linspace(-np.pi, np.pi, 8, False))
    for yaw in start_yaws:
        s = space.allocState()
        set_state(s, start[0], start[1], yaw)
        ss.addStartState(s)
    res = float(abs(terrain.grid[2]))
    if goal[2] is None:
        ss.setGoal(_make_planar_goal(si, goal[0], goal[1], 0.5 * res))
    else:
        g = space.allocState()
        set_state(g, goal[0], goal[1], goal[2])
        ss.setGoalState(g, 0.5 * res)
    pl = getattr(og, _OMPL_PLANNERS[planner])(si)
    if OMPL_TUNING and hasattr(pl, "setKNearest"):
        pl.setKNearest(False)  # r-disc: k-nearest prices ~64 ln(n) motions per sample
    if hasattr(pl, "setRange"):
        # short motions: the kernel integrates at sub-cell steps, so a long motion is
        # slow to price; 8 cells keeps RRT*'s rewiring affordable
        pl.setRange(8.0 * res)
    ss.setPlanner(pl)
    ss.setup()
    kernel = obj._kernel
    best_states: np.ndarray | None = None
    best = math.inf
    n_chunks = 20
    done_iters = 0
    while True:
        if iterations is not None:
            chunk = max(1, math.ceil(iterations / n_chunks))
            target = min(iterations, done_iters + chunk)
            counter = [0]
            allowed = target - done_iters

            def stop(counter=counter, allowed=allowed) -> bool:
                counter[0] += 1
                return counter[0] > allowed

            ss.solve(ob.PlannerTerminationCondition(stop))
            done_iters = target
            finished = done_iters >= iterations
        else:
            remaining = budget - progress.elapsed()
            if remaining <= 0:
                break
            ss.solve(min(remaining, max(0.1, budget / n_chunks)))
            finished = progress.elapsed() >= budget
        if ss.haveExactSolutionPath():
            states = path_states(ss.getSolutionPath())
            e = path_cost(kernel, _with_exact_goal(states, goal))
            if e < best:
                best, best_states = e, states
        progress.report(best)
        if finished:
            break
    info = {"motion_cost_calls": obj.calls, "motions_priced": obj.priced}
    if ctg is not None:
        info["cost_to_go"] = {"build_s": ctg.build_s, "h_start_j": ctg(start[0], start[1])}
    try:
        info["iterations"] = int(pl.numIterations())
    except AttributeError:
        pass
    ss.clear()
    del ss, pl, obj, si, space
    if best_states is None:
        raise PlanningError(
            f"{planner} found no finite-energy path in {budget:g} s; give it more time "
            "(--time), relax the limits, or use planner 'lattice'"
        )
    return _with_exact_goal(best_states, goal), info


def _with_exact_goal(states: np.ndarray, goal) -> np.ndarray:
    """Append the exact goal pose if the planner stopped within its goal threshold."""
    last = states[-1]
    gyaw = last[2] if goal[2] is None else float(wrap(goal[2]))
    if abs(last[0] - goal[0]) > 1e-9 or abs(last[1] - goal[1]) > 1e-9 or abs(last[2] - gyaw) > 1e-9:
        return np.vstack([states, [goal[0], goal[1], gyaw]])
    return states


#: Heuristic weight of the ``auto`` and ``search`` planners: the search's energy is at
#: most this factor above the optimum on its primitives; measured well below it
#: (``benchmarks/bench_planning_scale.py``, ``docs/planning.md``).
DEFAULT_EPS = 1.05

#: ``auto``'s refinement without a time budget: a quarter of the search's time, at most
#: 10 s, and at least :data:`REFINE_MIN_ROUNDS` rounds (a floor of work, not of seconds:
#: the first rounds' shortcuts and pose moves give most of the gain, e.g. 1.7 % above the
#: ``eps = 1`` optimum to about 1 % below it on the 800² notch DEM of ``bench_peers.py``).
REFINE_SHARE, REFINE_MAX_S, REFINE_MIN_ROUNDS = 0.25, 10.0, 4


@dataclass
class _Run:
    """What a planner runner needs (:data:`RUNNERS`); ``info`` collects what it reports."""

    problem: Any
    start: tuple
    goal: tuple
    planner: str
    budget: float
    seed: int
    iterations: int | None
    prog: Any
    info: dict[str, Any]
    step: float | None
    n_headings: int
    moves: str
    eps: float
    progress: bool
    ctg: Any = None

    @property
    def cost(self):
        """The problem's motion cost (every limit in it)."""
        return self.problem.cost

    @property
    def terrain(self):
        """The problem's terrain."""
        return self.problem.terrain


def _run_search(r: _Run) -> np.ndarray:
    """``search``: A* at the DEM's resolution; ``auto``: then the refinement."""
    from energy_planner.planning.search import search_plan

    sr = search_plan(
        r.problem, r.start, r.goal, step=r.step, n_headings=r.n_headings,
        moves=r.moves, eps=r.eps, progress=r.progress, time_budget=r.budget,
    )  # fmt: skip
    r.info["search"] = {
        "step_m": sr.step,
        "headings": sr.n_headings,
        "eps": sr.eps,
        "states": sr.states_total,
        "expanded": sr.expanded,
        "edges_priced": sr.priced,
        "heuristic_s": sr.heuristic_s,
        "search_s": sr.search_s,
        "h_start_j": sr.info["h_start"],
        "certified": sr.info["certified"],
    }
    r.prog.report(sr.cost)
    if r.planner != "auto":
        return sr.states
    from energy_planner.planning.refine import refine_path

    spent = r.prog.elapsed()
    if math.isfinite(r.budget):
        left, min_rounds = r.budget - spent, 0
        if left <= 0.05:
            return sr.states
    else:
        left, min_rounds = min(REFINE_SHARE * spent, REFINE_MAX_S), REFINE_MIN_ROUNDS
    states, r.info["refine"] = refine_path(
        r.cost,
        sr.states,
        budget=left,
        seed=r.seed,
        spacing=max(sr.step, float(abs(r.terrain.grid[2]))),
        free_start_yaw=r.start[2] is None,
        free_goal_yaw=r.goal[2] is None,
        max_rounds=r.iterations,
        min_rounds=min_rounds,
        report=r.prog.report,
    )
    return states


def _run_lattice(r: _Run) -> np.ndarray:
    """``lattice``: the full lattice graph, Dijkstra (not interruptible)."""
    from energy_planner.planning.lattice import lattice_plan

    lat = lattice_plan(
        r.problem, r.start, r.goal, step=r.step, n_headings=r.n_headings, moves=r.moves
    )
    r.info["lattice"] = {
        "step_m": lat.step,
        "headings": lat.n_headings,
        "nodes": lat.n_nodes,
        "edges": lat.n_edges,
        "build_s": lat.build_s,
        "search_s": lat.search_s,
    }
    r.prog.report(_batch_path_cost(r.cost, lat.states))
    return lat.states


def _batch_path_cost(cost, states: np.ndarray) -> float:
    """:func:`~energy_planner.planning.binding.path_cost` of ``states`` by ``cost.batch``.

    The same kernel per motion and the same sum, priced by the batch kernel rather than a
    Python call per motion (:func:`~energy_planner.planning.binding.bind_kernel`, which
    OMPL's planners use).
    """
    s = np.asarray(states, float)
    if len(s) < 2:
        return 0.0
    a, b = s[:-1], s[1:]
    return float(sum(cost.batch(a[:, 0], a[:, 1], a[:, 2], b[:, 0], b[:, 1], b[:, 2]).tolist()))


def _run_ompl_planner(r: _Run) -> np.ndarray:
    """An OMPL planner of :data:`_OMPL_PLANNERS` with the energy objective."""
    states, oinfo = _run_ompl(
        r.cost, r.terrain, r.start, r.goal, r.planner, r.budget, r.seed, r.iterations, r.prog,
        r.ctg,
    )  # fmt: skip
    r.info.update(oinfo)
    return states


#: planner name -> the function that runs it (the one registry; its names are
#: :data:`energy_planner.planning.PLANNERS`, in that order)
RUNNERS: dict[str, Callable[[_Run], np.ndarray]] = {
    "auto": _run_search,
    "search": _run_search,
    "lattice": _run_lattice,
    **dict.fromkeys(_OMPL_PLANNERS, _run_ompl_planner),
}
assert tuple(RUNNERS) == PLANNERS, "planning.PLANNERS and plan.RUNNERS name the same planners"


@takes_problem(2)
def plan(
    problem,
    start: Sequence[float],
    goal: Sequence[float],
    *,
    planner: str = "auto",
    time: float | None = None,
    seed: int = 0,
    progress: bool = True,
    step: float | None = None,
    n_headings: int = 16,
    moves: str = "all",
    eps: float | None = None,
    iterations: int | None = None,
    callback: Callable[[Any], None] | None = None,
    speed: Any = None,
    deadline: float | None = None,
    time_weight: float = 0.0,
    **trust: Any,
) -> PlanResult:
    """Plan an energy-minimal SE(2) path.

    Parameters
    ----------
    problem : Problem
        Terrain, model and request (robot, limits, keep-outs, channels) bound once
        (:class:`energy_planner.problem.Problem`); every planner prices with its
        :attr:`~energy_planner.problem.Problem.cost`. The older form ``plan(terrain,
        model, start, goal, request=None, ..., cost=None)`` is accepted
        (:func:`energy_planner.problem.takes_problem`).
    start, goal : sequence of float
        ``(x, y)`` or ``(x, y, yaw)`` in the working CRS (metres; yaw radians CCW from
        +x). Without a yaw the planner chooses the best one.
    planner : str
        One of :data:`energy_planner.planning.PLANNERS`.
    time : float, optional
        Budget in seconds for the whole planning after kernel compilation: the search's
        relaxed problem and search (a :class:`PlanningError` when they do not finish in
        time) and then ``auto``'s refinement, which gets what is left. Default: no limit
        for the search, and a quarter of the search's time (at most 10 s, and at least
        :data:`REFINE_MIN_ROUNDS` rounds) for the refinement. OMPL planners run for
        ``time`` (default 10 s); BIT*'s cost-to-go (:data:`OMPL_COST_TO_GO`) is built
        before that clock starts. The ``lattice`` planner is not interruptible: ``time``
        does not bound it.
    seed : int
        Random seed (refinement, OMPL's RNG).
    progress : bool
        Progress bars on stderr (only on a terminal).
    step : float, optional
        Position spacing for ``auto``/``search`` (default: the DEM's cell size) and
        ``lattice`` (default :func:`energy_planner.planning.lattice.default_step`).
    n_headings : int
        Headings per position.
    moves : {"all", "crab", "axes"}
        Translations per heading for ``auto``/``search``/``lattice``
        (:data:`energy_planner.planning.search.MOVE_SETS`): all 16 lattice directions at
        every heading (default; crab walking), 8, or the 4 closest to the body axes.
    eps : float, optional
        Heuristic weight of ``auto``/``search`` (default :data:`DEFAULT_EPS`; 1 = optimal
        on the primitives, slower).
    iterations : int, optional
        For OMPL planners: stop after this many planner iterations instead of ``time``
        (reproducible). For ``auto``: the maximum number of refinement rounds.
    callback : callable, optional
        ``callback(event)`` with a :class:`energy_planner.progress.ProgressEvent` at every
        report of the anytime planners (``event.value``: the best energy so far, J;
        ``event.elapsed``: seconds), as every progress callback of the library.
    speed : float, (float, float) or "auto", optional
        Ground speed, m/s. A number: every motion at that speed (the request's nominal
        speed otherwise; the fixed-speed planner, unchanged). ``(vmin, vmax)``: each
        motion of the search and the refinement walks at its own best speed in the range
        (:mod:`energy_planner.energy.speed`, closed form), and the result carries the
        speed profile (:attr:`PlanResult.times`). ``"auto"``: the range of speeds the
        model's calibration logged (:func:`energy_planner.planning.speed.speed_range_of`).
    deadline : float, optional
        Seconds: the least-energy path that arrives in time, speed and route chosen
        together (:func:`energy_planner.planning.speed.plan_deadline`: minimises energy +
        lambda x time, lambda found by bisection). Needs a speed range (default
        ``"auto"``). A :class:`PlanningError` gives the fastest path's time when no path
        can.
    time_weight : float
        ``lambda``, J/s: minimise energy + lambda x duration (a point of the energy-time
        front, :func:`energy_planner.planning.speed.pareto`).
    **trust
        ``level``, ``battery_wh``, ``reserve_wh``, ``confidence``
        (:class:`~energy_planner.trust.Trust`, or ``trust=`` one): the result's
        ``assessment`` (interval at ``level``, domain report, battery verdict).

    Returns
    -------
    PlanResult

    Raises
    ------
    InvalidStateError
        If the start or goal breaks a limit (fields ``endpoint``, ``limit``, ``value``).
    PlanningConfigError
        Unknown planner, bad parameters, invalid keep-out polygons (older form:
        ``cost`` and ``request`` disagreeing).
    PlanningError
        No feasible path, or the budget ran out (field ``limit="time"``).
    """
    from energy_planner.planning.limits import check_endpoint, keep_out_violation
    from energy_planner.trust import Trust

    if deadline is not None:
        from energy_planner.planning.speed import plan_deadline

        return plan_deadline(
            problem, start, goal, deadline, speed=speed, planner=planner, time=time, seed=seed,
            progress=progress, step=step, n_headings=n_headings, moves=moves, eps=eps,
            iterations=iterations, callback=callback, **trust,
        )  # fmt: skip
    if speed is not None or time_weight:
        from energy_planner.planning.speed import with_speed

        problem = with_speed(problem, speed, time_weight)
    want = Trust.pop(trust)
    if trust:
        raise TypeError(f"plan() got unexpected keyword(s) {', '.join(trust)}")
    if planner not in PLANNERS:
        raise PlanningConfigError(
            f"unknown planner {planner!r}; valid planners: {', '.join(PLANNERS)}",
            value=planner,
            param="planner",
        )
    if time is not None and not (time > 0):
        raise PlanningConfigError(
            f"time must be > 0 seconds, got {time!r}", value=time, param="time"
        )
    eps = DEFAULT_EPS if eps is None else float(eps)
    start_p = _pose(start, "start")
    goal_p = _pose(goal, "goal")
    terrain, cost, geoms = problem.terrain, problem.cost, problem.keep_out
    if planner in ("auto", "search") and not cost.ranged:
        # the motion and search kernels compiled ahead of time (once per machine and
        # model): a plan then loads no numba, whose import and registries cost more
        # than a small map's search (search.precompiled_search)
        cost.precompile()
    check_endpoint(cost, terrain, "start", start_p, geoms)
    check_endpoint(cost, terrain, "goal", goal_p, geoms)

    if math.hypot(goal_p[0] - start_p[0], goal_p[1] - start_p[1]) <= 1e-9:
        return _stay(problem, start_p, goal_p, planner, seed, want)

    ctg = _warm_up(problem, planner, start_p, goal_p, step, n_headings, moves)
    budget = time if time is not None else (10.0 if planner in _OMPL_PLANNERS else math.inf)
    prog = _Progress(
        budget if math.isfinite(budget) else 0.0,
        progress is True or (progress is None and planner in _OMPL_PLANNERS),
        callback,
        f"plan ({planner})",
    )
    info: dict[str, Any] = {"request": problem.request}
    run = _Run(problem, start_p, goal_p, planner, budget, seed, iterations, prog, info,
               step, n_headings, moves, eps, progress, ctg)  # fmt: skip
    try:
        states = RUNNERS[planner](run)
    finally:
        prog.close()
    from energy_planner.planning.lattice import simplify_states
    from energy_planner.planning.speed import gait_changes

    states = simplify_states(states, keep=gait_changes(problem.cost, states))
    bad = keep_out_violation(states, geoms)
    if bad is not None:
        raise PlanningError(f"the {planner} path enters a keep-out area: {bad}", limit="keep_out")
    return _priced(problem, states, f"the {planner} path is not feasible", want,
                   planner=planner, history=prog.history, time_s=prog.elapsed(), seed=seed,
                   info=info)  # fmt: skip


def _warm_up(problem, planner: str, start_p, goal_p, step=None, n_headings=16, moves="all"):
    """Compile the kernels before the clock starts (numba compiles on first call).

    The search's bound tables too (:func:`~energy_planner.planning.search.prepare_bound`):
    on a cold cache a speed range's heading tables are built once per machine (seconds),
    which would eat a time budget and change the plan.

    Returns BIT*'s cost-to-go (:data:`OMPL_COST_TO_GO`), prepared before the clock too
    (its time is in the info), or None.
    """
    cost = problem.cost.compile()
    if planner in ("auto", "search"):
        from energy_planner.planning.search import search_module

        search_module(cost, "path")
        from energy_planner.planning.search import prepare_bound

        prepare_bound(problem, start_p, step, n_headings, moves)
    elif planner != "lattice":
        # the Python-callable kernel, needed by OMPL only (the search and the lattice
        # price by batch): its first call loads the kernel's signature
        warm = _cost_fn(cost)
        warm(start_p[0], start_p[1], 0.0, start_p[0], start_p[1], 0.0)
    if planner == "bitstar" and OMPL_COST_TO_GO:
        from energy_planner.planning.objective import CostToGo

        return CostToGo(cost, problem.terrain, goal_p[:2])
    return None


def _priced(problem, states: np.ndarray, what: str, trust: Any, **fields: Any) -> PlanResult:
    """``states`` priced by :func:`energy_planner.energy.path_energy` with the problem's cost.

    With its assessment for ``trust`` (:func:`energy_planner.uncertainty.assess.assess_path`).
    A motion that breaks a limit raises :class:`PlanningError` starting with ``what``.
    """
    from energy_planner.energy import path_energy
    from energy_planner.uncertainty.assess import assess_path

    cost = problem.cost
    t = None
    gaits = None
    if cost.ranged:  # the speeds the motions chose: their durations time the poses
        dt, gaits = cost.best_timing(states[:, 0], states[:, 1], states[:, 2])
        if not np.isfinite(dt).all():
            raise PlanningError(f"{what}: a motion breaks a limit at every speed of the range")
        t = np.concatenate([[0.0], np.cumsum(dt)])
        fields["info"] = {**fields.get("info", {}), "speed_range": cost.speed_range,
                          "time_weight": cost.time_weight}  # fmt: skip
        if cost.speed_law is not None:
            fields["info"]["speed_law"] = cost.speed_law.note
        if gaits is not None:  # and the gaits they chose
            fields["info"]["gaits"] = gaits
            fields["info"]["gait_ranges"] = {g: list(r) for g, r in cost.gait_ranges.items()}
    try:
        pe = path_energy(problem.terrain, problem.model, states[:, :2], yaw=states[:, 2], t=t,
                         cost=cost, gait=gaits)  # fmt: skip
    except EnergyPlannerError as exc:
        raise PlanningError(f"{what}: {exc}") from exc
    if t is not None:
        fields["info"]["segment_distance_m"] = np.asarray(pe.table["distance_m"], float).tolist()
    res = PlanResult(states=states, energy_j=pe.energy_j, distance_m=pe.distance_m,
                     duration_s=pe.duration_s,
                     assessment=assess_path(problem.model, pe, cost, trust), times=t,
                     **fields)  # fmt: skip
    res.problem = problem
    return res


def _stay(problem, start_p, goal_p, planner: str, seed: int, trust: Any) -> PlanResult:
    """Start and goal at the same position: stay, turning in place if both yaws are given."""
    x, y = start_p[0], start_p[1]
    cost = problem.cost
    if start_p[2] is not None:
        y0 = float(wrap(start_p[2]))
    elif goal_p[2] is not None:
        y0 = float(wrap(goal_p[2]))
    else:
        y0 = next(
            (float(wrap(th)) for th in np.linspace(-np.pi, np.pi, 16, endpoint=False)
             if math.isfinite(cost(x, y, th, x, y, th))),
            0.0,
        )  # fmt: skip
    y1 = float(wrap(goal_p[2])) if goal_p[2] is not None else y0
    states = np.array([[x, y, y0], [x, y, y1]])
    return _priced(problem, states, "turning in place at the start is not feasible", trust,
                   planner=planner, seed=seed,
                   info={"trivial": "start and goal are the same position"})  # fmt: skip


def _cost_fn(cost):
    from energy_planner.planning.binding import bind_kernel

    return bind_kernel(cost)
