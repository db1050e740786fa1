"""The energy matrix of a mission: one early-stopped search per site, serial or on dask.

Each row of the matrix is one search from a site over the planner's own motions
(:func:`energy_planner.planning.search.targets_search`: the primitives, kernel and
float32 energies of :func:`~energy_planner.planning.search.reach_search` and ``plan``)
that stops as soon as every other site is settled. It is an A* toward all the other
sites at once, guided by the least of their relaxed costs-to-go (the bound ``plan``'s
search uses, :func:`~energy_planner.planning.search.target_heuristics`, computed once per
site and shared by every row). Its entries equal those of a full search (Dijkstra over
the whole map, read at the sites) up to float rounding (with ``eps = 1``).

**Heuristics priced once.** Every site's bound is the same relaxed problem solved toward
another goal, so its edges are priced once for all of them (:func:`relaxed_table`, 64
bytes per position, when it takes at most a quarter of the memory cap) and each site's
bound is a Dijkstra that reads them (:func:`relaxed_heuristics`): on the 2000² benchmark
DEM the 20 bounds took 128 CPU s priced per site; now 18 CPU s for the table and about 2
CPU s per Dijkstra (at load 8 on 2 cores). Otherwise each bound prices its own edges
(:func:`~energy_planner.planning.search.target_heuristics`).

**Weighted (eps).** With ``eps > 1`` (``plan``'s default is 1.05) each search keys its
states ``g + eps * h``: the weighted A* bound holds for every site at once (``h``, the
least of the remaining sites' bounds, is a consistent lower bound of the cost to each of
them), so each entry is at most ``eps`` times the least energy (the tests check it
against the full search). On a large map this is what makes the matrix affordable: at
eps 1 a search widens around every way to a site by the bound's slack (the relaxed
bound is 4-6 % under the true cost on the hilly benchmark DEM), at 1.05 it keeps to
narrow bands (20 sites, states expanded per row: 11 % at 200² against 20 % at eps 1;
4.9 % at 500², 2.3 % at 1000²).

**Edges priced once.** The cost of a search is the kernel pricing its edges (18 per state
expanded, each sampling the terrain every half cell with the model's power), not the
heap. The sites' searches run on one lattice, so they share a cache filled as they go
(:func:`~energy_planner.planning.search.edge_cache`): an edge is priced when a row first
needs it and read by the later rows (an edge to a closed state, or one that could not
improve its end even at the least energy of its move, is not needed: about half of a
row's translations; per process; on dask, per batch of
rows, the batches passing each other what they priced after every round:
:func:`_lazy_rounds`), and its memory follows the states expanded. Alternatively every edge of the
window is priced once (:func:`~energy_planner.planning.search.edge_table`, by strips of
rows, 72 bytes per state, :data:`~energy_planner.planning.search.EDGE_BYTES_PER_STATE`)
and the searches read the prices: both are float32 prices of the same kernel call, so
the entries are the same, and they agree with the on-demand search to float32
rounding. One cache never prices more than the table, so the table is used only on dask
with ``eps = 1`` and many sites (:func:`_edge_mode`).

**Window.** The searches stand inside a box around the sites, proven by the corridor's
argument (:mod:`energy_planner.planning.corridor`): ``c_min`` bounds the energy per
metre of any translation from below (:func:`~energy_planner.planning.corridor.least_cost_per_metre`
over the terrain's gradients), so a path from site ``i`` to site ``j`` cheaper than the
window's ``E[i, j]`` (a feasible path, an upper bound) has length at most
``E[i, j] / c_min`` and lies in the ellipse with foci ``i`` and ``j`` of that length. If
every pair's ellipse lies inside the window, the window's matrix is the whole map's
(with ``eps > 1``: the whole map's least energy lies in the window, and each entry is
at most ``eps`` times it). If
not, the window grows to the ellipses' bounding box (clipped to the map) and the searches
run again, which proves it. A pair without a path in the window, or ``c_min = 0``
(channel rasters), takes the whole map. The second pass does not price again the edges
the first one priced (serial, lazy cache: :func:`_carry_cache`): a motion between two
positions of the first window costs the same in the grown one, so the edges priced in
the first window are copied into the new cache and only the others are priced. The
searches run again (their heuristics, bounds over the grown window, are lower), over the
same float32 prices, so the entries are those of a second pass that prices everything.
On the README's mission (``--dem hill --sites hill_sites``) the first window is refused
(the pairs' ellipses reach the map's edges) and the second pass expands the same 58,893
states: with the copied edges it prices none of them, and the matrix takes 2.2 CPU s
instead of 4.1 (``benchmarks/bench_mission_passes.py``).

**dask.** The relaxed table (by strips of rows), the per-site heuristics and then the
per-site searches are independent tasks:
with a ``dask.distributed`` client (a :class:`~distributed.LocalCluster`, or a
``Client("tcp://host:8786")`` given by address) they run on its workers, with the same
result as the serial loop. The terrain, the model and the request are sent once
(``scatter``); each worker builds the motion cost from them (the kernels come from the
disk cache). The relaxed table's strips and the heuristics' rows stay on the workers
(the tasks that read them fetch them from the workers that made them). The rows run in one
batch per worker thread, in rounds that share the edges they priced (:func:`_lazy_rounds`);
the whole edge table, when used, is priced by strips of rows on the workers, then sent to
each of them. What such a cluster spends beside these long tasks is its processes'
periodic work (profiler, event-loop ticks, system and memory monitors): a cluster running
the matrix should be started with :data:`CLUSTER_CONFIG`.
"""

