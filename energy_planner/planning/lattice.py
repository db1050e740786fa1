"""The lattice planner: Dijkstra on a fully built state lattice over (x, y, heading).

``plan(..., planner="lattice")`` and the benchmarks use it as the resolution-optimal
reference; the default planner is the full-resolution search of
:mod:`energy_planner.planning.search`, which has the same motion primitives and edge costs
but prices edges on demand instead of building the graph (so at equal ``step`` both find
the same optimum). The primitives themselves (positions, headings, move sets) live in
:mod:`energy_planner.planning.moves`; :func:`lattice_graph` builds the graph that
:func:`lattice_plan` searches and that reach searches forwards and backwards
(:mod:`energy_planner.planning.reach`).

The lattice places positions on a square grid (spacing ``step`` metres, aligned so that
the start lies exactly on a node) and ``n_headings`` evenly spaced headings at each
position. Its motion primitives are

* translations at constant heading to neighbours among the 16 ``(1,0), (2,1), (1,1),
  (1,2), ...``: with ``moves="axes"`` (default) the 4 closest to the body axes (forward,
  left, backward, right), with ``moves="crab"`` also the 4 obliques at 45 degrees, with
  ``moves="all"`` all 16 (any mix of forward and sideways: crab walking);
* turns in place to the next heading on either side.

With 16 headings the headings are the directions of the 16 moves, so a robot can walk
exactly forward (or sideways) along every move.

Every edge cost is the energy of that SE(2) motion from the **same** numba kernel that
prices any other path (:class:`energy_planner.energy.MotionCost`), evaluated for all
edges at once with ``MotionCost.batch``. Edges with an infinite cost (leaving the map,
nodata, a slope or cross-slope limit, a keep-out cell) are dropped. The graph is a
``scipy.sparse`` CSR matrix and :func:`scipy.sparse.csgraph.dijkstra` finds the exact
optimum on the lattice: the resolution-optimal energy that the sampling-based planners
are compared with.

With ``metric="distance"`` the same graph (same limits) is searched with the
horizontal length of each edge as its weight: the shortest feasible path. Its edges are
priced only where such a path can pass (inside an ellipse about the start and the goal
that grows until the path found fits in it), so a short route on a large map prices a
small part of the lattice.
"""

from __future__ import annotations

import math
import time
import weakref
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from energy_planner.angles import wrap
from energy_planner.errors import InvalidStateError, PlanningConfigError, PlanningError
from energy_planner.planning.moves import (
    MOVES_16,
    check_headings,
    check_moves,
    exact_ends,
    lattice_geometry,
    lattice_headings,
    move_table,
    terrain_extent,
)
from energy_planner.problem import takes_problem

__all__ = [
    "LatticeGraph",
    "LatticeResult",
    "MOVES_16",
    "default_step",
    "lattice_graph",
    "lattice_headings",
    "lattice_geometry",
    "lattice_plan",
    "simplify_states",
]

#: Edge weight given to turns in place with ``metric="distance"`` (per radian), so that a
#: shortest path does not spin for nothing while turning stays possible.
_TURN_EPS = 1e-6
#: Smallest edge weight (csgraph treats a weight as an edge, but keep them positive).
_MIN_W = 1e-12


@dataclass
class LatticeResult:
    """A path found on the lattice.

    Attributes
    ----------
    states : ndarray, shape (n, 3)
        ``x, y, yaw`` (working CRS, radians) from the exact start to the exact goal;
        collinear lattice steps at the same heading are merged.
    cost : float
        The graph cost of the lattice part (J, or m with ``metric="distance"``).
    metric : str
        ``"energy"`` or ``"distance"``.
    step : float
        Lattice spacing, m.
    n_headings : int
        Headings per position.
    n_nodes, n_edges : int
        Size of the searched graph (with ``metric="distance"``: the edges priced).
    build_s, search_s : float
        Wall time to build the graph (edge costs included) and to search it, s.
    """

    states: np.ndarray
    cost: float
    metric: str
    step: float
    n_headings: int
    n_nodes: int
    n_edges: int
    build_s: float
    search_s: float
    info: dict = field(default_factory=dict)


