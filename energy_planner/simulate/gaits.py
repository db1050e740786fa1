"""Gaits of the simulated robot across speeds: what changes between a walk and a trot.

With a :class:`GaitSchedule` (``CampaignConfig.gaits``, ``MissionConfig.gaits``) the
simulated controller picks a gait per sample, as a real one does, and logs it as the
categorical channel ``gait``: a statically stable walk below ``trot_speed``, a trot from
it, and (when ``crawl`` is among the gaits) a crawl on slopes of at least
``crawl_slope_deg`` whatever the speed. Each :class:`Gait` changes the physics of
:mod:`energy_planner.simulate.physics` through three things, all of which vary with speed:

``duty factor``
    the share of a stride a leg stands, falling with speed (``duty_factor -
    duty_per_speed * v``, at least ``min_duty``). The stance legs carry the body with a
    half-sine force, so the copper losses of carrying it grow as ``pi^2 / (8 d)``: a
    walk (long stance) is cheap per second, a fast trot dear.
``stride frequency``
    ``stride_hz * (v / 0.3 m/s) ** stride_exponent``: strides lengthen and quicken
    together as the robot speeds up. Foot lifting is paid per stride, and the swing legs,
    which must cover a stride in ``1 - d`` of the stride time at ``v / (1 - d)``, cost
    ``f m_leg (v / (1 - d))^2`` per second: fast walking (short swing phase) is dear.
``touch-downs``
    the touch-down loss of the base robot times ``collision_factor``, growing with the
    impact speed as ``1 + impact_per_speed * v``.

Standing power (electronics, holding the body) is paid per second, so slow walking costs
much per metre; the swing and impact losses grow faster than the speed, so fast walking
does too: the cost per metre has an interior optimum, and since holding a slope's load is
paid per second as well, that optimum moves to faster speeds on slopes and with a load.
None of these laws is a term of the model's catalog (powers like ``v ** 0.5`` and
``1 / (d0 - k v)``): a fit approximates them.

Without a schedule (the default) the physics is the base robot's single gait, whose stride
frequency and duty factor do not depend on speed.

Examples
--------
>>> s = GaitSchedule()
>>> s.gait_of([0.3, 0.6], [0.0, 0.0]).tolist()
['walk', 'trot']
>>> round(float(GAITS["trot"].duty([1.0])[0]), 2)
0.48
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from energy_planner.simulate.config import ConfigError, check_fields, in_range

__all__ = [
    "Gait",
    "GAITS",
    "GaitSchedule",
    "REFERENCE_SPEED",
    "true_cost_per_metre",
    "true_optimum_speed",
]

#: Speed at which a gait's stride frequency is ``Gait.stride_hz``, m/s.
REFERENCE_SPEED = 0.3
#: The stride frequency and duty factor of a gait are computed at no less than this speed
#: (turning in place and standing have a gait too), m/s.
MIN_GAIT_SPEED = 0.1


@dataclass(frozen=True)
class Gait:
    """The speed-dependent parameters of one gait.

    Attributes
    ----------
    name : str
        The value of the ``gait`` channel.
    duty_factor : float
        Duty factor extrapolated to zero speed, 1.
    duty_per_speed : float
        Fall of the duty factor per m/s, s/m.
    min_duty : float
        Smallest duty factor, 1.
    stride_hz : float
        Stride frequency at :data:`REFERENCE_SPEED`, Hz.
    stride_exponent : float
        The stride frequency grows as the speed to this power, 1.
    collision_factor : float
        Touch-down losses relative to the base robot's, 1.
    impact_per_speed : float
        Growth of the touch-down loss with speed, s/m.
    """

    name: str
    duty_factor: float
    duty_per_speed: float
    min_duty: float
    stride_hz: float
    stride_exponent: float
    collision_factor: float
    impact_per_speed: float

    def duty(self, speed: Any) -> np.ndarray:
        """Duty factor at ``speed`` (m/s), 1."""
        v = np.maximum(np.asarray(speed, dtype=float), MIN_GAIT_SPEED)
        return np.clip(self.duty_factor - self.duty_per_speed * v, self.min_duty, 0.95)

    def stride_frequency(self, speed: Any) -> np.ndarray:
        """Stride frequency at ``speed`` (m/s), Hz."""
        v = np.maximum(np.asarray(speed, dtype=float), MIN_GAIT_SPEED)
        return self.stride_hz * (v / REFERENCE_SPEED) ** self.stride_exponent

    def impact(self, speed: Any) -> np.ndarray:
        """Touch-down losses relative to the base robot's at ``speed`` (m/s), 1."""
        return self.collision_factor * (1.0 + self.impact_per_speed * np.asarray(speed, float))