from __future__ import annotations

import math
import time
import weakref
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["CLUSTER_CONFIG", "MatrixResult", "matrix_search", "window_proof"]

#: The dask configuration a cluster running the matrix should use (docs/routes.md): set it
#: where the scheduler, the nannies and the workers start (``dask.config.set(CLUSTER_CONFIG)``
#: before a :class:`~distributed.LocalCluster`; the same keys in a dask YAML file or
#: ``DASK_*`` variables for ``dask scheduler`` / ``dask worker``). The matrix's tasks run
#: for seconds to minutes, so what costs CPU beside them is each process's periodic work,
#: for as long as the matrix takes: the workers' statistical profiler (every 10 ms), the
#: event loops' health tick (every 20 ms in every server), the system monitor (every
#: 500 ms, with disk and network counters) and the memory monitor (every 100 ms in each
#: worker and nanny). An idle LocalCluster of 2 workers took 0.15 CPU s per second with
#: dask's defaults and 0.02 with these; the 20-site matrix on a 400² DEM (load about 9 on
#: 2 cores) spent 10.3 CPU s outside its tasks with the defaults and 2.6 s with these. The
#: costs: no statistical profile on the dashboard, memory limits checked every second.
CLUSTER_CONFIG: dict[str, Any] = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "10s",
    "distributed.worker.memory.monitor-interval": "1s",
}

#: Initial window: the sites' bounding box grown by this share of its larger side ...
WINDOW_SHARE = 0.25
#: ... and at least this many cells.
WINDOW_MIN_CELLS = 20


@dataclass
class MatrixResult:
    """The energy matrix and how it was found.

    Attributes
    ----------
    energy_j : ndarray, shape (n, n)
        ``E[i, j]``: least energy from site ``i`` to site ``j`` (min over the headings of
        arrival, any heading at the start), J; ``inf`` unreachable, 0 on the diagonal.
    info : dict
        ``window`` (the box searched, working CRS), ``whole_map``, ``proven``,
        ``c_min_j_per_m``, ``passes``, ``expanded`` (states, all rows and passes),
        ``states_total`` (positions x headings x rows of the last pass), ``heuristic_s``,
        ``search_s`` (edge table included), ``edge_table`` (used), ``edges`` (``"table"``,
        ``"lazy"`` or ``"on demand"``, :func:`_edge_mode`), ``priced`` (edges priced by
        the searches, all passes; the table's not counted), ``edge_table_s``, ``carried``
        (states whose edges a pass took from the previous one, :func:`_carry_cache`).
    """

    energy_j: np.ndarray
    info: dict[str, Any] = field(default_factory=dict)


def _setup(terrain, model, request, n_headings, box, anchor, speed=None):
    """The motion cost (with ``speed``: ``(speed_range, time_weight)``) and the search grid."""
    from energy_planner.planning.search import search_grid

    cost = _cost(terrain, model, request, speed)
    cost.compile()
    return cost, search_grid(cost, terrain, anchor, n_headings=n_headings, box=box)


def _cost(terrain, model, request, speed):
    """The problem's motion cost, each motion choosing its speed with ``speed``.

    ``speed``: ``(speed_range, time_weight)``
    (:meth:`~energy_planner.problem.Problem.with_speed`), or None.
    """
    from energy_planner.problem import Problem

    prob = Problem(terrain, model, request)
    return (prob if speed is None else prob.with_speed(*speed)).cost


#: Bytes per position of the relaxed edge table (16 float32 moves) and of one Dijkstra's
#: work arrays (float64 cost, int32 heap index, float64 key, int64 value).
RELAXED_BYTES_PER_POSITION = 4 * 16 + 28


