"""The public verbs: ``import energy_planner as ep``.

One :class:`~energy_planner.problem.Problem` binds a terrain, a model and a planning
request (robot, limits, keep-outs, channels) once (it lives below planning, in
:mod:`energy_planner.problem`, and is re-exported here); every verb takes a DEM path or a
:class:`Problem` and returns
the library's own result object, which writes and draws itself. Coordinates are in the
DEM's own CRS unless ``crs=`` names another (lon/lat, another UTM zone, ...); yaw is in
radians (the Python API's convention), counter-clockwise from that CRS's x axis.

The library, not the caller, decides how to read the map: :func:`plan` on a DEM path too
large for the memory cap reads it by windows (:mod:`energy_planner.planning.corridor`), as
the ``plan`` command does.

Examples
--------
>>> import energy_planner as ep
>>> prob = ep.Problem.from_dem(ep.map_path("plane"), max_slope_deg=30)
>>> e = prob.path_energy([(500010.0, 5000050.0), (500030.0, 5000050.0)])
>>> round(e.distance_m, 2) > 20, e.energy_j > 0
(True, True)
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.problem import Problem
from energy_planner.terrain.memory import DEFAULT_CAP

__all__ = [
    "Problem",
    "compare_routes",
    "discover",
    "energy_map",
    "fit",
    "load_model",
    "mission",
    "open_terrain",
    "pareto",
    "path_energy",
    "plan",
    "reach",
]


def open_terrain(path: str | Path, *, band: int | None = None):
    """Open a DEM (any CRS) as a :class:`~energy_planner.terrain.Terrain`.

    A geographic DEM is put on a metric working grid; slopes and aspects are metric.
    """
    from energy_planner.terrain import load_dem

    return load_dem(path, band=band)


def load_model(path: str | Path | None = None):
    """The bundled B1-class model (``path=None``) or a model file."""
    from energy_planner.model import EnergyModel

    return EnergyModel.default() if path is None else EnergyModel.load(path)


def _problem(dem: Any, model: Any, request: Any) -> Problem:
    return Problem.coerce(dem, model, request)


def _pose(problem: Problem, p: Any, crs: Any) -> tuple:
    """A point ``(x, y[, yaw])`` in the DEM's CRS (or ``crs``) in the working CRS."""
    return tuple(float(v) for v in problem.to_work(p, crs)[0])


def plan(dem: Any, start: Any, goal: Any, *, model: Any = None, request: Any = None,
         crs: Any = None, memory_cap: Any = DEFAULT_CAP, **kwargs: Any):  # fmt: skip
    """Plan an energy-minimal path from ``start`` to ``goal``.

    ``dem`` is a path, a Terrain or a :class:`Problem`. A DEM path too large for the memory
    cap (``memory_cap``: bytes, ``DEFAULT_CAP`` or ``NO_CAP``, as
    :func:`energy_planner.terrain.memory.resolve_cap` reads it) is read by windows; the
    result's ``info["corridor"]`` says whether the window is proven.
    """
    if isinstance(dem, str | Path):
        from energy_planner.planning.corridor import needs_windows, plan_in_corridor

        if needs_windows(dem, memory_cap):
            if isinstance(model, str | Path) or model is None:
                model = load_model(model)
            s, g = (np.asarray(p, dtype=float) for p in (start, goal))
            if crs is not None:
                raise ValueError("crs= is not supported on a DEM read by windows; give the "
                                 "points in the DEM's CRS")  # fmt: skip
            if any(kwargs.get(k) for k in ("speed", "deadline", "time_weight")):
                from energy_planner.errors import PlanningConfigError

                raise PlanningConfigError(
                    f"{dem}: a DEM read by windows (over memory_cap) is planned at the "
                    "request's speed; expected no speed=, deadline= or time_weight= (give the "
                    "speed in request=), or a larger memory_cap",
                    value=kwargs.get("speed"),
                    param="speed",
                )
            res, _ = plan_in_corridor(dem, model, tuple(s), tuple(g), request, cap=memory_cap,
                                      **kwargs)  # fmt: skip
            return res
    from energy_planner.planning.plan import plan as _plan

    prob = _problem(dem, model, request)
    kwargs.setdefault("progress", False)
    return _plan(prob, _pose(prob, start, crs), _pose(prob, goal, crs), **kwargs)


def pareto(dem: Any, start: Any, goal: Any, n: int = 9, *, model: Any = None,
           request: Any = None, crs: Any = None, **kwargs: Any):  # fmt: skip
    """The energy-time front from ``start`` to ``goal``: ``n`` plans over a sweep of lambda.

    Each point minimises energy + lambda x time over routes and speeds within ``speed=``
    (default ``"auto"``: the range the model's logs cover); only the front's convex hull
    is found (:func:`energy_planner.planning.speed.pareto`). ``plan(..., deadline=...)``
    gives the least-energy path that arrives in time.
    """
    from energy_planner.planning.speed import pareto as _pareto

    prob = _problem(dem, model, request)
    kwargs.setdefault("progress", False)
    return _pareto(prob, _pose(prob, start, crs), _pose(prob, goal, crs), n, **kwargs)


