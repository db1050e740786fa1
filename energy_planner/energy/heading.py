"""The cheapest way to move along a heading at a cell, over the body's yaw.

One concept, one implementation: :class:`HeadingCost` answers "how much energy per metre
of map does it cost, at the least, to move along this heading on this ground?" for

- the energy map's ``best_*`` and ``cheapest`` bands (:mod:`energy_planner.energymap`);
- the planner's 2-D heuristic, a lower bound of every motion the search prices
  (:func:`energy_planner.planning.search.bound_table`, read at each sample of a motion),
  and the bound of the corridor planner's and the windowed reach's windows
  (:func:`energy_planner.planning.search.gradient_table`);
- compare-routes' cost of climbing a grade and its critical grade with the best yaw
  (:func:`energy_planner.planning.compare.grade_cost`).

**Which yaws.** The continuous minimum over the body's yaw ``r`` relative to the
direction of travel (map angles, as every yaw in energy_planner; 0 facing it, ``+-pi/2``
sideways, ``pi`` walking backward), within the gait limits:

- ``max_crab_deg``: body x within ``max_crab`` of the travel (walking forward or
  sideways) or of its opposite (walking backward) (None: any yaw; 0: face along or
  straight back);
- ``max_backward_slope_deg``: no backward walking (more than 90 deg between body x and
  the travel) on ground steeper than this (None: anywhere);
- ``max_cross_slope_deg``: no yaw that holds the body across a steeper cross-slope
  (as every motion of the kernels); ``max_slope_deg``: ``inf`` on steeper ground.

The gait limits hold as the motion kernels check them
(:func:`energy_planner.energy._motion.gait_violation`, within ``gait_cost``): on angles
in the slope plane, between body x and the velocity. The sweep runs over map angles, so
each half's window is the map image of the in-plane one (``yaw_window``: wider than
``max_crab`` near the fall line, narrower across it; the forward half is exactly the
in-plane forward yaws, all that is left where backward walking is forbidden).

The minimum is found by a sweep of ``r`` at 6 degrees on each half (forward; backward)
and a golden-section refinement of the two best basins to 0.02 degrees
(``cheapest_at`` in :mod:`energy_planner.energy._motion`, compiled with the model's
``power``, pricing with the very ``gait_cost`` of the motion kernels: a short straight
motion's energy per map metre). Every value is an evaluated cost of an allowed yaw.

**What the planners realise.** The search moves at its lattice headings (16) along
the 16 lattice directions (``moves="all"``; fewer with ``"crab"``/``"axes"``), so it
realises only the crab angles between those; the refinement (``planner="auto"``), OMPL
and ``energy`` of given waypoints walk any yaw. The continuous minimum is below every one
of them, which is what an admissible heuristic needs.

**Raster speed.** The cost per map metre depends only on the slope ``alpha``, the
travel direction relative to uphill ``phi`` (map angle), the channel values and the
speed (the ground's azimuth only rotates the problem). So it is tabulated once over
``alpha`` (1 degree steps, up to 60 degrees or the slope limit, built lazily as steeper
cells come) and ``phi`` (0.5 degree steps), each half of the yaws apart (so that the
backward-slope limit is applied per cell, exactly), with walking forward facing the
travel (the map's ``along``) beside them, and looked up bilinearly. Bilinear
interpolation is exact at the nodes and within 0.3 % of the minimum over a dense
sample of slopes up to 55 degrees under the bundled model (largest where the cheapest
gait switches branch between two nodes on steep ground: the minimum has a kink there;
``along`` is smooth between nodes, its kinks facing across the slope lie on them);
``tests/test_energy_heading.py`` checks the table against the exact minimum. A cell
steeper than the table, a lookup that touches a node where no yaw may move
(cross-slope limit), and maps with a numeric channel raster (the cost varies with it)
are computed by the exact minimum itself; categorical channel rasters get one table
per combination of categories met. The table is cached on disk next to the
compiled kernels. Channel values (``--set`` constants, raster values) are inputs of the
compiled kernels, never compiled in: a new value builds (or loads) its table and
compiles nothing.
"""

from __future__ import annotations