def default_step(terrain, max_positions: int = 20_000) -> float:
    """The DEM cell size, coarsened so the lattice has at most ``max_positions`` positions.

    Parameters
    ----------
    terrain : Terrain
        The map (working CRS).
    max_positions : int
        Upper bound on the number of lattice positions (nodes = positions x headings).

    Returns
    -------
    float
        Spacing in metres.
    """
    x0, y0, dx, dy = terrain.grid
    xmin, xmax, ymin, ymax = terrain_extent(terrain)
    step = max(abs(dx), abs(dy))
    area = max(xmax - xmin, step) * max(ymax - ymin, step)
    return max(step, math.sqrt(area / max_positions))


def simplify_states(states: np.ndarray, tol: float = 1e-9, keep: Any = None) -> np.ndarray:
    """Drop repeated poses and interior poses on a straight, constant-yaw run.

    The energy of a straight motion at constant yaw is the integral of the same
    per-metre cost, so merging collinear steps does not change it (up to sampling).
    ``keep``: a mask of poses kept whatever (where the motions change gait,
    :func:`energy_planner.planning.speed.gait_changes`: one motion walks one gait).

    Examples
    --------
    >>> s = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [2, 0, 1.0]], float)
    >>> simplify_states(s).tolist()
    [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 0.0, 1.0]]
    """
    states = np.asarray(states, float)
    dup = np.r_[False, np.all(np.abs(np.diff(states, axis=0)) <= tol, axis=1)]
    pinned = np.zeros(len(states), bool) if keep is None else np.asarray(keep, bool).copy()
    if keep is not None:  # a dropped repeat passes its pin to the pose it repeats
        for k in np.flatnonzero(dup & pinned):
            pinned[k - 1] = True
    states = states[~dup]
    pinned = pinned[~dup]
    if len(states) <= 2:
        return states.copy()
    keep = [0]
    for k in range(1, len(states) - 1):
        if pinned[k]:
            keep.append(k)
            continue
        a, b, c = states[keep[-1]], states[k], states[k + 1]
        same_yaw = abs(wrap(b[2] - a[2])) < tol and abs(wrap(c[2] - b[2])) < tol
        u = b[:2] - a[:2]
        v = c[:2] - b[:2]
        cross = u[0] * v[1] - u[1] * v[0]
        moving = np.hypot(*u) > tol and np.hypot(*v) > tol
        collinear = moving and abs(cross) < tol * max(1.0, np.hypot(*u) * np.hypot(*v))
        if not (same_yaw and collinear and float(u @ v) > 0):
            keep.append(k)
    keep.append(len(states) - 1)
    return states[keep]


@dataclass
class LatticeGraph:
    """The state lattice over ``(position, heading)`` as a weighted directed graph.

    Attributes
    ----------
    graph : scipy.sparse.csr_matrix, shape (n_nodes, n_nodes)
        Node ``p * n_headings + h`` is position ``p`` (row-major over ``ys``, ``xs``) at
        heading ``h``; every edge ``u -> v`` is weighted in its own direction.
    xs, ys : ndarray
        Lattice x (columns) and y (rows) coordinates, increasing.
    headings : ndarray
        :func:`lattice_headings` of ``n_headings``.
    valid : ndarray of bool, shape (n_positions, n_headings)
        The poses that break no limit.
    step : float
        Lattice spacing, m.
    """

    graph: Any
    xs: np.ndarray
    ys: np.ndarray
    headings: np.ndarray
    valid: np.ndarray
    step: float

    @property
    def n_headings(self) -> int:
        """Headings per position."""
        return len(self.headings)

    @property
    def n_nodes(self) -> int:
        """Positions x headings."""
        return len(self.xs) * len(self.ys) * self.n_headings

    def position(self, p) -> tuple[np.ndarray, np.ndarray]:
        """``(x, y)`` of position index (or indices) ``p``."""
        j, i = np.divmod(p, len(self.xs))
        return self.xs[i], self.ys[j]


