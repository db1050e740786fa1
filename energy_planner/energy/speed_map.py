"""The cheapest way to move along a heading when the robot also chooses its speed.

:class:`RangedHeadingCost` is :class:`~energy_planner.energy.heading.HeadingCost` (the
energy map's ``best_*`` bands, its table and lookups) with every body yaw walked at its
best ground speed within a range, as each motion of the planners walks
(:func:`energy_planner.energy._motion.motion_best`): the least J per map metre over yaw
**and** speed, and the speed that gives it (:meth:`RangedHeadingCost.cheapest_speed`).

How: the kernels of ``_motion.py`` run unchanged in a module of their own
(:func:`speed_map_source`) whose ``power`` returns, for the body twist of 1 m/s of
ground, the cost of a ground metre at the best speed of the range (``_speedmap.py``:
the motions' closed form on the Laurent polynomial of the model's speed law,
:mod:`energy_planner.energy.speed`). So one yaw sweep, one table and one bilinear lookup
serve both maps, and a model without a speed range compiles nothing new: its kernel
modules, and their text, are those of :mod:`energy_planner.energy.kernels`.
"""

from __future__ import annotations

import hashlib
import math
import re
import warnings
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from energy_planner.energy.heading import TABLE_TOP_DEG, HeadingCost, _top, heading_cost

__all__ = [
    "GaitChoice",
    "RangedHeadingCost",
    "gait_choice",
    "ranged_heading_cost",
    "speed_map_source",
    "speed_tail",
]

_TEMPLATE = Path(__file__).with_name("_speedmap.py")
#: The imports of ``_speedmap.py`` that stand for the generated module's own functions.
_IMPORTS = re.compile(
    r"from energy_planner\.energy\._motion import \(  # --- motion ---\n.*?\)\n"
    r"|from energy_planner\.energy\._motion import power as model_power  # --- model power ---\n",
    re.S,
)
_WRAPPER = (
    "def power(alpha, gamma, vx, vy, wz, ax, ay, ch):\n"
    "    return ranged_power(alpha, gamma, vx, vy, wz, ax, ay, ch)\n\n\n"
    "@numba.njit(cache=True)\n"
)


def ranged_power_source(power_source: str) -> str:
    """The ``power`` block of the module: :func:`ranged_power` over the model's power.

    The model's ``power`` (:meth:`EnergyModel.kernel_source`) renamed ``model_power``.
    """
    head = "def power(alpha, gamma, vx, vy, wz, ax, ay, ch):"
    assert power_source.lstrip().startswith(head), "unexpected power source"
    return _WRAPPER + power_source.replace("def power(", "def model_power(", 1)


def speed_map_source(ranged_source: str) -> str:
    """The text of the module: the motion kernels with ``ranged_source``, then ``_speedmap.py``.

    ``ranged_source``: :func:`ranged_power_source` of a model's power. The text holds
    every function it compiles (the helpers ``_motion.py`` imports are hashed in the
    motion kernels' header), so a change to this file's Python compiles nothing.
    """
    from energy_planner.energy.kernels import motion_source

    text = _TEMPLATE.read_text().replace("from __future__ import annotations\n", "")
    text, n = _IMPORTS.subn("", text)
    assert n == 2, "the import markers of _speedmap.py are missing"
    return (
        "# speed_map.py\n"
        + motion_source(ranged_source)
        + "\n\n# --- the best speed of each heading (energy/_speedmap.py) ---\n"
        + text
    )


@lru_cache(maxsize=16)
def speed_map_module(ranged_source: str):
    """The compiled module of :func:`speed_map_source` (numba's disk cache, as the others)."""
    from energy_planner.model._codegen import load_generated_module

    return load_generated_module(speed_map_source(ranged_source), prefix="speedmap")


