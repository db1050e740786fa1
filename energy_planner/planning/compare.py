"""Direct climb versus detour (the paper's Fig. 1): three routes between two points.

* ``direct``: the straight line, walked facing the goal (turns in place at the ends if
  a start/goal yaw is given). If it breaks a limit it is reported as infeasible with
  the reason, and its energy is still given when it stays on the map.
* ``direct_best_yaw``: the same straight line walked with the body at its cheapest
  constant yaw from the direction of travel (crabbing, as ``plan`` and ``energy`` allow),
  so that the saving of the energy-optimal route splits into gait (``direct`` ->
  ``direct_best_yaw``) and route (``direct_best_yaw`` -> ``energy_optimal``).
* ``shortest``: the shortest feasible path, by distance along the ground: the lattice
  searched with edge length as the weight under the same limits, then refined off the
  lattice under a cost equal to the ground distance (starting also from the straight
  line and from the energy-optimal path, whichever ends shorter), walked facing forward.
* ``energy_optimal``: :func:`energy_planner.planning.plan` (default ``auto``), refined
  again, and the shortest route and the straight line refined under the energy (local
  refinement keeps the homotopy class of its start); each start is also tried walked
  with the cheapest constant body yaw (a model can make crabbing up a slope cheaper than
  facing it, and pose-by-pose refinement cannot reach a whole-path gait change); the
  cheapest is kept.

When two routes are the same path (within a cell everywhere, and with the body turned
the same way within 15 deg), the later one says so
(``same_as``) instead of repeating the other: with no limit the straight line is usually
the shortest feasible path.

Why a detour can save energy without any limit: walking up a grade ``g`` (the sine of the
path's inclination) costs ``c(g)`` joules per metre, so a metre of height costs
``c(g) / g``. When ``c`` is convex (copper losses grow with the square of the force the
legs hold against gravity: ``c = a + b g + k g^2``), ``c(g) / g`` is least at the
critical grade ``g* = sqrt(a / k)``; climbing a hill steeper than ``g*`` costs more per
metre of height than zig-zagging or going round at ``g*``. :func:`grade_cost` computes
``c``, ``g*`` and the closed form from a model; the comparison reports them with each
route's climbing grade.

Every energy is :func:`energy_planner.energy.path_energy` of the route's poses with the
same :class:`~energy_planner.energy.MotionCost`, the problem's
(:attr:`energy_planner.problem.Problem.cost`, every limit and keep-out area in it); the
shortest route is planned with the same problem pricing ground distance
(:meth:`~energy_planner.problem.Problem.distance`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from energy_planner.errors import EnergyPlannerError, PlanningConfigError, PlanningError
from energy_planner.planning.gradecost import GradeCost, grade_cost
from energy_planner.planning.routes import ROUTE_NAMES, Route, RouteComparison
from energy_planner.problem import takes_problem

__all__ = [
    "GradeCost",
    "ROUTE_NAMES",
    "Route",
    "RouteComparison",
    "compare_routes",
    "grade_cost",
]


def _climb(terrain, states: np.ndarray) -> tuple[float, float | None]:
    """Total ascent (m) and mean climbing grade along a route's positions.

    The grade is ascent / ground length of the climbing parts; ``None`` if the route
    never climbs.
    """
    from energy_planner.planning.refine import densify

    xy = np.column_stack([states[:, :2], np.zeros(len(states))])
    d = densify(xy, 0.25 * abs(float(terrain.grid[2])))
    z = np.asarray(terrain.sample(d[:, 0], d[:, 1]).elevation, float)
    dz = np.diff(z)
    ds = np.sqrt(np.hypot(np.diff(d[:, 0]), np.diff(d[:, 1])) ** 2 + dz**2)
    up = np.isfinite(dz) & (dz > 0)
    ascent = float(dz[up].sum())
    length = float(ds[up].sum())
    return ascent, (ascent / length if length > 0 else None)


def _walk(problem, states: np.ndarray, t: np.ndarray | None = None):
    """``states`` priced with the problem's cost: ``(PathEnergy, times or None)``.

    Where the motions choose their speed (a speed range, a price of a second) each walks
    at its chosen speed and the poses get their times, as a plan's do; given ``t``
    (seconds per pose), at those times.
    """
    from energy_planner.energy import path_energy

    cost = problem.cost
    if t is None and cost.ranged:
        dt = cost.best_durations(states[:, 0], states[:, 1], states[:, 2])
        if not np.isfinite(dt).all():
            raise EnergyPlannerError("a motion breaks a limit at every speed of the range")
        t = np.concatenate([[0.0], np.cumsum(dt)])
    pe = path_energy(problem.terrain, problem.model, states[:, :2], yaw=states[:, 2], t=t,
                     cost=cost)  # fmt: skip
    return pe, t


def _route(name: str, states: np.ndarray, problem, t: np.ndarray | None = None) -> Route:
    """Price ``states`` with the problem's cost (raises EnergyPlannerError past a limit).

    ``t``: seconds at each pose (else the chosen speeds', or the nominal speed's).
    """
    pe, t = _walk(problem, states, t)
    ascent, grade = _climb(problem.terrain, states)
    return Route(
        name=name,
        states=states,
        energy_j=pe.energy_j,
        distance_m=pe.distance_m,
        duration_s=pe.duration_s,
        max_slope_deg=float(pe.segments["max_slope_deg"].max()),
        feasible=True,
        ascent_m=ascent,
        climb_grade=grade,
        times=t,
        segment_distance_m=None if t is None else np.asarray(pe.table["distance_m"], float),
    )


def _assessed(problem, states: np.ndarray, trust: Any, times: np.ndarray | None = None):
    """A route's assessment: its poses priced with the problem's cost, then assessed.

    Interval, domain report, battery verdict
    (:func:`energy_planner.uncertainty.assess.assess_path`); ``times``: the route's own.
    """
    from energy_planner.uncertainty.assess import assess_path

    pe, _ = _walk(problem, states, times)
    return assess_path(problem.model, pe, problem.cost, trust)


def _face_along(states: np.ndarray, start, goal) -> np.ndarray:
    """Poses that walk forward along each segment of ``states`` and turn at corners.

    A distance-optimal path's headings are arbitrary (turning is free for a distance
    metric); a robot taking the shortest route walks it facing forward.
    """
    from energy_planner.energy.path import face_along_poses
    from energy_planner.planning.lattice import simplify_states

    xy = simplify_states(np.column_stack([states[:, :2], np.zeros(len(states))]))[:, :2]
    xy = xy[np.r_[True, np.any(np.diff(xy, axis=0) != 0, axis=1)]]
    if len(xy) < 2:
        return states
    poses = face_along_poses(xy)
    if start[2] is not None:
        poses = np.vstack([[xy[0, 0], xy[0, 1], math.remainder(start[2], 2 * math.pi)], poses])
    if goal[2] is not None:
        poses = np.vstack([poses, [xy[-1, 0], xy[-1, 1], math.remainder(goal[2], 2 * math.pi)]])
    return simplify_states(poses)


def _direct_states(start, goal) -> np.ndarray:
    heading = math.atan2(goal[1] - start[1], goal[0] - start[0])
    poses = []
    if start[2] is not None and abs(math.remainder(start[2] - heading, 2 * math.pi)) > 1e-12:
        poses.append((start[0], start[1], math.remainder(start[2], 2 * math.pi)))
    poses += [(start[0], start[1], heading), (goal[0], goal[1], heading)]
    if goal[2] is not None and abs(math.remainder(goal[2] - heading, 2 * math.pi)) > 1e-12:
        poses.append((goal[0], goal[1], math.remainder(goal[2], 2 * math.pi)))
    return np.array(poses, dtype=float)


#: Two routes whose body yaws differ by more than this at matching places are not the
#: same path, even along the same line (a crabbed walk is another gait).
SAME_YAW_TOL = math.radians(15.0)


def _same_path(a: Route, b: Route, tol: float, yaw_tol: float = SAME_YAW_TOL) -> bool:
    """True when both routes' poses match.

    Positions within ``tol`` metres everywhere (Hausdorff) and, at every vertex of either,
    the body yaw within ``yaw_tol`` of the other route's nearest vertex.
    """
    from shapely.geometry import LineString, Point

    if a.states is None or b.states is None:
        return False

    def geom(s):
        xy = s[:, :2]
        xy = xy[np.r_[True, np.any(np.diff(xy, axis=0) != 0, axis=1)]]
        return Point(xy[0]) if len(xy) < 2 else LineString(xy)

    if geom(a.states).hausdorff_distance(geom(b.states)) > tol:
        return False
    for p, q in ((a.states, b.states), (b.states, a.states)):
        d = np.hypot(p[:, None, 0] - q[None, :, 0], p[:, None, 1] - q[None, :, 1])
        dyaw = np.remainder(p[:, 2] - q[np.argmin(d, axis=1), 2] + np.pi, 2 * np.pi) - np.pi
        if np.max(np.abs(dyaw)) > yaw_tol:
            return False
    return True


def _best_gait(states: np.ndarray, cost, start, goal) -> tuple[np.ndarray, float]:
    """The path's positions walked with the body at the cheapest constant yaw offset.

    The yaw ``psi`` is measured from the direction of travel (0: facing it); the cheapest
    ``psi`` on a 10 deg grid is used.

    Local refinement moves one pose at a time, so it cannot turn a whole path into a
    crabbing gait (each single yaw change costs two turns first); this offers it whole.
    """
    base = _face_along(states, start, goal)
    fixed = np.zeros(len(base), bool)
    if start[2] is not None:
        fixed[0] = True
    if goal[2] is not None:
        fixed[-1] = True
    best, best_e, best_psi = states, float(np.sum(_edges(cost, states))), 0.0
    for grid in (np.arange(-180.0, 180.0, 10.0), None):
        if grid is None:  # then 1 deg steps about the best of the 10 deg grid
            grid = math.degrees(best_psi) + np.arange(-9.0, 10.0, 1.0)
        for psi in np.radians(grid):
            cand = base.copy()
            cand[~fixed, 2] = np.remainder(cand[~fixed, 2] + psi + np.pi, 2 * np.pi) - np.pi
            e = float(np.sum(_edges(cost, cand)))
            if e < best_e:
                best, best_e, best_psi = cand, e, float(psi)
    return best, best_psi


def _edges(cost, s: np.ndarray) -> np.ndarray:
    return cost.batch(s[:-1, 0], s[:-1, 1], s[:-1, 2], s[1:, 0], s[1:, 1], s[1:, 2])


class _Candidates:
    """Refine several starting paths under one problem's cost; keep the best route by a key.

    ``objective`` (a :class:`~energy_planner.problem.Problem`: the energy one, or its
    :meth:`~energy_planner.problem.Problem.distance` for the shortest route) prices the
    refinement; every candidate is then walked as ``post(states)`` and priced by
    :func:`_route` with ``problem``, whose cost holds every limit and keep-out area, so
    that only feasible routes compete.
    """

    def __init__(self, name, problem, key, budget, seed, post=None):
        self.name, self.problem, self.key = name, problem, key
        self.budget, self.seed = budget, seed
        self.post = post or (lambda s: s)
        self.best: Route | None = None
        self.origin: str | None = None
        # the (states, objective) already offered: the same path offered again (the plan
        # offered with its cheapest constant body yaw when that yaw is its own) would be
        # refined again from the same seed, the same search repeated (under a time budget
        # that is a budget spent for nothing), and walked again to the same route
        self._offered: set[tuple[bytes, int]] = set()

    def offer(self, states: np.ndarray | None, origin: str, objective=None, gait=None) -> None:
        """Offer ``states`` as a candidate route.

        They are refined under ``objective`` (a Problem) first when given; with ``gait =
        (start, goal)``, first walked with the cheapest constant body yaw.
        """
        from energy_planner.planning.refine import densify, refine_path

        if states is None:
            return
        if gait is not None:
            states, psi = _best_gait(states, (objective or self.problem).cost, *gait)
            if psi:
                origin += f", body turned {math.degrees(psi):.0f} deg"
        seen = (np.ascontiguousarray(states, dtype=np.float64).tobytes(), id(objective))
        if seen in self._offered:
            return
        self._offered.add(seen)
        tries = [(states, origin)]
        spacing = abs(float(self.problem.terrain.grid[2]))
        # refinement densifies the path first; a path that hugs a limit can break it
        # once resampled, and then cannot be refined (it still competes as it is)
        dense = densify(states, spacing)
        if (
            objective is not None
            and np.isfinite(objective.cost.batch(*dense[:-1].T, *dense[1:].T)).all()
        ):
            refined, _ = refine_path(
                objective.cost, states, budget=self.budget, seed=self.seed, spacing=spacing
            )
            tries.insert(0, (refined, origin + ", refined"))
        for s, why in tries:
            s = self.post(s)
            try:
                r = _route(self.name, s, self.problem)
            except EnergyPlannerError:
                continue
            if self.best is None or self.key(r) < self.key(self.best) * (1 - 1e-9):
                self.best, self.origin = r, why


@takes_problem(2)
def compare_routes(
    problem,
    start: Sequence[float],
    goal: Sequence[float],
    *,
    planner: str = "auto",
    time: float = 5.0,
    seed: int = 0,
    step: float | None = None,
    progress: bool = True,
    speed: Any = None,
    deadline: float | None = None,
    pareto: int | None = None,
    **trust: Any,
) -> RouteComparison:
    """Compare the direct line, the shortest feasible path and the energy-optimal path.

    Parameters
    ----------
    problem : Problem
        Terrain, model and request (robot, limits applied to every route, keep-outs,
        channels) bound once (:class:`energy_planner.problem.Problem`; the older form
        ``compare_routes(terrain, model, start, goal, request=None, ...)`` is accepted).
        Every route is priced, and planned, with its cost, so keep-out areas and limits
        hold during planning; the shortest route is planned with
        :meth:`~energy_planner.problem.Problem.distance`.
    start, goal : sequence of float
        ``(x, y)`` or ``(x, y, yaw)`` in the working CRS (metres, radians).
    planner, time, seed, step, progress
        Passed to :func:`energy_planner.planning.plan` for the energy-optimal route
        (``step`` also sets the shortest-path lattice). Each extra refinement gets
        ``min(2, max(time / 4, 0.5))`` seconds.
    speed : float, (float, float) or "auto", optional
        A number: every route at that speed (the request's nominal speed otherwise).
        A range (``"auto"``: the one the model's logs cover,
        :func:`~energy_planner.planning.speed.resolve_speed`): every route is walked at
        its best speed profile, each motion at its least-energy speed in the range, and
        the energy-optimal route is planned with the speeds chosen; each route carries
        its ``times`` and :meth:`~Route.speed_profile`.
    deadline : float, optional
        Seconds (speeds within ``speed``, default ``"auto"``): each route walked at the
        least-energy speed profile that arrives in time
        (:func:`~energy_planner.planning.speed.timed_deadline`; ``Route.deadline`` says
        whether it can, and ``lambda``), and the energy-optimal route is the least-energy
        one in time among them and the plan under the deadline
        (:func:`~energy_planner.planning.speed.plan_deadline`): a deadline may favour
        the direct climb over the detour. ``info["deadline"]`` says which it is.
    pareto : int, optional
        ``N`` points of each route's energy-time front (``fronts``, by route name): the
        energy-optimal one from :func:`~energy_planner.planning.speed.pareto` (the route
        changes with ``lambda``: the front's convex hull), each other distinct route
        walked at the same ``lambda`` values (:func:`~energy_planner.planning.speed.route_front`).
    **trust
        ``level``, ``battery_wh``, ``reserve_wh``, ``confidence``
        (:class:`~energy_planner.trust.Trust`, or ``trust=`` one): each feasible route's
        ``assessment`` (interval, domain report, battery verdict).

    Returns
    -------
    RouteComparison
        ``routes`` in the order ``direct``, ``direct_best_yaw``, ``shortest``,
        ``energy_optimal``; ``saving_vs_direct`` is ``(E_direct - E) / E_direct``;
        ``physics`` the model's critical grade; ``fronts`` with ``pareto``.
    """
    from energy_planner.planning.limits import check_endpoint
    from energy_planner.planning.plan import _pose
    from energy_planner.trust import Trust

    want = Trust.pop(trust)
    if trust:
        raise TypeError(f"compare_routes() got unexpected keyword(s) {', '.join(trust)}")
    if deadline is not None and pareto is not None:
        raise PlanningConfigError("give a deadline or a pareto front, not both",
                                  value=pareto, param="pareto")  # fmt: skip
    spec, fixed = None, problem  # the limits do not depend on the speed: the lattice's
    if speed is not None or deadline is not None or pareto is not None:
        from energy_planner.planning.speed import resolve_speed, with_speed

        spec = resolve_speed("auto" if speed is None else speed, problem.model)
        problem = with_speed(problem, spec)  # a number: the nominal speed, as before
        spec = problem.cost.speed_range
        if spec is None and (deadline is not None or pareto is not None):
            raise PlanningConfigError(
                "a deadline or a front needs a speed range (vmin, vmax) or 'auto' from a "
                f"model whose logs cover several speeds, got speed={speed!r}",
                value=speed,
                param="speed",
            )
    s, g = _pose(start, "start"), _pose(goal, "goal")
    for which, pose in (("start", s), ("goal", g)):
        check_endpoint(problem.cost, problem.terrain, which, pose, problem.keep_out)
    direct, direct_yaw = _direct_routes(problem, s, g)
    dist = problem.distance()
    dist.cost.compile()  # before the refinements' time budgets start
    found = _planned_paths(problem, fixed, s, g, planner, time, seed, step, progress)
    short, best = _refined_routes(problem, dist, s, g, direct, found, min(2.0, max(time / 4, 0.5)),
                                  seed)  # fmt: skip
    info = found["info"]
    info["energy_optimal_from"] = best.origin
    info["shortest_from"] = short.origin
    routes = [direct, direct_yaw]
    errors = (found["lattice_error"], found["plan_error"])
    for cand, err in ((short, errors[0] or errors[1]), (best, errors[1] or errors[0])):
        routes.append(cand.best or Route(cand.name, None, None, None, None, None, False, err))
    plan_kw = dict(planner=planner, time=time, seed=seed, step=step, progress=progress)
    if deadline is not None:
        _meet_deadline(problem, routes, s, g, deadline, spec, plan_kw, info)
    _mark_same_paths(routes, abs(float(problem.terrain.grid[2])))
    if direct.energy_j:
        for r in routes:
            if r.energy_j is not None:
                r.saving_vs_direct = (direct.energy_j - r.energy_j) / direct.energy_j
    for r in routes:
        if r.feasible and r.states is not None and r.energy_j is not None:
            r.assessment = _assessed(problem, r.states, want, r.times)
    lim = problem.request.limits
    comp = RouteComparison(
        routes=routes,
        start=s,
        goal=g,
        limits={
            "max_slope_deg": lim.max_slope_deg,
            "max_cross_slope_deg": lim.max_cross_slope_deg,
            "max_backward_slope_deg": lim.max_backward_slope_deg,
            "max_crab_deg": lim.max_crab_deg,
            "keep_out_areas": len(problem.keep_out),
        },
        info=info,
        physics=_physics(problem, routes),
    )
    if spec is not None:
        info["speed"] = {"speed_range": list(spec) if spec else None,
                         "speed_law": problem.cost.speed_law.note
                         if problem.cost.speed_law is not None else None}  # fmt: skip
    if pareto is not None:
        comp.fronts = _fronts(problem, routes, s, g, pareto, spec, plan_kw)
    comp.problem = problem
    return comp


def _meet_deadline(problem, routes, s, g, deadline, spec, plan_kw, info) -> None:
    """Each route walked at its least-energy timing in time; the best of them energy-optimal.

    The energy-optimal route becomes the least-energy one in time among the routes (each
    retimed, :func:`~energy_planner.planning.speed.timed_deadline`; the energy-optimal one
    found without the deadline too) and the plan under the deadline
    (:func:`~energy_planner.planning.speed.plan_deadline`, retimed the same way); none in
    time: it says so with the fastest duration. ``info["deadline"]["candidates"]`` lists
    each with its energy and duration in time (or its fastest duration).
    """
    from energy_planner.planning.speed import plan_deadline, timed_deadline

    cands: list[dict[str, Any]] = []
    winners: list[tuple[Route, str]] = []

    def retime(r: Route, states, label: str) -> Route:
        row: dict[str, Any] = {"route": label}
        try:
            res = timed_deadline(problem, states, deadline, speed=spec, name=label)
        except PlanningError as exc:
            if getattr(exc, "limit", None) != "deadline":
                raise
            r.deadline = {"on_time": False, "lambda_j_per_s": None, "fastest_s": exc.value}
            cands.append({**row, "on_time": False, "energy_j": None, "duration_s": None,
                          "lambda_j_per_s": None, "fastest_s": exc.value})  # fmt: skip
            return r
        out = _route(r.name, res.states, problem, res.times)  # at the deadline's timing
        out.body_yaw_deg = r.body_yaw_deg
        lam = res.info["deadline"]["lambda_j_per_s"]
        out.deadline = {"on_time": True, "lambda_j_per_s": lam, "fastest_s": None}
        cands.append({**row, "on_time": True, "energy_j": out.energy_j,
                      "duration_s": out.duration_s, "lambda_j_per_s": lam,
                      "fastest_s": None})  # fmt: skip
        winners.append((out, label))
        return out

    for i, r in enumerate(routes):
        if r.feasible and r.states is not None:
            label = r.name + (" (found without the deadline)" if r.name == "energy_optimal" else "")
            routes[i] = retime(r, r.states, label)
    try:
        planned = plan_deadline(problem, s, g, deadline, speed=spec, **plan_kw)
        cand = Route("energy_optimal", planned.states, None, None, None, None, True)
        retime(cand, planned.states, "plan under the deadline")
    except PlanningError as exc:
        if getattr(exc, "limit", None) != "deadline":
            raise
    eo = next(i for i, r in enumerate(routes) if r.name == "energy_optimal")
    d_info: dict[str, Any] = {"deadline_s": float(deadline), "energy_optimal_from": None,
                              "candidates": cands}  # fmt: skip
    if winners:
        best, label = min(winners, key=lambda rl: rl[0].energy_j)
        routes[eo] = dataclasses.replace(best, name="energy_optimal", same_as=None)
        d_info["energy_optimal_from"] = label
    else:
        fastest = [c["fastest_s"] for c in cands if c["fastest_s"] is not None]
        fast = min(fastest) if fastest else None
        routes[eo] = Route("energy_optimal", None, None, None, None, None, False,
                           f"no route arrives within {deadline:g} s"
                           + ("" if fast is None else f"; the fastest takes {fast:.1f} s"),
                           deadline={"on_time": False, "lambda_j_per_s": None,
                                     "fastest_s": fast})  # fmt: skip
    info["deadline"] = d_info


def _fronts(problem, routes, s, g, n, spec, plan_kw) -> dict[str, Any]:
    """Each distinct route's energy-time front; the energy-optimal one planned per lambda."""
    from energy_planner.planning.speed import pareto, route_front

    fronts: dict[str, Any] = {}
    try:
        fronts["energy_optimal"] = pareto(problem, s, g, n, speed=spec, **plan_kw)
        lams = fronts["energy_optimal"].lambdas
    except PlanningError:
        best = next(r for r in routes if r.name == "energy_optimal")
        if best.energy_j is None:
            return fronts
        from energy_planner.planning.speed import front_lambdas

        lams = front_lambdas(best.energy_j / max(best.duration_s, 1e-9), n)
    for r in routes:
        if r.name == "energy_optimal" or not r.feasible or r.states is None or r.same_as:
            continue
        fronts[r.name] = route_front(problem, r.states, lams, speed=spec, name=r.name)
    return dict(sorted(fronts.items(), key=lambda kv: ROUTE_NAMES.index(kv[0])))


def _direct_routes(problem, s, g) -> tuple[Route, Route]:
    """The straight line facing the goal, and walked at its cheapest constant body yaw.

    A line that breaks a limit (or enters a keep-out area) is infeasible with the reason;
    its energy is still given, priced without limits, when it stays on the map.
    """
    d_states = _direct_states(s, g)
    try:
        direct = _route("direct", d_states, problem)
    except EnergyPlannerError as exc:
        reason = _direct_reason(problem.cost, d_states, str(exc))
        try:
            direct = _route("direct", d_states, problem.unlimited())
        except EnergyPlannerError:
            direct = Route("direct", d_states, None, None, None, None, False)
        direct.feasible = False
        if direct.max_slope_deg is not None and problem.request.limits.max_slope_deg is not None:
            reason += f" (the line reaches {direct.max_slope_deg:.1f} deg)"
        direct.reason = reason
        return direct, Route("direct_best_yaw", None, None, None, None, None, False, reason)
    # the same line at its cheapest constant body yaw: the gait part of any saving
    crab, psi = _best_gait(d_states, problem.cost, s, g)
    direct_yaw = _route("direct_best_yaw", crab, problem)
    direct_yaw.body_yaw_deg = round(math.degrees(psi), 1)
    direct.body_yaw_deg = 0.0
    return direct, direct_yaw


def _planned_paths(problem, fixed, s, g, planner, time, seed, step, progress) -> dict[str, Any]:
    """The distance-optimal lattice path and the energy-optimal plan, or why not.

    ``fixed``: the problem at the nominal speed, whose cost tells the lattice which edges
    break a limit (the same at every speed, and cheaper to price).
    """
    from energy_planner.planning.lattice import lattice_plan
    from energy_planner.planning.plan import plan

    out: dict[str, Any] = {"lattice": None, "lattice_error": None, "plan": None,
                           "plan_error": None, "info": {"planner": planner}}  # fmt: skip
    try:
        out["lattice"] = lattice_plan(fixed, s, g, step=step, metric="distance").states
    except EnergyPlannerError as exc:
        out["lattice_error"] = str(exc)
    try:
        res = plan(problem, s, g, planner=planner, time=time, seed=seed, progress=progress,
                   step=step)  # fmt: skip
        out["plan"] = res.states
        skip = ("request", "segment_distance_m", "speed_range", "time_weight", "speed_law")
        out["info"].update({k: v for k, v in res.info.items() if k not in skip},
                           time_s=res.time_s)  # fmt: skip
    except EnergyPlannerError as exc:
        out["plan_error"] = str(exc)
    return out


def _refined_routes(problem, dist, s, g, direct: Route, found, budget, seed):
    """The shortest and the energy-optimal routes, each the best of several refinements.

    Shortest: least ground distance over the distance lattice's path, the straight line
    and the energy-optimal path refined under ``dist``; energy-optimal: the plan, and the
    shortest route and the straight line refined under the energy (each also walked at
    its cheapest constant body yaw).
    """
    d_states = direct.states if direct.feasible else None
    plan_states = found["plan"]
    short = _Candidates("shortest", problem, lambda r: r.distance_m, budget, seed,
                        post=lambda st: _face_along(st, s, g))  # fmt: skip
    short.offer(found["lattice"], "distance lattice", dist)
    short.offer(d_states, "straight line")
    short.offer(plan_states, "energy-optimal path", dist)
    best = _Candidates("energy_optimal", problem, lambda r: r.energy_j, budget, seed)
    name = f"plan ({found['info']['planner']})"
    best.offer(plan_states, name, problem)
    best.offer(plan_states, name, problem, gait=(s, g))
    if short.best is not None:
        best.offer(short.best.states, "shortest route", problem, gait=(s, g))
    best.offer(d_states, "straight line", problem, gait=(s, g))
    if best.best is not None and not best.origin.startswith("plan"):
        # the energy refinement of the shortest route can end shorter than it
        short.offer(best.best.states, "energy-optimal route", dist)
        if short.best is not None:
            best.offer(short.best.states, "shortest route")
    return short, best


def _mark_same_paths(routes: list[Route], cell: float) -> None:
    """A route that is the same path as an earlier one says so (``same_as``)."""
    for i in range(1, len(routes)):
        for j in range(i):
            if routes[i].feasible and routes[j].feasible and _same_path(routes[i], routes[j], cell):
                routes[i].same_as = routes[j].name
                break


def _physics(problem, routes: list[Route]) -> dict[str, Any] | None:
    """The model's critical grade and each route's cost per metre of height (or None)."""
    request = problem.request
    try:
        consts = dict(request.channels.constants) if request.channels is not None else None
        gc = grade_cost(problem.model, request.robot.speed, constants=consts)
    except EnergyPlannerError:
        return None  # the model needs channels that are not given as constants
    physics = gc.to_dict()
    physics["per_height"] = {r.name: gc.per_height(r.climb_grade) for r in routes if r.climb_grade}
    return physics


def _direct_reason(cost, states: np.ndarray, fallback: str) -> str:
    """Name the limit the straight line breaks first, with its value."""
    from energy_planner.planning.limits import fmt_xy

    d = np.asarray(states)
    for a, b in zip(d[:-1], d[1:], strict=True):
        length = math.hypot(b[0] - a[0], b[1] - a[1])
        n = max(2, int(length / (0.25 * abs(cost.terrain.grid[2]))) + 1)
        for f in np.linspace(0, 1, n):
            x, y = a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])
            v = cost.violation(x, y, b[2])
            if v is not None:
                return f"{v} at {fmt_xy(cost.terrain, x, y)}, {f * length:.1f} m along"
    return fallback
