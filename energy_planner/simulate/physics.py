"""Mechanistic ground truth: the electrical power of a ~50 kg B1-class quadruped.

The simulator's truth is computed here from physics, never from the model's terms.
For every sample (slope ``alpha``, in-plane heading ``gamma``, body twist ``vx, vy,
wz``, body accelerations ``ax, ay`` and the extra channels) the electrical power drawn
from the battery is the sum of

``electronics``
    computers, sensors and motor drivers (constant; with the ``idle_power`` effect plus
    cooling fans that follow the air temperature).
``copper``
    Joule losses ``R i^2`` in the 12 motor windings. A leg carrying a foot force ``F``
    along one direction needs joint torques ``l F`` (``l`` the effective lever of that
    direction: the joint torques per newton of the leg's three joints, summed in
    quadrature) and motor currents ``l F / (k_t N)``, so its copper loss is
    ``kappa F^2`` with ``kappa = R l^2 / (k_t N)^2``. The total ground reaction
    balances gravity (and the inertial force): ``F_x = M g s_x + M a_x`` along body x,
    ``F_y = M g s_y + M a_y`` along body y (``s_x = sin(alpha) cos(gamma)`` and
    ``s_y = -sin(alpha) sin(gamma)`` are the grades along the body axes), and ``F_z =
    M g cos(alpha)`` along the normal. It is shared by the legs: normal loads shift
    front/back by ``F_x h / (2 L)`` (pitch moment of the tangential force at the centre
    of mass height ``h``) and left/right by ``F_y h / (2 W)`` (roll holding on a cross
    slope); each leg takes a quarter of the tangential force. Walking, only the stance
    legs carry (duty factor ``d``) with a half-sine force profile (mean of ``F^2`` is
    ``pi^2/8`` times the square of the mean), so the losses grow by ``pi^2 / (8 d)``
    against standing. The tangential lever depends on the leg's configuration:
    pushing (or holding) with the hip uses the whole leg (``lever_push_m``); braking
    while walking forward downhill the front legs are stretched along the force line
    (short ``lever_brake_forward_m``); braking backward uses the hip and the knee
    (``lever_brake_backward_m``); sideways forces go through the hip ab/adduction
    joints (``lever_lateral_m``).
``mechanical``
    gravity and inertial work ``M (g dz/dt + v . a)``. Positive work is paid through
    the drive efficiency ``lift_efficiency``; negative work (lowering, slowing down) is
    partly returned to the DC bus and used by the other consumers: a fraction that
    depends on the gait direction (forward gaits lower the body onto the next stance
    leg, backward and sideways gaits brake with impacts). The rest is dissipated in
    impacts, deformation and heat, so lowering never gives more than it releases and
    the power never goes negative.
``collisions``
    each stance leg touching down loses kinetic energy: a force ``c_dir M g`` along the
    motion, per gait direction (sidestepping is the least efficient gait).
``swing``
    lifting the feet to the step clearance at the stride frequency, and accelerating
    and braking the swing legs (grows with the square of the speed).
``gearbox``
    viscous friction in the gearboxes, proportional to the joint speeds (walking and
    turning); its grease viscosity depends on temperature (effect ``cold_joints``).
``turning``
    twisting the planted feet (friction torque ``mu M g cos(alpha) r``) and holding
    the tangential gravity load while the support pattern rotates (``M g sin(alpha)
    r``), times the yaw rate.
``ripple``
    the gait's power oscillates at the step frequency (zero mean over a cycle; its
    phase starts at zero at the start of a run).

``expected`` power is the sum without the ripple (the gait-cycle mean): what a perfect
model of the per-sample features could predict.

Hidden effects (:mod:`energy_planner.simulate.effects`) change this physics: extra
mass, a surface, the winding temperature, air temperature, grass, parameters.

Examples
--------
Level forward walk at 0.3 m/s, and the same walk 20 degrees uphill and downhill:

>>> import numpy as np
>>> phys = Physics()
>>> f = {"alpha": np.radians([0.0, 20.0, 20.0]), "gamma": np.radians([0.0, 0.0, 180.0]),
...      "vx": np.full(3, 0.3), "vy": np.zeros(3), "wz": np.zeros(3)}
>>> level, up, down = phys.power(f)
>>> bool(up > level > down > 0)
True
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from energy_planner.errors import ModelError

__all__ = ["RobotParams", "Physics", "GROUNDS", "COMPONENTS", "critical_grade"]

#: Ground types of the categorical channel ``ground``: (sinkage force as a fraction of
#: the weight, fraction of the lowering recovery kept). Used by the ``ground`` effect.
GROUNDS: dict[str, tuple[float, float]] = {
    "asphalt": (0.00, 1.0),
    "meadow": (0.03, 0.9),
    "gravel": (0.05, 0.8),
    "mud": (0.14, 0.4),
}

#: Power components, W, in the order :meth:`Physics.components` returns them.
COMPONENTS = (
    "electronics",
    "copper",
    "mechanical",
    "collisions",
    "swing",
    "gearbox",
    "turning",
    "terrain",
    "ripple",
)


@dataclass(frozen=True)
class RobotParams:
    """Physical parameters of the simulated robot (Unitree B1 class), each with its unit.

    Attributes
    ----------
    mass_kg : float
        Total robot mass, kg.
    gravity : float
        Gravitational acceleration, m/s^2.
    electronics_w : float
        Computers, sensors and motor drivers, W.
    winding_resistance_ohm : float
        Motor winding resistance (phase to phase) at ``reference_temp_c``, ohm.
    torque_constant_nm_a : float
        Motor torque constant, N m/A.
    gear_ratio : float
        Joint gear ratio, 1.
    lever_support_m : float
        Effective lever of the normal (supporting) foot force: mainly the knee, m.
    lever_push_m : float
        Effective lever of a tangential force that pushes along the motion or holds, m.
    lever_brake_forward_m : float
        Effective lever of the braking force when walking forward downhill, m.
    lever_brake_backward_m : float
        Effective lever of the braking force when walking backward downhill, m.
    lever_lateral_m : float
        Effective lever of a sideways foot force when stepping sideways (hip
        ab/adduction), m.
    lever_side_hold_m : float
        Effective lever of a sideways foot force when walking forward or backward (or
        standing) across a slope: the downhill feet are placed wide, so the load runs
        mostly along the legs, m.
    com_height_m : float
        Height of the centre of mass above the feet, m.
    half_length_m : float
        Half the distance between front and hind feet, m.
    half_width_m : float
        Half the distance between left and right feet, m.
    duty_factor : float
        Fraction of the gait cycle a leg is in stance (trot: 0.5), 1.
    stance_profile_factor : float
        Mean of F^2 over the mean of F, squared, for the stance force profile (half
        sine: pi^2/8), 1.
    lift_efficiency : float
        Electrical-to-mechanical efficiency of positive work (drivers and gearboxes,
        copper losses counted apart), 1.
    recovery_forward, recovery_backward, recovery_lateral : float
        Fraction of the released potential and kinetic energy returned to the bus when
        walking forward, backward and sideways, 1.
    collision_forward, collision_backward, collision_lateral : float
        Touch-down loss as a force along the motion, in units of the weight, 1.
    stride_frequency_hz : float
        Stride frequency of the gait (each leg swings once per stride), Hz.
    leg_mass_kg : float
        Mass of one leg, kg.
    step_clearance_m : float
        How high a foot is lifted, m.
    swing_efficiency : float
        Efficiency of the swing work (lifting and accelerating the legs), 1.
    swing_lateral_factor : float
        Swing losses of sideways steps relative to forward ones, 1.
    gearbox_friction_n : float
        Viscous gearbox loss at ``gearbox_reference_c`` as a force along the motion, N.
    gearbox_reference_c : float
        Temperature at which ``gearbox_friction_n`` holds, deg C.
    gearbox_viscosity_per_k : float
        Relative change of the grease viscosity per kelvin (exponential law), 1/K.
    turn_friction : float
        Friction coefficient of a planted foot twisting on the ground, 1.
    foot_radius_m : float
        Distance of a foot from the yaw axis, m.
    turn_slope_factor : float
        Share of the tangential gravity load re-balanced while turning on a slope, 1.
    ripple_fraction : float
        Amplitude of the power ripple at the step frequency, relative to the gait's
        power (all but electronics), 1.
    gait_on_speed : float
        Body speed (m/s; yaw rate times ``foot_radius_m`` counts) at which the gait is
        fully active; below it the stepping power ramps in linearly.
    reference_temp_c : float
        Winding temperature at which ``winding_resistance_ohm`` holds, deg C.
    copper_temp_coeff : float
        Temperature coefficient of copper resistance, 1/K.
    nominal_speed : float
        Speed at which the stride frequency is ``stride_frequency_hz``, m/s (used by
        the ``speed_dependence`` effect).
    """

    mass_kg: float = 50.0
    gravity: float = 9.81
    electronics_w: float = 45.0
    winding_resistance_ohm: float = 0.15
    torque_constant_nm_a: float = 0.12
    gear_ratio: float = 15.0
    lever_support_m: float = 0.11
    lever_push_m: float = 0.50
    lever_brake_forward_m: float = 0.08
    lever_brake_backward_m: float = 0.30
    lever_lateral_m: float = 0.50
    lever_side_hold_m: float = 0.15
    com_height_m: float = 0.35
    half_length_m: float = 0.33
    half_width_m: float = 0.19
    duty_factor: float = 0.5
    stance_profile_factor: float = math.pi**2 / 8
    lift_efficiency: float = 0.70
    recovery_forward: float = 0.60
    recovery_backward: float = 0.20
    recovery_lateral: float = 0.05
    collision_forward: float = 0.06
    collision_backward: float = 0.10
    collision_lateral: float = 0.16
    stride_frequency_hz: float = 0.9
    leg_mass_kg: float = 3.5
    step_clearance_m: float = 0.08
    swing_efficiency: float = 0.5
    swing_lateral_factor: float = 1.3
    gearbox_friction_n: float = 70.0
    gearbox_reference_c: float = 20.0
    gearbox_viscosity_per_k: float = 0.05
    turn_friction: float = 0.25
    foot_radius_m: float = 0.37
    turn_slope_factor: float = 1.0
    ripple_fraction: float = 0.10
    gait_on_speed: float = 0.05
    reference_temp_c: float = 40.0
    copper_temp_coeff: float = 0.0039
    nominal_speed: float = 0.3

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if not (isinstance(v, int | float) and math.isfinite(v)):
                raise ModelError(f"RobotParams.{f.name} = {v!r}: expected a finite number")
        positive = (
            "mass_kg",
            "gravity",
            "winding_resistance_ohm",
            "torque_constant_nm_a",
            "gear_ratio",
            "com_height_m",
            "half_length_m",
            "half_width_m",
            "lift_efficiency",
            "swing_efficiency",
            "stride_frequency_hz",
            "gait_on_speed",
            "nominal_speed",
        )
        for name in positive:
            if getattr(self, name) <= 0:
                raise ModelError(f"RobotParams.{name} = {getattr(self, name)!r}: expected > 0")
        for name in (
            "duty_factor",
            "lift_efficiency",
            "swing_efficiency",
            "recovery_forward",
            "recovery_backward",
            "recovery_lateral",
        ):
            v = getattr(self, name)
            if not 0 <= v <= 1:
                raise ModelError(f"RobotParams.{name} = {v!r}: expected a value in [0, 1]")
        if self.duty_factor == 0:
            raise ModelError("RobotParams.duty_factor = 0: expected a value in (0, 1]")

    def replace(self, **changes: float) -> RobotParams:
        """A copy with some parameters changed."""
        return dataclasses.replace(self, **changes)

    def kappa(self, lever_m: float, resistance_factor: Any = 1.0) -> Any:
        """Copper loss per squared foot force of one leg, ``R l^2 / (k_t N)^2``, W/N^2.

        >>> round(RobotParams().kappa(0.11) * 1e4, 3)
        5.602
        """
        r = self.winding_resistance_ohm * resistance_factor
        return r * lever_m**2 / (self.torque_constant_nm_a * self.gear_ratio) ** 2

    def table(self) -> list[dict[str, Any]]:
        """Rows ``name, value, unit`` of every parameter (for docs and ``--json``)."""
        units = {
            "mass_kg": "kg",
            "gravity": "m/s^2",
            "electronics_w": "W",
            "winding_resistance_ohm": "ohm",
            "torque_constant_nm_a": "N m/A",
            "stride_frequency_hz": "Hz",
            "leg_mass_kg": "kg",
            "gearbox_friction_n": "N",
            "gearbox_reference_c": "deg C",
            "gearbox_viscosity_per_k": "1/K",
            "reference_temp_c": "deg C",
            "copper_temp_coeff": "1/K",
            "nominal_speed": "m/s",
            "gait_on_speed": "m/s",
        }
        return [
            {
                "name": f.name,
                "value": getattr(self, f.name),
                "unit": units.get(f.name, "m" if f.name.endswith("_m") else "1"),
            }
            for f in dataclasses.fields(self)
        ]


def _arr(f: Mapping[str, Any], key: str, n: int, default: float = 0.0) -> np.ndarray:
    v = f.get(key)
    if v is None:
        return np.full(n, default)
    return np.broadcast_to(np.asarray(v, dtype=float), (n,)).astype(float, copy=False)


def _length(f: Mapping[str, Any]) -> int:
    """Number of samples: the largest size among the features (scalars broadcast)."""
    sizes = [int(np.size(v)) for v in f.values() if v is not None]
    if not any(k in f for k in ("alpha", "gamma", "vx", "vy", "wz")) or not sizes:
        raise ModelError("features need at least one of alpha, gamma, vx, vy, wz")
    return max(sizes)


class Physics:
    """The robot's electrical power from its motion, with effects switched on.

    Parameters
    ----------
    params : RobotParams, optional
        Physical parameters (default :class:`RobotParams`).
    effects : iterable of str
        Effect names (:data:`energy_planner.simulate.effects.EFFECTS`); each changes
        the physics as its description says.

    Notes
    -----
    Features (arrays of one length, or scalars): ``alpha, gamma`` (rad), ``vx, vy``
    (m/s), ``wz`` (rad/s), optional ``ax, ay`` (m/s^2, default 0), ``t_gait`` (s since
    the gait started, for the ripple phase; default no ripple) and the channels the
    switched-on effects read (``load_kg``, ``ground``, ``motor_temp``, ``air_temp_c``,
    ``grass_height_m``).
    """

    def __init__(
        self,
        params: RobotParams | None = None,
        effects: Iterable[str] = (),
        gaits: Any = None,
    ) -> None:
        from energy_planner.simulate.effects import check_effects

        self.effects = check_effects(effects)
        #: The controller's gaits (:class:`~energy_planner.simulate.gaits.GaitSchedule`),
        #: or None for the base robot's single gait (speed-independent stride).
        self.gaits = gaits
        base = params or RobotParams()
        self.base_params = base
        from energy_planner.simulate.effects import EFFECTS

        for name in self.effects:
            base = EFFECTS[name].adjust(base)
        self.params = base

    def __repr__(self) -> str:
        if self.gaits is not None:
            return f"Physics(effects={self.effects!r}, gaits={self.gaits.gaits!r})"
        return f"Physics(effects={self.effects!r})"

    def needs(self) -> tuple[str, ...]:
        """Channels the switched-on effects read."""
        from energy_planner.simulate.effects import EFFECTS

        return tuple(EFFECTS[n].channel for n in self.effects if EFFECTS[n].channel)

    def components(self, features: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """Every power component, W, per sample (see the module docstring).

        Raises
        ------
        ModelError
            A switched-on effect reads a channel the features do not have, or an
            unknown ``ground`` value.
        """
        for ch in self.needs():
            if features.get(ch) is None:
                raise ModelError(
                    f"effect reading channel {ch!r} is on but the features have no {ch!r}; "
                    f"give it (e.g. channels={{{ch!r}: value}})",
                    value=ch,
                    expected=f"features with the channel {ch!r}",
                )
        m = _Motion.of(features, self.params, set(self.effects))
        steps = None  # per sample (duty, stride frequency, impact) of the gaits
        if self.gaits is not None:
            from energy_planner.simulate.gaits import gait_arrays

            codes = features.get("gait")
            if codes is None:
                codes = self.gaits.gait_of(m.speed, m.alpha)
            codes = np.broadcast_to(np.asarray(codes, dtype=object), (m.n,))
            steps = gait_arrays(codes, m.speed)
        duty = None if steps is None else steps[0]
        mechanical, descent, sinkage = _mechanical(m)
        copper = _copper(m, descent, duty)
        collisions, stride_f = _collisions(m, steps)
        swing, terrain = _swing_and_grass(m, stride_f, duty)
        terrain = terrain + sinkage * m.weight * m.speed / m.p.lift_efficiency
        gearbox, turning = _gearbox(m), _turning(m)
        gait = copper + mechanical + collisions + swing + gearbox + turning + terrain
        return {
            "electronics": _electronics(m),
            "copper": copper,
            "mechanical": mechanical,
            "collisions": collisions,
            "swing": swing,
            "gearbox": gearbox,
            "turning": turning,
            "terrain": terrain,
            "ripple": _ripple(m, gait, stride_f),
        }

    def expected_power(self, features: Mapping[str, Any]) -> np.ndarray:
        """Gait-cycle mean electrical power, W (every component but the ripple)."""
        c = self.components({**features, "t_gait": None})
        return np.maximum(sum(v for k, v in c.items() if k != "ripple"), 0.0)

    def power(self, features: Mapping[str, Any]) -> np.ndarray:
        """Instantaneous electrical power, W (with the ripple when ``t_gait`` is given)."""
        c = self.components(features)
        return np.maximum(sum(c.values()), 0.0)


@dataclass(frozen=True)
class _Motion:
    """The features of :meth:`Physics.components` as arrays, and what every component uses."""

    f: Mapping[str, Any]
    p: RobotParams
    on: set[str]
    n: int
    alpha: np.ndarray
    gamma: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    wz: np.ndarray
    ax: np.ndarray
    ay: np.ndarray
    mass: Any  # kg (an array with the load effect)
    weight: Any  # N
    speed: np.ndarray
    yaw_speed: np.ndarray  # foot speed of the turn, m/s
    activity: np.ndarray  # 0 standing .. 1 walking
    sa: np.ndarray
    ca: np.ndarray
    s_x: np.ndarray  # grade along body x (uphill positive)
    s_y: np.ndarray  # grade along body y
    w_fwd: np.ndarray  # direction weights of the motion (squared direction cosines)
    w_bwd: np.ndarray
    w_lat: np.ndarray

    @classmethod
    def of(cls, f: Mapping[str, Any], p: RobotParams, on: set[str]) -> _Motion:
        n = _length(f)
        alpha, gamma = _arr(f, "alpha", n), _arr(f, "gamma", n)
        vx, vy, wz = _arr(f, "vx", n), _arr(f, "vy", n), _arr(f, "wz", n)
        mass = p.mass_kg + (_arr(f, "load_kg", n) if "load" in on else 0.0)
        speed = np.hypot(vx, vy)
        yaw_speed = p.foot_radius_m * np.abs(wz)
        sa = np.sin(alpha)
        # direction weights of the motion, 0 when standing
        safe = np.where(speed > 0, speed, 1.0)
        return cls(
            f, p, on, n, alpha, gamma, vx, vy, wz, _arr(f, "ax", n), _arr(f, "ay", n),
            mass, mass * p.gravity, speed, yaw_speed,
            np.clip((speed + yaw_speed) / p.gait_on_speed, 0.0, 1.0),
            sa, np.cos(alpha), sa * np.cos(gamma), -sa * np.sin(gamma),
            np.where(speed > 0, (np.maximum(vx, 0) / safe) ** 2, 0.0),
            np.where(speed > 0, (np.maximum(-vx, 0) / safe) ** 2, 0.0),
            np.where(speed > 0, (vy / safe) ** 2, 0.0),
        )  # fmt: skip

    @property
    def forces(self) -> tuple[Any, Any, Any]:
        """Ground reaction along body x, y and the normal, N."""
        return (
            self.weight * self.s_x + self.mass * self.ax,
            self.weight * self.s_y + self.mass * self.ay,
            self.weight * self.ca,
        )


def _mechanical(m: _Motion) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gravity and inertial work through the drives; also the descent mode and sinkage."""
    p, on = m.p, m.on
    m_inertial = m.mass + (p_extra_inertia(p) if "acceleration" in on else 0.0)
    dz_dt = m.vx * m.s_x + m.vy * m.s_y
    p_mech = m.weight * dz_dt + m_inertial * (m.vx * m.ax + m.vy * m.ay)
    rec_fwd: Any = p.recovery_forward
    descent = np.zeros(m.n, dtype=bool)
    if "downhill_braking" in on:
        # stiff descent mode when walking forward down more than DESCENT_GRADE
        descent = (m.vx > 0) & (-m.s_x > DESCENT_GRADE)
        rec_fwd = np.where(descent, DESCENT_RECOVERY, p.recovery_forward)
    recovery = rec_fwd * m.w_fwd + p.recovery_backward * m.w_bwd + p.recovery_lateral * m.w_lat
    sinkage = np.zeros(m.n)
    if "ground" in on:
        codes = _ground_codes(m.f["ground"], m.n)
        sinkage = np.select([codes == k for k in GROUNDS], [v[0] for v in GROUNDS.values()])
        recovery = recovery * np.select(
            [codes == k for k in GROUNDS], [v[1] for v in GROUNDS.values()]
        )
    mechanical = np.where(p_mech >= 0, p_mech / p.lift_efficiency, recovery * p_mech)
    return mechanical, descent, sinkage


