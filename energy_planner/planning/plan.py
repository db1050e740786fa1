"""Energy-minimal SE(2) planning: one entry point over the lattice and OMPL planners.

Planners (``planner=``):

``"lattice"``
    Dijkstra on the (x, y, heading) lattice (:mod:`energy_planner.planning.lattice`):
    deterministic, resolution-optimal.
``"rrtstar"``, ``"sorrtstar"``, ``"bitstar"``
    OMPL's asymptotically optimal planners with the energy objective
    (:class:`~energy_planner.planning.objective.EnergyObjective`), run for ``time``
    seconds (or ``iterations`` planner iterations, which is reproducible).
``"auto"`` (default)
    The lattice solution refined by OMPL's cost-aware path simplifier
    (``perturbPath`` + ``partialShortcutPath``): the lattice gives the right homotopy
    class and the simplifier removes the lattice's heading/direction discretisation.
    Chosen by measurement (``benchmarks/bench_planning.py``, ``docs/planning.md``).

The returned energy is always :func:`energy_planner.energy.path_energy` of the returned
poses with the same :class:`~energy_planner.energy.MotionCost`, so a planned path and a
queried path never disagree. Positions are in the terrain's working CRS (metres); yaw
in radians CCW from +x; use :meth:`PlanResult.waypoints` for the DEM's CRS.
"""

from __future__ import annotations

import math
import sys
import time as _time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from energy_planner.errors import PlanningConfigError, PlanningError
from energy_planner.planning import PLANNERS

__all__ = ["PlanResult", "plan", "PLANNERS"]

_OMPL_PLANNERS = {"rrtstar": "RRTstar", "sorrtstar": "SORRTstar", "bitstar": "BITstar"}


@dataclass
class PlanResult:
    """A planned path and its energy.

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

    @property
    def energy_wh(self) -> float:
        """Energy in Wh."""
        return self.energy_j / 3600.0

    def waypoints(self, terrain) -> list[dict[str, float]]:
        """Poses in the DEM's CRS: dicts with ``x``, ``y``, ``yaw_deg``."""
        x, y = terrain.from_work(self.states[:, 0], self.states[:, 1])
        x, y = np.atleast_1d(x), np.atleast_1d(y)
        yaw = np.degrees(self.states[:, 2])
        return [
            {"x": float(a), "y": float(b), "yaw_deg": float(c)}
            for a, b, c in zip(x, y, yaw, strict=True)
        ]

    def to_geojson(self, terrain) -> dict[str, Any]:
        """A GeoJSON Feature: LineString in the DEM's CRS, ``yaw_deg`` per vertex."""
        wps = self.waypoints(terrain)
        crs = getattr(terrain, "source_crs", None)
        return {
            "type": "Feature",
            "geometry": {"type": "LineString", "coordinates": [[w["x"], w["y"]] for w in wps]},
            "properties": {
                "yaw_deg": [w["yaw_deg"] for w in wps],
                "energy_j": self.energy_j,
                "distance_m": self.distance_m,
                "duration_s": self.duration_s,
                "planner": self.planner,
                "crs": None if crs is None else str(crs),
            },
        }

    def to_dict(self, terrain) -> dict[str, Any]:
        """JSON-ready summary (waypoints in the DEM's CRS)."""
        return {
            "energy_j": self.energy_j,
            "energy_wh": self.energy_wh,
            "distance_m": self.distance_m,
            "duration_s": self.duration_s,
            "planner": self.planner,
            "seed": self.seed,
            "time_s": self.time_s,
            "history": [list(h) for h in self.history],
            "waypoints": self.waypoints(terrain),
        }


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
    """Best-energy-so-far reporting: tqdm on stderr and/or a callback."""

    def __init__(self, total: float, show: bool, callback: Callable | None, desc: str):
        self.t0 = _time.perf_counter()
        self.history: list[tuple[float, float]] = []
        self.callback = callback
        self.bar = None
        if show:
            from tqdm import tqdm

            self.bar = tqdm(
                total=round(total, 2),
                unit="s",
                desc=desc,
                file=sys.stderr,
                disable=None,  # off when stderr is not a TTY
                bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total:.1f} s {postfix}",
            )
        self.best = math.inf

    def elapsed(self) -> float:
        return _time.perf_counter() - self.t0

    def report(self, energy: float) -> None:
        t = self.elapsed()
        if energy < self.best:
            self.best = float(energy)
        if math.isfinite(self.best):
            self.history.append((t, self.best))
        if self.callback is not None:
            self.callback(t, self.best)
        if self.bar is not None:
            self.bar.n = min(round(t, 2), self.bar.total)
            self.bar.set_postfix_str(f"best {self.best:.1f} J", refresh=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _seed_ompl(seed: int) -> None:
    from ompl import util as ou

    ou.setLogLevel(ou.LOG_NONE)  # setSeed complains (harmlessly) after the first run
    ou.RNG.setSeed(int(seed) % 2_147_483_000 + 1)  # OMPL rejects 0
    ou.setLogLevel(ou.LOG_WARN)


def _ompl_setup(cost, terrain):
    from ompl import geometric as og

    from energy_planner.planning.objective import EnergyObjective, make_space

    space = make_space(terrain)
    ss = og.SimpleSetup(space)
    si = ss.getSpaceInformation()
    obj = EnergyObjective(si, cost)
    # poses that break a limit are invalid, so the tree does not grow into them (a
    # Python checker, about 1 us per pose; motions are still priced - and limited - by
    # the kernel, whose sub-steps are finer than the 2% checking resolution)
    kernel = obj._kernel

    def valid(state) -> bool:
        x, y, th = state.getX(), state.getY(), state.getYaw()
        return math.isfinite(kernel(x, y, th, x, y, th))

    ss.setStateValidityChecker(valid)
    si.setStateValidityCheckingResolution(0.02)
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
            s.setYaw(math.remainder(self._k * math.pi / 8, 2 * math.pi))  # 16 yaws in turn

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
) -> tuple[np.ndarray, dict]:
    """Run an OMPL planner in chunks, reporting the best energy after each chunk."""
    from ompl import base as ob
    from ompl import geometric as og

    from energy_planner.planning.objective import path_cost, path_states, set_state

    _seed_ompl(seed)
    space, ss, si, obj = _ompl_setup(cost, terrain)
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
    info = {"motion_cost_calls": obj.calls}
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
    gyaw = last[2] if goal[2] is None else math.remainder(goal[2], 2 * math.pi)
    if abs(last[0] - goal[0]) > 1e-9 or abs(last[1] - goal[1]) > 1e-9 or abs(last[2] - gyaw) > 1e-9:
        return np.vstack([states, [goal[0], goal[1], gyaw]])
    return states


