"""The canonical robot log table and its validation.

One row per sample, SI units (see the project's design notes, "Canonical robot log"):

=========================  ===========================================================
column                     meaning
=========================  ===========================================================
``run``                    run identifier (string)
``t``                      time, s, strictly increasing within a run
``qw, qx, qy, qz``         IMU orientation, body to world (ENU), as ``sensor_msgs/Imu``
``vx, vy, wz``             body-frame twist (m/s, m/s, rad/s) from legged odometry
``voltage``                battery voltage, V
``current``                battery current, A, positive while the battery discharges
``x, y, yaw``              optional odometry pose (m, m, rad)
anything else              extra channels (numeric or categorical), carried through
=========================  ===========================================================

:func:`validate_log` raises :class:`~energy_planner.errors.LogError` on structural
faults (a missing column, time going backwards or repeated within a run) and *counts*
the faults that preprocessing later removes (NaN, absurd voltage, time gaps), so that
nothing is changed silently.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from energy_planner.errors import LogError

#: Columns every log must have (besides ``run``, which may come from the file name).
REQUIRED_COLUMNS: tuple[str, ...] = (
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
)
#: Optional odometry pose columns.
OPTIONAL_COLUMNS: tuple[str, ...] = ("x", "y", "yaw")
#: All canonical columns in their canonical order.
CANONICAL_COLUMNS: tuple[str, ...] = ("run", *REQUIRED_COLUMNS, *OPTIONAL_COLUMNS)

#: Default plausible battery voltage range, V (outside: the sample is dropped, counted).
VOLTAGE_RANGE: tuple[float, float] = (5.0, 1000.0)
#: A time step longer than this many of its run's sample periods (the median time step
#: of the run) is a gap: the run is split there (:func:`time_gaps`). Five periods leave
#: a logger's jitter and a few dropped samples alone (a 1 Hz log is never split at every
#: sample) and still split a 100 Hz log at a 0.3 s hole.
GAP_PERIODS: float = 5.0


@dataclass
class ValidationReport:
    """What :func:`validate_log` found in a canonical table (nothing is changed).

    Attributes
    ----------
    n_rows : int
        Number of rows checked.
    runs : list of str
        Run identifiers, sorted.
    n_nan : dict
        Number of non-finite values per required column (only columns with any).
    n_bad_voltage : int
        Number of finite voltages outside ``voltage_range`` (V).
    n_bad_quaternion : int
        Number of finite IMU quaternions whose norm is off 1 by more than 0.1 (e.g. all
        zeros from a driver without orientation).
    gaps : list of dict
        One entry per time gap (:func:`time_gaps`): ``run``, ``t_before``, ``t_after``,
        ``dt``. Preprocessing splits the run there into segments.
    voltage_range : tuple of float
        The voltage range used.
    max_gap : float or None
        The fixed gap threshold given, s, or None: each run's own (:data:`GAP_PERIODS`
        sample periods).
    gap_text : str
        One line: how many gaps split which run (:meth:`TimeGaps.describe`).
    """

    n_rows: int
    runs: list[str]
    n_nan: dict[str, int] = field(default_factory=dict)
    n_bad_voltage: int = 0
    n_bad_quaternion: int = 0
    gaps: list[dict[str, Any]] = field(default_factory=list)
    voltage_range: tuple[float, float] = VOLTAGE_RANGE
    max_gap: float | None = None
    gap_text: str = ""

    def to_dict(self) -> dict[str, Any]:
        """Plain-data form (for ``--json``)."""
        return {
            "n_rows": self.n_rows,
            "runs": list(self.runs),
            "n_nan": dict(self.n_nan),
            "n_bad_voltage": self.n_bad_voltage,
            "n_bad_quaternion": self.n_bad_quaternion,
            "n_gaps": len(self.gaps),
            "gaps": [dict(g) for g in self.gaps],
            "voltage_range": list(self.voltage_range),
            "max_gap": self.max_gap,
            "gap_text": self.gap_text,
        }


def float_values(col: pd.Series) -> np.ndarray:
    """``col`` as a float array, values that are not numbers NaN.

    ``pd.to_numeric(col, errors="coerce").to_numpy(float)``, without the conversion for a
    column that is float64 already (every column of a loaded log: called per file, per
    column, it was a tenth of loading one).
    """
    if col.dtype == np.float64:
        return col.to_numpy()
    return pd.to_numeric(col, errors="coerce").to_numpy(dtype=float)


def _unique_inverse(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(values, return_inverse=True)`` for a string array, by hashing.

    Sorts only the distinct values (a campaign's runs), not every sample as
    ``np.unique`` does: a quarter of its time on a campaign's samples.
    """
    first, uniq = pd.factorize(values)
    uniq = np.asarray(uniq, dtype=values.dtype)
    order = np.argsort(uniq)
    rank = np.empty(len(order), dtype=np.intp)
    rank[order] = np.arange(len(order))
    return uniq[order], rank[first]


