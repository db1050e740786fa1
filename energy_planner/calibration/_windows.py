"""Helpers shared by the calibration modules: aligning windows, motion and heading classes.

The measurements module delivers a ``Windows`` object with ``.samples`` (one row per
sample, with an integer ``window`` column) and ``.table`` (one row per window). Every
calibration function works on per-window quantities in the order of the sorted window
ids, which is the order ``EnergyModel.design_matrix(samples, groups=samples["window"])``
returns; :func:`aligned_table` puts the table in that order.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from energy_planner.errors import FitError
from energy_planner.stats import classify_motion

__all__ = [
    "aligned_table",
    "heading_class",
    "window_climb_fraction",
    "window_kind",
    "window_energy",
    "MOTION_KIND",
    "STRAIGHT_KINDS",
]

#: Motion class of a window (measurements contract) -> kind of the base terms it exercises.
MOTION_KIND: dict[str, str] = {
    "forward": "forward",
    "backward": "backward",
    "lateral_left": "lateral",
    "lateral_right": "lateral",
    "turn_left": "turning",
    "turn_right": "turning",
}
#: Kinds whose force is power / speed (N); the turning kind gives power / |wz| (N m).
STRAIGHT_KINDS = ("forward", "backward", "lateral")
#: Kind of a window in which the robot stands (mean speed and yaw rate below walking).
STANDING = "standing"


def window_kind(motion: Any, speed: Any, wz: Any) -> np.ndarray:
    """Kind of the base terms each window exercises, from its motion class and mean twist.

    :data:`MOTION_KIND` of the motion class (``mixed`` for the others), and
    :data:`STANDING` where the window's mean speed and yaw rate are below walking
    (:data:`energy_planner.model.model.WALKING_SPEED`, ``WALKING_YAW_RATE``), whatever
    the sensor noise made of its class.

    Examples
    --------
    >>> window_kind(["forward", "mixed", "forward", "turn_left"], [0.3, 0.0, 0.01, 0.0],
    ...             [0.0, 0.0, 0.0, 0.5]).tolist()
    ['forward', 'standing', 'standing', 'turning']
    """
    from energy_planner.model.model import WALKING_SPEED, WALKING_YAW_RATE

    kind = pd.Series(np.asarray(motion, dtype=object)).map(MOTION_KIND).fillna("mixed")
    still = (np.asarray(speed, dtype=float) < WALKING_SPEED) & (
        np.abs(np.asarray(wz, dtype=float)) < WALKING_YAW_RATE
    )
    return np.where(still, STANDING, kind.to_numpy(dtype=object)).astype(object)


_REQUIRED_SAMPLES = ("run", "t", "vx", "vy", "wz", "alpha", "gamma", "power", "window")
_REQUIRED_TABLE = ("run", "window", "duration", "power")


def _check_columns(df: pd.DataFrame, required: tuple[str, ...], what: str) -> None:
    missing = [c for c in required if c not in df.columns]
    if missing:
        raise FitError(
            f"windows.{what} lacks column(s) {', '.join(missing)}; expected the measurements "
            f"contract columns {', '.join(required)} (have: {', '.join(map(str, df.columns))})"
        )


def aligned_table(windows: Any) -> pd.DataFrame:
    """The window table sorted by window id, checked against the samples.

    Parameters
    ----------
    windows : Windows
        Any object with ``samples`` and ``table`` DataFrames (measurements contract).

    Returns
    -------
    pandas.DataFrame
        ``windows.table`` sorted by ``window``, with ``motion`` filled in by
        :func:`energy_planner.stats.classify_motion` when the table has none, the
        per-window mean climb fraction ``climb`` (see :func:`window_climb_fraction`) and
        ``kind`` (:func:`window_kind`).

    Raises
    ------
    FitError
        If a column is missing, a window id repeats, or samples and table disagree.
    """
    samples, table = windows.samples, windows.table
    _check_columns(samples, _REQUIRED_SAMPLES, "samples")
    _check_columns(table, _REQUIRED_TABLE, "table")
    if table["window"].duplicated().any():
        dup = table.loc[table["window"].duplicated(), "window"].iloc[0]
        raise FitError(f"window id {dup} appears twice in windows.table; ids must be unique")
    table = table.sort_values("window").reset_index(drop=True)
    ids = np.unique(samples["window"].to_numpy())
    if len(ids) != len(table) or not np.array_equal(ids, table["window"].to_numpy()):
        raise FitError(
            f"windows.samples has {len(ids)} window ids and windows.table {len(table)} rows, "
            "and they differ; build both with measurements.make_windows"
        )
    table = table.copy()
    if "motion" not in table.columns:
        table["motion"] = classify_motion(
            table["vx"].to_numpy(), table["vy"].to_numpy(), table["wz"].to_numpy()
        )
    climb = window_climb_fraction(samples)
    table["climb"] = climb.reindex(table["window"]).to_numpy()
    speed = (
        table["speed"].to_numpy(float)
        if "speed" in table
        else np.hypot(table["vx"].to_numpy(float), table["vy"].to_numpy(float))
    )
    table["kind"] = window_kind(table["motion"].to_numpy(), speed, table["wz"].to_numpy(float))
    return table


def window_climb_fraction(samples: pd.DataFrame) -> pd.Series:
    """Per-window mean of the fraction of the velocity that climbs the slope.

    ``climb = (vx cos(gamma) - vy sin(gamma)) / speed``: +1 walking straight uphill,
    -1 straight downhill, 0 across the slope, whatever the body points to (a robot
    walking sideways up the slope climbs with ``climb = 1``). Averaging this per sample
    avoids averaging ``gamma`` across the +-pi wrap. Samples without speed count as 0.

    Examples
    --------
    >>> s = pd.DataFrame({"window": [0, 0, 1], "vx": [0.3, 0.3, 0.0], "vy": [0.0, 0.0, 0.3],
    ...                   "gamma": [np.pi, -np.pi, -np.pi / 2]})
    >>> window_climb_fraction(s).round(6).tolist()
    [-1.0, 1.0]
    """
    vx = samples["vx"].to_numpy(float)
    vy = samples["vy"].to_numpy(float)
    g = samples["gamma"].to_numpy(float)
    speed = np.hypot(vx, vy)
    along = vx * np.cos(g) - vy * np.sin(g)
    frac = np.divide(along, speed, out=np.zeros_like(along), where=speed > 1e-9)
    return pd.Series(frac, index=samples.index).groupby(samples["window"].to_numpy()).mean()


def heading_class(alpha: np.ndarray, climb: np.ndarray, *, level_deg: float = 2.0) -> np.ndarray:
    """Name the direction of travel relative to the slope.

    ``level`` below ``level_deg`` of slope; otherwise ``uphill`` when the travel is within
    30 deg of the uphill direction (``climb >= cos 30``), ``downhill`` within 30 deg of
    downhill, ``cross`` within 30 deg of the contour line (``|climb| <= sin 30``), and
    ``oblique`` in between.

    Examples
    --------
    >>> heading_class(np.radians([10, 10, 10, 10, 1]), np.array([0.9, -1, 0.1, 0.6, 1])).tolist()
    ['uphill', 'downhill', 'cross', 'oblique', 'level']
    """
    alpha = np.asarray(alpha, dtype=float)
    climb = np.asarray(climb, dtype=float)
    c30 = np.cos(np.pi / 6)
    out = np.full(alpha.shape, "oblique", dtype=object)
    out[climb >= c30] = "uphill"
    out[climb <= -c30] = "downhill"
    out[np.abs(climb) <= 0.5] = "cross"
    out[alpha < np.radians(level_deg)] = "level"
    return out.astype(str)


def window_energy(samples: pd.DataFrame, power: np.ndarray | None = None) -> pd.Series:
    """Energy (J) of each window: trapezoidal integral of power over its samples' times.

    Parameters
    ----------
    samples : pandas.DataFrame
        Per-sample rows with ``window`` and ``t``.
    power : ndarray, optional
        Per-sample power (W) aligned with ``samples``; ``samples["power"]`` by default.

    Returns
    -------
    pandas.Series
        Energy per window id, sorted by window id.

    Examples
    --------
    >>> s = pd.DataFrame({"window": [1, 1, 1, 2, 2], "t": [0.0, 1.0, 2.0, 5.0, 5.5],
    ...                   "power": [100.0, 100.0, 200.0, 10.0, 30.0]})
    >>> window_energy(s).tolist()
    [250.0, 10.0]
    """
    p = samples["power"].to_numpy(float) if power is None else np.asarray(power, dtype=float)
    w = samples["window"].to_numpy()
    t = samples["t"].to_numpy(float)
    order = np.lexsort((t, w))
    w, t, p = w[order], t[order], p[order]
    same = w[1:] == w[:-1]
    seg = np.where(same, 0.5 * (p[1:] + p[:-1]) * (t[1:] - t[:-1]), 0.0)
    energy = pd.Series(seg).groupby(w[:-1]).sum() if len(seg) else pd.Series(dtype=float)
    return energy.reindex(np.unique(w), fill_value=0.0)