def speed_tail(model: Any, constants: dict[str, Any], lo: float, hi: float, before: int):
    """The kernel's speed inputs, appended to the channel values (``_speedmap.py``).

    ``vmin, vmax, K, exponents, nodes, inverse, offset``: the model's speed law
    (:func:`~energy_planner.energy.speed.speed_law`, with the channel ``constants``) and
    its nodes on ``[lo, hi]`` (:func:`~energy_planner.energy.speed.speed_nodes`);
    ``before``: the number of channel values before it (the offset of ``vmin``).
    """
    from energy_planner.energy.speed import speed_law, speed_nodes

    law = speed_law(model, constants)
    nodes, inverse = speed_nodes(law, lo, hi)
    k = len(nodes) - 1 if len(nodes) else 0
    exps = np.asarray(law.exponents if k else (), dtype=np.float64)
    tail = [lo, hi, float(k), *exps.tolist(), *nodes.tolist(), *inverse.ravel().tolist()]
    return (*tail, float(before)), law


class RangedHeadingCost(HeadingCost):
    """:class:`~energy_planner.energy.heading.HeadingCost` at the best speed of a range.

    Build it with :func:`ranged_heading_cost`. Its ``source`` is the ranged ``power``
    (:func:`ranged_power_source`), its ``speed`` 1 (m/s: the unit twist that power takes)
    and its ``consts`` end with the speed inputs (:func:`speed_tail`). Its table holds,
    after the three costs, the speed of each (``speed_heading_table``); it has no
    precompiled module (numba's kernels, parallel over a block's rows, serve).
    """

    _TABLE_KERNEL = "speed_heading_table"
    _TABLE_DEPTH = 6
    #: The bands it adds after the energy map's summary bands (:meth:`fill_speed_bands`).
    speed_band_names = ("cheapest_speed",)

    @property
    def _mod(self) -> Any:
        if self._numba is None:
            self._numba = speed_map_module(self.source)
        return self._numba

    def precompiled_map(self) -> Any:
        """None: the ranged map runs numba's kernels."""
        return None

    def _key(self, values: tuple[float, ...] = (), top_deg: float | None = None) -> str:
        """The table's cache key: the fixed-speed key's text, and ``_speedmap.py``'s."""
        base = super()._key(values, top_deg)
        return hashlib.sha256(base.encode() + _TEMPLATE.read_bytes()).hexdigest()[:24]

    def __reduce__(self):
        return (_ranged_cached, self.params)

    @property
    def speed_range(self) -> tuple[float, float]:
        """``(vmin, vmax)``, m/s."""
        o = int(self.consts[-1]) - self.rasters
        return self.consts[o], self.consts[o + 1]

    def cheapest_speed(
        self, gx: np.ndarray, gy: np.ndarray, chan: np.ndarray, heading: np.ndarray,
        out: np.ndarray,
    ) -> None:  # fmt: skip
        """The best ground speed (m/s) of moving along ``heading`` (radians, per cell).

        ``gx``, ``gy``: float64 ``(rows, cols)``; ``chan``: ``(k, rows, cols)``;
        ``heading``: ``(rows, cols)`` (NaN: none); ``out``: ``(rows, cols)`` float32. The
        speed of the yaw :meth:`map_bands` prices ``best`` with (from the table's speed
        layers, bilinear, where the cost is read from the table; else at the exact
        minimum's yaw). NaN where the cost is not finite.
        """
        head = np.ascontiguousarray(heading, dtype=np.float64)
        res = np.empty(gx.shape)
        with np.errstate(invalid="ignore"):
            g2 = gx * gx + gy * gy
            ok = np.isfinite(g2) & (g2 <= self.tmax * self.tmax)
        if not self.rasters or not self.categorical:
            table = np.zeros((6, 0, 0))
            if not self.rasters:
                table = np.ascontiguousarray(self.table(_top(g2[ok])))
            self._speeds(gx, gy, chan, head, table, res)
            out[:] = res
            return
        out[:] = np.nan
        for cells, table in self._combination_tables(chan, g2, ok):
            self._speeds(gx, gy, chan, np.where(cells, head, np.nan),
                         np.ascontiguousarray(table), res)  # fmt: skip
            out[cells] = res[cells]

    def fill_speed_bands(self, gx, gy, chan, heading, out, best=None) -> None:
        """The bands of :attr:`speed_band_names` into ``out`` (``(1, rows, cols)``)."""
        self.cheapest_speed(gx, gy, chan, heading, out[0])

    def _speeds(self, gx, gy, chan, head, table, res) -> None:
        self._mod.map_speeds(
            gx, gy, chan, self._consts, head, self.tmax, self.smax, self.back_tan, self.crab,
            table, self.d_alpha, res,
        )  # fmt: skip


