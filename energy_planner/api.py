"""The public verbs: ``import energy_planner as ep``.

One :class:`Problem` binds a terrain, a model and a planning request (robot, limits,
keep-outs, channels) once; every verb takes a DEM path or a :class:`Problem` and returns
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
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

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


@dataclass
class Problem:
    """A terrain, a model and a planning request, bound once for every verb.

    Attributes
    ----------
    terrain : Terrain
    model : EnergyModel
    request : Request
        Robot speed and yaw rate, slope limits, keep-outs, channels.
    """

    terrain: Any
    model: Any = None
    request: Any = None
    _cost: Any = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        from energy_planner.request import Request

        if self.model is None:
            self.model = load_model()
        if self.request is None:
            self.request = Request()

    @classmethod
    def from_dem(
        cls, dem: str | Path, model: Any = None, *, band: int | None = None, **request: Any
    ) -> Problem:
        """Open ``dem`` and bind it to ``model`` and a request.

        ``request`` keywords go to ``Request.make`` (``speed``, ``yaw_rate``,
        ``max_slope_deg``, ``max_cross_slope_deg``, ``keep_out``, ``channels``).
        """
        from energy_planner.request import Request

        m = load_model(model) if isinstance(model, str | Path) or model is None else model
        return cls(open_terrain(dem, band=band), m, Request.make(**request))

    @property
    def cost(self):
        """The motion cost of this terrain, model and request (built once)."""
        if self._cost is None:
            from energy_planner.planning.compare import _motion_cost

            self._cost = _motion_cost(self.terrain, self.model, self.request)[0]
        return self._cost

    def to_work(self, points: Any, crs: Any = None) -> np.ndarray:
        """Points ``(x, y[, yaw])`` in the DEM's CRS (or ``crs``) -> working CRS."""
        arr = np.atleast_2d(np.asarray(points, dtype=float))
        if crs is not None:
            from energy_planner.io import reproject_xy

            x, y = reproject_xy(crs, self.terrain.crs, arr[:, 0], arr[:, 1])
        else:
            x, y = self.terrain.to_work(arr[:, 0], arr[:, 1])
        out = np.column_stack([np.atleast_1d(x), np.atleast_1d(y)])
        return np.column_stack([out, arr[:, 2]]) if arr.shape[1] > 2 else out

    def _pose(self, p: Any, crs: Any) -> tuple:
        return tuple(float(v) for v in self.to_work(p, crs)[0])

    def plan(self, start: Any, goal: Any, *, crs: Any = None, **kwargs: Any):
        """An energy-minimal path (:func:`energy_planner.planning.plan`)."""
        from energy_planner.planning.plan import plan as _plan

        kwargs.setdefault("progress", False)
        return _plan(self.terrain, self.model, self._pose(start, crs), self._pose(goal, crs),
                     self.request, **kwargs)  # fmt: skip

    def path_energy(self, points: Any, yaw: Any = None, t: Any = None, *, crs: Any = None):
        """Energy of walking the given points (:func:`energy_planner.energy.path_energy`).

        The request's gait limits hold, as ``energy --max-crab/--max-backward-slope`` does:
        a segment that breaks one is an error naming it.
        """
        from energy_planner.energy import MotionCost
        from energy_planner.energy import path_energy as _pe

        xy = self.to_work(points, crs)[:, :2]
        r, lim = self.request.robot, self.request.limits
        cost = MotionCost(self.terrain, self.model, r.speed, r.yaw_rate,
                          channels=self.request.channels,
                          max_backward_slope_deg=lim.max_backward_slope_deg,
                          max_crab_deg=lim.max_crab_deg)  # fmt: skip
        return _pe(self.terrain, self.model, xy, yaw=yaw, t=t, cost=cost)

    def compare_routes(self, start: Any, goal: Any, *, crs: Any = None, **kwargs: Any):
        """Direct vs shortest vs energy-optimal (paper Fig. 1)."""
        from energy_planner.planning.compare import compare_routes as _cr

        kwargs.setdefault("progress", False)
        return _cr(self.terrain, self.model, self._pose(start, crs), self._pose(goal, crs),
                   self.request, **kwargs)  # fmt: skip

    def reach(self, start: Any, *, crs: Any = None, **kwargs: Any):
        """Least energy from ``start`` to every cell (:class:`~energy_planner.planning.reach.ReachMap`)."""  # noqa: E501
        from energy_planner.planning.reach import reach as _reach

        return _reach(self.terrain, self.model, self._pose(start, crs)[:2], self.request,
                      **kwargs)  # fmt: skip

    def energy_map(self, out: str | Path, **kwargs: Any):
        """The heading-dependent energy map, written to ``out`` (GeoTIFF)."""
        from energy_planner.energymap import energy_map as _em

        return _em(self.terrain, out, self.model, request=self.request, **kwargs)

    def mission(self, sites: Any, **kwargs: Any):
        """Several sites in the least-energy order (:func:`energy_planner.mission.mission`)."""
        from energy_planner.mission import mission as _mission

        return _mission(self.terrain, self.model, sites, self.request, **kwargs)

    def interval(
        self, energy_j: float, level: float = 0.9, *, duration_s: float | None = None,
        outside_share: float = 0.0,
    ):  # fmt: skip
        """The model's prediction interval of an energy (None if it carries none).

        ``duration_s`` (the path's) and ``outside_share`` (of it outside the calibration's
        domain) are inputs of the fit's error model
        (:func:`energy_planner.uncertainty.predict_interval`).
        """
        from energy_planner.uncertainty import predict_interval

        return predict_interval(self.model, energy_j, level, outside_share, duration_s)