def _ground_codes(ground: Any, n: int) -> np.ndarray:
    """The ``ground`` feature as ``n`` strings, each one of :data:`GROUNDS`."""
    codes = np.asarray(np.broadcast_to(np.asarray(ground, dtype=object), (n,))).astype(str)
    bad = sorted(set(np.unique(codes).tolist()) - set(GROUNDS))
    if bad:
        raise ModelError(
            f"unknown ground {bad[0]!r}; expected one of {', '.join(GROUNDS)}",
            value=bad[0],
            expected=f"one of {', '.join(GROUNDS)}",
        )
    return codes


def _copper(m: _Motion, descent: np.ndarray, duty: Any = None) -> np.ndarray:
    """Joule losses in the windings from the legs' share of the ground reaction.

    ``duty``: per-sample duty factors of the gaits (default the robot's one).
    """
    p, vx = m.p, m.vx
    f_x, f_y, f_z = m.forces
    r_factor: Any = 1.0
    if "motor_temp" in m.on:
        r_factor = 1.0 + p.copper_temp_coeff * (_arr(m.f, "motor_temp", m.n) - p.reference_temp_c)
    k_z = p.kappa(p.lever_support_m, r_factor)
    k_push = p.kappa(p.lever_push_m, r_factor)
    k_bf = np.where(
        descent, p.kappa(DESCENT_LEVER_M, r_factor), p.kappa(p.lever_brake_forward_m, r_factor)
    )
    k_bb = p.kappa(p.lever_brake_backward_m, r_factor)
    # sideways forces: stepping sideways the stance legs pass through the vertical
    # (hip ab/adduction lever); walking forward the feet are placed wide on the
    # downhill side, so a sideways load runs mostly along the legs (short lever)
    k_y = m.w_lat * p.kappa(p.lever_lateral_m, r_factor) + (1.0 - m.w_lat) * p.kappa(
        p.lever_side_hold_m, r_factor
    )
    braking = f_x * vx < 0  # the x force opposes the motion along x
    moving_x = np.clip(np.abs(vx) / p.gait_on_speed, 0.0, 1.0)
    k_brake = np.where(vx > 0, k_bf, k_bb)
    k_x = np.where(braking, moving_x * k_brake + (1 - moving_x) * k_push, k_push)
    d = p.duty_factor if duty is None else duty
    share = 1.0 + m.activity * (p.stance_profile_factor / d - 1.0)
    h = p.com_height_m
    pitch, roll = (h / p.half_length_m) ** 2, (h / p.half_width_m) ** 2
    return (
        share
        / 4.0
        * (k_z * (f_z**2 + pitch * f_x**2 + roll * f_y**2) + k_x * f_x**2 + k_y * f_y**2)
    )


