"""Order a tour of sites on an asymmetric energy matrix.

Uphill is not downhill, so ``E[i, j] != E[j, i]``: the order is an asymmetric travelling
salesman problem. The first site is the depot (where the robot stands); the tour visits
every other site once and, with ``return_to_start``, comes back.

- :func:`held_karp`: exact dynamic programming over subsets, ``O(2^n n^2)`` time; used up
  to :data:`EXACT_MAX_SITES` sites.
- beyond that, OR-Tools' routing solver (guided local search, a few seconds) when
  ``ortools`` is installed, else :func:`local_search`: nearest neighbour then or-opt
  moves (move one site elsewhere in the tour) until none improves. Either gives a good
  tour, not a proven one.
- :func:`brute_force`: every permutation, for tests.

Examples
--------
>>> import numpy as np
>>> E = np.array([[0, 1, 9], [9, 0, 1], [1, 9, 0]], float)
>>> held_karp(E, return_to_start=True)
([0, 1, 2], 3.0)
>>> brute_force(E, return_to_start=True)
([0, 1, 2], 3.0)
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "EXACT_MAX_SITES",
    "SettledOrder",
    "brute_force",
    "held_karp",
    "local_search",
    "order_legs",
    "order_sites",
    "settle_order",
]

#: Up to this many sites (depot included) the best order is exact (Held-Karp).
EXACT_MAX_SITES = 15


def order_legs(order: list[int], return_to_start: bool = False) -> list[tuple[int, int]]:
    """The legs ``(a, b)`` of a visiting order, with the way back to site 0 if asked.

    Examples
    --------
    >>> order_legs([0, 2, 1], return_to_start=True)
    [(0, 2), (2, 1), (1, 0)]
    """
    legs = list(zip(order[:-1], order[1:], strict=True))
    if return_to_start and len(order) > 1:
        legs.append((order[-1], order[0]))
    return legs


def _cost(E: np.ndarray, order: list[int], ret: bool) -> float:
    return float(sum(E[a, b] for a, b in order_legs(order, ret)))


def brute_force(E: np.ndarray, return_to_start: bool = False) -> tuple[list[int], float]:
    """The best order by trying every permutation (site 0 first); as :func:`held_karp`.

    The reference the exact solver is tested against (parameters and returns as
    :func:`held_karp`'s).
    """
    n = np.shape(E)[0]
    E = np.asarray(E, dtype=float)
    best, best_order = math.inf, list(range(n))
    for perm in itertools.permutations(range(1, n)):
        order = [0, *perm]
        c = _cost(E, order, return_to_start)
        if c < best:
            best, best_order = c, order
    return best_order, best


def held_karp(E: np.ndarray, return_to_start: bool = False) -> tuple[list[int], float]:
    """The exact best order (site 0 first) by Held-Karp dynamic programming.

    ``D[S, j]`` is the least energy leaving site 0, visiting the sites in the bit set
    ``S`` (over sites 1..n-1) and ending at ``j`` in ``S``. Vectorised over ``j``.

    Parameters
    ----------
    E : ndarray, shape (n, n)
        Energy from row site to column site (``inf`` where unreachable).
    return_to_start : bool
        Add the leg back to site 0.

    Returns
    -------
    order : list of int
        Site indices, starting with 0.
    energy : float
        The tour's energy (``inf`` if no order is feasible).
    """
    E = np.asarray(E, dtype=float)
    n = E.shape[0]
    if n <= 2:
        order = list(range(n))
        return order, _cost(E, order, return_to_start)
    m = n - 1  # sites 1..n-1 are bits 0..m-1
    full = (1 << m) - 1
    D = np.full((1 << m, m), math.inf)
    P = np.full((1 << m, m), -1, dtype=np.int64)
    W = E[1:, 1:]  # W[a, b]: site a+1 -> site b+1
    for j in range(m):
        D[1 << j, j] = E[0, j + 1]
    bits = np.arange(m)
    for S in range(1, full + 1):
        members = bits[(S >> bits) & 1 == 1]
        if members.size < 2:
            continue
        for j in members:
            prev = S & ~(1 << j)
            cand = D[prev, members] + W[members, j]
            cand[members == j] = math.inf
            k = int(np.argmin(cand))
            D[S, j] = cand[k]
            P[S, j] = members[k]
    end = D[full] + (E[1:, 0] if return_to_start else 0.0)
    j = int(np.argmin(end))
    best = float(end[j])
    if not math.isfinite(best):
        return list(range(n)), math.inf
    order, S = [], full
    while j >= 0:
        order.append(j + 1)
        S, j = S & ~(1 << j), int(P[S, j])
    return [0, *reversed(order)], best


def local_search(E: np.ndarray, return_to_start: bool = False) -> tuple[list[int], float]:
    """A good order for many sites: nearest neighbour, then or-opt moves to a local optimum.

    Parameters and returns as :func:`held_karp`'s; the order is a local optimum, not
    always the best.
    """
    E = np.asarray(E, dtype=float)
    n = E.shape[0]
    order, left = [0], set(range(1, n))
    while left:
        nxt = min(left, key=lambda b: E[order[-1], b])
        order.append(nxt)
        left.remove(nxt)
    best = _cost(E, order, return_to_start)
    improved = True
    while improved:
        improved = False
        for i in range(1, n):
            for k in range(1, n):
                if i == k:
                    continue
                cand = order[:i] + order[i + 1 :]
                cand.insert(k, order[i])
                c = _cost(E, cand, return_to_start)
                if c < best - 1e-9:
                    order, best, improved = cand, c, True
    return order, best


def order_sites(
    E: np.ndarray, order: str = "best", return_to_start: bool = False, time_limit_s: int = 3
) -> tuple[list[int], float, str]:
    """The visiting order: ``"given"`` (as listed) or ``"best"``.

    ``time_limit_s`` bounds OR-Tools' search beyond :data:`EXACT_MAX_SITES` sites.

    Returns
    -------
    order : list of int
    energy : float
    method : str
        ``"given"``, ``"held-karp (exact)"`` or ``"nearest neighbour + or-opt (not proven)"``.
    """
    E = np.asarray(E, dtype=float)
    n = E.shape[0]
    if order == "given":
        o = list(range(n))
        return o, _cost(E, o, return_to_start), "given"
    if order != "best":
        raise ValueError(f"order must be 'given' or 'best', not {order!r}")
    if n <= EXACT_MAX_SITES:
        o, c = held_karp(E, return_to_start)
        return o, c, "held-karp (exact)"
    try:
        o = _ortools(E, return_to_start, time_limit_s)
    except ImportError:
        o, c = local_search(E, return_to_start)
        return o, c, "nearest neighbour + or-opt (not proven)"
    return o, _cost(E, o, return_to_start), "or-tools guided local search (not proven)"


@dataclass
class SettledOrder:
    """An order whose legs are all priced, and how far it is proven (:func:`settle_order`).

    Attributes
    ----------
    order : list of int
        Visiting order (site 0 first).
    energy : float
        Its energy: the sum of its priced legs.
    method : str
        How the last order was chosen (:func:`order_sites`).
    priced : dict
        ``(a, b) -> value``: every leg priced, the order's and the others tried.
    rounds : int
        Orders chosen.
    proven : bool
        True when no order can cost less given the bounds: the order is exact
        (:func:`held_karp`) on the bounds with the priced legs in place, and every one
        of its own legs is priced (so its energy there is its true energy).
    bound : float
        The least energy of any order given the bounds (with ``proven``: ``energy``
        itself; otherwise the last exact order's cost on the bounds, or ``nan``).
    """

    order: list[int]
    energy: float
    method: str
    priced: dict[tuple[int, int], float] = field(default_factory=dict)
    rounds: int = 0
    proven: bool = False
    bound: float = math.nan


def settle_order(
    lower: np.ndarray,
    price: Callable[[int, int], float],
    return_to_start: bool = False,
    *,
    max_priced: int | None = None,
    time_limit_s: int = 3,
) -> SettledOrder:
    """The best order when only bounds of the legs are known and pricing a leg costs.

    ``lower[a, b]`` bounds leg ``a -> b``'s energy from below (a matrix entry over its
    search's ``eps``: a weighted search finds at most ``eps`` times the least energy);
    ``price(a, b)`` gives its energy (``plan``'s). The order is chosen on the bounds;
    its legs not yet priced are priced and take their energy in place of the bound, and
    the order is chosen again, until the order's legs are all priced: then no order
    costs less given the bounds (each leg of another order costs at least its bound, or
    its price), when the order is exact (at most :data:`EXACT_MAX_SITES` sites). Beyond
    that (a solver's order, not proven) one order is priced. ``max_priced`` caps the
    legs priced: the best fully priced order so far is returned, not proven.

    Examples
    --------
    >>> true = np.array([[0, 4, 2], [1, 0, 3], [3, 1, 0]], float)
    >>> s = settle_order(true / 1.5, lambda a, b: true[a, b])
    >>> s.order, s.energy, s.proven, s.rounds
    ([0, 2, 1], 3.0, True, 2)
    >>> brute_force(true)
    ([0, 2, 1], 3.0)
    """
    M = np.array(lower, dtype=float)
    n = M.shape[0]
    exact = n <= EXACT_MAX_SITES
    known = np.eye(n, dtype=bool)
    priced: dict[tuple[int, int], float] = {}
    best: SettledOrder | None = None
    rounds = 0
    while True:
        o, c, method = order_sites(M, "best", return_to_start, time_limit_s)
        rounds += 1
        legs = order_legs(o, return_to_start)
        new = [(a, b) for a, b in legs if not known[a, b]]
        if not math.isfinite(c) or not new:  # its legs all priced: exact on the bounds
            done = SettledOrder(o, c, method, priced, rounds, exact and math.isfinite(c),
                                c if exact else math.nan)  # fmt: skip
            if best is None or not done.energy > best.energy:
                return done
            best.rounds, best.bound = rounds, done.bound
            return best
        for a, b in new:
            priced[a, b] = M[a, b] = float(price(a, b))
            known[a, b] = True
        energy = float(sum(M[a, b] for a, b in legs))
        if best is None or energy < best.energy:
            best = SettledOrder(o, energy, method, priced, rounds)
        full = max_priced is not None and len(priced) >= max_priced
        if not exact or full:
            best.rounds = rounds
            best.bound = c if exact else math.nan
            return best


def _ortools(E: np.ndarray, return_to_start: bool, seconds: int = 3) -> list[int]:
    """OR-Tools' routing solver on the asymmetric matrix (integer millijoules)."""
    from ortools.constraint_solver import pywrapcp, routing_enums_pb2

    n = E.shape[0]
    big = float(np.nanmax(np.where(np.isfinite(E), E, 0.0))) * n * 10 + 1.0
    M = np.where(np.isfinite(E), E, big)
    if not return_to_start:
        M = M.copy()
        M[:, 0] = 0.0  # the way back is free: an open tour from site 0
    cost = np.rint(M * 1000).astype(np.int64)
    mgr = pywrapcp.RoutingIndexManager(n, 1, 0)
    routing = pywrapcp.RoutingModel(mgr)
    cb = routing.RegisterTransitCallback(
        lambda i, j: int(cost[mgr.IndexToNode(i), mgr.IndexToNode(j)])
    )
    routing.SetArcCostEvaluatorOfAllVehicles(cb)
    params = pywrapcp.DefaultRoutingSearchParameters()
    params.first_solution_strategy = routing_enums_pb2.FirstSolutionStrategy.PATH_CHEAPEST_ARC
    params.local_search_metaheuristic = (
        routing_enums_pb2.LocalSearchMetaheuristic.GUIDED_LOCAL_SEARCH
    )
    params.time_limit.seconds = seconds
    sol = routing.SolveWithParameters(params)
    idx, order = routing.Start(0), []
    while not routing.IsEnd(idx):
        order.append(mgr.IndexToNode(idx))
        idx = sol.Value(routing.NextVar(idx))
    return order
