"""Battery reach: the least energy to reach every cell of a map from a start.

:func:`reach` prices every cell of the terrain's working grid with the least energy of a
path from the start to it (or, with ``round_trip=True``, of going there and coming back
to the start), using the planner's own search over (x, y, heading) with the same motion
primitives and the same kernel as :func:`energy_planner.planning.plan`, so that the
energy of a cell equals the energy ``plan`` finds to that cell (``planner="lattice"`` at
the same step; ``auto`` refines off the lattice and can end slightly lower).

The search positions lie on the DEM's own cells: the start is moved to the centre of its
cell (reported as ``start``) so that every cell centre is a search position. Headings are
free at the start; the cost of a cell is the least over the headings the robot may
arrive with. For a round trip the robot arrives with some heading and leaves again: by
default (``turn_at_cell=True``) it keeps its heading at the cell, so the cost is
``min over h of (to[cell, h] + back[cell, h])`` where ``back`` is the least energy from
the state back to the start (turning round, walking back backwards or crabbing at the
cell is paid). With ``turn_at_cell=False`` the two legs' headings at the cell are free,
``min_h to[cell, h] + min_h back[cell, h]``, as ``plan`` treats a goal without yaw and a
start without yaw: it equals ``plan(start, cell) + plan(cell, start)`` and is lower by at
most one half turn in place at the cell.

:class:`ReachMap` writes the result as a GeoTIFF on the DEM's grid and CRS (nodata where
the DEM has none or the cell cannot be reached), the area within a battery budget as a
GeoJSON polygon in the DEM's CRS, and a PNG (cost over a hillshade with the budget
contour).

The search sits behind one function, :func:`least_energy`: one way it is the planner's
full-resolution search run without a goal
(:func:`energy_planner.planning.search.reach_search`); a round trip needs per-heading
energies and a backward search, which run on the lattice graph of
:mod:`energy_planner.planning.lattice` with the search's move set (``moves="all"``, crab
walking included, as ``plan``'s default) and edge costs, every edge ``u -> v`` priced by
the kernel in its own direction, searched by scipy's Dijkstra forwards and on the
transposed graph.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.errors import InvalidStateError, PlanningError, ReachEdgeWarning
from energy_planner.planning.lattice import _GRAPHS, GRAPH_KEEP_BYTES, kept_graph  # noqa: F401
from energy_planner.problem import takes_problem
from energy_planner.results import Result, path_first

__all__ = ["ReachMap", "battery_area", "least_energy", "reach", "NODATA"]

#: Nodata value of the written GeoTIFF.
NODATA = float("nan")  # the project's one raster nodata (energy_planner.io)


@takes_problem(1)
def least_energy(
    problem,
    start_xy: tuple[float, float],
    *,
    step: float,
    n_headings: int = 16,
    round_trip: bool = False,
    turn_at_cell: bool = True,
    moves: str = "all",
    progress: bool = False,
    max_energy: float = math.inf,
    tree: bool = False,
) -> tuple:
    """Least energy from ``start_xy`` (any initial heading) to every search position.

    The one boundary between :func:`reach` and the search (priced by ``problem.cost``,
    :class:`~energy_planner.problem.Problem`; the older form ``least_energy(cost,
    terrain, start_xy, ...)`` is accepted). One way: the planner's own
    full-resolution search without a goal
    (:func:`energy_planner.planning.search.reach_search`). Round trip: the lattice graph
    with the same move set ``moves`` and edge costs, searched forwards and backwards
    (scipy's Dijkstra on the graph and its transpose, so every edge keeps the price of
    its true direction): ``min over h of (to[p, h] + back[p, h])`` with
    ``turn_at_cell``, else ``min_h to[p, h] + min_h back[p, h]`` (headings free at the
    cell, as two ``plan`` calls). With ``max_energy`` finite each search stops there
    (exact for every position whose energy is at most ``max_energy``; others ``inf``).
    With ``tree`` (one way only) a fifth item: the tree of the least-energy paths
    (:attr:`energy_planner.planning.search.ReachResult.tree`; None for a round trip).

    Returns
    -------
    xs, ys : ndarray
        Position x and y coordinates (increasing).
    energy : ndarray, shape (len(ys), len(xs))
        Least energy, J (row ``j`` is ``ys[j]``); ``inf`` where unreachable.
    search : str
        Which search produced it.
    """
    cost, terrain = problem.cost, problem.terrain
    if not round_trip:
        from energy_planner.planning.search import reach_search

        res = reach_search(
            cost, terrain, (start_xy[0], start_xy[1], None), step=step, n_headings=n_headings,
            moves=moves, progress=progress, max_energy=max_energy, tree=tree,
        )  # fmt: skip
        out = (res.xs, res.ys, res.energy, "planner's search (reach_search), no goal")
        return (*out, res.tree) if tree else out
    from scipy.sparse.csgraph import dijkstra

    lat = kept_graph(problem, start_xy, step, n_headings, moves)  # kept: see _GRAPHS
    graph, xs, ys, valid = lat.graph, lat.xs, lat.ys, lat.valid
    H = int(n_headings)
    p0 = int(np.argmin(np.abs(ys - start_xy[1]))) * len(xs) + int(
        np.argmin(np.abs(xs - start_xy[0]))
    )
    hs = np.nonzero(valid[p0])[0]
    if hs.size == 0:
        raise InvalidStateError(
            f"start ({start_xy[0]:.2f}, {start_xy[1]:.2f}) breaks a limit at every heading",
            endpoint="start", value=tuple(start_xy),
        )  # fmt: skip
    sources = p0 * H + hs
    lim = float(max_energy) if math.isfinite(max_energy) else np.inf
    kw = {"directed": True, "indices": sources, "min_only": True, "limit": lim,
          "return_predecessors": tree}  # fmt: skip
    to = dijkstra(graph, **kw)
    back = dijkstra(graph.T.tocsr(), **kw)
    if tree:
        (to, to_pred, _), (back, back_pred, _) = to, back
    to, back = to.reshape(-1, H), back.reshape(-1, H)
    if turn_at_cell:
        h_to = h_back = np.argmin(to + back, axis=1)
        e = (to + back)[np.arange(to.shape[0]), h_to]
    else:
        h_to, h_back = np.argmin(to, axis=1), np.argmin(back, axis=1)
        e = to.min(axis=1) + back.min(axis=1)
    e[e > max_energy] = np.inf
    out = (xs, ys, e.reshape(len(ys), len(xs)),
           f"lattice graph (moves={moves!r}), forward + backward Dijkstra")  # fmt: skip
    if not tree:
        return out
    from energy_planner.planning._pathtree import parent_tree

    pos = np.arange(e.size)
    legs = []
    for pred, hb, back_leg in ((to_pred, h_to, False), (back_pred, h_back, True)):
        best = np.where(np.isfinite(e), pos * H + hb, -1).astype(np.int64)
        states, parent, at = parent_tree(np.asarray(pred, np.int64), best)
        legs.append({"states": states, "parent": parent, "at": at, "back": back_leg})
    paths = {"legs": legs, "xs": xs, "ys": ys, "headings": np.asarray(lat.headings, float)}
    return (*out, paths)


@dataclass(repr=False)
class ReachMap(Result):
    """Least energy from a start to every cell of the terrain's working grid.

    Attributes
    ----------
    energy_j : ndarray, shape (rows, cols)
        On the terrain's working grid (row 0 north); NaN where the DEM has no data or
        the cell cannot be reached.
    start : tuple of float
        The start used (the centre of the start's cell), working CRS.
    round_trip : bool
        Whether ``energy_j`` is the cost of going and coming back.
    step : float
        Search spacing, m.
    info : dict
        Search details (time, states).
    battery : dict or None
        Given a battery (``reach(..., battery_wh=...)``): the battery's verdict on the
        map, :func:`battery_area` (the largest predicted energy reached with the required
        chance, and the cells and area within it).
    time_s : ndarray or None
        With ``reach(..., max_time=)``: the least time to each cell (s; round trip: to
        go and come back) within that bound, NaN beyond; ``info["time_bound"]`` the bound,
        the top speed and the yaw rate it was priced at.
    budget_wh : float or None
        The budget the map is read against (``ep.reach(..., budget_wh=)``): the default
        of :meth:`to_dict`, and with :attr:`battery` of the area, contour and GeoJSON
        (:attr:`budget_j`).
    problem : Problem or None
        The terrain, model and request it was computed on
        (:class:`~energy_planner.results.Result`): the writers need no terrain.
    domain : dict or None
        With a model that records its calibration domain: the map's domain summary
        (:func:`domain_summary`: the domain, per quantity and per reason the reached
        cells whose least-energy path leaves it, their share; with a budget or a battery
        the same within it). None for a model without a domain.
    outside_share : ndarray or None
        Per cell the share of its least-energy path's duration outside the domain (0-1,
        per metre walked, as :func:`energy_planner.uncertainty.domain.path_domain`
        reports a path; NaN where unreached). One way only: a round trip's cells carry
        none (:attr:`domain` says so).
    outside_m : ndarray or None
        Per cell the metres of its path outside the domain.
    shares, excess : dict
        Per quantity a raster: the share of the path's duration outside it, and (numeric
        ranges: slope, speed, numeric channels, the mean power) the distance beyond the
        range averaged over the duration, what the fit's measured error growth widens
        by (:meth:`energy_planner.uncertainty.ErrorModel.outside`).
    duration_s : ndarray or None
        Per cell its least-energy path's duration, s (the error model's input).
    """

    energy_j: np.ndarray
    start: tuple[float, float]
    round_trip: bool
    step: float
    info: dict[str, Any] = field(default_factory=dict)
    battery: dict[str, Any] | None = field(default=None, repr=False)
    budget_wh: float | None = None
    time_s: np.ndarray | None = field(default=None, repr=False)
    domain: dict[str, Any] | None = field(default=None, repr=False)
    outside_share: np.ndarray | None = field(default=None, repr=False)
    outside_m: np.ndarray | None = field(default=None, repr=False)
    shares: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    excess: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    duration_s: np.ndarray | None = field(default=None, repr=False)

    @property
    def budget_j(self) -> float | None:
        """The budget the area is drawn at, J.

        With a battery, the energy reached with the required chance
        (``battery["confident_budget_wh"]``), else :attr:`budget_wh`.
        """
        if self.battery is not None:
            return float(self.battery["confident_budget_wh"]) * 3600.0
        return None if self.budget_wh is None else float(self.budget_wh) * 3600.0

    def write_json(self, path: str | Path, terrain: Any = None) -> Path:
        """Write :meth:`to_dict` to ``path`` atomically; returns the path."""
        from energy_planner.io import write_json

        return write_json(path, self.to_dict(terrain))

    def to_dict(self, terrain: Any = None, budget_wh: float | None = None) -> dict[str, Any]:
        """JSON-ready summary: the start (DEM CRS), the reachable cells and their energy.

        With ``budget_wh`` (default :attr:`budget_wh`): the cells and area within it; with
        a battery, its record (:attr:`battery`); a warning per budget whose area the map's
        edge (or nodata) cuts (``warnings``, ``edge_cut``).
        """
        terrain = self._terrain(terrain)
        budget_wh = self.budget_wh if budget_wh is None else budget_wh
        wh = self.energy_j / 3600.0
        finite = wh[np.isfinite(wh)]
        sx, sy = terrain.from_work(*self.start)
        out: dict[str, Any] = {
            "start": [float(sx), float(sy)],
            "round_trip": self.round_trip,
            "turn_at_cell": self.info.get("turn_at_cell"),
            "reachable_cells": int(finite.size),
            "min_wh": float(finite.min()),
            "median_wh": float(np.median(finite)),
            "max_wh": float(finite.max()),
            "budget_wh": budget_wh,
            "search": self.info["search"],
            "time_s": self.info["time_s"],
        }
        if "window" in self.info:
            out["window"] = {k: v for k, v in self.info["window"].items() if k != "log"}
        if "speed" in self.info:
            out["speed"] = dict(self.info["speed"])
        if "time_bound" in self.info and self.time_s is not None:
            t = self.time_s[np.isfinite(self.energy_j)]
            far = float(t.max()) if t.size else None
            out["time_bound"] = {**self.info["time_bound"], "least_time_max_s": far}
        if budget_wh is not None:
            out["budget_cells"] = int(self.mask(budget_wh * 3600.0).sum())
            out["budget_area_m2"] = float(self.area(terrain, budget_wh * 3600.0).area)
        if self.battery is not None:
            out["battery"] = dict(self.battery)
        if self.domain is not None:
            out["domain"] = dict(self.domain)
            if budget_wh is not None and self.outside_share is not None:
                m = self.mask(budget_wh * 3600.0)
                with np.errstate(invalid="ignore"):
                    far = int((m & (self.outside_share > 0)).sum())
                out["domain"]["within_budget"] = {"budget_wh": budget_wh, "cells": int(m.sum()),
                                                  "outside_cells": far}  # fmt: skip
            if self.battery is not None and "outside_cells" in self.battery:
                b = self.battery
                out["domain"]["confident"] = {"confidence": b["confidence"], "cells": b["cells"],
                                              "outside_cells": b["outside_cells"]}  # fmt: skip
        budgets = [budget_wh, (self.battery or {}).get("confident_budget_wh")]
        for b in sorted({b for b in budgets if b is not None}):
            w = self.edge_warning(terrain, b * 3600.0)
            if w is not None:
                out.setdefault("warnings", []).append(str(w))
                out.setdefault("edge_cut", []).append(
                    {"budget_wh": b, **{k: w.fields[k] for k in ("cells", "map_edge_cells",
                                                                "nodata_edge_cells")}}
                )  # fmt: skip
        return out

    def mask(self, budget_j: float) -> np.ndarray:
        """Cells reachable within ``budget_j`` joules."""
        with np.errstate(invalid="ignore"):
            return np.isfinite(self.energy_j) & (self.energy_j <= budget_j)

    def edge_cells(self, terrain, budget_j: float) -> dict[str, int]:
        """Cells reached within ``budget_j`` that touch the edge of the map or of its nodata.

        A cell touches an edge when one of its eight neighbours is off the grid or has no
        slope (no data, or the ring of cells at the DEM's border where Horn's gradient is
        not defined). Nodata connected to the outside of the grid (a lon/lat DEM's margins
        on the working grid included) counts as the map's edge; the rest as nodata.
        Limits (slope, keep-out) are walls the robot really meets and do not count.

        Returns
        -------
        dict
            ``cells`` (either kind), ``map_edge_cells``, ``nodata_edge_cells``.
        """
        from scipy import ndimage

        reached = self.mask(budget_j)
        empty = np.pad(~np.isfinite(terrain.slope), 1, constant_values=True)
        labels, _ = ndimage.label(empty)
        outside = np.isin(labels, np.unique(labels[0]))[1:-1, 1:-1]
        hole = empty[1:-1, 1:-1] & ~outside
        ring = np.ones((3, 3), bool)

        def near(m: np.ndarray, off_grid: bool) -> np.ndarray:
            padded = np.pad(m, 1, constant_values=off_grid)
            return ndimage.binary_dilation(padded, structure=ring)[1:-1, 1:-1]

        # a neighbour off the grid is the map's edge, never a hole
        at_map, at_hole = reached & near(outside, True), reached & near(hole, False)
        return {
            "cells": int((at_map | at_hole).sum()),
            "map_edge_cells": int(at_map.sum()),
            "nodata_edge_cells": int(at_hole.sum()),
        }

    def edge_warning(self, terrain, budget_j: float) -> ReachEdgeWarning | None:
        """A :class:`ReachEdgeWarning` if the area within ``budget_j`` meets an edge, else None.

        See :meth:`edge_cells`. :func:`reach` issues it when given ``max_energy``; the
        ``reach`` command prints it for each budget it reports.
        """
        from energy_planner.errors import fmt_num

        e = self.edge_cells(terrain, budget_j)
        if not e["cells"]:
            return None
        kinds = []
        if e["map_edge_cells"]:
            kinds.append(f"the map's edge ({e['map_edge_cells']} cells)")
        if e["nodata_edge_cells"]:
            kinds.append(f"its nodata ({e['nodata_edge_cells']} cells)")
        return ReachEdgeWarning(
            f"{e['cells']} cells reached within {fmt_num(budget_j / 3600.0, 4)} Wh touch "
            f"{' and '.join(kinds)}: the map ends there, so the area reachable within the "
            "budget may be larger than reported; give a DEM that covers it (or fill the "
            "nodata) to see all of it",
            budget_j=float(budget_j), **e,
        )  # fmt: skip

    def area(self, terrain, budget_j: float | None = None, *, mask: Any = None):
        """The area reachable within ``budget_j`` (or the cells of ``mask``).

        A shapely (Multi)Polygon of whole cells, in the working CRS.
        """
        from rasterio import features
        from shapely.geometry import shape
        from shapely.ops import unary_union

        m = self.mask(budget_j) if mask is None else np.asarray(mask, bool)
        polys = [
            shape(geom)
            for geom, v in features.shapes(
                m.astype(np.uint8), mask=m, transform=terrain.transform, connectivity=8
            )
            if v == 1
        ]
        return unary_union(polys)

    def area_geojson(
        self, terrain: Any = None, budget_j: float | None = None, *, native: bool = False
    ) -> dict[str, Any]:
        """A GeoJSON FeatureCollection with the area reachable within ``budget_j``.

        RFC 7946 (longitude, latitude; what QGIS, geopandas and web maps expect) by
        default; ``native=True`` writes the DEM's own CRS and declares it with the
        ``crs`` member (:func:`energy_planner.io.feature_collection`). ``budget_j``:
        default :attr:`budget_j`; with a battery whose decision is per cell (the cells'
        domain reports widen their chances, :func:`battery_area`) and no ``budget_j``, the
        cells reached with the required chance (``battery["cells"]``).
        """
        from shapely.ops import transform as shp_transform

        from energy_planner.io import crs_name, feature_collection

        terrain = self._terrain(terrain)
        mask = None
        if budget_j is None and self.battery is not None and "decision" in self.battery:
            model, usable_j = self._battery_inputs(None, None)
            with np.errstate(invalid="ignore"):
                mask = self.chance(model, usable_j) >= self.battery["confidence"]
        budget_j = self.budget_j if budget_j is None else budget_j
        if budget_j is None:
            raise ValueError("no budget: give budget_j (or reach with budget_wh or battery_wh)")

        work = self.area(terrain, budget_j, mask=mask)
        geom, crs = work, terrain.crs
        if native and str(terrain.source_crs) != str(terrain.crs):
            geom = shp_transform(lambda x, y: terrain.from_work(x, y), work)
            crs = terrain.source_crs
        props = {
            "budget_j": budget_j,
            "budget_wh": budget_j / 3600.0,
            "round_trip": self.round_trip,
            "area_m2": float(work.area),
            "cells": int((self.mask(budget_j) if mask is None else mask).sum()),
            "dem_crs": crs_name(terrain.source_crs),
        }
        return feature_collection([(geom, props)], crs=crs, native=native)

    def write_geojson(
        self,
        path: str | Path,
        terrain: Any = None,
        *,
        budget_j: float | None = None,
        native: bool = False,
    ) -> Path:
        """Write :meth:`area_geojson` (the area within the budget) to ``path`` atomically."""
        from energy_planner.io import write_geojson

        path, terrain = path_first(path, terrain)
        doc = self.area_geojson(terrain, budget_j, native=native)
        return write_geojson(path, doc, indent=None)

    def write_geotiff(self, path: str | Path, terrain: Any = None) -> Path:
        """Write ``energy_j`` (J, float32, nodata NaN) on the DEM's grid and CRS.

        A DEM in longitude/latitude gets the working grid's values resampled to its own
        grid (nearest cell).
        """
        path, terrain = path_first(path, terrain)
        what = "go and come back" if self.round_trip else "reach"
        return self._write(terrain, path, self.energy_j, "energy_j", "J",
                           f"least energy to {what} the cell from the start, J")  # fmt: skip

    def chance(self, model, usable_j: float) -> np.ndarray:
        """Per cell, the chance that going there (and back) fits in ``usable_j`` joules.

        The model's error model when it has one
        (:meth:`energy_planner.uncertainty.errormodel.ErrorModel.probability`), else
        :func:`energy_planner.uncertainty.success_probability` of each cell's energy from
        the relative held-out run errors; NaN where the cell cannot be reached. With the
        cells' domain reports (:attr:`outside_share`) each cell is widened as its path's
        interval is (:meth:`widening`: the measured growth beyond each range, the fitted
        ``d`` or the assumed factor, its path's duration) and a cell whose widening is
        not calibrated gets no chance: NaN (:attr:`battery` counts it as refused).
        Without an error model the relative errors are not widened and every cell whose
        path leaves the domain is refused. Without reports (a model without a domain, a
        round trip) the duration is the energy over the held-out runs' mean power.
        """
        from energy_planner.uncertainty import BatteryError, model_error_model, model_scores

        em = model_error_model(model)
        e = self.energy_j
        ok = np.isfinite(e)
        w = self.widening(model)
        out = np.full(e.shape, np.nan)
        if em is not None:
            if w is None:
                out[ok] = em.probability(e[ok], usable_j)
            else:
                dur = None if self.duration_s is None else self.duration_s[ok]
                out[ok] = em.probability(e[ok], usable_j, dur, w.share[ok],
                                         w.extra_rel_var[ok], w.assumed_share[ok])  # fmt: skip
        else:
            s = model_scores(model)
            if s is None:
                raise BatteryError("the model carries no held-out run errors: refit it with "
                                   "cross-validation (energy-planner fit --folds 5)")  # fmt: skip
            with np.errstate(invalid="ignore", divide="ignore"):
                count = s.size - np.searchsorted(s, e / usable_j - 1.0, side="left")
                out = np.where(ok, count / (s.size + 1.0), np.nan)
        if w is not None:
            out[w.refused] = np.nan
        return out

    def interval(self, level: float = 0.9, model: Any = None) -> tuple[np.ndarray, np.ndarray]:
        """Per cell the interval on the true energy at ``level``: ``(low_j, high_j)``, J.

        Each cell's as :func:`energy_planner.uncertainty.predict_interval` gives its
        least-energy path's: the fit's error model at the path's duration, widened by its
        domain report (:meth:`widening`; where :meth:`widening` says ``refused`` the
        widening is the assumed factor, not calibrated); without an error model the
        relative held-out run errors, widened by the share outside. NaN where the cell is
        not reached. ``model``: default the model it was computed with.

        Raises
        ------
        BatteryError
            The model carries neither an error model nor held-out run errors.
        """
        from energy_planner.uncertainty import (
            OUTSIDE_WIDENING,
            BatteryError,
            conformal_bounds,
            model_error_model,
            model_scores,
        )

        model = self._battery_inputs(model, None)[0]
        e = self.energy_j
        ok = np.isfinite(e)
        low, high = np.full(e.shape, np.nan), np.full(e.shape, np.nan)
        em = model_error_model(model)
        w = self.widening(model)
        if em is not None:
            dur = None if self.duration_s is None else self.duration_s[ok]
            more = () if w is None else (w.share[ok], w.extra_rel_var[ok], w.assumed_share[ok])
            low[ok], high[ok] = em.bounds(e[ok], level, dur, *more)
            return low, high
        s = model_scores(model)
        if s is None:
            raise BatteryError("the model carries no held-out run errors: refit it with "
                               "cross-validation (energy-planner fit --folds 5)")  # fmt: skip
        # predict_interval scales every score by (1 + W share), kept above -0.9: both
        # keep the scores' order, so its bounds are the scaled bounds
        r_lo, r_hi = conformal_bounds(s, level)
        share = 0.0 if self.outside_share is None else np.nan_to_num(self.outside_share[ok])
        f = 1.0 + OUTSIDE_WIDENING * share
        low[ok] = e[ok] / (1.0 + np.maximum(r_hi * f, -0.9))
        high[ok] = e[ok] / (1.0 + np.maximum(r_lo * f, -0.9))
        return low, high

    def widening(self, model: Any = None) -> Any:
        """How each cell's domain report widens its chance, or None without reports.

        :func:`energy_planner.uncertainty.errormodel.outside_cells` of the cells'
        :attr:`shares` and :attr:`excess` with the model's error model (default: the
        Problem's model): per cell the extra relative variance, the share the fitted
        ``d`` (or the assumed factor) widens, the assumed share of a mean power beyond the
        runs', and ``refused`` (no battery decision) with why.
        """
        from energy_planner.uncertainty import model_error_model
        from energy_planner.uncertainty.errormodel import outside_cells

        if self.outside_share is None:
            return None
        if model is None and self.problem is not None:
            model = self.problem.model
        w = outside_cells(model_error_model(model), self.shares, self.excess)
        reached = np.isfinite(self.energy_j)
        refused = w.refused & reached & np.isfinite(self.outside_share)
        return type(w)(w.extra_rel_var, w.share, w.assumed_share, refused,
                       {k: v & refused for k, v in w.why.items()})  # fmt: skip

    def write_chance_geotiff(
        self, path: str | Path, terrain: Any = None, model: Any = None, usable_j: Any = None
    ) -> Path:
        """Write :meth:`chance` (0-1, float32, nodata NaN) on the DEM's grid and CRS.

        ``model`` and ``usable_j``: default the model it was computed with and the
        battery's usable energy (:attr:`battery`).
        """
        path, terrain = path_first(path, terrain)
        model, usable_j = self._battery_inputs(model, usable_j)
        if usable_j is None:
            raise ValueError("no battery: give usable_j (or reach with battery_wh)")
        what = "go there and come back" if self.round_trip else "reach the cell"
        return self._write(terrain, path, self.chance(model, usable_j), "chance", "1",
                           f"chance to {what} within {usable_j / 3600:.2f} Wh usable")  # fmt: skip

    def write_domain_geotiff(self, path: str | Path, terrain: Any = None) -> Path:
        """Write :attr:`outside_share` (0-1, float32, nodata NaN) on the DEM's grid and CRS.

        Raises
        ------
        ValueError
            The map has no per-cell domain report (its model records no calibration
            domain).
        """
        path, terrain = path_first(path, terrain)
        if self.outside_share is None:
            raise ValueError("no domain report: the model records no calibration domain "
                             "(metadata.fit.domain)")  # fmt: skip
        return self._write(terrain, path, self.outside_share, "outside_share", "1",
                           "share of the least-energy path's duration outside the "
                           "calibration's ranges")  # fmt: skip

    def _battery_inputs(self, model: Any, usable_j: Any) -> tuple[Any, Any]:
        """``model`` and ``usable_j``, by default the Problem's model and the battery's."""
        if model is None and self.problem is not None:
            model = self.problem.model
        if usable_j is None and self.battery is not None:
            usable_j = float(self.battery["usable_wh"]) * 3600.0
        return model, usable_j

    def _write(self, terrain, path, values, name: str, unit: str, desc: str) -> Path:
        from energy_planner.io import write_geotiff

        terrain = self._terrain(terrain)

        data = np.where(np.isfinite(values), values, NODATA).astype(np.float32)
        transform, crs = terrain.transform, terrain.crs
        if str(terrain.source_crs) != str(terrain.crs):
            from rasterio.warp import Resampling, reproject

            out = np.full(tuple(terrain.source_shape), NODATA, np.float32)
            reproject(
                data, out, src_transform=terrain.transform, src_crs=terrain.crs,
                dst_transform=terrain.source_transform, dst_crs=terrain.source_crs,
                src_nodata=NODATA, dst_nodata=NODATA, resampling=Resampling.nearest,
            )  # fmt: skip
            data, transform, crs = out, terrain.source_transform, terrain.source_crs
        return write_geotiff(
            Path(path), data, transform=transform, crs=crs, names=[name], units=[unit],
            descriptions=[desc], band_tags=[{"round_trip": self.round_trip}],
            tags={"software": "energy_planner reach"},
        )  # fmt: skip

    def write_html(
        self,
        path: str | Path,
        terrain: Any = None,
        budget_j: float | None = None,
        *,
        model: Any = None,
        usable_j: float | None = None,
    ) -> Path:
        """One self-contained HTML page (:func:`energy_planner.webmap.reach_page`).

        The energy to every cell (Wh), the contour of ``budget_j`` (default
        :attr:`budget_j`) and, with a battery (or ``model`` and ``usable_j``), the chance
        the battery suffices to each cell (:meth:`chance`).
        """
        from energy_planner.webmap import reach_page

        path, terrain = path_first(path, terrain)
        terrain = self._terrain(terrain)
        budget_j = self.budget_j if budget_j is None else budget_j
        model, usable_j = self._battery_inputs(model, usable_j)
        chance = None if model is None or usable_j is None else self.chance(model, usable_j)
        return reach_page(terrain, self, path, budget_j, chance)

    def plot(
        self,
        path: str | Path,
        terrain: Any = None,
        budget_j: float | None = None,
        request: Any = None,
    ) -> Path:
        """PNG: energy (Wh) over a hillshade, the budget contour and the start.

        ``budget_j``: default :attr:`budget_j`. The request it was computed with (or
        ``request``) adds its keep-outs, slope-limit mask and channel rasters
        (:func:`energy_planner.plotting.draw_request`). The map is drawn in the DEM's own
        CRS (:class:`energy_planner.plotting.MapFrame`: degrees for a longitude/latitude
        DEM, the energies resampled onto its grid), its axes named with their units.
        """
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from energy_planner.plotting import MapFrame, draw_request

        path, terrain = path_first(path, terrain)
        terrain, request = self._terrain(terrain), self._request(request)
        budget_j = self.budget_j if budget_j is None else budget_j
        path = Path(path)
        frame = MapFrame(terrain)
        extent = frame.extent
        fig, ax = plt.subplots(figsize=(8, 7))
        ax.imshow(frame.hillshade(), cmap="gray", extent=extent, origin="upper")
        wh = frame.raster(self.energy_j / 3600.0)
        im = ax.imshow(wh, cmap="viridis", extent=extent, origin="upper", alpha=0.6)
        fig.colorbar(
            im, ax=ax, shrink=0.8,
            label="energy to go and come back, Wh" if self.round_trip else "energy to reach, Wh",
        )  # fmt: skip
        if budget_j is not None and np.isfinite(wh).any() and np.nanmin(wh) < budget_j / 3600:
            if frame.reprojected:
                xc, yc = frame.centres()
            else:
                x0, y0, dx, dy = terrain.grid
                rows, cols = self.energy_j.shape
                xc, yc = x0 + dx * np.arange(cols), y0 + dy * np.arange(rows)
            budget = ax.contour(
                xc, yc, np.where(np.isfinite(wh), wh, np.nanmax(wh) * 2),
                levels=[budget_j / 3600.0], colors="red", linewidths=2,
            )  # fmt: skip
            budget.set_gid("budget")
            ax.plot([], [], color="red", lw=2, label=f"budget {budget_j / 3600:.1f} Wh")
        draw_request(ax, frame, request)
        ax.plot(*frame.xy(*self.start[:2]), "o", color="white", mec="k", ms=9, label="start")
        ax.set_xlim(extent[0], extent[1])
        ax.set_ylim(extent[2], extent[3])
        ax.ticklabel_format(useOffset=False, style="plain")
        frame.finish(ax)
        ax.set_title("Battery reach" + (" (out and back)" if self.round_trip else ""))
        ax.legend(loc="lower left", fontsize=8)
        fig.tight_layout()
        from energy_planner.io import save_figure

        save_figure(fig, path, dpi=120)
        plt.close(fig)
        return path


@takes_problem(1)
def reach(
    problem,
    start: Sequence[float],
    *,
    round_trip: bool = False,
    turn_at_cell: bool = True,
    n_headings: int = 16,
    progress: bool = False,
    max_energy: float | None = None,
    max_time: float | None = None,
    **trust: Any,
) -> ReachMap:
    """Least energy from ``start`` to every cell (or to go there and back).

    Parameters
    ----------
    problem : Problem
        Terrain (the result is on its working grid), model and request (robot, limits,
        channels) bound once (:class:`energy_planner.problem.Problem`; the older form
        ``reach(terrain, model, start, request=None, ...)`` is accepted).
    start : sequence of float
        ``(x, y)`` in the working CRS; moved to the centre of its cell.
    round_trip : bool
        Cost of going to each cell and back to the start.
    turn_at_cell : bool
        Round trip only. True (default): the robot leaves the cell with the heading it
        arrived with, so turning round there (or walking back backwards or crabbing) is
        paid. False: each leg's heading at the cell is free, as two ``plan`` calls with
        no yaw at the cell (``plan(start, cell) + plan(cell, start)``); lower by at most
        one turn in place at the cell.
    n_headings : int
        Search headings.
    progress : bool
        Progress bar on stderr (one-way search).
    max_energy : float, optional
        Search only as far as this energy, J (a budget): exact for every cell within it,
        the others NaN; much faster than the whole map when the budget is small.
    max_time : float, optional
        Seconds: only the cells some path reaches (and leaves, round trip) within this
        time, the others NaN. The least time to each cell is the same search priced in
        seconds (:meth:`~energy_planner.problem.Problem.duration`: every translation at
        the top of the problem's speed range, or at its fixed speed; turns at the yaw
        rate); it is :attr:`ReachMap.time_s`. Each kept cell's energy stays the least
        energy (each motion at its best speed where the problem has a speed range,
        :meth:`~energy_planner.problem.Problem.with_speed`); the path of least energy may
        itself take longer than ``max_time``, and arriving in time may then cost more.
    **trust
        ``battery_wh``, ``reserve_wh``, ``confidence`` (and ``level``;
        :class:`~energy_planner.trust.Trust`, or ``trust=`` one): with a battery, the
        result's :attr:`ReachMap.battery` (:func:`battery_area`).

    Returns
    -------
    ReachMap

    Raises
    ------
    InvalidStateError
        If the start is outside the map or breaks a limit.

    Warns
    -----
    ReachEdgeWarning
        With ``max_energy``: cells reached within it touch the edge of the map or of its
        nodata, so the area within the budget is cut there (:meth:`ReachMap.edge_cells`).
    """
    from energy_planner.planning.limits import check_endpoint, fmt_xy
    from energy_planner.planning.plan import _pose
    from energy_planner.trust import Trust

    want = Trust.pop(trust)
    if trust:
        raise TypeError(f"reach() got unexpected keyword(s) {', '.join(trust)}")
    terrain = problem.terrain
    sx, sy, _ = _pose(start, "start")
    x0, y0, dx, dy = terrain.grid
    rows, cols = terrain.shape
    # floor(v + 0.5), not round(): a start on a cell edge picks the same cell in every
    # window of the grid (round() sends ties to the even index, which depends on the window)
    c = math.floor((sx - x0) / dx + 0.5)
    r = math.floor((sy - y0) / dy + 0.5)
    if not (0 <= r < rows and 0 <= c < cols):
        from energy_planner.errors import extent_text

        sb = terrain.source_bounds
        raise InvalidStateError(
            f"start {fmt_xy(terrain, sx, sy)} is outside the map, which covers "
            f"{extent_text(sb, terrain.source_crs)}",
            endpoint="start", value=(sx, sy), limit="map", bounds=sb, crs=str(terrain.source_crs),
        )  # fmt: skip
    s = (x0 + c * dx, y0 + r * dy)
    cost = problem.cost
    check_endpoint(cost, terrain, "start", (s[0], s[1], None), problem.keep_out)
    cost.compile()
    t0 = time.perf_counter()
    step = abs(float(dx))
    if abs(abs(dy) - step) > 1e-9 * step:
        raise PlanningError(f"reach needs square cells; the working grid has {dx} x {-dy} m")
    from energy_planner.uncertainty.domain import domain_of

    dom = domain_of(problem.model)
    xs, ys, grid, search, *paths = least_energy(
        problem, s, step=step, n_headings=n_headings, round_trip=round_trip,
        turn_at_cell=turn_at_cell, progress=progress,
        max_energy=math.inf if max_energy is None else float(max_energy),
        tree=dom is not None,
    )  # fmt: skip
    # lattice positions are cell centres: map them to (row, col)
    ci = np.rint((xs - x0) / dx).astype(int)
    ri = np.rint((ys - y0) / dy).astype(int)
    out = np.full((rows, cols), np.nan)
    out[np.ix_(ri, ci)] = grid
    out[~np.isfinite(out)] = np.nan
    times, bound = None, None
    if max_time is not None:
        times, bound = _least_time(problem, s, step, n_headings, round_trip, turn_at_cell,
                                   float(max_time))  # fmt: skip
        out[~(times <= max_time)] = np.nan
    res = ReachMap(
        energy_j=out,
        start=s,
        round_trip=round_trip,
        step=step,
        info={"search": search, "states": int(grid.size * n_headings),
              "turn_at_cell": bool(turn_at_cell) if round_trip else None,
              "time_s": time.perf_counter() - t0},
        time_s=times,
    )  # fmt: skip
    if dom is not None:
        t1 = time.perf_counter()
        cells = path_domains(problem, paths[0], dom, ri, ci, (rows, cols), np.isfinite(out))
        res.outside_share = cells.pop("outside_share")
        res.excess = cells.pop("excess")
        res.shares = cells.pop("shares")
        res.duration_s = cells.pop("duration_s")
        res.outside_m = cells.pop("outside_m")
        res.domain = cells.pop("summary")
        res.info["domain_s"] = time.perf_counter() - t1
        res.info["time_s"] = time.perf_counter() - t0
    if bound is not None:
        res.info["time_bound"] = bound
    if cost.speed_range is not None:
        res.info["speed"] = {"speed_range": list(cost.speed_range),
                             "speed_law": cost.speed_law.note}  # fmt: skip
    if want.battery_wh is not None:
        res.battery = battery_area(res, terrain, problem.model, want)
    if max_energy is not None and math.isfinite(max_energy):
        w = res.edge_warning(terrain, max_energy)
        if w is not None:
            warnings.warn(w, stacklevel=2)
    res.problem = problem
    return res


def _least_time(problem, s, step, n_headings, round_trip, turn_at_cell, max_time):
    """The least time (s) to each cell within ``max_time``, and the bound's record.

    :func:`least_energy` of :meth:`~energy_planner.problem.Problem.duration` at the top
    speed (of the range, or the fixed speed), searched only as far as ``max_time``.
    """
    from energy_planner.errors import PlanningConfigError

    if not (math.isfinite(max_time) and max_time > 0):
        raise PlanningConfigError(f"max_time must be > 0 seconds, got {max_time!r}",
                                  value=max_time, param="max_time")  # fmt: skip
    cost = problem.cost
    top = cost.speed_range[1] if cost.speed_range is not None else cost.speed
    terrain = problem.terrain
    x0, y0, dx, dy = terrain.grid
    xs, ys, grid, _ = least_energy(
        problem.duration(top), s, step=step, n_headings=n_headings, round_trip=round_trip,
        turn_at_cell=turn_at_cell, max_energy=max_time,
    )  # fmt: skip
    times = np.full(terrain.shape, np.nan)
    ci = np.rint((xs - x0) / dx).astype(int)
    ri = np.rint((ys - y0) / dy).astype(int)
    times[np.ix_(ri, ci)] = grid
    times[~np.isfinite(times)] = np.nan
    bound = {"max_time_s": max_time, "top_speed_m_s": float(top),
             "yaw_rate_rad_s": float(cost.yaw_rate)}  # fmt: skip
    return times, bound


def battery_area(res: ReachMap, terrain: Any, model: Any, trust: Any) -> dict[str, Any]:
    """A battery's verdict on a reach map: what is reached with the required chance.

    :func:`energy_planner.uncertainty.confident_budget` of the usable energy (battery
    less reserve) at ``trust.confidence``: the largest predicted energy whose chance of
    fitting is at least that; the cells (and their area) within it. With the cells'
    domain reports (a model with a calibration domain, one way) the cells and area are
    those whose own chance (:meth:`ReachMap.chance`, widened by its path's domain) is at
    least the confidence; ``refused_cells`` the reached cells given no battery decision
    (their path leaves the domain where the error growth was not measured, or lies
    beyond the calibration runs' mean power) and ``refused`` how many for each reason.

    Raises
    ------
    BatteryError
        The model carries no held-out run errors, or the reserve is not below the battery.
    """
    from energy_planner.uncertainty import BatteryError, confident_budget

    if not trust.reserve_wh < trust.battery_wh:
        raise BatteryError(f"the reserve ({trust.reserve_wh:g} Wh) must be below the battery "
                           f"({trust.battery_wh:g} Wh)", value=trust.reserve_wh)  # fmt: skip
    usable = trust.usable_j
    budget_j = confident_budget(model, usable, trust.confidence)
    out = {
        "battery_wh": trust.battery_wh, "reserve_wh": trust.reserve_wh,
        "confidence": trust.confidence, "usable_wh": usable / 3600.0,
        "confident_budget_wh": budget_j / 3600.0, "cells": int(res.mask(budget_j).sum()),
        "area_m2": float(res.area(terrain, budget_j).area),
    }  # fmt: skip
    w = res.widening(model)
    if w is None:
        return out
    with np.errstate(invalid="ignore"):
        sure = res.chance(model, usable) >= trust.confidence
    out["cells"] = int(sure.sum())
    out["area_m2"] = float(res.area(terrain, mask=sure).area)
    with np.errstate(invalid="ignore"):
        out["outside_cells"] = int((sure & (res.outside_share > 0)).sum())
    out["refused_cells"] = int(w.refused.sum())
    out["refused"] = {k: int(v.sum()) for k, v in w.why.items() if v.any()}
    out["decision"] = ("per cell: its chance with its path's domain widening (cells and "
                       "area reached with the required chance); refused cells have "
                       "none")  # fmt: skip
    return out


def path_domains(problem, paths, dom, ri, ci, shape, reached) -> dict[str, Any]:
    """Each cell's calibration domain: the report of its least-energy path from the start.

    The report :func:`energy_planner.uncertainty.domain.path_domain` gives of a path,
    computed for every cell at once: each state on the tree of least-energy paths
    (``paths``, :attr:`energy_planner.planning.search.ReachResult.tree`) has one motion
    from its parent, priced by the kernel as :func:`energy_planner.energy.path_energy`
    prices a path's motions (durations, distances, turns, mean slope and relative
    heading) and sampled per metre as :func:`~energy_planner.uncertainty.domain.path_samples`
    samples them (slope, raster channels); its columns
    (:func:`~energy_planner.uncertainty.domain.segment_terms`: seconds and metres outside
    each range, the distance beyond it, the channel constants, the gaits) are summed from
    the start along the tree, and each cell's sums make its report
    (:meth:`~energy_planner.uncertainty.domain.SegmentTerms.report`), the mean power of its
    path included. The numbers are those of ``path_domain`` of the path ``plan`` finds to
    the cell on the same lattice, cut into its lattice motions.

    Parameters
    ----------
    problem : Problem
    paths : dict
        The tree (one way), or ``legs``: the tree of the paths there and the tree of the
        paths back (a round trip, the lattice graph's two searches; a cell's report is
        that of its path there followed by its path back).
    dom : dict
        The model's calibration domain.
    ri, ci : ndarray
        Row and column on the working grid of each search row and column.
    shape : tuple of int
        The working grid's shape.
    reached : ndarray of bool
        The cells the map keeps (finite energy).

    Returns
    -------
    dict
        ``outside_share`` (raster, NaN where unreached), ``excess`` and ``shares`` (per
        quantity a raster), ``duration_s`` (each cell's path's duration, s), ``summary``
        (:func:`domain_summary`).
    """
    nan = np.full(shape, np.nan)
    legs = paths.get("legs") or [{**paths, "back": False}]
    keys: list[Any] = []
    qs: list[str] = []
    per_leg = []
    for leg in legs:
        terms, cols, peaks = _leg_sums(problem, dom, paths, leg)
        keys += [k for k in terms.cols if k not in keys]
        qs += [q for q in terms.peaks if q not in qs]
        per_leg.append((terms, cols, peaks, leg["at"]))
    npos = per_leg[0][3].size
    sums = {k: np.zeros(npos) for k in keys}
    top = {q: np.zeros(npos) for q in qs}
    have_pos = np.ones(npos, bool)
    for _terms, cols, peaks, at in per_leg:
        ok = at >= 0
        have_pos &= ok
        for k in keys:
            if k in cols:
                sums[k][ok] += cols[k][at[ok]]
        for q in qs:
            if q in peaks:
                top[q][ok] = np.maximum(top[q][ok], peaks[q][at[ok]])
    # per cell of the working grid, its position's sums
    pos_grid = np.full(shape, -1, np.int64)
    pos_grid[np.ix_(ri, ci)] = np.where(have_pos, np.arange(npos), -1).reshape(
        len(paths["ys"]), len(paths["xs"]))  # fmt: skip
    pos_grid[~reached] = -1
    have = pos_grid >= 0
    k = pos_grid[have]
    rep = per_leg[0][0].report(dom, {key: v[k] for key, v in sums.items()},
                               {q: v[k] for q, v in top.items()})  # fmt: skip

    def raster(v: Any) -> np.ndarray:
        r = nan.copy()
        r[have] = v
        return r

    summary = domain_summary(rep, dom)
    if len(legs) > 1:
        summary["paths"] = ("each cell's least-energy round trip (its path there and its "
                            "path back, as the lattice graph's two searches find them), "
                            "counted per metre")  # fmt: skip
    return {
        "outside_share": raster(rep["outside_share"]),
        "excess": {q: raster(v) for q, v in rep["excess"].items()},
        "shares": {q: raster(v) for q, v in rep["shares"].items()},
        "duration_s": raster(sums["duration_s"][k]),
        "summary": summary,
        "outside_m": raster(rep["outside_m"]),
    }


def _leg_sums(problem, dom, paths, leg) -> tuple[Any, dict[Any, np.ndarray], dict[str, Any]]:
    """One tree's columns summed from its root: ``(terms, cols, peaks)`` per tree state.

    ``leg["back"]``: each state's motion goes from it to its parent (the way back to the
    start), else from its parent to it.
    """
    from energy_planner.planning._pathtree import prefix_sums
    from energy_planner.uncertainty.domain import motion_samples, segment_terms

    cost = problem.cost
    S, par = leg["states"], leg["parent"]
    H = len(paths["headings"])
    nx = len(paths["xs"])
    p, h = np.divmod(S, H)
    j, i = np.divmod(p, nx)
    b = np.column_stack([paths["xs"][i], paths["ys"][j], paths["headings"][h]])
    root = par < 0
    a = b[np.where(root, np.arange(S.size), par)]
    if leg["back"]:
        a, b = b, a
    segments, gaits = _motion_table(cost, a, b)
    channels = cost.channels
    if channels is not None and getattr(channels, "rasters", None):
        channels = channels.bind(problem.terrain)
    along = motion_samples(problem.terrain, a, b, channels)
    consts = None if channels is None else dict(channels.constants)
    terms = segment_terms(dom, segments, consts, gaits, None, along)
    keys, qs = list(terms.cols), list(terms.peaks)
    cols = np.column_stack([terms.cols[k] for k in keys]) if keys else np.zeros((S.size, 0))
    peaks = np.column_stack([terms.peaks[q] for q in qs]) if qs else np.zeros((S.size, 0))
    cols[root] = 0.0  # a start state: no motion
    peaks[root] = 0.0
    cols, peaks = np.ascontiguousarray(cols), np.ascontiguousarray(peaks)
    prefix_sums(np.ascontiguousarray(par, np.int64), cols, peaks)
    return (terms, {k: cols[:, c] for c, k in enumerate(keys)},
            {q: peaks[:, c] for c, q in enumerate(qs)})  # fmt: skip


def _motion_table(cost, a: np.ndarray, b: np.ndarray) -> tuple[dict[str, np.ndarray], Any]:
    """The kernel's segment columns of independent motions ``a[k] -> b[k]``, and their gaits.

    The motions are priced as one pose sequence ``a0, b0, a1, b1, ...`` by
    :meth:`~energy_planner.energy.MotionCost.details` (with a speed range, at the speeds
    and gaits :meth:`~energy_planner.energy.MotionCost.best_timing` chooses, as ``plan``
    times its path) and every other motion kept; the columns are those
    :func:`energy_planner.energy.path_energy` gives a path's segments.
    """
    from energy_planner.energy.path import _segment_table
    from energy_planner.uncertainty.domain import motion_gaits

    m = a.shape[0]
    seq = np.empty((2 * m, 3))
    seq[0::2], seq[1::2] = a, b
    x, y, th = seq[:, 0], seq[:, 1], seq[:, 2]
    durations = gaits = None
    if cost.ranged:
        durations, names = cost.best_timing(x, y, th)
        if names is not None:
            gaits = cost.gait_indices(names)
    out = cost.details(x, y, th, durations, gaits)[0::2]
    table = _segment_table(out, np.arange(m), m)
    return table, motion_gaits(table["distance_m"], table["turn_deg"], a, b)


def domain_summary(rep: dict[str, Any], dom: dict[str, Any]) -> dict[str, Any]:
    """A reach map's domain in a few numbers: per quantity and reason, the cells outside.

    ``rep``: the per-cell report (:meth:`~energy_planner.uncertainty.domain.SegmentTerms.report`
    with one value per reached cell).
    """
    share = np.asarray(rep["outside_share"], float)
    n = int(share.size)
    out = int(np.count_nonzero(share > 0))
    return {
        "domain": dict(dom),
        "paths": "each cell's least-energy path from the start, counted per metre",
        "reached_cells": n,
        "outside_cells": out,
        "outside_cell_share": round(out / n, 4) if n else 0.0,
        "quantities": {
            q: int(np.count_nonzero(np.asarray(v) > 0)) for q, v in rep["shares"].items()
        },  # fmt: skip
        "reasons": {w: int(np.count_nonzero(np.asarray(v) > 0)) for w, v in rep["reasons"].items()},
        "max_excess": {
            q: round(float(np.max(v)), 6) if np.size(v) else 0.0
            for q, v in rep["max_excess"].items()
        },  # fmt: skip
    }
