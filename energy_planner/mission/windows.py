"""Per-site arrival windows of a mission: the order and each leg's speeds that keep them.

Each site may have a window ``[arrive_after, arrive_before]`` (seconds from the mission's
start, :mod:`energy_planner.mission.sites`). The robot leaves the start at its
``arrive_after`` (0 without one); a robot early at a site waits until the window opens,
standing, and the wait costs the model's **standing power** there (:func:`standing_power`:
the model's power at zero twist on the site's slope, at the least-power heading; a model
without a per-second term stands for free, and the result says 0 W); it must arrive by
``arrive_before``.

**Speeds.** Each leg's route is the one ``plan`` gives from its site to the next (the
least energy, each motion at its least-energy speed in the range); a leg that must arrive
sooner walks the same route faster, each motion at the speed minimising its energy +
``lambda`` x time (:func:`energy_planner.planning.speed.timed`). The legs that lead to a
late site, back to the last site where the robot waits (or the start), share one
``lambda``: the least that brings it in time (bisection,
:func:`~energy_planner.planning.speed.close_on_deadline`); a second is then worth the same
on each of them, the optimum of one deadline over several legs. Windows are met in visit
order; a leg already sped up for an earlier window keeps at least its ``lambda``. Motions
never walk slower than their least-energy speed: an early robot waits.

**Order.** With ``order="best"`` and up to :data:`MAX_ORDERED_SITES` sites the candidate
orders are taken in increasing energy of the matrix (the searches' least energy of each
leg, :func:`~energy_planner.mission.energy_matrix`) and each is scheduled; the search stops
once the next order's matrix energy exceeds the least scheduled tour (speeding up and
waiting only add to it, so a later order cannot win, up to the legs' refinement below the
matrix's entries). An order some window rules out with every leg at the top of the range
is skipped. Beyond that many sites, the least-energy order and the given order are tried.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from energy_planner.errors import PlanningConfigError, PlanningError

__all__ = ["MAX_ORDERED_SITES", "Schedule", "standing_power", "schedule"]

#: Up to this many sites (start included) ``order="best"`` tries every order (by matrix
#: energy) against the windows.
MAX_ORDERED_SITES = 8
#: Headings over which the standing power is the least (the robot may stand any way).
_STAND_HEADINGS = 16
#: Arrival later than its bound by at most this many seconds counts as in time (the
#: bisection closes on the bound from below, float rounding above it).
_LATE_TOL_S = 1e-6


def standing_power(problem: Any, xy: Any) -> np.ndarray:
    """The model's power standing still at each point, W: the cost of a second of waiting.

    Zero twist on the terrain's slope at the point, at the heading of least power
    (:data:`_STAND_HEADINGS` headings), with the problem's channel constants; floored at 0
    as the model's power is (0 for a model without a per-second term).

    Examples
    --------
    >>> from energy_planner.model import EnergyModel
    >>> from energy_planner.problem import Problem
    >>> from energy_planner.terrain import Terrain
    >>> t = Terrain.from_function(lambda x, y: 0.0 * x, size=(8, 8), resolution=1.0)
    >>> m = EnergyModel(["1", "speed"], {"1": 40.0, "speed": 100.0})
    >>> standing_power(Problem(t, m), [[t.grid[0] + 3, t.grid[1] - 3]]).tolist()
    [40.0]
    """
    from energy_planner.energy.speed import _channel_values, _features

    xy = np.atleast_2d(np.asarray(xy, dtype=float))
    s = problem.terrain.sample(xy[:, 0], xy[:, 1])
    n, k = len(xy), _STAND_HEADINGS
    alpha = np.repeat(np.nan_to_num(np.atleast_1d(s.slope)), k)
    gamma = np.tile(np.linspace(-math.pi, math.pi, k, endpoint=False), n)
    chans = _channel_values(problem.model, getattr(problem.cost, "constants", None))
    feats = _features(np.zeros(n * k), alpha, gamma, 0.0, 0.0, chans)
    return np.asarray(problem.model.power(feats), dtype=float).reshape(n, k).min(axis=1)


@dataclass
class Schedule:
    """The legs of one order walked in their windows.

    Attributes
    ----------
    stops : list of int
        Sites in visit order (the start again at the end of a round trip).
    legs : list of PlanResult
        Each leg's route timed at its ``lambda`` (:func:`~energy_planner.planning.speed.timed`).
    lambdas : ndarray
        Price of a second of each leg, J/s (0: its least-energy speeds).
    arrive, wait, depart : ndarray
        Per stop, seconds from the start (the start's arrival is 0).
    wait_j : ndarray
        Energy of each stop's wait (standing power x wait), J.
    """

    stops: list[int]
    legs: list[Any]
    lambdas: np.ndarray
    arrive: np.ndarray
    wait: np.ndarray
    depart: np.ndarray
    wait_j: np.ndarray

    @property
    def energy_j(self) -> float:
        """Walking and waiting energy, J."""
        return float(sum(r.energy_j for r in self.legs) + self.wait_j.sum())

    @property
    def duration_s(self) -> float:
        """Arrival at the last stop (for the bisection's deadline)."""
        return float(self.arrive[-1])


class _Timer:
    """Each leg's route timed at a price of a second (memoised), and the stops' clocks."""

    def __init__(self, problem, speed, routes, stops, windows, power, names):
        from energy_planner.planning.speed import FASTEST_WEIGHT

        self.problem, self.speed, self.routes, self.names = problem, speed, routes, names
        self.stops, self.power = stops, power
        w = windows[stops]
        self.after = np.where(np.isnan(w[:, 0]), 0.0, w[:, 0])
        self.before = np.where(np.isnan(w[:, 1]), math.inf, w[:, 1])
        if len(stops) > 1 and stops[-1] == stops[0]:  # back at the start: its latest return
            self.after[-1] = 0.0
        self._memo: dict[tuple[int, float], Any] = {}
        base = [self.leg(i, 0.0) for i in range(len(routes))]
        self.fastest = np.array([FASTEST_WEIGHT * r.energy_j / max(r.duration_s, 1e-9)
                                 for r in base])  # fmt: skip

    def leg(self, i: int, lam: float) -> Any:
        from energy_planner.planning.speed import timed

        key = (i, float(lam))
        if key not in self._memo:
            self._memo[key] = timed(self.problem, self.routes[i], speed=self.speed,
                                    time_weight=float(lam), name=f"leg {i + 1}")  # fmt: skip
        return self._memo[key]

    def run(self, lams: np.ndarray) -> Schedule:
        legs = [self.leg(i, lam) for i, lam in enumerate(lams)]
        m = len(self.stops)
        arrive, wait, depart = np.zeros(m), np.zeros(m), np.zeros(m)
        depart[0] = self.after[0]  # leaves the start when its window opens
        for k in range(1, m):
            arrive[k] = depart[k - 1] + legs[k - 1].duration_s
            wait[k] = max(0.0, self.after[k] - arrive[k])
            depart[k] = arrive[k] + wait[k]
        wait_j = wait * self.power[self.stops]
        return Schedule(list(self.stops), legs, np.asarray(lams, float), arrive, wait, depart,
                        wait_j)  # fmt: skip

    def late(self, s: Schedule) -> int | None:
        """The first stop reached after its window closes, or None."""
        bad = np.nonzero(s.arrive > self.before + _LATE_TOL_S)[0]
        return int(bad[0]) if bad.size else None


def schedule(timer: _Timer) -> Schedule:
    """The legs' prices of a second that keep every window of one order (see the module).

    Raises
    ------
    PlanningError
        ``limit="window"``: a site cannot be reached in its window even with every leg at
        the top of the speed range; names the site and its earliest arrival.
    """
    from energy_planner.planning.speed import close_on_deadline

    lams = np.zeros(len(timer.routes))
    while True:
        s = timer.run(lams)
        m = timer.late(s)
        if m is None:
            return s
        # the legs since the last wait (their start fixed by a window) lead to stop m
        r = max(j for j in range(m) if j == 0 or s.wait[j] > 0)
        block = np.arange(r, m)
        hi = float(timer.fastest[block].max())

        def run(mu: float, block=block, m=m, lams=lams) -> Any:
            trial = lams.copy()
            trial[block] = np.maximum(trial[block], mu)
            out = timer.run(trial)
            return _Clock(float(out.arrive[m]), out)

        top = run(hi)
        deadline = float(timer.before[m])
        if top.duration_s > deadline + _LATE_TOL_S:
            raise _late(timer, m, top.schedule)
        best, _ = close_on_deadline(run, deadline, 1e-6 * hi, hi, top)
        lams = best.schedule.lambdas


@dataclass
class _Clock:
    """A schedule seen by the bisection: ``duration_s`` is its arrival at the late stop."""

    duration_s: float
    schedule: Schedule


def _late(timer: _Timer, m: int, fastest: Schedule) -> PlanningError:
    name = timer.names[timer.stops[m]]
    return PlanningError(
        f"site {name!r} cannot be reached in its window: the earliest arrival is "
        f"{fastest.arrive[m]:.1f} s (every leg before it at the top of the speed range) "
        f"and the window closes at {timer.before[m]:g} s",
        limit="window", value=float(fastest.arrive[m]), site=name,
    )  # fmt: skip


def _orders(E: np.ndarray, order: str, return_to_start: bool) -> tuple[list[list[int]], str]:
    """Candidate orders, by increasing matrix energy, and how they were chosen."""
    from energy_planner.mission.tour import _cost, order_sites

    n = E.shape[0]
    given = list(range(n))
    if order == "given":
        return [given], "given"
    if n <= MAX_ORDERED_SITES:
        perms = [[0, *p] for p in itertools.permutations(range(1, n))]
        perms.sort(key=lambda o: _cost(E, o, return_to_start))
        return perms, "orders by matrix energy, each scheduled in the windows (exact)"
    best, _, _ = order_sites(E, "best", return_to_start)
    method = "least-energy order or the given one, scheduled in the windows (not proven)"
    return ([best] if best == given else [best, given]), method


def in_windows(problem, sites, E: np.ndarray, speed: Any, legs_of: Any, *, order: str,
               return_to_start: bool) -> tuple[Schedule, str, int]:  # fmt: skip
    """The least-energy order whose legs keep every window, and its schedule.

    ``legs_of(a, b)``: the states of the leg from site ``a`` to ``b`` (planned once per
    pair). Returns the schedule, the method and the number of orders scheduled.

    Raises
    ------
    PlanningError
        ``limit="window"``: no order keeps every window; names the site of the order
        closest to keeping them and its earliest arrival.
    """
    from energy_planner.mission.tour import _cost

    if order not in ("best", "given"):
        raise PlanningConfigError(f"order must be 'best' or 'given', not {order!r}",
                                  value=order, param="order")  # fmt: skip
    windows = sites.windows
    power = standing_power(problem, sites.xy)
    cands, method = _orders(E, order, return_to_start)
    best, tried, closest = None, 0, None
    for o in cands:
        if best is not None and _cost(E, o, return_to_start) > best.energy_j:
            break
        stops = o + [o[0]] if return_to_start and len(o) > 1 else list(o)
        if not all(math.isfinite(E[a, b]) for a, b in itertools.pairwise(stops)):
            continue
        routes = [legs_of(a, b) for a, b in itertools.pairwise(stops)]
        timer = _Timer(problem, speed, routes, stops, windows, power, sites.names)
        fast = timer.run(timer.fastest)
        m = timer.late(fast)
        if m is not None:  # no speed keeps this order in its windows
            over = float(fast.arrive[m] - timer.before[m])
            if closest is None or over < closest[0]:
                closest = (over, _late(timer, m, fast))
            continue
        tried += 1
        s = schedule(timer)
        if best is None or s.energy_j < best.energy_j:
            best = s
    if best is None:
        if closest is None:
            raise PlanningError("no order visits every site: some legs have no path",
                                limit="window")  # fmt: skip
        err = closest[1]
        if len(cands) > 1:
            raise PlanningError(
                f"no order of the {len(cands)} tried keeps every window; in the one that "
                f"comes closest, {err.message}", limit="window", value=err.value,
                site=err.site,
            )  # fmt: skip
        raise err
    return best, method, tried