def _collisions(m: _Motion, gait: Any = None) -> tuple[np.ndarray, np.ndarray]:
    """Touch-down losses, and the stride frequency (Hz) per sample.

    ``gait``: per-sample ``(duty, stride frequency, impact factor)`` of the gaits
    (:func:`~energy_planner.simulate.gaits.gait_arrays`); then the gaits set the stride
    frequency and scale the touch-downs, and ``speed_dependence`` has nothing to add.
    """
    p = m.p
    coll = p.collision_forward * m.w_fwd + p.collision_backward * m.w_bwd
    coll = coll + p.collision_lateral * m.w_lat
    collisions = coll * m.weight * m.speed / p.lift_efficiency
    if gait is not None:
        return collisions * gait[2], gait[1]
    stride_f = np.full(m.n, p.stride_frequency_hz)
    if "speed_dependence" in m.on:
        # fixed stride length: the frequency follows the speed, and so do the number
        # of touch-downs per second (each as hard as at the nominal speed)
        stride_f = p.stride_frequency_hz * np.maximum(m.speed / p.nominal_speed, 0.5)
        collisions = collisions * stride_f / p.stride_frequency_hz
    return collisions, stride_f


def _swing_and_grass(
    m: _Motion, stride_f: np.ndarray, duty: Any = None
) -> tuple[np.ndarray, np.ndarray]:
    """Swinging the legs (lift and kinetic), and the drag of grass stems (terrain).

    ``duty``: per-sample duty factors of the gaits (default the robot's one).
    """
    p, speed = m.p, m.speed
    clearance = p.step_clearance_m
    terrain = np.zeros(m.n)
    if "vegetation" in m.on:
        grass = np.maximum(_arr(m.f, "grass_height_m", m.n), 0.0)
        clearance = clearance + 0.5 * grass  # feet lifted above the grass
        terrain = terrain + VEGETATION_DRAG_N_PER_M * grass * speed  # stems drag on the legs
    lift = m.activity * 4 * stride_f * p.leg_mass_kg * p.gravity * clearance / p.swing_efficiency
    lat_factor = 1.0 + (p.swing_lateral_factor - 1.0) * m.w_lat
    if duty is not None:
        swing_v = speed / (1.0 - duty)
    else:
        swing_v = speed / (1.0 - p.duty_factor) if p.duty_factor < 1 else speed
    kinetic = 4 * stride_f * p.leg_mass_kg * swing_v**2 * lat_factor / p.swing_efficiency
    return lift + kinetic, terrain


