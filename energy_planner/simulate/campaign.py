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
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from energy_planner.errors import LogError, LogIOError, RemovedAPIError
from energy_planner.simulate.battery import battery_current
from energy_planner.simulate.config import CampaignConfig
from energy_planner.simulate.design import RunSpec, plan_runs
from energy_planner.simulate.effects import check_effects, check_faults
from energy_planner.simulate.kinematics import integrate_pose, twist_profile, wrap
from energy_planner.simulate.physics import Physics, RobotParams
from energy_planner.simulate.records import (
    ChannelDraws,
    TruthStreams,
    lay_out,
    logs_from_truth,
    run_record,
    sensor_offsets,
)

__all__ = [
    "Campaign",
    "NoiseFloor",
    "simulate_campaign",
    "LOG_COLUMNS",
    "CHANNELS",
    "battery_current",
]

#: Canonical log columns written by the simulator, in order.
LOG_COLUMNS = (
    "run",
    "t",
    "qw",
    "qx",
    "qy",
    "qz",
    "vx",
    "vy",
    "wz",
    "voltage",
    "current",
    "x",
    "y",
    "yaw",
)
#: Extra channels: carried mass (kg), surface (categorical), winding temperature (deg C,
#: warming during a run), air temperature (deg C), grass height (m). The model's catalog
#: reads none of them; each is logged in every campaign, its effect on or not.
CHANNELS = ("load_kg", "ground", "motor_temp", "air_temp_c", "grass_height_m")
#: Channels that are categorical.
CATEGORICAL = ("ground",)


@dataclass(frozen=True)
class NoiseFloor:
    """Noise floor of a campaign on a set of windows (:meth:`Campaign.noise_floor`).

    Attributes
    ----------
    rmse_w : float
        Root mean square over windows of (measured window power - true window power), W.
    bias_w : float
        Mean of that difference, W.
    n_windows : int
        Windows compared.
    reference : str
        ``expected`` (gait-cycle mean truth, the default) or ``instantaneous`` (with the
        ripple).
    per_window : DataFrame
        window, run, measured_w, true_w.
    """

    rmse_w: float
    bias_w: float
    n_windows: int
    reference: str
    per_window: pd.DataFrame

    def to_dict(self) -> dict[str, Any]:
        """Plain data for ``--json``."""
        return {
            "rmse_w": self.rmse_w,
            "bias_w": self.bias_w,
            "n_windows": self.n_windows,
            "reference": self.reference,
        }


