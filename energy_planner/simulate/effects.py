"""Hidden effects: switchable changes to the simulator's physics, and sensor faults.

Each :class:`Effect` changes the mechanistic truth of
:mod:`energy_planner.simulate.physics` (a parameter, or a physical process that the
base robot does not have); none is a formula of the model's catalog. Effects tied to a
log channel make the physics read that channel; the channel is logged in every
campaign (varying between runs) whether its effect is on or not. Any effects combine.

Three effects are not discovery targets (``Effect.target`` False): ``joule_heating`` and
``downhill_braking`` are *robot-parameter variants*, they change parameters whose shape
the base model already has (the copper losses of the leg forces, the braking of a forward
descent), so a fit absorbs them into the base's coefficients; ``acceleration``, sized
from the robot's rotors and legs, costs about 1.4 J more per start at 0.3 m/s, far below
the noise of a logged window. :data:`HIDDEN_EFFECTS` lists the effects a discovery should
find.

Sensor faults (:data:`FAULTS`) are not physics: they corrupt the logs (odometry slip
that grows with slope, the ROS sign of the battery current, a clock offset between the
battery and the odometry streams), for diagnosis to report as data findings.

Examples
--------
>>> sorted(EFFECTS)[:4]
['acceleration', 'cold_joints', 'downhill_braking', 'ground']
>>> [e.name for e in EFFECTS.values() if e.channel]
['idle_power', 'load', 'ground', 'motor_temp', 'cold_joints', 'vegetation']
>>> EFFECTS["joule_heating"].adjust(RobotParams()).winding_resistance_ohm
0.195
>>> check_effects(["load", "ground", "load"])
('load', 'ground')
>>> [n for n in EFFECTS if n not in HIDDEN_EFFECTS]
['joule_heating', 'downhill_braking', 'acceleration']
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field

from energy_planner.errors import ModelError, RemovedAPIError
from energy_planner.simulate.physics import RobotParams

__all__ = [
    "Effect",
    "EFFECTS",
    "FAULTS",
    "HIDDEN_EFFECTS",
    "check_effects",
    "check_faults",
    "effect_table",
    "truth_model",
]


@dataclass(frozen=True)
class Effect:
    """One physical change the simulator can switch on.

    Attributes
    ----------
    name : str
        Effect name (``--effect NAME``).
    explanation : str
        The physics that changes.
    needs : tuple of str
        What a campaign must contain for the effect to be visible.
    channel : str or None
        The log channel the physics reads when the effect is on (None: structural).
    changes : mapping
        Parameter changes of :class:`RobotParams` (name -> new value, or a function of
        the old parameters).
    resembles : str or None
        The catalog term whose shape is closest (for orientation only: the simulated
        physics is not that formula); None when the catalog does not read the channel.
    target : bool
        A hidden effect that discovery should find (True), or a robot-parameter variant
        (False): it changes parameters whose shape the base model already has, so a fit
        absorbs it into the base's coefficients and there is nothing to add.
    """

    name: str
    explanation: str
    needs: tuple[str, ...] = ()
    channel: str | None = None
    changes: Mapping[str, float | Callable[[RobotParams], float]] = field(default_factory=dict)
    resembles: str | None = None
    target: bool = True

    def adjust(self, params: RobotParams) -> RobotParams:
        """The parameters with this effect's changes applied."""
        new = {k: (v(params) if callable(v) else v) for k, v in self.changes.items()}
        return dataclasses.replace(params, **new) if new else params