def _valid_poses(cost, px, py, headings) -> np.ndarray:
    """(position, heading) table of the poses that break no limit.

    A zero-length motion is finite iff its pose is valid.
    """
    valid = np.zeros((px.size, len(headings)), dtype=bool)
    for h, heading in enumerate(headings):
        th = np.full(px.size, heading)
        valid[:, h] = np.isfinite(cost.batch(px, py, th, px, py, th))
    return valid


def _translation_edges(cost, xs, ys, headings, valid, moves, metric, step, done=None):
    """Edges ``(src, dst, weight)`` of the translations at constant heading.

    ``done``: a mask of positions whose edges among themselves are already priced
    (:func:`_distance_search`): those edges are left out.
    """
    nx, ny, H = len(xs), len(ys), len(headings)
    jj, ii = np.divmod(np.arange(nx * ny), nx)
    px, py = xs[ii], ys[jj]
    move_ok = move_table(headings, moves)
    for mi, (di, dj) in enumerate(MOVES_16):
        ok_pos = (ii + di >= 0) & (ii + di < nx) & (jj + dj >= 0) & (jj + dj < ny)
        p_src = np.nonzero(ok_pos)[0]
        p_dst = p_src + dj * nx + di
        if done is not None:
            keep = ~(done[p_src] & done[p_dst])
            p_src, p_dst = p_src[keep], p_dst[keep]
        for h in np.nonzero(move_ok[:, mi])[0]:
            m = valid[p_src, h] & valid[p_dst, h]
            a, b = p_src[m], p_dst[m]
            if a.size == 0:
                continue
            th = np.full(a.size, headings[h])
            w = cost.batch(px[a], py[a], th, px[b], py[b], th)
            f = np.isfinite(w)
            a, b, w = a[f], b[f], w[f]
            if metric == "distance":
                w = np.full(a.size, step * math.hypot(di, dj))
            yield a * H + h, b * H + h, w


def _turn_edges(cost, px, py, headings, valid, metric, done=None):
    """Edges ``(src, dst, weight)`` of the turns in place to the neighbouring headings.

    ``done``: a mask of positions whose turns are already priced (left out).
    """
    H = len(headings)
    todo = np.ones(px.size, bool) if done is None else ~done
    for h in range(H):
        for dh in (-1, 1):
            h2 = (h + dh) % H
            a = np.nonzero(valid[:, h] & valid[:, h2] & todo)[0]
            if a.size == 0:
                continue
            th0, th1 = np.full(a.size, headings[h]), np.full(a.size, headings[h2])
            w = cost.batch(px[a], py[a], th0, px[a], py[a], th1)
            f = np.isfinite(w)
            a, w = a[f], w[f]
            if metric == "distance":
                w = np.full(a.size, _TURN_EPS * abs(wrap(headings[h2] - headings[h])))
            yield a * H + h, a * H + h2, w


def lattice_graph(
    cost,
    terrain,
    start_xy: tuple[float, float],
    step: float,
    n_headings: int = 16,
    moves: str = "axes",
    metric: str = "energy",
) -> LatticeGraph:
    """Build the state lattice's graph: every edge priced by ``cost.batch``.

    Parameters
    ----------
    cost : MotionCost
        Motion cost; an infinite cost drops the edge.
    terrain : Terrain
        The map; the lattice covers its extent.
    start_xy : (float, float)
        A node of the lattice (working CRS).
    step : float
        Lattice spacing, m.
    n_headings : int
        Headings per position.
    moves : {"axes", "crab", "all"}
        The move set (:data:`~energy_planner.planning.moves.MOVE_SETS`).
    metric : {"energy", "distance"}
        Edge weight: the motion's energy, or its horizontal length (turns in place weigh
        a tiny :data:`_TURN_EPS` per radian) on the same feasible edges.

    Returns
    -------
    LatticeGraph
    """
    xs, ys = lattice_geometry(terrain, start_xy, step)
    headings = lattice_headings(int(n_headings))
    jj, ii = np.divmod(np.arange(len(xs) * len(ys)), len(xs))
    px, py = xs[ii], ys[jj]
    valid = _valid_poses(cost, px, py, headings)
    edges = [
        *_translation_edges(cost, xs, ys, headings, valid, moves, metric, step),
        *_turn_edges(cost, px, py, headings, valid, metric),
    ]
    return _graph(edges, xs, ys, headings, valid, step)


