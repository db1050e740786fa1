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
#: Default longest time step, s, that is not a gap.
MAX_GAP_S: float = 0.5


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
        One entry per time step longer than ``max_gap`` (s): ``run``, ``t_before``,
        ``t_after``, ``dt``. Preprocessing splits the run there into segments.
    voltage_range, max_gap : tuple of float, float
        The thresholds used.
    """

    n_rows: int
    runs: list[str]
    n_nan: dict[str, int] = field(default_factory=dict)
    n_bad_voltage: int = 0
    n_bad_quaternion: int = 0
    gaps: list[dict[str, Any]] = field(default_factory=list)
    voltage_range: tuple[float, float] = VOLTAGE_RANGE
    max_gap: float = MAX_GAP_S

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
        }


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
    t = pd.to_numeric(samples["t"], errors="coerce").to_numpy(dtype=float)
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


def validate_log(
    samples: pd.DataFrame,
    source: str | None = None,
    *,
    voltage_range: tuple[float, float] = VOLTAGE_RANGE,
    max_gap: float = MAX_GAP_S,
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
    max_gap : float
        Longest time step, s, that is not a gap. Gaps are listed here; preprocessing
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
    >>> df = pd.DataFrame({"run": "a", "t": [0.0, 0.1, 2.0], "qw": 1.0, "qx": 0.0,
    ...     "qy": 0.0, "qz": 0.0, "vx": 0.3, "vy": 0.0, "wz": 0.0,
    ...     "voltage": [50.0, 0.0, 50.0], "current": 4.0})
    >>> r = validate_log(df)
    >>> r.n_bad_voltage, len(r.gaps), r.gaps[0]["dt"]
    (1, 1, 1.9)
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
    order, same = _by_run(runs)
    ts, rs = t[order], runs[order]
    dt = np.diff(ts)
    for i in np.flatnonzero(same & (dt > max_gap)):
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
        max_gap=float(max_gap),
    )
