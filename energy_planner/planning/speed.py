"""Speed as a decision: the speed range, a deadline, and the energy-time front.

:func:`energy_planner.planning.plan.plan` walks each motion at its best speed within a
range (``speed=(vmin, vmax)``: :mod:`energy_planner.energy.speed`, closed form per motion).
Trading energy for time is its Lagrangian: minimise ``energy + lambda x time`` (each
motion's speed then minimises its own ``E + lambda T``, the same closed form with one more
``1 / v`` term), for a price of a second ``lambda`` >= 0 (J/s):

- :func:`plan_deadline`: the least ``lambda`` whose path arrives in time, by bisection;
  the least-energy path on time among those the sweep priced. Speed and route change
  together: a dearer second may favour the direct climb over the detour.
- :func:`pareto`: the energy-time front from a sweep of ``lambda``. A Lagrangian sweep
  finds only the points of the front's **convex hull**: a path on a concave stretch of the
  front (cheaper than the chord between its neighbours in neither energy nor time) is
  never the minimum of ``E + lambda T`` for any ``lambda``, so it is not reported; the
  points between two reported ones are not known to be reachable.

A route whose poses are given (the direct climb, the shortest route of
:func:`~energy_planner.planning.compare.compare_routes`, a mission's leg) is timed the same
way without a search: :func:`timed` walks its poses at each motion's best speed for a
``lambda``, :func:`timed_deadline` finds the least ``lambda`` whose timing is in time (one
route: its duration falls as ``lambda`` grows, so the bisection closes on the deadline),
and :func:`route_front` sweeps ``lambda`` over it.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from energy_planner.errors import EnergyPlannerWarning, PlanningConfigError, PlanningError

__all__ = [
    "gait_changes",
    "speed_range_of",
    "resolve_speed",
    "with_speed",
    "plan_deadline",
    "pareto",
    "ParetoFront",
    "DEADLINE_ITERS",
    "bisect_time_price",
    "timed",
    "timed_deadline",
    "close_on_deadline",
    "route_front",
    "front_lambdas",
    "retimed",
    "speed_profile",
    "plot_fronts",
]

#: Bisection steps of :func:`plan_deadline` on ``log(lambda)`` after the bracket is found.
DEADLINE_ITERS = 6
#: ``lambda`` of the fastest path, in units of the least-energy path's mean power: the
#: time then weighs 100 times the energy, every motion walks at the top of the range.
FASTEST_WEIGHT = 100.0
#: Bisections of :func:`timed_deadline` on ``log(lambda)`` (it stops earlier once the
#: route arrives within :data:`ROUTE_DEADLINE_RTOL` of the deadline).
ROUTE_DEADLINE_ITERS = 40
#: A timed route whose duration is within this fraction below the deadline is not slowed
#: further (its energy is then within about this fraction of the constrained optimum).
ROUTE_DEADLINE_RTOL = 1e-4


def speed_profile(
    states: Any, times: Any, distances: Any = None, gaits: Any = None
) -> list[dict[str, Any]]:
    """Per segment of a timed path: ``distance_m``, ``duration_s`` and ``speed_m_s``.

    ``times``: seconds at each pose; ``distances``: ground length of each segment (metres;
    default the horizontal one); ``gaits``: each segment's gait, given as ``gait`` (where
    the motions chose it). A segment that only turns has speed 0. Empty without times.

    Examples
    --------
    >>> speed_profile([[0, 0, 0], [3, 4, 0], [3, 4, 1]], [0.0, 10.0, 12.0])[:2]
    [{'distance_m': 5.0, 'duration_s': 10.0, 'speed_m_s': 0.5}, \
{'distance_m': 0.0, 'duration_s': 2.0, 'speed_m_s': 0.0}]
    """
    if times is None:
        return []
    states = np.asarray(states, dtype=float)
    dt = np.diff(np.asarray(times, dtype=float))
    if distances is None:
        distances = np.hypot(*np.diff(states[:, :2], axis=0).T)
    out = [
        {"distance_m": float(d), "duration_s": float(t),
         "speed_m_s": float(d / t) if d > 1e-9 else 0.0}
        for d, t in zip(distances, dt, strict=True)
    ]  # fmt: skip
    if gaits is not None:
        for seg, g in zip(out, gaits, strict=True):
            seg["gait"] = g
    return out


def gait_changes(cost: Any, states: Any) -> np.ndarray | None:
    """Mask of the poses where the motions' chosen gait changes (None: no gait choice).

    A pose between a motion walked in one gait and the next in another (as the cost
    chooses them, :meth:`~energy_planner.energy.MotionCost.best_timing`): merging the two
    motions into one would walk both in one gait.
    """
    if not (getattr(cost, "gaits", ()) and getattr(cost, "ranged", False)):
        return None
    s = np.asarray(states, dtype=float)
    if len(s) < 3:
        return None
    _, gaits = cost.best_timing(s[:, 0], s[:, 1], s[:, 2])
    g = np.array([-1 if v is None else cost.gaits.index(v) for v in gaits])
    walk = np.hypot(*np.diff(s[:, :2], axis=0).T) > 1e-9
    out = np.zeros(len(s), bool)
    idx = np.flatnonzero(walk)  # turns in place do not break a run's gait
    change = idx[1:][g[idx[1:]] != g[idx[:-1]]]
    out[change] = True
    return out


def speed_range_of(model: Any) -> tuple[float, float] | None:
    """The range of walking speeds the model's calibration logged, m/s.

    The fit's domain (``metadata.fit.domain.speed_m_s``), else the simulated campaign's
    speeds (``metadata.campaign.speeds_m_s``). None (with a warning) when the logs hold
    one speed: the speed terms are not identified, and a plan keeps its nominal speed.

    Raises
    ------
    PlanningConfigError
        If the model records no logged speeds at all.
    """
    from energy_planner.uncertainty.domain import domain_of

    meta = getattr(model, "metadata", None) or {}
    dom = domain_of(model) or {}
    rng = dom.get("speed_m_s")
    if not rng:
        speeds = (meta.get("campaign") or {}).get("speeds_m_s")
        rng = [min(speeds), max(speeds)] if speeds else None
    if not rng:
        raise PlanningConfigError(
            "speed 'auto' needs the speeds the model's logs cover, and the model records "
            "none (metadata.fit.domain.speed_m_s); expected a model fitted from logs, or "
            "give the range as MIN:MAX (m/s)",
            value="auto",
            param="speed",
        )
    lo, hi = float(rng[0]), float(rng[1])
    if not hi > lo:
        warnings.warn(
            EnergyPlannerWarning(
                f"the model's logs hold one walking speed ({lo:g} m/s): its speed terms are "
                "not identified, so every motion keeps the nominal speed",
                api_hint="give speed=(vmin, vmax) to choose within a range anyway",
                cli_hint="give --speed MIN:MAX to choose within a range anyway",
            ),
            stacklevel=3,
        )
        return None
    return lo, hi


def resolve_speed(speed: Any, model: Any) -> float | tuple[float, float] | None:
    """A speed argument as a number (fixed), a ``(vmin, vmax)`` range, or None.

    ``speed``: None, a number, a pair, ``"auto"`` (:func:`speed_range_of`) or a string
    ``"V"`` / ``"MIN:MAX"`` (the command line's form).
    """
    if speed is None:
        return None
    if isinstance(speed, str):
        text = speed.strip()
        if text == "auto":
            return speed_range_of(model)
        parts = text.split(":")
        try:
            vals = [float(p) for p in parts]
        except ValueError:
            vals = []
        if len(vals) not in (1, 2):
            raise PlanningConfigError(
                f"speed {speed!r} is not a speed; expected V, MIN:MAX (m/s) or auto",
                value=speed,
                param="speed",
            )
        speed = vals[0] if len(vals) == 1 else tuple(vals)
    if isinstance(speed, int | float):
        v = float(speed)
        if not (math.isfinite(v) and v > 0):
            raise PlanningConfigError(
                f"speed must be > 0 m/s, got {speed!r}", value=speed, param="speed"
            )
        return v
    try:
        lo, hi = (float(v) for v in speed)
    except (TypeError, ValueError):
        raise PlanningConfigError(
            f"speed must be a number, (vmin, vmax) or 'auto', got {speed!r}",
            value=speed,
            param="speed",
        ) from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
        raise PlanningConfigError(
            f"speed range must satisfy 0 < vmin <= vmax m/s, got {lo:g}:{hi:g}",
            value=(lo, hi),
            param="speed",
        )
    return lo, hi


def with_speed(problem: Any, speed: Any, time_weight: float = 0.0) -> Any:
    """``problem`` with the speed choice of ``speed`` (:func:`resolve_speed`) and ``lambda``.

    A number replaces the request's nominal speed (the fixed-speed planner); a range
    makes every motion choose its speed (:meth:`energy_planner.problem.Problem.with_speed`).
    """
    import dataclasses

    spec = resolve_speed(speed, problem.model)
    if isinstance(spec, float):
        robot = dataclasses.replace(problem.request.robot, speed=spec)
        problem = problem.replace(request=dataclasses.replace(problem.request, robot=robot))
        spec = None
    if not (isinstance(time_weight, int | float) and math.isfinite(time_weight)
            and time_weight >= 0):  # fmt: skip
        raise PlanningConfigError(
            f"time_weight must be a finite number >= 0 J/s, got {time_weight!r}",
            value=time_weight,
            param="time_weight",
        )
    return problem.with_speed(spec, float(time_weight))


def _plan(problem, start, goal, speed, lam, kw):
    from energy_planner.planning.plan import plan

    return plan(problem, start, goal, speed=speed, time_weight=lam, **kw)


def _check_deadline(deadline: Any) -> None:
    if not (isinstance(deadline, int | float) and math.isfinite(deadline) and deadline > 0):
        raise PlanningConfigError(
            f"deadline must be > 0 seconds, got {deadline!r}", value=deadline, param="deadline"
        )


def plan_deadline(
    problem: Any,
    start: Sequence[float],
    goal: Sequence[float],
    deadline: float,
    *,
    speed: Any = "auto",
    **kw: Any,
) -> Any:
    """The least-energy path that arrives within ``deadline`` seconds.

    Minimises ``energy + lambda x time`` over routes and each motion's speed within
    ``speed`` (:func:`resolve_speed`; default the logged range), with ``lambda`` found
    by bisection: ``lambda = 0`` (the least-energy path) if it is in time; else the
    bracket grows by 4 from the least-energy path's mean power until a path is in time,
    then :data:`DEADLINE_ITERS` bisections on ``log(lambda)``. The path returned is the
    least-energy one in time among those priced (a point of the front's convex hull, see
    the module docstring). ``kw``: :func:`~energy_planner.planning.plan.plan`'s.

    Returns
    -------
    PlanResult
        With ``info["deadline"]``: the deadline, ``lambda``, the plans priced.

    Raises
    ------
    PlanningError
        ``limit="deadline"``: no path arrives in time; the message and ``value`` give the
        fastest path's duration.
    """
    _check_deadline(deadline)
    if speed is None:
        speed = "auto"
    speed = resolve_speed(speed, problem.model)
    tried: list[tuple[float, float, float]] = []

    def run(lam: float):
        res = _plan(problem, start, goal, speed, lam, kw)
        tried.append((lam, res.energy_j, res.duration_s))
        return res

    def done(res, lam: float):
        res.info["deadline"] = {"deadline_s": float(deadline), "lambda_j_per_s": lam,
                                "plans": [list(t) for t in tried]}  # fmt: skip
        return res

    late = (
        f"no path arrives within {deadline:g} s: the fastest path found takes "
        "{duration:.1f} s ({energy:.0f} J, every motion at the top of the speed range); "
        "give a later deadline or a higher top speed"
    )
    return done(*bisect_time_price(run, deadline, late))


def bisect_time_price(run: Any, deadline: float, late: str) -> tuple[Any, float]:
    """The least-energy result in time over a bisection on the price of a second.

    ``run(lam)`` plans (a path, a tour) minimising ``energy + lam x time`` and returns a
    result with ``energy_j`` and ``duration_s``. ``lam = 0`` if that result is in time;
    else the bracket grows by 4 from its mean power until a result is in time (up to
    :data:`FASTEST_WEIGHT` times that power: every motion at the top of the speed
    range), then :data:`DEADLINE_ITERS` bisections on ``log(lambda)``. Returns the
    least-energy result in time among those priced and its ``lambda``.

    Raises
    ------
    PlanningError
        ``limit="deadline"``: nothing arrives in time; ``late`` (formatted with the
        fastest result's ``duration`` and ``energy``) is the message, ``value`` its
        duration.
    """
    base = run(0.0)
    if base.duration_s <= deadline:
        return base, 0.0
    power = base.energy_j / max(base.duration_s, 1e-9)
    fastest_lam = FASTEST_WEIGHT * power
    lo, hi = 0.0, power
    while True:
        res = run(hi)
        if res.duration_s <= deadline:
            best = (res, hi)
            break
        lo = hi
        if hi >= fastest_lam:
            raise PlanningError(
                late.format(duration=res.duration_s, energy=res.energy_j),
                limit="deadline",
                value=float(res.duration_s),
            )
        hi = min(4.0 * hi, fastest_lam)
    for _ in range(DEADLINE_ITERS):
        mid = math.sqrt(lo * hi) if lo > 0 else 0.5 * hi
        res = run(mid)
        if res.duration_s <= deadline:
            hi = mid
            if res.energy_j < best[0].energy_j:
                best = (res, mid)
        else:
            lo = mid
    return best


@dataclass
class ParetoFront:
    """The energy-time front of a start and goal: one path per price of a second.

    Attributes
    ----------
    lambdas : list of float
        ``lambda`` (J/s) of each point, increasing.
    plans : list of PlanResult
        The path of each ``lambda``: energy (with its interval), duration and speed
        profile.
    note : str
        What the front is: its convex hull only (see the module docstring).
    """

    lambdas: list[float]
    plans: list[Any]
    note: str = field(
        default="a Lagrangian sweep (min energy + lambda x time): these are the points of "
        "the front's convex hull; a path on a concave stretch of the front is not found"
    )

    @property
    def problem(self) -> Any:
        """The Problem the front was planned on (its plans remember it)."""
        return getattr(self.plans[0], "problem", None) if self.plans else None

    def __repr__(self) -> str:
        e = [round(p.energy_j) for p in self.plans]
        t = [round(p.duration_s) for p in self.plans]
        return f"ParetoFront({len(self.plans)} points, energy {e} J, duration {t} s)"[:300]

    def rows(self) -> list[dict[str, Any]]:
        """One dict per point: lambda, energy and its interval, duration, distance, speeds."""
        out = []
        for lam, p in zip(self.lambdas, self.plans, strict=True):
            iv = getattr(p.assessment, "interval", None)
            prof = p.speed_profile()
            walk = [s["speed_m_s"] for s in prof if s["speed_m_s"] > 0]
            out.append({
                "lambda_j_per_s": lam,
                "energy_j": p.energy_j,
                "energy_low_j": None if iv is None else iv.low_j,
                "energy_high_j": None if iv is None else iv.high_j,
                "duration_s": p.duration_s,
                "distance_m": p.distance_m,
                "speed_min_m_s": min(walk) if walk else None,
                "speed_max_m_s": max(walk) if walk else None,
            })  # fmt: skip
        return out

    def text(self) -> str:
        """The front as a table for people."""
        lines = [
            f"{'lambda J/s':>10}  {'energy J':>9}  {'interval J':>17}  {'time s':>8}  "
            f"{'dist m':>7}  {'speed m/s':>11}"
        ]
        for r in self.rows():
            iv = ("-" if r["energy_low_j"] is None
                  else f"{r['energy_low_j']:.0f}-{r['energy_high_j']:.0f}")  # fmt: skip
            sp = ("-" if r["speed_min_m_s"] is None
                  else f"{r['speed_min_m_s']:.2f}-{r['speed_max_m_s']:.2f}")  # fmt: skip
            lines.append(
                f"{r['lambda_j_per_s']:>10.1f}  {r['energy_j']:>9.0f}  {iv:>17}  "
                f"{r['duration_s']:>8.1f}  {r['distance_m']:>7.1f}  {sp:>11}"
            )
        lines.append(f"note: {self.note}")
        return "\n".join(lines)

    def to_dict(self, terrain: Any = None) -> dict[str, Any]:
        """JSON-ready: the rows, each with its plan (waypoints, times, speed profile)."""
        return {
            "note": self.note,
            "points": [
                {**row, "plan": p.to_dict(terrain)}
                for row, p in zip(self.rows(), self.plans, strict=True)
            ],
        }

    def plot(self, path: Any, title: str | None = None) -> Any:
        """Energy against duration, with the intervals; a PNG at ``path`` (written atomically)."""
        return plot_fronts({"": self}, path, title)


def plot_fronts(fronts: dict[str, ParetoFront], path: Any, title: str | None = None) -> Any:
    """Energy against duration of one or more fronts (labelled by their keys); a PNG.

    Each point with its energy interval (where every point has one) and its ``lambda``
    (J/s); written atomically at ``path``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from energy_planner.io.atomic import save_figure

    fig, ax = plt.subplots(figsize=(6, 4))
    for i, (label, front) in enumerate(fronts.items()):
        rows = front.rows()
        t = np.array([r["duration_s"] for r in rows])
        e = np.array([r["energy_j"] for r in rows])
        color = f"C{i % 10}"
        if all(r["energy_low_j"] is not None for r in rows):
            lo = e - np.array([r["energy_low_j"] for r in rows])
            hi = np.array([r["energy_high_j"] for r in rows]) - e
            ax.errorbar(t, e, yerr=[lo, hi], fmt="none", ecolor=color, alpha=0.4, capsize=3)
        ax.plot(t, e, "o-", color=color, label=label.replace("_", " ") or None)
        for r in rows:
            ax.annotate(f"{r['lambda_j_per_s']:.0f}", (r["duration_s"], r["energy_j"]),
                        textcoords="offset points", xytext=(4, 4), fontsize=7)  # fmt: skip
    ax.set_xlabel("duration (s)")
    ax.set_ylabel("energy (J)")
    ax.set_title(title or "Energy-time front (labels: lambda, J/s; convex hull only)")
    if any(fronts):
        ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)
    return path


def pareto(
    problem: Any,
    start: Sequence[float],
    goal: Sequence[float],
    n: int = 9,
    *,
    speed: Any = "auto",
    **kw: Any,
) -> ParetoFront:
    """The energy-time front from ``n`` plans over a sweep of the price of a second.

    ``lambda = 0`` (the least-energy path), then ``n - 1`` values spread geometrically
    from 0.05 to :data:`FASTEST_WEIGHT` times that path's mean power (the last: every
    motion at the top of the range). Points whose path and timing repeat the previous
    one are kept (the front has fewer distinct points than ``n`` then). ``kw``:
    :func:`~energy_planner.planning.plan.plan`'s.

    Each point first walks the route of the last point planned at its own ``lambda``'s
    speeds (:func:`retimed`), and keeps it when that carries a search's certificate: its
    ``energy + lambda x time`` at most ``eps`` times a lower bound of every path's (the
    least-energy search's bound of the energy, plus ``lambda`` times the straight line
    at the top speed). Otherwise (where another route may be better: the bound is loose
    where the least-energy and the fastest routes differ) it is planned.
    ``info["retimed"]`` says which route a point walks and its certificate.
    """
    if not (isinstance(n, int) and n >= 2):
        raise PlanningConfigError(f"pareto needs n >= 2 points, got {n!r}", value=n, param="n")
    if speed is None:
        speed = "auto"
    speed = resolve_speed(speed, problem.model)
    base = _plan(problem, start, goal, speed, 0.0, kw)
    lams = front_lambdas(base.energy_j / max(base.duration_s, 1e-9), n)
    # every path of the search's primitives costs at least this energy (the least-energy
    # search's bound; none from a planner other than the search)
    lower = (base.info.get("search") or {}).get("h_start_j")
    plans, route = [base], (base, 0.0)
    for lam in lams[1:]:
        res = None if lower is None else retimed(problem, route, start, goal, lam, lower, kw)
        if res is None:
            res = _plan(problem, start, goal, speed, lam, kw)
            route = (res, lam)
        plans.append(res)
    return ParetoFront(lams, plans)


def retimed(
    problem: Any,
    route: tuple[Any, float],
    start: Sequence[float],
    goal: Sequence[float],
    lam: float,
    lower_j: float,
    kw: dict[str, Any],
) -> Any:
    """A planned route walked at another price of a second, where that is certified.

    ``route``: a plan with a speed range (its ``info["speed_range"]``) and the
    ``lambda`` it was planned at. Its poses walk at each motion's best speed for ``lam``
    (:func:`timed`, with the trust keywords of ``kw``). Every path of the search's
    primitives costs at least ``lower_j + lam x D / vmax``: ``lower_j`` a lower bound of
    its energy (the least-energy search's ``h_start``), ``D`` the straight line from
    start to goal and ``vmax`` the top of the range (no motion is faster). The retimed
    route is returned when its ``energy + lam x time`` is at most the search's ``eps``
    (``kw``, default :data:`~energy_planner.planning.plan.DEFAULT_EPS`) times that bound:
    the certificate a search's path carries (its cost at most ``eps`` times the optimum
    on the primitives); else None.
    """
    from energy_planner.planning.plan import DEFAULT_EPS
    from energy_planner.trust import Trust

    plan0, lam0 = route
    rng = plan0.info.get("speed_range")
    if rng is None:
        return None
    eps = DEFAULT_EPS if kw.get("eps") is None else float(kw["eps"])
    line = math.hypot(goal[0] - start[0], goal[1] - start[1])
    bound = float(lower_j) + lam * line / float(rng[1])
    want = Trust.pop(dict(kw))
    res = timed(problem, plan0.states, speed=tuple(rng), time_weight=lam, name=plan0.planner,
                trust=want)  # fmt: skip
    objective = res.energy_j + lam * res.duration_s
    if not (bound > 0 and objective <= eps * bound):
        return None
    res.info["retimed"] = {"from_lambda_j_per_s": float(lam0), "certified": objective / bound}
    return res


def front_lambdas(power: float, n: int) -> list[float]:
    """The prices of a second a front of ``n`` points sweeps: 0, then geometric.

    ``n - 1`` values from 0.05 to :data:`FASTEST_WEIGHT` times ``power`` (J/s: the mean
    power of the least-energy path).

    Examples
    --------
    >>> [round(v, 2) for v in front_lambdas(10.0, 3)]
    [0.0, 0.5, 1000.0]
    """
    if not (isinstance(n, int) and n >= 2):
        raise PlanningConfigError(f"a front needs n >= 2 points, got {n!r}", value=n, param="n")
    return [0.0, *np.geomspace(0.05 * power, FASTEST_WEIGHT * power, n - 1).tolist()]


def timed(
    problem: Any,
    states: Any,
    *,
    speed: Any = "auto",
    time_weight: float = 0.0,
    name: str = "route",
    **trust: Any,
) -> Any:
    """Given poses walked at each motion's best speed: energy, duration and speed profile.

    The poses stay as they are; each motion walks at the speed within ``speed``
    (:func:`resolve_speed`) that minimises its energy plus ``time_weight`` times its
    duration (the same choice as the planner's, :meth:`MotionCost.best_durations
    <energy_planner.energy.MotionCost.best_durations>`), priced as a plan is
    (:func:`energy_planner.planning.plan.plan`'s pricing, with its assessment for
    ``trust``: ``level``, ``battery_wh``, ...). A fixed speed walks every motion at it.

    Parameters
    ----------
    problem : Problem
    states : array_like, shape (n, 3)
        Poses ``x, y, yaw`` in the working CRS (metres, radians).
    speed : float, (float, float) or "auto"
    time_weight : float
        ``lambda``, J/s.
    name : str
        The result's ``planner`` (what the poses are), and the error's subject.

    Returns
    -------
    PlanResult

    Raises
    ------
    PlanningError
        A motion breaks a limit (at every speed of the range).
    """
    from energy_planner.planning.plan import _priced
    from energy_planner.trust import Trust

    want = Trust.pop(trust)
    if trust:
        raise TypeError(f"timed() got unexpected keyword(s) {', '.join(trust)}")
    states = np.asarray(states, dtype=float)
    prob = with_speed(problem, speed, time_weight)
    return _priced(prob, states, f"the {name} is not feasible", want, planner=name)


def timed_deadline(
    problem: Any,
    states: Any,
    deadline: float,
    *,
    speed: Any = "auto",
    name: str = "route",
    **trust: Any,
) -> Any:
    """Given poses walked in at most ``deadline`` seconds with the least energy.

    ``lambda = 0`` (each motion at its least-energy speed) if that is in time; else the
    least ``lambda`` whose timing (:func:`timed`) is in time, by bisection on
    ``log(lambda)`` (:data:`ROUTE_DEADLINE_ITERS`, stopping within
    :data:`ROUTE_DEADLINE_RTOL` of the deadline). The route is fixed, so its duration
    falls as ``lambda`` grows, and each motion's speed is the least-energy one for its
    share of the time: the route's least energy in time. ``info["deadline"]`` holds the
    deadline and ``lambda``.

    Raises
    ------
    PlanningError
        ``limit="deadline"``: the route cannot arrive in time even with every motion at
        the top of the range; ``value`` is that fastest duration.
    """
    _check_deadline(deadline)
    spec = resolve_speed("auto" if speed is None else speed, problem.model)

    def run(lam: float):
        return timed(problem, states, speed=spec, time_weight=lam, name=name, **trust)

    def done(res, lam: float):
        res.info["deadline"] = {"deadline_s": float(deadline), "lambda_j_per_s": float(lam)}
        return res

    base = run(0.0)
    if base.duration_s <= deadline:
        return done(base, 0.0)
    power = base.energy_j / max(base.duration_s, 1e-9)
    hi = FASTEST_WEIGHT * power
    best = run(hi)
    if best.duration_s > deadline:
        raise PlanningError(
            f"the {name} cannot arrive within {deadline:g} s: it takes {best.duration_s:.1f} "
            f"s with every motion at the top of the speed range ({best.energy_j:.0f} J)",
            limit="deadline",
            value=float(best.duration_s),
        )
    return done(*close_on_deadline(run, deadline, 1e-6 * power, hi, best))


def close_on_deadline(
    run: Any, deadline: float, lo: float, hi: float, best: Any
) -> tuple[Any, float]:
    """Slow a fixed route down to its deadline: bisection on ``log(lambda)`` in ``[lo, hi]``.

    ``run(lam)`` times the route (:func:`timed`, or several legs together) and returns a
    result with ``duration_s``, non-increasing in ``lam``; ``best = run(hi)`` is in time.
    Stops after :data:`ROUTE_DEADLINE_ITERS` steps or once the result in time is within
    :data:`ROUTE_DEADLINE_RTOL` of the deadline. Returns it and its ``lambda``.
    """
    for _ in range(ROUTE_DEADLINE_ITERS):
        if best.duration_s >= deadline * (1 - ROUTE_DEADLINE_RTOL):
            break
        mid = math.sqrt(lo * hi)
        res = run(mid)
        if res.duration_s <= deadline:
            hi, best = mid, res
        else:
            lo = mid
    return best, hi


def route_front(
    problem: Any, states: Any, lambdas: Sequence[float], *, speed: Any = "auto", name: str = "route"
) -> ParetoFront:
    """The energy-time front of given poses: :func:`timed` at each ``lambda``.

    The route stays; only its speed profile changes (each motion's least ``E + lambda
    T``), so the front is exact for this route (no hull to miss: each motion's cost is
    convex in its duration where the speed's closed form holds).
    """
    spec = resolve_speed("auto" if speed is None else speed, problem.model)
    lams = [float(v) for v in lambdas]
    plans = [timed(problem, states, speed=spec, time_weight=lam, name=name) for lam in lams]
    return ParetoFront(lams, plans, note="one route walked at each lambda's speed profile")
