"""The best walking speed of a motion: closed form where the power is polynomial in speed.

A motion at ground speed ``v`` along a straight line of ground length ``L`` costs
``E(v) = L P(v) / v`` joules and lasts ``L / v`` seconds, where the power ``P`` is the
model's at the motion state: slope ``alpha``, relative heading ``gamma``, the direction of
travel in the body frame (``travel``: 0 walking forward, ``pi/2`` to the left) and the
channels. The body twist scales with the speed (``vx = v cos(travel)``, ``vy = v
sin(travel)``, ``wz = v * turn_per_metre``), so every term of the model is, in each
regime, a power of ``v``: the per-second terms (standing, copper losses) of degree 0,
the per-metre forces of degree 1, swing and damping losses of degree 2 or 3.

:func:`speed_law` finds these degrees from the term formulas (each term evaluated at
three speeds over a sample of states: a term whose ratios are one integer power of the
speed ratio is homogeneous of that degree). Energy per metre is then the Laurent
polynomial ``sum_k a_k v^(d_k - 1)``; :func:`best_speed` recovers its coefficients at
each state from the model evaluated at ``K`` speeds (a ``K x K`` linear solve, the same
matrix for every state), checks the fit at one more speed, and takes the least over
``[vmin, vmax]`` in closed form (:func:`energy_planner.energy._laurent.laurent_argmin`:
ends and roots of the derivative). Where the check fails (a term with a kink inside the
range, as the brake terms' switch at 0.05 m/s of forward speed, or the floor of the
power at zero) the state falls back to a bounded scalar minimisation (golden section,
which assumes a single minimum in the range); a model whose terms are not polynomial in
speed at all (:attr:`SpeedLaw.polynomial` False) falls back everywhere, and says so.

Trading energy for time (a deadline), the cost of a metre is ``E / L + lambda / v``
(``lambda`` in J/s, :func:`best_speed`'s ``time_weight``): one more ``v^-1`` term, the
same closed form.

The motion kernels choose speed the same way per motion, summing the node energies over
the motion's sub-steps (:func:`energy_planner.energy._motion.motion_best`).

Examples
--------
>>> from energy_planner.model import EnergyModel
>>> m = EnergyModel(["1", "speed", "speed ** 3"], {"1": 40.0, "speed": 100.0, "speed ** 3": 90.0})
>>> speed_law(m).exponents
(-1, 0, 2)
>>> round(float(best_speed(m, 0.0, 0.0, speed_range=(0.1, 2.0)).speed), 4)  # (40 / 2 / 90) ** (1/3)
0.6057
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

from energy_planner.errors import ModelError

__all__ = ["SpeedLaw", "SpeedChoice", "speed_law", "speed_nodes", "best_speed", "MAX_DEGREE"]

#: Degrees of power in speed the closed form handles: ``-1 .. 3`` (energy per metre
#: ``v^-2 .. v^2``: the derivative times ``v^3`` is a polynomial of degree at most 4).
MIN_DEGREE, MAX_DEGREE = -1, 3
#: Relative tolerance of the check of the Laurent fit at an extra speed.
FIT_RTOL = 1e-7
#: Speeds at which :func:`speed_law` compares each term (m/s; ratios 2 and 2).
_PROBE = (0.3, 0.6, 1.2)
#: Golden-section iterations of the fallback (the bracket shrinks to 0.618^48 of the range).
_GOLDEN_ITERS = 48


@dataclass(frozen=True)
class SpeedLaw:
    """How a model's power depends on the ground speed.

    Attributes
    ----------
    exponents : tuple of int
        Exponents of the energy per metre's Laurent polynomial in ``v`` (power degree
        minus one), increasing; ``-1`` (per-second power, and the time weight) always.
    degrees : dict
        Term name -> its degree in speed; None where the term is not homogeneous (a kink
        in speed, see the module docstring), absent where it vanishes on every motion.
    polynomial : bool
        Every non-vanishing term has a degree in ``[-1, 3]``: the closed form applies (the
        fit is still checked per state).
    """

    exponents: tuple[int, ...]
    degrees: dict[str, int | None]
    polynomial: bool

    @property
    def note(self) -> str:
        """One line for reports: closed form, piecewise, or scalar minimisation."""
        if not self.polynomial:
            return (
                "power is not a polynomial in speed: the best speed of every motion is found "
                "by a bounded scalar minimisation (golden section)"
            )
        kinked = [n for n, d in self.degrees.items() if d is None]
        base = "best speed in closed form (energy per metre a Laurent polynomial in speed"
        if kinked:
            return (
                f"{base}); where {', '.join(kinked)} switch regime within the speed range, by "
                "a bounded scalar minimisation"
            )
        return base + ")"


@dataclass
class SpeedChoice:
    """The best speed of each motion state (:func:`best_speed`).

    Attributes
    ----------
    speed : ndarray
        m/s, within the range.
    energy_per_metre : ndarray
        J per metre of ground at that speed (the time weight not included).
    closed_form : ndarray of bool
        The Laurent fit was exact at the state (else the scalar minimisation chose).
    law : SpeedLaw
    """

    speed: np.ndarray
    energy_per_metre: np.ndarray
    closed_form: np.ndarray
    law: SpeedLaw


def _channel_values(model: Any, constants: Mapping[str, Any] | None) -> dict[str, Any]:
    from energy_planner.model.formula import MOTION_FEATURES

    consts = dict(constants or {})
    return {n: consts.get(n, 1.0) for n in sorted(model.variables - MOTION_FEATURES)}


def _features(v: np.ndarray, alpha, gamma, travel, turn, chans: Mapping[str, Any]) -> dict:
    """Model features of walking at speed ``v`` (arrays broadcast together)."""
    v, alpha, gamma, travel, turn = np.broadcast_arrays(
        *(np.asarray(a, dtype=np.float64) for a in (v, alpha, gamma, travel, turn))
    )
    z = np.zeros(v.shape)
    feats: dict[str, Any] = {
        "alpha": alpha, "gamma": gamma, "vx": v * np.cos(travel), "vy": v * np.sin(travel),
        "wz": v * turn, "ax": z, "ay": z, "speed": v,
    }  # fmt: skip
    for name, val in chans.items():
        feats[name] = np.full(v.shape, val, dtype=object if isinstance(val, str) else float)
    return feats


def speed_law(model: Any, constants: Mapping[str, Any] | None = None) -> SpeedLaw:
    """The degrees in speed of a model's terms, and the Laurent exponents they give.

    Each term's formula is evaluated over a fixed sample of motion states (slopes to 35
    degrees, every heading and direction of travel, with and without turning) at the
    speeds 0.3, 0.6 and 1.2 m/s; where both ratios are the same integer power of 2 at
    every state the term is homogeneous of that degree. A term that vanishes on every
    motion (``ax``, ``ay`` are 0 on a planned motion) is left out; one that is not
    homogeneous has degree None, and contributes the integer degrees it shows at most
    states (the fit is checked per state, see :func:`best_speed`).

    Parameters
    ----------
    model : EnergyModel
    constants : mapping, optional
        Values of the channels the terms read (others are taken as 1).

    Notes
    -----
    The law depends on the terms and the channel values only, not on the coefficients:
    it is computed once per such pair (every cost with a speed range asks for it, and a
    deadline or a front builds dozens of costs on one model).
    """
    key = (tuple(model.terms), tuple(_channel_values(model, constants).items()))
    try:
        hash(key)
    except TypeError:  # a channel value that cannot be a key
        return _speed_law.__wrapped__(*key)
    return _speed_law(*key)


@lru_cache(maxsize=32)
def _speed_law(terms: tuple, chan_items: tuple) -> SpeedLaw:
    """:func:`speed_law` of the model of ``terms`` with these channel values."""
    from energy_planner.model import EnergyModel

    model, chans = EnergyModel(terms), dict(chan_items)
    rng = np.random.default_rng(12345)
    n = 256
    alpha = rng.uniform(0.0, math.radians(35.0), n)
    gamma = rng.uniform(-math.pi, math.pi, n)
    travel = rng.uniform(-math.pi, math.pi, n)
    turn = np.where(np.arange(n) % 2 == 0, 0.0, rng.uniform(-0.5, 0.5, n))
    cols = [
        model.design_matrix(_features(np.full(n, v), alpha, gamma, travel, turn, chans))
        for v in _PROBE
    ]
    degrees: dict[str, int | None] = {}
    exps = {-1}
    polynomial = True
    for j, term in enumerate(model.terms):
        t1, t2, t3 = (c[:, j] for c in cols)
        scale = max(float(np.max(np.abs(np.concatenate([t1, t2, t3])))), 0.0)
        if scale == 0.0:
            continue  # vanishes on every motion
        live = (np.abs(t1) > 1e-12 * scale) & (np.abs(t2) > 1e-12 * scale)
        with np.errstate(divide="ignore", invalid="ignore"):
            d12 = np.log2(t2[live] / t1[live])
            d23 = np.log2(t3[live] / t2[live])
        ok = np.isfinite(d12) & np.isfinite(d23) & (np.sign(t1[live]) == np.sign(t2[live]))
        r12 = np.round(d12)
        homog = bool(
            live.any()
            and ok.all()
            and np.all(np.abs(d12 - r12) < 1e-6)
            and np.all(np.abs(d23 - r12) < 1e-6)
            and np.all(r12 == r12[0])
            and not np.any((np.abs(t1) <= 1e-12 * scale) & (np.abs(t3) > 1e-12 * scale))
        )
        if homog:
            d = int(r12[0])
            degrees[term.name] = d
        else:
            degrees[term.name] = None
            near = ok & (np.abs(d12 - r12) < 1e-6)
            seen = sorted({int(v) for v in r12[near]}) if near.any() else []
            for d in seen:
                if MIN_DEGREE <= d <= MAX_DEGREE:
                    exps.add(d - 1)
            continue
        if not (MIN_DEGREE <= d <= MAX_DEGREE):
            polynomial = False
        else:
            exps.add(d - 1)
    if not polynomial:
        exps = {-1}
    return SpeedLaw(tuple(sorted(exps)), degrees, polynomial)


def speed_nodes(law: SpeedLaw, vmin: float, vmax: float) -> tuple[np.ndarray, np.ndarray]:
    """The speeds at which the Laurent coefficients are solved for, and the inverse matrix.

    ``K = len(law.exponents)`` speeds spread geometrically over ``[vmin, vmax]`` (over
    ``[vmin, 2 vmin]`` when the range is a single speed or narrower than 1 %), then one
    more between the first two for the check. Returns ``(nodes, inverse)``: ``nodes`` of
    length ``K + 1``, ``inverse`` the ``K x K`` inverse of
    ``M[j, k] = nodes[j] ** exponents[k]``, so that the coefficients are
    ``inverse @ E(nodes[:K])``. A law that is not polynomial
    gives ``K = 0``: no nodes, an empty matrix.
    """
    k = len(law.exponents) if law.polynomial else 0
    if k == 0:
        return np.zeros(0), np.zeros((0, 0))
    # a range narrower than 1 % would make the matrix (nearly) singular: the law is a
    # polynomial everywhere, so its coefficients are solved on [vmin, 2 vmin] instead
    hi = vmax if vmax > vmin * 1.01 else 2.0 * vmin
    base = np.geomspace(vmin, hi, k) if k > 1 else np.array([math.sqrt(vmin * hi)])
    check = math.sqrt(base[0] * base[1]) if k > 1 else 0.5 * (vmin + base[0]) + 0.25 * vmin
    nodes = np.append(base, check)
    exps = np.asarray(law.exponents, dtype=np.float64)
    mat = nodes[:k, None] ** exps[None, :]
    return np.ascontiguousarray(nodes), np.ascontiguousarray(np.linalg.inv(mat))


def _check_range(speed_range: Any) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in speed_range)
    except (TypeError, ValueError):
        raise ModelError(f"speed_range must be (vmin, vmax) in m/s, got {speed_range!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
        raise ModelError(f"speed_range must satisfy 0 < vmin <= vmax (m/s), got ({lo:g}, {hi:g})")
    return lo, hi


def best_speed(
    model: Any,
    alpha: Any,
    gamma: Any,
    travel: Any = 0.0,
    *,
    speed_range: tuple[float, float],
    turn_per_metre: Any = 0.0,
    time_weight: float = 0.0,
    constants: Mapping[str, Any] | None = None,
    law: SpeedLaw | None = None,
) -> SpeedChoice:
    """The ground speed in ``speed_range`` that minimises the cost per metre of each state.

    Cost per metre: ``P(v) / v + time_weight / v`` (energy, plus ``time_weight`` J per
    second of walking). Vectorised: the arguments broadcast together.

    Parameters
    ----------
    model : EnergyModel
        A fitted model.
    alpha, gamma : array_like
        Slope and relative heading, radians (the model's conventions).
    travel : array_like
        Direction of travel in the body frame, radians (0 forward, ``pi/2`` left,
        ``pi`` backward).
    speed_range : (float, float)
        ``(vmin, vmax)``, m/s.
    turn_per_metre : array_like
        Yaw change per metre of ground, rad/m (``wz = v * turn_per_metre``).
    time_weight : float
        ``lambda`` >= 0, J/s: the price of a second.
    constants : mapping, optional
        Values of the channels the model reads.
    law : SpeedLaw, optional
        :func:`speed_law` of the model (computed if not given).

    Returns
    -------
    SpeedChoice
    """
    from energy_planner.energy._laurent import laurent_argmin_batch

    if not model.is_fitted:
        raise ModelError("the energy model has no coefficients: fit or load a fitted model")
    lo, hi = _check_range(speed_range)
    if not (time_weight >= 0 and math.isfinite(time_weight)):
        raise ModelError(f"time_weight must be a finite number >= 0 (J/s), got {time_weight!r}")
    law = law if law is not None else speed_law(model, constants)
    chans = _channel_values(model, constants)
    alpha, gamma, travel, turn = np.broadcast_arrays(
        *(np.asarray(a, dtype=np.float64) for a in (alpha, gamma, travel, turn_per_metre))
    )
    shape = alpha.shape
    a, g, t, w = (np.ravel(x) for x in (alpha, gamma, travel, turn))
    n = a.size

    def per_metre(v: np.ndarray) -> np.ndarray:
        v = np.broadcast_to(np.asarray(v, dtype=np.float64), (n,))
        return model.power(_features(v, a, g, t, w, chans)) / v

    exps = np.asarray(law.exponents, dtype=np.float64)
    nodes, inverse = speed_nodes(law, lo, hi)
    k = len(nodes) - 1 if len(nodes) else 0
    closed = np.zeros(n, dtype=bool)
    v_best = np.full(n, lo)
    if k > 0 and hi > lo:
        f = np.column_stack([per_metre(np.full(n, v)) for v in nodes])
        coef = f[:, :k] @ inverse.T
        pred = coef @ (nodes[k] ** exps)
        closed = np.abs(pred - f[:, k]) <= FIT_RTOL * np.max(np.abs(f), axis=1) + 1e-12
        coef[:, list(law.exponents).index(-1)] += time_weight
        v_best = laurent_argmin_batch(
            np.ascontiguousarray(coef), exps, np.full(n, lo), np.full(n, hi)
        )
    elif hi <= lo:
        closed[:] = True
    rest = ~closed
    if rest.any():

        def cost_at(v: np.ndarray) -> np.ndarray:
            full = np.full(n, lo)
            full[rest] = v
            return per_metre(full)[rest] + time_weight / v

        v_best[rest] = _golden(cost_at, int(rest.sum()), lo, hi)
    e = per_metre(v_best)
    return SpeedChoice(v_best.reshape(shape), e.reshape(shape), closed.reshape(shape), law)


def _golden(f: Any, m: int, lo: float, hi: float) -> np.ndarray:
    """Golden-section search of ``f`` (``m`` speeds -> ``m`` costs) on [lo, hi], per state.

    Assumes one minimum in the range; the least of the final bracket and both ends.
    """
    g = 0.3819660112501051  # 2 - golden ratio
    a = np.full(m, lo)
    b = np.full(m, hi)
    for _ in range(_GOLDEN_ITERS):
        x1 = a + g * (b - a)
        x2 = b - g * (b - a)
        left = f(x1) <= f(x2)
        b = np.where(left, x2, b)
        a = np.where(left, a, x1)
    cand = np.column_stack([0.5 * (a + b), np.full(m, lo), np.full(m, hi)])
    vals = np.column_stack([f(cand[:, i]) for i in range(cand.shape[1])])
    return cand[np.arange(m), np.argmin(vals, axis=1)]
