"""From true motion to logs and run records: what the campaign and the missions share.

Both simulators end the same way. Their runs (a designed run or a mission) are laid out
one after another on the campaign clock (:func:`lay_out`); the extra channels are drawn
once per run or block (:class:`ChannelDraws`); the true motion of all runs
(:class:`TruthStreams`) goes through the physics, the battery and the sensors
(:func:`logs_from_truth`); and each run gets one row of ``Campaign.runs``
(:func:`run_record`).

Examples
--------
>>> lay = lay_out([np.arange(3) * 0.5, np.arange(2) * 0.5], gap_s=1.0)
>>> lay.starts.tolist(), lay.t.tolist()
([0.0, 2.0], [0.0, 0.5, 1.0, 2.0, 2.5])
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from energy_planner.simulate.battery import Discharge, discharge
from energy_planner.simulate.kinematics import imu_quaternion, quat_from_rotvec, quat_mul, wrap
from energy_planner.simulate.physics import Physics

__all__ = [
    "ChannelDraws",
    "RunLayout",
    "TruthStreams",
    "lay_out",
    "run_slices",
    "runs_in",
    "logs_from_truth",
    "run_record",
    "sensor_offsets",
    "switch_on",
]


@dataclass(frozen=True)
class RunLayout:
    """Runs laid out one after another on the campaign clock (in log order).

    Attributes
    ----------
    sizes : ndarray of int
        Samples per run.
    starts : ndarray
        Campaign clock at each run's start, s.
    durations : list of float
        Each run's length (its last time stamp), s.
    run_of_sample : ndarray of int
        Position (in log order) of each sample's run.
    t_run, t : ndarray
        Per sample: time since its run started, and on the campaign clock (s, rounded
        to 1 ns).
    """

    sizes: np.ndarray
    starts: np.ndarray
    durations: list[float]
    run_of_sample: np.ndarray
    t_run: np.ndarray
    t: np.ndarray


def run_slices(sizes: Sequence[int] | np.ndarray) -> list[slice]:
    """Slices of runs of ``sizes`` samples laid one after another.

    >>> run_slices([2, 3])
    [slice(0, 2, None), slice(2, 5, None)]
    """
    bounds = np.concatenate([[0], np.cumsum(sizes)]).astype(int)
    return [slice(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]


def runs_in(run: np.ndarray) -> list[slice]:
    """Slices of the runs of a log column (each run's samples together).

    >>> runs_in(np.array(["a", "a", "b"]))
    [slice(0, 2, None), slice(2, 3, None)]
    """
    starts = np.flatnonzero(np.r_[True, run[1:] != run[:-1]])
    return run_slices(np.diff(np.r_[starts, len(run)]))


def lay_out(times: Sequence[np.ndarray], gap_s: float) -> RunLayout:
    """Lay runs with time stamps ``times`` (each from 0) out with ``gap_s`` between them."""
    durations = [float(tt[-1]) for tt in times]
    starts = np.concatenate([[0.0], np.cumsum([d + gap_s for d in durations])[:-1]])
    sizes = np.array([len(tt) for tt in times])
    run_of_sample = np.repeat(np.arange(len(times)), sizes)
    t_run = np.concatenate(times)
    t = np.round(t_run + starts[run_of_sample], 9)
    return RunLayout(sizes, starts, durations, run_of_sample, t_run, t)


@dataclass(frozen=True)
class ChannelDraws:
    """The extra channels of a set of units (runs or blocks of runs), drawn once each.

    Attributes
    ----------
    load, air, grass, motor0, warm : ndarray
        Per unit: carried mass (kg, balanced over the config's values), air temperature
        (deg C), grass height (m), winding temperature at the start (deg C) and its
        warming rate (K/s).
    ground : ndarray or None
        Per unit ground type (balanced), or None where the ground varies within a run.
    """

    load: np.ndarray
    air: np.ndarray
    grass: np.ndarray
    motor0: np.ndarray
    warm: np.ndarray
    ground: np.ndarray | None = None

    @classmethod
    def draw(cls, rng: np.random.Generator, config: Any, n: int, *, ground: bool) -> ChannelDraws:
        """Draw the channels of ``n`` units from ``config`` (ground too if ``ground``)."""
        ground_u = _balanced(rng, config.grounds, n) if ground else None
        load = _balanced(rng, config.loads_kg, n).astype(float)
        air = rng.uniform(*config.air_temp_range_c, n)
        grass = rng.uniform(*config.grass_height_range_m, n)
        motor0 = rng.uniform(*config.motor_temp_range_c, n)
        warm = rng.uniform(0.0, config.motor_warming_k_s, n)
        return cls(load, air, grass, motor0, warm, ground_u)

    def per_sample(
        self, unit: np.ndarray, t_run: np.ndarray, ground: np.ndarray | None = None
    ) -> dict[str, np.ndarray]:
        """The channels per sample (``unit`` per sample; ``ground`` if it varies)."""
        return {
            "load_kg": self.load[unit],
            "ground": self.ground[unit].astype(str) if ground is None else ground,
            "motor_temp": self.motor0[unit] + self.warm[unit] * t_run,
            "air_temp_c": self.air[unit],
            "grass_height_m": self.grass[unit],
        }

    def row(self, u: int) -> dict[str, Any]:
        """The channel columns of unit ``u``'s run record."""
        return {
            "load_kg": self.load[u],
            "ground": "varies" if self.ground is None else self.ground[u],
            "motor_temp_start": self.motor0[u],
            "air_temp_c": self.air[u],
            "grass_height_m": self.grass[u],
        }


def _balanced(rng: np.random.Generator, values: tuple, n: int) -> np.ndarray:
    """``n`` draws that use every value equally often (up to one), in random order."""
    return np.asarray(values, dtype=object)[rng.permutation(n) % len(values)]


def switch_on(
    effects: Iterable[str], faults: Iterable[str], params: Any, sensors: Any, gaits: Any = None
) -> tuple[tuple[str, ...], tuple[str, ...], Physics, Any]:
    """The effects and faults checked, the truth with the effects, the sensors with the faults.

    ``gaits``: the controller's :class:`~energy_planner.simulate.gaits.GaitSchedule` (None:
    the base robot's one gait).

    Raises
    ------
    ModelError
        Unknown effect or fault.
    """
    from energy_planner.simulate.effects import check_effects, check_faults

    names, fault_names = check_effects(effects), check_faults(faults)
    physics = Physics(params, names, gaits=gaits)
    return names, fault_names, physics, sensors.with_faults(fault_names)


def sensor_offsets(rng: np.random.Generator, sens: Any, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Per run: a standard normal draw of the slip, and the IMU's (roll, pitch) bias, rad."""
    slip_raw = rng.standard_normal(n)
    bias = np.radians(sens.imu_bias_deg) * rng.standard_normal((n, 2))
    return slip_raw, bias


@dataclass
class TruthStreams:
    """True motion of consecutive runs (concatenated, each run's samples together)."""

    run: np.ndarray
    t: np.ndarray  # campaign clock
    t_run: np.ndarray  # time since the run (gait) started
    alpha: np.ndarray
    psi: np.ndarray
    gamma: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    wz: np.ndarray
    ax: np.ndarray
    ay: np.ndarray
    pos: np.ndarray
    yaw: np.ndarray
    channels: dict[str, np.ndarray]


def logs_from_truth(
    tr: TruthStreams,
    physics: Physics,
    sens: Any,
    bat: Any,
    dt: float,
    sizes: np.ndarray,
    slip: np.ndarray,
    bias: np.ndarray,
    noise_rng: np.random.Generator,
    grounds: list[str],
) -> dict[str, Any]:
    """Truth power, battery and sensors for runs laid out one after another.

    ``sizes`` are the sample counts of the runs in log order, ``slip`` and ``bias``
    (roll, pitch; rad) per sample (constant per run).

    Returns
    -------
    dict
        ``logs`` and ``true_samples`` (DataFrames) and, per run, ``energy`` (J),
        ``pack``, ``soc_start`` and ``soc_end``.
    """
    features: dict[str, Any] = {
        "alpha": tr.alpha,
        "gamma": wrap(tr.gamma),
        "vx": tr.vx,
        "vy": tr.vy,
        "wz": tr.wz,
        "ax": tr.ax,
        "ay": tr.ay,
        "t_gait": tr.t_run,
        **tr.channels,
    }
    gait = None
    if physics.gaits is not None:  # the controller picks its gait and reports it
        gait = physics.gaits.gait_of(np.hypot(tr.vx, tr.vy), tr.alpha)
        features["gait"] = gait
    power = physics.power(features)
    expected = physics.expected_power(features)
    runs = run_slices(sizes)
    dis = discharge(power, bat, dt, runs)
    meas = _measure(tr, dis, sens, runs, slip, bias, noise_rng)
    ch = tr.channels
    logs = pd.DataFrame(
        {
            "run": tr.run,
            "t": tr.t,
            **meas,
            "x": tr.pos[:, 0],
            "y": tr.pos[:, 1],
            "yaw": tr.yaw,
            "load_kg": ch["load_kg"],
            "ground": pd.Categorical(ch["ground"], categories=grounds),
            "motor_temp": ch["motor_temp"],
            "air_temp_c": ch["air_temp_c"],
            "grass_height_m": ch["grass_height_m"],
        }
    )
    if gait is not None:
        logs["gait"] = pd.Categorical(gait, categories=list(physics.gaits.gaits))
    true_samples = pd.DataFrame(
        {
            "run": tr.run,
            "t": tr.t,
            "alpha": tr.alpha,
            "gamma": features["gamma"],
            "vx": tr.vx,
            "vy": tr.vy,
            "wz": tr.wz,
            "speed": np.hypot(tr.vx, tr.vy),
            "ax": tr.ax,
            "ay": tr.ay,
            "z": tr.pos[:, 2],
            "t_gait": tr.t_run,
            "power": power,
            "power_expected": expected,
            "voltage": dis.voltage,
            "current": dis.current,
            "soc": dis.soc,
        }
    )
    return {
        "logs": logs,
        "true_samples": true_samples,
        "energy": dis.energy,
        "pack": dis.pack,
        "soc_start": dis.soc_start,
        "soc_end": dis.soc_end,
    }


def _measure(
    tr: TruthStreams,
    dis: Discharge,
    sens: Any,
    runs: list[slice],
    slip: np.ndarray,
    bias: np.ndarray,
    noise_rng: np.random.Generator,
) -> dict[str, np.ndarray]:
    """What the sensors log: IMU quaternion, odometry twist, battery voltage and current."""
    n = len(tr.t)
    g = 1.0 - np.clip(slip, -0.5, 0.5)
    meas_vx = tr.vx * g + sens.twist_noise_v * noise_rng.standard_normal(n)
    meas_vy = tr.vy * g + sens.twist_noise_v * noise_rng.standard_normal(n)
    meas_wz = tr.wz * g + sens.twist_noise_w * noise_rng.standard_normal(n)
    spikes = noise_rng.random(n) < sens.spike_prob
    spike_size = noise_rng.uniform(0.5, 1.5, n) * np.where(noise_rng.random(n) < 0.5, -1, 1)
    cur_src, volt_src = dis.current, dis.voltage
    if sens.battery_clock_offset_s > 0:  # the battery stream lags: shows older values
        cur_src, volt_src = np.empty(n), np.empty(n)
        for sl in runs:
            tt = tr.t[sl]
            cur_src[sl] = np.interp(tt - sens.battery_clock_offset_s, tt, dis.current[sl])
            volt_src[sl] = np.interp(tt - sens.battery_clock_offset_s, tt, dis.voltage[sl])
    meas_current = (
        cur_src
        + sens.current_noise_a * noise_rng.standard_normal(n)
        + np.where(spikes, sens.spike_current_a * spike_size, 0.0)
    )
    if sens.ros_current_sign:
        meas_current = -meas_current
    meas_voltage = volt_src + sens.voltage_noise_v * noise_rng.standard_normal(n)
    q = imu_quaternion(tr.alpha, tr.psi, tr.gamma)
    rotvec = np.zeros((n, 3))
    rotvec[:, :2] = bias
    rotvec += np.radians(sens.imu_noise_deg) * noise_rng.standard_normal((n, 3))
    if np.any(rotvec):  # a misaligned, noisy IMU: R_measured = R_true R_error
        q = quat_mul(q, quat_from_rotvec(rotvec))
        q = np.where(q[:, :1] < 0, -q, q)
    return {
        "qw": q[:, 0],
        "qx": q[:, 1],
        "qy": q[:, 2],
        "qz": q[:, 3],
        "vx": meas_vx,
        "vy": meas_vy,
        "wz": meas_wz,
        "voltage": meas_voltage,
        "current": meas_current,
    }


#: What a simulator says of a run, ahead of what :func:`run_record` derives.
RUN_FIELDS = (
    "run",
    "kind",
    "motion",
    "slope_deg",
    "uphill_azimuth_deg",
    "heading_deg",
    "speed",
    "yaw_rate",
    "composite",
    "part",
    "distance_m",
    "turn_deg",
    "repeat",
)


def run_record(
    run: Mapping[str, Any],
    k: int,
    lay: RunLayout,
    out: Mapping[str, Any],
    channels: Mapping[str, Any],
    slip: float,
    bias: np.ndarray,
    pos: np.ndarray,
    end_yaw: float,
    end_heading: float,
) -> dict[str, Any]:
    """One row of ``Campaign.runs``: the ``k``-th run in log order.

    Parameters
    ----------
    run : mapping
        The simulator's description of the run (:data:`RUN_FIELDS` and any more), in
        the order of the record's columns; the duration follows ``yaw_rate``, the true
        energy and mean power follow ``part``.
    k : int
        Position of the run in log order.
    lay : RunLayout
        Where the runs lie on the campaign clock.
    out : mapping
        :func:`logs_from_truth`'s result (energy and battery state per run).
    channels : mapping
        :meth:`ChannelDraws.row` of the run.
    slip : float
        Odometry slip of the run, 1.
    bias : ndarray
        IMU (roll, pitch) bias, rad.
    pos : ndarray
        True positions of the run (rows x, y, z).
    end_yaw, end_heading : float
        Yaw and relative heading gamma at the end, rad.
    """
    missing = [f for f in RUN_FIELDS if f not in run]
    if missing:  # pragma: no cover - a simulator's bug
        raise KeyError(f"run description lacks {missing}")
    dur = lay.durations[k]
    energy = out["energy"][k]
    derived = {
        "yaw_rate": {"duration_s": dur},
        "part": {"true_energy_j": energy, "true_mean_power_w": energy / dur},
    }
    rec: dict[str, Any] = {}
    for key, value in run.items():  # the description's order, with what follows from it
        rec[key] = value
        rec.update(derived.get(key, {}))
    return {
        **rec,
        "order": k,
        "t_start": lay.starts[k],
        "n_samples": int(lay.sizes[k]),
        **channels,
        "slip": slip,
        "imu_roll_bias_deg": math.degrees(bias[0]),
        "imu_pitch_bias_deg": math.degrees(bias[1]),
        "battery_pack": out["pack"][k],
        "soc_start": out["soc_start"][k],
        "soc_end": out["soc_end"][k],
        "start_x": pos[0, 0],
        "start_y": pos[0, 1],
        "end_x": pos[-1, 0],
        "end_y": pos[-1, 1],
        "end_yaw_deg": math.degrees(end_yaw),
        "end_heading_deg": math.degrees(end_heading),
    }