def relaxed_table(cost, grid, rows: tuple[int, int] | None = None) -> np.ndarray:
    """The relaxed problem's edges of ``grid`` priced once (float32, J; see :mod:`._relaxed`).

    ``rows`` = ``(j0, j1)``: the edges leaving lattice rows ``j0 .. j1 - 1`` only (strips
    stacked in order give the whole table).

    Returns
    -------
    ndarray of float32, shape ((j1 - j0) * grid.nx, 16)
        ``out[p, m]``: the bound of translation ``grid.moves[m]`` from position ``p``
        (:func:`energy_planner.planning.search.relaxed_cost_to_go`'s edge), ``inf`` where
        there is none.
    """
    from energy_planner.energy.kernels import IN_BLOCKED, IN_GRAD, IN_TMAX
    from energy_planner.mission import _relaxed
    from energy_planner.planning.search import BOUND_MARGIN, _geo, _sampling, bound_table

    j0, j1 = (0, grid.ny) if rows is None else (int(rows[0]), int(rows[1]))
    table, tgeo = bound_table(cost, grid.headings, grid.move_ok)
    grad, blocked = cost.data[IN_GRAD], cost.data[IN_BLOCKED]
    from energy_planner.planning._search import unsafe_cells

    unsafe = unsafe_cells(grad, blocked, float(cost.data[IN_TMAX]))
    out = np.empty(((j1 - j0) * grid.nx, grid.moves.shape[0]), np.float32)
    _relaxed.relaxed_edges(grad, blocked, unsafe, _geo(cost), _sampling(cost), grid.lat,
                           grid.moves, table, tgeo, BOUND_MARGIN, j0, j1, out)  # fmt: skip
    return out


def relaxed_heuristics(grid, edges: np.ndarray, targets_xy: np.ndarray) -> np.ndarray:
    """The relaxed cost-to-go of every position to each target, over :func:`relaxed_table`.

    The same rows as :func:`energy_planner.planning.search.target_heuristics` (up to the
    float32 rounding of the edges, downward: still lower bounds), each a Dijkstra that
    reads the shared table instead of pricing the edges again.

    Returns
    -------
    ndarray of float32, shape (len(targets_xy), grid.P)
        J, rounded down; ``inf`` where the target cannot be reached in the relaxed problem.
    """
    from energy_planner.mission._relaxed import relaxed_dijkstra

    xy = np.asarray(targets_xy, float).reshape(-1, 2)
    out = np.empty((len(xy), grid.P), np.float32)
    h = np.empty(grid.P)
    pos = np.empty(grid.P, np.int32)
    keys = np.empty(grid.P)
    vals = np.empty(grid.P, np.int64)
    for k, (x, y) in enumerate(xy):
        h.fill(np.inf)
        pos.fill(-1)
        relaxed_dijkstra(edges, grid.lat, grid.moves, grid.position(x, y, "target"), h, pos,
                         keys, vals)  # fmt: skip
        h32 = h.astype(np.float32)
        out[k] = np.where(h32 > h, np.nextafter(h32, np.float32(-np.inf)), h32)
    return out


def _relaxed_fits(grid) -> bool:
    """Whether :func:`relaxed_table` and a Dijkstra's arrays take at most a quarter of the cap."""
    from energy_planner.terrain.memory import resolve_cap

    return grid.P * RELAXED_BYTES_PER_POSITION <= 0.25 * resolve_cap()


def _heuristic_task(terrain, model, request, n_headings, box, anchor, speed, xys, edges=None):
    """The heuristics' rows of the targets ``xys``.

    Over ``edges`` (:func:`relaxed_table`, or its strips of rows in order) if given, else
    :func:`~energy_planner.planning.search.target_heuristics`.
    """
    from energy_planner.planning.search import target_heuristics

    cost, grid = _setup(terrain, model, request, n_headings, box, anchor, speed)
    xys = np.asarray(xys, float).reshape(-1, 2)
    if isinstance(edges, list):  # strips of rows, in order
        edges = np.concatenate(edges)
    if edges is not None:
        return relaxed_heuristics(grid, edges, xys)
    return target_heuristics(cost, grid, xys)


def _relaxed_task(terrain, model, request, n_headings, box, anchor, speed, rows):
    cost, grid = _setup(terrain, model, request, n_headings, box, anchor, speed)
    return relaxed_table(cost, grid, rows)


def _edges_task(terrain, model, request, n_headings, box, anchor, speed, rows):
    from energy_planner.planning.search import edge_table

    cost, grid = _setup(terrain, model, request, n_headings, box, anchor, speed)
    return edge_table(cost, grid, rows)


def _rows_task(terrain, model, request, n_headings, box, anchor, speed, starts, targets, heur,
               max_energy, edges, eps, lazy):  # fmt: skip
    """The rows of ``starts``.

    ``heur``: the heuristics' rows, or their parts (:func:`_stack`); ``edges``: the
    shared edge table, or None; ``lazy``: one edge cache for these rows.
    """
    from energy_planner.planning.search import edge_cache

    cost, grid = _setup(terrain, model, request, n_headings, box, anchor, speed)
    heur = _stack(heur)
    cache = edge_cache(grid) if lazy else None
    return [_row(cost, grid, p, targets, heur, max_energy, eps, edges, cache) for p in starts]


