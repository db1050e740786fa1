"""What a simulation returns: the logs, the runs and the truth (:class:`Campaign`).

A :class:`Campaign` holds a designed campaign (:func:`~energy_planner.simulate.simulate_campaign`)
or a set of missions (:func:`~energy_planner.simulate.simulate_missions`). Writing it
(:mod:`~energy_planner.simulate.writer`), its fall-line costs and their plot
(:mod:`~energy_planner.simulate.costs`) and its noise floor
(:mod:`~energy_planner.simulate.noise`) live in their own modules; the methods here call
them.

Examples
--------
>>> from energy_planner.simulate import simulate_campaign, CampaignConfig
>>> camp = simulate_campaign(seed=0, config=CampaignConfig.small())
>>> camp.summary()["runs"], list(camp.logs.columns[: len(LOG_COLUMNS)]) == list(LOG_COLUMNS)
(95, True)
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from energy_planner.errors import RemovedAPIError
from energy_planner.measurements.schema import CANONICAL_COLUMNS
from energy_planner.simulate.config import CampaignConfig
from energy_planner.simulate.effects import check_effects
from energy_planner.simulate.noise import NoiseFloor
from energy_planner.simulate.physics import Physics

__all__ = ["Campaign", "LOG_COLUMNS", "CHANNELS", "CATEGORICAL"]

#: Canonical log columns written by the simulator, in order (the log readers' own).
LOG_COLUMNS = CANONICAL_COLUMNS
#: Extra channels: carried mass (kg), surface (categorical), winding temperature (deg C,
#: warming during a run), air temperature (deg C), grass height (m). The model's catalog
#: reads none of them; each is logged in every campaign, its effect on or not.
CHANNELS = ("load_kg", "ground", "motor_temp", "air_temp_c", "grass_height_m")
#: Channels that are categorical.
CATEGORICAL = ("ground",)


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
        self,
        out_dir: str | Path,
        fmt: str = "csv",
        bag: bool = False,
        progress: bool = False,
        overwrite: bool = False,
    ) -> list[Path]:
        """Write the campaign to ``out_dir``: one log per run, the run table, the truth.

        ``out_dir`` must be empty or new; ``overwrite=True`` replaces it whole. Parameters
        and files: :func:`~energy_planner.simulate.writer.write_campaign`.
        """
        from energy_planner.simulate.writer import write_campaign

        return write_campaign(self, out_dir, fmt, bag, progress, overwrite=overwrite)

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
        from energy_planner.simulate.costs import cost_table

        return cost_table(self)

    def plot(self, path: str | Path) -> Path:
        """PNG of the force-equivalent cost versus slope (as the paper's Fig. 4).

        Uphill (left) and downhill (right) straight runs along the fall line, forward and
        lateral: measured cost per run (points) and the truth (lines).
        """
        from energy_planner.simulate.costs import plot_costs

        return plot_costs(self, path)

    def physics_dict(self) -> dict[str, Any]:
        """The truth as plain data: effects and every robot parameter with its unit."""
        out: dict[str, Any] = {
            "generator": "energy_planner.simulate.physics",
            "effects": list(self.effects),
            "params": self.physics.params.table(),
        }
        if self.physics.gaits is not None:
            g = self.physics.gaits
            out["gaits"] = {
                "schedule": {
                    "gaits": list(g.gaits),
                    "trot_speed": g.trot_speed,
                    "crawl_slope_deg": g.crawl_slope_deg,
                },
                "params": g.table(),
            }
        return out

    def metadata(self) -> dict[str, Any]:
        """Seed, effects, faults, counts and every parameter, JSON-ready."""
        return {
            "generator": "energy_planner.simulate",
            "seed": self.seed,
            "effects": list(self.effects),
            "faults": list(self.faults),
            "runs": len(self.runs),
            "samples": len(self.logs),
            "config": _config_dict(self.config),
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
        if "gait" in self.logs:
            f["gait"] = self.logs["gait"].astype(str).to_numpy()
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
        gaits = self.physics.gaits
        base = Physics(params, gaits=gaits).expected_power(f)
        rows = []
        for name in names:
            contrib = Physics(params, (name,), gaits=gaits).expected_power(f) - base
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

        Parameters and method: :func:`~energy_planner.simulate.noise.noise_floor`.
        """
        from energy_planner.simulate.noise import noise_floor

        return noise_floor(self, windows, reference, smoothing_tau_s)

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


def _config_dict(config: Any) -> dict[str, Any]:
    """The config as plain data, ``gaits`` only when the campaign has gaits.

    A campaign without gaits writes the files it wrote before gaits existed.
    """
    doc = asdict(config)
    if doc.get("gaits") is None:
        doc.pop("gaits", None)
    return doc
