"""A fitted model's cost per metre against speed, and its optimum speed.

With the speed terms (:data:`energy_planner.model.SPEED_TERMS`, fitted when the logs span
a range of speeds, :func:`energy_planner.calibration.fit.speed_support`) the cost per
metre of steady walking, ``P(v) / v``, has an optimum: standing power paid per second
makes slow walking dear, swing and impact losses growing with speed make fast walking
dear. These functions evaluate it numerically on a fine grid of speeds, per gait where the
model reads the ``gait`` channel (each gait within the speeds the logs walked it at,
:func:`energy_planner.uncertainty.domain.gait_speed_ranges`), so that it holds for any
term set.

Examples
--------
>>> from energy_planner.model import EnergyModel
>>> m = EnergyModel(["idle_power", "fwd_const", "speed_cubed"],
...                 {"idle_power": 100.0, "fwd_const": 50.0, "speed_cubed": 200.0})
>>> round(optimum_speed(m, 0.0, speed_range=(0.1, 2.0))["speed"], 2)  # (100 / 400) ** (1/3)
0.63
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from energy_planner.errors import ModelError
from energy_planner.model import GAIT_CHANNEL

__all__ = ["cost_per_metre", "cost_curves", "optimum_speed"]

_MOTIONS = {"forward": (1.0, 0.0), "backward": (-1.0, 0.0), "left": (0.0, 1.0),
            "right": (0.0, -1.0)}  # fmt: skip


def cost_per_metre(
    model: Any,
    speeds: Any,
    slope_deg: float,
    heading_deg: float = 0.0,
    *,
    motion: str = "forward",
    channels: Mapping[str, Any] | None = None,
    gait: str | None = None,
) -> np.ndarray:
    """The model's cost per metre (J/m) of steady straight walking at each speed.

    Parameters
    ----------
    model : EnergyModel
        A fitted model.
    speeds : array-like
        Speeds, m/s (> 0).
    slope_deg, heading_deg : float
        Slope and relative heading ``gamma`` (0 uphill, 180 downhill, +90 uphill on the
        right), deg.
    motion : str
        ``forward``, ``backward``, ``left`` or ``right``.
    channels : mapping, optional
        Values of the log channels the model reads (``load_kg``, ...).
    gait : str, optional
        The value of the ``gait`` channel (needed when the model reads it).

    Raises
    ------
    ModelError
        Unknown motion, or a model that reads the gait channel without ``gait``.
    """
    if motion not in _MOTIONS:
        raise ModelError(f"motion {motion!r} is unknown: expected one of {', '.join(_MOTIONS)}")
    v = np.atleast_1d(np.asarray(speeds, dtype=float))
    n = v.size
    ux, uy = _MOTIONS[motion]
    f: dict[str, Any] = {
        "alpha": np.full(n, math.radians(slope_deg)),
        "gamma": np.full(n, math.radians(heading_deg)),
        "vx": ux * v,
        "vy": uy * v,
        "wz": np.zeros(n),
        "ax": np.zeros(n),
        "ay": np.zeros(n),
        "speed": v,
    }
    for name, value in dict(channels or {}).items():
        f[name] = np.full(n, value, dtype=object if isinstance(value, str) else float)
    if GAIT_CHANNEL in model.variables:
        if gait is None:
            raise ModelError(
                "the model prices the gait channel: give the gait (one of "
                + ", ".join(gait_ranges(model) or ["its gaits"])
                + ")",
                expected="a gait",
            )
        f[GAIT_CHANNEL] = np.full(n, gait, dtype=object)
    return model.power(f) / v


def gait_ranges(model: Any) -> dict[str, tuple[float, float]]:
    """Per gait of the model, the speeds its calibration walked it at (empty without)."""
    from energy_planner.uncertainty.domain import gait_speed_ranges

    return gait_speed_ranges(model) if GAIT_CHANNEL in model.variables else {}


def cost_curves(
    model: Any,
    slope_deg: float,
    heading_deg: float = 0.0,
    *,
    speed_range: tuple[float, float] | None = None,
    motion: str = "forward",
    channels: Mapping[str, Any] | None = None,
    n: int = 401,
) -> dict[str, dict[str, np.ndarray]]:
    """The cost per metre over the calibrated speeds, per gait (one curve without gaits).

    Returns
    -------
    dict
        Gait (``""`` for a model without the gait channel) -> ``{"speed", "cost_n"}``
        arrays over the gait's recorded speeds within ``speed_range`` (default: the
        model's :func:`~energy_planner.uncertainty.domain.speed_range`).

    Raises
    ------
    ModelError
        No speed range given and none recorded.
    """
    from energy_planner.uncertainty.domain import speed_range as recorded

    rng = speed_range or recorded(model)
    if rng is None:
        raise ModelError(
            "the model records no walking speeds (metadata.fit.domain.speed_m_s): give "
            "speed_range=(low, high)",
            expected="a speed range",
        )
    lo, hi = float(rng[0]), float(rng[1])
    gaits = gait_ranges(model) or {"": (lo, hi)}
    out = {}
    for g, (glo, ghi) in gaits.items():
        a, b = max(lo, glo), min(hi, ghi)
        if not b > a:
            continue
        v = np.linspace(a, b, n)
        c = cost_per_metre(model, v, slope_deg, heading_deg, motion=motion,
                           channels=channels, gait=g or None)  # fmt: skip
        out[g] = {"speed": v, "cost_n": c}
    return out


def optimum_speed(
    model: Any,
    slope_deg: float,
    heading_deg: float = 0.0,
    *,
    speed_range: tuple[float, float] | None = None,
    motion: str = "forward",
    channels: Mapping[str, Any] | None = None,
    n: int = 1001,
) -> dict[str, Any]:
    """The speed of least cost per metre within the calibrated speeds (and its gait).

    Numerically, on :func:`cost_curves`. ``interior`` is False when the least cost lies at
    an end of the range (the logs do not bracket the optimum there).

    Returns
    -------
    dict
        ``speed`` (m/s), ``cost_n`` (J/m), ``gait`` (None without a gait channel),
        ``interior``.
    """
    curves = cost_curves(model, slope_deg, heading_deg, speed_range=speed_range,
                         motion=motion, channels=channels, n=n)  # fmt: skip
    if not curves:
        raise ModelError("no gait of the model was walked within the speed range")
    best = None
    for g, c in curves.items():
        k = int(np.argmin(c["cost_n"]))
        if best is None or c["cost_n"][k] < best[1]:
            best = (g, float(c["cost_n"][k]), float(c["speed"][k]))
    g, cost, v = best
    lo = min(float(c["speed"][0]) for c in curves.values())
    hi = max(float(c["speed"][-1]) for c in curves.values())
    return {"speed": v, "cost_n": cost, "gait": g or None, "interior": lo < v < hi}