def _row(cost, grid, start, targets, heur, max_energy, eps, edges=None, cache=None) -> tuple:
    """One site's row: ``(energy to each target, expanded, states_total, priced)``.

    :func:`~energy_planner.planning.search.targets_search` from ``start``, over the edge
    table ``edges`` or the edge cache ``cache`` if given.
    """
    from energy_planner.planning.search import targets_search

    r = targets_search(cost, grid, tuple(start), targets, heur, max_energy=max_energy,
                       edges=edges, eps=eps, cache=cache)  # fmt: skip
    return r.energy, r.expanded, r.states_total, r.priced


#: Rows of each batch between two exchanges of the batches' new edges (dask, lazy cache).
ROWS_PER_ROUND = 1

#: Per worker process: ``(token, batch) -> (cost, grid, (edges, done), seen)``, the state
#: of a batch's rows kept between its rounds (:func:`_round_task`).
_BATCHES: dict[tuple[str, int], tuple] = {}


def _round_task(terrain, model, request, n_headings, box, anchor, speed, starts, targets,
                heur, max_energy, eps, key, after, incoming):  # fmt: skip
    """One round of a batch's rows on its own edge cache, then its new edges.

    The batch's cost, grid and cache live in this process (:data:`_BATCHES`, ``key`` =
    ``(token, batch)``) from round to round. ``incoming``: the other batches' results of
    the previous round (their new edges: ``(states, rows of edges, priced bits)``),
    written into the cache first (:func:`~energy_planner.planning.search.merge_edges`),
    so no edge another batch priced before is priced again; ``after``: this batch's
    previous round (only its order matters). Returns the rows (as :func:`_rows_task`'s)
    and the states with edges this round priced, with their edges and priced bits.
    """
    from energy_planner.planning.search import _untouched, edge_cache, merge_edges

    if key not in _BATCHES:  # its first round: the heuristics' parts come with it
        cost, grid = _setup(terrain, model, request, n_headings, box, anchor, speed)
        cache = edge_cache(grid)
        _BATCHES[key] = (cost, grid, cache, _untouched(cache[1].size, np.uint32, zero=True),
                         _stack(heur))  # fmt: skip
    cost, grid, cache, seen, heur = _BATCHES[key]
    edges, done = cache
    for _, (idx, vals, bits) in incoming:  # the other batches' results
        merge_edges(cache, idx, vals, bits)
        seen[idx] = done[idx]
    rows = [_row(cost, grid, p, targets, heur, max_energy, eps, cache=cache) for p in starts]
    new = np.flatnonzero(done != seen)
    seen[new] = done[new]
    return rows, (new, edges[new], done[new])


def _stack(parts) -> np.ndarray:
    """The heuristics' rows from the per-batch parts (part ``b``: rows ``b::len(parts)``).

    An array is returned as it is.
    """
    if not isinstance(parts, list):
        return parts
    nb = len(parts)
    out = np.empty((sum(len(p) for p in parts), parts[0].shape[1]), np.float32)
    for b, part in enumerate(parts):
        out[b::nb] = part
    return out


def _drop_batches(token: str) -> int:
    """Free this process's batches of the matrix ``token``; how many there were."""
    keys = [k for k in _BATCHES if k[0] == token]
    for k in keys:
        del _BATCHES[k]
    return len(keys)


def _lazy_rounds(client, fixed, uxy, batches, heur_f, max_energy, eps) -> list:
    """The rows of ``batches`` on ``client``, in rounds that share the edges they price.

    Batch ``b`` runs on one worker thread (its cache stays in that process), its rows
    :data:`ROWS_PER_ROUND` at a time; each round of a batch first takes the edges the
    other batches priced in their previous round. Without this each batch's cache priced
    the states the others had priced (20 sites on the 2000² benchmark DEM, 2 batches:
    42.1 M edges priced against 35.4 M for one cache); now only the states two rows
    of the same round both reach are priced twice. Dependencies between the rounds'
    tasks order them on the workers (the edges move from worker to worker, not through
    the client). Returns each batch's rows, as :func:`_rows_task`'s.
    """
    import operator
    import uuid

    token = uuid.uuid4().hex
    slots = [a for a, k in sorted(client.nthreads().items()) for _ in range(k)]
    prev: list = [None] * len(batches)
    out: list[list] = [[] for _ in batches]
    k = ROWS_PER_ROUND
    try:
        for r in range(max(math.ceil(len(b) / k) for b in batches)):
            cur: list = [None] * len(batches)
            for b, batch in enumerate(batches):
                chunk = batch[r * k : (r + 1) * k]
                if chunk.size == 0:
                    continue
                incoming = [f for o, f in enumerate(prev) if o != b and f is not None]
                cur[b] = client.submit(_round_task, *fixed, uxy[chunk], uxy,
                                       heur_f if r == 0 else None, max_energy, eps,
                                       (token, b), prev[b], incoming,
                                       workers=[slots[b % len(slots)]],
                                       allow_other_workers=False, pure=False)  # fmt: skip
                out[b].append(client.submit(operator.getitem, cur[b], 0, pure=False,
                                            workers=[slots[b % len(slots)]]))  # fmt: skip
            prev = cur
        got = client.gather(out)
    finally:
        del prev, out
        client.run(_drop_batches, token)
    return [[row for rows in batch for row in rows] for batch in got]