@lru_cache(maxsize=32)
def _ranged_cached(*params: Any) -> RangedHeadingCost:
    return RangedHeadingCost(*params)


def ranged_heading_cost(
    model: Any,
    speed_range: tuple[float, float],
    *,
    channels: Any = None,
    max_slope_deg: float | None = None,
    max_cross_slope_deg: float | None = None,
    max_crab_deg: float | None = None,
    max_backward_slope_deg: float | None = None,
    top_deg: float = TABLE_TOP_DEG,
) -> RangedHeadingCost:
    """:func:`~energy_planner.energy.heading.heading_cost` with each yaw at its best speed.

    ``speed_range``: ``(vmin, vmax)``, ground speeds in m/s; the other arguments as
    :func:`~energy_planner.energy.heading.heading_cost`'s (its source, limits and channel
    values: the physics of the fixed-speed map, then the speed choice on top).

    Examples
    --------
    >>> from energy_planner.model import EnergyModel
    >>> m = EnergyModel(["speed", "1", "speed ** 2"], {"speed": 120.0, "1": 40.0,
    ...                                                "speed ** 2": 100.0})
    >>> hc = ranged_heading_cost(m, (0.2, 1.5))  # flat: 120 + 40 / v + 100 v, v = 0.632
    >>> hc.speed_range
    (0.2, 1.5)
    """
    from energy_planner.energy.channels import Channels
    from energy_planner.errors import ModelError

    lo, hi = (float(v) for v in speed_range)
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
        raise ModelError(f"speed_range must satisfy 0 < vmin <= vmax (m/s), got ({lo:g}, {hi:g})")
    fixed = heading_cost(
        model, speed=lo, channels=channels, max_slope_deg=max_slope_deg,
        max_cross_slope_deg=max_cross_slope_deg, max_crab_deg=max_crab_deg,
        max_backward_slope_deg=max_backward_slope_deg, top_deg=top_deg,
    )  # fmt: skip
    resolved = (channels if channels is not None else Channels()).resolve(model)
    tail, _ = speed_tail(model, dict(resolved.constants), lo, hi,
                         fixed.rasters + len(fixed.consts))  # fmt: skip
    p = fixed.params
    return _ranged_cached(ranged_power_source(p[0]), 1.0, *p[2:8], (*p[8], *tail), *p[9:])