def _gearbox(m: _Motion) -> np.ndarray:
    """Viscous gearbox friction; the grease thickens in the cold (``cold_joints``)."""
    p = m.p
    visc: Any = 1.0
    if "cold_joints" in m.on:
        visc = np.exp(
            p.gearbox_viscosity_per_k * (p.gearbox_reference_c - _arr(m.f, "air_temp_c", m.n))
        )
    return p.gearbox_friction_n * visc * (m.speed + m.yaw_speed)


def _turning(m: _Motion) -> np.ndarray:
    """Twisting the planted feet and holding the slope's load while the support rotates."""
    p, w = m.p, np.abs(m.wz)
    turning = (
        w
        * p.foot_radius_m
        * m.weight
        * (p.turn_friction * m.ca + p.turn_slope_factor * m.sa)
        / p.lift_efficiency
    )
    if "turn_while_walking" in m.on:  # planted feet scuff sideways on arcs
        scuff = TURN_SCUFF * m.weight * p.foot_radius_m * w * m.speed / (m.speed + 0.05)
        turning = turning + scuff / p.lift_efficiency
    return turning


def _electronics(m: _Motion) -> np.ndarray:
    """Computers and drivers; with ``idle_power``, fans that follow the air temperature."""
    electronics = np.full(m.n, m.p.electronics_w)
    if "idle_power" in m.on:  # cooling fans follow the air temperature (fan law)
        air = _arr(m.f, "air_temp_c", m.n)
        fan_speed = np.clip((air - FAN_ON_C) / (FAN_FULL_C - FAN_ON_C), 0.0, 1.0)
        electronics = electronics + FAN_POWER_W * fan_speed**3
    return electronics


