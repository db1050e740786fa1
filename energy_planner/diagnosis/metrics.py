"""How far the model is from the measurements: error metrics and breakdowns.

Power-level metrics are computed on windows (mean measured vs mean predicted power);
run-level metrics compare the energy of whole runs; the breakdown splits the window
residuals by slope, heading, speed, motion type and every extra channel so that one can
see where the model fails.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

if TYPE_CHECKING:
    from energy_planner.calibration.windowdata import WindowData

#: Heading sectors (centre in degrees, label); gamma = 0 faces uphill, +90 has uphill on
#: the robot's right (design notes).
HEADING_SECTORS = (
    (0.0, "uphill"),
    (45.0, "uphill, slope on right"),
    (90.0, "cross, uphill on right"),
    (135.0, "downhill, slope on right"),
    (180.0, "downhill"),
    (-135.0, "downhill, slope on left"),
    (-90.0, "cross, uphill on left"),
    (-45.0, "uphill, slope on left"),
)


def power_metrics(measured: np.ndarray, predicted: np.ndarray) -> dict[str, float]:
    """RMSE, MAE (W), bias (mean of measured - predicted, W) and R^2 over windows.

    Non-finite pairs are ignored.

    Examples
    --------
    >>> m = power_metrics(np.array([1.0, 2, 3, 4]), np.array([1.0, 2, 3, 6]))
    >>> m["rmse_w"], m["mae_w"], m["bias_w"], round(m["r2"], 12)
    (1.0, 0.5, -0.5, 0.2)
    """
    y = np.asarray(measured, float)
    p = np.asarray(predicted, float)
    ok = np.isfinite(y) & np.isfinite(p)
    y, p = y[ok], p[ok]
    if y.size == 0:
        return {"rmse_w": np.nan, "mae_w": np.nan, "bias_w": np.nan, "r2": np.nan, "n": 0}
    r = y - p
    ss_tot = float(np.sum((y - y.mean()) ** 2))
    r2 = 1.0 - float(r @ r) / ss_tot if ss_tot > 0 else np.nan
    return {
        "rmse_w": float(np.sqrt(np.mean(r**2))),
        "mae_w": float(np.mean(np.abs(r))),
        "bias_w": float(np.mean(r)),
        "r2": r2,
        "n": int(y.size),
    }


def _t_stat(ri: np.ndarray, gi: np.ndarray | None) -> float:
    """Bias over its standard error; with groups (runs), from the per-run mean residuals.

    Windows of one run share their ground, battery and gait, so their errors are
    correlated: the standard error counts runs, not windows.
    """
    if gi is not None:
        _, inv = np.unique(gi, return_inverse=True)
        ri = np.bincount(inv, weights=ri) / np.bincount(inv)
    if ri.size < 2:
        return np.nan
    sd = float(np.std(ri, ddof=1))
    return float(ri.mean() / (sd / np.sqrt(ri.size))) if sd > 0 else np.nan


def _bin_stats(labels, codes, r, extra, groups=None) -> list[dict]:
    total = float(np.sum(r**2)) or 1.0
    rows = []
    for i, label in enumerate(labels):
        sel = codes == i
        ri = r[sel]
        if ri.size == 0:
            continue
        row = {
            "bin": label,
            "n": int(ri.size),
            "bias_w": float(ri.mean()),
            "rmse_w": float(np.sqrt(np.mean(ri**2))),
            "mae_w": float(np.mean(np.abs(ri))),
            "share_sq_error": float(np.sum(ri**2) / total),
            "t": _t_stat(ri, None if groups is None else groups[sel]),
        }
        row.update(extra[i] if i < len(extra) else {})
        rows.append(row)
    return rows


def numeric_bins(x: np.ndarray, n_bins: int = 5) -> tuple[np.ndarray, list[str], list[dict]]:
    """Bin a numeric variable by quantiles (per value when it has few distinct values).

    Returns the bin code of each element (-1 for NaN), the labels and the bin bounds.

    Examples
    --------
    >>> codes, labels, _ = numeric_bins(np.array([0.0, 0, 10, 10, np.nan]))
    >>> codes.tolist(), labels
    ([0, 0, 1, 1, -1], ['0', '10'])
    """
    x = np.asarray(x, float)
    ok = np.isfinite(x)
    codes = np.full(x.shape, -1, dtype=np.int64)
    if not ok.any():
        return codes, [], []
    values = np.unique(x[ok])
    if values.size <= n_bins:
        codes[ok] = np.searchsorted(values, x[ok])
        bounds = [{"lo": float(v), "hi": float(v)} for v in values]
        return codes, [f"{v:.4g}" for v in values], bounds
    edges = np.unique(np.quantile(x[ok], np.linspace(0, 1, n_bins + 1)))
    inner = edges[1:-1]
    codes[ok] = np.searchsorted(inner, x[ok], side="right")
    labels, bounds = [], []
    for i in range(len(edges) - 1):
        lo, hi = edges[i], edges[i + 1]
        close = "]" if i == len(edges) - 2 else ")"
        labels.append(f"[{lo:.4g}, {hi:.4g}{close}")
        bounds.append({"lo": float(lo), "hi": float(hi)})
    return codes, labels, bounds


def categorical_bins(values: Sequence) -> tuple[np.ndarray, list[str], list[dict]]:
    """One bin per value; missing values get their own bin ``"(missing)"``."""
    s = pd.Series(np.asarray(values, dtype=object))
    s = s.where(s.notna(), "(missing)").astype(str)
    codes, uniq = pd.factorize(s, sort=True)
    return np.asarray(codes), [str(u) for u in uniq], [{} for _ in uniq]


def heading_bins(gamma_deg: np.ndarray) -> tuple[np.ndarray, list[str], list[dict]]:
    """Eight 45-degree heading sectors centred on uphill, cross-slope and downhill."""
    g = np.asarray(gamma_deg, float)
    codes = np.full(g.shape, -1, dtype=np.int64)
    ok = np.isfinite(g)
    codes[ok] = np.round(np.mod(g[ok], 360.0) / 45.0).astype(np.int64) % 8
    centres = [0, 45, 90, 135, 180, -135, -90, -45]
    names = dict(HEADING_SECTORS)
    labels = [f"{c:+d} deg ({names[float(c)]})" for c in centres]
    return codes, labels, [{"centre_deg": float(c)} for c in centres]


def breakdown(
    table: pd.DataFrame,
    residual: np.ndarray,
    numeric: Sequence[str] = (),
    categorical: Sequence[str] = (),
    n_bins: int = 5,
    groups: np.ndarray | None = None,
) -> dict[str, dict]:
    """Window residuals split by slope, heading, speed, motion type and extra channels.

    Parameters
    ----------
    table : pandas.DataFrame
        Per-window variables (``alpha_deg``, ``gamma_deg``, ``speed``, ``wz``, ``motion``
        and the extra channels).
    residual : numpy.ndarray
        Measured minus predicted mean power of each window, W.
    numeric, categorical : sequence of str
        Extra channels by kind (numeric ones are binned by quantiles, categorical ones per
        value).
    n_bins : int
        Number of quantile bins.
    groups : numpy.ndarray, optional
        Run of each window: the ``t`` of a bin is then computed from the per-run mean
        residuals in it (windows of one run are not independent).

    Returns
    -------
    dict
        ``{variable: {"kind", "bins": [{"bin", "n", "bias_w", "rmse_w", "mae_w",
        "share_sq_error", "t", ...}], "spread_w"}}`` where ``t`` is the bias over its
        standard error (over runs when ``groups`` is given) and ``spread_w`` the largest
        minus smallest bin bias.
    """
    r = np.asarray(residual, float)
    ok = np.isfinite(r)
    out: dict[str, dict] = {}
    plan: list[tuple[str, str, str]] = []
    for col, kind in (
        ("alpha_deg", "slope"),
        ("gamma_deg", "heading"),
        ("speed", "numeric"),
        ("wz", "numeric"),
        ("motion", "categorical"),
    ):
        if col in table.columns:
            plan.append((col, col, kind))
    plan += [(c, c, "numeric") for c in numeric if c in table.columns]
    plan += [(c, c, "categorical") for c in categorical if c in table.columns]
    for name, col, kind in plan:
        v = table[col].to_numpy()
        if kind == "heading":
            codes, labels, extra = heading_bins(v.astype(float))
        elif kind == "categorical":
            codes, labels, extra = categorical_bins(v)
        else:
            codes, labels, extra = numeric_bins(v.astype(float), n_bins)
        rows = _bin_stats(labels, np.where(ok, codes, -1), np.where(ok, r, 0.0), extra, groups)
        biases = [row["bias_w"] for row in rows]
        out[name] = {
            "kind": "numeric" if kind == "slope" else kind,
            "bins": rows,
            "spread_w": float(max(biases) - min(biases)) if biases else 0.0,
        }
    return out


def hotspots(bd: Mapping[str, dict], top: int = 5) -> list[dict]:
    """Bins where the model fails most clearly: largest ``|t|`` (bias over its error)."""
    rows = []
    for var, info in bd.items():
        for row in info["bins"]:
            if np.isfinite(row["t"]):
                rows.append({"variable": var, **row})
    rows.sort(key=lambda r: -abs(r["t"]))
    return rows[:top]


def superposition(
    runs: pd.DataFrame, composites: Sequence[dict] | Mapping[str, Sequence[str]]
) -> list[dict]:
    """Energy of composite paths against the sum of their parts, measured and predicted.

    Parameters
    ----------
    runs : pandas.DataFrame
        Per run: ``run``, ``measured_j``, ``predicted_j``.
    composites : list of dict or mapping
        ``[{"composite": run, "parts": [runs], "kind": ...}]`` (see
        :func:`energy_planner.diagnosis.infer_composites`) or composite run -> part runs.

    Returns
    -------
    list of dict
        Per composite: measured ``E(AB)`` and ``sum E(parts)``, the superposition error
        (their difference, absolute and relative), and the model's errors on both.
        Composites whose runs are not all in ``runs`` are skipped.

    Examples
    --------
    >>> r = pd.DataFrame({"run": ["A", "B", "AB"], "measured_j": [10.0, 20, 33],
    ...                   "predicted_j": [11.0, 19, 30]})
    >>> s = superposition(r, {"AB": ["A", "B"]})[0]
    >>> s["measured_parts_j"], s["superposition_error_j"], s["model_error_composite_j"]
    (30.0, 3.0, -3.0)
    """
    if isinstance(composites, Mapping):
        composites = [
            {"composite": k, "parts": list(v), "kind": "concatenation"}
            for k, v in composites.items()
        ]
    by = runs.set_index(runs["run"].astype(str))
    out = []
    for c in composites:
        comp, parts = str(c["composite"]), [str(p) for p in c["parts"]]
        if not all(n in by.index for n in [comp, *parts]):
            continue
        m_c = float(by.at[comp, "measured_j"])
        p_c = float(by.at[comp, "predicted_j"])
        m_p = float(sum(by.at[p, "measured_j"] for p in parts))
        p_p = float(sum(by.at[p, "predicted_j"] for p in parts))
        out.append(
            {
                "composite": comp,
                "parts": parts,
                "kind": c.get("kind", "concatenation"),
                "measured_composite_j": m_c,
                "measured_parts_j": m_p,
                "superposition_error_j": m_c - m_p,
                "superposition_error_rel": (m_c - m_p) / m_p if m_p else np.nan,
                "predicted_composite_j": p_c,
                "predicted_parts_j": p_p,
                "model_error_composite_j": p_c - m_c,
                "model_error_parts_j": p_p - m_p,
            }
        )
    return out


#: How the noise floor is estimated from the logs (printed with it).
NOISE_FLOOR_METHOD = (
    "per window: the white sensor noise of the window mean (robust successive-difference sd "
    "of the raw power voltage x current within windows, over sqrt(samples)) and the shift "
    "the preprocessing's smoothing makes (mean smoothed minus mean raw power); "
    "floor = sqrt(mean over windows of both squared)"
)


@dataclass(frozen=True)
class NoiseFloorEstimate:
    """What the logs alone say about the smallest window-power RMSE to expect.

    Attributes
    ----------
    rmse_w : float
        The floor, W: ``sqrt(mean over windows of (noise_w^2 + shift_w^2))``; NaN when the
        windows carry no raw ``voltage`` and ``current``.
    sensor_noise_w : float
        RMS over windows of the white sensor noise of the window mean, W.
    smoothing_shift_w : float
        RMS over windows of the smoothing's shift of the window mean, W.
    sample_sd_w : float
        Robust white-noise sd of one raw power sample, W.
    n_windows : int
        Windows used.
    method : str
        :data:`NOISE_FLOOR_METHOD`, or why no floor could be estimated.
    """

    rmse_w: float
    sensor_noise_w: float
    smoothing_shift_w: float
    sample_sd_w: float
    n_windows: int
    method: str = NOISE_FLOOR_METHOD

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly dict."""
        return asdict(self)


