"""The noise floor of a simulated campaign: measured against true power on the same windows.

No model of the per-sample features can predict the measured window power better, on
average, than the truth does: the floor is what calibration's held-out RMSE is judged
against.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from energy_planner.errors import LogError
from energy_planner.simulate.records import runs_in

if TYPE_CHECKING:
    from energy_planner.simulate.result import Campaign

__all__ = ["NoiseFloor", "noise_floor"]


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


def noise_floor(
    campaign: Campaign, windows: Any, reference: str = "expected", smoothing_tau_s: float = 0.0
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
            f"unknown noise-floor reference {reference!r}; expected 'expected' or 'instantaneous'"
        )
    samples = windows.samples
    key = pd.DataFrame(
        {
            "run": samples["run"].astype(str).to_numpy(),
            "tk": np.round(samples["t"].to_numpy(float) * 1e6).astype(np.int64),
            "window": samples["window"].to_numpy(),
        }
    )
    ts = campaign.true_samples
    true_p = ts[col].to_numpy(float)
    if smoothing_tau_s > 0:
        from energy_planner.measurements.preprocess import ema

        run = ts["run"].to_numpy()
        t = ts["t"].to_numpy(float)
        true_p = true_p.copy()
        for sl in runs_in(run):
            true_p[sl] = ema(true_p[sl], t[sl], smoothing_tau_s)
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
