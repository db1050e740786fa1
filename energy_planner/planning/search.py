"""Full-resolution search over (x, y, heading) with edges priced on demand.

The default planner. Positions lie on a square grid at the DEM's own cell size (or a given
``step``), aligned so that the start is a position; each position has ``n_headings``
headings. The motion primitives are those of the reference lattice
(:mod:`energy_planner.planning.lattice`): at each heading, translations at constant
heading to the 16 neighbours ``(1, 0), (2, 1), (1, 1), ...`` (``moves="all"``, the
default: the body may face any lattice heading while it travels in any lattice direction,
i.e. crab walking, which a model with a large fore-aft tilt cost prefers on steep slopes;
``moves="crab"``: the 8 neighbours closest to the body axes and their 45-degree
obliques; ``moves="axes"``: only the 4 closest to the body axes, forward, left, backward,
right), and turns in place to the next heading on either side. No graph is built: an edge is priced
by the motion kernel (:class:`energy_planner.energy.MotionCost`, the same numba function
that prices every other path) when the search first reaches it.

The search is A* with keys ``g + eps * h``. The heuristic ``h`` is the exact solution of a
relaxed problem solved once on the 2-D grid of positions (a backward search from the
goal): no turning, and every translation priced by a lower bound of its kernel cost over
all headings. The kernel prices a translation as a sum over its sub-steps (at each, the
gradient interpolated from the DEM); the bound takes the same sub-steps, each priced by
the project's one cheapest way to move along a heading
(:class:`energy_planner.energy.heading.HeadingCost`: the least energy per metre over every
body yaw, priced by the kernel's own gait cost) at that sub-step's own gradient, read
from a table over a grid of gradients for each move direction (:func:`bound_table`) by
bilinear interpolation. A 1 % margin covers the interpolation. Turns cost >= 0 (the
model's power is clipped at 0), so ``h`` never exceeds the search's cost to go: with
``eps = 1`` the path is optimal on these primitives (the same optimum as the full
lattice); with ``eps > 1`` its energy is at most ``eps`` times that optimum, and at most
``cost / h(start)`` times it (``info["certified"]``: the bound the run itself proves,
usually far below ``eps``).

Memory: one float32 ``g`` and one int8 code per state reached (5 bytes x headings per
position the search reaches: the arrays are allocated untouched and the operating system
maps a page only when the search first writes to it), the 2-D heuristic (float32 ``h``
and an int32 heap index per cell: 8 bytes per cell) and the open lists. All hot loops are
numba functions in :mod:`energy_planner.planning._search`, compiled once per energy model
and cached on disk.

Without a goal (:func:`reach_search`) the same search runs with ``h = 0`` (Dijkstra) and
returns the least energy to every position.
"""

from __future__ import annotations

import math
import os
import time
import weakref
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.angles import wrap
from energy_planner.energy.kernels import IN_BLOCKED, IN_DY, IN_GRAD, IN_STEP, IN_TMAX, IN_X0
from energy_planner.errors import InvalidStateError, PlanningConfigError, PlanningError
from energy_planner.planning.moves import MOVE_SETS, exact_ends  # noqa: F401 - MOVE_SETS: documented here too
from energy_planner.problem import takes_problem

__all__ = [
    "SearchResult",
    "ReachResult",
    "bound_table",
    "prune_bound_cache",
    "prepare_bound",
    "gradient_table",
    "relaxed_cost_to_go",
    "search_plan",
    "reach_search",
    "search_module",
    "search_grid",
    "target_heuristics",
    "targets_search",
    "TargetsResult",
    "edge_table",
    "edge_cache",
    "merge_edges",
    "EDGE_BYTES_PER_STATE",
]

_TEMPLATE = Path(__file__).with_name("_search.py")
_IMPORT_LINE = (
    "from energy_planner.energy._motion import motion_full as kernel  # --- kernel import ---"
)
#: Scale applied to every edge bound (covers the gradient table's spacing).
BOUND_MARGIN = 0.99
#: Nodes per axis of the gradient table.
TABLE_NODES = 96


#: The groups of numba functions :func:`search_module` loads before a clock starts:
#: ``path`` what :func:`search_plan` calls (the relaxed problem and the A*), ``all`` every
#: function (the multi-target, reach and edge-table searches too). Loading one from
#: numba's disk cache costs a few ms; a plan loads only its own.
KERNEL_GROUPS = ("path", "all")


def search_module(cost, kernels: str = "all"):
    """The numba search functions compiled against ``cost``'s motion kernel (cached).

    The functions of the group ``kernels`` (:data:`KERNEL_GROUPS`) are compiled (or
    loaded from numba's disk cache) here, by a call on a problem with nothing to do, so
    that a planner's time budget does not pay for it; the others load on first use.
    """
    from energy_planner.model._codegen import load_generated_module

    if kernels not in KERNEL_GROUPS:
        raise ValueError(f"unknown kernel group {kernels!r}; valid: {', '.join(KERNEL_GROUPS)}")
    if kernels == "path" and getattr(cost, "precompiled", False):
        aot = precompiled_search(cost)
        if aot is not None:
            return aot
    mod_name = cost.kernel.py_func.__module__
    # a cost that chooses its speed prices edges by motion_best (the fixed-speed search
    # keeps motion_full: its code and numbers are unchanged), one that chooses its gait
    # by gait_best (energy/_gait.py)
    fn = "motion_best" if getattr(cost, "ranged", False) else "motion_full"
    if getattr(cost, "gaits", ()):
        fn = "gait_best"
    if mod_name == "energy_planner.energy._motion" and fn == "motion_full":
        import energy_planner.planning._search as mod
    else:
        text = _TEMPLATE.read_text()
        assert _IMPORT_LINE in text, "the kernel import marker of _search.py is missing"
        text = text.replace(_IMPORT_LINE, f"from {mod_name} import {fn} as kernel")
        mod = load_generated_module(text, prefix="search")
    warm = getattr(mod, "_warm", set())
    for group in KERNEL_GROUPS[: KERNEL_GROUPS.index(kernels) + 1]:
        if group not in warm:
            _WARM_UP[group](mod, cost)
            warm.add(group)
    mod._warm = warm
    return mod


#: The functions of :func:`search_plan` (``search_module``'s ``path`` group) that a
#: precompiled search module holds (:func:`precompiled_search`).
PRECOMPILED_SEARCH = (
    "heuristic_chunk", "astar_chunk", "heap_push", "trace", "unsafe_cells", "cap_unsettled",
)  # fmt: skip
_PRECOMPILED: dict[str, Any] = {}  # the model's kernel source -> its functions


def precompiled_search(cost):
    """The search functions of a plan compiled ahead of time for ``cost``, or None.

    A plan on a small map spends more on loading numba (its import, its typing
    registries, the cached functions' index: about 0.4 s) than on its search. For a cost
    at a fixed speed and gait whose motion kernels are precompiled
    (:attr:`energy_planner.energy.MotionCost.precompiled`), the functions
    :data:`PRECOMPILED_SEARCH` are compiled by numba's ahead-of-time compiler from the
    same source as :func:`search_module`'s (the model's kernel module followed by
    ``_search.py``, its kernel ``motion_full``) into a C extension in the kernel cache,
    built once per machine and model (said on stderr) and then imported without numba.

    Returns
    -------
    namespace or None
        The functions and ``_search.py``'s constants (``START``, ``FOUND``, ...); None
        for a cost that chooses its speed or gait, or where the extension cannot be
        built (then :func:`search_module` loads the numba functions).
    """
    if getattr(cost, "ranged", False) or getattr(cost, "gaits", ()):
        return None
    ns = _PRECOMPILED.get(cost.source)
    if ns is not None:
        return ns
    from energy_planner.energy.kernels import motion_source
    from energy_planner.model._codegen import load_precompiled

    text = _TEMPLATE.read_text()
    assert _IMPORT_LINE in text, "the kernel import marker of _search.py is missing"
    text = (
        f"# precompiled: {', '.join(PRECOMPILED_SEARCH)}\n"
        + motion_source(cost.source)
        + "\n\n# --- the search (planning/_search.py), its kernel motion_full ---\n"
        + text.replace(_IMPORT_LINE, "kernel = motion_full")
    )
    build = os.environ.get("ENERGY_PLANNER_PRECOMPILE", "1") != "0"
    ext = load_precompiled(text, prefix="aotsearch", build=build, kind="search")
    if ext is None:
        return None
    from types import SimpleNamespace

    fns = {name: getattr(ext, name) for name in PRECOMPILED_SEARCH}
    ns = _PRECOMPILED[cost.source] = SimpleNamespace(**_search_constants(), **fns)
    return ns


def _search_constants() -> dict[str, int]:
    """The integer constants of ``_search.py`` (state codes, chunk return codes), read as text.

    A precompiled module holds functions only; reading the template's plain assignments
    keeps the one definition without importing numba.
    """
    import ast

    out: dict[str, int] = {}
    for node in ast.parse(_TEMPLATE.read_text()).body:
        if not (isinstance(node, ast.Assign) and len(node.targets) == 1):
            continue
        target, value = node.targets[0], node.value
        names = target.elts if isinstance(target, ast.Tuple) else [target]
        values = value.elts if isinstance(value, ast.Tuple) else [value]
        for n, v in zip(names, values, strict=False):
            if isinstance(n, ast.Name) and n.id.isupper() and isinstance(v, ast.Constant):
                out[n.id] = v.value
    return out