#: The whole edge table only for at least this many sites (and several processes): the
#: rows of a few sites read a small share of the window's edges (3 sites on the bundled
#: hill at eps 1: 7 % of its states; 8, 20 and 40 sites: about half).
TABLE_MIN_SITES = 8


def _edge_mode(terrain, box, n_headings, edge_cache, eps, n_sites=2, n_caches=1) -> str:
    """How the searches get their edges: ``"table"``, ``"lazy"`` or ``"on demand"``.

    ``edge_cache`` True: the window's whole table; False: each search prices its own.
    Default: a cache filled as the searches go
    (:func:`~energy_planner.planning.search.edge_cache`: a state's edges priced when a
    search first expands it, shared by the next rows), which prices an edge by the
    table's kernel call but only for the states the rows expand. The rows of one cache
    never price more than the table, so one process (``n_caches == 1``) keeps the cache:
    on the bundled hill at eps 1, serial, the whole matrix took 4.4 CPU s against 27.8 s
    with the table for its 3 sites (the rows expand 7 % of the window's states), 6.5
    against 18.6 s for 8 sites, 9.6 against 24.4 s for 20 and 14.9 against 30.6 s for 40
    (about half the window), the same entries (measured when the cache priced a state's
    whole row at its first expansion; pricing each edge as a row first needs it only
    lowers the cache's side). On dask each batch of rows fills its own
    cache (``n_caches`` batches, pricing some states more than once) while the table is
    priced once by strips on every worker: there the table is kept for ``eps == 1`` and
    at least :data:`TABLE_MIN_SITES` sites when it fits (half the memory cap per
    process). With ``eps > 1`` the weighted searches expand narrow bands along the ways
    to the sites (a few % of the window's states per row on a large map), so most of a
    table would never be read.

    Examples
    --------
    >>> from energy_planner.terrain import Terrain
    >>> t = Terrain.from_array(np.zeros((20, 20)), resolution=1.0, origin=(0.0, 0.0))
    >>> box = (0.0, 0.0, 19.0, 19.0)
    >>> _edge_mode(t, box, 16, None, 1.0, n_sites=3), _edge_mode(t, box, 16, None, 1.0, 20, 1)
    ('lazy', 'lazy')
    >>> _edge_mode(t, box, 16, None, 1.0, 20, 2), _edge_mode(t, box, 16, None, 1.05, 20, 2)
    ('table', 'lazy')
    >>> _edge_mode(t, box, 16, True, 1.05), _edge_mode(t, box, 16, False, 1.0)
    ('table', 'on demand')
    """
    if edge_cache is not None:
        return "table" if edge_cache else "on demand"
    table = eps == 1.0 and n_caches >= 2 and n_sites >= TABLE_MIN_SITES
    return "table" if table and _table_fits(terrain, box, n_headings) else "lazy"


def _table_fits(terrain, box, n_headings) -> bool:
    from energy_planner.planning.search import EDGE_BYTES_PER_STATE
    from energy_planner.terrain.memory import resolve_cap

    cell = float(min(abs(terrain.grid[2]), abs(terrain.grid[3])))
    cells = ((box[2] - box[0]) / cell + 1) * ((box[3] - box[1]) / cell + 1)
    return cells * n_headings * EDGE_BYTES_PER_STATE <= 0.5 * resolve_cap()