def noise_floor(wd: WindowData) -> NoiseFloorEstimate:
    """Estimate from the logs the RMSE no model of the window features is expected to beat.

    A window's measured power is the mean of the preprocessed (smoothed) power of its
    samples. Two parts of it are not in any feature and both are measured from the logs,
    without a model:

    - the sensor's white noise on the mean: the robust standard deviation of successive
      differences of the raw power ``voltage * current`` within each window (the data
      checks' estimator, ``datacheck._noise_sd``: 1.4826 MAD / sqrt(2)) over the square
      root of the window's samples;
    - the shift the preprocessing's smoothing (an exponential moving average) makes: it
      moves power across window edges at every change of gait or speed; per window, mean
      smoothed minus mean raw power.

    The floor is ``sqrt(mean over windows of noise^2 + shift^2)``, comparable with the
    held-out window-power RMSE. Checked against the simulator's floor from the true power
    (``Campaign.noise_floor``, tests/test_discover.py): 0.92-0.98 of it on designed
    campaigns, 1.02 on missions. It is a yardstick, not a bound: a model can come a little
    below it.

    Parameters
    ----------
    wd : WindowData
        Windows of preprocessed samples that still carry ``voltage`` and ``current``.

    Returns
    -------
    NoiseFloorEstimate
    """
    from energy_planner.measurements.datacheck import _noise_sd

    s = wd.samples
    if not {"voltage", "current", "power"} <= set(s.columns):
        nan = math.nan
        why = "not estimable: the windows carry no raw voltage and current"
        return NoiseFloorEstimate(nan, nan, nan, nan, 0, why)
    raw = s["voltage"].to_numpy(float) * s["current"].to_numpy(float)
    shift = wd.window_mean(s["power"].to_numpy(float)) - wd.window_mean(raw)
    sd = _noise_sd(raw, wd.key)
    n = np.bincount(wd.key, weights=np.isfinite(raw), minlength=wd.n_windows)
    noise2 = np.where(n > 0, sd**2 / np.maximum(n, 1), np.nan)
    ok = np.isfinite(shift) & np.isfinite(noise2)
    if not ok.any():
        nan = math.nan
        return NoiseFloorEstimate(nan, nan, nan, sd, 0, "not estimable: no window has raw power")
    return NoiseFloorEstimate(
        rmse_w=float(np.sqrt(np.mean(shift[ok] ** 2 + noise2[ok]))),
        sensor_noise_w=float(np.sqrt(np.mean(noise2[ok]))),
        smoothing_shift_w=float(np.sqrt(np.mean(shift[ok] ** 2))),
        sample_sd_w=float(sd),
        n_windows=int(ok.sum()),
    )