class GaitChoice:
    """Each cell and heading in the gait and at the speed that cost it least.

    The gaits of a model that names them (the motions' choice, :class:`~energy_planner.
    energy.MotionCost`'s ``gaits``), each a :class:`RangedHeadingCost` within its logged
    speeds clipped to the range: ``along`` and ``best`` are the least over the gaits;
    the bands ``cheapest_speed`` and ``cheapest_gait`` (the gait's index in
    :attr:`gaits`) are those of the gait cheapest along the cheapest heading. Build it
    with :func:`gait_choice`.
    """

    speed_band_names = ("cheapest_speed", "cheapest_gait")

    def __init__(self, gaits: tuple[str, ...], costs: list[RangedHeadingCost]) -> None:
        self.gaits = tuple(gaits)
        self.costs = list(costs)
        first = self.costs[0]
        self.tmax, self.smax, self.crab, self.back_tan = (
            first.tmax, first.smax, first.crab, first.back_tan
        )  # fmt: skip
        self.ranges = {g: c.speed_range for g, c in zip(self.gaits, self.costs, strict=True)}

    @property
    def speed_range(self) -> tuple[float, float]:
        """The least and greatest speed over the gaits' ranges, m/s."""
        return min(r[0] for r in self.ranges.values()), max(r[1] for r in self.ranges.values())

    def precompiled_map(self) -> Any:
        """None: numba's kernels."""
        return None

    def map_bands(self, gx, gy, chan, headings, along, best, precompiled=False) -> None:
        """``along`` and ``best`` least over the gaits (as :meth:`HeadingCost.map_bands`)."""
        a = np.empty_like(along)
        kept = []
        for k, hc in enumerate(self.costs):
            b = np.empty_like(best)
            hc.map_bands(gx, gy, chan, headings, a, b)
            kept.append(b)
            if k == 0:
                along[:] = a
                best[:] = b
            else:
                np.minimum(along, a, out=along)
                np.minimum(best, b, out=best)
        # each gait's best bands, for fill_speed_bands of the same block (block_bands
        # calls it next, in the same thread; the dask path holds a lock around both)
        self._kept = (gx, headings, kept)

    def fill_speed_bands(self, gx, gy, chan, heading, out, best=None) -> None:
        """``cheapest_speed`` and ``cheapest_gait`` into ``out`` (``(2, rows, cols)``).

        ``best``: the map's ``best`` bands (N headings), whose heading nearest
        ``heading`` is the cheapest one; each gait prices it again (its ``best`` band at
        that heading) and the cheapest gait's speed is kept (the first on ties).
        """
        n = best.shape[0]
        fin = np.isfinite(heading)
        j = np.where(fin, np.rint(np.where(fin, heading, 0.0) / (2 * np.pi / n)), 0).astype(int) % n
        ang = 2 * np.pi * np.arange(n) / n
        keep = np.full(heading.shape, np.inf)
        out[0] = np.nan
        out[1] = np.nan
        kept = getattr(self, "_kept", None)
        same = (kept is not None and kept[0] is gx and len(kept[1]) == n
                and np.allclose(kept[1], ang))  # fmt: skip
        a = np.empty_like(best)
        v = np.empty(heading.shape, np.float32)
        for k, hc in enumerate(self.costs):
            if same:
                b = kept[2][k]
            else:
                b = np.empty_like(best)
                hc.map_bands(gx, gy, chan, ang, a, b)
            cost = np.take_along_axis(b, j[None], axis=0)[0].astype(np.float64)
            better = fin & np.isfinite(cost) & (cost < keep)
            if not better.any():
                continue
            hc.cheapest_speed(gx, gy, chan, heading, v)
            keep[better] = cost[better]
            out[0][better] = v[better]
            out[1][better] = k
        self._kept = None


def gait_choice(
    model: Any, speed_range: tuple[float, float], channels: Any, **limits: Any
) -> GaitChoice | None:
    """The gait choice of a map at the best speed, or None where the model names no gaits.

    As the motions choose (:class:`~energy_planner.energy.MotionCost`'s ``gait_choice``):
    where the model reads a gait channel, its logs name the speeds of each gait
    (:func:`~energy_planner.uncertainty.domain.gait_speed_ranges`) and ``channels`` (the
    resolved channels) do not give the gait, each gait within its logged speeds clipped
    to ``speed_range``. ``limits``: :func:`ranged_heading_cost`'s.

    Raises
    ------
    MotionCostError
        No gait's logged speeds meet the range.
    """
    from dataclasses import replace

    from energy_planner.energy.channels import Category
    from energy_planner.energy.motion import _gait_channels, _wants_gaits
    from energy_planner.errors import MotionCostError
    from energy_planner.model import GAIT_CHANNEL
    from energy_planner.uncertainty.domain import gait_speed_ranges

    if not _wants_gaits(model, channels, None):
        return None
    lo, hi = (float(v) for v in speed_range)
    base, gaits = _gait_channels(model, channels, lo)
    logged = gait_speed_ranges(model)
    names, costs = [], []
    for g in gaits:
        if g not in logged:
            continue
        a, b = max(lo, logged[g][0]), min(hi, logged[g][1])
        if b < a:
            continue
        mine = replace(base, constants={**base.constants, GAIT_CHANNEL: Category(g)})
        names.append(g)
        with warnings.catch_warnings():  # the reference gait: priced as none named
            warnings.filterwarnings("ignore", message="channel 'gait'")
            costs.append(ranged_heading_cost(model, (a, b), channels=mine, **limits))
    if not costs:
        have = ", ".join(f"{g} {a:g}-{b:g}" for g, (a, b) in logged.items())
        raise MotionCostError(
            f"no gait's logged speeds ({have} m/s) meet the speed range {lo:g}-{hi:g} m/s; "
            "expected a range that overlaps the logs'"
        )
    return GaitChoice(tuple(names), costs)