@dataclass
class Campaign:
    """A simulated field campaign (or a set of mission logs).

    Attributes
    ----------
    logs : DataFrame
        Canonical log of all runs in campaign order (:data:`LOG_COLUMNS` plus
        :data:`CHANNELS`); ``ground`` is categorical.
    runs : DataFrame
        One row per run: run, kind, motion, slope_deg, uphill_azimuth_deg, heading_deg
        (gamma at the start), speed, yaw_rate, duration_s, composite, part,
        true_energy_j, and more (distance, channels, slip, IMU bias, battery state,
        start and end pose).
    physics : Physics
        The ground truth: robot parameters and the effects switched on.
    effects : tuple of str
        The effects switched on.
    true_samples : DataFrame
        The noise-free truth per log row: run, t, alpha, gamma (rad), true twist, ax,
        ay, z, t_gait (s since the run started), power (W, instantaneous, with the gait
        ripple), power_expected (W, gait-cycle mean: what a perfect model of the
        features predicts), true voltage, current and soc.
    seed : int
        Random seed.
    config : CampaignConfig
        The campaign parameters.
    faults : tuple of str
        Sensor faults switched on (:data:`energy_planner.simulate.FAULTS`).
    ground_map : GroundMap or None
        Missions: the map of ground types the ``ground`` channel was sampled from.
    """

    logs: pd.DataFrame
    runs: pd.DataFrame
    physics: Physics
    effects: tuple[str, ...]
    true_samples: pd.DataFrame
    seed: int = 0
    config: Any = field(default_factory=CampaignConfig)
    faults: tuple[str, ...] = ()
    ground_map: Any = None

    @property
    def truth(self) -> Any:
        """Removed: the truth is :attr:`physics`, not an EnergyModel.

        Raises
        ------
        RemovedAPIError
            Always, naming the replacements.
        """
        raise RemovedAPIError(
            "Campaign.truth was removed: the simulator's truth is mechanistic physics "
            "(Campaign.physics, a Physics object), not an EnergyModel. Per-sample true "
            "power: Campaign.true_samples['power'] / ['power_expected']; a path's true "
            "energy: energy_planner.simulate.true_path_energy(terrain, states, "
            "effects=campaign.effects)"
        )

    def write(
        self, out_dir: str | Path, fmt: str = "csv", bag: bool = False, progress: bool = False
    ) -> list[Path]:
        """Write the campaign to ``out_dir``.

        Files: ``<run>.csv`` (or ``.parquet``) per run, ``runs.csv``, ``physics.json``
        (robot parameters and effects of the truth), ``campaign.json`` (seed, effects,
        faults, parameters), for missions ``ground.tif`` and ``ground.csv`` (the ground map,
        for ``--channel ground=ground.tif:ground.csv``) and
        with ``bag=True`` one ROS 2 bag per run in ``bags/<run>/`` (written by
        :func:`energy_planner.measurements.write_rosbag`; current with the ROS sign).

        Parameters
        ----------
        out_dir : path
            Directory (created if missing).
        fmt : {"csv", "parquet"}
            Per-run log format.
        bag : bool
            Also write a ROS 2 bag (needs :func:`energy_planner.measurements.write_rosbag`).
        progress : bool
            Show a progress bar on stderr.

        Returns
        -------
        list of Path
            The files and directories written.

        Raises
        ------
        LogError
            Unknown ``fmt``.
        LogIOError
            ``out_dir`` cannot be created or written, or the bag writer is missing.
        """
        if fmt not in ("csv", "parquet"):
            raise LogError(f"unknown log format {fmt!r}; expected 'csv' or 'parquet'")
        out = Path(out_dir)
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise LogIOError(f"cannot create output directory {str(out)!r}: {exc}") from exc
        import pyarrow as pa
        import pyarrow.csv as pa_csv
        import pyarrow.parquet as pq
        from tqdm.auto import tqdm

        from energy_planner.io import atomic_path, write_json

        written: list[Path] = []
        logs = self.logs
        if fmt == "csv":
            logs = logs.assign(**{c: logs[c].astype(str) for c in CATEGORICAL})
        table = pa.Table.from_pandas(logs, preserve_index=False)
        run = logs["run"].to_numpy()
        starts = np.flatnonzero(np.r_[True, run[1:] != run[:-1]])
        ends = np.r_[starts[1:], len(run)]
        try:
            for s, e in tqdm(
                zip(starts, ends, strict=True),
                total=len(starts),
                desc="writing runs",
                disable=not progress,
                unit="run",
            ):
                path = out / f"{run[s]}.{fmt}"
                with atomic_path(path) as tmp:
                    if fmt == "csv":
                        pa_csv.write_csv(table.slice(s, e - s), tmp)
                    else:
                        pq.write_table(table.slice(s, e - s), tmp)
                written.append(path)
            runs_path = out / "runs.csv"
            with atomic_path(runs_path) as tmp:
                self.runs.to_csv(tmp, index=False, float_format="%.10g")
            truth_path = write_json(out / "physics.json", self.physics_dict())
            meta_path = write_json(out / "campaign.json", self.metadata())
        except OSError as exc:
            raise LogIOError(f"cannot write the campaign to {str(out)!r}: {exc}") from exc
        written += [runs_path, truth_path, meta_path]
        if self.ground_map is not None:
            written += list(self.ground_map.write(out / "ground.tif", out / "ground.csv"))
        if bag:
            written += self._write_bag(out / "bags", progress)
        return written

    def _write_bag(self, path: Path, progress: bool = False) -> list[Path]:
        try:
            from energy_planner.measurements import write_rosbag
        except ImportError as exc:  # pragma: no cover - the measurements module is present
            raise LogIOError(
                f"cannot write ROS 2 bags to {str(path)!r}: energy_planner.measurements does "
                "not provide write_rosbag; write CSV or Parquet instead"
            ) from exc
        from tqdm.auto import tqdm

        if path.exists() and any(path.iterdir()):
            raise LogIOError(
                f"bag folder {str(path)!r} already holds bags; remove it or choose another "
                "--out directory (bags are never overwritten)"
            )
        path.mkdir(parents=True, exist_ok=True)
        written: list[Path] = []
        groups = self.logs.groupby("run", sort=False, observed=True)
        for run, df in tqdm(
            groups, total=len(self.runs), desc="writing bags", disable=not progress, unit="bag"
        ):
            written += list(write_rosbag(df, path / str(run), version=2))
        return written

    def run_energies(self) -> pd.Series:
        """Measured energy per run, J: trapezoid integral of logged ``voltage * current``."""
        logs = self.logs
        p = (logs["voltage"] * logs["current"]).to_numpy()
        t = logs["t"].to_numpy()
        run = logs["run"].to_numpy()
        same = run[1:] == run[:-1]
        piece = np.where(same, (p[1:] + p[:-1]) * np.diff(t) / 2, 0.0)
        per_run = pd.Series(piece).groupby(run[1:], sort=False).sum()
        return per_run.reindex(self.runs["run"]).fillna(0.0).rename("energy_j")

    def cost_table(self) -> pd.DataFrame:
        """Force-equivalent cost (J/m) of the straight runs along the fall line.

        One row per straight run whose travel direction is straight uphill or downhill:
        slope_deg, direction (uphill/downhill), motion (forward/lateral), measured cost
        (logged energy / distance) and true cost (truth energy / distance).
        """
        r = self.runs[self.runs["kind"] == "straight"].copy()
        offset = r["motion"].map({"forward": 0.0, "backward": 180.0, "left": 90.0, "right": -90.0})
        travel = np.mod(r["heading_deg"] + offset, 360.0)
        r["direction"] = np.select(
            [np.isclose(travel, 0.0) | np.isclose(travel, 360.0), np.isclose(travel, 180.0)],
            ["uphill", "downhill"],
            "",
        )
        r = r[r["direction"] != ""]
        r["motion"] = np.where(r["motion"].isin(["left", "right"]), "lateral", r["motion"])
        measured = self.run_energies()
        return pd.DataFrame(
            {
                "run": r["run"],
                "slope_deg": r["slope_deg"],
                "direction": r["direction"],
                "motion": r["motion"],
                "speed": r["speed"],
                "measured_cost_n": measured.loc[r["run"]].to_numpy() / r["distance_m"],
                "true_cost_n": r["true_energy_j"] / r["distance_m"],
            }
        ).reset_index(drop=True)

    def plot(self, path: str | Path) -> Path:
        """PNG of the force-equivalent cost versus slope (as the paper's Fig. 4).

        Uphill (left) and downhill (right) straight runs along the fall line, forward and
        lateral: measured cost per run (points) and the truth (lines).
        """
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        table = self.cost_table()
        fig, axes = plt.subplots(1, 2, figsize=(9, 3.6), sharey=True, constrained_layout=True)
        colours = {"forward": "tab:red", "backward": "tab:orange", "lateral": "tab:blue"}
        for ax, direction in zip(axes, ("uphill", "downhill"), strict=True):
            sub = table[table["direction"] == direction]
            for motion, g in sub.groupby("motion"):
                c = colours.get(str(motion), "k")
                ax.scatter(
                    g["slope_deg"],
                    g["measured_cost_n"],
                    s=12,
                    alpha=0.6,
                    color=c,
                    label=f"{motion} (measured)",
                )
                truth = g.groupby("slope_deg")["true_cost_n"].mean()
                ax.plot(truth.index, truth.to_numpy(), color=c, lw=1.5, label=f"{motion} (truth)")
            ax.set_title(direction)
            ax.set_xlabel("slope alpha (deg)")
            ax.grid(alpha=0.3)
        axes[0].set_ylabel("force-equivalent cost (J/m = N)")
        axes[1].legend(fontsize=7)
        effects = ", ".join(self.effects) or "none"
        fig.suptitle(f"simulated campaign (seed {self.seed}, effects: {effects})", fontsize=9)
        path = Path(path)
        try:
            from energy_planner.io import save_figure

            save_figure(fig, path, dpi=120)
        except OSError as exc:
            raise LogIOError(f"cannot write the plot {str(path)!r}: {exc}") from exc
        finally:
            plt.close(fig)
        return path

    def physics_dict(self) -> dict[str, Any]:
        """The truth as plain data: effects and every robot parameter with its unit."""
        return {
            "generator": "energy_planner.simulate.physics",
            "effects": list(self.effects),
            "params": self.physics.params.table(),
        }

    def metadata(self) -> dict[str, Any]:
        """Seed, effects, faults, counts and every parameter, JSON-ready."""
        return {
            "generator": "energy_planner.simulate",
            "seed": self.seed,
            "effects": list(self.effects),
            "faults": list(self.faults),
            "runs": len(self.runs),
            "samples": len(self.logs),
            "config": asdict(self.config),
        }

    def features(self) -> dict[str, np.ndarray]:
        """True per-sample features (alpha, gamma, twist, speed, ax, ay, t_gait, channels)."""
        ts = self.true_samples
        f = {
            k: ts[k].to_numpy()
            for k in ("alpha", "gamma", "vx", "vy", "wz", "speed", "ax", "ay", "t_gait")
        }
        for ch in CHANNELS:
            col = self.logs[ch]
            f[ch] = col.astype(str).to_numpy() if ch in CATEGORICAL else col.to_numpy(float)
        return f

    def effect_shares(self, effects: Iterable[str] | None = None) -> pd.DataFrame:
        """How much power each effect adds in this campaign's motions, switched on or not.

        For every effect (default: all of :data:`~energy_planner.simulate.EFFECTS`), the
        difference of the expected truth power with only that effect on and with none,
        on this campaign's true features: its mean over all samples, the fraction of
        samples where it acts (|difference| > 0.01 W), its mean where it acts, and its
        share there relative to the base power.

        Returns
        -------
        DataFrame
            Columns effect, mean_w, active_fraction, mean_active_w, share_active.
        """
        from energy_planner.simulate.effects import EFFECTS

        names = list(EFFECTS) if effects is None else list(check_effects(effects))
        f = self.features()
        params = self.physics.base_params
        base = Physics(params).expected_power(f)
        rows = []
        for name in names:
            contrib = Physics(params, (name,)).expected_power(f) - base
            active = np.abs(contrib) > 1e-2
            rows.append(
                {
                    "effect": name,
                    "mean_w": float(contrib.mean()),
                    "active_fraction": float(active.mean()),
                    "mean_active_w": float(contrib[active].mean()) if active.any() else 0.0,
                    "share_active": float(contrib[active].sum() / base[active].sum())
                    if active.any() and base[active].sum() > 0
                    else 0.0,
                }
            )
        return pd.DataFrame(rows)

    def noise_floor(
        self, windows: Any, reference: str = "expected", smoothing_tau_s: float = 0.0
    ) -> NoiseFloor:
        """RMSE of the measured against the true power on the same windows.

        Every sample of ``windows.samples`` is matched to its log row by ``run`` and
        ``t`` (to 1e-6 s); a window's true power is the plain mean of the truth over its
        samples (as :func:`~energy_planner.measurements.make_windows` averages the
        measured power), its measured power is ``windows.table["power"]``; the floor is
        ``sqrt(mean over windows of (measured - true)^2)``, unweighted, as calibration's
        held-out power RMSE. No model of the per-sample features can do better on
        average.

        Parameters
        ----------
        windows : Windows
            Windows of this campaign's logs (raw or preprocessed), from
            :func:`energy_planner.measurements.make_windows`.
        reference : {"expected", "instantaneous"}
            Truth to compare with: the gait-cycle mean power (default; the ripple counts
            as noise, since its phase is not in the features) or the instantaneous power.
        smoothing_tau_s : float
            If > 0, the truth is first smoothed per run with the exponential moving
            average that :func:`energy_planner.measurements.preprocess` applies to the
            measured power (its ``ema_tau``, 0.2 s by default), so that the floor counts
            the sensors alone and not the smoothing's lag at speed changes.

        Raises
        ------
        LogError
            Unknown ``reference``, or a window sample that is not a row of these logs.
        """
        col = {"expected": "power_expected", "instantaneous": "power"}.get(reference)
        if col is None:
            raise LogError(
                f"unknown noise-floor reference {reference!r}; expected 'expected' or "
                "'instantaneous'"
            )
        samples = windows.samples
        key = pd.DataFrame(
            {
                "run": samples["run"].astype(str).to_numpy(),
                "tk": np.round(samples["t"].to_numpy(float) * 1e6).astype(np.int64),
                "window": samples["window"].to_numpy(),
            }
        )
        ts = self.true_samples
        true_p = ts[col].to_numpy(float)
        if smoothing_tau_s > 0:
            from energy_planner.measurements.preprocess import ema

            run = ts["run"].to_numpy()
            t = ts["t"].to_numpy(float)
            starts = np.flatnonzero(np.r_[True, run[1:] != run[:-1]])
            ends = np.r_[starts[1:], len(run)]
            true_p = true_p.copy()
            for a, b in zip(starts, ends, strict=True):
                true_p[a:b] = ema(true_p[a:b], t[a:b], smoothing_tau_s)
        truth = pd.DataFrame(
            {
                "run": ts["run"].astype(str).to_numpy(),
                "tk": np.round(ts["t"].to_numpy(float) * 1e6).astype(np.int64),
                "true": true_p,
            }
        )
        merged = key.merge(truth, on=["run", "tk"], how="left", validate="many_to_one")
        missing = merged["true"].isna()
        if missing.any():
            r = merged.loc[missing].iloc[0]
            raise LogError(
                f"{int(missing.sum())} window sample(s) are not rows of this campaign's "
                f"logs (first: run {r['run']!r} at t = {r['tk'] / 1e6:.6f} s); expected "
                "windows made from Campaign.logs"
            )
        true_w = merged.groupby("window", sort=True)["true"].mean()
        table = windows.table.sort_values("window")
        measured = table.set_index("window")["power"].reindex(true_w.index).to_numpy(float)
        diff = measured - true_w.to_numpy()
        per = pd.DataFrame(
            {
                "window": true_w.index.to_numpy(),
                "run": table.set_index("window")["run"].reindex(true_w.index).to_numpy(),
                "measured_w": measured,
                "true_w": true_w.to_numpy(),
            }
        )
        return NoiseFloor(
            rmse_w=float(np.sqrt(np.mean(diff**2))) if len(diff) else float("nan"),
            bias_w=float(np.mean(diff)) if len(diff) else float("nan"),
            n_windows=len(diff),
            reference=reference,
            per_window=per,
        )

    def summary(self) -> dict[str, Any]:
        """Counts, effects, faults and the truth's headline numbers (what the CLI prints)."""
        kinds = self.runs["kind"].value_counts().sort_index()
        return {
            "seed": self.seed,
            "runs": len(self.runs),
            "samples": len(self.logs),
            "duration_s": float(self.runs["duration_s"].sum()),
            "kinds": {str(k): int(v) for k, v in kinds.items()},
            "effects": list(self.effects),
            "faults": list(self.faults),
            "mean_power_w": float(self.true_samples["power"].mean()),
            "battery_packs": int(self.runs["battery_pack"].max()) + 1,
        }


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
    names = check_effects(effects)
    fault_names = check_faults(faults)
    physics = Physics(params, names)
    sens = config.sensors.with_faults(fault_names)
    from tqdm.auto import tqdm

    design_rng, channel_rng, noise_rng = np.random.default_rng(seed).spawn(3)
    plan = plan_runs(config)
    psi_of, run_block, order = _field_design(plan, design_rng)
    draws = ChannelDraws.draw(channel_rng, config, max(run_block) + 1, ground=True)
    slip_raw, bias = sensor_offsets(noise_rng, sens, len(plan))

    # ---- geometry, in design order (leg B starts where leg A ended)
    geo: list[dict[str, Any]] = []
    end_of: dict[str, tuple[np.ndarray, float]] = {}
    for spec in tqdm(plan, desc="simulating runs", disable=not progress, unit="run"):
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