def _run(terrain, model, request, uxy, n_headings, box, max_energy, client, progress,
         edge_cache, eps, speed=None, carry=None):  # fmt: skip
    """One pass: the matrix between the distinct positions ``uxy`` inside ``box``.

    ``carry``: a dict kept from pass to pass (serial, lazy cache): the previous pass's
    ``(grid, cache)`` seeds this pass's cache (:func:`_carry_cache`), and this pass's are
    left in it for the next.
    """
    anchor = tuple(map(float, uxy[0]))
    n = len(uxy)
    # one batch of rows per worker thread: each task builds the motion cost once
    nw = 1 if client is None else max(1, sum(client.nthreads().values()))
    nb = min(n, nw)
    mode = _edge_mode(terrain, box, n_headings, edge_cache, eps, n, nb)
    use_edges, lazy = mode == "table", mode == "lazy"
    carried = 0
    t0 = time.perf_counter()
    args = (n_headings, box, anchor, speed)
    if client is not None:
        from energy_planner.planning.search import search_grid

        ter_f, mod_f, req_f = client.scatter([terrain, model, request], broadcast=True, hash=False)
        # (the lattice's geometry does not read the cost)
        grid0 = search_grid(None, terrain, anchor, n_headings=n_headings, box=box)
        ny = grid0.ny
        cuts = np.linspace(0, ny, min(ny, 2 * nw) + 1).astype(int)
        rel_f = None
        if _relaxed_fits(grid0):  # the relaxed edges by strips of rows, shared by every site
            rel_f = [client.submit(_relaxed_task, ter_f, mod_f, req_f, *args, (a, b),
                                   pure=False)
                     for a, b in zip(cuts[:-1], cuts[1:], strict=True)]  # fmt: skip
        # the strips and the heuristics' rows stay on the workers: the tasks that read them
        # take them from the workers that made them, not through the client
        heur_f = [client.submit(_heuristic_task, ter_f, mod_f, req_f, *args, uxy[b::nb], rel_f,
                                pure=False) for b in range(nb)]  # fmt: skip
        from distributed import wait

        wait(heur_f)
        del rel_f
        t1 = time.perf_counter()
        edges_f, t_edges = None, 0.0
        if use_edges:  # priced by strips of rows on the workers, then shared by every row
            futs = [client.submit(_edges_task, ter_f, mod_f, req_f, *args, (a, b), pure=False)
                    for a, b in zip(cuts[:-1], cuts[1:], strict=True)]  # fmt: skip
            edges_f = client.scatter(np.concatenate(client.gather(futs)), broadcast=True,
                                     hash=False)  # fmt: skip
            del futs
            t_edges = time.perf_counter() - t1
        # one batch of rows per worker thread, each of neighbouring sites (_batches)
        batches = _batches(uxy, nb)
        if lazy:  # the batches' caches share their new edges after every round of rows
            got = _lazy_rounds(client, (ter_f, mod_f, req_f, *args), uxy, batches, heur_f,
                               max_energy, eps)  # fmt: skip
        else:
            futs = [client.submit(_rows_task, ter_f, mod_f, req_f, *args, uxy[b], uxy,
                                  heur_f, max_energy, edges_f, eps, lazy, pure=False)
                    for b in batches]  # fmt: skip
            got = client.gather(futs)
            del futs
        del heur_f, edges_f
        rows = [None] * n
        for b, res in zip(batches, got, strict=True):
            for i, r in zip(b, res, strict=True):
                rows[i] = r
    else:
        from energy_planner.planning import search
        from energy_planner.progress import track

        cost, grid = _setup(terrain, model, request, *args)
        cache = search.edge_cache(grid) if lazy else None
        if carry:  # (the previous pass's cache freed before the heuristics' arrays)
            old = carry.pop("pass")
            carried = 0 if cache is None else _carry_cache(*old, grid, cache)
            del old
        if _relaxed_fits(grid):  # the relaxed edges priced once for every site's Dijkstra
            heur = relaxed_heuristics(grid, relaxed_table(cost, grid), uxy)
        else:
            heur = search.target_heuristics(cost, grid, uxy)
        t1 = time.perf_counter()
        edges = search.edge_table(cost, grid) if use_edges else None
        t_edges = time.perf_counter() - t1
        rows = []
        for i in track(range(n), "matrix searches", progress or False, unit="site"):
            rows.append(_row(cost, grid, uxy[i], uxy, heur, max_energy, eps, edges, cache))
        if cache is not None and carry is not None:
            carry["pass"] = (grid, cache)
        del edges, cache
    E = np.array([r[0] for r in rows]).reshape(n, n)
    np.fill_diagonal(E, 0.0)
    return E, {
        "expanded": int(sum(r[1] for r in rows)),
        "states_total": int(sum(r[2] for r in rows)),
        "heuristic_s": t1 - t0,
        "search_s": time.perf_counter() - t1,
        "edge_table": use_edges,
        "edges": mode,
        "priced": int(sum(r[3] for r in rows)),
        "edge_table_s": t_edges if use_edges else 0.0,
        "carried": carried,
    }