def plan(
    terrain,
    model,
    start: Sequence[float],
    goal: Sequence[float],
    planner: str = "auto",
    time: float = 5.0,
    seed: int = 0,
    max_slope_deg: float | None = None,
    max_cross_slope_deg: float | None = None,
    keep_out: Any = None,
    progress: bool = True,
    *,
    speed: float = 0.3,
    yaw_rate: float = 0.5,
    step: float | None = None,
    n_headings: int = 16,
    iterations: int | None = None,
    callback: Callable[[float, float], None] | None = None,
    cost: Any = None,
) -> PlanResult:
    """Plan an energy-minimal SE(2) path.

    Parameters
    ----------
    terrain : Terrain
        The map.
    model : EnergyModel
        A fitted energy model.
    start, goal : sequence of float
        ``(x, y)`` or ``(x, y, yaw)`` in the working CRS (metres; yaw radians CCW from
        +x). Without a yaw the planner chooses the best one.
    planner : str
        One of :data:`energy_planner.planning.PLANNERS`.
    time : float
        Planning budget in seconds (the lattice ignores it; ``auto`` spends what is
        left after the lattice - at least a fifth of ``time`` - on refinement, stopping
        early once it converges).
    seed : int
        Random seed (OMPL's RNG); the same seed gives the same path for ``lattice``,
        ``auto`` when it converges within ``time``, and OMPL planners run with
        ``iterations``.
    max_slope_deg, max_cross_slope_deg : float, optional
        Limits (slope of the ground; slope across the body).
    keep_out : path or sequence of shapely geometries, optional
        Keep-out polygons in the DEM's CRS (GeoJSON file or geometries).
    progress : bool
        Show a tqdm bar with the best energy on stderr (only on a terminal).
    speed, yaw_rate : float
        Nominal walking speed (m/s) and turning rate (rad/s).
    step : float, optional
        Lattice spacing for ``lattice``/``auto`` (default
        :func:`energy_planner.planning.lattice.default_step`).
    n_headings : int
        Lattice headings.
    iterations : int, optional
        For OMPL planners: stop after this many planner iterations instead of ``time``
        (reproducible). For ``auto``: the maximum number of refinement rounds.
    callback : callable, optional
        ``callback(seconds, best_energy_j)`` whenever the best energy is reported.
    cost : MotionCost, optional
        Use this motion cost (limits included) instead of building one.

    Returns
    -------
    PlanResult

    Raises
    ------
    InvalidStateError
        If the start or goal breaks a limit (message names the limit and the value).
    PlanningError
        Unknown planner, or no feasible path.
    """
    from energy_planner.energy import path_energy
    from energy_planner.planning.lattice import lattice_plan
    from energy_planner.planning.limits import check_endpoint, keep_out_violation, make_motion_cost

    if planner not in PLANNERS:
        raise PlanningConfigError(
            f"unknown planner {planner!r}; valid planners: {', '.join(PLANNERS)}"
        )
    if not (time > 0):
        raise PlanningConfigError(f"time must be > 0 seconds, got {time!r}")
    start_p = _pose(start, "start")
    goal_p = _pose(goal, "goal")
    geoms: list[Any] = []
    if cost is None:
        cost, geoms = make_motion_cost(
            terrain,
            model,
            speed=speed,
            yaw_rate=yaw_rate,
            max_slope_deg=max_slope_deg,
            max_cross_slope_deg=max_cross_slope_deg,
            keep_out=keep_out,
        )
    check_endpoint(cost, terrain, "start", start_p, geoms)
    check_endpoint(cost, terrain, "goal", goal_p, geoms)

    # compile the kernels before the clock starts (numba compiles on first call)
    cost.compile()
    warm = _cost_fn(cost)
    warm(start_p[0], start_p[1], 0.0, start_p[0], start_p[1], 0.0)
    one = np.array([start_p[0]])
    cost.batch(one, np.array([start_p[1]]), np.zeros(1), one, np.array([start_p[1]]), np.zeros(1))
    prog = _Progress(time, progress, callback, f"plan ({planner})")
    info: dict[str, Any] = {}
    try:
        if planner in ("lattice", "auto"):
            lat = lattice_plan(cost, terrain, start_p, goal_p, step=step, n_headings=n_headings)
            info["lattice"] = {
                "step_m": lat.step,
                "headings": lat.n_headings,
                "nodes": lat.n_nodes,
                "edges": lat.n_edges,
                "build_s": lat.build_s,
                "search_s": lat.search_s,
            }
            states = lat.states
            from energy_planner.planning.objective import path_cost

            prog.report(path_cost(_cost_fn(cost), states))
            if planner == "auto":
                from energy_planner.planning.refine import refine_path

                states, rinfo = refine_path(
                    cost,
                    states,
                    budget=max(time - prog.elapsed(), 0.2 * time),
                    seed=seed,
                    spacing=max(lat.step, float(abs(terrain.grid[2]))),
                    free_start_yaw=start_p[2] is None,
                    free_goal_yaw=goal_p[2] is None,
                    max_rounds=iterations,
                    report=prog.report,
                )
                info["refine"] = rinfo
        else:
            states, info = _run_ompl(
                cost, terrain, start_p, goal_p, planner, time, seed, iterations, prog
            )
    finally:
        prog.close()
    from energy_planner.planning.lattice import simplify_states

    states = simplify_states(states)
    bad = keep_out_violation(states, geoms)
    if bad is not None:
        raise PlanningError(f"the {planner} path enters a keep-out area: {bad}")
    try:
        pe = path_energy(terrain, model, states[:, :2], yaw=states[:, 2], cost=cost)
    except Exception as exc:
        raise PlanningError(f"the {planner} path is not feasible: {exc}") from exc
    return PlanResult(
        states=states,
        energy_j=pe.energy_j,
        distance_m=pe.distance_m,
        duration_s=pe.duration_s,
        planner=planner,
        history=prog.history,
        time_s=prog.elapsed(),
        seed=seed,
        info=info,
    )


def _cost_fn(cost):
    from energy_planner.planning.objective import bind_kernel

    return bind_kernel(cost)