#: Every physical effect the simulator knows: name -> :class:`Effect`.
EFFECTS: dict[str, Effect] = {
    e.name: e
    for e in (
        Effect(
            "idle_power",
            "the cooling fans of the computers and motor drivers follow the air temperature "
            "(channel air_temp_c): off below 5 C, full speed (30 W) from 30 C, their power "
            "growing with the cube of the fan speed in between (fan law); drawn also "
            "while standing",
            ("channel air_temp_c varies between runs (default -5 to 30 C)",),
            channel="air_temp_c",
        ),
        Effect(
            "speed_dependence",
            "the gait keeps its stride length, so the stride frequency follows the speed: "
            "foot lifting and touch-downs per second grow with v, swing-leg kinetic losses "
            "with v^3 (same power as the base robot at 0.3 m/s)",
            ("several speeds (e.g. --speeds 0.2,0.3,0.45)",),
            resembles="speed_dependence",
        ),
        Effect(
            "joule_heating",
            "motors with 1.3 times the winding resistance (a thinner-wire actuator "
            "version): every copper loss, which grows with the square of the leg forces, "
            "is 1.3 times larger (a robot-parameter variant: the base's squared-force "
            "copper terms absorb it)",
            ("several slopes; stand runs and cross-slope headings help",),
            changes={"winding_resistance_ohm": lambda p: 1.3 * p.winding_resistance_ohm},
            resembles="joule_heating",
            target=False,
        ),
        Effect(
            "downhill_braking",
            "a stiff descent mode that engages walking forward down more than 8 deg of "
            "grade: the legs brake with the hip (lever 0.30 m instead of 0.08 m) and "
            "return 10 % of the released energy instead of 60 % (a step in the cost at "
            "the threshold; a robot-parameter variant: the base's forward-descent terms "
            "absorb it)",
            ("forward runs downhill at slopes on both sides of 8 deg",),
            resembles="downhill_braking",
            target=False,
        ),
        Effect(
            "turn_while_walking",
            "on arcs the planted feet scuff sideways (friction 0.8 times the weight at "
            "the foot radius, growing with speed as v / (v + 0.05 m/s))",
            ("arc runs (CampaignConfig.arcs) or mission logs",),
            resembles="turn_while_walking",
        ),
        Effect(
            "acceleration",
            "speed changes also spin the rotors of the hip and knee motors and swing the "
            "legs relative to the body (about 22 kg more kinetic mass, see "
            "physics.p_extra_inertia): paid through the drive when speeding up, returned "
            "like the body's share when slowing down. Not a discovery target: physically "
            "sized, a start at 0.3 m/s costs about 1.4 J more, far below the noise of a "
            "window",
            ("speed ramps (CampaignConfig.ramp_s > 0) or mission logs with speed changes",),
            resembles="acceleration",
            target=False,
        ),
        Effect(
            "load",
            "a carried load (channel load_kg) adds to the mass everywhere: gravity work, "
            "inertia, the copper losses of the leg forces (which grow with the square of "
            "the mass), touch-down losses",
            ("channel load_kg varies between runs (default 0, 5, 10, 15 kg)",),
            channel="load_kg",
        ),
        Effect(
            "ground",
            "the surface (channel ground) resists: feet sink in meadow, gravel and mud "
            "(a force of 3, 5, 14 % of the weight along the motion) and slip, so less of "
            "the lowering energy is recovered (asphalt is the reference)",
            ("channel ground varies between runs (meadow, gravel, mud, asphalt)",),
            channel="ground",
        ),
        Effect(
            "motor_temp",
            "the winding resistance follows the logged winding temperature (channel "
            "motor_temp): +0.39 %/K from 40 C, so every copper loss grows with it",
            (
                "channel motor_temp varies (default 25-75 C at run start, warming during runs)",
                "copper-heavy motions (slopes, standing) make it clearer",
            ),
            channel="motor_temp",
        ),
        Effect(
            "cold_joints",
            "gearbox grease stiffens in the cold (channel air_temp_c): its viscous loss "
            "grows as exp(0.05 (20 - T)) (x3.5 at -5 C, x0.61 at 30 C)",
            ("channel air_temp_c varies between runs (default -5 to 30 C)",),
            channel="air_temp_c",
        ),
        Effect(
            "vegetation",
            "grass (channel grass_height_m) drags on the swinging legs (250 N per metre "
            "of grass height along the motion) and the feet are lifted above half of it",
            ("channel grass_height_m varies between runs (default 0-0.4 m)",),
            channel="grass_height_m",
        ),
    )
}

#: The hidden effects a discovery should find (every effect but the robot-parameter
#: variants, whose physics the base model's coefficients absorb).
HIDDEN_EFFECTS: tuple[str, ...] = tuple(n for n, e in EFFECTS.items() if e.target)

#: Sensor faults (``--fault NAME``): data problems, not physics. name -> description.
FAULTS: dict[str, str] = {
    "slope_slip": "odometry slip grows strongly with slope: measured speed = true * "
    "(1 - 0.02 - 0.6 sin(alpha)) (default sensors: 0.1 sin(alpha))",
    "ros_current_sign": "the battery current is logged with the ROS sign convention "
    "(negative while discharging)",
    "clock_offset": "the battery stream (voltage, current) lags the odometry and IMU by 0.4 s",
}


def check_effects(effects: Iterable[str]) -> tuple[str, ...]:
    """Validate effect names; return them in order without duplicates.

    Raises
    ------
    ModelError
        Naming the unknown effect and listing the valid ones.
    """
    if isinstance(effects, str):
        effects = (effects,)
    out: list[str] = []
    for name in effects:
        if name not in EFFECTS:
            raise ModelError(
                f"unknown effect {name!r}; valid effects: {', '.join(sorted(EFFECTS))}"
            )
        if name not in out:
            out.append(name)
    return tuple(out)


def check_faults(faults: Iterable[str]) -> tuple[str, ...]:
    """Validate sensor-fault names (see :data:`FAULTS`).

    >>> check_faults(["clock_offset"])
    ('clock_offset',)
    """
    if isinstance(faults, str):
        faults = (faults,)
    out: list[str] = []
    for name in faults:
        if name not in FAULTS:
            raise ModelError(f"unknown sensor fault {name!r}; valid faults: {', '.join(FAULTS)}")
        if name not in out:
            out.append(name)
    return tuple(out)


def effect_table(effects: Mapping[str, Effect] | None = None) -> list[dict[str, object]]:
    """Rows describing the effects (name, channel, explanation, needs, resembles, target)."""
    effects = EFFECTS if effects is None else effects
    return [
        {
            "name": e.name,
            "channel": e.channel,
            "explanation": e.explanation,
            "needs": list(e.needs),
            "resembles": e.resembles,
            "target": e.target,
        }
        for e in effects.values()
    ]


def truth_model(*args: object, **kwargs: object):
    """Removed: the truth is no longer an EnergyModel.

    Raises
    ------
    RemovedAPIError
        Always, pointing to :class:`energy_planner.simulate.Physics` and
        :func:`energy_planner.simulate.true_path_energy`.
    """
    raise RemovedAPIError(
        "energy_planner.simulate.truth_model was removed: the simulator's truth is "
        "mechanistic physics, not an EnergyModel. Use Campaign.physics / "
        "energy_planner.simulate.Physics(effects=...).power(features) for per-sample "
        "power and energy_planner.simulate.true_path_energy(...) for a path"
    )


def __getattr__(name: str):
    if name == "BASE_COEFFICIENTS":
        raise RemovedAPIError(
            "energy_planner.simulate.BASE_COEFFICIENTS was removed: the simulator's truth "
            "is mechanistic (energy_planner.simulate.RobotParams) and has no model "
            "coefficients; compare a fitted model with the truth's power "
            "(Campaign.true_samples['power_expected'], Physics.expected_power) instead"
        )
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
