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
from dataclasses import dataclass, field
from typing import Any

from energy_planner.errors import EnergyPlannerError

__all__ = ["SensorConfig", "BatteryConfig", "CampaignConfig", "ConfigError"]


class ConfigError(EnergyPlannerError, ValueError):
    """A campaign parameter is out of its valid range."""


def _check(cond: bool, what: str, value: Any, expected: str) -> None:
    if not cond:
        raise ConfigError(f"{what} = {value!r} is invalid: expected {expected}")


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
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            _check(
                isinstance(v, int | float) and math.isfinite(v) and v >= 0,
                f"SensorConfig.{f.name}",
                v,
                "a finite number >= 0",
            )
        _check(self.spike_prob <= 1, "SensorConfig.spike_prob", self.spike_prob, "<= 1")


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
        _check(
            isinstance(self.cells, int) and self.cells > 0,
            "BatteryConfig.cells",
            self.cells,
            "a positive integer",
        )
        _check(
            0 < self.cell_empty_v < self.cell_full_v,
            "BatteryConfig.cell_empty_v",
            self.cell_empty_v,
            f"0 < cell_empty_v < cell_full_v ({self.cell_full_v})",
        )
        _check(
            self.internal_resistance_ohm >= 0,
            "BatteryConfig.internal_resistance_ohm",
            self.internal_resistance_ohm,
            ">= 0",
        )
        _check(self.capacity_ah > 0, "BatteryConfig.capacity_ah", self.capacity_ah, "> 0")
        _check(0 < self.soc_start <= 1, "BatteryConfig.soc_start", self.soc_start, "in (0, 1]")
        _check(
            0 <= self.soc_swap < self.soc_start,
            "BatteryConfig.soc_swap",
            self.soc_swap,
            f"in [0, soc_start={self.soc_start})",
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

    def __post_init__(self) -> None:
        for name in (
            "slopes_deg",
            "headings_deg",
            "motions",
            "speeds",
            "turn_headings_deg",
            "composite_slopes_deg",
            "composite_headings_deg",
            "composite_legs_m",
            "grounds",
            "loads_kg",
            "air_temp_range_c",
            "motor_temp_range_c",
            "grass_height_range_m",
        ):
            object.__setattr__(self, name, tuple(getattr(self, name)))
        _check(
            all(0 <= s < 60 for s in self.slopes_deg),
            "CampaignConfig.slopes_deg",
            self.slopes_deg,
            "slopes in [0, 60) deg",
        )
        _check(
            all(0 <= s < 60 for s in self.composite_slopes_deg),
            "CampaignConfig.composite_slopes_deg",
            self.composite_slopes_deg,
            "slopes in [0, 60) deg",
        )
        valid = ("forward", "backward", "left", "right")
        _check(
            all(m in valid for m in self.motions),
            "CampaignConfig.motions",
            self.motions,
            f"a subset of {', '.join(valid)}",
        )
        _check(
            len(self.speeds) > 0 and all(0 < v <= 3 for v in self.speeds),
            "CampaignConfig.speeds",
            self.speeds,
            "one or more speeds in (0, 3] m/s",
        )
        _check(
            0 < self.yaw_rate <= 3,
            "CampaignConfig.yaw_rate",
            self.yaw_rate,
            "a yaw rate in (0, 3] rad/s",
        )
        _check(self.arc_radius_m > 0, "CampaignConfig.arc_radius_m", self.arc_radius_m, "> 0")
        _check(
            isinstance(self.repeats, int) and self.repeats >= 1,
            "CampaignConfig.repeats",
            self.repeats,
            "an integer >= 1",
        )
        _check(
            1 <= self.rate_hz <= 2000,
            "CampaignConfig.rate_hz",
            self.rate_hz,
            "a rate in [1, 2000] Hz",
        )
        _check(self.ramp_s >= 0, "CampaignConfig.ramp_s", self.ramp_s, ">= 0 s")
        _check(
            self.run_s > self.ramp_s,
            "CampaignConfig.run_s",
            self.run_s,
            f"longer than ramp_s = {self.ramp_s} s",
        )
        _check(self.gap_s >= 0, "CampaignConfig.gap_s", self.gap_s, ">= 0 s")
        _check(
            len(self.composite_legs_m) == 2 and all(d > 0 for d in self.composite_legs_m),
            "CampaignConfig.composite_legs_m",
            self.composite_legs_m,
            "two positive lengths (A forward, B sideways) in m",
        )
        _check(
            0 < abs(self.composite_turn_deg) < 180,
            "CampaignConfig.composite_turn_deg",
            self.composite_turn_deg,
            "an angle in (0, 180) deg",
        )
        from energy_planner.simulate.physics import GROUNDS

        _check(
            len(self.grounds) > 0 and all(g in GROUNDS for g in self.grounds),
            "CampaignConfig.grounds",
            self.grounds,
            f"one or more of {', '.join(GROUNDS)}",
        )
        _check(
            len(self.loads_kg) > 0 and all(p >= 0 for p in self.loads_kg),
            "CampaignConfig.loads_kg",
            self.loads_kg,
            "one or more masses >= 0 kg",
        )
        _check(
            self.motor_warming_k_s >= 0,
            "CampaignConfig.motor_warming_k_s",
            self.motor_warming_k_s,
            ">= 0 K/s",
        )
        for name in ("air_temp_range_c", "motor_temp_range_c", "grass_height_range_m"):
            lo_hi = getattr(self, name)
            _check(
                len(lo_hi) == 2 and lo_hi[0] <= lo_hi[1],
                f"CampaignConfig.{name}",
                lo_hi,
                "(low, high) with low <= high",
            )
        _check(
            self.grass_height_range_m[0] >= 0,
            "CampaignConfig.grass_height_range_m",
            self.grass_height_range_m,
            "heights >= 0 m",
        )

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

    def replace(self, **changes: Any) -> CampaignConfig:
        """A copy with some parameters changed."""
        return dataclasses.replace(self, **changes)
