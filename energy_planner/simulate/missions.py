"""Mission logs: a robot following smooth paths over a DEM, in the canonical log format.

Each mission is one run: the robot follows a smooth random path (a Catmull-Rom spline
through random waypoints inside the map; no planning), so slope and heading change
continuously. It walks in phases of constant commanded speed (drawn from
``MissionConfig.speeds``), stops now and then, and at a stop may turn in place to walk
the next phase sideways or backward; speed changes are ramped (moving average over
``ramp_s``), so it accelerates and turns while walking. The same physics, effects,
battery and sensors as :func:`~energy_planner.simulate.simulate_campaign` apply; the
``ground`` channel varies along the path (patches of a categorical ground map), the
other channels per mission. Besides the designed campaign's columns, the logs hold the
pose's altitude ``z`` (m, the DEM under the robot, as exact as ``x, y``): a robot on a
mission localizes on the map, and the IMU's tilt against the body can be checked
against it (``imu_tilt`` in :mod:`energy_planner.measurements.datacheck`).

Examples
--------
>>> camp = simulate_missions(seed=0, config=MissionConfig.small())
>>> camp.runs["kind"].unique().tolist(), len(camp.runs)
(['mission'], 2)
>>> bool(camp.true_samples["alpha"].std() > 0.01)
True
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from energy_planner.errors import LogIOError
from energy_planner.simulate.campaign import Campaign
from energy_planner.simulate.config import (
    BatteryConfig,
    MissionEvent,
    Rule,
    SensorConfig,
    check_fields,
    in_range,
    low_high,
    positive_int,
    shared_rules,
)
from energy_planner.simulate.kinematics import wrap
from energy_planner.simulate.physics import GROUNDS, RobotParams
from energy_planner.simulate.records import (
    ChannelDraws,
    TruthStreams,
    lay_out,
    logs_from_truth,
    run_record,
    sensor_offsets,
    switch_on,
)

__all__ = ["MissionConfig", "GroundMap", "simulate_missions", "synthetic_dem", "ground_map"]


@dataclass(frozen=True)
class MissionConfig:
    """What a set of simulated missions contains.

    Attributes
    ----------
    missions : int
        Number of missions (one run each).
    duration_s : float
        Length of each mission, s.
    speeds : tuple of float
        Commanded walking speeds, m/s (one drawn per phase).
    phase_s : tuple of float
        Range of the length of a walking phase, s.
    stop_prob : float
        Probability that a phase is followed by a stop, 1.
    stop_s : float
        Length of a stop (longer when the robot turns in place), s.
    sideways_prob, backward_prob : float
        Probability that a phase after a stop is walked sideways / backward, 1.
    yaw_rate : float
        Yaw rate of turns in place, rad/s.
    ramp_s : float
        Speed ramps, s.
    rate_hz : float
        Sample rate, Hz.
    gap_s : float
        Pause between missions on the campaign clock, s.
    waypoint_spacing_m : float
        Typical distance between the path's random waypoints, m.
    grounds, loads_kg, air_temp_range_c, motor_temp_range_c, motor_warming_k_s,
    grass_height_range_m
        Channels, as in :class:`~energy_planner.simulate.CampaignConfig` (``ground``
        varies along the path).
    sensors : SensorConfig
    battery : BatteryConfig
    events : tuple of MissionEvent
        Changes partway along every mission (a payload picked up, ground turning to
        mud, a stretch where the DEM is wrong by a known bias); see
        :class:`~energy_planner.simulate.config.MissionEvent`. A ``payload`` event
        switches on the ``load`` effect and a ``mud`` event the ``ground`` effect (the
        missions' drawn loads and ground patches then count too: give ``loads_kg=(0.0,)``
        and ``grounds=("asphalt",)`` for a baseline without them).
    gaits : GaitSchedule or None
        The controller's gaits across speeds, logged as the channel ``gait``, as in
        :class:`~energy_planner.simulate.CampaignConfig` (None: the base robot's one gait).
    """

    missions: int = 8
    duration_s: float = 240.0
    speeds: tuple[float, ...] = (0.2, 0.3, 0.45)
    phase_s: tuple[float, float] = (8.0, 25.0)
    stop_prob: float = 0.3
    stop_s: float = 3.0
    sideways_prob: float = 0.15
    backward_prob: float = 0.1
    yaw_rate: float = 0.5
    ramp_s: float = 1.0
    rate_hz: float = 50.0
    gap_s: float = 10.0
    waypoint_spacing_m: float = 6.0
    grounds: tuple[str, ...] = ("meadow", "gravel", "mud", "asphalt")
    loads_kg: tuple[float, ...] = (0.0, 5.0, 10.0, 15.0)
    air_temp_range_c: tuple[float, float] = (-5.0, 30.0)
    motor_temp_range_c: tuple[float, float] = (25.0, 75.0)
    motor_warming_k_s: float = 0.02
    grass_height_range_m: tuple[float, float] = (0.0, 0.4)
    sensors: SensorConfig = field(default_factory=SensorConfig)
    battery: BatteryConfig = field(default_factory=BatteryConfig)
    events: tuple[MissionEvent, ...] = ()
    gaits: Any = None

    def __post_init__(self) -> None:
        check_fields(self, _mission_rules())

    @property
    def dt(self) -> float:
        """Sample period, s."""
        return 1.0 / self.rate_hz

    @classmethod
    def small(cls, **overrides: Any) -> MissionConfig:
        """Two 60 s missions at 20 Hz (for tests)."""
        base: dict[str, Any] = dict(missions=2, duration_s=60.0, rate_hz=20.0)
        base.update(overrides)
        return cls(**base)

    @classmethod
    def varied(cls, **overrides: Any) -> MissionConfig:
        """An hour of missions that walk every gait direction often (for discovery).

        60 missions of 60 s at 20 Hz, phases of 5-12 s, a stop after half of them, and
        after a stop a sideways phase with probability 0.25 and a backward one with 0.2.
        The base model has terms for walking backward and sideways up and down slopes;
        with the default phases (one stop in three, sideways 0.15, backward 0.1) an hour
        of one-minute missions walked backward downhill in 2 runs (seed 2), and the fit
        that held them out predicted 0 W there (base model at 4.4x the noise floor on
        logs with no hidden effect; 0.66x with these). The runs are the units of
        ``discover``'s test by run, hence many short missions.

        >>> c = MissionConfig.varied()
        >>> c.missions * c.duration_s / 3600, c.backward_prob
        (1.0, 0.2)
        """
        base: dict[str, Any] = dict(
            missions=60,
            duration_s=60.0,
            rate_hz=20.0,
            phase_s=(5.0, 12.0),
            stop_prob=0.5,
            sideways_prob=0.25,
            backward_prob=0.2,
        )
        base.update(overrides)
        return cls(**base)

    @classmethod
    def across_speeds(cls, **overrides: Any) -> MissionConfig:
        """Missions whose phases walk at 8 speeds from 0.15 to 1.2 m/s, walking and trotting.

        >>> MissionConfig.across_speeds().gaits.trot_speed
        0.5
        """
        from energy_planner.simulate.config import speed_grid
        from energy_planner.simulate.gaits import GaitSchedule

        base: dict[str, Any] = dict(speeds=speed_grid(0.15, 1.2), gaits=GaitSchedule())
        base.update(overrides)
        return cls(**base)

    def replace(self, **changes: Any) -> MissionConfig:
        """A copy with some parameters changed."""
        return dataclasses.replace(self, **changes)


def _mission_rules() -> dict[str, Rule]:
    """Rules of :class:`MissionConfig`'s fields (its own and those shared with the campaign)."""
    probability = in_range(0, 1)
    return {
        "missions": (positive_int, "an integer >= 1"),
        "duration_s": (in_range(10), "a duration >= 10 s"),
        "phase_s": (
            lambda v, c=None: low_high(0)(v) and v[0] > 0,
            "(low, high) with 0 < low <= high, s",
        ),
        "stop_prob": (probability, "a probability in [0, 1]"),
        "sideways_prob": (probability, "a probability in [0, 1]"),
        "backward_prob": (
            lambda v, c: probability(v) and c.sideways_prob + v <= 1,
            "a probability in [0, 1 - sideways_prob = {c.sideways_prob}]",
        ),
        "stop_s": (in_range(0), "a stop length >= 0 s"),
        "waypoint_spacing_m": (in_range(0, lo_open=True), "a spacing > 0 m"),
        "events": (
            lambda v, c=None: all(isinstance(e, MissionEvent) for e in v),
            "a tuple of MissionEvent",
        ),
        **shared_rules(),
    }


def _smooth_noise(
    rng: np.random.Generator, shape: tuple[int, int], scale_cells: float
) -> np.ndarray:
    """Smooth random field (Gaussian-filtered white noise), zero mean, unit std."""
    from scipy.ndimage import gaussian_filter

    z = gaussian_filter(rng.standard_normal(shape), scale_cells, mode="reflect")
    return (z - z.mean()) / (z.std() or 1.0)


def synthetic_dem(
    seed: int = 0, size_m: float = 300.0, resolution: float = 2.0, max_slope_deg: float = 25.0
) -> Any:
    """Rolling hills: a smooth random surface.

    It is scaled so its steepest slope is ``max_slope_deg``.

    >>> t = synthetic_dem(seed=1, size_m=100.0)
    >>> bool(abs(float(np.degrees(np.nanmax(t.slope))) - 25.0) < 2.0)
    True
    """
    from energy_planner.terrain import Terrain

    n = max(8, int(round(size_m / resolution)))
    rng = np.random.default_rng(seed)
    z = _smooth_noise(rng, (n, n), 40.0 / resolution)
    gy, gx = np.gradient(z, resolution)
    steep = float(np.nanmax(np.hypot(gx, gy)))
    z *= math.tan(math.radians(max_slope_deg)) / steep
    t = Terrain.from_array(z, resolution=resolution)
    s = float(np.nanmax(t.slope))
    return Terrain.from_array(
        z * math.tan(math.radians(max_slope_deg)) / math.tan(s), resolution=resolution
    )


@dataclass(frozen=True)
class GroundMap:
    """A categorical ground map on a terrain's grid (patches of ground types).

    Attributes
    ----------
    codes : ndarray of int16
        ``codes[row, col]`` in ``1 .. len(names)`` (raster order, as the terrain).
    names : tuple of str
        Ground type of code ``k`` is ``names[k - 1]``.
    terrain : Terrain
        The grid the map lies on.
    """

    codes: np.ndarray
    names: tuple[str, ...]
    terrain: Any

    def sample(self, x: Any, y: Any) -> np.ndarray:
        """Ground type at points (nearest cell; points outside take the edge cell)."""
        x_min, _, _, y_max = self.terrain.bounds
        res_x, res_y = (abs(r) for r in self.terrain.resolution)
        x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
        c = np.clip(np.floor((x - x_min) / res_x).astype(int), 0, self.codes.shape[1] - 1)
        r = np.clip(np.floor((y_max - y) / res_y).astype(int), 0, self.codes.shape[0] - 1)
        return np.asarray(self.names, dtype=object)[self.codes[r, c] - 1]

    def write(self, raster: str | Path, table: str | Path) -> tuple[Path, Path]:
        """Write the codes as a GeoTIFF on the terrain's grid and the table ``code,ground``.

        For ``--channel ground=RASTER:TABLE``.
        """
        import rasterio

        from energy_planner.io import write_geotiff, write_text

        raster, table = Path(raster), Path(table)
        try:
            write_geotiff(
                raster, self.codes, transform=self.terrain.transform, crs=self.terrain.crs,
                dtype="int16", nodata=0, names=["ground"],
                descriptions=["ground class code (0 = none); names in the code,ground table"],
            )  # fmt: skip
            write_text(
                table,
                "code,ground\n"
                + "".join(f"{k},{name}\n" for k, name in enumerate(self.names, start=1)),
            )
        except (OSError, rasterio.errors.RasterioError) as exc:
            raise LogIOError(
                f"cannot write the ground map to {str(raster)!r} / {str(table)!r}: {exc}"
            ) from exc
        return raster, table


def ground_map(
    terrain: Any, grounds: tuple[str, ...] = tuple(GROUNDS), seed: int = 0, patch_m: float = 25.0
) -> GroundMap:
    """Patches of ground types on the terrain's grid, about equally common.

    >>> gm = ground_map(synthetic_dem(seed=1, size_m=60.0), ("meadow", "mud"), seed=2)
    >>> set(gm.sample([5.0, 30.0, 55.0], [5.0, 30.0, 55.0])) <= {"meadow", "mud"}
    True
    >>> sorted(np.unique(gm.codes).tolist())
    [1, 2]
    """
    rng = np.random.default_rng(seed)
    res = abs(terrain.resolution[0])
    z = _smooth_noise(rng, terrain.shape, patch_m / res)
    qs = np.quantile(z, np.linspace(0, 1, len(grounds) + 1)[1:-1])
    return GroundMap((np.digitize(z, qs) + 1).astype(np.int16), tuple(grounds), terrain)


def _catmull_rom(p: np.ndarray, per_seg: int = 40) -> np.ndarray:
    """Dense points of a centripetal-free (uniform) Catmull-Rom spline through ``p``."""
    p = np.vstack([2 * p[0] - p[1], p, 2 * p[-1] - p[-2]])
    u = np.linspace(0, 1, per_seg, endpoint=False)[:, None]
    out = []
    for i in range(1, len(p) - 2):
        p0, p1, p2, p3 = p[i - 1], p[i], p[i + 1], p[i + 2]
        out.append(
            0.5
            * (
                (2 * p1)
                + (-p0 + p2) * u
                + (2 * p0 - 5 * p1 + 4 * p2 - p3) * u**2
                + (-p0 + 3 * p1 - 3 * p2 + p3) * u**3
            )
        )
    out.append(p[-2][None, :])
    return np.vstack(out)


def _mission_track(rng: np.random.Generator, terrain: Any, cfg: MissionConfig) -> dict:
    """Commanded phases, the path and the sampled true motion of one mission."""
    dt = cfg.dt
    n = int(round(cfg.duration_s / dt)) + 1
    t = np.arange(n) * dt
    # ---- phases: commanded speed and body yaw offset from the path tangent
    v_cmd = np.zeros(n)
    off_cmd = np.zeros(n)
    k, offset = 0, 0.0
    first = True
    while k < n:
        if not first and rng.random() < cfg.stop_prob:
            r = rng.random()
            new = (
                0.0
                if r >= cfg.sideways_prob + cfg.backward_prob
                else (math.pi if r < cfg.backward_prob else rng.choice([-1, 1]) * math.pi / 2)
            )
            turn = abs(math.remainder(new - offset, 2 * math.pi))
            m = int(round((cfg.stop_s + turn / cfg.yaw_rate) / dt))
            # turn in place at the yaw rate in the middle of the stop
            ramp = np.clip(
                (np.arange(m) * dt - cfg.stop_s / 2) * cfg.yaw_rate / max(turn, 1e-12), 0, 1
            )
            d = math.remainder(new - offset, 2 * math.pi)
            off_cmd[k : k + m] = (offset + ramp * d)[: max(0, min(m, n - k))]
            v_cmd[k : k + m] = 0.0
            k += m
            offset = offset + d
        first = False
        m = int(round(rng.uniform(*cfg.phase_s) / dt))
        v_cmd[k : k + m] = rng.choice(cfg.speeds)
        off_cmd[k : k + m] = offset
        k += m
    v_cmd[-max(1, int(round(cfg.ramp_s / dt))) :] = 0.0  # end at rest
    r = int(round(cfg.ramp_s / dt))
    if r > 0:
        kern = np.ones(r) / r
        v = np.convolve(np.r_[np.zeros(r), v_cmd], kern, mode="full")[r : r + n]
    else:
        v = v_cmd.copy()
    # ---- the path: random waypoints within the map, a smooth spline
    x_min, y_min, x_max, y_max = terrain.bounds
    margin = 0.15 * min(x_max - x_min, y_max - y_min)
    total = float(np.sum(v) * dt) * 1.2 + 10.0
    n_wp = max(3, int(total / cfg.waypoint_spacing_m) + 2)
    wp = [
        np.array(
            [
                rng.uniform(x_min + margin, x_max - margin),
                rng.uniform(y_min + margin, y_max - margin),
            ]
        )
    ]
    heading = rng.uniform(-math.pi, math.pi)
    for _ in range(n_wp - 1):
        for _try in range(20):
            h = heading + rng.normal(0.0, 0.6)
            step = cfg.waypoint_spacing_m * rng.uniform(0.7, 1.3)
            q = wp[-1] + step * np.array([math.cos(h), math.sin(h)])
            inside_x = x_min + margin <= q[0] <= x_max - margin
            if inside_x and y_min + margin <= q[1] <= y_max - margin:
                break
            heading += math.pi / 3  # steer away from the edge
        else:
            q = wp[-1]
        heading = h
        wp.append(q)
    dense = _catmull_rom(np.array(wp))
    seg = np.hypot(*np.diff(dense, axis=0).T)
    s_h = np.concatenate([[0.0], np.cumsum(seg)])
    keep = np.concatenate([[True], seg > 1e-9])
    dense, s_h = dense[keep], s_h[keep]
    smp = terrain.sample(dense[:, 0], dense[:, 1])
    tang = np.gradient(dense, s_h, axis=0)
    tang /= np.linalg.norm(tang, axis=1)[:, None]
    grade_along = np.asarray(smp.dzdx) * tang[:, 0] + np.asarray(smp.dzdy) * tang[:, 1]
    # horizontal progress: the speed is along the surface
    pos_h = np.zeros(n)
    for i in range(1, n):
        ga = np.interp(pos_h[i - 1], s_h, grade_along)
        pos_h[i] = pos_h[i - 1] + 0.5 * (v[i] + v[i - 1]) * dt / math.sqrt(1 + ga * ga)
    pos_h = np.minimum(pos_h, s_h[-1])
    x = np.interp(pos_h, s_h, dense[:, 0])
    y = np.interp(pos_h, s_h, dense[:, 1])
    tx = np.interp(pos_h, s_h, tang[:, 0])
    ty = np.interp(pos_h, s_h, tang[:, 1])
    theta = np.unwrap(np.arctan2(ty, tx)) + off_cmd
    return {"t": t, "x": x, "y": y, "theta": theta}


def _dem_bias(tr: dict, events: Iterable[MissionEvent]) -> np.ndarray:
    """Per sample, the true ground's gradient minus the DEM's (``dem_bias`` events).

    Over an event's stretch the true ground climbs ``tan(slope_bias_deg)`` more per metre
    along the path's heading at the stretch's start.
    """
    t = tr["t"]
    frac = t / t[-1] if t[-1] > 0 else np.zeros_like(t)
    bias = np.zeros((t.size, 2))
    for ev in events:
        if ev.kind != "dem_bias":
            continue
        on = ev.active(frac)
        if not on.any():
            continue
        i0 = int(np.flatnonzero(on)[0])
        i1 = min(i0 + 5, t.size - 1)
        h = math.atan2(tr["y"][i1] - tr["y"][i0], tr["x"][i1] - tr["x"][i0])
        g = math.tan(math.radians(ev.slope_bias_deg))
        bias[on] += g * np.array([math.cos(h), math.sin(h)])
    return bias


def _body_motion(
    terrain: Any, tr: dict, dt: float, grad_bias: np.ndarray | None = None
) -> dict[str, np.ndarray]:
    """Slope, heading, body twist and accelerations of a sampled track.

    ``grad_bias`` (per sample, ``(n, 2)``) is added to the DEM's gradient: the true
    ground where the DEM is wrong; the altitude follows it (its integral along the track).
    """
    x, y, theta = tr["x"], tr["y"], tr["theta"]
    smp = terrain.sample(x, y)
    gx, gy = np.asarray(smp.dzdx, float), np.asarray(smp.dzdy, float)
    z = np.asarray(smp.elevation, float)
    if grad_bias is not None and np.any(grad_bias):
        gx, gy = gx + grad_bias[:, 0], gy + grad_bias[:, 1]
        dz = grad_bias[1:, 0] * np.diff(x) + grad_bias[1:, 1] * np.diff(y)
        z = z + np.concatenate([[0.0], np.cumsum(dz)])
    g2 = gx * gx + gy * gy
    alpha = np.arctan(np.sqrt(g2))
    psi = np.arctan2(gy, gx)
    gh = theta - psi
    gamma = np.arctan2(np.sin(gh) * np.cos(alpha), np.cos(gh))
    c, s = np.cos(theta), np.sin(theta)
    bx = np.stack([c, s, gx * c + gy * s], axis=1)
    bx /= np.linalg.norm(bx, axis=1)[:, None]
    bz = np.stack([-gx, -gy, np.ones_like(gx)], axis=1) / np.sqrt(1 + g2)[:, None]
    by = np.cross(bz, bx)
    pos = np.stack([x, y, z], axis=1)
    vel = np.gradient(pos, dt, axis=0)
    vx = np.sum(vel * bx, axis=1)
    vy = np.sum(vel * by, axis=1)
    R = np.stack([bx, by, bz], axis=2)  # columns: body axes in the world
    rel = np.einsum("nji,njk->nik", R[:-1], R[1:])  # R_k^T R_{k+1}
    w = (rel[:, 1, 0] - rel[:, 0, 1]) / (2 * dt)
    wz = (
        np.concatenate([[w[0]], 0.5 * (w[1:] + w[:-1]), [w[-1]]])
        if len(w) > 1
        else np.zeros(len(x))
    )
    ax = np.gradient(vx, dt)
    ay = np.gradient(vy, dt)
    return {
        "alpha": alpha,
        "psi": psi,
        "gamma": gamma,
        "vx": vx,
        "vy": vy,
        "wz": wz,
        "ax": ax,
        "ay": ay,
        "pos": pos,
        "yaw": wrap(theta),
    }


def simulate_missions(
    seed: int = 0,
    effects: Iterable[str] = (),
    config: MissionConfig | None = None,
    *,
    terrain: Any = None,
    faults: Iterable[str] = (),
    params: RobotParams | None = None,
    progress: bool = False,
) -> Campaign:
    """Simulate mission logs over a DEM.

    Parameters
    ----------
    seed : int
        Random seed (paths, phases, channels and sensors; the same with and without
        an effect).
    effects, faults : iterable of str
        As for :func:`~energy_planner.simulate.simulate_campaign`.
    config : MissionConfig, optional
        Mission parameters (default :class:`MissionConfig`).
    terrain : Terrain, optional
        The map (default :func:`synthetic_dem` with this seed); e.g.
        ``load_dem("maps/hill.tif")``.
    params : RobotParams, optional
        Robot parameters of the truth.
    progress : bool
        Progress bar on stderr.

    Returns
    -------
    Campaign
        ``runs`` has one row per mission (kind ``mission``); ``config`` is the
        :class:`MissionConfig`.
    """
    from energy_planner.progress import track

    cfg = config or MissionConfig()
    kinds = {e.kind for e in cfg.events}
    effects = (
        tuple(effects)
        + (("load",) if "payload" in kinds else ())
        + (("ground",) if "mud" in kinds else ())
    )
    names, fault_names, physics, sens = switch_on(effects, faults, params, cfg.sensors, cfg.gaits)
    if terrain is None:
        terrain = synthetic_dem(seed)
    path_rng, channel_rng, noise_rng = np.random.default_rng(seed).spawn(3)
    grounds = ground_map(terrain, cfg.grounds, seed=seed)

    tracks, motions = [], []
    for _ in track(range(cfg.missions), "simulating missions", progress, unit="mission"):
        tracks.append(_mission_track(path_rng, terrain, cfg))
        motions.append(_body_motion(terrain, tracks[-1], cfg.dt, _dem_bias(tracks[-1], cfg.events)))
    draws = ChannelDraws.draw(channel_rng, cfg, cfg.missions, ground=False)
    slip_raw, bias = sensor_offsets(noise_rng, sens, cfg.missions)
    slip = sens.slip_mean + sens.slip_std * slip_raw

    lay = lay_out([tr["t"] for tr in tracks], cfg.gap_s)
    idx = lay.run_of_sample
    mo = {key: np.concatenate([m[key] for m in motions]) for key in motions[0]}
    pos = mo["pos"]
    run_ids = np.array([f"mission_{i:03d}" for i in range(cfg.missions)], dtype=object)
    channels = draws.per_sample(idx, lay.t_run, grounds.sample(pos[:, 0], pos[:, 1]).astype(str))
    categories = _apply_events(cfg, channels, lay.t_run, idx, [tr["t"][-1] for tr in tracks])
    truth = TruthStreams(
        run_ids[idx], lay.t, lay.t_run, mo["alpha"], mo["psi"], mo["gamma"], mo["vx"],
        mo["vy"], mo["wz"], mo["ax"], mo["ay"], pos, mo["yaw"], channels,
    )  # fmt: skip
    slip_s = slip[idx] + sens.slip_per_sin_slope * np.sin(mo["alpha"])
    out = logs_from_truth(
        truth, physics, sens, cfg.battery, cfg.dt, lay.sizes, slip_s, bias[idx], noise_rng,
        categories,
    )  # fmt: skip
    # the pose has an altitude: a map-referenced localization (x, y as logged already)
    out["logs"].insert(out["logs"].columns.get_loc("y") + 1, "z", pos[:, 2])
    rows = [
        run_record(
            _mission_description(run_ids[i], m, cfg.dt),
            i,
            lay,
            out,
            draws.row(i),
            slip[i],
            bias[i],
            m["pos"],
            m["yaw"][-1],
            m["gamma"][-1],
        )  # fmt: skip
        for i, m in enumerate(motions)
    ]
    return Campaign(
        out["logs"], pd.DataFrame(rows), physics, names, out["true_samples"], seed, cfg,
        fault_names, grounds,
    )  # fmt: skip


def _apply_events(
    cfg: MissionConfig,
    channels: dict[str, np.ndarray],
    t_run: np.ndarray,
    idx: np.ndarray,
    durations: list[float],
) -> list[str]:
    """Change the channels where ``payload`` and ``mud`` events are on; the ground names."""
    frac = t_run / np.maximum(np.asarray(durations, dtype=float)[idx], 1e-12)
    grounds = list(cfg.grounds)
    for ev in cfg.events:
        on = ev.active(frac)
        if ev.kind == "payload":
            channels["load_kg"] = np.where(on, channels["load_kg"] + ev.load_kg,
                                           channels["load_kg"])  # fmt: skip
        elif ev.kind == "mud":
            channels["ground"] = np.where(on, "mud", channels["ground"].astype(object)).astype(str)
            if "mud" not in grounds:
                grounds.append("mud")
    return grounds


def _mission_description(run: str, mo: dict[str, np.ndarray], dt: float) -> dict[str, Any]:
    """What a mission's run record says of its motion (:data:`~.records.RUN_FIELDS`)."""
    speed = np.hypot(mo["vx"], mo["vy"])
    return {
        "run": run,
        "kind": "mission",
        "motion": "mission",
        "slope_deg": float(np.degrees(np.mean(mo["alpha"]))),
        "max_slope_deg": float(np.degrees(np.max(mo["alpha"]))),
        "uphill_azimuth_deg": float("nan"),
        "heading_deg": float(np.degrees(mo["gamma"][0])),
        "speed": float(np.mean(speed[speed > 0.05])) if np.any(speed > 0.05) else 0.0,
        "yaw_rate": float(np.mean(np.abs(mo["wz"]))),
        "composite": "",
        "part": "",
        "distance_m": float(np.sum(0.5 * (speed[1:] + speed[:-1])) * dt),
        "turn_deg": float(np.degrees(mo["yaw"][-1] - mo["yaw"][0])),
        "repeat": 0,
    }
