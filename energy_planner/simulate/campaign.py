"""Simulate a field campaign in the canonical robot-log format.

The pipeline, for every planned run (:func:`~energy_planner.simulate.design.plan_runs`):

1. twist profile with linear ramps (:func:`~energy_planner.simulate.kinematics.twist_profile`),
2. true pose on the planar ramp and the true IMU orientation,
3. true electrical power from the mechanistic physics
   (:class:`~energy_planner.simulate.physics.Physics`, with the effects switched on),
4. the battery: current solving ``P = V I`` with ``V = OCV(soc) - R I``,
5. sensors: current/voltage noise and spikes, odometry slip and noise, IMU tilt bias and
   noise, and the sensor faults asked for.

Random streams are split so that the design (ramp azimuths, run order), the extra
channels and the sensor noise do not depend on which effects are switched on: the same
seed gives the same runs with and without an effect.

Examples
--------
>>> from energy_planner.simulate import simulate_campaign, CampaignConfig
>>> camp = simulate_campaign(seed=0, effects=("load",), config=CampaignConfig.small())
>>> len(camp.runs), camp.effects
(95, ('load',))
>>> bool((camp.logs["current"].median() > 0))
True
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

import numpy as np
import pandas as pd

from energy_planner.simulate.battery import battery_current
from energy_planner.simulate.config import CampaignConfig
from energy_planner.simulate.design import RunSpec, plan_runs
from energy_planner.simulate.kinematics import integrate_pose, twist_profile, wrap
from energy_planner.simulate.physics import RobotParams
from energy_planner.simulate.records import (
    ChannelDraws,
    TruthStreams,
    lay_out,
    logs_from_truth,
    run_record,
    sensor_offsets,
    switch_on,
)
from energy_planner.simulate.result import CHANNELS, LOG_COLUMNS, Campaign, NoiseFloor

__all__ = [
    "Campaign",
    "NoiseFloor",
    "simulate_campaign",
    "LOG_COLUMNS",
    "CHANNELS",
    "battery_current",
]


def simulate_campaign(
    seed: int = 0,
    effects: Iterable[str] = (),
    config: CampaignConfig | None = None,
    *,
    faults: Iterable[str] = (),
    params: RobotParams | None = None,
    progress: bool = False,
) -> Campaign:
    """Simulate a field campaign.

    Parameters
    ----------
    seed : int
        Random seed; the same seed and parameters give the same campaign.
    effects : iterable of str
        Effects to switch on (names from :data:`energy_planner.simulate.EFFECTS`).
    config : CampaignConfig, optional
        Campaign parameters (default :class:`CampaignConfig`); ``CampaignConfig.small()``
        for tests, ``CampaignConfig(sensors=SensorConfig.ideal())`` for noise-free logs.
    faults : iterable of str
        Sensor faults (names from :data:`energy_planner.simulate.FAULTS`), applied on
        top of ``config.sensors``.
    params : RobotParams, optional
        Robot parameters of the truth (default :class:`RobotParams`).
    progress : bool
        Show a progress bar on stderr.

    Returns
    -------
    Campaign

    Raises
    ------
    ModelError
        Unknown effect or fault.
    """
    config = config or CampaignConfig()
    names, fault_names, physics, sens = switch_on(
        effects, faults, params, config.sensors, config.gaits
    )
    from energy_planner.progress import track

    design_rng, channel_rng, noise_rng = np.random.default_rng(seed).spawn(3)
    plan = plan_runs(config)
    psi_of, run_block, order = _field_design(plan, design_rng)
    draws = ChannelDraws.draw(channel_rng, config, max(run_block) + 1, ground=True)
    slip_raw, bias = sensor_offsets(noise_rng, sens, len(plan))

    # ---- geometry, in design order (leg B starts where leg A ended)
    geo: list[dict[str, Any]] = []
    end_of: dict[str, tuple[np.ndarray, float]] = {}
    for spec in track(plan, "simulating runs", progress, unit="run"):
        geo.append(_run_geometry(spec, config, psi_of[spec.slope_deg], end_of))

    # ---- assemble in field order on the campaign clock
    lay = lay_out([geo[k]["t"] for k in order], config.gap_s)
    idx = np.asarray(order)[lay.run_of_sample]  # design index per sample
    g = {key: np.concatenate([geo[k][key] for k in order]) for key in geo[0]}
    slopes = np.radians([s.slope_deg for s in plan])
    slip_run = sens.slip_mean + sens.slip_per_sin_slope * np.sin(slopes) + sens.slip_std * slip_raw
    truth = TruthStreams(
        np.array([s.run for s in plan], dtype=object)[idx], lay.t, lay.t_run, slopes[idx],
        np.array([psi_of[s.slope_deg] for s in plan])[idx], g["gamma"], g["vx"], g["vy"],
        g["wz"], g["ax"], g["ay"], g["pos"], g["yaw"],
        draws.per_sample(np.asarray(run_block)[idx], lay.t_run),
    )  # fmt: skip
    out = logs_from_truth(
        truth, physics, sens, config.battery, config.dt, lay.sizes, slip_run[idx], bias[idx],
        noise_rng, list(config.grounds),
    )  # fmt: skip
    rows = [
        run_record(
            _run_description(plan[k], psi_of),
            rank,
            lay,
            out,
            draws.row(run_block[k]),
            slip_run[k],
            bias[k],
            geo[k]["pos"],
            geo[k]["yaw"][-1],
            float(wrap(geo[k]["gamma"][-1])),
        )  # fmt: skip
        for rank, k in enumerate(order)
    ]
    return Campaign(
        out["logs"], pd.DataFrame(rows), physics, names, out["true_samples"], seed, config,
        fault_names,
    )  # fmt: skip


def _field_design(
    plan: list[RunSpec], rng: np.random.Generator
) -> tuple[dict[float, float], list[int], list[int]]:
    """A ramp azimuth per slope, the block of each run, and the runs in field order.

    The runs of a slope are walked together (slopes in increasing order), its blocks (a
    condition, or the parts of a composite) in random order.
    """
    slope_values = sorted({r.slope_deg for r in plan})
    psi_of = {s: float(rng.uniform(-math.pi, math.pi)) for s in slope_values}
    blocks = list(dict.fromkeys(r.composite or r.run for r in plan))
    block_index = {b: i for i, b in enumerate(blocks)}
    shuffled = rng.permutation(len(blocks))
    slope_rank = {s: i for i, s in enumerate(slope_values)}
    run_block = [block_index[r.composite or r.run] for r in plan]
    order = sorted(
        range(len(plan)),
        key=lambda k: (slope_rank[plan[k].slope_deg], shuffled[run_block[k]], k),
    )
    return psi_of, run_block, order


def _run_description(spec: RunSpec, psi_of: dict[float, float]) -> dict[str, Any]:
    """What a designed run's record says of it (:data:`~.records.RUN_FIELDS`)."""
    return {
        "run": spec.run,
        "kind": spec.kind,
        "motion": spec.motion,
        "slope_deg": spec.slope_deg,
        "uphill_azimuth_deg": math.degrees(psi_of[spec.slope_deg]),
        "heading_deg": spec.heading_deg,
        "speed": spec.speed,
        "yaw_rate": spec.yaw_rate,
        "composite": spec.composite,
        "part": spec.part,
        "distance_m": spec.distance_m,
        "turn_deg": math.degrees(spec.turn_rad),
        "repeat": spec.repeat,
    }


def _run_geometry(
    spec: RunSpec,
    config: CampaignConfig,
    psi: float,
    end_of: dict[str, tuple[np.ndarray, float]],
) -> dict[str, Any]:
    """Twist, pose and true orientation of one run (time from 0)."""
    t, vx, vy, wz, ax, ay = twist_profile(spec.segments, config.ramp_s, config.dt)
    alpha = math.radians(spec.slope_deg)
    if spec.start_after:
        start, gamma0 = end_of[spec.start_after]
    else:
        start, gamma0 = np.zeros(3), math.radians(spec.heading_deg)
    pos, gamma, yaw = integrate_pose(t, vx, vy, wz, alpha, psi, gamma0, start)
    end_of[spec.run] = (pos[-1], float(gamma[-1]))
    return {
        "t": t,
        "vx": vx,
        "vy": vy,
        "wz": wz,
        "ax": ax,
        "ay": ay,
        "pos": pos,
        "gamma": gamma,
        "yaw": yaw,
    }
