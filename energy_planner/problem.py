"""One planning problem: terrain, model and request bound once, below every planner.

A :class:`Problem` binds a :class:`~energy_planner.terrain.Terrain`, an
:class:`~energy_planner.model.EnergyModel` and a :class:`~energy_planner.request.Request`
(robot speed and yaw rate, slope and gait limits, keep-out areas, channels) and derives,
once, what every planner and product needs from them:

* :attr:`Problem.keep_out`: the keep-out polygons on the working grid
  (:mod:`energy_planner.keepout`), and :attr:`Problem.blocked` their raster;
* :attr:`Problem.cost`: the one :class:`~energy_planner.energy.MotionCost` with every
  limit in its kernel (slope, cross-slope, keep-out mask, gait), so a path planned under
  it never enters a keep-out area or breaks a limit.

Every planner (``plan`` with the search, the lattice or OMPL) and every product
(``compare_routes``, ``reach``, ``energy_map``, ``energy_matrix``, ``mission``) takes a
Problem as its first argument; data flows one way, from here into planning. Variants
(:meth:`Problem.distance`, :meth:`Problem.unlimited`, :meth:`Problem.gait_only`) are
Problems too, so that a cost is never assembled by hand elsewhere.

This module imports only the terrain, model, energy, keep-out and request layers.

Examples
--------
>>> import numpy as np
>>> from energy_planner.terrain import Terrain
>>> t = Terrain.from_array(np.zeros((10, 10)), resolution=1.0)
>>> p = Problem(t)
>>> p.cost is p.cost, round(p.cost(1.5, 1.5, 0.0, 4.5, 1.5, 0.0), 1) > 0
(True, True)
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.errors import PlanningConfigError
from energy_planner.request import Limits, Request

__all__ = ["REQUEST_KEYS", "Problem", "request_with", "takes_problem", "verb_doc"]

#: The keywords of a verb that make its request (robot, limits, channels), named and in
#: the units of its command's options (``--max-slope`` is ``max_slope_deg``).
REQUEST_KEYS = ("speed", "yaw_rate", "max_slope_deg", "max_cross_slope_deg", "keep_out",
                "max_backward_slope_deg", "max_crab_deg", "channels",
                "allow_unknown_category")  # fmt: skip


def request_with(base: Request | None, **given: Any) -> Request | None:
    """``base`` (a Request or None) with the :data:`REQUEST_KEYS` given (not None) replaced.

    ``channels`` as :meth:`~energy_planner.energy.channels.Channels.coerce` takes it.
    Nothing given: ``base`` as it is (None stays None).

    >>> request_with(None, max_slope_deg=25, channels={"load_kg": 10}).limits.max_slope_deg
    25.0
    >>> request_with(None) is None
    True
    """
    from energy_planner.energy.channels import Channels
    from energy_planner.request import RequestError

    allow = bool(given.pop("allow_unknown_category", False))
    ch = Channels.coerce(given.pop("channels", None), allow)
    given = {k: v for k, v in given.items() if v is not None}
    if not given and ch is None:
        return base
    if base is not None and not isinstance(base, Request):
        raise RequestError(
            f"request must be an energy_planner.request.Request, got {type(base).__name__}",
            field="request",
            value=base,
        )
    base = base if base is not None else Request()
    robot = {k: given.pop(k) for k in ("speed", "yaw_rate") if k in given}
    return Request(
        robot=dataclasses.replace(base.robot, **robot),
        limits=dataclasses.replace(base.limits, **given),
        channels=base.channels if ch is None else ch,
    )


#: Parameter texts every verb shares (numpydoc), filled in by :func:`verb_doc`.
VERB_DOCS = {
    "dem": """\
dem : str, path, Terrain or Problem
    A DEM file, a bundled map's name (``"hill"``, ``"plane"``, ``"jacksboro"``), a
    loaded :class:`~energy_planner.terrain.Terrain`, or a :class:`Problem` (its
    model and request, which the keywords below replace).""",
    "common": """\
model : EnergyModel or path, optional
    The energy model (``--model``; default: the bundled B1-class model).
