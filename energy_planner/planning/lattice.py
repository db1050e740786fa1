"""Reference planner: Dijkstra on a fully built state lattice over (x, y, heading).

Kept for reference and benchmarks; the default planner is the full-resolution search of
:mod:`energy_planner.planning.search`, which has the same motion primitives and edge costs
but prices edges on demand instead of building the graph (so at equal ``step`` both find
the same optimum).

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
horizontal length of each edge as its weight: the shortest feasible path.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from energy_planner.angles import wrap
from energy_planner.errors import InvalidStateError, PlanningConfigError, PlanningError

__all__ = [
    "LatticeResult",
    "MOVES_16",
    "default_step",
    "lattice_headings",
    "lattice_geometry",
    "lattice_plan",
    "simplify_states",
]

#: The 16 neighbour displacements (in lattice steps), counter-clockwise from +x.
MOVES_16: np.ndarray = np.array(
    [
        (1, 0), (2, 1), (1, 1), (1, 2), (0, 1), (-1, 2), (-1, 1), (-2, 1),
        (-1, 0), (-2, -1), (-1, -1), (-1, -2), (0, -1), (1, -2), (1, -1), (2, -1),
    ],
    dtype=np.int64,
)  # fmt: skip

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
        Size of the searched graph.
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


def _terrain_extent(terrain) -> tuple[float, float, float, float]:
    """(xmin, xmax, ymin, ymax) of the terrain's cell centres in the working CRS."""
    x0, y0, dx, dy = terrain.grid
    rows, cols = np.shape(terrain.elevation)
    xs = (x0, x0 + (cols - 1) * dx)
    ys = (y0, y0 + (rows - 1) * dy)
    return min(xs), max(xs), min(ys), max(ys)


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
    xmin, xmax, ymin, ymax = _terrain_extent(terrain)
    step = max(abs(dx), abs(dy))
    area = max(xmax - xmin, step) * max(ymax - ymin, step)
    return max(step, math.sqrt(area / max_positions))


def lattice_geometry(terrain, start_xy: tuple[float, float], step: float):
    """Lattice positions covering the terrain, aligned so that ``start_xy`` is a node.

    Returns
    -------
    xs, ys : ndarray
        The lattice's x (columns) and y (rows) coordinates, increasing.
    """
    xmin, xmax, ymin, ymax = _terrain_extent(terrain)
    sx, sy = start_xy
    i0 = math.floor((sx - xmin) / step + 1e-9)
    j0 = math.floor((sy - ymin) / step + 1e-9)
    i1 = math.floor((xmax - sx) / step + 1e-9)
    j1 = math.floor((ymax - sy) / step + 1e-9)
    xs = sx + step * np.arange(-i0, i1 + 1)
    ys = sy + step * np.arange(-j0, j1 + 1)
    return xs, ys


def lattice_headings(n_headings: int) -> np.ndarray:
    """The lattice's headings, radians in [0, 2 pi).

    With 16 headings they are the directions of :data:`MOVES_16` (0, 26.6, 45, 63.4,
    90 deg, ...), so that every heading has a move straight ahead, behind and to
    either side; otherwise they are evenly spaced.

    Examples
    --------
    >>> np.round(np.degrees(lattice_headings(16)[:5]), 1).tolist()
    [0.0, 26.6, 45.0, 63.4, 90.0]
    >>> np.degrees(lattice_headings(8)).tolist()
    [0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0]
    """
    if n_headings == len(MOVES_16):
        return np.arctan2(MOVES_16[:, 1], MOVES_16[:, 0]) % (2 * np.pi)
    return 2 * np.pi * np.arange(n_headings) / n_headings