def _problem(dem: Any, model: Any, request: Any) -> Problem:
    if isinstance(dem, Problem):
        return dem
    if isinstance(model, str | Path) or model is None:
        model = load_model(model)
    terrain = dem if hasattr(dem, "to_work") else open_terrain(dem)
    return Problem(terrain, model, request)


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
            res, _ = plan_in_corridor(dem, model, tuple(s), tuple(g), request, cap=memory_cap,
                                      **kwargs)  # fmt: skip
            return res
    return _problem(dem, model, request).plan(start, goal, crs=crs, **kwargs)


def path_energy(dem: Any, points: Any, yaw: Any = None, t: Any = None, *, model: Any = None,
                request: Any = None, crs: Any = None):  # fmt: skip
    """Energy of walking ``points`` (DEM CRS, or ``crs``) over ``dem``."""
    return _problem(dem, model, request).path_energy(points, yaw, t, crs=crs)


def compare_routes(dem: Any, start: Any, goal: Any, *, model: Any = None, request: Any = None,
                   crs: Any = None, **kwargs: Any):  # fmt: skip
    """The direct line, the shortest and the energy-optimal path (paper Fig. 1)."""
    return _problem(dem, model, request).compare_routes(start, goal, crs=crs, **kwargs)


def reach(dem: Any, start: Any, *, model: Any = None, request: Any = None, crs: Any = None,
          **kwargs: Any):  # fmt: skip
    """Least energy from ``start`` to every cell of ``dem``."""
    return _problem(dem, model, request).reach(start, crs=crs, **kwargs)


def energy_map(dem: Any, out: str | Path, *, model: Any = None, request: Any = None,
               **kwargs: Any):  # fmt: skip
    """The heading-dependent energy map of ``dem``, written to ``out``.

    A DEM path is handed to the energy map as a path, so that it decides between memory,
    windows and dask (``memory_cap_bytes=``, ``use_dask=``).
    """
    from energy_planner.energymap import energy_map as _em

    if isinstance(dem, Problem):
        return dem.energy_map(out, **kwargs)
    if isinstance(model, str | Path) or model is None:
        model = load_model(model)
    return _em(dem, out, model, request=request, **kwargs)


def mission(dem: Any, sites: Any, *, model: Any = None, request: Any = None, **kwargs: Any):
    """Visit ``sites`` (a file or :class:`~energy_planner.mission.Sites`) in the best order."""
    return _problem(dem, model, request).mission(sites, **kwargs)


def _samples(logs: Any):
    from energy_planner.measurements import load_logs
    from energy_planner.measurements.logs import log_files

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

    Data checks (``repair=False``: report only), then the staircase
    (:func:`energy_planner.diagnosis.discover`); returns its ``Discovery``.
    """
    from energy_planner.diagnosis import discover as _discover

    return _discover(_samples(logs), **kwargs)