def _empty_work() -> tuple:
    """Arguments of a search with nothing to do: lattice, moves, heap, table, table geometry."""
    i8 = np.int64
    lat = np.array([0.0, 0.0, 1.0, 1.0, 1.0])
    heap = np.zeros(4), np.zeros(4, i8), np.zeros(1, i8)
    table = np.zeros((16, 2, 2), np.float32)
    return lat, np.zeros((16, 2), i8), heap, table, np.array([0.0, 0.0, 1.0, 1.0])


def _warm_up_path(mod, cost) -> None:
    """Call the numba functions of :func:`search_plan` once with empty work (compiles them)."""
    i8 = np.int64
    lat, moves, (keys, vals, n), table, tgeo = _empty_work()
    mod.heuristic_chunk(
        cost.data[IN_GRAD], cost.data[IN_BLOCKED], np.zeros((1, 1), np.uint8), _geo(cost),
        _sampling(cost), lat, moves,
        np.ones(16), table, tgeo, np.zeros(1, np.float32), np.zeros(1, np.int32), keys, vals,
        n, 0, 1.0, -1, 1.5, np.full(2, np.inf),
    )  # fmt: skip
    mod.astar_chunk(
        cost.data, lat, np.zeros(16), moves, np.zeros((16, 4), i8), np.zeros(16),
        np.zeros(1, np.float32), 1.0, np.zeros(16, np.float32), np.zeros(16, np.int8), -1, -1,
        keys, vals, n, 0, 0.0, np.zeros(1, i8),
    )  # fmt: skip
    mod.heap_push(keys, vals, n, 0.0, 0)
    mod.trace(np.full(16, mod.START, np.int8), moves, 1, 16, 0)
    mod.unsafe_cells(np.zeros((1, 1, 2)), np.zeros((0, 0), np.bool_), 1.0)
    mod.cap_unsettled(np.zeros(1, np.float32), np.zeros(1, np.int32), 1, 0, 0.0, 1.0, 1.0)


def _warm_up_rest(mod, cost) -> None:
    """Call the other numba functions of ``mod`` once with empty work (compiles them)."""
    i8 = np.int64
    lat, moves, (keys, vals, n), table, tgeo = _empty_work()
    mod.min_over_headings(np.zeros(16, np.float32), np.zeros(16, np.int8), 1, 16)
    mod.min_rows(np.zeros((1, 1), np.float32), np.zeros(1, i8), np.zeros(1))
    mod.rekey(keys, vals, np.zeros(1, i8), np.zeros(16, np.float32), np.zeros(16, np.int8),
              np.zeros(1), 16)  # fmt: skip
    mod.edge_costs(cost.data, lat, np.zeros(16), moves, np.zeros((16, 4), i8), 0, 0,
                   np.zeros((0, 6), np.float32))  # fmt: skip
    mod.astar_cached_chunk(
        np.zeros((16, 6), np.float32), lat, 16, moves, np.zeros((16, 4), i8), np.zeros(1),
        np.zeros(16, np.float32), np.zeros(16, np.int8), -1, keys, vals, n, 0, 0.0,
    )  # fmt: skip
    mod.edge_bound(cost.data[IN_GRAD], *_geo(cost), 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, table,
                   np.zeros(16), 0, *tgeo)  # fmt: skip
    mod.astar_lazy_chunk(
        cost.data, lat, np.zeros(16), moves, np.zeros((16, 4), i8), np.zeros(16), np.zeros(1),
        np.zeros(16, np.float32), np.zeros(16, np.int8), -1, keys, vals, n, 0, 0.0,
        np.zeros((16, 6), np.float32), np.zeros(16, np.uint32),
    )  # fmt: skip


#: group of :data:`KERNEL_GROUPS` -> the warm-up that loads its functions
_WARM_UP = {"path": _warm_up_path, "all": _warm_up_rest}


@dataclass
class SearchResult:
    """A path found by the full-resolution search.

    Attributes
    ----------
    states : ndarray, shape (n, 3)
        ``x, y, yaw`` (working CRS, radians) from the exact start to the exact goal;
        collinear steps at the same heading merged.
    cost : float
        The search's cost of the lattice part, J.
    step : float
        Position spacing, m.
    n_headings : int
        Headings per position.
    eps : float
        Heuristic weight; the energy is at most ``eps`` times the optimum on the
        primitives.
    expanded, priced : int
        States expanded and edges priced by the search.
    states_total : int
        Positions x headings.
    heuristic_s, search_s : float
        Wall time of the relaxed problem and of the search, s.
    info : dict
        Lower bound ``h`` at the start (``h_start``, J: no path on the primitives costs
        less), ``certified`` (``cost / h_start``: the path's cost is at most this times
        the optimum, whatever ``eps``) and other details.
    """

    states: np.ndarray
    cost: float
    step: float
    n_headings: int
    eps: float
    expanded: int
    priced: int
    states_total: int
    heuristic_s: float
    search_s: float
    info: dict = field(default_factory=dict)


@dataclass
class ReachResult:
    """Least energy from a start to every position (min over headings).

    Attributes
    ----------
    xs, ys : ndarray
        Position coordinates (working CRS, increasing).
    energy : ndarray, shape (len(ys), len(xs))
        Least energy in J to reach each position (row ``j`` is ``ys[j]``, so row 0 is the
        south edge); ``inf`` where unreachable (or above ``max_energy``).
    step : float
    n_headings : int
    expanded : int
    time_s : float
    tree : dict or None
        With ``reach_search(..., tree=True)``: the least-energy paths to every reached
        position as a tree of states (:func:`energy_planner.planning._pathtree.path_tree`):
        ``states`` (``p * n_headings + h``, each after its parent), ``parent`` (index in
        ``states``, -1 at a start state), ``at`` (per position, row-major over
        ``energy``, the index of its least-energy state, -1 where unreached), ``xs``,
        ``ys`` and ``headings`` (rad) to turn a state into a pose.
    priced : int
        Edges priced by the kernel.
    """

    xs: np.ndarray
    ys: np.ndarray
    energy: np.ndarray
    step: float
    n_headings: int
    expanded: int
    time_s: float
    tree: dict | None = None
    priced: int = 0


class _Grid:
    """Lattice geometry, headings and primitives of one search."""

    def __init__(self, cost, terrain, start_xy, step, n_headings, moves):
        from energy_planner.planning.moves import (
            MOVES_16,
            check_headings,
            check_moves,
            lattice_geometry,
            lattice_headings,
            move_table,
        )

        check_moves(moves)
        check_headings(n_headings)
        cell = float(min(abs(terrain.grid[2]), abs(terrain.grid[3])))
        step = cell if step is None else float(step)
        if not (math.isfinite(step) and step > 0):
            raise PlanningConfigError(
                f"step must be a positive number of metres, got {step!r}", value=step,
                param="step",
            )  # fmt: skip
        self.step = step
        self.xs, self.ys = lattice_geometry(terrain, start_xy, step)
        self.nx, self.ny = len(self.xs), len(self.ys)
        self.H = int(n_headings)
        self.headings = np.ascontiguousarray(wrap(lattice_headings(self.H)), dtype=np.float64)
        self.moves = np.ascontiguousarray(MOVES_16, dtype=np.int64)
        self.move_len = np.hypot(self.moves[:, 0], self.moves[:, 1]).astype(np.float64)
        self.move_ok = move_table(lattice_headings(self.H), moves)
        k = int(self.move_ok.sum(axis=1).max())
        mo = np.full((self.H, k), -1, dtype=np.int64)
        for h in range(self.H):
            idx = np.nonzero(self.move_ok[h])[0]
            mo[h, : len(idx)] = idx
        self.moves_of = mo
        self.lat = np.array([self.xs[0], self.ys[0], step, self.nx, self.ny], dtype=np.float64)
        self.P = self.nx * self.ny

    def position(self, x: float, y: float, which: str) -> int:
        i = int(round((x - self.xs[0]) / self.step))
        j = int(round((y - self.ys[0]) / self.step))
        if not (0 <= i < self.nx and 0 <= j < self.ny):
            raise InvalidStateError(
                f"{which} ({x:.2f}, {y:.2f}) is outside the map (positions x "
                f"{self.xs[0]:.2f}..{self.xs[-1]:.2f}, y {self.ys[0]:.2f}..{self.ys[-1]:.2f} in "
                "the working CRS)",
                endpoint=which,
                limit="map",
                value=(x, y),
            )
        return j * self.nx + i

    def xy(self, p: int) -> tuple[float, float]:
        j, i = divmod(int(p), self.nx)
        return float(self.xs[i]), float(self.ys[j])

    def heading_index(self, yaw: float) -> int:
        return int(np.argmin(np.abs(wrap(self.headings - float(yaw)))))


