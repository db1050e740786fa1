"""Field-campaign and mission simulator: mechanistic ground truth to canonical robot logs.

The truth is physics (:mod:`energy_planner.simulate.physics`: gravity work through an
efficiency, direction-dependent recovery when lowering, copper losses from the square
of the leg forces, standing, swing, turning, ripple), never the model's own terms.
Writes the campaign of the paper's section IV-C (straight runs on planar slopes at many
headings, turns, arcs, standing, composite paths for the superposition test) or mission
logs over a DEM, with realistic sensors, so that calibration and diagnosis can be
developed and tested against a known truth. See ``docs/simulate.md``.

>>> from energy_planner.simulate import simulate_campaign, CampaignConfig
>>> camp = simulate_campaign(seed=1, effects=("cold_joints",), config=CampaignConfig.small())
>>> camp.physics.effects
('cold_joints',)
"""

from energy_planner.simulate.campaign import (
    CHANNELS,
    LOG_COLUMNS,
    Campaign,
    NoiseFloor,
    battery_current,
    simulate_campaign,
)
from energy_planner.simulate.config import (
    BatteryConfig,
    CampaignConfig,
    ConfigError,
    SensorConfig,
)
from energy_planner.simulate.design import RunSpec, plan_runs
from energy_planner.simulate.effects import (
    EFFECTS,
    FAULTS,
    HIDDEN_EFFECTS,
    Effect,
    check_effects,
    check_faults,
    effect_table,
    truth_model,
)
from energy_planner.simulate.gaits import (
    GAITS,
    Gait,
    GaitSchedule,
    true_cost_per_metre,
    true_optimum_speed,
)
from energy_planner.simulate.missions import (
    GroundMap,
    MissionConfig,
    ground_map,
    simulate_missions,
    synthetic_dem,
)
from energy_planner.simulate.path import true_path_energy
from energy_planner.simulate.physics import (
    COMPONENTS,
    GROUNDS,
    Physics,
    RobotParams,
    critical_grade,
)

__all__ = [
    "CHANNELS",
    "COMPONENTS",
    "EFFECTS",
    "FAULTS",
    "GAITS",
    "GROUNDS",
    "HIDDEN_EFFECTS",
    "LOG_COLUMNS",
    "BatteryConfig",
    "Campaign",
    "CampaignConfig",
    "ConfigError",
    "Effect",
    "Gait",
    "GaitSchedule",
    "GroundMap",
    "MissionConfig",
    "NoiseFloor",
    "Physics",
    "RobotParams",
    "RunSpec",
    "SensorConfig",
    "battery_current",
    "check_effects",
    "check_faults",
    "critical_grade",
    "effect_table",
    "ground_map",
    "plan_runs",
    "simulate_campaign",
    "simulate_missions",
    "synthetic_dem",
    "true_cost_per_metre",
    "true_optimum_speed",
    "true_path_energy",
    "truth_model",
]


def __getattr__(name: str):
    if name == "BASE_COEFFICIENTS":
        from energy_planner.simulate import effects

        return effects.__getattr__(name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