request : Request, optional
    A whole :class:`~energy_planner.request.Request`; the keywords below replace
    its fields (default: the Problem's request, else ``Request()``).
speed : float, optional
    Nominal walking speed, m/s (``--speed``; default 0.3).
yaw_rate : float, optional
    Nominal turning rate, rad/s (``--yaw-rate``; default 0.5).
max_slope_deg : float, optional
    Steepest ground slope the path may cross, degrees (``--max-slope``).
max_cross_slope_deg : float, optional
    Steepest slope across the robot's body, degrees (``--max-cross-slope``).
keep_out : path or geometries, optional
    Keep-out polygons (``--keep-out``): a GeoJSON file or shapely geometries in the
    DEM's CRS (:class:`~energy_planner.request.Limits`).
max_backward_slope_deg : float, optional
    No backward walking on ground steeper than this, degrees
    (``--max-backward-slope``).
max_crab_deg : float, optional
    Largest crab angle, degrees (``--max-crab``).
channels : dict or Channels, optional
    Values of the extra channels the model reads (``--set``, ``--channel``): a
    number or a category name per channel (``{"load_kg": 10, "ground": "meadow"}``),
    a :class:`pathlib.Path` of a raster, or ``(raster, value_table)`` paths.
allow_unknown_category : bool
    Accept a category the model does not name (``--allow-unknown-category``).""",
    "trust": """\
level : float
    Nominal coverage of the energy's prediction interval (``--level``).
battery_wh : float, optional
    Battery energy, Wh (``--battery-wh``): the chance that it suffices.
reserve_wh : float
    Energy to keep in the battery, Wh (``--reserve-wh``).
confidence : float
    Required chance that the battery suffices (``--confidence``).""",
    "planning": """\
planner : str
    ``auto``, ``search``, ``lattice`` or an OMPL planner (``--planner``;
    :data:`energy_planner.planning.PLANNERS`).
time : float, optional
    Planning budget, seconds (``--time``).
seed : int
    Random seed (``--seed``).""",
}


def verb_doc(fn: Callable) -> Callable:
    """Fill a verb's docstring placeholders (``{dem}``, ``{common}``, ...) from :data:`VERB_DOCS`.

    A placeholder stands on its own line at the docstring's indentation (4 spaces), which
    its text's first line takes; its other lines get the same.
    """
    parts = {k: v.replace("\n", "\n    ") for k, v in VERB_DOCS.items()}
    fn.__doc__ = fn.__doc__.format(**parts)
    return fn


def _load_model(model: Any):
    from energy_planner.model import EnergyModel

    if model is None:
        return EnergyModel.default()
    if isinstance(model, str | Path):
        return EnergyModel.load(model)
    return model


@dataclass
class Problem:
    """A terrain, a model and a planning request, bound once for every planner and product.

    Attributes
    ----------
    terrain : Terrain
        The map (working grid).
    model : EnergyModel
        Default: the bundled model; a path is loaded.
    request : Request
        Robot speed and yaw rate, slope and gait limits, keep-outs, channels
        (default ``Request()``).
    """

    terrain: Any
    model: Any = None
    request: Any = None
    _cost: Any = field(default=None, init=False, repr=False, compare=False)
    _keep_out: Any = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        self.model = _load_model(self.model)
        if self.request is None:
            self.request = Request()
        elif not isinstance(self.request, Request):
            raise PlanningConfigError(
                f"request must be an energy_planner.request.Request, got "
                f"{type(self.request).__name__}",
                param="request",
                value=self.request,
            )

    def __getstate__(self) -> dict[str, Any]:
        """Pickled without the compiled cost (a dask worker builds its own)."""
        return {**self.__dict__, "_cost": None}

    @classmethod
    def from_dem(
        cls, dem: str | Path, model: Any = None, *, band: int | None = None, **request: Any
    ) -> Problem:
        """Open ``dem`` (any CRS) and bind it to ``model`` and a request.

        ``request`` keywords go to :meth:`Request.make` (``speed``, ``yaw_rate``,
        ``max_slope_deg``, ``max_cross_slope_deg``, ``keep_out``, ``channels``, gait
        limits).
        """
        from energy_planner.terrain import load_dem

        return cls(load_dem(dem, band=band), model, Request.make(**request))

    @classmethod
    def coerce(
        cls, dem: Any, model: Any = None, request: Request | None = None, **given: Any
    ) -> Problem:
        """A Problem as is, or one built on a Terrain or a DEM (a path or a bundled name).

        What every verb does with its first argument (``ep.plan("hill", ...)``). ``model``,
        ``request`` and the :data:`REQUEST_KEYS` given (:func:`request_with`) replace a
        Problem's own (the Problem itself is not changed).
        """
        if isinstance(dem, cls):
            req = request_with(request if request is not None else dem.request, **given)
            if model is None and req is dem.request:
                return dem
            return dem.replace(model=model, request=req)
        request = request_with(request, **given)
        if hasattr(dem, "to_work"):
            terrain = dem
        else:
            from energy_planner.terrain import load_dem

            terrain = load_dem(dem)
        return cls(terrain, model, request)

    @classmethod
    def of_cost(cls, cost: Any, request: Request | None = None) -> Problem:
        """The Problem a prepared motion cost was built for, bound to that cost.

        ``request``, when given, must agree with the cost's speed, yaw rate and limits
        (a :class:`PlanningConfigError` naming the first that differs otherwise).
        """
        derived = getattr(cost, "request", None)
        if derived is None:
            derived = Request.make(
                speed=cost.speed, yaw_rate=cost.yaw_rate, max_slope_deg=cost.max_slope_deg,
                max_cross_slope_deg=cost.max_cross_slope_deg,
                max_backward_slope_deg=getattr(cost, "max_backward_slope_deg", None),
                max_crab_deg=getattr(cost, "max_crab_deg", None),
                channels=getattr(cost, "channels", None),
            )  # fmt: skip
        if request is not None:
            _check_agrees(request, cost)
        p = cls(cost.terrain, cost.model, request if request is not None else derived)
        p._cost = cost
        return p

    @property
    def keep_out(self) -> list[Any]:
        """The request's keep-out polygons in the working CRS (read once; [] without)."""
        if self._keep_out is None:
            from energy_planner.keepout import keep_out_geometries

            self._keep_out = keep_out_geometries(self.request.limits.keep_out, self.terrain)
        return self._keep_out

    @property
    def blocked(self) -> np.ndarray | None:
        """Cells the keep-out areas block (the cost kernel's mask), None without any."""
        from energy_planner.keepout import rasterize_keep_out

        return rasterize_keep_out(self.keep_out, self.terrain) if self.keep_out else None

    @property
    def cost(self):
        """The motion cost of this terrain, model and request, with every limit (built once)."""
        if self._cost is None:
            self._cost = self._make_cost()
        return self._cost

    def _make_cost(self, **speed: Any):
        """A :class:`~energy_planner.energy.MotionCost` of this problem.

        ``speed``: its ``speed_range`` and ``time_weight``, if any.
        """
        from energy_planner.energy import MotionCost

        lim, robot = self.request.limits, self.request.robot
        kwargs: dict[str, Any] = {}
        if self.request.channels is not None:
            kwargs["channels"] = self.request.channels
        cost = MotionCost(
            self.terrain,
            self.model,
            speed=robot.speed,
            yaw_rate=robot.yaw_rate,
            max_slope_deg=lim.max_slope_deg,
            max_cross_slope_deg=lim.max_cross_slope_deg,
            max_backward_slope_deg=lim.max_backward_slope_deg,
            max_crab_deg=lim.max_crab_deg,
            blocked=self.blocked,
            **kwargs,
            **speed,
        )
        cost.request = self.request
        return cost

    def with_speed(
        self, speed_range: tuple[float, float] | None, time_weight: float = 0.0
    ) -> Problem:
        """The same problem whose motions choose their ground speed in ``speed_range``.

        Each translation walks at the speed that minimises its energy plus ``time_weight``
        (J/s) times its duration (:mod:`energy_planner.energy.speed`); the request's
        nominal speed stays the one of turns' neighbours and of given waypoints without
        times. ``speed_range`` None with no time weight: this problem.
        """
        if speed_range is None and not time_weight:
            return self
        p = self.replace()
        p._cost = self._make_cost(speed_range=speed_range, time_weight=time_weight)
        return p

    def replace(self, *, model: Any = None, request: Request | None = None) -> Problem:
        """The same terrain with another model and/or request (keep-outs kept if unchanged)."""
        p = Problem(self.terrain, self.model if model is None else model,
                    self.request if request is None else request)  # fmt: skip
        if p.request.limits.keep_out is self.request.limits.keep_out:
            p._keep_out = self._keep_out
        return p

    def distance(self) -> Problem:
        """The same problem with the ground distance as its energy, under the same limits.

        The model's power is the speed (1 J per metre walked along the ground); it reads
        no channel, so the request's channels are dropped.
        """
        from energy_planner.model import EnergyModel

        return self.replace(
            model=EnergyModel(["speed"], {"speed": 1.0}),
            request=dataclasses.replace(self.request, channels=None),
        )

    def duration(self, speed: float | None = None) -> Problem:
        """The same problem with the time as its energy (1 J per second), same limits.

        Every translation at ``speed`` (default the request's nominal speed), turns at
        its yaw rate: the cost of a motion is its duration in seconds (the least one
        when ``speed`` is the top of a speed range). The model reads no channel, so the
        request's channels are dropped.
        """
        from energy_planner.model import EnergyModel

        robot = self.request.robot
        if speed is not None:
            robot = dataclasses.replace(robot, speed=float(speed))
        return self.replace(
            model=EnergyModel(["1"], {"1": 1.0}),
            request=dataclasses.replace(self.request, robot=robot, channels=None),
        )

    def unlimited(self) -> Problem:
        """The same problem without any limit (to price a path that breaks one)."""
        return self.replace(request=dataclasses.replace(self.request, limits=Limits()))

    def gait_only(self) -> Problem:
        """The same problem with only its gait limits (what pricing given points holds)."""
        lim = self.request.limits
        gait = Limits(max_backward_slope_deg=lim.max_backward_slope_deg,
                      max_crab_deg=lim.max_crab_deg)  # fmt: skip
        return self.replace(request=dataclasses.replace(self.request, limits=gait))

    def to_work(self, points: Any, crs: Any = None) -> np.ndarray:
        """Points ``(x, y[, yaw])`` in the DEM's CRS (or ``crs``) -> working CRS."""
        arr = np.atleast_2d(np.asarray(points, dtype=float))
        if crs is not None and crs == self.terrain.crs:  # already on the working grid
            x, y = arr[:, 0], arr[:, 1]
        elif crs is not None:
            from energy_planner.io import reproject_xy

            x, y = reproject_xy(crs, self.terrain.crs, arr[:, 0], arr[:, 1])
        else:
            x, y = self.terrain.to_work(arr[:, 0], arr[:, 1])
        out = np.column_stack([np.atleast_1d(x), np.atleast_1d(y)])
        return np.column_stack([out, arr[:, 2]]) if arr.shape[1] > 2 else out

    def path_energy(self, points: Any, yaw: Any = None, t: Any = None, *, crs: Any = None,
                    segment_gaits: Any = None, **trust: Any):  # fmt: skip
        """Energy of walking the given points, with its interval, domain and battery verdict.

        :func:`energy_planner.energy.path_energy` of the points; the result's
        ``assessment`` (``.interval``, ``.domain``, ``.battery``) is
        :func:`energy_planner.uncertainty.assess.assess_path` with the
        :class:`~energy_planner.trust.Trust` keywords ``level``, ``battery_wh``,
        ``reserve_wh``, ``confidence``. The request's gait limits hold
        (:meth:`gait_only`), as ``energy --max-crab`` does: a segment that breaks one is
        an error naming it. ``segment_gaits``: each segment's gait (a plan's, for a model that names
        gaits; see :func:`~energy_planner.energy.path_energy`).
        """
        from energy_planner.energy import path_energy
        from energy_planner.trust import Trust
        from energy_planner.uncertainty.assess import assess_path

        want = Trust.pop(trust)
        if trust:
            raise TypeError(f"path_energy() got unexpected keyword(s) {', '.join(trust)}")
        xy = self.to_work(points, crs)[:, :2]
        gait = self.gait_only()
        cost = self.cost if gait.request == self.request else gait.cost
        if segment_gaits is not None and not cost.gaits:  # the cost walks a given gait
            cost = gait._make_cost(gait_choice=True)
        pe = path_energy(self.terrain, self.model, xy, yaw=yaw, t=t, cost=cost,
                         gait=segment_gaits)  # fmt: skip
        pe.assessment = assess_path(self.model, pe, cost, want)
        pe.problem = self
        return pe


def _check_agrees(request: Request, cost: Any) -> None:
    """Raise :class:`PlanningConfigError` if ``cost`` was built for another request."""
    pairs = [
        ("speed", request.robot.speed, cost.speed),
        ("yaw_rate", request.robot.yaw_rate, cost.yaw_rate),
        ("max_slope_deg", request.limits.max_slope_deg, cost.max_slope_deg),
        ("max_cross_slope_deg", request.limits.max_cross_slope_deg, cost.max_cross_slope_deg),
        ("max_backward_slope_deg", request.limits.max_backward_slope_deg,
         getattr(cost, "max_backward_slope_deg", None)),
        ("max_crab_deg", request.limits.max_crab_deg, getattr(cost, "max_crab_deg", None)),
    ]  # fmt: skip
    for name, want, have in pairs:
        same = want == have or (want is not None and have is not None and math.isclose(want, have))
        if not same:
            raise PlanningConfigError(
                f"cost= was built with {name}={have!r} but request= asks for {name}={want!r}; "
                "give one of them (or a Problem(terrain, model, request))",
                param=name,
                value=want,
                expected=f"{name}={have!r} as in cost=",
            )
    from energy_planner.energy.kernels import IN_BLOCKED

    if request.limits.keep_out is not None and cost.data[IN_BLOCKED].size == 0:
        raise PlanningConfigError(
            "request= has keep-out areas but cost= was built without them; give a "
            "Problem(terrain, model, request)",
            param="keep_out",
        )


def takes_problem(n_args: int) -> Callable:
    """Let ``fn(problem, *args, **kw)`` also be called in the older forms.

    ``fn(terrain, model, *args, request=None, **kw)``: ``request`` positional right after
    the ``n_args`` arguments or as a keyword; a prepared motion cost may come as
    ``cost=``. ``fn(cost, terrain, *args, **kw)``: a prepared
    :class:`~energy_planner.energy.MotionCost` and its terrain (the lower-level planners'
    form). Both become one :class:`Problem`; nothing else changes.
    """

    def deco(fn: Callable) -> Callable:
        @functools.wraps(fn)
        def wrapper(first: Any, *args: Any, **kwargs: Any) -> Any:
            if not isinstance(first, Problem):
                first, args, kwargs = _bind(first, args, kwargs, n_args)
            return fn(first, *args, **kwargs)

        return wrapper

    return deco


def _bind(first: Any, args: tuple, kwargs: dict, n_args: int) -> tuple[Problem, tuple, dict]:
    """The :class:`Problem` of an older call form (see :func:`takes_problem`)."""
    if hasattr(first, "kernel") and hasattr(first, "data"):  # (cost, terrain, ...)
        if args and args[0] is not first.terrain:
            raise PlanningConfigError("cost= and terrain= are for different terrains",
                                      param="terrain")  # fmt: skip
        return Problem.of_cost(first), args[1:], kwargs
    if not args:
        raise TypeError("give a Problem, or a terrain and a model")
    model, rest = args[0], list(args[1:])
    request = kwargs.pop("request", None)
    if len(rest) > n_args:
        if request is not None:
            raise TypeError("request given twice (positional and request=)")
        request = rest.pop(n_args)
    cost = kwargs.pop("cost", None)
    if cost is not None:
        problem = Problem.of_cost(cost, request)
    else:
        problem = Problem(first, model, request)
    return problem, tuple(rest), kwargs