#: The bound tables of each cost (:func:`bound_table`), as long as the cost lives.
_TABLES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def bound_table(cost, headings: np.ndarray, move_ok: np.ndarray, nodes: int = TABLE_NODES):
    """Least J per map metre of each move direction at each node of a grid of gradients.

    For every gradient ``(gx, gy)`` on a ``nodes x nodes`` grid spanning the terrain's
    gradients (clipped to the slope limit), and every move direction ``m`` of
    :data:`~energy_planner.planning.lattice.MOVES_16` that some heading may make
    (``move_ok``), the cheapest way to move in that direction on ground of that gradient
    over every body yaw the gait limits allow
    (:class:`energy_planner.energy.heading.HeadingCost`, its table looked up bilinearly:
    the energy map's ``best``). The search's edge bound (:func:`_search.edge_bound`)
    interpolates it bilinearly at each sample of a motion, and scales the sum by
    :data:`BOUND_MARGIN` (which covers both interpolations; the kernel is checked to be
    above it in ``tests/test_planning_search.py``).

    Returns
    -------
    table : ndarray of float32, shape (16, nodes, nodes)
        J per metre (rounded down), ``inf`` where no heading can move (limits) or the node
        is steeper than the slope limit by more than one node diagonal (the nodes just
        past it, which a walkable sample's lookup reads, hold the physics' value there:
        :func:`_past_the_limit`).
    tgeo : ndarray
        ``(gx of node 0, gy of node 0, gx spacing, gy spacing)``.
    """
    # each cost keeps its tables: a plan prices them before its clock (prepare_bound),
    # then in its search, and a reach for its move bounds; a cost that chooses its speed
    # takes the least over its speeds' tables (each read from the cache) and a pass over
    # the map's gradients (about 0.1 s on 1600^2), one at a fixed speed its grid's memo
    # hit and the heading cost's parameters (about 5 ms)
    try:
        kept = _TABLES.setdefault(cost, {})
    except TypeError:  # a cost that cannot be weakly referenced: computed each time
        kept = None
    key = (np.asarray(headings).tobytes(), np.asarray(move_ok).tobytes(), int(nodes))
    if kept is not None and key in kept:
        return tuple(a.copy() for a in kept[key])
    out = _bound_table(cost, headings, move_ok, nodes)
    if kept is not None:
        kept[key] = tuple(a.copy() for a in out)
    return out


def _bound_table(cost, headings: np.ndarray, move_ok: np.ndarray, nodes: int):
    """:func:`bound_table`, computed (each speed node's bands from :func:`_node_bands`)."""
    from energy_planner.planning.moves import MOVES_16

    parts = _node_bands(cost, nodes)
    if parts is None:  # rasters that the table cannot bound: the heuristic is 0
        zero = np.zeros((len(MOVES_16), 2, 2), np.float32)
        return zero, np.array([-1e6, -1e6, 2e6, 2e6])
    tgeo, per_node, ratio = parts
    lam = float(getattr(cost, "time_weight", 0.0))
    table = np.full((len(MOVES_16), nodes, nodes), np.inf)
    for speed, best in per_node:
        if lam > 0:  # a map metre lasts at least 1 / v s: its price is part of the bound
            best = best + np.float32(lam / speed)
        table = np.minimum(table, best)
    if len(per_node) > 1:  # the least between the speed nodes (the widest spacing of any gait)
        law = getattr(cost, "speed_law", None)
        exps = law.exponents if law is not None and law.polynomial else (-2, 2)
        table = table * (1.0 - speed_dip(ratio, (*exps, -1)))
    table[np.isnan(table)] = np.inf  # the nodes left out above
    table[~move_ok.any(axis=0)] = np.inf
    table = np.maximum(table, 0.0)
    # float32, each value rounded down so that it stays a lower bound
    t32 = table.astype(np.float32)
    up = t32.astype(np.float64) > table
    t32[up] = np.nextafter(t32[up], np.float32(-np.inf))
    return np.ascontiguousarray(t32), tgeo


#: :func:`_node_bands` of costs that choose their speed, by terrain (weakly), then model,
#: request, speed range and nodes: the bands leave the price of a second out (it only adds
#: ``lambda / v`` at each node), so the plans of a deadline's or a time budget's bisection,
#: each at its own ``lambda``, price them once.
_RANGED_NODES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _node_bands(cost, nodes: int):
    """``(tgeo, [(speed, best)], ratio)`` of :func:`bound_table`, without the time price.

    ``best``: the least J per map metre at one speed node of :func:`bound_speeds`
    (float32, ``(16, nodes, nodes)``, NaN at the nodes left out); ``ratio``: the widest
    spacing of the speed nodes. None where channel rasters leave the heuristic at 0.
    A cost that chooses its speed, made by a :class:`~energy_planner.problem.Problem`
    (its ``request``), reads them from :data:`_RANGED_NODES` at any ``lambda``.
    """
    request = getattr(cost, "request", None)
    if not (getattr(cost, "ranged", False) and request is not None):
        return _node_bands_computed(cost, nodes)
    return kept_per_terrain(
        _RANGED_NODES, cost.terrain, cost.model, request, (tuple(cost.speed_range), int(nodes)),
        lambda: _node_bands_computed(cost, nodes), keep=4,
    )  # fmt: skip


def kept_per_terrain(store: weakref.WeakKeyDictionary, terrain, model, request, extra: tuple,
                     compute, keep: int):  # fmt: skip
    """``compute()``, kept in ``store`` by terrain (weakly), model, request and ``extra``.

    The model and request are kept themselves beside their ids (so an id is never
    another object's), and each terrain keeps its last ``keep`` entries: the bounds of a
    speed range that leave the price of a second out, read again at every ``lambda`` of a
    deadline's or a time budget's bisection.
    """
    kept = store.setdefault(terrain, {})
    key = (id(model), id(request), *extra)
    hit = kept.get(key)
    if hit is not None and hit[0] is model and hit[1] is request:
        return hit[2]
    out = compute()
    kept[key] = (model, request, out)
    while len(kept) > keep:
        kept.pop(next(iter(kept)))
    return out


def _node_bands_computed(cost, nodes: int):
    """:func:`_node_bands`, computed."""
    from energy_planner.energy.heading import TABLE_TOP_DEG, HeadingCost
    from energy_planner.planning.moves import MOVES_16

    grad = cost.data[IN_GRAD]
    gx = grad[..., 0]
    gy = grad[..., 1]
    fin = np.isfinite(gx) & np.isfinite(gy)
    combos = None
    if getattr(getattr(cost, "channels", None), "rasters", None):
        # categorical channel rasters: the least over the combinations of categories on
        # the map (a sample reads its nearest cell's); numeric ones (or too many
        # combinations) vary too freely for the table: the heuristic is 0 (the search
        # is then Dijkstra: slower, still optimal)
        combos = _raster_combinations(cost)
        if combos is None:
            return None
    if not fin.any():
        raise PlanningError("the terrain has no valid gradient (all nodata)")
    # reductions under a mask (gx[fin] would copy the whole raster)
    lo = np.array([float(np.min(v, where=fin, initial=np.inf)) for v in (gx, gy)])
    hi = np.array([float(np.max(v, where=fin, initial=-np.inf)) for v in (gx, gy)])
    del fin
    heading = HeadingCost.of_motion_cost(cost)
    lo, hi, tgeo = _table_grid(lo, hi, heading.tmax, nodes)
    GX, GY = np.meshgrid(lo[0] + tgeo[2] * np.arange(nodes), lo[1] + tgeo[3] * np.arange(nodes),
                         indexing="ij")  # fmt: skip
    dirs = np.arctan2(MOVES_16[:, 1], MOVES_16[:, 0])
    along = np.empty((len(MOVES_16), nodes, nodes), np.float32)
    nodes_by_gait = bound_speeds(cost)
    top = TABLE_TOP_DEG
    n_nodes = sum(len(speeds) for _, speeds in nodes_by_gait)
    if n_nodes > 1:
        # a sample's gradient is a convex combination of cells' gradients: nodes steeper
        # than the steepest cell by two spacings are never read by the bilinear lookup, so
        # they are left inf (edge_bound then takes the table's least: still a bound)
        gmax = float(np.nanmax(np.hypot(gx, gy))) + 2.0 * max(tgeo[2], tgeo[3])
        far = np.hypot(GX, GY) > gmax
        GX, GY = np.where(far, np.nan, GX), np.where(far, np.nan, GY)
        # the others from heading tables that reach them (computed once per machine,
        # model and speed, as the kernels), not by the exact minimum at each node of
        # each map at each speed, which was most of a plan's time on steep ground
        top = max(TABLE_TOP_DEG, min(RANGED_TOP_MAX_DEG, RANGED_TOP_STEP_DEG * math.ceil(
            (math.degrees(math.atan(gmax)) + 1.0) / RANGED_TOP_STEP_DEG)))  # fmt: skip
    per_node = []
    for gait, speeds in nodes_by_gait:
        for speed in speeds:
            if gait is None and speed == heading.speed and top == TABLE_TOP_DEG:
                hc = heading
            else:  # gait None: the cost's own channels
                hc = HeadingCost.of_motion_cost(cost, speed=speed, gait=gait, top_deg=top)
            best = _best_bands(hc, GX, GY, dirs, along, combos)
            _past_the_limit(hc, GX, GY, dirs, along, best, tgeo, combos)
            per_node.append((float(speed), best))
    ratio = max((float(s[1] / s[0]) for _, s in nodes_by_gait if len(s) > 1), default=1.0)
    return tgeo, per_node, ratio


