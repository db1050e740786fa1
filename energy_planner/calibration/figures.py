"""The paper's figures from logs: force against slope, yaw torque, superposition.

* Fig. 4 - :func:`plot_force_slope`: force-equivalent cost ``P / v`` (N) against slope,
  uphill and downhill panels, forward (red) and lateral (blue) windows, with the model's
  curves for travel straight up and down the fall line.
* Fig. 5 - :func:`plot_yaw_torque`: yaw torque ``P / |w|`` (N m) of turns in place
  against slope, with the model's torque averaged over the headings a turn sweeps and its
  range (the per-second holding terms depend on the heading).
* Fig. 3 - :func:`plot_superposition`: measured energy of composite paths against the
  sum of their parts (runs labelled ``A``, ``B``, ``AB``, ``C`` within a composite).
* :func:`plot_speed_cost`: cost per metre ``P / v`` (J/m) against speed, per slope and
  relative heading (uphill, across, downhill), steady forward windows per gait over the
  model's curves per gait, with the optimum speed marked (logs across speeds).

matplotlib (Agg backend) is imported inside the plotting functions.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from energy_planner.errors import EnergyPlannerError, LogError
from energy_planner.model import EnergyModel
from energy_planner.model.formula import MOTION_FEATURES
from energy_planner.plotting import fit_layout, new_figure

__all__ = [
    "model_curve",
    "plot_force_slope",
    "plot_yaw_torque",
    "superposition_table",
    "plot_superposition",
    "plot_speed_cost",
    "speed_panels",
    "run_energy",
]

_FWD_COLOR, _LAT_COLOR = "tab:red", "tab:blue"

#: Resolution of the written figures (dpi); each is laid out for it.
_DPI = 110


def model_curve(
    model: EnergyModel,
    alpha: np.ndarray,
    *,
    gamma: float,
    vx: float = 0.0,
    vy: float = 0.0,
    wz: float = 0.0,
    constants: Mapping[str, Any] | None = None,
) -> np.ndarray | None:
    """Model power (W) along a slope sweep at a fixed heading and twist.

    Returns None when the model needs a channel that ``constants`` does not give.

    Examples
    --------
    >>> m = EnergyModel(["fwd_const", "fwd_up"], {"fwd_const": 600.0, "fwd_up": 1000.0})
    >>> model_curve(m, np.radians([0.0, 30.0]), gamma=0.0, vx=0.3).round(1).tolist()
    [180.0, 330.0]
    """
    alpha = np.asarray(alpha, dtype=float)
    n = alpha.shape[0]
    feats: dict[str, Any] = {
        "alpha": alpha,
        "gamma": np.full(n, gamma),
        "vx": np.full(n, vx),
        "vy": np.full(n, vy),
        "wz": np.full(n, wz),
        "ax": np.zeros(n),
        "ay": np.zeros(n),
    }
    for k, v in (constants or {}).items():
        feats.setdefault(k, np.full(n, v, dtype=object if isinstance(v, str) else float))
    try:
        return model.power(feats)
    except EnergyPlannerError:
        return None


def typical_channels(samples: pd.DataFrame, model: EnergyModel) -> dict[str, Any]:
    """Typical value (median, or most common category) of each extra channel the model reads."""
    out: dict[str, Any] = {}
    for name in model.variables - MOTION_FEATURES:
        if name not in samples:
            continue
        col = samples[name]
        if pd.api.types.is_numeric_dtype(col):
            out[name] = float(np.nanmedian(col.to_numpy(float)))
        else:
            out[name] = str(col.astype(str).mode().iloc[0])
    return out


def _median(x: pd.Series, default: float) -> float:
    x = x.to_numpy(float)
    x = x[np.isfinite(x)]
    return float(np.median(x)) if x.size else default


def _cruise(x: pd.Series, default: float) -> float:
    """Cruising rate: the 75th percentile (windows on speed ramps pull the median down)."""
    x = x.to_numpy(float)
    x = x[np.isfinite(x)]
    return float(np.percentile(x, 75)) if x.size else default


def _scatter_windows(ax: Any, pts: pd.DataFrame, color: Any, label: str, **kw: Any) -> None:
    """The windows ``pts`` as points: their estimate (``value``) against slope (deg)."""
    ax.scatter(pts["alpha_deg"], pts["value"], s=14, alpha=0.6, color=color, label=label, **kw)


def _save(fig: Any, path: str | Path) -> None:
    """Lay out (once: :func:`energy_planner.plotting.fit_layout`) and write ``fig``.

    Written by :func:`energy_planner.io.save_figure` at 110 dpi, the resolution it is
    laid out for.
    """
    from energy_planner.io import save_figure

    save_figure(fit_layout(fig, dpi=_DPI), path, dpi=_DPI)


def plot_force_slope(
    estimates: pd.DataFrame,
    model: EnergyModel | None,
    path: str | Path,
    *,
    constants: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """Fig. 4: force-equivalent cost against slope, uphill and downhill panels.

    Parameters
    ----------
    estimates : pandas.DataFrame
        From :func:`energy_planner.calibration.force_estimates`.
    model : EnergyModel or None
        Drawn as curves for travel straight up / down the fall line at the median speed.
    path : path
        PNG to write.
    constants : mapping, optional
        Values of extra channels the model reads (e.g. ``payload_kg``).

    Returns
    -------
    dict
        Points per panel and motion (level windows appear in both panels), and the
        median force (N) and slope (deg) of the sloped windows per panel and motion.
    """
    fwd = estimates[estimates["kind"] == "forward"]
    lat = estimates[estimates["kind"] == "lateral"]
    speed = _cruise(pd.concat([fwd["rate"], lat["rate"]]), 0.3)
    amax = max(float(estimates["alpha_deg"].max()) if len(estimates) else 0.0, 5.0) + 2.0
    grid = np.radians(np.linspace(0.0, amax, 60))
    fig, axes = new_figure(1, 2, figsize=(11, 4.3), sharey=True)
    summary: dict[str, Any] = {"speed_m_s": speed}
    for ax, direction in zip(axes, ("uphill", "downhill"), strict=True):
        for df, label, color, climb_gamma in (
            (
                fwd,
                "forward",
                _FWD_COLOR,
                {"uphill": (0.0, speed, 0.0), "downhill": (np.pi, speed, 0.0)},
            ),
            (
                lat,
                "lateral",
                _LAT_COLOR,
                {"uphill": (-np.pi / 2, 0.0, speed), "downhill": (np.pi / 2, 0.0, speed)},
            ),
        ):
            pts = df[df["heading"].isin([direction, "level"])]
            _scatter_windows(ax, pts, color, f"{label} windows (n={len(pts)})")
            summary[f"{direction}_{label}_n"] = int(len(pts))
            sloped = pts[pts["heading"] == direction]
            summary[f"{direction}_{label}_median_n"] = _median(sloped["value"], float("nan"))
            summary[f"{direction}_{label}_median_alpha_deg"] = _median(
                sloped["alpha_deg"], float("nan")
            )
            if model is not None and model.is_fitted:
                g, vx, vy = climb_gamma[direction]
                p = model_curve(model, grid, gamma=g, vx=vx, vy=vy, constants=constants)
                if p is not None:
                    ax.plot(
                        np.degrees(grid),
                        p / speed,
                        color=color,
                        lw=2,
                        label=f"model, {label} straight {direction}",
                    )
        ax.set_title(f"{direction.capitalize()} travel")
        ax.set_xlabel("slope angle alpha (deg)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="upper left")
    axes[0].set_ylabel("force-equivalent cost P / v (N = J/m)")
    fig.suptitle(
        f"Force-equivalent cost against slope (curves at the cruising speed {speed:.2f} m/s)"
    )
    _save(fig, path)
    return summary


def plot_yaw_torque(
    estimates: pd.DataFrame,
    model: EnergyModel | None,
    path: str | Path,
    *,
    constants: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """Fig. 5: yaw torque ``P / |w|`` of turns in place against slope.

    Returns
    -------
    dict
        Number of turn windows, median torque (N m) and the median yaw rate (rad/s).
    """
    turns = estimates[estimates["kind"] == "turning"]
    rate = _cruise(turns["rate"], 0.5)
    fig, ax = new_figure(figsize=(6.5, 4.3))
    for motion, color in (("turn_left", "tab:purple"), ("turn_right", "tab:orange")):
        pts = turns[turns["motion"] == motion]
        _scatter_windows(ax, pts, color, f"{motion.replace('_', ' ')} windows (n={len(pts)})",
                         zorder=3)  # fmt: skip
    amax = max(float(turns["alpha_deg"].max()) if len(turns) else 0.0, 5.0) + 2.0
    grid = np.radians(np.linspace(0.0, amax, 60))
    if model is not None and model.is_fitted:
        # a turn sweeps the heading: the model's torque at every heading, its mean and range
        curves = [
            model_curve(model, grid, gamma=g, wz=rate, constants=constants)
            for g in np.linspace(-np.pi, np.pi, 24, endpoint=False)
        ]
        if all(c is not None for c in curves):
            tau = np.array(curves) / rate
            deg = np.degrees(grid)
            ax.fill_between(
                deg,
                tau.min(axis=0),
                tau.max(axis=0),
                color="0.85",
                zorder=0,
                label="model, over headings",
            )
            ax.plot(deg, tau.mean(axis=0), color="k", lw=2, label="model, heading mean")
    ax.set_xlabel("slope angle alpha (deg)")
    ax.set_ylabel("yaw torque P / |w| (N m)")
    ax.set_title(
        f"Turning in place (model at the cruising yaw rate {rate:.2f} rad/s;\n"
        "windows on the speed ramps, at lower yaw rates, sit higher)",
        fontsize=10,
    )
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    _save(fig, path)
    return {
        "n": int(len(turns)),
        "median_torque_nm": _median(turns["value"], float("nan")),
        "yaw_rate_rad_s": rate,
    }


def run_energy(samples: pd.DataFrame) -> pd.Series:
    """Measured energy (J) of each run: trapezoidal integral of ``power`` over ``t``.

    ``power`` is used when present, else ``voltage * current``.

    Examples
    --------
    >>> s = pd.DataFrame({"run": ["a", "a", "b", "b"], "t": [0.0, 2.0, 0.0, 1.0],
    ...                   "power": [100.0, 100.0, 50.0, 150.0]})
    >>> run_energy(s).to_dict()
    {'a': 200.0, 'b': 100.0}
    """
    if "power" in samples:
        p = samples["power"].to_numpy(float)
    else:
        p = samples["voltage"].to_numpy(float) * samples["current"].to_numpy(float)
    df = pd.DataFrame(
        {"run": samples["run"].astype(str).to_numpy(), "t": samples["t"].to_numpy(float), "p": p}
    )
    out = {}
    for run, g in df.groupby("run", sort=True):
        g = g.sort_values("t")
        t, pp = g["t"].to_numpy(), g["p"].to_numpy()
        out[run] = float(np.sum(0.5 * (pp[1:] + pp[:-1]) * np.diff(t))) if len(t) > 1 else 0.0
    return pd.Series(out, name="energy_j", dtype=float)


def superposition_table(energy: pd.Series, meta: pd.DataFrame) -> pd.DataFrame:
    """Energies of composite paths against the sum of their parts.

    Parameters
    ----------
    energy : pandas.Series
        Energy (J) per run id.
    meta : pandas.DataFrame
        Columns ``run``, ``composite`` (group id) and ``part`` (``A``, ``B``, ``AB``,
        ``C``); repeats of a part are averaged.

    Returns
    -------
    pandas.DataFrame
        One row per composite: A, B, AB, C (J; NaN when absent), sum_ab = A + B,
        rel_ab = AB / (A + B) - 1, rel_c = C / (A + B) - 1.

    Examples
    --------
    >>> e = pd.Series({"r1": 100.0, "r2": 50.0, "r3": 160.0, "r4": 140.0})
    >>> meta = pd.DataFrame({"run": ["r1", "r2", "r3", "r4"], "composite": "c0",
    ...                      "part": ["A", "B", "AB", "C"]})
    >>> superposition_table(e, meta)[["sum_ab", "rel_ab"]].round(4).to_dict("records")
    [{'sum_ab': 150.0, 'rel_ab': 0.0667}]
    """
    missing = [c for c in ("run", "composite", "part") if c not in meta.columns]
    if missing:
        raise LogError(
            f"composite metadata lacks column(s) {', '.join(missing)}; expected run, "
            "composite, part (A, B, AB, C)"
        )
    m = meta[meta["composite"].notna() & meta["part"].notna()].copy()
    m = m[m["composite"].astype(str).str.len() > 0]
    m["run"] = m["run"].astype(str)
    m["part"] = m["part"].astype(str).str.upper()
    m["energy_j"] = energy.reindex(m["run"]).to_numpy()
    m = m[np.isfinite(m["energy_j"].to_numpy(float))]
    cols = ["A", "B", "AB", "C"]
    if m.empty:
        return pd.DataFrame(columns=["composite", *cols, "sum_ab", "rel_ab", "rel_c"])
    wide = m.pivot_table(index="composite", columns="part", values="energy_j", aggfunc="mean")
    wide = wide.reindex(columns=cols)
    wide["sum_ab"] = wide["A"] + wide["B"]
    with np.errstate(divide="ignore", invalid="ignore"):
        wide["rel_ab"] = wide["AB"] / wide["sum_ab"] - 1
        wide["rel_c"] = wide["C"] / wide["sum_ab"] - 1
    wide.columns.name = None
    return wide.reset_index()


def plot_superposition(table: pd.DataFrame, path: str | Path) -> dict[str, Any]:
    """Fig. 3: composite energy (AB, C) against the sum of the parts (A + B).

    Returns
    -------
    dict
        Number of composites and the mean absolute relative differences.
    """
    fig, (ax, ax2) = new_figure(1, 2, figsize=(12, 4.5), gridspec_kw={"width_ratios": [2.2, 1]})
    n = len(table)
    x = np.arange(n)
    w = 0.27
    a = table["A"].to_numpy(float)
    b = table["B"].to_numpy(float)
    ax.bar(x - w, a, w, color="tab:gray", label="A (measured part)")
    ax.bar(x - w, b, w, bottom=a, color="silver", label="B (measured part)")
    ax.bar(x, table["AB"].to_numpy(float), w, color="tab:green", label="A then B (one run)")
    ax.bar(x + w, table["C"].to_numpy(float), w, color="tab:cyan", label="C (alternative)")
    for i, r in table.iterrows():
        if np.isfinite(r["rel_ab"]):
            ax.annotate(
                f"{100 * r['rel_ab']:+.1f}%", (i, r["AB"]), ha="center", va="bottom", fontsize=8
            )
    ax.set_xticks(x, [str(c) for c in table["composite"]], rotation=20, ha="right", fontsize=8)
    ax.set_ylabel("energy (J)")
    ax.set_title("Composite paths: sum of parts vs measured")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.28), ncol=4)
    ax.set_ylim(0, 1.15 * np.nanmax(np.r_[a + b, table["AB"], table["C"], 1.0]))
    ax.grid(axis="y", alpha=0.3)
    s = table["sum_ab"].to_numpy(float)
    lim = [0, 1.1 * np.nanmax(np.r_[s, table["AB"], table["C"], 1.0])]
    ax2.plot(lim, lim, "k--", lw=1, label="equal energy")
    ax2.scatter(s, table["AB"], color="tab:green", label="A then B")
    ax2.scatter(s, table["C"], color="tab:cyan", marker="s", label="C")
    ax2.set_xlim(lim)
    ax2.set_ylim(lim)
    ax2.set_xlabel("E(A) + E(B) (J)")
    ax2.set_ylabel("measured composite energy (J)")
    ax2.legend(fontsize=8)
    ax2.grid(alpha=0.3)
    from energy_planner.io import save_figure

    save_figure(fit_layout(fig, dpi=_DPI), path, dpi=_DPI, bbox_inches="tight")
    rel_ab = table["rel_ab"].to_numpy(float)
    rel_c = table["rel_c"].to_numpy(float)
    return {
        "n": int(n),
        "mean_abs_rel_ab": float(np.nanmean(np.abs(rel_ab))) if np.isfinite(rel_ab).any() else None,
        "mean_abs_rel_c": float(np.nanmean(np.abs(rel_c))) if np.isfinite(rel_c).any() else None,
    }


#: Relative heading classes of the speed figure: name -> (gamma drawn, deg; |gamma| range).
_HEADING_CLASSES = {"uphill": (0.0, 0.0, 30.0), "across": (90.0, 60.0, 120.0),
                    "downhill": (180.0, 150.0, 180.0)}  # fmt: skip
_GAIT_COLORS = ("tab:green", "tab:orange", "tab:purple", "tab:brown")


def speed_panels(table: pd.DataFrame, max_slopes: int = 3) -> list[dict[str, Any]]:
    """The panels of :func:`plot_speed_cost`: slope levels times relative heading classes.

    Steady forward windows (speed above 0.05 m/s, mean acceleration below 0.05 m/s^2).
    The slopes are the logs' groups of slopes (separated by gaps of more than 2 deg, as a
    campaign's ramps are) when there are at most ``max_slopes``, else ``max_slopes``
    quantile bins; level ground (below 3 deg) is one
    panel, sloped ground a panel per heading class with windows.

    Returns
    -------
    list of dict
        ``label``, ``slope_deg`` (the bin's median), ``heading_deg`` (0, 90 or 180),
        ``rows`` (boolean mask of ``table``).
    """
    from energy_planner.uncertainty.domain import SLOPED_DEG

    speed = table["speed"].to_numpy(float)
    steady = (table["kind"].to_numpy() == "forward") & (speed > 0.05)
    if {"ax", "ay"} <= set(table.columns):
        acc = np.hypot(table["ax"].to_numpy(float), table["ay"].to_numpy(float))
        steady &= np.nan_to_num(acc, nan=np.inf) < 0.05
    slope = np.degrees(table["alpha"].to_numpy(float))
    gamma = np.abs(np.degrees(table["gamma"].to_numpy(float)))
    level = slope < SLOPED_DEG
    panels = []
    if (steady & level).any():
        panels.append({"label": "level", "slope_deg": 0.0, "heading_deg": 0.0,
                       "rows": steady & level})  # fmt: skip
    sloped = steady & ~level
    if sloped.any():
        values = np.sort(slope[sloped])
        cut = np.flatnonzero(np.diff(values) > 2.0)  # a campaign's ramps: gaps > 2 deg
        groups = np.split(values, cut + 1)
        if len(groups) <= max_slopes:
            bins = [(float(g[0]), float(g[-1])) for g in groups]
        else:
            q = np.quantile(slope[sloped], np.linspace(0, 1, max_slopes + 1))
            bins = list(zip(q[:-1], q[1:], strict=True))
        for k, (lo, hi) in enumerate(bins):
            in_bin = (
                sloped & (slope >= lo) & ((slope <= hi) if k == len(bins) - 1 else (slope < hi))
            )
            if not in_bin.any():
                continue
            med = float(np.median(slope[in_bin]))
            for name, (g, glo, ghi) in _HEADING_CLASSES.items():
                rows = in_bin & (gamma >= glo) & (gamma <= ghi)
                if rows.any():
                    panels.append({"label": f"{med:.0f} deg, {name}", "slope_deg": med,
                                   "heading_deg": g, "rows": rows})  # fmt: skip
    return panels


def plot_speed_cost(
    table: pd.DataFrame,
    model: EnergyModel | None,
    path: str | Path,
    *,
    constants: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """Cost per metre against speed, per slope and relative heading, per gait (a PNG).

    Each panel (:func:`speed_panels`) shows the steady forward windows (``P / v``, J/m)
    coloured by their gait (the ``gait`` channel, when the logs have it), the model's cost
    per metre per gait over the speeds the logs walked it at
    (:func:`energy_planner.calibration.speed.cost_curves`), and its optimum speed marked.

    Parameters
    ----------
    table : pandas.DataFrame
        The window table (:func:`~energy_planner.calibration._windows.aligned_table`:
        ``speed``, ``power``, ``alpha``, ``gamma``, ``kind``; ``gait`` optional).
    model : EnergyModel or None
        The fitted model (None: windows only).
    path : str or Path
        PNG to write.
    constants : mapping, optional
        Values of the channels the model reads other than ``gait`` (typical values).

    Returns
    -------
    dict
        ``panels``: per panel its label, slope, heading, windows and the model's optimum
        (``optimum_speed``, ``optimum_cost_n``, ``optimum_gait``, ``interior``).

    Raises
    ------
    LogError
        No steady forward windows to draw.
    """
    from energy_planner.calibration.speed import cost_curves, optimum_speed
    from energy_planner.model import GAIT_CHANNEL

    panels = speed_panels(table)
    if not panels:
        raise LogError("no steady forward windows: the cost against speed cannot be drawn")
    consts = {k: v for k, v in dict(constants or {}).items() if k != GAIT_CHANNEL}
    gaits = (
        sorted(table[GAIT_CHANNEL].dropna().astype(str).unique()) if GAIT_CHANNEL in table else []
    )
    color = {g: _GAIT_COLORS[i % len(_GAIT_COLORS)] for i, g in enumerate(gaits)}
    ncol = min(3, len(panels))
    nrow = -(-len(panels) // ncol)
    fig, axes = new_figure(nrow, ncol, cells=len(panels), figsize=(4.6 * ncol, 3.6 * nrow))
    speed = table["speed"].to_numpy(float)
    cost = table["power"].to_numpy(float) / np.where(speed > 0, speed, np.nan)
    out = []
    for ax, panel in zip(axes, panels, strict=True):
        rows = panel["rows"]
        if gaits:
            g_of = table[GAIT_CHANNEL].astype(str).to_numpy()
            for g in gaits:
                sel = rows & (g_of == g)
                if sel.any():
                    ax.scatter(speed[sel], cost[sel], s=10, alpha=0.45, color=color[g],
                               label=f"{g} windows")  # fmt: skip
        else:
            ax.scatter(speed[rows], cost[rows], s=10, alpha=0.45, color="tab:gray",
                       label="windows")  # fmt: skip
        rec: dict[str, Any] = {k: panel[k] for k in ("label", "slope_deg", "heading_deg")}
        rec["windows"] = int(rows.sum())
        if model is not None and model.is_fitted:
            try:
                curves = cost_curves(model, panel["slope_deg"], panel["heading_deg"],
                                     channels=consts)  # fmt: skip
                best = optimum_speed(model, panel["slope_deg"], panel["heading_deg"],
                                     channels=consts)  # fmt: skip
            except EnergyPlannerError:
                curves, best = {}, None
            for g, c in curves.items():
                ax.plot(c["speed"], c["cost_n"], color=color.get(g, "k"), lw=1.8,
                        label=f"model, {g}" if g else "model")  # fmt: skip
            if best is not None:
                ax.axvline(best["speed"], color="k", ls=":", lw=1)
                ax.plot([best["speed"]], [best["cost_n"]], marker="*", ms=13, color="k",
                        label=f"optimum {best['speed']:.2f} m/s")  # fmt: skip
                rec.update(optimum_speed=round(best["speed"], 3),
                           optimum_cost_n=round(best["cost_n"], 1),
                           optimum_gait=best["gait"], interior=bool(best["interior"]))  # fmt: skip
        ax.set_title(panel["label"], fontsize=10)
        ax.set_xlabel("speed (m/s)")
        ax.set_ylabel("cost per metre P/v (J/m)")
        finite = cost[rows][np.isfinite(cost[rows])]
        if finite.size:
            ax.set_ylim(0.0, float(np.percentile(finite, 99)) * 1.15)
        ax.legend(fontsize=7)
        out.append(rec)
    fig.suptitle("Cost per metre against speed (steady forward windows; optimum marked)")
    _save(fig, path)
    return {"panels": out}