def _ripple(m: _Motion, gait: np.ndarray, stride_f: np.ndarray) -> np.ndarray:
    """The gait's power oscillation at the step frequency (none without ``t_gait``)."""
    p = m.p
    if m.f.get("t_gait") is None or p.ripple_fraction <= 0:
        return np.zeros(m.n)
    t_gait = _arr(m.f, "t_gait", m.n)
    return (
        p.ripple_fraction
        * m.activity
        * np.maximum(gait, 0.0)
        * np.sin(4 * np.pi * stride_f * t_gait)
    )


#: Drag of grass stems on the swinging legs per metre of grass height, N/m.
VEGETATION_DRAG_N_PER_M = 250.0
#: Friction coefficient of the sideways scuffing of planted feet on arcs (effect).
TURN_SCUFF = 0.8
#: ``downhill_braking`` effect: the stiff descent mode engages beyond this downhill grade
#: along the forward motion (sin 8 deg), brakes with this lever (m) and returns this share.
DESCENT_GRADE = math.sin(math.radians(8.0))
DESCENT_LEVER_M = 0.30
DESCENT_RECOVERY = 0.10
#: ``acceleration`` effect: inertia of one motor rotor, kg m^2.
ROTOR_INERTIA_KG_M2 = 2e-3
#: ``idle_power`` effect: the cooling fans of the computers and drivers draw up to this
#: (W); they start at ``FAN_ON_C`` and run at full speed from ``FAN_FULL_C`` (deg C of the
#: air); fan power grows with the cube of the fan speed (fan affinity law).
FAN_POWER_W = 30.0
FAN_ON_C = 5.0
FAN_FULL_C = 30.0