def _past_the_limit(hc, GX: np.ndarray, GY: np.ndarray, dirs: np.ndarray, along: np.ndarray,
                    best: np.ndarray, tgeo: np.ndarray, combos=None) -> None:  # fmt: skip
    """Give ``best``'s nodes just past the slope limit the physics' value there (in place).

    A walkable sample (gradient within the limit ``hc.tmax``) reads the four nodes of its
    table cell, and near the limit some of them lie past it, where ``hc`` says ``inf``
    (nothing can stand there): :func:`_search.edge_bound` then priced the sample at the
    table's least (``tmin``, the cheapest ground anywhere, downhill), and on a climb
    that runs along the limit the heuristic fell far below the cost (on the bundled
    hill with a 40-degree limit ``h(start)`` was 0.67 of the path's cost and the search
    expanded half of the map's 634 000 states). The nodes a walkable sample can read
    (within one cell diagonal past the limit) now hold the same heading cost without
    the slope limit: the least J per metre of the same model, speed, cross-slope and
    gait limits at that gradient. The slope limit changes nothing of the energy of a
    walkable sample, only whether the kernel refuses a steeper one, so between those
    nodes the bilinear value approximates the sample's true least as everywhere else
    in the table (its error is what :data:`BOUND_MARGIN` covers); samples past the
    limit are still ``inf`` in the bound (``edge_bound`` checks ``tmax`` itself).
    Nodes past the limit farther out are never read by a walkable sample: they stay
    ``inf``, and the table's least (``tmin``) is unchanged. ``combos``: as
    :func:`_best_bands`.
    """
    tmax = float(hc.tmax)
    if not math.isfinite(tmax):
        return
    with np.errstate(invalid="ignore"):
        g = np.hypot(GX, GY)
        ring = (g > tmax) & (g <= tmax + math.hypot(tgeo[2], tgeo[3]))
    if not ring.any():
        return
    from energy_planner.energy.heading import _cached

    params = hc.params
    free = _cached(params[0], params[1], math.inf, *params[3:])  # the same, no slope limit
    nan = np.full(GX.shape, np.nan)
    past = _best_bands(free, np.where(ring, GX, nan), np.where(ring, GY, nan), dirs, along,
                       combos)  # fmt: skip
    best[:, ring] = past[:, ring]


#: Least J per map metre over the body's yaw (``best``) of the bound's gradient grids,
#: by :func:`_best_key`: plans on one map with one model (a mission's legs, the deadline's
#: bisection, a Pareto sweep, later commands) price its grid once. Kept in this process
#: (the last :data:`_BEST_MEMO_SIZE`) and in the kernel cache folder.
_BEST_MEMO: dict[str, np.ndarray] = {}
_BEST_MEMO_SIZE = 32


#: The most combinations of categorical channel rasters' values the bound takes the least
#: over (:func:`_raster_combinations`); with more, the heuristic is 0.
MAX_RASTER_COMBINATIONS = 16


#: :func:`_raster_combinations` of each cost, as long as the cost lives (a plan prices its
#: bound before its clock and again in its search).
_COMBOS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _raster_combinations(cost) -> tuple[tuple[float, ...], ...] | None:
    """The combinations of the cost's channel rasters' values met on its map.

    Each a tuple of the rasters' values (category indices) at one cell, every raster
    defined there, in lexicographic order; a motion's sample reads its nearest cell's
    categories (:func:`energy_planner.energy.kernels.sample_channels`), so it costs at
    least the least over these. None where a raster is numeric (sampled bilinearly, any
    value between its cells'), none has a value anywhere, or there are more than
    :data:`MAX_RASTER_COMBINATIONS`.
    """
    try:
        return _COMBOS[cost]
    except (KeyError, TypeError):
        pass
    out = _combinations_met(cost)
    try:
        _COMBOS[cost] = out
    except TypeError:  # a cost that cannot be weakly referenced: computed each time
        pass
    return out


def _combinations_met(cost) -> tuple[tuple[float, ...], ...] | None:
    """:func:`_raster_combinations`, computed."""
    from energy_planner.energy.kernels import IN_CHAN, IN_NEAREST

    n = len(cost.channels.rasters)
    chan, nearest = cost.data[IN_CHAN][:n], np.asarray(cost.data[IN_NEAREST][:n])
    if n == 0 or len(nearest) < n or not nearest.all():
        return None
    flat = chan.reshape(n, -1)
    fin = np.isfinite(flat).all(axis=0)
    if not fin.any():
        return None
    combos = np.unique(flat[0, fin]) if n == 1 else np.unique(flat[:, fin], axis=1).T
    if len(combos) > MAX_RASTER_COMBINATIONS:
        return None
    return tuple(tuple(float(v) for v in np.atleast_1d(c)) for c in combos)


def _best_key(hc, GX: np.ndarray, GY: np.ndarray, dirs: np.ndarray, combos=None) -> str:
    """The cache key of ``hc``'s ``best`` bands on the gradient grid ``GX, GY``."""
    import hashlib

    h = hashlib.sha256(hc._key().encode())
    if combos is not None:
        h.update(repr(combos).encode())
    for arr in (GX, GY, dirs):
        h.update(np.ascontiguousarray(arr, dtype=np.float64).tobytes())
    return h.hexdigest()[:24]


def _best_bands(hc, GX: np.ndarray, GY: np.ndarray, dirs: np.ndarray, along: np.ndarray,
                combos=None):  # fmt: skip
    """``hc``'s ``best`` bands (float32, ``(len(dirs),) + GX.shape``) on a gradient grid.

    ``combos``: the channel rasters' combinations of values (:func:`_raster_combinations`)
    where ``hc`` reads rasters: the least over them.

    Computed by :meth:`~energy_planner.energy.heading.HeadingCost.map_bands` once per
    physics (model, speed, limits, channel values) and grid, then read from
    :data:`_BEST_MEMO` or the kernel cache folder (``bound_<key>.npy``): the values are
    the same bit for bit, and the nodes steeper than the heading table (computed by the
    exact minimum, most of the time of a table) are paid once per map and model. The
    folder keeps the most recently used tables (:func:`prune_bound_cache`).
    """
    from energy_planner.io import atomic_path
    from energy_planner.model._codegen import cache_dir

    key = _best_key(hc, GX, GY, dirs, combos)
    hit = _BEST_MEMO.get(key)
    if hit is None:
        path = cache_dir() / f"bound_{key}.npy"
        try:
            arr = np.load(path, allow_pickle=False)
            if arr.shape == along.shape and arr.dtype == np.float32:
                hit = arr
                path.touch()  # recently used: kept by the pruning below
        except (OSError, ValueError):
            pass
    if hit is None:
        best = np.empty_like(along)
        if combos is None:
            hc.map_bands(GX, GY, np.zeros((0,) + GX.shape), dirs, along, best)
        else:
            one = np.empty_like(along)
            best.fill(np.inf)
            for values in combos:  # a node left out (NaN) stays NaN
                chan = np.stack([np.full(GX.shape, v) for v in values])
                hc.map_bands(GX, GY, chan, dirs, along, one)
                best = np.minimum(best, one)
        hit = best
        try:
            with atomic_path(path) as tmp, open(tmp, "wb") as f:
                np.save(f, hit)
            prune_bound_cache(path.parent)
        except OSError:
            pass  # the cache is an optimisation only
    _BEST_MEMO[key] = hit
    while len(_BEST_MEMO) > _BEST_MEMO_SIZE:
        _BEST_MEMO.pop(next(iter(_BEST_MEMO)))
    return hit.copy()


def prepare_bound(problem, start, step=None, n_headings: int = 16, moves: str = "all") -> None:
    """Price the search's bound tables of ``problem`` now (kept in this process and on disk).

    :func:`search_plan` then reads them: time-budgeted callers call this before their
    clock starts, as they compile the kernels, so that a cold cache (a speed range's heading
    tables, built once per machine) does not eat the budget and change the plan.
    """
    grid = _Grid(problem.cost, problem.terrain, (start[0], start[1]), step, n_headings, moves)
    bound_table(problem.cost, grid.headings, grid.move_ok)


#: The bound tables kept on disk (``bound_*.npy`` in the kernel cache folder): the most
#: recently used this many (each ``16 x TABLE_NODES^2`` float32, 0.6 MB: 38 MB in all) ...
BOUND_CACHE_FILES = 64
#: ... and at most this many bytes.
BOUND_CACHE_BYTES = 64 * 2**20


def prune_bound_cache(folder: Path, keep: int | None = None, max_bytes: int | None = None) -> int:
    """Delete the least recently used bound tables of ``folder`` beyond the cache's limits.

    Keeps the ``keep`` (default :data:`BOUND_CACHE_FILES`) most recently used
    ``bound_*.npy`` files (a read touches its file), and of those at most ``max_bytes``
    (default :data:`BOUND_CACHE_BYTES`). A file another process removes first is skipped.
    Returns the number of files deleted.

    Examples
    --------
    >>> import os, tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> for k in range(5):
    ...     f = d / f"bound_{k}.npy"
    ...     _ = f.write_bytes(b"x" * 10)
    ...     os.utime(f, (k, k))
    >>> prune_bound_cache(d, keep=3), sorted(p.name for p in d.iterdir())
    (2, ['bound_2.npy', 'bound_3.npy', 'bound_4.npy'])
    >>> prune_bound_cache(d, max_bytes=15), sorted(p.name for p in d.iterdir())
    (2, ['bound_4.npy'])
    """
    keep = BOUND_CACHE_FILES if keep is None else keep
    max_bytes = BOUND_CACHE_BYTES if max_bytes is None else max_bytes
    files = []
    for f in Path(folder).glob("bound_*.npy"):
        try:
            st = f.stat()
        except OSError:
            continue
        files.append((st.st_mtime, st.st_size, f))
    files.sort(key=lambda t: t[0], reverse=True)  # newest first
    total, gone = 0, 0
    for k, (_, size, f) in enumerate(files):
        total += size
        if k >= keep or total > max_bytes:
            f.unlink(missing_ok=True)
            gone += 1
    return gone


