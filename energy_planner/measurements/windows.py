"""Short time windows for calibration, motion classes, and measured run energies.

A window lies within one run, one gap-free segment and one motion class, and covers at
most ``duration`` seconds (default 2 s). Per-sample rows carry a window id; the window
table holds arithmetic means (circular mean for ``gamma``), the window energy and the
mode of categorical channels. Means are plain per-sample means, the same as
``EnergyModel.design_matrix(samples, groups=samples["window"])``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from energy_planner.errors import LogError
from energy_planner.measurements.imu import imu_slope_heading
from energy_planner.measurements.schema import check_columns, check_runs, time_gaps
from energy_planner.stats import MOTIONS, classify_motion

__all__ = [
    "DERIVED_COLUMNS",
    "MOTIONS",
    "Windows",
    "classify_motion",
    "make_windows",
    "run_energies",
]

#: Columns derived by measurements (not extra channels).
DERIVED_COLUMNS: tuple[str, ...] = (
    "power",
    "alpha",
    "gamma",
    "speed",
    "ax",
    "ay",
    "motion",
    "window",
    "segment",
)


@dataclass
class Windows:
    """Windows of a sample table (see :func:`make_windows`).

    Attributes
    ----------
    samples : pandas.DataFrame
        Per-sample rows inside a window: canonical columns, ``power`` (W), ``alpha``,
        ``gamma``, ``speed``, ``ax``, ``ay``, ``motion``, ``window`` (int id) and extras.
    table : pandas.DataFrame
        One row per window: ``run, window, t_start, t_end, duration, n, alpha, gamma, vx,
        vy, wz, speed, ax, ay, power, energy_j, motion`` and each extra channel.
    duration : float
        Nominal window length, s.
    dropped : dict
        Samples not put in any window, reason -> count.
    params : dict
        Settings used.
    dropped_runs : list of dict
        Runs with samples but no window: ``run``, ``n_samples``, ``longest_window_s`` and
        ``most_samples`` (of its candidate windows) and ``reason``. Also a
        ``UserWarning``.
    whole_runs : WholeRuns or None
        Every run's battery energy over all its samples and the samples its windows leave
        out (``calibration.prepare.whole_runs``), so that a held-out run's energy can be
        scored whole; None when the windows were cut without them (then only the
        windows' energies can be scored).
    """

    samples: pd.DataFrame
    table: pd.DataFrame
    duration: float
    dropped: dict[str, int] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)
    dropped_runs: list[dict[str, Any]] = field(default_factory=list)
    whole_runs: Any = None

    def __len__(self) -> int:
        return len(self.table)

    def to_dict(self) -> dict[str, Any]:
        """Summary in plain data (for ``--json``)."""
        return {
            "n_windows": len(self.table),
            "n_samples": len(self.samples),
            "duration": self.duration,
            "dropped": dict(self.dropped),
            "dropped_runs": [dict(d) for d in self.dropped_runs],
            "by_motion": {
                str(k): int(v) for k, v in self.table["motion"].value_counts().sort_index().items()
            },
            "params": dict(self.params),
        }


def _ensure_features(samples: pd.DataFrame) -> pd.DataFrame:
    """Add power, alpha, gamma, speed, ax, ay where absent (raw, unsmoothed logs)."""
    from energy_planner.measurements.preprocess import segment_gradient, segment_slices

    out = samples.copy(deep=False)  # copy-on-write: columns shared until replaced
    if "power" not in out.columns:
        out["power"] = out["voltage"].to_numpy(float) * out["current"].to_numpy(float)
    if "alpha" not in out.columns or "gamma" not in out.columns:
        out["alpha"], out["gamma"] = imu_slope_heading(
            *(out[c].to_numpy(float) for c in ("qw", "qx", "qy", "qz"))
        )
    if "speed" not in out.columns:
        out["speed"] = np.hypot(out["vx"].to_numpy(float), out["vy"].to_numpy(float))
    if "ax" not in out.columns or "ay" not in out.columns:
        t = out["t"].to_numpy(float)
        bounds = [sl.start for sl in segment_slices(out)] + [len(out)]
        for src, dst in (("vx", "ax"), ("vy", "ay")):
            out[dst] = segment_gradient(out[src].to_numpy(float), t, bounds)
    return out


def _modes(window: np.ndarray, values: pd.Series, windows: pd.Index) -> list:
    """The most frequent value of each window, in the order of ``windows``.

    Ties as ``value_counts`` ranks them: the first category of a categorical, else the
    value that comes first; None where the window holds no value. One grouping of all
    the samples, not one ``value_counts`` per window.
    """
    if isinstance(values.dtype, pd.CategoricalDtype):
        got = _category_modes(window, values, windows)
        if got is not None:
            return got
    ok = values.notna().to_numpy()
    if isinstance(values.dtype, pd.CategoricalDtype):
        order = values.cat.codes.to_numpy()[ok]
    else:
        order = np.flatnonzero(ok)
    sub = pd.DataFrame({"w": window[ok], "v": values.to_numpy(object)[ok], "i": order})
    if sub.empty:
        return [None] * len(windows)
    counts = sub.groupby(["w", "v"], sort=False).agg(n=("i", "size"), first=("i", "min"))
    counts = counts.reset_index().sort_values(["w", "n", "first"], ascending=[True, False, True])
    best = counts.drop_duplicates("w").set_index("w")["v"]
    return [best.get(w) for w in windows]


def _category_modes(window: np.ndarray, values: pd.Series, windows: pd.Index) -> list | None:
    """:func:`_modes` of a categorical: per window, its most frequent category's value.

    Counted by category code (a tie goes to the first category, as in :func:`_modes`);
    None when ``windows`` is not the sorted set of labels the samples hold (then
    :func:`_modes` groups them itself).
    """
    wins = np.asarray(windows)
    window = np.asarray(window)
    if wins.ndim != 1 or (wins.size > 1 and not np.all(wins[1:] > wins[:-1])):
        return None
    pos = np.searchsorted(wins, window)
    if np.any(pos >= wins.size) or not np.array_equal(wins[np.minimum(pos, wins.size - 1)], window):
        return None
    codes = values.cat.codes.to_numpy()
    n_cat = len(values.cat.categories)
    ok = codes >= 0
    counts = np.bincount(
        pos[ok] * n_cat + codes[ok].astype(np.int64), minlength=wins.size * n_cat
    ).reshape(wins.size, n_cat)
    best = counts.argmax(axis=1) if n_cat else np.zeros(wins.size, dtype=np.int64)
    cats = values.cat.categories.to_numpy(dtype=object)
    return [cats[b] if n_cat and counts[i, b] > 0 else None for i, b in enumerate(best)]


def _mode(s: pd.Series):
    """The mode of one window's values (:func:`_modes` of a single window)."""
    return _modes(np.zeros(len(s), dtype=np.int64), s, pd.Index([0]))[0]


def make_windows(
    samples: pd.DataFrame,
    duration: float = 2.0,
    *,
    max_gap: float | None = None,
    min_fraction: float = 0.5,
    min_samples: int = 3,
    motion_length: float = 0.5,
    motion_ratio: float = 0.3,
) -> Windows:
    """Cut samples into short windows within a run, segment and motion class.

    Consecutive samples form a block while the run, the ``segment`` (if present) and the
    motion class stay the same and no time step is a gap (longer than five of the run's
    sample periods, or than ``max_gap`` s if given:
    :func:`~energy_planner.measurements.schema.time_gaps`). Each block is cut
    at ``t0 + k * duration``. Sample ``i`` stands for the interval to the next sample of
    its block (the last one for the block's previous step), so a window's ``duration`` is
    the sum of its sample intervals, ``t_end = t_start + duration`` and ``energy_j =
    sum(power_i * dt_i)``. Windows shorter than ``min_fraction * duration`` or with fewer
    than ``min_samples`` samples are dropped (counted in ``Windows.dropped``).

    Parameters
    ----------
    samples : pandas.DataFrame
        Canonical samples, cleaned (:func:`~energy_planner.measurements.preprocess`) or
        raw (then power = voltage * current, alpha/gamma from the IMU and ax/ay by
        differences are computed here).
    duration : float
        Window length, s.
    max_gap, min_fraction, min_samples
        See above.
    motion_length, motion_ratio
        Passed to :func:`energy_planner.stats.classify_motion` (the project's one motion
        classifier) as ``length`` and ``ratio``.

    Returns
    -------
    Windows

    Examples
    --------
    >>> t = np.arange(0, 5, 0.5)
    >>> df = pd.DataFrame({"run": "a", "t": t, "qw": 1.0, "qx": 0.0, "qy": 0.0, "qz": 0.0,
    ...     "vx": 0.3, "vy": 0.0, "wz": 0.0, "voltage": 50.0, "current": t})
    >>> w = make_windows(df, 2.0)
    >>> w.table[["t_start", "duration", "n", "power", "energy_j"]].to_numpy().tolist()
    [[0.0, 2.0, 4.0, 37.5, 75.0], [2.0, 2.0, 4.0, 137.5, 275.0]]
    >>> w.dropped
    {'window shorter than 1 s or 3 samples': 2}
    """
    if duration <= 0:
        raise LogError(f"window duration {duration!r} s must be > 0")
    check_columns(samples.columns, "samples given to make_windows")
    check_runs(samples, "samples given to make_windows")
    df = samples.assign(run=samples["run"].astype(str))
    df = df.sort_values(["run", "t"], kind="stable").reset_index(drop=True)
    df = _ensure_features(df)
    df["motion"] = classify_motion(
        df["vx"], df["vy"], df["wz"], length=motion_length, ratio=motion_ratio
    )
    n = len(df)
    params = {
        "duration": duration,
        "max_gap": max_gap,
        "min_fraction": min_fraction,
        "min_samples": min_samples,
        "motion_length": motion_length,
        "motion_ratio": motion_ratio,
    }
    if n == 0:
        df["window"] = np.zeros(0, dtype=np.int64)
        return Windows(df, _table(df, np.zeros(0), duration), duration, {}, params)
    t = df["t"].to_numpy(float)
    run = df["run"].to_numpy()
    motion = df["motion"].to_numpy()
    dt_next = np.diff(t)
    gap = time_gaps(run, t, max_gap=max_gap).step
    brk = (run[1:] != run[:-1]) | (motion[1:] != motion[:-1]) | gap
    if "segment" in df.columns:
        seg = df["segment"].to_numpy()
        brk |= seg[1:] != seg[:-1]
    block = np.concatenate([[0], np.cumsum(brk)])
    # Interval of each sample: to the next sample of its block; the block's last sample
    # takes the previous step (0 for a one-sample block).
    dt = np.zeros(n)
    dt[:-1] = np.where(brk, 0.0, dt_next)
    last = np.concatenate([brk, [True]])
    prev_ok = np.concatenate([[False], ~brk])
    fill = last & prev_ok
    dt[fill] = np.concatenate([[0.0], dt_next])[fill]
    t0 = pd.Series(t).groupby(block).transform("first").to_numpy()
    k = np.floor((t - t0) / duration + 1e-9).astype(np.int64)
    # the (block, k) pairs numbered in order of first appearance, as factorizing their
    # MultiIndex would, from one int64 key per pair (no tuple per sample)
    kb = pd.factorize(k)[0]
    codes = pd.factorize(block * np.int64(kb.max() + 1) + kb)[0]
    dur = np.bincount(codes, weights=dt)
    cnt = np.bincount(codes)
    ok_win = (dur >= min_fraction * duration - 1e-9) & (cnt >= min_samples)
    keep = ok_win[codes]
    dropped: dict[str, int] = {}
    if (~keep).any():
        dropped[f"window shorter than {min_fraction * duration:g} s or {min_samples} samples"] = (
            int((~keep).sum())
        )
    new_id = np.cumsum(ok_win) - 1
    df["window"] = new_id[codes]
    df["_dt"] = dt
    kept_runs = set(run[keep])
    lost = []
    if len(kept_runs) < len(set(run)):
        # per candidate window: its run, length and sample count
        per = pd.DataFrame({"run": run, "code": codes}).drop_duplicates("code")
        per = per.assign(dur=dur[per["code"].to_numpy()], cnt=cnt[per["code"].to_numpy()])
        n_run = pd.Series(run).value_counts()
        for r, g in per.groupby("run", sort=True):
            if r in kept_runs:
                continue
            lost.append(
                {
                    "run": str(r),
                    "n_samples": int(n_run[r]),
                    "longest_window_s": float(g["dur"].max()),
                    "most_samples": int(g["cnt"].max()),
                    "reason": f"no window long enough: cut every {duration:g} s within "
                    f"stretches of one motion class without a gap, its windows reach at most "
                    f"{float(g['dur'].max()):.3g} s and {int(g['cnt'].max())} samples; a "
                    f"window needs {min_fraction * duration:g} s and {min_samples} "
                    "samples",
                }
            )
    df = df.loc[keep].reset_index(drop=True)
    table = _table(df, df.pop("_dt").to_numpy(), duration)
    from energy_planner.measurements.preprocess import warn_dropped_runs

    warn_dropped_runs(lost, "make_windows")
    return Windows(df, table, duration, dropped, params, lost)


def _table(df: pd.DataFrame, dt: np.ndarray, duration: float) -> pd.DataFrame:
    cols = [
        "run",
        "window",
        "t_start",
        "t_end",
        "duration",
        "n",
        "alpha",
        "gamma",
        "vx",
        "vy",
        "wz",
        "speed",
        "ax",
        "ay",
        "power",
        "energy_j",
        "motion",
    ]
    if len(df) == 0:
        return pd.DataFrame({c: [] for c in cols})
    g = df.assign(
        _dt=dt,
        _e=df["power"].to_numpy(float) * dt,
        _s=np.sin(df["gamma"].to_numpy(float)),
        _c=np.cos(df["gamma"].to_numpy(float)),
    ).groupby("window", sort=True)
    tab = pd.DataFrame(
        {
            "run": g["run"].first(),
            "window": g["window"].first(),
            "t_start": g["t"].first(),
            "duration": g["_dt"].sum(),
            "n": g["t"].size(),
        }
    )
    tab["t_end"] = tab["t_start"] + tab["duration"]
    for c in ("alpha", "vx", "vy", "wz", "speed", "ax", "ay", "power"):
        tab[c] = g[c].mean()
    tab["gamma"] = np.arctan2(g["_s"].mean(), g["_c"].mean())
    tab["energy_j"] = g["_e"].sum()
    tab["motion"] = g["motion"].first()
    from energy_planner.measurements.schema import CANONICAL_COLUMNS

    for c in df.columns:
        if c in CANONICAL_COLUMNS or c in DERIVED_COLUMNS or c.startswith("_"):
            continue
        if pd.api.types.is_numeric_dtype(df[c]) and not pd.api.types.is_bool_dtype(df[c]):
            tab[c] = g[c].mean()
        else:
            tab[c] = _modes(df["window"].to_numpy(), df[c], tab.index)
            if isinstance(df[c].dtype, pd.CategoricalDtype):
                tab[c] = pd.Categorical(tab[c], categories=df[c].cat.categories)
    extras = [c for c in tab.columns if c not in cols]
    return tab[cols + extras].reset_index(drop=True)


def run_energies(samples: pd.DataFrame, *, max_gap: float | None = None) -> pd.DataFrame:
    """Measured electrical energy of each run: trapezoidal integral of voltage * current.

    Parameters
    ----------
    samples : pandas.DataFrame
        Canonical samples (raw: ``voltage * current``; the ``power`` column is not used).
    max_gap : float, optional
        Time gaps are not integrated (a gap is never bridged); they are counted in
        ``n_gaps`` and their total length in ``gap_s``. A gap is a step longer than five
        of the run's sample periods (:func:`~energy_planner.measurements.schema.time_gaps`),
        or than ``max_gap`` s if given (``math.inf`` integrates every step).

    Returns
    -------
    pandas.DataFrame
        One row per run: ``run``, ``duration_s`` (integrated time, s), ``measured_j``
        (J), ``n_gaps``, ``gap_s``, ``t_start``, ``t_end``.

    Examples
    --------
    >>> df = pd.DataFrame({"run": "a", "t": [0.0, 0.5, 1.0, 4.0], "voltage": 50.0,
    ...                    "current": [2.0, 4.0, 4.0, 4.0]})
    >>> run_energies(df)[["run", "duration_s", "measured_j", "n_gaps", "gap_s"]].to_numpy().tolist()
    [['a', 1.0, 175.0, 1, 3.0]]
    """
    missing = [c for c in ("run", "t", "voltage", "current") if c not in samples.columns]
    if missing:
        raise LogError(
            f"run_energies needs column(s) {', '.join(missing)}; required: run, t, voltage, current"
        )
    check_runs(samples, "samples given to run_energies")
    df = samples.assign(run=samples["run"].astype(str)).sort_values(["run", "t"], kind="stable")
    gaps = np.r_[time_gaps(df["run"], df["t"], max_gap=max_gap).step, False][: len(df)]
    # the runs are contiguous, in sorted order: each one's slice of the columns (a pandas
    # group per run cost ~100x the arithmetic on a campaign of short runs)
    runs = df["run"].to_numpy(dtype=object)
    times = df["t"].to_numpy(float)
    power = df["voltage"].to_numpy(float) * df["current"].to_numpy(float)
    n = len(df)
    starts = np.flatnonzero(np.r_[True, runs[1:] != runs[:-1]]) if n else np.zeros(0, int)
    bounds = np.r_[starts, n]
    rows = []
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        run, t, p = runs[a], times[a:b], power[a:b]
        dt = np.diff(t)
        gap = gaps[a:b][:-1]
        use = ~gap
        e = float(np.sum(0.5 * (p[1:] + p[:-1])[use] * dt[use]))
        rows.append(
            {
                "run": run,
                "duration_s": float(dt[use].sum()),
                "measured_j": e,
                "n_gaps": int(gap.sum()),
                "gap_s": float(dt[gap].sum()),
                "t_start": float(t[0]),
                "t_end": float(t[-1]),
            }
        )
    cols = ["run", "duration_s", "measured_j", "n_gaps", "gap_s", "t_start", "t_end"]
    return pd.DataFrame(rows, columns=cols)