#: The gaits the simulated controller knows: name -> :class:`Gait`.
GAITS: dict[str, Gait] = {
    g.name: g
    for g in (
        # statically stable walk: long stance, short quick swings, soft touch-downs
        Gait("walk", 0.80, 0.10, 0.50, 0.55, 0.85, 0.67, 2.0),
        # trot: diagonal pairs, half the cycle in stance at rest, shorter when faster
        Gait("trot", 0.60, 0.12, 0.35, 0.85, 0.50, 1.0, 2.0),
        # crawl: one leg at a time, for steep ground
        Gait("crawl", 0.90, 0.10, 0.75, 0.40, 0.90, 0.5, 2.0),
    )
}


@dataclass(frozen=True)
class GaitSchedule:
    """How the simulated controller picks its gait, and the gaits it has.

    Attributes
    ----------
    gaits : tuple of str
        Names from :data:`GAITS`. One gait: always that one. ``walk`` and ``trot``: walk
        below ``trot_speed``, trot from it. With ``crawl``: crawl on slopes of at least
        ``crawl_slope_deg``.
    trot_speed : float
        Speed from which the controller trots, m/s.
    crawl_slope_deg : float
        Slope from which it crawls (when ``crawl`` is a gait), deg.

    Examples
    --------
    >>> GaitSchedule(("walk", "trot", "crawl")).gait_of([1.0], [np.radians(25)]).tolist()
    ['crawl']
    >>> try:
    ...     GaitSchedule(("gallop",))
    ... except ConfigError as err:
    ...     print(err)
    GaitSchedule.gaits = ('gallop',) is invalid: expected one or more of walk, trot, crawl
    """

    gaits: tuple[str, ...] = ("walk", "trot")
    trot_speed: float = 0.5
    crawl_slope_deg: float = 20.0

    def __post_init__(self) -> None:
        check_fields(
            self,
            {
                "gaits": (
                    lambda v, c=None: (
                        isinstance(v, tuple)
                        and len(v) > 0
                        and len(set(v)) == len(v)
                        and all(g in GAITS for g in v)
                    ),
                    "one or more of " + ", ".join(GAITS),
                ),
                "trot_speed": (in_range(0, 3, lo_open=True), "a speed in (0, 3] m/s"),
                "crawl_slope_deg": (in_range(0, 60), "a slope in [0, 60] deg"),
            },
        )

    def gait_of(self, speed: Any, alpha: Any) -> np.ndarray:
        """The gait of each sample (names) from its commanded speed, m/s, and slope, rad."""
        v = np.asarray(speed, dtype=float)
        a = np.broadcast_to(np.asarray(alpha, dtype=float), v.shape)
        names = [g for g in self.gaits if g != "crawl"]
        if not names:
            out = np.full(v.shape, "crawl", dtype=object)
        elif len(names) == 1:
            out = np.full(v.shape, names[0], dtype=object)
        else:
            slow, fast = ("walk", "trot") if "walk" in names else (names[0], names[-1])
            out = np.where(v >= self.trot_speed, fast, slow).astype(object)
        if "crawl" in self.gaits:
            out = np.where(a >= math.radians(self.crawl_slope_deg), "crawl", out).astype(object)
        return out.astype(str)

    def table(self) -> list[dict[str, Any]]:
        """Rows of the gaits' parameters (for ``physics.json``)."""
        from dataclasses import asdict

        return [asdict(GAITS[g]) for g in self.gaits]