def _run_codes(run: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``_unique_inverse(run.astype(str))`` of an object array of run ids.

    Run ids that are all text (as every log's are) are hashed as they are: the text of
    each sample (``astype(str)``, a fixed-width copy of every id) and its hashing were
    most of :func:`time_gaps`, which every cleaning and windowing step calls. Other ids
    (numbers, missing values, text ending in NUL, which ``astype(str)`` drops) are turned
    into text first, as before.
    """
    first, uniq = pd.factorize(run, use_na_sentinel=False)
    if all(type(u) is str and not u.endswith("\x00") for u in uniq):
        uniq = np.asarray(uniq, dtype=object)
        order = np.argsort(uniq, kind="stable")
        rank = np.empty(len(order), dtype=np.intp)
        rank[order] = np.arange(len(order))
        return uniq[order].astype(str), rank[first]
    return _unique_inverse(run.astype(str))


def _where(source: str | None) -> str:
    return f" in {source}" if source else ""


def check_columns(columns, source: str | None = None, *, need_run: bool = True) -> None:
    """Raise :class:`LogError` if a required column is missing.

    The message names the missing column(s), the file and lists the required ones.

    Examples
    --------
    >>> check_columns(["run", "t"], "a.csv")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    energy_planner.errors.LogError: log a.csv lacks required column(s) 'qw', 'qx', ...
    """
    need = (("run",) if need_run else ()) + REQUIRED_COLUMNS
    missing = [c for c in need if c not in set(columns)]
    if missing:
        names = ", ".join(repr(c) for c in missing)
        raise LogError(
            f"log{(' ' + source) if source else ''} lacks required column(s) {names}; "
            f"required columns are {', '.join(need)} (optional: {', '.join(OPTIONAL_COLUMNS)}); "
            f"found {', '.join(map(str, columns))}",
            path=source,
            column=missing[0],
            value=missing,
            expected=", ".join(need),
        )


def check_runs(samples: pd.DataFrame, source: str | None = None) -> None:
    """Raise :class:`LogError` if a ``run`` value is missing (empty cell, NaN, None).

    The message names the first rows (0-based, in the table's order) and the file.

    Examples
    --------
    >>> check_runs(pd.DataFrame({"run": ["a", None]}), "a.csv")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    energy_planner.errors.LogError: log a.csv: the run id is missing at row(s) 1; expected ...
    """
    missing = np.flatnonzero(pd.isna(samples["run"].to_numpy(dtype=object)))
    if missing.size:
        rows = [int(r) for r in missing[:10]]
        raise LogError(
            f"log{(' ' + source) if source else ''}: the run id is missing at row(s) "
            f"{', '.join(map(str, rows))}{' ...' if missing.size > 10 else ''}; expected a run "
            "id in every row (or no 'run' column: then the file name is the run id)",
            path=source,
            column="run",
            rows=rows,
            row=rows[0],
            expected="a run id in every row",
        )


def check_time(samples: pd.DataFrame, source: str | None = None) -> None:
    """Raise :class:`LogError` if ``t`` goes backwards or repeats within a run.

    The order checked is the row order of ``samples`` (before any sorting), so that a
    log written out of order is reported rather than silently re-ordered. The message
    gives the run, the row number (0-based, in the file) and the two times.
    """
    t = float_values(samples["t"])
    if np.isnan(t).any():
        row = int(np.flatnonzero(np.isnan(t))[0])
        raise LogError(
            f"log{_where(source)}: time 't' is missing or not a number at row {row} "
            f"(value {samples['t'].iloc[row]!r}); expected seconds, increasing within a run",
            path=source,
            column="t",
            row=row,
            value=samples["t"].iloc[row],
            expected="seconds, increasing within a run",
        )
    runs = samples["run"].astype(str).to_numpy()
    order, same = _by_run(runs)
    ts = t[order]
    bad = np.flatnonzero(same & (np.diff(ts) <= 0))
    if bad.size:
        # report the offending row that comes first in the file
        j = int(bad[np.argmin(order[bad + 1])])
        row = int(order[j + 1])
        what = "repeats" if ts[j + 1] == ts[j] else "goes backwards"
        raise LogError(
            f"log{_where(source)}: time {what} in run {runs[row]!r} at row {row}: "
            f"t={float(ts[j + 1])!r} s after t={float(ts[j])!r} s; expected t strictly "
            f"increasing within a run",
            path=source,
            column="t",
            row=row,
            run=str(runs[row]),
            value=float(ts[j + 1]),
            expected=f"t > {float(ts[j])!r} s",
        )


def _by_run(runs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Row order grouping runs, and which consecutive rows in that order share a run.

    File order is kept within a run.
    """
    codes = pd.factorize(runs)[0]
    order = np.argsort(codes, kind="stable")
    c = codes[order]
    return order, c[1:] == c[:-1]


@dataclass(frozen=True)
class TimeGaps:
    """The time gaps of a log: where its runs are split (see :func:`time_gaps`).

    Attributes
    ----------
    step : numpy.ndarray of bool
        One per step between consecutive rows (``n - 1``): True where the step stays
        within a run and is longer than the run's threshold.
    threshold : dict
        Per run (str), the longest step that is not a gap, s (``inf`` for a run of fewer
        than two samples).
    period : dict
        Per run (str), its sample period: the median of its positive time steps, s (NaN
        for a run of fewer than two samples).
    n_gaps : dict
        Number of gaps per run, for the runs that have any (sorted by run).
    max_gap : float or None
        The fixed threshold given, or None when each run's own sample period set it.
    """

    step: np.ndarray
    threshold: dict[str, float]
    period: dict[str, float]
    n_gaps: dict[str, int]
    max_gap: float | None = None

    def describe(self) -> str:
        """One line: how many gaps split which run, and the rule.

        Examples
        --------
        >>> g = time_gaps(["a"] * 4 + ["b"] * 3, [0, 1, 2, 60, 0, 0.1, 0.2])
        >>> g.describe()
        '1 time gap(s) (a step longer than 5 sample periods): run a split in 2 at 1 gap (> 5 s)'
        """
        rule = (
            f"a step longer than {self.max_gap:g} s"
            if self.max_gap is not None
            else f"a step longer than {GAP_PERIODS:g} sample periods"
        )
        gaps = self.n_gaps
        if not gaps:
            return f"no time gap ({rule})"
        shown = [
            f"run {r} split in {n + 1} at {n} gap{'s' if n > 1 else ''} "
            f"(> {self.threshold[r]:.3g} s)"
            for r, n in list(gaps.items())[:10]
        ]
        more = f"; and {len(gaps) - 10} more run(s)" if len(gaps) > 10 else ""
        return f"{sum(gaps.values())} time gap(s) ({rule}): {'; '.join(shown)}{more}"


def time_gaps(run, t, *, max_gap: float | None = None) -> TimeGaps:
    """Which time steps of a log are gaps: the one rule every step that splits runs uses.

    A step is a gap when it is longer than :data:`GAP_PERIODS` times its run's sample
    period (the median of the run's positive time steps), so the rule follows the log's
    own rate: a 1 Hz log is never split at every sample, a 100 Hz log is split at a
    0.3 s hole. A fixed ``max_gap`` (s) replaces the rule for every run.

    Parameters
    ----------
    run : array-like
        Run id of each row. The rows of a run must be consecutive and in time order
        (sorted by run and ``t``).
    t : array-like of float
        Time of each row, s.
    max_gap : float, optional
        A fixed longest step that is not a gap, s, instead of the runs' own rates.

    Returns
    -------
    TimeGaps

    Examples
    --------
    A 1 Hz run stays whole; a 100 Hz run with a 0.3 s hole is split there:

    >>> t = np.r_[np.arange(10.0), 0.01 * np.arange(50), 0.8 + 0.01 * np.arange(50)]
    >>> g = time_gaps(["slow"] * 10 + ["fast"] * 100, t)
    >>> g.n_gaps, g.threshold["slow"], round(g.threshold["fast"], 6)
    ({'fast': 1}, 5.0, 0.05)
    >>> int(np.flatnonzero(g.step)[0])
    59
    """
    run = np.asarray(run, dtype=object)
    t = np.asarray(t, dtype=float)
    if run.shape != t.shape:
        raise LogError(f"time_gaps: {run.size} run ids for {t.size} times; expected one each")
    dt = np.diff(t)
    uniq, code = _run_codes(run)
    same = code[1:] == code[:-1]
    names = [str(r) for r in uniq]
    step_run = code[1:].astype(np.int64)
    ok = same & (dt > 0)
    period = pd.Series(dt[ok]).groupby(step_run[ok]).median()
    periods = np.full(len(names), np.nan)
    periods[period.index.to_numpy(dtype=np.int64)] = period.to_numpy(float)
    if max_gap is not None:
        if not max_gap > 0:
            raise LogError(f"max_gap={max_gap!r} s; expected a time step > 0 s", value=max_gap)
        per_run = np.full(len(names), float(max_gap))
    else:  # a run without two distinct times has no step to split
        per_run = np.where(np.isfinite(periods), GAP_PERIODS * periods, np.inf)
    step = same & (dt > per_run[step_run])
    counts = np.bincount(step_run[step], minlength=len(names))
    return TimeGaps(
        step=step,
        threshold={r: float(v) for r, v in zip(names, per_run, strict=True)},
        period={r: float(v) for r, v in zip(names, periods, strict=True)},
        n_gaps={r: int(n) for r, n in zip(names, counts, strict=True) if n},
        max_gap=None if max_gap is None else float(max_gap),
    )


def validate_log(
    samples: pd.DataFrame,
    source: str | None = None,
    *,
    voltage_range: tuple[float, float] = VOLTAGE_RANGE,
    max_gap: float | None = None,
) -> ValidationReport:
    """Check a canonical log table; raise on structural faults, count the rest.

    Parameters
    ----------
    samples : pandas.DataFrame
        Canonical table (with a ``run`` column), in file order.
    source : str, optional
        File name used in messages.
    voltage_range : (float, float)
        Plausible battery voltage, V. Samples outside it are counted here and dropped
        (counted) by :func:`~energy_planner.measurements.preprocess`; they are not an error.
    max_gap : float, optional
        Longest time step, s, that is not a gap; default: :data:`GAP_PERIODS` times each
        run's sample period (:func:`time_gaps`). Gaps are listed here; preprocessing
        splits the run into segments at each gap (windows never cross one).

    Returns
    -------
    ValidationReport

    Raises
    ------
    LogError
        A required column is missing, ``t`` is not numeric, or ``t`` goes backwards or
        repeats within a run.

    Examples
    --------
    >>> import pandas as pd
    >>> df = pd.DataFrame({"run": "a", "t": [0.0, 0.1, 0.2, 0.3, 2.0], "qw": 1.0,
    ...     "qx": 0.0, "qy": 0.0, "qz": 0.0, "vx": 0.3, "vy": 0.0, "wz": 0.0,
    ...     "voltage": [50.0, 0.0, 50.0, 50.0, 50.0], "current": 4.0})
    >>> r = validate_log(df)
    >>> r.n_bad_voltage, len(r.gaps), r.gaps[0]["dt"]
    (1, 1, 1.7)
    """
    check_columns(samples.columns, source)
    check_runs(samples, source)
    check_time(samples, source)
    n_nan: dict[str, int] = {}
    for c in REQUIRED_COLUMNS:
        vals = pd.to_numeric(samples[c], errors="coerce").to_numpy(dtype=float)
        k = int((~np.isfinite(vals)).sum())
        if k:
            n_nan[c] = k
    v = pd.to_numeric(samples["voltage"], errors="coerce").to_numpy(dtype=float)
    lo, hi = voltage_range
    with np.errstate(invalid="ignore"):
        n_bad_v = int((np.isfinite(v) & ((v < lo) | (v > hi))).sum())
    q = np.column_stack(
        [
            pd.to_numeric(samples[c], errors="coerce").to_numpy(dtype=float)
            for c in ("qw", "qx", "qy", "qz")
        ]
    )
    with np.errstate(invalid="ignore"):
        n_bad_q = int((np.abs(np.linalg.norm(q, axis=1) - 1.0) > 0.1).sum())
    gaps = []
    runs = samples["run"].astype(str).to_numpy()
    t = samples["t"].to_numpy(dtype=float)
    order, _ = _by_run(runs)
    ts, rs = t[order], runs[order]
    dt = np.diff(ts)
    found = time_gaps(rs, ts, max_gap=max_gap)
    for i in np.flatnonzero(found.step):
        gaps.append(
            {
                "run": str(rs[i]),
                "t_before": float(ts[i]),
                "t_after": float(ts[i + 1]),
                "dt": round(float(dt[i]), 12),
            }
        )
    gaps.sort(key=lambda g: (g["run"], g["t_before"]))
    return ValidationReport(
        n_rows=len(samples),
        runs=sorted(map(str, pd.unique(runs))),
        n_nan=n_nan,
        n_bad_voltage=n_bad_v,
        n_bad_quaternion=n_bad_q,
        gaps=gaps,
        voltage_range=(float(lo), float(hi)),
        max_gap=found.max_gap,
        gap_text=found.describe(),
    )