#: The heading tables of a cost that chooses its speed reach the terrain's steepest
#: gradient node (and one degree more), rounded up to this step (degrees: maps share
#: tables), ...
RANGED_TOP_STEP_DEG = 5.0
#: ... and at most this (degrees; steeper nodes take the exact minimum).
RANGED_TOP_MAX_DEG = 85.0


#: Speeds of a cost that chooses its speed over which the search's bound is the least
#: (geometric over the range, ends included; where the motions choose their gait, no
#: further apart in ratio than these over the gaits' whole range).
SPEED_BOUND_NODES = 7


def bound_speeds(cost) -> list[tuple[str | None, np.ndarray]]:
    """The (gait, speeds) whose tables :func:`bound_table` takes the least of.

    A fixed-speed cost: gait ``None`` at its nominal speed. A cost that chooses its speed:
    :data:`SPEED_BOUND_NODES` speeds spread geometrically over its range (gait ``None``,
    the cost's own channels). With a time price ``lambda`` the bound at each speed adds
    ``lambda / v`` (a map metre lasts at least ``1 / v``), so that a dear second keeps the
    heuristic as tight as a free one. Between two nodes the energy per metre may dip below
    both: :func:`speed_dip` scales the least over the nodes down by that dip.

    Where the motions also choose their gait (:attr:`~energy_planner.energy.MotionCost.
    gaits`): each gait at node speeds over its own range (:attr:`~energy_planner.energy.
    MotionCost.gait_ranges`), no further apart than :data:`SPEED_BOUND_NODES` over the
    whole range (at least 3 per gait). One table per speed range, its top speed's shifted
    down by what the speed terms can save, was tried: it is looser (on the bundled hill
    the speed-choosing plan took 4.35 s against about 1 s; with ``b1_speeds``, one shifted
    table per gait, 8.4 s against 1.0 s).
    """
    rng = getattr(cost, "speed_range", None)
    if rng is None:
        return [(None, np.array([cost.speed]))]
    ranges = getattr(cost, "gait_ranges", None) if getattr(cost, "gaits", ()) else None
    if not ranges:
        return [(None, np.geomspace(rng[0], rng[1], SPEED_BOUND_NODES))]
    lo_all = min(lo for lo, _ in ranges.values())
    span = math.log(max(hi for _, hi in ranges.values()) / lo_all)
    out = []
    for g, (lo, hi) in ranges.items():
        share = math.log(hi / lo) / span if span > 0 else 0.0
        n = max(3, math.ceil((SPEED_BOUND_NODES - 1) * share - 1e-9) + 1)
        out.append((g, np.geomspace(lo, hi, n)))
    return out


def speed_dip(ratio: float, exponents) -> float:
    """How far below both ends a metre's cost may dip between two speeds ``ratio`` apart.

    A motion's energy per metre at ground speed ``v`` is a Laurent polynomial ``sum_d
    c_d v^d`` (:mod:`energy_planner.energy.speed`; the time price adds ``lambda / v``),
    whose terms of degree other than 0 have ``c_d >= 0`` (standing and copper power per
    second, swing losses). Between speeds ``v`` and ``ratio x v`` its least may lie below
    the lesser end: the most, as a fraction of that end, for the family ``v^dmin + D
    v^dmax`` of the extreme exponents ``dmin < 0 < dmax`` with equal ends (none when the
    exponents are all of one sign: the cost is then monotone).

    Examples
    --------
    >>> round(speed_dip(1.468, (-1, 0, 1)), 4)  # 7 nodes over 0.2-2 m/s: 1.8 %
    0.0181
    >>> speed_dip(1.5, (-1, 0))
    0.0
    """
    dmin, dmax = float(min(exponents)), float(max(exponents))
    q = float(ratio)
    if not (dmin < 0 < dmax) or q <= 1.0:
        return 0.0
    d = (1.0 - q**dmin) / (q**dmax - 1.0)  # ends equal: 1 + d = q^dmin + d q^dmax
    r = (-dmin / (d * dmax)) ** (1.0 / (dmax - dmin))  # the least of r^dmin + d r^dmax
    return max(0.0, 1.0 - (r**dmin + d * r**dmax) / (1.0 + d))


def _table_grid(lo: np.ndarray, hi: np.ndarray, tmax: float, nodes: int):
    """The gradient grid of a table: ``lo .. hi`` clipped to ``+-tmax``, 1 % wider."""
    lo = np.asarray(lo, dtype=np.float64).copy()
    hi = np.asarray(hi, dtype=np.float64).copy()
    if math.isfinite(tmax):
        lo = np.maximum(lo, -tmax)
        hi = np.minimum(hi, tmax)
    span = np.maximum(hi - lo, 1e-6)
    lo = lo - 0.01 * span
    hi = hi + 0.01 * span
    tdx, tdy = (hi - lo) / (nodes - 1)
    return lo, hi, np.array([lo[0], lo[1], tdx, tdy], dtype=np.float64)


def gradient_table(
    cost,
    headings: np.ndarray,
    move_ok: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    nodes: int = TABLE_NODES,
) -> tuple[np.ndarray, np.ndarray]:
    """Least J per metre of each move direction over a box of constant gradients.

    For any gradient box ``lo .. hi`` (``(gx, gy)`` m/m, east and north), clipped to the
    slope limit of ``cost``. Each node holds the cheapest way to move in the move's
    direction on ground of that gradient, over every body yaw the gait limits allow
    (:class:`energy_planner.energy.heading.HeadingCost`, its lower bound: below the
    kernel's energy of any translation there at any heading, so also below the lattice
    headings that may make the move), then the least over the 3 x 3 neighbouring nodes
    (so values between nodes are covered). Its minimum is a lower bound of the energy
    per metre of any translation on ground whose gradients lie in the box (the corridor
    planner's ellipse and the windowed reach use it; the search's own table, priced at
    each sample of a motion, is :func:`bound_table`).

    Returns
    -------
    table : ndarray, shape (16, nodes, nodes)
        J per metre (>= 0; ``inf`` where no heading can move).
    tgeo : ndarray
        ``(gx of node 0, gy of node 0, gx spacing, gy spacing)``.
    """
    from scipy.ndimage import minimum_filter

    from energy_planner.energy.heading import HeadingCost
    from energy_planner.planning.moves import MOVES_16

    heading = HeadingCost.of_motion_cost(cost)
    tmax = heading.tmax
    lo, hi, tgeo = _table_grid(lo, hi, tmax, nodes)
    gxs = lo[0] + tgeo[2] * np.arange(nodes)
    gys = lo[1] + tgeo[3] * np.arange(nodes)
    GX, GY = np.meshgrid(gxs, gys, indexing="ij")
    walkable = GX**2 + GY**2 <= tmax**2 if math.isfinite(tmax) else np.ones(GX.shape, bool)
    dirs = np.arctan2(MOVES_16[:, 1], MOVES_16[:, 0])
    table = np.full((len(MOVES_16), nodes, nodes), np.inf)
    for m, ang in enumerate(dirs):
        if move_ok[:, m].any():
            # nodes steeper than the limit cannot be walked: inf without pricing them
            best = np.full(GX.shape, np.inf)
            best[walkable] = heading.lower_bound(GX[walkable], GY[walkable], ang)
            table[m] = minimum_filter(best, size=3, mode="nearest")
    table = np.maximum(table, 0.0)
    return table, tgeo


def _geo(cost) -> np.ndarray:
    return np.array(cost.data[IN_X0 : IN_DY + 1], dtype=np.float64)


def _sampling(cost) -> np.ndarray:
    """(kernel sample step, tmax): what :func:`_search.translation_refused` needs."""
    return np.array([cost.data[IN_STEP], cost.data[IN_TMAX]], dtype=np.float64)


class _Heap:
    """Open-list arrays for the numba heap, grown on demand."""

    def __init__(self, size: int):
        self.keys = np.empty(size, np.float64)
        self.vals = np.empty(size, np.int64)
        self.n = np.zeros(1, np.int64)

    def grow(self) -> None:
        size = 2 * len(self.keys)
        k = np.empty(size, np.float64)
        v = np.empty(size, np.int64)
        m = int(self.n[0])
        k[:m] = self.keys[:m]
        v[:m] = self.vals[:m]
        self.keys, self.vals = k, v


def _bar(progress, desc: str, total: int | None, unit: str):
    """A stage of the search on the one progress reporter (None when ``progress`` is False)."""
    if progress is False:
        return None
    from energy_planner.progress import reporter

    return reporter(progress).bar(desc, total, unit)