def p_extra_inertia(p: RobotParams) -> float:
    """Extra effective mass of the ``acceleration`` effect: rotors and legs, kg.

    The kinetic energy the gait carries beyond the body's, ``m_extra v^2 / 2`` at body
    speed ``v``. In a trot every foot moves at ``v`` relative to the body (stance feet
    backward, swing feet forward), so the hip turns at about ``v / h`` (``h =
    com_height_m``, the leg's height) and the knee at about half that. The rotors (``J =
    2e-3 kg m^2`` each, the B1 class's large actuators, behind gear ratio ``N``) of the
    hip and knee of four legs then hold ``4 J N^2 (1 + 1/4) / h^2``; the legs' own masses,
    whose centres move at about ``v / 2`` relative to the body, ``4 m_leg / 4``. The
    ab/adduction joints do not turn walking straight.

    >>> round(p_extra_inertia(RobotParams()), 1)
    21.9
    """
    rotor = 4 * ROTOR_INERTIA_KG_M2 * p.gear_ratio**2 * 1.25 / p.com_height_m**2
    return float(rotor + p.leg_mass_kg)


def critical_grade(
    physics: Physics | None = None, speed: float = 0.3, max_deg: float = 45.0
) -> dict[str, float]:
    """Grade beyond which a zig-zag detour pays, from the truth walking forward uphill.

    The cost per metre straight up the fall line is ``c(g) = P / v`` at grade ``g =
    sin(alpha)``; climbing a height ``H`` at grade ``g`` takes ``H / g`` metres, so the
    energy ``H c(g) / g`` is least at the grade ``g*`` minimising ``c(g) / g``. On
    steeper ground a detour at grade ``g*`` beats the direct climb. For the default
    physics ``c(g) = a + b g + q g^2`` exactly (``a`` the level cost, ``b = M g /
    lift_efficiency``, ``q`` the copper losses of the tangential force, see
    docs/simulate.md), so ``g* = sqrt(a / q)``; this function minimises numerically so
    that it holds for any parameters and effects.

    Returns
    -------
    dict
        ``grade`` (g*), ``slope_deg`` (asin g*), ``cost_n`` (c(g*), J/m) and
        ``level_cost_n`` (c(0)).

    Examples
    --------
    >>> c = critical_grade()
    >>> 15 <= c["slope_deg"] <= 22
    True
    """
    physics = physics or Physics()
    deg = np.linspace(0.05, max_deg, 8000)
    a = np.radians(deg)
    n = len(a)
    f = {
        "alpha": a,
        "gamma": np.zeros(n),
        "vx": np.full(n, speed),
        "vy": np.zeros(n),
        "wz": np.zeros(n),
    }
    cost = physics.expected_power(f) / speed
    k = int(np.argmin(cost / np.sin(a)))
    level = (
        physics.expected_power(
            {
                "alpha": np.zeros(1),
                "gamma": np.zeros(1),
                "vx": np.full(1, speed),
                "vy": np.zeros(1),
                "wz": np.zeros(1),
            }
        )[0]
        / speed
    )
    return {
        "grade": float(np.sin(a[k])),
        "slope_deg": float(deg[k]),
        "cost_n": float(cost[k]),
        "level_cost_n": float(level),
    }