#: The last lattice graph of each terrain (weakly), with what it was built for: a second
#: round trip of the same problem from the same start (``reach``: the other
#: ``turn_at_cell``, another budget), or a second lattice plan from that start (another
#: goal), searches it again instead of pricing every edge anew.
_GRAPHS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()

#: The largest graph kept in :data:`_GRAPHS` (bytes of its arrays).
GRAPH_KEEP_BYTES = 64 * 2**20


def kept_graph(problem, start_xy, step: float, n_headings: int, moves: str) -> LatticeGraph:
    """:func:`lattice_graph` of ``problem``, or the kept one.

    Kept (:data:`_GRAPHS`) for a cost its problem made (its model, an equal request without
    channel rasters, the same speed range and price of a second) and graphs up to
    :data:`GRAPH_KEEP_BYTES`; the same graph either way.
    """
    cost, terrain, request = problem.cost, problem.terrain, problem.request
    lam = float(getattr(cost, "time_weight", 0.0))
    xy = tuple(float(v) for v in start_xy[:2])
    key = (xy, float(step), int(n_headings), str(moves), getattr(cost, "speed_range", None), lam)
    keep = getattr(cost, "request", None) is request and request.channels is None
    if keep:
        hit = _GRAPHS.get(terrain)
        if hit is not None and hit[0] is problem.model and hit[2] == key:
            try:
                same = hit[1] is request or bool(hit[1] == request)
            except (TypeError, ValueError):  # a keep-out that does not compare
                same = False
            if same:
                return hit[3]
    lat = lattice_graph(cost, terrain, start_xy, step, n_headings, moves)
    g = lat.graph
    size = g.data.nbytes + g.indices.nbytes + g.indptr.nbytes + lat.valid.nbytes
    if keep and size <= GRAPH_KEEP_BYTES:
        _GRAPHS[terrain] = (problem.model, request, key, lat)
    return lat


def _graph(edges: list, xs, ys, headings, valid, step) -> LatticeGraph:
    """The :class:`LatticeGraph` of the edge parts ``(src, dst, weight)``."""
    from scipy.sparse import csr_matrix

    n = len(xs) * len(ys) * len(headings)
    if edges:
        src, dst, w = (np.concatenate(parts) for parts in zip(*edges, strict=True))
    else:
        src, dst, w = np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    graph = csr_matrix((np.maximum(w, _MIN_W), (src, dst)), shape=(n, n))
    return LatticeGraph(graph, xs, ys, headings, valid, float(step))


#: :func:`_distance_search`: the first bound on the shortest path's length, as a factor of
#: the start-goal distance (a lattice path along the 16 move directions is at most 2.8 %
#: longer than the straight line), and the factor it grows by while no path fits in it
_FIRST_BOUND, _BOUND_GROWTH = 1.04, 1.5