def path_energy(dem: Any, points: Any, yaw: Any = None, t: Any = None, *, model: Any = None,
                request: Any = None, crs: Any = None, **trust: Any):  # fmt: skip
    """Energy of walking ``points`` (DEM CRS, or ``crs``) over ``dem``.

    The result carries its interval, domain report and, with ``battery_wh=`` (and
    ``reserve_wh=``, ``confidence=``), the battery's verdict; ``level=`` sets the
    interval's coverage (:class:`energy_planner.trust.Trust`).
    """
    return _problem(dem, model, request).path_energy(points, yaw, t, crs=crs, **trust)


def compare_routes(dem: Any, start: Any, goal: Any, *, model: Any = None, request: Any = None,
                   crs: Any = None, **kwargs: Any):  # fmt: skip
    """The direct line, the shortest and the energy-optimal path (paper Fig. 1)."""
    from energy_planner.planning.compare import compare_routes as _cr

    prob = _problem(dem, model, request)
    kwargs.setdefault("progress", False)
    return _cr(prob, _pose(prob, start, crs), _pose(prob, goal, crs), **kwargs)


def reach(dem: Any, start: Any, *, model: Any = None, request: Any = None, crs: Any = None,
          **kwargs: Any):  # fmt: skip
    """Least energy from ``start`` to every cell of ``dem``."""
    from energy_planner.planning.reach import reach as _reach

    prob = _problem(dem, model, request)
    return _reach(prob, _pose(prob, start, crs)[:2], **kwargs)


def energy_map(dem: Any, out: str | Path, *, model: Any = None, request: Any = None,
               **kwargs: Any):  # fmt: skip
    """The heading-dependent energy map of ``dem``, written to ``out``.

    A DEM path is handed to the energy map as a path, so that it decides between memory,
    windows and dask (``memory_cap_bytes=``, ``use_dask=``).
    """
    from energy_planner.energymap import energy_map as _em

    if isinstance(dem, Problem):
        return _em(dem, out, **kwargs)
    return _em(dem, out, load_model(model) if isinstance(model, str | Path) or model is None
               else model, request=request, **kwargs)  # fmt: skip


def mission(dem: Any, sites: Any, *, model: Any = None, request: Any = None, **kwargs: Any):
    """Visit ``sites`` (a file or :class:`~energy_planner.mission.Sites`) in the best order."""
    from energy_planner.mission import mission as _mission

    return _mission(_problem(dem, model, request), sites, **kwargs)


def _samples(logs: Any):
    """Canonical samples from log paths, a DataFrame of them, or a simulated campaign."""
    import pandas as pd

    from energy_planner.measurements import load_logs
    from energy_planner.measurements.logs import log_files

    if isinstance(logs, pd.DataFrame):
        return logs
    if isinstance(getattr(logs, "logs", None), pd.DataFrame):  # a simulated Campaign
        return logs.logs
    return load_logs(log_files([logs] if isinstance(logs, str | Path) else list(logs)))


def fit(
    logs: Any,
    terms: Any = None,
    *,
    window: float = 2.0,
    n_splits: int = 5,
    seed: int = 0,
    repair: bool = True,
):
    """Fit a model from robot logs (files or folders; CSV, Parquet, ROS bags).

    Runs the data checks and repairs what they find (``repair=False``: report only), as
    ``diagnose`` and ``discover`` do; cleans (paper IV-B) and windows the logs, then fits
    ``terms`` (default: the base model) jointly and validates them by run; returns the
    :class:`~energy_planner.calibration.fit.FitResult` (``.model`` is the model, with the
    held-out run errors its intervals use; ``.data_findings`` the checks' results).
    """
    from energy_planner.calibration import fit_model

    if not (window > 0 and math.isfinite(window)):
        raise ValueError(f"window must be a positive number of seconds, not {window!r}")
    return fit_model(
        _samples(logs), terms, n_splits=n_splits, seed=seed, window=window, repair=repair
    )


def discover(logs: Any, **kwargs: Any):
    """Find the effects the base model lacks in robot logs.

    ``logs``: log files or folders (CSV, Parquet, ROS bags), a DataFrame of canonical
    samples, or a simulated campaign. Data checks (``repair=False``: report only), then
    the staircase (:func:`energy_planner.diagnosis.discover`); returns its ``Discovery``
    (``.table()``, ``.write_json``, ``.write_html``, ``.plot``).
    """
    from energy_planner.diagnosis import discover as _discover

    return _discover(_samples(logs), **kwargs)
