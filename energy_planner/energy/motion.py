"""Energy of SE(2) motions over a terrain: the one cost that queries and planners share."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from energy_planner.energy.channels import Channels
from energy_planner.energy.gait_kernels import gait_kernel_module
from energy_planner.energy.kernels import (
    IN_GRAD,
    IN_X0,
    IN_Y0,
    N_OUT,
    OK,
    OUT_CODE,
    TOO_CROSS,
    TOO_STEEP,
    VIOLATIONS,
    kernel_module,
    precompiled_module,
)
from energy_planner.errors import ChannelError, ModelError, MotionCostError
from energy_planner.model import GAIT_CHANNEL
from energy_planner.request import DEFAULT_SPEED, DEFAULT_YAW_RATE

__all__ = ["MotionCost", "gait_limit_values"]


class MotionCost:
    """Energy (J) of SE(2) motions over a terrain under an energy model.

    Coordinates are in the terrain's working CRS (metres); yaw in radians CCW from +x.
    A motion moves linearly in x, y and along the shortest arc in yaw at constant rates,
    for ``max(distance / speed, |dyaw| / yaw_rate)`` seconds (see
    :mod:`energy_planner.energy.kernels`).

    Parameters
    ----------
    terrain : Terrain
        Provides ``grid`` (x0, y0, dx, dy), ``dzdx`` and ``dzdy``; its ``grad`` (as
        :attr:`Terrain.grad <energy_planner.terrain.Terrain.grad>`), when it has one,
        is read as it is, else the two components are stacked into a copy.
    model : EnergyModel
        A fitted model.
    speed, yaw_rate : float
        Nominal walking speed (m/s) and turning rate (rad/s).
    max_slope_deg, max_cross_slope_deg : float, optional
        Limits; a motion that samples a steeper slope, or holds the body across a
        steeper cross-slope (``asin(sin(alpha) |sin(gamma)|)``), costs ``inf``.
    max_backward_slope_deg, max_crab_deg : float, optional
        Gait limits (:class:`energy_planner.request.Limits`): a translation that walks
        backward on a steeper slope, or with a larger crab angle, costs ``inf``.
    blocked : ndarray of bool, optional
        Keep-out mask on the terrain grid (nearest cell).
    constants : mapping, optional
        Values of extra channels the model's terms read (e.g. ``payload_kg``); merged
        with ``channels.constants``.
    channels : Channels, optional
        Extra channels: constants (kernel inputs at run time) and rasters (aligned to the
        terrain's grid here if they are not yet, sampled at every sub-step).
    step : float, optional
        Integration sub-step in metres (default half the smaller cell size: the gradient is
        bilinear between cell centres, so the midpoint rule at half-cell steps resolves it).
    ang_step : float
        Integration sub-step for rotations, radians.
    speed_range : (float, float), optional
        Ground speed range ``(vmin, vmax)``, m/s: every translation priced from Python
        (:meth:`__call__`, :meth:`batch`), by the search and the refinement walks at the
        speed in the range that minimises its energy (plus ``time_weight`` times its
        duration), chosen in closed form (:mod:`energy_planner.energy.speed`;
        :meth:`best_durations` gives the chosen durations of a path). None: every motion
        at ``speed`` (the fixed-speed kernels, unchanged).
    time_weight : float
        The price of a second, J/s (``lambda`` >= 0): motions minimise energy + lambda x
        duration (a deadline's Lagrangian, :func:`energy_planner.planning.speed.plan_deadline`).
    gait_choice : bool, optional
        Where the model names gaits (a ``gait`` channel, and the speeds its logs walked
        each gait at, :func:`energy_planner.uncertainty.domain.gait_speed_ranges`) and
        the channels do not give the gait: with a ``speed_range`` every motion chooses
        its gait, each gait within its own logged speeds (clipped to the range), the
        cheapest (gait, speed) pair kept (:attr:`gaits`; :meth:`best_timing` reports
        each motion's); at the nominal speed, motions walk the gait whose logged speeds
        hold it (:attr:`nominal_gait`), or the gait given per motion to :meth:`details`.
        Default (None) or True: so; False: off (the model then needs the gait as a
        channel).
    precompiled : bool
        Price motions asked from Python (:meth:`__call__`, :meth:`batch`,
        :meth:`details`) with the model's precompiled kernel module
        (:func:`energy_planner.energy.kernels.precompiled_module`: built once per machine
        and model, then loaded without numba), not with numba's kernels. Same numbers;
        for commands whose work is small beside numba's start-up. The numba kernels
        (:attr:`kernel`, :attr:`map_kernel`, the planners') load on first use either way.
        A cost that chooses its gait has none (its inputs hold one tuple per gait, whose
        number is part of their type): numba's kernels serve it.
    """

    def __init__(
        self,
        terrain: Any,
        model: Any,
        speed: float = DEFAULT_SPEED,
        yaw_rate: float = DEFAULT_YAW_RATE,
        *,
        max_slope_deg: float | None = None,
        max_cross_slope_deg: float | None = None,
        max_backward_slope_deg: float | None = None,
        max_crab_deg: float | None = None,
        blocked: np.ndarray | None = None,
        constants: Mapping[str, Any] | None = None,
        channels: Channels | None = None,
        step: float | None = None,
        ang_step: float = 0.05,
        speed_range: tuple[float, float] | None = None,
        time_weight: float = 0.0,
        precompiled: bool = False,
        gait_choice: bool | None = None,
    ) -> None:
        if not (speed > 0 and yaw_rate > 0):
            raise MotionCostError(
                f"speed and yaw_rate must be > 0 (m/s, rad/s), got {speed}, {yaw_rate}"
            )
        if not model.is_fitted:
            raise ModelError("the energy model has no coefficients: fit or load a fitted model")
        self.terrain = terrain
        self.model = model
        self.speed = float(speed)
        self.yaw_rate = float(yaw_rate)
        self.max_slope_deg = max_slope_deg
        self.max_cross_slope_deg = max_cross_slope_deg
        self.max_backward_slope_deg = max_backward_slope_deg
        self.max_crab_deg = max_crab_deg
        channels = channels if channels is not None else Channels()
        extra = dict(constants or {})
        clash = sorted(set(extra) & set(channels.names))
        if clash:
            raise ChannelError(f"channel(s) {', '.join(clash)} given in constants and channels")
        if extra:
            channels = replace(channels, constants={**channels.constants, **extra})
        channels = channels.resolve(model)  # values of the kinds the model reads
        self.gaits: tuple[str, ...] = ()
        self.gait_ranges: dict[str, tuple[float, float]] = {}
        self.nominal_gait: str | None = None
        if _wants_gaits(model, channels, gait_choice):
            channels, self.gaits = _gait_channels(model, channels, float(speed))
            self.nominal_gait = str(channels.constants[GAIT_CHANNEL])
        if channels.rasters:
            channels = channels.bind(terrain)
        self.channels = channels
        self.constants = dict(channels.constants)
        x0, y0, dx, dy = (float(v) for v in terrain.grid)
        self.step = float(step) if step else 0.5 * min(abs(dx), abs(dy))
        grad = _shared_gradient(terrain)
        gx = grad[..., 0]
        if blocked is None:
            mask = np.zeros((0, 0), dtype=np.bool_)
        else:
            mask = np.ascontiguousarray(blocked, dtype=np.bool_)
            if mask.shape != gx.shape:
                raise MotionCostError(f"blocked mask shape {mask.shape} != terrain grid {gx.shape}")
        tmax = math.inf if max_slope_deg is None else math.tan(math.radians(max_slope_deg))
        smax = (
            math.inf if max_cross_slope_deg is None else math.sin(math.radians(max_cross_slope_deg))
        )
        btan, cmax = gait_limit_values(max_backward_slope_deg, max_crab_deg)
        chan, nearest = channels.stack(gx.shape, runtime=True)  # constants: run-time inputs
        self.speed_range, self.time_weight, self.speed_law, speed_in = _speed_inputs(
            model, self.speed, speed_range, time_weight, self.constants
        )
        self.data = (
            grad, mask, x0, y0, dx, dy,
            self.speed, self.yaw_rate, self.step, float(ang_step), tmax, smax,
            chan, nearest, btan, cmax, *speed_in,
        )  # fmt: skip
        if self.gaits:  # one input tuple per gait after the nominal gait's (gait_kernels)
            self.gait_ranges, law, gait_data, self.gaits = _gait_inputs(
                model, self.gaits, channels, self.data, gx.shape, speed_range, self.time_weight
            )
            if law is not None:
                self.speed_law = law
            self.data = (*self.data, gait_data)
        self.source = model.kernel_source(self.constants, channels.kernel_layout(runtime=True))
        self._aot = precompiled_module(self.source) if precompiled and not self.gaits else None
        self._fns: dict[str, Any] = {}

    @property
    def ranged(self) -> bool:
        """Motions choose their speed (a speed range or a time price), not the nominal one."""
        return self.speed_range is not None or self.time_weight > 0

    def best_durations(self, x, y, th) -> np.ndarray:
        """Durations (s) of the motions between consecutive poses at their chosen speeds.

        The speeds :meth:`__call__` prices them at (the nominal speed and yaw rate without
        a range); ``inf`` where a motion breaks a limit. Give them to :meth:`details` (or
        ``t`` to :func:`energy_planner.energy.path_energy`) for the energy and its breakdown.
        """
        return self.best_timing(x, y, th)[0]

    def best_timing(self, x, y, th) -> tuple[np.ndarray, list[str | None] | None]:
        """Durations (s) and gaits of the motions between consecutive poses as chosen.

        The durations of :meth:`best_durations`; the gaits (names of :attr:`gaits`, None
        for a motion in none, e.g. one that breaks a limit) where the motions choose their
        gait, else None.
        """
        x, y, th = (np.ascontiguousarray(a, dtype=np.float64) for a in (x, y, th))
        mod = self._kernels()
        if not self.gaits:
            return mod.path_speeds(x, y, th, self.data), None
        res = mod.gait_speeds(x, y, th, self.data)
        return res[:, 0], [self.gaits[int(g)] if g >= 0 else None for g in res[:, 1]]

    def gait_indices(self, gaits: Any, where: str = "gait") -> np.ndarray:
        """The kernel's gait index of each gait name (None: -1, the default gait).

        Raises
        ------
        MotionCostError
            A name that is none of :attr:`gaits` (naming it and ``where``), or gaits given
            to a cost that does not choose its gait.
        """
        names = list(gaits)
        if not self.gaits:
            if all(g is None for g in names):
                return np.full(len(names), -1.0)
            raise MotionCostError(
                f"{where}: gaits given ({sorted({str(g) for g in names if g is not None})}) "
                "but the model names no gaits it chooses among (no gait channel with the "
                "speeds per gait in metadata.fit.domain.gait_speed_m_s), or the gait is "
                "fixed by a channel; expected a model fitted on logs with a gait channel"
            )
        out = np.empty(len(names))
        for i, g in enumerate(names):
            if g is None:
                out[i] = -1.0
            elif g in self.gaits:
                out[i] = float(self.gaits.index(g))
            else:
                raise MotionCostError(
                    f"{where}: gait {g!r} of segment {i} is not one the model names; "
                    f"expected one of {', '.join(self.gaits)}"
                )
        return out

    def __getstate__(self) -> dict[str, Any]:
        """Pickled without compiled code (a dask worker loads the kernels itself)."""
        return {**self.__dict__, "_aot": None, "_fns": {}}

    def _kernels(self) -> Any:
        """The compiled kernel module of this cost.

        The motion kernels (:func:`~energy_planner.energy.kernels.kernel_module`); where
        the motions choose their gait, :func:`~energy_planner.energy.gait_kernels.
        gait_kernel_module` (the same kernels and the gait choice's).
        """
        return (gait_kernel_module if self.gaits else kernel_module)(self.source)

    @property
    def kernel(self) -> Any:
        """The numba kernel ``motion_cost(x0, y0, th0, x1, y1, th1, data)`` (J or inf).

        Where the motions choose their gait, ``gait_cost`` of :mod:`energy_planner.energy.
        gait_kernels`' module (the same signature).
        """
        return self._fn_numba("motion_cost")

    @property
    def map_kernel(self) -> Any:
        """The numba kernel of the energy map's costs (``map_costs``, see ``make_kernels``)."""
        return self._kernels().map_costs

    def _fn(self, name: str) -> Any:
        """Kernel ``name``: the precompiled one if there is one, else numba's."""
        fn = self._fns.get(name)
        if fn is None:
            fn = self._fns[name] = (
                getattr(self._aot, name) if self._aot is not None else self._fn_numba(name)
            )
        return fn

    def _fn_numba(self, name: str) -> Any:
        """The numba kernel ``name`` (its gait-choosing form where the motions choose)."""
        return getattr(self._kernels(), _GAIT_FORMS[name] if self.gaits else name)

    @property
    def precompiled(self) -> bool:
        """Whether the kernels are served by the precompiled module (no numba loaded).

        See :meth:`precompile` and ``precompiled=`` of the constructor.
        """
        return self._aot is not None

    def precompile(self, build: bool = True) -> bool:
        """Serve the kernels from the model's precompiled module, where there is one.

        :func:`energy_planner.energy.kernels.precompiled_module`: built once per machine
        and model (unless ``ENERGY_PLANNER_PRECOMPILE=0``), then imported without numba;
        ``build=False``: only where this machine has built it already. A cost whose
        motions choose their gait keeps numba's kernels. Returns :attr:`precompiled`.
        """
        if self._aot is None and not self.gaits:
            self._aot = precompiled_module(self.source, build=build)
            if self._aot is not None:
                self._fns = {}
        return self._aot is not None

    def compile(self) -> MotionCost:
        """Compile (or load from the disk cache) every kernel now, not on first use.

        Time-budgeted callers (planners) call this before their clock starts, so that
        a cold cache does not eat into the budget and change the result.
        """
        x, y = self.data[IN_X0], self.data[IN_Y0]  # centre of cell (0, 0): any point will do
        if self._aot is None:  # (precompiled: numba stays unloaded until a caller needs it)
            self.kernel(x, y, 0.0, x, y, 0.0, self.data)
        self(x, y, 0.0, x, y, 0.0)
        one = np.array([x])
        zero = np.zeros(1)
        self.batch(one, one * 0 + y, zero, one, one * 0 + y, zero)
        self.details(np.array([x, x]), np.array([y, y]), np.zeros(2), np.full(1, -1.0))
        return self

    def __call__(self, x0: float, y0: float, th0: float, x1: float, y1: float, th1: float):
        """Energy in J of one motion, ``inf`` if it breaks a limit or leaves the map."""
        return self._fn("motion_cost")(x0, y0, th0, x1, y1, th1, self.data)

    def batch(self, x0, y0, th0, x1, y1, th1) -> np.ndarray:
        """Vectorized :meth:`__call__` over equal-length arrays."""
        arrs = [np.ascontiguousarray(a, dtype=np.float64) for a in (x0, y0, th0, x1, y1, th1)]
        return self._fn("motion_batch")(*arrs, self.data)

    def details(self, x, y, th, durations=None, gaits=None) -> np.ndarray:
        """Per-motion results along a pose sequence, shape ``(n - 1, N_OUT)``.

        Columns, read through the named indices ``OUT_*`` of
        :mod:`energy_planner.energy.kernels`: energy J, duration s, distance m, |turn|
        rad, mean slope rad, mean |gamma| rad, max slope rad, energy by kind (forward,
        backward, lateral, turning, other), violation code, gait. ``gaits``: each
        motion's gait, an index of :attr:`gaits` (:meth:`gait_indices`; -1 or None: the
        channels' own).
        """
        x, y, th = (np.ascontiguousarray(a, dtype=np.float64) for a in (x, y, th))
        m = max(len(x) - 1, 0)
        if durations is None:
            durations = np.full(m, -1.0)
        durations = np.ascontiguousarray(durations, dtype=np.float64)
        if not self.gaits:
            if gaits is not None and np.any(np.asarray(gaits, dtype=np.float64) >= 0):
                raise MotionCostError("gaits given to a cost that does not choose its gait")
            out = self._fn("path_table")(x, y, th, durations, self.data)
        else:
            gaits = np.full(m, -1.0) if gaits is None else np.ascontiguousarray(gaits, np.float64)
            out = self._fn("path_table")(x, y, th, durations, gaits, self.data)
        assert out.shape[1] == N_OUT
        return out

    @property
    def min_cost_per_metre(self) -> float:
        """An admissible lower bound of J per metre of any motion on this terrain.

        The minimum of power / speed over slopes up to the terrain's steepest (or the
        limit), all headings, all directions of motion and speeds from a tenth of to the
        nominal speed (and over the speed range), with a 5% margin for the grid of the
        search; never negative.
        """
        if not hasattr(self, "_lb"):
            slope = np.arctan(np.hypot(self.data[IN_GRAD][..., 0], self.data[IN_GRAD][..., 1]))
            amax = float(np.nanmax(slope)) if np.isfinite(slope).any() else 0.0
            if self.max_slope_deg is not None:
                amax = min(amax, math.radians(self.max_slope_deg))
            speeds = self.speed * np.array([0.1, 0.25, 0.5, 0.75, 1.0])
            if self.speed_range is not None:  # and the range (a time price only adds)
                speeds = np.concatenate([speeds, np.geomspace(*self.speed_range, 9)])
            a, g, b, v = np.meshgrid(
                np.linspace(0, amax, 16),
                np.linspace(-np.pi, np.pi, 37),
                np.linspace(-np.pi, np.pi, 37),
                speeds,
                indexing="ij",
            )
            feats = {
                "alpha": a.ravel(), "gamma": g.ravel(), "vx": (v * np.cos(b)).ravel(),
                "vy": (v * np.sin(b)).ravel(), "wz": np.zeros(a.size), "ax": np.zeros(a.size),
                "ay": np.zeros(a.size),
            }  # fmt: skip
            per_m = np.inf
            samples = self.channels.value_samples()
            if self.gaits:  # every gait the motions may choose
                samples[GAIT_CHANNEL] = np.array(self.gaits, dtype=object)
            for combo in _combinations(samples):
                for k, val in combo.items():
                    feats[k] = np.full(a.size, val)
                per_m = min(per_m, float((self.model.power(feats) / v.ravel()).min()))
            self._lb = max(0.0, 0.95 * per_m)
        return self._lb

    def violation(self, x: float, y: float, th: float = 0.0) -> str | None:
        """Which limit the pose breaks (with the value), or ``None`` if it is valid."""
        out = self.details([x, x], [y, y], [th, th], [1.0])[0]
        code = int(out[OUT_CODE])
        if code == OK:
            # a zero-length motion samples the pose itself
            return None
        t = self.terrain
        sample = t.sample(np.array([x]), np.array([y]))
        slope = float(np.degrees(np.asarray(sample.slope)[0]))
        if code == TOO_STEEP:
            return f"slope {slope:.1f} deg > limit {self.max_slope_deg:g} deg"
        if code == TOO_CROSS:
            gamma = th - float(np.asarray(sample.uphill_azimuth)[0])
            cross = math.degrees(math.asin(math.sin(math.radians(slope)) * abs(math.sin(gamma))))
            return f"cross-slope {cross:.1f} deg > limit {self.max_cross_slope_deg:g} deg"
        return VIOLATIONS[code]


def _speed_inputs(
    model: Any, speed: float, speed_range: Any, time_weight: float, constants: Mapping[str, Any]
) -> tuple[tuple[float, float] | None, float, Any, tuple]:
    """``(speed_range, time_weight, law, kernel inputs IN_VMIN .. IN_VINV)`` of a cost."""
    if not (isinstance(time_weight, int | float) and math.isfinite(time_weight)
            and time_weight >= 0):  # fmt: skip
        raise MotionCostError(f"time_weight must be a finite number >= 0 J/s, got {time_weight!r}")
    if speed_range is None:
        empty = (np.zeros(0), np.zeros(0), np.zeros((0, 0)))
        return None, float(time_weight), None, (speed, speed, float(time_weight), *empty)
    from energy_planner.energy.speed import speed_law, speed_nodes

    try:
        lo, hi = (float(v) for v in speed_range)
    except (TypeError, ValueError):
        raise MotionCostError(
            f"speed_range must be (vmin, vmax) in m/s, got {speed_range!r}"
        ) from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
        raise MotionCostError(f"speed_range must satisfy 0 < vmin <= vmax m/s, got {lo:g}, {hi:g}")
    law = speed_law(model, constants)
    nodes, inverse = speed_nodes(law, lo, hi)
    exps = np.asarray(law.exponents if law.polynomial else (), dtype=np.float64)
    return (lo, hi), float(time_weight), law, (lo, hi, float(time_weight), exps, nodes, inverse)


#: The gait-choosing form of each kernel a cost calls (:mod:`energy_planner.energy._gait`).
_GAIT_FORMS = {
    "motion_cost": "gait_cost",
    "motion_batch": "gait_batch",
    "path_table": "gait_table",
    "path_speeds": "gait_speeds",
}


def _wants_gaits(model: Any, channels: Channels, choice: bool | None) -> bool:
    """Whether a cost chooses its gait (see :class:`MotionCost`'s ``gait_choice``)."""
    from energy_planner.uncertainty.domain import gait_speed_ranges

    if choice is False or GAIT_CHANNEL in channels.names or GAIT_CHANNEL not in model.variables:
        return False
    return bool(gait_speed_ranges(model))


def _gait_channels(
    model: Any, channels: Channels, speed: float
) -> tuple[Channels, tuple[str, ...]]:
    """``channels`` with the gait as a run-time constant over every gait, and the gaits.

    The gait channel's categories in the kernel: those the model's formulas name, then
    the other gaits its logs walked (the reference gait, priced as none of the named
    ones). Its value (the gait of a motion at the nominal ``speed``): the gait whose
    logged speeds hold ``speed`` (the narrowest range if several), else the one whose
    range is nearest; the kernels override it per motion where they choose.
    """
    from energy_planner.energy.channels import Category, channel_kinds
    from energy_planner.uncertainty.domain import gait_speed_ranges as gait_ranges

    logged = gait_ranges(model)
    named = tuple(channel_kinds(model)[GAIT_CHANNEL].categories or ())
    cats = named + tuple(sorted(g for g in logged if g not in named))
    nominal = min(
        (g for g in cats if g in logged),
        key=lambda g: (max(logged[g][0] - speed, speed - logged[g][1], 0.0),
                       logged[g][1] - logged[g][0]),
    )  # fmt: skip
    channels = replace(
        channels,
        constants={**channels.constants, GAIT_CHANNEL: Category(nominal)},
        runtime={**(channels.runtime or {}), GAIT_CHANNEL: cats},
        allow_unknown_categories=True,  # the reference gait: none the formulas name
    )
    return channels, cats


def _gait_inputs(
    model: Any,
    gaits: tuple[str, ...],
    channels: Channels,
    data: tuple,
    shape: tuple[int, int],
    speed_range: Any,
    time_weight: float,
) -> tuple[dict[str, tuple[float, float]], Any, tuple, tuple[str, ...]]:
    """The gait choice's ranges, speed law, per-gait kernel inputs and gaits.

    Each gait within the speeds its logs walked it at, clipped to ``speed_range`` (the
    gaits whose speeds miss it are left out); its inputs are ``data`` (the nominal
    gait's, :attr:`MotionCost.data`) with the gait's channel values and its own speed
    range and speed law's nodes (:mod:`energy_planner.energy.gait_kernels`). Without
    ``speed_range`` the motions keep the nominal speed and gait (a gait is given per
    motion to :meth:`MotionCost.details`): every gait, its logged range, the nominal
    speed. The law returned covers every gait (the union of their Laurent exponents;
    None without a range). Returns ``(ranges, law, per-gait inputs, gaits)``.

    Raises
    ------
    MotionCostError
        No gait's logged speeds meet ``speed_range``.
    """
    from energy_planner.energy.channels import Category
    from energy_planner.energy.kernels import IN_CHAN, IN_SPEED, IN_VMIN
    from energy_planner.energy.speed import SpeedLaw
    from energy_planner.uncertainty.domain import gait_speed_ranges as gait_ranges

    logged = gait_ranges(model)
    if speed_range is None:
        ranges = {g: logged[g] for g in gaits if g in logged}
    else:
        lo, hi = (float(v) for v in speed_range)
        ranges = {}
        for g in gaits:
            if g in logged:
                a, b = max(lo, logged[g][0]), min(hi, logged[g][1])
                if b >= a:
                    ranges[g] = (a, b)
        if not ranges:
            have = ", ".join(f"{g} {a:g}-{b:g}" for g, (a, b) in logged.items())
            raise MotionCostError(
                f"no gait's logged speeds ({have} m/s) meet the speed range {lo:g}-{hi:g} "
                "m/s; expected a range that overlaps the logs'"
            )
        gaits = tuple(ranges)  # the kernel's gaits: those within the range
    consts = dict(channels.constants)
    per_gait = []
    laws = []
    for g in gaits:
        mine = replace(channels, constants={**consts, GAIT_CHANNEL: Category(g)})
        chan, _ = mine.stack(shape, runtime=True)
        speed_in = data[IN_VMIN:]
        if speed_range is not None:
            _, _, law, speed_in = _speed_inputs(
                model, data[IN_SPEED], ranges[g], time_weight, {**consts, GAIT_CHANNEL: g}
            )
            laws.append(law)
        per_gait.append((*data[:IN_CHAN], chan, *data[IN_CHAN + 1 : IN_VMIN], *speed_in))
    if not laws:
        return ranges, None, tuple(per_gait), gaits
    degrees: dict[str, int | None] = {}
    for law in laws:
        for name, d in law.degrees.items():
            degrees[name] = d if degrees.get(name, d) == d else None
    polynomial = all(law.polynomial for law in laws)
    exps = sorted({e for law in laws for e in law.exponents}) if polynomial else [-1]
    return ranges, SpeedLaw(tuple(exps), degrees, polynomial), tuple(per_gait), gaits


def gait_limit_values(
    max_backward_slope_deg: float | None, max_crab_deg: float | None
) -> tuple[float, float]:
    """The kernels' form of the gait limits: ``(btan, cmax)``.

    ``btan`` is the tangent of the steepest slope on which walking backward is allowed,
    ``cmax`` the largest crab angle in radians; ``inf`` for no limit. Used by the motion
    kernel's data tuple and by the energy map.

    Examples
    --------
    >>> gait_limit_values(None, 0)
    (inf, 0.0)
    >>> round(gait_limit_values(45, None)[0], 12)
    1.0
    """
    btan = (
        math.inf
        if max_backward_slope_deg is None
        else math.tan(math.radians(max_backward_slope_deg))
    )
    cmax = math.inf if max_crab_deg is None else math.radians(max_crab_deg)
    return btan, cmax


def _combinations(samples: Mapping[str, np.ndarray]) -> list[dict[str, Any]]:
    """Every combination of the sampled channel values (one dict per combination)."""
    combos: list[dict[str, Any]] = [{}]
    for name, values in samples.items():
        combos = [{**c, name: v} for c in combos for v in values]
    return combos


def _shared_gradient(terrain: Any) -> np.ndarray:
    """The terrain's gradient as the kernels read it: ``(rows, cols, 2)`` float64, C order.

    A :class:`~energy_planner.terrain.Terrain` keeps it in that layout (``grad``): shared,
    not copied (on a 3200 x 3200 DEM a copy is 164 MB). Other terrains (windows, test
    doubles) give ``dzdx`` and ``dzdy``, stacked here.
    """
    g = getattr(terrain, "grad", None)
    gx = np.asarray(terrain.dzdx)
    if (
        isinstance(g, np.ndarray)
        and g.dtype == np.float64
        and g.flags.c_contiguous
        and g.shape == (*gx.shape, 2)
    ):
        return g
    gy = np.asarray(terrain.dzdy, dtype=np.float64)
    return np.ascontiguousarray(np.stack([gx.astype(np.float64, copy=False), gy], axis=-1))