def relaxed_cost_to_go(
    cost,
    grid: _Grid,
    goal_p: int,
    *,
    mod=None,
    progress: bool = False,
    deadline: float = math.inf,
    stop_p: int = -1,
    stop_factor: float = 1.04,
    table: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """The admissible heuristic: least relaxed cost from every position to ``goal_p``.

    With ``stop_p`` >= 0 (the start ``s``) the backward search is an A* towards ``s``
    (keys ``h(p) + c |p - s|``, ``c`` the least J/m of any relaxed edge) that stops at
    ``stop_factor`` times ``h(s)``; a position it has not settled then gets
    ``stop_factor * h(s) - c |p - s|`` (:func:`_search.heuristic_chunk`): still a lower
    bound everywhere, and only the region a path of that energy can visit is settled.
    ``table``: :func:`bound_table` of ``grid``, when the caller solves several goals on
    it.

    Returns
    -------
    ndarray of float32, shape (nx * ny,)
        J; ``inf`` where the goal cannot be reached even in the relaxed problem. (Rounding
        to float32 moves a value by under 1e-7 of it, far inside the 1 % margin of the
        edge bounds, :data:`BOUND_MARGIN`.)
    """
    mod = mod or search_module(cost, "path")
    table, tgeo = bound_table(cost, grid.headings, grid.move_ok) if table is None else table
    h = np.full(grid.P, np.inf, dtype=np.float32)
    h[goal_p] = 0.0
    pos = np.full(grid.P, -1, dtype=np.int32)
    keys = np.empty(grid.P, np.float64)
    vals = np.empty(grid.P, np.int64)
    n = np.ones(1, np.int64)
    keys[0], vals[0], pos[goal_p] = 0.0, goal_p, 0
    grad = cost.data[IN_GRAD]
    blocked = cost.data[IN_BLOCKED]
    unsafe = mod.unsafe_cells(grad, blocked, float(cost.data[IN_TMAX]))
    geo = _geo(cost)
    sampling = _sampling(cost)
    bar = _bar(progress, "heuristic (2-D)", grid.P, "cells")
    limit = np.full(2, np.inf)  # stop key, least J/m of an edge
    try:
        while True:
            code, pops = mod.heuristic_chunk(
                grad, blocked, unsafe, geo, sampling, grid.lat, grid.moves, grid.move_len, table,
                tgeo, h, pos, keys, vals, n, 1_000_000, BOUND_MARGIN, stop_p, stop_factor, limit,
            )  # fmt: skip
            if bar is not None:
                bar.update(pops)
            if code == mod.EXHAUSTED:
                break
            if time.perf_counter() > deadline:
                raise PlanningError(
                    "the planning time budget ran out while solving the relaxed problem "
                    "(heuristic); give more time (time=) or a coarser step (step=)",
                    limit="time",
                    stage="heuristic",
                )
    finally:
        if bar is not None:
            bar.close()
    del keys, vals
    if math.isfinite(limit[0]):
        mod.cap_unsettled(h, pos, grid.nx, stop_p, limit[1], grid.step, limit[0])
    del pos
    return h


def _start_states(cost, grid: _Grid, p: int, yaw: float | None, which: str) -> np.ndarray:
    x, y = grid.xy(p)
    hs = [grid.heading_index(yaw)] if yaw is not None else range(grid.H)
    ok = [h for h in hs if math.isfinite(cost(x, y, grid.headings[h], x, y, grid.headings[h]))]
    if not ok:
        raise InvalidStateError(
            f"{which} position ({x:.2f}, {y:.2f}) breaks a limit at "
            f"{'every heading' if yaw is None else 'the requested heading'} "
            f"(step {grid.step:.2f} m)",
            endpoint=which,
            value=(x, y),
        )
    return np.array(ok, dtype=np.int64)


def _untouched(n: int, dtype, zero: bool = False) -> np.ndarray:
    """A 1-D array whose memory is mapped page by page on first write.

    numpy asks the kernel for transparent huge pages (2 MB) on large arrays; one write
    then maps 2 MB, and a path that crosses the map writes into every huge page of the
    per-state arrays. With 4 KB pages the memory follows the states reached.
    """
    try:
        from numpy._core import multiarray
    except ImportError:  # numpy < 2
        from numpy.core import multiarray
    setter = getattr(multiarray, "_set_madvise_hugepage", None)
    prev = setter(False) if setter is not None else None
    try:
        return np.zeros(n, dtype) if zero else np.empty(n, dtype)
    finally:
        if setter is not None:
            setter(prev)


def move_bounds(cost, grid: _Grid, table: tuple | None = None) -> np.ndarray:
    """A lower bound of the kernel's energy of each translation of ``grid``, anywhere (J).

    ``out[m]`` for the move ``grid.moves[m]``: its map length times the least J per map
    metre of :func:`bound_table` (``table``, when the caller has it) in that direction,
    times :data:`BOUND_MARGIN`: the least of every edge bound of the relaxed problem
    (:func:`_search.edge_bound`), so a lower bound of every such translation's kernel
    energy wherever the relaxed problem's is (``tests/test_planning_search.py``). 0
    where the table holds none. :func:`_search.astar_chunk` leaves a translation
    unpriced when even this energy could not improve the state it leads to.
    """
    table = bound_table(cost, grid.headings, grid.move_ok)[0] if table is None else table[0]
    least = table.reshape(len(table), -1).min(axis=1).astype(np.float64)
    out = BOUND_MARGIN * (grid.move_len * grid.step) * least
    out[~np.isfinite(out)] = 0.0
    # each a float32 rounded down: below the float32 price an edge cache keeps as well
    o32 = out.astype(np.float32)
    up = o32.astype(np.float64) > out
    o32[up] = np.nextafter(o32[up], np.float32(-np.inf))
    return np.ascontiguousarray(o32, dtype=np.float64)


def _run_search(mod, cost, grid, h2d, eps, starts_p, start_hs, goal_p, goal_h, *,
                max_key, progress, deadline, desc, move_lb):  # fmt: skip
    N = grid.P * grid.H
    # untouched pages cost no memory: g is read only where code says reached
    g = _untouched(N, np.float32)
    code = _untouched(N, np.int8, zero=True)
    heap = _Heap(1 << 22)
    for h in start_hs:
        s = starts_p * grid.H + int(h)
        g[s] = 0.0
        code[s] = mod.START
        mod.heap_push(heap.keys, heap.vals, heap.n, eps * float(h2d[starts_p]), s)
    out = np.zeros(1, np.int64)
    expanded = priced = 0
    bar = _bar(progress, desc, None, "states")
    status = mod.RUNNING
    try:
        while True:
            status, pops, pr = mod.astar_chunk(
                cost.data, grid.lat, grid.headings, grid.moves, grid.moves_of, move_lb, h2d,
                eps, g, code, goal_p, goal_h, heap.keys, heap.vals, heap.n, 500_000, max_key,
                out,
            )  # fmt: skip
            expanded += pops
            priced += pr
            if bar is not None:
                bar.update(pops)
            if status == mod.HEAP_FULL:
                heap.grow()
            elif status in (mod.FOUND, mod.EXHAUSTED):
                break
            if time.perf_counter() > deadline:
                raise PlanningError(
                    f"the planning time budget ran out after {expanded} states expanded; "
                    "give more time (time=), a coarser step (step=) or a larger eps (eps=)",
                    limit="time",
                    stage="search",
                    expanded=expanded,
                )
    finally:
        if bar is not None:
            bar.close()
    return status, int(out[0]), g, code, expanded, priced


@takes_problem(2)
def search_plan(
    problem,
    start: tuple[float, float, float | None],
    goal: tuple[float, float, float | None],
    *,
    step: float | None = None,
    n_headings: int = 16,
    moves: str = "all",
    eps: float = 1.0,
    progress: bool = False,
    time_budget: float = math.inf,
) -> SearchResult:
    """Energy-optimal path on the (x, y, heading) primitives, without building the graph.

    Parameters
    ----------
    problem : Problem
        Terrain (positions cover its extent) and motion cost (``problem.cost`` prices
        every edge; limits make edges infinite), :class:`energy_planner.problem.Problem`;
        the older form ``search_plan(cost, terrain, start, goal, ...)`` is accepted.
    start, goal : tuple
        ``(x, y, yaw)`` in the working CRS, yaw in radians or ``None`` (free).
    step : float, optional
        Position spacing, m (default: the DEM's cell size).
    n_headings : int
        Headings per position.
    moves : {"all", "crab", "axes"}
        Translations per heading (:data:`MOVE_SETS`): all 16 (default; crab walking at
        any lattice yaw offset), the 8 closest to the body axes and their 45-degree
        obliques, or the 4 closest to the body axes.
    eps : float
        Heuristic weight >= 1; the path's search cost is at most ``eps`` times the optimum.
    progress : bool
        Bars on stderr (relaxed problem, then the search), or a callable / Reporter
        (:func:`energy_planner.progress.reporter`).
    time_budget : float
        Seconds for the whole call (heuristic included); :class:`PlanningError` when
        exceeded.

    Returns
    -------
    SearchResult

    Raises
    ------
    InvalidStateError
        If the start or goal position breaks a limit or lies outside the map.
    PlanningError
        If no path exists under the limits, or the time budget runs out.
    """
    if not (eps >= 1.0 and math.isfinite(eps)):
        raise PlanningConfigError(f"eps must be >= 1, got {eps!r}", value=eps, param="eps")
    cost, terrain = problem.cost, problem.terrain
    t0 = time.perf_counter()
    deadline = t0 + time_budget
    grid = _Grid(cost, terrain, (start[0], start[1]), step, n_headings, moves)
    mod = search_module(cost, "path")
    ps = grid.position(start[0], start[1], "start")
    pg = grid.position(goal[0], goal[1], "goal")
    hs_start = _start_states(cost, grid, ps, start[2], "start")
    hs_goal = _start_states(cost, grid, pg, goal[2], "goal")
    goal_h = int(hs_goal[0]) if goal[2] is not None else -1
    table = bound_table(cost, grid.headings, grid.move_ok)
    h2d = relaxed_cost_to_go(
        cost, grid, pg, mod=mod, progress=progress, deadline=deadline, stop_p=ps, table=table
    )
    t1 = time.perf_counter()
    if not np.isfinite(h2d[ps]):
        raise PlanningError(
            f"no feasible path from start ({start[0]:.2f}, {start[1]:.2f}) to goal "
            f"({goal[0]:.2f}, {goal[1]:.2f}): the goal is unreachable even without turning "
            "costs (limits, keep-out areas or nodata cut it off); relax the limits",
            limit="unreachable",
        )
    status, s_goal, g, code, expanded, priced = _run_search(
        mod, cost, grid, h2d, float(eps), ps, hs_start, pg, goal_h, max_key=math.inf,
        progress=progress, deadline=deadline, desc="search (x, y, heading)",
        move_lb=move_bounds(cost, grid, table),
    )  # fmt: skip
    if status != mod.FOUND:
        raise PlanningError(
            f"no feasible path from start ({start[0]:.2f}, {start[1]:.2f}) to goal "
            f"({goal[0]:.2f}, {goal[1]:.2f}) at step {grid.step:.2f} m with {grid.H} "
            "headings under the given limits; relax the slope limits or keep-out areas",
            limit="unreachable",
        )
    chain = mod.trace(code, grid.moves, grid.nx, grid.H, s_goal)
    total = float(g[s_goal])
    del g, code
    p_of, h_of = np.divmod(chain, grid.H)
    j_of, i_of = np.divmod(p_of, grid.nx)
    states = np.column_stack([grid.xs[i_of], grid.ys[j_of], grid.headings[h_of]])
    states = exact_ends(states, start, goal)
    t2 = time.perf_counter()
    from energy_planner.planning.lattice import simplify_states
    from energy_planner.planning.speed import gait_changes

    return SearchResult(
        states=simplify_states(states, keep=gait_changes(cost, states)),
        cost=total,
        step=grid.step,
        n_headings=grid.H,
        eps=float(eps),
        expanded=expanded,
        priced=priced,
        states_total=grid.P * grid.H,
        heuristic_s=t1 - t0,
        search_s=t2 - t1,
        info={
            "h_start": float(h2d[ps]),
            "positions": grid.P,
            # h(start) is a lower bound of the optimum: cost / h(start) bounds the ratio
            "certified": total / float(h2d[ps])
            if h2d[ps] > 0
            else (1.0 if total <= 0 else math.inf),
        },
    )


def reach_search(
    cost,
    terrain,
    start: tuple[float, float, float | None],
    *,
    step: float | None = None,
    n_headings: int = 16,
    moves: str = "all",
    max_energy: float = math.inf,
    progress: bool = False,
    time_budget: float = math.inf,
    tree: bool = False,
) -> ReachResult:
    """Least energy from ``start`` to every position: the planner's search without a goal.

    The same primitives and edge costs as :func:`search_plan` (so ``reach`` and ``plan``
    agree: the energy at the goal's position equals ``search_plan``'s cost with
    ``eps=1``), searched by Dijkstra (``h = 0``) until every state with energy
    ``<= max_energy`` is settled.

    Parameters
    ----------
    cost : MotionCost
    terrain : Terrain
    start : tuple
        ``(x, y, yaw)`` in the working CRS; yaw ``None`` = any initial heading (free).
    step, n_headings, moves
        As :func:`search_plan`.
    max_energy : float
        Stop at this energy, J (positions beyond read ``inf``).
    progress : bool
        A bar on stderr, or a callable / Reporter (:func:`energy_planner.progress.reporter`).
    time_budget : float
        Seconds; :class:`PlanningError` when exceeded.
    tree : bool
        Also the tree of each position's least-energy path (:attr:`ReachResult.tree`),
        read from the search's predecessor codes before they are freed.

    Returns
    -------
    ReachResult
    """
    t0 = time.perf_counter()
    grid = _Grid(cost, terrain, (start[0], start[1]), step, n_headings, moves)
    mod = search_module(cost)
    ps = grid.position(start[0], start[1], "start")
    hs = _start_states(cost, grid, ps, start[2], "start")
    h0 = np.zeros(grid.P)
    _, _, g, _code, expanded, priced = _run_search(
        mod, cost, grid, h0, 0.0, ps, hs, -1, -1, max_key=float(max_energy),
        progress=progress, deadline=t0 + time_budget, desc="reach (x, y, heading)",
        move_lb=move_bounds(cost, grid),
    )  # fmt: skip
    e = mod.min_over_headings(g, _code, grid.P, grid.H)
    e[e > max_energy] = np.inf
    paths = None
    if tree:
        from energy_planner.planning import _pathtree

        best = _pathtree.best_states(g, _code, grid.P, grid.H, mod.UNSEEN)
        best[~np.isfinite(e)] = -1
        states, parent, at = _pathtree.path_tree(
            _code, grid.moves, grid.nx, grid.H, best, mod.START, mod.TURN_FROM_PREV,
            mod.TURN_FROM_NEXT, mod.CLOSED,
        )  # fmt: skip
        paths = {"states": states, "parent": parent, "at": at, "xs": grid.xs, "ys": grid.ys,
                 "headings": grid.headings}  # fmt: skip
    return ReachResult(
        xs=grid.xs,
        ys=grid.ys,
        energy=e.reshape(grid.ny, grid.nx),
        step=grid.step,
        n_headings=grid.H,
        expanded=expanded,
        time_s=time.perf_counter() - t0,
        tree=paths,
        priced=priced,
    )


def search_grid(
    cost,
    terrain,
    anchor: tuple[float, float],
    *,
    step: float | None = None,
    n_headings: int = 16,
    moves: str = "all",
    box: tuple[float, float, float, float] | None = None,
) -> _Grid:
    """The search's lattice aligned on ``anchor``, optionally cut to a window.

    ``box`` = ``(xmin, ymin, xmax, ymax)`` (working CRS) keeps the positions inside it:
    the search never stands outside the box, while its motions are still priced by the
    kernel on the whole terrain (a motion between two positions of the box samples the
    same gradients as on the whole map). A path found in the box is a path of the whole
    map with the same energy.
    """
    grid = _Grid(cost, terrain, anchor, step, n_headings, moves)
    if box is not None:
        tol = 1e-9 * grid.step
        ix = np.nonzero((grid.xs >= box[0] - tol) & (grid.xs <= box[2] + tol))[0]
        iy = np.nonzero((grid.ys >= box[1] - tol) & (grid.ys <= box[3] + tol))[0]
        if ix.size == 0 or iy.size == 0:
            raise PlanningConfigError(f"the search window {tuple(box)} holds no position",
                                      value=tuple(box), param="box")  # fmt: skip
        grid.xs, grid.ys = grid.xs[ix[0] : ix[-1] + 1], grid.ys[iy[0] : iy[-1] + 1]
        grid.nx, grid.ny = len(grid.xs), len(grid.ys)
        grid.lat = np.array([grid.xs[0], grid.ys[0], grid.step, grid.nx, grid.ny], np.float64)
        grid.P = grid.nx * grid.ny
    return grid


def target_heuristics(
    cost, grid: _Grid, targets_xy: np.ndarray, *, progress: bool = False
) -> np.ndarray:
    """The relaxed cost-to-go of every position to each target (the A* bound), float32.

    Row ``k`` is :func:`relaxed_cost_to_go` to ``targets_xy[k]`` over the whole of
    ``grid``, rounded down to float32 (so it stays a lower bound; half the memory).

    Returns
    -------
    ndarray of float32, shape (len(targets_xy), grid.P)
        J; ``inf`` where the target cannot be reached even in the relaxed problem.
    """
    mod = search_module(cost)
    out = np.empty((len(targets_xy), grid.P), np.float32)
    table = bound_table(cost, grid.headings, grid.move_ok)
    for k, (x, y) in enumerate(np.asarray(targets_xy, float)):
        h = relaxed_cost_to_go(cost, grid, grid.position(x, y, "target"), mod=mod,
                               progress=progress, table=table)  # fmt: skip
        h32 = h.astype(np.float32)
        out[k] = np.where(h32 > h, np.nextafter(h32, np.float32(-np.inf)), h32)
    return out


@dataclass
class TargetsResult:
    """Least energy from one start to several target positions.

    Attributes
    ----------
    energy : ndarray, shape (n_targets,)
        Least energy to each target (min over the headings of arrival), J; ``inf`` where
        unreachable (or above ``max_energy``).
    expanded, priced : int
        States expanded and edges priced.
    states_total : int
        Positions x headings of the grid.
    time_s : float
        Wall time, s.
    """

    energy: np.ndarray
    expanded: int
    priced: int
    states_total: int
    time_s: float


def targets_search(
    cost,
    grid: _Grid,
    start_xy: tuple[float, float],
    targets_xy: np.ndarray,
    heuristics: np.ndarray,
    *,
    max_energy: float = math.inf,
    progress: bool = False,
    time_budget: float = math.inf,
    chunk: int = 4096,
    edges: np.ndarray | None = None,
    eps: float = 1.0,
    cache: tuple[np.ndarray, np.ndarray] | None = None,
) -> TargetsResult:
    """Least energy from ``start_xy`` (any initial heading) to each of several targets.

    The planner's search (the same primitives, kernel and float32 ``g`` as
    :func:`search_plan` and :func:`reach_search`) as one A* toward every target at once:
    the heuristic is the least of the remaining targets' relaxed costs-to-go
    (``heuristics``, from :func:`target_heuristics`), consistent as each of them is. A
    target is settled when the first state at its position is expanded: with a
    heuristic that is the same at every heading of a position, that state has the least
    ``g`` over the headings, which is what :func:`reach_search` reads there and what
    :func:`search_plan` finds with ``eps = 1`` and a goal without yaw. The settled
    target then leaves the heuristic, which can only grow (the others' bound), and the
    open list is re-keyed (closed states keep their optimal ``g``, so A* stays exact
    under the new consistent heuristic). The search stops when every target is settled,
    so it expands only what lies below the farthest target, along the ways to them.

    Parameters
    ----------
    cost : MotionCost
    grid : _Grid
        From :func:`search_grid` (the same one as the heuristics').
    start_xy : tuple
        Start position (working CRS), any heading.
    targets_xy : ndarray, shape (n, 2)
        Target positions.
    heuristics : ndarray, shape (n, grid.P)
        Row ``k``: a consistent lower bound of the cost to target ``k``.
    max_energy : float
        Stop at this energy, J (farther targets read ``inf``).
    progress : bool
        tqdm bar on stderr.
    time_budget : float
        Seconds; :class:`PlanningError` when exceeded.
    chunk : int
        States expanded between checks of the targets.
    edges : ndarray, optional
        Every edge's cost from :func:`edge_table` on ``grid`` (shared by the searches from
        several starts: each edge priced once instead of once per search); None: edges
        priced on demand (then ``g`` and the codes are mapped page by page as the search
        reaches them, as :func:`search_plan`'s).
    eps : float
        Heuristic weight >= 1 (keys ``g + eps * h``, as :func:`search_plan`'s). Each
        target's energy is then at most ``eps`` times its optimum: the weighted A*
        bound holds for each target, since the least of the remaining targets' bounds is
        a consistent lower bound of the cost to each of them (with 1 the optimum).
    cache : tuple, optional
        :func:`edge_cache` of ``grid`` (instead of ``edges``): each edge is priced when
        a search first needs it and kept for the next searches on ``grid`` (the same
        prices as ``edges``, for only the edges the searches need).

    Returns
    -------
    TargetsResult
    """
    if not (eps >= 1.0 and math.isfinite(eps)):
        raise PlanningConfigError(f"eps must be >= 1, got {eps!r}", value=eps, param="eps")
    t0 = time.perf_counter()
    mod = search_module(cost)
    H = grid.H
    ps = grid.position(start_xy[0], start_xy[1], "start")
    tp = np.array([grid.position(x, y, "target") for x, y in np.asarray(targets_xy, float)],
                  dtype=np.int64).reshape(-1)  # fmt: skip
    energy = np.full(len(tp), np.inf)
    remaining = [k for k in range(len(tp)) if math.isfinite(heuristics[k, ps])]
    hs = _start_states(cost, grid, ps, None, "start")
    if edges is None:  # astar_chunk (and the lazy one) read g only where the code says reached
        g = _untouched(grid.P * H, np.float32)
        code = _untouched(grid.P * H, np.int8, zero=True)
    else:  # astar_cached_chunk compares with g everywhere
        g = np.full(grid.P * H, np.inf, dtype=np.float32)
        code = np.full(grid.P * H, -1, dtype=np.int8)
    heap = _Heap(1 << 16)
    h2d = np.empty(grid.P)
    mod.min_rows(heuristics, np.array(remaining, np.int64), h2d)
    if eps != 1.0:  # the kernels key g + h2d: h2d holds eps * h
        h2d *= eps
    for h in hs:
        s = ps * H + int(h)
        g[s] = 0.0
        code[s] = mod.START
        mod.heap_push(heap.keys, heap.vals, heap.n, float(h2d[ps]), s)
    heads = np.arange(H)
    out = np.zeros(1, np.int64)
    move_lb = move_bounds(cost, grid) if edges is None else None
    expanded = priced = 0
    bar = _bar(progress, "matrix search (x, y, heading)", None, "states")
    try:
        while remaining:
            # the last target ends the search as a goal: no expansion after it
            last = int(tp[remaining[0]]) if len(remaining) == 1 else -1
            if cache is not None:
                status, pops, pr = mod.astar_lazy_chunk(
                    cost.data, grid.lat, grid.headings, grid.moves, grid.moves_of, move_lb,
                    h2d, g, code, last, heap.keys, heap.vals, heap.n, chunk,
                    float(max_energy), cache[0], cache[1],
                )  # fmt: skip
            elif edges is None:
                status, pops, pr = mod.astar_chunk(
                    cost.data, grid.lat, grid.headings, grid.moves, grid.moves_of, move_lb,
                    h2d, 1.0, g, code, last, -1, heap.keys, heap.vals, heap.n, chunk,
                    float(max_energy), out,
                )  # fmt: skip
            else:
                status, pops = mod.astar_cached_chunk(
                    edges, grid.lat, H, grid.moves, grid.moves_of, h2d, g, code, last,
                    heap.keys, heap.vals, heap.n, chunk, float(max_energy),
                )  # fmt: skip
                pr = 0
            expanded += pops
            priced += pr
            if bar is not None:
                bar.update(pops)
            if status == mod.HEAP_FULL:
                heap.grow()
                continue
            rem = np.array(remaining, np.int64)
            st = tp[rem, None] * H + heads
            closed = code[st] >= mod.CLOSED
            hit = closed.any(axis=1)
            if hit.any():
                for k, row, c in zip(rem[hit], st[hit], closed[hit], strict=True):
                    energy[k] = float(g[row[c]].min())
                remaining = [int(k) for k in rem[~hit]]
                if remaining:
                    mod.min_rows(heuristics, np.array(remaining, np.int64), h2d)
                    if eps != 1.0:
                        h2d *= eps
                    mod.rekey(heap.keys, heap.vals, heap.n, g, code, h2d, H)
            if status in (mod.EXHAUSTED, mod.FOUND):
                break
            if time.perf_counter() > t0 + time_budget:
                raise PlanningError(
                    f"the matrix search's time budget ran out after {expanded} states "
                    "expanded", limit="time", stage="search", expanded=expanded,
                )  # fmt: skip
    finally:
        if bar is not None:
            bar.close()
    energy[energy > max_energy] = np.inf
    return TargetsResult(energy=energy, expanded=expanded, priced=priced,
                         states_total=grid.P * H, time_s=time.perf_counter() - t0)  # fmt: skip


#: Bytes per (x, y, heading) state of :func:`edge_table` (18 float32 edges: 16 moves, 2 turns).
EDGE_BYTES_PER_STATE = 4 * 18


def edge_cache(grid: _Grid) -> tuple[np.ndarray, np.ndarray]:
    """An empty shared edge cache of ``grid``: :func:`edge_table`'s entries, filled on demand.

    ``(edges, done)``: float32 ``(grid.P * grid.H, grid.moves_of.shape[1] + 2)`` and a
    uint32 per state whose bit ``k`` says column ``k`` is priced, both mapped page by page
    when first written (:func:`targets_search` with ``cache=``), so their memory follows
    the states the searches expand (at most :data:`EDGE_BYTES_PER_STATE` + 4 bytes per
    state).
    """
    N = grid.P * grid.H
    edges = _untouched(N * (grid.moves_of.shape[1] + 2), np.float32)
    return edges.reshape(N, -1), _untouched(N, np.uint32, zero=True)


def merge_edges(cache: tuple[np.ndarray, np.ndarray], states: np.ndarray, rows: np.ndarray,
                done: np.ndarray) -> None:  # fmt: skip
    """Write into ``cache`` (:func:`edge_cache`) the entries another cache priced.

    ``rows[i]`` holds state ``states[i]``'s edges where bit ``k`` of ``done[i]`` is set;
    only the entries ``cache`` lacks are written (the others hold the same price).
    """
    edges, have = cache
    states = np.asarray(states, np.int64)
    old = have[states]
    new = np.asarray(done, np.uint32) & ~old
    for k in range(edges.shape[1]):
        sel = ((new >> np.uint32(k)) & np.uint32(1)).astype(bool)
        edges[states[sel], k] = rows[sel, k]
    have[states] = old | new


def edge_table(cost, grid: _Grid, rows: tuple[int, int] | None = None) -> np.ndarray:
    """Every edge of ``grid``'s lattice priced once by the kernel (float32, J).

    ``rows`` = ``(j0, j1)``: only the states of lattice rows ``j0 .. j1 - 1`` (a strip;
    strips stacked in order give the whole table, so they can be priced in parallel).

    ``out[s, k]``: from state ``s``, the ``k``-th translation of its heading
    (``grid.moves_of``; ``inf`` off the lattice or under a limit), then the turns in
    place to the previous and the next heading: the edges the search prices on demand,
    by the same kernel call. Searches from several starts on the same lattice share it
    (:func:`targets_search` with ``edges=``).

    Returns
    -------
    ndarray of float32, shape ((j1 - j0) * grid.nx * grid.H, grid.moves_of.shape[1] + 2)
    """
    mod = search_module(cost)
    j0, j1 = (0, grid.ny) if rows is None else (int(rows[0]), int(rows[1]))
    out = np.empty(((j1 - j0) * grid.nx * grid.H, grid.moves_of.shape[1] + 2), np.float32)
    mod.edge_costs(cost.data, grid.lat, grid.headings, grid.moves, grid.moves_of, j0, j1, out)
    return out