def gait_arrays(codes: Any, speed: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per sample: duty factor, stride frequency (Hz) and impact factor of its gait.

    Raises
    ------
    ConfigError
        A gait name not in :data:`GAITS`.
    """
    codes = np.asarray(codes).astype(str)
    v = np.broadcast_to(np.asarray(speed, dtype=float), codes.shape)
    duty, freq, impact = np.ones(codes.shape), np.zeros(codes.shape), np.zeros(codes.shape)
    for name in np.unique(codes):
        if name not in GAITS:
            raise ConfigError(
                f"gait {name!r} is unknown: expected one of {', '.join(GAITS)}",
                value=name,
                param="gait",
                expected=", ".join(GAITS),
            )
        sel = codes == name
        g = GAITS[name]
        duty[sel], freq[sel], impact[sel] = (
            g.duty(v[sel]),
            g.stride_frequency(v[sel]),
            g.impact(v[sel]),
        )
    return duty, freq, impact


def true_cost_per_metre(
    physics: Any,
    speeds: Any,
    slope_deg: float,
    heading_deg: float = 0.0,
    channels: dict[str, Any] | None = None,
    motion: str = "forward",
) -> dict[str, np.ndarray]:
    """The truth's cost per metre of steady straight walking at each speed.

    Parameters
    ----------
    physics : Physics
        The truth (its gaits pick the gait of each speed as the controller does).
    speeds : array-like
        Speeds, m/s (> 0).
    slope_deg, heading_deg : float
        Slope and relative heading ``gamma`` (0 uphill, 180 downhill), deg.
    channels : dict, optional
        Values of the channels the physics' effects read (``load_kg``, ...).
    motion : str
        ``forward``, ``backward``, ``left`` or ``right``.

    Returns
    -------
    dict
        ``speed`` (m/s), ``cost_n`` (expected power / speed, J/m) and ``gait`` per speed.

    Examples
    --------
    >>> from energy_planner.simulate import Physics
    >>> c = true_cost_per_metre(Physics(gaits=GaitSchedule()), [0.3, 0.7], 0.0)
    >>> c["gait"].tolist(), bool(c["cost_n"][1] < c["cost_n"][0])
    (['walk', 'trot'], True)
    """
    v = np.asarray(speeds, dtype=float)
    ux, uy = {"forward": (1, 0), "backward": (-1, 0), "left": (0, 1), "right": (0, -1)}[motion]
    n = v.size
    alpha = np.full(n, math.radians(slope_deg))
    f: dict[str, Any] = {
        "alpha": alpha,
        "gamma": np.full(n, math.radians(heading_deg)),
        "vx": ux * v,
        "vy": uy * v,
        "wz": np.zeros(n),
        **{k: np.full(n, val) for k, val in (channels or {}).items()},
    }
    gaits = getattr(physics, "gaits", None)
    gait = (
        gaits.gait_of(v, alpha) if gaits is not None else np.full(n, "base", dtype=object)
    ).astype(str)
    if gaits is not None:
        f["gait"] = gait
    return {"speed": v, "cost_n": physics.expected_power(f) / v, "gait": gait}


def true_optimum_speed(
    physics: Any,
    slope_deg: float,
    heading_deg: float = 0.0,
    speed_range: tuple[float, float] = (0.15, 1.2),
    channels: dict[str, Any] | None = None,
    motion: str = "forward",
    n: int = 2001,
) -> dict[str, Any]:
    """The speed of least cost per metre of the truth within ``speed_range`` (numerically).

    Returns
    -------
    dict
        ``speed`` (m/s), ``cost_n`` (J/m), ``gait`` and ``interior`` (False when the least
        cost lies at an end of the range).

    Examples
    --------
    >>> from energy_planner.simulate import Physics
    >>> phys = Physics(gaits=GaitSchedule())
    >>> level, steep = true_optimum_speed(phys, 0.0), true_optimum_speed(phys, 20.0)
    >>> level["interior"], 0.5 < level["speed"] < steep["speed"] < 1.2
    (True, True)
    """
    lo, hi = speed_range
    c = true_cost_per_metre(physics, np.linspace(lo, hi, n), slope_deg, heading_deg, channels,
                            motion)  # fmt: skip
    k = int(np.argmin(c["cost_n"]))
    return {
        "speed": float(c["speed"][k]),
        "cost_n": float(c["cost_n"][k]),
        "gait": str(c["gait"][k]),
        "interior": 0 < k < n - 1,
    }