def _distance_search(cost, terrain, start, goal, step, n_headings, moves) -> LatticeGraph:
    """The distance lattice restricted to the positions its shortest path can pass.

    A lattice path of length ``L`` from ``s`` to ``g`` stays in the ellipse
    ``|p - s| + |p - g| <= L`` (its parts are at least as long as straight lines). So the
    edges are priced inside the ellipse of a bound ``L`` only, growing ``L`` (pricing the
    new ring's poses and edges) until the shortest path inside is no longer than ``L``:
    then no path that leaves the ellipse is shorter, and the restricted graph's shortest
    path is a shortest path of the whole lattice (the same length; where several paths
    are equally short, Dijkstra's order over the fewer edges may pick another of them).
    Where the straight line is open this prices a thin ellipse instead of the whole map;
    a detour, the ellipse of its length.
    """
    xs, ys = lattice_geometry(terrain, (start[0], start[1]), step)
    headings = lattice_headings(int(n_headings))
    jj, ii = np.divmod(np.arange(len(xs) * len(ys)), len(xs))
    px, py = xs[ii], ys[jj]
    gi = np.clip(np.round((goal[0] - xs[0]) / step), 0, len(xs) - 1)
    gj = np.clip(np.round((goal[1] - ys[0]) / step), 0, len(ys) - 1)
    gx, gy = xs[int(gi)], ys[int(gj)]
    reach = np.hypot(px - start[0], py - start[1]) + np.hypot(px - gx, py - gy)
    bound = max(_FIRST_BOUND * math.hypot(gx - start[0], gy - start[1]), 2 * step)
    valid = np.zeros((px.size, len(headings)), dtype=bool)
    done = np.zeros(px.size, bool)
    edges: list = []
    while True:
        inside = reach <= bound * (1 + 1e-9)
        new = inside & ~done
        valid[new] = _valid_poses(cost, px[new], py[new], headings)
        edges += [
            *_translation_edges(cost, xs, ys, headings, valid, moves, "distance", step, done),
            *_turn_edges(cost, px, py, headings, valid, "distance", done),
        ]
        done = inside
        lat = _graph(edges, xs, ys, headings, valid, step)
        if done.all():
            return lat
        length = _shortest(lat, start, goal)[0]
        if length <= bound:
            return lat
        bound = (
            min(length, _BOUND_GROWTH * bound) if math.isfinite(length) else _BOUND_GROWTH * bound
        )


def _check_options(metric: str, moves: str, n_headings: int) -> None:
    """:class:`PlanningConfigError` for a metric, move set or heading count not offered."""
    if metric not in ("energy", "distance"):
        raise PlanningConfigError(
            f"metric {metric!r} is not one of 'energy', 'distance'", value=metric, param="metric"
        )
    check_moves(moves)
    check_headings(n_headings)


def _endpoint_nodes(lat: LatticeGraph, x: float, y: float, yaw, which: str) -> np.ndarray:
    """Graph nodes of endpoint ``which`` at the heading nearest ``yaw`` (None: every one).

    Raises
    ------
    InvalidStateError
        Outside the lattice, or no valid heading there.
    """
    xs, ys, step = lat.xs, lat.ys, lat.step
    nx, ny = len(xs), len(ys)
    i = int(round((x - xs[0]) / step))
    j = int(round((y - ys[0]) / step))
    if not (0 <= i < nx and 0 <= j < ny):
        from energy_planner.planning.limits import outside_map

        raise outside_map(which, x, y, f"the map (lattice x {xs[0]:.2f}..{xs[-1]:.2f}, "
                          f"y {ys[0]:.2f}..{ys[-1]:.2f} in the working CRS)")  # fmt: skip
    p = j * nx + i
    if yaw is None:
        hs = np.nonzero(lat.valid[p])[0]
    else:
        hs = np.array([int(np.argmin(np.abs(wrap(lat.headings - float(yaw)))))])
        hs = hs[lat.valid[p, hs]]
    if hs.size == 0:
        raise InvalidStateError(
            f"{which} lattice node ({xs[i]:.2f}, {ys[j]:.2f}) breaks a limit at "
            f"{'every heading' if yaw is None else 'the requested heading'} "
            f"(lattice step {step:.2f} m)"
        )
    return p * lat.n_headings + hs


def _shortest(lat: LatticeGraph, start, goal) -> tuple[float, int, np.ndarray, np.ndarray]:
    """Dijkstra from the start's nodes: ``(cost, best goal node, sources, predecessors)``.

    Raises
    ------
    InvalidStateError
        An endpoint outside the lattice or breaking a limit at its headings.
    """
    from scipy.sparse.csgraph import dijkstra

    sources = _endpoint_nodes(lat, start[0], start[1], start[2], "start")
    goals = _endpoint_nodes(lat, goal[0], goal[1], goal[2], "goal")
    dist, pred, _src = dijkstra(
        lat.graph, directed=True, indices=sources, return_predecessors=True, min_only=True
    )
    best = goals[int(np.argmin(dist[goals]))]
    return float(dist[best]), int(best), sources, pred