import hashlib
import math
import threading
import warnings
from collections.abc import Mapping
from dataclasses import replace
from functools import lru_cache
from typing import Any

import numpy as np

from energy_planner.request import DEFAULT_SPEED

__all__ = ["HeadingCost", "heading_cost", "TABLE_D_ALPHA_DEG", "TABLE_D_PHI_DEG"]

#: Slope step of the table, degrees.
TABLE_D_ALPHA_DEG = 1.0
#: Step of the travel direction relative to uphill, degrees (divides 360).
TABLE_D_PHI_DEG = 0.5
#: Steepest slope the table holds, degrees (steeper cells: the exact minimum).
TABLE_TOP_DEG = 60.0
#: Rows of slope built at once when the table grows.
_ROWS_PER_BUILD = 10


#: Not looked up yet (:meth:`HeadingCost.precompiled_map`).
_UNSET = object()


def _angle(deg: float | None, fn: Any) -> float:
    """``fn(radians(deg))``, ``inf`` for None (no limit)."""
    return math.inf if deg is None else float(fn(math.radians(deg)))


class HeadingCost:
    """The cheapest way to move along a heading, over the body yaws the gait allows.

    Build it with :func:`heading_cost` (or :meth:`of_motion_cost`, :meth:`of_request`):
    instances with the same physics share one table within a process.

    Parameters
    ----------
    source : str
        The model's ``power`` source (:meth:`EnergyModel.kernel_source` with the
        channels' run-time layout: the rasters, then the constants the model reads; the
        same source as :class:`~energy_planner.energy.MotionCost`'s, so both share one
        compiled module).
    speed : float
        Walking speed along the ground, m/s.
    tmax, smax : float
        ``tan`` of the slope limit, ``sin`` of the cross-slope limit (``inf``: none).
    crab : float
        Largest angle between body x and the travel (or its opposite walking backward),
        radians, in the slope plane (``inf``: none): the motion kernel's ``cmax``
        (:func:`~energy_planner.energy.motion.gait_limit_values`).
    back_tan : float
        ``tan`` of the steepest slope on which the robot may walk backward (``inf``:
        anywhere; negative: nowhere): the motion kernel's ``btan``.
    rasters : int
        Number of channel rasters the kernel reads.
    categorical : bool
        Every raster is categorical: one table per combination of categories met;
        otherwise (a numeric raster) no table, the exact minimum everywhere.
    consts : tuple of float
        The constant channels' values (``--set``; a category as its index), kernel
        inputs after the rasters: a new value builds a new table but compiles nothing.
    top_deg : float
        Steepest slope the table holds, degrees (default :data:`TABLE_TOP_DEG`; steeper
        cells take the exact minimum). A table with a higher top has the same rows
        below the default's (each node is computed on its own) and starts from them.
    """

    #: The kernel that builds the table's rows, and the number of layers it returns (the
    #: three costs; a subclass may add layers after them).
    _TABLE_KERNEL = "heading_table"
    _TABLE_DEPTH = 3

    def __init__(
        self, source: str, speed: float, tmax: float, smax: float, crab: float,
        back_tan: float, rasters: int = 0, categorical: bool = False,
        consts: tuple[float, ...] = (), top_deg: float = TABLE_TOP_DEG,
    ) -> None:  # fmt: skip
        self.source = source
        self.speed = float(speed)
        self.tmax = float(tmax)
        self.smax = float(smax)
        self.crab = float(crab)
        self.back_tan = float(back_tan)
        self.rasters = int(rasters)
        self.categorical = bool(categorical)
        self.consts = tuple(float(v) for v in consts)
        self._consts = np.array(self.consts, dtype=np.float64)
        self._numba: Any = None  # numba's kernel module, loaded on first use
        self._aot: Any = _UNSET  # the precompiled map module (precompiled_map)
        self.top_deg = float(top_deg)
        top = min(self.top_deg, math.degrees(math.atan(self.tmax)))
        self.d_alpha = math.radians(TABLE_D_ALPHA_DEG)
        self.n_alpha = max(2, int(math.ceil(top / TABLE_D_ALPHA_DEG - 1e-9)) + 1)
        self.n_phi = int(round(360.0 / TABLE_D_PHI_DEG))
        # per combination of categorical channel values (() without rasters): the
        # table and the number of rows built
        self._tables: dict[tuple[float, ...], list[Any]] = {}
        self._lock = threading.Lock()

    @property
    def _mod(self) -> Any:
        """The model's numba kernel module, loaded on first use.

        (:func:`~energy_planner.energy.kernels.kernel_module`): a map from precompiled
        kernels and a cached table never loads numba.
        """
        if self._numba is None:
            from energy_planner.energy.kernels import kernel_module

            self._numba = kernel_module(self.source)
        return self._numba

    def precompiled_map(self) -> Any:
        """The model's precompiled energy-map kernels, or None where there are none.

        :func:`~energy_planner.energy.kernels.precompiled_map_module` (built once per
        machine and model; None when building is off or failed): ``map_costs`` and
        ``summary``, GIL-free, run in threads over a block's rows (:func:`run_by_rows`).
        """
        if self._aot is _UNSET:
            from energy_planner.energy.kernels import precompiled_map_module

            self._aot = precompiled_map_module(self.source)
        return self._aot

    def __reduce__(self):  # the dask workers rebuild it from its parameters (cached)
        return (_cached, self.params)

    @property
    def params(self) -> tuple[Any, ...]:
        """The parameters that define it (those of the constructor)."""
        return (self.source, self.speed, self.tmax, self.smax, self.crab, self.back_tan,
                self.rasters, self.categorical, self.consts, self.top_deg)  # fmt: skip

    # ------------------------------------------------------------------ constructors
    @classmethod
    def of_motion_cost(
        cls, cost: Any, *, max_crab_deg: float | None = None,
        max_backward_slope_deg: float | None = None, speed: float | None = None,
        gait: str | None = None, top_deg: float = TABLE_TOP_DEG,
    ) -> HeadingCost:  # fmt: skip
        """The heading cost of a :class:`~energy_planner.energy.MotionCost`'s physics.

        Its model, speed (or ``speed``: one of a cost's speed range), channels and slope
        limits; the gait limits given here, or the cost's own ``max_crab_deg`` /
        ``max_backward_slope_deg`` if it has them. ``gait``: one of the gaits a cost
        chooses among (:attr:`MotionCost.gaits`), walked everywhere; ``top_deg``: the
        table's steepest slope.
        """
        channels = cost.channels
        if gait is None and getattr(cost, "gaits", ()):  # the gait at the nominal speed
            gait = cost.nominal_gait
        if gait is not None:
            from energy_planner.model import GAIT_CHANNEL

            channels = replace(
                channels, constants={**channels.constants, GAIT_CHANNEL: str(gait)},
                allow_unknown_categories=True,
            )  # fmt: skip
        if max_crab_deg is None:
            max_crab_deg = getattr(cost, "max_crab_deg", None)
        if max_backward_slope_deg is None:
            max_backward_slope_deg = getattr(cost, "max_backward_slope_deg", None)
        with warnings.catch_warnings():
            if gait is not None:  # a gait the model does not name: its reference gait
                warnings.filterwarnings("ignore", message="channel 'gait'")
            return heading_cost(
                cost.model, speed=cost.speed if speed is None else speed, channels=channels,
                max_slope_deg=cost.max_slope_deg, max_cross_slope_deg=cost.max_cross_slope_deg,
                max_crab_deg=max_crab_deg, max_backward_slope_deg=max_backward_slope_deg,
                top_deg=top_deg,
            )  # fmt: skip

    @classmethod
    def of_request(cls, model: Any, request: Any = None, channels: Any = None) -> HeadingCost:
        """From a :class:`~energy_planner.request.Request`: speed, limits, channels."""
        from energy_planner.request import Request

        request = Request() if request is None else request
        lim = request.limits
        if channels is None:
            channels = request.channels
        return heading_cost(
            model, speed=request.robot.speed, channels=channels,
            max_slope_deg=lim.max_slope_deg, max_cross_slope_deg=lim.max_cross_slope_deg,
            max_crab_deg=getattr(lim, "max_crab_deg", None),
            max_backward_slope_deg=getattr(lim, "max_backward_slope_deg", None),
        )  # fmt: skip

    # ------------------------------------------------------------------ exact
    def per_metre(
        self, gx: Any, gy: Any, heading: Any, chan: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """The exact cheapest J per map metre and the body yaw that gives it.

        Parameters
        ----------
        gx, gy : array_like
            Gradient ``dz/dx``, ``dz/dy`` of the ground (broadcast with ``heading``).
        heading : array_like
            Direction of travel, radians CCW from +x (east).
        chan : ndarray, optional
            Channel raster values, shape ``(k,) + shape`` (the kernel's raster layout).

        Returns
        -------
        cost : ndarray
            J per metre of map distance (``inf`` where no allowed yaw may move, or
            above the slope limit; NaN where the gradient is not finite).
        yaw : ndarray
            The body's yaw relative to the travel, radians in (-pi, pi] (map angles).
        """
        gx, gy, h = np.broadcast_arrays(
            *(np.asarray(v, dtype=np.float64) for v in (gx, gy, heading))
        )
        shape = gx.shape
        n = gx.size
        if chan is None:
            chan = np.zeros((0, n))
        chan = np.ascontiguousarray(np.asarray(chan, dtype=np.float64).reshape(-1, n))
        if chan.shape[0] != self.rasters:
            raise ValueError(f"chan has {chan.shape[0]} channels, the kernel reads {self.rasters}")
        flat = [np.ascontiguousarray(v.ravel()) for v in (gx, gy, h)]
        cost, yaw = self._mod.cheapest_batch(*flat, self.speed, self.smax, self.back_tan,
                                             self.crab, chan, self._consts)  # fmt: skip
        steep = flat[0] ** 2 + flat[1] ** 2 > self.tmax**2
        cost[steep] = np.inf
        return cost.reshape(shape), yaw.reshape(shape)

    # ------------------------------------------------------------------ the table
    def table(self, max_alpha: float = 0.0, values: tuple[float, ...] = ()) -> np.ndarray:
        """The table, built at least up to slope ``max_alpha`` (radians).

        ``table[h, i, j]``: J per map metre at slope ``i * d_alpha`` moving ``2 pi j /
        n_phi`` CCW from uphill, least over the forward (``h = 0``: body x at most 90 deg
        from the travel, in the slope plane) or backward (``h = 1``, whatever the slope:
        the backward-slope limit is applied per cell) half of the yaws within the crab
        limit; ``h = 2``: walking forward
        facing the travel (the map's ``along``). ``values``: the categorical channels'
        values (category indices) it is for. Rows are added as needed (each node on its
        own: a table grown in pieces equals one built whole).
        """
        need = min(self.n_alpha, int(math.floor(max(max_alpha, 0.0) / self.d_alpha)) + 2)
        with self._lock:
            entry = self._tables.get(values)
            if entry is None:
                shape = (self._TABLE_DEPTH, self.n_alpha, self.n_phi)
                entry = self._tables[values] = [np.full(shape, np.nan), 0]
            if need > entry[1]:
                self._grow(entry, need, values)
            return entry[0][:, : entry[1]]

    def _grow(self, entry: list[Any], need: int, values: tuple[float, ...]) -> None:
        table, start = entry
        key = self._key(values)
        stop = min(self.n_alpha, max(need, start + _ROWS_PER_BUILD))
        if start == 0:
            cached = _load_table(key, self._TABLE_DEPTH)
            if cached is None and self.top_deg != TABLE_TOP_DEG:  # the default's rows
                cached = _load_table(self._key(values, TABLE_TOP_DEG), self._TABLE_DEPTH)
            if cached is not None and cached.shape[2] == self.n_phi:
                rows = min(cached.shape[1], self.n_alpha)
                table[:, :rows] = cached[:, :rows]
                entry[1] = start = rows
                if start >= need:
                    return
                stop = min(self.n_alpha, max(need, start + _ROWS_PER_BUILD))
        chv = np.asarray((*values, *self.consts), dtype=np.float64)
        aot = None if self._aot is _UNSET else self._aot
        if aot is None:
            part = getattr(self._mod, self._TABLE_KERNEL)(
                self.speed, self.smax, self.crab, self.d_alpha, start, stop - start,
                self.n_phi, chv,
            )  # fmt: skip
            table[:, start:stop] = part
        else:  # each node on its own: rows built in pieces equal rows built whole

            def rows(a: int, b: int) -> None:
                table[:, start + a : start + b] = aot.heading_table(
                    self.speed, self.smax, self.crab, self.d_alpha, start + a, b - a,
                    self.n_phi, chv,
                )  # fmt: skip

            run_by_rows(rows, stop - start)
        entry[1] = stop
        _save_table(key, table[:, :stop])

    def _key(self, values: tuple[float, ...] = (), top_deg: float | None = None) -> str:
        from energy_planner.energy import kernels

        top = self.top_deg if top_deg is None else top_deg
        # the default top is not in the text: the tables cached before it was a
        # parameter keep their keys
        params = (*self.params[:-1], *(() if top == TABLE_TOP_DEG else (top,)))
        text = repr((params, values, TABLE_D_ALPHA_DEG, TABLE_D_PHI_DEG))
        helpers = (kernels._TEMPLATE.read_bytes(), text.encode())
        return hashlib.sha256(b"\0".join(helpers)).hexdigest()[:24]

    def lower_bound(self, gx: Any, gy: Any, heading: Any) -> np.ndarray:
        """A lower bound of the cheapest J per map metre at each point.

        The least of the table's nodes around the point (both halves where walking
        backward is allowed). Exact at the nodes; between them it is below the bilinear
        value, and below the exact minimum wherever that is concave or monotone across
        the table's cell (a smooth minimum inside a cell can dip below its corners by a
        fraction of the interpolation error: planners scale the bound by their margin).
        Points steeper than the table, or whose four nodes all forbid moving, take the
        exact minimum. Without a table (channel rasters) it is 0.
        """
        gx, gy, h = np.broadcast_arrays(
            *(np.asarray(v, dtype=np.float64) for v in (gx, gy, heading))
        )
        if self.rasters:
            return np.zeros(gx.shape)
        g = np.hypot(gx, gy)
        alpha = np.arctan(g)
        fin = np.isfinite(alpha)
        table = self.table(float(alpha[fin].max()) if fin.any() else 0.0)
        rows = table.shape[1]
        psi = np.where(g > 0, np.arctan2(gy, gx), 0.0)
        phi = np.mod(h - psi, 2 * np.pi)
        fi = np.where(fin, alpha / self.d_alpha, np.inf)
        inside = fi <= rows - 1
        i0 = np.clip(np.floor(np.where(inside, fi, 0)).astype(int), 0, max(rows - 2, 0))
        fj = phi / (2 * np.pi / self.n_phi)
        j0 = np.floor(np.where(np.isfinite(fj), fj, 0)).astype(int) % self.n_phi
        j1 = (j0 + 1) % self.n_phi
        back = g <= self.back_tan
        out = np.full(gx.shape, np.inf)
        for half in (0, 1):
            ok = back if half else np.ones(gx.shape, bool)
            corners = np.minimum.reduce(
                [table[half, i0 + di, j] for di in (0, 1) for j in (j0, j1)]
            )
            out = np.where(ok, np.minimum(out, corners), out)
        exact = fin & (~inside | ~np.isfinite(out))
        if exact.any():
            out[exact] = self.per_metre(gx[exact], gy[exact], h[exact])[0]
        out[~fin] = np.nan
        out[g > self.tmax] = np.inf
        return np.maximum(out, 0.0)

    # ------------------------------------------------------------------ the map
    def map_bands(
        self, gx: np.ndarray, gy: np.ndarray, chan: np.ndarray, headings: np.ndarray,
        along: np.ndarray, best: np.ndarray, precompiled: bool = False,
        then: Any = None,
    ) -> None:  # fmt: skip
        """Fill the energy map's ``along`` and ``best`` bands of a block of cells.

        ``gx``, ``gy``: float64 ``(rows, cols)``; ``chan``: ``(k, rows, cols)`` channel
        rasters; ``headings``: radians; ``along``, ``best``: ``(N, rows, cols)``
        outputs (float32). ``along`` walks forward facing the heading; ``best`` is the
        cheapest way over the allowed yaws (never above ``along``). Both from the table,
        or exactly where the table does not serve. ``precompiled``: with the model's
        precompiled kernels (:meth:`precompiled_map`) where there are some, the same
        code and values as numba's. ``then(a, b)``: called for each range of rows
        ``a .. b`` once its bands are filled, in the precompiled kernel's row thread that
        filled them (:func:`run_by_rows`: what comes next for those rows follows in the
        same thread, with no wait for the other rows); else over the row ranges of
        :func:`run_by_rows` after the whole block.
        """
        ang = np.ascontiguousarray(headings, dtype=np.float64)
        if precompiled:
            self.precompiled_map()  # a table not on disk is built by it too
        if not self.rasters or not self.categorical:
            table = np.zeros((3, 0, 0))  # a numeric raster: the exact minimum everywhere
            if not self.rasters:
                table = np.ascontiguousarray(self.table(_steepest(gx, gy, self.tmax)))
            self._map(gx, gy, chan, ang, table, along, best, precompiled, then)
            return
        with np.errstate(invalid="ignore"):
            g2 = gx * gx + gy * gy
            ok = np.isfinite(g2) & (g2 <= self.tmax * self.tmax)
        # categorical rasters: one pass per combination of categories in the block, the
        # other cells masked (NaN), each with that combination's table
        along[:] = np.nan
        best[:] = np.nan
        # bands of the same layout as numba's kernel is compiled for (empty_like of a view
        # with a stride of 0, the along bands nobody reads, would put the headings last);
        # such a view itself takes every pass's along values (:func:`~energy_planner.
        # energymap.bands.block_bands`)
        a = along if along.strides[0] == 0 else np.empty(along.shape, along.dtype)
        b = np.empty(best.shape, best.dtype)
        for cells, table in self._combination_tables(chan, g2, ok):
            nan = np.full(gx.shape, np.nan)
            self._map(np.where(cells, gx, nan), np.where(cells, gy, nan), chan, ang,
                      np.ascontiguousarray(table), a, b, precompiled)  # fmt: skip
            if a is not along:
                along[:, cells] = a[:, cells]
            best[:, cells] = b[:, cells]
        if then is not None:
            run_by_rows(then, gx.shape[0])

    def _combination_tables(self, chan, g2, ok):
        """``(cells, table)`` for each combination of the categorical rasters in a block.

        ``chan``: the block's channel rasters ``(n, rows, cols)``; ``g2``: squared gradients;
        ``ok``: cells within the slope limit. ``cells`` masks the cells (all channels
        finite) with that combination; ``table`` is its heading table up to the steepest of
        them. Nothing where no cell has every channel.
        """
        flat = chan.reshape(chan.shape[0], -1)
        fin = np.isfinite(flat).all(axis=0)
        if not fin.any():
            return
        combos, which = np.unique(flat[:, fin], axis=1, return_inverse=True)
        index = np.full(fin.size, -1)
        index[fin] = which.ravel()
        index = index.reshape(g2.shape)
        for k in range(combos.shape[1]):
            cells = index == k
            table = self.table(_top(g2[cells & ok]), tuple(float(v) for v in combos[:, k]))
            yield cells, table

    def _map(
        self, gx, gy, chan, ang, table, along, best, precompiled: bool = False, then=None
    ) -> None:
        aot = self.precompiled_map() if precompiled else None
        if aot is None:
            self._mod.map_costs(
                gx, gy, chan, self._consts, ang, self.speed, self.tmax, self.smax,
                self.back_tan, self.crab, table, self.d_alpha, along, best,
            )  # fmt: skip
            if then is not None:
                run_by_rows(then, gx.shape[0])
            return
        per_row = chan.shape[1:] == gx.shape  # rasters on the block's cells, else a stub

        def rows(a: int, b: int) -> None:
            aot.map_costs(
                gx[a:b], gy[a:b], chan[:, a:b] if per_row else chan, self._consts, ang,
                self.speed, self.tmax, self.smax, self.back_tan, self.crab, table,
                self.d_alpha, along[:, a:b], best[:, a:b],
            )  # fmt: skip
            if then is not None:
                then(a, b)

        run_by_rows(rows, gx.shape[0])


def usable_cores() -> int:
    """The number of cores this process may run on (its CPU affinity, else all)."""
    import os

    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def run_by_rows(fn: Any, rows: int) -> None:
    """``fn(a, b)`` over consecutive row ranges covering ``0 .. rows``, one per core, in threads.

    For the precompiled map kernels, which release the GIL (numba's own kernels spread a
    block over the cores with ``prange``).
    """
    import threading

    n = max(1, min(usable_cores(), rows))
    cuts = [rows * k // n for k in range(n + 1)]
    if n == 1 or threading.current_thread().name.startswith(_ROW_THREADS):
        fn(0, rows)  # one core, or called from a row thread itself (its pool is busy)
        return
    pool = _row_pool(n - 1)
    # the calling thread takes the last range itself: n - 1 helper threads, kept between
    # calls (a map calls this for every window and band group)
    futures = [pool.submit(fn, a, b) for a, b in zip(cuts[:-2], cuts[1:-1], strict=True)]
    try:
        fn(cuts[-2], cuts[-1])
    finally:
        for f in futures:  # no range is still being written when this returns or raises
            f.exception()
    for f in futures:
        f.result()


_POOL: dict[tuple[int, int], Any] = {}
_ROW_THREADS = "energy_planner_rows"


def _row_pool(threads: int) -> Any:
    """A thread pool of ``threads`` workers for :func:`run_by_rows`, one per process.

    Keyed by the process id too: a forked child does not inherit the parent's threads.
    """
    import os
    from concurrent.futures import ThreadPoolExecutor

    key = (os.getpid(), threads)
    pool = _POOL.get(key)
    if pool is None:  # an executor starts no thread before its first task: a lost race is free
        pool = _POOL.setdefault(key, ThreadPoolExecutor(threads, thread_name_prefix=_ROW_THREADS))
    return pool


def _top(g2: np.ndarray) -> float:
    """The steepest slope (radians) of squared gradients ``g2`` (0 if none)."""
    return float(np.arctan(np.sqrt(g2.max()))) if g2.size else 0.0


def _steepest(gx: np.ndarray, gy: np.ndarray, tmax: float) -> float:
    """:func:`_top` of the cells of gradient ``(gx, gy)`` within the slope limit ``tmax``.

    The squared gradients of ``gx * gx + gy * gy`` that are finite and at most
    ``tmax ** 2``, their greatest found over the row ranges of :func:`run_by_rows` in
    threads (NumPy lets go of Python's lock) and without gathering them: the same value.
    """
    lim = tmax * tmax
    tops: list[float] = []
    cols = gx.shape[1] if gx.ndim == 2 else 1
    step = max(1, _STRIP_CELLS // max(cols, 1))

    def rows(a: int, b: int) -> None:
        # by strips of rows whose scratch stays in the cache (the same squares and maximum)
        n = min(step, b - a)
        g2, y2 = np.empty((2, n, *gx.shape[1:]))
        ok, below = np.empty((2, n, *gx.shape[1:]), dtype=bool)
        top = -np.inf
        for s in range(a, b, step):
            m = min(step, b - s)
            x, y = gx[s : s + m], gy[s : s + m]
            with np.errstate(invalid="ignore"):
                np.multiply(x, x, out=g2[:m])
                g2[:m] += np.multiply(y, y, out=y2[:m])
                np.isfinite(g2[:m], out=ok[:m])
                ok[:m] &= np.less_equal(g2[:m], lim, out=below[:m])
            top = max(top, np.max(g2[:m], where=ok[:m], initial=-np.inf))
        tops.append(top)

    run_by_rows(rows, gx.shape[0])
    top = max(tops, default=-np.inf)
    return float(np.arctan(np.sqrt(top))) if top > -np.inf else 0.0


#: Cells of a strip of rows :func:`_steepest` squares at a time (its scratch, 256 KB an
#: array, stays in a core's cache).
_STRIP_CELLS = 32768


@lru_cache(maxsize=32)
def _cached(*params: Any) -> HeadingCost:
    return HeadingCost(*params)


def heading_cost(
    model: Any,
    *,
    speed: float = DEFAULT_SPEED,
    channels: Any = None,
    constants: Mapping[str, Any] | None = None,
    max_slope_deg: float | None = None,
    max_cross_slope_deg: float | None = None,
    max_crab_deg: float | None = None,
    max_backward_slope_deg: float | None = None,
    top_deg: float = TABLE_TOP_DEG,
) -> HeadingCost:
    """The cheapest way to move along a heading under a model, speed and limits.

    Parameters
    ----------
    model : EnergyModel
        A fitted model.
    speed : float
        Walking speed along the ground, m/s.
    channels : Channels, optional
        Extra channels: constants (kernel inputs at run time: a new value compiles
        nothing) and rasters (their layout; the values are given per call).
    constants : mapping, optional
        More channel constants (merged with ``channels.constants``).
    max_slope_deg, max_cross_slope_deg : float, optional
        Slope limits, as :class:`~energy_planner.request.Limits`.
    max_crab_deg : float, optional
        Largest angle between the body's x axis and the direction of travel, or its
        opposite when walking backward, degrees in [0, 90], measured in the slope plane
        as the motion kernel checks it (None: any yaw; 0: face along or straight back;
        sideways is 90).
    max_backward_slope_deg : float, optional
        No backward walking (body x more than 90 degrees from the travel) on ground
        steeper than this, degrees (None: anywhere; negative: nowhere, not even on flat
        ground).
    top_deg : float
        Steepest slope of the table, degrees (steeper cells: the exact minimum).

    Returns
    -------
    HeadingCost
        Shared with every other call of the same physics in this process.

    Examples
    --------
    >>> import math
    >>> from energy_planner.model import EnergyModel
    >>> m = EnergyModel(["pos(vx)", "pos(-vx)", "abs(vy)"],
    ...                 {"pos(vx)": 600.0, "pos(-vx)": 700.0, "abs(vy)": 800.0})
    >>> hc = heading_cost(m)
    >>> cost, yaw = hc.per_metre(0.0, 0.0, 0.0)  # flat: walk forward, 600 J/m
    >>> round(float(cost), 6), round(float(yaw), 6)
    (600.0, 0.0)
    >>> round(float(heading_cost(m, max_crab_deg=0).per_metre(0.0, 0.0, 1.0)[0]), 6)
    600.0
    """
    from energy_planner.energy.channels import Channels
    from energy_planner.energy.motion import gait_limit_values
    from energy_planner.errors import ModelError

    if not model.is_fitted:
        raise ModelError("the energy model has no coefficients: fit or load a fitted model")
    channels = channels if channels is not None else Channels()
    if constants:
        channels = replace(channels, constants={**channels.constants, **dict(constants)})
    channels = channels.resolve(model)  # values of the kinds the model reads
    # the constants are kernel inputs after the rasters, as in MotionCost: the source
    # depends on the model and the channels' layout only (one table per value)
    source = model.kernel_source(channels.constants, channels.kernel_layout(runtime=True))
    # the motion kernel's form of the gait limits (a negative backward slope gives a
    # negative tangent: never backward)
    back_tan, crab = gait_limit_values(max_backward_slope_deg, max_crab_deg)
    return _cached(
        source,
        float(speed),
        _angle(max_slope_deg, math.tan),
        _angle(max_cross_slope_deg, math.sin),
        crab,
        back_tan,
        len(channels.rasters),
        all(cats is not None for _, cats in channels.kernel_layout()),
        tuple(channels.runtime_values().tolist()),
        float(top_deg),
    )


def _table_path(key: str):
    from energy_planner.model._codegen import cache_dir

    return cache_dir() / f"heading_{key}.npy"


def _load_table(key: str, depth: int = 3) -> np.ndarray | None:
    try:
        arr = np.load(_table_path(key), allow_pickle=False)
    except (OSError, ValueError):
        return None
    return arr if arr.ndim == 3 and arr.shape[0] == depth else None


def _save_table(key: str, table: np.ndarray) -> None:
    from energy_planner.io import atomic_path

    try:
        path = _table_path(key)
        with atomic_path(path) as tmp, open(tmp, "wb") as f:
            np.save(f, np.ascontiguousarray(table))
    except OSError:
        pass  # the cache is an optimisation only