def _move_table(headings: np.ndarray, moves: str) -> np.ndarray:
    """Boolean (heading, move) table of the translations allowed at each heading.

    Examples
    --------
    >>> t = _move_table(lattice_headings(16), "axes")
    >>> t.sum(axis=1).tolist() == [4] * 16
    True
    >>> [tuple(MOVES_16[m].tolist()) for m in np.nonzero(t[1])[0]]
    [(2, 1), (-1, 2), (-2, -1), (1, -2)]
    >>> _move_table(lattice_headings(16), "crab").sum(axis=1).tolist() == [8] * 16
    True
    """
    n_headings = len(headings)
    if moves == "all":
        return np.ones((n_headings, len(MOVES_16)), dtype=bool)
    ang = np.arctan2(MOVES_16[:, 1], MOVES_16[:, 0])
    table = np.zeros((n_headings, len(MOVES_16)), dtype=bool)
    n_dirs = 8 if moves == "crab" else 4
    for h in range(n_headings):
        for k in range(n_dirs):
            axis = headings[h] + k * 2 * np.pi / n_dirs
            table[h, int(np.argmin(np.abs(wrap(ang - axis))))] = True
    return table


def simplify_states(states: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """Drop repeated poses and interior poses on a straight, constant-yaw run.

    The energy of a straight motion at constant yaw is the integral of the same
    per-metre cost, so merging collinear steps does not change it (up to sampling).

    Examples
    --------
    >>> s = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [2, 0, 1.0]], float)
    >>> simplify_states(s).tolist()
    [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 0.0, 1.0]]
    """
    states = np.asarray(states, float)
    dup = np.r_[False, np.all(np.abs(np.diff(states, axis=0)) <= tol, axis=1)]
    states = states[~dup]
    if len(states) <= 2:
        return states.copy()
    keep = [0]
    for k in range(1, len(states) - 1):
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


def lattice_plan(
    cost,
    terrain,
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
    cost : MotionCost
        Motion cost (its ``batch`` prices every edge; limits make edges infinite).
    terrain : Terrain
        The map; the lattice covers its extent.
    start, goal : tuple
        ``(x, y, yaw)`` in the working CRS, yaw in radians or ``None`` (free: the search
        picks the best lattice heading).
    step : float, optional
        Lattice spacing, m (default :func:`default_step`).
    n_headings : int
        Headings per position (a multiple of 4 keeps the axes).
    metric : {"energy", "distance"}
        Edge weight: the motion's energy, or its horizontal length (shortest feasible
        path under the same limits).
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
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import dijkstra

    if metric not in ("energy", "distance"):
        raise PlanningConfigError(
            f"metric {metric!r} is not one of 'energy', 'distance'", value=metric, param="metric"
        )
    if moves not in ("axes", "crab", "all"):
        raise PlanningConfigError(
            f"moves {moves!r} is not one of 'axes', 'crab', 'all'", value=moves, param="moves"
        )
    if n_headings < 4:
        raise PlanningConfigError(
            f"n_headings={n_headings} is too small; use at least 4 (e.g. 16)",
            value=n_headings,
            param="n_headings",
        )
    t0 = time.perf_counter()
    step = float(step) if step is not None else default_step(terrain)
    xs, ys = lattice_geometry(terrain, (start[0], start[1]), step)
    nx, ny = len(xs), len(ys)
    H = int(n_headings)
    headings = lattice_headings(H)
    P = nx * ny
    jj, ii = np.divmod(np.arange(P), nx)
    px, py = xs[ii], ys[jj]

    # pose validity per (position, heading): a zero-length motion is finite iff valid
    valid = np.zeros((P, H), dtype=bool)
    for h in range(H):
        th = np.full(P, headings[h])
        valid[:, h] = np.isfinite(cost.batch(px, py, th, px, py, th))

    srcs: list[np.ndarray] = []
    dsts: list[np.ndarray] = []
    ws: list[np.ndarray] = []
    # translations at constant heading
    move_ok = _move_table(headings, moves)
    for mi, (di, dj) in enumerate(MOVES_16):
        ok_pos = (ii + di >= 0) & (ii + di < nx) & (jj + dj >= 0) & (jj + dj < ny)
        p_src = np.nonzero(ok_pos)[0]
        p_dst = p_src + dj * nx + di
        length = step * math.hypot(di, dj)
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
                w = np.full(a.size, length)
            srcs.append(a * H + h)
            dsts.append(b * H + h)
            ws.append(w)
    # turns in place to the neighbouring headings
    for h in range(H):
        for dh in (-1, 1):
            h2 = (h + dh) % H
            m = valid[:, h] & valid[:, h2]
            a = np.nonzero(m)[0]
            if a.size == 0:
                continue
            w = cost.batch(
                px[a],
                py[a],
                np.full(a.size, headings[h]),
                px[a],
                py[a],
                np.full(a.size, headings[h2]),
            )
            f = np.isfinite(w)
            a, w = a[f], w[f]
            if metric == "distance":
                w = np.full(a.size, _TURN_EPS * abs(wrap(headings[h2] - headings[h])))
            srcs.append(a * H + h)
            dsts.append(a * H + h2)
            ws.append(w)
    N = P * H
    src = np.concatenate(srcs) if srcs else np.zeros(0, np.int64)
    dst = np.concatenate(dsts) if dsts else np.zeros(0, np.int64)
    w = np.maximum(np.concatenate(ws), _MIN_W) if ws else np.zeros(0)
    graph = csr_matrix((w, (src, dst)), shape=(N, N))
    del srcs, dsts, ws, src, dst, w
    t1 = time.perf_counter()

    def node_index(x, y, yaw, which):
        i = int(round((x - xs[0]) / step))
        j = int(round((y - ys[0]) / step))
        if not (0 <= i < nx and 0 <= j < ny):
            raise InvalidStateError(
                f"{which} ({x:.2f}, {y:.2f}) is outside the map (lattice x {xs[0]:.2f}.."
                f"{xs[-1]:.2f}, y {ys[0]:.2f}..{ys[-1]:.2f} in the working CRS)",
                endpoint=which,
                limit="map",
                value=(x, y),
            )
        p = j * nx + i
        if yaw is None:
            hs = np.nonzero(valid[p])[0]
        else:
            hs = np.array([int(np.argmin(np.abs(wrap(headings - float(yaw)))))])
            hs = hs[valid[p, hs]]
        if hs.size == 0:
            raise InvalidStateError(
                f"{which} lattice node ({px[p]:.2f}, {py[p]:.2f}) breaks a limit at "
                f"{'every heading' if yaw is None else 'the requested heading'} "
                f"(lattice step {step:.2f} m)"
            )
        return p, hs

    ps, hs_start = node_index(start[0], start[1], start[2], "start")
    pg, hs_goal = node_index(goal[0], goal[1], goal[2], "goal")
    sources = ps * H + hs_start
    dist, pred, _src = dijkstra(
        graph, directed=True, indices=sources, return_predecessors=True, min_only=True
    )
    goals = pg * H + hs_goal
    best = goals[int(np.argmin(dist[goals]))]
    if not np.isfinite(dist[best]):
        raise PlanningError(
            f"no feasible path from start ({start[0]:.2f}, {start[1]:.2f}) to goal "
            f"({goal[0]:.2f}, {goal[1]:.2f}) on the lattice (step {step:.2f} m, {H} headings) "
            "under the given limits; relax the slope limits or keep-out areas"
        )
    chain = [int(best)]
    while chain[-1] not in set(sources.tolist()):
        prev = int(pred[chain[-1]])
        if prev < 0:
            break
        chain.append(prev)
    chain.reverse()
    nodes = np.array(chain)
    p_of, h_of = np.divmod(nodes, H)
    states = np.column_stack([px[p_of], py[p_of], wrap(headings[h_of])])
    # exact start and goal poses around the lattice part
    first = states[0]
    if start[2] is not None and abs(wrap(float(start[2]) - first[2])) > 1e-12:
        states = np.vstack([[start[0], start[1], float(wrap(start[2]))], states])
    last = states[-1]
    gyaw = float(wrap(goal[2])) if goal[2] is not None else last[2]
    if (
        abs(goal[0] - last[0]) > 1e-9
        or abs(goal[1] - last[1]) > 1e-9
        or abs(gyaw - last[2]) > 1e-12
    ):
        states = np.vstack([states, [goal[0], goal[1], gyaw]])
    t2 = time.perf_counter()
    return LatticeResult(
        states=simplify_states(states),
        cost=float(dist[best]),
        metric=metric,
        step=step,
        n_headings=H,
        n_nodes=N,
        n_edges=int(graph.nnz),
        build_s=t1 - t0,
        search_s=t2 - t1,
    )
