"""Parameters of a simulated field campaign, each with its unit.

Three frozen dataclasses: :class:`SensorConfig` (noise, spikes, slip, IMU bias),
:class:`BatteryConfig` (open-circuit voltage, internal resistance, capacity) and
:class:`CampaignConfig` (which runs, how long, how fast, which extra channels).

Examples
--------
>>> c = CampaignConfig.small()
>>> c.rate_hz, c.sensors.current_noise_a > 0
(20.0, True)
>>> CampaignConfig(sensors=SensorConfig.ideal()).sensors.spike_prob
0.0
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from energy_planner.errors import EnergyPlannerError

__all__ = [
    "SensorConfig",
    "BatteryConfig",
    "CampaignConfig",
    "ConfigError",
    "MissionEvent",
    "EVENT_KINDS",
    "check_fields",
    "shared_rules",
    "speed_grid",
]


class ConfigError(EnergyPlannerError, ValueError):
    """A parameter of a simulator config is out of its valid range or of the wrong type."""


def _check(cond: bool, what: str, value: Any, expected: str) -> None:
    if not cond:
        raise ConfigError(
            f"{what} = {value!r} is invalid: expected {expected}",
            value=value,
            param=what,
            expected=expected,
        )


#: A rule on one field: ``(test(value, config), expected)``. ``expected`` says what a
#: valid value is, in words; it may name other fields as ``{c.name}``. A test that
#: raises (a string where a number belongs, say) counts as failed.
Rule = tuple[Callable[[Any, Any], bool], str]


def is_number(v: Any) -> bool:
    """A finite real number (not a bool)."""
    return isinstance(v, numbers.Real) and not isinstance(v, bool) and math.isfinite(v)


def in_range(lo: float, hi: float = math.inf, *, lo_open: bool = False, hi_open: bool = False):
    """Test of a finite number between ``lo`` and ``hi`` (closed ends unless told)."""

    def test(v: Any, _c: Any = None) -> bool:
        if not is_number(v):
            return False
        above = v > lo if lo_open else v >= lo
        return above and (v < hi if hi_open else v <= hi)

    return test


def all_in(test: Callable[[Any, Any], bool], min_len: int = 1):
    """Test of a tuple of at least ``min_len`` items that each pass ``test``."""
    return lambda v, c=None: (
        isinstance(v, tuple) and len(v) >= min_len and all(test(x, c) for x in v)
    )


def low_high(lo: float = -math.inf):
    """Test of a ``(low, high)`` pair of numbers with ``lo <= low <= high``."""
    return lambda v, c=None: (
        isinstance(v, tuple) and len(v) == 2 and all(map(is_number, v)) and lo <= v[0] <= v[1]
    )


def positive_int(v: Any, _c: Any = None) -> bool:
    """Test of an integer >= 1 (not a bool)."""
    return isinstance(v, numbers.Integral) and not isinstance(v, bool) and v >= 1


def _grounds_rule() -> Rule:
    from energy_planner.simulate.physics import GROUNDS

    return (
        lambda v, c=None: isinstance(v, tuple) and len(v) > 0 and all(g in GROUNDS for g in v),
        f"one or more of {', '.join(GROUNDS)}",
    )


def check_fields(config: Any, rules: dict[str, Rule]) -> None:
    """Validate a config's fields against ``rules``, first failure first.

    Fields typed as tuples are first made tuples (any iterable but a string is accepted).

    Raises
    ------
    ConfigError
        Naming ``Class.field``, the value and what was expected.

    Examples
    --------
    >>> from energy_planner.simulate import MissionConfig
    >>> try:
    ...     MissionConfig(gap_s=-3)
    ... except ConfigError as err:
    ...     print(err, err.param, err.value, sep=" | ")
    MissionConfig.gap_s = -3 is invalid: expected a pause >= 0 s | MissionConfig.gap_s | -3
    """
    for f in dataclasses.fields(config):
        v = getattr(config, f.name)
        if str(f.type).startswith("tuple") and isinstance(v, Iterable) and not isinstance(v, str):
            object.__setattr__(config, f.name, tuple(v))
    owner = type(config).__name__
    for name, (test, expected) in rules.items():
        value = getattr(config, name)
        try:
            ok = bool(test(value, config))
        except (TypeError, ValueError):
            ok = False
        _check(ok, f"{owner}.{name}", value, expected.format(c=config))


def shared_rules() -> dict[str, Rule]:
    """Rules of the fields :class:`CampaignConfig` and ``MissionConfig`` share.

    One rule per field, so that both configs accept and refuse the same values.
    """
    return {
        "speeds": (all_in(in_range(0, 3, lo_open=True)), "one or more speeds in (0, 3] m/s"),
        "yaw_rate": (in_range(0, 3, lo_open=True), "a yaw rate in (0, 3] rad/s"),
        "ramp_s": (in_range(0), "a ramp length >= 0 s"),
        "rate_hz": (in_range(1, 2000), "a rate in [1, 2000] Hz"),
        "gap_s": (in_range(0), "a pause >= 0 s"),
        "grounds": _grounds_rule(),
        "loads_kg": (all_in(in_range(0)), "one or more masses >= 0 kg"),
        "air_temp_range_c": (low_high(), "(low, high) with low <= high, deg C"),
        "motor_temp_range_c": (low_high(), "(low, high) with low <= high, deg C"),
        "motor_warming_k_s": (in_range(0), "a warming rate >= 0 K/s"),
        "grass_height_range_m": (low_high(0.0), "(low, high) with 0 <= low <= high, m"),
        "sensors": (lambda v, c=None: isinstance(v, SensorConfig), "a SensorConfig"),
        "battery": (lambda v, c=None: isinstance(v, BatteryConfig), "a BatteryConfig"),
        "gaits": _gaits_rule(),
    }


def _gaits_rule() -> Rule:
    def test(v: Any, _c: Any = None) -> bool:
        from energy_planner.simulate.gaits import GaitSchedule

        return v is None or isinstance(v, GaitSchedule)

    return (test, "None (the base robot's one gait) or a GaitSchedule")


def speed_grid(lo: float, hi: float, n: int = 8) -> tuple[float, ...]:
    """``n`` evenly spaced speeds from ``lo`` to ``hi``, m/s, rounded to the mm/s.

    >>> speed_grid(0.15, 1.2)
    (0.15, 0.3, 0.45, 0.6, 0.75, 0.9, 1.05, 1.2)
    >>> try:
    ...     speed_grid(0.5, 0.2)
    ... except ConfigError as err:
    ...     print(err)
    speed range = (0.5, 0.2, 8) is invalid: expected 0 < low < high <= 3 m/s and n >= 2
    """
    ok = is_number(lo) and is_number(hi) and 0 < lo < hi <= 3 and positive_int(n) and n >= 2
    _check(ok, "speed range", (lo, hi, n), "0 < low < high <= 3 m/s and n >= 2")
    return tuple(round(lo + (hi - lo) * k / (n - 1), 3) for k in range(n))


#: Mid-mission events: kind -> the physics it changes (see :class:`MissionEvent`).
EVENT_KINDS: dict[str, str] = {
    "payload": "a payload of load_kg is picked up: the load channel grows by it (the physics "
    "reads it through the load effect, switched on by the event)",
    "mud": "the ground turns to mud: the ground channel becomes 'mud' (sinkage and lost "
    "recovery, through the ground effect, switched on by the event)",
    "dem_bias": "the true ground is steeper than the DEM by slope_bias_deg along the path's "
    "heading at the stretch's start (the DEM is wrong there; altitude shifts with it)",
}


@dataclass(frozen=True)
class MissionEvent:
    """Something that happens partway along every mission (a change of the truth).

    Attributes
    ----------
    kind : str
        One of :data:`EVENT_KINDS`: ``payload``, ``mud`` or ``dem_bias``.
    at : float
        When it starts, as a fraction of the mission's duration, 1.
    until : float
        When it ends (fraction; 1 = the end of the mission).
    load_kg : float
        Mass picked up (``payload``), kg.
    slope_bias_deg : float
        Extra slope of the true ground over the DEM's (``dem_bias``), deg.

    Examples
    --------
    >>> MissionEvent("payload", at=0.4).load_kg
    15.0
    >>> try:
    ...     MissionEvent("flood")
    ... except ConfigError as err:
    ...     print(err)
    MissionEvent.kind = 'flood' is invalid: expected one of payload, mud, dem_bias
    """

    kind: str
    at: float = 0.4
    until: float = 1.0
    load_kg: float = 15.0
    slope_bias_deg: float = 5.0

    def __post_init__(self) -> None:
        check_fields(
            self,
            {
                "kind": (lambda v, c=None: v in EVENT_KINDS, "one of " + ", ".join(EVENT_KINDS)),
                "at": (in_range(0, 1, hi_open=True), "a fraction of the mission in [0, 1)"),
                "until": (
                    lambda v, c: in_range(0, 1)(v) and v > c.at,
                    "a fraction in ({c.at}, 1] (after 'at')",
                ),
                "load_kg": (in_range(0, 200), "a mass in [0, 200] kg"),
                "slope_bias_deg": (in_range(-30, 30), "a slope in [-30, 30] deg"),
            },
        )

    def active(self, fraction: Any) -> Any:
        """Where (fractions of the mission) the event is on."""
        import numpy as np

        f = np.asarray(fraction, dtype=float)
        return (f >= self.at) & (f < self.until if self.until < 1.0 else f <= 1.0)


@dataclass(frozen=True)
class SensorConfig:
    """Sensor imperfections.

    Attributes
    ----------
    current_noise_a : float
        Standard deviation of white noise on the battery current, A.
    voltage_noise_v : float
        Standard deviation of white noise on the battery voltage, V.
    spike_prob : float
        Probability per sample of a current spike (rare large outlier), 1.
    spike_current_a : float
        Typical spike size, A (each spike is +-U(0.5, 1.5) times this).
    slip_mean : float
        Mean odometry slip on level ground, 1 (measured twist = true twist * (1 - slip)).
    slip_per_sin_slope : float
        Extra slip per unit of ``sin(alpha)``, 1 (feet slip more on steep ground).
    slip_std : float
        Run-to-run standard deviation of the slip, 1.
    twist_noise_v : float
        White noise on measured ``vx, vy``, m/s.
    twist_noise_w : float
        White noise on measured ``wz``, rad/s.
    imu_bias_deg : float
        Standard deviation of the fixed per-run tilt bias of the IMU (roll and pitch), deg.
    imu_noise_deg : float
        White orientation noise per axis, deg.
    ros_current_sign : bool
        Log the battery current with the ROS sign (negative while discharging): the
        ``ros_current_sign`` fault.
    battery_clock_offset_s : float
        The battery stream (voltage, current) lags the odometry and IMU by this, s: the
        ``clock_offset`` fault.
    """

    current_noise_a: float = 0.1
    voltage_noise_v: float = 0.05
    spike_prob: float = 1e-3
    spike_current_a: float = 15.0
    slip_mean: float = 0.02
    slip_per_sin_slope: float = 0.1
    slip_std: float = 0.01
    twist_noise_v: float = 0.01
    twist_noise_w: float = 0.01
    imu_bias_deg: float = 0.3
    imu_noise_deg: float = 0.05
    ros_current_sign: bool = False
    battery_clock_offset_s: float = 0.0

    @classmethod
    def ideal(cls) -> SensorConfig:
        """Perfect sensors: no noise, no spikes, no slip, no IMU bias, no fault."""
        return cls(
            **{f.name: False if f.type in (bool, "bool") else 0.0 for f in dataclasses.fields(cls)}
        )

    def with_faults(self, faults: tuple[str, ...]) -> SensorConfig:
        """These sensors with the named faults (:data:`energy_planner.simulate.FAULTS`).

        >>> SensorConfig().with_faults(("slope_slip", "clock_offset")).battery_clock_offset_s
        0.4
        """
        from energy_planner.simulate.effects import check_faults

        changes: dict[str, Any] = {}
        for name in check_faults(faults):
            if name == "slope_slip":
                changes["slip_per_sin_slope"] = 0.6
            elif name == "ros_current_sign":
                changes["ros_current_sign"] = True
            elif name == "clock_offset":
                changes["battery_clock_offset_s"] = 0.4
        return dataclasses.replace(self, **changes)

    @property
    def is_ideal(self) -> bool:
        """True when every imperfection is zero."""
        return all(getattr(self, f.name) == 0 for f in dataclasses.fields(self))

    def __post_init__(self) -> None:
        rules: dict[str, Rule] = {
            f.name: (in_range(0), "a finite number >= 0") for f in dataclasses.fields(self)
        }
        rules["spike_prob"] = (in_range(0, 1), "a probability in [0, 1]")
        rules["ros_current_sign"] = (lambda v, c=None: v in (True, False), "True or False")
        check_fields(self, rules)


@dataclass(frozen=True)
class BatteryConfig:
    """A Li-ion pack with a linear open-circuit voltage and an internal resistance.

    ``V = OCV(soc) - R I`` with ``OCV(soc) = cells * (cell_empty_v + (cell_full_v -
    cell_empty_v) * soc)``; the current drawn for an electrical power ``P`` solves
    ``P = V I`` (the smaller root, positive while discharging).

    Attributes
    ----------
    cells : int
        Cells in series, 1.
    cell_full_v : float
        Open-circuit cell voltage when full (soc = 1), V.
    cell_empty_v : float
        Open-circuit cell voltage when empty (soc = 0), V.
    internal_resistance_ohm : float
        Pack internal resistance, ohm.
    capacity_ah : float
        Pack capacity, Ah.
    soc_start : float
        State of charge of a fresh pack, 1.
    soc_swap : float
        A pack is swapped for a fresh one before a run that would end below this, 1.
    """

    cells: int = 14
    cell_full_v: float = 4.15
    cell_empty_v: float = 3.45
    internal_resistance_ohm: float = 0.1
    capacity_ah: float = 15.0
    soc_start: float = 1.0
    soc_swap: float = 0.2

    def __post_init__(self) -> None:
        check_fields(
            self,
            {
                "cells": (positive_int, "a positive integer"),
                "cell_full_v": (in_range(0, lo_open=True), "a voltage > 0 V"),
                "cell_empty_v": (
                    lambda v, c: in_range(0, c.cell_full_v, lo_open=True, hi_open=True)(v),
                    "0 < cell_empty_v < cell_full_v ({c.cell_full_v})",
                ),
                "internal_resistance_ohm": (in_range(0), "a resistance >= 0 ohm"),
                "capacity_ah": (in_range(0, lo_open=True), "a capacity > 0 Ah"),
                "soc_start": (in_range(0, 1, lo_open=True), "in (0, 1]"),
                "soc_swap": (
                    lambda v, c: in_range(0, c.soc_start, hi_open=True)(v),
                    "in [0, soc_start={c.soc_start})",
                ),
            },
        )

    def ocv(self, soc):
        """Open-circuit pack voltage, V, at state of charge ``soc`` (1).

        >>> round(BatteryConfig().ocv(1.0), 6)
        58.1
        """
        return self.cells * (self.cell_empty_v + (self.cell_full_v - self.cell_empty_v) * soc)


_HEADINGS = (-135.0, -90.0, -45.0, 0.0, 45.0, 90.0, 135.0, 180.0)


@dataclass(frozen=True)
class CampaignConfig:
    """What a simulated field campaign contains (paper section IV-C).

    Attributes
    ----------
    slopes_deg : tuple of float
        Slopes of the planar test ramps, deg.
    headings_deg : tuple of float
        Relative headings ``gamma`` of the straight runs, deg (0 uphill, 180 downhill,
        +90 with uphill on the robot's right).
    motions : tuple of str
        Straight motions: any of ``forward, backward, left, right``.
    speeds : tuple of float
        Walking speeds of straight runs, arcs and composites, m/s (the paper: 0.3).
    yaw_rate : float
        Yaw rate of turns in place, rad/s.
    turn_headings_deg : tuple of float
        Start headings of the turns in place, deg.
    arcs : bool
        Add arc runs (walking forward while turning) at every slope, both ways.
    arc_radius_m : float
        Radius of arc runs and of the composite arcs, m.
    stand : bool
        Add standing runs (zero twist) at every slope.
    repeats : int
        Repeats of every straight, turn, arc and stand condition, 1.
    run_s : float
        Duration of straight, turn, arc and stand runs including ramps, s.
    ramp_s : float
        Length of the linear speed ramps at run start and end, s (0: step to full
        speed). Distances are kept: a part of ``d`` metres at ``v`` m/s lasts
        ``d / v + ramp_s``.
    rate_hz : float
        Sample rate of every channel, Hz.
    gap_s : float
        Pause between runs on the campaign clock, s.
    composite_slopes_deg : tuple of float
        Slopes of the composite (superposition) runs, deg; empty for none.
    composite_headings_deg : tuple of float
        Start headings of the composite runs, deg.
    composite_legs_m : tuple of float
        Lengths of leg A (forward) and leg B (sideways) of composite (a), m; leg C is
        the straight diagonal between the same end points.
    composite_turn_deg : float
        Pose change of composite (b): yaw in place by this angle then a straight
        translation, against a circular arc of radius ``arc_radius_m``, deg.
    grounds : tuple of str
        Values of the categorical channel ``ground``, balanced over runs (names from
        :data:`energy_planner.simulate.GROUNDS`).
    loads_kg : tuple of float
        Values of the channel ``load_kg`` (carried mass), balanced over runs, kg.
    air_temp_range_c : tuple of float
        Range of the uniform per-run channel ``air_temp_c``, deg C.
    motor_temp_range_c : tuple of float
        Range of the uniform winding temperature at run start (channel ``motor_temp``),
        deg C.
    motor_warming_k_s : float
        Largest warming rate of the windings during a run (uniform per run from 0), K/s.
    grass_height_range_m : tuple of float
        Range of the uniform per-run channel ``grass_height_m``, m.
    sensors : SensorConfig
        Sensor imperfections (:meth:`SensorConfig.ideal` for none).
    battery : BatteryConfig
        Battery pack.
    gaits : GaitSchedule or None
        The controller's gaits across speeds (:mod:`energy_planner.simulate.gaits`):
        speed-dependent stride and duty factor, a walk below a transition speed and a trot
        above, logged as the categorical channel ``gait``. None (default): the base
        robot's one gait, no ``gait`` channel.
    """

    slopes_deg: tuple[float, ...] = (0.0, 5.0, 10.0, 15.0, 20.0, 25.0)
    headings_deg: tuple[float, ...] = _HEADINGS
    motions: tuple[str, ...] = ("forward", "backward", "left", "right")
    speeds: tuple[float, ...] = (0.3,)
    yaw_rate: float = 0.5
    turn_headings_deg: tuple[float, ...] = (0.0,)
    arcs: bool = True
    arc_radius_m: float = 1.5
    stand: bool = True
    repeats: int = 2
    run_s: float = 20.0
    ramp_s: float = 1.0
    rate_hz: float = 50.0
    gap_s: float = 10.0
    composite_slopes_deg: tuple[float, ...] = (10.0, 20.0)
    composite_headings_deg: tuple[float, ...] = (0.0, 90.0, 180.0, -90.0)
    composite_legs_m: tuple[float, float] = (4.0, 3.0)
    composite_turn_deg: float = 90.0
    grounds: tuple[str, ...] = ("meadow", "gravel", "mud", "asphalt")
    loads_kg: tuple[float, ...] = (0.0, 5.0, 10.0, 15.0)
    air_temp_range_c: tuple[float, float] = (-5.0, 30.0)
    motor_temp_range_c: tuple[float, float] = (25.0, 75.0)
    motor_warming_k_s: float = 0.05
    grass_height_range_m: tuple[float, float] = (0.0, 0.4)
    sensors: SensorConfig = field(default_factory=SensorConfig)
    battery: BatteryConfig = field(default_factory=BatteryConfig)
    gaits: Any = None

    def __post_init__(self) -> None:
        check_fields(self, _campaign_rules())

    @property
    def dt(self) -> float:
        """Sample period, s."""
        return 1.0 / self.rate_hz

    @classmethod
    def small(cls, **overrides: Any) -> CampaignConfig:
        """A tiny campaign for tests and quick looks (simulates in well under a second).

        Three slopes, four headings, one repeat, 6 s runs at 20 Hz, one composite slope.
        """
        base: dict[str, Any] = dict(
            slopes_deg=(0.0, 10.0, 20.0),
            headings_deg=(0.0, 90.0, 180.0, -90.0),
            repeats=1,
            run_s=6.0,
            ramp_s=1.0,
            rate_hz=20.0,
            gap_s=2.0,
            composite_slopes_deg=(15.0,),
            composite_headings_deg=(0.0, 180.0),
            composite_legs_m=(1.2, 0.9),
            arc_radius_m=1.0,
        )
        base.update(overrides)
        return cls(**base)

    @classmethod
    def across_speeds(cls, small: bool = False, **overrides: Any) -> CampaignConfig:
        """A campaign over a range of speeds, walking and trotting (identifies the speed).

        Straight runs at 8 speeds from 0.15 to 1.2 m/s (walk below 0.5 m/s, trot from it;
        :class:`~energy_planner.simulate.gaits.GaitSchedule`) on slopes of 0-24 deg at
        eight headings, turns, arcs at the speeds up to 0.6 m/s and standing; no
        composites. ``small``: three slopes, four headings, forward and sideways, 6 s runs
        (for tests).

        >>> c = CampaignConfig.across_speeds(small=True)
        >>> c.speeds[0], c.speeds[-1], c.gaits.gaits
        (0.15, 1.2, ('walk', 'trot'))
        """
        from energy_planner.simulate.gaits import GaitSchedule

        base: dict[str, Any] = dict(
            slopes_deg=(0.0, 8.0, 16.0, 24.0),
            speeds=speed_grid(0.15, 1.2),
            gaits=GaitSchedule(),
            repeats=1,
            run_s=12.0,
            rate_hz=20.0,
            gap_s=2.0,
            composite_slopes_deg=(),
        )
        if small:
            base.update(
                slopes_deg=(0.0, 10.0, 20.0),
                headings_deg=(0.0, 90.0, 180.0, -90.0),
                motions=("forward", "left"),
                run_s=6.0,
                arcs=False,
            )
        base.update(overrides)
        return cls(**base)

    def replace(self, **changes: Any) -> CampaignConfig:
        """A copy with some parameters changed."""
        return dataclasses.replace(self, **changes)


def _campaign_rules() -> dict[str, Rule]:
    """Rules of :class:`CampaignConfig`'s fields (the shared ones and its own)."""
    slopes = all_in(in_range(0, 60, hi_open=True), min_len=0)
    motions = ("forward", "backward", "left", "right")
    return {
        "slopes_deg": (slopes, "slopes in [0, 60) deg"),
        "composite_slopes_deg": (slopes, "slopes in [0, 60) deg"),
        "headings_deg": (all_in(in_range(-math.inf), min_len=0), "headings in deg"),
        "turn_headings_deg": (all_in(in_range(-math.inf), min_len=0), "headings in deg"),
        "composite_headings_deg": (all_in(in_range(-math.inf), min_len=0), "headings in deg"),
        "motions": (
            lambda v, c=None: isinstance(v, tuple) and all(m in motions for m in v),
            f"a subset of {', '.join(motions)}",
        ),
        **shared_rules(),
        "arc_radius_m": (in_range(0, lo_open=True), "a radius > 0 m"),
        "repeats": (positive_int, "an integer >= 1"),
        "run_s": (
            lambda v, c: in_range(c.ramp_s, lo_open=True)(v),
            "longer than ramp_s = {c.ramp_s} s",
        ),
        "composite_legs_m": (
            lambda v, c=None: len(v) == 2 and all(in_range(0, lo_open=True)(d) for d in v),
            "two positive lengths (A forward, B sideways) in m",
        ),
        "composite_turn_deg": (
            lambda v, c=None: in_range(-180, 180, lo_open=True, hi_open=True)(v) and v != 0,
            "an angle in (0, 180) deg",
        ),
    }
