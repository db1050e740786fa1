"""Field-campaign simulator: ground-truth physics to canonical robot logs.

Writes the campaign of the paper's section IV-C (straight runs on planar slopes at many
headings, turns, arcs, standing, composite paths for the superposition test) with
realistic sensors, so that calibration and diagnosis can be developed and tested
against a known truth. See ``docs/simulate.md``.

>>> from energy_planner.simulate import simulate_campaign, CampaignConfig, EFFECTS
>>> camp = simulate_campaign(seed=1, effects=("cold_joints",), config=CampaignConfig.small())
>>> camp.truth.coefficients["cold_joints"] == EFFECTS["cold_joints"].coefficient
True
"""

from energy_planner.simulate.campaign import (
    CHANNELS,
    LOG_COLUMNS,
    Campaign,
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
    BASE_COEFFICIENTS,
    EFFECTS,
    Effect,
    check_effects,
    effect_table,
    truth_model,
)

__all__ = [
    "BASE_COEFFICIENTS",
    "CHANNELS",
    "EFFECTS",
    "LOG_COLUMNS",
    "BatteryConfig",
    "Campaign",
    "CampaignConfig",
    "ConfigError",
    "Effect",
    "RunSpec",
    "SensorConfig",
    "battery_current",
    "check_effects",
    "effect_table",
    "plan_runs",
    "simulate_campaign",
    "truth_model",
]