def _carry_cache(old_grid, old_cache, grid, cache) -> int:
    """Copy the edges a previous pass priced into ``cache``: they are the same.

    Both lattices are cut from the one aligned on the first site (:func:`_run`), so a
    position of the old window is a position of the new one, shifted by whole steps. The
    kernel prices a motion on the whole terrain whatever the window, so an edge priced in
    the old window (a turn, or a translation that stayed in it: one that would leave it
    is never priced there) costs the same in the new one: every priced entry is copied
    with its bit (:func:`~energy_planner.planning.search.edge_cache`), and the others are
    priced when a search needs them.

    Returns
    -------
    int
        States whose edges were copied.
    """
    H = grid.H
    oi = int(round((old_grid.xs[0] - grid.xs[0]) / grid.step))
    oj = int(round((old_grid.ys[0] - grid.ys[0]) / grid.step))
    old = np.flatnonzero(old_cache[1])
    j, i = np.divmod(old // H, old_grid.nx)
    new = ((j + oj) * grid.nx + (i + oi)) * H + old % H
    cache[0][new] = old_cache[0][old]
    cache[1][new] = old_cache[1][old]
    return int(new.size)


def _batches(xy: np.ndarray, nb: int) -> list[np.ndarray]:
    """``nb`` runs of consecutive sites along the longer side of their bounding box.

    On a cluster each batch of rows fills its own edge cache (one per worker process):
    the searches from neighbouring sites expand much the same states on their ways to the
    others, so batches of neighbours price fewer edges twice than sites dealt in turn
    (20 sites on the 1000² benchmark DEM, 2 batches: 20 % more edges priced than one
    cache, against 40 % dealt in turn).

    Examples
    --------
    >>> [b.tolist() for b in _batches(np.array([[0.0, 0], [9, 1], [1, 2], [8, 0]]), 2)]
    [[0, 2], [3, 1]]
    """
    ax = int(np.argmax(np.ptp(xy, axis=0)))
    return [b for b in np.array_split(np.argsort(xy[:, ax], kind="stable"), nb) if b.size]


def window_proof(
    xy: np.ndarray, E: np.ndarray, c_min: float
) -> tuple[float, float, float, float] | None:
    """The box that holds every path that could beat ``E`` (None: some pair is unbounded).

    The union of the bounding boxes of the ellipses with foci ``xy[i]``, ``xy[j]`` and
    length ``E[i, j] / c_min`` (:func:`energy_planner.planning.corridor.ellipse_box`),
    over the pairs ``i != j``; None if a pair has no finite energy or ``c_min <= 0``.

    Examples
    --------
    >>> window_proof(np.array([[0.0, 0.0], [6.0, 0.0]]), np.array([[0, 10.0], [10.0, 0]]), 1.0)
    (-2.0, -4.0, 8.0, 4.0)
    """
    from energy_planner.planning.corridor import ellipse_box

    if not c_min > 0:
        return None
    lo, hi = np.array([np.inf, np.inf]), np.array([-np.inf, -np.inf])
    for i in range(len(xy)):
        for j in range(len(xy)):
            if i == j:
                continue
            if not math.isfinite(E[i, j]):
                return None
            b = ellipse_box(xy[i], xy[j], E[i, j] / c_min)
            lo = np.minimum(lo, b[:2])
            hi = np.maximum(hi, b[2:])
    return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))


#: :func:`_c_min` of the motions choosing their speed, by terrain (weakly), then model,
#: request and speed range: the bound leaves the price of a second out, so a mission within
#: a time budget prices it once for every ``lambda`` its bisection tries.
_C_MIN_RANGED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _c_min(terrain, model, request, n_headings, speed=None) -> float:
    from energy_planner.energy.kernels import IN_GRAD
    from energy_planner.planning.corridor import least_cost_per_metre

    if speed is not None:  # a bound over the speed range (and a time price only adds)
        from energy_planner.planning.search import kept_per_terrain

        return kept_per_terrain(
            _C_MIN_RANGED, terrain, model, request, (tuple(speed[0]),),
            lambda: _cost(terrain, model, request, speed).min_cost_per_metre, keep=8,
        )  # fmt: skip
    cost = _cost(terrain, model, request, speed)
    grad = cost.data[IN_GRAD]
    fin = np.isfinite(grad[..., 0]) & np.isfinite(grad[..., 1])
    if not fin.any():
        return 0.0
    lo = [float(grad[..., 0][fin].min()), float(grad[..., 1][fin].min())]
    hi = [float(grad[..., 0][fin].max()), float(grad[..., 1][fin].max())]
    return least_cost_per_metre(cost, lo, hi, n_headings)