def _node_chain(pred: np.ndarray, best: int, sources: np.ndarray) -> np.ndarray:
    """The nodes from a source to ``best``, following Dijkstra's predecessors."""
    chain = [int(best)]
    starts = set(sources.tolist())
    while chain[-1] not in starts:
        prev = int(pred[chain[-1]])
        if prev < 0:
            break
        chain.append(prev)
    chain.reverse()
    return np.array(chain)


@takes_problem(2)
def lattice_plan(
    problem,
    start: tuple[float, float, float | None],
    goal: tuple[float, float, float | None],
    *,
    step: float | None = None,
    n_headings: int = 16,
    metric: str = "energy",
    moves: str = "axes",
) -> LatticeResult:
    """Resolution-optimal path on the (x, y, heading) lattice.

    Parameters
    ----------
    problem : Problem
        Terrain (the lattice covers its extent) and motion cost (``problem.cost.batch``
        prices every edge; limits make edges infinite), :class:`energy_planner.problem.Problem`;
        the older form ``lattice_plan(cost, terrain, start, goal, ...)`` is accepted.
    start, goal : tuple
        ``(x, y, yaw)`` in the working CRS, yaw in radians or ``None`` (free: the search
        picks the best lattice heading).
    step : float, optional
        Lattice spacing, m (default :func:`default_step`).
    n_headings : int
        Headings per position (a multiple of 4 keeps the axes).
    metric : {"energy", "distance"}
        Edge weight: the motion's energy, or its horizontal length (shortest feasible
        path under the same limits; its edges priced only where it can pass,
        :func:`_distance_search`).
    moves : {"axes", "crab", "all"}
        ``"axes"``: at each heading, the neighbour move closest to each body axis
        (forward, left, backward, right) - 4 translations per node, the paper's motion
        primitives; ``"crab"``: also the 4 obliques at 45 degrees to them (8);
        ``"all"``: all 16 neighbours at every heading (4x the edges; any body yaw
        relative to the direction of travel: crab walking).

    Returns
    -------
    LatticeResult

    Raises
    ------
    InvalidStateError
        If the start or goal lattice node breaks a limit.
    PlanningError
        If the goal cannot be reached on the lattice.
    """
    _check_options(metric, moves, n_headings)
    cost, terrain = problem.cost, problem.terrain
    t0 = time.perf_counter()
    step = float(step) if step is not None else default_step(terrain)
    if metric == "distance":
        lat = _distance_search(cost, terrain, start, goal, step, int(n_headings), moves)
    else:
        lat = kept_graph(problem, (start[0], start[1]), step, int(n_headings), moves)
    t1 = time.perf_counter()
    length, best, sources, pred = _shortest(lat, start, goal)
    if not np.isfinite(length):
        raise PlanningError(
            f"no feasible path from start ({start[0]:.2f}, {start[1]:.2f}) to goal "
            f"({goal[0]:.2f}, {goal[1]:.2f}) on the lattice (step {step:.2f} m, "
            f"{lat.n_headings} headings) under the given limits; relax the slope limits or "
            "keep-out areas"
        )
    p_of, h_of = np.divmod(_node_chain(pred, best, sources), lat.n_headings)
    states = np.column_stack([*lat.position(p_of), wrap(lat.headings[h_of])])
    states = exact_ends(states, start, goal)
    t2 = time.perf_counter()
    return LatticeResult(
        states=simplify_states(states),
        cost=float(length),
        metric=metric,
        step=step,
        n_headings=lat.n_headings,
        n_nodes=lat.n_nodes,
        n_edges=int(lat.graph.nnz),
        build_s=t1 - t0,
        search_s=t2 - t1,
    )