def matrix_search(
    terrain,
    model,
    sites,
    request=None,
    *,
    n_headings: int = 16,
    max_energy: float | None = None,
    client: Any = None,
    window: bool = True,
    edge_cache: bool | None = None,
    eps: float = 1.0,
    progress: bool = False,
    speed: tuple[tuple[float, float], float] | None = None,
) -> MatrixResult:
    """Least energy between every ordered pair of sites, one early-stopped search per site.

    Parameters
    ----------
    terrain : Terrain
        The map.
    model : EnergyModel
        A fitted model.
    sites : Sites
        On cell centres (working CRS; :meth:`~energy_planner.mission.Sites.on_cells`).
    request : Request, optional
        Robot, limits, channels (as for ``plan``).
    n_headings : int
        Search headings.
    max_energy : float, optional
        Stop each search at this energy (J); farther sites read ``inf`` (and the window
        is then the whole map).
    client : distributed.Client, optional
        Run the heuristics and the searches on this dask cluster's workers.
    window : bool
        Search in a proven window around the sites (see the module); False: the whole map.
    edge_cache : bool, optional
        True: price every edge of the window once and share the prices between the
        sites' searches (72 bytes per state per process). False: each search prices its
        edges itself (the same kernel call). Default: a cache filled as the searches
        expand states, or on dask with ``eps = 1`` and many sites the table when it takes
        at most half the memory cap (:func:`energy_planner.terrain.memory.resolve_cap`;
        :func:`_edge_mode`).
    eps : float
        Heuristic weight >= 1 of every search (as ``plan``'s ``eps``): each entry is at
        most ``eps`` times the least energy between the two sites (1: the least energy;
        the plan's default :data:`~energy_planner.planning.plan.DEFAULT_EPS` expands
        far fewer states on a large map).
    progress : bool
        A progress bar over the sites on stderr (serial).
    speed : ((float, float), float), optional
        ``(speed_range, time_weight)``: each motion walks at its own speed in the range
        minimising energy + ``time_weight`` x time, and the entries are that sum
        (:meth:`~energy_planner.problem.Problem.with_speed`).

    Returns
    -------
    MatrixResult

    Raises
    ------
    InvalidStateError
        If a site is off the map or breaks a limit at every heading.
    PlanningConfigError
        If ``eps`` is below 1 or not finite.
    """
    from energy_planner.errors import PlanningConfigError
    from energy_planner.planning.limits import check_endpoint
    from energy_planner.planning.moves import terrain_extent
    from energy_planner.problem import Problem
    from energy_planner.request import Request

    if not (eps >= 1.0 and math.isfinite(eps)):
        raise PlanningConfigError(f"eps must be >= 1, got {eps!r}", value=eps, param="eps")
    request = Request() if request is None else request
    rc = sites.cells(terrain)
    prob = Problem(terrain, model, request)
    cost, geoms = prob.cost, prob.keep_out
    for x, y in sites.xy:
        check_endpoint(cost, terrain, "site", (float(x), float(y), None), geoms)
    del cost
    # sites sharing a cell share a row and a column (0 between them)
    _, first, inv = np.unique(rc, axis=0, return_index=True, return_inverse=True)
    inv = inv.reshape(-1)
    uxy = np.asarray(sites.xy, float)[first]
    cap = math.inf if max_energy is None else float(max_energy)
    xmin, xmax, ymin, ymax = terrain_extent(terrain)
    full = (xmin, ymin, xmax, ymax)
    c_min = _c_min(terrain, model, request, n_headings, speed) if window else 0.0
    box, proven, passes, stats, carry = full, True, 0, [], {}
    if window and c_min > 0 and math.isinf(cap) and len(uxy) > 1:
        cell = float(min(abs(terrain.grid[2]), abs(terrain.grid[3])))
        lo, hi = uxy.min(axis=0), uxy.max(axis=0)
        m = max(WINDOW_SHARE * float((hi - lo).max()), WINDOW_MIN_CELLS * cell)
        box = _clip((lo[0] - m, lo[1] - m, hi[0] + m, hi[1] + m), full)
        proven = box == full
    while True:
        E, st = _run(terrain, model, request, uxy, n_headings, box, cap, client, progress,
                     edge_cache, float(eps), speed, carry)  # fmt: skip
        passes += 1
        stats.append(st)
        if proven:
            break
        need = window_proof(uxy, E, c_min)
        if need is not None and _inside(need, box):
            proven = True
            break
        box = full if need is None else _clip(_union(need, box), full)
        proven = box == full or need is not None  # the grown window holds every ellipse
    carry.clear()
    out = E[np.ix_(inv, inv)]
    np.fill_diagonal(out, 0.0)
    info = {
        "window": [float(v) for v in box],
        "whole_map": box == full,
        "proven": bool(proven),
        "c_min_j_per_m": float(c_min),
        "passes": passes,
        "expanded": sum(s["expanded"] for s in stats),
        "states_total": stats[-1]["states_total"],
        "heuristic_s": sum(s["heuristic_s"] for s in stats),
        "search_s": sum(s["search_s"] for s in stats),
        "edge_table": stats[-1]["edge_table"],
        "edges": stats[-1]["edges"],
        "priced": sum(s["priced"] for s in stats),
        "edge_table_s": sum(s["edge_table_s"] for s in stats),
        "carried": sum(s["carried"] for s in stats),
    }
    return MatrixResult(out, info)


def _clip(b, full):
    return (max(b[0], full[0]), max(b[1], full[1]), min(b[2], full[2]), min(b[3], full[3]))


def _union(a, b):
    return (min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3]))


def _inside(inner, outer) -> bool:
    return (inner[0] >= outer[0] and inner[1] >= outer[1] and inner[2] <= outer[2]
            and inner[3] <= outer[3])  # fmt: skip
